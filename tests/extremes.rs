//! Extremes (docs/design.md §9 layer 6): the real binary on exact polynomial solutions written
//! in-process, at the edges of the parameter space, each result checked against the exact value
//! (F = 0) or a value derived by hand below.
//!
//! **The field.** On Ω = [0, W] × [0, H] (P2 triangles, interior vertices jittered), with
//! α = 1e-3, γ = 5e-4, δ = 4e-3, a pressure p = s (P₀ + P₁x + P₂y), (P₀, P₁, P₂) = (300, 20, −10)
//! scaled by s = E / 20600, and k = (1 − 2ν)/μ:
//!
//! ```text
//!   u = curl ψ − k w,   ψ = y (αx² + γy² + δx),   w = (P₀x + P₁x²/2, P₂y²/2) s,   div w = p,
//!   σ = C ε(u) = 2μ ε(u) − 2ν p I          (λ tr ε(u) = −λ k p = −2ν p, since λ/μ = 2ν/(1−2ν)),
//!   f = −div σ = ( −2μ(α + 3γ) + (2 − 2ν) P₁ s,  (2 − 2ν) P₂ s ).
//! ```
//!
//! u is quadratic and σ linear, so the pair is exact in P2 × (nodal P2) and in P2 × RT_1, for
//! every ν up to 0.5 (where u = curl ψ and σ = 2μ ε − p I). On the bottom y = 0 (contact with
//! the plane y = −g, `normal = "obstacle"`, so n = (0, −1), t = (1, 0)): u_y = 0, σ_xy = 0 and
//!
//! ```text
//!   σ_n = σ_yy = −(a₀ + a₁x),  a₀ = 2μδ + 2νP₀s,  a₁ = 4μα + 2νP₁s        (compression),
//!   u_t = u_x = b₁x + b₂x²,    b₁ = δ − kP₀s,     b₂ = α − kP₁s/2.
//! ```
//!
//! Hence, with ∫₀² x^m dx = 2^{m+1}/(m+1):
//!
//! - complementarity ⟨u_n − g, σ_n⟩ = ∫ (−g)(−(a₀ + a₁x)) = g (2a₀ + 2a₁);
//! - friction 𝔉⟨|σ_n|, |u_t|⟩ + ⟨σ_t, u_t⟩ = 𝔉 |∫ (a₀ + a₁x)(b₁x + b₂x²)| when u_t keeps one
//!   sign on (0, 2] (checked), = 𝔉 |2a₀b₁ + 8/3 a₀b₂ + 8/3 a₁b₁ + 4a₁b₂|;
//! - a constant perturbation D of σ_xx adds Aδ = D/(2μ) (1 − ν, −ν) (plane strain: the c of
//!   docs/design.md §2 is λ/(2μ + 2λ) = ν), so the constitutive term is ½ D²(1 − ν)/(2μ) · |Ω|
//!   (energy) and μ (D/2μ)² ((1 − ν)² + ν²) · |Ω| (robust), and nothing else changes.
//!
//! The other sides carry the exact displacement as Dirichlet data (expressions), so the exact
//! stress is admissible and the reconstruction sees the right problem.
//!
//! Slow cases (aspect ratio 1e4, the full reconstruction sweep) are `#[ignore]`d and run by
//! `.ci/run` with `--ignored`.

use std::path::{Path, PathBuf};
use std::process::Command;

use fosls::read::decode::Scalar;
use fosls::read::vtu::{DataArray, VtuFile};
use fosls::write::{Placement, write_vtu};
use serde::Deserialize;

const ALPHA: f64 = 1e-3;
const GAMMA: f64 = 5e-4;
const DELTA: f64 = 4e-3;
const P: [f64; 3] = [300.0, 20.0, -10.0];
/// The body is [0, 2] × [0, H]; H = 1 except for slivers.
const W: f64 = 2.0;

/// One case of the matrix.
#[derive(Clone, Debug)]
struct Case {
    e: f64,
    nu: f64,
    /// Cell aspect ratio (width / height of the squares before splitting).
    aspect: f64,
    gap: f64,
    friction: f64,
    /// Constant added to σ_xx of the file's stress (scaled by s).
    perturb: f64,
    norm: &'static str,
    /// Γ_C is the bottom from x = 0 to this (W: the whole bottom; 0.5: its first edge).
    contact_to: f64,
    /// Uniaxial stress σ = (K, 0, 0) instead of the field above: Γ_C traction-free.
    uniaxial: bool,
}

impl Default for Case {
    fn default() -> Self {
        Case {
            e: 20600.0,
            nu: 0.3,
            aspect: 1.0,
            gap: 0.0,
            friction: 0.0,
            perturb: 0.0,
            norm: "energy",
            contact_to: W,
            uniaxial: false,
        }
    }
}

