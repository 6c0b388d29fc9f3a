//! `fosls estimate` end to end: the real binary on the reference fixtures (NGSolve and
//! scikit-fem contact solutions written by `reference/`), its JSON parsed with serde and
//! compared with the values the Python harness computed on the same fields.

use std::path::PathBuf;
use std::process::{Command, Output};

use serde::Deserialize;
use serde_json::Value;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn fosls(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_fosls"))
        .args(args)
        .current_dir(root())
        .output()
        .unwrap()
}

#[derive(Debug, Deserialize)]
struct Functional {
    total: f64,
    constitutive: f64,
    equilibrium: f64,
    complementarity: f64,
    friction: f64,
}

#[derive(Debug, Deserialize)]
struct Admissibility {
    penetration_max: f64,
}

#[derive(Debug, Deserialize)]
struct ContactReport {
    active_length: f64,
    stick_length: f64,
    slip_length: f64,
    normal_force: f64,
    normal_force_stress: f64,
}

#[derive(Debug, Deserialize)]
struct Bound {
    guaranteed: bool,
    failed_hypotheses: Vec<String>,
}

#[derive(Debug, Deserialize)]
struct Worst {
    cell: usize,
    eta: f64,
}

#[derive(Debug, Deserialize)]
struct Cells {
    count: usize,
    worst: Vec<Worst>,
}

#[derive(Debug, Deserialize)]
struct Report {
    norm: String,
    functional: Functional,
    energy: f64,
    relative: Option<f64>,
    admissibility: Admissibility,
    contact: ContactReport,
    bound: Bound,
    cells: Cells,
    version: String,
}

