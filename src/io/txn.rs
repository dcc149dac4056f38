//! One write transaction per command, so a command with several outputs is
//! all-or-nothing (issue 29). While a transaction is open ([`begin`], done
//! by the CLI before any command runs), [`super::AtomicFile::commit`] does
//! not rename its temporary file into place: it hands it to the
//! transaction. The command then prints its `--json` object (an error there,
//! other than a closed pipe, fails the command) and [`commit`] renames every
//! file, keeping a hard link to each replaced file until every rename has
//! succeeded and restoring them if one fails. [`abort`] (or a command that
//! returns an error) removes the temporaries, and a report directory the
//! command created is removed again. Without an open transaction (library
//! use), a commit renames at once, as before.
//!
//! Shared files that several runs update (`truth.json`) are read and
//! written under a lock on their directory ([`lock_beside`]) that the
//! transaction holds until its renames are done.
//!
//! Interrupts (SIGINT/SIGTERM): the signal handler asks [`on_interrupt`]
//! what to do. While the command works (before [`commit`]) the handler
//! removes the temporaries and exits at once (130). Once the renames have
//! begun, the handler only records the interrupt: the rename phase is a
//! critical section, and [`commit`] checks the record before each rename
//! and once more after the last; if it is set, every rename done so far is
//! undone (each replaced file restored from its hard link, each new file
//! removed), the temporaries and created directories are removed and
//! [`commit`] returns [`Error::Interrupted`] (exit 130). An interrupt that
//! comes after that last check is too late to undo anything: the command
//! has written every output and exits as it would have.

use super::TempPath;
use crate::error::{Error, Result};
use std::fs::File;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU8, Ordering::SeqCst};
use std::sync::Mutex;

/// Where the process stands for an interrupt (see the module docs).
static PHASE: AtomicU8 = AtomicU8::new(WORKING);
/// The command works: an interrupt removes the temporaries and exits.
const WORKING: u8 = 0;
/// The renames are under way: an interrupt is only recorded.
const RENAMING: u8 = 1;
/// The signal handler is removing the temporaries and exiting: no rename
/// may start.
const EXITING: u8 = 2;
/// Every output is in place: an interrupt is too late to undo anything.
const COMMITTED: u8 = 3;
/// Whether an interrupt came.
static INTERRUPTED: AtomicBool = AtomicBool::new(false);

/// For the signal handler: records the interrupt and says whether the
/// handler should remove the temporaries and exit now (`true`: the command
/// is still working), or leave it to [`commit`] (`false`: the renames are
/// under way and will be undone, or are all done).
pub fn on_interrupt() -> bool {
    INTERRUPTED.store(true, SeqCst);
    PHASE
        .compare_exchange(WORKING, EXITING, SeqCst, SeqCst)
        .is_ok()
}

/// One file written to its temporary, waiting for the rename.
struct Pending {
    tmp: TempPath,
    /// Where the rename goes (a symlink's target for user-named paths).
    dest: PathBuf,
    /// The path as named (for messages).
    target: PathBuf,
}

/// The open transaction's state.
#[derive(Default)]
struct State {
    pending: Vec<Pending>,
    /// Directories this command created (outermost first), removed on failure.
    created_dirs: Vec<PathBuf>,
    /// Locks held until the renames are done.
    locks: Vec<File>,
    /// The one thread whose outputs join the transaction (unit tests, which
    /// run beside others in one process); `None`: every thread (the CLI).
    thread: Option<std::thread::ThreadId>,
}

static CURRENT: Mutex<Option<State>> = Mutex::new(None);
/// Created directories, also for the signal handler (which must not wait
/// for [`CURRENT`]).
static CREATED: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

fn state() -> std::sync::MutexGuard<'static, Option<State>> {
    CURRENT.lock().unwrap_or_else(|p| p.into_inner())
}

/// Opens the process's write transaction (the CLI does, before a command
/// runs). Outputs committed from now on are renamed by [`commit`].
pub fn begin() {
    *state() = Some(State::default());
    INTERRUPTED.store(false, SeqCst);
    PHASE.store(WORKING, SeqCst);
}

/// Opens a transaction that only this thread's outputs join (for tests).
#[cfg(test)]
fn begin_in_thread() {
    *state() = Some(State {
        thread: Some(std::thread::current().id()),
        ..State::default()
    });
    INTERRUPTED.store(false, SeqCst);
    PHASE.store(WORKING, SeqCst);
}

/// The open transaction, if this thread's outputs join it.
fn mine(s: &mut Option<State>) -> Option<&mut State> {
    s.as_mut()
        .filter(|st| st.thread.is_none_or(|t| t == std::thread::current().id()))
}

