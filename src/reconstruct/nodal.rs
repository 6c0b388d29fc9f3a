//! What the nodal QPs of the projection onto K_u ([`super::projection`]) and of the
//! displacement reconstruction ([`super::displacement`]) share (docs/design.md §5.6, §5.7):
//! the Dirichlet and contact data per node, the stiffness of the energy form, the change of
//! variables into contact frames, and the cell tables of the geometry layer.

use crate::geometry::values::rule_degree;
use crate::geometry::{CellValues, Family, Shape, Table, table};
use crate::mesh::{Mesh, NONE};
use crate::problem::{BoundaryEdge, Condition};
use crate::read::scene::{BoundaryKind, Scene};
use crate::solve::Lower;
use crate::topology::Topology;

/// Dirichlet values and contact (direction, gap) per mesh node; Dirichlet wins where both.
#[allow(clippy::type_complexity)]
pub(super) fn boundary_nodes(
    mesh: &Mesh,
    topo: &Topology,
    scene: &Scene,
    edges: &[BoundaryEdge],
) -> (Vec<Option<[f64; 2]>>, Vec<Option<([f64; 2], f64)>>) {
    let (dir, mut con) = boundary_nodes_both(mesh, topo, scene, edges);
    for (c, d) in con.iter_mut().zip(&dir) {
        if d.is_some() {
            *c = None;
        }
    }
    (dir, con)
}

/// The nodes held by Dirichlet data inside the obstacle of a contact boundary they also lie
/// on: n·u_D − g > `tol` there, so no displacement meets both conditions (K_u is empty and no
/// bound can hold). Each as (node, n·u_D − g).
pub fn dirichlet_inside_obstacle(ctx: &crate::problem::Context, tol: f64) -> Vec<(usize, f64)> {
    let (dir, con) = boundary_nodes_both(ctx.mesh, ctx.topo, ctx.scene, ctx.edges);
    dir.iter()
        .zip(&con)
        .enumerate()
        .filter_map(|(p, (d, c))| {
            let (ud, (n, g)) = ((*d)?, (*c)?);
            let excess = n[0] * ud[0] + n[1] * ud[1] - g;
            (excess > tol).then_some((p, excess))
        })
        .collect()
}

/// [`boundary_nodes`] with the contact (direction, gap) kept at Dirichlet nodes too.
#[allow(clippy::type_complexity)]
fn boundary_nodes_both(
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
        let [ea, eb, _] = mesh.edge(be.cell as usize, be.local as usize);
        let (s, e) = (mesh.points[ea as usize], mesh.points[eb as usize]);
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

/// The lower triangle of ∫ a ε(v):ε(w) + b tr ε(v) tr ε(w) over the 2·np nodal unknowns
/// (x and y of each mesh node interleaved), and the lumped mass per node. Quadrature is exact
/// on straight cells (degree 2(k − 1)) and of degree [`CURVED_DEGREE`] on curved ones.
pub(super) fn stiffness(mesh: &Mesh, a: f64, b: f64) -> (Vec<(usize, usize, f64)>, Vec<f64>) {
    stiffness_of(mesh, 0..mesh.len(), a, b)
}

/// [`stiffness`] assembled over the cells `cells` only (the lumped masses too).
pub(super) fn stiffness_of(
    mesh: &Mesh,
    cells: impl Iterator<Item = usize>,
    a: f64,
    b: f64,
) -> (Vec<(usize, usize, f64)>, Vec<f64>) {
    let np = mesh.points.len();
    let mut entries: Vec<(usize, usize, f64)> = Vec::new();
    let mut lumped = vec![0.0; np];
    let mut tables = CellTables::new(|f, sh| {
        let p = f.degree();
        let deg = if f.is_quad() { 2 * p } else { 2 * (p - 1) };
        table(f, rule_degree(sh, deg), false)
    });
    for t in cells {
        let nodes = mesh.nodes(t);
        let nn = nodes.len();
        let x = mesh.coords(t);
        let cv = tables.get(mesh, t);
        cv.reinit(&x[..nn], mesh.shape[t]);
        let mut k = vec![0.0; 4 * nn * nn];
        for q in 0..cv.len() {
            let wd = cv.jxw[q];
            for p in 0..nn {
                lumped[nodes[p] as usize] += wd / nn as f64;
            }
            let gp = &cv.grad[q];
            // ε of the basis function (node i, component c): sym(e_c ⊗ ∇φ_i).
            for i in 0..nn {
                for c in 0..2 {
                    let ei = strain(c, gp[i]);
                    for j in 0..nn {
                        for d in 0..2 {
                            let ej = strain(d, gp[j]);
                            let dd = ei[0] * ej[0] + 2.0 * ei[1] * ej[1] + ei[2] * ej[2];
                            let tr = (ei[0] + ei[2]) * (ej[0] + ej[2]);
                            k[((2 * i + c) * nn + j) * 2 + d] += wd * (a * dd + b * tr);
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
                            entries.push((gi, gj, k[((2 * i + c) * nn + j) * 2 + d]));
                        }
                    }
                }
            }
        }
    }
    (entries, lumped)
}

/// What the tangential unknown of a contact node may do (always `Free` for a projection).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Tangential {
    Free,
    /// v_t = 0 (the talk's remedy).
    Zero,
    /// v_t = a − b with a, b ≥ 0, for the friction term c_p |v_t(p)| = c_p (a + b) at the
    /// minimiser (where at most one of a, b is positive).
    Split,
}

