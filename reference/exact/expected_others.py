#!/usr/bin/env python3
"""fosls_ref's output for every *other* fixture case: fixtures/<case>/expected_fosls.json.

"Other" = every folder fixtures/<case>/ holding solution.vtu and scene.toml whose name does not
start with exact_, perturbed_ or scaled_ (those are written by make.py next to this file).  The
JSON is fosls_ref's (python -m fosls_ref evaluate solution.vtu scene.toml --json), default options
(cell order 19, 20 edge points, contact tol 1e-10), with `elapsed_seconds` removed and the input
paths made relative, plus `generated_by`.  When fosls_ref refuses the input (exit status 2), the
file holds {"error": "<fosls_ref's message>", "exit_status": 2, ...} instead.

    reference/.venv/bin/python reference/exact/expected_others.py            # (re)write all
    reference/.venv/bin/python reference/exact/expected_others.py --only hertz_skfem_p2
    reference/.venv/bin/python reference/exact/expected_others.py --check    # recompute, compare (rel 1e-10)

--check fails on a number differing by more than rel. 1e-10 (round-off floors as in compare.py),
on a case without expected_fosls.json, and on an expected_fosls.json whose case lost its files.
"""
import argparse
import json
import os
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
REF = os.path.dirname(HERE)
ROOT = os.path.dirname(REF)
sys.path.insert(0, HERE)
sys.path.insert(0, REF)

from fosls_ref import InputError, evaluate_files  # noqa: E402
from fosls_ref.cli import _clean  # noqa: E402

from compare import compare  # noqa: E402

FIXTURES = os.path.join(ROOT, "fixtures")
MINE = ("exact_", "perturbed_", "scaled_")
# reference/reconstruct writes its own expected values (the minimiser), not the file-field terms.
OTHERS_SKIP = ("reconstruct_",)
OUTNAME = "expected_fosls.json"
GEN = "reference/.venv/bin/python reference/exact/expected_others.py"


def other_cases(fixtures):
    out = []
    for name in sorted(os.listdir(fixtures)):
        d = os.path.join(fixtures, name)
        if not os.path.isdir(d) or name.startswith(MINE) or name.startswith(OTHERS_SKIP):
            continue
        if os.path.isfile(os.path.join(d, "solution.vtu")) and os.path.isfile(os.path.join(d, "scene.toml")):
            out.append(name)
    return out


def evaluate(d):
    t0 = time.perf_counter()
    try:
        out = evaluate_files(os.path.join(d, "solution.vtu"), os.path.join(d, "scene.toml"))
    except InputError as exc:
        msg = str(exc).replace(os.path.abspath(d) + os.sep, "").replace(d + os.sep, "")
        return {"error": msg, "exit_status": 2, "tool": "fosls_ref",
                "generated_by": f"{GEN} --only {os.path.basename(d)}"}, time.perf_counter() - t0
    dt = time.perf_counter() - t0
    out = _clean(out)
    out.pop("elapsed_seconds", None)
    out["input"]["solution"] = "solution.vtu"
    out["input"]["scene"] = "scene.toml"
    out["generated_by"] = f"{GEN} --only {os.path.basename(d)}"
    return out, dt


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--check", action="store_true")
    ap.add_argument("--only", nargs="*")
    ap.add_argument("--fixtures", default=FIXTURES)
    a = ap.parse_args(argv)
    names = other_cases(a.fixtures)
    if a.only:
        missing = set(a.only) - set(names)
        if missing:
            print(f"not a fixture case with solution.vtu + scene.toml: {sorted(missing)}", file=sys.stderr)
            return 2
        names = [n for n in names if n in a.only]
    status = 0
    for name in names:
        d = os.path.join(a.fixtures, name)
        doc, dt = evaluate(d)
        if "error" in doc:
            summary = f"fosls_ref refused: {doc['error']}"
        else:
            fu = doc["functional"]
            rel = doc.get("relative")
            summary = (f"F={fu['total']:.6e} const={fu['constitutive']:.3e} equi={fu['equilibrium']:.3e} "
                       f"comp={fu['complementarity']:.3e} fric={fu['friction']:.3e} relative={rel}")
        path = os.path.join(d, OUTNAME)
        if a.check:
            if not os.path.isfile(path):
                print(f"MISSING {name}/{OUTNAME}")
                status = 1
                continue
            with open(path) as fh:
                ref = json.load(fh)
            msgs = compare(ref, doc)
            if msgs:
                status = 1
                print(f"MISMATCH {name}:")
                for m in msgs[:20]:
                    print(f"    {m}")
            else:
                print(f"ok  {name:36s} {summary} ({dt:.2f}s)")
        else:
            with open(path, "w") as fh:
                json.dump(doc, fh, indent=2)
                fh.write("\n")
            print(f"{name:36s} {summary} ({dt:.2f}s)")
    if a.check and not a.only:
        for name in sorted(os.listdir(a.fixtures)):
            p = os.path.join(a.fixtures, name, OUTNAME)
            if os.path.isfile(p) and name not in names:
                print(f"STALE {name}/{OUTNAME} (case has no solution.vtu + scene.toml any more)")
                status = 1
        print("expected_others.py --check: " + ("OK" if status == 0 else "FAILED"))
    return status


if __name__ == "__main__":
    sys.exit(main())
