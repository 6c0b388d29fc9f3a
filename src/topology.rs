//! Mesh topology, built once: edges, boundary edges, cell↔edge maps, edge orientation.
//!
//! Edge `e` joins vertices `edges[e] = [a, b]` with `a < b`; its global orientation runs from
//! `a` to `b`. Local edge `k` of a triangle joins local vertices `k` and `(k + 1) % 3` (VTK's
//! order, matching mid-edge node `3 + k`); `cell_edge_sign[t][k]` is +1 when the local direction
//! agrees with the global one. Shared orientation is what makes the normal degrees of freedom
//! of H(div) elements (docs/design.md §4) single-valued across cells.

use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::mesh::{Dataset, Mesh, NONE, list_indices};
use crate::tolerance::{HANGING_CHAIN, HANGING_NODE_RELATIVE};

/// Edges of a mesh of triangles and quadrilaterals and their incidences.
#[derive(Clone, Debug)]
pub struct Topology {
    /// Vertex pair of each edge, smaller index first.
    pub edges: Vec<[u32; 2]>,
    /// Mid-edge node of each edge (`NONE` for linear cells).
    pub edge_mid: Vec<u32>,
    /// Cells on each side of an edge; the second is `NONE` on the boundary.
    pub edge_cells: Vec<[u32; 2]>,
    /// Edges of each cell, local edge `k` from local vertex `k` to `(k + 1) % n_v`; slot 3 is
    /// `NONE` for triangles.
    pub cell_edges: Vec<[u32; 4]>,
    /// +1 where local and global edge directions agree, −1 otherwise.
    pub cell_edge_sign: Vec<[i8; 4]>,
    /// Boundary edges (one adjacent cell), ascending.
    pub boundary_edges: Vec<u32>,
    /// Edge of each line cell of the mesh.
    pub line_edge: Vec<u32>,
}

impl Topology {
    /// Whether edge `e` lies on the boundary.
    pub fn is_boundary(&self, e: usize) -> bool {
        self.edge_cells[e][1] == NONE
    }

    /// The edge with vertices `a`, `b`, if any.
    pub fn find_edge(&self, a: u32, b: u32) -> Option<usize> {
        self.edges.binary_search(&[a.min(b), a.max(b)]).ok()
    }
}