/// Material and field constants of a case.
struct Field {
    mu: f64,
    nu: f64,
    s: f64,
    k: f64,
    uniaxial: bool,
}

/// σ_xx of the uniaxial field (scaled by s): ε = Aσ = K/(2μ) (1 − ν, −ν), u = (ε_xx x, ε_yy y).
const K: f64 = 50.0;

impl Field {
    fn new(c: &Case) -> Field {
        let mu = c.e / (2.0 * (1.0 + c.nu));
        Field {
            mu,
            nu: c.nu,
            s: c.e / 20600.0,
            k: (1.0 - 2.0 * c.nu) / mu,
            uniaxial: c.uniaxial,
        }
    }
    fn u(&self, x: f64, y: f64) -> [f64; 2] {
        let (k, s) = (self.k, self.s);
        if self.uniaxial {
            let a = K * s / (2.0 * self.mu);
            return [a * (1.0 - self.nu) * x, -a * self.nu * y];
        }
        [
            ALPHA * x * x + 3.0 * GAMMA * y * y + DELTA * x
                - k * s * (P[0] * x + P[1] * x * x / 2.0),
            -y * (2.0 * ALPHA * x + DELTA) - k * s * P[2] * y * y / 2.0,
        ]
    }
    /// (σ_xx, σ_yy, σ_xy).
    fn sigma(&self, x: f64, y: f64) -> [f64; 3] {
        let (mu, k, s) = (self.mu, self.k, self.s);
        if self.uniaxial {
            return [K * s, 0.0, 0.0];
        }
        let p = s * (P[0] + P[1] * x + P[2] * y);
        let exx = 2.0 * ALPHA * x + DELTA - k * s * (P[0] + P[1] * x);
        let eyy = -(2.0 * ALPHA * x + DELTA) - k * s * P[2] * y;
        let exy = (3.0 * GAMMA - ALPHA) * y;
        [
            2.0 * mu * exx - 2.0 * self.nu * p,
            2.0 * mu * eyy - 2.0 * self.nu * p,
            2.0 * mu * exy,
        ]
    }
    fn f(&self) -> [f64; 2] {
        let (mu, nu, s) = (self.mu, self.nu, self.s);
        if self.uniaxial {
            return [0.0, 0.0];
        }
        [
            -2.0 * mu * (ALPHA + 3.0 * GAMMA) + (2.0 - 2.0 * nu) * P[1] * s,
            (2.0 - 2.0 * nu) * P[2] * s,
        ]
    }
    /// |σ_n| = a₀ + a₁x and u_t = b₁x + b₂x² on y = 0.
    fn contact(&self) -> ([f64; 2], [f64; 2]) {
        let (mu, nu, s, k) = (self.mu, self.nu, self.s, self.k);
        (
            [
                2.0 * mu * DELTA + 2.0 * nu * P[0] * s,
                4.0 * mu * ALPHA + 2.0 * nu * P[1] * s,
            ],
            [DELTA - k * P[0] * s, ALPHA - k * P[1] * s / 2.0],
        )
    }
}

fn height(c: &Case) -> f64 {
    // nx = 4, ny = 3 squares: (W/4) / (H/3) = aspect.
    if c.aspect == 1.0 {
        1.0
    } else {
        W * 3.0 / (4.0 * c.aspect)
    }
}

/// VTK cells: (type, nodes).
type Cells = Vec<(u8, Vec<u32>)>;

/// A P2 mesh of [0, W] × [0, h], nx × ny rectangles split in two, interior vertices jittered,
/// mid nodes at chord midpoints (straight cells).
fn mesh(nx: usize, ny: usize, h: f64) -> (Vec<[f64; 3]>, Cells) {
    let id = |i: usize, j: usize| (j * (2 * nx + 1) + i) as u32;
    let mut pts = Vec::new();
    for j in 0..=2 * ny {
        for i in 0..=2 * nx {
            let (mut x, mut y) = (
                W * i as f64 / (2 * nx) as f64,
                h * j as f64 / (2 * ny) as f64,
            );
            if i % 2 == 0 && j % 2 == 0 && i > 0 && j > 0 && i < 2 * nx && j < 2 * ny {
                x += 0.15 * W / nx as f64 * ((i * 7 + j * 3) as f64).sin();
                y += 0.15 * h / ny as f64 * ((i * 5 + j * 11) as f64).cos();
            }
            pts.push([x, y, 0.0]);
        }
    }
    let mut cells = Vec::new();
    for j in 0..ny {
        for i in 0..nx {
            let (a, b, c, d) = (
                id(2 * i, 2 * j),
                id(2 * i + 2, 2 * j),
                id(2 * i + 2, 2 * j + 2),
                id(2 * i, 2 * j + 2),
            );
            let m = id(2 * i + 1, 2 * j + 1);
            cells.push((
                22,
                vec![a, b, c, id(2 * i + 1, 2 * j), id(2 * i + 2, 2 * j + 1), m],
            ));
            cells.push((
                22,
                vec![a, c, d, m, id(2 * i + 1, 2 * j + 2), id(2 * i, 2 * j + 1)],
            ));
        }
    }
    for (_, n) in &cells {
        for (m, a, b) in [(3, 0, 1), (4, 1, 2), (5, 2, 0)] {
            let (pa, pb) = (pts[n[a] as usize], pts[n[b] as usize]);
            pts[n[m] as usize] = [0.5 * (pa[0] + pb[0]), 0.5 * (pa[1] + pb[1]), 0.0];
        }
    }
    (pts, cells)
}

