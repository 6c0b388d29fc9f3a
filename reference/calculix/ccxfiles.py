"""Readers for the CalculiX and sfepy fixture files (reference/.venv: numpy, scipy, meshio, vtk) and
every number of expected.json that depends only on them.

- CalculiX .dat (`*NODE PRINT` totals and per-node forces, `*CONTACT PRINT` contact stresses and relative
  contact displacements), the .inp node table, and the expanded-node rule: CalculiX turns every plane
  strain node k (k-th in ascending node number, N = the largest node number) into three 3D nodes
  N + 3k + 1, N + 3k + 2, N + 3k + 3 at z = -1/2, 0, +1/2 (thickness 1); the contact output of a deck
  whose slave surface consists of element faces refers to those 3D nodes.  make.py verifies the rule
  against a companion run with `*NODE FILE, OUTPUT=3D` whenever it runs CalculiX.
- VTU (ccx2paraview) and legacy VTK (sfepy) with VTK, meshio as second reader; connected components
  (bodies) of the cells; the file-based numbers through reference/hertz/evaluate.py (nodal stress) or,
  for sfepy's cell-average stress, from the owning cell of every boundary edge.
"""
import math
import re
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "hertz"))
sys.path.insert(0, str(HERE.parent / "othercodes"))
import evaluate  # noqa: E402
import filecheck  # noqa: E402  (reference/othercodes: read_piece, piece_facts, meshio_agrees, evaluate_fields)

VTK_NAMES = dict(filecheck.VTK_NAMES)


# ------------------------------------------------------------------ CalculiX text files
def inp_nodes(path):
    """{node number: (x, y)} from every *NODE block of a CalculiX deck."""
    out = {}
    sec = False
    for line in Path(path).read_text().splitlines():
        if line.startswith("**"):
            continue
        if line.startswith("*"):
            key = line.split(",")[0].strip().upper()
            sec = key == "*NODE"
            continue
        if sec and line.strip():
            p = [s.strip() for s in line.split(",")]
            out[int(p[0])] = (float(p[1]), float(p[2]))
    return out


def dat_blocks(path):
    """The .dat file as a list of (title, time, rows): every block CalculiX printed, rows as float
    arrays (first column the node number where there is one)."""
    lines = Path(path).read_text().splitlines()
    blocks, i = [], 0
    while i < len(lines):
        ln = lines[i].strip()
        m = re.match(r"(.*?)\s+(?:for set (\S+)|for all contact elements) and time\s+(\S+)$", ln)
        if m:
            title, nset, t = m.group(1), m.group(2), float(m.group(3))
            i += 2
            rows = []
            while i < len(lines) and lines[i].strip():
                rows.append([float(v) for v in lines[i].split()])
                i += 1
            blocks.append(dict(title=title, set=nset, time=t, rows=np.array(rows)))
        else:
            i += 1
    return blocks


def dat_get(blocks, title, nset=None):
    hits = [b for b in blocks if b["title"] == title and b["set"] == nset]
    if len(hits) != 1:
        raise ValueError(f"{title} / {nset}: {len(hits)} blocks in the .dat")
    return hits[0]


