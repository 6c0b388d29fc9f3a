//! The error bound of docs/design.md §6 end to end (issue 13). Independent sources: the exact
//! solutions of `reference/exact` (the bound must vanish to round-off and be guaranteed) and
//! the manufactured family of `reference/manufactured`, whose true energy error is in each
//! fixture's expected.json.

mod common;

use common::cli::{estimate, fixture_with_scene, root};

/// A fixture's expected.json (written by `reference/`, never by fosls).
fn expected(dir: &std::path::Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join("expected.json")).unwrap()).unwrap()
}

/// For an exact solution in the spaces the patch reconstruction reproduces Cε(u_h), and the
/// bound is 0 to round-off and guaranteed: P1 (RT_1 patches, and the file's own stress), P2
/// (RT_2 patches) on straight and on curved cells.
#[test]
fn exact_solutions_give_a_zero_guaranteed_bound() {
    let cases: [(&str, &[&str]); 4] = [
        ("exact_p1_energy", &["--stress", "patch"]),
        ("exact_p1_energy", &["--stress", "file"]),
        ("exact_p2_energy", &["--stress", "patch"]),
        ("exact_p2_curved_energy", &["--stress", "patch"]),
    ];
    for (case, args) in cases {
        let file = root().join(format!("fixtures/{case}/solution.vtu"));
        let (code, r, err) = estimate(&file, args);
        assert_eq!(code, 0, "{case} {args:?}: {err}");
        let b = r.expect("a report").bound;
        assert!(b.guaranteed, "{case} {args:?}: {:?}", b.failed_hypotheses);
        let rel = b.relative.expect("a relative bound");
        assert!(rel < 1e-10, "{case} {args:?}: bound / energy^½ = {rel:e}");
        assert!(b.failed_hypotheses.is_empty());
    }
}

/// A known perturbation of an exact P2 solution (reference/exact: u + δw, lift-off on the
/// contact line, σ exact): the file's displacement is not a Galerkin solution, so the patch
/// loads are rebalanced by flows; the bound is guaranteed and above the true error
/// (½|||δw|||²)^½ = F_const^½ of the hand integration, and `relative` does not depend on the
/// scale of E (1e-3 and 1e9 times the same problem).
#[test]
fn perturbed_solution_gets_a_guaranteed_bound_above_the_true_error() {
    let dir = root().join("fixtures/perturbed_u_energy");
    let expected = expected(&dir);
    let truth = expected["hand"]["constitutive"].as_f64().unwrap().sqrt();
    let (code, r, err) = estimate(&dir.join("solution.vtu"), &["--stress", "patch"]);
    assert!(code == 0 || code == 1, "{err}");
    let b = r.expect("a report").bound;
    assert!(b.guaranteed, "{:?}", b.failed_hypotheses);
    let e = b.energy_error.expect("a bound");
    assert!(e >= truth, "bound {e} below the true error {truth}");
    let rel = b.relative.unwrap();
    for scaled in [
        "scaled_e9_perturbed_u_energy",
        "scaled_em3_perturbed_u_energy",
    ] {
        let file = root().join(format!("fixtures/{scaled}/solution.vtu"));
        let (_, r, err) = estimate(&file, &["--stress", "patch"]);
        let other = r.expect(&err).bound.relative.expect("a relative bound");
        // 1e-8: the lift-off patches are infeasible and take the all-rows-penalised fallback
        // (M + ρQᵀQ, ρ = 1e6 max M_ii), whose minimiser carries round-off ~1e-10 relative that
        // differs between the scalings (measured 3.3e-10 for 1e9).
        assert!(
            (other - rel).abs() <= 1e-8 * rel,
            "{scaled}: relative {other} against {rel}"
        );
    }
}

/// The global FOSLS minimiser of a non-Galerkin-exact problem is not equilibrated: no bound
/// is printed, and the reason says so (the old `bound.value` was 0.38–0.61 of the error).
#[test]
fn the_global_minimiser_gives_no_bound() {
    let file = root().join("fixtures/manufactured_frictionless_p1_n08/solution.vtu");
    assert_refused_as_not_equilibrated(&file, &["--stress", "global"]);
}

