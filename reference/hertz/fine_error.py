#!/usr/bin/env python3
"""True energy error of the committed scikit-fem Hertz fixtures against a fine reference solution.

    reference/.venv/bin/python reference/hertz/fine_error.py                  # hertz_skfem_p2, hertz_skfem_p1
    reference/.venv/bin/python reference/hertz/fine_error.py --levels 2 4 8   # refinement factors (last = reference)

The reference is the harness's own scikit-fem P2 (isoparametric, curved) active-set solution of the same
problem (problems.solve_skfem, same E, nu, u_D, tags, curved tags 1 and 3) on netgen meshes of the same
OCC half disc with hc and hmax of make.py's MESH_A divided by k (k = 2, 4, 8; reference = k = 8: h/8), netgen
grading 0.15 instead of 0.3 (as table.py uses for its finer meshes; with 0.3 the interior around the contact
zone is under-resolved and the reference converges slowly) and an extra RestrictH of size 0.004/k at the two
top corners (clamped top meets free arc).  For every fixture

    e = ( 1/2 (C eps(u_ref - u_h), eps(u_ref - u_h)) )^(1/2)

is integrated with the fine mesh's quadrature (each fine cell optionally subdivided in reference space to
reduce the error of integrating the coarse field's gradient jumps); u_h is evaluated at the fine quadrature
points by point location in the coarse mesh (KD-tree candidates, Newton inversion of the isoparametric
map).  Fine points outside the coarse mesh (curved boundary mismatch) are skipped; their area fraction is
reported, and a second value evaluates u_h there by polynomial extension of the nearest coarse cell.
The reference's own error is estimated by the same error of the coarser levels against the finest.
Cross-check: sqrt(E(u_h) - E(u_ref)) (energy difference; equals e for linear problems with nested spaces).
Defaults: ~75 s on 2 cores (k = 8 solve: 121k dofs, 11 active-set steps), a few GB of memory.
"""
import argparse
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
ROOT = HERE.parent.parent
sys.path.insert(0, str(ROOT / "reference" / "quads"))  # qshape: quadrilateral shape functions

import numpy as np  # noqa: E402
import meshio  # noqa: E402
from scipy.spatial import cKDTree  # noqa: E402
from skfem import Basis, ElementVector  # noqa: E402

import geometry as G  # noqa: E402
import problems as PR  # noqa: E402
import fem_skfem as S  # noqa: E402
import qshape  # noqa: E402

MESH_A = dict(hc=0.004, hmax=0.1, grading=0.3)  # make.py: committed frictionless cases
NU = 0.28
LAM, MU = S.lame(PR.E, NU)


# ------------------------------------------------------------------ shape functions on the reference triangle
def shape(xi, eta, quad):
    """N (..., n), dN/dxi, dN/deta.  Node order: v0 (0,0), v1 (1,0), v2 (0,1) [, m01, m12, m20] (VTK / make.py)."""
    l0, l1, l2 = 1 - xi - eta, xi, eta
    if not quad:
        N = np.stack([l0, l1, l2], -1)
        one = np.ones_like(xi)
        return N, np.stack([-one, one, 0 * one], -1), np.stack([-one, 0 * one, one], -1)
    N = np.stack([l0 * (2 * l0 - 1), l1 * (2 * l1 - 1), l2 * (2 * l2 - 1), 4 * l0 * l1, 4 * l1 * l2, 4 * l2 * l0], -1)
    # d/dxi: dl0 = -1, dl1 = 1, dl2 = 0 ; d/deta: dl0 = -1, dl1 = 0, dl2 = 1
    dx = np.stack([-(4 * l0 - 1), 4 * l1 - 1, 0 * xi, 4 * (l0 - l1), 4 * l2, -4 * l2], -1)
    de = np.stack([-(4 * l0 - 1), 0 * xi, 4 * l2 - 1, -4 * l1, 4 * l1, 4 * (l0 - l2)], -1)
    return N, dx, de


