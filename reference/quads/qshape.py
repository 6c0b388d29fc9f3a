"""Reference shape functions in VTK node order and quadrature rules (numpy only, independent of
scikit-fem).  Quads on [0, 1]^2, triangles on {r, s >= 0, r + s <= 1}; see qmeshes.py for the orders.

shape(ctype, xi, eta) -> N (q, k), dN (q, 2, k) with dN[:, 0] = d/dxi, dN[:, 1] = d/deta.
"""
import numpy as np

NNODES = {"quad": 4, "quad8": 8, "quad9": 9, "triangle": 3, "triangle6": 6}
PARAM = {
    "quad": [(0, 0), (1, 0), (1, 1), (0, 1)],
    "quad8": [(0, 0), (1, 0), (1, 1), (0, 1), (0.5, 0), (1, 0.5), (0.5, 1), (0, 0.5)],
    "quad9": [(0, 0), (1, 0), (1, 1), (0, 1), (0.5, 0), (1, 0.5), (0.5, 1), (0, 0.5), (0.5, 0.5)],
    "triangle": [(0, 0), (1, 0), (0, 1)],
    "triangle6": [(0, 0), (1, 0), (0, 1), (0.5, 0), (0.5, 0.5), (0, 0.5)],
}


def _lag2(s):
    """1D quadratic Lagrange on nodes 0, 1, 1/2: values and derivatives (q, 3)."""
    L = np.stack([(1 - s) * (1 - 2 * s), s * (2 * s - 1), 4 * s * (1 - s)], -1)
    dL = np.stack([4 * s - 3, 4 * s - 1, 4 - 8 * s], -1)
    return L, dL


# index of the 1D node (0 -> 0, 1 -> 1, 1/2 -> 2) per VTK quad9 node
_Q9 = [(0, 0), (1, 0), (1, 1), (0, 1), (2, 0), (1, 2), (2, 1), (0, 2), (2, 2)]


def shape(ctype, xi, eta):
    xi = np.atleast_1d(np.asarray(xi, float))
    eta = np.atleast_1d(np.asarray(eta, float))
    o, z = np.ones_like(xi), np.zeros_like(xi)
    if ctype == "quad":
        N = np.stack([(1 - xi) * (1 - eta), xi * (1 - eta), xi * eta, (1 - xi) * eta], -1)
        dx = np.stack([-(1 - eta), 1 - eta, eta, -eta], -1)
        dy = np.stack([-(1 - xi), -xi, xi, 1 - xi], -1)
    elif ctype == "quad9":
        Lx, dLx = _lag2(xi)
        Ly, dLy = _lag2(eta)
        N = np.stack([Lx[:, i] * Ly[:, j] for i, j in _Q9], -1)
        dx = np.stack([dLx[:, i] * Ly[:, j] for i, j in _Q9], -1)
        dy = np.stack([Lx[:, i] * dLy[:, j] for i, j in _Q9], -1)
    elif ctype == "quad8":
        x, y = 2 * xi - 1, 2 * eta - 1
        Ns, dxs, dys = [], [], []
        for (a, b) in PARAM["quad8"][:4]:
            xa, ya = 2 * a - 1, 2 * b - 1
            Ns.append(0.25 * (1 + x * xa) * (1 + y * ya) * (x * xa + y * ya - 1))
            dxs.append(0.25 * xa * (1 + y * ya) * (2 * x * xa + y * ya))
            dys.append(0.25 * ya * (1 + x * xa) * (x * xa + 2 * y * ya))
        for (a, b) in PARAM["quad8"][4:]:
            xa, ya = 2 * a - 1, 2 * b - 1
            if xa == 0:
                Ns.append(0.5 * (1 - x * x) * (1 + y * ya))
                dxs.append(-x * (1 + y * ya))
                dys.append(0.5 * ya * (1 - x * x))
            else:
                Ns.append(0.5 * (1 + x * xa) * (1 - y * y))
                dxs.append(0.5 * xa * (1 - y * y))
                dys.append(-y * (1 + x * xa))
        N = np.stack(Ns, -1)
        dx = 2 * np.stack(dxs, -1)
        dy = 2 * np.stack(dys, -1)
    elif ctype == "triangle":
        N = np.stack([1 - xi - eta, xi, eta], -1)
        dx = np.stack([-o, o, z], -1)
        dy = np.stack([-o, z, o], -1)
    elif ctype == "triangle6":
        l0, l1, l2 = 1 - xi - eta, xi, eta
        N = np.stack([l0 * (2 * l0 - 1), l1 * (2 * l1 - 1), l2 * (2 * l2 - 1), 4 * l0 * l1, 4 * l1 * l2, 4 * l2 * l0], -1)
        dx = np.stack([-(4 * l0 - 1), 4 * l1 - 1, z, 4 * (l0 - l1), 4 * eta, -4 * eta], -1)
        dy = np.stack([-(4 * l0 - 1), z, 4 * l2 - 1, -4 * xi, 4 * xi, 4 * (l0 - l2)], -1)
    else:
        raise ValueError(ctype)
    return N, np.stack([dx, dy], 1)


def rule(ctype, n):
    """n x n Gauss (tensor on the square; Duffy-collapsed on the triangle): xi, eta, w."""
    g, w = np.polynomial.legendre.leggauss(n)
    g, w = 0.5 * (g + 1), 0.5 * w
    A, B = np.meshgrid(g, g, indexing="ij")
    WA, WB = np.meshgrid(w, w, indexing="ij")
    if ctype.startswith("quad"):
        return A.ravel(), B.ravel(), (WA * WB).ravel()
    return (A * (1 - B)).ravel(), B.ravel(), (WA * WB * (1 - B)).ravel()


def self_test():
    """Nodality, partition of unity, derivatives against central differences."""
    rng = np.random.default_rng(0)
    err = efd = 0.0
    for ct, pts in PARAM.items():
        P = np.array(pts, float)
        N, _ = shape(ct, P[:, 0], P[:, 1])
        err = max(err, np.abs(N - np.eye(len(P))).max())
        xi, eta = rng.uniform(0.05, 0.45, 20), rng.uniform(0.05, 0.45, 20)
        N, dN = shape(ct, xi, eta)
        err = max(err, np.abs(N.sum(-1) - 1).max(), np.abs(dN.sum(-1)).max())
        h = 1e-6
        fx = (shape(ct, xi + h, eta)[0] - shape(ct, xi - h, eta)[0]) / (2 * h)
        fy = (shape(ct, xi, eta + h)[0] - shape(ct, xi, eta - h)[0]) / (2 * h)
        efd = max(efd, np.abs(fx - dN[:, 0]).max(), np.abs(fy - dN[:, 1]).max())
    assert err < 1e-13 and efd < 1e-7, (err, efd)
    return err, efd
