//! VTU (XML UnstructuredGrid) reader.
