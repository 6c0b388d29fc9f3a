"""scikit-fem reference solvers: P1 / P2 (curved, isoparametric) / Taylor-Hood P2-P1 elasticity with a
primal-dual active-set (semismooth Newton) loop on the nodal contact constraints, optionally with
Coulomb friction (single load step from zero, so u_t is the slip of that step).

Contact is measured along the obstacle normal of the plane y = 0:  u_y(x_i) >= -y_i  at every node x_i
of the contact boundary (vertices and, for P2, the curved mid-edge nodes).  The nodal reaction
r = K u - F at a contact node is the force the obstacle exerts on the body: r_y = lambda_n >= 0,
r_x = lambda_t with |lambda_t| <= F lambda_n (Coulomb), lambda_t opposite to the slip u_x.
"""
import time
import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spl
import skfem
from skfem import (MeshTri1, MeshTri2, Basis, ElementVector, ElementTriP1, ElementTriP2, BilinearForm,
                   LinearForm, asm)
from skfem.helpers import ddot, sym_grad, trace, div, dot

from geometry import TriMesh, project_circle, edge_table


def lame(E, nu):
    mu = E / (2 * (1 + nu))
    lam = np.inf if nu == 0.5 else E * nu / ((1 + nu) * (1 - 2 * nu))
    return lam, mu


class Discretisation:
    """skfem mesh + bases on a TriMesh, and the map from skfem dofs to output nodes."""

    def __init__(self, tm: TriMesh, degree, curved_tags=(), mixed=False):
        self.tm, self.degree, self.mixed = tm, degree, mixed
        m1 = MeshTri1(tm.p.T.copy(), tm.t.T.copy())
        Nv = tm.p.shape[0]
        if degree == 1:
            self.mesh = m1
            self.nodes = tm.p.copy()
            self.cells = tm.t.copy()
            self.lines = tm.be.copy()
            elem = ElementTriP1()
        else:
            M = MeshTri2.from_mesh(m1)
            fac = M.facets.T  # (Nf, 2) sorted
            fid = {(int(a), int(b)): k for k, (a, b) in enumerate(fac)}
            doflocs = M.doflocs.copy()
            bes = np.sort(tm.be, axis=1)
            for (a, b), tag in zip(bes, tm.btag):
                if tag in curved_tags:
                    f = fid[(int(a), int(b))]
                    doflocs[:, Nv + f] = project_circle(doflocs[:, Nv + f])
            from dataclasses import replace
            self.mesh = replace(M, doflocs=doflocs)
            self.nodes = doflocs.T.copy()
            t = tm.t
            mids = [[Nv + fid[tuple(sorted((int(r[i]), int(r[j]))))] for (i, j) in ((0, 1), (1, 2), (2, 0))] for r in t]
            self.cells = np.hstack([t, np.array(mids, dtype=np.int64)])
            self.lines = np.array([[a, b, Nv + fid[tuple(sorted((int(a), int(b))))]] for a, b in tm.be], dtype=np.int64)
            elem = ElementTriP2()
        self.elem = elem
        self.ub = Basis(self.mesh, ElementVector(elem))
        self.sb = Basis(self.mesh, elem)
        if mixed:
            self.pb = Basis(self.mesh, ElementTriP1(), quadrature=self.ub.quadrature)
        nd = self.ub.nodal_dofs
        if degree == 1:
            self.node_dofs = nd.T.copy()  # (Nnodes, 2)
            self.snode = self.sb.nodal_dofs[0].copy()
        else:
            self.node_dofs = np.vstack([nd.T, self.ub.facet_dofs.T])
            self.snode = np.concatenate([self.sb.nodal_dofs[0], self.sb.facet_dofs[0]])
        self.nu_dofs = self.ub.N
        self.ndofs = self.ub.N + (self.pb.N if mixed else 0)

    def boundary_nodes(self, tags):
        sel = np.isin(self.tm.btag, tags)
        return np.unique(self.lines[sel].ravel())


