"""The FOSLS functional (docs/design.md §3), admissibility (§5) and contact measurements, for nodal
P1/P2 displacement and stress fields as given in the file (no reconstruction).

All squares are squares of pointwise differences. Cell integrals: scikit-fem triangle rule of
order `cell_order` (default 19; exact for the polynomial integrands on straight cells, converged
for curved ones). Edge integrals on contact edges: `edge_points`-point Gauss-Legendre on every
piece of the edge between consecutive sign changes of the kink functions (see `_contact_edge`).
"""
import math
import time

import numpy as np
from scipy.optimize import minimize_scalar
from scipy.spatial import ConvexHull

from .errors import InputError
from .fem import EDGE_NODE_S, cell_fields, edge_fields, gauss, tri_rule
from .roots import roots

CHUNK = 20000
NGRID = 256  # uniform samples per edge for suprema (plus nodes, split points, then polished)


# --------------------------------------------------------------------------------------------
# global quantities
# --------------------------------------------------------------------------------------------
def diameter(sol):
    """max |p - q| over all points referenced by the triangle cells (vertices and P2 mid nodes),
    computed on their convex hull."""
    used = np.unique(sol.cells)
    P = np.unique(sol.points[used], axis=0)
    try:
        H = P[ConvexHull(P).vertices]
    except Exception:
        H = P
    best = 0.0
    for i in range(len(H)):
        d = np.hypot(*(H[i + 1:] - H[i]).T)
        if len(d):
            best = max(best, float(d.max()))
    return best


def choose_norm(scene, norm_cli):
    mat = scene.material
    if norm_cli is not None:
        norm, src = norm_cli, "command line"
    elif scene.norm is not None:
        norm, src = scene.norm, "scene"
    else:
        norm, src = ("energy", "default") if mat.nu < 0.5 else ("robust", "default (nu = 0.5)")
    if norm == "energy" and mat.nu >= 0.5:
        raise InputError(f"{scene.path}: estimate.norm = \"energy\" with poisson_ratio = {mat.nu}: "
                         "use \"robust\" (nu >= 0.5)")
    return norm, src


# --------------------------------------------------------------------------------------------
# boundary edge assignment
# --------------------------------------------------------------------------------------------
def assign_boundaries(sol, scene):
    """owner[i] = index of the first [[boundary]] (file order) selecting boundary edge i, or -1.

    `tag`: the line cells whose tag equals `tag` (matched to boundary edges by their merged end
    points). `where`: the expression evaluated at the edge point of parameter 1/2 (the P2 mid
    node; the chord midpoint for P1), selected where > 0.
    """
    nb = len(sol.bedge_cell)
    owner = np.full(nb, -1)
    keymap = {(int(a), int(b)): i for i, (a, b) in enumerate(sol.bedge_key)}
    mid = edge_fields(sol, sol.bedge_cell, sol.bedge_local, np.full((nb, 1), 0.5))["x"][:, 0, :]
    notes = []
    for b in scene.boundaries:
        if b.tag is not None:
            hit = np.nonzero(sol.line_tags == b.tag)[0]
            if len(hit) == 0:
                raise InputError(f"{scene.path}: boundary {b.name!r}: tag {b.tag} absent from "
                                 f"{sol.path} (cell data {scene.tag_array!r})")
            sel = []
            for li in hit:
                k = (int(sol.line_keys[li, 0]), int(sol.line_keys[li, 1]))
                if k not in keymap:
                    raise InputError(f"{sol.path}: line cell {li} (tag {b.tag}, boundary {b.name!r}) "
                                     "is not a boundary edge of the triangle mesh")
                sel.append(keymap[k])
            sel = np.unique(np.array(sel, dtype=int))
        else:
            sel = np.nonzero(b.where.selects(mid[:, 0], mid[:, 1]))[0]
            if len(sel) == 0:
                raise InputError(f"{scene.path}: boundary {b.name!r}: where = {b.where.text!r} "
                                 f"matches no boundary edge of {sol.path}")
        taken = sel[owner[sel] >= 0]
        if len(taken):
            notes.append(f"boundary {b.name!r}: {len(taken)} edge(s) already selected by an earlier "
                         "[[boundary]] (first one wins)")
        owner[sel[owner[sel] < 0]] = b.index
    return owner, notes


