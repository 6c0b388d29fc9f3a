"""NGSolve side of `cargo bench --bench reconstruct`: the global least-squares stress
reconstruction on the benchmark's structured meshes, timed (assembly, factorisation, solve) with
its peak memory; one JSON line per case on stdout.

    reference/.venv/bin/python reference/reconstruct_bench/ngsolve_lsq.py --cells 100000 --order 1
        [--threads 2] [--inverse sparsecholesky] [--repeat 2]

The problem is the one `fosls::reconstruct::stress::reconstruct` solves for the bench scene
(`benches/reconstruct.rs`), *without the sign constraint*:

    sigma_h = argmin { F(u_h, tau) : tau in RT_k(T_h)^2 row-wise, tau n = 0 on the sides,
                                      tau_t = 0 on the contact bottom }

  - unit square, n x n squares each cut along the diagonal (a, c): 2 n^2 triangles,
    n = round(sqrt(cells / 2)); vertex (i, j) at (i/n, j/n) (k = 0: the P1 mesh of the bench;
    k = 1: the vertices of its P2 mesh, whose mid nodes sit at (i_a + i_b)/(2n) etc.);
  - u_h = the P_{k+1} nodal interpolant of u, `--displacement liftoff` (default, the timed
    cases): u = (1e-3 sin(xy), -1e-2 y (1 - 1.5 x) + 1e-4 x^2), tensile C eps(u) on the bottom
    for x > 2/3, so the dropped constraint would be active there (max_tau_n > 0 here);
    `--displacement compressed`: u = (1e-3 sin(xy), -1e-2 y + 1e-3 x^2), the unconstrained
    minimiser already has tau_n < 0 everywhere, so fosls (with the constraint) and this script
    solve the same problem and F must agree;
  - E = 20600, nu = 0.28, plane strain, energy norm, w_d = l^2/(2 mu), l = sqrt(2)/pi
    (diameter / pi, the default of fosls);
  - top y = 1: Dirichlet (no condition on tau); sides x = 0, 1: traction free (tau n = 0,
    essential, both rows); bottom y = 0: frictionless contact with the plane y = 0,
    normal = "obstacle": n = (0, -1), t = (1, 0), g = y, u_n = -u_y, tau_n = tau_yy,
    tau_t = -tau_xy. tau_t = 0 is essential (row 0 of tau has zero normal trace there); the
    inequality tau_n <= 0 is DROPPED, so the bottom's row-1 normal trace is free and the
    complementarity term <u_n - g, tau_n> is a plain linear term.

Minimising F(tau) = 1/2 Q(tau, tau) - l(tau) + c0 with (energy norm, C A = I)

    Q(tau, s) = int A tau : s + w_d div tau . div s dx,
    l(s)      = int eps(u_h) : s dx - int_bottom (u_n - g) s_n ds

is one SPD solve. Timed: assembly of Q and l, factorisation (`inverse=`, default NGSolve's own
"sparsecholesky"; "umfpack" also works, MKL pardiso is not installed here), solve. Best of
`--repeat`. Peak memory: ru_maxrss of this process (fresh process per case); `base_mib` is the RSS
before the first assembly (interpreter, NGSolve, mesh, u_h). F at the minimiser is evaluated in
difference form (squares of pointwise differences), as fosls does.
"""
import argparse
import json
import math
import resource
import time

import netgen.meshing as ngm
import ngsolve as ng
import numpy as np

E, NU = 20600.0, 0.28
MU = E / (2 * (1 + NU))
LAM = E * NU / ((1 + NU) * (1 - 2 * NU))
ELL = math.sqrt(2.0) / math.pi
W_D = ELL * ELL / (2 * MU)


DISPLACEMENT = "liftoff"


def u_exact(x, y):
    """The bench's displacements (benches/reconstruct.rs `Disp`)."""
    if DISPLACEMENT == "compressed":
        return np.stack([1e-3 * np.sin(x * y), -1e-2 * y + 1e-3 * x * x], axis=-1)
    return np.stack([1e-3 * np.sin(x * y), -1e-2 * y * (1.0 - 1.5 * x) + 1e-4 * x * x], axis=-1)


def rss_mib(key="VmRSS"):
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith(key + ":"):
                return int(line.split()[1]) / 1024.0
    return float("nan")


