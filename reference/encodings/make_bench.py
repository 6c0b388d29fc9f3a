#!/usr/bin/env python3
"""Large P2 benchmark file: a structured mesh of the unit square split into
N quadratic triangles (VTK_QUADRATIC_TRIANGLE), with point data
`displacement` (3 components, z = 0) and `stress` (4 components xx,yy,zz,xy),
written by meshio with its default encoding (inline binary, zlib).

    reference/.venv/bin/python reference/encodings/make_bench.py --cells 1000000 --out bench-data/p2_tri_1000000.vtu

The fields are smooth closed-form functions (not a FE solution): the file is
for timing readers, not for checking numbers.  Deterministic for a given N.

Grid: nx * ny squares, each cut along its a-c diagonal into (a,b,c) and
(a,c,d).  When N/2 factors as nx * ny with 1 <= nx/ny <= 4 (e.g. N = 10^6:
800 x 625) exactly N triangles; otherwise the smallest nearly square grid
with >= N triangles is cut after the first N triangles and unused nodes are
dropped.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time

import numpy as np


def grid_size(n):
    if n % 2 == 0:
        half = n // 2
        for ny in range(int(math.isqrt(half)), 0, -1):
            if half % ny == 0:
                nx = half // ny
                if nx <= 4 * ny:
                    return nx, ny
                break
    nx = math.ceil(math.sqrt(n / 2))
    ny = math.ceil(n / (2 * nx))
    return nx, ny


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
    ap.add_argument("--cells", type=int, required=True, help="number of P2 triangles (N >= 2)")
    ap.add_argument("--out", required=True, help="output .vtu path")
    ap.add_argument("--compression", default="zlib", choices=["zlib", "lzma", "none"],
                    help="meshio compression (default zlib, meshio's default)")
    args = ap.parse_args()
    if args.cells < 2:
        ap.error("--cells must be >= 2")
    import meshio

    t0 = time.perf_counter()
    pts, tri, disp, stress, (nx, ny) = build(args.cells)
    t1 = time.perf_counter()
    mesh = meshio.Mesh(pts, [("triangle6", tri)], point_data={"displacement": disp, "stress": stress})
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    tmp = args.out + ".tmp"
    comp = None if args.compression == "none" else args.compression
    meshio.vtu.write(tmp, mesh, binary=True, compression=comp)
    os.replace(tmp, args.out)
    t2 = time.perf_counter()
    print(f"{args.out}: {len(tri)} VTK_QUADRATIC_TRIANGLE, {len(pts)} points (grid {nx}x{ny}), "
          f"{os.path.getsize(args.out)} bytes, {args.compression}; build {t1 - t0:.1f} s, write {t2 - t1:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