# --------------------------------------------------------------------------------------------
# cell terms
# --------------------------------------------------------------------------------------------
def cell_terms(sol, scene, norm, wd, cell_order):
    mat = scene.material
    mu, lam, c = mat.mu, mat.lam, mat.trace_coef
    X, W = tri_rule(cell_order)
    nc = len(sol.cells)
    const = np.zeros(nc)
    equi = np.zeros(nc)
    energy = np.zeros(nc)
    const_energy = np.zeros(nc)  # 1/2 (C e, e) (for the bound), nan if lam = inf
    div_l2, f_l2, res_l2 = 0.0, 0.0, 0.0
    asym_max = 0.0
    for c0 in range(0, nc, CHUNK):
        idx = np.arange(c0, min(nc, c0 + CHUNK))
        q = cell_fields(sol, idx, X)
        dx = np.abs(q["det"]) * W[None, :]
        gu = q["grad_u"]
        eps = 0.5 * (gu + np.swapaxes(gu, -1, -2))
        tau = q["tau"]
        trt = tau[..., 0, 0] + tau[..., 1, 1]
        Atau = tau.copy()
        Atau[..., 0, 0] -= c * trt
        Atau[..., 1, 1] -= c * trt
        Atau /= 2.0 * mu
        e = eps - Atau                      # pointwise difference, then squared
        e2 = np.sum(e * e, axis=(-1, -2))
        tre = e[..., 0, 0] + e[..., 1, 1]
        eps2 = np.sum(eps * eps, axis=(-1, -2))
        treps = eps[..., 0, 0] + eps[..., 1, 1]
        if scene.body_force is not None:
            f = scene.body_force(q["x"][..., 0], q["x"][..., 1])
        else:
            f = np.zeros_like(q["div"])
        r = q["div"] + f
        r2 = np.sum(r * r, axis=-1)
        if math.isinf(lam):
            ce = np.where(tre == 0, mu * e2, np.inf)
        else:
            ce = mu * e2 + 0.5 * lam * tre * tre
        const_energy[idx] = np.sum(ce * dx, axis=1)
        if norm == "energy":
            const[idx] = np.sum((mu * e2 + 0.5 * lam * tre * tre) * dx, axis=1)
            equi[idx] = 0.5 * wd * np.sum(r2 * dx, axis=1)
            energy[idx] = np.sum((mu * eps2 + 0.5 * lam * treps * treps) * dx, axis=1)
        elif norm == "robust":
            const[idx] = np.sum(mu * e2 * dx, axis=1)
            equi[idx] = 0.5 * wd * np.sum(r2 * dx, axis=1)
            energy[idx] = np.sum(mu * eps2 * dx, axis=1)
        else:  # seed
            const[idx] = np.sum(0.5 * e2 * dx, axis=1)
            equi[idx] = np.sum(0.5 * r2 * dx, axis=1)
            energy[idx] = np.sum(mu * eps2 * dx, axis=1)
        div_l2 += float(np.sum(np.sum(q["div"] ** 2, axis=-1) * dx))
        f_l2 += float(np.sum(np.sum(f ** 2, axis=-1) * dx))
        res_l2 += float(np.sum(r2 * dx))
        asym_max = max(asym_max, float(np.max(np.abs(tau[..., 0, 1] - tau[..., 1, 0]))))
    return {
        "const": const, "equi": equi, "energy": energy, "const_energy": const_energy,
        "div_l2": math.sqrt(div_l2), "f_l2": math.sqrt(f_l2), "res_l2": math.sqrt(res_l2),
        "asym_max": asym_max,
    }


