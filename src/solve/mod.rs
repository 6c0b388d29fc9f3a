//! The bound-constrained quadratic program of the reconstruction (docs/design.md §5):
//!
//! ```text
//! minimise ½ xᵀ K x − bᵀ x   subject to  x_i ≤ 0 for i ∈ C,
//! ```
//!
//! K symmetric positive definite, by the primal-dual active-set method (a semismooth Newton
//! method for the complementarity function min(λ, −c x) = 0; Hintermüller, Ito, Kunisch, SIAM
//! J. Optim. 13, 2002), run on the Schur complement of the constrained block ([`schur`]):
//! with the free unknowns F first and C last,
//!
//! ```text
//! S = K_CC − K_CF K_FF⁻¹ K_FC,   c = b_C − K_CF K_FF⁻¹ b_F,
//! minimise ½ yᵀ S y − cᵀ y  subject to  y ≤ 0,      x_C = y,  x_F = K_FF⁻¹ (b_F − K_FC y).
//! ```
//!
//! K is factorised once (sparse Cholesky, faer, with C ordered last so that the trailing block
//! of the factor is the Cholesky factor of S); each active-set step then costs one dense
//! Cholesky of the inactive block S_II (|C| is the number of contact unknowns, at most a few
//! thousand). Eliminating F is exact, so the iterates are those of the same method applied to
//! K directly (active rows and columns replaced by the identity, one sparse factorisation per
//! step, as this module did before issue 13).

pub mod condition;
pub mod dense;
pub mod schur;

use faer::sparse::{Pair, SparseColMat, SymbolicSparseColMat, SymbolicSparseColMatRef};
use faer::{Mat, Side};

use crate::tolerance::{ACTIVE_SET_SCALE_FLOOR, SINGULAR_CONDITION};

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

/// A symmetric matrix stored as its lower triangle in compressed sparse columns: column j
/// holds the rows i ≥ j of its pattern in increasing order, without duplicates, and `values`
/// the entries K_ij in the same order.
pub struct SymCsc {
    pub n: usize,
    pub(crate) col_ptr: Vec<usize>,
    pub(crate) row_idx: Vec<usize>,
    pub values: Vec<f64>,
}

impl SymCsc {
    /// The pattern in which every two members of one group couple, and every diagonal entry
    /// (for finite elements: a group is the unknowns of one cell); values zero. Groups are
    /// given compressed: group g is `members[ptr[g]..ptr[g + 1]]` (repeats allowed).
    ///
    /// Built column by column from the inverse map unknown → groups, so that no (row, column)
    /// list of the whole matrix is ever held.
    pub fn from_groups(n: usize, ptr: &[usize], members: &[usize]) -> Result<SymCsc, String> {
        if ptr.is_empty()
            || ptr[0] != 0
            || ptr.windows(2).any(|w| w[0] > w[1])
            || ptr[ptr.len() - 1] != members.len()
        {
            return Err("sparse pattern: malformed group pointers".into());
        }
        if members.iter().any(|&m| m >= n) {
            return Err("sparse pattern: an unknown out of range".into());
        }
        // Unknown → groups, compressed.
        let mut start = vec![0usize; n + 1];
        for &m in members {
            start[m + 1] += 1;
        }
        for i in 0..n {
            start[i + 1] += start[i];
        }
        let mut fill = start.clone();
        let mut groups_of = vec![0usize; members.len()];
        for g in 0..ptr.len() - 1 {
            for &m in &members[ptr[g]..ptr[g + 1]] {
                groups_of[fill[m]] = g;
                fill[m] += 1;
            }
        }
        drop(fill);
        let mut col_ptr = Vec::with_capacity(n + 1);
        col_ptr.push(0);
        let mut row_idx = Vec::new();
        // mark[i] = j: row i already listed in column j.
        let mut mark = vec![usize::MAX; n];
        for j in 0..n {
            let first = row_idx.len();
            row_idx.push(j);
            mark[j] = j;
            for &g in &groups_of[start[j]..start[j + 1]] {
                for &i in &members[ptr[g]..ptr[g + 1]] {
                    if i > j && mark[i] != j {
                        mark[i] = j;
                        row_idx.push(i);
                    }
                }
            }
            row_idx[first..].sort_unstable();
            col_ptr.push(row_idx.len());
        }
        let values = vec![0.0; row_idx.len()];
        Ok(SymCsc {
            n,
            col_ptr,
            row_idx,
            values,
        })
    }

