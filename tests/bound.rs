//! The error bound of docs/design.md §6 end to end (issue 13). Independent sources: the exact
//! solutions of `reference/exact` (the bound must vanish to round-off and be guaranteed) and
//! the manufactured family of `reference/manufactured`, whose true energy error is in each
//! fixture's expected.json.

mod common;

use common::cli::{estimate, root};

/// For an exact solution in the spaces the patch reconstruction reproduces Cε(u_h), and the
/// bound is 0 to round-off and guaranteed (P1: RT_1 patches).
#[test]
fn exact_p1_solution_gives_a_zero_guaranteed_bound() {
    let file = root().join("fixtures/exact_p1_energy/solution.vtu");
    for args in [&["--stress", "patch"][..], &["--stress", "file"][..]] {
        let (code, r, err) = estimate(&file, args);
        assert_eq!(code, 0, "{args:?}: {err}");
        let r = r.expect("a report");
        let b = &r.bound;
        assert!(b.guaranteed, "{args:?}: {:?}", b.failed_hypotheses);
        let rel = b.relative.expect("a relative bound");
        assert!(rel < 1e-10, "{args:?}: bound / energy^½ = {rel:e}");
        assert!(b.failed_hypotheses.is_empty());
    }
}

/// The global FOSLS minimiser of a non-Galerkin-exact problem is not equilibrated: no bound
/// is printed, and the reason says so (the old `bound.value` was 0.38–0.61 of the error).
#[test]
fn the_global_minimiser_gives_no_bound() {
    let file = root().join("fixtures/manufactured_frictionless_p1_n08/solution.vtu");
    let (code, r, err) = estimate(&file, &["--stress", "global"]);
    assert!(code == 0 || code == 1, "{err}");
    let b = r.expect("a report").bound;
    assert!(!b.guaranteed);
    assert_eq!(b.energy_error, None);
    assert!(
        b.failed_hypotheses
            .iter()
            .any(|h| h.starts_with("σ_h is not equilibrated")),
        "{:?}",
        b.failed_hypotheses
    );
}

/// Wherever a bound is printed on the manufactured family it is ≥ the true energy error, and
/// it is never called guaranteed there (the data are not in the discrete spaces).
#[test]
fn printed_bounds_on_the_manufactured_family_are_above_the_true_error() {
    for p in [1, 2] {
        for n in ["04", "08", "16"] {
            let dir = root().join(format!("fixtures/manufactured_frictionless_p{p}_n{n}"));
            let expected: serde_json::Value =
                serde_json::from_str(&std::fs::read_to_string(dir.join("expected.json")).unwrap())
                    .unwrap();
            let truth = expected["errors"]["fe"]["energy"].as_f64().unwrap();
            let (code, r, err) = estimate(&dir.join("solution.vtu"), &["--stress", "patch"]);
            assert!(code == 0 || code == 1, "p{p} n{n}: {err}");
            let b = r.expect("a report").bound;
            assert!(!b.guaranteed, "p{p} n{n}");
            if let Some(e) = b.energy_error {
                assert!(
                    e >= truth,
                    "p{p} n{n}: bound {e} below the true error {truth}"
                );
            }
        }
    }
}

/// ν = 0.5: no bound in the energy norm, with the reason.
#[test]
fn incompressible_material_gives_no_bound() {
    let file = root().join("fixtures/hertz_skfem_p2_nu05/solution.vtu");
    let (code, r, err) = estimate(&file, &[]);
    assert!(code == 0 || code == 1, "{err}");
    let b = r.expect("a report").bound;
    assert!(!b.guaranteed && b.energy_error.is_none());
    assert_eq!(
        b.failed_hypotheses,
        ["ν = 0.5: no bound in the energy norm"]
    );
}

/// `--stress patch` at ν = 0.5 is refused with one line naming the reason.
#[test]
fn patch_reconstruction_is_refused_at_nu_one_half() {
    let file = root().join("fixtures/hertz_skfem_p2_nu05/solution.vtu");
    let (code, _, err) = estimate(&file, &["--stress", "patch"]);
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("the patch reconstruction needs λ < ∞"),
        "{err}"
    );
    assert_eq!(err.trim().lines().count(), 1, "{err}");
}
