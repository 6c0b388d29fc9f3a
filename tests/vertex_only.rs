//! A P2 displacement written at the vertices only (sfepy's default output keeps the vertex
//! values; other writers leave zeros at the mid-edge nodes), docs/design.md §4.1. Independent
//! source: an exact linear solution, for which F vanishes to round-off.

use std::path::{Path, PathBuf};
use std::process::Command;

use fosls::read::decode::Scalar;
use fosls::read::vtu::{DataArray, VtuFile};
use fosls::report::json::Report;
use fosls::write::{Placement, write_vtu};

/// u = 10⁻³ (x + 2y, x/2 − y): linear, so σ is constant and div σ = 0.
fn exact(x: f64, y: f64) -> [f64; 2] {
    [1e-3 * (x + 2.0 * y), 1e-3 * (0.5 * x - y)]
}

const SCENE: &str = "[material]\nyoungs_modulus = 1.0\npoisson_ratio = 0.3\n\
                     [[boundary]]\nname = \"all\"\nwhere = \"1 > 0\"\nkind = \"dirichlet\"\n\
                     displacement = [\"1e-3*(x + 2*y)\", \"1e-3*(0.5*x - y)\"]\n";

/// The unit square in 2 × 2 squares of two P2 triangles each (nodes on the 5 × 5 grid of
/// spacing 1/4), with the exact u at the vertices and `mid(x, y)` at the mid-edge nodes.
fn square(dir: &Path, name: &str, mid: impl Fn(f64, f64) -> [f64; 2]) -> PathBuf {
    let id = |i: u32, j: u32| 5 * j + i;
    let points: Vec<[f64; 3]> = (0..25)
        .map(|k| [0.25 * (k % 5) as f64, 0.25 * (k / 5) as f64, 0.0])
        .collect();
    let mut cells = Vec::new();
    for j in (0..4).step_by(2) {
        for i in (0..4).step_by(2) {
            let (a, b, c, d) = (id(i, j), id(i + 2, j), id(i + 2, j + 2), id(i, j + 2));
            let m = |p: u32, q: u32| (p + q) / 2;
            cells.push((22u8, vec![a, b, c, m(a, b), m(b, c), m(c, a)]));
            cells.push((22u8, vec![a, c, d, m(a, c), m(c, d), m(d, a)]));
        }
    }
    let path = dir.join(name);
    let mut f = VtuFile::from_cells(&path, points.clone(), &cells);
    let vertex = |k: usize| (k % 5).is_multiple_of(2) && (k / 5).is_multiple_of(2);
    f.point_data.push(DataArray {
        name: "displacement".into(),
        scalar: Scalar::Float64,
        components: 2,
        component_names: Vec::new(),
        values: points
            .iter()
            .enumerate()
            .flat_map(|(k, p)| {
                if vertex(k) {
                    exact(p[0], p[1])
                } else {
                    mid(p[0], p[1])
                }
            })
            .collect(),
    });
    write_vtu(&path, &f, Placement::Inline).unwrap();
    path
}

fn estimate(file: &Path, scene: &Path) -> Report {
    let out = Command::new(env!("CARGO_BIN_EXE_fosls"))
        .arg("estimate")
        .arg(file)
        .arg("--scene")
        .arg(scene)
        .args(["--json", "-", "--quiet"])
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

#[test]
fn zero_mid_edge_values_are_audited_as_p1_and_the_exact_solution_stays_exact() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("scene.toml");
    std::fs::write(&scene, SCENE).unwrap();
    let zeroed = estimate(&square(dir.path(), "zeroed.vtu", |_, _| [0.0, 0.0]), &scene);
    assert!(zeroed.displacement.vertices_only);
    assert!(
        zeroed.notes.iter().any(|n| n
            == "warning: displacement given at the vertices only (every mid-edge value is \
                zero): audited as P1 (mid-edge values interpolated linearly)"),
        "{:?}",
        zeroed.notes
    );
    // The exact solution: F vanishes to round-off relative to the energy.
    assert!(
        zeroed.energy > 0.0 && zeroed.functional.total.abs() <= 1e-10 * zeroed.energy,
        "F = {} (energy {})",
        zeroed.functional.total,
        zeroed.energy
    );

    // The genuine field (the exact u at the mid nodes too, i.e. the mean of the ends): not
    // called vertex-only, only noted as linear along the edges; the same F and energy.
    let intact = estimate(&square(dir.path(), "intact.vtu", exact), &scene);
    assert!(!intact.displacement.vertices_only);
    assert!(
        intact
            .notes
            .iter()
            .any(|n| n.starts_with("displacement linear along every edge")),
        "{:?}",
        intact.notes
    );
    assert!((intact.energy - zeroed.energy).abs() <= 1e-12 * intact.energy);
}

#[test]
fn sfepy_vertex_field_on_linear_cells_is_plain_p1() {
    // sfepy's file keeps the 445 vertices of its P2 field on 3-node triangles: a P1 file, so
    // no zero mid-edge values to detect; the flag stays false and the degree is 1. Its cell
    // stress is the cell mean of Cε of the P2 solution (the fixture's README: ev_cauchy_stress
    // el_avg), which the vertex field does not reproduce: the report says so, and that the
    // field is audited as P1.
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("fixtures/sfepy_hertz_p2_vtk");
    let r = estimate(&dir.join("hertz.vtk"), &dir.join("scene.toml"));
    assert_eq!(r.displacement.degree, 1);
    assert!(!r.displacement.vertices_only);
    let w: Vec<&String> = r
        .notes
        .iter()
        .filter(|n| n.contains("cell stress \"cauchy_stress\" differs"))
        .collect();
    assert_eq!(w.len(), 1, "{:?}", r.notes);
    assert!(w[0].contains("audited as P1"), "{}", w[0]);
    let pct: f64 = w[0]
        .split(" by ")
        .nth(1)
        .unwrap()
        .split(' ')
        .next()
        .unwrap()
        .parse()
        .unwrap();
    assert!(pct > 2.0, "{pct}");
}
