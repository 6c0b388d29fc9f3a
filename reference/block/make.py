#!/usr/bin/env python3
"""Regenerate the block-on-a-plane fixtures fixtures/block_*/ (the talk's "straight boundaries" example).

    reference/.venv/bin/python reference/block/make.py            # write fixtures/block_*
    reference/.venv/bin/python reference/block/make.py --check    # regenerate in a temp dir, compare (rel 1e-8)

Rectangle [-1,1]x[0,1] on the rigid plane y = 0 (initial gap 0 on the whole bottom), pressed by
u = (0, -0.01) on the top, sides traction-free, E = 20600, nu = 0.28, plane strain.  The contact zone is
the whole bottom and ends at the corners.  Library code: reference/hertz/.
"""
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "hertz"))

import geometry as G  # noqa: E402
import problems as PR  # noqa: E402
import runner  # noqa: E402

MESH = dict(hc=0.002, hb=0.02, hmax=0.1, grading=0.3)

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
}

ENC = {"zlib": "meshio 5.3.5, inline binary (base64) + zlib", "ascii": "meshio 5.3.5, ascii (12 significant digits)",
       "vtk-appended-raw": "VTK 9 vtkXMLUnstructuredGridWriter, appended raw binary, uncompressed"}


def scene(c):
    f = c["file"]
    sc = {"material": {"youngs_modulus": PR.E, "poisson_ratio": 0.28, "model": "plane_strain"},
          "fields": {"displacement": f["displacement"], "stress": f["stress"]}}
    if f.get("write_layout"):
        sc["fields"]["stress_layout"] = f["layout"]
    tag = c["sel"] == "tag"
    if tag:
        sc["boundaries"] = {"tag_array": "boundary_tag"}
    con = {"name": "bottom", **({"tag": 1} if tag else {"where": "y < 0.0001"}), "kind": "contact",
           "obstacle": PR.PLANE}
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


def make_one(name, outdir, results):
    c = CASES[name]
    tm = G.block(**MESH)
    if c["lib"] == "skfem":
        sol = PR.solve_skfem(tm, c["degree"], 0.28, friction=c["friction"])
    else:
        sol = PR.solve_ngsolve(tm, c["degree"], 0.28, friction=c["friction"])
    cfg = dict(c["file"], delta=1e-10, command=f"reference/block/make.py --only {name}")
    info = dict(sol["info"], mesh_parameters=MESH)
    exp = runner.write_fixture(outdir, name, sol["nodes"], sol["cells"], sol["lines"], sol["tags"], sol["U"], sol["S4"],
                               scene(c), cfg, info, None, readme="")
    (Path(outdir) / name / "README.md").write_text(readme(name, c, sol, exp))
    return exp


if __name__ == "__main__":
    sys.exit(runner.run(CASES, make_one, sys.argv[1:], "block"))
