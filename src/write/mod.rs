//! VTU writer.
