//! Patch reconstruction and bound benchmark (a program, not a timed test):
//!
//! ```text
//! cargo bench --bench patch                                  # 10k, 100k, 1M; P1 and P2; 1 and 2 threads
//! cargo bench --bench patch -- 10000 100000                  # chosen sizes
//! cargo bench --bench patch -- 1000000 --degree 2 --threads 2
//! cargo bench --bench patch -- 100000 --reps 3               # best of 3 (default: 2 below 1M, 1 from 1M)
//! ```
//!
//! Builds a structured triangle mesh of the rectangle [0, 2] × [0, 1] in memory (2n × n squares
//! cut along a diagonal, 4n² triangles, n = round(√(cells/4)); P1 or P2) with the nodal
//! interpolant of a smooth displacement, and times the stages of
//! `fosls estimate --stress patch` after reading, in-process, as `audit::run` chains them:
//!
//! * setup: `mesh::build`, `topology::build`, `select_fields`, `classify`, `Context::new`
//!   and the nodal admissibility check of u (`projection::nodal_violations`);
//! * patch: `reconstruct::patch::reconstruct` (order `patch::default_order`: RT_2, on P1 with
//!   the weak symmetry of the rotation shares);
//! * sweep: `reconstruct::sweep::sweep`, `sweep::DEFAULT_SWEEPS` improvement sweeps (set
//!   `FOSLS_BENCH_SWEEPS` to change the count);
//! * F: `estimate::interior` + `estimate::boundary` at (u_h, σ_h);
//! * bound: `estimate::bound::bound` (with the per-cell symmetric correction);
//!
//! "whole" is their sum, i.e. `fosls estimate` without reading a file and writing the report.
//! F + bound is exactly `estimate::run`, which is split here only to time the bound alone.
//!
//! Scene: E = 20600, ν = 0.28, plane strain, body force (0, −1); top y = 1 Dirichlet
//! (u_D = u); bottom y = 0 frictionless contact, `gap = 1e-5 + 2e-4 (x − 1)²` along the body
//! normal; sides x = 0, x = 2 Neumann with traction (0, 0). u = (1e-3 sin(xy),
//! −1e-2 y (1 − 0.3 x) + 1e-4 (x − 1)²) (no penetration, so the projection stage never runs).
//! u is not a Galerkin solution, so the flows rebalance the patch loads (`balanced`).
//!
//! Each (size, degree, threads) runs in a fresh child process (this binary re-executed with
//! `FOSLS_PATCH_CASE`) with a rayon pool of that many threads, so that the peak memory
//! (VmHWM, whole process, mesh included) is its own.

use std::path::Path;
use std::process::Command;
use std::time::Instant;

use fosls::estimate::{self, StressField, Terms};
use fosls::read::vtu::VtuFile;
use fosls::reconstruct::{patch, projection, sweep};
use fosls::{mesh, problem, topology};
use serde_json::{Value, json};

mod common;

use common::{grid, list, scene, status_mib, with_displacement};

const CASE_ENV: &str = "FOSLS_PATCH_CASE";

