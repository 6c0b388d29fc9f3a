//! Finite or refused (issue 14, defects 4, 13 and 17): every number that reaches a report is
//! finite, or the run exits with status 2 and one line naming the quantity. Each case changes
//! one thing in a small fixture (scene data that overflows or is undefined somewhere, extreme
//! material data, scaled coordinates or fields, one NaN in one node copy of an exploded mesh)
//! and runs `fosls estimate --json` through the real binary.
//!
//! The checks live in the audit pipeline (`src/audit/finite.rs`): bounded inputs before any
//! work, every reported number after the estimate.

use std::path::{Path, PathBuf};
use std::process::Command;

use fosls::read::vtu::{VtuFile, parse_vtu};
use fosls::write::{Placement, to_bytes};

const BIN: &str = env!("CARGO_BIN_EXE_fosls");

fn fixture(case: &str, file: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("fixtures")
        .join(case)
        .join(file)
}

/// Runs `estimate` on `case`'s solution (changed by `vtu`) with its scene (with `from`
/// replaced by `to`); checks exit status 2, one line on stderr containing every `names`, no
/// JSON report; returns the line.
fn refused_naming(
    case: &str,
    from: &str,
    to: &str,
    vtu: impl FnOnce(&mut VtuFile),
    names: &[&str],
) -> String {
    let dir = tempfile::tempdir().unwrap();
    let scene = std::fs::read_to_string(fixture(case, "scene.toml")).unwrap();
    assert!(scene.contains(from), "{from}");
    let scene_path = dir.path().join("solution.toml");
    std::fs::write(&scene_path, scene.replacen(from, to, 1)).unwrap();
    let bytes = std::fs::read(fixture(case, "solution.vtu")).unwrap();
    let mut file = parse_vtu(Path::new("solution.vtu"), &bytes).unwrap();
    vtu(&mut file);
    let path = dir.path().join("solution.vtu");
    std::fs::write(&path, to_bytes(&file, Placement::AppendedRaw)).unwrap();
    let json = dir.path().join("r.json");
    let out = Command::new(BIN)
        .arg("estimate")
        .arg(&path)
        .arg("--json")
        .arg(&json)
        .arg("--quiet")
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    let report = std::fs::read_to_string(&json).unwrap_or_default();
    assert_eq!(
        out.status.code(),
        Some(2),
        "exit {:?}, stderr {stderr}, total {}",
        out.status.code(),
        serde_json::from_str::<serde_json::Value>(&report)
            .map(|v| v["functional"]["total"].to_string())
            .unwrap_or_default()
    );
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    for n in names {
        assert!(stderr.contains(n), "{n}: {stderr}");
    }
    assert!(!json.exists(), "a report was written for a failed run");
    stderr.trim_end().to_string()
}

const EXACT: &str = "exact_p2_energy";
const BODY: &str = "\"-29.261363636363637\"";
const LEFT: &str = "\"14.630681818181827 - 10.241477272727275*y + 2.9261363636363624*x\"";
const TOP: &str = "\"0.0005 + 0.001*x + 0.0015*y^2 - 0.00025*x^2\"";

fn same(_: &mut VtuFile) {}

fn scale_points(f: &mut VtuFile, s: f64) {
    for p in &mut f.points {
        p[0] *= s;
        p[1] *= s;
    }
}

fn scale_array(f: &mut VtuFile, name: &str, s: f64) {
    let a = f
        .point_data
        .iter_mut()
        .find(|a| a.name == name)
        .unwrap_or_else(|| panic!("no point array {name}"));
    for v in &mut a.values {
        *v *= s;
    }
}

#[test]
fn body_force_one_over_zero() {
    refused_naming(EXACT, BODY, "\"1/0\"", same, &["body_force"]);
}

#[test]
fn traction_one_over_x_at_x_0() {
    refused_naming(EXACT, LEFT, "\"1/x\"", same, &["traction", "1/x"]);
}

#[test]
fn body_force_sqrt_of_negative() {
    refused_naming(
        EXACT,
        BODY,
        "\"sqrt(x-0.5)\"",
        same,
        &["body_force", "sqrt"],
    );
}

#[test]
fn traction_log_x_at_x_0() {
    refused_naming(EXACT, LEFT, "\"log(x)\"", same, &["traction", "log(x)"]);
}

#[test]
fn body_force_exp_overflow() {
    refused_naming(EXACT, BODY, "\"exp(1000*x)\"", same, &["body_force", "exp"]);
}

#[test]
fn dirichlet_zero_over_zero() {
    refused_naming(EXACT, TOP, "\"0/0\"", same, &["displacement"]);
}

#[test]
fn body_force_1e300() {
    refused_naming(EXACT, BODY, "1e300", same, &["body_force"]);
}

#[test]
fn friction_1e308() {
    refused_naming(
        EXACT,
        "normal = \"obstacle\"",
        "normal = \"obstacle\"\nfriction = 1e308",
        same,
        &["friction"],
    );
}

#[test]
fn youngs_modulus_1e_minus_300() {
    refused_naming(
        EXACT,
        "youngs_modulus = 20600.0",
        "youngs_modulus = 1e-300",
        same,
        &["youngs_modulus"],
    );
}

#[test]
fn length_scale_1e300() {
    refused_naming(
        EXACT,
        "[estimate]",
        "[estimate]\nlength_scale = 1e300",
        same,
        &["length_scale"],
    );
}

#[test]
fn obstacle_point_1e308() {
    refused_naming(
        EXACT,
        "point = [0.0, 0.0]",
        "point = [0.0, 1e308]",
        same,
        &["obstacle"],
    );
}

