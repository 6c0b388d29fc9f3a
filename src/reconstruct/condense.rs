//! Reference-cell data of the vertex-patch problems (docs/design.md §5.10, "static
//! condensation"): what every cell of a patch shares, computed once per RT order.
//!
//! **Divergence moments.** With the contravariant Piola map φ = Jφ̂/det J, div φ = div̂ φ̂/det J
//! on straight and curved cells alike, so the patch rows (div τ_r, q)_T for q ∈ P_k(T̂) ∘ F_T⁻¹
//! have the same matrix on every cell,
//!
//! ```text
//! D_qi = ∫_T̂ div̂ φ̂_i q̂_q        (q̂ = 1, ξ, η, ξ², ξη, η²),
//! ```
//!
//! split into the edge columns D_E and the interior (bubble) columns D_I.
//!
//! **Static condensation.** The interior RT_k functions have no normal flux, so div̂ maps them
//! onto the mean-free part of P_k (RT_1: 2 bubbles onto a 2-dimensional space; RT_2: 6 bubbles
//! onto 5 dimensions, with the 1-dimensional kernel spanned by the curl of the cubic bubble).
//! With D_I = U S Vᵀ (numerical rank ρ), every (c_E, c_I) satisfying the part of D c = g in the
//! range of D_I is
//!
//! ```text
//! c_I = D_I⁺ (g − D_E c_E) + Z z,       Z = kernel of D_I (columns of V past ρ),
//! ```
//!
//! and the rows left are U₀ᵀ(D_E c_E − g) = 0 with U₀ the left kernel (the moment against
//! q̂ = 1: the flux balance of the cell). So each cell and row keeps its 3(k+1) edge values and
//! dim ker D_I free interior values, c = T y + t₀ with y = (c_E, z),
//!
//! ```text
//! T = [ I        0 ]        t₀ = [ 0        ]
//!     [ −D_I⁺D_E  Z ],            [ D_I⁺ g   ],
//! ```
//!
//! and one or two constraint rows instead of (k+1)(k+2)/2. The patch QP shrinks from ~110 to
//! ~50 unknowns on interior P2 patches (and the rows from ~80 to ~20), the same minimiser.
//!
//! **Affine compliance matrix.** For the compliance A and row-wise τ = e_r ⊗ φ_i,
//! `(Aτ_ri, τ_r'j)_T = Σ_{s,s'} A_(rs),(r's') ∫_T φ_i[s] φ_j[s']`, and on an affine cell
//!
//! ```text
//! ∫_T φ_i[s] φ_j[s'] = (1/det J) Σ_{a,b} J_sa J_s'b G^{ab}_ij,      G^{ab}_ij = ∫_T̂ φ̂_i[a] φ̂_j[b],
//! ```
//!
//! no quadrature per cell.
//!
//! **Weak-symmetry row.** ∫_T φ_i = ∫_T̂ J(ξ) φ̂_i dξ exactly, and on straight and 6-node cells
//! J is linear in ξ, J = J₀ + ξ J_ξ + η J_η, so ∫_T φ_i = J₀ ∫φ̂_i + J_ξ ∫ξφ̂_i + J_η ∫ηφ̂_i
//! ([`mean_value`]). It must be exact: Σ_T ∫_T as τ is tied to the rotation moments of the
//! divergence rows, and a row computed on a slightly different map (a 6-node cell within the
//! tolerance of straight) breaks that dependence and blows the patch problem up.

use std::sync::OnceLock;

use faer::Mat;

use crate::element::rt::{self, MAX_RT_DOFS, RtOrder};
use crate::geometry::map::Jacobian;
use crate::material::Elastic;
use crate::quadrature::triangle_rule;
use crate::tolerance::{ASYMMETRY_WEIGHT, CONDENSATION_RANK};

/// Largest number of edge DOFs per row of a cell (RT_2: 3 × 3), of reduced unknowns per row
/// (RT_2: 9 edge values + 1 kernel value) and of test moments per row (P_2: 6).
pub const MAX_EDGE_DOFS: usize = 9;
pub const MAX_REDUCED: usize = MAX_EDGE_DOFS + 1;
pub const MAX_MOMENTS: usize = 6;

/// Test monomials q̂ of degree ≤ 2 (the first (k+1)(k+2)/2 are used).
#[inline]
pub fn test_monomials(xi: [f64; 2]) -> [f64; MAX_MOMENTS] {
    [
        1.0,
        xi[0],
        xi[1],
        xi[0] * xi[0],
        xi[0] * xi[1],
        xi[1] * xi[1],
    ]
}

