"""Read the DOLFINx / MFEM output files as written (VTK XML pieces, PVTU/PVD collections, XDMF + HDF5,
ADIOS2 BP4 folders) in reference/.venv (Python 3.11: numpy, scipy, vtk, meshio) and compute every
number of expected.json that depends only on the files.

Readers: VTK's vtkXMLUnstructuredGridReader per piece (the PVD and PVTU are parsed as XML and their
pieces read one by one, so each piece's own layout is reported), meshio as a second reader of each
piece (points, cells and arrays must agree with VTK), h5lite.py (this folder) for the HDF5 file of
the XDMF case (no h5py in reference/.venv).  Pieces are merged: cells with vtkGhostType & 1
(duplicate cell) are dropped, coincident points (1e-12 of the diameter) are merged after checking
that their copies carry the same values; what is left is handed to reference/hertz/evaluate.py
(the definitions of every boundary / contact / energy number are in reference/hertz/README.md).
"""
import json
import math
import re
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "hertz"))
sys.path.insert(0, str(HERE))
import evaluate  # noqa: E402
import vtuio  # noqa: E402
import h5lite  # noqa: E402

VTK_NAMES = {3: "VTK_LINE", 5: "VTK_TRIANGLE", 21: "VTK_QUADRATIC_EDGE", 22: "VTK_QUADRATIC_TRIANGLE",
             68: "VTK_LAGRANGE_CURVE", 69: "VTK_LAGRANGE_TRIANGLE"}


# ------------------------------------------------------------------ stress layouts
def detect_stress(arr):
    """-> (S (N, 3) columns xx, yy, xy; facts).  Detection from the values (no component names in
    these files): 9 components with components 4..8 identically zero and c1 == c2 is DOLFINx's
    zero-padded 2x2 tensor (xx, xy, yx, yy, 0, 0, 0, 0, 0); 9 with c2 = c5 = c6 = c7 = 0 would be a
    row-major 3x3 (xx, xy, xz, yx, yy, yz, zx, zy, zz); 3 components are MFEM's Voigt xx, yy, xy."""
    a = np.asarray(arr, dtype=float)
    nc = a.shape[1]
    cmax = np.abs(a).max(axis=0)
    facts = dict(components=int(nc), component_max_abs=[float(v) for v in cmax])
    if nc == 9:
        if cmax[4:].max() == 0.0 and cmax[3] > 0:
            facts.update(layout="xx,xy,yx,yy,0,0,0,0,0", description=(
                "DOLFINx 2x2 tensor Function: row-major 2x2 (xx, xy, yx, yy) in components 0-3, "
                "components 4-8 zero padding (NOT a row-major 3x3: component 4 is not yy)"),
                padding_components=[4, 5, 6, 7, 8], padding_max_abs=float(cmax[4:].max()),
                xy_minus_yx_max_abs=float(np.abs(a[:, 1] - a[:, 2]).max()))
            return np.stack([a[:, 0], a[:, 3], 0.5 * (a[:, 1] + a[:, 2])], axis=1), facts
        if max(cmax[2], cmax[5], cmax[6], cmax[7]) == 0.0:
            facts.update(layout="row-major 3x3", xy_minus_yx_max_abs=float(np.abs(a[:, 1] - a[:, 3]).max()))
            return np.stack([a[:, 0], a[:, 4], 0.5 * (a[:, 1] + a[:, 3])], axis=1), facts
        raise ValueError("unrecognised 9-component stress")
    if nc == 3:
        facts.update(layout="xx,yy,xy", description="MFEM vector GridFunction vdim 3, Voigt order xx, yy, xy")
        return a.copy(), facts
    raise ValueError(f"stress with {nc} components")