/// The displacement as scene expressions in x, y.
fn u_expr(fl: &Field) -> [String; 2] {
    let (k, s) = (fl.k, fl.s);
    if fl.uniaxial {
        let a = K * s / (2.0 * fl.mu);
        return [
            format!("({:e})*x", a * (1.0 - fl.nu)),
            format!("({:e})*y", -a * fl.nu),
        ];
    }
    [
        format!(
            "({ALPHA:e})*x^2 + ({:e})*y^2 + ({DELTA:e})*x - ({:e})*x - ({:e})*x^2",
            3.0 * GAMMA,
            k * s * P[0],
            k * s * P[1] / 2.0
        ),
        format!(
            "-y*(({:e})*x + ({DELTA:e})) - ({:e})*y^2",
            2.0 * ALPHA,
            k * s * P[2] / 2.0
        ),
    ]
}

/// Writes solution.vtu and scene.toml for `c` into `dir`.
fn write_case(dir: &Path, c: &Case) -> PathBuf {
    let fl = Field::new(c);
    let h = height(c);
    let (pts, cells) = mesh(4, 3, h);
    let mut file = VtuFile::from_cells(Path::new("solution.vtu"), pts.clone(), &cells);
    let d = c.perturb * fl.s;
    file.point_data.push(DataArray {
        name: "displacement".into(),
        scalar: Scalar::Float64,
        components: 2,
        component_names: Vec::new(),
        values: pts.iter().flat_map(|p| fl.u(p[0], p[1])).collect(),
    });
    file.point_data.push(DataArray {
        name: "stress".into(),
        scalar: Scalar::Float64,
        components: 3,
        component_names: Vec::new(),
        values: pts
            .iter()
            .flat_map(|p| {
                let s = fl.sigma(p[0], p[1]);
                [s[0] + d, s[1], s[2]]
            })
            .collect(),
    });
    let vtu = dir.join("solution.vtu");
    write_vtu(&vtu, &file, Placement::AppendedRaw).unwrap();
    let f = fl.f();
    let [ux, uy] = u_expr(&fl);
    let tol = 1e-3 * h.min(W) / 6.0;
    // Γ_C: the bottom up to x = contact_to; Dirichlet data on the rest of the boundary.
    let xc = c.contact_to + 1e-3;
    let scene = format!(
        "[material]\nyoungs_modulus = {e:e}\npoisson_ratio = {nu}\n\
         [fields]\ndisplacement = \"displacement\"\nstress = \"stress\"\nstress_layout = \"xx,yy,xy\"\n\
         [loads]\nbody_force = [{f0:e}, {f1:e}]\n\
         [estimate]\nnorm = \"{norm}\"\n\
         [[boundary]]\nname = \"bottom\"\nwhere = \"min({tol:e} - y, {xc:e} - x) > 0\"\nkind = \"contact\"\n\
         obstacle = {{ plane = {{ point = [0.0, {g:e}], normal = [0.0, 1.0] }} }}\n\
         normal = \"obstacle\"\nfriction = {fr:e}\n\
         [[boundary]]\nname = \"rest\"\nwhere = \"max(y - {tol:e}, x - {xc:e}) > 0\"\nkind = \"dirichlet\"\n\
         displacement = [\"{ux}\", \"{uy}\"]\n",
        e = c.e,
        nu = c.nu,
        f0 = f[0],
        f1 = f[1],
        norm = c.norm,
        g = -c.gap,
        fr = c.friction,
    );
    std::fs::write(dir.join("scene.toml"), scene).unwrap();
    vtu
}

#[derive(Debug, Deserialize)]
struct Terms {
    total: f64,
    constitutive: f64,
    equilibrium: f64,
    complementarity: f64,
    friction: f64,
}

#[derive(Debug, Deserialize)]
struct Source {
    source: String,
}

