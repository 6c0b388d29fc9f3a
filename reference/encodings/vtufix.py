"""Shared helpers of the `encodings` reference family.

Everything here is plain numpy + meshio + vtk (+ scikit-fem / NGSolve for the
solves).  The scripts in this folder (make.py, check_writer.py, make_bench.py)
import it; nothing outside reference/ uses it.

A "grid" below is the reader-independent, normalised view of one VTU file:

    {
      "points":  (N, 3) float array (dtype as stored in the file),
      "types":   (M,)  int64 VTK cell type per cell, in file order,
      "offsets": (M+1,) int64, cell k has conn[offsets[k]:offsets[k+1]],
      "conn":    int64 connectivity,
      "point_data": {name: (N, c) array},      # c = 1 for scalar arrays
      "cell_data":  {name: (M, c) array},
      "component_names": {name: [str, ...] or None},
      "pieces":  [(n_points, n_cells), ...]    # as concatenated by the reader
    }
"""

from __future__ import annotations

import contextlib
import io
import math
import os
import warnings

import numpy as np

# ---------------------------------------------------------------------------
# constants of the problem
# ---------------------------------------------------------------------------
E = 20600.0
NU = 0.28
LAM = E * NU / ((1.0 + NU) * (1.0 - 2.0 * NU))  # plane strain
MU = E / (2.0 * (1.0 + NU))
CENTRE = np.array([0.0, 1.0])
TOP_DISPLACEMENT = (0.0, -0.01)
# u_y = 0 on the part of the arc within pi/8 of the lowest point (|x| < sin(pi/8))
CONTACT_HALF_ANGLE = math.pi / 8.0
N_RINGS = 8  # ring j (1..8) of the polar mesh has 2j segments -> 128 triangles

VTK_VERTEX = 1
VTK_LINE = 3
VTK_TRIANGLE = 5
VTK_QUADRATIC_EDGE = 21
VTK_QUADRATIC_TRIANGLE = 22
VTK_NAMES = {
    VTK_VERTEX: "VTK_VERTEX",
    VTK_LINE: "VTK_LINE",
    VTK_TRIANGLE: "VTK_TRIANGLE",
    VTK_QUADRATIC_EDGE: "VTK_QUADRATIC_EDGE",
    VTK_QUADRATIC_TRIANGLE: "VTK_QUADRATIC_TRIANGLE",
}

STRESS4_NAMES = ["xx", "yy", "zz", "xy"]
STRESS3_NAMES = ["xx", "yy", "xy"]
DISP_NAMES = ["x", "y", "z"]

TAG_INTERIOR = 0
TAG_ARC = 1
TAG_TOP = 2


# ---------------------------------------------------------------------------
# mesh of the lower half disc  {x^2 + (y-1)^2 <= 1, y <= 1}
# ---------------------------------------------------------------------------
def _ring(j):
    """Angles and points of ring j (radius j/N_RINGS), angles in [pi, 2 pi]."""
    if j == 0:
        return np.array([1.5 * math.pi]), CENTRE[None, :].copy()
    n = 2 * j
    ang = math.pi + math.pi * np.arange(n + 1) / n
    r = j / N_RINGS
    pts = np.column_stack([r * np.cos(ang), 1.0 + r * np.sin(ang)])
    # exact values on the top line and the axis
    pts[0] = (-r, 1.0)
    pts[-1] = (r, 1.0)
    pts[j] = (0.0, 1.0 - r)
    return ang, pts


