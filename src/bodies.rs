//! Bodies: the connected components of the cells of a mesh (docs/design.md §4.2 "Bodies").
//!
//! Two cells are connected when they share a point (after the merge of node copies); a body is
//! a class of that relation. They are found once, in O(cells · nodes) with a union-find over
//! the points. Bodies are numbered by their first cell in the file. [`restrict`] cuts a
//! [`Dataset`] down to one body (cells, points, point and cell arrays, boundary lines) so that
//! every later stage sees a one-body mesh; [`choose`] decides which body a scene audits.

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::mesh::{Dataset, Mesh, NONE};
use crate::problem::boundary::{Boundaries, Condition};
use crate::read::scene::{BodySelector, Scene};
use crate::read::vtu::DataArray;

/// One body of the file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Body {
    pub index: usize,
    /// 2D cells.
    pub cells: usize,
    /// Mesh points its cells use.
    pub points: usize,
    /// `[xmin, ymin, xmax, ymax]` of those points.
    pub bounding_box: [f64; 4],
    /// File index of its first cell.
    pub first_cell: usize,
}

impl Body {
    /// `body 1 (250 cells, x ∈ [-0.255, 0.245], y ∈ [-0.1, 0])`: how messages name it.
    pub fn describe(&self) -> String {
        let [x0, y0, x1, y1] = self.bounding_box;
        format!(
            "body {} ({} {}, x ∈ [{}, {}], y ∈ [{}, {}])",
            self.index,
            self.cells,
            if self.cells == 1 { "cell" } else { "cells" },
            short(x0),
            short(x1),
            short(y0),
            short(y1)
        )
    }
}

/// A number in at most ~10 characters, for messages.
fn short(v: f64) -> String {
    let s = format!("{v}");
    if s.len() <= 10 { s } else { format!("{v:.5e}") }
}

/// The bodies of a mesh and the body of each cell.
#[derive(Clone, Debug)]
pub struct Bodies {
    /// Body index of each cell of the mesh.
    pub of_cell: Vec<u32>,
    pub list: Vec<Body>,
}

fn root(parent: &mut [u32], mut i: u32) -> u32 {
    while parent[i as usize] != i {
        let p = parent[i as usize];
        parent[i as usize] = parent[p as usize]; // path halving
        i = p;
    }
    i
}

/// The connected components of the cells of `mesh` (cells sharing a point are connected).
pub fn find(mesh: &Mesh) -> Bodies {
    let mut parent: Vec<u32> = (0..mesh.points.len() as u32).collect();
    for t in 0..mesh.len() {
        let n = mesh.nodes(t);
        let r0 = root(&mut parent, n[0]);
        for &p in &n[1..] {
            let r = root(&mut parent, p);
            if r != r0 {
                parent[r as usize] = r0;
            }
        }
    }
    // Number the roots by first cell.
    let mut id = vec![NONE; mesh.points.len()];
    let mut of_cell = Vec::with_capacity(mesh.len());
    let mut list: Vec<Body> = Vec::new();
    for t in 0..mesh.len() {
        let r = root(&mut parent, mesh.nodes(t)[0]) as usize;
        if id[r] == NONE {
            id[r] = list.len() as u32;
            list.push(Body {
                index: list.len(),
                cells: 0,
                points: 0,
                bounding_box: [
                    f64::INFINITY,
                    f64::INFINITY,
                    f64::NEG_INFINITY,
                    f64::NEG_INFINITY,
                ],
                first_cell: mesh.file_cell[t] as usize,
            });
        }
        of_cell.push(id[r]);
        list[id[r] as usize].cells += 1;
    }
    let mut seen = vec![false; mesh.points.len()];
    for t in 0..mesh.len() {
        let b = &mut list[of_cell[t] as usize];
        for &p in mesh.nodes(t) {
            if !std::mem::replace(&mut seen[p as usize], true) {
                let x = mesh.points[p as usize];
                b.points += 1;
                let bb = &mut b.bounding_box;
                bb[0] = bb[0].min(x[0]);
                bb[1] = bb[1].min(x[1]);
                bb[2] = bb[2].max(x[0]);
                bb[3] = bb[3].max(x[1]);
            }
        }
    }
    Bodies { of_cell, list }
}

