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

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::linalg::cholesky::{LltRef, SymbolicCholesky, factorize_symbolic_cholesky};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, Par, Side};

use crate::tolerance::{FLOW_ITERATIONS, FLOW_RELATIVE};

/// A 3 × 3 matrix.
pub type M3 = [[f64; 3]; 3];

/// The orthogonal projector onto the complement of span(`g`) (Gram–Schmidt; vectors whose
/// remainder is below `rel` of their norm are dependent): the moments a patch cannot take.
pub fn complement(g: &[[f64; 3]], rel: f64) -> M3 {
    let mut basis: Vec<[f64; 3]> = Vec::new();
    for v in g {
        let n0 = dot(*v, *v).sqrt();
        if n0 == 0.0 {
            continue;
        }
        let mut w = *v;
        for _ in 0..2 {
            for b in &basis {
                let a = dot(w, *b);
                for i in 0..3 {
                    w[i] -= a * b[i];
                }
            }
        }
        let n = dot(w, w).sqrt();
        if n > rel * n0 {
            basis.push([w[0] / n, w[1] / n, w[2] / n]);
        }
    }
    let mut q = [[0.0; 3]; 3];
    for i in 0..3 {
        q[i][i] = 1.0;
        for j in 0..3 {
            for b in &basis {
                q[i][j] -= b[i] * b[j];
            }
        }
    }
    q
}

#[inline]
fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

#[inline]
fn mul(q: &M3, v: [f64; 3]) -> [f64; 3] {
    [dot(q[0], v), dot(q[1], v), dot(q[2], v)]
}

/// The potentials p of module doc: Q L Q p = Q d with p = Q p, where Q_a projects onto the
/// moments patch a cannot take (identity for a patch without free fluxes, 0 for a Dirichlet
/// patch, the complement of its normal-flux moments for a contact patch; [`complement`]).
/// Returns q = Q p per vertex; the flow on edge (a, b) is q_a − q_b.
pub fn potentials(edges: &[[u32; 2]], q: &[M3], d: &[[f64; 3]]) -> Vec<[f64; 3]> {
    potentials_cached(edges, q, d, &mut FlowCache::default())
}

/// [`potentials`], keeping the factorisation in `cache` for later calls with the same `edges`
/// and `q` (the passes of one reconstruction; only the defects change).
pub fn potentials_cached(
    edges: &[[u32; 2]],
    q: &[M3],
    d: &[[f64; 3]],
    cache: &mut FlowCache,
) -> Vec<[f64; 3]> {
    let n = d.len();
    let (start, adj) = graph(edges, n);
    let comps = components(&start, &adj, q);
    let factors = cache
        .direct
        .get_or_insert_with(|| direct_for(&comps, &start, &adj, q));
    if let Some(p) = factors.as_ref().and_then(|f| solve_direct(f, d)) {
        return p;
    }
    let remove_kernel = |v: &mut [[f64; 3]]| {
        for (members, k) in &comps {
            if k.iter().all(|row| row.iter().all(|&x| x == 0.0)) {
                continue;
            }
            let mut mean = [0.0; 3];
            for &i in members {
                for c in 0..3 {
                    mean[c] += v[i as usize][c];
                }
            }
            let m = members.len() as f64;
            let km = mul(k, [mean[0] / m, mean[1] / m, mean[2] / m]);
            for &i in members {
                for c in 0..3 {
                    v[i as usize][c] -= km[c];
                }
            }
        }
    };
    let apply = |p: &[[f64; 3]], out: &mut [[f64; 3]]| {
        let qp: Vec<[f64; 3]> = (0..n).map(|v| mul(&q[v], p[v])).collect();
        for v in 0..n {
            let mut s = [0.0; 3];
            for &w in &adj[start[v]..start[v + 1]] {
                for c in 0..3 {
                    s[c] += qp[v][c] - qp[w as usize][c];
                }
            }
            out[v] = mul(&q[v], s);
        }
    };
    let mut rhs: Vec<[f64; 3]> = (0..n)
        .map(|v| {
            if start[v + 1] > start[v] {
                mul(&q[v], d[v])
            } else {
                [0.0; 3]
            }
        })
        .collect();
    remove_kernel(&mut rhs);
    let diag: Vec<f64> = (0..n)
        .map(|v| (start[v + 1] - start[v]).max(1) as f64)
        .collect();
    let p = cg(&apply, &rhs, &diag, q, &remove_kernel);
    (0..n).map(|v| mul(&q[v], p[v])).collect()
}

