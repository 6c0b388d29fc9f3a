"""Problem data shared by the two solvers: reading solution.vtu + scene.toml, material and
norm constants, boundary edges with their kind, contact frame and gap.

Only the *scene semantics* are borrowed from fosls_ref (scene parsing, boundary selection by
`tag` / `where`, norm choice, diameter), so that the reconstruction solves the problem fosls_ref
evaluates. Everything about the stress space (Raviart-Thomas elements, assembly, constraints,
QP) is in skfem_solver.py and ngsolve_solver.py, which share nothing but this module.
"""
import math
import os
import sys
from dataclasses import dataclass, field

import meshio
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))  # reference/ -> import fosls_ref

from fosls_ref.evaluate import assign_boundaries, choose_norm, diameter  # noqa: E402
from fosls_ref.mesh import EDGE_MID, EDGE_VERTS, Solution, build_topology  # noqa: E402
from fosls_ref.scene import load_scene  # noqa: E402

_DISP_NAMES = ("displacement", "displacements", "disp", "u", "d")


@dataclass
class Edge:
    """One boundary edge. a, b: point ids (VTU numbering) in the owning cell's local order
    (v0->v1, v1->v2, v2->v0); m: mid node id (P2) or -1; kind: dirichlet | neumann | free |
    contact; bnd: the scene Boundary (None for free edges)."""
    index: int
    cell: int
    local: int
    a: int
    b: int
    m: int
    kind: str
    bnd: object = None


@dataclass
class Problem:
    name: str
    vtu: str
    scene_path: str
    scene: object
    points: np.ndarray        # (Np, 2)
    cells: np.ndarray         # (Nc, 3|6) VTU connectivity (v0 v1 v2 [m01 m12 m20])
    degree: int               # 1 | 2 (displacement P1 | P2)
    disp: np.ndarray          # (Np, 2)
    line_cells: np.ndarray    # (Nl, 2|3) for writing
    line_tags: np.ndarray     # (Nl,) or None
    norm: str
    mu: float
    lam: float
    ctr: float                # c in A tau = (tau - c tr(tau) I) / (2 mu)
    k1: float                 # constitutive integrand k1 |e|^2 + k2 (tr e)^2
    k2: float
    wd: float                 # equilibrium integrand 1/2 wd |div tau + f|^2
    ell: float
    diam: float
    edges: list = field(default_factory=list)
    curved: bool = False
    notes: list = field(default_factory=list)

    # ---------------------------------------------------------------- expressions
    def body_force(self, x, y):
        bf = self.scene.body_force
        if bf is None:
            return np.zeros(np.shape(x) + (2,))
        return bf(x, y)

    def traction(self, e, x, y):
        if e.kind == "free":
            return np.zeros(np.shape(x) + (2,))
        return e.bnd.traction(x, y)

    def frame(self, e, x, y, nO):
        """Contact frame (n, t) and gap g at points x, y (arrays) with outward normals nO (...,2)."""
        b = e.bnd
        if b.normal == "body":
            n = np.array(nO, dtype=float)
        else:
            n = np.broadcast_to(-b.plane_normal, np.shape(nO)).astype(float)
        t = np.stack([-n[..., 1], n[..., 0]], axis=-1)
        if b.gap is not None:
            g = b.gap(x, y)
        else:
            m, p = b.plane_normal, b.plane_point
            h = (x - p[0]) * m[0] + (y - p[1]) * m[1]
            if b.normal == "obstacle":
                g = h
            else:
                den = -(n[..., 0] * m[0] + n[..., 1] * m[1])
                if np.any(den <= 0):
                    raise ValueError("body normal: a contact point whose normal ray never meets the plane")
                g = h / den
        return n, t, g


