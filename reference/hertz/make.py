#!/usr/bin/env python3
"""Regenerate the Hertz contact fixtures fixtures/hertz_*/ (solution.vtu, scene.toml, expected.json, README.md).

    reference/.venv/bin/python reference/hertz/make.py            # write fixtures/hertz_*
    reference/.venv/bin/python reference/hertz/make.py --check    # regenerate in a temp dir, compare (rel 1e-8)
    reference/.venv/bin/python reference/hertz/make.py --only hertz_skfem_p1

The larger meshes of the Hertz comparison table: reference/hertz/table.py (see README.md).
"""
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import numpy as np  # noqa: E402

import geometry as G  # noqa: E402
import problems as PR  # noqa: E402
import runner  # noqa: E402

MESH_A = dict(hc=0.004, hmax=0.1, grading=0.3)    # committed frictionless / P2 cases
MESH_B = dict(hc=0.002, hmax=0.1, grading=0.3)    # committed P1 Coulomb cases (stick zone resolved)

CASES = {
    "hertz_skfem_p1": dict(
        lib="skfem", degree=1, nu=0.28, mesh=MESH_A, sel="tag", upper=True,
        file=dict(displacement="u", ucomp=2, stress="stress", layout="xx,yy,xy", write_layout=True,
                  encoding="ascii", tags=True, cell_stress_name="stress_cell")),
    "hertz_skfem_p2": dict(
        lib="skfem", degree=2, nu=0.28, mesh=MESH_A, sel="where", upper=False,
        file=dict(displacement="displacement", ucomp=2, stress="stress", layout="xx,yy,xy", write_layout=True,
                  encoding="zlib", tags=False)),
    "hertz_skfem_p2_nu05": dict(
        lib="skfem", degree=2, nu=0.5, mixed=True, mesh=MESH_A, sel="tag", upper=False,
        file=dict(displacement="U", ucomp=2, stress="sigma", layout="xx,yy,zz,xy", write_layout=False,
                  encoding="zlib", tags=True)),
    "hertz_ngsolve_p1": dict(
        lib="ngsolve", degree=1, nu=0.28, mesh=MESH_A, sel="where", upper=True,
        file=dict(displacement="displacement", ucomp=3, stress="stress", layout="xx,yy,zz,xy", write_layout=False,
                  encoding="vtk-appended-raw", tags=False)),
    "hertz_ngsolve_p2": dict(
        lib="ngsolve", degree=2, nu=0.28, mesh=MESH_A, sel="tag", upper=False,
        file=dict(displacement="u", ucomp=3, stress="stress", layout="9", write_layout=False,
                  encoding="zlib", tags=True)),
    "hertz_ngsolve_p2_nu05": dict(
        lib="ngsolve", degree=2, nu=0.5, mixed=True, mesh=MESH_A, sel="where", upper=False,
        file=dict(displacement="U", ucomp=2, stress="stress", layout="xx,yy,xy", write_layout=True,
                  encoding="uint64", tags=False, write_lines=False)),
    "hertz_ngsolve_p1_vtkoutput": dict(
        lib="ngsolve", degree=1, nu=0.28, mesh=MESH_A, sel="where", upper=False,
        file=dict(displacement="displacement", ucomp=2, stress="stress", layout="xx,yy,zz,xy", write_layout=True,
                  encoding="ngsolve-vtkoutput", tags=False, write_lines=False)),
    "hertz_skfem_p1_coulomb": dict(
        lib="skfem", degree=1, nu=0.28, friction=0.4, mesh=MESH_B, sel="tag", upper=False,
        file=dict(displacement="u", ucomp=2, stress="stress", layout="xx,yy,xy", write_layout=False,
                  encoding="raw", tags=True)),
    "hertz_ngsolve_p1_coulomb": dict(
        lib="ngsolve", degree=1, nu=0.28, friction=0.4, mesh=MESH_B, sel="where", upper=True,
        file=dict(displacement="displacement", ucomp=3, stress="stress", layout="xx,yy,zz,xy", write_layout=True,
                  encoding="vtk-appended-zlib", tags=False)),
    "hertz_skfem_p2_coulomb": dict(
        lib="skfem", degree=2, nu=0.28, friction=0.4, mesh=MESH_A, sel="tag", upper=True,
        file=dict(displacement="U", ucomp=3, stress="stress", layout="9", write_layout=False,
                  encoding="zlib", tags=True)),
}

