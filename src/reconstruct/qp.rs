//! Small dense convex QPs with equality rows and sign bounds (the vertex-patch problems of
//! [`super::patch`]; docs/design.md §5.10):
//!
//! ```text
//! min ½ xᵀMx − bᵀx   s.t.   B x = d,   x_i ≤ 0 for i ∈ `bounded`,
//! ```
//!
//! M symmetric positive definite (n up to a few hundred), B possibly rank deficient and
//! slightly inconsistent.
//!
//! Method ([`solve`]):
//! 1. The rows of B are orthonormalised once (modified Gram–Schmidt, a second pass when the
//!    first cancelled much of the row; a row whose
//!    component orthogonal to the previous ones is below [`PATCH_DEPENDENT_ROW`] of its norm is
//!    dependent and dropped): Q x = d_Q with QQᵀ = I. If a dropped row's right-hand side
//!    disagrees with what the others give it (beyond [`INCONSISTENT_ROW`]), the later row would
//!    be the one missed, so the rows are orthonormalised again with the nearest right-hand side
//!    they can meet (`consistent_rhs`, independent of the order); the defect still shows the
//!    rows as given.
//! 2. One Cholesky factorisation of M and one of S = Q M⁻¹ Qᵀ give the equality-constrained
//!    minimiser x₀ and the reduced inverse K = M⁻¹ − M⁻¹Qᵀ S⁻¹ Q M⁻¹ (only its columns at the
//!    bounded variables). Every point of the dual path is x(λ) = x₀ − K E λ with λ ≥ 0 the bound
//!    multipliers, so the bound slacks are s(λ) = h − Gλ with h = x₀|_bounded and
//!    G = Eᵀ K E (m × m, m = number of bounds, a few dozen at most).
//! 3. The Goldfarb–Idnani dual active-set method (Goldfarb & Idnani 1983; Nocedal–Wright §16.8
//!    notes) runs on (G, h) alone: starting from the unconstrained (equality-only) minimiser, it
//!    adds the most violated bound, moving primal and dual along the step that keeps the working
//!    set active, and drops a working bound when its multiplier would turn negative (partial
//!    step). It needs no feasible starting point.
//!
//! Termination: every full step (a bound added) has a positive length and strictly increases
//! the dual objective, which at a full step's end equals the minimum of the QP with the working
//! set as equalities; so no working set recurs after a full step, and there are at most 2^m of
//! them. Between two full steps, each partial step drops one bound, so at most m follow each
//! other. Hence the method is finite; [`PATCH_ACTIVE_SET_ITERATIONS`] only guards against
//! round-off. When a violated bound is linearly dependent (in the K metric) on the working set
//! and no working multiplier can decrease, the bounds and the equalities are incompatible (the
//! GI infeasibility certificate); then the problem is re-solved with the bounds hard, the
//! caller's "hard" rows (the first ones; for the patches the equilibrium rows) exact and the
//! others (the contact equalities) as a quadratic penalty (weight [`PATCH_QP_PENALTY`] relative
//! to M), i.e. in the least-squares sense among the points satisfying the rest; if that is
//! still infeasible, with all rows soft: the minimiser among the points of least violation of
//! the unit rows (`least_violation_minimiser`), or, if that fails, with all rows penalised.
//! That last problem has bounds only and is always feasible, so there no bound counts as
//! dependent unless its Schur complement is not positive (the penalty makes those of pinned
//! bounds ~1/ρ, which the relative dependence test took for zero). The result says
//! `feasible: false`, with the defect showing the violation.
//!
//! Cost: one Cholesky M = LLᵀ (n³/3), one forward substitution of b, Qᵀ and the bounds' unit
//! vectors (n² each), S = VᵀV with V = L⁻¹Qᵀ and its Cholesky, one back substitution of 1 + m
//! columns; the active-set loop then works on m × m data only.

use faer::linalg::solvers::Llt;
use faer::linalg::triangular_solve::{
    solve_lower_triangular_in_place, solve_upper_triangular_in_place,
};
use faer::prelude::Solve;
use faer::{Mat, Par, Side};

use crate::solve::dense::{cholesky, cholesky_solve};
use crate::tolerance::{
    INCONSISTENT_ROW, PATCH_ACTIVE_SET_ITERATIONS, PATCH_DEPENDENT_ROW, PATCH_QP_DEPENDENT_BOUND,
    PATCH_QP_FEASIBILITY, PATCH_QP_PENALTY, PATCH_QP_REGULARISATION, PATCH_REORTHOGONALISE,
};

/// The outcome of [`solve`].
#[derive(Clone, Debug)]
pub struct QpResult {
    /// The minimiser (finite; bounded components ≤ 0 exactly).
    pub x: Vec<f64>,
    /// Bounds in the final working set (active, x_i = 0 up to round-off).
    pub active: usize,
    /// The active-set method reached a KKT point (of the penalised problem when `!feasible`)
    /// within [`PATCH_ACTIVE_SET_ITERATIONS`] changes and without a failed factorisation.
    pub settled: bool,
    /// The bounds and the (independent) equality rows are compatible.
    pub feasible: bool,
    /// Relative defect of the equality rows, max_k |B_k x − d_k| / max_k (Σ_j |B_kj x_j| + |d_k|)
    /// (each row's residual against the largest row scale of the problem, so a row whose own
    /// terms are round-off, e.g. a fixed tangential flux, is measured against that).
    pub defect: f64,
}

/// Solves min ½xᵀMx − bᵀx s.t. Bx = d, x_i ≤ 0 for i ∈ `bounded` (module doc).
///
/// `m`: dense row-major n × n, only the lower triangle is read; `rows`: B dense row-major
/// (d.len() × n); `bounded`: distinct indices < n. Rows from `hard_rows` on are relaxed first
/// when the problem is infeasible (module doc); `hard_rows = d.len()` treats all alike. Never
/// panics on singular or inconsistent data; the result is always finite.
pub fn solve(
    n: usize,
    m: &[f64],
    b: &[f64],
    rows: &[f64],
    d: &[f64],
    hard_rows: usize,
    bounded: &[usize],
) -> QpResult {
    assert_eq!(m.len(), n * n, "M is n × n");
    assert_eq!(b.len(), n, "b has n entries");
    assert_eq!(rows.len(), d.len() * n, "B is d.len() × n");
    let (mut q, mut dq, mut hard_q, unmet) = orthonormal_rows(n, rows, d, hard_rows);
    // A dependent row whose right-hand side disagrees with the others: which row is dropped
    // (the later one) would decide which one is missed, and with it the patch's defect and the
    // flows (`consistent_rhs`). The defect below is still that of the rows as given.
    if unmet && let Some(dc) = consistent_rhs(n, rows, d) {
        (q, dq, hard_q, _) = orthonormal_rows(n, rows, &dc, hard_rows);
    }
    let mm = symmetric_from_lower(n, m);
    let mut feasible = true;
    let (mut x, active, mut settled) = match equality_bound_qp(&mm, b, &q, &dq, bounded) {
        Some((x, active, Outcome::Optimal)) => (x, active, true),
        Some((x, active, Outcome::Cap)) => (x, active, false),
        Some((x0, a0, Outcome::Infeasible)) => {
            feasible = false;
            // Hard bounds, the first orthonormal rows (from the hard rows) exact and the others
            // in the least-squares sense (penalty M + ρQ_sᵀQ_s, b + ρQ_sᵀd_s); if that is still
            // infeasible, all rows penalised.
            let r = dq.len();
            let mut out = None;
            for keep in [hard_q, 0] {
                if keep == r && keep != 0 {
                    continue;
                }
                // All rows soft: their least violation first, exactly, then the minimiser
                // with the rows held at it (`least_violation`); the penalty below only if
                // that fails.
                if keep == 0
                    && let Some((x, active)) = least_violation_minimiser(&mm, b, rows, d, bounded)
                {
                    out = Some((x, active, true));
                    break;
                }
                let (mp, bp) = penalised(&mm, b, &q[keep * n..], &dq[keep..]);
                let got = equality_bound_qp(&mp, &bp, &q[..keep * n], &dq[..keep], bounded);
                if let Some((x, active, outcome)) = got
                    && outcome != Outcome::Infeasible
                {
                    out = Some((x, active, outcome == Outcome::Optimal));
                    break;
                }
            }
            out.unwrap_or((x0, a0, false))
        }
        None => (vec![0.0; n], 0, false),
    };
    if x.iter().any(|v| !v.is_finite()) {
        x.iter_mut().for_each(|v| *v = 0.0);
        settled = false;
    }
    // Round-off above zero at active bounds (or violations left by an unsettled solve).
    for &i in bounded {
        x[i] = x[i].min(0.0);
    }
    let defect = defect(n, rows, d, &x);
    QpResult {
        x,
        active,
        settled,
        feasible,
        defect,
    }
}