class Field:
    """Continuous P1 / isoparametric P2 field: nodes X (N,2), cells (M,3|6), values U (N,2)."""

    def __init__(self, X, cells, U, name=""):
        self.X, self.cells, self.U, self.name = np.asarray(X, float), np.asarray(cells, np.int64), np.asarray(U, float)[:, :2], name
        self.quad = self.cells.shape[1] == 6
        self.tree = cKDTree(self.X[self.cells[:, :3]].mean(axis=1))

    def _newton(self, cid, x):
        """reference coordinates of the points x (n,2) in the cells cid (n,)."""
        Xc = self.X[self.cells[cid]]  # (n, k, 2)
        v0, v1, v2 = Xc[:, 0], Xc[:, 1], Xc[:, 2]
        A = np.stack([v1 - v0, v2 - v0], -1)  # (n,2,2)
        r = np.linalg.solve(A, (x - v0)[..., None])[..., 0]
        if self.quad:
            for _ in range(12):
                N, dx, de = shape(r[:, 0], r[:, 1], True)
                F = np.einsum("nk,nkd->nd", N, Xc) - x
                J = np.stack([np.einsum("nk,nkd->nd", dx, Xc), np.einsum("nk,nkd->nd", de, Xc)], -1)
                step = np.linalg.solve(J, F[..., None])[..., 0]
                r = r - step
                if np.abs(step).max() < 1e-14:
                    break
        return r

    def _outside(self, r):
        """how far the reference points r (n,2) lie outside the reference triangle (0 inside)."""
        return np.maximum.reduce([-r[:, 0], -r[:, 1], r[:, 0] + r[:, 1] - 1, np.zeros(len(r))])

    def locate(self, x, k=12, tol=1e-10):
        """-> cell id (-1 outside), reference coords, and for outside points the nearest-candidate cell."""
        n = len(x)
        cid = -np.ones(n, np.int64)
        ref = np.zeros((n, 2))
        best = -np.ones(n, np.int64)
        bestref = np.zeros((n, 2))
        bestout = np.full(n, np.inf)
        todo = np.arange(n)
        for kk in (k, 60):
            if len(todo) == 0:
                break
            _, cand = self.tree.query(x[todo], k=min(kk, len(self.cells)))
            for j in range(cand.shape[1]):
                sel = todo[cid[todo] < 0]
                if len(sel) == 0:
                    break
                c = cand[np.searchsorted(todo, sel), j]
                r = self._newton(c, x[sel])
                out = self._outside(r)
                ok = out <= tol
                cid[sel[ok]] = c[ok]
                ref[sel[ok]] = r[ok]
                imp = out < bestout[sel]
                bestout[sel[imp]] = out[imp]
                best[sel[imp]] = c[imp]
                bestref[sel[imp]] = r[imp]
            todo = todo[cid[todo] < 0]
        return cid, ref, best, bestref

    def grad(self, cid, ref):
        """displacement gradient (n,2,2) [i, j] = d u_i / d x_j at the reference points of the cells."""
        Xc = self.X[self.cells[cid]]
        Uc = self.U[self.cells[cid]]
        _, dx, de = shape(ref[:, 0], ref[:, 1], self.quad)
        J = np.stack([np.einsum("nk,nkd->nd", dx, Xc), np.einsum("nk,nkd->nd", de, Xc)], -1)  # dX_d/dxi_a
        G_ref = np.stack([np.einsum("nk,nki->ni", dx, Uc), np.einsum("nk,nki->ni", de, Uc)], -1)  # du_i/dxi_a
        return G_ref @ np.linalg.inv(J)

    def energy(self, order=8):
        """1/2 (C eps(u_h), eps(u_h)) with Duffy order x order Gauss per cell (isoparametric)."""
        g, w = np.polynomial.legendre.leggauss(order)
        g, w = 0.5 * (g + 1), 0.5 * w
        s, t = np.meshgrid(g, g, indexing="ij")
        xi, eta = (s * (1 - t)).ravel(), t.ravel()
        wq = (np.outer(w, w) * (1 - t)).ravel()
        M = len(self.cells)
        cid = np.repeat(np.arange(M), len(xi))
        ref = np.tile(np.stack([xi, eta], -1), (M, 1))
        Xc = self.X[self.cells[cid]]
        _, dx, de = shape(ref[:, 0], ref[:, 1], self.quad)
        J = np.stack([np.einsum("nk,nkd->nd", dx, Xc), np.einsum("nk,nkd->nd", de, Xc)], -1)
        dV = np.abs(np.linalg.det(J)) * np.tile(wq, M)
        return float((density(self.grad(cid, ref)) * dV).sum())