/// Edges of cells given as vertex loops (counter-clockwise, `n[c]` vertices each) with an
/// optional mid node per local edge: the shared core of [`build`] and of the sub-triangulation
/// of [`crate::reconstruct`]. Returns the topology (without line cells) and the cells that hit
/// each defect: (non-manifold, non-conforming mid nodes, folded).
pub fn from_loops(
    n: usize,
    vertex: impl Fn(usize, usize) -> u32 + Sync,
    count: impl Fn(usize) -> usize + Sync,
    mid: impl Fn(usize, usize) -> u32 + Sync,
) -> (Topology, [Vec<usize>; 3]) {
    // (vertex pair, cell, local edge), sorted: equal pairs are one edge.
    let mut half: Vec<([u32; 2], u32, u8)> = Vec::with_capacity(3 * n);
    for t in 0..n {
        let nv = count(t);
        for k in 0..nv {
            let (a, b) = (vertex(t, k), vertex(t, (k + 1) % nv));
            half.push(([a.min(b), a.max(b)], t as u32, k as u8));
        }
    }
    half.par_sort_unstable();

    let mut edges = Vec::with_capacity(half.len() / 2 + 1);
    let mut edge_mid = Vec::with_capacity(half.len() / 2 + 1);
    let mut edge_cells = Vec::with_capacity(half.len() / 2 + 1);
    let mut cell_edges = vec![[NONE; 4]; n];
    let mut cell_edge_sign = vec![[0i8; 4]; n];
    let mut non_manifold = Vec::new();
    let mut non_conforming = Vec::new();
    let mut folded = Vec::new();
    let mut i = 0;
    while i < half.len() {
        let mut j = i + 1;
        while j < half.len() && half[j].0 == half[i].0 {
            j += 1;
        }
        let e = edges.len() as u32;
        edges.push(half[i].0);
        let mid_of = |h: &([u32; 2], u32, u8)| mid(h.1 as usize, h.2 as usize);
        edge_mid.push(mid_of(&half[i]));
        if j - i > 2 {
            non_manifold.push(half[i + 2].1 as usize);
        }
        if j - i == 2 && mid_of(&half[i]) != mid_of(&half[i + 1]) {
            non_conforming.push(half[i + 1].1 as usize);
        }
        // Counter-clockwise neighbours run a shared edge in opposite directions; the same
        // direction means both lie on one side of it: the cells overlap (a folded mesh).
        if j - i == 2 {
            let dir = |h: &([u32; 2], u32, u8)| vertex(h.1 as usize, h.2 as usize);
            if dir(&half[i]) == dir(&half[i + 1]) {
                folded.push(half[i].1 as usize);
                folded.push(half[i + 1].1 as usize);
            }
        }
        edge_cells.push([half[i].1, if j - i >= 2 { half[i + 1].1 } else { NONE }]);
        for h in &half[i..j] {
            let (t, k) = (h.1 as usize, h.2 as usize);
            cell_edges[t][k] = e;
            cell_edge_sign[t][k] = if vertex(t, k) == h.0[0] { 1 } else { -1 };
        }
        i = j;
    }
    let boundary_edges: Vec<u32> = (0..edges.len() as u32)
        .filter(|&e| edge_cells[e as usize][1] == NONE)
        .collect();
    (
        Topology {
            edges,
            edge_mid,
            edge_cells,
            cell_edges,
            cell_edge_sign,
            boundary_edges,
            line_edge: Vec::new(),
        },
        [non_manifold, non_conforming, folded],
    )
}

/// Builds the topology, or reports non-manifold edges, non-conforming P2 edges and line cells
/// that are no edge of the mesh (with file cell indices).
pub fn build(data: &Dataset) -> Result<Topology> {
    build_with(data, false).map(|(topo, _)| topo)
}

/// A hanging edge: local edge `edge` of cell `cell` (from its node `a` to its node `b`, as
/// [`Mesh::edge`] gives them), which its neighbours meet in pieces through the vertices
/// `inner` (in order from a to b); `pieces[i]` is the neighbours' edge from the i-th to the
/// (i + 1)-th point of a, inner…, b.
#[derive(Clone, Debug)]
pub struct Hanging {
    pub cell: usize,
    pub edge: usize,
    pub inner: Vec<u32>,
    pub pieces: Vec<u32>,
}

/// The one-line refusal of a mesh with hanging edges `hanging` (not empty): where they are,
/// the first hanging vertex, and `why` fosls cannot close them.
pub fn refuse_hanging(data: &Dataset, hanging: &[Hanging], why: &str) -> Error {
    let mesh = &data.mesh;
    let mut cells: Vec<usize> = hanging
        .iter()
        .map(|h| mesh.file_cell[h.cell] as usize)
        .collect();
    cells.sort_unstable();
    cells.dedup();
    let p = |i: u32| {
        let [x, y] = mesh.points[i as usize];
        format!("({x}, {y})")
    };
    let Some(h) = hanging.first() else {
        return Error::input(&data.path, "Cells", why.to_string());
    };
    let [a, b, _] = mesh.edge(h.cell, h.edge);
    Error::input(
        &data.path,
        "Cells",
        format!(
            "hanging nodes: the mesh is not conforming (cells {} ({} in all) have an edge that \
             their neighbours meet in pieces; the first: the vertex at {} lies inside the edge \
             {}–{} of cell {}); {why}: write the solution on a conforming mesh",
            list_indices(&cells),
            cells.len(),
            p(h.inner[0]),
            p(a),
            p(b),
            mesh.file_cell[h.cell],
        ),
    )
}

