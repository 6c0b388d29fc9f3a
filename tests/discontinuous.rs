//! A displacement written per cell whose node copies disagree (an exploded file of a
//! discontinuous field, docs/design.md §4.2 "Discontinuous displacements"): F and the bound use
//! the copies' average ū_h, and the bound adds |||ū_h − u_h|||_h so that it bounds the error of
//! the file's u_h in the broken energy norm. Independent sources: an exact linear solution with
//! one copy moved, whose broken-norm errors follow by hand from the hat functions' gradients,
//! and NGSolve's output of a DG field with the numbers computed from the file by numpy.

use std::path::{Path, PathBuf};

use fosls::read::decode::Scalar;
use fosls::read::vtu::{DataArray, VtuFile};
use fosls::write::{Placement, write_vtu};

mod common;

/// u = (10⁻³x + 2·10⁻⁴y, 10⁻⁴x − 3·10⁻⁴y): linear, so the Dirichlet data on the whole
/// boundary make it the exact solution.
fn exact(x: f64, y: f64) -> [f64; 2] {
    [1e-3 * x + 2e-4 * y, 1e-4 * x - 3e-4 * y]
}

const E: f64 = 20600.0;
const NU: f64 = 0.28;

const SCENE: &str = "[material]\nyoungs_modulus = 20600.0\npoisson_ratio = 0.28\n\
                     model = \"plane_strain\"\n\
                     [[boundary]]\nname = \"all\"\nwhere = \"1 > 0\"\nkind = \"dirichlet\"\n\
                     displacement = [\"1e-3*x + 2e-4*y\", \"1e-4*x - 3e-4*y\"]\n";

const POINTS: [[f64; 2]; 8] = [
    [0., 0.],
    [1., 0.],
    [1., 1.],
    [0., 1.],
    [2., 0.],
    [2., 1.],
    [1., 0.5],
    [2., 0.5],
];
const CELLS: [[usize; 3]; 7] = [
    [0, 1, 6],
    [0, 6, 2],
    [0, 2, 3],
    [1, 4, 7],
    [1, 7, 6],
    [6, 7, 5],
    [6, 5, 2],
];
/// The moved copy: node 6 of cell 0, x-component.
const MOVE: f64 = 1e-5;

/// The exact stress Cε(u) (constant), as the 9 components xx, xy, xz, yx, yy, yz, zx, zy, zz
/// of plane strain.
fn exact_stress() -> [f64; 9] {
    let mu = E / (2.0 * (1.0 + NU));
    let lambda = E * NU / ((1.0 + NU) * (1.0 - 2.0 * NU));
    let (exx, eyy, exy) = (1e-3, -3e-4, 1.5e-4);
    let tr = exx + eyy;
    let (sxx, syy, sxy) = (
        2.0 * mu * exx + lambda * tr,
        2.0 * mu * eyy + lambda * tr,
        2.0 * mu * exy,
    );
    [sxx, sxy, 0.0, sxy, syy, 0.0, 0.0, 0.0, lambda * tr]
}

/// [0, 2] × [0, 1] in 7 P1 triangles, every cell with its own node copies (as NGSolve's
/// `VTKOutput` writes), u exact except the first cell's copy of node 6 moved by `moved`, and
/// the exact stress except the first cell's copies scaled by 1 + `stress_off`.
fn exploded(dir: &Path, moved: f64, stress_off: f64) -> PathBuf {
    exploded_with(dir, moved, stress_off, false)
}

/// [`exploded`], with the first cell's nodes written clockwise when `clockwise` (the mesh
/// build reorders them after merging the copies).
fn exploded_with(dir: &Path, moved: f64, stress_off: f64, clockwise: bool) -> PathBuf {
    exploded_file(dir, moved, stress_off, clockwise, false)
}