/// Fills `cache` with the factorisation that [`potentials_cached`] builds for `edges` and `q`
/// (one entry of `q` per vertex), so that it can run beside other work: it depends on the
/// graph and Q only, not on the defects. The caller must pass the same `edges` and `q` later.
pub fn prepare(edges: &[[u32; 2]], q: &[M3], cache: &mut FlowCache) {
    let (start, adj) = graph(edges, q.len());
    let comps = components(&start, &adj, q);
    cache.direct = Some(direct_for(&comps, &start, &adj, q));
}

/// The vertex graph of `edges` in CSR form: the neighbours of v are
/// `adj[start[v]..start[v + 1]]`.
fn graph(edges: &[[u32; 2]], n: usize) -> (Vec<usize>, Vec<u32>) {
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
    (start, adj)
}

/// Connected components and the moments none of their patches can take (the kernel of
/// Q L Q: p constant = c with c in every range of Q_a): the defect along them stays.
fn components(start: &[usize], adj: &[u32], q: &[M3]) -> Vec<(Vec<u32>, M3)> {
    let n = start.len() - 1;
    let mut comp = vec![u32::MAX; n];
    let mut comps: Vec<(Vec<u32>, M3)> = Vec::new();
    for s0 in 0..n {
        if comp[s0] != u32::MAX || start[s0 + 1] == start[s0] {
            continue;
        }
        let id = comps.len() as u32;
        let mut members = vec![s0 as u32];
        comp[s0] = id;
        let mut i = 0;
        let mut taken: Vec<[f64; 3]> = Vec::new();
        while i < members.len() {
            let v = members[i] as usize;
            // I − Q_a spans what patch a takes (Q_a is symmetric: its rows are its columns).
            for (r, row) in q[v].iter().enumerate() {
                let col: [f64; 3] = std::array::from_fn(|c| f64::from(u8::from(r == c)) - row[c]);
                if dot(col, col) > 1e-24 {
                    taken.push(col);
                }
            }
            for &w in &adj[start[v]..start[v + 1]] {
                if comp[w as usize] == u32::MAX {
                    comp[w as usize] = id;
                    members.push(w);
                }
            }
            i += 1;
        }
        let kernel = complement(&taken, 1e-10);
        comps.push((members, kernel));
    }
    comps
}

/// The direct factors when no component has a kernel ([`factor_direct`]), else None (CG).
fn direct_for(comps: &[(Vec<u32>, M3)], start: &[usize], adj: &[u32], q: &[M3]) -> Option<Direct> {
    comps
        .iter()
        .all(|(_, k)| k.iter().all(|row| row.iter().all(|&x| x == 0.0)))
        .then(|| factor_direct(start, adj, q))
        .flatten()
}

