//! Evaluation benchmark (a program, not a timed test):
//!
//! ```text
//! cargo bench --bench estimate                     # 10k, 100k, 1M: P2 and Q2 in memory, and the files
//! cargo bench --bench estimate -- 100000 1000000   # chosen sizes
//! cargo bench --bench estimate -- --no-files       # in-memory meshes only
//! cargo bench --bench estimate -- --family p2      # one family only (p2 or q2)
//! ```
//!
//! Builds structured meshes of the unit square in memory: P2 (n × n squares cut along a
//! diagonal, 2n² triangles, n = round(√(cells/2))) and Q2 (n × n biquadratic quadrilaterals,
//! n = round(√cells)), smooth displacement and nodal stress fields, a contact boundary on
//! y = 0 and a Dirichlet top, and times each stage of `fosls estimate` after reading: mesh
//! build, topology, field setup, and the evaluation of F (interior and boundary terms), with
//! the rayon pool at 1 and 2 threads. "evaluate" is `problem::Context::new` (its length scale
//! ℓ = diam(Ω)/π, which `estimate::run` computed itself before the Context) plus
//! `estimate::run`; the Context alone is printed as "context".
//!
//! Then the same scene on the files of the read benchmark, `bench-data/p2_tri_N.vtu` and
//! `bench-data/q2_quad_N.vtu` (`reference/encodings/make_bench.py [--family q2]`), when they
//! exist: read (bytes + parse), mesh, topology, fields, evaluate — the whole of
//! `fosls estimate` but the report.
//!
//! Each (mesh, size) runs in a fresh child process (this binary re-executed with
//! `FOSLS_ESTIMATE_CASE`), so that the peak memory (VmHWM) is its own. The closing tables give
//! the times per million points and, for Q2 against P2 of the same size and threads, the
//! ratio of the time per point (issue 11: ≤ 1.3).

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use fosls::estimate;
use fosls::read::scene::{Scene, parse_scene};
use fosls::read::vtu::VtuFile;
use fosls::{mesh, problem, read, topology};

const CASE_ENV: &str = "FOSLS_ESTIMATE_CASE";

/// n × n squares, each split in two: 2n² P2 triangles.
fn square(cells: usize) -> VtuFile {
    let n = ((cells / 2) as f64).sqrt().round() as usize;
    let m = 2 * n + 1;
    let id = |i: usize, j: usize| (j * m + i) as u32;
    let mut c = Vec::with_capacity(2 * n * n + 4 * n);
    for j in 0..n {
        for i in 0..n {
            let (i2, j2) = (2 * i, 2 * j);
            let (a, b, cc, d) = (
                id(i2, j2),
                id(i2 + 2, j2),
                id(i2 + 2, j2 + 2),
                id(i2, j2 + 2),
            );
            let e = id(i2 + 1, j2 + 1);
            c.push((22u8, vec![a, b, cc, id(i2 + 1, j2), id(i2 + 2, j2 + 1), e]));
            c.push((22u8, vec![a, cc, d, e, id(i2 + 1, j2 + 2), id(i2, j2 + 1)]));
        }
    }
    with_fields(lattice(m), &c)
}

/// n × n squares, one Q2 (VTK_BIQUADRATIC_QUAD) cell each: corners, edge mids 0-1, 1-2, 2-3,
/// 3-0, centre.
fn square_q2(cells: usize) -> VtuFile {
    let n = (cells as f64).sqrt().round() as usize;
    let m = 2 * n + 1;
    let id = |i: usize, j: usize| (j * m + i) as u32;
    let mut c = Vec::with_capacity(n * n);
    for j in 0..n {
        for i in 0..n {
            let (i2, j2) = (2 * i, 2 * j);
            c.push((
                28u8,
                vec![
                    id(i2, j2),
                    id(i2 + 2, j2),
                    id(i2 + 2, j2 + 2),
                    id(i2, j2 + 2),
                    id(i2 + 1, j2),
                    id(i2 + 2, j2 + 1),
                    id(i2 + 1, j2 + 2),
                    id(i2, j2 + 1),
                    id(i2 + 1, j2 + 1),
                ],
            ));
        }
    }
    with_fields(lattice(m), &c)
}

/// The m × m lattice of the unit square, row by row.
fn lattice(m: usize) -> Vec<[f64; 3]> {
    let mut pts = Vec::with_capacity(m * m);
    for j in 0..m {
        for i in 0..m {
            pts.push([i as f64 / (m - 1) as f64, j as f64 / (m - 1) as f64, 0.0]);
        }
    }
    pts
}

