#!/usr/bin/env python3
"""Hertz comparison table (larger meshes than the committed fixtures; nothing is written to fixtures/).

    reference/.venv/bin/python reference/hertz/table.py            # prints the tables, updates README.md
    reference/.venv/bin/python reference/hertz/table.py --no-readme

Every solution is written to a temporary VTU exactly like a fixture and evaluated from the file
(evaluate.py), so the table uses the same definitions as expected.json.  Run time about 2-4 minutes.
"""
import argparse
import re
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import numpy as np  # noqa: E402

import geometry as G  # noqa: E402
import problems as PR  # noqa: E402
import runner  # noqa: E402

MESHES = {
    1: [dict(hc=0.002, hmax=0.05, grading=0.15), dict(hc=0.001, hmax=0.025, grading=0.15),
        dict(hc=0.0005, hmax=0.0125, grading=0.15)],
    2: [dict(hc=0.004, hmax=0.1, grading=0.3), dict(hc=0.002, hmax=0.05, grading=0.2),
        dict(hc=0.001, hmax=0.025, grading=0.15)],
}
RUNS = [("skfem", 1, 0.28, False), ("ngsolve", 1, 0.28, False), ("skfem", 2, 0.28, False), ("ngsolve", 2, 0.28, False),
        ("skfem", 2, 0.5, True), ("ngsolve", 2, 0.5, True)]


def evaluate_solution(tmp, name, sol, nu, friction=0.0):
    scene = {"material": {"youngs_modulus": PR.E, "poisson_ratio": nu, "model": "plane_strain"},
             "fields": {"displacement": "u", "stress": "stress"},
             "boundaries": {"tag_array": "boundary_tag"},
             "boundary": [{"name": "top", "tag": 2, "kind": "dirichlet", "displacement": [0.0, -0.01]},
                          {"name": "contact", "tag": 1, "kind": "contact", "obstacle": PR.PLANE, "normal": "obstacle",
                           **({"friction": friction} if friction else {})}]}
    cfg = dict(displacement="u", stress="stress", layout="xx,yy,zz,xy", encoding="zlib", tags=True,
               delta=1e-10, command="table.py")
    return runner.write_fixture(tmp, name, sol["nodes"], sol["cells"], sol["lines"], sol["tags"], sol["U"], sol["S4"],
                                scene, cfg, sol["info"], None, readme="")


def solve(lib, deg, nu, mixed, mesh, friction=0.0):
    tm = G.half_disc(**mesh)
    if lib == "skfem":
        return tm, PR.solve_skfem(tm, deg, nu, friction=friction, mixed=mixed, curved_tags=(1, 3))
    return tm, PR.solve_ngsolve(tm, deg, nu, friction=friction, mixed=mixed)


def pct(a, b):
    return f"{100 * (a / b - 1):+.2f}"


def hertz_table(tmp):
    rows = []
    head = ("| library | element | ν | mesh (hc / hmax / grading) | cells | dofs | P | a Hertz | a moment (%) "
            "| a half-width (%) | p0 Hertz | p max (%) | penetration | time s |")
    sep = "|" + "---|" * 14
    lines = [head, sep]
    for lib, deg, nu, mixed in RUNS:
        for k, mesh in enumerate(MESHES[deg]):
            t0 = time.time()
            tm, sol = solve(lib, deg, nu, mixed, mesh)
            exp = evaluate_solution(tmp, f"t_{lib}_{deg}_{nu}_{k}", sol, nu)
            dt = time.time() - t0
            P = sol["info"]["reaction_top"]["P"]
            h = PR.hertz_ab(P, PR.E, nu)
            c = exp["boundaries"]["contact"]
            el = ("TH P2/P1" if mixed else f"P{deg}")
            lines.append(f"| {lib} | {el} | {nu} | {mesh['hc']} / {mesh['hmax']} / {mesh['grading']} | {len(tm.t)} | "
                         f"{sol['info']['dofs']} | {P:.4f} | {h['a']:.5f} | {c['a_moment']:.5f} ({pct(c['a_moment'], h['a'])}) | "
                         f"{c['active_half_width']:.5f} ({pct(c['active_half_width'], h['a'])}) | {h['p0']:.2f} | "
                         f"{c['pressure_max_nodes']:.2f} ({pct(c['pressure_max_nodes'], h['p0'])}) | "
                         f"{c['penetration_max']:.2e} | {dt:.1f} |")
            print(lines[-1], flush=True)
            rows.append(dict(lib=lib, deg=deg, nu=nu, mesh=mesh, P=P, hertz=h, contact=c))
    return "\n".join(lines), rows