#[derive(Debug, Deserialize)]
struct Contact {
    active_length: f64,
}

#[derive(Debug, Deserialize)]
struct Report {
    norm: String,
    functional: Terms,
    energy: f64,
    relative: Option<f64>,
    stress: Source,
    contact: Contact,
    notes: Vec<String>,
    bound: BoundJson,
}

/// The report's bound (docs/design.md §8.2).
#[derive(Debug, Deserialize)]
struct BoundJson {
    guaranteed: bool,
    energy_error: Option<f64>,
    relative: Option<f64>,
    failed_hypotheses: Vec<String>,
}

/// Runs `fosls estimate` on the case with `extra` arguments: (exit code, stdout, stderr).
fn run_raw(c: &Case, extra: &[&str]) -> (Option<i32>, Vec<u8>, String) {
    let dir = tempfile::tempdir().unwrap();
    let vtu = write_case(dir.path(), c);
    let out = Command::new(env!("CARGO_BIN_EXE_fosls"))
        .arg("estimate")
        .arg(&vtu)
        .args(["--quiet", "--json", "-", "--timeout", "300"])
        .args(extra)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr).replace(&*vtu.to_string_lossy(), "FILE");
    (out.status.code(), out.stdout, stderr)
}

/// Runs `fosls estimate` on the case with `extra` arguments; the parsed JSON report.
fn run(c: &Case, extra: &[&str]) -> Report {
    let (code, stdout, stderr) = run_raw(c, extra);
    assert!(code == Some(0), "{c:?}: {stderr}");
    serde_json::from_slice(&stdout).unwrap()
}

/// F for the file's stress, used as it is.
fn file(c: &Case) -> Report {
    let r = run(c, &["--stress", "file", "--displacement", "file"]);
    assert_eq!(r.stress.source, "file");
    assert_eq!(r.norm, c.norm);
    r
}

/// The hand value of the constitutive term for the σ_xx perturbation (module doc).
fn perturbation_value(c: &Case) -> f64 {
    let fl = Field::new(c);
    let d = c.perturb * fl.s;
    let area = W * height(c);
    match c.norm {
        "energy" => 0.5 * d * d * (1.0 - c.nu) / (2.0 * fl.mu) * area,
        _ => fl.mu * (d / (2.0 * fl.mu)).powi(2) * ((1.0 - c.nu).powi(2) + c.nu * c.nu) * area,
    }
}

fn rel_err(got: f64, want: f64) -> f64 {
    (got - want).abs() / want.abs()
}

/// What the solver says when the reconstruction's quadratic form is singular.
const SINGULAR: &str =
    "is not determined by the functional (at ν = 0.5 a constant pressure is free";

const NUS: [f64; 6] = [0.0, 0.3, 0.49, 0.4999, 0.4999999, 0.5];

/// ν sweep: exact pairs give F/energy < 1e-20, the σ_xx perturbation its hand value to 1e-6.
#[test]
fn poisson_ratio_sweep_is_exact_and_matches_the_perturbation() {
    for nu in NUS {
        for norm in ["robust", "energy"] {
            if nu == 0.5 && norm == "energy" {
                continue; // λ = ∞: the energy preset is refused (tested in bad_input.rs)
            }
            let c = Case {
                nu,
                norm,
                ..Case::default()
            };
            let r = file(&c);
            let rel = r.functional.total.abs() / r.energy;
            assert!(rel < 1e-20, "ν = {nu} {norm}: F/energy = {rel:e}");
            assert!((r.contact.active_length - W).abs() < 1e-12, "{r:?}");
            let c = Case { perturb: 3.0, ..c };
            let r = file(&c);
            let want = perturbation_value(&c);
            let e = rel_err(r.functional.total, want);
            assert!(
                e < 1e-6,
                "ν = {nu} {norm}: F = {} vs {want}",
                r.functional.total
            );
            // All of it in the constitutive term.
            assert!(rel_err(r.functional.constitutive, want) < 1e-6, "{r:?}");
            assert!(r.functional.equilibrium.abs() < 1e-12 * want, "{r:?}");
            eprintln!("nu={nu} norm={norm}: exact F/energy={rel:.1e}, perturbed rel err={e:.1e}");
        }
    }
}

/// E sweep with fields scaled by E (u fixed, σ and f ∝ E): `relative` is invariant.
#[test]
fn youngs_modulus_sweep_keeps_the_relative_error() {
    let base = Case {
        perturb: 3.0,
        ..Case::default()
    };
    let reference = file(&base).relative.unwrap();
    // Hand value: relative² = F / energy, F from the perturbation; energy from the tool.
    for e in [1e-3, 1.0, 2.06e11, 1e12] {
        let c = Case { e, ..base.clone() };
        let r = file(&c);
        let rel = r.relative.unwrap();
        let d = rel_err(rel, reference);
        assert!(
            d < 1e-10,
            "E = {e:e}: relative {rel} vs {reference} ({d:e})"
        );
        let e_f = rel_err(r.functional.total, perturbation_value(&c));
        assert!(e_f < 1e-6, "E = {e:e}: F off by {e_f:e}");
        eprintln!("E={e:e}: relative={rel:.12e} (drift {d:.1e}), F rel err={e_f:.1e}");
    }
}

