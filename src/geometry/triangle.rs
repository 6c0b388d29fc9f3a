//! Lagrange shape functions on the reference triangle and the reference edge (docs/design.md §4:
//! displacements as P1 or P2 point data).
//!
//! Reference triangle T̂ with vertices (0,0), (1,0), (0,1), barycentric coordinates
//! λ0 = 1 − ξ − η, λ1 = ξ, λ2 = η (∇̂λ0 = (−1, −1), ∇̂λ1 = (1, 0), ∇̂λ2 = (0, 1)).
//! Node order is VTK's: vertices 0, 1, 2, then the mid-edge nodes 3 on edge (0,1), 4 on edge
//! (1,2), 5 on edge (2,0).
//!
//! | node | P1 | P2 |
//! |---|---|---|
//! | 0, 1, 2 (vertex i) | λi | λi (2λi − 1) |
//! | 3 (edge 0–1) | | 4 λ0 λ1 |
//! | 4 (edge 1–2) | | 4 λ1 λ2 |
//! | 5 (edge 2–0) | | 4 λ2 λ0 |
//!
//! Reference edge [0, 1] (VTK line order: ends 0, 1, then the mid node 2):
//! P1: (1 − s, s); P2: ((1 − s)(1 − 2s), s(2s − 1), 4s(1 − s)).
//!
//! All functions take fixed-size arrays and return fixed-size arrays: no allocation.

/// Reference coordinates of the three P1 nodes (the vertices).
pub const P1_NODES: [[f64; 2]; 3] = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]];

/// Reference coordinates of the six P2 nodes, VTK order.
pub const P2_NODES: [[f64; 2]; 6] = [
    [0.0, 0.0],
    [1.0, 0.0],
    [0.0, 1.0],
    [0.5, 0.0],
    [0.5, 0.5],
    [0.0, 0.5],
];

/// Reference gradients ∇̂λi of the P1 shape functions (constant).
pub const P1_GRADIENTS: [[f64; 2]; 3] = [[-1.0, -1.0], [1.0, 0.0], [0.0, 1.0]];

/// Barycentric coordinates (λ0, λ1, λ2) = (1 − ξ − η, ξ, η) of the reference point `xi`.
#[inline]
pub fn barycentric(xi: [f64; 2]) -> [f64; 3] {
    [1.0 - xi[0] - xi[1], xi[0], xi[1]]
}

/// P1 shape functions φi = λi at `xi`.
#[inline]
pub fn p1_values(xi: [f64; 2]) -> [f64; 3] {
    barycentric(xi)
}

/// Reference gradients ∇̂φi of the P1 shape functions (independent of the point; see
/// [`P1_GRADIENTS`]). Takes `xi` for symmetry with [`p2_gradients`].
#[inline]
pub fn p1_gradients(_xi: [f64; 2]) -> [[f64; 2]; 3] {
    P1_GRADIENTS
}

/// P2 shape functions at `xi`, VTK order: λi(2λi − 1) at the vertices, 4λaλb at the
/// mid-edge nodes.
#[inline]
pub fn p2_values(xi: [f64; 2]) -> [f64; 6] {
    let [l0, l1, l2] = barycentric(xi);
    [
        l0 * (2.0 * l0 - 1.0),
        l1 * (2.0 * l1 - 1.0),
        l2 * (2.0 * l2 - 1.0),
        4.0 * l0 * l1,
        4.0 * l1 * l2,
        4.0 * l2 * l0,
    ]
}

/// Reference gradients ∇̂φi = (∂φi/∂ξ, ∂φi/∂η) of the P2 shape functions at `xi`:
/// ∇̂(λi(2λi − 1)) = (4λi − 1)∇̂λi and ∇̂(4λaλb) = 4(λa∇̂λb + λb∇̂λa).
#[inline]
pub fn p2_gradients(xi: [f64; 2]) -> [[f64; 2]; 6] {
    let [l0, l1, l2] = barycentric(xi);
    let d0 = 4.0 * l0 - 1.0;
    [
        [-d0, -d0],
        [4.0 * l1 - 1.0, 0.0],
        [0.0, 4.0 * l2 - 1.0],
        [4.0 * (l0 - l1), -4.0 * l1],
        [4.0 * l2, 4.0 * l1],
        [-4.0 * l2, 4.0 * (l0 - l2)],
    ]
}