# ------------------------------------------------------------------ VTK XML
def xml_header_facts(path):
    """Attributes of the VTKFile element and every DataArray tag, parsed from the file text (the
    inline data of ascii / base64 files does not matter)."""
    txt = Path(path).read_text(errors="replace")
    head = re.search(r"<VTKFile[^>]*>", txt).group(0)
    attrs = dict(re.findall(r'(\w+)="([^"]*)"', head))
    arrays = []
    for tag in re.findall(r"<(?:P?DataArray)\b[^>]*>", txt):
        d = dict(re.findall(r'(\w+)\s*=\s*"([^"]*)"', tag))
        arrays.append({k: d[k] for k in ("Name", "type", "NumberOfComponents", "format") if k in d})
    piece = re.search(r"<Piece[^>]*>", txt)
    pattrs = dict(re.findall(r'(\w+)="([^"]*)"', piece.group(0))) if piece else {}
    ghost = re.search(r'GhostLevel="(\d+)"', txt)
    return dict(vtkfile=attrs, arrays=arrays, piece=pattrs, ghost_level=int(ghost.group(1)) if ghost else None)


def read_piece(path):
    """One .vtu with VTK: points, cells (list of id arrays), types, point/cell arrays (numpy)."""
    import vtk
    from vtk.util.numpy_support import vtk_to_numpy as v2n
    r = vtk.vtkXMLUnstructuredGridReader()
    r.SetFileName(str(path))
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
    pd = {g.GetPointData().GetArrayName(i): v2n(g.GetPointData().GetArray(i))
          for i in range(g.GetPointData().GetNumberOfArrays())}
    cd = {g.GetCellData().GetArrayName(i): v2n(g.GetCellData().GetArray(i))
          for i in range(g.GetCellData().GetNumberOfArrays())}
    pd = {k: (v.reshape(len(v), -1) if v.ndim == 1 else v) for k, v in pd.items()}
    return dict(points=P, cells=cells, types=types, point_data=pd, cell_data=cd)


def meshio_agrees(path, piece):
    """meshio reads the same piece: same points, cell connectivity and point arrays (exact)."""
    import contextlib
    import io
    import meshio
    err = io.StringIO()
    try:
        with contextlib.redirect_stdout(err), contextlib.redirect_stderr(err):
            m = meshio.vtu.read(str(path))
    except (Exception, SystemExit) as exc:  # meshio 5.3.5 refuses VTKFile version="2.2" (DOLFINx, MFEM)
        msg = " ".join(err.getvalue().split()).replace(str(Path(path).parent) + "/", "")
        return dict(meshio_version=meshio.__version__, readable=False,
                    error=f"{type(exc).__name__}: {msg or exc}")
    conn = np.concatenate([c.data.ravel() for c in m.cells])
    ok = (np.array_equal(m.points, piece["points"]) and np.array_equal(conn, np.concatenate(piece["cells"])))
    for k, v in piece["point_data"].items():
        mv = np.asarray(m.point_data[k])
        ok &= np.array_equal(mv.reshape(len(mv), -1).astype(float), v.astype(float))
    return dict(meshio_version=meshio.__version__, readable=True,
                meshio_cell_blocks=[[c.type, int(len(c.data))] for c in m.cells], identical_to_vtk=bool(ok))


def piece_facts(path, piece, root):
    h = xml_header_facts(path)
    ct, cn = np.unique(piece["types"], return_counts=True)
    npc = sorted({int(len(c)) for c in piece["cells"]})
    gc = piece["cell_data"].get("vtkGhostType")
    gp = piece["point_data"].get("vtkGhostType")
    return dict(
        file=str(Path(path).relative_to(root)), bytes=Path(path).stat().st_size,
        vtkfile_attributes=h["vtkfile"], data_formats=sorted({a.get("format", "") for a in h["arrays"] if "format" in a}),
        points=int(len(piece["points"])), cells=int(len(piece["cells"])),
        cell_types={f"{int(t)} {VTK_NAMES.get(int(t), '?')}": int(n) for t, n in zip(ct, cn)},
        nodes_per_cell=npc,
        cells_per_point_max=int(np.bincount(np.concatenate(piece["cells"]), minlength=len(piece["points"])).max()),
        unreferenced_points=int((np.bincount(np.concatenate(piece["cells"]), minlength=len(piece["points"])) == 0).sum()),
        point_arrays={k: dict(components=int(v.shape[1]), dtype=str(v.dtype)) for k, v in piece["point_data"].items()},
        cell_arrays={k: dict(components=int(v.reshape(len(v), -1).shape[1]), dtype=str(v.dtype))
                     for k, v in piece["cell_data"].items()},
        ghost_cells=None if gc is None else int((np.asarray(gc).ravel() & 1).astype(bool).sum()),
        ghost_points=None if gp is None else int((np.asarray(gp).ravel() != 0).sum()),
        points_z_max_abs=float(np.abs(piece["points"][:, 2]).max()),
    )


