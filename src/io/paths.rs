//! The checks every command makes before any work: each input is a
//! readable regular file; each output is a new name or a regular file (a
//! symlink is written through to its target), with the extension of the
//! format written, in an existing directory, not an input, and no two
//! outputs alike; a report directory is a directory or a new name. A
//! command that passes these checks and then fails writes nothing (its
//! outputs are atomic); one that fails them has done no work.

use crate::error::{Error, Result};
use std::path::{Path, PathBuf};

/// One output file of a command: the flag that names it, its path and the
/// extensions of the format it writes (lower case, without the dot; the
/// first is the one named in messages).
#[derive(Debug, Clone, Copy)]
pub struct Output<'a> {
    /// The flag, e.g. `--plot`.
    pub flag: &'static str,
    /// The path given.
    pub path: &'a Path,
    /// The accepted extensions, e.g. `["svg"]`.
    pub exts: &'static [&'static str],
}

impl<'a> Output<'a> {
    /// An output file.
    pub fn file(flag: &'static str, path: &'a Path, exts: &'static [&'static str]) -> Self {
        Self { flag, path, exts }
    }

    /// A directory (`--report DIR`): an existing directory or a new name.
    pub fn dir(flag: &'static str, path: &'a Path) -> Self {
        Self {
            flag,
            path,
            exts: &[],
        }
    }

    fn is_dir(&self) -> bool {
        self.exts.is_empty()
    }
}

fn input_err(path: &Path, msg: impl Into<String>) -> Error {
    Error::Input {
        path: path.to_path_buf(),
        msg: msg.into(),
    }
}

use crate::limits::special_kind;

/// Refuses an existing output path (`dest`, the resolved `target`) that is
/// not a regular file: the atomic rename would replace it.
pub(crate) fn refuse_special(target: &Path, dest: &Path) -> Result<()> {
    match std::fs::metadata(dest) {
        Ok(m) if m.is_dir() => Err(input_err(
            target,
            "is a directory: give a file name for this output",
        )),
        Ok(m) => match special_kind(&m.file_type()) {
            Some(kind) => Err(input_err(
                target,
                format!("is {kind}: stickslip writes regular files only, give a file name"),
            )),
            None => Ok(()),
        },
        Err(_) => Ok(()),
    }
}

/// Checks that every input is an existing, readable regular file (a FIFO
/// or device would block or never end; a directory is not a log).
pub fn check_inputs<'a>(inputs: impl IntoIterator<Item = &'a Path>) -> Result<()> {
    for p in inputs {
        let m = std::fs::metadata(p).map_err(|source| Error::Io {
            path: p.to_path_buf(),
            source,
        })?;
        if m.is_dir() {
            return Err(input_err(p, "is a directory, not a file"));
        }
        if let Some(kind) = special_kind(&m.file_type()) {
            return Err(input_err(
                p,
                format!("is {kind}, not a regular file: give the file itself"),
            ));
        }
        std::fs::File::open(p).map_err(|source| Error::Io {
            path: p.to_path_buf(),
            source,
        })?;
    }
    Ok(())
}

/// Reads a small text input (a plan, a sensor set) with the checks logs
/// get, before any read (see [`crate::limits::read_small_text`]).
pub fn read_small_text(path: &Path, what: &str, max_bytes: u64) -> Result<String> {
    crate::limits::read_small_text(path, what, max_bytes).map_err(|e| match e {
        crate::limits::SmallReadError::Io(source) => Error::Io {
            path: path.to_path_buf(),
            source,
        },
        crate::limits::SmallReadError::Refused(msg) => input_err(path, msg),
    })
}

/// The identity of a path for comparisons: the canonical file if it
/// exists, else the canonical directory joined with the name.
fn identity(path: &Path) -> PathBuf {
    if let Ok(c) = std::fs::canonicalize(path) {
        return c;
    }
    match (path.parent(), path.file_name()) {
        (Some(dir), Some(name)) => {
            let dir = if dir.as_os_str().is_empty() {
                Path::new(".")
            } else {
                dir
            };
            std::fs::canonicalize(dir)
                .map(|d| d.join(name))
                .unwrap_or_else(|_| path.to_path_buf())
        }
        _ => path.to_path_buf(),
    }
}

