//! Read benchmark (a program, not a timed test): `cargo bench --bench read -- FILE.vtu`.
//!
//! Times each stage of reading a VTU file (bytes from disk, XML + decode, mesh build,
//! topology) over several runs, reports the best run and the peak resident memory against the
//! decoded data size, and times `meshio.read` on the same file in the same run when the
//! reference environment is present (`reference/.venv`), so that a ratio can be quoted.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use fosls::{mesh, read, topology};

fn peak_rss_mib() -> f64 {
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    status
        .lines()
        .find(|l| l.starts_with("VmHWM:"))
        .and_then(|l| l.split_whitespace().nth(1))
        .and_then(|v| v.parse::<f64>().ok())
        .map_or(f64::NAN, |kib| kib / 1024.0)
}

fn main() {
    let args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| a != "--bench")
        .collect();
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let file = args
        .first()
        .map(PathBuf::from)
        .unwrap_or_else(|| root.join("bench-data/p2_tri_1000000.vtu"));
    if !file.exists() {
        eprintln!(
            "{} is missing; generate it with\n  reference/.venv/bin/python reference/encodings/make_bench.py --cells 1000000 --out {}",
            file.display(),
            file.display()
        );
        std::process::exit(2);
    }
    let runs = 3;
    let mut best = [f64::INFINITY; 5];
    let mut decoded_bytes = 0usize;
    let mut cells = 0usize;
    for _ in 0..runs {
        let t0 = Instant::now();
        let bytes = std::fs::read(&file).unwrap();
        let t1 = Instant::now();
        let vtu = read::vtu::parse_vtu(&file, &bytes).unwrap();
        let t2 = Instant::now();
        drop(bytes);
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
        let data = mesh::build(vtu).unwrap();
        let t4 = Instant::now();
        let topo = topology::build(&data).unwrap();
        let t5 = Instant::now();
        cells = data.mesh.cells.len();
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
    }
    let peak = peak_rss_mib();
    let size = std::fs::metadata(&file).unwrap().len() as f64 / (1 << 20) as f64;
    println!(
        "file            {} ({size:.1} MiB, {cells} triangles)",
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
    let decoded = decoded_bytes as f64 / (1 << 20) as f64;
    println!(
        "peak memory     {peak:.0} MiB = {:.2} × decoded data ({decoded:.0} MiB)",
        peak / decoded
    );
    let python = root.join("reference/.venv/bin/python");
    let script = root.join("reference/encodings/time_meshio.py");
    if python.exists() && script.exists() {
        let out = Command::new(&python)
            .arg(&script)
            .arg(&file)
            .output()
            .unwrap();
        let line = String::from_utf8_lossy(&out.stdout);
        println!("meshio.read     {}", line.trim());
        if let Some(t) = serde_json::from_str::<serde_json::Value>(line.trim())
            .ok()
            .and_then(|v| v["seconds_best"].as_f64())
        {
            println!("ratio           meshio / fosls read = {:.1}×", t / best[4]);
        }
    }
}
