//! Equilibrated stress reconstruction on vertex patches (docs/design.md §5.10; Braess–Schöberl
//! 2008, Ern–Vohralík 2015 for the patch problems, Bertrand–Kober–Moldenhauer–Starke 2021 for
//! the weak symmetry of elasticity).
//!
//! With ψ_a the P1 hat function of vertex a (the barycentric coordinate of the cell's reference
//! map, so Σ_a ψ_a = 1 on every cell, curved ones too) and ω_a its patch, each patch solves
//!
//! ```text
//! σ_a = argmin ½‖τ − ψ_a Cε*‖²_A + ⟨τ_n, ψ_a (u_n − g)⟩_{Γ_C ∩ ∂ω_a}
//!   over τ ∈ RT_k(ω_a)² row-wise with
//!   (div τ, q)_T = (−ψ_a f + Cε(u_h)∇ψ_a, q)_T     for q ∈ P_k(T̂) ∘ F_T⁻¹, every T ⊂ ω_a,
//!   ∫_T as τ q = 0 on every T for q ∈ P_1 with RT_2 (weak symmetry; the constant moment is
//!   the rotation share α_{a,T} on P1 meshes, design §5.10),
//!   τn = 0 on ∂ω_a inside Ω, τn|x'| = Π_k(ψ_a t|x'|) on Γ_N and free edges (t = 0),
//!   τn free on Γ_D, and on Γ_C τ_t = 0, τ_n ≤ 0 (frictionless) or |τ_t| ≤ −𝔉τ_n (Coulomb),
//! ```
//!
//! with ε* the recovered strain of `recovered_strain` (the target only: the loads keep
//! Cε(u_h)), and σ_h = Σ_a σ_a. Since Σ_a ψ_a = 1 and Σ_a ∇ψ_a = 0, div σ_h = −Π_k f in every
//! cell (on curved cells in the reference moments), σ_h n = Π_k t on Γ_N, and the contact
//! constraints hold for the sum because they hold for every summand (cones are convex). Each
//! patch problem is solvable exactly when u_h satisfies the discrete equations tested with
//! ψ_a e_r (and, for the weak symmetry, ψ_a × the rotation field): true for any Galerkin
//! solution; otherwise the constraints are met in the least-squares sense and the defect is
//! reported.
//!
//! The contact sign constraints on RT_2 edges are imposed on the Bernstein coefficients of the
//! quadratic flux (non-positive Bernstein coefficients ⇒ non-positive on the whole edge); on
//! RT_1 the Bernstein coefficients are the end values.
//!
//! Every patch is an independent dense QP (a few dozen to ~150 unknowns), solved by
//! [`qp::solve`]: the equality constraints orthonormalised once (modified Gram–Schmidt,
//! dependent rows dropped) and eliminated through the Schur complement, then the
//! Goldfarb–Idnani dual active-set method on the sign-constrained variables (finite).
//!
//! After the balancing flows, every patch is solved once more with its final loads, colour by
//! colour of a vertex colouring, against the sum of the colours before it (the target becomes
//! Ψ_a Cε* − σ_prior with Ψ_a the hats of the vertices done and of a; design §5.10,
//! "Colour-ordered solves"). Patches of one colour share no cell and run in parallel (rayon),
//! the colours one after the other, so the result does not depend on the thread count.

use std::sync::atomic::{AtomicU64, Ordering::Relaxed};

use rayon::prelude::*;

use super::condense::{self, MAX_EDGE_DOFS, MAX_MOMENTS, MAX_REDUCED};
use super::flow;
use crate::element::rt::{self, MAX_RT_DOFS, RtOrder};
pub use crate::field::RtStress;
use crate::geometry::Family;
use crate::geometry::Shape;
use crate::geometry::values::{
    SubPoint, TriangleTable, rule_degree, sub_edge_point, sub_jacobian, sub_point,
};
use crate::mesh::{Mesh, NONE};
use crate::problem::{Condition, Context};
use crate::quadrature::{line_rule_cached, triangle_rule_cached};
use crate::read::scene::BoundaryKind;
use crate::tolerance::{
    EDGE_DEGREE, EDGE_OPEN_SAMPLES, FLOW_PASS_DEFECT, FLOW_PASSES, KERNEL_ELIMINATION_CONDITION,
    KERNEL_PIVOT_RELATIVE, LOAD_DEFECT_FLOOR, LOAD_DEGREE, MIN_CONE_FRICTION, OPEN_GAP_RELATIVE,
    PATCH_DEFECT_RELATIVE, PATCH_DEPENDENT_ROW,
};

use super::qp;

/// What the patch reconstruction reports besides the stress.
#[derive(Clone, Debug, Default)]
pub struct PatchInfo {
    pub patches: usize,
    /// Largest number of unknowns of one patch.
    pub max_unknowns: usize,
    /// Sign-constrained contact variables active (= 0) at the end, over all patches.
    pub active: usize,
    /// Patches whose active set did not settle within the cap.
    pub unsettled: usize,
    /// Patches whose equality constraints could not be met (u_h is not a Galerkin solution of
    /// this problem there, or they are incompatible with the contact sign constraints), and the
    /// largest relative defect.
    pub incompatible: usize,
    pub max_defect: f64,
    /// Whether ∫_T as σ_h = 0 was imposed (P2 displacements).
    pub weak_symmetry: bool,
    /// Patches that could not meet the P_1 weak-symmetry rows and were solved without them
    /// (their cells keep the constant weak symmetry only; design §5.10).
    pub p1_symmetry_dropped: usize,
    /// Whether the patch loads were rebalanced by flows between patches (flow.rs): the file's
    /// displacement was not the Galerkin solution of this discrete problem.
    pub balanced: bool,
    /// The largest force defect ∫ψ_a(f·e_r) + … of the patches without Dirichlet or contact
    /// edges, relative to its terms, before any flow: round-off for a Galerkin solution
    /// (tested with ψ_a e_r, in the space for every degree), the size of the residual otherwise
    /// (sfepy's vertex-only P2 file: see `tolerance::GALERKIN_DEFECT_RELATIVE`).
    pub load_defect: f64,
    /// What the improvement sweeps did (`sweep.rs`), when they ran.
    pub sweeps: super::sweep::SweepInfo,
    /// Wall seconds per step of [`reconstruct`], in the order of design §5.10 (the flow steps
    /// summed over the passes), for the benchmark's stage table.
    pub stages: Vec<(&'static str, f64)>,
}

/// The result.
pub struct Reconstruction {
    pub stress: RtStress,
    pub info: PatchInfo,
}

/// An affine expression Σ c_j x_j + c₀ in the patch unknowns, on the stack: at most 6 terms
/// (a contact slot of RT_2: 3 Bernstein coefficients × 2 variables).
#[derive(Clone, Copy, Debug, Default)]
struct Lin {
    terms: [(u32, f64); 6],
    n: u8,
    c: f64,
}

impl Lin {
    fn push(&mut self, var: usize, coef: f64) {
        self.terms[self.n as usize] = (var as u32, coef);
        self.n += 1;
    }

    fn terms(&self) -> &[(u32, f64)] {
        &self.terms[..self.n as usize]
    }

