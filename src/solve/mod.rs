//! The bound-constrained quadratic program of the reconstruction (docs/design.md §5):
//!
//! ```text
//! minimise ½ xᵀ K x − bᵀ x   subject to  x_i ≤ 0 for i ∈ C,
//! ```
//!
//! K symmetric positive definite, by the primal-dual active-set method (a semismooth Newton
//! method for the complementarity function min(λ, −c x) = 0; Hintermüller, Ito, Kunisch, SIAM
//! J. Optim. 13, 2002). Each step solves K x = b with the active constraints as equations
//! x_i = 0: their rows and columns are replaced by the identity *inside the same sparsity
//! pattern*, so K is compressed once and the symbolic Cholesky factorisation (faer) is computed
//! once and reused.

pub mod condition;
pub mod dense;

use faer::Side;
use faer::prelude::Solve;
use faer::sparse::linalg::solvers::{Llt, SymbolicLlt};
use faer::sparse::{Pair, SparseColMat, SymbolicSparseColMat};

/// A symmetric matrix given by its lower-triangle entries (duplicates are summed).
pub struct Lower {
    pub n: usize,
    /// (row, column, value) with row ≥ column.
    pub entries: Vec<(usize, usize, f64)>,
}

impl Lower {
    /// y = K x.
    pub fn apply(&self, x: &[f64]) -> Vec<f64> {
        let mut y = vec![0.0; self.n];
        for &(i, j, v) in &self.entries {
            y[i] += v * x[j];
            if i != j {
                y[j] += v * x[i];
            }
        }
        y
    }
}

/// How the solve went.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct SolveInfo {
    pub unknowns: usize,
    pub nonzeros: usize,
    pub iterations: usize,
    /// Constraints active at the solution (x_i = 0, λ_i ≥ 0).
    pub active: usize,
    /// max of: primal violation max x_i⁺ (scaled by max |x|), dual violation max λ_i⁻ and
    /// stationarity |Kx − b + λ| on all unknowns (scaled by max |b|).
    pub kkt_residual: f64,
    pub converged: bool,
    /// Estimated condition number of the last system, Jacobi-scaled ([`condition`]).
    pub condition_estimate: f64,
}

/// The fixed-pattern sparse Cholesky solver: K in faer's compressed lower-triangle form,
/// assembled once (duplicates summed); each active-set step edits a copy of its values in
/// place and refactorises numerically with the same symbolic analysis.
struct Factor {
    symbolic: SymbolicSparseColMat<usize>,
    llt: SymbolicLlt<usize>,
    /// K's values in the compressed order.
    values: Vec<f64>,
}

impl Factor {
    fn new(k: &Lower) -> Result<Factor, String> {
        let pairs: Vec<Pair<usize, usize>> =
            k.entries.iter().map(|&(i, j, _)| Pair::new(i, j)).collect();
        let (symbolic, argsort) = SymbolicSparseColMat::try_new_from_indices(k.n, k.n, &pairs)
            .map_err(|e| format!("sparse pattern: {e:?}"))?;
        drop(pairs);
        let triplet_values: Vec<f64> = k.entries.iter().map(|e| e.2).collect();
        let mat = SparseColMat::<usize, f64>::new_from_argsort(
            symbolic.clone(),
            &argsort,
            &triplet_values,
        )
        .map_err(|e| format!("sparse matrix: {e:?}"))?;
        let values = mat.val().to_vec();
        let llt = SymbolicLlt::try_new(symbolic.as_ref(), Side::Lower)
            .map_err(|e| format!("symbolic Cholesky: {e:?}"))?;
        Ok(Factor {
            symbolic,
            llt,
            values,
        })
    }

    /// Calls `f(i, j, slot)` for every stored entry (i ≥ j) of the lower triangle.
    #[inline]
    fn for_each(&self, mut f: impl FnMut(usize, usize, usize)) {
        let (cp, ri) = (self.symbolic.col_ptr(), self.symbolic.row_idx());
        for j in 0..cp.len() - 1 {
            for (slot, &i) in ri.iter().enumerate().take(cp[j + 1]).skip(cp[j]) {
                f(i, j, slot);
            }
        }
    }

