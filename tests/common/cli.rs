//! Run the real binary and parse its JSON report into the library's own type.

use std::path::{Path, PathBuf};
use std::process::Command;

use fosls::report::json::Report;

/// The repository root.
pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// `fosls estimate FILE ARGS --json -`: the exit status and the parsed report (None if the
/// run failed before writing one), and stderr.
pub fn estimate(file: &Path, args: &[&str]) -> (i32, Option<Report>, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_fosls"))
        .arg("estimate")
        .arg(file)
        .args(args)
        .args(["--json", "-"])
        .output()
        .expect("fosls runs");
    let code = out.status.code().unwrap_or(-1);
    let report = serde_json::from_slice(&out.stdout).ok();
    (
        code,
        report,
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// A copy of `fixtures/<case>/solution.vtu` in a temporary folder, with the fixture's scene
/// beside it where the first `from` is replaced by `to` (panics if the scene has no `from`:
/// the fixture changed). Returns the folder (dropped = removed) and the copied solution's path.
pub fn fixture_with_scene(case: &str, from: &str, to: &str) -> (tempfile::TempDir, PathBuf) {
    let src = root().join("fixtures").join(case);
    let scene = std::fs::read_to_string(src.join("scene.toml")).unwrap();
    assert!(scene.contains(from), "{case}: the fixture's scene changed");
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("solution.vtu");
    std::fs::copy(src.join("solution.vtu"), &file).unwrap();
    std::fs::write(dir.path().join("scene.toml"), scene.replacen(from, to, 1)).unwrap();
    (dir, file)
}
