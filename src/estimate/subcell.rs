//! The oscillation pairing of one straight cell, bounded on the cells of its uniform split
//! (docs/design.md §6.2, "Oscillation on the split").
//!
//! The whole-cell bound of `bound` is (r, w)_T ≤ (h/j₁,₁) C_K ‖r‖_T ‖ε(w)‖_T for r ⊥ RM(T)
//! (r = div τ + f after the bubble of `bubble`). Here T is split L times at its edge midpoints
//! (4^L cells T_i, all similar to T: diameter h/2^L, the same K_T), and a symmetric field ζ,
//! continuous and piecewise P_j on the split and zero on ∂T (so ζ ∈ H(div) with ζn = 0 on ∂T),
//! is chosen so that r'' := r + div ζ is orthogonal to the rigid motions of every T_i. Then
//!
//! ```text
//! (r, w)_T = (r'', w)_T − (div ζ, w)_T = Σ_i (r'', w − ρ_i)_{T_i} + (ζ, ε(w))_T
//!          ≤ ((h/2^L)/j₁,₁) C_K ‖r''‖_T ‖ε(w)‖_T + ‖ζ‖_{A,T} |||w|||_T,
//! ```
//!
//! with ρ_i the rigid motion of the whole-cell argument on T_i and Cauchy–Schwarz over the
//! T_i. The second term has no Korn constant. ζ minimises the proxy ‖ζ‖²_A + W‖r + div ζ‖²
//! (W = ((h/2^L)/j₁,₁)² C_K²/c_min) under the moment constraints of every T_i but the last;
//! the last cell's moments are then those of the whole cell (ζ ∈ H₀(div) adds none to them),
//! which the equilibration makes 0. Any such ζ gives a valid bound; `bound` keeps the least of
//! the whole-cell and split bounds per cell. The constraints and the measure use the same
//! points, so the moments vanish in that rule (for a kinked f, to the rule's accuracy, as the
//! whole cell's moments do in the equilibration).

use crate::material::Elastic;
use crate::solve::dense::{cholesky, cholesky_solve};

/// Degree j of ζ on each sub-cell.
pub const DEGREE: usize = 3;

/// Interior lattice points of the split (barycentric coordinates in units of 1/(2j)).
/// The P_j nodes of the split of depth L are the points of the degree-2^L·j lattice of T; those
/// off ∂T carry the unknowns: (M − 1)(M − 2)/2 of them, M = 2^L j, 3 components each.
fn unknowns(levels: u32) -> usize {
    let m = DEGREE << levels;
    3 * (m - 1) * (m - 2) / 2
}

/// Deepest split served.
pub const MAX_LEVELS: u32 = 2;

/// Local lattice nodes (a, b, c), a + b + c = j, of one sub-cell.
const LOCAL: usize = (DEGREE + 1) * (DEGREE + 2) / 2;

/// Vertices of T₀..T₃ in barycentric coordinates of T, in units of ½.
const SUB: [[[usize; 3]; 3]; 4] = [
    [[2, 0, 0], [1, 1, 0], [1, 0, 1]],
    [[1, 1, 0], [0, 2, 0], [0, 1, 1]],
    [[1, 0, 1], [0, 1, 1], [0, 0, 2]],
    [[0, 1, 1], [1, 0, 1], [1, 1, 0]],
];

/// The symmetric unit tensors E_xx, E_xy, E_yy, row-major [xx, xy, yx, yy].
const E: [[f64; 4]; 3] = [
    [1.0, 0.0, 0.0, 0.0],
    [0.0, 1.0, 1.0, 0.0],
    [0.0, 0.0, 0.0, 1.0],
];

/// The index among the interior points of the degree-`m` lattice of the point with coordinates
/// `g` (units of 1/m), or None on ∂T.
fn node_index(g: [usize; 3], m: usize) -> Option<usize> {
    if g.contains(&0) {
        return None;
    }
    // Interior points ordered by (g0, g1): g0 = 1..m−2, g1 = 1..m−1−g0.
    let mut idx = 0;
    for a in 1..g[0] {
        idx += m - 1 - a;
    }
    Some(idx + g[1] - 1)
}

