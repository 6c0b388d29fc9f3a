//! An exactly symmetric correction of an equilibrated stress, cell by cell (docs/design.md
//! §5.11): the Korn-free way to the Prager–Synge bound.
//!
//! In 2D a divergence-free tensor field is the row-wise curl of a vector field φ,
//! `Curl φ = [[∂_y φ₀, −∂_x φ₀], [∂_y φ₁, −∂_x φ₁]]`, whose asymmetry is
//! `as(Curl φ) = (Curl φ)_xy − (Curl φ)_yx = −div φ`. On a straight triangle T with
//! ∫_T as τ = 0 we look for
//!
//! ```text
//! φ ∈ V_m(T) = { φ ∈ C⁰(T)², φ|_S ∈ P_m on each of the three triangles S of the Alfeld
//!                (barycentric) split of T, φ = 0 on ∂T }
//! with div φ = as τ exactly (as τ ∈ P_{m−1}(T) for τ ∈ RT_k, m = k + 2),
//! minimising ‖τ + Curl φ − Cε(v)‖_A.
//! ```
//!
//! Then τ* = τ + Curl φ is symmetric pointwise, div τ* = div τ, and τ* n = τ n on every edge
//! (Curl φ · n is the tangential derivative of φ, zero on ∂T), so the contact and traction
//! constraints of τ are kept and the sum over the cells stays in H(div). Solvability: div maps
//! V_m(T) onto the discontinuous P_{m−1} functions of the split with zero mean for m ≥ 2 (the
//! Scott–Vogelius pair on Alfeld splits, Arnold–Qin 1992; Guzmán–Neilan 2018); the rank is
//! checked numerically (once per degree on the reference split for straight cells, per cell for
//! curved ones), and a failure is reported, not hidden.
//!
//! Straight cells, [`correct_affine`]: the same space as the Piola image of the reference
//! split, so the divergence matrix, its SVD and the Gram matrices of the reference gradients
//! are computed once per degree; per cell only the field is evaluated (once per point of the
//! exact rule of degree 2m − 2) and a Cholesky solve of size n − rank done.
//!
//! Curved (isoparametric P2) cells, [`correct_curved`]: the contravariant Piola image
//! φ = J φ̂ / det J of φ̂ ∈ V_m(T̂) on the Alfeld split of the reference triangle keeps
//! continuity and φ = 0 on ∂T, with div φ = div̂ φ̂ / det J; the constraint becomes
//! div̂ φ̂ = (as τ ∘ F) det J, a polynomial of degree ≤ k + 2 for τ ∈ RT_k, so m = k + 3.
//!
//! The cost is one small dense problem per cell (20 unknowns for m = 3, 38 for m = 4): the
//! constraints are eliminated through the SVD of the divergence matrix (per cell on curved
//! cells, once per degree on straight ones), the remaining freedom (the divergence-free part,
//! which only lowers ‖τ* − Cε(v)‖_A) by a Cholesky solve.

use std::sync::OnceLock;

use faer::prelude::Solve;
use faer::{Mat, Side};

use crate::geometry::map::{Jacobian, QuadraticTriangle};
use crate::material::Elastic;
use crate::quadrature::triangle_rule_cached;
use crate::solve::dense::{cholesky, cholesky_solve};
use crate::tolerance::SYMMETRIC_RANK;

/// What the correction of one cell gives.
#[derive(Clone, Debug)]
pub struct Corrected {
    /// ‖C^{1/2}ε(v) − C^{−1/2} sym τ*‖²_T (the cell's Prager–Synge term squared).
    pub ps2: f64,
    /// ‖as τ*‖_T (round-off when the correction succeeded).
    pub asym_after: f64,
    /// ‖as τ‖_T before the correction.
    pub asym_before: f64,
    /// Numerical rank of the divergence matrix and its number of rows (full: rows − 1).
    pub rank: usize,
    pub rows: usize,
    /// φ at the split's free Lagrange nodes, node-major [φ₀, φ₁].
    pub phi: Vec<f64>,
}

/// The Alfeld split of a straight triangle and its P_m Lagrange space vanishing on ∂T.
struct Split {
    m: usize,
    /// Lattice points (a, b, c), a + b + c = m, of a sub-triangle (P_i, P_{i+1}, C).
    lattice: Vec<[usize; 3]>,
    /// Per sub-triangle, the free node of each lattice point (None on ∂T).
    node: [Vec<Option<usize>>; 3],
    nodes: usize,
    /// Per sub-triangle, the physical gradients of its barycentric coordinates.
    grad: [[[f64; 2]; 3]; 3],
    /// Per sub-triangle, twice its area.
    det: [f64; 3],
}

impl Split {
    fn new(v: [[f64; 2]; 3], m: usize) -> Split {
        let c = [
            (v[0][0] + v[1][0] + v[2][0]) / 3.0,
            (v[0][1] + v[1][1] + v[2][1]) / 3.0,
        ];
        let mut lattice = Vec::new();
        for a in (0..=m).rev() {
            for b in (0..=m - a).rev() {
                lattice.push([a, b, m - a - b]);
            }
        }
        let nint = (m.saturating_sub(1)) * (m.saturating_sub(2)) / 2;
        let mut node: [Vec<Option<usize>>; 3] = Default::default();
        let mut grad = [[[0.0; 2]; 3]; 3];
        let mut det = [0.0; 3];
        for i in 0..3 {
            let j = (i + 1) % 3;
            let mut interior = 0;
            node[i] = lattice
                .iter()
                .map(|&[a, b, cc]| {
                    if cc == 0 {
                        None
                    } else if cc == m {
                        Some(0)
                    } else if b == 0 {
                        Some(1 + i * (m - 1) + cc - 1)
                    } else if a == 0 {
                        Some(1 + j * (m - 1) + cc - 1)
                    } else {
                        interior += 1;
                        Some(1 + 3 * (m - 1) + i * nint + interior - 1)
                    }
                })
                .collect();
            let (x0, x1, x2) = (v[i], v[j], c);
            let d = (x1[0] - x0[0]) * (x2[1] - x0[1]) - (x2[0] - x0[0]) * (x1[1] - x0[1]);
            det[i] = d;
            grad[i] = [
                [(x1[1] - x2[1]) / d, (x2[0] - x1[0]) / d],
                [(x2[1] - x0[1]) / d, (x0[0] - x2[0]) / d],
                [(x0[1] - x1[1]) / d, (x1[0] - x0[0]) / d],
            ];
        }
        Split {
            m,
            lattice,
            node,
            nodes: 1 + 3 * (m - 1) + 3 * nint,
            grad,
            det,
        }
    }

    /// The parent's reference point (λ₁, λ₂ of T) of sub-triangle `i` at its barycentrics `l`.
    fn parent_xi(&self, i: usize, l: [f64; 3]) -> [f64; 2] {
        let mut lam = [l[2] / 3.0; 3];
        lam[i] += l[0];
        lam[(i + 1) % 3] += l[1];
        [lam[1], lam[2]]
    }

    /// Values and gradients (in the coordinates of the triangle the split was built on) of the
    /// Lagrange functions of sub-triangle `i` at barycentrics `l`, one per lattice point:
    /// φ_abc = p_a(l₀) p_b(l₁) p_c(l₂), p_n(s) = Π_{j<n} (ms − j)/(j + 1).
    fn basis(&self, i: usize, l: [f64; 3], val: &mut Vec<f64>, out: &mut Vec<[f64; 2]>) {
        let m = self.m;
        let p = |n: usize, s: f64| -> (f64, f64) {
            let mut val = 1.0;
            let mut der = 0.0;
            for j in 0..n {
                let f = (m as f64 * s - j as f64) / (j + 1) as f64;
                der = der * f + val * m as f64 / (j + 1) as f64;
                val *= f;
            }
            (val, der)
        };
        val.clear();
        out.clear();
        let g = &self.grad[i];
        for &[a, b, c] in &self.lattice {
            let (va, da) = p(a, l[0]);
            let (vb, db) = p(b, l[1]);
            let (vc, dc) = p(c, l[2]);
            let (d0, d1, d2) = (da * vb * vc, va * db * vc, va * vb * dc);
            val.push(va * vb * vc);
            out.push([
                d0 * g[0][0] + d1 * g[1][0] + d2 * g[2][0],
                d0 * g[0][1] + d1 * g[1][1] + d2 * g[2][1],
            ]);
        }
    }
}

/// Curl of the unknown (node, row r) with physical gradient `g` of its Lagrange function, as
/// a row-major tensor [xx, xy, yx, yy].
#[inline]
fn curl(r: usize, g: [f64; 2]) -> [f64; 4] {
    if r == 0 {
        [g[1], -g[0], 0.0, 0.0]
    } else {
        [0.0, 0.0, g[1], -g[0]]
    }
}

#[inline]
fn dot4(a: [f64; 4], b: [f64; 4]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3]
}

