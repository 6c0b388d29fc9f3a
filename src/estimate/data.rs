//! The data terms of the bound (docs/design.md §6.2, "Data outside the discrete spaces"):
//! Neumann data that the normal traces of τ do not match, and Dirichlet data that the trace of
//! v does not match.
//!
//! **Traction.** With w = u − v vanishing on Γ_D, the pairing of §6.1 gains
//! ⟨t − τn, w⟩_{Γ_N}. Where m := t − τn is orthogonal on the edge E to the traces of the rigid
//! motions (the patch reconstruction imposes τn = Π_k t), ⟨m, w⟩_E = ⟨m, φ⟩_E with
//! φ = w − ρ, ρ the rigid motion of the oscillation argument on the cell T of E (mean φ = 0,
//! mean rotation of φ = 0). The trace inequality on a simplex (divergence theorem applied to
//! φ²(x − x_c), x_c the vertex opposite E, whose (x − x_c)·n is the height 2|T|/|E| on E and 0
//! on the other edges)
//!
//! ```text
//! ‖φ‖²_E ≤ (|E|/|T|) (‖φ‖²_T + h_T ‖φ‖_T ‖∇φ‖_T),
//! ```
//!
//! with ‖φ‖_T ≤ (h_T/j₁,₁) C_K ‖ε(w)‖_T (Laugesen–Siudeja's Poincaré constant of a triangle,
//! `bound::J11`) and ‖∇φ‖_T ≤ C_K ‖ε(w)‖_T,
//! C_K = (1 + ½K_T²)^½, gives ⟨m, w⟩_E ≤ η_tr,E ‖ε(w)‖_T with
//!
//! ```text
//! η_tr,E = h_T C_K ((|E|/|T|)(1/j₁,₁² + 1/j₁,₁))^½ ‖t − τn‖_E,
//! ```
//!
//! added to the cell's oscillation term (same φ, same K_T). Straight cells only.
//!
//! **Dirichlet lifting.** Where d := u_D − v vanishes at the ends a, b of a Dirichlet edge E of
//! a straight cell T (c the third vertex), the field z(c + t(a + s(b − a) − c)) = t^p d(s),
//! (s, t) ∈ [0, 1]², p > 0, is in H¹(T), equals d on E and vanishes on the two other edges, so
//! it extends by 0 and v' = v + z meets the data exactly (and is unchanged on Γ_C). With
//! e = b − a, q = a + s e − c, D = e × (a − c):
//!
//! ```text
//! ∇z_i = t^(p−1) (d_i′(s) (q_y, −q_x) + p d_i(s) (−e_y, e_x)) / D,
//! ```
//!
//! so |||z|||²_T is a one-dimensional integral over the edge, least at a p computed per edge
//! (`collapsed_lifting`).
//!
//! with d′ = (∇u_D − ∇v)·e from the forward-mode gradient of the data expression
//! ([`crate::expr::Expr::eval_gradient`]). The bound is taken for v'
//! (η_PS,T(v') ≤ η_PS,T(v) + |||z|||_T, c unchanged) and |||z||| is added like the projection
//! distance: |||u − v||| ≤ |||u − v'||| + |||z|||.

use crate::field::StressField;
use crate::geometry::Shape;
use crate::geometry::values::{SubPoint, sub_point};
use crate::material::Elastic;
use crate::problem::{Condition, Context};
use crate::quadrature::line_rule_cached;
use crate::scene::BoundaryKind;
use crate::tolerance::{BOUND_MOMENT_RELATIVE, DATA_PANELS, EDGE_DEGREE, LOAD_DEGREE};

