//! `fosls estimate`: read → mesh and fields → admissibility and terms → report
//! (DESIGN.md §1, §8). Exit status 0 done, 1 `--fail-above` exceeded or `--strict` check
//! failed, 2 bad input or usage.

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use fosls::element::rt::RtOrder;
use fosls::estimate::{self, Estimate, StressField};
use fosls::problem::{self, Stress};
use fosls::read::scene::{self, Norm, Scene};
use fosls::{Error, mesh, read, reconstruct, report, topology};

use super::{EstimateArgs, NormArg, Source};

/// The scene for `file`: `--scene`, else `<stem>.toml` beside it, else `scene.toml` there.
fn find_scene(file: &Path, given: Option<&Path>) -> Result<PathBuf, Error> {
    if let Some(s) = given {
        return Ok(s.to_path_buf());
    }
    let dir = file.parent().unwrap_or(Path::new("."));
    let stem = file.with_extension("toml");
    let shared = dir.join("scene.toml");
    for c in [&stem, &shared] {
        if c.is_file() {
            return Ok(c.clone());
        }
    }
    Err(Error::input(
        file,
        "scene",
        format!(
            "no scene file: neither {} nor {} exists; pass --scene FILE (a TOML file with \
             [material] youngs_modulus, poisson_ratio and one [[boundary]] per boundary part, \
             see README \"Scene file\"; `fosls inspect` lists the boundary tags)",
            stem.display(),
            shared.display()
        ),
    ))
}

/// A spinner on stderr for one stage, hidden when stderr is not a terminal or with --quiet.
fn stage(quiet: bool, what: &str) -> indicatif::ProgressBar {
    fosls::limits::set_stage(what);
    if quiet || !std::io::stderr().is_terminal() {
        return indicatif::ProgressBar::hidden();
    }
    let bar = indicatif::ProgressBar::new_spinner();
    bar.set_message(what.to_string());
    bar.enable_steady_tick(std::time::Duration::from_millis(120));
    bar
}

/// Whether a stress is symmetric to round-off: max |σxy − σyx| ≤ 1e-12 max |σ|.
fn symmetric(sigma: &[[f64; 4]]) -> bool {
    let (mut asym, mut max) = (0.0f64, 0.0f64);
    for s in sigma {
        asym = asym.max((s[1] - s[2]).abs());
        max = s.iter().fold(max, |m, v| m.max(v.abs()));
    }
    asym <= 1e-12 * max
}

/// Adds the rebuilt fields to the output file: the reconstructed stress as cell averages
/// (9 components, row-major, σ_zz = 0 as stored; one tuple per cell, zeros on lines) and the
/// projected displacement as point data.
fn add_reconstructed(
    file: &mut fosls::read::vtu::VtuFile,
    data: &mesh::Dataset,
    stress: Option<&reconstruct::stress::Reconstruction>,
    displacement: Option<(&str, &[[f64; 2]])>,
) {
    use fosls::read::{decode::Scalar, vtu::DataArray};
    let ncells = file.cell_count();
    if let Some(r) = stress {
        let mut values = vec![0.0; 9 * ncells];
        for t in 0..data.mesh.triangles.len() {
            let x = data.mesh.coords(t);
            // The centroid value is the cell average for the affine part of the field.
            let jac = fosls::element::map::Jacobian::new([
                [x[1][0] - x[0][0], x[2][0] - x[0][0]],
                [x[1][1] - x[0][1], x[2][1] - x[0][1]],
            ]);
            let (s, _) = r.stress.at(t, &jac, [1.0 / 3.0, 1.0 / 3.0]);
            values[9 * t..9 * t + 9].copy_from_slice(&report::vtu::tensor9(s));
        }
        file.cell_data
            .push(report::vtu::tensor_array("stress_reconstructed", values));
    }
    if let Some((name, u)) = displacement {
        file.point_data.push(DataArray {
            name: name.into(),
            scalar: Scalar::Float64,
            components: 2,
            component_names: vec!["x".into(), "y".into()],
            values: u.iter().flatten().copied().collect(),
        });
    }
}

