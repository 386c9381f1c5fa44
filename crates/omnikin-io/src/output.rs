//! Output rules shared by every command: what the CLI may write, and how.
//!
//! 1. **An input is never overwritten**, not even with `--force`: every file a command reads is
//!    registered with [`input`] before anything is written, and every output is compared with
//!    them (canonical path, and device + inode on Unix, so symlinks and hard links count).
//! 2. **An existing output is replaced only with `--force`** (a global flag, [`set_force`]); an
//!    output directory must be new or empty unless `--force` (then the files the command writes
//!    replace their namesakes and everything else in it is left alone).
//! 3. **Every file is written to a temporary file in the same directory and renamed** into place
//!    once complete ([`OutFile`]), so an interrupted or failed command never leaves a truncated
//!    output or a half-replaced old one. Without `--force` the final step is a no-clobber link,
//!    so a file that appeared meanwhile is not replaced either. Devices and pipes
//!    (`/dev/stdout`, a FIFO) are written directly.
//! 4. **Logs keep what they have** ([`OutFile::log`]): a log is renamed into place on every exit
//!    path, including errors and SIGINT/SIGTERM ([`catch_signals`], [`interrupted`]).
//! 5. **stdout is written fallibly** ([`outln!`](crate::outln)): a full or failing stdout is an
//!    error with a message and a non-zero exit; a closed pipe (EPIPE) ends the command quietly
//!    with status 141, as if killed by SIGPIPE ([`stdout_broken`]).
//!
//! Error messages name the flag, the path, the rule and how to override it where one can.

use std::fs::{File, OpenOptions};
use std::io::{self, BufWriter, ErrorKind, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, OnceLock};

use anyhow::{Context, Result, bail};

/// A file the command reads: the flag that named it and its identity.
struct Input {
    flag: String,
    path: PathBuf,
    canonical: PathBuf,
    #[cfg(unix)]
    id: (u64, u64),
}

/// The process-wide rules: `--force` and the registered inputs.
struct Rules {
    force: bool,
    /// Whether the front end has a `--force` to name in errors (Python has none).
    force_option: bool,
    inputs: Vec<Input>,
}

static RULES: Mutex<Rules> = Mutex::new(Rules {
    force: false,
    force_option: true,
    inputs: Vec::new(),
});

fn rules() -> std::sync::MutexGuard<'static, Rules> {
    RULES.lock().unwrap_or_else(|p| p.into_inner())
}

/// Sets the global `--force`: existing outputs may be replaced (never inputs).
pub fn set_force(force: bool) {
    rules().force = force;
}

fn force() -> bool {
    rules().force
}

/// For a front end without a `--force` (Python): an existing output is never replaced, and the
/// errors say so instead of pointing to a flag the user cannot pass.
pub fn set_no_force_option() {
    let mut r = rules();
    r.force = false;
    r.force_option = false;
}

/// How to replace an existing output, for an error's last words.
fn replace_hint(what: &str) -> String {
    if rules().force_option {
        format!("not replaced without --force (pass --force to replace {what}")
    } else {
        format!("never replaced from this program (remove {what} first")
    }
}

/// Registers a file the command reads (`flag` names it in messages: `--plan`, `FILE`, …).
/// Paths that do not exist (a preset name, a file the command will fail to read) are ignored.
pub fn input(flag: &str, path: &Path) {
    let Ok(canonical) = path.canonicalize() else {
        return;
    };
    let Ok(meta) = std::fs::metadata(&canonical) else {
        return;
    };
    if meta.is_dir() {
        return;
    }
    #[cfg(unix)]
    let id = {
        use std::os::unix::fs::MetadataExt;
        (meta.dev(), meta.ino())
    };
    rules().inputs.push(Input {
        flag: flag.to_string(),
        path: path.to_path_buf(),
        canonical,
        #[cfg(unix)]
        id,
    });
}

/// The registered input that `path` (an existing file) is, if any.
fn is_input(path: &Path) -> Option<(String, PathBuf)> {
    let canonical = path.canonicalize().ok()?;
    #[cfg(unix)]
    let id = {
        use std::os::unix::fs::MetadataExt;
        let m = std::fs::metadata(&canonical).ok()?;
        (m.dev(), m.ino())
    };
    let r = rules();
    r.inputs
        .iter()
        .find(|i| {
            #[cfg(unix)]
            if i.id == id {
                return true;
            }
            i.canonical == canonical
        })
        .map(|i| (i.flag.clone(), i.path.clone()))
}