ENCODING_TEXT = {
    "zlib": "meshio 5.3.5, inline binary (base64) + zlib, UInt32 headers",
    "uint64": "meshio 5.3.5, inline binary (base64) + zlib, UInt64 headers",
    "raw": "meshio 5.3.5, inline binary (base64), uncompressed",
    "ascii": "meshio 5.3.5, ascii (12 significant digits)",
    "vtk-appended-raw": "VTK 9 vtkXMLUnstructuredGridWriter, appended raw binary, uncompressed",
    "vtk-appended-zlib": "VTK 9 vtkXMLUnstructuredGridWriter, appended raw binary + zlib",
    "ngsolve-vtkoutput": ("NGSolve's own VTKOutput (subdivision 0): appended raw binary, *exploded* mesh (every "
                          "triangle has its own 3 points; coincident points carry identical values)"),
}


def hertz_scene(c):
    f = c["file"]
    nu = c["nu"]
    sc = {"material": {"youngs_modulus": PR.E, "poisson_ratio": nu, "model": "plane_strain"},
          "fields": {"displacement": f["displacement"], "stress": f["stress"]}}
    if f.get("write_layout"):
        sc["fields"]["stress_layout"] = f["layout"]
    if c["sel"] == "tag":
        sc["boundaries"] = {"tag_array": "boundary_tag"}
    tag = c["sel"] == "tag"
    top = {"name": "top", **({"tag": G.TAG_TOP} if tag else {"where": "y > 0.9999"}),
           "kind": "dirichlet", "displacement": [float(PR.UD[0]), float(PR.UD[1])]}
    con = {"name": "contact", **({"tag": G.TAG_CONTACT} if tag else {"where": "y < 0.5001"}),
           "kind": "contact", "obstacle": PR.PLANE, "normal": "obstacle"}
    if c.get("friction"):
        con["friction"] = float(c["friction"])
    sc["boundary"] = [top, con]
    if c.get("upper"):
        sc["boundary"].append({"name": "arc_upper",
                               **({"tag": G.TAG_FREE} if tag else {"where": "min(y - 0.5001, 0.9999 - y)"}),
                               "kind": "neumann", "traction": [0.0, 0.0]})
    if nu == 0.5:
        sc["estimate"] = {"norm": "robust"}
    return sc


def hertz_extra(sol, nu):
    def extra(exp):
        P_file = -exp["boundaries"]["top"]["force"][1]
        P_solver = sol["info"]["reaction_top"]["P"]
        con = exp["boundaries"]["contact"]
        h = PR.hertz_ab(P_file, PR.E, nu)
        hs = PR.hertz_ab(P_solver, PR.E, nu)
        out = dict(
            P_file=P_file, E_star=h["E_star"], a=h["a"], p0=h["p0"],
            P_solver=P_solver, a_from_P_solver=hs["a"], p0_from_P_solver=hs["p0"],
            a_moment=con["a_moment"], active_half_width=con["active_half_width"], p_max=con["pressure_max_nodes"],
        )
        out["deviation_percent"] = dict(
            a_moment=100 * (con["a_moment"] / h["a"] - 1) if con["a_moment"] else None,
            active_half_width=100 * (con["active_half_width"] / h["a"] - 1) if con["active_half_width"] else None,
            p_max=100 * (con["pressure_max_nodes"] / h["p0"] - 1),
            normal_force_vs_P=100 * (con["normal_force"] / P_file - 1))
        return {"hertz": out}
    return extra


DEFINITIONS = """\
Numbers in expected.json are computed from solution.vtu as written (read back with meshio), by
reference/hertz/evaluate.py; the definitions are in reference/hertz/README.md ("expected.json")."""