/// max_k |B_k x − d_k| / max_k (Σ_j |B_kj x_j| + |d_k|), 0 without rows.
pub fn defect(n: usize, rows: &[f64], d: &[f64], x: &[f64]) -> f64 {
    let (mut worst, mut scale) = (0.0f64, 0.0f64);
    for (r, &dk) in rows.chunks_exact(n.max(1)).zip(d) {
        let (mut bx, mut abs) = (0.0, 0.0);
        for (a, v) in r.iter().zip(x) {
            bx += a * v;
            abs += (a * v).abs();
        }
        worst = worst.max((bx - dk).abs());
        scale = scale.max(abs + dk.abs());
    }
    if scale > 0.0 { worst / scale } else { 0.0 }
}

/// Σ_i a_i b_i over the common length, in four interleaved partial sums: an iterator sum is
/// one dependent chain of additions the compiler may not reorder, and the Gram–Schmidt dot
/// products of [`orthonormal_rows`] were half of this module's time in that form (profile of
/// the patch bench, 100k P2 cells).
#[inline]
fn dot(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len());
    let (a, b) = (&a[..n], &b[..n]);
    let mut s = [0.0f64; 4];
    let (ca, cb) = (a.chunks_exact(4), b.chunks_exact(4));
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        for k in 0..4 {
            s[k] += x[k] * y[k];
        }
    }
    let tail: f64 = ra.iter().zip(rb).map(|(x, y)| x * y).sum();
    (s[0] + s[2]) + (s[1] + s[3]) + tail
}

/// min ½xᵀMx − bᵀx over the points of least violation of the rows `rows`, `d` (all soft), x_i
/// ≤ 0 on `bounded`. The violation is Σ_k ((B_k x − d_k)/|B_k|)² over every row as given: the
/// orthonormal rows Q of the other problems drop a dependent row, and which one depends on the
/// order of the rows; with rows that cannot all hold, the least-squares problem then depends on
/// it (a contact patch with its tangential unknowns in the other order gave a pressure 2 %
/// apart, and the Hertz Q2 halves' bound moved by 1e-3 when the points were renumbered; design
/// §5.10, "Solver"). The rows are then held at their values there ([`least_violation`]), the
/// bounds every such point has at 0 (a positive NNLS gradient) become equalities, so that the
/// problem left is not degenerate for the active-set method's dependence test, and the
/// minimiser is the exact one of a well-conditioned problem, where the penalty M + ρQᵀQ (ρ = 1e6
/// max M_ii) left the directions only M decides with ~6 fewer digits. None if a step fails; the
/// caller then takes the penalty.
fn least_violation_minimiser(
    mm: &Mat<f64>,
    b: &[f64],
    rows: &[f64],
    d: &[f64],
    bounded: &[usize],
) -> Option<(Vec<f64>, usize)> {
    let n = b.len();
    // Unit rows (zero rows dropped) and their right-hand sides.
    let (mut unit, mut du) = (Vec::new(), Vec::new());
    for (row, &dk) in rows.chunks_exact(n.max(1)).zip(d) {
        let norm = dot(row, row).sqrt();
        if norm > 0.0 {
            unit.extend(row.iter().map(|v| v / norm));
            du.push(dk / norm);
        }
    }
    let (held, pinned) = least_violation(n, &unit, &du, bounded)?;
    let mut all = unit;
    let mut target: Vec<f64> = held;
    for &p in &pinned {
        let mut row = vec![0.0; n];
        row[p] = 1.0;
        all.extend(row);
        target.push(0.0);
    }
    let free: Vec<usize> = bounded
        .iter()
        .copied()
        .filter(|p| !pinned.contains(p))
        .collect();
    let (q2, dq2, _, _) = orthonormal_rows(n, &all, &target, target.len());
    match equality_bound_qp(mm, b, &q2, &dq2, &free)? {
        (mut x, active, Outcome::Optimal) if x.iter().all(|v| v.is_finite()) => {
            for &p in &pinned {
                x[p] = 0.0;
            }
            Some((x, active + pinned.len()))
        }
        _ => None,
    }
}

/// The values of the rows (flat, unit norm, `q`, right-hand sides `dq`) at a point x* of least
/// violation, min ‖Qx − d_Q‖ over x with x_i ≤ 0 on `bounded`: d_Q + v* with v* the residual,
/// which is unique although x* is not. The free unknowns take the part of d_Q in the range of
/// their columns Q_F, so v* = A y − c with A = P⊥Q_B, c = P⊥d_Q (P⊥ the projector off range
/// Q_F) and y ≤ 0 the bounded unknowns of the small nonnegative least-squares problem
/// min ‖A y − c‖ (Lawson–Hanson 1974, §23.3, on z = −y). Also the bounded unknowns every point
/// of least violation has at 0: those whose NNLS gradient is positive beyond round-off (by
/// complementarity with the unique residual). None when the problem is degenerate (no rows, or
/// no bounded unknowns).
fn least_violation(
    n: usize,
    q: &[f64],
    dq: &[f64],
    bounded: &[usize],
) -> Option<(Vec<f64>, Vec<usize>)> {
    let r = dq.len();
    let m = bounded.len();
    if r == 0 || m == 0 || n == 0 {
        return None;
    }
    let column = |j: usize| -> Vec<f64> { (0..r).map(|k| q[k * n + j]).collect() };
    let mut is_bounded = vec![false; n];
    for &p in bounded {
        is_bounded[p] = true;
    }
    // An orthonormal basis U of range Q_F, and P⊥ = I − UUᵀ.
    let basis = orthonormal_basis((0..n).filter(|&j| !is_bounded[j]).map(column), r);
    let project = |mut v: Vec<f64>| {
        remove_components(&basis, &mut v);
        v
    };
    // E = −A (columns for z = −y ≥ 0) and c.
    let e: Vec<Vec<f64>> = bounded
        .iter()
        .map(|&p| project(column(p)).into_iter().map(|v| -v).collect())
        .collect();
    let c = project(dq.to_vec());
    let (z, tol) = nnls(&e, &c)?;
    let mut held = dq.to_vec();
    let mut resid: Vec<f64> = c.iter().map(|v| -v).collect();
    for (ej, &zj) in e.iter().zip(&z) {
        resid.iter_mut().zip(ej).for_each(|(ri, ei)| *ri += zj * ei);
    }
    held.iter_mut().zip(&resid).for_each(|(h, v)| *h += v);
    // Eᵀ(Ez − c) > tol: raising z_j would add violation.
    let pinned = bounded
        .iter()
        .zip(&e)
        .zip(&z)
        .filter(|((_, ej), zj)| **zj == 0.0 && dot(ej, &resid) > tol)
        .map(|((&p, _), _)| p)
        .collect();
    held.iter().all(|v| v.is_finite()).then_some((held, pinned))
}

