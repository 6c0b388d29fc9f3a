//! Cell values, facet points and sub-triangles: the quantities every stage reads
//! (docs/design.md §4.3).
//!
//! - [`Table`]: a quadrature rule on the reference cell of a family with the shape values and
//!   reference gradients at its points, built once per (family, degree, split) and cached.
//!   Quadrilaterals use the tensor Gauss–Legendre rule with ⌊d/2⌋ + 1 points per direction
//!   (exact for degree d in each variable); triangles the symmetric rules of
//!   [`crate::quadrature`]. A *split* table on a quadrilateral is the triangle rule on each
//!   half of the fixed sub-triangulation ([`SubCell`]), for integrands that are polynomial on
//!   the halves (RT fields, docs/design.md §5.4).
//! - [`CellValues`]: for one cell, at every point q of a table: x_q, w_q det J(ξ_q),
//!   J(ξ_q) and the physical gradients ∇φ_i = J^{−T} ∇̂φ_i.
//! - [`facet_point`]: on local edge k at s: x, the outward unit normal, |dx/ds|, ξ, J, φ, ∇φ.

// The kernels index nodal arrays, shape tables and outputs in lockstep by node.
#![allow(clippy::needless_range_loop)]

use std::collections::HashMap;
use std::sync::{Mutex, OnceLock};

use super::{Family, Jacobian, MAX_NODES, Shape};
use crate::quadrature::{line_rule, triangle_rule_cached};
use crate::tolerance;

/// A rule on a family's reference cell with the shape functions tabulated at its points.
#[derive(Debug)]
pub struct Table {
    pub family: Family,
    /// The polynomial degree the rule integrates exactly (per variable on quadrilaterals).
    pub degree: usize,
    pub points: Vec<[f64; 2]>,
    pub weights: Vec<f64>,
    pub values: Vec<[f64; MAX_NODES]>,
    pub gradients: Vec<[[f64; 2]; MAX_NODES]>,
    /// Split tables: the sub-triangle of each point and its coordinate there.
    pub sub: Vec<u8>,
    pub sub_points: Vec<[f64; 2]>,
}

impl Table {
    fn build(family: Family, degree: usize, split: bool) -> Table {
        let mut points = Vec::new();
        let mut weights = Vec::new();
        let mut sub = Vec::new();
        let mut sub_points = Vec::new();
        if family.is_quad() && !split {
            let r = line_rule(degree);
            for (&y, &wy) in r.points.iter().zip(&r.weights) {
                for (&x, &wx) in r.points.iter().zip(&r.weights) {
                    points.push([x, y]);
                    weights.push(wx * wy);
                }
            }
        } else {
            let r = triangle_rule_cached(degree);
            for k in 0..sub_count(family) {
                let (a, b) = sub_map(family, k);
                for (&p, &w) in r.points.iter().zip(&r.weights) {
                    points.push(apply(a, b, p));
                    weights.push(w * det2(a));
                    sub.push(k as u8);
                    sub_points.push(p);
                }
            }
        }
        let (values, gradients) = points.iter().map(|&p| family.shape(p)).unzip();
        Table {
            family,
            degree,
            points,
            weights,
            values,
            gradients,
            sub,
            sub_points,
        }
    }

    #[inline]
    pub fn len(&self) -> usize {
        self.weights.len()
    }

    #[inline]
    pub fn is_empty(&self) -> bool {
        self.weights.is_empty()
    }
}

/// The cached table of `family` exact to `degree`; `split` asks for the rule on the
/// sub-triangles (the same as the plain rule on triangles).
pub fn table(family: Family, degree: usize, split: bool) -> &'static Table {
    type Cache = Mutex<HashMap<(Family, usize, bool), &'static Table>>;
    static CACHE: OnceLock<Cache> = OnceLock::new();
    let split = split && family.is_quad();
    let mut map = CACHE
        .get_or_init(Default::default)
        .lock()
        .unwrap_or_else(|e| e.into_inner());
    map.entry((family, degree, split))
        .or_insert_with(|| Box::leak(Box::new(Table::build(family, degree, split))))
}

/// The polynomial degree (per variable on quadrilaterals) of the interior integrands on an
/// affine cell of `family`: squares of ε(u_h) − Aσ_h and div σ_h + f with u_h, σ_h of the
/// family's degree (2 for P1/Q1, 4 for P2/Q2/S2), or of an RT_k stress on the sub-triangles
/// (degree 2(k + 1) against ε(u_h) of degree 2p − 1 on the halves of a quadrilateral).
pub fn integrand_degree(family: Family, rt: Option<usize>) -> usize {
    let p = family.degree();
    match rt {
        None => 2 * p,
        Some(k) if family.is_quad() => (2 * (k + 1)).max(2 * (2 * p - 1)),
        Some(k) => (2 * (k + 1)).max(2 * p),
    }
}

