//! Lagrange and serendipity shape functions on the reference square Q̂ = [0, 1]²
//! (docs/design.md §4.3), VTK node order:
//!
//! | node | position | Q1 | Q2 (biquadratic) |
//! |---|---|---|---|
//! | 0 | (0, 0) | (1−ξ)(1−η) | L₀(ξ)L₀(η) |
//! | 1 | (1, 0) | ξ(1−η) | L₁(ξ)L₀(η) |
//! | 2 | (1, 1) | ξη | L₁(ξ)L₁(η) |
//! | 3 | (0, 1) | (1−ξ)η | L₀(ξ)L₁(η) |
//! | 4 | (½, 0) | | L_m(ξ)L₀(η) |
//! | 5 | (1, ½) | | L₁(ξ)L_m(η) |
//! | 6 | (½, 1) | | L_m(ξ)L₁(η) |
//! | 7 | (0, ½) | | L₀(ξ)L_m(η) |
//! | 8 | (½, ½) | | L_m(ξ)L_m(η) |
//!
//! with the 1D quadratics L₀(t) = (1−t)(1−2t), L₁(t) = t(2t−1), L_m(t) = 4t(1−t). The
//! 8-node serendipity element (VTK_QUADRATIC_QUAD) uses nodes 0–7 with, in r = 2ξ−1,
//! s = 2η−1 and the node's (r_i, s_i) ∈ {−1, 0, 1}²:
//! corners ¼(1+r r_i)(1+s s_i)(r r_i + s s_i − 1), mid nodes on r_i = 0: ½(1−r²)(1+s s_i),
//! on s_i = 0: ½(1+r r_i)(1−s²) (Zienkiewicz–Taylor, The Finite Element Method, vol. 1 §8.7).
//! VTK_LAGRANGE_QUADRILATERAL of order 2 has the same node order as the biquadratic quad
//! (edges 0→1, 1→2, 3→2, 0→3 each hold one node, then the centre).

/// Reference positions of the nodes, VTK order.
pub const NODES: [[f64; 2]; 9] = [
    [0.0, 0.0],
    [1.0, 0.0],
    [1.0, 1.0],
    [0.0, 1.0],
    [0.5, 0.0],
    [1.0, 0.5],
    [0.5, 1.0],
    [0.0, 0.5],
    [0.5, 0.5],
];

#[inline]
fn quadratics(t: f64) -> ([f64; 3], [f64; 3]) {
    (
        [
            (1.0 - t) * (1.0 - 2.0 * t),
            t * (2.0 * t - 1.0),
            4.0 * t * (1.0 - t),
        ],
        [4.0 * t - 3.0, 4.0 * t - 1.0, 4.0 - 8.0 * t],
    )
}

/// Q1 values and reference gradients.
#[inline]
pub fn q1(xi: [f64; 2]) -> ([f64; 4], [[f64; 2]; 4]) {
    let [x, y] = xi;
    (
        [(1.0 - x) * (1.0 - y), x * (1.0 - y), x * y, (1.0 - x) * y],
        [
            [-(1.0 - y), -(1.0 - x)],
            [1.0 - y, -x],
            [y, x],
            [-y, 1.0 - x],
        ],
    )
}

/// Index pairs (i in ξ, j in η) of the 1D factors of each Q2 node: 0 = L₀, 1 = L₁, 2 = L_m.
const Q2_FACTORS: [[usize; 2]; 9] = [
    [0, 0],
    [1, 0],
    [1, 1],
    [0, 1],
    [2, 0],
    [1, 2],
    [2, 1],
    [0, 2],
    [2, 2],
];

/// Q2 values and reference gradients.
#[inline]
pub fn q2(xi: [f64; 2]) -> ([f64; 9], [[f64; 2]; 9]) {
    let (lx, dx) = quadratics(xi[0]);
    let (ly, dy) = quadratics(xi[1]);
    let mut v = [0.0; 9];
    let mut g = [[0.0; 2]; 9];
    for (k, &[i, j]) in Q2_FACTORS.iter().enumerate() {
        v[k] = lx[i] * ly[j];
        g[k] = [dx[i] * ly[j], lx[i] * dy[j]];
    }
    (v, g)
}

