//! User expressions in x, y (z) for boundary selectors, data and gaps (DESIGN.md §7).
