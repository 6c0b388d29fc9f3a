#!/usr/bin/env python3
"""Manufactured smooth contact problems on the unit square (exact u, sigma; active and inactive part of
Gamma_C; frictionless and Coulomb 0.4), P1 and P2, on a sequence of uniform meshes (n x n squares, each
cut along the diagonal), for convergence tests.  See exact.py for the solution.

    reference/.venv/bin/python reference/manufactured/make.py            # fixtures/manufactured_* (n = 4, 8, 16; frictionless also 32)
    reference/.venv/bin/python reference/manufactured/make.py --check    # regenerate in a temp dir, compare (rel 1e-8)
    reference/.venv/bin/python reference/manufactured/rates.py           # error table incl. n = 32, 64 (not committed)

Each fixture holds the FE solution (scikit-fem, primal-dual active set on the nodal constraints, data from
the exact solution) as `u`/`stress`, and the nodal interpolants of the exact solution as
`u_exact`/`stress_exact`; scene.toml selects the FE fields, scene_exact.toml the exact ones.
"""
import json
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "hertz"))
sys.path.insert(0, str(HERE))

import numpy as np  # noqa: E402
import scipy.sparse as sp  # noqa: E402
from skfem import Basis, FacetBasis, ElementVector, LinearForm, asm  # noqa: E402

import geometry as G  # noqa: E402
import fem_skfem as S  # noqa: E402
import runner  # noqa: E402
import evaluate  # noqa: E402
import exact as EX  # noqa: E402

TAGS = dict(bottom=1, top=2, left=3, right=4)
LEVELS = (4, 8, 16)
# The frictionless family has a 4th level (issue 13: bound reliability / efficiency over 4 refinements);
# Coulomb and aligned keep LEVELS.
FRICTIONLESS_LEVELS = LEVELS + (32,)
ENC = {4: "ascii", 8: "raw", 16: "zlib", 32: "zlib"}
# the exact slip starts smoothly (u_t ~ (x - x1)^4): nodes count as slipping when |u_t| > 1e-2 max |u_t|
SLIP_TOL = 1e-2


def case_name(fr, deg, n):
    return f"manufactured_{'coulomb' if fr else 'frictionless'}_p{deg}_n{n:02d}"


CASES = {case_name(fr, deg, n): dict(friction=fr, degree=deg, n=n)
         for fr in (0.0, 0.4) for deg in (1, 2) for n in (FRICTIONLESS_LEVELS if fr == 0.0 else LEVELS)}
# The frictionless problem with its kink on mesh lines and without the slip profile w (x0 = 0.5,
# w = 0, exact.configure): smooth on every cell, for the optimal-rate test of the reconstruction
# (tests/reconstruct_cli.rs).
ALIGNED = (0.5, 0.25, 0.0)
CASES.update({f"manufactured_aligned_p{deg}_n{n:02d}": dict(friction=0.0, degree=deg, n=n, aligned=True)
              for deg in (1, 2) for n in LEVELS})


def square_mesh(n):
    xs = np.linspace(0.0, 1.0, n + 1)
    X, Y = np.meshgrid(xs, xs, indexing="ij")
    p = np.stack([X.ravel(), Y.ravel()], 1)
    idx = lambda i, j: i * (n + 1) + j  # noqa: E731
    t = []
    for i in range(n):
        for j in range(n):
            a, b, c, d = idx(i, j), idx(i + 1, j), idx(i + 1, j + 1), idx(i, j + 1)
            t += [[a, b, c], [a, c, d]]
    t = np.array(t, dtype=np.int64)
    e = np.vstack([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]])
    key = np.sort(e, axis=1)
    uniq, inv, cnt = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    bmask = cnt[inv.ravel()] == 1
    be = e[bmask]
    tags = []
    for a, b in be:
        pa, pb = p[a], p[b]
        if pa[1] == 0 and pb[1] == 0:
            tags.append(TAGS["bottom"])
        elif pa[1] == 1 and pb[1] == 1:
            tags.append(TAGS["top"])
        elif pa[0] == 0 and pb[0] == 0:
            tags.append(TAGS["left"])
        else:
            tags.append(TAGS["right"])
    return G.TriMesh(p, t, be, np.array(tags), None, dict(kind="unit_square", n=n))


