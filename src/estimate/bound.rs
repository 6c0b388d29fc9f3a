//! The error bound of docs/design.md §6 for the pair (v, τ) evaluated:
//!
//! ```text
//! |||u − v||| ≤ ½ (R + √(R² + 4c)),   R = (Σ_T (η_PS,T + η_osc,T + η_as,T)²)^½,
//! |||u − u_h||| ≤ |||u − v||| + ‖v − u_h‖_E (projection distance),
//! ```
//!
//! or, with a Dirichlet lifting z of the data v misses, the least of that triangle form and two
//! hypercircle forms (`combine`, design §6.2 "Combination"),
//!
//! with |||w|||² = (Cε(w), ε(w)), η_PS = ‖C^{1/2}ε(v) − C^{−1/2} sym τ‖, c = ⟨τ_n, v_n − g⟩ (+ the
//! friction pairing, Tresca-labelled), and per cell, with r = div τ + f ⊥ rigid motions and
//! ∫_T as τ = 0 (as τ = τ_xy − τ_yx):
//!
//! ```text
//! (r, w)_T ≤ (h_T/j₁,₁) (1 + ½K_T²)^{1/2} ‖r‖_T ‖ε(w)‖_T  (Laugesen–Siudeja, triangles; [`J11`])
//! ½(as τ, rot w)_T ≤ ½ K_T ‖as τ‖_T ‖ε(w)‖_T,   K_T = 2/β_T     (§6.4: ∇rot w = 2 div(Mε(w)))
//! ‖ε(w)‖ ≤ |||w||| / √c_min,   c_min = min(2μ, 2(μ + λ)).
//! ```
//!
//! β_T is the inf-sup constant of the divergence on T; it is taken as sin(θ_min/4), the
//! Horgan–Payne bound with the incentre as star centre (HP angle θ_min/2). That bound is not
//! proven for every domain (Costabel–Dauge 2015), so every term it enters is reported and the
//! bound is called guaranteed only when those terms vanish to round-off.
//!
//! `energy_error` bounds (½|||u − u_h|||²)^½, the units of η.

use rayon::prelude::*;
use serde::Serialize;

use super::{Admissibility, Terms, failed_checks};
use super::{bubble, data, lift, subcell, symmetric};
use crate::element::rt::MAX_RT_DOFS;
use crate::field::{RtStress, StressField};
use crate::geometry::Shape;
use crate::geometry::values::{SubPoint, TriangleTable, rule_degree, sub_point};
use crate::problem::Context;
use crate::quadrature::{TriangleRule, triangle_rule_cached};
use crate::tolerance::{
    BOUND_MOMENT_RELATIVE, BUBBLE_WORTH, LOAD_DEGREE, STRAIGHT_MID_RELATIVE, SYMMETRIC_RESIDUAL,
    UNCERTIFIED_NEGLIGIBLE,
};

/// The terms of the bound (units of |||·|||, i.e. √(2 × energy); `complementarity` in energy).
#[derive(Clone, Debug, Default, Serialize, serde::Deserialize, PartialEq)]
pub struct BoundTerms {
    /// η_PS = ‖C^{1/2}ε(v) − C^{−1/2} sym τ‖.
    pub prager_synge: f64,
    /// c = ⟨τ_n, v_n − g⟩_{Γ_C} (+ ∫ 𝔉|τ_n||v_t| + τ_t v_t with friction).
    pub complementarity: f64,
    /// η_osc: the body-force oscillation f − Π_k f.
    pub oscillation: f64,
    /// η_as: the asymmetry of τ.
    pub asymmetry: f64,
    /// ‖v − u_h‖_E when the displacement was projected onto K_u, else 0.
    pub projection: f64,
    /// η_tr: Neumann data outside the normal traces of τ, (Σ_T η_tr,T²/c_min)^½
    /// (`estimate::data`, design §6.2).
    #[serde(default)]
    pub traction: f64,
    /// |||z|||: the lifting of the Dirichlet data that v misses between its nodes
    /// (`estimate::data`), added like the projection distance.
    #[serde(default)]
    pub dirichlet_lift: f64,
    /// R = (Σ_T (η'_PS,T + (η_osc,T + η_as,T + η_tr,T)/√c_min)²)^½, η'_PS,T ≥ η_PS,T(v + z)
    /// (η_PS,T + |||z|||_T, or (η_PS,T² + 2X_T + |||z|||²_T)^½ on symmetrised lift cells): the
    /// terms bound the cell's share of |||w|||² against |||w|||_T, so Cauchy–Schwarz over the
    /// cells needs only their sum per cell (docs/design.md §6.2).
    #[serde(default)]
    pub combined: f64,
    /// O = (Σ_T ((η_osc,T + η_as,T + η_tr,T)/√c_min)²)^½, the bound of the pairing
    /// (div τ + f, w) + (as τ, skw ∇w) + ⟨t − τn, w⟩_{Γ_N} against |||w||| (Cauchy–Schwarz over
    /// the cells), used by the hypercircle forms (docs/design.md §6.2 "Combination").
    #[serde(default)]
    pub pairing: f64,
    /// Which combination gave `energy_error`: "triangle" (|||u − v||| ≤ ½(R + √(R² + 4c)) +
    /// |||z|||), "hypercircle" or "hypercircle-quadratic" (docs/design.md §6.2 "Combination").
    #[serde(default)]
    pub combination: String,
    /// |||ũ_h − u_h|||: on a mesh with quadrilaterals the bound is taken for the P2
    /// interpolant ũ_h on a triangle split (the halves, or four triangles about each centre;
    /// `estimate::halves`, design §6.3), and this distance is added like the projection
    /// distance.
    #[serde(default)]
    pub halves: f64,
    /// |||ū_h − u_h|||_h: a displacement written per cell whose node copies disagree (an
    /// exploded file of a discontinuous field) is averaged over them when the mesh is built;
    /// the bound is taken for that average ū_h, and this distance in the broken energy norm
    /// added, so that it bounds the error of the file's u_h in the broken norm (design §4.2,
    /// "Discontinuous displacements").
    #[serde(default)]
    pub copies: f64,
    /// Largest local Korn constant K_T used.
    pub korn_max: f64,
    /// Cells whose stress was made exactly symmetric by the Alfeld-split correction
    /// (`estimate::symmetric`, design §5.11; straight and curved P2 triangles); their
    /// asymmetry term is 0 and their η_PS is that of the corrected stress.
    #[serde(default)]
    pub symmetrised_cells: usize,
}

