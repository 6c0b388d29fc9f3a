"""Reference P1/P2 bases, quadrature rules (scikit-fem) and the isoparametric map.

Cell map: x(xi) = sum_i phi_i(xi) X_i with the scikit-fem P1/P2 basis on the reference triangle
(0,0),(1,0),(0,1); scikit-fem's P2 local order (v0, v1, v2, m01, m12, m02) is VTK triangle6's.
Physical gradients: grad phi_i = J^{-T} grad_ref phi_i, J = dx/dxi; integrals use |det J|.
"""
import numpy as np
from skfem.element import ElementTriP1, ElementTriP2
from skfem.quadrature import get_quadrature, get_quadrature_line
from skfem.refdom import RefTri

from .errors import InputError

_ELEMS = {1: ElementTriP1(), 2: ElementTriP2()}
# reference edge parametrisation s in [0,1]: xi(s) = XI0 + s * DXI (follows v0->v1->v2->v0)
EDGE_XI0 = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
EDGE_DXI = np.array([[1.0, 0.0], [-1.0, 1.0], [0.0, -1.0]])
# node positions (parameter s) on an edge: end vertices and (P2) mid node
EDGE_NODE_S = {1: np.array([0.0, 1.0]), 2: np.array([0.0, 0.5, 1.0])}


def ref_basis(degree, X):
    """phi (nloc, *shape), dphi (nloc, 2, *shape) at reference points X (2, *shape)."""
    e = _ELEMS[degree]
    nloc = 3 if degree == 1 else 6
    phis, dphis = [], []
    for i in range(nloc):
        p, dp = e.lbasis(X, i)
        phis.append(np.broadcast_to(p, X.shape[1:]))
        dphis.append(np.broadcast_to(dp, X.shape))
    return np.array(phis), np.array(dphis)


def tri_rule(order):
    """Quadrature on the reference triangle exact to `order`: scikit-fem's rules up to 19,
    beyond that a collapsed (Duffy) Gauss-Legendre product built from scikit-fem's line rule."""
    if order <= 19:
        return get_quadrature(RefTri, order)
    xl, wl = get_quadrature_line(order + 1)
    u, v = np.meshgrid(xl[0], xl[0], indexing="ij")
    wu, wv = np.meshgrid(wl, wl, indexing="ij")
    X = np.array([u.ravel(), (v * (1.0 - u)).ravel()])
    W = (wu * wv * (1.0 - u)).ravel()
    return X, W


def gauss(n, a=0.0, b=1.0):
    """n-point Gauss-Legendre rule on [a, b] (scikit-fem's line rule, exact to 2n-1)."""
    x, w = get_quadrature_line(2 * n - 1)
    return a + (b - a) * x[0], (b - a) * w


def cell_geometry(points, cells, degree, X):
    """x (C,Nq,2), J (C,Nq,2,2) with J[a,b] = dx_a/dxi_b, det (C,Nq), phi, dphi."""
    phi, dphi = ref_basis(degree, X)
    P = points[cells]  # (C, nloc, 2)
    x = np.einsum("cia,iq->cqa", P, phi)
    J = np.einsum("cia,ibq->cqab", P, dphi)
    det = J[..., 0, 0] * J[..., 1, 1] - J[..., 0, 1] * J[..., 1, 0]
    return x, J, det, phi, dphi


def cell_orientation(sol):
    """+1 / -1 per cell; error for cells whose Jacobian vanishes or changes sign."""
    X, _ = tri_rule(10)
    X = np.hstack([X, np.array([[0.0, 1.0, 0.0, 0.5, 0.5, 0.0], [0.0, 0.0, 1.0, 0.0, 0.5, 0.5]])])
    out = np.empty(len(sol.cells))
    for c0 in range(0, len(sol.cells), 20000):
        cl = sol.cells[c0:c0 + 20000]
        _, J, det, _, _ = cell_geometry(sol.points, cl, sol.degree, X)
        scale = np.abs(J).reshape(len(cl), -1).max(axis=1) ** 2
        pos = np.all(det > 1e-12 * scale[:, None], axis=1)
        neg = np.all(det < -1e-12 * scale[:, None], axis=1)
        bad = ~(pos | neg)
        if np.any(bad):
            i = c0 + int(np.nonzero(bad)[0][0])
            raise InputError(f"{sol.path}: cell {i} is inverted or degenerate (Jacobian vanishes or changes sign)")
        out[c0:c0 + len(cl)] = np.where(pos, 1.0, -1.0)
    return out


def cell_fields(sol, cells_idx, X):
    """Fields at the quadrature points X of the given cells.

    Returns dict with x (C,Nq,2), det (C,Nq), grad_u (C,Nq,2,2) [k,a] = du_k/dx_a,
    u (C,Nq,2), tau (C,Nq,2,2), div (C,Nq,2) [a] = sum_b dtau_ab/dx_b.
    """
    cl = sol.cells[cells_idx]
    x, J, det, phi, dphi = cell_geometry(sol.points, cl, sol.degree, X)
    Jinv = np.empty_like(J)
    Jinv[..., 0, 0] = J[..., 1, 1] / det
    Jinv[..., 1, 1] = J[..., 0, 0] / det
    Jinv[..., 0, 1] = -J[..., 0, 1] / det
    Jinv[..., 1, 0] = -J[..., 1, 0] / det
    # dphi/dx_a = sum_b dphi/dxi_b * dxi_b/dx_a = sum_b dphi_b Jinv[b, a]
    G = np.einsum("ibq,cqba->ciqa", dphi, Jinv)  # (C, nloc, Nq, 2)
    U = sol.disp[cl]          # (C, nloc, 2)
    S = sol.stress[cl]        # (C, nloc, 2, 2)
    return {
        "x": x,
        "det": det,
        "u": np.einsum("cik,iq->cqk", U, phi),
        "grad_u": np.einsum("cik,ciqa->cqka", U, G),
        "tau": np.einsum("ciab,iq->cqab", S, phi),
        "div": np.einsum("ciab,ciqb->cqa", S, G),
    }


def edge_fields(sol, cells_idx, local, s):
    """Fields on boundary edges (owning cell, local edge) at parameters s (E, Ns).

    Returns x (E,Ns,2), T = dx/ds (E,Ns,2), jac = |T| (E,Ns), n (outward unit normal, E,Ns,2),
    u (E,Ns,2), tau (E,Ns,2,2).
    """
    s = np.asarray(s, dtype=float)
    xi = EDGE_XI0[local][:, :, None] + EDGE_DXI[local][:, :, None] * s[:, None, :]  # (E,2,Ns)
    X = np.moveaxis(xi, 1, 0)  # (2, E, Ns)
    phi, dphi = ref_basis(sol.degree, X)  # (nloc,E,Ns), (nloc,2,E,Ns)
    cl = sol.cells[cells_idx]
    P = sol.points[cl]  # (E,nloc,2)
    dphids = np.einsum("ibes,eb->ies", dphi, EDGE_DXI[local])
    x = np.einsum("eia,ies->esa", P, phi)
    T = np.einsum("eia,ies->esa", P, dphids)
    jac = np.hypot(T[..., 0], T[..., 1])
    o = sol.orient[cells_idx][:, None]
    # interior is on the left of the positively oriented boundary: outward = rotate T by -90 deg
    n = np.stack([o * T[..., 1], -o * T[..., 0]], axis=-1) / jac[..., None]
    return {
        "x": x,
        "T": T,
        "jac": jac,
        "n": n,
        "u": np.einsum("eik,ies->esk", sol.disp[cl], phi),
        "tau": np.einsum("eiab,ies->esab", sol.stress[cl], phi),
    }