/// The shared data of one RT order (module doc). Matrices are dense row-major.
pub struct Reference {
    /// Local DOFs per row, edge DOFs (3(k+1)), interior DOFs, test moments (k+1)(k+2)/2.
    pub nloc: usize,
    pub nedge: usize,
    pub nint: usize,
    pub nq: usize,
    /// Kernel dimension of D_I (free interior values per cell and row) and left-kernel
    /// dimension (constraint rows kept per cell and row).
    pub nz: usize,
    pub n0: usize,
    /// Reduced unknowns per row: nedge + nz.
    pub nred: usize,
    /// D (nq × nloc).
    pub div: Vec<f64>,
    /// D_I⁺ (nint × nq).
    pub pinv: Vec<f64>,
    /// T (nloc × nred).
    pub transform: Vec<f64>,
    /// U₀ᵀ D T (n0 × nred) and U₀ᵀ (n0 × nq): the rows kept.
    pub kept: Vec<f64>,
    pub left: Vec<f64>,
    /// G^{ab} (index 2a + b), nloc × nloc each.
    pub gram: [Vec<f64>; 4],
    /// Tᵀ G^{ab} (nred × nloc) and Tᵀ G^{ab} T (nred × nred): the reduced Gram matrices of
    /// [`affine_reduced_form`].
    pub gram_left: [Vec<f64>; 4],
    pub gram_red: [Vec<f64>; 4],
    /// ∫_T̂ q̂_m φ̂_i for q̂ = 1, ξ, η (indexed `[i][m]`).
    pub first: Vec<[[f64; 2]; 3]>,
}

/// The cached [`Reference`] of `order` (k ≥ 1).
pub fn reference(order: RtOrder) -> &'static Reference {
    static CACHE: [OnceLock<Reference>; 3] = [const { OnceLock::new() }; 3];
    CACHE[order.k()].get_or_init(|| build(order))
}

fn build(order: RtOrder) -> Reference {
    let k = order.k();
    let nloc = order.dofs();
    let nedge = 3 * order.edge_dofs();
    let nint = order.interior_dofs();
    let nq = (k + 1) * (k + 2) / 2;
    // Exact for the products of two RT_k functions (degree 2k + 2).
    let rule = triangle_rule(2 * k + 2);
    let mut div = vec![0.0; nq * nloc];
    let mut gram: [Vec<f64>; 4] = std::array::from_fn(|_| vec![0.0; nloc * nloc]);
    let mut first = vec![[[0.0; 2]; 3]; nloc];
    for (&xi, &w) in rule.points.iter().zip(&rule.weights) {
        let (v, d) = rt::reference(order, xi);
        let q = test_monomials(xi);
        for i in 0..nloc {
            for (qq, &qv) in q.iter().enumerate().take(nq) {
                div[qq * nloc + i] += w * d[i] * qv;
            }
            for (m, fm) in first[i].iter_mut().enumerate() {
                fm[0] += w * q[m] * v[i][0];
                fm[1] += w * q[m] * v[i][1];
            }
            for j in 0..nloc {
                for a in 0..2 {
                    for b in 0..2 {
                        gram[2 * a + b][i * nloc + j] += w * v[i][a] * v[j][b];
                    }
                }
            }
        }
    }
    // D_I = U S Vᵀ.
    let di = Mat::<f64>::from_fn(nq, nint, |q, i| div[q * nloc + nedge + i]);
    let svd = di
        .svd()
        .expect("the SVD of a fixed reference matrix converges");
    let (u, s, v) = (svd.U(), svd.S().column_vector(), svd.V());
    let smax = if s.nrows() > 0 { s[0] } else { 0.0 };
    let rank = (0..s.nrows())
        .filter(|&j| s[j] > CONDENSATION_RANK * smax)
        .count();
    let nz = nint - rank;
    let n0 = nq - rank;
    let mut pinv = vec![0.0; nint * nq];
    for j in 0..rank {
        for i in 0..nint {
            for q in 0..nq {
                pinv[i * nq + q] += v[(i, j)] * u[(q, j)] / s[j];
            }
        }
    }
    let nred = nedge + nz;
    let mut transform = vec![0.0; nloc * nred];
    for e in 0..nedge {
        transform[e * nred + e] = 1.0;
    }
    for i in 0..nint {
        for e in 0..nedge {
            let pd: f64 = (0..nq).map(|q| pinv[i * nq + q] * div[q * nloc + e]).sum();
            transform[(nedge + i) * nred + e] = -pd;
        }
        for m in 0..nz {
            transform[(nedge + i) * nred + nedge + m] = v[(i, rank + m)];
        }
    }
    let mut left = vec![0.0; n0 * nq];
    for m in 0..n0 {
        for q in 0..nq {
            left[m * nq + q] = u[(q, rank + m)];
        }
    }
    // The kernel columns of U₀ᵀ D T are U₀ᵀ D_I V₀ = 0 (V₀ spans ker D_I): exact zeros, not the
    // ~1e-14 the products leave. Round-off there made a corner patch whose only unknowns are
    // kernel values (a cell with two Neumann edges at the vertex) meet an inconsistent flux
    // balance by values ~1e14 instead of reporting it (design §5.10).
    let mut kept = vec![0.0; n0 * nred];
    for m in 0..n0 {
        for y in 0..nedge {
            kept[m * nred + y] = (0..nq)
                .map(|q| {
                    left[m * nq + q]
                        * (0..nloc)
                            .map(|c| div[q * nloc + c] * transform[c * nred + y])
                            .sum::<f64>()
                })
                .sum();
        }
    }
    let gram_left: [Vec<f64>; 4] = std::array::from_fn(|ab| {
        let mut out = vec![0.0; nred * nloc];
        for y in 0..nred {
            for j in 0..nloc {
                out[y * nloc + j] = (0..nloc)
                    .map(|c| transform[c * nred + y] * gram[ab][c * nloc + j])
                    .sum();
            }
        }
        out
    });
    let gram_red: [Vec<f64>; 4] = std::array::from_fn(|ab| {
        let mut out = vec![0.0; nred * nred];
        for y in 0..nred {
            for y2 in 0..nred {
                out[y * nred + y2] = (0..nloc)
                    .map(|j| gram_left[ab][y * nloc + j] * transform[j * nred + y2])
                    .sum();
            }
        }
        out
    });
    Reference {
        nloc,
        nedge,
        nint,
        nq,
        nz,
        n0,
        nred,
        div,
        pinv,
        transform,
        kept,
        left,
        gram,
        gram_left,
        gram_red,
        first,
    }
}