    /// Compresses a triplet list (duplicates summed).
    pub fn from_lower(k: &Lower) -> Result<SymCsc, String> {
        if k.entries.iter().any(|&(i, j, _)| i < j || i >= k.n) {
            return Err("sparse matrix: an entry outside the lower triangle".into());
        }
        let pairs: Vec<Pair<usize, usize>> =
            k.entries.iter().map(|&(i, j, _)| Pair::new(i, j)).collect();
        let (symbolic, argsort) = SymbolicSparseColMat::try_new_from_indices(k.n, k.n, &pairs)
            .map_err(|e| format!("sparse pattern: {e:?}"))?;
        drop(pairs);
        let triplet_values: Vec<f64> = k.entries.iter().map(|e| e.2).collect();
        let mat = SparseColMat::<usize, f64>::new_from_argsort(symbolic, &argsort, &triplet_values)
            .map_err(|e| format!("sparse matrix: {e:?}"))?;
        let (symbolic, values) = mat.into_parts();
        let (_, _, col_ptr, _, row_idx) = symbolic.into_parts();
        Ok(SymCsc {
            n: k.n,
            col_ptr,
            row_idx,
            values,
        })
    }

    /// K_ij += v (and K_ji, the same entry), i and j in either order; false (nothing added)
    /// when (i, j) is not in the pattern.
    #[inline]
    pub fn add(&mut self, i: usize, j: usize, v: f64) -> bool {
        let (i, j) = if i >= j { (i, j) } else { (j, i) };
        if i >= self.n {
            return false;
        }
        let (a, e) = (self.col_ptr[j], self.col_ptr[j + 1]);
        match self.row_idx[a..e].binary_search(&i) {
            Ok(p) => {
                self.values[a + p] += v;
                true
            }
            Err(_) => false,
        }
    }

    /// Stored entries of the lower triangle.
    pub fn nnz(&self) -> usize {
        self.row_idx.len()
    }

    /// Calls `f(i, j, v)` for every stored entry (i ≥ j) of the lower triangle.
    #[inline]
    pub(crate) fn for_each(&self, mut f: impl FnMut(usize, usize, f64)) {
        for j in 0..self.n {
            for p in self.col_ptr[j]..self.col_ptr[j + 1] {
                f(self.row_idx[p], j, self.values[p]);
            }
        }
    }

    /// y = K x.
    pub fn apply(&self, x: &[f64]) -> Vec<f64> {
        let mut y = vec![0.0; self.n];
        self.for_each(|i, j, v| {
            y[i] += v * x[j];
            if i != j {
                y[j] += v * x[i];
            }
        });
        y
    }

    /// diag K.
    pub fn diagonal(&self) -> Vec<f64> {
        let mut d = vec![0.0; self.n];
        self.for_each(|i, j, v| {
            if i == j {
                d[i] += v;
            }
        });
        d
    }

    fn symbolic(&self) -> SymbolicSparseColMatRef<'_, usize> {
        // The constructors keep the invariants (sorted, in range, col_ptr monotone).
        SymbolicSparseColMatRef::new_checked(self.n, self.n, &self.col_ptr, None, &self.row_idx)
    }
}