/// The table the interior terms of a cell are integrated with: exact for the polynomial
/// integrands on affine cells, `smooth_data` false raising it for non-polynomial body forces.
pub fn interior_table(
    family: Family,
    shape: Shape,
    rt: Option<usize>,
    smooth_data: bool,
) -> &'static Table {
    let p = integrand_degree(family, rt);
    let p = if smooth_data {
        p
    } else {
        p.max(crate::quadrature::MAX_TABULATED_DEGREE)
    };
    table(family, rule_degree(shape, p), rt.is_some())
}

/// The rule degree for an integrand that is a polynomial of degree `p` (per variable on
/// quadrilaterals) on affine cells: `p` there, `p` + [`tolerance::BILINEAR_EXTRA_DEGREE`] on
/// bilinear quadrilaterals and at least [`tolerance::CURVED_DEGREE`] on curved cells, where
/// the integrands are rational.
pub fn rule_degree(shape: Shape, p: usize) -> usize {
    match shape {
        Shape::Affine => p,
        Shape::Bilinear => p + tolerance::BILINEAR_EXTRA_DEGREE,
        Shape::Curved => p.max(tolerance::CURVED_DEGREE),
    }
}

#[inline]
fn apply(a: [[f64; 2]; 2], b: [f64; 2], p: [f64; 2]) -> [f64; 2] {
    [
        b[0] + a[0][0] * p[0] + a[0][1] * p[1],
        b[1] + a[1][0] * p[0] + a[1][1] * p[1],
    ]
}

#[inline]
fn det2(a: [[f64; 2]; 2]) -> f64 {
    a[0][0] * a[1][1] - a[0][1] * a[1][0]
}

/// J = Σ_i (x_i − x_0) ⊗ ∇̂φ_i (differences keep the digits of cells far from the origin;
/// Σ ∇̂φ_i = 0).
#[inline]
pub fn jacobian(x: &[[f64; 2]], n: usize, g: &[[f64; 2]; MAX_NODES]) -> Jacobian {
    let mut m = [[0.0; 2]; 2];
    for i in 1..n {
        let d = [x[i][0] - x[0][0], x[i][1] - x[0][1]];
        for a in 0..2 {
            m[a][0] += d[a] * g[i][0];
            m[a][1] += d[a] * g[i][1];
        }
    }
    Jacobian::new(m)
}

/// x(ξ) = x_0 + Σ_i (x_i − x_0) φ_i(ξ).
#[inline]
pub fn position(x: &[[f64; 2]], n: usize, phi: &[f64; MAX_NODES]) -> [f64; 2] {
    let p = offset(x, n, phi);
    [p[0] + x[0][0], p[1] + x[0][1]]
}

/// Σ_i (x_i − x_0) φ_i(ξ) = x(ξ) − x_0, before x_0 is added: of the cell's size, so it keeps
/// the digits that adding x_0 (of the mesh's distance from the origin) rounds away.
#[inline]
fn offset(x: &[[f64; 2]], n: usize, phi: &[f64; MAX_NODES]) -> [f64; 2] {
    let mut p = [0.0; 2];
    for i in 1..n {
        p[0] += (x[i][0] - x[0][0]) * phi[i];
        p[1] += (x[i][1] - x[0][1]) * phi[i];
    }
    p
}

/// One [`CellValues`] per (family, shape) a thread meets, made on first use: the per-thread
/// state of a parallel loop over cells (`map_init(CellValuesCache::default, …)`).
#[derive(Default)]
pub struct CellValuesCache(Vec<(Family, Shape, CellValues)>);

impl CellValuesCache {
    /// The values for a cell of `family` and `shape`, on the table `table` gives for them
    /// (asked once per pair); the caller reinitialises them at the cell.
    pub fn get(
        &mut self,
        family: Family,
        shape: Shape,
        table: impl FnOnce(Family, Shape) -> &'static Table,
    ) -> &mut CellValues {
        let i = match self.0.iter().position(|c| c.0 == family && c.1 == shape) {
            Some(i) => i,
            None => {
                self.0
                    .push((family, shape, CellValues::new(table(family, shape))));
                self.0.len() - 1
            }
        };
        &mut self.0[i].2
    }
}

