//! The map from the reference triangle to a physical cell, straight (3 nodes) or curved
//! (6 nodes, isoparametric P2).
//!
//! With node coordinates x_i and the Lagrange shape functions φ_i of [`super::triangle`]:
//!
//! - position x(ξ) = Σ_i x_i φ_i(ξ),
//! - Jacobian J(ξ) = ∂x/∂ξ = Σ_i x_i ⊗ ∇̂φ_i(ξ), i.e. J_{ab} = ∂x_a/∂ξ_b,
//! - det J (> 0 for a counter-clockwise cell), the area element: ∫_T f dx = ∫_T̂ f(x(ξ)) det J dξ,
//! - physical gradients ∇φ = J^{−T} ∇̂φ.
//!
//! The sums are evaluated relative to vertex 0 (x = x_0 + Σ_i (x_i − x_0) φ_i, which is the same
//! because Σ_i φ_i = 1) so that cells far from the origin lose no digits.
//!
//! A 6-node cell whose mid nodes sit at the chord midpoints is the affine 3-node map; on a truly
//! curved cell J varies with ξ, det J is a quadratic polynomial, and the isoparametric P2 space
//! reproduces linear functions of x exactly but not quadratic ones. docs/design.md §4 (the fields),
//! §9 layer 1 (element tests).

use super::edge::{EDGE_NODES, LinearEdge, QuadraticEdge};
use super::triangle::{P1_GRADIENTS, P2_HESSIANS, p1_values, p2_gradients, p2_values};

/// The Jacobian J = ∂x/∂ξ of a reference-to-physical map at one point, with its determinant
/// and inverse.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Jacobian {
    /// J_{ab} = ∂x_a/∂ξ_b (row a: physical component, column b: reference direction).
    pub matrix: [[f64; 2]; 2],
    /// det J = J_00 J_11 − J_01 J_10; the ratio of physical to reference area.
    pub det: f64,
    /// J^{−1}, (J^{−1})_{ab} = ∂ξ_a/∂x_b. Infinite or NaN when det J = 0: callers reject
    /// degenerate cells (det J ≤ 0) before using it.
    pub inverse: [[f64; 2]; 2],
}

impl Jacobian {
    /// J, det J and J^{−1} = adj(J)/det J from the matrix J_{ab} = ∂x_a/∂ξ_b.
    #[inline]
    pub fn new(matrix: [[f64; 2]; 2]) -> Jacobian {
        let [[a, b], [c, d]] = matrix;
        let det = a * d - b * c;
        let r = 1.0 / det;
        Jacobian {
            matrix,
            det,
            inverse: [[d * r, -b * r], [-c * r, a * r]],
        }
    }

    /// The physical gradient ∇φ = J^{−T} ∇̂φ of a function with reference gradient `g`:
    /// (∇φ)_a = Σ_b (J^{−1})_{ba} ĝ_b.
    #[inline]
    pub fn physical_gradient(&self, g: [f64; 2]) -> [f64; 2] {
        let m = &self.inverse;
        [
            m[0][0] * g[0] + m[1][0] * g[1],
            m[0][1] * g[0] + m[1][1] * g[1],
        ]
    }

    /// [`Jacobian::physical_gradient`] of each of `N` reference gradients (for instance the
    /// P2 gradients of a displacement on a straight cell).
    #[inline]
    pub fn physical_gradients<const N: usize>(&self, g: [[f64; 2]; N]) -> [[f64; 2]; N] {
        g.map(|g| self.physical_gradient(g))
    }
}

/// x_0 + Σ_i (x_i − x_0) c_i: a combination of node coordinates with coefficients `c` summing
/// to 1 (shape function values).
#[inline]
fn combine<const N: usize>(nodes: &[[f64; 2]; N], c: [f64; N]) -> [f64; 2] {
    let o = nodes[0];
    let mut x = o;
    for i in 1..N {
        x[0] += (nodes[i][0] - o[0]) * c[i];
        x[1] += (nodes[i][1] - o[1]) * c[i];
    }
    x
}

