//! Global stress reconstruction benchmark (a program, not a timed test):
//!
//!     cargo bench --bench reconstruct [-- SIZES…] [--no-ngsolve] [--no-threads] [--no-check]
//!
//! For each size (default 10k, 100k, 250k triangles) and each order (RT_0 on a structured P1
//! mesh, RT_1 on a structured P2 mesh of the unit square, built in memory) it runs
//! `fosls::reconstruct::stress::reconstruct` (energy norm, best of 2) in a fresh child process
//! (this binary re-executed with `FOSLS_RECONSTRUCT_CASE` set) so that the peak memory (VmHWM)
//! is the case's own, then evaluates F at the minimiser with `fosls::estimate::run`. The same
//! least-squares problem without the sign constraint is solved by NGSolve
//! (`reference/reconstruct_bench/ngsolve_lsq.py`, also one fresh process per case) in the same
//! run, interleaved with the fosls cases, so that a time ratio can be quoted. Python:
//! `$FOSLS_PYTHON`, default `reference/.venv/bin/python`.
//!
//! Scene: E = 20600, ν = 0.28, plane strain; top y = 1 Dirichlet (u_D = u on the top); bottom
//! y = 0 frictionless contact with the plane y = 0, `normal = "obstacle"`; the sides are
//! traction free (unselected). Displacement (the P1/P2 nodal interpolant of)
//!
//! * `liftoff` (the timed cases): u = (1e-3 sin(xy), −1e-2 y (1 − 1.5 x) + 1e-4 x²): the
//!   bottom is compressed for x < 2/3 and pulled (tensile Cε(u)) beyond, with a small opening
//!   gap, so that τ_n ≤ 0 is active on part of Γ_C and the active set has work to do;
//! * `compressed` (the check, `--no-check` skips it): u = (1e-3 sin(xy), −1e-2 y + 1e-3 x²):
//!   compressive everywhere on Γ_C, the constraint is inactive at the minimiser, so fosls and
//!   NGSolve solve the same problem and their F must agree.
//!
//! Per case (fosls): unknowns of the global system (the edge DOFs, including the fixed
//! essential values; since issue 13 the interior DOFs are condensed cell by cell and reported
//! separately as `condensed`), the `nonzeros` of `SolveInfo` (distinct entries of K's lower
//! triangle), distinct nonzeros of the lower triangle of the same pattern rebuilt in the bench,
//! nonzeros of its Cholesky factor (that pattern analysed again with faer, after the timed
//! runs, faer's default AMD), active-set iterations, active constraints, KKT residual,
//! reconstruction time (best of 2), the time of one symbolic and one numeric factorisation of
//! that pattern, peak memory, F and its terms.
//!
//! Threads: the rayon pool and faer's global parallelism are set together in the child:
//! 1 thread = a 1-thread rayon pool and `Par::Seq`; 2 = a 2-thread pool and `Par::rayon(2)`.
//! `--no-threads` skips the 1-thread runs of the 100k case.

// Only the mesh file and the process figures are shared (the displacement and scene are this
// bench's own).
#[allow(dead_code)]
mod common;

use std::io::Write;
use std::path::Path;
use std::process::Command;
use std::time::Instant;

use faer::sparse::linalg::cholesky::factorize_symbolic_cholesky;
use faer::sparse::linalg::solvers::{Llt, SymbolicLlt};
use faer::sparse::{Pair, SparseColMat, SymbolicSparseColMat};
use faer::{Par, Side};
use fosls::element::rt::RtOrder;
use fosls::estimate::{self, StressField};
use fosls::problem::Condition;
use fosls::read::scene::{Norm, Scene, parse_scene};
use fosls::read::vtu::VtuFile;
use fosls::reconstruct::stress;
use fosls::{mesh, problem, topology};
use serde_json::{Value, json};

const CASE_ENV: &str = "FOSLS_RECONSTRUCT_CASE";

#[derive(Clone, Copy, PartialEq)]
enum Disp {
    Liftoff,
    Compressed,
}

impl Disp {
    fn name(self) -> &'static str {
        match self {
            Disp::Liftoff => "liftoff",
            Disp::Compressed => "compressed",
        }
    }
    fn parse(s: &str) -> Disp {
        match s {
            "compressed" => Disp::Compressed,
            _ => Disp::Liftoff,
        }
    }
    fn u(self, x: f64, y: f64) -> [f64; 2] {
        match self {
            Disp::Liftoff => [
                1e-3 * (x * y).sin(),
                -1e-2 * y * (1.0 - 1.5 * x) + 1e-4 * x * x,
            ],
            Disp::Compressed => [1e-3 * (x * y).sin(), -1e-2 * y + 1e-3 * x * x],
        }
    }
    /// The same u as scene expressions (Dirichlet data on the top).
    fn expressions(self) -> [&'static str; 2] {
        match self {
            Disp::Liftoff => ["1e-3*sin(x*y)", "-1e-2*y*(1 - 1.5*x) + 1e-4*x^2"],
            Disp::Compressed => ["1e-3*sin(x*y)", "-1e-2*y + 1e-3*x^2"],
        }
    }
}