/// Geometry of one cell at the points of a [`Table`], refilled by [`CellValues::reinit`]
/// (one per thread; no allocation per cell).
pub struct CellValues {
    pub table: &'static Table,
    /// Nodes of the family.
    pub n: usize,
    pub x: Vec<[f64; 2]>,
    /// w_q · det J(ξ_q).
    pub jxw: Vec<f64>,
    pub jac: Vec<Jacobian>,
    /// ∇φ_i(x_q) = J^{−T} ∇̂φ_i(ξ_q).
    pub grad: Vec<[[f64; 2]; MAX_NODES]>,
    /// Split tables: the parent's shape values at each point (the table's are those of the
    /// reference correspondence, exact only on parallelograms); `jac` holds the
    /// sub-triangles' Jacobians there.
    phi_split: Vec<[f64; MAX_NODES]>,
}

impl CellValues {
    pub fn new(table: &'static Table) -> CellValues {
        let nq = table.len();
        CellValues {
            table,
            n: table.family.nodes(),
            x: vec![[0.0; 2]; nq],
            jxw: vec![0.0; nq],
            jac: vec![Jacobian::new([[1.0, 0.0], [0.0, 1.0]]); nq],
            grad: vec![[[0.0; 2]; MAX_NODES]; nq],
            phi_split: if table.sub.is_empty() || !table.family.is_quad() {
                Vec::new()
            } else {
                vec![[0.0; MAX_NODES]; nq]
            },
        }
    }

    /// Fills the values for the cell with node coordinates `coords` and shape `shape`
    /// (decided once by the mesh); affine cells evaluate J once. On a split table the points
    /// are those of the sub-triangles ([`sub_point`]), weighted by their det J.
    pub fn reinit(&mut self, coords: &[[f64; 2]], shape: Shape) {
        let t = self.table;
        let n = self.n;
        if !self.phi_split.is_empty() {
            for q in 0..t.len() {
                let sp = sub_point(t.family, coords, shape, t.sub[q] as usize, t.sub_points[q]);
                self.jac[q] = sp.jac;
                self.jxw[q] = t.weights[q] * sp.jac.det;
                self.x[q] = sp.x;
                self.grad[q] = sp.grad;
                self.phi_split[q] = sp.phi;
            }
            return;
        }
        let affine = shape == Shape::Affine;
        let fixed = affine.then(|| jacobian(coords, n, &t.gradients[0]));
        for q in 0..t.len() {
            let jac = fixed.unwrap_or_else(|| jacobian(coords, n, &t.gradients[q]));
            self.jac[q] = jac;
            self.jxw[q] = t.weights[q] * jac.det;
            self.x[q] = position(coords, n, &t.values[q]);
            let g = &t.gradients[q];
            let out = &mut self.grad[q];
            for i in 0..n {
                out[i] = jac.physical_gradient(g[i]);
            }
        }
    }

    #[inline]
    pub fn len(&self) -> usize {
        self.jxw.len()
    }

    #[inline]
    pub fn is_empty(&self) -> bool {
        self.jxw.is_empty()
    }

    /// Shape values at point q.
    #[inline]
    pub fn phi(&self, q: usize) -> &[f64; MAX_NODES] {
        if self.phi_split.is_empty() {
            &self.table.values[q]
        } else {
            &self.phi_split[q]
        }
    }

    /// Σ_i v_i φ_i(x_q) of a vector field with nodal values `v`.
    #[inline]
    pub fn value2(&self, q: usize, v: &[[f64; 2]]) -> [f64; 2] {
        let phi = self.phi(q);
        let mut r = [0.0; 2];
        for i in 0..self.n {
            r[0] += v[i][0] * phi[i];
            r[1] += v[i][1] * phi[i];
        }
        r
    }

    /// ∇v(x_q) (row a: component, column b: ∂/∂x_b) of a vector field with nodal values `v`.
    #[inline]
    pub fn gradient2(&self, q: usize, v: &[[f64; 2]]) -> [[f64; 2]; 2] {
        let g = &self.grad[q];
        let mut r = [[0.0; 2]; 2];
        for i in 0..self.n {
            for a in 0..2 {
                r[a][0] += v[i][a] * g[i][0];
                r[a][1] += v[i][a] * g[i][1];
            }
        }
        r
    }
}

/// Values on a cell edge at one parameter.
#[derive(Clone, Copy, Debug)]
pub struct FacetPoint {
    pub x: [f64; 2],
    /// Outward unit normal of the (counter-clockwise) cell.
    pub normal: [f64; 2],
    /// |dx/ds|.
    pub ds: f64,
    /// Tangent dx/ds.
    pub tangent: [f64; 2],
    /// Reference point in the cell.
    pub xi: [f64; 2],
    pub jac: Jacobian,
    pub phi: [f64; MAX_NODES],
    /// Physical gradients.
    pub grad: [[f64; 2]; MAX_NODES],
}

