"""Quadrilateral (and mixed) meshes for the quads family, with the VTK node orderings.

A mesh is a ``QMesh``: points (N, 2), 2D cell blocks [(meshio type, connectivity)], boundary line
cells (K, 2) or (K, 3) (VTK order: end, end, mid) with an integer tag each.  Every 2D cell is
counter-clockwise.  VTK local node orders (parametric coordinates on [0, 1]^2 for quads, (r, s) with
(0,0), (1,0), (0,1) for triangles):

    quad  (VTK_QUAD 9):              (0,0) (1,0) (1,1) (0,1)
    quad8 (VTK_QUADRATIC_QUAD 23):   corners, then (1/2,0) (1,1/2) (1/2,1) (0,1/2)  (edges 01 12 23 30)
    quad9 (VTK_BIQUADRATIC_QUAD 28): quad8, then (1/2,1/2)
    triangle6 (22):                  (0,0) (1,0) (0,1), then (1/2,0) (1/2,1/2) (0,1/2) (edges 01 12 20)
    line3 (21):                      s = 0, 1, then 1/2

The Hertz half disc is built from the graded netgen triangle mesh of reference/hertz/geometry.py by
splitting every triangle into three quadrilaterals (vertex, edge mid point, centroid, edge mid point):
all-quad, unstructured, graded, no hanging nodes; mid points of arc edges are put on the circle.
"""
import math
from dataclasses import dataclass, field

import numpy as np

CENTRE = np.array([0.0, 1.0])
TAG_CONTACT, TAG_TOP, TAG_FREE = 1, 2, 3          # Hertz (as reference/hertz)
SQ_TAGS = dict(bottom=1, top=2, left=3, right=4)  # unit square (as reference/manufactured)
RECT_TAGS = dict(bottom=1, right=2, top=3, left=4)  # rectangle / annulus (as reference/exact)

VTK_ID = {"quad": 9, "quad8": 23, "quad9": 28, "triangle": 5, "triangle6": 22, "line": 3, "line3": 21}


@dataclass
class QMesh:
    points: np.ndarray
    blocks: list            # [(meshio type, (M, k) int64)]
    lines: np.ndarray
    tags: np.ndarray
    info: dict = field(default_factory=dict)

    @property
    def ncells(self):
        return int(sum(len(c) for _, c in self.blocks))


def project_circle(q, centre=CENTRE, radius=1.0):
    d = q - centre
    return centre + radius * d / np.linalg.norm(d, axis=-1, keepdims=True)


def signed_area(P):
    """P (M, k, 2) polygon corners -> 2 * signed area (shoelace)."""
    x, y = P[..., 0], P[..., 1]
    return np.sum(x * np.roll(y, -1, axis=-1) - np.roll(x, -1, axis=-1) * y, axis=-1)


# ---------------------------------------------------------------------------------------------
# Hertz half disc: split graded triangles into quads
# ---------------------------------------------------------------------------------------------
def hertz_q1(hc, hmax, grading):
    """Q1 mesh (points, quads (M,4), lines (K,2), tags) of the lower half disc."""
    import geometry as G  # reference/hertz
    tm = G.half_disc(hc, hmax=hmax, grading=grading)
    p, t, be, btag = tm.p, tm.t, tm.be, tm.btag
    edges, t2e = G.edge_table(t)
    eid = {(int(a), int(b)): k for k, (a, b) in enumerate(edges)}
    Nv, Ne = len(p), len(edges)
    mid = 0.5 * (p[edges[:, 0]] + p[edges[:, 1]])
    arc = np.array([eid[tuple(sorted((int(a), int(b))))] for (a, b), tg in zip(be, btag) if tg != TAG_TOP])
    mid[arc] = project_circle(mid[arc])
    cen = p[t].mean(axis=1)
    P = np.vstack([p, mid, cen])
    quads = []
    for k, (a, b, c) in enumerate(t):
        m0, m1, m2 = Nv + t2e[k, 0], Nv + t2e[k, 1], Nv + t2e[k, 2]  # ab, bc, ca
        g = Nv + Ne + k
        quads += [[a, m0, g, m2], [b, m1, g, m0], [c, m2, g, m1]]
    quads = np.array(quads, dtype=np.int64)
    lines, tags = [], []
    for (a, b), tg in zip(be, btag):
        m = Nv + eid[tuple(sorted((int(a), int(b))))]
        lines += [[a, m], [m, b]]
        tags += [tg, tg]
    assert (signed_area(P[quads]) > 0).all()
    info = dict(kind="half_disc", construction="netgen graded triangles (reference/hertz/geometry.py half_disc), "
                "each split into 3 quads (vertex, edge mid points, centroid); arc mid points on the circle",
                triangle_mesh=dict(hc=hc, hmax=hmax, grading=grading, triangles=int(len(t))),
                quad_edge_size_near_contact=hc / 2)
    return P, quads, np.array(lines, dtype=np.int64), np.array(tags, dtype=np.int64), info


