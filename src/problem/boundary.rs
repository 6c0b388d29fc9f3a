//! Boundary conditions per edge (docs/design.md §2, §7): each boundary edge gets the condition
//! of the first `[[boundary]]` that selects it, or [`Condition::Free`], with the owning cell and
//! the local edge index that orients it.

use std::collections::BTreeMap;

use serde::Serialize;

use super::fields::{components, plural, quoted_names, short};
use crate::error::Result;
use crate::mesh::{Dataset, NONE, list_indices};
use crate::read::scene::{BoundaryKind, Scene, Selector};
use crate::read::vtu::DataArray;
use crate::topology::Topology;

// ---------------------------------------------------------------------------------------------
// Boundary conditions

/// The condition on one boundary edge; the index is into [`Scene::boundaries`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Condition {
    /// Selected by no `[[boundary]]`: traction-free, σn = 0 (docs/design.md §7).
    Free,
    /// u = u_D.
    Dirichlet(usize),
    /// σn = t.
    Neumann(usize),
    /// Signorini contact, with friction when the boundary has some.
    Contact(usize),
}

impl Condition {
    /// The `[[boundary]]` it comes from (`None` for [`Condition::Free`]).
    pub fn boundary(self) -> Option<usize> {
        match self {
            Condition::Free => None,
            Condition::Dirichlet(b) | Condition::Neumann(b) | Condition::Contact(b) => Some(b),
        }
    }
}

/// One boundary edge with its owning cell, orientation and condition.
#[derive(Clone, Debug, PartialEq)]
pub struct BoundaryEdge {
    /// Edge index in [`Topology::edges`].
    pub edge: u32,
    /// The one triangle holding the edge.
    pub cell: u32,
    /// Local edge index in `cell`: the edge runs from local vertex `local` to
    /// `(local + 1) % 3`, mid node `3 + local`. Triangles are counter-clockwise, so this is
    /// the counter-clockwise direction along ∂Ω and the outward normal n_Ω is on the right of
    /// the direction of travel: n_Ω = (Δy, −Δx)/|Δ| on a straight edge.
    pub local: u8,
    /// A line cell of the mesh on this edge ([`crate::mesh::Mesh::lines`] index, the first if
    /// there are several), or `NONE`.
    pub line: u32,
    pub condition: Condition,
}

/// What one `[[boundary]]` ended up governing.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct BoundarySummary {
    pub name: String,
    /// Edges with this boundary's condition (after overlaps were resolved).
    pub edges: usize,
    /// Sum of their chord (straight) lengths: exact for P1, a summary figure for curved P2
    /// edges, whose true length is integrated where it matters (the boundary terms).
    pub length: f64,
}

/// The boundary conditions of the mesh.
#[derive(Clone, Debug, PartialEq)]
pub struct Boundaries {
    /// One per boundary edge, in the order of [`Topology::boundary_edges`].
    pub edges: Vec<BoundaryEdge>,
    /// One per `[[boundary]]`, in file order.
    pub per_boundary: Vec<BoundarySummary>,
    /// Findings for the report (ignored interior line cells, overlaps, free edges).
    pub notes: Vec<String>,
}

impl Boundaries {
    /// The edges governed by `[[boundary]]` number `b`.
    pub fn edges_of(&self, b: usize) -> impl Iterator<Item = &BoundaryEdge> {
        self.edges
            .iter()
            .filter(move |e| e.condition.boundary() == Some(b))
    }
}