impl Bodies {
    /// The body of each point used by a cell (`NONE` for unused points).
    fn of_point(&self, mesh: &Mesh) -> Vec<u32> {
        let mut b = vec![NONE; mesh.points.len()];
        for t in 0..mesh.len() {
            for &p in mesh.nodes(t) {
                b[p as usize] = self.of_cell[t];
            }
        }
        b
    }

    /// The bodies for messages: `body 0 (…); body 1 (…)`, at most [`LISTED`] of them.
    pub fn describe(&self) -> String {
        bounded_list(self.list.iter().map(Body::describe), "; ")
    }
}

/// How many items a message lists before "… and N more": an error stays one short line
/// whatever the file holds (a mutated exploded mesh can have hundreds of bodies).
pub const LISTED: usize = 4;

/// The first [`LISTED`] items joined by `sep`, then "… and N more" for the rest.
fn bounded_list(items: impl Iterator<Item = String>, sep: &str) -> String {
    let mut shown = Vec::new();
    let mut rest = 0usize;
    for item in items {
        if shown.len() < LISTED {
            shown.push(item);
        } else {
            rest += 1;
        }
    }
    let mut out = shown.join(sep);
    if rest > 0 {
        out.push_str(&format!("{sep}… and {rest} more"));
    }
    out
}

/// How the audited body was chosen, for the report.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Choice {
    /// Every body of the file.
    pub list: Vec<Body>,
    /// The index of the audited body.
    pub audited: usize,
    /// `only body`, `[body] index`, `[body] cell_data`, `[body] where` or `boundary conditions`.
    pub selected_by: String,
}

/// The body the scene audits (docs/design.md §4.2): the one selected by `[body]`; else the only
/// one; else the only body with Dirichlet or contact edges under the scene's boundaries
/// (`full`: the boundaries classified on the whole mesh). Every failure is one line naming the scene key.
pub fn choose(
    data: &Dataset,
    bodies: &Bodies,
    scene: &Scene,
    full: Option<&Boundaries>,
) -> Result<(usize, &'static str)> {
    let mesh = &data.mesh;
    let n = bodies.list.len();
    let holding = |hit: &dyn Fn(usize) -> bool, place: &str, what: String| -> Result<usize> {
        let mut found: Vec<usize> = Vec::new();
        for t in 0..mesh.len() {
            let b = bodies.of_cell[t] as usize;
            if hit(t) && !found.contains(&b) {
                found.push(b);
            }
        }
        found.sort_unstable();
        match found.as_slice() {
            [b] => Ok(*b),
            [] => Err(scene.error(
                place,
                format!(
                    "{what} at no cell of {} (bodies: {})",
                    data.path.display(),
                    bodies.describe()
                ),
            )),
            many => Err(scene.error(
                place,
                format!(
                    "{what} at cells of {} bodies ({}); a body selector must pick one body",
                    many.len(),
                    bounded_list(many.iter().map(|&b| bodies.list[b].describe()), "; ")
                ),
            )),
        }
    };
    match &scene.body {
        Some(BodySelector::Index(i)) => {
            if *i < n {
                Ok((*i, "[body] index"))
            } else {
                Err(scene.error(
                    "body.index",
                    format!(
                        "{} has {n} {} (index 0 to {}): {}",
                        data.path.display(),
                        if n == 1 { "body" } else { "bodies" },
                        n - 1,
                        bodies.describe()
                    ),
                ))
            }
        }
        Some(BodySelector::CellData { name, value }) => {
            let Some(a) = data.cell_data.iter().find(|a| &a.name == name) else {
                let names: Vec<String> = data
                    .cell_data
                    .iter()
                    .map(|a| format!("\"{}\"", a.name.escape_debug()))
                    .collect();
                return Err(scene.error(
                    "body.cell_data.name",
                    format!(
                        "{} has no cell array \"{}\" (cell arrays: {})",
                        data.path.display(),
                        name.escape_debug(),
                        if names.is_empty() {
                            "none".to_string()
                        } else {
                            names.join(", ")
                        }
                    ),
                ));
            };
            if a.components != 1 {
                return Err(scene.error(
                    "body.cell_data.name",
                    format!(
                        "cell array \"{}\" has {} components; a body is selected by a \
                         one-component array",
                        name.escape_debug(),
                        a.components
                    ),
                ));
            }
            let b = holding(
                &|t| a.values[t] == *value,
                "body.cell_data",
                format!("\"{}\" = {value} holds", name.escape_debug()),
            )?;
            Ok((b, "[body] cell_data"))
        }
        Some(BodySelector::Where(e)) => {
            let b = holding(
                &|t| {
                    let v = mesh.vertices(t);
                    let (mut x, mut y) = (0.0, 0.0);
                    for &p in v {
                        x += mesh.points[p as usize][0];
                        y += mesh.points[p as usize][1];
                    }
                    let k = v.len() as f64;
                    e.holds(x / k, y / k, 0.0)
                },
                "body.where",
                format!("\"{}\" holds", e.source().escape_debug()),
            )?;
            Ok((b, "[body] where"))
        }
        None if n == 1 => Ok((0, "only body")),
        None => {
            let supported = match full {
                Some(boundaries) => supported_bodies(bodies, boundaries),
                None => Vec::new(),
            };
            match supported.as_slice() {
                [b] => Ok((*b, "boundary conditions")),
                _ => Err(scene.error(
                    "body",
                    format!(
                        "{} holds {n} bodies ({}) and the scene's Dirichlet and contact \
                         boundaries {}; add a [body] table (index = N, cell_data = {{ name, \
                         value }} or where = \"…\") to choose one",
                        data.path.display(),
                        bodies.describe(),
                        if supported.is_empty() {
                            "touch none of them".to_string()
                        } else {
                            format!(
                                "touch {}",
                                bounded_list(
                                    supported.iter().map(|b| format!("body {b}")),
                                    " and "
                                )
                            )
                        }
                    ),
                )),
            }
        }
    }
}

