//! Files written by other codes (issue 12): DOLFINx 0.11 `VTKFile` pieces (Lagrange cells,
//! the padded 9-component tensor) and PyMFEM 4.10's low-order `ParaViewDataCollection`
//! (every element refined into linear cells, points shared only inside an element), from
//! `reference/othercodes/`. Independent sources: the solvers' reactions and the contact
//! widths in `expected.json`, and scikit-fem's solution of the same problem on the same mesh.
//! And MFEM's output of a non-conforming quadrilateral mesh (`reference/nonconforming/`),
//! refused naming a hanging vertex that VTK's reader finds too.

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

/// Every Hertz contact fixture in default mode (issue 12): the normal force within 1 % of the
/// solver's reaction and the active length within 3 % of 2a = 2√(4PR/(πE*)) as one contact
/// interval without islands.
#[test]
fn default_mode_contact_zone_on_every_hertz_fixture() {
    #[derive(Debug, Deserialize)]
    struct Interval {
        state: String,
        length: f64,
    }
    #[derive(Debug, Deserialize)]
    struct Zone {
        normal_force: f64,
        normal_force_stress: f64,
        normal_force_from: String,
        active_length: f64,
        intervals: Vec<Interval>,
    }
    #[derive(Debug, Deserialize)]
    struct Out {
        contact: Zone,
    }
    let mut checked = 0;
    for entry in std::fs::read_dir(root().join("fixtures")).unwrap() {
        let case = entry.unwrap().file_name().to_string_lossy().into_owned();
        if !(case.starts_with("hertz_") || case.starts_with("quad_hertz_")) {
            continue;
        }
        let dir = root().join("fixtures").join(&case);
        let e = expected(&case);
        // The solver's reaction at the top.
        let p = e["hertz"]["P_solver"]
            .as_f64()
            .or_else(|| e["solver"]["reaction_top"]["P"].as_f64())
            .unwrap_or_else(|| panic!("{case}: no solver reaction"));
        let nu = if case.contains("nu05") { 0.5 } else { 0.28 };
        let e_star = 20600.0 / (1.0 - nu * nu);
        let two_a = 2.0 * (4.0 * p / (std::f64::consts::PI * e_star)).sqrt();
        let out = Command::new(env!("CARGO_BIN_EXE_fosls"))
            .arg("estimate")
            .arg(dir.join("solution.vtu"))
            .args(["--json", "-", "--quiet"])
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(0), "{case}");
        let r: Out = serde_json::from_slice(&out.stdout).unwrap();
        // The reported force is the residual reaction of the file's displacement (the
        // solver's own figure) wherever the material is compressible; at ν = 0.5 it is the
        // stress's.
        let force = r.contact.normal_force;
        assert_eq!(
            r.contact.normal_force_from,
            if nu < 0.5 { "displacement" } else { "stress" },
            "{case}"
        );
        assert!(
            ((force - p) / p).abs() < 0.01,
            "{case}: normal force {force} against the reaction {p}"
        );
        // The stress used carries its own force: the global RT_0 minimiser of F on P1 files is
        // not equilibrated and carries 2.2–2.6 % less (the equilibrated patch reconstruction of
        // issue 13 would close this); P2/Q2/S2 and Q1 are within 1.01 %.
        let p1 = case.contains("_p1");
        let stress_tol = if p1 { 0.027 } else { 0.011 };
        let carried = r.contact.normal_force_stress;
        assert!(
            ((carried - p) / p).abs() < stress_tol,
            "{case}: the stress used carries {carried} against the reaction {p}"
        );
        let len = r.contact.active_length;
        // With Coulomb friction on the P1 meshes the zone is 3.7 % (independent patches) or
        // 4.1 % (colour-ordered patches, session 28: its ends, zeros of the stress's normal
        // trace inside edges, move by 0.0003 and 0.0004) short of the frictionless 2a; Hertz's formula
        // has no friction, and friction shortens the zone of a compressible body (Spence 1975),
        // so 2a is no exact reference there. Every other file is within 2.8 %.
        let len_tol = if p1 && case.contains("coulomb") {
            0.045
        } else {
            0.03
        };
        assert!(
            ((len - two_a) / two_a).abs() < len_tol,
            "{case}: active length {len} against 2a = {two_a}"
        );
        // One zone: the states other than "separated" form one run.
        let states: Vec<&str> = r
            .contact
            .intervals
            .iter()
            .map(|i| i.state.as_str())
            .collect();
        assert_eq!(zone_runs(&states), 1, "{case}: {:?}", r.contact.intervals);
        assert!(r.contact.intervals.iter().all(|i| i.length > 0.0));
        checked += 1;
    }
    assert!(checked >= 13, "{checked} Hertz fixtures checked");
}

