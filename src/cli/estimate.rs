//! `fosls estimate`: parse → [`fosls::audit::run`] → write and print → exit status
//! (docs/design.md §8, §10). Exit status 0 done, 1 `--fail-above` exceeded or `--strict` check
//! failed, 2 bad input or usage.

use std::io::IsTerminal;
use std::path::Path;
use std::process::ExitCode;

use fosls::audit::{self, Options, Progress};
use fosls::read::scene::Norm;
use fosls::report;

use super::{EstimateArgs, NormArg, Source};

/// A spinner on stderr for each stage, hidden when stderr is not a terminal or with --quiet.
struct Spinner {
    quiet: bool,
    bar: std::cell::RefCell<Option<indicatif::ProgressBar>>,
}

impl Progress for Spinner {
    fn stage(&self, what: &str) {
        fosls::limits::set_stage(what);
        if self.quiet || !std::io::stderr().is_terminal() {
            return;
        }
        let bar = indicatif::ProgressBar::new_spinner();
        bar.set_message(what.to_string());
        bar.enable_steady_tick(std::time::Duration::from_millis(120));
        *self.bar.borrow_mut() = Some(bar);
    }

    fn done(&self) {
        if let Some(b) = self.bar.borrow_mut().take() {
            b.finish_and_clear();
        }
    }
}

fn source(s: Source) -> audit::Source {
    match s {
        Source::Auto => audit::Source::Auto,
        Source::File => audit::Source::File,
        Source::Reconstruct => audit::Source::Reconstruct,
        Source::Patch => audit::Source::Patch,
        Source::Global => audit::Source::Global,
    }
}

/// Runs the estimate command.
pub fn run(args: &EstimateArgs) -> anyhow::Result<ExitCode> {
    // Every input and output path checked before the work; outputs appear only at the end
    // (docs/robustness.md, issue 14).
    let mut plan = fosls::write::OutputPlan::new();
    plan.input(&args.file, "input file")?;
    if let Ok(scene) = audit::find_scene(&args.file, args.scene.as_deref()) {
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
    if let Some(x) = args.fail_above
        && !x.is_finite()
    {
        return Err(fosls::Error::Usage(format!("--fail-above {x}: give a finite number")).into());
    }
    let opts = Options {
        file: args.file.clone(),
        scene: args.scene.clone(),
        norm: args.norm.map(|n| match n {
            NormArg::Energy => Norm::Energy,
            NormArg::Robust => Norm::Robust,
            NormArg::Seed => Norm::Seed,
        }),
        stress: source(args.stress),
        displacement: source(args.displacement),
        degree: args.degree,
        sweeps: args.sweeps,
        mark: args.mark,
        step: super::step_choice(args.step, args.time),
    };
    opts.validate()?;
    let spinner = Spinner {
        quiet: args.quiet,
        bar: Default::default(),
    };
    let a = audit::run(&opts, &spinner)?;

    fosls::limits::set_stage("writing the outputs");
    if let (Some(out), Some(id)) = (&args.output, vtu_out) {
        let (file, copy) = audit::output_files(&a, out);
        let placement = fosls::write::Placement::AppendedRaw;
        plan.stage_vtu(id, &file, placement)?;
        if let (Some(copy), Some(cid)) = (copy, copy_out) {
            plan.stage_vtu(cid, &copy, placement)?;
        }
    }
    if let Some(id) = json_out {
        let r = report::json::report(&a.run, &a.estimate, &a.data.mesh);
        plan.stage_json(id, &r)?;
    }
    let to_stdout = args.json.as_deref() == Some(Path::new("-"));
    if !args.quiet && !to_stdout {
        let text = report::text::render(&a.run, &a.estimate, &a.data.mesh);
        fosls::write::stdio::write_stdout_text(&text)?;
    }
    plan.commit()?;

    if let Some(x) = args.fail_above {
        let over = a.estimate.relative.is_none_or(|r| r.is_nan() || r > x);
        if over {
            if !args.quiet {
                fosls::write::stdio::note_line(&format!(
                    "fosls: relative error {} exceeds --fail-above {x}",
                    a.estimate
                        .relative
                        .map_or("undefined (F < 0)".into(), |r| format!("{r:.3e}"))
                ));
            }
            return Ok(ExitCode::from(1));
        }
    }
    if args.strict && !a.failed.is_empty() {
        if !args.quiet {
            fosls::write::stdio::note_line(&format!("fosls: --strict: {}", a.failed.join("; ")));
        }
        return Ok(ExitCode::from(1));
    }
    Ok(ExitCode::SUCCESS)
}