/// The topology of a mesh that may have hanging nodes, and its hanging edges (empty when the
/// mesh is conforming); every other defect is reported as by [`build`]. For
/// [`crate::closure`], which splits the cells with hanging edges.
pub fn build_allowing_hanging(data: &Dataset) -> Result<(Topology, Vec<Hanging>)> {
    build_with(data, true)
}

fn build_with(data: &Dataset, allow_hanging: bool) -> Result<(Topology, Vec<Hanging>)> {
    let err = |problem: String| Error::input(&data.path, "Cells", problem);
    let mesh: &Mesh = &data.mesh;
    let noun = if mesh.has_quads() {
        "cells"
    } else {
        "triangles"
    };
    let (topo, [non_manifold, non_conforming, mut folded]) = from_loops(
        mesh.len(),
        |t, k| mesh.cells[t][k],
        |t| mesh.family[t].vertices(),
        |t, k| mesh.edge(t, k)[2],
    );
    let file =
        |v: &[usize]| -> Vec<usize> { v.iter().map(|&t| mesh.file_cell[t] as usize).collect() };
    let (non_manifold, non_conforming) = (file(&non_manifold), file(&non_conforming));
    folded = file(&folded);
    let Topology {
        edges,
        edge_mid,
        edge_cells,
        cell_edges,
        cell_edge_sign,
        boundary_edges,
        ..
    } = topo;
    if !non_manifold.is_empty() {
        return Err(err(format!(
            "edges shared by more than two {noun} (non-manifold mesh) at cells {} ({} in all)",
            list_indices(&non_manifold),
            non_manifold.len()
        )));
    }
    if !folded.is_empty() {
        folded.sort_unstable();
        folded.dedup();
        return Err(err(format!(
            "inverted or overlapping {noun} (neighbours on the same side of their shared \
             edge): cells {} ({} in all)",
            list_indices(&folded),
            folded.len()
        )));
    }
    if !non_conforming.is_empty() {
        return Err(err(format!(
            "neighbouring quadratic {noun} with different mid-edge nodes (non-conforming) at \
             cells {} ({} in all)",
            list_indices(&non_conforming),
            non_conforming.len()
        )));
    }
    let hanging = hanging_nodes(mesh, &edges, &edge_cells, &cell_edges, &boundary_edges);
    if !allow_hanging && !hanging.is_empty() {
        return Err(refuse_hanging(
            data,
            &hanging,
            "fosls splits straight triangles and Q1 parallelograms at hanging nodes, not curved \
             triangles or quadratic quadrilaterals",
        ));
    }
    // Line cells: each must be an edge of the mesh.
    let mut line_edge = Vec::with_capacity(mesh.lines.len());
    let mut dangling = Vec::new();
    let mut wrong_mid = Vec::new();
    for (l, line) in mesh.lines.iter().enumerate() {
        let key = [line[0].min(line[1]), line[0].max(line[1])];
        match edges.binary_search(&key) {
            Ok(e) => {
                if line[2] != NONE && line[2] != edge_mid[e] {
                    wrong_mid.push(mesh.line_cell[l] as usize);
                }
                line_edge.push(e as u32);
            }
            Err(_) => {
                dangling.push(mesh.line_cell[l] as usize);
                line_edge.push(NONE);
            }
        }
    }
    if !dangling.is_empty() {
        return Err(err(format!(
            "dangling line cells (not an edge of any {}): cells {} ({} in all)",
            if mesh.has_quads() { "cell" } else { "triangle" },
            list_indices(&dangling),
            dangling.len()
        )));
    }
    if !wrong_mid.is_empty() {
        return Err(err(format!(
            "quadratic line cells whose mid node is not the mid node of their edge: cells {} \
             ({} in all)",
            list_indices(&wrong_mid),
            wrong_mid.len()
        )));
    }

    let topo = Topology {
        edges,
        edge_mid,
        edge_cells,
        cell_edges,
        cell_edge_sign,
        boundary_edges,
        line_edge,
    };
    Ok((topo, hanging))
}

