//! Output safety (issue 14, defects 1, 2, 3, 6, 14, 15 and `--output -`): no output over an
//! input or over another output, devices and FIFOs written in place, unpredictable temporary
//! names, names up to `NAME_MAX`, nothing left behind or published after a signal or a
//! timeout. Every case runs the real binary in a temporary folder and checks the exit status,
//! the exact one-line message and what is left in the folder (`src/write/output.rs`).

use std::os::unix::fs::FileTypeExt;
use std::os::unix::process::ExitStatusExt;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

const BIN: &str = env!("CARGO_BIN_EXE_fosls");

fn fixture(case: &str, file: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("fixtures")
        .join(case)
        .join(file)
}

/// A folder with `in.vtu` and its scene `in.toml` (exact_p2_energy: small and fast).
fn setup() -> (tempfile::TempDir, PathBuf, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let vtu = dir.path().join("in.vtu");
    let scene = dir.path().join("in.toml");
    std::fs::copy(fixture("exact_p2_energy", "solution.vtu"), &vtu).unwrap();
    std::fs::copy(fixture("exact_p2_energy", "scene.toml"), &scene).unwrap();
    (dir, vtu, scene)
}

fn fosls(args: &[&dyn AsRef<std::ffi::OsStr>]) -> Output {
    let mut c = Command::new(BIN);
    for a in args {
        c.arg(a);
    }
    c.output().unwrap()
}

/// Exit status 2 and exactly one line on stderr, returned without `error: ` and the newline.
fn refused(out: &Output) -> String {
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    stderr
        .strip_prefix("error: ")
        .unwrap_or_else(|| panic!("{stderr}"))
        .trim_end()
        .to_string()
}

