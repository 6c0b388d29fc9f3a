//! Quadrature rules on the reference triangle and the reference edge.
//!
//! docs/design.md §3 asks for rules that integrate the polynomial parts of the functional exactly
//! (degree 2k+2 on elements for RT_k × P_{k+1}) and rules of order ≥ 2k+4 on contact edges.
//! This module supplies, for any requested degree p:
//!
//! - [`triangle_rule`]: ∫_T̂ f dξ ≈ Σ_q w_q f(ξ_q) on the reference triangle
//!   T̂ = {(ξ, η): ξ, η ≥ 0, ξ + η ≤ 1} (vertices (0,0), (1,0), (0,1); area ½, so Σ w_q = ½),
//!   exact for every polynomial of total degree ≤ p. Degrees 0..=12 use the fully symmetric
//!   rules of Xiao and Gimbutas (positive weights, interior points; tables of FEniCS/basix,
//!   polished to round-off by Newton's method on the moment equations in 60-digit arithmetic).
//!   Higher degrees use the collapsed (Duffy/Stroud conical product) Gauss–Jacobi rule.
//! - [`line_rule`]: ∫_0^1 f(s) ds ≈ Σ_q w_q f(s_q), Gauss–Legendre (Σ w_q = 1), exact for
//!   polynomials of degree ≤ p.
//!
//! Every rule records in `degree` the degree it is exact for, which is ≥ the requested one
//! (for instance `triangle_rule(3)` returns the 6-point rule of degree 4). The `*_cached`
//! variants return a shared `&'static` rule, built once per degree.
//!
//! Exactness test: ∫_T̂ ξ^a η^b dξ = a! b! / (a + b + 2)!.
//!
//! Sources: H. Xiao, Z. Gimbutas, *A numerical algorithm for the construction of efficient
//! quadrature rules in two and higher dimensions*, Comput. Math. Appl. 59 (2010) 663–676;
//! A. H. Stroud, *Approximate Calculation of Multiple Integrals* (1971) (conical product rules).

use std::collections::HashMap;
use std::f64::consts::PI;
use std::sync::{Mutex, OnceLock};

/// A quadrature rule on the reference triangle (0,0), (1,0), (0,1).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TriangleRule {
    /// Exact for all polynomials of total degree ≤ `degree`.
    pub degree: usize,
    /// Points ξ_q = (ξ, η) in reference coordinates, all strictly inside the triangle.
    pub points: Vec<[f64; 2]>,
    /// Weights w_q > 0, summing to ½ (the reference area).
    pub weights: Vec<f64>,
}

/// A quadrature rule on the reference edge [0, 1].
#[derive(Clone, Debug, PartialEq)]
pub struct LineRule {
    /// Exact for all polynomials of degree ≤ `degree`.
    pub degree: usize,
    /// Points s_q in (0, 1), increasing.
    pub points: Vec<f64>,
    /// Weights w_q > 0, summing to 1.
    pub weights: Vec<f64>,
}

impl TriangleRule {
    /// Number of points.
    #[inline]
    pub fn len(&self) -> usize {
        self.weights.len()
    }

    /// True when the rule has no points (never the case for rules built here).
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.weights.is_empty()
    }

    /// Σ_q w_q f(ξ_q): the rule applied to `f` on the reference triangle.
    #[inline]
    pub fn integrate(&self, mut f: impl FnMut([f64; 2]) -> f64) -> f64 {
        self.points
            .iter()
            .zip(&self.weights)
            .map(|(&p, &w)| w * f(p))
            .sum()
    }
}

impl LineRule {
    /// Number of points.
    #[inline]
    pub fn len(&self) -> usize {
        self.weights.len()
    }

    /// True when the rule has no points (never the case for rules built here).
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.weights.is_empty()
    }

    /// Σ_q w_q f(s_q): the rule applied to `f` on [0, 1].
    #[inline]
    pub fn integrate(&self, mut f: impl FnMut(f64) -> f64) -> f64 {
        self.points
            .iter()
            .zip(&self.weights)
            .map(|(&s, &w)| w * f(s))
            .sum()
    }
}

