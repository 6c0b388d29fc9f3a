//! From the file and the scene to the problem the estimator works on: the discrete fields u_h
//! and σ_h (docs/design.md §4) and the boundary condition of every boundary edge (docs/design.md §2, §7).
//!
//! [`select_fields`] finds the displacement and the stress among the arrays of the solution
//! file, decides the stress layout and stores every tensor as a full 2×2 row-major
//! `[σxx, σxy, σyx, σyy]`. [`classify`] gives each boundary edge of the mesh the condition of
//! the first `[[boundary]]` that selects it, or [`Condition::Free`] (traction-free, docs/design.md
//! §7), together with the owning cell and the local edge index that orients it.
//!
//! Every refusal is one [`Error::Input`] line naming the file it is about: the solution file
//! for what its arrays hold, the scene file for what a scene key asks and the file cannot give.
//! Findings that are not errors (a dropped z component, a non-symmetric stress, a tagged line
//! cell on an interior edge, overlapping selectors) are returned as `notes` for the report.

use std::collections::BTreeMap;
use std::fmt;

use serde::Serialize;

use crate::error::{Error, Result};
use crate::mesh::{Dataset, NONE, list_indices};
use crate::read::scene::{BoundaryKind, Component, Scene, Selector, StressLayout};
use crate::read::vtu::DataArray;
use crate::topology::Topology;

// ---------------------------------------------------------------------------------------------
// Fields

/// Point-array names (compared case-insensitively) taken for the displacement when
/// `[fields] displacement` is not given.
pub const DISPLACEMENT_NAMES: [&str; 4] = ["displacement", "displacements", "disp", "u"];

/// Point- or cell-array names (compared case-insensitively) taken for the stress when
/// `[fields] stress` is not given.
pub const STRESS_NAMES: [&str; 5] = ["stress", "stresses", "sigma", "s", "cauchy_stress"];

/// Relative tolerance (of the array's largest magnitude) under which two stress components are
/// taken as equal at a point, for the ambiguity test of 4-component arrays.
pub const EQUAL_COMPONENTS: f64 = 1e-12;

/// The discrete fields read from the solution file (docs/design.md §4).
#[derive(Clone, Debug, PartialEq)]
pub struct Fields {
    /// u_h at each mesh point (P1 or P2 nodes, [`crate::mesh::Mesh::points`] order); a z
    /// component in the file is dropped. `None` when the file holds none but a nodal stress
    /// (a pure stress method): the displacement is then reconstructed (docs/design.md §4, §5).
    pub displacement: Option<Vec<[f64; 2]>>,
    /// The point array it was read from.
    pub displacement_name: Option<String>,
    pub stress: Stress,
    /// Findings for the report (dropped components, asymmetry, how the layout was chosen).
    pub notes: Vec<String>,
}

/// The stress σ_h of the file, each tensor as a full 2×2 row-major `[σxx, σxy, σyx, σyy]`.
///
/// Symmetric layouts fill σyx = σxy; layouts that store both (9 components, a 2×2 `xx,xy,yx,yy`)
/// keep them apart, so that a non-symmetric stress is audited as it is. σzz and out-of-plane
/// shear are not kept: the functional of docs/design.md §3 is two-dimensional.
#[derive(Clone, Debug, PartialEq)]
pub enum Stress {
    /// One tensor per mesh point: a continuous P1/P2 nodal stress.
    Nodal {
        values: Vec<[f64; 4]>,
        /// The point array.
        name: String,
        /// The layout used, e.g. `xx,yy,zz,xy`.
        layout: String,
    },
    /// One tensor per triangle ([`crate::mesh::Mesh::triangles`] order): piecewise constant,
    /// not H(div)-conforming (docs/design.md §4: reconstruct).
    Cell {
        values: Vec<[f64; 4]>,
        /// The cell array.
        name: String,
        /// The layout used, e.g. `xx,yy,zz,xy`.
        layout: String,
    },
    /// No stress in the file (docs/design.md §4: reconstruct).
    Absent,
}

/// Whether an array is point data or cell data, for messages.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    Point,
    Cell,
}

/// `point array "u"` / `cell array "s"`: how messages name an array (as the VTU reader does).
struct Place<'a>(Kind, &'a str);

impl fmt::Display for Place<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let kind = match self.0 {
            Kind::Point => "point",
            Kind::Cell => "cell",
        };
        write!(f, "{kind} array \"{}\"", self.1.escape_debug())
    }
}

/// Selects and converts the displacement and the stress of the solution file.
///
/// **Displacement** (required unless the stress is nodal): the point array
/// `[fields] displacement`, else the one point array named like [`DISPLACEMENT_NAMES`] with 2
/// or 3 components; none found and a nodal stress present gives `None`. A third (z) component is
/// dropped, with a note giving max |u_z| when it is not zero everywhere: fosls audits the
/// plane problem (docs/design.md §2).
///
/// **Stress** (optional): the point or cell array `[fields] stress`, else the one point array
/// named like [`STRESS_NAMES`], else the one such cell array, else [`Stress::Absent`]. Cell
/// arrays are read on the triangles only. The layout (docs/design.md §4) is, in this order:
///
/// 1. `[fields] stress_layout`, whose length must be the component count;
/// 2. the `ComponentName` attributes, when every component has one and all are recognised:
///    case is ignored, characters other than letters and digits are dropped, and the last two
///    characters are read as the component, either two axes (`xx`, `XY`, `sigma_xx`, `Sxy`,
///    `s_yy`, `SIXY`) or two indices (`0_0`, `[0][1]`, `s01`: 0-based; `S11`, `S12`, `S33`:
///    1-based, assumed when no index is 0). Recognised names that do not form a layout (a
///    component twice, no yy, …) are an error; unrecognised names fall back to the count, with
///    a note;
/// 3. the component count: 3 → `xx,yy,xy`; 6 → `xx,yy,zz,xy,yz,xz` (VTK's symmetric order);
///    9 → row-major 3×3; 4 → `xx,yy,zz,xy` (meshio/scikit-fem, NGSolve), refused as ambiguous
///    when the array could just as well be a row-major 2×2 `xx,xy,yx,yy`: when components 2
///    and 3 (1-based) agree at every tuple to [`EQUAL_COMPONENTS`] times the array's largest
///    magnitude — unless components 2, 3 and 4 all agree, when both readings give the same
///    in-plane tensor.
///
/// Non-finite values in either array are refused (naming the first bad point or cell). A layout
/// with both σxy and σyx gets a note with max |σxy − σyx| / max |σ|, and one with out-of-plane
/// shear (xz, yz, …) a note when that shear is not zero.
pub fn select_fields(data: &Dataset, scene: &Scene) -> Result<Fields> {
    let mut notes = Vec::new();
    let array = displacement_array(data, scene)?;
    let stress = select_stress(data, scene, &mut notes)?;
    let Some(array) = array else {
        // A pure stress method's output: the displacement is rebuilt from the stress.
        if matches!(stress, Stress::Nodal { .. }) {
            return Ok(Fields {
                displacement: None,
                displacement_name: None,
                stress,
                notes,
            });
        }
        return Err(no_displacement(data, scene));
    };
    check_finite(data, array, Kind::Point)?;
    let c = array.components;
    let displacement: Vec<[f64; 2]> = array.values.chunks_exact(c).map(|v| [v[0], v[1]]).collect();
    if c == 3 {
        let max_z = array
            .values
            .chunks_exact(3)
            .fold(0.0f64, |m, v| m.max(v[2].abs()));
        if max_z > 0.0 {
            notes.push(format!(
                "displacement \"{}\" has 3 components: the z component is dropped (max |u_z| = \
                 {})",
                array.name.escape_debug(),
                short(max_z)
            ));
        }
    }
    Ok(Fields {
        displacement: Some(displacement),
        displacement_name: Some(array.name.clone()),
        stress,
        notes,
    })
}

