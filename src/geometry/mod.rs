//! The geometry layer: every cell and facet quantity of every cell family, in one place
//! (docs/design.md §4.3), in the manner of deal.II's `FEValues`/`FEFaceValues` and
//! scikit-fem's `CellBasis`/`FacetBasis`.
//!
//! A cell of family F with node coordinates x_i is the image of its reference cell K̂ (the
//! triangle conv{(0,0), (1,0), (0,1)} or the square [0, 1]²) under the isoparametric map
//!
//! ```text
//! x(ξ) = Σ_i x_i φ_i(ξ),   J(ξ) = ∂x/∂ξ,   ∫_T f dx = ∫_K̂ f(x(ξ)) det J(ξ) dξ,
//! ∇φ_i = J^{−T} ∇̂φ_i,
//! ```
//!
//! and its local edge k (from vertex k to vertex k + 1 mod n_v, mid node n_v + k) is the curve
//! s ↦ x(ξ_k(s)), s ∈ [0, 1], with ds = |J ξ_k'| ds_ref and the outward normal n = (t_y, −t_x)/|t|
//! for the tangent t = J ξ_k' of a counter-clockwise cell. Adding a family means a module with
//! its shape functions and a row in [`Family`]'s tables; nothing else computes geometry.
//!
//! - [`triangle`], [`quadrilateral`]: reference shape functions per family.
//! - [`map`], [`edge`]: the Jacobian type and the stand-alone maps used by tests and by the RT
//!   interpolation.
//! - [`values`]: [`values::CellValues`] (x, w·det J, φ, ∇φ at the points of a rule),
//!   [`values::facet_point`] (x, n, ds, ξ on an edge), [`values::SubCell`] (the triangles
//!   of the fixed sub-triangulation that carry RT fields on quadrilaterals, docs/design.md §5.4).
//!
//! The dimension is fixed at 2 today; a 3D family would add its reference cell and a face
//! table here, and `DIM`-sized arrays would take over from the `[f64; 2]` of this module.

pub mod edge;
pub mod map;
pub mod quadrilateral;
pub mod triangle;
pub mod values;

pub use map::Jacobian;
pub use values::{CellValues, CellValuesCache, FacetPoint, SubCell, Table, facet_point, table};

/// Largest number of nodes of a cell of any family.
pub const MAX_NODES: usize = 9;

/// The spatial dimension read today; 3D cells are refused by the mesh builder.
pub const DIM: usize = 2;

/// The cell families fosls reads (docs/design.md §4.3).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize)]
pub enum Family {
    /// Straight P1 triangle (VTK 5, 69 of order 1).
    Tri3,
    /// Isoparametric P2 triangle (VTK 22, 69 of order 2).
    Tri6,
    /// Bilinear Q1 quadrilateral (VTK 9, 70 of order 1).
    Quad4,
    /// 8-node serendipity quadrilateral (VTK 23).
    Quad8,
    /// Biquadratic Q2 quadrilateral (VTK 28, 70 of order 2).
    Quad9,
}

impl Family {
    pub const ALL: [Family; 5] = [
        Family::Tri3,
        Family::Tri6,
        Family::Quad4,
        Family::Quad8,
        Family::Quad9,
    ];

    /// Nodes per cell.
    #[inline]
    pub const fn nodes(self) -> usize {
        match self {
            Family::Tri3 => 3,
            Family::Tri6 => 6,
            Family::Quad4 => 4,
            Family::Quad8 => 8,
            Family::Quad9 => 9,
        }
    }

    /// Vertices (= edges) per cell.
    #[inline]
    pub const fn vertices(self) -> usize {
        match self {
            Family::Tri3 | Family::Tri6 => 3,
            _ => 4,
        }
    }

    #[inline]
    pub const fn is_quad(self) -> bool {
        self.vertices() == 4
    }

    /// Polynomial degree along an edge (1 or 2): the degree of the trace space.
    #[inline]
    pub const fn degree(self) -> usize {
        match self {
            Family::Tri3 | Family::Quad4 => 1,
            _ => 2,
        }
    }

    /// Index of the family in [`Family::ALL`].
    #[inline]
    pub const fn index(self) -> usize {
        self as usize
    }

