#!/usr/bin/env python3
"""Speed against accuracy of `fosls estimate` on the Hertz problem (tracker issue 4).

    reference/.venv/bin/python reference/speed_accuracy/run.py            # full table, updates BENCHMARKS.md
    reference/.venv/bin/python reference/speed_accuracy/run.py --quick    # fixture-size mesh only, coarser reference
    reference/.venv/bin/python reference/speed_accuracy/run.py --no-write # only print

The binary comes from $FOSLS (default <repo>/target/release/fosls).

1. Solves the Hertz problem of reference/hertz (half disc R = 1, E = 20600, nu = 0.28, u_D = (0, -0.01),
   plane y = 0) with the scikit-fem active-set solver (P1 and curved P2, frictionless and Coulomb F = 0.4)
   on graded netgen meshes, the smallest of which is the mesh of the committed fixtures
   (hc = 0.004, maxh = 0.1, grading = 0.3), and writes solution.vtu + scene.toml like the fixtures
   into a temporary folder (nothing goes to fixtures/).
2. Solves the same problems with scikit-fem P2 on a much finer mesh: the reference u_ref.
3. Runs every setting of `fosls estimate` on every file (wall time and peak RSS from /usr/bin/time,
   best of --repeat runs) and computes the error against the reference on the fine mesh's quadrature
   points (coarse fields evaluated at those points, gradient from the coarse element):
       ||e_u||_E = ( 1/2 (C eps(u_ref - u), eps(u_ref - u)) )^(1/2)       (the "energy" preset's norm)
       ||e_s||_A = ( 1/2 (A(s_ref - s_h), s_ref - s_h) )^(1/2),  s_ref = C eps(u_ref)   (file stress only)
   u is the file's u_h, or fosls's reconstructed displacement (read back from --output). The report's
   bound.energy_error (given for an equilibrated stress: --stress patch) is set against ||e_u||_E the same way.
4. Prints the table, writes reference/speed_accuracy/results.json and rewrites the block
   <!-- speed-accuracy:begin --> ... <!-- speed-accuracy:end --> in BENCHMARKS.md.
"""
import argparse
import json
import os
import platform
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO = HERE.parents[1]
sys.path.insert(0, str(REPO / "reference" / "hertz"))

import numpy as np  # noqa: E402
import meshio  # noqa: E402
from scipy.spatial import cKDTree  # noqa: E402
from matplotlib.tri import Triangulation  # noqa: E402

import geometry as G  # noqa: E402
import problems as PR  # noqa: E402
import runner  # noqa: E402
import vtuio  # noqa: E402
import fem_skfem as S  # noqa: E402

# SuperLU with a symmetric ordering: the same solutions, ~3x faster than scipy's default COLAMD here
_spsolve = S.spl.spsolve
S.spl = type("spl", (), {"spsolve": staticmethod(lambda A, b: _spsolve(A, b, permc_spec="MMD_AT_PLUS_A")),
                         "splu": staticmethod(S.spl.splu)})

NU = 0.28
FRICTION = 0.4
MESHES = {  # graded half-disc meshes (reference/hertz/geometry.py half_disc)
    "M0": dict(hc=0.004, hmax=0.1, grading=0.3),     # the committed fixtures' mesh (775 cells)
    "M1": dict(hc=0.002, hmax=0.05, grading=0.2),
    "M2": dict(hc=0.001, hmax=0.025, grading=0.15),
}
FULL = dict(coarse={1: ["M0", "M1", "M2"], 2: ["M0", "M1"]}, ref=dict(hc=0.0005, hmax=0.0125, grading=0.15))
QUICK = dict(coarse={1: ["M0"], 2: ["M0"]}, ref=dict(hc=0.001, hmax=0.025, grading=0.15))

# (stress source, RT degree or None, friction model on, displacement source)
# "patch": the equilibrated reconstruction on vertex patches (RT_P, degree chosen by fosls), the one with a bound
SETTINGS_FRICTIONLESS = [("file", None, False, "file"), ("reconstruct", 0, False, "file"),
                         ("reconstruct", 1, False, "file"), ("patch", None, False, "file"),
                         ("file", None, False, "reconstruct")]
