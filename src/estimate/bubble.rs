//! A symmetric cell-bubble correction that moves most of the body-force oscillation of a cell
//! into the constant-free Prager–Synge term (docs/design.md §6.2, "Oscillation").
//!
//! On a straight triangle T with barycentric coordinates λ₀, λ₁, λ₂ and bubble b = λ₀λ₁λ₂, the
//! correction is
//!
//! ```text
//! δ = b S,   S = Σ_{|α| = j, c} s_αc λ^α E_c,   E_xx, E_xy = e_x⊗e_y + e_y⊗e_x, E_yy,
//! ```
//!
//! with j = [`S_DEGREE`] = 4 (45 unknowns; δ has degree j + 3, div δ degree j + 2).
//!
//! δ vanishes on ∂T (so τ + δ keeps every normal trace: continuity, tractions and contact
//! signs), it is symmetric (as(τ + δ) = as τ: the symmetric correction of §5.11 is unchanged),
//! and for every rigid motion ρ, (div δ, ρ)_T = −(δ, ε(ρ))_T = 0, so r' = div(τ + δ) + f keeps
//! r's orthogonality to the rigid motions that the Payne–Weinberger–Korn oscillation bound
//! needs. Any such δ therefore gives a valid bound; it is chosen to minimise the cell's share
//!
//! ```text
//! ‖sym τ + δ − Cε(v)‖²_A + W ‖r + div δ‖²,    W = (h_T/j₁,₁)² (1 + ½K_T²) / c_min,
//! ```
//!
//! i.e. η_PS,T² + η_osc,T² of the module `bound`: the part of r that div δ ∈ P₆ can reach is
//! paid for in the A-norm of δ, with no Korn constant, instead of at (h/j₁,₁)(1 + ½K²)^½ ≈ 1.9 h
//! with K ≈ 10. The module `bound` fits δ on the points of one rule and measures the share on
//! the points of another (a fit matches a kinked r at its own points better than in L²).
//! Measured on the manufactured P2 family (design §6.2), see [`S_DEGREE`].

use crate::material::Elastic;
use crate::solve::dense::{cholesky, cholesky_solve};

/// Degree j of S: δ = b S has degree j + 3 and div δ reaches P_{j+2}.
pub const S_DEGREE: usize = 4;

/// Number of scalars q_α, |α| = j.
const SCALARS: usize = (S_DEGREE + 1) * (S_DEGREE + 2) / 2;

/// Unknowns: the scalars q_α × 3 symmetric components.
const N: usize = 3 * SCALARS;

/// Exponents e = α + (1, 1, 1), |α| = j, of the scalars q_α = b λ^α = λ^e.
const EXPONENTS: [[u32; 3]; SCALARS] = {
    let j = S_DEGREE as u32;
    let mut out = [[0u32; 3]; SCALARS];
    let (mut i, mut a) = (0, j + 1);
    while a > 0 {
        a -= 1;
        let mut b = j - a + 1;
        while b > 0 {
            b -= 1;
            out[i] = [a + 1, b + 1, j - a - b + 1];
            i += 1;
        }
    }
    out
};

/// The symmetric unit tensors E_xx, E_xy, E_yy, row-major [xx, xy, yx, yy].
const E: [[f64; 4]; 3] = [
    [1.0, 0.0, 0.0, 0.0],
    [0.0, 1.0, 1.0, 0.0],
    [0.0, 0.0, 0.0, 1.0],
];

/// One quadrature point of the cell: weight (with the Jacobian), barycentric coordinates, the
/// mismatch m = sym τ − Cε(v) and the residual r = div τ + f there.
#[derive(Clone, Copy, Debug)]
pub struct Point {
    pub w: f64,
    pub lam: [f64; 3],
    pub mismatch: [f64; 4],
    pub r: [f64; 2],
}

/// The fitted correction δ = b S on one straight triangle.
#[derive(Clone, Copy, Debug)]
pub struct Bubble {
    coef: [f64; N],
    /// Physical gradients of λ₀, λ₁, λ₂ (constant on a straight triangle).
    grad: [[f64; 2]; 3],
}

