//! Exactness (docs/design.md §9 layer 2): an exact polynomial solution in the discrete spaces gives
//! F ≈ 0 to round-off, for each preset, and a known perturbation gives the hand-derived F.

use std::path::Path;

use super::*;
use crate::mesh;
use crate::problem::Condition;
use crate::read::scene::Scene;
use crate::read::scene::parse_scene;
use crate::read::vtu::VtuFile;
use crate::topology;

/// A P2 mesh of [0, 2] × [0, 1] with nx × ny squares split in two, interior vertices jittered
/// (straight cells).
pub(super) fn rectangle(nx: usize, ny: usize) -> mesh::Dataset {
    let (w, h) = (2.0, 1.0);
    let mut pts = Vec::new();
    let id = |i: usize, j: usize| (j * (2 * nx + 1) + i) as u32;
    for j in 0..=2 * ny {
        for i in 0..=2 * nx {
            let (mut x, mut y) = (
                w * i as f64 / (2 * nx) as f64,
                h * j as f64 / (2 * ny) as f64,
            );
            // Jitter interior vertices only (even indices), deterministically.
            if i % 2 == 0 && j % 2 == 0 && i > 0 && j > 0 && i < 2 * nx && j < 2 * ny {
                x += 0.15 * w / nx as f64 * ((i * 7 + j * 3) as f64).sin();
                y += 0.15 * h / ny as f64 * ((i * 5 + j * 11) as f64).cos();
            }
            pts.push([x, y, 0.0]);
        }
    }
    // Mid nodes at chord midpoints of the jittered vertices.
    let mut cells = Vec::new();
    for j in 0..ny {
        for i in 0..nx {
            let (a, b, c, d) = (
                id(2 * i, 2 * j),
                id(2 * i + 2, 2 * j),
                id(2 * i + 2, 2 * j + 2),
                id(2 * i, 2 * j + 2),
            );
            let center = id(2 * i + 1, 2 * j + 1);
            cells.push((
                22u8,
                vec![
                    a,
                    b,
                    c,
                    id(2 * i + 1, 2 * j),
                    id(2 * i + 2, 2 * j + 1),
                    center,
                ],
            ));
            cells.push((
                22u8,
                vec![
                    a,
                    c,
                    d,
                    center,
                    id(2 * i + 1, 2 * j + 2),
                    id(2 * i, 2 * j + 1),
                ],
            ));
        }
    }
    for (_, n) in &cells {
        for (m, a, b) in [(3, 0, 1), (4, 1, 2), (5, 2, 0)] {
            let (pa, pb) = (pts[n[a] as usize], pts[n[b] as usize]);
            pts[n[m] as usize] = [0.5 * (pa[0] + pb[0]), 0.5 * (pa[1] + pb[1]), 0.0];
        }
    }
    mesh::build(VtuFile::from_cells(Path::new("exact.vtu"), pts, &cells)).unwrap()
}

/// Bottom edges (y = 0) are contact boundary 0; the rest are free.
fn edges(d: &mesh::Dataset, t: &topology::Topology) -> Vec<crate::problem::BoundaryEdge> {
    t.boundary_edges
        .iter()
        .map(|&e| {
            let cell = t.edge_cells[e as usize][0];
            let local = t.cell_edges[cell as usize]
                .iter()
                .position(|&x| x == e)
                .unwrap() as u8;
            let [a, b] = t.edges[e as usize];
            let bottom = d.mesh.points[a as usize][1] == 0.0 && d.mesh.points[b as usize][1] == 0.0;
            crate::problem::BoundaryEdge {
                edge: e,
                cell,
                local,
                line: crate::mesh::NONE,
                condition: if bottom {
                    Condition::Contact(0)
                } else {
                    Condition::Free
                },
            }
        })
        .collect()
}

fn scene(nu: f64, norm: &str, f: [f64; 2]) -> Scene {
    let text = format!(
        "[material]\nyoungs_modulus = 20600.0\npoisson_ratio = {nu}\n\
         [loads]\nbody_force = [{:e}, {:e}]\n\
         [estimate]\nnorm = \"{norm}\"\n\
         [[boundary]]\nname = \"bottom\"\nwhere = \"y < 1e-9\"\nkind = \"contact\"\n\
         obstacle = {{ plane = {{ point = [0.0, 0.0], normal = [0.0, 1.0] }} }}\n\
         normal = \"obstacle\"\n",
        f[0], f[1]
    );
    parse_scene(Path::new("exact.toml"), &text).unwrap()
}

/// Displacement gradient of the test fields at (x, y): u quadratic with u_y(x, 0) = 0, and
/// for the incompressible case div u = 0 (u = curl ψ, ψ = y(αx² + βxy + γy² + δx + εy)).
fn grad_u(x: f64, y: f64, div_free: bool) -> ([f64; 2], [[f64; 2]; 2]) {
    if div_free {
        let (al, be, ga, de, ep) = (1e-3, -2e-3, 5e-4, -4e-3, 1e-3);
        // ψ_y = αx² + 2βxy + 3γy² + δx + 2εy, ψ_x = y(2αx + βy + δ).
        let u = [
            al * x * x + 2.0 * be * x * y + 3.0 * ga * y * y + de * x + 2.0 * ep * y,
            -y * (2.0 * al * x + be * y + de),
        ];
        let g = [
            [
                2.0 * al * x + 2.0 * be * y + de,
                2.0 * be * x + 6.0 * ga * y + 2.0 * ep,
            ],
            [-2.0 * al * y, -(2.0 * al * x + 2.0 * be * y + de)],
        ];
        (u, g)
    } else {
        let u = [
            1e-3 * x + 2e-3 * y - 1e-3 * x * x + 5e-4 * x * y + 1e-3 * y * y,
            y * (-8e-3 + 1e-3 * x + 2e-3 * y),
        ];
        let g = [
            [1e-3 - 2e-3 * x + 5e-4 * y, 2e-3 + 5e-4 * x + 2e-3 * y],
            [1e-3 * y, -8e-3 + 1e-3 * x + 4e-3 * y],
        ];
        (u, g)
    }
}

