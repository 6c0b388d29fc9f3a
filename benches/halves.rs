//! The bound on quadrilaterals (docs/design.md §6.3) benchmark (a program, not a timed test):
//!
//! ```text
//! cargo bench --bench halves                       # 10k and 100k cells; Q1 and Q2; 2 threads
//! cargo bench --bench halves -- 1000000 --family 1 --threads 1,2
//! cargo bench --bench halves -- 10000 100000 --family 2 --distort   # no parallelograms
//! ```
//!
//! Builds n × 2n squares of [0, 2] × [0, 1] (Q1 or biquadratic Q2, n = round(√(cells/2))) with
//! the nodal interpolant of the patch bench's displacement and scene (`benches/patch.rs`), and
//! times `fosls estimate` (default `auto`) after reading, in-process, as `audit::run` chains
//! it on quadrilaterals:
//!
//! * setup: `mesh::build`, `topology::build`, `select_fields`, `classify`, `Context::new`;
//! * global: the global minimiser of F on the quadrilaterals (`reconstruct::stress`, RT_{p−1}),
//!   the stress F uses;
//! * F: `estimate::run` with it;
//! * halves: `audit::halves::on_halves`, the split, its patch equilibration and sweeps, the
//!   bound on the split and the split term.
//!
//! Each case runs in a fresh child process with a rayon pool of that many threads, so that the
//! peak memory (VmHWM, whole process) is its own.

use std::process::Command;
use std::time::Instant;

use fosls::element::rt::RtOrder;
use fosls::estimate::{self, StressField};
use fosls::read::vtu::VtuFile;
use fosls::reconstruct::{patch, stress, sweep};
use fosls::{audit, mesh, problem, topology};
use serde_json::{Value, json};

mod common;

use common::{grid, list, scene, status_mib, with_displacement};

const CASE_ENV: &str = "FOSLS_HALVES_CASE";

/// 2n × n squares of [0, 2] × [0, 1]: Q1 (VTK 9) or Q2 (VTK 28) cells. With `distort` the
/// interior vertices move by up to 0.2 h along a smooth field and the other Q2 nodes sit at the
/// straight midpoints and the vertex mean: straight-edged cells that are no parallelograms, on
/// which u_h is rational in x (the bound's costly case, design §6.3 "u_h itself").
fn rectangle(cells: usize, degree: usize, distort: bool) -> VtuFile {
    let n = ((cells / 2) as f64).sqrt().round().max(1.0) as usize;
    let (mx, my) = (degree * 2 * n + 1, degree * n + 1);
    let mut pts = grid(mx, my);
    if distort {
        let h = 1.0 / n as f64;
        let at = |i: usize, j: usize| j * mx + i;
        for j in (degree..my - 1).step_by(degree) {
            for i in (degree..mx - 1).step_by(degree) {
                let p = pts[at(i, j)];
                pts[at(i, j)][0] += 0.2 * h * (7.1 * p[0] + 3.3 * p[1]).sin();
                pts[at(i, j)][1] += 0.2 * h * (5.3 * p[0] - 2.9 * p[1]).cos();
            }
        }
        if degree == 2 {
            for j in 0..my {
                for i in 0..mx {
                    let (oi, oj) = (i % 2 == 1, j % 2 == 1);
                    let corners: Vec<usize> = match (oi, oj) {
                        (false, false) => continue,
                        (true, false) => vec![at(i - 1, j), at(i + 1, j)],
                        (false, true) => vec![at(i, j - 1), at(i, j + 1)],
                        (true, true) => vec![
                            at(i - 1, j - 1),
                            at(i + 1, j - 1),
                            at(i + 1, j + 1),
                            at(i - 1, j + 1),
                        ],
                    };
                    let k = corners.len() as f64;
                    let mean = corners.iter().fold([0.0; 2], |m, &c| {
                        [m[0] + pts[c][0] / k, m[1] + pts[c][1] / k]
                    });
                    pts[at(i, j)] = [mean[0], mean[1], 0.0];
                }
            }
        }
    }
    let id = |i: usize, j: usize| (j * mx + i) as u32;
    let mut c = Vec::with_capacity(2 * n * n);
    for j in 0..n {
        for i in 0..2 * n {
            if degree == 1 {
                c.push((
                    9u8,
                    vec![id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)],
                ));
            } else {
                let (a, b) = (2 * i, 2 * j);
                c.push((
                    28u8,
                    vec![
                        id(a, b),
                        id(a + 2, b),
                        id(a + 2, b + 2),
                        id(a, b + 2),
                        id(a + 1, b),
                        id(a + 2, b + 1),
                        id(a + 1, b + 2),
                        id(a, b + 1),
                        id(a + 1, b + 1),
                    ],
                ));
            }
        }
    }
    with_displacement(pts, &c)
}