/// 2n × n squares of [0, 2] × [0, 1], each cut along (a, c): 4n² triangles of degree 1 or 2.
fn rectangle(cells: usize, degree: usize) -> VtuFile {
    let n = ((cells / 4) as f64).sqrt().round().max(1.0) as usize;
    let (mx, my) = (degree * 2 * n + 1, degree * n + 1);
    let pts = grid(mx, my);
    let id = |i: usize, j: usize| (j * mx + i) as u32;
    let mut c = Vec::with_capacity(4 * n * n);
    for j in 0..n {
        for i in 0..2 * n {
            if degree == 1 {
                let (a, b, cc, d) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
                c.push((5u8, vec![a, b, cc]));
                c.push((5u8, vec![a, cc, d]));
            } else {
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
    }
    with_displacement(pts, &c)
}

/// CPU time of the whole process, all threads (`CLOCK_PROCESS_CPUTIME_ID`), as in
/// `benches/estimate.rs`: it does not grow while the process waits for a core.
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

fn loadavg() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .unwrap_or_default()
        .split_whitespace()
        .take(3)
        .collect::<Vec<_>>()
        .join(" ")
}

/// One case in this process (spec "cells,degree,threads,reps"); prints one JSON line.
fn child(spec: &str) {
    let parts: Vec<usize> = spec.split(',').map(|p| p.parse().unwrap()).collect();
    let (cells, degree, threads, reps) = (parts[0], parts[1], parts[2], parts[3].max(1));
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build_global()
        .unwrap();
    let scene = scene();
    let file = rectangle(cells, degree);
    // [setup, patch, sweep, F, bound] wall and CPU, best over the repetitions (each stage its
    // own best).
    let mut best = [f64::INFINITY; 5];
    let mut best_cpu = [f64::INFINITY; 5];
    let sweeps = std::env::var("FOSLS_BENCH_SWEEPS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(sweep::DEFAULT_SWEEPS);
    let mut best_whole = f64::INFINITY;
    let mut out = json!({});
    for _ in 0..reps {
        let file = file.clone();
        let mut wall = [0.0; 5];
        let mut cpus = [0.0; 5];
        let (t0, c0) = (Instant::now(), cpu());
        let data = mesh::build(file).unwrap();
        let topo = topology::build(&data).unwrap();
        let fields = problem::select_fields(&data, &scene).unwrap();
        let bounds = problem::classify(&data, &topo, &scene).unwrap();
        let ctx = problem::Context::new(
            &data.mesh,
            &topo,
            &scene,
            &bounds.edges,
            scene.effective_norm(),
        );
        let u = fields.displacement.as_deref().expect("a displacement");
        let violations = projection::nodal_violations(&ctx, u);
        let (t1, c1) = (Instant::now(), cpu());
        let mut r = patch::reconstruct(&ctx, u, patch::default_order(data.mesh.degree)).unwrap();
        let (ts, cs) = (Instant::now(), cpu());
        let swept = sweep::sweep(&ctx, u, &mut r.stress, r.info.weak_symmetry, sweeps);
        let (t2, c2) = (Instant::now(), cpu());
        let sigma = StressField::Rt(&r.stress);
        // `estimate::run`, split at the bound.
        let interior = estimate::interior::interior(&ctx, u, sigma);
        let boundary = estimate::boundary::boundary(&ctx, u, sigma);
        let sum = |v: &[f64]| v.iter().sum::<f64>();
        let mut f = Terms {
            total: 0.0,
            constitutive: sum(&interior.constitutive),
            equilibrium: sum(&interior.equilibrium),
            complementarity: sum(&boundary.complementarity),
            friction: sum(&boundary.friction),
        };
        f.total = f.constitutive + f.equilibrium + f.complementarity + f.friction;
        let (t3, c3) = (Instant::now(), cpu());
        let b = estimate::bound::bound(&ctx, u, sigma, &f, &boundary.admissibility);
        let (t4, c4) = (Instant::now(), cpu());
        for (k, (a, z)) in [(t0, t1), (t1, ts), (ts, t2), (t2, t3), (t3, t4)]
            .into_iter()
            .enumerate()
        {
            wall[k] = (z - a).as_secs_f64();
        }
        for (k, (a, z)) in [(c0, c1), (c1, cs), (cs, c2), (c2, c3), (c3, c4)]
            .into_iter()
            .enumerate()
        {
            cpus[k] = z - a;
        }
        for k in 0..5 {
            best[k] = best[k].min(wall[k]);
            best_cpu[k] = best_cpu[k].min(cpus[k]);
        }
        best_whole = best_whole.min(wall.iter().sum());
        let i = &r.info;
        out = json!({
            "cells": data.mesh.cells.len(), "points": data.mesh.points.len(),
            "degree": degree, "threads": threads, "reps": reps,
            "order": patch::default_order(data.mesh.degree).k(),
            "patches": i.patches, "max_unknowns": i.max_unknowns, "active": i.active,
            "unsettled": i.unsettled, "incompatible": i.incompatible,
            "max_defect": i.max_defect, "weak_symmetry": i.weak_symmetry,
            "balanced": i.balanced, "nodal_violations": violations,
            "sweeps": swept.sweeps, "colours": swept.colours, "sweep_skipped": swept.skipped,
            "F": f.total, "guaranteed": b.guaranteed, "relative": b.relative,
            "energy_error": b.energy_error,
            "symmetrised_cells": b.terms.as_ref().map(|t| t.symmetrised_cells),
            "oscillation": b.terms.as_ref().map(|t| t.oscillation),
            "traction": b.terms.as_ref().map(|t| t.traction),
            "energy": b.energy,
            "failed": b.failed_hypotheses,
            "patch_stages": i.stages.iter().map(|(n, s)| json!([n, s])).collect::<Vec<_>>(),
        });
    }
    out["setup"] = json!(best[0]);
    out["patch"] = json!(best[1]);
    out["sweep"] = json!(best[2]);
    out["F_time"] = json!(best[3]);
    out["bound"] = json!(best[4]);
    out["whole"] = json!(best_whole);
    out["cpu"] = json!({"setup": best_cpu[0], "patch": best_cpu[1], "sweep": best_cpu[2],
                        "F": best_cpu[3], "bound": best_cpu[4]});
    out["peak_mib"] = json!(status_mib("VmHWM:"));
    out["loadavg"] = json!(loadavg());
    println!("{out}");
}

fn run_case(exe: &Path, spec: &str) -> Option<Value> {
    let out = Command::new(exe).env(CASE_ENV, spec).output().unwrap();
    if !out.status.success() {
        eprintln!("{spec}: {}", String::from_utf8_lossy(&out.stderr));
        return None;
    }
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .find(|l| l.starts_with('{'))
        .map(|l| serde_json::from_str(l).unwrap())
}

fn main() {
    if let Ok(spec) = std::env::var(CASE_ENV) {
        child(&spec);
        return;
    }
    let args: Vec<String> = std::env::args().skip(1).collect();
    // Positional sizes: numbers not following a flag.
    let mut sizes = Vec::new();
    for (k, a) in args.iter().enumerate() {
        if k > 0 && args[k - 1].starts_with("--") && args[k - 1] != "--bench" {
            continue;
        }
        if let Ok(n) = a.parse::<usize>() {
            sizes.push(n);
        }
    }
    if sizes.is_empty() {
        sizes = vec![10_000, 100_000, 1_000_000];
    }
    let degrees = list(&args, "--degree", &[1, 2]);
    let threads = list(&args, "--threads", &[2, 1]);
    let reps = list(&args, "--reps", &[0])[0];
    let exe = std::env::current_exe().unwrap();
    println!(
        "machine: {} logical CPUs (shared), load {}",
        std::thread::available_parallelism().map_or(0, |n| n.get()),
        loadavg()
    );
    let mut rows = Vec::new();
    for &n in &sizes {
        for &d in &degrees {
            for &t in &threads {
                let r = if reps > 0 {
                    reps
                } else if n >= 1_000_000 {
                    1
                } else {
                    2
                };
                let spec = format!("{n},{d},{t},{r}");
                eprintln!("case {spec} …");
                if let Some(v) = run_case(&exe, &spec) {
                    eprintln!("{v}");
                    rows.push(v);
                }
            }
        }
    }
    println!();
    println!(
        "| cells | degree | threads | patch reconstruction s | sweeps s | bound s | F s | whole \
         estimate s | peak MiB | patches | CPU µs/patch | CPU µs/patch/sweep | incompatible | \
         bound.relative |"
    );
    println!("|---:|:--|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|");
    for v in &rows {
        let patches = v["patches"].as_f64().unwrap_or(f64::NAN);
        println!(
            "| {} | P{} | {} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.0} | {} | {:.1} | {:.1} | {} | {} |",
            v["cells"],
            v["degree"],
            v["threads"],
            v["patch"].as_f64().unwrap_or(f64::NAN),
            v["sweep"].as_f64().unwrap_or(f64::NAN),
            v["bound"].as_f64().unwrap_or(f64::NAN),
            v["F_time"].as_f64().unwrap_or(f64::NAN),
            v["whole"].as_f64().unwrap_or(f64::NAN),
            v["peak_mib"].as_f64().unwrap_or(f64::NAN),
            v["patches"],
            1e6 * v["cpu"]["patch"].as_f64().unwrap_or(f64::NAN) / patches.max(1.0),
            1e6 * v["cpu"]["sweep"].as_f64().unwrap_or(f64::NAN)
                / (patches * v["sweeps"].as_f64().unwrap_or(f64::NAN)).max(1.0),
            v["incompatible"],
            v["relative"]
                .as_f64()
                .map_or("—".to_string(), |r| format!("{r:.3e}")),
        );
    }
    // Speed-up of 2 threads over 1 (patch + bound, wall), where both ran.
    for a in &rows {
        if a["threads"] != 2 {
            continue;
        }
        if let Some(b) = rows
            .iter()
            .find(|b| b["threads"] == 1 && b["cells"] == a["cells"] && b["degree"] == a["degree"])
        {
            let pb = |v: &Value| {
                v["patch"].as_f64().unwrap()
                    + v["sweep"].as_f64().unwrap()
                    + v["bound"].as_f64().unwrap()
            };
            println!(
                "speed-up 1 → 2 threads, {} cells P{}: patch {:.2}×, sweeps {:.2}×, bound {:.2}×, \
                 patch+sweeps+bound {:.2}×",
                a["cells"],
                a["degree"],
                b["patch"].as_f64().unwrap() / a["patch"].as_f64().unwrap(),
                b["sweep"].as_f64().unwrap() / a["sweep"].as_f64().unwrap(),
                b["bound"].as_f64().unwrap() / a["bound"].as_f64().unwrap(),
                pb(b) / pb(a)
            );
        }
    }
}
