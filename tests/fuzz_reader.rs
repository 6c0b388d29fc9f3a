//! Fuzzing of the reader by random byte mutations of real fixture files (proptest): whatever
//! the bytes, reading, building the mesh and the topology, and summarising must return a value
//! or an error, never panic, never hang, and never allocate more than twice the file's declared
//! data size. `FOSLS_FUZZ_CASES` raises the number of cases (default 200); the cases that once
//! failed are kept in `tests/fuzz_reader.proptest-regressions` and, as files, in
//! `tests/corpus/vtu/` (run by `tests/corpus.rs`). A case that panics is saved to
//! `target/fuzz-failures/` before the panic is passed on.
//!
//! The declared data size D of a file is its length plus the bytes the reader reserved for the
//! arrays the file declares ([`fosls::limits::Budget::used`]: 8 bytes per declared value plus the
//! staging buffers of compressed non-Float64 arrays). The reader's peak allocation must stay
//! below `2 D + 256 KiB`; the constant covers the XML parser and the thread pool.
mod common;

use std::path::Path;
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::time::{Duration, Instant};

use common::alloc::{self, Counting};
use fosls::limits::Budget;
use fosls::{inspect, mesh, read, topology};
use proptest::prelude::*;

#[global_allocator]
static ALLOC: Counting = Counting;

/// Running totals, printed every 10 000 cases and at the end of the configured number.
static CASES: AtomicUsize = AtomicUsize::new(0);
/// Largest peak / D seen over cases with D ≥ 64 KiB, in millionths.
static WORST_RATIO: AtomicU64 = AtomicU64::new(0);
static WORST_MICROS: AtomicU64 = AtomicU64::new(0);

/// Peak allocation allowed for a file of declared data size `d`: twice that, plus 64 KiB for
/// each decoding thread (a zlib inflater holds a 32 KiB window and its state) and 128 KiB for
/// the XML parser.
fn allowed(d: u64) -> u64 {
    2 * d + (64 << 10) * rayon::current_num_threads() as u64 + (128 << 10)
}

/// The slowest a single case may be: far above the slowest honest file (milliseconds), far
/// below what a loop over a hostile count would take.
const CASE_TIME: Duration = Duration::from_secs(20);

const FILES: [&str; 14] = [
    "p2_vtk_appended_raw_zlib.vtu",
    "p2_vtk_appended_raw_lz4.vtu",
    "p2_vtk_appended_raw_lzma.vtu",
    "p2_vtk_appended_base64.vtu",
    "p2_vtk_bigendian_zlib.vtu",
    "p2_meshio_zlib.vtu",
    "p2_meshio_ascii.vtu",
    "p2_vtk_pieces3.vtu",
    "p1_vtk_binary_zlib.vtu",
    "ngsolve_p2_exploded.vtu",
    "p2_meshio_lzma.vtu",
    "p2_meshio_zlib_uint64.vtu",
    "p2_vtk_float32_int32.vtu",
    "p2_vtk_uint32header.vtu",
];

#[derive(Clone, Debug)]
enum Mutation {
    Set(usize, u8),
    Insert(usize, u8),
    Delete(usize),
    Truncate(usize),
    /// Replace a digit with another one: hits counts, offsets and sizes in the XML.
    Digit(usize, u8),
    /// Replace the number around a digit with an extreme one (counts, offsets, components).
    Number(usize, usize),
}

/// Numbers that break naive size arithmetic: zero, one, 2^31, 2^32 − 1, 2^64 − 1, 10^12.
const EXTREME_NUMBERS: [&str; 6] = [
    "0",
    "1",
    "2147483648",
    "4294967295",
    "18446744073709551615",
    "1000000000000",
];

fn mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        (any::<usize>(), any::<u8>()).prop_map(|(i, b)| Mutation::Set(i, b)),
        (any::<usize>(), any::<u8>()).prop_map(|(i, b)| Mutation::Insert(i, b)),
        any::<usize>().prop_map(Mutation::Delete),
        any::<usize>().prop_map(Mutation::Truncate),
        (any::<usize>(), 0u8..10).prop_map(|(i, d)| Mutation::Digit(i, d)),
        (any::<usize>(), 0..EXTREME_NUMBERS.len()).prop_map(|(i, k)| Mutation::Number(i, k)),
    ]
}

