//! Read benchmark (a program, not a timed test):
//!
//! ```text
//! cargo bench --bench read                          # P2 and Q2 files of 10k, 100k, 1M cells
//! cargo bench --bench read -- --sizes 1000000       # both families, chosen sizes
//! cargo bench --bench read -- FILE.vtu [FILE.vtu …] # given files
//! cargo bench --bench read -- --no-meshio …         # skip the meshio.read runs
//! ```
//!
//! Times each stage of reading a VTU file (bytes from disk, XML + decode, mesh build,
//! topology) over several runs, reports the best run and the peak resident memory against the
//! decoded data size, and times `meshio.read` on the same file in the same run when the
//! reference environment is present (`reference/.venv`), so that a ratio can be quoted.
//!
//! Each file is read in a fresh child process (this binary re-executed with
//! `FOSLS_READ_CASE=FILE`), so that the peak memory (VmHWM) is the file's own. The default
//! files are `bench-data/p2_tri_N.vtu` and `bench-data/q2_quad_N.vtu`
//! (`reference/encodings/make_bench.py [--family q2]`). At the end a table gives the times per
//! million points of the file and, for a Q2 and a P2 file of the same cell count, the ratio
//! Q2 / P2 of the time per point (issue 11: ≤ 1.3). `RAYON_NUM_THREADS` sets the threads. The
//! `cpu` line gives the CPU seconds of the same stages (all threads): on a shared machine the
//! figure to compare between versions at `RAYON_NUM_THREADS=1`.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use fosls::{mesh, read, topology};

const CASE_ENV: &str = "FOSLS_READ_CASE";

/// CPU time of the whole process so far, all threads, those that ended included
/// (`clock_gettime(CLOCK_PROCESS_CPUTIME_ID)`): unlike the wall time it does not grow while the
/// process waits for a core, so it is the figure to compare on a shared machine (at 1 thread it
/// equals the wall time of a quiet machine; at 2 threads it also counts rayon's idle spinning).
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

fn peak_rss_mib() -> f64 {
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    status
        .lines()
        .find(|l| l.starts_with("VmHWM:"))
        .and_then(|l| l.split_whitespace().nth(1))
        .and_then(|v| v.parse::<f64>().ok())
        .map_or(f64::NAN, |kib| kib / 1024.0)
}

/// Reads `file` `runs` times in this process, prints the stages and one JSON line.
fn case(file: &Path, runs: usize) {
    let mut best = [f64::INFINITY; 5];
    let mut best_cpu = [f64::INFINITY; 5];
    let mut decoded_bytes = 0usize;
    let mut cells = 0usize;
    let mut points = 0usize;
    let mut family = String::new();
    for _ in 0..runs {
        let t0 = Instant::now();
        let c0 = cpu();
        let bytes = std::fs::read(file).unwrap();
        let t1 = Instant::now();
        let c1 = cpu();
        let vtu = read::vtu::parse_vtu(file, &bytes).unwrap();
        let t2 = Instant::now();
        let c2 = cpu();
        drop(bytes);
        points = vtu.points.len();
        decoded_bytes = vtu.points.len() * 24
            + vtu.connectivity.len() * 4
            + vtu.offsets.len() * 8
            + vtu.types.len()
            + vtu
                .point_data
                .iter()
                .chain(&vtu.cell_data)
                .map(|a| a.values.len() * 8)
                .sum::<usize>();
        let t3 = Instant::now();
        let c3 = cpu();
        let data = mesh::build(vtu).unwrap();
        let t4 = Instant::now();
        let c4 = cpu();
        let topo = topology::build(&data).unwrap();
        let t5 = Instant::now();
        let c5 = cpu();
        cells = data.mesh.cells.len();
        family = data
            .mesh
            .families()
            .iter()
            .map(|f| f.name().split(' ').next().unwrap_or("?"))
            .collect::<Vec<_>>()
            .join("+");
        std::hint::black_box(&topo);
        let times = [
            (t1 - t0).as_secs_f64(),
            (t2 - t1).as_secs_f64(),
            (t4 - t3).as_secs_f64(),
            (t5 - t4).as_secs_f64(),
            (t2 - t0).as_secs_f64(),
        ];
        for (b, t) in best.iter_mut().zip(times) {
            *b = b.min(t);
        }
        let cpus = [c1 - c0, c2 - c1, c4 - c3, c5 - c4, c2 - c0];
        for (b, t) in best_cpu.iter_mut().zip(cpus) {
            *b = b.min(t);
        }
    }
    let peak = peak_rss_mib();
    let size = std::fs::metadata(file).unwrap().len() as f64 / (1 << 20) as f64;
    let mpts = points as f64 / 1e6;
    println!(
        "file            {} ({size:.1} MiB, {cells} {family} cells, {points} points)",
        file.display()
    );
    println!("threads         {}", rayon::current_num_threads());
    println!("read bytes      {:.3} s", best[0]);
    println!("parse + decode  {:.3} s", best[1]);
    println!(
        "read total      {:.3} s  (file → arrays, what meshio.read does)",
        best[4]
    );
    println!("mesh build      {:.3} s", best[2]);
    println!("topology        {:.3} s", best[3]);
    println!(
        "cpu             read {:.3} s, mesh build {:.3} s, topology {:.3} s  (all threads)",
        best_cpu[4], best_cpu[2], best_cpu[3]
    );
    let all = best[4] + best[2] + best[3];
    println!(
        "per Mpoint      read {:.3} s, mesh + topology {:.3} s, all {:.3} s",
        best[4] / mpts,
        (best[2] + best[3]) / mpts,
        all / mpts
    );
    let decoded = decoded_bytes as f64 / (1 << 20) as f64;
    println!(
        "peak memory     {peak:.0} MiB = {:.2} × decoded data ({decoded:.0} MiB)",
        peak / decoded
    );
    println!(
        "{}",
        serde_json::json!({
            "file": file.display().to_string(),
            "family": family,
            "cells": cells,
            "points": points,
            "size_mib": size,
            "threads": rayon::current_num_threads(),
            "read_bytes": best[0],
            "parse_decode": best[1],
            "read": best[4],
            "mesh": best[2],
            "topology": best[3],
            "cpu_read": best_cpu[4],
            "cpu_mesh": best_cpu[2],
            "cpu_topology": best_cpu[3],
            "peak_mib": peak,
            "decoded_mib": decoded,
        })
    );
}

