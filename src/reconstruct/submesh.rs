//! The fixed sub-triangulation that carries RT fields (docs/design.md §5.4): every triangle
//! is its own sub-triangle, every quadrilateral is cut along the diagonal from its local
//! vertex 0 to vertex 2 into halves (0, 1, 2) and (0, 2, 3)
//! ([`crate::geometry::values::sub_vertices`]). The halves use only the cell's vertices, so the
//! sub-triangulation is conforming and its edges are the mesh's edges plus one diagonal per
//! quadrilateral; boundary edges are the mesh's boundary edges.

use crate::geometry::values::{sub_count, sub_vertices};
use crate::mesh::{Mesh, NONE};
use crate::topology::{self, Topology};

/// Sub-triangles of a mesh and their topology.
#[derive(Clone, Debug)]
pub struct SubMesh {
    /// Parent cell of each sub-triangle.
    pub parent: Vec<u32>,
    /// Half of the parent (0 for triangles).
    pub index: Vec<u8>,
    /// First sub-triangle of each cell, with one more entry at the end.
    pub first: Vec<u32>,
    /// Global vertices of each sub-triangle, counter-clockwise.
    pub vertices: Vec<[u32; 3]>,
    pub topo: Topology,
}

impl SubMesh {
    pub fn new(mesh: &Mesh) -> SubMesh {
        let mut parent = Vec::with_capacity(mesh.len());
        let mut index = Vec::with_capacity(mesh.len());
        let mut first = Vec::with_capacity(mesh.len() + 1);
        let mut vertices = Vec::with_capacity(mesh.len());
        for t in 0..mesh.len() {
            let f = mesh.family[t];
            first.push(parent.len() as u32);
            for k in 0..sub_count(f) {
                let v = sub_vertices(f, k);
                parent.push(t as u32);
                index.push(k as u8);
                vertices.push(v.map(|i| mesh.cells[t][i]));
            }
        }
        first.push(parent.len() as u32);
        // The mesh topology has already refused non-manifold and folded meshes; the diagonals
        // add neither.
        let (topo, _) =
            topology::from_loops(vertices.len(), |r, k| vertices[r][k], |_| 3, |_, _| NONE);
        SubMesh {
            parent,
            index,
            first,
            vertices,
            topo,
        }
    }

    #[inline]
    pub fn len(&self) -> usize {
        self.parent.len()
    }

    #[inline]
    pub fn is_empty(&self) -> bool {
        self.parent.is_empty()
    }

    /// The sub-triangle and its local edge on the mesh edge with vertices `a`, `b`, with the
    /// sub-mesh edge index.
    pub fn locate_edge(&self, a: u32, b: u32) -> Option<(usize, usize, usize)> {
        let e = self.topo.find_edge(a, b)?;
        let r = self.topo.edge_cells[e][0] as usize;
        let l = self.topo.cell_edges[r]
            .iter()
            .position(|&x| x == e as u32)?;
        Some((e, r, l))
    }
}
