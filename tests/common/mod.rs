//! Helpers shared by the test binaries (each binary uses a part of them).
#![allow(dead_code)]

pub mod alloc;
pub mod cli;