/// ‖C^{1/2}ε − C^{−1/2} sym s‖² density at a point, `ce` = Cε(v) (the bound's η_PS).
#[inline]
fn ps_density(el: &Elastic, s: [f64; 4], ce: [f64; 4]) -> f64 {
    let ss = 0.5 * (s[1] + s[2]);
    let d = [ce[0] - s[0], ce[1] - ss, ce[2] - ss, ce[3] - s[3]];
    dot4(el.compliance(d), d)
}

/// The correction of module doc on the straight triangle `verts` (counter-clockwise) with
/// polynomial degree `m` ≥ 2. `field(ξ)` gives τ and Cε(v) at the parent reference point ξ;
/// both must be polynomials of degree ≤ m − 1 (exact quadrature).
///
/// This is the direct assembly on the PHYSICAL split (a quadrature pass for M, B and the
/// data, an SVD of B per cell): the independent check of [`correct_affine`], which gives the
/// same result from cell-independent reference matrices and is what the bound uses.
#[cfg(test)]
pub fn correct(
    verts: [[f64; 2]; 3],
    m: usize,
    el: &Elastic,
    field: impl Fn([f64; 2]) -> ([f64; 4], [f64; 4]),
) -> Corrected {
    let split = Split::new(verts, m);
    let n = 2 * split.nodes;
    let nq = m * (m + 1) / 2;
    let rows = 3 * nq;
    let rule = triangle_rule_cached(2 * m);
    let mut mm = Mat::<f64>::zeros(n, n);
    let mut bv = vec![0.0; n];
    let mut bm = Mat::<f64>::zeros(rows, n);
    let mut d = vec![0.0; rows];
    let mut vals = Vec::with_capacity(split.lattice.len());
    let mut grads = Vec::with_capacity(split.lattice.len());
    let mut asym_before = 0.0;
    for i in 0..3 {
        for (&xi, &wq) in rule.points.iter().zip(&rule.weights) {
            let l = [1.0 - xi[0] - xi[1], xi[0], xi[1]];
            let w = wq * split.det[i];
            let (tau, ce) = field(split.parent_xi(i, l));
            let base = [
                tau[0] - ce[0],
                tau[1] - ce[1],
                tau[2] - ce[2],
                tau[3] - ce[3],
            ];
            let abase = el.compliance(base);
            let g = tau[1] - tau[2];
            asym_before += w * g * g;
            split.basis(i, l, &mut vals, &mut grads);
            // Test monomials l₁^p l₂^q, p + q ≤ m − 1, of the sub-triangle.
            let mut qv = Vec::with_capacity(nq);
            for p in 0..m {
                for q in 0..m - p {
                    qv.push(l[1].powi(p as i32) * l[2].powi(q as i32));
                }
            }
            for (&na, &ga) in split.node[i].iter().zip(&grads) {
                let Some(na) = na else { continue };
                for r in 0..2 {
                    let ia = 2 * na + r;
                    let ca = curl(r, ga);
                    let aca = el.compliance(ca);
                    bv[ia] -= w * dot4(abase, ca);
                    for (&nb, &gb) in split.node[i].iter().zip(&grads) {
                        let Some(nb) = nb else { continue };
                        for s in 0..2 {
                            mm[(ia, 2 * nb + s)] += w * dot4(aca, curl(s, gb));
                        }
                    }
                    // div φ = ∂_x φ₀ + ∂_y φ₁.
                    for (qi, &qq) in qv.iter().enumerate() {
                        bm[(i * nq + qi, ia)] += w * ga[r] * qq;
                    }
                }
            }
            for (qi, &qq) in qv.iter().enumerate() {
                d[i * nq + qi] += w * g * qq;
            }
        }
    }
    let (x, rank) = solve(&mm, &bv, &bm, &d);
    // Second pass: the corrected field's Prager–Synge density and asymmetry, pointwise.
    let (mut ps2, mut asym_after) = (0.0, 0.0);
    for i in 0..3 {
        for (&xi, &wq) in rule.points.iter().zip(&rule.weights) {
            let l = [1.0 - xi[0] - xi[1], xi[0], xi[1]];
            let w = wq * split.det[i];
            let (mut tau, ce) = field(split.parent_xi(i, l));
            split.basis(i, l, &mut vals, &mut grads);
            for (&na, &ga) in split.node[i].iter().zip(&grads) {
                let Some(na) = na else { continue };
                for r in 0..2 {
                    let c = curl(r, ga);
                    for (t, cv) in tau.iter_mut().zip(c) {
                        *t += x[2 * na + r] * cv;
                    }
                }
            }
            ps2 += w * ps_density(el, tau, ce);
            let a = tau[1] - tau[2];
            asym_after += w * a * a;
        }
    }
    Corrected {
        ps2,
        asym_after: asym_after.sqrt(),
        asym_before: asym_before.sqrt(),
        rank,
        rows,
        phi: x,
    }
}

/// Largest degree m served by [`correct_affine`] (RT_k stresses use m = k + 2 ≤ 4).
pub const MAX_AFFINE_DEGREE: usize = 8;

/// Quadrature degree of [`correct_affine`] on each reference sub-triangle: 2m − 2, exact for
/// every integrand (τ, Cε(v) and Curl φ are of degree ≤ m − 1 on each sub-triangle, the test
/// monomials of degree m − 1).
pub const fn affine_rule_degree(m: usize) -> usize {
    2 * m - 2
}

/// What [`correct_affine`] needs of the reference split for one degree m, built once
/// ([`affine_reference`]): nothing in it depends on the cell.
struct AffineReference {
    /// Free Lagrange nodes of the reference split; the unknowns are node-major [φ̂₀, φ̂₁].
    nodes: usize,
    /// Test monomials per sub-triangle, m(m + 1)/2.
    nq: usize,
    /// Rows of B̂ (3 nq) and its numerical rank (`SYMMETRIC_RANK`).
    rows: usize,
    rank: usize,
    /// B̂⁺ (n × rows, row-major): the pseudo-inverse through the numerical range.
    pinv: Vec<f64>,
    /// N̂ (n × nk, row-major, nk = n − rank): an orthonormal basis of the kernel of B̂.
    kernel: Vec<f64>,
    /// K^{stij} = N̂_sᵀ S^{ij} N̂_t (nk × nk each, index ((2s + t)2 + i)2 + j), with N̂_s the rows
    /// of N̂ of component s and S^{ij}_{ab} = ∫_T̂ ∂_i N_a ∂_j N_b dξ (the three sub-triangles).
    projected: Vec<f64>,
    /// Quadrature points: parent reference point ξ, reference weight (the sub-triangle's
    /// factor included, Σ = ½) and sub-triangle.
    points: Vec<([f64; 2], f64, usize)>,
    /// Per sub-triangle, its free nodes (the same number, `per_sub`, for the three).
    sub_nodes: [Vec<usize>; 3],
    per_sub: usize,
    /// Per point, ∇̂N of its sub-triangle's free nodes (order of `sub_nodes`), `per_sub` each.
    grads: Vec<[f64; 2]>,
    /// Per point, the test monomials l₁^p l₂^q (p + q ≤ m − 1) of its sub-triangle, `nq` each.
    tests: Vec<f64>,
}

/// The parent reference points at which [`correct_affine`] of degree `m` evaluates its field,
/// in the order of its point index (2 ≤ m ≤ [`MAX_AFFINE_DEGREE`]).
pub fn affine_points(m: usize) -> Vec<[f64; 2]> {
    affine_reference(m).points.iter().map(|p| p.0).collect()
}

/// The cached [`AffineReference`] of degree `m` (2 ≤ m ≤ [`MAX_AFFINE_DEGREE`]).
fn affine_reference(m: usize) -> &'static AffineReference {
    static CACHE: [OnceLock<AffineReference>; MAX_AFFINE_DEGREE + 1] =
        [const { OnceLock::new() }; MAX_AFFINE_DEGREE + 1];
    assert!(
        (2..=MAX_AFFINE_DEGREE).contains(&m),
        "symmetric correction: degree {m} outside 2..={MAX_AFFINE_DEGREE}"
    );
    CACHE[m].get_or_init(|| build_affine(m))
}

