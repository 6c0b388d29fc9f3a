//! Standard output and standard error that never panic.
//!
//! `print!` panics when standard output fails (a closed pipe, `/dev/full`), and Rust's
//! `std::io::stdout` silently discards everything when file descriptor 1 is closed. Here:
//!
//! - whether descriptor 1 was closed is recorded before `main` runs (a constructor in
//!   `.init_array`: Rust's runtime then opens `/dev/null` on closed standard descriptors, so
//!   that no file fosls opens later becomes "standard output", and writes to it would vanish);
//!   [`guard_standard_streams`], called first thing in `main`, fills any hole left;
//! - [`write_stdout`] writes and flushes, returning an error naming "standard output" for a
//!   broken pipe, a full disk or a closed descriptor;
//! - [`error_line`] and [`note_line`] write one line to standard error, made safe for a
//!   terminal ([`crate::error::clean_line`]), and ignore failures (there is nowhere left to
//!   report them).

use std::io::Write;
use std::os::fd::AsFd;
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};

use crate::error::{Error, Result};

static STDOUT_CLOSED: AtomicBool = AtomicBool::new(false);

/// Runs before Rust's runtime replaces closed standard descriptors with `/dev/null`: records
/// whether descriptor 1 is open (`/proc/self/fd/1` exists; without `/proc`, it counts as open).
extern "C" fn probe_stdout() {
    if let Err(e) = std::fs::symlink_metadata("/proc/self/fd/1")
        && e.kind() == std::io::ErrorKind::NotFound
        && std::fs::symlink_metadata("/proc/self/fd").is_ok()
    {
        STDOUT_CLOSED.store(true, Ordering::SeqCst);
    }
}

#[used]
#[unsafe(link_section = ".init_array")]
static PROBE_STDOUT: extern "C" fn() = probe_stdout;

/// The name standard output has in messages.
pub const STDOUT_NAME: &str = "standard output";

fn is_open(fd: i32) -> bool {
    let borrowed = match fd {
        0 => std::io::stdin().as_fd().try_clone_to_owned(),
        1 => std::io::stdout().as_fd().try_clone_to_owned(),
        _ => std::io::stderr().as_fd().try_clone_to_owned(),
    };
    // dup(2) of a closed descriptor fails with EBADF; the duplicate is closed on drop.
    borrowed.is_ok()
}

/// Fills closed standard descriptors with `/dev/null` and records whether standard output was
/// closed (then [`write_stdout`] fails). Call before any file is opened.
pub fn guard_standard_streams() {
    // Keeps the constructor (and so the record made before `main`) in the binary.
    std::hint::black_box(&PROBE_STDOUT);
    let closed: Vec<i32> = (0..3).filter(|&fd| !is_open(fd)).collect();
    if closed.contains(&1) {
        STDOUT_CLOSED.store(true, Ordering::SeqCst);
    }
    // open(2) returns the lowest free descriptor: each call fills the lowest hole.
    for _ in &closed {
        match std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .open("/dev/null")
        {
            Ok(f) => {
                use std::os::fd::{AsRawFd, IntoRawFd};
                if f.as_raw_fd() > 2 {
                    // No hole left below 3 (should not happen): the file is closed on drop.
                    break;
                }
                // Kept open for the life of the process, as descriptor 0, 1 or 2.
                let _ = f.into_raw_fd();
            }
            Err(_) => break,
        }
    }
}

/// Whether standard output was closed when fosls started.
pub fn stdout_closed() -> bool {
    STDOUT_CLOSED.load(Ordering::SeqCst)
}

/// Writes `bytes` to standard output and flushes; an error names "standard output" (exit
/// status 2 in the binary).
pub fn write_stdout(bytes: &[u8]) -> Result<()> {
    let fail = |e: std::io::Error| Error::io(Path::new(STDOUT_NAME), e);
    if stdout_closed() {
        return Err(fail(std::io::Error::new(
            std::io::ErrorKind::BrokenPipe,
            "is closed (file descriptor 1 was not open)",
        )));
    }
    let mut out = std::io::stdout().lock();
    out.write_all(bytes).map_err(fail)?;
    out.flush().map_err(fail)
}

/// Writes a text report to standard output ([`write_stdout`]) with its control characters
/// other than newline and tab escaped ([`crate::error::escape_controls`]): names from files and
/// scenes never reach the terminal raw.
pub fn write_stdout_text(text: &str) -> Result<()> {
    if !text
        .chars()
        .any(|c| c.is_control() && c != '\n' && c != '\t')
    {
        return write_stdout(text.as_bytes());
    }
    let mut safe = String::with_capacity(text.len() + 16);
    for c in text.chars() {
        if c.is_control() && c != '\n' && c != '\t' {
            safe.push_str(&crate::error::escape_controls(c.encode_utf8(&mut [0; 4])));
        } else {
            safe.push(c);
        }
    }
    write_stdout(safe.as_bytes())
}

/// Writes `error: LINE` on standard error, as one safe line; failures are ignored.
pub fn error_line(line: &str) {
    note_line(&format!("error: {line}"));
}

/// Writes one line on standard error ([`crate::error::clean_line`]); failures are ignored.
pub fn note_line(line: &str) {
    let mut text = crate::error::clean_line(line);
    text.push('\n');
    let _ = std::io::stderr().lock().write_all(text.as_bytes());
}