/// Whether a transaction is open.
pub fn active() -> bool {
    state().is_some()
}

/// Hands a finished temporary file to the open transaction, or renames it
/// into place at once when none is open.
pub(crate) fn finish(tmp: TempPath, dest: &Path, target: &Path) -> Result<()> {
    let mut s = state();
    match mine(&mut s) {
        Some(st) => {
            st.pending.push(Pending {
                tmp,
                dest: dest.to_path_buf(),
                target: target.to_path_buf(),
            });
            Ok(())
        }
        None => {
            drop(s);
            std::fs::rename(tmp.path(), dest).map_err(|source| Error::Io {
                path: target.to_path_buf(),
                source,
            })?;
            tmp.keep();
            Ok(())
        }
    }
}

/// The size of the file that will land at `path` (its pending temporary
/// while a transaction is open, else the file itself).
pub fn written_len(path: &Path) -> Option<u64> {
    let dest = super::resolve_output(path);
    let from_txn = state().as_ref().and_then(|st| {
        st.pending
            .iter()
            .rev()
            .find(|p| p.dest == dest || p.target == path)
            .and_then(|p| std::fs::metadata(p.tmp.path()).ok())
            .map(|m| m.len())
    });
    from_txn.or_else(|| std::fs::metadata(path).ok().map(|m| m.len()))
}

/// Creates the directory `dir` (and missing parents) for a command's
/// outputs; those it created are removed again if the command fails.
pub fn create_dir(dir: &Path) -> Result<()> {
    let mut missing = Vec::new();
    let mut d = Some(dir);
    while let Some(p) = d {
        if p.as_os_str().is_empty() || std::fs::symlink_metadata(p).is_ok() {
            break;
        }
        missing.push(p.to_path_buf());
        d = p.parent();
    }
    std::fs::create_dir_all(dir).map_err(|source| Error::Io {
        path: dir.to_path_buf(),
        source,
    })?;
    missing.reverse();
    if let Some(st) = mine(&mut state()) {
        st.created_dirs.extend(missing.iter().cloned());
        CREATED
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .extend(missing);
    }
    Ok(())
}

/// Takes the exclusive lock for updating a shared file `path` (`flock` on
/// the directory that holds it: no lock file is left behind), waiting for
/// other runs that hold it. Inside a transaction the lock is held until its
/// renames are done; without one, until the returned guard is dropped.
pub fn lock_beside(path: &Path) -> Result<Option<File>> {
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let io = |source| Error::Io {
        path: dir.clone(),
        source,
    };
    let file = File::open(&dir).map_err(io)?;
    file.lock().map_err(io)?;
    let mut s = state();
    match mine(&mut s) {
        Some(st) => {
            st.locks.push(file);
            Ok(None)
        }
        None => Ok(Some(file)),
    }
}

/// A hidden name beside `dest` for a replaced file's hard link.
fn backup_path(dest: &Path) -> Result<TempPath> {
    super::temp_beside(dest, Some("bak"))
}

/// Renames every pending file into place (see the module docs): a
/// replaced file is kept as a hard link until all renames have succeeded,
/// and restored if one fails or an interrupt comes before the last check.
/// Closes the transaction.
pub fn commit() -> Result<()> {
    let Some(mut st) = state().take() else {
        return Ok(());
    };
    // From here an interrupt is only recorded; if the handler is already
    // removing the temporaries, it exits the process: wait for that.
    if PHASE
        .compare_exchange(WORKING, RENAMING, SeqCst, SeqCst)
        .is_err()
    {
        drop(st);
        loop {
            std::thread::park();
        }
    }
    let pending = std::mem::take(&mut st.pending);
    let mut done: Vec<(PathBuf, Option<TempPath>)> = Vec::new();
    let mut failure = None;
    let mut rest = pending.into_iter();
    for p in rest.by_ref() {
        if INTERRUPTED.load(SeqCst) {
            failure = Some(Error::Interrupted);
            break;
        }
        let backup = match std::fs::symlink_metadata(&p.dest) {
            Ok(m) if m.is_file() => {
                let b = match backup_path(&p.dest) {
                    Ok(b) => b,
                    Err(e) => {
                        failure = Some(e);
                        break;
                    }
                };
                if let Err(source) = std::fs::hard_link(&p.dest, b.path()) {
                    failure = Some(Error::Io {
                        path: p.target.clone(),
                        source,
                    });
                    break;
                }
                Some(b)
            }
            _ => None,
        };
        if let Err(source) = std::fs::rename(p.tmp.path(), &p.dest) {
            failure = Some(Error::Io {
                path: p.target.clone(),
                source,
            });
            break;
        }
        p.tmp.keep();
        done.push((p.dest, backup));
        after_rename(done.len());
    }
    // The commit point: an interrupt recorded up to here undoes every
    // rename; one after it finds the phase COMMITTED and changes nothing.
    if failure.is_none() {
        PHASE.store(COMMITTED, SeqCst);
        if INTERRUPTED.load(SeqCst) {
            failure = Some(Error::Interrupted);
        }
    }
    // Temporaries not renamed are dropped (removed) here.
    drop(rest);
    match failure {
        None => {
            // Dropping the backups removes the hard links.
            drop(done);
            forget_created();
            drop(st);
            Ok(())
        }
        Some(e) => {
            for (dest, backup) in done.into_iter().rev() {
                match backup {
                    Some(b) => {
                        if std::fs::rename(b.path(), &dest).is_ok() {
                            b.keep();
                        }
                    }
                    None => {
                        let _ = std::fs::remove_file(&dest);
                    }
                }
            }
            remove_created(&st.created_dirs);
            forget_created();
            drop(st);
            PHASE.store(COMMITTED, SeqCst);
            Err(e)
        }
    }
}