fn build_affine(m: usize) -> AffineReference {
    let split = Split::new([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]], m);
    let nodes = split.nodes;
    let n = 2 * nodes;
    let nq = m * (m + 1) / 2;
    let rows = 3 * nq;
    let rule = triangle_rule_cached(affine_rule_degree(m));
    let sub_nodes: [Vec<usize>; 3] =
        std::array::from_fn(|i| split.node[i].iter().flatten().copied().collect());
    let per_sub = sub_nodes[0].len();
    let mut gram: [Vec<f64>; 4] = std::array::from_fn(|_| vec![0.0; nodes * nodes]);
    let mut bm = Mat::<f64>::zeros(rows, n);
    let (mut points, mut grads, mut tests) = (Vec::new(), Vec::new(), Vec::new());
    let (mut vals, mut all) = (Vec::new(), Vec::new());
    for i in 0..3 {
        for (&xi, &wq) in rule.points.iter().zip(&rule.weights) {
            let l = [1.0 - xi[0] - xi[1], xi[0], xi[1]];
            let w = wq * split.det[i];
            split.basis(i, l, &mut vals, &mut all);
            let g: Vec<[f64; 2]> = split.node[i]
                .iter()
                .zip(&all)
                .filter_map(|(na, &g)| na.map(|_| g))
                .collect();
            let mut qv = Vec::with_capacity(nq);
            for p in 0..m {
                for q in 0..m - p {
                    qv.push(l[1].powi(p as i32) * l[2].powi(q as i32));
                }
            }
            for (&a, ga) in sub_nodes[i].iter().zip(&g) {
                for (&b, gb) in sub_nodes[i].iter().zip(&g) {
                    for (ij, s) in gram.iter_mut().enumerate() {
                        s[a * nodes + b] += w * ga[ij / 2] * gb[ij % 2];
                    }
                }
                // div̂ (N e_s) = ∂_s N.
                for r in 0..2 {
                    for (qi, &qq) in qv.iter().enumerate() {
                        bm[(i * nq + qi, 2 * a + r)] += w * ga[r] * qq;
                    }
                }
            }
            points.push((split.parent_xi(i, l), w, i));
            grads.extend_from_slice(&g);
            tests.extend_from_slice(&qv);
        }
    }
    let svd = bm.svd().expect("SVD of the reference divergence matrix");
    let (u, s, v) = (svd.U(), svd.S().column_vector(), svd.V());
    let smax = if s.nrows() > 0 { s[0] } else { 0.0 };
    let rank = (0..s.nrows())
        .filter(|&j| s[j] > SYMMETRIC_RANK * smax)
        .count();
    let mut pinv = vec![0.0; n * rows];
    for k in 0..n {
        for r in 0..rows {
            pinv[k * rows + r] = (0..rank).map(|j| v[(k, j)] * u[(r, j)] / s[j]).sum();
        }
    }
    let nk = n - rank;
    let kernel: Vec<f64> = (0..n * nk).map(|kj| v[(kj / nk, rank + kj % nk)]).collect();
    let mut projected = vec![0.0; 16 * nk * nk];
    for (idx, kk) in projected.chunks_mut((nk * nk).max(1)).enumerate() {
        let (st, ij) = (idx / 4, idx % 4);
        let (sc, tc) = (st / 2, st % 2);
        let sg = &gram[ij];
        for p in 0..nk {
            for q in 0..nk {
                let mut acc = 0.0;
                for a in 0..nodes {
                    let na = kernel[(2 * a + sc) * nk + p];
                    if na == 0.0 {
                        continue;
                    }
                    let row: f64 = (0..nodes)
                        .map(|b| sg[a * nodes + b] * kernel[(2 * b + tc) * nk + q])
                        .sum();
                    acc += na * row;
                }
                kk[p * nk + q] = acc;
            }
        }
    }
    AffineReference {
        nodes,
        nq,
        rows,
        rank,
        pinv,
        kernel,
        projected,
        points,
        sub_nodes,
        per_sub,
        grads,
        tests,
    }
}

/// The correction of the module doc on the straight triangle `verts` (counter-clockwise) with
/// polynomial degree `m` (2 ≤ m ≤ [`MAX_AFFINE_DEGREE`]), evaluated on the REFERENCE split
/// (docs/design.md §5.11). `field(ξ)` gives τ and Cε(v) at the parent reference point ξ; both
/// must be polynomials of degree ≤ m − 1 (exact quadrature, degree [`affine_rule_degree`]).
///
/// With the constant Jacobian J = [x₁ − x₀ | x₂ − x₀], D = det J > 0, the contravariant Piola
/// image φ = J φ̂ / D of φ̂ ∈ V_m(T̂) (Alfeld split of the reference triangle T̂) spans V_m(T):
/// the affine map sends the reference split onto the split of T. Then:
///
/// ```text
/// div φ = div̂ φ̂ / D            ⇒  constraint  B̂ x̂ = d̂,  d̂_(i,q) = ∫_{T̂_i} (as τ ∘ F) D q̂ dξ,
/// ∇φ = a gᵀ for φ̂ = N e_s,  a = J e_s / D,  g = J⁻ᵀ ∇̂N  ⇒  Curl φ = L_s ∇̂N,
/// L_s rows [xx, xy, yx, yy] = (a₀[−J₀₁, J₀₀], a₀[−J₁₁, J₁₀], a₁[−J₀₁, J₀₀], a₁[−J₁₁, J₁₀]) / D,
/// M_(a s),(b t) = D Σ_ij (L_sᵀ A L_t)_ij S^{ij}_ab,   S^{ij}_ab = ∫_T̂ ∂_i N_a ∂_j N_b dξ,
/// ```
///
/// with B̂ (the reference divergence matrix, tested with the monomials of each reference
/// sub-triangle) and S^{ij} the same for every cell: B̂'s SVD gives, once per m, its
/// pseudo-inverse B̂⁺ and an orthonormal kernel basis N̂ (`AffineReference`). Per cell,
/// x̂ = x_p + N̂ z with x_p = B̂⁺ d̂ and (N̂ᵀ M N̂) z = −N̂ᵀ ∫_T A(τ − Cε(v) + Curl φ_p) : Curl φ_·,
/// a Cholesky solve of size n − rank, where N̂ᵀ M N̂ = D Σ_{s,t,i,j} (L_sᵀ A L_t)_ij N̂_sᵀ S^{ij} N̂_t
/// comes from projected reference matrices (no quadrature for M). The field is evaluated
/// once per point; ps2 and ‖as τ*‖ are integrated pointwise from τ + Curl φ.
///
/// Same minimiser, hence the same result to round-off, as the physical-split assembly (kept
/// as `correct` for the tests): the constraint rows differ from the physical ones by the
/// factor D only. `phi` holds the physical φ = J x̂ / D at the free nodes, node-major.
///
/// `field(p, ξ)` gives (τ, Cε(v)) at ξ = [`affine_points`]`(m)[p]`; the index lets a caller
/// read tabulated basis values instead of evaluating them at ξ.
pub fn correct_affine(
    verts: [[f64; 2]; 3],
    m: usize,
    el: &Elastic,
    field: impl Fn(usize, [f64; 2]) -> ([f64; 4], [f64; 4]),
) -> Corrected {
    let re = affine_reference(m);
    let (nodes, nq, rows, rank, ps) = (re.nodes, re.nq, re.rows, re.rank, re.per_sub);
    let n = 2 * nodes;
    let nk = n - rank;
    let jm = [
        [verts[1][0] - verts[0][0], verts[2][0] - verts[0][0]],
        [verts[1][1] - verts[0][1], verts[2][1] - verts[0][1]],
    ];
    let det = jm[0][0] * jm[1][1] - jm[0][1] * jm[1][0];
    // L_s (4 × 2): Curl φ = L_s ∇̂N for φ̂ = N e_s.
    let mut lm = [[[0.0; 2]; 4]; 2];
    for (s, ls) in lm.iter_mut().enumerate() {
        for r in 0..2 {
            let a = jm[r][s] / (det * det);
            ls[2 * r] = [-a * jm[0][1], a * jm[0][0]];
            ls[2 * r + 1] = [-a * jm[1][1], a * jm[1][0]];
        }
    }
    let curl_of = |h: [[f64; 2]; 2]| -> [f64; 4] {
        std::array::from_fn(|c| {
            lm[0][c][0] * h[0][0]
                + lm[0][c][1] * h[0][1]
                + lm[1][c][0] * h[1][0]
                + lm[1][c][1] * h[1][1]
        })
    };
    // The values x_(a s) of each sub-triangle's nodes side by side (sub-triangle i at i·ps),
    // gathered once per pass into one buffer: `grad_sum` then reads two contiguous arrays (it
    // indexed x through the node list at each of the split rule's points, 17 % of the bound's
    // instructions).
    let mut xs = vec![[0.0; 2]; 3 * ps];
    let gather = |x: &[f64], xs: &mut [[f64; 2]]| {
        for (i, sub) in re.sub_nodes.iter().enumerate() {
            for (xa, &a) in xs[i * ps..(i + 1) * ps].iter_mut().zip(sub) {
                *xa = [x[2 * a], x[2 * a + 1]];
            }
        }
    };
    // h_s = Σ_a x_(a s) ∇̂N_a at point p (the same sums, in the order of the nodes).
    let grad_sum = |xs: &[[f64; 2]], p: usize| -> [[f64; 2]; 2] {
        let i = re.points[p].2;
        let mut h = [[0.0; 2]; 2];
        for (xa, g) in xs[i * ps..(i + 1) * ps]
            .iter()
            .zip(&re.grads[p * ps..(p + 1) * ps])
        {
            for (hs, &xas) in h.iter_mut().zip(xa) {
                hs[0] += xas * g[0];
                hs[1] += xas * g[1];
            }
        }
        h
    };
    // First pass: the field once per point, as τ's moments d̂ and ‖as τ‖.
    let np = re.points.len();
    let mut vals = Vec::with_capacity(np);
    let mut d = vec![0.0; rows];
    let mut asym_before = 0.0;
    for (p, &(xi, wr, i)) in re.points.iter().enumerate() {
        let (tau, ce) = field(p, xi);
        let w = wr * det;
        let g = tau[1] - tau[2];
        asym_before += w * g * g;
        for (dq, &qq) in d[i * nq..(i + 1) * nq]
            .iter_mut()
            .zip(&re.tests[p * nq..(p + 1) * nq])
        {
            *dq += w * g * qq;
        }
        vals.push((tau, ce));
    }
    // x_p = B̂⁺ d̂.
    let mut x: Vec<f64> = (0..n)
        .map(|k| {
            re.pinv[k * rows..(k + 1) * rows]
                .iter()
                .zip(&d)
                .map(|(a, b)| a * b)
                .sum()
        })
        .collect();
    if nk > 0 {
        // r = −∫ A(τ − Cε + Curl φ_p) : Curl φ_a (= b − M x_p, by exact quadrature).
        let mut r = vec![0.0; n];
        gather(&x, &mut xs);
        for (p, &(_, wr, i)) in re.points.iter().enumerate() {
            let (tau, ce) = vals[p];
            let cp = curl_of(grad_sum(&xs, p));
            let base: [f64; 4] = std::array::from_fn(|c| tau[c] - ce[c] + cp[c]);
            let ab = el.compliance(base);
            let w = wr * det;
            // v_s = L_sᵀ A base.
            let vs: [[f64; 2]; 2] = std::array::from_fn(|s| {
                std::array::from_fn(|e| (0..4).map(|c| lm[s][c][e] * ab[c]).sum::<f64>())
            });
            for (&a, g) in re.sub_nodes[i].iter().zip(&re.grads[p * ps..(p + 1) * ps]) {
                for (s, v) in vs.iter().enumerate() {
                    r[2 * a + s] -= w * (v[0] * g[0] + v[1] * g[1]);
                }
            }
        }
        // H = N̂ᵀ M N̂ = D Σ (L_sᵀ A L_t)_ij K^{stij}; rhs = N̂ᵀ r.
        let al: [[[f64; 4]; 2]; 2] = std::array::from_fn(|t| {
            std::array::from_fn(|j| el.compliance(std::array::from_fn(|c| lm[t][c][j])))
        });
        let mut h = vec![0.0; nk * nk];
        for (idx, kk) in re.projected.chunks(nk * nk).enumerate() {
            let (s, t, i, j) = (idx / 8, (idx / 4) % 2, (idx / 2) % 2, idx % 2);
            let c = det * (0..4).map(|c| lm[s][c][i] * al[t][j][c]).sum::<f64>();
            for (hv, kv) in h.iter_mut().zip(kk) {
                *hv += c * kv;
            }
        }
        let mut z: Vec<f64> = (0..nk)
            .map(|j| (0..n).map(|k| re.kernel[k * nk + j] * r[k]).sum())
            .collect();
        let set: Vec<usize> = (0..nk).collect();
        let mut lf = vec![0.0; nk * nk];
        if cholesky(nk, &h, &set, &mut lf) {
            cholesky_solve(nk, nk, &lf, &mut z);
            for (k, xk) in x.iter_mut().enumerate() {
                *xk += re.kernel[k * nk..(k + 1) * nk]
                    .iter()
                    .zip(&z)
                    .map(|(a, b)| a * b)
                    .sum::<f64>();
            }
        }
    }
    // Second pass: the corrected field's Prager–Synge density and asymmetry, pointwise.
    let (mut ps2, mut asym_after) = (0.0, 0.0);
    gather(&x, &mut xs);
    for (p, &(_, wr, _)) in re.points.iter().enumerate() {
        let (tau, ce) = vals[p];
        let cp = curl_of(grad_sum(&xs, p));
        let t: [f64; 4] = std::array::from_fn(|c| tau[c] + cp[c]);
        let w = wr * det;
        ps2 += w * ps_density(el, t, ce);
        let a = t[1] - t[2];
        asym_after += w * a * a;
    }
    let phi = (0..n)
        .map(|k| {
            let (a, r) = (k / 2, k % 2);
            (jm[r][0] * x[2 * a] + jm[r][1] * x[2 * a + 1]) / det
        })
        .collect();
    Corrected {
        ps2,
        asym_after: asym_after.sqrt(),
        asym_before: asym_before.sqrt(),
        rank,
        rows,
        phi,
    }
}

