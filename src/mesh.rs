//! The mesh and its fields: the nouns passed between the stages after reading.
//!
//! A [`Dataset`] is built once from a [`VtuFile`]: triangles and boundary lines are separated,
//! vertex cells dropped, an exploded mesh (every cell with its own node copies, as NGSolve's
//! `VTKOutput` writes) merged by coincident coordinates, and the geometry checked (planar
//! points, consistent orientation, no zero-area or duplicate cells). Cell data is split into
//! triangle data and line data.

use std::path::PathBuf;

use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::geometry::{self, Family, MAX_NODES, Shape};
use crate::read::cell_type;
use crate::read::vtu::{DataArray, VtuFile};
use crate::tolerance;

/// Marks an absent node (the mid nodes of P1 cells).
pub const NONE: u32 = u32::MAX;

/// A 2D mesh of triangles and quadrilaterals of degree 1 (straight) or 2 (isoparametric,
/// possibly curved), in any mix of families of one degree (docs/design.md §4.3).
///
/// Node order is VTK's per family ([`crate::geometry`]): vertices counter-clockwise, then one
/// node per edge (edge k from vertex k to k + 1, node n_v + k), then the centre of a Q2 cell.
/// Lines are `[end, end, mid]`.
#[derive(Clone, Debug)]
pub struct Mesh {
    pub points: Vec<[f64; 2]>,
    /// Largest trace degree of the cells: 1 or 2.
    pub degree: usize,
    /// Nodes of each cell; slots past the family's node count are `NONE`.
    pub cells: Vec<[u32; MAX_NODES]>,
    pub family: Vec<Family>,
    /// Affine, bilinear or curved: decided once here with [`tolerance::CURVED_RELATIVE`].
    pub shape: Vec<Shape>,
    /// Boundary line cells of the file; slot 2 is `NONE` for straight lines.
    pub lines: Vec<[u32; 3]>,
    /// Index in the VTU file of each cell (for messages and cell data).
    pub file_cell: Vec<u32>,
    /// Index in the VTU file of each line.
    pub line_cell: Vec<u32>,
}

impl Mesh {
    /// Number of 2D cells.
    #[inline]
    pub fn len(&self) -> usize {
        self.cells.len()
    }

    #[inline]
    pub fn is_empty(&self) -> bool {
        self.cells.is_empty()
    }

    /// Nodes of cell `t`.
    #[inline]
    pub fn nodes(&self, t: usize) -> &[u32] {
        &self.cells[t][..self.family[t].nodes()]
    }

    /// Vertices of cell `t` (3 or 4).
    #[inline]
    pub fn vertices(&self, t: usize) -> &[u32] {
        &self.cells[t][..self.family[t].vertices()]
    }

    /// Node coordinates of cell `t` (slots past the family's node count are 0).
    #[inline]
    pub fn coords(&self, t: usize) -> [[f64; 2]; MAX_NODES] {
        let mut x = [[0.0; 2]; MAX_NODES];
        for (k, &n) in self.nodes(t).iter().enumerate() {
            x[k] = self.points[n as usize];
        }
        x
    }

    /// Whether cell `t` has a constant Jacobian.
    #[inline]
    pub fn is_affine(&self, t: usize) -> bool {
        self.shape[t] == Shape::Affine
    }

    /// Whether cell `t` has a curved edge.
    #[inline]
    pub fn is_curved(&self, t: usize) -> bool {
        self.shape[t] == Shape::Curved
    }

    /// The global end vertices and mid node of local edge `k` of cell `t`.
    #[inline]
    pub fn edge(&self, t: usize, k: usize) -> [u32; 3] {
        let [a, b, m] = self.family[t].edge_nodes(k);
        let c = &self.cells[t];
        [c[a], c[b], if m == usize::MAX { NONE } else { c[m] }]
    }

    /// Twice the signed area of the straight polygon through the vertices of `t`.
    pub fn double_area(&self, t: usize) -> f64 {
        let v = self.vertices(t);
        let p0 = self.points[v[0] as usize];
        let mut a = 0.0;
        for k in 1..v.len() - 1 {
            a += double_area(
                p0,
                self.points[v[k] as usize],
                self.points[v[k + 1] as usize],
            );
        }
        a
    }

    /// The families present, in order.
    pub fn families(&self) -> Vec<Family> {
        let mut seen = [false; 5];
        for f in &self.family {
            seen[f.index()] = true;
        }
        Family::ALL
            .into_iter()
            .filter(|f| seen[f.index()])
            .collect()
    }

    /// Whether any cell is a quadrilateral.
    pub fn has_quads(&self) -> bool {
        self.family.iter().any(|f| f.is_quad())
    }

    /// Bounding box `[xmin, ymin, xmax, ymax]`.
    pub fn bounding_box(&self) -> [f64; 4] {
        let mut b = [
            f64::INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NEG_INFINITY,
        ];
        for p in &self.points {
            b[0] = b[0].min(p[0]);
            b[1] = b[1].min(p[1]);
            b[2] = b[2].max(p[0]);
            b[3] = b[3].max(p[1]);
        }
        b
    }
}