/// Called after the `n`-th rename of [`commit`]: where tests put an
/// interrupt between two renames. Unit tests record one directly; in debug
/// builds `STICKSLIP_FAILPOINT=interrupt-after-rename:N` makes the process
/// send itself SIGINT after the N-th rename and wait until its handler has
/// recorded it (the integration rows of `tests/misuse.rs`). Release builds
/// have neither.
fn after_rename(n: usize) {
    #[cfg(test)]
    if TEST_INTERRUPT_AFTER.load(SeqCst) == n {
        assert!(!on_interrupt(), "the renames are under way: only recorded");
    }
    #[cfg(debug_assertions)]
    if let Ok(v) = std::env::var("STICKSLIP_FAILPOINT") {
        let at = v
            .strip_prefix("interrupt-after-rename:")
            .and_then(|k| k.parse::<usize>().ok());
        if at == Some(n) {
            let _ = std::process::Command::new("kill")
                .args(["-INT", &std::process::id().to_string()])
                .status();
            let t0 = std::time::Instant::now();
            while !INTERRUPTED.load(SeqCst) && t0.elapsed().as_secs() < 60 {
                std::thread::sleep(std::time::Duration::from_millis(1));
            }
        }
    }
    let _ = n;
}

/// The rename after which a unit test records an interrupt (0: none).
#[cfg(test)]
static TEST_INTERRUPT_AFTER: std::sync::atomic::AtomicUsize =
    std::sync::atomic::AtomicUsize::new(0);

/// Abandons the open transaction: removes its temporaries and the
/// directories it created.
pub fn abort() {
    let Some(mut st) = state().take() else {
        return;
    };
    st.pending.clear();
    remove_created(&st.created_dirs);
    forget_created();
}

/// Removes created directories, innermost first, where they are empty
/// (after the temporaries are gone they are).
fn remove_created(dirs: &[PathBuf]) {
    for d in dirs.iter().rev() {
        let _ = std::fs::remove_dir(d);
    }
}

fn forget_created() {
    CREATED.lock().unwrap_or_else(|p| p.into_inner()).clear();
}