def half_disc_p1():
    """Deterministic 'polar' triangulation: centre + rings j=1..8 with 2j
    segments each (ring 8 = the arc, 16 segments, vertices at angles
    pi + k pi/16, so |x| = sin(pi/8) is a vertex).  Returns p (2,V), t (3,T)
    with counter-clockwise triangles."""
    pts = []
    idx = []
    start = 0
    for j in range(N_RINGS + 1):
        ang, p = _ring(j)
        pts.append(p)
        idx.append(np.arange(start, start + len(p)))
        start += len(p)
    p = np.vstack(pts)
    tris = []
    # centre fan
    c = idx[0][0]
    r1 = idx[1]
    tris += [(c, r1[0], r1[1]), (c, r1[1], r1[2])]
    # zipper between ring j and j+1
    for j in range(1, N_RINGS):
        a_ang, _ = _ring(j)
        b_ang, _ = _ring(j + 1)
        ia, ib = idx[j], idx[j + 1]
        i = k = 0
        m, n = len(ia) - 1, len(ib) - 1
        while i < m or k < n:
            adv_b = k < n and (i == m or b_ang[k + 1] <= a_ang[i + 1] + 1e-14)
            if adv_b:
                tris.append((ia[i], ib[k], ib[k + 1]))
                k += 1
            else:
                tris.append((ia[i], ib[k], ia[i + 1]))
                i += 1
    t = np.array(tris, dtype=np.int64).T
    # orient counter-clockwise
    a, b, cc = p[t[0]], p[t[1]], p[t[2]]
    area = (b[:, 0] - a[:, 0]) * (cc[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (cc[:, 0] - a[:, 0])
    neg = area < 0
    t[1, neg], t[2, neg] = t[2, neg].copy(), t[1, neg].copy()
    return p.T.copy(), t


def on_arc(x, y):
    return np.abs(np.hypot(x - CENTRE[0], y - CENTRE[1]) - 1.0) < 1e-9


def on_top(y):
    return np.abs(y - 1.0) < 1e-12


def project_to_circle(xy):
    d = xy - CENTRE[:, None]
    return CENTRE[:, None] + d / np.linalg.norm(d, axis=0)


# ---------------------------------------------------------------------------
# scikit-fem solve
# ---------------------------------------------------------------------------
def solve_skfem(order):
    """Plane-strain elasticity on the half disc, P1 or isoparametric P2.

    Returns the canonical in-memory solution `sol` (see grid layout in the
    module docstring; float64 points, int64 connectivity, int32 tags)."""
    import scipy.sparse.linalg as spla
    from skfem import (Basis, BilinearForm, ElementTriP1, ElementTriP2,
                       ElementVector, MeshTri1, MeshTri2, asm, condense)
    from skfem.helpers import dot
    from skfem.models.elasticity import linear_elasticity

    p, t = half_disc_p1()
    m1 = MeshTri1(p, t, sort_t=False)
    if order == 1:
        mesh = m1
        se = ElementTriP1()
    else:
        m2 = MeshTri2.from_mesh(m1)
        # isoparametric: mid-edge nodes of arc edges onto the circle
        bf = m2.boundary_facets()
        arcf = bf[on_arc(*m2.p[:, m2.facets[:, bf]].reshape(2, -1)).reshape(2, -1).all(axis=0)]
        D = m2.dofs.get_facet_dofs(arcf).flatten()
        doflocs = m2.doflocs.copy()
        doflocs[:, D] = project_to_circle(doflocs[:, D])
        mesh = MeshTri2(doflocs, m1.t, sort_t=False)
        se = ElementTriP2()
    intorder = 4 if order == 2 else 2
    vb = Basis(mesh, ElementVector(se), intorder=intorder)
    sb = Basis(mesh, se, intorder=intorder)
    nv = mesh.p.shape[1]

    K = asm(linear_elasticity(LAM, MU), vb)

    # boundary facets, classified
    bf = mesh.boundary_facets()
    fv = mesh.p[:, mesh.facets[:, bf]]  # (2, 2, nbf)
    is_top = on_top(fv[1]).all(axis=0)
    is_arc = on_arc(fv[0], fv[1]).all(axis=0)
    assert np.all(is_top ^ is_arc)
    mid = fv.mean(axis=1)
    is_contact = is_arc & (np.abs(mid[0]) < math.sin(CONTACT_HALF_ANGLE))
    assert is_contact.sum() == 4

    x = np.zeros(vb.N)
    top_dofs = vb.get_dofs(facets=bf[is_top])
    dx_top = top_dofs.all("u^1")
    dy_top = top_dofs.all("u^2")
    dy_contact = vb.get_dofs(facets=bf[is_contact]).all("u^2")
    x[dx_top] = TOP_DISPLACEMENT[0]
    x[dy_top] = TOP_DISPLACEMENT[1]
    D = np.unique(np.concatenate([dx_top, dy_top, dy_contact]))
    x = x.copy()
    Kc, fc, xc, I = condense(K, np.zeros(vb.N), x=x, D=D)
    x[I] = spla.spsolve(Kc.tocsc(), fc)

    # displacement per scalar dof
    (ux, bx), (uy, by) = vb.split(x)
    # strain at quadrature points
    w = vb.interpolate(x)
    G = w.grad  # (2, 2, nel, nqp)
    exx, eyy, exy = G[0, 0], G[1, 1], 0.5 * (G[0, 1] + G[1, 0])
    tr = exx + eyy
    sig = {
        "xx": 2 * MU * exx + LAM * tr,
        "yy": 2 * MU * eyy + LAM * tr,
        "zz": LAM * tr,
        "xy": 2 * MU * exy,
    }
    # L2 projection onto the scalar Lagrange space (continuous nodal stress)
    M = asm(BilinearForm(lambda u, v, _: u * v), sb)
    phi = [sb.basis[i][0].value for i in range(sb.Nbfun)]  # (nel, nqp) each
    dxq = sb.dx
    lu = spla.splu(M.tocsc())
    stress = np.zeros((sb.N, 4))
    for c, name in enumerate(STRESS4_NAMES):
        rhs = np.zeros(sb.N)
        for i in range(sb.Nbfun):
            np.add.at(rhs, sb.element_dofs[i], np.sum(sig[name] * phi[i] * dxq, axis=1))
        stress[:, c] = lu.solve(rhs)
    # element averages (piecewise constant), xx, yy, xy
    area = dxq.sum(axis=1)
    cell_stress = np.column_stack([np.sum(sig[n] * dxq, axis=1) / area for n in STRESS3_NAMES])

    # --- assemble the VTU layout -------------------------------------------
    pts2 = sb.doflocs.T  # scalar dof order: vertices, then one node per edge
    points = np.column_stack([pts2, np.zeros(sb.N)])
    tri = sb.element_dofs.T.astype(np.int64)  # P2: v0 v1 v2 e01 e12 e02
    if order == 2:
        # VTK quadratic triangle node order: v0 v1 v2 m01 m12 m20
        chk = points[tri[:, 3], :2] - 0.5 * (points[tri[:, 0], :2] + points[tri[:, 1], :2])
        assert np.all(np.abs(chk) < 0.05)
    # boundary edges, oriented with the body on the left, ordered along the
    # counter-clockwise boundary loop: arc (angle pi -> 2pi), then top (x 1 -> -1)
    f2t = mesh.f2t[0, bf]
    lines = []
    tags = []
    keys = []
    for k, f in enumerate(bf):
        a, b = mesh.facets[:, f]
        opp = [v for v in mesh.t[:, f2t[k]] if v not in (a, b)][0]
        pa, pb, po = mesh.p[:, a], mesh.p[:, b], mesh.p[:, opp]
        cross = (pb[0] - pa[0]) * (po[1] - pa[1]) - (pb[1] - pa[1]) * (po[0] - pa[0])
        if cross < 0:
            a, b = b, a
        cell = [a, b] + ([sb.facet_dofs[0, f]] if order == 2 else [])
        lines.append(cell)
        m = 0.5 * (mesh.p[:, a] + mesh.p[:, b])
        if is_top[k]:
            tags.append(TAG_TOP)
            keys.append((1, -m[0]))
        else:
            tags.append(TAG_ARC)
            keys.append((0, math.atan2(m[1] - 1.0, m[0]) % (2 * math.pi)))
    order_l = sorted(range(len(lines)), key=lambda i: keys[i])
    lines = np.array([lines[i] for i in order_l], dtype=np.int64)
    tags = np.array([tags[i] for i in order_l], dtype=np.int32)

    ntri, nlin = tri.shape[0], lines.shape[0]
    tri_type = VTK_QUADRATIC_TRIANGLE if order == 2 else VTK_TRIANGLE
    lin_type = VTK_QUADRATIC_EDGE if order == 2 else VTK_LINE
    blocks = [(tri_type, tri), (lin_type, lines)]
    disp = np.column_stack([ux, uy, np.zeros(sb.N)])
    cell_stress_all = np.vstack([cell_stress, np.zeros((nlin, 3))])
    tag_all = np.concatenate([np.full(ntri, TAG_INTERIOR, np.int32), tags])
    sol = make_grid(
        points,
        blocks,
        point_data={"displacement": disp, "stress": stress},
        cell_data={"cell_stress": cell_stress_all, "boundary_tag": tag_all[:, None]},
        component_names={
            "displacement": None,
            "stress": STRESS4_NAMES,
            "cell_stress": STRESS3_NAMES,
            "boundary_tag": None,
        },
    )
    sanity_check_solution(sol, order)
    return sol


def sanity_check_solution(sol, order):
    pts = sol["points"]
    disp = sol["point_data"]["displacement"]
    y = pts[:, 1]
    top = on_top(y)
    assert np.allclose(disp[top, 1], TOP_DISPLACEMENT[1], atol=1e-14)
    assert np.allclose(disp[top, 0], 0.0, atol=1e-14)
    arc = on_arc(pts[:, 0], pts[:, 1])
    # P2: every arc node (including the mid-edge ones) is on the circle
    types = sol["types"]
    nb = np.isin(types, [VTK_LINE, VTK_QUADRATIC_EDGE])
    bnodes = np.unique(np.concatenate([cell for ty, cell in iter_cells(sol) if ty in (VTK_LINE, VTK_QUADRATIC_EDGE)]))
    assert np.all(arc[bnodes] | top[bnodes]), "boundary node off the boundary"
    assert nb.sum() == 32
    assert np.all(np.isfinite(disp)) and np.abs(disp).max() > 1e-3


def make_grid(points, blocks, point_data, cell_data, component_names):
    types = np.concatenate([np.full(len(c), ty, np.int64) for ty, c in blocks])
    conn = np.concatenate([c.ravel() for _, c in blocks]).astype(np.int64)
    sizes = np.concatenate([np.full(len(c), c.shape[1], np.int64) for _, c in blocks])
    offsets = np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64)
    return {
        "points": np.ascontiguousarray(points, dtype=np.float64),
        "types": types,
        "offsets": offsets,
        "conn": conn,
        "point_data": {k: _2d(v) for k, v in point_data.items()},
        "cell_data": {k: _2d(v) for k, v in cell_data.items()},
        "component_names": dict(component_names),
        "pieces": [(len(points), len(types))],
    }


def _2d(a):
    a = np.asarray(a)
    return a.reshape(len(a), -1) if a.ndim == 1 else a


def iter_cells(g):
    """Yield (vtk_type, connectivity row) for every cell, in file order."""
    off = g["offsets"]
    for k, ty in enumerate(g["types"]):
        yield int(ty), g["conn"][off[k]:off[k + 1]]


def blocks_of(g):
    """Consecutive runs of equal cell type -> [(type, (n, nodes) array), ...]."""
    out = []
    types = g["types"]
    off = g["offsets"]
    k = 0
    while k < len(types):
        j = k
        while j < len(types) and types[j] == types[k]:
            j += 1
        nn = off[k + 1] - off[k]
        seg = g["conn"][off[k]:off[j]]
        out.append((int(types[k]), seg.reshape(j - k, nn)))
        k = j
    return out


# ---------------------------------------------------------------------------
# NGSolve solve
# ---------------------------------------------------------------------------
def ngsolve_geometry():
    from netgen.occ import ArcOfCircle, Face, OCCGeometry, Pnt, Segment, Wire

    def P(t):
        return Pnt(math.cos(t), 1.0 + math.sin(t), 0.0)

    ts = [math.pi, 1.5 * math.pi - CONTACT_HALF_ANGLE, 1.5 * math.pi + CONTACT_HALF_ANGLE, 2 * math.pi]
    edges = []
    for i in range(3):
        a, b = ts[i], ts[i + 1]
        edges.append(ArcOfCircle(P(a), P(0.5 * (a + b)), P(b)))
    edges.append(Segment(Pnt(1, 1, 0), Pnt(-1, 1, 0)))
    f = Face(Wire(edges))
    for e in f.edges:
        c = e.center
        if abs(c.y - 1.0) < 1e-12:
            e.name = "top"
        elif abs(c.x) < 0.2:
            e.name = "contact"
        else:
            e.name = "arc"
    return OCCGeometry(f, dim=2)


def solve_ngsolve_and_write(order, outdir, basename):
    """Solve with NGSolve and write the result with VTKOutput.

    Returns the list of files VTKOutput produced (paths)."""
    import ngsolve as ngs

    ngs.SetNumThreads(1)
    before = set(os.listdir(outdir))
    mesh = ngs.Mesh(ngsolve_geometry().GenerateMesh(maxh=0.15))
    assert set(mesh.GetBoundaries()) == {"arc", "contact", "top"}, mesh.GetBoundaries()
    if order == 2:
        mesh.Curve(2)
    fes = ngs.VectorH1(mesh, order=order, dirichletx="top", dirichlety="top|contact")
    u, v = fes.TnT()

    def eps(w):
        return ngs.Sym(ngs.Grad(w))

    a = ngs.BilinearForm(fes, symmetric=True)
    a += (2 * MU * ngs.InnerProduct(eps(u), eps(v)) + LAM * ngs.div(u) * ngs.div(v)) * ngs.dx
    a.Assemble()
    gfu = ngs.GridFunction(fes)
    gfu.Set(ngs.CF(TOP_DISPLACEMENT), definedon=mesh.Boundaries("top"))
    r = gfu.vec.CreateVector()
    r.data = -a.mat * gfu.vec
    gfu.vec.data += a.mat.Inverse(fes.FreeDofs(), inverse="sparsecholesky") * r

    e = eps(gfu)
    tr = e[0, 0] + e[1, 1]
    sig = [2 * MU * e[0, 0] + LAM * tr, 2 * MU * e[1, 1] + LAM * tr, LAM * tr, 2 * MU * e[0, 1]]
    # continuous nodal stress: NGSolve's Set (local projection + averaging) into H1 of the same order
    hs = ngs.H1(mesh, order=order)
    sgf = []
    for s in sig:
        g = ngs.GridFunction(hs)
        g.Set(s)
        sgf.append(g)
    coefs = [
        ngs.CF((gfu[0], gfu[1], 0.0)),
        ngs.CF(tuple(sgf)),
        ngs.CF(tuple(sig)),
    ]
    names = ["displacement", "stress", "stress_elementwise"]
    out = ngs.VTKOutput(ma=mesh, coefs=coefs, names=names, filename=os.path.join(outdir, basename),
                        subdivision=0, order=order)
    out.Do()
    after = set(os.listdir(outdir))
    return sorted(os.path.join(outdir, f) for f in after - before)


# ---------------------------------------------------------------------------
# merging coincident points (own implementation, numpy only)
# ---------------------------------------------------------------------------
def merge_coincident(points, tol):
    """Group points closer than `tol` (max-norm).  Returns (rep, inverse):
    rep[i] = index (into `points`) of the first point of group i, groups
    numbered by first appearance; inverse[k] = group of point k.

    Sort along x, sweep, and compare with the candidates whose x lies within
    tol; then verify that groups are well separated (no chaining)."""
    pts = np.asarray(points, dtype=np.float64)
    n = len(pts)
    order = np.lexsort((pts[:, 2], pts[:, 1], pts[:, 0]))
    xs = pts[order, 0]
    group = np.full(n, -1, np.int64)
    ngroups = 0
    for a in range(n):
        ia = order[a]
        if group[ia] >= 0:
            continue
        group[ia] = ngroups
        b = a + 1
        while b < n and xs[b] - xs[a] <= tol:
            ib = order[b]
            if group[ib] < 0 and np.max(np.abs(pts[ib] - pts[ia])) <= tol:
                group[ib] = ngroups
            b += 1
        ngroups += 1
    # renumber groups by first appearance in the original order
    first = np.full(ngroups, n, np.int64)
    np.minimum.at(first, group, np.arange(n))
    rank = np.argsort(first, kind="stable")
    newid = np.empty(ngroups, np.int64)
    newid[rank] = np.arange(ngroups)
    inverse = newid[group]
    rep = first[rank]
    # separation check: representatives pairwise farther than 1000*tol
    rp = pts[rep]
    if len(rp) < 20000:
        d = np.max(np.abs(rp[:, None, :] - rp[None, :, :]), axis=2)
        np.fill_diagonal(d, np.inf)
        if d.min() <= 1000 * tol:
            raise ValueError(f"merge_coincident: ambiguous points (min separation {d.min():g})")
    return rep, inverse


def merge_grid(g, tol=1e-9):
    """Conforming counterpart of an exploded grid.  Point data at a merged point
    is the mean of its copies.  Returns (merged grid, max_jump dict)."""
    rep, inv = merge_coincident(g["points"], tol)
    ng = len(rep)
    counts = np.bincount(inv, minlength=ng).astype(np.float64)
    merged_pd = {}
    jumps = {}
    for name, a in g["point_data"].items():
        a = np.asarray(a, dtype=np.float64)
        s = np.zeros((ng, a.shape[1]))
        np.add.at(s, inv, a)
        mean = s / counts[:, None]
        lo = np.full((ng, a.shape[1]), np.inf)
        hi = np.full((ng, a.shape[1]), -np.inf)
        np.minimum.at(lo, inv, a)
        np.maximum.at(hi, inv, a)
        merged_pd[name] = mean
        jumps[name] = (hi - lo).max(axis=0).tolist()
    out = {
        "points": np.asarray(g["points"], dtype=np.float64)[rep],
        "types": g["types"].copy(),
        "offsets": g["offsets"].copy(),
        "conn": inv[g["conn"]],
        "point_data": merged_pd,
        "cell_data": {k: v.copy() for k, v in g["cell_data"].items()},
        "component_names": dict(g["component_names"]),
        "pieces": [(ng, len(g["types"]))],
    }
    return out, jumps, int(ng)


# ---------------------------------------------------------------------------
# writers
# ---------------------------------------------------------------------------
@contextlib.contextmanager
def quiet_meshio():
    """meshio prints its warnings ('VTU ASCII files are only meant for
    debugging', ...) through rich on stderr; keep them out of our output."""
    with warnings.catch_warnings(), contextlib.redirect_stderr(io.StringIO()):
        warnings.simplefilter("ignore")
        yield


def to_meshio(g):
    import meshio

    blocks = blocks_of(g)
    cells = [(meshio._vtk_common.vtk_to_meshio_type[ty], c) for ty, c in blocks]
    cell_data = {}
    for name, a in g["cell_data"].items():
        parts = []
        k = 0
        for _, c in blocks:
            part = a[k:k + len(c)]
            parts.append(part[:, 0] if part.shape[1] == 1 else part)
            k += len(c)
        cell_data[name] = parts
    point_data = {n: (a[:, 0] if a.shape[1] == 1 else a) for n, a in g["point_data"].items()}
    return meshio.Mesh(g["points"], cells, point_data=point_data, cell_data=cell_data)


def write_meshio(g, path, binary=True, compression=None, header_type=None):
    import meshio

    with quiet_meshio():
        meshio.vtu.write(path, to_meshio(g), binary=binary, compression=compression, header_type=header_type)


def _vtk_array(a, name, comp_names=None):
    from vtkmodules.util import numpy_support as ns

    arr = ns.numpy_to_vtk(np.ascontiguousarray(a), deep=True)
    arr.SetName(name)
    if comp_names:
        for i, cn in enumerate(comp_names):
            arr.SetComponentName(i, cn)
    return arr


def to_vtk(g, float32=False, int32=False):
    """vtkUnstructuredGrid from a grid (numpy -> vtk via numpy_support).
    float32: points and float arrays as Float32; int32: the vtkCellArray uses
    32-bit storage (offsets and connectivity are then written as Int32)."""
    import vtk
    from vtkmodules.util import numpy_support as ns

    fdt = np.float32 if float32 else np.float64
    ug = vtk.vtkUnstructuredGrid()
    pts = vtk.vtkPoints()
    pts.SetData(ns.numpy_to_vtk(np.ascontiguousarray(g["points"], dtype=fdt), deep=True))
    ug.SetPoints(pts)
    ca = vtk.vtkCellArray()
    if int32:
        off = vtk.vtkTypeInt32Array()
        off.DeepCopy(ns.numpy_to_vtk(g["offsets"].astype(np.int32), deep=True))
        con = vtk.vtkTypeInt32Array()
        con.DeepCopy(ns.numpy_to_vtk(g["conn"].astype(np.int32), deep=True))
        ca.SetData(off, con)
        assert not ca.IsStorage64Bit()
    else:
        ca.SetData(ns.numpy_to_vtkIdTypeArray(g["offsets"].astype(np.int64), deep=True),
                   ns.numpy_to_vtkIdTypeArray(g["conn"].astype(np.int64), deep=True))
    types = ns.numpy_to_vtk(g["types"].astype(np.uint8), deep=True, array_type=vtk.VTK_UNSIGNED_CHAR)
    ug.SetCells(types, ca)
    cn = g["component_names"]
    for name, a in g["point_data"].items():
        a = a.astype(fdt) if a.dtype.kind == "f" else a
        ug.GetPointData().AddArray(_vtk_array(a, name, cn.get(name)))
    for name, a in g["cell_data"].items():
        a = a.astype(fdt) if a.dtype.kind == "f" else a
        ug.GetCellData().AddArray(_vtk_array(a, name, cn.get(name)))
    return ug


def _piece_source(g, npieces):
    """A VTK algorithm that serves piece i of `npieces` on request: piece i =
    the contiguous cell range [i*M/n, (i+1)*M/n) of `g` with the points those
    cells use (in increasing original index).  Lets the stock serial
    vtkXMLUnstructuredGridWriter stream a file with `npieces` <Piece>s."""
    import vtk
    from vtkmodules.util.vtkAlgorithm import VTKPythonAlgorithmBase

    M = len(g["types"])
    bounds = [(i * M) // npieces for i in range(npieces + 1)]
    subgrids = []
    for i in range(npieces):
        c0, c1 = bounds[i], bounds[i + 1]
        o0, o1 = g["offsets"][c0], g["offsets"][c1]
        conn = g["conn"][o0:o1]
        used = np.unique(conn)
        remap = np.full(len(g["points"]), -1, np.int64)
        remap[used] = np.arange(len(used))
        sub = {
            "points": g["points"][used],
            "types": g["types"][c0:c1],
            "offsets": g["offsets"][c0:c1 + 1] - o0,
            "conn": remap[conn],
            "point_data": {k: v[used] for k, v in g["point_data"].items()},
            "cell_data": {k: v[c0:c1] for k, v in g["cell_data"].items()},
            "component_names": g["component_names"],
        }
        subgrids.append(to_vtk(sub))

    class PieceSource(VTKPythonAlgorithmBase):
        def __init__(self):
            VTKPythonAlgorithmBase.__init__(self, nInputPorts=0, nOutputPorts=1,
                                            outputType="vtkUnstructuredGrid")
            self.served = []

        def RequestInformation(self, request, inInfo, outInfo):
            outInfo.GetInformationObject(0).Set(vtk.vtkAlgorithm.CAN_HANDLE_PIECE_REQUEST(), 1)
            return 1

        def RequestData(self, request, inInfo, outInfo):
            info = outInfo.GetInformationObject(0)
            sddp = vtk.vtkStreamingDemandDrivenPipeline
            piece = info.Get(sddp.UPDATE_PIECE_NUMBER())
            n = info.Get(sddp.UPDATE_NUMBER_OF_PIECES())
            assert n == npieces, (n, npieces)
            self.served.append(piece)
            out = vtk.vtkUnstructuredGrid.GetData(outInfo)
            out.ShallowCopy(subgrids[piece])
            return 1

    return PieceSource(), [(s.GetNumberOfPoints(), s.GetNumberOfCells()) for s in subgrids]


VTK_DEFAULTS = dict(mode="appended", encode=False, compressor="none", byte_order="little",
                    header="UInt64", idtype="Int64", pieces=1, float32=False, level=None)


def write_vtk(g, path, **opts):
    """vtkXMLUnstructuredGridWriter with explicit settings (every option is set,
    none is left to the VTK default)."""
    import vtk

    o = dict(VTK_DEFAULTS)
    o.update(opts)
    w = vtk.vtkXMLUnstructuredGridWriter()
    src = None
    if o["pieces"] > 1:
        src, _ = _piece_source(g, o["pieces"])
        w.SetInputConnection(src.GetOutputPort())
    else:
        w.SetInputData(to_vtk(g, float32=o["float32"], int32=o["idtype"] == "Int32"))
    w.SetFileName(str(path))
    {"appended": w.SetDataModeToAppended, "binary": w.SetDataModeToBinary,
     "ascii": w.SetDataModeToAscii}[o["mode"]]()
    w.SetEncodeAppendedData(bool(o["encode"]))
    {"none": w.SetCompressorTypeToNone, "zlib": w.SetCompressorTypeToZLib,
     "lz4": w.SetCompressorTypeToLZ4, "lzma": w.SetCompressorTypeToLZMA}[o["compressor"]]()
    if o["level"] is not None:
        w.SetCompressionLevel(o["level"])
    {"little": w.SetByteOrderToLittleEndian, "big": w.SetByteOrderToBigEndian}[o["byte_order"]]()
    {"UInt32": w.SetHeaderTypeToUInt32, "UInt64": w.SetHeaderTypeToUInt64}[o["header"]]()
    {"Int32": w.SetIdTypeToInt32, "Int64": w.SetIdTypeToInt64}[o["idtype"]]()
    w.SetNumberOfPieces(o["pieces"])
    if o["pieces"] > 1:
        w.SetWritePiece(-1)
    if w.Write() != 1:
        raise RuntimeError(f"vtkXMLUnstructuredGridWriter failed on {path}")
    if src is not None and sorted(src.served) != list(range(o["pieces"])):
        raise RuntimeError(f"piece source served {src.served}")
    if len(xml_pieces(path)) != o["pieces"]:
        raise RuntimeError(f"{path}: {len(xml_pieces(path))} <Piece> elements, wanted {o['pieces']}")


# ---------------------------------------------------------------------------
# readers -> normalised grid
# ---------------------------------------------------------------------------
def read_vtk(path):
    """Read with vtkXMLUnstructuredGridReader (all pieces, appended by VTK)."""
    import vtk
    from vtkmodules.util import numpy_support as ns

    if not os.path.isfile(path):
        raise FileNotFoundError(path)
    r = vtk.vtkXMLUnstructuredGridReader()
    r.SetFileName(str(path))
    errs = _ErrorCatcher()
    r.Update()
    if errs.errors():
        raise RuntimeError("vtk reader: " + " | ".join(errs.errors()[:2]))
    ug = r.GetOutput()
    npieces = r.GetNumberOfPieces()
    if ug.GetPoints() is None:
        raise RuntimeError("vtk reader: no points")
    points = ns.vtk_to_numpy(ug.GetPoints().GetData()).copy()
    cells = ug.GetCells()
    offsets = ns.vtk_to_numpy(cells.GetOffsetsArray()).astype(np.int64)
    conn = ns.vtk_to_numpy(cells.GetConnectivityArray()).astype(np.int64)
    types = ns.vtk_to_numpy(ug.GetCellTypesArray()).astype(np.int64) if ug.GetNumberOfCells() else np.zeros(0, np.int64)
    g = {"points": points, "types": types, "offsets": offsets, "conn": conn,
         "point_data": {}, "cell_data": {}, "component_names": {}, "npieces_reported": npieces}
    for kind, data in (("point_data", ug.GetPointData()), ("cell_data", ug.GetCellData())):
        for i in range(data.GetNumberOfArrays()):
            arr = data.GetAbstractArray(i)
            name = arr.GetName()
            a = ns.vtk_to_numpy(arr).copy()
            g[kind][name] = _2d(a)
            nc = arr.GetNumberOfComponents()
            names = [arr.GetComponentName(c) for c in range(nc)]
            g["component_names"][name] = names if any(n is not None for n in names) else None
    g["pieces"] = xml_pieces(path)
    return g


class _ErrorCatcher:
    """Routes VTK's error/warning text into a string (instead of stderr) for
    the duration of one read."""

    def __init__(self):
        import vtk

        vtk.vtkLogger.SetStderrVerbosity(vtk.vtkLogger.VERBOSITY_OFF)
        self.window = vtk.vtkStringOutputWindow()
        vtk.vtkOutputWindow.SetInstance(self.window)

    def errors(self):
        out = []
        for block in self.window.GetOutput().split("ERROR:")[1:]:
            lines = [ln.strip() for ln in block.strip().splitlines() if ln.strip()]
            if len(lines) > 1:
                out.append(lines[1].split("): ", 1)[-1])
        return out


def read_meshio(path):
    """Read with meshio.vtu.read; cells flattened back into file order (meshio
    keeps consecutive runs of one type as one block, in order)."""
    import meshio

    with quiet_meshio():
        m = meshio.vtu.read(path)
    types, conns, sizes = [], [], []
    for b in m.cells:
        ty = meshio._vtk_common.meshio_to_vtk_type[b.type]
        d = np.asarray(b.data)
        order = meshio._vtk_common.meshio_to_vtk_order(b.type) if hasattr(meshio._vtk_common, "meshio_to_vtk_order") else None
        if order is not None:
            d = d[:, order]
        types.append(np.full(len(d), ty, np.int64))
        conns.append(d.ravel().astype(np.int64))
        sizes.append(np.full(len(d), d.shape[1], np.int64))
    types = np.concatenate(types) if types else np.zeros(0, np.int64)
    conn = np.concatenate(conns) if conns else np.zeros(0, np.int64)
    sizes = np.concatenate(sizes) if sizes else np.zeros(0, np.int64)
    g = {"points": np.asarray(m.points), "types": types,
         "offsets": np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64), "conn": conn,
         "point_data": {k: _2d(v) for k, v in m.point_data.items()},
         "cell_data": {k: _2d(np.concatenate([np.asarray(p) for p in v])) for k, v in m.cell_data.items()},
         "component_names": {}, "pieces": xml_pieces(path)}
    return g


def xml_pieces(path):
    """(NumberOfPoints, NumberOfCells) of every <Piece> tag, scanned from the
    XML head of the file (stops at <AppendedData>)."""
    import re

    head = b""
    with open(path, "rb") as f:
        while True:
            chunk = f.read(1 << 16)
            if not chunk:
                break
            head += chunk
            i = head.find(b"<AppendedData")
            if i >= 0:
                head = head[:i]
                break
    out = []
    for m in re.finditer(rb"<Piece\b([^>]*)>", head):
        attrs = dict(re.findall(rb'(\w+)="([^"]*)"', m.group(1)))
        out.append((int(attrs[b"NumberOfPoints"]), int(attrs[b"NumberOfCells"])))
    return out


def xml_root_attrs(path):
    import re

    with open(path, "rb") as f:
        head = f.read(4096)
    m = re.search(rb"<VTKFile\b([^>]*)>", head)
    return {k.decode(): v.decode() for k, v in re.findall(rb'(\w+)="([^"]*)"', m.group(1))}


def xml_data_arrays(path):
    """Attributes of every <DataArray> tag (from the XML head)."""
    import re

    with open(path, "rb") as f:
        data = f.read()
    i = data.find(b"<AppendedData")
    if i >= 0:
        data = data[:i]
    out = []
    for m in re.finditer(rb"<DataArray\b([^>]*)>", data):
        out.append({k.decode(): v.decode() for k, v in re.findall(rb'(\w+)="([^"]*)"', m.group(1))})
    return out


# ---------------------------------------------------------------------------
# comparison
# ---------------------------------------------------------------------------
def unpiece(g, ref):
    """Map a multi-piece grid (pieces concatenated, interface points repeated)
    onto the point numbering of `ref` by coordinates (exact match required).
    Returns a grid with ref's point set, or raises."""
    pts = np.asarray(g["points"], dtype=np.float64)
    rpts = np.asarray(ref["points"], dtype=np.float64)
    keyr = {tuple(p): i for i, p in enumerate(rpts.tolist())}
    if len(keyr) != len(rpts):
        raise ValueError("reference has coincident points")
    idx = np.array([keyr.get(tuple(p), -1) for p in pts.tolist()])
    if np.any(idx < 0):
        raise ValueError(f"{int(np.sum(idx < 0))} points of the file are not points of the reference")
    n = len(rpts)
    out_pd = {}
    for name, a in g["point_data"].items():
        b = np.full((n, a.shape[1]), np.nan, dtype=a.dtype if a.dtype.kind == "f" else np.float64)
        b[idx] = a
        # repeated copies must agree exactly
        if not np.array_equal(b[idx], a):
            raise ValueError(f"point array '{name}' differs between copies of one point")
        out_pd[name] = b
    seen = np.zeros(n, bool)
    seen[idx] = True
    if not seen.all():
        raise ValueError(f"{int((~seen).sum())} reference points missing from the file")
    out = dict(g)
    out["points"] = rpts.astype(g["points"].dtype)
    out["conn"] = idx[g["conn"]]
    out["point_data"] = out_pd
    return out


def compare_grids(got, ref, rtol=0.0, float32_exact=True, allow_extra=True):
    """Compare `got` against `ref`.  Returns a list of problems (empty = equal).

    Float64 data: |got - ref| <= rtol * max|ref| per array (rtol=0: bitwise
    equal values).  Float32 data in `got` with float32_exact: must equal
    ref rounded to float32 (correct rounding), unless rtol > 0 is larger.
    Integer data and topology: exact."""
    probs = []

    def cmp_float(what, a, b):
        a = np.asarray(a)
        b = np.asarray(b, dtype=np.float64)
        if a.shape != b.shape:
            probs.append(f"{what}: shape {a.shape} != {b.shape}")
            return
        if a.dtype.kind not in "f":
            probs.append(f"{what}: type {a.dtype} is not floating point")
            return
        if a.dtype == np.float32 and float32_exact and rtol == 0.0:
            b32 = b.astype(np.float32)
            bad = a != b32
            if bad.any():
                probs.append(f"{what}: {int(bad.sum())} Float32 values differ from the correctly rounded reference")
            return
        scale = float(np.max(np.abs(b))) if b.size else 0.0
        diff = np.abs(a.astype(np.float64) - b)
        tol = rtol * scale
        bad = ~(diff <= tol)
        if bad.any():
            probs.append(f"{what}: {int(bad.sum())} values differ, max |diff| = {np.nanmax(diff):.3e} (tolerance {tol:.3e})")

    cmp_float("points", got["points"], ref["points"])
    if not np.array_equal(got["types"], ref["types"]):
        probs.append(f"cell types differ: {_type_count(got['types'])} vs {_type_count(ref['types'])}")
    elif not (np.array_equal(got["offsets"], ref["offsets"]) and np.array_equal(got["conn"], ref["conn"])):
        nbad = sum(1 for (t1, c1), (t2, c2) in zip(iter_cells(got), iter_cells(ref)) if not np.array_equal(c1, c2))
        probs.append(f"connectivity differs in {nbad} cells")
    for kind in ("point_data", "cell_data"):
        for name, b in ref[kind].items():
            if name not in got[kind]:
                probs.append(f"{kind} '{name}' missing")
                continue
            a = got[kind][name]
            if b.dtype.kind in "iu":
                if a.dtype.kind not in "iu":
                    probs.append(f"{kind} '{name}': integer array written as {a.dtype}")
                elif a.shape != b.shape or not np.array_equal(a, b):
                    probs.append(f"{kind} '{name}': integer values differ")
            else:
                cmp_float(f"{kind} '{name}'", a, b)
        extra = sorted(set(got[kind]) - set(ref[kind]))
        if extra and not allow_extra:
            probs.append(f"{kind}: extra arrays {extra}")
    return probs


def _type_count(types):
    u, c = np.unique(types, return_counts=True)
    return {int(a): int(b) for a, b in zip(u, c)}


def summarize(g):
    """Counts and per-component ranges, JSON-ready."""
    out = {
        "num_points": int(len(g["points"])),
        "num_cells": int(len(g["types"])),
        "cells_by_type": {VTK_NAMES.get(k, str(k)) + f" ({k})": v for k, v in _type_count(g["types"]).items()},
        "pieces": [{"points": int(p), "cells": int(c)} for p, c in g.get("pieces", [])],
        "points_type": _vtu_type(g["points"].dtype),
        "points_min": np.asarray(g["points"], dtype=np.float64).min(axis=0).tolist(),
        "points_max": np.asarray(g["points"], dtype=np.float64).max(axis=0).tolist(),
    }
    for kind in ("point_data", "cell_data"):
        d = {}
        for name in sorted(g[kind]):
            a = g[kind][name]
            af = a.astype(np.float64)
            d[name] = {
                "components": int(a.shape[1]),
                "type": _vtu_type(a.dtype),
                "component_names": (g["component_names"] or {}).get(name),
                "min": af.min(axis=0).tolist(),
                "max": af.max(axis=0).tolist(),
                "absmax": float(np.abs(af).max()),
            }
        out[kind] = d
    return out


def _vtu_type(dt):
    dt = np.dtype(dt)
    return {"f": "Float", "i": "Int", "u": "UInt"}[dt.kind] + str(8 * dt.itemsize)