    /// Human name for reports.
    pub const fn name(self) -> &'static str {
        match self {
            Family::Tri3 => "P1 triangle",
            Family::Tri6 => "P2 triangle",
            Family::Quad4 => "Q1 quadrilateral",
            Family::Quad8 => "serendipity quadrilateral",
            Family::Quad9 => "Q2 quadrilateral",
        }
    }

    /// Short name (JSON, `inspect`).
    pub const fn short(self) -> &'static str {
        match self {
            Family::Tri3 => "triangle",
            Family::Tri6 => "triangle6",
            Family::Quad4 => "quad",
            Family::Quad8 => "quad8",
            Family::Quad9 => "quad9",
        }
    }

    /// The family of the same vertices and degree 1 (the "straight" cell).
    #[inline]
    pub const fn linear(self) -> Family {
        if self.is_quad() {
            Family::Quad4
        } else {
            Family::Tri3
        }
    }

    /// Local nodes of edge k: start vertex, end vertex, mid node (`usize::MAX` for degree 1).
    #[inline]
    pub const fn edge_nodes(self, k: usize) -> [usize; 3] {
        let nv = self.vertices();
        let mid = if self.degree() == 2 {
            nv + k
        } else {
            usize::MAX
        };
        [k, (k + 1) % nv, mid]
    }

    /// Reference positions of the nodes.
    pub fn reference_nodes(self) -> &'static [[f64; 2]] {
        match self {
            Family::Tri3 => &triangle::P2_NODES[..3],
            Family::Tri6 => &triangle::P2_NODES,
            Family::Quad4 => &quadrilateral::NODES[..4],
            Family::Quad8 => &quadrilateral::NODES[..8],
            Family::Quad9 => &quadrilateral::NODES,
        }
    }

    /// Shape values and reference gradients at ξ (slots past [`Family::nodes`] are 0).
    #[inline]
    pub fn shape(self, xi: [f64; 2]) -> ([f64; MAX_NODES], [[f64; 2]; MAX_NODES]) {
        let mut v = [0.0; MAX_NODES];
        let mut g = [[0.0; 2]; MAX_NODES];
        match self {
            Family::Tri3 => {
                v[..3].copy_from_slice(&triangle::p1_values(xi));
                g[..3].copy_from_slice(&triangle::P1_GRADIENTS);
            }
            Family::Tri6 => {
                v[..6].copy_from_slice(&triangle::p2_values(xi));
                g[..6].copy_from_slice(&triangle::p2_gradients(xi));
            }
            Family::Quad4 => {
                let (a, b) = quadrilateral::q1(xi);
                v[..4].copy_from_slice(&a);
                g[..4].copy_from_slice(&b);
            }
            Family::Quad8 => {
                let (a, b) = quadrilateral::s2(xi);
                v[..8].copy_from_slice(&a);
                g[..8].copy_from_slice(&b);
            }
            Family::Quad9 => {
                let (a, b) = quadrilateral::q2(xi);
                v = a;
                g = b;
            }
        }
        (v, g)
    }

    /// The reference point of local edge k at parameter s ∈ [0, 1] (s = 0 at vertex k).
    #[inline]
    pub fn edge_point(self, k: usize, s: f64) -> [f64; 2] {
        if self.is_quad() {
            match k {
                0 => [s, 0.0],
                1 => [1.0, s],
                2 => [1.0 - s, 1.0],
                _ => [0.0, 1.0 - s],
            }
        } else {
            edge::edge_reference_point(k, s)
        }
    }

    /// dξ/ds along local edge k.
    #[inline]
    pub const fn edge_tangent(self, k: usize) -> [f64; 2] {
        if self.is_quad() {
            match k {
                0 => [1.0, 0.0],
                1 => [0.0, 1.0],
                2 => [-1.0, 0.0],
                _ => [0.0, -1.0],
            }
        } else {
            match k {
                0 => [1.0, 0.0],
                1 => [-1.0, 1.0],
                _ => [0.0, -1.0],
            }
        }
    }

    /// Reference area (½ or 1).
    #[inline]
    pub const fn reference_area(self) -> f64 {
        if self.is_quad() { 1.0 } else { 0.5 }
    }
}

/// How far a cell is from the straight cell of its vertices, decided once by the mesh builder
/// with [`crate::tolerance::CURVED_RELATIVE`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub enum Shape {
    /// Constant Jacobian: a straight triangle or a parallelogram with its edge and centre
    /// nodes at their straight positions.
    Affine,
    /// A straight-sided quadrilateral that is no parallelogram (bilinear map, J varies).
    Bilinear,
    /// Some edge or centre node off its straight position (isoparametric, curved edges).
    Curved,
}

