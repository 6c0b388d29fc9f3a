//! Containers end to end (issue 12): the real binary on one DOLFINx Hertz solution written as
//! `.pvd`, `.pvtu` (one piece, and two MPI ranks with ghost cells), the piece `.vtu` and XDMF +
//! HDF5 (with `--features xdmf`), and on the scikit-fem Hertz solution rewritten here as legacy
//! VTK (ASCII and BINARY, versions 4.2 and 5.1, two layouts of the cells). Every container of
//! one solution must give the same F; broken files of every format give one line and exit 2.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use fosls::read::vtu::{DataArray, VtuFile, read_vtu};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn fixture(path: &str) -> PathBuf {
    root().join("fixtures").join(path)
}

fn fosls(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_fosls"))
        .args(args)
        .current_dir(root())
        .output()
        .unwrap()
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// F (`functional.total`) of `fosls estimate FILE --json - --quiet ARGS…`.
fn f_total(file: &Path, args: &[&str]) -> f64 {
    let mut all = vec!["estimate", s(file), "--json", "-", "--quiet"];
    all.extend_from_slice(args);
    let out = fosls(&all);
    assert!(
        out.status.code() == Some(0),
        "{}: exit {:?}: {}",
        file.display(),
        out.status.code(),
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    v["functional"]["total"].as_f64().unwrap()
}

/// `fosls inspect FILE --json - ARGS…`, parsed.
fn inspect(file: &Path, args: &[&str]) -> serde_json::Value {
    let mut all = vec!["inspect", s(file), "--json", "-"];
    all.extend_from_slice(args);
    let out = fosls(&all);
    assert!(
        out.status.code() == Some(0),
        "{}: exit {:?}: {}",
        file.display(),
        out.status.code(),
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

/// Runs `args`, expects exit status 2 and one line on stderr naming `name`; returns it.
fn refused(args: &[&str], name: &str) -> String {
    let out = fosls(args);
    let err = String::from_utf8_lossy(&out.stderr).to_string();
    assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
    assert!(!err.contains("panicked"), "{args:?}: {err}");
    assert_eq!(err.trim_end().lines().count(), 1, "{args:?}: {err}");
    assert!(err.contains(name), "{args:?}: {err} does not name {name}");
    err
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

const FILE_FIELDS: [&str; 4] = ["--stress", "file", "--displacement", "file"];

/// The DOLFINx Hertz solution's scene (no stress layout: the padded tensor is detected).
fn dolfinx_scene() -> PathBuf {
    fixture("dolfinx_hertz_p2_vtkfile/scene.toml")
}

fn dolfinx_f(file: &Path) -> f64 {
    let scene = dolfinx_scene();
    let mut args = vec!["--scene", s(&scene)];
    args.extend_from_slice(&FILE_FIELDS);
    f_total(file, &args)
}

#[test]
fn one_dolfinx_solution_gives_one_f_in_every_vtk_container() {
    let serial = fixture("dolfinx_hertz_p2_vtkfile");
    let piece = dolfinx_f(&serial.join("solution_p0_000000.vtu"));
    assert!(piece > 0.0 && piece.is_finite(), "{piece}");
    for f in ["solution000000.pvtu", "solution.pvd"] {
        let v = dolfinx_f(&serial.join(f));
        assert!(
            rel(v, piece) <= 1e-10,
            "{f}: F {v} against the piece's {piece}"
        );
    }
    // Two MPI ranks: ghost cells dropped, the interface points merged; the partition changes
    // the order of the sums and the stress projection by 6.5e-11 (README of the fixture).
    let mpi = fixture("dolfinx_hertz_p2_vtkfile_mpi2");
    for f in ["solution000000.pvtu", "solution.pvd"] {
        let v = dolfinx_f(&mpi.join(f));
        eprintln!(
            "2 ranks, {f}: F {v:.16e}, relative difference {:.1e}",
            rel(v, piece)
        );
        assert!(rel(v, piece) <= 1e-8, "2 ranks, {f}: F {v} against {piece}");
    }
    let j = inspect(&mpi.join("solution.pvd"), &[]);
    assert_eq!(j["mesh_points"], 1664);
    let container = j["format"]["container"].as_str().unwrap();
    assert!(
        container.starts_with("PVD step 0 (t = 0; 1 step in all) → PVTU of 2 pieces")
            && container.contains("26 ghost cells dropped"),
        "{container}"
    );
    // The bookkeeping arrays are no fields.
    let arrays = |k: &str| -> Vec<String> {
        j[k].as_array()
            .unwrap()
            .iter()
            .map(|a| a["name"].as_str().unwrap().to_string())
            .collect()
    };
    assert_eq!(arrays("point_arrays"), vec!["displacement", "stress"]);
    assert!(
        arrays("cell_arrays").is_empty(),
        "{:?}",
        arrays("cell_arrays")
    );
}

#[test]
fn version_2_2_pieces_are_read_directly() {
    // DOLFINx and MFEM write version="2.2"; each piece of a .pvtu is a .vtu of its own.
    for p in [
        "dolfinx_hertz_p2_vtkfile_mpi2/solution_p1_000000.vtu",
        "mfem_hertz_p2_highorder/solution/Cycle000000/proc000000.vtu",
    ] {
        let file = fixture(p);
        let head = std::fs::read_to_string(&file).unwrap();
        assert!(head[..400].contains("version=\"2.2\""), "{p}");
        let j = inspect(&file, &[]);
        assert!(j["mesh_points"].as_u64().unwrap() > 0, "{p}");
    }
    // A piece with ghost cells read alone: its ghost cells are dropped too.
    let j = inspect(
        &fixture("dolfinx_hertz_p2_vtkfile_mpi2/solution_p1_000000.vtu"),
        &[],
    );
    let container = j["format"]["container"].as_str().unwrap();
    assert!(
        container.starts_with("VTU (13 ghost cells dropped"),
        "{container}"
    );
}

#[test]
fn mfem_collection_gives_the_f_of_its_piece() {
    let dir = fixture("mfem_hertz_p2_highorder");
    let scene = dir.join("scene.toml");
    let mut args = vec!["--scene", s(&scene)];
    args.extend_from_slice(&FILE_FIELDS);
    let piece = f_total(&dir.join("solution/Cycle000000/proc000000.vtu"), &args);
    let pvd = f_total(&dir.join("solution/solution.pvd"), &args);
    assert!(rel(pvd, piece) <= 1e-12, "{pvd} against {piece}");
}

#[cfg(feature = "xdmf")]
#[test]
fn xdmf_gives_the_f_of_the_vtk_files() {
    let piece = dolfinx_f(&fixture("dolfinx_hertz_p2_vtkfile/solution_p0_000000.vtu"));
    let xdmf = fixture("dolfinx_hertz_p2_xdmf/solution.xdmf");
    let v = dolfinx_f(&xdmf);
    eprintln!(
        "XDMF: F {v:.16e}, relative difference {:.1e}",
        rel(v, piece)
    );
    assert!(rel(v, piece) <= 1e-10, "XDMF F {v} against {piece}");
    // Its own scene selects the boundaries by the facet tags: the same edges, the same F.
    let own = fixture("dolfinx_hertz_p2_xdmf/scene.toml");
    let mut args = vec!["--scene", s(&own)];
    args.extend_from_slice(&FILE_FIELDS);
    let t = f_total(&xdmf, &args);
    assert!(
        rel(t, piece) <= 1e-10,
        "XDMF with tags: F {t} against {piece}"
    );
    let j = inspect(&xdmf, &[]);
    // DOLFINx 0.11 writes Triangle_6 in VTK's node order: nothing is permuted.
    let container = j["format"]["container"].as_str().unwrap();
    assert_eq!(
        container,
        "XDMF 3.0 step 0 (t = 0; 1 step in all), 113 tagged facets"
    );
    let tags = &j["tag_arrays"];
    assert!(
        tags.to_string().contains("facet_tags"),
        "no facet_tags among the tag arrays: {tags}"
    );
    // Broken heavy data: a missing HDF5 file, a missing dataset.
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(&xdmf).unwrap();
    let copy = dir.path().join("solution.xdmf");
    std::fs::write(&copy, &text).unwrap();
    refused(&["inspect", s(&copy)], "solution.h5 does not exist");
    std::fs::copy(
        fixture("dolfinx_hertz_p2_xdmf/solution.h5"),
        dir.path().join("solution.h5"),
    )
    .unwrap();
    std::fs::write(
        &copy,
        text.replace("/Function/stress/0", "/Function/stress/7"),
    )
    .unwrap();
    refused(&["inspect", s(&copy)], "/Function/stress/7");
}

#[cfg(not(feature = "xdmf"))]
#[test]
fn xdmf_without_the_feature_says_how_to_build_it() {
    let xdmf = fixture("dolfinx_hertz_p2_xdmf/solution.xdmf");
    let e = refused(&["estimate", s(&xdmf)], "solution.xdmf");
    assert!(
        e.trim_end().ends_with(
            "solution.xdmf: XDMF needs fosls built with --features xdmf (and libhdf5-dev): \
             cargo build --release --features xdmf"
        ),
        "{e}"
    );
}

/// How a legacy file is written.
#[derive(Clone, Copy, Debug)]
struct Legacy {
    binary: bool,
    /// 5.1: OFFSETS/CONNECTIVITY; else 4.2 with counts before each cell.
    v51: bool,
    /// Arrays as FIELD data (any component count), else SCALARS/VECTORS.
    field: bool,
}

/// Writes `f` as a legacy VTK file in the layout `how`.
fn write_legacy(f: &VtuFile, how: Legacy) -> Vec<u8> {
    let mut out = Vec::new();
    let version = if how.v51 { "5.1" } else { "4.2" };
    let mode = if how.binary { "BINARY" } else { "ASCII" };
    out.extend_from_slice(
        format!("# vtk DataFile Version {version}\nwritten by tests/containers.rs\n{mode}\nDATASET UNSTRUCTURED_GRID\n")
            .as_bytes(),
    );
    let floats = |out: &mut Vec<u8>, v: &[f64]| {
        if how.binary {
            for x in v {
                out.extend_from_slice(&x.to_be_bytes());
            }
        } else {
            for (k, x) in v.iter().enumerate() {
                out.extend_from_slice(format!("{x:e}").as_bytes());
                out.push(if k % 9 == 8 { b'\n' } else { b' ' });
            }
        }
        out.push(b'\n');
    };
    let ints32 = |out: &mut Vec<u8>, v: &[i64]| {
        if how.binary {
            for &x in v {
                out.extend_from_slice(&(x as i32).to_be_bytes());
            }
        } else {
            for x in v {
                out.extend_from_slice(format!("{x} ").as_bytes());
            }
        }
        out.push(b'\n');
    };
    let ints64 = |out: &mut Vec<u8>, v: &[i64]| {
        if how.binary {
            for &x in v {
                out.extend_from_slice(&x.to_be_bytes());
            }
        } else {
            for x in v {
                out.extend_from_slice(format!("{x}\n").as_bytes());
            }
        }
    };
    // Data-set field data and point metadata, which the reader skips.
    out.extend_from_slice(b"FIELD FieldData 1\nTIME 1 1 double\n");
    floats(&mut out, &[0.0]);
    out.extend_from_slice(format!("POINTS {} double\n", f.points.len()).as_bytes());
    let xyz: Vec<f64> = f.points.iter().flatten().copied().collect();
    floats(&mut out, &xyz);
    out.extend_from_slice(b"METADATA\nINFORMATION 0\n\n");
    let n = f.cell_count();
    if how.v51 {
        out.extend_from_slice(
            format!(
                "CELLS {} {}\nOFFSETS vtktypeint64\n",
                n + 1,
                f.connectivity.len()
            )
            .as_bytes(),
        );
        let o: Vec<i64> = f.offsets.iter().map(|&o| o as i64).collect();
        ints64(&mut out, &o);
        out.extend_from_slice(b"CONNECTIVITY vtktypeint64\n");
        let c: Vec<i64> = f.connectivity.iter().map(|&v| v as i64).collect();
        ints64(&mut out, &c);
    } else {
        out.extend_from_slice(format!("CELLS {n} {}\n", n + f.connectivity.len()).as_bytes());
        let mut list = Vec::new();
        for c in 0..n {
            list.push(f.cell(c).len() as i64);
            list.extend(f.cell(c).iter().map(|&v| v as i64));
        }
        ints32(&mut out, &list);
    }
    out.extend_from_slice(format!("CELL_TYPES {n}\n").as_bytes());
    let t: Vec<i64> = f.types.iter().map(|&t| t as i64).collect();
    ints32(&mut out, &t);
    let arrays = |out: &mut Vec<u8>, list: &[DataArray]| {
        if how.field {
            out.extend_from_slice(format!("FIELD FieldData {}\n", list.len()).as_bytes());
            for a in list {
                out.extend_from_slice(
                    format!("{} {} {} double\n", a.name, a.components, a.tuples()).as_bytes(),
                );
                floats(out, &a.values);
            }
            return;
        }
        for a in list {
            out.extend_from_slice(
                format!(
                    "SCALARS {} double {}\nLOOKUP_TABLE default\n",
                    a.name, a.components
                )
                .as_bytes(),
            );
            floats(out, &a.values);
            if !a.component_names.is_empty() {
                out.extend_from_slice(b"METADATA\nCOMPONENT_NAMES\n");
                for c in &a.component_names {
                    out.extend_from_slice(format!("{c}\n").as_bytes());
                }
                out.push(b'\n');
            }
        }
    };
    out.extend_from_slice(format!("POINT_DATA {}\n", f.points.len()).as_bytes());
    arrays(&mut out, &f.point_data);
    // A cell array on every cell, unused by the scene.
    let region = DataArray {
        name: "region".into(),
        scalar: fosls::read::decode::Scalar::Int32,
        components: 1,
        component_names: Vec::new(),
        values: (0..n).map(|c| (c % 3) as f64).collect(),
    };
    out.extend_from_slice(format!("CELL_DATA {n}\n").as_bytes());
    arrays(&mut out, &[region]);
    out
}

const LAYOUTS: [Legacy; 4] = [
    Legacy {
        binary: false,
        v51: false,
        field: false,
    },
    Legacy {
        binary: true,
        v51: false,
        field: true,
    },
    Legacy {
        binary: false,
        v51: true,
        field: true,
    },
    Legacy {
        binary: true,
        v51: true,
        field: false,
    },
];

#[test]
fn legacy_vtk_ascii_and_binary_give_the_f_of_the_vtu() {
    let vtu = fixture("hertz_skfem_p2/solution.vtu");
    let scene = fixture("hertz_skfem_p2/scene.toml");
    let mut args = vec!["--scene", s(&scene)];
    args.extend_from_slice(&FILE_FIELDS);
    let reference = f_total(&vtu, &args);
    let f = read_vtu(&vtu).unwrap();
    let dir = tempfile::tempdir().unwrap();
    for how in LAYOUTS {
        let path = dir.path().join(format!(
            "hertz_{}_{}_{}.vtk",
            if how.binary { "binary" } else { "ascii" },
            if how.v51 { "51" } else { "42" },
            if how.field { "field" } else { "scalars" }
        ));
        std::fs::write(&path, write_legacy(&f, how)).unwrap();
        let v = f_total(&path, &args);
        eprintln!(
            "{how:?}: F {v:.16e}, relative difference {:.1e}",
            rel(v, reference)
        );
        assert!(
            rel(v, reference) <= 1e-12,
            "{how:?}: F {v} against the VTU's {reference}"
        );
        let j = inspect(&path, &[]);
        let container = j["format"]["container"].as_str().unwrap();
        assert!(container.starts_with("legacy VTK"), "{container}");
        assert_eq!(j["cell_arrays"][0]["name"], "region", "{how:?}");
    }
    // An XML file named .vtk is read as the VTU it is.
    let xml = dir.path().join("xml.vtk");
    std::fs::copy(&vtu, &xml).unwrap();
    assert_eq!(f_total(&xml, &args), reference);
}

#[test]
fn broken_files_of_every_format_get_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let write = |name: &str, bytes: &[u8]| -> PathBuf {
        let p = d.join(name);
        std::fs::write(&p, bytes).unwrap();
        p
    };
    let serial = fixture("dolfinx_hertz_p2_vtkfile");
    let pvtu_text = std::fs::read_to_string(serial.join("solution000000.pvtu")).unwrap();
    let piece = std::fs::read(serial.join("solution_p0_000000.vtu")).unwrap();

    // PVTU: a missing piece, a truncated index, a wrong declared component count, a truncated
    // piece.
    let p = write("missing.pvtu", pvtu_text.as_bytes());
    let e = refused(&["inspect", s(&p)], "missing.pvtu");
    assert!(
        e.contains("solution_p0_000000.vtu does not exist (missing piece)"),
        "{e}"
    );
    let p = write("cut.pvtu", &pvtu_text.as_bytes()[..pvtu_text.len() / 2]);
    let e = refused(&["inspect", s(&p)], "cut.pvtu");
    assert!(e.contains("truncated file?"), "{e}");
    write("solution_p0_000000.vtu", &piece);
    let bad = pvtu_text.replace(
        "Name=\"displacement\" NumberOfComponents=\"3\"",
        "Name=\"displacement\" NumberOfComponents=\"2\"",
    );
    let p = write("count.pvtu", bad.as_bytes());
    let e = refused(&["inspect", s(&p)], "solution_p0_000000.vtu");
    assert!(
        e.contains("point array \"displacement\": has 3 components, 2 in the PVTU"),
        "{e}"
    );
    let p = write(
        "cutpiece.pvtu",
        pvtu_text.replace("solution_p0", "cut_p0").as_bytes(),
    );
    write("cut_p0_000000.vtu", &piece[..piece.len() * 2 / 3]);
    refused(&["inspect", s(&p)], "cut_p0_000000.vtu");
    let _ = p;

    // PVD: a missing data set, a truncated collection, a bad timestep, a step out of range,
    // --step on a single data set.
    let pvd = std::fs::read_to_string(serial.join("solution.pvd")).unwrap();
    let p = write(
        "missing.pvd",
        pvd.replace("solution000000", "nothing").as_bytes(),
    );
    let e = refused(&["inspect", s(&p)], "missing.pvd");
    assert!(e.contains("nothing.pvtu does not exist"), "{e}");
    let p = write("cut.pvd", &pvd.as_bytes()[..pvd.len() - 40]);
    let e = refused(&["inspect", s(&p)], "cut.pvd");
    assert!(e.contains("truncated file?"), "{e}");
    let p = write(
        "time.pvd",
        pvd.replace("timestep=\"0\"", "timestep=\"x\"").as_bytes(),
    );
    refused(&["inspect", s(&p)], "\"x\" is not a finite number");
    let pvd_path = serial.join("solution.pvd");
    let e = refused(&["inspect", s(&pvd_path), "--step", "3"], "solution.pvd");
    assert!(
        e.contains("the collection has 1 time step (--step 0 to 0"),
        "{e}"
    );
    let vtu = serial.join("solution_p0_000000.vtu");
    refused(
        &["estimate", s(&vtu), "--step", "0"],
        "is a single data set",
    );

    // Legacy VTK: truncated, a bad CELLS size, a bad POINTS count, a binary file cut short.
    let f = read_vtu(&fixture("hertz_skfem_p1/solution.vtu")).unwrap();
    for how in [LAYOUTS[0], LAYOUTS[1]] {
        let text = write_legacy(&f, how);
        let tag = if how.binary { "binary" } else { "ascii" };
        let p = write(&format!("cut_{tag}.vtk"), &text[..text.len() * 3 / 4]);
        let e = refused(&["inspect", s(&p)], &format!("cut_{tag}.vtk"));
        assert!(e.contains("truncated file?"), "{e}");
        let mut bad = text.clone();
        let at = memfind(&bad, b"CELLS ");
        let line_end = at + bad[at..].iter().position(|&c| c == b'\n').unwrap();
        let line = String::from_utf8(bad[at..line_end].to_vec()).unwrap();
        let mut w = line.split_whitespace().skip(1);
        let (n, size): (usize, usize) = (
            w.next().unwrap().parse().unwrap(),
            w.next().unwrap().parse().unwrap(),
        );
        bad.splice(at..line_end, format!("CELLS {n} {}", size + 1).into_bytes());
        let p = write(&format!("cells_{tag}.vtk"), &bad);
        refused(&["inspect", s(&p)], &format!("cells_{tag}.vtk"));
    }
    let text = String::from_utf8(write_legacy(&f, LAYOUTS[0])).unwrap();
    let np = f.points.len();
    let p = write(
        "points.vtk",
        text.replace(
            &format!("POINTS {np} double"),
            &format!("POINTS {} double", np + 1),
        )
        .as_bytes(),
    );
    let e = refused(&["inspect", s(&p)], "points.vtk");
    assert!(e.contains("POINTS (line"), "{e}");
    let p = write(
        "polydata.vtk",
        text.replace("UNSTRUCTURED_GRID", "POLYDATA").as_bytes(),
    );
    refused(&["inspect", s(&p)], "fosls reads DATASET UNSTRUCTURED_GRID");

    // XDMF: truncated, a bad count (without the feature, with inline data).
    let xdmf = std::fs::read_to_string(fixture("dolfinx_hertz_p2_xdmf/solution.xdmf")).unwrap();
    let p = write("cut.xdmf", &xdmf.as_bytes()[..xdmf.len() / 2]);
    let e = refused(&["inspect", s(&p)], "cut.xdmf");
    assert!(e.contains("truncated file?"), "{e}");
    let p = write(
        "count.xdmf",
        xdmf.replace("NumberOfElements=\"775\"", "NumberOfElements=\"776\"")
            .replace(
                "<DataItem Dimensions=\"775 6\" NumberType=\"Int\" Format=\"HDF\">solution.h5:/Mesh/mesh/topology</DataItem>",
                "<DataItem Dimensions=\"775 6\" NumberType=\"Int\" Format=\"XML\">0 1 2</DataItem>",
            )
            .replace(
                "<DataItem Dimensions=\"1664 2\" Format=\"HDF\">solution.h5:/Mesh/mesh/geometry</DataItem>",
                "<DataItem Dimensions=\"3 2\" Format=\"XML\">0 0 1 0 0 1</DataItem>",
            )
            .as_bytes(),
    );
    let e = refused(&["inspect", s(&p)], "count.xdmf");
    assert!(
        e.contains("Dimensions \"775 6\" need 4650 values, the data has 3"),
        "{e}"
    );
}

fn memfind(hay: &[u8], needle: &[u8]) -> usize {
    hay.windows(needle.len()).position(|w| w == needle).unwrap()
}

#[test]
fn pvd_steps_are_chosen_by_index_and_time() {
    // Three steps on two different solutions: t = 0 and 1 the P1 file, t = 0.5 the P2 file.
    let dir = tempfile::tempdir().unwrap();
    let p1 = fixture("hertz_skfem_p1/solution.vtu");
    let p2 = fixture("hertz_skfem_p2/solution.vtu");
    let pvd = format!(
        r#"<?xml version="1.0"?>
<VTKFile type="Collection" version="0.1">
  <Collection>
    <DataSet timestep="1" part="0" file="{}"/>
    <DataSet timestep="0" part="0" file="{}"/>
    <DataSet timestep="0.5" part="0" file="{}"/>
  </Collection>
</VTKFile>
"#,
        s(&p1),
        s(&p1),
        s(&p2)
    );
    let path = dir.path().join("steps.pvd");
    std::fs::write(&path, pvd).unwrap();
    let degree = |args: &[&str]| inspect(&path, args)["degree"].as_u64().unwrap();
    assert_eq!(degree(&[]), 1, "the last step (t = 1)");
    assert_eq!(degree(&["--step", "1"]), 2);
    assert_eq!(degree(&["--step", "0"]), 1);
    assert_eq!(degree(&["--time", "0.6"]), 2);
    assert_eq!(degree(&["--time", "0.9"]), 1);
    let j = inspect(&path, &["--time", "0.4"]);
    let c = j["format"]["container"].as_str().unwrap();
    assert!(
        c.starts_with("PVD step 1 (t = 0.5; 3 steps in all) → VTU"),
        "{c}"
    );
    // The estimate reads the same step: F of the P2 file.
    let scene = fixture("hertz_skfem_p2/scene.toml");
    let mut args = vec!["--scene", s(&scene), "--step", "1"];
    args.extend_from_slice(&FILE_FIELDS);
    let a = f_total(&path, &args);
    let mut args = vec!["--scene", s(&scene)];
    args.extend_from_slice(&FILE_FIELDS);
    let b = f_total(&p2, &args);
    assert_eq!(a, b);
    let out = fosls(&["inspect", s(&path), "--step", "1", "--time", "0.5"]);
    assert_eq!(out.status.code(), Some(2), "--step and --time together");
}