/// ‖C^{1/2}ε(v) − C^{−1/2} sym(τ + Curl φ)‖²_T for the correction φ = `phi` that
/// [`correct_affine`] of degree `m` gave on the straight triangle `verts`, integrated with the
/// rule of degree `degree` on each sub-triangle of the split. For a field whose τ or Cε(v) is
/// not a polynomial of degree ≤ m − 1 (u_h through a parent quadrilateral that is not a
/// parallelogram, design §6.3 "u_h itself"), where `correct_affine`'s own rule is exact for
/// Curl φ but not for the rest: φ stays the minimiser it found (any φ with div φ = as τ keeps
/// τ + Curl φ symmetric and equilibrated), and its term is integrated at the degree of the
/// rational cells' other integrals. `field(p, ξ)` gives τ and Cε(v) at the reference point ξ =
/// [`corrected_points`]`(m, degree)[p]`.
pub fn corrected_ps2(
    verts: [[f64; 2]; 3],
    m: usize,
    el: &Elastic,
    phi: &[f64],
    degree: usize,
    field: impl Fn(usize, [f64; 2]) -> ([f64; 4], [f64; 4]),
) -> f64 {
    let re = split_rule(m, degree);
    let jm = [
        [verts[1][0] - verts[0][0], verts[2][0] - verts[0][0]],
        [verts[1][1] - verts[0][1], verts[2][1] - verts[0][1]],
    ];
    let det = jm[0][0] * jm[1][1] - jm[0][1] * jm[1][0];
    let mut ps2 = 0.0;
    for (p, ((xi, wr), grads)) in re.points.iter().zip(&re.grads).enumerate() {
        let mut cp = [0.0; 4];
        for &(a, gr) in grads {
            // ∇N = J⁻ᵀ ∇̂N̂ (the physical split is the affine image of the reference one).
            let g = [
                (jm[1][1] * gr[0] - jm[1][0] * gr[1]) / det,
                (jm[0][0] * gr[1] - jm[0][1] * gr[0]) / det,
            ];
            for r in 0..2 {
                let c = curl(r, g);
                for (k, ck) in cp.iter_mut().enumerate() {
                    *ck += phi[2 * a + r] * c[k];
                }
            }
        }
        let (tau, ce) = field(p, *xi);
        let t: [f64; 4] = std::array::from_fn(|k| tau[k] + cp[k]);
        ps2 += wr * det * ps_density(el, t, ce);
    }
    ps2
}

/// The parent reference points at which [`corrected_ps2`] of (m, `degree`) evaluates its field,
/// in the order of its point index.
pub fn corrected_points(m: usize, degree: usize) -> Vec<[f64; 2]> {
    split_rule(m, degree).points.iter().map(|p| p.0).collect()
}

/// The points of the rule of degree `degree` on each sub-triangle of the reference split of
/// degree m, for [`corrected_ps2`]: parent ξ and reference weight (Σ = ½), and per point ∇̂ of
/// its sub-triangle's free Lagrange functions (node, gradient).
struct SplitRule {
    points: Vec<([f64; 2], f64)>,
    grads: Vec<Vec<(usize, [f64; 2])>>,
}

/// The cached [`SplitRule`] of (m, degree).
fn split_rule(m: usize, degree: usize) -> &'static SplitRule {
    type Cache = std::sync::Mutex<std::collections::HashMap<(usize, usize), &'static SplitRule>>;
    static CACHE: OnceLock<Cache> = OnceLock::new();
    let mut cache = CACHE
        .get_or_init(Default::default)
        .lock()
        .unwrap_or_else(|e| e.into_inner());
    cache.entry((m, degree)).or_insert_with(|| {
        let split = Split::new([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]], m);
        let rule = triangle_rule_cached(degree);
        let (mut vals, mut all) = (Vec::new(), Vec::new());
        let (mut points, mut grads) = (Vec::new(), Vec::new());
        for i in 0..3 {
            for (&xi, &wq) in rule.points.iter().zip(&rule.weights) {
                let l = [1.0 - xi[0] - xi[1], xi[0], xi[1]];
                split.basis(i, l, &mut vals, &mut all);
                grads.push(
                    split.node[i]
                        .iter()
                        .zip(&all)
                        .filter_map(|(na, &g)| na.map(|a| (a, g)))
                        .collect(),
                );
                points.push((split.parent_xi(i, l), wq * split.det[i]));
            }
        }
        Box::leak(Box::new(SplitRule { points, grads }))
    })
}