SETTINGS_COULOMB = [("file", None, True, "file"), ("reconstruct", 0, True, "file"), ("reconstruct", 1, True, "file"),
                    ("patch", None, True, "file"), ("file", None, True, "reconstruct"),
                    ("file", None, False, "file"), ("reconstruct", 0, False, "file"), ("reconstruct", 1, False, "file"),
                    ("patch", None, False, "file")]


# ------------------------------------------------------------------ files
def scene_dict(friction):
    return {"material": {"youngs_modulus": PR.E, "poisson_ratio": NU, "model": "plane_strain"},
            "fields": {"displacement": "u", "stress": "stress"},
            "boundaries": {"tag_array": "boundary_tag"},
            "boundary": [{"name": "top", "tag": 2, "kind": "dirichlet", "displacement": [0.0, -0.01]},
                         {"name": "contact", "tag": 1, "kind": "contact", "obstacle": PR.PLANE, "normal": "obstacle",
                          **({"friction": friction} if friction else {})}]}


def write_case(outdir, name, sol, friction):
    d = Path(outdir) / name
    d.mkdir(parents=True, exist_ok=True)
    pdata = {"u": np.ascontiguousarray(sol["U"]), "stress": vtuio.stress_layout(sol["S4"], "xx,yy,zz,xy")}
    vtuio.write(d / "solution.vtu", sol["nodes"], sol["cells"], sol["lines"], pdata, tag_name="boundary_tag",
                tags=sol["tags"], encoding="zlib", write_lines=True)
    hdr = f"{name}: written by reference/speed_accuracy/run.py"
    (d / "scene.toml").write_text(runner.scene_toml(scene_dict(friction), hdr))
    if friction:  # the same file evaluated without the friction model
        (d / "scene_nofriction.toml").write_text(runner.scene_toml(scene_dict(0.0), hdr + " (friction removed)"))
    return d


# ------------------------------------------------------------------ errors against the reference
def locate(tm, X):
    """cell of the coarse TriMesh containing each point X (2, N); points outside the straight-sided mesh
    (between a chord and the arc) go to the candidate cell with the largest minimal barycentric coordinate."""
    tri = Triangulation(tm.p[:, 0], tm.p[:, 1], tm.t)
    cells = tri.get_trifinder()(X[0], X[1]).astype(np.int64)
    out = np.where(cells < 0)[0]
    if len(out):
        cen = tm.p[tm.t].mean(axis=1)
        _, cand = cKDTree(cen).query(X[:, out].T, k=8)
        best = np.full(len(out), -np.inf)
        for j in range(cand.shape[1]):
            c = cand[:, j]
            a, b, cc = tm.p[tm.t[c, 0]], tm.p[tm.t[c, 1]], tm.p[tm.t[c, 2]]
            v0, v1, v2 = b - a, cc - a, X[:, out].T - a
            det = v0[:, 0] * v1[:, 1] - v0[:, 1] * v1[:, 0]
            l1 = (v2[:, 0] * v1[:, 1] - v2[:, 1] * v1[:, 0]) / det
            l2 = (v0[:, 0] * v2[:, 1] - v0[:, 1] * v2[:, 0]) / det
            m = np.minimum(np.minimum(l1, l2), 1 - l1 - l2)
            upd = m > best
            best[upd] = m[upd]
            cells[out[upd]] = c[upd]
    return cells, (len(out), int((np.asarray(best) < -0.5).sum()) if len(out) else 0)