impl FacetPoint {
    /// Σ_i v_i φ_i of nodal vectors.
    #[inline]
    pub fn value2(&self, n: usize, v: &[[f64; 2]]) -> [f64; 2] {
        let mut r = [0.0; 2];
        for i in 0..n {
            r[0] += v[i][0] * self.phi[i];
            r[1] += v[i][1] * self.phi[i];
        }
        r
    }

    /// ∇v of nodal vectors.
    #[inline]
    pub fn gradient2(&self, n: usize, v: &[[f64; 2]]) -> [[f64; 2]; 2] {
        let mut r = [[0.0; 2]; 2];
        for i in 0..n {
            for a in 0..2 {
                r[a][0] += v[i][a] * self.grad[i][0];
                r[a][1] += v[i][a] * self.grad[i][1];
            }
        }
        r
    }
}

/// The point at parameter s ∈ [0, 1] of local edge `k` (from vertex k towards vertex k + 1)
/// of the cell of `family` with node coordinates `x`: x(ξ_k(s)), the tangent J ξ_k', |dx/ds|
/// and the outward normal (t_y, −t_x)/|t|.
#[inline]
pub fn facet_point(family: Family, x: &[[f64; 2]], k: usize, s: f64) -> FacetPoint {
    let xi = family.edge_point(k, s);
    let n = family.nodes();
    let (phi, g) = family.shape(xi);
    let jac = jacobian(x, n, &g);
    let d = family.edge_tangent(k);
    let m = jac.matrix;
    let tangent = [
        m[0][0] * d[0] + m[0][1] * d[1],
        m[1][0] * d[0] + m[1][1] * d[1],
    ];
    let ds = super::dist2(tangent, [0.0, 0.0]).sqrt();
    let mut grad = [[0.0; 2]; MAX_NODES];
    for i in 0..n {
        grad[i] = jac.physical_gradient(g[i]);
    }
    FacetPoint {
        x: position(x, n, &phi),
        normal: [tangent[1] / ds, -tangent[0] / ds],
        ds,
        tangent,
        xi,
        jac,
        phi,
        grad,
    }
}

/// A triangle of the fixed sub-triangulation that carries RT fields (docs/design.md §5.4):
/// the whole cell for a triangle; for a quadrilateral, half 0 through the vertices (0, 1, 2)
/// or half 1 through (0, 2, 3), cut along the straight diagonal from vertex 0 to vertex 2. A
/// half is a triangle of its own: straight (its three vertices) when the quadrilateral has
/// straight edges, isoparametric P2 when it is curved, with the quadrilateral's edge nodes on
/// its two outer edges and the chord midpoint on the diagonal. P2 traces are the same curves
/// as the quadrilateral's (three nodes, the same quadratic parametrisation), so the halves
/// tile the cell exactly, and RT_k on them contains every polynomial field of degree ≤ k on
/// straight cells, whatever the quadrilateral's bilinear distortion.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SubCell {
    pub parent: u32,
    pub index: u8,
}

/// Sub-triangles per cell of a family.
#[inline]
pub const fn sub_count(family: Family) -> usize {
    if family.is_quad() { 2 } else { 1 }
}

/// Parent-local vertices of sub-triangle `k`, counter-clockwise.
#[inline]
pub const fn sub_vertices(family: Family, k: usize) -> [usize; 3] {
    if family.is_quad() {
        if k == 0 { [0, 1, 2] } else { [0, 2, 3] }
    } else {
        [0, 1, 2]
    }
}

/// (A, b) of the reference correspondence ξ_parent = b + A ξ_sub of half `k` (exact on
/// parallelograms, the starting guess of the inverse map otherwise).
#[inline]
pub const fn sub_map(family: Family, k: usize) -> ([[f64; 2]; 2], [f64; 2]) {
    if family.is_quad() {
        if k == 0 {
            ([[1.0, 1.0], [0.0, 1.0]], [0.0, 0.0])
        } else {
            ([[1.0, 0.0], [1.0, 1.0]], [0.0, 0.0])
        }
    } else {
        ([[1.0, 0.0], [0.0, 1.0]], [0.0, 0.0])
    }
}

/// The parent edge under local edge `e` of sub-triangle `k`, traversed in the same direction
/// with the same parameter, or `None` for the diagonal.
#[inline]
pub const fn sub_edge_parent(family: Family, k: usize, e: usize) -> Option<usize> {
    if !family.is_quad() {
        return Some(e);
    }
    match (k, e) {
        (0, 0) => Some(0),
        (0, 1) => Some(1),
        (1, 1) => Some(2),
        (1, 2) => Some(3),
        _ => None,
    }
}

