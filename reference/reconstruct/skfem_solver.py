"""Stress reconstruction with scikit-fem: row-wise Raviart-Thomas, nodal normal-trace unknowns
on the constrained boundary edges, primal-dual active set on bounds.

scikit-fem naming: ElementTriRT0 is an alias of ElementTriRT1, the *lowest order* element
(3 DOFs per triangle, normal flux per edge) = RT_0 here; ElementTriRT2 (8 DOFs: 2 per edge,
moments of the normal trace against the two P1 edge hats, + 2 interior) = RT_1 here.
ElementTriRT2 is H(div)-conforming only on meshes whose cells list their vertices in increasing
global order (scikit-fem's MeshTri1 sorts, MeshTri2 does not): the mesh is built sorted here.

Unknowns: x = [row 1 of tau | row 2 of tau], each in the RT_k basis. On every Neumann, free
and contact edge the k+1 edge DOFs of each row are replaced (x = T z) by the point values of
the row's normal trace tau_i . n_Omega at the edge's points (RT_0: the mid point, RT_1: the two
end points); on contact edges the two rows' values at a point are further rotated into
(tau_n, tau_t) = (n . q, t . q), q = (tau_1 . n_Omega, tau_2 . n_Omega). Essential conditions
are then fixed values (tau n = t: point values of t; tau_t = 0) and tau_n <= 0 is a bound.
"""
import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from skfem import (Basis, BilinearForm, ElementTriP1, ElementTriP2, ElementTriRT0, ElementTriRT2,
                   FacetBasis, Functional, LinearForm, MeshTri1, MeshTri2)


def _rt_element(k):
    return {0: ElementTriRT0(), 1: ElementTriRT2()}[k]


def edge_points(k):
    """Reference parameters of the nodal points on an edge."""
    return np.array([0.5]) if k == 0 else np.array([0.0, 1.0])