# --------------------------------------------------------------------------------------------
# contact edges
# --------------------------------------------------------------------------------------------
def contact_frame(sol, b, cell, local, s):
    """All contact quantities of boundary `b` on one edge at parameters s (1D array)."""
    E = edge_fields(sol, np.array([cell]), np.array([local]), s[None, :])
    x, jac, nO, u, tau = E["x"][0], E["jac"][0], E["n"][0], E["u"][0], E["tau"][0]
    trac = np.einsum("sab,sb->sa", tau, nO)          # traction tau n_Omega
    if b.normal == "body":
        n = nO
    else:
        n = np.broadcast_to(-b.plane_normal, nO.shape)
    t = np.stack([-n[:, 1], n[:, 0]], axis=-1)
    if b.gap is not None:
        g = b.gap(x[:, 0], x[:, 1])
    else:
        m, p = b.plane_normal, b.plane_point
        h = (x - p) @ m                                # signed distance to the plane
        if b.normal == "obstacle":
            g = h
        else:
            den = -(n @ m)                             # ray x + s n meets the plane at s = h/den
            with np.errstate(divide="ignore", invalid="ignore"):
                g = np.where(den > 0, h / np.where(den > 0, den, 1.0), np.inf)
    vn = np.sum(n * u, axis=-1)
    vt = np.sum(t * u, axis=-1)
    tn = np.sum(n * trac, axis=-1)
    tt = np.sum(t * trac, axis=-1)
    with np.errstate(invalid="ignore"):
        gap_res = np.where(np.isinf(g), -np.inf, vn - g)     # v_n - g
        comp = np.where(np.isinf(g) & (tn == 0), 0.0, gap_res * tn)
    F = b.friction
    fric = F * np.abs(tn) * np.abs(vt) + tt * vt
    return {"x": x, "jac": jac, "vn": vn, "vt": vt, "tn": tn, "tt": tt, "g": g, "gap_res": gap_res,
            "comp": comp, "fric": fric, "pen": np.maximum(gap_res, 0.0),
            "tension": np.maximum(tn, 0.0), "cone": np.maximum(np.abs(tt) - F * np.abs(tn), 0.0)}