/// The family and node coordinates of sub-triangle `k` of the cell of `family` with nodes `x`
/// (`curved`: the cell has a curved edge).
#[inline]
pub fn sub_nodes(
    family: Family,
    x: &[[f64; 2]],
    curved: bool,
    k: usize,
) -> (Family, [[f64; 2]; 6]) {
    let mut y = [[0.0; 2]; 6];
    if !family.is_quad() {
        y[..family.nodes()].copy_from_slice(&x[..family.nodes()]);
        return (family, y);
    }
    let v = sub_vertices(family, k);
    for j in 0..3 {
        y[j] = x[v[j]];
    }
    if !curved {
        return (Family::Tri3, y);
    }
    let chord = [0.5 * (x[0][0] + x[2][0]), 0.5 * (x[0][1] + x[2][1])];
    // Mid nodes of the half's edges (v0, v1), (v1, v2), (v2, v0).
    let mids = if k == 0 {
        [x[4], x[5], chord]
    } else {
        [chord, x[6], x[7]]
    };
    y[3..6].copy_from_slice(&mids);
    (Family::Tri6, y)
}

/// The reference point ξ of the cell of `family` with nodes `x` whose image is `target`, by
/// Newton's method from `guess`: ξ ← ξ − J(ξ)⁻¹ (x(ξ) − target), until the step is below
/// [`tolerance::INVERSE_MAP_STEP`] (quadratic convergence from the reference correspondence;
/// at most [`tolerance::INVERSE_MAP_ITERATIONS`] steps).
pub fn invert(family: Family, x: &[[f64; 2]], target: [f64; 2], guess: [f64; 2]) -> [f64; 2] {
    let n = family.nodes();
    let mut xi = guess;
    for _ in 0..tolerance::INVERSE_MAP_ITERATIONS {
        let (phi, g) = family.shape(xi);
        let j = jacobian(x, n, &g);
        // x(ξ) − target as (x(ξ) − x_0) − (target − x_0): differences of nearby points, so the
        // residual can reach ε h rather than the ε|x| of an absolute position.
        let p = offset(x, n, &phi);
        let r = [p[0] - (target[0] - x[0][0]), p[1] - (target[1] - x[0][1])];
        let m = j.inverse;
        let d = [
            m[0][0] * r[0] + m[0][1] * r[1],
            m[1][0] * r[0] + m[1][1] * r[1],
        ];
        xi = [xi[0] - d[0], xi[1] - d[1]];
        // A NaN step (a degenerate map) stops too.
        let step = d[0].abs().max(d[1].abs());
        if step <= tolerance::INVERSE_MAP_STEP || step.is_nan() {
            break;
        }
    }
    xi
}

/// Geometry at a point of a sub-triangle.
#[derive(Clone, Copy, Debug)]
pub struct SubPoint {
    pub x: [f64; 2],
    /// x = base + offset: the map's first node and the point's offset from it ([`offset`]),
    /// for differences x − p that keep the digits of the cell's size ([`SubPoint::from`]).
    base: [f64; 2],
    offset: [f64; 2],
    /// The parent's reference point.
    pub xi: [f64; 2],
    /// The sub-triangle's Jacobian (the Piola map of RT fields).
    pub jac: Jacobian,
    /// The parent's shape values and physical gradients there.
    pub phi: [f64; MAX_NODES],
    pub grad: [[f64; 2]; MAX_NODES],
}

impl SubPoint {
    /// x − p for a point p of this cell or near it, as (x_0 − p) + Σ_i (x_i − x_0) φ_i: both
    /// parts are differences of nearby coordinates, so a mesh far from the origin (|x| ≫ h)
    /// loses nothing, where (x − p) would carry the ε|x| of x's rounding (design §5.1, "Frame").
    #[inline]
    pub fn from(&self, p: [f64; 2]) -> [f64; 2] {
        [
            self.offset[0] + (self.base[0] - p[0]),
            self.offset[1] + (self.base[1] - p[1]),
        ]
    }

    /// Σ_i `u[nodes[i]]` φ_i: a nodal vector field of the parent cell (global values `u`).
    #[inline]
    pub fn value_at(&self, nodes: &[u32], u: &[[f64; 2]]) -> [f64; 2] {
        let mut r = [0.0; 2];
        for (i, &p) in nodes.iter().enumerate() {
            r[0] += u[p as usize][0] * self.phi[i];
            r[1] += u[p as usize][1] * self.phi[i];
        }
        r
    }

