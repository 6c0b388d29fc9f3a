"""VTK-library side of the quads family: writing the type-numbering twins with vtkUnstructuredGrid +
vtkXMLUnstructuredGridWriter (appended raw binary, zlib), and checking with VTK itself

- that VTK's interpolation weights of every cell type we write (5, 22, 9, 23, 28, 69, 70, 3, 21, 68)
  are the shape functions of qshape.py in the same local node order (nodality at qshape.PARAM and
  agreement at random parametric points): this *is* the node ordering;
- that two files represent the same field: the first file's cells are sampled at parametric points
  (EvaluateLocation: physical point + weights), the same physical point is located in the second
  file's cell (EvaluatePosition) and both interpolated point-data fields are compared.
"""
import numpy as np
import vtk
from vtk.util import numpy_support as ns

import qshape

VTK_TYPES = {"triangle": 5, "triangle6": 22, "quad": 9, "quad8": 23, "quad9": 28, "line": 3, "line3": 21,
             "lagrange_triangle": 69, "lagrange_quadrilateral": 70, "lagrange_curve": 68}
SHAPE_OF = {5: "triangle", 22: "triangle6", 69: "triangle6", 9: "quad", 23: "quad8", 28: "quad9", 70: "quad9",
            3: "line", 21: "line3", 68: "line3"}
COMPONENTS = {3: ["xx", "yy", "xy"]}


def write(path, points, cells, point_data, cell_data=None, higher_order_degrees=None):
    """cells: list of (vtk type id, connectivity (M, k)); cell_data: name -> array over all cells (in
    the order of `cells`); higher_order_degrees: (ncells, 3) ints written as the cell array
    `HigherOrderDegrees` (and declared as the HigherOrderDegrees attribute of the cell data)."""
    ug = vtk.vtkUnstructuredGrid()
    P = np.zeros((len(points), 3))
    P[:, :2] = points
    vp = vtk.vtkPoints()
    vp.SetData(ns.numpy_to_vtk(P, deep=True))
    ug.SetPoints(vp)
    for typ, conn in cells:
        for c in conn:
            ids = vtk.vtkIdList()
            for i in c:
                ids.InsertNextId(int(i))
            ug.InsertNextCell(int(typ), ids)
    for name, arr in point_data.items():
        a = ns.numpy_to_vtk(np.ascontiguousarray(arr, dtype=np.float64), deep=True)
        a.SetName(name)
        if name == "stress" and arr.shape[1] in COMPONENTS:
            for k, cn in enumerate(COMPONENTS[arr.shape[1]]):
                a.SetComponentName(k, cn)
        ug.GetPointData().AddArray(a)
    for name, arr in (cell_data or {}).items():
        a = ns.numpy_to_vtk(np.ascontiguousarray(arr), deep=True)
        a.SetName(name)
        ug.GetCellData().AddArray(a)
    if higher_order_degrees is not None:
        a = ns.numpy_to_vtk(np.ascontiguousarray(higher_order_degrees, dtype=np.int32), deep=True,
                            array_type=vtk.VTK_INT)
        a.SetName("HigherOrderDegrees")
        ug.GetCellData().SetHigherOrderDegrees(a)
    w = vtk.vtkXMLUnstructuredGridWriter()
    w.SetFileName(str(path))
    w.SetInputData(ug)
    w.SetDataModeToAppended()
    w.EncodeAppendedDataOff()
    w.SetCompressorTypeToZLib()
    if not w.Write():
        raise RuntimeError(f"vtk writer failed: {path}")


def read(path):
    r = vtk.vtkXMLUnstructuredGridReader()
    r.SetFileName(str(path))
    r.Update()
    ug = r.GetOutput()
    if ug.GetNumberOfCells() == 0:
        raise RuntimeError(f"{path}: VTK read no cells")
    return ug


def _eval_loc(cell, pc):
    n = cell.GetNumberOfPoints()
    x = [0.0, 0.0, 0.0]
    w = [0.0] * n
    sub = vtk.reference(0)
    cell.EvaluateLocation(sub, [float(pc[0]), float(pc[1]), 0.0], x, w)
    return np.array(x), np.array(w)


def _random_params(ctype, rng, k):
    a, b = rng.uniform(0.02, 0.98, k), rng.uniform(0.02, 0.98, k)
    if ctype.startswith("triangle"):
        flip = a + b > 1
        a[flip], b[flip] = 1 - a[flip], 1 - b[flip]
    if ctype.startswith("line"):
        b[:] = 0.0
    return np.stack([a, b], 1)


def _line_shape(ctype, s):
    s = np.atleast_1d(s)
    if ctype == "line":
        return np.stack([1 - s, s], -1)
    return np.stack([(1 - s) * (1 - 2 * s), s * (2 * s - 1), 4 * s * (1 - s)], -1)


def cell_order(cell):
    """VTK's order of a higher-order (Lagrange) cell: [per parametric direction], None for fixed types."""
    if not hasattr(cell, "GetOrder"):
        return None
    t = cell.GetCellType()
    if t == 68:
        return [int(cell.GetOrder(0))]
    if t == 69:
        return [int(cell.GetOrder())]
    if t == 70:
        return [int(cell.GetOrder(0)), int(cell.GetOrder(1))]
    return None