/// One level of the split: the sub-cell holding the barycentric point `lam` and its local
/// barycentric coordinates μ (∇μ_k = s ∇λ_k, s = 2 on the corner cells, −2 on the middle one).
fn locate(lam: [f64; 3]) -> (usize, [f64; 3], f64) {
    for k in 0..3 {
        if lam[k] >= 0.5 {
            let mut mu = lam.map(|l| 2.0 * l);
            mu[k] = 2.0 * lam[k] - 1.0;
            return (k, mu, 2.0);
        }
    }
    (3, lam.map(|l| 1.0 - 2.0 * l), -2.0)
}

/// The sub-cell of the depth-`levels` split holding `lam`: its index (0..4^L, the last one the
/// middle cell of the middle cells), its vertices in units of 2^−L, its local barycentric
/// coordinates and the factor s with ∇μ_k = s ∇λ_k.
fn descend(lam: [f64; 3], levels: u32) -> (usize, [[usize; 3]; 3], [f64; 3], f64) {
    let mut verts = [[1, 0, 0], [0, 1, 0], [0, 0, 1]];
    let (mut idx, mut mu, mut s) = (0, lam, 1.0);
    for _ in 0..levels {
        let (i, m, f) = locate(mu);
        verts = SUB[i].map(|sv| std::array::from_fn(|c| (0..3).map(|k| sv[k] * verts[k][c]).sum()));
        idx = 4 * idx + i;
        mu = m;
        s *= f;
    }
    (idx, verts, mu, s)
}

/// The local lattice nodes (a, b, c) of a sub-cell, in a fixed order.
fn local_nodes() -> [[usize; 3]; LOCAL] {
    let mut out = [[0; 3]; LOCAL];
    let mut i = 0;
    for a in 0..=DEGREE {
        for b in 0..=DEGREE - a {
            out[i] = [a, b, DEGREE - a - b];
            i += 1;
        }
    }
    out
}

/// The Lagrange basis function of local node `n` at μ and its derivatives ∂/∂μ_k:
/// Π_k Π_{m < n_k} (jμ_k − m)/(n_k − m).
fn lagrange(n: [usize; 3], mu: [f64; 3]) -> (f64, [f64; 3]) {
    let j = DEGREE as f64;
    let mut f = [1.0; 3];
    let mut df = [0.0; 3];
    for k in 0..3 {
        for m in 0..n[k] {
            let den = (n[k] - m) as f64;
            let t = (j * mu[k] - m as f64) / den;
            df[k] = df[k] * t + f[k] * j / den;
            f[k] *= t;
        }
    }
    (
        f[0] * f[1] * f[2],
        [
            df[0] * f[1] * f[2],
            f[0] * df[1] * f[2],
            f[0] * f[1] * df[2],
        ],
    )
}

/// One point of the cell: weight (with the Jacobian), barycentric coordinates and the residual r.
#[derive(Clone, Copy, Debug)]
pub struct Point {
    pub w: f64,
    pub lam: [f64; 3],
    pub x: [f64; 2],
    pub r: [f64; 2],
}

/// The field ζ on one straight triangle.
#[derive(Clone, Debug)]
pub struct Field {
    coef: Vec<f64>,
    grad: [[f64; 2]; 3],
    levels: u32,
}

impl Field {
    /// (index, value, divergence row) of the nonzero basis tensors at `lam`.
    fn basis(&self, lam: [f64; 3]) -> Vec<(usize, [f64; 4], [f64; 2])> {
        let (_, sv, mu, s) = descend(lam, self.levels);
        let m = DEGREE << self.levels;
        let mut out = Vec::with_capacity(3 * LOCAL);
        for n in local_nodes() {
            let g: [usize; 3] =
                std::array::from_fn(|k| n[0] * sv[0][k] + n[1] * sv[1][k] + n[2] * sv[2][k]);
            let Some(idx) = node_index(g, m) else {
                continue;
            };
            let (v, dmu) = lagrange(n, mu);
            let grad = [0, 1].map(|d| s * (0..3).map(|k| dmu[k] * self.grad[k][d]).sum::<f64>());
            for (c, ec) in E.iter().enumerate() {
                out.push((
                    3 * idx + c,
                    ec.map(|e| e * v),
                    [
                        ec[0] * grad[0] + ec[1] * grad[1],
                        ec[2] * grad[0] + ec[3] * grad[1],
                    ],
                ));
            }
        }
        out
    }

