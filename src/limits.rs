//! Resource limits for files from anywhere: a memory budget for decoded data and a wall-clock
//! deadline for a whole run.
//!
//! **Memory.** Every buffer whose size a file declares (decoded arrays and the byte buffers they
//! are converted from) is reserved from a [`Budget`] before it is allocated. A budget refuses a
//! reservation that would take the total past its cap, so the memory a file can make fosls
//! allocate is bounded by
//!
//! ```text
//!     min( Σ declared data sizes,  cap )   +   O(file size)   (base64 text, XML copies)
//! ```
//!
//! and every declared size is itself bounded by the bytes present in the file times the largest
//! ratio its compressor can reach ([`crate::read::decode::max_ratio`]). The cap is
//! [`DEFAULT_MAX_ALLOC`] unless the environment variable `FOSLS_MAX_ALLOC` gives another number
//! of bytes (suffixes `K`, `M`, `G` for powers of 1024 are accepted).
//!
//! **Time.** [`start_watchdog`] arms a thread that, when the deadline passes, prints one line
//! naming the stage that was running (set with [`set_stage`]) and exits with status 2. Output
//! files are written while holding [`output_lock`], which the watchdog takes before exiting:
//! an output file is either complete or absent, never cut short, and no temporary file is left
//! behind.

use std::io::Read;
use std::path::Path;
use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

use crate::error::Error;

/// The default global cap on declared data held in memory: 16 GiB (two thirds of the 24 GiB
/// the project's machines have).
pub const DEFAULT_MAX_ALLOC: u64 = 16 << 30;

/// The global cap in bytes: `FOSLS_MAX_ALLOC` when it is set and valid, else
/// [`DEFAULT_MAX_ALLOC`].
pub fn max_alloc() -> u64 {
    std::env::var("FOSLS_MAX_ALLOC")
        .ok()
        .and_then(|v| parse_size(&v))
        .unwrap_or(DEFAULT_MAX_ALLOC)
}

/// Parses `"123"`, `"64K"`, `"512M"`, `"2G"` (powers of 1024) into bytes.
pub fn parse_size(text: &str) -> Option<u64> {
    let t = text.trim();
    let (digits, shift) = match t.as_bytes().last()?.to_ascii_uppercase() {
        b'K' => (&t[..t.len() - 1], 10),
        b'M' => (&t[..t.len() - 1], 20),
        b'G' => (&t[..t.len() - 1], 30),
        _ => (t, 0),
    };
    let n: u64 = digits.trim().parse().ok()?;
    n.checked_mul(1u64 << shift)
}

/// A memory budget shared by the threads that decode one file.
#[derive(Debug)]
pub struct Budget {
    cap: u64,
    used: AtomicU64,
}

impl Budget {
    /// A budget of `cap` bytes.
    pub fn new(cap: u64) -> Budget {
        Budget {
            cap,
            used: AtomicU64::new(0),
        }
    }

    /// A budget with the global cap ([`max_alloc`]).
    pub fn global() -> Budget {
        Budget::new(max_alloc())
    }

    /// Reserves `bytes` for `what`; an error naming the sizes when the total would pass the cap.
    pub fn reserve(&self, bytes: u64, what: &str) -> Result<(), String> {
        let mut used = self.used.load(Ordering::Relaxed);
        loop {
            let total = used.saturating_add(bytes);
            if total > self.cap {
                return Err(format!(
                    "{what} needs {bytes} bytes, which would take the decoded data to {total} \
                     bytes, past the limit of {} bytes (set FOSLS_MAX_ALLOC to raise it)",
                    self.cap
                ));
            }
            match self
                .used
                .compare_exchange_weak(used, total, Ordering::Relaxed, Ordering::Relaxed)
            {
                Ok(_) => return Ok(()),
                Err(now) => used = now,
            }
        }
    }

    /// Bytes reserved so far: the file's declared data size as fosls holds it.
    pub fn used(&self) -> u64 {
        self.used.load(Ordering::Relaxed)
    }

    /// The cap in bytes.
    pub fn cap(&self) -> u64 {
        self.cap
    }
}

/// The largest scene file read (a scene is a few kilobytes of TOML).
pub const MAX_SCENE_BYTES: u64 = 16 << 20;