def ordering_check(ug, samples=5, seed=0):
    """For one cell of every type in the grid: VTK's weights at our parametric node points are the unit
    vectors (nodality: VTK node k sits at qshape.PARAM[type][k]) and VTK's weights at random parametric
    points equal our shape functions.  Returns {vtk type: {...}}."""
    rng = np.random.default_rng(seed)
    seen = {}
    for i in range(ug.GetNumberOfCells()):
        t = ug.GetCellType(i)
        if t in seen:
            continue
        cell = ug.GetCell(i)
        ctype = SHAPE_OF[t]
        n = cell.GetNumberOfPoints()
        if ctype.startswith("line"):
            params = {"line": [(0, 0), (1, 0)], "line3": [(0, 0), (1, 0), (0.5, 0)]}[ctype]
        else:
            params = qshape.PARAM[ctype]
        nod = 0.0
        for k, pc in enumerate(params):
            _, w = _eval_loc(cell, pc)
            e = np.zeros(n)
            e[k] = 1.0
            nod = max(nod, float(np.abs(w - e).max()))
        pr = _random_params(ctype, rng, samples)
        diff = 0.0
        for pc in pr:
            _, w = _eval_loc(cell, pc)
            N = _line_shape(ctype, pc[0])[0] if ctype.startswith("line") else qshape.shape(ctype, pc[0], pc[1])[0][0]
            diff = max(diff, float(np.abs(w - N).max()))
        order = cell_order(cell)
        seen[t] = dict(cell_class=cell.GetClassName(), nodes=n, parametric_nodes=[list(map(float, p)) for p in params],
                       nodality_max_error=nod, shape_function_max_difference=diff, order=order)
    return seen


def same_field(ug_a, ug_b, names, samples=4, seed=1):
    """Max difference of the point-data fields `names` between the two grids at physical points sampled
    in every cell of ug_a (cells matched by index), and the max distance of the located point."""
    rng = np.random.default_rng(seed)
    assert ug_a.GetNumberOfCells() == ug_b.GetNumberOfCells()
    fa = {n: ns.vtk_to_numpy(ug_a.GetPointData().GetArray(n)) for n in names}
    fb = {n: ns.vtk_to_numpy(ug_b.GetPointData().GetArray(n)) for n in names}
    worst = {n: 0.0 for n in names}
    worst_same = {n: 0.0 for n in names}
    dsame = 0.0
    scale = {n: float(np.abs(fa[n]).max()) for n in names}
    dmax = 0.0
    types = set()
    for i in range(ug_a.GetNumberOfCells()):
        ca, cb = ug_a.GetCell(i), ug_b.GetCell(i)
        ta, tb = ug_a.GetCellType(i), ug_b.GetCellType(i)
        types.add((ta, tb))
        ctype = SHAPE_OF[ta]
        ida = [ca.GetPointId(k) for k in range(ca.GetNumberOfPoints())]
        idb = [cb.GetPointId(k) for k in range(cb.GetNumberOfPoints())]
        for pc in _random_params(ctype, rng, samples):
            x, wa = _eval_loc(ca, pc)
            if ctype.startswith("line"):
                # curves: no EvaluatePosition in 2D needed; the same parameter must give the same point
                xb, wb = _eval_loc(cb, pc)
                d = float(np.linalg.norm(xb - x))
            else:
                closest = [0.0, 0.0, 0.0]
                pcb = [0.0, 0.0, 0.0]
                d2 = vtk.reference(0.0)
                sub = vtk.reference(0)
                wb = [0.0] * cb.GetNumberOfPoints()
                inside = cb.EvaluatePosition(list(x), closest, sub, pcb, d2, wb)
                assert inside == 1, (i, inside)
                wb = np.array(wb)
                d = float(np.sqrt(d2.get()))
            dmax = max(dmax, d)
            xs, ws = _eval_loc(cb, pc)  # the same parametric point in the other cell type
            dsame = max(dsame, float(np.linalg.norm(xs - x)))
            for n in names:
                va = wa @ fa[n][ida]
                vb = np.asarray(wb) @ fb[n][idb]
                worst[n] = max(worst[n], float(np.abs(va - vb).max()))
                worst_same[n] = max(worst_same[n], float(np.abs(va - ws @ fb[n][idb]).max()))
    return dict(types=sorted([list(t) for t in types]), samples=samples * ug_a.GetNumberOfCells(),
                max_abs_difference=worst, field_scale=scale,
                max_relative_difference={n: worst[n] / scale[n] for n in names}, located_point_distance_max=dmax,
                same_parametric_point_max_abs_difference=worst_same, same_parametric_point_distance_max=dsame,
                note="located: the physical point of cell A found in cell B by VTK's EvaluatePosition (Newton, "
                     "parametric tolerance ~1e-12, hence ~1e-12 relative); same parametric point: both cells "
                     "evaluated at the same (r, s) (same parametric conventions), geometry and fields")


def arrays(ug):
    """points, per-cell (type, ids), point data as numpy (for --check comparisons)."""
    P = ns.vtk_to_numpy(ug.GetPoints().GetData())
    cells = []
    for i in range(ug.GetNumberOfCells()):
        c = ug.GetCell(i)
        cells.append((ug.GetCellType(i), tuple(c.GetPointId(k) for k in range(c.GetNumberOfPoints()))))
    pd = {ug.GetPointData().GetArrayName(k): ns.vtk_to_numpy(ug.GetPointData().GetArray(k))
          for k in range(ug.GetPointData().GetNumberOfArrays())}
    cd = {ug.GetCellData().GetArrayName(k): ns.vtk_to_numpy(ug.GetCellData().GetArray(k))
          for k in range(ug.GetCellData().GetNumberOfArrays())}
    return P, cells, pd, cd
