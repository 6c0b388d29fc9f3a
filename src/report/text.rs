//! The terminal printer: the summary of docs/design.md §8, in sections.
//!
//! 1. Inputs: files, where each field came from (file or reconstructed, and why), the
//!    boundaries, notes.
//! 2. Admissibility: each kind of violation with its maximum, L² size and place.
//! 3. Functional: the four terms, their signed share of F and the negative parts of the
//!    boundary terms.
//! 4. Estimate: η = F^½, the energy and the relative error (F / energy)^½; undefined when
//!    F < 0, which only an inadmissible pair can give.
//! 5. Bound: its value, and whether it is guaranteed or which hypotheses failed.
//! 6. Worst cells: file cell index, η_T, η_T², share of F, dominant term.
//! 7. Contact zone: separated / stick / slip intervals, lengths and forces.
//! 8. Marking and time per stage, when present.
//!
//! Numbers have six significant digits ([`num`]); columns are aligned by padding to the widest
//! entry. No colours.

use std::fmt::Write as _;

use super::{FileCells, Run, WORST, cell_eta, dominant, mark, num, worst_cells};
use crate::estimate::{Estimate, Violation};
use crate::mesh::Mesh;
use crate::read::scene::Norm;

/// Significant digits of the numbers shown.
const SIG: usize = 6;

fn n(x: f64) -> String {
    num(x, SIG)
}

fn point(p: [f64; 2]) -> String {
    format!("({}, {})", n(p[0]), n(p[1]))
}

fn percent(part: f64, whole: f64) -> String {
    if whole != 0.0 && whole.is_finite() {
        format!("{:.2} %", 100.0 * part / whole)
    } else {
        "-".into()
    }
}

/// The relative difference (value − reference)/reference as "+1.23 %".
fn signed_percent(value: f64, reference: f64) -> String {
    if reference != 0.0 && reference.is_finite() {
        format!("{:+.2} %", 100.0 * (value - reference) / reference)
    } else {
        "-".into()
    }
}

/// Columns aligned by padding every cell to the widest entry of its column: `right[k]` says
/// whether column `k` is right-aligned (numbers). Each row is indented by `indent` spaces.
fn table(o: &mut String, indent: usize, right: &[bool], rows: &[Vec<String>]) {
    let cols = rows.iter().map(Vec::len).max().unwrap_or(0);
    let width: Vec<usize> = (0..cols)
        .map(|k| {
            rows.iter()
                .filter_map(|r| r.get(k))
                .map(|s| s.chars().count())
                .max()
                .unwrap_or(0)
        })
        .collect();
    for r in rows {
        let mut line = " ".repeat(indent);
        for (k, s) in r.iter().enumerate() {
            if k > 0 {
                line.push_str("  ");
            }
            let pad = " ".repeat(width[k] - s.chars().count());
            if right.get(k).copied().unwrap_or(false) {
                line.push_str(&pad);
                line.push_str(s);
            } else {
                line.push_str(s);
                line.push_str(&pad);
            }
        }
        let _ = writeln!(o, "{}", line.trim_end());
    }
}

