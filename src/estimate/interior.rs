//! The interior terms of F per cell (docs/design.md §3), and the energy of the displacement:
//!
//! - constitutive: ∫_T density(ε(u_h) − Aσ_h), the density of the norm preset;
//! - equilibrium: ½ w_d ∫_T |div σ_h + f|²;
//! - energy: ∫_T ½(Cε(u_h), ε(u_h)) (or μ|ε(u_h)|²).
//!
//! Every square is the square of a pointwise difference. Quadrature is exact for the
//! polynomial integrands on affine cells (degree 2 for P1/Q1, 4 for P2/Q2/S2, per variable on
//! quadrilaterals); a body force given as a non-constant expression raises the rule to degree 12,
//! and curved and bilinear cells get more ([`crate::geometry::values::rule_degree`]): the
//! integrand is rational there. Geometry comes from [`crate::geometry::CellValues`].

use rayon::prelude::*;

use crate::expr::Expr;
use crate::field::StressField;
use crate::geometry::values::interior_table;
use crate::geometry::{CellValues, CellValuesCache, MAX_NODES};
use crate::material::Elastic;
use crate::mesh::Mesh;
use crate::problem::Context;
use crate::read::scene::Norm;

/// What the interior terms need (built from the [`Context`]).
struct Input<'a> {
    pub mesh: &'a Mesh,
    /// Displacement per mesh point.
    pub u: &'a [[f64; 2]],
    pub sigma: StressField<'a>,
    pub elastic: Elastic,
    pub norm: Norm,
    /// w_d of the equilibrium term.
    pub w_d: f64,
    pub body_force: Option<&'a [Expr; 2]>,
}

/// Per-cell values.
pub struct Interior {
    pub constitutive: Vec<f64>,
    pub equilibrium: Vec<f64>,
    pub energy: Vec<f64>,
}

/// The interior terms and the energy of every cell of `u` and `sigma` in the problem `ctx`.
pub fn interior(ctx: &Context, u: &[[f64; 2]], sigma: StressField) -> Interior {
    let inp = &Input {
        mesh: ctx.mesh,
        u,
        sigma,
        elastic: ctx.elastic,
        norm: ctx.norm,
        w_d: ctx.elastic.equilibrium_weight(ctx.norm, ctx.length_scale),
        body_force: ctx.scene.body_force.as_ref(),
    };
    let constant_f = inp
        .body_force
        .is_none_or(|f| f[0].is_constant() && f[1].is_constant());
    let rt = match inp.sigma {
        StressField::Rt(r) => Some(r.order.k()),
        StressField::Nodal(_) => None,
    };
    // Polynomial integrands are integrated exactly; a non-polynomial body force gets the
    // highest tabulated rule (degree 12), which resolves smooth data to ~1e-10 on usual meshes.
    let f_const = inp.body_force.map(|f| {
        [
            f[0].constant_value().unwrap_or(0.0),
            f[1].constant_value().unwrap_or(0.0),
        ]
    });
    let mesh = inp.mesh;
    let per_cell: Vec<[f64; 3]> = (0..mesh.len())
        .into_par_iter()
        .with_min_len(1024)
        .map_init(CellValuesCache::default, |cache, t| {
            let cv = cache.get(mesh.family[t], mesh.shape[t], |f, sh| {
                interior_table(f, sh, rt, constant_f)
            });
            cell(inp, t, cv, constant_f, f_const)
        })
        .collect();
    Interior {
        constitutive: per_cell.iter().map(|c| c[0]).collect(),
        equilibrium: per_cell.iter().map(|c| c[1]).collect(),
        energy: per_cell.iter().map(|c| c[2]).collect(),
    }
}

/// [constitutive, equilibrium, energy] of cell `t`.
fn cell(
    inp: &Input,
    t: usize,
    cv: &mut CellValues,
    constant_f: bool,
    f_const: Option<[f64; 2]>,
) -> [f64; 3] {
    let mesh = inp.mesh;
    let nodes = mesh.nodes(t);
    let x = mesh.coords(t);
    let mut u = [[0.0; 2]; MAX_NODES];
    let mut s = [[0.0; 4]; MAX_NODES];
    for (k, &p) in nodes.iter().enumerate() {
        u[k] = inp.u[p as usize];
        if let StressField::Nodal(sv) = inp.sigma {
            s[k] = sv[p as usize];
        }
    }
    cv.reinit(&x[..nodes.len()], mesh.shape[t]);

    let (mut c, mut d, mut e) = (0.0, 0.0, 0.0);
    for q in 0..cv.len() {
        let w = cv.jxw[q];
        let gu = cv.gradient2(q, &u);
        let (sig, div) = inp.sigma.at_point(cv, t, q, &s);
        let sym = 0.5 * (gu[0][1] + gu[1][0]);
        let eps = [gu[0][0], sym, sym, gu[1][1]];
        let a = inp.elastic.compliance(sig);
        let mismatch = [eps[0] - a[0], eps[1] - a[1], eps[2] - a[2], eps[3] - a[3]];
        c += w * inp.elastic.constitutive_density(inp.norm, mismatch);
        e += w * inp.elastic.energy_density(inp.norm, eps);
        let f = match (inp.body_force, constant_f) {
            (None, _) => [0.0; 2],
            (Some(_), true) => f_const.unwrap_or([0.0; 2]),
            (Some(f), false) => {
                let p = cv.x[q];
                [f[0].eval(p[0], p[1], 0.0), f[1].eval(p[0], p[1], 0.0)]
            }
        };
        let r = [div[0] + f[0], div[1] + f[1]];
        d += w * 0.5 * inp.w_d * (r[0] * r[0] + r[1] * r[1]);
    }
    [c, d, e]
}
