//! One sparse Cholesky factorisation of K with the constrained unknowns C ordered last, and
//! what the active-set method needs from it: solves with K_FF and the Schur complement S.
//!
//! With the symmetric permutation P = [F in AMD order; C] (a minimum degree order of the
//! whole pattern, then the C unknowns moved to the end in the same relative order; of two
//! such orders, AMD of the quotient graph and AMD of the pattern itself, the one whose factor
//! has fewer entries),
//!
//! ```text
//! P K Pᵀ = [K_FF K_FC; K_CF K_CC] = L Lᵀ,   L = [L_FF 0; L_CF L_CC],
//! L_FF L_FFᵀ = K_FF,   L_CC L_CCᵀ = K_CC − K_CF K_FF⁻¹ K_FC = S.
//! ```
//!
//! The fill of L_FF is that of K_FF in the restricted AMD order, and the C rows of L only add
//! the |C| trailing rows, so the factor is not much larger than an unconstrained one. S is
//! formed explicitly as L_CC L_CCᵀ (|C|³/3 flops, |C|² doubles): |C| is the number of contact
//! unknowns, a few hundred to a few thousand, so S is at most tens of MiB and the dense
//! active-set steps cost little next to the sparse factorisation. (Forming S by |C| solves
//! with K_FF would cost |C| × 4 nnz(L) flops, e.g. 5·10¹¹ at 250k RT_1 cells; reading L_CC
//! from the factor costs nothing. Keeping S implicit would cost a sparse solve per product.)
//!
//! K_FF⁻¹ r_F uses the same factor: the forward solve L z = [r_F; 0] gives z_F = L_FF⁻¹ r_F
//! in its leading block; with z_C set to 0 the backward solve Lᵀ x = [z_F; 0] gives x_C = 0
//! and x_F = L_FF⁻ᵀ z_F = K_FF⁻¹ r_F.

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::matmul::matmul;
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::linalg::amd;
use faer::sparse::linalg::cholesky::supernodal::SupernodalLltRef;
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, SymbolicCholesky, SymbolicCholeskyRaw, SymmetricOrdering,
    factorize_symbolic_cholesky,
};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Accum, Conj, Mat, Par, Side};

use rayon::prelude::*;

use super::SymCsc;

/// The factor of P K Pᵀ (supernodal), with the permutation.
pub struct Factor {
    symbolic: SymbolicCholesky<usize>,
    values: Vec<f64>,
    /// fwd[new] = old: position `new` of the factor's order is unknown `old` of K.
    fwd: Vec<usize>,
    /// Free unknowns, the leading block.
    nf: usize,
    par: Par,
}

fn out_of_memory(what: &str) -> String {
    format!("out of memory for the {what}")
}

