//! Files holding several bodies (issue 12, docs/design.md §4.2 "Bodies"): the CalculiX disc on
//! its foundation block, and small two-body files built here. Independent sources: the
//! solver's reaction and the Hertz width in `expected.json`, the bodies listed there by the
//! reference script, and the construction of the small files.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use fosls::read::decode::Scalar;
use fosls::read::vtu::{DataArray, VtuFile};
use fosls::report::json::Report;
use fosls::write::{Placement, write_vtu};
use serde_json::Value;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn run(args: &[&std::ffi::OsStr]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_fosls"))
        .args(args)
        .output()
        .unwrap()
}

fn estimate(file: &Path, scene: &Path) -> Output {
    run(&[
        "estimate".as_ref(),
        file.as_os_str(),
        "--scene".as_ref(),
        scene.as_os_str(),
        "--json".as_ref(),
        "-".as_ref(),
        "--quiet".as_ref(),
    ])
}

fn report(out: &Output) -> Report {
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

/// The one-line error of a failed run (exit status 2).
fn error(out: &Output) -> String {
    assert_eq!(
        out.status.code(),
        Some(2),
        "{}",
        String::from_utf8_lossy(&out.stdout)
    );
    let e = String::from_utf8_lossy(&out.stderr).trim().to_string();
    assert_eq!(e.lines().count(), 1, "{e}");
    e.strip_prefix("error: ").unwrap_or(&e).to_string()
}

fn expected(case: &str) -> Value {
    let p = root().join("fixtures").join(case).join("expected.json");
    serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap()
}

#[test]
fn calculix_disc_on_its_block_is_audited_alone() {
    let dir = root().join("fixtures/calculix_hertz_cpe6_twobody");
    let e = expected("calculix_hertz_cpe6_twobody");
    let r = report(&estimate(&dir.join("hertz.vtu"), &dir.join("scene.toml")));
    let bodies = r.bodies.expect("a bodies key");
    assert_eq!(bodies.selected_by, "[body] where");
    let listed = e["layout"]["bodies"].as_array().unwrap();
    assert_eq!(bodies.list.len(), listed.len());
    for (b, l) in bodies.list.iter().zip(listed) {
        assert_eq!(b.cells as u64, l["cells"].as_u64().unwrap());
        assert_eq!(b.points as u64, l["points"].as_u64().unwrap());
        assert_eq!(b.first_cell as u64, l["first_cell"].as_u64().unwrap());
        let bb = &l["bbox"];
        assert_eq!(
            b.bounding_box,
            [
                bb[0][0].as_f64().unwrap(),
                bb[0][1].as_f64().unwrap(),
                bb[1][0].as_f64().unwrap(),
                bb[1][1].as_f64().unwrap()
            ]
        );
    }
    assert_eq!(
        bodies.audited as u64,
        e["layout"]["selected_body"].as_u64().unwrap()
    );
    let p = e["hertz"]["P_solver"].as_f64().unwrap();
    let two_a = e["hertz"]["two_a"].as_f64().unwrap();
    let force = r.contact.normal_force;
    assert!((force - p).abs() <= 0.01 * p, "force {force} vs {p}");
    let length = r.contact.active_length;
    assert!(
        (length - two_a).abs() <= 0.03 * two_a,
        "active length {length} vs 2a = {two_a}"
    );
    let contact: Vec<_> = r
        .contact
        .intervals
        .iter()
        .filter(|i| i.state != "separated")
        .collect();
    assert_eq!(contact.len(), 1, "{:?}", r.contact.intervals);
    assert_eq!(contact[0].length, length);
}

#[test]
fn inspect_lists_the_bodies_of_the_reference_script() {
    let file = root().join("fixtures/calculix_hertz_cpe6_twobody/hertz.vtu");
    let out = run(&[
        "inspect".as_ref(),
        file.as_os_str(),
        "--json".as_ref(),
        "-".as_ref(),
    ]);
    assert_eq!(out.status.code(), Some(0));
    let s: Value = serde_json::from_slice(&out.stdout).unwrap();
    let e = expected("calculix_hertz_cpe6_twobody");
    let listed = e["layout"]["bodies"].as_array().unwrap();
    let bodies = s["bodies"].as_array().unwrap();
    assert_eq!(bodies.len(), listed.len());
    for (b, l) in bodies.iter().zip(listed) {
        assert_eq!(b["index"], l["index"]);
        assert_eq!(b["cells"], l["cells"]);
        assert_eq!(b["points"], l["points"]);
    }
}

/// Two unit squares, [0, 1]² (body 0, cell array "mat" = 1) and [2, 3] × [0, 1] (body 1,
/// "mat" = 2), each of 2 × 2 × 2 P1 triangles, with u = (0, −10⁻³ y).
fn two_squares(dir: &Path) -> PathBuf {
    let mut points = Vec::new();
    let mut cells = Vec::new();
    let mut mat = Vec::new();
    for (body, x0) in [(1.0, 0.0), (2.0, 2.0)] {
        let base = points.len() as u32;
        for j in 0..3 {
            for i in 0..3 {
                points.push([x0 + 0.5 * i as f64, 0.5 * j as f64, 0.0]);
            }
        }
        for j in 0..2u32 {
            for i in 0..2u32 {
                let a = base + 3 * j + i;
                cells.push((5u8, vec![a, a + 1, a + 4]));
                cells.push((5u8, vec![a, a + 4, a + 3]));
                mat.extend([body, body]);
            }
        }
    }
    let path = dir.join("two.vtu");
    let mut f = VtuFile::from_cells(&path, points.clone(), &cells);
    f.point_data.push(DataArray {
        name: "displacement".into(),
        scalar: Scalar::Float64,
        components: 2,
        component_names: Vec::new(),
        values: points.iter().flat_map(|p| [0.0, -1e-3 * p[1]]).collect(),
    });
    f.cell_data.push(DataArray {
        name: "mat".into(),
        scalar: Scalar::Float64,
        components: 1,
        component_names: Vec::new(),
        values: mat,
    });
    write_vtu(&path, &f, Placement::Inline).unwrap();
    path
}

const MATERIAL: &str = "[material]\nyoungs_modulus = 1.0\npoisson_ratio = 0.3\n";
const BOTTOM: &str = "[[boundary]]\nname = \"bottom\"\nwhere = \"y < 1e-9\"\nkind = \"dirichlet\"\n\
                      displacement = [0.0, 0.0]\n";
const LEFT: &str = "[[boundary]]\nname = \"left\"\nwhere = \"x < 1e-9\"\nkind = \"dirichlet\"\n\
                    displacement = [0.0, 0.0]\n";
const BODY0: &str = "body 0 (8 cells, x ∈ [0, 1], y ∈ [0, 1])";
const BODY1: &str = "body 1 (8 cells, x ∈ [2, 3], y ∈ [0, 1])";

fn scene(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, format!("{MATERIAL}{text}")).unwrap();
    p
}

