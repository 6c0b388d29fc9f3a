#!/usr/bin/env python3
"""Exact and known-perturbation fixtures: fixtures/{exact,perturbed,scaled}_*/.

    reference/.venv/bin/python reference/exact/make.py                 # (re)write all cases
    reference/.venv/bin/python reference/exact/make.py --only NAME ...  # some cases
    reference/.venv/bin/python reference/exact/make.py --check         # regenerate in a temp dir, compare
    reference/.venv/bin/python reference/exact/make.py --list

Each case folder gets solution.vtu (meshio, binary + zlib), scene.toml, expected.json
(fosls_ref's JSON output for the case, without `elapsed_seconds`, with input paths made relative,
plus `case` (construction, exact formulas, scales, round-off keys) and `hand` (exact rational
evaluation of F for the polynomial fields, hand.py) / `hand_closed` (closed forms)) and README.md.
--check compares every number of expected.json with rel. tol 1e-10 (round-off floors, compare.py),
scene.toml byte for byte and the VTU arrays exactly; exit status 1 on any mismatch.
"""
import argparse
import json
import math
import os
import shutil
import sys
import tempfile
import time

import meshio
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
REF = os.path.dirname(HERE)
ROOT = os.path.dirname(REF)
sys.path.insert(0, HERE)
sys.path.insert(0, REF)

from fosls_ref import evaluate_files  # noqa: E402
from fosls_ref.cli import _clean  # noqa: E402

from cases import REGEN, build_cases  # noqa: E402
from compare import compare, noise_paths  # noqa: E402

FIXTURES = os.path.join(ROOT, "fixtures")


def layout_columns(S, ncomp, nu):
    xx, yy, xy, yx = S[:, 0, 0], S[:, 1, 1], S[:, 0, 1], S[:, 1, 0]
    zz = nu * (xx + yy)
    z = np.zeros_like(xx)
    if ncomp == 3:
        cols = [xx, yy, xy]
    elif ncomp == 4:
        cols = [xx, yy, zz, xy]
    elif ncomp == 6:
        cols = [xx, yy, zz, xy, z, z]
    elif ncomp == 9:
        cols = [xx, xy, z, yx, yy, z, z, z, zz]
    else:
        raise ValueError(ncomp)
    return np.stack(cols, axis=1)


def nodal_fields(case):
    pts, cells, lines, tags = case.mesh
    x, y = pts[:, 0], pts[:, 1]
    disp = np.stack([case.u[0](x, y), case.u[1](x, y)], axis=1)
    sxx, syy, sxy = (s(x, y) for s in case.sigma)
    S = np.zeros((len(pts), 2, 2))
    S[:, 0, 0], S[:, 1, 1], S[:, 0, 1], S[:, 1, 0] = sxx, syy, sxy, sxy
    if case.nodal_fix is not None:
        case.nodal_fix(pts, disp, S)
    return disp, S


def write_vtu(case, path):
    pts, cells, lines, tags = case.mesh
    disp, S = nodal_fields(case)
    if case.disp_comps == 3:
        disp = np.hstack([disp, np.zeros((len(pts), 1))])
    cols = layout_columns(S, case.ncomp, case.nu)
    p3 = np.hstack([pts, np.zeros((len(pts), 1))])
    ctype, ltype = ("triangle6", "line3") if case.degree == 2 else ("triangle", "line")
    m = meshio.Mesh(p3, [(ctype, cells), (ltype, lines)],
                    point_data={case.disp_name: disp, case.stress_name: cols},
                    cell_data={"boundary_tag": [np.zeros(len(cells), dtype=np.int32), tags.astype(np.int32)]})
    meshio.write(path, m, file_format="vtu", binary=True, compression="zlib")


def readme_text(case):
    cmd = f"{REGEN} --only {case.name}"
    txt = (f"# {case.name}\n\n{case.summary[0].upper() + case.summary[1:]}. {case.formulas} "
           f"Files: `solution.vtu` (meshio binary+zlib VTU), `scene.toml`, `expected.json` "
           f"(fosls_ref output, `case` block with the construction")
    if case.hand is not None:
        txt += ", `hand`: exact rational integration of F for the polynomial fields"
    if case.hand_closed is not None:
        txt += ", `hand_closed`: the closed form above evaluated"
    txt += f"). Regenerate with `{cmd}` (from the repository root).\n"
    return txt


def evaluate_case(dirname):
    t0 = time.perf_counter()
    out = evaluate_files(os.path.join(dirname, "solution.vtu"), os.path.join(dirname, "scene.toml"))
    dt = time.perf_counter() - t0
    out = _clean(out)
    out.pop("elapsed_seconds", None)
    out["input"]["solution"] = "solution.vtu"
    out["input"]["scene"] = "scene.toml"
    return out, dt


