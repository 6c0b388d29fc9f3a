//! Edges: the local edges of the reference triangle and the parametrisation of boundary edges
//! (contact, Dirichlet, Neumann terms of docs/design.md §3 and §5 are integrals over them).
//!
//! An edge with nodes x_j (2 nodes, or 3 with the mid node last, VTK line order) is the curve
//! x(s) = Σ_j x_j ψ_j(s), s ∈ [0, 1], with the line shape functions ψ_j of
//! [`super::triangle`]. Its tangent is x'(s) = Σ_j x_j ψ_j'(s), its length element |x'(s)|,
//! so ∫_E f dσ = ∫_0^1 f(x(s)) |x'(s)| ds.
//!
//! Normal convention: the local edges of a counter-clockwise cell, traversed in their local
//! order (0→1, 1→2, 2→0), have the cell on their left, so the outward unit normal is the
//! tangent turned clockwise: n = (t_y, −t_x)/|t| ([`outward_normal`]).

use super::triangle::{line_p1_values, line_p2_derivatives, line_p2_values};

/// Local edges of the triangle, VTK order: [start vertex, end vertex, mid node]. Edge i is
/// opposite vertex (i + 2) mod 3.
pub const EDGE_NODES: [[usize; 3]; 3] = [[0, 1, 3], [1, 2, 4], [2, 0, 5]];

/// Outward unit normals n̂ of the reference triangle's local edges 0, 1, 2.
pub const REFERENCE_NORMALS: [[f64; 2]; 3] = [
    [0.0, -1.0],
    [
        std::f64::consts::FRAC_1_SQRT_2,
        std::f64::consts::FRAC_1_SQRT_2,
    ],
    [-1.0, 0.0],
];

/// The reference point ξ(s) on local edge `edge` at parameter s ∈ [0, 1], running from the
/// edge's start vertex to its end vertex: edge 0: (s, 0); edge 1: (1 − s, s); edge 2: (0, 1 − s).
/// Evaluating a cell's fields at ξ(s) and its edge map ([`super::map::QuadraticTriangle::edge`])
/// at s gives the same physical point. Panics if `edge` > 2.
#[inline]
pub fn edge_reference_point(edge: usize, s: f64) -> [f64; 2] {
    match edge {
        0 => [s, 0.0],
        1 => [1.0 - s, s],
        2 => [0.0, 1.0 - s],
        _ => panic!("a triangle has edges 0, 1, 2, not {edge}"),
    }
}

/// The outward unit normal n = (t_y, −t_x)/|t| of an edge with tangent `t`, for an edge of a
/// counter-clockwise cell traversed in its local order (the cell on the left). For an edge
/// traversed the other way round, negate the result.
#[inline]
pub fn outward_normal(t: [f64; 2]) -> [f64; 2] {
    let len = t[0].hypot(t[1]);
    [t[1] / len, -t[0] / len]
}

/// A straight edge between two nodes (VTK_LINE): x(s) = (1 − s) x_0 + s x_1.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LinearEdge {
    /// End points x_0, x_1.
    pub nodes: [[f64; 2]; 2],
}

impl LinearEdge {
    /// The edge from `nodes[0]` to `nodes[1]`.
    #[inline]
    pub fn new(nodes: [[f64; 2]; 2]) -> LinearEdge {
        LinearEdge { nodes }
    }

    /// x(s) = (1 − s) x_0 + s x_1.
    #[inline]
    pub fn position(&self, s: f64) -> [f64; 2] {
        let [a, b] = self.nodes;
        let [_, c1] = line_p1_values(s);
        [a[0] + (b[0] - a[0]) * c1, a[1] + (b[1] - a[1]) * c1]
    }

    /// dx/ds = x_1 − x_0 (constant).
    #[inline]
    pub fn tangent(&self, _s: f64) -> [f64; 2] {
        let [a, b] = self.nodes;
        [b[0] - a[0], b[1] - a[1]]
    }

    /// |dx/ds| = the edge length.
    #[inline]
    pub fn length_element(&self, s: f64) -> f64 {
        let t = self.tangent(s);
        t[0].hypot(t[1])
    }

    /// The edge length |x_1 − x_0|.
    #[inline]
    pub fn length(&self) -> f64 {
        self.length_element(0.0)
    }

    /// [`outward_normal`] of the tangent (outward when the edge is traversed counter-clockwise
    /// around its cell).
    #[inline]
    pub fn normal(&self, s: f64) -> [f64; 2] {
        outward_normal(self.tangent(s))
    }
}

/// A quadratic edge (VTK_QUADRATIC_EDGE): ends x_0, x_1 and mid node x_2,
/// x(s) = (1 − s)(1 − 2s) x_0 + s(2s − 1) x_1 + 4s(1 − s) x_2.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct QuadraticEdge {
    /// x_0 (start), x_1 (end), x_2 (mid node), VTK order.
    pub nodes: [[f64; 2]; 3],
}

