"""Quantities for expected.json, computed from a fixture VTU *as written to disk* (read back with meshio),
so the numbers belong to exactly the fields in the file (including the rounding of ascii files).

Conventions (docs/design.md §2, §7): n_Ω outward unit normal of the body, traction σn_Ω.  Contact frame
(n, t): with normal = "obstacle" and a plane (point p, unit normal m), n = -m, t = (-n_2, n_1),
g(x) = m·(x - p); with normal = "body", n = n_Ω of the discrete boundary and g = distance from x to
the plane along n.  σ_n = n·(σn_Ω), σ_t = t·(σn_Ω), u_n = n·u, u_t = t·u.

Every boundary edge is parametrised by s in [0, 1] through its nodes (P1: straight; P2: quadratic
through the mid node, isoparametric), fields are interpolated with the same shape functions.
"""
import math
import numpy as np

import vtuio

GL_X, GL_W = np.polynomial.legendre.leggauss(8)
GL_X, GL_W = 0.5 * (GL_X + 1), 0.5 * GL_W  # on [0, 1], exact to degree 15


def shape1d(s, quad):
    s = np.asarray(s, dtype=float)
    if quad:  # nodes a (s=0), b (s=1), m (s=1/2)
        N = np.stack([(1 - s) * (1 - 2 * s), s * (2 * s - 1), 4 * s * (1 - s)], axis=-1)
        dN = np.stack([4 * s - 3, 4 * s - 1, 4 - 8 * s], axis=-1)
    else:
        N = np.stack([1 - s, s], axis=-1)
        dN = np.stack([-np.ones_like(s), np.ones_like(s)], axis=-1)
    return N, dN


def parse_stress(arr, layout=None):
    """-> (N, 3) columns xx, yy, xy."""
    arr = np.asarray(arr, dtype=float)
    nc = arr.shape[1]
    if layout is None:
        layout = {3: "xx,yy,xy", 4: "xx,yy,zz,xy", 9: "9"}[nc]
    if layout == "xx,yy,xy":
        return arr[:, [0, 1, 2]]
    if layout == "xx,yy,zz,xy":
        return arr[:, [0, 1, 3]]
    if layout in ("9", "xx,xy,xz,yx,yy,yz,zx,zy,zz"):
        return np.stack([arr[:, 0], arr[:, 4], 0.5 * (arr[:, 1] + arr[:, 3])], axis=1)
    raise ValueError(layout)


def safe_eval(expr, x, y):
    env = {"x": x, "y": y, "abs": np.abs, "sqrt": np.sqrt, "sin": np.sin, "cos": np.cos, "exp": np.exp,
           "log": np.log, "min": np.minimum, "max": np.maximum, "pi": np.pi, "__builtins__": {}}
    return eval(expr.replace("^", "**"), env)


def vec_data(spec, xs):
    """[a, b] with numbers or expression strings -> values (q, 2) at the points xs (q, 2)."""
    cols = []
    for v in spec:
        if isinstance(v, str):
            cols.append(np.broadcast_to(safe_eval(v, xs[:, 0], xs[:, 1]), (len(xs),)).astype(float))
        else:
            cols.append(np.full(len(xs), float(v)))
    return np.stack(cols, axis=1)