/// The correction on a curved (isoparametric P2) triangle with nodes `nodes` (VTK order,
/// counter-clockwise) and polynomial degree `m` ≥ 2, through the contravariant Piola map
/// φ = J φ̂ / det J of a φ̂ ∈ V_m(T̂) on the Alfeld split of the REFERENCE triangle.
///
/// φ is continuous, vanishes on ∂T, and div φ = div̂ φ̂ / det J, so div φ = as τ is
/// div̂ φ̂ = ĝ := (as τ ∘ F) det J, imposed exactly on each reference sub-triangle (tested with
/// P_{m−1} there, reference weights). For a row-wise RT_k stress τ_r = J τ̂_r / det J
/// ([`crate::element::rt::piola`]), ĝ = (J τ̂₀)_y − (J τ̂₁)_x is a polynomial of degree ≤ k + 2
/// (J has degree 1), so m = k + 3 makes the constraint exact. Curl φ in physical coordinates
/// is built from ∇_x φ = (∇_ξ (J φ̂ / det J)) J⁻¹, with the constant ∂J/∂ξ of the P2 map
/// ([`QuadraticTriangle::jacobian_derivatives`]).
///
/// The objective ‖τ + Curl φ − Cε(v)‖²_A, the second pass and ‖as τ‖ are integrated over the
/// physical cell with weights w det J on the reference sub-triangles; these integrands are
/// rational in ξ, so the rule has degree 2m + 6 (an approximation, not exact; the constraint
/// integrals, polynomial of degree 2m − 2, are exact). `field(ξ)` gives τ and Cε(v) at the
/// reference point ξ of the cell map. On a 6-node cell with straight edges this is the straight
/// correction of [`correct_affine`] with degree m (same space, since J is constant), up to
/// round-off.
pub fn correct_curved(
    nodes: [[f64; 2]; 6],
    m: usize,
    el: &Elastic,
    field: impl Fn([f64; 2]) -> ([f64; 4], [f64; 4]),
) -> Corrected {
    let map = QuadraticTriangle::new(nodes);
    let dj = map.jacobian_derivatives();
    let split = Split::new([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]], m);
    let n = 2 * split.nodes;
    let nq = m * (m + 1) / 2;
    let rows = 3 * nq;
    let rule = triangle_rule_cached(curved_rule_degree(m));
    let mut mm = Mat::<f64>::zeros(n, n);
    let mut bv = vec![0.0; n];
    let mut bm = Mat::<f64>::zeros(rows, n);
    let mut d = vec![0.0; rows];
    let mut vals = Vec::with_capacity(split.lattice.len());
    let mut grads = Vec::with_capacity(split.lattice.len());
    let mut curls = Vec::with_capacity(split.lattice.len());
    let mut asym_before = 0.0;
    for i in 0..3 {
        for (&xi, &wq) in rule.points.iter().zip(&rule.weights) {
            let l = [1.0 - xi[0] - xi[1], xi[0], xi[1]];
            let xp = split.parent_xi(i, l);
            let jac = map.jacobian(xp);
            let wr = wq * split.det[i];
            let w = wr * jac.det;
            let (tau, ce) = field(xp);
            let base = [
                tau[0] - ce[0],
                tau[1] - ce[1],
                tau[2] - ce[2],
                tau[3] - ce[3],
            ];
            let abase = el.compliance(base);
            let g = tau[1] - tau[2];
            asym_before += w * g * g;
            split.basis(i, l, &mut vals, &mut grads);
            piola_curls(&jac, &dj, &vals, &grads, &mut curls);
            let mut qv = Vec::with_capacity(nq);
            for p in 0..m {
                for q in 0..m - p {
                    qv.push(l[1].powi(p as i32) * l[2].powi(q as i32));
                }
            }
            for ((&na, &ga), ca) in split.node[i].iter().zip(&grads).zip(&curls) {
                let Some(na) = na else { continue };
                for r in 0..2 {
                    let ia = 2 * na + r;
                    let aca = el.compliance(ca[r]);
                    bv[ia] -= w * dot4(abase, ca[r]);
                    for (&nb, cb) in split.node[i].iter().zip(&curls) {
                        let Some(nb) = nb else { continue };
                        for s in 0..2 {
                            mm[(ia, 2 * nb + s)] += w * dot4(aca, cb[s]);
                        }
                    }
                    // div̂ φ̂ = ∂_ξ φ̂₀ + ∂_η φ̂₁, reference weights.
                    for (qi, &qq) in qv.iter().enumerate() {
                        bm[(i * nq + qi, ia)] += wr * ga[r] * qq;
                    }
                }
            }
            for (qi, &qq) in qv.iter().enumerate() {
                d[i * nq + qi] += wr * g * jac.det * qq;
            }
        }
    }
    let (x, rank) = solve(&mm, &bv, &bm, &d);
    let (mut ps2, mut asym_after) = (0.0, 0.0);
    for i in 0..3 {
        for (&xi, &wq) in rule.points.iter().zip(&rule.weights) {
            let l = [1.0 - xi[0] - xi[1], xi[0], xi[1]];
            let xp = split.parent_xi(i, l);
            let jac = map.jacobian(xp);
            let w = wq * split.det[i] * jac.det;
            let (mut tau, ce) = field(xp);
            split.basis(i, l, &mut vals, &mut grads);
            piola_curls(&jac, &dj, &vals, &grads, &mut curls);
            for (&na, c) in split.node[i].iter().zip(&curls) {
                let Some(na) = na else { continue };
                for (r, cr) in c.iter().enumerate() {
                    for (t, cv) in tau.iter_mut().zip(cr) {
                        *t += x[2 * na + r] * cv;
                    }
                }
            }
            ps2 += w * ps_density(el, tau, ce);
            let a = tau[1] - tau[2];
            asym_after += w * a * a;
        }
    }
    Corrected {
        ps2,
        asym_after: asym_after.sqrt(),
        asym_before: asym_before.sqrt(),
        rank,
        rows,
        phi: x,
    }
}

/// Quadrature degree of [`correct_curved`] on each reference sub-triangle: 2m + 6.
pub const fn curved_rule_degree(m: usize) -> usize {
    2 * m + 6
}

/// Physical gradient ∇_x φ (row a: ∂φ_a/∂x, ∂φ_a/∂y) of φ = J φ̂ / det J for φ̂ = N e_s,
/// with N's value `v` and reference gradient `g`, at a point with Jacobian `jac`, and
/// ∂J/∂ξ_c = `dj[c]`:
/// ∂_c (J_as N / det J) = (∂_c J_as N + J_as ∂_c N)/det J − J_as N ∂_c det J / det J²,
/// ∂_c det J = det J tr(J⁻¹ ∂_c J), then ∇_x = ∇_ξ J⁻¹.
#[inline]
fn piola_gradient(
    jac: &Jacobian,
    dj: &[[[f64; 2]; 2]; 2],
    s: usize,
    v: f64,
    g: [f64; 2],
) -> [[f64; 2]; 2] {
    let (jm, ji, det) = (&jac.matrix, &jac.inverse, jac.det);
    let mut dref = [[0.0; 2]; 2];
    for c in 0..2 {
        let tr = ji[0][0] * dj[c][0][0]
            + ji[0][1] * dj[c][1][0]
            + ji[1][0] * dj[c][0][1]
            + ji[1][1] * dj[c][1][1];
        for a in 0..2 {
            dref[a][c] = (dj[c][a][s] * v + jm[a][s] * g[c]) / det - jm[a][s] * v * tr / det;
        }
    }
    let mut out = [[0.0; 2]; 2];
    for a in 0..2 {
        for e in 0..2 {
            out[a][e] = dref[a][0] * ji[0][e] + dref[a][1] * ji[1][e];
        }
    }
    out
}

/// Curl (row-major [xx, xy, yx, yy]) of the Piola images of N e₀ and N e₁ for every Lagrange
/// function N (values `vals`, reference gradients `grads`).
fn piola_curls(
    jac: &Jacobian,
    dj: &[[[f64; 2]; 2]; 2],
    vals: &[f64],
    grads: &[[f64; 2]],
    out: &mut Vec<[[f64; 4]; 2]>,
) {
    out.clear();
    for (&v, &g) in vals.iter().zip(grads) {
        out.push([0, 1].map(|s| {
            let gp = piola_gradient(jac, dj, s, v, g);
            [gp[0][1], -gp[0][0], gp[1][1], -gp[1][0]]
        }));
    }
}