class CoarseEval:
    """evaluate grad u_h and the nodal stress of a coarse solution at arbitrary points."""

    def __init__(self, dsc, X):
        self.dsc = dsc
        self.cells, self.outside = locate(dsc.tm, X)
        self.mapping = dsc.ub.mapping
        self.pts = self.mapping.invF(X[:, :, None], tind=self.cells)

    def grad(self, u):
        ub, c = self.dsc.ub, self.cells
        g = 0.0
        for k in range(ub.Nbfun):
            gk = ub.elem.gbasis(self.mapping, self.pts, k, tind=c)[0].grad[..., 0]  # (2, 2, N)
            g = g + u[ub.element_dofs[k, c]][None, None, :] * gk
        return g

    def stress(self, S4):
        sb, c = self.dsc.sb, self.cells
        out = []
        for i in (0, 1, 3):  # xx, yy, xy
            sd = np.zeros(sb.N)
            sd[self.dsc.snode] = S4[:, i]
            v = 0.0
            for k in range(sb.Nbfun):
                v = v + sd[sb.element_dofs[k, c]] * sb.elem.gbasis(self.mapping, self.pts, k, tind=c)[0].value[:, 0]
            out.append(v)
        xx, yy, xy = out
        return np.array([[xx, xy], [xy, yy]])


class Reference:
    def __init__(self, mesh, friction):
        t0 = time.time()
        self.tm = G.half_disc(**mesh)
        self.sol = PR.solve_skfem(self.tm, 2, NU, friction=friction, curved_tags=(1, 3))
        d = self.sol["dsc"]
        fb = d.ub
        Xg = fb.mapping.F(fb.X)  # (2, nel, nq)
        self.shape = Xg.shape[1:]
        self.X = Xg.reshape(2, -1)
        self.dx = np.asarray(fb.dx).reshape(-1)
        self.grad = np.asarray(fb.interpolate(self.sol["raw"]["u"]).grad).reshape(2, 2, -1)
        self.lam, self.mu = S.lame(PR.E, NU)
        eps = 0.5 * (self.grad + self.grad.transpose(1, 0, 2))
        self.sigma = 2 * self.mu * eps + self.lam * np.einsum("iin->n", eps)[None, None, :] * np.eye(2)[:, :, None]
        self.energy = self.norm_E(self.grad * 0.0)
        self.cells = len(self.tm.t)
        self.dofs = self.sol["info"]["dofs"]
        self.seconds = time.time() - t0

    def norm_E(self, grad_h):
        e = self.grad - grad_h
        e = 0.5 * (e + e.transpose(1, 0, 2))
        tr = e[0, 0] + e[1, 1]
        dens = self.mu * (e ** 2).sum(axis=(0, 1)) + 0.5 * self.lam * tr ** 2
        return float(np.sqrt((dens * self.dx).sum()))

    def norm_A(self, sig_h):
        e = self.sigma - sig_h
        tr = e[0, 0] + e[1, 1]
        Ae = (e - (self.lam / (2 * (self.mu + self.lam))) * tr[None, None, :] * np.eye(2)[:, :, None]) / (2 * self.mu)
        return float(np.sqrt(0.5 * ((Ae * e).sum(axis=(0, 1)) * self.dx).sum()))


def dofvec_from_nodes(dsc, U):
    u = np.zeros(dsc.nu_dofs)
    u[dsc.node_dofs[:, 0]] = U[:, 0]
    u[dsc.node_dofs[:, 1]] = U[:, 1]
    return u


def read_reconstructed_u(path, dsc):
    m = meshio.read(path)
    U = np.asarray(m.point_data["displacement_reconstructed"])[:, :2]
    P = np.asarray(m.points)[:, :2]
    if P.shape[0] == dsc.nodes.shape[0] and np.allclose(P, dsc.nodes, atol=1e-12):
        return dofvec_from_nodes(dsc, U)
    dist, idx = cKDTree(P).query(dsc.nodes)
    assert dist.max() < 1e-9, "output points do not match the file's nodes"
    return dofvec_from_nodes(dsc, U[idx])


