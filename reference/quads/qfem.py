"""scikit-fem on quadrilaterals: Q1 (ElementQuad1), isoparametric Q2 (MeshQuad2 + ElementQuad2) and
isoparametric serendipity S2 (an 8-node mesh class MeshQuadS2 whose geometry element is ElementQuadS2,
+ ElementQuadS2), curved arc edges allowed.  Elasticity, the primal-dual active set of
reference/hertz/fem_skfem.py (solve_contact / solve_contact_general, reused as is), and the L2
projection of C eps(u_h) onto the continuous displacement space (componentwise).

Output nodes are the scalar basis' global dofs (vertices, then edges, then cell centres); the local
dof order of ElementQuad1/S2/Quad2 (corners, edges 01 12 23 30, centre) is the VTK order of types
9 / 23 / 28, so the connectivity is basis.element_dofs transposed (checked against the dof locations).
"""
from dataclasses import dataclass, field, replace
from typing import Type

import numpy as np
import scipy.sparse.linalg as spl
from numpy import ndarray
from skfem import (Basis, BilinearForm, Element, ElementQuad1, ElementQuad2, ElementQuadS2, ElementVector,
                   LinearForm, MeshQuad1, MeshQuad2, asm)
from skfem.helpers import ddot, sym_grad, trace
from skfem.mesh.mesh_2d_2 import Mesh2D2

import qmeshes as QM


@dataclass(repr=False)
class MeshQuadS2(Mesh2D2, MeshQuad1):
    """An 8-node (serendipity) isoparametric quadrilateral mesh: vertices, then one node per edge."""

    doflocs: ndarray = field(default_factory=lambda: np.array(
        [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0], [0.5, 0.0], [0.0, 0.5], [1.0, 0.5], [0.5, 1.0]]).T)
    elem: Type[Element] = ElementQuadS2

    @property
    def bndelem(self):  # the trace on an edge: quadratic through the 2 vertices and the edge node (as MeshQuad2)
        from skfem.element import ElementLineP2
        return ElementLineP2()


KINDS = {"q1": (ElementQuad1, None, "quad"), "q2": (ElementQuad2, MeshQuad2, "quad9"),
         "s2": (ElementQuadS2, MeshQuadS2, "quad8")}


def lame(E, nu):
    mu = E / (2 * (1 + nu))
    return E * nu / ((1 + nu) * (1 - 2 * nu)), mu


