"""Stress reconstruction with NGSolve: row-wise HDiv (Raviart-Thomas), essential Neumann data
through `dirichlet=`, contact conditions as linear constraint rows (point values of the normal
trace), primal-dual active set on the KKT system.

NGSolve naming: HDiv(mesh, order=k, RT=True) is RT_k (order 0: 3 DOFs per triangle; order 1:
8 DOFs = 2 per edge + 2 interior). Without RT=True, order 1 is BDM_1 (6 DOFs, no interior
DOFs): not the space meant here. The edge DOFs of HDiv are hierarchical (lowest-order flux +
Legendre-type higher-order coefficients), so neither bound is on a single DOF: the constraint
rows are obtained by evaluating the normal trace of each edge basis function at the edge points.

Geometry: the mesh is built from the VTU vertices; for P2 input the curved edges come from
`mesh.SetDeformation` with a VectorH1 order-2 field (mid node - chord mid point), i.e. exactly
the isoparametric P2 map. u_h is a VectorH1 order-1/2 GridFunction on that mesh.

Shares nothing with skfem_solver.py; the problem data (boundary kinds, expressions, material,
w_d) come from common.py.
"""
import ast

import netgen.meshing as ngm
import ngsolve as ng
import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from common import point_key


# ---------------------------------------------------------------------- expressions -> CF
def expr_cf(text):
    """fosls_ref expression grammar (numbers, x, y, z, pi, + - * / ^ **, sqrt abs sin cos exp
    log min max) as an NGSolve CoefficientFunction."""
    funcs = {"sqrt": ng.sqrt, "sin": ng.sin, "cos": ng.cos, "exp": ng.exp, "log": ng.log,
             "abs": lambda a: ng.IfPos(a, a, -a)}

    def ev(node):
        if isinstance(node, ast.Constant):
            return float(node.value)
        if isinstance(node, ast.Name):
            return {"x": ng.x, "y": ng.y, "z": ng.z, "pi": np.pi}[node.id]
        if isinstance(node, ast.BinOp):
            a, b = ev(node.left), ev(node.right)
            op = type(node.op)
            if op is ast.Add:
                return a + b
            if op is ast.Sub:
                return a - b
            if op is ast.Mult:
                return a * b
            if op is ast.Div:
                return a / b
            if op is ast.Pow:
                if isinstance(b, float) and b == int(b) and 0 <= b <= 8:
                    out = 1.0
                    for _ in range(int(b)):
                        out = out * a
                    return out
                return a ** b
        if isinstance(node, ast.UnaryOp):
            v = ev(node.operand)
            return -v if isinstance(node.op, ast.USub) else v
        if isinstance(node, ast.Call):
            args = [ev(a) for a in node.args]
            name = node.func.id
            if name in ("min", "max"):
                out = args[0]
                for a in args[1:]:
                    out = ng.IfPos(a - out, out, a) if name == "min" else ng.IfPos(a - out, a, out)
                return out
            return funcs[name](*args)
        raise ValueError(f"expression {text!r}: unsupported syntax for NGSolve")

    return ev(ast.parse(text.replace("^", "**").strip(), mode="eval").body)


def scalar_cf(sf):
    """fosls_ref ScalarField -> CF."""
    if sf.expr is None:
        return ng.CF(sf.const)
    return expr_cf(sf.expr.text)


def vector_cf(vf):
    return [scalar_cf(c) for c in vf.comps]


