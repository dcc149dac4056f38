//! Output helpers shared by the stages: atomic file writes, so a failed or
//! interrupted job never leaves a partial file or clobbers the user's data.

pub mod json;
mod parquet;

pub use parquet::{write_parquet, write_table};

use crate::error::{Error, Result};
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// A file being written atomically: data goes to a temporary file beside the
/// target, and only [`AtomicFile::commit`] renames it into place. Dropping it
/// without committing removes the temporary file.
pub struct AtomicFile {
    target: PathBuf,
    tmp: PathBuf,
    writer: Option<BufWriter<File>>,
}

impl AtomicFile {
    /// Starts writing `target` (its directory must exist).
    pub fn create(target: &Path) -> Result<Self> {
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
        let tmp = dir.join(format!(".{name}.{}.tmp", std::process::id()));
        let file = File::create(&tmp).map_err(|source| Error::Io {
            path: target.to_path_buf(),
            source,
        })?;
        Ok(Self {
            target: target.to_path_buf(),
            tmp,
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

    /// Flushes, syncs and renames the temporary file into place.
    pub fn commit(mut self) -> Result<()> {
        let w = self.writer.take().expect("writer present until commit");
        let file = w.into_inner().map_err(|e| self.io_err(e.into_error()))?;
        file.sync_all().map_err(|e| self.io_err(e))?;
        drop(file);
        std::fs::rename(&self.tmp, &self.target).map_err(|e| self.io_err(e))?;
        Ok(())
    }
}

impl Drop for AtomicFile {
    fn drop(&mut self) {
        if self.writer.is_some() {
            self.writer = None;
            let _ = std::fs::remove_file(&self.tmp);
        }
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