def assemble(dsc: Discretisation, E, nu):
    lam, mu = lame(E, nu)

    if dsc.mixed:
        @BilinearForm
        def a(u, v, w):
            return 2 * mu * ddot(sym_grad(u), sym_grad(v))

        @BilinearForm
        def b(u, q, w):
            return -div(u) * q

        A = asm(a, dsc.ub)
        B = asm(b, dsc.ub, dsc.pb)
        K = sp.bmat([[A, B.T], [B, None]], format="csr")
    else:
        @BilinearForm
        def a(u, v, w):
            e, f = sym_grad(u), sym_grad(v)
            return 2 * mu * ddot(e, f) + lam * trace(e) * trace(f)

        K = asm(a, dsc.ub).tocsr()
    return K


def solve_contact(dsc: Discretisation, K, top_nodes, uD, contact_nodes, friction=0.0, cscale=None,
                  maxit=100, verbose=False, obstacle_gap=None):
    """Hertz / block set-up: Dirichlet uD on top_nodes, plane y = 0 (gap = y), no load.
    obstacle_gap: optional callable of the nodal x (array) returning an extra gap added to y, i.e. the
    obstacle surface y = -obstacle_gap(x) below the plane (e.g. a rigid cylinder of radius R below y = 0:
    R - sqrt(R^2 - x^2)); the contact direction stays (0, -1).  None: the plane y = 0."""
    top_nodes = np.asarray(top_nodes)
    cn = np.setdiff1d(np.asarray(contact_nodes), top_nodes)
    gap = dsc.nodes[cn, 1]
    if obstacle_gap is not None:
        gap = gap + np.asarray(obstacle_gap(dsc.nodes[cn, 0]), float)
    # initial guess: the rigid translation uD -> contact where it would penetrate, all stick
    state = np.where(gap + uD[1] < 0, 1 if friction > 0 else 2, 0)
    dvals = np.tile(np.asarray(uD, float), (len(top_nodes), 1))
    return solve_contact_general(dsc, K, np.zeros(K.shape[0]), top_nodes, dvals, cn, gap, friction=friction,
                                 cscale=cscale, maxit=maxit, verbose=verbose, state=state)


def solve_contact_general(dsc: Discretisation, K, F, dir_nodes, dir_vals, cn, gap, friction=0.0, cscale=None,
                          maxit=100, verbose=False, state=None):
    """Primal-dual active set for  -u_y <= gap  (contact direction n = (0,-1), t = (1,0)) at the nodes cn,
    Dirichlet values dir_vals (N_d, 2) at dir_nodes, load vector F.  state: initial partition
    (0 free, 1 stick, 2 slip with lambda_t = +F lambda_n, 3 slip with lambda_t = -F lambda_n); default all free."""
    t0 = time.time()
    n = K.shape[0]
    dir_nodes = np.asarray(dir_nodes)
    dx, dy = dsc.node_dofs[cn, 0], dsc.node_dofs[cn, 1]
    gap0 = np.asarray(gap, float)
    Dtop = np.concatenate([dsc.node_dofs[dir_nodes, 0], dsc.node_dofs[dir_nodes, 1]])
    vtop = np.concatenate([dir_vals[:, 0], dir_vals[:, 1]])
    c = cscale if cscale is not None else K.diagonal()[dy].mean()
    state = np.zeros(len(cn), dtype=int) if state is None else np.asarray(state).copy()
    Kc = K.tocsr()
    history = []
    for it in range(1, maxit + 1):
        act = state > 0
        stick = state == 1
        slip = state >= 2
        D = np.concatenate([Dtop, dy[act], dx[stick]])
        vD = np.concatenate([vtop, -gap0[act], np.zeros(stick.sum())])
        u = np.zeros(n)
        u[D] = vD
        # slip nodes: x-row replaced by  (K u - F)_x - s F (K u - F)_y = 0,  i.e. lambda_t = s F lambda_n
        A, rhs = Kc, F
        if friction > 0 and slip.any():
            s = np.where(state[slip] == 2, 1.0, -1.0)
            Pm = sp.identity(n, format="csr") + sp.csr_matrix((-s * friction, (dx[slip], dy[slip])), shape=(n, n))
            A = (Pm @ Kc).tocsr()
            rhs = Pm @ F
        I = np.setdiff1d(np.arange(n), D)
        AII = A[I][:, I].tocsc()
        b = rhs[I] - A[I][:, D] @ vD
        u[I] = spl.spsolve(AII, b)
        r = Kc @ u - F
        ln, lt = r[dy], r[dx]
        g = gap0 + u[dy]
        ut = u[dx]
        lnt = ln - c * g
        new = np.zeros_like(state)
        inc = lnt > 0
        if friction > 0:
            z = lt - c * ut
            st = np.abs(z) <= friction * lnt
            new[inc & st] = 1
            new[inc & ~st & (z > 0)] = 2
            new[inc & ~st & (z <= 0)] = 3
        else:
            new[inc] = 2
        changed = int((new != state).sum())
        # NCP residuals (scaled by the largest contact force)
        scale = max(np.abs(ln).max(), 1e-300)
        ncp_n = np.abs(ln - np.maximum(0, ln - c * g)).max() / scale
        if friction > 0:
            bound = friction * np.maximum(ln, 0)
            z = lt - c * ut
            ncp_t = np.abs(lt - np.clip(z, -bound, bound)).max() / scale
        else:
            ncp_t = 0.0
        lin = np.abs((A @ u - rhs)[I]).max() / max(np.abs(r[Dtop]).max(), 1e-300)
        history.append(dict(it=it, active=int(act.sum()), stick=int(stick.sum()), changed=changed,
                            ncp_normal=float(ncp_n), ncp_tangential=float(ncp_t), linear=float(lin)))
        if verbose:
            print(history[-1])
        if changed == 0:
            break
        state = new
    else:
        raise RuntimeError("active set did not converge")
    P = -r[dsc.node_dofs[dir_nodes, 1]].sum()
    Fx_top = r[dsc.node_dofs[dir_nodes, 0]].sum()
    return dict(u=u, r=r, contact_nodes=cn, lambda_n=ln, lambda_t=lt, state=state, iterations=it,
                history=history, P=float(P), Fx_top=float(Fx_top), time=time.time() - t0,
                final_residual=float(max(history[-1]["ncp_normal"], history[-1]["ncp_tangential"],
                                         history[-1]["linear"])))


