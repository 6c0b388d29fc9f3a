//! Bytes → data: the VTU reader ([`vtu`], [`decode`]) and the scene file ([`scene`]).

pub mod cell_type;
pub mod decode;
pub mod scene;
pub mod vtu;
