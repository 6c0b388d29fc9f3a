//! The bound on meshes with quadrilateral cells (docs/design.md §6.3): computed on a
//! triangle split.
//!
//! [`Pattern::Lattice`]: every quadrilateral is cut along a diagonal into two halves (straight,
//! or isoparametric P2 with the cell's edge nodes and the chord midpoint on the diagonal when
//! the cell is curved, as [`crate::geometry::values::sub_nodes`] cuts it from vertex 0 to 2; here
//! the diagonal from 1 to 3 where that gives much better angles), and every cell becomes a P2
//! triangle. [`Pattern::Cross`]: every quadrilateral into four P2 triangles about the image of
//! its reference centre, each on one whole edge of the parent (the same argument for the traces
//! below holds), where the P2 interpolant of a biquadratic field is about 3× closer.
//! The displacement on the halves is ũ_h, the P2 interpolant of u_h at their nodes. The
//! patch equilibration and the bound of §6 then run on this triangle mesh, and
//!
//! ```text
//! |||u − u_h||| ≤ |||u − ũ_h||| + |||ũ_h − u_h|||
//! ```
//!
//! adds the interpolation distance, computed here by quadrature on the halves.
//!
//! On a P1 triangle mesh [`Pattern::Lattice`] with one sub-square is the P2 elevation (every
//! cell one P2 triangle, ũ_h = u_h), on which `bound` lifts the mid-edge nodes of contact
//! edges that cross the obstacle between their vertices (docs/design.md §6.2, "Between nodes").
//!
//! Why ũ_h keeps the admissibility of u_h: on every edge of the quadrilateral mesh the trace
//! of u_h is a polynomial of degree ≤ 2 in the edge's own parameter (Q1: linear; Q2 and the
//! serendipity element: quadratic), and the half's edge carries the same nodes with the same
//! parametrisation, so the P2 interpolant has the same trace. Non-penetration, the Dirichlet
//! data and the complementarity pairing are those of u_h. Only the interior changes: on a
//! parallelogram a Q1 field is a quadratic polynomial and ũ_h = u_h exactly; on other cells
//! the distance is what the bound pays for the split.

use std::path::Path;

use crate::geometry::values::{SubPoint, invert, jacobian, sub_point};
use crate::geometry::{Family, MAX_NODES, Shape};
use crate::mesh::{Dataset, Mesh, MeshReport, NONE};
use crate::problem::{BoundaryEdge, Context};
use crate::quadrature::triangle_rule_cached;
use crate::topology::Topology;

/// The triangle split of a mesh and the displacement on it.
pub struct Halves {
    pub data: Dataset,
    pub topo: Topology,
    /// The parent's boundary edges, each as the sub-edges that cover it, ascending by edge.
    pub edges: Vec<BoundaryEdge>,
    /// ũ_h at the split's nodes (the parent's points first, in their order).
    pub u: Vec<[f64; 2]>,
    /// The parent cell of each triangle (ascending).
    pub parent: Vec<u32>,
    /// The parent reference coordinates of each triangle's vertices: ξ_parent = r₀ + ξ̂₀(r₁ −
    /// r₀) + ξ̂₁(r₂ − r₀) is the starting guess of the inverse map at its point ξ̂ (exact on
    /// affine parents).
    pub reference: Vec<[[f64; 2]; 3]>,
}

/// Sub-squares per side of each quadrilateral in the split (`split`'s `m`): 1, the two halves.
///
/// Measured against m = 3 on the manufactured family (exact solution known): ũ_h, the P2
/// interpolant of a Q2 or serendipity field, misses it by O(h_sub²), and with the halves alone
/// the distance is 1.35–1.40 × the true error (index 3.0–3.3 on Q2 and S2), against 0.15 ×
/// with m = 3 (index 1.96–2.51). But m > 1 puts new nodes on the boundary edges, where ũ_h
/// takes u_h's trace between the parent's nodes: the nodal admissibility that u_h meets only at
/// its own nodes then fails there (penetration up to 4.5e-6 on the Hertz Q2 file, the
/// Dirichlet expression missed by up to 4.4e-5), the bound loses its guarantee and the
/// Prager–Synge term of the Hertz Q2 file rose from 0.031 to 0.145. `split` builds any m.
pub const SUB_SQUARES: usize = 1;

/// How [`split`] cuts the cells.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Pattern {
    /// Every quadrilateral into four triangles about the image of its reference centre, each
    /// on one whole edge of the parent; triangles stay whole.
    Cross,
    /// m × m sub-squares per quadrilateral, each cut along a diagonal, and m² sub-triangles
    /// per triangle (m = [`SUB_SQUARES`]: the two halves).
    Lattice(usize),
}

/// The lattice point (a, b) of a cell on the reference grid of spacing 1/(2m) (the nodes of
/// its P2 sub-triangles), in the parent's reference coordinates.
fn lattice_point(a: usize, b: usize, m: usize) -> [f64; 2] {
    let d = (2 * m) as f64;
    [a as f64 / d, b as f64 / d]
}