/// Σ_i (x_i − x_0) ⊗ g_i: the Jacobian matrix from reference gradients `g` summing to 0.
#[inline]
fn jacobian_matrix<const N: usize>(nodes: &[[f64; 2]; N], g: [[f64; 2]; N]) -> [[f64; 2]; 2] {
    let o = nodes[0];
    let mut j = [[0.0; 2]; 2];
    for i in 1..N {
        let dx = [nodes[i][0] - o[0], nodes[i][1] - o[1]];
        for a in 0..2 {
            for b in 0..2 {
                j[a][b] += dx[a] * g[i][b];
            }
        }
    }
    j
}

/// A straight triangle given by its three vertices (VTK_TRIANGLE): the affine map
/// x(ξ) = x_0 + (x_1 − x_0) ξ + (x_2 − x_0) η with constant J = [x_1 − x_0 | x_2 − x_0].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LinearTriangle {
    /// Vertex coordinates x_0, x_1, x_2.
    pub nodes: [[f64; 2]; 3],
}

impl LinearTriangle {
    /// The triangle with these vertices.
    #[inline]
    pub fn new(nodes: [[f64; 2]; 3]) -> LinearTriangle {
        LinearTriangle { nodes }
    }

    /// x(ξ) = Σ_i x_i λ_i(ξ).
    #[inline]
    pub fn position(&self, xi: [f64; 2]) -> [f64; 2] {
        combine(&self.nodes, p1_values(xi))
    }

    /// The constant Jacobian [x_1 − x_0 | x_2 − x_0].
    #[inline]
    pub fn jacobian(&self) -> Jacobian {
        Jacobian::new(jacobian_matrix(&self.nodes, P1_GRADIENTS))
    }

    /// Physical gradients ∇λ_i = J^{−T} ∇̂λ_i of the P1 shape functions (constant on the cell).
    #[inline]
    pub fn gradients(&self) -> [[f64; 2]; 3] {
        self.jacobian().physical_gradients(P1_GRADIENTS)
    }

    /// Signed area ½ det J (positive for counter-clockwise vertices).
    #[inline]
    pub fn signed_area(&self) -> f64 {
        0.5 * self.jacobian().det
    }

    /// Local edge `i` (0: vertices 0→1, 1: 1→2, 2: 2→0) in the cell's order. Panics if i > 2.
    #[inline]
    pub fn edge(&self, i: usize) -> LinearEdge {
        let [a, b, _] = EDGE_NODES[i];
        LinearEdge::new([self.nodes[a], self.nodes[b]])
    }
}

/// A possibly curved triangle given by six nodes in VTK order (VTK_QUADRATIC_TRIANGLE):
/// vertices 0, 1, 2 and mid-edge nodes 3 (edge 0–1), 4 (edge 1–2), 5 (edge 2–0); the
/// isoparametric map x(ξ) = Σ_i x_i φ_i(ξ) with the P2 shape functions.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct QuadraticTriangle {
    /// Node coordinates x_0..x_5, VTK order.
    pub nodes: [[f64; 2]; 6],
}

impl QuadraticTriangle {
    /// The cell with these six nodes (VTK order).
    #[inline]
    pub fn new(nodes: [[f64; 2]; 6]) -> QuadraticTriangle {
        QuadraticTriangle { nodes }
    }

    /// The straight 6-node cell of a 3-node triangle: mid nodes at the chord midpoints.
    #[inline]
    pub fn from_linear(t: &LinearTriangle) -> QuadraticTriangle {
        let [a, b, c] = t.nodes;
        let mid = |p: [f64; 2], q: [f64; 2]| [0.5 * (p[0] + q[0]), 0.5 * (p[1] + q[1])];
        QuadraticTriangle::new([a, b, c, mid(a, b), mid(b, c), mid(c, a)])
    }

    /// The straight triangle through the three vertices.
    #[inline]
    pub fn vertices(&self) -> LinearTriangle {
        LinearTriangle::new([self.nodes[0], self.nodes[1], self.nodes[2]])
    }