# ------------------------------------------------------------------ fosls
def run_fosls(fosls, case_dir, scene, stress, degree, disp, repeat, want_output):
    out_vtu = case_dir / "out.vtu"
    args = [fosls, "estimate", str(case_dir / "solution.vtu"), "--scene", str(case_dir / scene), "--json", "-",
            "--quiet", "--stress", stress, "--displacement", disp]
    if degree is not None:
        args += ["--degree", str(degree)]
    if want_output:
        args += ["--output", str(out_vtu)]
    best = None
    for _ in range(repeat):
        tf = case_dir / "time.txt"
        t0 = time.perf_counter()
        p = subprocess.run(["/usr/bin/time", "-f", "%e %M", "-o", str(tf)] + args, capture_output=True, text=True)
        wall = time.perf_counter() - t0
        if p.returncode != 0:
            raise RuntimeError(f"fosls failed ({p.returncode}): {' '.join(args)}\n{p.stderr}")
        rss_kib = int(tf.read_text().split()[-1])
        rep = json.loads(p.stdout)
        if best is None or wall < best["wall"]:
            best = dict(wall=wall, rss_mib=rss_kib / 1024.0, report=rep)
        else:
            best["rss_mib"] = max(best["rss_mib"], rss_kib / 1024.0)
    return best, (out_vtu if want_output else None)


# ------------------------------------------------------------------ main
def stress_label(r):
    if r["stress"] == "file":
        return "nodal (file)"
    if r["stress"] == "patch":
        m = re.match(r"RT_(\d+)", r.get("stress_used") or "")
        return f"RT_{m.group(1) if m else '?'} patch"
    return f"RT_{r['degree']} reconstruct"


def fmt_row(r):
    es = f"{r['err_sigma_A']:.3e}" if r.get("err_sigma_A") is not None else "—"
    ip = f"{r['index_pair']:.2f}" if r.get("index_pair") is not None else "—"
    b = r.get("bound") or {}
    has_b = b.get("energy_error") is not None
    bd = f"{b['energy_error']:.3e}" if has_b else "—"
    bi = f"{r['index_bound']:.2f}" if r.get("index_bound") is not None else "—"
    bg = ("yes" if b.get("guaranteed") else "no") if has_b else "—"
    return (f"| {r['case']} ({r['cells']}) | P{r['P']} | {stress_label(r)} | {'on' if r['friction_model'] else 'off'} "
            f"| {r['displacement']} | {r['wall_s']:.2f} | {r['recon_s']:.2f} | {r['rss_mib']:.1f} | {r['eta']:.3e} "
            f"| {r['err_u_E']:.3e} | {r['index_u']:.2f} | {es} | {ip} | {bd} | {bi} | {bg} |")


