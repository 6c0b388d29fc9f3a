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
//! of bytes ([`parse_size`]: `512M`, `2G`, `1024K`, `2GiB`; a malformed value is refused by the
//! binary at start, [`check_environment`]).
//!
//! **Time.** [`start_watchdog`] arms a thread that, when the deadline passes, prints one line
//! naming the stage that was running (set with [`set_stage`]) and exits with status 2. Output
//! files are staged as temporary files and published at the very end of a run while holding
//! [`output_lock`] ([`crate::write::output`]); the watchdog removes every temporary file under
//! that lock before exiting: no output file appears, and none is cut short or left behind.

use std::io::Read;
use std::path::Path;
use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

use crate::error::Error;

/// The default global cap on declared data held in memory: 16 GiB (two thirds of the 24 GiB
/// the project's machines have).
pub const DEFAULT_MAX_ALLOC: u64 = 16 << 30;

/// The global cap in bytes: `FOSLS_MAX_ALLOC` when it is set, else [`DEFAULT_MAX_ALLOC`]. The
/// binary refuses a malformed value at start ([`check_environment`]); a library caller that
/// did not check gets the default for one.
pub fn max_alloc() -> u64 {
    std::env::var("FOSLS_MAX_ALLOC")
        .ok()
        .and_then(|v| parse_size(&v).ok())
        .unwrap_or(DEFAULT_MAX_ALLOC)
}

/// Parses a size in bytes, strictly: a whole number of bytes (`123`), or a whole number with a
/// binary unit `K`, `M`, `G`, `T` or `KiB`, `MiB`, `GiB`, `TiB` (any case; powers of 1024:
/// `64K`, `512M`, `2GiB`). Decimal units (`KB`, `MB`, …) are refused as ambiguous, and so are
/// fractions, signs, zero, other text and sizes past 2⁶⁴ − 1.
pub fn parse_size(text: &str) -> Result<u64, String> {
    let t = text.trim();
    if t.is_empty() {
        return Err("is empty; give a number of bytes such as 512M or 2G".into());
    }
    let split = t.find(|c: char| !c.is_ascii_digit()).unwrap_or(t.len());
    let (digits, unit) = t.split_at(split);
    let unit_trimmed = unit.trim_start();
    let shift = match unit_trimmed.to_ascii_lowercase().as_str() {
        "" => 0,
        "k" | "kib" => 10,
        "m" | "mib" => 20,
        "g" | "gib" => 30,
        "t" | "tib" => 40,
        "kb" | "mb" | "gb" | "tb" => {
            return Err(format!(
                "unit \"{unit_trimmed}\" is ambiguous (1000 or 1024?); write {0}{1} or {0}{1}iB \
                 for powers of 1024",
                digits,
                &unit_trimmed[..1].to_ascii_uppercase()
            ));
        }
        _ => {
            return Err(
                "is not a size: expected a whole number of bytes, optionally with K, M, G, T \
                 (or KiB, MiB, GiB, TiB), e.g. 512M or 2G"
                    .into(),
            );
        }
    };
    if digits.is_empty() {
        return Err(
            "is not a size: expected a whole number of bytes, optionally with K, M, G, T \
             (or KiB, MiB, GiB, TiB), e.g. 512M or 2G"
                .into(),
        );
    }
    let n: u64 = digits
        .parse()
        .map_err(|_| "is larger than 2^64 - 1 bytes".to_string())?;
    if n == 0 {
        return Err("is zero; the cap must be at least one byte".into());
    }
    n.checked_mul(1u64 << shift)
        .ok_or_else(|| "is larger than 2^64 - 1 bytes".to_string())
}

/// The most worker threads `RAYON_NUM_THREADS` may ask for.
pub const MAX_THREADS: usize = 1024;

/// Parses `RAYON_NUM_THREADS`: a whole number from 1 to [`MAX_THREADS`].
pub fn parse_threads(text: &str) -> Result<usize, String> {
    let t = text.trim();
    match t.parse::<usize>() {
        Ok(n) if (1..=MAX_THREADS).contains(&n) => Ok(n),
        _ => Err(format!(
            "is not a whole number of threads from 1 to {MAX_THREADS}"
        )),
    }
}