fn double_area(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> f64 {
    (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
}

fn dist(a: [f64; 2], b: [f64; 2]) -> f64 {
    geometry::dist2(a, b).sqrt()
}

/// How node copies of an exploded mesh were merged.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Merge {
    /// Every cell had its own node copies (else: copies at the interfaces of pieces).
    pub exploded: bool,
    /// When points were shared inside groups of cells only (MFEM's low-order output): the
    /// number of such groups (connected components) before merging.
    pub groups: Option<usize>,
    pub points_in_file: usize,
    pub points_merged: usize,
    /// Per point array: the largest difference between copies of one node (any component),
    /// absolute and relative to the array's largest magnitude. Non-zero means the field is
    /// discontinuous across cells.
    pub jumps: Vec<Jump>,
}

/// The largest disagreement between node copies of one point array.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Jump {
    pub array: String,
    pub max: f64,
    pub relative: f64,
}

/// What the closure of hanging nodes did ([`crate::closure`]), for the report.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct Closure {
    /// Cells split (the parents).
    pub cells_split: usize,
    /// Triangles that replace them.
    pub children: usize,
    /// Hanging vertices (distinct).
    pub hanging_vertices: usize,
    /// Per point array whose parent traces differ from the merged values at the hanging
    /// nodes by more than [`crate::tolerance::HANGING_JUMP_RELATIVE`]: the largest difference, absolute and
    /// relative to the array's largest magnitude, and whether the parents' values were kept
    /// as the children's own copies.
    pub jumps: Vec<ClosureJump>,
    /// Q1 parallelograms first cut into P2 triangle halves (a quadrilateral mesh with hanging
    /// nodes), 0 otherwise.
    pub quadrilaterals: usize,
}

/// The largest difference at the hanging nodes of one point array.
#[derive(Clone, Debug, serde::Serialize)]
pub struct ClosureJump {
    pub array: String,
    pub max: f64,
    pub relative: f64,
    pub kept_as_copies: bool,
}

/// What building the mesh found or changed, for the report.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct MeshReport {
    pub vertex_cells_ignored: usize,
    pub merge: Option<Merge>,
    /// Cells with an edge or centre node off its straight position.
    pub curved_cells: usize,
    /// Straight quadrilaterals that are no parallelogram.
    pub bilinear_cells: usize,
    /// Clockwise cells reordered counter-clockwise.
    pub reoriented: usize,
    /// Line cells lying on interior edges (file cell indices).
    pub interior_lines: Vec<usize>,
    /// Cells split at hanging nodes ([`crate::closure`]).
    pub closure: Option<Closure>,
}

/// Mesh, fields and the findings of building them.
#[derive(Clone, Debug)]
pub struct Dataset {
    pub path: PathBuf,
    pub mesh: Mesh,
    /// One tuple per mesh point (averaged over copies for exploded meshes).
    pub point_data: Vec<DataArray>,
    /// Cell arrays restricted to the 2D cells.
    pub cell_data: Vec<DataArray>,
    /// Cell arrays restricted to the lines.
    pub line_data: Vec<DataArray>,
    /// Per 2D cell, for each point array of 2 or 3 components whose node copies disagree (an
    /// exploded file of a field that is discontinuous across cells): the cell's own copy minus
    /// the merged value at each of its nodes, as [`CopyRows`]. Empty otherwise.
    pub copies: Vec<DataArray>,
    pub report: MeshReport,
}

/// The rows of a [`Dataset::copies`] array: per cell, [`MAX_NODES`] slots of (merged node, its
/// c deviations), the node stored as f64 (`NONE` in unused slots). Keyed by node, not slot,
/// because building the mesh may reorder a cell's nodes after the merge (clockwise cells).
pub struct CopyRows<'a> {
    array: &'a DataArray,
    components: usize,
}

