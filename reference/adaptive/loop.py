"""Building blocks of the adaptive loop (reference/adaptive/run.py): problems, conforming refinement,
solve with the scikit-fem reference solver, write solution.vtu + scene.toml, run `fosls estimate`,
read the marked cells back, and the energy-norm error against a finer reference solution.

Library code for meshes and solvers: reference/hertz/ (geometry.py, fem_skfem.py, problems.py, vtuio.py,
runner.py).
"""
import json
import math
import os
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
REPO = HERE.parents[1]
sys.path.insert(0, str(REPO / "reference" / "hertz"))

import geometry as G  # noqa: E402
import fem_skfem as S  # noqa: E402
import problems as PR  # noqa: E402
import vtuio  # noqa: E402
import runner  # noqa: E402

E = PR.E
UD = PR.UD


def fosls_binary():
    return os.environ.get("FOSLS", str(REPO / "target" / "release" / "fosls"))


# ------------------------------------------------------------------ problems
@dataclass
class Case:
    geometry: str      # "hertz" | "block"
    friction: float
    nu: float

    @property
    def name(self):
        fr = "coulomb04" if self.friction else "frictionless"
        return f"{self.geometry}_{fr}_nu{'05' if self.nu == 0.5 else '028'}"

    @property
    def mixed(self):
        return self.nu == 0.5

    @property
    def curved_tags(self):
        return (G.TAG_CONTACT, G.TAG_FREE) if self.geometry == "hertz" else ()


def initial_mesh(geometry):
    """Coarse quasi-uniform start meshes (netgen OCC): Hertz half disc with h = 0.2 (90 triangles; the
    geometry vertices at x = 0 and |x| = 0.12 are the only contact-zone nodes), block with h = 0.25
    (70 triangles)."""
    if geometry == "hertz":
        tm = G.half_disc(hc=0.15, hmax=0.2, grading=0.3)
    else:
        tm = G.block(hc=0.25, hb=0.25, hmax=0.25, grading=0.3)
    tm.ngmesh = None
    return tm


def scene(case: Case):
    sc = {"material": {"youngs_modulus": E, "poisson_ratio": case.nu, "model": "plane_strain"},
          "fields": {"displacement": "u", "stress": "stress", "stress_layout": "xx,yy,zz,xy"},
          "boundaries": {"tag_array": "boundary_tag"}}
    top = {"name": "top", "tag": G.TAG_TOP, "kind": "dirichlet", "displacement": [float(UD[0]), float(UD[1])]}
    con = {"name": "contact", "tag": G.TAG_CONTACT, "kind": "contact", "obstacle": PR.PLANE}
    if case.geometry == "hertz":
        con["normal"] = "obstacle"
    if case.friction:
        con["friction"] = float(case.friction)
    free = {"name": "arc_upper" if case.geometry == "hertz" else "sides", "tag": G.TAG_FREE, "kind": "neumann",
            "traction": [0.0, 0.0]}
    sc["boundary"] = [top, con, free]
    if case.nu == 0.5:
        sc["estimate"] = {"norm": "robust"}
    return sc


# ------------------------------------------------------------------ refinement
def _classify(geometry, a, b):
    if geometry == "hertz":
        if a[1] == 1.0 and b[1] == 1.0:
            return G.TAG_TOP
        return G.TAG_CONTACT if max(a[1], b[1]) <= 0.5 + 1e-12 else G.TAG_FREE
    if a[1] == 0.0 and b[1] == 0.0:
        return G.TAG_CONTACT
    if a[1] == 1.0 and b[1] == 1.0:
        return G.TAG_TOP
    return G.TAG_FREE


def refine(tm: G.TriMesh, geometry, marked=None):
    """Conforming refinement with scikit-fem's MeshTri1.refined: marked = boolean/index array of
    triangles (adaptive, red-green-blue closure) or None (uniform red refinement).  New vertices on the
    Hertz arc are projected onto the circle; boundary tags are rebuilt from the geometry."""
    from skfem import MeshTri1
    m = MeshTri1(tm.p.T.copy(), tm.t.T.copy())
    if marked is None:
        m2 = m.refined(1)
    else:
        ix = np.flatnonzero(marked) if np.asarray(marked).dtype == bool else np.asarray(marked)
        m2 = m.refined(ix)
    p = m2.p.T.copy()
    t = m2.t.T.astype(np.int64).copy()
    be = m2.facets[:, m2.boundary_facets()].T.astype(np.int64).copy()
    if geometry == "hertz":
        bn = np.unique(be.ravel())
        nold = tm.p.shape[0]
        new = bn[(bn >= nold) & (p[bn, 1] < 1.0)]   # new vertices on the arc (top edge: y = 1 exactly)
        p[new] = G.project_circle(p[new])
    a = p[t[:, 1]] - p[t[:, 0]]
    b = p[t[:, 2]] - p[t[:, 0]]
    det = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    assert (np.abs(det) > 0).all(), "degenerate triangle after refinement"
    neg = det < 0
    t[neg] = t[neg][:, [0, 2, 1]]
    btag = np.array([_classify(geometry, p[e[0]], p[e[1]]) for e in be], dtype=np.int64)
    return G.TriMesh(p, t, be, btag, None, dict(tm.info))