def pvd_datasets(pvd):
    root = ET.parse(pvd).getroot()
    return [dict(d.attrib) for d in root.iter("DataSet")]


def pvtu_facts(pvtu):
    root = ET.parse(pvtu).getroot()
    pug = root.find("PUnstructuredGrid")
    arr = lambda sec: [{k: a.attrib[k] for k in ("Name", "type", "NumberOfComponents") if k in a.attrib}
                       for a in (pug.find(sec) if pug.find(sec) is not None else [])]
    return dict(vtkfile_attributes=dict(root.attrib), ghost_level=int(pug.attrib.get("GhostLevel", 0)),
                pieces=[p.attrib["Source"] for p in pug.iter("Piece")],
                point_arrays=arr("PPointData"), cell_arrays=arr("PCellData"))


def merge_pieces(pieces):
    """Concatenate pieces, drop ghost cells, merge coincident points (values must agree), drop
    unreferenced points.  -> points (N, 2), cells (M, k) VTK node order, point data, facts."""
    P, C, T, PD, base = [], [], [], {}, 0
    ghosts = 0
    for pc in pieces:
        gc = pc["cell_data"].get("vtkGhostType")
        keep = np.ones(len(pc["cells"]), bool) if gc is None else (np.asarray(gc).ravel() & 1) == 0
        ghosts += int((~keep).sum())
        P.append(pc["points"])
        C += [c + base for c, k in zip(pc["cells"], keep) if k]
        T.append(pc["types"][keep])
        for k, v in pc["point_data"].items():
            PD.setdefault(k, []).append(np.asarray(v, dtype=float))
        base += len(pc["points"])
    P = np.vstack(P)
    PD = {k: np.vstack(v) for k, v in PD.items()}
    T = np.concatenate(T)
    nn = {len(c) for c in C}
    assert len(nn) == 1, f"mixed cell sizes {nn}"
    C = np.array(C, dtype=np.int64)
    first, inv = vtuio.merge_points(P[:, :2])
    jumps = {}
    skip = ("vtkOriginalPointIds", "vtkGhostType")
    for k, v in PD.items():
        if k in skip:
            continue
        d = float(np.abs(v - v[first][inv]).max())
        if d > 1e-10 * max(float(np.abs(v).max()), 1e-300):
            raise ValueError(f"coincident points carry different values of {k} (max {d})")
        jumps[k] = d
    C = inv[C]
    used = np.unique(C)
    remap = -np.ones(len(first), np.int64)
    remap[used] = np.arange(len(used))
    X = P[first][used][:, :2]
    C = remap[C]
    pdata = {k: v[first][used] for k, v in PD.items()}
    facts = dict(points_in_files=int(len(P)), points_merged=int(len(X)), cells_kept=int(len(C)),
                 ghost_cells_dropped=ghosts, merged_value_jump=max(jumps.values()) if jumps else 0.0)
    return X, C, T, pdata, facts