    /// The values of K with the rows and columns of `active` replaced by the identity.
    fn with_active(&self, active: &[bool]) -> Vec<f64> {
        let mut v = self.values.clone();
        self.for_each(|i, j, slot| {
            if active[i] || active[j] {
                v[slot] = if i == j { 1.0 } else { 0.0 };
            }
        });
        v
    }

    /// y = M x for the symmetric matrix with lower-triangle `values` in this pattern.
    fn apply(&self, values: &[f64], x: &[f64]) -> Vec<f64> {
        let mut y = vec![0.0; x.len()];
        self.for_each(|i, j, slot| {
            let v = values[slot];
            y[i] += v * x[j];
            if i != j {
                y[j] += v * x[i];
            }
        });
        y
    }

    fn diagonal(&self, values: &[f64]) -> Vec<f64> {
        let mut d = vec![0.0; self.symbolic.ncols()];
        self.for_each(|i, j, slot| {
            if i == j {
                d[i] += values[slot];
            }
        });
        d
    }

    fn factor(&self, values: Vec<f64>) -> Result<(Llt<usize, f64>, Vec<f64>), String> {
        let mat = SparseColMat::<usize, f64>::new(self.symbolic.clone(), values);
        let llt = Llt::try_new_with_symbolic(self.llt.clone(), mat.as_ref(), Side::Lower).map_err(
            |e| {
                format!(
                    "the reconstruction matrix is not positive definite ({e:?}): the field is \
                     not determined by the functional"
                )
            },
        )?;
        let (_, values) = mat.into_parts();
        Ok((llt, values))
    }
}

fn solve_with(llt: &Llt<usize, f64>, rhs: &[f64]) -> Vec<f64> {
    let mut x = faer::Mat::from_fn(rhs.len(), 1, |i, _| rhs[i]);
    llt.solve_in_place(&mut x);
    (0..rhs.len()).map(|i| x[(i, 0)]).collect()
}

/// Solves the QP; `constrained` lists the i with x_i ≤ 0. Stops after `max_iterations`
/// active-set changes (reported as not converged, with the last iterate's KKT residual).
pub fn solve_bound_qp(
    k: &Lower,
    b: &[f64],
    constrained: &[usize],
    max_iterations: usize,
) -> Result<(Vec<f64>, SolveInfo), String> {
    solve_bound_qp_from(k, b, constrained, max_iterations, &[])
}

/// [`solve_bound_qp`] started from the active set `guess` (a subset of `constrained`): each
/// active-set step costs a numeric factorisation, and a good guess (e.g. the open part of the
/// gap, where the contact stress must vanish) saves most of them. The solution does not depend
/// on the guess; only the number of iterations does.
pub fn solve_bound_qp_from(
    k: &Lower,
    b: &[f64],
    constrained: &[usize],
    max_iterations: usize,
    guess: &[usize],
) -> Result<(Vec<f64>, SolveInfo), String> {
    let n = k.n;
    let factor = Factor::new(k)?;
    let diag = factor.diagonal(&factor.values);
    let scale = diag
        .iter()
        .fold(0.0f64, |m, d| m.max(d.abs()))
        .max(f64::MIN_POSITIVE);
    let mut active = vec![false; n];
    let mut is_constrained = vec![false; n];
    for &i in constrained {
        is_constrained[i] = true;
    }
    for &i in guess {
        if is_constrained[i] {
            active[i] = true;
        }
    }
    let mut info = SolveInfo {
        unknowns: n,
        nonzeros: k.entries.len(),
        ..SolveInfo::default()
    };
    let mut x = vec![0.0; n];
    let mut lambda = vec![0.0; n];
    let mut last = None;
    for it in 0..=max_iterations {
        info.iterations = it + 1;
        let rhs: Vec<f64> = (0..n).map(|i| if active[i] { 0.0 } else { b[i] }).collect();
        // The previous factor goes first: two factors alive at once double the peak memory.
        drop(last.take());
        let (llt, values) = factor.factor(factor.with_active(&active))?;
        x = solve_with(&llt, &rhs);
        last = Some((llt, values));
        let kx = factor.apply(&factor.values, &x);
        lambda.iter_mut().for_each(|l| *l = 0.0);
        for &i in constrained {
            if active[i] {
                lambda[i] = b[i] - kx[i];
            }
        }
        let mut changed = false;
        for &i in constrained {
            let c = diag[i].abs().max(scale * 1e-12);
            let now = lambda[i] + c * x[i] > 0.0;
            if now != active[i] {
                active[i] = now;
                changed = true;
            }
        }
        if !changed {
            info.converged = true;
            break;
        }
    }
    let kx = factor.apply(&factor.values, &x);
    let xmax = x
        .iter()
        .fold(0.0f64, |m, v| m.max(v.abs()))
        .max(f64::MIN_POSITIVE);
    let bmax = b
        .iter()
        .fold(0.0f64, |m, v| m.max(v.abs()))
        .max(f64::MIN_POSITIVE);
    let mut primal = 0.0f64;
    let mut dual = 0.0f64;
    for &i in constrained {
        primal = primal.max(x[i].max(0.0) / xmax);
        dual = dual.max((-lambda[i]).max(0.0) / bmax);
    }
    let stationarity = (0..n)
        .map(|i| (kx[i] - b[i] + lambda[i]).abs())
        .fold(0.0f64, f64::max)
        / bmax;
    info.active = constrained.iter().filter(|&&i| active[i]).count();
    info.kkt_residual = primal.max(dual).max(stationarity);
    if let Some((llt, values)) = &last {
        info.condition_estimate = last_system_condition(llt, &factor, values);
    }
    Ok((x, info))
}

