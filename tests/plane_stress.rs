//! Plane stress (docs/design.md §2.1: λ* = Eν/(1 − ν²)) against plane strain. The in-plane
//! elasticity tensors agree when ν_stress = ν/(1 − ν) and E_stress = E/(1 − ν²) for the plane
//! strain (E, ν) (a hand derivation: μ = E_s/(2(1 + ν_s)) = E/(2(1 + ν)) and
//! E_s ν_s/(1 − ν_s²) = Eν/((1 + ν)(1 − 2ν))), so every number of an audit of one file must
//! agree between the two models. No fixture is written in plane stress: the fixtures' plane
//! strain audits, which are checked against exact solutions and fine references elsewhere,
//! are the independent source.

use std::path::Path;

use fosls::report::json::Report;

mod common;

/// The fixture's scene with the material replaced, written beside a copy of its solution.
fn audit(case: &str, material: (f64, f64, &str), args: &[&str]) -> Report {
    let src = common::cli::root().join("fixtures").join(case);
    let mut scene: toml::Table = std::fs::read_to_string(src.join("scene.toml"))
        .unwrap()
        .parse()
        .unwrap();
    let m = scene["material"].as_table_mut().unwrap();
    m.insert("youngs_modulus".into(), material.0.into());
    m.insert("poisson_ratio".into(), material.1.into());
    m.insert("model".into(), material.2.into());
    if let Some(e) = scene.get_mut("estimate").and_then(|e| e.as_table_mut()) {
        e.remove("norm");
    }
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("solution.vtu");
    std::fs::copy(src.join("solution.vtu"), &file).unwrap();
    let scene_path = dir.path().join("scene.toml");
    std::fs::write(&scene_path, toml::to_string(&scene).unwrap()).unwrap();
    let mut all = vec!["--scene", scene_path.to_str().unwrap(), "--quiet"];
    all.extend(args);
    let (code, report, stderr) = common::cli::estimate(Path::new(&file), &all);
    assert_eq!(code, 0, "{case}: {stderr}");
    report.unwrap()
}

fn plane_strain_e_nu(case: &str) -> (f64, f64) {
    let scene: toml::Table = std::fs::read_to_string(
        common::cli::root()
            .join("fixtures")
            .join(case)
            .join("scene.toml"),
    )
    .unwrap()
    .parse()
    .unwrap();
    let m = &scene["material"];
    let e = m["youngs_modulus"].as_float().unwrap();
    let nu = m["poisson_ratio"].as_float().unwrap();
    assert_eq!(
        m["model"].as_str().unwrap_or("plane_strain"),
        "plane_strain"
    );
    (e, nu)
}

fn close(what: &str, a: f64, b: f64, tol: f64) {
    assert!(
        (a - b).abs() <= tol * a.abs().max(b.abs()),
        "{what}: {a} (plane strain) vs {b} (plane stress)"
    );
}

fn compare(case: &str, strain: &Report, stress: &Report, tol: f64) {
    close(
        &format!("{case} F"),
        strain.functional.total,
        stress.functional.total,
        tol,
    );
    close(&format!("{case} energy"), strain.energy, stress.energy, tol);
    assert_eq!(strain.bound.guaranteed, stress.bound.guaranteed, "{case}");
    match (strain.bound.energy_error, stress.bound.energy_error) {
        (Some(a), Some(b)) => close(&format!("{case} bound"), a, b, tol),
        (a, b) => assert_eq!(a, b, "{case}"),
    }
}

/// Triangles and quadrilaterals, P1 and P2, frictionless and Coulomb, file stress and
/// reconstructions: every number agrees. The tolerance covers the last bits of λ and μ,
/// which the two models compute by different formulas (measured: ≤ 3e-9 relative, on the
/// manufactured P2 file whose projection onto K_u amplifies round-off).
#[test]
fn plane_stress_audits_agree_with_the_equivalent_plane_strain() {
    for case in [
        "perturbed_u_energy",
        "hertz_skfem_p2",
        "quad_hertz_skfem_q2",
        "block_skfem_p1_coulomb",
        "manufactured_frictionless_p2_n08",
    ] {
        let (e, nu) = plane_strain_e_nu(case);
        let strain = audit(case, (e, nu, "plane_strain"), &[]);
        let stress = audit(
            case,
            (e / (1.0 - nu * nu), nu / (1.0 - nu), "plane_stress"),
            &[],
        );
        compare(case, &strain, &stress, 1e-8);
    }
}

/// ν = 0.5 in plane stress is plane strain with ν = 1/3: λ* = 2E/3 is finite, and the audits
/// agree in the robust norm (the one ν = 0.5 allows).
#[test]
fn plane_stress_at_one_half_is_plane_strain_at_one_third() {
    for case in ["perturbed_u_energy", "hertz_skfem_p2"] {
        let (e, _) = plane_strain_e_nu(case);
        let nu = 1.0 / 3.0;
        let strain = audit(case, (e, nu, "plane_strain"), &["--norm", "robust"]);
        let stress = audit(
            case,
            (e / (1.0 - nu * nu), 0.5, "plane_stress"),
            &["--norm", "robust"],
        );
        assert_eq!(stress.norm, "robust");
        compare(case, &strain, &stress, 1e-10);
        assert!(stress.bound.energy_error.is_some(), "{case}");
    }
}