/// The error for a file without a displacement and without a nodal stress to rebuild it from.
fn no_displacement(data: &Dataset, scene: &Scene) -> Error {
    Error::input(
        &data.path,
        "PointData",
        format!(
            "no displacement found (a point array named displacement, displacements, disp or u \
             with 2 or 3 components; point arrays: {}); set [fields] displacement = \"…\" in {}",
            list_arrays(&data.point_data),
            scene.file.display()
        ),
    )
}

/// The displacement's point array: named in the scene, or the one auto-detected candidate.
fn displacement_array<'a>(data: &'a Dataset, scene: &Scene) -> Result<Option<&'a DataArray>> {
    let scene_file = scene.file.display();
    let file = data.path.display();
    if let Some(name) = &scene.fields.displacement {
        let place = "fields.displacement";
        let Some(a) = data.point_array(name) else {
            let cell = if data.cell_data.iter().any(|a| &a.name == name) {
                " (it is a cell array; the displacement must be point data)"
            } else {
                ""
            };
            return Err(scene.error(
                place,
                format!(
                    "no point array \"{}\" in {file}{cell} (point arrays: {})",
                    name.escape_debug(),
                    list_arrays(&data.point_data)
                ),
            ));
        };
        if !(a.components == 2 || a.components == 3) {
            return Err(scene.error(
                place,
                format!(
                    "point array \"{}\" in {file} has {}; a displacement needs 2 or 3 (point \
                     arrays: {})",
                    name.escape_debug(),
                    components(a.components),
                    list_arrays(&data.point_data)
                ),
            ));
        }
        return Ok(Some(a));
    }
    let candidates: Vec<&DataArray> = data
        .point_data
        .iter()
        .filter(|a| named_like(a, &DISPLACEMENT_NAMES) && (a.components == 2 || a.components == 3))
        .collect();
    match candidates[..] {
        [a] => Ok(Some(a)),
        [] => Ok(None),
        _ => Err(Error::input(
            &data.path,
            "PointData",
            format!(
                "several displacement candidates ({}); set [fields] displacement = \"…\" in \
                 {scene_file} (point arrays: {})",
                quoted_names(&candidates),
                list_arrays(&data.point_data)
            ),
        )),
    }
}

/// The stress: chosen array, checked, layout decided, converted.
fn select_stress(data: &Dataset, scene: &Scene, notes: &mut Vec<String>) -> Result<Stress> {
    let scene_file = scene.file.display();
    let find = |arrays: &'_ [DataArray], name: &str| -> Option<usize> {
        arrays.iter().position(|a| a.name == name)
    };
    let (array, kind) = if let Some(name) = &scene.fields.stress {
        match (find(&data.point_data, name), find(&data.cell_data, name)) {
            (Some(p), c) => {
                if c.is_some() {
                    notes.push(format!(
                        "stress: the file has a point and a cell array \"{}\"; the point array \
                         is used",
                        name.escape_debug()
                    ));
                }
                (&data.point_data[p], Kind::Point)
            }
            (None, Some(c)) => (&data.cell_data[c], Kind::Cell),
            (None, None) => {
                return Err(scene.error(
                    "fields.stress",
                    format!(
                        "no point or cell array \"{}\" in {} (point arrays: {}; cell arrays: {})",
                        name.escape_debug(),
                        data.path.display(),
                        list_arrays(&data.point_data),
                        list_arrays(&data.cell_data)
                    ),
                ));
            }
        }
    } else {
        let points: Vec<&DataArray> = data
            .point_data
            .iter()
            .filter(|a| named_like(a, &STRESS_NAMES))
            .collect();
        let cells: Vec<&DataArray> = data
            .cell_data
            .iter()
            .filter(|a| named_like(a, &STRESS_NAMES))
            .collect();
        let several = |section: &str, found: &[&DataArray]| {
            Error::input(
                &data.path,
                section,
                format!(
                    "several stress candidates ({}); set [fields] stress = \"…\" in {scene_file}",
                    quoted_names(found)
                ),
            )
        };
        match (&points[..], &cells[..]) {
            ([a], _) => {
                if !cells.is_empty() {
                    notes.push(format!(
                        "stress: point array \"{}\" is preferred over cell data ({})",
                        a.name.escape_debug(),
                        quoted_names(&cells)
                    ));
                }
                (*a, Kind::Point)
            }
            ([_, _, ..], _) => return Err(several("PointData", &points)),
            ([], [a]) => (*a, Kind::Cell),
            ([], [_, _, ..]) => return Err(several("CellData", &cells)),
            ([], []) => return Ok(Stress::Absent),
        }
    };
    check_finite(data, array, kind)?;
    let (layout, how) = stress_layout(data, scene, array, kind)?;
    if let Some(how) = how {
        notes.push(how);
    }
    let n = layout.len();
    let (xx, xy, yx, yy) = (layout.xx(), layout.xy(), layout.yx(), layout.yy());
    let values: Vec<[f64; 4]> = array
        .values
        .chunks_exact(n)
        .map(|v| [v[xx], v[xy], v[yx], v[yy]])
        .collect();
    let name = array.name.escape_debug().to_string();
    let max_abs = values.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
    let relative = |m: f64| if max_abs > 0.0 { m / max_abs } else { 0.0 };
    if layout.has_yx() {
        let asym = values
            .iter()
            .fold(0.0f64, |m, s| m.max((s[1] - s[2]).abs()));
        notes.push(format!(
            "stress \"{name}\" stores σxy and σyx separately: max |σxy − σyx| / max |σ| = {:.3e}",
            relative(asym)
        ));
    }
    let out_of_plane: Vec<usize> = layout
        .components()
        .iter()
        .enumerate()
        .filter(|(_, c)| {
            matches!(
                c,
                Component::Xz | Component::Zx | Component::Yz | Component::Zy
            )
        })
        .map(|(k, _)| k)
        .collect();
    if !out_of_plane.is_empty() {
        let shear = array
            .values
            .chunks_exact(n)
            .flat_map(|v| out_of_plane.iter().map(move |&k| v[k].abs()))
            .fold(0.0f64, f64::max);
        if shear > 0.0 {
            let names: Vec<&str> = out_of_plane
                .iter()
                .map(|&k| layout.components()[k].as_str())
                .collect();
            notes.push(format!(
                "stress \"{name}\": out-of-plane shear ({}) is not zero (max {}, {:.3e} of max \
                 |σ|); the in-plane part is used",
                names.join(", "),
                short(shear),
                relative(shear)
            ));
        }
    }
    let layout = layout.to_string();
    let name = array.name.clone();
    Ok(match kind {
        Kind::Point => Stress::Nodal {
            values,
            name,
            layout,
        },
        Kind::Cell => Stress::Cell {
            values,
            name,
            layout,
        },
    })
}