def _contact_edge(sol, b, cell, local, tol_abs, npts):
    """Integrals over one contact edge with splitting at all kinks / indicator changes.

    Split points: roots of tau_n, v_t, tau_t, v_n - g (smooth on the edge), then on each piece
    roots of |tau_t| - F|tau_n| and of the friction integrand (smooth on a piece). Every
    integrand and indicator is smooth / sign-constant on the resulting pieces; each piece gets an
    npts-point Gauss-Legendre rule.
    """
    F = b.friction
    q = lambda s, key: contact_frame(sol, b, cell, local, s)[key]
    pts = [0.0, 1.0]
    smooth = [lambda s: q(s, "tn"), lambda s: q(s, "tt"), lambda s: q(s, "vt"),
              lambda s: np.nan_to_num(q(s, "gap_res"), neginf=-1e300)]
    for fn in smooth:
        pts.extend(roots(fn, 0.0, 1.0))
    pts = np.unique(np.array(pts))

    def cone_f(s):
        d = contact_frame(sol, b, cell, local, s)
        return np.abs(d["tt"]) - F * np.abs(d["tn"])

    piecewise = [cone_f]
    if F > 0:
        piecewise.append(lambda s: q(s, "fric"))
    extra = []
    for a, bb in zip(pts[:-1], pts[1:]):
        for fn in piecewise:
            extra.extend(roots(fn, a, bb, ngrid=8))
    pts = np.unique(np.concatenate([pts, extra]))

    acc = dict.fromkeys(["length", "comp", "comp_neg", "fric", "fric_neg", "normal_force",
                         "tangential_force", "active", "active_strict", "stick", "stick_strict",
                         "pen2", "tension2", "cone2"], 0.0)
    info = []
    for a, bb in zip(pts[:-1], pts[1:]):
        if not bb > a:
            continue
        s, w = gauss(npts, a, bb)
        d = contact_frame(sol, b, cell, local, np.append(s, 0.5 * (a + bb)))
        dl = w * d["jac"][:-1]
        L = float(np.sum(dl))
        acc["length"] += L
        acc["comp"] += float(np.sum(d["comp"][:-1] * dl))
        acc["comp_neg"] += float(np.sum(np.minimum(d["comp"][:-1], 0.0) * dl))
        if F > 0:
            acc["fric"] += float(np.sum(d["fric"][:-1] * dl))
            acc["fric_neg"] += float(np.sum(np.minimum(d["fric"][:-1], 0.0) * dl))
        acc["normal_force"] += float(np.sum(-d["tn"][:-1] * dl))
        acc["tangential_force"] += float(np.sum(d["tt"][:-1] * dl))
        acc["pen2"] += float(np.sum(d["pen"][:-1] ** 2 * dl))
        acc["tension2"] += float(np.sum(d["tension"][:-1] ** 2 * dl))
        acc["cone2"] += float(np.sum(d["cone"][:-1] ** 2 * dl))
        # indicator functions are sign-constant on a piece: record the midpoint value and the
        # minimum over the piece's sample points (for the significance test below)
        tn_all = d["tn"]
        h_all = np.abs(d["tt"]) - F * np.abs(d["tn"])
        info.append((L, tn_all[-1], float(tn_all.min()), h_all[-1], float(h_all.min())))
    # active: tau_n < 0, stick: |tau_t| < F|tau_n| (and active). A maximal run of consecutive
    # pieces where the function is negative counts only if the function is < -tol somewhere
    # on the run (tol = contact_tol * max|sigma_n| on Gamma_C): round-off noise around zero
    # (separated zone with sigma_n ~ 1e-17, slip zone with |sigma_t| - F|sigma_n| ~ 1e-17) is
    # not classified active / stick, while genuine zones keep their exact end points.
    info = np.array(info).reshape(-1, 5)
    for tol, ka, ks in ((tol_abs, "active", "stick"), (0.0, "active_strict", "stick_strict")):
        act = _significant_runs(info[:, 1] < 0, info[:, 2], tol)
        stk = act & _significant_runs(info[:, 3] < 0, info[:, 4], tol)
        acc[ka] += float(np.sum(info[act, 0]))
        acc[ks] += float(np.sum(info[stk, 0]))
    acc["pieces"] = len(pts) - 1
    acc["split_points"] = pts
    return acc


def _significant_runs(neg, fmin, tol):
    """neg[i]: function negative on piece i; fmin[i]: its minimum there. Returns, per piece,
    whether it belongs to a run of consecutive negative pieces whose minimum is < -tol
    (tol = 0: simply `neg`)."""
    out = np.zeros(len(neg), dtype=bool)
    i = 0
    while i < len(neg):
        if not neg[i]:
            i += 1
            continue
        j = i
        while j < len(neg) and neg[j]:
            j += 1
        out[i:j] = fmin[i:j].min() < -tol
        i = j
    return out