fn meshio_seconds(root: &Path, file: &Path) -> Option<f64> {
    let python = root.join("reference/.venv/bin/python");
    let script = root.join("reference/encodings/time_meshio.py");
    if !python.exists() || !script.exists() {
        return None;
    }
    let out = Command::new(&python)
        .arg(&script)
        .arg(file)
        .output()
        .unwrap();
    let line = String::from_utf8_lossy(&out.stdout);
    println!("meshio.read     {}", line.trim());
    serde_json::from_str::<serde_json::Value>(line.trim())
        .ok()
        .and_then(|v| v["seconds_best"].as_f64())
}

fn main() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let runs = 3;
    if let Ok(file) = std::env::var(CASE_ENV) {
        case(Path::new(&file), runs);
        return;
    }
    let args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| a != "--bench")
        .collect();
    let mut files: Vec<PathBuf> = Vec::new();
    let mut sizes: Vec<usize> = Vec::new();
    let mut meshio = true;
    let mut it = args.iter();
    while let Some(a) = it.next() {
        match a.as_str() {
            "--no-meshio" => meshio = false,
            "--sizes" => {
                let list = it.next().expect("--sizes N,N,…");
                sizes.extend(list.split(',').map(|s| s.trim().parse::<usize>().unwrap()));
            }
            _ => files.push(PathBuf::from(a)),
        }
    }
    if files.is_empty() && sizes.is_empty() {
        sizes = vec![10_000, 100_000, 1_000_000];
    }
    for n in &sizes {
        files.push(root.join(format!("bench-data/p2_tri_{n}.vtu")));
        files.push(root.join(format!("bench-data/q2_quad_{n}.vtu")));
    }
    let missing: Vec<&PathBuf> = files.iter().filter(|f| !f.exists()).collect();
    if !missing.is_empty() {
        eprintln!("missing benchmark files; generate them with");
        for f in missing {
            let name = f.file_name().unwrap().to_string_lossy();
            let family = if name.starts_with("q2") {
                "--family q2 "
            } else {
                ""
            };
            let n: String = name
                .chars()
                .filter(|c| c.is_ascii_digit())
                .skip(1)
                .collect();
            eprintln!(
                "  reference/.venv/bin/python reference/encodings/make_bench.py {family}--cells {n} --out {}",
                f.display()
            );
        }
        std::process::exit(2);
    }
    let exe = std::env::current_exe().unwrap();
    let mut rows: Vec<(serde_json::Value, Option<f64>)> = Vec::new();
    for file in &files {
        let out = Command::new(&exe).env(CASE_ENV, file).output().unwrap();
        let text = String::from_utf8_lossy(&out.stdout);
        if !out.status.success() {
            eprintln!(
                "{}: {}",
                file.display(),
                String::from_utf8_lossy(&out.stderr)
            );
            std::process::exit(1);
        }
        let mut json = serde_json::Value::Null;
        for line in text.lines() {
            if line.starts_with('{') {
                json = serde_json::from_str(line).unwrap();
            } else {
                println!("{line}");
            }
        }
        let m = if meshio {
            meshio_seconds(root, file)
        } else {
            None
        };
        if let Some(t) = m {
            println!(
                "ratio           meshio / fosls read = {:.1}×",
                t / json["read"].as_f64().unwrap()
            );
        }
        println!();
        rows.push((json, m));
    }
    let f = |v: &serde_json::Value, k: &str| v[k].as_f64().unwrap_or(f64::NAN);
    let per_point = |v: &serde_json::Value| {
        (f(v, "read") + f(v, "mesh") + f(v, "topology")) / (f(v, "points") / 1e6)
    };
    println!(
        "| family | cells | points | file MiB | threads | read s | mesh s | topology s | peak MiB | s / Mpoint (read) | s / Mpoint (read+mesh+topology) | Q2/P2 per point | meshio.read s | meshio / fosls read |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    for (v, m) in &rows {
        let pts = f(v, "points") / 1e6;
        let ratio = (v["family"] == "Q2")
            .then(|| {
                rows.iter().find(|(w, _)| {
                    w["family"] == "P2" && w["cells"] == v["cells"] && w["threads"] == v["threads"]
                })
            })
            .flatten()
            .map_or("—".to_string(), |(w, _)| {
                format!("{:.2}", per_point(v) / per_point(w))
            });
        println!(
            "| {} | {} | {} | {:.1} | {} | {:.3} | {:.3} | {:.3} | {:.0} | {:.3} | {:.3} | {ratio} | {} | {} |",
            v["family"].as_str().unwrap_or("?"),
            v["cells"],
            v["points"],
            f(v, "size_mib"),
            v["threads"],
            f(v, "read"),
            f(v, "mesh"),
            f(v, "topology"),
            f(v, "peak_mib"),
            f(v, "read") / pts,
            per_point(v),
            m.map_or("—".into(), |t| format!("{t:.3}")),
            m.map_or("—".into(), |t| format!("{:.1}×", t / f(v, "read"))),
        );
    }
}
