//! Raviart–Thomas elements RT_0, RT_1 and RT_2 on the reference triangle, with the contravariant
//! Piola map to straight and curved (isoparametric P2) cells (docs/design.md §4: the stress space;
//! §5: the contact sign constraint as a bound on single unknowns).
//!
//! **Naming.** RT_k is the space RT_k = P_k² + ξ P̃_k (P̃_k: homogeneous polynomials of degree
//! k), so RT_0 is the lowest order (3 functions, normal trace constant on each edge), RT_1
//! the next (8 functions, normal trace linear on each edge: the talk's choice) and RT_2 the
//! one after (15 functions, normal trace quadratic on each edge). scikit-fem
//! counts from one: its lowest order is `ElementTriRT1` (`ElementTriRT0` is an alias of it).
//!
//! **Reference triangle** T̂ = conv{(0,0), (1,0), (0,1)}. Local edge e runs from vertex e to
//! vertex (e + 1) mod 3 ([`crate::geometry::edge::EDGE_NODES`]), ξ(s) = [`edge_reference_point`]`(e, s)`,
//! s ∈ [0, 1]. Its scaled outward normal ν̂_e = n̂_e |dξ/ds| = (t̂_y, −t̂_x) with t̂ = dξ/ds is
//! [`REFERENCE_FLUX_NORMALS`]: (0, −1), (1, 1), (−1, 0).
//!
//! **Degrees of freedom** (point values of the normal flux density, so that τ_n ≤ 0 on a contact
//! edge is a sign bound on single unknowns):
//!
//! - edge DOF of edge e at s: q_e(s) = φ̂(ξ(s)) · ν̂_e, the flux per unit of s;
//!   RT_0 at s = ½, RT_1 at s = 0 and s = 1 (the edge's end points), RT_2 at s = 0, ½, 1;
//! - interior DOFs, the moments ∫_T̂ φ̂_c q dξ of the components c ∈ {x, y} against
//!   q ∈ P_{k−1}(T̂): none for RT_0; RT_1: q = 1 (two moments); RT_2: q ∈ {1, ξ, η} (six).
//!
//! **DOF order**: edge 0 (s ascending), edge 1, edge 2, then the interior moments, test function
//! q major and component (x, then y) minor, so that RT_1's interior DOFs are the first two of
//! RT_2's (interior DOF i is ∫φ̂_c q_m with m = i / 2, c = i mod 2, q_0, q_1, q_2 = 1, ξ, η):
//!
//! | order | edge e, slot i | interior |
//! |---|---|---|
//! | RT_0 | e (s = ½) | — |
//! | RT_1 | 2e + i (s = i) | 6 (∫φ̂_x), 7 (∫φ̂_y) |
//! | RT_2 | 3e + i (s = i/2) | 9 (∫φ̂_x), 10 (∫φ̂_y), 11 (∫φ̂_x ξ), 12 (∫φ̂_y ξ), 13 (∫φ̂_x η), 14 (∫φ̂_y η) |
//!
//! See [`RtOrder::edge_dof`] and [`RtOrder::interior_dof`].
//!
//! **Basis.** The local basis is the nodal (dual) basis of these DOFs, built once, at first use,
//! by inverting the DOF matrix D_ij = DOF_i(m_j) of the monomial basis m_j of RT_k (RT_0:
//! (1,0), (0,1), (ξ,η); RT_1: (1,0), (0,1), (ξ,0), (0,ξ), (η,0), (0,η), ξ(ξ,η), η(ξ,η); RT_2:
//! the twelve (m,0), (0,m) for m ∈ {1, ξ, η, ξ², ξη, η²}, then ξ²(ξ,η), ξη(ξ,η), η²(ξ,η)); D is
//! evaluated exactly (point values, ∫_T̂ ξ^a η^b = a! b!/(a + b + 2)!). The result, in closed
//! form: RT_0: (ξ, η − 1), (ξ, η), (ξ − 1, η) (the classical basis: unit total flux through one
//! edge); RT_1: see the test `basis_in_closed_form`.
//!
//! **Piola map** (the one place where it is written: [`piola`]). On a cell with map x(ξ) and
//! Jacobian J = ∂x/∂ξ (straight: 3 nodes; curved: 6 nodes, isoparametric P2):
//!
//! ```text
//! φ(x(ξ)) = J(ξ) φ̂(ξ) / det J(ξ),    div φ(x(ξ)) = div̂ φ̂(ξ) / det J(ξ).
//! ```
//!
//! Since Jᵀ R J = det J · R for the quarter turn R(t) = (t_y, −t_x), on a physical edge
//! x(s) = x(ξ(s)) with x'(s) = J t̂:
//!
//! ```text
//! φ(x(s)) · n |x'(s)| = φ(x(s)) · R x'(s) = φ̂(ξ(s)) · ν̂_e = q_e(s),
//! ```
//!
//! n the outward unit normal of the (possibly curved) physical edge of a counter-clockwise
//! cell (det J > 0). So the DOFs are the physical flux densities per unit of s, the physical
//! normal trace at x(s) is DOF / |x'(s)| (a positive factor, [`edge_trace_weights`]), and
//! signs and the 2D friction cone |τ_t| ≤ 𝔉|τ_n| are preserved. The total flux through edge e
//! is ∫_0^1 q_e(s) ds.
//!
//! **Orientation.** A global edge DOF is defined w.r.t. the global edge direction a → b
//! (a < b, [`crate::topology::Topology::edges`]) and the normal to its right, i.e. pointing out
//! of the cell that runs the edge a → b counter-clockwise. A cell whose local edge runs a → b
//! (forward) has local DOF at s = global DOF at s; one whose local edge runs b → a has local DOF
//! at s = − global DOF at 1 − s (normal flipped, parameter reversed):
//! [`local_to_global_edge`]. Interior DOFs are local to the cell.
//!
//! All evaluation functions take and return fixed-size arrays (slots beyond
//! [`RtOrder::dofs`] are 0) and allocate nothing after the one-time basis construction.

use std::sync::OnceLock;

use crate::geometry::edge::edge_reference_point;
use crate::geometry::map::{CellMap, Jacobian};
use crate::quadrature::triangle_rule_cached;

/// Number of RT_0 functions (one per edge).
pub const RT0_DOFS: usize = 3;
/// Number of RT_1 functions (two per edge, two interior).
pub const RT1_DOFS: usize = 8;
/// Number of RT_2 functions (three per edge, six interior).
pub const RT2_DOFS: usize = 15;
/// Size of the fixed arrays returned here: the largest number of functions.
pub const MAX_RT_DOFS: usize = RT2_DOFS;

/// Tangents t̂_e = dξ/ds of the reference edges 0, 1, 2 (edge e from vertex e to vertex e + 1).
pub const REFERENCE_EDGE_TANGENTS: [[f64; 2]; 3] = [[1.0, 0.0], [-1.0, 1.0], [0.0, -1.0]];

/// Scaled outward normals ν̂_e = n̂_e |dξ/ds| = (t̂_y, −t̂_x) of the reference edges: the edge
/// DOF at s is φ̂(ξ(s)) · ν̂_e.
pub const REFERENCE_FLUX_NORMALS: [[f64; 2]; 3] = [[0.0, -1.0], [1.0, 1.0], [-1.0, 0.0]];

/// Quadrature degree used by [`interpolate`] for the interior moments.
pub const INTERPOLATION_DEGREE: usize = 10;

/// The order k of a Raviart–Thomas space RT_k (module doc: RT_0 is the lowest order).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum RtOrder {
    /// Lowest order: normal trace constant per edge; 3 DOFs (edge midpoints).
    Rt0,
    /// Next order: normal trace linear per edge; 8 DOFs (edge end points, two interior moments).
    Rt1,
    /// Normal trace quadratic per edge; 15 DOFs (edge end points and midpoints, six interior
    /// moments).
    Rt2,
}

impl RtOrder {
    /// k: the polynomial degree of the normal traces and of the divergences.
    #[inline]
    pub const fn k(self) -> usize {
        match self {
            RtOrder::Rt0 => 0,
            RtOrder::Rt1 => 1,
            RtOrder::Rt2 => 2,
        }
    }

    /// Number of basis functions: [`RT0_DOFS`], [`RT1_DOFS`] or [`RT2_DOFS`].
    #[inline]
    pub const fn dofs(self) -> usize {
        match self {
            RtOrder::Rt0 => RT0_DOFS,
            RtOrder::Rt1 => RT1_DOFS,
            RtOrder::Rt2 => RT2_DOFS,
        }
    }

