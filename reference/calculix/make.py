#!/usr/bin/env python3
"""Hertz contact fixtures computed and written by CalculiX 2.20 (+ ccx2paraview) and sfepy 2026.3:
fixtures/calculix_hertz_cpe6_{penalty,twobody,friction} and fixtures/sfepy_hertz_p2_vtk.
See reference/calculix/README.md.

    reference/.venv/bin/python reference/calculix/make.py            # solve + write the four fixtures
    reference/.venv/bin/python reference/calculix/make.py --check    # see below
    reference/.venv/bin/python reference/calculix/make.py --check --files-only

Runs under reference/.venv (Python 3.11: numpy, scipy, meshio, vtk; netgen for the mesh when solving).
The solvers run by subprocess: `ccx` (Debian calculix-ccx 2.20) and, in reference/.venv-calculix
(Python 3.12), `ccx2paraview` and solve_sfepy.py.

--check: (1) re-reads the committed files of every fixture (VTK, meshio as second reader, the CalculiX
.dat and .inp) and recomputes every number of expected.json except the `solver` block (run facts:
versions, increments, iterations, times; for sfepy also its numbers, which only the solve knows),
comparing at rel. 1e-10; (2) when `ccx` and reference/.venv-calculix are there (and not --files-only),
re-runs the solvers into a temporary folder and compares the regenerated expected.json with the
committed one (rel. 1e-8; sizes, versions, times not compared).  Without them it prints that the solver
re-run was skipped.  Exit status 1 on any mismatch.
"""
import argparse
import json
import math
import os
import shutil
import subprocess
import sys
import tempfile
import time
import tomllib
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
REF = HERE.parent
REPO = REF.parent
sys.path.insert(0, str(REF / "hertz"))
sys.path.insert(0, str(REF / "othercodes"))
sys.path.insert(0, str(HERE))

import runner  # noqa: E402  (scene_toml, compare, _clean)
import filecheck  # noqa: E402
import ccxfiles as CF  # noqa: E402

VENV = REF / ".venv-calculix"
CCX = shutil.which("ccx")
E, NU, UD = 20600.0, 0.28, (0.0, -0.01)
PLANE = {"plane": {"point": [0.0, 0.0], "normal": [0.0, 1.0]}}
DELTA = 1e-10
GEN = "reference/.venv/bin/python reference/calculix/make.py"
TENSION = 0.294      # CalculiX's default sigma_inf = E / 70000, given explicitly
LIMITS = dict(reaction_vs_contact_rel=1e-5, half_width_percent=3.5, penetration_solver=2e-5,
              penetration_file=2e-5, P_file_vs_solver_percent=3.0)

CASES = {
    "calculix_hertz_cpe6_penalty": dict(code="calculix", kind="plane", penalty=5.0e7, increment=0.05),
    "calculix_hertz_cpe6_twobody": dict(code="calculix", kind="block", penalty=2.0e8, increment=0.05, e_block=2.06e8),
    "calculix_hertz_cpe6_friction": dict(code="calculix", kind="plane", penalty=5.0e7, increment=0.05,
                                         friction=0.4, stick_slope=5.0e7),
    "sfepy_hertz_p2_vtk": dict(code="sfepy"),
}
ENTRY = {"calculix": "hertz.vtu", "sfepy": "hertz.vtk"}
COMMITTED = {"calculix": ["hertz.inp", "hertz.dat", "hertz.vtu"], "sfepy": ["hertz.vtk"]}


def env1():
    env = dict(os.environ, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1", CCX_NPROC_EQUATION_SOLVER="1",
               CCX_NPROC_RESULTS="1", CCX_NPROC_STIFFNESS="1")
    env.pop("PYTHONPATH", None)
    return env


def run(cmd, cwd, what):
    t0 = time.perf_counter()
    p = subprocess.run(cmd, cwd=cwd, env=env1(), capture_output=True, text=True)
    (Path(cwd) / f"{what}.stdout").write_text(p.stdout + p.stderr)
    if p.returncode != 0 or "*ERROR" in p.stdout:
        sys.stderr.write(p.stdout[-3000:] + p.stderr[-3000:])
        raise RuntimeError(f"{what} failed ({p.returncode}): {' '.join(map(str, cmd))} in {cwd}")
    return p.stdout + p.stderr, time.perf_counter() - t0