/// The bound and its status.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Bound {
    pub guaranteed: bool,
    /// Upper bound of (½|||u − u_h|||²)^½ when computable (units of η).
    pub energy_error: Option<f64>,
    /// energy_error / (½|||u_h|||²)^½.
    pub relative: Option<f64>,
    /// What the number bounds.
    pub statement: String,
    pub terms: Option<BoundTerms>,
    pub failed_hypotheses: Vec<String>,
    /// Per cell: (η_PS,T + (osc_T + as_T)/√c_min)², summing to R² (units of |||·|||²).
    pub cells: Vec<f64>,
    /// ½|||v|||², the reference of `relative`.
    #[serde(skip)]
    pub energy: f64,
}

impl Bound {
    /// The bound for the file's u_h when the pair used its projection v onto K_u:
    /// |||u − u_h||| ≤ |||u − v||| + ‖v − u_h‖_E (the other terms do not change).
    pub fn add_projection(&mut self, distance: f64) {
        let Some(t) = self.terms.as_mut() else {
            return;
        };
        t.projection += distance;
        self.refresh();
    }

    /// The bound taken for ũ_h on the triangle halves, made one for u_h on the parent mesh
    /// (design §6.3): |||u − u_h||| ≤ |||u − ũ_h||| + `distance`.
    pub fn add_halves(&mut self, distance: f64) {
        let Some(t) = self.terms.as_mut() else {
            return;
        };
        t.halves += distance;
        self.refresh();
    }

    /// The bound taken for the average ū_h of a displacement whose node copies disagree, made
    /// one for the file's u_h in the broken energy norm: |||u − u_h|||_h ≤ |||u − ū_h||| +
    /// `distance` (the triangle inequality; u and ū_h are continuous).
    pub fn add_copies(&mut self, distance: f64) {
        let Some(t) = self.terms.as_mut() else {
            return;
        };
        t.copies += distance;
        self.refresh();
    }

    /// `relative` against `energy` (the energy of u_h where the bound was taken for another
    /// displacement: ũ_h on the triangle halves).
    pub fn set_reference_energy(&mut self, energy: f64) {
        self.energy = energy;
        self.refresh();
    }

    /// `energy_error` and `relative` from the terms.
    fn refresh(&mut self) {
        let Some(t) = self.terms.as_ref() else {
            return;
        };
        if let Some(e) = self.energy_error.as_mut() {
            *e = energy_error(t);
            self.relative = (self.energy > 0.0).then(|| *e / self.energy.sqrt());
        }
    }
}

/// (½)^½ (E + ‖v − u_h‖_E) with E the least of three upper bounds of |||u − v|||
/// (docs/design.md §6.2 "Combination"); with a = ½(R + √(R² + 4c)) ≥ |||u − v'|||,
/// v' = v + z, P = η_PS(v), Z = |||z|||, O = `pairing`:
///
/// ```text
/// triangle:               E ≤ a + Z
/// hypercircle:            E² ≤ P² + Z² + 2c + 2O a
/// hypercircle-quadratic:  E ≤ O + √(O² + P² + Z² + 2c + 2OZ)
/// ```
///
/// The hypercircle forms rest on |||u − v|||² = P² − b² + 2(σ − sym τ, ε(u − v')) +
/// 2(σ − sym τ, ε(z)) with b = ‖σ − sym τ‖_A, the second pairing ≤ bZ and −b² + 2bZ ≤ Z², so
/// the Dirichlet lifting enters squared instead of twice linearly.
fn combine(t: &BoundTerms) -> (f64, &'static str) {
    let (r, p, o, z) = (t.combined, t.prager_synge, t.pairing, t.dirichlet_lift);
    let c = t.complementarity.max(0.0);
    let a = 0.5 * (r + (r * r + 4.0 * c).sqrt());
    let forms = [
        (a + z, "triangle"),
        (
            (p * p + z * z + 2.0 * c + 2.0 * o * a).sqrt(),
            "hypercircle",
        ),
        (
            o + (o * o + p * p + z * z + 2.0 * c + 2.0 * o * z).sqrt(),
            "hypercircle-quadratic",
        ),
    ];
    // NaN terms must not be hidden by the minimum: they poison every form alike.
    if forms.iter().any(|f| !f.0.is_finite()) {
        return (f64::NAN, "triangle");
    }
    forms.into_iter().fold(
        (f64::INFINITY, "triangle"),
        |m, f| if f.0 < m.0 { f } else { m },
    )
}

/// (½)^½ (E + ‖v − u_h‖_E + |||ũ_h − u_h||| + |||ū_h − u_h|||_h), E from [`combine`] (the
/// third term only on the triangle halves of a mesh with quadrilaterals, the last only for a
/// displacement whose node copies disagree).
fn energy_error(t: &BoundTerms) -> f64 {
    0.5f64.sqrt() * (combine(t).0 + t.projection + t.halves + t.copies)
}

/// j₁,₁ ≈ 3.8317, the first positive root of the Bessel function J₁: on a triangle T of
/// diameter h every mean-free φ ∈ H¹(T) has ‖φ‖_T ≤ (h/j₁,₁)‖∇φ‖_T (Laugesen and Siudeja,
/// "Minimizing Neumann fundamental tones of triangles: an optimal Poincaré inequality",
/// J. Differential Equations 249 (2010): μ₁h² is least for the degenerate acute isosceles
/// triangle, where it tends to j₁,₁²). It replaces Payne–Weinberger's π (any convex domain) on
/// straight cells; curved cells keep π.
pub const J11: f64 = 3.831_705_970_207_512;

/// Per-cell results of the pass over the cells.
#[derive(Clone, Copy, Default)]
struct Cell {
    ps2: f64,
    local: f64,
    osc: f64,
    asym: f64,
    energy: f64,
    /// Cell moment defects, relative: rigid-motion moments of r, the mean of as τ.
    moment: f64,
    mean_as: f64,
    korn: f64,
    symmetrised: bool,
}