# ------------------------------------------------------------------ solve
def solve(tm, case: Case, state_from=None):
    """scikit-fem P2 (isoparametric on the arc) / Taylor-Hood P2-P1 (nu = 0.5) with the primal-dual active
    set of reference/hertz/fem_skfem.py.  state_from = (x, state) of a previous solution's contact nodes:
    warm start of the active set (nearest node in x)."""
    t0 = time.time()
    d = S.Discretisation(tm, 2, curved_tags=case.curved_tags, mixed=case.mixed)
    K = S.assemble(d, E, case.nu)
    top = d.boundary_nodes([G.TAG_TOP])
    cn = np.setdiff1d(d.boundary_nodes([G.TAG_CONTACT]), top)
    gap = d.nodes[cn, 1]
    if state_from is None:
        state = np.where(gap + UD[1] < 0, 1 if case.friction > 0 else 2, 0)
    else:
        xs, st = state_from
        order = np.argsort(xs)
        xs, st = xs[order], st[order]
        j = np.clip(np.searchsorted(xs, d.nodes[cn, 0]), 1, len(xs) - 1)
        left = np.abs(d.nodes[cn, 0] - xs[j - 1]) <= np.abs(d.nodes[cn, 0] - xs[j])
        state = np.where(left, st[j - 1], st[j])
    dvals = np.tile(np.asarray(UD, float), (len(top), 1))
    res = S.solve_contact_general(d, K, np.zeros(K.shape[0]), top, dvals, cn, gap, friction=case.friction,
                                  state=state)
    U, S4 = S.nodal_fields(d, E, case.nu, res["u"])
    return dict(dsc=d, u=res["u"], U=U, S4=S4, cn=cn, state=res["state"], lambda_n=res["lambda_n"],
                lambda_t=res["lambda_t"], P=res["P"], iterations=res["iterations"], ndofs=int(K.shape[0]),
                time=time.time() - t0)


def write_solution(folder, tm, sol, case):
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    d = sol["dsc"]
    vtuio.write(folder / "solution.vtu", d.nodes, d.cells, d.lines,
                {"u": np.ascontiguousarray(sol["U"]), "stress": np.ascontiguousarray(sol["S4"])},
                tag_name="boundary_tag", tags=tm.btag, encoding="raw")
    (folder / "scene.toml").write_text(runner.scene_toml(scene(case), f"{case.name}: adaptive loop step"))


def estimate(folder, theta, stress="reconstruct"):
    """fosls estimate --stress <stress> --mark theta --json --output; returns (report, marked, cell eta,
    line contact_state, seconds)."""
    import meshio
    folder = Path(folder)
    cmd = [fosls_binary(), "estimate", str(folder / "solution.vtu"), "--scene", str(folder / "scene.toml"),
           "--json", str(folder / "estimate.json"), "--output", str(folder / "cells.vtu"), "--stress", stress,
           "--mark", repr(float(theta)), "--quiet"]
    t0 = time.time()
    r = subprocess.run(cmd, capture_output=True, text=True)
    dt = time.time() - t0
    if r.returncode not in (0, 1):
        raise RuntimeError(f"fosls failed ({r.returncode}): {' '.join(cmd)}\n{r.stderr}")
    rep = json.loads((folder / "estimate.json").read_text())
    m = meshio.read(folder / "cells.vtu")
    k = [i for i, c in enumerate(m.cells) if c.type.startswith("triangle")][0]
    marked = np.asarray(m.cell_data["marked"][k]).ravel() > 0
    eta = np.asarray(m.cell_data["eta"][k]).ravel()
    return rep, marked, eta, dt


