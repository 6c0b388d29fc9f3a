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

    Ok(Topology {
        edges,
        edge_mid,
        edge_cells,
        cell_edges,
        cell_edge_sign,
        boundary_edges,
        line_edge,
    })
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
}
