//! Standard output that fails (issue 14, defect 5): a full device, a closed pipe or a closed
//! descriptor give exit status 2 and one line on stderr, never a panic (exit 101), and no
//! output file appears (`src/write/stdio.rs`).

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

const BIN: &str = env!("CARGO_BIN_EXE_fosls");

fn fixture() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/exact_p2_energy/solution.vtu")
}

fn line(out: &Output) -> String {
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    stderr.trim_end().to_string()
}

/// Runs `sh -c SCRIPT` with `$F` the binary and `$V` the fixture.
fn sh(script: &str) -> Output {
    Command::new("/bin/sh")
        .arg("-c")
        .arg(script)
        .env("F", BIN)
        .env("V", fixture())
        .output()
        .unwrap()
}

#[test]
fn a_full_device_is_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let o = dir.path().join("o.vtu");
    let o_arg = o.display().to_string();
    for args in [
        vec!["inspect"],
        vec!["inspect", "--json", "-", "--quiet"],
        vec!["estimate", "--output", &o_arg],
        vec!["estimate", "--json", "-", "--quiet", "--output", &o_arg],
    ] {
        let out = Command::new(BIN)
            .arg(args[0])
            .arg(fixture())
            .args(&args[1..])
            .stdout(std::fs::File::create("/dev/full").unwrap())
            .output()
            .unwrap();
        assert_eq!(
            line(&out),
            "error: standard output: No space left on device (os error 28)",
            "{args:?}"
        );
        assert!(
            !o.exists(),
            "{args:?}: the output appeared although the run failed"
        );
        assert!(std::fs::read_dir(dir.path()).unwrap().next().is_none());
    }
}

#[test]
fn a_closed_pipe_is_one_line() {
    for args in [
        vec!["inspect"],
        vec!["estimate"],
        vec!["estimate", "--json", "-"],
    ] {
        let mut child = Command::new(BIN)
            .arg(args[0])
            .arg(fixture())
            .args(&args[1..])
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        // The reader goes away before fosls has read its input.
        drop(child.stdout.take());
        let out = child.wait_with_output().unwrap();
        assert_eq!(
            line(&out),
            "error: standard output: Broken pipe (os error 32)",
            "{args:?}"
        );
    }
}

#[test]
fn a_closed_descriptor_is_one_line() {
    for script in [
        "exec \"$F\" estimate \"$V\" --json - --quiet >&-",
        "exec \"$F\" inspect \"$V\" --json - --quiet >&-",
        "exec \"$F\" inspect \"$V\" >&-",
    ] {
        let out = sh(script);
        assert_eq!(
            line(&out),
            "error: standard output: is closed (file descriptor 1 was not open)",
            "{script}"
        );
    }
    // Nothing to print: a closed standard output does not matter.
    let out = sh("exec \"$F\" inspect \"$V\" --quiet >&-");
    assert_eq!(out.status.code(), Some(0), "{out:?}");
    // A closed standard error: the exit status still tells.
    let out = sh("exec \"$F\" inspect /nonexistent.vtu 2>&-");
    assert_eq!(out.status.code(), Some(2));
    // With stdout closed, the files fosls opens must not become "standard output": the JSON
    // file gets the JSON and nothing else.
    let dir = tempfile::tempdir().unwrap();
    let j = dir.path().join("r.json");
    let out = sh(&format!(
        "exec \"$F\" estimate \"$V\" --json '{}' >&-",
        j.display()
    ));
    assert_eq!(
        line(&out),
        "error: standard output: is closed (file descriptor 1 was not open)"
    );
    assert!(!j.exists());
}
