//! HTML reports: one `index.html` per report directory, rendered with
//! minijinja from an embedded template. The template's name ends in
//! `.html`, so minijinja escapes every interpolated value: text that came
//! from a log (metadata `notes`, file names, warnings) shows as text and
//! never runs. Figures are SVG files beside the page; the page references
//! nothing on the network.
//!
//! The page is assembled from small serialisable view structs ([`Page`]),
//! filled by the CLI from the typed results of the stages.

use crate::error::{Error, Result};
use serde::Serialize;
use std::path::{Path, PathBuf};

const TEMPLATE: &str = include_str!("templates/index.html");

/// A key–value line of a summary table.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct KeyValue {
    /// Label.
    pub key: String,
    /// Value as displayed.
    pub value: String,
}

impl KeyValue {
    /// A line.
    pub fn new(key: impl Into<String>, value: impl Into<String>) -> Self {
        Self {
            key: key.into(),
            value: value.into(),
        }
    }
}

/// An input file: path, size and SHA-256 (for provenance).
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct InputFile {
    /// Path as given.
    pub path: String,
    /// Size in bytes.
    pub bytes: u64,
    /// SHA-256, hex.
    pub sha256: String,
}

/// Hashes an input file (streamed, see [`crate::io::sha256_file`]).
pub fn input_file(path: &Path) -> Result<InputFile> {
    let (sha256, bytes) = crate::io::sha256_file(path)?;
    Ok(InputFile {
        path: path.display().to_string(),
        bytes,
        sha256,
    })
}

/// One parameter row of a fit table.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct ParamRow {
    /// Name.
    pub name: String,
    /// Estimate.
    pub value: String,
    /// 95 % interval.
    pub interval: String,
    /// Unit.
    pub unit: String,
}

/// The fit of one characteristic log.
#[derive(Debug, Clone, Serialize, PartialEq, Default)]
pub struct FitView {
    /// Log path.
    pub log: String,
    /// Short flags (law, stuck, never sticks, estimate).
    pub flags: Vec<String>,
    /// Error when the log could not be fitted.
    pub error: Option<String>,
    /// Parameter rows.
    pub rows: Vec<ParamRow>,
    /// Figure file name (relative to the page).
    pub figure: Option<String>,
    /// Warnings.
    pub warnings: Vec<String>,
    /// Diagnostics.
    pub notes: Vec<String>,
    /// The log's own `notes` metadata (shown as text).
    pub rig_notes: Option<String>,
}

/// The validation of one sweep.
#[derive(Debug, Clone, Serialize, PartialEq, Default)]
pub struct ValidationView {
    /// Sweep log path.
    pub sweep: String,
    /// Characteristic log path.
    pub characteristic: String,
    /// Law family.
    pub law: String,
    /// Which estimate the prediction used.
    pub estimate: String,
    /// The sweep's measured drive amplitude, formatted.
    pub amplitude: String,
    /// Score lines.
    pub scores: Vec<KeyValue>,
    /// Figure file name.
    pub figure: String,
    /// Column names of the per-step table.
    pub header: Vec<String>,
    /// Per-step rows.
    pub steps: Vec<Vec<String>>,
    /// Warnings.
    pub warnings: Vec<String>,
}

/// The batch comparison.
#[derive(Debug, Clone, Serialize, PartialEq, Default)]
pub struct BatchView {
    /// Headline lines (μ, recommendation, cliff).
    pub summary: Vec<KeyValue>,
    /// Column names of the comparison table.
    pub header: Vec<String>,
    /// Rows.
    pub rows: Vec<Vec<String>>,
    /// Figure file name.
    pub figure: Option<String>,
    /// Conflicts between logs, in words (with what was set aside).
    pub conflicts: Vec<String>,
    /// Warnings.
    pub warnings: Vec<String>,
}

/// A whole report page.
#[derive(Debug, Clone, Serialize, PartialEq, Default)]
pub struct Page {
    /// Title.
    pub title: String,
    /// Tool version.
    pub version: String,
    /// The command that produced it.
    pub command: String,
    /// Headline lines.
    pub summary: Vec<KeyValue>,
    /// Report-level warnings.
    pub warnings: Vec<String>,
    /// Batch section.
    pub batch: Option<BatchView>,
    /// Validation sections.
    pub validations: Vec<ValidationView>,
    /// Fit sections.
    pub fits: Vec<FitView>,
    /// Input files.
    pub inputs: Vec<InputFile>,
    /// Wall seconds per stage (empty: not shown).
    pub timings: Vec<KeyValue>,
}

