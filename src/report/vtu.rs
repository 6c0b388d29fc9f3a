//! The VTU printer (`--output FILE`): the mesh as read (node copies of an exploded file
//! merged) with the indicators as cell data, for ParaView, VTK and meshio.
//!
//! Cells: the triangles (VTK type 5, or 22 for P2 meshes), then the line cells (3, or 21 for
//! quadratic edges), in mesh order; triangles of an all-clockwise input come out
//! counter-clockwise, as the mesh holds them. Points get z = 0. Vertex cells of the input are
//! not written.
//!
//! Point data: every point array of the input (averaged over node copies).
//!
//! Cell data, one tuple per cell; triangles carry the values, line cells 0 (NaN upsets
//! ParaView's colour maps), except where noted:
//!
//! | array | value on triangle T |
//! |---|---|
//! | `eta` | η_T = (max(η_T², 0))^½ |
//! | `eta_squared` | η_T², signed |
//! | `eta_constitutive`, `eta_equilibrium`, `eta_complementarity`, `eta_friction` | the term's contribution to η_T² (an energy; signed for the boundary terms), so that the four add up to `eta_squared` |
//! | `bound_squared` (only with a bound) | the cell's share of R² in the bound (docs/design.md §6.2: (η'_PS,T + (η_osc,T + η_as,T + η_tr,T)/√c_min)², units of \|\|\|·\|\|\|²; summed over the halves of a quadrilateral, §6.3) |
//! | `marked` (Int, only when marking) | 1 if marked, else 0 |
//! | `contact_state` (Int) | −1 on triangles and off Γ_C; on contact lines 0 separated, 1 stick, 2 slip |
//! | `file_cell` (Int, only when cells were split at hanging nodes, `crate::closure`) | the index in the input file of the cell T comes from; on lines, the line's |
//!
//! The cell arrays of the input follow, with their values on the triangles and on the lines
//! (an input array whose name clashes with one above gets the suffix `_input`). Fields
//! reconstructed by the estimate can be pushed onto the returned [`VtuFile`] as point or cell
//! data before writing.

use std::path::Path;

use crate::error::{Error, Result};
use crate::estimate::{ContactState, Estimate};
use crate::mesh::{Dataset, NONE};
use crate::read::decode::Scalar;
use crate::read::vtu::{DataArray, VtuFile, cell_type};
use crate::write::{Placement, write_vtu};

/// Names of the cell arrays written from the estimate.
pub const ARRAYS: [&str; 9] = [
    "eta",
    "eta_squared",
    "eta_constitutive",
    "eta_equilibrium",
    "eta_complementarity",
    "eta_friction",
    "bound_squared",
    "marked",
    "contact_state",
];

fn scalar_array(name: &str, scalar: Scalar, values: Vec<f64>) -> DataArray {
    DataArray {
        name: name.into(),
        scalar,
        components: 1,
        component_names: Vec::new(),
        values,
    }
}

/// Code of a contact state in `contact_state`.
pub fn state_code(s: Option<ContactState>) -> f64 {
    match s {
        None => -1.0,
        Some(ContactState::Separated) => 0.0,
        Some(ContactState::Stick) => 1.0,
        Some(ContactState::Slip) => 2.0,
        Some(ContactState::Contact) => 3.0,
    }
}

