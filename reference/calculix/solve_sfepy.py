"""sfepy 2026.3 solve of the Hertz problem (runs in reference/.venv-calculix, Python 3.12).

    reference/.venv-calculix/bin/python reference/calculix/solve_sfepy.py --mesh MESH.npz --out DIR --info INFO.json

Lower half disc (radius 1, centre (0, 1)), top y = 1 displaced by (0, -0.01), E = 20600, nu = 0.28, plane
strain, P2 displacement on the straight-sided netgen triangles of MESH.npz (the vertices and triangles of
the committed hertz_* mesh; sfepy's P2 on '2_3' cells has affine geometry, so the arc mid nodes are on the
chords).  Contact with the rigid plane y = 0 by sfepy's penalty contact-plane term: sfepy's
`dw_contact_plane` (sfepy.terms.terms_surface.ContactPlaneTerm) declares geometries '3_4', '3_8' only
(its ContactPlane rotates the plane onto z = const and masks points by a polygon), so this script
registers `dw_contact_plane_2d`: the same term class (same force law f(d) = k d for d > 0, f0 = 0, same
weak form  int_Gamma v . f(d(u)) n,  d(u) = (X + u - A) . n,  same Jacobian) with geometries ['2_3'] and a
2D plane whose mask keeps the facet quadrature points whose x lies in [bounds x min, bounds x max].
A = (0, 0), n = (0, -1) (pointing into the obstacle y < 0, as in sfepy's example), Gamma = arc below
y = 1/2 (a boundary facet region).  Semismooth Newton (nls.newton, ls.scipy_direct) from u = 0 in one
load step, penalty k = K_PENALTY.

Output as sfepy writes it by default: `pb.save_state('hertz.vtk', out=out)` (legacy VTK, sfepy's own
VTKMeshIO), `out` = the displacement's default create_output (linearization 'strip': P2 values at the
vertices only, on the 3-node triangles) and the Cauchy stress `ev_cauchy_stress ... mode='el_avg'` as
cell data (the usual sfepy post-processing).  --info gets the solver's numbers: top reaction and contact
force from the assembled residual vectors, penetration and the active (force > 0) quadrature points.
"""
import argparse
import json
import math
import os
import platform
import sys
import time
from pathlib import Path

import numpy as nm

E, NU, UD = 20600.0, 0.28, -0.01
K_PENALTY = 2.0e8
INTEGRAL_ORDER = 6     # facet quadrature of the contact term (exact for P2 traces times P2 test functions x 2)
X_BOUNDS = (-0.5, 0.5)  # the plane's extent in x (the contact zone |x| < 0.08 is far inside)