/// A weak-symmetry row in the reduced unknowns of both rows, g = srowᵀ T per row (`srow`: the
/// row over the local functions, row r at r·nloc). For the constant row (`constant`), the
/// kernel columns are set to exact zeros: a kernel value is the curl of the cubic bubble b in
/// one row, whose ∫_T as τ = ±∫_T ∂b vanishes as b = 0 on ∂T; the products leave ~1e-14 there,
/// which a patch whose only unknowns are kernel values met with values ~1e14 (design §5.10).
pub fn symmetry_row_reduced(re: &Reference, srow: &[f64], constant: bool, g: &mut [f64]) {
    // RT_2's sizes fixed at compile time (the loops unroll); same sums, same order.
    if (re.nloc, re.nred) == (15, 10) {
        symmetry_row_fixed::<15, 10>(re, srow, constant, g);
    } else {
        symmetry_row_any(re, srow, constant, g);
    }
}

/// [`symmetry_row_reduced`] for any sizes.
fn symmetry_row_any(re: &Reference, srow: &[f64], constant: bool, g: &mut [f64]) {
    let (nloc, nred, nedge) = (re.nloc, re.nred, re.nedge);
    g[..2 * nred].fill(0.0);
    for r in 0..2 {
        // Accumulated along T's rows (contiguous).
        let out = &mut g[r * nred..(r + 1) * nred];
        for c in 0..nloc {
            let sc = srow[r * nloc + c];
            if sc == 0.0 {
                continue;
            }
            let tc = &re.transform[c * nred..(c + 1) * nred];
            for (o, t) in out.iter_mut().zip(tc) {
                *o += sc * t;
            }
        }
        if constant {
            out[nedge..].fill(0.0);
        }
    }
}