def solve(ex, tm, deg):
    t0 = time.time()
    d = S.Discretisation(tm, deg)
    K = S.assemble(d, EX.E, EX.NU)
    vb = Basis(d.mesh, ElementVector(d.elem), intorder=10)

    @LinearForm
    def load(v, w):
        return ex.ev("f1", w.x[0], w.x[1]) * v[0] + ex.ev("f2", w.x[0], w.x[1]) * v[1]

    F = asm(load, vb)
    side = d.mesh.facets_satisfying(lambda x: (x[0] < 1e-12) | (x[0] > 1 - 1e-12))
    fb = FacetBasis(d.mesh, ElementVector(d.elem), facets=side, intorder=10)

    @LinearForm
    def neumann(v, w):
        s4 = ex.sigma4(w.x[0], w.x[1])
        n = w.n
        t1 = s4[..., 0] * n[0] + s4[..., 3] * n[1]
        t2 = s4[..., 3] * n[0] + s4[..., 1] * n[1]
        return t1 * v[0] + t2 * v[1]

    F = F + asm(neumann, fb)
    top = d.boundary_nodes([TAGS["top"]])
    cn = np.setdiff1d(d.boundary_nodes([TAGS["bottom"]]), top)
    xy = d.nodes
    res = S.solve_contact_general(d, K, F, top, ex.u(xy[top, 0], xy[top, 1]), cn,
                                  ex.ev("gap", xy[cn, 0], xy[cn, 1]), friction=ex.F)
    U, S4 = S.nodal_fields(d, EX.E, EX.NU, res["u"])
    info = dict(library="scikit-fem", method="primal-dual active set (semismooth Newton) on nodal constraints"
                + (", nodal Coulomb friction" if ex.F else ""), element=f"P{deg} displacement",
                dofs=int(K.shape[0]), iterations=res["iterations"], final_residual=res["final_residual"],
                history=[{k: v for k, v in h.items() if k in ("it", "active", "stick", "changed")} for h in res["history"]],
                reaction_top=dict(P=res["P"], Fx=res["Fx_top"]), time_s=time.time() - t0)
    return d, U, S4, info


def scene(ex, fields, tags):
    sc = {"material": {"youngs_modulus": EX.E, "poisson_ratio": EX.NU, "model": "plane_strain"},
          "fields": fields,
          "loads": {"body_force": [ex.e["f1"], ex.e["f2"]]}}
    if tags:
        sc["boundaries"] = {"tag_array": "boundary_tag"}
    sel = (lambda name, where: {"tag": TAGS[name]} if tags else {"where": where})
    con = {"name": "bottom", **sel("bottom", "y < 0.0001"), "kind": "contact", "gap": ex.e["gap"], "normal": "body"}
    if ex.F:
        con["friction"] = ex.F
    sc["boundary"] = [
        {"name": "top", **sel("top", "y > 0.9999"), "kind": "dirichlet", "displacement": [ex.e["u1"], ex.e["u2"]]},
        {"name": "left", **sel("left", "x < 0.0001"), "kind": "neumann", "traction": ex.traction(-1.0, 0.0)},
        {"name": "right", **sel("right", "x > 0.9999"), "kind": "neumann", "traction": ex.traction(1.0, 0.0)},
        con,
    ]
    return sc