def hertz_tag(a, b):
    if a[1] == 1.0 and b[1] == 1.0:
        return TAG_TOP
    return TAG_CONTACT if max(a[1], b[1]) <= 0.5 + 1e-12 else TAG_FREE


# ---------------------------------------------------------------------------------------------
# unit square (manufactured)
# ---------------------------------------------------------------------------------------------
def unit_square_q1(n):
    xs = np.linspace(0.0, 1.0, n + 1)
    X, Y = np.meshgrid(xs, xs, indexing="ij")
    p = np.stack([X.ravel(), Y.ravel()], 1)
    idx = lambda i, j: i * (n + 1) + j  # noqa: E731
    q = np.array([[idx(i, j), idx(i + 1, j), idx(i + 1, j + 1), idx(i, j + 1)] for i in range(n) for j in range(n)],
                 dtype=np.int64)
    lines, tags = [], []
    for i in range(n):
        lines.append([idx(i, 0), idx(i + 1, 0)]); tags.append(SQ_TAGS["bottom"])
    for j in range(n):
        lines.append([idx(n, j), idx(n, j + 1)]); tags.append(SQ_TAGS["right"])
    for i in range(n):
        lines.append([idx(n - i, n), idx(n - i - 1, n)]); tags.append(SQ_TAGS["top"])
    for j in range(n):
        lines.append([idx(0, n - j), idx(0, n - j - 1)]); tags.append(SQ_TAGS["left"])
    return p, q, np.array(lines, dtype=np.int64), np.array(tags, dtype=np.int64)


# ---------------------------------------------------------------------------------------------
# straight higher-order cells from a Q1 / P1 vertex mesh (sub-parametric geometry)
# ---------------------------------------------------------------------------------------------
QUAD_EDGES = ((0, 1), (1, 2), (2, 3), (3, 0))
TRI_EDGES = ((0, 1), (1, 2), (2, 0))


def straight_high_order(pts, blocks, lines, order, centre=True, midpoint=None, cellpoint=None):
    """Add mid-edge nodes (at the chord mid points, or midpoint(p, q) -> point) and, for quad9, the
    centre node (mean of the 4 corners = the bilinear image of (1/2, 1/2), or cellpoint(corners ids))."""
    P = [tuple(p) for p in pts]
    mids = {}
    midpoint = midpoint or (lambda a, b: 0.5 * (pts[a] + pts[b]))

    def mid(a, b):
        k = (min(a, b), max(a, b))
        if k not in mids:
            mids[k] = len(P)
            P.append(tuple(midpoint(a, b)))
        return mids[k]

    out = []
    for typ, conn in blocks:
        if typ == "quad":
            rows = []
            for c in conn:
                r = list(c) + [mid(c[i], c[j]) for i, j in QUAD_EDGES]
                if centre:
                    r.append(None)
                rows.append(r)
            out.append(["quad9" if centre else "quad8", rows])
        elif typ == "triangle":
            out.append(["triangle6", [list(c) + [mid(c[i], c[j]) for i, j in TRI_EDGES] for c in conn]])
        else:
            raise ValueError(typ)
    # centre nodes last
    for blk in out:
        if blk[0] == "quad9":
            for r in blk[1]:
                pc = cellpoint(r[:4]) if cellpoint else np.mean([pts[i] for i in r[:4]], axis=0)
                r[8] = len(P)
                P.append(tuple(pc))
        blk[1] = np.array(blk[1], dtype=np.int64)
    L = np.array([[a, b, mid(a, b)] for a, b in lines], dtype=np.int64)
    return np.array(P, dtype=float), [tuple(b) for b in out], L