    /// The parameters s of the edge DOFs on each edge, ascending: RT_0 `[½]`, RT_1 `[0, 1]`,
    /// RT_2 `[0, ½, 1]`.
    /// Symmetric under s ↦ 1 − s, which [`local_to_global_edge`] relies on.
    #[inline]
    pub const fn edge_points(self) -> &'static [f64] {
        match self {
            RtOrder::Rt0 => &[0.5],
            RtOrder::Rt1 => &[0.0, 1.0],
            RtOrder::Rt2 => &[0.0, 0.5, 1.0],
        }
    }

    /// Number of DOFs per edge (k + 1).
    #[inline]
    pub const fn edge_dofs(self) -> usize {
        self.k() + 1
    }

    /// Number of interior DOFs (RT_0: 0, RT_1: 2, RT_2: 6).
    #[inline]
    pub const fn interior_dofs(self) -> usize {
        self.dofs() - 3 * self.edge_dofs()
    }

    /// Local index of the DOF at `edge_points()[slot]` on local edge `edge`:
    /// `edge · edge_dofs() + slot`.
    #[inline]
    pub const fn edge_dof(self, edge: usize, slot: usize) -> usize {
        edge * self.edge_dofs() + slot
    }

    /// Local index of interior DOF `i`: `3 · edge_dofs() + i`. Interior DOF i is ∫_T̂ φ̂_c q_m
    /// with m = i / 2, c = i mod 2 (0: x, 1: y) and q_0, q_1, q_2 = 1, ξ, η: 0 ∫φ̂_x, 1 ∫φ̂_y,
    /// 2 ∫φ̂_x ξ, 3 ∫φ̂_y ξ, 4 ∫φ̂_x η, 5 ∫φ̂_y η (module doc).
    #[inline]
    pub const fn interior_dof(self, i: usize) -> usize {
        3 * self.edge_dofs() + i
    }
}

/// Number of monomials of degree ≤ 3.
const TERMS: usize = 10;

/// Coefficients of a scalar polynomial of degree ≤ 3 in the monomials 1, ξ, η, ξ², ξη, η², ξ³,
/// ξ²η, ξη², η³ (degree by degree, ξ-power descending: ξ^a η^b has index
/// (a + b)(a + b + 1)/2 + b).
type Poly = [f64; TERMS];

/// The exponents (a, b) of the monomials of [`Poly`].
const EXPONENTS: [(usize, usize); TERMS] = [
    (0, 0),
    (1, 0),
    (0, 1),
    (2, 0),
    (1, 1),
    (0, 2),
    (3, 0),
    (2, 1),
    (1, 2),
    (0, 3),
];

/// The index of ξ^a η^b in [`Poly`].
const fn monomial_index(a: usize, b: usize) -> usize {
    (a + b) * (a + b + 1) / 2 + b
}

/// ∫_T̂ ξ^a η^b dξ = a! b!/(a + b + 2)!.
fn monomial_moment(a: usize, b: usize) -> f64 {
    let factorial = |n: usize| (1..=n).map(|i| i as f64).product::<f64>();
    factorial(a) * factorial(b) / factorial(a + b + 2)
}

/// The exponents of the interior test functions q_0, q_1, q_2 = 1, ξ, η (module doc).
const MOMENT_WEIGHTS: [(usize, usize); 3] = [(0, 0), (1, 0), (0, 1)];

/// The interior test function q_m at `xi`.
#[inline]
fn moment_weight(m: usize, xi: [f64; 2]) -> f64 {
    match m {
        0 => 1.0,
        1 => xi[0],
        _ => xi[1],
    }
}

/// The monomials of [`Poly`] at `xi`.
#[inline]
fn monomials(xi: [f64; 2]) -> Poly {
    let [x, y] = xi;
    let (xx, xy, yy) = (x * x, x * y, y * y);
    [1.0, x, y, xx, xy, yy, xx * x, xx * y, xy * y, yy * y]
}

/// Σ_q p_q m_q over the first `terms` monomials.
#[inline]
fn eval(p: &[f64], m: &Poly, terms: usize) -> f64 {
    p[..terms].iter().zip(m).map(|(a, b)| a * b).sum()
}

/// [`eval`] with `N` terms known at compile time: the same sum in the same order.
#[inline(always)]
fn eval_fixed<const N: usize>(p: &Poly, m: &Poly) -> f64 {
    let mut s = -0.0;
    for q in 0..N {
        s += p[q] * m[q];
    }
    s
}

/// The nodal basis of one order: component polynomials of each function and its divergence.
#[derive(Debug)]
struct NodalBasis {
    n: usize,
    /// Monomials used by the values ((k + 2)(k + 3)/2) and by the divergences ((k + 1)(k + 2)/2).
    value_terms: usize,
    divergence_terms: usize,
    values: [[Poly; 2]; MAX_RT_DOFS],
    divergence: [Poly; MAX_RT_DOFS],
}

/// The monomial basis of RT_k (module doc), as component polynomials.
fn monomial_basis(order: RtOrder) -> Vec<[Poly; 2]> {
    let unit = |a: usize, b: usize| {
        let mut p = [0.0; TERMS];
        p[monomial_index(a, b)] = 1.0;
        p
    };
    let zero = [0.0; TERMS];
    let k = order.k();
    // P_k²: (m, 0), (0, m) for the monomials m of degree ≤ k, in [`Poly`] order.
    let mut fields: Vec<[Poly; 2]> = Vec::with_capacity(order.dofs());
    for &(a, b) in EXPONENTS.iter().filter(|(a, b)| a + b <= k) {
        fields.push([unit(a, b), zero]);
        fields.push([zero, unit(a, b)]);
    }
    // ξ P̃_k: h (ξ, η) for the monomials h of degree exactly k.
    for &(a, b) in EXPONENTS.iter().filter(|(a, b)| a + b == k) {
        fields.push([unit(a + 1, b), unit(a, b + 1)]);
    }
    fields
}

/// ∫_T̂ p q_m dξ, exactly.
fn polynomial_moment(p: &Poly, m: usize) -> f64 {
    let (sa, sb) = MOMENT_WEIGHTS[m];
    p.iter()
        .zip(EXPONENTS)
        .filter(|(c, _)| **c != 0.0)
        .map(|(c, (a, b))| c * monomial_moment(a + sa, b + sb))
        .sum()
}

/// The DOFs of a polynomial field, evaluated exactly.
fn polynomial_dofs(order: RtOrder, f: &[Poly; 2]) -> Vec<f64> {
    let mut d = Vec::with_capacity(order.dofs());
    for (e, nu) in REFERENCE_FLUX_NORMALS.iter().enumerate() {
        for &s in order.edge_points() {
            let m = monomials(edge_reference_point(e, s));
            d.push(eval(&f[0], &m, TERMS) * nu[0] + eval(&f[1], &m, TERMS) * nu[1]);
        }
    }
    for i in 0..order.interior_dofs() {
        d.push(polynomial_moment(&f[i % 2], i / 2));
    }
    d
}

/// The inverse of the n × n matrix `a` by Gauss–Jordan elimination with partial pivoting.
fn invert(mut a: Vec<Vec<f64>>) -> Vec<Vec<f64>> {
    let n = a.len();
    let mut inv: Vec<Vec<f64>> = (0..n)
        .map(|i| (0..n).map(|j| if i == j { 1.0 } else { 0.0 }).collect())
        .collect();
    for c in 0..n {
        let p = (c..n)
            .max_by(|&i, &j| a[i][c].abs().total_cmp(&a[j][c].abs()))
            .expect("non-empty column");
        assert!(a[p][c].abs() > 1e-12, "RT DOF matrix is singular");
        a.swap(c, p);
        inv.swap(c, p);
        let r = 1.0 / a[c][c];
        for j in 0..n {
            a[c][j] *= r;
            inv[c][j] *= r;
        }
        for i in 0..n {
            if i != c && a[i][c] != 0.0 {
                let f = a[i][c];
                for j in 0..n {
                    a[i][j] -= f * a[c][j];
                    inv[i][j] -= f * inv[c][j];
                }
            }
        }
    }
    inv
}