/// [`symmetry_row_reduced`] with NLOC = nloc and NRED = nred fixed.
fn symmetry_row_fixed<const NLOC: usize, const NRED: usize>(
    re: &Reference,
    srow: &[f64],
    constant: bool,
    g: &mut [f64],
) {
    g[..2 * NRED].fill(0.0);
    for r in 0..2 {
        let out: &mut [f64; NRED] = (&mut g[r * NRED..(r + 1) * NRED])
            .try_into()
            .expect("NRED values");
        for c in 0..NLOC {
            let sc = srow[r * NLOC + c];
            if sc == 0.0 {
                continue;
            }
            // T's edge rows are unit rows (module doc): their other products are exact zeros,
            // which leave the sums as they are.
            if c < re.nedge {
                out[c] += sc;
                continue;
            }
            let tc: &[f64; NRED] = re.transform[c * NRED..(c + 1) * NRED]
                .try_into()
                .expect("NRED values");
            for (o, t) in out.iter_mut().zip(tc) {
                *o += sc * t;
            }
        }
        if constant {
            out[re.nedge..].fill(0.0);
        }
    }
}

/// ∫_T φ_i for the Jacobians `jac` at the reference vertices (0,0), (1,0), (0,1) of a cell
/// whose J is linear in ξ (straight or 6-node; module doc).
pub fn mean_value(re: &Reference, jac: [[[f64; 2]; 2]; 3], i: usize) -> [f64; 2] {
    let [m0, mx, my] = re.first[i];
    let mut out = [0.0; 2];
    for (s, o) in out.iter_mut().enumerate() {
        for a in 0..2 {
            let (j0, jx, jy) = (
                jac[0][s][a],
                jac[1][s][a] - jac[0][s][a],
                jac[2][s][a] - jac[0][s][a],
            );
            *o += j0 * m0[a] + jx * mx[a] + jy * my[a];
        }
    }
    out
}

/// A as a 4 × 4 matrix on (τ_xx, τ_xy, τ_yx, τ_yy).
pub fn compliance_matrix(el: &Elastic) -> [[f64; 4]; 4] {
    let mut a = [[0.0; 4]; 4];
    for q in 0..4 {
        let mut e = [0.0; 4];
        e[q] = 1.0;
        let col = el.compliance(e);
        for p in 0..4 {
            a[p][q] = col[p];
        }
    }
    a
}

/// The pointwise form of the patch and sweep objectives on (τ_xx, τ_xy, τ_yx, τ_yy): the
/// compliance A, plus w/(2μ)(τ_xy − τ_yx)² with w = [`ASYMMETRY_WEIGHT`] when the weak symmetry
/// is imposed (design §5.10: the bound pays for as σ_h through the symmetric correction, which
/// A alone does not see).
pub fn objective_form(el: &Elastic, weak_symmetry: bool) -> [[f64; 4]; 4] {
    let mut form = compliance_matrix(el);
    if weak_symmetry {
        let wk = ASYMMETRY_WEIGHT / (2.0 * el.mu);
        let asv = [0.0, 1.0, -1.0, 0.0];
        for p in 0..4 {
            for q in 0..4 {
                form[p][q] += wk * asv[p] * asv[q];
            }
        }
    }
    form
}

/// The coefficients C^{rr'}_{ab} = (1/det J) Σ_{s,s'} A_(rs),(r's') J_sa J_s'b of module doc's
/// affine compliance matrix: (Aτ_ri, τ_r'j)_T = Σ_ab C^{rr'}_ab G^{ab}_ij.
fn affine_coefficients(jac: &Jacobian, a: &[[f64; 4]; 4]) -> [[[f64; 4]; 2]; 2] {
    let jm = jac.matrix;
    let inv = 1.0 / jac.det;
    let mut out = [[[0.0; 4]; 2]; 2];
    for (r, row) in out.iter_mut().enumerate() {
        for (r2, c) in row.iter_mut().enumerate() {
            for s in 0..2 {
                for s2 in 0..2 {
                    let apq = a[2 * r + s][2 * r2 + s2];
                    if apq == 0.0 {
                        continue;
                    }
                    for ab in 0..4 {
                        c[ab] += apq * jm[s][ab / 2] * jm[s2][ab % 2] * inv;
                    }
                }
            }
        }
    }
    out
}

