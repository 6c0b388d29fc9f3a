//! Output files from anywhere: never over an input, never two outputs on one file, nothing
//! left behind, nothing published unless the run ends normally.
//!
//! An [`OutputPlan`] is made before the work starts. It is told every file the run reads
//! ([`OutputPlan::input`]) and every file it will write ([`OutputPlan::output`]); an output that
//! is an input, or another output, is refused at once with one line naming both. Paths are
//! compared after resolution — the canonical folder joined with the file name, and where the
//! file exists its device and inode (`std::os::unix::fs::MetadataExt`), so symbolic links, hard
//! links, `..` and `/dev/stdout` are seen through.
//!
//! **How a target is written** ([`Target`]):
//!
//! - a regular file, or a name that does not exist yet: the bytes go to a temporary file
//!   created in the target's folder with `O_EXCL` and an unpredictable short name
//!   (`.fosls-XXXXXXXX.tmp`, from the `tempfile` crate, so any target name up to `NAME_MAX`
//!   works), synced, and renamed onto the target by [`OutputPlan::commit`]; a symbolic link is
//!   followed (as the shell's `>` does): the file it names is replaced, keeping its mode;
//! - `-`: standard output, written directly at commit ([`super::stdio::write_stdout`]);
//! - an existing file that is not regular (a character device such as `/dev/null` or
//!   `/dev/full`, a FIFO, a socket, `/dev/stdout` on a pipe or terminal): opened without
//!   creating or truncating and written directly at commit, never renamed over.
//!
//! **When.** [`OutputPlan::stage`] writes a temporary file (or keeps the bytes of a direct
//! target); nothing is visible under the target names until [`OutputPlan::commit`], the last
//! step of a run that ends with exit status 0 or 1. Commit writes the direct targets first
//! (a broken pipe or a full device fails the run before any file is renamed), then renames
//! every temporary file while holding [`crate::limits::output_lock`].
//!
//! **Interruption.** Every live temporary file is in a global registry. The `--timeout`
//! watchdog ([`crate::limits::start_watchdog`]) and a handler of SIGINT, SIGTERM and SIGHUP
//! (installed with the first temporary file; a signal the parent ignores, as under `nohup`,
//! stays ignored) call [`abandon_outputs`]: it waits for a commit in progress, removes every
//! temporary file and keeps the lock until the process ends, so no output appears. A timeout
//! exits with status 2; a signal ends the process by that signal (the shell reports
//! 128 + its number: 130 for SIGINT, 143 for SIGTERM, 129 for SIGHUP). Once the outputs are
//! committed the run is over: a deadline passing then is ignored and a signal is acted on only
//! if the process has not ended by itself within two seconds.

use std::fs::{self, File, OpenOptions};
use std::io::Write;
use std::os::unix::fs::{FileTypeExt, MetadataExt, PermissionsExt};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Mutex, MutexGuard, Once};

use crate::error::{Error, Result};

/// Live temporary files: removed by [`abandon_outputs`].
static LIVE: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());
/// Set once a plan's temporary files have been renamed into place.
static COMMITTED: AtomicBool = AtomicBool::new(false);
static SIGNALS: Once = Once::new();

fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

fn unregister(path: &Path) {
    let mut live = lock(&LIVE);
    if let Some(i) = live.iter().position(|p| p == path) {
        live.swap_remove(i);
    }
}

/// Paths of the temporary files alive now (for tests and diagnostics).
pub fn live_temporaries() -> Vec<PathBuf> {
    lock(&LIVE).clone()
}

/// Whether outputs have been committed in this process.
pub fn committed() -> bool {
    COMMITTED.load(Ordering::SeqCst)
}

/// Removes every live temporary file and returns the output lock, to be held until the process
/// exits, so that no output is published; `None` when the outputs were already committed (the
/// run is over and should end with its own status).
pub fn abandon_outputs() -> Option<MutexGuard<'static, ()>> {
    let guard = crate::limits::output_lock();
    if committed() {
        return None;
    }
    let live = lock(&LIVE);
    for p in live.iter() {
        let _ = fs::remove_file(p);
    }
    // LIVE stays locked until exit: no temporary file can be created after the clean-up.
    std::mem::forget(live);
    Some(guard)
}