/// For the signal handler, after the temporaries are removed: removes the
/// directories the command created (where empty).
pub fn remove_created_dirs() {
    let dirs = match CREATED.try_lock() {
        Ok(d) => d.clone(),
        Err(_) => return,
    };
    remove_created(&dirs);
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The transaction is process-global: its tests run one at a time.
    static SERIAL: Mutex<()> = Mutex::new(());

    #[test]
    fn a_failed_rename_restores_every_replaced_file() {
        let _g = SERIAL.lock().unwrap_or_else(|p| p.into_inner());
        let t = tempfile::tempdir().unwrap();
        let d = t.path();
        let a = d.join("a.csv");
        std::fs::write(&a, b"old a").unwrap();
        let b = d.join("b.csv");
        begin_in_thread();
        super::super::write_atomic(&a, b"new a").unwrap();
        super::super::write_atomic(&b, b"new b").unwrap();
        // Nothing is in place before the commit.
        assert_eq!(std::fs::read(&a).unwrap(), b"old a");
        assert!(!b.exists());
        // The second rename will fail: its destination became a non-empty
        // directory.
        std::fs::create_dir(&b).unwrap();
        std::fs::write(b.join("x"), b"x").unwrap();
        assert!(commit().is_err());
        assert_eq!(std::fs::read(&a).unwrap(), b"old a");
        let mut names: Vec<_> = std::fs::read_dir(d)
            .unwrap()
            .flatten()
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        assert_eq!(names, ["a.csv", "b.csv"], "no temporary or backup left");
        assert!(!active());
    }

    /// The names in `d`, sorted.
    fn names(d: &Path) -> Vec<String> {
        let mut v: Vec<_> = std::fs::read_dir(d)
            .unwrap()
            .flatten()
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    /// An interrupt recorded after the k-th of three renames (every k,
    /// the last included: before the commit point) undoes them all: the
    /// two replaced files hold their old bytes, the new file and the
    /// created directory are gone, no temporary or backup is left, and the
    /// handler was told not to exit (the transaction honours the
    /// interrupt). Deterministic: the interrupt is injected between the
    /// renames, not timed.
    #[test]
    fn an_interrupt_between_renames_undoes_every_rename() {
        let _g = SERIAL.lock().unwrap_or_else(|p| p.into_inner());
        for k in 1..=3 {
            let t = tempfile::tempdir().unwrap();
            let d = t.path();
            let (a, b) = (d.join("a.csv"), d.join("b.svg"));
            std::fs::write(&a, b"old a").unwrap();
            std::fs::write(&b, b"old b").unwrap();
            begin_in_thread();
            let rep = d.join("rep");
            create_dir(&rep).unwrap();
            let c = rep.join("c.json");
            super::super::write_atomic(&a, b"new a").unwrap();
            super::super::write_atomic(&b, b"new b").unwrap();
            super::super::write_atomic(&c, b"new c").unwrap();
            TEST_INTERRUPT_AFTER.store(k, SeqCst);
            let r = commit();
            TEST_INTERRUPT_AFTER.store(0, SeqCst);
            assert!(matches!(r, Err(Error::Interrupted)), "k = {k}: {r:?}");
            assert_eq!(std::fs::read(&a).unwrap(), b"old a", "k = {k}");
            assert_eq!(std::fs::read(&b).unwrap(), b"old b", "k = {k}");
            assert_eq!(names(d), ["a.csv", "b.svg"], "k = {k}");
            assert!(!active());
        }
    }

    /// The handler's decision by phase: exit at once while the command
    /// works; only record once the renames have begun or are done (an
    /// interrupt after the commit point changes nothing).
    #[test]
    fn the_handler_exits_only_before_the_renames() {
        let _g = SERIAL.lock().unwrap_or_else(|p| p.into_inner());
        let t = tempfile::tempdir().unwrap();
        let a = t.path().join("a.csv");
        begin_in_thread();
        super::super::write_atomic(&a, b"new").unwrap();
        commit().unwrap();
        assert!(!on_interrupt(), "after the commit point: too late, no exit");
        assert_eq!(std::fs::read(&a).unwrap(), b"new");
        begin_in_thread();
        assert!(on_interrupt(), "while working: the handler exits");
        // (The handler would now remove the temporaries and exit; reset.)
        abort();
        PHASE.store(WORKING, SeqCst);
        INTERRUPTED.store(false, SeqCst);
    }

    #[test]
    fn commit_renames_all_and_abort_removes_temps_and_created_dirs() {
        let _g = SERIAL.lock().unwrap_or_else(|p| p.into_inner());
        let t = tempfile::tempdir().unwrap();
        let d = t.path();
        let a = d.join("a.csv");
        std::fs::write(&a, b"old").unwrap();
        begin_in_thread();
        super::super::write_atomic(&a, b"new").unwrap();
        assert_eq!(written_len(&a), Some(3));
        commit().unwrap();
        assert_eq!(std::fs::read(&a).unwrap(), b"new");
        assert_eq!(std::fs::read_dir(d).unwrap().count(), 1);
        begin_in_thread();
        let rep = d.join("rep/sub");
        create_dir(&rep).unwrap();
        super::super::write_atomic(&rep.join("index.html"), b"x").unwrap();
        abort();
        assert!(!d.join("rep").exists());
        assert_eq!(std::fs::read_dir(d).unwrap().count(), 1);
    }

    #[test]
    fn lock_is_exclusive_between_handles() {
        let _g = SERIAL.lock().unwrap_or_else(|p| p.into_inner());
        let t = tempfile::tempdir().unwrap();
        let p = t.path().join("truth.json");
        let held = lock_beside(&p).unwrap().expect("no transaction: a guard");
        let other = File::open(t.path()).unwrap();
        assert!(matches!(
            other.try_lock(),
            Err(std::fs::TryLockError::WouldBlock)
        ));
        drop(held);
        assert!(other.try_lock().is_ok());
    }
}
