//! The FOSLS functional of DESIGN.md §3, its terms per cell, admissibility (§5) and the
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

/// Size and place of one kind of admissibility violation (DESIGN.md §5).
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
    /// σ_n⁺ on Γ_C.
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
}

/// State of a piece of the contact boundary (as in the talk's figure).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum ContactState {
    Separated,
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
    /// ∫_{Γ_C} −σ_n ds.
    pub normal_force: f64,
    /// ∫_{Γ_C} σ_t ds.
    pub tangential_force: f64,
    pub intervals: Vec<ContactInterval>,
    /// State of each line cell of the mesh on Γ_C, by mesh line index (the state covering
    /// most of the edge); `None` off Γ_C.
    #[serde(skip)]
    pub line_state: Vec<Option<ContactState>>,
}

/// The guaranteed bound of DESIGN.md §6.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Bound {
    pub guaranteed: bool,
    pub value: Option<f64>,
    pub failed_hypotheses: Vec<String>,
}

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

pub mod boundary;
pub mod interior;
pub mod material;
