//! Fuzzing of the reader by random byte mutations of real fixture files (proptest): whatever
//! the bytes, reading, building the mesh and the topology, and summarising must return a value
//! or an error, never panic. `FOSLS_FUZZ_CASES` raises the number of cases (default 200 per
//! file); the cases that once failed are kept in `tests/fuzz_reader.proptest-regressions`.

use std::path::Path;

use fosls::{inspect, mesh, read, topology};
use proptest::prelude::*;

const FILES: [&str; 10] = [
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
];

#[derive(Clone, Debug)]
enum Mutation {
    Set(usize, u8),
    Insert(usize, u8),
    Delete(usize),
    Truncate(usize),
    /// Replace a digit with another one: hits counts, offsets and sizes in the XML.
    Digit(usize, u8),
}

fn mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        (any::<usize>(), any::<u8>()).prop_map(|(i, b)| Mutation::Set(i, b)),
        (any::<usize>(), any::<u8>()).prop_map(|(i, b)| Mutation::Insert(i, b)),
        any::<usize>().prop_map(Mutation::Delete),
        any::<usize>().prop_map(Mutation::Truncate),
        (any::<usize>(), 0u8..10).prop_map(|(i, d)| Mutation::Digit(i, d)),
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
    }
}

fn read_all(path: &Path, bytes: &[u8]) {
    let Ok(vtu) = read::vtu::parse_vtu(path, bytes) else {
        return;
    };
    let Ok(data) = mesh::build(vtu.clone()) else {
        return;
    };
    if let Ok(topo) = topology::build(&data) {
        let s = inspect::summary(&vtu, &data, &topo);
        let _ = inspect::render(&s);
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
    fn mutated_fixtures_never_panic(
        file in 0..FILES.len(),
        mutations in prop::collection::vec(mutation(), 1..6),
    ) {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/encodings");
        let path = dir.join(FILES[file]);
        let mut bytes = std::fs::read(&path).unwrap();
        for m in &mutations {
            apply(&mut bytes, m);
        }
        read_all(&path, &bytes);
    }
}

#[test]
fn unmutated_fixtures_read() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/encodings");
    for f in FILES {
        let path = dir.join(f);
        let bytes = std::fs::read(&path).unwrap();
        let vtu = read::vtu::parse_vtu(&path, &bytes).unwrap();
        topology::build(&mesh::build(vtu).unwrap()).unwrap();
    }
}
