#!/usr/bin/env python3
"""Adaptive vs uniform refinement driven by `fosls estimate` (tracker issue 6; the talk's last section).

    cargo build --release                                          # the fosls binary (or FOSLS=/path/to/fosls)
    reference/.venv/bin/python reference/adaptive/run.py           # full run, writes docs/adaptive/
    reference/.venv/bin/python reference/adaptive/run.py --quick   # smoke run (Hertz, nu = 0.28, 3 steps)

Per case (Hertz half disc / straight-boundary block; frictionless / Coulomb 0.4; nu = 0.28 / 0.5):
  adaptive: solve (scikit-fem P2 isoparametric, Taylor-Hood P2/P1 at nu = 0.5, primal-dual active set)
            -> solution.vtu + scene.toml -> `fosls estimate --stress reconstruct --mark THETA --json --output`
            -> refine the marked triangles (scikit-fem conforming red-green-blue refinement, new arc vertices
            projected onto the circle) -> repeat;
  uniform:  the same with red refinement of every triangle, up to --max-uniform-dofs;
  reference: the finest adaptive mesh refined adaptively --ref-extra more times, then once uniformly;
            energy-norm error of every step's u_h against it -> efficiency index eta / ||u_ref - u_h||_E.
Writes figures (PNG), their data (CSV / JSON) and summary.json into --out (default docs/adaptive).
"""
import argparse
import csv
import json
import math
import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import loop as L  # noqa: E402
import plots  # noqa: E402
import report  # noqa: E402


def hertz_a(P, nu):
    return L.PR.hertz_ab(P, L.E, nu)["a"]


def region_shares(case, tm, marked, a, trans):
    """Shares of the marked cells (by count) whose centroid lies in the named regions, and the same regions'
    shares of the domain area (`area_*`, geometric) for comparison.  Hertz: disc of
    radius 2a around the contact centre (0, 0); discs of radius a/4 around the contact ends and around the
    stick/slip transitions of this step's solution (points on the arc); the top corners (radius 0.1).  Block:
    the bottom corners (the contact ends) and the top corners (radius 0.1).  A disc counts a cell when the cell's
    centroid lies in it."""
    c = tm.p[tm.t].mean(axis=1)
    n = max(int(marked.sum()), 1)

    def near(points, r):
        if not points:
            return np.zeros(len(c), bool)
        P = np.asarray(points, float)
        return (np.linalg.norm(c[:, None, :] - P[None, :, :], axis=2) <= r).any(axis=1)

    corners_top = [(-1.0, 1.0), (1.0, 1.0)]
    if case.geometry == "hertz":
        arc = lambda x: (x, 1.0 - np.sqrt(1.0 - x * x))
        ends = [arc(t["x"]) for t in trans if 0 in (t["left"], t["right"])]
        sticks = [arc(t["x"]) for t in trans if 0 not in (t["left"], t["right"])]
        discs = dict(within_2a=([(0.0, 0.0)], 2 * a), near_contact_ends=(ends, 0.25 * a),
                     near_stick_slip=(sticks, 0.25 * a), near_top_corners=(corners_top, 0.1))
        if not case.friction:
            discs.pop("near_stick_slip")
    else:
        discs = dict(near_bottom_corners=([(-1.0, 0.0), (1.0, 0.0)], 0.1), near_top_corners=(corners_top, 0.1))
    regions = {k: near(*v) for k, v in discs.items()}
    out = {}
    for k, sel in regions.items():
        out[k] = float((sel & marked).sum() / n)
        out["area_" + k] = geometric_share(case.geometry, *discs[k])
    return out


def geometric_share(geometry, centres, r):
    """Share of the domain's area covered by the union of the discs of radius r around centres (sampled on a
    grid of spacing r/150 over their bounding box)."""
    if not centres:
        return 0.0
    P = np.asarray(centres, float)
    h = r / 150.0
    lo, hi = P.min(axis=0) - r, P.max(axis=0) + r
    xs = np.arange(lo[0] + h / 2, hi[0], h)
    ys = np.arange(lo[1] + h / 2, hi[1], h)
    X, Y = np.meshgrid(xs, ys)
    inside = np.zeros(X.shape, bool)
    for px, py in P:
        inside |= (X - px) ** 2 + (Y - py) ** 2 <= r * r
    if geometry == "hertz":
        dom = (Y <= 1.0) & (X ** 2 + (Y - 1.0) ** 2 <= 1.0)
        total = np.pi / 2
    else:
        dom = (np.abs(X) <= 1.0) & (Y >= 0.0) & (Y <= 1.0)
        total = 2.0
    return float((inside & dom).sum() * h * h / total)


