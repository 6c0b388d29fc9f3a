//! The `fosls` binary: parse, run, map errors to exit codes (0 done, 1 threshold exceeded,
//! 2 bad input or usage; docs/design.md §8).

mod cli;

use std::process::ExitCode;

use clap::Parser;

fn main() -> ExitCode {
    let args = cli::Cli::parse();
    match cli::run(args) {
        Ok(code) => code,
        Err(e) => {
            // One line: the library's errors already name the file, the place and the problem.
            let line = e.to_string().replace('\n', " ");
            eprintln!("error: {line}");
            ExitCode::from(2)
        }
    }
}