/// [`bound`] on the P2 elevation of a P1 triangle mesh: every cell one P2 triangle with
/// straight mid-edge nodes (`halves::split` with one sub-square). On it v, τ (a nodal τ with
/// the mid-edge values of its linear interpolant), the admissibility and the pairings `f` are
/// those of the P1 mesh, and [`lift::lift`] can move the mid-edge nodes of the contact edges
/// whose linear trace crosses a convex obstacle between admissible vertices (design §6.2,
/// "Between nodes"). None when the elevation cannot be built.
fn on_elevation(
    ctx: &Context,
    v: &[[f64; 2]],
    sigma: StressField,
    f: &Terms,
    adm: &Admissibility,
) -> Option<Bound> {
    let elevated = super::halves::split(
        ctx,
        std::path::Path::new(""),
        v,
        super::halves::Pattern::Lattice(1),
    )
    .ok()?;
    // Cell t of the elevation is cell t of the mesh, with the same vertex order, so the
    // coefficients of τ and the per-cell contributions carry over as they are.
    if elevated.parent.len() != ctx.mesh.len()
        || elevated
            .parent
            .iter()
            .enumerate()
            .any(|(s, &t)| s != t as usize)
    {
        return None;
    }
    // A nodal stress gets the mid-edge values of its linear interpolant too (the split puts
    // the node of edge e at index npts + e).
    let (npts, edges) = (ctx.mesh.points.len(), &ctx.topo.edges);
    if elevated.u.len() != npts + edges.len() {
        return None;
    }
    let nodal: Vec<[f64; 4]> = match sigma {
        StressField::Nodal(values) => values
            .iter()
            .copied()
            .chain(edges.iter().map(|&[a, b]| {
                let (a, b) = (values[a as usize], values[b as usize]);
                std::array::from_fn(|i| 0.5 * (a[i] + b[i]))
            }))
            .collect(),
        StressField::Rt(_) => Vec::new(),
    };
    let sigma = match sigma {
        StressField::Nodal(_) => StressField::Nodal(&nodal),
        rt => rt,
    };
    let mut sub = Context::new(
        &elevated.data.mesh,
        &elevated.topo,
        ctx.scene,
        &elevated.edges,
        ctx.norm,
    );
    sub.length_scale = ctx.length_scale;
    let mut b = bound(&sub, &elevated.u, sigma, f, adm);
    b.statement = format!(
        "{} (taken on the P2 elevation of the P1 mesh, where the mid-edge nodes of the contact \
         edges that cross the obstacle are moved off it)",
        b.statement
    );
    Some(b)
}

/// The bound for displacement `v` and stress `sigma` (docs/design.md §6).
pub fn bound(
    ctx: &Context,
    v: &[[f64; 2]],
    sigma: StressField,
    f: &Terms,
    adm: &Admissibility,
) -> Bound {
    bound_with(ctx, v, sigma, f, adm, None)
}

