//! The `fosls` binary: parse, run, map errors to exit codes (0 done, 1 threshold exceeded,
//! 2 bad input or usage; docs/design.md §8).

mod cli;

use std::process::ExitCode;

use clap::Parser;

fn main() -> ExitCode {
    fosls::write::stdio::guard_standard_streams(); // issue 14: before any file is opened
    let args = cli::Cli::parse();
    // issue 14: FOSLS_MAX_ALLOC, RAYON_NUM_THREADS and the thread pool, before any work.
    let checked = fosls::limits::check_environment().map_err(anyhow::Error::from);
    match checked.and_then(|()| cli::run(args)) {
        Ok(code) => code,
        Err(e) => {
            // One line: the library's errors already name the file, the place and the problem;
            // issue 14: written safely (control characters escaped, long values cut, no panic).
            fosls::write::stdio::error_line(&e.to_string());
            ExitCode::from(2)
        }
    }
}
