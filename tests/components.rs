//! Fields written one scalar array per component (docs/design.md §4.1, "Component arrays"):
//! NGSolve's `VTKOutput` of one solution as vector arrays and, in the same run, as component
//! arrays under MOOSE's, deal.II's and FreeFEM's names and under names only a scene list can
//! give (`fixtures/ngsolve_components_p2`, reference/components/make.py). Independent source:
//! the vector file, whose arrays VTK's reader finds equal to the components bit for bit
//! (`expected.json`); every number must then be the vector file's, bit for bit.

use std::path::PathBuf;

use fosls::report::json::Report;

mod common;

fn dir() -> PathBuf {
    common::cli::root().join("fixtures/ngsolve_components_p2")
}

fn expected() -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(dir().join("expected.json")).unwrap()).unwrap()
}

fn run(file: &str, scene: &str) -> Report {
    let (code, report, stderr) = common::cli::estimate(
        &dir().join(file),
        &["--scene", dir().join(scene).to_str().unwrap(), "--quiet"],
    );
    assert_eq!(code, 0, "{file}: {stderr}");
    report.unwrap()
}

#[test]
fn component_arrays_give_the_numbers_of_the_vector_file() {
    let exp = expected();
    let vector = run("vector.vtu", "scene.toml");
    assert_eq!(vector.displacement.name, "displacement");
    for (file, scene, u, s) in [
        (
            "moose",
            "scene.toml",
            "(disp_x, disp_y)",
            "(stress_xx, stress_yy, stress_xy)",
        ),
        ("freefem", "scene.toml", "(u, v)", "(sxx, syy, sxy)"),
        (
            "listed",
            "scene_listed.toml",
            "(U1h, U2h)",
            "(T11, T22, T12)",
        ),
    ] {
        // The files hold the vector file's field (VTK's reader, in the harness).
        let e = &exp["files"][file];
        assert_eq!(e["displacement_equal"], true, "{file}");
        assert_eq!(e["stress_equal"], true, "{file}");
        let r = run(&format!("{file}.vtu"), scene);
        assert_eq!(r.displacement.name, u, "{file}");
        assert_eq!(r.stress.name, s, "{file}");
        assert_eq!(r.functional, vector.functional, "{file}");
        assert_eq!(r.eta, vector.eta, "{file}");
        assert_eq!(r.bound.energy_error, vector.bound.energy_error, "{file}");
        assert_eq!(r.bound.guaranteed, vector.bound.guaranteed, "{file}");
        assert_eq!(r.bound.cells, vector.bound.cells, "{file}");
        assert_eq!(r.admissibility, vector.admissibility, "{file}");
        let how = if scene == "scene.toml" {
            "read as the components of one vector"
        } else {
            "read as the components of one field (named in the scene)"
        };
        assert!(
            r.notes
                .iter()
                .any(|n| n.starts_with("displacement:") && n.contains(how)),
            "{file}: {:?}",
            r.notes
        );
    }
    // deal.II's names, displacement only: the stress is rebuilt, the bound (from u_h alone)
    // is the vector file's.
    assert_eq!(exp["files"]["dealii"]["displacement_equal"], true);
    let d = run("dealii.vtu", "scene.toml");
    assert_eq!(d.displacement.name, "(x_displacement, y_displacement)");
    assert_eq!(d.stress.source, "reconstructed");
    assert_eq!(d.bound.energy_error, vector.bound.energy_error);
    assert!(vector.bound.guaranteed);
}

#[test]
fn component_lists_that_do_not_fit_are_refused_in_one_line() {
    let d = tempfile::tempdir().unwrap();
    let base = std::fs::read_to_string(dir().join("scene.toml")).unwrap();
    for (fields, message) in [
        (
            "displacement = [\"U1h\", \"U3h\"]",
            "fields.displacement: no point array \"U3h\" in ",
        ),
        (
            "stress = [\"T11\", \"T22\", \"T21\"]",
            "fields.stress: no point or cell array \"T21\" in ",
        ),
    ] {
        let scene = d.path().join("scene.toml");
        std::fs::write(&scene, format!("{base}\n[fields]\n{fields}\n")).unwrap();
        let file = dir().join("listed.vtu");
        let (code, report, stderr) =
            common::cli::estimate(&file, &["--scene", scene.to_str().unwrap()]);
        assert_eq!(code, 2, "{stderr}");
        assert!(report.is_none());
        assert_eq!(stderr.lines().count(), 1, "{stderr}");
        assert_eq!(
            stderr.trim_end(),
            format!("error: {}: {message}{}", scene.display(), file.display())
        );
    }
    let scene = d.path().join("scene.toml");
    std::fs::write(
        &scene,
        format!("{base}\n[fields]\ndisplacement = [\"displacement\", \"stress\"]\n"),
    )
    .unwrap();
    let file = dir().join("vector.vtu");
    let (code, _, stderr) = common::cli::estimate(&file, &["--scene", scene.to_str().unwrap()]);
    assert_eq!(code, 2, "{stderr}");
    // VTK's reader finds the components the message names.
    let n = expected()["files"]["vector"]["components"]["displacement"]
        .as_u64()
        .unwrap();
    assert_eq!(
        stderr.trim_end(),
        format!(
            "error: {}: fields.displacement: point array \"displacement\" in {} has {n} \
             components; each array of a list is one component",
            scene.display(),
            file.display()
        )
    );
}

/// `fosls scene` writes the list it joined, and `estimate` reads it back to the same numbers.
#[test]
fn the_starter_scene_lists_the_components() {
    let d = tempfile::tempdir().unwrap();
    let file = d.path().join("moose.vtu");
    std::fs::copy(dir().join("moose.vtu"), &file).unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_fosls"))
        .args(["scene", file.to_str().unwrap(), "--output", "-"])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(
        text.contains("displacement = [\"disp_x\", \"disp_y\"]"),
        "{text}"
    );
    assert!(
        text.contains("stress = [\"stress_xx\", \"stress_yy\", \"stress_xy\"]"),
        "{text}"
    );
}
