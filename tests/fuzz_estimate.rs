//! Whole-path fuzzing of `fosls estimate` (issue 14): fixture meshes and scenes are mutated
//! (coordinates scaled or moved, field values set to extremes, tags broken, cells flipped or
//! collapsed, arrays renamed or dropped, names given control characters, bytes of the file
//! changed; scene numbers set to extremes, expressions replaced by ones that overflow or are
//! undefined somewhere, TOML fragments spliced in, lines dropped or repeated) and run through
//! the real binary with random options, `--json`, `--output` and `--timeout` in a temporary
//! folder. Every run must:
//!
//! - end with exit status 0, 1 or 2 (no panic, exit 101, or signal), within the timeout;
//! - on status 2, print exactly one line on stderr and write no output file;
//! - on status 0 or 1, write strict JSON (serde_json refuses NaN and infinities) with no null
//!   where the report promises a number, and a readable VTU;
//! - leave no temporary file (`.fosls-*`) nor any other file in the folder.
//!
//! The cases are drawn by a seeded generator (`FOSLS_FUZZ_SEED`, default 14); their number is
//! `FOSLS_FUZZ_CASES` (default 24, a few seconds in a debug build), or as many as fit in
//! `FOSLS_FUZZ_SECONDS`; `FOSLS_FUZZ_JOBS` runs that many at once. A failing case is saved to
//! `target/fuzz-failures/estimate-<class>-<hash>/` (solution.vtu, solution.toml, args,
//! stderr) for `tests/corpus/`.
//!
//! A null or non-finite number in a report of status 0 or 1 (defect 4 of issue 14) is a
//! finding: the library's `audit::finite` checks refuse such runs with exit 2. Set
//! `FOSLS_FUZZ_STRICT_FINITE=0` to count them without failing (to survey an old binary).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use fosls::read::vtu::{VtuFile, parse_vtu};
use fosls::write::{Placement, to_bytes};

const BIN: &str = env!("CARGO_BIN_EXE_fosls");

/// Small fixtures: P2 and P1 exact solutions, Hertz P1 (skfem), a Coulomb block, an exploded
/// NGSolve mesh.
const CASES: [&str; 5] = [
    "exact_p2_energy",
    "exact_p1_energy",
    "hertz_skfem_p1",
    "block_skfem_p1_coulomb",
    "hertz_ngsolve_p1_vtkoutput",
];

/// The watchdog's limit per run; the harness kills a run at twice that.
const TIMEOUT_S: u64 = 60;

/// splitmix64.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e3779b97f4a7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58476d1ce4e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d049bb133111eb);
        z ^ (z >> 31)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
    fn pick<T: Copy>(&mut self, v: &[T]) -> T {
        v[self.below(v.len())]
    }
    fn chance(&mut self, p: f64) -> bool {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64 <= p
    }
}

const EXTREMES: [f64; 14] = [
    0.0,
    -0.0,
    1e308,
    -1e308,
    1e-308,
    5e-324,
    1e300,
    1e150,
    -1e150,
    1e-160,
    f64::NAN,
    f64::INFINITY,
    f64::NEG_INFINITY,
    1e20,
];

const SCALES: [f64; 9] = [1e-160, 1e-100, 1e-8, 1e8, 1e100, 1e150, 1e300, -1.0, 0.0];

