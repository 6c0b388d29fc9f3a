"""Reading the solution VTU (meshio) and building the mesh topology.

Cells: `triangle` (P1) or `triangle6` (P2, VTK order v0 v1 v2 m01 m12 m20, mid nodes may be
curved). Boundary: `line` / `line3` cells carrying a cell-data tag array. Point data are used per
cell with the cell's own point indices, so exploded (discontinuous, e.g. NGSolve VTKOutput)
meshes work; topology (which edges are on the boundary, which line cell is which edge) is found
on geometrically merged points.
"""
import re
from dataclasses import dataclass, field

import meshio
import numpy as np
from scipy.spatial import cKDTree

from .errors import InputError

_DISP_NAMES = ("displacement", "displacements", "disp", "u", "d")
_STRESS_NAMES = ("stress", "stresses", "sigma", "s", "cauchy_stress")
_DEFAULT_LAYOUTS = {
    3: ["xx", "yy", "xy"],
    4: ["xx", "yy", "zz", "xy"],
    6: ["xx", "yy", "zz", "xy", "yz", "xz"],
    9: ["xx", "xy", "xz", "yx", "yy", "yz", "zx", "zy", "zz"],
}
_IDX = {"x": 0, "y": 1, "z": 2}
_NUMERIC = {"1": "x", "2": "y", "3": "z"}
# local edges of a triangle (vertex pairs) and the local index of their mid node (P2)
EDGE_VERTS = np.array([[0, 1], [1, 2], [2, 0]])
EDGE_MID = np.array([3, 4, 5])


@dataclass
class Solution:
    path: str
    points: np.ndarray          # (Np, 2)
    cells: np.ndarray           # (Nc, 3|6)
    degree: int
    disp: np.ndarray            # (Np, 2)
    stress: np.ndarray          # (Np, 2, 2) (row-major tensor)
    disp_name: str
    stress_name: str
    stress_layout: list
    merged: np.ndarray = None   # (Np,) canonical point id (geometric merge)
    orient: np.ndarray = None   # (Nc,) +1 counter-clockwise, -1 clockwise
    bedge_cell: np.ndarray = None   # (Nb,) owning cell of each boundary edge
    bedge_local: np.ndarray = None  # (Nb,) local edge 0:(v0,v1) 1:(v1,v2) 2:(v2,v0)
    bedge_key: np.ndarray = None    # (Nb, 2) sorted merged end-point ids
    line_keys: np.ndarray = None    # (Nl, 2) sorted merged end-point ids of line cells
    line_tags: np.ndarray = None    # (Nl,) tag values (or None)
    notes: list = field(default_factory=list)


def _header_component_names(path):
    """ComponentName<i> attributes of PointData arrays (meshio drops them)."""
    try:
        with open(path, "rb") as fh:
            raw = fh.read()
    except OSError:
        return {}
    cut = raw.find(b"<AppendedData")
    if cut >= 0:
        raw = raw[:cut]
    text = raw.decode("latin-1")
    out = {}
    for tag in re.findall(r"<DataArray\b[^>]*>", text):
        attrs = dict(re.findall(r'(\w+)\s*=\s*"([^"]*)"', tag))
        names = {int(k[len("ComponentName"):]): v for k, v in attrs.items()
                 if k.startswith("ComponentName") and k[len("ComponentName"):].isdigit()}
        if "Name" in attrs and names:
            n = max(names) + 1
            out[attrs["Name"]] = [names.get(i, "") for i in range(n)]
    return out


def _normalise_component(name):
    s = name.strip().lower()
    m = re.search(r"([xyz]{2})$", s)
    if m:
        return m.group(1)
    m = re.search(r"([123]{2})$", s)
    if m:
        return _NUMERIC[m.group(1)[0]] + _NUMERIC[m.group(1)[1]]
    return None


def parse_layout(spec, ncomp, where):
    labels = [c.strip().lower() for c in spec.split(",")] if isinstance(spec, str) else list(spec)
    if len(labels) != ncomp:
        raise InputError(f"{where}: stress layout {spec!r} has {len(labels)} components, the array has {ncomp}")
    for lab in labels:
        if len(lab) != 2 or lab[0] not in _IDX or lab[1] not in _IDX:
            raise InputError(f"{where}: stress layout component {lab!r} not understood")
    if len(set(labels)) != len(labels):
        raise InputError(f"{where}: stress layout {spec!r} repeats a component")
    if "xx" not in labels or "yy" not in labels or not ({"xy", "yx"} & set(labels)):
        raise InputError(f"{where}: stress layout {spec!r} lacks xx, yy or xy")
    return labels