impl Bubble {
    /// Basis values β_i (tensors) and divergences at `lam`, i = 3α + c.
    fn basis(&self, lam: [f64; 3]) -> ([[f64; 4]; N], [[f64; 2]; N]) {
        let mut val = [[0.0; 4]; N];
        let mut div = [[0.0; 2]; N];
        let pw = |x: f64, n: u32| x.powi(n as i32);
        for (a, e) in EXPONENTS.iter().enumerate() {
            let q = pw(lam[0], e[0]) * pw(lam[1], e[1]) * pw(lam[2], e[2]);
            let mut g = [0.0; 2];
            for m in 0..3 {
                let mut d = e[m] as f64;
                for (k, &ek) in e.iter().enumerate() {
                    d *= pw(lam[k], if k == m { ek - 1 } else { ek });
                }
                g[0] += d * self.grad[m][0];
                g[1] += d * self.grad[m][1];
            }
            for (c, ec) in E.iter().enumerate() {
                val[3 * a + c] = ec.map(|x| x * q);
                // Row r of div(q E) = Σ_s E_rs ∂_s q.
                div[3 * a + c] = [ec[0] * g[0] + ec[1] * g[1], ec[2] * g[0] + ec[3] * g[1]];
            }
        }
        (val, div)
    }

    /// δ and div δ at barycentric coordinates `lam`, row-major [xx, xy, yx, yy].
    pub fn at(&self, lam: [f64; 3]) -> ([f64; 4], [f64; 2]) {
        let (val, div) = self.basis(lam);
        let v = std::array::from_fn(|k| self.coef.iter().zip(&val).map(|(c, b)| c * b[k]).sum());
        let d = std::array::from_fn(|k| self.coef.iter().zip(&div).map(|(c, b)| c * b[k]).sum());
        (v, d)
    }

    /// δ at barycentric coordinates `lam`.
    pub fn value(&self, lam: [f64; 3]) -> [f64; 4] {
        self.at(lam).0
    }

    /// div δ at barycentric coordinates `lam` (row-wise).
    pub fn divergence(&self, lam: [f64; 3]) -> [f64; 2] {
        self.at(lam).1
    }

    /// Degree of δ as a polynomial (b has degree 3).
    pub const DEGREE: usize = S_DEGREE + 3;
}

/// Physical gradients of the barycentric coordinates of the straight triangle `v`.
fn barycentric_gradients(v: [[f64; 2]; 3]) -> [[f64; 2]; 3] {
    let d = (v[1][0] - v[0][0]) * (v[2][1] - v[0][1]) - (v[2][0] - v[0][0]) * (v[1][1] - v[0][1]);
    std::array::from_fn(|m| {
        let (a, b) = (v[(m + 1) % 3], v[(m + 2) % 3]);
        [(a[1] - b[1]) / d, (b[0] - a[0]) / d]
    })
}

/// The two parts (Σ_p w (m + δ):A(m + δ), Σ_p w |r + div δ|²) of one cell's share for the
/// correction `b` (None: δ = 0), evaluated pointwise.
pub fn share(el: &Elastic, points: &[Point], b: Option<&Bubble>) -> (f64, f64) {
    let (mut ps2, mut r2) = (0.0, 0.0);
    for p in points {
        let (d, dv) = match b {
            Some(b) => b.at(p.lam),
            None => ([0.0; 4], [0.0; 2]),
        };
        let m: [f64; 4] = std::array::from_fn(|k| p.mismatch[k] + d[k]);
        let a = el.compliance(m);
        ps2 += p.w * (m[0] * a[0] + m[1] * a[1] + m[2] * a[2] + m[3] * a[3]);
        let r = [p.r[0] + dv[0], p.r[1] + dv[1]];
        r2 += p.w * (r[0] * r[0] + r[1] * r[1]);
    }
    (ps2, r2)
}