def contact_profile(case, tm, sol):
    """Γ_C nodes: x, y, state (0 no contact, 1 stick, 2 slip), σ_n, σ_t (L2-projected stress, body normal frame:
    n = outward normal of Ω, t = (−n2, n1)), u_t, nodal multipliers."""
    d = sol["dsc"]
    cn = sol["cn"]
    X = d.nodes[cn]
    if case.geometry == "hertz":
        n = X - L.G.CENTRE
        n = n / np.linalg.norm(n, axis=1, keepdims=True)
    else:
        n = np.tile([0.0, -1.0], (len(cn), 1))
    t = np.stack([-n[:, 1], n[:, 0]], axis=1)
    S4 = sol["S4"][cn]
    sx = S4[:, 0] * n[:, 0] + S4[:, 3] * n[:, 1]
    sy = S4[:, 3] * n[:, 0] + S4[:, 1] * n[:, 1]
    sn = sx * n[:, 0] + sy * n[:, 1]
    st = sx * t[:, 0] + sy * t[:, 1]
    U = sol["U"][cn]
    ut = U[:, 0] * t[:, 0] + U[:, 1] * t[:, 1]
    st8 = np.where(sol["state"] == 0, 0, np.where(sol["state"] == 1, 1, 2))
    if not case.friction:
        st8 = np.where(sol["state"] > 0, 2, 0)  # frictionless: every contact node slips
    o = np.argsort(X[:, 0])
    return dict(x=X[o, 0], y=X[o, 1], state=st8[o], sigma_n=sn[o], sigma_t=st[o], u_t=ut[o],
                lambda_n=sol["lambda_n"][o], lambda_t=sol["lambda_t"][o])


def transitions(prof):
    """x of the contact ends and stick ends (midway between nodes of different state)."""
    x, s = prof["x"], prof["state"]
    out = []
    for i in range(len(x) - 1):
        if s[i] != s[i + 1]:
            out.append(dict(x=float(0.5 * (x[i] + x[i + 1])), left=int(s[i]), right=int(s[i + 1])))
    return out


def run_case(case, args, work, log):
    tm = L.initial_mesh(case.geometry)
    res = {"case": case.name, "geometry": case.geometry, "friction": case.friction, "nu": case.nu}
    keep = {}
    for mode in ("adaptive", "uniform"):
        m = tm
        steps, sols, meshes, prev = [], [], [], None
        nsteps = args.steps if mode == "adaptive" else 100
        extra = args.ref_extra if mode == "adaptive" else 0
        k = 0
        while True:
            t0 = time.time()
            sol = L.solve(m, case, prev)
            folder = work / case.name / f"{mode}_{k:02d}"
            L.write_solution(folder, m, sol, case)
            rep, marked, eta_cells, t_est = L.estimate(folder, args.theta, args.stress)
            a = hertz_a(sol["P"], case.nu) if case.geometry == "hertz" else None
            prof = contact_profile(case, m, sol)
            trans = transitions(prof)
            st = dict(step=k, cells=int(len(m.t)), dofs=sol["ndofs"], eta=rep["eta"], relative=rep["relative"],
                      functional=rep["functional"], energy=rep["energy"], norm=rep["norm"],
                      marked=int(marked.sum()), marked_eta2_share=rep["marked"]["share"],
                      marked_shares=region_shares(case, m, marked, a, trans), P=sol["P"], hertz_a=a,
                      active_set_iterations=sol["iterations"], contact=dict(
                          active_length=rep["contact"]["active_length"], stick_length=rep["contact"]["stick_length"],
                          slip_length=rep["contact"]["slip_length"], normal_force=rep["contact"]["normal_force"]),
                      transitions=trans, stress_source=rep["stress"]["source"],
                      bound_guaranteed=rep["bound"]["guaranteed"],
                      time_solve_s=sol["time"], time_fosls_s=t_est)
            st["time_step_s"] = time.time() - t0
            prev = (prof["x"], sol["state"][np.argsort(sol["dsc"].nodes[sol["cn"], 0])])
            reported = k <= nsteps
            if reported:
                steps.append(st)
                sols.append(sol)
                meshes.append(dict(tm=m, marked=marked, prof=prof))
                log(f"{case.name} {mode:8s} step {k:2d}: cells {st['cells']:6d} dofs {st['dofs']:7d} "
                    f"eta {st['eta']:.4e} marked {st['marked']:5d} solve {sol['time']:.1f}s fosls {t_est:.1f}s")
            if mode == "uniform":
                if 4 * sol["ndofs"] > args.max_uniform_dofs:
                    break
                m = L.refine(m, case.geometry)
            else:
                if k >= nsteps + extra:
                    break
                m = L.refine(m, case.geometry, marked)
            k += 1
        res[mode] = steps
        keep[mode] = dict(sols=sols, meshes=meshes, last=(m, sol))
    # reference: the last adaptive mesh (after --ref-extra further adaptive steps) refined once uniformly
    t0 = time.time()
    m_last, s_last = keep["adaptive"]["last"]
    mref = L.refine(m_last, case.geometry)
    pr = contact_profile(case, m_last, s_last)
    ref = L.solve(mref, case, (pr["x"], s_last["state"][np.argsort(s_last["dsc"].nodes[s_last["cn"], 0])]))
    t_ref_solve = time.time() - t0
    for mode in ("adaptive", "uniform"):
        errs, nref = L.energy_errors(ref, keep[mode]["sols"], case.nu)
        for st, e in zip(res[mode], errs):
            st["error_energy"] = e
            st["efficiency"] = st["eta"] / e
    res["reference"] = dict(cells=int(len(mref.t)), dofs=ref["ndofs"], energy_norm=nref, P=ref["P"],
                            time_s=time.time() - t0, time_solve_s=t_ref_solve,
                            mesh="finest reported adaptive mesh + %d adaptive steps, then one uniform refinement"
                            % args.ref_extra)
    # the error of the reference itself, estimated by fosls on the reference mesh
    folder = work / case.name / "reference"
    L.write_solution(folder, mref, ref, case)
    rep, _, _, _ = L.estimate(folder, args.theta, args.stress)
    res["reference"]["eta"] = rep["eta"]
    log(f"{case.name} reference: cells {len(mref.t)} dofs {ref['ndofs']} eta {rep['eta']:.3e} "
        f"({time.time() - t0:.1f}s incl. errors)")
    for mode in ("adaptive", "uniform"):
        res[f"rates_{mode}"] = rates(res[mode])
    return res, keep


