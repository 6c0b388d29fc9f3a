"""Small in-code meshes for the exact fixtures (deterministic).

rectangle(): [0, Lx] x [0, Ly], nx x ny squares cut into two triangles (alternating diagonals),
interior vertices jittered (numpy default_rng(seed), PCG64), straight cells (P2 mid nodes at edge
midpoints).  Line cells carry tags: bottom 1, right 2, top 3, left 4.

quarter_annulus(): r in [r0, r1], theta in [0, pi/2], isoparametric P2 image of a polar grid:
every node (vertex or mid node) is the polar map of the (r, theta) grid point, so the arcs and
the diagonals are curved, radial edges straight.  Tags: y = 0 side 1, outer arc 2, x = 0 side 3,
inner arc 4.

Every triangle is counter-clockwise unless `flip` lists cells to write clockwise.
"""
import math

import numpy as np


def _p2_from_vertices(pts, tris, bnd, midpoint):
    pts = [tuple(p) for p in pts]
    mids = {}

    def mid(p, q):
        k = (min(p, q), max(p, q))
        if k not in mids:
            mids[k] = len(pts)
            pts.append(tuple(midpoint(p, q)))
        return mids[k]

    cells = np.array([[a, b, c, mid(a, b), mid(b, c), mid(c, a)] for a, b, c in tris], dtype=np.int64)
    lines = np.array([[p, q, mid(p, q)] for p, q, _ in bnd], dtype=np.int64)
    return np.array(pts, dtype=float), cells, lines


def rectangle(nx, ny, degree, Lx=2.0, Ly=1.0, jitter=0.25, seed=1, flip=()):
    rng = np.random.default_rng(seed)
    xs = np.linspace(0.0, Lx, nx + 1)
    ys = np.linspace(0.0, Ly, ny + 1)
    X, Y = np.meshgrid(xs, ys)
    pts = np.stack([X.ravel(), Y.ravel()], axis=1)
    vid = lambda i, j: j * (nx + 1) + i
    hx, hy = Lx / nx, Ly / ny
    for j in range(1, ny):
        for i in range(1, nx):
            pts[vid(i, j)] += jitter * rng.uniform(-1.0, 1.0, 2) * np.array([hx, hy])
    tris = []
    for j in range(ny):
        for i in range(nx):
            a, b, c, d = vid(i, j), vid(i + 1, j), vid(i, j + 1), vid(i + 1, j + 1)
            if (i + j) % 2:
                tris += [(a, b, d), (a, d, c)]
            else:
                tris += [(a, b, c), (b, d, c)]
    bnd = []
    for i in range(nx):
        bnd.append((vid(i, 0), vid(i + 1, 0), 1))
    for j in range(ny):
        bnd.append((vid(nx, j), vid(nx, j + 1), 2))
    for i in range(nx):
        bnd.append((vid(nx - i, ny), vid(nx - i - 1, ny), 3))
    for j in range(ny):
        bnd.append((vid(0, ny - j), vid(0, ny - j - 1), 4))
    tags = np.array([t for _, _, t in bnd], dtype=np.int32)
    if degree == 2:
        P = pts
        P, cells, lines = _p2_from_vertices(pts, tris, bnd, lambda p, q: 0.5 * (P[p] + P[q]))
        pts = P
    else:
        cells = np.array(tris, dtype=np.int64)
        lines = np.array([[p, q] for p, q, _ in bnd], dtype=np.int64)
    cells = _flip(cells, flip)
    return pts, cells, lines, tags


def _flip(cells, flip):
    cells = cells.copy()
    for k in flip:
        if cells.shape[1] == 6:
            cells[k] = cells[k][[0, 2, 1, 5, 4, 3]]
        else:
            cells[k] = cells[k][[0, 2, 1]]
    return cells


def quarter_annulus(nr, nt, r0=1.0, r1=2.0):
    """P2 isoparametric quarter annulus; returns pts, cells, lines, tags."""
    # polar grid with half steps: index (2i, 2j) vertices, odd indices mid nodes
    R = np.linspace(r0, r1, 2 * nr + 1)
    T = np.linspace(0.0, 0.5 * math.pi, 2 * nt + 1)

    def xy(a, b):
        r, t = R[a], T[b]
        if b == 0:
            return (r, 0.0)
        if b == 2 * nt:
            return (0.0, r)
        return (r * math.cos(t), r * math.sin(t))

    index = {}
    pts = []

    def node(a, b):
        if (a, b) not in index:
            index[(a, b)] = len(pts)
            pts.append(xy(a, b))
        return index[(a, b)]

    # vertices first (so that P1 numbering is a prefix), then mid nodes
    for b in range(0, 2 * nt + 1, 2):
        for a in range(0, 2 * nr + 1, 2):
            node(a, b)
    cells = []
    for j in range(nt):
        for i in range(nr):
            A, B, C, D = (2 * i, 2 * j), (2 * i + 2, 2 * j), (2 * i, 2 * j + 2), (2 * i + 2, 2 * j + 2)
            # (r, theta) is a right-handed frame in the plane: CCW in (r, t) is CCW in (x, y)
            if (i + j) % 2:
                tri = [(A, B, D), (A, D, C)]
            else:
                tri = [(A, B, C), (B, D, C)]
            for p, q, s in tri:
                m = lambda u, v: ((u[0] + v[0]) // 2, (u[1] + v[1]) // 2)
                cells.append([node(*p), node(*q), node(*s), node(*m(p, q)), node(*m(q, s)), node(*m(s, p))])
    lines, tags = [], []
    # y = 0 side (theta = 0), r increasing: tag 1
    for i in range(nr):
        lines.append([node(2 * i, 0), node(2 * i + 2, 0), node(2 * i + 1, 0)]); tags.append(1)
    # outer arc r = r1, theta increasing: tag 2
    for j in range(nt):
        lines.append([node(2 * nr, 2 * j), node(2 * nr, 2 * j + 2), node(2 * nr, 2 * j + 1)]); tags.append(2)
    # x = 0 side (theta = pi/2), r decreasing: tag 3
    for i in range(nr):
        a = 2 * (nr - i)
        lines.append([node(a, 2 * nt), node(a - 2, 2 * nt), node(a - 1, 2 * nt)]); tags.append(3)
    # inner arc r = r0, theta decreasing: tag 4
    for j in range(nt):
        b = 2 * (nt - j)
        lines.append([node(0, b), node(0, b - 2), node(0, b - 1)]); tags.append(4)
    return (np.array(pts, dtype=float), np.array(cells, dtype=np.int64),
            np.array(lines, dtype=np.int64), np.array(tags, dtype=np.int32))