    fn value(&self, x: &[f64]) -> f64 {
        self.terms().iter().map(|&(v, c)| c * x[v as usize]).sum()
    }
}

/// Bernstein-to-point-value matrix of the edge slots: value at slot i = Σ_j B_ij b_j.
fn bernstein(order: RtOrder) -> &'static [[f64; 3]] {
    match order.edge_dofs() {
        1 => &[[1.0, 0.0, 0.0]],
        2 => &[[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
        _ => &[[1.0, 0.0, 0.0], [0.25, 0.5, 0.25], [0.0, 0.0, 1.0]],
    }
}

/// Coefficients of Π_k g on [0, 1] in point values at `points`, from samples of g at a Gauss
/// rule: the L² projection onto the Legendre polynomials of degree ≤ k, evaluated.
fn project_points(k: usize, points: &[f64], g: impl Fn(f64) -> f64) -> [f64; 3] {
    let lr = line_rule_cached(EDGE_DEGREE);
    let leg = |j: usize, s: f64| match j {
        0 => 1.0,
        1 => 2.0 * s - 1.0,
        _ => 6.0 * s * s - 6.0 * s + 1.0,
    };
    let mut c = [0.0; 3];
    for (&s, &w) in lr.points.iter().zip(&lr.weights) {
        let v = g(s);
        for (j, cj) in c.iter_mut().enumerate().take(k + 1) {
            *cj += w * v * leg(j, s);
        }
    }
    let mut out = [0.0; 3];
    for (i, &s) in points.iter().enumerate() {
        out[i] = (0..=k).map(|j| c[j] * (2 * j + 1) as f64 * leg(j, s)).sum();
    }
    out
}

/// The RT order of the patch reconstruction without `--degree`: RT_2 for every displacement
/// degree. On P2 it is RT_p (ψ_a Cε(u_h) has degree p, so RT_p reproduces an exact stress); on
/// P1 it is one more than needed for exactness, for the weak symmetry with the rotation shares
/// of the P1 patches (`rotation_shares`), which makes every cell exactly symmetric: on the
/// manufactured P1 family the index went 4.81 / 4.04 / 3.81 / 3.71 (RT_1, Korn asymmetry term)
/// → 3.08 / 2.33 / 1.75 / 1.56 (design §5.10). With RT_1 the weak symmetry made it worse
/// (4.54 … 4.11): too few free values per cell to be symmetric and equilibrated.
pub fn default_order(_p: usize) -> RtOrder {
    RtOrder::Rt2
}

/// The RT order asked for with `--degree p`: RT_1 for p ≤ 1 (k ≥ 1 keeps the rigid motions in
/// the moments), RT_2 for p ≥ 2, the highest order available.
pub fn order_for_degree(p: usize) -> RtOrder {
    if p >= 2 { RtOrder::Rt2 } else { RtOrder::Rt1 }
}

/// Reconstructs σ_h patch by patch (module doc). Triangle meshes only; λ < ∞.
pub fn reconstruct(
    ctx: &Context,
    u: &[[f64; 2]],
    order: RtOrder,
) -> Result<Reconstruction, String> {
    let mesh = ctx.mesh;
    let mut stages = Stages::default();
    if mesh.family.iter().any(|f| f.is_quad()) {
        return Err(
            "the patch reconstruction is implemented for triangle meshes only \
                    (quadrilateral cells: use --stress global)"
                .into(),
        );
    }
    if ctx.elastic.lambda.is_infinite() {
        return Err(
            "the patch reconstruction needs λ < ∞ (ν < 0.5): at ν = 0.5 Cε(u_h) is \
                    undefined"
                .into(),
        );
    }
    if order.k() == 0 {
        return Err("the patch reconstruction needs RT_k with k ≥ 1".into());
    }
    let topo = ctx.topo;
    let mut condition: Vec<Option<Condition>> = vec![None; topo.edges.len()];
    // OPEN_GAP_RELATIVE of max |u_h| on the contact edges: a gap that counts as open.
    let gap_tolerance = OPEN_GAP_RELATIVE
        * ctx
            .edges
            .iter()
            .filter(|be| matches!(be.condition, Condition::Contact(_)))
            .flat_map(|be| mesh.nodes(be.cell as usize).iter().copied())
            .fold(0.0f64, |m, n| {
                m.max(u[n as usize][0].hypot(u[n as usize][1]))
            });
    for be in ctx.edges {
        // A contact edge where u_h is open at every sample carries no traction: it is
        // solved as traction-free, so that a patch's load defect (another quadrature of the
        // file's solver, on curved cells) is moved by the flows instead of being carried by a
        // pressure on the open gap, which the complementarity pairing pays at the full gap
        // (hertz_skfem_p2: c = 6.5e-4 from τ_n ≈ −5e-3 along the whole open arc).
        let open = matches!(be.condition, Condition::Contact(_))
            && contact_edge_is_open(ctx, u, be, gap_tolerance);
        condition[be.edge as usize] = Some(if open { Condition::Free } else { be.condition });
    }
    let npts = mesh.points.len();
    let (count, members) = vertex_patches(mesh);
    // P1 patches with RT_2 keep the weak symmetry too, with the cell shares of their rotation
    // moments as the symmetry rows' right-hand sides (`rotation_shares`): ψ_a ρ₃ is not in the
    // P1 space, so ∫_T as τ_a = 0 would make most P1 patches infeasible.
    let weak_symmetry = mesh.degree >= 2 || order.k() >= 2;
    let vertices: Vec<usize> = (0..npts).filter(|&v| count[v + 1] > count[v]).collect();
    // Rotation moments about one point for all patches (the flows compare them): the mean of
    // the points, and per unit of the largest distance from it, so that a rotated or moved
    // mesh gets the same flows (the flows are orthogonal projections in the moment space
    // (e_x, e_y, (x − x₀)^⊥/L), which a frame-dependent x₀ or L would skew: the Hertz P1 file
    // turned by 107° about the origin had one contact patch with another active set, and its
    // bound moved by 1e-4 of itself, with the bounding box's centre and half-width).
    let origin = {
        let n = mesh.points.len().max(1) as f64;
        let s = mesh
            .points
            .iter()
            .fold([0.0; 2], |s, p| [s[0] + p[0], s[1] + p[1]]);
        [s[0] / n, s[1] / n]
    };
    let length = mesh
        .points
        .iter()
        .map(|p| (p[0] - origin[0]).hypot(p[1] - origin[1]))
        .fold(0.0f64, f64::max)
        .max(f64::MIN_POSITIVE);
    let recovered = recovered_strain(mesh, u);
    let varying_force = ctx
        .scene
        .body_force
        .as_ref()
        .is_some_and(|f| !(f[0].is_constant() && f[1].is_constant()));
    let tables = RuleTable::build(mesh, order, varying_force);
    let setup = PatchSetup {
        prior: None,
        form: condense::objective_form(&ctx.elastic, weak_symmetry),
        tables: &tables,
        varying_force,
        order,
        condition: &condition,
        weak_symmetry,
        origin,
        length,
        recovered: &recovered,
    };
    // `balance_only`: patches whose balance is independent of the solution only give it in the
    // passes (the flows need nothing else); every patch is solved with its final loads after
    // the passes, colour by colour.
    let solve_with = |setup: &PatchSetup, i: usize, extra: &[Extra], balance_only: bool| {
        let v = vertices[i];
        let range = count[v] as usize..count[v + 1] as usize;
        let ex = extra.get(range.clone()).unwrap_or(&[]);
        solve_patch(ctx, u, setup, v as u32, &members[range], ex, balance_only)
    };
    let solve_one =
        |i: usize, extra: &[Extra], balance_only: bool| solve_with(&setup, i, extra, balance_only);
    // The flow loads, one per patch and cell (the slots of `members`), summed over the passes;
    // on P1 with the weak symmetry they start with the cell shares of the rotation moments.
    let mut extra: Vec<Extra> = vec![[0.0; 4]; members.len()];
    if weak_symmetry && mesh.degree == 1 {
        let stress = p1_cell_stresses(ctx, u);
        let shares: Vec<[f64; 3]> = (0..mesh.len())
            .into_par_iter()
            .with_min_len(256)
            .map(|t| rotation_shares(ctx, u, &stress, &condition, gap_tolerance, t))
            .collect();
        for (t, sh) in shares.iter().enumerate() {
            for (j, &v) in mesh.nodes(t)[..3].iter().enumerate() {
                let range = count[v as usize] as usize..count[v as usize + 1] as usize;
                if let Some(slot) = members[range.clone()].iter().position(|m| m.0 == t as u32) {
                    extra[range.start + slot][3] = sh[j];
                }
            }
        }
    }
    // What each patch cannot take (flow.rs's Q_a) follows from its kind alone, so it is known
    // before any solve.
    let mut q = vec![[[0.0; 3]; 3]; npts];
    for &v in &vertices {
        let range = count[v] as usize..count[v + 1] as usize;
        q[v] = cannot_take(
            touches_dirichlet(ctx, &condition, &members[range]),
            weak_symmetry,
        );
    }
    let balance_pass = |range: std::ops::Range<usize>| -> Vec<PatchOut> {
        range
            .into_par_iter()
            .with_min_len(64)
            .map(|i| solve_one(i, &extra, true))
            .collect()
    };
    let needs_flow = |(o, &v): (&PatchOut, &usize)| {
        (o.defect > FLOW_PASS_DEFECT || !o.feasible) && q[v] != [[0.0; 3]; 3]
    };
    // Q is the same in every pass (it depends on the patch kinds only): one factorisation.
    let mut flow_cache = flow::FlowCache::default();
    // One patch that needs the flows starts them (the loop below), and their factorisation
    // depends on the graph and Q only: when the first FLOW_SAMPLE patches have one, it runs
    // beside the other patches' balance instead of after it (1M P2 bench: ≈ 4 s of a serial
    // stage). Otherwise nothing is started that may not be needed.
    stages.lap("setup");
    let first = vertices.len().min(FLOW_SAMPLE);
    let mut outs = balance_pass(0..first);
    if outs.iter().zip(&vertices).any(needs_flow) {
        let (rest, ()) = rayon::join(
            || balance_pass(first..vertices.len()),
            || flow::prepare(&topo.edges, &q, &mut flow_cache),
        );
        outs.extend(rest);
    } else {
        outs.extend(balance_pass(first..vertices.len()));
    }
    stages.lap("balance pass");
    // Each closed patch's force defect relative to its loads, but to no less than
    // LOAD_DEFECT_FLOOR × the largest patch's: where the loads themselves are at the solver's
    // residual level the ratio is 1 whatever the solver did.
    let largest = outs.iter().fold(0.0f64, |m, o| m.max(o.balance_scale));
    let load_defect = outs
        .iter()
        .zip(&vertices)
        .filter(|&(o, &v)| !o.solved && q[v] != [[0.0; 3]; 3])
        .map(|(o, _)| {
            relative_balance(
                [o.balance[0], o.balance[1], 0.0],
                o.balance_scale.max(LOAD_DEFECT_FLOOR * largest),
            )
        })
        .fold(0.0f64, f64::max);
    // Patches whose constraints are not met leave rigid-motion moments e_a: move them to the
    // patches that take them (flow.rs), and solve again; a pass can change active sets, so the
    // residual of the new solution is balanced again, up to FLOW_PASSES times while a defect is
    // above FLOW_PASS_DEFECT (design §5.10, step 4).
    let mut passes = 0;
    while passes < FLOW_PASSES && outs.iter().zip(&vertices).any(needs_flow) {
        let mut d = vec![[0.0; 3]; npts];
        for (o, &v) in outs.iter().zip(&vertices) {
            d[v] = o.balance;
        }
        let p = flow::potentials_cached(&topo.edges, &q, &d, &mut flow_cache);
        stages.lap("flow potentials");
        // The moments of this pass' loads per patch: −(p_a − p_b) on a, + on b (flow.rs).
        // Each edge's load and the patch slots of its cells are found in parallel, a chunk of
        // edges at a time (the quadrature and the slot searches were a serial step: 2.3 s of a
        // 1M P2 run), and added in the edges' order (`add_moves`).
        let mut shift = vec![[0.0; 3]; npts];
        for start in (0..topo.edges.len()).step_by(LOAD_CHUNK) {
            let end = (start + LOAD_CHUNK).min(topo.edges.len());
            let loads: Vec<EdgeMoves> = (start..end)
                .into_par_iter()
                .with_min_len(256)
                .filter_map(|e| {
                    edge_moves(
                        ctx,
                        &p,
                        e,
                        weak_symmetry,
                        length,
                        origin,
                        (&count, &members),
                    )
                })
                .collect();
            stages.lap("flow loads");
            add_moves(&loads, &topo.edges, &mut extra, &mut shift);
            stages.lap("flow loads added");
        }
        // A patch that only gave its balance: that balance is linear in the load, and the
        // loads h_E have the moments the flows gave them (edge_load), so it moves by `shift`
        // (exact on its straight cells, up to round-off). The others are solved again.
        let again: Vec<(usize, PatchOut)> = outs
            .par_iter()
            .enumerate()
            .with_min_len(16)
            .filter(|(_, o)| o.solved)
            .map(|(i, _)| (i, solve_one(i, &extra, true)))
            .collect();
        for (o, &v) in outs.iter_mut().zip(&vertices) {
            if !o.solved {
                for (bc, sc) in o.balance.iter_mut().zip(shift[v]) {
                    *bc += sc;
                }
                o.defect = relative_balance(o.balance, o.balance_scale);
            }
        }
        for (i, o) in again {
            outs[i] = o;
        }
        passes += 1;
        stages.lap("flow re-solves");
    }
    // The factors and Q are not needed by the final solves (≈ 0.6 GiB at 1M P2 cells).
    drop(flow_cache);
    drop(q);
    // Every patch solved with the final loads, colour by colour of a vertex colouring (patches
    // of one colour share no cell, so each colour runs in parallel and the result does not
    // depend on the thread count), each against the stress of the colours before it: patch a
    // minimises ‖σ_prior + τ − Ψ_a Cε*‖² with Ψ_a the sum of the hats of the vertices done and
    // of a (design §5.10, "Colour-ordered solves"). The first colour is the plain ψ_a problem;
    // the last sees the whole sum, as a sweep step does. Per colour in chunks whose
    // coefficients are summed at once (a million patches' cell lists would be ~0.7 GiB).
    let balanced = passes > 0;
    // The cell coefficients as bits: a patch adds its cells' coefficients in the parallel
    // solve itself, since the patches of one colour share no cell (each cell gets one
    // addition per colour, in colour order, so the sums do not depend on the thread count).
    // The serial merge of the returned cell lists it replaces was 0.75–1.7 s of a 1M P2 run
    // (a million lists freed on the main thread). Relaxed order suffices: a colour's reads
    // and writes of a cell are by one patch, and rayon's join orders the colours.
    let coefficients: Vec<CellBits> = (0..mesh.len())
        .map(|_| std::array::from_fn(|_| std::array::from_fn(|_| AtomicU64::new(0))))
        .collect();
    let mut done = vec![false; npts];
    let mut index = vec![usize::MAX; npts];
    for (i, &v) in vertices.iter().enumerate() {
        index[v] = i;
    }
    for group in colour_vertices(mesh, &count, &members, boundary_hint(ctx)) {
        let ids: Vec<usize> = group.iter().map(|&v| index[v]).collect();
        for chunk in ids.chunks(FINAL_CHUNK) {
            let finals: Vec<(PatchOut, bool)> = {
                let with_prior = PatchSetup {
                    prior: Some(Prior {
                        coefficients: &coefficients,
                        done: &done,
                    }),
                    ..setup
                };
                let outs = &outs;
                let coefficients = &coefficients;
                chunk
                    .par_iter()
                    .with_min_len(64)
                    .map(|&i| {
                        let mut o = solve_with(&with_prior, i, &extra, false);
                        // A patch solved in the passes (contact or curved) already has a
                        // solution with these loads: keep it when the colour-ordered solve met
                        // its constraints worse (the dual active-set method's infeasibility
                        // test depends on the objective through round-off: a Coulomb Hertz
                        // file evaluated without friction had one contact patch declared
                        // infeasible, with tangential traction left).
                        let old = &outs[i];
                        let keep_old = old.solved && worse(&o, old);
                        let cells = if keep_old { &old.cells } else { &o.cells };
                        for (t, c) in cells {
                            let bits = &coefficients[*t as usize];
                            for r in 0..2 {
                                for (b, cj) in bits[r].iter().zip(c[r]) {
                                    let sum = f64::from_bits(b.load(Relaxed)) + cj;
                                    b.store(sum.to_bits(), Relaxed);
                                }
                            }
                        }
                        o.cells = Vec::new();
                        (o, keep_old)
                    })
                    .collect()
            };
            stages.lap("final solves");
            for (&i, (o, keep_old)) in chunk.iter().zip(finals) {
                if keep_old {
                    outs[i].cells = Vec::new();
                } else {
                    outs[i] = o;
                }
            }
            stages.lap("final merge");
        }
        for &v in &group {
            done[v] = true;
        }
    }
    // In place (same size and alignment): no second copy of the coefficients.
    let coefficients: Vec<[[f64; MAX_RT_DOFS]; 2]> = coefficients
        .into_iter()
        .map(|c| c.map(|row| row.map(|b| f64::from_bits(b.into_inner()))))
        .collect();
    let mut info = PatchInfo {
        patches: outs.len(),
        weak_symmetry,
        balanced,
        load_defect,
        ..Default::default()
    };
    for o in outs {
        info.max_unknowns = info.max_unknowns.max(o.unknowns);
        info.active += o.active;
        info.unsettled += usize::from(!o.settled);
        info.p1_symmetry_dropped += usize::from(o.dropped_higher);
        if o.defect > PATCH_DEFECT_RELATIVE || !o.feasible {
            info.incompatible += 1;
        }
        info.max_defect = info.max_defect.max(o.defect);
    }
    stages.lap("summary");
    info.stages = stages.seconds;
    let first = (0..=mesh.len() as u32).collect();
    Ok(Reconstruction {
        stress: RtStress {
            order,
            coefficients,
            first,
        },
        info,
    })
}

/// What one edge moves in a flow pass (`edge_moves`).
struct EdgeMoves {
    edge: usize,
    /// p_a − p_b, the moments taken from a and given to b.
    moment: [f64; 3],
    /// Per cell of the edge (the first `cells`), its slot in the patch lists (`members`) of a
    /// and of b.
    slots: [[Option<u32>; 2]; 2],
    cells: usize,
    /// With the weak symmetry, the rotation moment's share per cell, moved through the
    /// symmetry rows instead of a load.
    asym_share: Option<f64>,
    /// The load of the other moments on the cells (`edge_load`; the first `cells`), None
    /// when it has none.
    load: Option<[EdgeLoad; 2]>,
}

/// The moves of edge `e` = (a, b) for potentials `p` (flow.rs): None when p_a = p_b.
/// `patches`: the vertex patches' offsets and cell lists ([`vertex_patches`]).
fn edge_moves(
    ctx: &Context,
    p: &[[f64; 3]],
    e: usize,
    weak_symmetry: bool,
    length: f64,
    origin: [f64; 2],
    (count, members): (&[u32], &[(u32, u8)]),
) -> Option<EdgeMoves> {
    let [a, b] = ctx.topo.edges[e];
    let moment = [
        p[a as usize][0] - p[b as usize][0],
        p[a as usize][1] - p[b as usize][1],
        p[a as usize][2] - p[b as usize][2],
    ];
    if moment == [0.0; 3] {
        return None;
    }
    let y = [moment[0], moment[1], moment[2] * length];
    // The edge's cells, on the stack (this runs for every edge of every pass).
    let mut both = [0u32; 2];
    let mut n = 0;
    for &c in ctx.topo.edge_cells[e].iter().filter(|&&c| c != NONE) {
        both[n] = c;
        n += 1;
    }
    let cells = &both[..n];
    let (y, asym_share) = if weak_symmetry && !cells.is_empty() {
        ([y[0], y[1], 0.0], Some(y[2] / cells.len() as f64))
    } else {
        (y, None)
    };
    let load = edge_load(ctx, cells, y, origin);
    let slot = |vertex: u32, t: u32| -> Option<u32> {
        let range = count[vertex as usize] as usize..count[vertex as usize + 1] as usize;
        members[range.clone()]
            .iter()
            .position(|m| m.0 == t)
            .map(|k| (range.start + k) as u32)
    };
    let mut slots = [[None; 2]; 2];
    for (s, &t) in slots.iter_mut().zip(cells) {
        *s = [slot(a, t), slot(b, t)];
    }
    Some(EdgeMoves {
        edge: e,
        moment,
        slots,
        cells: n,
        asym_share,
        load,
    })
}

/// Adds a chunk of edge moves to the patch loads `extra` and the balance shifts, in the edges'
/// order (so the sums do not depend on the thread count). Serial on purpose: a split over
/// vertex ranges, each range scanning the chunk's moves in parallel, was no faster at 1M P2
/// cells (0.9 s against 0.8–1.2 s: scattered accesses to memory) and 2.5× slower at 100k.
/// With the weak symmetry a rotation moment moves through the symmetry rows: patch a's cells
/// of E get ∫_T as τ_a = +y₂/|cells|, b's the opposite, so every cell's sum stays 0 and div σ_h
/// is untouched (no body load to carry).
fn add_moves(moves: &[EdgeMoves], edges: &[[u32; 2]], extra: &mut [Extra], shift: &mut [[f64; 3]]) {
    for mv in moves {
        let [a, b] = edges[mv.edge];
        let slots = &mv.slots[..mv.cells];
        if let Some(share) = mv.asym_share {
            for slots in slots {
                for (slot, sign) in slots.iter().zip([1.0, -1.0]) {
                    if let Some(slot) = slot {
                        extra[*slot as usize][3] += sign * share;
                    }
                }
            }
        }
        let Some(h) = &mv.load else {
            continue;
        };
        for (&(_, c, from_centre), slots) in h[..mv.cells].iter().zip(slots) {
            // c₂(x − x̄)^⊥ = c₂(x − x_T)^⊥ + c₂(x_T − x̄)^⊥ about the cell's anchor x_T.
            let c = [
                c[0] - c[2] * from_centre[1],
                c[1] + c[2] * from_centre[0],
                c[2],
            ];
            // Taken from a, given to b.
            for (slot, sign) in slots.iter().zip([-1.0, 1.0]) {
                let Some(slot) = slot else {
                    continue;
                };
                for (e, ci) in extra[*slot as usize].iter_mut().zip(c) {
                    *e += sign * ci;
                }
            }
        }
        for (c, mc) in mv.moment.iter().enumerate() {
            shift[a as usize][c] -= mc;
            shift[b as usize][c] += mc;
        }
    }
}

/// Wall time per named step, summed over repeated laps of one name.
struct Stages {
    clock: std::time::Instant,
    seconds: Vec<(&'static str, f64)>,
}

impl Default for Stages {
    fn default() -> Self {
        Stages {
            clock: std::time::Instant::now(),
            seconds: Vec::new(),
        }
    }
}

impl Stages {
    /// Adds the time since the last lap to `name`.
    fn lap(&mut self, name: &'static str) {
        let now = std::time::Instant::now();
        let dt = (now - self.clock).as_secs_f64();
        self.clock = now;
        match self.seconds.iter_mut().find(|(n, _)| *n == name) {
            Some((_, s)) => *s += dt,
            None => self.seconds.push((name, dt)),
        }
    }
}

/// Whether solution `new` of a patch meets its constraints worse than `old` of the same patch
/// and loads: infeasible or unsettled where `old` was not, or a defect above both
/// `PATCH_DEFECT_RELATIVE` and `old`'s.
fn worse(new: &PatchOut, old: &PatchOut) -> bool {
    (old.feasible && !new.feasible)
        || (old.settled && !new.settled)
        || new.defect > old.defect.max(PATCH_DEFECT_RELATIVE)
}

/// Vertex patches in CSR form: the cells of vertex v, each with v's local index, are
/// `members[count[v]..count[v + 1]]`.
pub(super) fn vertex_patches(mesh: &Mesh) -> (Vec<u32>, Vec<(u32, u8)>) {
    let npts = mesh.points.len();
    let mut count = vec![0u32; npts + 1];
    for t in 0..mesh.len() {
        for &v in &mesh.nodes(t)[..3] {
            count[v as usize + 1] += 1;
        }
    }
    for i in 0..npts {
        count[i + 1] += count[i];
    }
    let mut fill = count.clone();
    let mut members = vec![(0u32, 0u8); count[npts] as usize];
    for t in 0..mesh.len() {
        for (j, &v) in mesh.nodes(t)[..3].iter().enumerate() {
            members[fill[v as usize] as usize] = (t as u32, j as u8);
            fill[v as usize] += 1;
        }
    }
    (count, members)
}

/// The vertices with a patch, by colour of a greedy colouring of the vertex graph in the
/// [`geometric_order`] (with `hint`): two vertices of one cell get different colours, so two
/// patches of one colour share no cell. `start`, `cells`: [`vertex_patches`].
pub(super) fn colour_vertices(
    mesh: &Mesh,
    start: &[u32],
    cells: &[(u32, u8)],
    hint: Option<[f64; 2]>,
) -> Vec<Vec<usize>> {
    let npts = mesh.points.len();
    let mut colour = vec![u16::MAX; npts];
    let mut used: Vec<bool> = Vec::new();
    let mut ncol = 0usize;
    let vertices: Vec<usize> = (0..npts).filter(|&v| start[v + 1] > start[v]).collect();
    for v in geometric_order(&mesh.points, vertices, hint) {
        used.iter_mut().for_each(|u| *u = false);
        for &(t, _) in &cells[start[v] as usize..start[v + 1] as usize] {
            for &w in &mesh.nodes(t as usize)[..3] {
                let c = colour[w as usize];
                if c != u16::MAX {
                    used[c as usize] = true;
                }
            }
        }
        let c = used.iter().position(|&u| !u).unwrap_or(used.len());
        if c == used.len() {
            used.push(false);
        }
        colour[v] = c as u16;
        ncol = ncol.max(c + 1);
    }
    let mut by_colour: Vec<Vec<usize>> = vec![Vec::new(); ncol];
    for (v, &c) in colour.iter().enumerate() {
        if c != u16::MAX {
            by_colour[c as usize].push(v);
        }
    }
    by_colour
}

/// The mean of the contact edges' midpoints, else of the Dirichlet edges' (None without
/// either): a point of the problem that a rotation or a renumbering carries along, which
/// [`geometric_order`] uses where the cloud of vertices alone has no preferred direction.
pub(super) fn boundary_hint(ctx: &Context) -> Option<[f64; 2]> {
    let mean = |pick: &dyn Fn(&Condition) -> bool| {
        let (mut s, mut k) = ([0.0; 2], 0usize);
        for be in ctx.edges.iter().filter(|be| pick(&be.condition)) {
            let [a, b] = ctx.topo.edges[be.edge as usize];
            let (pa, pb) = (ctx.mesh.points[a as usize], ctx.mesh.points[b as usize]);
            s[0] += 0.5 * (pa[0] + pb[0]);
            s[1] += 0.5 * (pa[1] + pb[1]);
            k += 1;
        }
        (k > 0).then(|| [s[0] / k as f64, s[1] / k as f64])
    };
    mean(&|c| matches!(c, Condition::Contact(_)))
        .or_else(|| mean(&|c| matches!(c, Condition::Dirichlet(_))))
}

/// `vertices` sorted by a key of their positions alone, so that the colouring, and with it the
/// colour-ordered patch solves, do not depend on the point numbering (a file renumbered, or
/// merged from pieces or exploded cells, gave η and the bound up to 0.9 % apart before), nor,
/// where the point cloud has a preferred direction, on the frame. With c the mean of the
/// vertices, R their largest distance from c, e₁ the principal axis of their covariance (its sign
/// making the third moment along e₁, else along e₂, positive) and e₂ = e₁ turned by +90°: the
/// key is (x − c)·e₁ rounded to 1e-9 R (so that round-off of a turned file does not reorder),
/// then (x − c)·e₂, a sweep across the body as a mesh generator's numbering often is (sorting by
/// distance from c instead raised the Q1 manufactured index at n = 4 from 1.48 to 1.59). A cloud
/// without a principal axis or a sign (both below 1e-9 of their scale: a square grid) takes the
/// frame's axes instead, unless `hint` (a point the problem's data single out, [`boundary_hint`])
/// is away from c: then e₁ is the direction from c to it turned by +90° (a sweep along that
/// boundary; the unit-square meshes with contact below keep their x-major order).
pub(super) fn geometric_order(
    points: &[[f64; 2]],
    mut vertices: Vec<usize>,
    hint: Option<[f64; 2]>,
) -> Vec<usize> {
    let n = vertices.len().max(1) as f64;
    let mut c = [0.0; 2];
    for &v in &vertices {
        c[0] += points[v][0] / n;
        c[1] += points[v][1] / n;
    }
    let d = |v: usize| [points[v][0] - c[0], points[v][1] - c[1]];
    let (mut sxx, mut sxy, mut syy, mut r) = (0.0, 0.0, 0.0, 0.0f64);
    for &v in &vertices {
        let p = d(v);
        sxx += p[0] * p[0];
        sxy += p[0] * p[1];
        syy += p[1] * p[1];
        r = r.max(p[0].hypot(p[1]));
    }
    let tiny = 1e-9;
    let spread = sxx + syy;
    let anisotropy = ((sxx - syy).powi(2) + 4.0 * sxy * sxy).sqrt();
    let towards = hint.map(|h| [h[0] - c[0], h[1] - c[1]]).and_then(|h| {
        let l = h[0].hypot(h[1]);
        (l > tiny * r).then(|| [h[0] / l, h[1] / l])
    });
    let isotropic = anisotropy <= tiny * spread;
    let mut e1 = match (isotropic, towards) {
        (false, _) => {
            let phi = 0.5 * (2.0 * sxy).atan2(sxx - syy);
            [phi.cos(), phi.sin()]
        }
        (true, Some(h)) => [-h[1], h[0]],
        (true, None) => [1.0, 0.0],
    };
    let third = |e: [f64; 2]| -> f64 {
        vertices
            .iter()
            .map(|&v| {
                let p = d(v);
                (p[0] * e[0] + p[1] * e[1]).powi(3)
            })
            .sum()
    };
    let scale = n * r.powi(3);
    let m1 = third(e1);
    if isotropic && towards.is_some() {
        // e₁ is fixed by the hint, sign included.
    } else if m1.abs() > tiny * scale {
        if m1 < 0.0 {
            e1 = [-e1[0], -e1[1]];
        }
    } else if third([-e1[1], e1[0]]) < -tiny * scale {
        e1 = [-e1[0], -e1[1]];
    }
    let e2 = [-e1[1], e1[0]];
    let unit = (tiny * r).max(f64::MIN_POSITIVE);
    let key = |v: usize| {
        let p = d(v);
        // An integer, so that −0 and +0 (a turned file's round-off either side) are one row.
        let along = ((p[0] * e1[0] + p[1] * e1[1]) / unit).round() as i64;
        (along, p[0] * e2[0] + p[1] * e2[1])
    };
    let mut keyed: Vec<(i64, f64, usize)> = vertices
        .iter()
        .map(|&v| {
            let (a, b) = key(v);
            (a, b, v)
        })
        .collect();
    keyed.sort_unstable_by(|x, y| x.0.cmp(&y.0).then(x.1.total_cmp(&y.1)).then(x.2.cmp(&y.2)));
    vertices.clear();
    vertices.extend(keyed.into_iter().map(|k| k.2));
    vertices
}

impl PatchOut {
    /// The outcome of a patch whose P_1 symmetry rows cannot be met (`solve_patch` solves it
    /// again without them).
    fn higher_failed(unknowns: usize) -> PatchOut {
        PatchOut {
            solved: true,
            cells: Vec::new(),
            unknowns,
            active: 0,
            settled: false,
            feasible: false,
            defect: f64::INFINITY,
            higher_defect: f64::INFINITY,
            dropped_higher: false,
            balance: [0.0; 3],
            balance_scale: 0.0,
        }
    }
}

struct PatchOut {
    /// False when only the balance was computed (`solve_patch`'s `balance_only` on a patch
    /// whose balance does not depend on its unknowns, `linear_balance`): `cells` is empty.
    solved: bool,
    cells: Vec<(u32, [[f64; MAX_RT_DOFS]; 2])>,
    unknowns: usize,
    active: usize,
    settled: bool,
    feasible: bool,
    defect: f64,
    /// The largest residual of the P_1 weak-symmetry rows relative to their terms (0 without
    /// them): above `PATCH_DEFECT_RELATIVE` the patch is solved again without them.
    higher_defect: f64,
    /// Whether it was solved again without them.
    dropped_higher: bool,
    /// Moments of the patch load against e_x, e_y and (x − x₀)^⊥/L (flow.rs's d_a).
    balance: [f64; 3],
    /// The largest sum of the magnitudes of the terms that make up a balance component.
    balance_scale: f64,
}

/// The degree of the rule of a patch cell's integrals (design §5.10): exact on a straight cell
/// (the mass matrix comes from the reference Gram matrices), where ψ_a φ_i·ε(u_h) has degree
/// 1 + k + (p − 1) and the divergence moments (ψ_a f + Cε(u_h)∇ψ_a + the linear flow loads)·q̂
/// at most k + max(p − 1, 1) with f constant; curved cells integrate the mass matrix here too
/// (2k + 2, and the map); a non-constant body force takes `LOAD_DEGREE`.
fn cell_rule_degree(shape: Shape, k: usize, p: usize, varying_force: bool) -> usize {
    let mut deg = if shape == Shape::Affine {
        k + p
    } else {
        (2 * k + 2).max(k + p + 1).max(2 * p)
    };
    if varying_force {
        deg = deg.max(LOAD_DEGREE);
    }
    rule_degree(shape, deg)
}

/// The shape functions and the RT reference basis of one triangle family at the points of one
/// rule, evaluated once for all cells (per cell and point they were a tenth of the patch
/// stage): [`TriangleTable::point`] is `sub_point` to the bit, and `rt::piola_of` of the
/// tabulated values is `rt::piola`.
struct RuleTable {
    family: Family,
    degree: usize,
    geometry: TriangleTable,
    rt: Vec<([[f64; 2]; MAX_RT_DOFS], [f64; MAX_RT_DOFS])>,
}

impl RuleTable {
    /// The tables of the rules `cell_rule_degree` gives, for every triangle family of `mesh`.
    fn build(mesh: &Mesh, order: RtOrder, varying_force: bool) -> Vec<RuleTable> {
        let mut tables: Vec<RuleTable> = Vec::new();
        for fam in Family::ALL {
            if fam.is_quad() || !mesh.family.contains(&fam) {
                continue;
            }
            for shape in [Shape::Affine, Shape::Curved] {
                let degree = cell_rule_degree(shape, order.k(), mesh.degree, varying_force);
                if tables.iter().any(|t| t.family == fam && t.degree == degree) {
                    continue;
                }
                let rule = triangle_rule_cached(degree);
                tables.push(RuleTable {
                    family: fam,
                    degree,
                    geometry: TriangleTable::new(fam, &rule.points),
                    rt: rule
                        .points
                        .iter()
                        .map(|&xi| rt::reference(order, xi))
                        .collect(),
                });
            }
        }
        tables
    }
}

/// A cell's coefficients (row, local function) as the bits of f64 values, written by the
/// final solves (`reconstruct`).
type CellBits = [[AtomicU64; MAX_RT_DOFS]; 2];

/// The stress of the patches solved before this one, and which vertices those were
/// (`reconstruct`'s colour-ordered final solves).
#[derive(Clone, Copy)]
struct Prior<'a> {
    coefficients: &'a [CellBits],
    done: &'a [bool],
}

/// What every patch shares.
#[derive(Clone, Copy)]
struct PatchSetup<'a> {
    /// With the patches solved so far: the patch minimises ‖σ_prior + τ − Ψ Cε*‖² (the
    /// norm of `form`), Ψ the sum of the hat functions of those vertices and of its own;
    /// without, ‖τ − ψ_a Cε*‖².
    prior: Option<Prior<'a>>,
    /// The objective's pointwise form (`condense::objective_form`).
    form: [[f64; 4]; 4],
    /// The cells' rules, tabulated (`RuleTable::build`).
    tables: &'a [RuleTable],
    /// The body force is not constant (the rules take `LOAD_DEGREE`).
    varying_force: bool,
    order: RtOrder,
    condition: &'a [Option<Condition>],
    weak_symmetry: bool,
    /// x₀ of the rotation moments, and the length they are divided by.
    origin: [f64; 2],
    length: f64,
    /// ε*: the averaged strain at the nodes (xx, xy, yy), the strain of the patch target.
    recovered: &'a [[f64; 3]],
}

/// ε* = the nodal average of ε(u_h), weighted by the areas of the cells sharing the node
/// (Zienkiewicz–Zhu averaging), interpolated with the displacement's shape functions.
///
/// It is only the target of the patch minimisation (design §5.10): any target gives an
/// equilibrated σ_h and a valid bound. It is kept in f64 all the same: an exact solution in
/// the space must reproduce its own strain to round-off, and f32 left 7e-9 of the bound there.
/// A smoother target than the piecewise Cε(u_h) lowers η_PS: on the
/// manufactured family P1 n = 32 the index fell from 1.86 to 1.59.
fn recovered_strain(mesh: &Mesh, u: &[[f64; 2]]) -> Vec<[f64; 3]> {
    let mut acc = vec![[0.0f64; 4]; mesh.points.len()];
    for t in 0..mesh.len() {
        let fam = mesh.family[t];
        let x = mesh.coords(t);
        let nodes = mesh.nodes(t);
        let sh = mesh.shape[t];
        let c = sub_point(fam, &x[..fam.nodes()], sh, 0, [1.0 / 3.0, 1.0 / 3.0]);
        let w = c.jac.det.abs();
        for (i, &xi) in fam.reference_nodes().iter().enumerate() {
            let sp = sub_point(fam, &x[..fam.nodes()], sh, 0, xi);
            let g = sp.gradient_at(nodes, u);
            let a = &mut acc[nodes[i] as usize];
            a[0] += w * g[0][0];
            a[1] += w * 0.5 * (g[0][1] + g[1][0]);
            a[2] += w * g[1][1];
            a[3] += w;
        }
    }
    acc.iter()
        .map(|a| {
            if a[3] > 0.0 {
                [a[0] / a[3], a[1] / a[3], a[2] / a[3]]
            } else {
                [0.0; 3]
            }
        })
        .collect()
}

/// An added body load on one cell of a patch: c₀e_x + c₁e_y + c₂(x − x_T)^⊥ with x_T the cell's
/// [`anchor`] (flow.rs).
type Extra = [f64; 4];

/// Patches solved at once in the last stage, whose cell coefficients are then summed.
const FINAL_CHUNK: usize = 16_384;

/// Edges per parallel chunk of a flow pass' loads (`edge_moves`): ~4 MB of moves at a time.
const LOAD_CHUNK: usize = 16_384;

/// Patches whose balance is found first, to learn whether the flows will run (`reconstruct`):
/// enough to meet a defect on a file that has them, few against a million patches.
const FLOW_SAMPLE: usize = 4096;

/// Whether a cell of the patch has an edge on a Dirichlet boundary: such a patch takes any
/// rigid-motion moment (its unknowns include the fluxes through that edge). The one rule for
/// Q_a: the flows read it before any patch is solved.
fn touches_dirichlet(ctx: &Context, condition: &[Option<Condition>], cells: &[(u32, u8)]) -> bool {
    let topo = ctx.topo;
    cells.iter().any(|&(t, _)| {
        topo.cell_edges[t as usize][..3].iter().any(|&e| {
            topo.edge_cells[e as usize][1] == NONE
                && matches!(condition[e as usize], Some(Condition::Dirichlet(_)))
        })
    })
}

/// The moments a patch cannot take (flow.rs's Q_a): none with a Dirichlet edge; else the
/// forces, and the rotation too when the weak symmetry rows fix ∫ as τ (without them the
/// asymmetric part meets any rotation moment).
fn cannot_take(dirichlet: bool, weak_symmetry: bool) -> flow::M3 {
    if dirichlet {
        [[0.0; 3]; 3]
    } else if weak_symmetry {
        flow::complement(&[], PATCH_DEPENDENT_ROW)
    } else {
        flow::complement(&[[0.0, 0.0, 1.0]], PATCH_DEPENDENT_ROW)
    }
}

/// The point the flow loads of cell t turn about: its first node, a coordinate of the file, so
/// that x − x_T keeps the digits of the cell's size however far the mesh is from the origin
/// ([`crate::geometry::values::SubPoint::from`]; the mean of the corners was rounded to ε|x|, which left the Hertz P1
/// file moved to |x| = 3e4 equilibrated to 4.6e-9 instead of 1e-13).
fn anchor(mesh: &Mesh, t: usize) -> [f64; 2] {
    mesh.coords(t)[0]
}

/// One cell's part of an edge load: the cell, (c₀, c₁, c₂) and x_T − x̄ (its anchor's offset
/// from the centre).
type EdgeLoad = (u32, [f64; 3], [f64; 2]);

/// The load h_E on the cells of an edge with rigid-motion moments y = (∫h·e_x, ∫h·e_y,
/// ∫h·(x − x₀)^⊥): h = c₀e_x + c₁e_y + c₂(x − x̄)^⊥ with x̄ the centroid of the cells, so
/// c₀ = y₀/|ω|, c₁ = y₁/|ω|, c₂ = (y₂ + |ω|(ȳ − y₀')c₀ − |ω|(x̄ − x₀')c₁)/∫|x − x̄|² (x₀ =
/// (x₀', y₀')). Straight-cell quadrature of the area and second moment (the patch rows use the
/// same points, so the moments the patches see are these up to round-off). Closed forms on
/// straight cells are not: far from the origin they differ from the rule by ~1e-10 relative,
/// and the Hertz Q1 halves moved to (1e4, −3e4) kept patch defects of 1e-9 and lost their
/// guarantee (BENCHMARKS.md, session 37).
///
/// An edge has at most two cells: the points and the result stay on the stack (this runs for
/// every edge of every flow pass, and the lists were freed by the serial step).
fn edge_load(ctx: &Context, cells: &[u32], y: [f64; 3], origin: [f64; 2]) -> Option<[EdgeLoad; 2]> {
    let mesh = ctx.mesh;
    let rule = triangle_rule_cached(EDGE_LOAD_DEGREE);
    debug_assert_eq!(rule.points.len(), EDGE_LOAD_POINTS);
    // Positions relative to the first cell's anchor x_r: differences of nearby points.
    let reference = anchor(mesh, *cells.first()? as usize);
    let (mut area, mut first) = (0.0, [0.0; 2]);
    let mut pts = [([0.0; 2], 0.0); 2 * EDGE_LOAD_POINTS];
    let mut npts = 0;
    for &t in &cells[..cells.len().min(2)] {
        let t = t as usize;
        let fam = mesh.family[t];
        let x = mesh.coords(t);
        for (&xi, &wq) in rule.points.iter().zip(&rule.weights) {
            let sp = sub_point(fam, &x[..fam.nodes()], mesh.shape[t], 0, xi);
            let w = wq * sp.jac.det;
            let p = sp.from(reference);
            area += w;
            first[0] += w * p[0];
            first[1] += w * p[1];
            pts[npts] = (p, w);
            npts += 1;
        }
    }
    if area <= 0.0 {
        return None;
    }
    // x̄ − x_r.
    let centre = [first[0] / area, first[1] / area];
    let second: f64 = pts[..npts]
        .iter()
        .map(|(p, w)| w * ((p[0] - centre[0]).powi(2) + (p[1] - centre[1]).powi(2)))
        .sum();
    if second <= 0.0 {
        return None;
    }
    let c0 = y[0] / area;
    let c1 = y[1] / area;
    let from_origin = [
        reference[0] - origin[0] + centre[0],
        reference[1] - origin[1] + centre[1],
    ];
    let c2 = (y[2] + area * from_origin[1] * c0 - area * from_origin[0] * c1) / second;
    let mut out = [(0, [0.0; 3], [0.0; 2]); 2];
    for (o, &t) in out.iter_mut().zip(cells) {
        let xt = anchor(mesh, t as usize);
        let d = [
            xt[0] - reference[0] - centre[0],
            xt[1] - reference[1] - centre[1],
        ];
        *o = (t, [c0, c1, c2], d);
    }
    Some(out)
}

/// The degree of `edge_load`'s rule, and its number of points.
const EDGE_LOAD_DEGREE: usize = 4;
const EDGE_LOAD_POINTS: usize = 6;

/// One patch: unknowns, local maps, quadrature, QP (module doc).
fn solve_patch(
    ctx: &Context,
    u: &[[f64; 2]],
    setup: &PatchSetup,
    vertex: u32,
    cells: &[(u32, u8)],
    extra: &[Extra],
    balance_only: bool,
) -> PatchOut {
    // A patch whose balance does not depend on its unknowns only gives it in the passes.
    if balance_only && is_linear(ctx, setup.condition, cells) {
        return linear_balance(ctx, u, setup, vertex, cells, extra);
    }
    // The P_1 moments of the weak symmetry (design §5.10): with RT_2, not with RT_1 (too few
    // free values per cell) and not P_2 (RT_2 × P_2 × P_2 is not stable: the manufactured
    // patches became infeasible). They only lower the price of the symmetric correction, so a
    // patch that cannot meet them (a corner cell with all three fluxes fixed has two free
    // values) is solved without them.
    let higher = setup.weak_symmetry && setup.order.k() >= 2;
    let out = solve_patch_rows(ctx, u, setup, vertex, cells, extra, higher);
    if higher && out.higher_defect > PATCH_DEFECT_RELATIVE {
        PatchOut {
            dropped_higher: true,
            ..solve_patch_rows(ctx, u, setup, vertex, cells, extra, false)
        }
    } else {
        out
    }
}

/// [`solve_patch`] with or without the P_1 weak-symmetry rows.
// Index loops over (row, DOF, moment) mirror the formulas of condense.rs.
#[allow(clippy::needless_range_loop, clippy::too_many_arguments)]
fn solve_patch_rows(
    ctx: &Context,
    u: &[[f64; 2]],
    setup: &PatchSetup,
    vertex: u32,
    cells: &[(u32, u8)],
    extra: &[Extra],
    higher: bool,
) -> PatchOut {
    let (order, condition, weak_symmetry) = (setup.order, setup.condition, setup.weak_symmetry);
    let (x0, length) = (setup.origin, setup.length);
    let mesh = ctx.mesh;
    let topo = ctx.topo;
    let scene = ctx.scene;
    let ne = order.edge_dofs();
    let bern = bernstein(order);
    let mut nvar = 0usize;
    let mut bounded: Vec<usize> = Vec::new();
    // Extra equalities x_j = 0 (contact edges facing an infinite gap).
    let mut zero_vars: Vec<usize> = Vec::new();
    // Global edge → its slot values per row (global orientation).
    // At most 3 per cell; sized once (their regrowth copied ~3 % of a balance-only patch).
    let mut edge_ids: Vec<u32> = Vec::with_capacity(3 * cells.len());
    let mut edge_vals: Vec<[[Lin; 3]; 2]> = Vec::with_capacity(3 * cells.len());
    for &(t, _) in cells {
        let t = t as usize;
        for l in 0..3 {
            let e = topo.cell_edges[t][l];
            if edge_ids.contains(&e) {
                continue;
            }
            let [ea, eb] = topo.edges[e as usize];
            let radial = ea == vertex || eb == vertex;
            let boundary = topo.edge_cells[e as usize][1] == NONE;
            let mut vals: [[Lin; 3]; 2] = Default::default();
            let forward = topo.cell_edge_sign[t][l] > 0;
            let sgn = if forward { 1.0 } else { -1.0 };
            let owner_s = |sg: f64| if forward { sg } else { 1.0 - sg };
            let cond = if boundary {
                condition[e as usize].unwrap_or(Condition::Free)
            } else {
                Condition::Free
            };
            let fam = mesh.family[t];
            let x = mesh.coords(t);
            let sh = mesh.shape[t];
            match (boundary, cond) {
                (false, _) if radial => {
                    for row in vals.iter_mut() {
                        for v in row.iter_mut().take(ne) {
                            v.push(nvar, 1.0);
                            nvar += 1;
                        }
                    }
                }
                (false, _) => {}
                (true, Condition::Dirichlet(_)) => {
                    for row in vals.iter_mut() {
                        for v in row.iter_mut().take(ne) {
                            v.push(nvar, 1.0);
                            nvar += 1;
                        }
                    }
                }
                (true, Condition::Free) => {}
                (true, Condition::Neumann(b)) => {
                    if radial {
                        let p = neumann_constants(ctx, order, t, l, vertex, b);
                        for (row, pr) in vals.iter_mut().zip(p) {
                            for (v, pv) in row.iter_mut().zip(pr).take(ne) {
                                v.c = pv;
                            }
                        }
                    }
                }
                (true, Condition::Contact(b)) => {
                    let BoundaryKind::Contact(spec) = &scene.boundaries[b].kind else {
                        unreachable!("a contact edge has a contact spec")
                    };
                    let fr = spec.friction;
                    let cone = fr >= MIN_CONE_FRICTION;
                    let base = nvar;
                    // Two variable sets per Bernstein index: (y_n, y_t) or the cone (w₁, w₂).
                    nvar += 2 * ne;
                    for j in 0..ne {
                        if cone {
                            bounded.push(base + 2 * j);
                            bounded.push(base + 2 * j + 1);
                        } else {
                            bounded.push(base + 2 * j);
                            zero_vars.push(base + 2 * j + 1);
                        }
                    }
                    for (slot, &sg) in order.edge_points().iter().enumerate() {
                        let (sp, normal, _, _) =
                            sub_edge_point(fam, &x[..fam.nodes()], sh, 0, l, owner_s(sg));
                        let cn = spec.direction(normal);
                        let ct = [-cn[1], cn[0]];
                        if !spec.gap_at(sp.x, cn).is_finite() {
                            for j in 0..ne {
                                zero_vars.push(base + 2 * j);
                            }
                        }
                        let (c0, c1) = if cone {
                            let h = 0.5 / fr;
                            (
                                [h * cn[0] + 0.5 * ct[0], h * cn[1] + 0.5 * ct[1]],
                                [h * cn[0] - 0.5 * ct[0], h * cn[1] - 0.5 * ct[1]],
                            )
                        } else {
                            (cn, ct)
                        };
                        for (r, row) in vals.iter_mut().enumerate() {
                            for (j, &bij) in bern[slot].iter().enumerate().take(ne) {
                                if bij != 0.0 {
                                    row[slot].push(base + 2 * j, sgn * bij * c0[r]);
                                    row[slot].push(base + 2 * j + 1, sgn * bij * c1[r]);
                                }
                            }
                        }
                    }
                }
            }
            edge_ids.push(e);
            edge_vals.push(vals);
        }
    }
    // Interior values: condensed (condense.rs), dim ker D_I free values per cell and row.
    let re = condense::reference(order);
    let (nloc, nedge, nq, nz, nred) = (re.nloc, re.nedge, re.nq, re.nz, re.nred);
    // With the P_1 symmetry rows and one free interior value per cell and row (RT_2), those
    // two rows fix the cell's two free values given its edge values: they are eliminated in
    // the cell (`eliminate_kernel`), which takes 2 unknowns and 2 rows per cell out of the
    // patch QP (an equivalent problem: the other rows have exact zeros in those columns).
    // Only on straight, well-shaped cells: H⁻¹ amplifies round-off by cond(H) = cond(J) there
    // (at aspect 1e3 the bound of an exact pair rose from 3e-7 to 1.7e-5 of energy^½). And
    // not on patches with sign bounds: the QP's dependence tests are relative to (M⁻¹)_pp,
    // which the elimination changes, and with 𝔉 = 1e6 on the manufactured P2 mesh 9 contact
    // patches were left unmet instead of 5 (defect 7.9e-6 instead of 7.3e-10).
    // Per cell, computed once: the Jacobian at the centroid of a straight cell in a solved
    // patch (the reduced mass matrix below, and the shape test here), and the first patch
    // unknown of its free values (unused when they are eliminated).
    let mut centre_jac = Vec::with_capacity(cells.len());
    let mut eliminated = Vec::with_capacity(cells.len());
    let mut kernel_first = Vec::with_capacity(cells.len());
    for &(t, _) in cells {
        let t = t as usize;
        let fam = mesh.family[t];
        let jac = (mesh.shape[t] == Shape::Affine).then(|| {
            sub_jacobian(
                fam,
                &mesh.coords(t)[..fam.nodes()],
                Shape::Affine,
                0,
                [1.0 / 3.0; 2],
            )
        });
        let eliminate = higher
            && bounded.is_empty()
            && nz == 1
            && jac.as_ref().is_some_and(|j| well_shaped(j.matrix));
        kernel_first.push(nvar);
        if !eliminate {
            nvar += 2 * nz;
        }
        centre_jac.push(jac);
        eliminated.push(eliminate);
    }
    let (nl, nr) = (2 * nloc, 2 * nred);

    let mut m = vec![0.0; nvar * nvar];
    let mut bvec = vec![0.0; nvar];
    // Equality rows B (flat, row-major, nvar columns) and their right-hand sides d.
    let mut rows: Vec<f64> = Vec::new();
    let mut rhs: Vec<f64> = Vec::new();
    let mut parts: Vec<CellPart> = Vec::with_capacity(cells.len());
    // The full local matrices of curved cells, sized when one is met (zeroing them for every
    // patch was ~2 % of the patch stage's instructions).
    let mut mloc = Vec::new();
    let mut mt = Vec::new();
    let mut mred = vec![0.0; nr * nr];
    for (ci, &(t, j)) in cells.iter().enumerate() {
        let t = t as usize;
        let j = j as usize;
        let fam = mesh.family[t];
        let x = mesh.coords(t);
        let nodes = mesh.nodes(t);
        let sh = mesh.shape[t];
        let affine = sh == Shape::Affine;
        let xt = anchor(mesh, t);
        let mut part = CellPart {
            t: t as u32,
            emap: [[EdgeRef::default(); MAX_EDGE_DOFS]; 2],
            c0: [0.0; 2 * MAX_RT_DOFS],
            g: [[0.0; MAX_MOMENTS]; 2],
            srow: [0.0; 2 * MAX_RT_DOFS],
            shi: [[0.0; 2 * MAX_RT_DOFS]; 2],
            asym: extra.get(ci).map_or(0.0, |e| e[3]),
            kernel: kernel_first[ci],
            eliminated: None,
            rigid: [[[0.0; 3]; 2]; 3],
        };
        // Local edge function (row r, DOF e) → affine expression in the unknowns.
        for r in 0..2 {
            for l in 0..3 {
                let e = topo.cell_edges[t][l];
                let pos = edge_ids.iter().position(|&x| x == e).expect("patch edge");
                let forward = topo.cell_edge_sign[t][l] > 0;
                for (loc, slot, sign) in rt::local_to_global_edge(order, l, forward) {
                    part.emap[r][loc] = EdgeRef {
                        pos: pos as u16,
                        slot: slot as u8,
                        negative: sign < 0.0,
                    };
                }
            }
        }
        let p = mesh.degree;
        let k = order.k();
        let degree = cell_rule_degree(sh, k, p, setup.varying_force);
        let rule = triangle_rule_cached(degree);
        let table = setup
            .tables
            .iter()
            .find(|tb| tb.family == fam && tb.degree == degree);
        let mut bloc = [0.0; 2 * MAX_RT_DOFS];
        // The symmetry row ∫_T (τ_xy − τ_yx) exactly (J is linear in ξ; condense.rs).
        part.srow = symmetry_row(re, fam, &x[..fam.nodes()], sh);
        if higher {
            part.shi = higher_symmetry_rows(re, order, fam, &x[..fam.nodes()], sh);
        }
        if !affine {
            mloc.clear();
            mloc.resize(nl * nl, 0.0);
            mt.resize(nl * nr, 0.0);
        }
        for (pi, (&xi, &wq)) in rule.points.iter().zip(&rule.weights).enumerate() {
            let sp = match table {
                Some(tb) => tb.geometry.point(&x[..fam.nodes()], pi),
                None => sub_point(fam, &x[..fam.nodes()], sh, 0, xi),
            };
            let jac = sp.jac;
            let w = wq * jac.det;
            let lam = [1.0 - xi[0] - xi[1], xi[0], xi[1]];
            let psi = lam[j];
            add_load_moments(
                ctx,
                u,
                nodes,
                &sp,
                wq,
                xi,
                j,
                extra.get(ci),
                xt,
                &mut part.g,
            );
            let (v, _) = match table {
                Some(tb) => rt::piola_of(&tb.rt[pi], &jac),
                None => rt::piola(order, &jac, xi),
            };
            // The target's strain ε* (its stress Cε*: the linear term (τ, ψ_a ε*)).
            let eps = {
                let mut e = [0.0; 3];
                for (i, &n) in nodes.iter().enumerate() {
                    let r = setup.recovered[n as usize];
                    for c in 0..3 {
                        e[c] += sp.phi[i] * r[c];
                    }
                }
                [e[0], e[1], e[1], e[2]]
            };
            let weight = match setup.prior {
                None => psi,
                Some(pr) => (0..3)
                    .filter(|&jj| jj == j || pr.done[nodes[jj] as usize])
                    .map(|jj| lam[jj])
                    .sum(),
            };
            for r in 0..2 {
                for i in 0..nloc {
                    bloc[r * nloc + i] +=
                        w * weight * (v[i][0] * eps[2 * r] + v[i][1] * eps[2 * r + 1]);
                }
            }
            if !affine {
                let mut tau = [[0.0; 4]; 2 * MAX_RT_DOFS];
                let mut at = [[0.0; 4]; 2 * MAX_RT_DOFS];
                for r in 0..2 {
                    for i in 0..nloc {
                        let a = r * nloc + i;
                        tau[a][2 * r] = v[i][0];
                        tau[a][2 * r + 1] = v[i][1];
                        at[a] = std::array::from_fn(|p| dot4(setup.form[p], tau[a]));
                    }
                }
                for a in 0..nl {
                    for c in 0..=a {
                        mloc[a * nl + c] += w * dot4(at[a], tau[c]);
                    }
                }
            }
        }
        if !affine {
            for a in 0..nl {
                for c in 0..a {
                    mloc[c * nl + a] = mloc[a * nl + c];
                }
            }
        }
        // Complementarity term on contact edges: + ⟨τ_n, ψ_a (u_n − g)⟩.
        for l in 0..3 {
            let e = topo.cell_edges[t][l] as usize;
            let Some(Condition::Contact(bi)) = condition[e] else {
                continue;
            };
            if topo.edge_cells[e][1] != NONE {
                continue;
            }
            let BoundaryKind::Contact(spec) = &scene.boundaries[bi].kind else {
                continue;
            };
            let lr = line_rule_cached(EDGE_DEGREE);
            for (&s, &wq) in lr.points.iter().zip(&lr.weights) {
                let (sp, normal, len, xs) = sub_edge_point(fam, &x[..fam.nodes()], sh, 0, l, s);
                let lam = [1.0 - xs[0] - xs[1], xs[0], xs[1]];
                let psi = lam[j];
                if psi == 0.0 {
                    continue;
                }
                let cn = spec.direction(normal);
                let gap = spec.gap_at(sp.x, cn);
                if !gap.is_finite() {
                    continue;
                }
                let uu = sp.value_at(nodes, u);
                let un = cn[0] * uu[0] + cn[1] * uu[1];
                let (v, _) = rt::piola(order, &sp.jac, xs);
                for r in 0..2 {
                    for i in 0..nloc {
                        let flux = v[i][0] * normal[0] + v[i][1] * normal[1];
                        bloc[r * nloc + i] -= wq * len * psi * (un - gap) * cn[r] * flux;
                    }
                }
            }
        }
        // The local constant c₀ = T ē₀ + t₀ (Neumann fluxes through T, D_I⁺g) and
        // c = T E y + c₀ with y the patch unknowns (condense.rs).
        let ec: [[f64; MAX_EDGE_DOFS]; 2] = std::array::from_fn(|r| {
            std::array::from_fn(|e| {
                if e < nedge {
                    part.emap[r][e].constant(&edge_vals, r)
                } else {
                    0.0
                }
            })
        });
        part.c0 = cell_constant(re, &ec, &part.g);
        part.rigid = rigid_moments(&x, x0, length);
        // Reduced local problem: Tᵀ M T and Tᵀ(b − M c₀), T block-diagonal over the rows; with
        // the prior stress c_p on the cell, Tᵀ(b − M(c₀ + c_p)).
        let mut shifted = [0.0; 2 * MAX_RT_DOFS];
        shifted[..nl].copy_from_slice(&part.c0[..nl]);
        if let Some(pr) = setup.prior {
            let cp = &pr.coefficients[t];
            for r in 0..2 {
                for i in 0..nloc {
                    shifted[r * nloc + i] += f64::from_bits(cp[r][i].load(Relaxed));
                }
            }
        }
        let mut bred = [0.0; 2 * MAX_REDUCED];
        if affine {
            // Within the straightness tolerance of `Shape::Affine`, the Jacobian at the
            // centroid: the mass matrix only chooses among the equilibrated stresses.
            let jac = centre_jac[ci].expect("a straight cell of a solved patch");
            let mut tmc0 = [0.0; 2 * MAX_REDUCED];
            // Edge values without patch unknowns: their rows of Tᵀ M T are never read (the
            // scatter and `eliminate_kernel` use the rows of the other values only).
            let skip = (0..nr).fold(0u32, |bits, a| {
                let (r, y) = (a / nred, a % nred);
                let fixed = y < nedge && part.emap[r][y].of(&edge_vals, r).0.terms().is_empty();
                bits | u32::from(fixed) << a
            });
            condense::affine_reduced_form(
                re,
                &jac,
                &setup.form,
                &shifted[..nl],
                skip,
                &mut mred,
                &mut tmc0,
            );
            // Tᵀ b: T's edge rows are unit rows (condense.rs), so the sum over the local
            // functions starts at the edge value's own term (the other products of those rows
            // are exact zeros) and runs over the interior functions.
            for r in 0..2 {
                for y in 0..nred {
                    let start = if y < nedge { bloc[r * nloc + y] } else { -0.0 };
                    let tb = (nedge..nloc).fold(start, |s, c| {
                        s + re.transform[c * nred + y] * bloc[r * nloc + c]
                    });
                    bred[r * nred + y] = tb - tmc0[r * nred + y];
                }
            }
        } else {
            // Accumulated below (an affine cell's form overwrites every entry instead).
            mred.iter_mut().for_each(|v| *v = 0.0);
            for a in 0..nl {
                let ma = &mloc[a * nl..(a + 1) * nl];
                for r2 in 0..2 {
                    for y in 0..nred {
                        let mut v = 0.0;
                        for c in 0..nloc {
                            let tc = re.transform[c * nred + y];
                            if tc != 0.0 {
                                v += ma[r2 * nloc + c] * tc;
                            }
                        }
                        mt[a * nr + r2 * nred + y] = v;
                    }
                }
            }
            let mut rb = [0.0; 2 * MAX_RT_DOFS];
            for a in 0..nl {
                let ma = &mloc[a * nl..(a + 1) * nl];
                rb[a] = bloc[a]
                    - ma.iter()
                        .zip(&shifted[..nl])
                        .map(|(p, q)| p * q)
                        .sum::<f64>();
            }
            for r in 0..2 {
                for y in 0..nred {
                    let (mut bv, row) = (0.0, r * nred + y);
                    for c in 0..nloc {
                        let tc = re.transform[c * nred + y];
                        if tc == 0.0 {
                            continue;
                        }
                        bv += tc * rb[r * nloc + c];
                        let mr = &mt[(r * nloc + c) * nr..(r * nloc + c + 1) * nr];
                        for (acc, v) in mred[row * nr..(row + 1) * nr].iter_mut().zip(mr) {
                            *acc += tc * v;
                        }
                    }
                    bred[row] = bv;
                }
            }
        }
        let eliminate = eliminated[ci];
        if eliminate {
            match eliminate_kernel(re, &part.shi, &part.c0[..nl], &mut mred, &mut bred) {
                Some(k) => part.eliminated = Some(k),
                // A cell whose P_1 rows do not fix its free values (degenerate): the patch is
                // solved again without those rows (`solve_patch`).
                None => return PatchOut::higher_failed(nvar),
            }
        }
        // Reduced local unknown (row r, y) → patch unknowns: the edge value's terms, or the
        // cell's free interior value (borrowed, not copied: this runs for every cell of every
        // patch); none for an eliminated free value.
        let kernel_terms: [[(u32, f64); 1]; 2 * MAX_REDUCED] = std::array::from_fn(|a| {
            let (r, y) = (a / nred.max(1), a % nred.max(1));
            [((part.kernel + r * nz + y.saturating_sub(nedge)) as u32, 1.0)]
        });
        // Each with its sign (±1, so the products are those of scaled copies, bit for bit).
        let rmap: [(&[(u32, f64)], f64); 2 * MAX_REDUCED] = std::array::from_fn(|a| {
            let (r, y) = (a / nred.max(1), a % nred.max(1));
            if a >= nr || (y >= nedge && eliminate) {
                (&[][..], 1.0)
            } else if y < nedge {
                let (lin, sign) = part.emap[r][y].of(&edge_vals, r);
                (lin.terms(), sign)
            } else {
                (&kernel_terms[a][..], 1.0)
            }
        });
        // Only the reduced unknowns that reach patch unknowns (12 of 20 in an interior P2
        // cell: the others are constants or eliminated) take part in the scatter, in the same
        // order as over all of them (this loop ran 57k instructions per patch over all pairs).
        let mut reach: [Reach; 2 * MAX_REDUCED] = [(0, &[][..], 1.0); 2 * MAX_REDUCED];
        let mut nreach = 0;
        for (a, &(ta, sa)) in rmap.iter().enumerate().take(nr) {
            if !ta.is_empty() {
                reach[nreach] = (a, ta, sa);
                nreach += 1;
            }
        }
        for &(a, ta, sa) in &reach[..nreach] {
            let mred_a = &mred[a * nr..(a + 1) * nr];
            for &(c, tc, sc) in &reach[..nreach] {
                let mv = mred_a[c];
                if mv == 0.0 {
                    continue;
                }
                for &(va, ca) in ta {
                    let ca = sa * ca;
                    let mrow = &mut m[va as usize * nvar..(va as usize + 1) * nvar];
                    // The lower triangle only: `qp::solve` reads nothing else.
                    for &(vc, cc) in tc.iter().filter(|&&(vc, _)| vc <= va) {
                        mrow[vc as usize] += ca * (sc * cc) * mv;
                    }
                }
            }
            for &(va, ca) in ta {
                bvec[va as usize] += (sa * ca) * bred[a];
            }
        }
        let mut push_row = |g: &[f64], d: f64| {
            let start = rows.len();
            rows.resize(start + nvar, 0.0);
            let row = &mut rows[start..];
            for (a, &ga) in g.iter().enumerate() {
                if ga == 0.0 {
                    continue;
                }
                let (ta, sa) = rmap[a];
                for &(va, ca) in ta {
                    row[va as usize] += ga * (sa * ca);
                }
            }
            rhs.push(d);
        };
        // The kept rows U₀ᵀ(D c_r − g_r) = 0 per row r.
        let mut g_red = [0.0; 2 * MAX_REDUCED];
        for r in 0..2 {
            for m0 in 0..re.n0 {
                g_red.iter_mut().for_each(|v| *v = 0.0);
                g_red[r * nred..(r + 1) * nred]
                    .copy_from_slice(&re.kept[m0 * nred..(m0 + 1) * nred]);
                let d: f64 = (0..nq)
                    .map(|q| {
                        re.left[m0 * nq + q]
                            * (part.g[r][q]
                                - (0..nloc)
                                    .map(|c| re.div[q * nloc + c] * part.c0[r * nloc + c])
                                    .sum::<f64>())
                    })
                    .sum();
                push_row(&g_red[..nr], d);
            }
        }
        if weak_symmetry {
            // The constant row (right-hand side: the flows' as-moment), then the P_1 rows (0).
            let nhigher = if higher && !eliminate {
                part.shi.len()
            } else {
                0
            };
            let sym_rows = std::iter::once((&part.srow, part.asym))
                .chain(part.shi[..nhigher].iter().map(|row| (row, 0.0)));
            for (which, (srow, rhs)) in sym_rows.enumerate() {
                condense::symmetry_row_reduced(re, &srow[..], which == 0, &mut g_red);
                let d = rhs
                    - srow[..nl]
                        .iter()
                        .zip(&part.c0[..nl])
                        .map(|(a, b)| a * b)
                        .sum::<f64>();
                push_row(&g_red[..nr], d);
            }
        }
        parts.push(part);
    }
    // The contact equalities come last: relaxed first if the patch problem is infeasible.
    let hard_rows = rhs.len();
    for &z in &zero_vars {
        let start = rows.len();
        rows.resize(start + nvar, 0.0);
        rows[start + z] = 1.0;
        rhs.push(0.0);
    }
    let qp::QpResult {
        x,
        active,
        settled,
        feasible,
        defect: _,
    } = qp::solve(nvar, &m, &bvec, &rows, &rhs, hard_rows, &bounded);
    // The rigid-motion moments of the constraint residual (flow.rs's e_a): with the rows
    // (div τ − target, q)_T and ∫_T as τ, e_i = ∫(target − div τ)·ρ_i, plus ∫ as τ/L for the
    // rotation (the divergence theorem: ∫ div τ·ρ₃ = ∫_∂ τn·ρ₃ + ∫ as τ).
    // Variables that must vanish (frictionless tangential fluxes, infinite gaps) count at 0:
    // a fallback that relaxed them carries illegal moments, which are a defect too. The
    // residuals are those of all the rows, the condensed ones included, so the defect is
    // max |row residual| / max (Σ|row terms| + |rhs|) over the full rows (qp::defect's measure).
    let mut legal = x.clone();
    for &z in &zero_vars {
        legal[z] = 0.0;
    }
    let mut balance = [0.0; 3];
    // Σ of the magnitudes that make up each balance: its round-off scale.
    let mut balance_scale = [0.0f64; 3];
    let (mut worst, mut scale) = (0.0f64, 0.0f64);
    let (mut higher_worst, mut higher_scale) = (0.0f64, 0.0f64);
    let mut out_cells = Vec::with_capacity(parts.len());
    for part in &parts {
        let full = |x: &[f64]| {
            let mut c = [[0.0; MAX_RT_DOFS]; 2];
            let mut y = [[0.0; MAX_REDUCED]; 2];
            for r in 0..2 {
                for e in 0..nedge {
                    let (lin, sign) = part.emap[r][e].of(&edge_vals, r);
                    y[r][e] = sign * lin.value(x);
                }
            }
            for r in 0..2 {
                for mz in 0..nz {
                    y[r][nedge + mz] = match &part.eliminated {
                        None => x[part.kernel + r * nz + mz],
                        Some(k) => {
                            k.constant[r]
                                + (0..2)
                                    .flat_map(|s| (0..nedge).map(move |e| (s, e)))
                                    .map(|(s, e)| k.map[r][s * nred + e] * y[s][e])
                                    .sum::<f64>()
                        }
                    };
                }
            }
            // c = c₀ + T y; T's edge rows are unit rows (condense.rs).
            for r in 0..2 {
                for (i, ci) in c[r].iter_mut().enumerate().take(nloc) {
                    *ci = part.c0[r * nloc + i]
                        + if i < nedge {
                            y[r][i]
                        } else {
                            (0..nred)
                                .map(|yy| re.transform[i * nred + yy] * y[r][yy])
                                .sum::<f64>()
                        };
                }
            }
            c
        };
        let c = full(&legal);
        let (cell_worst, cell_scale) = add_cell_balance(
            re,
            &c,
            &part.g,
            &part.rigid,
            &mut balance,
            &mut balance_scale,
        );
        worst = worst.max(cell_worst);
        scale = scale.max(cell_scale);
        if weak_symmetry {
            let (value, terms) = row_value(&part.srow, &c, nloc);
            let (sres, abs) = (value - part.asym, terms + part.asym.abs());
            worst = worst.max(sres.abs());
            scale = scale.max(abs);
            if higher {
                for srow in &part.shi {
                    let (hres, habs) = row_value(srow, &c, nloc);
                    higher_worst = higher_worst.max(hres.abs());
                    higher_scale = higher_scale.max(habs);
                }
            }
            balance[2] += sres / length;
            balance_scale[2] += abs / length;
        }
        // `legal` is `x` itself without variables that must vanish.
        out_cells.push((part.t, if zero_vars.is_empty() { c } else { full(&x) }));
    }
    let balance_scale = balance_scale.iter().fold(0.0f64, |m, v| m.max(*v));
    let defect = if scale > 0.0 { worst / scale } else { 0.0 };
    PatchOut {
        solved: true,
        balance_scale,
        cells: out_cells,
        unknowns: nvar,
        active,
        settled,
        feasible,
        defect,
        higher_defect: if higher_scale > 0.0 {
            higher_worst / higher_scale
        } else {
            0.0
        },
        dropped_higher: false,
        balance,
    }
}

/// The rigid-motion balance of a patch whose balance does not depend on its unknowns (no
/// contact edge, straight cells: module doc), without setting up its problem: the moments of
/// the residual of c₀, the stress it would have with every unknown 0. The sums and their
/// order as the general code's (`solve_patch_rows`) before the solve, so c = c₀ + T·0 gives the
/// bits that code gave with the unknowns at zero; without its edge expressions, cell records and
/// matrices this took ~⅓ of the time (the balance pass of the 1M P2 bench). Its defect is the
/// balance relative to its terms: the defect a solve would leave (a balanced patch of this kind
/// is solvable: design §5.10).
fn linear_balance(
    ctx: &Context,
    u: &[[f64; 2]],
    setup: &PatchSetup,
    vertex: u32,
    cells: &[(u32, u8)],
    extra: &[Extra],
) -> PatchOut {
    let (mesh, topo, order) = (ctx.mesh, ctx.topo, setup.order);
    let re = condense::reference(order);
    let (ne, nloc) = (order.edge_dofs(), re.nloc);
    let (mut balance, mut balance_scale) = ([0.0; 3], [0.0f64; 3]);
    // The patch's unknowns, as `solve_patch_rows` counts them: the values of the interior
    // radial edges (two cells each) and of the Dirichlet edges, and the free interior values.
    let (mut radial_sides, mut dirichlet) = (0usize, 0usize);
    for (ci, &(t, j)) in cells.iter().enumerate() {
        let (t, j) = (t as usize, j as usize);
        let fam = mesh.family[t];
        let x = mesh.coords(t);
        let nodes = mesh.nodes(t);
        // The local edge constants: ψ_a's Neumann traction on the radial boundary edges.
        let mut ec = [[0.0; MAX_EDGE_DOFS]; 2];
        for l in 0..3 {
            let e = topo.cell_edges[t][l];
            let [ea, eb] = topo.edges[e as usize];
            let radial = ea == vertex || eb == vertex;
            let boundary = topo.edge_cells[e as usize][1] == NONE;
            let mut p = [[0.0; 3]; 2];
            match (boundary, setup.condition[e as usize]) {
                (false, _) if radial => radial_sides += 1,
                (true, Some(Condition::Dirichlet(_))) => dirichlet += 1,
                (true, Some(Condition::Neumann(b))) if radial => {
                    p = neumann_constants(ctx, order, t, l, vertex, b);
                }
                _ => {}
            }
            let forward = topo.cell_edge_sign[t][l] > 0;
            for (loc, slot, sign) in rt::local_to_global_edge(order, l, forward) {
                for r in 0..2 {
                    ec[r][loc] = sign * p[r][slot];
                }
            }
        }
        let degree = cell_rule_degree(Shape::Affine, order.k(), mesh.degree, setup.varying_force);
        let rule = triangle_rule_cached(degree);
        let table = setup
            .tables
            .iter()
            .find(|tb| tb.family == fam && tb.degree == degree);
        let xt = anchor(mesh, t);
        let mut g = [[0.0; MAX_MOMENTS]; 2];
        for (pi, (&xi, &wq)) in rule.points.iter().zip(&rule.weights).enumerate() {
            let sp = match table {
                Some(tb) => tb.geometry.point(&x[..fam.nodes()], pi),
                None => sub_point(fam, &x[..fam.nodes()], Shape::Affine, 0, xi),
            };
            add_load_moments(ctx, u, nodes, &sp, wq, xi, j, extra.get(ci), xt, &mut g);
        }
        let c0 = cell_constant(re, &ec, &g);
        let mut c = [[0.0; MAX_RT_DOFS]; 2];
        for r in 0..2 {
            c[r][..nloc].copy_from_slice(&c0[r * nloc..(r + 1) * nloc]);
        }
        let rigid = rigid_moments(&x, setup.origin, setup.length);
        add_cell_balance(re, &c, &g, &rigid, &mut balance, &mut balance_scale);
        if setup.weak_symmetry {
            let srow = symmetry_row(re, fam, &x[..fam.nodes()], Shape::Affine);
            let asym = extra.get(ci).map_or(0.0, |e| e[3]);
            let (value, terms) = row_value(&srow, &c, nloc);
            let (sres, abs) = (value - asym, terms + asym.abs());
            balance[2] += sres / setup.length;
            balance_scale[2] += abs / setup.length;
        }
    }
    let balance_scale = balance_scale.iter().fold(0.0f64, |m, v| m.max(*v));
    PatchOut {
        solved: false,
        balance_scale,
        cells: Vec::new(),
        unknowns: 2 * ne * (radial_sides / 2 + dirichlet) + 2 * re.nz * cells.len(),
        active: 0,
        settled: true,
        feasible: true,
        defect: relative_balance(balance, balance_scale),
        higher_defect: 0.0,
        dropped_higher: false,
        balance,
    }
}

/// Whether a patch's balance does not depend on its unknowns: no contact edge among its cells'
/// edges (the only source of sign bounds and vanishing variables) and straight cells.
fn is_linear(ctx: &Context, condition: &[Option<Condition>], cells: &[(u32, u8)]) -> bool {
    cells.iter().all(|&(t, _)| {
        let t = t as usize;
        ctx.mesh.shape[t] == Shape::Affine
            && ctx.topo.cell_edges[t][..3].iter().all(|&e| {
                !matches!(condition[e as usize], Some(Condition::Contact(_)))
                    || ctx.topo.edge_cells[e as usize][1] != NONE
            })
    })
}

/// ψ_a's Neumann flux on the radial boundary edge `l` of cell `t` (its only cell), per row
/// and edge slot in the edge's global orientation: the projection of ψ_a t |e| onto the
/// slots' polynomials (`project_points`), signed by the cell's orientation of the edge.
fn neumann_constants(
    ctx: &Context,
    order: RtOrder,
    t: usize,
    l: usize,
    vertex: u32,
    boundary: usize,
) -> [[f64; 3]; 2] {
    let mesh = ctx.mesh;
    let BoundaryKind::Neumann { traction } = &ctx.scene.boundaries[boundary].kind else {
        unreachable!("a Neumann edge has a traction")
    };
    let (fam, x, sh) = (mesh.family[t], mesh.coords(t), mesh.shape[t]);
    let forward = ctx.topo.cell_edge_sign[t][l] > 0;
    let sgn = if forward { 1.0 } else { -1.0 };
    // ψ_a along the owner's local edge l (from local vertex l to l + 1).
    let a_first = mesh.nodes(t)[l] == vertex;
    let local_points: Vec<f64> = order
        .edge_points()
        .iter()
        .map(|&s| if forward { s } else { 1.0 - s })
        .collect();
    let mut out = [[0.0; 3]; 2];
    for (r, row) in out.iter_mut().enumerate() {
        let p = project_points(order.k(), &local_points, |s| {
            let (sp, _, len, _) = sub_edge_point(fam, &x[..fam.nodes()], sh, 0, l, s);
            let psi = if a_first { 1.0 - s } else { s };
            psi * traction[r].eval(sp.x[0], sp.x[1], 0.0) * len
        });
        for (v, pv) in row.iter_mut().zip(p).take(order.edge_dofs()) {
            *v = sgn * pv;
        }
    }
    out
}

/// Adds one point's share of a patch cell's divergence-row right-hand sides, ∫ target_r q̂
/// (reference moments: the rows are (div τ, q)_T = ∫_T̂ div̂ τ̂ q̂, condense.rs), with weight
/// `wq` det J. The target is ψ_a's share of the equilibrium, −ψ_a f + Cε(u_h)∇ψ_a (ψ_a = λ_j),
/// plus the flows' load c_x, c_y, c_rot (x − x_T)^⊥ about the cell's anchor x_T (design §5.10).
#[allow(clippy::too_many_arguments)]
#[inline]
fn add_load_moments(
    ctx: &Context,
    u: &[[f64; 2]],
    nodes: &[u32],
    sp: &SubPoint,
    wq: f64,
    xi: [f64; 2],
    j: usize,
    extra: Option<&Extra>,
    xt: [f64; 2],
    g: &mut [[f64; MAX_MOMENTS]; 2],
) {
    let w = wq * sp.jac.det;
    let gu = sp.gradient_at(nodes, u);
    let sym = 0.5 * (gu[0][1] + gu[1][0]);
    let eps = [gu[0][0], sym, sym, gu[1][1]];
    let sig = ctx.elastic.stress(eps);
    let lam = [1.0 - xi[0] - xi[1], xi[0], xi[1]];
    let glam = [[-1.0, -1.0], [1.0, 0.0], [0.0, 1.0]];
    let psi = lam[j];
    let gpsi = sp.jac.physical_gradient(glam[j]);
    let f = match ctx.scene.body_force.as_ref() {
        None => [0.0; 2],
        Some(fe) => [
            fe[0].eval(sp.x[0], sp.x[1], 0.0),
            fe[1].eval(sp.x[0], sp.x[1], 0.0),
        ],
    };
    let mut target = [
        -psi * f[0] + sig[0] * gpsi[0] + sig[1] * gpsi[1],
        -psi * f[1] + sig[2] * gpsi[0] + sig[3] * gpsi[1],
    ];
    if let Some(ex) = extra {
        let d = sp.from(xt);
        target[0] += ex[0] - ex[2] * d[1];
        target[1] += ex[1] + ex[2] * d[0];
    }
    let qv = condense::test_monomials(xi);
    for r in 0..2 {
        for (gq, qq) in g[r].iter_mut().zip(&qv) {
            *gq += w * target[r] * qq;
        }
    }
}

/// The weak-symmetry row ∫_T (τ_xy − τ_yx) over the local functions (row 0: τ_xy at i, row 1:
/// −τ_yx at nloc + i), exact: J is linear in ξ (condense.rs's mean values at the vertices).
fn symmetry_row(
    re: &condense::Reference,
    fam: Family,
    x: &[[f64; 2]],
    sh: Shape,
) -> [f64; 2 * MAX_RT_DOFS] {
    let jv = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]].map(|xi| sub_jacobian(fam, x, sh, 0, xi).matrix);
    let mut row = [0.0; 2 * MAX_RT_DOFS];
    for i in 0..re.nloc {
        let [a, b] = condense::mean_value(re, jv, i);
        row[i] = b;
        row[re.nloc + i] = -a;
    }
    row
}

