//! The interior terms of F per cell (DESIGN.md §3), and the energy of the displacement:
//!
//! - constitutive: ∫_T density(ε(u_h) − Aσ_h), the density of the norm preset;
//! - equilibrium: ½ w_d ∫_T |div σ_h + f|²;
//! - energy: ∫_T ½(Cε(u_h), ε(u_h)) (or μ|ε(u_h)|²).
//!
//! Every square is the square of a pointwise difference. Quadrature is exact for the
//! polynomial integrands on straight cells (degree 2 for P1, 4 for P2); a body force given as a
//! non-constant expression raises the rule to degree 12, and curved cells get degree 10 (the
//! integrand is rational there).

use rayon::prelude::*;

use super::material::Elastic;
use crate::element::lagrange::{jacobian, shape_gradients, shape_values};
use crate::element::map::Jacobian;
use crate::expr::Expr;
use crate::mesh::Mesh;
use crate::quadrature::{TriangleRule, triangle_rule_cached};
use crate::read::scene::Norm;

/// What the interior terms need.
pub struct Input<'a> {
    pub mesh: &'a Mesh,
    /// Displacement per mesh point.
    pub u: &'a [[f64; 2]],
    pub sigma: super::StressField<'a>,
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

/// Relative offset of a mid node from its chord midpoint above which a cell is curved.
const STRAIGHT_TOLERANCE: f64 = 1e-12;

/// Quadrature degree on curved (isoparametric P2) cells.
pub const CURVED_DEGREE: usize = 10;

/// Shape values and reference gradients at the points of one rule.
struct Table {
    rule: &'static TriangleRule,
    values: Vec<[f64; 6]>,
    gradients: Vec<[[f64; 2]; 6]>,
}

impl Table {
    fn new(degree: usize, p2: bool) -> Table {
        let rule = triangle_rule_cached(degree);
        let n = if p2 { 6 } else { 3 };
        let values = rule.points.iter().map(|&xi| shape_values(n, xi)).collect();
        let gradients = rule
            .points
            .iter()
            .map(|&xi| shape_gradients(n, xi))
            .collect();
        Table {
            rule,
            values,
            gradients,
        }
    }
}

/// Whether the P2 cell `t` has a mid node off its chord midpoint.
pub fn is_curved(mesh: &Mesh, t: usize) -> bool {
    if mesh.degree != 2 {
        return false;
    }
    let x = mesh.coords(t);
    [[0, 1, 3], [1, 2, 4], [2, 0, 5]].iter().any(|&[a, b, m]| {
        let off = [
            x[m][0] - 0.5 * (x[a][0] + x[b][0]),
            x[m][1] - 0.5 * (x[a][1] + x[b][1]),
        ];
        let len = (x[b][0] - x[a][0]).hypot(x[b][1] - x[a][1]);
        off[0].hypot(off[1]) > STRAIGHT_TOLERANCE * len
    })
}

/// The interior terms and the energy of every cell.
pub fn interior(inp: &Input) -> Interior {
    let p2 = inp.mesh.degree == 2;
    let constant_f = inp
        .body_force
        .is_none_or(|f| f[0].is_constant() && f[1].is_constant());
    // Polynomial integrands are integrated exactly; a non-polynomial body force gets the
    // highest tabulated rule (degree 12), which resolves smooth data to ~1e-10 on usual meshes.
    let straight_degree = if constant_f {
        if p2 { 4 } else { 2 }
    } else {
        crate::quadrature::MAX_TABULATED_DEGREE
    };
    let straight = Table::new(straight_degree, p2);
    let curved = Table::new(CURVED_DEGREE, p2);
    let f_const = inp.body_force.map(|f| {
        [
            f[0].constant_value().unwrap_or(0.0),
            f[1].constant_value().unwrap_or(0.0),
        ]
    });

    let per_cell: Vec<[f64; 3]> = (0..inp.mesh.triangles.len())
        .into_par_iter()
        .with_min_len(1024)
        .map(|t| {
            let is_curved = is_curved(inp.mesh, t);
            let table = if is_curved { &curved } else { &straight };
            cell(inp, t, table, is_curved, constant_f, f_const)
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
    table: &Table,
    curved: bool,
    constant_f: bool,
    f_const: Option<[f64; 2]>,
) -> [f64; 3] {
    let mesh = inp.mesh;
    let nodes = mesh.nodes(t);
    let n = nodes.len();
    let x = mesh.coords(t);
    let mut u = [[0.0; 2]; 6];
    let mut s = [[0.0; 4]; 6];
    for (k, &p) in nodes.iter().enumerate() {
        u[k] = inp.u[p as usize];
        if let super::StressField::Nodal(sv) = inp.sigma {
            s[k] = sv[p as usize];
        }
    }
    // P1 cells and straight P2 cells have the constant Jacobian of their vertices.
    let fixed = (!curved).then(|| affine_jacobian(&x));

    let (mut c, mut d, mut e) = (0.0, 0.0, 0.0);
    for q in 0..table.rule.weights.len() {
        let gref = &table.gradients[q];
        let jac = match fixed {
            Some(j) => j,
            None => jacobian(&x, n, gref),
        };
        let w = table.rule.weights[q] * jac.det;
        let phi = &table.values[q];
        let mut gu = [[0.0; 2]; 2];
        let mut sig = [0.0; 4];
        let mut div = [0.0; 2];
        for k in 0..n {
            let g = jac.physical_gradient(gref[k]);
            for a in 0..2 {
                gu[a][0] += u[k][a] * g[0];
                gu[a][1] += u[k][a] * g[1];
            }
            for m in 0..4 {
                sig[m] += s[k][m] * phi[k];
            }
            div[0] += s[k][0] * g[0] + s[k][1] * g[1];
            div[1] += s[k][2] * g[0] + s[k][3] * g[1];
        }
        if let super::StressField::Rt(rt) = inp.sigma {
            (sig, div) = rt.at(t, &jac, table.rule.points[q]);
        }
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
                let mut p = [0.0; 2];
                for k in 0..n {
                    p[0] += x[k][0] * phi[k];
                    p[1] += x[k][1] * phi[k];
                }
                [f[0].eval(p[0], p[1], 0.0), f[1].eval(p[0], p[1], 0.0)]
            }
        };
        let r = [div[0] + f[0], div[1] + f[1]];
        d += w * 0.5 * inp.w_d * (r[0] * r[0] + r[1] * r[1]);
    }
    [c, d, e]
}

/// J of the straight triangle through the vertices: columns x₁ − x₀, x₂ − x₀.
#[inline]
fn affine_jacobian(x: &[[f64; 2]; 6]) -> Jacobian {
    Jacobian::new([
        [x[1][0] - x[0][0], x[2][0] - x[0][0]],
        [x[1][1] - x[0][1], x[2][1] - x[0][1]],
    ])
}