/// The lower-case extension of a path's file name.
fn extension(path: &Path) -> String {
    path.extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default()
}

/// The name of the format an extension stands for, as messages spell it.
fn format_name(ext: &str) -> String {
    match ext {
        "parquet" => "Parquet".into(),
        "toml" => "a TOML channel map".into(),
        other => other.to_ascii_uppercase(),
    }
}

fn ext_list(exts: &[&str]) -> String {
    let dotted: Vec<String> = exts.iter().map(|e| format!(".{e}")).collect();
    match dotted.as_slice() {
        [one] => one.clone(),
        [init @ .., last] => format!("{} or {last}", init.join(", ")),
        [] => String::new(),
    }
}

/// Checks one output file (see the module docs).
fn check_file(o: &Output) -> Result<()> {
    let path = o.path;
    let flag = o.flag;
    let text = path.as_os_str().to_string_lossy();
    if text.ends_with('/') || path.file_name().is_none() {
        return Err(input_err(
            path,
            format!(
                "{flag} names a directory: give a file name ending in {}",
                ext_list(o.exts)
            ),
        ));
    }
    let name_len = path.file_name().map_or(0, |n| n.len());
    if name_len > super::NAME_MAX {
        return Err(input_err(
            path,
            format!(
                "{flag}: the file name is {name_len} bytes, over the file system's limit of {} bytes: give a shorter name",
                super::NAME_MAX
            ),
        ));
    }
    let ext = extension(path);
    if !o.exts.contains(&ext.as_str()) {
        return Err(input_err(
            path,
            format!(
                "{flag} writes {}: give a file name ending in {}",
                format_name(o.exts[0]),
                ext_list(o.exts)
            ),
        ));
    }
    let dest = super::resolve_output(path);
    if let Ok(m) = std::fs::symlink_metadata(path) {
        if m.file_type().is_symlink() && std::fs::metadata(path).is_err() {
            return Err(input_err(
                path,
                format!("{flag} is a broken symlink: remove it or give another file name"),
            ));
        }
    }
    refuse_special(path, &dest)?;
    if dest != path {
        // A symlink: its target must be a file of the same kind.
        let target_ext = extension(&dest);
        if !o.exts.contains(&target_ext.as_str()) {
            return Err(input_err(
                path,
                format!(
                    "{flag} is a symlink to {}, a file of another kind: it would be replaced by {} output",
                    dest.display(),
                    format_name(o.exts[0])
                ),
            ));
        }
    }
    let dir = match dest.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    match std::fs::metadata(&dir) {
        Ok(m) if m.is_dir() => Ok(()),
        Ok(_) => Err(input_err(
            path,
            format!("{flag}: {} is not a directory", dir.display()),
        )),
        Err(_) => Err(input_err(
            path,
            format!(
                "{flag}: the directory {} does not exist (create it first)",
                dir.display()
            ),
        )),
    }
}

/// Checks a file the tool names itself inside a report directory: an
/// existing symlink is refused (never written through: it may point at a
/// user's file), as is anything but a regular file.
pub fn check_tool_named(path: &Path) -> Result<()> {
    match std::fs::symlink_metadata(path) {
        Ok(m) if m.file_type().is_symlink() => Err(input_err(
            path,
            "is a symlink inside the report directory: stickslip names the report's files itself and never writes them through a symlink; remove it or choose another --report directory",
        )),
        Ok(_) => refuse_special(path, path),
        Err(_) => Ok(()),
    }
}

/// Checks a report directory: an existing directory (or a symlink to one)
/// or a new name; in an existing one, its `index.html` must not be a
/// symlink or a special file (the figures are checked as they are named).
fn check_dir(o: &Output) -> Result<()> {
    match std::fs::metadata(o.path) {
        Ok(m) if m.is_dir() => check_tool_named(&o.path.join("index.html")),
        Ok(_) => Err(input_err(
            o.path,
            format!(
                "{} must be a directory (or a new name); this is a file",
                o.flag
            ),
        )),
        Err(_) => Ok(()),
    }
}