/// Renders the page to HTML.
///
/// ```
/// use stickslip::report::html::{render, Page};
/// // Everything from a log is auto-escaped.
/// let page = Page { title: "pad <b>A</b>".into(), ..Default::default() };
/// let html = render(&page)?;
/// assert!(html.contains("<h1>pad &lt;b&gt;A&lt;&#x2f;b&gt;</h1>"));
/// assert!(!html.contains("<b>A"));
/// # Ok::<(), stickslip::Error>(())
/// ```
pub fn render(page: &Page) -> Result<String> {
    let mut env = minijinja::Environment::new();
    env.add_template("index.html", TEMPLATE)
        .map_err(|e| template_err(&e))?;
    let t = env
        .get_template("index.html")
        .map_err(|e| template_err(&e))?;
    t.render(page).map_err(|e| template_err(&e))
}

fn template_err(e: &minijinja::Error) -> Error {
    Error::Input {
        path: PathBuf::from("index.html"),
        msg: format!("report template: {e}"),
    }
}

/// A report directory: creates it, and refuses to write a file that is one
/// of the inputs, a symlink or a special file.
#[derive(Debug, Clone)]
pub struct ReportDir {
    dir: PathBuf,
    inputs: Vec<PathBuf>,
}

impl ReportDir {
    /// Creates (if needed) the directory `dir` for a report on `inputs`.
    pub fn create(dir: &Path, inputs: &[PathBuf]) -> Result<Self> {
        // A directory this command creates is removed again if it fails.
        crate::io::txn::create_dir(dir)?;
        let inputs = inputs
            .iter()
            .filter_map(|p| std::fs::canonicalize(p).ok())
            .collect();
        Ok(Self {
            dir: dir.to_path_buf(),
            inputs,
        })
    }

    /// The path of `name` in the directory, checked not to be an input
    /// and not a symlink: the files of a report are named by the tool, so
    /// they are never written through a symlink (it could point at a
    /// user's file), and not onto anything but a regular file.
    pub fn file(&self, name: &str) -> Result<PathBuf> {
        let p = self.dir.join(name);
        crate::io::paths::check_tool_named(&p)?;
        if let Ok(c) = std::fs::canonicalize(&p) {
            if self.inputs.contains(&c) {
                return Err(Error::Input {
                    path: p,
                    msg: "the report would overwrite an input file: choose another --report directory".into(),
                });
            }
        }
        Ok(p)
    }

    /// Writes `index.html` atomically.
    pub fn write_page(&self, page: &Page) -> Result<PathBuf> {
        let html = render(page)?;
        let p = self.file("index.html")?;
        crate::io::write_atomic(&p, html.as_bytes())?;
        Ok(p)
    }
}

/// A file-name stem safe for figure names ("char_N4.mcap" → "char_N4").
pub fn stem(path: &Path) -> String {
    path.file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "log".into())
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '.' || c == '-' || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect()
}

/// Formats a number with `d` significant-looking decimals, `–` for None.
pub fn fmt(x: Option<f64>, d: usize) -> String {
    match x {
        Some(v) if v.is_finite() => format!("{v:.d$}"),
        _ => "–".into(),
    }
}

/// Formats an interval.
pub fn fmt_interval(iv: Option<(f64, f64)>, d: usize) -> String {
    match iv {
        Some((a, b)) if a.is_finite() && b.is_finite() => format!("[{a:.d$}, {b:.d$}]"),
        _ => "–".into(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Markup from a log (metadata notes, file names) is escaped, never
    /// emitted as markup.
    #[test]
    fn log_text_is_escaped() {
        let page = Page {
            title: "t".into(),
            fits: vec![FitView {
                log: "<b>evil</b>.mcap".into(),
                rig_notes: Some("<script>alert(1)</script>".into()),
                ..FitView::default()
            }],
            ..Page::default()
        };
        let html = render(&page).unwrap();
        assert!(!html.contains("<script>alert"), "{html}");
        assert!(html.contains("&lt;script&gt;alert(1)&lt;"), "{html}");
        assert!(!html.contains("<b>evil"));
    }

    /// The page references nothing on the network.
    #[test]
    fn page_is_offline() {
        let html = render(&Page::default()).unwrap();
        assert!(!html.contains("http://") && !html.contains("https://"));
    }
}