class QuadDisc:
    """Duck-compatible with reference/hertz/fem_skfem.Discretisation for solve_contact_general:
    .nodes, .node_dofs, .ub, .sb, .snode, .nu_dofs, .mixed."""

    def __init__(self, p, quads, lines, tags, kind, curved=None):
        """p (N,2), quads (M,4) CCW, lines (K,2) vertex pairs with tags; kind q1|q2|s2;
        curved: None or callable(points (n,2)) -> points on the curve, applied to the mid-edge nodes of
        the boundary edges whose tag is in curved_tags (set self.curved_tags before)."""
        self.kind = kind
        self.mixed = False
        elem_cls, mesh_cls, self.ctype = KINDS[kind]
        m1 = MeshQuad1(np.ascontiguousarray(p.T, dtype=float), np.ascontiguousarray(quads.T))
        assert np.array_equal(m1.t, quads.T), "skfem kept the connectivity"
        fid = {(int(a), int(b)): k for k, (a, b) in enumerate(m1.facets.T)}
        self.line_facets = np.array([fid[tuple(sorted((int(a), int(b))))] for a, b in lines])
        if mesh_cls is None:
            self.mesh = m1
        else:
            M = mesh_cls.from_mesh(m1)
            d = M.doflocs.copy()
            Nv = m1.p.shape[1]
            if curved is not None:
                sel = self.line_facets[np.isin(tags, curved[0])]
                d[:, Nv + sel] = curved[1](d[:, Nv + sel].T).T
                if kind == "q2":  # centre node: the serendipity-consistent point 1/2 sum(mids) - 1/4 sum(corners)
                    Nf = m1.facets.shape[1]
                    cells = np.unique(np.nonzero(np.isin(m1.t2f, sel))[1])
                    for c in cells:
                        mids = d[:, Nv + m1.t2f[:, c]]
                        cor = d[:, m1.t[:, c]]
                        d[:, Nv + Nf + c] = 0.5 * mids.sum(1) - 0.25 * cor.sum(1)
            self.mesh = replace(M, doflocs=d)
        self.elem = elem_cls()
        self.ub = Basis(self.mesh, ElementVector(self.elem))
        self.sb = Basis(self.mesh, self.elem)
        sb, ub = self.sb, self.ub
        self.nodes = sb.doflocs.T.copy()
        nd = np.zeros((sb.N, 2), dtype=np.int64)
        for part in ("nodal_dofs", "facet_dofs", "interior_dofs"):
            s, v = getattr(sb, part), getattr(ub, part)
            if s.size:
                nd[s[0]] = v.T
        self.node_dofs = nd
        assert np.allclose(ub.doflocs[:, nd[:, 0]], sb.doflocs) and np.allclose(ub.doflocs[:, nd[:, 1]], sb.doflocs)
        self.snode = np.arange(sb.N)
        self.nu_dofs = ub.N
        self.ndofs = ub.N
        self.cells = sb.element_dofs.T.copy().astype(np.int64)
        if kind == "q1":
            self.lines = np.asarray(lines, dtype=np.int64).copy()
        else:
            fd = sb.facet_dofs[0]
            self.lines = np.array([[a, b, fd[f]] for (a, b), f in zip(lines, self.line_facets)], dtype=np.int64)
        self.tags = np.asarray(tags, dtype=np.int64)
        self._check_order()

    def _check_order(self):
        """The connectivity is in VTK order: corners CCW; edge nodes between corners (k, k+1) on straight
        cells (chord mid point), between them in parameter on curved ones (distance check)."""
        X = self.nodes
        C = self.cells
        assert (QM.signed_area(X[C[:, :4]]) > 0).all()
        if C.shape[1] > 4:
            for k, (i, j) in enumerate(QM.QUAD_EDGES):
                chord = X[C[:, j]] - X[C[:, i]]
                m = X[C[:, 4 + k]] - 0.5 * (X[C[:, i]] + X[C[:, j]])
                # mid node near the chord mid point (curved arcs: sagitta << chord)
                assert (np.linalg.norm(m, axis=1) < 0.3 * np.linalg.norm(chord, axis=1)).all()
        for l in self.lines:
            if len(l) == 3:
                assert np.linalg.norm(X[l[2]] - 0.5 * (X[l[0]] + X[l[1]])) < 0.3 * np.linalg.norm(X[l[1]] - X[l[0]])

    def boundary_nodes(self, tags):
        sel = np.isin(self.tags, tags)
        return np.unique(self.lines[sel].ravel())


def assemble(dsc, E, nu):
    lam, mu = lame(E, nu)

    @BilinearForm
    def a(u, v, w):
        e, f = sym_grad(u), sym_grad(v)
        return 2 * mu * ddot(e, f) + lam * trace(e) * trace(f)

    return asm(a, dsc.ub).tocsr()


def projected_stress(dsc, E, nu, u):
    """L2 projection of C eps(u_h) onto the continuous scalar space, componentwise: (N, 4) xx, yy, zz, xy."""
    lam, mu = lame(E, nu)
    uh = dsc.ub.interpolate(u)
    Mm = asm(BilinearForm(lambda a, b, w: a * b), dsc.sb).tocsc()
    lu = spl.splu(Mm)
    out = np.zeros((dsc.sb.N, 4))

    def comp(i):
        def f(v, w):
            e = sym_grad(w["uh"])
            tr = e[0, 0] + e[1, 1]
            return [2 * mu * e[0, 0] + lam * tr, 2 * mu * e[1, 1] + lam * tr, lam * tr, 2 * mu * e[0, 1]][i] * v
        return LinearForm(f)

    for i in range(4):
        out[:, i] = lu.solve(asm(comp(i), dsc.sb, uh=uh))
    return out
