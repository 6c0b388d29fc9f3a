#!/usr/bin/env python3
"""Regenerate the block-on-a-plane fixtures fixtures/block_*/ (the talk's "straight boundaries" example).

    reference/.venv/bin/python reference/block/make.py            # write fixtures/block_*
    reference/.venv/bin/python reference/block/make.py --check    # regenerate in a temp dir, compare (rel 1e-8)

Rectangle [-1,1]x[0,1] on the rigid plane y = 0 (initial gap 0 on the whole bottom), pressed by
u = (0, -0.01) on the top, sides traction-free, E = 20600, nu = 0.28, plane strain.  The contact zone is
the whole bottom and ends at the corners.  Library code: reference/hertz/.

block_cylinder_*: the same block pressed onto a rigid cylinder of radius R = 5 below it (surface
y = -(R - sqrt(R^2 - x^2))), contact direction (0, -1), gap g = y + R - sqrt(R^2 - x^2) given in the scene
as a `gap` expression; the contact zone ends inside the bottom edge (|x| ~ 0.2).  True errors against a
fine reference: reference/block/fine_error.py.
"""
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "hertz"))

import geometry as G  # noqa: E402
import problems as PR  # noqa: E402
import runner  # noqa: E402

import numpy as np  # noqa: E402

MESH = dict(hc=0.002, hb=0.02, hmax=0.1, grading=0.3)
R_CYL = 5.0  # block_cylinder_*: radius of the rigid cylinder below the block

CASES = {
    "block_skfem_p1": dict(
        lib="skfem", degree=1, friction=0.0, sel="where", normal=None,
        file=dict(displacement="u", ucomp=2, stress="stress", layout="xx,yy,zz,xy", write_layout=True,
                  encoding="ascii", tags=False)),
    "block_ngsolve_p2": dict(
        lib="ngsolve", degree=2, friction=0.0, sel="tag", normal="body",
        file=dict(displacement="displacement", ucomp=3, stress="stress", layout="xx,yy,xy", write_layout=False,
                  encoding="zlib", tags=True)),
    "block_skfem_p1_coulomb": dict(
        lib="skfem", degree=1, friction=0.4, sel="tag", normal="body",
        file=dict(displacement="U", ucomp=3, stress="stress", layout="9", write_layout=False,
                  encoding="zlib", tags=True)),
    "block_skfem_p1_coulomb02": dict(
        lib="skfem", degree=1, friction=0.2, sel="tag", normal="body",
        file=dict(displacement="u", ucomp=2, stress="stress", layout="xx,yy,xy", write_layout=True,
                  encoding="vtk-appended-raw", tags=True)),
    "block_ngsolve_p1_coulomb02": dict(
        lib="ngsolve", degree=1, friction=0.2, sel="where", normal=None,
        file=dict(displacement="displacement", ucomp=2, stress="stress", layout="xx,yy,zz,xy", write_layout=True,
                  encoding="zlib", tags=False)),
    # rigid cylinder R = 5 below the block: gap expression instead of an obstacle plane (same MESH: the
    # contact zone |x| <~ 0.2 is covered by ~17 bottom edges of size 0.02)
    # gap_delta 1e-8 (not 1e-10): on P2 the quadratic u_h and the non-polynomial gap differ by up to ~5e-10
    # between the (exactly constrained) nodes, so at 1e-10 half of every active edge would count as open
    "block_cylinder_skfem_p1": dict(
        lib="skfem", degree=1, friction=0.0, sel="where", normal=None, cylinder=R_CYL, delta=1e-8,
        file=dict(displacement="u", ucomp=2, stress="stress", layout="xx,yy,zz,xy", write_layout=True,
                  encoding="ascii", tags=False)),
    "block_cylinder_skfem_p2": dict(
        lib="skfem", degree=2, friction=0.0, sel="where", normal=None, cylinder=R_CYL, delta=1e-8,
        file=dict(displacement="u", ucomp=2, stress="stress", layout="xx,yy,zz,xy", write_layout=True,
                  encoding="zlib", tags=False)),
}

ENC = {"zlib": "meshio 5.3.5, inline binary (base64) + zlib", "ascii": "meshio 5.3.5, ascii (12 significant digits)",
       "vtk-appended-raw": "VTK 9 vtkXMLUnstructuredGridWriter, appended raw binary, uncompressed"}


def cylinder_gap_expr(R):
    """gap along n = (0, -1) from the bottom of the block to the cylinder y = -(R - sqrt(R^2 - x^2))"""
    return f"y + {R:g} - sqrt({R * R:g} - x*x)"


def cylinder_gap(R):
    """the extra nodal gap below y = 0 for fem_skfem.solve_contact (same formula as the expression)"""
    return lambda x: R - np.sqrt(R * R - x * x)