def errors(path, scene_, ex):
    """‖u - u_h‖_L2, energy norm ½(Cε(e), ε(e))^½ of e = u - u_h, ‖σ_exact - σ_file‖_L2 (stress field of
    the file), ‖σ_exact - Cε(u_h)‖_L2; Duffy-collapsed 10x10 Gauss rule per (straight) triangle."""
    fx = evaluate.Fixture(path, scene_)
    g, w = np.polynomial.legendre.leggauss(10)
    g, w = 0.5 * (g + 1), 0.5 * w
    A, B = np.meshgrid(g, g, indexing="ij")
    WA, WB = np.meshgrid(w, w, indexing="ij")
    xi, eta, wt = (A * (1 - B)).ravel(), B.ravel(), (WA * WB * (1 - B)).ravel()
    l0, l1, l2 = 1 - xi - eta, xi, eta
    if fx.quad:
        N = np.stack([l0 * (2 * l0 - 1), l1 * (2 * l1 - 1), l2 * (2 * l2 - 1), 4 * l0 * l1, 4 * l1 * l2, 4 * l2 * l0], -1)
        dN = np.stack([
            np.stack([-(4 * l0 - 1), 4 * l1 - 1, 0 * xi, 4 * (l0 - l1), 4 * eta, -4 * eta], -1),
            np.stack([-(4 * l0 - 1), 0 * xi, 4 * l2 - 1, -4 * xi, 4 * xi, 4 * (l0 - l2)], -1)], 1)
    else:
        N = np.stack([l0, l1, l2], -1)
        dN = np.tile(np.array([[-1.0, 1.0, 0.0], [-1.0, 0.0, 1.0]]), (len(xi), 1, 1))
    Xe, Ue = fx.X[fx.cells], fx.U[fx.cells]
    Se = fx.S[fx.cells]  # (M,k,3) xx,yy,xy
    xq = np.einsum("qk,mkd->mqd", N, Xe)
    J = np.einsum("qrk,mkd->mqdr", dN, Xe)
    det = J[..., 0, 0] * J[..., 1, 1] - J[..., 0, 1] * J[..., 1, 0]
    Jinv = np.stack([np.stack([J[..., 1, 1], -J[..., 0, 1]], -1), np.stack([-J[..., 1, 0], J[..., 0, 0]], -1)], -2) / det[..., None, None]
    Gh = np.einsum("mqcr,mqrd->mqcd", np.einsum("qrk,mkc->mqcr", dN, Ue), Jinv)
    uh = np.einsum("qk,mkc->mqc", N, Ue)
    sh = np.einsum("qk,mkc->mqc", N, Se)
    x, y = xq[..., 0], xq[..., 1]
    ue = ex.u(x, y)
    Ge = ex.grad(x, y)
    s4 = ex.sigma4(x, y)
    se = np.stack([s4[..., 0], s4[..., 1], s4[..., 3]], -1)
    dV = np.abs(det) * wt
    eu = ue - uh
    ee = 0.5 * ((Ge - Gh) + np.swapaxes(Ge - Gh, -1, -2))
    tr = ee[..., 0, 0] + ee[..., 1, 1]
    en = np.sum((EX.MU * np.einsum("mqij,mqij->mq", ee, ee) + 0.5 * EX.LAM * tr ** 2) * dV)
    eh = 0.5 * (Gh + np.swapaxes(Gh, -1, -2))
    trh = eh[..., 0, 0] + eh[..., 1, 1]
    sig_uh = np.stack([2 * EX.MU * eh[..., 0, 0] + EX.LAM * trh, 2 * EX.MU * eh[..., 1, 1] + EX.LAM * trh, 2 * EX.MU * eh[..., 0, 1]], -1)

    def l2(a):  # tensor rows xx, yy, xy: xy counted twice (Frobenius)
        wts = np.array([1.0, 1.0, 2.0])[: a.shape[-1]] if a.shape[-1] == 3 else np.ones(a.shape[-1])
        return float(np.sqrt(np.sum((a ** 2 * wts).sum(-1) * dV)))
    return dict(u_L2=float(np.sqrt(np.sum((eu ** 2).sum(-1) * dV))), energy=float(np.sqrt(en)),
                stress_file_L2=l2(se - sh), stress_of_uh_L2=l2(se - sig_uh),
                u_exact_L2=float(np.sqrt(np.sum((ue ** 2).sum(-1) * dV))), stress_exact_L2=l2(se))


