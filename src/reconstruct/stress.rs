//! Global stress reconstruction (docs/design.md §5):
//!
//! ```text
//! σ_h = argmin { F(u_h, τ) : τ ∈ RT_k(T_h)² ∩ K_σ },
//! ```
//!
//! rows of τ in RT_k (k = 0, 1; [`crate::element::rt`]), with
//! K_σ: τn = t on Neumann and unselected (traction-free) edges, τ_t = 0 on frictionless
//! contact edges (both essential, imposed on the edge DOFs), τ_n ≤ 0 at the contact DOF points
//! (a bound on single unknowns after rotating the two rows' edge DOFs into the contact frame
//! (n, t)). F(u_h, ·) is quadratic: with e = ε(u_h) − Aτ and the preset's density Q(e) with
//! bilinear form B,
//!
//! ```text
//! F = ∫ Q(ε) − 2B(ε, Aτ) + B(Aτ, Aτ) + ½ w_d |div τ + f|² + ⟨u_n − g, τ_n⟩_{Γ_C},
//! ```
//!
//! so F = ½ xᵀKx − bᵀx + const in the DOFs x, minimised by [`crate::solve::solve_bound_qp_csc`]
//! (K assembled straight into its compressed lower triangle, [`crate::solve::SymCsc`]). The
//! interior DOFs of each cell (RT_1: 2 per row, RT_2: 6) couple only within their cell and carry
//! no constraint: they are condensed cell by cell before the assembly (`condense_element`, in
//! parallel) and recovered after the solve, so K holds the edge DOFs only (issue 13).
//! With Coulomb friction the friction term is linear on K_σ too (|τ_n| = −τ_n), and the 2D
//! cone |τ_t| ≤ 𝔉|τ_n| at each contact DOF point becomes two bounds after the change of
//! variables w₁ = τ_t + 𝔉τ_n, w₂ = −τ_t + 𝔉τ_n (flux densities).

use rayon::prelude::*;

use super::submesh::SubMesh;
use crate::element::rt::{self, MAX_RT_DOFS, RtOrder};
pub use crate::field::RtStress;
use crate::geometry::values::{rule_degree, sub_edge_point, sub_point};
use crate::material::Elastic;
use crate::mesh::Mesh;
use crate::problem::{BoundaryEdge, Condition, Context};
use crate::quadrature::{line_rule_cached, triangle_rule_cached};
use crate::read::scene::{BoundaryKind, Norm, Scene};
use crate::solve::{SolveInfo, SymCsc, dense, solve_bound_qp_csc};
use crate::tolerance::{EDGE_DEGREE, GAP_RELATIVE, MAX_ACTIVE_SET_ITERATIONS, MIN_CONE_FRICTION};

/// What the reconstruction reads (built from the [`Context`]).
struct Input<'a> {
    mesh: &'a Mesh,
    scene: &'a Scene,
    u: &'a [[f64; 2]],
    edges: &'a [BoundaryEdge],
    norm: Norm,
    length_scale: f64,
    order: RtOrder,
}

/// Cells whose element matrices are computed in parallel before being added to K: enough
/// work per batch for the thread pool, a few MiB of element matrices.
const ELEMENT_CHUNK: usize = 4096;

/// Cap on active-set changes.
pub const MAX_ITERATIONS: usize = MAX_ACTIVE_SET_ITERATIONS;

/// Global unknowns: per row, the edge slots of every edge, then the interior DOFs of every
/// cell (none when they are condensed, [`condense_element`]); at contact slots the two rows'
/// unknowns are replaced by (y_n, y_t).
struct Dofs {
    per_row: usize,
    edge_dofs: usize,
    interior: usize,
    edges: usize,
}

impl Dofs {
    fn edge(&self, row: usize, e: usize, slot: usize) -> usize {
        row * self.per_row + e * self.edge_dofs + slot
    }
    fn interior(&self, row: usize, t: usize, m: usize) -> usize {
        row * self.per_row + self.edges * self.edge_dofs + t * self.interior + m
    }
}

/// At a contact DOF point, the two unknowns (y₀, y₁) stored in the two rows' slots and the
/// owner's orientation sign: the owner's outward flux of row r is c₀_r y₀ + c₁_r y₁ (the
/// frame (n, t) without friction, the cone variables with it), the global DOF is sign × that.
type Frame = ([f64; 2], [f64; 2], f64);

