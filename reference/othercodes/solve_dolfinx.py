"""DOLFINx 0.11 Hertz contact solve and output with DOLFINx's own writers.  Runs in
reference/.venv-dolfinx (Python 3.12, PyPI wheel dolfinx-solver-real), serial or under
`mpiexec -n 2`; started by reference/othercodes/make.py.

    python solve_dolfinx.py --mesh half_disc_p2.msh --degree 2 --vtkfile DIR [--xdmf DIR] [--vtx DIR] --info F

Problem: lower half of the disc of radius 1 centred (0, 1), top y = 1 displaced by (0, -0.01),
E = 20600, nu = 0.28, plane strain, frictionless contact with the plane y = 0 along the obstacle
normal (u_y >= -y) on the arc below y = 1/2 (facet tag 1); top tag 2; rest of the arc tag 3,
traction-free.

Contact solver: primal-dual active set (semismooth Newton) on the nodal constraints
u_y(x_i) >= -y_i at the Lagrange nodes x_i of Gamma_C.  Each step is one linear solve (PETSc
LinearProblem, MUMPS LU) with the top Dirichlet condition and u_y = -y imposed as a Dirichlet
condition (dirichletbc on V.sub(1)) at the active nodes; the nodal reaction r = K u_h (assembled
residual of the elasticity form, no conditions) gives the multipliers lambda_i = r_y(x_i) >= 0.
Update A = {i : lambda_i + c (-y_i - u_y(x_i)) > 0}, c = E; stop when A does not change.

Output: displacement `displacement` (vector P_k) and the L2 projection `stress` of C eps(u_h) onto
the continuous tensor Lagrange space P_k^{2x2}, written as DOLFINx writes them.
"""
import argparse
import json
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("UCX_TLS", "self,sm,tcp")
import dolfinx_solver  # noqa: E402,F401  (orders MPI ahead of the bindings; required by the wheel)
import numpy as np  # noqa: E402
from mpi4py import MPI  # noqa: E402
import basix.ufl  # noqa: E402
import ufl  # noqa: E402
import dolfinx  # noqa: E402
from dolfinx import fem, io, mesh as dmesh, la  # noqa: E402
from dolfinx.fem.petsc import LinearProblem  # noqa: E402

E, NU = 20600.0, 0.28
UD = (0.0, -0.01)
TAG_CONTACT, TAG_TOP, TAG_FREE = 1, 2, 3
LU = {"ksp_type": "preonly", "pc_type": "lu", "pc_factor_mat_solver_type": "mumps"}


def read_msh(path):
    """gmsh 2.2 ASCII (as written by mesh.py): nodes (N, 2), triangles (gmsh order), lines, line tags."""
    lines = Path(path).read_text().splitlines()
    i = lines.index("$Nodes")
    n = int(lines[i + 1])
    X = np.array([[float(v) for v in s.split()[1:3]] for s in lines[i + 2:i + 2 + n]])
    j = lines.index("$Elements")
    m = int(lines[j + 1])
    tri, lin, tags = [], [], []
    for s in lines[j + 2:j + 2 + m]:
        v = [int(a) for a in s.split()]
        typ, nt = v[1], v[2]
        conn = [a - 1 for a in v[3 + nt:]]
        if typ in (2, 9):
            tri.append(conn)
        elif typ in (1, 8):
            lin.append(conn)
            tags.append(v[3])
    return X, np.array(tri, dtype=np.int64), np.array(lin, dtype=np.int64), np.array(tags)


def build_mesh(comm, path, degree):
    if comm.rank == 0:
        X, tri, _, _ = read_msh(path)
        if degree == 2:  # gmsh (v0 v1 v2 m01 m12 m20) -> DOLFINx (v0 v1 v2 m12 m20 m01)
            tri = tri[:, [0, 1, 2, 4, 5, 3]]
    else:
        X = np.zeros((0, 2))
        tri = np.zeros((0, 3 if degree == 1 else 6), dtype=np.int64)
    cel = ufl.Mesh(basix.ufl.element("Lagrange", "triangle", degree, shape=(2,)))
    part = None
    if comm.size > 1:  # ghost cells across the partition boundary (shared facets)
        part = dmesh.create_cell_partitioner(dolfinx.graph.partitioner(), dmesh.GhostMode.shared_facet, 2)
    return dmesh.create_mesh(comm, tri, cel, X, partitioner=part)