/// φ_j = Σ_m C_mj m_m with C = D⁻¹, D_im = DOF_i(m_m): then DOF_i(φ_j) = (D C)_ij = δ_ij.
fn build(order: RtOrder) -> NodalBasis {
    let mono = monomial_basis(order);
    let n = mono.len();
    debug_assert_eq!(n, order.dofs());
    let columns: Vec<Vec<f64>> = mono.iter().map(|m| polynomial_dofs(order, m)).collect();
    let d: Vec<Vec<f64>> = (0..n)
        .map(|i| (0..n).map(|m| columns[m][i]).collect())
        .collect();
    let c = invert(d);
    let mut values = [[[0.0; TERMS]; 2]; MAX_RT_DOFS];
    let mut divergence = [[0.0; TERMS]; MAX_RT_DOFS];
    for j in 0..n {
        for (m, field) in mono.iter().enumerate() {
            for comp in 0..2 {
                for q in 0..TERMS {
                    values[j][comp][q] += c[m][j] * field[comp][q];
                }
            }
        }
        // ∂φ_x/∂ξ + ∂φ_y/∂η, term by term.
        let [px, py] = values[j];
        for (q, &(a, b)) in EXPONENTS.iter().enumerate() {
            if a > 0 {
                divergence[j][monomial_index(a - 1, b)] += a as f64 * px[q];
            }
            if b > 0 {
                divergence[j][monomial_index(a, b - 1)] += b as f64 * py[q];
            }
        }
    }
    let k = order.k();
    NodalBasis {
        n,
        value_terms: (k + 2) * (k + 3) / 2,
        divergence_terms: (k + 1) * (k + 2) / 2,
        values,
        divergence,
    }
}

fn basis(order: RtOrder) -> &'static NodalBasis {
    static RT0: OnceLock<NodalBasis> = OnceLock::new();
    static RT1: OnceLock<NodalBasis> = OnceLock::new();
    static RT2: OnceLock<NodalBasis> = OnceLock::new();
    match order {
        RtOrder::Rt0 => RT0.get_or_init(|| build(RtOrder::Rt0)),
        RtOrder::Rt1 => RT1.get_or_init(|| build(RtOrder::Rt1)),
        RtOrder::Rt2 => RT2.get_or_init(|| build(RtOrder::Rt2)),
    }
}

/// Reference values φ̂_j(ξ) and divergences div̂ φ̂_j(ξ) of the nodal basis at `xi`.
#[inline]
pub fn reference(order: RtOrder, xi: [f64; 2]) -> ([[f64; 2]; MAX_RT_DOFS], [f64; MAX_RT_DOFS]) {
    let b = basis(order);
    let m = monomials(xi);
    let mut v = [[0.0; 2]; MAX_RT_DOFS];
    let mut d = [0.0; MAX_RT_DOFS];
    // Fixed term counts per order, so that the sums unroll and the CPU overlaps them (with a
    // run-time count each was a chain of dependent adds: RT_2 took ~2600 instructions per
    // point, ~5 % of the F and bound stages).
    fn fill<const NV: usize, const ND: usize>(
        b: &NodalBasis,
        m: &Poly,
        v: &mut [[f64; 2]; MAX_RT_DOFS],
        d: &mut [f64; MAX_RT_DOFS],
    ) {
        debug_assert_eq!((b.value_terms, b.divergence_terms), (NV, ND));
        for j in 0..b.n {
            v[j] = [
                eval_fixed::<NV>(&b.values[j][0], m),
                eval_fixed::<NV>(&b.values[j][1], m),
            ];
            d[j] = eval_fixed::<ND>(&b.divergence[j], m);
        }
    }
    // (k + 2)(k + 3)/2 value terms and (k + 1)(k + 2)/2 divergence terms.
    match order {
        RtOrder::Rt0 => fill::<3, 1>(b, &m, &mut v, &mut d),
        RtOrder::Rt1 => fill::<6, 3>(b, &m, &mut v, &mut d),
        RtOrder::Rt2 => fill::<10, 6>(b, &m, &mut v, &mut d),
    }
    (v, d)
}

/// Reference values φ̂_j(ξ) of the nodal basis at `xi` (DOF order of the module doc; slots
/// ≥ `order.dofs()` are 0).
#[inline]
pub fn reference_values(order: RtOrder, xi: [f64; 2]) -> [[f64; 2]; MAX_RT_DOFS] {
    reference(order, xi).0
}

/// Reference divergences div̂ φ̂_j(ξ) = ∂φ̂_x/∂ξ + ∂φ̂_y/∂η at `xi` (polynomials of degree k).
#[inline]
pub fn reference_divergence(order: RtOrder, xi: [f64; 2]) -> [f64; MAX_RT_DOFS] {
    reference(order, xi).1
}

/// The contravariant Piola map at one point, given the Jacobian there: values J φ̂_j / det J
/// and divergences div̂ φ̂_j / det J at x(ξ), valid for straight and curved cells (the
/// divergence identity holds for any smooth map).
#[inline]
pub fn piola(
    order: RtOrder,
    jac: &Jacobian,
    xi: [f64; 2],
) -> ([[f64; 2]; MAX_RT_DOFS], [f64; MAX_RT_DOFS]) {
    piola_of(&reference(order, xi), jac)
}

/// [`piola`] of reference values already evaluated (`reference(order, ξ)`, e.g. tabulated at
/// fixed points). The only place where the map is written.
#[inline]
pub fn piola_of(
    reference: &([[f64; 2]; MAX_RT_DOFS], [f64; MAX_RT_DOFS]),
    jac: &Jacobian,
) -> ([[f64; 2]; MAX_RT_DOFS], [f64; MAX_RT_DOFS]) {
    let (v, d) = reference;
    let r = 1.0 / jac.det;
    let [[a, b], [c, e]] = jac.matrix;
    (
        v.map(|[p, q]| [(a * p + b * q) * r, (c * p + e * q) * r]),
        d.map(|d| d * r),
    )
}

/// The combinations Σ_i c_ri φ_i (rows r = 0, 1, the first `n` functions) and their
/// divergences at a point, from the reference values there (`reference(order, ξ)`): the map
/// of [`piola_of`] is linear, so the reference combination is mapped once, J (Σ c_ri φ̂_i) / det J
/// and (Σ c_ri div̂ φ̂_i) / det J, instead of every basis function (half the products, and no
/// 360-byte table of mapped values per point: the bound and F evaluate a stress this way at
/// every quadrature point). Returns (σ_r0, σ_r1 for r = 0, 1 flattened, div σ_r).
#[inline]
pub fn piola_combination(
    reference: &([[f64; 2]; MAX_RT_DOFS], [f64; MAX_RT_DOFS]),
    jac: &Jacobian,
    c: &[[f64; MAX_RT_DOFS]; 2],
    n: usize,
) -> ([f64; 4], [f64; 2]) {
    let (v, d) = reference;
    let mut h = [[0.0; 2]; 2];
    let mut div = [0.0; 2];
    for i in 0..n {
        for r in 0..2 {
            h[r][0] += c[r][i] * v[i][0];
            h[r][1] += c[r][i] * v[i][1];
            div[r] += c[r][i] * d[i];
        }
    }
    let r = 1.0 / jac.det;
    let [[a, b], [cc, e]] = jac.matrix;
    let map = |[p, q]: [f64; 2]| [(a * p + b * q) * r, (cc * p + e * q) * r];
    let [s0, s1] = h.map(map);
    ([s0[0], s0[1], s1[0], s1[1]], [div[0] * r, div[1] * r])
}

/// Physical values φ_j(x(ξ)) = J φ̂_j / det J, divergences div φ_j = div̂ φ̂_j / det J, and
/// det J at reference point `xi` of the cell with 3 (straight) or 6 (curved, VTK order) node
/// coordinates `nodes`. Panics for any other number of nodes.
#[inline]
pub fn physical(
    order: RtOrder,
    nodes: &[[f64; 2]],
    xi: [f64; 2],
) -> ([[f64; 2]; MAX_RT_DOFS], [f64; MAX_RT_DOFS], f64) {
    let jac = cell_map(nodes).jacobian(xi);
    let (v, d) = piola(order, &jac, xi);
    (v, d, jac.det)
}

fn cell_map(nodes: &[[f64; 2]]) -> CellMap {
    CellMap::from_nodes(nodes)
        .unwrap_or_else(|| panic!("an RT cell has 3 or 6 nodes, not {}", nodes.len()))
}

/// R t = (t_y, −t_x): the scaled outward normal n |x'(s)| of an edge with tangent t = x'(s)
/// (counter-clockwise cell, local edge direction). The edge DOF of a physical field σ is
/// σ(x(s)) · R x'(s).
#[inline]
pub fn edge_flux_normal(t: [f64; 2]) -> [f64; 2] {
    [t[1], -t[0]]
}

/// Weights w_i(s) with q_e(s) = Σ_i w_i(s) c_{edge_dof(e, i)}: the flux density per unit of s
/// on local edge e of the field Σ_j c_j φ_j (interior functions and the other edges' functions
/// have zero normal trace on edge e): the Lagrange basis of degree k in s at
/// [`RtOrder::edge_points`]. RT_0: `[1]`; RT_1: `[1 − s, s]`; RT_2:
/// `[(1 − s)(1 − 2s), 4s(1 − s), s(2s − 1)]`. The physical normal trace is q_e(s) / |x'(s)|.
/// Unused slots 0.
#[inline]
pub fn edge_trace_weights(order: RtOrder, s: f64) -> [f64; 3] {
    match order {
        RtOrder::Rt0 => [1.0, 0.0, 0.0],
        RtOrder::Rt1 => [1.0 - s, s, 0.0],
        RtOrder::Rt2 => [
            (1.0 - s) * (1.0 - 2.0 * s),
            4.0 * s * (1.0 - s),
            s * (2.0 * s - 1.0),
        ],
    }
}