    /// ζ and div ζ at `lam`.
    pub fn at(&self, lam: [f64; 3]) -> ([f64; 4], [f64; 2]) {
        let (mut v, mut d) = ([0.0; 4], [0.0; 2]);
        for (i, bv, bd) in self.basis(lam) {
            for k in 0..4 {
                v[k] += self.coef[i] * bv[k];
            }
            d[0] += self.coef[i] * bd[0];
            d[1] += self.coef[i] * bd[1];
        }
        (v, d)
    }
}

/// The rigid motions at x (translations, rotation about `c`).
fn rigid(x: [f64; 2], c: [f64; 2]) -> [[f64; 2]; 3] {
    [[1.0, 0.0], [0.0, 1.0], [-(x[1] - c[1]), x[0] - c[0]]]
}

/// The result for one cell: ‖r + div ζ‖_T and ‖ζ‖_{A,T} measured on `check`.
#[derive(Clone, Copy, Debug)]
pub struct Relief {
    pub residual: f64,
    pub energy: f64,
}

/// ζ for the straight triangle `verts` (module doc), fitted on `fit` with the moment
/// constraints taken on `check`, and measured on `check`. None when a system is singular or a
/// value is not finite.
pub fn relieve(
    verts: [[f64; 2]; 3],
    levels: u32,
    el: &Elastic,
    weight: f64,
    fit: &[Point],
    check: &[Point],
) -> Option<(Field, Relief)> {
    if !(1..=MAX_LEVELS).contains(&levels) {
        return None;
    }
    let n_unknowns = unknowns(levels);
    let d = (verts[1][0] - verts[0][0]) * (verts[2][1] - verts[0][1])
        - (verts[2][0] - verts[0][0]) * (verts[1][1] - verts[0][1]);
    let grad: [[f64; 2]; 3] = std::array::from_fn(|m| {
        let (a, b) = (verts[(m + 1) % 3], verts[(m + 2) % 3]);
        [(a[1] - b[1]) / d, (b[0] - a[0]) / d]
    });
    if !(weight.is_finite() && weight > 0.0 && grad.iter().flatten().all(|g| g.is_finite())) {
        return None;
    }
    let mut field = Field {
        coef: vec![0.0; n_unknowns],
        grad,
        levels,
    };
    let dot = |a: &[f64; 4], b: &[f64; 4]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3];
    let mut h = vec![0.0; n_unknowns * n_unknowns];
    let mut g = vec![0.0; n_unknowns];
    for p in fit {
        let b = field.basis(p.lam);
        let ab: Vec<[f64; 4]> = b.iter().map(|(_, v, _)| el.compliance(*v)).collect();
        for (i, vi, di) in &b {
            g[*i] += p.w * weight * (di[0] * p.r[0] + di[1] * p.r[1]);
            for ((k, _, dk), ak) in b.iter().zip(&ab) {
                h[i * n_unknowns + k] +=
                    p.w * (dot(vi, ak) + weight * (di[0] * dk[0] + di[1] * dk[1]));
            }
        }
    }
    // Constraints: per sub-cell i but the last and rigid motion ρ (rotation about the sub-cell's
    // centre), Σ_check w (div ζ)·ρ = −Σ_check w r·ρ. The last cell's moments are then the whole
    // cell's (ζ ∈ H₀(div) adds none to those).
    let cells = 1usize << (2 * levels);
    let scale = (1usize << levels) as f64;
    let centre = |sv: &[[usize; 3]; 3]| -> [f64; 2] {
        let mut c = [0.0; 2];
        for v in sv {
            for k in 0..3 {
                c[0] += v[k] as f64 / scale * verts[k][0] / 3.0;
                c[1] += v[k] as f64 / scale * verts[k][1] / 3.0;
            }
        }
        c
    };
    let m = 3 * (cells - 1);
    let mut cm = vec![0.0; m * n_unknowns];
    let mut rhs = vec![0.0; m];
    for p in check {
        let (i, sv, _, _) = descend(p.lam, levels);
        if i == cells - 1 {
            continue;
        }
        let rho = rigid(p.x, centre(&sv));
        for (q, rq) in rho.iter().enumerate() {
            rhs[3 * i + q] -= p.w * (p.r[0] * rq[0] + p.r[1] * rq[1]);
        }
        for (k, _, dk) in field.basis(p.lam) {
            for (q, rq) in rho.iter().enumerate() {
                cm[(3 * i + q) * n_unknowns + k] += p.w * (dk[0] * rq[0] + dk[1] * rq[1]);
            }
        }
    }
    // Jacobi scaling of H (the A-norm and W|div|² scales differ).
    let s: Vec<f64> = (0..n_unknowns)
        .map(|i| {
            let d = h[i * n_unknowns + i];
            if d > 0.0 { 1.0 / d.sqrt() } else { 0.0 }
        })
        .collect();
    if s.contains(&0.0) {
        return None;
    }
    for i in 0..n_unknowns {
        for k in 0..n_unknowns {
            h[i * n_unknowns + k] *= s[i] * s[k];
        }
        g[i] *= s[i];
        for q in 0..m {
            cm[q * n_unknowns + i] *= s[i];
        }
    }
    let set: Vec<usize> = (0..n_unknowns).collect();
    let mut l = vec![0.0; n_unknowns * n_unknowns];
    if !cholesky(n_unknowns, &h, &set, &mut l) {
        return None;
    }
    // x = −H⁻¹(g + Cᵀλ), S λ = −d − C H⁻¹ g with S = C H⁻¹ Cᵀ.
    let mut hg = g.clone();
    cholesky_solve(n_unknowns, n_unknowns, &l, &mut hg);
    let hc: Vec<Vec<f64>> = (0..m)
        .map(|q| {
            let mut v = cm[q * n_unknowns..(q + 1) * n_unknowns].to_vec();
            cholesky_solve(n_unknowns, n_unknowns, &l, &mut v);
            v
        })
        .collect();
    let mut sm = vec![0.0; m * m];
    let mut b = vec![0.0; m];
    for q in 0..m {
        for t in 0..m {
            sm[q * m + t] = (0..n_unknowns)
                .map(|i| cm[q * n_unknowns + i] * hc[t][i])
                .sum();
        }
        b[q] = -rhs[q]
            - (0..n_unknowns)
                .map(|i| cm[q * n_unknowns + i] * hg[i])
                .sum::<f64>();
    }
    let mset: Vec<usize> = (0..m).collect();
    let mut ls = vec![0.0; m * m];
    if !cholesky(m, &sm, &mset, &mut ls) {
        return None;
    }
    cholesky_solve(m, m, &ls, &mut b);
    for i in 0..n_unknowns {
        let x = -(hg[i] + (0..m).map(|q| hc[q][i] * b[q]).sum::<f64>());
        field.coef[i] = x * s[i];
    }
    if !field.coef.iter().all(|c| c.is_finite()) {
        return None;
    }
    let (mut r2, mut e2) = (0.0, 0.0);
    for p in check {
        let (z, dz) = field.at(p.lam);
        let r = [p.r[0] + dz[0], p.r[1] + dz[1]];
        r2 += p.w * (r[0] * r[0] + r[1] * r[1]);
        e2 += p.w * dot(&z, &el.compliance(z));
    }
    let relief = Relief {
        residual: r2.sqrt(),
        energy: if e2 < 0.0 { 0.0 } else { e2.sqrt() },
    };
    (relief.residual.is_finite() && relief.energy.is_finite()).then_some((field, relief))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::quadrature::split_rule;

    const T: [[f64; 2]; 3] = [[0.3, 0.1], [1.4, 0.35], [0.5, 1.2]];

    fn el() -> Elastic {
        Elastic {
            mu: 80.0,
            lambda: 120.0,
        }
    }

    fn points(
        rule: &crate::quadrature::TriangleRule,
        r: impl Fn([f64; 2]) -> [f64; 2],
    ) -> Vec<Point> {
        let d = ((T[1][0] - T[0][0]) * (T[2][1] - T[0][1])
            - (T[2][0] - T[0][0]) * (T[1][1] - T[0][1]))
            .abs();
        rule.points
            .iter()
            .zip(&rule.weights)
            .map(|(xi, w)| {
                let lam = [1.0 - xi[0] - xi[1], xi[0], xi[1]];
                let x = [0, 1].map(|k| lam[0] * T[0][k] + lam[1] * T[1][k] + lam[2] * T[2][k]);
                Point {
                    w: w * d,
                    lam,
                    x,
                    r: r(x),
                }
            })
            .collect()
    }

    #[test]
    fn nodes_are_the_interior_lattice_points() {
        // j = 3, depth 1: the degree-6 lattice of T has 28 points, 18 on ∂T, 10 inside; depth
        // 2: degree 12, 91 points, 36 on ∂T, 55 inside. Every sub-cell node lands on the
        // lattice, and the interior ones cover the unknowns.
        for (levels, inside) in [(1, 10), (2, 55)] {
            assert_eq!(unknowns(levels), 3 * inside);
            let m = DEGREE << levels;
            let mut seen = vec![false; inside];
            let cells = 1 << (2 * levels);
            let mut hit = vec![false; cells];
            // A grid of points: every sub-cell is hit, and μ maps back to λ.
            for a in 0..=40 {
                for b in 0..=40 - a {
                    let lam = [
                        (a as f64 + 0.3) / 41.2,
                        (b as f64 + 0.3) / 41.2,
                        1.0 - (a + b) as f64 / 41.2 - 0.6 / 41.2,
                    ];
                    if lam[2] <= 0.0 {
                        continue;
                    }
                    let (i, sv, mu, _) = descend(lam, levels);
                    hit[i] = true;
                    // μ are the barycentric coordinates of lam in the sub-cell sv.
                    for c in 0..3 {
                        let back: f64 = (0..3).map(|v| mu[v] * sv[v][c] as f64).sum::<f64>()
                            / (1 << levels) as f64;
                        assert!((back - lam[c]).abs() < 1e-12, "{lam:?} {sv:?} {mu:?}");
                    }
                    for n in local_nodes() {
                        let g: [usize; 3] = std::array::from_fn(|k| {
                            n[0] * sv[0][k] + n[1] * sv[1][k] + n[2] * sv[2][k]
                        });
                        assert_eq!(g.iter().sum::<usize>(), m);
                        if let Some(idx) = node_index(g, m) {
                            seen[idx] = true;
                        }
                    }
                }
            }
            assert!(seen.iter().all(|&s| s), "depth {levels}");
            assert!(hit.iter().all(|&h| h), "depth {levels}");
        }
    }

    #[test]
    fn divergence_is_the_derivative_of_the_value() {
        let d =
            (T[1][0] - T[0][0]) * (T[2][1] - T[0][1]) - (T[2][0] - T[0][0]) * (T[1][1] - T[0][1]);
        let grad: [[f64; 2]; 3] = std::array::from_fn(|m| {
            let (a, b) = (T[(m + 1) % 3], T[(m + 2) % 3]);
            [(a[1] - b[1]) / d, (b[0] - a[0]) / d]
        });
        let f = Field {
            coef: (0..unknowns(2))
                .map(|i| ((i * 37 % 11) as f64 - 5.0) / 7.0)
                .collect(),
            grad,
            levels: 2,
        };
        // Barycentric coordinates of x, central differences inside each sub-cell.
        let lam_of = |x: [f64; 2]| {
            let l1 = ((x[0] - T[0][0]) * (T[2][1] - T[0][1])
                - (x[1] - T[0][1]) * (T[2][0] - T[0][0]))
                / d;
            let l2 = ((T[1][0] - T[0][0]) * (x[1] - T[0][1])
                - (T[1][1] - T[0][1]) * (x[0] - T[0][0]))
                / d;
            [1.0 - l1 - l2, l1, l2]
        };
        for lam in [
            [0.7, 0.2, 0.1],
            [0.1, 0.7, 0.2],
            [0.62, 0.21, 0.17],
            [0.2, 0.1, 0.7],
            [0.3, 0.35, 0.35],
        ] {
            let x = [0, 1].map(|k| lam[0] * T[0][k] + lam[1] * T[1][k] + lam[2] * T[2][k]);
            let eps = 1e-6;
            let dv = |k: usize| {
                let (mut xp, mut xm) = (x, x);
                xp[k] += eps;
                xm[k] -= eps;
                let (a, b) = (f.at(lam_of(xp)).0, f.at(lam_of(xm)).0);
                std::array::from_fn::<f64, 4, _>(|c| (a[c] - b[c]) / (2.0 * eps))
            };
            let (gx, gy) = (dv(0), dv(1));
            let div = f.at(lam).1;
            assert!(
                (div[0] - (gx[0] + gy[1])).abs() < 1e-6 * (1.0 + div[0].abs()),
                "{div:?}"
            );
            assert!(
                (div[1] - (gx[2] + gy[3])).abs() < 1e-6 * (1.0 + div[1].abs()),
                "{div:?}"
            );
        }
    }

    #[test]
    fn zeta_is_continuous_and_vanishes_on_the_boundary() {
        let f = Field {
            coef: (0..unknowns(2))
                .map(|i| ((i * 37 % 11) as f64 - 5.0) / 7.0)
                .collect(),
            grad: [[0.0; 2]; 3],
            levels: 2,
        };
        // Across the interior edge λ₀ = ½ (T₀ | T₃), and on ∂T.
        for t in [0.1, 0.27, 0.4] {
            let a = f.at([0.5 + 1e-13, t, 0.5 - t - 1e-13]).0;
            let b = f.at([0.5 - 1e-13, t, 0.5 - t + 1e-13]).0;
            assert!(
                a.iter().zip(&b).all(|(x, y)| (x - y).abs() < 1e-10),
                "{a:?} {b:?}"
            );
            let z = f.at([0.0, t, 1.0 - t]).0;
            assert!(z.iter().all(|x| x.abs() < 1e-14), "{z:?}");
        }
    }

    #[test]
    fn relieved_residual_is_orthogonal_to_the_rigid_motions_of_every_sub_cell() {
        // A kinked residual with zero moments against the rigid motions of T (as after the
        // equilibration): its moments are removed on the three corner cells of depth 1 and the
        // fifteen first cells of depth 2, and the last cell's follow.
        let raw = |x: [f64; 2]| [(x[0] - 0.7).abs(), (x[1] - 0.5).max(0.0) * 2.0 - x[0]];
        for levels in [1, 2] {
            let fit = points(&split_rule(12, levels), raw);
            let mut check = points(&split_rule(15, levels), raw);
            // Make r ⊥ RM(T) on the check points: subtract its L² projection onto RM(T).
            let c = [
                (T[0][0] + T[1][0] + T[2][0]) / 3.0,
                (T[0][1] + T[1][1] + T[2][1]) / 3.0,
            ];
            let mut g = [[0.0; 3]; 3];
            let mut b = [0.0; 3];
            for p in &check {
                let rho = rigid(p.x, c);
                for q in 0..3 {
                    b[q] += p.w * (p.r[0] * rho[q][0] + p.r[1] * rho[q][1]);
                    for t in 0..3 {
                        g[q][t] += p.w * (rho[q][0] * rho[t][0] + rho[q][1] * rho[t][1]);
                    }
                }
            }
            // g is diagonal (translations ⊥ the rotation about the centroid).
            for p in check.iter_mut() {
                let rho = rigid(p.x, c);
                for q in 0..3 {
                    let a = b[q] / g[q][q];
                    p.r[0] -= a * rho[q][0];
                    p.r[1] -= a * rho[q][1];
                }
            }
            let (z, relief) = relieve(T, levels, &el(), 0.01, &fit, &check).expect("a field");
            let cells = 1 << (2 * levels);
            let mut mom = vec![[0.0; 3]; cells];
            let mut scale = 0.0;
            for p in &check {
                let (i, sv, _, _) = descend(p.lam, levels);
                let mut cc = [0.0; 2];
                for v in sv {
                    for k in 0..3 {
                        cc[0] += v[k] as f64 / (1 << levels) as f64 * T[k][0] / 3.0;
                        cc[1] += v[k] as f64 / (1 << levels) as f64 * T[k][1] / 3.0;
                    }
                }
                let dz = z.at(p.lam).1;
                let rr = [p.r[0] + dz[0], p.r[1] + dz[1]];
                for (q, rq) in rigid(p.x, cc).iter().enumerate() {
                    mom[i][q] += p.w * (rr[0] * rq[0] + rr[1] * rq[1]);
                }
                scale += p.w * (p.r[0].abs() + p.r[1].abs());
            }
            for (i, m) in mom.iter().enumerate() {
                for (q, v) in m.iter().enumerate() {
                    assert!(
                        v.abs() < 1e-12 * scale,
                        "depth {levels} T{i} moment {q}: {v}"
                    );
                }
            }
            assert!(relief.residual > 0.0 && relief.energy > 0.0);
        }
    }
}