/// Per-cell data terms and whether they replace the admissibility checks of the data.
pub struct DataTerms {
    /// Σ_E η_tr,E over the cell's Neumann and traction-free edges (stress × length: divided by
    /// √c_min like the oscillation term).
    pub trace: Vec<f64>,
    /// Σ_E |||z_E|||_T over the cell's Dirichlet edges.
    pub lift: Vec<f64>,
    /// Every lifting z_E, for the pairing (Cε(v) − τ*, ε(z_E))_T (`lift_pairing`).
    pub lifts: Vec<Lift>,
    /// Every edge with a traction mismatch has its term (orthogonality held, straight cell).
    pub traction_covered: bool,
    /// Every Dirichlet edge was lifted (data met at its ends, straight cell).
    pub dirichlet_covered: bool,
}

/// One Dirichlet lifting z = t^p d(s) (module doc) on edge `local` of cell `cell`.
#[derive(Clone, Copy, Debug)]
pub struct Lift {
    pub cell: usize,
    pub local: usize,
    pub p: f64,
    /// The scene boundary whose data d = u_D − v is lifted.
    pub boundary: usize,
}

/// The data terms for displacement `v` and stress `sigma` (module doc).
pub fn data_terms(
    ctx: &Context,
    v: &[[f64; 2]],
    sigma: StressField,
    sigma_scale: f64,
) -> DataTerms {
    let mesh = ctx.mesh;
    let n = mesh.len();
    let mut out = DataTerms {
        trace: vec![0.0; n],
        lift: vec![0.0; n],
        lifts: Vec::new(),
        traction_covered: true,
        dirichlet_covered: true,
    };
    let tol = super::displacement_tolerance(
        crate::field::max_norm(v),
        crate::field::max_norm(&mesh.points),
    );
    for be in ctx.edges {
        let t = be.cell as usize;
        let straight = mesh.shape[t] == Shape::Affine;
        match be.condition {
            Condition::Dirichlet(b) => {
                let BoundaryKind::Dirichlet { displacement } = &ctx.scene.boundaries[b].kind else {
                    continue;
                };
                match straight
                    .then(|| lifting(ctx, v, t, be.local as usize, displacement, tol))
                    .flatten()
                {
                    Some((p, z)) => {
                        out.lift[t] += z;
                        // z = 0: its pairing is 0 as well.
                        if z == 0.0 {
                            continue;
                        }
                        out.lifts.push(Lift {
                            cell: t,
                            local: be.local as usize,
                            p,
                            boundary: b,
                        });
                    }
                    None => out.dirichlet_covered = false,
                }
            }
            Condition::Neumann(_) | Condition::Free => {
                let traction = match be.condition {
                    Condition::Neumann(b) => match &ctx.scene.boundaries[b].kind {
                        BoundaryKind::Neumann { traction } => Some(traction),
                        _ => None,
                    },
                    _ => None,
                };
                match straight
                    .then(|| trace(ctx, sigma, t, be.local as usize, traction, sigma_scale))
                    .flatten()
                {
                    Some(e) => out.trace[t] += e,
                    None => out.traction_covered = false,
                }
            }
            Condition::Contact(_) => {}
        }
    }
    out
}

/// The straight edge `l` of cell `t`: its ends a, b, the opposite vertex c, and the
/// reference coordinates of a and b.
struct Edge {
    a: [f64; 2],
    e: [f64; 2],
    c: [f64; 2],
    xi_a: [f64; 2],
    xi_b: [f64; 2],
}

const REF: [[f64; 2]; 3] = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]];

impl Edge {
    fn new(x: &[[f64; 2]], l: usize) -> Edge {
        let (a, b, c) = (x[l], x[(l + 1) % 3], x[(l + 2) % 3]);
        Edge {
            a,
            e: [b[0] - a[0], b[1] - a[1]],
            c,
            xi_a: REF[l],
            xi_b: REF[(l + 1) % 3],
        }
    }

    fn len(&self) -> f64 {
        self.e[0].hypot(self.e[1])
    }

    fn xi(&self, s: f64) -> [f64; 2] {
        [
            (1.0 - s) * self.xi_a[0] + s * self.xi_b[0],
            (1.0 - s) * self.xi_a[1] + s * self.xi_b[1],
        ]
    }

