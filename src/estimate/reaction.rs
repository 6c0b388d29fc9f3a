//! The contact force the displacement transmits: its consistent (residual) reaction on Γ_C
//! (docs/design.md §5.8).
//!
//! For the file's u_h, the residual of the elasticity equations at node i and direction a is
//!
//! ```text
//! R_{i,a} = ∫_Ω Cε(u_h) : ∇(φ_i e_a) dx − ∫_Ω f·φ_i e_a dx − ∫_{Γ_N} t·φ_i e_a ds.
//! ```
//!
//! A Galerkin solution of the contact problem (active set, penalty, Nitsche or a mortar
//! method on this mesh) has R_i = 0 at every free node, so for the nodes N_C of the contact
//! edges Σ_{i ∈ N_C} R_i = ∫_{Γ_C} σn ds: the force the solver itself reports as its reaction.
//! The sum does not depend on the basis (it is the residual tested against any discrete
//! function equal to e_a on Γ_C and zero at the other constrained nodes), so a code that
//! writes its P2 field at Lagrange points gives the same figure. The normal force is
//!
//! ```text
//! N = −Σ_{i ∈ N_C} R_i · n_i,
//! ```
//!
//! n_i the contact direction at node i (the obstacle's normal, or the mean of the outward
//! normals of the contact edges at the node): exact for a plane obstacle, within O(h²)·curvature
//! of ∫ −σ_n ds otherwise.
//!
//! Not available (`None`) where it would not be the contact force: an incompressible material
//! (Cε(u_h) is not defined at λ = ∞), or a contact node that also lies on a Dirichlet edge (the
//! Dirichlet reaction would enter the sum).

use rayon::prelude::*;

use crate::geometry::values::interior_table;
use crate::geometry::{CellValuesCache, MAX_NODES, facet_point};
use crate::problem::{Condition, Context};
use crate::quadrature::line_rule_cached;
use crate::read::scene::BoundaryKind;
use crate::tolerance::EDGE_DEGREE;