def read_problem(name, vtu, scene_path):
    scene = load_scene(scene_path)
    m = meshio.read(vtu)
    pts = np.ascontiguousarray(np.asarray(m.points, dtype=float)[:, :2])
    tri = [(i, b) for i, b in enumerate(m.cells) if b.type in ("triangle", "triangle6")]
    lines = [(i, b) for i, b in enumerate(m.cells) if b.type in ("line", "line3")]
    types = {b.type for _, b in tri}
    if len(types) != 1:
        raise ValueError(f"{vtu}: need exactly one triangle cell type, got {types}")
    degree = 2 if "triangle6" in types else 1
    cells = np.concatenate([np.asarray(b.data, dtype=np.int64) for _, b in tri])
    dname = scene.displacement_name
    if dname is None:
        low = {k.lower(): k for k in m.point_data}
        dname = next(low[c] for c in _DISP_NAMES if c in low)
    disp = np.ascontiguousarray(np.asarray(m.point_data[dname], dtype=float)[:, :2])
    lk, lt, lc = [], [], []
    for ib, blk in lines:
        d = np.asarray(blk.data, dtype=np.int64)
        lc.append(d)
        lk.append(d[:, :2])
        if scene.tag_array is not None and scene.tag_array in m.cell_data:
            lt.append(np.asarray(m.cell_data[scene.tag_array][ib]).reshape(len(d), -1)[:, 0].astype(float))
        else:
            lt.append(np.full(len(d), np.nan))
    line_keys = np.concatenate(lk) if lk else np.zeros((0, 2), dtype=np.int64)
    line_tags = np.concatenate(lt) if lt else np.zeros(0)
    sol = Solution(path=vtu, points=pts, cells=cells, degree=degree, disp=disp,
                   stress=np.zeros((len(pts), 2, 2)), disp_name=dname, stress_name="",
                   stress_layout=[], line_keys=line_keys, line_tags=line_tags)
    build_topology(sol)
    used = np.unique(cells)
    if np.any(sol.merged[used] != used):
        raise ValueError(f"{vtu}: exploded / duplicated points: not supported by the reconstruction reference")
    owner, notes = assign_boundaries(sol, scene)

    mat = scene.material
    norm, _ = choose_norm(scene, None)
    mu, lam, ctr = mat.mu, mat.lam, mat.trace_coef
    if norm == "energy":
        k1, k2 = mu, 0.5 * lam
    elif norm == "robust":
        k1, k2 = mu, 0.0
    else:
        k1, k2 = 0.5, 0.0
    diam = diameter(sol)
    ell = scene.length_scale if scene.length_scale is not None else diam / math.pi
    wd = ell * ell / (2.0 * mu) if norm != "seed" else 1.0

    bmap = {b.index: b for b in scene.boundaries}
    edges = []
    for i in range(len(sol.bedge_cell)):
        c, loc = int(sol.bedge_cell[i]), int(sol.bedge_local[i])
        a, b = cells[c, EDGE_VERTS[loc]]
        mid = int(cells[c, EDGE_MID[loc]]) if degree == 2 else -1
        if owner[i] < 0:
            kind, bd = "free", None
        else:
            bd = bmap[int(owner[i])]
            kind = bd.kind
            if kind == "contact" and bd.friction > 0:
                raise NotImplementedError("Coulomb friction: the reconstruction reference is frictionless only")
        edges.append(Edge(i, c, loc, int(a), int(b), mid, kind, bd))
    curved = False
    if degree == 2:
        for j, (p, q) in enumerate(EDGE_VERTS):
            chord = 0.5 * (pts[cells[:, p]] + pts[cells[:, q]])
            dev = np.hypot(*(pts[cells[:, EDGE_MID[j]]] - chord).T)
            if np.any(dev > 1e-13 * diam):
                curved = True
    return Problem(name=name, vtu=vtu, scene_path=scene_path, scene=scene, points=pts, cells=cells,
                   degree=degree, disp=disp,
                   line_cells=np.concatenate(lc) if lc else np.zeros((0, 2), dtype=np.int64),
                   line_tags=line_tags if scene.tag_array is not None else None,
                   norm=norm, mu=mu, lam=lam, ctr=ctr, k1=k1, k2=k2, wd=wd, ell=ell, diam=diam,
                   edges=edges, curved=curved, notes=notes)


def point_key(x, y, scale):
    """Hashable key of a point, rounded to 1e-9 of the domain size."""
    q = 1e-9 * scale
    return (int(round(x / q)), int(round(y / q)))