# ------------------------------------------------------------------ solves
def versions_calculix(log):
    import re
    v = re.search(r"CalculiX Version (\d[\d.]*\d)", log)
    deb = subprocess.run(["dpkg-query", "-W", "-f", "${Version}", "calculix-ccx"], capture_output=True, text=True)
    py = str(VENV / "bin" / "python")
    q = subprocess.run([py, "-c", "import importlib.metadata as m, numpy, vtk, platform; print(m.version('ccx2paraview'),"
                        " numpy.__version__, vtk.vtkVersion.GetVTKVersion(), platform.python_version())"],
                       capture_output=True, text=True, env=env1())
    c2p, npv, vtkv, pyv = q.stdout.split()
    return dict(calculix=v.group(1) if v else None, debian_package=f"calculix-ccx {deb.stdout.strip()}",
                ccx2paraview=c2p, ccx2paraview_numpy=npv, ccx2paraview_vtk=vtkv, ccx2paraview_python=pyv)


def sta_facts(path):
    rows = []
    for line in Path(path).read_text().splitlines():
        p = line.split()
        if len(p) == 7 and p[0].isdigit():
            rows.append(p)
    ok = [r for r in rows if not r[2].endswith("U")]          # "1U": an attempt that did not converge
    return dict(increments=len(ok), cutbacks=len(rows) - len(ok), iterations=int(sum(int(r[3]) for r in rows)),
                final_time=float(ok[-1][4]))


def run_calculix(case, build):
    import re
    import ccxdeck
    c = CASES[case]
    d = Path(build) / case
    d.mkdir(parents=True)
    txt, facts = ccxdeck.deck(c["kind"], c["penalty"], TENSION, c["increment"], friction=c.get("friction"),
                              stick_slope=c.get("stick_slope"), e_block=c.get("e_block"))
    (d / "hertz.inp").write_text(txt)
    log, t_ccx = run([CCX, "-i", "hertz"], d, "ccx")
    sta = sta_facts(d / "hertz.sta")
    springs = [int(m) for m in re.findall(r"Number of contact spring elements=\s*(\d+)", log)]
    out, t_c2p = run([str(VENV / "bin" / "ccx2paraview"), "hertz.frd", "vtu"], d, "ccx2paraview")
    info = dict(library="calculix", versions=versions_calculix(log),
                method=(f"node-to-surface penalty contact (*CONTACT PAIR, TYPE=NODE TO SURFACE, "
                        f"*SURFACE BEHAVIOR, PRESSURE-OVERCLOSURE=LINEAR, slope {c['penalty']:g}, tension {TENSION:g}"
                        + (f"; *FRICTION {c['friction']:g}, stick slope {c['stick_slope']:g}" if c.get("friction") else "")
                        + f"), one *STATIC step (NLGEOM off), automatic increments from {c['increment']:g}"),
                element="CPE6 (plane strain, 6-node triangles, thickness 1)",
                stress="CalculiX nodal stress S: integration-point values extrapolated to the nodes and averaged",
                deck=facts, **sta, contact_springs_last_iteration=springs[-1] if springs else None,
                frd_bytes=(d / "hertz.frd").stat().st_size, time_ccx_s=t_ccx, time_ccx2paraview_s=t_c2p,
                ccx2paraview_log=[ln for ln in out.splitlines() if ln.startswith(("INFO", "WARNING"))])
    if c["kind"] == "block":
        # companion run with the expanded 3D mesh in the .frd: checks the expanded-node rule of
        # ccxfiles.expanded_xy, by which the .dat contact output (3D slave nodes) gets its x
        d3 = Path(build) / (case + "_3d")
        d3.mkdir()
        (d3 / "hertz.inp").write_text(txt.replace("*NODE FILE, FREQUENCY=1000", "*NODE FILE, FREQUENCY=1000, OUTPUT=3D"))
        run([CCX, "-i", "hertz"], d3, "ccx")
        if (d3 / "hertz.dat").read_text() != (d / "hertz.dat").read_text():
            raise RuntimeError("the OUTPUT=3D companion run printed a different .dat")
        info["expanded_node_rule_checked"] = check_expanded_rule(d / "hertz.inp", d3 / "hertz.frd")
    return info, d


def check_expanded_rule(inp, frd3):
    import re
    nodes2d = CF.inp_nodes(inp)
    lines = Path(frd3).read_text().splitlines()
    i = [k for k, ln in enumerate(lines) if ln.startswith("    2C")][0] + 1
    ids, xyz = [], []
    while not lines[i].startswith(" -3"):
        m = re.match(r"^ -1(.{10})(.{12})(.{12})(.{12})", lines[i])
        ids.append(int(m.group(1)))
        xyz.append([float(m.group(j)) for j in (2, 3, 4)])
        i += 1
    xyz = np.array(xyz)
    xy, z = CF.expanded_xy(nodes2d, ids)
    dev = float(np.abs(xy - xyz[:, :2]).max())
    dz = float(np.abs((-0.5 + 0.5 * z) - xyz[:, 2]).max())
    if dev > 1e-5 or dz > 0:
        raise RuntimeError(f"expanded-node rule fails: max |dx| {dev}, |dz| {dz}")
    return dict(nodes_3d=len(ids), max_xy_difference=dev)


