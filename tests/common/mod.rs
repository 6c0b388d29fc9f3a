//! Helpers shared by the fuzz test binaries.

pub mod alloc;