/// [`exploded_with`], with the displacement written as two scalar arrays "u_x", "u_y" when
/// `split` (joined before the copies are merged: read::components).
fn exploded_file(dir: &Path, moved: f64, stress_off: f64, clockwise: bool, split: bool) -> PathBuf {
    let mut points = Vec::new();
    let mut u = Vec::new();
    let mut stress = Vec::new();
    let mut cells = Vec::new();
    for (t, c) in CELLS.iter().enumerate() {
        let mut ids = Vec::new();
        for &n in c {
            let [x, y] = POINTS[n];
            let mut v = exact(x, y);
            if t == 0 && n == 6 {
                v[0] += moved;
            }
            ids.push(points.len() as u32);
            points.push([x, y, 0.0]);
            u.extend(v);
            let scale = if t == 0 { 1.0 + stress_off } else { 1.0 };
            stress.extend(exact_stress().map(|c| c * scale));
        }
        if clockwise && t == 0 {
            ids.reverse();
        }
        cells.push((5u8, ids));
    }
    let path = dir.join(format!(
        "exploded_{moved:e}_{stress_off:e}_{clockwise}_{split}.vtu"
    ));
    let mut f = VtuFile::from_cells(&path, points, &cells);
    if split {
        for (k, name) in ["u_x", "u_y"].into_iter().enumerate() {
            f.point_data.push(DataArray {
                name: name.into(),
                scalar: Scalar::Float64,
                components: 1,
                component_names: Vec::new(),
                values: u.iter().skip(k).step_by(2).copied().collect(),
            });
        }
    } else {
        f.point_data.push(DataArray {
            name: "u".into(),
            scalar: Scalar::Float64,
            components: 2,
            component_names: Vec::new(),
            values: u,
        });
    }
    f.point_data.push(DataArray {
        name: "stress".into(),
        scalar: Scalar::Float64,
        components: 9,
        component_names: Vec::new(),
        values: stress,
    });
    write_vtu(&path, &f, Placement::Inline).unwrap();
    path
}

/// |||(a φ, 0)|||²_T for the hat φ of local vertex `k` of triangle `c`:
/// a²((2μ + λ)φ_x² + μφ_y²)|T| (plane strain; ∇φ constant).
fn hat_energy(c: [usize; 3], k: usize, a: f64) -> f64 {
    let mu = E / (2.0 * (1.0 + NU));
    let lambda = E * NU / ((1.0 + NU) * (1.0 - 2.0 * NU));
    let p = c.map(|n| POINTS[n]);
    let det = (p[1][0] - p[0][0]) * (p[2][1] - p[0][1]) - (p[2][0] - p[0][0]) * (p[1][1] - p[0][1]);
    // ∇φ_k = (y_{k+1} − y_{k+2}, x_{k+2} − x_{k+1}) / det.
    let (i, j) = ((k + 1) % 3, (k + 2) % 3);
    let g = [(p[i][1] - p[j][1]) / det, (p[j][0] - p[i][0]) / det];
    a * a * ((2.0 * mu + lambda) * g[0] * g[0] + mu * g[1] * g[1]) * 0.5 * det.abs()
}

/// |||ū_h − u_h|||_h by hand: node 6 has 5 copies, one moved by MOVE, so the average is
/// u + MOVE/5 and ū_h − u_h|_T is (MOVE/5 − MOVE)φ₆ on the first cell and (MOVE/5)φ₆ on the
/// four others.
fn copies_by_hand() -> f64 {
    let share = MOVE / 5.0;
    CELLS
        .iter()
        .enumerate()
        .filter_map(|(t, c)| {
            let k = c.iter().position(|&n| n == 6)?;
            let a = if t == 0 { share - MOVE } else { share };
            Some(hat_energy(*c, k, a))
        })
        .sum::<f64>()
        .sqrt()
}

/// Written one scalar array per component, the displacement's copies are kept as for a
/// vector array: the same distance, by hand.
#[test]
fn a_displacement_written_per_component_keeps_its_copies() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("scene.toml");
    std::fs::write(&scene, SCENE).unwrap();
    let file = exploded_file(dir.path(), MOVE, 0.0, false, true);
    let (code, report, stderr) =
        common::cli::estimate(&file, &["--scene", scene.to_str().unwrap(), "--quiet"]);
    assert_eq!(code, 0, "{stderr}");
    let r = report.unwrap();
    assert_eq!(r.displacement.name, "(u_x, u_y)");
    let copies = r.bound.terms.unwrap().copies;
    let by_hand = copies_by_hand();
    assert!(
        (copies - by_hand).abs() <= 1e-12 * by_hand,
        "{copies} vs {by_hand}"
    );
}