def run_sfepy(build):
    import ccxdeck
    d = Path(build) / "sfepy"
    d.mkdir(parents=True)
    import geometry as G
    tm = G.half_disc(**ccxdeck.MESH)
    np.savez(d / "mesh.npz", p=tm.p, t=tm.t)
    out, t = run([str(VENV / "bin" / "python"), str(HERE / "solve_sfepy.py"), "--mesh", "mesh.npz", "--out", "out",
                  "--info", "info.json"], d, "sfepy")
    info = json.loads((d / "info.json").read_text())
    info["wall_s"] = t
    info["mesh_file"] = dict(parameters=ccxdeck.MESH, vertices=int(len(tm.p)), triangles=int(len(tm.t)))
    return info, d / "out"


# ------------------------------------------------------------------ scenes
def scene_for(case):
    c = CASES[case]
    sc = {"material": {"youngs_modulus": E, "poisson_ratio": NU, "model": "plane_strain"}}
    if c["code"] == "calculix":
        sc["fields"] = {"displacement": "U", "stress": "S"}
    else:
        sc["fields"] = {"displacement": "u", "stress": "cauchy_stress", "stress_layout": "xx,yy,xy"}
    contact_where = "(y > 1e-9) && (y < 0.5001)" if c.get("kind") == "block" else "y < 0.5001"
    con = {"name": "contact", "where": contact_where, "kind": "contact", "obstacle": PLANE, "normal": "obstacle"}
    if c.get("friction"):
        con["friction"] = c["friction"]
    if c.get("kind") == "block":
        # Two bodies in the file: audit the disc (the body of the cells with y > 0 at their centroid).
        sc["body"] = {"where": "y > 0"}
    sc["boundary"] = [{"name": "top", "where": "y > 0.9999", "kind": "dirichlet", "displacement": [UD[0], UD[1]]}, con]
    return sc


def scene_header(case):
    c = CASES[case]
    if c["code"] == "sfepy":
        return (f"{case}: scene for hertz.vtk (sfepy 2026.3, legacy VTK 5.1 BINARY written through meshio).\n"
                "u: sfepy's P2 displacement stripped to the 445 vertices (default output), on 3-node triangles.\n"
                "cauchy_stress: cell data, element averages, sfepy's 2D order xx, yy, xy.\n"
                f"Generated by {GEN} -- do not edit by hand.")
    h = (f"{case}: scene for hertz.vtu (CalculiX 2.20 .frd converted by ccx2paraview 3.2.0).\n"
         "U: 3 components D1, D2, D3 (D3 = 0); S: 6 components XX, YY, ZZ, XY, YZ, ZX (ComponentName attributes,\n"
         "no stress_layout given on purpose); other point arrays (S_Mises, S_Principal, RF, CONTACT, ERROR) unused.\n")
    if c["kind"] == "block":
        h += ("TWO BODIES in this file (connected components of the cells): body 0 = the disc (775 CPE6, points with\n"
              "y >= 0; E = 20600, nu = 0.28: this scene), body 1 = the foundation block [-0.255, 0.245] x [-0.1, 0]\n"
              "(250 CPE6, points with y <= 0; E = 2.06e8, bottom y = -0.1 clamped in CalculiX; NOT described here).\n"
              "Audit the disc: [body] where = \"y > 0\" selects the body of the cells with y > 0 at their centroid\n"
              "(docs/design.md 4.2, Bodies).  The contact selector excludes the block's top\n"
              "(y = 0) by y > 1e-9; no point of the block coincides with a point of the disc.\n")
    return h + f"Generated by {GEN} -- do not edit by hand."


# ------------------------------------------------------------------ expected values
STRESS_DERIVED = ("normal_force", "tangential_force", "normal_force_active", "pressure_centroid_x", "a_moment",
                  "tension_max", "pressure_max_nodes", "pressure_max_at_x", "cone_violation_max")