def make_one(name, outdir, results, levels_ok=True):
    c = CASES[name] if name in CASES else dict(zip(("friction", "degree", "n"), name))
    EX.configure(*(ALIGNED if c.get("aligned") else (0.6, 0.3, 0.0005)))
    ex = EX.Exact(c["friction"])
    tm = square_mesh(c["n"])
    d, U, S4, info = solve(ex, tm, c["degree"])
    nodes = d.nodes
    Uex = ex.u(nodes[:, 0], nodes[:, 1])
    Sex = ex.sigma4(nodes[:, 0], nodes[:, 1])
    tags = c["n"] != 8  # n = 8 uses where selectors
    layout = "xx,yy,xy"
    import vtuio
    cfg = dict(displacement="u", stress="stress", layout=layout, write_layout=True, encoding=ENC.get(c["n"], "zlib"),
               tags=tags, delta=1e-10, command=f"reference/manufactured/make.py --only {name}",
               extra_point_data={"u_exact": Uex, "stress_exact": vtuio.stress_layout(Sex, layout)})
    sc = scene(ex, {"displacement": "u", "stress": "stress", "stress_layout": layout}, tags)
    sce = scene(ex, {"displacement": "u_exact", "stress": "stress_exact", "stress_layout": layout}, tags)
    exp = runner.write_fixture(outdir, name, nodes, d.cells, d.lines, tm.btag, U, S4, sc, cfg, info, None, readme="",
                               slip_rel_tol=SLIP_TOL)
    fdir = Path(outdir) / name
    text = runner.scene_toml(sce, f"{name}: scene selecting the exact fields (nodal interpolants) of solution.vtu.\n"
                             f"Generated by {cfg['command']} -- do not edit by hand.")
    (fdir / "scene_exact.toml").write_text(text)
    import tomllib
    sce_rt = tomllib.loads(text)
    cfg_e = dict(cfg, displacement="u_exact", stress="stress_exact")
    interp = runner.expected_from_file(fdir / "solution.vtu", sce_rt, cfg_e, SLIP_TOL)
    exp["interpolant"] = runner._clean({k: interp[k] for k in ("energy", "boundaries", "traction_free_unselected") if k in interp})
    exp["exact"] = ex.contact_exact()
    exp["errors"] = dict(fe=errors(fdir / "solution.vtu", tomllib.loads((fdir / "scene.toml").read_text()), ex),
                         interpolant=errors(fdir / "solution.vtu", sce_rt, ex))
    exp["manufactured"] = dict(E=EX.E, nu=EX.NU, x0=EX.X0, x1=EX.X1, n=c["n"], h=1.0 / c["n"], friction=ex.F)
    (fdir / "expected.json").write_text(json.dumps(runner._clean(exp), indent=1) + "\n")
    (fdir / "README.md").write_text(readme(name, c, exp))
    return exp


def readme(name, c, exp):
    fr = c["friction"]
    con = exp["boundaries"]["bottom"]
    er = exp["errors"]
    enc = {"ascii": "meshio ascii", "raw": "meshio inline binary, uncompressed", "zlib": "meshio inline binary + zlib"}[ENC.get(c["n"], "zlib")]
    return f"""# {name}

Manufactured smooth contact problem on the unit square (reference/manufactured/exact.py), E = 1000,
nu = 0.3, plane strain, {'Coulomb friction ' + str(fr) if fr else 'frictionless'}. Gamma_C = bottom (normal = body, gap given as an
expression): active for 0 <= x < {EX.X0:g} (pressure p = P0 ({EX.X0:g} - x)^3), inactive for {EX.X0:g} < x <= 1""" + (
        f", stick for x < {EX.X1:g}, slip for {EX.X1:g} < x < {EX.X0:g}" if fr else "") + f""".
Top: Dirichlet (exact u); left/right: Neumann (exact traction); body force f = -div sigma; all data are
expressions in scene.toml.  Mesh: {c['n']} x {c['n']} squares cut along the diagonal, P{c['degree']}.

Produced by

    reference/.venv/bin/python reference/manufactured/make.py --only {name}

- file ({enc}): point data `u` (FE solution, scikit-fem, primal-dual active set on the nodal constraints
  -u_y <= g), `stress` (L2 projection of C eps(u_h) onto continuous P{c['degree']}), `u_exact`, `stress_exact`
  (nodal interpolants of the exact fields); stress layout xx, yy, xy
- boundaries: {'line cells with `boundary_tag` (1 bottom, 2 top, 3 left, 4 right; 0 on triangles)' if c['n'] != 8 else '`where` selectors (line cells present, no tag array)'}
- scene.toml selects `u`/`stress`, scene_exact.toml selects `u_exact`/`stress_exact`

Errors of the FE solution against the exact one: ||u - u_h||_L2 = {er['fe']['u_L2']:.4e}, energy norm
{er['fe']['energy']:.4e}; contact force {con['normal_force']:.6g} (exact {exp['exact']['normal_force']:.6g}).
expected.json: top-level blocks from the FE fields; `interpolant` from the exact fields; `exact` the
analytic contact quantities; `errors` as defined in reference/manufactured/make.py:errors().
"""


if __name__ == "__main__":
    sys.exit(runner.run(CASES, make_one, sys.argv[1:], "manufactured"))