def expanded_xy(nodes2d, ids):
    """(x, y) and z slot of 3D nodes made by CalculiX's expansion of plane elements (module doc)."""
    keys = np.array(sorted(nodes2d))
    nk = int(keys.max())
    k = (np.asarray(ids, dtype=np.int64) - nk - 1)
    if (k < 0).any() or (k // 3 >= len(keys)).any():
        raise ValueError("node numbers outside the expanded range")
    xy = np.array([nodes2d[int(keys[j])] for j in k // 3])
    return xy, k % 3


def solver_numbers(case_kind, folder, spacing=None):
    """The solver's numbers from the committed hertz.dat (+ hertz.inp): top reaction, contact force,
    active zone from the solver's contact pressure, penetration."""
    folder = Path(folder)
    B = dat_blocks(folder / "hertz.dat")
    times = sorted({b["time"] for b in B})
    top = dat_get(B, "total force (fx,fy,fz)", "NTOP")["rows"][0]
    out = dict(dat_times=times, reaction_top=dict(Fx=float(top[0]), Fy=float(top[1]), P=float(-top[1])))
    cs = dat_get(B, "contact stress (slave node,press,tang1,tang2)")["rows"]
    cd = dat_get(B, "relative contact displacement (slave node,normal,tang1,tang2)")["rows"]
    nodes2d = inp_nodes(folder / "hertz.inp")
    out["contact_print_nodes"] = int(len(cs))
    out["penetration_max_solver"] = float(max(0.0, -cd[:, 1].min()))
    out["clearance_max_printed"] = float(cd[:, 1].max())
    out["cpress_max"] = float(cs[:, 1].max())
    out["cshear_abs_max"] = float(np.abs(cs[:, 2]).max())
    if case_kind == "plane":
        # the slave nodes are the fixed plane nodes: their reactions are the nodal contact forces
        rf = dat_get(B, "forces (fx,fy,fz)", "NPLANE")["rows"]
        tot = dat_get(B, "total force (fx,fy,fz)", "NPLANE")["rows"][0]
        x = np.array([nodes2d[int(n)][0] for n in rf[:, 0]])
        fy, fx = rf[:, 2], rf[:, 1]
        act = fy > 0
        xa = x[act]
        out.update(contact_force=dict(Fx=float(tot[0]), Fy=float(tot[1])),
                   contact_force_nodes_sum=float(fy.sum()),
                   active_nodes=int(act.sum()), plane_nodes=int(len(rf)),
                   active_x_range=[float(xa.min()), float(xa.max())],
                   active_half_width=float(0.5 * (xa.max() - xa.min())),
                   a_moment_nodal_forces=float(2.0 * math.sqrt((fy[act] * xa ** 2).sum() / fy[act].sum())),
                   pressure_max_nodal=float((fy / spacing).max()),
                   pressure_max_at_x=float(x[int(np.argmax(fy))]),
                   tangential_over_normal_max=float(np.abs(fx[act] / fy[act]).max()),
                   slave_nodes_with_cpress=int((cs[:, 1] > 0).sum()))
        # stick / slip from the printed shear: |tau| = mu p on slipping nodes (only with friction)
        ratio = np.abs(cs[:, 2]) / np.maximum(cs[:, 1], 1e-300)
        xs = np.array([nodes2d[int(n)][0] for n in cs[:, 0]])
        out["shear_over_pressure"] = dict(max=float(ratio[cs[:, 1] > 0].max()) if (cs[:, 1] > 0).any() else 0.0)
        out["_cs_x"] = (xs, cs[:, 1], cs[:, 2])
    else:
        tot = dat_get(B, "total force (fx,fy,fz)", "NBOTTOM")["rows"][0]
        xy, z = expanded_xy(nodes2d, cs[:, 0].astype(np.int64))
        act = cs[:, 1] > 0
        xa = xy[act, 0]
        out.update(contact_force=dict(Fx=float(tot[0]), Fy=float(tot[1])),
                   active_nodes=int(act.sum()), active_nodes_2d=int(len(np.unique(xy[act], axis=0))),
                   active_x_range=[float(xa.min()), float(xa.max())],
                   active_half_width=float(0.5 * (xa.max() - xa.min())),
                   slave_z_slots=[int(v) for v in np.unique(z)])
    return out


def stick_slip(xs, p, tau, mu, rel=1e-3):
    """Runs of the slave (plane) nodes sorted by x: open (p <= 0), slip (|tau| >= (1 - rel) mu p), stick."""
    o = np.argsort(xs)
    xs, p, tau = xs[o], p[o], tau[o]
    cls = np.where(p <= 0, 0, np.where(np.abs(tau) >= (1 - rel) * mu * p, 2, 1))
    runs, s = [], 0
    for i in range(1, len(cls) + 1):
        if i == len(cls) or cls[i] != cls[s]:
            runs.append(dict(state={0: "open", 1: "stick", 2: "slip"}[int(cls[s])], x=[float(xs[s]), float(xs[i - 1])],
                             nodes=int(i - s)))
            s = i
    stick = [r for r in runs if r["state"] == "stick"]
    w = max(stick, key=lambda r: r["x"][1] - r["x"][0]) if stick else None
    return dict(relative_tolerance=rel, intervals=runs,
                stick_x_range=w["x"] if w else None, stick_half_width=0.5 * (w["x"][1] - w["x"][0]) if w else 0.0)


# ------------------------------------------------------------------ files
def read_legacy(path):
    """A legacy .vtk unstructured grid with VTK (every scalar / vector / field array)."""
    import vtk
    from vtk.util.numpy_support import vtk_to_numpy as v2n
    r = vtk.vtkUnstructuredGridReader()
    r.SetFileName(str(path))
    r.ReadAllScalarsOn()
    r.ReadAllVectorsOn()
    r.ReadAllTensorsOn()
    r.ReadAllFieldsOn()
    r.Update()
    g = r.GetOutput()
    if g is None or g.GetNumberOfPoints() == 0:
        raise ValueError(f"{path}: VTK read nothing")
    P = v2n(g.GetPoints().GetData()).astype(float)
    ca = g.GetCells()
    off = v2n(ca.GetOffsetsArray()).astype(np.int64)
    conn = v2n(ca.GetConnectivityArray()).astype(np.int64)
    types = np.array([g.GetCellType(i) for i in range(g.GetNumberOfCells())], dtype=np.int64)
    cells = [conn[off[i]:off[i + 1]] for i in range(len(off) - 1)]
    pd = {g.GetPointData().GetArrayName(i): v2n(g.GetPointData().GetArray(i)) for i in range(g.GetPointData().GetNumberOfArrays())}
    cd = {g.GetCellData().GetArrayName(i): v2n(g.GetCellData().GetArray(i)) for i in range(g.GetCellData().GetNumberOfArrays())}
    pd = {k: (v.reshape(len(v), -1) if v.ndim == 1 else v) for k, v in pd.items()}
    cd = {k: (v.reshape(len(v), -1) if v.ndim == 1 else v) for k, v in cd.items()}
    return dict(points=P, cells=cells, types=types, point_data=pd, cell_data=cd)


def legacy_header(path, arrays):
    """The ASCII lines of a legacy VTK file: the first four lines and the section / FIELD array
    descriptors (the binary payload between them is skipped by matching the known keywords)."""
    raw = Path(path).read_bytes()
    first = raw.split(b"\n", 4)[:4]
    sec = []
    for m in re.finditer(rb"(?<=\n)((?:POINTS|CELLS|OFFSETS|CONNECTIVITY|CELL_TYPES|POINT_DATA|CELL_DATA|FIELD|METADATA)"
                         rb"(?: [\w. ]+)?)(?=\n)", raw):
        sec.append(m.group(1).decode())
    fields = {}
    for name in arrays:
        m = re.search(rb"\n" + re.escape(name.encode()) + rb" (\d+) (\d+) (\w+)\n", raw)
        if m:
            fields[name] = dict(components=int(m.group(1)), tuples=int(m.group(2)), type=m.group(3).decode())
    return dict(lines=[x.decode(errors="replace") for x in first], sections=sec, field_arrays=fields)


def meshio_agrees_any(path, piece):
    """meshio (5.3.5) reads the same file: same points, connectivity and every point / cell array."""
    import contextlib
    import io
    import meshio
    err = io.StringIO()
    try:
        with contextlib.redirect_stdout(err), contextlib.redirect_stderr(err):
            m = meshio.read(str(path))
    except (Exception, SystemExit) as exc:
        return dict(meshio_version=meshio.__version__, readable=False, error=f"{type(exc).__name__}: {exc}")
    conn = np.concatenate([c.data.ravel() for c in m.cells])
    ok = np.array_equal(np.asarray(m.points, float), piece["points"]) and np.array_equal(conn, np.concatenate(piece["cells"]))
    for k, v in piece["point_data"].items():
        mv = np.asarray(m.point_data[k])
        ok &= np.array_equal(mv.reshape(len(mv), -1).astype(float), v.astype(float))
    for k, v in piece["cell_data"].items():
        mv = np.concatenate([np.asarray(b) for b in m.cell_data[k]])
        ok &= np.array_equal(mv.reshape(len(mv), -1).astype(float), v.astype(float))
    return dict(meshio_version=meshio.__version__, readable=True,
                meshio_cell_blocks=[[c.type, int(len(c.data))] for c in m.cells], identical_to_vtk=bool(ok))


def points_dtype(path, legacy=False):
    """The type the file declares for its point coordinates (ccx2paraview: Float32, vtkPoints' default)."""
    if legacy:
        m = re.search(rb"\nPOINTS \d+ (\w+)\n", Path(path).read_bytes())
    else:
        m = re.search(r"<Points>\s*<DataArray\b[^>]*\btype=\"(\w+)\"", Path(path).read_text(errors="replace"))
    return m.group(1).decode() if isinstance(m.group(1), bytes) else m.group(1)


def component_names(path, legacy=False):
    """ComponentName attributes of every array as written (XML files; legacy files have none)."""
    if legacy:
        return {}
    txt = Path(path).read_text(errors="replace")
    out = {}
    for tag in re.findall(r"<DataArray\b[^>]*>", txt):
        d = dict(re.findall(r'(\w+)="([^"]*)"', tag))
        if "Name" in d:
            names = [d[k] for k in sorted((k for k in d if k.startswith("ComponentName")), key=lambda s: int(s[13:]))]
            out[d["Name"]] = names
    return out


def bodies(points, cells):
    """Connected components of the cells (cells sharing a point), largest first: cell indices."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    C = np.array([np.asarray(c) for c in cells])
    nc, npc = C.shape
    rows = np.repeat(np.arange(nc), npc)
    A = coo_matrix((np.ones(rows.size), (rows, C.ravel())), shape=(nc, len(points))).tocsr()
    n, lab = connected_components(A @ A.T, directed=False)
    comps = [np.nonzero(lab == k)[0] for k in range(n)]
    comps.sort(key=lambda c: (-len(c), int(c[0])))
    return comps


def body_facts(points, cells, types, comps):
    C = np.array([np.asarray(c) for c in cells])
    out = []
    for k, cc in enumerate(comps):
        pts = np.unique(C[cc].ravel())
        X = points[pts]
        ct, cn = np.unique(types[cc], return_counts=True)
        out.append(dict(index=k, cells=int(len(cc)), points=int(len(pts)),
                        cell_types={f"{int(t)} {VTK_NAMES.get(int(t), '?')}": int(n) for t, n in zip(ct, cn)},
                        bbox=[[float(X[:, 0].min()), float(X[:, 1].min())], [float(X[:, 0].max()), float(X[:, 1].max())]],
                        first_cell=int(cc[0])))
    return out


def min_distance_between(points, cells, comps):
    from scipy.spatial import cKDTree
    C = np.array([np.asarray(c) for c in cells])
    if len(comps) < 2:
        return None
    a = np.unique(C[comps[0]].ravel())
    b = np.unique(C[comps[1]].ravel())
    d, _ = cKDTree(points[a, :2]).query(points[b, :2])
    return float(d.min())


def submesh(points, cells, keep):
    """(X (n, 2), cells (m, k) renumbered, old point ids) of the cells `keep`."""
    C = np.array([np.asarray(c) for c in cells])[keep]
    used = np.unique(C)
    remap = -np.ones(len(points), np.int64)
    remap[used] = np.arange(len(used))
    return points[used][:, :2], remap[C], used


def scene_for_python(scene):
    """The scene with `where` expressions turned into Python (&& -> &, || -> |) for evaluate.safe_eval."""
    import copy
    sc = copy.deepcopy(scene)
    for bd in sc["boundary"]:
        if "where" in bd:
            bd["where"] = bd["where"].replace("&&", "&").replace("||", "|")
    return sc


# ------------------------------------------------------------------ cell-average stress (sfepy)
def cell_stress_numbers(fx, S_cell, scene):
    """Boundary numbers from a piecewise constant stress (cell data): every boundary edge takes the
    stress of the one cell that owns it.  fx: an evaluate.Fixture on straight P1 triangles."""
    C = fx.cells
    owner = {}
    for k, row in enumerate(C):
        for a, b in ((0, 1), (1, 2), (2, 0)):
            owner.setdefault(tuple(sorted((int(row[a]), int(row[b])))), []).append(k)
    out = {}
    for bd, idx in fx.parts:
        F = np.zeros(2)
        sn_int = st_int = 0.0
        pmax = tmax = 0.0
        M0 = M2 = 0.0
        for e in idx:
            a, b = (int(v) for v in fx.edges[e][:2])
            k = owner[tuple(sorted((a, b)))]
            assert len(k) == 1
            s = S_cell[k[0]]
            d = fx.X[b] - fx.X[a]
            nom = np.array([d[1], -d[0]])           # outward normal times length (body on the left of a -> b)
            t = np.array([s[0] * nom[0] + s[2] * nom[1], s[2] * nom[0] + s[1] * nom[1]])
            F += t
            if bd["kind"] == "contact":
                m = np.array(bd["obstacle"]["plane"]["normal"], float)
                n = -m / np.linalg.norm(m)
                tt = np.array([-n[1], n[0]])
                L = float(np.linalg.norm(d))
                sn, st = float(n @ t), float(tt @ t)
                sn_int += -sn
                st_int += st
                pmax = max(pmax, -sn / L)
                tmax = max(tmax, sn / L)
                ivs, _ = fx.gap_poly_roots(fx.edges[e], bd, 1e-10)
                for s0, s1 in ivs:
                    xa = fx.X[a] + s0 * d
                    xb = fx.X[a] + s1 * d
                    w = -sn * (s1 - s0)
                    M0 += w
                    # exact integral of x^2 over the sub-segment with constant pressure
                    M2 += w * (xa[0] ** 2 + xa[0] * xb[0] + xb[0] ** 2) / 3.0
        ent = dict(force=[float(F[0]), float(F[1])])
        if bd["kind"] == "contact":
            ent.update(normal_force=sn_int, tangential_force=st_int, pressure_max_cells=pmax, tension_max_cells=tmax,
                       normal_force_active=M0, a_moment=2.0 * math.sqrt(M2 / M0) if M0 > 0 and M2 > 0 else None)
        out[bd["name"]] = ent
    return out