/// Checks every output of a command against each other and against its
/// inputs (see the module docs). The channel map (`NAME.map.toml`) of a
/// CSV, TDMS or MAT input counts as an input.
pub fn check_outputs<'a>(
    inputs: impl IntoIterator<Item = &'a Path>,
    outputs: &[Output],
) -> Result<()> {
    let mut ins: Vec<(PathBuf, &Path)> = Vec::new();
    for p in inputs {
        ins.push((identity(p), p));
        if matches!(extension(p).as_str(), "csv" | "tdms" | "mat") {
            ins.push((identity(&p.with_extension("map.toml")), p));
        }
    }
    let mut seen: Vec<(PathBuf, &Output)> = Vec::new();
    for o in outputs {
        // The gravest first: an output that would destroy an input.
        let id = identity(o.path);
        if let Some((_, input)) = ins.iter().find(|(i, _)| *i == id) {
            return Err(input_err(
                o.path,
                format!(
                    "{} would overwrite the input {}: choose another output file",
                    o.flag,
                    input.display()
                ),
            ));
        }
        if o.is_dir() {
            check_dir(o)?;
        } else {
            check_file(o)?;
        }
        if let Some((_, other)) = seen.iter().find(|(i, _)| *i == id) {
            return Err(input_err(
                o.path,
                format!(
                    "{} and {} name the same file: give each output its own name",
                    other.flag, o.flag
                ),
            ));
        }
        seen.push((id, o));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refuses_wrong_extension_duplicates_inputs_and_fifos() {
        let t = tempfile::tempdir().unwrap();
        let d = t.path();
        let log = d.join("log.mcap");
        std::fs::write(&log, b"x").unwrap();
        let svg = d.join("a.svg");
        // Wrong extension.
        let e = check_outputs([], &[Output::file("--plot", &log, &["svg"])]);
        assert!(e.unwrap_err().to_string().contains("--plot writes SVG"));
        // Two outputs alike.
        let e = check_outputs(
            [],
            &[
                Output::file("--events", &d.join("s.csv"), &["csv"]),
                Output::file("--trajectory", &d.join("s.csv"), &["csv"]),
            ],
        );
        assert!(e.unwrap_err().to_string().contains("same file"));
        // An input.
        let e = check_outputs([log.as_path()], &[Output::file("--out", &log, &["mcap"])]);
        assert!(e.unwrap_err().to_string().contains("overwrite the input"));
        // A FIFO, as input and as output.
        let fifo = d.join("f.svg");
        let ok = std::process::Command::new("mkfifo")
            .arg(&fifo)
            .status()
            .is_ok_and(|s| s.success());
        if ok {
            let e = check_outputs([], &[Output::file("--plot", &fifo, &["svg"])]);
            assert!(e.unwrap_err().to_string().contains("FIFO"));
            assert!(check_inputs([fifo.as_path()])
                .unwrap_err()
                .to_string()
                .contains("FIFO"));
        }
        // Missing directory, directory name.
        let e = check_outputs([], &[Output::file("--plot", &d.join("no/a.svg"), &["svg"])]);
        assert!(e.unwrap_err().to_string().contains("does not exist"));
        let e = check_outputs([], &[Output::file("--out", d, &["json"])]);
        assert!(e.is_err());
        // A fine one.
        assert!(check_outputs([log.as_path()], &[Output::file("--plot", &svg, &["svg"])]).is_ok());
    }

    #[test]
    fn symlink_is_written_through_unless_its_target_is_another_kind() {
        let t = tempfile::tempdir().unwrap();
        let d = t.path();
        let real = d.join("real.svg");
        std::fs::write(&real, b"old").unwrap();
        let link = d.join("link.svg");
        std::os::unix::fs::symlink(&real, &link).unwrap();
        check_outputs([], &[Output::file("--plot", &link, &["svg"])]).unwrap();
        crate::io::write_atomic(&link, b"new").unwrap();
        assert!(std::fs::symlink_metadata(&link)
            .unwrap()
            .file_type()
            .is_symlink());
        assert_eq!(std::fs::read(&real).unwrap(), b"new");
        let log = d.join("log.mcap");
        std::fs::write(&log, b"data").unwrap();
        let bad = d.join("bad.svg");
        std::os::unix::fs::symlink(&log, &bad).unwrap();
        let e = check_outputs([], &[Output::file("--plot", &bad, &["svg"])]);
        assert!(e.unwrap_err().to_string().contains("another kind"));
    }
}