def fit(dofs, vals):
    x, y = np.log(np.asarray(dofs, float)), np.log(np.asarray(vals, float))
    if len(x) < 2:
        return None
    return float(-np.polyfit(x, y, 1)[0])


def rates(steps):
    d = [s["dofs"] for s in steps]
    e = [s["eta"] for s in steps]
    er = [s.get("error_energy") for s in steps]
    h = len(d) // 2
    return dict(eta_all=fit(d, e), eta_second_half=fit(d[h:], e[h:]),
                error_all=fit(d, er) if None not in er else None,
                error_second_half=fit(d[h:], er[h:]) if None not in er else None)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default=str(L.REPO / "docs" / "adaptive"))
    ap.add_argument("--quick", action="store_true", help="smoke run: Hertz, nu = 0.28, frictionless, 3 steps")
    ap.add_argument("--steps", type=int, default=10, help="adaptive refinement steps (default 10)")
    ap.add_argument("--theta", type=float, default=0.5, help="Dörfler parameter for fosls --mark (default 0.5)")
    ap.add_argument("--stress", default="reconstruct", choices=["reconstruct", "file", "auto"],
                    help="fosls --stress (default reconstruct: RT_1 minimiser of F, the talk's estimator)")
    ap.add_argument("--max-uniform-dofs", type=int, default=100000,
                    help="stop uniform refinement before the next mesh exceeds this many dofs")
    ap.add_argument("--ref-extra", type=int, default=0, help="extra adaptive steps before the reference mesh")
    ap.add_argument("--cases", nargs="*", default=None, help="subset of case names")
    ap.add_argument("--work", default=None, help="keep the step folders (VTU, JSON) here")
    args = ap.parse_args(argv)
    fosls = L.fosls_binary()
    if not Path(fosls).exists():
        sys.exit(f"fosls binary not found: {fosls} (cargo build --release, or set FOSLS)")
    cases = [L.Case(g, f, nu) for g in ("hertz", "block") for f in (0.0, 0.4) for nu in (0.28, 0.5)]
    if args.quick:
        cases = [L.Case("hertz", 0.0, 0.28)]
        args.steps = min(args.steps, 3)
        args.max_uniform_dofs = min(args.max_uniform_dofs, 20000)
        args.ref_extra = min(args.ref_extra, 1)
    if args.cases:
        cases = [c for c in cases if c.name in args.cases]
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    work = Path(args.work) if args.work else Path(tempfile.mkdtemp(prefix="fosls-adaptive-"))
    t_all = time.time()
    lines = []

    def log(s):
        s = f"[{time.time() - t_all:7.1f}s] {s}"
        print(s, flush=True)
        lines.append(s)

    results, kept = {}, {}
    for c in cases:
        results[c.name], kept[c.name] = run_case(c, args, work, log)
    total = time.time() - t_all
    summary = dict(command="reference/.venv/bin/python reference/adaptive/run.py" + (" --quick" if args.quick else ""),
                   fosls=fosls, fosls_options=f"estimate --stress {args.stress} --mark {args.theta}",
                   theta=args.theta, steps=args.steps, max_uniform_dofs=args.max_uniform_dofs,
                   ref_extra=args.ref_extra, dofs_counted="scikit-fem unknowns (u, and p for Taylor-Hood)",
                   error_norm="(C eps(e), eps(e))^1/2, nu = 0.5: (2 mu ||eps(e)||^2)^1/2, e = u_ref - u_h",
                   versions=L.runner.versions(), time_total_s=None, cases=results)
    t0 = time.time()
    plots.all_figures(out, results, kept, log)
    summary["time_figures_s"] = time.time() - t0
    summary["time_total_s"] = time.time() - t_all
    (out / "summary.json").write_text(json.dumps(L.runner._clean(summary), indent=1) + "\n")
    (out / "log.txt").write_text("\n".join(lines) + f"\ntotal {summary['time_total_s']:.1f} s\n")
    print(f"tables: {report.update(out)}")
    if not args.work:
        shutil.rmtree(work, ignore_errors=True)
    print(f"total {summary['time_total_s']:.1f} s; written to {out}")


if __name__ == "__main__":
    main()