    /// ∇u = Σ_i `u[nodes[i]]` ⊗ ∇φ_i (row a: ∂u_a/∂x, ∂u_a/∂y).
    #[inline]
    pub fn gradient_at(&self, nodes: &[u32], u: &[[f64; 2]]) -> [[f64; 2]; 2] {
        let mut r = [[0.0; 2]; 2];
        for (i, &p) in nodes.iter().enumerate() {
            let (v, g) = (u[p as usize], self.grad[i]);
            for a in 0..2 {
                r[a][0] += v[a] * g[0];
                r[a][1] += v[a] * g[1];
            }
        }
        r
    }
}

/// The shape values and reference gradients of a triangle family at fixed reference points,
/// the same for every cell: [`TriangleTable::point`] is [`sub_point`] of a triangle without
/// re-evaluating them (the bound's split quadrature calls it ~10⁸ times at 1M P2 cells).
pub struct TriangleTable {
    family: Family,
    points: Vec<[f64; 2]>,
    shapes: Vec<([f64; MAX_NODES], [[f64; 2]; MAX_NODES])>,
}

impl TriangleTable {
    /// The table of `family` (a triangle family) at `points`.
    pub fn new(family: Family, points: &[[f64; 2]]) -> TriangleTable {
        assert!(
            !family.is_quad(),
            "a triangle table of a quadrilateral family"
        );
        TriangleTable {
            family,
            points: points.to_vec(),
            shapes: points.iter().map(|&xi| family.shape(xi)).collect(),
        }
    }

    pub fn family(&self) -> Family {
        self.family
    }

    /// `sub_point(family, x, shape, 0, points[p])` for a triangle cell of this family with
    /// nodes `x`, straight or curved: a triangle is its own sub-triangle, so the Piola
    /// Jacobian is the cell map's at ξ (sub_map is the identity).
    #[inline]
    pub fn point(&self, x: &[[f64; 2]], p: usize) -> SubPoint {
        triangle_point(self.family, x, self.points[p], &self.shapes[p])
    }

    /// The reference point p.
    #[inline]
    pub fn xi(&self, p: usize) -> [f64; 2] {
        self.points[p]
    }

    /// Σ_i `u[nodes[i]]` ⊗ ∇̂φ_i(ξ_p) (row a: ∂u_a/∂ξ, ∂u_a/∂η): on a straight cell, where J is
    /// one matrix, ∇u = this · J⁻¹ without the physical gradient of every shape function.
    #[inline]
    pub fn reference_gradient(&self, p: usize, nodes: &[u32], u: &[[f64; 2]]) -> [[f64; 2]; 2] {
        let g = &self.shapes[p].1;
        let mut r = [[0.0; 2]; 2];
        for (i, &n) in nodes.iter().enumerate() {
            let v = u[n as usize];
            for a in 0..2 {
                r[a][0] += v[a] * g[i][0];
                r[a][1] += v[a] * g[i][1];
            }
        }
        r
    }
}

/// The geometry of a triangle cell (its own sub-triangle) at ξ from the family's shape values
/// and reference gradients there: [`sub_point`] of a triangle and [`TriangleTable::point`].
#[inline]
fn triangle_point(
    family: Family,
    x: &[[f64; 2]],
    xi: [f64; 2],
    (phi, g): &([f64; MAX_NODES], [[f64; 2]; MAX_NODES]),
) -> SubPoint {
    let n = family.nodes();
    let jac = jacobian(x, n, g);
    let mut grad = [[0.0; 2]; MAX_NODES];
    for i in 0..n {
        grad[i] = jac.physical_gradient(g[i]);
    }
    let off = offset(x, n, phi);
    SubPoint {
        x: [off[0] + x[0][0], off[1] + x[0][1]],
        base: x[0],
        offset: off,
        xi,
        jac,
        phi: *phi,
        grad,
    }
}

/// `sub_point(family, x, shape, k, ξ_sub).jac` alone, to the bit: on a triangle the cell
/// map's Jacobian without the point and the physical gradients (the patch rows ask for four
/// Jacobians per cell and patch).
#[inline]
pub fn sub_jacobian(
    family: Family,
    x: &[[f64; 2]],
    shape: Shape,
    k: usize,
    xi_sub: [f64; 2],
) -> Jacobian {
    if family.is_quad() {
        sub_point(family, x, shape, k, xi_sub).jac
    } else {
        jacobian(x, family.nodes(), &family.shape(xi_sub).1)
    }
}