def file_part(case, folder):
    c = CASES[case]
    folder = Path(folder)
    sc = tomllib.loads((folder / "scene.toml").read_text())
    scp = CF.scene_for_python(sc)
    entry = folder / ENTRY[c["code"]]
    legacy = c["code"] == "sfepy"
    piece = CF.read_legacy(entry) if legacy else filecheck.read_piece(entry)
    facts = filecheck.piece_facts(entry, piece, folder) if not legacy else dict(
        file=entry.name, bytes=entry.stat().st_size, points=int(len(piece["points"])), cells=int(len(piece["cells"])),
        cell_types={f"{int(t)} {CF.VTK_NAMES.get(int(t), '?')}": int(n)
                    for t, n in zip(*np.unique(piece["types"], return_counts=True))},
        nodes_per_cell=sorted({int(len(x)) for x in piece["cells"]}),
        point_arrays={k: dict(components=int(v.shape[1]), dtype=str(v.dtype)) for k, v in piece["point_data"].items()},
        cell_arrays={k: dict(components=int(v.shape[1]), dtype=str(v.dtype)) for k, v in piece["cell_data"].items()},
        points_z_max_abs=float(np.abs(piece["points"][:, 2]).max()))
    if legacy:
        facts["legacy_header"] = CF.legacy_header(entry, list(piece["point_data"]) + list(piece["cell_data"]))
        facts.pop("vtkfile_attributes", None)
    else:
        names = CF.component_names(entry)
        for k, a in facts["point_arrays"].items():
            a["component_names"] = names.get(k, [])
    facts["points_dtype"] = CF.points_dtype(entry, legacy)
    facts["meshio"] = CF.meshio_agrees_any(entry, piece)
    comps = CF.bodies(piece["points"], piece["cells"])
    bl = CF.body_facts(piece["points"], piece["cells"], piece["types"], comps)
    top_body = [b["index"] for b in bl if b["bbox"][1][1] > 0.9999]
    assert len(top_body) == 1
    sel = top_body[0]
    for b in bl:
        b["role"] = "disc (the audited body)" if b["index"] == sel else "foundation block (not in the scene)"
    layout = dict(file=facts, bodies=bl, selected_body=sel,
                  min_distance_between_bodies=CF.min_distance_between(piece["points"], piece["cells"], comps))
    X, C, used = CF.submesh(piece["points"], piece["cells"], comps[sel])
    f = sc["fields"]
    U = piece["point_data"][f["displacement"]][used]
    layout["displacement"] = dict(name=f["displacement"], components=int(U.shape[1]),
                                  padding_max_abs=float(np.abs(U[:, 2:]).max()) if U.shape[1] > 2 else None)
    if legacy:
        Sc = piece["cell_data"][f["stress"]][comps[sel]]
        layout["stress"] = dict(name=f["stress"], association="cell", components=int(Sc.shape[1]), layout="xx,yy,xy",
                                component_max_abs=[float(v) for v in np.abs(Sc).max(axis=0)])
        layout["displacement"]["vertices_only"] = True
        S3 = np.zeros((len(X), 3))
    else:
        Sraw = piece["point_data"][f["stress"]][used]
        S3 = Sraw[:, [0, 1, 3]]
        layout["stress"] = dict(name=f["stress"], association="point", components=int(Sraw.shape[1]),
                                component_names=facts["point_arrays"][f["stress"]]["component_names"],
                                layout="xx,yy,zz,xy,yz,zx",
                                component_max_abs=[float(v) for v in np.abs(Sraw).max(axis=0)],
                                out_of_plane_shear_max_abs=float(np.abs(Sraw[:, 4:6]).max()))
        con = piece["point_data"].get("CONTACT")
        if con is not None:
            layout["contact_array"] = dict(
                name="CONTACT", components=int(con.shape[1]),
                component_names=facts["point_arrays"]["CONTACT"]["component_names"], max_abs=float(np.abs(con).max()),
                note=("CalculiX's contact output (COPEN ... CSHEAR2) belongs to the slave nodes, which are not in "
                      "the file (the fixed plane nodes / the expanded 3D nodes); ccx2paraview fills the file's "
                      "nodes with zeros"))
        rf = piece["point_data"].get("RF")
        if rf is not None:
            ytop = X[:, 1] > 0.9999
            layout["RF_top_sum"] = [float(v) for v in rf[used][ytop].sum(axis=0)[:2]]
    ev, fx = filecheck.evaluate_fields(X, C, U, S3, scp, DELTA)
    if legacy:
        ev["cell_stress"] = cs = CF.cell_stress_numbers(fx, Sc, scp)
        for k in STRESS_DERIVED:
            ev["boundaries"]["contact"].pop(k, None)
        ev["boundaries"]["contact"].update({k: v for k, v in cs["contact"].items() if k != "force"})
        ev["boundaries"]["top"]["force"] = cs["top"]["force"]
        ev.pop("traction_free_unselected", None)
    out = dict(files=[dict(file=p, bytes=(folder / p).stat().st_size) for p in COMMITTED[c["code"]]], layout=layout)
    out.update(ev)
    return out