/// n × n squares of the unit square, each cut along (a, c): 2n² triangles, n = round(√(cells/2)).
/// Degree 1: vertex (i, j) at (i/n, j/n), index j(n+1) + i (ngsolve_lsq.py builds the same).
/// Degree 2: the node grid (2n+1)², node (i, j) at (i/2n, j/2n), as in `benches/estimate.rs`.
fn square(cells: usize, degree: usize, disp: Disp) -> VtuFile {
    let n = ((cells / 2) as f64).sqrt().round() as usize;
    let m = degree * n + 1;
    let mut pts = Vec::with_capacity(m * m);
    for j in 0..m {
        for i in 0..m {
            pts.push([i as f64 / (m - 1) as f64, j as f64 / (m - 1) as f64, 0.0]);
        }
    }
    let id = |i: usize, j: usize| (j * m + i) as u32;
    let mut c = Vec::with_capacity(2 * n * n);
    for j in 0..n {
        for i in 0..n {
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
    common::with_field(pts, &c, |x, y| disp.u(x, y))
}

fn scene(disp: Disp) -> Scene {
    let [ux, uy] = disp.expressions();
    parse_scene(
        Path::new("bench.toml"),
        &format!(
            "[material]\nyoungs_modulus = 20600.0\npoisson_ratio = 0.28\n\
             [[boundary]]\nname = \"top\"\nwhere = \"y > 0.999999\"\nkind = \"dirichlet\"\n\
             displacement = [\"{ux}\", \"{uy}\"]\n\
             [[boundary]]\nname = \"bottom\"\nwhere = \"y < 1e-9\"\nkind = \"contact\"\n\
             obstacle = {{ plane = {{ point = [0.0, 0.0], normal = [0.0, 1.0] }} }}\n\
             normal = \"obstacle\"\n\
             [estimate]\nnorm = \"energy\"\n"
        ),
    )
    .unwrap()
}

fn loadavg() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .unwrap_or_default()
        .split_whitespace()
        .take(3)
        .collect::<Vec<_>>()
        .join(" ")
}

/// The lower-triangle pattern of the reconstruction matrix, rebuilt from the topology with
/// the numbering of `reconstruct::stress` (per row: the edge slots of every edge; rows 0 and 1
/// one after the other; the interior DOFs are condensed cell by cell and not in the global
/// system). Fixed unknowns (traction
/// on free/Neumann edges, τ_t on contact edges) keep only their diagonal entry; at a contact
/// slot row 1's unknown is the fixed y_t and row 0's the free y_n.
fn pattern(
    topo: &topology::Topology,
    edges: &[problem::BoundaryEdge],
    order: RtOrder,
    ntri: usize,
) -> (usize, Vec<Pair<usize, usize>>) {
    let ed = order.edge_dofs();
    let ne = topo.edges.len();
    let per_row = ne * ed;
    let n = 2 * per_row;
    let mut fixed = vec![false; n];
    for be in edges {
        let e = be.edge as usize;
        for s in 0..ed {
            match be.condition {
                Condition::Free | Condition::Neumann(_) => {
                    fixed[e * ed + s] = true;
                    fixed[per_row + e * ed + s] = true;
                }
                Condition::Contact(_) => fixed[per_row + e * ed + s] = true,
                Condition::Dirichlet(_) => {}
            }
        }
    }
    let mut pairs = Vec::with_capacity(ntri * 136);
    let mut dofs = Vec::with_capacity(16);
    for t in 0..ntri {
        dofs.clear();
        for r in 0..2 {
            // Triangles use 3 of the 4 edge slots; the fourth is `u32::MAX`.
            for &e in topo.cell_edges[t].iter().filter(|&&e| e != u32::MAX) {
                for s in 0..ed {
                    dofs.push(r * per_row + e as usize * ed + s);
                }
            }
        }
        dofs.retain(|&g| !fixed[g]);
        for &a in &dofs {
            for &c in &dofs {
                if a >= c {
                    pairs.push(Pair::new(a, c));
                }
            }
        }
    }
    for (g, f) in fixed.iter().enumerate() {
        if *f {
            pairs.push(Pair::new(g, g));
        }
    }
    (n, pairs)
}

/// One case in this process; prints one JSON line.
fn child(spec: &str) {
    let parts: Vec<&str> = spec.split(',').collect();
    let cells: usize = parts[0].parse().unwrap();
    let order = if parts[1] == "1" {
        RtOrder::Rt1
    } else {
        RtOrder::Rt0
    };
    let threads: usize = parts[2].parse().unwrap();
    let disp = Disp::parse(parts[3]);
    let repeat: usize = parts.get(4).and_then(|r| r.parse().ok()).unwrap_or(2);
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build_global()
        .unwrap();
    faer::set_global_parallelism(if threads == 1 {
        Par::Seq
    } else {
        Par::rayon(threads)
    });

    let scene = scene(disp);
    let degree = order.k() + 1;
    let t_setup = Instant::now();
    let file = square(cells, degree, disp);
    let data = mesh::build(file).unwrap();
    let topo = topology::build(&data).unwrap();
    let fields = problem::select_fields(&data, &scene).unwrap();
    let bounds = problem::classify(&data, &topo, &scene).unwrap();
    let setup = t_setup.elapsed().as_secs_f64();
    let ctx = problem::Context::new(&data.mesh, &topo, &scene, &bounds.edges, Norm::Energy);
    let base_rss = common::status_mib("VmRSS:");
    let base_hwm = common::status_mib("VmHWM:");

    let mut best = f64::INFINITY;
    let mut times = Vec::new();
    let mut result = None;
    for _ in 0..repeat {
        drop(result.take());
        let t0 = Instant::now();
        let r = stress::reconstruct(
            &ctx,
            fields.displacement.as_deref().expect("a displacement"),
            order,
        )
        .unwrap();
        let dt = t0.elapsed().as_secs_f64();
        times.push(dt);
        best = best.min(dt);
        result = Some(r);
    }
    let r = result.unwrap();
    let t_est = Instant::now();
    let est = estimate::run(
        &ctx,
        fields.displacement.as_deref().expect("a displacement"),
        StressField::Rt(&r.stress),
    );
    let estimate_time = t_est.elapsed().as_secs_f64();
    let peak = common::status_mib("VmHWM:");

    // The same pattern analysed again: distinct nonzeros, factor size, and the time of one
    // symbolic and one numeric factorisation of that pattern.
    let ntri = data.mesh.cells.len();
    let contact_points = bounds
        .edges
        .iter()
        .filter(|e| matches!(e.condition, Condition::Contact(_)))
        .count()
        * order.edge_dofs();
    drop(r.stress);
    let (n, pairs) = pattern(&topo, &bounds.edges, order, ntri);
    let (symbolic, argsort) = SymbolicSparseColMat::try_new_from_indices(n, n, &pairs).unwrap();
    drop(pairs);
    let distinct = symbolic.compute_nnz();
    let t_sym = Instant::now();
    let llt_sym = SymbolicLlt::try_new(symbolic.as_ref(), Side::Lower).unwrap();
    let symbolic_time = t_sym.elapsed().as_secs_f64();
    let raw = factorize_symbolic_cholesky(
        symbolic.as_ref(),
        Side::Lower,
        Default::default(),
        Default::default(),
    )
    .unwrap();
    let factor_nnz = raw.len_val();
    drop(raw);
    // Identity values in the full pattern: the factorisation does the same work on the
    // explicit zeros (and meets no denormals, unlike a diagonally dominant matrix whose fill
    // decays geometrically).
    let col_ptr = symbolic.col_ptr().to_vec();
    let row_idx = symbolic.row_idx().to_vec();
    let mut values = vec![0.0; distinct];
    for j in 0..n {
        for p in col_ptr[j]..col_ptr[j + 1] {
            if row_idx[p] == j {
                values[p] = 1.0;
            }
        }
    }
    drop(argsort);
    let mat = SparseColMat::<usize, f64>::new(symbolic, values);
    let t_num = Instant::now();
    let llt = Llt::try_new_with_symbolic(llt_sym, mat.as_ref(), Side::Lower).unwrap();
    let numeric_time = t_num.elapsed().as_secs_f64();
    drop(llt);

    let line = json!({
        "tool": "fosls",
        "cells": ntri,
        "order": order.k(),
        "threads": threads,
        "displacement": disp.name(),
        "unknowns": r.info.unknowns,
        "condensed": r.info.condensed,
        "triplets": r.info.nonzeros,
        "nonzeros": distinct,
        "factor_nonzeros": factor_nnz,
        "iterations": r.info.iterations,
        "active": r.info.active,
        "contact_points": contact_points,
        "converged": r.info.converged,
        "kkt_residual": r.info.kkt_residual,
        "time": best,
        "times": times,
        "symbolic": symbolic_time,
        "numeric": numeric_time,
        "setup": setup,
        "estimate": estimate_time,
        "peak_mib": peak,
        "base_mib": base_rss,
        "base_hwm_mib": base_hwm,
        "F": est.functional.total,
        "constitutive": est.functional.constitutive,
        "equilibrium": est.functional.equilibrium,
        "complementarity": est.functional.complementarity,
        "energy": est.energy,
        "tension_max": est.admissibility.tension.max,
        "neumann_max": est.admissibility.neumann.max,
        "cone_violation_max": est.admissibility.cone_violation.max,
    });
    println!("{line}");
}

fn run_json(cmd: &mut Command, what: &str) -> Option<Value> {
    let out = match cmd.output() {
        Ok(o) => o,
        Err(e) => {
            eprintln!("{what}: cannot start ({e})");
            return None;
        }
    };
    if !out.status.success() {
        eprintln!(
            "{what}: failed ({})\n{}",
            out.status,
            String::from_utf8_lossy(&out.stderr)
        );
        return None;
    }
    let text = String::from_utf8_lossy(&out.stdout);
    let v = text
        .lines()
        .rev()
        .find_map(|l| serde_json::from_str::<Value>(l).ok());
    if v.is_none() {
        eprintln!("{what}: no JSON line in\n{text}");
    }
    v
}

fn fosls_case(cells: usize, k: usize, threads: usize, disp: Disp) -> Option<Value> {
    let exe = std::env::current_exe().unwrap();
    run_json(
        Command::new(exe).env(CASE_ENV, format!("{cells},{k},{threads},{}", disp.name())),
        &format!("fosls {cells} RT_{k} {threads} thread(s)"),
    )
}

fn ngsolve_case(python: &str, cells: usize, k: usize, threads: usize, disp: Disp) -> Option<Value> {
    run_json(
        Command::new(python).args([
            "reference/reconstruct_bench/ngsolve_lsq.py",
            "--cells",
            &cells.to_string(),
            "--order",
            &k.to_string(),
            "--threads",
            &threads.to_string(),
            "--displacement",
            disp.name(),
        ]),
        &format!("ngsolve {cells} RT_{k} {threads} thread(s)"),
    )
}

fn f(v: &Value, key: &str) -> f64 {
    v[key].as_f64().unwrap_or(f64::NAN)
}

fn u(v: &Value, key: &str) -> u64 {
    v[key].as_u64().unwrap_or(0)
}

fn main() {
    if let Ok(spec) = std::env::var(CASE_ENV) {
        child(&spec);
        return;
    }
    let args: Vec<String> = std::env::args().skip(1).collect();
    let flag = |s: &str| args.iter().any(|a| a == s);
    let sizes: Vec<usize> = args.iter().filter_map(|a| a.parse().ok()).collect();
    let sizes = if sizes.is_empty() {
        vec![10_000, 100_000, 250_000]
    } else {
        sizes
    };
    let python =
        std::env::var("FOSLS_PYTHON").unwrap_or_else(|_| "reference/.venv/bin/python".into());
    let ngsolve = !flag("--no-ngsolve");
    println!("load average at start: {}", loadavg());
    println!(
        "{:>8} {:>2} {:>3} {:>10} {:>9} {:>10} {:>11} {:>3} {:>7} {:>7} {:>8} {:>8} {:>8} {:>8} {:>6} {:>5}  {:>15} {:>15}",
        "cells",
        "k",
        "thr",
        "u_h",
        "unknowns",
        "nonzeros",
        "factor nnz",
        "it",
        "active",
        "kkt",
        "fosls s",
        "MiB",
        "ngs s",
        "ngs MiB",
        "ratio",
        "load",
        "F fosls",
        "F ngsolve"
    );
    // (cells, k, threads, displacement): the liftoff cases, interleaved fosls / NGSolve, the
    // 1-thread runs of 100k, then the same-problem check (compressed) at every size.
    let mut cases: Vec<(usize, usize, usize, Disp)> = Vec::new();
    for &n in &sizes {
        for k in [0, 1] {
            cases.push((n, k, 2, Disp::Liftoff));
        }
        if n == 100_000 && !flag("--no-threads") {
            for k in [0, 1] {
                cases.push((n, k, 1, Disp::Liftoff));
            }
        }
    }
    if !flag("--no-check") {
        for &n in &sizes {
            for k in [0, 1] {
                cases.push((n, k, 2, Disp::Compressed));
            }
        }
    }
    let mut rows: Vec<(Value, Option<Value>)> = Vec::new();
    let mut out = std::io::stdout();
    for (n, k, threads, disp) in cases {
        let Some(a) = fosls_case(n, k, threads, disp) else {
            continue;
        };
        let b = if ngsolve {
            ngsolve_case(&python, n, k, threads, disp)
        } else {
            None
        };
        let load = loadavg();
        let (nt, nm, ratio, fb) = match &b {
            Some(b) => (
                format!("{:.2}", f(b, "time")),
                format!("{:.0}", f(b, "peak_mib")),
                format!("{:.2}", f(b, "time") / f(&a, "time")),
                format!("{:.9e}", f(b, "F")),
            ),
            None => ("-".into(), "-".into(), "-".into(), "-".into()),
        };
        println!(
            "{:>8} {:>2} {:>3} {:>10} {:>9} {:>10} {:>11} {:>3} {:>3}/{:<3} {:>7.0e} {:>8.2} {:>8.0} {:>8} {:>8} {:>6} {:>5}  {:>15.9e} {:>15}",
            u(&a, "cells"),
            k,
            threads,
            disp.name(),
            u(&a, "unknowns"),
            u(&a, "nonzeros"),
            u(&a, "factor_nonzeros"),
            u(&a, "iterations"),
            u(&a, "active"),
            u(&a, "contact_points"),
            f(&a, "kkt_residual"),
            f(&a, "time"),
            f(&a, "peak_mib"),
            nt,
            nm,
            ratio,
            load.split(' ').next().unwrap_or(""),
            f(&a, "F"),
            fb
        );
        out.flush().ok();
        rows.push((a, b));
    }
    println!("load average at end: {}", loadavg());

    // Markdown for BENCHMARKS.md ("-" where NGSolve did not run).
    let ng = |b: &Option<Value>, key: &str, digits: usize| -> String {
        b.as_ref()
            .map_or("-".into(), |b| format!("{:.digits$}", f(b, key)))
    };
    println!(
        "\n| cells | order | threads | u_h | unknowns | nonzeros | factor nonzeros | iterations | \
         active / points | KKT residual | fosls time | fosls peak MiB | NGSolve time | NGSolve \
         peak MiB (base) | ratio NGSolve/fosls |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    for (a, b) in &rows {
        let ratio = b.as_ref().map_or("-".into(), |b| {
            format!("{:.2}", f(b, "time") / f(a, "time"))
        });
        println!(
            "| {} | RT_{} | {} | {} | {} | {} | {} | {} | {} / {} | {:.0e} | {:.2} | {:.0} | {} | \
             {} ({}) | {} |",
            u(a, "cells"),
            u(a, "order"),
            u(a, "threads"),
            a["displacement"].as_str().unwrap_or(""),
            u(a, "unknowns"),
            u(a, "nonzeros"),
            u(a, "factor_nonzeros"),
            u(a, "iterations"),
            u(a, "active"),
            u(a, "contact_points"),
            f(a, "kkt_residual"),
            f(a, "time"),
            f(a, "peak_mib"),
            ng(b, "time", 2),
            ng(b, "peak_mib", 0),
            ng(b, "base_mib", 0),
            ratio,
        );
    }
    println!(
        "\n| cells | order | threads | u_h | fosls: symbolic | one numeric (separate) | time / \
         iteration | NGSolve: assembly | factorisation | solve | F fosls | F NGSolve \
         (unconstrained) | rel. diff |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    for (a, b) in &rows {
        let fa = f(a, "F");
        let diff = b.as_ref().map_or("-".into(), |b| {
            format!("{:.1e}", (fa - f(b, "F")).abs() / f(b, "F").abs())
        });
        println!(
            "| {} | RT_{} | {} | {} | {:.2} | {:.2} | {:.2} | {} | {} | {} | {:.10e} | {} | {} |",
            u(a, "cells"),
            u(a, "order"),
            u(a, "threads"),
            a["displacement"].as_str().unwrap_or(""),
            f(a, "symbolic"),
            f(a, "numeric"),
            f(a, "time") / u(a, "iterations") as f64,
            ng(b, "assemble", 2),
            ng(b, "factor", 2),
            ng(b, "solve", 2),
            fa,
            b.as_ref()
                .map_or("-".into(), |b| format!("{:.10e}", f(b, "F"))),
            diff
        );
    }
    println!("\nraw JSON lines:");
    for (a, b) in &rows {
        println!("{a}");
        if let Some(b) = b {
            println!("{b}");
        }
    }
}