impl QuadraticEdge {
    /// The edge with ends `nodes[0]`, `nodes[1]` and mid node `nodes[2]`.
    #[inline]
    pub fn new(nodes: [[f64; 2]; 3]) -> QuadraticEdge {
        QuadraticEdge { nodes }
    }

    /// x(s) = Σ_j x_j ψ_j(s), evaluated relative to x_0.
    #[inline]
    pub fn position(&self, s: f64) -> [f64; 2] {
        let [a, b, m] = self.nodes;
        let [_, c1, c2] = line_p2_values(s);
        [
            a[0] + (b[0] - a[0]) * c1 + (m[0] - a[0]) * c2,
            a[1] + (b[1] - a[1]) * c1 + (m[1] - a[1]) * c2,
        ]
    }

    /// The tangent dx/ds = Σ_j x_j ψ_j'(s) = (x_1 − x_0) + (4 − 8s)(x_2 − (x_0 + x_1)/2).
    #[inline]
    pub fn tangent(&self, s: f64) -> [f64; 2] {
        let [a, b, m] = self.nodes;
        let [_, d1, d2] = line_p2_derivatives(s);
        [
            (b[0] - a[0]) * d1 + (m[0] - a[0]) * d2,
            (b[1] - a[1]) * d1 + (m[1] - a[1]) * d2,
        ]
    }

    /// The length element |dx/ds|.
    #[inline]
    pub fn length_element(&self, s: f64) -> f64 {
        let t = self.tangent(s);
        t[0].hypot(t[1])
    }

    /// [`outward_normal`] of the tangent at s (outward when the edge is traversed
    /// counter-clockwise around its cell).
    #[inline]
    pub fn normal(&self, s: f64) -> [f64; 2] {
        outward_normal(self.tangent(s))
    }
}

/// An edge map of either kind, for code that handles both straight and curved meshes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum EdgeMap {
    /// 2 nodes.
    Linear(LinearEdge),
    /// 3 nodes (ends, then mid).
    Quadratic(QuadraticEdge),
}

impl EdgeMap {
    /// The map of an edge with 2 or 3 nodes (VTK order); `None` for any other count.
    pub fn from_nodes(nodes: &[[f64; 2]]) -> Option<EdgeMap> {
        match *nodes {
            [a, b] => Some(EdgeMap::Linear(LinearEdge::new([a, b]))),
            [a, b, m] => Some(EdgeMap::Quadratic(QuadraticEdge::new([a, b, m]))),
            _ => None,
        }
    }

    /// x(s).
    #[inline]
    pub fn position(&self, s: f64) -> [f64; 2] {
        match self {
            EdgeMap::Linear(e) => e.position(s),
            EdgeMap::Quadratic(e) => e.position(s),
        }
    }

    /// dx/ds.
    #[inline]
    pub fn tangent(&self, s: f64) -> [f64; 2] {
        match self {
            EdgeMap::Linear(e) => e.tangent(s),
            EdgeMap::Quadratic(e) => e.tangent(s),
        }
    }

    /// |dx/ds|.
    #[inline]
    pub fn length_element(&self, s: f64) -> f64 {
        let t = self.tangent(s);
        t[0].hypot(t[1])
    }

