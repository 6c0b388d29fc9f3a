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