    /// Points s and weights (summing to 1) of a composite Gauss–Legendre rule: `DATA_PANELS`
    /// panels of degree `LOAD_DEGREE` (exact for the polynomial parts; the panels resolve
    /// kinks of the data better than one rule of high degree).
    fn rule() -> impl Iterator<Item = (f64, f64)> {
        let rule = line_rule_cached(LOAD_DEGREE);
        (0..DATA_PANELS).flat_map(move |p| {
            rule.points
                .iter()
                .zip(&rule.weights)
                .map(move |(&s, &w)| ((p as f64 + s) / DATA_PANELS as f64, w / DATA_PANELS as f64))
        })
    }
}

/// η_tr,E of the module doc for the edge `l` of the straight cell `t` (t = `traction`, or 0),
/// or `None` when t − τn is not orthogonal to the rigid motions on E (then the mismatch stays
/// a failed hypothesis).
fn trace(
    ctx: &Context,
    sigma: StressField,
    t: usize,
    l: usize,
    traction: Option<&[crate::expr::Expr; 2]>,
    sigma_scale: f64,
) -> Option<f64> {
    let mesh = ctx.mesh;
    let (fam, x, nodes) = (mesh.family[t], mesh.coords(t), mesh.nodes(t));
    let edge = Edge::new(&x, l);
    let len = edge.len();
    // Outward: on the right of the counter-clockwise edge (problem::boundary).
    let nrm = [edge.e[1] / len, -edge.e[0] / len];
    let mid = [edge.a[0] + 0.5 * edge.e[0], edge.a[1] + 0.5 * edge.e[1]];
    let (mut m2, mut mom, mut scale) = (0.0, [0.0; 3], 0.0);
    // The rule with which the patches project t onto P_k (`reconstruct::patch`), so that the
    // moments checked are the ones they matched.
    let lr = line_rule_cached(EDGE_DEGREE);
    for (&s, &w) in lr.points.iter().zip(&lr.weights) {
        let xi = edge.xi(s);
        let sp = sub_point(fam, &x[..fam.nodes()], Shape::Affine, 0, xi);
        let st = stress_at(sigma, t, nodes, &sp, xi);
        let tn = [
            st[0] * nrm[0] + st[1] * nrm[1],
            st[2] * nrm[0] + st[3] * nrm[1],
        ];
        let tv = traction.map_or([0.0; 2], |tr| {
            [
                tr[0].eval(sp.x[0], sp.x[1], 0.0),
                tr[1].eval(sp.x[0], sp.x[1], 0.0),
            ]
        });
        let m = [tv[0] - tn[0], tv[1] - tn[1]];
        let w = w * len;
        m2 += w * (m[0] * m[0] + m[1] * m[1]);
        let rot = [-(sp.x[1] - mid[1]), sp.x[0] - mid[0]];
        mom[0] += w * m[0];
        mom[1] += w * m[1];
        mom[2] += w * (m[0] * rot[0] + m[1] * rot[1]);
        scale += w * (tv[0].abs() + tv[1].abs() + tn[0].abs() + tn[1].abs());
    }
    let defect = mom[0].abs().max(mom[1].abs()).max(2.0 * mom[2].abs() / len);
    if defect > BOUND_MOMENT_RELATIVE * scale.max(sigma_scale * len) {
        return None;
    }
    let verts = [x[0], x[1], x[2]];
    let area = crate::geometry::straight_area(verts);
    let h = crate::geometry::diameter(fam, &x[..fam.nodes()]);
    let korn = super::bound::korn_constant(verts);
    let j = super::bound::J11;
    let factor =
        h * (1.0 + 0.5 * korn * korn).sqrt() * (len / area * (1.0 / (j * j) + 1.0 / j)).sqrt();
    Some(factor * m2.sqrt())
}