/// How the solve went.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct SolveInfo {
    /// Unknowns of the system solved globally (K's dimension, fixed values included as
    /// identity rows). The global stress reconstruction condenses the interior RT DOFs cell by
    /// cell first: they are counted in [`SolveInfo::condensed`], not here.
    pub unknowns: usize,
    /// Unknowns eliminated cell by cell before the global solve and recovered after it (the
    /// interior DOFs of the stress reconstruction; 0 for the other solves). The problem has
    /// `unknowns + condensed` unknowns in all.
    pub condensed: usize,
    /// Stored (distinct) entries of the lower triangle of K.
    pub nonzeros: usize,
    /// Active-set steps (each one dense Cholesky of the inactive block of S).
    pub iterations: usize,
    /// Constraints active at the solution (x_i = 0, λ_i ≥ 0).
    pub active: usize,
    /// max of: primal violation max x_i⁺ (scaled by max |x|), dual violation max λ_i⁻ and
    /// stationarity |Kx − b + λ| on all unknowns (scaled by max |b|), on the system solved
    /// (with condensed unknowns: the condensed system, whose stationarity is that of the full
    /// one on the kept unknowns; the condensed rows hold by their cell-wise solves).
    pub kkt_residual: f64,
    pub converged: bool,
    /// Estimated condition number of the Jacobi-scaled K, the matrix factorised
    /// ([`condition`]). It bounds that of every active-set system (K with active rows and
    /// columns replaced by the identity; Cauchy interlacing, the identity rows have scaled
    /// eigenvalue 1 ∈ [λ_min, λ_max]), and so also that of the last one. Computed right after
    /// the factorisation: at or above [`SINGULAR_CONDITION`] K is numerically singular and the
    /// solve is refused.
    pub condition_estimate: f64,
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

/// [`solve_bound_qp`] started from the active set `guess` (a subset of `constrained`): a good
/// guess (e.g. the open part of the gap, where the contact stress must vanish) saves
/// active-set steps. The solution does not depend on the guess; only the number of iterations
/// does.
pub fn solve_bound_qp_from(
    k: &Lower,
    b: &[f64],
    constrained: &[usize],
    max_iterations: usize,
    guess: &[usize],
) -> Result<(Vec<f64>, SolveInfo), String> {
    let k = SymCsc::from_lower(k)?;
    solve_bound_qp_csc(&k, b, constrained, max_iterations, guess)
}