/// Mutates the file as data (what a writer could produce), not as bytes.
fn mutate_vtu(f: &mut VtuFile, rng: &mut Rng) {
    let n = f.points.len();
    // Value changes (which reach the estimate) weigh more than structural breakage (which the
    // reader and the mesh refuse).
    let kind = rng.pick(&[0, 1, 2, 2, 2, 2, 3, 3, 3, 4, 5, 6, 7, 8, 9, 10, 10]);
    match kind {
        0 => {
            let s = rng.pick(&SCALES);
            for p in &mut f.points {
                p[0] *= s;
                p[1] *= s;
            }
        }
        1 if n > 0 => {
            let k = rng.below(n);
            f.points[k][rng.below(2)] = rng.pick(&EXTREMES);
        }
        2 if !f.point_data.is_empty() => {
            let a = rng.below(f.point_data.len());
            let a = &mut f.point_data[a];
            if !a.values.is_empty() {
                let k = rng.below(a.values.len());
                a.values[k] = rng.pick(&EXTREMES);
            }
        }
        3 if !f.point_data.is_empty() => {
            let a = rng.below(f.point_data.len());
            let s = rng.pick(&[0.0, 1e-200, 1e200, -1.0, 1e150]);
            for v in &mut f.point_data[a].values {
                *v *= s;
            }
        }
        4 if !f.cell_data.is_empty() => {
            let a = rng.below(f.cell_data.len());
            let a = &mut f.cell_data[a];
            a.scalar = fosls::read::decode::Scalar::Float64;
            if !a.values.is_empty() {
                let k = rng.below(a.values.len());
                a.values[k] = rng.pick(&[f64::NAN, 1.5, -1.0, 99.0, 9007199254740993.0, 0.0]);
            }
        }
        5 if f.connectivity.len() > 1 => {
            // Swap two nodes of one cell (orientation) or of two cells.
            let c = rng.below(f.cell_count());
            let (a, b) = (f.offsets[c], f.offsets[c + 1]);
            if b - a >= 2 {
                let i = a + rng.below(b - a);
                let j = if rng.chance(0.7) {
                    a + rng.below(b - a)
                } else {
                    rng.below(f.connectivity.len())
                };
                f.connectivity.swap(i, j);
            }
        }
        6 if n > 1 => {
            // Move a point onto another: a collapsed or duplicated cell.
            let (i, j) = (rng.below(n), rng.below(n));
            f.points[i] = f.points[j];
        }
        7 if !f.point_data.is_empty() => {
            let a = rng.below(f.point_data.len());
            f.point_data[a].name = rng.pick(&["x", "", "stress", "u", "σ"]).to_string();
        }
        8 if !f.point_data.is_empty() => {
            let a = rng.below(f.point_data.len());
            f.point_data.remove(a);
        }
        9 => {
            let arrays = if rng.chance(0.5) {
                &mut f.point_data
            } else {
                &mut f.cell_data
            };
            if !arrays.is_empty() {
                let a = rng.below(arrays.len());
                arrays[a]
                    .name
                    .push(rng.pick(&['\u{1}', '\u{1b}', '\u{7f}', '\t', '&']));
            }
        }
        _ => {
            // A small displacement of every point (breaks exactness, keeps validity).
            for p in &mut f.points {
                p[0] += 1e-3 * ((rng.next() % 1000) as f64 / 1000.0 - 0.5);
            }
        }
    }
}

/// Byte-level mutations of the written file (rarely: the reader has its own fuzzer).
fn mutate_bytes(bytes: &mut Vec<u8>, rng: &mut Rng) {
    let n = bytes.len();
    if n == 0 {
        return;
    }
    match rng.below(4) {
        0 => bytes[rng.below(n)] = rng.next() as u8,
        1 => {
            bytes.remove(rng.below(n));
        }
        2 => bytes.insert(rng.below(n + 1), rng.next() as u8),
        _ => {
            // Change a digit in the XML part.
            let xml = memchr::memmem::find(bytes, b"<AppendedData").unwrap_or(n);
            let digits: Vec<usize> = (0..xml).filter(|&k| bytes[k].is_ascii_digit()).collect();
            if !digits.is_empty() {
                let k = rng.pick(&digits);
                bytes[k] = b'0' + rng.below(10) as u8;
            }
        }
    }
}

const EXPRESSIONS: [&str; 16] = [
    "1/x",
    "1/y",
    "1/0",
    "0/0",
    "sqrt(x-0.5)",
    "log(x)",
    "log(y - 0.5)",
    "exp(1000*x)",
    "1e308*x*x + 1e308",
    "x^1e6",
    "max(x, y)",
    "-1e300",
    "abs(x) < 1e-12",
    "y > 0.999 || x < 1e-9",
    "tan(pi/2)",
    "atan2(y, x)",
];

const NUMBERS: [&str; 16] = [
    "0",
    "-0.0",
    "1e308",
    "-1e308",
    "1e-308",
    "1e300",
    "1e-300",
    "0.5",
    "0.4999999",
    "nan",
    "inf",
    "-inf",
    "1e3",
    "-1",
    "1e-12",
    "2",
];

