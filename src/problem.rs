//! Provisional types (replaced by the full module on merge).

/// Boundary condition of an edge: index into `scene.boundaries`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Condition {
    Free,
    Dirichlet(usize),
    Neumann(usize),
    Contact(usize),
}

/// One boundary edge with its owning cell and local edge.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BoundaryEdge {
    pub edge: u32,
    pub cell: u32,
    pub local: u8,
    pub line: u32,
    pub condition: Condition,
}
