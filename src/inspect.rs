//! `fosls inspect`: what a VTU file holds, for a user about to write a scene (docs/design.md §7).
//!
//! Cells by type, points, every array with its range and non-finite count, candidate
//! boundary-tag arrays with the edges each tag selects, whether the mesh is exploded or curved,
//! and the bounding box.

use std::collections::BTreeMap;
use std::fmt::Write as _;

use serde::Serialize;

use crate::mesh::{Dataset, Merge};
use crate::read::vtu::{DataArray, FileFormat, VtuFile, cell_type};
use crate::topology::{self, Topology};

/// Range and health of one array.
#[derive(Clone, Debug, Serialize)]
pub struct ArraySummary {
    pub name: String,
    #[serde(rename = "type")]
    pub scalar: String,
    pub components: usize,
    pub component_names: Vec<String>,
    /// Per component, over finite values (null when there are none).
    pub min: Vec<Option<f64>>,
    pub max: Vec<Option<f64>>,
    pub nan: usize,
    pub infinite: usize,
}

/// Edges selected by one value of a tag array.
#[derive(Clone, Debug, Serialize)]
pub struct TagCount {
    pub value: i64,
    pub line_cells: usize,
    /// Sum of the straight lengths of those lines.
    pub length: f64,
}

/// An integer cell array on the line cells, usable as `[boundaries] tag_array`.
#[derive(Clone, Debug, Serialize)]
pub struct TagArray {
    pub name: String,
    pub values: Vec<TagCount>,
}

/// Everything `inspect` reports.
#[derive(Clone, Debug, Serialize)]
pub struct Summary {
    pub file: String,
    pub format: FileFormat,
    pub points_in_file: usize,
    pub mesh_points: usize,
    /// "triangle (5)" → count, for every VTK cell type present.
    pub cells_by_type: BTreeMap<String, usize>,
    pub degree: usize,
    /// Cell family ("P2 triangle", "Q2 quadrilateral", …) → count.
    pub families: BTreeMap<String, usize>,
    /// Cells with an edge node off its straight position (docs/design.md §4.3).
    pub curved_cells: usize,
    /// Straight quadrilaterals that are no parallelogram.
    pub bilinear_cells: usize,
    pub exploded: Option<Merge>,
    /// Clockwise cells reordered counter-clockwise.
    pub reoriented: usize,
    /// [xmin, ymin, xmax, ymax].
    pub bounding_box: [f64; 4],
    pub edges: usize,
    pub boundary_edges: usize,
    /// Boundary edges covered by no line cell (traction-free unless a `where` selects them).
    pub boundary_edges_without_line: usize,
    pub interior_lines: Vec<usize>,
    pub point_arrays: Vec<ArraySummary>,
    pub cell_arrays: Vec<ArraySummary>,
    pub tag_arrays: Vec<TagArray>,
    /// The connected components of the cells (docs/design.md §4.2 "Bodies").
    pub bodies: Vec<crate::bodies::Body>,
    /// Fields written one array per component that `estimate` joins (docs/design.md §4.1
    /// "Component arrays"), one line each.
    pub joined: Vec<String>,
    /// Straight triangles split at hanging nodes (docs/design.md §4.2 "Closure").
    pub closure: Option<crate::mesh::Closure>,
}

fn summarize(a: &DataArray) -> ArraySummary {
    let c = a.components.max(1);
    let mut min = vec![None::<f64>; c];
    let mut max = vec![None::<f64>; c];
    let (mut nan, mut infinite) = (0, 0);
    for (i, &v) in a.values.iter().enumerate() {
        if v.is_nan() {
            nan += 1;
        } else if v.is_infinite() {
            infinite += 1;
        } else {
            let k = i % c;
            min[k] = Some(min[k].map_or(v, |m| m.min(v)));
            max[k] = Some(max[k].map_or(v, |m| m.max(v)));
        }
    }
    ArraySummary {
        name: a.name.clone(),
        scalar: a.scalar.name().into(),
        components: a.components,
        component_names: a.component_names.clone(),
        min,
        max,
        nan,
        infinite,
    }
}