/// Gaps 0, 1e-12 and 1e-6 of the body size: the complementarity term is g (2a₀ + 2a₁).
#[test]
fn gap_sweep_matches_the_complementarity_term() {
    for rel_gap in [0.0, 1e-12, 1e-6] {
        let c = Case {
            gap: rel_gap * W,
            ..Case::default()
        };
        let r = file(&c);
        let (a, _) = Field::new(&c).contact();
        let want = c.gap * (2.0 * a[0] + 2.0 * a[1]);
        let got = r.functional.complementarity;
        if rel_gap == 0.0 {
            assert!(got.abs() < 1e-20 * r.energy, "{r:?}");
        } else {
            let e = rel_err(got, want);
            assert!(e < 1e-6, "gap {rel_gap:e}: {got} vs {want}");
            eprintln!("gap={rel_gap:e}: complementarity rel err={e:.1e}");
        }
        let rest = r.functional.total - got;
        assert!(rest.abs() < 1e-20 * r.energy, "{r:?}");
    }
}

/// Friction 0, 1e-8, 0.4, 10, 1e3 on the slipping bottom (σ_t = 0): the friction term is
/// 𝔉 |∫ |σ_n| u_t|; everything else stays exact.
#[test]
fn friction_sweep_matches_the_friction_term() {
    for fr in [0.0, 1e-8, 0.4, 10.0, 1e3] {
        let c = Case {
            friction: fr,
            ..Case::default()
        };
        let (a, b) = Field::new(&c).contact();
        // u_t = x (b₁ + b₂ x) keeps one sign on (0, 2].
        assert!(b[0] * (b[0] + 2.0 * b[1]) > 0.0);
        let integral = 2.0 * a[0] * b[0]
            + 8.0 / 3.0 * a[0] * b[1]
            + 8.0 / 3.0 * a[1] * b[0]
            + 4.0 * a[1] * b[1];
        let want = fr * integral.abs();
        let r = file(&c);
        let got = r.functional.friction;
        if fr == 0.0 {
            assert_eq!(got, 0.0);
        } else {
            let e = rel_err(got, want);
            assert!(e < 1e-6, "𝔉 = {fr:e}: {got} vs {want}");
            eprintln!("friction={fr:e}: friction term rel err={e:.1e}");
        }
        let rest = r.functional.total - got;
        assert!(rest.abs() < 1e-20 * r.energy, "{r:?}");
    }
}

/// Slivers: cells of aspect ratio 1e2 and 1e3 (1e4 in the slow test) hold the same exact field.
#[test]
fn sliver_cells_keep_exactness() {
    for aspect in [1e2, 1e3] {
        sliver(aspect);
    }
}

#[test]
#[ignore = "slow: run by .ci/run with --ignored"]
fn sliver_cells_keep_exactness_at_aspect_1e4() {
    sliver(1e4);
}

fn sliver(aspect: f64) {
    let c = Case {
        aspect,
        ..Case::default()
    };
    let r = file(&c);
    let rel = r.functional.total.abs() / r.energy;
    assert!(rel < 1e-20, "aspect {aspect:e}: F/energy = {rel:e}");
    let c = Case { perturb: 3.0, ..c };
    let r = file(&c);
    let e = rel_err(r.functional.total, perturbation_value(&c));
    assert!(e < 1e-6, "aspect {aspect:e}: perturbed F off by {e:e}");
    eprintln!("aspect={aspect:e}: exact F/energy={rel:.1e}, perturbed rel err={e:.1e}");
}