/// Checks the environment the binary depends on and starts the thread pool: a malformed
/// `FOSLS_MAX_ALLOC` or `RAYON_NUM_THREADS` is an error naming the variable and its value,
/// and so is a pool that cannot be started (e.g. too many threads under a memory limit).
pub fn check_environment() -> crate::Result<()> {
    let var = |name: &str| -> crate::Result<Option<String>> {
        match std::env::var(name) {
            Ok(v) => Ok(Some(v)),
            Err(std::env::VarError::NotPresent) => Ok(None),
            Err(std::env::VarError::NotUnicode(v)) => Err(Error::Usage(format!(
                "{name}={}: is not valid text",
                crate::error::quote(&v.to_string_lossy())
            ))),
        }
    };
    if let Some(v) = var("FOSLS_MAX_ALLOC")? {
        parse_size(&v).map_err(|problem| {
            Error::Usage(format!(
                "FOSLS_MAX_ALLOC={}: {problem}",
                crate::error::quote(&v)
            ))
        })?;
    }
    let threads = match var("RAYON_NUM_THREADS")? {
        Some(v) => Some(parse_threads(&v).map_err(|problem| {
            Error::Usage(format!(
                "RAYON_NUM_THREADS={}: {problem}",
                crate::error::quote(&v)
            ))
        })?),
        None => None,
    };
    // Under an address-space limit (ulimit -v) a worker whose stack fits can still fail to map
    // its signal stack, and std panics inside that thread (a second line on stderr) instead
    // of the pool reporting an error: refuse such a count before starting any thread.
    if let (Some(n), Some((limit, used))) = (threads, address_space()) {
        let need = n as u64 * THREAD_ADDRESS_SPACE;
        if used.saturating_add(need) > limit {
            return Err(Error::Usage(format!(
                "cannot start {n} worker threads ({} MiB of stacks on top of {} MiB in use \
                 exceed the address-space limit of {} MiB); lower RAYON_NUM_THREADS",
                need >> 20,
                used >> 20,
                limit >> 20
            )));
        }
    }
    let mut builder = rayon::ThreadPoolBuilder::new();
    if let Some(n) = threads {
        builder = builder.num_threads(n);
    }
    builder.build_global().map_err(|e| {
        Error::Usage(format!(
            "cannot start {} worker threads ({e}){}",
            threads.map_or_else(|| "the".to_string(), |n| n.to_string()),
            if threads.is_some() {
                "; lower RAYON_NUM_THREADS"
            } else {
                "; set RAYON_NUM_THREADS to fewer threads"
            }
        ))
    })
}

/// Address space one worker thread maps: std's 2 MiB stack, its guard page and the signal
/// stack, rounded up.
const THREAD_ADDRESS_SPACE: u64 = (2 << 20) + (128 << 10);

/// The soft address-space limit and the address space in use, in bytes, when the process has
/// such a limit (Linux `/proc/self/limits` and `/proc/self/status`); None otherwise.
fn address_space() -> Option<(u64, u64)> {
    let limits = std::fs::read_to_string("/proc/self/limits").ok()?;
    let line = limits
        .lines()
        .find(|l| l.starts_with("Max address space"))?;
    let soft = line["Max address space".len()..]
        .split_whitespace()
        .next()?;
    let limit: u64 = soft.parse().ok()?; // "unlimited" does not parse: no limit.
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let vm = status.lines().find(|l| l.starts_with("VmSize:"))?;
    let kib: u64 = vm["VmSize:".len()..]
        .split_whitespace()
        .next()?
        .parse()
        .ok()?;
    Some((limit, kib << 10))
}

/// Parses a finite number (for thresholds such as `--fail-above`).
pub fn parse_finite(text: &str) -> Result<f64, String> {
    match text.trim().parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        Ok(_) => Err(format!("\"{text}\" is not a finite number")),
        Err(_) => Err(format!("\"{text}\" is not a number")),
    }
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
    read_bounded_checked(path, cap, remedy, |_| Ok(true), |_| String::new())
}

/// The windows [`read_bounded_checked`] shows its check: 4 KiB, then 64 KiB, then 1 MiB.
pub const START_WINDOWS: [usize; 3] = [4 << 10, 64 << 10, 1 << 20];