/// The local constant c₀ = T ē₀ + t₀ of a patch cell (condense.rs), local index r·nloc + i:
/// the edge constants `ec` (row r, local edge DOF), and the interior values D_I⁺g plus the
/// edge constants' share through T.
fn cell_constant(
    re: &condense::Reference,
    ec: &[[f64; MAX_EDGE_DOFS]; 2],
    g: &[[f64; MAX_MOMENTS]; 2],
) -> [f64; 2 * MAX_RT_DOFS] {
    let (nloc, nedge, nred, nq) = (re.nloc, re.nedge, re.nred, re.nq);
    let mut c0 = [0.0; 2 * MAX_RT_DOFS];
    for r in 0..2 {
        c0[r * nloc..r * nloc + nedge].copy_from_slice(&ec[r][..nedge]);
        for i in 0..re.nint {
            let mut v: f64 = (0..nq).map(|q| re.pinv[i * nq + q] * g[r][q]).sum();
            let row = &re.transform[(nedge + i) * nred..(nedge + i) * nred + nedge];
            for (t, c) in row.iter().zip(&ec[r][..nedge]) {
                v += t * c;
            }
            c0[r * nloc + nedge + i] = v;
        }
    }
    c0
}

/// e_x, e_y and (x − x₀)^⊥/L of a straight cell with vertices x[0..3] in the moments 1, ξ, η
/// per row (the flows' rigid motions, `reconstruct`).
fn rigid_moments(x: &[[f64; 2]], x0: [f64; 2], length: f64) -> [[[f64; 3]; 2]; 3] {
    let (p0, p1, p2) = (x[0], x[1], x[2]);
    let (dx1, dx2) = (
        [p1[0] - p0[0], p1[1] - p0[1]],
        [p2[0] - p0[0], p2[1] - p0[1]],
    );
    [
        [[1.0, 0.0, 0.0], [0.0; 3]],
        [[0.0; 3], [1.0, 0.0, 0.0]],
        [
            [
                -(p0[1] - x0[1]) / length,
                -dx1[1] / length,
                -dx2[1] / length,
            ],
            [(p0[0] - x0[0]) / length, dx1[0] / length, dx2[0] / length],
        ],
    ]
}