/// κ estimate of the last system solved (active rows replaced by identity rows), reusing its
/// numeric factor for the inverse iteration.
fn last_system_condition(llt: &Llt<usize, f64>, factor: &Factor, values: &[f64]) -> f64 {
    let apply = |x: &[f64]| factor.apply(values, x);
    condition::estimate(
        apply,
        |b| Some(solve_with(llt, b)),
        &factor.diagonal(values),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The 1D Laplacian K = tridiag(−1, 2, −1) with b = 1: unconstrained x_i = i(n+1−i)/2;
    /// with x ≤ 0 imposed on every unknown the solution is x = 0 (all active, λ = b).
    #[test]
    fn laplacian_unconstrained_and_fully_active() {
        let n = 9;
        let mut e = Vec::new();
        for i in 0..n {
            e.push((i, i, 2.0));
            if i > 0 {
                e.push((i, i - 1, -1.0));
            }
        }
        let k = Lower { n, entries: e };
        let b = vec![1.0; n];
        let (x, info) = solve_bound_qp(&k, &b, &[], 10).unwrap();
        for (i, v) in x.iter().enumerate() {
            let m = (i + 1) as f64;
            assert!((v - m * (n as f64 + 1.0 - m) / 2.0).abs() < 1e-12);
        }
        assert!(info.converged && info.kkt_residual < 1e-14);
        let all: Vec<usize> = (0..n).collect();
        let (x, info) = solve_bound_qp(&k, &b, &all, 10).unwrap();
        assert!(x.iter().all(|v| v.abs() < 1e-15));
        assert_eq!(info.active, n);
        assert!(info.converged);
    }

    /// A 2×2 problem solved by hand: K = [[2, 1], [1, 2]], b = (1, −3). Unconstrained x =
    /// K⁻¹b = (5/3, −7/3); with x₀ ≤ 0: x₀ = 0, 2x₁ = −3 → x₁ = −1.5, λ₀ = b₀ − (Kx)₀ = 2.5.
    #[test]
    fn two_by_two_by_hand() {
        let k = Lower {
            n: 2,
            entries: vec![(0, 0, 2.0), (1, 0, 1.0), (1, 1, 2.0)],
        };
        let (x, info) = solve_bound_qp(&k, &[1.0, -3.0], &[0], 10).unwrap();
        assert!((x[0]).abs() < 1e-15 && (x[1] + 1.5).abs() < 1e-15, "{x:?}");
        assert_eq!(info.active, 1);
        assert!(info.kkt_residual < 1e-15);
    }
}