def _sup_on_edges(sol, fn, cells, locals_, extra_s=None):
    """sup over the given edges of fn(fields of edge at s) >= 0.

    Evaluates on NGRID+1 uniform parameters (which include the P1/P2 nodes) plus `extra_s`
    (per edge, e.g. split points), then polishes the best candidates with a bounded scalar
    search. Returns (sup, x of sup, max over nodes).
    """
    if len(cells) == 0:
        return 0.0, None, 0.0
    grid = np.linspace(0.0, 1.0, NGRID + 1)
    vals = np.zeros((len(cells), len(grid)))
    for c0 in range(0, len(cells), 2000):
        sl = slice(c0, c0 + 2000)
        S = np.broadcast_to(grid, (len(cells[sl]), len(grid)))
        vals[sl] = fn(cells[sl], locals_[sl], S)
    node_cols = np.searchsorted(grid, EDGE_NODE_S[sol.degree])
    node_max = float(vals[:, node_cols].max())
    best_val, best_e, best_s = float(vals.max()), None, None
    ie, isg = np.unravel_index(np.argmax(vals), vals.shape)
    best_e, best_s = int(ie), float(grid[isg])
    if extra_s is not None:
        for i, s in extra_s.items():
            if len(s):
                v = fn(cells[i:i + 1], locals_[i:i + 1], np.asarray(s)[None, :])[0]
                k = int(np.argmax(v))
                if v[k] > best_val:
                    best_val, best_e, best_s = float(v[k]), i, float(s[k])
    if best_val > 0:
        emax = vals.max(axis=1)
        cand = np.argsort(-emax)[:32]
        cand = cand[emax[cand] >= 0.5 * emax[cand[0]]]
        for i in cand:
            k = int(np.argmax(vals[i]))
            lo, hi = grid[max(k - 1, 0)], grid[min(k + 1, len(grid) - 1)]
            f1 = lambda s: -float(fn(cells[i:i + 1], locals_[i:i + 1], np.array([[s]]))[0, 0])
            r = minimize_scalar(f1, bounds=(lo, hi), method="bounded",
                                options={"xatol": 1e-15})
            if -r.fun > best_val:
                best_val, best_e, best_s = -float(r.fun), int(i), float(r.x)
    if not best_val > 0:
        return 0.0, None, max(node_max, 0.0)
    xloc = edge_fields(sol, cells[best_e:best_e + 1], locals_[best_e:best_e + 1],
                       np.array([[best_s]]))["x"][0, 0]
    return best_val, [float(xloc[0]), float(xloc[1])], node_max


def _qp_max_and_l2(sol, fn, cells, locals_, npts):
    """max over the npts-point Gauss points of each (unsplit) edge, and the integral of fn^2."""
    if len(cells) == 0:
        return 0.0, 0.0
    s, w = gauss(npts)
    mx, l2 = 0.0, 0.0
    for c0 in range(0, len(cells), 2000):
        sl = slice(c0, c0 + 2000)
        S = np.broadcast_to(s, (len(cells[sl]), len(s)))
        v = fn(cells[sl], locals_[sl], S)
        jac = edge_fields(sol, cells[sl], locals_[sl], S)["jac"]
        mx = max(mx, float(v.max()))
        l2 += float(np.sum(v * v * jac * w[None, :]))
    return mx, l2