/// `estimate file args` prints no bound, and says the stress is not equilibrated.
fn assert_refused_as_not_equilibrated(file: &std::path::Path, args: &[&str]) {
    let (code, r, err) = estimate(file, args);
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

/// The manufactured family (scikit-fem, its own quadrature of the kinked f and t, so the patch
/// loads are rebalanced): a bound is printed on every mesh (n = 4, 8, 16, 32), it is ≥ the true
/// energy error, never called guaranteed (data outside the discrete spaces, Korn constants), and
/// on P2 it converges at least at rate 1.5 from n = 8 to 16 (the error's rate there: 1.76).
///
/// Over the finest pair (n = 16 → 32) the bound's rate is compared with the true error's own
/// rate (from expected.json; measured 1.89 for P2, 0.99 for P1, against 2.04 and 1.07 for the
/// bound): it may fall short of it by at most 0.1, i.e. the efficiency index may grow by at
/// most 2^0.1 ≈ 7 % on that refinement. It falls on both degrees (P2 2.33 → 2.10: η_osc is of
/// higher order; P1 3.98 → 3.76: η_as and η_PS converge at the error's rate 1, η_osc at ≈ 2.5),
/// so the margin only absorbs changes of the reconstruction that leave it asymptotically
/// efficient. The comparison is meaningful only in the asymptotic regime, which the error's
/// own rates are checked to be in (P2 ≥ 1.8 with u ∈ H^{3.5−}, P1 ≥ 0.9).
#[test]
fn bounds_on_the_manufactured_family_are_above_the_true_error() {
    let log2_ratio = |v: &[f64], i: usize| (v[i] / v[i + 1]).log2();
    for p in [1, 2] {
        let mut bounds = Vec::new();
        let mut truths = Vec::new();
        let (mut traction, mut lift) = (Vec::new(), Vec::new());
        for n in ["04", "08", "16", "32"] {
            let dir = root().join(format!("fixtures/manufactured_frictionless_p{p}_n{n}"));
            let expected = expected(&dir);
            let truth = expected["errors"]["fe"]["energy"].as_f64().unwrap();
            let (code, r, err) = estimate(&dir.join("solution.vtu"), &["--stress", "patch"]);
            assert!(code == 0 || code == 1, "p{p} n{n}: {err}");
            let b = r.expect("a report").bound;
            assert!(!b.guaranteed, "p{p} n{n}");
            let e = b
                .energy_error
                .unwrap_or_else(|| panic!("p{p} n{n}: no bound: {:?}", b.failed_hypotheses));
            assert!(
                e >= truth,
                "p{p} n{n}: bound {e} below the true error {truth}"
            );
            // Every cell exactly symmetric, P1 included (RT_2 with the rotation shares of the
            // P1 patches): no Korn asymmetry term, and no asymmetry hypothesis fails.
            let terms = b.terms.as_ref().expect("terms");
            assert_eq!(terms.asymmetry, 0.0, "p{p} n{n}");
            assert!(
                !b.failed_hypotheses.iter().any(|h| h.contains("as σ_h")),
                "p{p} n{n}: {:?}",
                b.failed_hypotheses
            );
            // Data outside the spaces are terms (the trace term of the Neumann data, the lifting
            // of the Dirichlet data between the nodes), not failed hypotheses.
            assert!(
                !b.failed_hypotheses
                    .iter()
                    .any(|h| h.contains("Dirichlet data") || h.contains("traction data")),
                "p{p} n{n}: {:?}",
                b.failed_hypotheses
            );
            assert!(
                terms.traction > 0.0 && terms.dirichlet_lift > 0.0,
                "p{p} n{n}"
            );
            // The P1 files' linear traces cross the convex obstacle between their active
            // nodes (the scikit-fem solver meets the constraints at the nodes only): the bound
            // is taken on the P2 elevation, whose lifted mid-edge nodes remove the penetration
            // from the failed hypotheses (P2: the lift on the file's own mid nodes).
            assert!(
                !b.failed_hypotheses.iter().any(|h| h.contains("penetrates")),
                "p{p} n{n}: {:?}",
                b.failed_hypotheses
            );
            assert_eq!(
                b.statement.contains("P2 elevation of the P1 mesh"),
                p == 1,
                "p{p} n{n}: {}",
                b.statement
            );
            traction.push(terms.traction);
            lift.push(terms.dirichlet_lift);
            bounds.push(e);
            truths.push(truth);
        }
        // Both data terms are of higher order than the error (the lifting of a trace mismatch
        // of O(h^(p+1)) costs O(h^(p+½)) in energy; the traction term O(h^(k+1+½+½))): their
        // rates from n = 16 to 32 exceed the error's by at least 0.3.
        let true_rate = log2_ratio(&truths, 2);
        for (what, v) in [("lifting", &lift), ("traction", &traction)] {
            let r = log2_ratio(v, 2);
            assert!(r >= true_rate + 0.3, "P{p} {what} rate {r} ({v:?})");
        }
        if p == 2 {
            let rate = log2_ratio(&bounds, 1);
            assert!(rate >= 1.5, "P2 bound rate {rate} ({bounds:?})");
        }
        // Efficiency against the exact solution (n = 4 / 8 / 16 / 32): P1 1.56 / 1.31 / 1.18 /
        // 1.08 with the lift on the P2 elevation (session 35; 1.55 / 1.28 / 1.15 / 1.07 before,
        // for a v that penetrated), P2 1.90 / 1.46 / 1.26 / 1.15 with the default colour-ordered
        // patches and the rows that disagree met order-independently (session 33; P1 before: 1.82 / 1.44 / 1.17
        // / 1.07; session 28, independent patches + one sweep: P1 1.70 / 1.37 / 1.15 / 1.06, P2 1.89 / 1.45 /
        // 1.25 / 1.14; independent patches alone, session 24: P1 2.07 / 1.61 / 1.25 / 1.11, P2 1.95 / 1.53 / 1.37 / 1.30; session 23:
        // P1 3.17 / 2.32 / 1.68 / 1.40, P2 3.96 / 2.72 / 1.79 / 1.60). Issue 13 asks ≤ 2 on
        // every mesh, with ≤ 1.5 as the target: asserted ≤ 2 at n = 4 and ≤ 1.5 from n = 8.
        for i in 0..4 {
            let index = bounds[i] / truths[i];
            let limit = [2.0, 1.5, 1.5, 1.5][i];
            assert!(
                index <= limit,
                "P{p} mesh {i}: efficiency index {index} > {limit}"
            );
        }
        let rate = log2_ratio(&bounds, 2);
        let asymptotic = if p == 2 { 1.8 } else { 0.9 };
        assert!(
            true_rate >= asymptotic,
            "P{p}: the true error's rate {true_rate} from n = 16 to 32 ({truths:?})"
        );
        assert!(
            rate >= true_rate - 0.1,
            "P{p}: bound rate {rate} from n = 16 to 32 against the error's {true_rate} \
             (bounds {bounds:?}, errors {truths:?})"
        );
    }
}

/// `--sweeps 1` after the colour-ordered patch solves (design §5.10) lowers the bound on the
/// coarsest manufactured P1 mesh, where the default gives the largest index (measured 1.82
/// without, 1.62 with the sweep), and the bound stays above the exact solution's true error.
#[test]
fn a_sweep_lowers_the_bound_and_keeps_it_above_the_true_error() {
    let dir = root().join("fixtures/manufactured_frictionless_p1_n04");
    let expected = expected(&dir);
    let truth = expected["errors"]["fe"]["energy"].as_f64().unwrap();
    let bound = |args: &[&str]| {
        let (code, r, err) = estimate(&dir.join("solution.vtu"), args);
        assert!(code == 0 || code == 1, "{args:?}: {err}");
        let b = r.expect("a report").bound;
        b.energy_error
            .unwrap_or_else(|| panic!("{args:?}: no bound: {:?}", b.failed_hypotheses))
    };
    let plain = bound(&["--stress", "patch"]);
    let swept = bound(&["--stress", "patch", "--sweeps", "1"]);
    assert!(
        swept >= truth,
        "swept bound {swept} below the true error {truth}"
    );
    assert!(
        swept < 0.95 * plain,
        "the sweep left the bound at {swept} against {plain} (true error {truth})"
    );
}

/// Dirichlet data that u_h misses AT its nodes cannot be lifted edge by edge (the lifting
/// must vanish at the edge's ends): with `--displacement file` (no projection onto K_u, which
/// would move the nodes) the mismatch stays a failed hypothesis, with its size (1e-3 plus the
/// 6e-6 the file misses between its nodes). Here the data
/// of the top edge of manufactured_frictionless_p2_n08 are shifted by 1e-3.
#[test]
fn dirichlet_data_missed_at_the_nodes_stay_a_failed_hypothesis() {
    let (_dir, file) = fixture_with_scene(
        "manufactured_frictionless_p2_n08",
        "displacement = [\"(",
        "displacement = [\"1e-3 + (",
    );
    let (code, r, err) = estimate(&file, &["--stress", "patch", "--displacement", "file"]);
    assert!(code == 0 || code == 1, "{err}");
    let b = r.expect("a report").bound;
    assert!(
        b.failed_hypotheses
            .iter()
            .any(|h| h.starts_with("u_h misses the Dirichlet data (max 1.00")),
        "{:?}",
        b.failed_hypotheses
    );
    // The Neumann data are still covered by their term.
    assert!(
        !b.failed_hypotheses
            .iter()
            .any(|h| h.contains("traction data")),
        "{:?}",
        b.failed_hypotheses
    );
}

/// A vertex whose only cell has both of its edges there on Neumann boundaries: its patch's
/// only unknowns are the cell's interior (kernel) values, which enter neither the flux balance
/// nor the constant weak-symmetry row. Those rows used to carry ~1e-14 of round-off there, so
/// an unbalanced load was "met" by values ~1e14: the stress was 1e13 times too large, missed
/// its tractions by 38 and the bound was 1.2e13. The curved P2 exact mesh with its inner arc
/// made traction-free (the file's u_h then solves another problem, so the loads need flows):
/// by construction σ_h n = Π_2 t exactly on every Neumann edge (t = 0 on the arc and a constant
/// on the left edge, both in the space), so the traction misfit is round-off of the largest
/// traction 14.6, and the bound is finite and guaranteed.
#[test]
fn a_corner_patch_with_kernel_values_only_meets_its_tractions() {
    let arc = "name = \"inner_arc\"\ntag = 4\nkind = \"dirichlet\"\n\
               displacement = [\"0.0005 + 0.001*x\", \"-0.004*y\"]";
    let free = "name = \"inner_arc\"\ntag = 4\nkind = \"neumann\"\ntraction = [\"0\", \"0\"]";
    let (_dir, file) = fixture_with_scene("exact_p2_curved_energy", arc, free);
    let (code, r, err) = estimate(&file, &["--stress", "patch"]);
    assert!(code == 0 || code == 1, "{err}");
    let r = r.expect("a report");
    let misfit = r.admissibility.neumann_max;
    assert!(misfit <= 1e-9 * 14.63, "σ_h n − t up to {misfit:e}");
    let b = &r.bound;
    assert!(b.guaranteed, "{:?}", b.failed_hypotheses);
    let e = b.energy_error.expect("a bound");
    // u_h solves another problem, so the error is of the size of u_h itself: a sane stress
    // gives a bound of the order of energy^½ (measured 0.436 against 0.656), not 1e13.
    assert!(e.is_finite() && e < 10.0 * r.energy.sqrt(), "bound {e:e}");
}

/// A scene without a Dirichlet boundary whose only support is frictionless contact on the
/// plane y = 0 leaves the translation along x free (by hand: ρ = e_x has ρ·n = 0 on every
/// contact edge, while e_y and the rotation move the contact edges along n). The block file
/// with its Dirichlet top made traction-free: the report says so; with the scene as committed
/// it does not.
#[test]
fn a_scene_without_dirichlet_data_names_the_rigid_motion_it_leaves_free() {
    let (_dir, file) = fixture_with_scene(
        "block_skfem_p1",
        "kind = \"dirichlet\"\ndisplacement = [0.0, -0.01]",
        "kind = \"neumann\"\ntraction = [\"0\", \"0\"]",
    );
    let free_notes = |r: &fosls::report::json::Report| -> Vec<String> {
        r.notes
            .iter()
            .filter(|n| n.starts_with("the scene leaves"))
            .cloned()
            .collect()
    };
    let (code, r, err) = estimate(&file, &[]);
    assert!(code == 0 || code == 1, "{err}");
    let notes = free_notes(&r.expect("a report"));
    assert_eq!(notes.len(), 1, "{notes:?}");
    assert!(
        notes[0].starts_with("the scene leaves the translation along (1.000, 0.000) free")
            || notes[0].starts_with("the scene leaves the translation along (-1.000, 0.000) free"),
        "{}",
        notes[0]
    );
    let committed = root().join("fixtures/block_skfem_p1/solution.vtu");
    let (code, r, err) = estimate(&committed, &[]);
    assert!(code == 0 || code == 1, "{err}");
    assert!(free_notes(&r.expect("a report")).is_empty());
}

/// A contact edge whose direction never meets the obstacle (the exact P1 square's left side
/// as contact with the plane y = 0 and `normal = "body"`: n = (−1, 0) is parallel to the plane)
/// can never be in contact, so its condition is σ_n = 0. By hand, the file's exact stress has
/// σ_n = σ_xx = −14.6307 there: that is the tension violation, named, and no pairing is
/// infinite. (Every stress source used to stop with "functional.total is infinite / not a
/// number": the pairing (u_n − g)σ_n with g = ∞, or the global minimiser's load with it.) The
/// patch stress is traction-free there to round-off and gets a finite bound.
#[test]
fn a_contact_edge_facing_away_from_the_obstacle_is_traction_free() {
    let left = "kind = \"neumann\"\ntraction = [\"14.630681818181827\", \"0.0\"]";
    let away = "kind = \"contact\"\n\
                obstacle = { plane = { point = [0.0, 0.0], normal = [0.0, 1.0] } }\n\
                normal = \"body\"";
    let (_dir, file) = fixture_with_scene("exact_p1_energy", left, away);
    let (code, r, err) = estimate(&file, &["--stress", "file", "--displacement", "file"]);
    assert!(code == 0 || code == 1, "{err}");
    let r = r.expect("a report");
    let sigma_xx = 14.630681818181827;
    let t = r.admissibility.tension_max;
    assert!((t - sigma_xx).abs() <= 1e-9 * sigma_xx, "tension_max {t}");
    assert!(r.functional.total.is_finite());
    assert!(
        r.bound
            .failed_hypotheses
            .iter()
            .any(|h| h.contains("presses where its direction never meets the obstacle")),
        "{:?}",
        r.bound.failed_hypotheses
    );
    for stress in ["patch", "global"] {
        let (code, r, err) = estimate(&file, &["--stress", stress, "--displacement", "file"]);
        assert!(code == 0 || code == 1, "{stress}: {err}");
        let r = r.expect("a report");
        assert!(r.functional.total.is_finite(), "{stress}");
        let t = r.admissibility.tension_max;
        assert!(t <= 1e-9 * sigma_xx, "{stress}: tension_max {t}");
    }
}

/// `auto` (no option) rebuilds a missing or inadmissible stress by patch equilibration on
/// triangles, so the default run gives the bound: above the exact solution's error on a
/// manufactured P2 mesh, guaranteed on the Hertz P2 file. On quadrilaterals F keeps the global
/// minimiser, and the bound is taken on the triangle halves (design §6.7).
#[test]
fn the_default_mode_gives_the_bound() {
    let dir = root().join("fixtures/manufactured_frictionless_p2_n16");
    let expected = expected(&dir);
    let truth = expected["errors"]["fe"]["energy"].as_f64().unwrap();
    let (code, r, err) = estimate(&dir.join("solution.vtu"), &[]);
    assert!(code == 0 || code == 1, "{err}");
    let r = r.expect("a report");
    assert!(
        r.stress.space.contains("equilibrated on vertex patches"),
        "{}",
        r.stress.space
    );
    let e = r.bound.energy_error.expect("a bound");
    assert!(e >= truth, "bound {e} below the true error {truth}");
    let (code, r, err) = estimate(&root().join("fixtures/hertz_skfem_p2/solution.vtu"), &[]);
    assert!(code == 0 || code == 1, "{err}");
    let b = r.expect("a report").bound;
    assert!(b.guaranteed, "{:?}", b.failed_hypotheses);
    let (code, r, err) = estimate(
        &root().join("fixtures/quad_manufactured_q2_n08/solution.vtu"),
        &[],
    );
    assert!(code == 0 || code == 1, "{err}");
    let r = r.expect("a report");
    assert!(
        r.stress.space.contains("global minimiser"),
        "{}",
        r.stress.space
    );
    let truth = crate::expected(&root().join("fixtures/quad_manufactured_q2_n08"))["errors"]["fe"]
        ["energy"]
        .as_f64()
        .unwrap();
    let e = r.bound.energy_error.expect("a bound on quadrilaterals");
    assert!(e >= truth, "Q2: bound {e} below the true error {truth}");
    // The four triangles about each centre give the smaller bound here (index 1.88 against
    // 2.95 on the halves), and the statement says which split it was taken on.
    assert!(
        r.bound
            .statement
            .contains("four triangles about each quadrilateral's centre"),
        "{}",
        r.bound.statement
    );
}

/// The bound on quadrilaterals (design §6.7) for exact solutions in the spaces: Q1, Q2 (straight
/// and curved), serendipity and a mixed P2/Q2 mesh. The P2 interpolant on the halves is u_h
/// itself where u_h is quadratic (Q1 on parallelograms, every exact field here is at most
/// quadratic), so the bound and its split term vanish to round-off, and it is guaranteed.
#[test]
fn quadrilateral_exact_solutions_give_a_zero_guaranteed_bound() {
    for case in [
        "quad_exact_q1_energy",
        "quad_exact_q2_energy",
        "quad_exact_q2_curved_energy",
        "quad_exact_s2_energy",
        "quad_exact_mixed_p2q2_energy",
    ] {
        let file = root().join(format!("fixtures/{case}/solution.vtu"));
        let (code, r, err) = estimate(&file, &[]);
        assert_eq!(code, 0, "{case}: {err}");
        let b = r.expect("a report").bound;
        assert!(b.guaranteed, "{case}: {:?}", b.failed_hypotheses);
        let rel = b.relative.expect("a relative bound");
        assert!(rel < 1e-10, "{case}: bound / energy^½ = {rel:e}");
        let split = b.terms.expect("terms").halves;
        assert!(split < 1e-12, "{case}: |||ũ_h − u_h||| = {split:e}");
    }
}

/// The bound on quadrilaterals against the manufactured family's exact solution (Q1, Q2 and
/// serendipity, 4 / 8 / 16 squares per side): above the true error on every mesh, at its rate.
/// On the parallelograms of Q1 the field is P2 on the halves, so the split costs nothing
/// (|||ũ_h − u_h||| at round-off) and the index is that of the triangle bound: measured 1.43 /
/// 1.27 / 1.15. On Q2 and S2 ũ_h misses the biquadratic part, by 0.58–0.60 × the true error
/// on the four triangles about each centre: added to the bound for ũ_h, the index was 2.00 /
/// 1.88 / 1.85. The stress equilibrated on the split, paired with u_h itself (design §6.3, "u_h
/// itself"), pays no such distance: measured 1.32 / 1.17 / 1.14 (S2 1.31 / 1.18 / 1.14).
#[test]
fn quadrilateral_bounds_on_the_manufactured_family_are_above_the_true_error() {
    for (family, limit) in [
        ("q1", [1.5, 1.35, 1.25]),
        ("q2", [1.4, 1.25, 1.2]),
        ("s2", [1.4, 1.25, 1.2]),
    ] {
        let (mut bounds, mut truths) = (Vec::new(), Vec::new());
        for (i, n) in ["04", "08", "16"].into_iter().enumerate() {
            let dir = root().join(format!("fixtures/quad_manufactured_{family}_n{n}"));
            let truth = expected(&dir)["errors"]["fe"]["energy"].as_f64().unwrap();
            let (code, r, err) = estimate(&dir.join("solution.vtu"), &[]);
            assert!(code == 0 || code == 1, "{family} n{n}: {err}");
            let b = r.expect("a report").bound;
            let e = b
                .energy_error
                .unwrap_or_else(|| panic!("{family} n{n}: no bound: {:?}", b.failed_hypotheses));
            assert!(
                e >= truth,
                "{family} n{n}: bound {e} below the true error {truth}"
            );
            assert!(
                e <= limit[i] * truth,
                "{family} n{n}: index {} > {}",
                e / truth,
                limit[i]
            );
            let split = b.terms.expect("terms").halves;
            assert!(
                split < 1e-12 * e,
                "{family} n{n}: |||ũ_h − u_h||| = {split:e} in the bound"
            );
            if family != "q1" {
                assert!(
                    b.statement.ends_with("paired with u_h itself)"),
                    "{family} n{n}: {}",
                    b.statement
                );
            }
            bounds.push(e);
            truths.push(truth);
        }
        let rate = |v: &[f64]| (v[1] / v[2]).log2();
        assert!(
            (rate(&bounds) - rate(&truths)).abs() < 0.15,
            "{family}: bound rate {} against the error's {} ({bounds:?}, {truths:?})",
            rate(&bounds),
            rate(&truths)
        );
    }
}

/// A patch reconstruction whose constraints cannot all be met is not used by `auto`: on the
/// CalculiX CPE6 Hertz file with `normal = "body"` (float32 coordinates, so the body normal
/// turns inside the edges) it left σ_t ≈ 2e5 on the frictionless contact and η = 2.1e5. The
/// default run falls back to the global minimiser: the same η as `--stress global`, with the
/// note saying so, naming the likely cause (`normal = "body"` on a curved boundary), and no
/// bound.
#[test]
fn auto_falls_back_to_the_global_minimiser_when_patches_cannot_be_met() {
    let src = root().join("fixtures/calculix_hertz_cpe6_penalty");
    let dir = tempfile::tempdir().unwrap();
    for f in std::fs::read_dir(&src).unwrap() {
        let f = f.unwrap().path();
        std::fs::copy(&f, dir.path().join(f.file_name().unwrap())).unwrap();
    }
    let scene = std::fs::read_to_string(src.join("scene.toml")).unwrap();
    let body = scene.replace("normal = \"obstacle\"", "normal = \"body\"");
    assert_ne!(body, scene);
    let scene_path = dir.path().join("scene.toml");
    std::fs::write(&scene_path, body).unwrap();
    let expected = expected(&src);
    let file = dir.path().join(expected["entry"].as_str().unwrap());
    let scene_arg = scene_path.to_str().unwrap();
    let (code, auto, err) = estimate(&file, &["--scene", scene_arg]);
    assert!(code == 0 || code == 1, "{err}");
    let auto = auto.expect("a report");
    let (code, global, err) = estimate(&file, &["--scene", scene_arg, "--stress", "global"]);
    assert!(code == 0 || code == 1, "{err}");
    let global = global.expect("a report");
    let note = auto
        .notes
        .iter()
        .find(|n| n.starts_with("the patch reconstruction could not meet the constraints"))
        .unwrap_or_else(|| panic!("{:?}", auto.notes));
    // The likely cause is named: the arc is curved and the scene measures along the body's
    // normal, while CalculiX constrained u along the plane's.
    assert!(
        note.ends_with(
            "; the contact boundary \"contact\" is curved and the scene measures u_n and g \
             along the body's normal (normal = \"body\", the default): if the solver \
             constrained u along the plane's normal, normal = \"obstacle\" states its problem \
             (docs/design.md §2.4)"
        ),
        "{note}"
    );
    let (a, g) = (auto.eta.unwrap(), global.eta.unwrap());
    assert!((a - g).abs() <= 1e-12 * g, "auto η {a}, global η {g}");
    assert!(a < 0.1 && auto.bound.energy_error.is_none(), "{a}");
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

/// `--degree` with `--stress patch` names RT_k, k ∈ {1, 2}; anything else is a usage error, and
/// the report says which option rebuilt the stress and which space it used.
#[test]
fn patch_degree_is_checked_and_the_reason_names_the_option() {
    let file = root().join("fixtures/hertz_skfem_p1/solution.vtu");
    for k in ["0", "3"] {
        let (code, _, err) = estimate(&file, &["--stress", "patch", "--degree", k]);
        assert_eq!(code, 2, "{err}");
        assert_eq!(
            err.trim(),
            format!(
                "error: --degree {k} with --stress patch: RT_1 and RT_2 are available \
                 (default: RT_2)"
            )
        );
    }
    for (args, space) in [
        (&["--stress", "patch"][..], "RT_2 row-wise"),
        (&["--stress", "patch", "--degree", "1"][..], "RT_1 row-wise"),
    ] {
        let (code, r, err) = estimate(&file, args);
        assert!(code == 0 || code == 1, "{err}");
        let r = r.expect("a report");
        assert!(r.stress.space.starts_with(space), "{}", r.stress.space);
        assert_eq!(r.stress.reason, "asked for with --stress patch");
    }
}

/// Hertz against the fine scikit-fem reference of `reference/speed_accuracy` (its committed
/// `results.json`: `err_u_E_file_nodal` of the M0 file, the committed fixture's mesh and
/// solver, is the true energy error of the file's u_h, computed without fosls): the patch bound
/// is guaranteed, above the true error and within 1.5 times it, on P1 and P2 (measured 1.06 and
/// 1.09 with the colour-ordered patches of session 28, 1.09 and 1.11 with independent ones and
/// the P_1 weak symmetry; 1.17 and 1.31 with constant weak symmetry, 1.41 and 1.43
/// with the piecewise Cε(u_h) target; before the open-arc edges were solved traction-free and
/// the P1 weak symmetry: 3.33 P1 not guaranteed, 2.31 P2).
#[test]
fn hertz_patch_bounds_are_guaranteed_and_within_one_and_a_half_times_the_true_error() {
    let results: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(root().join("reference/speed_accuracy/results.json")).unwrap(),
    )
    .unwrap();
    for p in [1, 2] {
        let case = format!("hertz_skfem_p{p}_M0");
        let truth = results["rows"]
            .as_array()
            .unwrap()
            .iter()
            .find(|r| r["case"] == case.as_str() && r["displacement"] == "file")
            .and_then(|r| r["err_u_E_file_nodal"].as_f64())
            .unwrap_or_else(|| panic!("{case}: no reference error"));
        let file = root().join(format!("fixtures/hertz_skfem_p{p}/solution.vtu"));
        let (code, r, err) = estimate(&file, &["--stress", "patch"]);
        assert!(code == 0 || code == 1, "{err}");
        let b = r.expect("a report").bound;
        assert!(b.guaranteed, "P{p}: {:?}", b.failed_hypotheses);
        let e = b.energy_error.expect("a bound");
        assert!(
            e >= truth && e <= 1.5 * truth,
            "P{p}: bound {e}, true error {truth}, index {}",
            e / truth
        );
    }
}

/// CalculiX writes float32 coordinates, so its straight CPE6 cells have mid nodes ~1e-7 off the
/// edge midpoints: the bound corrects them with the exact Piola map (curved-cell correction),
/// and every one of the 775 cells is symmetrised (30 kept a Korn term before, and the bound
/// was not guaranteed).
#[test]
fn float32_six_node_cells_are_all_symmetrised() {
    let file = root().join("fixtures/calculix_hertz_cpe6_penalty/hertz.vtu");
    let (code, r, err) = estimate(&file, &["--stress", "patch"]);
    assert!(code == 0 || code == 1, "{err}");
    let b = r.expect("a report").bound;
    let terms = b.terms.as_ref().expect("terms");
    assert_eq!(terms.symmetrised_cells, b.cells.len());
    assert_eq!(terms.asymmetry, 0.0);
    assert!(b.guaranteed, "{:?}", b.failed_hypotheses);
}

/// A fine reference's committed true errors (`reference/<family>/fine_errors.json`, computed
/// without fosls) and the reference's own error bound.
fn fine_reference(family: &str) -> (serde_json::Value, f64) {
    let path = root().join(format!("reference/{family}/fine_errors.json"));
    let fine: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    let reference_error = fine["reference_error_bound"].as_f64().expect("a bound");
    (fine, reference_error)
}

/// The true error of fixture `case` in a [`fine_reference`].
fn true_error(fine: &serde_json::Value, case: &str) -> f64 {
    fine["fixtures"][case]["energy_error"]
        .as_f64()
        .unwrap_or_else(|| panic!("{case}: no reference error"))
}

/// Bound `e` of `case` is above its true error plus the reference's own error, and within
/// `limit` times the true error.
fn assert_above_and_within(case: &str, e: f64, truth: f64, reference_error: f64, limit: f64) {
    assert!(
        e >= truth + reference_error && e <= limit * truth,
        "{case}: bound {e}, true error {truth} (± {reference_error}), index {}",
        e / truth
    );
}

/// Hertz from NGSolve's penalty solver (the files penetrate the obstacle by ≈ 9e-6, so the bound
/// adds the distance of the projection onto K_u) against the fine scikit-fem reference of
/// `reference/hertz/fine_error.py` (its committed `fine_errors.json`, computed without fosls):
/// the patch bound is guaranteed, above the true error plus the reference's own error bound,
/// and within 1.5 times the true error (measured P2 1.17, P1 1.06; independent patches P2 1.19,
/// P1 1.09).
#[test]
fn hertz_penalty_bounds_are_guaranteed_against_the_fine_reference() {
    let (fine, reference_error) = fine_reference("hertz");
    for case in ["hertz_ngsolve_p1", "hertz_ngsolve_p2"] {
        let truth = true_error(&fine, case);
        let file = root().join(format!("fixtures/{case}/solution.vtu"));
        let (code, r, err) = estimate(&file, &["--stress", "patch"]);
        assert!(code == 0 || code == 1, "{err}");
        let b = r.expect("a report").bound;
        assert!(b.guaranteed, "{case}: {:?}", b.failed_hypotheses);
        let e = b.energy_error.expect("a bound");
        assert_above_and_within(case, e, truth, reference_error, 1.5);
    }
}

/// A block pressed onto a rigid cylinder (R = 5, `reference/block`, scikit-fem active set with
/// the constraints at the nodes): the P1 file's chords cross the convex obstacle between its
/// active nodes by up to 1.67e-5, which the lift on the P2 elevation removes (before it, the
/// penetration was a failed hypothesis); the P2 file crosses it between its nodes too (6.1e-6,
/// the lift on its own mid nodes). Against the fine scikit-fem reference of
/// `reference/block/fine_error.py` (its committed `fine_errors.json`, computed without fosls)
/// both bounds are guaranteed, above the true error plus the reference's own error bound, and
/// within 1.5 times the true error (measured P1 1.13, P2 1.29).
#[test]
fn block_on_a_cylinder_bounds_are_guaranteed_against_the_fine_reference() {
    let (fine, reference_error) = fine_reference("block");
    for p in [1, 2] {
        let case = format!("block_cylinder_skfem_p{p}");
        let truth = true_error(&fine, &case);
        let file = root().join(format!("fixtures/{case}/solution.vtu"));
        let (code, r, err) = estimate(&file, &[]);
        assert!(code == 0 || code == 1, "{err}");
        let r = r.expect("a report");
        // An active-set solution: its closed patches balance to the solver's residual. The
        // traction-free bottom corners carry loads of 4e-10 and balances of the same size,
        // which `LOAD_DEFECT_FLOOR` keeps from reading as a defect of 1 (P1: 1.0 before).
        assert!(
            !r.notes
                .iter()
                .any(|n| n.contains("far from a Galerkin solution")),
            "{case}: {:?}",
            r.notes
        );
        let b = r.bound;
        assert!(b.guaranteed, "{case}: {:?}", b.failed_hypotheses);
        assert_eq!(
            b.statement.contains("P2 elevation of the P1 mesh"),
            p == 1,
            "{case}: {}",
            b.statement
        );
        // The lift's distance is in the projection term (the file's nodes are admissible).
        let lift = b.terms.as_ref().expect("terms").projection;
        assert!(lift > 0.0, "{case}");
        let e = b.energy_error.expect("a bound");
        assert_above_and_within(&case, e, truth, reference_error, 1.5);
    }
}

/// Coulomb files whose displacement crosses the obstacle between admissible nodes (scikit-fem
/// P2 Hertz: 2.4e-6, CalculiX CPE6 Hertz: 6.1e-8, the manufactured P1 and P2 meshes at n = 4:
/// 4.7e-5 and 1.1e-6) are lifted as frictionless ones are: the contact direction is the
/// obstacle's normal or the edges are straight, so the move leaves v_t and the friction pairing
/// as they are. The penetration leaves the failed hypotheses; the Tresca label stays, first.
#[test]
fn coulomb_files_crossing_the_obstacle_between_nodes_are_lifted() {
    for (case, entry) in [
        ("hertz_skfem_p2_coulomb", "solution.vtu"),
        ("calculix_hertz_cpe6_friction", "hertz.vtu"),
        ("manufactured_coulomb_p1_n04", "solution.vtu"),
        ("manufactured_coulomb_p2_n04", "solution.vtu"),
    ] {
        let file = root().join(format!("fixtures/{case}/{entry}"));
        let (code, r, err) = estimate(&file, &[]);
        assert!(code == 0 || code == 1, "{case}: {err}");
        let b = r.expect("a report").bound;
        assert!(b.energy_error.is_some_and(f64::is_finite), "{case}");
        assert!(!b.guaranteed, "{case}");
        assert!(
            b.failed_hypotheses[0].starts_with("Coulomb friction"),
            "{case}: {:?}",
            b.failed_hypotheses
        );
        assert!(
            !b.failed_hypotheses.iter().any(|h| h.contains("penetrates")),
            "{case}: {:?}",
            b.failed_hypotheses
        );
        assert!(b.terms.expect("terms").projection > 0.0, "{case}");
    }
}

/// A file stress that is admissible but not equilibrated (reference/exact's perturbed σ: the
/// displacement is the exact solution, τ_yy = σ_yy + 0.1x(1 + y)) is what F uses under `auto`,
/// and F is the hand integration's. It gives no bound itself (`--stress file`), so the bound
/// takes the patch equilibration of u_h as its stress: u_h is exact, so the bound is 0 to
/// round-off and guaranteed.
#[test]
fn a_file_stress_that_is_not_equilibrated_leaves_the_bound_to_the_patch_stress() {
    let dir = root().join("fixtures/perturbed_sigma_energy");
    let hand = expected(&dir)["hand"]["total"].as_f64().unwrap();
    let (code, r, err) = estimate(&dir.join("solution.vtu"), &[]);
    assert!(code == 0 || code == 1, "{err}");
    let r = r.expect("a report");
    assert_eq!(r.stress.source, "file");
    assert!(
        ((r.functional.total - hand) / hand).abs() < 1e-10,
        "F {} against the hand integration's {hand}",
        r.functional.total
    );
    let b = r.bound;
    assert!(b.guaranteed, "{:?}", b.failed_hypotheses);
    let rel = b.relative.expect("a relative bound");
    assert!(rel < 1e-10, "bound / energy^½ = {rel:e}");
    assert!(
        b.statement.contains("patch equilibration of u_h"),
        "{}",
        b.statement
    );
    assert_refused_as_not_equilibrated(&dir.join("solution.vtu"), &["--stress", "file"]);
}

/// The scikit-fem Hertz files on quadrilaterals (Q1, Q2, serendipity; distorted cells near the
/// contact): the bound on a triangle split is guaranteed on all three, above the true error of
/// `reference/hertz/fine_error.py` (its committed `fine_errors.json`: the fine triangle
/// reference, u_h located in the quadrilaterals and evaluated through their isoparametric maps,
/// computed without fosls) plus the reference's own error bound, and within the index measured
/// with the stress of the halves paired with u_h itself (design §6.3, "u_h itself"): Q1 1.35,
/// Q2 1.60, S2 1.70. For the P2 interpolant ũ_h plus |||ũ_h − u_h||| they were 1.64, 2.38 (on
/// the four triangles about each centre) and 2.85 (session 34), so the limits check that the
/// direct pairing is the one reported. The cells are no parallelograms: u_h is
/// rational on the split, and its terms are integrated at degree 20 (the symmetric correction's
/// own rule read cells up to 1 % off). The Q2 halves need their most distorted cells cut along
/// the other diagonal: with the diagonal 0–2 everywhere, K_T reached 40 and the bound was not
/// guaranteed.
#[test]
fn hertz_quadrilateral_bounds_are_guaranteed_against_the_fine_reference() {
    let (fine, reference_error) = fine_reference("hertz");
    for (family, index) in [("q1", 1.45), ("q2", 1.7), ("s2", 1.85)] {
        let case = format!("quad_hertz_skfem_{family}");
        let truth = true_error(&fine, &case);
        let file = root().join(format!("fixtures/{case}/solution.vtu"));
        let (code, r, err) = estimate(&file, &[]);
        assert!(code == 0 || code == 1, "{family}: {err}");
        let b = r.expect("a report").bound;
        assert!(b.guaranteed, "{family}: {:?}", b.failed_hypotheses);
        let e = b.energy_error.expect("a bound");
        assert_above_and_within(&case, e, truth, reference_error, index);
        let t = b.terms.expect("terms");
        assert!(t.korn_max < 40.0, "{family}: K_T up to {}", t.korn_max);
        assert_eq!(t.halves, 0.0, "{family}");
        assert!(
            b.statement.ends_with("paired with u_h itself)"),
            "{family}: {}",
            b.statement
        );
    }
}

/// `--output` writes each cell's share of R² (`bound_squared`, design §6.2) for ParaView: on a
/// triangle file and on a quadrilateral one (summed over each cell's halves, §6.3) the shares
/// add up to R² = `terms.combined`² of the JSON report.
#[test]
fn the_output_file_carries_the_bound_per_cell() {
    for case in ["hertz_skfem_p2", "quad_hertz_skfem_q1"] {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("out.vtu");
        let file = root().join(format!("fixtures/{case}/solution.vtu"));
        let (code, r, err) = estimate(&file, &["--output", out.to_str().unwrap()]);
        assert!(code == 0 || code == 1, "{case}: {err}");
        let b = r.expect("a report").bound;
        let r2 = b.terms.expect("terms").combined.powi(2);
        let vtu = fosls::read::vtu::read_vtu(&out).unwrap();
        let shares = vtu
            .cell_data
            .iter()
            .find(|a| a.name == "bound_squared")
            .expect("bound_squared");
        let sum: f64 = shares.values.iter().sum();
        assert!(
            ((sum - r2) / r2).abs() < 1e-12,
            "{case}: Σ {sum} against R² {r2}"
        );
    }
}

/// A quadrilateral that misses a parallelogram by less than `CURVED_RELATIVE` of its size is
/// taken for one (design §4.3), and the triangle split must take it so too: the diagonal's
/// midpoint of its halves is then off the image of the reference centre by that much. Before,
/// the split asked 1e-9 of the size there, and refused such a cell ("the inverse map missed it
/// by 1.5e-9" on a smoothly distorted 100k Q2 mesh in `benches/halves.rs`). Here the centre
/// vertex of the manufactured Q2 mesh (n = 4, h = 0.25) moves by δ, |δ| = 3.6e-8 (1.4e-7 h),
/// its four edge nodes by δ/2 and the four cell centres by δ/4: exact bilinear cells with
/// straight edges, so only the map changes, by 1e-7 of the cells. (Moving the vertex alone
/// leaves the edge nodes 1e-7 h off their midpoints: those cells then take the curved
/// treatment, and the bound moved by 0.4 %.)
#[test]
fn a_quadrilateral_within_round_off_of_a_parallelogram_is_split() {
    let src = root().join("fixtures/quad_manufactured_q2_n04");
    let (code, here, err) = estimate(&src.join("solution.vtu"), &[]);
    assert!(code == 0 || code == 1, "{err}");
    let mut file = fosls::read::vtu::read_vtu(&src.join("solution.vtu")).unwrap();
    let delta = [3e-8, -2e-8];
    for p in &mut file.points {
        // The node at (0.5, 0.5) moves by δ, those 0.125 away on a line by δ/2, those 0.125
        // away on both axes (the centres) by δ/4.
        let (dx, dy) = ((p[0] - 0.5).abs(), (p[1] - 0.5).abs());
        let share = |d: f64| match d {
            0.0 => 1.0,
            0.125 => 0.5,
            _ => 0.0,
        };
        let w = share(dx) * share(dy);
        p[0] += w * delta[0];
        p[1] += w * delta[1];
    }
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("solution.vtu");
    fosls::write::write_vtu(&path, &file, fosls::write::Placement::AppendedRaw).unwrap();
    std::fs::copy(src.join("scene.toml"), dir.path().join("scene.toml")).unwrap();
    let (code, there, err) = estimate(&path, &[]);
    assert!(code == 0 || code == 1, "{err}");
    let (b0, b1) = (here.unwrap().bound, there.unwrap().bound);
    let e1 = b1
        .energy_error
        .unwrap_or_else(|| panic!("no bound: {:?}", b1.failed_hypotheses));
    let e0 = b0.energy_error.unwrap();
    assert!((e1 - e0).abs() <= 1e-6 * e0, "bound {e0} → {e1}");
    assert_eq!(b0.failed_hypotheses, b1.failed_hypotheses);
}

/// A side obstacle that touches the Hertz body exactly at its Dirichlet corner (−1, 1): the P2
/// trace of the projected u_h crosses it next to that node, where the penetration and the
/// lifted mid node's shape function vanish together. The lift must leave no penetration above
/// round-off (its defining property, docs/design.md §6.2 "between nodes"): before, its
/// refinement only halved the missing lift per round and left 4.8e-12 after 8 rounds, which
/// made the bound "not guaranteed: u_h penetrates the obstacle".
#[test]
fn a_lift_next_to_an_active_end_node_closes_the_penetration() {
    let side = "normal = \"obstacle\"\n\n[[boundary]]\nname = \"side\"\n\
                where = \"x < 0 && y > 0.5001 && y < 0.9999\"\nkind = \"contact\"\n\
                obstacle = { plane = { point = [-1.0, 0.0], normal = [1.0, 0.0] } }\n\
                normal = \"obstacle\"\n";
    let (_dir, file) = fixture_with_scene("hertz_skfem_p2", "normal = \"obstacle\"", side);
    let (code, report, stderr) = estimate(&file, &["--quiet"]);
    assert_eq!(code, 0, "{stderr}");
    let r = report.unwrap();
    // The file's trace crosses the side obstacle between nodes (by 5.4e-6 of |u_h| ≈ 0.01).
    assert!(r.admissibility.penetration_max > 1e-6);
    assert!(r.bound.guaranteed, "{:?}", r.bound.failed_hypotheses);
    assert!(r.bound.failed_hypotheses.is_empty());
}

/// The side plane moved to x = −0.9 cuts off the Dirichlet corner (−1, 1), which u_D = (0,
/// −0.01) holds in place: n·u_D − g = 0 − (−0.1) = 0.1 there (by hand), so no displacement meets
/// both conditions. The report says so; touching (x = −1, the case above) is no conflict.
#[test]
fn dirichlet_data_inside_the_obstacle_are_named() {
    for (plane, conflict) in [("-0.9", true), ("-1.0", false)] {
        let side = format!(
            "normal = \"obstacle\"\n\n[[boundary]]\nname = \"side\"\n\
             where = \"x < 0 && y > 0.5001 && y < 0.9999\"\nkind = \"contact\"\n\
             obstacle = {{ plane = {{ point = [{plane}, 0.0], normal = [1.0, 0.0] }} }}\n\
             normal = \"obstacle\"\n"
        );
        let (_dir, file) = fixture_with_scene("hertz_skfem_p2", "normal = \"obstacle\"", &side);
        let (code, report, stderr) = estimate(&file, &["--quiet"]);
        assert_eq!(code, 0, "{stderr}");
        let r = report.unwrap();
        let warning = r.notes.iter().find(|n| n.contains("K_u is empty"));
        if conflict {
            let w = warning.expect("a warning");
            assert!(
                w.contains(
                    "put 1 node that lies on a contact boundary inside the obstacle (the \
                            deepest at (-1, 1), by 1.000e-1)"
                ),
                "{w}"
            );
            assert!(!r.bound.guaranteed);
        } else {
            assert!(warning.is_none(), "{warning:?}");
        }
    }
}