/// Names in `dir`, sorted.
fn listing(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

fn d(p: &Path) -> String {
    p.display().to_string()
}

/// Defect 1: the scene (found beside the file, or given with --scene) is an input too.
#[test]
fn the_scene_is_never_overwritten() {
    let (dir, vtu, scene) = setup();
    let before = std::fs::read(&scene).unwrap();
    for option in ["--json", "--output"] {
        let line = refused(&fosls(&[&"estimate", &vtu, &option, &scene, &"--quiet"]));
        assert_eq!(
            line,
            format!("{}: refusing to overwrite the scene file", d(&scene))
        );
    }
    // Spelled differently, through a hard link and through a symbolic link.
    let my = dir.path().join("my.toml");
    std::fs::copy(&scene, &my).unwrap();
    let dotted = dir.path().join(".").join("my.toml");
    let line = refused(&fosls(&[
        &"estimate",
        &vtu,
        &"--scene",
        &my,
        &"--json",
        &dotted,
        &"--quiet",
    ]));
    assert_eq!(
        line,
        format!(
            "{}: refusing to overwrite the scene file {} (the same file)",
            d(&dotted),
            d(&my)
        )
    );
    let hard = dir.path().join("hard.json");
    std::fs::hard_link(&scene, &hard).unwrap();
    let soft = dir.path().join("soft.json");
    std::os::unix::fs::symlink(&scene, &soft).unwrap();
    for link in [&hard, &soft] {
        let line = refused(&fosls(&[&"estimate", &vtu, &"--json", link, &"--quiet"]));
        assert_eq!(
            line,
            format!(
                "{}: refusing to overwrite the scene file {} (the same file)",
                d(link),
                d(&scene)
            )
        );
    }
    // The VTU input keeps its old message.
    let line = refused(&fosls(&[&"estimate", &vtu, &"--output", &vtu, &"--quiet"]));
    assert_eq!(
        line,
        format!("{}: refusing to overwrite the input file", d(&vtu))
    );
    assert_eq!(std::fs::read(&scene).unwrap(), before);
    assert_eq!(std::fs::read(&my).unwrap(), before);
    assert_eq!(
        listing(dir.path()),
        ["hard.json", "in.toml", "in.vtu", "my.toml", "soft.json"]
    );
}

/// Defect 14: --json and --output on one path, or --json on the discontinuous copy's name.
#[test]
fn one_output_never_replaces_another() {
    let (dir, vtu, _) = setup();
    let o = dir.path().join("o.vtu");
    let line = refused(&fosls(&[&"estimate", &vtu, &"--json", &o, &"--output", &o]));
    assert_eq!(
        line,
        format!("{}: --json and --output would both write this file", d(&o))
    );
    let copy = dir.path().join("o_discontinuous.vtu");
    let line = refused(&fosls(&[
        &"estimate",
        &vtu,
        &"--json",
        &copy,
        &"--output",
        &o,
    ]));
    assert_eq!(
        line,
        format!(
            "{}: --json and --output's copy would both write this file",
            d(&copy)
        )
    );
    let other = dir.path().join("sub").join("..").join("o.vtu");
    std::fs::create_dir(dir.path().join("sub")).unwrap();
    let line = refused(&fosls(&[
        &"estimate",
        &vtu,
        &"--json",
        &o,
        &"--output",
        &other,
    ]));
    assert_eq!(
        line,
        format!(
            "{}: --output would write the same file as --json {}",
            d(&other),
            d(&o)
        )
    );
    assert_eq!(listing(dir.path()), ["in.toml", "in.vtu", "sub"]);
}

/// `--output -` is refused instead of creating a file named `-`.
#[test]
fn output_dash_is_refused() {
    let (dir, vtu, _) = setup();
    let out = Command::new(BIN)
        .current_dir(dir.path())
        .args(["estimate", "in.vtu", "--output", "-", "--quiet"])
        .output()
        .unwrap();
    assert_eq!(
        refused(&out),
        "--output -: this output must be a file (standard output is not accepted here)"
    );
    assert!(out.stdout.is_empty());
    assert_eq!(listing(dir.path()), ["in.toml", "in.vtu"]);
    let _ = vtu;
}

/// Defect 2: character devices and FIFOs are written in place, never replaced by a file.
#[test]
fn devices_and_fifos_are_written_in_place() {
    let (dir, vtu, _) = setup();
    let null = dir.path().join("null");
    let full = dir.path().join("full");
    let made = Command::new("mknod")
        .arg(&null)
        .args(["c", "1", "3"])
        .status()
        .is_ok_and(|s| s.success())
        && Command::new("mknod")
            .arg(&full)
            .args(["c", "1", "7"])
            .status()
            .is_ok_and(|s| s.success());
    if made {
        let out = fosls(&[&"estimate", &vtu, &"--json", &null, &"--quiet"]);
        assert_eq!(out.status.code(), Some(0), "{out:?}");
        let out = fosls(&[&"inspect", &vtu, &"--json", &full, &"--quiet"]);
        assert_eq!(
            refused(&out),
            format!("{}: No space left on device (os error 28)", d(&full))
        );
        for p in [&null, &full] {
            let ft = std::fs::symlink_metadata(p).unwrap().file_type();
            assert!(ft.is_char_device(), "{} was replaced", d(p));
        }
    } else {
        eprintln!("mknod not permitted here: device part skipped");
    }
    // A FIFO: the report goes to its reader, and it stays a FIFO.
    let fifo = dir.path().join("fifo");
    assert!(
        Command::new("mkfifo")
            .arg(&fifo)
            .status()
            .unwrap()
            .success()
    );
    let reader = {
        let fifo = fifo.clone();
        std::thread::spawn(move || std::fs::read(&fifo).unwrap())
    };
    let out = fosls(&[&"estimate", &vtu, &"--json", &fifo, &"--quiet"]);
    assert_eq!(out.status.code(), Some(0), "{out:?}");
    let json = reader.join().unwrap();
    let v: serde_json::Value = serde_json::from_slice(&json).unwrap();
    assert!(v["functional"]["total"].is_number());
    assert!(
        std::fs::symlink_metadata(&fifo)
            .unwrap()
            .file_type()
            .is_fifo()
    );
    // /dev/stdout on a pipe is written in place too (as root the old writer renamed a
    // temporary file onto it).
    let out = fosls(&[&"inspect", &vtu, &"--json", &"/dev/stdout", &"--quiet"]);
    assert_eq!(out.status.code(), Some(0), "{out:?}");
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(v["points_in_file"].is_number());
    assert!(Path::new("/dev/stdout").is_symlink() || Path::new("/dev/stdout").exists());
}

/// Defect 3: the temporary name cannot be guessed, and a planted symbolic link at the old
/// predictable name is not followed.
#[test]
fn a_planted_temporary_name_is_not_followed() {
    let (dir, vtu, _) = setup();
    let victim = dir.path().join("victim.txt");
    std::fs::write(&victim, b"precious").unwrap();
    let script = format!(
        "cd '{}' && ln -s victim.txt .r.json.$$.tmp && exec '{BIN}' estimate '{}' --json r.json \
         --quiet",
        d(dir.path()),
        d(&vtu)
    );
    let out = Command::new("/bin/sh")
        .arg("-c")
        .arg(script)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(0), "{out:?}");
    assert_eq!(std::fs::read(&victim).unwrap(), b"precious");
    let r: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("r.json")).unwrap()).unwrap();
    assert!(r["functional"]["total"].is_number());
    // Only the planted link is left besides the inputs and the report.
    let left: Vec<String> = listing(dir.path())
        .into_iter()
        .filter(|n| n.starts_with(".fosls-"))
        .collect();
    assert!(left.is_empty(), "{left:?}");
}

