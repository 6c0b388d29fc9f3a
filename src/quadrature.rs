//! Quadrature rules on the reference triangle and the reference edge.