def hertz_part(case, fe, so, info):
    c = CASES[case]
    if c["code"] == "calculix":
        P, Fc = so["reaction_top"]["P"], so["contact_force"]["Fy"]
        hw, xr, pen = so["active_half_width"], so["active_x_range"], so["penetration_max_solver"]
    else:
        P, Fc = info["reaction_top"]["P"], info["contact_force"]["Fy"]
        hw, xr, pen = info["active_half_width"], info["active_x_range"], info["penetration_max_qp"]
    Es = E / (1 - NU ** 2)
    a = math.sqrt(4 * P / (math.pi * Es))
    p0 = 2 * P / (math.pi * a)
    con = fe["boundaries"]["contact"]
    Pf = -fe["boundaries"]["top"]["force"][1]
    h = dict(P_solver=P, contact_force_solver=Fc, E_star=Es, R=1.0, a=a, two_a=2 * a, p0=p0,
             active_half_width_solver=hw, active_x_range_solver=xr, penetration_max_solver=pen,
             P_file=Pf, contact_force_file=con["normal_force"], active_half_width_file=con["active_half_width"],
             active_x_range_file=con["active_x_range"], a_moment_file=con["a_moment"],
             p_max_file=con.get("pressure_max_nodes", con.get("pressure_max_cells")),
             penetration_max_file=con["penetration_max"], penetration_max_nodes_file=con["penetration_max_nodes"],
             gamma_c_length_file=con["length"])
    dev = dict(active_half_width_solver=100 * (hw / a - 1), P_file_vs_P_solver=100 * (Pf / P - 1),
               contact_force_file_vs_P_solver=100 * (con["normal_force"] / P - 1),
               active_half_width_file=100 * (con["active_half_width"] / a - 1),
               a_moment_file=100 * (con["a_moment"] / a - 1), p_max_file=100 * (h["p_max_file"] / p0 - 1))
    if c["code"] == "calculix" and "a_moment_nodal_forces" in so:
        h["a_moment_solver"] = so["a_moment_nodal_forces"]
        h["p_max_solver"] = so["pressure_max_nodal"]
        dev.update(a_moment_solver=100 * (so["a_moment_nodal_forces"] / a - 1), p_max_solver=100 * (so["pressure_max_nodal"] / p0 - 1))
    if c["code"] == "sfepy":
        h["a_moment_solver"] = info["a_moment_quadrature"]
        h["p_max_solver"] = info["pressure_max_qp"]
        dev.update(a_moment_solver=100 * (info["a_moment_quadrature"] / a - 1), p_max_solver=100 * (info["pressure_max_qp"] / p0 - 1))
    h["deviation_percent"] = dev
    return h


def checks_part(case, h):
    lim = dict(LIMITS)
    if CASES[case]["code"] == "sfepy":
        lim["P_file_vs_solver_percent"] = 6.0   # cell-average stress at the clamped top corners
    if CASES[case].get("friction"):
        # incremental Coulomb friction (CalculiX cannot take the load in one increment): the contact
        # zone of the frictional problem is not Hertz's (skfem's one-step P2 friction solution: -3.0 %)
        lim["half_width_percent"] = 7.0
    ch = dict(limits=lim, reaction_vs_contact_rel=abs(h["P_solver"] - h["contact_force_solver"]) / h["P_solver"],
              half_width_vs_a_percent=h["deviation_percent"]["active_half_width_solver"],
              penetration_max_solver=h["penetration_max_solver"], penetration_max_file=h["penetration_max_file"],
              P_file_vs_P_solver_percent=h["deviation_percent"]["P_file_vs_P_solver"])
    ch["passed"] = bool(ch["reaction_vs_contact_rel"] < lim["reaction_vs_contact_rel"]
                        and abs(ch["half_width_vs_a_percent"]) < lim["half_width_percent"]
                        and 0 < ch["penetration_max_solver"] < lim["penetration_solver"]
                        and ch["penetration_max_file"] < lim["penetration_file"]
                        and abs(ch["P_file_vs_P_solver_percent"]) < lim["P_file_vs_solver_percent"])
    return ch