/// The factorisations for the potentials by sparse Cholesky when every Q_a is diagonal with
/// entries 0 and 1 (a patch takes a moment wholly or not at all: the projectors
/// `reconstruct::patch` builds) and every
/// connected component has a sink for every moment (no kernel). Then the three moments
/// decouple: for moment c, L restricted to the patches that cannot take it, with p = 0 on the
/// others, is the graph Laplacian with Dirichlet vertices, symmetric positive definite because
/// each free part of a component touches a sink. One factorisation per distinct free set
/// (O(N log N) fill for mesh graphs) replaces the O(N^½) CG steps per decade of accuracy, which
/// would be the serial bottleneck of a million-cell mesh. None when Q is not of that kind or
/// the factorisation fails (the caller then runs the CG). The factors depend on Q only, so
/// they are kept in a [`FlowCache`] for the next pass.
fn factor_direct(start: &[usize], adj: &[u32], q: &[M3]) -> Option<Direct> {
    let n = q.len();
    for m in q {
        for (i, row) in m.iter().enumerate() {
            for (j, &x) in row.iter().enumerate() {
                let ok = if i == j {
                    x == 0.0 || x == 1.0
                } else {
                    x == 0.0
                };
                if !ok {
                    return None;
                }
            }
        }
    }
    let free = |v: usize, c: usize| q[v][c][c] == 1.0 && start[v + 1] > start[v];
    let mut out = Direct {
        per: [None; 3],
        factors: Vec::new(),
    };
    for c in 0..3 {
        if c > 0 && (0..n).all(|v| free(v, c) == free(v, c - 1)) {
            out.per[c] = out.per[c - 1];
            continue;
        }
        let mut index = vec![usize::MAX; n];
        let mut count = 0usize;
        for (v, slot) in index.iter_mut().enumerate() {
            if free(v, c) {
                *slot = count;
                count += 1;
            }
        }
        if count == 0 {
            continue;
        }
        // The lower triangle column by column (unknowns in vertex order): the diagonal, then
        // the later neighbours in increasing order; a CSC built directly, not by sorting
        // (row, column) pairs (at 1M cells that sort took 0.66 s of a serial stage).
        let mut col_ptr = Vec::with_capacity(count + 1);
        let mut row_idx = Vec::with_capacity(count + adj.len() / 2);
        let mut values = Vec::with_capacity(count + adj.len() / 2);
        col_ptr.push(0usize);
        let mut later: Vec<usize> = Vec::new();
        for v in 0..n {
            let iv = index[v];
            if iv == usize::MAX {
                continue;
            }
            row_idx.push(iv);
            values.push((start[v + 1] - start[v]) as f64);
            later.clear();
            later.extend(
                adj[start[v]..start[v + 1]]
                    .iter()
                    .map(|&w| index[w as usize])
                    .filter(|&iw| iw != usize::MAX && iw > iv),
            );
            later.sort_unstable();
            row_idx.extend_from_slice(&later);
            values.extend(std::iter::repeat_n(-1.0, later.len()));
            col_ptr.push(row_idx.len());
        }
        let symbolic = SymbolicSparseColMatRef::new_checked(count, count, &col_ptr, None, &row_idx);
        let mat = SparseColMatRef::<usize, f64>::new(symbolic, &values);
        // Sequential on purpose: faer's parallel supernodal factorisation rounds differently
        // with the thread count, and the patch QPs carry that to the stress (1M bench:
        // bound.relative 69.0282 with 2 threads against 69.0292 with 1). Sequential, the
        // factorisation takes 1.9 s and the solves 0.26 s of the 1M patch stage (≈ 31–38 s).
        let sym = factorize_symbolic_cholesky(
            symbolic,
            Side::Lower,
            Default::default(),
            Default::default(),
        )
        .ok()?;
        let mut values = vec![0.0; sym.len_val()];
        let mut mem = MemBuffer::try_new(
            sym.factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default()),
        )
        .ok()?;
        sym.factorize_numeric_llt(
            &mut values,
            mat,
            Side::Lower,
            Default::default(),
            Par::Seq,
            MemStack::new(&mut mem),
            Default::default(),
        )
        .ok()?;
        out.per[c] = Some(out.factors.len());
        out.factors.push(Factor {
            index,
            count,
            symbolic: sym,
            values,
        });
    }
    Some(out)
}