def tensor_from_layout(arr, labels):
    """(Np, ncomp) -> (Np, 2, 2); a missing transpose partner means symmetric."""
    S = np.zeros((arr.shape[0], 2, 2))
    for j, lab in enumerate(labels):
        a, b = _IDX[lab[0]], _IDX[lab[1]]
        if a < 2 and b < 2:
            S[:, a, b] = arr[:, j]
            if lab[::-1] not in labels:
                S[:, b, a] = arr[:, j]
    return S


def _find_array(data, wanted, candidates, what, path, cell_data=None):
    if wanted is not None:
        if wanted in data:
            return wanted
        if cell_data is not None and wanted in cell_data:
            raise InputError(f"{path}: {what} {wanted!r} is cell data: the reference evaluates nodal "
                             "(point-data) fields only, it does not reconstruct")
        raise InputError(f"{path}: no point-data array {wanted!r} ({what}); point data: {sorted(data)}")
    lower = {k.lower(): k for k in data}
    for c in candidates:
        if c in lower:
            return lower[c]
    if cell_data is not None:
        lc = {k.lower(): k for k in cell_data}
        for c in candidates:
            if c in lc:
                raise InputError(f"{path}: {what} {lc[c]!r} is cell data: the reference evaluates "
                                 "nodal (point-data) fields only, it does not reconstruct")
    raise InputError(f"{path}: cannot find the {what} array (looked for {list(candidates)}); "
                     f"point data: {sorted(data)}")


def _count_pieces(path):
    try:
        with open(path, "rb") as fh:
            raw = fh.read()
    except OSError:
        return 0
    cut = raw.find(b"<AppendedData")
    return len(re.findall(rb"<Piece\b", raw[:cut] if cut >= 0 else raw))


def read_solution(path, scene, layout_override=None):
    if _count_pieces(path) > 1:
        raise InputError(f"{path}: {_count_pieces(path)} <Piece> elements: meshio 5.3.5 reads only "
                         "the last piece, so the reference refuses multi-piece files")
    try:
        m = meshio.read(path)
    except FileNotFoundError:
        raise InputError(f"{path}: file not found") from None
    except Exception as exc:  # meshio raises many types
        raise InputError(f"{path}: cannot read VTU: {exc}") from None
    pts = np.asarray(m.points, dtype=float)
    if pts.ndim != 2 or pts.shape[1] < 2:
        raise InputError(f"{path}: points array has shape {pts.shape}")
    if pts.shape[1] == 3 and np.any(pts[:, 2] != 0):
        raise InputError(f"{path}: points have nonzero z: only 2D meshes in the xy-plane are supported")
    pts = np.ascontiguousarray(pts[:, :2])
    if not np.all(np.isfinite(pts)):
        raise InputError(f"{path}: non-finite point coordinates")

    tri_blocks, line_blocks = [], []
    for ib, blk in enumerate(m.cells):
        if blk.type in ("triangle", "triangle6"):
            tri_blocks.append((ib, blk))
        elif blk.type in ("line", "line3"):
            line_blocks.append((ib, blk))
        elif blk.type == "vertex":
            continue
        else:
            raise InputError(f"{path}: unsupported cell type {blk.type!r}")
    if not tri_blocks:
        raise InputError(f"{path}: no triangle cells")
    types = {b.type for _, b in tri_blocks}
    if len(types) > 1:
        raise InputError(f"{path}: mixed triangle and triangle6 cells are not supported")
    degree = 2 if "triangle6" in types else 1
    cells = np.concatenate([np.asarray(b.data, dtype=np.int64) for _, b in tri_blocks])
    if cells.min() < 0 or cells.max() >= len(pts):
        raise InputError(f"{path}: cell connectivity out of range")

    # fields
    dname = _find_array(m.point_data, scene.displacement_name, _DISP_NAMES, "displacement", path,
                        m.cell_data)
    sname = _find_array(m.point_data, scene.stress_name, _STRESS_NAMES, "stress", path, m.cell_data)
    disp = np.asarray(m.point_data[dname], dtype=float)
    if disp.ndim == 1 or disp.shape[1] not in (2, 3):
        raise InputError(f"{path}: displacement {dname!r} must have 2 or 3 components, has shape {disp.shape}")
    notes = []
    if disp.shape[1] == 3 and np.any(disp[:, 2] != 0):
        notes.append(f"displacement {dname!r}: nonzero z component ignored")
    disp = np.ascontiguousarray(disp[:, :2])
    sarr = np.asarray(m.point_data[sname], dtype=float)
    if sarr.ndim == 3 and sarr.shape[1:] in ((3, 3), (2, 2)):
        sarr = sarr.reshape(len(sarr), -1)
    if sarr.ndim != 2 or sarr.shape[1] not in (3, 4, 6, 9):
        raise InputError(f"{path}: stress {sname!r}: {sarr.shape[1:] } components, expected 3, 4, 6 or 9")
    ncomp = sarr.shape[1]
    if layout_override is not None or scene.stress_layout is not None:
        spec = layout_override if layout_override is not None else scene.stress_layout
        labels = parse_layout(spec, ncomp, path)
        layout_src = "explicit"
    else:
        names = _header_component_names(path).get(sname)
        labels = None
        if names and len(names) == ncomp:
            lab = [_normalise_component(n) for n in names]
            if all(lab) and len(set(lab)) == ncomp:
                labels = parse_layout(lab, ncomp, path)
                layout_src = "ComponentName"
        if labels is None:
            labels = _DEFAULT_LAYOUTS[ncomp]
            layout_src = "component count"
    notes.append(f"stress layout {','.join(labels)} (from {layout_src})")
    if len(disp) != len(pts) or len(sarr) != len(pts):
        raise InputError(f"{path}: point-data array sizes do not match the number of points")
    used = np.unique(cells)
    if not np.all(np.isfinite(disp[used])) or not np.all(np.isfinite(sarr[used])):
        raise InputError(f"{path}: NaN/Inf in the displacement or stress data")
    stress = tensor_from_layout(sarr, labels)

    sol = Solution(path=path, points=pts, cells=cells, degree=degree, disp=disp, stress=stress,
                   disp_name=dname, stress_name=sname, stress_layout=labels, notes=notes)

    # line cells and their tags
    keys, tags = [], []
    for ib, blk in line_blocks:
        d = np.asarray(blk.data, dtype=np.int64)
        keys.append(d[:, :2])
        t = None
        if scene.tag_array is not None:
            cd = m.cell_data.get(scene.tag_array)
            if cd is not None:
                t = np.asarray(cd[ib]).reshape(len(d), -1)[:, 0]
        tags.append(np.full(len(d), np.nan) if t is None else t.astype(float))
    if keys:
        sol.line_keys = np.concatenate(keys)
        sol.line_tags = np.concatenate(tags)
    else:
        sol.line_keys = np.zeros((0, 2), dtype=np.int64)
        sol.line_tags = np.zeros(0)
    if scene.tag_array is not None and scene.tag_array not in m.cell_data:
        if any(b.tag is not None for b in scene.boundaries):
            raise InputError(f"{path}: cell-data tag array {scene.tag_array!r} (boundaries.tag_array) "
                             f"not in the file; cell data: {sorted(m.cell_data)}")
    build_topology(sol)
    return sol