/// The minimiser of the module doc's cell share over δ = b S on the straight triangle
/// `verts`, from the normal equations assembled at `points` (a least-squares fit at those
/// points: measure the result elsewhere). None when the share at `points` does not decrease
/// (then δ = 0 is kept) or the system is not positive definite.
pub fn fit(verts: [[f64; 2]; 3], el: &Elastic, weight: f64, points: &[Point]) -> Option<Bubble> {
    if !(weight.is_finite() && weight > 0.0) {
        return None;
    }
    let mut bubble = Bubble {
        coef: [0.0; N],
        grad: barycentric_gradients(verts),
    };
    if !bubble.grad.iter().flatten().all(|g| g.is_finite()) {
        return None;
    }
    let dot = |a: &[f64; 4], b: &[f64; 4]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3];
    let mut h = [0.0; N * N];
    let mut g = [0.0; N];
    for p in points {
        let (val, div) = bubble.basis(p.lam);
        let aval = val.map(|v| el.compliance(v));
        let am = el.compliance(p.mismatch);
        for i in 0..N {
            g[i] += p.w * (dot(&val[i], &am) + weight * (div[i][0] * p.r[0] + div[i][1] * p.r[1]));
            for k in 0..=i {
                h[i * N + k] += p.w
                    * (dot(&val[i], &aval[k])
                        + weight * (div[i][0] * div[k][0] + div[i][1] * div[k][1]));
            }
        }
    }
    for i in 0..N {
        for k in i + 1..N {
            h[i * N + k] = h[k * N + i];
        }
    }
    // Jacobi scaling: the basis mixes the A-norm and W|div|² scales.
    let s: [f64; N] = std::array::from_fn(|i| {
        let d = h[i * N + i];
        if d > 0.0 { 1.0 / d.sqrt() } else { 0.0 }
    });
    if s.contains(&0.0) {
        return None;
    }
    for i in 0..N {
        for k in 0..N {
            h[i * N + k] *= s[i] * s[k];
        }
    }
    let set: [usize; N] = std::array::from_fn(|i| i);
    let mut l = [0.0; N * N];
    if !cholesky(N, &h, &set, &mut l) {
        return None;
    }
    let mut c: [f64; N] = std::array::from_fn(|i| -g[i] * s[i]);
    cholesky_solve(N, N, &l, &mut c);
    bubble.coef = std::array::from_fn(|i| c[i] * s[i]);
    if !bubble.coef.iter().all(|c| c.is_finite()) {
        return None;
    }
    let before = share(el, points, None);
    let after = share(el, points, Some(&bubble));
    (after.0 + weight * after.1 < before.0 + weight * before.1).then_some(bubble)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::quadrature::triangle_rule_cached;

    fn el() -> Elastic {
        Elastic {
            mu: 80.0,
            lambda: 120.0,
        }
    }

    const T: [[f64; 2]; 3] = [[0.3, 0.1], [1.4, 0.35], [0.5, 1.2]];

    /// Fixed coefficients in [−1, 1] (a linear congruential sequence).
    fn coefficients(seed: u64) -> [f64; N] {
        let mut uniform = crate::testing::uniform(seed);
        // The first state is skipped (as the sequence was first written).
        uniform();
        std::array::from_fn(|_| uniform() * 2.0 - 1.0)
    }

    fn points(f: impl Fn([f64; 3], [f64; 2]) -> ([f64; 4], [f64; 2])) -> Vec<Point> {
        let rule = triangle_rule_cached(10);
        let det =
            (T[1][0] - T[0][0]) * (T[2][1] - T[0][1]) - (T[2][0] - T[0][0]) * (T[1][1] - T[0][1]);
        rule.points
            .iter()
            .zip(&rule.weights)
            .map(|(&xi, &w)| {
                let lam = [1.0 - xi[0] - xi[1], xi[0], xi[1]];
                let x = [
                    T[0][0] + (T[1][0] - T[0][0]) * xi[0] + (T[2][0] - T[0][0]) * xi[1],
                    T[0][1] + (T[1][1] - T[0][1]) * xi[0] + (T[2][1] - T[0][1]) * xi[1],
                ];
                let (mismatch, r) = f(lam, x);
                Point {
                    w: w * det.abs(),
                    lam,
                    mismatch,
                    r,
                }
            })
            .collect()
    }

    /// The divergence against a central difference of the value, through x ↦ λ(x).
    #[test]
    fn divergence_is_the_derivative_of_the_value() {
        let b = Bubble {
            coef: coefficients(1),
            grad: barycentric_gradients(T),
        };
        let lam_at = |x: [f64; 2]| {
            let g = b.grad;
            let l1 = g[1][0] * (x[0] - T[0][0]) + g[1][1] * (x[1] - T[0][1]);
            let l2 = g[2][0] * (x[0] - T[0][0]) + g[2][1] * (x[1] - T[0][1]);
            [1.0 - l1 - l2, l1, l2]
        };
        let x = [0.7, 0.5];
        let hh = 1e-5;
        let d = |k: usize, s: usize| {
            let mut xp = x;
            let mut xm = x;
            xp[s] += hh;
            xm[s] -= hh;
            (b.value(lam_at(xp))[k] - b.value(lam_at(xm))[k]) / (2.0 * hh)
        };
        let div = b.divergence(lam_at(x));
        let fd = [d(0, 0) + d(1, 1), d(2, 0) + d(3, 1)];
        for r in 0..2 {
            assert!(
                (div[r] - fd[r]).abs() < 1e-8 * (1.0 + fd[r].abs()),
                "{div:?} {fd:?}"
            );
        }
    }

    /// div δ has zero moments against the three rigid motions (δ = 0 on ∂T, δ symmetric).
    #[test]
    fn divergence_is_orthogonal_to_the_rigid_motions() {
        let b = Bubble {
            coef: coefficients(2),
            grad: barycentric_gradients(T),
        };
        let pts = points(|_, _| ([0.0; 4], [0.0; 2]));
        let rule = triangle_rule_cached(10);
        let mut mom = [0.0; 3];
        let mut scale = 0.0;
        for (p, xi) in pts.iter().zip(&rule.points) {
            let x = [
                T[0][0] + (T[1][0] - T[0][0]) * xi[0] + (T[2][0] - T[0][0]) * xi[1],
                T[0][1] + (T[1][1] - T[0][1]) * xi[0] + (T[2][1] - T[0][1]) * xi[1],
            ];
            let d = b.divergence(p.lam);
            mom[0] += p.w * d[0];
            mom[1] += p.w * d[1];
            mom[2] += p.w * (-x[1] * d[0] + x[0] * d[1]);
            scale += p.w * (d[0].abs() + d[1].abs());
        }
        for m in mom {
            assert!(m.abs() < 1e-13 * scale, "{mom:?} against {scale}");
        }
    }

    /// With m = −δ₀ and r = −div δ₀ for a δ₀ in the space, the share vanishes at δ = δ₀, so
    /// the fit must return δ₀.
    #[test]
    fn fit_recovers_a_correction_in_the_space() {
        let b0 = Bubble {
            coef: coefficients(3),
            grad: barycentric_gradients(T),
        };
        let pts = points(|lam, _| {
            let d = b0.value(lam);
            let dv = b0.divergence(lam);
            (d.map(|x| -x), [-dv[0], -dv[1]])
        });
        let b = fit(T, &el(), 0.3, &pts).expect("a fit");
        for (c, c0) in b.coef.iter().zip(&b0.coef) {
            assert!((c - c0).abs() < 1e-9 * (1.0 + c0.abs()), "{:?}", b.coef);
        }
    }

    /// A residual outside the reach of div δ: the share still decreases, never increases.
    #[test]
    fn fit_lowers_the_share_or_declines() {
        let pts = points(|_, x| {
            (
                [0.01 * x[0], 0.0, 0.0, -0.02 * x[1]],
                [(3.0 * x[0]).sin() - 0.5, (2.0 * x[1]).cos() * x[0]],
            )
        });
        let w = 0.05;
        let before = share(&el(), &pts, None);
        let b = fit(T, &el(), w, &pts).expect("div δ reaches part of r");
        let after = share(&el(), &pts, Some(&b));
        assert!(after.0 + w * after.1 < 0.99 * (before.0 + w * before.1));
    }
}