/// [`bound`] for v + `shift` on a triangle split (design §6.3, "u_h itself"): the gradient of
/// the displacement paired with `sigma` is ∇v + ∇(u_h − ũ_h) in every cell term; the traces,
/// and with them the admissibility, the pairings, the lift and the data terms, are those of v.
pub fn bound_with(
    ctx: &Context,
    v: &[[f64; 2]],
    sigma: StressField,
    f: &Terms,
    adm: &Admissibility,
    shift: Option<&super::halves::Shift>,
) -> Bound {
    let mesh = ctx.mesh;
    let el = ctx.elastic;
    let mut failed = Vec::new();
    let frictional = ctx
        .scene
        .boundaries
        .iter()
        .any(|b| b.contact().is_some_and(|c| c.friction > 0.0));
    if el.lambda.is_infinite() {
        return Bound {
            statement: "no bound: at ν = 0.5 (λ = ∞) the energy norm of u − u_h is not defined \
                        for a displacement that is not divergence-free"
                .into(),
            failed_hypotheses: vec!["ν = 0.5: no bound in the energy norm".into()],
            ..Default::default()
        };
    }
    if mesh.family.iter().any(|f| f.is_quad()) {
        return Bound {
            statement: "no bound: on quadrilateral cells the bound is taken on their triangle \
                        halves, under --stress auto or patch (docs/design.md §6.3)"
                .into(),
            failed_hypotheses: vec![
                "quadrilateral cells: the bound is taken on their triangle halves (--stress \
                 auto or patch)"
                    .into(),
            ],
            ..Default::default()
        };
    }
    // A P2 trace that crosses the obstacle between admissible nodes: the bound is taken for
    // the lifted v' (lift.rs), the lift's distance and pairing added.
    let tol = adm.displacement_tolerance();
    // A P1 trace crosses a convex obstacle between its active nodes: the same lift on the P2
    // elevation of the mesh.
    if mesh.degree == 1
        && adm.penetration.max > tol
        && let Some(b) = on_elevation(ctx, v, sigma, f, adm)
    {
        return b;
    }
    let lifted = if adm.penetration.max > tol {
        lift::lift(ctx, v, sigma, tol, frictional)
    } else {
        None
    };
    let mut adm_used = adm.clone();
    if let Some(l) = &lifted {
        adm_used.penetration.max = l.max_after;
    }
    let v: &[[f64; 2]] = lifted.as_ref().map_or(v, |l| &l.v[..]);
    let sigma_scale = sigma.scale(mesh);
    // Data outside the discrete spaces become terms (data.rs); where every such edge has its
    // term, the mismatch is no longer a failed hypothesis.
    let dt = data::data_terms(ctx, v, sigma, sigma_scale);
    let mut lifts_of: std::collections::HashMap<usize, Vec<data::Lift>> = Default::default();
    for l in &dt.lifts {
        lifts_of.entry(l.cell).or_default().push(*l);
    }
    if dt.traction_covered {
        adm_used.neumann = super::Violation::default();
    }
    if dt.dirichlet_covered {
        adm_used.dirichlet = super::Violation::default();
    }
    let adm = &adm_used;
    let c_min = (2.0 * el.mu).min(2.0 * (el.mu + el.lambda));
    let f_expr = ctx.scene.body_force.as_ref();
    let f_poly = f_expr.is_none_or(|f| f[0].is_constant() && f[1].is_constant());
    // The bubble fit's points (the load rule on the 4 cells of the split) and the points on
    // which its result is measured (a Gauss–Jacobi rule on the same split, other points, exact
    // to degree 15 ≥ 2 deg δ for |sym τ + δ − Cε(v)|²).
    let (fit_rule, check_rule) = if f_poly {
        (TriangleRule::default(), TriangleRule::default())
    } else {
        (
            crate::quadrature::split_rule(LOAD_DEGREE, 1),
            crate::quadrature::split_rule(2 * bubble::Bubble::DEGREE, 1),
        )
    };
    // The fit and measure points of the depth-2 split (subcell.rs): lower degrees on 16 cells.
    let deep_rules = if f_poly {
        (TriangleRule::default(), TriangleRule::default())
    } else {
        (
            crate::quadrature::split_rule(8, 2),
            crate::quadrature::split_rule(10, 2),
        )
    };
    // The bases at the split points of the symmetric correction, per degree m it may use, and
    // at the points of the affine cells' rule (`BasisTable`), per triangle family present.
    // With a shift: the correction's degree on rational cells (k + 3), and the points at which
    // its term is integrated again (`symmetric::corrected_ps2`).
    let (split_tables, rule_tables, check_tables) = match sigma {
        StressField::Rt(rt) => {
            let k = rt.order.k();
            let mut ms = vec![k + 2];
            if !f_poly && (k + 2) < bubble::Bubble::DEGREE + 1 {
                ms.push(bubble::Bubble::DEGREE + 1);
            }
            if shift.is_some() {
                ms.push(k + 3);
            }
            let split = BasisTable::build(mesh, rt.order, &ms, symmetric::affine_points);
            let check = if shift.is_some() {
                BasisTable::build(mesh, rt.order, &[k + 3], |m| {
                    symmetric::corrected_points(m, super::halves::DISTANCE_DEGREE_OTHER)
                })
            } else {
                Vec::new()
            };
            let rule = if f_poly || shift.is_some() {
                let mut degrees: Vec<usize> = if f_poly {
                    [1, 2]
                        .map(|p| rule_degree(Shape::Affine, affine_degree(sigma, p)))
                        .to_vec()
                } else {
                    Vec::new()
                };
                if shift.is_some() {
                    degrees.push(rule_degree(
                        Shape::Affine,
                        super::halves::DISTANCE_DEGREE_OTHER,
                    ));
                }
                degrees.sort_unstable();
                degrees.dedup();
                BasisTable::build(mesh, rt.order, &degrees, |d| {
                    triangle_rule_cached(d).points.clone()
                })
            } else {
                Vec::new()
            };
            (split, rule, check)
        }
        StressField::Nodal(_) => (Vec::new(), Vec::new(), Vec::new()),
    };
    // (sigma_scale: the round-off floor of the moment checks, the stress scale times the
    // cell's area; a zero divergence or asymmetry has nothing else to be measured against.)
    let cells: Vec<Cell> = (0..mesh.len())
        .into_par_iter()
        .with_min_len(256)
        .map(|t| {
            let fam = mesh.family[t];
            let x = mesh.coords(t);
            let nodes = mesh.nodes(t);
            let sh = mesh.shape[t];
            // u_h through a parent that is not a parallelogram is rational: the rule of
            // `halves::distance` for such cells.
            let rational = shift.is_some_and(|sf| sf.rational(t));
            let deg = if rational {
                super::halves::DISTANCE_DEGREE_OTHER
            } else if !f_poly {
                LOAD_DEGREE
            } else if sh == Shape::Affine {
                affine_degree(sigma, fam.degree())
            } else {
                8
            };
            let rule = triangle_rule_cached(rule_degree(sh, deg));
            let verts = [x[0], x[1], x[2]];
            let h = crate::geometry::diameter(fam, &x[..fam.nodes()]);
            let korn = korn_constant(verts);
            // The centroid's offset from the first vertex (SubPoint::from: x − x̄ keeps the
            // digits of the cell's size on a mesh far from the origin).
            let centre = [
                ((verts[1][0] - verts[0][0]) + (verts[2][0] - verts[0][0])) / 3.0,
                ((verts[1][1] - verts[0][1]) + (verts[2][1] - verts[0][1])) / 3.0,
            ];
            let mut c = Cell {
                korn,
                ..Default::default()
            };
            let shifted = |g: [[f64; 2]; 2], sp: &SubPoint| match shift {
                Some(sf) => {
                    let d = sf.gradient(t, sp);
                    std::array::from_fn(|a| std::array::from_fn(|b| g[a][b] + d[a][b]))
                }
                None => g,
            };
            let (mut r2, mut a2, mut mom, mut mscale, mut amean, mut ascale) =
                (0.0, 0.0, [0.0; 3], 0.0, 0.0, 0.0);
            // A body force outside P_k on a straight cell with an RT stress: keep the points
            // for the bubble correction (bubble.rs), which moves the reachable part of r into
            // the Prager–Synge term (not on a rational cell: its measure rule is not exact there).
            let relieve = !f_poly
                && !rational
                && sh == Shape::Affine
                && !fam.is_quad()
                && matches!(sigma, StressField::Rt(_));
            // The rule's points from the table on affine cells (same values as sub_point).
            let table = if sh == Shape::Affine {
                BasisTable::find(&rule_tables, rule_degree(sh, deg), fam)
            } else {
                None
            };
            for (p, (&xi, &wq)) in rule.points.iter().zip(&rule.weights).enumerate() {
                let sp = match table {
                    Some(tb) => tb.geometry.point(&x[..fam.nodes()], p),
                    None => sub_point(fam, &x[..fam.nodes()], sh, 0, xi),
                };
                let w = wq * sp.jac.det;
                let gu = shifted(sp.gradient_at(nodes, v), &sp);
                let (s, d) = match sigma {
                    StressField::Nodal(sv) => {
                        let (mut sn, mut dn) = ([0.0; 4], [0.0; 2]);
                        for (k, &p) in nodes.iter().enumerate() {
                            let (sk, g) = (sv[p as usize], sp.grad[k]);
                            for (m, sm) in sn.iter_mut().enumerate() {
                                *sm += sk[m] * sp.phi[k];
                            }
                            dn[0] += sk[0] * g[0] + sk[1] * g[1];
                            dn[1] += sk[2] * g[0] + sk[3] * g[1];
                        }
                        (sn, dn)
                    }
                    StressField::Rt(rt) => match table {
                        Some(tb) => rt.at_reference(rt.first[t] as usize, &sp.jac, &tb.rt[p]),
                        None => rt.at(rt.first[t] as usize, &sp.jac, xi),
                    },
                };
                let sym = 0.5 * (gu[0][1] + gu[1][0]);
                let eps = [gu[0][0], sym, sym, gu[1][1]];
                let ss = 0.5 * (s[1] + s[2]);
                let a = el.compliance([s[0], ss, ss, s[3]]);
                let e = [eps[0] - a[0], eps[1] - a[1], eps[2] - a[2], eps[3] - a[3]];
                let tr = e[0] + e[3];
                c.ps2 += w
                    * (2.0 * el.mu * (e[0] * e[0] + e[1] * e[1] + e[2] * e[2] + e[3] * e[3])
                        + el.lambda * tr * tr);
                let tre = eps[0] + eps[3];
                c.energy += w
                    * 0.5
                    * (2.0 * el.mu * (eps[0] * eps[0] + 2.0 * eps[1] * eps[1] + eps[3] * eps[3])
                        + el.lambda * tre * tre);
                let fv = match f_expr {
                    None => [0.0; 2],
                    Some(fe) => [
                        fe[0].eval(sp.x[0], sp.x[1], 0.0),
                        fe[1].eval(sp.x[0], sp.x[1], 0.0),
                    ],
                };
                let r = [d[0] + fv[0], d[1] + fv[1]];
                r2 += w * (r[0] * r[0] + r[1] * r[1]);
                let d = sp.from(verts[0]);
                let rot = [-(d[1] - centre[1]), d[0] - centre[0]];
                mom[0] += w * r[0];
                mom[1] += w * r[1];
                mom[2] += w * (r[0] * rot[0] + r[1] * rot[1]);
                mscale += w * h * (d[0].abs() + d[1].abs() + fv[0].abs() + fv[1].abs());
                let asv = s[1] - s[2];
                a2 += w * asv * asv;
                amean += w * asv;
                ascale += w * (s[1].abs() + s[2].abs());
            }
            let poincare = if sh == Shape::Affine {
                h / J11
            } else {
                h / std::f64::consts::PI
            };
            let osc_factor = poincare * (1.0 + 0.5 * korn * korn).sqrt();
            // Only where the oscillation is a visible part of the cell's share (a fit costs
            // ~0.2 ms; any δ, or none, gives a valid bound).
            let weight = osc_factor * osc_factor / c_min;
            // The bubble's data at a reference point of the cell (RT stress, straight cell).
            let point = |rt: &RtStress, xi: [f64; 2], wq: f64| {
                let sp = sub_point(fam, &x[..fam.nodes()], sh, 0, xi);
                let gu = shifted(sp.gradient_at(nodes, v), &sp);
                let (s, d) = rt.at(rt.first[t] as usize, &sp.jac, xi);
                let sym = 0.5 * (gu[0][1] + gu[1][0]);
                let ce = el.stress([gu[0][0], sym, sym, gu[1][1]]);
                let ss = 0.5 * (s[1] + s[2]);
                let fv = f_expr.map_or([0.0; 2], |fe| {
                    [
                        fe[0].eval(sp.x[0], sp.x[1], 0.0),
                        fe[1].eval(sp.x[0], sp.x[1], 0.0),
                    ]
                });
                let pt = bubble::Point {
                    w: wq * sp.jac.det,
                    lam: [1.0 - xi[0] - xi[1], xi[0], xi[1]],
                    mismatch: [s[0] - ce[0], ss - ce[1], ss - ce[2], s[3] - ce[3]],
                    r: [d[0] + fv[0], d[1] + fv[1]],
                };
                (pt, sp.x)
            };
            let mut fitted = None;
            // The oscillation pairing bounded on the split of T instead (subcell.rs): the
            // smaller of the two bounds of the cell's pairing, osc_T ‖ε(w)‖_T.
            let mut split_osc = f64::INFINITY;
            if let (true, StressField::Rt(rt)) =
                (relieve && weight * r2 > BUBBLE_WORTH * c.ps2, sigma)
            {
                // Fitted on the points of `fit_rule`, its ‖r + div δ‖ taken on those of
                // `check_rule`: a fit can match a non-polynomial r (a kink inside the cell) at
                // its own points far better than in L² (S ∈ P₃ read r2 up to 2.2× low there).
                let rule_points = |rule: &TriangleRule| -> Vec<(bubble::Point, [f64; 2])> {
                    (rule.points.iter().zip(&rule.weights))
                        .map(|(&xi, &wq)| point(rt, xi, wq))
                        .collect()
                };
                let (kept, check) = (rule_points(&fit_rule), rule_points(&check_rule));
                let bare = |v: &[(bubble::Point, [f64; 2])]| -> Vec<bubble::Point> {
                    v.iter().map(|p| p.0).collect()
                };
                if let Some(b) = bubble::fit(verts, &el, weight, &bare(&kept)) {
                    let (ps2, r2b) = bubble::share(&el, &bare(&check), Some(&b));
                    // Kept only if the cell's share really decreases (any δ, or none, is valid).
                    if ps2 + weight * r2b < c.ps2 + weight * r2 {
                        (c.ps2, r2) = (ps2, r2b);
                        fitted = Some(b);
                    }
                }
                let residual = |v: &[(bubble::Point, [f64; 2])]| -> Vec<subcell::Point> {
                    v.iter()
                        .map(|(p, x)| {
                            let dd = fitted.as_ref().map_or([0.0; 2], |b| b.divergence(p.lam));
                            subcell::Point {
                                w: p.w,
                                lam: p.lam,
                                x: *x,
                                r: [p.r[0] + dd[0], p.r[1] + dd[1]],
                            }
                        })
                        .collect()
                };
                // Depth 1 (h/2) on the bubble's points, depth 2 (h/4) on points of its own; the
                // smaller bound is kept (manufactured P2 n = 4: index 2.25 with depth 1 only,
                // 2.04 with both; the pair costs ≈ 0.15 ms CPU per cell at n = 32).
                for (levels, fit, check) in [
                    (1, residual(&kept), residual(&check)),
                    (
                        2,
                        residual(&rule_points(&deep_rules.0)),
                        residual(&rule_points(&deep_rules.1)),
                    ),
                ] {
                    let part = osc_factor / (1u32 << levels) as f64;
                    let w_split = part * part / c_min;
                    if let Some((_, relief)) =
                        subcell::relieve(verts, levels, &el, w_split, &fit, &check)
                    {
                        split_osc =
                            split_osc.min(part * relief.residual + c_min.sqrt() * relief.energy);
                    }
                }
            }
            // Not f64::min: a NaN of the whole-cell term must reach the report, not be replaced.
            let whole = osc_factor * r2.sqrt();
            c.osc = if split_osc < whole { split_osc } else { whole };
            c.asym = 0.5 * korn * a2.sqrt();
            let area = crate::geometry::straight_area(verts);
            mscale = mscale.max(sigma_scale * area);
            ascale = ascale.max(sigma_scale * area);
            let mnorm = (mom[0] * h).abs().max((mom[1] * h).abs()).max(mom[2].abs());
            c.moment = if mscale > 0.0 { mnorm / mscale } else { 0.0 };
            c.mean_as = if ascale > 0.0 {
                amean.abs() / ascale
            } else {
                0.0
            };
            // Mean-free asymmetry on a triangle with an RT stress: remove it exactly (design
            // §5.11), which drops the Korn-constant term of this cell. Straight cells use the
            // Alfeld split of T (m = k + 2) through the Piola image of the reference split and
            // cell-independent reference matrices (`symmetric::correct_affine`); curved P2
            // cells the Piola image with a per-cell assembly (m = k + 3,
            // `symmetric::correct_curved`).
            if let StressField::Rt(rt) = sigma
                && !fam.is_quad()
                && c.mean_as <= BOUND_MOMENT_RELATIVE
                && (sh == Shape::Affine || (sh == Shape::Curved && fam.nodes() == 6))
            {
                let first = rt.first[t] as usize;
                // (τ + δ, Cε(v)) at reference point ξ of the cell, from τ and ∇v there.
                let at_parts = |xi: [f64; 2], gu: [[f64; 2]; 2], s: [f64; 4]| {
                    let mut s = s;
                    if let Some(b) = &fitted {
                        let d = b.value([1.0 - xi[0] - xi[1], xi[0], xi[1]]);
                        s = std::array::from_fn(|k| s[k] + d[k]);
                    }
                    let sym = 0.5 * (gu[0][1] + gu[1][0]);
                    (s, el.stress([gu[0][0], sym, sym, gu[1][1]]))
                };
                let at = |sp: &crate::geometry::values::SubPoint, s: [f64; 4]| {
                    at_parts(sp.xi, shifted(sp.gradient_at(nodes, v), sp), s)
                };
                let field = |xi: [f64; 2]| {
                    let sp = sub_point(fam, &x[..fam.nodes()], sh, 0, xi);
                    at(&sp, rt.at(first, &sp.jac, xi).0)
                };
                // The split's rule (degree 2m − 2) must be exact for |τ + δ|²: m ≥ deg δ + 1.
                let m = if fitted.is_some() {
                    (rt.order.k() + 2).max(bubble::Bubble::DEGREE + 1)
                } else if rational {
                    // Cε(u_h) is not a polynomial here: the degree of the curved correction,
                    // which a cell with mid nodes off by round-off gets (a moved file's bound
                    // then stays within 1e-4 instead of 1.1e-3 on the Hertz S2 file).
                    rt.order.k() + 3
                } else {
                    rt.order.k() + 2
                };
                // A rule's points from its table: the same values as `field`, without
                // evaluating the bases again.
                let from_table = |table: Option<&BasisTable>, p: usize, xi: [f64; 2]| match table {
                    Some(st) => {
                        let sp = st.geometry.point(&x[..fam.nodes()], p);
                        at(&sp, rt.at_reference(first, &sp.jac, &st.rt[p]).0)
                    }
                    None => field(xi),
                };
                // The split's rule, and that of `symmetric::corrected_ps2` (rational cells).
                let (split_table, check_table) = (
                    BasisTable::find(&split_tables, m, fam),
                    BasisTable::find(&check_tables, m, fam),
                );
                let checked = |p: usize, xi: [f64; 2]| from_table(check_table, p, xi);
                // A 6-node cell taken for straight whose mid nodes are off the midpoints (float32
                // coordinates) has a slightly non-constant J: its RT field is not polynomial to
                // round-off, and the reference-split correction leaves ~1e-9 of the stress
                // scale (CalculiX CPE6 Hertz: 30 cells kept their Korn term). The Piola
                // correction of curved cells takes the map as it is.
                let affine = sh == Shape::Affine && !mid_nodes_off(fam, &x[..fam.nodes()]);
                // On such a cell (not a rational one, and without a shift of u_h) J is one
                // matrix: ∇v = (Σ v_i ⊗ ∇̂φ_i) J⁻¹ and the stress mapped with that J at every
                // point of the split's rule, instead of the full geometry of each point (the
                // bound of the 10k P2 bench: 1.172G → 1.050G instructions).
                let one_jacobian = (affine && !rational && shift.is_none())
                    .then(|| split_table.map(|st| st.geometry.point(&x[..fam.nodes()], 0).jac))
                    .flatten();
                let tabulated = |p: usize, xi: [f64; 2]| match (one_jacobian, split_table) {
                    (Some(jac), Some(st)) => {
                        let g = st.geometry.reference_gradient(p, nodes, v);
                        let gu = g.map(|ga| jac.physical_gradient(ga));
                        let s = rt.at_reference(first, &jac, &st.rt[p]).0;
                        at_parts(st.geometry.xi(p), gu, s)
                    }
                    _ => from_table(split_table, p, xi),
                };
                let fix = if affine {
                    symmetric::correct_affine(verts, m, &el, tabulated)
                } else {
                    let n6 = [x[0], x[1], x[2], x[3], x[4], x[5]];
                    symmetric::correct_curved(n6, rt.order.k() + 3, &el, field)
                };
                let floor = fix.asym_before.max(sigma_scale * area.sqrt());
                if fix.rank + 1 == fix.rows && fix.asym_after <= SYMMETRIC_RESIDUAL * floor {
                    // On a rational cell the split's rule is exact for Curl φ but not for
                    // Cε(u_h): the corrected stress's term at the degree of the cell loop (the
                    // Hertz Q2 file: up to 1 % per cell at 2m − 2; degree 20 and 30 agree to
                    // 1.5e-11 in the bound).
                    c.ps2 = if rational && affine {
                        symmetric::corrected_ps2(verts, m, &el, &fix.phi, deg, checked)
                    } else {
                        fix.ps2
                    };
                    c.asym = 0.0;
                    c.symmetrised = true;
                }
            }
            // η_PS of v' = v + z on a lifted, symmetrised cell: η_PS(v)² + 2X + |||z|||² with
            // X = (Cε(v) − τ*, ε(z)) (data::lift_pairing), instead of η_PS(v) + |||z|||.
            let mut ps_lifted = c.ps2.sqrt() + dt.lift[t];
            if let (Some(lifts), StressField::Rt(rt), true) = (
                lifts_of.get(&t),
                sigma,
                c.symmetrised && sh == Shape::Affine && shift.is_none(),
            ) {
                let first = rt.first[t] as usize;
                let ce_at = |xi: [f64; 2]| {
                    let sp = sub_point(fam, &x[..fam.nodes()], sh, 0, xi);
                    let gu = sp.gradient_at(nodes, v);
                    let sym = 0.5 * (gu[0][1] + gu[1][0]);
                    (sp, el.stress([gu[0][0], sym, sym, gu[1][1]]))
                };
                // div Cε(v): Cε(v) is affine on a straight cell, Σ_k ∇λ_k ⊗ its vertex values.
                let corner = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]].map(|xi| ce_at(xi).1);
                let dv = (verts[1][0] - verts[0][0]) * (verts[2][1] - verts[0][1])
                    - (verts[2][0] - verts[0][0]) * (verts[1][1] - verts[0][1]);
                let gl: [[f64; 2]; 3] = std::array::from_fn(|m| {
                    let (a, b) = (verts[(m + 1) % 3], verts[(m + 2) % 3]);
                    [(a[1] - b[1]) / dv, (b[0] - a[0]) / dv]
                });
                let div_ce: [f64; 2] = std::array::from_fn(|i| {
                    (0..3)
                        .map(|k| corner[k][2 * i] * gl[k][0] + corner[k][2 * i + 1] * gl[k][1])
                        .sum()
                });
                let edge_m = |xi: [f64; 2]| {
                    let (sp, ce) = ce_at(xi);
                    let tau = rt.at(first, &sp.jac, xi).0;
                    std::array::from_fn(|k| ce[k] - tau[k])
                };
                let div_m = |xi: [f64; 2]| {
                    let sp = sub_point(fam, &x[..fam.nodes()], sh, 0, xi);
                    let dtau = rt.at(first, &sp.jac, xi).1;
                    let dd = fitted.as_ref().map_or([0.0; 2], |b| {
                        b.divergence([1.0 - xi[0] - xi[1], xi[0], xi[1]])
                    });
                    [div_ce[0] - dtau[0] - dd[0], div_ce[1] - dtau[1] - dd[1]]
                };
                let pairing: Option<f64> = lifts
                    .iter()
                    .map(|l| data::lift_pairing(ctx, v, l, edge_m, div_m))
                    .sum();
                if let Some(xz) = pairing {
                    // Round-off can make the square slightly negative; a NaN must not pass.
                    let square = c.ps2 + 2.0 * xz + dt.lift[t] * dt.lift[t];
                    let direct = if square < 0.0 { 0.0 } else { square.sqrt() };
                    if direct < ps_lifted {
                        ps_lifted = direct;
                    }
                }
            }
            c.local = (ps_lifted + (c.osc + c.asym + dt.trace[t]) / c_min.sqrt()).powi(2);
            c
        })
        .collect();
    let ps = cells.iter().map(|c| c.ps2).sum::<f64>().sqrt();
    let osc = (cells.iter().map(|c| c.osc * c.osc).sum::<f64>() / c_min).sqrt();
    let asym = (cells.iter().map(|c| c.asym * c.asym).sum::<f64>() / c_min).sqrt();
    let traction = (dt.trace.iter().map(|e| e * e).sum::<f64>() / c_min).sqrt();
    let energy: f64 = cells.iter().map(|c| c.energy).sum();
    let korn_max = cells.iter().fold(0.0f64, |m, c| m.max(c.korn));
    let mut terms = BoundTerms {
        prager_synge: ps,
        complementarity: f.complementarity
            + f.friction
            + lifted.as_ref().map_or(0.0, |l| l.complementarity),
        oscillation: osc,
        asymmetry: asym,
        projection: lifted.as_ref().map_or(0.0, |l| l.distance),
        traction,
        dirichlet_lift: dt.lift.iter().map(|z| z * z).sum::<f64>().sqrt(),
        combined: cells.iter().map(|c| c.local).sum::<f64>().sqrt(),
        pairing: (cells
            .iter()
            .zip(&dt.trace)
            .map(|(c, tr)| (c.osc + c.asym + tr).powi(2))
            .sum::<f64>()
            / c_min)
            .sqrt(),
        combination: String::new(),
        halves: 0.0,
        copies: 0.0,
        korn_max,
        symmetrised_cells: cells.iter().filter(|c| c.symmetrised).count(),
    };
    terms.combination = combine(&terms).1.to_string();
    let energy_error = energy_error(&terms);

    if frictional {
        failed.push(
            "Coulomb friction: the number bounds the error of the Tresca problem with the \
             threshold 𝔉|σ_h,n| of this stress, not that of the Coulomb problem"
                .to_string(),
        );
    }
    failed.extend(failed_checks(adm, frictional));
    let unbalanced = cells
        .iter()
        .filter(|c| c.moment > BOUND_MOMENT_RELATIVE)
        .count();
    let mut computable = true;
    if unbalanced > 0 {
        computable = false;
        failed.push(format!(
            "σ_h is not equilibrated: div σ_h + f has non-zero moments against the rigid motions \
             on {unbalanced} cells (largest relative moment {:.1e}); the patch reconstruction \
             (--stress patch) equilibrates exactly wherever its patch problems can be met",
            cells.iter().fold(0.0f64, |m, c| m.max(c.moment))
        ));
    }
    let curved = mesh.shape.contains(&crate::geometry::Shape::Curved);
    let negligible = UNCERTIFIED_NEGLIGIBLE * (2.0 * energy).sqrt();
    if curved && osc > negligible {
        failed.push(
            "curved cells: Payne–Weinberger's h_T/π is proven for convex cells; the \
             oscillation term uses it on curved cells"
                .to_string(),
        );
    }
    let skew_means = cells
        .iter()
        .filter(|c| c.mean_as > BOUND_MOMENT_RELATIVE)
        .count();
    if skew_means > 0 {
        failed.push(format!(
            "∫_T as σ_h ≠ 0 on {skew_means} cells: the local Korn argument needs mean-free \
             asymmetry (P1 displacements), so the asymmetry term is an estimate"
        ));
    }
    if (osc + asym + traction) > negligible {
        failed.push(format!(
            "the local Korn constants K_T = 2/sin(θ_min/4) (up to {korn_max:.2}) rest on the \
             Horgan–Payne bound of the inf-sup constant, not proven for every triangle \
             (Costabel–Dauge 2015): asymmetry term {asym:.3e}, oscillation term {osc:.3e}, \
             traction term {traction:.3e}"
        ));
    }
    let guaranteed = computable && failed.is_empty() && energy_error.is_finite();
    let statement = if !computable {
        "no bound: the stress is not equilibrated (the FOSLS η is an estimate, not a bound)"
            .to_string()
    } else if guaranteed {
        "energy_error ≥ (½(Cε(u − u_h), ε(u − u_h)))^½, guaranteed".to_string()
    } else {
        "energy_error: the bound (½(Cε(u − u_h), ε(u − u_h)))^½ ≤ energy_error holds under the \
         failed hypotheses listed; not guaranteed"
            .to_string()
    };
    Bound {
        guaranteed,
        energy_error: computable.then_some(energy_error),
        relative: (computable && energy > 0.0).then(|| energy_error / energy.sqrt()),
        statement,
        terms: Some(terms),
        failed_hypotheses: failed,
        cells: cells.iter().map(|c| c.local).collect(),
        energy,
    }
}

