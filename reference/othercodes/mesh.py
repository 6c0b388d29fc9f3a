"""The Hertz half-disc mesh shared by the DOLFINx and MFEM runs, as a gmsh 2.2 ASCII file.

Made in reference/.venv (Python 3.11, netgen) by reference/hertz/geometry.half_disc, i.e. exactly the
mesh of the committed fixtures/hertz_* cases (same parameters, netgen is deterministic), so the
numbers are comparable with hertz_skfem_p2 / hertz_ngsolve_p2 node for node.

P2 file: 6-node triangles (gmsh type 9) and 3-node lines (type 8); the mid node of every arc edge
(tags 1 and 3) is projected onto the circle |x - (0, 1)| = 1, interior and top mid nodes are edge
mid points (mesh MESH_P2).  P1 file (finer mesh MESH_P1): 3-node triangles (type 2) and 2-node lines (type 1), straight edges.
Physical tags: triangles 1 (MFEM element attribute 1); lines 1 = Gamma_C (arc, y <= 1/2),
2 = top (y = 1), 3 = arc above y = 1/2 (MFEM boundary attributes).
"""
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "hertz"))
import geometry as G  # noqa: E402

MESH_P2 = dict(hc=0.004, hmax=0.1, grading=0.3)  # = reference/hertz/make.py MESH_A (775 triangles)
MESH_P1 = dict(hc=0.003, hmax=0.05, grading=0.2)  # 2285 triangles: P1 needs a finer contact zone and far field


def p2_arrays(tm):
    """P2 nodes (vertices first, then one mid node per edge), triangles (v0 v1 v2 m01 m12 m20) and
    boundary lines (a b m), mid nodes of arc edges on the circle."""
    Nv = len(tm.p)
    uniq, tri_e = G.edge_table(tm.t)
    mids = 0.5 * (tm.p[uniq[:, 0]] + tm.p[uniq[:, 1]])
    eid = {(int(a), int(b)): k for k, (a, b) in enumerate(uniq)}
    bid = np.array([eid[tuple(sorted((int(a), int(b))))] for a, b in tm.be])
    curved = bid[np.isin(tm.btag, (G.TAG_CONTACT, G.TAG_FREE))]
    mids[curved] = G.project_circle(mids[curved])
    nodes = np.vstack([tm.p, mids])
    cells = np.hstack([tm.t, Nv + tri_e])
    lines = np.hstack([tm.be, (Nv + bid)[:, None]])
    return nodes, cells, lines


def write_msh(path, nodes, cells, lines, line_tags):
    quad = cells.shape[1] == 6
    ttype, ltype = (9, 8) if quad else (2, 1)
    out = ["$MeshFormat", "2.2 0 8", "$EndMeshFormat", "$Nodes", str(len(nodes))]
    out += [f"{i + 1} {x!r} {y!r} 0" for i, (x, y) in enumerate(nodes.tolist())]
    out += ["$EndNodes", "$Elements", str(len(lines) + len(cells))]
    k = 1
    for ln, tg in zip(lines.tolist(), np.asarray(line_tags).tolist()):
        out.append(f"{k} {ltype} 2 {tg} {tg} " + " ".join(str(v + 1) for v in ln))
        k += 1
    for c in cells.tolist():
        out.append(f"{k} {ttype} 2 1 1 " + " ".join(str(v + 1) for v in c))
        k += 1
    out += ["$EndElements", ""]
    Path(path).write_text("\n".join(out))


def make(outdir):
    """Write half_disc_p1.msh and half_disc_p2.msh into outdir; returns mesh facts."""
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    facts = {}
    t1 = G.half_disc(**MESH_P1)
    write_msh(outdir / "half_disc_p1.msh", t1.p, t1.t, t1.be, t1.btag)
    facts["half_disc_p1.msh"] = dict(parameters=MESH_P1, nodes=int(len(t1.p)), triangles=int(len(t1.t)),
                                     boundary_edges=int(len(t1.be)))
    t2 = G.half_disc(**MESH_P2)
    n2, c2, l2 = p2_arrays(t2)
    write_msh(outdir / "half_disc_p2.msh", n2, c2, l2, t2.btag)
    facts["half_disc_p2.msh"] = dict(parameters=MESH_P2, vertices=int(len(t2.p)), nodes=int(len(n2)),
                                     triangles=int(len(t2.t)), boundary_edges=int(len(t2.be)))
    return facts


if __name__ == "__main__":
    print(make(sys.argv[1] if len(sys.argv) > 1 else "."))