class QuadField(Field):
    """Continuous isoparametric Q1 / Q2 (quad9) / serendipity (quad8) field in VTK node order on the
    reference square [0, 1]^2 (reference/quads/qshape.py): Field's location with the square's
    inside test, Newton's method from the cell centre for the inverse map, gradient and energy
    through qshape."""

    def __init__(self, X, cells, U, ctype, name=""):
        self.X, self.cells, self.U, self.name = np.asarray(X, float), np.asarray(cells, np.int64), np.asarray(U, float)[:, :2], name
        self.ctype = ctype
        self.quad = ctype != "quad"
        self.tree = cKDTree(self.X[self.cells[:, :4]].mean(axis=1))

    def _jacobian(self, Xc, ref):
        N, dN = qshape.shape(self.ctype, ref[:, 0], ref[:, 1])
        J = np.stack([np.einsum("nk,nkd->nd", dN[:, 0], Xc), np.einsum("nk,nkd->nd", dN[:, 1], Xc)], -1)
        return N, dN, J

    def _newton(self, cid, x):
        Xc = self.X[self.cells[cid]]
        r = np.full((len(cid), 2), 0.5)
        with np.errstate(all="ignore"):
            for _ in range(30):
                N, _, J = self._jacobian(Xc, r)
                F = np.einsum("nk,nkd->nd", N, Xc) - x
                ok = np.isfinite(J).all(axis=(1, 2)) & (np.abs(np.linalg.det(np.where(np.isfinite(J), J, 1.0))) > 0)
                step = np.zeros_like(r)
                step[ok] = np.linalg.solve(J[ok], F[ok][..., None])[..., 0]
                # far outside its cell a point may run away: keep it bounded (it is then not located there)
                r = np.clip(r - step, -10.0, 11.0)
                if np.abs(step).max() < 1e-14:
                    break
        return r

    def _outside(self, r):
        """how far the reference points r (n,2) lie outside the reference square [0, 1]^2 (0 inside)."""
        return np.maximum.reduce([-r[:, 0], -r[:, 1], r[:, 0] - 1, r[:, 1] - 1, np.zeros(len(r))])

    def grad(self, cid, ref):
        Xc = self.X[self.cells[cid]]
        Uc = self.U[self.cells[cid]]
        _, dN, J = self._jacobian(Xc, ref)
        G_ref = np.stack([np.einsum("nk,nki->ni", dN[:, 0], Uc), np.einsum("nk,nki->ni", dN[:, 1], Uc)], -1)
        return G_ref @ np.linalg.inv(J)

    def energy(self, order=8):
        xi, eta, wq = qshape.rule(self.ctype, order)
        M = len(self.cells)
        cid = np.repeat(np.arange(M), len(xi))
        ref = np.tile(np.stack([xi, eta], -1), (M, 1))
        _, _, J = self._jacobian(self.X[self.cells[cid]], ref)
        dV = np.abs(np.linalg.det(J)) * np.tile(wq, M)
        return float((density(self.grad(cid, ref)) * dV).sum())


def density(Gu):
    e = 0.5 * (Gu + np.swapaxes(Gu, -1, -2))
    tr = e[:, 0, 0] + e[:, 1, 1]
    return 0.5 * (2 * MU * np.einsum("nij,nij->n", e, e) + LAM * tr ** 2)


def read_fixture(name):
    d = ROOT / "fixtures" / name
    import tomllib
    sc = tomllib.loads((d / "scene.toml").read_text())
    mat = sc["material"]
    assert mat["youngs_modulus"] == PR.E and mat["poisson_ratio"] == NU and mat["model"] == "plane_strain"
    m = meshio.read(d / "solution.vtu")
    U = np.asarray(m.point_data[sc["fields"]["displacement"]], float)[:, :2]
    quads = [c for c in m.cells if c.type in ("quad", "quad8", "quad9")]
    if quads:
        assert len(quads) == 1 and not any(c.type in ("triangle", "triangle6") for c in m.cells)
        return QuadField(m.points[:, :2], quads[0].data, U, quads[0].type, name)
    cells = [c.data for c in m.cells if c.type in ("triangle", "triangle6")]
    assert len(cells) == 1
    return Field(m.points[:, :2], cells[0], U, name)