impl Factor {
    /// Orders K's unknowns (free first, `is_constrained` last), analyses and factorises once.
    /// Errors: K not numerically positive definite, out of memory.
    pub fn new(k: &SymCsc, is_constrained: &[bool]) -> Result<Factor, String> {
        let pattern = k.symbolic();
        // Two fill-reducing orders, analysed side by side; the one with the smaller factor is
        // kept (as CHOLMOD tries several orderings and keeps the best). AMD's fill on these
        // mesh graphs depends on its tie-breaking, i.e. on the numbering, by up to a third
        // either way (issue 13: 100k RT_1 cells, 74.9M factor entries for AMD of the
        // quotient graph against 56.3M for AMD of the whole pattern; 250k: 152M against
        // 203M), and the numeric factorisation, its memory and every solve scale with it.
        let (quotient, whole) = rayon::join(
            || analyse(k, compressed_amd(k)?, is_constrained),
            || analyse(k, whole_amd(k)?, is_constrained),
        );
        let (symbolic, fwd, nf) = match (quotient, whole) {
            (Ok(a), Ok(b)) => {
                if b.0.len_val() < a.0.len_val() {
                    b
                } else {
                    a
                }
            }
            (Ok(a), Err(_)) | (Err(_), Ok(a)) => a,
            (Err(e), Err(_)) => return Err(e),
        };
        let mut values = Vec::new();
        values
            .try_reserve_exact(symbolic.len_val())
            .map_err(|_| out_of_memory("Cholesky factor"))?;
        // Written in parallel: the time here is the page faults of fresh memory (≈ 600 MB at
        // 100k RT_1 cells: 0.30 s on one thread, 0.12 s on two), which the kernel serves
        // concurrently. The capacity is already there, so the collect does not reallocate.
        (0..symbolic.len_val())
            .into_par_iter()
            .map(|_| 0.0)
            .collect_into_vec(&mut values);
        let par = faer::get_global_parallelism();
        {
            let mut mem = MemBuffer::try_new(
                symbolic.factorize_numeric_llt_scratch::<f64>(par, Default::default()),
            )
            .map_err(|_| out_of_memory("Cholesky factorisation"))?;
            symbolic
                .factorize_numeric_llt(
                    &mut values,
                    SparseColMatRef::new(pattern, &k.values),
                    Side::Lower,
                    Default::default(),
                    par,
                    MemStack::new(&mut mem),
                    Default::default(),
                )
                .map_err(|e| {
                    format!(
                        "the reconstruction matrix is not positive definite ({e:?}): the field \
                         is not determined by the functional"
                    )
                })?;
        }
        Ok(Factor {
            symbolic,
            values,
            fwd,
            nf,
            par,
        })
    }

    /// The constrained unknowns in the factor's order: `y_p = x_{constrained()[p]}`, the order
    /// of the rows and columns of [`Factor::schur`].
    pub fn constrained(&self) -> Vec<usize> {
        self.fwd[self.nf..].to_vec()
    }

    fn supernodal(&self) -> Result<SupernodalLltRef<'_, usize, f64>, String> {
        match self.symbolic.raw() {
            SymbolicCholeskyRaw::Supernodal(s) => Ok(SupernodalLltRef::new(s, &self.values)),
            SymbolicCholeskyRaw::Simplicial(_) => {
                Err("internal: the Cholesky factor is not supernodal".into())
            }
        }
    }

    /// Forward and backward solve with L in the factor's order; with `free_only` the trailing
    /// (constrained) block of the intermediate is zeroed and of the input ignored, so that
    /// the result is K_FF⁻¹ r_F on F and 0 on C; otherwise K⁻¹ r.
    fn solve_permuted(&self, r: &[f64], free_only: bool) -> Result<Vec<f64>, String> {
        let n = self.fwd.len();
        let last = if free_only { self.nf } else { n };
        let sup = self.supernodal()?;
        let mut z = Mat::<f64>::zeros(n, 1);
        for (new, &old) in self.fwd.iter().enumerate().take(last) {
            z[(new, 0)] = r[old];
        }
        let par = self.par;
        let mut mem = MemBuffer::try_new(sup.symbolic().solve_in_place_scratch::<f64>(1, par))
            .map_err(|_| out_of_memory("solve"))?;
        let stack = MemStack::new(&mut mem);
        sup.l_solve_with_conj(Conj::No, z.as_mut(), par, stack);
        for new in last..n {
            z[(new, 0)] = 0.0;
        }
        sup.l_transpose_solve_with_conj(Conj::No, z.as_mut(), par, stack);
        let mut x = vec![0.0; n];
        for (new, &old) in self.fwd.iter().enumerate().take(last) {
            x[old] = z[(new, 0)];
        }
        Ok(x)
    }

    /// x_F = K_FF⁻¹ r_F, x_C = 0 (r_C is not read).
    pub fn solve_free(&self, r: &[f64]) -> Result<Vec<f64>, String> {
        self.solve_permuted(r, true)
    }

    /// x = K⁻¹ r.
    pub fn solve(&self, r: &[f64]) -> Result<Vec<f64>, String> {
        self.solve_permuted(r, false)
    }

    /// S = L_CC L_CCᵀ = K_CC − K_CF K_FF⁻¹ K_FC, dense |C| × |C|, rows and columns in the
    /// order of [`Factor::constrained`].
    pub fn schur(&self) -> Result<Mat<f64>, String> {
        let n = self.fwd.len();
        let m = n - self.nf;
        let mut lcc = Mat::<f64>::zeros(m, m);
        if m == 0 {
            return Ok(lcc);
        }
        let sup = self.supernodal()?;
        let sym = sup.symbolic();
        for s in 0..sym.n_supernodes() {
            let node = sup.supernode(s);
            let start = node.start();
            let val = node.val();
            let size = val.ncols();
            if start + size <= self.nf {
                continue;
            }
            for jj in 0..size {
                let j = start + jj;
                if j < self.nf {
                    continue;
                }
                let cj = j - self.nf;
                // The diagonal block is lower triangular (its upper part is not referenced);
                // the rows below it are the supernode's pattern, all > j ≥ nf.
                for r in jj..size {
                    lcc[(start + r - self.nf, cj)] = val[(r, jj)];
                }
                for (idx, &i) in node.pattern().iter().enumerate() {
                    lcc[(i - self.nf, cj)] = val[(size + idx, jj)];
                }
            }
        }
        let mut s = Mat::<f64>::zeros(m, m);
        matmul(
            s.as_mut(),
            Accum::Replace,
            lcc.as_ref(),
            lcc.transpose(),
            1.0,
            self.par,
        );
        Ok(s)
    }
}