# ---------------------------------------------------------------------------------------------
# rectangle [0, 2] x [0, 1] (exact cases), jittered like reference/exact/meshes.py
# ---------------------------------------------------------------------------------------------
def rect_vertices(nx, ny, Lx=2.0, Ly=1.0, jitter=0.25, seed=1, tensor=False):
    """(nx+1)(ny+1) vertices; interior vertices moved by U(-jitter, jitter) * (hx, hy)
    (numpy default_rng(seed)).  tensor=True: jitter the grid lines instead (x of each vertical line,
    y of each horizontal line), so every cell is a rectangle (affine), of varying size."""
    rng = np.random.default_rng(seed)
    xs = np.linspace(0.0, Lx, nx + 1)
    ys = np.linspace(0.0, Ly, ny + 1)
    hx, hy = Lx / nx, Ly / ny
    if tensor:
        xs[1:-1] += jitter * hx * rng.uniform(-1.0, 1.0, nx - 1)
        ys[1:-1] += jitter * hy * rng.uniform(-1.0, 1.0, ny - 1)
    X, Y = np.meshgrid(xs, ys)
    pts = np.stack([X.ravel(), Y.ravel()], axis=1)
    vid = lambda i, j: j * (nx + 1) + i  # noqa: E731
    if not tensor:
        for j in range(1, ny):
            for i in range(1, nx):
                pts[vid(i, j)] += jitter * rng.uniform(-1.0, 1.0, 2) * np.array([hx, hy])
    bnd = []
    for i in range(nx):
        bnd.append((vid(i, 0), vid(i + 1, 0), RECT_TAGS["bottom"]))
    for j in range(ny):
        bnd.append((vid(nx, j), vid(nx, j + 1), RECT_TAGS["right"]))
    for i in range(nx):
        bnd.append((vid(nx - i, ny), vid(nx - i - 1, ny), RECT_TAGS["top"]))
    for j in range(ny):
        bnd.append((vid(0, ny - j), vid(0, ny - j - 1), RECT_TAGS["left"]))
    lines = np.array([[a, b] for a, b, _ in bnd], dtype=np.int64)
    tags = np.array([t for _, _, t in bnd], dtype=np.int64)
    return pts, vid, lines, tags


def rectangle(nx, ny, kind, seed=1, tensor=False, tri_from_column=None):
    """kind: quad | quad8 | quad9; tri_from_column=i0: columns i >= i0 are cut into two triangles
    (alternating diagonals), P2 triangles when kind is quad8/quad9 (mixed mesh)."""
    pts, vid, lines, tags = rect_vertices(nx, ny, seed=seed, tensor=tensor)
    quads, tris = [], []
    for j in range(ny):
        for i in range(nx):
            a, b, c, d = vid(i, j), vid(i + 1, j), vid(i + 1, j + 1), vid(i, j + 1)
            if tri_from_column is not None and i >= tri_from_column:
                tris += [(a, b, c), (a, c, d)] if (i + j) % 2 else [(a, b, d), (b, c, d)]
            else:
                quads.append((a, b, c, d))
    blocks = []
    if tris:
        blocks.append(("triangle", np.array(tris, dtype=np.int64)))
    if quads:
        blocks.append(("quad", np.array(quads, dtype=np.int64)))
    info = {"domain": "[0, 2] x [0, 1]", "nx": nx, "ny": ny, "seed": seed,
            "jitter": ("grid lines moved by U(-0.25, 0.25) * h (rectangular cells of varying size: affine)" if tensor else
                       "interior vertices moved by U(-0.25, 0.25) * (h_x, h_y), numpy default_rng(%d)" % seed),
            "straight_cells": True,
            "line_tags": {"1": "bottom y=0 (contact)", "2": "right x=2", "3": "top y=1", "4": "left x=0"}}
    if kind == "quad":
        P, L = pts, lines
    else:
        P, blocks, L = straight_high_order(pts, blocks, lines, 2, centre=(kind == "quad9"))
        if kind == "quad9":
            info["geometry"] = ("sub-parametric: mid-edge nodes at the chord mid points, centre node at the mean "
                                "of the 4 corners (the bilinear image of (1/2, 1/2))")
        else:
            info["geometry"] = "mid-edge nodes at the chord mid points"
    for typ, conn in blocks:
        k = 3 if typ.startswith("triangle") else 4
        assert (signed_area(P[conn[:, :k]]) > 0).all()
    info["cells"] = int(sum(len(c) for _, c in blocks))
    info["points"] = int(len(P))
    info["cell_types"] = {typ: int(len(c)) for typ, c in blocks}
    return QMesh(P, blocks, L, tags, info)


