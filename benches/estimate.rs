//! Evaluation benchmark (a program, not a timed test): `cargo bench --bench estimate`.
//!
//! Builds structured P2 meshes of the unit square with 10k, 100k and 1M triangles in memory,
//! smooth displacement and nodal stress fields, a contact boundary on y = 0 and a Dirichlet
//! top, and times each stage of `fosls estimate` after reading: mesh build, topology, field
//! setup, and the evaluation of F (interior and boundary terms), with the rayon pool at 1 and
//! 2 threads. Peak memory is the process's VmHWM after all runs.

use std::path::Path;
use std::time::Instant;

use fosls::estimate;
use fosls::read::scene::parse_scene;
use fosls::read::vtu::VtuFile;
use fosls::{mesh, problem, topology};

fn square(cells: usize) -> VtuFile {
    // n × n squares, each split in two: 2n² triangles.
    let n = ((cells / 2) as f64).sqrt().round() as usize;
    let m = 2 * n + 1;
    let mut pts = Vec::with_capacity(m * m);
    for j in 0..m {
        for i in 0..m {
            pts.push([i as f64 / (m - 1) as f64, j as f64 / (m - 1) as f64, 0.0]);
        }
    }
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
    let mut f = VtuFile::from_cells(Path::new("bench.vtu"), pts, &c);
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

fn peak_rss_mib() -> f64 {
    std::fs::read_to_string("/proc/self/status")
        .unwrap_or_default()
        .lines()
        .find(|l| l.starts_with("VmHWM:"))
        .and_then(|l| l.split_whitespace().nth(1))
        .and_then(|v| v.parse::<f64>().ok())
        .map_or(f64::NAN, |kib| kib / 1024.0)
}

fn main() {
    let scene = parse_scene(
        Path::new("bench.toml"),
        "[material]\nyoungs_modulus = 20600.0\npoisson_ratio = 0.28\n\
         [[boundary]]\nname = \"top\"\nwhere = \"y > 0.999999\"\nkind = \"dirichlet\"\n\
         displacement = [0.0, -0.01]\n\
         [[boundary]]\nname = \"bottom\"\nwhere = \"y < 1e-9\"\nkind = \"contact\"\n\
         obstacle = { plane = { point = [0.0, 0.0], normal = [0.0, 1.0] } }\n\
         normal = \"obstacle\"\nfriction = 0.4\n",
    )
    .unwrap();
    let sizes: Vec<usize> = std::env::args()
        .skip(1)
        .filter_map(|a| a.parse().ok())
        .collect();
    let sizes = if sizes.is_empty() {
        vec![10_000, 100_000, 1_000_000]
    } else {
        sizes
    };
    println!("cells      threads  mesh     topology  fields   evaluate  (best of 3, seconds)");
    for &n in &sizes {
        let file = square(n);
        for threads in [1, 2] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let mut best = [f64::INFINITY; 4];
            let mut cells = 0;
            let mut total = 0.0;
            for _ in 0..3 {
                pool.install(|| {
                    let t0 = Instant::now();
                    let data = mesh::build(file.clone()).unwrap();
                    let t1 = Instant::now();
                    let topo = topology::build(&data).unwrap();
                    let t2 = Instant::now();
                    let fields = problem::select_fields(&data, &scene).unwrap();
                    let bounds = problem::classify(&data, &topo, &scene).unwrap();
                    let problem::Stress::Nodal { values, .. } = &fields.stress else {
                        panic!("no nodal stress");
                    };
                    let t3 = Instant::now();
                    let est = estimate::run(&estimate::Input {
                        mesh: &data.mesh,
                        scene: &scene,
                        u: fields.displacement.as_deref().expect("a displacement"),
                        sigma: estimate::StressField::Nodal(values),
                        edges: &bounds.edges,
                        norm: scene.effective_norm(),
                        symmetric_stress: true,
                    });
                    let t4 = Instant::now();
                    cells = data.mesh.cells.len();
                    total = est.functional.total;
                    let times = [t1 - t0, t2 - t1, t3 - t2, t4 - t3];
                    for (b, t) in best.iter_mut().zip(times) {
                        *b = b.min(t.as_secs_f64());
                    }
                });
            }
            println!(
                "{cells:>9}  {threads:>7}  {:.3}    {:.3}     {:.3}    {:.3}     F = {total:.6e}",
                best[0], best[1], best[2], best[3]
            );
        }
    }
    println!("peak memory {:.0} MiB", peak_rss_mib());
}
