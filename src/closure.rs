//! Conforming closure of hanging nodes (docs/design.md §4.2, "Hanging nodes").
//!
//! Adaptive codes that refine without closure (MFEM's non-conforming meshes) leave vertices of
//! refined cells inside edges of their unrefined neighbours. The patch equilibration and the
//! bound need a conforming mesh, so every straight triangle with such an edge is split into
//! triangles that fan from a centre c, one per piece of its boundary: for the boundary points
//! p₀, p₁, … (its vertices and the hanging vertices on its edges, counter-clockwise) the
//! children are (pᵢ, pᵢ₊₁, c). When the hanging vertices lie on one edge, c is the opposite
//! vertex (the pieces adjacent to it make no child: a bisection for one hanging vertex, which
//! keeps the parent's angles and Korn constant); otherwise c is the centroid, a new point. On a
//! P2 mesh the child's mid node on a boundary piece is the neighbour's mid node of that piece,
//! and the nodes halfway to c are the parent's own edge mid nodes or new points.
//!
//! The children carry the parent's own field: a polynomial of degree ≤ 2 on a straight
//! triangle is one on every child, and the new nodes take the parent's values there. At the
//! hanging vertices and the pieces' mid nodes the merged value is the neighbours'; where the
//! parent's trace differs from it by more than [`HANGING_JUMP_RELATIVE`] of the array's size
//! (a code that does not constrain the hanging values, or a low-order output of a high-order
//! field), a point array of 2 or 3 components keeps the parent's value as the children's own
//! copy ([`Dataset::copies`]), as an exploded file of a discontinuous field does, so the bound
//! takes the broken norm; other arrays take the neighbours' value there, and the report says
//! by how much it differs. A mesh of Q1 parallelograms is first cut into P2 triangles that
//! carry the same field (`quads_as_p2`): a quadrilateral cannot be split into
//! quadrilaterals at an odd number of boundary points. Curved triangles with hanging edges are
//! refused (a child of a curved cell is no isoparametric P2 cell), as are quadratic
//! quadrilaterals and bilinear ones ([`topology::refuse_hanging`]).

use std::collections::BTreeMap;

use crate::error::Result;
use crate::geometry::{Family, MAX_NODES, Shape, triangle};
use crate::mesh::{Closure, ClosureJump, Dataset, Mesh, NONE};
use crate::read::decode::Scalar;
use crate::read::vtu::DataArray;
use crate::tolerance::{CURVED_RELATIVE, HANGING_JUMP_RELATIVE};
use crate::topology::{self, Hanging, Topology};

impl Closure {
    /// The report's note.
    pub fn note(&self) -> String {
        let mut s = String::new();
        if self.quadrilaterals > 0 {
            s.push_str(&format!(
                "hanging nodes on quadrilaterals: the {} Q1 parallelograms were cut into P2 \
                 triangle halves carrying the same field (Q1 on a parallelogram is quadratic), \
                 so the mesh is audited as P2 triangles; ",
                self.quadrilaterals
            ));
        }
        s += &format!(
            "hanging nodes: {} cells with {} hanging vertices on their edges were split into {} \
             triangles at those vertices, carrying the same field (a conforming mesh, \
             docs/design.md §4.2); the report counts, ranks and marks the file's cells (a \
             split cell as one), and --output writes the split mesh with the cell array \
             file_cell",
            self.cells_split, self.hanging_vertices, self.children
        );
        for j in &self.jumps {
            s.push_str(&format!(
                "; '{}' differs from the neighbours' values at the hanging nodes by up to {:.3e} \
                 ({:.1e} of its size){}",
                j.array,
                j.max,
                j.relative,
                if j.kept_as_copies {
                    ": the split cells keep their own values (a discontinuous field, broken norm)"
                } else {
                    ": the split cells take the neighbours' values there"
                }
            ));
        }
        s
    }
}

