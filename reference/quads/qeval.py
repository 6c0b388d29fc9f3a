"""Numbers of expected.json computed from a quads-family VTU *as written* (read back with meshio), for
any mix of quad / quad8 / quad9 / triangle / triangle6 cells with line / line3 boundary cells.

QFixture reuses the boundary machinery of reference/hertz/evaluate.py (edges parametrised by s in
[0, 1] through their nodes, forces, active set with exact polynomial roots, penetration, nodal
pressures; definitions in reference/hertz/README.md) and replaces the cell parts: topology of the
boundary from the line cells (oriented by the owning cell), isoparametric cell integrals with Gauss
rules per cell type (qshape.py).
"""
import math

import meshio
import numpy as np

import evaluate  # reference/hertz
import qshape

LOCAL_EDGES = {
    "triangle": [(0, 1), (1, 2), (2, 0)],
    "triangle6": [(0, 1, 3), (1, 2, 4), (2, 0, 5)],
    "quad": [(0, 1), (1, 2), (2, 3), (3, 0)],
    "quad8": [(0, 1, 4), (1, 2, 5), (2, 3, 6), (3, 0, 7)],
    "quad9": [(0, 1, 4), (1, 2, 5), (2, 3, 6), (3, 0, 7)],
}
CELL_2D = tuple(LOCAL_EDGES)
VTK_NAME = {"quad": "VTK_QUAD (9)", "quad8": "VTK_QUADRATIC_QUAD (23)", "quad9": "VTK_BIQUADRATIC_QUAD (28)",
            "triangle": "VTK_TRIANGLE (5)", "triangle6": "VTK_QUADRATIC_TRIANGLE (22)",
            "line": "VTK_LINE (3)", "line3": "VTK_QUADRATIC_EDGE (21)"}


