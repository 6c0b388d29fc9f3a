#!/usr/bin/env python3
"""Hertz contact fixtures computed and written by other codes: DOLFINx 0.11 (fixtures/dolfinx_*) and
PyMFEM 4.10 (fixtures/mfem_*), each with its own writers.  See reference/othercodes/README.md.

    reference/.venv/bin/python reference/othercodes/make.py            # solve + write all fixtures
    reference/.venv/bin/python reference/othercodes/make.py --check    # see below
    reference/.venv/bin/python reference/othercodes/make.py --check --files-only

Runs under reference/.venv (Python 3.11, numpy/scipy/meshio/vtk/ngsolve): the mesh is made here
(netgen, mesh.py), the solves run by subprocess in reference/.venv-dolfinx (solve_dolfinx.py, also
under the wheel's `mpiexec -n 2`) and reference/.venv-mfem (solve_mfem.py), both Python 3.12.

--check: (1) re-reads the committed files of every fixture (VTK and meshio, h5lite for HDF5) and
recomputes every number of expected.json that depends on the files (the `solver` block is taken
from the committed expected.json), comparing with rel. tol. 1e-10; (2) when a code's venv is
present (and not --files-only), re-runs that code's solves into a temporary folder and compares the
regenerated expected.json with the committed one (rel. 1e-8; file sizes, versions, times and
residuals below 1e-8 not compared).  Without the venvs (CI) it prints that the solver re-run was
skipped.  Exit status 1 on any mismatch.
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

HERE = Path(__file__).resolve().parent
REF = HERE.parent
REPO = REF.parent
sys.path.insert(0, str(REF / "hertz"))
sys.path.insert(0, str(HERE))

import runner  # noqa: E402  (scene_toml, compare, _clean)
import filecheck  # noqa: E402

VENV = {"dolfinx": REF / ".venv-dolfinx", "mfem": REF / ".venv-mfem"}
E, NU, UD = 20600.0, 0.28, (0.0, -0.01)
PLANE = {"plane": {"point": [0.0, 0.0], "normal": [0.0, 1.0]}}
DELTA = 1e-10                      # gap tolerance of the file-based active set (hertz/README.md)
LIMITS = dict(reaction_vs_contact_rel=1e-4, half_width_percent=3.5, penetration_nodes=1e-12,
              penetration_file=1e-5, P_file_vs_solver_percent=3.0, mpi_vs_serial_rel=1e-10)

RUNS = {
    "dolfinx_p2": dict(code="dolfinx", mesh="half_disc_p2.msh", degree=2, ranks=1,
                       writers={"vtkfile": "dolfinx_hertz_p2_vtkfile", "xdmf": "dolfinx_hertz_p2_xdmf",
                                "vtx": "dolfinx_hertz_p2_vtx"}),
    "dolfinx_p2_mpi2": dict(code="dolfinx", mesh="half_disc_p2.msh", degree=2, ranks=2,
                            writers={"vtkfile": "dolfinx_hertz_p2_vtkfile_mpi2"}),
    "dolfinx_p1": dict(code="dolfinx", mesh="half_disc_p1.msh", degree=1, ranks=1,
                       writers={"vtkfile": "dolfinx_hertz_p1_vtkfile"}),
    "mfem_highorder": dict(code="mfem", mesh="half_disc_p2.msh", degree=2, high_order=1, lod=2,
                           writers={"paraview": "mfem_hertz_p2_highorder"}),
    "mfem_loworder": dict(code="mfem", mesh="half_disc_p2.msh", degree=2, high_order=0, lod=2,
                          writers={"paraview": "mfem_hertz_p2_loworder"}),
}
# fixture -> (run, writer, boundary selection, entry file, companion fixture)
CASES = {
    "dolfinx_hertz_p2_vtkfile": dict(run="dolfinx_p2", writer="vtkfile", sel="where", entry="solution.pvd"),
    "dolfinx_hertz_p2_vtkfile_mpi2": dict(run="dolfinx_p2_mpi2", writer="vtkfile", sel="where", entry="solution.pvd",
                                          serial="dolfinx_hertz_p2_vtkfile"),
    "dolfinx_hertz_p2_xdmf": dict(run="dolfinx_p2", writer="xdmf", sel="tag", entry="solution.xdmf"),
    "dolfinx_hertz_p2_vtx": dict(run="dolfinx_p2", writer="vtx", sel="where", entry="solution.bp",
                                 companion="dolfinx_hertz_p2_vtkfile"),
    "dolfinx_hertz_p1_vtkfile": dict(run="dolfinx_p1", writer="vtkfile", sel="where", entry="solution.pvd"),
    "mfem_hertz_p2_highorder": dict(run="mfem_highorder", writer="paraview", sel="where",
                                    entry="solution/solution.pvd"),
    "mfem_hertz_p2_loworder": dict(run="mfem_loworder", writer="paraview", sel="where",
                                   entry="solution/solution.pvd"),
}
GEN = "reference/.venv/bin/python reference/othercodes/make.py"


# ------------------------------------------------------------------ solves
def solver_env():
    env = dict(os.environ, UCX_TLS="self,sm,tcp", OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1")
    env.pop("PYTHONPATH", None)
    return env


def run_solvers(build, codes):
    """mesh + every run of the given codes into build/; -> {run: (info, {writer: folder})}."""
    import mesh as MESH
    build = Path(build)
    mfacts = MESH.make(build / "mesh")
    res = {}
    for name, r in RUNS.items():
        if r["code"] not in codes:
            continue
        py = str(VENV[r["code"]] / "bin" / "python")
        m = str(build / "mesh" / r["mesh"])
        info = build / f"{name}.json"
        outs = {w: build / name / w for w in r["writers"]}
        if r["code"] == "dolfinx":
            cmd = [py, str(HERE / "solve_dolfinx.py"), "--mesh", m, "--degree", str(r["degree"]), "--info", str(info)]
            for w, d in outs.items():
                cmd += [f"--{w}", str(d)]
            if r["ranks"] > 1:
                cmd = [str(VENV["dolfinx"] / "bin" / "mpiexec"), "-n", str(r["ranks"])] + cmd
        else:
            cmd = [py, str(HERE / "solve_mfem.py"), "--mesh", m, "--order", str(r["degree"]), "--out",
                   str(outs["paraview"]), "--high-order", str(r["high_order"]), "--lod", str(r["lod"]),
                   "--info", str(info)]
        t0 = time.perf_counter()
        p = subprocess.run(cmd, env=solver_env(), capture_output=True, text=True)
        if p.returncode != 0:
            sys.stderr.write(p.stdout + p.stderr)
            raise RuntimeError(f"{name}: solver failed ({p.returncode}): {' '.join(cmd)}")
        print(f"  {name}: {p.stdout.strip().splitlines()[-1]} (wall {time.perf_counter() - t0:.1f} s)")
        d = json.loads(info.read_text())
        d["wall_s"] = time.perf_counter() - t0
        d["mesh_file"] = dict(file=r["mesh"], **mfacts[r["mesh"]])
        res[name] = (d, outs)
    return res


# ------------------------------------------------------------------ scenes
def scene_for(case):
    c = CASES[case]
    sc = {"material": {"youngs_modulus": E, "poisson_ratio": NU, "model": "plane_strain"},
          "fields": {"displacement": "displacement", "stress": "stress"}}
    if case.startswith("mfem_"):
        sc["fields"]["stress_layout"] = "xx,yy,xy"
    if c["sel"] == "tag":
        sc["boundaries"] = {"tag_array": "facet_tags"}
        top, con = {"tag": 2}, {"tag": 1}
    else:
        top, con = {"where": "y > 0.9999"}, {"where": "y < 0.5001"}
    sc["boundary"] = [
        {"name": "top", **top, "kind": "dirichlet", "displacement": [UD[0], UD[1]]},
        {"name": "contact", **con, "kind": "contact", "obstacle": PLANE, "normal": "obstacle"}]
    return sc


def scene_header(case):
    c = CASES[case]
    what = {"vtkfile": "the DOLFINx VTKFile set (solution.pvd -> solution000000.pvtu -> solution_p*_000000.vtu)",
            "xdmf": "solution.xdmf + solution.h5 (DOLFINx XDMFFile); tags = the meshtags 'facet_tags'",
            "vtx": "solution.bp (DOLFINx VTXWriter, ADIOS2 BP4)",
            "paraview": "the MFEM ParaViewDataCollection solution/ (solution.pvd, Cycle000000/proc000000.vtu)"}[c["writer"]]
    lay = ("stress: no stress_layout on purpose (9 components xx, xy, yx, yy + 5 zeros, DOLFINx's padded 2x2 tensor; "
           "to be detected)" if case.startswith("dolfinx_") else "stress: MFEM vdim-3 GridFunction, Voigt xx, yy, xy")
    return (f"{case}: scene for {what}.\n{lay}.\n"
            f"Generated by {GEN} -- do not edit by hand.")


# ------------------------------------------------------------------ expected values
def file_part(case, folder, root):
    c = CASES[case]
    sc = tomllib.loads((Path(folder) / "scene.toml").read_text())
    fields = None
    if c["writer"] in ("vtkfile", "paraview"):
        out, fields = filecheck.check_vtk_case(folder, sc, c["entry"], DELTA)
    elif c["writer"] == "xdmf":
        out, fields = filecheck.check_xdmf_case(folder, sc, DELTA, c["entry"])
    else:
        out = filecheck.check_vtx_case(folder, Path(root) / c["companion"])
    if c.get("serial") and fields is not None:
        twin = Path(root) / c["serial"]
        if twin.exists():
            sct = tomllib.loads((twin / "scene.toml").read_text())
            _, tf = filecheck.check_vtk_case(twin, sct, CASES[c["serial"]]["entry"], DELTA)
            out["vs_serial"] = dict(fixture=c["serial"], **filecheck.compare_fields(fields, tf))
    return out


def hertz_part(fe, info):
    P = info["reaction_top"]["P"]
    Es = E / (1 - NU ** 2)
    a = math.sqrt(4 * P / (math.pi * Es))
    p0 = 2 * P / (math.pi * a)
    h = dict(P_solver=P, contact_force_solver=info["contact_force_multipliers"], E_star=Es, R=1.0,
             a=a, two_a=2 * a, p0=p0, active_half_width_solver=info["active_half_width"],
             active_x_range_solver=info["active_x_range"], a_moment_multipliers=info["a_moment_multipliers"],
             penetration_max_nodes_solver=info["penetration_max_nodes"])
    dev = dict(active_half_width_solver=100 * (info["active_half_width"] / a - 1),
               a_moment_multipliers=100 * (info["a_moment_multipliers"] / a - 1))
    if "boundaries" in fe:
        con = fe["boundaries"]["contact"]
        Pf = -fe["boundaries"]["top"]["force"][1]
        h.update(P_file=Pf, contact_force_file=con["normal_force"], active_half_width_file=con["active_half_width"],
                 a_moment_file=con["a_moment"], p_max_file=con["pressure_max_nodes"],
                 penetration_max_file=con["penetration_max"], penetration_max_nodes_file=con["penetration_max_nodes"],
                 gamma_c_length_file=con["length"])
        dev.update(P_file_vs_P_solver=100 * (Pf / P - 1), active_half_width_file=100 * (con["active_half_width"] / a - 1),
                   a_moment_file=100 * (con["a_moment"] / a - 1), p_max_file=100 * (con["pressure_max_nodes"] / p0 - 1))
    h["deviation_percent"] = dev
    return h


def checks_part(fe, h):
    ch = dict(limits=LIMITS,
              reaction_vs_contact_rel=abs(h["P_solver"] - h["contact_force_solver"]) / h["P_solver"],
              half_width_vs_a_percent=h["deviation_percent"]["active_half_width_solver"],
              penetration_max_nodes_solver=h["penetration_max_nodes_solver"])
    ok = (ch["reaction_vs_contact_rel"] < LIMITS["reaction_vs_contact_rel"]
          and abs(ch["half_width_vs_a_percent"]) < LIMITS["half_width_percent"]
          and ch["penetration_max_nodes_solver"] < LIMITS["penetration_nodes"])
    if "P_file" in h:
        ch["penetration_max_file"] = h["penetration_max_file"]
        ch["P_file_vs_P_solver_percent"] = h["deviation_percent"]["P_file_vs_P_solver"]
        ok &= h["penetration_max_file"] < LIMITS["penetration_file"]
        ok &= abs(ch["P_file_vs_P_solver_percent"]) < LIMITS["P_file_vs_solver_percent"]
    if "vs_serial" in fe:
        vs = fe["vs_serial"]
        ch["mpi_vs_serial_stress_rel"] = vs["stress"] / vs["stress_max_abs"]
        ch["mpi_vs_serial_displacement_abs"] = vs["displacement"]
        ok &= ch["mpi_vs_serial_stress_rel"] < LIMITS["mpi_vs_serial_rel"] and vs["points"] < 1e-14
    if "arrays_in_data0_vs_vtkfile" in fe.get("layout", {}):
        loc = fe["layout"]["arrays_in_data0_vs_vtkfile"]
        ch["vtx_arrays_found"] = (all(loc[k] is not None for k in ("geometry", "displacement", "stress"))
                                  and loc["connectivity"]["offset"] is not None)
        ok &= ch["vtx_arrays_found"]
    ch["passed"] = bool(ok)
    return ch


def solver_block(info):
    return {k: v for k, v in info.items() if k not in ("time_s", "time_solve_s", "wall_s")}


def expected_for(case, folder, root, info):
    fe = file_part(case, folder, root)
    exp = dict(case=case, entry=CASES[case]["entry"], writer=CASES[case]["writer"])
    exp.update(fe)
    exp["hertz"] = hertz_part(fe, info)
    exp["checks"] = checks_part(fe, exp["hertz"])
    exp["solver"] = solver_block(info)
    return runner._clean(exp)


# ------------------------------------------------------------------ README per fixture
WRITER_TEXT = {
    "vtkfile": "DOLFINx `io.VTKFile(comm, \"solution.pvd\", \"w\").write_function([u, sigma], 0.0)`",
    "xdmf": ("DOLFINx `io.XDMFFile(comm, \"solution.xdmf\", \"w\")`: `write_mesh`, `write_meshtags(facet_tags, "
             "mesh.geometry)`, `write_function(u, 0.0)`, `write_function(sigma, 0.0)` (HDF5 data in solution.h5)"),
    "vtx": "DOLFINx `io.VTXWriter(comm, \"solution.bp\", [u, sigma], engine=\"BP4\").write(0.0)` (ADIOS2)",
    "paraview": "MFEM `ParaViewDataCollection(\"solution\", mesh)`",
}


def fixture_readme(case, exp, info):
    c = CASES[case]
    r = RUNS[c["run"]]
    h = exp["hertz"]
    v = info["versions"]
    lay = exp.get("layout", {})
    if r["code"] == "dolfinx":
        cmd = (f"reference/.venv-dolfinx/bin/{'mpiexec -n 2 reference/.venv-dolfinx/bin/' if r['ranks'] > 1 else ''}"
               f"python reference/othercodes/solve_dolfinx.py --mesh {r['mesh']} --degree {r['degree']} "
               f"--{c['writer']} DIR")
        ver = (f"DOLFINx {v['dolfinx']} (PyPI wheel dolfinx-solver-real {v['dolfinx_solver_real']}; basix {v['basix']}, "
               f"ffcx {v['ffcx']}, ufl {v['ufl']}, petsc4py {v['petsc4py']}, mpi4py {v['mpi4py']}, mpich {v['mpich']}), "
               f"Python {v['python']}")
    else:
        cmd = (f"reference/.venv-mfem/bin/python reference/othercodes/solve_mfem.py --mesh {r['mesh']} --order 2 "
               f"--high-order {r['high_order']} --lod {r['lod']} --out DIR")
        ver = f"PyMFEM (pip `mfem`) {v['mfem']}, numpy {v['numpy']}, Python {v['python']}"
    lines = [f"# {case}", "",
             "Hertz contact (same problem and mesh as fixtures/hertz_skfem_p2 / hertz_ngsolve_p2"
             + (", P1 on the finer mesh hc = 0.003" if r["degree"] == 1 else "") + "): lower half of the disc of",
             "radius 1 centred (0, 1), top y = 1 displaced by (0, -0.01), E = 20600, nu = 0.28, plane strain, frictionless",
             "contact with the plane y = 0 along the obstacle normal (u_y >= -y) on the arc below y = 1/2; rest of the arc",
             "traction-free. Computed and written by " + ("DOLFINx" if r["code"] == "dolfinx" else "MFEM") + " itself.", "",
             "Produced by", "", f"    {GEN}", "",
             f"which runs `{cmd}`" + (" (2 MPI ranks, the wheel's MPICH `mpiexec`)" if r.get("ranks", 1) > 1 else "")
             + (" (one run writes " + ", ".join(f"`{x}`" for x in r["writers"].values()) + ")" if len(r["writers"]) > 1 else "")
             + ".", "",
             f"- versions: {ver}",
             f"- solver: {info['method']}; {info['element']}; {info['dofs']} dofs; {info['iterations']} active-set steps; "
             f"solve + output {info['time_s']:.1f} s (wall incl. start-up {info['wall_s']:.1f} s)",
             f"- stress: {info['stress']}",
             f"- mesh: {info['mesh_file']['file']} (netgen, reference/othercodes/mesh.py; hc = {info['mesh_file']['parameters']['hc']}, "
             f"maxh {info['mesh_file']['parameters']['hmax']}, grading {info['mesh_file']['parameters']['grading']}), "
             f"{info['cells']} triangles",
             f"- writer: {WRITER_TEXT[c['writer']]}"
             + (f", SetLevelsOfDetail({r['lod']}), SetHighOrderOutput({bool(r['high_order'])})" if r["code"] == "mfem" else ""),
             "", "## Files", ""]
    for f in exp["files"]:
        lines.append(f"- `{f['file']}`" + (f" ({f['bytes']} bytes)" if f["bytes"] is not None else " (ADIOS2 profiling, run-dependent)"))
    lines += ["", "## Layout", ""]
    if c["writer"] in ("vtkfile", "paraview"):
        def arrs(d):
            return ", ".join("%s (%d)" % (k, a["components"]) for k, a in d.items()) or "none"
        for p in lay["pieces"]:
            npc = "/".join(map(str, p["nodes_per_cell"]))
            lines.append(f"- `{p['file']}`: {p['points']} points, {p['cells']} cells {p['cell_types']} "
                         f"({npc} nodes per cell; a point is used by at most {p['cells_per_point_max']} cells), "
                         f"data {', '.join(p['data_formats'])}, "
                         f"point arrays {arrs(p['point_arrays'])}, cell arrays {arrs(p['cell_arrays'])}"
                         + (f", ghost cells {p['ghost_cells']}, ghost points {p['ghost_points']}" if p["ghost_cells"] is not None else ""))
        m = lay["merge"]
        lines.append(f"- PVTU GhostLevel {lay['pvtu']['ghost_level']}; merged (ghost cells dropped, coincident points merged): "
                     f"{m['points_merged']} points of {m['points_in_files']} in the files, {m['cells_kept']} cells")
    elif c["writer"] == "xdmf":
        for d, i in lay["h5"]["datasets"].items():
            lines.append(f"- `solution.h5:{d}` {i['shape']} {i['dtype']} ({i['layout']})")
        lines.append(f"- XDMF {lay['xdmf']['version']}, grids: " + ", ".join(
            f"{g['Name']} ({g['GridType']})" for g in lay["xdmf"]["grids"]) + f"; facet tag counts {lay['facet_tags']}")
    else:
        lines.append(f"- ADIOS2 BP4 folder; the VTK schema in md.0 names {', '.join(lay['schema_arrays'])}")
        loc = lay.get("arrays_in_data0_vs_vtkfile", {})
        for k in ("geometry", "displacement", "stress"):
            if loc.get(k):
                lines.append(f"- `{k}` {loc[k]['shape']} float64 at byte {loc[k]['offset']} of data.0 "
                             f"(= the {loc['companion']} values, max diff {loc[k]['max_abs_difference']:.1e})")
    if "stress" in lay:
        s = lay["stress"]
        lines.append(f"- `displacement`: {lay['displacement']['components']} components"
                     + (" (z = 0 padding)" if lay["displacement"]["components"] == 3 else ""))
        lines.append(f"- `stress`: {s['components']} components, layout **{s['layout']}** — {s.get('description', '')}")
    lines += ["", "## Key numbers (expected.json)", "",
              f"- solver: top reaction P = {h['P_solver']:.10g}, contact force (multipliers) {h['contact_force_solver']:.10g}",
              f"- Hertz (P from the solver, E* = {h['E_star']:.6g}): a = {h['a']:.6f}, 2a = {h['two_a']:.6f}, p0 = {h['p0']:.6g}",
              f"- active half-width (solver's active set) {h['active_half_width_solver']:.6f} "
              f"({h['deviation_percent']['active_half_width_solver']:+.2f} % of a)"]
    if "P_file" in h:
        lines += [f"- from the file: P = {h['P_file']:.6g} ({h['deviation_percent']['P_file_vs_P_solver']:+.2f} %), "
                  f"contact force {h['contact_force_file']:.6g}, active half-width {h['active_half_width_file']:.6f}, "
                  f"a moment {h['a_moment_file']:.6f}, p max {h['p_max_file']:.6g}, max penetration {h['penetration_max_file']:.3g} "
                  f"(nodes {h['penetration_max_nodes_file']:.3g})",
                  f"- arc lengths from the file: Gamma_C {exp['arc']['gamma_c_length']:.10f} (2 pi / 3 = {2 * math.pi / 3:.10f}), "
                  f"whole arc {exp['arc']['whole_arc_length']:.10f} (pi = {math.pi:.10f})"]
    if "vs_serial" in exp:
        vs = exp["vs_serial"]
        lines.append(f"- against the serial {vs['fixture']}: max |d stress| {vs['stress']:.2e}, max |d u| {vs['displacement']:.2e}")
    lines += ["", "Every key is described in reference/othercodes/README.md; `make.py --check` recomputes the file-based",
              "numbers from these files (VTK, meshio, h5lite) without DOLFINx or MFEM.", ""]
    return "\n".join(lines)


# ------------------------------------------------------------------ write / check
def write_case(case, root, res):
    c = CASES[case]
    info, outs = res[c["run"]]
    dest = Path(root) / case
    if dest.exists():
        shutil.rmtree(dest)
    shutil.copytree(outs[c["writer"]], dest)
    (dest / "scene.toml").write_text(runner.scene_toml(scene_for(case), scene_header(case)))
    exp = expected_for(case, dest, root, info)
    if not exp["checks"]["passed"]:
        raise RuntimeError(f"{case}: physical checks failed: {json.dumps(exp['checks'], indent=1)}")
    (dest / "expected.json").write_text(json.dumps(exp, indent=1) + "\n")
    (dest / "README.md").write_text(fixture_readme(case, exp, info))
    return exp


STRIP = {"bytes", "versions", "time_s", "wall_s", "time_solve_s", "meshio_version"}


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
        info = dict(ref["solver"])
        new = expected_for(case, d, root, info)
        diffs = runner.compare(_strip_volatile_keep(ref), _strip_volatile_keep(new), case, rtol=1e-10)
        if not new["checks"]["passed"]:
            diffs.append(f"{case}: physical checks fail on the committed files")
        if diffs:
            bad += 1
            print(f"{case} [files]: MISMATCH")
            for x in diffs[:20]:
                print("   ", x)
        else:
            print(f"{case} [files]: ok ({time.perf_counter() - t0:.1f} s; P_file {new['hertz'].get('P_file', float('nan')):.6g}, "
                  f"stress layout {new.get('layout', {}).get('stress', {}).get('layout', '-')})")
    return bad


def _strip_volatile_keep(o):
    """for the file check: everything is recomputed from the same bytes, only meshio's version string
    may legitimately differ."""
    if isinstance(o, dict):
        return {k: _strip_volatile_keep(v) for k, v in o.items() if k not in ("meshio_version", "versions")}
    if isinstance(o, list):
        return [_strip_volatile_keep(v) for v in o]
    return o


def codes_available():
    return [c for c, v in VENV.items() if (v / "bin" / "python").exists()]


def generate(root, codes):
    with tempfile.TemporaryDirectory(prefix="fosls-othercodes-build-") as build:
        res = run_solvers(build, codes)
        out = {}
        for case in CASES:
            if RUNS[CASES[case]["run"]]["code"] in codes:
                t0 = time.perf_counter()
                out[case] = write_case(case, root, res)
                h = out[case]["hertz"]
                print(f"{case}: P {h['P_solver']:.10g}, contact {h['contact_force_solver']:.10g}, a {h['a']:.5f}, "
                      f"half-width {h['active_half_width_solver']:.5f} ({h['deviation_percent']['active_half_width_solver']:+.2f} %)"
                      f" ({time.perf_counter() - t0:.1f} s)")
        return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--check", action="store_true")
    ap.add_argument("--files-only", action="store_true", help="with --check: never re-run the solvers")
    ap.add_argument("--out", default=str(REPO / "fixtures"))
    a = ap.parse_args(argv)
    t_all = time.perf_counter()
    codes = codes_available()
    if not a.check:
        missing = [c for c in VENV if c not in codes]
        if missing:
            print(f"cannot regenerate: {', '.join(str(VENV[c]) for c in missing)} missing "
                  f"(install: see reference/othercodes/README.md)", file=sys.stderr)
            return 2
        generate(a.out, codes)
        print(f"total {time.perf_counter() - t_all:.1f} s")
        return 0
    bad = check_files(a.out)
    if a.files_only or not codes:
        why = "--files-only" if a.files_only else ", ".join(str(v.relative_to(REPO)) for v in VENV.values()) + " absent"
        print(f"solver re-run skipped ({why}); the committed files were re-read and their numbers recomputed")
    else:
        skipped = [c for c in VENV if c not in codes]
        if skipped:
            print(f"solver re-run skipped for {', '.join(skipped)} (venv absent)")
        with tempfile.TemporaryDirectory(prefix="fosls-othercodes-") as tmp:
            # companions / serial twins of the cases of a skipped code come from the committed tree
            for case in CASES:
                if RUNS[CASES[case]["run"]]["code"] not in codes:
                    shutil.copytree(Path(a.out) / case, Path(tmp) / case)
            regen = generate(tmp, codes)
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
