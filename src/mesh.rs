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
use crate::read::vtu::{DataArray, VtuFile, cell_type};

/// Marks an absent node (the mid nodes of P1 cells).
pub const NONE: u32 = u32::MAX;

/// Relative tolerance for merging node copies of an exploded mesh: copies closer than this
/// times the shortest edge of the cells that hold them are one node.
pub const MERGE_TOLERANCE: f64 = 1e-6;

/// A 2D triangle mesh of degree 1 (straight) or 2 (isoparametric, possibly curved).
///
/// Node order is VTK's: vertices 0, 1, 2 counter-clockwise, then mid-edge nodes 3 on (0, 1),
/// 4 on (1, 2), 5 on (2, 0). Lines are `[end, end, mid]`.
#[derive(Clone, Debug)]
pub struct Mesh {
    pub points: Vec<[f64; 2]>,
    /// 1 or 2.
    pub degree: usize,
    /// P1 cells have `NONE` in slots 3..6.
    pub triangles: Vec<[u32; 6]>,
    /// Boundary line cells of the file; slot 2 is `NONE` for straight lines.
    pub lines: Vec<[u32; 3]>,
    /// Index in the VTU file of each triangle (for messages and cell data).
    pub triangle_cell: Vec<u32>,
    /// Index in the VTU file of each line.
    pub line_cell: Vec<u32>,
}

impl Mesh {
    /// Nodes of triangle `t`: 3 for P1, 6 for P2.
    pub fn nodes(&self, t: usize) -> &[u32] {
        &self.triangles[t][..if self.degree == 2 { 6 } else { 3 }]
    }

    /// Node coordinates of triangle `t` (6 slots; P1 cells fill only the first 3).
    pub fn coords(&self, t: usize) -> [[f64; 2]; 6] {
        let mut x = [[0.0; 2]; 6];
        for (k, &n) in self.nodes(t).iter().enumerate() {
            x[k] = self.points[n as usize];
        }
        x
    }

    /// Twice the signed area of the straight triangle through the vertices of `t`.
    pub fn double_area(&self, t: usize) -> f64 {
        let [a, b, c, ..] = self.triangles[t];
        double_area(
            self.points[a as usize],
            self.points[b as usize],
            self.points[c as usize],
        )
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
    (a[0] - b[0]).hypot(a[1] - b[1])
}

/// How node copies of an exploded mesh were merged.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Merge {
    /// Every cell had its own node copies (else: copies at the interfaces of pieces).
    pub exploded: bool,
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

/// What building the mesh found or changed, for the report.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct MeshReport {
    pub vertex_cells_ignored: usize,
    pub merge: Option<Merge>,
    /// P2 cells with a mid-edge node off the chord midpoint.
    pub curved_cells: usize,
    /// Clockwise cells reordered counter-clockwise.
    pub reoriented: usize,
    /// Line cells lying on interior edges (file cell indices).
    pub interior_lines: Vec<usize>,
}

/// Mesh, fields and the findings of building them.
#[derive(Clone, Debug)]
pub struct Dataset {
    pub path: PathBuf,
    pub mesh: Mesh,
    /// One tuple per mesh point (averaged over copies for exploded meshes).
    pub point_data: Vec<DataArray>,
    /// Cell arrays restricted to the triangles.
    pub triangle_data: Vec<DataArray>,
    /// Cell arrays restricted to the lines.
    pub line_data: Vec<DataArray>,
    pub report: MeshReport,
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
    if !file.points.is_empty() && zmax - zmin > 1e-12 * extent.max(f64::MIN_POSITIVE) {
        return Err(err(
            "Points",
            format!("z ranges over [{zmin}, {zmax}]; fosls reads planar 2D meshes (z constant)"),
        ));
    }

    // Classify cells.
    let mut degree = 0usize;
    let mut triangles = Vec::new();
    let mut triangle_cell = Vec::new();
    let mut lines = Vec::new();
    let mut line_cell = Vec::new();
    for c in 0..file.cell_count() {
        let n = file.cell(c);
        let t = file.types[c];
        match t {
            cell_type::VERTEX => report.vertex_cells_ignored += 1,
            cell_type::TRIANGLE | cell_type::QUADRATIC_TRIANGLE => {
                let d = if t == cell_type::TRIANGLE { 1 } else { 2 };
                if degree != 0 && degree != d {
                    return Err(err(
                        &format!("cell {c}"),
                        "mixes linear and quadratic triangles in one mesh".into(),
                    ));
                }
                degree = d;
                let mut tri = [NONE; 6];
                tri[..n.len()].copy_from_slice(n);
                triangles.push(tri);
                triangle_cell.push(c as u32);
            }
            _ => {
                lines.push([n[0], n[1], if n.len() == 3 { n[2] } else { NONE }]);
                line_cell.push(c as u32);
            }
        }
    }
    if triangles.is_empty() {
        return Err(err(
            "Cells",
            "no triangles (fosls needs a 2D mesh of triangles)".into(),
        ));
    }
    if degree == 1
        && let Some(k) = lines.iter().position(|l| l[2] != NONE)
    {
        return Err(err(
            &format!("cell {}", line_cell[k]),
            "is a quadratic edge in a mesh of linear triangles".into(),
        ));
    }

