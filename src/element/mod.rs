//! Reference finite elements and the isoparametric map.
