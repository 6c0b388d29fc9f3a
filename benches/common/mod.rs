//! Shared by the benchmarks (`benches/patch.rs`, `benches/halves.rs`, `benches/reconstruct.rs`):
//! the patch benches' displacement and scene, a mesh file with a displacement array, and
//! process figures.

use std::path::Path;

use fosls::read::scene::{Scene, parse_scene};
use fosls::read::vtu::VtuFile;

/// The displacement of both benches' meshes (smooth, not a Galerkin solution; no penetration).
pub fn u_exact(x: f64, y: f64) -> [f64; 2] {
    [
        1e-3 * (x * y).sin(),
        -1e-2 * y * (1.0 - 0.3 * x) + 1e-4 * (x - 1.0) * (x - 1.0),
    ]
}

/// The mx × my lattice of points of [0, 2] × [0, 1], row by row (z = 0).
pub fn grid(mx: usize, my: usize) -> Vec<[f64; 3]> {
    let mut pts = Vec::with_capacity(mx * my);
    for j in 0..my {
        for i in 0..mx {
            pts.push([
                2.0 * i as f64 / (mx - 1) as f64,
                j as f64 / (my - 1) as f64,
                0.0,
            ]);
        }
    }
    pts
}

/// The file of the cells `c` (VTK type, nodes) on `pts`, with [`u_exact`] at every point as
/// the point array "displacement".
pub fn with_displacement(pts: Vec<[f64; 3]>, c: &[(u8, Vec<u32>)]) -> VtuFile {
    with_field(pts, c, u_exact)
}

/// The file of the cells `c` on `pts`, with `u(x, y)` at every point as the point array
/// "displacement".
pub fn with_field(
    pts: Vec<[f64; 3]>,
    c: &[(u8, Vec<u32>)],
    u: impl Fn(f64, f64) -> [f64; 2],
) -> VtuFile {
    let mut f = VtuFile::from_cells(Path::new("bench.vtu"), pts, c);
    let mut values = Vec::with_capacity(2 * f.points.len());
    for p in &f.points {
        values.extend_from_slice(&u(p[0], p[1]));
    }
    f.point_data.push(fosls::read::vtu::DataArray {
        name: "displacement".into(),
        scalar: fosls::read::decode::Scalar::Float64,
        components: 2,
        component_names: vec![],
        values,
    });
    f
}

/// E = 20600, ν = 0.28, plane strain, body force (0, −1); top Dirichlet (u_D = u), bottom
/// frictionless contact along the body normal, sides traction-free.
pub fn scene() -> Scene {
    parse_scene(
        Path::new("bench.toml"),
        "[material]\nyoungs_modulus = 20600.0\npoisson_ratio = 0.28\n\
         [loads]\nbody_force = [0.0, -1.0]\n\
         [[boundary]]\nname = \"top\"\nwhere = \"y > 0.999999\"\nkind = \"dirichlet\"\n\
         displacement = [\"1e-3*sin(x*y)\", \"-1e-2*y*(1 - 0.3*x) + 1e-4*(x - 1)^2\"]\n\
         [[boundary]]\nname = \"bottom\"\nwhere = \"y < 1e-9\"\nkind = \"contact\"\n\
         gap = \"1e-5 + 2e-4*(x - 1)^2\"\nnormal = \"body\"\n\
         [[boundary]]\nname = \"sides\"\nwhere = \"x < 1e-9 || x > 1.999999\"\n\
         kind = \"neumann\"\ntraction = [0.0, 0.0]\n\
         [estimate]\nnorm = \"energy\"\n",
    )
    .unwrap()
}

/// A `/proc/self/status` figure in MiB (e.g. "VmHWM:", the peak resident set).
pub fn status_mib(key: &str) -> f64 {
    std::fs::read_to_string("/proc/self/status")
        .unwrap_or_default()
        .lines()
        .find(|l| l.starts_with(key))
        .and_then(|l| l.split_whitespace().nth(1))
        .and_then(|v| v.parse::<f64>().ok())
        .map_or(f64::NAN, |kib| kib / 1024.0)
}

/// The comma-separated numbers after `flag`, or `default`.
pub fn list(args: &[String], flag: &str, default: &[usize]) -> Vec<usize> {
    match args.iter().position(|a| a == flag) {
        Some(i) => args[i + 1]
            .split(',')
            .map(|s| s.parse().expect("a number"))
            .collect(),
        None => default.to_vec(),
    }
}
