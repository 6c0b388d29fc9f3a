//! Stress reconstruction end to end (docs/design.md §5): the real binary with
//! `--stress reconstruct`, its JSON parsed with serde.

use std::path::PathBuf;
use std::process::Command;

use serde_json::Value;

fn run(case: &str, extra: &[&str]) -> Value {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let dir = root.join("fixtures").join(case);
    let out = Command::new(env!("CARGO_BIN_EXE_fosls"))
        .arg("estimate")
        .arg(dir.join("solution.vtu"))
        .arg("--scene")
        .arg(dir.join("scene.toml"))
        .args(["--quiet", "--json", "-"])
        .args(extra)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{case}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

fn total(r: &Value) -> f64 {
    r["functional"]["total"].as_f64().unwrap()
}

/// Reconstruction reproduces what the space holds: for exact solutions whose stress lies in
/// RT_k (constant stress for P1/RT_0, linear for P2/RT_1; also ν = 0.5 and curved cells), the
/// minimiser is the exact stress and F/energy < 1e-16 — whatever stress the file holds.
/// (The `seed` preset weighs ‖div τ + f‖² against ‖ε − Aτ‖² without units; its system is so
/// badly scaled, ~1e10, that the minimiser reaches only F/energy ≈ 7e-14 there.)
#[test]
fn reconstruction_is_exact_on_the_space() {
    for (case, k) in [
        ("exact_p1_energy", "0"),
        ("exact_p2_energy", "1"),
        ("exact_p2_robust", "1"),
    ] {
        let r = run(case, &["--stress", "reconstruct", "--degree", k]);
        assert_eq!(r["stress"]["source"], "reconstructed");
        let rel = total(&r).abs() / r["energy"].as_f64().unwrap();
        assert!(rel < 1e-16, "{case}: F/energy = {rel:e}");
    }
}

/// The reconstruction minimises F over admissible stresses: it is never above F for the
/// file's conforming nodal stress when that stress is admissible, and with the sign
/// constraint active it keeps τ_n ≤ 0 (to round-off) and the tractions exact.
#[test]
fn reconstruction_minimises_and_is_admissible() {
    for case in [
        "perturbed_u_energy",
        "perturbed_sigma_energy",
        "perturbed_u_seed",
    ] {
        let nodal = run(case, &["--stress", "file"]);
        let rec = run(case, &["--stress", "reconstruct"]);
        assert!(
            total(&rec) <= total(&nodal) * (1.0 + 1e-12),
            "{case}: {} > {}",
            total(&rec),
            total(&nodal)
        );
    }
    for case in [
        "hertz_skfem_p1",
        "hertz_skfem_p2",
        "hertz_ngsolve_p2",
        "block_skfem_p1",
    ] {
        let r = run(case, &["--stress", "reconstruct"]);
        let a = &r["admissibility"];
        let scale = 1e3; // pressures of the fixtures are O(1e2–1e3)
        assert!(
            a["tension_max"].as_f64().unwrap() <= 1e-12 * scale,
            "{case}: {a}"
        );
        assert!(
            a["neumann_max"].as_f64().unwrap() <= 1e-12 * scale,
            "{case}: {a}"
        );
        assert!(
            a["cone_violation_max"].as_f64().unwrap() <= 1e-12 * scale,
            "{case}: {a}"
        );
        // The reconstructed contact force matches the top reaction better than the projected
        // nodal stress (which misses it by 0.6–2.4 %).
        let exp: Value = serde_json::from_str(
            &std::fs::read_to_string(
                PathBuf::from(env!("CARGO_MANIFEST_DIR"))
                    .join("fixtures")
                    .join(case)
                    .join("expected.json"),
            )
            .unwrap(),
        )
        .unwrap();
        // P2 only: on the coarse P1 meshes the discrete reaction itself is 2 % off.
        if let (Some(p), true) = (
            exp["solver"]["reaction_top"]["P"].as_f64(),
            case.ends_with("p2"),
        ) {
            let f = r["contact"]["normal_force"].as_f64().unwrap();
            assert!((f - p).abs() <= 0.005 * p, "{case}: force {f} vs P {p}");
        }
    }
}

/// The minimum agrees with the independent reference (scikit-fem RT and NGSolve HDiv,
/// `reference/reconstruct`, same functional and constraints) to 1e-8 relative in F, and the
/// number of active contact constraints is the same.
#[test]
fn minimum_agrees_with_the_reference_harness() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let mut n = 0;
    for entry in std::fs::read_dir(root.join("fixtures")).unwrap() {
        let case = entry.unwrap().file_name().to_string_lossy().into_owned();
        if !case.starts_with("reconstruct_") {
            continue;
        }
        let exp: Value = serde_json::from_str(
            &std::fs::read_to_string(root.join("fixtures").join(&case).join("expected.json"))
                .unwrap(),
        )
        .unwrap();
        let k = exp["k"].as_u64().unwrap().to_string();
        let r = run(
            &case,
            &[
                "--stress",
                "reconstruct",
                "--degree",
                &k,
                "--displacement",
                "file",
            ],
        );
        let c = &exp["constrained"];
        let want = c["functional"]["total"].as_f64().unwrap();
        let energy = c["energy"].as_f64().unwrap();
        let got = total(&r);
        // Exact cases sit at round-off: compare against the energy there.
        assert!(
            (got - want).abs() <= 1e-8 * want.abs() + 1e-20 * energy,
            "{case}: F = {got} vs {want}"
        );
        let notes: Vec<String> = serde_json::from_value(r["notes"].clone()).unwrap();
        let active = c["active_count"].as_u64().unwrap();
        assert!(
            notes
                .iter()
                .any(|n| n.contains(&format!("{active} active contact constraints"))),
            "{case}: {notes:?}"
        );
        n += 1;
    }
    assert!(n >= 6);
}