/// The symbolic factorisation of K in the order `amd_fwd` with the constrained unknowns moved
/// last (same relative order): (symbolic factor, fwd with fwd[new] = old, number of free
/// unknowns).
fn analyse(
    k: &SymCsc,
    amd_fwd: Vec<usize>,
    is_constrained: &[bool],
) -> Result<(SymbolicCholesky<usize>, Vec<usize>, usize), String> {
    let n = k.n;
    let fwd: Vec<usize> = amd_fwd
        .iter()
        .copied()
        .filter(|&i| !is_constrained[i])
        .chain(amd_fwd.iter().copied().filter(|&i| is_constrained[i]))
        .collect();
    drop(amd_fwd);
    let nf = fwd.iter().filter(|&&i| !is_constrained[i]).count();
    let mut inv = vec![0usize; n];
    for (new, &old) in fwd.iter().enumerate() {
        inv[old] = new;
    }
    let perm = faer::perm::PermRef::new_checked(&fwd, &inv, n);
    // Supernodal always: the trailing block L_CC is then read from the last supernodes.
    let params = CholeskySymbolicParams {
        supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SUPERNODAL,
        ..Default::default()
    };
    let symbolic = factorize_symbolic_cholesky(
        k.symbolic(),
        Side::Lower,
        SymmetricOrdering::Custom(perm),
        params,
    )
    .map_err(|e| format!("symbolic Cholesky: {e:?}"))?;
    drop(inv);
    Ok((symbolic, fwd, nf))
}

/// AMD of K's whole pattern: `order[position] = unknown`.
fn whole_amd(k: &SymCsc) -> Result<Vec<usize>, String> {
    amd_order(k.symbolic())
}

/// faer's AMD of a symmetric `pattern` (either triangle or both): `order[position] = unknown`.
fn amd_order(pattern: SymbolicSparseColMatRef<'_, usize>) -> Result<Vec<usize>, String> {
    let n = pattern.ncols();
    let mut order = vec![0usize; n];
    let mut order_inv = vec![0usize; n];
    let mut mem = MemBuffer::try_new(amd::order_maybe_unsorted_scratch::<usize>(
        n,
        pattern.row_idx().len(),
    ))
    .map_err(|_| out_of_memory("fill-reducing ordering"))?;
    amd::order_maybe_unsorted(
        &mut order,
        &mut order_inv,
        pattern,
        Default::default(),
        MemStack::new(&mut mem),
    )
    .map_err(|e| format!("fill-reducing ordering: {e:?}"))?;
    Ok(order)
}