    /// True when every mid node lies within `rel_tol` × (edge length) of its chord midpoint,
    /// i.e. the map is affine up to that tolerance and [`QuadraticTriangle::vertices`] can
    /// replace it (constant Jacobian).
    pub fn is_straight(&self, rel_tol: f64) -> bool {
        EDGE_NODES.iter().all(|&[a, b, m]| {
            let (p, q, r) = (self.nodes[a], self.nodes[b], self.nodes[m]);
            let off = [r[0] - 0.5 * (p[0] + q[0]), r[1] - 0.5 * (p[1] + q[1])];
            let len = (q[0] - p[0]).hypot(q[1] - p[1]);
            off[0].hypot(off[1]) <= rel_tol * len
        })
    }

    /// x(ξ) = Σ_i x_i φ_i(ξ).
    #[inline]
    pub fn position(&self, xi: [f64; 2]) -> [f64; 2] {
        combine(&self.nodes, p2_values(xi))
    }

    /// J(ξ) = Σ_i x_i ⊗ ∇̂φ_i(ξ), with det J and J^{−1}.
    #[inline]
    pub fn jacobian(&self, xi: [f64; 2]) -> Jacobian {
        Jacobian::new(jacobian_matrix(&self.nodes, p2_gradients(xi)))
    }

    /// The Jacobian at `xi` and the physical gradients ∇φ_i = J^{−T} ∇̂φ_i of the six P2
    /// shape functions there.
    #[inline]
    pub fn gradients(&self, xi: [f64; 2]) -> (Jacobian, [[f64; 2]; 6]) {
        let g = p2_gradients(xi);
        let jac = Jacobian::new(jacobian_matrix(&self.nodes, g));
        (jac, jac.physical_gradients(g))
    }

    /// The constant derivatives of the Jacobian, `d[c][a][b]` = ∂J_ab/∂ξ_c = ∂²x_a/∂ξ_b∂ξ_c
    /// (the map is quadratic, so J(ξ) = J(0) + Σ_c ξ_c `d[c]` exactly).
    pub fn jacobian_derivatives(&self) -> [[[f64; 2]; 2]; 2] {
        let o = self.nodes[0];
        let mut d = [[[0.0; 2]; 2]; 2];
        for (x, h) in self.nodes.iter().zip(&P2_HESSIANS).skip(1) {
            let dx = [x[0] - o[0], x[1] - o[1]];
            for (c, dc) in d.iter_mut().enumerate() {
                for a in 0..2 {
                    for b in 0..2 {
                        dc[a][b] += dx[a] * h[b][c];
                    }
                }
            }
        }
        d
    }

    /// Local edge `i` (0: nodes 0→1 mid 3, 1: 1→2 mid 4, 2: 2→0 mid 5) in the cell's order.
    /// Panics if i > 2.
    #[inline]
    pub fn edge(&self, i: usize) -> QuadraticEdge {
        let [a, b, m] = EDGE_NODES[i];
        QuadraticEdge::new([self.nodes[a], self.nodes[b], self.nodes[m]])
    }
}

/// A cell map of either kind, for code that handles both straight and curved meshes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CellMap {
    /// 3 nodes, constant Jacobian.
    Linear(LinearTriangle),
    /// 6 nodes, isoparametric P2.
    Quadratic(QuadraticTriangle),
}

impl CellMap {
    /// The map of a cell with 3 or 6 nodes (VTK order); `None` for any other count.
    pub fn from_nodes(nodes: &[[f64; 2]]) -> Option<CellMap> {
        match *nodes {
            [a, b, c] => Some(CellMap::Linear(LinearTriangle::new([a, b, c]))),
            [a, b, c, d, e, f] => Some(CellMap::Quadratic(QuadraticTriangle::new([
                a, b, c, d, e, f,
            ]))),
            _ => None,
        }
    }

    /// x(ξ).
    #[inline]
    pub fn position(&self, xi: [f64; 2]) -> [f64; 2] {
        match self {
            CellMap::Linear(t) => t.position(xi),
            CellMap::Quadratic(t) => t.position(xi),
        }
    }