/// Runs the estimate for the exact fields (optionally with the stress perturbed).
fn exact(nu: f64, norm: Norm, perturb: impl Fn([f64; 2]) -> [f64; 4]) -> (Estimate, f64) {
    let d = rectangle(4, 3);
    let t = topology::build(&d).unwrap();
    let material = scene(nu, "seed", [0.0; 2]).material;
    let el = crate::material::Elastic::new(&material);
    let div_free = nu == 0.5;
    let mut u = Vec::new();
    let mut sigma = Vec::new();
    let stress_at = |x: f64, y: f64| {
        let (_, g) = grad_u(x, y, div_free);
        let s = 0.5 * (g[0][1] + g[1][0]);
        let eps = [g[0][0], s, s, g[1][1]];
        if div_free {
            // σ = 2μ ε(u) − p I with the pressure p = 300 + 20x − 10y.
            let p = 300.0 + 20.0 * x - 10.0 * y;
            [
                2.0 * el.mu * eps[0] - p,
                2.0 * el.mu * eps[1],
                2.0 * el.mu * eps[2],
                2.0 * el.mu * eps[3] - p,
            ]
        } else {
            el.stress(eps)
        }
    };
    for p in &d.mesh.points {
        let (uu, _) = grad_u(p[0], p[1], div_free);
        u.push(uu);
        let mut s = stress_at(p[0], p[1]);
        let dp = perturb(*p);
        for k in 0..4 {
            s[k] += dp[k];
        }
        sigma.push(s);
    }
    // f = −div σ (constant: σ is linear), by central differences of the linear field, exact.
    let h = 0.5;
    let dx = |k: usize| (stress_at(1.0 + h, 0.5)[k] - stress_at(1.0 - h, 0.5)[k]) / (2.0 * h);
    let dy = |k: usize| (stress_at(1.0, 0.5 + h)[k] - stress_at(1.0, 0.5 - h)[k]) / (2.0 * h);
    let f = [-(dx(0) + dy(1)), -(dx(2) + dy(3))];
    let sc = scene(nu, norm.as_str(), f);
    let e = edges(&d, &t);
    let ctx = crate::problem::Context::new(&d.mesh, &t, &sc, &e, norm);
    let est = run(&ctx, &u, StressField::Nodal(&sigma));
    (est, el.mu)
}

#[test]
fn exact_solution_gives_zero_for_every_preset() {
    for (nu, norm) in [
        (0.28, Norm::Energy),
        (0.28, Norm::Robust),
        (0.28, Norm::Seed),
        (0.5, Norm::Robust),
        (0.5, Norm::Seed),
    ] {
        let (est, _) = exact(nu, norm, |_| [0.0; 4]);
        let rel = est.functional.total.abs() / est.energy;
        assert!(
            rel < 1e-20,
            "ν = {nu}, {norm:?}: F/energy = {rel:e} ({:?})",
            est.functional
        );
        // The contact boundary is active (σ_n < 0) along its whole length 2.
        assert!(
            (est.contact.active_length - 2.0).abs() < 1e-12,
            "ν = {nu} {:?}",
            est.contact.intervals
        );
        assert!(est.contact.normal_force > 0.0);
        assert_eq!(est.admissibility.penetration.max, 0.0);
    }
}

/// Perturbing σ by a constant δ in σ_xx only: Aδ has components δ/(2μ)(1 − c) (xx) and
/// −δ c/(2μ) (yy), c = λ/(2μ + 2λ). In the `seed` preset the constitutive term is
/// ½ |Aδ|² · area = ½ (δ/2μ)² ((1 − c)² + c²) · 2, the equilibrium term is 0 (δ is constant),
/// and the complementarity term is 0 (u_n = g on Γ_C).
#[test]
fn constant_stress_perturbation_matches_the_hand_value() {
    let delta = 3.0;
    let (est, mu) = exact(0.28, Norm::Seed, |_| [delta, 0.0, 0.0, 0.0]);
    let m = Material {
        youngs_modulus: 20600.0,
        poisson_ratio: 0.28,
        model: crate::read::scene::Model::PlaneStrain,
    };
    let lambda = m.lambda();
    let c = lambda / (2.0 * mu + 2.0 * lambda);
    let a = delta / (2.0 * mu);
    let want = 0.5 * a * a * ((1.0 - c).powi(2) + c * c) * 2.0;
    let got = est.functional.constitutive;
    assert!((got - want).abs() <= 1e-12 * want, "{got} vs {want}");
    assert!(est.functional.equilibrium.abs() <= 1e-16 * want);
    assert!(est.functional.complementarity.abs() <= 1e-12 * want);
}

use crate::read::scene::Material;
