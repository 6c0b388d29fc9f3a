//! Displacement reconstruction from a stress (docs/design.md §5.7): u_h = argmin F(·, σ_h) over
//! the mesh's Lagrange space with v = u_D and v_n ≤ g at the nodes, a bound-constrained QP in
//! the contact frames of [`super::nodal`]; with Coulomb friction the lumped |v_t| is split as
//! v_t = a − b, a, b ≥ 0, and the talk's remedy holds v_t = 0 where it changes sign in an edge.

use super::nodal::{CellTables, Frames, Tangential, boundary_nodes, stiffness, strain};
use crate::field::StressField;
use crate::geometry::values::interior_table;
use crate::geometry::{MAX_NODES, facet_point};
use crate::material::Elastic;
use crate::mesh::{Mesh, NONE};
use crate::problem::{BoundaryEdge, Condition, Context};
use crate::quadrature::line_rule_cached;
use crate::read::scene::{BoundaryKind, Norm, Scene};
use crate::solve::{Lower, SolveInfo, solve_bound_qp_from};
use crate::topology::Topology;

/// What the reconstruction's parts read (built from the [`Context`]).
struct ReconstructInput<'a> {
    mesh: &'a Mesh,
    topo: &'a Topology,
    scene: &'a Scene,
    edges: &'a [BoundaryEdge],
    sigma: StressField<'a>,
    norm: Norm,
}

/// A reconstructed displacement and what it took.
pub struct Reconstruction {
    pub displacement: Vec<[f64; 2]>,
    /// The last QP solve, with `iterations` summed over all of them.
    pub info: SolveInfo,
    /// QP solves (1, plus one per round of the remedy).
    pub friction_iterations: usize,
    /// Whether the remedy settled before the cap.
    pub friction_converged: bool,
    /// Frictional contact nodes with v_t = 0 (to 1e-12 of max |v|; stick, or the remedy) and
    /// with v_t ≠ 0.
    pub stick: usize,
    pub slip: usize,
    /// Nodes held at v_t = 0 by the remedy (a sign change of v_t inside an edge).
    pub remedied: usize,
}

/// Cap on the rounds of the remedy in [`reconstruct`].
pub const MAX_FRICTION_ITERATIONS: usize = 50;