fn apply(bytes: &mut Vec<u8>, m: &Mutation) {
    if bytes.is_empty() {
        return;
    }
    let n = bytes.len();
    match *m {
        Mutation::Set(i, b) => bytes[i % n] = b,
        Mutation::Insert(i, b) => bytes.insert(i % (n + 1), b),
        Mutation::Delete(i) => {
            bytes.remove(i % n);
        }
        Mutation::Truncate(i) => bytes.truncate(i % n),
        Mutation::Digit(i, d) => {
            let digits: Vec<usize> = (0..n).filter(|&k| bytes[k].is_ascii_digit()).collect();
            if !digits.is_empty() {
                bytes[digits[i % digits.len()]] = b'0' + d;
            }
        }
        Mutation::Number(i, k) => {
            // Only the XML part: the binary data is covered by Set.
            let xml = memchr::memmem::find(bytes, b"<AppendedData").unwrap_or(n);
            let digits: Vec<usize> = (0..xml).filter(|&k| bytes[k].is_ascii_digit()).collect();
            if let Some(&at) = digits.get(i % digits.len().max(1)) {
                let start = (0..=at)
                    .rev()
                    .take_while(|&k| bytes[k].is_ascii_digit())
                    .last()
                    .unwrap_or(at);
                let end = (at..n).take_while(|&k| bytes[k].is_ascii_digit()).count() + at;
                bytes.splice(start..end, EXTREME_NUMBERS[k].bytes());
            }
        }
    }
}

/// Reads `bytes` as the file at `path` through every stage, checking the reader's allocation.
fn read_all(path: &Path, bytes: &[u8]) {
    let budget = Budget::global();
    let before = alloc::reset_peak();
    let start = Instant::now();
    let vtu = read::vtu::parse_vtu_with(path, bytes, &budget);
    let peak = (alloc::peak() - before) as u64;
    let declared = bytes.len() as u64 + budget.used();
    assert!(
        peak <= allowed(declared),
        "reader allocated {peak} bytes for a declared data size of {declared}"
    );
    if declared >= 64 << 10 {
        WORST_RATIO.fetch_max(peak * 1_000_000 / declared, Ordering::Relaxed);
    }
    if let Ok(vtu) = vtu
        && let Ok(data) = mesh::build(vtu.clone())
        && let Ok(topo) = topology::build(&data)
    {
        let s = inspect::summary(&vtu, &data, &topo);
        let _ = inspect::render(&s);
    }
    let took = start.elapsed();
    WORST_MICROS.fetch_max(took.as_micros() as u64, Ordering::Relaxed);
    assert!(took < CASE_TIME, "one case took {took:?}");
    let n = CASES.fetch_add(1, Ordering::Relaxed) + 1;
    if n.is_multiple_of(10_000) || n == cases() as usize {
        eprintln!(
            "fuzz_reader: {n} cases, worst peak/declared {:.3} (D ≥ 64 KiB), slowest case {:.1} ms",
            WORST_RATIO.load(Ordering::Relaxed) as f64 / 1e6,
            WORST_MICROS.load(Ordering::Relaxed) as f64 / 1e3
        );
    }
}

/// Runs `read_all`, saving the bytes to `target/fuzz-failures/` if it panics.
fn read_all_or_save(path: &Path, bytes: &[u8]) {
    let result = std::panic::catch_unwind(|| read_all(path, bytes));
    if let Err(panic) = result {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("target/fuzz-failures");
        let _ = std::fs::create_dir_all(&dir);
        let name = format!("vtu-{:016x}.vtu", fnv(bytes));
        let _ = std::fs::write(dir.join(name), bytes);
        std::panic::resume_unwind(panic);
    }
}

/// FNV-1a, to name saved cases.
fn fnv(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf29ce484222325u64, |h, &b| {
        (h ^ b as u64).wrapping_mul(0x100000001b3)
    })
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
    fn mutated_fixtures_never_panic(
        file in 0..FILES.len(),
        mutations in prop::collection::vec(mutation(), 1..6),
    ) {
        let _serial = alloc::serial();
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/encodings");
        let path = dir.join(FILES[file]);
        let mut bytes = std::fs::read(&path).unwrap();
        for m in &mutations {
            apply(&mut bytes, m);
        }
        read_all_or_save(&path, &bytes);
    }
}

#[test]
fn unmutated_fixtures_read() {
    let _serial = alloc::serial();
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/encodings");
    for f in FILES {
        let path = dir.join(f);
        let bytes = std::fs::read(&path).unwrap();
        let vtu = read::vtu::parse_vtu(&path, &bytes).unwrap();
        topology::build(&mesh::build(vtu).unwrap()).unwrap();
    }
}