class SkfemReconstruction:
    def __init__(self, P, k, intorder=None, facet_intorder=None):
        self.P, self.k = P, k
        if intorder is None:
            intorder = 2 * k + 6 if not P.curved else 2 * k + 14
        if facet_intorder is None:
            facet_intorder = 2 * k + 8 if not P.curved else 2 * k + 16
        self.intorder, self.facet_intorder = intorder, facet_intorder
        self._mesh()
        self.rb = Basis(self.mesh, _rt_element(k), intorder=intorder)
        self.Nrt = self.rb.N
        self.ub = self.rb.with_element(self.uelem)
        self.ux = self.ub.interpolate(self.xu[:, 0])
        self.uy = self.ub.interpolate(self.xu[:, 1])

    # ------------------------------------------------------------------ mesh and u_h
    def _mesh(self):
        P = self.P
        pts, cells = P.points, P.cells
        verts = np.unique(cells[:, :3])
        newid = -np.ones(len(pts), dtype=np.int64)
        newid[verts] = np.arange(len(verts))
        t = np.sort(newid[cells[:, :3]], axis=1)
        m1 = MeshTri1(pts[verts].T.copy(), t.T.copy())
        assert np.array_equal(m1.t, t.T)
        fkey = {(int(a), int(b)): f for f, (a, b) in enumerate(m1.facets.T)}
        if P.degree == 2:
            mid = {}
            for c in cells:
                for (i, j), mm in zip(((0, 1), (1, 2), (2, 0)), (3, 4, 5)):
                    a, b = sorted((newid[c[i]], newid[c[j]]))
                    mid[(a, b)] = c[mm]
            fmid = np.array([mid[(int(a), int(b))] for a, b in m1.facets.T])
            doflocs = np.hstack([m1.p, pts[fmid].T])
            self.mesh = MeshTri2(doflocs, m1.t.copy())
            assert np.array_equal(self.mesh.facets, m1.facets)
            self.uelem = ElementTriP2()
            self.xu = np.vstack([P.disp[verts], P.disp[fmid]])
        else:
            self.mesh = m1
            self.uelem = ElementTriP1()
            self.xu = P.disp[verts].copy()
        self.verts, self.newid, self.fkey = verts, newid, fkey
        # scene edges -> facets
        self.edge_facet = np.array([fkey[tuple(sorted((int(newid[e.a]), int(newid[e.b]))))]
                                    for e in P.edges])

    # ------------------------------------------------------------------ helpers
    def _A(self, T):
        tr = T[0, 0] + T[1, 1]
        out = T.copy()
        out[0, 0] = out[0, 0] - self.P.ctr * tr
        out[1, 1] = out[1, 1] - self.P.ctr * tr
        return out / (2.0 * self.P.mu)

    @staticmethod
    def _row(i, vec):
        T = np.zeros((2, 2) + vec.shape[1:])
        T[i] = vec
        return T

    @staticmethod
    def _eps(ux, uy):
        gx, gy = ux.grad, uy.grad
        return np.array([[gx[0], 0.5 * (gx[1] + gy[0])], [0.5 * (gx[1] + gy[0]), gy[1]]])

    # ------------------------------------------------------------------ assembly
    def assemble(self):
        P = self.P
        k1, k2, wd = P.k1, P.k2, P.wd
        blocks = [[None, None], [None, None]]
        for i in range(2):
            for j in range(2):
                def form(u, v, w, i=i, j=j):
                    AT = self._A(self._row(i, u.value))
                    AS = self._A(self._row(j, v.value))
                    val = 2.0 * k1 * np.einsum("ab...,ab...->...", AT, AS) \
                        + 2.0 * k2 * (AT[0, 0] + AT[1, 1]) * (AS[0, 0] + AS[1, 1])
                    if i == j:
                        val = val + wd * u.div * v.div
                    return val
                # skfem: rows = test (v, row j), columns = trial (u, row i)
                blocks[j][i] = BilinearForm(form).assemble(self.rb)
        K = sp.bmat(blocks, format="csr")
        rhs = []
        for j in range(2):
            def lform(v, w, j=j):
                AS = self._A(self._row(j, v.value))
                E = self._eps(w.ux, w.uy)
                f = P.body_force(w.x[0], w.x[1])[..., j]
                return 2.0 * k1 * np.einsum("ab...,ab...->...", E, AS) \
                    + 2.0 * k2 * (E[0, 0] + E[1, 1]) * (AS[0, 0] + AS[1, 1]) - wd * f * v.div
            rhs.append(LinearForm(lform).assemble(self.rb, ux=self.ux, uy=self.uy))
        rhs = np.concatenate(rhs)
        # contact: - <u_n - g, sigma_n>, grouped by [[boundary]]
        for bidx in sorted({e.bnd.index for e in P.edges if e.kind == "contact"}):
            es = [e for e in P.edges if e.kind == "contact" and e.bnd.index == bidx]
            fb = FacetBasis(self.mesh, _rt_element(self.k), facets=self.edge_facet[[e.index for e in es]],
                            intorder=self.facet_intorder)
            fu = fb.with_element(self.uelem)
            e0 = es[0]
            for j in range(2):
                def cform(v, w, j=j):
                    nO = np.moveaxis(w.n, 0, -1)
                    n, t, g = P.frame(e0, w.x[0], w.x[1], nO)
                    un = n[..., 0] * w.ux + n[..., 1] * w.uy
                    sn = n[..., j] * (v.value[0] * w.n[0] + v.value[1] * w.n[1])
                    return -(un - g) * sn
                rhs[j * self.Nrt:(j + 1) * self.Nrt] += LinearForm(cform).assemble(
                    fb, ux=fu.interpolate(self.xu[:, 0]), uy=fu.interpolate(self.xu[:, 1]))
        self.K, self.rhs = K, rhs
        return K, rhs

    # ------------------------------------------------------------------ nodal edge unknowns
    def nodal_transform(self):
        """x = T z; returns T, fixed (slot -> value), bound slots, point table."""
        P, k, N, Nrt = self.P, self.k, 2 * self.Nrt, self.Nrt
        cons = [e for e in P.edges if e.kind in ("neumann", "free", "contact")]
        s = edge_points(k)
        fb = FacetBasis(self.mesh, _rt_element(k), facets=self.edge_facet[[e.index for e in cons]],
                        quadrature=(s[None, :], np.full(len(s), 1.0 / len(s))))
        X = fb.global_coordinates().value            # (2, nf, np)
        nrm = fb.normals                             # (2, nf, np)
        vals = np.array([np.einsum("afp,afp->fp", fb.basis[j][0].value, nrm)
                         for j in range(fb.element_dofs.shape[0])])   # (nloc, nf, np)
        fdofs = self.rb.dofs.facet_dofs              # (k+1, nfacets)
        rows, cols, data = [], [], []
        touched = np.zeros(N, dtype=bool)
        fixed = {}
        bound = []
        points = []
        maxleak = 0.0
        for r, e in enumerate(cons):
            f = self.edge_facet[e.index]
            D = fdofs[:, f]
            loc = [int(np.nonzero(fb.element_dofs[:, r] == d)[0][0]) for d in D]
            others = [j for j in range(vals.shape[0]) if j not in loc]
            maxleak = max(maxleak, float(np.abs(vals[others, r, :]).max()) if others else 0.0)
            Pm = vals[loc, r, :].T                   # (np, k+1): point values of the k+1 DOFs
            Pinv = np.linalg.inv(Pm)
            x, y = X[0, r], X[1, r]
            nO = nrm[:, r, :].T
            if e.kind in ("neumann", "free"):
                tr = P.traction(e, x, y)             # (np, 2)
                for i in range(2):
                    sl = i * Nrt + D
                    for a in range(len(D)):
                        for b in range(len(D)):
                            rows.append(sl[a]); cols.append(sl[b]); data.append(Pinv[a, b])
                        fixed[int(sl[a])] = float(tr[a, i])
                    touched[sl] = True
            else:
                n, t, g = P.frame(e, x, y, nO)
                s0, s1 = D, Nrt + D
                for p in range(len(D)):
                    for i in range(2):
                        sl = i * Nrt + D
                        for a in range(len(D)):
                            rows.append(sl[a]); cols.append(s0[p]); data.append(Pinv[a, p] * n[p, i])
                            rows.append(sl[a]); cols.append(s1[p]); data.append(Pinv[a, p] * t[p, i])
                    fixed[int(s1[p])] = 0.0
                    bound.append(int(s0[p]))
                    points.append({"edge": e.index, "slot": int(s0[p]), "x": float(x[p]), "y": float(y[p]),
                                   "edge_a": P.points[e.a].tolist(), "edge_b": P.points[e.b].tolist(),
                                   "boundary": e.bnd.name})
                touched[s0] = True
                touched[s1] = True
        idle = np.nonzero(~touched)[0]
        rows += idle.tolist(); cols += idle.tolist(); data += [1.0] * len(idle)
        T = sp.csr_matrix((data, (rows, cols)), shape=(N, N))
        self.T, self.fixed, self.bound, self.points = T, fixed, np.array(bound, dtype=np.int64), points
        self.trace_leak = maxleak
        return T

    # ------------------------------------------------------------------ solve
    def solve(self, constrained=True, max_iter=100):
        K, rhs = self.K, self.rhs
        T = self.T
        Kz = (T.T @ K @ T).tocsr()
        rz = T.T @ rhs
        N = Kz.shape[0]
        fix_idx = np.array(sorted(self.fixed), dtype=np.int64)
        fix_val = np.array([self.fixed[i] for i in fix_idx])
        A = np.zeros(0, dtype=np.int64)
        history = []
        for it in range(max_iter + 1):
            z = np.zeros(N)
            z[fix_idx] = fix_val
            fx = np.concatenate([fix_idx, A])
            isfree = np.ones(N, dtype=bool)
            isfree[fx] = False
            fr = np.nonzero(isfree)[0]
            b = rz[fr] - Kz[fr][:, fx] @ z[fx]
            Kff = Kz[fr][:, fr].tocsc()
            lu = spla.splu(Kff)
            zf = lu.solve(b)
            zf += lu.solve(b - Kff @ zf)            # one step of iterative refinement
            z[fr] = zf
            res = np.abs(Kff @ zf - b).max() / max(np.abs(b).max(), 1e-300)
            lam = rz - Kz @ z                        # multipliers of z_j <= 0 on the bound slots
            history.append({"active": int(len(A)), "solve_residual": float(res)})
            if not constrained:
                break
            inA = np.zeros(N, dtype=bool)
            inA[A] = True
            B = self.bound
            newA = B[(inA[B] & (lam[B] > 0)) | (~inA[B] & (z[B] > 0))]
            newA = np.sort(newA)
            if np.array_equal(newA, A):
                break
            A = newA
        else:
            raise RuntimeError("primal-dual active set did not converge")
        self.z, self.lam, self.A, self.history = z, lam, A, history
        self.x = T @ z
        self.ndof_free = int(len(fr))
        return self.x

    # ------------------------------------------------------------------ evaluation (difference form)
    def evaluate(self, x=None):
        P = self.P
        x = self.x if x is None else x
        Nrt = self.Nrt
        t1 = self.rb.interpolate(x[:Nrt])
        t2 = self.rb.interpolate(x[Nrt:])

        def pieces(w):
            tau = np.array([w.t1.value, w.t2.value])
            e = self._eps(w.ux, w.uy) - self._A(tau)
            f = P.body_force(w.x[0], w.x[1])
            r0 = w.t1.div + f[..., 0]
            r1 = w.t2.div + f[..., 1]
            return e, r0, r1

        @Functional
        def const(w):
            e, _, _ = pieces(w)
            return P.k1 * np.einsum("ab...,ab...->...", e, e) + P.k2 * (e[0, 0] + e[1, 1]) ** 2

        @Functional
        def equi(w):
            _, r0, r1 = pieces(w)
            return 0.5 * P.wd * (r0 * r0 + r1 * r1)

        @Functional
        def energy(w):
            E = self._eps(w.ux, w.uy)
            tr = E[0, 0] + E[1, 1]
            if P.norm == "energy":
                return P.mu * np.einsum("ab...,ab...->...", E, E) + 0.5 * P.lam * tr * tr
            return P.mu * np.einsum("ab...,ab...->...", E, E)

        kw = dict(t1=t1, t2=t2, ux=self.ux, uy=self.uy)
        out = {"constitutive": float(const.assemble(self.rb, **kw)),
               "equilibrium": float(equi.assemble(self.rb, **kw)),
               "energy": float(energy.assemble(self.rb, **kw))}
        comp = 0.0
        for bidx in sorted({e.bnd.index for e in P.edges if e.kind == "contact"}):
            es = [e for e in P.edges if e.kind == "contact" and e.bnd.index == bidx]
            fb = FacetBasis(self.mesh, _rt_element(self.k), facets=self.edge_facet[[e.index for e in es]],
                            intorder=self.facet_intorder)
            fu = fb.with_element(self.uelem)
            e0 = es[0]

            @Functional
            def cterm(w):
                nO = np.moveaxis(w.n, 0, -1)
                n, t, g = P.frame(e0, w.x[0], w.x[1], nO)
                un = n[..., 0] * w.ux + n[..., 1] * w.uy
                q0 = w.t1.value[0] * w.n[0] + w.t1.value[1] * w.n[1]
                q1 = w.t2.value[0] * w.n[0] + w.t2.value[1] * w.n[1]
                return (un - g) * (n[..., 0] * q0 + n[..., 1] * q1)
            comp += float(cterm.assemble(fb, t1=fb.interpolate(x[:Nrt]), t2=fb.interpolate(x[Nrt:]),
                                         ux=fu.interpolate(self.xu[:, 0]), uy=fu.interpolate(self.xu[:, 1])))
        out["complementarity"] = comp
        out["total"] = out["constitutive"] + out["equilibrium"] + out["complementarity"]
        return out

    def constant(self):
        """c0 with F(tau) = 1/2 x^T K x - rhs^T x + c0 (for the assembly self-check)."""
        P = self.P

        @Functional
        def c0(w):
            E = self._eps(w.ux, w.uy)
            f = P.body_force(w.x[0], w.x[1])
            return P.k1 * np.einsum("ab...,ab...->...", E, E) + P.k2 * (E[0, 0] + E[1, 1]) ** 2 \
                + 0.5 * P.wd * (f[..., 0] ** 2 + f[..., 1] ** 2)
        return float(c0.assemble(self.rb, ux=self.ux, uy=self.uy))

    def contact_values(self, x=None):
        """(tau_n, tau_t) at the nodal points of the contact edges, by evaluating x."""
        x = self.x if x is None else x
        z = spla.spsolve(self.T.tocsc(), x) if x is not self.x else self.z
        return z[self.bound], np.array([z[s + self.Nrt] for s in self.bound])