def facet_tags(msh):
    fdim = 1
    msh.topology.create_connectivity(fdim, 2)
    top = dmesh.locate_entities_boundary(msh, fdim, lambda x: np.isclose(x[1], 1.0, atol=1e-12))
    con = dmesh.locate_entities_boundary(msh, fdim, lambda x: x[1] <= 0.5 + 1e-9)
    allb = dmesh.exterior_facet_indices(msh.topology)
    free = np.setdiff1d(allb, np.union1d(top, con))
    idx = np.concatenate([con, top, free]).astype(np.int32)
    val = np.concatenate([np.full(len(con), TAG_CONTACT), np.full(len(top), TAG_TOP),
                          np.full(len(free), TAG_FREE)]).astype(np.int32)
    o = np.argsort(idx)
    ft = dmesh.meshtags(msh, fdim, idx[o], val[o])
    ft.name = "facet_tags"
    return ft


def versions():
    import basix, ffcx, petsc4py, mpi4py
    from importlib.metadata import version
    return dict(dolfinx=dolfinx.__version__, dolfinx_solver_real=version("dolfinx-solver-real"),
                basix=basix.__version__, ffcx=ffcx.__version__, ufl=ufl.__version__, petsc4py=petsc4py.__version__,
                mpi4py=mpi4py.__version__, mpich=version("mpich"), numpy=np.__version__,
                python=sys.version.split()[0])


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--mesh", required=True)
    ap.add_argument("--degree", type=int, default=2)
    ap.add_argument("--vtkfile", default=None, help="folder for io.VTKFile output solution.pvd")
    ap.add_argument("--xdmf", default=None, help="folder for io.XDMFFile output solution.xdmf + .h5")
    ap.add_argument("--vtx", default=None, help="folder for io.VTXWriter output solution.bp (ADIOS2 BP4)")
    ap.add_argument("--info", default=None, help="solver info JSON (rank 0)")
    a = ap.parse_args()
    comm = MPI.COMM_WORLD
    t0 = time.perf_counter()
    k = a.degree
    msh = build_mesh(comm, a.mesh, k)
    ft = facet_tags(msh)
    fdim = 1
    V = fem.functionspace(msh, ("Lagrange", k, (2,)))
    mu = E / (2 * (1 + NU))
    lam = E * NU / ((1 + NU) * (1 - 2 * NU))

    def eps(w):
        return ufl.sym(ufl.grad(w))

    def sigma(w):
        return lam * ufl.tr(eps(w)) * ufl.Identity(2) + 2 * mu * eps(w)

    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    a_form = ufl.inner(sigma(u), eps(v)) * ufl.dx
    L_form = ufl.inner(fem.Constant(msh, np.zeros(2)), v) * ufl.dx
    uh = fem.Function(V, name="displacement")
    res_form = fem.form(ufl.inner(sigma(uh), eps(v)) * ufl.dx)

    top_f = ft.find(TAG_TOP)
    con_f = ft.find(TAG_CONTACT)
    top_nodes = fem.locate_dofs_topological(V, fdim, top_f)          # block (node) indices
    bc_top = fem.dirichletbc(np.array(UD, dtype=np.float64), top_nodes, V)
    V1, _ = V.sub(1).collapse()
    dV, dV1 = fem.locate_dofs_topological((V.sub(1), V1), fdim, con_f)  # unrolled y dofs of V, dofs of V1
    gy = fem.Function(V1)
    gy.interpolate(lambda x: -x[1])
    xc = V1.tabulate_dof_coordinates()[dV1, :2]
    yc = xc[:, 1]
    bs = V.dofmap.index_map_bs
    n_owned = V.dofmap.index_map.size_local * bs
    owned = dV < n_owned
    ytop = 2 * top_nodes + 1
    ytop_owned = ytop[ytop < n_owned]
    xtop_owned = ytop_owned - 1

    def gsum(x):
        return comm.allreduce(float(np.sum(x)), op=MPI.SUM)

    def gmax(x):
        return comm.allreduce(float(np.max(x)) if len(x) else -np.inf, op=MPI.MAX)

    def gmin(x):
        return comm.allreduce(float(np.min(x)) if len(x) else np.inf, op=MPI.MIN)

    c = E
    active = yc + UD[1] < 0  # rigid translation would penetrate
    history = []
    for it in range(1, 101):
        bcs = [bc_top]
        if comm.allreduce(int(active.sum()), op=MPI.SUM) > 0:
            bcs.append(fem.dirichletbc(gy, [dV[active].astype(np.int32), dV1[active].astype(np.int32)], V.sub(1)))
        prob = LinearProblem(a_form, L_form, bcs=bcs, u=uh, petsc_options_prefix=f"pdas{it}_", petsc_options=LU)
        prob.solve()
        uh.x.scatter_forward()
        r = fem.assemble_vector(res_form)
        r.scatter_reverse(la.InsertMode.add)
        r.scatter_forward()
        lam_c = r.array[dV]
        gap = -yc - uh.x.array[dV]  # <= 0 admissible
        new = lam_c + c * gap > 0
        changed = comm.allreduce(int((new != active)[owned].sum()), op=MPI.SUM)
        n_act = comm.allreduce(int(active[owned].sum()), op=MPI.SUM)
        history.append(dict(it=it, active=n_act, changed=changed))
        if changed == 0:
            break
        active = new
    ncp = gmax(np.abs(np.minimum(lam_c, -c * gap))[owned]) / max(gmax(lam_c[owned]), 1e-300)
    P = -gsum(r.array[ytop_owned])
    Fx = gsum(r.array[xtop_owned])
    lam_o, x_o = lam_c[owned], xc[owned, 0]
    contact_force = gsum(lam_o)
    act_o = active[owned]
    a_mom = 2 * np.sqrt(gsum(lam_o * x_o ** 2) / contact_force)
    t_solve = time.perf_counter() - t0

    # L2 projection of C eps(u_h) onto the continuous tensor Lagrange space of degree k
    W = fem.functionspace(msh, ("Lagrange", k, (2, 2)))
    T, S = ufl.TrialFunction(W), ufl.TestFunction(W)
    sig = fem.Function(W, name="stress")
    LinearProblem(ufl.inner(T, S) * ufl.dx, ufl.inner(sigma(uh), S) * ufl.dx, u=sig,
                  petsc_options_prefix="proj_", petsc_options=LU).solve()
    sig.x.scatter_forward()

    written = []
    for kind in ("vtkfile", "xdmf", "vtx"):
        d = getattr(a, kind)
        if d is None:
            continue
        out = Path(d)
        if comm.rank == 0:
            out.mkdir(parents=True, exist_ok=True)
        comm.barrier()
        if kind == "vtkfile":
            with io.VTKFile(comm, out / "solution.pvd", "w") as f:
                f.write_function([uh, sig], 0.0)
        elif kind == "xdmf":
            with io.XDMFFile(comm, out / "solution.xdmf", "w") as f:
                f.write_mesh(msh)
                f.write_meshtags(ft, msh.geometry)
                f.write_function(uh, 0.0)
                f.write_function(sig, 0.0)
        else:
            with io.VTXWriter(comm, out / "solution.bp", [uh, sig], engine="BP4") as f:
                f.write(0.0)
        written.append(kind)

    ncells = comm.allreduce(msh.topology.index_map(2).size_local, op=MPI.SUM)
    nghost = comm.allreduce(msh.topology.index_map(2).num_ghosts, op=MPI.SUM)
    info = dict(
        library="DOLFINx", versions=versions(), mpi_ranks=comm.size,
        method=("primal-dual active set (semismooth Newton) on nodal constraints; active nodes as Dirichlet "
                "conditions u_y = -y (dirichletbc on V.sub(1)), one MUMPS LU solve per step (LinearProblem)"),
        element=f"P{k} displacement" + (", P2 (isoparametric) geometry, curved arc" if k == 2 else ", P1 geometry"),
        stress=f"L2 projection onto continuous Lagrange P{k} tensor (2x2) space, MUMPS LU",
        dofs=int(V.dofmap.index_map.size_global * bs), cells=int(ncells), ghost_cells=int(nghost),
        iterations=len(history), final_residual=ncp, history=history,
        reaction_top=dict(P=P, Fx=Fx),
        contact_force_multipliers=contact_force,
        active_nodes=comm.allreduce(int(act_o.sum()), op=MPI.SUM),
        contact_nodes=comm.allreduce(int(owned.sum()), op=MPI.SUM),
        active_x_range=[gmin(x_o[act_o]), gmax(x_o[act_o])],
        penetration_max_nodes=max(gmax(gap[owned]), 0.0),
        a_moment_multipliers=float(a_mom),
        written=written, time_s=time.perf_counter() - t0, time_solve_s=t_solve,
    )
    info["active_half_width"] = 0.5 * (info["active_x_range"][1] - info["active_x_range"][0])
    if comm.rank == 0:
        txt = json.dumps(info, indent=1)
        if a.info:
            Path(a.info).write_text(txt + "\n")
        print(f"DOLFINx P{k} ranks={comm.size}: P={P:.10g} contact={contact_force:.10g} it={len(history)} "
              f"active={info['active_nodes']} hw={info['active_half_width']:.5f} t={info['time_s']:.1f}s")


if __name__ == "__main__":
    main()