/// The output file for `path`: merged mesh, input point data, indicators and input cell data.
/// `marked` has one flag per triangle (mesh order).
pub fn output_file(
    path: &Path,
    data: &Dataset,
    est: &Estimate,
    marked: Option<&[bool]>,
) -> VtuFile {
    let mesh = &data.mesh;
    let nt = mesh.cells.len();
    let nl = mesh.lines.len();
    let mut cells: Vec<(u8, Vec<u32>)> = Vec::with_capacity(nt + nl);
    for t in 0..nt {
        cells.push((cell_type::of_family(mesh.family[t]), mesh.nodes(t).to_vec()));
    }
    for l in &mesh.lines {
        if l[2] == NONE {
            cells.push((cell_type::LINE, vec![l[0], l[1]]));
        } else {
            cells.push((cell_type::QUADRATIC_EDGE, l.to_vec()));
        }
    }
    let points = mesh.points.iter().map(|p| [p[0], p[1], 0.0]).collect();
    let mut file = VtuFile::from_cells(path, points, &cells);
    file.point_data = data.point_data.clone();

    // Triangle values, then zeros on the lines.
    let on_triangles = |f: &dyn Fn(usize) -> f64| -> Vec<f64> {
        (0..nt)
            .map(|t| {
                if t < super::cell_count(&est.cells) {
                    f(t)
                } else {
                    0.0
                }
            })
            .chain(std::iter::repeat_n(0.0, nl))
            .collect()
    };
    let c = &est.cells;
    let float = Scalar::Float64;
    let mut ours = vec![
        scalar_array("eta", float, on_triangles(&|t| super::cell_eta(c, t))),
        scalar_array("eta_squared", float, on_triangles(&|t| c.eta_squared(t))),
        scalar_array(
            "eta_constitutive",
            float,
            on_triangles(&|t| c.constitutive[t]),
        ),
        scalar_array(
            "eta_equilibrium",
            float,
            on_triangles(&|t| c.equilibrium[t]),
        ),
        scalar_array(
            "eta_complementarity",
            float,
            on_triangles(&|t| c.complementarity[t]),
        ),
        scalar_array("eta_friction", float, on_triangles(&|t| c.friction[t])),
    ];
    let bound = &est.bound.cells;
    if est.bound.energy_error.is_some() && bound.len() == nt {
        ours.push(scalar_array(
            "bound_squared",
            float,
            on_triangles(&|t| bound[t]),
        ));
    }
    if let Some(m) = marked {
        ours.push(scalar_array(
            "marked",
            Scalar::Int32,
            (0..nt)
                .map(|t| {
                    if m.get(t).copied().unwrap_or(false) {
                        1.0
                    } else {
                        0.0
                    }
                })
                .chain(std::iter::repeat_n(0.0, nl))
                .collect(),
        ));
    }
    ours.push(scalar_array(
        "contact_state",
        Scalar::Int32,
        std::iter::repeat_n(-1.0, nt)
            .chain((0..nl).map(|l| state_code(est.contact.line_state.get(l).copied().flatten())))
            .collect(),
    ));
    if data.report.closure.is_some() {
        let mesh = &data.mesh;
        ours.push(scalar_array(
            "file_cell",
            Scalar::Int32,
            mesh.file_cell
                .iter()
                .chain(&mesh.line_cell)
                .map(|&c| f64::from(c))
                .collect(),
        ));
    }
    file.cell_data = ours;

    // The input's cell arrays: triangle part, then line part (zeros if it is missing).
    for (k, a) in data.cell_data.iter().enumerate() {
        let w = a.components;
        let mut values = a.values.clone();
        values.resize(nt * w, 0.0);
        match data.line_data.get(k) {
            Some(b) if b.name == a.name && b.components == w && b.values.len() == nl * w => {
                values.extend_from_slice(&b.values)
            }
            _ => values.resize((nt + nl) * w, 0.0),
        }
        let name = if ARRAYS.contains(&a.name.as_str()) || a.name == "file_cell" {
            format!("{}_input", a.name)
        } else {
            a.name.clone()
        };
        file.cell_data.push(DataArray {
            name,
            values,
            ..a.clone()
        });
    }
    file
}

/// The point-wise discontinuous copy of the fields the estimate used (written next to the
/// `--output` file when a field was reconstructed): every triangle with its own copies of its
/// nodes (an exploded mesh, as NGSolve's `VTKOutput` writes), so that a stress that jumps
/// between cells (row-wise RT_k) is shown as it is, not averaged. Point data: `stress` (9
/// components, row-major, σ_zz = 0 as used; σ evaluated in the cell at each of its nodes) and
/// `displacement` (2 components). Cell data: `eta` as in [`output_file`].
pub fn discontinuous_file(
    path: &Path,
    mesh: &crate::mesh::Mesh,
    sigma: crate::estimate::StressField,
    u: &[[f64; 2]],
    est: &Estimate,
) -> VtuFile {
    let nt = mesh.cells.len();
    let total: usize = (0..nt).map(|t| mesh.family[t].nodes()).sum();
    let mut points = Vec::with_capacity(total);
    let mut cells = Vec::with_capacity(nt);
    let mut stress = Vec::with_capacity(total * 9);
    let mut displacement = Vec::with_capacity(total * 2);
    for t in 0..nt {
        let nodes = mesh.nodes(t);
        let fam = mesh.family[t];
        let nn = fam.nodes();
        let x = mesh.coords(t);
        let base = points.len() as u32;
        cells.push((
            cell_type::of_family(fam),
            (base..base + nn as u32).collect(),
        ));
        for (k, &xi) in fam.reference_nodes().iter().enumerate() {
            let p = nodes[k] as usize;
            points.push([x[k][0], x[k][1], 0.0]);
            displacement.extend_from_slice(&u[p]);
            let s = match sigma {
                crate::field::StressField::Nodal(v) => v[p],
                crate::field::StressField::Rt(rt) => rt.at_parent(mesh, t, xi).0,
            };
            stress.extend_from_slice(&tensor9(s));
        }
    }
    let mut file = VtuFile::from_cells(path, points, &cells);
    file.point_data = vec![
        tensor_array("stress", stress),
        DataArray {
            name: "displacement".into(),
            scalar: Scalar::Float64,
            components: 2,
            component_names: vec!["x".into(), "y".into()],
            values: displacement,
        },
    ];
    let c = &est.cells;
    file.cell_data = vec![scalar_array(
        "eta",
        Scalar::Float64,
        (0..nt)
            .map(|t| {
                if t < super::cell_count(c) {
                    super::cell_eta(c, t)
                } else {
                    0.0
                }
            })
            .collect(),
    )];
    file
}