/// [`solve_bound_qp_from`] for a matrix already compressed.
pub fn solve_bound_qp_csc(
    k: &SymCsc,
    b: &[f64],
    constrained: &[usize],
    max_iterations: usize,
    guess: &[usize],
) -> Result<(Vec<f64>, SolveInfo), String> {
    let n = k.n;
    if b.len() != n {
        return Err(format!(
            "the right-hand side has {} entries for {n} unknowns",
            b.len()
        ));
    }
    if constrained.iter().chain(guess).any(|&i| i >= n) {
        return Err("a constrained unknown out of range".into());
    }
    let mut info = SolveInfo {
        unknowns: n,
        nonzeros: k.nnz(),
        ..SolveInfo::default()
    };
    if n == 0 {
        info.converged = true;
        info.iterations = 1;
        info.condition_estimate = 1.0;
        return Ok((Vec::new(), info));
    }
    let mut is_constrained = vec![false; n];
    for &i in constrained {
        is_constrained[i] = true;
    }
    let diag = k.diagonal();
    let scale = diag
        .iter()
        .fold(0.0f64, |m, d| m.max(d.abs()))
        .max(f64::MIN_POSITIVE);

    let factor = schur::Factor::new(k, &is_constrained)?;
    // A singular K need not stop the factorisation: its zero pivot comes out as round-off of
    // either sign, and a positive one lets the factor through. The condition estimate of K
    // (which bounds that of every active-set system) tells: a singular K gives ≥ 1e18, far
    // above any determined problem ([`SINGULAR_CONDITION`]), and is refused as a failed
    // factorisation is. It needs only the factor, so it runs beside the active-set solve (its
    // inverse Lanczos steps are memory-bound triangular solves: 27 % of the time at 100k
    // RT_1 when run first); its verdict is read before the solution is returned.
    let (kappa, solved) = rayon::join(
        || {
            let solve_error = std::sync::Mutex::new(None);
            let kappa = condition::estimate(
                |v| k.apply(v),
                |r| {
                    factor
                        .solve(r)
                        .map_err(|e| {
                            if let Ok(mut slot) = solve_error.lock() {
                                *slot = Some(e);
                            }
                        })
                        .ok()
                },
                &diag,
            );
            match solve_error.into_inner().ok().flatten() {
                Some(e) => Err(e),
                None => Ok(kappa),
            }
        },
        || -> Result<(Vec<f64>, SolveInfo), String> {
            let mut info = info.clone();
            // The constrained unknowns in the factor's (trailing) order: y_p = x_{cset[p]}.
            let cset = factor.constrained();
            let m = cset.len();
            let mut position = vec![usize::MAX; n];
            for (p, &i) in cset.iter().enumerate() {
                position[i] = p;
            }
            // c = b_C − K_CF K_FF⁻¹ b_F.
            let w = factor.solve_free(b)?;
            let kw = k.apply(&w);
            let c: Vec<f64> = cset.iter().map(|&i| b[i] - kw[i]).collect();
            drop((w, kw));
            let s = factor.schur()?;
            let weight: Vec<f64> = cset
                .iter()
                .map(|&i| diag[i].abs().max(scale * ACTIVE_SET_SCALE_FLOOR))
                .collect();
            let mut active = vec![false; m];
            for &i in guess {
                if position[i] != usize::MAX {
                    active[position[i]] = true;
                }
            }
            let (y, active, iterations, converged) =
                dense_active_set(&s, &c, &weight, active, max_iterations)?;
            info.iterations = iterations;
            info.converged = converged;
            drop(s);

            // x_C = y, x_F = K_FF⁻¹ (b_F − K_FC y).
            let mut xc = vec![0.0; n];
            for (p, &i) in cset.iter().enumerate() {
                xc[i] = y[p];
            }
            let kxc = k.apply(&xc);
            let r: Vec<f64> = b.iter().zip(&kxc).map(|(bi, ki)| bi - ki).collect();
            drop(kxc);
            let mut x = factor.solve_free(&r)?;
            drop(r);
            for (p, &i) in cset.iter().enumerate() {
                x[i] = y[p];
            }

            // KKT on the full system: λ_i = b_i − (Kx)_i on the active constraints, 0 elsewhere.
            let kx = k.apply(&x);
            let mut lambda = vec![0.0; n];
            for (p, &i) in cset.iter().enumerate() {
                if active[p] {
                    lambda[i] = b[i] - kx[i];
                }
            }
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
            for &i in &cset {
                primal = primal.max(x[i].max(0.0) / xmax);
                dual = dual.max((-lambda[i]).max(0.0) / bmax);
            }
            let stationarity = (0..n)
                .map(|i| (kx[i] - b[i] + lambda[i]).abs())
                .fold(0.0f64, f64::max)
                / bmax;
            info.active = active.iter().filter(|&&a| a).count();
            info.kkt_residual = primal.max(dual).max(stationarity);
            drop(kx);
            Ok((x, info))
        },
    );
    let kappa = kappa?;
    if kappa.is_nan() || kappa >= SINGULAR_CONDITION {
        return Err(format!(
            "the reconstruction matrix is not positive definite (numerically singular: \
             condition estimate {kappa:.1e} ≥ {SINGULAR_CONDITION:.0e}): the field is not \
             determined by the functional"
        ));
    }
    let (x, mut info) = solved?;
    info.condition_estimate = kappa;
    Ok((x, info))
}