/// The bodies (increasing) holding a Dirichlet or contact edge.
pub fn supported_bodies(bodies: &Bodies, boundaries: &Boundaries) -> Vec<usize> {
    let mut has = vec![false; bodies.list.len()];
    for e in &boundaries.edges {
        if matches!(e.condition, Condition::Dirichlet(_) | Condition::Contact(_)) {
            has[bodies.of_cell[e.cell as usize] as usize] = true;
        }
    }
    (0..has.len()).filter(|&b| has[b]).collect()
}

/// The dataset cut down to body `b`: its cells (in order), the points they use (in order,
/// renumbered), the point arrays on those points, the cell arrays on those cells and the line
/// cells whose nodes are all points of the body. File cell indices are kept.
pub fn restrict(data: &Dataset, bodies: &Bodies, b: usize) -> Dataset {
    let mesh = &data.mesh;
    let of_point = bodies.of_point(mesh);
    let mut new_index = vec![NONE; mesh.points.len()];
    let mut kept_points = Vec::new();
    for (p, &body) in of_point.iter().enumerate() {
        if body == b as u32 {
            new_index[p] = kept_points.len() as u32;
            kept_points.push(p);
        }
    }
    let cells: Vec<usize> = (0..mesh.len())
        .filter(|&t| bodies.of_cell[t] == b as u32)
        .collect();
    let lines: Vec<usize> = (0..mesh.lines.len())
        .filter(|&l| {
            mesh.lines[l]
                .iter()
                .all(|&n| n == NONE || new_index[n as usize] != NONE)
        })
        .collect();
    let renumber = |n: u32| {
        if n == NONE {
            NONE
        } else {
            new_index[n as usize]
        }
    };
    let sub = Mesh {
        points: kept_points.iter().map(|&p| mesh.points[p]).collect(),
        degree: mesh.degree,
        cells: cells.iter().map(|&t| mesh.cells[t].map(renumber)).collect(),
        family: cells.iter().map(|&t| mesh.family[t]).collect(),
        shape: cells.iter().map(|&t| mesh.shape[t]).collect(),
        lines: lines.iter().map(|&l| mesh.lines[l].map(renumber)).collect(),
        file_cell: cells.iter().map(|&t| mesh.file_cell[t]).collect(),
        line_cell: lines.iter().map(|&l| mesh.line_cell[l]).collect(),
    };
    let pick = |a: &DataArray, rows: &[usize]| a.rows(rows.iter().copied());
    let mut report = data.report.clone();
    report.curved_cells = sub
        .shape
        .iter()
        .filter(|&&s| s == crate::geometry::Shape::Curved)
        .count();
    report.bilinear_cells = sub
        .shape
        .iter()
        .filter(|&&s| s == crate::geometry::Shape::Bilinear)
        .count();
    Dataset {
        path: data.path.clone(),
        mesh: sub,
        point_data: data
            .point_data
            .iter()
            .map(|a| pick(a, &kept_points))
            .collect(),
        cell_data: data.cell_data.iter().map(|a| pick(a, &cells)).collect(),
        line_data: data.line_data.iter().map(|a| pick(a, &lines)).collect(),
        // The copies' node keys follow the points' renumbering.
        copies: data
            .copies
            .iter()
            .map(|a| {
                let mut a = pick(a, &cells);
                let slot = a.components / crate::geometry::MAX_NODES;
                for r in a.values.chunks_exact_mut(slot) {
                    if r[0] != f64::from(NONE) {
                        r[0] = f64::from(new_index[r[0] as usize]);
                    }
                }
                a
            })
            .collect(),
        report,
    }
}

