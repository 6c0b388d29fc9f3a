//! Bytes → data: the VTU reader ([`vtu`], [`decode`]), the other containers of a solution
//! ([`container`]: [`pvtu`], [`pvd`], [`legacy`] VTK, [`xdmf`]) and the scene file ([`scene`]).

pub mod cell_type;
pub mod components;
pub mod container;
pub mod decode;
pub mod legacy;
pub mod pvd;
pub mod pvtu;
pub mod scene;
pub mod vtu;
pub mod xdmf;
