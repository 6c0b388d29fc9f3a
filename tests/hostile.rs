//! Resource limits on the command line: `--timeout` and `FOSLS_MAX_ALLOC` (see `src/limits.rs`).
//! Each run must end with exit status 2, exactly one line on stderr, and no output file (not
//! even a temporary one) in the output folder.

use std::path::Path;
use std::process::{Command, Output};

fn fixture(case: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("fixtures")
        .join(case)
        .join("solution.vtu")
}

/// Checks exit status 2, one stderr line, an empty output folder; returns the line.
fn refused(out: &Output, dir: &Path) -> String {
    let stderr = String::from_utf8(out.stderr.clone()).unwrap();
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    assert!(out.stdout.is_empty());
    let left: Vec<_> = std::fs::read_dir(dir).unwrap().collect();
    assert!(left.is_empty(), "files left behind: {left:?}");
    stderr.trim_end().to_string()
}

/// A timeout far shorter than the run (the stress reconstruction alone takes tens of
/// milliseconds) stops it during a named stage.
#[test]
fn estimate_timeout_names_the_stage_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_fosls"))
        .arg("estimate")
        .arg(fixture("hertz_skfem_p2"))
        .args(["--stress", "reconstruct", "--quiet", "--timeout", "0.001"])
        .arg("--json")
        .arg(dir.path().join("r.json"))
        .arg("--output")
        .arg(dir.path().join("r.vtu"))
        .output()
        .unwrap();
    let line = refused(&out, dir.path());
    let prefix = "error: timeout: estimate did not finish within 0.001 s (stage: ";
    assert!(line.starts_with(prefix), "{line}");
    let stage = &line[prefix.len()..line.len() - 1];
    let stages = [
        "starting",
        "reading the solution",
        "reading the scene",
        "projecting the displacement onto K_u",
        "reconstructing the stress",
        "evaluating the functional",
    ];
    assert!(stages.contains(&stage), "{line}");
}

/// A generous timeout changes nothing: the run completes with status 0.
#[test]
fn a_generous_timeout_lets_the_run_finish() {
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("r.json");
    let out = Command::new(env!("CARGO_BIN_EXE_fosls"))
        .arg("estimate")
        .arg(fixture("exact_p2_energy"))
        .args(["--quiet", "--timeout", "600"])
        .arg("--json")
        .arg(&json)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(0), "{:?}", out);
    assert!(json.exists());
}

#[test]
fn bad_timeout_values_are_usage_errors() {
    for (value, problem) in [
        ("0", "\"0\" is not a positive number of seconds"),
        ("soon", "\"soon\" is not a number of seconds"),
    ] {
        let out = Command::new(env!("CARGO_BIN_EXE_fosls"))
            .arg("inspect")
            .arg(fixture("exact_p2_energy"))
            .args(["--timeout", value])
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(2));
        let stderr = String::from_utf8(out.stderr).unwrap();
        assert!(
            stderr.contains(&format!(
                "invalid value '{value}' for '--timeout <SECONDS>': {problem}"
            )),
            "{stderr}"
        );
    }
}

/// `FOSLS_MAX_ALLOC` caps the decoded data. With the cap at the file's own length the file is
/// read, but its arrays need more: every value is held in 8 bytes, and the 54 cell types take 1
/// byte each in the file (zlib-compressed at that). One byte less and the file itself is refused.
#[test]
fn the_memory_cap_refuses_a_file_that_needs_more() {
    let dir = tempfile::tempdir().unwrap();
    let file = fixture("exact_p2_energy");
    let len = std::fs::metadata(&file).unwrap().len();
    let convert = |cap: u64| {
        Command::new(env!("CARGO_BIN_EXE_fosls"))
            .arg("convert")
            .arg(&file)
            .arg(dir.path().join("c.vtu"))
            .env("FOSLS_MAX_ALLOC", cap.to_string())
            .output()
            .unwrap()
    };
    let prefix = format!("error: {}: ", file.display());
    let line = refused(&convert(len), dir.path());
    assert!(line.starts_with(&prefix), "{line}");
    assert!(
        line.ends_with(&format!(
            "past the limit of {len} bytes (set FOSLS_MAX_ALLOC to raise it)"
        )),
        "{line}"
    );
    assert!(line.contains(" needs "), "{line}");
    let line = refused(&convert(len - 1), dir.path());
    assert_eq!(
        line,
        format!(
            "{prefix}file: is {len} bytes or more, past the limit of {} bytes (set \
             FOSLS_MAX_ALLOC to raise it)",
            len - 1
        )
    );
    // The same file converts under the default cap.
    let ok = Command::new(env!("CARGO_BIN_EXE_fosls"))
        .arg("convert")
        .arg(&file)
        .arg(dir.path().join("c.vtu"))
        .output()
        .unwrap();
    assert_eq!(ok.status.code(), Some(0));
}

/// A device that never ends is refused at the cap instead of being read forever.
#[test]
fn an_endless_input_stops_at_the_cap() {
    let out = Command::new(env!("CARGO_BIN_EXE_fosls"))
        .args(["inspect", "/dev/zero", "--quiet"])
        .env("FOSLS_MAX_ALLOC", "1M")
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert_eq!(
        String::from_utf8(out.stderr).unwrap(),
        "error: /dev/zero: file: is 1048577 bytes or more, past the limit of 1048576 bytes (set \
         FOSLS_MAX_ALLOC to raise it)\n"
    );
}

/// A scene file is read up to 16 MiB (`limits::MAX_SCENE_BYTES`) and refused beyond.
#[test]
fn an_oversized_scene_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("scene.toml");
    let cap = fosls::limits::MAX_SCENE_BYTES;
    std::fs::write(&scene, vec![b' '; cap as usize + 1]).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_fosls"))
        .arg("estimate")
        .arg(fixture("exact_p2_energy"))
        .arg("--scene")
        .arg(&scene)
        .arg("--quiet")
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert_eq!(
        String::from_utf8(out.stderr).unwrap(),
        format!(
            "error: {}: file: is {} bytes or more, past the limit of {cap} bytes (a scene file \
             is TOML of a few kilobytes)\n",
            scene.display(),
            cap + 1
        )
    );
}