/// Reconstructs the displacement from a stress (docs/design.md §5):
///
/// ```text
/// u_h = argmin { F(v, σ_h) : v ∈ P_k(T_h)², v = u_D at the Dirichlet nodes,
///                 v_n ≤ g at the contact nodes },
/// F(v, σ_h) = ∫ Q(ε(v) − Aσ_h) + ⟨v_n − g, σ_n⟩ + ⟨𝔉|σ_n|, |v_t|⟩ + ⟨σ_t, v_t⟩ + const,
/// ```
///
/// k the mesh degree and Q(e) = B(e, e) the preset's density: ½ vᵀKv − fᵀv with
/// K = 2∫B(ε(φ_i), ε(φ_j)) and f_j = 2∫B(Aσ_h, ε(φ_j)) − ∫_{Γ_C} (σ_n n + σ_t t)·φ_j (the
/// σ_t part with friction only: the frictionless functional has no friction term).
/// |v_t| is the nonsmooth part: lumped to Σ_p c_p |v_t(p)|, c_p = ∫ 𝔉|σ_n| φ_p (exact for P1
/// when v_t keeps its sign on each edge), and with v_t(p) = a_p − b_p, a_p, b_p ≥ 0, it becomes
/// the linear Σ_p c_p (a_p + b_p) of a bound-constrained QP (at its minimiser one of a_p, b_p
/// vanishes). Where v_t would change sign inside an edge the talk's remedy holds the node with
/// the smaller |v_t| at v_t = 0 and the QP is solved again.
pub fn reconstruct(ctx: &Context, sigma: StressField) -> Result<Reconstruction, String> {
    let inp = &ReconstructInput {
        mesh: ctx.mesh,
        topo: ctx.topo,
        scene: ctx.scene,
        edges: ctx.edges,
        sigma,
        norm: ctx.norm,
    };
    let mesh = inp.mesh;
    let np = mesh.points.len();
    let el = Elastic::new(&inp.scene.material);
    if inp.norm == Norm::Energy && el.lambda.is_infinite() {
        return Err("the energy norm needs λ < ∞".into());
    }
    let (dir, con) = boundary_nodes(mesh, inp.topo, inp.scene, inp.edges);
    if !dir.iter().any(Option::is_some) {
        return Err(
            "without a Dirichlet boundary the displacement is determined by the stress only up \
             to a rigid motion"
                .into(),
        );
    }
    // 2B(x, y) = a x:y + b tr x tr y (docs/design.md §3).
    let (a, b) = match inp.norm {
        Norm::Energy => (2.0 * el.mu, el.lambda),
        Norm::Robust => (2.0 * el.mu, 0.0),
        Norm::Seed => (1.0, 0.0),
    };
    let (entries, _) = stiffness(mesh, a, b);
    let k = Lower { n: 2 * np, entries };
    let mut f = volume_load(mesh, inp.sigma, &el, a, b);
    let (cweights, frictional) = contact_load(inp, &con, &mut f);

    // With friction: c_p |v_t(p)| by the split v_t = a − b (exact QP for the lumped term),
    // started with every frictional node sticking; then the talk's remedy where v_t changes
    // sign inside an edge (the lumped term would overrate |v_t| there): the weaker node is
    // held at v_t = 0 and the QP solved again.
    let mut tangential: Vec<Tangential> = (0..np)
        .map(|p| {
            if frictional[p] {
                Tangential::Split
            } else {
                Tangential::Free
            }
        })
        .collect();
    let maxdiag = k
        .entries
        .iter()
        .filter(|e| e.0 == e.1)
        .fold(0.0f64, |m, e| m.max(e.2.abs()));
    let delta = 1e-10 * maxdiag;
    let vscale = crate::field::max_norm;
    let mut iterations = 0;
    let mut converged = false;
    let mut remedied = 0;
    let mut qp_iterations = 0;
    let mut guess: Vec<usize> = Vec::new();
    let (mut v, mut info);
    loop {
        iterations += 1;
        let frames = Frames::new(&dir, &con, &tangential);
        let (kr, br, bounded) = frames.reduce(&k, &f, &cweights, delta);
        if iterations == 1 {
            // Stick: both split variables at their bound.
            guess = (0..np)
                .filter(|&p| frames.extra[p] != usize::MAX)
                .flat_map(|p| [2 * p + 1, frames.extra[p]])
                .collect();
        }
        let (mut y, mut i) =
            solve_bound_qp_from(&kr, &br, &bounded, super::stress::MAX_ITERATIONS, &guess)?;
        // The regularisation shifts the slipping nodes by O(delta): solve once more without
        // it from the final active set (at most one split variable per node is free there, so
        // the matrix is definite); keep the regularised solution if that fails.
        if frames.extra.iter().any(|&e| e != usize::MAX) {
            let active: Vec<usize> = bounded.iter().copied().filter(|&q| y[q] == 0.0).collect();
            let (k0, b0, _) = frames.reduce(&k, &f, &cweights, 0.0);
            if let Ok((y0, i0)) =
                solve_bound_qp_from(&k0, &b0, &bounded, super::stress::MAX_ITERATIONS, &active)
                && i0.converged
                && y0.iter().all(|x| x.is_finite())
            {
                qp_iterations += i.iterations;
                (y, i) = (y0, i0);
            }
        }
        v = frames.expand(&y);
        qp_iterations += i.iterations;
        info = SolveInfo {
            iterations: qp_iterations,
            ..i
        };
        // The same variables keep their numbers (2p, 2p + 1) when a node is remedied: the
        // next solve starts from this active set.
        guess = bounded
            .iter()
            .copied()
            .filter(|&q| y[q] == 0.0 && q < 2 * np)
            .collect();
        if !frictional.iter().any(|&x| x) {
            converged = true;
            break;
        }
        let tiny = 1e-12 * vscale(&v).max(f64::MIN_POSITIVE);
        let vt = |p: usize| -> f64 {
            let (n, _) = con[p].expect("frictional nodes are contact nodes");
            -n[1] * v[p][0] + n[0] * v[p][1]
        };
        let changed = remedy(inp, &mut tangential, &|p| vt(p), tiny);
        remedied += changed;
        if changed == 0 {
            converged = true;
            break;
        }
        if iterations >= MAX_FRICTION_ITERATIONS {
            break;
        }
    }
    let (mut stick, mut slip) = (0, 0);
    let tiny = 1e-12 * vscale(&v).max(f64::MIN_POSITIVE);
    for p in (0..np).filter(|&p| frictional[p]) {
        let (n, _) = con[p].expect("frictional nodes are contact nodes");
        if (-n[1] * v[p][0] + n[0] * v[p][1]).abs() <= tiny {
            stick += 1;
        } else {
            slip += 1;
        }
    }
    Ok(Reconstruction {
        displacement: v,
        info,
        friction_iterations: iterations,
        friction_converged: converged,
        stick,
        slip,
        remedied,
    })
}