/// The terminal summary of a run.
pub fn render(run: &Run, est: &Estimate, mesh: &Mesh) -> String {
    let mut o = String::new();
    let file_cell = |t: usize| mesh.file_cell.get(t).map_or(t, |&c| c as usize);
    let _ = writeln!(
        o,
        "fosls {}: FOSLS audit of {}",
        run.version,
        run.solution.display()
    );

    // The headline: what the numbers are about.
    let u_what = match (run.displacement.source.as_str(), run.projection_distance) {
        ("file", _) => "the file's displacement u_h".to_string(),
        (_, Some(d)) => format!(
            "the file's displacement u_h, projected onto K_u (distance ‖ũ_h − u_h‖_E = {}, \
             added to the error bound)",
            num(d, 3)
        ),
        _ => format!(
            "a displacement rebuilt from the file's stress ({})",
            run.displacement.space
        ),
    };
    let s_what = match run.stress.source.as_str() {
        "file" => "the file's stress".to_string(),
        _ => format!("the certificate stress σ_h: {}", run.stress.space),
    };
    match (est.eta, est.relative) {
        (Some(eta), Some(rel)) => {
            let _ = writeln!(
                o,
                "\nResult: η = F^½ = {} (relative error estimate {:.2} %) for {u_what}, measured \
                 against {s_what}.{}",
                n(eta),
                100.0 * rel,
                headline_bound(&est.bound)
            );
        }
        _ => {
            let _ = writeln!(
                o,
                "\nResult: F = {} < 0: the pair ({u_what}; {s_what}) is inadmissible, η is \
                 undefined (see Admissibility).",
                n(est.functional.total)
            );
        }
    }

    // 1. Inputs.
    let _ = writeln!(o, "\nInputs");
    let field = |f: &super::FieldInfo, extra: &str| {
        let name = if f.name.is_empty() {
            String::new()
        } else {
            format!("\"{}\" ", f.name)
        };
        let reason = if f.reason.is_empty() {
            String::new()
        } else {
            format!(" ({})", f.reason)
        };
        let source = match f.source.as_str() {
            "file" => "from the file".to_string(),
            s => s.to_string(),
        };
        format!("{name}{source}: {}{extra}{reason}", f.space)
    };
    let mut rows = vec![
        vec!["solution".into(), run.solution.display().to_string()],
        vec!["scene".into(), run.scene.display().to_string()],
        vec![
            "displacement".into(),
            field(
                &run.displacement,
                &format!(", degree {}", run.displacement_degree),
            ),
        ],
        vec!["stress".into(), field(&run.stress, "")],
    ];
    if let Some(d) = run.projection_distance {
        rows.push(vec![
            "projection".into(),
            format!(
                "‖ũ_h − u_h‖_E = {} (energy distance of the file's displacement from K_u, \
                 added to the error bound)",
                num(d, 6)
            ),
        ]);
    }
    rows.extend([vec![
        "mesh".into(),
        format!(
            "{} cells ({}), {} line cells",
            mesh.cells.len(),
            mesh.families()
                .iter()
                .map(|f| f.name())
                .collect::<Vec<_>>()
                .join(", "),
            mesh.lines.len()
        ),
    ]]);
    for b in &run.boundaries {
        rows.push(vec![
            "boundary".into(),
            format!(
                "{} ({}): {} edge{}, length {}",
                b.name,
                b.kind,
                b.edges,
                if b.edges == 1 { "" } else { "s" },
                n(b.length)
            ),
        ]);
    }
    for note in &run.notes {
        rows.push(vec!["note".into(), note.clone()]);
    }
    table(&mut o, 2, &[], &rows);

    // 2. Admissibility: the fields used and, where the estimate replaced one, the file's.
    let used = &est.admissibility;
    let file = run.file_admissibility.as_ref();
    let a = used;
    let cell_of = |v: &Violation| match (v.at, v.cell) {
        (Some(p), Some(t)) => format!("at {}, cell {}", point(p), file_cell(t)),
        (Some(p), None) => format!("at {}", point(p)),
        (None, Some(t)) => format!("cell {}", file_cell(t)),
        (None, None) => String::new(),
    };
    let value = |v: &Violation, real: bool| {
        if v.max <= 0.0 {
            "none".to_string()
        } else if real {
            format!("max {}  L² {}", n(v.max), n(v.l2))
        } else {
            format!("round-off ({})", n(v.max))
        }
    };
    let counted = |adm: &crate::estimate::Admissibility| adm.kinds().iter().filter(|k| k.3).count();
    let found = file.map_or(counted(used), |f| counted(&f.admissibility));
    let _ = writeln!(
        o,
        "\nAdmissibility: {} (above round-off: 1e-10 of max |u_h| or max |σ_h|)",
        if found == 0 {
            "no violation found".to_string()
        } else {
            format!(
                "{found} kind{} of violation{}",
                if found == 1 { "" } else { "s" },
                if file.is_some() {
                    " in the file's fields"
                } else {
                    ""
                }
            )
        }
    );
    let mut rows: Vec<Vec<String>> = Vec::new();
    match file {
        Some(f) => {
            rows.push(vec![
                String::new(),
                String::new(),
                format!(
                    "file ({}{})",
                    if f.displacement_from_file {
                        "u_h"
                    } else {
                        "u_h rebuilt"
                    },
                    if f.stress_from_file {
                        ", σ_h"
                    } else {
                        ", σ_h used"
                    }
                ),
                "used in F".into(),
                "where (file)".into(),
            ]);
            for (k, u) in f.admissibility.kinds().iter().zip(used.kinds()) {
                rows.push(vec![
                    k.0.to_string(),
                    k.1.to_string(),
                    value(k.2, k.3),
                    value(u.2, u.3),
                    if k.3 { cell_of(k.2) } else { String::new() },
                ]);
            }
        }
        None => {
            for k in used.kinds() {
                rows.push(vec![
                    k.0.to_string(),
                    k.1.to_string(),
                    value(k.2, k.3),
                    if k.3 { cell_of(k.2) } else { String::new() },
                ]);
            }
        }
    }
    table(&mut o, 2, &[], &rows);

    // 3. Functional.
    let f = &est.functional;
    let _ = writeln!(
        o,
        "\nFunctional F (norm {}, length scale ℓ = {})",
        est.norm,
        n(est.length_scale)
    );
    let _ = writeln!(
        o,
        "  norm {}: {}",
        est.norm,
        match est.norm {
            Norm::Energy => "constitutive term ½(C e, e) with e = ε(u_h) − Aσ_h: the energy norm",
            Norm::Robust => "constitutive term μ e:e: stays bounded as ν → 0.5 (incompressible)",
            Norm::Seed => "the talk's unweighted ½ e:e and ½‖div σ_h + f‖² (no material scaling)",
        }
    );
    let _ = writeln!(
        o,
        "  ℓ weights the equilibrium term ½ ℓ²/(2μ) ‖div σ_h + f‖² (default diam(Ω)/π); the \
         negative part of a boundary term is ∫ min(integrand, 0), nonzero only for an \
         inadmissible pair, so shares can exceed 100 %"
    );
    let mut rows = vec![vec![
        "term".to_string(),
        "value".into(),
        "share of F".into(),
        "negative part".into(),
    ]];
    for (name, v, neg) in [
        ("constitutive", f.constitutive, None),
        ("equilibrium", f.equilibrium, None),
        (
            "complementarity",
            f.complementarity,
            Some(a.complementarity_negative),
        ),
        ("friction", f.friction, Some(a.friction_negative)),
    ] {
        rows.push(vec![
            name.into(),
            n(v),
            percent(v, f.total),
            neg.map(n).unwrap_or_default(),
        ]);
    }
    rows.push(vec![
        "total F".into(),
        n(f.total),
        percent(f.total, f.total),
    ]);
    table(&mut o, 2, &[false, true, true, true], &rows);

    // 4. Estimate.
    let _ = writeln!(o, "\nEstimate");
    let energy_def = match est.norm {
        Norm::Energy => "½(Cε(u_h), ε(u_h))",
        Norm::Robust | Norm::Seed => "μ‖ε(u_h)‖²",
    };
    let mut rows = Vec::new();
    match est.eta {
        Some(eta) => rows.push(vec!["η = F^½".into(), n(eta)]),
        None => rows.push(vec![
            "η = F^½".into(),
            format!(
                "undefined: F = {} < 0, the pair (u_h, σ_h) is inadmissible \
                 (see Admissibility and the negative parts)",
                n(f.total)
            ),
        ]),
    }
    rows.push(vec![
        "energy".into(),
        format!("{} = {energy_def}", n(est.energy)),
    ]);
    match est.relative {
        Some(r) => rows.push(vec![
            "relative error".into(),
            format!("{} ({} %) = (F / energy)^½", n(r), num(100.0 * r, 4)),
        ]),
        None => rows.push(vec!["relative error".into(), "undefined".into()]),
    }
    table(&mut o, 2, &[], &rows);

    // 5. Bound.
    let b = &est.bound;
    let value = b.energy_error.map(n);
    let status = match (b.guaranteed, &value) {
        (true, Some(v)) => format!("guaranteed: (½|||u − u_h|||²)^½ ≤ {v}"),
        (true, None) => "guaranteed, but no value".into(),
        (false, Some(v)) => format!("NOT guaranteed: {v} (under the failed hypotheses below)"),
        (false, None) => "none".into(),
    };
    let _ = writeln!(
        o,
        "\nBound on the energy error (docs/design.md §6): {status}"
    );
    let _ = writeln!(o, "  {}", b.statement);
    if let Some(t) = &b.terms {
        let _ = writeln!(
            o,
            "  terms: Prager–Synge {}, complementarity {}, oscillation {}, asymmetry {}, \
             projection {} (Korn constant up to {})",
            n(t.prager_synge),
            n(t.complementarity),
            n(t.oscillation),
            n(t.asymmetry),
            n(t.projection),
            num(t.korn_max, 3)
        );
        if t.halves > 0.0 {
            let _ = writeln!(
                o,
                "  taken on a triangle split of the quadrilaterals: |||ũ_h − u_h||| = {} added \
                 (design §6.3)",
                n(t.halves)
            );
        }
        if t.copies > 0.0 {
            let _ = writeln!(
                o,
                "  u_h is discontinuous across cells (its node copies disagree): the bound is for \
                 the broken energy norm, |||ū_h − u_h|||_h = {} added to that of its average ū_h \
                 (design §4.2)",
                n(t.copies)
            );
        }
    }
    if let Some(r) = b.relative {
        let _ = writeln!(o, "  relative: {} ({} %)", n(r), num(100.0 * r, 4));
    }
    if !b.failed_hypotheses.is_empty() {
        let _ = writeln!(o, "  failed hypotheses:");
        for h in &b.failed_hypotheses {
            let _ = writeln!(o, "    - {h}");
        }
    }

    // 6. Worst cells.
    let files = FileCells::of(mesh);
    let c = &files.terms(&est.cells);
    let worst = worst_cells(c, WORST);
    let _ = writeln!(
        o,
        "\nWorst cells ({} of {}, by η_T; cell = index in the VTU file)",
        worst.len(),
        files.ids.len()
    );
    let mut rows = vec![vec![
        "rank".to_string(),
        "cell".into(),
        "η_T".into(),
        "η_T²".into(),
        "share of F".into(),
        "dominant term".into(),
    ]];
    for (r, &t) in worst.iter().enumerate() {
        let e2 = c.eta_squared(t);
        let (term, v) = dominant(c, t);
        let share = if e2 > 0.0 {
            format!("{term} ({})", percent(v, e2))
        } else {
            term.to_string()
        };
        rows.push(vec![
            (r + 1).to_string(),
            files.id(t).to_string(),
            n(cell_eta(c, t)),
            n(e2),
            if f.total > 0.0 {
                percent(e2, f.total)
            } else {
                "-".into()
            },
            share,
        ]);
    }
    table(&mut o, 2, &[true, true, true, true, true, false], &rows);

    // 7. Contact zone.
    let k = &est.contact;
    let has_contact = !k.intervals.is_empty() || run.boundaries.iter().any(|b| b.kind == "contact");
    if has_contact {
        let _ = writeln!(o, "\nContact zone");
        let mut rows = vec![vec![
            "boundary".to_string(),
            "state".into(),
            "from".into(),
            "to".into(),
            "length".into(),
        ]];
        for i in &k.intervals {
            rows.push(vec![
                i.boundary.clone(),
                super::json::state_name(i.state).into(),
                point(i.start),
                point(i.end),
                n(i.length),
            ]);
        }
        table(&mut o, 2, &[false, false, false, false, true], &rows);
        let _ = writeln!(
            o,
            "  active length {}, stick {}, slip {}",
            n(k.active_length),
            n(k.stick_length),
            n(k.slip_length)
        );
        match k.normal_force_from {
            crate::estimate::ForceSource::Displacement => {
                let _ = writeln!(
                    o,
                    "  normal force {} (the reaction of the file's displacement, as the solver \
                     computes it); the stress used carries ∫ -σ_n ds = {} ({})",
                    n(k.normal_force),
                    n(k.normal_force_stress),
                    signed_percent(k.normal_force_stress, k.normal_force)
                );
            }
            crate::estimate::ForceSource::Stress => {
                let _ = writeln!(o, "  normal force ∫ -σ_n ds = {}", n(k.normal_force));
            }
        }
        let _ = writeln!(o, "  tangential force ∫ σ_t ds = {}", n(k.tangential_force));
    } else {
        let _ = writeln!(o, "\nContact zone: none (the scene declares no contact)");
    }

    // 8. Marking and time.
    if let Some(m) = &run.marked {
        let e2 = super::eta_squared(c);
        let count = m.cells.iter().filter(|&&b| b).count();
        let _ = writeln!(o, "\nMarking (Dörfler, θ = {})", n(m.theta));
        let _ = writeln!(
            o,
            "  {count} of {} cells marked, holding {} of Σ max(η_T², 0)",
            m.cells.len(),
            percent(mark::share(&e2, &m.cells), 1.0)
        );
    }
    // Next step: where to refine.
    if c.constitutive.len() > 1 && run.marked.is_none() {
        let e2 = super::eta_squared(c);
        let marked = mark::dorfler(&e2, 0.5);
        let count = marked.iter().filter(|&&b| b).count();
        let (mut cx, mut cy, mut w) = (0.0, 0.0, 0.0);
        for (t, &m) in files.expand(&marked).iter().enumerate() {
            if m {
                let v = mesh.vertices(t);
                let k = v.len() as f64;
                for &p in v {
                    cx += mesh.points[p as usize][0] / k;
                    cy += mesh.points[p as usize][1] / k;
                }
                w += 1.0;
            }
        }
        if w > 0.0 {
            let _ = writeln!(
                o,
                "\nNext step\n  refine the {count} of {} cells that hold half of F (Dörfler θ = 0.5; their \
                 centre of mass is {}): `fosls estimate {} --mark 0.5 --output marked.vtu` writes \
                 them as cell data `marked`",
                marked.len(),
                point([cx / w, cy / w]),
                run.solution.display()
            );
        }
    }
    if !run.stages.is_empty() {
        let _ = writeln!(o, "\nTime");
        let mut rows: Vec<Vec<String>> = run
            .stages
            .iter()
            .map(|s| vec![s.name.clone(), format!("{:.3} s", s.seconds)])
            .collect();
        let total: f64 = run.stages.iter().map(|s| s.seconds).sum();
        rows.push(vec!["total".into(), format!("{total:.3} s")]);
        table(&mut o, 2, &[false, true], &rows);
    }
    o
}