def mid_node_offset(X, cells):
    """max over P2 edges of |mid node - chord midpoint| / edge length (VTK / XDMF node order check:
    0 for straight edges, the sagitta ratio h/(8R) on the arc; a wrong node order gives ~0.5)."""
    if cells.shape[1] != 6:
        return None
    m = 0.0
    for a, b, c in ((0, 1, 3), (1, 2, 4), (2, 0, 5)):
        L = np.linalg.norm(X[cells[:, b]] - X[cells[:, a]], axis=1)
        d = np.linalg.norm(X[cells[:, c]] - 0.5 * (X[cells[:, a]] + X[cells[:, b]]), axis=1)
        m = max(m, float((d / L).max()))
    return m


# ------------------------------------------------------------------ evaluation
class ArrayFixture(evaluate.Fixture):
    """evaluate.Fixture built from arrays instead of a meshio-read file."""

    def __init__(self, X, cells, U, S3, scene, lines=None, line_data=None, points_in_file=None, merge_jump=0.0):
        self.scene = scene
        self.X = np.asarray(X, float)
        self.points_in_file = int(points_in_file if points_in_file is not None else len(X))
        self.merge_jump = float(merge_jump)
        self.cells = np.asarray(cells, np.int64)
        self.quad = self.cells.shape[1] == 6
        self.U = np.asarray(U, float)[:, :2]
        self.S = np.asarray(S3, float)
        self._boundary(dict(lines=lines, line_data=line_data or {}))


def arc_lengths(fx):
    """lengths of all boundary edges below y = 0.9999 (the whole arc) and of those below 0.5001."""
    xm = fx.edge_point(0.5)
    tot = cont = 0.0
    for k, e in enumerate(fx.edges):
        if xm[k, 1] < 0.9999:
            L = fx._length(e, 0.0, 1.0)
            tot += L
            if xm[k, 1] < 0.5001:
                cont += L
    return tot, cont


def evaluate_fields(X, cells, U, S3, scene, delta, lines=None, line_data=None, points_in_file=None, merge_jump=0.0):
    fx = ArrayFixture(X, cells, U, S3, scene, lines, line_data, points_in_file, merge_jump)
    mat = scene["material"]
    out = dict(mesh=fx.mesh_stats(), tolerances=dict(gap_delta=delta),
               energy=fx.energy(mat["youngs_modulus"], mat["poisson_ratio"]))
    out["mesh"]["mid_node_offset_max"] = mid_node_offset(fx.X, fx.cells)
    out.update(fx.report(delta=delta))
    whole, below = arc_lengths(fx)
    out["arc"] = dict(whole_arc_length=whole, whole_arc_minus_pi=whole - math.pi,
                      gamma_c_length=out["boundaries"][out["contact"]]["length"],
                      gamma_c_exact=2 * math.pi / 3, gamma_c_minus_exact=out["boundaries"][out["contact"]]["length"] - 2 * math.pi / 3)
    return out, fx


def vtk_collection(folder, pvd_rel):
    """Read a PVD -> PVTU -> pieces set (DOLFINx VTKFile, MFEM ParaViewDataCollection)."""
    folder = Path(folder)
    pvd = folder / pvd_rel
    ds = pvd_datasets(pvd)
    assert len(ds) == 1, ds
    pvtu = pvd.parent / ds[0]["file"]
    pf = pvtu_facts(pvtu)
    pieces, facts = [], []
    for src in pf["pieces"]:
        p = pvtu.parent / src
        pc = read_piece(p)
        f = piece_facts(p, pc, folder)
        f["meshio"] = meshio_agrees(p, pc)
        pieces.append(pc)
        facts.append(f)
    return dict(pvd=dict(file=str(pvd.relative_to(folder)), datasets=ds),
                pvtu=dict(file=str(pvtu.relative_to(folder)), **pf), pieces=facts), pieces


def file_list(folder, volatile=("profiling.json",)):
    out = []
    for p in sorted(Path(folder).rglob("*")):
        if p.is_file() and p.name not in ("scene.toml", "expected.json", "README.md"):
            out.append(dict(file=str(p.relative_to(folder)),
                            bytes=None if p.name in volatile else p.stat().st_size))
    return out