/// `(table, line)`: the line is put in the table (after its header, or in a new one).
const FRAGMENTS: [(&str, &str); 14] = [
    ("", "friction = 1e3"),
    ("", "friction = 1e308"),
    ("", "friction = 1e-9"),
    ("", "friction = 0.4"),
    ("estimate", "length_scale = 1e300"),
    ("estimate", "length_scale = 1e-300"),
    ("estimate", "norm = \"robust\""),
    ("estimate", "norm = \"seed\""),
    ("loads", "body_force = [\"1/x\", \"0\"]"),
    ("loads", "body_force = [\"1e300\", \"-1e300\"]"),
    ("loads", "body_force = [\"0/0\", \"y\"]"),
    (
        "[boundary]",
        "name = \"extra\"\nwhere = \"x > 1.999\"\nkind = \"neumann\"\ntraction = [\"1/(x-2)\", 0.0]",
    ),
    (
        "[boundary]",
        "name = \"gap\"\nwhere = \"y < 1e-9\"\nkind = \"contact\"\nobstacle = { plane = { point = [0.0, -1e308], normal = [0.0, 1.0] } }",
    ),
    ("material", "poisson_ratio = 0.5"),
];

/// Puts `line` into `table` of the scene (`""`: after a random line; `[boundary]`: a new
/// array-of-tables entry at the end).
fn insert(text: &mut String, table: &str, line: &str, rng: &mut Rng) {
    if table.is_empty() {
        let ends: Vec<usize> = text.match_indices('\n').map(|(i, _)| i + 1).collect();
        let at = ends
            .get(rng.below(ends.len().max(1)))
            .copied()
            .unwrap_or(text.len());
        text.insert_str(at, &format!("{line}\n"));
        return;
    }
    let header = format!("[{table}]");
    match text.find(&format!("\n{header}\n")) {
        Some(i) if !table.starts_with('[') => {
            let at = i + header.len() + 2;
            text.insert_str(at, &format!("{line}\n"));
        }
        _ => text.push_str(&format!("\n{header}\n{line}\n")),
    }
}

/// Mutates the scene text.
fn mutate_scene(text: &mut String, rng: &mut Rng) {
    match rng.below(6) {
        0 | 1 => {
            // A number after `=` or in an array.
            let spots: Vec<(usize, usize)> = number_spans(text);
            if !spots.is_empty() {
                let (a, b) = rng.pick(&spots);
                text.replace_range(a..b, rng.pick(&NUMBERS));
            }
        }
        2 => {
            // A string (an expression or a name) replaced by an expression.
            let quotes: Vec<usize> = text.match_indices('"').map(|(i, _)| i).collect();
            if quotes.len() >= 2 {
                let k = rng.below(quotes.len() / 2) * 2;
                let (a, b) = (quotes[k] + 1, quotes[k + 1]);
                text.replace_range(a..b, rng.pick(&EXPRESSIONS));
            }
        }
        3 => {
            let (table, line) = rng.pick(&FRAGMENTS);
            insert(text, table, line, rng);
        }
        4 => {
            let lines: Vec<&str> = text.lines().collect();
            if !lines.is_empty() {
                let k = rng.below(lines.len());
                let mut out: Vec<&str> = lines.clone();
                if rng.chance(0.5) {
                    out.remove(k);
                } else {
                    out.insert(k, lines[k]);
                }
                *text = out.join("\n");
                text.push('\n');
            }
        }
        _ => {
            // Swap a boundary kind.
            let kinds = ["\"dirichlet\"", "\"neumann\"", "\"contact\""];
            let at: Vec<usize> = kinds
                .iter()
                .flat_map(|k| text.match_indices(k).map(|(i, m)| (i, m.len())))
                .map(|(i, _)| i)
                .collect();
            if let Some(&i) = at.get(rng.below(at.len().max(1))) {
                let end = i + text[i + 1..].find('"').unwrap() + 2;
                text.replace_range(i..end, rng.pick(&kinds));
            }
        }
    }
}