def expected_for(case, folder, info):
    c = CASES[case]
    fe = file_part(case, folder)
    exp = dict(case=case, entry=ENTRY[c["code"]], writer="ccx2paraview" if c["code"] == "calculix" else "sfepy save_state")
    exp.update(fe)
    so = None
    if c["code"] == "calculix":
        so = CF.solver_numbers(c["kind"], folder, spacing=0.001)
        xs, p, tau = so.pop("_cs_x", (None, None, None))
        if c.get("friction") and xs is not None:
            so["stick_slip"] = CF.stick_slip(xs, p, tau, c["friction"])
        exp["solver_output"] = so
    exp["hertz"] = hertz_part(case, fe, so, info)
    exp["checks"] = checks_part(case, exp["hertz"])
    exp["solver"] = {k: v for k, v in info.items() if k not in ("time_s", "time_solve_s", "wall_s", "time_ccx_s",
                                                                  "time_ccx2paraview_s")}
    return runner._clean(exp)


# ------------------------------------------------------------------ README per fixture
def fixture_readme(case, exp, info):
    c = CASES[case]
    h, lay = exp["hertz"], exp["layout"]
    fl = lay["file"]
    arrs = lambda d: ", ".join(f"{k} ({a['components']}" + (f": {', '.join(a['component_names'])}" if a.get("component_names") else "")
                                + ")" for k, a in d.items()) or "none"
    L = [f"# {case}", "",
         "Hertz contact (the problem of fixtures/hertz_skfem_p2, same netgen mesh: hc 0.004, maxh 0.1, grading 0.3,",
         "775 triangles): lower half of the disc of radius 1 centred (0, 1), top y = 1 displaced by (0, -0.01),",
         "E = 20600, nu = 0.28, plane strain, contact with the plane y = 0 on the arc below y = 1/2"
         + (", Coulomb friction 0.4" if c.get("friction") else ", frictionless") + ".", ""]
    if c["code"] == "calculix":
        d = info["deck"]
        v = info["versions"]
        L += [f"Computed by CalculiX {v['calculix']} ({v['debian_package']}) and converted by ccx2paraview {v['ccx2paraview']} "
              f"(numpy {v['ccx2paraview_numpy']}, VTK {v['ccx2paraview_vtk']}, Python {v['ccx2paraview_python']}):", "",
              f"    {GEN}", "",
              "which writes `hertz.inp` (reference/calculix/ccxdeck.py) and runs `ccx -i hertz` then "
              "`reference/.venv-calculix/bin/ccx2paraview hertz.frd vtu` (OMP_NUM_THREADS=1).", ""]
        if c["kind"] == "plane":
            L += [f"- model: the disc only (CPE6). The rigid plane is {d['plane_nodes']} fixed nodes on y = 0, x = {d['plane_x'][0]:g} "
                  f"... {d['plane_x'][1]:g} every {d['plane_spacing']:g}, belonging to no element: the dependent (slave) side "
                  "(`*SURFACE, TYPE=NODE`) of the contact pair, the disc's arc faces below y = 1/2 the independent (master) "
                  "side. CalculiX writes only nodes of elements into the .frd, so the file holds one body.",
                  "- penalty: with a nodal slave surface CalculiX takes the master face's area as the spring area, so "
                  f"the nodal stiffness is slope x face area ({c['penalty']:g} x ~0.004 near x = 0: about 2e8 per unit "
                  "length for the 0.001 node spacing); CalculiX's CPRESS of these nodes is force / master face area, "
                  "not a pressure: the solver's pressure here is the plane node's reaction / 0.001"]
        else:
            L += [f"- model: the disc (775 CPE6) and the foundation block [{d['block']['x'][0]:g}, {d['block']['x'][1]:g}] x [-0.1, 0] ({d['block']['triangles']} "
                  f"CPE6, E = {d['e_block']:g}, nu = 0.28, bottom clamped); slave = the disc's arc faces below y = 1/2, master "
                  "= the block's top faces. **The file holds both bodies** (two connected components, no shared or "
                  "coincident point); the scene describes the disc (see its header).",
                  "- the .dat contact output refers to CalculiX's expanded 3D nodes (3 per plane node); their x comes "
                  "from the rule in ccxfiles.expanded_xy, checked by a companion run with `*NODE FILE, OUTPUT=3D`"]
        L += [f"- solver: {info['method']}; {info['increments']} increments, {info['iterations']} iterations; "
              f"ccx {info.get('_t_ccx', 0):.0f} s wall on this 2-core machine (shared), ccx2paraview "
              f"{info.get('_t_c2p', 0):.1f} s",
              f"- output requests: `*NODE FILE` U, RF; `*EL FILE` S; `*CONTACT FILE` CDIS, CSTR; `*NODE PRINT` RF totals; "
              "`*CONTACT PRINT` CSTR, CDIS; all with FREQUENCY=1000, so only the last increment is written "
              f"(the .frd, {info['frd_bytes']} bytes, is not committed: ASCII, 6 significant digits, what the VTU holds)"]
    else:
        v = info["versions"]
        L += [f"Computed and written by sfepy {v['sfepy']} (numpy {v['numpy']}, scipy {v['scipy']}, Python {v['python']}):", "",
              f"    {GEN}", "",
              "which runs `reference/.venv-calculix/bin/python reference/calculix/solve_sfepy.py --mesh mesh.npz --out DIR`.", "",
              f"- solver: {info['method']}; {info['dofs']} dofs, {info['iterations']} Newton iterations, solve {info.get('_t', 0):.1f} s",
              f"- element: {info['element']}",
              f"- stress: {info['stress']}",
              "- sfepy's `dw_contact_plane` is 3D only (geometries 3_4, 3_8); solve_sfepy.py registers the same term "
              "class for 2D triangles with a 2D plane (see its docstring)",
              "- writer: `pb.save_state('hertz.vtk', out=out)`, sfepy's default 'strip' linearization: the P2 field at "
              f"the {info['vertices']} vertices only ({info['field_nodes']} P2 nodes in the solve), 3-node triangles; sfepy "
              "writes .vtk through meshio (legacy VTK 5.1, BINARY, big-endian, FIELD arrays)"]
    L += ["", "## Files", ""] + [f"- `{f['file']}` ({f['bytes']} bytes)" for f in exp["files"]]
    L += ["", "## Layout", "",
          f"- `{exp['entry']}`: {fl['points']} points, {fl['cells']} cells {fl['cell_types']}, point arrays "
          f"{arrs(fl['point_arrays'])}, cell arrays {arrs(fl['cell_arrays'])}"]
    if "legacy_header" in fl:
        L.append(f"- header: {' | '.join(fl['legacy_header']['lines'])}; sections {', '.join(fl['legacy_header']['sections'])}")
    L.append(f"- bodies: " + "; ".join(f"{b['index']}: {b['cells']} cells, {b['points']} points, bbox {b['bbox']} ({b['role']})"
                                      for b in lay["bodies"]))
    L.append(f"- meshio {fl['meshio']['meshio_version']}: " + ("reads it, identical to VTK" if fl["meshio"].get("identical_to_vtk")
                                                               else str(fl["meshio"])))
    L += ["", "## Key numbers (expected.json)", "",
          f"- solver: top reaction P = {h['P_solver']:.7g}, contact force {h['contact_force_solver']:.7g}",
          f"- Hertz (E* = {h['E_star']:.6g}): a = {h['a']:.6f}, 2a = {h['two_a']:.6f}, p0 = {h['p0']:.6g}",
          f"- active half-width from the solver's contact pressure {h['active_half_width_solver']:.6f} "
          f"({h['deviation_percent']['active_half_width_solver']:+.2f} % of a), x-range {[round(v, 6) for v in h['active_x_range_solver']]}; "
          f"penetration (solver) {h['penetration_max_solver']:.3g}",
          f"- from the file: P = {h['P_file']:.6g} ({h['deviation_percent']['P_file_vs_P_solver']:+.2f} %), contact force "
          f"{h['contact_force_file']:.6g}, penetration half-width {h['active_half_width_file']:.6f}, a moment {h['a_moment_file']:.6f}, "
          f"p max {h['p_max_file']:.6g}, max penetration {h['penetration_max_file']:.3g} (nodes {h['penetration_max_nodes_file']:.3g})"]
    if c.get("friction"):
        ss = exp["solver_output"]["stick_slip"]
        L.append(f"- solver stick zone (|tau| < 0.4 p at the plane nodes): x in {ss['stick_x_range']}")
    L += ["", "Every key is described in reference/calculix/README.md; `make.py --check` recomputes the file-based numbers",
          "(and, for CalculiX, the solver's numbers from hertz.dat / hertz.inp) without CalculiX or sfepy.", ""]
    return "\n".join(L)


