"""PyMFEM 4.10 (serial) Hertz contact solve and output with MFEM's ParaViewDataCollection.  Runs in
reference/.venv-mfem (Python 3.12, PyPI wheel mfem); started by reference/othercodes/make.py.

    python solve_mfem.py --mesh half_disc_p2.msh --order 2 --out DIR --high-order 1|0 [--lod 2]

Mesh: the gmsh 2.2 file of mesh.py, read by mfem.Mesh; its 6-node triangles make MFEM set up an
order-2 nodal curvature (H1 P2 mesh nodes, curved arc).  Element attribute 1; boundary attributes
1 = Gamma_C (arc, y <= 1/2), 2 = top, 3 = rest of the arc (traction-free).

Problem as in solve_dolfinx.py (E = 20600, nu = 0.28, plane strain: ElasticityIntegrator(lambda, mu)).
Contact solver: primal-dual active set on the nodal constraints u_y(x_i) >= -y_i at the H1 nodes of
boundary attribute 1; each step re-assembles the BilinearForm and solves with the top dofs and the
active y dofs as essential dofs (FormLinearSystem, u_y = -y there), PCG + Gauss-Seidel smoother,
relative tolerance 1e-14; multipliers lambda_i = (K u)_y at the contact nodes from the unconstrained
matrix; A = {i : lambda_i + E (-y_i - u_y(x_i)) > 0}; stop when A does not change.

Output: `displacement` (vector H1 P_k) and `stress` = L2 projection of C eps(u_h) onto the scalar
H1 P_k space, component by component (mass matrix, PCG), stored as one vector GridFunction with
vdim 3 in MFEM's Voigt order (xx, yy, xy), ordering byNODES.  ParaViewDataCollection "solution",
SetLevelsOfDetail(lod), SetHighOrderOutput(high_order), other settings MFEM's defaults.
"""
import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np
import mfem
import mfem.ser as M

E, NU = 20600.0, 0.28
UD = (0.0, -0.01)
ATTR_CONTACT, ATTR_TOP, ATTR_FREE = 1, 2, 3


