//! Mesh topology: edges, boundary edges, cell-edge maps, orientation.