fn child(spec: &str) {
    let parts: Vec<usize> = spec.split(',').map(|p| p.parse().unwrap()).collect();
    let (cells, degree, threads) = (parts[0], parts[1], parts[2]);
    let distort = parts.get(3) == Some(&1);
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build_global()
        .unwrap();
    let scene = scene();
    let file = rectangle(cells, degree, distort);
    let t0 = Instant::now();
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
    let t1 = Instant::now();
    let order = if degree == 1 {
        RtOrder::Rt0
    } else {
        RtOrder::Rt1
    };
    let global = stress::reconstruct(&ctx, u, order).unwrap();
    let t2 = Instant::now();
    let est = estimate::run(&ctx, u, StressField::Rt(&global.stress));
    let t3 = Instant::now();
    let b = audit::halves::on_halves(
        &ctx,
        &data,
        u,
        patch::default_order(data.mesh.degree),
        sweep::DEFAULT_SWEEPS,
    );
    let t4 = Instant::now();
    let s = |a: Instant, z: Instant| (z - a).as_secs_f64();
    let out = json!({
        "cells": data.mesh.cells.len(), "degree": degree, "threads": threads, "distort": distort,
        "setup": s(t0, t1), "global": s(t1, t2), "F_time": s(t2, t3), "halves": s(t3, t4),
        "whole": s(t0, t4), "peak_mib": status_mib("VmHWM:"),
        "eta": est.eta, "energy_error": b.energy_error, "relative": b.relative,
        "split_term": b.terms.as_ref().map(|t| t.halves),
        "guaranteed": b.guaranteed, "failed": b.failed_hypotheses,
    });
    println!("{out}");
}

fn main() {
    if let Ok(spec) = std::env::var(CASE_ENV) {
        child(&spec);
        return;
    }
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut sizes = Vec::new();
    for (k, a) in args.iter().enumerate() {
        if k > 0
            && args[k - 1].starts_with("--")
            && !["--bench", "--distort"].contains(&&*args[k - 1])
        {
            continue;
        }
        if let Ok(n) = a.parse::<usize>() {
            sizes.push(n);
        }
    }
    if sizes.is_empty() {
        sizes = vec![10_000, 100_000];
    }
    let families = list(&args, "--family", &[1, 2]);
    let threads = list(&args, "--threads", &[2]);
    let distort = args.iter().any(|a| a == "--distort");
    let exe = std::env::current_exe().unwrap();
    let mut rows: Vec<Value> = Vec::new();
    for &n in &sizes {
        for &d in &families {
            for &t in &threads {
                let spec = format!("{n},{d},{t},{}", u8::from(distort));
                eprintln!("case {spec} …");
                let out = Command::new(&exe).env(CASE_ENV, &spec).output().unwrap();
                if !out.status.success() {
                    eprintln!("{spec}: {}", String::from_utf8_lossy(&out.stderr));
                    continue;
                }
                if let Some(v) = String::from_utf8_lossy(&out.stdout)
                    .lines()
                    .find(|l| l.starts_with('{'))
                    .map(|l| serde_json::from_str::<Value>(l).unwrap())
                {
                    eprintln!("{v}");
                    rows.push(v);
                }
            }
        }
    }
    println!(
        "| cells | family | threads | setup s | global minimiser s | F s | bound on the halves s \
         | whole s | peak MiB | bound.relative | split term |"
    );
    println!("|---:|:--|--:|--:|--:|--:|--:|--:|--:|--:|--:|");
    for v in &rows {
        let f = |k: &str| v[k].as_f64().unwrap_or(f64::NAN);
        println!(
            "| {} | Q{} | {} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.0} | {:.3e} | {:.2e} |",
            v["cells"],
            v["degree"],
            v["threads"],
            f("setup"),
            f("global"),
            f("F_time"),
            f("halves"),
            f("whole"),
            f("peak_mib"),
            f("relative"),
            f("split_term"),
        );
    }
}
