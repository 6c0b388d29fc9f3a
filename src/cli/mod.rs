//! Command line: arguments, the run of each subcommand, and exit codes (docs/design.md §8).

mod estimate;

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Duration;

use clap::{Parser, Subcommand};

use fosls::read::container::StepChoice;
use fosls::{Error, inspect, limits, mesh, read, write};

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
        /// The solution (.vtu, .pvtu, .pvd, legacy .vtk, .xdmf).
        file: PathBuf,
        /// Time step of a .pvd or XDMF collection, by index (default: the last).
        #[arg(long, value_name = "N", conflicts_with = "time")]
        step: Option<usize>,
        /// Time step of a .pvd or XDMF collection: the one closest to this time.
        #[arg(long, value_name = "T")]
        time: Option<f64>,
        /// Also write the summary as JSON to this file (`-` for standard output).
        #[arg(long, value_name = "FILE")]
        json: Option<PathBuf>,
        /// Print nothing on success except what --json asks for.
        #[arg(long)]
        quiet: bool,
        /// Give up after this many seconds (exit status 2, no output file).
        #[arg(long, value_name = "SECONDS", value_parser = limits::parse_timeout)]
        timeout: Option<Duration>,
    },
    /// Evaluate the FOSLS functional of a solution: global estimate, indicators per cell,
    /// admissibility and the contact zone (docs/design.md §3–§8).
    Estimate(EstimateArgs),
    /// Write a starter scene for a solution file: its fields and layouts, its boundary parts
    /// (tags or bounding-box sides) with guessed kinds, material placeholders (docs/design.md
    /// §7). Then edit the lines marked EDIT and run `fosls estimate FILE`.
    Scene {
        /// The solution file.
        file: PathBuf,
        /// Where to write it (`-` for standard output); default `<file stem>.toml` beside the
        /// file. An existing file is never overwritten.
        #[arg(long, value_name = "FILE")]
        output: Option<PathBuf>,
        /// Give up after this many seconds (exit status 2, no output file).
        #[arg(long, value_name = "SECONDS", value_parser = limits::parse_timeout)]
        timeout: Option<Duration>,
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
        /// Give up after this many seconds (exit status 2, no output file).
        #[arg(long, value_name = "SECONDS", value_parser = limits::parse_timeout)]
        timeout: Option<Duration>,
    },
}

/// Where a field comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Source {
    /// Use the file's field when it is conforming, reconstruct otherwise.
    Auto,
    /// Use the file's field as it is.
    File,
    /// Rebuild the field from the other one (the stress: as `global`).
    Reconstruct,
    /// Stress only: the equilibrated reconstruction on vertex patches (the bound's stress).
    Patch,
    /// Stress only: the global FOSLS minimiser (the sharpest F, not a bound).
    Global,
}

/// Norm preset (overrides the scene's `[estimate] norm`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum NormArg {
    Energy,
    Robust,
    Seed,
}

#[derive(Debug, clap::Args)]
pub struct EstimateArgs {
    /// The solution (.vtu, .pvtu, .pvd, legacy .vtk, .xdmf).
    pub file: PathBuf,
    /// Time step of a .pvd or XDMF collection, by index (default: the last).
    #[arg(long, value_name = "N", conflicts_with = "time")]
    pub step: Option<usize>,
    /// Time step of a .pvd or XDMF collection: the one closest to this time.
    #[arg(long, value_name = "T")]
    pub time: Option<f64>,
    /// The scene (TOML); default: `<file stem>.toml` beside the file, else `scene.toml` there.
    #[arg(long, value_name = "FILE")]
    pub scene: Option<PathBuf>,
    /// Write the report as JSON to this file (`-` for standard output).
    #[arg(long, value_name = "FILE")]
    pub json: Option<PathBuf>,
    /// Write the mesh with per-cell indicators and contact states as VTU.
    #[arg(long, value_name = "FILE")]
    pub output: Option<PathBuf>,
    /// Norm preset (default: the scene's, else energy; robust at ν = 0.5).
    #[arg(long, value_enum)]
    pub norm: Option<NormArg>,
    /// Where the stress comes from.
    #[arg(long, value_enum, default_value = "auto")]
    pub stress: Source,
    /// Where the displacement comes from.
    #[arg(long, value_enum, default_value = "auto")]
    pub displacement: Source,
    /// Degree k of the RT_k stress reconstruction: 0 or 1, default displacement degree − 1;
    /// with `--stress patch` 1 or 2, default 2 (RT_2; on P1 with the weak symmetry).
    #[arg(long, value_name = "k")]
    pub degree: Option<usize>,
    /// Improvement sweeps of the patch stress over the vertex patches (default 0: the patch
    /// sum): each lowers the Prager–Synge term (one: 1–11 % lower bounds on the test families)
    /// and costs about half the patch stage.
    #[arg(long, value_name = "N")]
    pub sweeps: Option<usize>,
    /// Mark cells for refinement by Dörfler's bulk criterion with parameter θ ∈ (0, 1].
    #[arg(long, value_name = "θ")]
    pub mark: Option<f64>,
    /// Exit with status 1 when the relative error exceeds X.
    #[arg(long, value_name = "X", value_parser = limits::parse_finite)]
    pub fail_above: Option<f64>,
    /// Exit with status 1 when an admissibility check fails.
    #[arg(long)]
    pub strict: bool,
    /// Print nothing but errors (and what --json - asks for).
    #[arg(long)]
    pub quiet: bool,
    /// Give up after this many seconds: exit status 2 with one line naming the stage that was
    /// running; no output file is written.
    #[arg(long, value_name = "SECONDS", value_parser = limits::parse_timeout)]
    pub timeout: Option<Duration>,
}