/// Builds the summary from the file as read and the dataset built from it.
pub fn summary(file: &VtuFile, data: &Dataset, topo: &Topology) -> Summary {
    let mut cells_by_type = BTreeMap::new();
    for &t in &file.types {
        *cells_by_type
            .entry(format!("{} ({t})", cell_type::name(t)))
            .or_insert(0) += 1;
    }
    let mesh = &data.mesh;
    let mut tag_arrays = Vec::new();
    if !mesh.lines.is_empty() {
        for a in &data.line_data {
            if a.components != 1 || a.values.iter().any(|v| !v.is_finite() || v.fract() != 0.0) {
                continue;
            }
            let mut counts: BTreeMap<i64, (usize, f64)> = BTreeMap::new();
            for (l, &v) in a.values.iter().enumerate() {
                let [p, q, _] = mesh.lines[l];
                let (p, q) = (mesh.points[p as usize], mesh.points[q as usize]);
                let e = counts.entry(v as i64).or_insert((0, 0.0));
                e.0 += 1;
                e.1 += (p[0] - q[0]).hypot(p[1] - q[1]);
            }
            if counts.len() <= 64 {
                tag_arrays.push(TagArray {
                    name: a.name.clone(),
                    values: counts
                        .into_iter()
                        .map(|(value, (line_cells, length))| TagCount {
                            value,
                            line_cells,
                            length,
                        })
                        .collect(),
                });
            }
        }
    }
    let mut covered = vec![false; topo.edges.len()];
    for &e in &topo.line_edge {
        covered[e as usize] = true;
    }
    Summary {
        file: file.path.display().to_string(),
        format: file.format.clone(),
        points_in_file: file.points.len(),
        mesh_points: mesh.points.len(),
        cells_by_type,
        degree: mesh.degree,
        families: mesh.family.iter().fold(BTreeMap::new(), |mut m, f| {
            *m.entry(f.name().to_string()).or_insert(0) += 1;
            m
        }),
        curved_cells: data.report.curved_cells,
        bilinear_cells: data.report.bilinear_cells,
        exploded: data.report.merge.clone(),
        reoriented: data.report.reoriented,
        bounding_box: mesh.bounding_box(),
        edges: topo.edges.len(),
        boundary_edges: topo.boundary_edges.len(),
        boundary_edges_without_line: topo
            .boundary_edges
            .iter()
            .filter(|&&e| !covered[e as usize])
            .count(),
        interior_lines: topology::interior_lines(data, topo),
        point_arrays: file.point_data.iter().map(summarize).collect(),
        cell_arrays: file.cell_data.iter().map(summarize).collect(),
        tag_arrays,
        bodies: crate::bodies::find(mesh).list,
        joined: Vec::new(),
        closure: data.report.closure.clone(),
    }
}

fn range(s: &ArraySummary) -> String {
    (0..s.components)
        .map(|k| match (s.min[k], s.max[k]) {
            (Some(a), Some(b)) => format!("[{a:.6e}, {b:.6e}]"),
            _ => "[no finite values]".into(),
        })
        .collect::<Vec<_>>()
        .join(" ")
}