/// 8-node serendipity values and reference gradients.
#[inline]
pub fn s2(xi: [f64; 2]) -> ([f64; 8], [[f64; 2]; 8]) {
    let r = 2.0 * xi[0] - 1.0;
    let s = 2.0 * xi[1] - 1.0;
    let mut v = [0.0; 8];
    let mut g = [[0.0; 2]; 8];
    for k in 0..8 {
        let ri = 2.0 * NODES[k][0] - 1.0;
        let si = 2.0 * NODES[k][1] - 1.0;
        // d/dξ = 2 d/dr.
        let (val, dr, ds) = if k < 4 {
            let a = 1.0 + r * ri;
            let b = 1.0 + s * si;
            let c = r * ri + s * si - 1.0;
            (
                0.25 * a * b * c,
                0.25 * (ri * b * c + a * b * ri),
                0.25 * (a * si * c + a * b * si),
            )
        } else if ri == 0.0 {
            let b = 1.0 + s * si;
            (0.5 * (1.0 - r * r) * b, -r * b, 0.5 * (1.0 - r * r) * si)
        } else {
            let a = 1.0 + r * ri;
            (0.5 * a * (1.0 - s * s), 0.5 * ri * (1.0 - s * s), -a * s)
        };
        v[k] = val;
        g[k] = [2.0 * dr, 2.0 * ds];
    }
    (v, g)
}

#[cfg(test)]
mod tests {
    use super::*;

    type Shapes<const N: usize> = fn([f64; 2]) -> ([f64; N], [[f64; 2]; N]);

    fn check_family<const N: usize>(f: Shapes<N>) {
        // Nodality: φ_i(x_j) = δ_ij.
        for (j, &p) in NODES.iter().take(N).enumerate() {
            let (v, _) = f(p);
            for (i, &vi) in v.iter().enumerate() {
                let want = if i == j { 1.0 } else { 0.0 };
                assert!((vi - want).abs() < 1e-14, "node {j} function {i}: {vi}");
            }
        }
        // Partition of unity, linear reproduction and gradients against central differences.
        let h = 1e-6;
        for &p in &[[0.3, 0.7], [0.11, 0.42], [0.9, 0.05]] {
            let (v, g) = f(p);
            let sum: f64 = v.iter().sum();
            assert!((sum - 1.0).abs() < 1e-14);
            let mut lin = [0.0; 2];
            for (i, vi) in v.iter().enumerate() {
                lin[0] += vi * NODES[i][0];
                lin[1] += vi * NODES[i][1];
            }
            assert!((lin[0] - p[0]).abs() < 1e-14 && (lin[1] - p[1]).abs() < 1e-14);
            for d in 0..2 {
                let mut a = p;
                let mut b = p;
                a[d] += h;
                b[d] -= h;
                let (va, _) = f(a);
                let (vb, _) = f(b);
                for i in 0..N {
                    let fd = (va[i] - vb[i]) / (2.0 * h);
                    assert!((fd - g[i][d]).abs() < 1e-8, "function {i} dir {d}");
                }
            }
        }
    }

    #[test]
    fn q1_q2_s2_are_nodal_partitions_of_unity_with_right_gradients() {
        check_family(q1);
        check_family(q2);
        check_family(s2);
    }

    #[test]
    fn s2_reproduces_quadratics_but_not_x2y2() {
        // Serendipity spans {1, ξ, η, ξ², ξη, η², ξ²η, ξη²}: the interpolant of ξ²η is exact,
        // that of ξ²η² is not.
        let f = |p: [f64; 2]| p[0] * p[0] * p[1];
        let g = |p: [f64; 2]| p[0] * p[0] * p[1] * p[1];
        let p = [0.37, 0.81];
        let (v, _) = s2(p);
        let interp = |h: &dyn Fn([f64; 2]) -> f64| {
            v.iter()
                .enumerate()
                .map(|(i, vi)| vi * h(NODES[i]))
                .sum::<f64>()
        };
        assert!((interp(&f) - f(p)).abs() < 1e-14);
        assert!((interp(&g) - g(p)).abs() > 1e-3);
    }
}
