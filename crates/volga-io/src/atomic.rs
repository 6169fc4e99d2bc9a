//! Atomic output: temp file in the target's directory, fsync, rename.

use std::ffi::OsString;
use std::fs::{self, File, OpenOptions};
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use crate::IoError;

/// Distinguishes temp files of one process (threads may stage the same name).
static TEMP_COUNTER: AtomicU64 = AtomicU64::new(0);

/// Temp files that exist now (created, not yet renamed or deleted), so a signal handler
/// can delete them ([`remove_temp_files`]).
static LIVE_TEMPS: std::sync::Mutex<Vec<PathBuf>> = std::sync::Mutex::new(Vec::new());

/// Set by [`remove_temp_files`]: no temp file may be created after it ran.
static TEMPS_CLOSED: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

fn live_temps() -> std::sync::MutexGuard<'static, Vec<PathBuf>> {
    LIVE_TEMPS.lock().unwrap_or_else(|poisoned| poisoned.into_inner())
}

/// Deletes every temp file this process's staged and atomic writes hold now, and
/// returns how many. For a program's SIGINT/SIGTERM handler (the `volga` CLI installs
/// one) before it exits: an interrupted run then leaves no `.{name}.tmp-*` behind, and
/// its outputs as they were. After it, no staged or atomic write of this process creates a
/// temp file any more: a thread that tries waits for the process to end, so it can
/// neither leave a temp file behind nor report an error before the handler exits. Call it
/// only from a handler that ends the process right after.
pub fn remove_temp_files() -> usize {
    let mut live = live_temps();
    // From now on no temp file is created: a thread still writing cannot leave one
    // behind after this cleanup (creation and this flag are both under the lock).
    TEMPS_CLOSED.store(true, Ordering::SeqCst);
    let n = live.len();
    for temp in live.drain(..) {
        let _ = fs::remove_file(temp);
    }
    n
}

/// Buffer between the caller's writes and the temp file.
const WRITE_BUFFER: usize = 1 << 20;

/// A complete, synced temp file waiting to be renamed over `target`; deleted on drop
/// unless [`TempOutput::persist`] succeeded.
#[derive(Debug)]
struct TempOutput {
    temp: PathBuf,
    target: PathBuf,
    /// [`output_identity`] of `target`.
    identity: PathBuf,
    armed: bool,
}

impl TempOutput {
    /// Creates `.{name}.tmp-{pid}-{counter}` next to `target` and fills it with `write`.
    fn write(target: &Path, write: impl FnOnce(&mut dyn Write) -> io::Result<()>) -> Result<TempOutput, IoError> {
        let name = target.file_name().ok_or_else(|| {
            IoError::io(
                target,
                io::Error::new(io::ErrorKind::InvalidInput, "output path has no file name"),
            )
        })?;
        let dir = parent_dir(target);
        let mut attempts = 0;
        let (file, temp) = loop {
            let n = TEMP_COUNTER.fetch_add(1, Ordering::Relaxed);
            let mut temp_name = OsString::from(".");
            temp_name.push(name);
            temp_name.push(format!(".tmp-{}-{n}", std::process::id()));
            let temp = dir.join(temp_name);
            // Created and registered under the lock [`remove_temp_files`] takes, so a
            // signal handler's cleanup either sees this file or runs before it exists
            // and stops it from being created.
            let mut live = live_temps();
            if TEMPS_CLOSED.load(Ordering::SeqCst) {
                // The process is ending (the handler exits right after its cleanup): wait
                // for it rather than report an error that could race the handler's exit.
                drop(live);
                loop {
                    std::thread::park();
                }
            }
            match OpenOptions::new().write(true).create_new(true).open(&temp) {
                Ok(file) => {
                    live.push(temp.clone());
                    break (file, temp);
                }
                // A stale temp of an earlier process with the same pid: pick another.
                Err(e) if e.kind() == io::ErrorKind::AlreadyExists && attempts < 64 => attempts += 1,
                Err(e) => return Err(IoError::io(target, e)),
            }
        };
        // Declared before the writer so that on an early return the writer (and its
        // file handle) is dropped first, then the guard deletes the temp file.
        let guard = TempOutput {
            temp,
            target: target.to_path_buf(),
            identity: output_identity(target),
            armed: true,
        };
        let mut writer = BufWriter::with_capacity(WRITE_BUFFER, file);
        write(&mut writer).map_err(|e| IoError::io(target, e))?;
        let file = writer.into_inner().map_err(|e| IoError::io(target, e.into_error()))?;
        file.sync_all().map_err(|e| IoError::io(target, e))?;
        drop(file);
        Ok(guard)
    }

    /// Renames the temp file over the target; on failure the temp file is deleted
    /// (by drop) and the target is untouched.
    fn persist(mut self) -> Result<PathBuf, IoError> {
        fs::rename(&self.temp, &self.target).map_err(|e| IoError::io(&self.target, e))?;
        self.armed = false;
        forget_temp(&self.temp);
        Ok(std::mem::take(&mut self.target))
    }
}