/// What an output path is now.
enum Existing {
    Nothing,
    Regular,
    Directory,
    /// A device, FIFO or socket: written directly, never replaced.
    Special,
}

fn existing(path: &Path) -> io::Result<Existing> {
    match std::fs::metadata(path) {
        Ok(m) if m.is_dir() => Ok(Existing::Directory),
        Ok(m) if m.is_file() => Ok(Existing::Regular),
        Ok(_) => Ok(Existing::Special),
        Err(e) if e.kind() == ErrorKind::NotFound => Ok(Existing::Nothing),
        Err(e) => Err(e),
    }
}

/// Checks the rules for one output file named by `flag`: not an input, not a directory, and
/// not an existing file unless `--force`.
pub fn check_file(flag: &str, path: &Path) -> Result<()> {
    let shown = path.display();
    if let Some((in_flag, in_path)) = is_input(path) {
        bail!(
            "{flag} {shown}: is also the input {in_flag} {}; an input is never overwritten (not even with --force): write the output to another file",
            in_path.display()
        );
    }
    match existing(path).with_context(|| format!("{flag} {shown}: cannot inspect"))? {
        Existing::Nothing | Existing::Special => Ok(()),
        Existing::Directory => {
            bail!("{flag} {shown}: is a directory; {flag} names a file")
        }
        Existing::Regular if force() => Ok(()),
        Existing::Regular => bail!(
            "{flag} {shown}: exists; an existing output is {}, or choose another name)",
            replace_hint("it")
        ),
    }
}

/// Checks the rules for an output directory named by `flag`: a directory (or nothing yet),
/// and new or empty unless `--force`.
pub fn check_dir(flag: &str, dir: &Path) -> Result<()> {
    let shown = dir.display();
    match existing(dir).with_context(|| format!("{flag} {shown}: cannot inspect"))? {
        Existing::Nothing => Ok(()),
        Existing::Regular | Existing::Special => {
            bail!("{flag} {shown}: exists and is not a directory; {flag} names a directory")
        }
        Existing::Directory => {
            let mut entries =
                std::fs::read_dir(dir).with_context(|| format!("{flag} {shown}: cannot list"))?;
            if entries.next().is_some() && !force() {
                bail!(
                    "{flag} {shown}: directory exists and is not empty; its files are {}, or choose a new directory)",
                    replace_hint("the files this command writes there")
                );
            }
            Ok(())
        }
    }
}

/// `true` if `path` exists and is not a directory (an output directory named like a file).
pub fn is_file_like(path: &Path) -> bool {
    path.exists() && !path.is_dir()
}

/// Checks that no two outputs of one command are the same file (e.g. `--out X --plot X`).
pub fn check_distinct(outputs: &[(&str, &Path)]) -> Result<()> {
    let key = |p: &Path| -> PathBuf {
        let parent = match p.parent() {
            Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
            _ => PathBuf::from("."),
        };
        let dir = parent.canonicalize().unwrap_or(parent);
        match p.file_name() {
            Some(n) => dir.join(n),
            None => dir,
        }
    };
    for (i, (fa, a)) in outputs.iter().enumerate() {
        for (fb, b) in &outputs[i + 1..] {
            if key(a) == key(b) {
                bail!(
                    "{fa} {} and {fb} {} are the same file; each output needs its own name",
                    a.display(),
                    b.display()
                );
            }
        }
    }
    Ok(())
}

/// Creates the output directory `dir` (and its parents) after [`check_dir`].
pub fn create_dir(flag: &str, dir: &Path) -> Result<()> {
    check_dir(flag, dir)?;
    std::fs::create_dir_all(dir)
        .with_context(|| format!("{flag} {}: cannot create the directory", dir.display()))
}

/// A subdirectory the command creates inside an output directory (no emptiness rule).
pub fn create_subdir(flag: &str, dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir)
        .with_context(|| format!("{flag} {}: cannot create the directory", dir.display()))
}

static TMP_COUNTER: AtomicUsize = AtomicUsize::new(0);

/// An output file being written: a temporary file beside the destination, renamed into place
/// by [`commit`](Self::commit). Dropped without a commit, it is removed — unless it is a log
/// ([`OutFile::log`]), which is committed on every exit path.
pub struct OutFile {
    flag: String,
    dest: PathBuf,
    /// `None` for a device/FIFO written directly.
    tmp: Option<PathBuf>,
    file: Option<BufWriter<File>>,
    replace: bool,
    keep_partial: bool,
}