# ------------------------------------------------------------------ fine reference solutions
def half_disc_corners(hc, hmax, grading, hcorner, xz=0.12):
    """geometry.half_disc (same OCC geometry, names, tags, RestrictH along the contact zone) plus RestrictH
    with size hcorner at the two top corners (+-1, 1), where the clamped top meets the free arc (corner
    singularity that otherwise dominates the reference's own error)."""
    from netgen.occ import Pnt, Segment, ArcOfCircle, Wire, Face, OCCGeometry
    import netgen.meshing as nm
    tz = float(np.arcsin(xz))
    P = lambda s: Pnt(float(np.sin(s)), float(1.0 - np.cos(s)), 0.0)
    angles = [np.pi / 2, np.pi / 3, tz, 0.0, -tz, -np.pi / 3, -np.pi / 2]
    edges = [Segment(Pnt(-1.0, 1.0, 0.0), Pnt(1.0, 1.0, 0.0))]
    for k in range(6):
        a, b = angles[k], angles[k + 1]
        edges.append(ArcOfCircle(P(a), P(0.5 * (a + b)), P(b)))
    face = Face(Wire(edges))
    geo = OCCGeometry(face, dim=2)
    mp = nm.MeshingParameters(maxh=hmax, grading=grading)
    for s in np.linspace(-tz, tz, int(np.ceil(tz / hc)) + 1):
        mp.RestrictH(x=float(np.sin(s)), y=float(1.0 - np.cos(s)), z=0.0, h=hc)
    if hcorner:
        for xc in (-1.0, 1.0):
            mp.RestrictH(x=xc, y=1.0, z=0.0, h=hcorner)
    ngm = geo.GenerateMesh(mp=mp)

    def classify(a, b):
        if a[1] == 1.0 and b[1] == 1.0:
            return G.TAG_TOP
        return G.TAG_CONTACT if max(a[1], b[1]) <= 0.5 + 1e-12 else G.TAG_FREE

    p, t, be, btag = G._from_netgen(ngm, classify)
    return G.TriMesh(p, t, be, btag, ngm, dict(kind="half_disc", hc=hc, xz=xz, hmax=hmax, grading=grading,
                                                 hcorner=hcorner))


def solve_level(k, intorder, subdiv, hcorner=None, grading=MESH_A["grading"]):
    t0 = time.time()
    if hcorner:
        tm = half_disc_corners(MESH_A["hc"] / k, MESH_A["hmax"] / k, grading, hcorner / k)
    else:
        tm = G.half_disc(hc=MESH_A["hc"] / k, hmax=MESH_A["hmax"] / k, grading=grading)
    sol = PR.solve_skfem(tm, 2, NU, curved_tags=(1, 3))
    d = sol["dsc"]
    u = sol["raw"]["u"]
    fld = Field(d.nodes, d.cells, sol["U"], f"fine k={k}")
    # quadrature points of the fine mesh: skfem basis with intorder; optional subdivision of every
    # cell into subdiv^2 sub-triangles in reference space (points mapped by the isoparametric map)
    qp, qw = sub_quadrature(intorder, subdiv)
    M = len(d.cells)
    cid = np.repeat(np.arange(M), len(qw))
    ref = np.tile(qp, (M, 1))
    Xc = fld.X[fld.cells[cid]]
    N, dx, de = shape(ref[:, 0], ref[:, 1], True)
    x = np.einsum("nk,nkd->nd", N, Xc)
    J = np.stack([np.einsum("nk,nkd->nd", dx, Xc), np.einsum("nk,nkd->nd", de, Xc)], -1)
    dV = np.abs(np.linalg.det(J)) * np.tile(qw, M)
    Gf = fld.grad(cid, ref)
    # consistency: same energy through skfem's own basis
    ub = Basis(d.mesh, ElementVector(d.elem), intorder=4)
    uh = ub.interpolate(u[:d.nu_dofs])
    from skfem.helpers import sym_grad
    e = sym_grad(uh)
    tr = e[0, 0] + e[1, 1]
    en_skfem = float((0.5 * (2 * MU * (e[0, 0] ** 2 + e[1, 1] ** 2 + 2 * e[0, 1] ** 2) + LAM * tr ** 2) * ub.dx).sum())
    return dict(k=k, cells=M, dofs=sol["info"]["dofs"], its=sol["info"]["iterations"], P=sol["info"]["reaction_top"]["P"],
                field=fld, x=x, dV=dV, G=Gf, energy=float((density(Gf) * dV).sum()), energy_skfem=en_skfem,
                time=time.time() - t0)