impl<'a> CopyRows<'a> {
    pub fn new(array: &'a DataArray) -> CopyRows<'a> {
        CopyRows {
            array,
            components: array.components / MAX_NODES - 1,
        }
    }

    /// The cell's own value minus the merged one at `node` (its first two components), 0 for
    /// a node the cell does not hold.
    pub fn deviation(&self, t: usize, node: u32) -> [f64; 2] {
        let slot = 1 + self.components;
        let row = &self.array.values[t * self.array.components..(t + 1) * self.array.components];
        row.chunks_exact(slot)
            .find(|r| r[0] == f64::from(node))
            .map_or([0.0; 2], |r| [r[1], r[2]])
    }
}

impl Dataset {
    /// Finds a point array by name.
    pub fn point_array(&self, name: &str) -> Option<&DataArray> {
        self.point_data.iter().find(|a| a.name == name)
    }
}

/// Lists up to ten indices and how many more there are: "3, 17, 20".
pub fn list_indices(ix: &[usize]) -> String {
    let mut s = ix
        .iter()
        .take(10)
        .map(|i| i.to_string())
        .collect::<Vec<_>>()
        .join(", ");
    if ix.len() > 10 {
        s.push_str(&format!(" and {} more", ix.len() - 10));
    }
    s
}

/// The order of Lagrange cell `c` from a `HigherOrderDegrees` cell array, if the file has one.
fn declared_order(file: &VtuFile, c: usize) -> Option<std::result::Result<usize, String>> {
    let a = file
        .cell_data
        .iter()
        .find(|a| a.name == "HigherOrderDegrees")?;
    let v = &a.values[c * a.components..(c + 1) * a.components];
    let p = v[0];
    let t = file.types[c];
    let dims = if t == cell_type::LAGRANGE_CURVE { 1 } else { 2 };
    if v[..dims.min(v.len())].iter().any(|&d| d != p) || p.fract() != 0.0 || p < 1.0 {
        return Some(Err(format!(
            "HigherOrderDegrees {v:?} is not one integer order ≥ 1 in every direction"
        )));
    }
    Some(Ok(p as usize))
}

/// Builds the mesh and fields from a file, or says what is wrong with it.
pub fn build(file: VtuFile) -> Result<Dataset> {
    let path = file.path.clone();
    let err = |place: &str, problem: String| Error::input(&path, place, problem);
    let mut report = MeshReport::default();

    // Planar: z must be constant.
    let (zmin, zmax) = file
        .points
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
            (a.min(p[2]), b.max(p[2]))
        });
    let extent = file
        .points
        .iter()
        .fold(0.0f64, |m, p| m.max(p[0].abs()).max(p[1].abs()));
    if !file.points.is_empty()
        && zmax - zmin > tolerance::PLANAR_RELATIVE * extent.max(f64::MIN_POSITIVE)
    {
        return Err(err(
            "Points",
            format!(
                "z ranges over [{zmin}, {zmax}]; fosls reads planar 2D meshes (z constant); \
                 3D meshes are not supported yet"
            ),
        ));
    }

    // Classify cells.
    let mut degree = 0usize;
    let mut cells = Vec::new();
    let mut family = Vec::new();
    let mut file_cell = Vec::new();
    let mut lines = Vec::new();
    let mut line_cell = Vec::new();
    for c in 0..file.cell_count() {
        let n = file.cell(c);
        let t = file.types[c];
        let is_lagrange = matches!(
            t,
            cell_type::LAGRANGE_CURVE
                | cell_type::LAGRANGE_TRIANGLE
                | cell_type::LAGRANGE_QUADRILATERAL
        );
        let order = if is_lagrange {
            let from_count = cell_type::lagrange_order(t, n.len()).ok_or_else(|| {
                err(
                    &format!("cell {c}"),
                    format!(
                        "{} with {} nodes fits no Lagrange order",
                        cell_type::name(t),
                        n.len()
                    ),
                )
            })?;
            if let Some(d) = declared_order(&file, c) {
                let d = d.map_err(|m| err(&format!("cell {c}"), m))?;
                if d != from_count {
                    return Err(err(
                        &format!("cell {c}"),
                        format!(
                            "{} has {} nodes (order {from_count}) but HigherOrderDegrees says \
                             order {d}",
                            cell_type::name(t),
                            n.len()
                        ),
                    ));
                }
            }
            if from_count > 2 {
                return Err(err(
                    &format!("cell {c}"),
                    format!(
                        "is a {} of order {from_count}; fosls reads Lagrange cells of order 1 \
                         and 2",
                        cell_type::name(t)
                    ),
                ));
            }
            from_count
        } else {
            0
        };
        match cell_type::kind(t, n.len(), order) {
            cell_type::Kind::Point => report.vertex_cells_ignored += 1,
            cell_type::Kind::Line => {
                lines.push([n[0], n[1], if n.len() == 3 { n[2] } else { NONE }]);
                line_cell.push(c as u32);
            }
            cell_type::Kind::Cell(f) => {
                if degree != 0 && degree != f.degree() {
                    return Err(err(
                        &format!("cell {c}"),
                        "mixes linear and quadratic cells in one mesh".into(),
                    ));
                }
                degree = f.degree();
                let mut nodes = [NONE; MAX_NODES];
                match cell_type::node_order(t) {
                    Some(order) => {
                        for (slot, &i) in nodes.iter_mut().zip(order) {
                            *slot = n[i];
                        }
                    }
                    None => nodes[..n.len()].copy_from_slice(n),
                }
                cells.push(nodes);
                family.push(f);
                file_cell.push(c as u32);
            }
            cell_type::Kind::Solid => {
                return Err(err(
                    &format!("cell {c}"),
                    format!(
                        "3D cells are not supported yet ({}, VTK type {t}); fosls reads 2D \
                         meshes of triangles and quadrilaterals",
                        cell_type::name(t)
                    ),
                ));
            }
            cell_type::Kind::Unsupported => {
                return Err(err(
                    &format!("cell {c}"),
                    format!(
                        "has unsupported VTK cell type {t} ({}{}); fosls reads vertices, \
                         lines, triangles and quadrilaterals, linear, quadratic and Lagrange of \
                         order 1 and 2, pixels and polygons of 3 or 4 vertices (VTK 1, 3, 5, 7, \
                         8, 9, 21, 22, 23, 28, 68, 69, 70)",
                        cell_type::name(t),
                        if t == cell_type::POLYGON {
                            format!(" of {} vertices", n.len())
                        } else {
                            String::new()
                        }
                    ),
                ));
            }
        }
    }
    if cells.is_empty() {
        return Err(err(
            "Cells",
            "no 2D cells (fosls needs a mesh of triangles or quadrilaterals)".into(),
        ));
    }
    if degree == 1
        && let Some(k) = lines.iter().position(|l| l[2] != NONE)
    {
        return Err(err(
            &format!("cell {}", line_cell[k]),
            "is a quadratic edge in a mesh of linear cells".into(),
        ));
    }

    let shape = vec![Shape::Affine; cells.len()];
    let mut mesh = Mesh {
        points: file.points.iter().map(|p| [p[0], p[1]]).collect(),
        degree,
        cells,
        family,
        shape,
        lines,
        file_cell,
        line_cell,
    };
    let mut point_data = file.point_data;
    let mut copies = Vec::new();
    if let Some((merge, c)) = merge_copies(&mut mesh, &mut point_data, &file.piece_points) {
        report.merge = Some(merge);
        copies = c;
    }

    check_geometry(&mut mesh, &mut report).map_err(|(place, problem)| err(&place, problem))?;

    // Split cell data between 2D cells and lines.
    let pick = |a: &DataArray, cells: &[u32]| a.rows(cells.iter().map(|&c| c as usize));
    let cell_data = file
        .cell_data
        .iter()
        .map(|a| pick(a, &mesh.file_cell))
        .collect();
    let line_data = file
        .cell_data
        .iter()
        .map(|a| pick(a, &mesh.line_cell))
        .collect();

    Ok(Dataset {
        path,
        mesh,
        point_data,
        cell_data,
        line_data,
        copies,
        report,
    })
}