/// Gives every boundary edge its condition (docs/design.md §7).
///
/// - `tag = v` selects the edges of the line cells whose value in the tag array
///   ([`Scene::tag_array_name`], cell data on the line cells) is v. A tagged line cell on an
///   interior edge is ignored, with a note.
/// - `where = "expr"` selects a boundary edge when `expr(x, y, 0) > 0` at its midpoint: the
///   mid node of a quadratic mesh (which lies on the curved boundary), the chord midpoint of a
///   linear one. Testing the midpoint, not the end points, keeps a selector like `y > 0.999`
///   from picking up the side edges that merely end at a corner of the top.
/// - An edge selected by several boundaries gets the first in file order, with a note naming
///   both and how many edges they share; an edge selected by none is [`Condition::Free`].
///
/// A selector that selects nothing is an error naming the scene key: a tag array missing from
/// the file, a tag no line cell carries (or only interior ones), an expression true at no
/// boundary edge.
pub fn classify(data: &Dataset, topo: &Topology, scene: &Scene) -> Result<Boundaries> {
    let mesh = &data.mesh;
    let nb = topo.boundary_edges.len();
    let mut position = vec![NONE; topo.edges.len()];
    for (p, &e) in topo.boundary_edges.iter().enumerate() {
        position[e as usize] = p as u32;
    }
    let mut line_of = vec![NONE; nb];
    for (l, &e) in topo.line_edge.iter().enumerate() {
        if e != NONE && position[e as usize] != NONE {
            let p = position[e as usize] as usize;
            if line_of[p] == NONE {
                line_of[p] = l as u32;
            }
        }
    }
    let midpoints: Vec<[f64; 2]> = topo
        .boundary_edges
        .iter()
        .map(|&e| {
            let mid = topo.edge_mid[e as usize];
            if mid != NONE {
                mesh.points[mid as usize]
            } else {
                let [a, b] = topo.edges[e as usize];
                let (a, b) = (mesh.points[a as usize], mesh.points[b as usize]);
                [(a[0] + b[0]) / 2.0, (a[1] + b[1]) / 2.0]
            }
        })
        .collect();

    let mut notes = Vec::new();
    let mut owner: Vec<Option<usize>> = vec![None; nb];
    let mut overlaps: BTreeMap<(usize, usize), usize> = BTreeMap::new();
    for (b, boundary) in scene.boundaries.iter().enumerate() {
        let mut selected = vec![false; nb];
        match &boundary.selector {
            Selector::Tag(tag) => {
                let place = boundary.place("tag");
                let tags = tag_array(data, scene, &place)?;
                let lines: Vec<usize> = (0..tags.values.len())
                    .filter(|&l| tags.values[l] == *tag as f64)
                    .collect();
                if lines.is_empty() {
                    return Err(scene.error(
                        &place,
                        format!(
                            "no line cell of {} has tag {tag} in cell array \"{}\" (tags \
                             present: {})",
                            data.path.display(),
                            tags.name.escape_debug(),
                            tags_present(tags)
                        ),
                    ));
                }
                let mut interior = Vec::new();
                for &l in &lines {
                    // Topology refuses dangling lines; a `NONE` edge is treated as interior.
                    let e = topo.line_edge[l];
                    let p = if e == NONE {
                        NONE
                    } else {
                        position[e as usize]
                    };
                    if p == NONE {
                        interior.push(mesh.line_cell[l] as usize);
                    } else {
                        selected[p as usize] = true;
                    }
                }
                let cells = |ix: &[usize]| {
                    let word = if ix.len() == 1 { "cell" } else { "cells" };
                    format!("{word} {}", list_indices(ix))
                };
                if interior.len() == lines.len() {
                    let (what, lie) = match lines.len() {
                        1 => ("the line cell".to_string(), "lies on an interior edge"),
                        n => (format!("all {n} line cells"), "lie on interior edges"),
                    };
                    return Err(scene.error(
                        &place,
                        format!(
                            "{what} with tag {tag} in {} {lie}, not on the boundary ({})",
                            data.path.display(),
                            cells(&interior)
                        ),
                    ));
                }
                if !interior.is_empty() {
                    let lie = match interior.len() {
                        1 => "lies on an interior edge and is",
                        _ => "lie on interior edges and are",
                    };
                    notes.push(format!(
                        "{}: {} with tag {tag} {lie} ignored ({})",
                        boundary.label(),
                        plural(interior.len(), "line cell"),
                        cells(&interior)
                    ));
                }
            }
            Selector::Where(expr) => {
                for (p, x) in midpoints.iter().enumerate() {
                    selected[p] = expr.holds(x[0], x[1], 0.0);
                }
                if !selected.contains(&true) {
                    let [x0, y0, x1, y1] = mesh.bounding_box();
                    return Err(scene.error(
                        boundary.place("where"),
                        format!(
                            "\"{}\" holds at no boundary edge midpoint (the mesh spans x ∈ \
                             [{}, {}], y ∈ [{}, {}])",
                            expr.source().escape_debug(),
                            short(x0),
                            short(x1),
                            short(y0),
                            short(y1)
                        ),
                    ));
                }
            }
        }
        for (p, _) in selected.iter().enumerate().filter(|(_, s)| **s) {
            match owner[p] {
                None => owner[p] = Some(b),
                Some(first) => *overlaps.entry((first, b)).or_default() += 1,
            }
        }
    }
    for ((first, second), count) in overlaps {
        let first = scene.boundaries[first].label();
        notes.push(format!(
            "{first} and {} both select {}; {first} (first in file order) applies there",
            scene.boundaries[second].label(),
            plural(count, "edge")
        ));
    }

    let chord = |e: u32| {
        let [a, b] = topo.edges[e as usize];
        let (a, b) = (mesh.points[a as usize], mesh.points[b as usize]);
        (a[0] - b[0]).hypot(a[1] - b[1])
    };
    let mut per_boundary: Vec<BoundarySummary> = scene
        .boundaries
        .iter()
        .map(|b| BoundarySummary {
            name: b.name.clone(),
            edges: 0,
            length: 0.0,
        })
        .collect();
    let (mut free, mut free_length) = (0usize, 0.0f64);
    let mut edges = Vec::with_capacity(nb);
    for (p, &e) in topo.boundary_edges.iter().enumerate() {
        let cell = topo.edge_cells[e as usize][0];
        let local = topo.cell_edges[cell as usize]
            .iter()
            .position(|&k| k == e)
            .expect("a boundary edge is an edge of its cell") as u8;
        let condition = match owner[p] {
            None => {
                free += 1;
                free_length += chord(e);
                Condition::Free
            }
            Some(b) => {
                per_boundary[b].edges += 1;
                per_boundary[b].length += chord(e);
                match scene.boundaries[b].kind {
                    BoundaryKind::Dirichlet { .. } => Condition::Dirichlet(b),
                    BoundaryKind::Neumann { .. } => Condition::Neumann(b),
                    BoundaryKind::Contact(_) => Condition::Contact(b),
                }
            }
        };
        edges.push(BoundaryEdge {
            edge: e,
            cell,
            local,
            line: line_of[p],
            condition,
        });
    }
    if free > 0 {
        notes.push(format!(
            "{} (length {}) selected by no [[boundary]]: traction-free",
            plural(free, "boundary edge"),
            short(free_length)
        ));
    }
    Ok(Boundaries {
        edges,
        per_boundary,
        notes,
    })
}

