"""Helpers for the self-tests: exact polynomials, in-code meshes, VTU/scene writers."""
import os

import meshio
import numpy as np
from numpy.polynomial import polynomial as P


class Poly2:
    """Polynomial in x, y: c[i, j] is the coefficient of x^i y^j (exact derivatives)."""

    def __init__(self, c):
        self.c = np.atleast_2d(np.asarray(c, dtype=float))

    @staticmethod
    def mono(coef, i, j):
        c = np.zeros((i + 1, j + 1))
        c[i, j] = coef
        return Poly2(c)

    def _pad(self, other):
        a, b = self.c, other.c
        s = (max(a.shape[0], b.shape[0]), max(a.shape[1], b.shape[1]))
        A, B = np.zeros(s), np.zeros(s)
        A[:a.shape[0], :a.shape[1]] = a
        B[:b.shape[0], :b.shape[1]] = b
        return A, B

    def __add__(self, o):
        if not isinstance(o, Poly2):
            o = Poly2([[o]])
        A, B = self._pad(o)
        return Poly2(A + B)

    __radd__ = __add__

    def __sub__(self, o):
        return self + (-1.0) * o

    def __rmul__(self, k):
        return Poly2(k * self.c)

    def __neg__(self):
        return (-1.0) * self

    def dx(self):
        return Poly2(P.polyder(self.c, axis=0)) if self.c.shape[0] > 1 else Poly2([[0.0]])

    def dy(self):
        return Poly2(P.polyder(self.c, axis=1)) if self.c.shape[1] > 1 else Poly2([[0.0]])

    def __call__(self, x, y):
        return P.polyval2d(x, y, self.c)

    def expr(self):
        terms = []
        for (i, j), v in np.ndenumerate(self.c):
            if v != 0:
                terms.append(f"({float(v)!r})*x^{i}*y^{j}")
        return " + ".join(terms) if terms else "0"


def elastic_stress(u1, u2, mu, lam):
    """sigma = C eps(u) as Poly2 (s11, s22, s12); lam may be None (then the trace part is dropped)."""
    e11, e22 = u1.dx(), u2.dy()
    e12 = 0.5 * (u1.dy() + u2.dx())
    tr = e11 + e22
    L = 0.0 if lam is None else lam
    return 2 * mu * e11 + L * tr, 2 * mu * e22 + L * tr, 2 * mu * e12


