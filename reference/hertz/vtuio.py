"""Writing fixture VTU files in several encodings, and reading them back."""
import numpy as np
import meshio

LAYOUTS = {
    "xx,yy,xy": lambda S: S[:, [0, 1, 3]],
    "xx,yy,zz,xy": lambda S: S[:, [0, 1, 2, 3]],
    # row-major 3x3, plane strain: xz = yz = 0
    "9": lambda S: np.stack([S[:, 0], S[:, 3], 0 * S[:, 0], S[:, 3], S[:, 1], 0 * S[:, 0],
                             0 * S[:, 0], 0 * S[:, 0], S[:, 2]], axis=1),
}
COMPONENT_NAMES = {"xx,yy,xy": ["xx", "yy", "xy"], "xx,yy,zz,xy": ["xx", "yy", "zz", "xy"],
                   "9": ["xx", "xy", "xz", "yx", "yy", "yz", "zx", "zy", "zz"]}


def stress_layout(S4, layout):
    """S4 columns xx, yy, zz, xy -> the requested layout."""
    return np.ascontiguousarray(LAYOUTS[layout](S4))


def write(path, nodes, cells, lines, point_data, cell_data_tri=None, tag_name=None, tags=None,
          encoding="zlib", write_lines=True):
    """encoding: zlib | lzma | ascii | raw (inline base64, uncompressed) | uint64 (zlib, UInt64 headers)
    | vtk-appended-raw | vtk-appended-zlib (written by the VTK library itself)."""
    pts = np.zeros((nodes.shape[0], 3))
    pts[:, :2] = nodes
    quad = cells.shape[1] == 6
    tri_type, line_type = ("triangle6", "line3") if quad else ("triangle", "line")
    blocks = [(tri_type, cells.astype(np.int64))]
    if write_lines:
        blocks.append((line_type, lines.astype(np.int64)))
    cd = {}
    for name, arr in (cell_data_tri or {}).items():
        cd[name] = [arr] + ([np.zeros((len(lines),) + arr.shape[1:], dtype=arr.dtype)] if write_lines else [])
    if tag_name is not None:
        assert write_lines
        cd[tag_name] = [np.zeros(len(cells), dtype=np.int32), np.asarray(tags, dtype=np.int32)]
    if encoding.startswith("vtk-"):
        return _write_vtk(path, pts, blocks, point_data, cd, compress=encoding.endswith("zlib"))
    mesh = meshio.Mesh(pts, blocks, point_data=point_data, cell_data=cd)
    if encoding == "ascii":
        import contextlib
        import io
        with contextlib.redirect_stderr(io.StringIO()):  # meshio's "ascii only for debugging" notice
            meshio.vtu.write(path, mesh, binary=False)
    elif encoding == "raw":
        meshio.vtu.write(path, mesh, binary=True, compression=None)
    elif encoding == "uint64":
        meshio.vtu.write(path, mesh, binary=True, compression="zlib", header_type="UInt64")
    else:
        meshio.vtu.write(path, mesh, binary=True, compression=encoding)


def _write_vtk(path, pts, blocks, point_data, cell_data, compress):
    import vtk
    from vtk.util import numpy_support as ns
    ug = vtk.vtkUnstructuredGrid()
    vp = vtk.vtkPoints()
    vp.SetData(ns.numpy_to_vtk(pts, deep=True))
    ug.SetPoints(vp)
    vtk_type = {"triangle": 5, "triangle6": 22, "line": 3, "line3": 21}
    for name, conn in blocks:
        for c in conn:
            ids = vtk.vtkIdList()
            for i in c:
                ids.InsertNextId(int(i))
            ug.InsertNextCell(vtk_type[name], ids)
    for name, arr in point_data.items():
        a = ns.numpy_to_vtk(np.ascontiguousarray(arr), deep=True)
        a.SetName(name)
        if arr.ndim == 2 and name.lower().startswith("stress"):
            for k, cn in enumerate(COMPONENT_NAMES.get({3: "xx,yy,xy", 4: "xx,yy,zz,xy", 9: "9"}[arr.shape[1]])):
                a.SetComponentName(k, cn)
        ug.GetPointData().AddArray(a)
    for name, parts in cell_data.items():
        arr = np.concatenate(parts)
        a = ns.numpy_to_vtk(np.ascontiguousarray(arr), deep=True)
        a.SetName(name)
        ug.GetCellData().AddArray(a)
    w = vtk.vtkXMLUnstructuredGridWriter()
    w.SetFileName(str(path))
    w.SetInputData(ug)
    w.SetDataModeToAppended()
    w.EncodeAppendedDataOff()
    if compress:
        w.SetCompressorTypeToZLib()
    else:
        w.SetCompressorTypeToNone()
    if not w.Write():
        raise RuntimeError("vtk writer failed")


def merge_points(P, rtol=1e-12):
    """Union of points closer than rtol * diameter (exploded meshes from NGSolve's VTKOutput evaluate the
    same vertex once per element, identical up to round-off).  Returns (index of the kept copy per
    merged point, map file point -> merged point); the first copy in file order is kept."""
    from scipy.spatial import cKDTree
    diam = float(np.ptp(P, axis=0).max()) if len(P) else 1.0
    pairs = cKDTree(P).query_pairs(rtol * diam, output_type="ndarray")
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
    roots = np.array([find(i) for i in range(len(P))])
    keep, inv = np.unique(roots, return_inverse=True)
    return keep, inv.ravel()


def read(path):
    """Read a VTU; coincident points (within 1e-12 of the diameter) are merged: NGSolve's VTKOutput writes
    an exploded mesh, one copy of every vertex per cell.  Merged copies must carry the same point data
    (to 1e-10 relative); the first copy in file order is kept."""
    m = meshio.read(path)
    P = m.points[:, :2]
    first, inv = merge_points(P)
    pdata = {}
    jump = 0.0
    for k, v in m.point_data.items():
        v = np.asarray(v, dtype=float)
        if v.size:
            d = float(np.abs(v - v[first][inv]).max())
            if d > 1e-10 * max(float(np.abs(v).max()), 1e-300):
                raise ValueError(f"{path}: coincident points carry different values of {k} (max {d})")
            jump = max(jump, d)
        pdata[k] = v[first]
    out = dict(points=P[first].copy(), point_data=pdata, points_in_file=int(len(P)), merge_jump=jump)
    tri = [(i, c) for i, c in enumerate(m.cells) if c.type in ("triangle", "triangle6")]
    lin = [(i, c) for i, c in enumerate(m.cells) if c.type in ("line", "line3")]
    assert len(tri) == 1 and len(lin) <= 1
    out["cells"] = inv[tri[0][1].data]
    out["cell_data"] = {k: v[tri[0][0]] for k, v in m.cell_data.items()}
    if lin:
        out["lines"] = inv[lin[0][1].data]
        out["line_data"] = {k: v[lin[0][0]] for k, v in m.cell_data.items()}
    else:
        out["lines"] = None
        out["line_data"] = {}
    return out