impl OutFile {
    /// Starts writing the output `dest` named by `flag` (checks [`check_file`]).
    pub fn create(flag: &str, dest: &Path) -> Result<Self> {
        check_file(flag, dest)?;
        let shown = dest.display();
        // A symlink is written through: the file it points to is the output.
        let (dest, kind) = match existing(dest)? {
            Existing::Regular => (
                dest.canonicalize().unwrap_or_else(|_| dest.to_path_buf()),
                Existing::Regular,
            ),
            k => (dest.to_path_buf(), k),
        };
        if let Existing::Special = kind {
            let f = OpenOptions::new()
                .write(true)
                .open(&dest)
                .with_context(|| format!("{flag} {shown}: cannot open for writing"))?;
            return Ok(Self {
                flag: flag.into(),
                dest,
                tmp: None,
                file: Some(BufWriter::new(f)),
                replace: false,
                keep_partial: false,
            });
        }
        let Some(name) = dest.file_name() else {
            bail!("{flag} {shown}: names no file");
        };
        let dir = match dest.parent() {
            Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
            _ => PathBuf::from("."),
        };
        let tmp = dir.join(format!(
            ".{}.{}-{}.tmp",
            name.to_string_lossy(),
            std::process::id(),
            TMP_COUNTER.fetch_add(1, Ordering::Relaxed)
        ));
        let f = OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&tmp)
            .with_context(|| {
                format!(
                    "{flag} {shown}: cannot create a temporary file in {} (does the directory exist and is it writable?)",
                    dir.display()
                )
            })?;
        Ok(Self {
            flag: flag.into(),
            dest,
            tmp: Some(tmp),
            file: Some(BufWriter::new(f)),
            replace: matches!(kind, Existing::Regular),
            keep_partial: false,
        })
    }

    /// Starts a log: like [`create`](Self::create), but what was written is renamed into place
    /// on every exit path (errors, signals, drop), not only by [`commit`](Self::commit).
    pub fn log(flag: &str, dest: &Path) -> Result<Self> {
        let mut f = Self::create(flag, dest)?;
        f.keep_partial = true;
        Ok(f)
    }

    /// Flushes and moves the file into place.
    pub fn commit(mut self) -> Result<()> {
        self.finish()
    }

    fn finish(&mut self) -> Result<()> {
        let shown = self.dest.display().to_string();
        let flag = self.flag.clone();
        let Some(mut w) = self.file.take() else {
            return Ok(());
        };
        w.flush()
            .with_context(|| format!("{flag} {shown}: cannot write"))?;
        let f = w
            .into_inner()
            .map_err(|e| e.into_error())
            .with_context(|| format!("{flag} {shown}: cannot write"))?;
        let Some(tmp) = self.tmp.take() else {
            return Ok(());
        };
        let result = (|| -> Result<()> {
            if self.replace {
                // The old file disappears at the rename: make the new one durable first.
                f.sync_all()
                    .with_context(|| format!("{flag} {shown}: cannot write"))?;
            }
            drop(f);
            // The rules again, at the last moment (an input or another file may have appeared).
            check_file(&flag, &self.dest)?;
            if force() {
                std::fs::rename(&tmp, &self.dest).with_context(|| {
                    format!("{flag} {shown}: cannot move the finished file into place")
                })?;
                return Ok(());
            }
            match std::fs::hard_link(&tmp, &self.dest) {
                Ok(()) => {
                    let _ = std::fs::remove_file(&tmp);
                    Ok(())
                }
                Err(e) if e.kind() == ErrorKind::AlreadyExists => bail!(
                    "{flag} {shown}: appeared while this command ran; not replaced without --force"
                ),
                // A file system without hard links: check, then rename.
                Err(_) => {
                    if !matches!(existing(&self.dest)?, Existing::Nothing) {
                        bail!(
                            "{flag} {shown}: appeared while this command ran; not replaced without --force"
                        );
                    }
                    std::fs::rename(&tmp, &self.dest).with_context(|| {
                        format!("{flag} {shown}: cannot move the finished file into place")
                    })
                }
            }
        })();
        if result.is_err() {
            if self.keep_partial {
                eprintln_quiet(format_args!(
                    "warning: {flag} {shown}: the rows written so far are kept in {}",
                    tmp.display()
                ));
            } else {
                let _ = std::fs::remove_file(&tmp);
            }
        }
        result
    }
}

