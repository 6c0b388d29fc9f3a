//! The estimate and the bound do not depend on the frame: a file turned about the origin gives
//! the same numbers (the energy error, the functional and the contact zone are invariant under
//! rigid motions of the whole problem), and a file moved far from the origin keeps them to its
//! coordinates' round-off without reporting that round-off as a violation.

mod common;

use std::path::{Path, PathBuf};

use common::cli::{estimate, root};
use fosls::read::vtu::read_vtu;
use fosls::report::json::Report;
use fosls::write::{Placement, write_vtu};

/// The angle (degrees) the files are turned by: no multiple of 90°, so every component mixes.
const ANGLE: f64 = 107.0;

/// x ↦ R x + shift, applied to the file and to the scene.
struct Motion {
    c: f64,
    s: f64,
    shift: [f64; 2],
}

impl Motion {
    fn new(degrees: f64, shift: [f64; 2]) -> Motion {
        let a = degrees.to_radians();
        Motion {
            c: a.cos(),
            s: a.sin(),
            shift,
        }
    }

    fn turn(&self, v: [f64; 2]) -> [f64; 2] {
        [self.c * v[0] - self.s * v[1], self.s * v[0] + self.c * v[1]]
    }

    /// R S Rᵀ for S = [[a, b], [d, e]].
    fn turn_tensor(&self, t: [[f64; 2]; 2]) -> [[f64; 2]; 2] {
        let rs = [self.turn([t[0][0], t[1][0]]), self.turn([t[0][1], t[1][1]])];
        // rs[j] is column j of R S; (R S Rᵀ)_ik = Σ_j (RS)_ij R_kj.
        let r = [[self.c, -self.s], [self.s, self.c]];
        let mut out = [[0.0; 2]; 2];
        for (i, row) in out.iter_mut().enumerate() {
            for (k, o) in row.iter_mut().enumerate() {
                *o = rs[0][i] * r[k][0] + rs[1][i] * r[k][1];
            }
        }
        out
    }

    /// A scene expression in the original coordinates, rewritten in the moved ones:
    /// x ↦ c(x − x₀) + s(y − y₀), y ↦ −s(x − x₀) + c(y − y₀).
    fn expression(&self, e: &str) -> String {
        let (c, s, [x0, y0]) = (self.c, self.s, self.shift);
        let bytes = e.as_bytes();
        let mut out = String::new();
        for (i, ch) in e.chars().enumerate() {
            let alone = |j: Option<usize>| {
                j.and_then(|j| bytes.get(j))
                    .is_none_or(|b| !b.is_ascii_alphanumeric() && *b != b'_')
            };
            let isolated = alone(i.checked_sub(1)) && alone(Some(i + 1));
            match ch {
                'x' if isolated => out += &format!("({c:e}*(x - {x0:e}) + {s:e}*(y - {y0:e}))"),
                'y' if isolated => out += &format!("({:e}*(x - {x0:e}) + {c:e}*(y - {y0:e}))", -s),
                _ => out.push(ch),
            }
        }
        out
    }
}

/// Replaces `from` (which must occur) by `to` everywhere in `text`.
fn replace(text: &str, from: &str, to: &str) -> String {
    assert!(text.contains(from), "the fixture's scene has no {from:?}");
    text.replace(from, to)
}