/// Geometry at ξ_sub of sub-triangle `k` of the cell of `family` with nodes `x`; `shape` is
/// the cell's ([`crate::mesh::Mesh::shape`]).
#[inline]
pub fn sub_point(
    family: Family,
    x: &[[f64; 2]],
    shape: Shape,
    k: usize,
    xi_sub: [f64; 2],
) -> SubPoint {
    // A triangle is its own sub-triangle: one evaluation of the shape functions serves the
    // Piola Jacobian and the parent's gradients.
    if !family.is_quad() {
        return triangle_point(family, x, xi_sub, &family.shape(xi_sub));
    }
    let n = family.nodes();
    let (sf, y) = sub_nodes(family, x, shape == Shape::Curved, k);
    let (sphi, sg) = sf.shape(xi_sub);
    let js = jacobian(&y, sf.nodes(), &sg);
    let off = offset(&y, sf.nodes(), &sphi);
    let xp = [off[0] + y[0][0], off[1] + y[0][1]];
    let (a, b) = sub_map(family, k);
    let guess = apply(a, b, xi_sub);
    let xi = if !family.is_quad() || shape == Shape::Affine {
        guess
    } else {
        invert(family, x, xp, guess)
    };
    let (phi, g) = family.shape(xi);
    let jp = jacobian(x, n, &g);
    let mut grad = [[0.0; 2]; MAX_NODES];
    for i in 0..n {
        grad[i] = jp.physical_gradient(g[i]);
    }
    SubPoint {
        x: xp,
        base: y[0],
        offset: off,
        xi,
        jac: js,
        phi,
        grad,
    }
}

/// Geometry at parameter s of local edge `l` of sub-triangle `k` (from its vertex l towards
/// l + 1): the point, the outward normal, |dx/ds| and ξ_sub.
#[inline]
pub fn sub_edge_point(
    family: Family,
    x: &[[f64; 2]],
    shape: Shape,
    k: usize,
    l: usize,
    s: f64,
) -> (SubPoint, [f64; 2], f64, [f64; 2]) {
    let xs = super::edge::edge_reference_point(l, s);
    let p = sub_point(family, x, shape, k, xs);
    let d = Family::Tri3.edge_tangent(l);
    let m = p.jac.matrix;
    let t = [
        m[0][0] * d[0] + m[0][1] * d[1],
        m[1][0] * d[0] + m[1][1] * d[1],
    ];
    let len = super::dist2(t, [0.0, 0.0]).sqrt();
    (p, [t[1] / len, -t[0] / len], len, xs)
}