/// The DOFs of a physical field σ on the cell with 3 or 6 nodes `nodes` (the interpolant is
/// Σ_j c_j φ_j). `f(ξ, x(ξ))` returns σ at the point x(ξ). Edge DOFs: σ(x(s)) · R x'(s) at the
/// edge points, with x'(s) = J(ξ(s)) t̂_e; interior moments (RT_1, RT_2): ∫_T̂ (adj(J) σ(x(ξ)))_c
/// q_m(ξ) dξ (the inverse Piola map, adj J = det J · J⁻¹; q_m ∈ {1, ξ, η} as in the module doc),
/// by the triangle rule of degree [`INTERPOLATION_DEGREE`]: exact when adj(J) σ(x(ξ)) q_m is a
/// polynomial of degree ≤ 10 (any σ of degree ≤ 4 in x on a curved cell, ≤ 9 on a straight
/// one; the Piola image of any RT_2 field on any cell). Panics for a node count other than 3
/// or 6.
pub fn interpolate(
    order: RtOrder,
    nodes: &[[f64; 2]],
    mut f: impl FnMut([f64; 2], [f64; 2]) -> [f64; 2],
) -> [f64; MAX_RT_DOFS] {
    let map = cell_map(nodes);
    let mut c = [0.0; MAX_RT_DOFS];
    for (e, t_hat) in REFERENCE_EDGE_TANGENTS.iter().enumerate() {
        for (slot, &s) in order.edge_points().iter().enumerate() {
            let xi = edge_reference_point(e, s);
            let j = map.jacobian(xi).matrix;
            let t = [
                j[0][0] * t_hat[0] + j[0][1] * t_hat[1],
                j[1][0] * t_hat[0] + j[1][1] * t_hat[1],
            ];
            let sigma = f(xi, map.position(xi));
            let nu = edge_flux_normal(t);
            c[order.edge_dof(e, slot)] = sigma[0] * nu[0] + sigma[1] * nu[1];
        }
    }
    let nint = order.interior_dofs();
    if nint > 0 {
        let rule = triangle_rule_cached(INTERPOLATION_DEGREE);
        let mut m = [0.0; 6];
        for (&xi, &w) in rule.points.iter().zip(&rule.weights) {
            // adj J = [[J11, −J01], [−J10, J00]].
            let [[j00, j01], [j10, j11]] = map.jacobian(xi).matrix;
            let s = f(xi, map.position(xi));
            let a = [j11 * s[0] - j01 * s[1], -j10 * s[0] + j00 * s[1]];
            for (i, mi) in m.iter_mut().enumerate().take(nint) {
                *mi += w * moment_weight(i / 2, xi) * a[i % 2];
            }
        }
        for (i, &mi) in m.iter().enumerate().take(nint) {
            c[order.interior_dof(i)] = mi;
        }
    }
    c
}