/// What one cell adds to the global system: its matrix (lower triangle, row-major), its
/// vector, and the data that recovers its condensed DOFs ([`condense_element`]; empty without
/// condensation).
type ElementSystem = (Vec<f64>, Vec<f64>, Vec<f64>);

/// The result of a reconstruction.
pub struct Reconstruction {
    pub stress: RtStress,
    pub info: SolveInfo,
}

/// Reconstructs σ_h; errors name what is not supported. The interior DOFs of every cell are
/// condensed (eliminated cell by cell before the global solve, `condense_element`): the
/// global system holds only the edge DOFs, and [`SolveInfo::unknowns`] counts those.
pub fn reconstruct(
    ctx: &Context,
    u: &[[f64; 2]],
    order: RtOrder,
) -> Result<Reconstruction, String> {
    reconstruct_with(ctx, u, order, true)
}

/// [`reconstruct`] with the interior DOFs condensed (`condense`) or kept in the global system
/// (the reference the condensed path is tested against).
fn reconstruct_with(
    ctx: &Context,
    u: &[[f64; 2]],
    order: RtOrder,
    condense: bool,
) -> Result<Reconstruction, String> {
    // At ν = 0.5 (λ = ∞) a constant pressure τ = pI has Aτ = 0 and div τ = 0, and it meets
    // every constraint but a traction datum (τ_t = 0, τ_n ≤ 0 for p ≤ 0): without a boundary edge
    // that carries one (Neumann or traction-free) it is in the kernel of K. Refused here, from the
    // structure, because the factorisation's round-off pivots and the condition estimate of a
    // singular K do not always show it (docs/design.md §5.5).
    if ctx.elastic.lambda.is_infinite()
        && !ctx
            .edges
            .iter()
            .any(|e| matches!(e.condition, Condition::Neumann(_) | Condition::Free))
    {
        return Err(
            "the reconstruction matrix is not positive definite (τ = pI is in its \
                    kernel: no boundary edge carries traction data): the field is not \
                    determined by the functional"
                .into(),
        );
    }
    let inp = &Input {
        mesh: ctx.mesh,
        scene: ctx.scene,
        u,
        edges: ctx.edges,
        norm: ctx.norm,
        length_scale: ctx.length_scale,
        order,
    };
    let mesh = inp.mesh;
    let order = inp.order;
    let nloc = order.dofs();
    let sub = SubMesh::new(mesh);
    let topo = &sub.topo;
    let ntri = sub.len();
    // Interior DOFs per row and cell; with `condense` none of them is a global unknown.
    let condense = condense && order.interior_dofs() > 0;
    let interior_global = if condense { 0 } else { order.interior_dofs() };
    let dofs = Dofs {
        per_row: topo.edges.len() * order.edge_dofs() + ntri * interior_global,
        edge_dofs: order.edge_dofs(),
        interior: interior_global,
        edges: topo.edges.len(),
    };
    let n = 2 * dofs.per_row;
    let el = Elastic::new(&inp.scene.material);
    if inp.norm == Norm::Energy && el.lambda.is_infinite() {
        return Err("the energy norm needs λ < ∞".into());
    }
    let w_d = el.equilibrium_weight(inp.norm, inp.length_scale);

    // Condition of each edge, and contact frames / fixed values per edge slot.
    let mut condition = vec![None::<(Condition, u32, u8)>; topo.edges.len()];
    for be in inp.edges {
        let [a, b, _] = mesh.edge(be.cell as usize, be.local as usize);
        if let Some((e, r, l)) = sub.locate_edge(a, b) {
            condition[e] = Some((be.condition, r as u32, l as u8));
        }
    }
    // For contact slots: (n, t) such that x_r = n_r y_n + t_r y_t in the owner's outward sense.
    let mut frame: Vec<Option<Frame>> = vec![None; n];
    let mut fixed: Vec<Option<f64>> = vec![None; n];
    let mut constrained = Vec::new();
    // Open-gap contact slots with the normal pressure of Cε(u_h) there.
    let mut candidates: Vec<(f64, [usize; 2])> = Vec::new();
    // An open gap, beyond round-off of the contact-normal displacement (as in the estimator's
    // contact states, [`crate::estimate::boundary::GAP_TOLERANCE`]).
    let gap_tolerance = GAP_RELATIVE
        * inp
            .u
            .iter()
            .fold(0.0f64, |m, v| m.max(v[0].hypot(v[1])))
            .max(f64::MIN_POSITIVE);
    for (e, c) in condition.iter().enumerate() {
        let Some((cond, cell, local)) = *c else {
            continue;
        };
        let r = cell as usize;
        let l = local as usize;
        let t = sub.parent[r] as usize;
        let (fam, k) = (mesh.family[t], sub.index[r] as usize);
        let x = mesh.coords(t);
        let forward = topo.cell_edge_sign[r][l] > 0;
        for slot in 0..order.edge_dofs() {
            let s_global = order.edge_points()[slot];
            let s = if forward { s_global } else { 1.0 - s_global };
            let (sp, normal, len, _) =
                sub_edge_point(fam, &x[..fam.nodes()], mesh.shape[t], k, l, s);
            let p = sp.x;
            // Global DOF = sgn × (outward flux density of the owner).
            let sgn = if forward { 1.0 } else { -1.0 };
            let (g0, g1) = (dofs.edge(0, e, slot), dofs.edge(1, e, slot));
            match cond {
                Condition::Free | Condition::Neumann(_) => {
                    let tr = match cond {
                        Condition::Neumann(b) => match &inp.scene.boundaries[b].kind {
                            BoundaryKind::Neumann { traction } => [
                                traction[0].eval(p[0], p[1], 0.0),
                                traction[1].eval(p[0], p[1], 0.0),
                            ],
                            _ => [0.0; 2],
                        },
                        _ => [0.0; 2],
                    };
                    fixed[g0] = Some(sgn * tr[0] * len);
                    fixed[g1] = Some(sgn * tr[1] * len);
                }
                Condition::Contact(b) => {
                    let BoundaryKind::Contact(spec) = &inp.scene.boundaries[b].kind else {
                        continue;
                    };
                    let cn = spec.direction(normal);
                    // Where the contact direction never meets the obstacle (infinite gap)
                    // contact cannot happen: the slot is traction-free, as in the patches.
                    if !spec.gap_at(p, cn).is_finite() {
                        fixed[g0] = Some(0.0);
                        fixed[g1] = Some(0.0);
                        continue;
                    }
                    let ct = [-cn[1], cn[0]];
                    let fr = spec.friction;
                    // Where u_h leaves a gap and Cε(u_h) does not press on the boundary, the
                    // contact stress vanishes at the minimiser in all but degenerate cases: the
                    // active set starts there (only the iteration count depends on it).
                    let mut uh = [0.0; 2];
                    let mut gu = [[0.0; 2]; 2];
                    for (i, &q) in mesh.nodes(t).iter().enumerate() {
                        let uq = inp.u[q as usize];
                        let gk = sp.grad[i];
                        for a in 0..2 {
                            uh[a] += sp.phi[i] * uq[a];
                            gu[a][0] += uq[a] * gk[0];
                            gu[a][1] += uq[a] * gk[1];
                        }
                    }
                    let gap = spec.gap_at(p, cn) - (cn[0] * uh[0] + cn[1] * uh[1]);
                    let pressure = if el.lambda.is_finite() {
                        let sym = 0.5 * (gu[0][1] + gu[1][0]);
                        let sg = el.stress([gu[0][0], sym, sym, gu[1][1]]);
                        let tr = [
                            sg[0] * normal[0] + sg[1] * normal[1],
                            sg[2] * normal[0] + sg[3] * normal[1],
                        ];
                        -(cn[0] * tr[0] + cn[1] * tr[1])
                    } else {
                        0.0
                    };

                    if fr >= MIN_CONE_FRICTION {
                        // The 2D cone |y_t| ≤ −𝔉 y_n is w₁ = y_t + 𝔉y_n ≤ 0, w₂ = −y_t + 𝔉y_n ≤ 0:
                        // y_n = (w₁ + w₂)/(2𝔉), y_t = (w₁ − w₂)/2, bounds on single unknowns.
                        let h = 0.5 / fr;
                        let c1 = [h * cn[0] + 0.5 * ct[0], h * cn[1] + 0.5 * ct[1]];
                        let c2 = [h * cn[0] - 0.5 * ct[0], h * cn[1] - 0.5 * ct[1]];
                        frame[g0] = Some((c1, c2, sgn));
                        frame[g1] = Some((c1, c2, sgn));
                        constrained.push(g0);
                        constrained.push(g1);
                        if gap > gap_tolerance {
                            candidates.push((pressure, [g0, g1]));
                        }
                    } else {
                        // Local (owner) flux of row r = n_r y_n + t_r y_t; global = sgn × local.
                        frame[g0] = Some((cn, ct, sgn));
                        frame[g1] = Some((cn, ct, sgn));
                        fixed[g1] = Some(0.0);
                        constrained.push(g0);
                        if gap > gap_tolerance {
                            candidates.push((pressure, [g0, usize::MAX]));
                        }
                    }
                }
                Condition::Dirichlet(_) => {}
            }
        }
    }

    // Local function (row r, local DOF i) of cell t → [(global unknown, coefficient)].
    let map_local = |t: usize, r: usize, i: usize| -> [(usize, f64); 2] {
        if i >= 3 * order.edge_dofs() {
            let m = i - 3 * order.edge_dofs();
            return [(dofs.interior(r, t, m), 1.0), (usize::MAX, 0.0)];
        }
        let l = i / order.edge_dofs();
        let e = topo.cell_edges[t][l] as usize;
        let forward = topo.cell_edge_sign[t][l] > 0;
        let (_, slot, sign) = rt::local_to_global_edge(order, l, forward)
            .find(|&(loc, _, _)| loc == i)
            .unwrap_or((i, 0, 1.0));
        let g = dofs.edge(r, e, slot);
        match frame[g] {
            // x_r(global) = sgn (n_r y_n + t_r y_t); local = sign × global, sign = sgn here.
            Some((cn, ct, sgn)) => [
                (dofs.edge(0, e, slot), sign * sgn * cn[r]),
                (dofs.edge(1, e, slot), sign * sgn * ct[r]),
            ],
            None => [(g, sign), (usize::MAX, 0.0)],
        }
    };

    let f_expr = inp.scene.body_force.as_ref();
    let nl = 2 * nloc;
    // Local functions (a = row × nloc + i) that enter the global system: all, or the edge
    // functions when the interior ones are condensed (`interior` lists those).
    let is_interior = |a: usize| a % nloc >= 3 * order.edge_dofs();
    let kept: Vec<usize> = (0..nl).filter(|&a| !condense || !is_interior(a)).collect();
    let interior: Vec<usize> = (0..nl).filter(|&a| condense && is_interior(a)).collect();
    let (nk, ni) = (kept.len(), interior.len());
    // Per cell, what recovers its interior DOFs from its edge DOFs: W = K_II⁻¹ K_IE (ni × nk,
    // row-major) and w = K_II⁻¹ b_I (ni).
    let stride = ni * (nk + 1);
    let mut recovery = vec![0.0; ntri * stride];
    // The pattern of K from the connectivity: the free unknowns of one cell couple with each
    // other (fixed ones keep only their diagonal). Element matrices are then added in place.
    let mut group_ptr = Vec::with_capacity(ntri + 1);
    let mut members = Vec::with_capacity(ntri * nk);
    group_ptr.push(0);
    for t in 0..ntri {
        for &a in &kept {
            for (g, cf) in map_local(t, a / nloc, a % nloc) {
                if g != usize::MAX && cf != 0.0 && fixed[g].is_none() {
                    members.push(g);
                }
            }
        }
        group_ptr.push(members.len());
    }
    let mut k = SymCsc::from_groups(n, &group_ptr, &members)?;
    drop((group_ptr, members));
    let mut b = vec![0.0; n];
    // The element matrix and vector of cell t: K_loc (lower triangle, row-major) and b_loc.
    let full_element = |t: usize| -> (Vec<f64>, Vec<f64>) {
        let parent = sub.parent[t] as usize;
        let (fam, half) = (mesh.family[parent], sub.index[t] as usize);
        let x = mesh.coords(parent);
        let nodes = mesh.nodes(parent);
        let p_deg = crate::geometry::values::integrand_degree(fam, Some(order.k())).max(4);
        let rule = triangle_rule_cached(rule_degree(mesh.shape[parent], p_deg));
        let mut kloc = vec![0.0; nl * nl];
        let mut bloc = vec![0.0; nl];
        for (&xi, &wq) in rule.points.iter().zip(&rule.weights) {
            let sp = sub_point(fam, &x[..fam.nodes()], mesh.shape[parent], half, xi);
            let jac = sp.jac;
            let w = wq * jac.det;
            // ε(u_h).
            let mut gu = [[0.0; 2]; 2];
            for (k, &p) in nodes.iter().enumerate() {
                let gp = sp.grad[k];
                let u = inp.u[p as usize];
                for a in 0..2 {
                    gu[a][0] += u[a] * gp[0];
                    gu[a][1] += u[a] * gp[1];
                }
            }
            let sym = 0.5 * (gu[0][1] + gu[1][0]);
            let eps = [gu[0][0], sym, sym, gu[1][1]];
            let f = match f_expr {
                None => [0.0; 2],
                Some(fe) => [
                    fe[0].eval(sp.x[0], sp.x[1], 0.0),
                    fe[1].eval(sp.x[0], sp.x[1], 0.0),
                ],
            };
            let (v, d) = rt::piola(order, &jac, xi);
            // A τ and div τ of each local function (row r = φ_i, the other row 0).
            // On the stack: this runs at every quadrature point of every cell.
            let mut at = [[0.0; 4]; 2 * MAX_RT_DOFS];
            let mut dv = [[0.0; 2]; 2 * MAX_RT_DOFS];
            for r in 0..2 {
                for i in 0..nloc {
                    let mut tau = [0.0; 4];
                    tau[2 * r] = v[i][0];
                    tau[2 * r + 1] = v[i][1];
                    at[r * nloc + i] = el.compliance(tau);
                    dv[r * nloc + i][r] = d[i];
                }
            }
            for a in 0..nl {
                bloc[a] += w
                    * (2.0 * el.bilinear(inp.norm, eps, at[a])
                        - w_d * (f[0] * dv[a][0] + f[1] * dv[a][1]));
                for c in 0..=a {
                    let kv = w
                        * (2.0 * el.bilinear(inp.norm, at[a], at[c])
                            + w_d * (dv[a][0] * dv[c][0] + dv[a][1] * dv[c][1]));
                    kloc[a * nl + c] += kv;
                }
            }
        }
        // Contact edges of this cell: −⟨u_n − g, τ_n⟩ on the right-hand side.
        for l in 0..3 {
            let e = topo.cell_edges[t][l] as usize;
            let Some((Condition::Contact(bi), _, _)) = condition[e] else {
                continue;
            };
            let BoundaryKind::Contact(spec) = &inp.scene.boundaries[bi].kind else {
                continue;
            };
            let lr = line_rule_cached(EDGE_DEGREE);
            for (&s, &wq) in lr.points.iter().zip(&lr.weights) {
                let (sp, normal, len, xi) =
                    sub_edge_point(fam, &x[..fam.nodes()], mesh.shape[parent], half, l, s);
                let (v, _) = rt::piola(order, &sp.jac, xi);
                let mut u = [0.0; 2];
                for (k, &pn) in nodes.iter().enumerate() {
                    u[0] += inp.u[pn as usize][0] * sp.phi[k];
                    u[1] += inp.u[pn as usize][1] * sp.phi[k];
                }
                let p = sp.x;
                let cn = spec.direction(normal);
                let ct = [-cn[1], cn[0]];
                let gap = spec.gap_at(p, cn);
                // Traction-free there (the slots are fixed to 0 above): no pairing.
                if !gap.is_finite() {
                    continue;
                }
                let un = cn[0] * u[0] + cn[1] * u[1];
                let ut = ct[0] * u[0] + ct[1] * u[1];
                let fr = spec.friction;
                for r in 0..2 {
                    for i in 0..nloc {
                        let flux = v[i][0] * normal[0] + v[i][1] * normal[1];
                        // Complementarity ⟨u_n − g, τ_n⟩ and, on K_σ (|τ_n| = −τ_n), friction
                        // −𝔉⟨τ_n, |u_t|⟩ + ⟨τ_t, u_t⟩: linear in τ.
                        let mut lin = (un - gap) * cn[r] * flux;
                        if fr > 0.0 {
                            lin += -fr * ut.abs() * cn[r] * flux + ut * ct[r] * flux;
                        }
                        bloc[r * nloc + i] -= wq * len * lin;
                    }
                }
            }
        }
        (kloc, bloc)
    };
    // The matrix and vector that enter the global system (kept functions, lower triangle
    // row-major nk × nk), and the recovery data of the condensed ones; `Err(t)`: K_II of cell t
    // is not positive definite.
    let element = |t: usize| -> Result<ElementSystem, usize> {
        let (kloc, bloc) = full_element(t);
        if !condense {
            return Ok((kloc, bloc, Vec::new()));
        }
        condense_element(nl, &kloc, &bloc, &kept, &interior).ok_or(t)
    };
    // Element matrices in parallel, a chunk of cells at a time (bounded memory); the scatter
    // into the shared K stays serial.
    for first in (0..ntri).step_by(ELEMENT_CHUNK) {
        let last = (first + ELEMENT_CHUNK).min(ntri);
        let elements: Vec<Result<ElementSystem, usize>> =
            (first..last).into_par_iter().map(element).collect();
        for (t, el) in (first..last).zip(elements) {
            let (kloc, bloc, rec) = el.map_err(|t| {
                format!(
                    "the reconstruction matrix is not positive definite (the interior block of \
                     cell {t}): the field is not determined by the functional"
                )
            })?;
            recovery[t * stride..(t + 1) * stride].copy_from_slice(&rec);
            // Scatter.
            let maps: Vec<[(usize, f64); 2]> = kept
                .iter()
                .map(|&a| map_local(t, a / nloc, a % nloc))
                .collect();
            for a in 0..nk {
                for &(ga, ca) in &maps[a] {
                    if ga == usize::MAX || ca == 0.0 {
                        continue;
                    }
                    if fixed[ga].is_none() {
                        b[ga] += ca * bloc[a];
                    }
                    for c in 0..nk {
                        let kv = if c <= a {
                            kloc[a * nk + c]
                        } else {
                            kloc[c * nk + a]
                        };
                        for &(gc, cc) in &maps[c] {
                            if gc == usize::MAX || cc == 0.0 {
                                continue;
                            }
                            let v = ca * cc * kv;
                            match (fixed[ga], fixed[gc]) {
                                // The guard adds the entry; it fails only if the pattern lacks it.
                                (None, None) if ga >= gc && !k.add(ga, gc, v) => {
                                    return Err(format!(
                                        "internal: unknowns {ga} and {gc} of one cell are not \
                                         coupled in the pattern"
                                    ));
                                }
                                (None, Some(val)) => b[ga] -= v * val,
                                _ => {}
                            }
                        }
                    }
                }
            }
        }
    }
    for (g, f) in fixed.iter().enumerate() {
        if let Some(v) = f {
            // The diagonal is always in the pattern.
            k.add(g, g, 1.0);
            b[g] = *v;
        }
    }
    // Slots where Cε(u_h) presses with more than 20 % of the largest such pressure stay out of
    // the guess: a field compressed where its gap is open is no solution of the contact problem
    // (synthetic fields, gross errors), and its open gap says nothing about the stress there.
    let pmax = candidates.iter().fold(0.0f64, |m, c| m.max(c.0.abs()));
    let guess: Vec<usize> = candidates
        .iter()
        .filter(|c| c.0 <= 0.2 * pmax)
        .flat_map(|c| c.1)
        .filter(|&g| g != usize::MAX)
        .collect();
    let (x, mut info) = solve_bound_qp_csc(&k, &b, &constrained, MAX_ITERATIONS, &guess)?;
    drop(k);
    info.condensed = ntri * ni;

    let coefficients = (0..ntri)
        .into_par_iter()
        .map(|t| {
            let mut c = [[0.0; MAX_RT_DOFS]; 2];
            let mut edge = vec![0.0; nk];
            for (j, &a) in kept.iter().enumerate() {
                let v = map_local(t, a / nloc, a % nloc)
                    .iter()
                    .filter(|(g, _)| *g != usize::MAX)
                    .map(|&(g, cf)| cf * x[g])
                    .sum();
                c[a / nloc][a % nloc] = v;
                edge[j] = v;
            }
            // Condensed interior DOFs: x_I = K_II⁻¹ b_I − K_II⁻¹ K_IE x_E.
            let rec = &recovery[t * stride..(t + 1) * stride];
            let (w_mat, w_vec) = rec.split_at(ni * nk);
            for (p, &a) in interior.iter().enumerate() {
                let row = &w_mat[p * nk..(p + 1) * nk];
                c[a / nloc][a % nloc] =
                    w_vec[p] - row.iter().zip(&edge).map(|(w, e)| w * e).sum::<f64>();
            }
            c
        })
        .collect();
    Ok(Reconstruction {
        stress: RtStress {
            order,
            coefficients,
            first: sub.first,
        },
        info,
    })
}