/// The layout of a stress array and, when worth reporting, how it was chosen.
fn stress_layout(
    data: &Dataset,
    scene: &Scene,
    a: &DataArray,
    kind: Kind,
) -> Result<(StressLayout, Option<String>)> {
    let scene_file = scene.file.display();
    let place = Place(kind, &a.name);
    let c = a.components;
    if let Some(layout) = &scene.fields.stress_layout {
        if layout.len() != c {
            return Err(scene.error(
                "fields.stress_layout",
                format!(
                    "lists {} but {place} in {} has {}",
                    components(layout.len()),
                    data.path.display(),
                    components(c)
                ),
            ));
        }
        return Ok((layout.clone(), None));
    }
    let mut note = None;
    if a.component_names.len() == c && a.component_names.iter().all(|n| !n.is_empty()) {
        match layout_from_names(&a.component_names) {
            Some(Ok(layout)) => return Ok((layout, None)),
            Some(Err(problem)) => {
                return Err(Error::input(
                    &data.path,
                    place,
                    format!(
                        "ComponentName attributes ({}) do not form a stress layout: {problem}; \
                         give [fields] stress_layout = \"…\" in {scene_file}",
                        listed_names(&a.component_names)
                    ),
                ));
            }
            None => {
                note = Some(format!(
                    "stress \"{}\": ComponentName attributes ({}) not recognised as tensor \
                     components; layout inferred from the component count",
                    a.name.escape_debug(),
                    listed_names(&a.component_names)
                ));
            }
        }
    }
    let Some(layout) = StressLayout::for_component_count(c) else {
        return Err(Error::input(
            &data.path,
            place,
            format!(
                "has {} but a stress needs 3 (xx,yy,xy), 4 (xx,yy,zz,xy), 6 \
                 (xx,yy,zz,xy,yz,xz) or 9 (row-major); or give [fields] stress_layout = \"…\" in \
                 {scene_file}",
                components(c)
            ),
        ));
    };
    if c == 4 {
        let max = a.values.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let tol = EQUAL_COMPONENTS * max;
        let agree =
            |i: usize, j: usize| a.values.chunks_exact(4).all(|v| (v[i] - v[j]).abs() <= tol);
        if agree(1, 2) && !agree(1, 3) {
            return Err(Error::input(
                &data.path,
                place,
                format!(
                    "4 components are ambiguous: xx,yy,zz,xy, or a row-major 2×2 xx,xy,yx,yy \
                     (components 2 and 3 are equal everywhere); give [fields] stress_layout = \
                     \"…\" in {scene_file}"
                ),
            ));
        }
    }
    Ok((layout, note))
}

/// The layout named by `ComponentName` attributes (see [`select_fields`]): `None` when some
/// name is not recognised, `Some(Err)` when the names are recognised but form no layout.
fn layout_from_names(names: &[String]) -> Option<std::result::Result<StressLayout, String>> {
    let tails: Vec<[char; 2]> = names
        .iter()
        .map(|n| {
            let s: Vec<char> = n
                .chars()
                .filter(|c| c.is_alphanumeric())
                .flat_map(|c| c.to_lowercase())
                .collect();
            let t = [*s.get(s.len().checked_sub(2)?)?, *s.last()?];
            let axes = t.iter().all(|c| matches!(c, 'x' | 'y' | 'z'));
            let digits = t.iter().all(|c| matches!(c, '0'..='3'));
            (axes || digits).then_some(t)
        })
        .collect::<Option<_>>()?;
    let digits = || {
        tails
            .iter()
            .flatten()
            .copied()
            .filter(|c| c.is_ascii_digit())
    };
    let one_based = !digits().any(|c| c == '0');
    if !one_based && digits().any(|c| c == '3') {
        return None;
    }
    let axis = |c: char| match c {
        'x' | 'y' | 'z' => Some(c),
        _ => {
            let i = c.to_digit(10)? as usize - usize::from(one_based);
            ['x', 'y', 'z'].get(i).copied()
        }
    };
    let text = tails
        .iter()
        .map(|t| Some(format!("{}{}", axis(t[0])?, axis(t[1])?)))
        .collect::<Option<Vec<_>>>()?
        .join(",");
    Some(StressLayout::parse(&text))
}

/// `xx, yy, xy`: attribute values for a one-line message.
fn listed_names(names: &[String]) -> String {
    names
        .iter()
        .map(|n| n.escape_debug().to_string())
        .collect::<Vec<_>>()
        .join(", ")
}

/// Refuses NaN and ±∞, naming the array and the first bad point (mesh index and coordinates)
/// or cell (index in the file).
fn check_finite(data: &Dataset, a: &DataArray, kind: Kind) -> Result<()> {
    let Some(i) = a.values.iter().position(|v| !v.is_finite()) else {
        return Ok(());
    };
    let tuple = i / a.components.max(1);
    let at = match kind {
        Kind::Point => {
            let p = data.mesh.points[tuple];
            format!("point {tuple} (x = {}, y = {})", short(p[0]), short(p[1]))
        }
        Kind::Cell => format!("cell {}", data.mesh.file_cell[tuple]),
    };
    Err(Error::input(
        &data.path,
        Place(kind, &a.name),
        format!("non-finite value {} at {at}", a.values[i]),
    ))
}

fn named_like(a: &DataArray, names: &[&str]) -> bool {
    names.iter().any(|n| a.name.eq_ignore_ascii_case(n))
}

/// `3 components` / `1 component`.
fn components(n: usize) -> String {
    plural(n, "component")
}

fn plural(n: usize, what: &str) -> String {
    if n == 1 {
        format!("1 {what}")
    } else {
        format!("{n} {what}s")
    }
}