def build_mesh(n):
    """Structured mesh of the unit square, vertices in the bench's order (index j(n+1) + i)."""
    m = n + 1
    i, j = np.meshgrid(np.arange(m), np.arange(m))
    pts = np.stack([i.ravel() / n, j.ravel() / n, np.zeros(m * m)], axis=1)
    ii, jj = np.meshgrid(np.arange(n), np.arange(n))
    ii, jj = ii.ravel(), jj.ravel()
    a = jj * m + ii
    b = a + 1
    c = a + m + 1
    d = a + m
    tris = np.empty((2 * n * n, 3), dtype=np.int32)
    tris[0::2] = np.stack([a, b, c], axis=1)
    tris[1::2] = np.stack([a, c, d], axis=1)
    ngmesh = ngm.Mesh(dim=2)
    ngmesh.AddPoints(np.ascontiguousarray(pts))
    fd = ngmesh.Add(ngm.FaceDescriptor(surfnr=1, domin=1, bc=1))
    ngmesh.AddElements(dim=2, index=fd, data=tris, base=0)
    ngmesh.SetMaterial(1, "body")
    k = np.arange(n)
    # Boundary segments with the body on their left: bottom, right, top, left.
    segs = [
        np.stack([k, k + 1], axis=1),  # bottom: (i, 0) -> (i + 1, 0)
        np.stack([k * m + n, (k + 1) * m + n], axis=1),  # right
        np.stack([n * m + n - k, n * m + n - k - 1], axis=1),  # top, right to left
        np.stack([(n - k) * m, (n - k - 1) * m], axis=1),  # left, top to bottom
    ]
    for idx, s in enumerate(segs):
        ngmesh.AddElements(dim=1, index=idx + 1, data=np.ascontiguousarray(s, dtype=np.int32),
                           base=0)
    for idx, name in enumerate(["bottom", "right", "top", "left"]):
        ngmesh.SetBCName(idx, name)
    return ng.Mesh(ngmesh), pts[:, :2]