#[test]
fn each_selector_picks_its_body() {
    let dir = tempfile::tempdir().unwrap();
    let file = two_squares(dir.path());
    for (name, body, by, want) in [
        ("index.toml", "[body]\nindex = 1\n", "[body] index", 1),
        (
            "where.toml",
            "[body]\nwhere = \"x > 1.5\"\n",
            "[body] where",
            1,
        ),
        (
            "cell.toml",
            "[body]\ncell_data = { name = \"mat\", value = 1 }\n",
            "[body] cell_data",
            0,
        ),
        ("auto.toml", "", "boundary conditions", 0),
    ] {
        let bcs = if body.is_empty() { LEFT } else { BOTTOM };
        let s = scene(dir.path(), name, &format!("{body}{bcs}"));
        let r = report(&estimate(&file, &s));
        let b = r.bodies.unwrap();
        assert_eq!((b.audited, b.selected_by.as_str()), (want, by), "{name}");
        assert_eq!(b.list.len(), 2);
        // The audited body alone: its 8 cells, and one unit side of it under the boundary
        // (2 if the other square's side were counted too).
        assert_eq!(r.cells.count, 8, "{name}");
        let length: f64 = r.boundaries.iter().map(|b| b.length).sum();
        assert!((length - 1.0).abs() < 1e-12, "{name}: {length}");
    }
}