/// The bound's sentence for the headline: what bounds what, or nothing without a bound.
fn headline_bound(b: &crate::estimate::Bound) -> String {
    match (b.energy_error, b.relative) {
        (Some(e), Some(r)) => format!(
            " Error bound: (½|||u − u_h|||²)^½ ≤ {} ({:.2} % of the energy^½), {}.",
            num(e, 6),
            100.0 * r,
            if b.guaranteed {
                "guaranteed"
            } else {
                "NOT guaranteed: see the failed hypotheses under Bound"
            }
        ),
        _ => String::new(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::report::{Marking, fixture};

    fn line<'a>(text: &'a str, start: &str) -> &'a str {
        text.lines()
            .find(|l| l.trim_start().starts_with(start))
            .unwrap_or_else(|| panic!("no line starting with {start:?} in\n{text}"))
    }

    fn words(l: &str) -> Vec<&str> {
        l.split_whitespace().collect()
    }

    #[test]
    fn summary_has_the_key_lines() {
        let data = fixture::dataset();
        let est = fixture::estimate();
        let mut run = fixture::run();
        run.marked = Some(Marking {
            theta: 0.5,
            cells: mark::dorfler(&super::super::eta_squared(&est.cells), 0.5),
        });
        let t = render(&run, &est, &data.mesh);
        println!("{t}");

        assert!(line(&t, "displacement").contains("\"displacement\" from the file: P1 nodal"));
        assert!(line(&t, "stress").contains("reconstructed: RT0 row-wise (global)"));
        assert!(line(&t, "stress").contains("(the file holds no stress)"));
        assert!(line(&t, "note").contains("1 vertex cell ignored"));
        assert!(line(&t, "boundary").contains("bottom (contact): 2 edges, length 1"));

        assert!(line(&t, "Admissibility").starts_with("Admissibility: 1 kind of violation ("));
        assert!(line(&t, "penetration").ends_with("max 0.0025  L² 0.00125  at (0.25, 0), cell 1"));
        assert!(line(&t, "tension").ends_with("none"));

        assert!(line(&t, "Functional").contains("norm energy, length scale ℓ = 0.25"));
        assert_eq!(
            words(line(&t, "constitutive")),
            ["constitutive", "5", "57.14", "%"]
        );
        assert_eq!(
            words(line(&t, "complementarity")),
            ["complementarity", "0", "0.00", "%", "-0.75"]
        );
        assert_eq!(
            words(line(&t, "total F")),
            ["total", "F", "8.75", "100.00", "%"]
        );

        assert!(line(&t, "η = F^½").ends_with(&num(8.75f64.sqrt(), 6)));
        assert!(line(&t, "energy").contains("875 = ½(Cε(u_h), ε(u_h))"));
        assert!(line(&t, "relative error").contains("0.1 (10 %)"));
        assert!(
            line(&t, "Bound").contains("NOT guaranteed: 9.5 (under the failed hypotheses below)")
        );
        assert!(line(&t, "- u_h").contains("penetrates the obstacle"));

        assert!(line(&t, "Worst cells").contains("5 of 5"));
        assert_eq!(
            words(line(&t, "1 ")),
            [
                "1",
                "2",
                "2",
                "4",
                "45.71",
                "%",
                "equilibrium",
                "(62.50",
                "%)"
            ]
        );
        assert_eq!(
            words(line(&t, "5 ")),
            ["5", "5", "0", "-0.5", "-5.71", "%", "constitutive"]
        );

        let stick = line(&t, "bottom    stick");
        assert_eq!(
            words(stick),
            ["bottom", "stick", "(0,", "0)", "(0.5,", "0)", "0.5"]
        );
        assert!(line(&t, "active length").ends_with("active length 0.5, stick 0.5, slip 0"));
        assert!(line(&t, "normal force").contains("∫ -σ_n ds = 12.5"));
        assert!(line(&t, "2 of 5 cells marked").contains("86.49 %"));
        assert_eq!(words(line(&t, "estimate")), ["estimate", "0.500", "s"]);
        assert_eq!(words(line(&t, "total  ")), ["total", "0.625", "s"]);
    }

    #[test]
    fn negative_functional_is_called_inadmissible() {
        let data = fixture::dataset();
        let mut est = fixture::estimate();
        est.functional.total = -0.25;
        est.eta = None;
        est.relative = None;
        est.bound = Default::default();
        est.contact = Default::default();
        let mut run = fixture::run();
        run.boundaries.clear();
        run.stages.clear();
        let t = render(&run, &est, &data.mesh);
        assert!(line(&t, "η = F^½").contains("undefined: F = -0.25 < 0"));
        assert!(line(&t, "η = F^½").contains("inadmissible"));
        assert!(line(&t, "relative error").ends_with("undefined"));
        assert!(line(&t, "Bound").ends_with(": none"));
        assert!(line(&t, "Contact zone").contains("none"));
        assert!(!t.contains("\nTime"));
        assert!(!t.contains("Marking"));
        // Shares of a negative F are signed.
        assert_eq!(
            words(line(&t, "constitutive")),
            ["constitutive", "5", "-2000.00", "%"]
        );
        // Share of F in the worst-cell table is meaningless when F ≤ 0.
        assert_eq!(words(line(&t, "1 "))[4], "-");
    }
}