/// The node permutation that reverses the orientation of a cell of `family`.
fn reversal(family: Family) -> &'static [usize] {
    match family {
        Family::Tri3 => &[0, 2, 1],
        Family::Tri6 => &[0, 2, 1, 5, 4, 3],
        Family::Quad4 => &[0, 3, 2, 1],
        Family::Quad8 => &[0, 3, 2, 1, 7, 6, 5, 4],
        Family::Quad9 => &[0, 3, 2, 1, 7, 6, 5, 4, 8],
    }
}

/// Orientation, zero-area, duplicate and shape checks. All-clockwise meshes are reordered; a
/// mix of orientations means inverted cells. The shape of each cell (affine, bilinear,
/// curved) is decided here, once.
fn check_geometry(
    mesh: &mut Mesh,
    report: &mut MeshReport,
) -> std::result::Result<(), (String, String)> {
    let n = mesh.cells.len();
    let areas: Vec<f64> = (0..n)
        .into_par_iter()
        .map(|t| mesh.double_area(t))
        .collect();
    let scales: Vec<f64> = (0..n)
        .into_par_iter()
        .map(|t| geometry::diameter(mesh.family[t], &mesh.coords(t)))
        .collect();
    let degenerate: Vec<usize> = (0..n)
        .filter(|&t| {
            let a = areas[t].abs();
            a.is_nan() || a <= tolerance::DEGENERATE_AREA_RELATIVE * scales[t].powi(2)
        })
        .map(|t| mesh.file_cell[t] as usize)
        .collect();
    if !degenerate.is_empty() {
        return Err((
            "Cells".into(),
            format!(
                "zero-area {}: cells {} ({} in all)",
                noun(mesh),
                list_indices(&degenerate),
                degenerate.len()
            ),
        ));
    }
    // Node order is a writer's convention: clockwise cells are reordered counter-clockwise.
    // A truly inverted cell overlaps its neighbour; topology finds that as a shared edge with
    // both cells on the same side.
    for (t, cell) in mesh.cells.iter_mut().enumerate() {
        if areas[t] < 0.0 {
            let p = reversal(mesh.family[t]);
            let old = *cell;
            for (k, &j) in p.iter().enumerate() {
                cell[k] = old[j];
            }
            report.reoriented += 1;
        }
    }

    // Shapes, decided once; a non-affine cell must keep a positive Jacobian at its nodes and
    // at the points of a moderate rule.
    let shapes: Vec<Shape> = (0..n)
        .into_par_iter()
        .map(|t| geometry::classify(mesh.family[t], &mesh.coords(t), tolerance::CURVED_RELATIVE))
        .collect();
    let inverted: Vec<usize> = (0..n)
        .into_par_iter()
        .filter(|&t| shapes[t] != Shape::Affine && !positive_jacobian(mesh, t))
        .map(|t| mesh.file_cell[t] as usize)
        .collect();
    report.curved_cells = shapes.iter().filter(|&&s| s == Shape::Curved).count();
    report.bilinear_cells = shapes.iter().filter(|&&s| s == Shape::Bilinear).count();
    mesh.shape = shapes;
    if !inverted.is_empty() {
        return Err((
            "Cells".into(),
            format!(
                "{} with a non-positive Jacobian (a mid-edge node too far off the chord, or a \
                 non-convex quadrilateral): cells {} ({} in all)",
                if mesh.has_quads() {
                    "cells"
                } else {
                    "curved triangles"
                },
                list_indices(&inverted),
                inverted.len()
            ),
        ));
    }

    // Duplicates: equal vertex sets.
    let mut keys: Vec<([u32; 4], usize)> = (0..n)
        .map(|t| {
            let v = mesh.vertices(t);
            let mut k = [NONE; 4];
            k[..v.len()].copy_from_slice(v);
            k.sort_unstable();
            (k, t)
        })
        .collect();
    keys.par_sort_unstable();
    let dups: Vec<usize> = keys
        .windows(2)
        .filter(|w| w[0].0 == w[1].0)
        .map(|w| mesh.file_cell[w[1].1] as usize)
        .collect();
    if !dups.is_empty() {
        return Err((
            "Cells".into(),
            format!(
                "duplicate {} (same vertices as an earlier cell): cells {} ({} in all)",
                noun(mesh),
                list_indices(&dups),
                dups.len()
            ),
        ));
    }
    Ok(())
}