/// Byte ranges of the numbers of a scene (after `=`, `[` or `,`).
fn number_spans(text: &str) -> Vec<(usize, usize)> {
    let b = text.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        let starts = (b[i].is_ascii_digit() || b[i] == b'-')
            && i > 0
            && matches!(b[i - 1], b' ' | b'[' | b',' | b'=');
        if starts {
            let mut j = i + 1;
            while j < b.len()
                && (b[j].is_ascii_alphanumeric() || matches!(b[j], b'.' | b'-' | b'+'))
            {
                j += 1;
            }
            out.push((i, j));
            i = j;
        } else {
            i += 1;
        }
    }
    out
}

fn options(rng: &mut Rng) -> Vec<String> {
    let mut v: Vec<String> = Vec::new();
    let mut add = |o: &[&str]| v.extend(o.iter().map(|s| s.to_string()));
    if rng.chance(0.3) {
        add(&["--stress", rng.pick(&["auto", "file", "reconstruct"])]);
    }
    if rng.chance(0.2) {
        add(&["--displacement", rng.pick(&["auto", "file", "reconstruct"])]);
    }
    if rng.chance(0.15) {
        add(&["--degree", rng.pick(&["0", "1"])]);
    }
    if rng.chance(0.2) {
        add(&["--norm", rng.pick(&["energy", "robust", "seed"])]);
    }
    if rng.chance(0.2) {
        add(&["--mark", rng.pick(&["0.5", "1", "0.01"])]);
    }
    if rng.chance(0.2) {
        add(&["--fail-above", rng.pick(&["0.01", "1e-30", "1e30", "0"])]);
    }
    if rng.chance(0.15) {
        add(&["--strict"]);
    }
    v
}

/// Where the report may hold `null` (an `Option` in `report::json`), besides the bound's numbers when
/// there is no bound.
fn may_be_null(path: &str) -> bool {
    matches!(
        path,
        "eta" | "relative" | "displacement.projection_distance" | "admissibility_file"
    ) || ((path.starts_with("admissibility.") || path.starts_with("admissibility_file."))
        && (path.ends_with("_at") || path.ends_with("_cell")))
        || matches!(
            path,
            "bound.energy_error" | "bound.relative" | "bound.terms"
        )
}

/// Paths of the nulls in `v` that are not allowed.
fn bad_nulls(v: &serde_json::Value, path: &str, out: &mut Vec<String>) {
    match v {
        serde_json::Value::Null if !may_be_null(path) => out.push(path.to_string()),
        serde_json::Value::Array(a) => {
            for (i, x) in a.iter().enumerate() {
                bad_nulls(x, &format!("{path}[{i}]"), out);
            }
        }
        serde_json::Value::Object(m) => {
            for (k, x) in m {
                let p = if path.is_empty() {
                    k.clone()
                } else {
                    format!("{path}.{k}")
                };
                bad_nulls(x, &p, out);
            }
        }
        _ => {}
    }
}

struct Case {
    vtu: Vec<u8>,
    scene: String,
    args: Vec<String>,
}

fn make_case(rng: &mut Rng) -> Case {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures");
    let name = rng.pick(&CASES);
    let bytes = std::fs::read(dir.join(name).join("solution.vtu")).unwrap();
    let mut scene = std::fs::read_to_string(dir.join(name).join("scene.toml")).unwrap();
    let mut file = parse_vtu(Path::new("solution.vtu"), &bytes).unwrap();
    let (mesh_mutations, scene_mutations) = match rng.below(3) {
        0 => (1 + rng.below(3), 0),
        1 => (0, 1 + rng.below(3)),
        _ => (1 + rng.below(2), 1 + rng.below(2)),
    };
    for _ in 0..mesh_mutations {
        mutate_vtu(&mut file, rng);
    }
    for _ in 0..scene_mutations {
        mutate_scene(&mut scene, rng);
    }
    let placement = if rng.chance(0.5) {
        Placement::AppendedRaw
    } else {
        Placement::Inline
    };
    let mut vtu = to_bytes(&file, placement);
    if rng.chance(0.1) {
        mutate_bytes(&mut vtu, rng);
    }
    Case {
        vtu,
        scene,
        args: options(rng),
    }
}