/// With Coulomb friction the reconstructed stress lies in the cone (to round-off), and the
/// stick/slip transitions are those of the reference solver's solution (within one node
/// spacing of the harness's nodal classification).
#[test]
fn frictional_reconstruction_stays_in_the_cone_and_finds_the_stick_zone() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    // Node spacings at the stick ends: Hertz P2 0.0022, block P1 0.021–0.023.
    for (case, spacing) in [
        ("hertz_skfem_p2_coulomb", 0.003),
        ("block_skfem_p1_coulomb02", 0.025),
    ] {
        let r = run(case, &["--stress", "reconstruct"]);
        let a = &r["admissibility"];
        assert!(
            a["cone_violation_max"].as_f64().unwrap() < 1e-12 * 1e3,
            "{case}: {a}"
        );
        assert!(
            a["tension_max"].as_f64().unwrap() < 1e-12 * 1e3,
            "{case}: {a}"
        );
        let exp: Value = serde_json::from_str(
            &std::fs::read_to_string(root.join("fixtures").join(case).join("expected.json"))
                .unwrap(),
        )
        .unwrap();
        let name = exp["contact"].as_str().unwrap();
        let want: Vec<(String, f64, f64)> = exp["boundaries"][name]["intervals"]
            .as_array()
            .unwrap()
            .iter()
            .filter(|i| i["state"] == "stick")
            .map(|i| {
                let x = i["x"].as_array().unwrap();
                (
                    "stick".into(),
                    x[0].as_f64().unwrap(),
                    x[1].as_f64().unwrap(),
                )
            })
            .collect();
        let got: Vec<(f64, f64)> = r["contact"]["intervals"]
            .as_array()
            .unwrap()
            .iter()
            .filter(|i| i["state"] == "stick")
            .map(|i| {
                (
                    i["start"][0].as_f64().unwrap(),
                    i["end"][0].as_f64().unwrap(),
                )
            })
            .collect();
        assert_eq!(got.len(), want.len(), "{case}: {got:?} vs {want:?}");
        for ((a0, a1), (_, b0, b1)) in got.iter().zip(&want) {
            assert!(
                (a0 - b0).abs() <= spacing && (a1 - b1).abs() <= spacing,
                "{case}: stick [{a0}, {a1}] vs reference [{b0}, {b1}]"
            );
        }
    }
}