/// Highest degree served by a tabulated symmetric rule; above it [`triangle_rule`] uses the
/// collapsed Gauss–Jacobi rule.
pub const MAX_TABULATED_DEGREE: usize = 12;

/// A quadrature rule on the reference triangle exact for total degree ≤ `degree`.
///
/// Degrees 0..=12: Xiao–Gimbutas symmetric rules (points: 1, 3, 6, 6, 6, 7, 12, 15, 16, 19,
/// 25, 28, 33 for degrees 0..=12; degrees 0 and 3 get the rules of degree 1 and 4).
/// Degree p > 12: collapsed Gauss–Jacobi rule with n = ⌊p/2⌋ + 1 points per direction
/// (n² points, exact to degree 2n − 1).
pub fn triangle_rule(degree: usize) -> TriangleRule {
    if degree <= MAX_TABULATED_DEGREE {
        symmetric_rule(degree)
    } else {
        collapsed_rule(degree / 2 + 1)
    }
}

/// A quadrature rule on [0, 1] exact for degree ≤ `degree`: Gauss–Legendre with
/// n = ⌊degree/2⌋ + 1 points (exact to degree 2n − 1).
pub fn line_rule(degree: usize) -> LineRule {
    let n = degree / 2 + 1;
    let (x, w) = gauss_legendre(n);
    LineRule {
        degree: 2 * n - 1,
        points: x.iter().map(|&x| 0.5 * (1.0 + x)).collect(),
        weights: w.iter().map(|&w| 0.5 * w).collect(),
    }
}

/// [`triangle_rule`]`(degree)` on each of the 4^`levels` triangles of the uniform (midpoint)
/// refinement of the reference triangle: exact to `degree` for piecewise polynomials on that
/// refinement, and with points distinct from those of the single rule (the bubble fit of
/// `estimate::bubble` is checked on them, so that a fit to the rule's own points cannot
/// under-read a non-polynomial residual).
pub fn split_rule(degree: usize, levels: u32) -> TriangleRule {
    let base = triangle_rule(degree);
    let mut tris = vec![[[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]];
    for _ in 0..levels {
        let mid = |a: [f64; 2], b: [f64; 2]| [0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1])];
        tris = tris
            .iter()
            .flat_map(|&[a, b, c]| {
                let (ab, bc, ca) = (mid(a, b), mid(b, c), mid(c, a));
                [[a, ab, ca], [ab, b, bc], [ca, bc, c], [bc, ca, ab]]
            })
            .collect();
    }
    let mut points = Vec::with_capacity(tris.len() * base.points.len());
    let mut weights = Vec::with_capacity(points.capacity());
    for [a, b, c] in tris {
        let (e, f) = ([b[0] - a[0], b[1] - a[1]], [c[0] - a[0], c[1] - a[1]]);
        let det = (e[0] * f[1] - e[1] * f[0]).abs();
        for (p, w) in base.points.iter().zip(&base.weights) {
            points.push([
                a[0] + p[0] * e[0] + p[1] * f[0],
                a[1] + p[0] * e[1] + p[1] * f[1],
            ]);
            weights.push(w * det);
        }
    }
    TriangleRule {
        degree: base.degree,
        points,
        weights,
    }
}

/// Degrees below this are cached without a lock; higher ones go through a mutex.
const CACHE_SIZE: usize = 64;

/// [`triangle_rule`]`(degree)`, built once and shared. Fetch it once per pass over the mesh,
/// not once per cell.
pub fn triangle_rule_cached(degree: usize) -> &'static TriangleRule {
    static FAST: [OnceLock<TriangleRule>; CACHE_SIZE] = [const { OnceLock::new() }; CACHE_SIZE];
    static SLOW: OnceLock<Mutex<HashMap<usize, &'static TriangleRule>>> = OnceLock::new();
    if degree < CACHE_SIZE {
        return FAST[degree].get_or_init(|| triangle_rule(degree));
    }
    let mut map = SLOW
        .get_or_init(Default::default)
        .lock()
        .unwrap_or_else(|e| e.into_inner());
    // One leaked rule per distinct degree: bounded by the number of degrees ever asked for.
    map.entry(degree)
        .or_insert_with(|| Box::leak(Box::new(triangle_rule(degree))))
}