/// Defect 15: a 250-byte file name works (the temporary name no longer grows with it).
#[test]
fn long_output_names_work() {
    let (dir, vtu, _) = setup();
    let json = dir.path().join(format!("{}.json", "j".repeat(245)));
    let out_vtu = dir.path().join(format!("{}.vtu", "o".repeat(246)));
    assert_eq!(json.file_name().unwrap().len(), 250);
    let out = fosls(&[
        &"estimate",
        &vtu,
        &"--json",
        &json,
        &"--output",
        &out_vtu,
        &"--quiet",
    ]);
    assert_eq!(out.status.code(), Some(0), "{out:?}");
    assert!(json.is_file() && out_vtu.is_file());
    // A name past NAME_MAX is one line at the start, before any work.
    let too_long = dir.path().join(format!("{}.json", "t".repeat(300)));
    let line = refused(&fosls(&[&"estimate", &vtu, &"--json", &too_long]));
    assert!(line.ends_with("File name too long (os error 36)"), "{line}");
    assert_eq!(listing(dir.path()).len(), 4);
}

/// A new file gets the usual mode (0666 less the umask); a replaced file keeps its mode.
#[test]
fn modes_are_kept() {
    use std::os::unix::fs::PermissionsExt;
    let (dir, vtu, _) = setup();
    let fresh = dir.path().join("fresh.json");
    let kept = dir.path().join("kept.json");
    std::fs::write(&kept, b"old").unwrap();
    std::fs::set_permissions(&kept, std::fs::Permissions::from_mode(0o600)).unwrap();
    let script = format!(
        "umask 022 && exec '{BIN}' inspect '{}' --json '{}' --quiet && exit 9",
        d(&vtu),
        d(&fresh)
    );
    assert!(
        Command::new("/bin/sh")
            .arg("-c")
            .arg(&script)
            .status()
            .unwrap()
            .success()
    );
    let out = fosls(&[&"inspect", &vtu, &"--json", &kept, &"--quiet"]);
    assert_eq!(out.status.code(), Some(0));
    let mode = |p: &Path| std::fs::metadata(p).unwrap().permissions().mode() & 0o777;
    assert_eq!(mode(&fresh), 0o644);
    assert_eq!(mode(&kept), 0o600);
    assert_ne!(std::fs::read(&kept).unwrap(), b"old");
}

/// Starts `estimate` with `--output o.vtu --json fifo`: the run stages o.vtu as a temporary
/// file, then blocks in the commit opening the FIFO (no reader). Returns once the staged
/// temporary file is there.
fn blocked_run(dir: &Path, vtu: &Path, extra: &[&str]) -> std::process::Child {
    let fifo = dir.join("fifo");
    if !fifo.exists() {
        assert!(
            Command::new("mkfifo")
                .arg(&fifo)
                .status()
                .unwrap()
                .success()
        );
    }
    let child = Command::new(BIN)
        .arg("estimate")
        .arg(vtu)
        .arg("--output")
        .arg(dir.join("o.vtu"))
        .arg("--json")
        .arg(&fifo)
        .arg("--quiet")
        .args(extra)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    // The staged VTU (not the empty probe the plan makes when it checks the folder).
    let staged = |dir: &Path| {
        listing(dir).iter().any(|n| {
            n.starts_with(".fosls-") && std::fs::metadata(dir.join(n)).is_ok_and(|m| m.len() > 0)
        })
    };
    while !staged(dir) {
        assert!(
            start.elapsed() < Duration::from_secs(120),
            "no temporary file appeared: {:?}",
            listing(dir)
        );
        std::thread::sleep(Duration::from_millis(5));
    }
    child
}

