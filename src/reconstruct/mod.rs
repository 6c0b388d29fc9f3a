//! Reconstruction of missing, non-conforming or inadmissible fields (docs/design.md §5).
//!
//! Stress: σ_h = argmin over τ ∈ RT_k(T_h)² ∩ K_σ of F(u_h, τ), a convex quadratic program
//! with bound constraints on the normal traces at the contact points ([`solve`]).

pub mod condense;
pub mod displacement;
pub mod flow;
pub mod nodal;
pub mod patch;
pub mod projection;
pub mod qp;
pub mod stress;
pub mod submesh;
pub mod sweep;

/// The QP solver, a leaf of its own ([`crate::solve`]).
pub use crate::solve;
