#!/usr/bin/env python3
"""Stress reconstruction fixtures: fixtures/reconstruct_<case>/ (see README.md here).

    reference/.venv/bin/python reference/reconstruct/make.py            # write the fixtures
    reference/.venv/bin/python reference/reconstruct/make.py --check    # regenerate in a temp dir, compare
    ... --only NAME [NAME ...]                                          # a subset

For each case: sigma_h = argmin over tau in RT_k^2 (row-wise) with tau n = t on Neumann and
free edges, tau_t = 0 and tau_n <= 0 at the nodal points of the contact edges, of the FOSLS
functional F(u_h, tau) of the case's scene; solved twice (scikit-fem, NGSolve), without and
with the sign constraint, evaluated in difference form by both and by fosls_ref on a VTU of the
minimiser.
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
sys.path.insert(0, HERE)
REPO = os.path.dirname(os.path.dirname(HERE))
FIX = os.path.join(REPO, "fixtures")

import common  # noqa: E402
import ngsolve_solver  # noqa: E402
import skfem_solver  # noqa: E402

import fosls_ref  # noqa: E402  (common put reference/ on sys.path)

CASES = [
    # name, source fixture, k, note
    ("exact_p1_energy_rt0", "exact_p1_energy", 0,
     "exact constant stress (in RT_0), P1 u, Neumann data constant: F_min is round-off, no active point"),
    ("exact_p2_energy_rt1", "exact_p2_energy", 1,
     "exact linear stress (in RT_1), P2 u, body force, linear Neumann data: F_min is round-off, no active point"),
    ("perturbed_u_energy_rt1", "perturbed_u_energy", 1,
     "exact_p2 data with u perturbed (lift-off: u_n < g on all of Gamma_C), RT_1: F_min > 0, comp > 0"),
    ("perturbed_u_energy_rt0", "perturbed_u_energy", 0,
     "same u_h, RT_0 (P2 displacement, lowest-order stress; linear Neumann data: midpoint value = edge mean)"),
    ("hertz_skfem_p1_rt0", "hertz_skfem_p1", 0,
     "Hertz (scikit-fem P1, exact nodal complementarity), RT_0: nontrivial active set"),
    ("hertz_skfem_p2_rt1", "hertz_skfem_p2", 1,
     "Hertz (scikit-fem isoparametric P2, curved arc), RT_1 with the P2 (Piola) map: nontrivial active set"),
    ("block_skfem_p1_rt0", "block_skfem_p1", 0,
     "block on a plane (scikit-fem P1, `where` selectors, body normal), RT_0"),
    ("block_ngsolve_p2_rt1", "block_ngsolve_p2", 1,
     "block on a plane (NGSolve P2 penalty solution, slight penetration), RT_1: negative complementarity"),
]

FOSLS_LAYOUT = "xx,xy,xz,yx,yy,yz,zx,zy,zz"
MAX_CELLS_VTU = 200      # minimiser.vtu is stored for the small cases only (size); --vtu-all for every case
TERMS = ("total", "constitutive", "equilibrium", "complementarity")


def _npdefault(o):
    if isinstance(o, (np.integer, np.floating, np.bool_)):
        return o.item()
    raise TypeError(f"not JSON serialisable: {type(o).__name__}")


def rel(a, b, scale=None):
    s = max(abs(a), abs(b)) if scale is None else scale
    return 0.0 if s == 0 else abs(a - b) / s


# ------------------------------------------------------------------------------ one case
def run_case(name, src, k, note, outdir, vtu_all=False):
    t0 = time.perf_counter()
    vtu = os.path.join(FIX, src, "solution.vtu")
    scn = os.path.join(FIX, src, "scene.toml")
    P = common.read_problem(name, vtu, scn)

    # ---- scikit-fem
    S = skfem_solver.SkfemReconstruction(P, k)
    S.assemble()
    S.nodal_transform()
    S.solve(constrained=False)
    sk_u = S.evaluate()
    sk_u_maxtn = float(S.z[S.bound].max()) if len(S.bound) else None
    sk_u_hist = S.history
    sk_u_free = S.ndof_free
    S.solve(constrained=True)
    sk_c = S.evaluate()
    t_sk = time.perf_counter() - t0

    # ---- NGSolve (nodal Neumann data = the convention of the fixture), and NGSolve's own projection
    t1 = time.perf_counter()
    N = ngsolve_solver.NgsolveReconstruction(P, k)
    N.assemble()
    N.constraints()
    N.solve(constrained=False)
    ng_u = N.evaluate()
    ng_u_maxtn = float(N.tn.max()) if len(N.tn) else None
    ng_u_hist = N.history
    N.solve(constrained=True)
    ng_c = N.evaluate()
    N2 = ngsolve_solver.NgsolveReconstruction(P, k, neumann="l2")
    N2.assemble()
    N2.constraints()
    N2.solve(constrained=True)
    ng_l2 = N2.evaluate()
    t_ng = time.perf_counter() - t1

    energy = sk_c["energy"]
    keys_sk = [common.point_key(p["x"], p["y"], P.diam) for p in S.points]
    mids_sk = [common.point_key(0.5 * (p["edge_a"][0] + p["edge_b"][0]), 0.5 * (p["edge_a"][1] + p["edge_b"][1]),
                                P.diam) for p in S.points]
    keys_ng = N.point_keys()
    mids_ng = [common.point_key(*p["edge_mid"], P.diam) for p in N.cpoints]
    idx_ng = {(a, b): i for i, (a, b) in enumerate(zip(keys_ng, mids_ng))}
    assert len(idx_ng) == len(keys_ng) == len(keys_sk)
    perm = [idx_ng[(a, b)] for a, b in zip(keys_sk, mids_sk)]      # skfem point i -> NGSolve row
    activeA = set(int(s) for s in S.A)
    act_sk = [i for i, p in enumerate(S.points) if p["slot"] in activeA]
    act_ng_rows = set(int(j) for j in N.A)
    act_ng = [i for i in range(len(S.points)) if perm[i] in act_ng_rows]
    tn_sk = np.array([S.z[p["slot"]] for p in S.points])
    tt_sk = np.array([S.z[p["slot"] + S.Nrt] for p in S.points])
    lam_sk = np.array([S.lam[p["slot"]] for p in S.points])
    tn_ng = N.tn[perm]
    lam_ng = N.lam[perm]
    tn_scale = float(np.abs(tn_sk).max()) if len(tn_sk) else 0.0

    # nodal values of both minimisers at the VTU nodes
    nod_sk = skfem_solver.tau_at_nodes(S)
    nod_ng = ngsolve_solver.tau_at_nodes(N)
    tau_scale = float(np.abs(nod_sk).max())
    nodal_diff = float(np.abs(nod_sk - nod_ng).max()) / tau_scale

    # ---- minimiser as a VTU (discontinuous nodal interpolation on the u_h cells), fosls_ref on it
    os.makedirs(outdir, exist_ok=True)
    shutil.copyfile(vtu, os.path.join(outdir, "solution.vtu"))
    shutil.copyfile(scn, os.path.join(outdir, "scene.toml"))
    keep_vtu = len(P.cells) <= MAX_CELLS_VTU or vtu_all
    vtmp = None if keep_vtu else tempfile.mkdtemp(prefix="minimiser_")
    mpath = os.path.join(outdir if keep_vtu else vtmp, "minimiser.vtu")
    write_minimiser(P, nod_sk, mpath)
    t2 = time.perf_counter()
    fr = fosls_ref.evaluate_files(mpath, os.path.join(outdir, "scene.toml"), layout=FOSLS_LAYOUT)
    t_fr = time.perf_counter() - t2
    if vtmp:
        shutil.rmtree(vtmp, ignore_errors=True)
    fr_file = source_fosls_ref(src)
    exact_repr = not P.curved     # RT_k (degree k+1 <= degree of u_h) is exactly nodal on straight cells

    def terms(d):
        return {t: d[t] for t in TERMS}

    def block(sk, ng, **extra):
        out = {"functional": terms(sk), "energy": sk["energy"],
               "relative": math.sqrt(sk["total"] / sk["energy"]) if sk["total"] >= 0 else None,
               "skfem": terms(sk), "ngsolve": terms(ng),
               "rel_diff_skfem_ngsolve": {t: rel(sk[t], ng[t]) for t in TERMS},
               "diff_skfem_ngsolve_over_energy": {t: abs(sk[t] - ng[t]) / energy for t in TERMS}}
        out.update(extra)
        return out

    contact_pts = []
    for i, p in enumerate(S.points):
        contact_pts.append({"x": p["x"], "y": p["y"], "edge": [p["edge_a"], p["edge_b"]],
                            "boundary": p["boundary"], "tau_n": float(tn_sk[i]),
                            "active": i in set(act_sk), "multiplier": float(lam_sk[i]) if i in set(act_sk) else 0.0})
    inactive = [i for i in range(len(S.points)) if i not in set(act_sk)]
    ness = len(S.fixed)
    doc = {
        "case": name,
        "summary": note,
        "source": {"fixture": f"fixtures/{src}", "solution": "solution.vtu (copy)", "scene": "scene.toml (copy)"},
        "k": k,
        "space": f"row-wise RT_{k} (scikit-fem {'ElementTriRT0 = ElementTriRT1' if k == 0 else 'ElementTriRT2'}; "
                 f"NGSolve HDiv(order={k}, RT=True))",
        "displacement_degree": P.degree,
        "geometry": "isoparametric P2 (curved cells, Piola map with the P2 Jacobian)" if P.curved
                    else ("straight cells" + (" (P2 nodes at chord mid points)" if P.degree == 2 else "")),
        "norm": P.norm,
        "material": {"mu": P.mu, "lambda": P.lam, "trace_coef": P.ctr},
        "weights": {"w_d": P.wd, "length_scale": P.ell, "diameter": P.diam,
                    "constitutive_k1": P.k1, "constitutive_k2": P.k2},
        "conventions": {
            "unknowns": "nodal normal-trace values on constrained edges: RT_0 one value per edge "
                        "(at the edge mid point), RT_1 the values at the two edge end points",
            "neumann": "tau_i . n_Omega = t_i at those points (point interpolation of t)",
            "contact": "tau_t = 0 and tau_n <= 0 at those points; (n, t) the scene's contact frame",
            "active_set": "contact points where the bound tau_n <= 0 is active (tau_n = 0) at the end",
        },
        "dofs": {
            "rt_per_row": S.Nrt, "tau": 2 * S.Nrt, "ngsolve_tau": int(N.fes.ndof),
            "essential": ness, "contact_points": len(S.points),
            "free_unconstrained": sk_u_free, "free_constrained": S.ndof_free,
        },
        "unconstrained": block(sk_u, ng_u, max_tau_n=sk_u_maxtn, max_tau_n_ngsolve=ng_u_maxtn,
                               pdas_iterations=len(sk_u_hist)),
        "constrained": block(
            sk_c, ng_c,
            active_count=len(act_sk),
            active_set=[{"x": S.points[i]["x"], "y": S.points[i]["y"],
                         "edge": [S.points[i]["edge_a"], S.points[i]["edge_b"]]} for i in act_sk],
            active_sets_equal=sorted(act_sk) == sorted(act_ng),
            max_tau_n=float(tn_sk.max()) if len(tn_sk) else None,
            max_tau_n_ngsolve=float(tn_ng.max()) if len(tn_ng) else None,
            max_tau_n_inactive=float(tn_sk[inactive].max()) if inactive else None,
            min_multiplier_active=float(lam_sk[act_sk].min()) if act_sk else None,
            max_multiplier_active=float(lam_sk[act_sk].max()) if act_sk else None,
            multiplier_diff_skfem_ngsolve_over_max=(float(np.abs(lam_sk[act_sk] - lam_ng[act_sk]).max()
                                                          / lam_sk[act_sk].max()) if act_sk else 0.0),
            max_abs_tau_t=float(np.abs(tt_sk).max()) if len(tt_sk) else None,
            tau_n_diff_skfem_ngsolve_over_scale=float(np.abs(tn_sk - tn_ng).max() / tn_scale) if tn_scale else 0.0,
            tau_scale=tau_scale, tau_n_scale=tn_scale,
            nodal_tau_diff_skfem_ngsolve_over_scale=nodal_diff,
            pdas_active_counts_skfem=[h["active"] for h in S.history],
            pdas_active_counts_ngsolve=[h["active"] for h in N.history],
            ngsolve_neumann_l2_projection={"total": ng_l2["total"],
                                           "rel_diff_vs_interpolation": rel(ng_l2["total"], ng_c["total"]),
                                           "diff_over_energy": abs(ng_l2["total"] - ng_c["total"]) / energy},
            contact_points=contact_pts,
        ),
        "fosls_ref_minimiser": {
            "file": "minimiser.vtu" if keep_vtu else None,
            "file_note": "stored here" if keep_vtu else
                         f"not stored (size): make.py --vtu-all --out DIR --only {name} writes it",
            "layout": FOSLS_LAYOUT,
            "exact_representation": exact_repr,
            "functional": {t: fr["functional"][t] for t in TERMS},
            "energy": fr["energy"],
            "rel_diff_vs_skfem": {t: rel(fr["functional"][t], sk_c[t]) for t in TERMS},
            "diff_vs_skfem_over_energy": {t: abs(fr["functional"][t] - sk_c[t]) / energy for t in TERMS},
            "admissibility": {kk: fr["admissibility"][kk] for kk in ("tension_max", "cone_violation_max", "neumann_max")},
            "note": "nodal values exact (straight cells, RT_k of degree k+1 <= displacement degree)" if exact_repr
                    else "APPROXIMATE: the Piola-mapped RT field on curved cells is rational, the VTU holds its "
                         "P2 nodal interpolation; compare the functional with the skfem/NGSolve values only loosely",
        },
        "fosls_ref_file_stress": {"functional": {t: fr_file["functional"][t] for t in TERMS},
                                  "from": fr_file["from"],
                                  "note": "F with the stress stored in solution.vtu (fosls_ref), for comparison"},
        "solver": {"pdas": "primal-dual active set, start A = {}, A <- {lambda > 0 on A} u {tau_n > 0 off A}; "
                           "stops when A repeats",
                   "skfem_intorder": S.intorder, "skfem_facet_intorder": S.facet_intorder,
                   "ngsolve_bonus_intorder": N.bonus},
        "roundoff_note": None,
    }
    if abs(sk_c["total"]) < 1e-20 * energy:
        doc["roundoff_note"] = ("F_min and its terms are round-off (exact stress in the space): compare "
                                "|value| <= 1e-20 * energy, not relatively")
    dump_json(doc, os.path.join(outdir, "expected.json"))
    write_readme(doc, outdir)
    timing = {"skfem": t_sk, "ngsolve": t_ng, "fosls_ref": t_fr, "total": time.perf_counter() - t0}
    return doc, timing


def source_fosls_ref(src):
    """fosls_ref's result for the source fixture as stored there (expected_fosls.json or
    expected.json, whichever was written by fosls_ref)."""
    for f in ("expected_fosls.json", "expected.json"):
        pth = os.path.join(FIX, src, f)
        if os.path.exists(pth):
            with open(pth) as fh:
                d = json.load(fh)
            if d.get("tool") == "fosls_ref":
                d["from"] = f"fixtures/{src}/{f}"
                return d
    raise FileNotFoundError(f"no fosls_ref result in fixtures/{src}")


def dump_json(doc, path):
    """indent=1, but arrays of plain numbers on one line."""
    import re
    txt = json.dumps(doc, indent=1, default=_npdefault)
    txt = re.sub(r"\[\s*([-0-9.eE+]+(?:,\s*[-0-9.eE+]+)*)\s*\]",
                 lambda m: "[" + ", ".join(x.strip() for x in m.group(1).split(",")) + "]", txt)
    with open(path, "w") as fh:
        fh.write(txt + "\n")


def write_minimiser(P, nod, path):
    """Exploded mesh: every cell has its own nodes; stress 9 components row-major."""
    nc, nloc = P.cells.shape
    pts = P.points[P.cells].reshape(-1, 2)
    pts3 = np.hstack([pts, np.zeros((len(pts), 1))])
    disp = P.disp[P.cells].reshape(-1, 2)
    st = np.zeros((nc * nloc, 9))
    tn = nod.reshape(-1, 2, 2)
    st[:, 0], st[:, 1], st[:, 3], st[:, 4] = tn[:, 0, 0], tn[:, 0, 1], tn[:, 1, 0], tn[:, 1, 1]
    conn = np.arange(nc * nloc).reshape(nc, nloc)
    cells = [("triangle6" if nloc == 6 else "triangle", conn)]
    cell_data = {}
    if P.line_tags is not None:
        first = {}
        for c in range(nc):
            for a in range(nloc):
                first.setdefault(int(P.cells[c, a]), c * nloc + a)
        lc = np.vectorize(lambda v: first[int(v)])(P.line_cells)
        cells.append(("line3" if lc.shape[1] == 3 else "line", lc))
        cell_data[P.scene.tag_array] = [np.zeros(nc, dtype=np.int32), P.line_tags.astype(np.int32)]
    dname = P.scene.displacement_name or "displacement"
    sname = P.scene.stress_name or "stress"
    m = meshio.Mesh(pts3, cells, point_data={dname: disp, sname: st}, cell_data=cell_data)
    meshio.write(path, m, file_format="vtu", binary=True, compression="zlib")


def fmt(v):
    return "n/a" if v is None else f"{v:.10g}"


def write_readme(doc, outdir):
    c, u = doc["constrained"], doc["unconstrained"]
    fr = doc["fosls_ref_minimiser"]
    lines = [
        f"# reconstruct: {doc['case']}",
        "",
        f"{doc['summary']}.",
        "",
        f"Stress reconstruction of docs/design.md §5 for the displacement of `{doc['source']['fixture']}` "
        f"(copied here: `solution.vtu`, `scene.toml`): sigma_h = argmin over tau in {doc['space']} of "
        f"F(u_h, tau), norm `{doc['norm']}`, w_d = {doc['weights']['w_d']:.10g} "
        f"(length scale {doc['weights']['length_scale']:.10g}), displacement P{doc['displacement_degree']}, "
        f"{doc['geometry']}. Formulas and conventions: `reference/reconstruct/README.md`.",
        "",
        f"- DOFs: {doc['dofs']['tau']} (2 x {doc['dofs']['rt_per_row']}); essential {doc['dofs']['essential']}; "
        f"contact points {doc['dofs']['contact_points']}.",
        f"- Unconstrained (essential conditions only): F = {fmt(u['functional']['total'])} "
        f"(const {fmt(u['functional']['constitutive'])}, equi {fmt(u['functional']['equilibrium'])}, "
        f"comp {fmt(u['functional']['complementarity'])}); max tau_n = {fmt(u['max_tau_n'])}.",
        f"- Constrained (tau_n <= 0): F = {fmt(c['functional']['total'])} "
        f"(const {fmt(c['functional']['constitutive'])}, equi {fmt(c['functional']['equilibrium'])}, "
        f"comp {fmt(c['functional']['complementarity'])}); {c['active_count']} active point(s); "
        f"max tau_n = {fmt(c['max_tau_n'])}, max over inactive points {fmt(c['max_tau_n_inactive'])}; "
        f"PDAS iterations {len(c['pdas_active_counts_skfem'])}.",
        f"- scikit-fem vs NGSolve: rel. diff of F {u['rel_diff_skfem_ngsolve']['total']:.1e} (unconstrained), "
        f"{c['rel_diff_skfem_ngsolve']['total']:.1e} (constrained); same active set: {c['active_sets_equal']}; "
        f"nodal tau {c['nodal_tau_diff_skfem_ngsolve_over_scale']:.1e} of max |tau|.",
        f"- fosls_ref on the minimiser written as VTU ({'`minimiser.vtu` here' if fr['file'] else fr['file_note']}; "
        f"scikit-fem minimiser, discontinuous nodal interpolation, stress 9 components row-major): F = {fmt(fr['functional']['total'])} (rel. diff {fr['rel_diff_vs_skfem']['total']:.1e}; "
        f"{'exact representation' if fr['exact_representation'] else 'approximate: curved cells'}).",
        f"- F with the file's own stress (fosls_ref): {fmt(doc['fosls_ref_file_stress']['functional']['total'])}.",
        "",
        "`expected.json`: all numbers (both libraries, every term, the active set as contact-edge points with "
        "their edge, tau_n and the multiplier at every contact point). Regenerate / check with "
        "`reference/.venv/bin/python reference/reconstruct/make.py [--check] --only " + doc["case"] + "`.",
    ]
    if doc.get("roundoff_note"):
        lines[4:4] = [f"**{doc['roundoff_note']}.**", ""]
    with open(os.path.join(outdir, "README.md"), "w") as fh:
        fh.write("\n".join(lines) + "\n")


# ------------------------------------------------------------------------------ checking
NOISE_KEYS = {"rel_diff_skfem_ngsolve", "diff_skfem_ngsolve_over_energy", "rel_diff_vs_interpolation",
              "diff_over_energy", "rel_diff_vs_skfem", "diff_vs_skfem_over_energy",
              "tau_n_diff_skfem_ngsolve_over_scale", "nodal_tau_diff_skfem_ngsolve_over_scale",
              "multiplier_diff_skfem_ngsolve_over_max"}
STRESS_KEYS = {"tau_n", "max_tau_n", "max_tau_n_ngsolve", "max_tau_n_inactive",
               "max_abs_tau_t", "tension_max", "cone_violation_max", "neumann_max", "tau_scale", "tau_n_scale"}
MULT_KEYS = {"multiplier", "min_multiplier_active", "max_multiplier_active"}


def compare(a, b, path, scales, errs, rtol=1e-8):
    if isinstance(a, dict):
        if not isinstance(b, dict) or set(a) != set(b):
            errs.append(f"{path}: keys differ")
            return
        for kk in a:
            if kk in NOISE_KEYS:
                continue
            compare(a[kk], b[kk], f"{path}.{kk}", scales, errs, rtol)
    elif isinstance(a, list):
        if not isinstance(b, list) or len(a) != len(b):
            errs.append(f"{path}: list lengths differ ({len(a)} vs {len(b) if isinstance(b, list) else b})")
            return
        for i, (x, y) in enumerate(zip(a, b)):
            compare(x, y, f"{path}[{i}]", scales, errs, rtol)
    elif isinstance(a, bool) or isinstance(a, str) or a is None:
        if a != b:
            errs.append(f"{path}: {a!r} != {b!r}")
    elif isinstance(a, (int, float)):
        if not isinstance(b, (int, float)) or isinstance(b, bool):
            errs.append(f"{path}: {a!r} vs {b!r}")
            return
        last = path.split(".")[-1].split("[")[0]
        if last in STRESS_KEYS:
            atol = 1e-8 * scales["stress"]
        elif last in MULT_KEYS:
            atol = 1e-10 * scales["multiplier"]
        elif last == "relative":
            # (F / energy)^(1/2) of an exact case is round-off (5e-15): 1e-12 absolute.
            atol = 1e-12
        elif any(s in path for s in ("functional", "skfem", "ngsolve", "energy", "total")):
            atol = 1e-14 * scales["energy"]
        else:
            atol = 1e-13 * max(abs(a), abs(b), 1e-300) if isinstance(a, float) else 0
        if abs(a - b) > rtol * max(abs(a), abs(b)) + atol:
            errs.append(f"{path}: {a!r} vs {b!r}")


def sanity(doc):
    """Properties every case must have (independent of the stored values)."""
    errs = []
    c, u = doc["constrained"], doc["unconstrained"]
    for blk, nm in ((u, "unconstrained"), (c, "constrained")):
        for t in TERMS:
            if blk["diff_skfem_ngsolve_over_energy"][t] > 1e-10 and blk["rel_diff_skfem_ngsolve"][t] > 1e-10:
                errs.append(f"{nm}.{t}: scikit-fem and NGSolve differ by {blk['rel_diff_skfem_ngsolve'][t]:.2e}")
    if c["multiplier_diff_skfem_ngsolve_over_max"] > 1e-8:
        errs.append(f"multipliers differ: {c['multiplier_diff_skfem_ngsolve_over_max']:.2e} of the largest")
    if not c["active_sets_equal"]:
        errs.append("active sets of scikit-fem and NGSolve differ")
    if c["max_tau_n"] is not None and c["max_tau_n"] > 1e-10 * c["tau_n_scale"]:
        errs.append(f"constrained minimiser has tau_n = {c['max_tau_n']} > 0")
    if doc["fosls_ref_minimiser"]["exact_representation"]:
        fr = doc["fosls_ref_minimiser"]
        if fr["diff_vs_skfem_over_energy"]["total"] > 1e-10 and fr["rel_diff_vs_skfem"]["total"] > 1e-8:
            errs.append(f"fosls_ref on the minimiser differs: {fr['rel_diff_vs_skfem']['total']:.2e}")
    return errs


def compare_vtu(pa, pb, errs, rtol=1e-8):
    ma, mb = meshio.read(pa), meshio.read(pb)
    if not np.array_equal(ma.points, mb.points):
        errs.append(f"{os.path.basename(pa)}: points differ")
    for kk in ma.point_data:
        x, y = np.asarray(ma.point_data[kk]), np.asarray(mb.point_data.get(kk))
        if y is None or x.shape != y.shape:
            errs.append(f"{os.path.basename(pa)}: array {kk} missing / shape")
            continue
        sc = max(np.abs(x).max(), 1e-300)
        d = np.abs(x - y).max() / sc
        if d > rtol:
            errs.append(f"{os.path.basename(pa)}: array {kk} differs by {d:.2e} of its max")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--check", action="store_true", help="regenerate in a temp dir and compare (rel 1e-8)")
    ap.add_argument("--only", nargs="+", help="case names (folder names without reconstruct_)")
    ap.add_argument("--out", help="output root (default: fixtures/)")
    ap.add_argument("--vtu-all", action="store_true", help="store minimiser.vtu for every case")
    args = ap.parse_args()
    cases = [c for c in CASES if not args.only or c[0] in args.only]
    if args.only and len(cases) != len(args.only):
        known = ", ".join(c[0] for c in CASES)
        sys.exit(f"unknown case in --only; known: {known}")
    tmp = tempfile.mkdtemp(prefix="reconstruct_") if args.check else None
    root = tmp if args.check else (args.out or FIX)
    failures = 0
    t_all = time.perf_counter()
    for name, src, k, note in cases:
        outdir = os.path.join(root, f"reconstruct_{name}")
        doc, timing = run_case(name, src, k, note, outdir, vtu_all=args.vtu_all)
        with open(os.path.join(outdir, "expected.json")) as fh:
            doc = json.load(fh)            # compare what was written (plain JSON types)
        errs = sanity(doc)
        if args.check:
            ref_dir = os.path.join(FIX, f"reconstruct_{name}")
            try:
                with open(os.path.join(ref_dir, "expected.json")) as fh:
                    ref = json.load(fh)
            except FileNotFoundError:
                errs.append(f"{ref_dir}/expected.json missing")
                ref = None
            if ref is not None:
                scales = {"energy": ref["constrained"]["energy"],
                          "stress": max(ref["constrained"]["tau_scale"], 1e-300),
                          "multiplier": ref["constrained"]["max_multiplier_active"] or 0.0}
                compare(ref, doc, "expected", scales, errs)
                if ref["fosls_ref_minimiser"]["file"]:
                    compare_vtu(os.path.join(ref_dir, "minimiser.vtu"), os.path.join(outdir, "minimiser.vtu"), errs)
                for f in ("solution.vtu", "scene.toml"):
                    with open(os.path.join(ref_dir, f), "rb") as a, open(os.path.join(FIX, src, f), "rb") as b:
                        if a.read() != b.read():
                            errs.append(f"{f} differs from fixtures/{src}/{f}")
        c = doc["constrained"]
        status = "FAIL" if errs else "ok"
        print(f"{status:4s} reconstruct_{name}: k={k} F={c['functional']['total']:.12g} "
              f"(unconstrained {doc['unconstrained']['functional']['total']:.12g}) active={c['active_count']} "
              f"skfem/ngsolve rel {c['rel_diff_skfem_ngsolve']['total']:.1e} "
              f"fosls_ref rel {doc['fosls_ref_minimiser']['rel_diff_vs_skfem']['total']:.1e} "
              f"[{timing['total']:.1f} s]")
        for e in errs[:20]:
            print("     " + e)
        failures += bool(errs)
    print(f"{len(cases)} case(s), {failures} failure(s), {time.perf_counter() - t_all:.1f} s")
    if tmp:
        shutil.rmtree(tmp, ignore_errors=True)
    sys.exit(1 if failures else 0)


if __name__ == "__main__":
    main()