fn with_fields(pts: Vec<[f64; 3]>, c: &[(u8, Vec<u32>)]) -> VtuFile {
    let mut f = VtuFile::from_cells(Path::new("bench.vtu"), pts, c);
    let mut u = Vec::new();
    let mut s = Vec::new();
    for p in &f.points {
        let (x, y) = (p[0], p[1]);
        u.extend_from_slice(&[1e-3 * (x * y).sin(), -1e-2 * y + 1e-3 * x * x]);
        s.extend_from_slice(&[-10.0 * y + x, -100.0 + 5.0 * x * y, 0.0, 2.0 * x - y]);
    }
    for (name, comps, values) in [("displacement", 2, u), ("stress", 4, s)] {
        f.point_data.push(fosls::read::vtu::DataArray {
            name: name.into(),
            scalar: fosls::read::decode::Scalar::Float64,
            components: comps,
            component_names: vec![],
            values,
        });
    }
    f
}

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
    std::fs::read_to_string("/proc/self/status")
        .unwrap_or_default()
        .lines()
        .find(|l| l.starts_with("VmHWM:"))
        .and_then(|l| l.split_whitespace().nth(1))
        .and_then(|v| v.parse::<f64>().ok())
        .map_or(f64::NAN, |kib| kib / 1024.0)
}

fn scene() -> Scene {
    parse_scene(
        Path::new("bench.toml"),
        "[material]\nyoungs_modulus = 20600.0\npoisson_ratio = 0.28\n\
         [[boundary]]\nname = \"top\"\nwhere = \"y > 0.999999\"\nkind = \"dirichlet\"\n\
         displacement = [0.0, -0.01]\n\
         [[boundary]]\nname = \"bottom\"\nwhere = \"y < 1e-9\"\nkind = \"contact\"\n\
         obstacle = { plane = { point = [0.0, 0.0], normal = [0.0, 1.0] } }\n\
         normal = \"obstacle\"\nfriction = 0.4\n",
    )
    .unwrap()
}

/// Where the VtuFile of a case comes from.
enum Source {
    /// Built in memory (cloned per run: the clone is inside the "mesh" time, as before).
    Memory(Box<VtuFile>),
    /// Read from disk per run (bytes + parse: the "read" time).
    File(PathBuf),
}

/// One case (a mesh) at 1 and 2 threads, best of 3 each: one JSON line per thread count.
fn case(spec: &str) {
    let scene = scene();
    let parts: Vec<&str> = spec.splitn(3, ',').collect();
    let (kind, family, arg) = (parts[0], parts[1], parts[2]);
    let source = match kind {
        "mem" => {
            let n: usize = arg.parse().unwrap();
            Source::Memory(Box::new(if family == "q2" {
                square_q2(n)
            } else {
                square(n)
            }))
        }
        _ => Source::File(PathBuf::from(arg)),
    };
    for threads in [1, 2] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let mut best = [f64::INFINITY; 6];
        let mut best_cpu = [f64::INFINITY; 6];
        let mut cells = 0;
        let mut points = 0;
        let mut total = 0.0;
        for _ in 0..3 {
            pool.install(|| {
                let t0 = Instant::now();
                let c0 = cpu();
                let (file, (tm, cm)) = match &source {
                    Source::Memory(f) => ((**f).clone(), (t0, c0)),
                    Source::File(p) => {
                        let bytes = std::fs::read(p).unwrap();
                        let f = read::vtu::parse_vtu(p, &bytes).unwrap();
                        (f, (Instant::now(), cpu()))
                    }
                };
                points = file.points.len();
                let data = mesh::build(file).unwrap();
                let t1 = Instant::now();
                let c1 = cpu();
                let topo = topology::build(&data).unwrap();
                let t2 = Instant::now();
                let c2 = cpu();
                let fields = problem::select_fields(&data, &scene).unwrap();
                let bounds = problem::classify(&data, &topo, &scene).unwrap();
                let problem::Stress::Nodal { values, .. } = &fields.stress else {
                    panic!("no nodal stress");
                };
                let t3 = Instant::now();
                let c3 = cpu();
                let ctx = problem::Context::new(
                    &data.mesh,
                    &topo,
                    &scene,
                    &bounds.edges,
                    scene.effective_norm(),
                );
                let tc = Instant::now();
                let cc = cpu();
                let est = estimate::run(
                    &ctx,
                    fields.displacement.as_deref().expect("a displacement"),
                    estimate::StressField::Nodal(values),
                );
                let t4 = Instant::now();
                let c4 = cpu();
                cells = data.mesh.cells.len();
                total = est.functional.total;
                let times = [tm - t0, t1 - tm, t2 - t1, t3 - t2, t4 - t3, tc - t3];
                for (b, t) in best.iter_mut().zip(times) {
                    *b = b.min(t.as_secs_f64());
                }
                let cpus = [cm - c0, c1 - cm, c2 - c1, c3 - c2, c4 - c3, cc - c3];
                for (b, t) in best_cpu.iter_mut().zip(cpus) {
                    *b = b.min(t);
                }
            });
        }
        println!(
            "{}",
            serde_json::json!({
                "kind": kind, "family": family.to_uppercase(), "size": arg,
                "cells": cells, "points": points, "threads": threads,
                "read": best[0], "mesh": best[1], "topology": best[2],
                "fields": best[3], "evaluate": best[4], "context": best[5], "F": total,
                "cpu": {"read": best_cpu[0], "mesh": best_cpu[1], "topology": best_cpu[2],
                        "fields": best_cpu[3], "evaluate": best_cpu[4], "context": best_cpu[5]},
                "peak_mib": peak_rss_mib(),
            })
        );
    }
}