/// An orthonormal basis of the span of `vectors` (modified Gram–Schmidt, each vector twice;
/// one whose remainder is below [`PATCH_DEPENDENT_ROW`] of its norm is dependent), stopping at
/// `dim`, the dimension of their space.
fn orthonormal_basis(vectors: impl Iterator<Item = Vec<f64>>, dim: usize) -> Vec<Vec<f64>> {
    let mut basis: Vec<Vec<f64>> = Vec::new();
    for mut v in vectors {
        let norm0 = dot(&v, &v).sqrt();
        if norm0 == 0.0 {
            continue;
        }
        remove_components(&basis, &mut v);
        let norm = dot(&v, &v).sqrt();
        if norm > PATCH_DEPENDENT_ROW * norm0 {
            v.iter_mut().for_each(|vi| *vi /= norm);
            basis.push(v);
        }
        if basis.len() == dim {
            break;
        }
    }
    basis
}

/// v ← (I − UUᵀ)v for the orthonormal `basis` U, by modified Gram–Schmidt run twice.
fn remove_components(basis: &[Vec<f64>], v: &mut [f64]) {
    for _ in 0..2 {
        for u in basis {
            let a = dot(u, v);
            v.iter_mut().zip(u).for_each(|(vi, ui)| *vi -= a * ui);
        }
    }
}

/// min ‖Σ_j z_j e_j − c‖ over z ≥ 0 (Lawson–Hanson's NNLS; columns `e`, a few dozen at most).
/// The least-squares subproblems on the passive set by modified Gram–Schmidt; a column
/// dependent on the passive ones (to `PATCH_DEPENDENT_ROW`) is not entered. None if the
/// iteration cap (3 × columns outer steps) is reached; else z and the gradient tolerance used.
fn nnls(e: &[Vec<f64>], c: &[f64]) -> Option<(Vec<f64>, f64)> {
    let m = e.len();
    let mut z = vec![0.0; m];
    let mut passive = vec![false; m];
    let scale: f64 = e.iter().map(|col| dot(col, col)).sum::<f64>().sqrt() * dot(c, c).sqrt();
    let tol = 1e-13 * scale;
    // The least-squares solution on the passive columns (others 0), None if they are dependent.
    let solve = |passive: &[bool]| -> Option<Vec<f64>> {
        let cols: Vec<usize> = (0..m).filter(|&j| passive[j]).collect();
        let k = cols.len();
        let mut qs: Vec<Vec<f64>> = Vec::with_capacity(k);
        let mut rr = vec![0.0; k * k];
        for (a, &j) in cols.iter().enumerate() {
            let mut v = e[j].clone();
            let norm0 = dot(&v, &v).sqrt();
            for _ in 0..2 {
                for (b, u) in qs.iter().enumerate() {
                    let t = dot(u, &v);
                    rr[b * k + a] += t;
                    v.iter_mut().zip(u).for_each(|(vi, ui)| *vi -= t * ui);
                }
            }
            let norm = dot(&v, &v).sqrt();
            if norm <= PATCH_DEPENDENT_ROW * norm0 || norm == 0.0 {
                return None;
            }
            rr[a * k + a] = norm;
            v.iter_mut().for_each(|vi| *vi /= norm);
            qs.push(v);
        }
        let mut s: Vec<f64> = qs.iter().map(|u| dot(u, c)).collect();
        for a in (0..k).rev() {
            for b in a + 1..k {
                s[a] -= rr[a * k + b] * s[b];
            }
            s[a] /= rr[a * k + a];
        }
        let mut full = vec![0.0; m];
        for (a, &j) in cols.iter().enumerate() {
            full[j] = s[a];
        }
        Some(full)
    };
    for _ in 0..3 * m + 3 {
        // w = Eᵀ(c − Ez): the descent directions of the inactive columns.
        let mut resid = c.to_vec();
        for (ej, &zj) in e.iter().zip(&z) {
            if zj != 0.0 {
                resid.iter_mut().zip(ej).for_each(|(ri, ei)| *ri -= zj * ei);
            }
        }
        let best = (0..m)
            .filter(|&j| !passive[j])
            .map(|j| (j, dot(&e[j], &resid)))
            .filter(|&(_, w)| w > tol)
            .max_by(|a, b| a.1.total_cmp(&b.1));
        let Some((t, _)) = best else {
            return Some((z, tol));
        };
        passive[t] = true;
        let Some(mut s) = solve(&passive) else {
            // Dependent on the passive set: it cannot lower the residual further.
            passive[t] = false;
            return Some((z, tol));
        };
        for step in 0..=m {
            if step > 0 {
                s = solve(&passive)?;
            }
            if (0..m).filter(|&j| passive[j]).all(|j| s[j] > 0.0) {
                z = s;
                break;
            }
            // Step towards s until the first passive value reaches 0; it leaves the set.
            let alpha = (0..m)
                .filter(|&j| passive[j] && s[j] <= 0.0)
                .map(|j| z[j] / (z[j] - s[j]))
                .fold(f64::INFINITY, f64::min);
            for j in 0..m {
                z[j] += alpha * (s[j] - z[j]);
                if passive[j] && z[j] <= 0.0 {
                    z[j] = 0.0;
                    passive[j] = false;
                }
            }
        }
    }
    None
}

/// The full symmetric M from the lower triangle of the row-major `m` (n × n). Column j of M
/// is row j of the full matrix, so it is filled by one contiguous copy of row j's lower part
/// and a strided read below the diagonal (`Mat::from_fn`, with a closure and a branch per
/// entry, took ~23k instructions per interior P2 patch, a tenth of the QP).
fn symmetric_from_lower(n: usize, m: &[f64]) -> Mat<f64> {
    let mut mm = Mat::<f64>::zeros(n, n);
    for j in 0..n {
        let col = mm.col_as_slice_mut(j);
        col[..j].copy_from_slice(&m[j * n..j * n + j]);
        for (i, c) in col.iter_mut().enumerate().skip(j) {
            *c = m[i * n + j];
        }
    }
    mm
}

/// M + ρQ_sᵀQ_s and b + ρQ_sᵀd_s, ρ = [`PATCH_QP_PENALTY`] × max M_ii (Q_s orthonormal rows).
fn penalised(mm: &Mat<f64>, b: &[f64], qs: &[f64], ds: &[f64]) -> (Mat<f64>, Vec<f64>) {
    let n = b.len();
    let scale = (0..n).map(|i| mm[(i, i)].abs()).fold(0.0, f64::max);
    let rho = PATCH_QP_PENALTY * scale;
    let mut mp = mm.clone();
    let mut bp = b.to_vec();
    for (qi, &di) in qs.chunks_exact(n.max(1)).zip(ds) {
        for j in 0..n {
            let a = rho * qi[j];
            if a == 0.0 {
                continue;
            }
            bp[j] += a * di;
            for (k, &qk) in qi.iter().enumerate() {
                mp[(k, j)] += a * qk;
            }
        }
    }
    (mp, bp)
}