/// The dataset with every straight triangle that has a hanging edge split (module doc), or the
/// dataset itself when the mesh is conforming, with its topology (built once for a conforming
/// mesh). The errors are `topology::build`'s, also for hanging edges of quadrilaterals and
/// curved triangles.
pub fn close(data: Dataset) -> Result<(Dataset, Topology)> {
    let (topo, hanging) = topology::build_allowing_hanging(&data)?;
    if hanging.is_empty() {
        return Ok((data, topo));
    }
    if data.mesh.has_quads() {
        // Q1 parallelograms are P2 triangles first; their hanging edges are then split below.
        let triangles = quads_as_p2(&data, &hanging)?;
        return close(triangles);
    }
    let mesh = &data.mesh;
    let splittable = |h: &Hanging| {
        matches!(mesh.family[h.cell], Family::Tri3 | Family::Tri6)
            && mesh.shape[h.cell] == Shape::Affine
    };
    if let Some(h) = hanging.iter().find(|h| !splittable(h)) {
        return Err(topology::refuse_hanging(
            &data,
            &hanging,
            &format!(
                "fosls splits straight triangles at hanging nodes, and cell {} is curved (a \
                 child of a curved cell is no isoparametric P2 cell)",
                mesh.file_cell[h.cell]
            ),
        ));
    }
    let mut by_cell: BTreeMap<usize, [Option<&Hanging>; 3]> = BTreeMap::new();
    for h in &hanging {
        by_cell.entry(h.cell).or_default()[h.edge] = Some(h);
    }
    let mut hanging_vertices: Vec<u32> = hanging.iter().flat_map(|h| h.inner.clone()).collect();
    hanging_vertices.sort_unstable();
    hanging_vertices.dedup();

    let p2 = mesh.degree == 2;
    let n_old = mesh.points.len();
    let mut points = mesh.points.clone();
    // New points' values per point array (tuple-major), appended after the old ones.
    let mut added: Vec<Vec<f64>> = vec![Vec::new(); data.point_data.len()];
    // Own values of the children at hanging nodes that differ from the merged ones: per point
    // array, (child, node, deviation).
    let mut own: Vec<Vec<(usize, u32, Vec<f64>)>> = vec![Vec::new(); data.point_data.len()];
    let mut worst = vec![0.0f64; data.point_data.len()];
    let size: Vec<f64> = data
        .point_data
        .iter()
        .map(|a| a.values.iter().fold(0.0f64, |m, v| m.max(v.abs())))
        .collect();
    let copies_of = |name: &str| data.copies.iter().find(|c| c.name == name);

    let mut cells = Vec::with_capacity(mesh.len() + 4 * by_cell.len());
    let mut family = Vec::with_capacity(cells.capacity());
    let mut parent = Vec::with_capacity(cells.capacity());
    for t in 0..mesh.len() {
        let Some(edges) = by_cell.get(&t) else {
            cells.push(mesh.cells[t]);
            family.push(mesh.family[t]);
            parent.push(t);
            continue;
        };
        let fam = mesh.family[t];
        let nn = fam.nodes();
        let nodes = mesh.nodes(t);
        let x: Vec<[f64; 2]> = nodes.iter().map(|&n| mesh.points[n as usize]).collect();
        // Reference coordinates of a point of the (straight) parent.
        let (x0, x1, x2) = (x[0], x[1], x[2]);
        let det = (x1[0] - x0[0]) * (x2[1] - x0[1]) - (x1[1] - x0[1]) * (x2[0] - x0[0]);
        let reference = |p: [f64; 2]| {
            let (dx, dy) = (p[0] - x0[0], p[1] - x0[1]);
            [
                (dx * (x2[1] - x0[1]) - dy * (x2[0] - x0[0])) / det,
                ((x1[0] - x0[0]) * dy - (x1[1] - x0[1]) * dx) / det,
            ]
        };
        // The parent's own value of array `i` at a point: its nodes' merged values plus its
        // own copies' deviations.
        let value = |i: usize, p: [f64; 2]| -> Vec<f64> {
            let a = &data.point_data[i];
            let phi = triangle::shape_values(nn, reference(p));
            let rows = copies_of(&a.name).map(crate::mesh::CopyRows::new);
            let mut v = vec![0.0; a.components];
            for (j, &n) in nodes.iter().enumerate() {
                let dev = rows.as_ref().map_or([0.0; 2], |r| r.deviation(t, n));
                for (c, vc) in v.iter_mut().enumerate() {
                    let d = if c < 2 { dev[c] } else { 0.0 };
                    *vc += phi[j] * (a.values[n as usize * a.components + c] + d);
                }
            }
            v
        };
        let mut new_point = |p: [f64; 2], points: &mut Vec<[f64; 2]>| -> u32 {
            points.push(p);
            for (i, a) in added.iter_mut().enumerate() {
                a.extend(value(i, p));
            }
            (points.len() - 1) as u32
        };
        // Boundary points counter-clockwise, each with the mid node of the piece that follows.
        let mut ring: Vec<(u32, u32)> = Vec::new();
        let mut shared: Vec<u32> = Vec::new();
        for (k, h) in edges.iter().enumerate() {
            let [a, _, m] = mesh.edge(t, k);
            match h {
                None => ring.push((a, m)),
                Some(h) => {
                    let chain = std::iter::once(a).chain(h.inner.iter().copied());
                    for (i, (v, &e)) in chain.zip(&h.pieces).enumerate() {
                        let mid = if p2 { topo.edge_mid[e as usize] } else { NONE };
                        ring.push((v, mid));
                        // The parent's own vertex a is no hanging node.
                        if i > 0 {
                            shared.push(v);
                        }
                        if p2 {
                            shared.push(mid);
                        }
                    }
                }
            }
        }
        // With hanging vertices on one edge only, the children fan from the opposite vertex
        // (the bisection of a 2:1 refinement keeps the parent's angles, and so its Korn
        // constant, better than a centroid); otherwise from the centroid, a new point.
        let hanging_edges: Vec<usize> = (0..3).filter(|&k| edges[k].is_some()).collect();
        let apex = (hanging_edges.len() == 1).then(|| nodes[(hanging_edges[0] + 2) % 3]);
        let (c, centre) = match apex {
            Some(v) => (v, mesh.points[v as usize]),
            None => {
                let centroid = [(x0[0] + x1[0] + x2[0]) / 3.0, (x0[1] + x1[1] + x2[1]) / 3.0];
                (new_point(centroid, &mut points), centroid)
            }
        };
        // The mid node halfway from a boundary point to the centre: the parent's own edge mid
        // node when both are its vertices, else a new point.
        let spokes: Vec<u32> = if p2 {
            ring.iter()
                .map(|&(v, _)| {
                    if v == c {
                        return NONE;
                    }
                    if apex.is_some()
                        && let Some(k) = (0..3).find(|&k| {
                            let [a, b, _] = mesh.edge(t, k);
                            (a == v && b == c) || (a == c && b == v)
                        })
                    {
                        return mesh.edge(t, k)[2];
                    }
                    let pv = mesh.points[v as usize];
                    let half = [0.5 * (pv[0] + centre[0]), 0.5 * (pv[1] + centre[1])];
                    new_point(half, &mut points)
                })
                .collect()
        } else {
            Vec::new()
        };
        let first_child = cells.len();
        for i in 0..ring.len() {
            let j = (i + 1) % ring.len();
            if ring[i].0 == c || ring[j].0 == c {
                continue;
            }
            let mut child = [NONE; MAX_NODES];
            child[..3].copy_from_slice(&[ring[i].0, ring[j].0, c]);
            if p2 {
                child[3..6].copy_from_slice(&[ring[i].1, spokes[j], spokes[i]]);
            }
            cells.push(child);
            family.push(fam);
            parent.push(t);
        }
        // The neighbours' values at the hanging nodes against the parent's trace.
        for (i, a) in data.point_data.iter().enumerate() {
            for &v in &shared {
                let mine = value(i, mesh.points[v as usize]);
                let theirs = &a.values[v as usize * a.components..(v as usize + 1) * a.components];
                let dev: Vec<f64> = mine.iter().zip(theirs).map(|(m, t)| m - t).collect();
                let big = dev.iter().fold(0.0f64, |m, d| m.max(d.abs()));
                if big > HANGING_JUMP_RELATIVE * size[i] {
                    worst[i] = worst[i].max(big);
                    for (child, nodes) in cells.iter().enumerate().skip(first_child) {
                        if nodes.contains(&v) {
                            own[i].push((child, v, dev.clone()));
                        }
                    }
                }
            }
        }
    }

    let children = cells.len() - (mesh.len() - by_cell.len());
    let mut point_data = data.point_data.clone();
    for (a, extra) in point_data.iter_mut().zip(&added) {
        a.values.extend_from_slice(extra);
    }
    let cell_data = data
        .cell_data
        .iter()
        .map(|a| a.rows(parent.iter().copied()))
        .collect();
    // Own copies: the parents' rows carried to their children, plus the hanging nodes' own
    // values of the arrays that jump there.
    let mut jumps = Vec::new();
    let mut copies: Vec<DataArray> = Vec::new();
    for (i, a) in data.point_data.iter().enumerate() {
        let c = a.components;
        let kept = (2..=3).contains(&c) && !own[i].is_empty();
        if worst[i] > 0.0 {
            jumps.push(ClosureJump {
                array: a.name.clone(),
                max: worst[i],
                relative: if size[i] > 0.0 {
                    worst[i] / size[i]
                } else {
                    0.0
                },
                kept_as_copies: kept,
            });
        }
        let old = copies_of(&a.name);
        if old.is_none() && !kept {
            continue;
        }
        let slot = 1 + c;
        let row = MAX_NODES * slot;
        let mut values = vec![0.0; cells.len() * row];
        for (child, out) in values.chunks_exact_mut(row).enumerate() {
            let rows = old.map(crate::mesh::CopyRows::new);
            for (s, r) in cells[child].iter().zip(out.chunks_exact_mut(slot)) {
                r[0] = f64::from(*s);
                if *s == NONE || *s as usize >= n_old {
                    continue;
                }
                if let Some(rows) = &rows {
                    let d = rows.deviation(parent[child], *s);
                    r[1..1 + c.min(2)].copy_from_slice(&d[..c.min(2)]);
                }
            }
        }
        if kept {
            for (child, v, dev) in &own[i] {
                let out = &mut values[child * row..(child + 1) * row];
                if let Some(r) = out.chunks_exact_mut(slot).find(|r| r[0] == f64::from(*v)) {
                    r[1..].copy_from_slice(dev);
                }
            }
        }
        copies.push(DataArray {
            name: a.name.clone(),
            scalar: Scalar::Float64,
            components: row,
            component_names: Vec::new(),
            values,
        });
    }

    let closed = Mesh {
        points,
        degree: mesh.degree,
        shape: parent.iter().map(|&t| mesh.shape[t]).collect(),
        cells,
        family,
        lines: mesh.lines.clone(),
        file_cell: parent.iter().map(|&t| mesh.file_cell[t]).collect(),
        line_cell: mesh.line_cell.clone(),
    };
    let mut report = data.report.clone();
    // A quadrilateral mesh's conversion (`quads_as_p2`) came first: its count, and the jumps it
    // found in the arrays the split below cannot see (those without copies).
    let earlier = report.closure.take().unwrap_or_default();
    for j in earlier.jumps {
        if !jumps.iter().any(|k| k.array == j.array) {
            jumps.push(j);
        }
    }
    report.closure = Some(Closure {
        cells_split: by_cell.len(),
        children,
        hanging_vertices: hanging_vertices.len(),
        jumps,
        quadrilaterals: earlier.quadrilaterals,
    });
    let closed = Dataset {
        path: data.path.clone(),
        mesh: closed,
        point_data,
        cell_data,
        line_data: data.line_data.clone(),
        copies,
        report,
    };
    let topo = topology::build(&closed)?;
    Ok((closed, topo))
}