/// The number of runs of states other than "separated" along a boundary's intervals: one
/// run is one contact zone (contact, stick and slip pieces side by side).
fn zone_runs(states: &[&str]) -> usize {
    states
        .iter()
        .enumerate()
        .filter(|&(k, s)| *s != "separated" && (k == 0 || states[k - 1] == "separated"))
        .count()
}

/// The Hertz fixtures of the other codes (CalculiX penalty with and without friction, DOLFINx
/// P1/P2 serial and on 2 ranks, MFEM high- and low-order output, sfepy's legacy VTK), in
/// default mode through their container (`expected.json`'s entry), each against its own
/// solver: normal force within 1 % of the solver's reaction, active length within 3 % of
/// Hertz's 2a for that reaction, one contact zone. XDMF needs `--features xdmf`.
#[test]
fn other_codes_hertz_fixtures_in_default_mode() {
    #[derive(Debug, Deserialize)]
    struct Interval {
        state: String,
    }
    #[derive(Debug, Deserialize)]
    struct Zone {
        normal_force: f64,
        active_length: f64,
        intervals: Vec<Interval>,
    }
    #[derive(Debug, Deserialize)]
    struct Out {
        contact: Zone,
    }
    let mut cases = vec![
        "calculix_hertz_cpe6_penalty",
        "calculix_hertz_cpe6_friction",
        "dolfinx_hertz_p1_vtkfile",
        "dolfinx_hertz_p2_vtkfile",
        "dolfinx_hertz_p2_vtkfile_mpi2",
        "mfem_hertz_p2_highorder",
        "mfem_hertz_p2_loworder",
        "sfepy_hertz_p2_vtk",
    ];
    if cfg!(feature = "xdmf") {
        cases.push("dolfinx_hertz_p2_xdmf");
    }
    for case in cases {
        let dir = root().join("fixtures").join(case);
        let e = expected(case);
        let entry = dir.join(e["entry"].as_str().unwrap());
        let p = e["hertz"]["P_solver"].as_f64().unwrap();
        let two_a = e["hertz"]["two_a"].as_f64().unwrap();
        let out = Command::new(env!("CARGO_BIN_EXE_fosls"))
            .arg("estimate")
            .arg(&entry)
            .arg("--scene")
            .arg(dir.join("scene.toml"))
            .args(["--json", "-", "--quiet"])
            .output()
            .unwrap();
        assert_eq!(
            out.status.code(),
            Some(0),
            "{case}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let r: Out = serde_json::from_slice(&out.stdout).unwrap();
        let force = r.contact.normal_force;
        assert!(
            ((force - p) / p).abs() < 0.01,
            "{case}: normal force {force} against the solver's reaction {p}"
        );
        let len = r.contact.active_length;
        assert!(
            ((len - two_a) / two_a).abs() < 0.03,
            "{case}: active length {len} against 2a = {two_a}"
        );
        let states: Vec<&str> = r
            .contact
            .intervals
            .iter()
            .map(|i| i.state.as_str())
            .collect();
        assert_eq!(zone_runs(&states), 1, "{case}: {states:?}");
    }
}

/// From a DOLFINx file to a first estimate (issue 12): `fosls scene` writes the starter,
/// only the material numbers are edited, `fosls estimate` finds the scene beside the file.
#[test]
fn from_a_dolfinx_file_to_a_first_estimate() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("hertz.vtu");
    std::fs::copy(
        root().join("fixtures/dolfinx_hertz_p2_vtkfile/solution_p0_000000.vtu"),
        &file,
    )
    .unwrap();
    let bin = env!("CARGO_BIN_EXE_fosls");
    let out = Command::new(bin).arg("scene").arg(&file).output().unwrap();
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let scene = dir.path().join("hertz.toml");
    let text = std::fs::read_to_string(&scene).unwrap();
    // The starter never overwrites.
    let again = Command::new(bin).arg("scene").arg(&file).output().unwrap();
    assert_eq!(again.status.code(), Some(2));
    assert_eq!(std::fs::read_to_string(&scene).unwrap(), text);
    // Only the material numbers change.
    let edited = text
        .replace("youngs_modulus = 1.0 ", "youngs_modulus = 20600.0 ")
        .replace("poisson_ratio  = 0.3 ", "poisson_ratio  = 0.28 ");
    assert_ne!(edited, text);
    std::fs::write(&scene, edited).unwrap();
    let out = Command::new(bin)
        .arg("estimate")
        .arg(&file)
        .args(["--json", "-", "--quiet"])
        .output()
        .unwrap();
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    #[derive(Deserialize)]
    struct Zone {
        normal_force: f64,
        active_length: f64,
    }
    #[derive(Deserialize)]
    struct Out {
        contact: Zone,
    }
    let r: Out = serde_json::from_slice(&out.stdout).unwrap();
    let e = expected("dolfinx_hertz_p2_vtkfile");
    let p = e["hertz"]["P_solver"].as_f64().unwrap();
    let two_a = e["hertz"]["two_a"].as_f64().unwrap();
    assert!(((r.contact.normal_force - p) / p).abs() < 0.01);
    assert!(((r.contact.active_length - two_a) / two_a).abs() < 0.03);
}

