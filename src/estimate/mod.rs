//! The FOSLS functional of docs/design.md §3, its terms per cell, admissibility (§5) and the
//! contact zone, for a displacement and a stress given on the mesh.
//!
//! F(v, τ) = Σ_T [F_const,T + F_div,T] + Σ_{E ⊂ Γ_C} [F_comp,E + F_fric,E]; each boundary
//! contribution is attributed to the triangle owning the edge, so that the per-cell
//! indicators η_T² sum to F. The report layer (`crate::report`) turns an [`Estimate`] into
//! text, JSON and VTU.

use serde::Serialize;

use crate::read::scene::Norm;

/// Per-cell values of each term (one entry per triangle of the mesh, boundary terms
/// attributed to the owning triangle).
#[derive(Clone, Debug, Default, Serialize)]
pub struct CellTerms {
    pub constitutive: Vec<f64>,
    pub equilibrium: Vec<f64>,
    pub complementarity: Vec<f64>,
    pub friction: Vec<f64>,
}

impl CellTerms {
    /// η_T² = sum of the four terms of cell `t` (may be negative for inadmissible pairs).
    pub fn eta_squared(&self, t: usize) -> f64 {
        self.constitutive[t] + self.equilibrium[t] + self.complementarity[t] + self.friction[t]
    }
}

/// Totals of the terms.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct Terms {
    pub total: f64,
    pub constitutive: f64,
    pub equilibrium: f64,
    pub complementarity: f64,
    pub friction: f64,
}

/// Size and place of one kind of admissibility violation (docs/design.md §5).
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct Violation {
    /// Largest pointwise value (0 when admissible).
    pub max: f64,
    /// L² norm over the boundary part it lives on.
    pub l2: f64,
    /// Where the maximum is, if positive.
    pub at: Option<[f64; 2]>,
    /// Triangle owning the edge of the maximum, if positive.
    pub cell: Option<usize>,
}

/// All admissibility findings.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Admissibility {
    /// (u_n − g)⁺ on Γ_C.
    pub penetration: Violation,
    /// σ_n⁺ on Γ_C, and |σ_n| where the gap is infinite (contact cannot happen there).
    pub tension: Violation,
    /// (|σ_t| − 𝔉|σ_n|)⁺ on Γ_C (|σ_t| on frictionless contact).
    pub cone_violation: Violation,
    /// |u − u_D| on Γ_D.
    pub dirichlet: Violation,
    /// |σn − t| on Γ_N (including unselected, traction-free edges).
    pub neumann: Violation,
    /// Negative parts of the signed boundary terms, ∫ min(integrand, 0) ds (≤ 0).
    pub complementarity_negative: f64,
    pub friction_negative: f64,
    /// max |u_h| and max |σ_h|: the scales below which violations are round-off
    /// ([`crate::tolerance::ADMISSIBLE_RELATIVE`]).
    pub u_scale: f64,
    pub sigma_scale: f64,
    /// max |x| over the mesh points: gaps and data are evaluated at coordinates this large
    /// ([`crate::tolerance::COORDINATE_ROUNDOFF`]).
    pub coordinate_scale: f64,
}

impl Admissibility {
    /// The level below which a displacement violation (penetration, Dirichlet mismatch) is
    /// round-off: [`displacement_tolerance`] of this check's scales.
    pub fn displacement_tolerance(&self) -> f64 {
        displacement_tolerance(self.u_scale, self.coordinate_scale)
    }

    /// The level below which a stress violation is round-off.
    pub fn stress_tolerance(&self) -> f64 {
        crate::tolerance::ADMISSIBLE_RELATIVE * self.sigma_scale
    }