def _skfem_ref_nodes():
    X = np.array([[0.0, 1.0, 0.0, 0.5, 0.5, 0.0],
                  [0.0, 0.0, 1.0, 0.0, 0.5, 0.5]])
    pair = {(0, 1): 3, (1, 2): 4, (0, 2): 5}
    return X, pair


def tau_at_nodes(S, x=None):
    """tau (row-major 2x2) at the VTU nodes of every cell (vertices, and mid nodes for P2
    cells): array (Nc, nloc, 2, 2), in the VTU local node order."""
    from skfem import Basis
    x = S.x if x is None else x
    X, pair = _skfem_ref_nodes()
    b = Basis(S.mesh, _rt_element(S.k), quadrature=(X, np.full(6, 1.0 / 12)))
    v1 = b.interpolate(x[:S.Nrt]).value      # (2, nel, 6)
    v2 = b.interpolate(x[S.Nrt:]).value
    P = S.P
    cells = P.cells
    nloc = cells.shape[1]
    out = np.zeros((len(cells), nloc, 2, 2))
    t = S.mesh.t
    for c in range(len(cells)):
        pos = {int(S.newid[cells[c, j]]): j for j in range(3)}       # newid -> VTU local
        sk = [int(np.nonzero(t[:, c] == S.newid[cells[c, j]])[0][0]) for j in range(3)]
        idx = list(sk)
        if nloc == 6:
            for (i, j) in ((0, 1), (1, 2), (2, 0)):
                idx.append(pair[tuple(sorted((sk[i], sk[j])))])
        for a, q in enumerate(idx):
            out[c, a, 0] = v1[:, c, q]
            out[c, a, 1] = v2[:, c, q]
        del pos
    return out
