//! The library's one error type.
//!
//! Every user-facing failure is a single line naming the file, the place in it and the problem
//! (docs/design.md §7, §8): `file: place: problem`. The binary maps [`Error`] to exit status 2.

use std::fmt;
use std::path::{Path, PathBuf};

/// A failure of `fosls`, always printable as one line.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// Bad input: the file, the place in it (array, cell, key, line) and what is wrong.
    #[error("{}: {place}: {problem}", file.display())]
    Input {
        file: PathBuf,
        place: String,
        problem: String,
    },
    /// An operating-system failure while reading or writing `file`.
    #[error("{}: {source}", file.display())]
    Io {
        file: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// Wrong usage of the command line or the library (no file involved).
    #[error("{0}")]
    Usage(String),
}

impl Error {
    /// Bad input in `file` at `place`.
    pub fn input(file: &Path, place: impl fmt::Display, problem: impl fmt::Display) -> Self {
        Error::Input {
            file: file.to_path_buf(),
            place: place.to_string(),
            problem: problem.to_string(),
        }
    }

    /// An I/O failure on `file`.
    pub fn io(file: &Path, source: std::io::Error) -> Self {
        Error::Io {
            file: file.to_path_buf(),
            source,
        }
    }
}

/// The library's result type.
pub type Result<T> = std::result::Result<T, Error>;

/// The most characters of one value a message quotes ([`quote`], [`clean_line`]).
pub const MAX_QUOTED_CHARS: usize = 200;

/// Escapes the control characters of `s` for a terminal: `\t`, `\n`, `\r`, `\0` and `\x1b`
/// style for the others (C0, DEL and C1), so that bytes from a file never reach the terminal
/// raw.
pub fn escape_controls(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '\t' => out.push_str("\\t"),
            '\n' => out.push_str("\\n"),
            '\r' => out.push_str("\\r"),
            '\0' => out.push_str("\\0"),
            c if c.is_control() => {
                let n = c as u32;
                if n <= 0xff {
                    out.push_str(&format!("\\x{n:02x}"));
                } else {
                    out.push_str(&format!("\\u{{{n:x}}}"));
                }
            }
            c => out.push(c),
        }
    }
    out
}

/// `s` cut to its first [`MAX_QUOTED_CHARS`] characters, with `…` and the full length when it
/// is longer: `aaaa… (1048576 characters)`. Control characters are escaped.
pub fn shorten(s: &str) -> String {
    let n = s.chars().count();
    if n <= MAX_QUOTED_CHARS {
        return escape_controls(s);
    }
    let head: String = s.chars().take(MAX_QUOTED_CHARS).collect();
    format!("{}… ({n} characters)", escape_controls(&head))
}

/// A value from a file for a message: in double quotes, at most [`MAX_QUOTED_CHARS`]
/// characters, control characters escaped: `"abc"`, `"aaaa…" (1048576 characters)`.
pub fn quote(s: &str) -> String {
    let n = s.chars().count();
    if n <= MAX_QUOTED_CHARS {
        return format!("\"{}\"", escape_controls(s));
    }
    let head: String = s.chars().take(MAX_QUOTED_CHARS).collect();
    format!("\"{}…\" ({n} characters)", escape_controls(&head))
}

/// A message made safe for one terminal line: newlines become spaces, other control
/// characters are escaped, and every quoted segment (`"…"`) or unbroken run of characters
/// longer than [`MAX_QUOTED_CHARS`] is cut to that length with `…` and its full length. A
/// safety net for messages built from values that were not passed through [`quote`].
pub fn clean_line(line: &str) -> String {
    let line = line.replace(['\n', '\r'], " ");
    let line = escape_controls(&line);
    let chars: Vec<char> = line.chars().collect();
    let mut out = String::with_capacity(line.len().min(4096));
    let mut i = 0;
    while i < chars.len() {
        let c = chars[i];
        if c == '"' {
            // A quoted segment: up to the next quote (or the end of the line).
            let end = chars[i + 1..]
                .iter()
                .position(|&d| d == '"')
                .map_or(chars.len(), |p| i + 1 + p);
            let inner = &chars[i + 1..end];
            out.push('"');
            // (Already cut by `quote`: 200 characters and "…".)
            let cut = inner.len() == MAX_QUOTED_CHARS + 1 && inner.last() == Some(&'…');
            if inner.len() > MAX_QUOTED_CHARS && !cut {
                out.extend(&inner[..MAX_QUOTED_CHARS]);
                out.push('…');
                if end < chars.len() {
                    out.push('"');
                }
                out.push_str(&format!(" ({} characters)", inner.len()));
            } else {
                out.extend(inner);
                if end < chars.len() {
                    out.push('"');
                }
            }
            i = end + 1;
        } else if c.is_whitespace() {
            out.push(c);
            i += 1;
        } else {
            // A run up to the next space or quote.
            let end = chars[i..]
                .iter()
                .position(|&d| d.is_whitespace() || d == '"')
                .map_or(chars.len(), |p| i + p);
            let run = &chars[i..end];
            if run.len() > MAX_QUOTED_CHARS + 40 {
                out.extend(&run[..MAX_QUOTED_CHARS]);
                out.push_str(&format!("… ({} characters)", run.len()));
            } else {
                out.extend(run);
            }
            i = end;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_are_cut_and_escaped() {
        assert_eq!(quote("a\x1bb\x07\0"), "\"a\\x1bb\\x07\\0\"");
        let long = "x".repeat(1 << 20);
        let q = quote(&long);
        assert_eq!(q, format!("\"{}…\" (1048576 characters)", "x".repeat(200)));
        assert_eq!(shorten("ok"), "ok");
    }

    #[test]
    fn lines_are_cut_and_escaped() {
        let long = "7".repeat(100_000);
        let line = clean_line(&format!(
            "f.vtu: Piece 0 NumberOfPoints: \"{long}\" is bad\x1b[2J"
        ));
        assert_eq!(
            line,
            format!(
                "f.vtu: Piece 0 NumberOfPoints: \"{}…\" (100000 characters) is bad\\x1b[2J",
                "7".repeat(200)
            )
        );
        let run = clean_line(&format!("token {long} end"));
        assert_eq!(
            run,
            format!("token {}… (100000 characters) end", "7".repeat(200))
        );
        assert_eq!(clean_line("two\nlines"), "two lines");
        assert_eq!(clean_line("open \"quote"), "open \"quote");
        assert!(clean_line(&"é".repeat(300)).chars().count() < 260);
    }
}
