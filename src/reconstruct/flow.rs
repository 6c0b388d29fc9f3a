//! Balancing flows between vertex patches (docs/design.md §5.10, "defects").
//!
//! A patch problem is solvable only when its load ℓ_a (the body force and Cε(u_h)∇ψ_a, the
//! tractions ψ_a t) has zero moments d_a ∈ ℝ³ against the rigid motions ρ₁ = e_x, ρ₂ = e_y,
//! ρ₃ = (x − x₀)^⊥. That holds for a Galerkin solution of the discrete problem with our
//! quadrature, not for a file from a solver that integrated f or t otherwise. Any loads ℓ'_a with
//! Σ_a ℓ'_a = Σ_a ℓ_a give an equilibrated sum just as well, so the defects are moved between
//! patches: a load h_E with moments y_E on the cells of edge E = (a, b) is subtracted from patch a
//! and added to patch b. With y_E = p_a − p_b and the graph Laplacian L (unit weights),
//!
//! ```text
//! d'_a = d_a − Σ_{b ~ a} (p_a − p_b) = d_a − (L p)_a = 0     for every patch a that is not a sink,
//! ```
//!
//! p = 0 on the sinks (patches with Dirichlet or contact fluxes, which take any load). This
//! module solves L p = d, component by component, by conjugate gradients with a Jacobi
//! preconditioner (no factorisation; each step is one pass over the edges). A component of the
//! graph without a sink can only be balanced up to its mean defect, which is left (and shows
//! as a patch defect downstream).

use crate::tolerance::{FLOW_ITERATIONS, FLOW_RELATIVE};

/// p with L p = d on the non-sink vertices, p = 0 on the sinks (module doc), per component.
/// `edges` are vertex pairs; `d` has one entry per vertex (sinks' entries are ignored).
pub fn potentials(edges: &[[u32; 2]], sink: &[bool], d: &[[f64; 3]]) -> Vec<[f64; 3]> {
    let n = d.len();
    // CSR adjacency.
    let mut start = vec![0usize; n + 1];
    for &[a, b] in edges {
        start[a as usize + 1] += 1;
        start[b as usize + 1] += 1;
    }
    for i in 0..n {
        start[i + 1] += start[i];
    }
    let mut fill = start.clone();
    let mut adj = vec![0u32; start[n]];
    for &[a, b] in edges {
        adj[fill[a as usize]] = b;
        fill[a as usize] += 1;
        adj[fill[b as usize]] = a;
        fill[b as usize] += 1;
    }
    // Components without a sink: their defects are made mean-free (the rest is unreachable).
    let mut comp = vec![u32::MAX; n];
    let mut comps: Vec<(bool, Vec<u32>)> = Vec::new();
    for s in 0..n {
        if comp[s] != u32::MAX || start[s + 1] == start[s] {
            continue;
        }
        let id = comps.len() as u32;
        let mut members = vec![s as u32];
        comp[s] = id;
        let mut i = 0;
        let mut has_sink = false;
        while i < members.len() {
            let v = members[i] as usize;
            has_sink |= sink[v];
            for &w in &adj[start[v]..start[v + 1]] {
                if comp[w as usize] == u32::MAX {
                    comp[w as usize] = id;
                    members.push(w);
                }
            }
            i += 1;
        }
        comps.push((has_sink, members));
    }
    let free = |v: usize| !sink[v] && start[v + 1] > start[v];
    let mut out = vec![[0.0; 3]; n];
    for c in 0..3 {
        let mut rhs: Vec<f64> = (0..n).map(|v| if free(v) { d[v][c] } else { 0.0 }).collect();
        for (has_sink, members) in &comps {
            if !has_sink {
                let mean = members.iter().map(|&v| rhs[v as usize]).sum::<f64>()
                    / members.len() as f64;
                for &v in members {
                    rhs[v as usize] -= mean;
                }
            }
        }
        let apply = |p: &[f64], out: &mut [f64]| {
            for v in 0..n {
                out[v] = if free(v) {
                    let mut s = 0.0;
                    for &w in &adj[start[v]..start[v + 1]] {
                        s += p[v] - p[w as usize];
                    }
                    s
                } else {
                    0.0
                };
            }
        };
        let diag: Vec<f64> = (0..n)
            .map(|v| (start[v + 1] - start[v]).max(1) as f64)
            .collect();
        let p = cg(&apply, &rhs, &diag, &comps);
        for v in 0..n {
            out[v][c] = p[v];
        }
    }
    out
}