/// The sub-triangle holding the image of parent reference point ξ, its coordinate there and
/// its Jacobian. A quadrilateral's half 0 holds vertex 1: the points right of (or on) the
/// diagonal from vertex 0 to vertex 2.
pub fn locate_sub(
    family: Family,
    x: &[[f64; 2]],
    shape: Shape,
    xi: [f64; 2],
) -> (usize, [f64; 2], Jacobian) {
    if !family.is_quad() {
        let (_, g) = family.shape(xi);
        return (0, xi, jacobian(x, family.nodes(), &g));
    }
    let (phi, _) = family.shape(xi);
    let p = position(x, family.nodes(), &phi);
    let d = [x[2][0] - x[0][0], x[2][1] - x[0][1]];
    let r = [p[0] - x[0][0], p[1] - x[0][1]];
    let k = if d[0] * r[1] - d[1] * r[0] <= 0.0 {
        0
    } else {
        1
    };
    let (sf, y) = sub_nodes(family, x, shape == Shape::Curved, k);
    // ξ_sub from the straight triangle of the half's vertices, refined on a curved half.
    let (a0, a1, a2) = (y[0], y[1], y[2]);
    let j0 = Jacobian::new([
        [a1[0] - a0[0], a2[0] - a0[0]],
        [a1[1] - a0[1], a2[1] - a0[1]],
    ]);
    let m = j0.inverse;
    let mut xs = [
        m[0][0] * (p[0] - a0[0]) + m[0][1] * (p[1] - a0[1]),
        m[1][0] * (p[0] - a0[0]) + m[1][1] * (p[1] - a0[1]),
    ];
    if sf == Family::Tri6 {
        xs = invert(sf, &y, p, xs);
    }
    let (_, g) = sf.shape(xs);
    (k, xs, jacobian(&y, sf.nodes(), &g))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A curved Q2 cell: the unit square with the bottom mid node pushed down.
    fn curved_q9() -> Vec<[f64; 2]> {
        let mut x: Vec<[f64; 2]> = super::super::quadrilateral::NODES
            .iter()
            .map(|p| [2.0 * p[0] + 3.0, p[1] - 1.0])
            .collect();
        x[4][1] -= 0.1;
        x
    }

    /// The table's points are exactly `sub_point`'s: the same formulas on the same values,
    /// so every field agrees to the bit, on a straight P1 and a curved P2 triangle.
    #[test]
    fn a_triangle_table_gives_sub_point() {
        let pts = [[0.2, 0.3], [1.0 / 3.0, 1.0 / 3.0], [0.05, 0.9], [0.0, 0.0]];
        let p1 = [[1.0, 0.5], [3.0, 0.7], [1.4, 2.2]];
        let mut p2 = vec![p1[0], p1[1], p1[2]];
        for l in 0..3 {
            let (a, b) = (p1[l], p1[(l + 1) % 3]);
            p2.push([0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1])]);
        }
        p2[4][0] += 0.15;
        for (fam, x, shape) in [
            (Family::Tri3, p1.to_vec(), Shape::Affine),
            (Family::Tri6, p2, Shape::Curved),
        ] {
            let table = TriangleTable::new(fam, &pts);
            for (p, &xi) in pts.iter().enumerate() {
                let (a, b) = (table.point(&x, p), sub_point(fam, &x, shape, 0, xi));
                assert_eq!(a.x, b.x);
                assert_eq!(a.xi, b.xi);
                assert_eq!(a.jac.matrix, b.jac.matrix);
                assert_eq!(a.jac.det, b.jac.det);
                assert_eq!(a.phi, b.phi);
                assert_eq!(a.grad, b.grad);
            }
        }
    }

    #[test]
    fn areas_and_perimeters_match_hand_values() {
        // Area of the curved cell: 2 − ∫ parabola bump = 2 + 2·(2/3)·0.1 (the bottom edge
        // bulges outward by 0.1 at its middle; ∫_0^2 0.1·4s(1−s) dx with x = 2s is 2·0.1·2/3).
        let x = curved_q9();
        for deg in [3, 5, 9] {
            let mut cv = CellValues::new(table(Family::Quad9, deg, false));
            cv.reinit(&x, Shape::Curved);
            let area: f64 = cv.jxw.iter().sum();
            assert!((area - (2.0 + 0.4 / 3.0)).abs() < 1e-13, "{deg}: {area}");
            // The split rule integrates the same polynomial area.
            let mut cs = CellValues::new(table(Family::Quad9, deg + 2, true));
            cs.reinit(&x, Shape::Curved);
            let a2: f64 = cs.jxw.iter().sum();
            assert!((a2 - area).abs() < 1e-13);
        }
        // ∫ div(x) = 2·area = ∮ x·n ds over the four edges.
        let r = line_rule(20);
        let mut flux = 0.0;
        for k in 0..4 {
            for (&s, &w) in r.points.iter().zip(&r.weights) {
                let f = facet_point(Family::Quad9, &x, k, s);
                flux += w * f.ds * (f.x[0] * f.normal[0] + f.x[1] * f.normal[1]);
            }
        }
        assert!((flux - 2.0 * (2.0 + 0.4 / 3.0)).abs() < 1e-12, "{flux}");
    }

    #[test]
    fn gradients_reproduce_linear_fields_on_every_family() {
        for f in Family::ALL {
            let x: Vec<[f64; 2]> = f
                .reference_nodes()
                .iter()
                .map(|p| {
                    [
                        1.0 + 2.0 * p[0] + 0.3 * p[1],
                        -1.0 + 0.2 * p[0] + 1.5 * p[1] + 0.1 * p[0] * p[1],
                    ]
                })
                .collect();
            let u: Vec<[f64; 2]> = x
                .iter()
                .map(|p| [3.0 * p[0] - p[1], 0.5 * p[1] + 2.0])
                .collect();
            let mut cv = CellValues::new(table(f, 4, false));
            cv.reinit(&x, Shape::Curved);
            for q in 0..cv.len() {
                let g = cv.gradient2(q, &u);
                assert!((g[0][0] - 3.0).abs() < 1e-12 && (g[0][1] + 1.0).abs() < 1e-12);
                assert!(g[1][0].abs() < 1e-12 && (g[1][1] - 0.5).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn sub_triangles_tile_the_square_along_the_parent_edges() {
        let f = Family::Quad4;
        for k in 0..2 {
            let v = sub_vertices(f, k);
            let (a, b) = sub_map(f, k);
            for (j, &p) in [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]].iter().enumerate() {
                assert_eq!(apply(a, b, p), super::super::quadrilateral::NODES[v[j]]);
            }
            for e in 0..3 {
                if let Some(pe) = sub_edge_parent(f, k, e) {
                    for s in [0.0, 0.3, 1.0] {
                        let p = apply(a, b, crate::geometry::edge::edge_reference_point(e, s));
                        assert_eq!(p, f.edge_point(pe, s));
                    }
                }
            }
        }
    }
}