/// The condensed matrix Tᵀ M_a T (row-major (2·nred)², index r·nred + y) of an affine cell
/// and Tᵀ M_a c₀ (2·nred) for the local coefficients `c0` (index r·nloc + i), with
/// (M_a)_ij = ∫_T a τ_i : τ_j for the pointwise quadratic form `a` on (τ_xx, τ_xy, τ_yx, τ_yy)
/// (the compliance A, or [`objective_form`]), from the reduced Gram matrices: (TᵀM_aT)^{rr'} =
/// Σ_ab C^{rr'}_ab Tᵀ G^{ab} T (module doc, "affine compliance matrix"). With a = A the same
/// numbers as Tᵀ [`affine_mass`] T without the (2·nloc)² matrix.
///
/// The rows of `mred` whose bit is set in `skip` (bit r·nred + y) are set to zero instead: a
/// patch cell's reduced unknowns with a fixed value (the zero flux of its outer edge, 6 of 20
/// in an interior P2 cell) enter only through Tᵀ M_a c₀, so their rows are never read. The
/// other entries are the same numbers either way.
pub fn affine_reduced_form(
    re: &Reference,
    jac: &Jacobian,
    a: &[[f64; 4]; 4],
    c0: &[f64],
    skip: u32,
    mred: &mut [f64],
    tmc0: &mut [f64],
) {
    let coef = affine_coefficients(jac, a);
    // The sizes of RT_1 and RT_2 known at compile time: the loops unroll and vectorise (this
    // ran ~14k instructions per cell of a P2 patch with run-time sizes). Same sums, same order.
    match (re.nloc, re.nred) {
        (15, 10) => reduced_form_fixed::<15, 10>(re, &coef, c0, skip, mred, tmc0),
        (8, 6) => reduced_form_fixed::<8, 6>(re, &coef, c0, skip, mred, tmc0),
        _ => reduced_form_any(re, &coef, c0, skip, mred, tmc0),
    }
}

/// [`affine_reduced_form`] for any sizes.
fn reduced_form_any(
    re: &Reference,
    coef: &[[[f64; 4]; 2]; 2],
    c0: &[f64],
    skip: u32,
    mred: &mut [f64],
    tmc0: &mut [f64],
) {
    let (nloc, nred) = (re.nloc, re.nred);
    let nr = 2 * nred;
    // (Tᵀ G^{ab} c₀_r') per ab and r'.
    let mut gc = [[[0.0; MAX_REDUCED]; 2]; 4];
    for (ab, g) in gc.iter_mut().enumerate() {
        for (r2, out) in g.iter_mut().enumerate() {
            let c = &c0[r2 * nloc..(r2 + 1) * nloc];
            for (y, o) in out.iter_mut().enumerate().take(nred) {
                let row = &re.gram_left[ab][y * nloc..(y + 1) * nloc];
                *o = row.iter().zip(c).map(|(p, q)| p * q).sum();
            }
        }
    }
    for r in 0..2 {
        for y in 0..nred {
            let mut v = 0.0;
            for r2 in 0..2 {
                for ab in 0..4 {
                    v += coef[r][r2][ab] * gc[ab][r2][y];
                }
            }
            tmc0[r * nred + y] = v;
        }
        for r2 in 0..2 {
            let c = coef[r][r2];
            for y in 0..nred {
                let out = &mut mred[(r * nred + y) * nr + r2 * nred..][..nred];
                if skip >> (r * nred + y) & 1 == 1 {
                    out.iter_mut().for_each(|o| *o = 0.0);
                    continue;
                }
                let g = [
                    &re.gram_red[0][y * nred..(y + 1) * nred],
                    &re.gram_red[1][y * nred..(y + 1) * nred],
                    &re.gram_red[2][y * nred..(y + 1) * nred],
                    &re.gram_red[3][y * nred..(y + 1) * nred],
                ];
                for (y2, o) in out.iter_mut().enumerate() {
                    *o = c[0] * g[0][y2] + c[1] * g[1][y2] + c[2] * g[2][y2] + c[3] * g[3][y2];
                }
            }
        }
    }
}