/// Preconditioned conjugate gradients for the symmetric positive (semi-)definite operator
/// `apply` restricted to the free vertices; sink-free components are kept mean-free.
fn cg(
    apply: &dyn Fn(&[f64], &mut [f64]),
    rhs: &[f64],
    diag: &[f64],
    comps: &[(bool, Vec<u32>)],
) -> Vec<f64> {
    let n = rhs.len();
    let norm0 = rhs.iter().map(|v| v * v).sum::<f64>().sqrt();
    let mut x = vec![0.0; n];
    if norm0 == 0.0 {
        return x;
    }
    let project = |v: &mut [f64]| {
        for (has_sink, members) in comps {
            if !has_sink {
                let mean = members.iter().map(|&i| v[i as usize]).sum::<f64>()
                    / members.len() as f64;
                for &i in members {
                    v[i as usize] -= mean;
                }
            }
        }
    };
    let mut r = rhs.to_vec();
    let mut z: Vec<f64> = r.iter().zip(diag).map(|(a, b)| a / b).collect();
    project(&mut z);
    let mut p = z.clone();
    let mut rz: f64 = r.iter().zip(&z).map(|(a, b)| a * b).sum();
    let mut ap = vec![0.0; n];
    for _ in 0..FLOW_ITERATIONS {
        apply(&p, &mut ap);
        let pap: f64 = p.iter().zip(&ap).map(|(a, b)| a * b).sum();
        if pap <= 0.0 || !pap.is_finite() {
            break;
        }
        let alpha = rz / pap;
        for i in 0..n {
            x[i] += alpha * p[i];
            r[i] -= alpha * ap[i];
        }
        let rn = r.iter().map(|v| v * v).sum::<f64>().sqrt();
        if rn <= FLOW_RELATIVE * norm0 {
            break;
        }
        for i in 0..n {
            z[i] = r[i] / diag[i];
        }
        project(&mut z);
        let rz_new: f64 = r.iter().zip(&z).map(|(a, b)| a * b).sum();
        let beta = rz_new / rz;
        rz = rz_new;
        for i in 0..n {
            p[i] = z[i] + beta * p[i];
        }
    }
    project(&mut x);
    x
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_path_to_one_sink_carries_the_sum_of_the_defects_upstream() {
        // 0 — 1 — 2 — 3(sink): by hand, the flow on edge (i, i+1) is the sum of d over 0..=i,
        // and d'_a = d_a − (Lp)_a = 0 at the free vertices.
        let edges = [[0, 1], [1, 2], [2, 3]];
        let sink = [false, false, false, true];
        let d = [[1.0, 0.0, 2.0], [0.5, 0.0, 0.0], [-0.25, 1.0, 0.0], [9.0, 9.0, 9.0]];
        let p = potentials(&edges, &sink, &d);
        let flows: Vec<f64> = edges
            .iter()
            .map(|&[a, b]| p[a as usize][0] - p[b as usize][0])
            .collect();
        let expect = [1.0, 1.5, 1.25];
        for (f, e) in flows.iter().zip(expect) {
            assert!((f - e).abs() < 1e-12, "{flows:?}");
        }
        assert!((p[0][2] - p[1][2] - 2.0).abs() < 1e-12);
        assert_eq!(p[3], [0.0; 3]);
    }

    #[test]
    fn a_sink_free_cycle_is_balanced_when_the_defects_sum_to_zero() {
        let edges = [[0, 1], [1, 2], [2, 3], [3, 0], [0, 2]];
        let sink = [false; 4];
        let d = [[1.0, 0.0, 0.0], [-2.0, 0.0, 0.0], [0.5, 0.0, 0.0], [0.5, 0.0, 0.0]];
        let p = potentials(&edges, &sink, &d);
        let mut lp = [0.0; 4];
        for &[a, b] in &edges {
            let y = p[a as usize][0] - p[b as usize][0];
            lp[a as usize] += y;
            lp[b as usize] -= y;
        }
        for v in 0..4 {
            assert!((lp[v] - d[v][0]).abs() < 1e-12, "{lp:?}");
        }
    }
}