/// The straight (affine or bilinear) position of node `k` of a cell from its vertices.
pub fn straight_position(family: Family, x: &[[f64; 2]], k: usize) -> [f64; 2] {
    let xi = family.reference_nodes()[k];
    let lin = family.linear();
    let (v, _) = lin.shape(xi);
    let mut p = [0.0; 2];
    for i in 0..lin.nodes() {
        p[0] += v[i] * (x[i][0] - x[0][0]);
        p[1] += v[i] * (x[i][1] - x[0][1]);
    }
    [p[0] + x[0][0], p[1] + x[0][1]]
}

/// Area of the straight triangle through `v` (unsigned).
#[inline]
pub fn straight_area(v: [[f64; 2]; 3]) -> f64 {
    0.5 * ((v[1][0] - v[0][0]) * (v[2][1] - v[0][1]) - (v[2][0] - v[0][0]) * (v[1][1] - v[0][1]))
        .abs()
}

/// |a − b|², without `hypot`: the reader refuses coordinates past ±1e100 and extents below
/// 1e-100 (docs/design.md §4.2), so the squares neither overflow nor lose a meaningful digit,
/// and `hypot` costs about three times as much (a measurable share of the mesh build).
#[inline]
pub fn dist2(a: [f64; 2], b: [f64; 2]) -> f64 {
    let (dx, dy) = (a[0] - b[0], a[1] - b[1]);
    dx * dx + dy * dy
}

/// The diameter of the cell through its vertices (largest vertex distance).
pub fn diameter(family: Family, x: &[[f64; 2]]) -> f64 {
    diameter2(family, x).sqrt()
}

/// The squared diameter of the cell through its vertices.
fn diameter2(family: Family, x: &[[f64; 2]]) -> f64 {
    let nv = family.vertices();
    let mut h2 = 0.0f64;
    for i in 0..nv {
        for j in i + 1..nv {
            h2 = h2.max(dist2(x[i], x[j]));
        }
    }
    h2
}

/// The diameter of a point set: the largest distance between two points, over the convex
/// hull (Andrew's monotone chain), O(n log n) in the points that survive the Akl–Toussaint
/// filter: the extreme points in the eight directions 0°, 45°, …, 315° form, in that order,
/// a convex polygon inscribed in the hull, and a point strictly inside it is no hull vertex,
/// so only the points near the boundary of the hull are sorted.
pub fn point_set_diameter(points: &[[f64; 2]]) -> f64 {
    let s = std::f64::consts::FRAC_1_SQRT_2;
    let dirs: [[f64; 2]; 8] = [
        [1.0, 0.0],
        [s, s],
        [0.0, 1.0],
        [-s, s],
        [-1.0, 0.0],
        [-s, -s],
        [0.0, -1.0],
        [s, -s],
    ];
    let mut ext = [[0.0f64; 2]; 8];
    let mut best = [f64::NEG_INFINITY; 8];
    for &q in points {
        for k in 0..8 {
            let v = dirs[k][0] * q[0] + dirs[k][1] * q[1];
            if v > best[k] {
                best[k] = v;
                ext[k] = q;
            }
        }
    }
    let cross = |o: [f64; 2], a: [f64; 2], b: [f64; 2]| {
        (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])
    };
    let mut poly: Vec<[f64; 2]> = Vec::with_capacity(8);
    for &q in &ext {
        if poly.last() != Some(&q) && poly.first() != Some(&q) {
            poly.push(q);
        }
    }
    let inside = |q: [f64; 2]| {
        poly.len() >= 3
            && (0..poly.len()).all(|k| cross(poly[k], poly[(k + 1) % poly.len()], q) > 0.0)
    };
    let mut p: Vec<[f64; 2]> = points.iter().copied().filter(|&q| !inside(q)).collect();
    p.sort_unstable_by(|a, b| a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])));
    p.dedup();
    if p.len() < 2 {
        return 0.0;
    }
    let mut hull: Vec<[f64; 2]> = Vec::new();
    for pass in 0..2 {
        let start = hull.len();
        let iter: Box<dyn Iterator<Item = &[f64; 2]>> = if pass == 0 {
            Box::new(p.iter())
        } else {
            Box::new(p.iter().rev())
        };
        for &q in iter {
            while hull.len() >= start + 2
                && cross(hull[hull.len() - 2], hull[hull.len() - 1], q) <= 0.0
            {
                hull.pop();
            }
            hull.push(q);
        }
        hull.pop();
    }
    let mut d2 = 0.0f64;
    for i in 0..hull.len() {
        for j in i + 1..hull.len() {
            d2 = d2.max(dist2(hull[i], hull[j]));
        }
    }
    d2.sqrt()
}

