//! Projection of an inadmissible displacement onto K_u (DESIGN.md §5):
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

use super::solve::{Lower, SolveInfo, solve_bound_qp};
use crate::element::lagrange::{jacobian, shape_gradients};
use crate::estimate::interior::{CURVED_DEGREE, is_curved};
use crate::estimate::material::Elastic;
use crate::mesh::{Mesh, NONE};
use crate::problem::{BoundaryEdge, Condition};
use crate::quadrature::triangle_rule_cached;
use crate::read::scene::{BoundaryKind, Scene};
use crate::topology::Topology;

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
pub fn nodal_violations(
    mesh: &Mesh,
    topo: &Topology,
    scene: &Scene,
    edges: &[BoundaryEdge],
    u: &[[f64; 2]],
) -> usize {
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

/// Dirichlet values and contact (direction, gap) per mesh node; Dirichlet wins where both.
#[allow(clippy::type_complexity)]
fn boundary_nodes(
    mesh: &Mesh,
    topo: &Topology,
    scene: &Scene,
    edges: &[BoundaryEdge],
) -> (Vec<Option<[f64; 2]>>, Vec<Option<([f64; 2], f64)>>) {
    let np = mesh.points.len();
    let mut dir = vec![None; np];
    let mut normal_sum = vec![[0.0f64; 2]; np];
    let mut contact_of = vec![None::<usize>; np];
    for be in edges {
        let [a, b] = topo.edges[be.edge as usize];
        let mid = topo.edge_mid[be.edge as usize];
        let nodes = [a, b, mid];
        let (pa, pb) = (mesh.points[a as usize], mesh.points[b as usize]);
        // Outward normal of the chord (the owner runs local edge counter-clockwise).
        let tri = mesh.triangles[be.cell as usize];
        let l = be.local as usize;
        let (s, e) = (
            mesh.points[tri[l] as usize],
            mesh.points[tri[(l + 1) % 3] as usize],
        );
        let t = [e[0] - s[0], e[1] - s[1]];
        let len = t[0].hypot(t[1]);
        let n_out = [t[1] / len, -t[0] / len];
        let _ = (pa, pb);
        match be.condition {
            Condition::Dirichlet(bi) => {
                if let BoundaryKind::Dirichlet { displacement } = &scene.boundaries[bi].kind {
                    for &p in nodes.iter().filter(|&&p| p != NONE) {
                        let x = mesh.points[p as usize];
                        dir[p as usize] = Some([
                            displacement[0].eval(x[0], x[1], 0.0),
                            displacement[1].eval(x[0], x[1], 0.0),
                        ]);
                    }
                }
            }
            Condition::Contact(bi) => {
                for &p in nodes.iter().filter(|&&p| p != NONE) {
                    normal_sum[p as usize][0] += n_out[0];
                    normal_sum[p as usize][1] += n_out[1];
                    contact_of[p as usize] = Some(bi);
                }
            }
            _ => {}
        }
    }
    let mut con = vec![None; np];
    for p in 0..np {
        let Some(bi) = contact_of[p] else { continue };
        if dir[p].is_some() {
            continue;
        }
        let BoundaryKind::Contact(spec) = &scene.boundaries[bi].kind else {
            continue;
        };
        let s = normal_sum[p];
        let l = s[0].hypot(s[1]);
        let n_body = [s[0] / l, s[1] / l];
        let n = spec.direction(n_body);
        con[p] = Some((n, spec.gap_at(mesh.points[p], n)));
    }
    (dir, con)
}

/// Projects `u` onto K_u in the energy norm.
pub fn project(
    mesh: &Mesh,
    topo: &Topology,
    scene: &Scene,
    edges: &[BoundaryEdge],
    u: &[[f64; 2]],
    length_scale: f64,
) -> Result<Projection, String> {
    let np = mesh.points.len();
    let n = 2 * np;
    let el = Elastic::new(&scene.material);
    let (dir, con) = boundary_nodes(mesh, topo, scene, edges);
    let violations = nodal_violations(mesh, topo, scene, edges, u);
    let has_dirichlet = dir.iter().any(Option::is_some);

    // Energy matrix (lower triangle) over the 2 np nodal unknowns.
    let mut energy: Vec<(usize, usize, f64)> = Vec::new();
    let mut lumped = vec![0.0; np];
    let straight = triangle_rule_cached(if mesh.degree == 2 { 2 } else { 0 });
    let curved = triangle_rule_cached(CURVED_DEGREE);
    for t in 0..mesh.triangles.len() {
        let nodes = mesh.nodes(t);
        let nn = nodes.len();
        let x = mesh.coords(t);
        let rule = if is_curved(mesh, t) { curved } else { straight };
        let mut k = vec![0.0; 4 * nn * nn];
        for (&xi, &w) in rule.points.iter().zip(&rule.weights) {
            let g = shape_gradients(nn, xi);
            let jac = jacobian(&x, nn, &g);
            let wd = w * jac.det;
            for p in 0..nn {
                lumped[nodes[p] as usize] += wd / nn as f64;
            }
            let gp: Vec<[f64; 2]> = (0..nn).map(|i| jac.physical_gradient(g[i])).collect();
            // ε of the basis function (node i, component c): sym(e_c ⊗ ∇φ_i).
            for i in 0..nn {
                for c in 0..2 {
                    for j in 0..nn {
                        for d in 0..2 {
                            let ei = strain(c, gp[i]);
                            let ej = strain(d, gp[j]);
                            let dd = ei[0] * ej[0] + 2.0 * ei[1] * ej[1] + ei[2] * ej[2];
                            let tr = (ei[0] + ei[2]) * (ej[0] + ej[2]);
                            let lam = if el.lambda.is_finite() {
                                el.lambda
                            } else {
                                0.0
                            };
                            k[((2 * i + c) * nn + j) * 2 + d] += wd * (2.0 * el.mu * dd + lam * tr);
                        }
                    }
                }
            }
        }
        for i in 0..nn {
            for c in 0..2 {
                for j in 0..nn {
                    for d in 0..2 {
                        let (gi, gj) = (2 * nodes[i] as usize + c, 2 * nodes[j] as usize + d);
                        if gi >= gj {
                            energy.push((gi, gj, k[((2 * i + c) * nn + j) * 2 + d]));
                        }
                    }
                }
            }
        }
    }
    let mut system = energy.clone();
    if !has_dirichlet {
        let w = el.mu / (length_scale * length_scale);
        for (p, m) in lumped.iter().enumerate() {
            system.push((2 * p, 2 * p, w * m));
            system.push((2 * p + 1, 2 * p + 1, w * m));
        }
    }
    let kfull = Lower { n, entries: system };

    // Variables y: v = v0 + T y; T is the identity except at contact nodes, where
    // (v_x, v_y) = n y_0 + t y_1 and v0 = n g; Dirichlet unknowns are fixed to u_D.
    let mut v0 = vec![0.0; n];
    for p in 0..np {
        if let Some((nn, g)) = con[p] {
            v0[2 * p] = nn[0] * g;
            v0[2 * p + 1] = nn[1] * g;
        }
    }
    let ku: Vec<f64> = {
        let diff: Vec<f64> = (0..n).map(|i| u[i / 2][i % 2] - v0[i]).collect();
        kfull.apply(&diff)
    };
    // Tᵀ applied to the column i of the unknown: coefficients per variable.
    let t_of = |i: usize| -> [(usize, f64); 2] {
        let p = i / 2;
        match con[p] {
            Some((nn, _)) => {
                let tt = [-nn[1], nn[0]];
                let c = i % 2;
                [(2 * p, nn[c]), (2 * p + 1, tt[c])]
            }
            None => [(i, 1.0), (usize::MAX, 0.0)],
        }
    };
    let mut fixed = vec![None::<f64>; n];
    for (p, d) in dir.iter().enumerate() {
        if let Some(ud) = d {
            fixed[2 * p] = Some(ud[0]);
            fixed[2 * p + 1] = Some(ud[1]);
        }
    }
    let mut b = vec![0.0; n];
    let mut entries = Vec::with_capacity(kfull.entries.len() * 2);
    for (i, &kui) in ku.iter().enumerate() {
        for &(vi, ci) in &t_of(i) {
            if vi != usize::MAX && fixed[vi].is_none() {
                b[vi] += ci * kui;
            }
        }
    }
    let mut push = |i: usize, j: usize, v: f64, b: &mut Vec<f64>| {
        for &(vi, ci) in &t_of(i) {
            if vi == usize::MAX {
                continue;
            }
            for &(vj, cj) in &t_of(j) {
                if vj == usize::MAX {
                    continue;
                }
                let val = ci * cj * v;
                match (fixed[vi], fixed[vj]) {
                    (None, None) if vi >= vj => entries.push((vi, vj, val)),
                    (None, None) => entries.push((vj, vi, val)),
                    (None, Some(f)) => b[vi] -= val * f,
                    _ => {}
                }
            }
        }
    };
    for &(i, j, v) in &kfull.entries {
        push(i, j, v, &mut b);
        if i != j {
            push(j, i, v, &mut b);
        }
    }
    // push() adds both orientations of off-diagonal blocks; keep the lower half once.
    let mut seen: Vec<(usize, usize, f64)> = entries;
    for e in seen.iter_mut() {
        if e.0 != e.1 {
            e.2 *= 0.5;
        }
    }
    for (i, f) in fixed.iter().enumerate() {
        if let Some(v) = f {
            seen.push((i, i, 1.0));
            b[i] = *v;
        }
    }
    let constrained: Vec<usize> = (0..np)
        .filter(|&p| con[p].is_some() && fixed[2 * p].is_none())
        .map(|p| 2 * p)
        .collect();
    let k = Lower { n, entries: seen };
    let (y, info) = solve_bound_qp(&k, &b, &constrained, super::stress::MAX_ITERATIONS)?;
    let mut v = vec![[0.0; 2]; np];
    for p in 0..np {
        match con[p] {
            Some((nn, g)) if fixed[2 * p].is_none() => {
                let tt = [-nn[1], nn[0]];
                for c in 0..2 {
                    v[p][c] = nn[c] * (g + y[2 * p]) + tt[c] * y[2 * p + 1];
                }
            }
            _ => v[p] = [y[2 * p], y[2 * p + 1]],
        }
    }
    let diff: Vec<f64> = (0..n).map(|i| v[i / 2][i % 2] - u[i / 2][i % 2]).collect();
    let e = Lower { n, entries: energy };
    let kd = e.apply(&diff);
    let distance = diff
        .iter()
        .zip(&kd)
        .map(|(a, b)| a * b)
        .sum::<f64>()
        .max(0.0)
        .sqrt();
    Ok(Projection {
        displacement: v,
        distance,
        info,
        violations,
    })
}

/// sym(e_c ⊗ g) as [xx, xy, yy].
#[inline]
fn strain(c: usize, g: [f64; 2]) -> [f64; 3] {
    if c == 0 {
        [g[0], 0.5 * g[1], 0.0]
    } else {
        [0.0, 0.5 * g[0], g[1]]
    }
}