#[test]
fn a_reordered_cell_keeps_its_copies() {
    // The first cell written clockwise: reordered after the merge, its copies found by node.
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("scene.toml");
    std::fs::write(&scene, SCENE).unwrap();
    let file = exploded_with(dir.path(), MOVE, 0.0, true);
    let (code, report, stderr) =
        common::cli::estimate(&file, &["--scene", scene.to_str().unwrap(), "--quiet"]);
    assert_eq!(code, 0, "{stderr}");
    let copies = report.unwrap().bound.terms.unwrap().copies;
    let by_hand = copies_by_hand();
    assert!(
        (copies - by_hand).abs() <= 1e-12 * by_hand,
        "{copies} vs {by_hand}"
    );
}

#[test]
fn a_moved_copy_is_bounded_in_the_broken_norm() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("scene.toml");
    std::fs::write(&scene, SCENE).unwrap();
    let file = exploded(dir.path(), MOVE, 0.1);
    let (code, report, stderr) =
        common::cli::estimate(&file, &["--scene", scene.to_str().unwrap(), "--quiet"]);
    assert_eq!(code, 0, "{stderr}");
    let r = report.unwrap();
    let b = &r.bound;
    let terms = b.terms.as_ref().unwrap();
    let by_hand = copies_by_hand();
    assert!(
        (terms.copies - by_hand).abs() <= 1e-12 * by_hand,
        "{} vs {by_hand}",
        terms.copies
    );
    // The true error of the file's u_h in the broken norm: MOVE φ₆ on the first cell only.
    let truth = (0.5 * hat_energy(CELLS[0], 2, MOVE)).sqrt();
    let bound = b.energy_error.unwrap();
    assert!(bound >= truth, "{bound} < {truth}");
    assert!(b.guaranteed, "{:?}", b.failed_hypotheses);
    assert!(
        b.statement.contains("broken energy norm"),
        "{}",
        b.statement
    );
    println!(
        "copies {} (by hand {by_hand}); bound {bound}, true broken error {truth}, index {}",
        terms.copies,
        bound / truth
    );
}

#[test]
fn equal_copies_add_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("scene.toml");
    std::fs::write(&scene, SCENE).unwrap();
    let file = exploded(dir.path(), 0.0, 0.0);
    let (code, report, stderr) =
        common::cli::estimate(&file, &["--scene", scene.to_str().unwrap(), "--quiet"]);
    assert_eq!(code, 0, "{stderr}");
    let r = report.unwrap();
    assert_eq!(r.stress.reason, "conforming nodal stress, used as is");
    assert_eq!(
        r.displacement.reason,
        "conforming and admissible at the nodes, used as is"
    );
    let b = r.bound;
    assert_eq!(b.terms.as_ref().unwrap().copies, 0.0);
    assert!(!b.statement.contains("broken"), "{}", b.statement);
    // The exact solution: the bound is round-off.
    assert!(b.relative.unwrap() < 1e-10, "{:?}", b.relative);
    assert!(b.guaranteed);
}

#[test]
fn ngsolve_dg_field_is_bounded_in_the_broken_norm() {
    // NGSolve's VTKOutput of a VectorL2(order = 1) field: every cell with its own copies, which
    // disagree (reference/discontinuous/). Independent source: the distance and the true broken
    // error computed from the file with meshio + numpy (expected.json).
    let dir = common::cli::root().join("fixtures").join("ngsolve_dg_p1");
    let exp: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("expected.json")).unwrap()).unwrap();
    let scene = dir.join("scene.toml");
    let (code, report, stderr) = common::cli::estimate(
        &dir.join("solution.vtu"),
        &["--scene", scene.to_str().unwrap(), "--quiet"],
    );
    assert_eq!(code, 0, "{stderr}");
    let r = report.unwrap();
    let b = &r.bound;
    let copies = b.terms.as_ref().unwrap().copies;
    let want = exp["copies_distance"].as_f64().unwrap();
    assert!((copies - want).abs() <= 1e-10 * want, "{copies} vs {want}");
    let truth = exp["true_broken_error"].as_f64().unwrap();
    let bound = b.energy_error.unwrap();
    assert!(bound >= truth, "{bound} < {truth}");
    assert!(b.guaranteed, "{:?}", b.failed_hypotheses);
    assert!(
        r.notes
            .iter()
            .any(|n| n.contains("discontinuous across cells")),
        "{:?}",
        r.notes
    );
    println!(
        "NGSolve DG: copies {copies} (numpy {want}); bound {bound}, true {truth}, index {}",
        bound / truth
    );
}