HEAD = ("| file (cells) | P | stress | friction model | displacement | wall s | reconstruction s | peak RSS MiB | η "
        "| ‖e_u‖_E | η / ‖e_u‖_E | ‖e_σ‖_A | η / ‖(e_u, e_σ)‖ | bound | bound / ‖e_u‖_E | guaranteed |\n|"
        + "---|" * 16)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fixture-size meshes only and a coarser reference")
    ap.add_argument("--no-write", action="store_true", help="print only (no results.json, no BENCHMARKS.md)")
    ap.add_argument("--repeat", type=int, default=2, help="runs per setting; the fastest is reported")
    ap.add_argument("--keep", default=None, help="write the generated files to this folder instead of a temporary one")
    a = ap.parse_args()
    fosls = os.environ.get("FOSLS", str(REPO / "target" / "release" / "fosls"))
    if not Path(fosls).exists():
        sys.exit(f"fosls binary not found: {fosls} (set FOSLS)")
    conf = QUICK if a.quick else FULL
    t_all = time.time()
    load0 = os.getloadavg()
    refs = {}
    for fr in (0.0, FRICTION):
        refs[fr] = Reference(conf["ref"], fr)
        r = refs[fr]
        print(f"reference F={fr}: P2 on {conf['ref']} : {r.cells} cells, {r.dofs} dofs, "
              f"{r.sol['info']['iterations']} active-set steps, energy^1/2 {r.energy:.4e}, {r.seconds:.0f} s", flush=True)
    rows = []
    tmpctx = tempfile.TemporaryDirectory(prefix="fosls-speed-")
    outdir = Path(a.keep) if a.keep else Path(tmpctx.name)
    print(HEAD, flush=True)
    with tmpctx:
        for P in (1, 2):
            for mk in conf["coarse"][P]:
                tm = G.half_disc(**MESHES[mk])
                for fr in (0.0, FRICTION):
                    ref = refs[fr]
                    name = f"hertz_skfem_p{P}{'_coulomb' if fr else ''}_{mk}"
                    t0 = time.time()
                    sol = PR.solve_skfem(tm, P, NU, friction=fr, curved_tags=(1, 3))
                    solve_s = time.time() - t0
                    d = write_case(outdir, name, sol, fr)
                    dsc = sol["dsc"]
                    ev = CoarseEval(dsc, ref.X)
                    err_file = ref.norm_E(ev.grad(sol["raw"]["u"][:dsc.nu_dofs]))
                    # the file's u (nodal values as written) must give the same error
                    err_file_nodes = ref.norm_E(ev.grad(dofvec_from_nodes(dsc, sol["U"])))
                    err_sig = ref.norm_A(ev.stress(sol["S4"]))
                    for stress, deg, fon, disp in (SETTINGS_COULOMB if fr else SETTINGS_FRICTIONLESS):
                        scene = "scene.toml" if (fon or not fr) else "scene_nofriction.toml"
                        res, outv = run_fosls(fosls, d, scene, stress, deg, disp, a.repeat, disp == "reconstruct")
                        rep = res["report"]
                        eu = err_file if disp == "file" else ref.norm_E(ev.grad(read_reconstructed_u(outv, dsc)))
                        es = err_sig if (stress == "file" and rep["stress"]["source"] == "file") else None
                        eta = rep["eta"]
                        bnd = rep.get("bound") or {}
                        bound = {k: bnd.get(k) for k in ("energy_error", "guaranteed", "relative", "terms",
                                                         "failed_hypotheses", "statement")}
                        be = bound["energy_error"]
                        recon = sum(s["seconds"] for s in rep.get("stages", []) if "reconstruct" in s["name"])
                        row = dict(case=name, mesh=mk, mesh_params=MESHES[mk], cells=len(tm.t), P=P, friction=fr,
                                   dofs=sol["info"]["dofs"], solve_s=solve_s, stress=stress, degree=deg,
                                   friction_model=bool(fon and fr), displacement=disp,
                                   stress_used=rep["stress"]["space"], displacement_used=rep["displacement"]["space"],
                                   wall_s=res["wall"], recon_s=recon, rss_mib=res["rss_mib"],
                                   stages={s["name"]: s["seconds"] for s in rep.get("stages", [])},
                                   eta=eta, functional=rep["functional"], relative=rep["relative"],
                                   energy=rep["energy"], err_u_E=eu, err_u_E_file_nodal=err_file_nodes,
                                   err_sigma_A=es, index_u=eta / eu,
                                   index_pair=(eta / np.hypot(eu, es)) if es is not None else None,
                                   bound=bound, index_bound=(be / eu) if be is not None else None,
                                   outside_points=ev.outside, notes=rep.get("notes", []))
                        rows.append(row)
                        print(fmt_row(row), flush=True)
    total = time.time() - t_all
    load1 = os.getloadavg()
    print(f"total {total:.0f} s; load average (1/5/15 min) at start {load0[0]:.2f}/{load0[1]:.2f}/{load0[2]:.2f}, "
          f"at end {load1[0]:.2f}/{load1[1]:.2f}/{load1[2]:.2f}")
    if a.no_write:
        return
    meta = dict(command="reference/.venv/bin/python reference/speed_accuracy/run.py" + (" --quick" if a.quick else ""),
                fosls=fosls, total_s=total,
                machine=dict(cpus=os.cpu_count(), platform=platform.platform()),
                date=time.strftime("%Y-%m-%d"), repeat=a.repeat, loadavg_start=load0, loadavg_end=load1,
                reference={str(fr): dict(mesh=conf["ref"], cells=r.cells, dofs=r.dofs, iterations=r.sol["info"]["iterations"],
                                         energy_sqrt=r.energy, seconds=r.seconds) for fr, r in refs.items()})
    (HERE / "results.json").write_text(json.dumps(dict(meta=meta, rows=rows), indent=1, default=float) + "\n")
    rf = refs[0.0]
    block = "\n".join([
        f"Run {meta['date']}, {meta['command']}, {total / 60:.1f} min in total, best of {a.repeat} runs per setting, "
        f"load average (1 min) {load0[0]:.1f} at start and {load1[0]:.1f} at end on {os.cpu_count()} cores; "
        f"reference: scikit-fem P2 on hc = {conf['ref']['hc']}, maxh = {conf['ref']['hmax']}, grading = "
        f"{conf['ref']['grading']} ({rf.cells} cells, {rf.dofs} dofs), (½(Cε(u_ref), ε(u_ref)))^½ = {rf.energy:.4e} "
        f"(frictionless), {refs[FRICTION].energy:.4e} (Coulomb).", "", HEAD] + [fmt_row(r) for r in rows])
    bm = REPO / "BENCHMARKS.md"
    text = bm.read_text()
    if "<!-- speed-accuracy:begin -->" not in text:
        text = text.rstrip("\n") + "\n\n" + SECTION
    text = re.sub(r"(<!-- speed-accuracy:begin -->\n).*?(<!-- speed-accuracy:end -->)",
                  lambda m: m.group(1) + block + "\n" + m.group(2), text, flags=re.S)
    bm.write_text(text)


