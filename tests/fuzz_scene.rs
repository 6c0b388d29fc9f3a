//! Fuzzing of the scene parser and its expressions by random mutations of the fixtures' scene
//! files (proptest): whatever the text, `parse_scene` returns a scene or an error naming the
//! file, never panics or hangs, and a scene it accepts evaluates its expressions (body force,
//! selectors, boundary data, gap) to numbers without panicking. Peak allocation per case stays
//! below `2 × text length + 1 MiB` (a scene is small: the constant is the TOML tree).
//! `FOSLS_FUZZ_CASES` sets the number of cases (default 200); a panicking case is saved to
//! `target/fuzz-failures/` before the panic is passed on; kept cases live in
//! `tests/corpus/scene/` (run by `tests/corpus.rs`).

mod common;

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::time::{Duration, Instant};

use common::alloc::{self, Counting};
use fosls::read::scene::{self, BoundaryKind, Gap, Selector};
use proptest::prelude::*;

#[global_allocator]
static ALLOC: Counting = Counting;

static CASES: AtomicUsize = AtomicUsize::new(0);
static WORST_BYTES: AtomicU64 = AtomicU64::new(0);
static WORST_MICROS: AtomicU64 = AtomicU64::new(0);

const CASE_TIME: Duration = Duration::from_secs(10);

/// Fragments spliced into the text: TOML structure, expression syntax, extreme numbers.
const TOKENS: [&str; 44] = [
    "(",
    ")",
    "((((((((((((((((((((",
    "^",
    "^-",
    "1e308",
    "-1e308",
    "nan",
    "inf",
    "1e-320",
    "0",
    "0.5",
    "0.4999999",
    "-",
    "*",
    "/",
    "sqrt(",
    "log(",
    "exp(",
    "abs(",
    "min(",
    "max(x,",
    ",",
    "x",
    "y",
    "z",
    "pi",
    "[[boundary]]\n",
    "[",
    "]",
    "=",
    "\"",
    "'''",
    "\\u0000",
    "\n",
    "#",
    "{",
    "}",
    "true",
    "9999999999999999999999",
    "[material]\n",
    "poisson_ratio = 0.5\n",
    "friction = 1e3\n",
    "where = \"x^x^x^x^x^x^x^x^x^x^x^x^x^x^x^x^x^x^x^x\"\n",
];

#[derive(Clone, Debug)]
enum Mutation {
    Set(usize, u8),
    Delete(usize),
    Truncate(usize),
    Splice(usize, usize),
    /// Duplicate a line (repeated keys and tables).
    Repeat(usize),
}

fn mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        1 => (any::<usize>(), any::<u8>()).prop_map(|(i, b)| Mutation::Set(i, b)),
        1 => any::<usize>().prop_map(Mutation::Delete),
        1 => any::<usize>().prop_map(Mutation::Truncate),
        3 => (any::<usize>(), 0..TOKENS.len()).prop_map(|(i, k)| Mutation::Splice(i, k)),
        1 => any::<usize>().prop_map(Mutation::Repeat),
    ]
}

fn apply(bytes: &mut Vec<u8>, m: &Mutation) {
    let n = bytes.len();
    if n == 0 {
        return;
    }
    match *m {
        Mutation::Set(i, b) => bytes[i % n] = b,
        Mutation::Delete(i) => {
            bytes.remove(i % n);
        }
        Mutation::Truncate(i) => bytes.truncate(i % n),
        Mutation::Splice(i, k) => {
            let at = i % (n + 1);
            bytes.splice(at..at, TOKENS[k].bytes());
        }
        Mutation::Repeat(i) => {
            let at = i % n;
            let start = bytes[..at]
                .iter()
                .rposition(|&c| c == b'\n')
                .map_or(0, |p| p + 1);
            let end = bytes[at..]
                .iter()
                .position(|&c| c == b'\n')
                .map_or(n, |p| at + p + 1);
            let line = bytes[start..end].to_vec();
            bytes.splice(end..end, line);
        }
    }
}

fn scenes() -> Vec<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures");
    let mut out: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .filter_map(|e| {
            let p = e.ok()?.path().join("scene.toml");
            p.exists().then_some(p)
        })
        .collect();
    out.sort();
    out
}