/// [`reduced_form_any`] with NLOC = nloc and NRED = nred fixed.
// Index loops over (row, reduced unknown) mirror reduced_form_any's.
#[allow(clippy::needless_range_loop)]
fn reduced_form_fixed<const NLOC: usize, const NRED: usize>(
    re: &Reference,
    coef: &[[[f64; 4]; 2]; 2],
    c0: &[f64],
    skip: u32,
    mred: &mut [f64],
    tmc0: &mut [f64],
) {
    let nr = 2 * NRED;
    fn fixed<const N: usize>(v: &[f64]) -> &[f64; N] {
        v[..N].try_into().expect("N values")
    }
    // (Tᵀ G^{ab} c₀_r') per ab and r', summed as `Iterator::sum` does (from −0).
    let mut gc = [[[0.0; NRED]; 2]; 4];
    for (ab, g) in gc.iter_mut().enumerate() {
        for (r2, out) in g.iter_mut().enumerate() {
            let c = fixed::<NLOC>(&c0[r2 * NLOC..]);
            for (y, o) in out.iter_mut().enumerate() {
                let row = fixed::<NLOC>(&re.gram_left[ab][y * NLOC..]);
                let mut s = -0.0;
                for i in 0..NLOC {
                    s += row[i] * c[i];
                }
                *o = s;
            }
        }
    }
    for r in 0..2 {
        for y in 0..NRED {
            let mut v = 0.0;
            for r2 in 0..2 {
                for ab in 0..4 {
                    v += coef[r][r2][ab] * gc[ab][r2][y];
                }
            }
            tmc0[r * NRED + y] = v;
        }
        for r2 in 0..2 {
            let c = coef[r][r2];
            for y in 0..NRED {
                let out: &mut [f64; NRED] = (&mut mred[(r * NRED + y) * nr + r2 * NRED..][..NRED])
                    .try_into()
                    .expect("NRED values");
                if skip >> (r * NRED + y) & 1 == 1 {
                    *out = [0.0; NRED];
                    continue;
                }
                let g = [0, 1, 2, 3].map(|ab| fixed::<NRED>(&re.gram_red[ab][y * NRED..]));
                for y2 in 0..NRED {
                    out[y2] = c[0] * g[0][y2] + c[1] * g[1][y2] + c[2] * g[2][y2] + c[3] * g[3][y2];
                }
            }
        }
    }
}

/// The local compliance matrix (Aτ_a, τ_c)_T of an affine cell with Jacobian `jac`, full
/// (2·nloc)², local index a = r·nloc + i (module doc).
pub fn affine_mass(re: &Reference, jac: &Jacobian, el: &Elastic, out: &mut [f64]) {
    let nloc = re.nloc;
    let nl = 2 * nloc;
    let a = compliance_matrix(el);
    let jm = jac.matrix;
    let inv = 1.0 / jac.det;
    // W^{ss'}_ij = (1/det) Σ_ab J_sa J_s'b G^{ab}_ij.
    let mut w: [[f64; MAX_RT_DOFS * MAX_RT_DOFS]; 4] = [[0.0; MAX_RT_DOFS * MAX_RT_DOFS]; 4];
    for s in 0..2 {
        for s2 in 0..2 {
            let coef = [
                jm[s][0] * jm[s2][0] * inv,
                jm[s][0] * jm[s2][1] * inv,
                jm[s][1] * jm[s2][0] * inv,
                jm[s][1] * jm[s2][1] * inv,
            ];
            let ws = &mut w[2 * s + s2];
            for (ab, g) in re.gram.iter().enumerate() {
                let c = coef[ab];
                for (wij, gij) in ws.iter_mut().zip(g) {
                    *wij += c * gij;
                }
            }
        }
    }
    for r in 0..2 {
        for r2 in 0..2 {
            for i in 0..nloc {
                for j in 0..nloc {
                    let mut v = 0.0;
                    for s in 0..2 {
                        for s2 in 0..2 {
                            let apq = a[2 * r + s][2 * r2 + s2];
                            if apq != 0.0 {
                                v += apq * w[2 * s + s2][i * nloc + j];
                            }
                        }
                    }
                    out[(r * nloc + i) * nl + r2 * nloc + j] = v;
                }
            }
        }
    }
}

#[cfg(test)]
#[allow(clippy::needless_range_loop)]
mod tests {
    use super::*;
    use crate::geometry::map::LinearTriangle;

    fn elastic() -> Elastic {
        Elastic {
            mu: 80.0,
            lambda: 120.0,
        }
    }

    #[test]
    fn kernel_and_kept_rows_have_the_predicted_dimensions() {
        // RT_1: 2 bubbles onto the mean-free P_1 (dim 2): no kernel, one row kept.
        // RT_2: 6 bubbles onto the mean-free P_2 (dim 5): a kernel of 1, one row kept.
        let r1 = reference(RtOrder::Rt1);
        assert_eq!((r1.nz, r1.n0, r1.nred), (0, 1, 6));
        let r2 = reference(RtOrder::Rt2);
        assert_eq!((r2.nz, r2.n0, r2.nred), (1, 1, 10));
        // The kept row is the moment against 1 (the flux balance): U₀ = ±e₀.
        for re in [r1, r2] {
            assert!((re.left[0].abs() - 1.0).abs() < 1e-12);
            assert!(re.left[1..re.nq].iter().all(|v| v.abs() < 1e-12));
        }
    }