SECTION = """## Speed against accuracy (reference/speed_accuracy/run.py)

`FOSLS=target/release/fosls reference/.venv/bin/python reference/speed_accuracy/run.py` (about 5 min; `--quick`:
fixture mesh only) solves the Hertz problem of `reference/hertz` with scikit-fem (P1, curved P2; frictionless and
Coulomb F = 0.4) on graded meshes M0 (the fixtures' mesh, hc = 0.004) … M2 (hc = 0.001), writes them like the
`hertz_skfem_*` fixtures (temporary folder), solves a scikit-fem P2 reference on a much finer mesh, and runs
`fosls estimate` in each setting. Machine: 2 cores shared with other busy processes, so times and RSS are noisy
(best of 2 runs; wall = whole process from `/usr/bin/time`, reconstruction = the `reconstruct *` stages).
‖e_u‖_E = (½(Cε(u_ref − u), ε(u_ref − u)))^½ over the fine mesh's quadrature points (u = the file's u_h, or
fosls's reconstructed displacement when displacement = reconstruct), ‖e_σ‖_A = (½(A(σ_ref − σ_h), σ_ref − σ_h))^½
for the file's nodal stress only (σ_ref = Cε(u_ref)); η = F^½ from fosls (energy preset) bounds the pair, so
η / ‖e_u‖_E uses the displacement error alone and η / ‖(e_u, e_σ)‖ both. Stress = RT_k reconstruct is the
global FOSLS minimiser (`--stress reconstruct --degree k`); RT_k patch is the equilibrated reconstruction on
vertex patches (`--stress patch`, RT_1 for P1 and RT_2 for P2, chosen by fosls). bound = `bound.energy_error` of
the JSON report, an upper bound of ‖e_u‖_E for the file's u_h (Prager–Synge, complementarity, oscillation,
asymmetry and projection terms), and bound / ‖e_u‖_E its efficiency index against the same reference error; guaranteed = the
report's `bound.guaranteed` (no when a hypothesis fails, listed in `bound.failed_hypotheses` in results.json).
fosls gives a bound only for an equilibrated stress, so the nodal and global-minimiser rows have "—" in the three bound columns. On a
Coulomb file with the friction model on, fosls's bound is that of the Tresca problem with the threshold
𝔉|σ_h,n| (never guaranteed) while ‖e_u‖_E is still measured against the Coulomb reference. Friction model off =
the Coulomb file evaluated with the friction removed from the scene. Quadrature order is not an option of the
tool (one fixed rule), so it has no rows.

<!-- speed-accuracy:begin -->
<!-- speed-accuracy:end -->
"""

if __name__ == "__main__":
    main()