/// The solves of [`factor_direct`]'s factors for the defects `d`.
fn solve_direct(f: &Direct, d: &[[f64; 3]]) -> Option<Vec<[f64; 3]>> {
    let mut out = vec![[0.0; 3]; d.len()];
    for c in 0..3 {
        let Some(k) = f.per[c] else {
            continue;
        };
        let Factor {
            index,
            count,
            symbolic: sym,
            values,
        } = &f.factors[k];
        let mut rhs = faer::Mat::<f64>::zeros(*count, 1);
        for (v, &iv) in index.iter().enumerate() {
            if iv != usize::MAX {
                rhs[(iv, 0)] = d[v][c];
            }
        }
        let mut mem = MemBuffer::try_new(sym.solve_in_place_scratch::<f64>(1, Par::Seq)).ok()?;
        LltRef::<usize, f64>::new(sym, values).solve_in_place_with_conj(
            Conj::No,
            rhs.as_mut(),
            Par::Seq,
            MemStack::new(&mut mem),
        );
        for (v, &iv) in index.iter().enumerate() {
            if iv != usize::MAX {
                out[v][c] = rhs[(iv, 0)];
            }
        }
    }
    out.iter()
        .all(|p| p.iter().all(|x| x.is_finite()))
        .then_some(out)
}

/// Per moment, the factor of its free set (None: no free vertex); the factors with their
/// vertex → unknown maps and sizes.
struct Direct {
    per: [Option<usize>; 3],
    factors: Vec<Factor>,
}

/// One moment's factor: vertex → unknown map (usize::MAX for fixed vertices), size, and the
/// supernodal or simplicial L of the Dirichlet graph Laplacian.
struct Factor {
    index: Vec<usize>,
    count: usize,
    symbolic: SymbolicCholesky<usize>,
    values: Vec<f64>,
}

/// What [`potentials_cached`] keeps between the passes of one reconstruction: the sparse
/// Cholesky factors, which depend on the graph and Q only (or the finding that there are none).
#[derive(Default)]
pub struct FlowCache {
    direct: Option<Option<Direct>>,
}

/// y = A x on per-vertex 3-vectors.
type Operator<'a> = dyn Fn(&[[f64; 3]], &mut [[f64; 3]]) + 'a;