/// The lowest degree exact for every integrand of the cell loop of [`bound`] on a straight
/// triangle of mesh degree `p` with a constant body force: with s of degree q (k + 1 for an
/// RT_k stress, p for a nodal one) and ε(v) of degree p − 1, the Prager–Synge density and
/// ‖as s‖² have degree 2 max(q, p − 1), the energy 2(p − 1), |div s + f|² 2(q − 1) and the
/// rotation moment q. (The moment and asymmetry scales integrate absolute values: round-off
/// floors, not exact integrals.)
/// Fixed reference points of degree `m` for one triangle family (the symmetric correction's
/// split points, or the cell rule of that degree): the Lagrange shape functions and the RT
/// reference basis there, evaluated once for all cells (evaluated per cell and point, they
/// were most of the bound's time).
struct BasisTable {
    m: usize,
    geometry: TriangleTable,
    rt: Vec<([[f64; 2]; MAX_RT_DOFS], [f64; MAX_RT_DOFS])>,
}

impl BasisTable {
    /// The tables of `points(m)` for each m in `degrees` and each triangle family of `mesh`.
    fn build(
        mesh: &crate::mesh::Mesh,
        order: crate::element::rt::RtOrder,
        degrees: &[usize],
        points: impl Fn(usize) -> Vec<[f64; 2]>,
    ) -> Vec<BasisTable> {
        let families: Vec<crate::geometry::Family> = crate::geometry::Family::ALL
            .into_iter()
            .filter(|f| !f.is_quad() && mesh.family.contains(f))
            .collect();
        let mut tables = Vec::new();
        for &m in degrees {
            let pts = points(m);
            for &fam in &families {
                tables.push(BasisTable {
                    m,
                    geometry: TriangleTable::new(fam, &pts),
                    rt: pts
                        .iter()
                        .map(|&xi| crate::element::rt::reference(order, xi))
                        .collect(),
                });
            }
        }
        tables
    }