/// The change of variables v = v₀ + T y of the nodal QPs: T is the identity except at contact
/// nodes, where v = n (g + y₀) + t y₁, or with `Split` v = n (g + y₀) + t (y_b − y₁) with the
/// extra variable y_b (a = −y₁, b = −y_b), so that every bound reads y ≤ 0; Dirichlet unknowns
/// and `Zero` tangents are fixed.
pub(super) struct Frames<'a> {
    pub(super) con: &'a [Option<([f64; 2], f64)>],
    /// Index of the extra variable of each `Split` node (else `usize::MAX`).
    pub(super) extra: Vec<usize>,
    /// Variables: 2 per node, then the extra ones.
    pub(super) n: usize,
    pub(super) fixed: Vec<Option<f64>>,
}

impl Frames<'_> {
    pub(super) fn new<'a>(
        dir: &[Option<[f64; 2]>],
        con: &'a [Option<([f64; 2], f64)>],
        tangential: &[Tangential],
    ) -> Frames<'a> {
        let np = dir.len();
        let mut extra = vec![usize::MAX; np];
        let mut n = 2 * np;
        let mut fixed = vec![None; 2 * np];
        for (p, d) in dir.iter().enumerate() {
            if let Some(ud) = d {
                fixed[2 * p] = Some(ud[0]);
                fixed[2 * p + 1] = Some(ud[1]);
            } else if con[p].is_some() {
                match tangential[p] {
                    Tangential::Zero => fixed[2 * p + 1] = Some(0.0),
                    Tangential::Split => {
                        extra[p] = n;
                        n += 1;
                        fixed.push(None);
                    }
                    Tangential::Free => {}
                }
            }
        }
        Frames {
            con,
            extra,
            n,
            fixed,
        }
    }

    /// The column entries of Tᵀ for Cartesian unknown i: (variable, coefficient).
    pub(super) fn of(&self, i: usize) -> [(usize, f64); 3] {
        let p = i / 2;
        match self.con[p] {
            Some((n, _)) if self.fixed[2 * p].is_none() => {
                let t = [-n[1], n[0]];
                let c = i % 2;
                if self.extra[p] == usize::MAX {
                    [(2 * p, n[c]), (2 * p + 1, t[c]), (usize::MAX, 0.0)]
                } else {
                    [(2 * p, n[c]), (2 * p + 1, -t[c]), (self.extra[p], t[c])]
                }
            }
            _ => [(i, 1.0), (usize::MAX, 0.0), (usize::MAX, 0.0)],
        }
    }

    pub(super) fn v0(&self, np: usize) -> Vec<f64> {
        let mut v0 = vec![0.0; 2 * np];
        for p in 0..np {
            if let Some((n, g)) = self.con[p]
                && self.fixed[2 * p].is_none()
            {
                v0[2 * p] = n[0] * g;
                v0[2 * p + 1] = n[1] * g;
            }
        }
        v0
    }

    /// minimise ½ vᵀKv − fᵀv + Σ_p c_p (a_p + b_p) over v = v₀ + T y with the fixed variables
    /// eliminated: the reduced matrix (TᵀKT, identity rows at fixed variables, `delta` added
    /// on the diagonal of the split variables, whose sum a + b is otherwise only held by the
    /// bounds), its right-hand side, and the variables bounded by y ≤ 0. `c` is per node
    /// (empty: no split nodes).
    pub(super) fn reduce(
        &self,
        k: &Lower,
        f: &[f64],
        c: &[f64],
        delta: f64,
    ) -> (Lower, Vec<f64>, Vec<usize>) {
        let n = self.n;
        let np = k.n / 2;
        let v0 = self.v0(np);
        let kv0 = k.apply(&v0);
        let fixed = &self.fixed;
        let mut b = vec![0.0; n];
        for i in 0..k.n {
            for &(a, ca) in &self.of(i) {
                if a != usize::MAX && fixed[a].is_none() {
                    b[a] += ca * (f[i] - kv0[i]);
                }
            }
        }
        let mut entries = Vec::with_capacity(k.entries.len() * 2);
        // Adds `val` to the symmetric pair M_ac = M_ca of TᵀKT (once to M_aa when a = c);
        // couplings to fixed variables move to the right-hand side.
        let mut add = |a: usize, c: usize, val: f64, b: &mut [f64]| match (fixed[a], fixed[c]) {
            (None, None) => entries.push((a.max(c), a.min(c), val)),
            (None, Some(x)) if a != c => b[a] -= val * x,
            (Some(x), None) if a != c => b[c] -= val * x,
            _ => {}
        };
        for &(i, j, v) in &k.entries {
            let (ti, tj) = (self.of(i), self.of(j));
            for (ia, &(a, ca)) in ti.iter().enumerate() {
                if a == usize::MAX {
                    continue;
                }
                for (ic, &(c, cc)) in tj.iter().enumerate() {
                    if c == usize::MAX {
                        continue;
                    }
                    let val = v * ca * cc;
                    if i != j {
                        // v (y·T_i)(y·T_j) appears twice in yᵀ(TᵀKT)y.
                        add(a, c, if a == c { 2.0 * val } else { val }, &mut b);
                    } else if ic <= ia {
                        add(a, c, val, &mut b);
                    }
                }
            }
        }
        for (a, x) in fixed.iter().enumerate() {
            if let Some(x) = x {
                entries.push((a, a, 1.0));
                b[a] = *x;
            }
        }
        let mut bounded = Vec::new();
        for p in 0..np {
            if self.con[p].is_some() && fixed[2 * p].is_none() {
                bounded.push(2 * p);
                if self.extra[p] != usize::MAX {
                    // Friction c_p (a + b) = −c_p (y₁ + y_b): a linear cost, and the split's
                    // regularisation.
                    for q in [2 * p + 1, self.extra[p]] {
                        bounded.push(q);
                        b[q] += c[p];
                        entries.push((q, q, delta));
                    }
                }
            }
        }
        (Lower { n, entries }, b, bounded)
    }

    /// v = v₀ + T y.
    pub(super) fn expand(&self, y: &[f64]) -> Vec<[f64; 2]> {
        (0..self.extra.len())
            .map(|p| match self.con[p] {
                Some((n, g)) if self.fixed[2 * p].is_none() => {
                    let t = [-n[1], n[0]];
                    let w = if self.extra[p] == usize::MAX {
                        y[2 * p + 1]
                    } else {
                        y[self.extra[p]] - y[2 * p + 1]
                    };
                    [
                        n[0] * (g + y[2 * p]) + t[0] * w,
                        n[1] * (g + y[2 * p]) + t[1] * w,
                    ]
                }
                _ => [y[2 * p], y[2 * p + 1]],
            })
            .collect()
    }
}

