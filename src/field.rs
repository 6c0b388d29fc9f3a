//! The fields the functional is evaluated for (docs/design.md §4): a displacement per mesh
//! point and a stress that is either continuous nodal data or a row-wise Raviart–Thomas field
//! on the cells' sub-triangles (docs/design.md §5.4).

use crate::element::rt::{self, MAX_RT_DOFS, RtOrder};
use crate::geometry::values::{locate_sub, sub_count, sub_point};
use crate::geometry::{Jacobian, MAX_NODES};
use crate::mesh::Mesh;

/// max_i |v_i| with |·| the Euclidean length: the scale of a vector field, the same in every
/// frame (a largest component would change by up to √2 under a rotation, and with it every
/// tolerance taken relative to it).
pub fn max_norm(v: &[[f64; 2]]) -> f64 {
    v.iter().fold(0.0f64, |m, x| m.max(x[0].hypot(x[1])))
}

/// The Frobenius norm of a stress `[xx, xy, yx, yy]`, invariant under rotations of the frame.
#[inline]
pub fn frobenius(s: &[f64; 4]) -> f64 {
    (s[0] * s[0] + s[1] * s[1] + s[2] * s[2] + s[3] * s[3]).sqrt()
}

/// A row-wise RT_k stress: per sub-triangle and row, the coefficients of the local basis.
/// Sub-triangle `first[t] + k` is half `k` of cell `t` ([`crate::geometry::SubCell`]).
#[derive(Clone, Debug)]
pub struct RtStress {
    pub order: RtOrder,
    pub coefficients: Vec<[[f64; MAX_RT_DOFS]; 2]>,
    /// First sub-triangle of each cell (`first[t] = t` on triangle meshes), with one more
    /// entry at the end.
    pub first: Vec<u32>,
}

impl RtStress {
    /// σ (row-major `[xx, xy, yx, yy]`) and div σ at reference point `xi_sub` of sub-triangle
    /// `sub`, whose map has Jacobian `jac_sub` there (the contravariant Piola map).
    #[inline]
    pub fn at(&self, sub: usize, jac_sub: &Jacobian, xi_sub: [f64; 2]) -> ([f64; 4], [f64; 2]) {
        self.at_reference(sub, jac_sub, &rt::reference(self.order, xi_sub))
    }

    /// [`RtStress::at`] from the reference basis values at the point, already evaluated
    /// (`rt::reference(self.order, ξ)`, e.g. tabulated at fixed points).
    #[inline]
    pub fn at_reference(
        &self,
        sub: usize,
        jac_sub: &Jacobian,
        reference: &([[f64; 2]; MAX_RT_DOFS], [f64; MAX_RT_DOFS]),
    ) -> ([f64; 4], [f64; 2]) {
        rt::piola_combination(
            reference,
            jac_sub,
            &self.coefficients[sub],
            self.order.dofs(),
        )
    }

    /// σ and div σ at the image of parent reference point `xi` of cell `t`: the
    /// sub-triangle holding it is found first ([`locate_sub`]).
    #[inline]
    pub fn at_parent(&self, mesh: &Mesh, t: usize, xi: [f64; 2]) -> ([f64; 4], [f64; 2]) {
        let f = mesh.family[t];
        let x = mesh.coords(t);
        let (k, xs, js) = locate_sub(f, &x[..f.nodes()], mesh.shape[t], xi);
        self.at(self.first[t] as usize + k, &js, xs)
    }

    /// Sub-triangles of cell `t`.
    #[inline]
    pub fn subs(&self, mesh: &Mesh, t: usize) -> usize {
        sub_count(mesh.family[t])
    }
}

/// `rt::reference(order, ξ)` at one point: values and divergences of the reference basis.
type RtReference = ([[f64; 2]; MAX_RT_DOFS], [f64; MAX_RT_DOFS]);

/// Largest rule degree whose tables get their RT basis tabulated ([`rt_at_table`]).
const TABULATED_RT_DEGREE: usize = 63;

