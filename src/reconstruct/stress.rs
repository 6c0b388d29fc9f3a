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
//! (K assembled straight into its compressed lower triangle, [`crate::solve::SymCsc`]).
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
use crate::solve::{SolveInfo, SymCsc, solve_bound_qp_csc};
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
/// cell; at contact slots the two rows' unknowns are replaced by (y_n, y_t).
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

/// The result of a reconstruction.
pub struct Reconstruction {
    pub stress: RtStress,
    pub info: SolveInfo,
}

/// Reconstructs σ_h; errors name what is not supported.
pub fn reconstruct(
    ctx: &Context,
    u: &[[f64; 2]],
    order: RtOrder,
) -> Result<Reconstruction, String> {
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
    let dofs = Dofs {
        per_row: topo.edges.len() * order.edge_dofs() + ntri * order.interior_dofs(),
        edge_dofs: order.edge_dofs(),
        interior: order.interior_dofs(),
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
            .fold(0.0f64, |m, v| m.max(v[0].abs()).max(v[1].abs()))
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
    // The pattern of K from the connectivity: the free unknowns of one cell couple with each
    // other (fixed ones keep only their diagonal). Element matrices are then added in place.
    let mut group_ptr = Vec::with_capacity(ntri + 1);
    let mut members = Vec::with_capacity(ntri * nl);
    group_ptr.push(0);
    for t in 0..ntri {
        for a in 0..nl {
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
    let element = |t: usize| -> (Vec<f64>, Vec<f64>) {
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
            let mut at = vec![[0.0; 4]; nl];
            let mut dv = vec![[0.0; 2]; nl];
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
    // Element matrices in parallel, a chunk of cells at a time (bounded memory); the scatter
    // into the shared K stays serial.
    for first in (0..ntri).step_by(ELEMENT_CHUNK) {
        let last = (first + ELEMENT_CHUNK).min(ntri);
        let elements: Vec<(Vec<f64>, Vec<f64>)> =
            (first..last).into_par_iter().map(element).collect();
        for (t, (kloc, bloc)) in (first..last).zip(elements) {
            // Scatter.
            let maps: Vec<[(usize, f64); 2]> =
                (0..nl).map(|a| map_local(t, a / nloc, a % nloc)).collect();
            for a in 0..nl {
                for &(ga, ca) in &maps[a] {
                    if ga == usize::MAX || ca == 0.0 {
                        continue;
                    }
                    if fixed[ga].is_none() {
                        b[ga] += ca * bloc[a];
                    }
                    for c in 0..nl {
                        let kv = if c <= a {
                            kloc[a * nl + c]
                        } else {
                            kloc[c * nl + a]
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
    let (x, info) = solve_bound_qp_csc(&k, &b, &constrained, MAX_ITERATIONS, &guess)?;
    drop(k);

    let coefficients = (0..ntri)
        .map(|t| {
            let mut c = [[0.0; MAX_RT_DOFS]; 2];
            for (r, row) in c.iter_mut().enumerate() {
                for (i, ci) in row.iter_mut().enumerate().take(nloc) {
                    *ci = map_local(t, r, i)
                        .iter()
                        .filter(|(g, _)| *g != usize::MAX)
                        .map(|&(g, cf)| cf * x[g])
                        .sum();
                }
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