/// Signals whose disposition is "ignore" in this process (inherited, e.g. SIGHUP under
/// `nohup`), from `/proc/self/status`; empty if it cannot be read.
fn ignored_signals() -> u64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find_map(|l| l.strip_prefix("SigIgn:"))
                .and_then(|h| u64::from_str_radix(h.trim(), 16).ok())
        })
        .unwrap_or(0)
}

/// The watchdog's timeout action ([`crate::limits::set_timeout_hook`]): waits for a commit in
/// progress, removes every temporary file, keeps the outputs from being published until the
/// process has ended, prints the line and exits with status 2; returns when the outputs were
/// already committed (the run is over and ends with its own status).
fn on_timeout(message: &str) {
    let Some(_outputs) = abandon_outputs() else {
        return;
    };
    super::stdio::error_line(message);
    std::process::exit(2);
}

/// Installs the handler of SIGINT, SIGTERM and SIGHUP that removes the temporary files
/// (module documentation), and the watchdog's timeout hook. Called with the first temporary
/// file; idempotent.
pub fn install_signal_cleanup() {
    crate::limits::set_timeout_hook(on_timeout);
    SIGNALS.call_once(|| {
        use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
        let ignored = ignored_signals();
        let wanted: Vec<i32> = [SIGINT, SIGTERM, SIGHUP]
            .into_iter()
            .filter(|&s| ignored & (1u64 << (s - 1)) == 0)
            .collect();
        let Ok(mut signals) = signal_hook::iterator::Signals::new(&wanted) else {
            return;
        };
        let _ = std::thread::Builder::new()
            .name("fosls-signals".into())
            .spawn(move || {
                if let Some(sig) = signals.forever().next() {
                    let guard = abandon_outputs();
                    if guard.is_none() {
                        // Committed: the process is about to end with its own status.
                        std::thread::sleep(std::time::Duration::from_secs(2));
                    }
                    let _ = signal_hook::low_level::emulate_default_handler(sig);
                    std::process::exit(128 + sig);
                }
            });
    });
}

/// A registered temporary file; removed (and unregistered) on drop unless persisted.
struct Temp {
    path: Option<tempfile::TempPath>,
}

impl Temp {
    /// Creates `.fosls-XXXXXXXX.tmp` in `dir` (O_EXCL, mode 0666 less the umask, or `mode`).
    fn create(dir: &Path, mode: Option<u32>) -> std::io::Result<(File, Temp)> {
        install_signal_cleanup();
        let mut live = lock(&LIVE);
        let named = tempfile::Builder::new()
            .prefix(".fosls-")
            .suffix(".tmp")
            .rand_bytes(8)
            .permissions(fs::Permissions::from_mode(0o666))
            .tempfile_in(dir)?;
        live.push(named.path().to_path_buf());
        drop(live);
        let (file, path) = named.into_parts();
        let temp = Temp { path: Some(path) };
        if let Some(mode) = mode {
            file.set_permissions(fs::Permissions::from_mode(mode & 0o7777))?;
        }
        Ok((file, temp))
    }

    fn persist(mut self, target: &Path) -> std::io::Result<()> {
        let Some(tp) = self.path.take() else {
            return Ok(());
        };
        let p = tp.to_path_buf();
        let result = tp.persist(target).map_err(|e| {
            // The temporary file is removed when the returned path drops.
            drop(e.path);
            e.error
        });
        unregister(&p);
        result
    }
}

impl Drop for Temp {
    fn drop(&mut self) {
        if let Some(tp) = self.path.take() {
            let p = tp.to_path_buf();
            drop(tp);
            unregister(&p);
        }
    }
}

/// How one output path is written (see the module documentation).
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Target {
    /// `-`: standard output.
    Stdout,
    /// An existing file that is not regular (device, FIFO, socket): written in place.
    Direct(PathBuf),
    /// A regular or new file: temporary in `dir`, renamed onto `path` (resolved).
    Replace {
        path: PathBuf,
        dir: PathBuf,
        /// The mode of the file replaced, kept by the new one.
        mode: Option<u32>,
    },
}

/// What a path is, for comparisons.
#[derive(Clone, Debug)]
struct Identity {
    /// Canonical folder joined with the file name (or the canonical path of an existing file).
    path: PathBuf,
    /// Device and inode where the file exists.
    id: Option<(u64, u64)>,
}