# ------------------------------------------------------------------ write / check
def write_case(case, root, info, src):
    c = CASES[case]
    dest = Path(root) / case
    if dest.exists():
        shutil.rmtree(dest)
    dest.mkdir(parents=True)
    for f in COMMITTED[c["code"]]:
        shutil.copy2(Path(src) / f, dest / f)
    (dest / "scene.toml").write_text(runner.scene_toml(scene_for(case), scene_header(case)))
    exp = expected_for(case, dest, info)
    if not exp["checks"]["passed"]:
        raise RuntimeError(f"{case}: physical checks failed: {json.dumps(exp['checks'], indent=1)}")
    (dest / "expected.json").write_text(json.dumps(exp, indent=1) + "\n")
    rinfo = dict(info, _t_ccx=info.get("time_ccx_s", 0), _t_c2p=info.get("time_ccx2paraview_s", 0), _t=info.get("time_s", 0))
    (dest / "README.md").write_text(fixture_readme(case, exp, rinfo))
    return exp


STRIP = {"bytes", "versions", "frd_bytes", "meshio_version", "ccx2paraview_log", "free_dof_residual_max",
         "final_residual_relative"}


def _strip(o):
    if isinstance(o, dict):
        return {k: _strip(v) for k, v in o.items() if k not in STRIP}
    if isinstance(o, list):
        return [_strip(v) for v in o]
    return o