/// The normal force −Σ R_i·n_i over the contact nodes (see the module documentation), or
/// `None` where the residual is not the contact force.
pub fn contact_normal_force(ctx: &Context, u: &[[f64; 2]]) -> Option<f64> {
    if !ctx.elastic.lambda.is_finite() {
        return None;
    }
    let mesh = ctx.mesh;
    let np = u.len();
    // Contact direction per contact node (summed over the node's contact edges), and the
    // nodes of Dirichlet edges.
    let mut direction = vec![[0.0f64; 2]; np];
    let mut contact = vec![false; np];
    let mut dirichlet = vec![false; np];
    for e in ctx.edges {
        let t = e.cell as usize;
        let family = mesh.family[t];
        let nodes = mesh.nodes(t);
        let x = mesh.coords(t);
        let local = e.local as usize;
        let edge_nodes = family.edge_nodes(local);
        match e.condition {
            Condition::Contact(b) => {
                let BoundaryKind::Contact(c) = &ctx.scene.boundaries[b].kind else {
                    continue;
                };
                for (slot, s) in edge_nodes.iter().zip([0.0, 1.0, 0.5]) {
                    if *slot == usize::MAX {
                        continue;
                    }
                    let p = nodes[*slot] as usize;
                    let fp = facet_point(family, &x[..family.nodes()], local, s);
                    let n = c.direction(fp.normal);
                    direction[p][0] += n[0];
                    direction[p][1] += n[1];
                    contact[p] = true;
                }
            }
            Condition::Dirichlet(_) => {
                for slot in edge_nodes {
                    if slot != usize::MAX {
                        dirichlet[nodes[slot] as usize] = true;
                    }
                }
            }
            _ => {}
        }
    }
    if !contact.iter().any(|&c| c) || contact.iter().zip(&dirichlet).any(|(c, d)| *c && *d) {
        return None;
    }
    for d in direction.iter_mut() {
        let l = d[0].hypot(d[1]);
        if l > 0.0 {
            *d = [d[0] / l, d[1] / l];
        }
    }

    let body_force = ctx.scene.body_force.as_ref();
    let constant_f = body_force.is_none_or(|f| f[0].is_constant() && f[1].is_constant());
    let interior: f64 = (0..mesh.len())
        .into_par_iter()
        .with_min_len(1024)
        .map_init(CellValuesCache::default, |cache, t| {
            let nodes = mesh.nodes(t);
            if !nodes.iter().any(|&p| contact[p as usize]) {
                return 0.0;
            }
            let sh = mesh.shape[t];
            let cv = cache.get(mesh.family[t], sh, |f, sh| {
                interior_table(f, sh, None, constant_f)
            });
            let x = mesh.coords(t);
            cv.reinit(&x[..nodes.len()], sh);
            let mut ue = [[0.0; 2]; MAX_NODES];
            for (k, &p) in nodes.iter().enumerate() {
                ue[k] = u[p as usize];
            }
            let mut sum = 0.0;
            for q in 0..cv.len() {
                let gu = cv.gradient2(q, &ue);
                let sym = 0.5 * (gu[0][1] + gu[1][0]);
                let s = ctx.elastic.stress([gu[0][0], sym, sym, gu[1][1]]);
                let fq = body_force.map_or([0.0; 2], |bf| {
                    let p = cv.x[q];
                    [bf[0].eval(p[0], p[1], 0.0), bf[1].eval(p[0], p[1], 0.0)]
                });
                let phi = cv.phi(q);
                let g = &cv.grad[q];
                for (k, &p) in nodes.iter().enumerate() {
                    let p = p as usize;
                    if !contact[p] {
                        continue;
                    }
                    let n = direction[p];
                    // R_i·n_i = ∫ (σ ∇φ_i − f φ_i)·n_i.
                    let r = [
                        s[0] * g[k][0] + s[1] * g[k][1] - fq[0] * phi[k],
                        s[2] * g[k][0] + s[3] * g[k][1] - fq[1] * phi[k],
                    ];
                    sum += cv.jxw[q] * (r[0] * n[0] + r[1] * n[1]);
                }
            }
            sum
        })
        .sum();

    // Neumann data on edges that touch a contact node: − ∫_E t·φ_i n_i ds.
    let rule = line_rule_cached(EDGE_DEGREE);
    let mut neumann = 0.0;
    for e in ctx.edges {
        let Condition::Neumann(b) = e.condition else {
            continue;
        };
        let BoundaryKind::Neumann { traction } = &ctx.scene.boundaries[b].kind else {
            continue;
        };
        let t = e.cell as usize;
        let family = mesh.family[t];
        let nodes = mesh.nodes(t);
        let local = e.local as usize;
        if !family
            .edge_nodes(local)
            .iter()
            .any(|&s| s != usize::MAX && contact[nodes[s] as usize])
        {
            continue;
        }
        let x = mesh.coords(t);
        for (&r, &w) in rule.points.iter().zip(&rule.weights) {
            let fp = facet_point(family, &x[..family.nodes()], local, r);
            let tv = [
                traction[0].eval(fp.x[0], fp.x[1], 0.0),
                traction[1].eval(fp.x[0], fp.x[1], 0.0),
            ];
            for (k, &p) in nodes.iter().enumerate() {
                let p = p as usize;
                if contact[p] {
                    let n = direction[p];
                    neumann += w * fp.ds * fp.phi[k] * (tv[0] * n[0] + tv[1] * n[1]);
                }
            }
        }
    }
    Some(-(interior - neumann))
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use super::*;
    use crate::problem::BoundaryEdge;
    use crate::read::scene::{Norm, parse_scene};
    use crate::topology;

    /// u = (1e-3x + 2e-3y − 1e-3x² + 5e-4xy + 1e-3y², y(−8e-3 + 1e-3x + 2e-3y)): P2, so the
    /// discrete solution of its own data. The stress C ε(u) is linear: σ = σ0 + σ1 x + σ2 y.
    fn stress_coefficients(el: crate::material::Elastic) -> [[f64; 4]; 3] {
        let eps = |x: f64, y: f64| {
            let g = [
                [1e-3 - 2e-3 * x + 5e-4 * y, 2e-3 + 5e-4 * x + 2e-3 * y],
                [1e-3 * y, -8e-3 + 1e-3 * x + 4e-3 * y],
            ];
            let s = 0.5 * (g[0][1] + g[1][0]);
            el.stress([g[0][0], s, s, g[1][1]])
        };
        let (s0, sx, sy) = (eps(0.0, 0.0), eps(1.0, 0.0), eps(0.0, 1.0));
        let d = |a: [f64; 4], b: [f64; 4]| [a[0] - b[0], a[1] - b[1], a[2] - b[2], a[3] - b[3]];
        [s0, d(sx, s0), d(sy, s0)]
    }

    fn u_at(x: f64, y: f64) -> [f64; 2] {
        [
            1e-3 * x + 2e-3 * y - 1e-3 * x * x + 5e-4 * x * y + 1e-3 * y * y,
            y * (-8e-3 + 1e-3 * x + 2e-3 * y),
        ]
    }

    /// The scene: contact below, the exact traction σn on the other three sides (or a
    /// Dirichlet top), the exact body force f = −div σ.
    fn run(nu: f64, dirichlet_top: bool) -> (Option<f64>, f64) {
        let d = super::super::exact_tests::rectangle(4, 3);
        let t = topology::build(&d).unwrap();
        let probe = parse_scene(
            Path::new("r.toml"),
            &format!("[material]\nyoungs_modulus = 20600.0\npoisson_ratio = {nu}\n"),
        )
        .unwrap();
        let el = crate::material::Elastic::new(&probe.material);
        let [s0, sx, sy] = if el.lambda.is_finite() {
            stress_coefficients(el)
        } else {
            [[0.0; 4]; 3]
        };
        let lin = |k: usize, sign: f64| {
            format!(
                "\"{:e} + {:e}*x + {:e}*y\"",
                sign * s0[k],
                sign * sx[k],
                sign * sy[k]
            )
        };
        // div σ = (∂x σxx + ∂y σxy, ∂x σyx + ∂y σyy), constant.
        let f = [-(sx[0] + sy[1]), -(sx[2] + sy[3])];
        let top = if dirichlet_top {
            "kind = \"dirichlet\"\ndisplacement = [\"1e-3*x + 2e-3 - 1e-3*x*x + 5e-4*x + 1e-3\", \
             \"-8e-3 + 1e-3*x + 2e-3\"]\n"
                .to_string()
        } else {
            format!(
                "kind = \"neumann\"\ntraction = [{}, {}]\n",
                lin(1, 1.0),
                lin(3, 1.0)
            )
        };
        let text = format!(
            "[material]\nyoungs_modulus = 20600.0\npoisson_ratio = {nu}\n\
             [loads]\nbody_force = [{:e}, {:e}]\n\
             [[boundary]]\nname = \"bottom\"\nwhere = \"y < 1e-9\"\nkind = \"contact\"\n\
             obstacle = {{ plane = {{ point = [0.0, -1.0], normal = [0.0, 1.0] }} }}\n\
             normal = \"obstacle\"\n\
             [[boundary]]\nname = \"left\"\nwhere = \"x < 1e-9\"\nkind = \"neumann\"\n\
             traction = [{}, {}]\n\
             [[boundary]]\nname = \"right\"\nwhere = \"x > 2 - 1e-9\"\nkind = \"neumann\"\n\
             traction = [{}, {}]\n\
             [[boundary]]\nname = \"top\"\nwhere = \"y > 1 - 1e-9\"\n{top}",
            f[0],
            f[1],
            lin(0, -1.0),
            lin(2, -1.0),
            lin(0, 1.0),
            lin(2, 1.0),
        );
        let sc = parse_scene(Path::new("r.toml"), &text).unwrap();
        let p = &d.mesh.points;
        let edges: Vec<BoundaryEdge> = t
            .boundary_edges
            .iter()
            .map(|&e| {
                let cell = t.edge_cells[e as usize][0];
                let local = t.cell_edges[cell as usize]
                    .iter()
                    .position(|&x| x == e)
                    .unwrap() as u8;
                let [a, b] = t.edges[e as usize];
                let (pa, pb) = (p[a as usize], p[b as usize]);
                let on = |f: &dyn Fn([f64; 2]) -> bool| f(pa) && f(pb);
                let condition = if on(&|q| q[1] == 0.0) {
                    Condition::Contact(0)
                } else if on(&|q| q[0] == 0.0) {
                    Condition::Neumann(1)
                } else if on(&|q| q[0] == 2.0) {
                    Condition::Neumann(2)
                } else if dirichlet_top {
                    Condition::Dirichlet(3)
                } else {
                    Condition::Neumann(3)
                };
                BoundaryEdge {
                    edge: e,
                    cell,
                    local,
                    line: crate::mesh::NONE,
                    condition,
                }
            })
            .collect();
        let ctx = Context::new(&d.mesh, &t, &sc, &edges, Norm::Energy);
        let u: Vec<[f64; 2]> = p.iter().map(|q| u_at(q[0], q[1])).collect();
        // N = ∫_0^2 −σ_n dx with n = −m = (0, −1), n_Ω = (0, −1): σ_n = σ_yy(x, 0).
        let exact = -(2.0 * s0[3] + 2.0 * sx[3]);
        (contact_normal_force(&ctx, &u), exact)
    }

    #[test]
    fn residual_reaction_is_the_exact_contact_force() {
        let (n, exact) = run(0.28, false);
        let n = n.expect("a reaction");
        assert!(exact.abs() > 10.0, "{exact}");
        assert!(
            ((n - exact) / exact).abs() < 1e-12,
            "reaction {n} against ∫ −σ_yy dx = {exact}"
        );
    }

    #[test]
    fn no_reaction_when_incompressible_and_exact_beside_a_dirichlet_top() {
        // Incompressible: Cε(u) is undefined.
        assert_eq!(run(0.5, false).0, None);
        // A Dirichlet top does not touch the contact nodes: still available, and exact.
        let (n, exact) = run(0.28, true);
        assert!(((n.unwrap() - exact) / exact).abs() < 1e-12);
    }
}