/// The tag array on the line cells, or an error at `place` saying why it cannot be used.
fn tag_array<'a>(data: &'a Dataset, scene: &Scene, place: &str) -> Result<&'a DataArray> {
    let name = scene
        .tag_array_name()
        .expect("a tag selector implies a tag array name");
    let file = data.path.display();
    let Some(a) = data.line_data.iter().find(|a| a.name == name) else {
        let hint = if data.point_array(name).is_some() {
            " (it is a point array; tags are cell data on the line cells)".to_string()
        } else if data.mesh.lines.is_empty() {
            ", which has no line cells to carry tags; select edges with where = \"…\"".to_string()
        } else {
            let integer: Vec<&DataArray> = data
                .line_data
                .iter()
                .filter(|a| a.components == 1 && a.values.iter().all(|v| v.fract() == 0.0))
                .collect();
            format!(
                " (integer cell arrays: {}); name the tag array with [boundaries] tag_array = \
                 \"…\"",
                if integer.is_empty() {
                    "none".to_string()
                } else {
                    quoted_names(&integer)
                }
            )
        };
        return Err(scene.error(
            place,
            format!(
                "cell array \"{}\" is not in {file}{hint}",
                name.escape_debug()
            ),
        ));
    };
    if a.components != 1 {
        return Err(scene.error(
            place,
            format!(
                "cell array \"{}\" in {file} has {}; a tag array needs 1",
                name.escape_debug(),
                components(a.components)
            ),
        ));
    }
    Ok(a)
}

/// `1 (4 line cells), 2 (1 line cell)`, or `none`.
fn tags_present(a: &DataArray) -> String {
    let mut counts: BTreeMap<i64, usize> = BTreeMap::new();
    let mut other = 0;
    for &v in &a.values {
        if v.fract() == 0.0 {
            *counts.entry(v as i64).or_default() += 1;
        } else {
            other += 1;
        }
    }
    let mut parts: Vec<String> = counts
        .into_iter()
        .map(|(t, n)| format!("{t} ({})", plural(n, "line cell")))
        .collect();
    if other > 0 {
        parts.push(format!("{} not an integer", plural(other, "value")));
    }
    if parts.is_empty() {
        "none".to_string()
    } else {
        parts.join(", ")
    }
}
