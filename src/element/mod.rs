//! Reference finite elements and the isoparametric map (DESIGN.md §3, §4; tests: §9 layer 1).
//!
//! Everything here is concrete `f64` on fixed-size arrays and allocates nothing, since the
//! functions run once per quadrature point (~10⁷ times for a 1M-cell mesh).
//!
//! - [`lagrange`]: P1 and P2 shape functions φ_i and their reference gradients ∇̂φ_i on the
//!   reference triangle T̂ = conv{(0,0), (1,0), (0,1)}, VTK node order (vertices 0, 1, 2; mid
//!   nodes 3 on edge 0–1, 4 on edge 1–2, 5 on edge 2–0), and the P1/P2 functions of the
//!   reference edge [0, 1] (ends 0, 1, mid 2).
//! - [`map`]: the cell map x(ξ) = Σ_i x_i φ_i(ξ) of a straight (3-node) or curved (6-node)
//!   triangle, its Jacobian J = ∂x/∂ξ, det J and J^{−1}, and physical gradients
//!   ∇φ = J^{−T} ∇̂φ. Integrals: ∫_T f dx = ∫_T̂ f(x(ξ)) det J(ξ) dξ.
//! - [`edge`]: boundary edges x(s), s ∈ [0, 1], with tangent x'(s), length element |x'(s)|
//!   (∫_E f dσ = ∫_0^1 f(x(s)) |x'(s)| ds), the outward normal n = (t_y, −t_x)/|t| of an edge of
//!   a counter-clockwise cell traversed in its local order, and the local edges of T̂.
//!
//! The quadrature rules that go with these live in [`crate::quadrature`].

pub mod edge;
pub mod lagrange;
pub mod map;
pub mod rt;

pub use edge::{
    EDGE_NODES, EdgeMap, LinearEdge, QuadraticEdge, REFERENCE_NORMALS, edge_reference_point,
    outward_normal,
};
pub use lagrange::{
    P1_GRADIENTS, P1_NODES, P2_NODES, barycentric, line_p1_derivatives, line_p1_values,
    line_p2_derivatives, line_p2_values, p1_gradients, p1_values, p2_gradients, p2_values,
};
pub use map::{CellMap, Jacobian, LinearTriangle, QuadraticTriangle};
pub use rt::{RT0_DOFS, RT1_DOFS, RtOrder};