/// [`read_bounded`], with a look at the start of a large regular file before the rest is read:
/// `check_start` is given the first 4 KiB (then 64 KiB, then 1 MiB while it answers
/// `Ok(false)`, "undecided") and returns `Ok(true)` to read the file or `Err((place, problem))`
/// to refuse it at once, so a large file that cannot be what is expected costs a few
/// kilobytes of reading. Still undecided at 1 MiB, it is refused with the problem
/// `undecided(1048576)`. Files of at most 4 KiB, and pipes and devices (of
/// unknown length), are read whole as by [`read_bounded`]. The buffer for the file is reserved
/// with `try_reserve`: a file that does not fit in memory is an error, not an abort.
pub fn read_bounded_checked(
    path: &Path,
    cap: u64,
    remedy: &str,
    mut check_start: impl FnMut(&[u8]) -> Result<bool, (String, String)>,
    undecided: impl Fn(usize) -> String,
) -> crate::Result<Vec<u8>> {
    let file = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
    let meta = file.metadata().map_err(|e| Error::io(path, e))?;
    let hint = meta.len();
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
    let mut bytes: Vec<u8> = Vec::new();
    // Room for `total` bytes in all.
    let reserve = |bytes: &mut Vec<u8>, total: usize| {
        let more = total.saturating_sub(bytes.len());
        bytes.try_reserve_exact(more).map_err(|_| {
            Error::input(
                path,
                "file",
                format!("is {hint} bytes, more than fosls can allocate to read it"),
            )
        })
    };
    let mut file = file.take(cap.saturating_add(1));
    if meta.file_type().is_file() && hint > START_WINDOWS[0] as u64 {
        let mut decided = false;
        for window in START_WINDOWS {
            let want = window.min(hint as usize);
            reserve(&mut bytes, want)?;
            (&mut file)
                .take((want - bytes.len()) as u64)
                .read_to_end(&mut bytes)
                .map_err(|e| Error::io(path, e))?;
            match check_start(&bytes) {
                Ok(true) => {
                    decided = true;
                    break;
                }
                Ok(false) if bytes.len() < want || want as u64 == hint => {
                    // The whole file (or all there is) was shown: the parser decides.
                    decided = true;
                    break;
                }
                Ok(false) => {}
                Err((place, problem)) => return Err(Error::input(path, place, problem)),
            }
        }
        if !decided {
            return Err(Error::input(path, "file", undecided(bytes.len())));
        }
    }
    reserve(&mut bytes, hint as usize)?;
    file.read_to_end(&mut bytes)
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
        let message = format!(
            "timeout: {command} did not finish within {} s (stage: {})",
            limit.as_secs_f64(),
            stage()
        );
        match TIMEOUT_HOOK.get() {
            // The output layer's hook removes the temporary files and exits, or returns when
            // the outputs were already committed (the run ends with its own status).
            Some(hook) => hook(&message),
            None => {
                eprintln!("error: {message}");
                std::process::exit(2);
            }
        }
    });
}

/// What the watchdog calls on a timeout, set by the output layer
/// ([`crate::write::output::install_signal_cleanup`]), so that this module needs nothing
/// from it.
static TIMEOUT_HOOK: std::sync::OnceLock<fn(&str)> = std::sync::OnceLock::new();

/// Sets the timeout hook (first call wins).
pub fn set_timeout_hook(hook: fn(&str)) {
    let _ = TIMEOUT_HOOK.set(hook);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_parse_with_binary_suffixes() {
        assert_eq!(parse_size("123"), Ok(123));
        assert_eq!(parse_size("64K"), Ok(65536));
        assert_eq!(parse_size("3m"), Ok(3 * 1048576));
        assert_eq!(parse_size(" 2G "), Ok(2147483648));
        assert_eq!(parse_size("1024K"), Ok(1 << 20));
        assert_eq!(parse_size("2GiB"), Ok(2 << 30));
        assert_eq!(parse_size("1T"), Ok(1 << 40));
        assert_eq!(parse_size("16 MiB"), Ok(16 << 20));
        for bad in ["x", "", "-1", "0.5K", "abc", "0", "1e9", "+5", "12Q", "G"] {
            assert!(parse_size(bad).is_err(), "{bad}");
        }
        assert_eq!(
            parse_size("1KB").unwrap_err(),
            "unit \"KB\" is ambiguous (1000 or 1024?); write 1K or 1KiB for powers of 1024"
        );
        assert_eq!(
            parse_size("99999999999G").unwrap_err(),
            "is larger than 2^64 - 1 bytes"
        );
    }

    #[test]
    fn threads_and_thresholds_parse_strictly() {
        assert_eq!(parse_threads("4"), Ok(4));
        for bad in ["0", "3000", "-1", "x", "", "1.5"] {
            assert!(parse_threads(bad).is_err(), "{bad}");
        }
        assert_eq!(parse_finite("0.05"), Ok(0.05));
        assert_eq!(
            parse_finite("NaN").unwrap_err(),
            "\"NaN\" is not a finite number"
        );
        assert!(parse_finite("inf").is_err());
        assert!(parse_finite("x").is_err());
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