/// "(x, y)" as fosls prints a point, parsed.
fn point(s: &str) -> [f64; 2] {
    let v: Vec<f64> = s
        .trim_matches(|c| c == '(' || c == ')')
        .split(", ")
        .map(|t| t.parse().unwrap())
        .collect();
    [v[0], v[1]]
}

#[test]
fn mfem_non_conforming_q2_quadrilaterals_are_refused_naming_a_hanging_vertex() {
    // MFEM's ParaViewDataCollection of a non-conformingly refined quadrilateral mesh with a P2
    // field as Lagrange cells (Q2: not a P2 polynomial on triangle halves; reference/
    // nonconforming/). Independent source: the hanging vertices VTK's reader finds in the file
    // (expected.json). The triangle forms are split at their hanging vertices, and the Q1
    // quadrilateral forms cut into P2 triangles first, and audited (tests/hanging.rs).
    let dir = root().join("fixtures").join("mfem_nonconforming");
    let exp: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("expected.json")).unwrap()).unwrap();
    let cases = exp["cases"].as_object().unwrap();
    assert_eq!(cases.len(), 8);
    for (case, c) in cases.iter().filter(|(case, _)| *case == "p2_high_quad") {
        let file = dir.join(c["entry"].as_str().unwrap());
        let out = Command::new(env!("CARGO_BIN_EXE_fosls"))
            .arg("inspect")
            .arg(&file)
            .arg("--quiet")
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{case}: {stderr}");
        assert_eq!(stderr.lines().count(), 1, "{case}: {stderr}");
        assert!(
            stderr.contains("Cells: hanging nodes: the mesh is not conforming"),
            "{case}: {stderr}"
        );
        assert!(
            stderr.contains("not Q2 quadrilateral cells (cell 0)"),
            "{case}: {stderr}"
        );
        // "the vertex at (x, y) lies inside the edge (a)–(b) of cell …"
        let tail = stderr.split("the vertex at ").nth(1).unwrap();
        let (v, rest) = tail.split_once(" lies inside the edge ").unwrap();
        let (edge, _) = rest.split_once(" of cell ").unwrap();
        let (a, b) = edge.split_once('–').unwrap();
        let (v, a, b) = (point(v), point(a), point(b));
        let listed = c["hanging_vertices"].as_array().unwrap().iter().any(|h| {
            let p = |x: &Value| [x[0].as_f64().unwrap(), x[1].as_f64().unwrap()];
            let (hv, e0, e1) = (p(&h["vertex"]), p(&h["edge"][0]), p(&h["edge"][1]));
            let same = |x: [f64; 2], y: [f64; 2]| (x[0] - y[0]).abs() + (x[1] - y[1]).abs() < 1e-12;
            same(hv, v) && ((same(e0, a) && same(e1, b)) || (same(e0, b) && same(e1, a)))
        });
        assert!(listed, "{case}: {stderr} names no hanging vertex VTK found");
    }
}
