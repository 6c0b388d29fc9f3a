//! Penetration between the nodes of P2 contact edges, removed by a mid-edge lift (docs/design.md
//! §6.2, "between nodes").
//!
//! The projection onto K_u (`reconstruct::projection`) makes the nodal values admissible; a
//! quadratic trace can still cross the obstacle between them. On each such contact edge E the
//! mid-edge node is moved against the contact direction n_m (the direction at the midpoint):
//!
//! ```text
//! v' = v − Σ_E c_E n_m φ_m,   c_E = max_s (v_n(s) − g(s))⁺ / (φ_m(s) n(s)·n_m)   (sampled),
//! ```
//!
//! φ_m the mid node's shape function (1 at the midpoint, 0 at the ends and on the other edges'
//! midpoints). Then v' ∈ K_u at the samples, and by the triangle inequality
//! |||u − u_h||| ≤ |||u − v'||| + |||v' − v||| + |||v − u_h|||: the bound is taken for v' and
//! |||v' − v||| (computed by quadrature, exact for straight cells) is added to the projection
//! term. The complementarity pairing changes by
//! ⟨τ_n, v'_n − v_n⟩ = Σ_E c_E ∫_E (−τ_n) φ_m n·n_m ds ≥ 0 for τ_n ≤ 0, which is added.
//! With friction only edges with one contact direction are lifted (n = n_m: v'_t = v_t, and
//! the friction pairing is unchanged).

use super::boundary::maximum;
use crate::field::StressField;
use crate::geometry::Shape;
use crate::geometry::values::{sub_edge_point, sub_point};
use crate::problem::{Condition, Context};
use crate::quadrature::{line_rule_cached, triangle_rule_cached};
use crate::read::scene::{BoundaryKind, ContactNormal};
use crate::tolerance::{EDGE_DEGREE, LIFT_REFINE, LIFT_SAMPLES};

/// The lifted displacement and what it costs.
pub struct Lift {
    pub v: Vec<[f64; 2]>,
    /// |||v' − v|||.
    pub distance: f64,
    /// ⟨τ_n, v'_n − v_n⟩ ≥ 0, added to the complementarity term.
    pub complementarity: f64,
    /// Largest (v'_n − g)⁺ on the contact edges after the lift (`boundary::maximum`, as the
    /// admissibility check finds it).
    pub max_after: f64,
    /// Edges lifted.
    pub edges: usize,
}

