//! The VTK cell-type table: every type's name, dimension and node counts, and which cell
//! family of [`crate::geometry`] a 2D type is read as (docs/design.md §4.3).
//!
//! Adding a cell family means a row here and a module in `geometry/`. Node orders: VTK's
//! fixed-order quadratic types (21, 22, 23, 28) and the arbitrary-order Lagrange types
//! (68, 69, 70) of order ≤ 2 list vertices first, then one node per edge in the edge order
//! 0→1, 1→2, 2→0 (triangles) or 0→1, 1→2, 3→2, 0→3 (quadrilaterals, the same midpoints as
//! 2→3 and 3→0), then the centre (VTK's `vtkHigherOrderQuadrilateral::PointIndexFromIJK`
//! and `vtkHigherOrderTriangle` orderings). So for the orders read here every type maps to its
//! family with the identity permutation; only the order of a Lagrange type has to be found,
//! from its node count or its `HigherOrderDegrees` cell data. VTK_PIXEL (8) is a
//! quadrilateral whose corners are listed in x-then-y order ([`node_order`]); VTK_POLYGON (7)
//! of three or four vertices is a triangle or a quadrilateral.

use crate::geometry::Family;

pub const VERTEX: u8 = 1;
pub const LINE: u8 = 3;
pub const TRIANGLE: u8 = 5;
pub const POLYGON: u8 = 7;
pub const PIXEL: u8 = 8;
pub const QUAD: u8 = 9;
pub const QUADRATIC_EDGE: u8 = 21;
pub const QUADRATIC_TRIANGLE: u8 = 22;
pub const QUADRATIC_QUAD: u8 = 23;
pub const BIQUADRATIC_QUAD: u8 = 28;
pub const LAGRANGE_CURVE: u8 = 68;
pub const LAGRANGE_TRIANGLE: u8 = 69;
pub const LAGRANGE_QUADRILATERAL: u8 = 70;

/// What a cell of the file is, for the mesh builder.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// Vertex and poly-vertex cells: ignored (some writers add them).
    Point,
    /// A boundary line of `nodes` nodes (2 straight, 3 quadratic).
    Line,
    /// A 2D cell of a family fosls reads.
    Cell(Family),
    /// A known 2D or 1D type fosls does not read (polygons, strips, cubic cells, …).
    Unsupported,
    /// A 3D cell: refused with "3D cells are not supported yet".
    Solid,
}

/// The VTK type fosls writes for a cell family.
pub const fn of_family(f: Family) -> u8 {
    match f {
        Family::Tri3 => TRIANGLE,
        Family::Tri6 => QUADRATIC_TRIANGLE,
        Family::Quad4 => QUAD,
        Family::Quad8 => QUADRATIC_QUAD,
        Family::Quad9 => BIQUADRATIC_QUAD,
    }
}