/// The parent edge under lattice point (a, b) of a cell with `nv` vertices and its local
/// parameter there (from local vertex l to l + 1), or `None` off the edges and at vertices.
fn on_edge(a: usize, b: usize, n2: usize, nv: usize) -> Option<(usize, usize)> {
    let corner = |x: usize, y: usize| (x == 0 || x == n2) && (y == 0 || y == n2);
    if nv == 4 {
        if corner(a, b) {
            return None;
        }
        match (a, b) {
            (_, 0) => Some((0, a)),
            (x, _) if x == n2 => Some((1, b)),
            (_, y) if y == n2 => Some((2, n2 - a)),
            (0, _) => Some((3, n2 - b)),
            _ => None,
        }
    } else {
        if (a, b) == (0, 0) || (a, b) == (n2, 0) || (a, b) == (0, n2) {
            return None;
        }
        if b == 0 {
            Some((0, a))
        } else if a + b == n2 {
            Some((1, b))
        } else if a == 0 {
            Some((2, n2 - b))
        } else {
            None
        }
    }
}

/// The least angle of the triangle `p` (radians).
fn least_angle(p: [[f64; 2]; 3]) -> f64 {
    (0..3)
        .map(|k| {
            let (o, a, b) = (p[k], p[(k + 1) % 3], p[(k + 2) % 3]);
            let (u, v) = ([a[0] - o[0], a[1] - o[1]], [b[0] - o[0], b[1] - o[1]]);
            (u[0] * v[1] - u[1] * v[0])
                .abs()
                .atan2(u[0] * v[0] + u[1] * v[1])
        })
        .fold(f64::INFINITY, f64::min)
}

