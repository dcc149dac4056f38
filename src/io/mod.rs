//! Output helpers shared by the stages: atomic file writes, so a failed or
//! interrupted job never leaves a partial file or clobbers the user's data;
//! the checks every command makes on its inputs and outputs before any work
//! ([`paths`]); the command's write transaction that renames every output
//! at the end, all or nothing ([`txn`]); and the registry of live temporary
//! files that a signal handler removes ([`remove_live_temps`]).

pub mod json;
mod parquet;
pub mod paths;
pub mod txn;

pub use crate::limits as budget;
pub use crate::limits::thread_budget;
pub use parquet::{write_parquet, write_table};
pub use paths::{check_inputs, check_outputs, Output};

use crate::error::{Error, Result};
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// Temporary files being written now (removed by [`remove_live_temps`] on
/// SIGINT/SIGTERM, so an interrupted job leaves nothing behind).
static LIVE_TEMPS: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

/// A temporary file path, registered for removal on interruption while it
/// lives; dropping it removes the file unless [`TempPath::keep`] was called.
pub struct TempPath {
    path: PathBuf,
    armed: bool,
}

impl TempPath {
    /// Registers `path` (a temporary file about to be created).
    pub fn new(path: PathBuf) -> Self {
        if let Ok(mut live) = LIVE_TEMPS.lock() {
            live.push(path.clone());
        }
        Self { path, armed: true }
    }

    /// The path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The file was renamed into place: nothing to remove any more.
    pub fn keep(mut self) {
        self.armed = false;
        self.unregister();
    }

    fn unregister(&self) {
        if let Ok(mut live) = LIVE_TEMPS.lock() {
            if let Some(i) = live.iter().position(|p| *p == self.path) {
                live.swap_remove(i);
            }
        }
    }
}

impl Drop for TempPath {
    fn drop(&mut self) {
        if self.armed {
            let _ = std::fs::remove_file(&self.path);
            self.unregister();
        }
    }
}

/// Removes every temporary file being written now (for a signal handler:
/// call it, then exit).
pub fn remove_live_temps() {
    // A poisoned lock is still read; a held one is waited for briefly
    // (its holders only push or remove one path).
    let live = match LIVE_TEMPS.try_lock() {
        Ok(l) => l.clone(),
        Err(std::sync::TryLockError::Poisoned(p)) => p.into_inner().clone(),
        Err(std::sync::TryLockError::WouldBlock) => {
            std::thread::sleep(std::time::Duration::from_millis(50));
            LIVE_TEMPS.lock().map(|l| l.clone()).unwrap_or_default()
        }
    };
    for p in live {
        let _ = std::fs::remove_file(p);
    }
}

/// The longest file name the file systems we write to accept (NAME_MAX
/// of Linux file systems, in bytes).
pub const NAME_MAX: usize = 255;

/// The temporary file beside `target`: hidden, named after the target
/// (shortened at a character boundary so the whole name stays within
/// [`NAME_MAX`]), this process and a per-process counter, with `ext`
/// appended where a writer needs an extension. One scheme for every
/// temporary, backup included.
pub fn temp_beside(target: &Path, ext: Option<&str>) -> Result<TempPath> {
    static COUNTER: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    let name = target
        .file_name()
        .ok_or_else(|| Error::Input {
            path: target.to_path_buf(),
            msg: "output path names no file".into(),
        })?
        .to_string_lossy()
        .into_owned();
    let dir = match target.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let n = COUNTER.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let suffix = match ext {
        Some(e) => format!(".{}.{n}.tmp.{e}", std::process::id()),
        None => format!(".{}.{n}.tmp", std::process::id()),
    };
    Ok(TempPath::new(dir.join(temp_name(&name, &suffix))))
}

/// `.{name}{suffix}`, with `name` cut (at a character boundary) so the
/// result has at most [`NAME_MAX`] bytes.
fn temp_name(name: &str, suffix: &str) -> String {
    let room = NAME_MAX.saturating_sub(1 + suffix.len());
    let mut cut = name.len().min(room);
    while !name.is_char_boundary(cut) {
        cut -= 1;
    }
    format!(".{}{suffix}", &name[..cut])
}

/// Where an output to `path` really goes: an existing symlink is written
/// through to its target (the link stays).
pub fn resolve_output(path: &Path) -> PathBuf {
    match std::fs::symlink_metadata(path) {
        Ok(m) if m.file_type().is_symlink() => {
            std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf())
        }
        _ => path.to_path_buf(),
    }
}

/// A file being written atomically: data goes to a temporary file beside the
/// target, and only [`AtomicFile::commit`] renames it into place. Dropping it
/// without committing removes the temporary file.
pub struct AtomicFile {
    target: PathBuf,
    /// Where the rename goes (the target, or a symlink's target).
    dest: PathBuf,
    tmp: Option<TempPath>,
    writer: Option<BufWriter<File>>,
}