# ---------------------------------------------------------------------- the solver
class NgsolveReconstruction:
    def __init__(self, P, k, bonus=None, neumann="interp"):
        self.P, self.k, self.neumann = P, k, neumann
        self.bonus = bonus if bonus is not None else (4 if not P.curved else 12)
        self._mesh()
        self._displacement()

    def _mesh(self):
        P = self.P
        pts, cells = P.points, P.cells
        verts = np.unique(cells[:, :3])
        nid = -np.ones(len(pts), dtype=np.int64)
        nid[verts] = np.arange(len(verts))
        ngmesh = ngm.Mesh(dim=2)
        fd = ngmesh.Add(ngm.FaceDescriptor(surfnr=1, domin=1, bc=1))
        pn = [ngmesh.Add(ngm.MeshPoint(ngm.Pnt(float(pts[v, 0]), float(pts[v, 1]), 0.0))) for v in verts]
        ccw = np.ones(len(cells), dtype=bool)
        for ci, c in enumerate(cells):
            a, b, d = pts[c[0]], pts[c[1]], pts[c[2]]
            ar = (b[0] - a[0]) * (d[1] - a[1]) - (b[1] - a[1]) * (d[0] - a[0])
            ccw[ci] = ar > 0
            tri = [c[0], c[1], c[2]] if ar > 0 else [c[0], c[2], c[1]]
            ngmesh.Add(ngm.Element2D(fd, [pn[nid[v]] for v in tri]))
        ngmesh.SetMaterial(1, "body")
        # one bc name per edge group
        names = []
        for e in P.edges:
            if e.kind == "free":
                names.append("free")
            else:
                names.append(f"{e.kind}_{e.bnd.index}")
        uniq = sorted(set(names))
        bcnr = {nm: i + 1 for i, nm in enumerate(uniq)}
        for e, nm in zip(P.edges, names):
            a, b = (e.a, e.b) if ccw[e.cell] else (e.b, e.a)   # interior on the left
            ngmesh.Add(ngm.Element1D([pn[nid[a]], pn[nid[b]]], index=bcnr[nm]))
        for nm, i in bcnr.items():
            ngmesh.SetBCName(i - 1, nm)
        self.mesh = ng.Mesh(ngmesh)
        self.bcnames = uniq
        self.nid, self.verts = nid, verts
        # NGSolve edge numbers by vertex pair
        self.edge_nr = {}
        for ed in self.mesh.edges:
            va, vb = sorted(v.nr for v in ed.vertices)
            self.edge_nr[(va, vb)] = ed.nr
        # mid nodes of every cell edge (P2)
        if P.degree == 2:
            self.mid = {}
            for c in cells:
                for (i, j), mm in zip(((0, 1), (1, 2), (2, 0)), (3, 4, 5)):
                    self.mid[tuple(sorted((int(nid[c[i]]), int(nid[c[j]]))))] = int(c[mm])
            # value of the order-2 edge shape function at the edge mid point (reference)
            H = ng.H1(self.mesh, order=2)
            g = ng.GridFunction(H)
            for ed in self.mesh.edges:
                g.vec[H.GetDofNrs(ed)[0]] = 1.0
            cm = []
            for (va, vb), enr in self.edge_nr.items():
                pa, pb = self.mesh.vertices[va].point, self.mesh.vertices[vb].point
                cm.append(g(self.mesh(0.5 * (pa[0] + pb[0]), 0.5 * (pa[1] + pb[1]))))
            cm = np.array(cm)
            assert np.allclose(cm, cm[0], rtol=1e-13, atol=0), cm
            self.cmid = float(cm[0])
            if P.curved:
                D = ng.GridFunction(ng.VectorH1(self.mesh, order=2))
                self._set_p2(D, np.zeros((len(pts), 2)), deformation=True)
                self.deformation = D
                self.mesh.SetDeformation(D)

    def _set_p2(self, gf, vals, deformation=False):
        """Set a VectorH1 GridFunction from nodal values at the VTU points (vertices + mid nodes).
        deformation=True: value = mid node - chord mid point (vals ignored)."""
        P = self.P
        pts = P.points
        for comp in range(2):
            g = gf.components[comp]
            V = g.space
            vec = g.vec.FV().NumPy()
            vec[:] = 0.0
            for j, v in enumerate(self.verts):
                vec[V.GetDofNrs(ng.NodeId(ng.VERTEX, j))[0]] = 0.0 if deformation else vals[v, comp]
            if V.globalorder >= 2:
                inv = {j: v for j, v in enumerate(self.verts)}
                for (va, vb), enr in self.edge_nr.items():
                    m = self.mid[(va, vb)]
                    a, b = inv[va], inv[vb]
                    if deformation:
                        d = pts[m, comp] - 0.5 * (pts[a, comp] + pts[b, comp])
                    else:
                        d = vals[m, comp] - 0.5 * (vals[a, comp] + vals[b, comp])
                    vec[V.GetDofNrs(ng.NodeId(ng.EDGE, enr))[0]] = d / self.cmid

    def _displacement(self):
        P = self.P
        self.U = ng.VectorH1(self.mesh, order=P.degree)
        self.u = ng.GridFunction(self.U)
        if P.degree == 2:
            self._set_p2(self.u, P.disp)
        else:
            for comp in range(2):
                g = self.u.components[comp]
                vec = g.vec.FV().NumPy()
                for j, v in enumerate(self.verts):
                    vec[g.space.GetDofNrs(ng.NodeId(ng.VERTEX, j))[0]] = P.disp[v, comp]

    # ------------------------------------------------------------------ pieces
    def _A(self, T):
        return (T - self.P.ctr * ng.Trace(T) * ng.Id(2)) / (2.0 * self.P.mu)

    def _eps(self):
        return ng.Sym(ng.Grad(self.u))

    def _f(self):
        bf = self.P.scene.body_force
        return [ng.CF(0.0), ng.CF(0.0)] if bf is None else vector_cf(bf)

    def _contact_groups(self):
        P = self.P
        out = {}
        for e in P.edges:
            if e.kind == "contact":
                out.setdefault(e.bnd.index, e.bnd)
        return out

    def _frame_cf(self, b):
        nO = ng.specialcf.normal(2)
        if b.normal == "body":
            n = nO
        else:
            n = ng.CF((float(-b.plane_normal[0]), float(-b.plane_normal[1])))
        t = ng.CF((-n[1], n[0]))
        if b.gap is not None:
            g = scalar_cf(b.gap)
        else:
            m, p = b.plane_normal, b.plane_point
            h = (ng.x - float(p[0])) * float(m[0]) + (ng.y - float(p[1])) * float(m[1])
            if b.normal == "obstacle":
                g = h
            else:
                g = h / (-(n[0] * float(m[0]) + n[1] * float(m[1])))
        return n, t, g

    # ------------------------------------------------------------------ assembly
    def assemble(self):
        P, mesh, k = self.P, self.mesh, self.k
        neu = "|".join(nm for nm in self.bcnames if nm == "free" or nm.startswith("neumann_"))
        V = ng.HDiv(mesh, order=k, RT=True, dirichlet=neu)
        self.V = V
        fes = ng.FESpace([V, V])
        self.fes = fes
        (t1, t2), (s1, s2) = fes.TnT()
        tau = ng.CF((t1[0], t1[1], t2[0], t2[1]), dims=(2, 2))
        sig = ng.CF((s1[0], s1[1], s2[0], s2[1]), dims=(2, 2))
        AT, AS = self._A(tau), self._A(sig)
        dx = ng.dx(bonus_intorder=self.bonus)
        a = ng.BilinearForm(fes)
        a += (2 * P.k1 * ng.InnerProduct(AT, AS) + 2 * P.k2 * ng.Trace(AT) * ng.Trace(AS)
              + P.wd * (ng.div(t1) * ng.div(s1) + ng.div(t2) * ng.div(s2))) * dx
        a.Assemble()
        E = self._eps()
        f0, f1 = self._f()
        lf = ng.LinearForm(fes)
        lf += (2 * P.k1 * ng.InnerProduct(E, AS) + 2 * P.k2 * ng.Trace(E) * ng.Trace(AS)
               - P.wd * (f0 * ng.div(s1) + f1 * ng.div(s2))) * dx
        nO = ng.specialcf.normal(2)
        for bidx, b in self._contact_groups().items():
            n, t, g = self._frame_cf(b)
            un = n * self.u
            sn = n[0] * (s1.Trace() * nO) + n[1] * (s2.Trace() * nO)
            lf += -(un - g) * sn * ng.ds(definedon=mesh.Boundaries(f"contact_{bidx}"),
                                         bonus_intorder=self.bonus + 4)
        lf.Assemble()
        r, c, v = a.mat.COO()
        N = fes.ndof
        self.K = sp.csr_matrix((np.array(v), (np.array(r), np.array(c))), shape=(N, N))
        self.rhs = lf.vec.FV().NumPy().copy()
        self.free = np.array(list(fes.FreeDofs()), dtype=bool)
        # essential values tau_i . n_Omega = t_i on Neumann edges (0 on free edges)
        self.xD = self._neumann_interp() if self.neumann == "interp" else self._neumann_l2()
        self.xD[self.free] = 0.0
        return self.K, self.rhs

    def _edge_probe(self, el, s_pts):
        """Points, outward normals and the normal traces of the edge DOFs of BND element el at
        the reference parameters s_pts: X (np, 2), nO (np, 2), dofs, q (np, ndofs)."""
        mesh, V = self.mesh, self.V
        nO_cf = ng.specialcf.normal(2)
        xy = ng.CF((ng.x, ng.y))
        probe = ng.GridFunction(V)
        pv = probe.vec.FV().NumPy()
        tr_cf = probe * nO_cf
        trafo = mesh.GetTrafo(ng.ElementId(ng.BND, el.nr))
        mips = [trafo(s) for s in s_pts]
        X = np.array([xy(mp) for mp in mips])
        nO = np.array([nO_cf(mp) for mp in mips])
        dofs = list(V.GetDofNrs(ng.ElementId(ng.BND, el.nr)))
        q = np.zeros((len(mips), len(dofs)))
        for jd, d in enumerate(dofs):
            pv[:] = 0.0
            pv[d] = 1.0
            q[:, jd] = [tr_cf(mp) for mp in mips]
        return X, nO, dofs, q

    def _s_pts(self):
        return [0.5] if self.k == 0 else [0.0, 1.0]

    def _neumann_interp(self):
        """Edge DOFs such that the normal trace of each row equals t_i at the nodal points
        (RT_0: edge mid point, RT_1: end points) -- the nodal convention of docs/design.md section 4."""
        P, fes = self.P, self.fes
        xD = np.zeros(fes.ndof)
        bmap = {b.index: b for b in P.scene.boundaries}
        for el in self.mesh.Elements(ng.BND):
            name = el.mat
            if name == "free":
                continue
            if not name.startswith("neumann_"):
                continue
            b = bmap[int(name.split("_")[1])]
            X, nO, dofs, q = self._edge_probe(el, self._s_pts())
            tv = b.traction(X[:, 0], X[:, 1])
            c = np.linalg.solve(q, tv)            # (ndofs, 2)
            for i in range(2):
                xD[fes.Range(i).start + np.array(dofs)] = c[:, i]
        return xD

    def _neumann_l2(self):
        """NGSolve's own boundary projection (GridFunction.Set on the Neumann boundaries)."""
        P, fes, V, mesh = self.P, self.fes, self.V, self.mesh
        nO = ng.specialcf.normal(2)
        gD = np.zeros(fes.ndof)
        fixed = np.nonzero(~np.array(list(V.FreeDofs())))[0]
        for b in P.scene.boundaries:
            if b.kind == "neumann" and f"neumann_{b.index}" in self.bcnames:
                tc = vector_cf(b.traction)
                for i in range(2):
                    gi = ng.GridFunction(V)
                    gi.Set(tc[i] * nO, ng.BND, definedon=mesh.Boundaries(f"neumann_{b.index}"),
                           bonus_intorder=self.bonus + 4)
                    gD[fes.Range(i).start + fixed] += gi.vec.FV().NumPy()[fixed]
        return gD

    # ------------------------------------------------------------------ constraint rows
    def constraints(self):
        """Rows of tau_n (inequality) and tau_t (equality) at the nodal points of every contact
        edge: RT_0 the edge mid point, RT_1 the two end points."""
        P, mesh, fes = self.P, self.mesh, self.fes
        Gr, Er, pts = [], [], []
        groups = self._contact_groups()
        for el in mesh.Elements(ng.BND):
            name = el.mat
            if not name.startswith("contact_"):
                continue
            b = groups[int(name.split("_")[1])]
            X, nO, dofs, q = self._edge_probe(el, self._s_pts())
            if b.normal == "body":
                n = nO
            else:
                n = np.broadcast_to(-b.plane_normal, nO.shape)
            t = np.stack([-n[:, 1], n[:, 0]], axis=-1)
            va, vb = [self.mesh.vertices[v.nr].point for v in el.vertices]
            for p in range(len(X)):
                rowN, rowT = {}, {}
                for i in range(2):
                    off = fes.Range(i).start
                    for jd, d in enumerate(dofs):
                        rowN[off + d] = n[p, i] * q[p, jd]
                        rowT[off + d] = t[p, i] * q[p, jd]
                Gr.append(rowN)
                Er.append(rowT)
                pts.append({"x": float(X[p, 0]), "y": float(X[p, 1]),
                            "edge_mid": [0.5 * (va[0] + vb[0]), 0.5 * (va[1] + vb[1])]})
        N = fes.ndof

        def tomat(rows):
            r, c, v = [], [], []
            for i, row in enumerate(rows):
                for j, val in row.items():
                    r.append(i); c.append(j); v.append(val)
            return sp.csr_matrix((v, (r, c)), shape=(len(rows), N))
        self.G, self.E, self.cpoints = tomat(Gr), tomat(Er), pts
        return self.G, self.E

    # ------------------------------------------------------------------ solve
    def solve(self, constrained=True, max_iter=100):
        K, rhs, free, xD = self.K, self.rhs, self.free, self.xD
        fr = np.nonzero(free)[0]
        Kff = K[fr][:, fr]
        b = rhs[fr] - K[fr] @ xD
        Gf = self.G[:, fr]
        Ef = self.E[:, fr]
        gD = self.G @ xD
        eD = self.E @ xD
        nG = Gf.shape[0]
        A = np.zeros(0, dtype=np.int64)
        history = []
        for it in range(max_iter + 1):
            C = sp.vstack([Ef, Gf[A]]).tocsr()
            nc = C.shape[0]
            KKT = sp.bmat([[Kff, C.T], [C, None]], format="csc")
            R = np.concatenate([b, -eD, -gD[A]])
            sol = spla.splu(KKT).solve(R)
            res = np.abs(KKT @ sol - R).max() / np.abs(R).max()
            xf = sol[:len(fr)]
            mult = sol[len(fr) + Ef.shape[0]:]
            x = xD.copy()
            x[fr] = xf
            lam = np.zeros(nG)
            lam[A] = mult
            gx = self.G @ x
            history.append({"active": int(len(A)), "solve_residual": float(res)})
            if not constrained:
                break
            inA = np.zeros(nG, dtype=bool)
            inA[A] = True
            newA = np.nonzero((inA & (lam > 0)) | (~inA & (gx > 0)))[0]
            if np.array_equal(newA, A):
                break
            A = newA
        else:
            raise RuntimeError("primal-dual active set did not converge")
        self.x, self.A, self.lam, self.history = x, A, lam, history
        self.ndof_free = int(len(fr))
        self.tn = gx
        self.tt = self.E @ x
        return x

    # ------------------------------------------------------------------ evaluation (difference form)
    def evaluate(self, x=None):
        P, mesh = self.P, self.mesh
        x = self.x if x is None else x
        gf = ng.GridFunction(self.fes)
        gf.vec.FV().NumPy()[:] = x
        t1, t2 = gf.components
        tau = ng.CF((t1[0], t1[1], t2[0], t2[1]), dims=(2, 2))
        E = self._eps()
        e = E - self._A(tau)
        f0, f1 = self._f()
        order = 2 * self.k + 2 + 2 * self.bonus + 4
        const = ng.Integrate(P.k1 * ng.InnerProduct(e, e) + P.k2 * ng.Trace(e) * ng.Trace(e), mesh, order=order)
        r0 = ng.div(t1) + f0
        r1 = ng.div(t2) + f1
        equi = ng.Integrate(0.5 * P.wd * (r0 * r0 + r1 * r1), mesh, order=order)
        if P.norm == "energy":
            energy = ng.Integrate(P.mu * ng.InnerProduct(E, E) + 0.5 * P.lam * ng.Trace(E) ** 2, mesh, order=order)
        else:
            energy = ng.Integrate(P.mu * ng.InnerProduct(E, E), mesh, order=order)
        nO = ng.specialcf.normal(2)
        comp = 0.0
        for bidx, b in self._contact_groups().items():
            n, t, g = self._frame_cf(b)
            un = n * self.u
            sn = n[0] * (t1 * nO) + n[1] * (t2 * nO)
            comp += ng.Integrate((un - g) * sn, mesh, ng.BND, order=order,
                                 definedon=mesh.Boundaries(f"contact_{bidx}"))
        out = {"constitutive": float(const), "equilibrium": float(equi), "complementarity": float(comp),
               "energy": float(energy)}
        out["total"] = out["constitutive"] + out["equilibrium"] + out["complementarity"]
        return out

    def point_keys(self):
        return [point_key(p["x"], p["y"], self.P.diam) for p in self.cpoints]