/// Coordinates × 1e150: refused by the reader's range check (no longer zero-area triangles or
/// a NaN functional).
#[test]
fn coordinates_times_1e150() {
    let line = refused_naming(
        EXACT,
        "[estimate]",
        "[estimate]",
        |f| scale_points(f, 1e150),
        &["Points array", "the coordinates overflow"],
    );
    assert!(!line.contains("zero-area"), "{line}");
}

/// Defect 17: a mesh scaled by 1e300 was called "zero-area triangles".
#[test]
fn coordinates_times_1e300_overflow() {
    let line = refused_naming(
        EXACT,
        "[estimate]",
        "[estimate]",
        |f| scale_points(f, 1e300),
        &["the coordinates overflow"],
    );
    assert!(!line.contains("zero-area"), "{line}");
    // inspect says the same.
    let dir = tempfile::tempdir().unwrap();
    let bytes = std::fs::read(fixture(EXACT, "solution.vtu")).unwrap();
    let mut file = parse_vtu(Path::new("s.vtu"), &bytes).unwrap();
    scale_points(&mut file, 1e300);
    let path = dir.path().join("s.vtu");
    std::fs::write(&path, to_bytes(&file, Placement::Inline)).unwrap();
    let out = Command::new(BIN)
        .arg("inspect")
        .arg(&path)
        .arg("--quiet")
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("the coordinates overflow"), "{stderr}");
}

#[test]
fn coordinates_times_1e_minus_160() {
    refused_naming(
        EXACT,
        "[estimate]",
        "[estimate]",
        |f| scale_points(f, 1e-160),
        &["the coordinates underflow"],
    );
}

#[test]
fn displacement_times_1e200() {
    refused_naming(
        EXACT,
        "[estimate]",
        "[estimate]",
        |f| {
            let name = f.point_data[0].name.clone();
            scale_array(f, &name, 1e200)
        },
        &["displacement"],
    );
}

#[test]
fn one_nodal_value_1e308() {
    refused_naming(
        EXACT,
        "[estimate]",
        "[estimate]",
        |f| {
            // An interior node (no Dirichlet or contact constraint: used as is).
            let k = (0..f.points.len())
                .find(|&k| {
                    let p = f.points[k];
                    p[0] > 0.1 && p[0] < 1.9 && p[1] > 0.1 && p[1] < 0.9
                })
                .unwrap();
            let a = f
                .point_data
                .iter_mut()
                .find(|a| a.name == "displacement")
                .unwrap();
            a.values[a.components * k] = 1e308;
        },
        &["displacement"],
    );
}

/// Defect 13: a NaN in one node copy of an exploded mesh: `inspect` refuses the file, but
/// `estimate` merged the copies and reported a finite F.
#[test]
fn nan_in_one_node_copy_of_an_exploded_mesh() {
    refused_naming(
        "hertz_ngsolve_p1_vtkoutput",
        "[[boundary]]",
        "[[boundary]]",
        |f| {
            let a = f
                .point_data
                .iter_mut()
                .find(|a| a.name == "displacement")
                .unwrap();
            a.values[a.components * 7] = f64::NAN;
        },
        &["displacement", "NaN"],
    );
}

/// Defect 17: a NaN or fractional boundary tag became a traction-free edge with a note, where
/// `inspect` refuses it.
#[test]
fn nan_and_fractional_tags_are_refused() {
    for (value, shown) in [(f64::NAN, "NaN"), (1.5, "1.5")] {
        let mut cell = 0;
        let line = refused_naming(
            EXACT,
            "[estimate]",
            "[estimate]",
            |f| {
                let tags = f
                    .cell_data
                    .iter_mut()
                    .find(|a| a.name == "boundary_tag")
                    .unwrap();
                // The first line cell (tags on triangles are not read).
                let first = (0..f.types.len()).find(|&c| f.types[c] == 21).unwrap();
                cell = first;
                // Float64, so that the value is written as it is (an integer array would
                // hold 0 or 1).
                tags.scalar = fosls::read::decode::Scalar::Float64;
                tags.values[first] = value;
            },
            &["boundary_tag"],
        );
        assert_eq!(
            line,
            format!(
                "error: {}: cell array \"boundary_tag\": cell {cell} (a line cell) has the tag \
                 {shown}; boundary tags must be integers",
                line.split(": ").nth(1).unwrap()
            )
        );
    }
}

/// Found by `tests/fuzz_estimate.rs`: a NaN relative error (F and the energy both infinite:
/// no displacement in the file, a stress of 1e200) passed `--fail-above` (NaN > x is false)
/// and the run exited 0. It now counts as exceeding (status 1; status 2 once the estimator
/// refuses non-finite results).
#[test]
fn fail_above_never_passes_a_non_finite_estimate() {
    let dir = tempfile::tempdir().unwrap();
    let bytes = std::fs::read(fixture(EXACT, "solution.vtu")).unwrap();
    let mut file = parse_vtu(Path::new("solution.vtu"), &bytes).unwrap();
    file.point_data.retain(|a| a.name != "displacement");
    scale_array(&mut file, "stress", 1e200);
    let path = dir.path().join("solution.vtu");
    std::fs::write(&path, to_bytes(&file, Placement::AppendedRaw)).unwrap();
    std::fs::copy(
        fixture(EXACT, "scene.toml"),
        dir.path().join("solution.toml"),
    )
    .unwrap();
    let json = dir.path().join("r.json");
    let out = Command::new(BIN)
        .arg("estimate")
        .arg(&path)
        .arg("--json")
        .arg(&json)
        .args(["--fail-above", "0", "--quiet"])
        .output()
        .unwrap();
    assert!(
        matches!(out.status.code(), Some(1) | Some(2)),
        "{:?}: {}",
        out.status,
        std::fs::read_to_string(&json).unwrap_or_default()
    );
}