/// The summary as text for the terminal.
pub fn render(s: &Summary) -> String {
    let mut o = String::new();
    let _ = writeln!(o, "{}", s.file);
    let f = &s.format;
    let _ = writeln!(
        o,
        "  format      {} | compressor {} | header {} | {} | {} piece(s) | points {}",
        f.data_formats.join(", "),
        f.compressor,
        f.header_type,
        f.byte_order,
        f.pieces,
        f.points_type
    );
    if !f.container.is_empty() {
        let _ = writeln!(o, "  container   {}", f.container);
    }
    let _ = writeln!(
        o,
        "  points      {} in file, {} in the mesh",
        s.points_in_file, s.mesh_points
    );
    for (t, n) in &s.cells_by_type {
        let _ = writeln!(o, "  cells       {n:>9} {t}");
    }
    let _ = writeln!(
        o,
        "  mesh        {}; {} curved, {} bilinear; {} edges, {} on the boundary ({} without a \
         line cell)",
        s.families
            .iter()
            .map(|(f, n)| format!("{n} {f}"))
            .collect::<Vec<_>>()
            .join(", "),
        s.curved_cells,
        s.bilinear_cells,
        s.edges,
        s.boundary_edges,
        s.boundary_edges_without_line
    );
    let b = s.bounding_box;
    let _ = writeln!(
        o,
        "  bounds      x in [{}, {}], y in [{}, {}]",
        b[0], b[2], b[1], b[3]
    );
    if s.bodies.len() > 1 {
        let _ = writeln!(
            o,
            "  bodies      {} (connected components of the cells; a scene picks one with [body])",
            s.bodies.len()
        );
    }
    for b in s.bodies.iter().filter(|_| s.bodies.len() > 1) {
        let [x0, y0, x1, y1] = b.bounding_box;
        let _ = writeln!(
            o,
            "  body {:<6} {} cells, {} points, x in [{x0}, {x1}], y in [{y0}, {y1}], first cell {}",
            b.index, b.cells, b.points, b.first_cell
        );
    }
    match &s.exploded {
        Some(m) => {
            let _ = writeln!(
                o,
                "  {}: {} node copies merged into {} nodes",
                if m.exploded {
                    "exploded    yes"
                } else {
                    "exploded    no, but pieces share interface nodes"
                },
                m.points_in_file,
                m.points_merged
            );
            for j in &m.jumps {
                let _ = writeln!(
                    o,
                    "              \"{}\": max jump between copies {:.3e} ({:.3e} relative){}",
                    j.array,
                    j.max,
                    j.relative,
                    if j.max > 0.0 { ", discontinuous" } else { "" }
                );
            }
        }
        None => {
            let _ = writeln!(o, "  exploded    no");
        }
    }
    for j in &s.joined {
        let _ = writeln!(o, "  components  {j}");
    }
    if let Some(c) = &s.closure {
        if c.quadrilaterals > 0 {
            let _ = writeln!(
                o,
                "  hanging     {} Q1 parallelograms cut into P2 triangle halves carrying the same \
                 field (docs/design.md §4.2)",
                c.quadrilaterals
            );
        }
        let _ = writeln!(
            o,
            "  hanging     {} hanging vertices: {} triangles split into {} (the mesh line counts \
             the split)",
            c.hanging_vertices, c.cells_split, c.children
        );
        for j in &c.jumps {
            let _ = writeln!(
                o,
                "              \"{}\" differs from the split cells' trace there by up to {:.3e} \
                 ({:.3e} relative)",
                j.array, j.max, j.relative
            );
        }
    }
    if s.reoriented > 0 {
        let _ = writeln!(
            o,
            "  note        {} clockwise cells reordered counter-clockwise",
            s.reoriented
        );
    }
    if !s.interior_lines.is_empty() {
        let _ = writeln!(
            o,
            "  note        {} line cells lie on interior edges: {}",
            s.interior_lines.len(),
            crate::mesh::list_indices(&s.interior_lines)
        );
    }
    for (title, arrays) in [
        ("point data", &s.point_arrays),
        ("cell data", &s.cell_arrays),
    ] {
        for a in arrays.iter() {
            let names = if a.component_names.is_empty() {
                String::new()
            } else {
                format!(" ({})", a.component_names.join(","))
            };
            let bad = if a.nan + a.infinite > 0 {
                format!("  NaN {} Inf {}", a.nan, a.infinite)
            } else {
                String::new()
            };
            let _ = writeln!(
                o,
                "  {title:<11} \"{}\" {} x{}{names} {}{bad}",
                a.name,
                a.scalar,
                a.components,
                range(a)
            );
        }
    }
    for t in &s.tag_arrays {
        let vals = t
            .values
            .iter()
            .map(|v| {
                format!(
                    "{}: {} edges, length {:.6}",
                    v.value, v.line_cells, v.length
                )
            })
            .collect::<Vec<_>>()
            .join("; ");
        let _ = writeln!(o, "  tags        \"{}\" on line cells: {vals}", t.name);
    }
    o
}

/// The first array holding NaN or infinite values, as `(place, problem)`.
pub fn first_nonfinite(s: &Summary) -> Option<(String, String)> {
    let point = s.point_arrays.iter().map(|a| ("point", a));
    let cell = s.cell_arrays.iter().map(|a| ("cell", a));
    point
        .chain(cell)
        .find(|(_, a)| a.nan + a.infinite > 0)
        .map(|(kind, a)| {
            (
                format!("{kind} array \"{}\"", a.name),
                format!("{} NaN and {} infinite values", a.nan, a.infinite),
            )
        })
}
