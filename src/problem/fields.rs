//! Field selection (docs/design.md §4.1): which arrays of the solution file are u_h and σ_h,
//! their layouts, every tensor stored as a full 2×2 row-major `[σxx, σxy, σyx, σyy]`.

use std::fmt;

use crate::error::{Error, Result};
use crate::mesh::Dataset;
use crate::read::scene::{Component, Scene, StressLayout};
use crate::read::vtu::DataArray;

// ---------------------------------------------------------------------------------------------
// Fields

pub use crate::read::components::{DISPLACEMENT_NAMES, STRESS_NAMES};

/// Relative tolerance (of the array's largest magnitude) under which two stress components are
/// taken as equal at a point, for the ambiguity test of 4-component arrays.
pub const EQUAL_COMPONENTS: f64 = crate::tolerance::EQUAL_COMPONENTS;

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
    /// One tensor per triangle ([`crate::mesh::Mesh::cells`] order): piecewise constant,
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
             with 2 or 3 components; point arrays: {}); set [fields] displacement = \"…\"{} in {}",
            list_arrays(&data.point_data),
            if has_component_arrays(&data.point_data) {
                " (or the list of its component arrays, [\"…\", \"…\"])"
            } else {
                ""
            },
            scene.file.display()
        ),
    )
}

/// Whether `arrays` hold two or more one-component arrays: then the displacement may be written
/// one array per component, and the errors say how a scene lists them (`read::components`).
fn has_component_arrays(arrays: &[DataArray]) -> bool {
    arrays.iter().filter(|a| a.components == 1).count() >= 2
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
                    "no point array \"{}\" in {file}{cell} (point arrays: {}){}",
                    name.escape_debug(),
                    list_arrays(&data.point_data),
                    if has_component_arrays(&data.point_data) {
                        "; a field written one array per component is named by their list, \
                         displacement = [\"…\", \"…\"]"
                    } else {
                        ""
                    }
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
        .filter(|a| {
            named_like(a, &DISPLACEMENT_NAMES, &ASTER_DISPLACEMENT)
                && (a.components == 2 || a.components == 3)
        })
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
            .filter(|a| named_like(a, &STRESS_NAMES, &ASTER_STRESS))
            .collect();
        let cells: Vec<&DataArray> = data
            .cell_data
            .iter()
            .filter(|a| named_like(a, &STRESS_NAMES, &ASTER_STRESS))
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
    if c == 9 {
        // DOLFINx writes a 2×2 tensor as 9 components xx, xy, yx, yy, 0, 0, 0, 0, 0: the last
        // five are exactly zero and components 2, 3 (xz, yx of a row-major 3×3) carry the
        // in-plane yx, yy. A 3×3 of a 2D stress has xz = yx = 0 there, so the test is safe.
        let zero_tail = a
            .values
            .chunks_exact(9)
            .all(|v| v[4..].iter().all(|&x| x == 0.0));
        let in_plane = a.values.chunks_exact(9).any(|v| v[2] != 0.0 || v[3] != 0.0);
        if zero_tail && in_plane {
            let layout = StressLayout::parse("xx,xy,yx,yy,xz,yz,zx,zy,zz").expect("a valid layout");
            return Ok((
                layout,
                Some(format!(
                    "stress \"{}\": 9 components with the last five zero: read as DOLFINx's \
                     padded 2×2 tensor xx, xy, yx, yy, 0, 0, 0, 0, 0 (not a row-major 3×3)",
                    a.name.escape_debug()
                )),
            ));
        }
    }
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

/// Whether `a` is named like one of `names`, was joined from component arrays of such a name
/// (`(u_x, u_y)` for `u`: [`crate::read::components::joined_base`]), or is a code_aster result
/// of one of the fields `aster` ([`aster_field`]).
fn named_like(a: &DataArray, names: &[&str], aster: &[&str]) -> bool {
    names.iter().any(|n| a.name.eq_ignore_ascii_case(n))
        || crate::read::components::joined_base(a).is_some_and(|b| names.contains(&b.as_str()))
        || aster_field(&a.name).is_some_and(|f| aster.iter().any(|n| f.eq_ignore_ascii_case(n)))
}

/// code_aster's nodal displacement field (components DX, DY[, DZ]).
const ASTER_DISPLACEMENT: [&str; 1] = ["DEPL"];
/// code_aster's nodal stress fields (components SIXX, SIYY, SIZZ, SIXY, …: the layout follows
/// from those `ComponentName`s).
const ASTER_STRESS: [&str; 2] = ["SIEF_NOEU", "SIGM_NOEU"];

/// The field part of a code_aster result's array name as the MED reader writes it, the result
/// concept's name padded with `_` to 8 characters followed by the field (`RESU____DEPL` →
/// `DEPL`, `stat____SIEF_NOEU` → `SIEF_NOEU`), or the whole name when it is shorter (`DEPL`).
pub(super) fn aster_field(name: &str) -> Option<&str> {
    match name.char_indices().nth(8) {
        Some((i, _)) => name[..i]
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_')
            .then(|| &name[i..]),
        None => Some(name),
    }
}

/// `3 components` / `1 component`.
pub(super) fn components(n: usize) -> String {
    plural(n, "component")
}

pub(super) fn plural(n: usize, what: &str) -> String {
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
pub(super) fn quoted_names(arrays: &[&DataArray]) -> String {
    arrays
        .iter()
        .map(|a| format!("\"{}\"", a.name.escape_debug()))
        .collect::<Vec<_>>()
        .join(", ")
}

/// A number for a message: as written when short, else with 6 significant digits.
pub(super) fn short(v: f64) -> String {
    let s = format!("{v}");
    if s.len() <= 10 { s } else { format!("{v:.5e}") }
}

/// What the mid-edge values of a displacement on a quadratic mesh say (docs/design.md §4.1).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MidEdge {
    /// A linear mesh, or mid-edge values that are a genuine part of the field.
    Field,
    /// Every mid-edge value is zero (to [`crate::tolerance::VERTEX_ONLY_RELATIVE`] of the
    /// field's largest magnitude) while the vertices are not: the writer kept the vertex values
    /// only (sfepy's default output of a P2 field). They are replaced by the mean of the edge's
    /// end values, so the field is the P1 interpolant of the vertex values.
    VerticesOnly,
    /// Every mid-edge value is the mean of its ends (to the same tolerance): the field is linear
    /// along every edge, i.e. P1 in P2 form. It is evaluated as given (it *is* that field); a
    /// note says so, since a writer that interpolated linearly cannot be told from a linear
    /// solution.
    LinearOnEdges,
}

/// Classifies (and for [`MidEdge::VerticesOnly`] repairs) the mid-edge values of `u`: the mid
/// node m of edge [a, b] is "zero" when |u_m| ≤ τ s and "the mean" when
/// |u_m − (u_a + u_b)/2| ≤ τ s, s = max |u| over the vertices, τ = VERTEX_ONLY_RELATIVE.
pub fn mid_edge_values(
    mesh: &crate::mesh::Mesh,
    topo: &crate::topology::Topology,
    u: &mut [[f64; 2]],
) -> MidEdge {
    use crate::mesh::NONE;
    if mesh.degree != 2 {
        return MidEdge::Field;
    }
    let edges: Vec<(usize, usize, usize)> = topo
        .edges
        .iter()
        .zip(&topo.edge_mid)
        .filter(|(_, m)| **m != NONE)
        .map(|(e, &m)| (e[0] as usize, e[1] as usize, m as usize))
        .collect();
    if edges.is_empty() {
        return MidEdge::Field;
    }
    let scale = edges.iter().fold(0.0f64, |s, &(a, b, _)| {
        s.max(u[a][0].abs())
            .max(u[a][1].abs())
            .max(u[b][0].abs())
            .max(u[b][1].abs())
    });
    if scale == 0.0 || !scale.is_finite() {
        return MidEdge::Field;
    }
    let tol = crate::tolerance::VERTEX_ONLY_RELATIVE * scale;
    let mean =
        |u: &[[f64; 2]], a: usize, b: usize| [(u[a][0] + u[b][0]) / 2.0, (u[a][1] + u[b][1]) / 2.0];
    let zero = edges
        .iter()
        .all(|&(_, _, m)| u[m][0].abs() <= tol && u[m][1].abs() <= tol);
    if zero {
        for &(a, b, m) in &edges {
            u[m] = mean(u, a, b);
        }
        return MidEdge::VerticesOnly;
    }
    let linear = edges.iter().all(|&(a, b, m)| {
        let c = mean(u, a, b);
        (u[m][0] - c[0]).abs() <= tol && (u[m][1] - c[1]).abs() <= tol
    });
    if linear {
        MidEdge::LinearOnEdges
    } else {
        MidEdge::Field
    }
}

/// How far a piecewise-constant cell stress σ_T is from the displacement's own stress, in the
/// area-weighted RMS (docs/design.md §4.1 "Cell stress and displacement"):
///
/// ```text
/// r = ( Σ_T ∫_T |σ_T − m_T|² ) ^½ / ( Σ_T ∫_T |σ_T|² ) ^½,   m_T = (1/|T|) ∫_T Cε(u_h) dx,
/// ```
///
/// with |·| the Frobenius norm and the integrals by the cells' quadrature. `None` where it is
/// not defined: λ = ∞ (Cε(u_h) has no meaning) or a zero stress.
pub fn cell_stress_mismatch(
    mesh: &crate::mesh::Mesh,
    u: &[[f64; 2]],
    cells: &[[f64; 4]],
    elastic: &crate::material::Elastic,
) -> Option<f64> {
    use crate::geometry::MAX_NODES;
    use crate::geometry::values::interior_table;
    use rayon::prelude::*;
    if !elastic.lambda.is_finite() || cells.len() != mesh.len() {
        return None;
    }
    let (num, den) = (0..mesh.len())
        .into_par_iter()
        .with_min_len(1024)
        .map_init(
            crate::geometry::values::CellValuesCache::default,
            |cache, t| {
                let sh = mesh.shape[t];
                let cv = cache.get(mesh.family[t], sh, |f, sh| {
                    interior_table(f, sh, None, true)
                });
                let nodes = mesh.nodes(t);
                let x = mesh.coords(t);
                cv.reinit(&x[..nodes.len()], sh);
                let mut ue = [[0.0; 2]; MAX_NODES];
                for (k, &p) in nodes.iter().enumerate() {
                    ue[k] = u[p as usize];
                }
                let (mut area, mut m) = (0.0, [0.0; 4]);
                for q in 0..cv.len() {
                    let g = cv.gradient2(q, &ue);
                    let sym = 0.5 * (g[0][1] + g[1][0]);
                    let s = elastic.stress([g[0][0], sym, sym, g[1][1]]);
                    area += cv.jxw[q];
                    for k in 0..4 {
                        m[k] += cv.jxw[q] * s[k];
                    }
                }
                let s = cells[t];
                let (mut d2, mut s2) = (0.0, 0.0);
                for k in 0..4 {
                    let d = s[k] - m[k] / area;
                    d2 += d * d;
                    s2 += s[k] * s[k];
                }
                (area * d2, area * s2)
            },
        )
        .reduce(|| (0.0, 0.0), |a, b| (a.0 + b.0, a.1 + b.1));
    (den > 0.0 && num.is_finite()).then(|| (num / den).sqrt())
}

#[cfg(test)]
mod cell_stress_tests {
    use super::cell_stress_mismatch;
    use crate::material::Elastic;
    use crate::read::vtu::VtuFile;

    /// u = (a x + b y, c x + d y) on two triangles of the unit square: Cε(u) is one constant
    /// tensor S. A cell stress equal to S gives r = 0; S on one triangle and S + D on the
    /// other (equal areas) give r = |D| / (|S|² + |S + D|²)^½ · 1 by hand.
    #[test]
    fn mismatch_is_zero_for_the_own_stress_and_the_hand_value_otherwise() {
        let p = |x: f64, y: f64| [x, y, 0.0];
        let points = vec![p(0.0, 0.0), p(1.0, 0.0), p(1.0, 1.0), p(0.0, 1.0)];
        let cells = vec![(5u8, vec![0, 1, 2]), (5, vec![0, 2, 3])];
        let data = crate::mesh::build(VtuFile::from_cells(
            std::path::Path::new("s.vtu"),
            points,
            &cells,
        ))
        .unwrap();
        let (a, b, c, d) = (1e-3, 2e-3, -5e-4, -3e-3);
        let u: Vec<[f64; 2]> = data
            .mesh
            .points
            .iter()
            .map(|x| [a * x[0] + b * x[1], c * x[0] + d * x[1]])
            .collect();
        let el = Elastic {
            mu: 8000.0,
            lambda: 12000.0,
        };
        let e = 0.5 * (b + c);
        let s = el.stress([a, e, e, d]);
        let r = cell_stress_mismatch(&data.mesh, &u, &[s, s], &el).unwrap();
        assert!(r < 1e-15, "{r}");
        let dd = [3.0, -1.0, -1.0, 2.0];
        let s2 = [s[0] + dd[0], s[1] + dd[1], s[2] + dd[2], s[3] + dd[3]];
        let n2 = |t: [f64; 4]| t.iter().map(|v| v * v).sum::<f64>();
        let want = (n2(dd) / (n2(s) + n2(s2))).sqrt();
        let r = cell_stress_mismatch(&data.mesh, &u, &[s, s2], &el).unwrap();
        assert!((r - want).abs() <= 1e-14 * want, "{r} vs {want}");
        let inc = Elastic {
            mu: 8000.0,
            lambda: f64::INFINITY,
        };
        assert_eq!(cell_stress_mismatch(&data.mesh, &u, &[s, s], &inc), None);
    }
}