/// The talk's remedy: on a frictional contact edge whose nodes carry both signs of v_t (beyond
/// `tiny`), the node with the smaller |v_t| among the minority sign is held at v_t = 0.
/// Returns how many nodes changed.
fn remedy(
    inp: &ReconstructInput,
    state: &mut [Tangential],
    vt: &dyn Fn(usize) -> f64,
    tiny: f64,
) -> usize {
    let mut count = 0;
    for be in inp.edges {
        if !matches!(be.condition, Condition::Contact(_)) {
            continue;
        }
        let [a, b] = inp.topo.edges[be.edge as usize];
        let mid = inp.topo.edge_mid[be.edge as usize];
        let nodes: Vec<usize> = [a, b, mid]
            .into_iter()
            .filter(|&p| p != NONE && state[p as usize] == Tangential::Split)
            .map(|p| p as usize)
            .collect();
        let pos: Vec<usize> = nodes.iter().copied().filter(|&p| vt(p) > tiny).collect();
        let neg: Vec<usize> = nodes.iter().copied().filter(|&p| vt(p) < -tiny).collect();
        if pos.is_empty() || neg.is_empty() {
            continue;
        }
        let weakest = pos
            .iter()
            .chain(&neg)
            .copied()
            .min_by(|&p, &q| vt(p).abs().total_cmp(&vt(q).abs()))
            .expect("both signs present");
        state[weakest] = Tangential::Zero;
        count += 1;
    }
    count
}

/// σ (row-major) at parent reference point `xi` of cell `t` with map Jacobian `jac` and
/// shape values `phi` there.
fn stress_at(
    mesh: &Mesh,
    sigma: StressField,
    t: usize,
    xi: [f64; 2],
    phi: &[f64; MAX_NODES],
) -> [f64; 4] {
    match sigma {
        StressField::Rt(rt) => rt.at_parent(mesh, t, xi).0,
        StressField::Nodal(values) => {
            let mut s = [0.0; 4];
            for (k, &p) in mesh.nodes(t).iter().enumerate() {
                for m in 0..4 {
                    s[m] += phi[k] * values[p as usize][m];
                }
            }
            s
        }
    }
}

