"""CalculiX input decks for the Hertz problem (plane strain CPE6), made in reference/.venv (netgen).

Disc: the netgen half disc of reference/hertz/geometry.half_disc with the parameters of the committed
`hertz_*` fixtures (hc = 0.004 on the arc for |x| <= 0.12, maxh 0.1, grading 0.3: 775 triangles,
445 vertices, 1664 P2 nodes), made quadratic by reference/othercodes/mesh.p2_arrays (arc mid nodes on
the circle) and written as CPE6 (corner nodes counter-clockwise, then the mid nodes of 1-2, 2-3, 3-1:
CalculiX's and VTK's order).  Node numbers 1..1664, element numbers 1..775 (netgen order).

Foundation (two-body deck): the block [-XB - XS, XB - XS] x [-YB, 0], a structured grid of NX x NY
rectangles, each split into two CPE6 triangles; shifted by XS = half the node spacing, so no block node
coincides with the disc's vertex (0, 0) (closest block nodes (+-0.005, 0)).  Node numbers from 10001,
element numbers from 10001.

Rigid plane (one-body decks): FOUNDATION_POINTS fixed nodes on y = 0 (no elements), the dependent
(slave) side of a node-to-face contact pair whose independent (master) side is the disc's contact
arc.  CalculiX writes only nodes that belong to elements into the .frd, so the .frd and the VTU hold
the disc alone.
"""
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "hertz"))
import geometry as G  # noqa: E402