def merge_points(pts, used):
    """Canonical id per point: points closer than 1e-12 * bbox size are the same point."""
    P = pts[used]
    span = np.ptp(P, axis=0).max() if len(P) else 1.0
    tol = 1e-12 * max(span, np.finfo(float).tiny)
    tree = cKDTree(P)
    pairs = tree.query_pairs(tol, output_type="ndarray")
    parent = np.arange(len(P))

    def find(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for a, b in pairs:
        ra, rb = find(a), find(b)
        if ra != rb:
            parent[max(ra, rb)] = min(ra, rb)
    roots = np.array([find(i) for i in range(len(P))], dtype=np.int64)
    merged = np.full(len(pts), -1, dtype=np.int64)
    merged[used] = used[roots]
    return merged


def build_topology(sol):
    from .fem import cell_orientation  # local import: fem depends on nothing here

    used = np.unique(np.concatenate([sol.cells.ravel(), sol.line_keys.ravel()]))
    sol.merged = merge_points(sol.points, used)
    sol.orient = cell_orientation(sol)
    mc = sol.merged[sol.cells[:, :3]]
    ek = np.sort(np.stack([mc[:, EDGE_VERTS[j]] for j in range(3)], axis=1), axis=2)  # (Nc,3,2)
    flat = ek.reshape(-1, 2)
    uniq, inv, counts = np.unique(flat, axis=0, return_inverse=True, return_counts=True)
    inv = inv.ravel()
    if np.any(counts > 2):
        raise InputError(f"{sol.path}: non-manifold mesh: an edge is shared by more than two cells")
    if np.any(flat[:, 0] == flat[:, 1]):
        raise InputError(f"{sol.path}: degenerate cell (repeated vertex)")
    bmask = counts[inv] == 1
    idx = np.nonzero(bmask)[0]
    sol.bedge_cell = idx // 3
    sol.bedge_local = idx % 3
    sol.bedge_key = flat[idx]
    if len(sol.line_keys):
        sol.line_keys = np.sort(sol.merged[sol.line_keys], axis=1)
