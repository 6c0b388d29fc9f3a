//! Scene file (TOML), DESIGN.md §7.