def _othercodes_mesh():
    """reference/othercodes/mesh.py (p2_arrays, MESH_P2), loaded under its own name."""
    import importlib.util
    spec = importlib.util.spec_from_file_location("othercodes_mesh", HERE.parent / "othercodes" / "mesh.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


OM = _othercodes_mesh()

MESH = dict(OM.MESH_P2)           # hc 0.004, hmax 0.1, grading 0.3
XB, YB, NX, NY = 0.25, 0.1, 25, 5  # block [-0.255, 0.245] x [-0.1, 0], edges 0.02 x 0.02
XS = 0.25 * (2 * XB / NX)          # 0.005: half the node spacing (nodes every 0.01)
BLOCK_NODE0, BLOCK_ELEM0 = 10001, 10001
PLANE_NODE0 = 20001
FOUNDATION_POINTS = dict(x_max=0.16, spacing=0.001)  # rigid plane nodes x = -0.16 .. 0.16


def disc():
    """-> dict(nodes (N,2), cells (M,6) 0-based, lines (K,3), line_tags (K,), facts)."""
    tm = G.half_disc(**MESH)
    nodes, cells, lines = OM.p2_arrays(tm)
    return dict(nodes=nodes, cells=cells, lines=lines, line_tags=np.asarray(tm.btag),
                facts=dict(parameters=MESH, vertices=int(len(tm.p)), nodes=int(len(nodes)),
                           triangles=int(len(cells)), boundary_edges=int(len(lines))))


def block():
    """Structured CPE6 block: nodes on a (2 NX + 1) x (2 NY + 1) grid, every rectangle split along
    its diagonal from lower left to upper right."""
    xs = np.linspace(-XB, XB, 2 * NX + 1) - XS
    ys = np.linspace(-YB, 0.0, 2 * NY + 1)
    X, Y = np.meshgrid(xs, ys, indexing="ij")
    nodes = np.stack([X.ravel(), Y.ravel()], axis=1)
    nid = lambda i, j: i * (2 * NY + 1) + j
    cells = []
    for i in range(NX):
        for j in range(NY):
            a, b, c, d = (2 * i, 2 * j), (2 * i + 2, 2 * j), (2 * i + 2, 2 * j + 2), (2 * i, 2 * j + 2)
            mid = lambda p, q: ((p[0] + q[0]) // 2, (p[1] + q[1]) // 2)
            for t in ((a, b, c), (a, c, d)):
                cells.append([nid(*t[0]), nid(*t[1]), nid(*t[2]),
                              nid(*mid(t[0], t[1])), nid(*mid(t[1], t[2])), nid(*mid(t[2], t[0]))])
    cells = np.array(cells, dtype=np.int64)
    top = np.array([k for k in range(len(cells)) if np.allclose(nodes[cells[k, [2, 1]], 1], 0.0)
                    or np.allclose(nodes[cells[k, [1, 2]], 1], 0.0)], dtype=np.int64)
    return dict(nodes=nodes, cells=cells, facts=dict(x=[-XB - XS, XB - XS], y=[-YB, 0.0], nx=NX, ny=NY,
                                                     nodes=int(len(nodes)), triangles=int(len(cells))))


def _faces(cells, nodes, pick):
    """(element index, face label S1..S3) of the element edges (0-1, 1-2, 2-0) whose two corner
    nodes satisfy pick(points (2, 2)) and that are used by one element only."""
    count = {}
    for k, c in enumerate(cells):
        for f, (a, b) in enumerate(((0, 1), (1, 2), (2, 0))):
            count.setdefault(tuple(sorted((int(c[a]), int(c[b])))), []).append((k, f + 1))
    out = []
    for key, uses in count.items():
        if len(uses) == 1 and pick(nodes[list(key)]):
            out.append(uses[0])
    return sorted(out)


def _num(v):
    """a float for a CalculiX data line: repr when it fits CalculiX's 20-character fields, else 14
    significant digits (the .frd stores 6 anyway)."""
    r = repr(float(v))
    return r if len(r) <= 20 else f"{v:.14g}"


def _fmt_nodes(ids, xy):
    return [f"{i}, {_num(x)}, {_num(y)}, 0.0" for i, (x, y) in zip(ids, xy.tolist())]


def _fmt_set(ids, per_line=16):
    ids = [str(int(i)) for i in ids]
    return [", ".join(ids[k:k + per_line]) + "," for k in range(0, len(ids), per_line)]


def deck(kind, penalty, tension, increment, friction=None, stick_slope=None, e_block=None, contact="NODE TO SURFACE"):
    """The .inp text and facts.  kind: 'plane' (disc + fixed nodes on y = 0, node-to-face, the
    plane nodes dependent, the disc arc independent) or 'block' (disc + elastic block, node-to-face,
    the disc arc nodes dependent, the block top independent)."""
    D = disc()
    nodes, cells = D["nodes"], D["cells"]
    nn = len(nodes)
    L = ["** Hertz contact, plane strain CPE6: lower half disc of radius 1 centred (0, 1), top y = 1 moved by (0, -0.01),",
         "** E = 20600, nu = 0.28, contact with the plane y = 0 on the arc below y = 1/2.",
         f"** Written by reference/calculix/make.py (mesh: netgen hc {MESH['hc']}, maxh {MESH['hmax']}, grading {MESH['grading']}).",
         "*HEADING", f"Hertz disc CPE6 {kind}", "*NODE, NSET=NDISC"]
    L += _fmt_nodes(range(1, nn + 1), nodes)
    L += ["*ELEMENT, TYPE=CPE6, ELSET=EDISC"]
    L += [f"{k + 1}, " + ", ".join(str(int(v) + 1) for v in c) for k, c in enumerate(cells)]
    top = np.nonzero(np.abs(nodes[:, 1] - 1.0) < 1e-12)[0] + 1
    L += ["*NSET, NSET=NTOP"] + _fmt_set(top)
    arc = _faces(cells, nodes, lambda p: bool(np.all(p[:, 1] <= 0.5 + 1e-12)))
    facts = dict(kind=kind, disc=D["facts"], top_nodes=int(len(top)), contact_faces=int(len(arc)), penalty_slope=penalty)
    if kind == "block":
        B = block()
        bn = np.arange(len(B["nodes"])) + BLOCK_NODE0
        L += ["*NODE, NSET=NBLOCK"] + _fmt_nodes(bn, B["nodes"])
        L += ["*ELEMENT, TYPE=CPE6, ELSET=EBLOCK"]
        L += [f"{k + BLOCK_ELEM0}, " + ", ".join(str(int(v) + BLOCK_NODE0) for v in c) for k, c in enumerate(B["cells"])]
        bottom = bn[np.abs(B["nodes"][:, 1] + YB) < 1e-12]
        L += ["*NSET, NSET=NBOTTOM"] + _fmt_set(bottom)
        btop = _faces(B["cells"], B["nodes"], lambda p: bool(np.all(np.abs(p[:, 1]) < 1e-12)))
        L += ["*SURFACE, NAME=SDISC, TYPE=ELEMENT"] + [f"{k + 1}, S{f}" for k, f in arc]
        L += ["*SURFACE, NAME=SBLOCK, TYPE=ELEMENT"] + [f"{k + BLOCK_ELEM0}, S{f}" for k, f in btop]
        facts.update(block=B["facts"], block_top_faces=int(len(btop)), block_bottom_nodes=int(len(bottom)),
                     e_block=e_block, slave="SDISC (disc arc faces, y <= 1/2)", master="SBLOCK (block top faces)")
        pair = "SDISC, SBLOCK"
    else:
        xp = np.arange(-FOUNDATION_POINTS["x_max"], FOUNDATION_POINTS["x_max"] + 1e-12, FOUNDATION_POINTS["spacing"])
        xp = np.round(xp, 12)
        pn = np.arange(len(xp)) + PLANE_NODE0
        L += ["*NODE, NSET=NPLANE"] + _fmt_nodes(pn, np.stack([xp, 0 * xp], axis=1))
        L += ["*SURFACE, NAME=SPLANE, TYPE=NODE", "NPLANE"]
        L += ["*SURFACE, NAME=SDISC, TYPE=ELEMENT"] + [f"{k + 1}, S{f}" for k, f in arc]
        facts.update(plane_nodes=int(len(pn)), plane_x=[float(xp[0]), float(xp[-1])],
                     plane_spacing=FOUNDATION_POINTS["spacing"],
                     slave="SPLANE (fixed nodes on y = 0, no elements)", master="SDISC (disc arc faces, y <= 1/2)")
        pair = "SPLANE, SDISC"
    L += ["*MATERIAL, NAME=DISC", "*ELASTIC", "20600.0, 0.28", "*SOLID SECTION, ELSET=EDISC, MATERIAL=DISC", "1.0"]
    if kind == "block":
        L += ["*MATERIAL, NAME=FOUNDATION", "*ELASTIC", f"{e_block!r}, 0.28",
              "*SOLID SECTION, ELSET=EBLOCK, MATERIAL=FOUNDATION", "1.0"]
    L += ["*SURFACE INTERACTION, NAME=SI", "*SURFACE BEHAVIOR, PRESSURE-OVERCLOSURE=LINEAR",
          f"{penalty!r}, {tension!r}" if contact == "NODE TO SURFACE" else f"{penalty!r}"]
    if friction is not None:
        L += ["*FRICTION", f"{friction!r}, {stick_slope!r}"]
        facts.update(friction=friction, stick_slope=stick_slope)
    facts.update(tension=tension if contact == "NODE TO SURFACE" else None, contact=contact, increment=increment)
    L += [f"*CONTACT PAIR, INTERACTION=SI, TYPE={contact}", pair]
    L += ["*BOUNDARY", "NTOP, 1, 1, 0.0", "NTOP, 2, 2, -0.01"]
    if kind == "block":
        L += ["NBOTTOM, 1, 2, 0.0"]
    else:
        L += ["NPLANE, 1, 3, 0.0"]  # all three: the plane nodes belong to no element (z not eliminated)
    # one step, automatic incrementation; output only at the end of the step (FREQUENCY larger
    # than the number of increments: CalculiX always writes the last increment of a step)
    fr = "FREQUENCY=1000"
    L += ["*STEP", "*STATIC", f"{increment!r}, 1.0", f"*NODE FILE, {fr}", "U, RF", f"*EL FILE, {fr}", "S",
          f"*CONTACT FILE, {fr}", "CDIS, CSTR",
          f"*NODE PRINT, NSET=NTOP, TOTALS=ONLY, {fr}", "RF",
          (f"*NODE PRINT, NSET=NBOTTOM, TOTALS=ONLY, {fr}" if kind == "block" else
           f"*NODE PRINT, NSET=NPLANE, TOTALS=YES, {fr}"), "RF",
          f"*CONTACT PRINT, {fr}", "CSTR, CDIS", "*END STEP", ""]
    return "\n".join(L), facts


if __name__ == "__main__":
    kind = sys.argv[1] if len(sys.argv) > 1 else "plane"
    txt, f = deck(kind, float(sys.argv[3]), 0.294, 0.05, e_block=2.06e8,
                  contact=sys.argv[4] if len(sys.argv) > 4 else "NODE TO SURFACE")
    Path(sys.argv[2] if len(sys.argv) > 2 else f"hertz_{kind}.inp").write_text(txt)
    print(f)
