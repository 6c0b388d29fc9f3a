//! Projection of an inadmissible displacement onto K_u (docs/design.md §5):
//!
//! ```text
//! ũ_h = argmin { ½ a(v − u_h, v − u_h) : v ∈ P_k(T_h)², v = u_D at the Dirichlet nodes,
//!                 v_n ≤ g at the contact nodes },
//! ```
//!
//! a(v, w) = ∫ Cε(v) : ε(w) the energy inner product (2μ ε:ε for λ = ∞), on the Lagrange nodes
//! of the mesh. At a contact node v = n (g + z) + t w with z ≤ 0: a bound on a single unknown,
//! solved by [`super::solve::solve_bound_qp`]. The estimate then uses ũ_h, and the computable
//! distance ‖ũ_h − u_h‖_E is added to the error bound by the triangle inequality.
//! Without Dirichlet nodes the energy form has rigid motions in its kernel; a small L² term
//! (μ/ℓ² times the lumped mass) then makes the projection unique.

use super::nodal::{Frames, Tangential, boundary_nodes, distance, stiffness, stiffness_of};
use crate::material::Elastic;
use crate::problem::Context;
use crate::solve::{Lower, SolveInfo, solve_bound_qp_from};
use crate::tolerance::{PROJECTION_LAYERS, PROJECTION_REACH};

/// The projected displacement and what it took.
pub struct Projection {
    pub displacement: Vec<[f64; 2]>,
    /// ‖ũ_h − u_h‖_E.
    pub distance: f64,
    pub info: SolveInfo,
    /// Contact and Dirichlet nodes where u_h was inadmissible before.
    pub violations: usize,
}

/// Nodal admissibility of `u`: the number of Dirichlet nodes off u_D and of contact nodes
/// with n·u > g, beyond `ADMISSIBLE_TOLERANCE` × max |u|.
pub fn nodal_violations(ctx: &Context, u: &[[f64; 2]]) -> usize {
    violating_nodes(ctx, u).len()
}

/// The nodes counted by [`nodal_violations`].
fn violating_nodes(ctx: &Context, u: &[[f64; 2]]) -> Vec<usize> {
    let (mesh, topo, scene, edges) = (ctx.mesh, ctx.topo, ctx.scene, ctx.edges);
    let (dir, con) = boundary_nodes(mesh, topo, scene, edges);
    let tol = crate::estimate::displacement_tolerance(
        crate::field::max_norm(u),
        crate::field::max_norm(&mesh.points),
    );
    let mut out = Vec::new();
    for (p, d) in dir.iter().enumerate() {
        if let Some(ud) = d {
            if (u[p][0] - ud[0]).hypot(u[p][1] - ud[1]) > tol {
                out.push(p);
            }
        } else if let Some((normal, g)) = con[p]
            && normal[0] * u[p][0] + normal[1] * u[p][1] - g > tol
        {
            out.push(p);
        }
    }
    out
}

/// The cells of the local projection: those with a node within D of the box of the violating
/// nodes, D = max(`PROJECTION_REACH` × the box's diagonal, `PROJECTION_LAYERS` × the largest
/// diameter of a cell holding a violating node), or `None` when that is half the mesh or more
/// (then the projection is global).
fn local_cells(ctx: &Context, violating: &[usize]) -> Option<Vec<usize>> {
    let mesh = ctx.mesh;
    let mut bad = vec![false; mesh.points.len()];
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for &p in violating {
        bad[p] = true;
        let x = mesh.points[p];
        for k in 0..2 {
            lo[k] = lo[k].min(x[k]);
            hi[k] = hi[k].max(x[k]);
        }
    }
    let mut h = 0.0f64;
    for t in 0..mesh.len() {
        let nodes = mesh.nodes(t);
        if nodes.iter().any(|&p| bad[p as usize]) {
            let x = mesh.coords(t);
            let f = mesh.family[t];
            h = h.max(crate::geometry::diameter(f, &x[..f.nodes()]));
        }
    }
    let reach =
        (PROJECTION_REACH * (hi[0] - lo[0]).hypot(hi[1] - lo[1])).max(PROJECTION_LAYERS * h);
    let near = |x: [f64; 2]| {
        let dx = (lo[0] - x[0]).max(x[0] - hi[0]).max(0.0);
        let dy = (lo[1] - x[1]).max(x[1] - hi[1]).max(0.0);
        dx.hypot(dy) <= reach
    };
    let cells: Vec<usize> = (0..mesh.len())
        .filter(|&t| mesh.nodes(t).iter().any(|&p| near(mesh.points[p as usize])))
        .collect();
    (2 * cells.len() < mesh.len()).then_some(cells)
}

/// Projects `u` onto K_u in the energy norm; when the violations are confined to a small part
/// of the mesh, over the region around them only (`local_cells`: still an admissible v with
/// its exact distance, never below the global one).
pub fn project(ctx: &Context, u: &[[f64; 2]]) -> Result<Projection, String> {
    project_with(ctx, u, true)
}