def sub_quadrature(order, subdiv):
    """Duffy order x order Gauss rule on the reference triangle, on each of subdiv^2 sub-triangles."""
    g, w = np.polynomial.legendre.leggauss(order)
    g, w = 0.5 * (g + 1), 0.5 * w
    s, t = np.meshgrid(g, g, indexing="ij")
    xi, eta = (s * (1 - t)).ravel(), t.ravel()
    wq = (np.outer(w, w) * (1 - t)).ravel()
    P, W = [], []
    h = 1.0 / subdiv
    for i in range(subdiv):
        for j in range(subdiv - i):
            # upright sub-triangle (i,j),(i+1,j),(i,j+1)
            P.append(np.stack([(i + xi) * h, (j + eta) * h], -1)); W.append(wq * h * h)
            if i + j < subdiv - 1:  # inverted: (i+1,j+1),(i,j+1),(i+1,j)
                P.append(np.stack([(i + 1 - xi) * h, (j + 1 - eta) * h], -1)); W.append(wq * h * h)
    return np.concatenate(P), np.concatenate(W)


def error(coarse: Field, ref):
    """energy error of coarse against the fine level ref; skipped points and extension variant."""
    cid, r, best, bestr = coarse.locate(ref["x"])
    inside = cid >= 0
    Gc = np.zeros_like(ref["G"])
    Gc[inside] = coarse.grad(cid[inside], r[inside])
    dens = density(ref["G"] - Gc)
    dV = ref["dV"]
    e_skip = np.sqrt((dens * dV)[inside].sum())
    out = ~inside
    Gc2 = Gc.copy()
    if out.any():
        Gc2[out] = coarse.grad(best[out], bestr[out])
    dens2 = density(ref["G"] - Gc2)
    e_ext = np.sqrt((dens2 * dV).sum())
    return dict(e=float(e_skip), e_ext=float(e_ext), skipped_area=float(dV[out].sum() / dV.sum()),
                skipped_points=int(out.sum()), points=int(len(out)),
                ref_energy_skipped=float((density(ref["G"]) * dV)[out].sum() / ref["energy"]))