/// "triangles" on triangle meshes, "cells" otherwise (messages).
fn noun(mesh: &Mesh) -> &'static str {
    if mesh.has_quads() {
        "cells"
    } else {
        "triangles"
    }
}

/// det J > 0 at every node of the reference cell and at the points of a degree-4 rule.
fn positive_jacobian(mesh: &Mesh, t: usize) -> bool {
    let f = mesh.family[t];
    let x = mesh.coords(t);
    let nodes = f.reference_nodes().iter().copied();
    let rule = geometry::table(f, 4, false).points.iter().copied();
    nodes.chain(rule).all(|xi| {
        let (_, g) = f.shape(xi);
        geometry::values::jacobian(&x, f.nodes(), &g).det > 0.0
    })
}

/// The connected component of every point (cells sharing a node are connected); `NONE` for
/// points of no cell.
fn cell_components(mesh: &Mesh) -> Vec<u32> {
    let np = mesh.points.len();
    let mut parent: Vec<u32> = (0..np as u32).collect();
    fn root(parent: &mut [u32], mut i: u32) -> u32 {
        while parent[i as usize] != i {
            parent[i as usize] = parent[parent[i as usize] as usize];
            i = parent[i as usize];
        }
        i
    }
    // The vertices decide the components; a high-order node joins its cell's first vertex
    // afterwards (it is in that cell's component whatever other cells hold it).
    let mut used = vec![false; np];
    for t in 0..mesh.len() {
        let n = mesh.vertices(t);
        used[n[0] as usize] = true;
        for &v in &n[1..] {
            used[v as usize] = true;
            let a = root(&mut parent, n[0]);
            let b = root(&mut parent, v);
            if a != b {
                let (lo, hi) = (a.min(b), a.max(b));
                parent[hi as usize] = lo;
            }
        }
    }
    // A node that is a vertex of one cell and a high-order node of another (a hanging node of
    // a quadratic mesh) connects the two cells.
    for t in 0..mesh.len() {
        let n = mesh.nodes(t);
        for &v in &n[mesh.vertices(t).len()..] {
            if used[v as usize] {
                let a = root(&mut parent, n[0]);
                let b = root(&mut parent, v);
                if a != b {
                    let (lo, hi) = (a.min(b), a.max(b));
                    parent[hi as usize] = lo;
                }
            }
        }
    }
    let mut comp: Vec<u32> = (0..np as u32)
        .map(|i| {
            if used[i as usize] {
                root(&mut parent, i)
            } else {
                NONE
            }
        })
        .collect();
    for t in 0..mesh.len() {
        let n = mesh.nodes(t);
        let c = comp[n[0] as usize];
        for &v in &n[mesh.vertices(t).len()..] {
            if !used[v as usize] {
                comp[v as usize] = c;
            }
        }
    }
    comp
}

/// The number of components in `cell_components`' labelling: each component is labelled by
/// its smallest point index, so it is counted once, at that point.
fn component_count(comp: &[u32]) -> usize {
    comp.iter()
        .enumerate()
        .filter(|&(i, &c)| c == i as u32)
        .count()
}