/// Static condensation of one cell's element system (module doc; issue 13): with the local
/// functions split into the kept ones E (edge functions, shared with the neighbours) and the
/// interior ones I (which couple only within the cell: the functional's terms are cell
/// integrals, H(div) conformity and the constraints act on edge DOFs only),
///
/// ```text
/// K_red = K_EE − K_EI K_II⁻¹ K_IE,   b_red = b_E − K_EI K_II⁻¹ b_I,
/// x_I = K_II⁻¹ b_I − K_II⁻¹ K_IE x_E,
/// ```
///
/// and the minimiser of ½xᵀKx − bᵀx over all DOFs is that of the reduced problem over the edge
/// DOFs, with the same constraints, completed by x_I. `kloc` is the lower triangle of the
/// element matrix (row-major, nl × nl), `bloc` its vector. Returns (K_red lower triangle
/// row-major |E| × |E|, b_red, [W = K_II⁻¹ K_IE row-major |I| × |E|; w = K_II⁻¹ b_I]), or
/// `None` when K_II is not numerically positive definite.
fn condense_element(
    nl: usize,
    kloc: &[f64],
    bloc: &[f64],
    kept: &[usize],
    interior: &[usize],
) -> Option<ElementSystem> {
    let kv = |a: usize, c: usize| {
        if c <= a {
            kloc[a * nl + c]
        } else {
            kloc[c * nl + a]
        }
    };
    let (nk, ni) = (kept.len(), interior.len());
    let kii: Vec<f64> = (0..ni * ni)
        .map(|pq| kv(interior[pq / ni], interior[pq % ni]))
        .collect();
    let set: Vec<usize> = (0..ni).collect();
    let mut l = vec![0.0; ni * ni];
    if !dense::cholesky(ni, &kii, &set, &mut l) {
        return None;
    }
    // rec = [W (ni × nk, row-major); w]: columns of K_IE and b_I solved with K_II.
    let mut rec = vec![0.0; ni * (nk + 1)];
    let mut col = vec![0.0; ni];
    for j in 0..=nk {
        for (p, &ip) in interior.iter().enumerate() {
            col[p] = if j < nk { kv(ip, kept[j]) } else { bloc[ip] };
        }
        dense::cholesky_solve(ni, ni, &l, &mut col);
        for p in 0..ni {
            if j < nk {
                rec[p * nk + j] = col[p];
            } else {
                rec[ni * nk + p] = col[p];
            }
        }
    }
    let mut kred = vec![0.0; nk * nk];
    let mut bred = vec![0.0; nk];
    for a in 0..nk {
        let ka = kept[a];
        let kai: Vec<f64> = interior.iter().map(|&ip| kv(ka, ip)).collect();
        for c in 0..=a {
            let s: f64 = (0..ni).map(|p| kai[p] * rec[p * nk + c]).sum();
            kred[a * nk + c] = kv(ka, kept[c]) - s;
        }
        let s: f64 = (0..ni).map(|p| kai[p] * rec[ni * nk + p]).sum();
        bred[a] = bloc[ka] - s;
    }
    Some((kred, bred, rec))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The condensed solve (interior DOFs eliminated cell by cell) and the solve of the whole
    /// system give the same minimiser: the same coefficients to 1e-10 relative, the same
    /// active-set iterations and active constraints, on frictionless and Coulomb Hertz (RT_1
    /// and RT_2, interior DOFs present; RT_0 has none).
    #[test]
    fn condensed_solve_equals_the_full_one() {
        let mut with_contact = 0;
        for (case, norm) in [
            ("hertz_skfem_p2", Norm::Energy),
            ("hertz_skfem_p2_coulomb", Norm::Energy),
            ("block_skfem_p1", Norm::Energy),
            ("block_skfem_p1_coulomb", Norm::Robust),
        ] {
            let fx = crate::problem::fixture(case);
            let ctx = fx.context(norm);
            let u = fx.displacement();
            for order in [RtOrder::Rt1, RtOrder::Rt2] {
                let full = reconstruct_with(&ctx, &u, order, false).unwrap();
                let cond = reconstruct_with(&ctx, &u, order, true).unwrap();
                let (fi, ci) = (&full.info, &cond.info);
                assert_eq!(fi.condensed, 0);
                assert_eq!(ci.unknowns + ci.condensed, fi.unknowns, "{case} {order:?}");
                assert!(ci.nonzeros < fi.nonzeros, "{case} {order:?}");
                assert_eq!(ci.iterations, fi.iterations, "{case} {order:?}");
                assert_eq!(ci.active, fi.active, "{case} {order:?}");
                assert!(ci.converged, "{case} {order:?}: {ci:?}");
                with_contact += usize::from(ci.active > 0);
                assert!(ci.kkt_residual < 1e-10, "{case} {order:?}: {ci:?}");
                let scale = full
                    .stress
                    .coefficients
                    .iter()
                    .flatten()
                    .flatten()
                    .fold(0.0f64, |m, v| m.max(v.abs()));
                let diff = full
                    .stress
                    .coefficients
                    .iter()
                    .zip(&cond.stress.coefficients)
                    .flat_map(|(a, b)| a.iter().flatten().zip(b.iter().flatten()))
                    .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
                // Round-off of the full solve: its forward error bound κu exceeds 1e-10 at RT_2
                // (κ 3e8; the condensed system's is 3e6).
                let tolerance = 1e-10f64.max(fi.condition_estimate * f64::EPSILON);
                assert!(
                    scale > 0.0 && diff <= tolerance * scale,
                    "{case} {order:?}: {diff:e} of {scale:e}"
                );
                eprintln!(
                    "{case} {norm:?} {order:?}: {} + {} unknowns (full {}), nonzeros {} (full \
                     {}), κ {:.1e} (full {:.1e}), difference {:.1e} relative",
                    ci.unknowns,
                    ci.condensed,
                    fi.unknowns,
                    ci.nonzeros,
                    fi.nonzeros,
                    ci.condition_estimate,
                    fi.condition_estimate,
                    diff / scale
                );
            }
        }
        assert!(with_contact >= 4, "{with_contact}");
    }

    /// Condensing a small SPD system by hand: the reduced system's solution and the recovered
    /// interior values are those of the whole system.
    #[test]
    fn element_condensation_by_hand() {
        // K = [[4, 1, 0.5], [1, 3, 1], [0.5, 1, 2]] (lower triangle, row-major), b = (1, 2, 3);
        // kept {0, 2}, interior {1}.
        let nl = 3;
        let kloc = [4.0, 0.0, 0.0, 1.0, 3.0, 0.0, 0.5, 1.0, 2.0];
        let bloc = [1.0, 2.0, 3.0];
        let (kred, bred, rec) = condense_element(nl, &kloc, &bloc, &[0, 2], &[1]).unwrap();
        // K_red = K_EE − K_EI K_IE / 3.
        let k00 = 4.0 - 1.0 / 3.0;
        let k10 = 0.5 - 1.0 / 3.0;
        let k11 = 2.0 - 1.0 / 3.0;
        assert!((kred[0] - k00).abs() < 1e-15 && (kred[2] - k10).abs() < 1e-15);
        assert!((kred[3] - k11).abs() < 1e-15);
        assert!((bred[0] - (1.0 - 2.0 / 3.0)).abs() < 1e-15);
        assert!((bred[1] - (3.0 - 2.0 / 3.0)).abs() < 1e-15);
        // Solve the reduced 2×2 and recover x₁; compare with the whole 3×3 solve.
        let det = k00 * k11 - k10 * k10;
        let xe = [
            (k11 * bred[0] - k10 * bred[1]) / det,
            (k00 * bred[1] - k10 * bred[0]) / det,
        ];
        let x1 = rec[2] - rec[0] * xe[0] - rec[1] * xe[1];
        let x = [xe[0], x1, xe[1]];
        let k = [[4.0, 1.0, 0.5], [1.0, 3.0, 1.0], [0.5, 1.0, 2.0]];
        for i in 0..3 {
            let r: f64 = (0..3).map(|j| k[i][j] * x[j]).sum::<f64>() - bloc[i];
            assert!(r.abs() < 1e-14, "row {i}: {r}");
        }
        // A K_II that is not positive definite is reported.
        let bad = [4.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.5, 1.0, 2.0];
        assert!(condense_element(nl, &bad, &bloc, &[0, 2], &[1]).is_none());
    }
}
