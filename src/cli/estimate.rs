//! `fosls estimate`: parse → [`fosls::audit::run`] → write and print → exit status
//! (docs/design.md §8, §10). Exit status 0 done, 1 `--fail-above` exceeded or `--strict` check
//! failed, 2 bad input or usage.

use std::io::IsTerminal;
use std::path::Path;
use std::process::ExitCode;

use fosls::audit::{self, Options, Progress};
use fosls::read::scene::Norm;
use fosls::report;

use super::{EstimateArgs, NormArg, Source, check_output, write_json};

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
    }
}

/// Runs the estimate command.
pub fn run(args: &EstimateArgs) -> anyhow::Result<ExitCode> {
    for out in [args.json.as_deref(), args.output.as_deref()]
        .into_iter()
        .flatten()
    {
        if out != Path::new("-") {
            check_output(&args.file, out)?;
        }
    }
    if let Some(out) = &args.output {
        check_output(&args.file, &report::vtu::discontinuous_path(out))?;
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
        mark: args.mark,
    };
    opts.validate()?;
    let spinner = Spinner {
        quiet: args.quiet,
        bar: Default::default(),
    };
    let a = audit::run(&opts, &spinner)?;

    if let Some(out) = &args.output {
        audit::write_outputs(&a, out)?;
    }
    if let Some(j) = &args.json {
        let r = report::json::report(&a.run, &a.estimate, &a.data.mesh);
        write_json(j, &r)?;
    }
    let to_stdout = args.json.as_deref() == Some(Path::new("-"));
    if !args.quiet && !to_stdout {
        print!(
            "{}",
            report::text::render(&a.run, &a.estimate, &a.data.mesh)
        );
    }

    if let Some(x) = args.fail_above {
        let over = a.estimate.relative.is_none_or(|r| r > x);
        if over {
            if !args.quiet {
                eprintln!(
                    "fosls: relative error {} exceeds --fail-above {x}",
                    a.estimate
                        .relative
                        .map_or("undefined (F < 0)".into(), |r| format!("{r:.3e}"))
                );
            }
            return Ok(ExitCode::from(1));
        }
    }
    if args.strict && !a.failed.is_empty() {
        if !args.quiet {
            eprintln!("fosls: --strict: {}", a.failed.join("; "));
        }
        return Ok(ExitCode::from(1));
    }
    Ok(ExitCode::SUCCESS)
}