/// The hanging nodes of a non-conforming mesh (adaptive refinement that keeps "hanging"
/// vertices, as MFEM's and deal.II's non-conforming meshes do): a boundary edge a–b of cell t
/// whose ends are joined by a chain of other boundary edges a–v₁–…–b through vertices on the
/// edge's curve. Such an edge is no boundary at all: the cells on both sides of it meet along
/// it without sharing its nodes, and taken as a boundary it would be a traction-free crack
/// (a guaranteed bound for another domain). The chain must reach b: a crack whose two faces
/// are meshed differently also has vertices of one face inside edges of the other, but its
/// faces share no node except at the tip. Returns the chain of each such edge.
///
/// The edge's curve is x(s) = a + s(b − a) + 4s(1 − s)(m − (a + b)/2) (its mid node m, or the
/// chord); a vertex w lies on it when the nearest point x(s*) (Newton on (x(s) − w)·x'(s) = 0
/// from the chord's projection) is within [`HANGING_NODE_RELATIVE`] |b − a| of w, with s* inside
/// (that fraction away from the ends).
fn hanging_nodes(
    mesh: &Mesh,
    edges: &[[u32; 2]],
    edge_cells: &[[u32; 2]],
    cell_edges: &[[u32; 4]],
    boundary: &[u32],
) -> Vec<Hanging> {
    // (vertex, boundary edge), sorted by vertex: the boundary edges at each vertex.
    let mut at: Vec<(u32, u32)> = boundary
        .iter()
        .flat_map(|&e| edges[e as usize].map(|v| (v, e)))
        .collect();
    at.sort_unstable();
    let around = |v: u32| {
        let start = at.partition_point(|&(w, _)| w < v);
        at[start..]
            .iter()
            .take_while(move |&&(w, _)| w == v)
            .map(|&(_, e)| e)
    };
    let other = |e: u32, v: u32| {
        let [p, q] = edges[e as usize];
        if p == v { q } else { p }
    };
    let mut found = Vec::new();
    for &e in boundary {
        let t = edge_cells[e as usize][0] as usize;
        let Some(k) = cell_edges[t].iter().position(|&x| x == e) else {
            continue;
        };
        let [a, b, m] = mesh.edge(t, k);
        let pt = |i: u32| mesh.points[i as usize];
        let (pa, pb) = (pt(a), pt(b));
        let chord = [pb[0] - pa[0], pb[1] - pa[1]];
        let len2 = chord[0] * chord[0] + chord[1] * chord[1];
        if !(len2 > 0.0 && len2.is_finite()) {
            continue;
        }
        let bow = if m == NONE {
            [0.0; 2]
        } else {
            let pm = pt(m);
            [pm[0] - 0.5 * (pa[0] + pb[0]), pm[1] - 0.5 * (pa[1] + pb[1])]
        };
        let on_edge = |w: [f64; 2]| -> bool {
            let x = |s: f64| {
                let c = 4.0 * s * (1.0 - s);
                [
                    pa[0] + s * chord[0] + c * bow[0],
                    pa[1] + s * chord[1] + c * bow[1],
                ]
            };
            let dx = |s: f64| {
                let c = 4.0 * (1.0 - 2.0 * s);
                [chord[0] + c * bow[0], chord[1] + c * bow[1]]
            };
            let mut s = ((w[0] - pa[0]) * chord[0] + (w[1] - pa[1]) * chord[1]) / len2;
            for _ in 0..8 {
                let (p, d) = (x(s), dx(s));
                let r = [p[0] - w[0], p[1] - w[1]];
                let g = r[0] * d[0] + r[1] * d[1];
                let h = d[0] * d[0] + d[1] * d[1] - 8.0 * (r[0] * bow[0] + r[1] * bow[1]);
                // A NaN or non-positive curvature term: keep the last s (its distance decides).
                if h.is_nan() || h <= 0.0 {
                    break;
                }
                s = (s - g / h).clamp(-1.0, 2.0);
            }
            let p = x(s);
            let dist2 = (p[0] - w[0]).powi(2) + (p[1] - w[1]).powi(2);
            let tol = HANGING_NODE_RELATIVE;
            s > tol && s < 1.0 - tol && dist2 <= tol * tol * len2
        };
        // Walk from a along boundary edges through vertices on the edge, towards b.
        let (mut cur, mut came) = (a, e);
        let (mut inner, mut pieces) = (Vec::new(), Vec::new());
        for _ in 0..HANGING_CHAIN {
            let mut next = None;
            for f in around(cur) {
                if f == came {
                    continue;
                }
                let w = other(f, cur);
                if w == b && !inner.is_empty() {
                    next = Some((f, w));
                    break;
                }
                if w != a && w != b && on_edge(pt(w)) {
                    next = Some((f, w));
                    break;
                }
            }
            let Some((f, w)) = next else {
                break;
            };
            pieces.push(f);
            if w == b {
                found.push(Hanging {
                    cell: t,
                    edge: k,
                    inner,
                    pieces,
                });
                break;
            }
            inner.push(w);
            (cur, came) = (w, f);
        }
    }
    found
}