/// ‖v − u‖ in the seminorm of the lower-triangle matrix `k`.
pub(super) fn distance(k: &Lower, v: &[[f64; 2]], u: &[[f64; 2]]) -> f64 {
    let diff: Vec<f64> = v
        .iter()
        .zip(u)
        .flat_map(|(a, b)| [a[0] - b[0], a[1] - b[1]])
        .collect();
    let kd = k.apply(&diff);
    diff.iter()
        .zip(&kd)
        .map(|(a, b)| a * b)
        .sum::<f64>()
        .max(0.0)
        .sqrt()
}

/// sym(e_c ⊗ g) as [xx, xy, yy].
#[inline]
pub(super) fn strain(c: usize, g: [f64; 2]) -> [f64; 3] {
    if c == 0 {
        [g[0], 0.5 * g[1], 0.0]
    } else {
        [0.0, 0.5 * g[0], g[1]]
    }
}

/// One [`CellValues`] per (family, shape) met, made on first use by `make`.
pub(super) struct CellTables<F: Fn(Family, Shape) -> &'static Table> {
    make: F,
    values: Vec<(Family, Shape, CellValues)>,
}

impl<F: Fn(Family, Shape) -> &'static Table> CellTables<F> {
    pub(super) fn new(make: F) -> Self {
        CellTables {
            make,
            values: Vec::new(),
        }
    }

    pub(super) fn get(&mut self, mesh: &Mesh, t: usize) -> &mut CellValues {
        let (f, sh) = (mesh.family[t], mesh.shape[t]);
        let i = match self.values.iter().position(|c| c.0 == f && c.1 == sh) {
            Some(i) => i,
            None => {
                self.values
                    .push((f, sh, CellValues::new((self.make)(f, sh))));
                self.values.len() - 1
            }
        };
        &mut self.values[i].2
    }
}