class QFixture(evaluate.Fixture):
    def __init__(self, path, scene):
        self.scene = scene
        m = meshio.read(path)
        self.X = np.asarray(m.points[:, :2], dtype=float)
        self.points_in_file = int(len(self.X))
        self.merge_jump = 0.0
        self.blocks = []
        lines, line_data = [], {}
        for i, cb in enumerate(m.cells):
            if cb.type in CELL_2D:
                self.blocks.append((cb.type, cb.data.astype(np.int64)))
            elif cb.type in ("line", "line3"):
                lines.append(cb.data.astype(np.int64))
                for k, v in m.cell_data.items():
                    line_data.setdefault(k, []).append(np.asarray(v[i]).ravel())
            else:
                raise ValueError(f"{path}: cell type {cb.type}")
        types = {t for t, _ in self.blocks}
        self.quad = any(t in ("quad8", "quad9", "triangle6") for t in types)  # quadratic edges
        assert not (self.quad and ({"quad", "triangle"} & types)), "mixed edge degrees"
        f = scene["fields"]
        self.U = np.asarray(m.point_data[f["displacement"]], dtype=float)[:, :2]
        self.S = evaluate.parse_stress(m.point_data[f["stress"]], f.get("stress_layout"))
        self._lines = np.vstack(lines) if lines else None
        self._line_data = {k: np.concatenate(v) for k, v in line_data.items()}
        self._boundary_q()

    # ---------------------------------------------------------------- topology
    def _boundary_q(self):
        X = self.X
        count = {}
        self.orientation_ok = True
        for typ, conn in self.blocks:
            k = 3 if typ.startswith("triangle") else 4
            P = X[conn[:, :k]]
            area2 = np.sum(P[..., 0] * np.roll(P[..., 1], -1, axis=-1) - np.roll(P[..., 0], -1, axis=-1) * P[..., 1], -1)
            self.orientation_ok &= bool((area2 > 0).all())
            for c, a2 in zip(conn, area2):
                for l in LOCAL_EDGES[typ]:
                    e = tuple(int(c[i]) for i in l)
                    if a2 < 0:
                        e = (e[1], e[0]) + e[2:]
                    count.setdefault(tuple(sorted(e[:2])), []).append(e)
        bnd = {k: v[0] for k, v in count.items() if len(v) == 1}
        assert all(len(v) <= 2 for v in count.values()), "non-manifold"
        # conformity: the two cells sharing an edge agree on its mid node
        for v in count.values():
            if len(v) == 2 and len(v[0]) == 3:
                assert v[0][2] == v[1][2], "non-conforming mid node"
        if self._lines is not None:
            self.has_lines = True
            self.edges = np.array([bnd[tuple(sorted((int(l[0]), int(l[1]))))] for l in self._lines], dtype=np.int64)
            for l, e in zip(self._lines, self.edges):
                assert len(l) == len(e) and (len(l) == 2 or l[2] == e[2])
            self.line_data = self._line_data
            assert len(self._lines) == len(bnd), "line cells must cover the boundary exactly"
        else:
            self.has_lines = False
            self.edges = np.array(sorted(bnd.values()), dtype=np.int64)
            self.line_data = {}
        sc = self.scene
        tag_name = sc.get("boundaries", {}).get("tag_array")
        self.parts = []
        claimed = np.zeros(len(self.edges), dtype=bool)
        for bd in sc["boundary"]:
            if "tag" in bd:
                sel = np.asarray(self.line_data[tag_name]).ravel() == bd["tag"]
            else:
                xm = self.edge_point(0.5)
                sel = np.asarray(evaluate.safe_eval(bd["where"], xm[:, 0], xm[:, 1])) > 0
            assert sel.any(), bd["name"]
            assert not (sel & claimed).any(), "overlapping boundary selections"
            claimed |= sel
            self.parts.append((bd, np.nonzero(sel)[0]))
        self.free = np.nonzero(~claimed)[0]

    # ---------------------------------------------------------------- cell integrals
    def cell_quadrature(self, n=10):
        """Per block: dict(type, xq (M,q,2), Gh (M,q,2,2) grad u_h, uh (M,q,2), sh (M,q,3), dV (M,q), detJ)."""
        out = []
        for typ, conn in self.blocks:
            xi, eta, w = qshape.rule(typ, n)
            N, dN = qshape.shape(typ, xi, eta)
            Xe, Ue, Se = self.X[conn], self.U[conn], self.S[conn]
            xq = np.einsum("qk,mkd->mqd", N, Xe)
            J = np.einsum("qrk,mkd->mqdr", dN, Xe)
            det = J[..., 0, 0] * J[..., 1, 1] - J[..., 0, 1] * J[..., 1, 0]
            Jinv = np.stack([np.stack([J[..., 1, 1], -J[..., 0, 1]], -1),
                             np.stack([-J[..., 1, 0], J[..., 0, 0]], -1)], -2) / det[..., None, None]
            Gh = np.einsum("mqcr,mqrd->mqcd", np.einsum("qrk,mkc->mqcr", dN, Ue), Jinv)
            out.append(dict(type=typ, xq=xq, Gh=Gh, uh=np.einsum("qk,mkc->mqc", N, Ue),
                            sh=np.einsum("qk,mkc->mqc", N, Se), dV=np.abs(det) * w, detJ=det))
        return out

    def energy(self, E, nu, n=10):
        """½(Cε(u_h), ε(u_h)) (None for nu = 0.5), μ‖ε(u_h)‖², area, min det J: n x n Gauss per cell
        (tensor on quads, Duffy on triangles), isoparametric."""
        mu = E / (2 * (1 + nu))
        lam = None if nu == 0.5 else E * nu / ((1 + nu) * (1 - 2 * nu))
        en = me = area = 0.0
        dmin = np.inf
        for b in self.cell_quadrature(n):
            eps = 0.5 * (b["Gh"] + np.swapaxes(b["Gh"], -1, -2))
            tr = eps[..., 0, 0] + eps[..., 1, 1]
            ee = np.einsum("mqij,mqij->mq", eps, eps)
            me += float(mu * np.sum(ee * b["dV"]))
            if lam is not None:
                en += float(np.sum((mu * ee + 0.5 * lam * tr ** 2) * b["dV"]))
            area += float(b["dV"].sum())
            dmin = min(dmin, float(b["detJ"].min()))
        return dict(energy=None if lam is None else en, mu_eps2=me, area=area, min_detJ=dmin)

    def mesh_stats(self):
        X = self.X
        segs = []
        for typ, conn in self.blocks:
            for l in LOCAL_EDGES[typ]:
                segs.append(np.sort(conn[:, [l[0], l[1]]], axis=1))
        e = np.unique(np.vstack(segs), axis=0)
        L = np.linalg.norm(X[e[:, 0]] - X[e[:, 1]], axis=1)
        return dict(points=int(X.shape[0]), cells=int(sum(len(c) for _, c in self.blocks)),
                    cell_types={VTK_NAME[t]: int(len(c)) for t, c in self.blocks},
                    boundary_edges=int(len(self.edges)), line_cells_in_file=self.has_lines,
                    h_min=float(L.min()), h_max=float(L.max()), orientation_ccw=self.orientation_ok)

    def contact_zone_h(self, x_max):
        """longest / shortest vertex-to-vertex length of the contact boundary edges with |x| <= x_max."""
        bd_idx = [idx for bd, idx in self.parts if bd["kind"] == "contact"][0]
        E = self.edges[bd_idx]
        xa, xb = self.X[E[:, 0]], self.X[E[:, 1]]
        sel = (np.abs(xa[:, 0]) <= x_max) & (np.abs(xb[:, 0]) <= x_max)
        L = np.linalg.norm(xb[sel] - xa[sel], axis=1)
        return dict(x_max=x_max, edges=int(sel.sum()), h_max=float(L.max()), h_min=float(L.min()))