/// The VTK name of a cell type (as in `vtkCellType.h`), for messages and `inspect`.
pub fn name(t: u8) -> &'static str {
    match t {
        0 => "VTK_EMPTY_CELL",
        1 => "VTK_VERTEX",
        2 => "VTK_POLY_VERTEX",
        3 => "VTK_LINE",
        4 => "VTK_POLY_LINE",
        5 => "VTK_TRIANGLE",
        6 => "VTK_TRIANGLE_STRIP",
        7 => "VTK_POLYGON",
        8 => "VTK_PIXEL",
        9 => "VTK_QUAD",
        10 => "VTK_TETRA",
        11 => "VTK_VOXEL",
        12 => "VTK_HEXAHEDRON",
        13 => "VTK_WEDGE",
        14 => "VTK_PYRAMID",
        15 => "VTK_PENTAGONAL_PRISM",
        16 => "VTK_HEXAGONAL_PRISM",
        21 => "VTK_QUADRATIC_EDGE",
        22 => "VTK_QUADRATIC_TRIANGLE",
        23 => "VTK_QUADRATIC_QUAD",
        24 => "VTK_QUADRATIC_TETRA",
        25 => "VTK_QUADRATIC_HEXAHEDRON",
        26 => "VTK_QUADRATIC_WEDGE",
        27 => "VTK_QUADRATIC_PYRAMID",
        28 => "VTK_BIQUADRATIC_QUAD",
        29 => "VTK_TRIQUADRATIC_HEXAHEDRON",
        30 => "VTK_QUADRATIC_LINEAR_QUAD",
        31 => "VTK_QUADRATIC_LINEAR_WEDGE",
        32 => "VTK_BIQUADRATIC_QUADRATIC_WEDGE",
        33 => "VTK_BIQUADRATIC_QUADRATIC_HEXAHEDRON",
        34 => "VTK_BIQUADRATIC_TRIANGLE",
        35 => "VTK_CUBIC_LINE",
        36 => "VTK_QUADRATIC_POLYGON",
        37 => "VTK_TRIQUADRATIC_PYRAMID",
        41 => "VTK_CONVEX_POINT_SET",
        42 => "VTK_POLYHEDRON",
        51 => "VTK_PARAMETRIC_CURVE",
        52 => "VTK_PARAMETRIC_SURFACE",
        60 => "VTK_HIGHER_ORDER_EDGE",
        61 => "VTK_HIGHER_ORDER_TRIANGLE",
        62 => "VTK_HIGHER_ORDER_QUAD",
        63 => "VTK_HIGHER_ORDER_POLYGON",
        64 => "VTK_HIGHER_ORDER_TETRAHEDRON",
        65 => "VTK_HIGHER_ORDER_WEDGE",
        66 => "VTK_HIGHER_ORDER_PYRAMID",
        67 => "VTK_HIGHER_ORDER_HEXAHEDRON",
        68 => "VTK_LAGRANGE_CURVE",
        69 => "VTK_LAGRANGE_TRIANGLE",
        70 => "VTK_LAGRANGE_QUADRILATERAL",
        71 => "VTK_LAGRANGE_TETRAHEDRON",
        72 => "VTK_LAGRANGE_HEXAHEDRON",
        73 => "VTK_LAGRANGE_WEDGE",
        74 => "VTK_LAGRANGE_PYRAMID",
        75 => "VTK_BEZIER_CURVE",
        76 => "VTK_BEZIER_TRIANGLE",
        77 => "VTK_BEZIER_QUADRILATERAL",
        78 => "VTK_BEZIER_TETRAHEDRON",
        79 => "VTK_BEZIER_HEXAHEDRON",
        80 => "VTK_BEZIER_WEDGE",
        81 => "VTK_BEZIER_PYRAMID",
        _ => "unknown VTK cell type",
    }
}

/// Whether `t` is a 3D cell type.
pub fn is_solid(t: u8) -> bool {
    matches!(
        t,
        10..=16 | 24..=27 | 29 | 31..=33 | 37 | 41 | 42 | 64..=67 | 71..=74 | 78..=81
    )
}

/// Whether `t` is a type whose node count the reader must check against a fixed number
/// (`Some(n)`), or an arbitrary-order type whose node count is checked by [`lagrange_order`]
/// (`None`). Unknown types are `Some(0)`: refused by the reader.
pub fn fixed_nodes(t: u8) -> Option<usize> {
    match t {
        VERTEX => Some(1),
        LINE => Some(2),
        TRIANGLE | QUADRATIC_EDGE => Some(3),
        QUAD => Some(4),
        QUADRATIC_TRIANGLE => Some(6),
        QUADRATIC_QUAD => Some(8),
        BIQUADRATIC_QUAD => Some(9),
        10 => Some(4),
        12 => Some(8),
        13 => Some(6),
        14 => Some(5),
        24 => Some(10),
        25 => Some(20),
        26 => Some(15),
        27 => Some(13),
        29 => Some(27),
        2 | 4 | 6 | 7 | 42 | 60..=81 => None,
        8 => Some(4),
        11 => Some(8),
        30 => Some(6),
        34 => Some(7),
        35 => Some(4),
        _ => Some(0),
    }
}

/// The order of an arbitrary-order Lagrange cell with `nodes` nodes: p + 1 nodes for a
/// curve, (p + 1)(p + 2)/2 for a triangle, (p + 1)² for a quadrilateral; `None` when the count
/// fits no order.
pub fn lagrange_order(t: u8, nodes: usize) -> Option<usize> {
    (1..=64).find(|&p| match t {
        LAGRANGE_CURVE => nodes == p + 1,
        LAGRANGE_TRIANGLE => nodes == (p + 1) * (p + 2) / 2,
        LAGRANGE_QUADRILATERAL => nodes == (p + 1) * (p + 1),
        _ => false,
    })
}