/// `rt::reference(order, ξ_q)` at every point q of the cached `table` (the sub-triangle's ξ on
/// a split table), evaluated once per (order, family, degree, split): the stress at a point of
/// an RT field was ~40 % basis evaluation in the F stage. The tables of `values::table` are
/// one per such key, so the key names the points. None above [`TABULATED_RT_DEGREE`].
fn rt_at_table(
    order: RtOrder,
    table: &'static crate::geometry::values::Table,
) -> Option<&'static [RtReference]> {
    use std::sync::OnceLock;
    const FAMILIES: usize = crate::geometry::Family::ALL.len();
    const SLOTS: usize = 3 * FAMILIES * (TABULATED_RT_DEGREE + 1) * 2;
    static CACHE: [OnceLock<Box<[RtReference]>>; SLOTS] = [const { OnceLock::new() }; SLOTS];
    if table.degree > TABULATED_RT_DEGREE {
        return None;
    }
    let family = crate::geometry::Family::ALL
        .iter()
        .position(|&f| f == table.family)?;
    let split = !table.sub_points.is_empty();
    let key = ((order.k() * FAMILIES + family) * (TABULATED_RT_DEGREE + 1) + table.degree) * 2
        + usize::from(split);
    let points = if table.family.is_quad() {
        &table.sub_points
    } else {
        &table.points
    };
    Some(CACHE[key].get_or_init(|| points.iter().map(|&xi| rt::reference(order, xi)).collect()))
}

/// A stress the functional can be evaluated for (docs/design.md §4).
#[derive(Clone, Copy, Debug)]
pub enum StressField<'a> {
    /// Continuous nodal values per mesh point, row-major `[xx, xy, yx, yy]`.
    Nodal(&'a [[f64; 4]]),
    /// Row-wise Raviart–Thomas (a reconstruction).
    Rt(&'a RtStress),
}

impl StressField<'_> {
    /// The largest Frobenius norm of the stress (at nodes, or at sub-triangle centroids for RT),
    /// the scale of the stress admissibility tolerances.
    pub fn scale(&self, mesh: &Mesh) -> f64 {
        match self {
            StressField::Nodal(s) => s.iter().fold(0.0f64, |m, v| m.max(frobenius(v))),
            StressField::Rt(rt) => (0..mesh.len())
                .map(|t| {
                    let f = mesh.family[t];
                    let x = mesh.coords(t);
                    (0..sub_count(f))
                        .map(|k| {
                            let c = [1.0 / 3.0, 1.0 / 3.0];
                            let js = sub_point(f, &x[..f.nodes()], mesh.shape[t], k, c).jac;
                            let (s, _) = rt.at(rt.first[t] as usize + k, &js, c);
                            frobenius(&s)
                        })
                        .fold(0.0f64, f64::max)
                })
                .fold(0.0f64, f64::max),
        }
    }

    /// σ at point q of a [`crate::geometry::CellValues`] of cell `t` (nodal values `s` of the
    /// cell, or the RT field on the sub-triangle of a split table).
    #[inline]
    pub fn at_point(
        &self,
        cv: &crate::geometry::CellValues,
        t: usize,
        q: usize,
        s: &[[f64; 4]; MAX_NODES],
    ) -> ([f64; 4], [f64; 2]) {
        match self {
            StressField::Nodal(_) => {
                let phi = cv.phi(q);
                let g = &cv.grad[q];
                let mut sig = [0.0; 4];
                let mut div = [0.0; 2];
                for k in 0..cv.n {
                    for m in 0..4 {
                        sig[m] += s[k][m] * phi[k];
                    }
                    div[0] += s[k][0] * g[k][0] + s[k][1] * g[k][1];
                    div[1] += s[k][2] * g[k][0] + s[k][3] * g[k][1];
                }
                (sig, div)
            }
            StressField::Rt(rt) => {
                let table = cv.table;
                // Split tables hold the sub-triangles' Jacobians and coordinates (triangle
                // tables are their own sub-triangle).
                let (sub, xi) = if table.family.is_quad() {
                    (table.sub[q] as usize, table.sub_points[q])
                } else {
                    (0, table.points[q])
                };
                let first = rt.first[t] as usize + sub;
                match rt_at_table(rt.order, table) {
                    Some(basis) => rt.at_reference(first, &cv.jac[q], &basis[q]),
                    None => rt.at(first, &cv.jac[q], xi),
                }
            }
        }
    }
}