/// Adds a cell's share of its patch's rigid-motion balance, −Σ rigid_i · (D c − g) (flow.rs's
/// e_a), and of the magnitudes of its terms. Returns the cell's largest |D c − g| and the
/// largest Σ|terms| + |g| (the patch defect's measure).
fn add_cell_balance(
    re: &condense::Reference,
    c: &[[f64; MAX_RT_DOFS]; 2],
    g: &[[f64; MAX_MOMENTS]; 2],
    rigid: &[[[f64; 3]; 2]; 3],
    balance: &mut [f64; 3],
    balance_scale: &mut [f64; 3],
) -> (f64, f64) {
    let (nloc, nq) = (re.nloc, re.nq);
    let (mut worst, mut scale) = (0.0f64, 0.0f64);
    let mut res = [[0.0; MAX_MOMENTS]; 2];
    for r in 0..2 {
        for q in 0..nq {
            let (mut dc, mut abs) = (0.0, 0.0);
            for (d, ci) in re.div[q * nloc..(q + 1) * nloc].iter().zip(&c[r]) {
                let v = d * ci;
                dc += v;
                abs += v.abs();
            }
            res[r][q] = dc - g[r][q];
            worst = worst.max(res[r][q].abs());
            scale = scale.max(abs + g[r][q].abs());
        }
    }
    for ((bi, bs), ci) in balance.iter_mut().zip(balance_scale.iter_mut()).zip(rigid) {
        for (r, cr) in ci.iter().enumerate() {
            for (q, &cq) in cr.iter().enumerate() {
                if cq != 0.0 {
                    *bi -= cq * res[r][q];
                    *bs += (cq * res[r][q]).abs();
                }
            }
        }
    }
    (worst, scale)
}