impl Drop for TempOutput {
    fn drop(&mut self) {
        if self.armed {
            let _ = fs::remove_file(&self.temp);
            forget_temp(&self.temp);
        }
    }
}

/// Drops `temp` from the live list (renamed or deleted).
fn forget_temp(temp: &Path) {
    let mut live = live_temps();
    if let Some(i) = live.iter().rposition(|t| t == temp) {
        live.swap_remove(i);
    }
}

/// The file an output path will replace, as the filesystem sees it: its directory with
/// every symbolic link and `.`/`..` resolved, and its file name. Two output paths with the
/// same identity are the same file (`d/sub/../v.raw` and `d/v.raw`); a final symbolic
/// link is not followed, since the rename that writes an output replaces the link itself.
/// Where the directory does not exist yet, the path as given (made absolute) is used.
pub fn output_identity(path: &Path) -> PathBuf {
    let dir = parent_dir(path);
    let dir = dir.canonicalize().unwrap_or_else(|_| {
        std::env::current_dir()
            .map(|c| c.join(dir))
            .unwrap_or_else(|_| dir.to_path_buf())
    });
    match path.file_name() {
        Some(name) => dir.join(name),
        None => dir,
    }
}

/// The directory a relative or absolute file path lives in (`.` for a bare name).
fn parent_dir(path: &Path) -> &Path {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

/// Makes renames in `dir` durable (best effort: not every platform can open or sync a
/// directory, and the data itself is already synced).
fn sync_dir(dir: &Path) {
    if let Ok(d) = File::open(dir) {
        let _ = d.sync_all();
    }
}

/// Writes `path` atomically: `write` fills a temp file `.{name}.tmp-{pid}-{counter}` in
/// the same directory (buffered), which is flushed and synced, then renamed over
/// `path`.
///
/// If `write` (or the flush) fails, or panics, the temp file is removed and `path` is
/// untouched. Errors name `path`.
pub fn write_atomic(path: &Path, write: impl FnOnce(&mut dyn Write) -> io::Result<()>) -> Result<(), IoError> {
    TempOutput::write(path, write)?.persist()?;
    sync_dir(parent_dir(path));
    Ok(())
}

/// A set of outputs committed together.
///
/// Each [`stage`](StagedOutputs::stage) writes a complete, synced temp file next to
/// its final path; [`commit`](StagedOutputs::commit) renames all of them, in staging
/// order. Dropping the set without committing deletes every temp file, leaving
/// existing outputs untouched, so a run that fails half-way (an error in the third of
/// four outputs) changes nothing on disk.
///
/// Each rename is atomic, the set as a whole is not: if a rename fails during
/// `commit`, the outputs renamed before it stay in place and the rest are discarded.
#[derive(Debug, Default)]
pub struct StagedOutputs {
    staged: Vec<TempOutput>,
}

impl StagedOutputs {
    /// An empty set: nothing staged, nothing written.
    pub fn new() -> Self {
        StagedOutputs::default()
    }

    /// Writes `path`'s new content to a temp file in `path`'s directory. Staging the
    /// same file twice, under any spelling of its path ([`output_identity`]), is an error
    /// (two outputs would overwrite each other).
    pub fn stage(&mut self, path: &Path, write: impl FnOnce(&mut dyn Write) -> io::Result<()>) -> Result<(), IoError> {
        let identity = output_identity(path);
        if let Some(t) = self.staged.iter().find(|t| t.identity == identity) {
            return Err(IoError::io(
                path,
                io::Error::new(
                    io::ErrorKind::AlreadyExists,
                    format!("the same file as the output {} staged before it", t.target.display()),
                ),
            ));
        }
        let temp = TempOutput::write(path, write)?;
        self.staged.push(temp);
        Ok(())
    }

    /// Renames every staged file over its final path, in staging order, and returns
    /// the final paths.
    pub fn commit(self) -> Result<Vec<PathBuf>, IoError> {
        // Pre-flight: a target that is a directory would make its rename fail after
        // earlier targets were already replaced; refuse before renaming anything, so
        // the common failure leaves every existing output as it was.
        for temp in &self.staged {
            if temp.target.is_dir() {
                return Err(IoError::Io {
                    path: temp.target.clone(),
                    source: std::io::Error::new(
                        std::io::ErrorKind::IsADirectory,
                        "a directory is in the way of this output",
                    ),
                });
            }
        }
        let mut done = Vec::with_capacity(self.staged.len());
        let mut dirs: Vec<PathBuf> = Vec::new();
        for temp in self.staged {
            let dir = parent_dir(&temp.target).to_path_buf();
            // On error the remaining temps are dropped (deleted) with the iterator.
            done.push(temp.persist()?);
            if !dirs.contains(&dir) {
                dirs.push(dir);
            }
        }
        for dir in &dirs {
            sync_dir(dir);
        }
        Ok(done)
    }

    /// Final paths of the staged files, in staging order.
    pub fn staged_paths(&self) -> Vec<PathBuf> {
        self.staged.iter().map(|t| t.target.clone()).collect()
    }

    /// Number of staged files.
    pub fn len(&self) -> usize {
        self.staged.len()
    }

    /// Whether no file is staged.
    pub fn is_empty(&self) -> bool {
        self.staged.is_empty()
    }

    /// Discards (deletes) the files staged after the first `len`.
    pub(crate) fn truncate(&mut self, len: usize) {
        self.staged.truncate(len);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn entries(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    #[test]
    fn failed_write_keeps_old_content_and_leaves_no_temp() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.txt");
        fs::write(&path, "old").unwrap();
        let err = write_atomic(&path, |w| {
            w.write_all(b"partial")?;
            Err(io::Error::other("boom"))
        })
        .unwrap_err();
        assert!(matches!(&err, IoError::Io { path: p, .. } if p == &path));
        assert!(err.to_string().contains("a.txt"), "{err}");
        assert_eq!(fs::read_to_string(&path).unwrap(), "old");
        assert_eq!(entries(dir.path()), vec!["a.txt"]);

        write_atomic(&path, |w| w.write_all(b"new")).unwrap();
        assert_eq!(fs::read_to_string(&path).unwrap(), "new");
        assert_eq!(entries(dir.path()), vec!["a.txt"]);
    }

    #[test]
    fn panicking_write_leaves_no_temp() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("p.bin");
        let r = std::panic::catch_unwind(|| {
            let _ = write_atomic(&path, |w| {
                w.write_all(b"x")?;
                panic!("writer panicked")
            });
        });
        assert!(r.is_err());
        assert!(entries(dir.path()).is_empty());
    }

    #[test]
    fn write_creates_new_file_and_reports_missing_dir() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("new.bin");
        write_atomic(&path, |w| w.write_all(&[1, 2, 3])).unwrap();
        assert_eq!(fs::read(&path).unwrap(), vec![1, 2, 3]);

        let missing = dir.path().join("no/such/dir/x.png");
        let err = write_atomic(&missing, |w| w.write_all(b"x")).unwrap_err();
        assert!(err.to_string().contains("no/such/dir/x.png"), "{err}");
        assert!(write_atomic(Path::new("/"), |_| Ok(())).is_err());
    }

    #[test]
    fn staged_outputs_commit_together_or_not_at_all() {
        let dir = tempfile::tempdir().unwrap();
        let a = dir.path().join("a.txt");
        let b = dir.path().join("b.txt");
        fs::write(&a, "old a").unwrap();

        let mut s = StagedOutputs::new();
        s.stage(&a, |w| w.write_all(b"new a")).unwrap();
        s.stage(&b, |w| w.write_all(b"new b")).unwrap();
        assert_eq!(s.staged_paths(), vec![a.clone(), b.clone()]);
        assert_eq!(s.len(), 2);
        // Staged but not committed: finals untouched.
        assert_eq!(fs::read_to_string(&a).unwrap(), "old a");
        assert!(!b.exists());
        drop(s);
        assert_eq!(fs::read_to_string(&a).unwrap(), "old a");
        assert!(!b.exists());
        assert_eq!(entries(dir.path()), vec!["a.txt"]);

        let mut s = StagedOutputs::new();
        s.stage(&a, |w| w.write_all(b"new a")).unwrap();
        s.stage(&b, |w| w.write_all(b"new b")).unwrap();
        assert!(s.stage(&a, |w| w.write_all(b"again")).is_err());
        assert_eq!(s.commit().unwrap(), vec![a.clone(), b.clone()]);
        assert_eq!(fs::read_to_string(&a).unwrap(), "new a");
        assert_eq!(fs::read_to_string(&b).unwrap(), "new b");
        assert_eq!(entries(dir.path()), vec!["a.txt", "b.txt"]);
    }

    #[test]
    fn failed_stage_discards_only_itself() {
        let dir = tempfile::tempdir().unwrap();
        let a = dir.path().join("a.txt");
        let b = dir.path().join("b.txt");
        let mut s = StagedOutputs::new();
        s.stage(&a, |w| w.write_all(b"a")).unwrap();
        assert!(s.stage(&b, |_| Err(io::Error::other("no"))).is_err());
        assert_eq!(s.staged_paths(), vec![a.clone()]);
        s.commit().unwrap();
        assert_eq!(entries(dir.path()), vec!["a.txt"]);
    }

    #[test]
    fn commit_failure_discards_the_rest() {
        let dir = tempfile::tempdir().unwrap();
        let a = dir.path().join("a.txt");
        let blocker = dir.path().join("blocker");
        fs::create_dir(&blocker).unwrap();
        fs::write(blocker.join("inside"), "x").unwrap();
        let c = dir.path().join("c.txt");
        let mut s = StagedOutputs::new();
        s.stage(&a, |w| w.write_all(b"a")).unwrap();
        // Renaming a file over a non-empty directory fails.
        s.stage(&blocker, |w| w.write_all(b"b")).unwrap();
        s.stage(&c, |w| w.write_all(b"c")).unwrap();
        let err = s.commit().unwrap_err();
        assert_eq!(err.path(), blocker);
        // The pre-flight check refuses before any rename: nothing was replaced.
        assert_eq!(entries(dir.path()), vec!["blocker"]);
    }
}