/// Runs the estimate command.
pub fn run(args: &EstimateArgs) -> anyhow::Result<ExitCode> {
    // issue 14: every input and output path checked before the work (fosls::write::output).
    let mut plan = fosls::write::OutputPlan::new();
    plan.input(&args.file, "input file")?;
    if let Ok(scene) = find_scene(&args.file, args.scene.as_deref()) {
        plan.input(&scene, "scene file")?;
    }
    let json_out = args
        .json
        .as_deref()
        .map(|j| plan.output(j, "--json"))
        .transpose()?;
    let vtu_out = args
        .output
        .as_deref()
        .map(|o| plan.output_file(o, "--output"))
        .transpose()?;
    let copy_out = (args.output.as_deref())
        .map(|o| plan.optional_output(&report::vtu::discontinuous_path(o), "--output's copy"))
        .transpose()?;
    if let Some(theta) = args.mark {
        report::mark::check_theta(theta)?;
    }
    let mut stages: Vec<(String, f64)> = Vec::new();
    let mut clock = Instant::now();
    let mut lap = |name: &str, stages: &mut Vec<(String, f64)>| {
        stages.push((name.to_string(), clock.elapsed().as_secs_f64()));
        clock = Instant::now();
    };

    let bar = stage(args.quiet, "reading the solution");
    let vtu = read::vtu::read_vtu(&args.file)?;
    read::vtu::check_coordinates(&vtu)?; // issue 14
    let data = mesh::build(vtu)?;
    let topo = topology::build(&data)?;
    bar.finish_and_clear();
    lap("read", &mut stages);

    fosls::limits::set_stage("reading the scene"); // issue 14
    let scene_path = find_scene(&args.file, args.scene.as_deref())?;
    let scene: Scene = scene::load_scene(&scene_path)?;
    let line_cell = |l: usize| data.mesh.line_cell[l] as usize; // issue 14: tags as inspect
    read::vtu::check_tags(
        &args.file,
        &data.line_data,
        scene.tag_array_name(),
        line_cell,
    )?;
    let norm = match args.norm {
        None => scene.effective_norm(),
        Some(NormArg::Energy) if scene.material.is_incompressible() => {
            return Err(Error::Usage(
                "--norm energy: ν = 0.5 needs --norm robust or seed (DESIGN.md §3)".into(),
            )
            .into());
        }
        Some(NormArg::Energy) => Norm::Energy,
        Some(NormArg::Robust) => Norm::Robust,
        Some(NormArg::Seed) => Norm::Seed,
    };
    let fields = problem::select_fields(&data, &scene)?;
    let boundaries = problem::classify(&data, &topo, &scene)?;
    lap("scene and fields", &mut stages);

    let length_scale = scene
        .estimate
        .length_scale
        .unwrap_or_else(|| estimate::diameter(&data.mesh.points) / std::f64::consts::PI);
    // The displacement: the file's, projected onto K_u in the energy norm when it penetrates
    // or misses the Dirichlet data at the nodes (DESIGN.md §5) unless --displacement file; or
    // rebuilt from the file's nodal stress when the file holds none or it is asked for.
    let file_u: Option<&[[f64; 2]]> = fields.displacement.as_deref();
    let rebuild_reason = match (file_u, args.displacement) {
        (None, Source::File) => {
            return Err(Error::input(
                &args.file,
                "displacement",
                "--displacement file: the file holds no displacement",
            )
            .into());
        }
        (None, _) => Some("the file holds no displacement".to_string()),
        (Some(_), Source::Reconstruct) => {
            Some("asked for with --displacement reconstruct".to_string())
        }
        (Some(_), _) => None,
    };
    let rebuilt = match &rebuild_reason {
        None => None,
        Some(_) => {
            if args.stress == Source::Reconstruct {
                return Err(Error::Usage(
                    "--stress reconstruct: the displacement is reconstructed from the file's \
                     stress, so the stress cannot be reconstructed too"
                        .into(),
                )
                .into());
            }
            let Stress::Nodal { values, .. } = &fields.stress else {
                return Err(Error::input(
                    &args.file,
                    "stress",
                    "--displacement reconstruct: the displacement is rebuilt from the stress, \
                     which must be a nodal (point-data) stress; this file has none",
                )
                .into());
            };
            let bar = stage(args.quiet, "reconstructing the displacement");
            let r = reconstruct::displacement::reconstruct(
                &reconstruct::displacement::ReconstructInput {
                    mesh: &data.mesh,
                    topo: &topo,
                    scene: &scene,
                    edges: &boundaries.edges,
                    sigma: StressField::Nodal(values),
                    norm,
                },
            )
            .map_err(|problem| Error::input(&args.file, "displacement reconstruction", problem))?;
            bar.finish_and_clear();
            lap("reconstruct displacement", &mut stages);
            Some(r)
        }
    };
    let violations = file_u.map_or(0, |fu| {
        reconstruct::displacement::nodal_violations(
            &data.mesh,
            &topo,
            &scene,
            &boundaries.edges,
            fu,
        )
    });
    let projection = match file_u {
        Some(fu) if rebuilt.is_none() && violations > 0 && args.displacement == Source::Auto => {
            let bar = stage(args.quiet, "projecting the displacement onto K_u");
            let p = reconstruct::displacement::project(
                &data.mesh,
                &topo,
                &scene,
                &boundaries.edges,
                fu,
                length_scale,
            )
            .map_err(|problem| Error::input(&args.file, "displacement projection", problem))?;
            bar.finish_and_clear();
            lap("project displacement", &mut stages);
            Some(p)
        }
        _ => None,
    };
    let u: &[[f64; 2]] = match (&rebuilt, &projection, file_u) {
        (Some(r), _, _) => &r.displacement,
        (None, Some(p), _) => &p.displacement,
        (None, None, Some(fu)) => fu,
        (None, None, None) => unreachable!("an absent displacement is reconstructed"),
    };

    let degree = match args.degree {
        Some(k) if k <= 1 => k,
        Some(k) => {
            return Err(Error::Usage(format!("--degree {k}: RT_0 and RT_1 are available")).into());
        }
        None => data.mesh.degree - 1,
    };
    let order = if degree == 0 {
        RtOrder::Rt0
    } else {
        RtOrder::Rt1
    };
    let frictional = scene
        .boundaries
        .iter()
        .any(|b| b.contact().is_some_and(|c| c.friction > 0.0));
    let reconstruct_reason = match (&fields.stress, args.stress) {
        (_, Source::Reconstruct) => Some("asked for with --stress reconstruct".to_string()),
        // A conforming but inadmissible stress (tension, traction outside the cone, wrong
        // traction data) is rebuilt in K_σ under `auto` (DESIGN.md §5).
        (Stress::Nodal { values, name, .. }, Source::Auto) => {
            let field = StressField::Nodal(values);
            let check = estimate::boundary::boundary(&estimate::boundary::Input {
                mesh: &data.mesh,
                u,
                sigma: field,
                scene: &scene,
                edges: &boundaries.edges,
            });
            let failures: Vec<String> = estimate::failed_checks(
                &check.admissibility,
                u,
                field.scale(&data.mesh),
                frictional,
            )
            .into_iter()
            .filter(|f| f.starts_with("σ_h"))
            .collect();
            (!failures.is_empty()).then(|| {
                format!(
                    "the file's stress \"{name}\" is not in K_σ: {}",
                    failures.join("; ")
                )
            })
        }
        (Stress::Nodal { .. }, Source::File) => None,
        (Stress::Cell { name, .. }, Source::Auto) => Some(format!(
            "\"{name}\" is cell data (piecewise constant), not H(div)-conforming"
        )),
        (Stress::Cell { name, .. }, Source::File) => {
            return Err(Error::input(
                &args.file,
                format!("cell array \"{name}\""),
                "--stress file: a cell-data stress is not H(div)-conforming and cannot be \
                 evaluated as is (use --stress auto or reconstruct)",
            )
            .into());
        }
        (Stress::Absent, Source::File) => {
            return Err(Error::input(
                &args.file,
                "stress",
                "--stress file: the file holds no stress field",
            )
            .into());
        }
        (Stress::Absent, Source::Auto) => Some("the file holds no stress".to_string()),
    };
    let reconstruction = match &reconstruct_reason {
        None => None,
        Some(_) => {
            let bar = stage(args.quiet, "reconstructing the stress");
            let r = reconstruct::stress::reconstruct(&reconstruct::stress::Input {
                mesh: &data.mesh,
                topo: &topo,
                scene: &scene,
                u,
                edges: &boundaries.edges,
                norm,
                length_scale,
                order,
            })
            .map_err(|problem| Error::input(&args.file, "stress reconstruction", problem))?;
            bar.finish_and_clear();
            lap("reconstruct stress", &mut stages);
            Some(r)
        }
    };
    let (sigma, stress_info, symmetric) = match (&fields.stress, &reconstruction) {
        (_, Some(r)) => (
            StressField::Rt(&r.stress),
            report::FieldInfo {
                source: "reconstructed".into(),
                name: String::new(),
                space: format!("RT_{degree} row-wise (global minimiser of F)"),
                reason: reconstruct_reason.clone().unwrap_or_default(),
            },
            false,
        ),
        (
            Stress::Nodal {
                values,
                name,
                layout,
            },
            None,
        ) => (
            StressField::Nodal(values),
            report::FieldInfo {
                source: "file".into(),
                name: name.clone(),
                space: format!(
                    "P{} nodal, continuous (H(div)-conforming), layout {layout}",
                    data.mesh.degree
                ),
                reason: "conforming nodal stress, used as is".into(),
            },
            symmetric(values),
        ),
        _ => unreachable!("a stress that is not nodal is reconstructed"),
    };

    let bar = stage(args.quiet, "evaluating the functional");
    let mut est: Estimate = estimate::run(&estimate::Input {
        mesh: &data.mesh,
        scene: &scene,
        u,
        sigma,
        edges: &boundaries.edges,
        norm,
        symmetric_stress: symmetric,
    });
    // The findings on the displacement are the file's (what the user must hear about); F and
    // the rest use the projection.
    let mut projected_findings = None;
    if let (Some(_), Some(fu)) = (&projection, file_u) {
        let file = estimate::boundary::boundary(&estimate::boundary::Input {
            mesh: &data.mesh,
            u: fu,
            sigma,
            scene: &scene,
            edges: &boundaries.edges,
        });
        projected_findings = Some((
            est.admissibility.penetration.max,
            est.admissibility.dirichlet.max,
        ));
        est.admissibility.penetration = file.admissibility.penetration;
        est.admissibility.dirichlet = file.admissibility.dirichlet;
    }
    bar.finish_and_clear();
    lap("evaluate", &mut stages);

    let marked = args.mark.map(|theta| report::Marking {
        theta,
        cells: report::mark::dorfler(&report::eta_squared(&est.cells), theta),
    });
    let mut notes = fields.notes.clone();
    notes.extend(boundaries.notes.iter().cloned());
    if let Some(m) = &data.report.merge {
        notes.push(format!(
            "{}: {} node copies merged into {} nodes",
            if m.exploded {
                "exploded mesh"
            } else {
                "pieces"
            },
            m.points_in_file,
            m.points_merged
        ));
    }
    let failed = estimate::failed_checks(
        &est.admissibility,
        file_u.unwrap_or(u),
        sigma.scale(&data.mesh),
        frictional,
    );
    if let Some(p) = &projection {
        notes.push(format!(
            "displacement projected onto K_u: {} inadmissible nodes; {} active contact \
             constraints, {} iterations, KKT residual {:.2e}; ‖ũ_h − u_h‖_E = {:.6e}",
            p.violations, p.info.active, p.info.iterations, p.info.kkt_residual, p.distance
        ));
        notes.extend(reconstruct::condition::warning(
            &p.info,
            "displacement projection",
        ));
        if let Some((pen, dir)) = projected_findings {
            notes.push(format!(
                "after the projection: penetration max {pen:.3e} (between nodes: the \
                 constraint holds at the nodes), Dirichlet mismatch max {dir:.3e}; the \
                 admissibility table shows the file's displacement"
            ));
        }
    }
    if let Some(r) = &rebuilt {
        notes.push(format!(
            "displacement reconstruction: {} unknowns, {} active-set iterations, {} active \
             contact constraints, KKT residual {:.2e}{}",
            r.info.unknowns,
            r.info.iterations,
            r.info.active,
            r.info.kkt_residual,
            if r.stick + r.slip > 0 {
                format!(
                    "; friction (v_t split into a − b ≥ 0): {} QP solves{}, {} stick and {} slip \
                     nodes, {} held at v_t = 0 by the remedy (sign change of v_t inside an edge)",
                    r.friction_iterations,
                    if r.friction_converged {
                        ""
                    } else {
                        " (NOT settled: cap on the remedy rounds)"
                    },
                    r.stick,
                    r.slip,
                    r.remedied
                )
            } else {
                String::new()
            }
        ));
        notes.extend(reconstruct::condition::warning(
            &r.info,
            "displacement reconstruction",
        ));
    }
    if let Some(r) = &reconstruction {
        notes.push(format!(
            "stress reconstruction: {} unknowns, {} nonzeros, {} active-set iterations{}, {} \
             active contact constraints, KKT residual {:.2e}",
            r.info.unknowns,
            r.info.nonzeros,
            r.info.iterations,
            if r.info.converged {
                ""
            } else {
                " (NOT converged: iteration cap)"
            },
            r.info.active,
            r.info.kkt_residual
        ));
        notes.extend(reconstruct::condition::warning(
            &r.info,
            "stress reconstruction",
        ));
    }
    let run = report::Run {
        solution: args.file.clone(),
        scene: scene_path,
        version: env!("CARGO_PKG_VERSION"),
        displacement: report::FieldInfo {
            source: if projection.is_some() || rebuilt.is_some() {
                "reconstructed"
            } else {
                "file"
            }
            .into(),
            name: fields.displacement_name.clone().unwrap_or_default(),
            space: if rebuilt.is_some() {
                format!(
                    "P{} nodal (minimiser of F(·, σ_h) on K_u)",
                    data.mesh.degree
                )
            } else {
                format!("P{} nodal", data.mesh.degree)
            },
            reason: match (&rebuild_reason, &projection) {
                (Some(why), _) => why.clone(),
                (None, Some(p)) => format!(
                    "projected onto K_u in the energy norm: {} nodes penetrate the obstacle or \
                     miss the Dirichlet data",
                    p.violations
                ),
                (None, None) if violations > 0 => format!(
                    "used as is (--displacement file) although {violations} nodes are \
                     inadmissible"
                ),
                (None, None) => "conforming and admissible at the nodes, used as is".into(),
            },
        },
        displacement_degree: data.mesh.degree,
        stress: stress_info,
        notes,
        stages: stages
            .iter()
            .map(|(name, seconds)| report::Stage {
                name: name.clone(),
                seconds: *seconds,
            })
            .collect(),
        boundaries: boundaries
            .per_boundary
            .iter()
            .zip(&scene.boundaries)
            .map(|(s, b)| report::BoundaryInfo {
                name: s.name.clone(),
                kind: b.kind.as_str().to_string(),
                edges: s.edges,
                length: s.length,
            })
            .collect(),
        marked,
        projection_distance: projection.as_ref().map(|p| p.distance),
    };

    if let Some(out) = &args.output {
        let cells = run.marked.as_ref().map(|m| m.cells.as_slice());
        let mut file = report::vtu::output_file(out, &data, &est, cells);
        let displacement = match (&rebuilt, &projection) {
            (Some(r), _) => Some(("displacement_reconstructed", r.displacement.as_slice())),
            (None, Some(p)) => Some(("displacement_projected", p.displacement.as_slice())),
            _ => None,
        };
        add_reconstructed(&mut file, &data, reconstruction.as_ref(), displacement);
        let placement = fosls::write::Placement::AppendedRaw;
        if let Some(id) = vtu_out {
            plan.stage_vtu(id, &file, placement)?; // issue 14
        }
        if reconstruction.is_some() || rebuilt.is_some() || projection.is_some() {
            let copy = report::vtu::discontinuous_path(out);
            let file = report::vtu::discontinuous_file(&copy, &data.mesh, sigma, u, &est);
            if let Some(id) = copy_out {
                plan.stage_vtu(id, &file, placement)?; // issue 14
            }
        }
    }
    if let Some(id) = json_out {
        let r = report::json::report(&run, &est, &data.mesh);
        plan.stage_json(id, &r)?; // issue 14
    }
    let to_stdout = args.json.as_deref() == Some(Path::new("-"));
    if !args.quiet && !to_stdout {
        let text = report::text::render(&run, &est, &data.mesh);
        fosls::write::stdio::write_stdout_text(&text)?; // issue 14
    }
    plan.commit()?; // issue 14: outputs appear only now

    if let Some(x) = args.fail_above {
        let over = est.relative.is_none_or(|r| r.is_nan() || r > x); // issue 14: NaN exceeds
        if over {
            if !args.quiet {
                fosls::write::stdio::note_line(&format!(
                    "fosls: relative error {} exceeds --fail-above {x}",
                    est.relative
                        .map_or("undefined (F < 0)".into(), |r| format!("{r:.3e}"))
                ));
            }
            return Ok(ExitCode::from(1));
        }
    }
    if args.strict && !failed.is_empty() {
        if !args.quiet {
            fosls::write::stdio::note_line(&format!("fosls: --strict: {}", failed.join("; ")));
        }
        return Ok(ExitCode::from(1));
    }
    Ok(ExitCode::SUCCESS)
}