/// σ_T = Cε(u_h) of every cell at its centroid (constant on P1 cells), once for the rotation
/// shares of the cell and of its three neighbours.
fn p1_cell_stresses(ctx: &Context, u: &[[f64; 2]]) -> Vec<[f64; 4]> {
    let mesh = ctx.mesh;
    (0..mesh.len())
        .into_par_iter()
        .with_min_len(1024)
        .map(|c| {
            let fam = mesh.family[c];
            let x = mesh.coords(c);
            let sp = sub_point(fam, &x[..fam.nodes()], mesh.shape[c], 0, [1.0 / 3.0; 2]);
            let gu = sp.gradient_at(mesh.nodes(c), u);
            let sym = 0.5 * (gu[0][1] + gu[1][0]);
            ctx.elastic.stress([gu[0][0], sym, sym, gu[1][1]])
        })
        .collect()
}

/// True when u_h is open (g − u_n > `gap_tolerance`, `OPEN_GAP_RELATIVE` of max |u_h| on Γ_C) at every one of `EDGE_OPEN_SAMPLES`
/// points of the contact edge `be`, ends included.
fn contact_edge_is_open(
    ctx: &Context,
    u: &[[f64; 2]],
    be: &crate::problem::BoundaryEdge,
    gap_tolerance: f64,
) -> bool {
    let Condition::Contact(b) = be.condition else {
        return false;
    };
    let BoundaryKind::Contact(spec) = &ctx.scene.boundaries[b].kind else {
        return false;
    };
    let mesh = ctx.mesh;
    let t = be.cell as usize;
    let fam = mesh.family[t];
    let x = mesh.coords(t);
    let nodes = mesh.nodes(t);
    (0..EDGE_OPEN_SAMPLES).all(|i| {
        let s = i as f64 / (EDGE_OPEN_SAMPLES - 1) as f64;
        let (sp, normal, _, _) = sub_edge_point(
            fam,
            &x[..fam.nodes()],
            mesh.shape[t],
            0,
            be.local as usize,
            s,
        );
        let cn = spec.direction(normal);
        let uu = sp.value_at(nodes, u);
        let gap = spec.gap_at(sp.x, cn);
        gap.is_finite() && gap - (cn[0] * uu[0] + cn[1] * uu[1]) > gap_tolerance
    })
}

