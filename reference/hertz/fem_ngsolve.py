"""NGSolve reference solvers: penalty contact against the analytic plane y = 0 (obstacle normal),
energy  1/2 a(u,u) + 1/2 kappa ||(-y - u_y)^+||^2_{Gamma_C},  Newton with penalty continuation, P1 / P2
(mesh.Curve(2)) displacement, or Taylor-Hood P2/P1 (u, p) for nu = 0.5.  The penalty solution
penetrates by about p/kappa: deliberately, the audit tool must detect it.

Coulomb friction: regularised and penalised residual (not an energy: the friction threshold depends
on the normal pressure)
  a(u,v) - <p, v_y> + <F p u_x / sqrt(u_x^2 + eps^2), v_x>,   p = kappa (-y - u_y)^+,
Newton with continuation in eps (single load step from zero: u_x is the slip).
"""
import time
import numpy as np
import ngsolve as ngs
from ngsolve import (x, y, CF, IfPos, sqrt, InnerProduct, Sym, Grad, Trace, Id, dx, ds, BilinearForm,
                     GridFunction, VectorH1, H1, Parameter, IntegrationRule, VOL, BND, ElementId)

from geometry import TriMesh, edge_table
from fem_skfem import lame

ngs.SetNumThreads(1)


def pos(a):
    return IfPos(a, a, 0)


def _newton(a, gfu, freedofs, inverse, tol=1e-11, maxit=50, damping=True):
    res = gfu.vec.CreateVector()
    du = gfu.vec.CreateVector()
    w = gfu.vec.CreateVector()
    hist = []
    a.Apply(gfu.vec, res)
    fd = np.array(list(freedofs), dtype=bool)

    def rnorm(r):
        return float(np.abs(r.FV().NumPy()[fd]).max())

    r0 = max(rnorm(res), 1e-300)
    for it in range(1, maxit + 1):
        a.AssembleLinearization(gfu.vec)
        inv = a.mat.Inverse(freedofs, inverse=inverse)
        du.data = inv * res
        rn = rnorm(res)
        step = 1.0
        w.data = gfu.vec - du
        a.Apply(w, res)
        if damping:
            while rnorm(res) > rn and step > 1e-3 and rn > 1e-300:
                step *= 0.5
                w.data = gfu.vec - step * du
                a.Apply(w, res)
        gfu.vec.data = w
        rn_new = rnorm(res)
        dun = float(np.abs(du.FV().NumPy()).max()) * step
        hist.append(dict(it=it, residual=rn_new, step=step, du=dun))
        if dun < tol * max(float(np.abs(gfu.vec.FV().NumPy()).max()), 1e-300):
            break
    return hist