def readme(name, c, sol, exp):
    f = c["file"]
    fr = c.get("friction", 0.0)
    lib = "scikit-fem 12.0.2" if c["lib"] == "skfem" else "NGSolve 6.2.2608"
    elem = sol["info"]["element"]
    if c["lib"] == "skfem":
        meth = ("primal-dual active set (semismooth Newton) on the nodal constraints u_y(x_i) >= -y_i at every node of "
                "Gamma_C" + (" with nodal Coulomb friction (single load step from zero)" if fr else "") +
                ": exact complementarity at the nodes, no penetration at nodes")
    else:
        meth = ("penalty 1/2 kappa ||(-y - u_y)^+||^2 on Gamma_C (kappa = 1e4 ... 1e8), Newton"
                + (", then regularised Coulomb friction F p u_x / sqrt(u_x^2 + eps^2) with eps = 1e-4 ... 1e-8" if fr else "")
                + ": the solution penetrates the plane slightly (about p/kappa), deliberately")
    sel = ("line cells carry `boundary_tag` (1 = contact part of the arc, y <= 1/2; 2 = top; 3 = arc above y = 1/2; "
           "0 on triangles)" if f.get("tags") else
           ("`where` selectors (evaluated at edge mid points; also unambiguous when evaluated at all nodes of an edge); "
            + ("line cells present, no tag array" if f.get("write_lines", True) else "**no line cells in the file**: boundary edges come from the triangles")))
    lay = {"xx,yy,xy": "3 components xx, yy, xy", "xx,yy,zz,xy": "4 components xx, yy, zz, xy",
           "9": "9 components, row-major 3x3"}[f["layout"]]
    cells = "VTK_QUADRATIC_TRIANGLE + VTK_QUADRATIC_EDGE (curved mid nodes on the arc)" if c["degree"] == 2 else "VTK_TRIANGLE + VTK_LINE"
    if not f.get("write_lines", True):
        cells = cells.split(" + ")[0] + " only"
    h = exp["hertz"]
    con = exp["boundaries"]["contact"]
    txt = f"""# {name}

Hertz contact (docs/design.md §9; talk's test): lower half of the disc of radius 1 centred at (0, 1), pressed onto
the rigid plane y = 0 by u = (0, -0.01) on the flat top y = 1. E = 20600, nu = {c['nu']}, plane strain,
{'Coulomb friction ' + str(fr) if fr else 'frictionless'}. Gamma_C = arc below y = 1/2, contact measured along the
obstacle normal (`normal = "obstacle"`): u_y >= -y. Rest of the arc traction-free.

Produced by

    reference/.venv/bin/python reference/hertz/make.py --only {name}

- solver: {lib}, {elem}; {meth}
- mesh: netgen (OCC) half disc, graded toward the contact zone: edge size {c['mesh']['hc']} on the arc for
  |x| <= 0.12, maxh {c['mesh']['hmax']}, grading {c['mesh']['grading']}; {exp['mesh']['cells']} cells, {exp['mesh']['points']} points
- file: {ENCODING_TEXT[f['encoding']]}; {cells}
- point data `{f['displacement']}` ({f.get('ucomp', 2)} components), `{f['stress']}` = L2 projection of the
  stress of u_h onto the continuous P{c['degree']} space ({lay}; plane strain sigma_zz included where the layout has it)
""" + (f"- cell data `{f['cell_stress_name']}`: piecewise constant C eps(u_h) per triangle (xx, yy, zz, xy); zeros on the line cells\n" if f.get("cell_stress_name") else "") + f"""- boundaries: {sel}

Key numbers (expected.json): top reaction from the file's stress P = {h['P_file']:.6g} (solver reaction
{h['P_solver']:.6g}); contact force {con['normal_force']:.6g}; Hertz a = {h['a']:.5f}, p0 = {h['p0']:.5g}; from the
file: pressure-moment a = {h['a_moment']:.5f}, active half-width {h['active_half_width']:.5f}, max pressure
{h['p_max']:.5g}; max penetration {con['penetration_max']:.3g}.""" + (f"""
Stick zone x in [{con['stick_x_range'][0]:.5f}, {con['stick_x_range'][1]:.5f}], slip outside up to the contact ends.""" if fr else "") + f"""

{DEFINITIONS}
"""
    return txt


def make_one(name, outdir, results):
    c = CASES[name]
    tm = G.half_disc(**c["mesh"])
    if c["lib"] == "skfem":
        sol = PR.solve_skfem(tm, c["degree"], c["nu"], friction=c.get("friction", 0.0), mixed=c.get("mixed", False),
                             curved_tags=(1, 3), cell_stress=bool(c["file"].get("cell_stress_name")))
    else:
        sol = PR.solve_ngsolve(tm, c["degree"], c["nu"], friction=c.get("friction", 0.0), mixed=c.get("mixed", False))
    cfg = dict(c["file"], delta=1e-8 * abs(PR.UD[1]), cell_stress=sol["cell_stress"],
               command=f"reference/hertz/make.py --only {name}")
    if c["file"]["encoding"] == "ngsolve-vtkoutput":
        cfg["write_callback"] = PR.ngsolve_vtkoutput(sol, (c["file"]["displacement"], c["file"]["stress"]))
    scene = hertz_scene(c)
    info = dict(sol["info"], mesh_parameters=c["mesh"])
    holder = {}

    def rd(exp):
        holder["exp"] = exp
        return ""
    exp = runner.write_fixture(outdir, name, sol["nodes"], sol["cells"], sol["lines"], sol["tags"], sol["U"], sol["S4"],
                               scene, cfg, info, hertz_extra(sol, c["nu"]), readme="")
    (Path(outdir) / name / "README.md").write_text(readme(name, c, sol, exp))
    return exp


if __name__ == "__main__":
    sys.exit(runner.run(CASES, make_one, sys.argv[1:], "hertz"))