/// The cell shares α_{a,T} of the rotation moments of the P1 patch loads, for the three
/// vertices a of cell `t` (docs/design.md §5.10, "Weak symmetry on P1"): with ρ_a = (x − x_a)^⊥,
///
/// ```text
/// α_{a,T} = −∫_T ψ_a f·ρ_a + Σ_{E ⊂ ∂T interior, E ∋ a} ½ ∫_E ψ_a (σ_T − σ_T′) n_T·ρ_a,
/// ```
///
/// σ = Cε(u_h) (constant per P1 cell). They sum to 0 over the vertices of T (Σ_a ψ_a ρ_a = 0
/// and σ symmetric), and over the cells of a patch to the rotation moment ∫ target·ρ_a − the
/// patch's boundary fluxes ψ_a σ_T n·ρ_a, so the symmetry rows ∫_T as τ_a = α_{a,T} make the
/// rotation balance of every patch hold up to its boundary-data mismatch, without the Galerkin
/// property for ψ_a ρ (not in the P1 space) and without moving rotation moments far.
/// `stress` holds σ_T = Cε(u_h) per cell ([`p1_cell_stresses`]).
fn rotation_shares(
    ctx: &Context,
    u: &[[f64; 2]],
    stress: &[[f64; 4]],
    condition: &[Option<Condition>],
    gap_tolerance: f64,
    t: usize,
) -> [f64; 3] {
    let mesh = ctx.mesh;
    let topo = ctx.topo;
    let stress_of = |c: usize| stress[c];
    let fam = mesh.family[t];
    let x = mesh.coords(t);
    let v = [x[0], x[1], x[2]];
    let mut alpha = [0.0; 3];
    if let Some(fe) = ctx.scene.body_force.as_ref() {
        let constant = fe[0].is_constant() && fe[1].is_constant();
        let rule = triangle_rule_cached(if constant { 2 } else { LOAD_DEGREE });
        for (&xi, &wq) in rule.points.iter().zip(&rule.weights) {
            let sp = sub_point(fam, &x[..fam.nodes()], mesh.shape[t], 0, xi);
            let w = wq * sp.jac.det;
            let f = [
                fe[0].eval(sp.x[0], sp.x[1], 0.0),
                fe[1].eval(sp.x[0], sp.x[1], 0.0),
            ];
            let lam = [1.0 - xi[0] - xi[1], xi[0], xi[1]];
            for j in 0..3 {
                let d = sp.from(v[j]);
                let rho = [-d[1], d[0]];
                alpha[j] -= w * lam[j] * (f[0] * rho[0] + f[1] * rho[1]);
            }
        }
    }
    let s_t = stress_of(t);
    for l in 0..3 {
        let e = topo.cell_edges[t][l] as usize;
        let [c0, c1] = topo.edge_cells[e];
        let other = if c0 as usize == t { c1 } else { c0 };
        let (p, q, r) = (v[l], v[(l + 1) % 3], v[(l + 2) % 3]);
        // Outward normal times |E|: the edge vector turned away from the third vertex.
        let mut n = [q[1] - p[1], p[0] - q[0]];
        if n[0] * (r[0] - p[0]) + n[1] * (r[1] - p[1]) > 0.0 {
            n = [-n[0], -n[1]];
        }
        let sn = [s_t[0] * n[0] + s_t[1] * n[1], s_t[2] * n[0] + s_t[3] * n[1]];
        // (σ_T − ḡ)n|E| with a flux ḡ common to the edge's vertices (so the shares of T still
        // sum to 0): the mean of the two cells inside, the patch's own boundary flux outside
        // (t on Neumann, 0 on free edges, the normal part on frictionless contact, anything
        // on Dirichlet edges, whose patches take any load).
        let len = n[0].hypot(n[1]);
        let un = [n[0] / len, n[1] / len];
        let mut traction: Option<&[crate::expr::Expr; 2]> = None;
        let jump = if other != NONE {
            let s_o = stress_of(other as usize);
            let d = [
                s_t[0] - s_o[0],
                s_t[1] - s_o[1],
                s_t[2] - s_o[2],
                s_t[3] - s_o[3],
            ];
            [
                0.5 * (d[0] * n[0] + d[1] * n[1]),
                0.5 * (d[2] * n[0] + d[3] * n[1]),
            ]
        } else {
            match condition[e].unwrap_or(Condition::Free) {
                Condition::Free => sn,
                Condition::Dirichlet(_) => [0.0; 2],
                Condition::Neumann(b) => {
                    if let BoundaryKind::Neumann { traction: tr } = &ctx.scene.boundaries[b].kind {
                        traction = Some(tr);
                    }
                    sn
                }
                Condition::Contact(b) => {
                    let BoundaryKind::Contact(spec) = &ctx.scene.boundaries[b].kind else {
                        continue;
                    };
                    // ḡ: the traction of u_h made admissible (compressive, inside the cone)
                    // where u_h is in contact (at each end, closed within OPEN_GAP_RELATIVE), none
                    // where the gap is open: a share the patch cannot meet with its
                    // constrained flux would be paid in the complementarity pairing (Hertz P1:
                    // c = 0.045 with the pressure on every contact edge, 3e-6 with this; the
                    // manufactured family needs it in its contact zone).
                    let cn = spec.direction(un);
                    let ct = [-cn[1], cn[0]];
                    let closed = |x: [f64; 2], node: u32| {
                        let un = u[node as usize][0] * cn[0] + u[node as usize][1] * cn[1];
                        spec.gap_at(x, cn) - un <= gap_tolerance
                    };
                    let nodes = mesh.nodes(t);
                    let theta = 0.5
                        * (f64::from(u8::from(closed(p, nodes[l])))
                            + f64::from(u8::from(closed(q, nodes[(l + 1) % 3]))));
                    let snn = (sn[0] * cn[0] + sn[1] * cn[1]).min(0.0);
                    let cone = spec.friction * snn.abs();
                    let stt = (sn[0] * ct[0] + sn[1] * ct[1]).clamp(-cone, cone);
                    [
                        sn[0] - theta * (snn * cn[0] + stt * ct[0]),
                        sn[1] - theta * (snn * cn[1] + stt * ct[1]),
                    ]
                }
            }
        };
        // ∫_E ψ_a (x − x_a)^⊥ ds = |E|/6 (x_b − x_a)^⊥ (|E| is in n).
        for (a, b, j) in [(p, q, l), (q, p, (l + 1) % 3)] {
            let perp = [-(b[1] - a[1]), b[0] - a[0]];
            alpha[j] += (jump[0] * perp[0] + jump[1] * perp[1]) / 6.0;
        }
        // − ∫_E ψ_a t·(x − x_a)^⊥ ds on a Neumann edge, by Gauss–Legendre.
        if let Some(tr) = traction {
            let rule = crate::quadrature::line_rule_cached(LOAD_DEGREE);
            for (&sg, &wg) in rule.points.iter().zip(&rule.weights) {
                let xs = [p[0] + sg * (q[0] - p[0]), p[1] + sg * (q[1] - p[1])];
                let tv = [tr[0].eval(xs[0], xs[1], 0.0), tr[1].eval(xs[0], xs[1], 0.0)];
                // x − x_a from differences of nearby points (SubPoint::from).
                let along = [sg * (q[0] - p[0]), sg * (q[1] - p[1])];
                for (a, j, psi) in [(p, l, 1.0 - sg), (q, (l + 1) % 3, sg)] {
                    let d = [along[0] + (p[0] - a[0]), along[1] + (p[1] - a[1])];
                    let rho = [-d[1], d[0]];
                    alpha[j] -= wg * len * psi * (tv[0] * rho[0] + tv[1] * rho[1]);
                }
            }
        }
    }
    alpha
}

