"""Problem set-ups shared by the make scripts: solve with scikit-fem or NGSolve on a TriMesh and return
the nodal output (nodes, cells, line cells, tags, displacement, projected stress) + solver info."""
import math
import time
import numpy as np

import geometry as G
import fem_skfem as S

E = 20600.0
UD = (0.0, -0.01)
PLANE = {"plane": {"point": [0.0, 0.0], "normal": [0.0, 1.0]}}


def hertz_ab(P, E_, nu, R=1.0):
    Es = E_ / (1 - nu ** 2)
    a = math.sqrt(4 * P * R / (math.pi * Es))
    return dict(E_star=Es, P=P, a=a, p0=2 * P / (math.pi * a))


def solve_skfem(tm, degree, nu, friction=0.0, mixed=False, contact_tags=(1,), top_tag=2, curved_tags=(),
                cell_stress=False, uD=UD, obstacle_gap=None):
    """obstacle_gap: optional callable of the nodal x, extra gap below y = 0 (fem_skfem.solve_contact)."""
    t0 = time.time()
    d = S.Discretisation(tm, degree, curved_tags=curved_tags, mixed=mixed)
    K = S.assemble(d, E, nu)
    top = d.boundary_nodes([top_tag])
    cn = d.boundary_nodes(list(contact_tags))
    res = S.solve_contact(d, K, top, uD, cn, friction=friction, obstacle_gap=obstacle_gap)
    U, S4 = S.nodal_fields(d, E, nu, res["u"])
    cs = S.cell_stress(d, E, nu, res["u"]) if cell_stress else None
    info = dict(library="scikit-fem", method=("primal-dual active set (semismooth Newton) on nodal constraints"
                                              + (", Coulomb friction (nodal, single load step)" if friction else "")),
                element=("Taylor-Hood P2/P1 (u, p)" if mixed else f"P{degree} displacement")
                + (", isoparametric curved boundary" if degree == 2 and curved_tags else ""),
                dofs=int(K.shape[0]), iterations=res["iterations"], final_residual=res["final_residual"],
                history=[{k: v for k, v in h.items() if k in ("it", "active", "stick", "changed")} for h in res["history"]],
                reaction_top=dict(P=res["P"], Fx=res["Fx_top"]),
                contact_force_nodal=float(res["lambda_n"].sum()),
                tangential_force_nodal=float(res["lambda_t"].sum()),
                time_s=time.time() - t0)
    # nodal multipliers: pressure moment estimate of a
    x = d.nodes[res["contact_nodes"], 0]
    ln = res["lambda_n"]
    info["a_moment_multipliers"] = float(2 * math.sqrt((ln * x ** 2).sum() / ln.sum())) if ln.sum() > 0 else None
    return dict(nodes=d.nodes, cells=d.cells, lines=d.lines, tags=tm.btag, U=U, S4=S4, cell_stress=cs, info=info,
                raw=res, dsc=d)


def solve_ngsolve(tm, degree, nu, friction=0.0, mixed=False, kappa_final=1e8, eps_final=1e-8):
    import fem_ngsolve as N
    t0 = time.time()
    s = N.NGSolveContact(tm, degree, E, nu, mixed=mixed)
    kap = tuple(10.0 ** k for k in range(4, int(round(math.log10(kappa_final))) + 1))
    eps = tuple(10.0 ** k for k in range(-4, int(round(math.log10(eps_final))) - 1, -1))
    r = s.solve(uD=UD, kappas=kap, friction=friction, eps_list=eps)
    nodes, cells, lines, U, S4 = s.nodal_output()
    info = dict(library="NGSolve", method=("penalty 1/2 kappa ||(-y - u_y)^+||^2 on Gamma_C, Newton, penalty continuation"
                                           + (", regularised Coulomb friction F p u_x/sqrt(u_x^2+eps^2), eps continuation"
                                              if friction else "")),
                element=("Taylor-Hood P2/P1 (u, p)" if mixed else f"P{degree} displacement") + (", mesh.Curve(2)" if degree == 2 else ""),
                dofs=int(s.fes.ndof), kappa=kappa_final, eps=eps_final if friction else None,
                iterations=r["newton_total"], final_residual=r["final_residual"],
                history=[{k: v for k, v in h.items() if k != "residual"} for h in r["history"]],
                reaction_top=dict(P=r["P"], Fx=r["Fx_top"]),
                contact_force_penalty=r["P_contact"], tangential_force_penalty=r["Ft_contact"],
                time_s=time.time() - t0)
    return dict(nodes=nodes, cells=cells, lines=lines, tags=tm.btag, U=U, S4=S4, cell_stress=None, info=info, raw=r,
                solver=s)


def ngsolve_vtkoutput(sol, names=("displacement", "stress")):
    """writer callback: NGSolve's own VTKOutput (exploded mesh, appended raw binary), subdivision 0, the
    displacement GridFunction and the projected stress (xx, yy, zz, xy)."""
    import ngsolve as ngs
    s = sol["solver"]

    def write(stem):
        sg = s.stress_gf()
        u = s.gfu.components[0] if s.mixed else s.gfu
        ngs.VTKOutput(ma=s.mesh, coefs=[u, ngs.CF(tuple(sg))], names=list(names), filename=str(stem),
                      subdivision=0).Do()
    return write