/// Reference Hessians ∂²φi/∂ξ_b∂ξ_c of the P2 shape functions (constant, VTK order):
/// 4∇̂λi ⊗ ∇̂λi at the vertices, 4(∇̂λa ⊗ ∇̂λb + ∇̂λb ⊗ ∇̂λa) at the mid-edge nodes.
pub const P2_HESSIANS: [[[f64; 2]; 2]; 6] = [
    [[4.0, 4.0], [4.0, 4.0]],
    [[4.0, 0.0], [0.0, 0.0]],
    [[0.0, 0.0], [0.0, 4.0]],
    [[-8.0, -4.0], [-4.0, 0.0]],
    [[0.0, 4.0], [4.0, 0.0]],
    [[0.0, -4.0], [-4.0, -8.0]],
];

/// Values of the P1 (`n` = 3) or P2 (`n` = 6) shape functions at `xi`, in six slots (the
/// unused P1 slots are 0): one signature for cells of either degree.
#[inline]
pub fn shape_values(n: usize, xi: [f64; 2]) -> [f64; 6] {
    if n == 6 {
        p2_values(xi)
    } else {
        let v = p1_values(xi);
        [v[0], v[1], v[2], 0.0, 0.0, 0.0]
    }
}

/// Reference gradients of the P1 (`n` = 3) or P2 (`n` = 6) shape functions at `xi`, in six
/// slots (the unused P1 slots are 0).
#[inline]
pub fn shape_gradients(n: usize, xi: [f64; 2]) -> [[f64; 2]; 6] {
    if n == 6 {
        p2_gradients(xi)
    } else {
        let g = P1_GRADIENTS;
        [g[0], g[1], g[2], [0.0; 2], [0.0; 2], [0.0; 2]]
    }
}

/// The Jacobian J_{ab} = Σ_i (x_i − x_0)_a ∂̂_b φ_i of the P1/P2 cell map with node
/// coordinates `x` (first `n` used) at the point whose reference gradients are `g`: relative to
/// node 0 so that cells far from the origin lose no digits.
#[inline]
pub fn jacobian(x: &[[f64; 2]; 6], n: usize, g: &[[f64; 2]; 6]) -> super::map::Jacobian {
    let mut m = [[0.0; 2]; 2];
    for i in 1..n {
        let d = [x[i][0] - x[0][0], x[i][1] - x[0][1]];
        for a in 0..2 {
            for b in 0..2 {
                m[a][b] += d[a] * g[i][b];
            }
        }
    }
    super::map::Jacobian::new(m)
}

/// Linear edge shape functions (1 − s, s) at s ∈ [0, 1].
#[inline]
pub fn line_p1_values(s: f64) -> [f64; 2] {
    [1.0 - s, s]
}

/// Derivatives d/ds of the linear edge shape functions: (−1, 1).
#[inline]
pub fn line_p1_derivatives(_s: f64) -> [f64; 2] {
    [-1.0, 1.0]
}

/// Quadratic edge shape functions, VTK order (ends 0, 1, mid 2):
/// ((1 − s)(1 − 2s), s(2s − 1), 4s(1 − s)).
#[inline]
pub fn line_p2_values(s: f64) -> [f64; 3] {
    [
        (1.0 - s) * (1.0 - 2.0 * s),
        s * (2.0 * s - 1.0),
        4.0 * s * (1.0 - s),
    ]
}