/// A mesh of Q1 parallelograms (and P1 triangles) with hanging nodes as a mesh of straight P2
/// triangles carrying the same field (docs/design.md §4.2): every quadrilateral is cut along its
/// shorter diagonal, every triangle kept, and the new mid nodes take the field's values there:
/// the mean of the edge's ends (a Q1 or P1 field is linear along an edge) or, at a
/// quadrilateral's centre, of its four vertices. On a parallelogram the bilinear map is affine,
/// so a Q1 field is a quadratic polynomial, and it equals its P2 interpolant on each half:
/// the triangles carry u_h itself. A hanging vertex at the midpoint of an edge (a 2:1
/// refinement) is that edge's mid node; where the neighbours' value there differs from the
/// cell's own trace by more than [`HANGING_JUMP_RELATIVE`], a point array of 2 or 3 components
/// keeps the cell's value as its own copy (`Dataset::copies`), as [`close`] does, and the others
/// take the neighbours' (reported). A field the file holds discontinuous across cells (its
/// copies) keeps each cell's own values through the cut: a triangle's deviation at a new node
/// is the mean of its parent's at the corners the node's value comes from. Refused: quadratic
/// cells and quadrilaterals that are no parallelogram (Q1 is rational on their halves).
fn quads_as_p2(data: &Dataset, hanging: &[Hanging]) -> Result<Dataset> {
    let mesh = &data.mesh;
    let refuse = |why: String| topology::refuse_hanging(data, hanging, &why);
    if let Some(t) =
        (0..mesh.len()).find(|&t| !matches!(mesh.family[t], Family::Tri3 | Family::Quad4))
    {
        return Err(refuse(format!(
            "fosls audits Q1 parallelograms with hanging nodes (as P2 triangles), not {} cells \
             (cell {})",
            mesh.family[t].name(),
            mesh.file_cell[t]
        )));
    }
    if let Some(t) = (0..mesh.len()).find(|&t| mesh.shape[t] != Shape::Affine) {
        return Err(refuse(format!(
            "fosls audits Q1 quadrilaterals with hanging nodes as P2 triangles, which carry a Q1 \
             field exactly on parallelograms only, and cell {} is no parallelogram",
            mesh.file_cell[t]
        )));
    }
    let mut inner: BTreeMap<(usize, usize), &[u32]> = BTreeMap::new();
    for h in hanging {
        inner.insert((h.cell, h.edge), &h.inner);
    }
    let arrays = &data.point_data;
    let size: Vec<f64> = arrays
        .iter()
        .map(|a| a.values.iter().fold(0.0f64, |m, v| m.max(v.abs())))
        .collect();
    let mut points = mesh.points.clone();
    let mut values: Vec<Vec<f64>> = arrays.iter().map(|a| a.values.clone()).collect();
    // The mean of some points' values, appended as a new point's.
    let add_point = |of: &[u32], points: &mut Vec<[f64; 2]>, values: &mut Vec<Vec<f64>>| {
        let w = 1.0 / of.len() as f64;
        let mut p = [0.0; 2];
        for &v in of {
            p[0] += w * points[v as usize][0];
            p[1] += w * points[v as usize][1];
        }
        points.push(p);
        for (a, vals) in arrays.iter().zip(values.iter_mut()) {
            let c = a.components;
            for k in 0..c {
                let x: f64 = of.iter().map(|&v| w * vals[v as usize * c + k]).sum();
                vals.push(x);
            }
        }
        (points.len() - 1) as u32
    };
    let mut mids: BTreeMap<(u32, u32), u32> = BTreeMap::new();
    let mut cells = Vec::with_capacity(2 * mesh.len());
    let mut parent = Vec::with_capacity(2 * mesh.len());
    // Per parent cell, its edges' mid nodes (each takes the mean of the edge's ends).
    let mut cell_mids: Vec<[u32; 4]> = Vec::with_capacity(mesh.len());
    let mut quadrilaterals = 0;
    for t in 0..mesh.len() {
        let nv = mesh.family[t].vertices();
        let v: Vec<u32> = mesh.nodes(t)[..nv].to_vec();
        let mut edge_mid = [NONE; 4];
        for k in 0..nv {
            let (a, b) = (v[k], v[(k + 1) % nv]);
            if let Some(&m) = mids.get(&(a.min(b), a.max(b))) {
                edge_mid[k] = m;
                continue;
            }
            let (pa, pb) = (points[a as usize], points[b as usize]);
            let half = [0.5 * (pa[0] + pb[0]), 0.5 * (pa[1] + pb[1])];
            let reach = CURVED_RELATIVE * (pb[0] - pa[0]).hypot(pb[1] - pa[1]);
            let at_half = inner.get(&(t, k)).and_then(|vs| {
                vs.iter().copied().find(|&h| {
                    let q = points[h as usize];
                    (q[0] - half[0]).hypot(q[1] - half[1]) <= reach
                })
            });
            let m = at_half.unwrap_or_else(|| add_point(&[a, b], &mut points, &mut values));
            mids.insert((a.min(b), a.max(b)), m);
            edge_mid[k] = m;
        }
        cell_mids.push(edge_mid);
        let mut push = |n: [u32; 6]| {
            let mut nodes = [NONE; MAX_NODES];
            nodes[..6].copy_from_slice(&n);
            cells.push(nodes);
            parent.push(t);
        };
        if nv == 3 {
            push([v[0], v[1], v[2], edge_mid[0], edge_mid[1], edge_mid[2]]);
        } else {
            quadrilaterals += 1;
            let centre = add_point(&v, &mut points, &mut values);
            let d = |i: usize, j: usize| {
                let (p, q) = (points[v[i] as usize], points[v[j] as usize]);
                (q[0] - p[0]).hypot(q[1] - p[1])
            };
            if d(0, 2) <= d(1, 3) {
                push([v[0], v[1], v[2], edge_mid[0], edge_mid[1], centre]);
                push([v[0], v[2], v[3], centre, edge_mid[2], edge_mid[3]]);
            } else {
                push([v[0], v[1], v[3], edge_mid[0], centre, edge_mid[3]]);
                push([v[1], v[2], v[3], edge_mid[1], edge_mid[2], centre]);
            }
        }
    }
    // The parent's corners whose mean node `n` of a triangle cut from parent `t` takes: the
    // corner itself, an edge's ends, or all corners (the centre); and how many.
    let sources = |t: usize, n: u32| -> ([u32; 4], usize) {
        let nv = mesh.family[t].vertices();
        let v = &mesh.nodes(t)[..nv];
        let mut out = [NONE; 4];
        if v.contains(&n) {
            out[0] = n;
            (out, 1)
        } else if let Some(k) = cell_mids[t][..nv].iter().position(|&m| m == n) {
            out[..2].copy_from_slice(&[v[k], v[(k + 1) % nv]]);
            (out, 2)
        } else {
            out[..nv].copy_from_slice(v);
            (out, nv)
        }
    };
    // Each triangle's own value at each node: the mean of its parent's own values (merged plus
    // the file's copies) at the sources. Its deviation from the merged value there is the
    // parent's copy at a corner, the mean of the corners' at a new point, and at a hanging
    // midpoint also the difference between the parent's trace and the neighbours' value.
    let mut jumps = Vec::new();
    let mut copies = Vec::new();
    for (i, a) in arrays.iter().enumerate() {
        let c = a.components;
        let vals = &values[i];
        let file = data.copies.iter().find(|k| k.name == a.name);
        // The deviation of `child`'s own value at its node `n` (into `dev`), and whether `n` is
        // a hanging midpoint, where the merged value is the neighbours'.
        let deviation = |child: usize, n: u32, dev: &mut [f64]| -> bool {
            let t = parent[child];
            let (from, count) = sources(t, n);
            let from = &from[..count];
            let w = 1.0 / from.len() as f64;
            let row = file.map(|k| &k.values[t * k.components..(t + 1) * k.components]);
            for (j, d) in dev.iter_mut().enumerate() {
                *d = -vals[n as usize * c + j];
            }
            for &s in from {
                let copy = row.and_then(|r| r.chunks_exact(1 + c).find(|r| r[0] == f64::from(s)));
                for (j, d) in dev.iter_mut().enumerate() {
                    *d += w * (vals[s as usize * c + j] + copy.map_or(0.0, |r| r[1 + j]));
                }
            }
            (n as usize) < mesh.points.len() && from.len() == 2
        };
        let mut dev = vec![0.0; c];
        let (mut worst, mut any) = (0.0f64, false);
        for (child, nodes) in cells.iter().enumerate() {
            for &n in &nodes[..6] {
                let hanging_mid = deviation(child, n, &mut dev);
                let big = dev.iter().fold(0.0f64, |m, d| m.max(d.abs()));
                if hanging_mid && big > HANGING_JUMP_RELATIVE * size[i] {
                    worst = worst.max(big);
                }
                any |= big > 0.0;
            }
        }
        let kept = (2..=3).contains(&c) && (file.is_some() || worst > 0.0) && any;
        if worst > 0.0 {
            jumps.push(ClosureJump {
                array: a.name.clone(),
                max: worst,
                relative: worst / size[i].max(f64::MIN_POSITIVE),
                kept_as_copies: kept,
            });
        }
        if !kept {
            continue;
        }
        let slot = 1 + c;
        let row = MAX_NODES * slot;
        let mut rows = vec![0.0; cells.len() * row];
        for (child, (nodes, out)) in cells.iter().zip(rows.chunks_exact_mut(row)).enumerate() {
            for (&n, r) in nodes.iter().zip(out.chunks_exact_mut(slot)) {
                r[0] = f64::from(n);
                if n != NONE {
                    deviation(child, n, &mut r[1..]);
                }
            }
        }
        copies.push(DataArray {
            name: a.name.clone(),
            scalar: Scalar::Float64,
            components: row,
            component_names: Vec::new(),
            values: rows,
        });
    }
    let mut point_data = arrays.clone();
    for (a, vals) in point_data.iter_mut().zip(values) {
        a.values = vals;
    }
    let lines = mesh
        .lines
        .iter()
        .map(|l| {
            let m = mids.get(&(l[0].min(l[1]), l[0].max(l[1])));
            [l[0], l[1], m.copied().unwrap_or(NONE)]
        })
        .collect();
    let mut report = data.report.clone();
    report.closure = Some(Closure {
        quadrilaterals,
        jumps,
        ..Closure::default()
    });
    Ok(Dataset {
        path: data.path.clone(),
        mesh: Mesh {
            points,
            degree: 2,
            shape: vec![Shape::Affine; cells.len()],
            family: vec![Family::Tri6; cells.len()],
            cells,
            lines,
            file_cell: parent.iter().map(|&t| mesh.file_cell[t]).collect(),
            line_cell: mesh.line_cell.clone(),
        },
        point_data,
        cell_data: data
            .cell_data
            .iter()
            .map(|a| a.rows(parent.iter().copied()))
            .collect(),
        line_data: data.line_data.clone(),
        copies,
        report,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh;
    use crate::read::vtu::VtuFile;
    use std::path::Path;

    type Cells = Vec<(u8, Vec<u32>)>;

    /// A dataset of `cells` (VTK type, nodes) with the point array "u" = `u(x)`.
    fn dataset(
        points: &[[f64; 2]],
        cells: &[(u8, Vec<u32>)],
        u: impl Fn([f64; 2]) -> [f64; 2],
    ) -> Dataset {
        let mut f = VtuFile::from_cells(
            Path::new("m.vtu"),
            points.iter().map(|p| [p[0], p[1], 0.0]).collect(),
            cells,
        );
        f.point_data.push(DataArray {
            name: "u".into(),
            scalar: Scalar::Float64,
            components: 2,
            component_names: Vec::new(),
            values: points.iter().flat_map(|&p| u(p)).collect(),
        });
        mesh::build(f).unwrap()
    }

    /// [0, 2] × [0, 1]: the left square in two P2 triangles, the right one in four, which meet
    /// the left lower triangle's edge x = 1 in two pieces; nodes at the P2 positions.
    fn hanging_p2() -> (Vec<[f64; 2]>, Cells) {
        let mut points: Vec<[f64; 2]> = Vec::new();
        let id = |p: [f64; 2], points: &mut Vec<[f64; 2]>| match points
            .iter()
            .position(|q| (q[0] - p[0]).abs() + (q[1] - p[1]).abs() < 1e-14)
        {
            Some(i) => i as u32,
            None => {
                points.push(p);
                (points.len() - 1) as u32
            }
        };
        let tris: [[[f64; 2]; 3]; 6] = [
            [[0., 0.], [1., 0.], [1., 1.]],
            [[0., 0.], [1., 1.], [0., 1.]],
            [[1., 0.], [2., 0.], [2., 0.5]],
            [[1., 0.], [2., 0.5], [1., 0.5]],
            [[1., 0.5], [2., 0.5], [2., 1.]],
            [[1., 0.5], [2., 1.], [1., 1.]],
        ];
        let mut cells = Vec::new();
        for t in tris {
            let mid = |a: [f64; 2], b: [f64; 2]| [0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1])];
            let nodes = [
                t[0],
                t[1],
                t[2],
                mid(t[0], t[1]),
                mid(t[1], t[2]),
                mid(t[2], t[0]),
            ];
            cells.push((22u8, nodes.iter().map(|&p| id(p, &mut points)).collect()));
        }
        (points, cells)
    }

    /// A quadratic field: the children carry it exactly at every node, new or old.
    fn quadratic(p: [f64; 2]) -> [f64; 2] {
        let [x, y] = p;
        [
            1e-3 * x * x - 2e-4 * x * y + 3e-4,
            5e-4 * y * y + 1e-4 * x - 2e-4 * x * y,
        ]
    }

    #[test]
    fn a_p2_triangle_is_split_about_its_centroid_at_its_hanging_vertex() {
        let (points, cells) = hanging_p2();
        let (d, topo) = close(dataset(&points, &cells, quadratic)).unwrap();
        // Bisected from the opposite vertex (0, 0) at the hanging vertex. Conforming now: the
        // topology builds, with the 7 outer edges of the rectangle.
        assert_eq!(topo.boundary_edges.len(), 7);
        let c = d.report.closure.as_ref().unwrap();
        assert_eq!((c.cells_split, c.children, c.hanging_vertices), (1, 2, 1));
        assert!(c.jumps.is_empty(), "{:?}", c.jumps);
        assert!(d.copies.is_empty());
        // 5 cells kept + 2 children, the children with file cell 0; areas sum to the parent's.
        assert_eq!(d.mesh.len(), 7);
        let children: Vec<usize> = (0..7).filter(|&t| d.mesh.file_cell[t] == 0).collect();
        assert_eq!(children.len(), 2);
        assert!(children.iter().all(|&t| d.mesh.nodes(t)[..3].contains(&0)));
        let area: f64 = children.iter().map(|&t| 0.5 * d.mesh.double_area(t)).sum();
        assert!((area - 0.5).abs() < 1e-15, "{area}");
        assert!(children.iter().all(|&t| d.mesh.double_area(t) > 0.0));
        // Every node of the closed mesh holds the quadratic field (hand values at the points).
        let u = &d.point_data[0];
        for (i, &p) in d.mesh.points.iter().enumerate() {
            let want = quadratic(p);
            for (got, want) in u.values[2 * i..2 * i + 2].iter().zip(want) {
                assert!((got - want).abs() < 1e-17, "node {i} at {p:?}");
            }
        }
        // Mid nodes: at the midpoints of their edges.
        for t in children {
            let n = d.mesh.nodes(t);
            for k in 0..3 {
                let (a, b) = (
                    d.mesh.points[n[k] as usize],
                    d.mesh.points[n[(k + 1) % 3] as usize],
                );
                let m = d.mesh.points[n[3 + k] as usize];
                assert!(
                    (m[0] - 0.5 * (a[0] + b[0])).abs() + (m[1] - 0.5 * (a[1] + b[1])).abs() < 1e-15
                );
            }
        }
    }

    #[test]
    fn a_value_off_the_parents_trace_is_kept_as_the_childrens_own_copy() {
        // The hanging vertex (1, 0.5) is the parent's own mid node; the neighbours' mid node
        // (1, 0.25) of the lower piece moved by δ: the child on that piece keeps the parent's
        // trace there, δ below the merged value.
        let (points, cells) = hanging_p2();
        let v = points.iter().position(|p| *p == [1.0, 0.25]).unwrap() as u32;
        let delta = [2e-5, -3e-5];
        let (d, _) = close(dataset(&points, &cells, |p| {
            let q = quadratic(p);
            if p == [1.0, 0.25] {
                [q[0] + delta[0], q[1] + delta[1]]
            } else {
                q
            }
        }))
        .unwrap();
        let c = d.report.closure.as_ref().unwrap();
        assert_eq!(c.jumps.len(), 1);
        assert!(c.jumps[0].kept_as_copies);
        assert!((c.jumps[0].max - 3e-5).abs() < 1e-17, "{:?}", c.jumps);
        assert_eq!(d.copies.len(), 1);
        let rows = crate::mesh::CopyRows::new(&d.copies[0]);
        let holders: Vec<usize> = (0..d.mesh.len())
            .filter(|&t| d.mesh.file_cell[t] == 0 && d.mesh.nodes(t).contains(&v))
            .collect();
        assert_eq!(holders.len(), 1);
        for t in holders {
            let dev = rows.deviation(t, v);
            assert!(
                (dev[0] + delta[0]).abs() < 1e-17 && (dev[1] + delta[1]).abs() < 1e-17,
                "{dev:?}"
            );
        }
        // The neighbours keep the merged value as their own.
        for t in (0..d.mesh.len()).filter(|&t| d.mesh.file_cell[t] != 0) {
            assert_eq!(rows.deviation(t, v), [0.0; 2]);
        }
    }

    #[test]
    fn hanging_vertices_on_two_edges_fan_from_the_centroid() {
        // The P1 triangle (0, 0), (1, 0), (0, 1) with the vertex (0.5, 0) of the two triangles
        // below it and (0.5, 0.5) of the two beside it inside its edges: five boundary points,
        // five children about the centroid (1/3, 1/3), the only new point.
        let points = [
            [0., 0.],
            [1., 0.],
            [0., 1.],
            [0.5, 0.],
            [0.5, -0.5],
            [0.5, 0.5],
            [1., 1.],
        ];
        let cells: Cells = [[0, 3, 4], [3, 1, 4], [1, 6, 5], [5, 6, 2], [0, 1, 2]]
            .iter()
            .map(|c| (5u8, c.to_vec()))
            .collect();
        let linear = |p: [f64; 2]| [1e-3 * p[0] - 2e-4 * p[1], 3e-4 * p[0] + 5e-4 * p[1]];
        let (d, _) = close(dataset(&points, &cells, linear)).unwrap();
        let c = d.report.closure.as_ref().unwrap();
        assert_eq!((c.cells_split, c.children, c.hanging_vertices), (1, 5, 2));
        assert_eq!(d.mesh.points.len(), points.len() + 1);
        let centroid = d.mesh.points[points.len()];
        assert!((centroid[0] - 1.0 / 3.0).abs() + (centroid[1] - 1.0 / 3.0).abs() < 1e-16);
        let children: Vec<usize> = (0..d.mesh.len())
            .filter(|&t| d.mesh.file_cell[t] == 4)
            .collect();
        assert_eq!(children.len(), 5);
        let area: f64 = children.iter().map(|&t| 0.5 * d.mesh.double_area(t)).sum();
        assert!((area - 0.5).abs() < 1e-15, "{area}");
        let u = &d.point_data[0].values;
        let want = linear(centroid);
        assert!(
            (u[2 * points.len()] - want[0]).abs() + (u[2 * points.len() + 1] - want[1]).abs()
                < 1e-18
        );
    }

    /// Random red refinements of a structured P1 mesh (seeded): every unrefined cell next to
    /// refined ones gets hanging vertices on one, two or three edges. The closure must give a
    /// conforming mesh of the same area that carries the same linear field, without jumps.
    #[test]
    fn random_red_refinements_close_to_conforming_meshes() {
        let n = 6;
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut next = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            seed
        };
        let linear = |p: [f64; 2]| [1e-3 * p[0] - 2e-4 * p[1] + 1e-4, 3e-4 * p[0] + 5e-4 * p[1]];
        for round in 0..20 {
            let h = 1.0 / n as f64;
            let mut tris: Vec<[[f64; 2]; 3]> = Vec::new();
            for j in 0..n {
                for i in 0..n {
                    let p = |a: usize, b: usize| [(i + a) as f64 * h, (j + b) as f64 * h];
                    tris.push([p(0, 0), p(1, 0), p(1, 1)]);
                    tris.push([p(0, 0), p(1, 1), p(0, 1)]);
                }
            }
            let mut fine = Vec::new();
            let mut refined = 0;
            for t in tris {
                if next() % 3 == 0 {
                    refined += 1;
                    let m = |a: [f64; 2], b: [f64; 2]| [0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1])];
                    let (m01, m12, m20) = (m(t[0], t[1]), m(t[1], t[2]), m(t[2], t[0]));
                    fine.extend([
                        [t[0], m01, m20],
                        [m01, t[1], m12],
                        [m20, m12, t[2]],
                        [m01, m12, m20],
                    ]);
                } else {
                    fine.push(t);
                }
            }
            let mut points: Vec<[f64; 2]> = Vec::new();
            let mut cells: Cells = Vec::new();
            for t in &fine {
                let ids = t.map(|p| match points.iter().position(|q| *q == p) {
                    Some(i) => i as u32,
                    None => {
                        points.push(p);
                        (points.len() - 1) as u32
                    }
                });
                cells.push((5, ids.to_vec()));
            }
            let (d, topo) = close(dataset(&points, &cells, linear)).unwrap();
            let area: f64 = (0..d.mesh.len()).map(|t| 0.5 * d.mesh.double_area(t)).sum();
            assert!((area - 1.0).abs() < 1e-13, "round {round}: area {area}");
            assert!((0..d.mesh.len()).all(|t| d.mesh.double_area(t) > 0.0));
            // The outer boundary only: 4n pieces where no refined cell touches it, more where.
            let boundary: f64 = topo
                .boundary_edges
                .iter()
                .map(|&e| {
                    let [a, b] = topo.edges[e as usize];
                    crate::geometry::dist2(d.mesh.points[a as usize], d.mesh.points[b as usize])
                        .sqrt()
                })
                .sum();
            assert!(
                (boundary - 4.0).abs() < 1e-12,
                "round {round}: boundary length {boundary}"
            );
            let u = &d.point_data[0].values;
            for (i, &p) in d.mesh.points.iter().enumerate() {
                let want = linear(p);
                assert!(
                    (u[2 * i] - want[0]).abs() + (u[2 * i + 1] - want[1]).abs() < 1e-18,
                    "round {round}: node {i}"
                );
            }
            if let Some(c) = &d.report.closure {
                assert!(c.jumps.is_empty(), "round {round}: {:?}", c.jumps);
            } else {
                assert!(
                    refined == 0 || refined == 2 * n * n,
                    "round {round}: nothing split"
                );
            }
        }
    }

    #[test]
    fn a_discontinuous_q1_field_keeps_each_cells_own_values_through_the_cut_and_the_split() {
        // The mesh of the test below written exploded (each quadrilateral with its own points),
        // the left one's field shifted by s: the merge keeps the shift as that cell's copies,
        // and every triangle cut from it must carry bilinear + s at every node, the others
        // bilinear, new nodes included.
        let corners = [
            [[0., 0.], [1., 0.], [1., 1.], [0., 1.]],
            [[1., 0.], [2., 0.], [2., 0.5], [1., 0.5]],
            [[1., 0.5], [2., 0.5], [2., 1.], [1., 1.]],
        ];
        let bilinear = |p: [f64; 2]| {
            let [x, y] = p;
            [
                1e-3 * x - 2e-4 * y + 3e-4 * x * y,
                5e-4 * y - 1e-4 * x * y + 2e-4,
            ]
        };
        let shift = [2e-4, -1e-4];
        let points: Vec<[f64; 2]> = corners.iter().flatten().copied().collect();
        let quads: Cells = (0..3u32)
            .map(|q| (9u8, (4 * q..4 * q + 4).collect()))
            .collect();
        let mut f = VtuFile::from_cells(
            Path::new("m.vtu"),
            points.iter().map(|p| [p[0], p[1], 0.0]).collect(),
            &quads,
        );
        f.point_data.push(DataArray {
            name: "u".into(),
            scalar: Scalar::Float64,
            components: 2,
            component_names: Vec::new(),
            values: points
                .iter()
                .enumerate()
                .flat_map(|(i, &p)| {
                    let u = bilinear(p);
                    let s = if i < 4 { shift } else { [0.0; 2] };
                    [u[0] + s[0], u[1] + s[1]]
                })
                .collect(),
        });
        let (d, _) = close(mesh::build(f).unwrap()).unwrap();
        let m = &d.mesh;
        assert_eq!(m.len(), 7);
        let u = &d.point_data[0];
        let rows = crate::mesh::CopyRows::new(&d.copies[0]);
        for t in 0..m.len() {
            let s = if m.file_cell[t] == 0 { shift } else { [0.0; 2] };
            for &v in m.nodes(t) {
                let p = m.points[v as usize];
                let want = bilinear(p);
                let dev = rows.deviation(t, v);
                for j in 0..2 {
                    let got = u.values[2 * v as usize + j] + dev[j];
                    assert!((got - want[j] - s[j]).abs() < 1e-17, "cell {t} at {p:?}");
                }
            }
        }
    }

    #[test]
    fn q1_parallelograms_with_hanging_edges_become_p2_triangles_carrying_the_field() {
        // [0, 2] × [0, 1]: the left square one quadrilateral, whose edge x = 1 the right
        // square's two meet in two pieces (MFEM's and deal.II's non-conforming refinement).
        let points = [
            [0., 0.],
            [1., 0.],
            [1., 1.],
            [0., 1.],
            [2., 0.],
            [2., 1.],
            [1., 0.5],
            [2., 0.5],
        ];
        let quads = vec![
            (9u8, vec![0, 1, 2, 3]),
            (9, vec![1, 4, 7, 6]),
            (9, vec![6, 7, 5, 2]),
        ];
        // A Q1 field on these rectangles (span{1, x, y, xy}), continuous across x = 1.
        let bilinear = |p: [f64; 2]| {
            let [x, y] = p;
            [
                1e-3 * x - 2e-4 * y + 3e-4 * x * y,
                5e-4 * y - 1e-4 * x * y + 2e-4,
            ]
        };
        let (d, _) = close(dataset(&points, &quads, bilinear)).unwrap();
        let m = &d.mesh;
        assert_eq!(m.degree, 2);
        assert!(m.family.iter().all(|&f| f == Family::Tri6));
        // 3 quadrilaterals × 2 halves, the half with the hanging edge bisected: 7 triangles.
        assert_eq!(m.len(), 7);
        assert_eq!(m.file_cell.iter().filter(|&&c| c == 0).count(), 3);
        let c = d.report.closure.as_ref().unwrap();
        assert_eq!((c.quadrilaterals, c.cells_split, c.children), (3, 1, 2));
        assert!(c.jumps.is_empty());
        let area: f64 = (0..m.len())
            .map(|t| {
                let [a, b, e] = [0, 1, 2].map(|k| m.points[m.nodes(t)[k] as usize]);
                0.5 * ((b[0] - a[0]) * (e[1] - a[1]) - (b[1] - a[1]) * (e[0] - a[0]))
            })
            .sum();
        assert!((area - 2.0).abs() < 1e-15, "{area}");
        // The bilinear field at every node of every triangle, and mid nodes at midpoints.
        let u = &d.point_data[0];
        for t in 0..m.len() {
            let n = m.nodes(t);
            for (k, &v) in n.iter().enumerate() {
                let p = m.points[v as usize];
                let want = bilinear(p);
                let got = &u.values[2 * v as usize..2 * v as usize + 2];
                assert!(
                    (got[0] - want[0]).abs() + (got[1] - want[1]).abs() < 1e-18,
                    "{p:?}"
                );
                if k >= 3 {
                    let [a, b, _] = m.edge(t, k - 3);
                    let (pa, pb) = (m.points[a as usize], m.points[b as usize]);
                    assert_eq!(p, [0.5 * (pa[0] + pb[0]), 0.5 * (pa[1] + pb[1])]);
                }
            }
        }
        // The hanging vertex moved by δ (an unconstrained code): the left square keeps its own
        // trace there as its own copy: deviation −δ from the merged value.
        let delta = 1e-4;
        let (d, _) = close(dataset(&points, &quads, |p| {
            let mut u = bilinear(p);
            if p == [1.0, 0.5] {
                u[0] += delta;
            }
            u
        }))
        .unwrap();
        let c = d.report.closure.as_ref().unwrap();
        assert_eq!(c.jumps.len(), 1);
        assert!(c.jumps[0].kept_as_copies);
        assert!((c.jumps[0].max - delta).abs() < 1e-15);
        let rows = crate::mesh::CopyRows::new(&d.copies[0]);
        let left: Vec<usize> = (0..d.mesh.len())
            .filter(|&t| d.mesh.file_cell[t] == 0 && d.mesh.nodes(t).contains(&6))
            .collect();
        assert_eq!(left.len(), 2);
        for t in left {
            assert!((rows.deviation(t, 6)[0] + delta).abs() < 1e-15);
        }
        // A quadrilateral that is no parallelogram: refused, naming it.
        let mut skew = points;
        skew[3] = [0.0, 1.3];
        let e = close(dataset(&skew, &quads, bilinear))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("the vertex at (1, 0.5) lies inside the edge (1, 0)–(1, 1) of cell 0"),
            "{e}"
        );
        assert!(e.contains("and cell 0 is no parallelogram"), "{e}");
    }
}