    /// The five kinds with their names, definitions and whether each is above round-off.
    pub fn kinds(&self) -> [(&'static str, &'static str, &Violation, bool); 5] {
        let tu = self.displacement_tolerance();
        let ts = self.stress_tolerance();
        [
            (
                "penetration",
                "(u_n - g)+ on Γ_C",
                &self.penetration,
                self.penetration.max > tu,
            ),
            (
                "tension",
                "σ_n+ on Γ_C",
                &self.tension,
                self.tension.max > ts,
            ),
            (
                "cone violation",
                "(|σ_t| - 𝔉|σ_n|)+ on Γ_C",
                &self.cone_violation,
                self.cone_violation.max > ts,
            ),
            (
                "Dirichlet data",
                "|u - u_D| on Γ_D",
                &self.dirichlet,
                self.dirichlet.max > tu,
            ),
            (
                "Neumann data",
                "|σn - t| on Γ_N",
                &self.neumann,
                self.neumann.max > ts,
            ),
        ]
    }
}

/// State of a piece of the contact boundary (as in the talk's figure).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum ContactState {
    Separated,
    /// In contact without friction.
    Contact,
    Stick,
    Slip,
}

/// A maximal interval of one state along one contact boundary.
#[derive(Clone, Debug, Serialize)]
pub struct ContactInterval {
    /// Name of the `[[boundary]]`.
    pub boundary: String,
    pub state: ContactState,
    pub start: [f64; 2],
    pub end: [f64; 2],
    pub length: f64,
}

/// The contact zone.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Contact {
    /// Measure of {σ_n < 0} on Γ_C.
    pub active_length: f64,
    pub stick_length: f64,
    pub slip_length: f64,
    /// The normal force to compare with the solver's reaction: the consistent reaction of the
    /// file's displacement ([`reaction::contact_normal_force`], docs/design.md §5.8) where it is
    /// available, else `normal_force_stress`.
    pub normal_force: f64,
    /// ∫_{Γ_C} −σ_n ds of the stress used.
    pub normal_force_stress: f64,
    /// Where `normal_force` comes from.
    pub normal_force_from: ForceSource,
    /// ∫_{Γ_C} σ_t ds.
    pub tangential_force: f64,
    pub intervals: Vec<ContactInterval>,
    /// State of each line cell of the mesh on Γ_C, by mesh line index (the state covering
    /// most of the edge); `None` off Γ_C.
    #[serde(skip)]
    pub line_state: Vec<Option<ContactState>>,
}

/// What the reported normal force is computed from.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum ForceSource {
    /// ∫ −σ_n ds of the stress used.
    #[default]
    Stress,
    /// The residual of the file's displacement at the contact nodes.
    Displacement,
}

pub use bound::{Bound, BoundTerms};

/// Everything the estimate computes.
#[derive(Clone, Debug, Serialize)]
pub struct Estimate {
    pub norm: Norm,
    pub functional: Terms,
    /// η = F^½ (F ≥ 0 for admissible pairs; `None` if F < 0).
    pub eta: Option<f64>,
    /// ½(Cε(u_h), ε(u_h)) for `energy`, μ‖ε(u_h)‖² for `robust` and `seed`.
    pub energy: f64,
    /// (F / energy)^½.
    pub relative: Option<f64>,
    /// ℓ in w_d = ℓ²/(2μ).
    pub length_scale: f64,
    pub admissibility: Admissibility,
    pub contact: Contact,
    pub bound: Bound,
    #[serde(skip)]
    pub cells: CellTerms,
}

pub mod bound;
pub mod boundary;
pub mod bubble;
pub mod copies;
pub mod data;
pub mod halves;
pub mod interior;
pub mod lift;
pub mod reaction;
pub mod subcell;
pub mod symmetric;

use crate::problem::Context;

pub use crate::field::StressField;
pub use crate::tolerance::ADMISSIBLE_RELATIVE as ADMISSIBLE_TOLERANCE;

