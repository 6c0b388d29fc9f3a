//! Files written by other codes (issue 12): DOLFINx 0.11 `VTKFile` pieces (Lagrange cells,
//! the padded 9-component tensor) and PyMFEM 4.10's low-order `ParaViewDataCollection`
//! (every element refined into linear cells, points shared only inside an element), from
//! `reference/othercodes/`. Independent sources: the solvers' reactions and the contact
//! widths in `expected.json`, and scikit-fem's solution of the same problem on the same mesh.

use std::path::{Path, PathBuf};
use std::process::Command;

use serde::Deserialize;
use serde_json::Value;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

#[derive(Debug, Deserialize)]
struct Functional {
    total: f64,
}

#[derive(Debug, Deserialize)]
struct ContactReport {
    active_length: f64,
    normal_force: f64,
}

#[derive(Debug, Deserialize)]
struct BoundaryInfo {
    name: String,
    length: f64,
}

#[derive(Debug, Deserialize)]
struct Report {
    functional: Functional,
    contact: ContactReport,
    boundaries: Vec<BoundaryInfo>,
    notes: Vec<String>,
}

fn estimate(file: &Path, scene: &Path, args: &[&str]) -> Report {
    let out = Command::new(env!("CARGO_BIN_EXE_fosls"))
        .arg("estimate")
        .arg(file)
        .arg("--scene")
        .arg(scene)
        .args(["--json", "-", "--quiet"])
        .args(args)
        .output()
        .unwrap();
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

fn expected(case: &str) -> Value {
    let p = root().join("fixtures").join(case).join("expected.json");
    serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap()
}

#[test]
fn dolfinx_padded_tensor_is_detected_and_the_force_is_right() {
    let dir = root().join("fixtures/dolfinx_hertz_p2_vtkfile");
    let file = dir.join("solution_p0_000000.vtu");
    let scene = dir.join("scene.toml");
    let e = expected("dolfinx_hertz_p2_vtkfile");
    let p = e["hertz"]["P_solver"].as_f64().unwrap();
    let two_a = e["hertz"]["two_a"].as_f64().unwrap();
    // No layout in the scene: the padded xx, xy, yx, yy, 0, 0, 0, 0, 0 must be recognised.
    let d = estimate(&file, &scene, &[]);
    assert!(
        d.notes
            .iter()
            .any(|n| n.contains("DOLFINx's padded 2×2 tensor")),
        "{:?}",
        d.notes
    );
    let force = d.contact.normal_force;
    assert!(((force - p) / p).abs() < 0.01, "{force} against {p}");
    let len = d.contact.active_length;
    assert!(
        ((len - two_a) / two_a).abs() < 0.03,
        "{len} against {two_a}"
    );
    // The file's own fields: the same F as scikit-fem's solution of the same problem on the
    // same mesh (same active set; the stress projections agree to the solvers' round-off).
    let f = estimate(
        &file,
        &scene,
        &["--stress", "file", "--displacement", "file"],
    );
    let skfem = root().join("fixtures/hertz_skfem_p2");
    let s = estimate(
        &skfem.join("solution.vtu"),
        &skfem.join("scene.toml"),
        &["--stress", "file", "--displacement", "file"],
    );
    let rel = (f.functional.total - s.functional.total).abs() / s.functional.total;
    assert!(
        rel < 1e-5,
        "F {} against {}",
        f.functional.total,
        s.functional.total
    );
}

#[test]
fn mfem_low_order_output_is_merged_like_an_exploded_mesh() {
    let dir = root().join("fixtures/mfem_hertz_p2_loworder");
    let file = dir.join("solution/Cycle000000/proc000000.vtu");
    let scene = dir.join("scene.toml");
    let e = expected("mfem_hertz_p2_loworder");
    let p = e["hertz"]["P_solver"].as_f64().unwrap();
    let two_a = e["hertz"]["two_a"].as_f64().unwrap();
    let d = estimate(&file, &scene, &[]);
    assert!(
        d.notes.iter().any(|n| n.contains("exploded mesh")),
        "{:?}",
        d.notes
    );
    let force = d.contact.normal_force;
    assert!(((force - p) / p).abs() < 0.01, "{force} against {p}");
    let len = d.contact.active_length;
    assert!(
        ((len - two_a) / two_a).abs() < 0.03,
        "{len} against {two_a}"
    );
    // Γ_C is the arc below y = 1/2: length 2π/3 (polygonal: within 1e-3).
    let gc = d
        .boundaries
        .iter()
        .find(|b| b.name == "contact")
        .expect("a contact boundary");
    assert!(
        (gc.length - 2.0 * std::f64::consts::PI / 3.0).abs() < 1e-3,
        "{}",
        gc.length
    );
}