/// |||z_E|||_T of the module doc for the Dirichlet edge `l` of the straight cell `t`, or
/// `None` when the data are not met at the edge's ends (beyond `tol`, the round-off level of
/// [`super::displacement_tolerance`]) or not finite.
fn lifting(
    ctx: &Context,
    v: &[[f64; 2]],
    t: usize,
    l: usize,
    data: &[crate::expr::Expr; 2],
    tol: f64,
) -> Option<(f64, f64)> {
    let mesh = ctx.mesh;
    let (fam, x, nodes) = (mesh.family[t], mesh.coords(t), mesh.nodes(t));
    let edge = Edge::new(&x, l);
    let at = |s: f64| sub_point(fam, &x[..fam.nodes()], Shape::Affine, 0, edge.xi(s));
    for s in [0.0, 1.0] {
        let sp = at(s);
        let vv = sp.value_at(nodes, v);
        for i in 0..2 {
            let d = data[i].eval(sp.x[0], sp.x[1], 0.0) - vv[i];
            if d.is_nan() || d.abs() > tol {
                return None;
            }
        }
    }
    let samples = Edge::rule().map(|(s, w)| {
        let sp = at(s);
        let (vv, gv) = (sp.value_at(nodes, v), sp.gradient_at(nodes, v));
        let mut d = [0.0; 2];
        let mut dt = [0.0; 2];
        for i in 0..2 {
            let (ud, gd) = data[i].eval_gradient(sp.x[0], sp.x[1]);
            d[i] = ud - vv[i];
            dt[i] = (gd[0] - gv[i][0]) * edge.e[0] + (gd[1] - gv[i][1]) * edge.e[1];
        }
        (s, w, d, dt)
    });
    let (p, energy) = collapsed_lifting(&ctx.elastic, edge.a, edge.e, edge.c, samples);
    let z = energy.sqrt();
    (z.is_finite() && p.is_finite() && p > 0.0).then_some((p, z))
}

/// Degree up to which the inner integral of [`lift_pairing`] is exact: the divergence of
/// Cε(v) − τ − δ along a ray from the vertex c (δ the bubble of degree 7, `bubble`).
const PAIRING_DEGREE: usize = 8;

/// X = (m, ε(z))_T for the lifting `lift` and a symmetric field m = Cε(v) − s on its straight
/// cell, s the stress whose normal traces on ∂T are those of τ (the symmetric correction and the
/// bubble add none) and whose divergence is div τ + div δ. z vanishes on the two edges through
/// c and m is symmetric, so integrating by parts
///
/// ```text
/// X = ⟨m n, z⟩_E − (div m, z)_T
///   = |E| ∫_0^1 (m n)(x(s)) · d(s) ds − |D| ∫_0^1 d(s) · ∫_0^1 t^(p+1) div m(c + t q(s)) dt ds,
/// ```
///
/// q(s) = a + s e − c, n the outward normal on E. `edge_m(ξ)` gives m at reference point ξ of
/// the cell, `div_m(ξ)` its divergence. The inner integral is exact for div m of degree ≤
/// `PAIRING_DEGREE` along the ray (its values at PAIRING_DEGREE + 1 Chebyshev points give the
/// monomial coefficients c_j, and ∫_0^1 t^(p+1+j) dt = 1/(p + 2 + j)); the outer ones use the
/// panels of the data terms. Used for η_PS(v + z)² = η_PS(v)² + 2X + |||z|||² (design §6.2).
pub fn lift_pairing(
    ctx: &Context,
    v: &[[f64; 2]],
    lift: &Lift,
    edge_m: impl Fn([f64; 2]) -> [f64; 4],
    div_m: impl Fn([f64; 2]) -> [f64; 2],
) -> Option<f64> {
    let mesh = ctx.mesh;
    let t = lift.cell;
    let (fam, x, nodes) = (mesh.family[t], mesh.coords(t), mesh.nodes(t));
    let BoundaryKind::Dirichlet { displacement } = &ctx.scene.boundaries[lift.boundary].kind else {
        return None;
    };
    let edge = Edge::new(&x, lift.local);
    let xi_c = REF[(lift.local + 2) % 3];
    let xi_of = |s: f64, t: f64| {
        let xi_e = edge.xi(s);
        [
            xi_c[0] + t * (xi_e[0] - xi_c[0]),
            xi_c[1] + t * (xi_e[1] - xi_c[1]),
        ]
    };
    let d = |s: f64| -> [f64; 2] {
        let sp = sub_point(fam, &x[..fam.nodes()], Shape::Affine, 0, edge.xi(s));
        let vv = sp.value_at(nodes, v);
        std::array::from_fn(|i| displacement[i].eval(sp.x[0], sp.x[1], 0.0) - vv[i])
    };
    collapsed_pairing(
        edge.a,
        edge.e,
        edge.c,
        lift.p,
        Edge::rule(),
        d,
        |s| edge_m(edge.xi(s)),
        |s, t| div_m(xi_of(s, t)),
    )
}