/// Runs the command; `Ok(code)` for completed runs, `Err` for bad input or usage (exit 2).
pub fn run(cli: Cli) -> anyhow::Result<ExitCode> {
    let (timeout, name) = match &cli.command {
        Command::Inspect { timeout, .. } => (*timeout, "inspect"),
        Command::Estimate(args) => (args.timeout, "estimate"),
        Command::Convert { timeout, .. } => (*timeout, "convert"),
        Command::Scene { timeout, .. } => (*timeout, "scene"),
    };
    if let Some(limit) = timeout {
        limits::start_watchdog(limit, name);
    }
    match cli.command {
        Command::Inspect {
            file,
            step,
            time,
            json,
            quiet,
            ..
        } => inspect_file(&file, step_choice(step, time), json.as_deref(), quiet),
        Command::Estimate(args) => estimate::run(&args),
        Command::Scene { file, output, .. } => scene_file(&file, output.as_deref()),
        Command::Convert {
            input,
            output,
            inline,
            ..
        } => {
            // issue 14: output paths checked first, output published at the end.
            let mut plan = write::OutputPlan::new();
            plan.input(&input, "input file")?;
            let out = plan.output(&output, "the output")?;
            limits::set_stage("reading the input");
            let vtu = read::container::read_solution(&input, &Default::default())?;
            limits::set_stage("writing the output");
            let placement = if inline {
                write::Placement::Inline
            } else {
                write::Placement::AppendedRaw
            };
            plan.stage_vtu(out, &vtu, placement)?;
            plan.commit()?;
            Ok(ExitCode::SUCCESS)
        }
    }
}

/// `fosls scene`: the starter scene, written beside the file unless asked otherwise, never
/// over an existing file.
fn scene_file(file: &Path, output: Option<&Path>) -> anyhow::Result<ExitCode> {
    let target = output.map_or_else(|| file.with_extension("toml"), Path::to_path_buf);
    let mut plan = write::OutputPlan::new();
    plan.input(file, "input file")?;
    let id = plan.output(&target, "the scene")?;
    if target != Path::new("-") && target.exists() {
        return Err(Error::input(
            &target,
            "scene",
            "exists; fosls scene never overwrites a file (remove it or pass --output)",
        )
        .into());
    }
    limits::set_stage("reading the solution");
    let mut vtu = read::container::read_solution(file, &Default::default())?;
    read::components::detect(&mut vtu, &Default::default());
    let (data, topo) = fosls::closure::close(mesh::build(vtu)?)?;
    let name = file.file_name().map_or_else(
        || file.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    );
    let text = fosls::starter::starter_scene(&data, &topo, &name)?;
    plan.stage(id, text.as_bytes())?;
    plan.commit()?;
    if target != Path::new("-") {
        write::stdio::note_line(&format!("fosls: wrote {}", target.display()));
    }
    Ok(ExitCode::SUCCESS)
}

/// `--step N` or `--time T` (clap makes them exclusive).
pub(crate) fn step_choice(step: Option<usize>, time: Option<f64>) -> Option<StepChoice> {
    step.map(StepChoice::Index).or(time.map(StepChoice::Time))
}

fn inspect_file(
    file: &Path,
    step: Option<StepChoice>,
    json: Option<&Path>,
    quiet: bool,
) -> anyhow::Result<ExitCode> {
    // issue 14: output paths checked first, output published at the end.
    let mut plan = write::OutputPlan::new();
    plan.input(file, "input file")?;
    let json_out = json.map(|j| plan.output(j, "--json")).transpose()?;
    limits::set_stage("reading the solution");
    let vtu = read::container::read_solution(file, &read::container::ReadOptions { step })?;
    limits::set_stage("building the mesh");
    read::vtu::check_coordinates(&vtu)?; // issue 14
    // The mesh is built from the file with its component arrays joined, as `estimate` does,
    // so that the jumps of the joined fields show; the arrays listed are the file's own.
    let mut joined_vtu = vtu.clone();
    let joined = read::components::detect(&mut joined_vtu, &Default::default());
    let (data, topo) = fosls::closure::close(mesh::build(joined_vtu)?)?;
    limits::set_stage("summarising");
    let mut summary = inspect::summary(&vtu, &data, &topo);
    summary.joined = joined.notes;
    let to_stdout = json == Some(Path::new("-"));
    if !quiet && !to_stdout {
        write::stdio::write_stdout_text(&inspect::render(&summary))?; // issue 14
    }
    // Non-finite values make the file unusable: the text summary shows where they are, the
    // exit status says so, and no JSON is written for a failed run.
    if let Some((place, problem)) = inspect::first_nonfinite(&summary) {
        return Err(Error::input(file, place, problem).into());
    }
    if let Some(id) = json_out {
        plan.stage_json(id, &summary)?;
    }
    plan.commit()?; // issue 14
    Ok(ExitCode::SUCCESS)
}