/// Points where expressions are evaluated: ordinary, on the axes, huge, tiny.
const POINTS: [[f64; 2]; 5] = [
    [0.3, 0.7],
    [0.0, 0.0],
    [-1.0, 2.0],
    [1e300, -1e300],
    [1e-300, 0.0],
];

/// Parses `text` as the scene at `path` and uses every expression of an accepted scene.
pub fn check_scene(path: &Path, text: &str) {
    let before = alloc::reset_peak();
    let start = Instant::now();
    match scene::parse_scene(path, text) {
        Ok(s) => {
            let _ = (s.material.mu(), s.material.lambda(), s.effective_norm());
            for [x, y] in POINTS {
                if let Some(f) = &s.body_force {
                    let _ = (f[0].eval(x, y, 0.0), f[1].eval(x, y, 0.0));
                }
                for b in &s.boundaries {
                    if let Selector::Where(e) = &b.selector {
                        let _ = e.holds(x, y, 0.0);
                    }
                    match &b.kind {
                        BoundaryKind::Dirichlet { displacement: v }
                        | BoundaryKind::Neumann { traction: v } => {
                            let _ = (v[0].eval(x, y, 0.0), v[1].eval(x, y, 0.0));
                        }
                        BoundaryKind::Contact(c) => {
                            let n = c.direction([0.0, -1.0]);
                            let _ = c.gap_at([x, y], n);
                            if let Gap::Expr(e) = &c.gap {
                                let _ = e.eval(x, y, 0.0);
                            }
                        }
                    }
                }
            }
        }
        Err(e) => {
            let line = e.to_string();
            assert!(
                line.starts_with(&format!("{}: ", path.display())),
                "error does not name the file: {line}"
            );
        }
    }
    let peak = (alloc::peak() - before) as u64;
    let allowed = 2 * text.len() as u64 + (1 << 20);
    assert!(
        peak <= allowed,
        "scene parser allocated {peak} bytes for {} bytes of text",
        text.len()
    );
    WORST_BYTES.fetch_max(peak, Ordering::Relaxed);
    let took = start.elapsed();
    WORST_MICROS.fetch_max(took.as_micros() as u64, Ordering::Relaxed);
    assert!(took < CASE_TIME, "one case took {took:?}");
    let n = CASES.fetch_add(1, Ordering::Relaxed) + 1;
    if n.is_multiple_of(10_000) || n == cases() as usize {
        eprintln!(
            "fuzz_scene: {n} cases, worst peak {} bytes, slowest case {:.1} ms",
            WORST_BYTES.load(Ordering::Relaxed),
            WORST_MICROS.load(Ordering::Relaxed) as f64 / 1e3
        );
    }
}

fn cases() -> u32 {
    std::env::var("FOSLS_FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(200)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: cases(), ..ProptestConfig::default() })]

    #[test]
    fn mutated_scenes_never_panic(
        file in any::<prop::sample::Index>(),
        mutations in prop::collection::vec(mutation(), 1..8),
    ) {
        let _serial = alloc::serial();
        let all = scenes();
        let path = &all[file.index(all.len())];
        let mut bytes = std::fs::read(path).unwrap();
        for m in &mutations {
            apply(&mut bytes, m);
        }
        let text = String::from_utf8_lossy(&bytes).into_owned();
        let result = std::panic::catch_unwind(|| check_scene(path, &text));
        if let Err(panic) = result {
            let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("target/fuzz-failures");
            let _ = std::fs::create_dir_all(&dir);
            let _ = std::fs::write(dir.join(format!("scene-{}.toml", text.len())), &text);
            std::panic::resume_unwind(panic);
        }
    }
}

#[test]
fn deeply_nested_toml_and_expressions_are_errors() {
    let _serial = alloc::serial();
    let path = Path::new("deep.toml");
    let arrays = format!("x = {}{}\n", "[".repeat(100_000), "]".repeat(100_000));
    let e = scene::parse_scene(path, &arrays).unwrap_err().to_string();
    assert!(e.starts_with("deep.toml: "), "{e}");
    let tables = "a = { b = ".repeat(50_000) + "1" + &"}".repeat(50_000);
    let e = scene::parse_scene(path, &tables).unwrap_err().to_string();
    assert!(e.starts_with("deep.toml: "), "{e}");
}