/// The triangle split of the mesh of `ctx` (P2 triangles; m × m sub-squares per
/// quadrilateral, each cut along its diagonal from corner 0 to 2, or from 1 to 3 where that
/// makes the least angle [`crate::tolerance::HALVES_FLIP_GAIN`] times larger, and m²
/// sub-triangles per triangle) and ũ_h of `u` on it (module doc; design §6.3).
///
/// Nodes on the parent's edges are computed once per edge, from the edge's own trace (linear,
/// or the quadratic through its mid node, the same curve and parametrisation every cell of a
/// conforming mesh has there), so neighbours share them and ũ_h keeps u_h's traces. Inside a
/// triangle every node is the image of its lattice point (a P2 map composed with an affine one
/// is P2: ũ_h = u_h and the geometry is exact). Inside a quadrilateral the sub-triangles'
/// vertices are images of lattice points and their other nodes are straight midpoints: the
/// sub-triangles are straight except along a curved parent edge, and ũ_h there is u_h at the
/// parent point found by the inverse map.
pub fn split(
    ctx: &Context,
    path: &Path,
    u: &[[f64; 2]],
    pattern: Pattern,
) -> Result<Halves, String> {
    let mesh = ctx.mesh;
    let topo = ctx.topo;
    let (m, cross) = match pattern {
        Pattern::Cross => (1, true),
        Pattern::Lattice(m) => (m.max(1), false),
    };
    let n2 = 2 * m;
    let mut points = mesh.points.clone();
    let mut uh = u.to_vec();
    // Nodes on each parent edge at global parameters j/(2m), j = 1 … 2m − 1.
    let mut edge_nodes: Vec<u32> = Vec::with_capacity(topo.edges.len() * (n2 - 1));
    for (e, &[a, b]) in topo.edges.iter().enumerate() {
        let (a, b) = (a as usize, b as usize);
        let mid = topo.edge_mid[e];
        for j in 1..n2 {
            if j == m && mid != NONE {
                edge_nodes.push(mid);
                continue;
            }
            let s = j as f64 / n2 as f64;
            let w: [f64; 3] = if mid == NONE {
                [1.0 - s, s, 0.0]
            } else {
                [
                    (1.0 - s) * (1.0 - 2.0 * s),
                    s * (2.0 * s - 1.0),
                    4.0 * s * (1.0 - s),
                ]
            };
            let c = if mid == NONE { 0 } else { mid as usize };
            let comb = |v: &[[f64; 2]]| {
                std::array::from_fn(|i| w[0] * v[a][i] + w[1] * v[b][i] + w[2] * v[c][i])
            };
            edge_nodes.push(points.len() as u32);
            points.push(comb(&mesh.points));
            uh.push(comb(u));
        }
    }
    let mut cells = Vec::with_capacity(2 * m * m * mesh.len());
    let mut parent = Vec::with_capacity(cells.capacity());
    let mut reference = Vec::with_capacity(cells.capacity());
    // (cell, local edge) of each triangle edge on parent edge l, per parent cell.
    let mut on_parent: Vec<[Vec<(u32, u8)>; 4]> = Vec::with_capacity(mesh.len());
    let mut lattice = vec![NONE; (n2 + 1) * (n2 + 1)];
    for t in 0..mesh.len() {
        let fam = mesh.family[t];
        let nodes = mesh.nodes(t);
        let x = mesh.coords(t);
        let n = fam.nodes();
        let nv = fam.vertices();
        let quad = fam.is_quad();
        let affine = mesh.shape[t] == Shape::Affine;
        let idx = |a: usize, b: usize| a * (n2 + 1) + b;
        let value = |xi: [f64; 2]| {
            let (phi, _) = fam.shape(xi);
            let mut r = [[0.0; 2]; 2];
            for (i, &p) in nodes.iter().enumerate() {
                for c in 0..2 {
                    r[0][c] += phi[i] * x[i][c];
                    r[1][c] += phi[i] * u[p as usize][c];
                }
            }
            (r[0], r[1])
        };
        // The parent point whose image is `target`, found from `guess` (exact on an affine
        // parent), or the reason the split cannot be built there.
        let locate = |target: [f64; 2], guess: [f64; 2]| -> Result<[f64; 2], String> {
            let xi = if affine {
                guess
            } else {
                invert(fam, &x[..n], target, guess)
            };
            let (back, _) = value(xi);
            let miss = (back[0] - target[0]).abs() + (back[1] - target[1]).abs();
            // The target, a mean of two coordinates, is known to ε|x|: a mesh far from
            // the origin (|x| = 3e4, cells of 1e-2) missed by 9e-12 after convergence.
            // A cell taken for a parallelogram misses one by up to CURVED_RELATIVE of its
            // size (mesh.rs), and its affine map is used everywhere else: so here too.
            let scale = crate::geometry::diameter(fam, &x[..n]);
            let relative = if affine {
                crate::tolerance::CURVED_RELATIVE
            } else {
                crate::tolerance::HALVES_DIAGONAL_MISS_RELATIVE
            };
            let level = relative * scale
                + crate::tolerance::COORDINATE_ROUNDOFF * (target[0].abs() + target[1].abs());
            if miss.is_nan() || miss > level {
                return Err(format!(
                    "cell {}: a node of its triangle split is not inside the cell (the \
                     inverse map missed it by {miss:.1e})",
                    mesh.file_cell[t]
                ));
            }
            Ok(xi)
        };
        if quad && cross {
            // Four triangles about the image c of the reference centre, triangle k on parent
            // edge k (corner k, corner k + 1, c): the parent edge's node is its mid node there
            // (curved with the parent), the nodes halfway to c are straight midpoints.
            let (pc, vc) = value([0.5, 0.5]);
            points.push(pc);
            uh.push(vc);
            let centre = (points.len() - 1) as u32;
            let square = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
            let mut halfway = [NONE; 4];
            for (k, r) in square.iter().enumerate() {
                let xk = points[nodes[k] as usize];
                let target = [0.5 * (xk[0] + pc[0]), 0.5 * (xk[1] + pc[1])];
                let xi = locate(target, [0.5 * (r[0] + 0.5), 0.5 * (r[1] + 0.5)])?;
                points.push(target);
                uh.push(value(xi).1);
                halfway[k] = (points.len() - 1) as u32;
            }
            let mut edges_here: [Vec<(u32, u8)>; 4] = Default::default();
            for k in 0..4 {
                let k1 = (k + 1) % 4;
                let mut cell = [NONE; MAX_NODES];
                cell[..6].copy_from_slice(&[
                    nodes[k],
                    nodes[k1],
                    centre,
                    edge_nodes[topo.cell_edges[t][k] as usize * (n2 - 1)],
                    halfway[k1],
                    halfway[k],
                ]);
                edges_here[k].push((cells.len() as u32, 0));
                cells.push(cell);
                parent.push(t as u32);
                reference.push([square[k], square[k1], [0.5, 0.5]]);
            }
            on_parent.push(edges_here);
            continue;
        }
        // The lattice: vertices, edge nodes, then the interior.
        for a in 0..=n2 {
            for b in 0..=n2 {
                if !quad && a + b > n2 {
                    continue;
                }
                let corner = match (quad, a, b) {
                    (_, 0, 0) => Some(0),
                    (_, x, 0) if x == n2 => Some(1),
                    (true, x, y) if x == n2 && y == n2 => Some(2),
                    (true, 0, y) if y == n2 => Some(3),
                    (false, 0, y) if y == n2 => Some(2),
                    _ => None,
                };
                let node = if let Some(v) = corner {
                    nodes[v]
                } else if let Some((l, sl)) = on_edge(a, b, n2, nv) {
                    let e = topo.cell_edges[t][l] as usize;
                    let j = if topo.cell_edge_sign[t][l] > 0 {
                        sl
                    } else {
                        n2 - sl
                    };
                    edge_nodes[e * (n2 - 1) + j - 1]
                } else if !quad || (a % 2 == 0 && b % 2 == 0) {
                    let (p, v) = value(lattice_point(a, b, m));
                    points.push(p);
                    uh.push(v);
                    (points.len() - 1) as u32
                } else {
                    NONE
                };
                lattice[idx(a, b)] = node;
            }
        }
        // Per sub-square, the diagonal of its two triangles: from corner 0 to 2, or from 1 to
        // 3 where that makes the least angle `HALVES_FLIP_GAIN` times larger (the Korn
        // constants of §6.2 grow as 2/sin(θ_min/4)).
        let mut flip = vec![false; m * m];
        if quad {
            for (i, j) in (0..m).flat_map(|i| (0..m).map(move |j| (i, j))) {
                let (a, b) = (2 * i, 2 * j);
                let c = [(a, b), (a + 2, b), (a + 2, b + 2), (a, b + 2)]
                    .map(|(p, q)| points[lattice[idx(p, q)] as usize]);
                let least = |t: [usize; 3], u: [usize; 3]| {
                    least_angle([c[t[0]], c[t[1]], c[t[2]]])
                        .min(least_angle([c[u[0]], c[u[1]], c[u[2]]]))
                };
                let (keep, other) = (least([0, 1, 2], [0, 2, 3]), least([0, 1, 3], [1, 2, 3]));
                flip[i * m + j] = other > keep * crate::tolerance::HALVES_FLIP_GAIN;
            }
        }
        if quad {
            // The straight midpoints inside: between the two lattice vertices of the sub-edge
            // (horizontal, vertical, or the sub-square's diagonal).
            for a in 1..n2 {
                for b in 1..n2 {
                    if a % 2 == 0 && b % 2 == 0 {
                        continue;
                    }
                    let (p, q) = match (a % 2, b % 2) {
                        (1, 0) => ((a - 1, b), (a + 1, b)),
                        (0, 1) => ((a, b - 1), (a, b + 1)),
                        _ if flip[(a / 2) * m + b / 2] => ((a + 1, b - 1), (a - 1, b + 1)),
                        _ => ((a - 1, b - 1), (a + 1, b + 1)),
                    };
                    let (xp, xq) = (
                        points[lattice[idx(p.0, p.1)] as usize],
                        points[lattice[idx(q.0, q.1)] as usize],
                    );
                    let target = [0.5 * (xp[0] + xq[0]), 0.5 * (xp[1] + xq[1])];
                    let xi = locate(target, lattice_point(a, b, m))?;
                    points.push(target);
                    uh.push(value(xi).1);
                    lattice[idx(a, b)] = (points.len() - 1) as u32;
                }
            }
        }
        let mut edges_here: [Vec<(u32, u8)>; 4] = Default::default();
        // A P2 triangle from its three lattice vertices (its mid nodes are the lattice
        // midpoints), with the parent edge under each of its local edges, if any.
        let mut push = |v: [(usize, usize); 3], on: [Option<usize>; 3]| {
            let mut cell = [NONE; MAX_NODES];
            for k in 0..3 {
                let (p, q) = (v[k], v[(k + 1) % 3]);
                cell[k] = lattice[idx(p.0, p.1)];
                cell[3 + k] = lattice[idx((p.0 + q.0) / 2, (p.1 + q.1) / 2)];
            }
            let index = cells.len() as u32;
            for (local, l) in on.iter().enumerate() {
                if let Some(l) = l {
                    edges_here[*l].push((index, local as u8));
                }
            }
            cells.push(cell);
            parent.push(t as u32);
            reference.push(v.map(|(a, b)| lattice_point(a, b, m)));
        };
        for i in 0..m {
            for j in 0..m {
                let (a, b) = (2 * i, 2 * j);
                if quad {
                    let corner = [(a, b), (a + 2, b), (a + 2, b + 2), (a, b + 2)];
                    // Side s of the sub-square (corner s to s + 1) on parent edge s, if any.
                    let side = [
                        (j == 0).then_some(0),
                        (i == m - 1).then_some(1),
                        (j == m - 1).then_some(2),
                        (i == 0).then_some(3),
                    ];
                    let halves: [[usize; 3]; 2] = if flip[i * m + j] {
                        [[0, 1, 3], [1, 2, 3]]
                    } else {
                        [[0, 1, 2], [0, 2, 3]]
                    };
                    for h in halves {
                        let on = std::array::from_fn(|k| {
                            let (p, q) = (h[k], h[(k + 1) % 3]);
                            if q == (p + 1) % 4 { side[p] } else { None }
                        });
                        push(h.map(|k| corner[k]), on);
                    }
                } else if i + j < m {
                    push(
                        [(a, b), (a + 2, b), (a, b + 2)],
                        [
                            (j == 0).then_some(0),
                            (i + j == m - 1).then_some(1),
                            (i == 0).then_some(2),
                        ],
                    );
                    if i + j + 1 < m {
                        push([(a + 2, b), (a + 2, b + 2), (a, b + 2)], [None; 3]);
                    }
                }
            }
        }
        on_parent.push(edges_here);
        lattice.iter_mut().for_each(|v| *v = NONE);
    }
    let family = vec![Family::Tri6; cells.len()];
    let shape = cells
        .iter()
        .map(|c| {
            let x: [[f64; 2]; 6] = std::array::from_fn(|k| points[c[k] as usize]);
            crate::geometry::classify(Family::Tri6, &x, crate::tolerance::CURVED_RELATIVE)
        })
        .collect();
    let file_cell = parent.iter().map(|&t| mesh.file_cell[t as usize]).collect();
    // The parent's line cells are whole edges of the split only when m = 1; the boundary
    // conditions are carried over edge by edge below, so the split needs none.
    let split_mesh = Mesh {
        points,
        degree: 2,
        cells,
        family,
        shape,
        lines: Vec::new(),
        file_cell,
        line_cell: Vec::new(),
    };
    let sub = Dataset {
        path: path.to_path_buf(),
        mesh: split_mesh,
        point_data: Vec::new(),
        cell_data: Vec::new(),
        line_data: Vec::new(),
        copies: Vec::new(),
        report: MeshReport::default(),
    };
    let sub_topo = crate::topology::build(&sub).map_err(|e| e.to_string())?;
    let mut edges: Vec<BoundaryEdge> = ctx
        .edges
        .iter()
        .flat_map(|be| {
            on_parent[be.cell as usize][be.local as usize]
                .iter()
                .map(|&(cell, local)| BoundaryEdge {
                    edge: sub_topo.cell_edges[cell as usize][local as usize],
                    cell,
                    local,
                    line: NONE,
                    condition: be.condition,
                })
                .collect::<Vec<_>>()
        })
        .collect();
    edges.sort_by_key(|be| be.edge);
    if let Some(be) = edges
        .iter()
        .find(|be| !sub_topo.is_boundary(be.edge as usize))
    {
        return Err(format!(
            "cell {}: a boundary edge of the mesh is interior to its triangle split",
            sub.mesh.file_cell[be.cell as usize]
        ));
    }
    Ok(Halves {
        data: sub,
        topo: sub_topo,
        edges,
        u: uh,
        parent,
        reference,
    })
}