impl Identity {
    fn same(&self, other: &Identity) -> bool {
        match (self.id, other.id) {
            (Some(a), Some(b)) => a == b,
            _ => self.path == other.path,
        }
    }
}

fn id_of(m: &fs::Metadata) -> Option<(u64, u64)> {
    Some((m.dev(), m.ino()))
}

/// Canonical folder of `path` joined with its file name (no file needs to exist but the
/// folder).
fn lexical(path: &Path) -> std::io::Result<PathBuf> {
    let name = path
        .file_name()
        .ok_or_else(|| std::io::Error::new(std::io::ErrorKind::InvalidInput, "not a file name"))?;
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    Ok(fs::canonicalize(dir)?.join(name))
}

fn stdout_identity() -> Identity {
    use std::os::fd::AsFd;
    let id = std::io::stdout()
        .as_fd()
        .try_clone_to_owned()
        .ok()
        .map(File::from)
        .and_then(|f| f.metadata().ok())
        .and_then(|m| id_of(&m));
    Identity {
        path: PathBuf::from("-"),
        id: if super::stdio::stdout_closed() {
            None
        } else {
            id
        },
    }
}

/// Resolves an output path: its identity and how it is written.
fn resolve_output(path: &Path) -> Result<(Identity, Target)> {
    if path == Path::new("-") {
        return Ok((stdout_identity(), Target::Stdout));
    }
    let io = |e: std::io::Error| Error::io(path, e);
    match fs::metadata(path) {
        Ok(m) if m.is_dir() => Err(Error::io(
            path,
            std::io::Error::new(std::io::ErrorKind::IsADirectory, "is a directory"),
        )),
        Ok(m) if m.file_type().is_file() => {
            let resolved = fs::canonicalize(path).map_err(io)?;
            let dir = resolved
                .parent()
                .map_or_else(|| PathBuf::from("/"), Path::to_path_buf);
            Ok((
                Identity {
                    path: resolved.clone(),
                    id: id_of(&m),
                },
                Target::Replace {
                    path: resolved,
                    dir,
                    mode: Some(m.permissions().mode()),
                },
            ))
        }
        Ok(m) => {
            let ft = m.file_type();
            debug_assert!(
                ft.is_char_device() || ft.is_fifo() || ft.is_socket() || ft.is_block_device()
            );
            let resolved = fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf());
            Ok((
                Identity {
                    path: resolved,
                    id: id_of(&m),
                },
                Target::Direct(path.to_path_buf()),
            ))
        }
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            // A new file (or a dangling symbolic link, which is replaced).
            let resolved = lexical(path).map_err(io)?;
            let dir = resolved
                .parent()
                .map_or_else(|| PathBuf::from("/"), Path::to_path_buf);
            Ok((
                Identity {
                    path: resolved.clone(),
                    id: None,
                },
                Target::Replace {
                    path: resolved,
                    dir,
                    mode: None,
                },
            ))
        }
        Err(e) => Err(io(e)),
    }
}

fn resolve_input(path: &Path) -> Identity {
    match fs::canonicalize(path) {
        Ok(c) => Identity {
            id: fs::metadata(&c).ok().and_then(|m| id_of(&m)),
            path: c,
        },
        Err(_) => Identity {
            path: lexical(path).unwrap_or_else(|_| path.to_path_buf()),
            id: None,
        },
    }
}

/// Handle of one planned output.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct OutputId(usize);

enum Staged {
    None,
    Temp(Temp),
    Bytes(Vec<u8>),
}

struct Planned {
    role: String,
    given: PathBuf,
    identity: Identity,
    target: Target,
    staged: Staged,
    /// A resolution error of an optional output, raised when it is staged.
    deferred: Option<std::io::Error>,
}

struct Input {
    role: String,
    given: PathBuf,
    identity: Identity,
}

/// The outputs of one run (module documentation).
#[derive(Default)]
pub struct OutputPlan {
    inputs: Vec<Input>,
    outputs: Vec<Planned>,
}

fn show(p: &Path) -> String {
    p.display().to_string()
}

impl OutputPlan {
    /// An empty plan.
    pub fn new() -> OutputPlan {
        OutputPlan::default()
    }