impl Write for OutFile {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        match self.file.as_mut() {
            Some(f) => f.write(buf),
            None => Err(io::Error::other("output already finished")),
        }
    }
    fn write_all(&mut self, buf: &[u8]) -> io::Result<()> {
        match self.file.as_mut() {
            Some(f) => f.write_all(buf),
            None => Err(io::Error::other("output already finished")),
        }
    }
    fn flush(&mut self) -> io::Result<()> {
        match self.file.as_mut() {
            Some(f) => f.flush(),
            None => Ok(()),
        }
    }
}

impl Drop for OutFile {
    fn drop(&mut self) {
        if self.file.is_none() {
            return;
        }
        if self.keep_partial {
            if let Err(e) = self.finish() {
                eprintln_quiet(format_args!("warning: {e:#}"));
            }
        } else {
            self.file = None;
            if let Some(tmp) = self.tmp.take() {
                let _ = std::fs::remove_file(tmp);
            }
        }
    }
}

/// Writes the whole output file `path` (named by `flag`) with `write`, then moves it into place.
pub fn write_file(
    flag: &str,
    path: &Path,
    write: impl FnOnce(&mut OutFile) -> io::Result<()>,
) -> Result<()> {
    let mut f = OutFile::create(flag, path)?;
    write(&mut f).with_context(|| format!("{flag} {}: cannot write", path.display()))?;
    f.commit()
}

// ---------------------------------------------------------------------------------------------
// Signals

/// The signal that asked the process to stop (0: none yet), shared with the handlers.
static SIGNAL: OnceLock<Arc<AtomicUsize>> = OnceLock::new();
static SIGNALS_CAUGHT: AtomicBool = AtomicBool::new(false);

fn signal_cell() -> &'static Arc<AtomicUsize> {
    SIGNAL.get_or_init(|| Arc::new(AtomicUsize::new(0)))
}

/// From now on SIGINT and SIGTERM set a flag ([`interrupted`]) instead of killing the process,
/// so a loop can stop, flush its log and exit; a second signal ends the process at once (exit
/// status 130). Only commands whose loops poll [`interrupted`] may call this.
pub fn catch_signals() -> Result<()> {
    if SIGNALS_CAUGHT.swap(true, Ordering::SeqCst) {
        return Ok(());
    }
    #[cfg(unix)]
    {
        use signal_hook::consts::{SIGINT, SIGTERM};
        let seen = Arc::new(AtomicBool::new(false));
        for sig in [SIGINT, SIGTERM] {
            // Order matters: the shutdown check runs first and sees a flag set by an earlier
            // signal, so the second Ctrl-C ends a process that does not stop by itself.
            signal_hook::flag::register_conditional_shutdown(sig, 130, Arc::clone(&seen))
                .context("cannot install the signal handlers")?;
            signal_hook::flag::register(sig, Arc::clone(&seen))
                .context("cannot install the signal handlers")?;
            signal_hook::flag::register_usize(sig, Arc::clone(signal_cell()), sig as usize)
                .context("cannot install the signal handlers")?;
        }
    }
    Ok(())
}

/// The signal received since [`catch_signals`], if any.
pub fn interrupted() -> Option<Interrupted> {
    match signal_cell().load(Ordering::SeqCst) {
        0 => None,
        s => Some(Interrupted(s as i32)),
    }
}

/// `Err(Interrupted)` once a signal arrived since [`catch_signals`]: for a loop that stops by
/// returning the error, so that its [`OutFile`]s are dropped (their temporary files removed,
/// logs kept) before `main` exits with status 128 + signal.
pub fn check_interrupted() -> Result<()> {
    match interrupted() {
        Some(sig) => Err(sig.into()),
        None => Ok(()),
    }
}

/// A stop requested by a signal: an error that `main` turns into exit status 128 + signal.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Interrupted(pub i32);

impl Interrupted {
    /// The conventional exit status (130 for SIGINT, 143 for SIGTERM).
    pub fn exit_status(self) -> u8 {
        (128 + self.0).clamp(0, 255) as u8
    }
}

impl std::fmt::Display for Interrupted {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let name = match self.0 {
            2 => "SIGINT",
            15 => "SIGTERM",
            _ => "a signal",
        };
        write!(f, "stopped by {name}")
    }
}

impl std::error::Error for Interrupted {}

// ---------------------------------------------------------------------------------------------
// stdout and stderr

static STDOUT_BROKEN: AtomicBool = AtomicBool::new(false);

/// `true` once a write to stdout failed with a closed pipe (EPIPE): `main` then exits quietly
/// with status 141 (128 + SIGPIPE), as a C program killed by SIGPIPE would.
pub fn stdout_broken() -> bool {
    STDOUT_BROKEN.load(Ordering::SeqCst)
}