/// f_j = 2∫B(Aσ_h, ε(φ_j)) with 2B(x, y) = a x:y + b tr x tr y; quadrature of the interior
/// terms ([`interior_table`]): exact on affine cells.
fn volume_load(mesh: &Mesh, sigma: StressField, el: &Elastic, a: f64, b: f64) -> Vec<f64> {
    let mut f = vec![0.0; 2 * mesh.points.len()];
    let rt = match sigma {
        StressField::Rt(r) => Some(r.order.k()),
        StressField::Nodal(_) => None,
    };
    let mut tables = CellTables::new(|fam, sh| interior_table(fam, sh, rt, true));
    for t in 0..mesh.len() {
        let nodes = mesh.nodes(t);
        let nn = nodes.len();
        let x = mesh.coords(t);
        let mut sn = [[0.0; 4]; MAX_NODES];
        if let StressField::Nodal(v) = sigma {
            for (k, &p) in nodes.iter().enumerate() {
                sn[k] = v[p as usize];
            }
        }
        let cv = tables.get(mesh, t);
        cv.reinit(&x[..nn], mesh.shape[t]);
        for q in 0..cv.len() {
            let wd = cv.jxw[q];
            let e = el.compliance(sigma.at_point(cv, t, q, &sn).0);
            // a e:ε + b tr e tr ε with ε = sym(e_c ⊗ ∇φ) and e symmetrised (ε is symmetric).
            let exy = 0.5 * (e[1] + e[2]);
            let tr = e[0] + e[3];
            for (i, &p) in nodes.iter().enumerate() {
                let gp = cv.grad[q][i];
                for c in 0..2 {
                    let s = strain(c, gp);
                    let dd = e[0] * s[0] + 2.0 * exy * s[1] + e[3] * s[2];
                    f[2 * p as usize + c] += wd * (a * dd + b * tr * (s[0] + s[2]));
                }
            }
        }
    }
    f
}

/// Adds −∫_{Γ_C} (σ_n n + σ_t t)·φ_j to `f` (σ_t only with friction); returns c_p = ∫ 𝔉|σ_n| φ_p per node and which
/// nodes carry friction (contact nodes off the Dirichlet boundary with 𝔉 > 0).
fn contact_load(
    inp: &ReconstructInput,
    con: &[Option<([f64; 2], f64)>],
    f: &mut [f64],
) -> (Vec<f64>, Vec<bool>) {
    let mesh = inp.mesh;
    let np = mesh.points.len();
    let mut c = vec![0.0; np];
    let mut frictional = vec![false; np];
    let rule = line_rule_cached(EDGE_DEGREE);
    for be in inp.edges {
        let Condition::Contact(bi) = be.condition else {
            continue;
        };
        let BoundaryKind::Contact(spec) = &inp.scene.boundaries[bi].kind else {
            continue;
        };
        let t = be.cell as usize;
        let l = be.local as usize;
        let nodes = mesh.nodes(t);
        let nn = nodes.len();
        let x = mesh.coords(t);
        for (&s, &w) in rule.points.iter().zip(&rule.weights) {
            let fp = facet_point(mesh.family[t], &x[..nn], l, s);
            let (normal, len) = (fp.normal, fp.ds);
            let sig = stress_at(mesh, inp.sigma, t, fp.xi, &fp.phi);
            let tr = [
                sig[0] * normal[0] + sig[1] * normal[1],
                sig[2] * normal[0] + sig[3] * normal[1],
            ];
            let n = spec.direction(normal);
            let tt = [-n[1], n[0]];
            let sn = n[0] * tr[0] + n[1] * tr[1];
            let st = tt[0] * tr[0] + tt[1] * tr[1];
            let phi = fp.phi;
            let wl = w * len;
            for (k, &p) in nodes.iter().enumerate() {
                let p = p as usize;
                if phi[k] == 0.0 {
                    continue;
                }
                // The friction term ⟨𝔉|σ_n|, |v_t|⟩ + ⟨σ_t, v_t⟩ exists for 𝔉 > 0 only
                // (docs/design.md §3); without friction σ_t = 0 is a constraint on σ, not a load.
                let st = if spec.friction > 0.0 { st } else { 0.0 };
                for d in 0..2 {
                    f[2 * p + d] -= wl * phi[k] * (sn * n[d] + st * tt[d]);
                }
                if spec.friction > 0.0 && con[p].is_some() {
                    c[p] += wl * phi[k] * spec.friction * sn.abs();
                    frictional[p] = true;
                }
            }
        }
    }
    (c, frictional)
}