/// The primal-dual active-set method on the dense reduced problem min ½ yᵀSy − cᵀy, y ≤ 0,
/// from the active set `active`: each step solves S_II y_I = c_I with y_A = 0 (dense
/// Cholesky of the inactive block), sets λ_A = c_A − S_AI y_I, λ_I = 0, and makes active
/// exactly the p with λ_p + w_p y_p > 0 (w_p = K_ii of that unknown, the scale of the
/// method on K). Stops when the set repeats or after `max_iterations` changes. Returns
/// (y, active set, steps, converged).
fn dense_active_set(
    s: &Mat<f64>,
    c: &[f64],
    weight: &[f64],
    mut active: Vec<bool>,
    max_iterations: usize,
) -> Result<(Vec<f64>, Vec<bool>, usize, bool), String> {
    let m = c.len();
    let mut y = vec![0.0; m];
    let mut iterations = 0;
    let mut converged = false;
    for it in 0..=max_iterations {
        iterations = it + 1;
        let free: Vec<usize> = (0..m).filter(|&p| !active[p]).collect();
        y.iter_mut().for_each(|v| *v = 0.0);
        if !free.is_empty() {
            let sii = Mat::from_fn(free.len(), free.len(), |a, q| s[(free[a], free[q])]);
            let llt = sii.llt(Side::Lower).map_err(|e| {
                format!(
                    "the reconstruction matrix is not positive definite ({e:?}): the field is \
                     not determined by the functional"
                )
            })?;
            let rhs = Mat::from_fn(free.len(), 1, |a, _| c[free[a]]);
            let sol = faer::prelude::Solve::solve(&llt, &rhs);
            for (a, &p) in free.iter().enumerate() {
                y[p] = sol[(a, 0)];
            }
        }
        let mut changed = false;
        for p in 0..m {
            // S is symmetric: column p read down its contiguous storage.
            let lambda = if active[p] {
                c[p] - free.iter().map(|&q| s[(q, p)] * y[q]).sum::<f64>()
            } else {
                0.0
            };
            let now = lambda + weight[p] * y[p] > 0.0;
            if now != active[p] {
                active[p] = now;
                changed = true;
            }
        }
        if !changed {
            converged = true;
            break;
        }
    }
    Ok((y, active, iterations, converged))
}

