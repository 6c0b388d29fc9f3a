#!/usr/bin/env python3
"""Read-back check for VTU files written by another program (our Rust writer).

    reference/.venv/bin/python reference/encodings/check_writer.py OUT.vtu [OUT2.vtu ...] \
        --like fixtures/encodings/p2_meshio_binary.vtu

Every FILE is read with BOTH meshio (meshio.vtu.read) and VTK
(vtkXMLUnstructuredGridReader) and compared with the canonical file read by
the same reader:
  - points: Float64 must be bit-identical; Float32 must be the correctly
    rounded canonical values (or within --rtol if given);
  - cell types, offsets and connectivity: identical, in the same order;
  - every point/cell array of the canonical: present, same number of
    components, integer arrays identical, float arrays as the points;
  - component names: when both files carry them, they must agree.
Arrays the canonical does not have (e.g. `eta`) are listed, and fail only
with --strict.  A file with several <Piece>s is mapped onto the canonical's
points by exact coordinates first (VTK concatenates pieces).

One line per file, `OK` or `FAIL` with the reasons; exit status 0 if every
file passes, 1 otherwise, 2 on usage errors.
"""

from __future__ import annotations

import argparse
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import vtufix as V  # noqa: E402

READERS = {"vtk": V.read_vtk, "meshio": V.read_meshio}


def check_one(path, canon, readers, rtol, strict):
    problems = []
    info = []
    for rname in readers:
        try:
            g = READERS[rname](path)
        except Exception as e:  # noqa: BLE001
            problems.append(f"[{rname}] cannot read: {type(e).__name__}: {str(e)[:160]}")
            continue
        ref = canon[rname]
        if isinstance(ref, Exception):
            problems.append(f"[{rname}] cannot read the canonical file: {ref}")
            continue
        pieces = g.get("pieces") or []
        if len(pieces) > 1 and len(g["points"]) != len(ref["points"]):
            try:
                g = V.unpiece(g, ref)
                if rname == "vtk":
                    info.append(f"{len(pieces)} pieces mapped by coordinates")
            except ValueError as e:
                problems.append(f"[{rname}] {len(pieces)} pieces, cannot map onto the canonical points: {e}")
                continue
        for p in V.compare_grids(g, ref, rtol=rtol, float32_exact=True, allow_extra=not strict):
            problems.append(f"[{rname}] {p}")
        for name, cn in g["component_names"].items():
            rn = ref["component_names"].get(name)
            if cn and rn and list(cn) != list(rn):
                problems.append(f"[{rname}] '{name}': component names {cn} != canonical {rn}")
        if rname == "vtk":
            extra = sorted((set(g["point_data"]) - set(ref["point_data"])) | (set(g["cell_data"]) - set(ref["cell_data"])))
            info.append(f"{len(g['points'])} points, {len(g['types'])} cells")
            dtypes = sorted({V._vtu_type(a.dtype) for d in (g["point_data"], g["cell_data"]) for a in d.values()}
                            | {V._vtu_type(g["points"].dtype)})
            info.append("types " + "/".join(dtypes))
            if extra:
                info.append("extra arrays: " + ", ".join(extra))
    return problems, info


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("files", nargs="+", metavar="FILE.vtu")
    ap.add_argument("--like", required=True, metavar="CANONICAL.vtu", help="the file every FILE must equal")
    ap.add_argument("--rtol", type=float, default=0.0,
                    help="relative tolerance for float data, w.r.t. max |canonical array| (default 0: exact)")
    ap.add_argument("--strict", action="store_true", help="also fail on arrays the canonical does not have")
    ap.add_argument("--readers", default="vtk,meshio", help="comma-separated subset of vtk,meshio (default both)")
    args = ap.parse_args(argv)
    readers = [r.strip() for r in args.readers.split(",") if r.strip()]
    bad = [r for r in readers if r not in READERS]
    if bad or not readers:
        ap.error(f"unknown reader(s) {bad}; choose from {sorted(READERS)}")
    if not os.path.isfile(args.like):
        ap.error(f"--like {args.like}: no such file")
    canon = {}
    for r in readers:
        try:
            canon[r] = READERS[r](args.like)
        except Exception as e:  # noqa: BLE001
            canon[r] = e
    nfail = 0
    for path in args.files:
        if not os.path.isfile(path):
            print(f"FAIL {path}: no such file")
            nfail += 1
            continue
        problems, info = check_one(path, canon, readers, args.rtol, args.strict)
        if problems:
            nfail += 1
            print(f"FAIL {path}: " + "; ".join(problems))
        else:
            print(f"OK   {path} ({', '.join(readers)}: equal to {os.path.basename(args.like)}; " + "; ".join(info) + ")")
    if len(args.files) > 1:
        print(f"{len(args.files) - nfail}/{len(args.files)} files OK")
    return 1 if nfail else 0


if __name__ == "__main__":
    sys.exit(main())