/// Refuses a body that no Dirichlet or contact edge holds (rigid motions free), before any
/// solve (docs/design.md §4.2): one line naming it.
pub fn check_supported(
    data: &Dataset,
    body: &Body,
    scene: &Scene,
    boundaries: &Boundaries,
) -> Result<()> {
    let held = boundaries
        .edges
        .iter()
        .any(|e| matches!(e.condition, Condition::Dirichlet(_) | Condition::Contact(_)));
    if held {
        return Ok(());
    }
    Err(Error::input(
        &scene.file,
        "boundary",
        format!(
            "{} of {} is floating: no Dirichlet or contact boundary of the scene touches it, \
             so its rigid motions are free (add a [[boundary]] with kind = \"dirichlet\" or \
             \"contact\" on it)",
            body.describe(),
            data.path.display()
        ),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::read::vtu::VtuFile;

    /// Two unit squares of two triangles each, [0,1]² and [2,3]×[0,1], plus a lone triangle
    /// touching the second square at one corner (3, 1) — so two bodies.
    fn mesh() -> Dataset {
        let p = |x: f64, y: f64| [x, y, 0.0];
        let points = vec![
            p(0.0, 0.0),
            p(1.0, 0.0),
            p(1.0, 1.0),
            p(0.0, 1.0),
            p(2.0, 0.0),
            p(3.0, 0.0),
            p(3.0, 1.0),
            p(2.0, 1.0),
            p(4.0, 1.0),
            p(4.0, 2.0),
        ];
        let cells = vec![
            (5u8, vec![4, 5, 6]),
            (5, vec![0, 1, 2]),
            (5, vec![4, 6, 7]),
            (5, vec![0, 2, 3]),
            (5, vec![6, 8, 9]),
            (3, vec![0, 1]),
            (3, vec![4, 5]),
        ];
        let file = VtuFile::from_cells(std::path::Path::new("two.vtu"), points, &cells);
        crate::mesh::build(file).unwrap()
    }

    #[test]
    fn components_by_shared_points() {
        let d = mesh();
        let b = find(&d.mesh);
        // Body 0 holds file cell 0 (the right square and the triangle at its corner).
        assert_eq!(b.of_cell, vec![0, 1, 0, 1, 0]);
        assert_eq!(b.list.len(), 2);
        assert_eq!((b.list[0].cells, b.list[0].points), (3, 6));
        assert_eq!((b.list[1].cells, b.list[1].points), (2, 4));
        assert_eq!(b.list[0].bounding_box, [2.0, 0.0, 4.0, 2.0]);
        assert_eq!(b.list[1].bounding_box, [0.0, 0.0, 1.0, 1.0]);
        assert_eq!((b.list[0].first_cell, b.list[1].first_cell), (0, 1));
        assert_eq!(
            b.list[1].describe(),
            "body 1 (2 cells, x ∈ [0, 1], y ∈ [0, 1])"
        );
    }

    #[test]
    fn restriction_keeps_the_body_and_its_lines() {
        let d = mesh();
        let b = find(&d.mesh);
        let r = restrict(&d, &b, 1);
        assert_eq!(
            r.mesh.points,
            vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]
        );
        assert_eq!(r.mesh.file_cell, vec![1, 3]);
        assert_eq!(r.mesh.cells[1][..3], [0, 2, 3]);
        assert_eq!(r.mesh.lines, vec![[0, 1, NONE]]);
        assert_eq!(r.mesh.line_cell, vec![5]);
        let r0 = restrict(&d, &b, 0);
        assert_eq!(r0.mesh.len(), 3);
        assert_eq!(r0.mesh.points.len(), 6);
        assert_eq!(r0.mesh.line_cell, vec![6]);
        assert_eq!(find(&r0.mesh).list.len(), 1);
    }
}
