//! fosls: audit finite element solutions of elastic contact problems with the First-Order
//! System Least-Squares functional (see `docs/design.md`).
//!
//! The modules follow the data flow:
//! read (VTU, scene) → mesh and fields → topology → elements and quadrature → … → report.

pub mod audit;
pub mod bodies;
pub mod closure;
pub mod element;
pub mod error;
pub mod estimate;
pub mod expr;
pub mod field;
pub mod geometry;
pub mod inspect;
pub mod limits;
pub mod material;
pub mod mesh;
pub mod problem;
pub mod quadrature;
pub mod read;
pub mod reconstruct;
pub mod report;
pub mod scene;
pub mod solve;
pub mod starter;
pub mod tolerance;
pub mod topology;
pub mod write;

#[cfg(test)]
mod testing;

pub use error::{Error, Result};