class Fixture:
    def __init__(self, path, scene):
        self.scene = scene
        d = vtuio.read(path)
        self.X = d["points"]
        self.points_in_file = d["points_in_file"]
        self.merge_jump = d["merge_jump"]
        self.cells = d["cells"].astype(np.int64)
        self.quad = self.cells.shape[1] == 6
        f = scene["fields"]
        self.U = np.asarray(d["point_data"][f["displacement"]], dtype=float)[:, :2]
        self.S = parse_stress(d["point_data"][f["stress"]], f.get("stress_layout"))
        self._boundary(d)

    # ---------------------------------------------------------------- topology
    def _boundary(self, d):
        c = self.cells
        X = self.X
        a = X[c[:, 1]] - X[c[:, 0]]
        b = X[c[:, 2]] - X[c[:, 0]]
        area2 = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
        self.orientation_ok = bool((area2 > 0).all())
        loc = [(0, 1, 3), (1, 2, 4), (2, 0, 5)] if self.quad else [(0, 1), (1, 2), (2, 0)]
        count = {}
        for k, row in enumerate(c):
            sgn = area2[k] > 0
            for l in loc:
                e = tuple(int(row[i]) for i in l)
                if not sgn:  # keep the body on the left of a -> b
                    e = (e[1], e[0]) + e[2:]
                key = tuple(sorted(e[:2]))
                count.setdefault(key, []).append(e)
        bnd = {k: v[0] for k, v in count.items() if len(v) == 1}
        if d["lines"] is not None:
            lines = d["lines"].astype(np.int64)
            self.has_lines = True
            self.edges = np.array([bnd[tuple(sorted((int(l[0]), int(l[1]))))] for l in lines], dtype=np.int64)
            self.line_data = d["line_data"]
            assert len(lines) == len(bnd), "line cells must cover the boundary exactly"
        else:
            self.has_lines = False
            self.edges = np.array(sorted(bnd.values()), dtype=np.int64)
            self.line_data = {}
        # selection of boundary parts
        sc = self.scene
        tag_name = sc.get("boundaries", {}).get("tag_array")
        self.parts = []
        claimed = np.zeros(len(self.edges), dtype=bool)
        for bd in sc["boundary"]:
            if "tag" in bd:
                sel = np.asarray(self.line_data[tag_name]).ravel() == bd["tag"]
            else:
                xm = self.edge_point(0.5)
                sel = np.asarray(safe_eval(bd["where"], xm[:, 0], xm[:, 1])) > 0
            assert sel.any(), bd["name"]
            assert not (sel & claimed).any(), "overlapping boundary selections"
            claimed |= sel
            self.parts.append((bd, np.nonzero(sel)[0]))
        self.free = np.nonzero(~claimed)[0]

    def edge_point(self, s, idx=None):
        e = self.edges if idx is None else self.edges[idx]
        N, _ = shape1d(s, self.quad)
        return np.einsum("k,ekd->ed", N, self.X[e])

    # ---------------------------------------------------------------- edge kinematics
    def _edge_eval(self, e, s):
        """For one edge (node tuple) and parameters s (q,): points (q,2), dx/ds (q,2), u (q,2), σ (q,3)."""
        N, dN = shape1d(s, self.quad)
        idx = list(e)
        return N @ self.X[idx], dN @ self.X[idx], N @ self.U[idx], N @ self.S[idx]

    def _frame(self, bd, xs, dxs):
        """contact direction n (q,2), tangent t, gap g (q,) for a contact boundary."""
        if "gap" in bd:  # gap given directly; n = n_Ω (body normal)
            nom = np.stack([dxs[:, 1], -dxs[:, 0]], axis=1)
            n = nom / np.linalg.norm(nom, axis=1, keepdims=True)
            g = np.broadcast_to(safe_eval(bd["gap"], xs[:, 0], xs[:, 1]), (len(xs),)).astype(float)
            t = np.stack([-n[:, 1], n[:, 0]], axis=1)
            return n, t, g
        pl = bd["obstacle"]["plane"]
        p = np.array(pl["point"], float)
        m = np.array(pl["normal"], float)
        m = m / np.linalg.norm(m)
        if bd.get("normal", "body") == "obstacle":
            n = np.tile(-m, (len(xs), 1))
            g = (xs - p) @ m
        else:
            nom = np.stack([dxs[:, 1], -dxs[:, 0]], axis=1)
            n = nom / np.linalg.norm(nom, axis=1, keepdims=True)
            g = ((xs - p) @ m) / (-(n @ m))
        t = np.stack([-n[:, 1], n[:, 0]], axis=1)
        return n, t, g

    @staticmethod
    def _traction(S, dxs):
        """σ n_Ω |x'(s)| (q,2): the traction times the length element."""
        nom = np.stack([dxs[:, 1], -dxs[:, 0]], axis=1)  # outward, length |x'|
        return np.stack([S[:, 0] * nom[:, 0] + S[:, 2] * nom[:, 1], S[:, 2] * nom[:, 0] + S[:, 1] * nom[:, 1]], axis=1)

    def _length(self, e, s0, s1):
        s = s0 + (s1 - s0) * GL_X
        _, dxs, _, _ = self._edge_eval(e, s)
        return float((s1 - s0) * (GL_W @ np.linalg.norm(dxs, axis=1)))

    # ---------------------------------------------------------------- quantities
    def force(self, idx):
        F = np.zeros(2)
        for k in idx:
            xs, dxs, us, Ss = self._edge_eval(self.edges[k], GL_X)
            F += GL_W @ self._traction(Ss, dxs)
        return F

    def boundary_max(self, idx, fn):
        """max over (edge, node) pairs of fn(points, dx/ds, u, σ) at the edge's nodes."""
        sn = np.array([0.0, 1.0, 0.5]) if self.quad else np.array([0.0, 1.0])
        best = 0.0
        for k in idx:
            xs, dxs, us, Ss = self._edge_eval(self.edges[k], sn)
            best = max(best, float(np.max(fn(xs, dxs, us, Ss))))
        return best

    def gap_poly_roots(self, e, bd, delta):
        """sub-intervals of [0,1] where u_n - g >= -delta, and max of u_n - g on the edge."""
        if "gap" in bd:
            return self._gap_general(e, bd, delta)
        straight = (not self.quad) or bd.get("normal", "body") == "obstacle"
        if not straight:  # a P2 edge whose mid node lies on the chord has a constant normal
            xa, xb, xm = self.X[e[0]], self.X[e[1]], self.X[e[2]]
            d, q = xb - xa, xm - 0.5 * (xa + xb)
            straight = abs(d[0] * q[1] - d[1] * q[0]) <= 1e-12 * (d @ d)
        s = np.linspace(0.0, 1.0, 5)
        xs, dxs, us, _ = self._edge_eval(e, s)
        n, t, g = self._frame(bd, xs, dxs)
        f = np.einsum("qd,qd->q", n, us) - g
        if not straight:
            raise NotImplementedError("curved edges with normal = body")
        deg = 2 if self.quad else 1
        coef = np.polynomial.polynomial.polyfit(s, f, deg)
        fmax = max(f[0], f[-1])
        if deg == 2 and coef[2] < 0:
            sv = -coef[1] / (2 * coef[2])
            if 0 < sv < 1:
                fmax = max(fmax, np.polynomial.polynomial.polyval(sv, coef))
        c2 = coef.copy()
        c2[0] += delta
        r = np.polynomial.polynomial.polyroots(c2) if np.any(c2[1:] != 0) else np.array([])
        r = np.sort([float(z.real) for z in np.atleast_1d(r) if abs(z.imag) < 1e-14 and 0 < z.real < 1])
        br = np.concatenate([[0.0], r, [1.0]])
        ivs = []
        for a, b in zip(br[:-1], br[1:]):
            if b > a and np.polynomial.polynomial.polyval(0.5 * (a + b), c2) >= 0:
                ivs.append((a, b))
        return ivs, float(fmax)

    def _gap_general(self, e, bd, delta, nsamp=129):
        """Non-polynomial gap (expression): sign changes on a uniform sampling of s refined by brentq;
        maximum from the samples refined by a bounded scalar search."""
        from scipy.optimize import brentq, minimize_scalar

        def f(s):
            s = np.atleast_1d(np.asarray(s, float))
            xs, dxs, us, _ = self._edge_eval(e, s)
            n, t, g = self._frame(bd, xs, dxs)
            return np.einsum("qd,qd->q", n, us) - g

        s = np.linspace(0.0, 1.0, nsamp)
        fs = f(s) + delta
        roots = []
        for i in range(nsamp - 1):
            if fs[i] == 0.0:
                roots.append(s[i])
            elif fs[i] * fs[i + 1] < 0:
                roots.append(brentq(lambda z: f(z)[0] + delta, s[i], s[i + 1], xtol=1e-15, rtol=1e-15))
        br = np.unique(np.concatenate([[0.0], roots, [1.0]]))
        ivs = [(a, b) for a, b in zip(br[:-1], br[1:]) if b > a and f(0.5 * (a + b))[0] + delta >= 0]
        i = int(np.argmax(fs))
        lo, hi = s[max(i - 1, 0)], s[min(i + 1, nsamp - 1)]
        res = minimize_scalar(lambda z: -f(z)[0], bounds=(lo, hi), method="bounded", options=dict(xatol=1e-12))
        fmax = max(float(fs[i] - delta), float(-res.fun))
        return ivs, fmax

    def contact_report(self, bd, idx, delta, slip_rel_tol):
        F_fric = float(bd.get("friction", 0.0))
        normal_force = tangential_force = M0 = M1 = M2 = 0.0
        active_len = 0.0
        xr = [np.inf, -np.inf]
        pen_max = 0.0
        total_len = 0.0
        for k in idx:
            e = self.edges[k]
            xs, dxs, us, Ss = self._edge_eval(e, GL_X)
            n, t, g = self._frame(bd, xs, dxs)
            tr = self._traction(Ss, dxs)
            sn = np.einsum("qd,qd->q", n, tr)
            st = np.einsum("qd,qd->q", t, tr)
            normal_force += float(GL_W @ (-sn))
            tangential_force += float(GL_W @ st)
            total_len += float(GL_W @ np.linalg.norm(dxs, axis=1))
            ivs, fmax = self.gap_poly_roots(e, bd, delta)
            pen_max = max(pen_max, fmax)
            for a, b in ivs:
                active_len += self._length(e, a, b)
                sq = a + (b - a) * GL_X
                xq, dxq, _, Sq = self._edge_eval(e, sq)
                nq, _, _ = self._frame(bd, xq, dxq)
                pq = -np.einsum("qd,qd->q", nq, self._traction(Sq, dxq)) * (b - a)
                M0 += float(GL_W @ pq)
                M1 += float(GL_W @ (pq * xq[:, 0]))
                M2 += float(GL_W @ (pq * xq[:, 0] ** 2))
                N, _ = shape1d(np.array([a, b]), self.quad)
                xab = N @ self.X[list(e)]
                xr[0] = min(xr[0], xab[:, 0].min())
                xr[1] = max(xr[1], xab[:, 0].max())
        # node level (each edge with its own normal at its nodes)
        sn_nodes = np.array([0.0, 1.0, 0.5]) if self.quad else np.array([0.0, 1.0])
        nodes = {}
        for k in idx:
            e = self.edges[k]
            xs, dxs, us, Ss = self._edge_eval(e, sn_nodes)
            n, t, g = self._frame(bd, xs, dxs)
            tr = self._traction(Ss, dxs) / np.linalg.norm(dxs, axis=1)[:, None]
            for j, node in enumerate(e):
                rec = nodes.setdefault(int(node), dict(x=float(xs[j, 0]), gapf=[], ut=[], sn=[], st=[]))
                rec["gapf"].append(float(n[j] @ us[j] - g[j]))
                rec["ut"].append(float(t[j] @ us[j]))
                rec["sn"].append(float(n[j] @ tr[j]))
                rec["st"].append(float(t[j] @ tr[j]))
        ids = sorted(nodes, key=lambda i: nodes[i]["x"])
        xn = np.array([nodes[i]["x"] for i in ids])
        gapf = np.array([max(nodes[i]["gapf"]) for i in ids])
        ut = np.array([nodes[i]["ut"][0] for i in ids])
        sn_min = np.array([min(nodes[i]["sn"]) for i in ids])
        sn_max = np.array([max(nodes[i]["sn"]) for i in ids])
        cone = np.array([max(abs(a) - F_fric * abs(b) for a, b in zip(nodes[i]["st"], nodes[i]["sn"])) for i in ids])
        active = gapf >= -delta
        rep = dict(
            normal_force=normal_force,
            tangential_force=tangential_force,
            normal_force_active=M0,
            pressure_centroid_x=M1 / M0 if M0 else None,
            a_moment=2.0 * math.sqrt(M2 / M0) if M0 > 0 and M2 > 0 else None,
            length=total_len,
            active_length=active_len,
            active_x_range=[float(xr[0]), float(xr[1])] if active_len > 0 else None,
            active_half_width=0.5 * float(xr[1] - xr[0]) if active_len > 0 else None,
            penetration_max=max(pen_max, 0.0),
            penetration_max_nodes=max(float(gapf.max()), 0.0),
            tension_max=max(float(sn_max.max()), 0.0),
            pressure_max_nodes=float((-sn_min).max()),
            pressure_max_at_x=float(xn[int(np.argmax(-sn_min))]),
            cone_violation_max=max(float(cone.max()), 0.0),
            active_nodes=int(active.sum()),
            contact_nodes=len(ids),
        )
        if F_fric > 0:
            utmax = float(np.abs(ut[active]).max()) if active.any() else 0.0
            tol = slip_rel_tol * utmax
            cls = np.where(~active, 0, np.where(np.abs(ut) <= tol, 1, 2))  # 0 open, 1 stick, 2 slip
            runs = []
            start = 0
            for i in range(1, len(cls) + 1):
                if i == len(cls) or cls[i] != cls[start]:
                    runs.append((int(cls[start]), float(xn[start]), float(xn[i - 1]), i - start))
                    start = i
            name = {0: "open", 1: "stick", 2: "slip"}
            stick_runs = [r for r in runs if r[0] == 1]
            widest = max(stick_runs, key=lambda r: r[2] - r[1]) if stick_runs else None
            # edge lengths: an edge counts if all its nodes are active; stick if all its nodes stick
            cmap = dict(zip(ids, cls))
            stick_len = slip_len = 0.0
            for k in idx:
                e = self.edges[k]
                c = [cmap[int(v)] for v in e]
                if min(c) == 0:
                    continue
                L = self._length(e, 0.0, 1.0)
                if max(c) == 1:
                    stick_len += L
                else:
                    slip_len += L
            slip_dir = [float(np.sign(np.mean(ut[(cls == 2) & (xn < 0)]))) if ((cls == 2) & (xn < 0)).any() else 0.0,
                        float(np.sign(np.mean(ut[(cls == 2) & (xn > 0)]))) if ((cls == 2) & (xn > 0)).any() else 0.0]
            rep.update(
                slip_tolerance=tol,
                slip_max=utmax,
                intervals=[dict(state=name[r[0]], x=[r[1], r[2]], nodes=r[3]) for r in runs],
                stick_x_range=[widest[1], widest[2]] if widest else None,
                stick_half_width=0.5 * (widest[2] - widest[1]) if widest else 0.0,
                stick_length=stick_len,
                slip_length=slip_len,
                slip_sign_left_right=slip_dir,
            )
        return rep

    def report(self, delta, slip_rel_tol=1e-3):
        out = dict(boundaries={}, contact=None)
        for bd, idx in self.parts:
            entry = dict(kind=bd["kind"], edges=int(len(idx)))
            if bd["kind"] == "dirichlet":
                F = self.force(idx)
                spec = bd["displacement"]
                entry.update(force=[float(F[0]), float(F[1])],
                             dirichlet_max=self.boundary_max(idx, lambda xs, d, u, S: np.abs(u - vec_data(spec, xs)).max(axis=1)))
            elif bd["kind"] == "neumann":
                spec = bd["traction"]
                entry.update(neumann_max=self.boundary_max(
                    idx, lambda xs, d, u, S: np.linalg.norm(self._traction(S, d) / np.linalg.norm(d, axis=1)[:, None]
                                                            - vec_data(spec, xs), axis=1)))
            elif bd["kind"] == "contact":
                entry.update(self.contact_report(bd, idx, delta, slip_rel_tol))
                out["contact"] = bd["name"]
            out["boundaries"][bd["name"]] = entry
        if len(self.free):
            out["traction_free_unselected"] = dict(
                edges=int(len(self.free)),
                neumann_max=self.boundary_max(
                    self.free, lambda xs, d, u, S: np.linalg.norm(self._traction(S, d) / np.linalg.norm(d, axis=1)[:, None], axis=1)))
        return out

    # ---------------------------------------------------------------- volume quantities
    def energy(self, E, nu):
        """½(Cε(u_h), ε(u_h)) (None for nu = 0.5) and μ‖ε(u_h)‖², isoparametric, Duffy-collapsed
        Gauss rule with 8x8 points (exact for P1; for curved P2 the integrand is rational)."""
        mu = E / (2 * (1 + nu))
        lam = None if nu == 0.5 else E * nu / ((1 + nu) * (1 - 2 * nu))
        g, w = np.polynomial.legendre.leggauss(8)
        g, w = 0.5 * (g + 1), 0.5 * w
        A, B = np.meshgrid(g, g, indexing="ij")
        WA, WB = np.meshgrid(w, w, indexing="ij")
        xi = (A * (1 - B)).ravel()
        eta = B.ravel()
        wt = (WA * WB * (1 - B)).ravel()
        if self.quad:
            l0, l1, l2 = 1 - xi - eta, xi, eta
            dN = np.stack([
                np.stack([-(4 * l0 - 1), 4 * l1 - 1, 0 * xi, 4 * (l0 - l1), 4 * eta, -4 * eta], -1),
                np.stack([-(4 * l0 - 1), 0 * xi, 4 * l2 - 1, -4 * xi, 4 * xi, 4 * (l0 - l2)], -1)], 1)  # (q,2,6)
        else:
            dN = np.tile(np.array([[-1.0, 1.0, 0.0], [-1.0, 0.0, 1.0]]), (len(xi), 1, 1))
        Xe = self.X[self.cells]  # (M,k,2)
        Ue = self.U[self.cells]
        J = np.einsum("qrk,mkd->mqdr", dN, Xe)  # dx_d/dxi_r
        detJ = J[..., 0, 0] * J[..., 1, 1] - J[..., 0, 1] * J[..., 1, 0]
        Jinv = np.stack([np.stack([J[..., 1, 1], -J[..., 0, 1]], -1), np.stack([-J[..., 1, 0], J[..., 0, 0]], -1)], -2) / detJ[..., None, None]
        Gr = np.einsum("qrk,mkc->mqcr", dN, Ue)  # du_c/dxi_r
        Gx = np.einsum("mqcr,mqrd->mqcd", Gr, Jinv)  # du_c/dx_d
        eps = 0.5 * (Gx + np.swapaxes(Gx, -1, -2))
        tr = eps[..., 0, 0] + eps[..., 1, 1]
        ee = np.einsum("mqij,mqij->mq", eps, eps)
        dV = np.abs(detJ) * wt[None, :]
        mu_e2 = float(mu * np.sum(ee * dV))
        energy = None if lam is None else float(np.sum((mu * ee + 0.5 * lam * tr ** 2) * dV))
        return dict(energy=energy, mu_eps2=mu_e2, min_detJ=float(detJ.min()))

    def mesh_stats(self):
        c = self.cells[:, :3]
        e = np.unique(np.sort(np.vstack([c[:, [0, 1]], c[:, [1, 2]], c[:, [2, 0]]]), axis=1), axis=0)
        L = np.linalg.norm(self.X[e[:, 0]] - self.X[e[:, 1]], axis=1)
        return dict(points=int(self.X.shape[0]), points_in_file=self.points_in_file,
                    merged_value_jump=self.merge_jump, cells=int(self.cells.shape[0]),
                    cell_type="triangle6" if self.quad else "triangle",
                    boundary_edges=int(len(self.edges)), line_cells_in_file=self.has_lines,
                    h_min=float(L.min()), h_max=float(L.max()), orientation_ccw=self.orientation_ok)