    let mut mesh = Mesh {
        points: file.points.iter().map(|p| [p[0], p[1]]).collect(),
        degree,
        triangles,
        lines,
        triangle_cell,
        line_cell,
    };
    let mut point_data = file.point_data;
    if let Some(merge) = merge_copies(&mut mesh, &mut point_data, &file.piece_points) {
        report.merge = Some(merge);
    }

    check_geometry(&mut mesh, &mut report).map_err(|(place, problem)| err(&place, problem))?;

    // Split cell data between triangles and lines.
    let pick = |a: &DataArray, cells: &[u32]| DataArray {
        values: cells
            .iter()
            .flat_map(|&c| {
                let c = c as usize * a.components;
                a.values[c..c + a.components].iter().copied()
            })
            .collect(),
        ..a.clone()
    };
    let triangle_data = file
        .cell_data
        .iter()
        .map(|a| pick(a, &mesh.triangle_cell))
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
        triangle_data,
        line_data,
        report,
    })
}

/// Orientation, zero-area, duplicate and curved-cell checks. All-clockwise meshes are
/// reordered; a mix of orientations means inverted cells.
fn check_geometry(
    mesh: &mut Mesh,
    report: &mut MeshReport,
) -> std::result::Result<(), (String, String)> {
    let n = mesh.triangles.len();
    let areas: Vec<f64> = (0..n)
        .into_par_iter()
        .map(|t| mesh.double_area(t))
        .collect();
    let scales: Vec<f64> = (0..n)
        .into_par_iter()
        .map(|t| {
            let [a, b, c, ..] = mesh.triangles[t];
            let (a, b, c) = (
                mesh.points[a as usize],
                mesh.points[b as usize],
                mesh.points[c as usize],
            );
            dist(a, b).max(dist(b, c)).max(dist(c, a))
        })
        .collect();
    let degenerate: Vec<usize> = (0..n)
        .filter(|&t| areas[t].abs() <= 1e-12 * scales[t].powi(2))
        .map(|t| mesh.triangle_cell[t] as usize)
        .collect();
    if !degenerate.is_empty() {
        return Err((
            "Cells".into(),
            format!(
                "zero-area triangles: cells {} ({} in all)",
                list_indices(&degenerate),
                degenerate.len()
            ),
        ));
    }
    // Node order is a writer's convention: clockwise cells are reordered counter-clockwise.
    // A truly inverted cell overlaps its neighbour; topology finds that as a shared edge with
    // both cells on the same side.
    for (t, tri) in mesh.triangles.iter_mut().enumerate() {
        if areas[t] < 0.0 {
            *tri = [tri[0], tri[2], tri[1], tri[5], tri[4], tri[3]];
            report.reoriented += 1;
        }
    }

    if mesh.degree == 2 {
        // A curved cell must keep a positive Jacobian: checked at the vertices, where
        // det J of the P2 map is smallest for moderately curved cells.
        let mut inverted = Vec::new();
        let mut curved = 0;
        for (t, &h) in scales.iter().enumerate() {
            let x = mesh.coords(t);
            let off = |k: usize, a: usize, b: usize| {
                dist(x[k], [(x[a][0] + x[b][0]) / 2.0, (x[a][1] + x[b][1]) / 2.0])
            };
            if off(3, 0, 1).max(off(4, 1, 2)).max(off(5, 2, 0)) > 1e-12 * h {
                curved += 1;
                if p2_vertex_jacobians(&x).iter().any(|&d| d <= 0.0) {
                    inverted.push(mesh.triangle_cell[t] as usize);
                }
            }
        }
        report.curved_cells = curved;
        if !inverted.is_empty() {
            return Err((
                "Cells".into(),
                format!(
                    "curved triangles with a non-positive Jacobian (mid-edge node too far off \
                     the chord): cells {} ({} in all)",
                    list_indices(&inverted),
                    inverted.len()
                ),
            ));
        }
    }

    // Duplicates: equal vertex sets.
    let mut keys: Vec<([u32; 3], usize)> = (0..n)
        .map(|t| {
            let mut k = [
                mesh.triangles[t][0],
                mesh.triangles[t][1],
                mesh.triangles[t][2],
            ];
            k.sort_unstable();
            (k, t)
        })
        .collect();
    keys.par_sort_unstable();
    let dups: Vec<usize> = keys
        .windows(2)
        .filter(|w| w[0].0 == w[1].0)
        .map(|w| mesh.triangle_cell[w[1].1] as usize)
        .collect();
    if !dups.is_empty() {
        return Err((
            "Cells".into(),
            format!(
                "duplicate triangles (same vertices as an earlier cell): cells {} ({} in all)",
                list_indices(&dups),
                dups.len()
            ),
        ));
    }
    Ok(())
}

