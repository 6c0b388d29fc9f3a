"""Meshes for the reference contact problems (netgen generator, numpy data).

A mesh is a ``TriMesh``: vertex coordinates ``p`` (N, 2), counter-clockwise triangles ``t`` (M, 3),
boundary edges ``be`` (K, 2) with an integer tag ``btag`` (K,).  The netgen mesh it came from is kept
in ``ngmesh`` so that NGSolve works on exactly the same vertices and triangles.

Hertz half disc: centre (0, 1), radius 1, region y <= 1.  Tags: 1 = arc below y = 1/2 (contact part),
3 = arc above y = 1/2, 2 = flat top.  Geometry vertices at (0, 0), at the ends of the refined zone
|x| <= xz and at y = 1/2 on the arc, so no boundary edge straddles y = 1/2.
Block: [-1, 1] x [0, 1].  Tags: 1 = bottom (contact), 2 = top, 3 = sides.
"""
from dataclasses import dataclass, field
import numpy as np

TAG_CONTACT, TAG_TOP, TAG_FREE = 1, 2, 3
CENTRE = np.array([0.0, 1.0])


@dataclass
class TriMesh:
    p: np.ndarray
    t: np.ndarray
    be: np.ndarray
    btag: np.ndarray
    ngmesh: object = None
    info: dict = field(default_factory=dict)

    def edge_lengths(self):
        e = np.vstack([self.t[:, [0, 1]], self.t[:, [1, 2]], self.t[:, [2, 0]]])
        e = np.unique(np.sort(e, axis=1), axis=0)
        return np.linalg.norm(self.p[e[:, 0]] - self.p[e[:, 1]], axis=1)


def _from_netgen(ngm, classify):
    p = np.array([q.p[:2] for q in ngm.Points()], dtype=float)
    t = np.array([[v.nr - 1 for v in el.vertices] for el in ngm.Elements2D()], dtype=np.int64)
    a = p[t[:, 1]] - p[t[:, 0]]
    b = p[t[:, 2]] - p[t[:, 0]]
    det = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    neg = det < 0
    t[neg] = t[neg][:, [0, 2, 1]]
    be = np.array([[v.nr - 1 for v in s.vertices] for s in ngm.Elements1D()], dtype=np.int64)
    btag = np.array([classify(p[e[0]], p[e[1]]) for e in be], dtype=np.int64)
    return p, t, be, btag


def half_disc(hc, xz=0.12, hmax=0.1, grading=0.3):
    """Graded mesh of the lower half disc (netgen OCC); size hc along the arc for |x| <= xz, growing
    with netgen's grading into the body."""
    from netgen.occ import Pnt, Segment, ArcOfCircle, Wire, Face, OCCGeometry
    import netgen.meshing as nm
    tz = float(np.arcsin(xz))
    P = lambda s: Pnt(float(np.sin(s)), float(1.0 - np.cos(s)), 0.0)
    angles = [np.pi / 2, np.pi / 3, tz, 0.0, -tz, -np.pi / 3, -np.pi / 2]  # pi/3: y = 1/2 on the arc
    edges = [Segment(Pnt(-1.0, 1.0, 0.0), Pnt(1.0, 1.0, 0.0))]
    for k in range(6):
        a, b = angles[k], angles[k + 1]
        edges.append(ArcOfCircle(P(a), P(0.5 * (a + b)), P(b)))
    face = Face(Wire(edges))
    for e in face.edges:  # boundary names for NGSolve (same split as the tags below)
        ymax = max(e.start.y, e.end.y)
        e.name = "top" if e.start.y == 1.0 and e.end.y == 1.0 else ("contact" if ymax <= 0.5 + 1e-12 else "free")
    geo = OCCGeometry(face, dim=2)
    mp = nm.MeshingParameters(maxh=hmax, grading=grading)
    nres = int(np.ceil(tz / hc)) + 1
    for s in np.linspace(-tz, tz, nres):
        mp.RestrictH(x=float(np.sin(s)), y=float(1.0 - np.cos(s)), z=0.0, h=hc)
    ngm = geo.GenerateMesh(mp=mp)

    def classify(a, b):
        if a[1] == 1.0 and b[1] == 1.0:
            return TAG_TOP
        return TAG_CONTACT if max(a[1], b[1]) <= 0.5 + 1e-12 else TAG_FREE

    p, t, be, btag = _from_netgen(ngm, classify)
    return TriMesh(p, t, be, btag, ngm, dict(kind="half_disc", hc=hc, xz=xz, hmax=hmax, grading=grading))


def block(hc, hb=0.02, hmax=0.1, grading=0.3, refine=None):
    """Rectangle [-1,1]x[0,1] (netgen OCC): edge size hb along the bottom, refined to hc at the two bottom
    corners (where the contact zone ends).  Names/tags: bottom = "contact"/1, top = "top"/2, sides = "free"/3.
    refine: optional callable of the netgen MeshingParameters adding further RestrictH calls before meshing."""
    from netgen.occ import Pnt, Segment, Wire, Face, OCCGeometry
    import netgen.meshing as nm
    pts = [Pnt(-1.0, 0.0, 0.0), Pnt(1.0, 0.0, 0.0), Pnt(1.0, 1.0, 0.0), Pnt(-1.0, 1.0, 0.0)]
    face = Face(Wire([Segment(pts[i], pts[(i + 1) % 4]) for i in range(4)]))
    for e in face.edges:
        ys = (e.start.y, e.end.y)
        e.name = "contact" if ys == (0.0, 0.0) else ("top" if ys == (1.0, 1.0) else "free")
    geo = OCCGeometry(face, dim=2)
    mp = nm.MeshingParameters(maxh=hmax, grading=grading)
    for xb in np.linspace(-1.0, 1.0, int(np.ceil(2.0 / hb)) + 1):
        mp.RestrictH(x=float(xb), y=0.0, z=0.0, h=hb)
    for xc in (-1.0, 1.0):
        mp.RestrictH(x=xc, y=0.0, z=0.0, h=hc)
    if refine is not None:
        refine(mp)
    ngm = geo.GenerateMesh(mp=mp)

    def classify(a, b):
        if a[1] == 0.0 and b[1] == 0.0:
            return TAG_CONTACT
        if a[1] == 1.0 and b[1] == 1.0:
            return TAG_TOP
        return TAG_FREE

    p, t, be, btag = _from_netgen(ngm, classify)
    return TriMesh(p, t, be, btag, ngm, dict(kind="block", hc=hc, hb=hb, hmax=hmax, grading=grading))


def project_circle(q):
    d = q - CENTRE
    return CENTRE + d / np.linalg.norm(d, axis=-1, keepdims=True)


def edge_table(t):
    """Unique edges (sorted vertex pairs) and, per triangle, the edge ids of (v0v1, v1v2, v2v0)."""
    e = np.stack([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]], axis=1)  # (M,3,2)
    es = np.sort(e, axis=2).reshape(-1, 2)
    uniq, inv = np.unique(es, axis=0, return_inverse=True)
    return uniq, inv.reshape(-1, 3)