def write_case(case, outdir):
    d = os.path.join(outdir, case.name)
    os.makedirs(d, exist_ok=True)
    write_vtu(case, os.path.join(d, "solution.vtu"))
    with open(os.path.join(d, "scene.toml"), "w") as fh:
        fh.write(case.scene_text.rstrip("\n") + "\n")
    out, dt = evaluate_case(d)
    info = dict(case.info)
    info["scales"] = case.scales
    info["kind"] = "exact" if case.exact else ("scaled" if case.name.startswith("scaled") else "perturbed")
    info["generator"] = f"{REGEN} --only {case.name}"
    info["fosls_ref_options"] = {"cell_order": 19, "edge_points": 20, "contact_tol": 1e-10}
    doc = dict(out)
    doc["case"] = info
    if case.hand is not None:
        doc["hand"] = case.hand
    if case.hand_closed is not None:
        doc["hand_closed"] = case.hand_closed
    info["roundoff_keys"] = noise_paths(doc)
    info["roundoff_note"] = ("the listed values are round-off by construction (compare them with an "
                             "absolute tolerance, e.g. |F term| <= 1e-20 * energy, not relatively)")
    if case.checks is not None:
        info["assert"] = case.checks
    elif case.exact:
        info["assert"] = {"F_over_energy_max": 1e-24,
                          "note": "F and every term are round-off: |F| / energy <= 1e-24"}
    else:
        info["assert"] = {"F_rtol": 1e-10, "hand_rtol": 1e-10,
                          "note": "F terms that are not round-off agree with fosls_ref and with `hand` "
                                  "to rel. 1e-10 (observed: 1e-13 or better)"}
    with open(os.path.join(d, "expected.json"), "w") as fh:
        json.dump(doc, fh, indent=2)
        fh.write("\n")
    with open(os.path.join(d, "README.md"), "w") as fh:
        fh.write(readme_text(case))
    return doc, dt


def vtu_equal(a, b):
    ma, mb = meshio.read(a), meshio.read(b)
    if not np.array_equal(ma.points, mb.points):
        return "points differ"
    if len(ma.cells) != len(mb.cells) or any(
            ca.type != cb.type or not np.array_equal(ca.data, cb.data) for ca, cb in zip(ma.cells, mb.cells)):
        return "cells differ"
    for k in set(ma.point_data) | set(mb.point_data):
        if k not in ma.point_data or k not in mb.point_data or not np.array_equal(ma.point_data[k], mb.point_data[k]):
            return f"point data {k} differs"
    return None


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--check", action="store_true")
    ap.add_argument("--only", nargs="*")
    ap.add_argument("--list", action="store_true")
    ap.add_argument("--out", default=FIXTURES)
    a = ap.parse_args(argv)
    cases = build_cases()
    if a.list:
        for c in cases:
            print(c.name)
        return 0
    if a.only:
        unknown = set(a.only) - {c.name for c in cases}
        if unknown:
            print(f"unknown case(s): {sorted(unknown)}", file=sys.stderr)
            return 2
        cases = [c for c in cases if c.name in a.only]
    status = 0
    tmp = tempfile.mkdtemp(prefix="fosls_exact_") if a.check else None
    try:
        outdir = tmp if a.check else a.out
        for c in cases:
            doc, dt = write_case(c, outdir)
            fu = doc["functional"]
            line = (f"{c.name:34s} F={fu['total']: .6e} const={fu['constitutive']: .3e} "
                    f"equi={fu['equilibrium']: .3e} comp={fu['complementarity']: .3e} "
                    f"fric={fu['friction']: .3e} F/energy={fu['total'] / doc['energy']: .3e} ({dt:.2f}s)")
            if a.check:
                ref_dir = os.path.join(a.out, c.name)
                msgs = []
                try:
                    with open(os.path.join(ref_dir, "expected.json")) as fh:
                        ref = json.load(fh)
                    msgs += compare(ref, doc)
                    with open(os.path.join(ref_dir, "scene.toml")) as fh:
                        if fh.read() != c.scene_text.rstrip("\n") + "\n":
                            msgs.append("scene.toml differs")
                    v = vtu_equal(os.path.join(ref_dir, "solution.vtu"), os.path.join(outdir, c.name, "solution.vtu"))
                    if v:
                        msgs.append(f"solution.vtu: {v}")
                except FileNotFoundError as exc:
                    msgs.append(f"missing: {exc.filename}")
                if msgs:
                    status = 1
                    print(f"MISMATCH {c.name}:")
                    for m in msgs[:20]:
                        print(f"    {m}")
                else:
                    print(f"ok  {line}")
            else:
                print(line)
    finally:
        if tmp:
            shutil.rmtree(tmp, ignore_errors=True)
    if a.check:
        print("exact/make.py --check: " + ("OK" if status == 0 else "FAILED"))
    return status


if __name__ == "__main__":
    sys.exit(main())