/// Orthonormal rows Q (flat, row-major) spanning the rows of B, d_Q with the same
/// combinations applied to d (module doc, step 1), and how many of them come from the first
/// `hard` rows.
fn orthonormal_rows(
    n: usize,
    rows: &[f64],
    d: &[f64],
    hard: usize,
) -> (Vec<f64>, Vec<f64>, usize, bool) {
    let mut q: Vec<f64> = Vec::with_capacity(rows.len().min(n * n));
    let mut dq: Vec<f64> = Vec::new();
    let mut hard_q = 0;
    let rhs_scale = d.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let mut unmet = false;
    let mut v = vec![0.0; n];
    for (k, (row, &dk)) in rows.chunks_exact(n.max(1)).zip(d).enumerate() {
        if k == hard {
            hard_q = dq.len();
        }
        let norm0 = dot(row, row).sqrt();
        if norm0 == 0.0 {
            continue;
        }
        v.copy_from_slice(row);
        let mut dv = dk;
        let mut before = norm0;
        for _ in 0..2 {
            for (qj, &dj) in q.chunks_exact(n).zip(&dq) {
                let a = dot(qj, &v);
                if a == 0.0 {
                    continue;
                }
                for (vi, qi) in v.iter_mut().zip(qj) {
                    *vi -= a * qi;
                }
                dv -= a * dj;
            }
            // "Twice is enough" (Daniel–Gragg–Kaufman–Stewart 1976): a second pass only when
            // the first one cancelled much of the row.
            let after = dot(&v, &v).sqrt();
            if after >= PATCH_REORTHOGONALISE * before {
                break;
            }
            before = after;
        }
        let norm = dot(&v, &v).sqrt();
        if norm <= PATCH_DEPENDENT_ROW * norm0 {
            unmet |= dv.abs() > INCONSISTENT_ROW * rhs_scale;
            continue;
        }
        let s = 1.0 / norm;
        q.extend(v.iter().map(|a| a * s));
        dq.push(dv * s);
    }
    if hard >= d.len() {
        hard_q = dq.len();
    }
    (q, dq, hard_q, unmet)
}