    fn refuse_input(out: &Planned, input: &Input) -> Error {
        // Same spelling: the line names the file once.
        let problem = if out.given.as_os_str() == input.given.as_os_str() {
            format!("refusing to overwrite the {}", input.role)
        } else {
            format!(
                "refusing to overwrite the {} {} (the same file)",
                input.role,
                show(&input.given)
            )
        };
        Error::Usage(format!("{}: {problem}", show(&out.given)))
    }

    /// Records a file the run reads, described by `role` ("input file", "scene file"); refuses
    /// it if a planned output is the same file. A missing file is compared by its path.
    pub fn input(&mut self, path: &Path, role: &str) -> Result<()> {
        let input = Input {
            role: role.to_string(),
            given: path.to_path_buf(),
            identity: resolve_input(path),
        };
        if let Some(o) = self
            .outputs
            .iter()
            .find(|o| o.identity.same(&input.identity))
        {
            return Err(Self::refuse_input(o, &input));
        }
        self.inputs.push(input);
        Ok(())
    }

    /// Plans the output `path` (`-` for standard output) for `role` (the option, e.g.
    /// `--json`); refuses it, with one line naming both, if it is an input or another output,
    /// and fails at once if its folder is missing or not writable.
    pub fn output(&mut self, path: &Path, role: &str) -> Result<OutputId> {
        let (identity, target) = resolve_output(path)?;
        let planned = Planned {
            role: role.to_string(),
            given: path.to_path_buf(),
            identity,
            target,
            staged: Staged::None,
            deferred: None,
        };
        if let Some(i) = self
            .inputs
            .iter()
            .find(|i| i.identity.same(&planned.identity))
        {
            return Err(Self::refuse_input(&planned, i));
        }
        if let Some(o) = self
            .outputs
            .iter()
            .find(|o| o.identity.same(&planned.identity))
        {
            let what = if o.given.as_os_str() == planned.given.as_os_str() {
                format!("{} and {} would both write this file", o.role, planned.role)
            } else {
                format!(
                    "{} would write the same file as {} {}",
                    planned.role,
                    o.role,
                    show(&o.given)
                )
            };
            return Err(Error::Usage(format!("{}: {what}", show(&planned.given))));
        }
        if let Target::Replace { dir, .. } = &planned.target {
            // A missing or read-only folder fails now, not after the work.
            Temp::create(dir, None).map_err(|e| Error::io(path, e))?;
        }
        self.outputs.push(planned);
        Ok(OutputId(self.outputs.len() - 1))
    }

    /// Plans an output the run may or may not write (a copy written only in some cases): like
    /// [`output_file`](Self::output_file), refused at once if it is an input or another
    /// output, but a path that cannot be resolved (a name past `NAME_MAX`) is an error only
    /// when it is staged.
    pub fn optional_output(&mut self, path: &Path, role: &str) -> Result<OutputId> {
        match self.output_file(path, role) {
            Err(Error::Io { source, .. }) => {
                let resolved = path.to_path_buf();
                let dir = match path.parent() {
                    Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
                    _ => PathBuf::from("."),
                };
                self.outputs.push(Planned {
                    role: role.to_string(),
                    given: path.to_path_buf(),
                    identity: Identity {
                        path: lexical(path).unwrap_or_else(|_| resolved.clone()),
                        id: None,
                    },
                    target: Target::Replace {
                        path: resolved,
                        dir,
                        mode: None,
                    },
                    staged: Staged::None,
                    deferred: Some(source),
                });
                Ok(OutputId(self.outputs.len() - 1))
            }
            other => other,
        }
    }

    /// Like [`output`](Self::output), but refuses `-` (for outputs that cannot go to standard
    /// output).
    pub fn output_file(&mut self, path: &Path, role: &str) -> Result<OutputId> {
        if path == Path::new("-") {
            return Err(Error::Usage(format!(
                "{role} -: this output must be a file (standard output is not accepted here)"
            )));
        }
        self.output(path, role)
    }

    /// How output `id` will be written.
    pub fn target(&self, id: OutputId) -> &Target {
        &self.outputs[id.0].target
    }

    /// The path of output `id` as given.
    pub fn path(&self, id: OutputId) -> &Path {
        &self.outputs[id.0].given
    }