/// Γ_C fully active (the field above: σ_n < 0 and u_n = g = 0 on the whole bottom), fully
/// inactive (uniaxial stress σ = (K, 0, 0): σ_n = 0, gap 1e-3), and a single active edge (Γ_C is
/// the bottom edge [0, 0.5], gap 0, 𝔉 = 0.4: complementarity 0, friction
/// 𝔉 |a₀b₁/8 + a₀b₂/24 + a₁b₁/24 + a₁b₂/64|).
#[test]
fn contact_fully_active_fully_inactive_and_one_edge() {
    let r = file(&Case::default());
    assert!((r.contact.active_length - W).abs() < 1e-12, "{r:?}");

    let c = Case {
        uniaxial: true,
        gap: 1e-3,
        ..Case::default()
    };
    let r = file(&c);
    assert_eq!(r.contact.active_length, 0.0);
    assert!(r.functional.total.abs() < 1e-20 * r.energy, "{r:?}");
    // energy = ½ σ:ε |Ω| = ½ K²(1 − ν)/(2μ) · 2 (s = 1).
    let fl = Field::new(&c);
    let want = 0.5 * K * K * (1.0 - c.nu) / (2.0 * fl.mu) * W;
    let e = rel_err(r.energy, want);
    assert!(e < 1e-12, "inactive: energy {} vs {want}", r.energy);
    eprintln!(
        "inactive: F/energy={:.1e}, energy rel err={e:.1e}",
        r.functional.total.abs() / r.energy
    );

    let c = Case {
        contact_to: 0.5,
        friction: 0.4,
        ..Case::default()
    };
    let r = file(&c);
    assert!((r.contact.active_length - 0.5).abs() < 1e-12, "{r:?}");
    let (a, b) = Field::new(&c).contact();
    let fric = c.friction
        * (a[0] * b[0] / 8.0 + a[0] * b[1] / 24.0 + a[1] * b[0] / 24.0 + a[1] * b[1] / 64.0).abs();
    let ef = rel_err(r.functional.friction, fric);
    assert!(ef < 1e-6, "{r:?} vs {fric}");
    let rest = r.functional.total - r.functional.friction;
    assert!(rest.abs() < 1e-20 * r.energy, "{r:?}");
    eprintln!(
        "one edge: friction rel err={ef:.1e}, rest F/energy={:.1e}",
        rest.abs() / r.energy
    );
}

/// The reconstruction (`--stress reconstruct`, RT_1) on every case of the matrix: it converges
/// (or says it did not, with the KKT residual), never exceeds F of the file's admissible stress
/// (the minimiser over a set that contains it), and reproduces the exact stress where F = 0.
fn reconstruction_matrix(cases: &[Case]) {
    for c in cases {
        let given = file(c);
        let args = ["--stress", "reconstruct", "--displacement", "file"];
        if c.nu == 0.5 {
            // λ = ∞ with Dirichlet data and contact only: τ + cI has the same F for every
            // constant c (A(cI) = 0, div(cI) = 0, u_n = g on Γ_C), so the minimiser is not unique
            // and the tool must say so instead of returning one.
            let (code, _, stderr) = run_raw(c, &args);
            assert_eq!(code, Some(2), "{stderr}");
            assert!(
                stderr.starts_with("error: FILE: stress reconstruction: "),
                "{stderr}"
            );
            assert!(stderr.contains(SINGULAR), "{stderr}");
            eprintln!("reconstruct nu=0.5: refused: {}", stderr.trim_end());
            continue;
        }
        let r = run(c, &args);
        assert_eq!(r.stress.source, "reconstructed");
        let note = r
            .notes
            .iter()
            .find(|n| n.starts_with("stress reconstruction:"))
            .unwrap_or_else(|| panic!("{c:?}: no reconstruction note in {:?}", r.notes));
        let kkt: f64 = note
            .rsplit("KKT residual ")
            .next()
            .and_then(|t| t.split([' ', ';']).next())
            .and_then(|t| t.parse().ok())
            .unwrap_or_else(|| panic!("no KKT residual in {note}"));
        assert!(!note.contains("NOT converged"), "{c:?}: {note}");
        assert!(kkt < 1e-8, "{c:?}: {note}");
        let slack = 1e-12 * r.energy;
        assert!(
            r.functional.total <= given.functional.total + slack,
            "{c:?}: reconstructed F {} above the file's {}",
            r.functional.total,
            given.functional.total
        );
        let rel = r.functional.total / r.energy;
        let warned = r
            .notes
            .iter()
            .find(|n| n.starts_with("warning: stress reconstruction: condition estimate"));
        if given.functional.total.abs() < 1e-20 * given.energy {
            // Exact stress in the space: the minimiser reproduces it up to round-off, 1e-14
            // relative to the energy — or, where the tool warned about conditioning, up to the
            // square of the forward error bound κ u (F is a squared error). The printed
            // estimate is a lower bound of κ that stops within 0.8× of its settled value
            // (`solve::condition::SETTLED`), so κ is taken as estimate / 0.8.
            let allowed = match warned {
                None => 1e-14,
                Some(note) => {
                    let kappa: f64 = note
                        .trim_start_matches("warning: stress reconstruction: condition estimate ")
                        .split(' ')
                        .next()
                        .and_then(|t| t.parse().ok())
                        .unwrap_or_else(|| panic!("no estimate in {note}"));
                    (kappa / 0.8 * f64::EPSILON / 2.0).powi(2).max(1e-14)
                }
            };
            assert!(
                rel.abs() < allowed,
                "{c:?}: F/energy = {rel:e}, warning {warned:?}"
            );
        }
        eprintln!(
            "reconstruct nu={} E={:e} aspect={:e} gap={:e} friction={:e} uniaxial={} \
             contact_to={}: F/energy={rel:.1e} (file {:.1e}), KKT {kkt:.1e}, conditioning \
             warning: {warned:?}",
            c.nu,
            c.e,
            c.aspect,
            c.gap,
            c.friction,
            c.uniaxial,
            c.contact_to,
            given.functional.total / given.energy
        );
    }
}