def check_vtk_case(folder, scene, pvd_rel, delta):
    layout, pieces = vtk_collection(folder, pvd_rel)
    X, C, T, pdata, mf = merge_pieces(pieces)
    f = scene["fields"]
    S3, sfacts = detect_stress(pdata[f["stress"]])
    U = pdata[f["displacement"]]
    layout["merge"] = mf
    layout["displacement"] = dict(name=f["displacement"], components=int(U.shape[1]),
                                  padding_max_abs=float(np.abs(U[:, 2:]).max()) if U.shape[1] > 2 else None)
    layout["stress"] = dict(name=f["stress"], **sfacts)
    cells = C if C.shape[1] in (3, 6) else None
    ev, fx = evaluate_fields(X, cells, U, S3, scene, delta, points_in_file=mf["points_in_files"],
                             merge_jump=mf["merged_value_jump"])
    return dict(files=file_list(folder), layout=layout, **ev), (X, U, S3)


def check_xdmf_case(folder, scene, delta, xdmf_rel="solution.xdmf"):
    folder = Path(folder)
    xf = folder / xdmf_rel
    root = ET.parse(xf).getroot()
    dom = root.find("Domain")
    grids = []
    paths = {}
    for g in dom.findall("Grid"):
        gi = dict(Name=g.attrib.get("Name"), GridType=g.attrib.get("GridType"))
        if g.attrib.get("GridType") == "Collection":
            gi["CollectionType"] = g.attrib.get("CollectionType")
            subs = g.findall("Grid")
        else:
            subs = [g]
        items = []
        for s in subs:
            for el in s:
                tag = el.tag.split("}")[-1]
                rec = dict(element=tag, **{k: v for k, v in el.attrib.items()})
                di = el.find("DataItem")
                if di is not None:
                    rec["DataItem"] = dict(di.attrib, text=di.text.strip())
                    paths[(g.attrib.get("Name"), tag, el.attrib.get("Name"))] = di.text.strip()
                items.append(rec)
        gi["items"] = items
        grids.append(gi)
    h5name = {v.split(":")[0] for v in paths.values()}
    assert len(h5name) == 1, h5name
    h5 = h5lite.H5File(folder / h5name.pop())
    dsets = {d: dict(shape=list(h5.dataset_info(d)["shape"]), dtype=str(h5.dataset_info(d)["dtype"]),
                     layout=h5.dataset_info(d)["layout"][0]) for d in h5.walk("/")}
    get = lambda key: h5[paths[key].split(":", 1)[1]]
    X = get(("mesh", "Geometry", None))
    topo = get(("mesh", "Topology", None))
    ftopo = get(("facet_tags", "Topology", None))
    fvals = get(("facet_tags", "Attribute", "facet_tags")).ravel()
    f = scene["fields"]
    U = get((f["displacement"], "Attribute", f["displacement"]))
    Sraw = get((f["stress"], "Attribute", f["stress"]))
    S3, sfacts = detect_stress(Sraw)
    tags, counts = np.unique(fvals, return_counts=True)
    layout = dict(xdmf=dict(file=xdmf_rel, version=root.attrib.get("Version"), grids=grids),
                  h5=dict(file=Path(h5.path).name, superblock_version=h5.superblock_version, datasets=dsets),
                  facet_tags={str(int(t)): int(n) for t, n in zip(tags, counts)},
                  displacement=dict(name=f["displacement"], components=int(U.shape[1]),
                                    padding_max_abs=float(np.abs(U[:, 2:]).max()) if U.shape[1] > 2 else None),
                  stress=dict(name=f["stress"], **sfacts))
    tag_name = scene["boundaries"]["tag_array"]
    ev, fx = evaluate_fields(X, topo, U, S3, scene, delta, lines=ftopo, line_data={tag_name: fvals})
    return dict(files=file_list(folder), layout=layout, **ev), (X, U, S3)