/// Degree of the rule of [`distance`]: on a parallelogram u_h is a polynomial of degree ≤ 4
/// (Q2), so |ε(ũ_h − u_h)|² has degree ≤ 6; on other cells it is rational, and the rule is
/// taken well above that: on the Hertz Q1 file (cells down to det J = 4.7e-6) ½|||u_h|||² was
/// 2.9e-7 off the reference's with degree 12, 7e-10 with degree 20.
const DISTANCE_DEGREE_AFFINE: usize = 6;
pub(crate) const DISTANCE_DEGREE_OTHER: usize = 20;

/// |||ũ_h − u_h||| = (Σ_T (Cε(ũ_h − u_h), ε(ũ_h − u_h))_T)^½ over the split of the
/// quadrilaterals (zero on triangles, where ũ_h is u_h), with u_h at each point through the
/// inverse map of its parent, and ½|||u_h|||² (the reference of the bound's `relative`), by
/// the same quadrature.
pub fn distance(ctx: &Context, shift: &Shift) -> (f64, f64) {
    let (d2, energy) = distance_squares(ctx, shift)
        .iter()
        .fold((0.0, 0.0), |(a, b), &(d, e)| (a + d, b + e));
    (d2.max(0.0).sqrt(), energy)
}

/// Per triangle T of the split: ((Cε(ũ_h − u_h), ε(ũ_h − u_h))_T, ½(Cε(u_h), ε(u_h))_T)
/// ([`distance`]).
fn distance_squares(ctx: &Context, shift: &Shift) -> Vec<(f64, f64)> {
    use rayon::prelude::*;
    let sub = &shift.halves.data.mesh;
    let el = ctx.elastic;
    let density = |g: [[f64; 2]; 2]| {
        let sym = 0.5 * (g[0][1] + g[1][0]);
        let eps = [g[0][0], sym, sym, g[1][1]];
        let st = el.stress(eps);
        (0..4).map(|i| st[i] * eps[i]).sum::<f64>()
    };
    (0..sub.len())
        .into_par_iter()
        .with_min_len(256)
        .map(|s| {
            let deg = if shift.polynomial(s) {
                DISTANCE_DEGREE_AFFINE
            } else {
                DISTANCE_DEGREE_OTHER
            };
            let rule = triangle_rule_cached(deg);
            let (mut d2, mut energy) = (0.0, 0.0);
            for (&xi, &wq) in rule.points.iter().zip(&rule.weights) {
                let (w, gh, gp) = shift.gradients(s, xi);
                let w = wq * w;
                let d = std::array::from_fn(|a| std::array::from_fn(|b| gh[a][b] - gp[a][b]));
                d2 += w * density(d);
                energy += 0.5 * w * density(gp);
            }
            (d2, energy)
        })
        .collect()
}