# --------------------------------------------------------------------------------------------
# main entry
# --------------------------------------------------------------------------------------------
def evaluate(sol, scene, norm=None, cell_order=19, edge_points=20, contact_tol=1e-10,
             with_cells=False, worst=10):
    t0 = time.perf_counter()
    mat = scene.material
    norm, norm_src = choose_norm(scene, norm)
    diam = diameter(sol)
    if scene.length_scale is not None:
        ell, ell_src = scene.length_scale, "scene estimate.length_scale"
    else:
        ell, ell_src = diam / math.pi, "diameter/pi"
    wd = ell * ell / (2.0 * mat.mu) if norm != "seed" else 1.0
    nc = len(sol.cells)

    owner, notes = assign_boundaries(sol, scene)
    ct = cell_terms(sol, scene, norm, wd, cell_order)
    comp_cell = np.zeros(nc)
    fric_cell = np.zeros(nc)

    # ---- contact ----
    contact_bs = [b for b in scene.boundaries if b.kind == "contact"]
    tot = dict.fromkeys(["length", "comp", "comp_neg", "fric", "fric_neg", "normal_force",
                         "tangential_force", "active", "active_strict", "stick", "stick_strict",
                         "pen2", "tension2", "cone2"], 0.0)
    # scale of sigma_n on Gamma_C for the contact tolerance
    sn_scale = 0.0
    for b in contact_bs:
        ids = np.nonzero(owner == b.index)[0]
        for i in ids:
            d = contact_frame(sol, b, sol.bedge_cell[i], sol.bedge_local[i], np.linspace(0, 1, 33))
            sn_scale = max(sn_scale, float(np.max(np.abs(d["tn"]))))
    tol_abs = contact_tol * sn_scale
    per_boundary = []
    sups = {"penetration": [], "tension": [], "cone_violation": []}
    qpmax = {"penetration": 0.0, "tension": 0.0, "cone_violation": 0.0}
    n_pieces = 0
    for b in contact_bs:
        ids = np.nonzero(owner == b.index)[0]
        btot = dict.fromkeys(tot, 0.0)
        splits = {}
        for k, i in enumerate(ids):
            acc = _contact_edge(sol, b, sol.bedge_cell[i], sol.bedge_local[i], tol_abs, edge_points)
            n_pieces += acc["pieces"]
            splits[k] = acc["split_points"]
            comp_cell[sol.bedge_cell[i]] += acc["comp"]
            fric_cell[sol.bedge_cell[i]] += acc["fric"]
            for key in btot:
                btot[key] += acc[key]
        for key in tot:
            tot[key] += btot[key]
        cells_b, loc_b = sol.bedge_cell[ids], sol.bedge_local[ids]

        def mk(key):
            def fn(cells, locs, S):
                return np.array([contact_frame(sol, b, c, l, s)[key]
                                 for c, l, s in zip(cells, locs, S)])
            return fn

        bsup = {}
        for name, key in (("penetration", "pen"), ("tension", "tension"), ("cone_violation", "cone")):
            fn = mk(key)
            v = _sup_on_edges(sol, fn, cells_b, loc_b, splits)
            q, _ = _qp_max_and_l2(sol, fn, cells_b, loc_b, edge_points)
            bsup[name] = v[0]
            sups[name].append(v)
            qpmax[name] = max(qpmax[name], q)
        per_boundary.append({
            "name": b.name, "kind": "contact", "edges": int(len(ids)), "length": btot["length"],
            "normal": b.normal, "friction": b.friction,
            "complementarity": btot["comp"], "friction_term": btot["fric"],
            "normal_force": btot["normal_force"], "active_length": btot["active"],
            "penetration_max": bsup["penetration"], "tension_max": bsup["tension"],
            "cone_violation_max": bsup["cone_violation"],
        })

    def combine(lst):
        if not lst:
            return (0.0, None, 0.0)
        best = max(lst, key=lambda t: t[0])
        return (best[0], best[1], max(t[2] for t in lst))

    sup = {k: combine(v) for k, v in sups.items()}

    # ---- Dirichlet ----
    def dir_fn(b):
        def fn(cells, locs, S):
            E = edge_fields(sol, cells, locs, S)
            uD = b.displacement(E["x"][..., 0], E["x"][..., 1])
            d = E["u"] - uD
            return np.sqrt(np.sum(d * d, axis=-1))
        return fn

    def neu_fn(b):
        def fn(cells, locs, S):
            E = edge_fields(sol, cells, locs, S)
            tr = np.einsum("esab,esb->esa", E["tau"], E["n"])
            t = b.traction(E["x"][..., 0], E["x"][..., 1]) if b is not None else 0.0
            d = tr - t
            return np.sqrt(np.sum(d * d, axis=-1))
        return fn

    dsup, dnode, dqp, dl2, dloc = 0.0, 0.0, 0.0, 0.0, None
    nsup, nnode, nqp, nl2, nloc = 0.0, 0.0, 0.0, 0.0, None
    n_neumann_edges = 0
    groups = [(b, np.nonzero(owner == b.index)[0]) for b in scene.boundaries if b.kind != "contact"]
    groups.append((None, np.nonzero(owner < 0)[0]))  # unselected: traction-free
    for b, ids in groups:
        if len(ids) == 0:
            continue
        cells_b, loc_b = sol.bedge_cell[ids], sol.bedge_local[ids]
        length = float(np.sum(_qp_length(sol, cells_b, loc_b, edge_points)))
        if b is not None and b.kind == "dirichlet":
            fn = dir_fn(b)
            v, loc, nd = _sup_on_edges(sol, fn, cells_b, loc_b)
            q, l2 = _qp_max_and_l2(sol, fn, cells_b, loc_b, edge_points)
            if v >= dsup:
                dsup, dloc = v, loc
            dnode, dqp, dl2 = max(dnode, nd), max(dqp, q), dl2 + l2
            per_boundary.append({"name": b.name, "kind": "dirichlet", "edges": int(len(ids)),
                                 "length": length, "dirichlet_max": v, "dirichlet_l2": math.sqrt(l2)})
        else:
            fn = neu_fn(b)
            v, loc, nd = _sup_on_edges(sol, fn, cells_b, loc_b)
            q, l2 = _qp_max_and_l2(sol, fn, cells_b, loc_b, edge_points)
            if v >= nsup:
                nsup, nloc = v, loc
            nnode, nqp, nl2 = max(nnode, nd), max(nqp, q), nl2 + l2
            n_neumann_edges += len(ids)
            per_boundary.append({"name": b.name if b is not None else "(unselected: traction-free)",
                                 "kind": "neumann", "edges": int(len(ids)), "length": length,
                                 "neumann_max": v, "neumann_l2": math.sqrt(l2)})

    # ---- totals ----
    Fc, Fd = float(ct["const"].sum()), float(ct["equi"].sum())
    Fcomp, Ffric = float(comp_cell.sum()), float(fric_cell.sum())
    F = Fc + Fd + Fcomp + Ffric
    energy = float(ct["energy"].sum())
    eta2 = ct["const"] + ct["equi"] + comp_cell + fric_cell
    adm = {"penetration_max": sup["penetration"][0], "tension_max": sup["tension"][0],
           "cone_violation_max": sup["cone_violation"][0], "dirichlet_max": dsup,
           "neumann_max": nsup}

    # ---- bound (§6), frictionless only ----
    umax = float(np.max(np.abs(sol.disp[np.unique(sol.cells)])))
    smax = float(np.max(np.abs(sol.stress[np.unique(sol.cells)])))
    tu, ts = 1e-10 * umax, 1e-10 * smax
    failed = []
    if any(b.friction > 0 for b in contact_bs):
        failed.append("frictionless contact")
    if mat.incompressible:
        failed.append("finite lambda (nu < 0.5)")
    if dsup > tu:
        failed.append("v = u_D on Gamma_D")
    if adm["penetration_max"] > tu:
        failed.append("v_n <= g on Gamma_C")
    if nsup > ts:
        failed.append("tau n = t on Gamma_N")
    if adm["tension_max"] > ts:
        failed.append("tau_n <= 0 on Gamma_C")
    if adm["cone_violation_max"] > ts and not any(b.friction > 0 for b in contact_bs):
        failed.append("tau_t = 0 on Gamma_C")
    if ct["asym_max"] > ts:
        failed.append("tau symmetric")
    if ct["res_l2"] > 1e-10 * (ct["div_l2"] + ct["f_l2"]):
        failed.append("div tau + f = 0")
    bval = float(ct["const_energy"].sum()) + Fcomp
    bound = {"guaranteed": not failed, "value": bval if math.isfinite(bval) else None,
             "energy_error_bound": math.sqrt(2 * bval) if math.isfinite(bval) and bval >= 0 else None,
             "failed_hypotheses": failed}

    order = np.argsort(-eta2)[:worst]
    cells_out = {"count": int(nc),
                 "worst": [{"cell": int(i), "eta": math.sqrt(max(eta2[i], 0.0)), "eta2": float(eta2[i])}
                           for i in order]}
    if with_cells:
        cells_out.update({"eta2": eta2.tolist(), "constitutive": ct["const"].tolist(),
                          "equilibrium": ct["equi"].tolist(), "complementarity": comp_cell.tolist(),
                          "friction": fric_cell.tolist(), "energy": ct["energy"].tolist()})

    nul = lambda v: v if (v is None or math.isfinite(v)) else None
    out = {
        "tool": "fosls_ref",
        "norm": norm,
        "norm_source": norm_src,
        "functional": {"total": F, "constitutive": Fc, "equilibrium": Fd,
                       "complementarity": Fcomp, "friction": Ffric,
                       "complementarity_negative": tot["comp_neg"], "friction_negative": tot["fric_neg"]},
        "eta": math.sqrt(F) if F >= 0 else None,
        "energy": energy,
        "relative": math.sqrt(F / energy) if (F >= 0 and energy > 0) else None,
        "stress": {"source": "file", "space": f"P{sol.degree} nodal (continuous)",
                   "reason": "point data used as given (reference does not reconstruct)"},
        "displacement": {"source": "file", "degree": int(sol.degree)},
        "admissibility": adm,
        "admissibility_nodes": {"penetration_max": sup["penetration"][2], "tension_max": sup["tension"][2],
                                "cone_violation_max": sup["cone_violation"][2],
                                "dirichlet_max": dnode, "neumann_max": nnode},
        "admissibility_quadrature": {"penetration_max": qpmax["penetration"],
                                     "tension_max": qpmax["tension"],
                                     "cone_violation_max": qpmax["cone_violation"],
                                     "dirichlet_max": dqp, "neumann_max": nqp},
        "admissibility_l2": {"penetration": math.sqrt(tot["pen2"]), "tension": math.sqrt(tot["tension2"]),
                             "cone_violation": math.sqrt(tot["cone2"]), "dirichlet": math.sqrt(dl2),
                             "neumann": math.sqrt(nl2)},
        "admissibility_location": {"penetration_max": sup["penetration"][1], "tension_max": sup["tension"][1],
                                   "cone_violation_max": sup["cone_violation"][1],
                                   "dirichlet_max": dloc, "neumann_max": nloc},
        "contact": {"active_length": tot["active"], "stick_length": tot["stick"],
                    "slip_length": tot["active"] - tot["stick"], "normal_force": tot["normal_force"],
                    "tangential_force": tot["tangential_force"], "contact_length": tot["length"],
                    "active_length_strict": tot["active_strict"], "stick_length_strict": tot["stick_strict"],
                    "slip_length_strict": tot["active_strict"] - tot["stick_strict"],
                    "tolerance": tol_abs, "sigma_n_scale": sn_scale, "edge_pieces": int(n_pieces)},
        "bound": bound,
        "cells": cells_out,
        "boundaries": per_boundary,
        "material": {"youngs_modulus": mat.E, "poisson_ratio": mat.nu, "model": mat.model,
                     "mu": mat.mu, "lambda_effective": nul(mat.lam)},
        "weights": {"w_d": wd, "length_scale": ell, "length_scale_source": ell_src, "diameter": diam},
        "quadrature": {"cell_order": cell_order, "edge_points": edge_points,
                       "edge_splitting": True},
        "input": {"solution": sol.path, "scene": scene.path, "degree": int(sol.degree),
                  "cells": int(nc), "points": int(len(sol.points)),
                  "boundary_edges": int(len(sol.bedge_cell)),
                  "traction_free_edges": int(np.count_nonzero(owner < 0)),
                  "stress_array": sol.stress_name, "displacement_array": sol.disp_name,
                  "stress_layout": sol.stress_layout, "notes": sol.notes + notes},
        "elapsed_seconds": time.perf_counter() - t0,
    }
    return out


def _qp_length(sol, cells, locs, npts):
    s, w = gauss(npts)
    S = np.broadcast_to(s, (len(cells), len(s)))
    return np.sum(edge_fields(sol, cells, locs, S)["jac"] * w[None, :], axis=1)