# ------------------------------------------------------------------ errors against a reference solution
def _locate(dc, pts):
    """Cell of the coarse mesh (straight vertex triangulation) containing each point; points outside (between
    a chord and the arc) go to the cell with the nearest centroid."""
    import matplotlib.tri as mtri
    from scipy.spatial import cKDTree
    p, t = dc.tm.p, dc.tm.t
    tri = mtri.Triangulation(p[:, 0], p[:, 1], t)
    cells = tri.get_trifinder()(pts[0], pts[1]).astype(np.int64)
    out = cells < 0
    if out.any():
        cen = p[t].mean(axis=1)
        _, j = cKDTree(cen).query(pts[:, out].T)
        cells[out] = j
    return cells


def _p2_shape(xi, eta):
    """P2 shape functions on the reference triangle, node order v0, v1, v2, m01, m12, m20 (our `cells`):
    values (6, n) and reference gradients (6, 2, n)."""
    l = np.stack([1 - xi - eta, xi, eta])
    dl = np.array([[-1.0, -1.0], [1.0, 0.0], [0.0, 1.0]])[:, :, None]
    N = np.concatenate([l * (2 * l - 1), np.stack([4 * l[0] * l[1], 4 * l[1] * l[2], 4 * l[2] * l[0]])])
    dv = (4 * l - 1)[:, None, :] * dl
    dm = [4 * (l[j][None] * dl[i] + l[i][None] * dl[j]) for i, j in ((0, 1), (1, 2), (2, 0))]
    return N, np.concatenate([dv, np.stack(dm)])


def grad_at(sol, pts, iters=10):
    """Gradient (2, 2, n), [i, j] = d u_i / d x_j, of the coarse isoparametric P2 displacement u_h at global
    points pts (2, n): point location on the vertex triangulation, Newton for the inverse element map."""
    d = sol["dsc"]
    cells = _locate(d, pts)
    Xn = np.ascontiguousarray(d.nodes[d.cells[cells]].transpose(1, 2, 0))   # (6, 2, n)
    Un = np.ascontiguousarray(sol["U"][d.cells[cells]].transpose(1, 2, 0))  # (6, 2, n)
    xi = np.full(pts.shape[1], 1.0 / 3.0)
    eta = xi.copy()

    def jac(dN):  # J[c, d] = d x_c / d xi_d, (2, 2, n)
        return (Xn[:, :, None, :] * dN[:, None, :, :]).sum(axis=0)

    for _ in range(iters):
        N, dN = _p2_shape(xi, eta)
        x = (N[:, None, :] * Xn).sum(axis=0)
        J = jac(dN)
        r = pts - x
        det = J[0, 0] * J[1, 1] - J[0, 1] * J[1, 0]
        dxi = (J[1, 1] * r[0] - J[0, 1] * r[1]) / det
        deta = (-J[1, 0] * r[0] + J[0, 0] * r[1]) / det
        xi, eta = xi + dxi, eta + deta
        if max(np.abs(dxi).max(), np.abs(deta).max()) < 1e-13:
            break
    N, dN = _p2_shape(xi, eta)
    J = jac(dN)
    det = J[0, 0] * J[1, 1] - J[0, 1] * J[1, 0]
    Jinv = np.array([[J[1, 1], -J[0, 1]], [-J[1, 0], J[0, 0]]]) / det
    G = (Un[:, :, None, :] * dN[:, None, :, :]).sum(axis=0)   # d u_c / d xi_d
    return (G[:, :, None, :] * Jinv[None, :, :, :]).sum(axis=1)


def energy_errors(ref, sols, nu):
    """‖u_ref − u_h‖ in the energy norm (C ε(e), ε(e))^½ (ν = 0.5: (2μ‖ε(e)‖²)^½, the incompressible limit),
    integrated with the quadrature of the fine (reference) mesh; also the reference's own norm."""
    lam, mu = S.lame(E, nu)
    fb = ref["dsc"].ub
    X = fb.mapping.F(fb.X)  # (2, nel, nqp)
    pts = X.reshape(2, -1)
    dx = fb.dx.ravel()
    gf = fb.interpolate(ref["u"][:ref["dsc"].nu_dofs]).grad.reshape(2, 2, -1)

    def enorm2(g):
        e = 0.5 * (g + g.transpose(1, 0, 2))
        tr = e[0, 0] + e[1, 1]
        val = 2 * mu * (e ** 2).sum(axis=(0, 1))
        if math.isfinite(lam):
            val = val + lam * tr ** 2
        return float((val * dx).sum())

    out = []
    for s in sols:
        gc = grad_at(s, pts)
        out.append(math.sqrt(enorm2(gf - gc)))
    return out, math.sqrt(enorm2(gf))