def scene(c):
    f = c["file"]
    sc = {"material": {"youngs_modulus": PR.E, "poisson_ratio": 0.28, "model": "plane_strain"},
          "fields": {"displacement": f["displacement"], "stress": f["stress"]}}
    if f.get("write_layout"):
        sc["fields"]["stress_layout"] = f["layout"]
    tag = c["sel"] == "tag"
    if tag:
        sc["boundaries"] = {"tag_array": "boundary_tag"}
    con = {"name": "bottom", **({"tag": 1} if tag else {"where": "y < 0.0001"}), "kind": "contact"}
    if c.get("cylinder"):
        con["gap"] = cylinder_gap_expr(c["cylinder"])
    else:
        con["obstacle"] = PR.PLANE
    if c["normal"]:
        con["normal"] = c["normal"]
    if c["friction"]:
        con["friction"] = float(c["friction"])
    sc["boundary"] = [
        {"name": "top", **({"tag": 2} if tag else {"where": "y > 0.9999"}), "kind": "dirichlet",
         "displacement": [0.0, -0.01]},
        con,
        {"name": "sides", **({"tag": 3} if tag else {"where": "abs(x) > 0.9999"}), "kind": "neumann",
         "traction": [0.0, 0.0]},
    ]
    return sc


def readme(name, c, sol, exp):
    f = c["file"]
    con = exp["boundaries"]["bottom"]
    fr = c["friction"]
    lib = "scikit-fem 12.0.2, primal-dual active set on the nodal constraints (exact nodal complementarity" + \
        (", nodal Coulomb friction, single load step" if fr else "") + ")" if c["lib"] == "skfem" else \
        "NGSolve 6.2.2608, penalty kappa = 1e4 ... 1e8 against the plane (slight penetration, deliberately)" + \
        (", regularised Coulomb friction eps = 1e-4 ... 1e-8" if fr else "")
    lay = {"xx,yy,xy": "3 components xx, yy, xy", "xx,yy,zz,xy": "4 components xx, yy, zz, xy",
           "9": "9 components, row-major 3x3"}[f["layout"]]
    sel = ("line cells carry `boundary_tag` (1 = bottom, 2 = top, 3 = sides; 0 on triangles)" if f["tags"]
           else "`where` selectors at edge mid points (line cells present, no tag array)")
    txt = f"""# {name}

Block on a plane (docs/design.md §9, the talk's "straight boundaries" example): [-1,1]x[0,1] on the rigid plane
y = 0 (gap 0 on the whole bottom), u = (0, -0.01) on the top, sides traction-free; E = 20600, nu = 0.28,
plane strain, {'Coulomb friction ' + str(fr) if fr else 'frictionless'}. Gamma_C = bottom; normal = {c['normal'] or 'body (default, not written)'}.

Produced by

    reference/.venv/bin/python reference/block/make.py --only {name}

- solver: {lib}; {sol['info']['element']}
- mesh: netgen (OCC), edge size {c['mesh']['hb'] if 'mesh' in c else MESH['hb']} on the bottom, {MESH['hc']} at the bottom corners, maxh {MESH['hmax']},
  grading {MESH['grading']}; {exp['mesh']['cells']} cells, {exp['mesh']['points']} points
- file: {ENC[f['encoding']]}; point data `{f['displacement']}` ({f['ucomp']} components), `{f['stress']}` = L2 projection
  of the stress of u_h onto continuous P{c['degree']} ({lay})
- boundaries: {sel}

Key numbers: top reaction (solver) {sol['info']['reaction_top']['P']:.6g}, from the file's stress
{-exp['boundaries']['top']['force'][1]:.6g}; contact force {con['normal_force']:.6g}; active length {con['active_length']:.6g}
(the whole bottom is in contact); max penetration {con['penetration_max']:.3g}.""" + (f"""
Stick x in [{con['stick_x_range'][0]:.4f}, {con['stick_x_range'][1]:.4f}]; slip outside it.""" if fr else "") + (
        """ With friction 0.4 the bottom sticks almost entirely: only the corner nodes slip (the slip zone is a
corner effect that shrinks with the mesh).""" if fr == 0.4 else "") + """

Numbers in expected.json are computed from solution.vtu as written (read back with meshio) by
reference/hertz/evaluate.py; definitions in reference/hertz/README.md ("expected.json").
"""
    return txt