def tau_at_nodes(S, x=None):
    """tau at the VTU nodes of every cell, (Nc, nloc, 2, 2), VTU local node order."""
    x = S.x if x is None else x
    P, mesh = S.P, S.mesh
    gf = ng.GridFunction(S.fes)
    gf.vec.FV().NumPy()[:] = x
    t1, t2 = gf.components
    ref = [(1.0, 0.0), (0.0, 1.0), (0.0, 0.0), (0.5, 0.5), (0.0, 0.5), (0.5, 0.0)]
    ir = ng.IntegrationRule(ref, [1.0 / 12] * 6)
    mips = mesh.MapToAllElements(ir, ng.VOL)
    XY = np.asarray(ng.CF((ng.x, ng.y))(mips)).reshape(mesh.ne, 6, 2)
    T = np.asarray(ng.CF((t1[0], t1[1], t2[0], t2[1]))(mips)).reshape(mesh.ne, 6, 2, 2)
    cells = P.cells
    nloc = cells.shape[1]
    out = np.zeros((len(cells), nloc, 2, 2))
    for c in range(len(cells)):
        for a in range(nloc):
            d = np.hypot(*(XY[c] - P.points[cells[c, a]]).T)
            q = int(np.argmin(d))
            assert d[q] < 1e-9 * P.diam, (c, a, d)
            out[c, a] = T[c, q]
    return out