/// Line cells lying on interior edges (file cell indices): legal, but not boundary data.
pub fn interior_lines(data: &Dataset, topo: &Topology) -> Vec<usize> {
    topo.line_edge
        .iter()
        .enumerate()
        .filter(|&(_, &e)| e != NONE && !topo.is_boundary(e as usize))
        .map(|(l, _)| data.mesh.line_cell[l] as usize)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh;
    use crate::read::vtu::VtuFile;
    use std::path::Path;

    fn square(lines: &[Vec<u32>]) -> Result<(Dataset, Topology)> {
        let mut cells = vec![(5u8, vec![0, 1, 2]), (5, vec![1, 3, 2])];
        cells.extend(lines.iter().map(|l| (3u8, l.clone())));
        let f = VtuFile::from_cells(
            Path::new("m.vtu"),
            vec![
                [0., 0., 0.],
                [1., 0., 0.],
                [0., 1., 0.],
                [1., 1., 0.],
                [2., 2., 0.],
            ],
            &cells,
        );
        let d = mesh::build(f)?;
        let t = build(&d)?;
        Ok((d, t))
    }

    #[test]
    fn edges_boundary_and_orientation_of_two_triangles() {
        let (d, t) = square(&[vec![1, 0], vec![1, 2]]).unwrap();
        assert_eq!(t.edges, vec![[0, 1], [0, 2], [1, 2], [1, 3], [2, 3]]);
        assert_eq!(t.boundary_edges, vec![0, 1, 3, 4]);
        // The diagonal (1, 2) is shared: cell 0 runs 1→2 (+1), cell 1 runs 2→1 (−1).
        assert_eq!(t.edge_cells[2], [0, 1]);
        assert_eq!(t.cell_edges[0][..3], [0, 2, 1]);
        assert_eq!(t.cell_edge_sign[0][..3], [1, 1, -1]);
        assert_eq!(t.cell_edges[1][..3], [3, 4, 2]);
        assert_eq!(t.cell_edge_sign[1][..3], [1, -1, -1]);
        assert_eq!(t.line_edge, vec![0, 2]);
        assert_eq!(interior_lines(&d, &t), vec![3]);
        // Every edge's cells list it with opposite signs when shared.
        for (e, cells) in t.edge_cells.iter().enumerate() {
            let signs: Vec<i8> = cells
                .iter()
                .filter(|&&c| c != NONE)
                .map(|&c| {
                    let k = t.cell_edges[c as usize]
                        .iter()
                        .position(|&x| x == e as u32)
                        .unwrap();
                    t.cell_edge_sign[c as usize][k]
                })
                .collect();
            if signs.len() == 2 {
                assert_eq!(signs[0], -signs[1]);
            }
        }
    }

    #[test]
    fn dangling_line_is_named() {
        let e = square(&[vec![0, 1], vec![0, 3], vec![3, 4]])
            .unwrap_err()
            .to_string();
        assert_eq!(
            e,
            "m.vtu: Cells: dangling line cells (not an edge of any triangle): cells 3, 4 (2 in all)"
        );
    }

    #[test]
    fn a_flipped_cell_is_found_as_overlap() {
        // Vertex 3 of the upper-right triangle moved across the diagonal: the cell flips.
        let f = VtuFile::from_cells(
            Path::new("m.vtu"),
            vec![[0., 0., 0.], [1., 0., 0.], [0., 1., 0.], [0.2, 0.2, 0.]],
            &[(5, vec![0, 1, 2]), (5, vec![1, 3, 2])],
        );
        let e = build(&mesh::build(f).unwrap()).unwrap_err().to_string();
        assert_eq!(
            e,
            "m.vtu: Cells: inverted or overlapping triangles (neighbours on the same side of \
             their shared edge): cells 0, 1 (2 in all)"
        );
    }

    #[test]
    fn non_manifold_edge_is_named() {
        let f = VtuFile::from_cells(
            Path::new("m.vtu"),
            vec![
                [0., 0., 0.],
                [1., 0., 0.],
                [0., 1., 0.],
                [0., -1., 0.],
                [0.5, 1., 0.],
            ],
            &[(5, vec![0, 1, 2]), (5, vec![0, 3, 1]), (5, vec![0, 1, 4])],
        );
        let e = build(&mesh::build(f).unwrap()).unwrap_err().to_string();
        assert_eq!(
            e,
            "m.vtu: Cells: edges shared by more than two triangles (non-manifold mesh) at cells 2 (1 in all)"
        );
    }

    /// Cells as (VTK type, nodes).
    type Cells = Vec<(u8, Vec<u32>)>;

    /// Builds the topology of triangles, quads or quadratic cells given by VTK type.
    fn topology_of(points: &[[f64; 2]], cells: &[(u8, Vec<u32>)]) -> Result<Topology> {
        let f = VtuFile::from_cells(
            Path::new("m.vtu"),
            points.iter().map(|p| [p[0], p[1], 0.0]).collect(),
            cells,
        );
        build(&mesh::build(f)?)
    }

    /// [0, 2] × [0, 1]: the left square in two triangles, the right one in four, which meet
    /// the left triangle's edge x = 1 in two pieces (vertex 6 hangs on it).
    fn hanging_triangles() -> (Vec<[f64; 2]>, Cells) {
        let points = vec![
            [0., 0.],
            [1., 0.],
            [1., 1.],
            [0., 1.],
            [2., 0.],
            [2., 1.],
            [1., 0.5],
            [2., 0.5],
        ];
        let cells = [
            [0, 1, 2],
            [0, 2, 3],
            [1, 4, 7],
            [1, 7, 6],
            [6, 7, 5],
            [6, 5, 2],
        ];
        (points, cells.iter().map(|c| (5u8, c.to_vec())).collect())
    }

    #[test]
    fn a_hanging_node_is_named() {
        let (points, cells) = hanging_triangles();
        let e = topology_of(&points, &cells).unwrap_err().to_string();
        assert_eq!(
            e,
            "m.vtu: Cells: hanging nodes: the mesh is not conforming (cells 0 (1 in all) have \
             an edge that their neighbours meet in pieces; the first: the vertex at (1, 0.5) \
             lies inside the edge (1, 0)–(1, 1) of cell 0); fosls splits straight triangles and \
             Q1 parallelograms at hanging nodes, not curved triangles or quadratic \
             quadrilaterals: write the solution on a conforming mesh"
        );
        // Split at the hanging vertex, the same mesh is conforming.
        let mut split = cells.clone();
        split[0] = (5, vec![0, 1, 6]);
        split.push((5, vec![0, 6, 2]));
        let t = topology_of(&points, &split).unwrap();
        assert_eq!(t.boundary_edges.len(), 7);
    }

    #[test]
    fn two_levels_of_hanging_nodes_and_quadrilaterals() {
        // The right square fanned from (2, 0) and (2, 1): x = 1 in four pieces.
        let points = vec![
            [0., 0.],
            [1., 0.],
            [1., 1.],
            [0., 1.],
            [2., 0.],
            [2., 1.],
            [1., 0.25],
            [1., 0.5],
            [1., 0.75],
        ];
        let cells: Vec<(u8, Vec<u32>)> = [
            [0, 1, 2],
            [0, 2, 3],
            [1, 4, 6],
            [6, 4, 7],
            [7, 4, 5],
            [7, 5, 8],
            [8, 5, 2],
        ]
        .iter()
        .map(|c| (5u8, c.to_vec()))
        .collect();
        let e = topology_of(&points, &cells).unwrap_err().to_string();
        assert!(
            e.contains("the vertex at (1, 0.25) lies inside the edge (1, 0)–(1, 1) of cell 0"),
            "{e}"
        );
        // Bilinear quadrilaterals: one on the left, two on the right.
        let (points, _) = hanging_triangles();
        let quads = vec![
            (9u8, vec![0, 1, 2, 3]),
            (9, vec![1, 4, 7, 6]),
            (9, vec![6, 7, 5, 2]),
        ];
        let e = topology_of(&points, &quads).unwrap_err().to_string();
        assert!(
            e.contains("the vertex at (1, 0.5) lies inside the edge (1, 0)–(1, 1) of cell 0"),
            "{e}"
        );
    }

    #[test]
    fn a_hanging_node_on_a_quadratic_edge() {
        // The left triangle's mid node on x = 1 is a vertex of the two right triangles.
        let points = vec![
            [0., 0.],
            [1., 0.],
            [1., 1.],
            [0.5, 0.],
            [1., 0.5],
            [0.5, 0.5],
            [2., 0.5],
            [1.5, 0.25],
            [1.5, 0.5],
            [1., 0.25],
            [1.5, 0.75],
            [1., 0.75],
        ];
        let cells = vec![
            (22u8, vec![0, 1, 2, 3, 4, 5]),
            (22, vec![1, 6, 4, 7, 8, 9]),
            (22, vec![4, 6, 2, 8, 10, 11]),
        ];
        let e = topology_of(&points, &cells).unwrap_err().to_string();
        assert!(
            e.contains("the vertex at (1, 0.5) lies inside the edge (1, 0)–(1, 1) of cell 0"),
            "{e}"
        );
    }

    #[test]
    fn a_crack_with_unmatched_faces_is_no_hanging_node() {
        // [0, 2] × [−1, 1] cut along y = 0 for x < 1 (tip (1, 0)): the upper face has two edges,
        // the lower face one, inside which the upper face's middle vertex lies. The faces share
        // the tip only, so the cut stays a boundary.
        let points = vec![
            [0., 0.],  // 0: upper face
            [1., 0.],  // 1: tip
            [1., 1.],  // 2
            [0., 1.],  // 3
            [2., 0.],  // 4
            [2., 1.],  // 5
            [1., -1.], // 6
            [2., -1.], // 7
            [0., 0.],  // 8: lower face (a separate node at the same place)
            [0., -1.], // 9
            [0.5, 0.], // 10: upper face
        ];
        // The lower face's one edge runs from the tip (its first end: the walk starts there)
        // through the place of vertex 10 to node 8, which the upper face never reaches.
        let cells: Vec<(u8, Vec<u32>)> = [
            [0, 10, 3],
            [10, 1, 2],
            [10, 2, 3],
            [1, 4, 5],
            [1, 5, 2],
            [1, 6, 7],
            [1, 7, 4],
            [8, 9, 6],
            [8, 6, 1],
        ]
        .iter()
        .map(|c| (5u8, c.to_vec()))
        .collect();
        let t = topology_of(&points, &cells).unwrap();
        // Outer boundary 8 edges, and the cut's faces: 1 + 2.
        assert_eq!(t.boundary_edges.len(), 11);
    }
}