def check_files(root):
    bad = 0
    for case in CASES:
        d = Path(root) / case
        t0 = time.perf_counter()
        if not (d / "expected.json").exists():
            print(f"{case}: MISSING {d}/expected.json")
            bad += 1
            continue
        ref = json.loads((d / "expected.json").read_text())
        new = expected_for(case, d, dict(ref["solver"]))
        diffs = runner.compare(_strip(ref), _strip(new), case, rtol=1e-10)
        if not new["checks"]["passed"]:
            diffs.append(f"{case}: physical checks fail on the committed files")
        if diffs:
            bad += 1
            print(f"{case} [files]: MISMATCH")
            for x in diffs[:20]:
                print("   ", x)
        else:
            h = new["hertz"]
            print(f"{case} [files]: ok ({time.perf_counter() - t0:.1f} s; P solver {h['P_solver']:.7g}, half-width "
                  f"{h['active_half_width_solver']:.5f} ({h['deviation_percent']['active_half_width_solver']:+.2f} %), "
                  f"P file {h['P_file']:.6g}, bodies {len(new['layout']['bodies'])})")
    return bad


def tools_available():
    missing = []
    if CCX is None:
        missing.append("ccx (apt-get install calculix-ccx)")
    if not (VENV / "bin" / "python").exists():
        missing.append(str(VENV.relative_to(REPO)))
    return missing


def generate(root):
    out = {}
    with tempfile.TemporaryDirectory(prefix="fosls-calculix-build-") as build:
        for case, c in CASES.items():
            t0 = time.perf_counter()
            info, src = run_calculix(case, build) if c["code"] == "calculix" else run_sfepy(build)
            out[case] = exp = write_case(case, root, info, src)
            h = exp["hertz"]
            print(f"{case}: P {h['P_solver']:.7g}, contact {h['contact_force_solver']:.7g}, a {h['a']:.5f}, half-width "
                  f"{h['active_half_width_solver']:.5f} ({h['deviation_percent']['active_half_width_solver']:+.2f} %), "
                  f"penetration {h['penetration_max_solver']:.3g} ({time.perf_counter() - t0:.1f} s)")
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--check", action="store_true")
    ap.add_argument("--files-only", action="store_true", help="with --check: never re-run the solvers")
    ap.add_argument("--out", default=str(REPO / "fixtures"))
    a = ap.parse_args(argv)
    t_all = time.perf_counter()
    missing = tools_available()
    if not a.check:
        if missing:
            print(f"cannot regenerate: {', '.join(missing)} missing (install: see reference/calculix/README.md)",
                  file=sys.stderr)
            return 2
        generate(a.out)
        print(f"total {time.perf_counter() - t_all:.1f} s")
        return 0
    bad = check_files(a.out)
    if a.files_only or missing:
        why = "--files-only" if a.files_only else ", ".join(missing) + " absent"
        print(f"solver re-run skipped ({why}); the committed files were re-read and their numbers recomputed")
    else:
        with tempfile.TemporaryDirectory(prefix="fosls-calculix-") as tmp:
            regen = generate(tmp)
            for case, exp in regen.items():
                ref = json.loads((Path(a.out) / case / "expected.json").read_text())
                diffs = runner.compare(_strip(ref), _strip(exp), case, rtol=1e-8)
                if diffs:
                    bad += 1
                    print(f"{case} [re-run]: MISMATCH")
                    for x in diffs[:20]:
                        print("   ", x)
                else:
                    print(f"{case} [re-run]: ok")
    print(f"total {time.perf_counter() - t_all:.1f} s")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