# ---------------------------------------------------------------------------------------------
# quarter annulus, curved Q2 (isoparametric image of a polar grid)
# ---------------------------------------------------------------------------------------------
def quarter_annulus_q2(nr, nt, r0=1.0, r1=2.0):
    """Every node (vertex, mid-edge, centre) is the polar map of its (r, theta) grid point: arcs curved,
    radial edges straight.  Tags: y = 0 side 1, outer arc 2, x = 0 side 3, inner arc 4."""
    R = np.linspace(r0, r1, 2 * nr + 1)
    T = np.linspace(0.0, 0.5 * math.pi, 2 * nt + 1)

    def xy(a, b):
        r, t = R[a], T[b]
        if b == 0:
            return (r, 0.0)
        if b == 2 * nt:
            return (0.0, r)
        return (r * math.cos(t), r * math.sin(t))

    index, pts = {}, []

    def node(a, b):
        if (a, b) not in index:
            index[(a, b)] = len(pts)
            pts.append(xy(a, b))
        return index[(a, b)]

    for b in range(0, 2 * nt + 1, 2):
        for a in range(0, 2 * nr + 1, 2):
            node(a, b)
    cells = []
    for j in range(nt):
        for i in range(nr):
            a, b = 2 * i, 2 * j
            # (r, theta) right-handed: CCW corners (r0,t0) (r1,t0) (r1,t1) (r0,t1)
            cells.append([node(a, b), node(a + 2, b), node(a + 2, b + 2), node(a, b + 2),
                          node(a + 1, b), node(a + 2, b + 1), node(a + 1, b + 2), node(a, b + 1), node(a + 1, b + 1)])
    lines, tags = [], []
    for i in range(nr):
        lines.append([node(2 * i, 0), node(2 * i + 2, 0), node(2 * i + 1, 0)]); tags.append(1)
    for j in range(nt):
        lines.append([node(2 * nr, 2 * j), node(2 * nr, 2 * j + 2), node(2 * nr, 2 * j + 1)]); tags.append(2)
    for i in range(nr):
        a = 2 * (nr - i)
        lines.append([node(a, 2 * nt), node(a - 2, 2 * nt), node(a - 1, 2 * nt)]); tags.append(3)
    for j in range(nt):
        b = 2 * (nt - j)
        lines.append([node(0, b), node(0, b - 2), node(0, b - 1)]); tags.append(4)
    P = np.array(pts, dtype=float)
    C = np.array(cells, dtype=np.int64)
    assert (signed_area(P[C[:, :4]]) > 0).all()
    info = {"domain": "quarter annulus 1 <= r <= 2, 0 <= theta <= pi/2", "nr": nr, "nt": nt,
            "geometry": "isoparametric Q2: every node (incl. mid-edge and centre) is the polar image of its (r, theta) "
                        "grid point; arcs curved, radial edges straight",
            "cells": int(len(C)), "points": int(len(P)),
            "line_tags": {"1": "y=0 (contact)", "2": "outer arc r=2", "3": "x=0", "4": "inner arc r=1"}}
    return QMesh(P, [("quad9", C)], np.array(lines, dtype=np.int64), np.array(tags, dtype=np.int64), info)
