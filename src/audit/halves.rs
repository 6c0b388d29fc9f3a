//! The bound on meshes with quadrilaterals (docs/design.md §6.3): the patch stress and the
//! bound of §6.2 on the triangle split of `estimate::halves`, moved back to u_h.

use crate::estimate::halves::{SUB_SQUARES, distance, split};
use crate::mesh::Dataset;
use crate::problem::Context;

/// The bound for u_h on a mesh with quadrilaterals (design §6.3): the patch equilibration
/// (`order`, then `sweeps` improvement sweeps) and the bound of §6 for ũ_h on the halves,
/// plus |||ũ_h − u_h|||. `relative` is still against ũ_h's energy: the caller sets u_h's
/// ([`crate::estimate::bound::Bound::set_reference_energy`]). The per-cell contributions are summed
/// over each parent's halves.
pub fn bound(
    ctx: &Context,
    data: &Dataset,
    u: &[[f64; 2]],
    order: crate::element::rt::RtOrder,
    sweeps: usize,
) -> crate::estimate::bound::Bound {
    let refused = |why: String| crate::estimate::bound::Bound {
        statement: format!("no bound: {why}"),
        failed_hypotheses: vec![why],
        ..Default::default()
    };
    let halves = match split(ctx, data, u, SUB_SQUARES) {
        Ok(h) => h,
        Err(why) => return refused(format!("the triangle halves of the mesh: {why}")),
    };
    let mut sub = Context::new(
        &halves.data.mesh,
        &halves.topo,
        ctx.scene,
        &halves.edges,
        ctx.norm,
    );
    sub.length_scale = ctx.length_scale;
    let mut r = match crate::reconstruct::patch::reconstruct(&sub, &halves.u, order) {
        Ok(r) => r,
        Err(why) => {
            return refused(format!(
                "the patch reconstruction on the triangle halves failed ({why})"
            ));
        }
    };
    if sweeps > 0 {
        crate::reconstruct::sweep::sweep(
            &sub,
            &halves.u,
            &mut r.stress,
            r.info.weak_symmetry,
            sweeps,
        );
    }
    let est = crate::estimate::run(&sub, &halves.u, crate::field::StressField::Rt(&r.stress));
    let mut b = est.bound;
    b.add_halves(distance(ctx, &halves, u));
    let mut cells = vec![0.0; ctx.mesh.len()];
    for (s, &c) in b.cells.iter().enumerate() {
        cells[halves.parent[s] as usize] += c;
    }
    b.cells = cells;
    b.statement = format!(
        "{} (taken on the triangle halves of the quadrilaterals, for the P2 interpolant ũ_h of \
         u_h; |||ũ_h − u_h||| added)",
        b.statement
    );
    b
}
