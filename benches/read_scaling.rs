//! Read-scaling benchmark (a program, not a timed test): `cargo bench --bench read_scaling`.
//!
//! Issue 14, defect 7: reading many `<Piece>`s or many arrays was quadratic (2,000 / 4,000 /
//! 8,000 / 16,000 one-triangle pieces took 0.25 / 2.2 / 19 / 69 s; 50,000 point arrays 6–17
//! s). This program writes ASCII VTU files into a temporary folder and times `read_vtu` (the
//! whole read: bytes, start check, XML, decoding, merging of pieces) and `mesh::build`:
//!
//! - 2,000 … 16,000 one-triangle pieces (one point array each), against one piece holding the
//!   same 16,000 triangles and against one piece of the same file size;
//! - 12,500 … 50,000 point arrays of one triangle (three values each), against one array in
//!   one piece of the same file size.
//!
//! Every file is ASCII (`format="ascii"`, whitespace-separated numbers), the reference too: a
//! single piece whose points, connectivity, offsets, types and one point array are long ASCII
//! arrays, sized to match the many-piece (many-array) file. "ratio" is the time of the
//! many-piece (many-array) file over that of the reference scaled to the same size: linear
//! reading keeps it flat as the count grows, and the issue asks for at most 2.
//!
//! Two times are taken for `read_vtu`, each the best of `FOSLS_SCALING_RUNS` (default 5) runs
//! in each of `FOSLS_SCALING_ROUNDS` (default 3) rounds over all files (the rounds interleave
//! the files, so a burst of load on the shared machine does not hit one file only): the wall
//! time in rayon's default pool, and the CPU time of the process (all threads) in a one-thread
//! pool, where it is the work done and does not count the wait for a core or rayon's idle
//! spinning. PASS/FAIL is decided on the CPU ratio. `FOSLS_SCALING_CASE=pieces` or `arrays`
//! runs one half.

use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

use fosls::{mesh, read};

const HEAD: &str = "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"0.1\" \
                    byte_order=\"LittleEndian\">\n<UnstructuredGrid>\n";

/// One piece of `tris` disjoint triangles starting at x = `x0`, with `arrays` scalar point
/// arrays.
fn piece(out: &mut String, x0: f64, tris: usize, arrays: usize) {
    let _ = write!(
        out,
        "<Piece NumberOfPoints=\"{}\" NumberOfCells=\"{tris}\"><Points><DataArray \
         type=\"Float64\" NumberOfComponents=\"3\" format=\"ascii\">",
        3 * tris
    );
    for t in 0..tris {
        let x = x0 + 2.0 * t as f64;
        let _ = write!(out, "{x} 0 0 {} 0 0 {x} 1 0 ", x + 1.0);
    }
    out.push_str("</DataArray></Points><Cells><DataArray type=\"Int32\" Name=\"connectivity\" format=\"ascii\">");
    for k in 0..3 * tris {
        let _ = write!(out, "{k} ");
    }
    out.push_str("</DataArray><DataArray type=\"Int32\" Name=\"offsets\" format=\"ascii\">");
    for t in 0..tris {
        let _ = write!(out, "{} ", 3 * (t + 1));
    }
    out.push_str("</DataArray><DataArray type=\"UInt8\" Name=\"types\" format=\"ascii\">");
    for _ in 0..tris {
        out.push_str("5 ");
    }
    out.push_str("</DataArray></Cells><PointData>");
    for a in 0..arrays {
        let _ = write!(
            out,
            "<DataArray type=\"Float64\" Name=\"a{a}\" format=\"ascii\">"
        );
        for k in 0..3 * tris {
            let _ = write!(out, "{} ", (k % 7) + 1);
        }
        out.push_str("</DataArray>\n");
    }
    out.push_str("</PointData></Piece>\n");
}

/// A file of `pieces` pieces of `tris` triangles with `arrays` arrays each.
fn file(pieces: usize, tris: usize, arrays: usize) -> String {
    let mut s = String::from(HEAD);
    for p in 0..pieces {
        piece(&mut s, 2.0 * (p * tris) as f64, tris, arrays);
    }
    s.push_str("</UnstructuredGrid></VTKFile>\n");
    s
}

/// CPU time of the whole process so far, all threads
/// (`clock_gettime(CLOCK_PROCESS_CPUTIME_ID)`).
fn cpu() -> f64 {
    #[repr(C)]
    struct Timespec {
        sec: i64,
        nsec: i64,
    }
    unsafe extern "C" {
        fn clock_gettime(clock: i32, ts: *mut Timespec) -> i32;
    }
    const CLOCK_PROCESS_CPUTIME_ID: i32 = 2;
    let mut ts = Timespec { sec: 0, nsec: 0 };
    // SAFETY: `ts` is a valid, writable timespec (two 64-bit fields on x86_64/aarch64 Linux).
    if unsafe { clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &mut ts) } != 0 {
        return f64::NAN;
    }
    ts.sec as f64 + ts.nsec as f64 * 1e-9
}