/// A row-major 2×2 stress as the 9 components of a 3×3 tensor (zeros out of plane).
#[inline]
pub fn tensor9(s: [f64; 4]) -> [f64; 9] {
    [s[0], s[1], 0.0, s[2], s[3], 0.0, 0.0, 0.0, 0.0]
}

/// A 9-component tensor array (row-major `xx, xy, …, zz`, ParaView's tensor order).
pub fn tensor_array(name: &str, values: Vec<f64>) -> DataArray {
    DataArray {
        name: name.into(),
        scalar: Scalar::Float64,
        components: 9,
        component_names: ["xx", "xy", "xz", "yx", "yy", "yz", "zx", "zy", "zz"]
            .map(String::from)
            .to_vec(),
        values,
    }
}

/// The path of the discontinuous copy for `--output OUT`: `OUT` with `_discontinuous` added to
/// its stem (`out.vtu` → `out_discontinuous.vtu`).
pub fn discontinuous_path(output: &Path) -> std::path::PathBuf {
    let stem = output
        .file_stem()
        .map_or_else(|| "output".into(), |s| s.to_string_lossy().into_owned());
    output.with_file_name(format!("{stem}_discontinuous.vtu"))
}

/// Writes [`output_file`] to `path` atomically (appended raw, zlib), refusing to overwrite the
/// input file.
pub fn write(path: &Path, data: &Dataset, est: &Estimate, marked: Option<&[bool]>) -> Result<()> {
    let same = match (path.canonicalize(), data.path.canonicalize()) {
        (Ok(a), Ok(b)) => a == b,
        _ => path == data.path,
    };
    if same {
        return Err(Error::Usage(format!(
            "{}: the output file would overwrite the input; choose another --output",
            path.display()
        )));
    }
    write_vtu(
        path,
        &output_file(path, data, est, marked),
        Placement::AppendedRaw,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::read::vtu::parse_vtu;
    use crate::report::fixture;
    use crate::write::to_bytes;

    fn array<'a>(f: &'a VtuFile, name: &str) -> &'a DataArray {
        f.cell_data
            .iter()
            .find(|a| a.name == name)
            .unwrap_or_else(|| panic!("no cell array {name}"))
    }

    #[test]
    fn round_trip_holds_cells_and_arrays() {
        let data = fixture::dataset();
        let est = fixture::estimate();
        let marked = [false, true, false, true, false];
        let out = output_file(Path::new("out.vtu"), &data, &est, Some(&marked));
        for placement in [Placement::AppendedRaw, Placement::Inline] {
            let f = parse_vtu(Path::new("out.vtu"), &to_bytes(&out, placement)).unwrap();
            // 5 triangles then 3 lines; the vertex cell of the input is gone.
            assert_eq!(f.types, vec![5, 5, 5, 5, 5, 3, 3, 3]);
            assert_eq!(f.cell(0), &[0, 5, 4]);
            assert_eq!(f.cell(5), &[0, 5]);
            assert_eq!(f.cell(7), &[2, 3]);
            assert_eq!(f.points.len(), 6);
            assert_eq!(f.points[5], [0.5, 0.0, 0.0]);

            assert_eq!(f.point_data.len(), 1);
            assert_eq!(f.point_data[0].name, "displacement");
            assert_eq!(f.point_data[0].values, data.point_data[0].values);

            let names: Vec<&str> = f.cell_data.iter().map(|a| a.name.as_str()).collect();
            assert_eq!(
                names,
                [ARRAYS.as_slice(), &["boundary_tag"]].concat(),
                "cell arrays"
            );
            let zeros = [0.0; 3];
            let check = |name: &str, tri: &[f64], line: &[f64]| {
                assert_eq!(array(&f, name).values, [tri, line].concat(), "{name}");
            };
            check("eta", &[1.0, 2.0, 0.5, 2.0, 0.0], &zeros);
            check("eta_squared", &[1.0, 4.0, 0.25, 4.0, -0.5], &zeros);
            check("eta_constitutive", &[0.5, 1.0, 0.25, 3.0, 0.25], &zeros);
            check("eta_equilibrium", &[0.25, 2.5, 0.0, 1.0, 0.0], &zeros);
            check("eta_complementarity", &[0.25, 0.5, 0.0, 0.0, -0.75], &zeros);
            check("eta_friction", &[0.0; 5], &zeros);
            check("bound_squared", &[0.5, 1.0, 0.25, 2.0, 0.0], &zeros);
            check("marked", &[0.0, 1.0, 0.0, 1.0, 0.0], &zeros);
            check("contact_state", &[-1.0; 5], &[1.0, 0.0, -1.0]);
            check("boundary_tag", &[0.0; 5], &[1.0, 1.0, 2.0]);
            assert!(array(&f, "marked").scalar.is_integer());
            assert!(array(&f, "contact_state").scalar.is_integer());
            assert!(!array(&f, "eta").scalar.is_integer());
            // Every cell array has one tuple per cell.
            assert!(f.cell_data.iter().all(|a| a.tuples() == 8));
        }
    }

    #[test]
    fn quadratic_cells_clashing_names_and_no_marking() {
        // One P2 triangle with a quadratic edge (type 21) and a straight line (stays type 3),
        // and an input cell array named like one of ours.
        let pts = vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.5, 0.0, 0.0],
            [0.5, 0.5, 0.0],
            [0.0, 0.5, 0.0],
        ];
        let mut input = VtuFile::from_cells(
            Path::new("p2.vtu"),
            pts,
            &[
                (22, vec![0, 1, 2, 3, 4, 5]),
                (21, vec![0, 1, 3]),
                (3, vec![2, 0]),
            ],
        );
        input.cell_data.push(DataArray {
            name: "eta".into(),
            scalar: Scalar::Float64,
            components: 2,
            component_names: vec!["a".into(), "b".into()],
            values: vec![7.0, 8.0, 1.0, 2.0, 3.0, 4.0],
        });
        let data = crate::mesh::build(input).unwrap();
        let mut est = fixture::estimate();
        est.cells = crate::estimate::CellTerms {
            constitutive: vec![2.0],
            equilibrium: vec![2.0],
            complementarity: vec![0.0],
            friction: vec![0.0],
        };
        est.contact.line_state = vec![Some(ContactState::Slip), None];
        let out = output_file(Path::new("o.vtu"), &data, &est, None);
        let f = parse_vtu(Path::new("o.vtu"), &to_bytes(&out, Placement::AppendedRaw)).unwrap();
        assert_eq!(f.types, vec![22, 21, 3]);
        assert_eq!(f.cell(0), &[0, 1, 2, 3, 4, 5]);
        assert_eq!(f.cell(1), &[0, 1, 3]);
        assert_eq!(f.cell(2), &[2, 0]);
        assert!(f.cell_data.iter().all(|a| a.name != "marked"));
        assert_eq!(array(&f, "eta").values, vec![2.0, 0.0, 0.0]);
        assert_eq!(array(&f, "contact_state").values, vec![-1.0, 2.0, -1.0]);
        let old = array(&f, "eta_input");
        assert_eq!(old.values, vec![7.0, 8.0, 1.0, 2.0, 3.0, 4.0]);
        assert_eq!(old.component_names, vec!["a", "b"]);
    }

    #[test]
    fn write_is_atomic_and_never_overwrites_the_input() {
        let dir = tempfile::tempdir().unwrap();
        let input = dir.path().join("in.vtu");
        std::fs::write(&input, b"input").unwrap();
        let mut data = fixture::dataset();
        data.path = input.clone();
        let est = fixture::estimate();
        let e = write(&input, &data, &est, None).unwrap_err().to_string();
        assert!(e.contains("would overwrite the input"), "{e}");
        // Also through another spelling of the same path.
        let other = dir.path().join(".").join("in.vtu");
        assert!(write(&other, &data, &est, None).is_err());
        assert_eq!(std::fs::read(&input).unwrap(), b"input");

        let out = dir.path().join("out.vtu");
        write(&out, &data, &est, None).unwrap();
        let f = crate::read::vtu::read_vtu(&out).unwrap();
        assert_eq!(f.cell_count(), 8);
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 2);
    }
}
