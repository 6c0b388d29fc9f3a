//! Vector and tensor fields written as one scalar array per component (docs/design.md §4.1,
//! "Component arrays"): MOOSE/libMesh's `disp_x`, `disp_y` and `stress_xx`, …, deal.II's
//! `x_displacement`, `y_displacement` (a `DataOut` without a vector interpretation), NGSolve's
//! `VTKOutput(coefs=[u[0], u[1]], names=["ux", "uy"])`, FreeFEM's `u`, `v`.
//!
//! [`join`] runs on the file before the mesh is built, so that a joined field is merged over
//! node copies like any vector array (and keeps the copies when they disagree, which a scalar
//! array would not: [`crate::mesh::Dataset::copies`]). It appends one array per group, named
//! `(a, b, …)` after its parts, with the parts as its `ComponentName`s; the scalar arrays stay.
//!
//! - Named in the scene (`[fields] displacement = ["ux", "uy"]`, `stress = ["sxx", "syy",
//!   "sxy"]`): those arrays, which must exist, have one component and the same section (point
//!   data for the displacement); the scene's name for the field is then `(ux, uy)`.
//! - Otherwise, when the file has no array named like the field ([`DISPLACEMENT_NAMES`],
//!   [`STRESS_NAMES`]): the groups of one-component arrays of one
//!   section whose names are a base name of the field with component suffixes. Displacement:
//!   `u_x`, `ux`, `u[0]`, `disp_1`, `x_displacement` (axis letters x, y, z, or indices 0-based
//!   when one is 0, else 1-based), x and y both present, z optional; and the pair `u`, `v`.
//!   Stress: `stress_xx`, `sxx`, `sigma_12`, … (the last two letters or digits of the name, as
//!   for `ComponentName`s), with xx, yy and xy or yx present. Each group found is a candidate
//!   of [`crate::problem::select_fields`] like a vector array of that name ([`joined_base`]),
//!   so that two groups, or a group and a vector array, are reported as ambiguous.
//!
//! Case is ignored in every comparison.

use std::collections::BTreeMap;

use crate::error::Result;
use crate::read::decode::Scalar;
use crate::read::scene::{FieldNames, Scene};
use crate::read::vtu::{DataArray, VtuFile};

/// Point-array names (compared case-insensitively) taken for the displacement when
/// `[fields] displacement` is not given.
pub const DISPLACEMENT_NAMES: [&str; 4] = ["displacement", "displacements", "disp", "u"];

/// Point- or cell-array names (compared case-insensitively) taken for the stress when
/// `[fields] stress` is not given.
/// Kratos writes its 2D Voigt stress (xx, yy, xy) as `CAUCHY_STRESS_VECTOR`.
pub const STRESS_NAMES: [&str; 6] = [
    "stress",
    "stresses",
    "sigma",
    "s",
    "cauchy_stress",
    "cauchy_stress_vector",
];

/// What [`join`] did: one note per joined group.
#[derive(Clone, Debug, Default)]
pub struct Joined {
    pub notes: Vec<String>,
}

/// The separators allowed between a base name and a component suffix.
const SEPARATORS: [&str; 6] = ["", "_", "-", ".", " ", ":"];

/// The name of the array joined from `parts`.
pub fn joined_name(parts: &[String]) -> String {
    format!("({})", parts.join(", "))
}

/// The field base name of an array made by [`join`] from an auto-detected group (`u` for
/// `(u_x, u_y)`, `stress` for `(stress_xx, stress_yy, stress_xy)`), `None` for any other array.
pub fn joined_base(a: &DataArray) -> Option<String> {
    if a.component_names.len() != a.components
        || a.components < 2
        || a.name != joined_name(&a.component_names)
    {
        return None;
    }
    let names: Vec<String> = a
        .component_names
        .iter()
        .map(|s| s.to_ascii_lowercase())
        .collect();
    if let Some((base, _)) = vector_group(&names) {
        return Some(base);
    }
    stress_base(&names)
}

/// The axis of a vector component suffix: `x`/`0` → 0, …; digits are returned with a flag.
fn axis(suffix: &str) -> Option<(usize, bool)> {
    match suffix {
        "x" => Some((0, false)),
        "y" => Some((1, false)),
        "z" => Some((2, false)),
        "0" => Some((0, true)),
        "1" => Some((1, true)),
        "2" => Some((2, true)),
        "3" => Some((3, true)),
        _ => None,
    }
}