def errors(fx, ex, E, nu, n=10):
    """Against the exact solution `ex` (grad, u, sigma4 callables): ‖u − u_h‖_L2, energy norm
    ½(Cε(e), ε(e))^½, ‖σ − σ_file‖_L2 (Frobenius), ‖σ − Cε(u_h)‖_L2, ‖u‖_L2, ‖σ‖_L2."""
    mu = E / (2 * (1 + nu))
    lam = E * nu / ((1 + nu) * (1 - 2 * nu))
    acc = dict(u_L2=0.0, energy=0.0, stress_file_L2=0.0, stress_of_uh_L2=0.0, u_exact_L2=0.0, stress_exact_L2=0.0)
    wts = np.array([1.0, 1.0, 2.0])
    for b in fx.cell_quadrature(n):
        x, y = b["xq"][..., 0], b["xq"][..., 1]
        ue, Ge, s4 = ex.u(x, y), ex.grad(x, y), ex.sigma4(x, y)
        se = np.stack([s4[..., 0], s4[..., 1], s4[..., 3]], -1)
        dV = b["dV"]
        Gh = b["Gh"]
        ee = 0.5 * ((Ge - Gh) + np.swapaxes(Ge - Gh, -1, -2))
        tr = ee[..., 0, 0] + ee[..., 1, 1]
        eh = 0.5 * (Gh + np.swapaxes(Gh, -1, -2))
        trh = eh[..., 0, 0] + eh[..., 1, 1]
        sig_uh = np.stack([2 * mu * eh[..., 0, 0] + lam * trh, 2 * mu * eh[..., 1, 1] + lam * trh, 2 * mu * eh[..., 0, 1]], -1)
        acc["u_L2"] += float(np.sum(((ue - b["uh"]) ** 2).sum(-1) * dV))
        acc["energy"] += float(np.sum((mu * np.einsum("mqij,mqij->mq", ee, ee) + 0.5 * lam * tr ** 2) * dV))
        acc["stress_file_L2"] += float(np.sum(((se - b["sh"]) ** 2 * wts).sum(-1) * dV))
        acc["stress_of_uh_L2"] += float(np.sum(((se - sig_uh) ** 2 * wts).sum(-1) * dV))
        acc["u_exact_L2"] += float(np.sum((ue ** 2).sum(-1) * dV))
        acc["stress_exact_L2"] += float(np.sum((se ** 2 * wts).sum(-1) * dV))
    return {k: math.sqrt(v) for k, v in acc.items()}
