//! fosls inspect: what a VTU file holds.