/// `"u" (3 components), "T" (1 component)`, or `none`.
fn list_arrays(arrays: &[DataArray]) -> String {
    if arrays.is_empty() {
        return "none".to_string();
    }
    arrays
        .iter()
        .map(|a| {
            format!(
                "\"{}\" ({})",
                a.name.escape_debug(),
                components(a.components)
            )
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// `"u", "disp"`.
fn quoted_names(arrays: &[&DataArray]) -> String {
    arrays
        .iter()
        .map(|a| format!("\"{}\"", a.name.escape_debug()))
        .collect::<Vec<_>>()
        .join(", ")
}

/// A number for a message: as written when short, else with 6 significant digits.
fn short(v: f64) -> String {
    let s = format!("{v}");
    if s.len() <= 10 { s } else { format!("{v:.5e}") }
}

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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh;
    use crate::read::decode::Scalar;
    use crate::read::scene::parse_scene;
    use crate::read::vtu::VtuFile;
    use crate::topology;
    use std::path::Path;

    // The unit square on a 3×3 grid of points (i/2, j/2), point i + 3j, split into 8
    // counter-clockwise triangles (file cells 0..8), followed by line cells on the boundary.
    const TRIANGLES: usize = 8;

    /// Boundary line cells with their tags: bottom 1, right 2, top 3, left 4.
    const SIDES: [(u32, u32, f64); 8] = [
        (0, 1, 1.),
        (1, 2, 1.),
        (2, 5, 2.),
        (5, 8, 2.),
        (8, 7, 3.),
        (7, 6, 3.),
        (6, 3, 4.),
        (3, 0, 4.),
    ];

    fn grid_points() -> Vec<[f64; 3]> {
        (0..9)
            .map(|k| [(k % 3) as f64 / 2.0, (k / 3) as f64 / 2.0, 0.0])
            .collect()
    }

    fn grid_triangles(clockwise: bool) -> Vec<(u8, Vec<u32>)> {
        let mut cells = Vec::new();
        for j in 0..2u32 {
            for i in 0..2u32 {
                let a = i + 3 * j;
                let (b, c, d) = (a + 1, a + 4, a + 3);
                for t in [[a, b, c], [a, c, d]] {
                    let t = if clockwise { [t[0], t[2], t[1]] } else { t };
                    cells.push((5u8, t.to_vec()));
                }
            }
        }
        cells
    }

    /// The square with the given line cells and their tags in the cell array "boundary_tag"
    /// (0 on the triangles).
    fn square_with(lines: &[(u32, u32, f64)], clockwise: bool) -> VtuFile {
        let mut cells = grid_triangles(clockwise);
        cells.extend(lines.iter().map(|&(a, b, _)| (3u8, vec![a, b])));
        let mut f = VtuFile::from_cells(Path::new("m.vtu"), grid_points(), &cells);
        let mut tags = vec![0.0; TRIANGLES];
        tags.extend(lines.iter().map(|l| l.2));
        f.cell_data.push(array("boundary_tag", 1, tags));
        f
    }

    fn square() -> VtuFile {
        square_with(&SIDES, false)
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

    /// A point array on the 9 points with the same tuple everywhere.
    fn uniform(name: &str, tuple: &[f64]) -> DataArray {
        array(name, tuple.len(), tuple.repeat(9))
    }

    /// A cell array on the 16 cells of `square()` with the same tuple everywhere.
    fn uniform_cells(name: &str, tuple: &[f64]) -> DataArray {
        array(name, tuple.len(), tuple.repeat(TRIANGLES + SIDES.len()))
    }

    fn named(mut a: DataArray, names: &[&str]) -> DataArray {
        a.component_names = names.iter().map(|s| s.to_string()).collect();
        a
    }

    fn build(f: VtuFile) -> (Dataset, Topology) {
        let d = mesh::build(f).unwrap_or_else(|e| panic!("{e}"));
        let t = topology::build(&d).unwrap_or_else(|e| panic!("{e}"));
        (d, t)
    }

    const MATERIAL: &str = "[material]\nyoungs_modulus = 1.0\npoisson_ratio = 0.3\n";

    fn scene(extra: &str) -> Scene {
        parse_scene(Path::new("scene.toml"), &format!("{MATERIAL}{extra}"))
            .unwrap_or_else(|e| panic!("{e}"))
    }

    fn fields(f: VtuFile, extra: &str) -> Result<Fields> {
        let (d, _) = build(f);
        select_fields(&d, &scene(extra))
    }

    /// The one-line message of a refusal.
    fn message<T: fmt::Debug>(r: Result<T>) -> String {
        let m = r.expect_err("should be refused").to_string();
        assert!(!m.contains('\n'), "not one line: {m}");
        m
    }

    /// The square with point arrays `u` (a valid displacement) and `extra`.
    fn with_points(extra: Vec<DataArray>) -> VtuFile {
        let mut f = square();
        f.point_data.push(uniform("u", &[0.0, 0.0]));
        f.point_data.extend(extra);
        f
    }

    fn nodal(fields: &Fields) -> (&[[f64; 4]], &str) {
        match &fields.stress {
            Stress::Nodal { values, layout, .. } => (values, layout),
            other => panic!("not nodal: {other:?}"),
        }
    }

    // -----------------------------------------------------------------------------------------
    // Displacement

    #[test]
    fn displacement_is_auto_detected_and_a_zero_z_dropped_silently() {
        let mut f = square();
        f.point_data.push(uniform("T", &[7.0]));
        let values: Vec<f64> = (0..9).flat_map(|k| [k as f64, -(k as f64), 0.0]).collect();
        f.point_data.push(array("Displacement", 3, values));
        let r = fields(f, "").unwrap();
        assert_eq!(r.displacement_name.as_deref(), Some("Displacement"));
        assert_eq!(r.displacement.as_ref().unwrap().len(), 9);
        assert_eq!(r.displacement.as_ref().unwrap()[4], [4.0, -4.0]);
        assert_eq!(r.stress, Stress::Absent);
        assert!(r.notes.is_empty(), "{:?}", r.notes);
    }

    #[test]
    fn non_zero_z_is_dropped_with_a_note() {
        let mut values = [1.0, 2.0, 0.0].repeat(9);
        values[3 * 4 + 2] = -0.001;
        let r = fields(
            with_points(vec![]).tap(|f| f.point_data[0] = array("disp", 3, values)),
            "",
        )
        .unwrap();
        assert_eq!(r.displacement, Some(vec![[1.0, 2.0]; 9]));
        assert_eq!(
            r.notes,
            vec![
                "displacement \"disp\" has 3 components: the z component is dropped \
                 (max |u_z| = 0.001)"
            ]
        );
    }

    /// `tap` for building a value in an expression.
    trait Tap: Sized {
        fn tap(mut self, f: impl FnOnce(&mut Self)) -> Self {
            f(&mut self);
            self
        }
    }
    impl Tap for VtuFile {}

    #[test]
    fn displacement_named_in_the_scene_wins() {
        let f = with_points(vec![uniform("w", &[3.0, 4.0])]);
        let r = fields(f, "[fields]\ndisplacement = \"w\"\n").unwrap();
        assert_eq!(r.displacement_name.as_deref(), Some("w"));
        assert_eq!(r.displacement.as_ref().unwrap()[0], [3.0, 4.0]);
    }

    #[test]
    fn displacement_errors() {
        let base = || {
            with_points(vec![uniform("T", &[1.0])])
                .tap(|f| f.cell_data.push(uniform_cells("c", &[0.0, 0.0])))
        };
        assert_eq!(
            message(fields(base(), "[fields]\ndisplacement = \"q\"\n")),
            "scene.toml: fields.displacement: no point array \"q\" in m.vtu (point arrays: \
             \"u\" (2 components), \"T\" (1 component))"
        );
        assert_eq!(
            message(fields(base(), "[fields]\ndisplacement = \"c\"\n")),
            "scene.toml: fields.displacement: no point array \"c\" in m.vtu (it is a cell \
             array; the displacement must be point data) (point arrays: \"u\" (2 components), \
             \"T\" (1 component))"
        );
        assert_eq!(
            message(fields(base(), "[fields]\ndisplacement = \"T\"\n")),
            "scene.toml: fields.displacement: point array \"T\" in m.vtu has 1 component; a \
             displacement needs 2 or 3 (point arrays: \"u\" (2 components), \"T\" (1 \
             component))"
        );
        // None: `u` is a scalar here, so it is no candidate.
        let mut none = square();
        none.point_data.push(uniform("u", &[1.0]));
        assert_eq!(
            message(fields(none, "")),
            "m.vtu: PointData: no displacement found (a point array named displacement, \
             displacements, disp or u with 2 or 3 components; point arrays: \"u\" (1 \
             component)); set [fields] displacement = \"…\" in scene.toml"
        );
        assert_eq!(
            message(fields(square(), "")),
            "m.vtu: PointData: no displacement found (a point array named displacement, \
             displacements, disp or u with 2 or 3 components; point arrays: none); set [fields] \
             displacement = \"…\" in scene.toml"
        );
        // A nodal stress and no displacement (a pure stress method): the displacement is left
        // to the reconstruction; a cell stress cannot stand in (the error above).
        let mut stress_only = square();
        stress_only
            .point_data
            .push(uniform("stress", &[1.0, 2.0, 3.0]));
        let r = fields(stress_only, "").unwrap();
        assert!(r.displacement.is_none() && r.displacement_name.is_none());
        assert!(matches!(r.stress, Stress::Nodal { .. }));
        let several = with_points(vec![uniform("DISP", &[0.0, 0.0, 0.0])]);
        assert_eq!(
            message(fields(several, "")),
            "m.vtu: PointData: several displacement candidates (\"u\", \"DISP\"); set [fields] \
             displacement = \"…\" in scene.toml (point arrays: \"u\" (2 components), \"DISP\" \
             (3 components))"
        );
        let mut nan = with_points(vec![]);
        nan.point_data[0].values[2 * 4 + 1] = f64::NAN;
        assert_eq!(
            message(fields(nan, "")),
            "m.vtu: point array \"u\": non-finite value NaN at point 4 (x = 0.5, y = 0.5)"
        );
    }

    // -----------------------------------------------------------------------------------------
    // Stress

    #[test]
    fn three_components_are_xx_yy_xy() {
        let r = fields(with_points(vec![uniform("stress", &[1.0, 2.0, 3.0])]), "").unwrap();
        let (values, layout) = nodal(&r);
        assert_eq!(layout, "xx,yy,xy");
        assert_eq!(values, vec![[1.0, 3.0, 3.0, 2.0]; 9]);
        assert!(r.notes.is_empty(), "{:?}", r.notes);
    }

    #[test]
    fn four_components_are_xx_yy_zz_xy_unless_ambiguous() {
        let r = fields(
            with_points(vec![uniform("Sigma", &[1.0, 2.0, 0.9, 3.0])]),
            "",
        )
        .unwrap();
        assert_eq!(nodal(&r), (&[[1.0, 3.0, 3.0, 2.0]; 9][..], "xx,yy,zz,xy"));

        // Components 2 and 3 equal everywhere: could be a symmetric row-major 2×2.
        let mut values = [1.0, 3.0, 3.0, 2.0].repeat(9);
        values[5 * 4 + 1] = 5.0;
        values[5 * 4 + 2] = 5.0 + 2f64.powi(-42); // within 1e-12 · 5
        let ambiguous = || with_points(vec![array("S", 4, values.clone())]);
        assert_eq!(
            message(fields(ambiguous(), "")),
            "m.vtu: point array \"S\": 4 components are ambiguous: xx,yy,zz,xy, or a row-major \
             2×2 xx,xy,yx,yy (components 2 and 3 are equal everywhere); give [fields] \
             stress_layout = \"…\" in scene.toml"
        );
        let r = fields(ambiguous(), "[fields]\nstress_layout = \"xx,xy,yx,yy\"\n").unwrap();
        let (v, layout) = nodal(&r);
        assert_eq!(layout, "xx,xy,yx,yy");
        assert_eq!(v[0], [1.0, 3.0, 3.0, 2.0]);
        assert_eq!(v[5], [1.0, 5.0, 5.0 + 2f64.powi(-42), 2.0]);
        assert_eq!(
            r.notes,
            vec![
                "stress \"S\" stores σxy and σyx separately: max |σxy − σyx| / max |σ| = 4.547e-14"
            ]
        );
        // The scene's layout must fit the array.
        assert_eq!(
            message(fields(
                ambiguous(),
                "[fields]\nstress_layout = \"xx,yy,xy\"\n"
            )),
            "scene.toml: fields.stress_layout: lists 3 components but point array \"S\" in \
             m.vtu has 4 components"
        );

        // Components 2, 3 and 4 equal: both readings give the same in-plane tensor.
        let r = fields(with_points(vec![uniform("s", &[1.0, 2.0, 2.0, 2.0])]), "").unwrap();
        assert_eq!(nodal(&r), (&[[1.0, 2.0, 2.0, 2.0]; 9][..], "xx,yy,zz,xy"));
        let r = fields(with_points(vec![uniform("s", &[0.0; 4])]), "").unwrap();
        assert_eq!(nodal(&r).0, &[[0.0; 4]; 9][..]);
    }

    #[test]
    fn six_components_are_vtk_symmetric_order() {
        let r = fields(
            with_points(vec![uniform("stress", &[1.0, 2.0, 9.0, 3.0, 0.0, 0.0])]),
            "",
        )
        .unwrap();
        assert_eq!(
            nodal(&r),
            (&[[1.0, 3.0, 3.0, 2.0]; 9][..], "xx,yy,zz,xy,yz,xz")
        );
        assert!(r.notes.is_empty(), "{:?}", r.notes);

        let r = fields(
            with_points(vec![uniform("stress", &[1.0, 2.0, 9.0, 3.0, 0.5, 0.0])]),
            "",
        )
        .unwrap();
        assert_eq!(
            r.notes,
            vec![
                "stress \"stress\": out-of-plane shear (yz, xz) is not zero (max 0.5, 1.667e-1 \
                 of max |σ|); the in-plane part is used"
            ]
        );
    }

    #[test]
    fn nine_components_are_row_major_and_asymmetry_is_noted() {
        let r = fields(
            with_points(vec![uniform(
                "cauchy_stress",
                &[1.0, 3.0, 0.0, 3.5, 2.0, 0.0, 0.0, 0.0, 9.0],
            )]),
            "",
        )
        .unwrap();
        assert_eq!(
            nodal(&r),
            (&[[1.0, 3.0, 3.5, 2.0]; 9][..], "xx,xy,xz,yx,yy,yz,zx,zy,zz")
        );
        assert_eq!(
            r.notes,
            vec![
                "stress \"cauchy_stress\" stores σxy and σyx separately: max |σxy − σyx| / max |σ| = 1.429e-1"
            ]
        );
    }

    #[test]
    fn other_counts_and_non_finite_stress_are_refused() {
        assert_eq!(
            message(fields(with_points(vec![uniform("stress", &[1.0; 5])]), "")),
            "m.vtu: point array \"stress\": has 5 components but a stress needs 3 (xx,yy,xy), \
             4 (xx,yy,zz,xy), 6 (xx,yy,zz,xy,yz,xz) or 9 (row-major); or give [fields] \
             stress_layout = \"…\" in scene.toml"
        );
        // …but any count goes with an explicit layout.
        let r = fields(
            with_points(vec![uniform("stress", &[1.0, 2.0, 3.0, 4.0, 5.0])]),
            "[fields]\nstress_layout = \"zz, xx, yz, xy, yy\"\n",
        )
        .unwrap();
        assert_eq!(nodal(&r).0[0], [2.0, 4.0, 4.0, 5.0]);

        let mut f = with_points(vec![uniform("stress", &[1.0, 2.0, 3.0])]);
        f.point_data[1].values[3 * 7 + 2] = f64::INFINITY;
        assert_eq!(
            message(fields(f, "")),
            "m.vtu: point array \"stress\": non-finite value inf at point 7 (x = 0.5, y = 1)"
        );
    }

    #[test]
    fn component_names_decide_the_layout() {
        let case = |names: &[&str], tuple: &[f64]| {
            fields(
                with_points(vec![named(uniform("stress", tuple), names)]),
                "",
            )
        };
        // Ambiguous by count, resolved by the names.
        let r = case(&["XX", "XY", "YX", "YY"], &[1.0, 3.0, 3.0, 2.0]).unwrap();
        assert_eq!(nodal(&r), (&[[1.0, 3.0, 3.0, 2.0]; 9][..], "xx,xy,yx,yy"));
        let r = case(
            &["sigma_xx", "Sigma_YY", "sigma_zz", "sigma_xy"],
            &[1.0, 3.0, 3.0, 2.0],
        )
        .unwrap();
        assert_eq!(nodal(&r), (&[[1.0, 2.0, 2.0, 3.0]; 9][..], "xx,yy,zz,xy"));
        // Abaqus-style 1-based indices.
        let r = case(&["S11", "S22", "S12"], &[1.0, 2.0, 3.0]).unwrap();
        assert_eq!(nodal(&r), (&[[1.0, 3.0, 3.0, 2.0]; 9][..], "xx,yy,xy"));
        // 0-based indices with separators.
        let r = case(&["0_0", "1_1", "[0][1]"], &[1.0, 2.0, 3.0]).unwrap();
        assert_eq!(nodal(&r), (&[[1.0, 3.0, 3.0, 2.0]; 9][..], "xx,yy,xy"));
        let r = case(&["Sxx", "s_xy", "SYY"], &[1.0, 3.0, 2.0]).unwrap();
        assert_eq!(nodal(&r), (&[[1.0, 3.0, 3.0, 2.0]; 9][..], "xx,xy,yy"));
        // Unrecognised names: back to the count, with a note.
        let r = case(&["a", "b", "c"], &[1.0, 2.0, 3.0]).unwrap();
        assert_eq!(nodal(&r), (&[[1.0, 3.0, 3.0, 2.0]; 9][..], "xx,yy,xy"));
        assert_eq!(
            r.notes,
            vec![
                "stress \"stress\": ComponentName attributes (a, b, c) not recognised as tensor \
                 components; layout inferred from the component count"
            ]
        );
        // Recognised but no layout.
        assert_eq!(
            message(case(&["xx", "yy", "YY"], &[1.0, 2.0, 3.0])),
            "m.vtu: point array \"stress\": ComponentName attributes (xx, yy, YY) do not form a \
             stress layout: component 'yy' appears twice; give [fields] stress_layout = \"…\" in \
             scene.toml"
        );
        // The scene's layout overrides the names.
        let r = fields(
            with_points(vec![named(
                uniform("stress", &[1.0, 2.0, 3.0]),
                &["xx", "xy", "yy"],
            )]),
            "[fields]\nstress_layout = \"xx,yy,xy\"\n",
        )
        .unwrap();
        assert_eq!(nodal(&r).0[0], [1.0, 3.0, 3.0, 2.0]);
    }

    #[test]
    fn cell_stress_is_read_on_the_triangles() {
        // Per-cell values: cell c holds (c, 10 + c, 100 + c); lines hold NaN, which is not read.
        let values: Vec<f64> = (0..TRIANGLES + SIDES.len())
            .flat_map(|c| {
                if c < TRIANGLES {
                    [c as f64, 10.0 + c as f64, 100.0 + c as f64]
                } else {
                    [f64::NAN; 3]
                }
            })
            .collect();
        let f = with_points(vec![]).tap(|f| f.cell_data.push(array("SIGMA", 3, values)));
        let r = fields(f, "").unwrap();
        match &r.stress {
            Stress::Cell {
                values,
                name,
                layout,
            } => {
                assert_eq!(name, "SIGMA");
                assert_eq!(layout, "xx,yy,xy");
                assert_eq!(values.len(), TRIANGLES);
                assert_eq!(values[5], [5.0, 105.0, 105.0, 15.0]);
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn stress_selection_rules_and_errors() {
        // Point data is preferred over cell data.
        let f = with_points(vec![uniform("stress", &[1.0, 2.0, 3.0])])
            .tap(|f| f.cell_data.push(uniform_cells("sigma", &[1.0, 2.0, 3.0])));
        let r = fields(f, "").unwrap();
        assert!(matches!(r.stress, Stress::Nodal { .. }));
        assert_eq!(
            r.notes,
            vec!["stress: point array \"stress\" is preferred over cell data (\"sigma\")"]
        );
        // Named in the scene: a cell array.
        let f = with_points(vec![uniform("stress", &[1.0, 2.0, 3.0])])
            .tap(|f| f.cell_data.push(uniform_cells("other", &[4.0, 5.0, 6.0])));
        let r = fields(f, "[fields]\nstress = \"other\"\n").unwrap();
        assert!(
            matches!(&r.stress, Stress::Cell { values, .. } if values[0] == [4.0, 6.0, 6.0, 5.0])
        );

        let two_points = with_points(vec![
            uniform("stress", &[1.0, 2.0, 3.0]),
            uniform("S", &[1.0, 2.0, 3.0]),
        ]);
        assert_eq!(
            message(fields(two_points, "")),
            "m.vtu: PointData: several stress candidates (\"stress\", \"S\"); set [fields] \
             stress = \"…\" in scene.toml"
        );
        let two_cells = with_points(vec![]).tap(|f| {
            f.cell_data
                .push(uniform_cells("stresses", &[1.0, 2.0, 3.0]));
            f.cell_data.push(uniform_cells("Sigma", &[1.0, 2.0, 3.0]));
        });
        assert_eq!(
            message(fields(two_cells, "")),
            "m.vtu: CellData: several stress candidates (\"stresses\", \"Sigma\"); set [fields] \
             stress = \"…\" in scene.toml"
        );
        assert_eq!(
            message(fields(with_points(vec![]), "[fields]\nstress = \"sxx\"\n")),
            "scene.toml: fields.stress: no point or cell array \"sxx\" in m.vtu (point arrays: \
             \"u\" (2 components); cell arrays: \"boundary_tag\" (1 component))"
        );
        let mut bad = uniform_cells("stress", &[1.0, 2.0, 3.0]);
        bad.values[3 * 5 + 1] = f64::NEG_INFINITY;
        let f = with_points(vec![]).tap(|f| f.cell_data.push(bad));
        assert_eq!(
            message(fields(f, "")),
            "m.vtu: cell array \"stress\": non-finite value -inf at cell 5"
        );
    }

    // -----------------------------------------------------------------------------------------
    // Boundary conditions

    const TAGGED: &str = r#"
[[boundary]]
name = "bottom"
tag = 1
kind = "dirichlet"
displacement = [0.0, 0.0]

[[boundary]]
name = "right"
tag = 2
kind = "neumann"
traction = [1.0, 0.0]

[[boundary]]
name = "top"
tag = 3
kind = "contact"
gap = "0.1"
"#;

    fn classified(f: VtuFile, extra: &str) -> Result<(Dataset, Topology, Boundaries)> {
        let (d, t) = build(f);
        let b = classify(&d, &t, &scene(extra))?;
        Ok((d, t, b))
    }

    /// The midpoint of each boundary edge with the given condition, sorted.
    fn midpoints(d: &Dataset, b: &Boundaries, condition: Condition) -> Vec<[f64; 2]> {
        let mut m: Vec<[f64; 2]> = b
            .edges
            .iter()
            .filter(|e| e.condition == condition)
            .map(|e| {
                let tri = d.mesh.cells[e.cell as usize];
                let k = e.local as usize;
                let (p, q) = (
                    d.mesh.points[tri[k] as usize],
                    d.mesh.points[tri[(k + 1) % 3] as usize],
                );
                [(p[0] + q[0]) / 2.0, (p[1] + q[1]) / 2.0]
            })
            .collect();
        m.sort_by(|a, b| a.partial_cmp(b).unwrap());
        m
    }

    /// Every boundary edge is listed once, in topology order, and runs counter-clockwise:
    /// its midpoint lies on ∂[0,1]² and the normal on the right of travel points out.
    fn check_orientation(d: &Dataset, t: &Topology, b: &Boundaries) {
        assert_eq!(
            b.edges.iter().map(|e| e.edge).collect::<Vec<_>>(),
            t.boundary_edges
        );
        for e in &b.edges {
            assert_eq!(t.cell_edges[e.cell as usize][e.local as usize], e.edge);
            let tri = d.mesh.cells[e.cell as usize];
            let k = e.local as usize;
            let (p, q) = (
                d.mesh.points[tri[k] as usize],
                d.mesh.points[tri[(k + 1) % 3] as usize],
            );
            let m = [(p[0] + q[0]) / 2.0, (p[1] + q[1]) / 2.0];
            let on_side = |v: f64| v == 0.0 || v == 1.0;
            assert!(on_side(m[0]) || on_side(m[1]), "{m:?} not on the boundary");
            let len = (q[0] - p[0]).hypot(q[1] - p[1]);
            let n = [(q[1] - p[1]) / len, -(q[0] - p[0]) / len];
            let out = [m[0] + 0.1 * n[0], m[1] + 0.1 * n[1]];
            let inside = |v: f64| (0.0..=1.0).contains(&v);
            assert!(
                !(inside(out[0]) && inside(out[1])),
                "normal {n:?} at {m:?} points inwards"
            );
            if d.mesh.degree == 2 {
                assert_eq!(tri[3 + k], t.edge_mid[e.edge as usize]);
            }
        }
    }

    #[test]
    fn tags_select_their_edges_and_the_rest_is_free() {
        let (d, t, b) = classified(square(), TAGGED).unwrap();
        check_orientation(&d, &t, &b);
        assert_eq!(b.edges.len(), 8);
        assert_eq!(
            midpoints(&d, &b, Condition::Dirichlet(0)),
            vec![[0.25, 0.0], [0.75, 0.0]]
        );
        assert_eq!(
            midpoints(&d, &b, Condition::Neumann(1)),
            vec![[1.0, 0.25], [1.0, 0.75]]
        );
        assert_eq!(
            midpoints(&d, &b, Condition::Contact(2)),
            vec![[0.25, 1.0], [0.75, 1.0]]
        );
        assert_eq!(
            midpoints(&d, &b, Condition::Free),
            vec![[0.0, 0.25], [0.0, 0.75]]
        );
        // Each edge knows its line cell.
        for e in &b.edges {
            assert_ne!(e.line, NONE);
            assert_eq!(t.line_edge[e.line as usize], e.edge);
        }
        assert_eq!(b.edges_of(2).count(), 2);
        assert_eq!(
            b.per_boundary,
            vec![
                BoundarySummary {
                    name: "bottom".into(),
                    edges: 2,
                    length: 1.0
                },
                BoundarySummary {
                    name: "right".into(),
                    edges: 2,
                    length: 1.0
                },
                BoundarySummary {
                    name: "top".into(),
                    edges: 2,
                    length: 1.0
                },
            ]
        );
        assert_eq!(
            b.notes,
            vec!["2 boundary edges (length 1) selected by no [[boundary]]: traction-free"]
        );
    }

    #[test]
    fn clockwise_input_is_still_oriented_outwards() {
        let (d, t, b) = classified(square_with(&SIDES, true), TAGGED).unwrap();
        assert!(d.report.reoriented > 0);
        check_orientation(&d, &t, &b);
        assert_eq!(
            midpoints(&d, &b, Condition::Contact(2)),
            vec![[0.25, 1.0], [0.75, 1.0]]
        );
    }

    #[test]
    fn tagged_interior_line_is_ignored_with_a_note() {
        let mut lines = SIDES.to_vec();
        lines.push((0, 4, 3.0)); // the diagonal of the lower-left square: interior
        let (d, _, b) = classified(square_with(&lines, false), TAGGED).unwrap();
        assert_eq!(
            midpoints(&d, &b, Condition::Contact(2)),
            vec![[0.25, 1.0], [0.75, 1.0]]
        );
        assert_eq!(
            b.notes[0],
            "boundary[2] \"top\": 1 line cell with tag 3 lies on an interior edge and is ignored \
             (cell 16)"
        );
    }

    #[test]
    fn where_tests_the_edge_midpoint() {
        let text = r#"
[[boundary]]
name = "lid"
where = "y > 0.999"
kind = "dirichlet"
displacement = [0.0, "-0.01 * x"]

[[boundary]]
name = "sides"
where = "abs(x - 0.5) > 0.499"
kind = "neumann"
traction = [0.0, 0.0]
"#;
        // No line cells at all: `where` needs none.
        let (d, t, b) = classified(square_with(&[], false), text).unwrap();
        check_orientation(&d, &t, &b);
        // The corner edges of the sides end at y = 1 but their midpoints do not pass y > 0.999.
        assert_eq!(
            midpoints(&d, &b, Condition::Dirichlet(0)),
            vec![[0.25, 1.0], [0.75, 1.0]]
        );
        assert_eq!(
            midpoints(&d, &b, Condition::Neumann(1)),
            vec![[0.0, 0.25], [0.0, 0.75], [1.0, 0.25], [1.0, 0.75]]
        );
        assert_eq!(
            midpoints(&d, &b, Condition::Free),
            vec![[0.25, 0.0], [0.75, 0.0]]
        );
        assert!(b.edges.iter().all(|e| e.line == NONE));
        assert_eq!(b.per_boundary[1].length, 2.0);
    }

    #[test]
    fn where_uses_the_mid_node_of_quadratic_edges() {
        // One quadratic triangle whose bottom edge bulges down to (0.5, -0.1).
        let f = VtuFile::from_cells(
            Path::new("m.vtu"),
            vec![
                [0., 0., 0.],
                [1., 0., 0.],
                [0., 1., 0.],
                [0.5, -0.1, 0.],
                [0.5, 0.5, 0.],
                [0., 0.5, 0.],
            ],
            &[(22, vec![0, 1, 2, 3, 4, 5])],
        );
        let text = r#"
[[boundary]]
name = "bulge"
where = "y < -0.05"
kind = "contact"
gap = "0"
"#;
        let (d, t, b) = classified(f, text).unwrap();
        assert_eq!(d.mesh.degree, 2);
        let contact: Vec<&BoundaryEdge> = b.edges_of(0).collect();
        assert_eq!(contact.len(), 1);
        assert_eq!(contact[0].local, 0);
        assert_eq!(t.edge_mid[contact[0].edge as usize], 3);
        // Chord length, not arc length.
        assert_eq!(b.per_boundary[0].length, 1.0);
    }

    #[test]
    fn overlapping_selectors_first_in_file_order_wins() {
        let text = format!(
            "{TAGGED}{}",
            r#"
[[boundary]]
name = "floor"
where = "y < 0.001 && x > 0.5"
kind = "contact"
gap = "0"

[[boundary]]
name = "corner"
where = "x < 0.001 || y > 0.999"
kind = "neumann"
traction = [0.0, 0.0]
"#
        );
        let (d, _, b) = classified(square(), &text).unwrap();
        assert_eq!(
            midpoints(&d, &b, Condition::Dirichlet(0)),
            vec![[0.25, 0.0], [0.75, 0.0]]
        );
        assert_eq!(b.edges_of(3).count(), 0);
        assert_eq!(
            midpoints(&d, &b, Condition::Neumann(4)),
            vec![[0.0, 0.25], [0.0, 0.75]]
        );
        assert_eq!(b.per_boundary[3].edges, 0);
        assert_eq!(
            b.notes,
            vec![
                "boundary[0] \"bottom\" and boundary[3] \"floor\" both select 1 edge; boundary[0] \
                 \"bottom\" (first in file order) applies there",
                "boundary[2] \"top\" and boundary[4] \"corner\" both select 2 edges; boundary[2] \
                 \"top\" (first in file order) applies there",
            ]
        );
    }

    #[test]
    fn selector_errors_name_the_scene_key() {
        let boundary = |selector: &str| {
            format!(
                "[[boundary]]\nname = \"b\"\n{selector}\nkind = \"neumann\"\ntraction = [0, 0]\n"
            )
        };
        let err = |f: VtuFile, text: &str| message(classified(f, text));

        // Default tag array name missing; integer cell arrays are listed.
        let mut f = square();
        f.cell_data[0].name = "gmsh:physical".into();
        f.cell_data.push(uniform_cells("stress", &[0.5, 0.0, 0.0]));
        f.cell_data.push(uniform_cells("region", &[2.0]));
        assert_eq!(
            err(f, &boundary("tag = 1")),
            "scene.toml: boundary[0] \"b\".tag: cell array \"boundary_tag\" is not in m.vtu \
             (integer cell arrays: \"gmsh:physical\", \"region\"); name the tag array with \
             [boundaries] tag_array = \"…\""
        );
        // A named tag array that is point data.
        let f = square().tap(|f| f.point_data.push(uniform("ids", &[1.0])));
        assert_eq!(
            err(
                f,
                &format!("[boundaries]\ntag_array = \"ids\"\n{}", boundary("tag = 1"))
            ),
            "scene.toml: boundary[0] \"b\".tag: cell array \"ids\" is not in m.vtu (it is a \
             point array; tags are cell data on the line cells)"
        );
        // No line cells at all.
        let f = square_with(&[], false).tap(|f| f.cell_data.clear());
        assert_eq!(
            err(f, &boundary("tag = 1")),
            "scene.toml: boundary[0] \"b\".tag: cell array \"boundary_tag\" is not in m.vtu, \
             which has no line cells to carry tags; select edges with where = \"…\""
        );
        // A tag array with two components.
        let f = square().tap(|f| f.cell_data.push(uniform_cells("pair", &[1.0, 2.0])));
        assert_eq!(
            err(
                f,
                &format!(
                    "[boundaries]\ntag_array = \"pair\"\n{}",
                    boundary("tag = 1")
                )
            ),
            "scene.toml: boundary[0] \"b\".tag: cell array \"pair\" in m.vtu has 2 components; \
             a tag array needs 1"
        );
        // A tag no line cell carries.
        let mut f = square();
        f.cell_data[0].values[TRIANGLES] = 1.5;
        assert_eq!(
            err(f, &boundary("tag = 7")),
            "scene.toml: boundary[0] \"b\".tag: no line cell of m.vtu has tag 7 in cell array \
             \"boundary_tag\" (tags present: 1 (1 line cell), 2 (2 line cells), 3 (2 line \
             cells), 4 (2 line cells), 1 value not an integer)"
        );
        // Only interior line cells carry it.
        let mut lines = SIDES.to_vec();
        lines.push((0, 4, 9.0));
        lines.push((4, 8, 9.0));
        assert_eq!(
            err(square_with(&lines, false), &boundary("tag = 9")),
            "scene.toml: boundary[0] \"b\".tag: all 2 line cells with tag 9 in m.vtu lie on \
             interior edges, not on the boundary (cells 16, 17)"
        );
        lines.pop();
        assert_eq!(
            err(square_with(&lines, false), &boundary("tag = 9")),
            "scene.toml: boundary[0] \"b\".tag: the line cell with tag 9 in m.vtu lies on an \
             interior edge, not on the boundary (cell 16)"
        );
        // An expression true nowhere on the boundary (the centre is not on it).
        assert_eq!(
            err(
                square(),
                &boundary("where = \"abs(x - 0.5) + abs(y - 0.5) < 0.1\"")
            ),
            "scene.toml: boundary[0] \"b\".where: \"abs(x - 0.5) + abs(y - 0.5) < 0.1\" holds \
             at no boundary edge midpoint (the mesh spans x ∈ [0, 1], y ∈ [0, 1])"
        );
    }

    #[test]
    fn no_boundaries_leave_everything_free() {
        let (_, _, b) = classified(square(), "").unwrap();
        assert!(b.edges.iter().all(|e| e.condition == Condition::Free));
        assert!(b.per_boundary.is_empty());
        assert_eq!(
            b.notes,
            vec!["8 boundary edges (length 4) selected by no [[boundary]]: traction-free"]
        );
    }
}
