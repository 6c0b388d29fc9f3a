#!/usr/bin/env python3
"""Large P2 (or Q2) benchmark file: a structured mesh of the unit square split
into N quadratic triangles (VTK_QUADRATIC_TRIANGLE), or with `--family q2`
(alias `--quads`) into N biquadratic quadrilaterals (VTK_BIQUADRATIC_QUAD,
9 nodes), with point data `displacement` (3 components, z = 0) and `stress`
(4 components xx,yy,zz,xy), written by meshio with its default encoding
(inline binary, zlib).

    reference/.venv/bin/python reference/encodings/make_bench.py --cells 1000000 --out bench-data/p2_tri_1000000.vtu
    reference/.venv/bin/python reference/encodings/make_bench.py --family q2 --cells 1000000 --out bench-data/q2_quad_1000000.vtu

The fields are smooth closed-form functions (not a FE solution): the file is
for timing readers, not for checking numbers.  Deterministic for a given N.

Grid: nx * ny squares, each cut along its a-c diagonal into (a,b,c) and
(a,c,d).  When N/2 factors as nx * ny with 1 <= nx/ny <= 4 (e.g. N = 10^6:
800 x 625) exactly N triangles; otherwise the smallest nearly square grid
with >= N triangles is cut after the first N triangles and unused nodes are
dropped.

Q2 grid: nx * ny squares, one quadrilateral each, nodes in VTK order: corners
(i,j), (i+1,j), (i+1,j+1), (i,j+1), then the mid-edge nodes of the edges
0-1, 1-2, 2-3, 3-0, then the centre.  Exactly N cells when N factors as
nx * ny with 1 <= nx/ny <= 4 (N = 10^6: 1000 x 1000, 4,004,001 points, about
twice the points per cell of the P2 file), else cut as above.  Points are
numbered like the P2 file's: vertices, horizontal-edge mids, vertical-edge
mids, then centres (where the P2 file has its diagonal mids), each row by row.
The fields are the same functions of (x, y) as for P2.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time

import numpy as np


def grid_size(n, per_square=2):
    if n % per_square == 0:
        half = n // per_square
        for ny in range(int(math.isqrt(half)), 0, -1):
            if half % ny == 0:
                nx = half // ny
                if nx <= 4 * ny:
                    return nx, ny
                break
    nx = math.ceil(math.sqrt(n / per_square))
    ny = math.ceil(n / (per_square * nx))
    return nx, ny


def lattice(nx, ny):
    """Vertices, horizontal-edge mids, vertical-edge mids, square centres (row by row):
    the points and the index functions V, H, Vt, D of each kind."""
    hx, hy = 1.0 / nx, 1.0 / ny
    nv = (nx + 1) * (ny + 1)
    nh = nx * (ny + 1)
    nvt = (nx + 1) * ny
    nd = nx * ny
    jv, iv = np.divmod(np.arange(nv), nx + 1)
    jh, ih = np.divmod(np.arange(nh), nx)
    jt, it = np.divmod(np.arange(nvt), nx + 1)
    jd, idg = np.divmod(np.arange(nd), nx)
    x = np.concatenate([iv * hx, (ih + 0.5) * hx, it * hx, (idg + 0.5) * hx])
    y = np.concatenate([jv * hy, jh * hy, (jt + 0.5) * hy, (jd + 0.5) * hy])
    pts = np.column_stack([x, y, np.zeros_like(x)])
    return pts, jd, idg, (
        lambda i, j: j * (nx + 1) + i,
        lambda i, j: nv + j * nx + i,
        lambda i, j: nv + nh + j * (nx + 1) + i,
        lambda i, j: nv + nh + nvt + j * nx + i,
    )


def fields(pts):
    x, y = pts[:, 0], pts[:, 1]
    s, c = np.sin(math.pi * x), np.cos(math.pi * y)
    disp = np.column_stack([1e-2 * s * c, -1e-2 * (x * x + y), np.zeros_like(x)])
    stress = np.column_stack([100.0 * c * s, -200.0 * (1.0 + x * y), 84.0 * (c * s - 2.0 * (1.0 + x * y)), 30.0 * x * (1.0 - y)])
    return disp, stress


def cut(cells, pts, n):
    """The first n cells, unused points dropped."""
    if len(cells) > n:
        cells = cells[:n]
        used = np.unique(cells)
        remap = np.full(len(pts), -1, np.int64)
        remap[used] = np.arange(len(used))
        cells = remap[cells]
        pts = pts[used]
    return cells, pts


def build_q2(n):
    nx, ny = grid_size(n, per_square=1)
    pts, j, i, (V, H, Vt, C) = lattice(nx, ny)
    quad = np.column_stack([
        V(i, j), V(i + 1, j), V(i + 1, j + 1), V(i, j + 1),
        H(i, j), Vt(i + 1, j), H(i, j + 1), Vt(i, j),
        C(i, j),
    ]).astype(np.int64)
    del i, j
    quad, pts = cut(quad, pts, n)
    disp, stress = fields(pts)
    return pts, quad, disp, stress, (nx, ny)


def build(n):
    nx, ny = grid_size(n)
    hx, hy = 1.0 / nx, 1.0 / ny
    nv = (nx + 1) * (ny + 1)
    nh = nx * (ny + 1)
    nvt = (nx + 1) * ny
    nd = nx * ny
    # points: vertices, horizontal-edge mids, vertical-edge mids, diagonal mids
    jv, iv = np.divmod(np.arange(nv), nx + 1)
    jh, ih = np.divmod(np.arange(nh), nx)
    jt, it = np.divmod(np.arange(nvt), nx + 1)
    jd, idg = np.divmod(np.arange(nd), nx)
    x = np.concatenate([iv * hx, (ih + 0.5) * hx, it * hx, (idg + 0.5) * hx])
    y = np.concatenate([jv * hy, jh * hy, (jt + 0.5) * hy, (jd + 0.5) * hy])
    del jv, iv, jh, ih, jt, it
    pts = np.column_stack([x, y, np.zeros_like(x)])

    def V(i, j):
        return j * (nx + 1) + i

    def H(i, j):
        return nv + j * nx + i

    def Vt(i, j):
        return nv + nh + j * (nx + 1) + i

    def D(i, j):
        return nv + nh + nvt + j * nx + i

    j, i = jd, idg  # one entry per square, row by row
    a, b, c, d = V(i, j), V(i + 1, j), V(i + 1, j + 1), V(i, j + 1)
    t1 = np.column_stack([a, b, c, H(i, j), Vt(i + 1, j), D(i, j)])
    t2 = np.column_stack([a, c, d, D(i, j), H(i, j + 1), Vt(i, j)])
    tri = np.empty((2 * nd, 6), dtype=np.int64)
    tri[0::2] = t1
    tri[1::2] = t2
    del t1, t2, a, b, c, d
    if len(tri) > n:
        tri = tri[:n]
        used = np.unique(tri)
        remap = np.full(len(pts), -1, np.int64)
        remap[used] = np.arange(len(used))
        tri = remap[tri]
        pts = pts[used]
    x, y = pts[:, 0], pts[:, 1]
    s, c = np.sin(math.pi * x), np.cos(math.pi * y)
    disp = np.column_stack([1e-2 * s * c, -1e-2 * (x * x + y), np.zeros_like(x)])
    stress = np.column_stack([100.0 * c * s, -200.0 * (1.0 + x * y), 84.0 * (c * s - 2.0 * (1.0 + x * y)), 30.0 * x * (1.0 - y)])
    return pts, tri, disp, stress, (nx, ny)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cells", type=int, required=True, help="number of cells (P2: N >= 2, Q2: N >= 1)")
    ap.add_argument("--family", default="p2", choices=["p2", "q2"],
                    help="p2: VTK_QUADRATIC_TRIANGLE (default); q2: VTK_BIQUADRATIC_QUAD")
    ap.add_argument("--quads", dest="family", action="store_const", const="q2", help="same as --family q2")
    ap.add_argument("--out", required=True, help="output .vtu path")
    ap.add_argument("--compression", default="zlib", choices=["zlib", "lzma", "none"],
                    help="meshio compression (default zlib, meshio's default)")
    args = ap.parse_args()
    if args.cells < (2 if args.family == "p2" else 1):
        ap.error("--cells must be >= 2 for P2, >= 1 for Q2")
    import meshio

    t0 = time.perf_counter()
    if args.family == "p2":
        pts, cells, disp, stress, (nx, ny) = build(args.cells)
        meshio_type, vtk_name = "triangle6", "VTK_QUADRATIC_TRIANGLE"
    else:
        pts, cells, disp, stress, (nx, ny) = build_q2(args.cells)
        meshio_type, vtk_name = "quad9", "VTK_BIQUADRATIC_QUAD"
    t1 = time.perf_counter()
    mesh = meshio.Mesh(pts, [(meshio_type, cells)], point_data={"displacement": disp, "stress": stress})
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    tmp = args.out + ".tmp"
    comp = None if args.compression == "none" else args.compression
    meshio.vtu.write(tmp, mesh, binary=True, compression=comp)
    os.replace(tmp, args.out)
    t2 = time.perf_counter()
    print(f"{args.out}: {len(cells)} {vtk_name}, {len(pts)} points (grid {nx}x{ny}), "
          f"{os.path.getsize(args.out)} bytes, {args.compression}; build {t1 - t0:.1f} s, write {t2 - t1:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
