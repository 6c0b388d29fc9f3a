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

use super::nodal::{Frames, Tangential, boundary_nodes, distance, stiffness};
use crate::material::Elastic;
use crate::problem::Context;
use crate::solve::{Lower, SolveInfo, solve_bound_qp_from};

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
    let (mesh, topo, scene, edges) = (ctx.mesh, ctx.topo, ctx.scene, ctx.edges);
    let (dir, con) = boundary_nodes(mesh, topo, scene, edges);
    let umax = u
        .iter()
        .fold(0.0f64, |m, v| m.max(v[0].abs()).max(v[1].abs()));
    let tol = crate::estimate::ADMISSIBLE_TOLERANCE * umax;
    let mut n = 0;
    for (p, d) in dir.iter().enumerate() {
        if let Some(ud) = d {
            if (u[p][0] - ud[0]).hypot(u[p][1] - ud[1]) > tol {
                n += 1;
            }
        } else if let Some((normal, g)) = con[p]
            && normal[0] * u[p][0] + normal[1] * u[p][1] - g > tol
        {
            n += 1;
        }
    }
    n
}

/// Projects `u` onto K_u in the energy norm.
pub fn project(ctx: &Context, u: &[[f64; 2]]) -> Result<Projection, String> {
    let (mesh, topo, scene, edges) = (ctx.mesh, ctx.topo, ctx.scene, ctx.edges);
    let length_scale = ctx.length_scale;
    let np = mesh.points.len();
    let el = Elastic::new(&scene.material);
    let (dir, con) = boundary_nodes(mesh, topo, scene, edges);
    let violations = nodal_violations(ctx, u);
    let lambda = if el.lambda.is_finite() {
        el.lambda
    } else {
        0.0
    };
    let (energy, lumped) = stiffness(mesh, 2.0 * el.mu, lambda);
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