def pcg(A, B, X, prec, rtol=1e-14, maxit=50000):
    s = M.CGSolver()
    s.SetRelTol(rtol)
    s.SetAbsTol(0.0)
    s.SetMaxIter(maxit)
    s.SetPrintLevel(0)
    s.SetPreconditioner(prec)
    s.SetOperator(A)
    s.Mult(B, X)
    return s.GetNumIterations(), s.GetFinalNorm(), s.GetConverged()


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--mesh", required=True)
    ap.add_argument("--order", type=int, default=2)
    ap.add_argument("--out", required=True)
    ap.add_argument("--high-order", type=int, default=1)
    ap.add_argument("--lod", type=int, default=None, help="SetLevelsOfDetail (default: the order)")
    ap.add_argument("--info", default=None)
    a = ap.parse_args()
    t0 = time.perf_counter()
    k = a.order
    mesh = M.Mesh(a.mesh, 1, 1)
    dim = mesh.Dimension()
    curv = mesh.GetNodes()
    mesh_order = curv.FESpace().GetMaxElementOrder() if curv is not None else 1
    fec = M.H1_FECollection(k, dim)
    fes = M.FiniteElementSpace(mesh, fec, dim, M.Ordering.byNODES)
    sfes = M.FiniteElementSpace(mesh, fec, 1)
    n = sfes.GetNDofs()
    # physical coordinates of the H1 nodes (mesh nodes projected onto fes)
    xyz = M.GridFunction(fes)
    mesh.GetNodes(xyz)
    XY = xyz.GetDataArray().copy().reshape(dim, n).T

    def tdofs(attr, comp=-1):
        m = M.intArray(mesh.bdr_attributes.Max())
        m.Assign(0)
        m[attr - 1] = 1
        out = M.intArray()
        fes.GetEssentialTrueDofs(m, out, comp)
        return np.array(out.ToList(), dtype=np.int64)

    top = tdofs(ATTR_TOP)             # both components
    cy = tdofs(ATTR_CONTACT, 1)        # y dofs on Gamma_C
    cy = np.setdiff1d(cy, top)
    cnode = cy - n
    yc = XY[cnode, 1]
    xc = XY[cnode, 0]
    mu = E / (2 * (1 + NU))
    lam = E * NU / ((1 + NU) * (1 - 2 * NU))
    lam_c, mu_c = M.ConstantCoefficient(lam), M.ConstantCoefficient(mu)

    def stiffness():
        bf = M.BilinearForm(fes)
        bf.AddDomainIntegrator(M.ElasticityIntegrator(lam_c, mu_c))
        bf.Assemble()
        return bf

    K0 = stiffness()
    K0.Finalize()
    Kfull = K0.SpMat()
    zero = M.LinearForm(fes)
    zero.Assemble()
    x = M.GridFunction(fes)
    c = E
    active = yc + UD[1] < 0
    history = []
    lin_its = []
    for it in range(1, 101):
        ess = np.concatenate([top, cy[active]])
        xa = np.zeros(fes.GetVSize())
        xa[top[top < n]] = UD[0]
        xa[top[top >= n]] = UD[1]
        xa[cy[active]] = -yc[active]
        x.Assign(xa)
        bf = stiffness()
        ess_list = M.intArray(list(int(i) for i in ess))
        A = M.OperatorPtr()
        B, X = M.Vector(), M.Vector()
        b = M.LinearForm(fes)
        b.Assemble()
        bf.FormLinearSystem(ess_list, x, b, A, X, B)
        Am = M.OperatorHandle2SparseMatrix(A)
        prec = M.GSSmoother(Am)
        nit, fnorm, conv = pcg(Am, B, X, prec)
        if not conv:
            raise RuntimeError(f"PCG did not converge ({nit} its, {fnorm})")
        lin_its.append(int(nit))
        bf.RecoverFEMSolution(X, b, x)
        u = x.GetDataArray().copy()
        r = M.Vector(fes.GetVSize())
        Kfull.Mult(x, r)
        r = r.GetDataArray().copy()
        lam_n = r[cy]
        gap = -yc - u[cy]
        new = lam_n + c * gap > 0
        changed = int((new != active).sum())
        history.append(dict(it=it, active=int(active.sum()), changed=changed, pcg_iterations=int(nit)))
        if changed == 0:
            break
        active = new
    ncp = float(np.abs(np.minimum(lam_n, -c * gap)).max() / lam_n.max())
    P = -float(r[top[top >= n]].sum())
    Fx = float(r[top[top < n]].sum())
    free = np.ones(fes.GetVSize(), bool)
    free[np.concatenate([top, cy])] = False
    contact_force = float(lam_n.sum())
    t_solve = time.perf_counter() - t0

    # L2 projection of C eps(u_h) onto scalar H1 P_k, per component (xx, yy, xy)
    ux, uy = M.GridFunction(sfes), M.GridFunction(sfes)
    ux.Assign(u[:n].copy())
    uy.Assign(u[n:].copy())
    gx, gy = M.GradientGridFunctionCoefficient(ux), M.GradientGridFunctionCoefficient(uy)
    ex, ey = M.VectorConstantCoefficient(M.Vector([1.0, 0.0])), M.VectorConstantCoefficient(M.Vector([0.0, 1.0]))
    dxux, dyux = M.InnerProductCoefficient(gx, ex), M.InnerProductCoefficient(gx, ey)
    dxuy, dyuy = M.InnerProductCoefficient(gy, ex), M.InnerProductCoefficient(gy, ey)
    comps = [M.SumCoefficient(dxux, dyuy, lam + 2 * mu, lam),   # xx
             M.SumCoefficient(dxux, dyuy, lam, lam + 2 * mu),   # yy
             M.SumCoefficient(dyux, dxuy, mu, mu)]              # xy
    mass = M.BilinearForm(sfes)
    mass.AddDomainIntegrator(M.MassIntegrator())
    mass.Assemble()
    mass.Finalize()
    Ms = mass.SpMat()
    mprec = M.DSmoother(Ms)
    svals = []
    for cf in comps:
        lf = M.LinearForm(sfes)
        lf.AddDomainIntegrator(M.DomainLFIntegrator(cf, 2, 2))
        lf.Assemble()
        s = M.GridFunction(sfes)
        s.Assign(0.0)
        nit, fnorm, conv = pcg(Ms, lf, s, mprec)
        assert conv
        svals.append(s.GetDataArray().copy())
    vfes3 = M.FiniteElementSpace(mesh, fec, 3, M.Ordering.byNODES)
    sig = M.GridFunction(vfes3)
    sig.Assign(np.concatenate(svals))

    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    lod = a.lod if a.lod is not None else k
    pd = M.ParaViewDataCollection("solution", mesh)
    pd.SetPrefixPath(str(out))
    pd.SetLevelsOfDetail(lod)
    pd.SetHighOrderOutput(bool(a.high_order))
    pd.RegisterField("displacement", x)
    pd.RegisterField("stress", sig)
    pd.SetCycle(0)
    pd.SetTime(0.0)
    pd.Save()

    from importlib.metadata import version
    xa_ = xc[active]
    info = dict(
        library="MFEM (PyMFEM)", versions=dict(mfem=version("mfem"), numpy=np.__version__, python=sys.version.split()[0]),
        method=("primal-dual active set (semismooth Newton) on nodal constraints; active nodes as essential dofs "
                "u_y = -y (FormLinearSystem), PCG + GSSmoother (rel. tol. 1e-14) per step"),
        element=f"H1 P{k} displacement, mesh curvature order {mesh_order} (gmsh 6-node triangles)",
        stress=f"L2 projection per component onto H1 P{k} (MassIntegrator, DomainLFIntegrator order 2p+2), vdim 3 (xx, yy, xy)",
        dofs=int(fes.GetVSize()), cells=int(mesh.GetNE()), boundary_elements=int(mesh.GetNBE()),
        iterations=len(history), final_residual=ncp, history=history,
        reaction_top=dict(P=P, Fx=Fx), contact_force_multipliers=contact_force,
        free_dof_residual_max=float(np.abs(r[free]).max()),
        active_nodes=int(active.sum()), contact_nodes=int(len(cy)),
        active_x_range=[float(xa_.min()), float(xa_.max())],
        active_half_width=0.5 * float(xa_.max() - xa_.min()),
        penetration_max_nodes=max(float(gap.max()), 0.0),
        a_moment_multipliers=float(2 * np.sqrt((lam_n * xc ** 2).sum() / lam_n.sum())),
        paraview=dict(levels_of_detail=lod, high_order_output=bool(a.high_order),
                      data_format="binary" if pd.IsBinaryFormat() else "ascii", compression_level=pd.GetCompressionLevel()),
        time_s=time.perf_counter() - t0, time_solve_s=t_solve,
    )
    if a.info:
        Path(a.info).write_text(json.dumps(info, indent=1) + "\n")
    print(f"MFEM P{k} high_order={bool(a.high_order)}: P={P:.10g} contact={contact_force:.10g} it={len(history)} "
          f"active={info['active_nodes']} hw={info['active_half_width']:.5f} pcg={lin_its} t={info['time_s']:.1f}s")


if __name__ == "__main__":
    main()