def find_block(buf, arr, rtol=1e-15):
    """byte offset of the float64 array arr (C order) inside buf, values equal to rtol (the ascii copy
    it comes from has 16 significant digits); None if absent."""
    a = np.ascontiguousarray(arr, dtype="<f8").ravel()
    n = len(a)
    for shift in range(8):
        m = (len(buf) - shift) // 8
        v = np.frombuffer(buf, dtype="<f8", count=m, offset=shift)
        with np.errstate(invalid="ignore", over="ignore"):
            cand = np.nonzero(np.isfinite(v) & (np.abs(v - a[0]) <= rtol * max(abs(a[0]), 1e-300)))[0]
        for c in cand:
            if c + n <= m:
                blk = v[c:c + n]
                with np.errstate(invalid="ignore", over="ignore"):
                    hit = np.all(np.abs(blk - a) <= 1e-14 * np.maximum(np.abs(a), 1.0))
                if hit:
                    return int(shift + 8 * c), float(np.abs(blk - a).max())
    return None


def check_vtx_case(folder, companion):
    """ADIOS2 BP4 folder solution.bp: files, the VTK schema DOLFINx embeds in the metadata, and where
    the companion VTKFile fixture's geometry / displacement / stress arrays lie in data.0 (same
    DOLFINx run, same node order)."""
    folder = Path(folder)
    bp = folder / "solution.bp"
    md = (bp / "md.0").read_bytes()
    i, j = md.find(b"<?xml"), md.find(b"</VTKFile>")
    schema = md[i:j + len(b"</VTKFile>")].decode() if i >= 0 and j > i else None
    names = re.findall(r'Name="([^"]+)"', schema) if schema else []
    out = dict(files=file_list(folder), layout=dict(engine="BP4", vtk_schema=schema, schema_arrays=names))
    if companion is not None and Path(companion).exists():
        layout, pieces = vtk_collection(companion, "solution.pvd")
        pc = pieces[0]
        data = (bp / "data.0").read_bytes()
        loc = {}
        for nm, arr in (("geometry", pc["points"]), ("displacement", pc["point_data"]["displacement"]),
                        ("stress", pc["point_data"]["stress"])):
            r = find_block(data, arr)
            loc[nm] = None if r is None else dict(offset=r[0], shape=list(arr.shape), max_abs_difference=r[1])
        C = np.array(pc["cells"], dtype=np.int64)
        legacy = np.hstack([np.full((len(C), 1), C.shape[1]), C]).astype("<i8").tobytes()
        plain = C.astype("<i8").tobytes()
        loc["connectivity"] = dict(
            offset=data.find(legacy) if data.find(legacy) >= 0 else None,
            format="int64 VTK legacy cell array: per cell the node count, then its node ids (VTK order)",
            plain_int64_offset=data.find(plain) if data.find(plain) >= 0 else None)
        out["layout"]["arrays_in_data0_vs_vtkfile"] = dict(companion=Path(companion).name, **loc)
    return out


def compare_fields(a, b):
    """max |difference| of the merged fields of two solutions on the same mesh (points matched by
    coordinates): (points, displacement, stress)."""
    from scipy.spatial import cKDTree
    Xa, Ua, Sa = a
    Xb, Ub, Sb = b
    d, idx = cKDTree(Xb).query(Xa)
    return dict(points=float(d.max()), displacement=float(np.abs(Ua[:, :2] - Ub[idx, :2]).max()),
                stress=float(np.abs(Sa - Sb[idx]).max()), stress_max_abs=float(np.abs(Sb).max()))


if __name__ == "__main__":
    import tomllib
    folder = Path(sys.argv[1])
    sc = tomllib.loads((folder / "scene.toml").read_text())
    print(json.dumps(check_vtk_case(folder, sc, sys.argv[2], 1e-10)[0], indent=1, default=str)[:4000])