/// Runs one case: `Ok((exit status, whether a report of status 0 or 1 holds a null number))`
/// (the latter counted, see the module documentation), `Err((class, detail))` on a finding.
fn run_case(case: &Case) -> Result<(i32, bool), (String, String)> {
    let dir = tempfile::tempdir().unwrap();
    let vtu = dir.path().join("solution.vtu");
    let scene = dir.path().join("solution.toml");
    std::fs::write(&vtu, &case.vtu).unwrap();
    std::fs::write(&scene, &case.scene).unwrap();
    let json = dir.path().join("r.json");
    let out_vtu = dir.path().join("o.vtu");
    let mut child = Command::new(BIN)
        .arg("estimate")
        .arg(&vtu)
        .args(&case.args)
        .arg("--json")
        .arg(&json)
        .arg("--output")
        .arg(&out_vtu)
        .args(["--quiet", "--timeout", &TIMEOUT_S.to_string()])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if start.elapsed() > Duration::from_secs(2 * TIMEOUT_S) {
            let _ = child.kill();
            let _ = child.wait();
            return Err(("hang".into(), "killed by the harness".into()));
        }
        std::thread::sleep(Duration::from_millis(2));
    };
    let out = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    let finding = |class: &str, detail: String| Err((class.to_string(), detail));
    if stderr.contains("panicked") || status.code() == Some(101) {
        return finding("panic", stderr);
    }
    let Some(code) = status.code() else {
        return finding("signal", format!("{status:?} {stderr}"));
    };
    if stderr.contains("error: timeout:") {
        return finding("hang", stderr);
    }
    if !(0..=2).contains(&code) {
        return finding("exit-status", format!("{code}: {stderr}"));
    }
    let mut listing: Vec<String> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    listing.sort();
    let allowed = [
        "o.vtu",
        "o_discontinuous.vtu",
        "r.json",
        "solution.toml",
        "solution.vtu",
    ];
    if let Some(extra) = listing.iter().find(|n| !allowed.contains(&n.as_str())) {
        return finding("leftover", format!("{extra} in {listing:?}"));
    }
    if code == 2 {
        if stderr.lines().count() != 1 || !stderr.starts_with("error: ") {
            return finding("error-lines", stderr);
        }
        if json.exists() || out_vtu.exists() {
            return finding("output-on-failure", format!("{listing:?} {stderr}"));
        }
        if std::env::var_os("FOSLS_FUZZ_VERBOSE").is_some() {
            let line = stderr.trim_end();
            let cut: String = line.chars().take(160).collect();
            eprintln!(
                "exit 2: {}",
                cut.replace(&*dir.path().to_string_lossy(), "DIR")
            );
        }
        return Ok((2, false));
    }
    // Exit 0 or 1: a complete, strict report.
    let text = match std::fs::read_to_string(&json) {
        Ok(t) => t,
        Err(e) => return finding("no-report", format!("{e}; {stderr}")),
    };
    let v: serde_json::Value = match serde_json::from_str(&text) {
        Ok(v) => v,
        Err(e) => return finding("invalid-json", e.to_string()),
    };
    if let Err(e) = fosls::read::vtu::read_vtu(&out_vtu) {
        return finding("unreadable-vtu", e.to_string());
    }
    let copy = dir.path().join("o_discontinuous.vtu");
    if copy.exists()
        && let Err(e) = fosls::read::vtu::read_vtu(&copy)
    {
        return finding("unreadable-vtu", e.to_string());
    }
    let mut nulls = Vec::new();
    bad_nulls(&v, "", &mut nulls);
    if v["bound"]["guaranteed"] == serde_json::json!(true) && v["bound"]["energy_error"].is_null() {
        nulls.push("bound.energy_error (guaranteed)".into());
    }
    if code == 0
        && let Some(i) = case.args.iter().position(|a| a == "--fail-above")
    {
        let x: f64 = case.args[i + 1].parse().unwrap();
        match v["relative"].as_f64() {
            Some(r) if r <= x => {}
            _ => {
                return finding(
                    "exit-status",
                    format!("exit 0 with relative {}", v["relative"]),
                );
            }
        }
    }
    Ok((code, !nulls.is_empty()))
}

fn fnv(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf29ce484222325u64, |h, &b| {
        (h ^ b as u64).wrapping_mul(0x100000001b3)
    })
}