/// [`line_rule`]`(degree)`, built once and shared. Fetch it once per pass over the mesh.
pub fn line_rule_cached(degree: usize) -> &'static LineRule {
    static FAST: [OnceLock<LineRule>; CACHE_SIZE] = [const { OnceLock::new() }; CACHE_SIZE];
    static SLOW: OnceLock<Mutex<HashMap<usize, &'static LineRule>>> = OnceLock::new();
    if degree < CACHE_SIZE {
        return FAST[degree].get_or_init(|| line_rule(degree));
    }
    let mut map = SLOW
        .get_or_init(Default::default)
        .lock()
        .unwrap_or_else(|e| e.into_inner());
    map.entry(degree)
        .or_insert_with(|| Box::leak(Box::new(line_rule(degree))))
}

// ---------------------------------------------------------------------------------------------
// Symmetric rules (tables)

/// One orbit of the symmetry group of the triangle, in barycentric coordinates
/// (λ0, λ1, λ2) = (1 − ξ − η, ξ, η). `w` is the weight of each point of the orbit.
#[derive(Clone, Copy, Debug)]
enum Orbit {
    /// The centroid (⅓, ⅓, ⅓): 1 point.
    Centroid { w: f64 },
    /// The permutations of (a, a, 1 − 2a): 3 points.
    S21 { a: f64, w: f64 },
    /// The permutations of (a, b, 1 − a − b): 6 points.
    S111 { a: f64, b: f64, w: f64 },
}

use Orbit::{Centroid, S21, S111};

const fn centroid(w: f64) -> Orbit {
    Centroid { w }
}

const fn s21(a: f64, w: f64) -> Orbit {
    S21 { a, w }
}

const fn s111(a: f64, b: f64, w: f64) -> Orbit {
    S111 { a, b, w }
}