/// How the DOFs of a cell's local edge `local_edge` relate to the DOFs of the global edge:
/// yields `(local DOF index, global slot on the edge, sign)` for each edge DOF, with
/// local coefficient = sign × global coefficient of that slot.
///
/// `forward` is true when the local edge (vertex e → vertex e + 1) runs in the global direction
/// a → b, a < b (`cell_edge_sign[t][e] > 0` in [`crate::topology::Topology`]): then local slot i
/// is global slot i with sign +1. Otherwise the local DOF at s is minus the global DOF at 1 − s
/// (normal flipped, parameter reversed): local slot i is global slot `edge_dofs − 1 − i` with
/// sign −1.
pub fn local_to_global_edge(
    order: RtOrder,
    local_edge: usize,
    forward: bool,
) -> impl Iterator<Item = (usize, usize, f64)> {
    let n = order.edge_dofs();
    (0..n).map(move |slot| {
        let local = order.edge_dof(local_edge, slot);
        if forward {
            (local, slot, 1.0)
        } else {
            (local, n - 1 - slot, -1.0)
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::edge::{EDGE_NODES, REFERENCE_NORMALS};
    use crate::geometry::map::{LinearTriangle, QuadraticTriangle};
    use crate::quadrature::{line_rule, triangle_rule};

    const ORDERS: [RtOrder; 3] = [RtOrder::Rt0, RtOrder::Rt1, RtOrder::Rt2];
    const REFERENCE_NODES: [[f64; 2]; 3] = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]];

    fn sample_points() -> Vec<[f64; 2]> {
        let mut points = vec![[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0 / 3.0, 1.0 / 3.0]];
        for i in 0..=6 {
            for j in 0..=(6 - i) {
                points.push([i as f64 / 6.0 * 0.98 + 0.01, j as f64 / 6.0 * 0.97]);
            }
        }
        points
    }

    fn assert_close(a: f64, b: f64, tol: f64, what: &str) {
        assert!(
            (a - b).abs() <= tol,
            "{what}: {a} vs {b} (diff {:e})",
            (a - b).abs()
        );
    }

    /// Tolerance factor for round-off-scale checks: the RT_2 basis has values and
    /// divergences in the hundreds (the interior moment functions), so cancellation costs about
    /// two digits more than for RT_0 and RT_1; and its third derivatives are large, which
    /// enters central differences as O(H²).
    fn scale(order: RtOrder) -> f64 {
        match order {
            RtOrder::Rt0 | RtOrder::Rt1 => 1.0,
            RtOrder::Rt2 => 100.0,
        }
    }

    fn straight_cell() -> [[f64; 2]; 3] {
        [[0.2, -0.3], [1.1, 0.4], [-0.4, 0.9]]
    }

    /// A curved cell: a general triangle with all three mid nodes moved off their chords.
    fn curved_cell() -> [[f64; 2]; 6] {
        let v = [[0.2, -0.1], [1.7, 0.3], [0.5, 1.4]];
        let mut t = QuadraticTriangle::from_linear(&LinearTriangle::new(v));
        t.nodes[3][1] -= 0.12;
        t.nodes[4][0] += 0.08;
        t.nodes[4][1] += 0.05;
        t.nodes[5][0] -= 0.1;
        t.nodes[5][1] += 0.03;
        t.nodes
    }

    /// Σ_j c_j v_j.
    fn combine(c: &[f64; MAX_RT_DOFS], v: &[[f64; 2]; MAX_RT_DOFS]) -> [f64; 2] {
        let mut s = [0.0; 2];
        for (cj, vj) in c.iter().zip(v) {
            s[0] += cj * vj[0];
            s[1] += cj * vj[1];
        }
        s
    }

    /// ξ with x(ξ) = x, by Newton's method from the centroid.
    fn inverse_map(nodes: &[[f64; 2]], x: [f64; 2]) -> [f64; 2] {
        let map = CellMap::from_nodes(nodes).unwrap();
        let mut xi = [1.0 / 3.0, 1.0 / 3.0];
        for _ in 0..50 {
            let p = map.position(xi);
            let r = [x[0] - p[0], x[1] - p[1]];
            let inv = map.jacobian(xi).inverse;
            let d = [
                inv[0][0] * r[0] + inv[0][1] * r[1],
                inv[1][0] * r[0] + inv[1][1] * r[1],
            ];
            xi = [xi[0] + d[0], xi[1] + d[1]];
            if d[0].hypot(d[1]) < 1e-16 {
                break;
            }
        }
        xi
    }

    /// The mapped combination equals the combination of the mapped functions (`piola_of`), on a
    /// skewed straight cell, to round-off of the terms' magnitudes.
    #[test]
    fn mapped_combination_is_the_combination_of_mapped_functions() {
        let verts = [[0.3, -0.2], [2.1, 0.4], [0.9, 1.7]];
        let map = LinearTriangle::new(verts);
        for order in ORDERS {
            let n = order.dofs();
            let c: [[f64; MAX_RT_DOFS]; 2] = std::array::from_fn(|r| {
                std::array::from_fn(|i| ((3 * i + 7 * r) % 11) as f64 / 5.0 - 1.0)
            });
            for xi in sample_points() {
                let jac = map.jacobian();
                let reference = reference(order, xi);
                let (s, div) = piola_combination(&reference, &jac, &c, n);
                let (v, d) = piola_of(&reference, &jac);
                for r in 0..2 {
                    let (mut want, mut size) = ([0.0; 3], 0.0f64);
                    for i in 0..n {
                        want[0] += c[r][i] * v[i][0];
                        want[1] += c[r][i] * v[i][1];
                        want[2] += c[r][i] * d[i];
                        size = size.max((c[r][i] * v[i][0]).abs() + (c[r][i] * v[i][1]).abs());
                        size = size.max((c[r][i] * d[i]).abs());
                    }
                    let tol = 1e-13 * size * n as f64;
                    assert_close(s[2 * r], want[0], tol, "σ_r0");
                    assert_close(s[2 * r + 1], want[1], tol, "σ_r1");
                    assert_close(div[r], want[2], tol, "div σ_r");
                }
            }
        }
    }

    /// The fixed-length sums of `reference` are the run-time-length `eval` sums, term for term.
    #[test]
    fn fixed_sums_equal_the_general_ones() {
        for order in [RtOrder::Rt0, RtOrder::Rt1, RtOrder::Rt2] {
            let b = basis(order);
            for i in 0..=8 {
                for k in 0..=(8 - i) {
                    let xi = [i as f64 / 8.0 + 0.013, k as f64 / 8.0 - 0.007];
                    let m = monomials(xi);
                    let (v, d) = reference(order, xi);
                    for j in 0..b.n {
                        for (vc, poly) in v[j].iter().zip(&b.values[j]) {
                            assert_eq!(*vc, eval(poly, &m, b.value_terms));
                        }
                        assert_eq!(d[j], eval(&b.divergence[j], &m, b.divergence_terms));
                    }
                }
            }
        }
    }

    #[test]
    fn order_bookkeeping() {
        assert_eq!(RtOrder::Rt0.dofs(), RT0_DOFS);
        assert_eq!(RtOrder::Rt1.dofs(), RT1_DOFS);
        assert_eq!(RtOrder::Rt2.dofs(), RT2_DOFS);
        assert_eq!(MAX_RT_DOFS, RT2_DOFS);
        assert_eq!(RtOrder::Rt0.interior_dofs(), 0);
        assert_eq!(RtOrder::Rt1.interior_dofs(), 2);
        assert_eq!(RtOrder::Rt2.interior_dofs(), 6);
        assert_eq!(RtOrder::Rt2.k(), 2);
        assert_eq!(RtOrder::Rt2.edge_dofs(), 3);
        assert_eq!(RtOrder::Rt0.edge_points(), &[0.5]);
        assert_eq!(RtOrder::Rt1.edge_points(), &[0.0, 1.0]);
        assert_eq!(RtOrder::Rt2.edge_points(), &[0.0, 0.5, 1.0]);
        assert_eq!(RtOrder::Rt1.edge_dof(2, 1), 5);
        assert_eq!(RtOrder::Rt1.interior_dof(1), 7);
        assert_eq!(RtOrder::Rt0.edge_dof(2, 0), 2);
        assert_eq!(RtOrder::Rt2.edge_dof(2, 1), 7);
        assert_eq!(RtOrder::Rt2.interior_dof(0), 9);
        assert_eq!(RtOrder::Rt2.interior_dof(5), 14);
        for order in ORDERS {
            assert_eq!(3 * order.edge_dofs() + order.interior_dofs(), order.dofs());
            assert_eq!(order.edge_points().len(), order.edge_dofs());
            // The trace weights are the Lagrange basis at the edge points.
            for (i, &s) in order.edge_points().iter().enumerate() {
                let w = edge_trace_weights(order, s);
                for (l, &wl) in w.iter().enumerate() {
                    let want = if l == i { 1.0 } else { 0.0 };
                    assert_eq!(wl, want, "{order:?} w_{l}({s})");
                }
            }
            let pts = order.edge_points();
            for (i, &s) in pts.iter().enumerate() {
                assert_eq!(1.0 - s, pts[pts.len() - 1 - i], "edge points symmetric");
            }
            // Unused slots are zero.
            let (v, d) = reference(order, [0.3, 0.2]);
            for j in order.dofs()..MAX_RT_DOFS {
                assert_eq!(v[j], [0.0, 0.0]);
                assert_eq!(d[j], 0.0);
            }
        }
    }

    #[test]
    fn flux_normals_are_scaled_reference_normals() {
        for e in 0..3 {
            let (a, b) = (edge_reference_point(e, 0.0), edge_reference_point(e, 1.0));
            let t = [b[0] - a[0], b[1] - a[1]];
            assert_eq!(t, REFERENCE_EDGE_TANGENTS[e]);
            let len = t[0].hypot(t[1]);
            for c in 0..2 {
                assert_close(
                    REFERENCE_FLUX_NORMALS[e][c],
                    REFERENCE_NORMALS[e][c] * len,
                    1e-15,
                    "ν̂ = n̂ |dξ/ds|",
                );
            }
        }
    }

    /// The DOF functionals of the module doc, written independently of the basis construction:
    /// point values with n̂_e |ξ(1) − ξ(0)| and interior moments by quadrature.
    fn reference_dofs(order: RtOrder, f: impl Fn([f64; 2]) -> [f64; 2]) -> Vec<f64> {
        let mut d = Vec::new();
        for (e, n) in REFERENCE_NORMALS.iter().enumerate() {
            let (a, b) = (edge_reference_point(e, 0.0), edge_reference_point(e, 1.0));
            let len = (b[0] - a[0]).hypot(b[1] - a[1]);
            for &s in order.edge_points() {
                let v = f(edge_reference_point(e, s));
                d.push((v[0] * n[0] + v[1] * n[1]) * len);
            }
        }
        // Interior: ∫ φ̂_c q_m, m major, c minor; q = 1, ξ, η.
        let rule = triangle_rule(4);
        let q = [
            |_: [f64; 2]| 1.0,
            |xi: [f64; 2]| xi[0],
            |xi: [f64; 2]| xi[1],
        ];
        for i in 0..order.interior_dofs() {
            d.push(rule.integrate(|xi| f(xi)[i % 2] * q[i / 2](xi)));
        }
        d
    }

    #[test]
    fn reference_nodality() {
        for order in ORDERS {
            for j in 0..order.dofs() {
                let d = reference_dofs(order, |xi| reference_values(order, xi)[j]);
                for (i, &di) in d.iter().enumerate() {
                    let want = if i == j { 1.0 } else { 0.0 };
                    assert_close(di, want, 1e-12, &format!("{order:?} DOF {i} of φ{j}"));
                }
            }
        }
    }

    #[test]
    fn physical_nodality_on_straight_and_curved_cells() {
        let straight = straight_cell();
        let curved = curved_cell();
        let cells: [&[[f64; 2]]; 4] = [
            &REFERENCE_NODES,
            &straight,
            &QuadraticTriangle::from_linear(&LinearTriangle::new(straight)).nodes,
            &curved,
        ];
        for order in ORDERS {
            for nodes in cells {
                for j in 0..order.dofs() {
                    let c = interpolate(order, nodes, |xi, _| physical(order, nodes, xi).0[j]);
                    for (i, &ci) in c.iter().enumerate() {
                        let want = if i == j { 1.0 } else { 0.0 };
                        assert_close(ci, want, 1e-12, &format!("{order:?} DOF {i} of φ{j}"));
                    }
                }
            }
        }
    }

    /// The basis computed by sympy from the same DOF definition.
    #[test]
    fn basis_in_closed_form() {
        type Field = fn(f64, f64) -> [f64; 2];
        let rt0: [Field; 3] = [|x, y| [x, y - 1.0], |x, y| [x, y], |x, y| [x - 1.0, y]];
        const T: f64 = 1.0 / 3.0;
        let rt1: [Field; 8] = [
            |x, y| {
                [
                    T * (-4.0 * x * x - 8.0 * x * y + 4.0 * x),
                    T * (-4.0 * x * y - 8.0 * y * y + 11.0 * y) + x - 1.0,
                ]
            },
            |x, y| {
                [
                    T * (4.0 * x * x - 4.0 * x * y - x),
                    T * (4.0 * x * y - 4.0 * y * y + 4.0 * y) - x,
                ]
            },
            |x, y| {
                [
                    T * (8.0 * x * x + 4.0 * x * y - 5.0 * x),
                    T * (8.0 * x * y + 4.0 * y * y - 4.0 * y),
                ]
            },
            |x, y| {
                [
                    T * (4.0 * x * x + 8.0 * x * y - 4.0 * x),
                    T * (4.0 * x * y + 8.0 * y * y - 5.0 * y),
                ]
            },
            |x, y| {
                [
                    T * (-4.0 * x * x + 4.0 * x * y + 4.0 * x) - y,
                    T * (-4.0 * x * y + 4.0 * y * y - y),
                ]
            },
            |x, y| {
                [
                    T * (-8.0 * x * x - 4.0 * x * y + 11.0 * x) + y - 1.0,
                    T * (-8.0 * x * y - 4.0 * y * y + 4.0 * y),
                ]
            },
            |x, y| {
                [
                    -16.0 * x * x - 8.0 * x * y + 16.0 * x,
                    -16.0 * x * y - 8.0 * y * y + 8.0 * y,
                ]
            },
            |x, y| {
                [
                    -8.0 * x * x - 16.0 * x * y + 8.0 * x,
                    -8.0 * x * y - 16.0 * y * y + 16.0 * y,
                ]
            },
        ];
        for xi in sample_points() {
            let v0 = reference_values(RtOrder::Rt0, xi);
            for (j, f) in rt0.iter().enumerate() {
                let w = f(xi[0], xi[1]);
                for c in 0..2 {
                    assert_close(v0[j][c], w[c], 1e-15, "RT_0 closed form");
                }
            }
            let v1 = reference_values(RtOrder::Rt1, xi);
            for (j, f) in rt1.iter().enumerate() {
                let w = f(xi[0], xi[1]);
                for c in 0..2 {
                    assert_close(v1[j][c], w[c], 1e-13, "RT_1 closed form");
                }
            }
        }
    }

    #[test]
    fn reference_divergence_matches_finite_differences() {
        const H: f64 = 1e-5;
        for order in ORDERS {
            for xi in sample_points() {
                let d = reference_divergence(order, xi);
                let dx = |p: [f64; 2], m: [f64; 2], c: usize, j: usize| {
                    (reference_values(order, p)[j][c] - reference_values(order, m)[j][c])
                        / (2.0 * H)
                };
                for (j, &dj) in d.iter().enumerate().take(order.dofs()) {
                    let fd = dx([xi[0] + H, xi[1]], [xi[0] - H, xi[1]], 0, j)
                        + dx([xi[0], xi[1] + H], [xi[0], xi[1] - H], 1, j);
                    assert_close(dj, fd, 1e-9 * scale(order), &format!("{order:?} div φ̂{j}"));
                }
            }
        }
    }

    /// div φ at x(ξ) against central differences in x, with x ↦ ξ inverted by Newton.
    fn check_physical_divergence(nodes: &[[f64; 2]]) {
        const H: f64 = 1e-5;
        let map = CellMap::from_nodes(nodes).unwrap();
        for order in ORDERS {
            for xi in sample_points() {
                // Keep x ± H inside the cell's reference preimage well enough: shrink to the
                // interior (the map extends smoothly anyway).
                let xi = [0.05 + 0.9 * xi[0], 0.05 + 0.9 * xi[1]];
                let x = map.position(xi);
                let (_, div, det) = physical(order, nodes, xi);
                assert!(det > 0.0);
                let value = |x: [f64; 2]| physical(order, nodes, inverse_map(nodes, x)).0;
                let (xp, xm) = (value([x[0] + H, x[1]]), value([x[0] - H, x[1]]));
                let (yp, ym) = (value([x[0], x[1] + H]), value([x[0], x[1] - H]));
                for j in 0..order.dofs() {
                    let fd = (xp[j][0] - xm[j][0] + yp[j][1] - ym[j][1]) / (2.0 * H);
                    assert_close(
                        div[j],
                        fd,
                        1e-8 * scale(order),
                        &format!("{order:?} div φ{j}"),
                    );
                }
            }
        }
    }

    #[test]
    fn physical_divergence_matches_finite_differences() {
        check_physical_divergence(&straight_cell());
        check_physical_divergence(&curved_cell());
    }

    #[test]
    fn straight_six_node_cell_is_the_three_node_cell() {
        let lin = straight_cell();
        let quad = QuadraticTriangle::from_linear(&LinearTriangle::new(lin)).nodes;
        for order in ORDERS {
            for xi in sample_points() {
                let (vl, dl, jl) = physical(order, &lin, xi);
                let (vq, dq, jq) = physical(order, &quad, xi);
                assert_close(jl, jq, 1e-15, "det J");
                for j in 0..MAX_RT_DOFS {
                    assert_close(dl[j], dq[j], 1e-13 * scale(order), "div");
                    for c in 0..2 {
                        assert_close(vl[j][c], vq[j][c], 1e-13 * scale(order), "value");
                    }
                }
            }
        }
    }

    /// ∫_T div φ dx = Σ_e ∫_e φ · n dσ on a curved cell, with the edge geometry (normal, length
    /// element) from the edge maps; and the fluxes are those the DOFs prescribe.
    #[test]
    fn divergence_theorem_on_a_curved_cell() {
        let nodes = curved_cell();
        let cell = QuadraticTriangle::new(nodes);
        let area_rule = triangle_rule(8);
        let edge_rule = line_rule(8);
        for order in ORDERS {
            for j in 0..order.dofs() {
                let volume = area_rule.integrate(|xi| {
                    let (_, d, det) = physical(order, &nodes, xi);
                    d[j] * det
                });
                let mut boundary = 0.0;
                let mut fluxes = [0.0; 3];
                for (e, flux) in fluxes.iter_mut().enumerate() {
                    let edge = cell.edge(e);
                    *flux = edge_rule.integrate(|s| {
                        let v = physical(order, &nodes, edge_reference_point(e, s)).0[j];
                        let n = edge.normal(s);
                        (v[0] * n[0] + v[1] * n[1]) * edge.length_element(s)
                    });
                    boundary += *flux;
                }
                assert_close(volume, boundary, 1e-12, &format!("{order:?} φ{j}"));
                // Edge function of edge e, slot i: flux ∫ w_i(s) ds through e (RT_0: 1, RT_1: ½,
                // RT_2: 1/6, 2/3, 1/6), 0 elsewhere.
                for (e, &flux) in fluxes.iter().enumerate() {
                    let want = if j < 3 * order.edge_dofs() && j / order.edge_dofs() == e {
                        slot_flux(order, j % order.edge_dofs())
                    } else {
                        0.0
                    };
                    assert_close(flux, want, 1e-12, &format!("{order:?} flux of φ{j}"));
                }
            }
        }
    }

    /// ∫_0^1 w_i(s) ds, the total flux of the unit DOF at slot i ([`edge_trace_weights`]).
    fn slot_flux(order: RtOrder, i: usize) -> f64 {
        line_rule(4).integrate(|s| edge_trace_weights(order, s)[i])
    }

    #[test]
    fn slot_fluxes() {
        assert_close(slot_flux(RtOrder::Rt0, 0), 1.0, 1e-15, "RT_0");
        for i in 0..2 {
            assert_close(slot_flux(RtOrder::Rt1, i), 0.5, 1e-15, "RT_1");
        }
        for (i, want) in [1.0 / 6.0, 2.0 / 3.0, 1.0 / 6.0].into_iter().enumerate() {
            assert_close(slot_flux(RtOrder::Rt2, i), want, 1e-15, "RT_2");
        }
    }

    /// On T̂: ∫_T̂ div̂ φ̂_j = Σ_e ∫_0^1 q_e(s) ds (divergence theorem), with the edge fluxes
    /// those the DOFs prescribe (the nodal basis is dual to the point-value DOFs).
    #[test]
    fn reference_divergence_consistency() {
        let rule = triangle_rule(6);
        for order in ORDERS {
            for j in 0..order.dofs() {
                let volume = rule.integrate(|xi| reference_divergence(order, xi)[j]);
                let mut boundary = 0.0;
                for (e, nu) in REFERENCE_FLUX_NORMALS.iter().enumerate() {
                    boundary += line_rule(6).integrate(|s| {
                        let v = reference_values(order, edge_reference_point(e, s))[j];
                        v[0] * nu[0] + v[1] * nu[1]
                    });
                }
                let want = if j < 3 * order.edge_dofs() {
                    slot_flux(order, j % order.edge_dofs())
                } else {
                    0.0
                };
                assert_close(volume, boundary, 1e-12, &format!("{order:?} φ̂{j}"));
                assert_close(volume, want, 1e-12, &format!("{order:?} ∫div φ̂{j}"));
            }
        }
    }

    /// φ_j(x(s)) · n |x'(s)| on the edges of a curved cell is the DOF-interpolating trace
    /// ([`edge_trace_weights`]): linear in s for RT_1, and zero for interior functions.
    #[test]
    fn normal_traces_on_a_curved_cell() {
        let nodes = curved_cell();
        let cell = QuadraticTriangle::new(nodes);
        for order in ORDERS {
            for e in 0..3 {
                let edge = cell.edge(e);
                for k in 0..=10 {
                    let s = k as f64 / 10.0;
                    let v = physical(order, &nodes, edge_reference_point(e, s)).0;
                    let n = edge.normal(s);
                    let w = edge_trace_weights(order, s);
                    for (j, vj) in v.iter().enumerate().take(order.dofs()) {
                        let q = (vj[0] * n[0] + vj[1] * n[1]) * edge.length_element(s);
                        let want = (0..order.edge_dofs())
                            .find(|&i| order.edge_dof(e, i) == j)
                            .map_or(0.0, |i| w[i]);
                        assert_close(
                            q,
                            want,
                            1e-13 * scale(order),
                            &format!("{order:?} edge {e} φ{j}"),
                        );
                    }
                }
            }
        }
    }

    /// Two cells share a curved edge A → B (global vertices 0 < 1): cell 1 runs it forwards as
    /// its local edge 0, cell 2 backwards as its local edge 1. A global function assembled with
    /// [`local_to_global_edge`] has the same physical normal trace on both sides.
    #[test]
    fn normal_continuity_across_a_shared_curved_edge() {
        let (a, b, m) = ([0.0, 0.0], [1.0, 0.0], [0.5, 0.12]);
        let (c, d) = ([0.3, 0.9], [0.6, -0.8]);
        let mid = |p: [f64; 2], q: [f64; 2], off: [f64; 2]| {
            [0.5 * (p[0] + q[0]) + off[0], 0.5 * (p[1] + q[1]) + off[1]]
        };
        // Cell 1: A, B, C (edge 0 = A → B, forward).
        let cell1 = [a, b, c, m, mid(b, c, [0.04, 0.02]), mid(c, a, [-0.03, 0.0])];
        // Cell 2: D, B, A (edge 1 = B → A, backward).
        let cell2 = [
            d,
            b,
            a,
            mid(d, b, [0.03, -0.02]),
            m,
            mid(a, d, [-0.04, 0.01]),
        ];
        let (e1, e2) = (0, 1);
        for order in ORDERS {
            let n_edge = order.edge_dofs();
            let global: Vec<f64> = (0..n_edge).map(|i| 0.7 - 1.9 * i as f64).collect();
            // Unrelated DOFs of the two cells: arbitrary, different.
            let mut c1 = [0.0; MAX_RT_DOFS];
            let mut c2 = [0.0; MAX_RT_DOFS];
            for j in 0..order.dofs() {
                c1[j] = 0.3 + 0.2 * j as f64;
                c2[j] = -0.5 + 0.37 * j as f64;
            }
            for (local, slot, sign) in local_to_global_edge(order, e1, true) {
                c1[local] = sign * global[slot];
            }
            for (local, slot, sign) in local_to_global_edge(order, e2, false) {
                c2[local] = sign * global[slot];
            }
            let edge = QuadraticTriangle::new(cell1).edge(e1);
            for k in 0..=12 {
                let t = k as f64 / 12.0;
                let xi1 = edge_reference_point(e1, t);
                let xi2 = edge_reference_point(e2, 1.0 - t);
                let (v1, _, det1) = physical(order, &cell1, xi1);
                let (v2, _, det2) = physical(order, &cell2, xi2);
                assert!(det1 > 0.0 && det2 > 0.0);
                let (x1, x2) = (
                    CellMap::from_nodes(&cell1).unwrap().position(xi1),
                    CellMap::from_nodes(&cell2).unwrap().position(xi2),
                );
                assert_close(x1[0], x2[0], 1e-15, "same point x");
                assert_close(x1[1], x2[1], 1e-15, "same point y");
                // Global normal: to the right of A → B, outward of cell 1.
                let n = edge.normal(t);
                let (s1, s2) = (combine(&c1, &v1), combine(&c2, &v2));
                let tn1 = s1[0] * n[0] + s1[1] * n[1];
                let tn2 = s2[0] * n[0] + s2[1] * n[1];
                assert_close(
                    tn1,
                    tn2,
                    1e-13 * scale(order),
                    &format!("{order:?} σ·n at t = {t}"),
                );
                // And it is the global DOF trace over |x'(t)|.
                let w = edge_trace_weights(order, t);
                let q: f64 = (0..n_edge).map(|i| w[i] * global[i]).sum();
                assert_close(
                    tn1,
                    q / edge.length_element(t),
                    1e-13 * scale(order),
                    "trace = q/|x'|",
                );
            }
        }
    }

    #[test]
    fn local_to_global_edge_tables() {
        let f: Vec<_> = local_to_global_edge(RtOrder::Rt1, 2, true).collect();
        assert_eq!(f, vec![(4, 0, 1.0), (5, 1, 1.0)]);
        let b: Vec<_> = local_to_global_edge(RtOrder::Rt1, 1, false).collect();
        assert_eq!(b, vec![(2, 1, -1.0), (3, 0, -1.0)]);
        let b: Vec<_> = local_to_global_edge(RtOrder::Rt0, 1, false).collect();
        assert_eq!(b, vec![(1, 0, -1.0)]);
        let f: Vec<_> = local_to_global_edge(RtOrder::Rt2, 2, true).collect();
        assert_eq!(f, vec![(6, 0, 1.0), (7, 1, 1.0), (8, 2, 1.0)]);
        let b: Vec<_> = local_to_global_edge(RtOrder::Rt2, 1, false).collect();
        assert_eq!(b, vec![(3, 2, -1.0), (4, 1, -1.0), (5, 0, -1.0)]);
        // Reversal pairs s with 1 − s.
        for order in ORDERS {
            let pts = order.edge_points();
            for (local, slot, _) in local_to_global_edge(order, 0, false) {
                assert_eq!(pts[local], 1.0 - pts[slot]);
            }
        }
        assert_eq!(EDGE_NODES[1][0], 1);
    }

    /// Interpolates `f` on `nodes` and compares the interpolant with `f` at sample points.
    fn check_reproduction(
        order: RtOrder,
        nodes: &[[f64; 2]],
        f: impl Fn([f64; 2]) -> [f64; 2],
        tol: f64,
    ) {
        let map = CellMap::from_nodes(nodes).unwrap();
        let c = interpolate(order, nodes, |_, x| f(x));
        for xi in sample_points() {
            let x = map.position(xi);
            let v = combine(&c, &physical(order, nodes, xi).0);
            let want = f(x);
            for k in 0..2 {
                assert_close(v[k], want[k], tol, &format!("{order:?} at {x:?}"));
            }
        }
    }

    #[test]
    fn interpolation_reproduces_rt_fields_on_straight_cells() {
        let straight = straight_cell();
        let quad = QuadraticTriangle::from_linear(&LinearTriangle::new(straight)).nodes;
        for nodes in [&REFERENCE_NODES[..], &straight[..], &quad[..]] {
            // RT_0 = {a + b x}; contained in RT_1.
            for order in ORDERS {
                check_reproduction(
                    order,
                    nodes,
                    |x| [0.7 - 0.4 * x[0], -1.3 - 0.4 * x[1]],
                    1e-13,
                );
                check_reproduction(order, nodes, |_| [2.0, -0.5], 1e-13);
            }
            // RT_1 = P_1² + x P̃_1.
            let p1 = |x: [f64; 2]| {
                [
                    0.3 + 1.2 * x[0] - 0.7 * x[1],
                    -0.9 + 0.4 * x[0] + 2.1 * x[1],
                ]
            };
            check_reproduction(RtOrder::Rt1, nodes, p1, 1e-13);
            let rt1 = |x: [f64; 2]| {
                let h = 0.8 * x[0] - 1.1 * x[1];
                let p = p1(x);
                [p[0] + x[0] * h, p[1] + x[1] * h]
            };
            check_reproduction(RtOrder::Rt1, nodes, rt1, 1e-13);
            check_reproduction(RtOrder::Rt2, nodes, p1, 1e-12);
            check_reproduction(RtOrder::Rt2, nodes, rt1, 1e-12);
            // RT_2 = P_2² + x P̃_2.
            let p2 = |x: [f64; 2]| {
                let q = p1(x);
                [
                    q[0] + 0.6 * x[0] * x[0] - 1.4 * x[0] * x[1] + 0.9 * x[1] * x[1],
                    q[1] - 0.8 * x[0] * x[0] + 0.3 * x[0] * x[1] + 1.7 * x[1] * x[1],
                ]
            };
            check_reproduction(RtOrder::Rt2, nodes, p2, 1e-12);
            let rt2 = |x: [f64; 2]| {
                let h = 1.3 * x[0] * x[0] - 0.5 * x[0] * x[1] - 0.9 * x[1] * x[1];
                let p = p2(x);
                [p[0] + x[0] * h, p[1] + x[1] * h]
            };
            check_reproduction(RtOrder::Rt2, nodes, rt2, 1e-12);
            // Each of ξ (ξ², ξη, η²)-type fields alone.
            type Field = fn([f64; 2]) -> [f64; 2];
            let cubic: [Field; 3] = [
                |x| [x[0] * x[0] * x[0], x[0] * x[0] * x[1]],
                |x| [x[0] * x[0] * x[1], x[0] * x[1] * x[1]],
                |x| [x[0] * x[1] * x[1], x[1] * x[1] * x[1]],
            ];
            for f in cubic {
                check_reproduction(RtOrder::Rt2, nodes, f, 1e-12);
            }
        }
    }

    /// Every field of RT_k on any cell (straight or curved) is the Piola image of a reference
    /// field in RT_k(T̂): each monomial basis field and a combination of all of them is
    /// reproduced by `interpolate` (DOFs, then the nodal basis) to round-off.
    #[test]
    fn interpolation_reproduces_piola_images_on_all_cells() {
        let straight = straight_cell();
        let curved = curved_cell();
        let cells: [&[[f64; 2]]; 4] = [
            &REFERENCE_NODES,
            &straight,
            &QuadraticTriangle::from_linear(&LinearTriangle::new(straight)).nodes,
            &curved,
        ];
        for order in ORDERS {
            let mono = monomial_basis(order);
            let n = mono.len();
            // The fields: each monomial, then Σ_m (0.3 + 0.17 m)(−1)^m m-th monomial.
            let mut fields: Vec<Vec<f64>> = (0..n)
                .map(|m| (0..n).map(|l| if l == m { 1.0 } else { 0.0 }).collect())
                .collect();
            fields.push(
                (0..n)
                    .map(|m| (0.3 + 0.17 * m as f64) * if m % 2 == 0 { 1.0 } else { -1.0 })
                    .collect(),
            );
            let reference_field = |a: &[f64], xi: [f64; 2]| {
                let mv = monomials(xi);
                let mut v = [0.0; 2];
                for (am, field) in a.iter().zip(&mono) {
                    v[0] += am * eval(&field[0], &mv, TERMS);
                    v[1] += am * eval(&field[1], &mv, TERMS);
                }
                v
            };
            for nodes in cells {
                let map = CellMap::from_nodes(nodes).unwrap();
                let piola_field = |a: &[f64], xi: [f64; 2]| {
                    let jac = map.jacobian(xi);
                    let [p, q] = reference_field(a, xi);
                    let [[j00, j01], [j10, j11]] = jac.matrix;
                    [(j00 * p + j01 * q) / jac.det, (j10 * p + j11 * q) / jac.det]
                };
                for a in &fields {
                    let c = interpolate(order, nodes, |xi, _| piola_field(a, xi));
                    for xi in sample_points() {
                        let v = combine(&c, &physical(order, nodes, xi).0);
                        let want = piola_field(a, xi);
                        for k in 0..2 {
                            assert_close(v[k], want[k], 1e-12, &format!("{order:?} at {xi:?}"));
                        }
                    }
                }
            }
        }
    }

    /// RT_0 ⊂ RT_1 ⊂ RT_2 on a curved cell: each lower-order function is reproduced.
    #[test]
    fn lower_orders_are_contained_in_higher_ones() {
        let curved = curved_cell();
        let pairs = [
            (RtOrder::Rt0, RtOrder::Rt1),
            (RtOrder::Rt0, RtOrder::Rt2),
            (RtOrder::Rt1, RtOrder::Rt2),
        ];
        for (low, high) in pairs {
            for j in 0..low.dofs() {
                let c = interpolate(high, &curved, |xi, _| physical(low, &curved, xi).0[j]);
                for xi in sample_points() {
                    let v0 = physical(low, &curved, xi).0[j];
                    let v1 = combine(&c, &physical(high, &curved, xi).0);
                    for k in 0..2 {
                        assert_close(v1[k], v0[k], 1e-12, &format!("{low:?} φ{j} in {high:?}"));
                    }
                }
            }
        }
    }

    /// The normal trace of a general RT_2 function on each edge of a curved cell is the
    /// quadratic through its three edge DOFs: q_e(s) at s = 0, ½, 1 is the DOF, and q_e at
    /// other s is the quadratic interpolant of those three values.
    #[test]
    fn rt2_normal_trace_is_the_quadratic_through_the_dofs() {
        let order = RtOrder::Rt2;
        let nodes = curved_cell();
        let cell = QuadraticTriangle::new(nodes);
        let mut c = [0.0; MAX_RT_DOFS];
        for (j, cj) in c.iter_mut().enumerate().take(order.dofs()) {
            *cj = (1.0 + j as f64).sin() * 2.0 - 0.3;
        }
        for e in 0..3 {
            let edge = cell.edge(e);
            let q = |s: f64| {
                let v = combine(&c, &physical(order, &nodes, edge_reference_point(e, s)).0);
                let n = edge.normal(s);
                (v[0] * n[0] + v[1] * n[1]) * edge.length_element(s)
            };
            let dofs: Vec<f64> = (0..3).map(|i| c[order.edge_dof(e, i)]).collect();
            for (i, &s) in order.edge_points().iter().enumerate() {
                assert_close(q(s), dofs[i], 1e-12, &format!("edge {e} DOF {i}"));
            }
            for k in 0..=20 {
                let s = k as f64 / 20.0;
                let (l0, l1, l2) = (
                    (1.0 - s) * (1.0 - 2.0 * s),
                    4.0 * s * (1.0 - s),
                    s * (2.0 * s - 1.0),
                );
                let want = l0 * dofs[0] + l1 * dofs[1] + l2 * dofs[2];
                assert_close(q(s), want, 1e-12, &format!("edge {e} at s = {s}"));
            }
        }
    }

    #[test]
    fn interpolation_does_not_reproduce_outside_the_space() {
        // RT_0 cannot hold a general P_1 field; RT_1 cannot hold (x², 0); RT_2 not (x³, 0).
        let nodes = straight_cell();
        let map = CellMap::from_nodes(&nodes).unwrap();
        type Field = fn([f64; 2]) -> [f64; 2];
        let cases: [(RtOrder, Field); 3] = [
            (RtOrder::Rt0, |x| [x[1], 0.0]),
            (RtOrder::Rt1, |x| [x[0] * x[0], 0.0]),
            (RtOrder::Rt2, |x| [x[0] * x[0] * x[0], 0.0]),
        ];
        for (order, f) in cases {
            let c = interpolate(order, &nodes, |_, x| f(x));
            let worst = sample_points()
                .into_iter()
                .map(|xi| {
                    let v = combine(&c, &physical(order, &nodes, xi).0);
                    let w = f(map.position(xi));
                    (v[0] - w[0]).hypot(v[1] - w[1])
                })
                .fold(0.0, f64::max);
            assert!(worst > 1e-3, "{order:?}: {worst}");
        }
    }

    /// RT_0 ⊂ RT_1: each RT_0 function interpolated into RT_1 is reproduced, on the reference
    /// cell and on a curved one, with coefficients 1 on its edge's two end points and its
    /// moments inside.
    #[test]
    fn rt0_is_contained_in_rt1() {
        let curved = curved_cell();
        for nodes in [&REFERENCE_NODES[..], &curved[..]] {
            for e in 0..3 {
                let c = interpolate(RtOrder::Rt1, nodes, |xi, _| {
                    physical(RtOrder::Rt0, nodes, xi).0[e]
                });
                assert_close(c[2 * e], 1.0, 1e-14, "end point 0");
                assert_close(c[2 * e + 1], 1.0, 1e-14, "end point 1");
                for (j, &cj) in c.iter().enumerate().take(6) {
                    if j / 2 != e {
                        assert_close(cj, 0.0, 1e-14, "other edges");
                    }
                }
                let moments =
                    reference_dofs(RtOrder::Rt1, |xi| reference_values(RtOrder::Rt0, xi)[e]);
                assert_close(c[6], moments[6], 1e-14, "moment x");
                assert_close(c[7], moments[7], 1e-14, "moment y");
                for xi in sample_points() {
                    let v0 = physical(RtOrder::Rt0, nodes, xi).0[e];
                    let v1 = combine(&c, &physical(RtOrder::Rt1, nodes, xi).0);
                    for k in 0..2 {
                        assert_close(v1[k], v0[k], 1e-13, "RT_0 in RT_1");
                    }
                }
            }
        }
    }

    #[test]
    #[should_panic(expected = "3 or 6 nodes")]
    fn physical_rejects_other_node_counts() {
        let _ = physical(RtOrder::Rt0, &[[0.0, 0.0], [1.0, 0.0]], [0.2, 0.2]);
    }
}