/// det J of the P2 map at the three vertices of the reference triangle.
///
/// With λ₁ = ξ, λ₂ = η, λ₀ = 1 − ξ − η and φ₀ = λ₀(2λ₀ − 1), …, φ₃ = 4λ₀λ₁, φ₄ = 4λ₁λ₂,
/// φ₅ = 4λ₂λ₀: at vertex 0, ∂x/∂ξ = −3x₀ − x₁ + 4x₃ and ∂x/∂η = −3x₀ − x₂ + 4x₅, and
/// likewise at the other vertices.
fn p2_vertex_jacobians(x: &[[f64; 2]; 6]) -> [f64; 3] {
    let comb = |c: &[(usize, f64)]| {
        let mut v = [0.0; 2];
        for &(k, w) in c {
            v[0] += w * x[k][0];
            v[1] += w * x[k][1];
        }
        v
    };
    let det = |a: [f64; 2], b: [f64; 2]| a[0] * b[1] - a[1] * b[0];
    [
        det(
            comb(&[(0, -3.0), (1, -1.0), (3, 4.0)]),
            comb(&[(0, -3.0), (2, -1.0), (5, 4.0)]),
        ),
        det(
            comb(&[(0, 1.0), (1, 3.0), (3, -4.0)]),
            comb(&[(0, 1.0), (2, -1.0), (3, -4.0), (4, 4.0)]),
        ),
        det(
            comb(&[(0, 1.0), (1, -1.0), (4, 4.0), (5, -4.0)]),
            comb(&[(0, 1.0), (2, 3.0), (5, -4.0)]),
        ),
    ]
}

/// Merges node copies and averages point data over copies, recording the largest jump per
/// array. Copies arise in exploded meshes (no node shared by two triangles), where any two
/// coincident nodes are merged, and in files of several pieces, where coincident nodes of
/// different pieces are. Coincident nodes of one piece of a conforming mesh (a slit) are kept.
fn merge_copies(
    mesh: &mut Mesh,
    point_data: &mut [DataArray],
    piece_points: &[usize],
) -> Option<Merge> {
    let np = mesh.points.len();
    if mesh.triangles.len() < 2 {
        return None;
    }
    let mut users = vec![0u8; np];
    for t in 0..mesh.triangles.len() {
        for &v in mesh.nodes(t) {
            users[v as usize] = users[v as usize].saturating_add(1);
        }
    }
    let exploded = users.iter().all(|&u| u <= 1);
    if !exploded && piece_points.len() < 2 {
        return None;
    }
    // Nodes of one group are never merged with each other.
    let group: Vec<u32> = if exploded {
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
    for t in 0..mesh.triangles.len() {
        let [a, b, c, ..] = mesh.triangles[t];
        let (pa, pb, pc) = (
            mesh.points[a as usize],
            mesh.points[b as usize],
            mesh.points[c as usize],
        );
        let h = dist(pa, pb).min(dist(pb, pc)).min(dist(pc, pa));
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
                MERGE_TOLERANCE * s
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
    for a in point_data.iter_mut() {
        let c = a.components;
        let mut sum = vec![0.0; count as usize * c];
        let mut lo = vec![f64::INFINITY; count as usize * c];
        let mut hi = vec![f64::NEG_INFINITY; count as usize * c];
        for (i, &n) in new_index.iter().enumerate() {
            let n = n as usize;
            for k in 0..c {
                let v = a.values[i * c + k];
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
                sum[i] = if lo[i] == hi[i] {
                    lo[i]
                } else {
                    sum[i] / copies[n] as f64
                };
                max_jump = max_jump.max(hi[n * c + k] - lo[n * c + k]);
                max_abs = max_abs.max(lo[n * c + k].abs()).max(hi[n * c + k].abs());
            }
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
    for tri in &mut mesh.triangles {
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
    Some(Merge {
        exploded,
        points_in_file: np,
        points_merged: count as usize,
        jumps,
    })
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
        assert_eq!(d.mesh.triangles.len(), 2);
        assert_eq!(d.mesh.lines, vec![[0, 1, NONE]]);
        assert_eq!(d.triangle_data[0].values, vec![10., 11.]);
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
        assert_eq!(d.mesh.triangles[0], [0, 1, 2, 3, 4, 5]);
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
        assert_eq!(d.mesh.triangles[1][..3], [1, 3, 2]);
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
            "m.vtu: Points: z ranges over [0, 0.5]; fosls reads planar 2D meshes (z constant)"
        );
    }
}