    #[test]
    fn condensed_coefficients_meet_the_eliminated_rows() {
        // D(Ty + t₀) = Π_left D_E c_E + Π_range g (module doc): equal to g exactly when the
        // kept rows hold, U₀ᵀg = U₀ᵀ D T y. Random y and g, g's left-kernel part set so.
        for order in [RtOrder::Rt1, RtOrder::Rt2] {
            let re = reference(order);
            let y: Vec<f64> = (0..re.nred)
                .map(|i| (i as f64 * 0.37 + 0.1).sin())
                .collect();
            let mut g: Vec<f64> = (0..re.nq).map(|q| (q as f64 * 1.3 - 0.4).cos()).collect();
            for m in 0..re.n0 {
                let u0 = &re.left[m * re.nq..(m + 1) * re.nq];
                let along: f64 = u0.iter().zip(&g).map(|(a, b)| a * b).sum();
                let want: f64 = (0..re.nred).map(|j| re.kept[m * re.nred + j] * y[j]).sum();
                for q in 0..re.nq {
                    g[q] += (want - along) * u0[q];
                }
            }
            let mut c = vec![0.0; re.nloc];
            for (ci, cv) in c.iter_mut().enumerate() {
                *cv = (0..re.nred)
                    .map(|j| re.transform[ci * re.nred + j] * y[j])
                    .sum();
            }
            for i in 0..re.nint {
                c[re.nedge + i] += (0..re.nq)
                    .map(|q| re.pinv[i * re.nq + q] * g[q])
                    .sum::<f64>();
            }
            for q in 0..re.nq {
                let dc: f64 = (0..re.nloc).map(|i| re.div[q * re.nloc + i] * c[i]).sum();
                assert!(
                    (dc - g[q]).abs() < 1e-12,
                    "{order:?} moment {q}: {dc} vs {}",
                    g[q]
                );
            }
        }
    }

    /// The fixed-size symmetry row is the run-time-size one, bit for bit.
    #[test]
    fn fixed_symmetry_row_is_the_general_one() {
        let re = reference(RtOrder::Rt2);
        let srow: Vec<f64> = (0..2 * re.nloc)
            .map(|i| {
                if i % 4 == 1 {
                    0.0
                } else {
                    ((i * 5 + 2) % 9) as f64 / 3.0 - 1.1
                }
            })
            .collect();
        for constant in [false, true] {
            let mut fast = vec![0.0; 2 * re.nred];
            symmetry_row_reduced(re, &srow, constant, &mut fast);
            let mut slow = vec![0.0; 2 * re.nred];
            symmetry_row_any(re, &srow, constant, &mut slow);
            assert!(
                fast.iter()
                    .zip(&slow)
                    .all(|(a, b)| a.to_bits() == b.to_bits())
            );
        }
    }

    /// The fixed-size reduced form is the run-time-size one, bit for bit, on both orders.
    #[test]
    fn fixed_reduced_form_is_the_general_one() {
        let map = LinearTriangle::new([[0.3, -0.2], [1.7, 0.4], [0.1, 1.1]]);
        let jac = map.jacobian();
        let form = objective_form(&elastic(), true);
        for order in [RtOrder::Rt1, RtOrder::Rt2] {
            let re = reference(order);
            let (nl, nr) = (2 * re.nloc, 2 * re.nred);
            assert!(
                matches!((re.nloc, re.nred), (15, 10) | (8, 6)),
                "a size without a fixed form"
            );
            let c0: Vec<f64> = (0..nl)
                .map(|i| ((i * 7 + 3) % 11) as f64 / 7.0 - 0.6)
                .collect();
            let coef = affine_coefficients(&jac, &form);
            let (mut m1, mut b1) = (vec![0.0; nr * nr], vec![0.0; nr]);
            let (mut m2, mut b2) = (vec![0.0; nr * nr], vec![0.0; nr]);
            affine_reduced_form(re, &jac, &form, &c0, 0, &mut m1, &mut b1);
            reduced_form_any(re, &coef, &c0, 0, &mut m2, &mut b2);
            assert!(m1.iter().zip(&m2).all(|(a, b)| a.to_bits() == b.to_bits()));
            assert!(b1.iter().zip(&b2).all(|(a, b)| a.to_bits() == b.to_bits()));
            // Skipped rows (here every third, as a patch cell's fixed edge values) are zero
            // and every other entry is the full form's, bit for bit, in both versions.
            let skip = (0..nr).filter(|a| a % 3 == 1).fold(0u32, |s, a| s | 1 << a);
            for fixed in [true, false] {
                let (mut m3, mut b3) = (vec![1.0; nr * nr], vec![0.0; nr]);
                if fixed {
                    affine_reduced_form(re, &jac, &form, &c0, skip, &mut m3, &mut b3);
                } else {
                    reduced_form_any(re, &coef, &c0, skip, &mut m3, &mut b3);
                }
                for (k, (a, b)) in m3.iter().zip(&m1).enumerate() {
                    let expected = if skip >> (k / nr) & 1 == 1 { 0.0 } else { *b };
                    assert_eq!(a.to_bits(), expected.to_bits(), "entry {k}, fixed {fixed}");
                }
                assert!(b3.iter().zip(&b1).all(|(a, b)| a.to_bits() == b.to_bits()));
            }
        }
    }