#[test]
fn body_errors_are_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let file = two_squares(dir.path());
    let d = dir.path().display();
    let cases = [
        (
            "none.toml",
            BOTTOM.to_string(),
            format!(
                "{d}/none.toml: body: {d}/two.vtu holds 2 bodies ({BODY0}; {BODY1}) and the \
                 scene's Dirichlet and contact boundaries touch body 0 and body 1; add a [body] \
                 table (index = N, cell_data = {{ name, value }} or where = \"…\") to choose one"
            ),
        ),
        (
            "both.toml",
            format!("[body]\nwhere = \"y > 0\"\n{BOTTOM}"),
            format!(
                "{d}/both.toml: body.where: \"y > 0\" holds at cells of 2 bodies ({BODY0}; \
                 {BODY1}); a body selector must pick one body"
            ),
        ),
        (
            "nowhere.toml",
            format!("[body]\nwhere = \"x > 10\"\n{BOTTOM}"),
            format!(
                "{d}/nowhere.toml: body.where: \"x > 10\" holds at no cell of {d}/two.vtu \
                 (bodies: {BODY0}; {BODY1})"
            ),
        ),
        (
            "index.toml",
            format!("[body]\nindex = 2\n{BOTTOM}"),
            format!(
                "{d}/index.toml: body.index: {d}/two.vtu has 2 bodies (index 0 to 1): {BODY0}; \
                 {BODY1}"
            ),
        ),
        (
            "array.toml",
            format!("[body]\ncell_data = {{ name = \"id\", value = 1 }}\n{BOTTOM}"),
            format!(
                "{d}/array.toml: body.cell_data.name: {d}/two.vtu has no cell array \"id\" (cell \
                 arrays: \"mat\")"
            ),
        ),
        (
            "two.toml",
            format!("[body]\nindex = 0\nwhere = \"x > 1\"\n{BOTTOM}"),
            format!("{d}/two.toml: body: index and where are both given; give one body selector"),
        ),
        (
            "key.toml",
            format!("[body]\nid = 0\n{BOTTOM}"),
            format!(
                "{d}/key.toml: body.id: unknown key (accepted in [body]: index, cell_data, where)"
            ),
        ),
        (
            "floating.toml",
            format!("[body]\nindex = 1\n{LEFT}"),
            format!(
                "{d}/floating.toml: boundary[0] \"left\".where: \"x < 1e-9\" holds at no boundary edge \
                 midpoint (the mesh spans x ∈ [2, 3], y ∈ [0, 1])"
            ),
        ),
        (
            "loose.toml",
            "[body]\nindex = 1\n[[boundary]]\nname = \"pull\"\nwhere = \"x > 2.999\"\n\
             kind = \"neumann\"\ntraction = [1.0, 0.0]\n"
                .to_string(),
            format!(
                "{d}/loose.toml: boundary: {BODY1} of {d}/two.vtu is floating: no Dirichlet or \
                 contact boundary of the scene touches it, so its rigid motions are free (add a \
                 [[boundary]] with kind = \"dirichlet\" or \"contact\" on it)"
            ),
        ),
    ];
    for (name, text, want) in cases {
        let s = scene(dir.path(), name, &text);
        assert_eq!(error(&estimate(&file, &s)), want, "{name}");
    }
}

/// Regression (the whole-path fuzzer, seed 14: a mutated exploded mesh read as 769 bodies gave
/// an 80 KB error line): with many bodies the message lists four and counts the rest.
#[test]
fn many_bodies_give_a_short_line() {
    let dir = tempfile::tempdir().unwrap();
    let (mut points, mut cells) = (Vec::new(), Vec::new());
    for k in 0..300u32 {
        let x0 = 2.0 * k as f64;
        points.extend([[x0, 0.0, 0.0], [x0 + 1.0, 0.0, 0.0], [x0, 1.0, 0.0]]);
        cells.push((5u8, vec![3 * k, 3 * k + 1, 3 * k + 2]));
    }
    let path = dir.path().join("many.vtu");
    let mut f = VtuFile::from_cells(&path, points.clone(), &cells);
    f.point_data.push(DataArray {
        name: "displacement".into(),
        scalar: Scalar::Float64,
        components: 2,
        component_names: Vec::new(),
        values: vec![0.0; 2 * points.len()],
    });
    write_vtu(&path, &f, Placement::Inline).unwrap();
    let sc = scene(dir.path(), "many.toml", BOTTOM);
    let e = error(&estimate(&path, &sc));
    let d = dir.path().display();
    assert_eq!(
        e,
        format!(
            "{d}/many.toml: body: {d}/many.vtu holds 300 bodies (body 0 (1 cell, x ∈ [0, 1], y ∈ \
             [0, 1]); body 1 (1 cell, x ∈ [2, 3], y ∈ [0, 1]); body 2 (1 cell, x ∈ [4, 5], y ∈ \
             [0, 1]); body 3 (1 cell, x ∈ [6, 7], y ∈ [0, 1]); … and 296 more) and the scene's \
             Dirichlet and contact boundaries touch body 0 and body 1 and body 2 and body 3 and \
             … and 296 more; add a [body] table (index = N, cell_data = {{ name, value }} or \
             where = \"…\") to choose one"
        )
    );
}
