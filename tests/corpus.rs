//! Regression corpus of hostile inputs (`tests/corpus/`): files the fuzzers found and
//! hand-made decompression bombs and lying size declarations (`tests/corpus/hostile.py`).
//!
//! Each `NAME.vtu` / `NAME.toml` has a `NAME.expected` holding the exact error the file must
//! produce after `FILE: ` (or `ok`). Every VTU file is run through the real binary (`fosls
//! inspect`: exit status 2, exactly that one line on stderr) and through the library with a
//! counting allocator (peak allocation ≤ 2 × declared data size + 64 KiB per thread + 128 KiB,
//! as in `fuzz_reader.rs`). Every scene is parsed with `parse_scene`.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

use common::alloc::{self, Counting};
use fosls::limits::Budget;
use fosls::{mesh, read, topology};

#[global_allocator]
static ALLOC: Counting = Counting;

fn cases(folder: &str, ext: &str) -> Vec<(PathBuf, String)> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/corpus")
        .join(folder);
    let mut out: Vec<(PathBuf, String)> = std::fs::read_dir(&dir)
        .unwrap()
        .filter_map(|e| {
            let p = e.ok()?.path();
            (p.extension()? == ext).then_some(p)
        })
        .map(|p| {
            let expected = std::fs::read_to_string(p.with_extension("expected"))
                .unwrap_or_else(|_| panic!("{}: no .expected file", p.display()));
            (p, expected.trim_end().to_string())
        })
        .collect();
    out.sort();
    assert!(!out.is_empty(), "no cases in {}", dir.display());
    out
}

/// The library's result for a VTU file, as `ok` or the error after `FILE: `.
fn library_result(path: &Path, bytes: &[u8]) -> String {
    let budget = Budget::global();
    let before = alloc::reset_peak();
    let vtu = read::vtu::parse_vtu_with(path, bytes, &budget);
    let peak = (alloc::peak() - before) as u64;
    let declared = bytes.len() as u64 + budget.used();
    assert!(
        peak <= 2 * declared + (64 << 10) * rayon::current_num_threads() as u64 + (128 << 10),
        "{}: reader allocated {peak} bytes for a declared data size of {declared}",
        path.display()
    );
    let result = vtu.and_then(|v| {
        let data = mesh::build(v)?;
        topology::build(&data).map(|_| ())
    });
    match result {
        Ok(()) => "ok".to_string(),
        Err(e) => e
            .to_string()
            .strip_prefix(&format!("{}: ", path.display()))
            .unwrap_or_else(|| panic!("error does not name the file: {e}"))
            .to_string(),
    }
}

#[test]
fn hostile_vtu_files_give_their_exact_errors() {
    let _serial = alloc::serial();
    for (path, expected) in cases("vtu", "vtu") {
        let bytes = std::fs::read(&path).unwrap();
        assert_eq!(
            library_result(&path, &bytes),
            expected,
            "{}",
            path.display()
        );
        let out = Command::new(env!("CARGO_BIN_EXE_fosls"))
            .arg("inspect")
            .arg(&path)
            .arg("--quiet")
            .output()
            .unwrap();
        let stderr = String::from_utf8(out.stderr).unwrap();
        if expected == "ok" {
            assert_eq!(out.status.code(), Some(0), "{}: {stderr}", path.display());
        } else {
            assert_eq!(out.status.code(), Some(2), "{}: {stderr}", path.display());
            assert_eq!(
                stderr,
                format!("error: {}: {expected}\n", path.display()),
                "{}",
                path.display()
            );
        }
    }
}

#[test]
fn hostile_scenes_give_their_exact_errors() {
    let _serial = alloc::serial();
    for (path, expected) in cases("scene", "toml") {
        let text = String::from_utf8_lossy(&std::fs::read(&path).unwrap()).into_owned();
        let got = match read::scene::parse_scene(&path, &text) {
            Ok(_) => "ok".to_string(),
            Err(e) => e
                .to_string()
                .strip_prefix(&format!("{}: ", path.display()))
                .unwrap_or_else(|| panic!("error does not name the file: {e}"))
                .to_string(),
        };
        assert_eq!(got, expected, "{}", path.display());
    }
}