fn save(case: &Case, class: &str, detail: &str) -> PathBuf {
    let mut key = case.vtu.clone();
    key.extend_from_slice(case.scene.as_bytes());
    key.extend_from_slice(case.args.join(" ").as_bytes());
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("target/fuzz-failures")
        .join(format!("estimate-{class}-{:016x}", fnv(&key)));
    let _ = std::fs::create_dir_all(&dir);
    let _ = std::fs::write(dir.join("solution.vtu"), &case.vtu);
    let _ = std::fs::write(dir.join("solution.toml"), &case.scene);
    let _ = std::fs::write(dir.join("args"), case.args.join(" "));
    let _ = std::fs::write(dir.join("stderr"), detail);
    dir
}

fn env_number(name: &str) -> Option<u64> {
    std::env::var(name).ok().and_then(|v| v.trim().parse().ok())
}

#[derive(Default)]
struct Tally {
    runs: usize,
    exits: BTreeMap<i32, usize>,
    nulls: usize,
    findings: BTreeMap<String, Vec<String>>,
    slowest: f64,
}

#[test]
fn mutated_estimates_hold_the_contract() {
    let seed = env_number("FOSLS_FUZZ_SEED").unwrap_or(14);
    let seconds = env_number("FOSLS_FUZZ_SECONDS");
    let cases =
        env_number("FOSLS_FUZZ_CASES").unwrap_or(if seconds.is_some() { u64::MAX } else { 24 });
    let jobs = env_number("FOSLS_FUZZ_JOBS").unwrap_or(1).max(1);
    let strict = std::env::var("FOSLS_FUZZ_STRICT_FINITE").map_or(true, |v| v != "0");
    let start = Instant::now();
    let tally = Mutex::new(Tally::default());
    let next = std::sync::atomic::AtomicU64::new(0);
    std::thread::scope(|s| {
        for _ in 0..jobs {
            s.spawn(|| {
                loop {
                    let k = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                    if k >= cases || seconds.is_some_and(|t| start.elapsed().as_secs() >= t) {
                        break;
                    }
                    // Each case from its own seed: reproducible whatever the number of jobs.
                    let mut rng = Rng(seed ^ k.wrapping_mul(0x2545f4914f6cdd1d));
                    let case = make_case(&mut rng);
                    let t0 = Instant::now();
                    let result = run_case(&case);
                    let took = t0.elapsed().as_secs_f64();
                    let mut t = tally.lock().unwrap();
                    t.runs += 1;
                    t.slowest = t.slowest.max(took);
                    match result {
                        Ok((code, null)) => {
                            *t.exits.entry(code).or_default() += 1;
                            t.nulls += usize::from(null);
                            if null && strict {
                                let dir = save(&case, "null", "");
                                t.findings
                                    .entry("null-number".into())
                                    .or_default()
                                    .push(dir.display().to_string());
                            }
                        }
                        Err((class, detail)) => {
                            let dir = save(&case, &class, &detail);
                            t.findings
                                .entry(class)
                                .or_default()
                                .push(format!("{} ({})", dir.display(), detail.trim()));
                        }
                    }
                    if t.runs.is_multiple_of(1000) {
                        eprintln!(
                            "fuzz_estimate: {} runs in {:.0} s, {} with null numbers, findings {:?}",
                            t.runs,
                            start.elapsed().as_secs_f64(),
                            t.nulls,
                            t.findings.keys().collect::<Vec<_>>()
                        );
                    }
                }
            });
        }
    });
    let t = tally.into_inner().unwrap();
    eprintln!(
        "fuzz_estimate: {} runs in {:.1} s (seed {seed}, {jobs} jobs), exit statuses {:?}, slowest \
         {:.2} s; {} reports with a null number; findings: {}",
        t.runs,
        start.elapsed().as_secs_f64(),
        t.exits,
        t.slowest,
        t.nulls,
        if t.findings.is_empty() {
            "none".to_string()
        } else {
            t.findings
                .iter()
                .map(|(k, v)| format!("{k}: {}", v.len()))
                .collect::<Vec<_>>()
                .join(", ")
        }
    );
    assert!(
        t.findings.is_empty(),
        "findings: {:#?}",
        t.findings
            .iter()
            .map(|(k, v)| (k, v.iter().take(3).collect::<Vec<_>>()))
            .collect::<Vec<_>>()
    );
}