/// The core of [`lift_pairing`] in collapsed coordinates x = c + t(a + s e − c): X for
/// z = t^p d(s), with m n on E from `m_edge(s)` and div m from `div_m(s, t)`, the outer
/// integrals by the rule `rule` on [0, 1].
#[allow(clippy::too_many_arguments)]
fn collapsed_pairing(
    a: [f64; 2],
    e: [f64; 2],
    c: [f64; 2],
    p: f64,
    rule: impl Iterator<Item = (f64, f64)>,
    d: impl Fn(f64) -> [f64; 2],
    m_edge: impl Fn(f64) -> [f64; 4],
    div_m: impl Fn(f64, f64) -> [f64; 2],
) -> Option<f64> {
    let len = e[0].hypot(e[1]);
    // Outward normal of T on E: away from c.
    let mut n = [e[1] / len, -e[0] / len];
    if (a[0] - c[0]) * n[0] + (a[1] - c[1]) * n[1] < 0.0 {
        n = [-n[0], -n[1]];
    }
    let ac = [a[0] - c[0], a[1] - c[1]];
    let dd = (e[0] * ac[1] - e[1] * ac[0]).abs();
    let k = PAIRING_DEGREE + 1;
    let nodes_t: Vec<f64> = (0..k)
        .map(|i| 0.5 - 0.5 * ((2 * i + 1) as f64 * std::f64::consts::PI / (2 * k) as f64).cos())
        .collect();
    let moments: Vec<f64> = (0..k).map(|j| 1.0 / (p + 2.0 + j as f64)).collect();
    // Weights ω_i with Σ_i ω_i g(t_i) = ∫_0^1 t^(p+1) g(t) dt for every g of degree < k:
    // Σ_i ω_i t_i^j = 1/(p + 2 + j), j < k.
    let omega = solve_small(
        k,
        (0..k)
            .flat_map(|j| nodes_t.iter().map(move |&ti| ti.powi(j as i32)))
            .collect(),
        moments,
    )?;
    let mut x_e = 0.0;
    for (s, w) in rule {
        let dv = d(s);
        let m = m_edge(s);
        let mn = [m[0] * n[0] + m[1] * n[1], m[2] * n[0] + m[3] * n[1]];
        let mut inner = [0.0; 2];
        for (&ti, oi) in nodes_t.iter().zip(&omega) {
            let g = div_m(s, ti);
            inner[0] += oi * g[0];
            inner[1] += oi * g[1];
        }
        x_e += w
            * (len * (mn[0] * dv[0] + mn[1] * dv[1]) - dd * (inner[0] * dv[0] + inner[1] * dv[1]));
    }
    x_e.is_finite().then_some(x_e)
}