/// The lift of module doc for P2 meshes whose contact edges penetrate by more than `tol`
/// between nodes; `None` when nothing is to be lifted. With friction (`frictional`) only the
/// edges along which the contact direction is constant are lifted.
pub fn lift(
    ctx: &Context,
    v: &[[f64; 2]],
    sigma: StressField,
    tol: f64,
    frictional: bool,
) -> Option<Lift> {
    let mesh = ctx.mesh;
    if mesh.degree != 2 {
        return None;
    }
    let topo = ctx.topo;
    let el = ctx.elastic;
    let mut out = v.to_vec();
    let mut cells = Vec::new();
    let mut moved: Vec<(usize, usize, f64, [f64; 2])> = Vec::new(); // (edge idx, mid, c, n_m)
    // Largest (v'_n − g)⁺ on the contact edges, found as the admissibility check finds it.
    let mut max_after: f64 = 0.0;
    for (ei, be) in ctx.edges.iter().enumerate() {
        let Condition::Contact(b) = be.condition else {
            continue;
        };
        let BoundaryKind::Contact(spec) = &ctx.scene.boundaries[b].kind else {
            continue;
        };
        let t = be.cell as usize;
        let l = be.local as usize;
        let fam = mesh.family[t];
        if fam.nodes() != 6 {
            continue;
        }
        let x = mesh.coords(t);
        let nodes = mesh.nodes(t);
        let sh = mesh.shape[t];
        let mid = topo.edge_mid[be.edge as usize];
        if mid == crate::mesh::NONE {
            continue;
        }
        let (_, normal_m, _, _) = sub_edge_point(fam, &x[..6], sh, 0, l, 0.5);
        let nm = spec.direction(normal_m);
        // (v_n − g, φ_m n·n_m) at edge parameter s; None where the gap is infinite.
        let at = |s: f64| {
            let (sp, normal, _, _) = sub_edge_point(fam, &x[..6], sh, 0, l, s);
            let cn = spec.direction(normal);
            let g = spec.gap_at(sp.x, cn);
            g.is_finite().then(|| {
                let u = sp.value_at(nodes, v);
                (
                    cn[0] * u[0] + cn[1] * u[1] - g,
                    sp.phi[3 + l] * (cn[0] * nm[0] + cn[1] * nm[1]),
                )
            })
        };
        let lifted =
            |c: f64| move |s: f64| at(s).map_or(f64::NEG_INFINITY, |(pen, phi)| pen - c * phi);
        // With friction the pairing ∫ 𝔉|τ_n||v_t| + τ_t v_t must not change: only where the
        // contact direction is one along the edge (the obstacle's normal, or a straight edge)
        // does the move along n_m leave v_t as it is.
        let fixed_direction = spec.normal == ContactNormal::Obstacle || sh == Shape::Affine;
        if frictional && !fixed_direction {
            max_after = max_after.max(maximum(lifted(0.0)).0);
            continue;
        }
        let mut c: f64 = 0.0;
        for i in 1..LIFT_SAMPLES {
            if let Some((pen, phi)) = at(i as f64 / LIFT_SAMPLES as f64)
                && pen > tol
                && phi > 0.0
            {
                c = c.max(pen / phi);
            }
        }
        // The samples miss a crossing between them, next to an active node where φ_m is
        // small (CalculiX's two-body Hertz file: 5.3e-10 at s ≈ 1/100 of a curved edge, the
        // samples all admissible): the admissibility check's own maximiser then raises c until
        // what is left is below tol / 2. Where the penetration and φ_m vanish together at an
        // active end node and their ratio r = pen/φ_m rises towards it, the maximiser chases
        // that end: near it h = φ_m (r − c) ≈ 4t(r₁ − c − kt) (t = 1 − s) peaks at
        // t = (r₁ − c)/(2k), where r = (r₁ + c)/2, so the plain step only halves r₁ − c (and
        // quarters what is left) each round; 8 rounds left 4.8e-12 (above tol) on a Hertz P2
        // edge ending at a Dirichlet node that touches a side obstacle. From the second round
        // on the step is doubled, which lands on r₁ in that model; a first-round maximum
        // inside the edge (the CalculiX case) is closed by the plain step before.
        for round in 0..LIFT_REFINE {
            let (left, s) = maximum(lifted(c));
            let phi = at(s).map_or(0.0, |a| a.1);
            if left.is_nan() || left <= 0.5 * tol || phi <= 0.0 {
                break;
            }
            c += if round == 0 { 1.0 } else { 2.0 } * left / phi;
        }
        max_after = max_after.max(maximum(lifted(c)).0);
        if c > 0.0 {
            moved.push((ei, mid as usize, c, nm));
            cells.push(t);
        }
    }
    if moved.is_empty() {
        return None;
    }
    for &(_, mid, c, nm) in &moved {
        out[mid][0] -= c * nm[0];
        out[mid][1] -= c * nm[1];
    }
    // |||v' − v|||² over the cells of the lifted edges: a boundary edge's mid node belongs to
    // its one cell only.
    let delta: Vec<[f64; 2]> = out
        .iter()
        .zip(v)
        .map(|(a, b)| [a[0] - b[0], a[1] - b[1]])
        .collect();
    let rule = triangle_rule_cached(8);
    let mut d2 = 0.0;
    cells.sort_unstable();
    cells.dedup();
    for &t in &cells {
        let fam = mesh.family[t];
        let x = mesh.coords(t);
        let nodes = mesh.nodes(t);
        for (&xi, &wq) in rule.points.iter().zip(&rule.weights) {
            let sp = sub_point(fam, &x[..fam.nodes()], mesh.shape[t], 0, xi);
            let g = sp.gradient_at(nodes, &delta);
            let sym = 0.5 * (g[0][1] + g[1][0]);
            let eps = [g[0][0], sym, sym, g[1][1]];
            let s = el.stress(eps);
            d2 += wq * sp.jac.det * (s[0] * eps[0] + 2.0 * s[1] * eps[1] + s[3] * eps[3]);
        }
    }
    // The complementarity change on the lifted edges.
    let lr = line_rule_cached(EDGE_DEGREE);
    let mut dc = 0.0;
    for &(ei, _, c, nm) in &moved {
        let be = &ctx.edges[ei];
        let Condition::Contact(b) = be.condition else {
            continue;
        };
        let BoundaryKind::Contact(spec) = &ctx.scene.boundaries[b].kind else {
            continue;
        };
        let t = be.cell as usize;
        let l = be.local as usize;
        let fam = mesh.family[t];
        let x = mesh.coords(t);
        let nodes = mesh.nodes(t);
        let sh = mesh.shape[t];
        for (&s, &wq) in lr.points.iter().zip(&lr.weights) {
            let (sp, normal, len, xs) = sub_edge_point(fam, &x[..6], sh, 0, l, s);
            let cn = spec.direction(normal);
            let tau = match sigma {
                StressField::Rt(rt) => rt.at(rt.first[t] as usize, &sp.jac, xs).0,
                StressField::Nodal(sv) => {
                    let mut sn = [0.0; 4];
                    for (k, &p) in nodes.iter().enumerate() {
                        for (m, smv) in sn.iter_mut().enumerate() {
                            *smv += sv[p as usize][m] * sp.phi[k];
                        }
                    }
                    sn
                }
            };
            let tr = [
                tau[0] * normal[0] + tau[1] * normal[1],
                tau[2] * normal[0] + tau[3] * normal[1],
            ];
            let tn = cn[0] * tr[0] + cn[1] * tr[1];
            let phi = sp.phi[3 + l] * (cn[0] * nm[0] + cn[1] * nm[1]);
            dc += wq * len * (-tn) * c * phi;
        }
    }
    Some(Lift {
        v: out,
        distance: d2.max(0.0).sqrt(),
        complementarity: dc,
        max_after: max_after.max(0.0),
        edges: moved.len(),
    })
}