fn matrix() -> Vec<Case> {
    let mut out = Vec::new();
    for nu in NUS {
        let norm = if nu == 0.5 { "robust" } else { "energy" };
        out.push(Case {
            nu,
            norm,
            ..Case::default()
        });
    }
    for e in [1e-3, 1.0, 2.06e11, 1e12] {
        out.push(Case {
            e,
            ..Case::default()
        });
    }
    for gap in [1e-12 * W, 1e-6 * W] {
        out.push(Case {
            gap,
            ..Case::default()
        });
    }
    for friction in [1e-8, 0.4, 10.0, 1e3] {
        out.push(Case {
            friction,
            ..Case::default()
        });
    }
    for aspect in [1e2, 1e3, 1e4] {
        out.push(Case {
            aspect,
            ..Case::default()
        });
    }
    out.push(Case {
        uniaxial: true,
        gap: 1e-3,
        ..Case::default()
    });
    out.push(Case {
        contact_to: 0.5,
        friction: 0.4,
        ..Case::default()
    });
    out
}

#[test]
fn reconstruction_on_a_few_extremes() {
    let m = matrix();
    // ν = 0.4999999, E = 1e12, 𝔉 = 1e3, aspect 1e3.
    reconstruction_matrix(&[m[4].clone(), m[9].clone(), m[15].clone(), m[17].clone()]);
}

#[test]
#[ignore = "slow: run by .ci/run with --ignored"]
fn reconstruction_on_the_whole_matrix() {
    reconstruction_matrix(&matrix());
}

/// The patch reconstruction and the bound on the matrix (issue 13): without a gap the pair is
/// exact and the bound is 0 to round-off; with a gap it is ≈ (½c)^½, c = g(2a₀ + 2a₁) the
/// complementarity; guaranteed without friction; with friction it is the Tresca problem's and never
/// guaranteed; at ν = 0.5 the patch path is refused with its reason.
fn patch_matrix(cases: &[Case]) {
    for c in cases {
        let args = ["--stress", "patch", "--displacement", "file"];
        if c.nu == 0.5 {
            let (code, _, stderr) = run_raw(c, &args);
            assert_eq!(code, Some(2), "{stderr}");
            assert!(
                stderr.contains("the patch reconstruction needs λ < ∞"),
                "{stderr}"
            );
            continue;
        }
        let r = run(c, &args);
        let b = &r.bound;
        let e = b
            .energy_error
            .unwrap_or_else(|| panic!("{c:?}: no bound: {:?}", b.failed_hypotheses));
        let (a, _) = Field::new(c).contact();
        let comp = if c.uniaxial {
            0.0
        } else {
            c.gap * (2.0 * a[0] + 2.0 * a[1])
        };
        let want = (0.5 * comp).sqrt();
        // Round-off of η_PS: the exact pair cancels to ~1e-16 of the stress, and near ν = 0.5
        // the compliance amplifies that by λ/μ = 2ν/(1 − 2ν) (1e7 at ν = 0.4999999).
        let lam_mu = 2.0 * c.nu / (1.0 - 2.0 * c.nu);
        // On slivers the patch problems' conditioning grows like the aspect ratio squared
        // (measured: relative 3.2e-7 at aspect 1e3 with the full patch problems, 1.5e-6 with the
        // interior values condensed, reconstruct/condense.rs); reliability (bound ≥ 0 = the
        // error) holds.
        let mut scale = r.energy.sqrt() * (1e-10 + 1e-15 * lam_mu + 1e-11 * c.aspect * c.aspect);
        if c.gap > 0.0 {
            // A gap pairs τ_n with g: a τ_n of round-off (the traction-free uniaxial bottom)
            // gives c ~ 1e-16 × energy, and the bound takes c^½.
            scale += (1e-14 * r.energy).sqrt();
        }
        // With a gap the pair is not a solution (σ_n < 0 where u_n < g): the bound carries the
        // complementarity, with the patch stress's pairing (which the patch QP trades against
        // η_PS) in place of the exact one: within 5 % of (½c)^½ (measured: 1.1 %).
        let slack = if comp > 0.0 { 0.05 } else { 1e-6 };
        // With friction the slipping bottom (σ_t = 0, u_t ≠ 0) is no Coulomb solution: the
        // friction pairing enters; only the Tresca label and finiteness are checked there.
        assert!(
            c.friction > 0.0 && e.is_finite() || (e - want).abs() <= slack * want + scale,
            "{c:?}: bound {e} against (½c)^½ = {want} (energy^½ {scale})"
        );
        if c.friction > 0.0 {
            assert!(!b.guaranteed, "{c:?}");
            assert!(
                b.failed_hypotheses[0].starts_with("Coulomb friction"),
                "{b:?}"
            );
        } else if c.aspect > 1.0 {
            // Round-off in div τ + f times K_T (1.2e4 at aspect 1e3) passes the 1e-8 cut for
            // uncertified terms: the only hypothesis allowed to fail on slivers.
            for h in &b.failed_hypotheses {
                assert!(h.starts_with("the local Korn constants"), "{c:?}: {h}");
            }
        } else if c.nu > 0.4999 {
            // The patch QP meets τ_t = 0 to its round-off, amplified by λ/μ = 1e7 here: σ_t
            // 5e-10 of the stress scale fails the 1e-10 admissibility check (a known limit).
            for h in &b.failed_hypotheses {
                assert!(h.starts_with("σ_h has tangential traction"), "{c:?}: {h}");
            }
        } else {
            assert!(b.guaranteed, "{c:?}: {:?}", b.failed_hypotheses);
        }
        eprintln!(
            "patch nu={} E={:e} aspect={:e} gap={:e} friction={:e} uniaxial={} contact_to={}: \
             bound {e:.3e} (hand {want:.3e}), relative {:?}, guaranteed {}",
            c.nu,
            c.e,
            c.aspect,
            c.gap,
            c.friction,
            c.uniaxial,
            c.contact_to,
            b.relative,
            b.guaranteed
        );
    }
}

