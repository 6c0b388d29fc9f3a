//! The mesh and its fields.