def readme_cylinder(name, c, sol, exp):
    f = c["file"]
    con = exp["boundaries"]["bottom"]
    R = c["cylinder"]
    xr = con["active_x_range"]
    lay = {"xx,yy,xy": "3 components xx, yy, xy", "xx,yy,zz,xy": "4 components xx, yy, zz, xy"}[f["layout"]]
    Es = PR.E / (1 - 0.28 ** 2)
    P = con["normal_force"]
    a_h = float(np.sqrt(4 * P * R / (np.pi * Es)))
    pen = ("The nodal constraints hold exactly (active-set solution), but between two active nodes the\n"
           "straight P1 edge is a chord of the convex obstacle and crosses it: penetration between the nodes, up\n"
           "to h^2/(8R) on an edge of length h (the whole span of the active nodes counts as active)" if c["degree"] == 1 else
           "The nodal constraints (vertices and mid-edge nodes) hold exactly; between them the quadratic u_h\n"
           "and the non-polynomial gap differ by up to ~5e-10 inside the contact zone, hence gap_delta = 1e-8 for\n"
           "these cases (at 1e-10 half of every active edge would count as open); the largest penetration is\n"
           "on an edge at the end of the zone whose mid node is active and whose far vertex is not")
    return f"""# {name}

Block on a rigid cylinder: [-1,1]x[0,1], u = (0, -0.01) on the top, sides traction-free; E = 20600, nu = 0.28,
plane strain, frictionless, pressed onto a rigid cylinder of radius R = {R:g} below the block (surface
y = -(R - sqrt(R^2 - x^2)), touching the bottom at x = 0). Gamma_C = bottom with the gap given as an
expression, `gap = "{cylinder_gap_expr(R)}"` (gap along the body normal n = (0, -1) of the bottom, no
`obstacle`, default normal = body). The contact zone ends inside the bottom edge (active x in
[{xr[0]:.4f}, {xr[1]:.4f}], Hertz half width sqrt(4 P R / (pi E*)) = {a_h:.4f} for the file's contact force
P = {P:.6g}).

Produced by

    reference/.venv/bin/python reference/block/make.py --only {name}

- solver: scikit-fem 12.0.2, primal-dual active set on the nodal constraints -u_y <= R - sqrt(R^2 - x^2)
  at the bottom nodes{' (vertices and mid-edge nodes)' if c['degree'] == 2 else ''}; {sol['info']['element']}{', straight cells' if c['degree'] == 2 else ''}
- mesh: the other block cases' mesh: netgen (OCC), edge size {MESH['hb']} on the bottom, {MESH['hc']} at the bottom
  corners, maxh {MESH['hmax']}, grading {MESH['grading']}; {exp['mesh']['cells']} cells, {exp['mesh']['points']} points
- file: {ENC[f['encoding']]}; point data `{f['displacement']}` ({f['ucomp']} components), `{f['stress']}` = L2 projection
  of the stress of u_h onto continuous P{c['degree']} ({lay})
- boundaries: `where` selectors at edge mid points (line cells present, no tag array)

Key numbers: top reaction (solver) {sol['info']['reaction_top']['P']:.6g}, from the file's stress
{-exp['boundaries']['top']['force'][1]:.6g}; contact force {P:.6g}; active length {con['active_length']:.6g}
({con['active_nodes']} active of {con['contact_nodes']} bottom nodes); max penetration {con['penetration_max']:.3g}
(at the nodes {con['penetration_max_nodes']:.3g}).
{pen}.
True energy error against a fine reference: reference/block/fine_errors.json (reference/block/fine_error.py).

Numbers in expected.json are computed from solution.vtu as written (read back with meshio) by
reference/hertz/evaluate.py; definitions in reference/hertz/README.md ("expected.json").
"""


def make_one(name, outdir, results):
    c = CASES[name]
    tm = G.block(**MESH)
    if c["lib"] == "skfem":
        og = cylinder_gap(c["cylinder"]) if c.get("cylinder") else None
        sol = PR.solve_skfem(tm, c["degree"], 0.28, friction=c["friction"], obstacle_gap=og)
    else:
        sol = PR.solve_ngsolve(tm, c["degree"], 0.28, friction=c["friction"])
    cfg = dict(c["file"], delta=c.get("delta", 1e-10), command=f"reference/block/make.py --only {name}")
    info = dict(sol["info"], mesh_parameters=MESH)
    if c.get("cylinder"):
        info["obstacle"] = f"rigid cylinder R = {c['cylinder']:g} below the block, gap {cylinder_gap_expr(c['cylinder'])}"
    exp = runner.write_fixture(outdir, name, sol["nodes"], sol["cells"], sol["lines"], sol["tags"], sol["U"], sol["S4"],
                               scene(c), cfg, info, None, readme="")
    (Path(outdir) / name / "README.md").write_text((readme_cylinder if c.get("cylinder") else readme)(name, c, sol, exp))
    return exp


if __name__ == "__main__":
    sys.exit(runner.run(CASES, make_one, sys.argv[1:], "block"))
