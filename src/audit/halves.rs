//! Bounds whose stress is not the one F uses (docs/design.md §6.2–§6.3): the patch
//! equilibration of u_h for the bound alone, when the file's stress serves F but is not
//! equilibrated, and on meshes with quadrilaterals, on the triangle split of
//! `estimate::halves`, moved back to u_h.

use crate::element::rt::RtOrder;
use crate::estimate::bound::Bound;
use crate::estimate::halves::{SUB_SQUARES, distance, split};
use crate::field::StressField;
use crate::mesh::Dataset;
use crate::problem::Context;

fn refused(why: String) -> Bound {
    Bound {
        statement: format!("no bound: {why}"),
        failed_hypotheses: vec![why],
        ..Default::default()
    }
}

/// The bound of §6.2 for `u` with the patch equilibration of `u` (`order`, then `sweeps`
/// improvement sweeps) as its stress, or the reason there is none.
pub fn patch_bound(ctx: &Context, u: &[[f64; 2]], order: RtOrder, sweeps: usize) -> Bound {
    let mut r = match crate::reconstruct::patch::reconstruct(ctx, u, order) {
        Ok(r) => r,
        Err(why) => return refused(format!("the patch reconstruction failed ({why})")),
    };
    if sweeps > 0 {
        crate::reconstruct::sweep::sweep(ctx, u, &mut r.stress, r.info.weak_symmetry, sweeps);
    }
    // The bound needs the boundary pass (admissibility, complementarity and friction
    // pairings) but not the interior terms of F, which no one reads for this stress.
    let sigma = StressField::Rt(&r.stress);
    let boundary = crate::estimate::boundary::boundary(ctx, u, sigma);
    let pairing = crate::estimate::Terms {
        complementarity: boundary.complementarity.iter().sum(),
        friction: boundary.friction.iter().sum(),
        ..Default::default()
    };
    crate::estimate::bound::bound(ctx, u, sigma, &pairing, &boundary.admissibility)
}

/// The bound for u_h on a mesh with quadrilaterals (design §6.3): [`patch_bound`] for ũ_h on
/// the triangle halves, plus |||ũ_h − u_h|||, with `relative` against ½|||u_h|||². The per-cell
/// contributions are summed over each parent's halves.
pub fn on_halves(
    ctx: &Context,
    data: &Dataset,
    u: &[[f64; 2]],
    order: RtOrder,
    sweeps: usize,
) -> Bound {
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
    let mut b = patch_bound(&sub, &halves.u, order, sweeps);
    if b.terms.is_none() {
        return b;
    }
    let (d, energy) = distance(ctx, &halves, u);
    b.add_halves(d);
    b.set_reference_energy(energy);
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
