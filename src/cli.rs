//! Command line: arguments, the run of each subcommand, and exit codes (DESIGN.md §8).

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::{Parser, Subcommand};

use fosls::{Error, inspect, mesh, read, topology, write};

/// Audit finite element solutions of elastic contact problems with the FOSLS functional.
#[derive(Debug, Parser)]
#[command(name = "fosls", version, about)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// Show what a VTU file holds: cells, arrays and their ranges, boundary tags, geometry.
    Inspect {
        /// The VTU file.
        file: PathBuf,
        /// Also write the summary as JSON to this file (`-` for standard output).
        #[arg(long, value_name = "FILE")]
        json: Option<PathBuf>,
        /// Print nothing on success except what --json asks for.
        #[arg(long)]
        quiet: bool,
    },
    /// Rewrite a VTU file as binary zlib-compressed VTU (appended raw, or inline base64).
    Convert {
        /// The VTU file to read.
        input: PathBuf,
        /// The VTU file to write (never the input).
        output: PathBuf,
        /// Put the data inline (base64) instead of in one appended raw section.
        #[arg(long)]
        inline: bool,
    },
}

/// Runs the command; `Ok(code)` for completed runs, `Err` for bad input or usage (exit 2).
pub fn run(cli: Cli) -> anyhow::Result<ExitCode> {
    match cli.command {
        Command::Inspect { file, json, quiet } => inspect_file(&file, json.as_deref(), quiet),
        Command::Convert {
            input,
            output,
            inline,
        } => {
            check_output(&input, &output)?;
            let vtu = read::vtu::read_vtu(&input)?;
            let placement = if inline {
                write::Placement::Inline
            } else {
                write::Placement::AppendedRaw
            };
            write::write_vtu(&output, &vtu, placement)?;
            Ok(ExitCode::SUCCESS)
        }
    }
}

/// Refuses output paths that would overwrite the input.
fn check_output(input: &Path, output: &Path) -> Result<(), Error> {
    let same = match (input.canonicalize(), output.canonicalize()) {
        (Ok(a), Ok(b)) => a == b,
        _ => false,
    };
    if same {
        return Err(Error::Usage(format!(
            "{}: refusing to overwrite the input file",
            output.display()
        )));
    }
    Ok(())
}

fn write_json(path: &Path, value: &impl serde::Serialize) -> anyhow::Result<()> {
    let mut text = serde_json::to_string_pretty(value)?;
    text.push('\n');
    if path == Path::new("-") {
        std::io::stdout().write_all(text.as_bytes())?;
    } else {
        write::write_atomic(path, text.as_bytes())?;
    }
    Ok(())
}

fn inspect_file(file: &Path, json: Option<&Path>, quiet: bool) -> anyhow::Result<ExitCode> {
    if let Some(j) = json {
        check_output(file, j)?;
    }
    let vtu = read::vtu::read_vtu(file)?;
    let data = mesh::build(vtu.clone())?;
    let topo = topology::build(&data)?;
    let summary = inspect::summary(&vtu, &data, &topo);
    let to_stdout = json == Some(Path::new("-"));
    if !quiet && !to_stdout {
        print!("{}", inspect::render(&summary));
    }
    // Non-finite values make the file unusable: the text summary shows where they are, the
    // exit status says so, and no JSON is written for a failed run.
    if let Some((place, problem)) = inspect::first_nonfinite(&summary) {
        return Err(Error::input(file, place, problem).into());
    }
    if let Some(j) = json {
        write_json(j, &summary)?;
    }
    Ok(ExitCode::SUCCESS)
}