#[cfg(test)]
// Dense reference code indexes rows and columns by number.
#[allow(clippy::needless_range_loop)]
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

    /// A fixed pseudo-random sequence in [−1, 1): `testing::uniform` scaled (2u − 1 is exact).
    fn symmetric(seed: u64) -> impl FnMut() -> f64 {
        let mut u = crate::testing::uniform(seed);
        move || 2.0 * u() - 1.0
    }

    /// A random sparse SPD matrix: K = BᵀB + 0.1 I with B sparse (about 3 entries a row),
    /// returned dense and as lower-triangle triplets with duplicates (each entry split in two).
    fn random_spd(n: usize, rng: &mut impl FnMut() -> f64) -> (Vec<Vec<f64>>, Lower) {
        let mut bm = vec![vec![0.0; n]; n];
        for row in bm.iter_mut() {
            for _ in 0..3 {
                let j = ((rng() + 1.0) * 0.5 * n as f64) as usize % n;
                row[j] += rng();
            }
        }
        let mut k = vec![vec![0.0; n]; n];
        for i in 0..n {
            for j in 0..n {
                k[i][j] = (0..n).map(|r| bm[r][i] * bm[r][j]).sum::<f64>();
            }
            k[i][i] += 0.1;
        }
        let mut entries = Vec::new();
        for i in 0..n {
            for j in 0..=i {
                if k[i][j] != 0.0 || i == j {
                    entries.push((i, j, 0.25 * k[i][j]));
                    entries.push((i, j, 0.75 * k[i][j]));
                }
            }
        }
        (k, Lower { n, entries })
    }

    /// Dense Cholesky solve of the symmetric positive definite `a` (row-major).
    fn dense_solve(a: &[Vec<f64>], b: &[f64]) -> Vec<f64> {
        let n = b.len();
        let m = Mat::from_fn(n, n, |i, j| a[i][j]);
        let rhs = Mat::from_fn(n, 1, |i, _| b[i]);
        let x = faer::prelude::Solve::solve(&m.llt(Side::Lower).unwrap(), &rhs);
        (0..n).map(|i| x[(i, 0)]).collect()
    }

    /// The method as it was before the Schur complement (one factorisation of K with the
    /// active rows and columns replaced by the identity per step), densely: the reference
    /// the new path must reproduce, iterate for iterate. Returns (x, steps, active).
    fn reference(
        k: &[Vec<f64>],
        b: &[f64],
        constrained: &[usize],
        guess: &[usize],
    ) -> (Vec<f64>, usize, usize) {
        let n = b.len();
        let scale = (0..n).fold(0.0f64, |m, i| m.max(k[i][i].abs()));
        let mut active = vec![false; n];
        for &i in guess {
            active[i] = true;
        }
        let mut x = vec![0.0; n];
        for it in 0..=MAX_STEPS {
            let mut a = k.to_vec();
            let mut rhs = b.to_vec();
            for i in 0..n {
                if active[i] {
                    for j in 0..n {
                        a[i][j] = 0.0;
                        a[j][i] = 0.0;
                    }
                    a[i][i] = 1.0;
                    rhs[i] = 0.0;
                }
            }
            x = dense_solve(&a, &rhs);
            let mut changed = false;
            for &i in constrained {
                let kx: f64 = (0..n).map(|j| k[i][j] * x[j]).sum();
                let lambda = if active[i] { b[i] - kx } else { 0.0 };
                let c = k[i][i].abs().max(scale * ACTIVE_SET_SCALE_FLOOR);
                let now = lambda + c * x[i] > 0.0;
                if now != active[i] {
                    active[i] = now;
                    changed = true;
                }
            }
            if !changed {
                return (x, it + 1, active.iter().filter(|&&v| v).count());
            }
        }
        (x, MAX_STEPS + 1, active.iter().filter(|&&v| v).count())
    }

    const MAX_STEPS: usize = 50;

    /// Random sparse SPD problems of 1–40 unknowns, bounds on a random subset (sometimes all,
    /// sometimes none), a random guess: the Schur path gives the reference's x to round-off,
    /// with the same number of steps and active constraints, and a KKT point.
    #[test]
    fn schur_path_equals_refactorising_method() {
        let mut rng = symmetric(7);
        let (mut several_steps, mut some_active) = (0, 0);
        for case in 0..60 {
            let n = 1 + case % 40;
            let (kd, kl) = random_spd(n, &mut rng);
            let b: Vec<f64> = (0..n).map(|_| rng()).collect();
            let constrained: Vec<usize> = match case % 5 {
                0 => Vec::new(),
                1 => (0..n).collect(),
                _ => (0..n).filter(|_| rng() < 0.2).collect(),
            };
            let guess: Vec<usize> = constrained
                .iter()
                .copied()
                .filter(|_| rng() < -0.5)
                .collect();
            let (want, steps, active) = reference(&kd, &b, &constrained, &guess);
            let (x, info) = solve_bound_qp_from(&kl, &b, &constrained, MAX_STEPS, &guess).unwrap();
            let xmax = want.iter().fold(1e-300f64, |m, v| m.max(v.abs()));
            for i in 0..n {
                assert!(
                    (x[i] - want[i]).abs() <= 1e-10 * xmax,
                    "case {case}: x[{i}] = {} vs {}",
                    x[i],
                    want[i]
                );
            }
            assert_eq!(info.iterations, steps, "case {case}");
            assert_eq!(info.active, active, "case {case}");
            assert!(info.converged, "case {case}");
            assert!(
                info.kkt_residual < 1e-10,
                "case {case}: {}",
                info.kkt_residual
            );
            for &i in &constrained {
                assert!(x[i] <= 0.0, "case {case}: x[{i}] = {}", x[i]);
            }
            assert!(info.condition_estimate >= 1.0 && info.condition_estimate.is_finite());
            several_steps += usize::from(steps > 2);
            some_active += usize::from(active > 0 && active < constrained.len());
        }
        // The cases exercise the method, not only its first step.
        assert!(
            several_steps >= 5 && some_active >= 10,
            "{several_steps} {some_active}"
        );
    }

    /// Enumeration: for a small problem with m bounds, exactly one active set A gives a KKT
    /// point (x_A = 0, K_RR x_R = b_R on the rest R, x_C\A ≤ 0, λ_A = b_A − (Kx)_A ≥ 0;
    /// K SPD makes the minimiser unique). The Schur path must return that point.
    #[test]
    fn schur_path_matches_enumeration() {
        let mut rng = symmetric(11);
        for case in 0..12 {
            let n = 6 + case;
            let (kd, kl) = random_spd(n, &mut rng);
            let b: Vec<f64> = (0..n).map(|_| rng()).collect();
            let constrained: Vec<usize> = (0..n).step_by(2).take(7).collect();
            let m = constrained.len();
            let mut found = Vec::new();
            for mask in 0u32..(1 << m) {
                let act: Vec<usize> = (0..m)
                    .filter(|&p| mask & (1 << p) != 0)
                    .map(|p| constrained[p])
                    .collect();
                let rest: Vec<usize> = (0..n).filter(|i| !act.contains(i)).collect();
                let a: Vec<Vec<f64>> = rest
                    .iter()
                    .map(|&i| rest.iter().map(|&j| kd[i][j]).collect())
                    .collect();
                let xr = dense_solve(&a, &rest.iter().map(|&i| b[i]).collect::<Vec<_>>());
                let mut x = vec![0.0; n];
                for (p, &i) in rest.iter().enumerate() {
                    x[i] = xr[p];
                }
                let feasible = constrained
                    .iter()
                    .all(|&i| act.contains(&i) || x[i] <= 1e-12);
                let dual = act
                    .iter()
                    .all(|&i| b[i] - (0..n).map(|j| kd[i][j] * x[j]).sum::<f64>() >= -1e-12);
                if feasible && dual {
                    found.push(x);
                }
            }
            assert!(!found.is_empty(), "case {case}");
            let (x, info) = solve_bound_qp(&kl, &b, &constrained, MAX_STEPS).unwrap();
            assert!(info.converged);
            for want in &found {
                for i in 0..n {
                    assert!(
                        (x[i] - want[i]).abs() < 1e-10,
                        "case {case}: {x:?} vs {want:?}"
                    );
                }
            }
        }
    }

    /// The pattern from groups holds exactly the couplings of the groups and the diagonal,
    /// and scattering into it reproduces the triplet compression.
    #[test]
    fn pattern_from_groups_and_scatter() {
        // Unknowns 0..6; groups {0, 3, 5}, {1, 3}, {4, 4, 2} (a repeat), 6 alone.
        let ptr = [0, 3, 5, 8];
        let members = [0, 3, 5, 1, 3, 4, 4, 2];
        let mut k = SymCsc::from_groups(7, &ptr, &members).unwrap();
        let mut pattern = Vec::new();
        k.for_each(|i, j, _| pattern.push((i, j)));
        let want = vec![
            (0, 0),
            (3, 0),
            (5, 0),
            (1, 1),
            (3, 1),
            (2, 2),
            (4, 2),
            (3, 3),
            (5, 3),
            (4, 4),
            (5, 5),
            (6, 6),
        ];
        assert_eq!(pattern, want);
        let mut entries = Vec::new();
        for (t, &(i, j)) in want.iter().enumerate() {
            let v = 1.0 + t as f64;
            // Upper-triangle order for half of them: `add` takes either.
            assert!(if t % 2 == 0 {
                k.add(i, j, v)
            } else {
                k.add(j, i, v)
            });
            entries.push((i, j, v));
        }
        assert!(!k.add(1, 0, 1.0), "(1, 0) is not coupled");
        let l = Lower { n: 7, entries };
        let x: Vec<f64> = (0..7).map(|i| (i as f64).sin()).collect();
        let (y1, y2) = (k.apply(&x), l.apply(&x));
        let from = SymCsc::from_lower(&l).unwrap();
        assert_eq!(from.values, k.values);
        for i in 0..7 {
            assert!((y1[i] - y2[i]).abs() < 1e-14);
        }
        assert!(SymCsc::from_groups(3, &[0, 2], &[0, 3]).is_err());
        assert!(SymCsc::from_groups(3, &[0, 3], &[0, 1]).is_err());
    }

    /// A singular K = BᵀB (B of n − 1 random sparse rows) is never taken silently: its
    /// round-off pivot has either sign; a negative one stops the factorisation, and where a
    /// positive one lets it through, the condition estimate shows that no digit is left
    /// (measured 1.3e16–9.3e16 on these unstructured matrices; at or above
    /// [`SINGULAR_CONDITION`] it is refused, below it the report warns). A regular K of the
    /// same kind passes with a small estimate.
    #[test]
    fn singular_matrix_is_refused_or_flagged() {
        let mut rng = symmetric(5);
        let (mut factorised, mut refused) = (0, 0);
        for case in 0..40 {
            let n = 4 + case % 17;
            let mut bm = vec![vec![0.0; n]; n - 1];
            for (r, row) in bm.iter_mut().enumerate() {
                row[r] = 1.0 + rng().abs();
                for _ in 0..3 {
                    let j = ((rng() + 1.0) * 0.5 * n as f64) as usize % n;
                    row[j] += rng();
                }
            }
            let gram = |shift: f64| {
                let mut entries = Vec::new();
                for i in 0..n {
                    for j in 0..=i {
                        let v: f64 = bm.iter().map(|row| row[i] * row[j]).sum::<f64>()
                            + if i == j { shift } else { 0.0 };
                        entries.push((i, j, v));
                    }
                }
                Lower { n, entries }
            };
            let k = gram(0.0);
            let b: Vec<f64> = (0..n).map(|_| rng()).collect();
            let constrained = [n - 1];
            let is_constrained: Vec<bool> = (0..n).map(|i| i == n - 1).collect();
            factorised += usize::from(
                schur::Factor::new(&SymCsc::from_lower(&k).unwrap(), &is_constrained).is_ok(),
            );
            match solve_bound_qp(&k, &b, &constrained, MAX_STEPS) {
                Err(err) => {
                    assert!(
                        err.contains("not positive definite")
                            && err.ends_with("the field is not determined by the functional"),
                        "case {case}: {err}"
                    );
                    refused += 1;
                }
                Ok((_, info)) => assert!(
                    info.condition_estimate >= 1e15 && info.condition_estimate < SINGULAR_CONDITION,
                    "case {case}: {info:?}"
                ),
            }
            let (_, info) = solve_bound_qp(&gram(1e-3), &b, &constrained, MAX_STEPS).unwrap();
            assert!(info.condition_estimate < 1e10, "case {case}: {info:?}");
        }
        // Both signs of the round-off pivot occur.
        assert!(factorised >= 5 && refused >= 5, "{factorised} {refused}");
    }

    /// Bad input is an error, not a panic.
    #[test]
    fn bad_input_is_an_error() {
        let k = Lower {
            n: 2,
            entries: vec![(0, 0, 1.0), (1, 1, -1.0)],
        };
        assert!(solve_bound_qp(&k, &[1.0, 1.0], &[0], 10).is_err());
        assert!(solve_bound_qp(&k, &[1.0], &[0], 10).is_err());
        assert!(solve_bound_qp(&k, &[1.0, 1.0], &[5], 10).is_err());
        let upper = Lower {
            n: 2,
            entries: vec![(0, 1, 1.0)],
        };
        assert!(solve_bound_qp(&upper, &[1.0, 1.0], &[], 10).is_err());
    }
}