    fn find(tables: &[BasisTable], m: usize, fam: crate::geometry::Family) -> Option<&BasisTable> {
        tables
            .iter()
            .find(|t| t.m == m && t.geometry.family() == fam)
    }
}

fn affine_degree(sigma: StressField, p: usize) -> usize {
    let q = match sigma {
        StressField::Rt(rt) => rt.order.k() + 1,
        StressField::Nodal(_) => p,
    };
    2 * q.max(p.saturating_sub(1))
}

/// True for a 6-node triangle whose mid nodes are off its edge midpoints by more than
/// `STRAIGHT_MID_RELATIVE` of the diameter (straight within the shape test, but with a
/// non-constant Jacobian beyond round-off).
fn mid_nodes_off(fam: crate::geometry::Family, x: &[[f64; 2]]) -> bool {
    if x.len() != 6 || fam.is_quad() {
        return false;
    }
    let h = crate::geometry::diameter(fam, x);
    (0..3).any(|l| {
        let (a, b, m) = (x[l], x[(l + 1) % 3], x[3 + l]);
        let d = (m[0] - 0.5 * (a[0] + b[0])).hypot(m[1] - 0.5 * (a[1] + b[1]));
        d > STRAIGHT_MID_RELATIVE * h
    })
}

/// K_T = 2/β_T with β_T ≥ sin(ω_T/2), ω_T = θ_min/2 the Horgan–Payne angle of the triangle
/// seen from its incentre (the smallest angle between a boundary tangent and the ray from the
/// incentre is half the smallest vertex angle). Module doc for the status of this constant.
pub fn korn_constant(v: [[f64; 2]; 3]) -> f64 {
    let mut theta_min = std::f64::consts::PI;
    for i in 0..3 {
        let a = v[i];
        let b = v[(i + 1) % 3];
        let c = v[(i + 2) % 3];
        let u = [b[0] - a[0], b[1] - a[1]];
        let w = [c[0] - a[0], c[1] - a[1]];
        let cross = (u[0] * w[1] - u[1] * w[0]).abs();
        let dot = u[0] * w[0] + u[1] * w[1];
        theta_min = theta_min.min(cross.atan2(dot));
    }
    2.0 / (theta_min / 4.0).sin()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_projection_distance_is_added_by_the_triangle_inequality() {
        // R = 3 + 1, c = 0: |||u − v||| ≤ 4; + 1 for the projection; energy_error = √½ × that.
        // (The hypercircle forms give √(9 + 8) and 1 + √10, both above 4.)
        let terms = BoundTerms {
            prager_synge: 3.0,
            asymmetry: 1.0,
            pairing: 1.0,
            combined: 4.0,
            ..Default::default()
        };
        let mut b = Bound {
            energy_error: Some(energy_error(&terms)),
            terms: Some(terms),
            energy: 4.0,
            ..Default::default()
        };
        assert!((b.energy_error.unwrap() - 4.0 * 0.5f64.sqrt()).abs() < 1e-15);
        b.add_projection(1.0);
        assert!((b.energy_error.unwrap() - 5.0 * 0.5f64.sqrt()).abs() < 1e-15);
        assert!((b.relative.unwrap() - 2.5 * 0.5f64.sqrt()).abs() < 1e-15);
        // The broken-norm distance of a discontinuous u_h from its average, the same way.
        b.add_copies(2.0);
        assert!((b.energy_error.unwrap() - 7.0 * 0.5f64.sqrt()).abs() < 1e-15);
    }

    #[test]
    fn the_lifting_enters_squared_in_the_hypercircle_forms() {
        // P = 3, Z = 1, no pairing, c = 0: R = P + Z = 4, triangle a + Z = 5; hypercircle
        // √(P² + Z²) = √10 (by hand: P² − b² + 2bZ ≤ P² + Z²).
        let mut t = BoundTerms {
            prager_synge: 3.0,
            dirichlet_lift: 1.0,
            combined: 4.0,
            ..Default::default()
        };
        let (e, form) = combine(&t);
        assert!((e - 10f64.sqrt()).abs() < 1e-15, "{e}");
        assert_eq!(form, "hypercircle");
        // With c = 2: a = ½(4 + √(16 + 8)) = 2 + √6; hypercircle √(9 + 1 + 4) = √14.
        t.complementarity = 2.0;
        assert!((combine(&t).0 - 14f64.sqrt()).abs() < 1e-15);
        // A large pairing O = 3 (R = 7): triangle 7 + 1 = 8 (c = 0); hypercircle
        // √(10 + 42) = 7.21…; quadratic 3 + √(9 + 10 + 6) = 8: the hypercircle wins.
        t.complementarity = 0.0;
        t.pairing = 3.0;
        t.combined = 7.0;
        let (e, form) = combine(&t);
        assert!((e - 52f64.sqrt()).abs() < 1e-14, "{e}");
        assert_eq!(form, "hypercircle");
        // Without a lifting, O = 3, P = 3, R = 6: triangle 6 beats √(9 + 36) and 3 + √18.
        t.dirichlet_lift = 0.0;
        t.combined = 6.0;
        assert_eq!(combine(&t), (6.0, "triangle"));
        // A NaN term is never hidden by the minimum.
        t.prager_synge = f64::NAN;
        assert!(combine(&t).0.is_nan());
    }

    #[test]
    fn korn_constant_of_the_equilateral_and_right_triangles() {
        // θ_min = 60°: 2/sin 15° = 7.727…; θ_min = 45°: 2/sin 11.25° = 10.25…
        let s = 3f64.sqrt() / 2.0;
        let k = korn_constant([[0.0, 0.0], [1.0, 0.0], [0.5, s]]);
        assert!((k - 2.0 / (15f64.to_radians()).sin()).abs() < 1e-12, "{k}");
        let k = korn_constant([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]);
        assert!(
            (k - 2.0 / (11.25f64.to_radians()).sin()).abs() < 1e-12,
            "{k}"
        );
    }
}
