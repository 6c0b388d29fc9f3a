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
//! checked numerically for every cell, and a failure is reported, not hidden.
//!
//! The cost is one small dense problem per cell (20 unknowns for m = 3, 38 for m = 4): the
//! constraints are eliminated through the SVD of the divergence matrix, the remaining
//! freedom (the divergence-free part, which only lowers ‖τ* − Cε(v)‖_A) by a Cholesky solve.

use faer::prelude::Solve;
use faer::{Mat, Side};

use crate::material::Elastic;
use crate::quadrature::triangle_rule_cached;
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

    /// Physical gradients of the Lagrange functions of sub-triangle `i` at barycentrics `l`,
    /// one per lattice point: φ_abc = p_a(l₀) p_b(l₁) p_c(l₂), p_n(s) = Π_{j<n} (ms − j)/(j + 1).
    fn gradients(&self, i: usize, l: [f64; 3], out: &mut Vec<[f64; 2]>) {
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
        out.clear();
        let g = &self.grad[i];
        for &[a, b, c] in &self.lattice {
            let (va, da) = p(a, l[0]);
            let (vb, db) = p(b, l[1]);
            let (vc, dc) = p(c, l[2]);
            let (d0, d1, d2) = (da * vb * vc, va * db * vc, va * vb * dc);
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
            split.gradients(i, l, &mut grads);
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
    // B = U S Vᵀ: particular solution through the numerical range, the rest in the kernel.
    let (x, rank) = match bm.svd() {
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
            let h = nmat.transpose() * &mm * &nmat;
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
    };
    // Second pass: the corrected field's Prager–Synge density and asymmetry, pointwise.
    let (mut ps2, mut asym_after) = (0.0, 0.0);
    for i in 0..3 {
        for (&xi, &wq) in rule.points.iter().zip(&rule.weights) {
            let l = [1.0 - xi[0] - xi[1], xi[0], xi[1]];
            let w = wq * split.det[i];
            let (mut tau, ce) = field(split.parent_xi(i, l));
            split.gradients(i, l, &mut grads);
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

    #[test]
    fn divergence_is_onto_the_mean_free_split_polynomials() {
        // Scott–Vogelius on the Alfeld split (Arnold–Qin 1992): rank = rows − 1 (the mean).
        for m in [2, 3, 4] {
            let c = correct(tri(), m, &EL, |_| ([0.0; 4], [0.0; 4]));
            assert_eq!(c.rank, c.rows - 1, "m = {m}");
        }
    }

    #[test]
    fn a_mean_free_asymmetry_is_removed_exactly_and_the_divergence_kept() {
        // τ with as τ = x² − mean-ish quadratic: add the skew field a(x) [[0, 1], [−1, 0]]/2
        // to a symmetric field; a quadratic with zero mean on T (mean removed by hand below).
        let v = tri();
        let area = 0.5
            * ((v[1][0] - v[0][0]) * (v[2][1] - v[0][1])
                - (v[2][0] - v[0][0]) * (v[1][1] - v[0][1]));
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
        let c = correct(tri(), 3, &EL, field);
        assert!(c.asym_before > 1e-3, "{}", c.asym_before);
        assert!(
            c.asym_after < 1e-13 * c.asym_before.max(1.0),
            "{} → {}",
            c.asym_before,
            c.asym_after
        );
        let _ = area;
    }

    #[test]
    fn a_symmetric_exact_stress_gives_zero() {
        // τ = Cε(v) symmetric and linear: nothing to correct, η_PS = 0.
        let field = |xi: [f64; 2]| {
            let p = x_of(xi);
            let s = [p[0], 2.0 * p[1], 2.0 * p[1], 1.0 - p[0]];
            (s, s)
        };
        let c = correct(tri(), 3, &EL, field);
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
        let c = correct(tri(), 3, &EL, field);
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
