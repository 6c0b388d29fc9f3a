"""Command line: python -m fosls_ref evaluate SOLUTION.vtu SCENE.toml [options]"""
import argparse
import json
import math
import sys

from . import __version__, evaluate_files
from .errors import InputError


def _clean(o):
    if isinstance(o, float) and not math.isfinite(o):
        return None
    if isinstance(o, dict):
        return {k: _clean(v) for k, v in o.items()}
    if isinstance(o, (list, tuple)):
        return [_clean(v) for v in o]
    if hasattr(o, "tolist"):
        return _clean(o.tolist())
    return o


def main(argv=None):
    p = argparse.ArgumentParser(prog="python -m fosls_ref",
                                description="Independent reference evaluation of the FOSLS functional.")
    p.add_argument("--version", action="version", version=f"fosls_ref {__version__}")
    sub = p.add_subparsers(dest="cmd", required=True)
    e = sub.add_parser("evaluate", help="evaluate F, admissibility and contact measures")
    e.add_argument("solution")
    e.add_argument("scene")
    e.add_argument("--norm", choices=["energy", "robust", "seed"])
    e.add_argument("--json", metavar="OUT", help="write JSON to OUT ('-' for stdout)")
    e.add_argument("--stress-layout", help="override, e.g. 'xx,yy,zz,xy'")
    e.add_argument("--cell-order", type=int, default=19, help="triangle rule order (default 19)")
    e.add_argument("--edge-points", type=int, default=20, help="Gauss points per edge piece (default 20)")
    e.add_argument("--contact-tol", type=float, default=1e-10,
                   help="relative tolerance for active/stick classification (default 1e-10)")
    e.add_argument("--cells", action="store_true", help="include per-cell arrays in the JSON")
    e.add_argument("--allow-unknown", action="store_true", help="unknown scene keys: note, not error")
    e.add_argument("--quiet", action="store_true")
    a = p.parse_args(argv)
    try:
        out = evaluate_files(a.solution, a.scene, norm=a.norm, layout=a.stress_layout,
                             allow_unknown=a.allow_unknown, cell_order=a.cell_order,
                             edge_points=a.edge_points, contact_tol=a.contact_tol,
                             with_cells=a.cells)
    except InputError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    out = _clean(out)
    if a.json:
        text = json.dumps(out, indent=2)
        if a.json == "-":
            print(text)
        else:
            with open(a.json, "w") as fh:
                fh.write(text + "\n")
    if not a.quiet and a.json != "-":
        f = out["functional"]
        print(f"norm {out['norm']} ({out['norm_source']}), {out['input']['cells']} P{out['input']['degree']} cells")
        for k in ("total", "constitutive", "equilibrium", "complementarity", "friction"):
            print(f"  F_{k:16s} {f[k]: .16e}")
        print(f"  eta              {out['eta']}")
        print(f"  energy           {out['energy']: .16e}")
        print(f"  relative         {out['relative']}")
        for k, v in out["admissibility"].items():
            print(f"  {k:18s} {v: .6e}")
        c = out["contact"]
        print(f"  normal_force {c['normal_force']:.10e} active {c['active_length']:.10e} "
              f"stick {c['stick_length']:.10e} slip {c['slip_length']:.10e}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