fn env_count(key: &str, default: usize) -> usize {
    std::env::var(key)
        .ok()
        .and_then(|v| v.parse().ok())
        .filter(|&n| n > 0)
        .unwrap_or(default)
}

/// Best times of one file so far: read wall (default pool), read CPU (one-thread pool), mesh
/// wall.
#[derive(Clone, Copy)]
struct Best {
    wall: f64,
    cpu: f64,
    mesh: f64,
}

/// `runs` reads of `path`, improving `best`.
fn time(path: &Path, runs: usize, one_thread: &rayon::ThreadPool, best: &mut Best) {
    for _ in 0..runs {
        let t0 = Instant::now();
        let vtu = read::vtu::read_vtu(path).unwrap();
        let wall = t0.elapsed().as_secs_f64();
        let t1 = Instant::now();
        let data = mesh::build(vtu).unwrap();
        let m = t1.elapsed().as_secs_f64();
        std::hint::black_box(&data);
        drop(data);
        let c0 = cpu();
        let vtu = one_thread.install(|| read::vtu::read_vtu(path).unwrap());
        let c = cpu() - c0;
        std::hint::black_box(&vtu);
        best.wall = best.wall.min(wall);
        best.cpu = best.cpu.min(c);
        best.mesh = best.mesh.min(m);
    }
}

/// Triangles of a one-piece, one-array file of about `bytes` bytes.
fn tris_for(bytes: usize) -> usize {
    let one = file(1, 1000, 1).len();
    (bytes * 1000).div_ceil(one).max(1)
}

struct Case {
    label: String,
    text: String,
    /// Index of the reference case this one is compared with.
    reference: Option<usize>,
    best: Best,
}

fn main() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("f.vtu");
    let runs = env_count("FOSLS_SCALING_RUNS", 5);
    let rounds = env_count("FOSLS_SCALING_ROUNDS", 3);
    let which = std::env::var("FOSLS_SCALING_CASE").unwrap_or_default();
    let one_thread = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let mut cases: Vec<Case> = Vec::new();
    let mut add = |label: String, text: String, reference: Option<usize>| {
        cases.push(Case {
            label,
            text,
            reference,
            best: Best {
                wall: f64::INFINITY,
                cpu: f64::INFINITY,
                mesh: f64::INFINITY,
            },
        });
    };
    let mut k = 0;
    if which.is_empty() || which == "pieces" {
        let big = file(16_000, 1, 1);
        add(
            "one piece, same size as 16,000 pieces".into(),
            file(1, tris_for(big.len()), 1),
            None,
        );
        drop(big);
        add(
            "one piece, the same 16,000 triangles".into(),
            file(1, 16_000, 1),
            None,
        );
        let reference = k;
        k += 2;
        for n in [2_000, 4_000, 8_000, 16_000] {
            add(
                format!("{n} one-triangle pieces"),
                file(n, 1, 1),
                Some(reference),
            );
            k += 1;
        }
    }
    if which.is_empty() || which == "arrays" {
        let many = file(1, 1, 50_000);
        add(
            "one array, same size as 50,000 arrays".into(),
            file(1, tris_for(many.len()), 1),
            None,
        );
        drop(many);
        let reference = k;
        for n in [12_500, 25_000, 50_000] {
            add(format!("{n} point arrays"), file(1, 1, n), Some(reference));
        }
    }
    println!(
        "read_vtu (wall: default pool; cpu: one-thread pool) and mesh::build, best of {runs} \
         runs in each of {rounds} rounds (release build recommended)\n"
    );
    for _ in 0..rounds {
        for c in cases.iter_mut() {
            std::fs::write(&path, &c.text).unwrap();
            time(&path, runs, &one_thread, &mut c.best);
        }
    }
    let mut all_pass = true;
    for (i, c) in cases.iter().enumerate() {
        if i > 0 && c.label.starts_with("one array") {
            println!();
        }
        let mb = c.text.len() as f64 / 1e6;
        let b = c.best;
        let ratios = c.reference.map(|r| {
            let reference = &cases[r];
            // The reference scaled to this file's size.
            let scale = c.text.len() as f64 / reference.text.len() as f64;
            (
                b.wall / (reference.best.wall * scale),
                b.cpu / (reference.best.cpu * scale),
            )
        });
        let verdict = match ratios {
            Some((_, cpu)) if cpu <= 2.0 => "PASS",
            Some(_) => {
                all_pass = false;
                "FAIL"
            }
            None => "",
        };
        let ratio = ratios.map_or(String::from("       -        -"), |(w, c)| {
            format!("wall {w:>4.2} cpu {c:>4.2}")
        });
        println!(
            "{:<38} {mb:>6.2} MB  read wall {:>6.1} ms cpu {:>6.1} ms ({:>5.1} MB/s cpu)  mesh \
             {:>6.1} ms  ratio {ratio} {verdict}",
            c.label,
            b.wall * 1e3,
            b.cpu * 1e3,
            mb / b.cpu,
            b.mesh * 1e3,
        );
    }
    println!(
        "\n{} (CPU-time ratio against the reference of the same size, at most 2)",
        if all_pass { "PASS" } else { "FAIL" }
    );
}