def friction_table(tmp):
    head = ("| element | mesh (hc / hmax / grading) | skfem PDAS stick x-range | NGSolve reg. stick x-range | "
            "Δ left / right (cells) | skfem active half-width | NGSolve penetration half-width | P skfem / NGSolve |")
    lines = [head, "|" + "---|" * 8]
    worst = 0.0
    for deg in (1, 2):
        for k, mesh in enumerate(MESHES[deg]):
            res = {}
            for lib in ("skfem", "ngsolve"):
                tm, sol = solve(lib, deg, 0.28, False, mesh, friction=0.4)
                res[lib] = (evaluate_solution(tmp, f"f_{lib}_{deg}_{k}", sol, 0.28, friction=0.4), sol)
            a, b = res["skfem"][0]["boundaries"]["contact"], res["ngsolve"][0]["boundaries"]["contact"]
            # local cell size at the stick ends: contact edge length there
            sa, sb = a["stick_x_range"], b["stick_x_range"]
            hloc = []
            for xe in (sa[0], sa[1]):
                e = tm.be[tm.btag == 1]
                xm = tm.p[e].mean(axis=1)[:, 0]
                L = np.linalg.norm(tm.p[e[:, 0]] - tm.p[e[:, 1]], axis=1)
                hloc.append(L[np.argmin(np.abs(xm - xe))] / (2 if deg == 2 else 1))
            dl, dr = abs(sa[0] - sb[0]) / hloc[0], abs(sa[1] - sb[1]) / hloc[1]
            worst = max(worst, dl, dr)
            lines.append(f"| P{deg} | {mesh['hc']} / {mesh['hmax']} / {mesh['grading']} | [{sa[0]:.5f}, {sa[1]:.5f}] | "
                         f"[{sb[0]:.5f}, {sb[1]:.5f}] | {dl:.2f} / {dr:.2f} | {a['active_half_width']:.5f} | "
                         f"{b['active_half_width']:.5f} | {res['skfem'][1]['info']['reaction_top']['P']:.3f} / "
                         f"{res['ngsolve'][1]['info']['reaction_top']['P']:.3f} |")
            print(lines[-1], flush=True)
    lines.append("")
    lines.append(f"Largest stick-end difference: {worst:.2f} cells (cell = contact edge length at the stick end; "
                 f"P2: half an edge, the node spacing).")
    return "\n".join(lines)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--no-readme", action="store_true")
    ap.add_argument("--only", choices=["hertz", "friction"], default=None)
    a = ap.parse_args()
    t0 = time.time()
    with tempfile.TemporaryDirectory() as tmp:
        parts = {}
        if a.only in (None, "hertz"):
            parts["hertz"], _ = hertz_table(tmp)
        if a.only in (None, "friction"):
            parts["friction"] = friction_table(tmp)
    print(f"total {time.time() - t0:.0f} s")
    if not a.no_readme:
        readme = Path(__file__).with_name("README.md")
        text = readme.read_text()
        for key, body in parts.items():
            text = re.sub(rf"(<!-- {key}-table:begin -->\n).*?(<!-- {key}-table:end -->)",
                          lambda m: m.group(1) + body + "\n" + m.group(2), text, flags=re.S)
        readme.write_text(text)


if __name__ == "__main__":
    main()