/// The right-hand side nearest to `d` that the rows can meet: with unit rows B̂_k = B_k/|B_k|,
/// d̂ = W Wᵀ (d_k/|B_k|) for W an orthonormal basis of the range of B̂ (modified Gram–Schmidt
/// over its columns), returned as |B_k| d̂_k. It depends on the set of rows, not on their order
/// or on the order and signs of the unknowns, so the solution does not either: the orthonormal
/// rows of [`orthonormal_rows`] drop the later of two dependent rows, and with disagreeing
/// right-hand sides the patch met one and missed the other. On the Hertz Q2 halves (a
/// displacement that is not a Galerkin solution there) contact patches carried such rows, and
/// the same file with its points renumbered moved their rotation balance by 1e-3 (design
/// §5.10, "Solver"). None without rows.
fn consistent_rhs(n: usize, rows: &[f64], d: &[f64]) -> Option<Vec<f64>> {
    let norms: Vec<f64> = rows
        .chunks_exact(n.max(1))
        .map(|r| dot(r, r).sqrt())
        .collect();
    let k = norms.len();
    if k == 0 || n == 0 {
        return None;
    }
    let du: Vec<f64> = d
        .iter()
        .zip(&norms)
        .map(|(dk, &nk)| if nk > 0.0 { dk / nk } else { 0.0 })
        .collect();
    let unit_column = |j: usize| -> Vec<f64> {
        (0..k)
            .map(|i| {
                if norms[i] > 0.0 {
                    rows[i * n + j] / norms[i]
                } else {
                    0.0
                }
            })
            .collect()
    };
    let basis = orthonormal_basis((0..n).map(unit_column), k);
    let mut out = vec![0.0; k];
    for u in &basis {
        let a = dot(u, &du);
        out.iter_mut().zip(u).for_each(|(o, ui)| *o += a * ui);
    }
    Some(out.iter().zip(&norms).map(|(o, nk)| o * nk).collect())
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Outcome {
    /// KKT point found.
    Optimal,
    /// The bounds are incompatible with the equalities (GI certificate).
    Infeasible,
    /// Change cap or a failed factorisation of the working set.
    Cap,
}

/// Cholesky of a symmetric positive (semi)definite matrix, shifted by a growing multiple of
/// its largest diagonal entry if round-off makes it fail.
fn factor(mm: &Mat<f64>) -> Option<Llt<f64>> {
    if let Ok(l) = mm.llt(Side::Lower) {
        return Some(l);
    }
    let n = mm.nrows();
    let scale = (0..n).map(|i| mm[(i, i)].abs()).fold(0.0, f64::max);
    if !(scale > 0.0 && scale.is_finite()) {
        return None;
    }
    let mut shift = PATCH_QP_REGULARISATION * scale;
    for _ in 0..4 {
        let mut s = mm.clone();
        for i in 0..n {
            s[(i, i)] += shift;
        }
        if let Ok(l) = s.llt(Side::Lower) {
            return Some(l);
        }
        shift *= 100.0;
    }
    None
}

/// min ½xᵀMx − bᵀx s.t. Qx = d_Q (orthonormal rows, flat), x_i ≤ 0 on `bounded`: steps 2–3
/// of the module doc. Returns x, the working-set size and the outcome; None if M or S cannot
/// be factorised.
fn equality_bound_qp(
    mm: &Mat<f64>,
    b: &[f64],
    q: &[f64],
    dq: &[f64],
    bounded: &[usize],
) -> Option<(Vec<f64>, usize, Outcome)> {
    let n = b.len();
    let r = dq.len();
    let nb = bounded.len();
    let llt = factor(mm)?;
    let l = llt.L();
    // Columns b | E (the bounded unit vectors) | Qᵀ, forward-substituted: β | U | V = L⁻¹(…).
    let w = 1 + nb;
    let mut rhs = Mat::<f64>::zeros(n, w + r);
    rhs.col_as_slice_mut(0).copy_from_slice(b);
    for (k, &p) in bounded.iter().enumerate() {
        rhs[(p, 1 + k)] = 1.0;
    }
    for (j, qj) in q.chunks_exact(n.max(1)).enumerate() {
        rhs.col_as_slice_mut(w + j).copy_from_slice(qj);
    }
    solve_lower_triangular_in_place(l, rhs.as_mut(), Par::Seq);
    // (M⁻¹)_pp = |L⁻¹e_p|², the scale of the dependence test.
    let wdiag: Vec<f64> = (0..nb)
        .map(|k| (0..n).map(|i| rhs[(i, 1 + k)] * rhs[(i, 1 + k)]).sum())
        .collect();
    // With S = VᵀV = Q M⁻¹ Qᵀ and C = S⁻¹[Vᵀβ − d_Q | VᵀU]: x₀ = L⁻ᵀ(β − V C₀) and
    // K E = L⁻ᵀ(U − V C₁..), so only 1 + nb columns are back-substituted.
    let mut out = rhs.as_ref().subcols(0, w).to_owned();
    if r > 0 {
        let v = rhs.as_ref().subcols(w, r);
        let s = v.transpose() * v;
        let sl = factor(&s)?;
        let mut c = v.transpose() * rhs.as_ref().subcols(0, w);
        for (i, &di) in dq.iter().enumerate() {
            c[(i, 0)] -= di;
        }
        sl.solve_in_place(c.as_mut());
        let upd = v * c.as_ref();
        for j in 0..w {
            for i in 0..n {
                out[(i, j)] -= upd[(i, j)];
            }
        }
    }
    solve_upper_triangular_in_place(l.transpose(), out.as_mut(), Par::Seq);
    let mut x: Vec<f64> = (0..n).map(|i| out[(i, 0)]).collect();
    if nb == 0 {
        return Some((x, 0, Outcome::Optimal));
    }
    let g: Vec<f64> = (0..nb * nb)
        .map(|ij| out[(bounded[ij / nb], 1 + ij % nb)])
        .collect();
    let h: Vec<f64> = bounded.iter().map(|&p| x[p]).collect();
    // A bound can depend on the working set only through the equality rows: without them
    // G = Eᵀ M⁻¹ E is a principal submatrix of M⁻¹, positive definite, and a small Schur
    // complement is a stiff direction, not a dependence. That is the all-rows-penalised
    // fallback of `solve` (M + ρQᵀQ): a bound the penalised rows and the working set pin has
    // a Schur complement ~1/ρ, below PATCH_QP_DEPENDENT_BOUND of its diagonal entry whenever
    // M_pp < 1e-3 max M_ii, and the always-feasible problem was declared infeasible. There only
    // a non-positive Schur complement (round-off) counts as dependent.
    let relative = if r == 0 {
        0.0
    } else {
        PATCH_QP_DEPENDENT_BOUND
    };
    let dep: Vec<f64> = wdiag.iter().map(|w| relative * w).collect();
    let tol = PATCH_QP_FEASIBILITY * x.iter().fold(0.0f64, |a, v| a.max(v.abs()));
    let mut lambda = vec![0.0; nb];
    let (outcome, active) = dual_active_set(nb, &g, &h, &dep, tol, &mut lambda);
    for (k, &l) in lambda.iter().enumerate() {
        if l != 0.0 {
            for (i, xi) in x.iter_mut().enumerate() {
                *xi -= out[(i, 1 + k)] * l;
            }
        }
    }
    Some((x, active, outcome))
}

/// Goldfarb–Idnani on the bound slacks s(λ) = h − Gλ ≤ 0 (module doc, step 3). `g`: m × m
/// row-major, positive semidefinite; `dep[p]`: a bound whose Schur complement against the
/// working set is at most this is dependent on it; `tol`: slack counted as violated above it.
/// Returns the outcome and the working-set size; `lambda` the multipliers (≥ 0).
fn dual_active_set(
    m: usize,
    g: &[f64],
    h: &[f64],
    dep: &[f64],
    tol: f64,
    lambda: &mut [f64],
) -> (Outcome, usize) {
    let mut set: Vec<usize> = Vec::with_capacity(m);
    let mut in_set = vec![false; m];
    // Cholesky factor of G restricted to the working set (row-major, stride m), refactorised
    // at each change: m is a few dozen at most, negligible against the set-up.
    let mut l = vec![0.0; m * m];
    let mut r = vec![0.0; m];
    let mut changes = 0usize;
    let slack = |lambda: &[f64], i: usize| {
        h[i] - g[i * m..(i + 1) * m]
            .iter()
            .zip(lambda)
            .map(|(a, b)| a * b)
            .sum::<f64>()
    };
    loop {
        // The most violated bound outside the working set.
        let mut p = usize::MAX;
        let mut worst = tol;
        for i in (0..m).filter(|&i| !in_set[i]) {
            let s = slack(lambda, i);
            if s > worst {
                worst = s;
                p = i;
            }
        }
        if p == usize::MAX {
            return (Outcome::Optimal, set.len());
        }
        loop {
            if changes >= PATCH_ACTIVE_SET_ITERATIONS {
                return (Outcome::Cap, set.len());
            }
            changes += 1;
            let k = set.len();
            if !cholesky(m, g, &set, &mut l) {
                return (Outcome::Cap, set.len());
            }
            // r = G_SS⁻¹ G_Sp: the working multipliers' rate of decrease per unit of λ_p.
            for (a, &j) in set.iter().enumerate() {
                r[a] = g[j * m + p];
            }
            cholesky_solve(m, k, &l, &mut r[..k]);
            let delta = g[p * m + p]
                - set
                    .iter()
                    .zip(&r[..k])
                    .map(|(&j, ra)| g[p * m + j] * ra)
                    .sum::<f64>();
            let sp = slack(lambda, p);
            let t1 = if delta > dep[p] {
                (sp / delta).max(0.0)
            } else {
                f64::INFINITY
            };
            let (mut t2, mut drop) = (f64::INFINITY, usize::MAX);
            for (a, &j) in set.iter().enumerate() {
                if r[a] > 0.0 {
                    let t = lambda[j] / r[a];
                    if t < t2 {
                        t2 = t;
                        drop = a;
                    }
                }
            }
            if t1 == f64::INFINITY && t2 == f64::INFINITY {
                return (Outcome::Infeasible, set.len());
            }
            let t = t1.min(t2);
            for (a, &j) in set.iter().enumerate() {
                lambda[j] = (lambda[j] - t * r[a]).max(0.0);
            }
            lambda[p] += t;
            if t1 <= t2 {
                set.push(p);
                in_set[p] = true;
                break;
            }
            let j = set.remove(drop);
            in_set[j] = false;
            lambda[j] = 0.0;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rows_of(r: &[(Vec<f64>, f64)]) -> (Vec<f64>, Vec<f64>) {
        (
            r.iter().flat_map(|(a, _)| a.iter().copied()).collect(),
            r.iter().map(|&(_, d)| d).collect(),
        )
    }

    fn run(n: usize, m: &[f64], b: &[f64], r: &[(Vec<f64>, f64)], bounded: &[usize]) -> QpResult {
        let (rows, d) = rows_of(r);
        solve(n, m, b, &rows, &d, d.len(), bounded)
    }

    fn identity(n: usize) -> Vec<f64> {
        (0..n * n)
            .map(|ij| if ij / n == ij % n { 1.0 } else { 0.0 })
            .collect()
    }

    #[test]
    fn qp_with_a_bound_and_an_equality() {
        // min ½(x₀² + x₁²) − (x₀ + x₁) s.t. x₀ − x₁ = 0.5, x₀ ≤ 0: x = (0, −0.5) by hand.
        let m = identity(2);
        let b = vec![1.0, 1.0];
        let rows = vec![(vec![1.0, -1.0], 0.5)];
        let res = run(2, &m, &b, &rows, &[0]);
        assert!(res.settled && res.feasible && res.active == 1 && res.defect < 1e-14);
        let x = &res.x;
        assert!(x[0].abs() < 1e-14 && (x[1] + 0.5).abs() < 1e-14, "{x:?}");
        // Without the bound: x₀ = 1.25, x₁ = 0.75.
        let x = run(2, &m, &b, &rows, &[]).x;
        assert!((x[0] - 1.25).abs() < 1e-14 && (x[1] - 0.75).abs() < 1e-14);
    }

    #[test]
    fn dependent_rows_are_dropped_and_inconsistent_ones_reported() {
        let m = identity(2);
        let b = vec![0.0, 0.0];
        let rows = vec![(vec![1.0, 1.0], 1.0), (vec![2.0, 2.0], 2.0)];
        let res = run(2, &m, &b, &rows, &[]);
        assert!((res.x[0] - 0.5).abs() < 1e-14 && res.defect < 1e-14);
        // Disagreeing: the unit rows (x₀ + x₁)/√2 = 1/√2 and = 1.5/√2 are met by their mean,
        // x₀ + x₁ = 1.25, so x = (0.625, 0.625) in either order (before, the later row was
        // dropped: 0.5 or 0.75 each). Defect: |2.5 − 3| against the scale 2.5 + 3 = 5.5.
        let bad = vec![(vec![1.0, 1.0], 1.0), (vec![2.0, 2.0], 3.0)];
        for rows in [bad.clone(), bad.iter().rev().cloned().collect()] {
            let res = run(2, &m, &b, &rows, &[]);
            assert!(
                (res.x[0] - 0.625).abs() < 1e-14 && (res.x[1] - 0.625).abs() < 1e-14,
                "{res:?}"
            );
            assert!((res.defect - 0.5 / 5.5).abs() < 1e-14, "{}", res.defect);
        }
    }

    /// Where every row is soft, the minimiser among the points of least violation, exactly: rows
    /// x₀ = 1 and x₁ + x₂ = 2 with x₀ ≤ 0, M = I, b = 0. By hand the least violation has x₀ = 0
    /// and x₁ + x₂ = 2, and ½|x|² then gives x = (0, 1, 1). The penalty M + ρQᵀQ alone gave
    /// x₁ = x₂ = 1 − O(1/ρ).
    #[test]
    fn all_rows_soft_gives_the_minimiser_of_least_violation() {
        let m = identity(3);
        let rows = vec![(vec![1.0, 0.0, 0.0], 1.0), (vec![0.0, 1.0, 1.0], 2.0)];
        let res = run(3, &m, &[0.0; 3], &rows, &[0]);
        assert!(!res.feasible && res.settled, "{res:?}");
        for (x, want) in res.x.iter().zip([0.0, 1.0, 1.0]) {
            assert!((x - want).abs() < 1e-14, "{res:?}");
        }
    }

    /// Rows that cannot all hold (two dependent ones disagree, and one needs a bounded unknown
    /// positive) give one solution whatever the order of the rows and the order and signs of
    /// the unknowns: the same patch numbered otherwise must give the same stress (design §5.10,
    /// "Solver"). Before, the dropped dependent row followed the row order and the penalised
    /// fallback the unknowns' order (the Hertz Q2 halves' bound moved by 1e-3 on renumbering).
    #[test]
    fn the_solution_does_not_depend_on_the_order_of_rows_or_unknowns() {
        let n = 8;
        let mut rnd = crate::testing::uniform(11);
        let mut sym = |_: usize| 2.0 * rnd() - 1.0;
        let a: Vec<f64> = (0..n * n).map(&mut sym).collect();
        // M = AᵀA + I (positive definite).
        let mut m = vec![0.0; n * n];
        for i in 0..n {
            for j in 0..n {
                m[i * n + j] = (0..n).map(|k| a[k * n + i] * a[k * n + j]).sum::<f64>()
                    + if i == j { 1.0 } else { 0.0 };
            }
        }
        let b: Vec<f64> = (0..n).map(&mut sym).collect();
        let mut rows: Vec<(Vec<f64>, f64)> = (0..3)
            .map(|_| ((0..n).map(&mut sym).collect(), sym(0)))
            .collect();
        // A dependent row that disagrees with the first two by 0.3.
        let sum: Vec<f64> = (0..n).map(|j| rows[0].0[j] + rows[1].0[j]).collect();
        rows.push((sum, rows[0].1 + rows[1].1 + 0.3));
        let bounded = [2, 5];
        // Feasible bounds (x₂, x₅ ≤ 0 with room), then x₂ = 0.5 forced against x₂ ≤ 0.
        let mut unit = vec![0.0; n];
        unit[2] = 1.0;
        let infeasible: Vec<(Vec<f64>, f64)> = rows.iter().cloned().chain([(unit, 0.5)]).collect();
        for rows in [rows, infeasible] {
            let base = run(n, &m, &b, &rows, &bounded);
            // Unknowns reversed, the free ones with alternating signs; rows reversed.
            let perm: Vec<usize> = (0..n).rev().collect();
            let sign: Vec<f64> = (0..n)
                .map(|j| {
                    if bounded.contains(&j) || j % 2 == 0 {
                        1.0
                    } else {
                        -1.0
                    }
                })
                .collect();
            // New unknown k is old unknown perm[k] times sign[perm[k]].
            let mut m2 = vec![0.0; n * n];
            for k in 0..n {
                for l in 0..n {
                    let (i, j) = (perm[k], perm[l]);
                    m2[k * n + l] = sign[i] * sign[j] * m[i * n + j];
                }
            }
            let b2: Vec<f64> = (0..n).map(|k| sign[perm[k]] * b[perm[k]]).collect();
            let rows2: Vec<(Vec<f64>, f64)> = rows
                .iter()
                .rev()
                .map(|(r, d)| ((0..n).map(|k| sign[perm[k]] * r[perm[k]]).collect(), *d))
                .collect();
            let bounded2: Vec<usize> = bounded
                .iter()
                .map(|&i| perm.iter().position(|&p| p == i).unwrap())
                .collect();
            let other = run(n, &m2, &b2, &rows2, &bounded2);
            assert_eq!(base.feasible, other.feasible);
            for k in 0..n {
                let (i, v) = (perm[k], sign[perm[k]] * other.x[k]);
                assert!(
                    (base.x[i] - v).abs() < 1e-10 * (1.0 + base.x[i].abs()),
                    "unknown {i}: {} against {v}",
                    base.x[i]
                );
            }
            assert!(
                (base.defect - other.defect).abs() < 1e-10,
                "{base:?} {other:?}"
            );
        }
    }

    #[test]
    fn several_active_bounds_by_hand() {
        // min ½|x|² − (1, 2, 3, −1)·x s.t. x₀ + x₁ + x₂ + x₃ = 1, x₀, x₁, x₃ ≤ 0.
        // Unconstrained on the plane: x = b − μ(1,1,1,1), μ = (5 − 1)/4 = 1 → (0, 1, 2, −2):
        // x₁ violates. With x₁ = 0: x = (1 − μ, 0, 3 − μ, −1 − μ), 3 − 3μ = 1, μ = 2/3
        // → (1/3, 0, 7/3, −5/3): x₀ violates. With x₀ = x₁ = 0: μ = (3 − 1 − 1)/2 = 1/2,
        // x = (0, 0, 5/2, −3/2); multipliers ν₀ = b₀ − μ = 1/2 ≥ 0, ν₁ = 3/2 ≥ 0.
        let m = identity(4);
        let b = [1.0, 2.0, 3.0, -1.0];
        let rows = vec![(vec![1.0; 4], 1.0)];
        let res = run(4, &m, &b, &rows, &[0, 1, 3]);
        assert!(res.settled && res.feasible && res.active == 2, "{res:?}");
        let want = [0.0, 0.0, 2.5, -1.5];
        for (a, w) in res.x.iter().zip(want) {
            assert!((a - w).abs() < 1e-14, "{:?}", res.x);
        }
        // A coupled M: min ½xᵀMx − bᵀx, M = [[2,1,0],[1,2,1],[0,1,2]], b = (1, 1, 1), x ≤ 0
        // on all: the minimiser of a positive b on the negative orthant is 0 (ν = b > 0).
        let m = [2.0, 1.0, 0.0, 1.0, 2.0, 1.0, 0.0, 1.0, 2.0];
        let res = run(3, &m, &[1.0, 1.0, 1.0], &[], &[0, 1, 2]);
        assert!(res.settled && res.active == 3, "{res:?}");
        assert!(res.x.iter().all(|v| v.abs() < 1e-14), "{res:?}");
        // b = (1, −4, 1): x₁ free, x₀ = x₂ = 0 → x₁ = −2, ν₀ = 1 − (−2) = 3, ν₂ = 3.
        let res = run(3, &m, &[1.0, -4.0, 1.0], &[], &[0, 1, 2]);
        assert!(res.settled && res.active == 2, "{res:?}");
        let want = [0.0, -2.0, 0.0];
        assert!(
            res.x.iter().zip(want).all(|(a, w)| (a - w).abs() < 1e-14),
            "{res:?}"
        );
    }

    #[test]
    fn degenerate_dependent_rows_with_bounds() {
        // Rows x₀ + x₁ = −1 twice and x₀ + x₁ + 0·x₂ = −1 scaled, x₂ = 0 as an equality on a
        // bounded variable, bounds on x₀, x₁, x₂. min ½|x|² − (−3, −3, 1)·x: on the line
        // x₀ + x₁ = −1, x = (−3, −3) − μ(1, 1), μ = −5/2 → (−1/2, −1/2) feasible; x₂ = 0.
        let m = identity(3);
        let rows = vec![
            (vec![1.0, 1.0, 0.0], -1.0),
            (vec![2.0, 2.0, 0.0], -2.0),
            (vec![0.0, 0.0, 1.0], 0.0),
            (vec![-3.0, -3.0, 0.0], 3.0),
        ];
        let res = run(3, &m, &[-3.0, -3.0, 1.0], &rows, &[0, 1, 2]);
        assert!(res.settled && res.feasible && res.defect < 1e-14, "{res:?}");
        let want = [-0.5, -0.5, 0.0];
        assert!(
            res.x.iter().zip(want).all(|(a, w)| (a - w).abs() < 1e-14),
            "{res:?}"
        );
        // b = (3, −3, 1): on the line, μ = 1/2 and (5/2, −7/2) violates x₀ ≤ 0; x₀ = 0 gives
        // x₁ = −1, μ = b₁ − x₁ = −2, ν₀ = b₀ − x₀ − μ = 5 ≥ 0.
        let res = run(3, &m, &[3.0, -3.0, 1.0], &rows, &[0, 1, 2]);
        assert!(res.settled && res.feasible && res.defect < 1e-14, "{res:?}");
        assert!(res.active >= 1, "{res:?}");
        let want = [0.0, -1.0, 0.0];
        assert!(
            res.x.iter().zip(want).all(|(a, w)| (a - w).abs() < 1e-14),
            "{res:?}"
        );
    }

    #[test]
    fn infeasible_problems_report_a_defect_and_stay_finite() {
        // x₀ + x₁ = 1 with x₀, x₁ ≤ 0: incompatible. The bounds hold, the row is violated.
        let m = identity(3);
        let rows = vec![(vec![1.0, 1.0, 0.0], 1.0), (vec![0.0, 1.0, 1.0], 0.0)];
        let res = run(3, &m, &[0.0, 0.0, 0.0], &rows, &[0, 1]);
        assert!(!res.feasible && res.defect > 0.1, "{res:?}");
        assert!(res.x.iter().all(|v| v.is_finite()));
        assert!(res.x[0] <= 0.0 && res.x[1] <= 0.0);
        // A row fixing a bounded variable at a positive value.
        let rows = vec![(vec![0.0, 2.0, 0.0], 1.0)];
        let res = run(3, &m, &[0.0, 5.0, 0.0], &rows, &[1]);
        assert!(
            !res.feasible && res.defect > 0.1 && res.x[1] <= 0.0,
            "{res:?}"
        );
        // Priority: x₀ + x₁ = 1 hard, x₁ = 0 soft, x₀ ≤ 0: the hard row holds, x₁ ≈ 1.
        let (rows, d) = rows_of(&[(vec![1.0, 1.0, 0.0], 1.0), (vec![0.0, 1.0, 0.0], 0.0)]);
        let res = solve(3, &m, &[0.0; 3], &rows, &d, 1, &[0]);
        assert!(!res.feasible && res.settled && res.x[0] <= 0.0, "{res:?}");
        assert!((res.x[0] + res.x[1] - 1.0).abs() < 1e-8, "{res:?}");
        assert!((res.x[1] - 1.0).abs() < 1e-5, "{res:?}");
        // Singular M and NaN-free output anyway.
        let res = run(2, &[0.0; 4], &[1.0, 1.0], &[], &[0]);
        assert!(res.x.iter().all(|v| v.is_finite()));
    }

    #[test]
    fn penalised_fallback_without_rows_is_feasible() {
        // x₀ + x₁ = 1 with x₀, x₁ ≤ 0 is incompatible; the fallback minimises, with the bounds
        // hard, ½xᵀMx + ½ρ(x₀ + x₁ − 1)²/2 (the row orthonormalised: q = (1, 1, 0)/√2,
        // d_q = 1/√2), ρ = PATCH_QP_PENALTY × max M_ii = 1e10 for
        //     M = [[1, 0, c], [0, ½, 0], [c, 0, 1e4]],   c = 50 (positive definite: 1e4 > c²).
        // By hand its minimiser is x = 0: at 0 the gradient is (−ρ/2, −ρ/2, 0), so both bounds
        // are active with multipliers ρ/2 ≥ 0, and x₂ = −c x₀/1e4 = 0. The two bounds are
        // independent (no equality rows are left), but the second one's Schur complement
        // 1/(ρ/2 + O(1)) ≈ 2e-10 is below 1e-9 of its diagonal entry ~0.5: taken for a
        // dependence, it made the fallback look infeasible too, and the first attempt's last
        // iterate came back instead: x₀ = 1 from the row (clipped to 0), x₂ = −c/1e4 = −5e-3.
        let c = 50.0;
        let m = vec![1.0, 0.0, c, 0.0, 0.5, 0.0, c, 0.0, 1e4];
        let rows = vec![(vec![1.0, 1.0, 0.0], 1.0)];
        let res = run(3, &m, &[0.0; 3], &rows, &[0, 1]);
        assert!(!res.feasible && res.settled, "{res:?}");
        assert!(res.x.iter().all(|v| v.abs() < 1e-6), "{res:?}");
        // The defect is the whole row: |0 − 1| against the row scale 1.
        assert!((res.defect - 1.0).abs() < 1e-6, "{res:?}");
    }

    /// xorshift64*, in [−1, 1).
    struct Rng(u64);
    impl Rng {
        fn next(&mut self) -> f64 {
            self.0 ^= self.0 >> 12;
            self.0 ^= self.0 << 25;
            self.0 ^= self.0 >> 27;
            let v = self.0.wrapping_mul(0x2545_f491_4f6c_dd1d);
            (v >> 11) as f64 / (1u64 << 52) as f64 - 1.0
        }
    }

    /// Dense solve with partial pivoting; None if singular.
    fn gauss(n: usize, mut a: Vec<f64>, mut y: Vec<f64>) -> Option<Vec<f64>> {
        for c in 0..n {
            let p = (c..n).max_by(|&i, &j| a[i * n + c].abs().total_cmp(&a[j * n + c].abs()))?;
            if a[p * n + c].abs() < 1e-12 {
                return None;
            }
            for k in 0..n {
                a.swap(c * n + k, p * n + k);
            }
            y.swap(c, p);
            for i in c + 1..n {
                let f = a[i * n + c] / a[c * n + c];
                for k in c..n {
                    a[i * n + k] -= f * a[c * n + k];
                }
                y[i] -= f * y[c];
            }
        }
        for c in (0..n).rev() {
            let s: f64 = (c + 1..n).map(|k| a[c * n + k] * y[k]).sum();
            y[c] = (y[c] - s) / a[c * n + c];
        }
        Some(y)
    }

    /// The KKT point by enumeration of the active sets: for each subset, solve
    /// [M Bᵀ Eᵀ; B 0 0; E 0 0] and keep the one that is feasible with ν ≥ 0.
    fn brute_force(
        n: usize,
        m: &[f64],
        b: &[f64],
        rows: &[(Vec<f64>, f64)],
        bounded: &[usize],
    ) -> Option<Vec<f64>> {
        for mask in 0..1usize << bounded.len() {
            let act: Vec<usize> = (0..bounded.len())
                .filter(|k| mask >> k & 1 == 1)
                .map(|k| bounded[k])
                .collect();
            let dim = n + rows.len() + act.len();
            let mut a = vec![0.0; dim * dim];
            let mut y = vec![0.0; dim];
            for i in 0..n {
                for j in 0..n {
                    a[i * dim + j] = m[i * n + j];
                }
                y[i] = b[i];
            }
            for (k, (r, d)) in rows.iter().enumerate() {
                for i in 0..n {
                    a[(n + k) * dim + i] = r[i];
                    a[i * dim + n + k] = r[i];
                }
                y[n + k] = *d;
            }
            for (k, &i) in act.iter().enumerate() {
                let c = n + rows.len() + k;
                a[c * dim + i] = 1.0;
                a[i * dim + c] = 1.0;
            }
            let Some(sol) = gauss(dim, a, y) else {
                continue;
            };
            let feasible = bounded.iter().all(|&i| sol[i] <= 1e-12);
            let signs = (0..act.len()).all(|k| sol[n + rows.len() + k] >= -1e-12);
            if feasible && signs {
                return Some(sol[..n].to_vec());
            }
        }
        None
    }

    #[test]
    fn random_problems_match_enumeration_of_active_sets() {
        let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
        let mut compared = 0;
        for case in 0..400 {
            let n = 2 + case % 7;
            let nb = 1 + (case / 7) % 4.min(n);
            let nb = nb.min(n);
            let nr = (case / 3) % (n - nb + 1).min(4);
            // M = AᵀA + 0.1 I, rows random, b random; bounds on a random subset.
            let a: Vec<f64> = (0..n * n).map(|_| rng.next()).collect();
            let mut m = vec![0.0; n * n];
            for i in 0..n {
                for j in 0..n {
                    m[i * n + j] = (0..n).map(|k| a[k * n + i] * a[k * n + j]).sum::<f64>()
                        + if i == j { 0.1 } else { 0.0 };
                }
            }
            let b: Vec<f64> = (0..n).map(|_| 3.0 * rng.next()).collect();
            let rows: Vec<(Vec<f64>, f64)> = (0..nr)
                .map(|_| ((0..n).map(|_| rng.next()).collect(), rng.next()))
                .collect();
            let mut idx: Vec<usize> = (0..n).collect();
            for i in (1..n).rev() {
                let j = ((rng.next() + 1.0) * 0.5 * (i + 1) as f64) as usize;
                idx.swap(i, j.min(i));
            }
            let bounded = &idx[..nb];
            let Some(want) = brute_force(n, &m, &b, &rows, bounded) else {
                continue;
            };
            let res = run(n, &m, &b, &rows, bounded);
            assert!(res.settled && res.feasible, "case {case}: {res:?}");
            let err = res
                .x
                .iter()
                .zip(&want)
                .fold(0.0f64, |e, (x, w)| e.max((x - w).abs()));
            let scale = want.iter().fold(1.0f64, |e, w| e.max(w.abs()));
            assert!(err <= 1e-10 * scale, "case {case}: {:?} vs {want:?}", res.x);
            compared += 1;
        }
        assert!(compared > 300, "{compared}");
    }

    /// The former primal–dual active set (Newton-min) on x ≤ 0 without rows: x_A = 0,
    /// M_FF x_F = b_F, ν_A = b_A − (Mx)_A, next A = {i : ν_i + M_ii x_i > 0}. Whether it
    /// settles within `cap` changes.
    fn primal_dual_settles(n: usize, m: &[f64], b: &[f64], cap: usize) -> bool {
        let mut active = vec![false; n];
        for _ in 0..cap {
            let free: Vec<usize> = (0..n).filter(|&i| !active[i]).collect();
            let nf = free.len();
            let a: Vec<f64> = (0..nf * nf)
                .map(|ij| m[free[ij / nf] * n + free[ij % nf]])
                .collect();
            let Some(xf) = gauss(nf, a, free.iter().map(|&i| b[i]).collect()) else {
                return false;
            };
            let mut x = vec![0.0; n];
            for (k, &i) in free.iter().enumerate() {
                x[i] = xf[k];
            }
            let next: Vec<bool> = (0..n)
                .map(|i| {
                    let mx: f64 = (0..n).map(|j| m[i * n + j] * x[j]).sum();
                    let nu = if active[i] { b[i] - mx } else { 0.0 };
                    nu + m[i * n + i] * x[i] > 0.0
                })
                .collect();
            if next == active {
                return true;
            }
            active = next;
        }
        false
    }

    #[test]
    fn cycling_prone_instance_settles() {
        // Bound-only problems with strongly coupled M (AᵀA + 0.01 I, n = 3..5) on which the
        // former primal–dual active set (Newton-min, which cycles on such P-matrices; Ben
        // Gharbia–Gilbert 2012) does not settle within 50 changes: the dual method settles on
        // the enumerated KKT point.
        let mut rng = Rng(0x2545_f491_4f6c_dd1d);
        let mut cycling = 0;
        for _ in 0..20000 {
            let n = 3 + (rng.next().abs() * 3.0) as usize;
            let a: Vec<f64> = (0..n * n).map(|_| rng.next()).collect();
            let mut m = vec![0.0; n * n];
            for i in 0..n {
                for j in 0..n {
                    m[i * n + j] = (0..n).map(|k| a[k * n + i] * a[k * n + j]).sum::<f64>()
                        + if i == j { 0.01 } else { 0.0 };
                }
            }
            let b: Vec<f64> = (0..n).map(|_| rng.next()).collect();
            if primal_dual_settles(n, &m, &b, 50) {
                continue;
            }
            cycling += 1;
            let bounded: Vec<usize> = (0..n).collect();
            let res = run(n, &m, &b, &[], &bounded);
            assert!(res.settled && res.feasible, "{n} {m:?} {b:?}: {res:?}");
            let want = brute_force(n, &m, &b, &[], &bounded).expect("an LCP with a P-matrix");
            let scale = want.iter().fold(1.0f64, |e, w| e.max(w.abs()));
            for (x, w) in res.x.iter().zip(&want) {
                assert!(
                    (x - w).abs() <= 1e-9 * scale,
                    "{m:?} {b:?}: {:?} vs {want:?}",
                    res.x
                );
            }
            if cycling >= 20 {
                break;
            }
        }
        assert!(
            cycling > 0,
            "no cycling instance of the former method found"
        );
    }
}