    /// (t_y, −t_x)/|t|.
    #[inline]
    pub fn normal(&self, s: f64) -> [f64; 2] {
        outward_normal(self.tangent(s))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::triangle::P2_NODES;
    use crate::quadrature::line_rule;

    fn assert_close(a: f64, b: f64, tol: f64, what: &str) {
        assert!(
            (a - b).abs() <= tol,
            "{what}: {a} vs {b} (diff {:e})",
            (a - b).abs()
        );
    }

    #[test]
    fn reference_edges_run_between_their_nodes() {
        for (i, &[a, b, m]) in EDGE_NODES.iter().enumerate() {
            assert_eq!(edge_reference_point(i, 0.0), P2_NODES[a]);
            assert_eq!(edge_reference_point(i, 1.0), P2_NODES[b]);
            assert_eq!(edge_reference_point(i, 0.5), P2_NODES[m]);
        }
    }

    #[test]
    fn reference_normals_are_outward_normals_of_the_reference_edges() {
        for (i, n_hat) in REFERENCE_NORMALS.iter().enumerate() {
            let t = [
                edge_reference_point(i, 1.0)[0] - edge_reference_point(i, 0.0)[0],
                edge_reference_point(i, 1.0)[1] - edge_reference_point(i, 0.0)[1],
            ];
            let n = outward_normal(t);
            assert_close(n[0], n_hat[0], 2e-16, "n_x");
            assert_close(n[1], n_hat[1], 2e-16, "n_y");
        }
    }

    #[test]
    fn outward_normal_of_counter_clockwise_square_sides() {
        // Unit square traversed counter-clockwise: bottom → (0, −1), right → (1, 0), etc.
        let sides = [([1.0, 0.0], [0.0, -1.0]), ([0.0, 1.0], [1.0, 0.0])];
        for (t, n) in sides {
            assert_eq!(outward_normal(t), n);
            assert_eq!(outward_normal([-t[0], -t[1]]), [-n[0], -n[1]]);
        }
        assert_eq!(outward_normal([-3.0, 0.0]), [0.0, 1.0]);
    }

    #[test]
    fn length_of_quadratic_edge_on_a_parabola() {
        // y = x² on [0, 1]: nodes (0,0), (1,1), mid (½, ¼); the P2 edge is exactly x = s,
        // y = s². Length ∫_0^1 √(1 + 4x²) dx = √5/2 + asinh(2)/4.
        let e = QuadraticEdge::new([[0.0, 0.0], [1.0, 1.0], [0.5, 0.25]]);
        for k in 0..=8 {
            let s = k as f64 / 8.0;
            let x = e.position(s);
            assert_close(x[0], s, 1e-16, "x(s)");
            assert_close(x[1], s * s, 1e-16, "y(s)");
        }
        let exact = 5f64.sqrt() / 2.0 + 2f64.asinh() / 4.0;
        let length = line_rule(40).integrate(|s| e.length_element(s));
        assert_close(length, exact, 1e-14, "parabola length");
        // A rotated, shifted copy has the same length.
        let (c, sn) = (0.6f64, 0.8f64);
        let rot = |p: [f64; 2]| [5.0 + c * p[0] - sn * p[1], -2.0 + sn * p[0] + c * p[1]];
        let r = QuadraticEdge::new(e.nodes.map(rot));
        let length = line_rule(40).integrate(|s| r.length_element(s));
        assert_close(length, exact, 1e-13, "rotated parabola length");
    }

    #[test]
    fn straight_quadratic_edge_is_the_linear_edge() {
        let (a, b) = ([1.0, 2.0], [4.0, -2.0]);
        let lin = LinearEdge::new([a, b]);
        let quad = QuadraticEdge::new([a, b, [2.5, 0.0]]);
        assert_eq!(lin.length(), 5.0);
        for k in 0..=10 {
            let s = k as f64 / 10.0;
            let (pl, pq) = (lin.position(s), quad.position(s));
            let (tl, tq) = (lin.tangent(s), quad.tangent(s));
            for d in 0..2 {
                assert_close(pq[d], pl[d], 1e-15, "position");
                assert_close(tq[d], tl[d], 1e-15, "tangent");
            }
            assert_close(quad.length_element(s), 5.0, 1e-15, "length element");
            assert_eq!(lin.normal(s), [-0.8, -0.6]);
        }
    }

    #[test]
    fn tangent_matches_finite_differences() {
        const H: f64 = 1e-6;
        let e = QuadraticEdge::new([[0.3, -0.2], [1.4, 0.9], [1.1, 0.1]]);
        for k in 0..=10 {
            let s = k as f64 / 10.0;
            let (p, m) = (e.position(s + H), e.position(s - H));
            let t = e.tangent(s);
            for d in 0..2 {
                assert_close(t[d], (p[d] - m[d]) / (2.0 * H), 1e-8, "dx/ds");
            }
            let n = e.normal(s);
            assert_close(n[0] * t[0] + n[1] * t[1], 0.0, 1e-15, "n ⊥ t");
            assert_close(n[0].hypot(n[1]), 1.0, 1e-15, "|n|");
            // The cell lies to the left of t, n points to the right: t × n < 0.
            assert!(t[0] * n[1] - t[1] * n[0] < 0.0);
        }
    }

    #[test]
    fn edge_map_dispatch() {
        let nodes = [[0.0, 0.0], [1.0, 1.0], [0.5, 0.25]];
        let q = EdgeMap::from_nodes(&nodes).unwrap();
        let l = EdgeMap::from_nodes(&nodes[..2]).unwrap();
        assert!(EdgeMap::from_nodes(&nodes[..1]).is_none());
        assert_eq!(q.position(0.5), [0.5, 0.25]);
        assert_eq!(l.position(0.5), [0.5, 0.5]);
        assert_close(l.length_element(0.3), 2f64.sqrt(), 1e-15, "|t|");
        // y = x² has slope 0 at x = 0 and 2 at x = 1.
        assert_eq!(q.tangent(0.0), [1.0, 0.0]);
        assert_eq!(q.normal(0.0), [0.0, -1.0]);
        assert_eq!(q.tangent(1.0), [1.0, 2.0]);
    }
}