/// The defect of a patch that was not solved: max |balance| relative to its terms (a balanced
/// patch without inequalities is solvable, design §5.10).
fn relative_balance(balance: [f64; 3], scale: f64) -> f64 {
    let b = balance.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    if scale > 0.0 { b / scale } else { 0.0 }
}

/// A symmetry row applied to a cell's coefficients (rows r = 0, 1, local functions i < nloc):
/// Σ row[r·nloc + i] c[r][i], and the sum of the magnitudes of its terms (its round-off scale).
fn row_value(row: &[f64; 2 * MAX_RT_DOFS], c: &[[f64; MAX_RT_DOFS]; 2], nloc: usize) -> (f64, f64) {
    let (mut value, mut terms) = (0.0, 0.0);
    for (r, cr) in c.iter().enumerate() {
        for (i, ci) in cr.iter().enumerate().take(nloc) {
            let v = row[r * nloc + i] * ci;
            value += v;
            terms += v.abs();
        }
    }
    (value, terms)
}

/// The rows ∫_T (τ_xy − τ_yx) q̂ dx over the local functions of both rows (row 0: τ_xy, row 1:
/// −τ_yx), q̂ = ξ − ⅓ and η − ⅓. With φ = Jφ̂/det J and dx = det J dξ the integrand is
/// (Jφ̂)_s q̂: on a straight cell J is constant and the moments ∫_T̂ q̂ φ̂ of condense.rs give the
/// rows exactly; on a curved one J is linear in ξ and a rule of degree k + 3 is exact.
pub(super) fn higher_symmetry_rows(
    re: &condense::Reference,
    order: RtOrder,
    fam: crate::geometry::Family,
    x: &[[f64; 2]],
    sh: Shape,
) -> [[f64; 2 * MAX_RT_DOFS]; 2] {
    let nloc = re.nloc;
    let mut out = [[0.0; 2 * MAX_RT_DOFS]; 2];
    // ∫_T̂ J φ̂_i q̂ for the two q̂, as [q][i][component].
    let mut m = [[[0.0; 2]; MAX_RT_DOFS]; 2];
    if sh == Shape::Affine {
        let j = sub_jacobian(fam, x, sh, 0, [1.0 / 3.0; 2]).matrix;
        for (i, [m0, mx, my]) in re.first.iter().enumerate().take(nloc) {
            for (q, mq) in [mx, my].into_iter().enumerate() {
                let v = [mq[0] - m0[0] / 3.0, mq[1] - m0[1] / 3.0];
                m[q][i] = [
                    j[0][0] * v[0] + j[0][1] * v[1],
                    j[1][0] * v[0] + j[1][1] * v[1],
                ];
            }
        }
    } else {
        let rule = triangle_rule_cached(order.k() + 3);
        for (&xi, &w) in rule.points.iter().zip(&rule.weights) {
            let j = sub_jacobian(fam, x, sh, 0, xi).matrix;
            let (v, _) = rt::reference(order, xi);
            let q = [xi[0] - 1.0 / 3.0, xi[1] - 1.0 / 3.0];
            for i in 0..nloc {
                let jv = [
                    j[0][0] * v[i][0] + j[0][1] * v[i][1],
                    j[1][0] * v[i][0] + j[1][1] * v[i][1],
                ];
                for qq in 0..2 {
                    m[qq][i][0] += w * q[qq] * jv[0];
                    m[qq][i][1] += w * q[qq] * jv[1];
                }
            }
        }
    }
    for q in 0..2 {
        for i in 0..nloc {
            out[q][i] = m[q][i][1];
            out[q][nloc + i] = -m[q][i][0];
        }
    }
    out
}

/// A local edge DOF of a patch cell: slot `slot` of the patch's edge `pos` (its expression in
/// the patch unknowns, in the edge's global orientation), negated when the cell runs the edge
/// backwards (sign −1 of `rt::local_to_global_edge`). A reference, not a scaled copy of the
/// expression: those copies were ~17 % of a balance-only patch's time (1M P2 bench), and
/// negation is exact, so the products are the same bits.
#[derive(Clone, Copy, Default)]
struct EdgeRef {
    pos: u16,
    slot: u8,
    negative: bool,
}

impl EdgeRef {
    /// The expression (row r) and the sign ±1 it enters with.
    fn of(self, edge_vals: &[[[Lin; 3]; 2]], r: usize) -> (&Lin, f64) {
        let sign = if self.negative { -1.0 } else { 1.0 };
        (&edge_vals[self.pos as usize][r][self.slot as usize], sign)
    }

    /// The expression's constant, signed.
    fn constant(self, edge_vals: &[[[Lin; 3]; 2]], r: usize) -> f64 {
        let (lin, sign) = self.of(edge_vals, r);
        sign * lin.c
    }
}

/// A reduced local unknown that reaches patch unknowns: its index, their terms and its sign.
type Reach<'a> = (usize, &'a [(u32, f64)], f64);

/// One cell of a patch, kept from assembly to the recovery of its coefficients.
struct CellPart {
    t: u32,
    /// Local edge DOF (row r, e < 3(k+1)) → affine expression in the patch unknowns.
    emap: [[EdgeRef; MAX_EDGE_DOFS]; 2],
    /// c₀ = T ē₀ + t₀ per row (condense.rs), local index r·nloc + i.
    c0: [f64; 2 * MAX_RT_DOFS],
    /// The divergence rows' right-hand sides ∫ target_r q̂ (row r, moment q).
    g: [[f64; MAX_MOMENTS]; 2],
    /// The weak-symmetry row ∫_T (τ_xy − τ_yx) over the local functions.
    srow: [f64; 2 * MAX_RT_DOFS],
    /// The higher weak-symmetry rows ∫_T (τ_xy − τ_yx) q̂ for q̂ = ξ − ⅓, η − ⅓ (right-hand
    /// side 0), imposed with RT_2 unless the patch cannot meet them ([`solve_patch`]).
    shi: [[f64; 2 * MAX_RT_DOFS]; 2],
    /// Its right-hand side: the rotation moment this patch carries on T for its neighbours
    /// (the flows' as-moments; 0 without flows).
    asym: f64,
    /// First patch unknown of the cell's free interior values (row r at + r·nz), unless
    /// they are eliminated.
    kernel: usize,
    /// The free interior values as functions of the edge values (`eliminate_kernel`).
    eliminated: Option<KernelMap>,
    /// e_x, e_y, (x − x₀)^⊥/L in the moments 1, ξ, η per row (exact on straight cells).
    rigid: [[[f64; 3]; 2]; 3],
}

/// Whether a straight cell with Jacobian `j` has cond(J) ≤ [`KERNEL_ELIMINATION_CONDITION`]:
/// with σ₁ ≥ σ₂ its singular values, ‖J‖²_F/|det J| = σ₁/σ₂ + σ₂/σ₁ = cond + 1/cond.
fn well_shaped(j: [[f64; 2]; 2]) -> bool {
    let det = j[0][0] * j[1][1] - j[0][1] * j[1][0];
    let frob = j[0][0] * j[0][0] + j[0][1] * j[0][1] + j[1][0] * j[1][0] + j[1][1] * j[1][1];
    let c = KERNEL_ELIMINATION_CONDITION;
    frob <= (c + 1.0 / c) * det.abs()
}

/// A cell's free interior values (one per row, nz = 1) as affine functions of its reduced
/// edge values: y_k,r = Σ_a map[r][a] y_a + constant[r] (a over both rows, kernel slots 0).
#[derive(Clone, Copy)]
struct KernelMap {
    map: [[f64; 2 * MAX_REDUCED]; 2],
    constant: [f64; 2],
}

/// Eliminates the free interior values y_k (one per row) of a cell through its two P_1
/// weak-symmetry rows: with those rows g_q·y = d_q in the reduced unknowns y = (y_e, y_k) and
/// H = their y_k columns (2 × 2), y_k = K y_e + k_c with K = −H⁻¹G_e and k_c = H⁻¹d. On a
/// straight cell H = −(∫_T b)(∇q̂ components), b the cubic bubble whose curl the free value
/// is, so H is regular on every non-degenerate cell. With y = P y_e + p₀ the cell's reduced
/// objective ½yᵀMy − bᵀy becomes ½y_eᵀ(PᵀMP)y_e − (Pᵀ(b − Mp₀))ᵀy_e + const, written over
/// `mred` and `bred` with the y_k rows and columns zeroed. The other rows of the cell (the
/// kept divergence rows, the constant symmetry row) have exact zeros in the y_k columns
/// (condense.rs), so they are unchanged. None when H is singular to round-off.
// Index loops over (row, reduced unknown) mirror the formulas above.
#[allow(clippy::needless_range_loop)]
fn eliminate_kernel(
    re: &condense::Reference,
    shi: &[[f64; 2 * MAX_RT_DOFS]; 2],
    c0: &[f64],
    mred: &mut [f64],
    bred: &mut [f64],
) -> Option<KernelMap> {
    let (nred, nedge) = (re.nred, re.nedge);
    let nr = 2 * nred;
    let kc = [nedge, nred + nedge];
    let mut g = [[0.0; 2 * MAX_REDUCED]; 2];
    let mut d = [0.0; 2];
    for q in 0..2 {
        condense::symmetry_row_reduced(re, &shi[q][..], false, &mut g[q]);
        d[q] = -shi[q][..c0.len()]
            .iter()
            .zip(c0)
            .map(|(a, b)| a * b)
            .sum::<f64>();
    }
    let h = [[g[0][kc[0]], g[0][kc[1]]], [g[1][kc[0]], g[1][kc[1]]]];
    let det = h[0][0] * h[1][1] - h[0][1] * h[1][0];
    let scale = h.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
    if !(det.abs() > KERNEL_PIVOT_RELATIVE * scale * scale && det.is_finite()) {
        return None;
    }
    let hinv = [
        [h[1][1] / det, -h[0][1] / det],
        [-h[1][0] / det, h[0][0] / det],
    ];
    let mut k = KernelMap {
        map: [[0.0; 2 * MAX_REDUCED]; 2],
        constant: [0.0; 2],
    };
    for s in 0..2 {
        k.constant[s] = hinv[s][0] * d[0] + hinv[s][1] * d[1];
        for a in (0..nr).filter(|a| !kc.contains(a)) {
            k.map[s][a] = -(hinv[s][0] * g[0][a] + hinv[s][1] * g[1][a]);
        }
    }
    // b − M p₀ (p₀ = k_c in the y_k slots), from the original y_k columns.
    let mut bc = [0.0; 2 * MAX_REDUCED];
    for i in 0..nr {
        bc[i] =
            bred[i] - mred[i * nr + kc[0]] * k.constant[0] - mred[i * nr + kc[1]] * k.constant[1];
    }
    // M P (columns), then Pᵀ (M P) (rows). The map is 0 at the y_k slots, so the column
    // update leaves the y_k columns as they were; the row update runs over all columns
    // (branch-free), and what it adds to the y_k columns is zeroed below.
    for i in 0..nr {
        let (m0, m1) = (mred[i * nr + kc[0]], mred[i * nr + kc[1]]);
        let row = &mut mred[i * nr..(i + 1) * nr];
        for ((v, a), b) in row.iter_mut().zip(&k.map[0][..nr]).zip(&k.map[1][..nr]) {
            *v += m0 * a + m1 * b;
        }
    }
    let kernel_row = |c: usize| -> [f64; 2 * MAX_REDUCED] {
        std::array::from_fn(|b| if b < nr { mred[c * nr + b] } else { 0.0 })
    };
    let (k0row, k1row) = (kernel_row(kc[0]), kernel_row(kc[1]));
    for a in (0..nr).filter(|a| !kc.contains(a)) {
        let (k0, k1) = (k.map[0][a], k.map[1][a]);
        let row = &mut mred[a * nr..(a + 1) * nr];
        for ((v, p), q) in row.iter_mut().zip(&k0row[..nr]).zip(&k1row[..nr]) {
            *v += k0 * p + k1 * q;
        }
    }
    for a in (0..nr).filter(|a| !kc.contains(a)) {
        bred[a] = bc[a] + k.map[0][a] * bc[kc[0]] + k.map[1][a] * bc[kc[1]];
    }
    for &c in &kc {
        for i in 0..nr {
            mred[i * nr + c] = 0.0;
            mred[c * nr + i] = 0.0;
        }
        bred[c] = 0.0;
    }
    Some(k)
}