def set_displacement(mesh, pts, n, degree):
    """u_h in VectorH1(order=degree) with the nodal values of the bench's P_degree field."""
    U = ng.VectorH1(mesh, order=degree)
    u = ng.GridFunction(U)
    vals = u_exact(pts[:, 0], pts[:, 1])
    nv = mesh.nv
    if degree == 2:
        # Mid node values: at ((i_a + i_b)/(2n), (j_a + j_b)/(2n)), the bench's node coordinates.
        m = n + 1
        ev = np.array([[v.nr for v in ed.vertices] for ed in mesh.edges], dtype=np.int64)
        ia, ja = ev[:, 0] % m, ev[:, 0] // m
        ib, jb = ev[:, 1] % m, ev[:, 1] // m
        xm = (ia + ib) / (2 * n)
        ym = (ja + jb) / (2 * n)
        umid = u_exact(xm, ym)
        # Value of an order-2 edge shape function at its edge's mid point (-1/8 in 6.2.2608).
        H = ng.H1(mesh, order=2)
        g = ng.GridFunction(H)
        e0 = mesh.edges[0]
        g.vec[H.GetDofNrs(e0)[0]] = 1.0
        pa, pb = (mesh.vertices[v.nr].point for v in e0.vertices)
        cmid = g(mesh(0.5 * (pa[0] + pb[0]), 0.5 * (pa[1] + pb[1])))
    for comp in range(2):
        gc = u.components[comp]
        V = gc.space
        vec = gc.vec.FV().NumPy()
        vdofs = np.array([V.GetDofNrs(ng.NodeId(ng.VERTEX, v))[0] for v in range(nv)])
        vec[vdofs] = vals[:, comp]
        if degree == 2:
            edofs = np.array([V.GetDofNrs(ng.NodeId(ng.EDGE, e))[0] for e in range(len(ev))])
            vec[edofs] = (umid[:, comp] - 0.5 * (vals[ev[:, 0], comp] + vals[ev[:, 1], comp])) / cmid
    return u


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--cells", type=int, required=True)
    ap.add_argument("--order", type=int, choices=[0, 1], required=True)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--inverse", default="sparsecholesky")
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--displacement", choices=["liftoff", "compressed"], default="liftoff")
    ap.add_argument("--check-nodal", action="store_true",
                    help="assert that u_h equals u at the P2 mid nodes (slow, small meshes)")
    args = ap.parse_args()
    global DISPLACEMENT
    DISPLACEMENT = args.displacement

    n = int(round(math.sqrt(args.cells / 2)))
    k = args.order
    ng.SetNumThreads(args.threads)
    mesh, pts = build_mesh(n)
    u = set_displacement(mesh, pts, n, k + 1)
    if args.check_nodal and k == 1:
        for ed in list(mesh.edges)[:50]:
            pa, pb = (mesh.vertices[v.nr].point for v in ed.vertices)
            xm, ym = 0.5 * (pa[0] + pb[0]), 0.5 * (pa[1] + pb[1])
            assert np.allclose(u(mesh(xm, ym)), u_exact(np.array(xm), np.array(ym)), atol=1e-15)

    ctr = LAM / (2 * MU + 2 * LAM)

    def A(T):
        return (T - ctr * ng.Trace(T) * ng.Id(2)) / (2 * MU)

    X = (ng.HDiv(mesh, order=k, RT=True, dirichlet="left|right|bottom")
         * ng.HDiv(mesh, order=k, RT=True, dirichlet="left|right"))
    (t0, t1), (s0, s1) = X.TnT()
    T = ng.CF((t0, t1), dims=(2, 2))
    S = ng.CF((s0, s1), dims=(2, 2))
    nrm = ng.specialcf.normal(2)
    eps = ng.Sym(ng.Grad(u))
    gap_un = -u[1] - ng.y  # u_n - g on the bottom (n = (0, -1), g = y)
    # tau_n = n . (tau n_Omega) = -(row 1 . n_Omega) on the bottom.
    base = rss_mib()

    best = None
    sol = ng.GridFunction(X)
    for _ in range(args.repeat):
        with ng.TaskManager():
            t_0 = time.perf_counter()
            a = ng.BilinearForm(X, symmetric=True)
            a += (ng.InnerProduct(A(T), S) + W_D * (ng.div(t0) * ng.div(s0) + ng.div(t1) * ng.div(s1))) * ng.dx
            f = ng.LinearForm(X)
            f += ng.InnerProduct(eps, S) * ng.dx
            f += -gap_un * (-(s1.Trace() * nrm)) * ng.ds("bottom")
            a.Assemble()
            f.Assemble()
            t_1 = time.perf_counter()
            inv = a.mat.Inverse(X.FreeDofs(), inverse=args.inverse)
            t_2 = time.perf_counter()
            sol.vec.data = inv * f.vec
            t_3 = time.perf_counter()
        times = (t_1 - t_0, t_2 - t_1, t_3 - t_2)
        if best is None or sum(times) < sum(best):
            best = times
        nze = a.mat.nze
        del inv, a, f
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0

    s0h, s1h = sol.components
    Sig = ng.CF((s0h, s1h), dims=(2, 2))
    e = eps - A(Sig)
    with ng.TaskManager():
        f_const = ng.Integrate(MU * ng.InnerProduct(e, e) + 0.5 * LAM * ng.Trace(e) ** 2, mesh,
                               order=2 * k + 4)
        f_div = ng.Integrate(0.5 * W_D * (ng.div(s0h) ** 2 + ng.div(s1h) ** 2), mesh, order=2 * k + 2)
        f_comp = ng.Integrate(gap_un * (-(s1h * nrm)), mesh, ng.BND, definedon=mesh.Boundaries("bottom"),
                              order=2 * k + 4)
        energy = ng.Integrate(MU * ng.InnerProduct(eps, eps) + 0.5 * LAM * ng.Trace(eps) ** 2, mesh,
                              order=2 * k + 2)
    # Largest tau_n at the bottom (the sign constraint that was dropped), at the edge end points
    # and mid points.
    xs = np.linspace(0.0, 1.0, 2 * n + 1)
    mp = mesh(xs, np.zeros_like(xs), VOL_or_BND=ng.BND)
    taun = -(s1h * nrm)(mp).ravel()
    print(json.dumps({
        "tool": "ngsolve", "version": ng.__version__, "cells": mesh.ne, "order": k,
        "displacement": args.displacement,
        "threads": args.threads, "inverse": args.inverse, "unknowns": X.ndof,
        "free": int(sum(X.FreeDofs())), "nonzeros": nze,
        "assemble": best[0], "factor": best[1], "solve": best[2], "time": sum(best),
        "peak_mib": peak, "base_mib": base,
        "F": f_const + f_div + f_comp, "constitutive": f_const, "equilibrium": f_div,
        "complementarity": f_comp, "energy": energy, "max_tau_n": float(taun.max()),
    }), flush=True)


if __name__ == "__main__":
    main()