/// `(base, style, axis, digit)` readings of a lower-case name as a displacement component:
/// `style` tells the spellings apart (suffix with a separator, bracketed, prefixed), so that
/// only names spelled alike form a group.
fn vector_readings(name: &str) -> Vec<(&'static str, String, usize, bool)> {
    let mut out = Vec::new();
    for base in DISPLACEMENT_NAMES {
        if let Some(rest) = name.strip_prefix(base) {
            for sep in SEPARATORS {
                if let Some(s) = rest.strip_prefix(sep)
                    && let Some((a, d)) = axis(s)
                {
                    out.push((base, format!("suffix{sep}"), a, d));
                }
            }
            for (open, close) in [("[", "]"), ("(", ")")] {
                if let Some(s) = rest.strip_prefix(open).and_then(|s| s.strip_suffix(close))
                    && let Some((a, d)) = axis(s)
                {
                    out.push((base, format!("bracket{open}"), a, d));
                }
            }
        }
        if let Some(rest) = name.strip_suffix(base) {
            for sep in SEPARATORS.iter().skip(1) {
                if let Some(s) = rest.strip_suffix(sep)
                    && let Some((a, false)) = axis(s)
                {
                    out.push((base, format!("prefix{sep}"), a, false));
                }
            }
        }
    }
    out
}

/// The displacement group formed by exactly these lower-case names, in axis order: its base
/// and the order of the names (x, y[, z]).
fn vector_group(names: &[String]) -> Option<(String, Vec<usize>)> {
    if names == ["u", "v"] {
        return Some(("u".into(), vec![0, 1]));
    }
    let mut groups = vector_groups(names);
    (groups.len() == 1 && groups[0].2.len() == names.len()).then(|| {
        let (base, _, order) = groups.remove(0);
        (base, order)
    })
}