    #[test]
    fn affine_mass_matches_quadrature() {
        let x = [[0.3, -0.2], [1.7, 0.4], [0.1, 1.1]];
        let map = LinearTriangle::new(x);
        let el = elastic();
        for order in [RtOrder::Rt1, RtOrder::Rt2] {
            let re = reference(order);
            let nl = 2 * re.nloc;
            let jac = map.jacobian();
            let mut fast = vec![0.0; nl * nl];
            affine_mass(re, &jac, &el, &mut fast);
            let mut slow = vec![0.0; nl * nl];
            let rule = triangle_rule(2 * order.k() + 2);
            for (&xi, &wq) in rule.points.iter().zip(&rule.weights) {
                let (v, _) = rt::piola(order, &jac, xi);
                let tau = |a: usize| {
                    let (r, i) = (a / re.nloc, a % re.nloc);
                    let mut t = [0.0; 4];
                    t[2 * r] = v[i][0];
                    t[2 * r + 1] = v[i][1];
                    t
                };
                for a in 0..nl {
                    let at = el.compliance(tau(a));
                    for c in 0..nl {
                        let tc = tau(c);
                        slow[a * nl + c] +=
                            wq * jac.det * (0..4).map(|p| at[p] * tc[p]).sum::<f64>();
                    }
                }
            }
            let scale = slow.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            for (f, s) in fast.iter().zip(&slow) {
                assert!((f - s).abs() < 1e-12 * scale, "{order:?}: {f} vs {s}");
            }
            // The condensed form: Tᵀ M T and Tᵀ M c₀ against the products of the quadrature
            // matrix, for a random c₀.
            let (nloc, nred) = (re.nloc, re.nred);
            let nr = 2 * nred;
            let c0: Vec<f64> = (0..nl).map(|i| (i as f64 * 0.71 - 0.3).sin()).collect();
            let (mut mred, mut tmc0) = (vec![0.0; nr * nr], vec![0.0; nr]);
            affine_reduced_form(
                re,
                &jac,
                &compliance_matrix(&el),
                &c0,
                0,
                &mut mred,
                &mut tmc0,
            );
            let t = |a: usize, y: usize| {
                // T block-diagonal over the rows: local a = r·nloc + i, reduced y = r'·nred + j.
                if a / nloc == y / nred {
                    re.transform[(a % nloc) * nred + y % nred]
                } else {
                    0.0
                }
            };
            for y in 0..nr {
                let want: f64 = (0..nl)
                    .map(|a| t(a, y) * (0..nl).map(|c| slow[a * nl + c] * c0[c]).sum::<f64>())
                    .sum();
                assert!(
                    (tmc0[y] - want).abs() < 1e-11 * scale,
                    "{order:?} TᵀMc₀ {y}"
                );
                for y2 in 0..nr {
                    let want: f64 = (0..nl)
                        .map(|a| {
                            t(a, y) * (0..nl).map(|c| slow[a * nl + c] * t(c, y2)).sum::<f64>()
                        })
                        .sum();
                    let got = mred[y * nr + y2];
                    assert!(
                        (got - want).abs() < 1e-11 * scale,
                        "{order:?} TᵀMT {y} {y2}"
                    );
                }
            }
        }
    }
}
