//! Quadrilaterals and VTK Lagrange cells end to end (issue 11): the real binary on the
//! fixtures of `reference/quads/` (scikit-fem Q1, Q2 and serendipity solutions written by
//! meshio, and VTK-written twins of one solution under two cell numberings).
//!
//! Independent sources: exact polynomial solutions in the discrete spaces (F = 0), the
//! solver's reaction and Hertz's half-width 2a = 2√(4PR/(πE*)) from `expected.json`, the
//! energy error rates of the manufactured family, and the same file under other type numbers.

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
    intervals: Vec<Value>,
}

#[derive(Debug, Deserialize)]
struct Report {
    functional: Functional,
    energy: f64,
    contact: ContactReport,
}

/// `fosls estimate FILE --json - --quiet ARGS…`, parsed.
fn estimate(file: &Path, args: &[&str]) -> Report {
    let out = Command::new(env!("CARGO_BIN_EXE_fosls"))
        .arg("estimate")
        .arg(file)
        .args(["--json", "-", "--quiet"])
        .args(args)
        .current_dir(root())
        .output()
        .unwrap();
    assert!(
        out.status.code() == Some(0),
        "{}: exit {:?}: {}",
        file.display(),
        out.status.code(),
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

fn fixture(case: &str) -> PathBuf {
    root().join("fixtures").join(case).join("solution.vtu")
}

fn expected(case: &str) -> Value {
    let p = root().join("fixtures").join(case).join("expected.json");
    serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap()
}

const EXACT: [&str; 6] = [
    "quad_exact_q1_energy",
    "quad_exact_q2_energy",
    "quad_exact_s2_energy",
    "quad_exact_q2_curved_energy",
    "quad_exact_mixed_p2q2_energy",
    "quad_exact_q2_robust",
];

#[test]
fn exact_solutions_in_the_quad_spaces_give_zero() {
    for case in EXACT {
        for norm in ["energy", "robust", "seed"] {
            if case.ends_with("robust") && norm == "energy" {
                continue; // ν = 0.5
            }
            let r = estimate(&fixture(case), &["--stress", "file", "--norm", norm]);
            let rel = r.functional.total / r.energy;
            assert!(
                rel.abs() < 1e-20 && r.energy > 0.0,
                "{case} {norm}: F/energy = {rel:e}"
            );
        }
    }
}

#[test]
fn reconstruction_reproduces_a_stress_in_the_space_on_quads() {
    // Every exact stress is of degree ≤ 1 in x (RT_1 contains it on the straight or P2
    // sub-triangles, docs/design.md §5.4); the file's displacement is exact.
    for case in EXACT {
        let r = estimate(
            &fixture(case),
            &["--stress", "reconstruct", "--degree", "1"],
        );
        let rel = r.functional.total / r.energy;
        assert!(rel.abs() < 1e-16, "{case}: F/energy = {rel:e}");
    }
    // σ constant (the Q1 case) is in RT_0.
    let r = estimate(
        &fixture("quad_exact_q1_energy"),
        &["--stress", "reconstruct", "--degree", "0"],
    );
    assert!(r.functional.total / r.energy < 1e-16);
}

#[test]
fn the_same_solution_under_two_type_numberings_gives_the_same_f() {
    let dir = root().join("fixtures/quad_twins");
    // RT_0 cannot hold the linear stress, so F is far from zero: a real comparison.
    for (a, b) in [
        ("quad_twin_q2_type28.vtu", "quad_twin_q2_type70.vtu"),
        ("quad_twin_p2_type22.vtu", "quad_twin_p2_type69.vtu"),
    ] {
        for args in [
            &["--stress", "reconstruct", "--degree", "0"][..],
            &["--stress", "file"][..],
        ] {
            let ra = estimate(&dir.join(a), args);
            let rb = estimate(&dir.join(b), args);
            let (fa, fb) = (ra.functional.total, rb.functional.total);
            let scale = fa.abs().max(ra.energy * 1e-20);
            assert!(
                (fa - fb).abs() <= 1e-12 * scale,
                "{a} vs {b} {args:?}: {fa:e} vs {fb:e}"
            );
            assert!((ra.energy - rb.energy).abs() <= 1e-12 * ra.energy);
        }
    }
}

#[test]
fn quad_hertz_normal_force_and_contact_width() {
    // The force is the residual reaction of the file's displacement (docs/design.md §5.8),
    // which the solver's own reaction equals up to its tolerance.
    for (case, force_tol) in [
        ("quad_hertz_skfem_q1", 0.01),
        ("quad_hertz_skfem_q2", 0.01),
        ("quad_hertz_skfem_s2", 0.01),
    ] {
        let e = expected(case);
        let p = e["hertz"]["P_solver"].as_f64().unwrap();
        let two_a = e["hertz"]["two_a"].as_f64().unwrap();
        // Default mode: the file's stress is inadmissible, so the reconstruction is used.
        let r = estimate(&fixture(case), &[]);
        let force = r.contact.normal_force;
        assert!(
            ((force - p) / p).abs() < force_tol,
            "{case}: normal force {force} against the reaction {p}"
        );
        let len = r.contact.active_length;
        assert!(
            ((len - two_a) / two_a).abs() < 0.03,
            "{case}: active length {len} against 2a = {two_a}"
        );
        // One zone: exactly one interval in a state other than "separated", and it is the
        // one whose length was compared with 2a.
        let zones: Vec<&Value> = r
            .contact
            .intervals
            .iter()
            .filter(|i| i["state"] != "separated")
            .collect();
        assert_eq!(zones.len(), 1, "{case}: {:?}", r.contact.intervals);
        let zone_len = zones[0]["length"].as_f64().unwrap();
        assert!(
            (zone_len - len).abs() <= 1e-12 * len,
            "{case}: {zone_len} vs {len}"
        );
    }
}

/// Fitted slope of log η against log h (h = 1/n).
fn slope(n: &[f64], eta: &[f64]) -> f64 {
    let x: Vec<f64> = n.iter().map(|n| -(n.ln())).collect();
    let y: Vec<f64> = eta.iter().map(|e| e.ln()).collect();
    let mx = x.iter().sum::<f64>() / x.len() as f64;
    let my = y.iter().sum::<f64>() / y.len() as f64;
    let sxy: f64 = x.iter().zip(&y).map(|(a, b)| (a - mx) * (b - my)).sum();
    let sxx: f64 = x.iter().map(|a| (a - mx) * (a - mx)).sum();
    sxy / sxx
}

#[test]
fn manufactured_quads_converge_at_the_expected_rates() {
    for (fam, rate) in [("q1", 1.0), ("q2", 2.0), ("s2", 2.0)] {
        let mut eta = Vec::new();
        let mut err = Vec::new();
        for n in ["04", "08", "16"] {
            let case = format!("quad_manufactured_{fam}_n{n}");
            let r = estimate(&fixture(&case), &["--stress", "reconstruct"]);
            eta.push(r.functional.total.sqrt());
            let e = expected(&case);
            err.push(e["errors"]["fe"]["energy"].as_f64().unwrap());
        }
        let n = [4.0, 8.0, 16.0];
        let s = slope(&n, &eta);
        assert!((s - rate).abs() < 0.1, "{fam}: slope of η {s}");
        // The true error (from the exact solution) converges at the same rate.
        let se = slope(&n, &err);
        assert!((se - rate).abs() < 0.1, "{fam}: slope of the error {se}");
    }
}

#[test]
fn curvedness_survives_twelve_digit_ascii_coordinates() {
    // The binary Hertz P2 file and the same mesh with coordinates rounded to 12 significant
    // digits (what an ASCII writer with %.12g stores) must agree on the curved cells.
    use fosls::read::vtu::read_vtu;
    for case in [
        "hertz_skfem_p2",
        "quad_hertz_skfem_q2",
        "quad_hertz_skfem_s2",
    ] {
        let file = read_vtu(&fixture(case)).unwrap();
        let mut rounded = file.clone();
        for p in &mut rounded.points {
            for c in p.iter_mut() {
                *c = format!("{:.11e}", *c).parse().unwrap();
            }
        }
        let a = fosls::mesh::build(file).unwrap();
        let b = fosls::mesh::build(rounded).unwrap();
        assert!(a.report.curved_cells > 0, "{case}");
        assert_eq!(
            a.report.curved_cells, b.report.curved_cells,
            "{case}: curved cells of the binary and the rounded file"
        );
        assert_eq!(a.report.bilinear_cells, b.report.bilinear_cells, "{case}");
    }
}

#[test]
fn mfem_high_order_lagrange_output_matches_the_same_solution_as_vtk_22() {
    // PyMFEM's ParaViewDataCollection with high-order output: VTK_LAGRANGE_TRIANGLE (69),
    // every element with its own node copies. The solution is scikit-fem's hertz_skfem_p2
    // (same mesh and active set, reaction equal to 2e-14, reference/othercodes/README.md), so
    // F of the file's fields must agree to the difference of the two solvers' L² stress
    // projections (1e-6).
    let dir = root().join("fixtures/mfem_hertz_p2_highorder");
    let file = dir.join("solution/Cycle000000/proc000000.vtu");
    let scene = dir.join("scene.toml");
    let args = [
        "--scene",
        scene.to_str().unwrap(),
        "--stress",
        "file",
        "--displacement",
        "file",
    ];
    let m = estimate(&file, &args);
    let s = estimate(
        &fixture("hertz_skfem_p2"),
        &["--stress", "file", "--displacement", "file"],
    );
    let rel = (m.functional.total - s.functional.total).abs() / s.functional.total;
    assert!(
        rel < 1e-6,
        "F {} against {}",
        m.functional.total,
        s.functional.total
    );
    // In default mode (the file's stress is inadmissible: rebuilt), the contact force is the
    // solver's reaction.
    let p = expected("mfem_hertz_p2_highorder")["hertz"]["P_solver"]
        .as_f64()
        .unwrap();
    let d = estimate(&file, &args[..2]);
    let force = d.contact.normal_force;
    assert!(((force - p) / p).abs() < 0.01, "{force} against {p}");
}
