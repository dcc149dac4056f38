//! The `bench` job: the work-precision benchmark of the integrators (see
//! [`crate::sim::workprec`]); the full run also draws its figure
//! (`reports/bench.svg` unless another path is given), through the write
//! transaction ([`crate::io::txn`]). Its JSON object is [`BenchJson`].

use super::Progress;
use crate::sim::workprec::{self, WpRow};
use serde::Serialize;
use std::path::PathBuf;

/// The default figure of the full run.
pub const DEFAULT_BENCH_PLOT: &str = "reports/bench.svg";

/// One benchmark run.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BenchJob {
    /// Fewer scenarios and settings, and no figure.
    pub quick: bool,
    /// The figure of the full run (None: [`DEFAULT_BENCH_PLOT`], whose
    /// folder is made for it).
    pub plot: Option<PathBuf>,
}

/// One row of the `bench --json` object.
#[derive(Debug, Clone, Serialize)]
pub struct BenchRowJson {
    /// The method (or workload).
    pub method: String,
    /// Its setting.
    pub setting: String,
    /// Wall seconds over all scenarios.
    pub seconds: f64,
    /// Worst relative error (`null`: failed, or a timing row).
    pub error: Option<f64>,
}

/// The `bench --json` object.
#[derive(Debug, Clone, Serialize)]
pub struct BenchJson {
    /// One per method and setting.
    pub rows: Vec<BenchRowJson>,
}

/// What [`run_bench`] produced.
#[derive(Debug, Clone)]
pub struct BenchOutcome {
    /// The study's rows.
    pub rows: Vec<WpRow>,
    /// The JSON result.
    pub json: BenchJson,
}

/// Runs the benchmark: checks the figure's path (a given path's folder
/// must exist; an existing target must be a regular file), runs the study
/// and draws the figure of the full run.
pub fn run_bench(job: &BenchJob, _progress: &dyn Progress) -> crate::Result<BenchOutcome> {
    let plot = (!job.quick).then(|| {
        job.plot
            .clone()
            .unwrap_or_else(|| PathBuf::from(DEFAULT_BENCH_PLOT))
    });
    if let Some(p) = &plot {
        // The default's directory is made for it (then nothing is there to
        // check); a given path's must exist. Either way an existing target
        // is checked like every output (no FIFO, device or directory).
        let made_later = job.plot.is_none() && p.parent().is_some_and(|d| !d.exists());
        if !made_later {
            crate::io::check_outputs([], &[crate::io::Output::file("--plot", p, &["svg"])])?;
        }
    }
    let rows = workprec::study(job.quick);
    if let Some(plot) = &plot {
        if let Some(dir) = plot.parent() {
            if !dir.as_os_str().is_empty() && !dir.exists() {
                crate::io::txn::create_dir(dir)?;
            }
        }
        crate::report::plot::work_precision(&rows, plot)?;
    }
    let json = BenchJson {
        rows: rows
            .iter()
            .map(|r| BenchRowJson {
                method: r.method.clone(),
                setting: r.setting.clone(),
                seconds: r.seconds,
                error: r.error,
            })
            .collect(),
    };
    Ok(BenchOutcome { rows, json })
}