fn estimate(case: &str, extra: &[&str]) -> Report {
    let dir = format!("fixtures/{case}");
    // These tests evaluate the fields as the file holds them: no projection of a penetrating
    // displacement and no reconstruction of an inadmissible stress (that is `auto`, tested
    // in tests/reconstruct_cli.rs).
    let mut args = vec![
        "estimate",
        "--quiet",
        "--json",
        "-",
        "--displacement",
        "file",
        "--stress",
        "file",
        "--scene",
    ];
    let scene = format!("{dir}/scene.toml");
    let solution = format!("{dir}/solution.vtu");
    args.push(&scene);
    args.push(&solution);
    args.extend_from_slice(extra);
    let out = fosls(&args);
    assert!(
        out.status.success(),
        "{case}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

fn expected(case: &str, file: &str) -> Value {
    let text = std::fs::read_to_string(root().join("fixtures").join(case).join(file)).unwrap();
    serde_json::from_str(&text).unwrap()
}

fn close(what: &str, got: f64, want: f64, rel: f64) {
    assert!(
        (got - want).abs() <= rel * want.abs().max(f64::MIN_POSITIVE),
        "{what}: {got} vs {want} (rel {:e})",
        (got - want).abs() / want.abs()
    );
}

/// The Hertz half-width a = √(4PR/(πE*)), E* = E/(1 − ν²), R = 1.
fn hertz_a(p: f64, e: f64, nu: f64) -> f64 {
    (4.0 * p / (std::f64::consts::PI * e / (1.0 - nu * nu))).sqrt()
}

/// docs/design.md / issue: on the NGSolve penalty Hertz solution (P2, curved) the normal force is
/// within 1 % of the reaction at the top, the active length within 3 % of 2a, and the
/// penetration is reported. The force is the residual reaction of the file's displacement,
/// so P1 is held to 1 % too (its projected stress alone carries 1.2 % less).
#[test]
fn hertz_ngsolve_force_width_and_penetration() {
    for (case, force_tol) in [("hertz_ngsolve_p2", 0.01), ("hertz_ngsolve_p1", 0.01)] {
        let r = estimate(case, &[]);
        let exp = expected(case, "expected.json");
        let p = exp["solver"]["reaction_top"]["P"].as_f64().unwrap();
        close(
            &format!("{case} normal force vs P"),
            r.contact.normal_force,
            p,
            force_tol,
        );
        if case.ends_with("p2") {
            // The coarse P1 mesh resolves the zone to 5 % only; the curved P2 one to 0.2 %.
            let a = hertz_a(p, 20600.0, 0.28);
            close(
                &format!("{case} active length vs 2a"),
                r.contact.active_length,
                2.0 * a,
                0.03,
            );
        }
        let c = &exp["boundaries"]["contact"];
        assert!(
            r.admissibility.penetration_max > 1e-6,
            "{case}: penetration not reported"
        );
        close(
            &format!("{case} penetration"),
            r.admissibility.penetration_max,
            c["penetration_max"].as_f64().unwrap(),
            1e-6,
        );
        // The harness's own integral of the file's stress traction on the same fields is
        // the stress-side force; the reported force is the residual reaction of the file's
        // displacement (docs/design.md §5.8), compared with P above.
        close(
            &format!("{case} normal force of the stress"),
            r.contact.normal_force_stress,
            c["normal_force"].as_f64().unwrap(),
            1e-8,
        );
        // The harness measures where the file's gap is closed; fosls where the traction is
        // compressive (docs/design.md §5.8): the traction zone holds the gap zone.
        let gap_zone = c["active_length"].as_f64().unwrap();
        assert!(
            r.contact.active_length >= 0.99 * gap_zone,
            "{case}: {} against the closed-gap length {gap_zone}",
            r.contact.active_length
        );
        assert!(!r.bound.guaranteed);
        assert!(
            r.bound
                .failed_hypotheses
                .iter()
                .any(|h| h.starts_with("u_h penetrates the obstacle")),
            "{:?}",
            r.bound.failed_hypotheses
        );
    }
}

/// The contact force and lengths agree with the harness on every Hertz and block fixture,
/// including the frictional ones (stick and slip lengths within the harness's tolerance).
#[test]
fn contact_zone_agrees_with_the_harness_on_every_contact_fixture() {
    for entry in std::fs::read_dir(root().join("fixtures")).unwrap() {
        let case = entry.unwrap().file_name().to_string_lossy().into_owned();
        if !(case.starts_with("hertz_") || case.starts_with("block_")) {
            continue;
        }
        let r = estimate(&case, &[]);
        let exp = expected(&case, "expected.json");
        let name = exp["contact"].as_str().unwrap();
        let c = &exp["boundaries"][name];
        close(
            &format!("{case} normal force of the stress"),
            r.contact.normal_force_stress,
            c["normal_force"].as_f64().unwrap(),
            1e-8,
        );
        // The harness measures where the file's gap is closed; fosls where the traction of
        // the file's stress is compressive (docs/design.md §5.8), which holds the gap zone
        // and exceeds it by the oscillations of the L² projected stress at the zone's ends
        // (at most 17 %, on the P1 block-on-cylinder file, whose zone of 0.39 is 17 edges of
        // ≈ 0.026 long: 0.033 at each end, between one and two edges; 9.6 % on the coarse P1
        // NGSolve Hertz files; the default mode's reconstructed stress has no such tails,
        // tests/othercodes.rs).
        let gap_zone = c["active_length"].as_f64().unwrap();
        let active = r.contact.active_length;
        assert!(
            active >= 0.99 * gap_zone && active <= 1.2 * gap_zone,
            "{case}: active length {active} against the closed-gap length {gap_zone}"
        );
        assert!(r.contact.stick_length + r.contact.slip_length <= active * (1.0 + 1e-12));
        assert_eq!(
            r.cells.count as u64,
            exp["mesh"]["cells"].as_u64().unwrap(),
            "{case}"
        );
        assert!(r.version.starts_with("0."));
    }
}

/// Terms of F agree with the independent Python evaluator (`reference/fosls_ref`) to 1e-8
/// relative, wherever it has written `expected_fosls.json`.
#[test]
fn terms_agree_with_the_independent_reference() {
    let mut checked = 0;
    for entry in std::fs::read_dir(root().join("fixtures")).unwrap() {
        let case = entry.unwrap().file_name().to_string_lossy().into_owned();
        let dir = root().join("fixtures").join(&case);
        let file = if dir.join("expected_fosls.json").exists() {
            "expected_fosls.json"
        } else if case.starts_with("exact_")
            || case.starts_with("perturbed_")
            || case.starts_with("scaled_")
        {
            "expected.json"
        } else {
            continue;
        };
        let exp = expected(&case, file);
        let Some(f) = exp.get("functional") else {
            continue;
        };
        let norm = exp["norm"].as_str().unwrap();
        let r = estimate(&case, &["--norm", norm]);
        // The manufactured cases have a body force with kinks (max(x − 0.3, 0)^k): no fixed
        // quadrature integrates the equilibrium term to 1e-8 there; ours (degree 12) and the
        // reference's (degree 19) differ by up to 1 % on the coarsest mesh (ours moves by 4e-3
        // from degree 12 to 40 on manufactured_frictionless_p2_n08), so that term is compared
        // on the polynomial families only. The other terms must still agree.
        let rough = case.starts_with("manufactured_");
        assert_eq!(r.norm, norm);
        for (key, got) in [
            ("constitutive", r.functional.constitutive),
            ("equilibrium", r.functional.equilibrium),
            ("complementarity", r.functional.complementarity),
            ("friction", r.functional.friction),
            ("total", r.functional.total),
        ] {
            let want = f[key].as_f64().unwrap();
            // Their gap max(x − 0.6, 0)² has a kink too: boundary pieces meet it differently.
            let rel = match (rough, key) {
                (true, "equilibrium" | "total") => continue,
                (true, _) => 1e-7,
                _ => 1e-8,
            };
            // Round-off floor: exact cases sit at F/energy ~ 1e-30.
            assert!(
                (got - want).abs() <= rel * want.abs() + 1e-20 * r.energy,
                "{case} {key}: {got} vs {want}"
            );
        }
        close(
            &format!("{case} energy"),
            r.energy,
            exp["energy"].as_f64().unwrap(),
            1e-10,
        );
        checked += 1;
    }
    assert!(checked >= 1, "no fixture carries reference values");
}

/// Scene errors: exit status 2 and one line naming the file, the key and the problem.
#[test]
fn scene_errors_are_one_line_with_exit_status_2() {
    let dir = tempfile::tempdir().unwrap();
    let solution = root().join("fixtures/hertz_ngsolve_p2/solution.vtu");
    let good =
        std::fs::read_to_string(root().join("fixtures/hertz_ngsolve_p2/scene.toml")).unwrap();
    let cases: Vec<(String, String)> = vec![
        (
            good.replace("youngs_modulus = 20600.0", "youngs_modulus = 20600.0\ncolour = \"red\""),
            "material.colour: unknown key (accepted in [material]: youngs_modulus, poisson_ratio, model)".into(),
        ),
        (
            good.replace("youngs_modulus = 20600.0\n", ""),
            "material.youngs_modulus: missing required key".into(),
        ),
        (
            format!(
                "{}\n[estimate]\nnorm = \"energy\"\n",
                good.replace("poisson_ratio = 0.28", "poisson_ratio = 0.5")
            ),
            "estimate.norm: ν = 0.5 needs norm = \"robust\" or \"seed\"".into(),
        ),
        (
            good.replace("kind = \"contact\"", "kind = \"contakt\""),
            "boundary[1] \"contact\".kind: unknown kind \"contakt\"".into(),
        ),
        (
            good.replace("tag = 1", "tag = 7"),
            "boundary[1] \"contact\".tag: no line cell of".into(),
        ),
        (
            good.replace("tag = 1", "where = \"y < -5\""),
            "boundary[1] \"contact\".where: \"y < -5\" holds at no boundary edge midpoint".into(),
        ),
        (
            good.replace("tag_array = \"boundary_tag\"", "tag_array = \"labels\""),
            "boundary[0] \"top\".tag: cell array \"labels\" is not in".into(),
        ),
    ];
    for (i, (text, want)) in cases.iter().enumerate() {
        let scene = dir.path().join(format!("s{i}.toml"));
        std::fs::write(&scene, text).unwrap();
        let out = fosls(&[
            "estimate",
            "--scene",
            scene.to_str().unwrap(),
            solution.to_str().unwrap(),
        ]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "case {i}: {err}");
        assert_eq!(err.lines().count(), 1, "case {i}: {err}");
        assert!(
            err.starts_with(&format!("error: {}: ", scene.display())),
            "case {i}: {err}"
        );
        assert!(err.contains(want.as_str()), "case {i}: {err}");
        assert!(out.stdout.is_empty());
    }
    // No scene next to the file.
    let lone = dir.path().join("lone.vtu");
    std::fs::copy(&solution, &lone).unwrap();
    let out = fosls(&["estimate", lone.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2));
    assert!(err.contains("no scene file: neither"), "{err}");
    // The stem-named scene beside the file is found.
    std::fs::write(dir.path().join("lone.toml"), &good).unwrap();
    let out = fosls(&["estimate", "--quiet", lone.to_str().unwrap()]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Exit codes: --fail-above on the relative error, --strict on admissibility; the output VTU
/// carries the indicator arrays and never replaces the input.
#[test]
fn exit_codes_marking_and_output_file() {
    let dir = tempfile::tempdir().unwrap();
    let case = "fixtures/hertz_skfem_p2";
    let scene = format!("{case}/scene.toml");
    let solution = format!("{case}/solution.vtu");
    let r = estimate("hertz_skfem_p2", &[]);
    let rel = r.relative.unwrap();
    let above = format!("{}", rel * 0.5);
    let below = format!("{}", rel * 2.0);
    let code = |extra: &[&str]| {
        let mut a = vec![
            "estimate", "--quiet", "--stress", "file", "--scene", &scene, &solution,
        ];
        a.extend_from_slice(extra);
        fosls(&a).status.code()
    };
    assert_eq!(code(&["--fail-above", &above]), Some(1));
    assert_eq!(code(&["--fail-above", &below]), Some(0));
    // The scikit-fem P2 solution penetrates between nodes and its projected stress is tensile
    // somewhere: --strict fails.
    assert_eq!(code(&["--strict"]), Some(1));
    assert_eq!(code(&["--mark", "1.5"]), Some(2));
    assert_eq!(code(&["--output", &solution]), Some(2));

    let out = dir.path().join("out.vtu");
    let json = dir.path().join("r.json");
    let o = fosls(&[
        "estimate",
        "--quiet",
        "--stress",
        "file",
        "--scene",
        &scene,
        &solution,
        "--mark",
        "0.5",
        "--output",
        out.to_str().unwrap(),
        "--json",
        json.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let report: Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert!(report["marked"]["share"].as_f64().unwrap() >= 0.5);
    let marked = report["marked"]["count"].as_u64().unwrap() as usize;
    let vtu = fosls::read::vtu::read_vtu(&out).unwrap();
    let get = |n: &str| vtu.cell_data.iter().find(|a| a.name == n).unwrap();
    let eta = get("eta");
    let ntri = r.cells.count;
    // The signed per-cell indicators sum to F.
    let sum: f64 = get("eta_squared").values[..ntri].iter().sum();
    close("Σ η_T² = F", sum, r.functional.total, 1e-12);
    assert_eq!(
        get("marked").values.iter().filter(|&&m| m == 1.0).count(),
        marked
    );
    // η_T of the worst cell in the JSON is the largest of the file's per-cell η.
    let max_eta = eta.values[..ntri].iter().fold(0.0f64, |m, &v| m.max(v));
    close("worst eta", r.cells.worst[0].eta, max_eta, 1e-12);
    assert!(r.cells.worst[0].cell < vtu.cell_count());
    let states = get("contact_state");
    // Frictionless contact is "contact" (code 3), not slip (docs/design.md §8.3).
    assert!(states.values[ntri..].contains(&3.0));
    for name in [
        "eta_constitutive",
        "eta_equilibrium",
        "eta_complementarity",
        "eta_friction",
    ] {
        get(name);
    }
}

/// The same solution in every encoding of fixtures/encodings gives the same F to 1e-9.
#[test]
fn every_encoding_gives_the_same_functional() {
    let dir = tempfile::tempdir().unwrap();
    // The half disc of fixtures/encodings: u = (0, −0.01) on top (tag 2), the arc (tag 1) on
    // the plane y = 0; selected by `where` so that files without tags work too.
    let scene = dir.path().join("scene.toml");
    std::fs::write(
        &scene,
        "[material]\nyoungs_modulus = 20600.0\npoisson_ratio = 0.28\n\
         [fields]\ndisplacement = \"displacement\"\nstress = \"stress\"\n\
         [[boundary]]\nname = \"top\"\nwhere = \"y > 0.999\"\nkind = \"dirichlet\"\n\
         displacement = [0.0, -0.01]\n\
         [[boundary]]\nname = \"arc\"\nwhere = \"y < 0.999\"\nkind = \"contact\"\n\
         obstacle = { plane = { point = [0.0, 0.0], normal = [0.0, 1.0] } }\n\
         normal = \"obstacle\"\n",
    )
    .unwrap();
    let exp: Value = serde_json::from_str(
        &std::fs::read_to_string(root().join("fixtures/encodings/expected.json")).unwrap(),
    )
    .unwrap();
    let mut totals: std::collections::BTreeMap<String, Vec<(String, f64, bool)>> =
        Default::default();
    for (name, info) in exp["files"].as_object().unwrap() {
        let path = root().join("fixtures/encodings").join(name);
        let out = fosls(&[
            "estimate",
            "--quiet",
            "--json",
            "-",
            "--stress",
            "file",
            "--displacement",
            "file",
            "--scene",
            scene.to_str().unwrap(),
            path.to_str().unwrap(),
        ]);
        assert!(
            out.status.success(),
            "{name}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let r: Report = serde_json::from_slice(&out.stdout).unwrap();
        totals
            .entry(info["family"].as_str().unwrap().to_string())
            .or_default()
            .push((
                name.clone(),
                r.functional.total,
                info["lossless"].as_bool().unwrap(),
            ));
    }
    for (family, runs) in totals {
        let canonical = exp["families"][&family]["canonical"].as_str().unwrap();
        let want = runs.iter().find(|r| r.0 == canonical).unwrap().1;
        for (name, total, lossless) in &runs {
            // Lossy encodings (12-digit ASCII, Float32) change the data itself.
            let tol = if *lossless { 1e-9 } else { 1e-4 };
            close(&format!("{family}: {name}"), *total, want, tol);
        }
    }
}

/// ν = 0.4999999 with `energy`: each term equals the hand-derived value (exact rational
/// integration of the polynomial fields, `reference/exact/hand.py`) to 1e-6 relative.
#[test]
fn nearly_incompressible_energy_matches_the_hand_value() {
    let case = "perturbed_nu4999999_energy";
    let r = estimate(case, &["--norm", "energy"]);
    let hand = &expected(case, "expected.json")["hand"];
    close(
        "constitutive",
        r.functional.constitutive,
        hand["constitutive"].as_f64().unwrap(),
        1e-6,
    );
    close(
        "complementarity",
        r.functional.complementarity,
        hand["complementarity"].as_f64().unwrap(),
        1e-6,
    );
    close(
        "total",
        r.functional.total,
        hand["total"].as_f64().unwrap(),
        1e-6,
    );
    close(
        "relative",
        r.relative.unwrap(),
        hand["relative"].as_f64().unwrap(),
        1e-6,
    );
}

/// Scaling E, σ, f and the tractions by 1e9 or 1e-3 leaves `relative` unchanged to 1e-10.
#[test]
fn relative_error_is_invariant_under_scaling_of_the_units() {
    let base = estimate("perturbed_u_energy", &[]).relative.unwrap();
    for case in [
        "scaled_e9_perturbed_u_energy",
        "scaled_em3_perturbed_u_energy",
    ] {
        let r = estimate(case, &[]);
        close(case, r.relative.unwrap(), base, 1e-10);
    }
}

/// Exact solutions in the discrete spaces (the `exact_*` fixtures, incl. ν = 0.5 with
/// `robust`, curved P2 cells and Coulomb slip/stick) give F/energy < 1e-20.
#[test]
fn exact_fixtures_give_zero() {
    let mut n = 0;
    for entry in std::fs::read_dir(root().join("fixtures")).unwrap() {
        let case = entry.unwrap().file_name().to_string_lossy().into_owned();
        if !case.starts_with("exact_") {
            continue;
        }
        let r = estimate(&case, &[]);
        let rel = r.functional.total.abs() / r.energy;
        assert!(rel < 1e-20, "{case}: F/energy = {rel:e}");
        n += 1;
    }
    assert!(n >= 5);
}
