//! Bytes → data: the VTU reader ([`vtu`], [`decode`]) and the scene file ([`scene`]).

pub mod decode;
pub mod scene;
pub mod vtu;