impl AtomicFile {
    /// Starts writing `target` (its directory must exist). An existing
    /// symlink is written through to its target; an existing file that is
    /// not a regular file (a FIFO, a device, a directory) is refused.
    pub fn create(target: &Path) -> Result<Self> {
        let dest = resolve_output(target);
        paths::refuse_special(target, &dest)?;
        let tmp = temp_beside(&dest, None)?;
        let file = File::create(tmp.path()).map_err(|source| Error::Io {
            path: target.to_path_buf(),
            source,
        })?;
        Ok(Self {
            target: target.to_path_buf(),
            dest,
            tmp: Some(tmp),
            writer: Some(BufWriter::new(file)),
        })
    }

    /// The buffered writer of the temporary file.
    pub fn writer(&mut self) -> &mut BufWriter<File> {
        self.writer.as_mut().expect("writer present until commit")
    }

    /// Maps an I/O error to the crate error naming the target file.
    pub fn io_err(&self, source: std::io::Error) -> Error {
        Error::Io {
            path: self.target.clone(),
            source,
        }
    }

    /// Flushes and syncs the temporary file, and renames it into place
    /// (inside a write transaction: when the transaction commits).
    pub fn commit(mut self) -> Result<()> {
        let w = self.writer.take().expect("writer present until commit");
        let file = w.into_inner().map_err(|e| self.io_err(e.into_error()))?;
        file.sync_all().map_err(|e| self.io_err(e))?;
        drop(file);
        let tmp = self.tmp.take().expect("temp present until commit");
        txn::finish(tmp, &self.dest, &self.target)
    }
}

/// Writes `bytes` to `target` atomically.
pub fn write_atomic(target: &Path, bytes: &[u8]) -> Result<()> {
    let mut f = AtomicFile::create(target)?;
    f.writer().write_all(bytes).map_err(|e| Error::Io {
        path: target.to_path_buf(),
        source: e,
    })?;
    f.commit()
}

/// Refuses outputs that would overwrite an input (checked before any work
/// starts): an output path that exists and is the same file as one of the
/// `inputs` (or a CSV input's channel map `NAME.map.toml`) is an error
/// naming both. Outputs that do not exist yet cannot be inputs.
pub fn ensure_not_inputs<'a>(
    inputs: impl IntoIterator<Item = &'a Path>,
    outputs: impl IntoIterator<Item = &'a Path>,
) -> Result<()> {
    let mut ins: Vec<(std::path::PathBuf, &Path)> = Vec::new();
    for p in inputs {
        if let Ok(c) = std::fs::canonicalize(p) {
            ins.push((c, p));
        }
        if p.extension().is_some_and(|e| e.eq_ignore_ascii_case("csv")) {
            let map = p.with_extension("map.toml");
            if let Ok(c) = std::fs::canonicalize(&map) {
                ins.push((c, p));
            }
        }
    }
    for out in outputs {
        let Ok(c) = std::fs::canonicalize(out) else {
            continue;
        };
        if let Some((_, input)) = ins.iter().find(|(i, _)| *i == c) {
            return Err(Error::Input {
                path: out.to_path_buf(),
                msg: format!(
                    "this output would overwrite the input {} (or its channel map): choose another output file",
                    input.display()
                ),
            });
        }
    }
    Ok(())
}

/// SHA-256 (hex) and length of a file, streamed: a long log is hashed in
/// constant memory.
pub fn sha256_file(path: &Path) -> Result<(String, u64)> {
    use sha2::{Digest, Sha256};
    use std::io::Read;
    let io = |source| Error::Io {
        path: path.to_path_buf(),
        source,
    };
    let mut file = File::open(path).map_err(io)?;
    let mut hasher = Sha256::new();
    let mut buf = vec![0u8; 1 << 16];
    let mut len = 0u64;
    loop {
        let n = file.read(&mut buf).map_err(io)?;
        if n == 0 {
            break;
        }
        hasher.update(&buf[..n]);
        len += n as u64;
    }
    let digest = hasher.finalize();
    Ok((digest.iter().map(|b| format!("{b:02x}")).collect(), len))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn temporary_names_stay_within_name_max() {
        let names = [
            "a.json".to_string(),
            "é".repeat(100) + ".json",
            "a".repeat(245) + ".json",
            "é".repeat(125) + ".svg",
        ];
        for name in &names {
            assert!(name.len() <= NAME_MAX);
            let len = name.len();
            let t = temp_beside(Path::new(name), Some("png")).unwrap();
            let tn = t.path().file_name().unwrap().len();
            assert!(tn <= NAME_MAX, "{len}: {tn} bytes");
            let t2 = temp_beside(Path::new(name), Some("png")).unwrap();
            assert_ne!(t.path(), t2.path(), "each temporary is unique");
        }
        assert_eq!(temp_name("a.svg", ".1.0.tmp"), ".a.svg.1.0.tmp");
    }
}