fn run_case(exe: &Path, spec: &str) -> Vec<serde_json::Value> {
    let out = Command::new(exe).env(CASE_ENV, spec).output().unwrap();
    if !out.status.success() {
        eprintln!("{spec}: {}", String::from_utf8_lossy(&out.stderr));
        std::process::exit(1);
    }
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .filter(|l| l.starts_with('{'))
        .map(|l| serde_json::from_str(l).unwrap())
        .collect()
}

fn main() {
    if let Ok(spec) = std::env::var(CASE_ENV) {
        case(&spec);
        return;
    }
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut sizes: Vec<usize> = args.iter().filter_map(|a| a.parse().ok()).collect();
    if sizes.is_empty() {
        sizes = vec![10_000, 100_000, 1_000_000];
    }
    let files = !args.iter().any(|a| a == "--no-files");
    let families: Vec<&str> = match args.iter().position(|a| a == "--family") {
        Some(i) => vec![args[i + 1].as_str()],
        None => vec!["p2", "q2"],
    };
    let exe = std::env::current_exe().unwrap();
    let mut rows: Vec<serde_json::Value> = Vec::new();
    println!(
        "source  family  cells      points     threads  read    mesh    topology  fields  evaluate (context)  peak MiB  (best of 3, seconds)"
    );
    let mut specs = Vec::new();
    for &n in &sizes {
        for fam in &families {
            specs.push(format!("mem,{fam},{n}"));
        }
    }
    if files {
        for &n in &sizes {
            for fam in &families {
                let name = if *fam == "q2" { "q2_quad" } else { "p2_tri" };
                let path = root.join(format!("bench-data/{name}_{n}.vtu"));
                if path.exists() {
                    specs.push(format!("file,{fam},{}", path.display()));
                } else {
                    eprintln!("skipping {} (missing)", path.display());
                }
            }
        }
    }
    for spec in &specs {
        for v in run_case(&exe, spec) {
            let f = |k: &str| v[k].as_f64().unwrap_or(f64::NAN);
            println!(
                "{:<6}  {:<6}  {:>9}  {:>9}  {:>7}  {:.3}   {:.3}   {:.3}     {:.3}   {:.3} ({:.3})   {:>6.0}    F = {:.6e}",
                v["kind"].as_str().unwrap(),
                v["family"].as_str().unwrap(),
                v["cells"],
                v["points"],
                v["threads"],
                f("read"),
                f("mesh"),
                f("topology"),
                f("fields"),
                f("evaluate"),
                f("context"),
                f("peak_mib"),
                f("F"),
            );
            let c = |k: &str| v["cpu"][k].as_f64().unwrap_or(f64::NAN);
            println!(
                "        cpu s (all threads): read {:.3}  mesh {:.3}  topology {:.3}  fields {:.3}  evaluate {:.3} ({:.3})",
                c("read"),
                c("mesh"),
                c("topology"),
                c("fields"),
                c("evaluate"),
                c("context"),
            );
            rows.push(v);
        }
    }
    let f = |v: &serde_json::Value, k: &str| v[k].as_f64().unwrap_or(f64::NAN);
    let total = |v: &serde_json::Value| {
        f(v, "read") + f(v, "mesh") + f(v, "topology") + f(v, "fields") + f(v, "evaluate")
    };
    let mpts = |v: &serde_json::Value| f(v, "points") / 1e6;
    let partner = |v: &serde_json::Value| {
        rows.iter().find(|w| {
            w["family"] == "P2"
                && w["kind"] == v["kind"]
                && w["threads"] == v["threads"]
                && (w["size"] == v["size"] || w["cells"] == v["cells"])
        })
    };
    println!();
    println!(
        "| source | family | cells | points | threads | read s | mesh + topology s | fields s | evaluate s (context) | peak MiB | evaluate s / Mpoint | all s / Mpoint | Q2/P2 per point (evaluate) | Q2/P2 per point (all) |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    for v in &rows {
        let (re, ra) = match (v["family"] == "Q2").then(|| partner(v)).flatten() {
            Some(w) => (
                format!(
                    "{:.2}",
                    (f(v, "evaluate") / mpts(v)) / (f(w, "evaluate") / mpts(w))
                ),
                format!("{:.2}", (total(v) / mpts(v)) / (total(w) / mpts(w))),
            ),
            None => ("—".into(), "—".into()),
        };
        let read = if v["kind"] == "file" {
            format!("{:.3}", f(v, "read"))
        } else {
            "—".into()
        };
        println!(
            "| {} | {} | {} | {} | {} | {read} | {:.3} | {:.3} | {:.3} ({:.3}) | {:.0} | {:.3} | {:.3} | {re} | {ra} |",
            if v["kind"] == "file" {
                "file"
            } else {
                "memory"
            },
            v["family"].as_str().unwrap(),
            v["cells"],
            v["points"],
            v["threads"],
            f(v, "mesh") + f(v, "topology"),
            f(v, "fields"),
            f(v, "evaluate"),
            f(v, "context"),
            f(v, "peak_mib"),
            f(v, "evaluate") / mpts(v),
            total(v) / mpts(v),
        );
    }
}
