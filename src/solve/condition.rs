//! How far the reconstruction's linear systems can be trusted: an estimate of the condition
//! number of the factorised matrix, and the warning printed when it is large.
//!
//! Cholesky's backward error is small relative to each entry's diagonal scale, so what limits
//! the accuracy of x in K x = b is the condition number of the Jacobi-scaled matrix
//! (van der Sluis 1969; Higham, *Accuracy and Stability of Numerical Algorithms*, §10.1):
//!
//! ```text
//!     S = D^{-1/2} K D^{-1/2},  D = diag K,      κ(S) = λ_max(S) / λ_min(S),
//!     relative error of x  ≲  κ(S) · u,          u = 2^-53 ≈ 1.1e-16.
//! ```
//!
//! λ_max is estimated by the Lanczos method with K, λ_min by the Lanczos method with K⁻¹
//! (the Cholesky factor already computed: one pair of triangular solves per step), at most
//! [`ITERATIONS`] steps each from a fixed start vector, stopping once the largest Ritz value
//! settles ([`SETTLED`]). Lanczos reaches an extreme eigenvalue in far fewer steps than the
//! power iteration it replaced (issue 13: the inverse steps are full sparse solves, and took a
//! third of the global reconstruction's time); no reorthogonalisation is needed for the
//! largest Ritz value (lost orthogonality only repeats converged values), so three vectors are
//! held. The largest Ritz value bounds the largest eigenvalue from below, so the estimate is
//! a lower bound of κ(S) that is typically within a small factor of it. A result has lost more
//! than half of its 16 digits when κ(S) > 1e8 ([`WARN_ABOVE`]).

/// Most Lanczos steps for each of λ_max and λ_min; each stops earlier once its estimate (the
/// largest Ritz value) changes by less than [`SETTLED`] relative in one step.
pub const ITERATIONS: usize = 20;

/// Relative change of an eigenvalue estimate under which its iteration stops: the warning needs
/// the order of magnitude, and each inverse step costs a pair of triangular solves of the
/// whole system (≈ 0.15 s at 100k RT_1 cells, memory bound). Issue 13, 100k cells, inverse
/// Lanczos: RT_1 stops after 4 steps at 2.07e5 (5 %: 7 steps, 2.60e5), RT_0 after 3 at 1.54e5
/// (5 %: 5 steps, 1.72e5); the estimate stays a lower bound of κ, now within 0.8× of the
/// 5 % one, and the global reconstruction is 0.45 s shorter at 100k RT_1.
pub const SETTLED: f64 = 0.25;

/// κ(S) above which the report warns: half of double precision's digits may be lost.
pub const WARN_ABOVE: f64 = 1e8;

/// Estimates κ(D^{-1/2} K D^{-1/2}) from `apply` (y = K x), `solve` (x = K⁻¹ b with the
/// existing factor) and the diagonal of K. Returns `f64::INFINITY` when a solve fails or the
/// smallest eigenvalue estimate is not positive.
///
/// The two iterations run as a `rayon::join`, the inverse one first: the caller runs this
/// beside the active-set solve, and the thread that finishes that takes the cheap λ_max
/// iteration (≈ 0.1 s at 100k RT_1 cells, against ≈ 0.5 s for the inverse steps).
pub fn estimate(
    apply: impl Fn(&[f64]) -> Vec<f64> + Sync,
    solve: impl Fn(&[f64]) -> Option<Vec<f64>> + Sync,
    diag: &[f64],
) -> f64 {
    let n = diag.len();
    if n == 0 {
        return 1.0;
    }
    if diag.iter().any(|&d| d.is_nan() || d <= 0.0) {
        return f64::INFINITY;
    }
    let root: Vec<f64> = diag.iter().map(|d| d.sqrt()).collect();
    let start: Vec<f64> = (0..n).map(|i| 1.0 + 0.5 * (i as f64 * 0.7).sin()).collect();
    // S v = D^{-1/2} K D^{-1/2} v and S⁻¹ v = D^{1/2} K⁻¹ D^{1/2} v.
    let (inverse_max, lambda_max) = rayon::join(
        || {
            lanczos_max(&start, |v| {
                let b: Vec<f64> = v.iter().zip(&root).map(|(a, r)| a * r).collect();
                solve(&b).map(|x| x.iter().zip(&root).map(|(a, r)| a * r).collect())
            })
        },
        || {
            lanczos_max(&start, |v| {
                let x: Vec<f64> = v.iter().zip(&root).map(|(a, r)| a / r).collect();
                Some(apply(&x).iter().zip(&root).map(|(a, r)| a / r).collect())
            })
        },
    );
    match (lambda_max, inverse_max) {
        (Some(l), Some(i)) if l > 0.0 && l.is_finite() && i > 0.0 && i.is_finite() => {
            (l * i).max(1.0)
        }
        _ => f64::INFINITY,
    }
}