/// [`project`], globally when `local` is false.
fn project_with(ctx: &Context, u: &[[f64; 2]], local: bool) -> Result<Projection, String> {
    let (mesh, topo, scene, edges) = (ctx.mesh, ctx.topo, ctx.scene, ctx.edges);
    let length_scale = ctx.length_scale;
    let np = mesh.points.len();
    let el = Elastic::new(&scene.material);
    let (mut dir, mut con) = boundary_nodes(mesh, topo, scene, edges);
    let violating = violating_nodes(ctx, u);
    let violations = violating.len();
    let lambda = if el.lambda.is_finite() {
        el.lambda
    } else {
        0.0
    };
    // Local projection: only the nodes all of whose cells lie in the region around the
    // violations move; the others keep u_h (admissible there). Still an admissible v with its
    // exact distance, at the cost of the region instead of the mesh.
    let region = if local {
        local_cells(ctx, &violating)
    } else {
        None
    };
    let (energy, lumped) = match region {
        Some(cells) => {
            let mut inside = vec![0u32; np];
            let mut total = vec![0u32; np];
            for t in 0..mesh.len() {
                for &p in mesh.nodes(t) {
                    total[p as usize] += 1;
                }
            }
            for &t in &cells {
                for &p in mesh.nodes(t) {
                    inside[p as usize] += 1;
                }
            }
            for p in 0..np {
                if inside[p] < total[p] {
                    dir[p] = Some(u[p]);
                    con[p] = None;
                }
            }
            stiffness_of(mesh, cells.into_iter(), 2.0 * el.mu, lambda)
        }
        None => stiffness(mesh, 2.0 * el.mu, lambda),
    };
    let mut system = energy.clone();
    if !dir.iter().any(Option::is_some) {
        let w = el.mu / (length_scale * length_scale);
        for (p, m) in lumped.iter().enumerate() {
            system.push((2 * p, 2 * p, w * m));
            system.push((2 * p + 1, 2 * p + 1, w * m));
        }
    }
    let kfull = Lower {
        n: 2 * np,
        entries: system,
    };
    let flat: Vec<f64> = u.iter().flatten().copied().collect();
    let f = kfull.apply(&flat);
    let tangential = vec![Tangential::Free; np];
    let frames = Frames::new(&dir, &con, &tangential);
    let (k, b, bounded) = frames.reduce(&kfull, &f, &[], 0.0);
    // The nodes that penetrate go onto the obstacle: start the active set there.
    let guess: Vec<usize> = bounded
        .iter()
        .copied()
        .filter(|&i| {
            let p = i / 2;
            con[p].is_some_and(|(n, g)| n[0] * u[p][0] + n[1] * u[p][1] >= g)
        })
        .collect();
    let (y, info) = solve_bound_qp_from(&k, &b, &bounded, super::stress::MAX_ITERATIONS, &guess)?;
    let v = frames.expand(&y);
    let e = Lower {
        n: 2 * np,
        entries: energy,
    };
    Ok(Projection {
        distance: distance(&e, &v, u),
        displacement: v,
        info,
        violations,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Penetration pushed into two contact nodes of manufactured_frictionless_p2_n32 (u_y
    /// lowered by 1e-4 at x = 0.3125 and 0.328125 on y = 0): both projections give an admissible
    /// field, the local one over a fraction of the cells, and its distance is at least the
    /// global one's (the global projection is the minimum over a larger set) and within 2×.
    #[test]
    fn local_projection_is_admissible_and_close_to_the_global_one() {
        let fx = crate::problem::fixture("manufactured_frictionless_p2_n32");
        let ctx = fx.context(crate::read::scene::Norm::Energy);
        let mut u = fx.displacement();
        assert_eq!(nodal_violations(&ctx, &u), 0);
        let mesh = ctx.mesh;
        for (p, x) in mesh.points.iter().enumerate() {
            if x[1].abs() < 1e-12 && (0.30..=0.33).contains(&x[0]) {
                u[p][1] -= 1e-4;
            }
        }
        let bad = violating_nodes(&ctx, &u);
        assert_eq!(bad.len(), 2, "{bad:?}");
        let cells = local_cells(&ctx, &bad).expect("a local region");
        assert!(
            4 * cells.len() < mesh.len(),
            "{} of {}",
            cells.len(),
            mesh.len()
        );
        let local = project_with(&ctx, &u, true).unwrap();
        let global = project_with(&ctx, &u, false).unwrap();
        for p in [&local, &global] {
            assert_eq!(nodal_violations(&ctx, &p.displacement), 0);
        }
        assert!(global.distance > 0.0);
        assert!(
            local.distance >= global.distance * (1.0 - 1e-9),
            "{} {}",
            local.distance,
            global.distance
        );
        assert!(
            local.distance <= 2.0 * global.distance,
            "{} {}",
            local.distance,
            global.distance
        );
    }
}