/// Reads the file at `path`, refusing one longer than `cap` bytes without reading past the
/// cap (a device such as `/dev/zero` or a growing file cannot exhaust memory). `remedy` ends
/// the message, e.g. "set FOSLS_MAX_ALLOC to raise it".
pub fn read_bounded(path: &Path, cap: u64, remedy: &str) -> crate::Result<Vec<u8>> {
    let file = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
    let hint = file.metadata().map(|m| m.len()).unwrap_or(0);
    let too_long = |n: u64| {
        Error::input(
            path,
            "file",
            format!("is {n} bytes or more, past the limit of {cap} bytes ({remedy})"),
        )
    };
    if hint > cap {
        return Err(too_long(hint));
    }
    let mut bytes = Vec::with_capacity(hint as usize);
    file.take(cap.saturating_add(1))
        .read_to_end(&mut bytes)
        .map_err(|e| Error::io(path, e))?;
    if bytes.len() as u64 > cap {
        return Err(too_long(bytes.len() as u64));
    }
    Ok(bytes)
}

static STAGE: Mutex<String> = Mutex::new(String::new());
static OUTPUT: Mutex<()> = Mutex::new(());

/// Names the stage that is running, for the timeout message.
pub fn set_stage(stage: &str) {
    if let Ok(mut s) = STAGE.lock() {
        s.clear();
        s.push_str(stage);
    }
}

/// The stage that is running.
pub fn stage() -> String {
    match STAGE.lock() {
        Ok(s) if !s.is_empty() => s.clone(),
        _ => "starting".to_string(),
    }
}

/// Held while an output file is written and renamed into place: the watchdog waits for it, so
/// that a timeout never leaves a partial or temporary file.
pub fn output_lock() -> std::sync::MutexGuard<'static, ()> {
    OUTPUT.lock().unwrap_or_else(|e| e.into_inner())
}

/// Parses a `--timeout` value in seconds (positive, finite).
pub fn parse_timeout(text: &str) -> Result<Duration, String> {
    let s: f64 = text
        .trim()
        .parse()
        .map_err(|_| format!("\"{text}\" is not a number of seconds"))?;
    if !(s.is_finite() && s > 0.0 && s < 1e9) {
        return Err(format!("\"{text}\" is not a positive number of seconds"));
    }
    Ok(Duration::from_secs_f64(s))
}

/// Arms the deadline: after `limit` the process prints
/// `error: timeout: <command> did not finish within <limit> s (stage: <stage>)` on stderr and
/// exits with status 2.
pub fn start_watchdog(limit: Duration, command: &'static str) {
    std::thread::spawn(move || {
        std::thread::sleep(limit);
        // No output file may be half written when the process ends.
        let _guard = output_lock();
        eprintln!(
            "error: timeout: {command} did not finish within {} s (stage: {})",
            limit.as_secs_f64(),
            stage()
        );
        std::process::exit(2);
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_parse_with_binary_suffixes() {
        assert_eq!(parse_size("123"), Some(123));
        assert_eq!(parse_size("64K"), Some(65536));
        assert_eq!(parse_size("3m"), Some(3 * 1048576));
        assert_eq!(parse_size(" 2G "), Some(2147483648));
        assert_eq!(parse_size("x"), None);
        assert_eq!(parse_size("99999999999G"), None);
    }

    #[test]
    fn budget_refuses_past_the_cap_and_counts_what_it_granted() {
        let b = Budget::new(1000);
        b.reserve(600, "a").unwrap();
        let e = b.reserve(401, "array \"b\"").unwrap_err();
        assert_eq!(
            e,
            "array \"b\" needs 401 bytes, which would take the decoded data to 1001 bytes, past \
             the limit of 1000 bytes (set FOSLS_MAX_ALLOC to raise it)"
        );
        b.reserve(400, "c").unwrap();
        assert_eq!(b.used(), 1000);
    }

    #[test]
    fn timeouts_must_be_positive_seconds() {
        assert_eq!(parse_timeout("2.5").unwrap(), Duration::from_millis(2500));
        assert_eq!(
            parse_timeout("0").unwrap_err(),
            "\"0\" is not a positive number of seconds"
        );
        assert_eq!(
            parse_timeout("soon").unwrap_err(),
            "\"soon\" is not a number of seconds"
        );
    }
}