/// Xiao–Gimbutas rules, weights for the area-½ triangle, indexed by the requested degree; the
/// first field is the degree the rule is exact for (requests 0 and 3 get the rules of degree 1
/// and 4). Values from FEniCS/basix `quadrature.cpp`, refined to round-off by Newton's
/// method on all moment equations ξ^a η^b, a + b ≤ degree, in 60-digit arithmetic (the
/// corrections were ≤ 3e-16, i.e. the tables were already correct to the last digit or two).
const SYMMETRIC: [(usize, &[Orbit]); MAX_TABULATED_DEGREE + 1] = [
    (1, &[centroid(0.5)]),
    (1, &[centroid(0.5)]),
    (2, &[s21(1.0 / 6.0, 1.0 / 6.0)]),
    (4, DEGREE_4),
    (4, DEGREE_4),
    // 7 points
    (
        5,
        &[
            centroid(0.1125),
            s21(0.10128650732345634, 0.06296959027241357),
            s21(0.4701420641051151, 0.0661970763942531),
        ],
    ),
    // 12 points
    (
        6,
        &[
            s21(0.21942998254978296, 0.08566656207649051),
            s21(0.48013796411221504, 0.04036554479651549),
            s111(
                0.019371724361240787,
                0.14161901592396817,
                0.020317279896830333,
            ),
        ],
    ),
    // 15 points
    (
        7,
        &[
            s21(0.47319565368925104, 0.026590416648380175),
            s21(0.05779764005450647, 0.020459085197028465),
            s21(0.24166360639724738, 0.06386262428056692),
            s111(
                0.04697120613008547,
                0.2593390118657859,
                0.027877270270345554,
            ),
        ],
    ),
    // 16 points
    (
        8,
        &[
            centroid(0.07215780383889359),
            s21(0.1705693077517602, 0.05160868526735912),
            s21(0.4592925882927232, 0.04754581713364231),
            s21(0.05054722831703098, 0.01622924881159904),
            s111(
                0.008394777409957605,
                0.2631128296346381,
                0.013615157087217496,
            ),
        ],
    ),
    // 19 points
    (
        9,
        &[
            centroid(0.04856789814139942),
            s21(0.4896825191987376, 0.015667350113569536),
            s21(0.18820353561903272, 0.039823869463605124),
            s21(0.43708959149293664, 0.03891377050238714),
            s21(0.04472951339445271, 0.012788837829349016),
            s111(
                0.036838412054736286,
                0.2219629891607657,
                0.021641769688644688,
            ),
        ],
    ),
    // 25 points
    (
        10,
        &[
            centroid(0.041807437186986963),
            s21(0.4951734598011705, 0.004896295249209156),
            s21(0.019139415242841226, 0.003192679615059326),
            s21(0.1844850126852465, 0.039316884873188636),
            s21(0.4282348209437189, 0.03762366398427199),
            s111(
                0.03472362048232744,
                0.13373475510086913,
                0.014481140731628168,
            ),
            s111(
                0.037582727341191655,
                0.3266931362813369,
                0.01936952454300945,
            ),
        ],
    ),
    // 28 points
    (
        11,
        &[
            centroid(0.04072256735467568),
            s21(0.03084689563558801, 0.006124648475353971),
            s21(0.49878016517846074, 0.0062327459369407225),
            s21(0.11320782728669382, 0.020064621190654143),
            s21(0.43665501639317617, 0.03154743607994937),
            s21(0.21448345861926926, 0.03392255387184759),
            s111(
                0.01436666256955552,
                0.15930361983769337,
                0.007278811668904596,
            ),
            s111(
                0.047664066972150726,
                0.3106312163134628,
                0.020321424327943226,
            ),
        ],
    ),
    // 33 points
    (
        12,
        &[
            s21(0.2714625070149261, 0.03127060659795138),
            s21(0.1092578276593543, 0.014243026034438772),
            s21(0.4401116486585931, 0.02495916746403047),
            s21(0.4882037509455415, 0.012133419040726016),
            s21(0.024646363436335594, 0.0039658212549868194),
            s111(
                0.11629601967792659,
                0.25545422863851736,
                0.021613681829707104,
            ),
            s111(
                0.02138249025617059,
                0.12727971723358936,
                0.007541838788255719,
            ),
            s111(
                0.02303415635526714,
                0.29165567973834094,
                0.01089179251930378,
            ),
        ],
    ),
];

/// The 6-point rule of degree 4 (Strang–Fix, Dunavant, Xiao–Gimbutas all give this one).
const DEGREE_4: &[Orbit] = &[
    s21(0.4459484909159649, 0.11169079483900574),
    s21(0.09157621350977074, 0.054975871827660935),
];

/// Expand the orbits of the tabulated rule for `degree` into points (ξ, η) = (λ1, λ2).
fn symmetric_rule(degree: usize) -> TriangleRule {
    let (exact, orbits) = SYMMETRIC[degree];
    let mut points = Vec::new();
    let mut weights = Vec::new();
    for orbit in orbits {
        match *orbit {
            Centroid { w } => {
                points.push([1.0 / 3.0, 1.0 / 3.0]);
                weights.push(w);
            }
            S21 { a, w } => {
                let b = 1.0 - 2.0 * a;
                points.extend([[a, a], [a, b], [b, a]]);
                weights.extend([w; 3]);
            }
            S111 { a, b, w } => {
                let c = 1.0 - a - b;
                points.extend([[a, b], [b, a], [a, c], [c, a], [b, c], [c, b]]);
                weights.extend([w; 6]);
            }
        }
    }
    TriangleRule {
        degree: exact,
        points,
        weights,
    }
}

// ---------------------------------------------------------------------------------------------
// Collapsed Gauss–Jacobi rule