/// Merges node copies and averages point data over copies, recording the largest jump per
/// array and, for arrays of 2 or 3 components that jump, every cell's own copies
/// ([`Dataset::copies`]). Copies arise in exploded meshes (no node shared by two triangles),
/// where any two coincident nodes are merged, and in files of several pieces, where coincident
/// nodes of different pieces are. Coincident nodes of one piece of a conforming mesh (a slit)
/// are kept.
fn merge_copies(
    mesh: &mut Mesh,
    point_data: &mut [DataArray],
    piece_points: &[usize],
) -> Option<(Merge, Vec<DataArray>)> {
    let np = mesh.points.len();
    if mesh.cells.len() < 2 {
        return None;
    }
    let mut users = vec![0u8; np];
    for t in 0..mesh.cells.len() {
        for &v in mesh.nodes(t) {
            users[v as usize] = users[v as usize].saturating_add(1);
        }
    }
    let mut exploded = users.iter().all(|&u| u <= 1);
    // Points shared only inside groups of cells (MFEM's low-order output refines every element
    // and shares points only inside it): the connected components of the cells are the groups.
    // Merging across them needs at least three components and as many coincident pairs as
    // components, so that two bodies touching at a point (or flush along one interface with
    // duplicated nodes: K = 2) stay apart.
    let mut fragments = None;
    if !exploded && piece_points.len() < 2 {
        let comp = cell_components(mesh);
        let k = component_count(&comp);
        if k < 3 {
            return None;
        }
        fragments = Some((comp, k));
    }
    // Nodes of one group are never merged with each other.
    let group: Vec<u32> = if let Some((comp, _)) = &fragments {
        comp.clone()
    } else if exploded {
        (0..np as u32).collect()
    } else {
        let mut g = vec![0u32; np];
        for (k, w) in piece_points.windows(2).enumerate() {
            g[w[0]..w[1]].fill(k as u32);
        }
        let last = piece_points[piece_points.len() - 1];
        g[last..].fill(piece_points.len() as u32 - 1);
        g
    };

    // Local size: the shortest vertex-to-vertex edge of the cell holding the node.
    let mut size = vec![f64::INFINITY; np];
    for t in 0..mesh.cells.len() {
        let v = mesh.vertices(t);
        let h = (0..v.len())
            .map(|k| {
                dist(
                    mesh.points[v[k] as usize],
                    mesh.points[v[(k + 1) % v.len()] as usize],
                )
            })
            .fold(f64::INFINITY, f64::min);
        for &v in mesh.nodes(t) {
            size[v as usize] = size[v as usize].min(h);
        }
    }
    for l in &mesh.lines {
        let h = dist(mesh.points[l[0] as usize], mesh.points[l[1] as usize]);
        for &v in l.iter().filter(|&&v| v != NONE) {
            if !size[v as usize].is_finite() {
                size[v as usize] = h;
            }
        }
    }
    let tol: Vec<f64> = size
        .iter()
        .map(|&s| {
            if s.is_finite() {
                tolerance::MERGE_RELATIVE * s
            } else {
                0.0
            }
        })
        .collect();
    let bin = tol.iter().copied().fold(0.0f64, f64::max);
    if bin <= 0.0 {
        return None;
    }
    let key = |p: [f64; 2]| ((p[0] / bin).floor() as i64, (p[1] / bin).floor() as i64);
    let mut order: Vec<((i64, i64), u32)> =
        (0..np).map(|i| (key(mesh.points[i]), i as u32)).collect();
    order.par_sort_unstable();

    // Union-find over pairs closer than the smaller of their tolerances.
    let mut parent: Vec<u32> = (0..np as u32).collect();
    fn root(parent: &mut [u32], mut i: u32) -> u32 {
        while parent[i as usize] != i {
            parent[i as usize] = parent[parent[i as usize] as usize];
            i = parent[i as usize];
        }
        i
    }
    for &(k, i) in &order {
        for dx in -1..=1 {
            for dy in -1..=1 {
                // Keys saturate for huge coordinates; skip neighbours beyond the range.
                let (Some(kx), Some(ky)) = (k.0.checked_add(dx), k.1.checked_add(dy)) else {
                    continue;
                };
                let nk = (kx, ky);
                let start = order.partition_point(|e| e.0 < nk);
                for &(k2, j) in &order[start..] {
                    if k2 != nk {
                        break;
                    }
                    if j <= i || group[i as usize] == group[j as usize] {
                        continue;
                    }
                    let t = tol[i as usize].min(tol[j as usize]);
                    if dist(mesh.points[i as usize], mesh.points[j as usize]) <= t {
                        let (ri, rj) = (root(&mut parent, i), root(&mut parent, j));
                        if ri != rj {
                            parent[ri.max(rj) as usize] = ri.min(rj);
                        }
                    }
                }
            }
        }
    }
    let mut new_index = vec![NONE; np];
    let mut count = 0u32;
    for i in 0..np as u32 {
        let r = root(&mut parent, i);
        if new_index[r as usize] == NONE {
            new_index[r as usize] = count;
            count += 1;
        }
        new_index[i as usize] = new_index[r as usize];
    }
    if count as usize == np {
        return None;
    }
    if let Some((_, k)) = &fragments {
        if np - (count as usize) < *k {
            return None;
        }
        exploded = true;
    }

    let mut points = vec![[0.0; 2]; count as usize];
    for i in 0..np {
        if root(&mut parent, i as u32) == i as u32 {
            points[new_index[i] as usize] = mesh.points[i];
        }
    }
    let mut copies = vec![0u32; count as usize];
    for &n in &new_index {
        copies[n as usize] += 1;
    }
    let mut jumps = Vec::new();
    let mut own = Vec::new();
    for a in point_data.iter_mut() {
        let c = a.components;
        let mut sum = vec![0.0; count as usize * c];
        let mut lo = vec![f64::INFINITY; count as usize * c];
        let mut hi = vec![f64::NEG_INFINITY; count as usize * c];
        // A non-finite copy makes the merged value NaN, so that the field checks refuse it
        // (min and max would skip a NaN silently).
        let mut nonfinite = vec![false; count as usize * c];
        for (i, &n) in new_index.iter().enumerate() {
            let n = n as usize;
            for k in 0..c {
                let v = a.values[i * c + k];
                if !v.is_finite() {
                    nonfinite[n * c + k] = true;
                }
                sum[n * c + k] += v;
                lo[n * c + k] = lo[n * c + k].min(v);
                hi[n * c + k] = hi[n * c + k].max(v);
            }
        }
        let mut max_jump = 0.0f64;
        let mut max_abs = 0.0f64;
        for n in 0..count as usize {
            for k in 0..c {
                // Equal copies keep their value exactly (a mean of three equal values
                // need not round back to it).
                let i = n * c + k;
                sum[i] = if nonfinite[i] {
                    f64::NAN
                } else if lo[i] == hi[i] {
                    lo[i]
                } else {
                    sum[i] / copies[n] as f64
                };
                max_jump = max_jump.max(hi[n * c + k] - lo[n * c + k]);
                max_abs = max_abs.max(lo[n * c + k].abs()).max(hi[n * c + k].abs());
            }
        }
        // A displacement written per cell (a discontinuous field): the broken-norm distance
        // of the merged field from it enters the bound (`audit`), so each cell keeps its own.
        if max_jump > 0.0 && (2..=3).contains(&c) {
            let slot = 1 + c;
            let row = MAX_NODES * slot;
            let mut v = vec![0.0; mesh.cells.len() * row];
            for (cell, out) in mesh.cells.iter().zip(v.chunks_exact_mut(row)) {
                for (&i, r) in cell.iter().zip(out.chunks_exact_mut(slot)) {
                    if i == NONE {
                        r[0] = f64::from(NONE);
                        continue;
                    }
                    let (i, n) = (i as usize, new_index[i as usize] as usize);
                    r[0] = n as f64;
                    for k in 0..c {
                        r[1 + k] = a.values[i * c + k] - sum[n * c + k];
                    }
                }
            }
            own.push(DataArray {
                name: a.name.clone(),
                scalar: crate::read::decode::Scalar::Float64,
                components: row,
                component_names: Vec::new(),
                values: v,
            });
        }
        a.values = sum;
        jumps.push(Jump {
            array: a.name.clone(),
            max: max_jump,
            relative: if max_abs > 0.0 {
                max_jump / max_abs
            } else {
                0.0
            },
        });
    }
    for tri in &mut mesh.cells {
        for v in tri.iter_mut().filter(|v| **v != NONE) {
            *v = new_index[*v as usize];
        }
    }
    for l in &mut mesh.lines {
        for v in l.iter_mut().filter(|v| **v != NONE) {
            *v = new_index[*v as usize];
        }
    }
    mesh.points = points;
    Some((
        Merge {
            exploded,
            groups: fragments.map(|f| f.1),
            points_in_file: np,
            points_merged: count as usize,
            jumps,
        },
        own,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::read::decode::Scalar;
    use crate::read::vtu::{DataArray, VtuFile};
    use std::path::Path;

    /// Two triangles on the unit square, counter-clockwise, plus a boundary line.
    fn square() -> VtuFile {
        VtuFile::from_cells(
            Path::new("m.vtu"),
            vec![[0., 0., 0.], [1., 0., 0.], [0., 1., 0.], [1., 1., 0.]],
            &[
                (5, vec![0, 1, 2]),
                (5, vec![1, 3, 2]),
                (3, vec![0, 1]),
                (1, vec![3]),
            ],
        )
    }

    fn array(name: &str, components: usize, values: Vec<f64>) -> DataArray {
        DataArray {
            name: name.into(),
            scalar: Scalar::Float64,
            components,
            component_names: vec![],
            values,
        }
    }

    #[test]
    fn classifies_cells_and_splits_cell_data() {
        let mut f = square();
        f.cell_data.push(array("tag", 1, vec![10., 11., 12., 13.]));
        let d = build(f).unwrap();
        assert_eq!(d.mesh.degree, 1);
        assert_eq!(d.mesh.cells.len(), 2);
        assert_eq!(d.mesh.lines, vec![[0, 1, NONE]]);
        assert_eq!(d.cell_data[0].values, vec![10., 11.]);
        assert_eq!(d.line_data[0].values, vec![12.]);
        assert_eq!(d.report.vertex_cells_ignored, 1);
        assert_eq!(d.report.reoriented, 0);
        assert!(d.report.merge.is_none());
    }

    #[test]
    fn clockwise_cells_are_reordered() {
        let cw = VtuFile::from_cells(
            Path::new("m.vtu"),
            square().points,
            &[(5, vec![0, 2, 1]), (5, vec![1, 2, 3])],
        );
        let d = build(cw).unwrap();
        assert_eq!(d.report.reoriented, 2);
        assert!((0..2).all(|t| d.mesh.double_area(t) > 0.0));
        // P2: mid nodes follow their edges.
        let pts = vec![
            [0., 0., 0.],
            [1., 0., 0.],
            [0., 1., 0.],
            [0.5, 0., 0.],
            [0.5, 0.5, 0.],
            [0., 0.5, 0.],
        ];
        let d = build(VtuFile::from_cells(
            Path::new("m.vtu"),
            pts,
            &[(22, vec![0, 2, 1, 5, 4, 3])],
        ))
        .unwrap();
        assert_eq!(d.mesh.cells[0][..6], [0, 1, 2, 3, 4, 5]);
    }

    #[test]
    fn zero_area_and_duplicate_cells_are_errors() {
        let flat = VtuFile::from_cells(
            Path::new("m.vtu"),
            vec![[0., 0., 0.], [1., 0., 0.], [2., 0., 0.], [0., 1., 0.]],
            &[(5, vec![0, 1, 3]), (5, vec![0, 1, 2])],
        );
        assert_eq!(
            build(flat).unwrap_err().to_string(),
            "m.vtu: Cells: zero-area triangles: cells 1 (1 in all)"
        );
        let dup = VtuFile::from_cells(
            Path::new("m.vtu"),
            square().points,
            &[(5, vec![0, 1, 2]), (5, vec![1, 3, 2]), (5, vec![1, 2, 0])],
        );
        assert_eq!(
            build(dup).unwrap_err().to_string(),
            "m.vtu: Cells: duplicate triangles (same vertices as an earlier cell): cells 2 (1 in all)"
        );
    }

    #[test]
    fn exploded_mesh_is_merged_and_jumps_are_measured() {
        // Two cells with their own copies of the shared edge's nodes, one copy perturbed by
        // 1e-9 (well within the 1e-6 relative tolerance).
        let pts = vec![
            [0., 0., 0.],
            [1., 0., 0.],
            [0., 1., 0.],
            [1. + 1e-9, 0., 0.],
            [1., 1., 0.],
            [0., 1., 0.],
        ];
        let mut f = VtuFile::from_cells(
            Path::new("m.vtu"),
            pts,
            &[(5, vec![0, 1, 2]), (5, vec![3, 4, 5])],
        );
        // Continuous field u = x + y, discontinuous field s (jump 0.5 at node (0, 1)).
        f.point_data
            .push(array("u", 1, vec![0., 1., 1., 1., 2., 1.]));
        f.point_data
            .push(array("s", 1, vec![0., 1., 1., 1., 2., 1.5]));
        let d = build(f).unwrap();
        let m = d.report.merge.as_ref().unwrap();
        assert_eq!((m.points_in_file, m.points_merged), (6, 4));
        assert_eq!(d.mesh.cells[1][..3], [1, 3, 2]);
        assert_eq!(m.jumps[0].max, 0.0);
        assert_eq!(m.jumps[1].max, 0.5);
        assert_eq!(m.jumps[1].relative, 0.25);
        assert_eq!(d.point_array("s").unwrap().values, vec![0., 1., 1.25, 2.]);
    }

    #[test]
    fn distinct_nodes_of_a_conforming_mesh_are_never_merged() {
        // Coincident points in a conforming mesh (a slit) must stay apart.
        let f = VtuFile::from_cells(
            Path::new("m.vtu"),
            vec![
                [0., 0., 0.],
                [1., 0., 0.],
                [0., 1., 0.],
                [1., 1., 0.],
                [0., 1., 0.],
            ],
            &[(5, vec![0, 1, 2]), (5, vec![1, 3, 4]), (5, vec![1, 3, 2])],
        );
        assert!(build(f).unwrap().report.merge.is_none());
    }

    #[test]
    fn curved_p2_cells_are_counted_and_folded_ones_refused() {
        let pts = |mid_y: f64| {
            vec![
                [0., 0., 0.],
                [1., 0., 0.],
                [0., 1., 0.],
                [0.5, mid_y, 0.],
                [0.5, 0.5, 0.],
                [0., 0.5, 0.],
            ]
        };
        let cell = [(22u8, vec![0, 1, 2, 3, 4, 5])];
        let d = build(VtuFile::from_cells(Path::new("m.vtu"), pts(-0.1), &cell)).unwrap();
        assert_eq!((d.mesh.degree, d.report.curved_cells), (2, 1));
        let d = build(VtuFile::from_cells(Path::new("m.vtu"), pts(0.0), &cell)).unwrap();
        assert_eq!(d.report.curved_cells, 0);
        // Moving mid node 3 to (0.5, m): at vertex 1, ∂x/∂ξ = x₀ + 3x₁ − 4x₃ = (1, −4m) and
        // ∂x/∂η = x₀ − x₂ − 4x₃ + 4x₄ = (0, 1 − 4m), so det J = 1 − 4m < 0 for m = 0.3.
        let e = build(VtuFile::from_cells(Path::new("m.vtu"), pts(0.3), &cell))
            .unwrap_err()
            .to_string();
        assert!(e.contains("non-positive Jacobian"), "{e}");
    }

    #[test]
    fn non_planar_points_are_refused() {
        let mut f = square();
        f.points[3][2] = 0.5;
        assert_eq!(
            build(f).unwrap_err().to_string(),
            "m.vtu: Points: z ranges over [0, 0.5]; fosls reads planar 2D meshes (z constant); 3D \
             meshes are not supported yet"
        );
    }
}
