//! The environment and thresholds (issue 14, defects 8, 11, 18): `FOSLS_MAX_ALLOC` and
//! `RAYON_NUM_THREADS` parsed strictly with one line on bad values, a thread pool that cannot
//! start is an error (not an abort), `--fail-above` only finite, expression size bounded at
//! parse time, and `--timeout` naming the scene stage. Real binary, exact messages.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const BIN: &str = env!("CARGO_BIN_EXE_fosls");

fn fixture(file: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("fixtures/exact_p2_energy")
        .join(file)
}

fn inspect_with(var: &str, value: &str) -> Output {
    Command::new(BIN)
        .arg("inspect")
        .arg(fixture("solution.vtu"))
        .arg("--quiet")
        .env(var, value)
        .output()
        .unwrap()
}

fn one_line(out: &Output) -> String {
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    stderr.trim_end().to_string()
}

/// Defect 11: `1KB`, `0.5K`, `512MB`, `abc`, `-1` and the empty string were ignored silently
/// (the 16 GiB default was used).
#[test]
fn fosls_max_alloc_is_parsed_strictly() {
    let not_a_size = "is not a size: expected a whole number of bytes, optionally with K, M, G, \
                      T (or KiB, MiB, GiB, TiB), e.g. 512M or 2G";
    for (value, problem) in [
        (
            "1KB",
            "unit \"KB\" is ambiguous (1000 or 1024?); write 1K or 1KiB for powers of 1024",
        ),
        (
            "512MB",
            "unit \"MB\" is ambiguous (1000 or 1024?); write 512M or 512MiB for powers of 1024",
        ),
        ("0.5K", not_a_size),
        ("abc", not_a_size),
        ("-1", not_a_size),
        ("1T5", not_a_size),
        ("", "is empty; give a number of bytes such as 512M or 2G"),
        ("0", "is zero; the cap must be at least one byte"),
        ("99999999999999999999", "is larger than 2^64 - 1 bytes"),
        ("20000000T", "is larger than 2^64 - 1 bytes"),
    ] {
        assert_eq!(
            one_line(&inspect_with("FOSLS_MAX_ALLOC", value)),
            format!("error: FOSLS_MAX_ALLOC=\"{value}\": {problem}"),
            "{value}"
        );
    }
    for value in ["1T", "512M", "2G", "1024K", "2GiB", "16777216", " 64m "] {
        let out = inspect_with("FOSLS_MAX_ALLOC", value);
        assert_eq!(out.status.code(), Some(0), "{value}: {out:?}");
    }
    // A valid small cap still refuses the file with its own message.
    let out = inspect_with("FOSLS_MAX_ALLOC", "1K");
    assert!(
        one_line(&out).ends_with("past the limit of 1024 bytes (set FOSLS_MAX_ALLOC to raise it)")
    );
}

/// Defect 18: `RAYON_NUM_THREADS=3000` under a memory limit aborted inside rayon (exit 134).
#[test]
fn rayon_num_threads_is_parsed_strictly_and_the_pool_checked() {
    for value in ["0", "3000", "abc", "-2", "", "1.5"] {
        assert_eq!(
            one_line(&inspect_with("RAYON_NUM_THREADS", value)),
            format!(
                "error: RAYON_NUM_THREADS=\"{value}\": is not a whole number of threads from 1 \
                 to 1024"
            )
        );
    }
    for value in ["1", "2", "8"] {
        assert_eq!(
            inspect_with("RAYON_NUM_THREADS", value).status.code(),
            Some(0)
        );
    }
    // 1,000 threads with 2 MiB stacks do not fit in 1 GiB of address space.
    let out = Command::new("/bin/sh")
        .arg("-c")
        .arg(format!(
            "ulimit -v 1048576; RAYON_NUM_THREADS=1000 exec '{BIN}' estimate '{}' --quiet",
            fixture("solution.vtu").display()
        ))
        .output()
        .unwrap();
    let line = one_line(&out);
    assert!(
        line.starts_with("error: cannot start 1000 worker threads (")
            && line.ends_with("); lower RAYON_NUM_THREADS"),
        "{line}"
    );
}

/// Defect 18: `--fail-above NaN` was accepted.
#[test]
fn fail_above_takes_only_finite_numbers() {
    for value in ["NaN", "inf", "-inf", "nan", "x"] {
        let out = Command::new(BIN)
            .arg("estimate")
            .arg(fixture("solution.vtu"))
            .args(["--quiet", &format!("--fail-above={value}")])
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(2), "{value}");
        let stderr = String::from_utf8_lossy(&out.stderr);
        let problem = if value == "x" {
            "\"x\" is not a number".to_string()
        } else {
            format!("\"{value}\" is not a finite number")
        };
        assert_eq!(
            stderr.lines().next().unwrap(),
            format!("error: invalid value '{value}' for '--fail-above <X>': {problem}")
        );
    }
    let out = Command::new(BIN)
        .arg("estimate")
        .arg(fixture("solution.vtu"))
        .args(["--quiet", "--fail-above", "1e-30"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
}

fn scene_with_body_force(dir: &Path, expr: &str) -> PathBuf {
    let base = std::fs::read_to_string(fixture("scene.toml")).unwrap();
    assert!(base.contains("\"-29.261363636363637\""));
    let scene = dir.join("scene.toml");
    std::fs::write(
        &scene,
        base.replacen("\"-29.261363636363637\"", &format!("\"{expr}\""), 1),
    )
    .unwrap();
    scene
}

/// Defect 8: a body force `max` of 10,000 arguments ran for minutes on a large mesh; its size
/// is now refused when the scene is read.
#[test]
fn expression_size_is_bounded() {
    let dir = tempfile::tempdir().unwrap();
    let wide = format!("max({})", vec!["x"; 10_000].join(", "));
    let scene = scene_with_body_force(dir.path(), &wide);
    let out = Command::new(BIN)
        .arg("estimate")
        .arg(fixture("solution.vtu"))
        .arg("--scene")
        .arg(&scene)
        .arg("--quiet")
        .output()
        .unwrap();
    assert_eq!(
        one_line(&out),
        format!(
            "error: {}: loads.body_force[0]: expression too large (10001 nodes after constant \
             folding, limit 10000)",
            scene.display()
        )
    );
}

/// Defect 8: while the scene was parsed, `--timeout` named the stage "reading the solution".
/// Eight expressions of a million tokens each (`max(1, 1, …)`, folded to one constant) take
/// seconds to parse in a debug build.
#[test]
fn the_timeout_names_the_scene_stage() {
    let dir = tempfile::tempdir().unwrap();
    let long = format!("max({})", vec!["1"; 499_000].join(","));
    let base = std::fs::read_to_string(fixture("scene.toml")).unwrap();
    let mut text = String::new();
    for line in base.lines() {
        if line.starts_with("body_force")
            || line.starts_with("displacement")
            || line.starts_with("traction")
        {
            let key = line.split('=').next().unwrap().trim();
            text.push_str(&format!("{key} = [\"{long}\", \"{long}\"]\n"));
        } else {
            text.push_str(line);
            text.push('\n');
        }
    }
    let scene = dir.path().join("slow.toml");
    std::fs::write(&scene, text).unwrap();
    let out = Command::new(BIN)
        .arg("estimate")
        .arg(fixture("solution.vtu"))
        .arg("--scene")
        .arg(&scene)
        .args(["--quiet", "--timeout", "0.5"])
        .output()
        .unwrap();
    assert_eq!(
        one_line(&out),
        "error: timeout: estimate did not finish within 0.5 s (stage: reading the scene)"
    );
}