fn stdout_error(e: io::Error) -> anyhow::Error {
    if e.kind() == ErrorKind::BrokenPipe {
        STDOUT_BROKEN.store(true, Ordering::SeqCst);
    }
    anyhow::Error::new(e).context("cannot write to stdout")
}

/// Writes one line to stdout; a failure is an error (never a panic like `println!`).
pub fn stdout_line(args: std::fmt::Arguments<'_>) -> Result<()> {
    let mut out = io::stdout().lock();
    out.write_fmt(args)
        .and_then(|_| out.write_all(b"\n"))
        .map_err(stdout_error)
}

/// Flushes stdout; a failure is an error.
pub fn flush_stdout() -> Result<()> {
    io::stdout().flush().map_err(stdout_error)
}

/// stdout as a [`Write`] whose errors are recognised by [`stdout_broken`]: for bulk output
/// (a plan on stdout).
pub struct Stdout;

impl Write for Stdout {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        io::stdout()
            .lock()
            .write(buf)
            .inspect_err(note_stdout_error)
    }
    fn write_all(&mut self, buf: &[u8]) -> io::Result<()> {
        io::stdout()
            .lock()
            .write_all(buf)
            .inspect_err(note_stdout_error)
    }
    fn flush(&mut self) -> io::Result<()> {
        io::stdout().lock().flush().inspect_err(note_stdout_error)
    }
}

fn note_stdout_error(e: &io::Error) {
    if e.kind() == ErrorKind::BrokenPipe {
        STDOUT_BROKEN.store(true, Ordering::SeqCst);
    }
}

/// Writes a diagnostic line to stderr, ignoring failure (there is nowhere else to report it;
/// unlike `eprintln!`, a closed or full stderr never panics).
pub fn eprintln_quiet(args: std::fmt::Arguments<'_>) {
    let mut e = io::stderr().lock();
    let _ = e.write_fmt(args).and_then(|_| e.write_all(b"\n"));
}

/// `println!` that returns a `Result` instead of panicking on a broken or full stdout.
#[macro_export]
macro_rules! outln {
    ($($arg:tt)*) => {
        $crate::output::stdout_line(::std::format_args!($($arg)*))
    };
}

/// `eprintln!` that never panics (a closed or full stderr is ignored).
#[macro_export]
macro_rules! errln {
    ($($arg:tt)*) => {
        $crate::output::eprintln_quiet(::std::format_args!($($arg)*))
    };
}

/// A progress bar on stderr when it is a terminal; silent otherwise.
pub fn progress_bar(len: u64, what: &str) -> indicatif::ProgressBar {
    use std::io::IsTerminal;
    if !std::io::stderr().is_terminal() {
        return indicatif::ProgressBar::hidden();
    }
    let pb = indicatif::ProgressBar::new(len);
    pb.set_style(
        indicatif::ProgressStyle::with_template(
            "{msg} [{bar:30}] {pos}/{len} trials, {elapsed} (eta {eta})",
        )
        .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
        .progress_chars("=> "),
    );
    pb.set_message(what.to_string());
    pb
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dir(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("omnikin-output-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn temp_file_is_renamed_and_removed_on_drop() {
        let d = dir("tmp");
        let p = d.join("a.csv");
        let mut f = OutFile::create("--out", &p).unwrap();
        f.write_all(b"x\n").unwrap();
        assert!(!p.exists(), "the destination appears only at the commit");
        f.commit().unwrap();
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "x\n");
        let q = d.join("b.csv");
        let mut f = OutFile::create("--out", &q).unwrap();
        f.write_all(b"y\n").unwrap();
        drop(f);
        assert!(!q.exists());
        assert_eq!(
            std::fs::read_dir(&d).unwrap().count(),
            1,
            "no temp file left"
        );
        let r = d.join("log.csv");
        let mut f = OutFile::log("--log", &r).unwrap();
        f.write_all(b"row\n").unwrap();
        drop(f);
        assert_eq!(
            std::fs::read_to_string(&r).unwrap(),
            "row\n",
            "a log is kept on drop"
        );
    }

    #[test]
    fn distinct_outputs() {
        let d = dir("distinct");
        let a = d.join("x.svg");
        let b = d.join(".").join("x.svg");
        let e = check_distinct(&[("--out", &a), ("--plot", &b)]).unwrap_err();
        assert!(e.to_string().contains("same file"), "{e}");
        check_distinct(&[("--out", &a), ("--plot", &d.join("y.svg"))]).unwrap();
    }
}