def nodal_fields(dsc: Discretisation, E, nu, u):
    """Displacement at the output nodes and the L2 projection of the stress onto the continuous
    Lagrange space of the displacement degree: columns xx, yy, zz, xy (plane strain)."""
    lam, mu = lame(E, nu)
    U = u[dsc.node_dofs]
    uh = dsc.ub.interpolate(u[:dsc.nu_dofs])
    if dsc.mixed:
        ph = dsc.pb.interpolate(u[dsc.nu_dofs:])
    Mm = asm(BilinearForm(lambda a, b, w: a * b), dsc.sb).tocsc()
    lu = spl.splu(Mm)
    out = np.zeros((dsc.nodes.shape[0], 4))

    def comp(i):
        def f(v, w):
            e = sym_grad(w["uh"])
            if dsc.mixed:
                p = w["ph"]
                s = [2 * mu * e[0, 0] - p, 2 * mu * e[1, 1] - p, -p, 2 * mu * e[0, 1]][i]
            else:
                tr = e[0, 0] + e[1, 1]
                s = [2 * mu * e[0, 0] + lam * tr, 2 * mu * e[1, 1] + lam * tr, lam * tr, 2 * mu * e[0, 1]][i]
            return s * v
        return LinearForm(f)

    kw = dict(uh=uh)
    if dsc.mixed:
        kw["ph"] = ph
    for i in range(4):
        bvec = asm(comp(i), dsc.sb, **kw)
        out[:, i] = lu.solve(bvec)[dsc.snode]
    return U, out


def cell_stress(dsc: Discretisation, E, nu, u):
    """Element-wise constant Cε(u_h) (exact for P1): columns xx, yy, zz, xy."""
    lam, mu = lame(E, nu)
    uh = dsc.ub.interpolate(u[:dsc.nu_dofs])
    e = sym_grad(uh)
    tr = e[0, 0] + e[1, 1]
    comps = [2 * mu * e[0, 0] + lam * tr, 2 * mu * e[1, 1] + lam * tr, lam * tr, 2 * mu * e[0, 1]]
    return np.stack([np.asarray(cmp).mean(axis=1) for cmp in comps], axis=1)