/// The conical product rule with `n` points per direction (exact to degree 2n − 1).
///
/// The square (u, v) ∈ [0,1]² is collapsed onto the triangle by ξ = u(1 − v), η = v, with
/// dξ dη = (1 − v) du dv. In u: Gauss–Legendre; in v: Gauss–Jacobi for the weight (1 − v),
/// i.e. the roots of P_n^{(1,0)} mapped from [−1, 1] to [0, 1]. A monomial ξ^a η^b becomes
/// u^a (1 − v)^a v^b times the weight (1 − v), so both factors have degree ≤ a + b.
fn collapsed_rule(n: usize) -> TriangleRule {
    let (xu, wu) = gauss_legendre(n);
    let (xv, wv) = gauss_jacobi_10(n);
    let mut points = Vec::with_capacity(n * n);
    let mut weights = Vec::with_capacity(n * n);
    for (&sv, &omega_v) in xv.iter().zip(&wv) {
        let v = 0.5 * (1.0 + sv);
        // ∫_0^1 (1 − v) g dv = ¼ ∫_{−1}^{1} (1 − s) g ds.
        let weight_v = 0.25 * omega_v;
        for (&su, &omega_u) in xu.iter().zip(&wu) {
            let u = 0.5 * (1.0 + su);
            points.push([u * (1.0 - v), v]);
            weights.push(0.5 * omega_u * weight_v);
        }
    }
    TriangleRule {
        degree: 2 * n - 1,
        points,
        weights,
    }
}

// ---------------------------------------------------------------------------------------------
// One-dimensional Gauss rules on [−1, 1]

/// Legendre P_n(x) and P_n'(x) by the three-term recurrence
/// k P_k = (2k − 1) x P_{k−1} − (k − 1) P_{k−2}, and
/// P_n' = n (x P_n − P_{n−1}) / (x² − 1) (valid for |x| < 1).
fn legendre(n: usize, x: f64) -> (f64, f64) {
    let (mut p_prev, mut p) = (1.0, x);
    if n == 0 {
        return (1.0, 0.0);
    }
    for k in 2..=n {
        let k = k as f64;
        let p_next = ((2.0 * k - 1.0) * x * p - (k - 1.0) * p_prev) / k;
        p_prev = p;
        p = p_next;
    }
    let dp = n as f64 * (p_prev - x * p) / ((1.0 - x) * (1.0 + x));
    (p, dp)
}