/// Defect 6: SIGINT, SIGTERM and SIGHUP while the outputs are staged remove the temporary
/// files and publish nothing; the process ends by the signal.
#[test]
fn signals_remove_the_temporary_files() {
    let (dir, vtu, _) = setup();
    // A signal ignored by the environment (SIGHUP under nohup) stays ignored in the child, as
    // POSIX asks: such a signal cannot end the run, so it is not tested.
    let ignored = std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find_map(|l| l.strip_prefix("SigIgn:"))
                .and_then(|h| u64::from_str_radix(h.trim(), 16).ok())
        })
        .unwrap_or(0);
    for sig in [2, 15, 1] {
        if ignored & (1u64 << (sig - 1)) != 0 {
            continue;
        }
        let child = blocked_run(dir.path(), &vtu, &[]);
        let pid = child.id().to_string();
        assert!(
            Command::new("kill")
                .args([&format!("-{sig}"), &pid])
                .status()
                .unwrap()
                .success()
        );
        let out = child.wait_with_output().unwrap();
        assert_eq!(out.status.signal(), Some(sig), "{out:?}");
        assert_eq!(
            listing(dir.path()),
            ["fifo", "in.toml", "in.vtu"],
            "signal {sig}"
        );
    }
}

/// Defect 6: a timeout near the end (here: while the commit waits for the FIFO) exits 2 naming
/// the stage and leaves no output, not even the one staged first.
#[test]
fn a_timeout_at_the_end_publishes_nothing() {
    let (dir, vtu, _) = setup();
    let child = blocked_run(dir.path(), &vtu, &["--timeout", "3"]);
    let out = child.wait_with_output().unwrap();
    assert_eq!(
        refused(&out),
        "timeout: estimate did not finish within 3 s (stage: writing the outputs)"
    );
    assert_eq!(listing(dir.path()), ["fifo", "in.toml", "in.vtu"]);
}

/// A run that ends normally publishes every output, and only the outputs.
#[test]
fn a_normal_run_publishes_every_output() {
    let dir = tempfile::tempdir().unwrap();
    let vtu = fixture("hertz_skfem_p1", "solution.vtu");
    let o = dir.path().join("o.vtu");
    let j = dir.path().join("r.json");
    let out = fosls(&[
        &"estimate",
        &vtu,
        &"--stress",
        &"reconstruct",
        &"--output",
        &o,
        &"--json",
        &j,
        &"--quiet",
    ]);
    assert_eq!(out.status.code(), Some(0), "{out:?}");
    assert_eq!(
        listing(dir.path()),
        ["o.vtu", "o_discontinuous.vtu", "r.json"]
    );
    fosls::read::vtu::read_vtu(&o).unwrap();
    fosls::read::vtu::read_vtu(&dir.path().join("o_discontinuous.vtu")).unwrap();
}

/// `convert` follows the same rules: not onto its input, in place for devices.
#[test]
fn convert_is_planned_too() {
    let (dir, vtu, _) = setup();
    let line = refused(&fosls(&[&"convert", &vtu, &vtu]));
    assert_eq!(
        line,
        format!("{}: refusing to overwrite the input file", d(&vtu))
    );
    let link = dir.path().join("link.vtu");
    std::os::unix::fs::symlink(&vtu, &link).unwrap();
    let line = refused(&fosls(&[&"convert", &vtu, &link]));
    assert_eq!(
        line,
        format!(
            "{}: refusing to overwrite the input file {} (the same file)",
            d(&link),
            d(&vtu)
        )
    );
    let out = fosls(&[&"convert", &vtu, &"/dev/null"]);
    assert_eq!(out.status.code(), Some(0), "{out:?}");
    // Written through, never renamed over: a regular file here would break every later
    // process on the machine that reads /dev/null (cargo's rustc probe among them).
    use std::os::unix::fs::FileTypeExt;
    let kind = std::fs::metadata("/dev/null").unwrap().file_type();
    assert!(kind.is_char_device(), "/dev/null is no longer a device");
    let out = fosls(&[&"convert", &vtu, &"-"]);
    assert_eq!(out.status.code(), Some(0));
    assert!(out.stdout.starts_with(b"<?xml"));
}