/// Solves the k × k system A y = b (A row-major) by Gaussian elimination with partial
/// pivoting. None when singular.
fn solve_small(k: usize, a: Vec<f64>, b: Vec<f64>) -> Option<Vec<f64>> {
    let mut m: Vec<Vec<f64>> = (0..k)
        .map(|j| {
            let mut row = a[j * k..(j + 1) * k].to_vec();
            row.push(b[j]);
            row
        })
        .collect();
    for col in 0..k {
        let piv = (col..k).max_by(|&x, &y| m[x][col].abs().total_cmp(&m[y][col].abs()))?;
        if m[piv][col].abs() <= 1e-300 || m[piv][col].is_nan() {
            return None;
        }
        m.swap(col, piv);
        let pivot_row = m[col].clone();
        for (r, row) in m.iter_mut().enumerate() {
            if r != col {
                let f = row[col] / pivot_row[col];
                for (x, p) in row[col..].iter_mut().zip(&pivot_row[col..]) {
                    *x -= f * p;
                }
            }
        }
    }
    Some((0..k).map(|i| m[i][k] / m[i][i]).collect())
}

/// The exponent p and the energy |||z|||²_T of the lifting z = t^p d(s) of the module doc,
/// from samples (s, weight, d(s), d′(s)) of a rule on [0, 1]. With g₁ = d′(q_y, −q_x)/D and
/// g₂ = d(−e_y, e_x)/D, ∇z = t^(p−1)(g₁ + p g₂), so
///
/// ```text
/// |||z|||²_T = |D| ∫_0^1 t^(2p−1) dt ∫_0^1 Q(g₁ + p g₂) ds = |D|/(2p) (Q₁ + 2p Q₁₂ + p² Q₂),
/// ```
///
/// Q the energy density Cε:ε; p ↦ this is least at p = (Q₁/Q₂)^½, value |D|(√(Q₁Q₂) + Q₁₂)
/// (any p > 0 gives a lifting in H¹; a steeper decay than t pays for d′ rather than d).
fn collapsed_lifting(
    el: &Elastic,
    a: [f64; 2],
    e: [f64; 2],
    c: [f64; 2],
    samples: impl Iterator<Item = (f64, f64, [f64; 2], [f64; 2])>,
) -> (f64, f64) {
    let ac = [a[0] - c[0], a[1] - c[1]];
    let dd = e[0] * ac[1] - e[1] * ac[0];
    let (mut q1, mut q12, mut q2) = (0.0, 0.0, 0.0);
    for (s, w, d, dt) in samples {
        let q = [a[0] + s * e[0] - c[0], a[1] + s * e[1] - c[1]];
        let g1: [[f64; 2]; 2] = std::array::from_fn(|i| [dt[i] * q[1] / dd, -dt[i] * q[0] / dd]);
        let g2: [[f64; 2]; 2] = std::array::from_fn(|i| [-d[i] * e[1] / dd, d[i] * e[0] / dd]);
        q1 += w * energy_form(el, g1, g1);
        q12 += w * energy_form(el, g1, g2);
        q2 += w * energy_form(el, g2, g2);
    }
    if !(q1.is_finite() && q12.is_finite() && q2.is_finite()) {
        return (1.0, f64::NAN);
    }
    if q2 <= 0.0 {
        // d = 0 on the edge (then d′ = 0 too): nothing to lift.
        return (1.0, 0.0);
    }
    if q1 <= 0.0 {
        return (1.0, 0.5 * dd.abs() * (2.0 * q12 + q2).max(0.0));
    }
    let p = (q1 / q2).sqrt();
    (p, (dd.abs() * ((q1 * q2).sqrt() + q12)).max(0.0))
}

/// Cε(g):ε(h) for displacement gradients g, h (rows: components).
fn energy_form(el: &Elastic, g: [[f64; 2]; 2], h: [[f64; 2]; 2]) -> f64 {
    let (sg, sh) = (0.5 * (g[0][1] + g[1][0]), 0.5 * (h[0][1] + h[1][0]));
    2.0 * el.mu * (g[0][0] * h[0][0] + 2.0 * sg * sh + g[1][1] * h[1][1])
        + el.lambda * (g[0][0] + g[1][1]) * (h[0][0] + h[1][1])
}