/// u_h − ũ_h on the triangle split, for the bound taken with the file's u_h itself (design
/// §6.3, "u_h itself"): the stress equilibrated on the split is admissible for the parent
/// problem whatever displacement it is paired with, and on every parent edge ũ_h has u_h's
/// trace, so the Prager–Synge term can pair it with Cε(u_h) = Cε(ũ_h) + Cε(u_h − ũ_h) and no
/// distance is added. u_h at a split point is evaluated through the inverse map of its parent.
pub struct Shift<'a> {
    mesh: &'a Mesh,
    halves: &'a Halves,
    u: &'a [[f64; 2]],
    /// Per split cell under a parent that is not a parallelogram, the parent reference points
    /// of its three mid nodes (zeros elsewhere): with its vertices' (`Halves::reference`) they
    /// give the P2 interpolant of the inverse map, the first guess of Newton's method at its
    /// points (two or three steps instead of four or five from the affine guess).
    mids: Vec<[[f64; 2]; 3]>,
}

impl<'a> Shift<'a> {
    /// The shift of `u` (nodal values on `mesh`, the parent) on `halves`, its split.
    pub fn new(mesh: &'a Mesh, halves: &'a Halves, u: &'a [[f64; 2]]) -> Shift<'a> {
        use rayon::prelude::*;
        let sub = &halves.data.mesh;
        let mids = (0..sub.len())
            .into_par_iter()
            .with_min_len(256)
            .map(|s| {
                let t = halves.parent[s] as usize;
                let fam = mesh.family[t];
                if !fam.is_quad() || mesh.shape[t] == Shape::Affine {
                    return [[0.0; 2]; 3];
                }
                let (x, xs) = (mesh.coords(t), sub.coords(s));
                let r = halves.reference[s];
                // Tri6 mid nodes 3, 4, 5 lie on the edges (0, 1), (1, 2), (2, 0).
                std::array::from_fn(|j| {
                    let (a, b) = (r[j], r[(j + 1) % 3]);
                    let guess = [0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1])];
                    invert(fam, &x[..fam.nodes()], xs[3 + j], guess)
                })
            })
            .collect();
        Shift {
            mesh,
            halves,
            u,
            mids,
        }
    }

    /// Whether ũ_h = u_h everywhere: every quadrilateral is a Q1 parallelogram (a bilinear
    /// field is a quadratic polynomial there) or there is none.
    pub fn vanishes(&self) -> bool {
        (self.mesh.family.iter().zip(&self.mesh.shape))
            .all(|(f, &sh)| !f.is_quad() || (*f == Family::Quad4 && sh == Shape::Affine))
    }

    /// Whether u_h is a polynomial on split cell `s` (a triangle parent, or a parallelogram
    /// under a straight sub-triangle): then its integrals with polynomial stresses are exact
    /// with the polynomial rules; elsewhere u_h is rational in the split's coordinates.
    pub fn polynomial(&self, s: usize) -> bool {
        let t = self.halves.parent[s] as usize;
        self.mesh.shape[t] == Shape::Affine && self.halves.data.mesh.shape[s] == Shape::Affine
    }

    /// Whether the shift is rational on split cell `s`: a quadrilateral parent that is not a
    /// parallelogram, or a curved sub-triangle of one (on a triangle parent it is 0).
    pub fn rational(&self, s: usize) -> bool {
        let t = self.halves.parent[s] as usize;
        self.mesh.family[t].is_quad() && !self.polynomial(s)
    }

    /// ∇(u_h − ũ_h) at `sp`, a point of split cell `s` (its own map's point).
    pub fn gradient(&self, s: usize, sp: &SubPoint) -> [[f64; 2]; 2] {
        if !self.mesh.family[self.halves.parent[s] as usize].is_quad() {
            // ũ_h is u_h on a triangle parent (module doc).
            return [[0.0; 2]; 2];
        }
        let gh = sp.gradient_at(self.halves.data.mesh.nodes(s), &self.halves.u);
        let gp = self.parent_gradient(s, sp.xi, sp.x);
        std::array::from_fn(|a| std::array::from_fn(|b| gp[a][b] - gh[a][b]))
    }

    /// (det J of the split cell, ∇ũ_h, ∇u_h) at reference point `xi` of split cell `s`; on a
    /// triangle parent ũ_h is u_h (module doc).
    fn gradients(&self, s: usize, xi: [f64; 2]) -> (f64, [[f64; 2]; 2], [[f64; 2]; 2]) {
        let (mesh, sub) = (self.mesh, &self.halves.data.mesh);
        let t = self.halves.parent[s] as usize;
        let fam = mesh.family[t];
        let xs = sub.coords(s);
        let half = sub_point(Family::Tri6, &xs[..6], sub.shape[s], 0, xi);
        let gh = half.gradient_at(sub.nodes(s), &self.halves.u);
        if !fam.is_quad() {
            return (half.jac.det, gh, gh);
        }
        (half.jac.det, gh, self.parent_gradient(s, xi, half.x))
    }

    /// ∇u_h at the point `target` of split cell `s`, `xi` its reference point there, through
    /// the inverse map of the parent quadrilateral.
    fn parent_gradient(&self, s: usize, xi: [f64; 2], target: [f64; 2]) -> [[f64; 2]; 2] {
        let mesh = self.mesh;
        let t = self.halves.parent[s] as usize;
        let fam = mesh.family[t];
        let x = mesh.coords(t);
        let n = fam.nodes();
        let [r0, r1, r2] = self.halves.reference[s];
        let xp = if mesh.shape[t] == Shape::Affine {
            std::array::from_fn(|c| r0[c] + xi[0] * (r1[c] - r0[c]) + xi[1] * (r2[c] - r0[c]))
        } else {
            let [m01, m12, m20] = self.mids[s];
            let (w, _) = Family::Tri6.shape(xi);
            let r = [r0, r1, r2, m01, m12, m20];
            let guess = std::array::from_fn(|c| (0..6).map(|i| w[i] * r[i][c]).sum());
            invert(fam, &x[..n], target, guess)
        };
        let (_, g) = fam.shape(xp);
        let jp = jacobian(&x[..n], n, &g);
        let mut gp = [[0.0; 2]; 2];
        for (i, &p) in mesh.nodes(t).iter().enumerate() {
            let gi = jp.physical_gradient(g[i]);
            for (ga, ua) in gp.iter_mut().zip(self.u[p as usize]) {
                ga[0] += ua * gi[0];
                ga[1] += ua * gi[1];
            }
        }
        gp
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Norm;

    /// Splits of the exact fixtures, whose fields are at most quadratic: the finer lattice (m =
    /// 3, not a default) on the mixed P2/Q2 mesh, with 2m² triangles per quadrilateral and m² per
    /// triangle, and the four triangles about each centre on the mixed, curved Q2 and
    /// serendipity meshes, with 4 per quadrilateral and the triangles whole. Each is conforming
    /// (its topology builds), covers the fixture's area (expected.json, from reference/quads;
    /// Σ det J through the P2 maps, curved ones too), ũ_h is u_h (split term at round-off), and
    /// ½|||u_h|||² is the reference's.
    #[test]
    fn the_splits_tile_the_cells_and_keep_a_quadratic_field() {
        let rule = triangle_rule_cached(4);
        for (case, pattern) in [
            ("quad_exact_mixed_p2q2_energy", Pattern::Lattice(3)),
            ("quad_exact_mixed_p2q2_energy", Pattern::Cross),
            ("quad_exact_q2_curved_energy", Pattern::Cross),
            ("quad_exact_s2_energy", Pattern::Cross),
        ] {
            let fx = crate::problem::fixture(case);
            let ctx = fx.context(Norm::Energy);
            let u = fx.displacement();
            let halves = split(&ctx, &fx.data.path, &u, pattern).expect("a split");
            let mesh = ctx.mesh;
            let quads = mesh.family.iter().filter(|f| f.is_quad()).count();
            if case.contains("mixed") {
                assert!(quads > 0 && quads < mesh.len(), "a mixed mesh");
            }
            let sub = &halves.data.mesh;
            let (per_quad, per_triangle) = match pattern {
                Pattern::Lattice(m) => (2 * m * m, m * m),
                Pattern::Cross => (4, 1),
            };
            assert_eq!(
                sub.len(),
                per_quad * quads + per_triangle * (mesh.len() - quads),
                "{case} {pattern:?}"
            );
            let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                .join(format!("fixtures/{case}/expected.json"));
            let expected: serde_json::Value =
                serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
            let area: f64 = (0..sub.len())
                .map(|s| {
                    let x = sub.coords(s);
                    rule.points
                        .iter()
                        .zip(&rule.weights)
                        .map(|(&xi, &w)| {
                            w * sub_point(Family::Tri6, &x[..6], sub.shape[s], 0, xi)
                                .jac
                                .det
                        })
                        .sum::<f64>()
                })
                .sum();
            let reference = expected["energy"]["area"].as_f64().unwrap();
            assert!(
                ((area - reference) / reference).abs() < 1e-13,
                "{case} {pattern:?}: {area} against {reference}"
            );
            let (d, energy) = distance(&ctx, &Shift::new(ctx.mesh, &halves, &u));
            let reference = expected["energy"]["energy"].as_f64().unwrap();
            assert!(
                d < 1e-12 * reference.sqrt(),
                "{case} {pattern:?}: |||ũ_h − u_h||| = {d:e}"
            );
            assert!(
                ((energy - reference) / reference).abs() < 1e-12,
                "{case} {pattern:?}: {energy} against {reference}"
            );
        }
    }

    /// The Hertz Q1 file's cells are bilinear (no parallelograms): the split covers the same
    /// area (shoelace areas of the quadrilaterals against Σ det J/2 of the halves), and the
    /// split term agrees with an independent integration of the same density over each parent
    /// in its own reference square (a composite 4 × 4 Gauss rule on 48 × 48 sub-squares, the
    /// half located by its affine inverse).
    #[test]
    fn the_split_term_matches_an_integration_over_the_parent() {
        let fx = crate::problem::fixture("quad_hertz_skfem_q1");
        let ctx = fx.context(Norm::Energy);
        let u = fx.displacement();
        let halves =
            split(&ctx, &fx.data.path, &u, Pattern::Lattice(SUB_SQUARES)).expect("a split");
        let mesh = ctx.mesh;
        assert!(
            mesh.shape
                .iter()
                .all(|&s| s == Shape::Bilinear || s == Shape::Affine)
        );
        let shoelace: f64 = (0..mesh.len())
            .map(|t| {
                let x = mesh.coords(t);
                0.5 * (0..4)
                    .map(|i| {
                        let (a, b) = (x[i], x[(i + 1) % 4]);
                        a[0] * b[1] - a[1] * b[0]
                    })
                    .sum::<f64>()
            })
            .sum();
        let sub = &halves.data.mesh;
        let halves_area: f64 = (0..sub.len()).map(|s| 0.5 * sub.double_area(s)).sum();
        assert!(
            ((halves_area - shoelace) / shoelace).abs() < 1e-13,
            "{halves_area} against {shoelace}"
        );
        let squares: Vec<f64> = distance_squares(&ctx, &Shift::new(ctx.mesh, &halves, &u))
            .iter()
            .map(|p| p.0)
            .collect();
        let gauss = [
            (0.5 - 0.430_568_155_797_026_3, 0.173_927_422_568_726_9),
            (0.5 - 0.169_990_521_792_428_1, 0.326_072_577_431_273_1),
            (0.5 + 0.169_990_521_792_428_1, 0.326_072_577_431_273_1),
            (0.5 + 0.430_568_155_797_026_3, 0.173_927_422_568_726_9),
        ];
        let n = 48;
        let el = ctx.elastic;
        let mut checked = 0;
        for t in (0..mesh.len()).step_by(40) {
            let fam = mesh.family[t];
            let x = mesh.coords(t);
            let first = halves.parent.partition_point(|&p| (p as usize) < t);
            let mine = squares[first] + squares[first + 1];
            let mut other = 0.0;
            for (i, j) in (0..n).flat_map(|i| (0..n).map(move |j| (i, j))) {
                for &(gx, wx) in &gauss {
                    for &(gy, wy) in &gauss {
                        let xi = [(i as f64 + gx) / n as f64, (j as f64 + gy) / n as f64];
                        let (phi, g) = fam.shape(xi);
                        let jq = jacobian(&x[..4], 4, &g);
                        let p = crate::geometry::values::position(&x[..4], 4, &phi);
                        let mut gp = [[0.0; 2]; 2];
                        for (k, &node) in mesh.nodes(t).iter().enumerate() {
                            let gk = jq.physical_gradient(g[k]);
                            for a in 0..2 {
                                gp[a][0] += u[node as usize][a] * gk[0];
                                gp[a][1] += u[node as usize][a] * gk[1];
                            }
                        }
                        // The half holding p (the diagonal is 0–2 or 1–3), ξ_sub by its
                        // affine inverse.
                        let (s, y, xs) = (first..first + 2)
                            .map(|s| {
                                let y = sub.coords(s);
                                let m = [
                                    [y[1][0] - y[0][0], y[2][0] - y[0][0]],
                                    [y[1][1] - y[0][1], y[2][1] - y[0][1]],
                                ];
                                let det = m[0][0] * m[1][1] - m[0][1] * m[1][0];
                                let q = [p[0] - y[0][0], p[1] - y[0][1]];
                                let xs = [
                                    (m[1][1] * q[0] - m[0][1] * q[1]) / det,
                                    (-m[1][0] * q[0] + m[0][0] * q[1]) / det,
                                ];
                                (s, y, xs)
                            })
                            .find(|(_, _, xs)| xs[0].min(xs[1]).min(1.0 - xs[0] - xs[1]) > -1e-12)
                            .expect("a half holds the point");
                        let half = sub_point(Family::Tri6, &y[..6], sub.shape[s], 0, xs);
                        let gh = half.gradient_at(sub.nodes(s), &halves.u);
                        let e = [
                            gh[0][0] - gp[0][0],
                            0.5 * (gh[0][1] - gp[0][1] + gh[1][0] - gp[1][0]),
                            0.5 * (gh[0][1] - gp[0][1] + gh[1][0] - gp[1][0]),
                            gh[1][1] - gp[1][1],
                        ];
                        let st = el.stress(e);
                        let w = wx * wy * jq.det / (n * n) as f64;
                        other += w * (0..4).map(|c| st[c] * e[c]).sum::<f64>();
                    }
                }
            }
            if other > 0.0 {
                checked += 1;
                assert!(
                    ((mine - other) / other).abs() < 2e-3,
                    "cell {t}: split term² {mine:e} against {other:e}"
                );
            }
        }
        assert!(checked > 10, "{checked} cells with a split term");
        // ½|||u_h|||² by the split's quadrature against the fixture's reference value
        // (reference/quads, expected.json `energy`).
        let (d, energy) = distance(&ctx, &Shift::new(ctx.mesh, &halves, &u));
        assert!(d > 0.0);
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("fixtures/quad_hertz_skfem_q1/expected.json");
        let expected: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
        let own = expected["energy"]["energy"].as_f64().unwrap();
        assert!(
            ((energy - own) / own).abs() < 1e-8,
            "{energy} against {own}"
        );
    }
}