/// A fill-reducing order of K's pattern: AMD on the quotient graph of its indistinguishable
/// unknowns, expanded. Unknowns whose closed adjacency sets (neighbours and themselves) are
/// equal — here both rows' unknowns of an edge slot, the slots of an edge, the interior
/// unknowns of a cell — are eliminated together by minimum degree anyway; merging them first
/// gives AMD a graph several times smaller (issue 13: 0.39 s against 0.75 s for [`whole_amd`]
/// at 250k RT_1 cells). [`Factor::new`] runs both and keeps the smaller factor: their
/// tie-breaking differs, and each wins on one of the benchmark meshes. Sets are compared by a 64-bit hash of their members with their size; a
/// collision would only merge two unknowns in the order, never change the factorisation's
/// result, since any permutation gives the same solution.
fn compressed_amd(k: &SymCsc) -> Result<Vec<usize>, String> {
    let n = k.n;
    // splitmix64: independent-looking 64-bit values of the indices, summed per set.
    let mix = |i: usize| -> u64 {
        let mut z = (i as u64).wrapping_add(0x9E37_79B9_7F4A_7C15);
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    };
    let mut hash = vec![0u64; n];
    let mut degree = vec![0usize; n];
    for i in 0..n {
        hash[i] = mix(i);
        degree[i] = 1;
    }
    k.for_each(|i, j, _| {
        if i != j {
            hash[i] = hash[i].wrapping_add(mix(j));
            hash[j] = hash[j].wrapping_add(mix(i));
            degree[i] += 1;
            degree[j] += 1;
        }
    });
    // Supervariable of each unknown, numbered by first appearance; its first unknown.
    let mut id = std::collections::HashMap::with_capacity(n);
    let mut sv = vec![0usize; n];
    let mut first = Vec::new();
    for i in 0..n {
        let next = first.len();
        let s = *id.entry((hash[i], degree[i])).or_insert(next);
        if s == next {
            first.push(i);
        }
        sv[i] = s;
    }
    drop((id, hash, degree));
    let ns = first.len();
    // The quotient pattern from the first unknowns' lower columns: every edge of the quotient
    // graph appears there in at least one direction, which is all AMD (of A + Aᵀ) needs.
    let mut col_ptr = Vec::with_capacity(ns + 1);
    col_ptr.push(0usize);
    let mut row_idx = Vec::new();
    let mut mark = vec![usize::MAX; ns];
    for (s, &r) in first.iter().enumerate() {
        let begin = row_idx.len();
        row_idx.push(s);
        mark[s] = s;
        for &i in &k.row_idx[k.col_ptr[r]..k.col_ptr[r + 1]] {
            let t = sv[i];
            if mark[t] != s {
                mark[t] = s;
                row_idx.push(t);
            }
        }
        row_idx[begin..].sort_unstable();
        col_ptr.push(row_idx.len());
    }
    drop(mark);
    let order = amd_order(SymbolicSparseColMatRef::new_checked(
        ns, ns, &col_ptr, None, &row_idx,
    ))?;
    drop((col_ptr, row_idx));
    Ok(expand(&order, &sv, ns))
}

/// The unknowns in the order of their supervariables: `order[p]` is a supervariable, `sv[i]`
/// that of unknown i; members of one supervariable consecutively.
fn expand(order: &[usize], sv: &[usize], ns: usize) -> Vec<usize> {
    let n = sv.len();
    let mut start = vec![0usize; ns + 1];
    for &s in sv {
        start[s + 1] += 1;
    }
    for s in 0..ns {
        start[s + 1] += start[s];
    }
    let mut members = vec![0usize; n];
    let mut fill = start.clone();
    for (i, &s) in sv.iter().enumerate() {
        members[fill[s]] = i;
        fill[s] += 1;
    }
    order
        .iter()
        .flat_map(|&s| members[start[s]..start[s + 1]].iter().copied())
        .collect()
}