/// σ at the point `sp` (reference coordinates `xi`) of cell `t`.
fn stress_at(sigma: StressField, t: usize, nodes: &[u32], sp: &SubPoint, xi: [f64; 2]) -> [f64; 4] {
    match sigma {
        StressField::Nodal(sv) => {
            let mut s = [0.0; 4];
            for (k, &p) in nodes.iter().enumerate() {
                for (m, sm) in s.iter_mut().enumerate() {
                    *sm += sv[p as usize][m] * sp.phi[k];
                }
            }
            s
        }
        StressField::Rt(rt) => rt.at(rt.first[t] as usize, &sp.jac, xi).0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// z(x) = t^p d(s) evaluated directly (inverting x = c + t(a + s e − c)), its gradient by
    /// central differences and its energy by a tensor Gauss rule on T: an independent check
    /// of the closed form of `collapsed_lifting`.
    /// The pairing X = (m, ε(z))_T of the closed form (integration by parts, exact inner
    /// integral) against a direct tensor Gauss quadrature of m : ∇z in collapsed coordinates,
    /// with z and ∇z from the collapsed map and m an affine symmetric field (div m constant).
    #[test]
    fn lift_pairing_matches_a_direct_quadrature() {
        let (a, b, c) = ([0.2, 0.1], [1.3, 0.4], [0.5, 1.1]);
        let e = [b[0] - a[0], b[1] - a[1]];
        let ac = [a[0] - c[0], a[1] - c[1]];
        let d = |s: f64| [s * (1.0 - s) * (1.0 + s).exp(), (s * (1.0 - s)).powi(2)];
        let dp = |s: f64| {
            let h = 1e-6;
            let (p, m) = (d(s + h), d(s - h));
            [(p[0] - m[0]) / (2.0 * h), (p[1] - m[1]) / (2.0 * h)]
        };
        // m(x) = M0 + x M1 + y M2 + x² M3 (quadratic: div m affine), symmetric.
        let m = |x: [f64; 2]| {
            [
                1.0 + 2.0 * x[0] - x[1] + 0.5 * x[0] * x[0],
                0.3 - x[0] + 0.7 * x[1],
                0.3 - x[0] + 0.7 * x[1],
                -2.0 + x[0] * x[1] + 0.2 * x[0] * x[0],
            ]
        };
        let div_m = |x: [f64; 2]| [2.0 + x[0] + 0.7, -1.0 + x[0]];
        let at = |s: f64, t: f64| {
            [
                c[0] + t * (a[0] + s * e[0] - c[0]),
                c[1] + t * (a[1] + s * e[1] - c[1]),
            ]
        };
        for p in [0.6, 1.0, 2.3] {
            let rule = line_rule_cached(30);
            let pts = || {
                rule.points
                    .iter()
                    .copied()
                    .zip(rule.weights.iter().copied())
            };
            let closed = collapsed_pairing(
                a,
                e,
                c,
                p,
                pts(),
                d,
                |s| m(at(s, 1.0)),
                |s, t| div_m(at(s, t)),
            )
            .expect("finite");
            // ∇z = t^(p−1)(d′(s)(q_y, −q_x) + p d(s)(−e_y, e_x))/D, D = e × (a − c) = −det.
            let dd = e[0] * ac[1] - e[1] * ac[0];
            let mut direct = 0.0;
            // t = u³ (dt = 3u² du) smooths t^p at t = 0 for the Gauss rule.
            for (s, ws) in pts() {
                for (u, wu) in pts() {
                    let (t, wt) = (u * u * u, 3.0 * u * u * wu);
                    let q = [a[0] + s * e[0] - c[0], a[1] + s * e[1] - c[1]];
                    let (dv, dpv) = (d(s), dp(s));
                    let g: [[f64; 2]; 2] = std::array::from_fn(|i| {
                        let f = t.powf(p - 1.0) / dd;
                        [
                            f * (dpv[i] * q[1] - p * dv[i] * e[1]),
                            f * (-dpv[i] * q[0] + p * dv[i] * e[0]),
                        ]
                    });
                    let mm = m(at(s, t));
                    let dens =
                        mm[0] * g[0][0] + mm[1] * g[0][1] + mm[2] * g[1][0] + mm[3] * g[1][1];
                    direct += ws * wt * dd.abs() * t * dens;
                }
            }
            assert!(
                (closed - direct).abs() < 1e-9 * direct.abs().max(1e-3),
                "p = {p}: closed {closed}, direct {direct}"
            );
        }
    }

    #[test]
    fn lifting_energy_matches_a_direct_quadrature_of_the_field() {
        let (a, b, c) = ([0.2, 0.1], [1.3, 0.4], [0.5, 1.1]);
        let e = [b[0] - a[0], b[1] - a[1]];
        let ac = [a[0] - c[0], a[1] - c[1]];
        let dd = e[0] * ac[1] - e[1] * ac[0];
        // d(s) vanishing at both ends, with a non-polynomial factor.
        let d = |s: f64| {
            [
                s * (1.0 - s) * (1.0 + s).exp(),
                (s * (1.0 - s)).powi(2) - 0.3 * s * (1.0 - s),
            ]
        };
        let dp = |s: f64| {
            let h = 1e-6;
            let (p, m) = (d(s + h), d(s - h));
            [(p[0] - m[0]) / (2.0 * h), (p[1] - m[1]) / (2.0 * h)]
        };
        let el = Elastic {
            mu: 3.0,
            lambda: 7.0,
        };
        // Closed form.
        let rule = line_rule_cached(30);
        let samples = rule
            .points
            .iter()
            .zip(&rule.weights)
            .map(|(&s, &w)| (s, w, d(s), dp(s)));
        let (p, closed) = collapsed_lifting(&el, a, e, c, samples);
        assert!(p > 1.5, "a steeper decay than t: p = {p}");
        // Direct: z at x by inverting the collapsed map, gradient by differences, energy by a
        // tensor Gauss rule in (s, t) with the Jacobian 2|T| t.
        let z = |x: [f64; 2]| {
            // x − c = t (q(s)) ⇒ solve for t·(a − c) + (t s) e.
            let r = [x[0] - c[0], x[1] - c[1]];
            let det = ac[0] * e[1] - ac[1] * e[0];
            let tt = (r[0] * e[1] - r[1] * e[0]) / det;
            let ts = (ac[0] * r[1] - ac[1] * r[0]) / det;
            let dv = d(ts / tt);
            let chi = tt.powf(p);
            [chi * dv[0], chi * dv[1]]
        };
        let mut direct = 0.0;
        let h = 1e-6;
        for (&s, &ws) in rule.points.iter().zip(&rule.weights) {
            for (&t, &wt) in rule.points.iter().zip(&rule.weights) {
                let x = [
                    c[0] + t * (a[0] + s * e[0] - c[0]),
                    c[1] + t * (a[1] + s * e[1] - c[1]),
                ];
                let (xp, xm, yp, ym) = (
                    z([x[0] + h, x[1]]),
                    z([x[0] - h, x[1]]),
                    z([x[0], x[1] + h]),
                    z([x[0], x[1] - h]),
                );
                let g: [[f64; 2]; 2] = std::array::from_fn(|i| {
                    [(xp[i] - xm[i]) / (2.0 * h), (yp[i] - ym[i]) / (2.0 * h)]
                });
                direct += ws * wt * dd.abs() * t * energy_form(&el, g, g);
            }
        }
        assert!((closed - direct).abs() < 1e-6 * direct, "{closed} {direct}");
        // And z = d on E, 0 on the other edges.
        let on_e = z([a[0] + 0.3 * e[0], a[1] + 0.3 * e[1]]);
        assert!((on_e[0] - d(0.3)[0]).abs() < 1e-12 && (on_e[1] - d(0.3)[1]).abs() < 1e-12);
        let on_ac = z([c[0] + 0.4 * ac[0], c[1] + 0.4 * ac[1]]);
        assert!(on_ac[0].abs() < 1e-12 && on_ac[1].abs() < 1e-12);
    }
}