/// Derivatives d/ds of the quadratic edge shape functions: (4s − 3, 4s − 1, 4 − 8s).
#[inline]
pub fn line_p2_derivatives(s: f64) -> [f64; 3] {
    [4.0 * s - 3.0, 4.0 * s - 1.0, 4.0 - 8.0 * s]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Points inside and on the boundary of the reference triangle.
    fn sample_points() -> Vec<[f64; 2]> {
        let mut points = vec![[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0 / 3.0, 1.0 / 3.0]];
        for i in 0..=7 {
            for j in 0..=(7 - i) {
                points.push([i as f64 / 7.0 + 0.013, j as f64 / 7.0 * 0.97]);
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

    #[test]
    fn p1_nodality() {
        for (j, &node) in P1_NODES.iter().enumerate() {
            let phi = p1_values(node);
            for (i, &v) in phi.iter().enumerate() {
                assert_eq!(v, if i == j { 1.0 } else { 0.0 }, "φ{i}(node {j})");
            }
        }
    }

    #[test]
    fn p2_nodality() {
        for (j, &node) in P2_NODES.iter().enumerate() {
            let phi = p2_values(node);
            for (i, &v) in phi.iter().enumerate() {
                assert_eq!(v, if i == j { 1.0 } else { 0.0 }, "φ{i}(node {j})");
            }
        }
    }

    #[test]
    fn line_nodality() {
        for (j, s) in [0.0, 1.0].into_iter().enumerate() {
            for (i, v) in line_p1_values(s).into_iter().enumerate() {
                assert_eq!(v, if i == j { 1.0 } else { 0.0 });
            }
        }
        for (j, s) in [0.0, 1.0, 0.5].into_iter().enumerate() {
            for (i, v) in line_p2_values(s).into_iter().enumerate() {
                assert_eq!(v, if i == j { 1.0 } else { 0.0 });
            }
        }
    }

    #[test]
    fn partition_of_unity_and_zero_sum_gradients() {
        for xi in sample_points() {
            assert_close(p1_values(xi).iter().sum(), 1.0, 1e-15, "Σ P1");
            assert_close(p2_values(xi).iter().sum(), 1.0, 1e-14, "Σ P2");
            for d in 0..2 {
                assert_close(
                    p1_gradients(xi).iter().map(|g| g[d]).sum(),
                    0.0,
                    0.0,
                    "Σ∇ P1",
                );
                assert_close(
                    p2_gradients(xi).iter().map(|g| g[d]).sum(),
                    0.0,
                    1e-14,
                    "Σ∇ P2",
                );
            }
        }
        for k in 0..=10 {
            let s = k as f64 / 10.0;
            assert_close(line_p1_values(s).iter().sum(), 1.0, 1e-15, "Σ line P1");
            assert_close(line_p2_values(s).iter().sum(), 1.0, 1e-15, "Σ line P2");
            assert_close(
                line_p2_derivatives(s).iter().sum(),
                0.0,
                1e-15,
                "Σ d line P2",
            );
        }
    }

    #[test]
    fn p2_reproduces_quadratics() {
        // Σ f(node_i) φi = f for f in span{1, ξ, η, ξ², ξη, η²}.
        let f =
            |[x, y]: [f64; 2]| 0.3 - 1.1 * x + 0.7 * y + 2.0 * x * x - 0.4 * x * y + 1.3 * y * y;
        for xi in sample_points() {
            let phi = p2_values(xi);
            let u: f64 = P2_NODES.iter().zip(phi).map(|(&n, p)| f(n) * p).sum();
            assert_close(u, f(xi), 1e-14, "P2 interpolant");
        }
    }

    #[test]
    fn gradients_match_finite_differences() {
        const H: f64 = 1e-6;
        for xi in sample_points() {
            let fd = |f: &dyn Fn([f64; 2]) -> Vec<f64>, d: usize| -> Vec<f64> {
                let mut plus = xi;
                let mut minus = xi;
                plus[d] += H;
                minus[d] -= H;
                f(plus)
                    .iter()
                    .zip(f(minus))
                    .map(|(a, b)| (a - b) / (2.0 * H))
                    .collect()
            };
            for d in 0..2 {
                let p1 = fd(&|x| p1_values(x).to_vec(), d);
                let p2 = fd(&|x| p2_values(x).to_vec(), d);
                for (g, fd) in p1_gradients(xi).iter().zip(p1) {
                    assert_close(g[d], fd, 1e-8, "∇P1");
                }
                for (g, fd) in p2_gradients(xi).iter().zip(p2) {
                    assert_close(g[d], fd, 1e-8, "∇P2");
                }
            }
        }
    }

    #[test]
    fn line_derivatives_match_finite_differences() {
        const H: f64 = 1e-6;
        for k in 0..=10 {
            let s = k as f64 / 10.0;
            let p1 = line_p1_derivatives(s);
            let p2 = line_p2_derivatives(s);
            let (p1_plus, p1_minus) = (line_p1_values(s + H), line_p1_values(s - H));
            for (i, d) in p1.into_iter().enumerate() {
                assert_close(d, (p1_plus[i] - p1_minus[i]) / (2.0 * H), 1e-8, "d line P1");
            }
            let (p2_plus, p2_minus) = (line_p2_values(s + H), line_p2_values(s - H));
            for (i, d) in p2.into_iter().enumerate() {
                assert_close(d, (p2_plus[i] - p2_minus[i]) / (2.0 * H), 1e-8, "d line P2");
            }
        }
    }

    #[test]
    fn triangle_p2_restricted_to_an_edge_is_line_p2() {
        // On edge 0 (η = 0, from vertex 0 to vertex 1, mid node 3) the triangle's P2 functions
        // of nodes (0, 1, 3) are the line's P2 functions of (end 0, end 1, mid).
        for k in 0..=10 {
            let s = k as f64 / 10.0;
            let tri = p2_values([s, 0.0]);
            let line = line_p2_values(s);
            assert_close(tri[0], line[0], 1e-15, "edge 0, end 0");
            assert_close(tri[1], line[1], 1e-15, "edge 0, end 1");
            assert_close(tri[3], line[2], 1e-15, "edge 0, mid");
            for i in [2, 4, 5] {
                assert_close(tri[i], 0.0, 1e-15, "off-edge node");
            }
        }
    }
}