def register_contact_plane_2d():
    from sfepy.base.base import Struct
    from sfepy.terms import register_term
    from sfepy.terms.terms_surface import ContactPlaneTerm

    class ContactPlane2D(Struct):
        """The line through `anchor` with unit `normal`; points are masked by their x coordinate
        within the x-range of `bounds` (2D counterpart of sfepy.mechanics.contact_bodies.ContactPlane)."""

        def __init__(self, anchor, normal, bounds):
            n = nm.asarray(normal, dtype=nm.float64)
            Struct.__init__(self, anchor=nm.asarray(anchor, dtype=nm.float64), normal=n / nm.linalg.norm(n),
                            bounds=nm.asarray(bounds, dtype=nm.float64))
            self.adotn = float(self.anchor @ self.normal)

        def mask_points(self, points):
            x = points[:, 0]
            return (x >= self.bounds[:, 0].min()) & (x <= self.bounds[:, 0].max())

        def get_distance(self, points):
            return points @ self.normal - self.adotn

    class ContactPlane2DTerm(ContactPlaneTerm):
        """sfepy's dw_contact_plane for 2D triangles (see the module docstring)."""
        name = "dw_contact_plane_2d"
        geometries = ["2_3"]

        def get_fargs(self, force_pars, normal, anchor, bounds, virtual, state, mode=None, term_mode=None,
                      diff_var=None, **kwargs):
            if self.cp is None:
                self.cp = ContactPlane2D(anchor, normal, bounds)
            return ContactPlaneTerm.get_fargs(self, force_pars, normal, anchor, bounds, virtual, state, mode,
                                              term_mode, diff_var, **kwargs)

    register_term(ContactPlane2DTerm)
    return ContactPlane2DTerm


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--mesh", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--info", required=True)
    a = ap.parse_args(argv)
    t0 = time.perf_counter()

    import sfepy
    from sfepy.base.base import Struct, output
    from sfepy.discrete import FieldVariable, Material, Integral, Equation, Equations, Problem
    from sfepy.discrete.conditions import Conditions, EssentialBC
    from sfepy.discrete.fem import Mesh, FEDomain, Field
    from sfepy.mechanics.matcoefs import stiffness_from_youngpoisson
    from sfepy.solvers.ls import ScipyDirect
    from sfepy.solvers.nls import Newton
    from sfepy.terms import Term

    output.set_output(quiet=True)
    register_contact_plane_2d()

    d = nm.load(a.mesh)
    coors, conn = d["p"].astype(nm.float64), d["t"].astype(nm.int32)
    mesh = Mesh.from_data("hertz", coors, nm.zeros(len(coors), dtype=nm.int32), [conn],
                          [nm.zeros(len(conn), dtype=nm.int32)], ["2_3"])
    domain = FEDomain("domain", mesh)
    omega = domain.create_region("Omega", "all")
    top = domain.create_region("Top", "vertices in (y > 0.9999)", "facet")
    gamma = domain.create_region("Contact", "vertices of surface *v vertices in (y < 0.5000001)", "facet")

    field = Field.from_args("displacement", nm.float64, "vector", omega, approx_order=2)
    u = FieldVariable("u", "unknown", field)
    v = FieldVariable("v", "test", field, primary_var_name="u")

    solid = Material("solid", D=stiffness_from_youngpoisson(2, E, NU, plane="strain"))
    bounds = nm.array([[X_BOUNDS[0], 0.0], [X_BOUNDS[1], 0.0]])
    cp = Material("cp", values={"f": [K_PENALTY, 0.0], ".n": [0.0, -1.0], ".a": [0.0, 0.0], ".bs": bounds})
    i2 = Integral("i2", order=2)                      # exact for the P2 stiffness on affine triangles
    ic = Integral("ic", order=INTEGRAL_ORDER)

    t_el = Term.new("dw_lin_elastic(solid.D, v, u)", i2, omega, solid=solid, v=v, u=u)
    t_cp = Term.new("dw_contact_plane_2d(cp.f, cp.n, cp.a, cp.bs, v, u)", ic, gamma, cp=cp, v=v, u=u)
    eqs = Equations([Equation("balance", t_el + t_cp)])

    ebcs = Conditions([EssentialBC("top_x", top, {"u.0": 0.0}), EssentialBC("top_y", top, {"u.1": UD})])
    pb = Problem("hertz", equations=eqs)
    pb.set_bcs(ebcs=ebcs)
    nls_status = {}
    # semismooth Newton on the piecewise linear penalty force, no line search (ls_on huge): the line
    # search of nls.newton halves every step on this problem (linear convergence, 0.5 per iteration)
    nls = Newton({"i_max": 60, "eps_a": 1e-9, "eps_r": 1e-13, "eps_mode": "or", "ls_on": 1e10},
                 lin_solver=ScipyDirect({}), status=nls_status)
    pb.set_solver(nls)
    state = pb.solve(save_results=False)
    t_solve = time.perf_counter() - t0
    if nls_status.get("condition", 1) != 0:
        raise RuntimeError(f"Newton did not converge: {nls_status}")
    history = [float(r) for r in nls_status.get("err_history", [])] if "err_history" in nls_status else None

    # ------------------------------------------------------------ solver numbers
    var = pb.get_variables()["u"]
    U = var().reshape(-1, 2).copy()
    el = "dw_lin_elastic.2.Omega(solid.D, v, u)"
    ct = f"dw_contact_plane_2d.{INTEGRAL_ORDER}.Contact(cp.f, cp.n, cp.a, cp.bs, v, u)"
    r_free = pb.evaluate(el, mode="weak", dw_mode="vector", copy_materials=False) \
        + pb.evaluate(ct, mode="weak", dw_mode="vector", copy_materials=False)
    pb.remove_bcs()
    R = nm.asarray(pb.evaluate(el, mode="weak", dw_mode="vector", copy_materials=False)).reshape(-1, 2)
    C = nm.asarray(pb.evaluate(ct, mode="weak", dw_mode="vector", copy_materials=False)).reshape(-1, 2)
    assert len(R) == field.n_nod, (R.shape, field.n_nod)
    top_nodes = nm.unique(field.get_dofs_in_region(top, merge=True))
    reaction = R[top_nodes].sum(axis=0)               # force of the support on the body
    contact = -C.sum(axis=0)                          # force of the plane on the body
    free_res = float(nm.abs(r_free).max())
    # contact quadrature points: penetration d = (X + u - A) . n and the penalty pressure k d
    tc = eqs[0].terms[1]
    qps = tc.get_physical_qps().values
    uq = tc.get(var, "val").reshape(qps.shape)
    dist = (qps + uq) @ nm.array([0.0, -1.0])
    mask = (qps[:, 0] >= X_BOUNDS[0]) & (qps[:, 0] <= X_BOUNDS[1])
    act = mask & (dist > 0)
    xa = qps[act, 0]
    pres = K_PENALTY * dist[act]
    geo, _ = tc.get_mapping(v)
    wq = geo.det.reshape(-1)                          # quadrature weights times the facet Jacobian
    p_int = float((K_PENALTY * nm.maximum(dist, 0.0) * mask * wq).sum())
    m2 = float((K_PENALTY * nm.maximum(dist, 0.0) * mask * wq * qps[:, 0] ** 2).sum())
    # nodal penetration at the P2 nodes of Gamma (vertices and edge nodes)
    cn = nm.unique(field.get_dofs_in_region(gamma, merge=True))
    Xd = field.get_coor()
    pen_nodes = float(max(0.0, (-(Xd[cn, 1] + U[cn, 1])).max()))

    # ------------------------------------------------------------ output (sfepy defaults)
    outdir = Path(a.out)
    outdir.mkdir(parents=True, exist_ok=True)
    out = state.create_output()
    stress = pb.evaluate("ev_cauchy_stress.2.Omega(solid.D, u)", mode="el_avg", copy_materials=False)
    out["cauchy_stress"] = Struct(name="output_data", mode="cell", data=stress, dofs=None)
    cwd = os.getcwd()
    os.chdir(outdir)
    try:
        pb.save_state("hertz.vtk", out=out)
    finally:
        os.chdir(cwd)
    t_all = time.perf_counter() - t0

    import scipy
    info = dict(
        library="sfepy", versions=dict(sfepy=sfepy.__version__, numpy=nm.__version__, scipy=scipy.__version__,
                                       python=platform.python_version()),
        method=(f"penalty contact with the rigid plane y = 0: sfepy ContactPlaneTerm (dw_contact_plane) "
                f"registered for 2D as dw_contact_plane_2d, force k d for d > 0, k = {K_PENALTY:g}, f0 = 0, "
                f"facet quadrature order {INTEGRAL_ORDER}; semismooth Newton (nls.newton without line search, "
                f"ls.scipy_direct), one load step from u = 0"),
        element="P2 displacement (sfepy H1 Lagrange order 2) on straight 3-node triangles (geometry 2_3)",
        stress="ev_cauchy_stress mode el_avg (cell averages of C eps(u_h); sfepy 2D order xx, yy, xy)",
        dofs=int(var.n_dof), cells=int(len(conn)), vertices=int(len(coors)), field_nodes=int(len(Xd)),
        penalty=K_PENALTY, integral_order_contact=INTEGRAL_ORDER, x_bounds=list(X_BOUNDS),
        iterations=int(nls_status["n_iter"]), final_residual=float(nls_status["err"]),
        final_residual_relative=float(nls_status["err"] / nls_status["err0"]) if nls_status.get("err0") else None,
        free_dof_residual_max=free_res,
        reaction_top=dict(Fx=float(reaction[0]), P=float(-reaction[1])),
        contact_force=dict(Fx=float(contact[0]), Fy=float(contact[1])),
        contact_qps=int(mask.sum()), active_qps=int(act.sum()),
        active_x_range=[float(xa.min()), float(xa.max())], active_half_width=float(0.5 * (xa.max() - xa.min())),
        pressure_max_qp=float(pres.max()), penetration_max_qp=float(dist[mask].max()),
        contact_force_quadrature=p_int, a_moment_quadrature=float(2.0 * math.sqrt(m2 / p_int)),
        penetration_max_nodes=pen_nodes,
        time_s=t_all, time_solve_s=t_solve)
    Path(a.info).write_text(json.dumps(info, indent=1))
    print(f"sfepy: P {info['reaction_top']['P']:.8g}, contact {info['contact_force']['Fy']:.8g}, "
          f"half-width {info['active_half_width']:.5f}, penetration {info['penetration_max_qp']:.3g}, "
          f"{info['iterations']} Newton iterations, {t_all:.1f} s")


if __name__ == "__main__":
    sys.exit(main())