    /// J(ξ) with det J and J^{−1}.
    #[inline]
    pub fn jacobian(&self, xi: [f64; 2]) -> Jacobian {
        match self {
            CellMap::Linear(t) => t.jacobian(),
            CellMap::Quadratic(t) => t.jacobian(xi),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::edge::{REFERENCE_NORMALS, edge_reference_point, outward_normal};
    use crate::geometry::triangle::P2_NODES;
    use crate::quadrature::{line_rule, triangle_rule};

    #[test]
    fn jacobian_derivatives_are_the_differences_of_the_affine_jacobian() {
        let t = QuadraticTriangle::new([
            [0.1, 0.2],
            [1.3, 0.05],
            [0.4, 0.9],
            [0.75, 0.02],
            [0.9, 0.6],
            [0.2, 0.5],
        ]);
        let d = t.jacobian_derivatives();
        let j0 = t.jacobian([0.2, 0.3]).matrix;
        for c in 0..2 {
            let mut xi = [0.2, 0.3];
            xi[c] += 0.5;
            let j1 = t.jacobian(xi).matrix;
            for a in 0..2 {
                for b in 0..2 {
                    assert!((j1[a][b] - j0[a][b] - 0.5 * d[c][a][b]).abs() < 1e-14);
                }
            }
        }
    }

    fn sample_points() -> Vec<[f64; 2]> {
        let mut points = vec![[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]];
        for i in 0..=6 {
            for j in 0..=(6 - i) {
                points.push([i as f64 / 6.0 * 0.98 + 0.01, j as f64 / 6.0 * 0.97]);
            }
        }
        points
    }

    fn assert_close(a: f64, b: f64, tol: f64, what: &str) {
        assert!(
            (a - b).abs() <= tol,
            "{what}: {a} vs {b} (diff {:e})",
            (a - b).abs()
        );
    }

    /// A curved cell: a general triangle with all three mid nodes moved off their chords.
    fn curved_cell() -> QuadraticTriangle {
        let v = [[0.2, -0.1], [1.7, 0.3], [0.5, 1.4]];
        let mut t = QuadraticTriangle::from_linear(&LinearTriangle::new(v));
        t.nodes[3][1] -= 0.12;
        t.nodes[4][0] += 0.08;
        t.nodes[4][1] += 0.05;
        t.nodes[5][0] -= 0.1;
        t.nodes[5][1] += 0.03;
        t
    }

    #[test]
    fn jacobian_inverse_is_inverse() {
        let t = curved_cell();
        for xi in sample_points() {
            let jac = t.jacobian(xi);
            for a in 0..2 {
                for b in 0..2 {
                    let p: f64 = (0..2).map(|k| jac.matrix[a][k] * jac.inverse[k][b]).sum();
                    assert_close(p, if a == b { 1.0 } else { 0.0 }, 1e-14, "J J⁻¹");
                }
            }
        }
    }

    #[test]
    fn map_interpolates_the_nodes() {
        let t = curved_cell();
        for (i, &node) in P2_NODES.iter().enumerate() {
            let x = t.position(node);
            assert_close(x[0], t.nodes[i][0], 1e-15, "x");
            assert_close(x[1], t.nodes[i][1], 1e-15, "y");
        }
    }

    #[test]
    fn jacobian_matches_finite_differences() {
        const H: f64 = 1e-6;
        let t = curved_cell();
        for xi in sample_points() {
            let jac = t.jacobian(xi);
            for b in 0..2 {
                let (mut p, mut m) = (xi, xi);
                p[b] += H;
                m[b] -= H;
                let (xp, xm) = (t.position(p), t.position(m));
                for a in 0..2 {
                    let fd = (xp[a] - xm[a]) / (2.0 * H);
                    assert_close(jac.matrix[a][b], fd, 1e-8, "∂x/∂ξ");
                }
            }
        }
    }

    /// Compare the 6-node map with chord-midpoint mid nodes against the 3-node map; `scale`
    /// is the size of the coordinates (rounding the mid nodes costs ~1 ulp of it).
    fn check_straight_p2_is_affine(lin: LinearTriangle, scale: f64) {
        let quad = QuadraticTriangle::from_linear(&lin);
        assert!(quad.is_straight(0.0));
        let tol = 4.0 * f64::EPSILON * scale;
        let jl = lin.jacobian();
        let gl = lin.gradients();
        for xi in sample_points() {
            let (xl, xq) = (lin.position(xi), quad.position(xi));
            for a in 0..2 {
                assert_close(xq[a], xl[a], tol, "position");
            }
            let jq = quad.jacobian(xi);
            for a in 0..2 {
                for b in 0..2 {
                    assert_close(jq.matrix[a][b], jl.matrix[a][b], 4.0 * tol, "J");
                }
            }
            assert_close(jq.det, jl.det, 8.0 * tol, "det J");
            // λ_i = φ_i + ½ Σ_{mid nodes m next to vertex i} φ_m, so the P2 gradients combine
            // to the P1 ones.
            let (_, gq) = quad.gradients(xi);
            for (i, [m1, m2]) in [[3, 5], [3, 4], [4, 5]].into_iter().enumerate() {
                for a in 0..2 {
                    let g = gq[i][a] + 0.5 * (gq[m1][a] + gq[m2][a]);
                    assert_close(g, gl[i][a], 16.0 * tol, "∇λ from ∇φ");
                }
            }
        }
    }

    #[test]
    fn straight_p2_map_is_the_affine_map() {
        check_straight_p2_is_affine(
            LinearTriangle::new([[0.2, -0.3], [1.1, 0.4], [-0.4, 0.9]]),
            1.0,
        );
        // Far from the origin: agreement to round-off of the coordinates.
        check_straight_p2_is_affine(
            LinearTriangle::new([[1e3 + 0.2, -3.0], [1e3 + 1.1, -2.6], [1e3 + 0.4, -1.9]]),
            1e3,
        );
    }

    #[test]
    fn area_of_cell_with_one_curved_edge() {
        // Right triangle (0,0), (L,0), (0,H); the mid node of edge 0 is pushed by d along the
        // outward normal (0, −1). The edge becomes the parabola through the end points with
        // apex offset d, which adds (2/3)·L·d to the area L·H/2. det J is quadratic, so every
        // rule of degree ≥ 2 integrates it exactly.
        let (l, h, d) = (2.0, 1.5, 0.3);
        let mut t =
            QuadraticTriangle::from_linear(&LinearTriangle::new([[0.0, 0.0], [l, 0.0], [0.0, h]]));
        t.nodes[3][1] -= d;
        let exact = 0.5 * l * h + 2.0 / 3.0 * l * d;
        for degree in [2, 4, 8, 12, 20] {
            let area = triangle_rule(degree).integrate(|xi| t.jacobian(xi).det);
            assert_close(area, exact, 1e-14 * exact, "area");
        }
        // Pushing it inwards removes the same amount.
        t.nodes[3][1] += 2.0 * d;
        let area = triangle_rule(2).integrate(|xi| t.jacobian(xi).det);
        assert_close(
            area,
            0.5 * l * h - 2.0 / 3.0 * l * d,
            1e-14,
            "area (inward)",
        );
    }

    #[test]
    fn curved_cell_reproduces_linear_fields_and_their_gradient() {
        // Isoparametric P2 contains every linear function of x: u = c + b·x interpolated at
        // the nodes gives u_h(ξ) = u(x(ξ)) and ∇u_h = b everywhere on the curved cell.
        let t = curved_cell();
        let (c, b) = (0.7, [-1.3, 2.1]);
        let u = |x: [f64; 2]| c + b[0] * x[0] + b[1] * x[1];
        let coeffs = t.nodes.map(u);
        for xi in sample_points() {
            let (jac, g) = t.gradients(xi);
            assert!(jac.det > 0.0);
            let mut grad = [0.0; 2];
            for i in 0..6 {
                grad[0] += coeffs[i] * g[i][0];
                grad[1] += coeffs[i] * g[i][1];
            }
            assert_close(grad[0], b[0], 1e-13, "∂u/∂x");
            assert_close(grad[1], b[1], 1e-13, "∂u/∂y");
            let value: f64 = coeffs.iter().zip(p2_values(xi)).map(|(c, p)| c * p).sum();
            assert_close(value, u(t.position(xi)), 1e-13, "u_h(ξ) = u(x(ξ))");
        }
    }

    #[test]
    fn straight_cell_reproduces_quadratic_gradients() {
        // On an affine cell P2 contains all quadratics in x, so their gradients are exact.
        let t = QuadraticTriangle::from_linear(&LinearTriangle::new([
            [0.3, 0.1],
            [1.2, 0.4],
            [0.1, 0.9],
        ]));
        let u = |[x, y]: [f64; 2]| 1.0 + x - 2.0 * y + 0.5 * x * x + 3.0 * x * y - y * y;
        let grad_u = |[x, y]: [f64; 2]| [1.0 + x + 3.0 * y, -2.0 + 3.0 * x - 2.0 * y];
        let coeffs = t.nodes.map(u);
        for xi in sample_points() {
            let (_, g) = t.gradients(xi);
            let x = t.position(xi);
            for (a, exact) in grad_u(x).into_iter().enumerate() {
                let gh: f64 = coeffs.iter().zip(&g).map(|(c, g)| c * g[a]).sum();
                assert_close(gh, exact, 1e-12, "∇u_h");
            }
        }
    }

    #[test]
    fn physical_gradients_match_finite_differences_along_the_map() {
        // d/dξ_b φ_i(ξ) = Σ_a ∂φ_i/∂x_a · J_ab: the chain rule checked with finite differences.
        const H: f64 = 1e-6;
        let t = curved_cell();
        for xi in sample_points() {
            let (jac, g) = t.gradients(xi);
            for b in 0..2 {
                let (mut p, mut m) = (xi, xi);
                p[b] += H;
                m[b] -= H;
                let (vp, vm) = (p2_values(p), p2_values(m));
                for i in 0..6 {
                    let fd = (vp[i] - vm[i]) / (2.0 * H);
                    let chain = g[i][0] * jac.matrix[0][b] + g[i][1] * jac.matrix[1][b];
                    assert_close(chain, fd, 1e-8, "chain rule");
                }
            }
        }
    }

    #[test]
    fn linear_triangle_gradients_and_area() {
        let t = LinearTriangle::new([[0.0, 0.0], [2.0, 0.0], [0.0, 4.0]]);
        assert_eq!(t.signed_area(), 4.0);
        assert_eq!(t.gradients(), [[-0.5, -0.25], [0.5, 0.0], [0.0, 0.25]]);
        let cw = LinearTriangle::new([[0.0, 0.0], [0.0, 4.0], [2.0, 0.0]]);
        assert_eq!(cw.signed_area(), -4.0);
    }

    #[test]
    fn cell_edges_follow_the_reference_edges_and_point_outwards() {
        // The cell map on local edge i at ξ(s) is the edge map at s, and the edge normal
        // (t_y, −t_x)/|t| is the outward one: parallel to J^{−T} n̂ (Nanson), n̂ the reference
        // outward normal.
        let t = curved_cell();
        let rule = line_rule(5);
        for (i, &n_hat) in REFERENCE_NORMALS.iter().enumerate() {
            let edge = t.edge(i);
            for &s in &rule.points {
                let xi = edge_reference_point(i, s);
                let (xc, xe) = (t.position(xi), edge.position(s));
                assert_close(xc[0], xe[0], 1e-15, "edge position x");
                assert_close(xc[1], xe[1], 1e-15, "edge position y");
                let n = outward_normal(edge.tangent(s));
                let m = t.jacobian(xi).physical_gradient(n_hat);
                let m_len = m[0].hypot(m[1]);
                assert_close(n[0], m[0] / m_len, 1e-14, "n_x");
                assert_close(n[1], m[1] / m_len, 1e-14, "n_y");
            }
        }
    }

    #[test]
    fn cell_map_dispatch() {
        let t = curved_cell();
        let map = CellMap::from_nodes(&t.nodes).unwrap();
        let lin = CellMap::from_nodes(&t.nodes[..3]).unwrap();
        assert!(CellMap::from_nodes(&t.nodes[..4]).is_none());
        let xi = [0.2, 0.3];
        assert_eq!(map.position(xi), t.position(xi));
        assert_eq!(map.jacobian(xi), t.jacobian(xi));
        assert_eq!(lin.jacobian(xi), t.vertices().jacobian());
        assert!(!t.is_straight(1e-3));
    }
}