/// The largest Ritz value of the symmetric operator `op` after at most [`ITERATIONS`] Lanczos
/// steps from `start` (a lower bound of its largest eigenvalue); `None` when `op` fails or
/// returns non-finite values.
fn lanczos_max(start: &[f64], op: impl Fn(&[f64]) -> Option<Vec<f64>>) -> Option<f64> {
    let norm = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
    let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
    let s0 = norm(start);
    if !(s0 > 0.0 && s0.is_finite()) {
        return None;
    }
    let mut q: Vec<f64> = start.iter().map(|x| x / s0).collect();
    let mut q_prev = vec![0.0; q.len()];
    // The tridiagonal T: diagonal α, off-diagonal β.
    let mut alpha: Vec<f64> = Vec::new();
    let mut beta: Vec<f64> = Vec::new();
    let mut theta = 0.0f64;
    for _ in 0..ITERATIONS {
        let mut w = op(&q)?;
        if w.iter().any(|x| !x.is_finite()) {
            return None;
        }
        let a = dot(&w, &q);
        let b_prev = beta.last().copied().unwrap_or(0.0);
        for ((wi, qi), pi) in w.iter_mut().zip(&q).zip(&q_prev) {
            *wi -= a * qi + b_prev * pi;
        }
        alpha.push(a);
        let previous = theta;
        theta = tridiagonal_max(&alpha, &beta);
        let b = norm(&w);
        // An invariant subspace (b ≈ 0): T's eigenvalues are exact.
        if b <= 1e-14 * theta.abs().max(a.abs())
            || (alpha.len() > 1 && (theta - previous).abs() <= SETTLED * theta.abs())
        {
            break;
        }
        beta.push(b);
        q_prev = std::mem::replace(&mut q, w.iter().map(|x| x / b).collect());
    }
    Some(theta)
}

/// Largest eigenvalue of the symmetric tridiagonal matrix with diagonal `a` and off-diagonal
/// `b` (b.len() ≥ a.len() − 1; extra entries ignored), by bisection on the Sturm count
/// #{eigenvalues < x} = #{negative pivots of T − xI} inside the Gershgorin interval.
fn tridiagonal_max(a: &[f64], b: &[f64]) -> f64 {
    let k = a.len();
    let off = |i: usize| if i < k - 1 { b[i].abs() } else { 0.0 };
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for (i, &ai) in a.iter().enumerate() {
        let r = off(i) + if i > 0 { off(i - 1) } else { 0.0 };
        lo = lo.min(ai - r);
        hi = hi.max(ai + r);
    }
    let below = |x: f64| -> usize {
        let mut count = 0;
        let mut d = 1.0;
        for (i, &ai) in a.iter().enumerate() {
            let bb = if i > 0 { off(i - 1) * off(i - 1) } else { 0.0 };
            d = ai - x - if i > 0 { bb / d } else { 0.0 };
            if d == 0.0 {
                // A zero pivot: perturb by a relative ulp (the count is unchanged by it).
                d = f64::EPSILON * (x.abs() + bb.sqrt()).max(f64::MIN_POSITIVE);
            }
            if d < 0.0 {
                count += 1;
            }
        }
        count
    };
    // 100 halvings take any double interval down to its last bit.
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if mid <= lo || mid >= hi {
            break;
        }
        if below(mid) == k {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    hi
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A diagonal matrix diag(1, …, 1e10): Jacobi scaling makes it the identity, κ(S) = 1.
    /// The 1D Laplacian tridiag(−1, 2, −1) of size n has eigenvalues 2 − 2cos(kπ/(n+1)), so
    /// κ = (1 + cos(π/(n+1))) / (1 − cos(π/(n+1))); for n = 20 that is 178.06…
    #[test]
    fn condition_of_known_matrices() {
        let diag = [1.0, 1e5, 1e10];
        let kappa = estimate(
            |x| x.iter().zip(&diag).map(|(a, d)| a * d).collect(),
            |b| Some(b.iter().zip(&diag).map(|(a, d)| a / d).collect()),
            &diag,
        );
        assert!((kappa - 1.0).abs() < 1e-12, "{kappa}");

        let n = 20;
        let apply = |x: &[f64]| -> Vec<f64> {
            (0..n)
                .map(|i| {
                    2.0 * x[i]
                        - if i > 0 { x[i - 1] } else { 0.0 }
                        - if i + 1 < n { x[i + 1] } else { 0.0 }
                })
                .collect()
        };
        // Thomas algorithm for the inverse.
        let solve = |b: &[f64]| -> Option<Vec<f64>> {
            let (mut c, mut d) = (vec![0.0; n], vec![0.0; n]);
            for i in 0..n {
                let m = 2.0 + if i > 0 { c[i - 1] } else { 0.0 };
                c[i] = -1.0 / m;
                d[i] = (b[i] + if i > 0 { d[i - 1] } else { 0.0 }) / m;
            }
            let mut x = vec![0.0; n];
            for i in (0..n).rev() {
                x[i] = d[i] - c[i] * if i + 1 < n { x[i + 1] } else { 0.0 };
            }
            Some(x)
        };
        let t = (std::f64::consts::PI / (n as f64 + 1.0)).cos();
        let want = (1.0 + t) / (1.0 - t);
        let kappa = estimate(apply, solve, &[2.0; 20]);
        // Lanczos from a smooth start stops once a step changes it by less than SETTLED (25 %):
        // the estimate is a lower bound, within 0.8× of κ (here 0.86×; with 5 %, 0.95×).
        assert!(
            kappa <= want * (1.0 + 1e-9) && kappa > 0.8 * want,
            "{kappa} vs {want}"
        );
        // The Sturm bisection on a known tridiagonal: tridiag(−1, 2, −1) of size 5 has
        // largest eigenvalue 2 + 2cos(π/6) = 2 + √3.
        let top = tridiagonal_max(&[2.0; 5], &[-1.0; 4]);
        assert!((top - (2.0 + 3f64.sqrt())).abs() < 1e-14, "{top}");
    }
}
