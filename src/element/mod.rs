//! Finite element spaces on top of the geometry layer (docs/design.md §4, §5; tests: §9
//! layer 1): row-wise Raviart–Thomas RT_0 and RT_1 on triangles with the contravariant Piola
//! map ([`rt`]). The Lagrange shape functions of every cell family and the cell and facet maps
//! live in [`crate::geometry`].

pub mod rt;

pub use rt::{RT0_DOFS, RT1_DOFS, RT2_DOFS, RtOrder};
