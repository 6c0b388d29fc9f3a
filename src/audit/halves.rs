//! Bounds whose stress is not the one F uses (docs/design.md §6.2–§6.3): the patch
//! equilibration of u_h for the bound alone, when the file's stress serves F but is not
//! equilibrated, and on meshes with quadrilaterals, on the triangle split of
//! `estimate::halves`, moved back to u_h.

use crate::element::rt::RtOrder;
use crate::estimate::bound::Bound;
use crate::estimate::halves::{Pattern, SUB_SQUARES, Shift, distance, split};
use crate::field::StressField;
use crate::geometry::Family;
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
    patch_bounds(ctx, u, order, sweeps, None).0
}

/// [`patch_bound`], and with `shift` also the bound of the same stress for u + `shift`
/// (`estimate::bound::bound_with`).
fn patch_bounds(
    ctx: &Context,
    u: &[[f64; 2]],
    order: RtOrder,
    sweeps: usize,
    shift: Option<&Shift>,
) -> (Bound, Option<Bound>) {
    let mut r = match crate::reconstruct::patch::reconstruct(ctx, u, order) {
        Ok(r) => r,
        Err(why) => {
            return (
                refused(format!("the patch reconstruction failed ({why})")),
                None,
            );
        }
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
    let adm = &boundary.admissibility;
    let plain = crate::estimate::bound::bound(ctx, u, sigma, &pairing, adm);
    let shifted =
        shift.map(|sf| crate::estimate::bound::bound_with(ctx, u, sigma, &pairing, adm, Some(sf)));
    (plain, shifted)
}

/// The bound for u_h on a mesh with quadrilaterals (design §6.3): the least of the bounds
/// `on_split` gives on the cuts worth trying. Each is an upper bound of the same error, so
/// their least is one too; a guaranteed one is preferred to a smaller one that is not. Every
/// mesh is cut into the halves of its quadrilaterals; meshes with Q2 or serendipity cells are
/// also cut into four triangles about each cell's centre when the halves give no guaranteed
/// bound. Paired with u_h itself the four triangles gain little (manufactured Q2 index 1.40 /
/// 1.19 / 1.14 on the halves, 1.32 / 1.17 / 1.14 with them; the Hertz Q2 file 0.01494 against
/// 0.01462) for twice the halves' cost; for the P2 interpolant they gained more (3.06 → 2.00),
/// but that pairing is rarely the smaller now. The Q1 cells keep the halves only (on a
/// parallelogram ũ_h = u_h, and the finer cut raised the manufactured Q1 index at n = 16 from
/// 1.15 to 2.02).
pub fn on_halves(
    ctx: &Context,
    data: &Dataset,
    u: &[[f64; 2]],
    order: RtOrder,
    sweeps: usize,
) -> Bound {
    let quadratic = ctx
        .mesh
        .family
        .iter()
        .any(|f| matches!(f, Family::Quad8 | Family::Quad9));
    let mut best = on_split(ctx, data, u, order, sweeps, Pattern::Lattice(SUB_SQUARES));
    if quadratic && !best.guaranteed {
        let cross = on_split(ctx, data, u, order, sweeps, Pattern::Cross);
        if better(&cross, &best) {
            best = cross;
        }
    }
    best
}

/// Whether bound `a` is to be reported rather than `b`: guaranteed where `b` is not, else
/// computable and smaller (of the same guarantee).
fn better(a: &Bound, b: &Bound) -> bool {
    match (a.energy_error, b.energy_error) {
        (Some(_), None) => true,
        (None, _) => false,
        (Some(ea), Some(eb)) => {
            if a.guaranteed != b.guaranteed {
                a.guaranteed
            } else {
                ea < eb
            }
        }
    }
}

/// [`patch_bound`] for ũ_h on the triangle split `pattern` of the mesh, plus |||ũ_h − u_h|||,
/// with `relative` against ½|||u_h|||². The per-cell contributions are summed over each
/// parent's triangles.
fn on_split(
    ctx: &Context,
    data: &Dataset,
    u: &[[f64; 2]],
    order: RtOrder,
    sweeps: usize,
    pattern: Pattern,
) -> Bound {
    let halves = match split(ctx, &data.path, u, pattern) {
        Ok(h) => h,
        Err(why) => return refused(format!("the triangle split of the mesh: {why}")),
    };
    let mut sub = Context::new(
        &halves.data.mesh,
        &halves.topo,
        ctx.scene,
        &halves.edges,
        ctx.norm,
    );
    sub.length_scale = ctx.length_scale;
    let shift = Shift::new(ctx.mesh, &halves, u);
    // Where ũ_h = u_h (Q1 parallelograms) the direct pairing is the same bound.
    let direct = (!shift.vanishes()).then_some(&shift);
    let (mut b, direct) = patch_bounds(&sub, &halves.u, order, sweeps, direct);
    if b.terms.is_none() {
        return b;
    }
    let (d, energy) = distance(ctx, &shift);
    b.add_halves(d);
    let cut = match pattern {
        Pattern::Cross => "the four triangles about each quadrilateral's centre",
        Pattern::Lattice(_) => "the triangle halves of the quadrilaterals",
    };
    b.statement = format!(
        "{} (taken on {cut}, for the P2 interpolant ũ_h of u_h; |||ũ_h − u_h||| added)",
        b.statement
    );
    // The same stress paired with u_h itself (design §6.3, "u_h itself"): no distance to add.
    if let Some(mut direct) = direct
        && direct.terms.is_some()
    {
        direct.statement = format!(
            "{} (the stress equilibrated on {cut}, paired with u_h itself)",
            direct.statement
        );
        if better(&direct, &b) {
            b = direct;
        }
    }
    b.set_reference_energy(energy);
    let mut cells = vec![0.0; ctx.mesh.len()];
    for (s, &c) in b.cells.iter().enumerate() {
        cells[halves.parent[s] as usize] += c;
    }
    b.cells = cells;
    b
}