/// Preconditioned conjugate gradients for the symmetric positive semi-definite `apply`, the
/// iterates kept in the range of Q and off the kernel.
fn cg(
    apply: &Operator<'_>,
    rhs: &[[f64; 3]],
    diag: &[f64],
    q: &[M3],
    remove_kernel: &dyn Fn(&mut [[f64; 3]]),
) -> Vec<[f64; 3]> {
    let n = rhs.len();
    let inner =
        |a: &[[f64; 3]], b: &[[f64; 3]]| a.iter().zip(b).map(|(x, y)| dot(*x, *y)).sum::<f64>();
    let norm0 = inner(rhs, rhs).sqrt();
    let mut x = vec![[0.0; 3]; n];
    if norm0 == 0.0 {
        return x;
    }
    let precondition = |r: &[[f64; 3]]| -> Vec<[f64; 3]> {
        let mut z: Vec<[f64; 3]> = (0..n)
            .map(|v| {
                let s = 1.0 / diag[v];
                mul(&q[v], [r[v][0] * s, r[v][1] * s, r[v][2] * s])
            })
            .collect();
        remove_kernel(&mut z);
        z
    };
    let mut r = rhs.to_vec();
    let mut z = precondition(&r);
    let mut p = z.clone();
    let mut rz = inner(&r, &z);
    let mut ap = vec![[0.0; 3]; n];
    for _ in 0..FLOW_ITERATIONS {
        apply(&p, &mut ap);
        let pap = inner(&p, &ap);
        if pap <= 0.0 || !pap.is_finite() {
            break;
        }
        let alpha = rz / pap;
        for i in 0..n {
            for c in 0..3 {
                x[i][c] += alpha * p[i][c];
                r[i][c] -= alpha * ap[i][c];
            }
        }
        if inner(&r, &r).sqrt() <= FLOW_RELATIVE * norm0 {
            break;
        }
        z = precondition(&r);
        let rz_new = inner(&r, &z);
        let beta = rz_new / rz;
        rz = rz_new;
        for i in 0..n {
            for c in 0..3 {
                p[i][c] = z[i][c] + beta * p[i][c];
            }
        }
    }
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
        let id = complement(&[], 1e-10);
        let q = [id, id, id, [[0.0; 3]; 3]];
        let d = [
            [1.0, 0.0, 2.0],
            [0.5, 0.0, 0.0],
            [-0.25, 1.0, 0.0],
            [9.0, 9.0, 9.0],
        ];
        let p = potentials(&edges, &q, &d);
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
    fn a_grid_with_sinks_on_one_side_is_balanced_at_every_free_vertex() {
        // 30 × 20 grid with diagonals, sinks on the column x = 0, Q diagonal 0/1 (the direct
        // path), the rotation moment taken everywhere (as without weak symmetry): the defining
        // equation d_a = (L p)_a at every vertex that cannot take moment c, p_a = 0 elsewhere.
        let (nx, ny) = (30usize, 20usize);
        let id = |i: usize, j: usize| (j * nx + i) as u32;
        let mut edges = Vec::new();
        for j in 0..ny {
            for i in 0..nx {
                if i + 1 < nx {
                    edges.push([id(i, j), id(i + 1, j)]);
                }
                if j + 1 < ny {
                    edges.push([id(i, j), id(i, j + 1)]);
                }
                if i + 1 < nx && j + 1 < ny {
                    edges.push([id(i, j), id(i + 1, j + 1)]);
                }
            }
        }
        let n = nx * ny;
        let take_rotation = complement(&[[0.0, 0.0, 1.0]], 1e-10);
        let q: Vec<M3> = (0..n)
            .map(|v| {
                if v % nx == 0 {
                    [[0.0; 3]; 3]
                } else {
                    take_rotation
                }
            })
            .collect();
        let d: Vec<[f64; 3]> = (0..n)
            .map(|v| {
                let x = v as f64;
                [(0.37 * x).sin(), (0.11 * x).cos() - 0.5, 3.0]
            })
            .collect();
        let p = potentials(&edges, &q, &d);
        let mut lp = vec![[0.0; 3]; n];
        for &[a, b] in &edges {
            for c in 0..3 {
                let y = p[a as usize][c] - p[b as usize][c];
                lp[a as usize][c] += y;
                lp[b as usize][c] -= y;
            }
        }
        for v in 0..n {
            if v % nx == 0 {
                assert_eq!(p[v], [0.0; 3]);
                continue;
            }
            for c in 0..2 {
                assert!((lp[v][c] - d[v][c]).abs() < 1e-11, "vertex {v} moment {c}");
            }
            assert_eq!(p[v][2], 0.0, "the rotation is taken everywhere");
        }
    }

    #[test]
    fn a_sink_free_cycle_is_balanced_when_the_defects_sum_to_zero() {
        let edges = [[0, 1], [1, 2], [2, 3], [3, 0], [0, 2]];
        let q = [complement(&[], 1e-10); 4];
        let d = [
            [1.0, 0.0, 0.0],
            [-2.0, 0.0, 0.0],
            [0.5, 0.0, 0.0],
            [0.5, 0.0, 0.0],
        ];
        let p = potentials(&edges, &q, &d);
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

    #[test]
    fn a_contact_patch_takes_only_its_normal_moments() {
        // 0 — 1(contact: takes e_y only): the x-defect of 0 cannot go anywhere (kernel), the
        // y-defect flows into 1; vertex 0 balanced in y exactly.
        let edges = [[0, 1]];
        let q = [
            complement(&[], 1e-10),
            complement(&[[0.0, 1.0, 0.0]], 1e-10),
        ];
        let d = [[0.0, 2.0, 0.0], [0.0, 0.0, 0.0]];
        let p = potentials(&edges, &q, &d);
        let y = [p[0][1] - p[1][1], p[0][0] - p[1][0]];
        assert!((y[0] - 2.0).abs() < 1e-12 && y[1].abs() < 1e-12, "{p:?}");
        // Projector of the complement of span(e_y): diag(1, 0, 1).
        let c = complement(&[[0.0, 3.0, 0.0]], 1e-10);
        assert_eq!(c, [[1.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 1.0]]);
    }
}