/// Where a cell of type `t` stores its family's nodes: `order[i]` is the file slot of node i,
/// `None` for the identity. VTK_PIXEL (an axis-aligned rectangle, vtkImageData's cell) lists
/// its corners in x-then-y order (0, 1, 3, 2 around the cell).
pub fn node_order(t: u8) -> Option<&'static [usize]> {
    (t == PIXEL).then_some(&[0, 1, 3, 2])
}

/// What a cell of type `t` with `nodes` nodes and (Lagrange types) order `order` is read as.
pub fn kind(t: u8, nodes: usize, order: usize) -> Kind {
    match (t, order) {
        (VERTEX | 2, _) => Kind::Point,
        (LINE | QUADRATIC_EDGE, _) => Kind::Line,
        (LAGRANGE_CURVE, 1 | 2) => Kind::Line,
        (TRIANGLE, _) | (LAGRANGE_TRIANGLE, 1) => Kind::Cell(Family::Tri3),
        (QUADRATIC_TRIANGLE, _) | (LAGRANGE_TRIANGLE, 2) => Kind::Cell(Family::Tri6),
        (QUAD | PIXEL, _) | (LAGRANGE_QUADRILATERAL, 1) => Kind::Cell(Family::Quad4),
        // Polygons of three or four vertices (meshio's "polygon" blocks) are those cells.
        (POLYGON, _) if nodes == 3 => Kind::Cell(Family::Tri3),
        (POLYGON, _) if nodes == 4 => Kind::Cell(Family::Quad4),
        (QUADRATIC_QUAD, _) => Kind::Cell(Family::Quad8),
        (BIQUADRATIC_QUAD, _) | (LAGRANGE_QUADRILATERAL, 2) => Kind::Cell(Family::Quad9),
        _ if is_solid(t) => Kind::Solid,
        _ => {
            let _ = nodes;
            Kind::Unsupported
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lagrange_orders_come_from_the_node_count() {
        assert_eq!(lagrange_order(LAGRANGE_TRIANGLE, 3), Some(1));
        assert_eq!(lagrange_order(LAGRANGE_TRIANGLE, 6), Some(2));
        assert_eq!(lagrange_order(LAGRANGE_TRIANGLE, 10), Some(3));
        assert_eq!(lagrange_order(LAGRANGE_TRIANGLE, 7), None);
        assert_eq!(lagrange_order(LAGRANGE_QUADRILATERAL, 9), Some(2));
        assert_eq!(lagrange_order(LAGRANGE_QUADRILATERAL, 8), None);
        assert_eq!(lagrange_order(LAGRANGE_CURVE, 3), Some(2));
    }

    #[test]
    fn every_type_has_its_vtk_name() {
        for (t, n) in [
            (9, "VTK_QUAD"),
            (23, "VTK_QUADRATIC_QUAD"),
            (28, "VTK_BIQUADRATIC_QUAD"),
            (68, "VTK_LAGRANGE_CURVE"),
            (69, "VTK_LAGRANGE_TRIANGLE"),
            (70, "VTK_LAGRANGE_QUADRILATERAL"),
            (71, "VTK_LAGRANGE_TETRAHEDRON"),
            (72, "VTK_LAGRANGE_HEXAHEDRON"),
        ] {
            assert_eq!(name(t), n);
        }
        for t in [10, 12, 24, 25, 71, 72] {
            assert!(is_solid(t) && kind(t, 4, 1) == Kind::Solid, "{t}");
        }
        assert_eq!(kind(70, 9, 2), Kind::Cell(Family::Quad9));
        assert_eq!(kind(PIXEL, 4, 0), Kind::Cell(Family::Quad4));
        assert_eq!(kind(POLYGON, 3, 0), Kind::Cell(Family::Tri3));
        assert_eq!(kind(POLYGON, 4, 0), Kind::Cell(Family::Quad4));
        assert_eq!(kind(POLYGON, 5, 0), Kind::Unsupported);
        assert_eq!(kind(69, 10, 3), Kind::Unsupported);
    }
}