/// Every displacement group among the lower-case `names` (one-component arrays of one section):
/// (base, style, indices into `names` in axis order), x and y present, z optional.
fn vector_groups(names: &[String]) -> Vec<(String, String, Vec<usize>)> {
    // (base, style) → its readings: (axis, digit, index into `names`).
    type Readings = Vec<(usize, bool, usize)>;
    let mut found: BTreeMap<(&'static str, String), Readings> = BTreeMap::new();
    for (i, n) in names.iter().enumerate() {
        for (base, style, a, d) in vector_readings(n) {
            found.entry((base, style)).or_default().push((a, d, i));
        }
    }
    let mut out = Vec::new();
    for ((base, style), hits) in found {
        let digits = hits.iter().any(|h| h.1);
        let zero_based = hits.iter().any(|h| h.1 && h.0 == 0);
        let mut by_axis: [Vec<usize>; 3] = Default::default();
        for (a, _, i) in hits {
            let a = if digits && !zero_based {
                a.wrapping_sub(1)
            } else {
                a
            };
            if a < 3 {
                by_axis[a].push(i);
            }
        }
        if by_axis.iter().any(|v| v.len() > 1) || by_axis[0].is_empty() || by_axis[1].is_empty() {
            continue;
        }
        let order: Vec<usize> = by_axis.iter().flatten().copied().collect();
        out.push((base.to_string(), style, order));
    }
    if out.is_empty()
        && let (Some(u), Some(v)) = (
            names.iter().position(|n| n == "u"),
            names.iter().position(|n| n == "v"),
        )
    {
        out.push(("u".into(), "uv".into(), vec![u, v]));
    }
    out
}

/// The two axes a lower-case stress component name ends with (`xx`, `12`, …), as in
/// `ComponentName`s: the base before them, the two characters.
fn stress_reading(name: &str) -> Option<(&'static str, String)> {
    let clean: String = name.chars().filter(|c| c.is_ascii_alphanumeric()).collect();
    if clean.len() < 3 {
        return None;
    }
    let (head, ab) = clean.split_at(clean.len() - 2);
    let ok = ab.chars().all(|c| matches!(c, 'x' | 'y' | 'z'))
        || ab.chars().all(|c| matches!(c, '0'..='3'));
    if !ok {
        return None;
    }
    STRESS_NAMES
        .iter()
        .find(|b| b.replace('_', "") == head)
        .map(|b| (*b, ab.to_string()))
}

/// The stress base of exactly these lower-case names, when they form a stress group.
fn stress_base(names: &[String]) -> Option<String> {
    let groups = stress_groups(names);
    (groups.len() == 1 && groups[0].1.len() == names.len()).then(|| groups[0].0.clone())
}

/// Every stress group among the lower-case `names`: (base, indices in the names' order) with
/// xx, yy and xy or yx (or 00/11/01, 11/22/12) present, each component once.
fn stress_groups(names: &[String]) -> Vec<(String, Vec<usize>)> {
    let mut found: BTreeMap<&'static str, Vec<(String, usize)>> = BTreeMap::new();
    for (i, n) in names.iter().enumerate() {
        if let Some((base, ab)) = stress_reading(n) {
            found.entry(base).or_default().push((ab, i));
        }
    }
    let mut out = Vec::new();
    for (base, hits) in found {
        let has = |s: &[&str]| hits.iter().any(|(ab, _)| s.contains(&ab.as_str()));
        let mut seen: Vec<&str> = hits.iter().map(|(ab, _)| ab.as_str()).collect();
        seen.sort_unstable();
        let distinct = seen.windows(2).all(|w| w[0] != w[1]);
        let letters = has(&["xx"]) && has(&["yy"]) && has(&["xy", "yx"]);
        let zero = has(&["00"]) && has(&["11"]) && has(&["01", "10"]);
        let one = has(&["11"]) && has(&["22"]) && has(&["12", "21"]);
        if distinct && (letters || zero || one) {
            out.push((base.to_string(), hits.iter().map(|h| h.1).collect()));
        }
    }
    out
}

/// One array whose components are the one-component arrays `parts` of `arrays` (equal length).
fn joined(arrays: &[DataArray], parts: &[usize]) -> DataArray {
    let c = parts.len();
    let n = arrays[parts[0]].values.len();
    let mut values = vec![0.0; n * c];
    for (k, &p) in parts.iter().enumerate() {
        for (i, v) in arrays[p].values.iter().enumerate() {
            values[i * c + k] = *v;
        }
    }
    let names: Vec<String> = parts.iter().map(|&p| arrays[p].name.clone()).collect();
    let scalar = if parts
        .iter()
        .all(|&p| arrays[p].scalar == arrays[parts[0]].scalar)
    {
        arrays[parts[0]].scalar
    } else {
        Scalar::Float64
    };
    DataArray {
        name: joined_name(&names),
        scalar,
        components: c,
        component_names: names,
        values,
    }
}

fn scalar_names(arrays: &[DataArray]) -> (Vec<usize>, Vec<String>) {
    let index: Vec<usize> = (0..arrays.len())
        .filter(|&i| arrays[i].components == 1)
        .collect();
    let names = index
        .iter()
        .map(|&i| arrays[i].name.to_ascii_lowercase())
        .collect();
    (index, names)
}

/// Whether `arrays` hold a field named like `names` with one of `components` (a scalar `u`
/// beside a scalar `v` is a component, not a displacement).
fn named(arrays: &[DataArray], names: &[&str], components: &[usize]) -> bool {
    arrays.iter().any(|a| {
        components.contains(&a.components) && names.iter().any(|n| a.name.eq_ignore_ascii_case(n))
    })
}

fn quoted(parts: &[String]) -> String {
    parts
        .iter()
        .map(|p| format!("\"{}\"", p.escape_debug()))
        .collect::<Vec<_>>()
        .join(", ")
}

/// Joins the component arrays of `file` named by `scene` or auto-detected (module docs).
pub fn join(file: &mut VtuFile, scene: &Scene) -> Result<Joined> {
    let mut out = Joined::default();
    let fields = &scene.fields;
    // Named in the scene.
    for (place, parts, cells_too) in [
        ("fields.displacement", &fields.displacement_parts, false),
        ("fields.stress", &fields.stress_parts, true),
    ] {
        if parts.is_empty() {
            continue;
        }
        let find = |arrays: &[DataArray]| -> Vec<Option<usize>> {
            parts
                .iter()
                .map(|p| arrays.iter().position(|a| &a.name == p))
                .collect()
        };
        let in_points = find(&file.point_data);
        let in_cells = find(&file.cell_data);
        let (arrays, hits, section) = if in_points.iter().all(Option::is_some) {
            (&mut file.point_data, in_points, "point")
        } else if cells_too && in_cells.iter().all(Option::is_some) {
            (&mut file.cell_data, in_cells, "cell")
        } else {
            let first = parts
                .iter()
                .zip(in_points.iter().zip(&in_cells))
                .find(|(_, (p, c))| p.is_none() && (!cells_too || c.is_none()));
            let problem = match first {
                Some((p, _)) => format!(
                    "no {} array \"{}\" in {}",
                    if cells_too { "point or cell" } else { "point" },
                    p.escape_debug(),
                    file.path.display()
                ),
                None => format!(
                    "the arrays {} of {} are not all point arrays or all cell arrays",
                    quoted(parts),
                    file.path.display()
                ),
            };
            return Err(scene.error(place, problem));
        };
        let hits: Vec<usize> = hits.into_iter().flatten().collect();
        if let Some(&bad) = hits.iter().find(|&&h| arrays[h].components != 1) {
            return Err(scene.error(
                place,
                format!(
                    "{section} array \"{}\" in {} has {} components; each array of a list is \
                     one component",
                    arrays[bad].name.escape_debug(),
                    file.path.display(),
                    arrays[bad].components
                ),
            ));
        }
        let name = joined_name(parts);
        if !arrays.iter().any(|a| a.name == name) {
            let a = joined(arrays, &hits);
            arrays.push(a);
        }
        out.notes.push(format!(
            "{}: {section} arrays {} read as the components of one field (named in the scene)",
            &place["fields.".len()..],
            quoted(parts)
        ));
    }
    out.notes.extend(detect(file, fields).notes);
    Ok(out)
}

/// Joins the auto-detected component groups of `file` for the fields `fields` does not name
/// (module docs); `fosls scene` calls it with no names.
pub fn detect(file: &mut VtuFile, fields: &FieldNames) -> Joined {
    let mut out = Joined::default();
    if fields.displacement.is_none() && !named(&file.point_data, &DISPLACEMENT_NAMES, &[2, 3]) {
        let (index, names) = scalar_names(&file.point_data);
        for (_, _, order) in vector_groups(&names) {
            let parts: Vec<usize> = order.iter().map(|&k| index[k]).collect();
            let a = joined(&file.point_data, &parts);
            out.notes.push(format!(
                "displacement: point arrays {} read as the components of one vector",
                quoted(&a.component_names)
            ));
            file.point_data.push(a);
        }
    }
    if fields.stress.is_none()
        && !named(&file.point_data, &STRESS_NAMES, &[3, 4, 6, 9])
        && !named(&file.cell_data, &STRESS_NAMES, &[3, 4, 6, 9])
    {
        for (section, arrays) in [
            ("point", &mut file.point_data),
            ("cell", &mut file.cell_data),
        ] {
            let (index, names) = scalar_names(arrays);
            for (_, order) in stress_groups(&names) {
                let parts: Vec<usize> = order.iter().map(|&k| index[k]).collect();
                let a = joined(arrays, &parts);
                out.notes.push(format!(
                    "stress: {section} arrays {} read as the components of one tensor",
                    quoted(&a.component_names)
                ));
                arrays.push(a);
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::read::vtu::FileFormat;

    fn scalar(name: &str, values: &[f64]) -> DataArray {
        DataArray {
            name: name.into(),
            scalar: Scalar::Float64,
            components: 1,
            component_names: Vec::new(),
            values: values.to_vec(),
        }
    }

    /// A file of two points with the given one-component point arrays (values 10k + point).
    fn file(names: &[&str]) -> VtuFile {
        VtuFile {
            path: "f.vtu".into(),
            points: vec![[0.0; 3]; 2],
            point_components: 3,
            types: Vec::new(),
            offsets: vec![0],
            connectivity: Vec::new(),
            point_data: names
                .iter()
                .enumerate()
                .map(|(k, n)| scalar(n, &[10.0 * k as f64, 10.0 * k as f64 + 1.0]))
                .collect(),
            cell_data: Vec::new(),
            piece_points: vec![0],
            format: FileFormat::default(),
        }
    }

    fn lower(names: &[&str]) -> Vec<String> {
        names.iter().map(|n| n.to_ascii_lowercase()).collect()
    }

    /// The groups other codes write are found, in axis order whatever the array order.
    #[test]
    fn displacement_spellings_of_other_codes_form_groups() {
        for (names, order) in [
            (&["disp_y", "disp_x"][..], vec![1, 0]),
            (&["x_displacement", "y_displacement"][..], vec![0, 1]),
            (&["u[0]", "u[1]"][..], vec![0, 1]),
            (&["U1", "U2"][..], vec![0, 1]),
            (&["u_0", "u_1", "u_2"][..], vec![0, 1, 2]),
            (&["Displacement.X", "Displacement.Y"][..], vec![0, 1]),
            (&["uy", "ux", "uz"][..], vec![1, 0, 2]),
            (&["v", "u"][..], vec![1, 0]),
        ] {
            let groups = vector_groups(&lower(names));
            assert_eq!(groups.len(), 1, "{names:?}: {groups:?}");
            assert_eq!(groups[0].2, order, "{names:?}");
        }
    }

    /// No group without both x and y, with a component twice, or across spellings.
    #[test]
    fn incomplete_or_mixed_spellings_form_no_group() {
        for names in [
            &["u_x"][..],
            &["u_x", "u_z"][..],
            &["u_x", "u-y"][..],
            &["temperature", "pressure"][..],
            &["x", "y"][..],
        ] {
            assert!(vector_groups(&lower(names)).is_empty(), "{names:?}");
        }
        // A prefixed "x_u" is another spelling: "u_x" pairs with "u_y" alone.
        assert_eq!(
            vector_groups(&lower(&["u_x", "x_u", "u_y"])),
            [("u".to_string(), "suffix_".to_string(), vec![0, 2])]
        );
        // Two spellings of x beside one y: "u_x" pairs with "u_y", "ux" has no y.
        assert_eq!(
            vector_groups(&lower(&["ux", "u_x", "u_y"])),
            [("u".to_string(), "suffix_".to_string(), vec![1, 2])]
        );
        // Two complete groups are both reported (select_fields then names them as ambiguous).
        assert_eq!(
            vector_groups(&lower(&["u_x", "u_y", "disp_x", "disp_y"])).len(),
            2
        );
    }

    #[test]
    fn stress_spellings_form_groups() {
        for names in [
            &["stress_xx", "stress_yy", "stress_xy"][..],
            &["sxx", "syy", "szz", "sxy"][..],
            &["sigma_11", "sigma_22", "sigma_12"][..],
            &["S00", "S11", "S01"][..],
            &["Cauchy_Stress_xx", "Cauchy_Stress_yy", "Cauchy_Stress_yx"][..],
        ] {
            let groups = stress_groups(&lower(names));
            assert_eq!(groups.len(), 1, "{names:?}");
            assert_eq!(groups[0].1.len(), names.len(), "{names:?}");
        }
        for names in [
            &["stress_xx", "stress_yy"][..],
            &["stress_xx", "stress_xx", "stress_yy", "stress_xy"][..],
            &["strain_xx", "strain_yy", "strain_xy"][..],
        ] {
            assert!(stress_groups(&lower(names)).is_empty(), "{names:?}");
        }
    }

    /// The joined array interleaves the parts (x, y per point) and is recognised as the field.
    #[test]
    fn detected_groups_are_joined_and_named_after_their_parts() {
        let mut f = file(&[
            "disp_y",
            "T",
            "disp_x",
            "stress_xy",
            "stress_xx",
            "stress_yy",
        ]);
        let joined = detect(&mut f, &FieldNames::default());
        assert_eq!(joined.notes.len(), 2, "{:?}", joined.notes);
        let u = f
            .point_data
            .iter()
            .find(|a| a.name == "(disp_x, disp_y)")
            .unwrap();
        assert_eq!(u.components, 2);
        // disp_x is array 2 (values 20, 21), disp_y array 0 (0, 1).
        assert_eq!(u.values, [20.0, 0.0, 21.0, 1.0]);
        assert_eq!(joined_base(u).as_deref(), Some("disp"));
        let s = f
            .point_data
            .iter()
            .find(|a| a.name.starts_with("(stress"))
            .unwrap();
        assert_eq!(s.name, "(stress_xy, stress_xx, stress_yy)");
        assert_eq!(s.values, [30.0, 40.0, 50.0, 31.0, 41.0, 51.0]);
        assert_eq!(joined_base(s).as_deref(), Some("stress"));
        // A vector displacement in the file: nothing is joined for it.
        let mut g = file(&["u_x", "u_y"]);
        g.point_data.push(DataArray {
            components: 2,
            ..scalar("U", &[0.0; 4])
        });
        assert!(detect(&mut g, &FieldNames::default()).notes.is_empty());
        assert_eq!(g.point_data.len(), 3);
        // Named in the scene: not detected.
        let mut h = file(&["u_x", "u_y"]);
        let named = FieldNames {
            displacement: Some("u_x".into()),
            ..Default::default()
        };
        assert!(detect(&mut h, &named).notes.is_empty());
    }

    /// An array that merely looks like a joined name is not taken for one.
    #[test]
    fn joined_base_needs_the_parts_as_component_names() {
        let mut a = DataArray {
            components: 2,
            component_names: vec!["u_x".into(), "u_y".into()],
            ..scalar("(u_x, u_y)", &[0.0; 4])
        };
        assert_eq!(joined_base(&a).as_deref(), Some("u"));
        a.name = "u".into();
        assert_eq!(joined_base(&a), None);
        a.name = "(a, b)".into();
        a.component_names = vec!["a".into(), "b".into()];
        assert_eq!(joined_base(&a), None);
    }
}