/// Gauss–Legendre nodes (increasing) and weights on [−1, 1], n ≥ 1 points.
///
/// Newton's method on P_n from the guesses cos(π(i + ¾)/(n + ½)), iterated to round-off;
/// weights 2 / ((1 − x²) P_n'(x)²). Only half the nodes are computed, the rest mirrored, so the
/// rule is exactly symmetric.
fn gauss_legendre(n: usize) -> (Vec<f64>, Vec<f64>) {
    let mut x = vec![0.0; n];
    let mut w = vec![0.0; n];
    for i in 0..n.div_ceil(2) {
        let mut xi = (PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
        xi = newton(xi, |x| legendre(n, x));
        let (_, dp) = legendre(n, xi);
        let wi = 2.0 / ((1.0 - xi) * (1.0 + xi) * dp * dp);
        // xi decreases with i: the largest node first.
        x[n - 1 - i] = xi;
        w[n - 1 - i] = wi;
        x[i] = -xi;
        w[i] = wi;
    }
    if n % 2 == 1 {
        x[n / 2] = 0.0;
    }
    (x, w)
}

/// Jacobi P_n^{(1,0)}(x) and its derivative, for |x| < 1.
///
/// Recurrence, written for general (α, β) and used with α = 1, β = 0:
/// 2k(k+α+β)(2k+α+β−2) P_k = (2k+α+β−1)[(2k+α+β)(2k+α+β−2) x + α² − β²] P_{k−1}
///                           − 2(k+α−1)(k+β−1)(2k+α+β) P_{k−2},
/// P_0 = 1, P_1 = ((α+β+2) x + α − β)/2; derivative from
/// (2n+α+β)(1 − x²) P_n' = n[(α − β) − (2n+α+β) x] P_n + 2(n+α)(n+β) P_{n−1}.
fn jacobi_10(n: usize, x: f64) -> (f64, f64) {
    const A: f64 = 1.0;
    const B: f64 = 0.0;
    if n == 0 {
        return (1.0, 0.0);
    }
    let (mut p_prev, mut p) = (1.0, 0.5 * ((A + B + 2.0) * x + A - B));
    for k in 2..=n {
        let k = k as f64;
        let s = 2.0 * k + A + B;
        let a1 = 2.0 * k * (k + A + B) * (s - 2.0);
        let a2 = (s - 1.0) * (s * (s - 2.0) * x + A * A - B * B);
        let a3 = 2.0 * (k + A - 1.0) * (k + B - 1.0) * s;
        let p_next = (a2 * p - a3 * p_prev) / a1;
        p_prev = p;
        p = p_next;
    }
    let nf = n as f64;
    let s = 2.0 * nf + A + B;
    let dp = (nf * ((A - B) - s * x) * p + 2.0 * (nf + A) * (nf + B) * p_prev)
        / (s * (1.0 - x) * (1.0 + x));
    (p, dp)
}

/// Gauss–Jacobi nodes and weights on [−1, 1] for the weight (1 − x), n ≥ 1 points
/// (Σ w = 2).
///
/// Newton's method with deflation Σ_j 1/(x − x_j) over the roots already found
/// (as in Karniadakis & Sherwin, *Spectral/hp Element Methods*), started from the Chebyshev
/// points, then polished by plain Newton steps on P_n^{(1,0)}; weights
/// 2^{α+β+1} Γ(n+α+1)Γ(n+β+1)/(Γ(n+α+β+1) n!) / ((1 − x²) P_n'(x)²) = 4 / ((1 − x²) P_n'(x)²).
fn gauss_jacobi_10(n: usize) -> (Vec<f64>, Vec<f64>) {
    let mut x: Vec<f64> = Vec::with_capacity(n);
    for k in 0..n {
        let mut guess = -((2 * k + 1) as f64 * PI / (2 * n) as f64).cos();
        if let Some(&last) = x.last() {
            guess = 0.5 * (guess + last);
        }
        let mut xk = guess;
        for _ in 0..100 {
            let (p, dp) = jacobi_10(n, xk);
            let deflation: f64 = x.iter().map(|&xj| 1.0 / (xk - xj)).sum();
            let delta = p / (dp - p * deflation);
            xk -= delta;
            if delta.abs() <= 1e-15 * xk.abs().max(1e-3) {
                break;
            }
        }
        x.push(newton(xk, |t| jacobi_10(n, t)));
    }
    let w = x
        .iter()
        .map(|&xi| {
            let (_, dp) = jacobi_10(n, xi);
            4.0 / ((1.0 - xi) * (1.0 + xi) * dp * dp)
        })
        .collect();
    (x, w)
}

/// Newton's method x ← x − f/f' from a guess close to a simple root, until the step stops
/// shrinking (round-off level), at most 100 steps.
fn newton(mut x: f64, f: impl Fn(f64) -> (f64, f64)) -> f64 {
    let mut last_step = f64::INFINITY;
    for _ in 0..100 {
        let (p, dp) = f(x);
        let step = p / dp;
        if !step.is_finite() {
            break;
        }
        x -= step;
        if step.abs() >= last_step || step.abs() <= 1e-17 {
            break;
        }
        last_step = step.abs();
    }
    x
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn split_rule_integrates_a_kinked_function_and_monomials() {
        // ∫_T |x − ½| over the reference triangle, by hand: the kink x = ½ is an edge of the
        // refinement, so the split rule is exact: ∫_0^½ (½ − x)(1 − x) dx + ∫_½^1 (x − ½)(1 − x) dx
        // = 5/48 + 1/48 = 1/8.
        let r = split_rule(2, 1);
        assert_eq!(r.points.len(), 4 * triangle_rule(2).points.len());
        let k = r.integrate(|p| (p[0] - 0.5).abs());
        assert!((k - 0.125).abs() < 1e-15, "{k}");
        // x²y³: 2!3!/7! = 12/5040.
        let m = split_rule(5, 2).integrate(|p| p[0] * p[0] * p[1].powi(3));
        assert!((m - 12.0 / 5040.0).abs() < 1e-16, "{m}");
        let single = triangle_rule(2);
        assert!(r.points.iter().all(|p| !single.points.contains(p)));
    }

    /// ∫_T̂ ξ^a η^b = a! b! / (a + b + 2)!.
    fn triangle_moment(a: usize, b: usize) -> f64 {
        let fact = |n: usize| (1..=n).map(|k| k as f64).product::<f64>();
        fact(a) * fact(b) / fact(a + b + 2)
    }

    /// Largest relative error of the rule over all monomials of total degree `d`.
    fn worst_error_at_degree(rule: &TriangleRule, d: usize) -> f64 {
        (0..=d)
            .map(|a| {
                let b = d - a;
                let q = rule.integrate(|[x, y]| x.powi(a as i32) * y.powi(b as i32));
                let exact = triangle_moment(a, b);
                ((q - exact) / exact).abs()
            })
            .fold(0.0, f64::max)
    }

    fn degrees_to_check() -> impl Iterator<Item = usize> {
        (0..=24).chain([27, 30, 35, 40])
    }

    #[test]
    fn triangle_rules_are_exact_up_to_their_degree() {
        for p in degrees_to_check() {
            let rule = triangle_rule(p);
            assert!(rule.degree >= p, "degree {p}: rule claims {}", rule.degree);
            for d in 0..=rule.degree {
                let err = worst_error_at_degree(&rule, d);
                assert!(
                    err < 1e-14,
                    "requested {p}: monomials of degree {d}: rel. error {err:e}"
                );
            }
        }
    }

    #[test]
    fn triangle_rules_are_not_exact_one_degree_higher() {
        for p in degrees_to_check() {
            let rule = triangle_rule(p);
            let err = worst_error_at_degree(&rule, rule.degree + 1);
            // Round-off is ~1e-15; the smallest true error here (degree 41) is ~1e-12.
            assert!(
                err > 1e-13,
                "requested {p}: degree {} + 1 is exact ({err:e})",
                rule.degree
            );
        }
    }

    #[test]
    fn triangle_weights_positive_points_inside_sum_half() {
        for p in degrees_to_check() {
            let rule = triangle_rule(p);
            assert_eq!(rule.points.len(), rule.weights.len());
            assert!(
                rule.weights.iter().all(|&w| w > 0.0),
                "degree {p}: weight ≤ 0"
            );
            for &[x, y] in &rule.points {
                assert!(
                    x > 0.0 && y > 0.0 && x + y < 1.0,
                    "degree {p}: ({x}, {y}) not inside"
                );
            }
            let sum: f64 = rule.weights.iter().sum();
            assert!((sum - 0.5).abs() < 1e-15, "degree {p}: Σw = {sum}");
        }
    }

    #[test]
    fn tabulated_point_counts() {
        let counts: Vec<usize> = (0..=MAX_TABULATED_DEGREE)
            .map(|p| triangle_rule(p).len())
            .collect();
        assert_eq!(counts, [1, 1, 3, 6, 6, 7, 12, 15, 16, 19, 25, 28, 33]);
        // Collapsed rule: ⌊p/2⌋ + 1 points per direction.
        assert_eq!(triangle_rule(13).len(), 49);
        assert_eq!(triangle_rule(20).len(), 121);
    }

    #[test]
    fn tabulated_rules_are_symmetric() {
        // The six symmetries of the triangle permute barycentric coordinates; the point set
        // (with weights) must be invariant under the reflection ξ ↔ η and the rotation
        // (λ0, λ1, λ2) → (λ2, λ0, λ1), i.e. (ξ, η) → (1 − ξ − η, ξ).
        let maps: [fn([f64; 2]) -> [f64; 2]; 2] = [|[x, y]| [y, x], |[x, y]| [1.0 - x - y, x]];
        for p in 1..=MAX_TABULATED_DEGREE {
            let rule = triangle_rule(p);
            for map in maps {
                for (q, &w) in rule.points.iter().zip(&rule.weights) {
                    let image = map(*q);
                    let found = rule.points.iter().zip(&rule.weights).any(|(r, &v)| {
                        (r[0] - image[0]).abs() < 1e-15
                            && (r[1] - image[1]).abs() < 1e-15
                            && (v - w).abs() < 1e-18
                    });
                    assert!(found, "degree {p}: image {image:?} of {q:?} missing");
                }
            }
        }
    }

    #[test]
    fn cached_triangle_rule_is_the_same_rule() {
        for p in [0, 4, 13, 63, 64, 70] {
            assert_eq!(triangle_rule_cached(p), &triangle_rule(p));
            assert!(std::ptr::eq(
                triangle_rule_cached(p),
                triangle_rule_cached(p)
            ));
        }
    }

    #[test]
    fn line_rules_are_exact_and_tight() {
        for p in 0..=60 {
            let rule = line_rule(p);
            assert!(rule.degree >= p);
            assert_eq!(rule.len(), rule.degree.div_ceil(2));
            for k in 0..=rule.degree {
                let q = rule.integrate(|s| s.powi(k as i32));
                let exact = 1.0 / (k as f64 + 1.0);
                assert!(
                    ((q - exact) / exact).abs() < 1e-14,
                    "degree {p}: s^{k}: {q} vs {exact}"
                );
            }
            // Degree + 1 = 2n is not exact: P_n(2s − 1)² vanishes at the n Gauss points, yet
            // ∫_0^1 P_n(2s − 1)² ds = 1/(2n + 1).
            let n = rule.len();
            let q = rule.integrate(|s| legendre(n, 2.0 * s - 1.0).0.powi(2));
            let exact = 1.0 / (2.0 * n as f64 + 1.0);
            assert!(
                q.abs() < 1e-15 && exact > 1e-3,
                "degree {p}: Σ w P_n² = {q}"
            );
        }
    }

    #[test]
    fn line_rule_points_and_weights() {
        for p in 0..=60 {
            let rule = line_rule(p);
            assert!(rule.weights.iter().all(|&w| w > 0.0));
            assert!(rule.points.iter().all(|&s| s > 0.0 && s < 1.0));
            assert!(
                rule.points.windows(2).all(|w| w[0] < w[1]),
                "degree {p}: not increasing"
            );
            let sum: f64 = rule.weights.iter().sum();
            assert!((sum - 1.0).abs() < 1e-14, "degree {p}: Σw = {sum}");
            // Symmetric about ½.
            let n = rule.len();
            for i in 0..n {
                assert!((rule.points[i] + rule.points[n - 1 - i] - 1.0).abs() < 1e-15);
                assert_eq!(rule.weights[i], rule.weights[n - 1 - i]);
            }
        }
    }

    #[test]
    fn two_point_gauss_legendre_closed_form() {
        let rule = line_rule(3);
        let h = 0.5 / 3f64.sqrt();
        assert_eq!(rule.len(), 2);
        assert!((rule.points[0] - (0.5 - h)).abs() < 1e-15);
        assert!((rule.points[1] - (0.5 + h)).abs() < 1e-15);
        assert!(rule.weights.iter().all(|&w| (w - 0.5).abs() < 1e-15));
    }

    #[test]
    fn gauss_jacobi_rule_integrates_against_weight() {
        // ∫_{−1}^{1} (1 − x) x^k dx = 2/(k+1) for k even, −2/(k+2) for k odd.
        for n in 1..=30 {
            let (x, w) = gauss_jacobi_10(n);
            for k in 0..2 * n {
                let q: f64 = x.iter().zip(&w).map(|(&x, &w)| w * x.powi(k as i32)).sum();
                let exact = if k % 2 == 0 {
                    2.0 / (k as f64 + 1.0)
                } else {
                    -2.0 / (k as f64 + 2.0)
                };
                assert!(
                    (q - exact).abs() < 1e-14 * exact.abs().max(1.0),
                    "n {n} k {k}"
                );
            }
        }
    }

    #[test]
    fn cached_line_rule_is_the_same_rule() {
        for p in [0, 5, 63, 64, 100] {
            assert_eq!(line_rule_cached(p), &line_rule(p));
        }
    }
}