/// On the NGSolve penalty Hertz solution: the displacement is projected onto K_u (its nodal
/// penetration removed), the projection distance is reported, positive and small compared
/// with η, the file's penetration is still reported, and the reconstructed stress has
/// τ_n ≤ 0 everywhere (to round-off). F becomes non-negative again.
#[test]
fn penalty_solution_is_projected_and_reconstructed() {
    let nodal = run(
        "hertz_ngsolve_p2",
        &["--displacement", "file", "--stress", "reconstruct"],
    );
    assert!(total(&nodal) < 0.0, "the penetrating pair gives F < 0");
    let r = run("hertz_ngsolve_p2", &["--stress", "reconstruct"]);
    let d = r["displacement"]["projection_distance"].as_f64().unwrap();
    let eta = r["eta"].as_f64().unwrap();
    assert_eq!(r["displacement"]["source"], "reconstructed");
    assert!(d > 0.0 && d < 0.1 * eta, "distance {d} vs η {eta}");
    assert!(total(&r) > 0.0);
    // One penetration figure per source: the file's displacement penetrates by the penalty's
    // 8.7e-6, the projected one only between the nodes of curved edges (O(h³)).
    assert!(r["admissibility_file"]["penetration_max"].as_f64().unwrap() > 8e-6);
    assert!(r["admissibility"]["penetration_max"].as_f64().unwrap() < 1e-7);
    assert!(r["admissibility"]["tension_max"].as_f64().unwrap() < 1e-12 * 1e3);
    // P2 on the curved arc: the constraint holds at the nodes; between them 1.6e-8 of the
    // 8.7e-6 remains.
    let pen = r["admissibility"]["penetration_max"].as_f64().unwrap();
    assert!(pen < 1e-2 * 8.7e-6, "{pen}");
}