/// Evaluates F and everything around it for `u` and `sigma` in the problem `ctx`
/// (docs/design.md §3, §5, §6). The bound measures the symmetry of σ_h itself.
pub fn run(ctx: &Context, u: &[[f64; 2]], sigma: StressField) -> Estimate {
    let length_scale = ctx.length_scale;
    let interior = interior::interior(ctx, u, sigma);
    let boundary = boundary::boundary(ctx, u, sigma);
    let cells = CellTerms {
        constitutive: interior.constitutive,
        equilibrium: interior.equilibrium,
        complementarity: boundary.complementarity,
        friction: boundary.friction,
    };
    let sum = |v: &[f64]| v.iter().sum::<f64>();
    let mut functional = Terms {
        total: 0.0,
        constitutive: sum(&cells.constitutive),
        equilibrium: sum(&cells.equilibrium),
        complementarity: sum(&cells.complementarity),
        friction: sum(&cells.friction),
    };
    functional.total = functional.constitutive
        + functional.equilibrium
        + functional.complementarity
        + functional.friction;
    let energy = sum(&interior.energy);
    let eta = (functional.total >= 0.0).then(|| functional.total.sqrt());
    let relative =
        (functional.total >= 0.0 && energy > 0.0).then(|| (functional.total / energy).sqrt());
    let bound = bound::bound(ctx, u, sigma, &functional, &boundary.admissibility);
    Estimate {
        norm: ctx.norm,
        functional,
        eta,
        energy,
        relative,
        length_scale,
        admissibility: boundary.admissibility,
        contact: boundary.contact,
        bound,
        cells,
    }
}

/// The round-off level of a displacement check: ADMISSIBLE_RELATIVE × max |u_h| + COORDINATE_ROUNDOFF
/// × max |x|, since the gap g(x) − u_n and the Dirichlet data are evaluated at points x of that
/// size (docs/design.md §5, "Round-off").
pub fn displacement_tolerance(u_scale: f64, coordinate_scale: f64) -> f64 {
    ADMISSIBLE_TOLERANCE * u_scale + crate::tolerance::COORDINATE_ROUNDOFF * coordinate_scale
}

/// The admissibility checks that fail, as sentences (docs/design.md §5), each judged against
/// the round-off levels of the check's own scales.
pub fn failed_checks(adm: &Admissibility, frictional: bool) -> Vec<String> {
    let (tu, ts) = (adm.displacement_tolerance(), adm.stress_tolerance());
    let mut out = Vec::new();
    let mut check = |v: &Violation, tol: f64, what: &str| {
        if v.max > tol {
            out.push(format!("{what} (max {:.3e})", v.max));
        }
    };
    check(&adm.penetration, tu, "u_h penetrates the obstacle: u_n > g");
    check(&adm.dirichlet, tu, "u_h misses the Dirichlet data");
    check(
        &adm.tension,
        ts,
        "σ_h is tensile on the contact boundary (σ_n > 0), or presses where its direction \
         never meets the obstacle (σ_n ≠ 0 with an infinite gap)",
    );
    check(
        &adm.cone_violation,
        ts,
        if frictional {
            "σ_h leaves the friction cone: |σ_t| > 𝔉|σ_n|"
        } else {
            "σ_h has tangential traction on frictionless contact: σ_t ≠ 0"
        },
    );
    check(&adm.neumann, ts, "σ_h misses the traction data: σn ≠ t");
    out
}

pub use crate::geometry::point_set_diameter as diameter;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn diameter_of_a_rectangle_and_a_half_disc() {
        let pts = [
            [0.0, 0.0],
            [2.0, 0.0],
            [2.0, 1.0],
            [0.0, 1.0],
            [1.0, 0.5],
            [1.0, 0.0],
        ];
        assert_eq!(diameter(&pts), 5f64.sqrt());
        let disc: Vec<[f64; 2]> = (0..=100)
            .map(|i| {
                let a = std::f64::consts::PI * (1.0 + i as f64 / 100.0);
                [a.cos(), 1.0 + a.sin()]
            })
            .collect();
        assert!((diameter(&disc) - 2.0).abs() < 1e-15);
    }
}

#[cfg(test)]
mod exact_tests;