/// Gauss–Legendre degree on contact edges: the P2 × P2 × (curved) length-element integrands
/// with a margin; |σ_n| is smooth for σ_n of one sign.
const EDGE_DEGREE: usize = crate::tolerance::EDGE_DEGREE_NODAL;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::estimate;
    use crate::problem::Stress;
    use crate::reconstruct::projection::nodal_violations;

    struct Case {
        fx: crate::problem::Fixture,
        u: Vec<[f64; 2]>,
        sigma: Vec<[f64; 4]>,
    }

    fn load(case: &str) -> Case {
        let fx = crate::problem::fixture(case);
        let Stress::Nodal { values, .. } = &fx.fields.stress else {
            panic!("nodal stress expected")
        };
        Case {
            u: fx.displacement(),
            sigma: values.clone(),
            fx,
        }
    }

    impl Case {
        fn context(&self, norm: Norm) -> Context<'_> {
            self.fx.context(norm)
        }
    }

    fn functional(c: &Case, u: &[[f64; 2]], norm: Norm) -> f64 {
        estimate::run(&c.context(norm), u, StressField::Nodal(&c.sigma))
            .functional
            .total
    }

    /// The reconstruction minimises F(·, σ_h) on K_u: the file's displacement (a scikit-fem
    /// active-set solution, admissible at the nodes) gives a larger F, and the decrease equals
    /// the decrease of the QP's objective ½vᵀKv − fᵀv, which is F up to a constant, to round-off
    /// (an independent check of K, f and the constraint handling against the estimator).
    #[test]
    fn reconstruction_minimises_the_functional_on_k_u() {
        for (case, norm) in [
            ("hertz_skfem_p2", Norm::Energy),
            ("hertz_skfem_p2", Norm::Seed),
            ("hertz_skfem_p1", Norm::Robust),
            ("manufactured_frictionless_p2_n08", Norm::Energy),
        ] {
            let c = load(case);
            let ctx = c.context(norm);
            let inp = ReconstructInput {
                mesh: &c.fx.data.mesh,
                topo: &c.fx.topo,
                scene: &c.fx.scene,
                edges: &c.fx.edges,
                sigma: StressField::Nodal(&c.sigma),
                norm,
            };
            let r = reconstruct(&ctx, inp.sigma).unwrap();
            assert!(r.info.converged && r.info.kkt_residual < 1e-12, "{case}");
            assert_eq!(nodal_violations(&ctx, &r.displacement), 0);
            let el = Elastic::new(&c.fx.scene.material);
            let (a, b) = match norm {
                Norm::Energy => (2.0 * el.mu, el.lambda),
                Norm::Robust => (2.0 * el.mu, 0.0),
                Norm::Seed => (1.0, 0.0),
            };
            let k = Lower {
                n: 2 * c.u.len(),
                entries: stiffness(&c.fx.data.mesh, a, b).0,
            };
            let mut f = volume_load(&c.fx.data.mesh, inp.sigma, &el, a, b);
            let (_, con) = boundary_nodes(&c.fx.data.mesh, &c.fx.topo, &c.fx.scene, &c.fx.edges);
            contact_load(&inp, &con, &mut f);
            let j = |v: &[[f64; 2]]| {
                let x: Vec<f64> = v.iter().flatten().copied().collect();
                let kx = k.apply(&x);
                x.iter()
                    .zip(&kx)
                    .zip(&f)
                    .map(|((x, kx), f)| 0.5 * x * kx - x * f)
                    .sum::<f64>()
            };
            let (f_file, f_rec) = (
                functional(&c, &c.u, norm),
                functional(&c, &r.displacement, norm),
            );
            assert!(f_rec < f_file, "{case} {norm:?}: {f_rec} ≥ {f_file}");
            let (dj, df) = (j(&r.displacement) - j(&c.u), f_rec - f_file);
            assert!(
                (dj - df).abs() <= 1e-9 * f_file.abs(),
                "{case} {norm:?}: ΔJ {dj} ΔF {df}"
            );
        }
    }
}