/// `fixtures/<case>` moved by `m` into a temporary folder: the points, the displacement and the
/// stress arrays named by the scene, and the scene's selectors, Dirichlet data and obstacle.
fn moved(case: &str, m: &Motion) -> (tempfile::TempDir, PathBuf) {
    let src = root().join("fixtures").join(case);
    let mut file = read_vtu(&src.join("solution.vtu")).unwrap();
    for p in &mut file.points {
        let q = m.turn([p[0], p[1]]);
        p[0] = q[0] + m.shift[0];
        p[1] = q[1] + m.shift[1];
    }
    let scene = std::fs::read_to_string(src.join("scene.toml")).unwrap();
    let field = |key: &str| {
        let line = scene
            .lines()
            .find(|l| l.starts_with(&format!("{key} =")))
            .unwrap_or_else(|| panic!("{case}: no {key} in the scene"));
        line.split('"').nth(1).unwrap().to_string()
    };
    let (u_name, s_name) = (field("displacement"), field("stress"));
    for a in &mut file.point_data {
        let (n, v) = (a.components, &mut a.values);
        if a.name == u_name {
            for t in v.chunks_mut(n) {
                let q = m.turn([t[0], t[1]]);
                t[0] = q[0];
                t[1] = q[1];
            }
        } else if a.name == s_name {
            for t in v.chunks_mut(n) {
                // Layouts: xx,yy,xy (the scene says so), xx,xy,yx,yy, and 3 × 3 row-major.
                let (ix, s2) = match n {
                    3 => ([0, 2, 2, 1], [[t[0], t[2]], [t[2], t[1]]]),
                    4 => ([0, 1, 2, 3], [[t[0], t[1]], [t[2], t[3]]]),
                    9 => ([0, 1, 3, 4], [[t[0], t[1]], [t[3], t[4]]]),
                    _ => panic!("{case}: stress with {n} components"),
                };
                let r = m.turn_tensor(s2);
                let flat = [r[0][0], r[0][1], r[1][0], r[1][1]];
                for (k, &i) in ix.iter().enumerate() {
                    t[i] = flat[k];
                }
                if n == 9 {
                    let (a, b) = (m.turn([t[2], t[5]]), m.turn([t[6], t[7]]));
                    [t[2], t[5], t[6], t[7]] = [a[0], a[1], b[0], b[1]];
                }
            }
        }
    }
    let d = m.turn([0.0, -0.01]);
    let nrm = m.turn([0.0, 1.0]);
    let mut text = replace(
        &scene,
        "displacement = [0.0, -0.01]",
        &format!("displacement = [{:e}, {:e}]", d[0], d[1]),
    );
    text = replace(
        &text,
        "obstacle = { plane = { point = [0.0, 0.0], normal = [0.0, 1.0] } }",
        &format!(
            "obstacle = {{ plane = {{ point = [{:e}, {:e}], normal = [{:e}, {:e}] }} }}",
            m.shift[0], m.shift[1], nrm[0], nrm[1]
        ),
    );
    let text: String = text
        .lines()
        .map(|l| match l.strip_prefix("where = \"") {
            Some(rest) => format!("where = \"{}\"\n", m.expression(rest.trim_end_matches('"'))),
            None => format!("{l}\n"),
        })
        .collect();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("solution.vtu");
    write_vtu(&path, &file, Placement::AppendedRaw).unwrap();
    std::fs::write(dir.path().join("scene.toml"), text).unwrap();
    (dir, path)
}

fn run(file: &Path) -> Report {
    let (code, report, err) = estimate(file, &[]);
    assert_eq!(code, 0, "{}: {err}", file.display());
    report.unwrap()
}

fn relative(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

/// Before the flows' rotation moments were taken about the mean of the points (they were about
/// the bounding box's centre, per its half-width) and the gap tolerances used |u_h|'s length (its
/// largest component before), the Hertz P1 file turned by 107° had one contact patch with
/// another active set: η and the bound moved by 1e-4 of themselves.
#[test]
fn a_turned_file_gives_the_same_estimate_and_bound() {
    let turn = Motion::new(ANGLE, [0.0, 0.0]);
    for case in [
        "hertz_skfem_p1",
        "hertz_skfem_p2",
        "hertz_ngsolve_p1",
        "hertz_ngsolve_p2",
    ] {
        let here = run(&root().join("fixtures").join(case).join("solution.vtu"));
        let (_dir, file) = moved(case, &turn);
        let there = run(&file);
        let (e0, e1) = (here.eta.unwrap(), there.eta.unwrap());
        assert!(relative(e1, e0) < 1e-7, "{case}: η {e0} → {e1}");
        let (b0, b1) = (here.bound, there.bound);
        let (x0, x1) = (b0.energy_error.unwrap(), b1.energy_error.unwrap());
        assert!(relative(x1, x0) < 1e-7, "{case}: bound {x0} → {x1}");
        assert_eq!(b0.guaranteed, b1.guaranteed, "{case}");
        let (l0, l1) = (here.contact.active_length, there.contact.active_length);
        assert!(relative(l1, l0) < 1e-7, "{case}: active length {l0} → {l1}");
    }
}

/// Gaps evaluated at |x| ≈ 3e4 carry ~1e-11 of round-off, above 1e-10 max |u_h| = 1e-12: the
/// Hertz P1 file moved there reported "u_h penetrates the obstacle (max 1.9e-12)". The
/// displacement checks now add 16 ε max |x| to their round-off level (tolerance.rs).
#[test]
fn a_file_far_from_the_origin_reports_no_round_off_penetration() {
    let far = Motion::new(ANGLE, [1e4, -3e4]);
    for case in ["hertz_skfem_p1", "hertz_skfem_p2"] {
        let here = run(&root().join("fixtures").join(case).join("solution.vtu"));
        let (_dir, file) = moved(case, &far);
        let there = run(&file);
        let b = there.bound;
        assert!(
            !b.failed_hypotheses.iter().any(|f| f.contains("penetrates")),
            "{case}: {:?}",
            b.failed_hypotheses
        );
        let (e0, e1) = (here.eta.unwrap(), there.eta.unwrap());
        // Coordinates known to 3e4·ε ≈ 7e-12 on cells of 1e-2: ~1e-9 of the geometry.
        assert!(relative(e1, e0) < 1e-6, "{case}: η {e0} → {e1}");
        let x0 = here.bound.energy_error.unwrap();
        let x1 = b.energy_error.unwrap();
        assert!(relative(x1, x0) < 1e-3, "{case}: bound {x0} → {x1}");
    }
}