    /// Stages the content of output `id`: written and synced to a temporary file now (or kept
    /// for a direct target), published by [`commit`](Self::commit).
    pub fn stage(&mut self, id: OutputId, bytes: &[u8]) -> Result<()> {
        crate::limits::set_stage("writing the outputs");
        let o = &mut self.outputs[id.0];
        let given = o.given.clone();
        if let Some(e) = o.deferred.take() {
            return Err(Error::io(&given, e));
        }
        match &o.target {
            Target::Stdout | Target::Direct(_) => {
                o.staged = Staged::Bytes(bytes.to_vec());
            }
            Target::Replace { dir, mode, .. } => {
                let (mut file, temp) =
                    Temp::create(dir, *mode).map_err(|e| Error::io(&given, e))?;
                // Dropping `temp` on an error removes the partial file.
                file.write_all(bytes)
                    .and_then(|()| file.sync_all())
                    .map_err(|e| Error::io(&given, e))?;
                drop(file);
                o.staged = Staged::Temp(temp);
            }
        }
        Ok(())
    }

    /// Serialises `file` and stages it as output `id` (names XML cannot hold are refused).
    pub fn stage_vtu(
        &mut self,
        id: OutputId,
        file: &crate::read::vtu::VtuFile,
        placement: super::Placement,
    ) -> Result<()> {
        let bytes = super::try_to_bytes(file, placement)
            .map_err(|problem| Error::Usage(format!("{}: {problem}", show(self.path(id)))))?;
        self.stage(id, &bytes)
    }

    /// Serialises `value` as pretty JSON (with a final newline) and stages it as output `id`.
    pub fn stage_json(&mut self, id: OutputId, value: &impl serde::Serialize) -> Result<()> {
        let mut text = serde_json::to_string_pretty(value).map_err(|e| {
            Error::Usage(format!(
                "{}: cannot serialise the report ({e})",
                show(self.path(id))
            ))
        })?;
        text.push('\n');
        self.stage(id, text.as_bytes())
    }

    /// Publishes every staged output: direct targets are written first (standard output,
    /// devices, FIFOs), then every temporary file is renamed onto its target. Outputs planned
    /// but never staged are not written.
    pub fn commit(self) -> Result<()> {
        self.publish(true)
    }

    /// [`commit`](Self::commit); `last` marks the process's outputs as committed (after which
    /// a deadline or a signal no longer removes anything).
    fn publish(self, last: bool) -> Result<()> {
        if last {
            crate::limits::set_stage("writing the outputs");
        }
        let mut temps: Vec<(PathBuf, PathBuf, Temp)> = Vec::new();
        for o in self.outputs {
            match (o.staged, &o.target) {
                (Staged::Bytes(bytes), Target::Stdout) => super::stdio::write_stdout(&bytes)?,
                (Staged::Bytes(bytes), Target::Direct(p)) => write_direct(p, &bytes)?,
                (Staged::Temp(t), Target::Replace { path, .. }) => {
                    temps.push((o.given.clone(), path.clone(), t));
                }
                _ => {}
            }
        }
        let _publishing = crate::limits::output_lock();
        for (given, target, temp) in temps {
            temp.persist(&target).map_err(|e| Error::io(&given, e))?;
        }
        if last {
            COMMITTED.store(true, Ordering::SeqCst);
        }
        Ok(())
    }
}

/// Writes `bytes` into the existing non-regular file `path` (no creation, no truncation).
fn write_direct(path: &Path, bytes: &[u8]) -> Result<()> {
    let io = |e: std::io::Error| Error::io(path, e);
    let mut f = OpenOptions::new().write(true).open(path).map_err(io)?;
    if f.metadata().map_err(io)?.file_type().is_file() {
        // Replaced by a regular file since the plan was made: do not write into it in place.
        return Err(io(std::io::Error::other(
            "became a regular file during the run; not written",
        )));
    }
    f.write_all(bytes).and_then(|()| f.flush()).map_err(io)
}

/// Writes `bytes` to `path` at once, with the guarantees of a one-output plan: atomic for
/// regular files, in place for devices, FIFOs and `-`.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let mut plan = OutputPlan::new();
    let id = plan.output(path, "output")?;
    plan.stage(id, bytes)?;
    // Not the run's last step: a later deadline or signal still cleans up.
    plan.publish(false)
}