def main(argv):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--levels", type=int, nargs="+", default=[2, 4, 8], help="refinement factors of hc, hmax (last = reference)")
    ap.add_argument("--order", type=int, default=5, help="Duffy Gauss points per direction on every (sub)cell")
    ap.add_argument("--subdiv", type=int, default=1, help="reference-space subdivision of every fine cell")
    ap.add_argument("--grading", type=float, default=0.15, help="netgen grading of the fine meshes")
    ap.add_argument("--corner", type=float, default=0.004,
                    help="mesh size at the top corners (+-1, 1) at k = 1, divided by k (0: geometry.half_disc as is)")
    ap.add_argument("--check-quadrature", action="store_true", help="also integrate with subdiv 1 and 2*subdiv")
    ap.add_argument("--json", metavar="PATH",
                    help="also write the fixtures' errors and the reference's own error there (JSON)")
    ap.add_argument("fixtures", nargs="*", default=["hertz_skfem_p2", "hertz_skfem_p1"])
    a = ap.parse_args(argv)
    T0 = time.time()
    levels = sorted(a.levels)
    sols = {}
    for k in levels:
        s = solve_level(k, a.order, a.subdiv, a.corner, a.grading)
        sols[k] = s
        print(f"fine level k={k}: hc={MESH_A['hc'] / k:g} hmax={MESH_A['hmax'] / k:g} grading={a.grading} "
              f"corner h={a.corner / k:g}: "
              f"{s['cells']} cells, {s['dofs']} dofs, {s['its']} active-set steps, P={s['P']:.6f}, "
              f"energy={s['energy']:.10f} (skfem basis {s['energy_skfem']:.10f}), {len(s['dV'])} quadrature points, "
              f"{s['time']:.1f} s", flush=True)
    ref = sols[levels[-1]]
    print(f"\nreference: k={levels[-1]}; quadrature: Duffy {a.order}x{a.order} on {a.subdiv}^2 sub-triangles per fine cell\n")
    print("reference self-check (coarser fine levels against the reference):")
    self_err = {}
    for k in levels[:-1]:
        r = error(sols[k]["field"], ref)
        self_err[k] = r["e"]
        dE = sols[k]["energy"] - ref["energy"]
        print(f"  k={k} vs k={levels[-1]}: e = {r['e']:.6e} (extension {r['e_ext']:.6e}; sqrt(E_k - E_ref) = "
              f"{np.sqrt(max(dE, 0)):.3e}), "
              f"skipped area {r['skipped_area']:.2e} ({r['skipped_points']} pts)", flush=True)
    if len(levels) >= 3:
        k1, k2 = levels[-3], levels[-2]
        # e(k) ~ C k^-p measured against the finest level L: e_m(k) ~ e(k) - e(L) (crude); take the ratio of
        # the measured values for an order estimate, then e(L) ~ e(k2) (k2/L)^p
        p = np.log(self_err[k1] / self_err[k2]) / np.log(k2 / k1)
        est = self_err[k2] * (k2 / levels[-1]) ** p
        print(f"  observed rate p = {p:.2f} (in k); estimated own error of the reference ~ {est:.3e}"
              f" (conservative bound: e(k={k2} vs ref) = {self_err[k2]:.3e})")
        E1, E2, E3 = (sols[k]["energy"] for k in levels[-3:])
        if (E1 - E2) > (E2 - E3) > 0:
            Einf = E3 - (E2 - E3) ** 2 / ((E1 - E2) - (E2 - E3))  # Aitken
            print(f"  energies E(k) = {E1:.10f}, {E2:.10f}, {E3:.10f}; Aitken limit {Einf:.10f}: "
                  f"sqrt(E_ref - E_inf) = {np.sqrt(E3 - Einf):.3e} (energy-based estimate of the reference's own error)")
    else:
        est = None
    record = {
        "what": "true energy error (1/2 (C eps(u - u_h), eps(u - u_h)))^(1/2) of each fixture's u_h "
                "against the fine scikit-fem reference (reference/hertz/fine_error.py)",
        "levels": levels,
        "reference_error_estimate": est,
        "reference_error_bound": self_err[levels[-2]] if len(levels) >= 2 else None,
        "fixtures": {},
    }
    for name in a.fixtures:
        t0 = time.time()
        c = read_fixture(name)
        En = c.energy()
        r = error(c, ref)
        kind = getattr(c, "ctype", None) or ("P2 isoparametric" if c.quad else "P1")
        line = (f"\n{name}: {kind}, {len(c.cells)} cells, {len(c.X)} points\n"
                f"  energy 1/2(C eps(u_h), eps(u_h)) = {En:.10f}   (reference energy {ref['energy']:.10f})\n"
                f"  energy error e = {r['e']:.6e}   relative e/sqrt(E_ref) = {r['e'] / np.sqrt(ref['energy']):.4%}\n"
                f"  cross-check sqrt(E(u_h) - E(u_ref)) = {np.sqrt(max(En - ref['energy'], 0)):.6e}"
                f" (Pythagoras; exact for linear problems with nested spaces)\n"
                f"  with u_h extended polynomially into the skipped points: e = {r['e_ext']:.6e}\n"
                f"  skipped fine points outside the coarse mesh: {r['skipped_points']} of {r['points']}, area fraction "
                f"{r['skipped_area']:.3e}, reference energy fraction there {r['ref_energy_skipped']:.3e}\n"
                + (f"  reference's own error: ~{est:.3e} (estimate), <= {self_err[levels[-2]]:.3e} (k={levels[-2]} vs ref)"
                   f" -> {self_err[levels[-2]] / r['e']:.2%} of e at most\n" if est is not None else ""))
        if a.check_quadrature:
            for sd in sorted({1, 2 * a.subdiv}):
                qp, qw = sub_quadrature(a.order, sd)
                rr = dict(ref)
                fld = ref["field"]
                M = len(fld.cells)
                cid = np.repeat(np.arange(M), len(qw))
                rp = np.tile(qp, (M, 1))
                Xc = fld.X[fld.cells[cid]]
                N, dx, de = shape(rp[:, 0], rp[:, 1], True)
                rr["x"] = np.einsum("nk,nkd->nd", N, Xc)
                J = np.stack([np.einsum("nk,nkd->nd", dx, Xc), np.einsum("nk,nkd->nd", de, Xc)], -1)
                rr["dV"] = np.abs(np.linalg.det(J)) * np.tile(qw, M)
                rr["G"] = fld.grad(cid, rp)
                q = error(c, rr)
                line += f"  quadrature check, subdiv {sd}: e = {q['e']:.6e}\n"
        line += f"  time {time.time() - t0:.1f} s"
        print(line, flush=True)
        record["fixtures"][name] = {"energy_error": r["e"], "energy_error_extended": r["e_ext"],
                                    "skipped_area": r["skipped_area"]}
    if a.json:
        import json
        with open(a.json, "w") as fh:
            json.dump(record, fh, indent=1)
            fh.write("\n")
    print(f"\ntotal time {time.time() - T0:.1f} s")


if __name__ == "__main__":
    main(sys.argv[1:])