class NGSolveContact:
    def __init__(self, tm: TriMesh, degree, E, nu, mixed=False):
        self.tm, self.degree, self.E, self.nu, self.mixed = tm, degree, E, nu, mixed
        mesh = ngs.Mesh(tm.ngmesh)
        mesh.Curve(2 if degree == 2 else 1)
        self.mesh = mesh
        V = VectorH1(mesh, order=degree, dirichlet="top")
        if mixed:
            Q = H1(mesh, order=1)
            self.fes = V * Q
        else:
            self.fes = V
        self.gfu = GridFunction(self.fes)
        lam, mu = lame(E, nu)
        self.lam, self.mu = lam, mu
        self.kappa = Parameter(1e4)
        self.eps = Parameter(1e-4)
        self.friction = Parameter(0.0)

    def _u(self, U):
        return U[0] if self.mixed else U

    def _sigma(self, u, p=None):
        e = Sym(Grad(u))
        if self.mixed:
            return 2 * self.mu * e - p * Id(2)
        return 2 * self.mu * e + self.lam * Trace(e) * Id(2)

    def solve(self, uD=(0.0, -0.01), kappas=(1e4, 1e5, 1e6, 1e7, 1e8), friction=0.0,
              eps_list=(1e-4, 1e-5, 1e-6, 1e-7, 1e-8), bonus=6):
        t0 = time.time()
        mesh, fes = self.mesh, self.fes
        gfu = self.gfu
        gu = gfu.components[0] if self.mixed else gfu
        # start from the rigid translation
        gu.Set(CF(uD))
        U = fes.TrialFunction()
        V = fes.TestFunction()
        if self.mixed:
            (u, p), (v, q) = U, V
        else:
            u, v, p, q = U, V, None, None
        gap = -y - u[1]  # penetration measure (> 0: penetrates)
        dsc = ds("contact", bonus_intorder=bonus)
        inverse = "umfpack" if (self.mixed or friction > 0) else "sparsecholesky"
        if friction == 0:
            a = BilinearForm(fes, symmetric=True)
            if self.mixed:
                e = Sym(Grad(u))
                energy = self.mu * InnerProduct(e, e) - p * Trace(e)
            else:
                e = Sym(Grad(u))
                energy = self.mu * InnerProduct(e, e) + 0.5 * self.lam * Trace(e) ** 2
            a += energy * dx
            a += 0.5 * self.kappa * pos(gap) ** 2 * dsc
            # Variation-style: use the energy directly
            a = BilinearForm(fes, symmetric=True)
            a += ngs.Variation(energy * dx)
            a += ngs.Variation(0.5 * self.kappa * pos(gap) ** 2 * dsc)
        else:
            a = BilinearForm(fes, symmetric=False)
            sig = self._sigma(u, p)
            a += InnerProduct(sig, Sym(Grad(v))) * dx
            if self.mixed:
                a += -Trace(Sym(Grad(u))) * q * dx
            pn = self.kappa * pos(gap)
            a += (-pn * v[1] + self.friction * pn * u[0] / sqrt(u[0] ** 2 + self.eps ** 2) * v[0]) * dsc
        history = []
        if friction == 0:
            for k in kappas:
                self.kappa.Set(k)
                h = _newton(a, gfu, fes.FreeDofs(), inverse)
                history.append(dict(kappa=k, newton=len(h), residual=h[-1]["residual"]))
        else:
            # frictionless penalty first, then switch friction on and lower eps
            self.friction.Set(0.0)
            for k in kappas:
                self.kappa.Set(k)
                h = _newton(a, gfu, fes.FreeDofs(), inverse)
                history.append(dict(kappa=k, friction=0.0, newton=len(h), residual=h[-1]["residual"]))
            self.friction.Set(friction)
            for ep in eps_list:
                self.eps.Set(ep)
                h = _newton(a, gfu, fes.FreeDofs(), inverse, maxit=80)
                history.append(dict(kappa=kappas[-1], friction=friction, eps=ep, newton=len(h),
                                    residual=h[-1]["residual"]))
        self.form = a
        self.history = history
        # reactions: residual of the form on the Dirichlet dofs (internal force; penalty does not touch "top")
        res = gfu.vec.CreateVector()
        a.Apply(gfu.vec, res)
        vt = GridFunction(fes)
        (vt.components[0] if self.mixed else vt).Set(CF((0.0, 1.0)), definedon=mesh.Boundaries("top"))
        P = -InnerProduct(res, vt.vec)
        vt.vec[:] = 0.0
        (vt.components[0] if self.mixed else vt).Set(CF((1.0, 0.0)), definedon=mesh.Boundaries("top"))
        Fx = InnerProduct(res, vt.vec)
        uu = gfu.components[0] if self.mixed else gfu
        pen = -y - uu[1]
        Pc = ngs.Integrate(self.kappa * pos(pen) * ds("contact", bonus_intorder=bonus), mesh)
        Ft = ngs.Integrate(-self.friction * self.kappa * pos(pen) * uu[0] / sqrt(uu[0] ** 2 + self.eps ** 2)
                           * ds("contact", bonus_intorder=bonus), mesh) if friction > 0 else 0.0
        fd = np.array(list(fes.FreeDofs()), dtype=bool)
        rfree = float(np.abs(res.FV().NumPy()[fd]).max())
        return dict(P=float(P), Fx_top=float(Fx), P_contact=float(Pc), Ft_contact=float(Ft), history=history,
                    final_residual=rfree / max(abs(P), 1e-300), time=time.time() - t0,
                    newton_total=int(sum(h["newton"] for h in history)))

    def stress_gf(self):
        """L2 projection of the stress (xx, yy, zz, xy) onto continuous H1 of the displacement degree."""
        mesh = self.mesh
        S = H1(mesh, order=self.degree)
        s, t = S.TnT()
        m = BilinearForm(s * t * dx, symmetric=True).Assemble()
        inv = m.mat.Inverse(S.FreeDofs(), inverse="sparsecholesky")
        if self.mixed:
            u, p = self.gfu.components
            e = Sym(Grad(u))
            comps = [2 * self.mu * e[0, 0] - p, 2 * self.mu * e[1, 1] - p, -p, 2 * self.mu * e[0, 1]]
        else:
            u = self.gfu
            e = Sym(Grad(u))
            tr = e[0, 0] + e[1, 1]
            comps = [2 * self.mu * e[0, 0] + self.lam * tr, 2 * self.mu * e[1, 1] + self.lam * tr,
                     self.lam * tr, 2 * self.mu * e[0, 1]]
        out = []
        for c in comps:
            f = ngs.LinearForm(c * t * dx).Assemble()
            g = GridFunction(S)
            g.vec.data = inv * f.vec
            out.append(g)
        return out

    def nodal_output(self):
        """Nodes (vertices, then edge mid nodes for P2, numbered by geometry.edge_table), cells in the
        CCW vertex order of tm.t, displacement and projected stress at the nodes."""
        tm, mesh = self.tm, self.mesh
        Nv = tm.p.shape[0]
        ref = [(1.0, 0.0), (0.0, 1.0), (0.0, 0.0), (0.5, 0.5), (0.0, 0.5), (0.5, 0.0)]
        npt = 3 if self.degree == 1 else 6
        ir = IntegrationRule(points=ref[:npt], weights=[1.0] * npt)
        pts = mesh.MapToAllElements(ir, VOL)
        X = CF((x, y))(pts).reshape(-1, npt, 2)
        uu = self.gfu.components[0] if self.mixed else self.gfu
        Uv = uu(pts).reshape(-1, npt, 2)
        sg = self.stress_gf()
        Sv = np.stack([g(pts).reshape(-1, npt) for g in sg], axis=-1)
        edges, t2e = edge_table(tm.t)
        eid = {(int(a), int(b)): k for k, (a, b) in enumerate(edges)}
        nn = Nv if self.degree == 1 else Nv + len(edges)
        nodes = np.full((nn, 2), np.nan)
        U = np.full((nn, 2), np.nan)
        Sig = np.full((nn, 4), np.nan)
        for i in range(mesh.ne):
            vs = [v.nr for v in mesh[ElementId(VOL, i)].vertices]
            ids = list(vs)
            if self.degree == 2:
                for (aa, bb) in ((vs[0], vs[1]), (vs[1], vs[2]), (vs[0], vs[2])):
                    ids.append(Nv + eid[tuple(sorted((aa, bb)))])
            nodes[ids] = X[i]
            U[ids] = Uv[i]
            Sig[ids] = Sv[i]
        assert np.allclose(nodes[:Nv], tm.p, atol=1e-13, rtol=0)
        nodes[:Nv] = tm.p
        if self.degree == 1:
            cells, lines = tm.t.copy(), tm.be.copy()
        else:
            cells = np.hstack([tm.t, Nv + t2e])
            lines = np.array([[a, b, Nv + eid[tuple(sorted((int(a), int(b))))]] for a, b in tm.be], dtype=np.int64)
        return nodes, cells, lines, U, Sig