/// min ½ xᵀ M x − bᵀ x subject to B x = d (in the least-squares sense on the numerical range
/// of B): B = U S Vᵀ gives the particular solution through the range, the kernel's part is
/// the Cholesky solve of the projected M. Returns x and the numerical rank of B.
fn solve(mm: &Mat<f64>, bv: &[f64], bm: &Mat<f64>, d: &[f64]) -> (Vec<f64>, usize) {
    let (rows, n) = (bm.nrows(), bm.ncols());
    // B = U S Vᵀ: particular solution through the numerical range, the rest in the kernel.
    match bm.svd() {
        Ok(svd) => {
            let (u, s, v) = (svd.U(), svd.S().column_vector(), svd.V());
            let smax = if s.nrows() > 0 { s[0] } else { 0.0 };
            let rank = (0..s.nrows())
                .filter(|&j| s[j] > SYMMETRIC_RANK * smax)
                .count();
            let mut xp = vec![0.0; n];
            for j in 0..rank {
                let c = (0..rows).map(|k| u[(k, j)] * d[k]).sum::<f64>() / s[j];
                for (k, x) in xp.iter_mut().enumerate() {
                    *x += v[(k, j)] * c;
                }
            }
            let nk = n - rank;
            let nmat = Mat::<f64>::from_fn(n, nk, |k, j| v[(k, rank + j)]);
            let mx = Mat::<f64>::from_fn(n, 1, |k, _| {
                bv[k] - (0..n).map(|j| mm[(k, j)] * xp[j]).sum::<f64>()
            });
            let h = nmat.transpose() * mm * &nmat;
            let rhs = nmat.transpose() * &mx;
            if let Ok(llt) = h.llt(Side::Lower) {
                let z = llt.solve(&rhs);
                for (k, x) in xp.iter_mut().enumerate() {
                    *x += (0..nk).map(|j| nmat[(k, j)] * z[(j, 0)]).sum::<f64>();
                }
            }
            (xp, rank)
        }
        Err(_) => (vec![0.0; n], 0),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const EL: Elastic = Elastic {
        mu: 1.3,
        lambda: 2.1,
    };

    fn tri() -> [[f64; 2]; 3] {
        [[0.1, 0.2], [1.3, 0.05], [0.4, 0.9]]
    }

    /// x(ξ) of `tri()`.
    fn x_of(xi: [f64; 2]) -> [f64; 2] {
        let v = tri();
        [
            v[0][0] + xi[0] * (v[1][0] - v[0][0]) + xi[1] * (v[2][0] - v[0][0]),
            v[0][1] + xi[0] * (v[1][1] - v[0][1]) + xi[1] * (v[2][1] - v[0][1]),
        ]
    }

    /// [`correct_affine`] checked against the physical-split [`correct`]: same rank, rows,
    /// ps2, ‖as τ‖ and φ to round-off; returns the former.
    fn both(
        v: [[f64; 2]; 3],
        m: usize,
        field: impl Fn([f64; 2]) -> ([f64; 4], [f64; 4]) + Copy,
    ) -> Corrected {
        let old = correct(v, m, &EL, field);
        let new = correct_affine(v, m, &EL, |_, xi| field(xi));
        assert_eq!((old.rank, old.rows), (new.rank, new.rows), "m = {m}");
        let close = |a: f64, b: f64, floor: f64| (a - b).abs() <= 1e-10 * a.abs().max(floor);
        assert!(
            close(old.ps2, new.ps2, 1e-300),
            "ps2 {} vs {}",
            old.ps2,
            new.ps2
        );
        assert!(
            close(old.asym_before, new.asym_before, 1e-300),
            "{} vs {}",
            old.asym_before,
            new.asym_before
        );
        let floor = old.asym_before.max(1e-300);
        assert!(
            old.asym_after <= 1e-12 * floor.max(1.0),
            "{}",
            old.asym_after
        );
        assert!(
            new.asym_after <= 1e-12 * floor.max(1.0),
            "{}",
            new.asym_after
        );
        let scale = old.phi.iter().fold(0.0f64, |a, b| a.max(b.abs()));
        for (a, b) in old.phi.iter().zip(&new.phi) {
            assert!((a - b).abs() <= 1e-9 * scale, "φ {a} vs {b}");
        }
        new
    }

    #[test]
    fn divergence_is_onto_the_mean_free_split_polynomials() {
        // Scott–Vogelius on the Alfeld split (Arnold–Qin 1992): rank = rows − 1 (the mean).
        for m in [2, 3, 4] {
            let c = both(tri(), m, |_| ([0.0; 4], [0.0; 4]));
            assert_eq!(c.rank, c.rows - 1, "m = {m}");
        }
    }

    #[test]
    fn a_mean_free_asymmetry_is_removed_exactly_and_the_divergence_kept() {
        // τ with as τ = x² − mean-ish quadratic: add the skew field a(x) [[0, 1], [−1, 0]]/2
        // to a symmetric field; a quadratic with zero mean on T (mean removed by hand below).
        let v = tri();
        // ∫_T x dx / |T| = centroid; a = (x − x_c)(y − y_c) − M with M its mean (by quadrature).
        let xc = (v[0][0] + v[1][0] + v[2][0]) / 3.0;
        let yc = (v[0][1] + v[1][1] + v[2][1]) / 3.0;
        let rule = triangle_rule_cached(4);
        let mut mean = 0.0;
        for (&xi, &w) in rule.points.iter().zip(&rule.weights) {
            let p = x_of(xi);
            mean += w * 2.0 * (p[0] - xc) * (p[1] - yc);
        }
        let a = |p: [f64; 2]| (p[0] - xc) * (p[1] - yc) - mean;
        let field = |xi: [f64; 2]| {
            let p = x_of(xi);
            let s = [1.0 + p[0], 0.3 * p[1], 0.3 * p[1], -0.5];
            let h = 0.5 * a(p);
            ([s[0], s[1] + h, s[2] - h, s[3]], [0.7, 0.1, 0.1, 0.2])
        };
        let c = both(tri(), 3, field);
        assert!(c.asym_before > 1e-3, "{}", c.asym_before);
        assert!(
            c.asym_after < 1e-13 * c.asym_before.max(1.0),
            "{} → {}",
            c.asym_before,
            c.asym_after
        );
    }

    /// `corrected_ps2` re-integrates the term of φ found by `correct_affine`: for polynomial
    /// fields it is `correct_affine`'s own ps2 (φ read back in the same representation), at the
    /// exact degree and far above it; for a field off the polynomials (a smooth rational Cε)
    /// the high-degree value agrees with a still higher one and differs from the exact-degree
    /// rule's, which is why the bound calls it on rational cells.
    #[test]
    fn the_corrected_term_is_integrated_again_from_phi() {
        let v = tri();
        // A mean-free quadratic asymmetry a (the correction needs ∫_T as τ = 0).
        let (xc, yc) = (
            (v[0][0] + v[1][0] + v[2][0]) / 3.0,
            (v[0][1] + v[1][1] + v[2][1]) / 3.0,
        );
        let rule = triangle_rule_cached(4);
        let mean: f64 = (rule.points.iter().zip(&rule.weights))
            .map(|(&xi, &w)| {
                let p = x_of(xi);
                w * 2.0 * (p[0] - xc) * (p[1] - yc)
            })
            .sum();
        let poly = move |xi: [f64; 2]| {
            let p = x_of(xi);
            let h = 0.5 * ((p[0] - xc) * (p[1] - yc) - mean);
            let tau = [
                1.0 + p[0] * p[1],
                0.3 * p[1] + h,
                0.3 * p[1] - h,
                -0.5 + p[1],
            ];
            (tau, [0.7 + p[1], 0.1 * p[0], 0.1 * p[0], 0.2 * p[1] * p[1]])
        };
        let m = 4;
        let c = both(v, m, poly);
        assert!(c.asym_before > 1e-3 && c.ps2 > 1e-2, "{c:?}");
        for degree in [affine_rule_degree(m), 20] {
            let again = corrected_ps2(v, m, &EL, &c.phi, degree, |_, xi| poly(xi));
            assert!(
                (again - c.ps2).abs() <= 1e-12 * c.ps2,
                "degree {degree}: {again} against {}",
                c.ps2
            );
        }
        let rational = |xi: [f64; 2]| {
            let (tau, ce) = poly(xi);
            let p = x_of(xi);
            let r = 1.0 / (2.0 + p[0] - 0.5 * p[1]);
            (tau, [ce[0] + r, ce[1], ce[2], ce[3] - r * r])
        };
        let c = correct_affine(v, m, &EL, |_, xi| rational(xi));
        let (low, high, higher) = (
            corrected_ps2(v, m, &EL, &c.phi, affine_rule_degree(m), |_, xi| {
                rational(xi)
            }),
            corrected_ps2(v, m, &EL, &c.phi, 20, |_, xi| rational(xi)),
            corrected_ps2(v, m, &EL, &c.phi, 30, |_, xi| rational(xi)),
        );
        assert!(
            (low - c.ps2).abs() <= 1e-12 * c.ps2,
            "{low} against {}",
            c.ps2
        );
        assert!(
            (high - higher).abs() <= 1e-13 * higher,
            "{high} against {higher}"
        );
        assert!(
            (low - higher).abs() > 1e-12 * higher,
            "{low} against {higher}"
        );
    }

    #[test]
    fn a_symmetric_exact_stress_gives_zero() {
        // τ = Cε(v) symmetric and linear: nothing to correct, η_PS = 0.
        let field = |xi: [f64; 2]| {
            let p = x_of(xi);
            let s = [p[0], 2.0 * p[1], 2.0 * p[1], 1.0 - p[0]];
            (s, s)
        };
        let c = both(tri(), 3, field);
        assert!(
            c.ps2 < 1e-28 && c.asym_after < 1e-14,
            "{} {}",
            c.ps2,
            c.asym_after
        );
    }

    #[test]
    fn the_divergence_free_freedom_never_raises_the_term() {
        // A symmetric τ ≠ Cε(v): the correction may only lower ‖τ − Cε(v)‖_A (φ = 0 is allowed).
        let field = |xi: [f64; 2]| {
            let p = x_of(xi);
            ([p[0] * p[1], 0.2, 0.2, p[1] * p[1]], [0.0, 0.1, 0.1, p[0]])
        };
        let c = both(tri(), 3, field);
        let rule = triangle_rule_cached(8);
        let v = tri();
        let det =
            (v[1][0] - v[0][0]) * (v[2][1] - v[0][1]) - (v[2][0] - v[0][0]) * (v[1][1] - v[0][1]);
        let mut before = 0.0;
        for (&xi, &w) in rule.points.iter().zip(&rule.weights) {
            let (s, ce) = field(xi);
            before += w * det * ps_density(&EL, s, ce);
        }
        assert!(
            c.ps2 <= before * (1.0 + 1e-12) && c.ps2 > 0.0,
            "{} vs {before}",
            c.ps2
        );
    }
}

#[cfg(test)]
mod curved_tests {
    use super::*;
    use crate::element::rt::{self, RtOrder};

    const EL: Elastic = Elastic {
        mu: 1.3,
        lambda: 2.1,
    };

    /// `tri()` of the straight tests with edge 1–2 bent outwards and edge 2–0 slightly in.
    fn curved() -> [[f64; 2]; 6] {
        let v = [[0.1, 0.2], [1.3, 0.05], [0.4, 0.9]];
        let mid = |a: [f64; 2], b: [f64; 2]| [0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1])];
        let m12 = mid(v[1], v[2]);
        let m20 = mid(v[2], v[0]);
        [
            v[0],
            v[1],
            v[2],
            mid(v[0], v[1]),
            [m12[0] + 0.12, m12[1] + 0.1],
            [m20[0] + 0.03, m20[1] - 0.02],
        ]
    }

    fn straight6() -> [[f64; 2]; 6] {
        let v = [[0.1, 0.2], [1.3, 0.05], [0.4, 0.9]];
        let mid = |a: [f64; 2], b: [f64; 2]| [0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1])];
        [
            v[0],
            v[1],
            v[2],
            mid(v[0], v[1]),
            mid(v[1], v[2]),
            mid(v[2], v[0]),
        ]
    }

    /// τ = Σ c[r][i] (Piola image of the i-th RT basis field) on `nodes`.
    fn rt_tau(order: RtOrder, nodes: &[[f64; 2]; 6], c: &[[f64; 15]; 2], xi: [f64; 2]) -> [f64; 4] {
        let jac = QuadraticTriangle::new(*nodes).jacobian(xi);
        let (v, _) = rt::piola(order, &jac, xi);
        let mut s = [0.0; 4];
        for i in 0..order.dofs() {
            for r in 0..2 {
                s[2 * r] += c[r][i] * v[i][0];
                s[2 * r + 1] += c[r][i] * v[i][1];
            }
        }
        s
    }

    /// ∫_T as τ dx (exact: (as τ) det J is a polynomial of degree ≤ k + 2).
    fn mean_as(order: RtOrder, nodes: &[[f64; 2]; 6], c: &[[f64; 15]; 2]) -> f64 {
        let rule = triangle_rule_cached(12);
        let map = QuadraticTriangle::new(*nodes);
        rule.points
            .iter()
            .zip(&rule.weights)
            .map(|(&xi, &w)| {
                let s = rt_tau(order, nodes, c, xi);
                w * map.jacobian(xi).det * (s[1] - s[2])
            })
            .sum()
    }

    /// An RT_k stress with ∫_T as τ = 0: pseudo-random coefficients c₁ − (M₁/M₂) c₂.
    fn mean_free_rt(order: RtOrder, nodes: &[[f64; 2]; 6]) -> [[f64; 15]; 2] {
        let mut uniform = crate::testing::uniform(12345);
        let mut rnd = || uniform() * 2.0 - 1.0;
        let mut c1 = [[0.0; 15]; 2];
        let mut c2 = [[0.0; 15]; 2];
        for r in 0..2 {
            for i in 0..order.dofs() {
                c1[r][i] = rnd();
                c2[r][i] = rnd();
            }
        }
        let (m1, m2) = (mean_as(order, nodes, &c1), mean_as(order, nodes, &c2));
        assert!(m2.abs() > 1e-3);
        for r in 0..2 {
            for i in 0..15 {
                c1[r][i] -= m1 / m2 * c2[r][i];
            }
        }
        assert!(mean_as(order, nodes, &c1).abs() < 1e-13);
        c1
    }

    /// Curl φ at parent reference point ξ for the solution `phi` of [`correct_curved`].
    fn curl_at(nodes: &[[f64; 2]; 6], m: usize, phi: &[f64], xi: [f64; 2]) -> [f64; 4] {
        let map = QuadraticTriangle::new(*nodes);
        let split = Split::new([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]], m);
        let lam = [1.0 - xi[0] - xi[1], xi[0], xi[1]];
        // Sub-triangle (P_i, P_{i+1}, C) holds the points whose smallest λ is λ_{i+2}.
        let i = (0..3)
            .min_by(|&a, &b| lam[(a + 2) % 3].total_cmp(&lam[(b + 2) % 3]))
            .unwrap();
        let lo = lam[(i + 2) % 3];
        let l = [lam[i] - lo, lam[(i + 1) % 3] - lo, 3.0 * lo];
        let (mut vals, mut grads, mut curls) = (Vec::new(), Vec::new(), Vec::new());
        split.basis(i, l, &mut vals, &mut grads);
        piola_curls(
            &map.jacobian(xi),
            &map.jacobian_derivatives(),
            &vals,
            &grads,
            &mut curls,
        );
        let mut out = [0.0; 4];
        for (&na, c) in split.node[i].iter().zip(&curls) {
            let Some(na) = na else { continue };
            for (r, cr) in c.iter().enumerate() {
                for (o, cv) in out.iter_mut().zip(cr) {
                    *o += phi[2 * na + r] * cv;
                }
            }
        }
        out
    }

    fn points() -> Vec<[f64; 2]> {
        let mut p = Vec::new();
        for i in 0..=9 {
            for j in 0..=(9 - i) {
                p.push([(i as f64 + 0.13) / 9.6, (j as f64 + 0.21) / 9.7]);
            }
        }
        p
    }

    /// A counter-clockwise straight 6-node cell from vertices.
    fn straight_nodes(v: [[f64; 2]; 3]) -> [[f64; 2]; 6] {
        let mid = |a: [f64; 2], b: [f64; 2]| [0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1])];
        [
            v[0],
            v[1],
            v[2],
            mid(v[0], v[1]),
            mid(v[1], v[2]),
            mid(v[2], v[0]),
        ]
    }

    /// Old (physical split) and new (reference split) corrections of a mean-free RT_k stress on
    /// the straight cell `v`, with Cε a linear field in x.
    fn old_and_new(v: [[f64; 2]; 3], order: RtOrder) -> (Corrected, Corrected) {
        let nodes = straight_nodes(v);
        let c = mean_free_rt(order, &nodes);
        let map = QuadraticTriangle::new(nodes);
        let (xc, yc) = (
            (v[0][0] + v[1][0] + v[2][0]) / 3.0,
            (v[0][1] + v[1][1] + v[2][1]) / 3.0,
        );
        let size = ((v[1][0] - v[0][0]).powi(2) + (v[1][1] - v[0][1]).powi(2)).sqrt();
        let sigma = rt_tau(order, &nodes, &c, [1.0 / 3.0, 1.0 / 3.0])
            .iter()
            .fold(0.0f64, |a, b| a.max(b.abs()));
        let ce = |xi: [f64; 2]| {
            let x = map.position(xi);
            let (px, py) = ((x[0] - xc) / size, (x[1] - yc) / size);
            [
                sigma * px,
                sigma * 0.3 * py,
                sigma * 0.3 * py,
                sigma * (1.0 - px),
            ]
        };
        let field = |xi: [f64; 2]| (rt_tau(order, &nodes, &c, xi), ce(xi));
        let m = order.k() + 2;
        (
            correct(v, m, &EL, field),
            correct_affine(v, m, &EL, |_, xi| field(xi)),
        )
    }

    fn assert_same(old: &Corrected, new: &Corrected, what: &str) {
        assert_eq!(old.rank, new.rank, "{what}");
        assert_eq!(new.rank + 1, new.rows, "{what}");
        assert!(
            (old.ps2 - new.ps2).abs() <= 1e-10 * old.ps2,
            "{what}: ps2 {} vs {}",
            old.ps2,
            new.ps2
        );
        assert!(
            (old.asym_before - new.asym_before).abs() <= 1e-12 * old.asym_before,
            "{what}: {} vs {}",
            old.asym_before,
            new.asym_before
        );
        assert!(old.asym_before > 0.0, "{what}");
        // The physical-split SVD loses a few digits on the sliver; the reference one does not.
        for (c, which, tol) in [(old, "old", 1e-10), (new, "new", 1e-12)] {
            assert!(
                c.asym_after <= tol * c.asym_before,
                "{what} {which}: {} → {}",
                c.asym_before,
                c.asym_after
            );
        }
    }

    #[test]
    fn the_reference_split_correction_matches_the_physical_one_on_random_cells() {
        let mut rnd = crate::testing::uniform(987654321);
        for trial in 0..20 {
            let mut v = [[0.0; 2]; 3];
            for p in v.iter_mut() {
                *p = [4.0 * rnd() - 2.0, 4.0 * rnd() - 2.0];
            }
            let det = (v[1][0] - v[0][0]) * (v[2][1] - v[0][1])
                - (v[2][0] - v[0][0]) * (v[1][1] - v[0][1]);
            if det.abs() < 0.05 {
                continue;
            }
            if det < 0.0 {
                v.swap(1, 2);
            }
            for order in [RtOrder::Rt1, RtOrder::Rt2] {
                let (old, new) = old_and_new(v, order);
                assert_same(&old, &new, &format!("trial {trial} {order:?}"));
            }
        }
    }

    #[test]
    fn the_reference_split_correction_on_a_sliver_and_at_extreme_scales() {
        let base = [[0.1, 0.2], [1.3, 0.05], [0.4, 0.9]];
        // Aspect ratio 1e3: height 1e-3 over a unit base.
        let sliver = [[0.0, 0.0], [1.0, 0.0], [0.37, 1e-3]];
        for order in [RtOrder::Rt1, RtOrder::Rt2] {
            let (old, new) = old_and_new(sliver, order);
            assert_same(&old, &new, &format!("sliver {order:?}"));
            // A field fixed in ξ on a cell scaled by s: ps2/s² and the ratios are unchanged.
            let tau = |xi: [f64; 2]| {
                let a = xi[0] * xi[1] - 1.0 / 12.0 + 0.5 * (xi[0] * xi[0] - 1.0 / 6.0);
                let sy = [1.0 + xi[0], 0.3 * xi[1], 0.3 * xi[1], xi[0] * xi[1]];
                [sy[0], sy[1] + 0.5 * a, sy[2] - 0.5 * a, sy[3]]
            };
            let ce = |xi: [f64; 2]| [0.7 + xi[1], 0.1, 0.1, 0.2 - xi[0]];
            let m = order.k() + 2;
            let reference = correct_affine(base, m, &EL, |_, xi| (tau(xi), ce(xi)));
            for cell in [base, sliver] {
                let at_one = correct_affine(cell, m, &EL, |_, xi| (tau(xi), ce(xi)));
                for s in [1e6, 1e-6] {
                    let v = cell.map(|p| [s * p[0], s * p[1]]);
                    let c = correct_affine(v, m, &EL, |_, xi| (tau(xi), ce(xi)));
                    assert_eq!(c.rank, reference.rank);
                    assert!(
                        (c.ps2 / (s * s) - at_one.ps2).abs() <= 1e-10 * at_one.ps2,
                        "{order:?} ×{s}: {} vs {}",
                        c.ps2 / (s * s),
                        at_one.ps2
                    );
                    assert!(
                        (c.asym_before / s - at_one.asym_before).abs()
                            <= 1e-12 * at_one.asym_before
                    );
                    assert!(c.asym_after <= 1e-12 * c.asym_before, "{order:?} ×{s}");
                    let old = correct(v, m, &EL, |xi| (tau(xi), ce(xi)));
                    assert!(
                        (old.ps2 - c.ps2).abs() <= 1e-10 * c.ps2,
                        "{order:?} ×{s}: old {} vs new {}",
                        old.ps2,
                        c.ps2
                    );
                }
            }
        }
    }

    #[test]
    fn divergence_is_onto_on_the_reference_split() {
        for m in [2, 3, 4, 5] {
            let c = correct_curved(curved(), m, &EL, |_| ([0.0; 4], [0.0; 4]));
            assert_eq!(c.rank, c.rows - 1, "m = {m}");
        }
    }

    #[test]
    fn an_rt_stress_on_a_curved_cell_is_made_symmetric_with_its_divergence_and_traces_kept() {
        let nodes = curved();
        let map = QuadraticTriangle::new(nodes);
        for order in [RtOrder::Rt0, RtOrder::Rt1, RtOrder::Rt2] {
            let m = order.k() + 3;
            let c = mean_free_rt(order, &nodes);
            let ce = |xi: [f64; 2]| {
                let x = map.position(xi);
                [x[0], 0.3 * x[1], 0.3 * x[1], 1.0 - x[0] * x[1]]
            };
            let fix = correct_curved(nodes, m, &EL, |xi| (rt_tau(order, &nodes, &c, xi), ce(xi)));
            assert_eq!(fix.rank + 1, fix.rows, "{order:?}");
            assert!(fix.asym_before > 1e-2, "{order:?} {}", fix.asym_before);
            assert!(
                fix.asym_after < 1e-12 * fix.asym_before,
                "{order:?} {} → {}",
                fix.asym_before,
                fix.asym_after
            );
            let scale = fix.phi.iter().fold(0.0f64, |a, b| a.max(b.abs()));
            // Pointwise symmetry and zero divergence of Curl φ (central differences in ξ).
            let h = 1e-5;
            for xi in points() {
                let t = rt_tau(order, &nodes, &c, xi);
                let cp = curl_at(&nodes, m, &fix.phi, xi);
                let before = (t[1] - t[2]).abs();
                let after = (t[1] + cp[1] - t[2] - cp[2]).abs();
                assert!(
                    after < 1e-10 * before.max(1.0),
                    "{order:?} {xi:?}: {before} → {after}"
                );
                let ji = map.jacobian(xi).inverse;
                let mut dc = [[0.0; 4]; 2];
                for (k, dk) in dc.iter_mut().enumerate() {
                    let (mut p, mut q) = (xi, xi);
                    p[k] += h;
                    q[k] -= h;
                    let (cp, cq) = (
                        curl_at(&nodes, m, &fix.phi, p),
                        curl_at(&nodes, m, &fix.phi, q),
                    );
                    for j in 0..4 {
                        dk[j] = (cp[j] - cq[j]) / (2.0 * h);
                    }
                }
                // ∂_x f = Σ_k ∂_ξk f (J⁻¹)_{k0}, ∂_y f = Σ_k ∂_ξk f (J⁻¹)_{k1}.
                let dx = |j: usize, e: usize| dc[0][j] * ji[0][e] + dc[1][j] * ji[1][e];
                for r in 0..2 {
                    let div = dx(2 * r, 0) + dx(2 * r + 1, 1);
                    assert!(
                        div.abs() < 1e-5 * scale.max(1.0),
                        "{order:?} {xi:?} div {div}"
                    );
                }
            }
            // Curl φ · n = ∂_t φ = 0 on the three (curved) edges.
            for e in 0..3 {
                for s in [0.05, 0.3, 0.5, 0.77, 0.95] {
                    let xi = match e {
                        0 => [s, 0.0],
                        1 => [1.0 - s, s],
                        _ => [0.0, 1.0 - s],
                    };
                    let tr = [[1.0, 0.0], [-1.0, 1.0], [0.0, -1.0]][e];
                    let jm = map.jacobian(xi).matrix;
                    let t = [
                        jm[0][0] * tr[0] + jm[0][1] * tr[1],
                        jm[1][0] * tr[0] + jm[1][1] * tr[1],
                    ];
                    let n = [t[1], -t[0]];
                    let cp = curl_at(&nodes, m, &fix.phi, xi);
                    for r in 0..2 {
                        let cn = cp[2 * r] * n[0] + cp[2 * r + 1] * n[1];
                        assert!(
                            cn.abs() < 1e-11 * scale.max(1.0),
                            "{order:?} edge {e} s {s}: {cn}"
                        );
                    }
                }
            }
            // The divergence-free freedom only lowers the term (φ = 0 is admissible for the
            // symmetric part): τ* is no farther from Cε than sym τ is... checked loosely: finite.
            assert!(fix.ps2.is_finite() && fix.ps2 > 0.0);
        }
    }

    #[test]
    fn a_straight_six_node_cell_gives_the_straight_correction() {
        let nodes = straight6();
        let order = RtOrder::Rt1;
        let c = mean_free_rt(order, &nodes);
        let map = QuadraticTriangle::new(nodes);
        let ce = |xi: [f64; 2]| {
            let x = map.position(xi);
            [x[0], 0.3 * x[1], 0.3 * x[1], 1.0 - x[0]]
        };
        let field = |xi: [f64; 2]| (rt_tau(order, &nodes, &c, xi), ce(xi));
        let m = order.k() + 2;
        let a = correct([nodes[0], nodes[1], nodes[2]], m, &EL, field);
        let b = correct_curved(nodes, m, &EL, field);
        let r = correct_affine([nodes[0], nodes[1], nodes[2]], m, &EL, |_, xi| field(xi));
        assert!(
            (r.ps2 - b.ps2).abs() < 1e-11 * r.ps2,
            "{} vs {}",
            r.ps2,
            b.ps2
        );
        assert_eq!(a.rank, b.rank);
        assert!(
            (a.ps2 - b.ps2).abs() < 1e-11 * a.ps2,
            "{} vs {}",
            a.ps2,
            b.ps2
        );
        assert!((a.asym_before - b.asym_before).abs() < 1e-12 * a.asym_before);
        assert!(b.asym_after < 1e-12 * b.asym_before);
    }
}