#[inline]
fn dot4(a: [f64; 4], b: [f64; 4]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `geometric_order` depends on the positions alone: a cloud without symmetry (a sheared,
    /// unevenly filled ellipse) ordered after its points are renumbered, or turned by 107° and
    /// moved, visits the same positions in the same sequence.
    #[test]
    fn geometric_order_follows_the_positions_not_the_numbering_or_the_frame() {
        // A fixed pseudo-random cloud (linear congruential), denser on one side.
        let mut next = crate::testing::uniform(12345);
        let points: Vec<[f64; 2]> = (0..400)
            .map(|_| {
                let (r, a) = (
                    next().powf(0.7),
                    2.0 * std::f64::consts::PI * next().powi(2),
                );
                [3.0 * r * a.cos() + 0.5 * r * a.sin(), r * a.sin()]
            })
            .collect();
        let n = points.len();
        let base = geometric_order(&points, (0..n).collect(), None);
        // Renumbered: new index of old point i is (7i + 3) mod n (7 and 400 are coprime).
        let new_of = |i: usize| (7 * i + 3) % n;
        let mut renumbered = vec![[0.0; 2]; n];
        for (i, p) in points.iter().enumerate() {
            renumbered[new_of(i)] = *p;
        }
        let order = geometric_order(&renumbered, (0..n).collect(), None);
        let expected: Vec<usize> = base.iter().map(|&i| new_of(i)).collect();
        assert_eq!(order, expected);
        // Turned by 107° and moved.
        let (c, s) = (107f64.to_radians().cos(), 107f64.to_radians().sin());
        let turned: Vec<[f64; 2]> = points
            .iter()
            .map(|p| [c * p[0] - s * p[1] + 5.0, s * p[0] + c * p[1] - 2.0])
            .collect();
        assert_eq!(geometric_order(&turned, (0..n).collect(), None), base);
    }

    /// Eliminating a cell's two free interior values through its two P_1 symmetry rows
    /// (`eliminate_kernel`) must give the minimiser of the problem with those values free and
    /// the rows as equality constraints: a random SPD reduced matrix and load on a straight
    /// cell, with the cell's real rows (`higher_symmetry_rows`), both problems solved by the
    /// patch QP.
    #[test]
    fn eliminated_free_values_give_the_constrained_minimiser() {
        let re = condense::reference(RtOrder::Rt2);
        let (nloc, nred, nedge) = (re.nloc, re.nred, re.nedge);
        assert_eq!(re.nz, 1, "RT_2 has one free interior value per row");
        let nr = 2 * nred;
        let kc = [nedge, nred + nedge];
        let x = [[0.1, -0.2], [1.3, 0.2], [0.4, 0.9]];
        let shi = higher_symmetry_rows(re, RtOrder::Rt2, Family::Tri3, &x, Shape::Affine);
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut rand = move || {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        // M = AᵀA + I (SPD), b and c₀ random.
        let a: Vec<f64> = (0..nr * nr).map(|_| rand()).collect();
        let mut m = vec![0.0; nr * nr];
        for i in 0..nr {
            for j in 0..nr {
                m[i * nr + j] = (0..nr).map(|k| a[k * nr + i] * a[k * nr + j]).sum::<f64>()
                    + if i == j { 1.0 } else { 0.0 };
            }
        }
        let b: Vec<f64> = (0..nr).map(|_| rand()).collect();
        let c0: Vec<f64> = (0..2 * nloc).map(|_| rand()).collect();
        let mut rows = vec![0.0; 2 * nr];
        let mut d = [0.0; 2];
        for q in 0..2 {
            condense::symmetry_row_reduced(re, &shi[q][..], false, &mut rows[q * nr..]);
            d[q] = -shi[q][..2 * nloc]
                .iter()
                .zip(&c0)
                .map(|(s, c)| s * c)
                .sum::<f64>();
        }
        for q in 0..2 {
            assert!(
                kc.iter().all(|&c| rows[q * nr + c] != 0.0),
                "rows reach the free values"
            );
        }
        let full = qp::solve(nr, &m, &b, &rows, &d, 2, &[]);
        assert!(full.feasible && full.settled);
        let (mut me, mut be) = (m.clone(), b.clone());
        let k = eliminate_kernel(re, &shi, &c0, &mut me, &mut be).expect("a regular cell");
        for &c in &kc {
            assert!((0..nr).all(|i| me[i * nr + c] == 0.0 && me[c * nr + i] == 0.0));
            assert_eq!(be[c], 0.0);
            // A placeholder unknown (solved as 0) keeps the eliminated matrix regular.
            me[c * nr + c] = 1.0;
        }
        let red = qp::solve(nr, &me, &be, &[], &[], 0, &[]);
        let mut y = red.x.clone();
        for r in 0..2 {
            y[kc[r]] = k.constant[r] + (0..nr).map(|i| k.map[r][i] * red.x[i]).sum::<f64>();
        }
        let scale = full.x.iter().fold(0.0f64, |s, v| s.max(v.abs()));
        for (i, (yi, xi)) in y.iter().zip(&full.x).enumerate() {
            assert!(
                (yi - xi).abs() <= 1e-10 * scale,
                "unknown {i}: eliminated {yi} against {xi}"
            );
        }
        for q in 0..2 {
            let g: f64 = (0..nr).map(|i| rows[q * nr + i] * y[i]).sum();
            assert!(
                (g - d[q]).abs() <= 1e-12 * (1.0 + d[q].abs()),
                "row {q}: {g} ≠ {}",
                d[q]
            );
        }
    }

    /// The rotation shares of a P1 fixture with body force, Neumann, contact and Dirichlet
    /// edges: (1) they sum to 0 over each cell's vertices (Σ_a ψ_a (x − x_a)^⊥ = 0 pointwise and
    /// σ symmetric); (2) at an interior vertex a they sum over the patch to ∫_{ω_a} target·ρ_a,
    /// target = −ψ_a f + Cε(u_h)∇ψ_a, integrated here directly (the shares use the divergence
    /// theorem and the flux jumps instead).
    #[test]
    fn rotation_shares_cancel_per_cell_and_carry_the_patch_moment() {
        let fx = crate::problem::fixture("manufactured_frictionless_p1_n08");
        let (topo, scene, edges) = (&fx.topo, &fx.scene, &fx.edges);
        let ctx = fx.context(crate::read::scene::Norm::Energy);
        let u = fx.displacement();
        let mesh = ctx.mesh;
        let mut condition: Vec<Option<Condition>> = vec![None; topo.edges.len()];
        for be in edges {
            condition[be.edge as usize] = Some(be.condition);
        }
        let stress = p1_cell_stresses(&ctx, &u);
        let shares: Vec<[f64; 3]> = (0..mesh.len())
            .map(|t| rotation_shares(&ctx, &u, &stress, &condition, 0.0, t))
            .collect();
        let mut largest = 0.0f64;
        for sh in &shares {
            let abs: f64 = sh.iter().map(|a| a.abs()).sum();
            largest = largest.max(abs);
            assert!(
                (sh[0] + sh[1] + sh[2]).abs() <= 1e-12 * abs.max(1e-300),
                "{sh:?}"
            );
        }
        assert!(largest > 0.0);
        let mut boundary = vec![false; mesh.points.len()];
        for &[a, b] in topo
            .edges
            .iter()
            .enumerate()
            .filter(|(e, _)| topo.is_boundary(*e))
            .map(|(_, ab)| ab)
        {
            boundary[a as usize] = true;
            boundary[b as usize] = true;
        }
        let fe = scene.body_force.as_ref().expect("a body force");
        let rule = triangle_rule_cached(LOAD_DEGREE);
        let mut checked = 0;
        for (a, &on_boundary) in boundary.iter().enumerate() {
            if on_boundary {
                continue;
            }
            let (mut from_shares, mut direct, mut scale) = (0.0, 0.0, 0.0f64);
            for (t, share) in shares.iter().enumerate() {
                let Some(j) = mesh.nodes(t)[..3].iter().position(|&v| v as usize == a) else {
                    continue;
                };
                from_shares += share[j];
                let fam = mesh.family[t];
                let x = mesh.coords(t);
                let xa = x[j];
                for (&xi, &wq) in rule.points.iter().zip(&rule.weights) {
                    let sp = sub_point(fam, &x[..fam.nodes()], mesh.shape[t], 0, xi);
                    let w = wq * sp.jac.det;
                    let gu = sp.gradient_at(mesh.nodes(t), &u);
                    let sym = 0.5 * (gu[0][1] + gu[1][0]);
                    let sig = ctx.elastic.stress([gu[0][0], sym, sym, gu[1][1]]);
                    let lam = [1.0 - xi[0] - xi[1], xi[0], xi[1]];
                    let glam = [[-1.0, -1.0], [1.0, 0.0], [0.0, 1.0]];
                    let g = sp.jac.physical_gradient(glam[j]);
                    let f = [
                        fe[0].eval(sp.x[0], sp.x[1], 0.0),
                        fe[1].eval(sp.x[0], sp.x[1], 0.0),
                    ];
                    let target = [
                        -lam[j] * f[0] + sig[0] * g[0] + sig[1] * g[1],
                        -lam[j] * f[1] + sig[2] * g[0] + sig[3] * g[1],
                    ];
                    let d = sp.from(xa);
                    let rho = [-d[1], d[0]];
                    direct += w * (target[0] * rho[0] + target[1] * rho[1]);
                    scale += w * (target[0].abs() + target[1].abs()) * rho[0].hypot(rho[1]);
                }
            }
            assert!(
                (from_shares - direct).abs() <= 1e-11 * scale,
                "vertex {a}: shares {from_shares}, direct {direct} (scale {scale})"
            );
            checked += 1;
        }
        assert!(checked > 20, "{checked} interior vertices");
    }

    /// The P_1 weak symmetry of the sum: with RT_2 every cell of a P2 and of a P1 fixture has
    /// ∫_T as σ_h q = 0 for q = 1, ξ − ⅓, η − ⅓ (integrated here by a rule of degree 8 from the
    /// RT field, not from the patch rows), relative to ∫_T |σ_h|; and the rows are not void:
    /// the quadratic moment ∫_T as σ_h (ξ − ⅓)² is not zero on most cells.
    #[test]
    fn patch_stress_is_weakly_symmetric_against_linear_functions() {
        for case in [
            "manufactured_frictionless_p2_n08",
            "manufactured_frictionless_p1_n08",
        ] {
            let fx = crate::problem::fixture(case);
            let ctx = fx.context(crate::read::scene::Norm::Energy);
            let u = fx.displacement();
            let rec = reconstruct(&ctx, &u, RtOrder::Rt2).expect("a reconstruction");
            assert_eq!(rec.info.incompatible, 0, "{case}");
            let mesh = ctx.mesh;
            let rule = triangle_rule_cached(8);
            let (mut quadratic, mut violated) = (0usize, 0usize);
            for t in 0..mesh.len() {
                let fam = mesh.family[t];
                let x = mesh.coords(t);
                let (mut m, mut q2, mut scale) = ([0.0; 3], 0.0, 0.0);
                for (&xi, &wq) in rule.points.iter().zip(&rule.weights) {
                    let sp = sub_point(fam, &x[..fam.nodes()], mesh.shape[t], 0, xi);
                    let w = wq * sp.jac.det;
                    let (sg, _) = rec.stress.at(rec.stress.first[t] as usize, &sp.jac, xi);
                    let a = sg[1] - sg[2];
                    let (p, q) = (xi[0] - 1.0 / 3.0, xi[1] - 1.0 / 3.0);
                    m[0] += w * a;
                    m[1] += w * a * p;
                    m[2] += w * a * q;
                    q2 += w * a * p * p;
                    scale += w * sg.iter().map(|v| v.abs()).sum::<f64>();
                }
                let rel = m.iter().fold(0.0f64, |v, mi| v.max(mi.abs())) / scale;
                assert!(m[0].abs() <= 1e-10 * scale, "{case} cell {t}: {m:?}");
                violated += usize::from(rel > 1e-10);
                if q2.abs() > 1e-6 * scale {
                    quadratic += 1;
                }
            }
            // Only the cells of patches that dropped the rows (a corner cell with three fixed
            // fluxes: P2 n08 has one, cell 112) may miss the linear moments.
            let dropped = rec.info.p1_symmetry_dropped;
            assert!(
                dropped <= 2,
                "{case}: {dropped} patches dropped the P_1 rows"
            );
            assert!(
                violated <= 6 * dropped,
                "{case}: {violated} cells miss the P_1 moments, {dropped} patches dropped them"
            );
            assert!(
                quadratic * 2 > mesh.len(),
                "{case}: {quadratic} of {} cells",
                mesh.len()
            );
        }
    }

    /// A linear patch's balance does not depend on its stress (design §5.10, "Patches solved
    /// once"): `linear_balance` (c₀, the unknowns at zero) against the residual moments the full
    /// solve leaves, on every such patch of the manufactured files away from Dirichlet edges
    /// (whose fluxes are free), with flow loads on every cell.
    #[test]
    fn linear_balance_is_the_balance_a_solve_leaves() {
        for case in [
            "manufactured_frictionless_p2_n08",
            "manufactured_frictionless_p1_n08",
        ] {
            let fx = crate::problem::fixture(case);
            let ctx = fx.context(crate::read::scene::Norm::Energy);
            let u = fx.displacement();
            let mesh = ctx.mesh;
            let order = RtOrder::Rt2;
            let mut condition = vec![None; ctx.topo.edges.len()];
            for be in ctx.edges {
                condition[be.edge as usize] = Some(be.condition);
            }
            let varying_force = ctx
                .scene
                .body_force
                .as_ref()
                .is_some_and(|f| !(f[0].is_constant() && f[1].is_constant()));
            let tables = RuleTable::build(mesh, order, varying_force);
            let recovered = recovered_strain(mesh, &u);
            let setup = PatchSetup {
                prior: None,
                form: condense::objective_form(&ctx.elastic, true),
                tables: &tables,
                varying_force,
                order,
                condition: &condition,
                weak_symmetry: true,
                origin: [0.4, 0.6],
                length: 1.5,
                recovered: &recovered,
            };
            let (count, members) = vertex_patches(mesh);
            let (mut checked, mut neumann) = (0, 0);
            for v in 0..mesh.points.len() {
                let cells = &members[count[v] as usize..count[v + 1] as usize];
                if cells.is_empty()
                    || !is_linear(&ctx, &condition, cells)
                    || touches_dirichlet(&ctx, &condition, cells)
                {
                    continue;
                }
                let extra: Vec<Extra> = (0..cells.len())
                    .map(|k| [1e-3 * k as f64, -2e-3, 5e-4 * (k % 3) as f64, 1e-4])
                    .collect();
                let quick = linear_balance(&ctx, &u, &setup, v as u32, cells, &extra);
                let solved = solve_patch_rows(&ctx, &u, &setup, v as u32, cells, &extra, true);
                assert!(!quick.solved && solved.solved);
                let scale = quick.balance_scale.max(solved.balance_scale);
                for (i, (a, b)) in quick.balance.iter().zip(&solved.balance).enumerate() {
                    assert!(
                        (a - b).abs() <= 1e-10 * scale,
                        "{case} vertex {v} moment {i}: {a:e} vs {b:e} (scale {scale:e})"
                    );
                }
                assert!(quick.balance.iter().any(|b| b.abs() > 1e-6 * scale));
                // Counted as without the P_1 rows' elimination of the free interior values.
                let plain = solve_patch_rows(&ctx, &u, &setup, v as u32, cells, &extra, false);
                assert_eq!(quick.unknowns, plain.unknowns, "{case} vertex {v}");
                checked += 1;
                neumann += usize::from(cells.iter().any(|&(t, _)| {
                    ctx.topo.cell_edges[t as usize][..3]
                        .iter()
                        .any(|&e| matches!(condition[e as usize], Some(Condition::Neumann(_))))
                }));
            }
            assert!(
                checked > 40 && neumann > 4,
                "{case}: {checked} patches, {neumann} Neumann"
            );
        }
    }

    #[test]
    fn edge_load_rule_has_the_points_its_buffer_holds() {
        assert_eq!(
            triangle_rule_cached(EDGE_LOAD_DEGREE).points.len(),
            EDGE_LOAD_POINTS
        );
    }

    #[test]
    fn projection_onto_polynomials_reproduces_them() {
        // Π_1 of a linear function is itself; Π_1 of s² is s − 1/6 (hand: the L² projection).
        let p = project_points(1, &[0.0, 1.0], |s| 3.0 - 2.0 * s);
        assert!((p[0] - 3.0).abs() < 1e-14 && (p[1] - 1.0).abs() < 1e-14);
        let q = project_points(1, &[0.0, 1.0], |s| s * s);
        assert!((q[0] + 1.0 / 6.0).abs() < 1e-14 && (q[1] - 5.0 / 6.0).abs() < 1e-14);
    }
}