/// Classifies a cell: curved if any high-order node is off its straight position by more than
/// `rel_tol · h_T`, bilinear if a quadrilateral's vertices are no parallelogram to the same
/// tolerance, else affine.
pub fn classify(family: Family, x: &[[f64; 2]], rel_tol: f64) -> Shape {
    // Compared squared: |off|² > (rel_tol · h)².
    let tol2 = rel_tol * rel_tol * diameter2(family, x);
    let nv = family.vertices();
    for k in nv..family.nodes() {
        if dist2(x[k], straight_position(family, x, k)) > tol2 {
            return Shape::Curved;
        }
    }
    if family.is_quad() {
        // Parallelogram: x0 − x1 + x2 − x3 = 0.
        let d = [
            x[0][0] - x[1][0] + x[2][0] - x[3][0],
            x[0][1] - x[1][1] + x[2][1] - x[3][1],
        ];
        if dist2(d, [0.0, 0.0]) > tol2 {
            return Shape::Bilinear;
        }
    }
    Shape::Affine
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The filtered hull diameter against the O(n²) definition: a lattice (ties in every
    /// direction), points on a circle and inside it, collinear points, one point.
    #[test]
    fn point_set_diameter_is_the_largest_distance() {
        let brute = |p: &[[f64; 2]]| {
            let mut d = 0.0f64;
            for a in p {
                for b in p {
                    d = d.max((a[0] - b[0]).hypot(a[1] - b[1]));
                }
            }
            d
        };
        let mut lattice = Vec::new();
        for i in 0..13 {
            for j in 0..7 {
                lattice.push([i as f64 * 0.25 - 1.0, j as f64 / 3.0]);
            }
        }
        let mut disc = Vec::new();
        let mut uniform = crate::testing::uniform(12345);
        for k in 0..500 {
            let r = uniform();
            let t = k as f64 * 0.7;
            let r = if k % 5 == 0 { 1.0 } else { r };
            disc.push([2.0 + r * t.cos(), -1.0 + r * t.sin()]);
        }
        let line: Vec<[f64; 2]> = (0..20).map(|k| [k as f64, 2.0 * k as f64]).collect();
        for p in [lattice, disc, line, vec![[3.0, 4.0]]] {
            let (d, b) = (point_set_diameter(&p), brute(&p));
            assert!((d - b).abs() <= 1e-15 * b.max(1.0), "{d} vs {b}");
        }
    }

    #[test]
    fn every_family_is_nodal_and_its_edges_follow_the_nodes() {
        for f in Family::ALL {
            let nodes = f.reference_nodes();
            assert_eq!(nodes.len(), f.nodes());
            for (j, &p) in nodes.iter().enumerate() {
                let (v, _) = f.shape(p);
                for (i, &vi) in v.iter().enumerate().take(f.nodes()) {
                    assert!((vi - if i == j { 1.0 } else { 0.0 }).abs() < 1e-14);
                }
            }
            for k in 0..f.vertices() {
                let [a, b, m] = f.edge_nodes(k);
                assert_eq!(f.edge_point(k, 0.0), nodes[a]);
                assert_eq!(f.edge_point(k, 1.0), nodes[b]);
                if m != usize::MAX {
                    assert_eq!(f.edge_point(k, 0.5), nodes[m]);
                }
                let (p0, p1) = (f.edge_point(k, 0.25), f.edge_point(k, 0.75));
                let t = f.edge_tangent(k);
                assert!((p1[0] - p0[0] - 0.5 * t[0]).abs() < 1e-15);
                assert!((p1[1] - p0[1] - 0.5 * t[1]).abs() < 1e-15);
            }
        }
    }

    #[test]
    fn classification_uses_one_relative_tolerance() {
        let sq = [[0., 0.], [2., 0.], [2., 1.], [0., 1.]];
        assert_eq!(classify(Family::Quad4, &sq, 1e-6), Shape::Affine);
        let trap = [[0., 0.], [2., 0.], [1.5, 1.], [0., 1.]];
        assert_eq!(classify(Family::Quad4, &trap, 1e-6), Shape::Bilinear);
        let mut q9: Vec<[f64; 2]> = quadrilateral::NODES.to_vec();
        assert_eq!(classify(Family::Quad9, &q9, 1e-6), Shape::Affine);
        // A rounding-sized offset (12 significant digits) stays straight, a real one curves.
        q9[4][1] += 1e-12;
        assert_eq!(classify(Family::Quad9, &q9, 1e-6), Shape::Affine);
        q9[4][1] -= 0.01;
        assert_eq!(classify(Family::Quad9, &q9, 1e-6), Shape::Curved);
    }
}