#[test]
fn patch_bound_on_a_few_extremes() {
    let m = matrix();
    // ν = 0.4999999, ν = 0.5 (refused), E = 1e12, gap 1e-6, aspect 1e3, one contact edge.
    patch_matrix(&[
        m[4].clone(),
        m[5].clone(),
        m[9].clone(),
        m[11].clone(),
        m[17].clone(),
        m[20].clone(),
    ]);
}

#[test]
#[ignore = "slow: run by .ci/run with --ignored"]
fn patch_bound_on_the_whole_matrix() {
    patch_matrix(&matrix());
}

/// With a gap of 1e-6 the bound is (½c)^½ > 0 and E-independent relative to the energy:
/// `bound.relative` is the same to 1e-10 for E from 1e-3 to 1e12.
#[test]
fn patch_bound_relative_is_invariant_in_e() {
    let rel = |e: f64| {
        let c = Case {
            e,
            gap: 1e-6 * W,
            ..Case::default()
        };
        run(&c, &["--stress", "patch", "--displacement", "file"])
            .bound
            .relative
            .unwrap()
    };
    let reference = rel(20600.0);
    assert!(reference > 0.0);
    for e in [1e-3, 1.0, 2.06e11, 1e12] {
        let d = rel_err(rel(e), reference);
        assert!(d < 1e-10, "E = {e:e}: relative off by {d:e}");
    }
}

/// The conditioning warning of the aspect-1e4 sliver (κ ≈ 8e9 > 1e8) is a line of the text
/// report too, not only of the JSON notes; the well-shaped mesh (κ below 1e8) has none. (The
/// aspect-1e3 sliver, κ ≈ 5e8 with the whole system, drops below 1e8 once the interior DOFs are
/// condensed cell by cell, issue 13; its F stays exact to 3e-18 of the energy.)
#[test]
fn conditioning_warning_reaches_the_text_report() {
    for (aspect, warned) in [(1e4, true), (1.0, false)] {
        let dir = tempfile::tempdir().unwrap();
        let c = Case {
            aspect,
            ..Case::default()
        };
        let vtu = write_case(dir.path(), &c);
        let out = Command::new(env!("CARGO_BIN_EXE_fosls"))
            .arg("estimate")
            .arg(&vtu)
            .args(["--stress", "reconstruct"])
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(0));
        let text = String::from_utf8(out.stdout).unwrap();
        let line = text
            .lines()
            .find(|l| l.contains("warning: stress reconstruction: condition estimate"));
        assert_eq!(line.is_some(), warned, "aspect {aspect:e}:\n{text}");
        if let Some(l) = line {
            assert!(
                l.contains("> 1e8; the reconstructed field (and F) may have lost"),
                "{l}"
            );
        }
    }
}