/// The binary on `file` with `scene`: (exit code, stdout, stderr).
fn run_file(
    file: &std::path::Path,
    scene: &std::path::Path,
    extra: &[&str],
) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_fosls"))
        .arg("estimate")
        .arg(file)
        .arg("--scene")
        .arg(scene)
        .args(["--quiet", "--json", "-"])
        .args(extra)
        .output()
        .unwrap();
    (
        out.status.code().unwrap(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// A pure stress method's file (the scikit-fem Hertz solution with its displacement array
/// removed): the displacement is rebuilt as the minimiser of F(·, σ_h) on K_u. It is the same
/// field as `--displacement reconstruct` on the full file (same F to round-off), admissible at
/// the nodes (no penetration reported), and F is below F for the file's own displacement,
/// which is admissible: the minimiser can only do better. Asking for both reconstructions, or
/// for the file's displacement where there is none, is refused with exit status 2.
#[test]
fn displacement_is_reconstructed_from_a_nodal_stress() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let dir = root.join("fixtures").join("hertz_skfem_p2");
    let scene = dir.join("scene.toml");
    let mut vtu = fosls::read::vtu::read_vtu(&dir.join("solution.vtu")).unwrap();
    let before = vtu.point_data.len();
    vtu.point_data.retain(|a| a.name != "displacement");
    assert_eq!(vtu.point_data.len(), before - 1);
    let tmp = tempfile::tempdir().unwrap();
    let stress_only = tmp.path().join("stress_only.vtu");
    fosls::write::write_vtu(&stress_only, &vtu, fosls::write::Placement::AppendedRaw).unwrap();

    // The scene names the displacement array; a pure stress method's scene does not.
    let text = std::fs::read_to_string(&scene).unwrap();
    assert!(text.contains("displacement = \"displacement\"\n"));
    let scene = tmp.path().join("scene.toml");
    std::fs::write(
        &scene,
        text.replace("displacement = \"displacement\"\n", ""),
    )
    .unwrap();
    // Default: u_h is rebuilt from the file's stress; that stress is tensile in places (an
    // L² projection), so `auto` then rebuilds the stress for the new u_h.
    let (code, out, err) = run_file(&stress_only, &scene, &[]);
    assert_eq!(code, 0, "{err}");
    let r: Value = serde_json::from_str(&out).unwrap();
    assert_eq!(r["displacement"]["source"], "reconstructed");
    assert_eq!(
        r["displacement"]["reason"],
        "the file holds no displacement"
    );
    assert_eq!(r["stress"]["source"], "reconstructed");

    let (code, out, err) = run_file(&stress_only, &scene, &["--stress", "file"]);
    assert_eq!(code, 0, "{err}");
    let r: Value = serde_json::from_str(&out).unwrap();
    assert_eq!(r["stress"]["source"], "file");

    let full = run(
        "hertz_skfem_p2",
        &["--stress", "file", "--displacement", "reconstruct"],
    );
    let given = run(
        "hertz_skfem_p2",
        &["--stress", "file", "--displacement", "file"],
    );
    let (f_rec, f_full, f_file) = (total(&r), total(&full), total(&given));
    assert!(
        (f_rec - f_full).abs() <= 1e-12 * f_file,
        "{f_rec} vs {f_full}"
    );
    assert!(f_rec < f_file, "{f_rec} ≥ {f_file}");
    // v_n ≤ g holds at the nodes; between the nodes of curved P2 edges both fields penetrate
    // by O(h³), the solver's own solution (7.2e-7 here) as much as the reconstruction.
    let pen = |r: &Value| r["admissibility"]["penetration_max"].as_f64().unwrap();
    assert!(
        pen(&r) <= 2.0 * pen(&given),
        "{} vs {}",
        pen(&r),
        pen(&given)
    );

    let (code, _, err) = run_file(&stress_only, &scene, &["--displacement", "file"]);
    assert_eq!(code, 2);
    assert_eq!(
        err.trim_end(),
        format!(
            "error: {}: displacement: --displacement file: the file holds no displacement",
            stress_only.display()
        )
    );
    let (code, _, err) = run_file(&stress_only, &scene, &["--stress", "reconstruct"]);
    assert_eq!(code, 2);
    assert_eq!(
        err.trim_end(),
        "error: --stress reconstruct: the displacement is reconstructed from the file's stress, \
         so the stress cannot be reconstructed too"
    );
}

/// Convergence of F^½ after the reconstruction on a smooth manufactured contact problem
/// (reference/manufactured, `manufactured_aligned_*`: scikit-fem solutions on n × n meshes,
/// n = 4, 8, 16, contact zone end on a mesh line so that the data are smooth on every cell):
/// the least-squares slope of log η against log h is the theoretical rate, 1 for P1/RT_0 and
/// 2 for P2/RT_1, within 0.1 (measured: 0.96 and 1.96).
#[test]
fn reconstruction_converges_at_the_optimal_rate() {
    for (p, rate) in [(1, 1.0), (2, 2.0)] {
        let pts: Vec<(f64, f64)> = [4, 8, 16]
            .iter()
            .map(|&n| {
                let r = run(
                    &format!("manufactured_aligned_p{p}_n{n:02}"),
                    &["--stress", "reconstruct", "--displacement", "file"],
                );
                assert_eq!(
                    r["stress"]["space"],
                    format!("RT_{} row-wise (global minimiser of F)", p - 1)
                );
                ((1.0 / n as f64).ln(), r["eta"].as_f64().unwrap().ln())
            })
            .collect();
        let m = pts.len() as f64;
        let (sx, sy) = pts.iter().fold((0.0, 0.0), |(a, b), (x, y)| (a + x, b + y));
        let (mx, my) = (sx / m, sy / m);
        let slope = pts.iter().map(|(x, y)| (x - mx) * (y - my)).sum::<f64>()
            / pts.iter().map(|(x, _)| (x - mx) * (x - mx)).sum::<f64>();
        assert!(
            (slope - rate).abs() <= 0.1,
            "P{p}: fitted slope {slope:.3}, expected {rate}"
        );
    }
}

/// `--output` with a reconstruction also writes `<stem>_discontinuous.vtu`: every cell with
/// its own node copies and the stress evaluated in that cell. On an exact solution whose
/// stress is linear (in RT_1, reproduced exactly), every copy carries the exact stress, which
/// the input file holds at the nodes.
#[test]
fn output_has_a_pointwise_discontinuous_copy() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let dir = root.join("fixtures").join("exact_p2_energy");
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("report.vtu");
    let (code, _, err) = run_file(
        &dir.join("solution.vtu"),
        &dir.join("scene.toml"),
        &["--stress", "reconstruct", "--output", out.to_str().unwrap()],
    );
    assert_eq!(code, 0, "{err}");
    let input = fosls::read::vtu::read_vtu(&dir.join("solution.vtu")).unwrap();
    let copy = fosls::read::vtu::read_vtu(&tmp.path().join("report_discontinuous.vtu")).unwrap();
    let triangles = input.types.iter().filter(|&&t| t == 22).count();
    assert_eq!(copy.points.len(), 6 * triangles);
    assert_eq!(copy.cell_count(), triangles);
    let exact = input
        .point_data
        .iter()
        .find(|a| a.name == "stress")
        .unwrap();
    let stress = copy.point_data.iter().find(|a| a.name == "stress").unwrap();
    assert_eq!(stress.components, 9);
    // The input's layout is xx, yy, zz, xy (meshio): σ = [[xx, xy], [xy, yy]].
    assert_eq!(exact.components, 4);
    let smax = exact.values.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let mut worst = 0.0f64;
    for (i, p) in copy.points.iter().enumerate() {
        let j = input
            .points
            .iter()
            .position(|q| (q[0] - p[0]).abs() < 1e-14 && (q[1] - p[1]).abs() < 1e-14)
            .unwrap();
        let e = &exact.values[4 * j..4 * j + 4];
        let s = &stress.values[9 * i..9 * i + 9];
        for (a, b) in [(s[0], e[0]), (s[1], e[3]), (s[3], e[3]), (s[4], e[1])] {
            worst = worst.max((a - b).abs() / smax);
        }
    }
    assert!(worst < 1e-10, "largest deviation {worst:e} of max |σ|");
}

/// Displacement reconstruction with Coulomb friction (v_t split into a − b ≥ 0, lumped
/// friction term): on an exact frictional solution it gives the exact displacement back
/// (F/energy < 1e-16), and on scikit-fem P1 Coulomb solutions, which are admissible at the
/// nodes and whose slip keeps its sign along each edge, it lowers F below the file's own
/// displacement: for P1 the lumped term is the exact one there, so the minimiser can only do
/// better.
#[test]
fn displacement_reconstruction_with_friction() {
    let r = run(
        "exact_p2_coulomb",
        &["--stress", "file", "--displacement", "reconstruct"],
    );
    assert_eq!(r["displacement"]["source"], "reconstructed");
    let rel = total(&r).abs() / r["energy"].as_f64().unwrap();
    assert!(rel < 1e-16, "F/energy = {rel:e}");
    for case in ["hertz_skfem_p1_coulomb", "block_skfem_p1_coulomb02"] {
        let rec = run(case, &["--stress", "file", "--displacement", "reconstruct"]);
        let file = run(case, &["--stress", "file", "--displacement", "file"]);
        assert!(
            total(&rec) < total(&file),
            "{case}: {} ≥ {}",
            total(&rec),
            total(&file)
        );
    }
}