def rect_mesh(nx, ny, degree, jitter=0.0, flip=0.0, seed=0, bottom_sag=0.0):
    """Unit square, (nx x ny) squares split in two triangles (alternating diagonals).

    jitter: interior vertices moved by up to jitter*h (cells stay straight: P2 mid nodes at edge
    midpoints); flip: fraction of cells written clockwise; bottom_sag: P2 mid nodes of the
    bottom edges moved down by bottom_sag * (edge length) (curved cells).
    Line cells: bottom tag 1, right 2, top 3, left 4.
    Returns points (N,2), cells, lines, line tags, bottom edges [(A, B, M)] left to right.
    """
    rng = np.random.default_rng(seed)
    xs, ys = np.linspace(0, 1, nx + 1), np.linspace(0, 1, ny + 1)
    X, Y = np.meshgrid(xs, ys)
    pts = np.stack([X.ravel(), Y.ravel()], axis=1)
    vid = lambda i, j: j * (nx + 1) + i
    if jitter:
        for j in range(1, ny):
            for i in range(1, nx):
                pts[vid(i, j)] += jitter * rng.uniform(-1, 1, 2) * np.array([1 / nx, 1 / ny])
    tris = []
    for j in range(ny):
        for i in range(nx):
            a, b, c, d = vid(i, j), vid(i + 1, j), vid(i, j + 1), vid(i + 1, j + 1)
            if (i + j) % 2:
                tris += [(a, b, d), (a, d, c)]
            else:
                tris += [(a, b, c), (b, d, c)]
    tris = np.array(tris)
    bnd = []
    for i in range(nx):
        bnd.append((vid(i, 0), vid(i + 1, 0), 1))
        bnd.append((vid(i + 1, ny), vid(i, ny), 3))
    for j in range(ny):
        bnd.append((vid(nx, j), vid(nx, j + 1), 2))
        bnd.append((vid(0, j + 1), vid(0, j), 4))
    pts = list(map(tuple, pts))
    bottom = []
    if degree == 2:
        mids = {}

        def mid(p, q):
            k = (min(p, q), max(p, q))
            if k not in mids:
                m = 0.5 * (np.array(pts[p]) + np.array(pts[q]))
                if pts[p][1] == 0 and pts[q][1] == 0 and bottom_sag:
                    m = m - np.array([0.0, bottom_sag * abs(pts[p][0] - pts[q][0])])
                mids[k] = len(pts)
                pts.append(tuple(m))
            return mids[k]

        cells = np.array([[a, b, c, mid(a, b), mid(b, c), mid(c, a)] for a, b, c in tris])
        lines = np.array([[p, q, mid(p, q)] for p, q, _ in bnd])
        for p, q, t in bnd:
            if t == 1:
                bottom.append((np.array(pts[p]), np.array(pts[q]), np.array(pts[mid(p, q)])))
    else:
        cells = tris
        lines = np.array([[p, q] for p, q, _ in bnd])
    tags = np.array([t for _, _, t in bnd])
    if flip:
        sel = rng.random(len(cells)) < flip
        if degree == 2:
            cells[sel] = cells[sel][:, [0, 2, 1, 5, 4, 3]]
        else:
            cells[sel] = cells[sel][:, [0, 2, 1]]
    return np.array(pts), cells, lines, tags, bottom


LAYOUT_COLS = {
    3: lambda s: [s[0, 0], s[1, 1], s[0, 1]],
    4: lambda s: [s[0, 0], s[1, 1], 0 * s[0, 0], s[0, 1]],
    6: lambda s: [s[0, 0], s[1, 1], 0 * s[0, 0], s[0, 1], 0 * s[0, 0], 0 * s[0, 0]],
    9: lambda s: [s[0, 0], s[0, 1], 0 * s[0, 0], s[1, 0], s[1, 1], 0 * s[0, 0],
                  0 * s[0, 0], 0 * s[0, 0], 0 * s[0, 0]],
}


def write_case(dirname, name, pts, cells, lines, tags, disp, stress, ncomp=4, exploded=False,
               binary=True, compression="zlib"):
    """disp (N,2), stress (N,2,2) at pts; writes dirname/name.vtu, returns the path."""
    degree = 2 if cells.shape[1] == 6 else 1
    S = np.moveaxis(stress, 0, -1)  # (2,2,N)
    cols = np.stack(LAYOUT_COLS[ncomp](S), axis=1)
    if exploded:  # every cell gets its own copies of its points (NGSolve VTKOutput style)
        newpts = pts[cells.ravel()]
        d = disp[cells.ravel()]
        c = cols[cells.ravel()]
        off = len(newpts)
        cells = np.arange(off).reshape(cells.shape)
        pts, disp, cols = (np.vstack([newpts, pts]), np.vstack([d, disp]), np.vstack([c, cols]))
        lines = lines + off
    p3 = np.hstack([pts, np.zeros((len(pts), 1))])
    d3 = np.hstack([disp, np.zeros((len(pts), 1))])
    m = meshio.Mesh(p3, [("triangle6" if degree == 2 else "triangle", cells),
                         ("line3" if degree == 2 else "line", lines)],
                    point_data={"displacement": d3, "stress": cols},
                    cell_data={"boundary_tag": [np.zeros(len(cells), dtype=np.int32),
                                                tags.astype(np.int32)]})
    path = os.path.join(dirname, name + ".vtu")
    meshio.write(path, m, binary=binary, compression=compression if binary else None)
    return path


def write_text(dirname, name, text):
    path = os.path.join(dirname, name)
    with open(path, "w") as fh:
        fh.write(text)
    return path
