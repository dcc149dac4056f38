//! `stickslip run PLAN.toml`: the whole pipeline on an experiment plan
//! (ingest → fit → validate → batch) with one HTML report; the plan format
//! and the work are [`crate::pipeline`]'s. This module parses, shows
//! progress and prints. A log that fails gives its `error:` line and the
//! rest completes (exit 1 at the end).

use crate::pipeline::{self, Plan, Progress};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use serde_json::json;
use std::io::IsTerminal;
use std::path::PathBuf;
use std::time::Instant;

/// Arguments of `stickslip run`.
#[derive(Debug, Args)]
pub struct RunArgs {
    /// The experiment plan (TOML; see `stickslip run --help` and datasets/plan.toml).
    pub plan: PathBuf,
    /// Write the HTML report (index.html and SVG figures) into this directory.
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// Write the JSON result to this file (atomically).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Most laws drawn from each fit's uncertainty for the prediction bands
    /// (0 to 2000): drawn in rounds (40, then doubling) until the replay
    /// coverages are known to --band-coverage-se.
    #[arg(long, default_value_t = crate::validate::predict::DEFAULT_BAND_SAMPLES, value_parser = super::args::band_samples, allow_hyphen_values = true)]
    pub samples: usize,
    /// Bootstrap standard error to which the draws must fix every replay
    /// coverage (a fraction, 0 to 0.5; 0: draw all --samples).
    #[arg(long, default_value_t = 0.025, value_parser = super::args::coverage_se, allow_hyphen_values = true)]
    pub band_coverage_se: f64,
    /// Use logs whose rig constants (M1, M2, K1, K2, d) differ by more than 1 %.
    #[arg(long)]
    pub allow_mixed_rigs: bool,
    /// Print one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
}

/// The pipeline's progress on an indicatif bar.
struct Bar(ProgressBar);

impl Progress for Bar {
    fn stage(&self, what: &str) {
        self.0.set_message(what.to_string());
    }
    fn advance(&self, n: u64) {
        self.0.inc(n);
    }
}

/// Runs the plan. A step that fails (a log that cannot be fitted, a
/// validation) makes the command fail without writing a file.
pub fn run(args: RunArgs) -> crate::Result<()> {
    let t0 = Instant::now();
    let plan = Plan::read(&args.plan)?;
    let logs = plan.logs();
    let outputs = super::json_and_report(args.out.as_deref(), args.report.as_deref());
    super::check_paths(
        logs.iter()
            .chain(&plan.fits)
            .map(PathBuf::as_path)
            .chain([args.plan.as_path()]),
        &outputs,
    )?;
    let bar = if !args.json && std::io::stderr().is_terminal() {
        let b = ProgressBar::new(plan.steps());
        b.set_style(
            ProgressStyle::with_template("{elapsed_precise} [{bar:30}] {pos}/{len} {msg}")
                .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
        b
    } else {
        ProgressBar::hidden()
    };
    let opts = pipeline::Options {
        samples: args.samples,
        band_coverage_se: args.band_coverage_se,
        allow_mixed_rigs: args.allow_mixed_rigs,
        figures: args.report.is_some(),
        ..pipeline::Options::default()
    };
    let result = pipeline::run(&plan, &opts, &Bar(bar.clone()));
    bar.finish_and_clear();
    let report = result?;
    for e in &report.errors {
        eprintln!("error: {e}");
    }
    let mut out = report.to_json(&plan, &args.plan);
    let mut stages = report.seconds.clone();
    if !report.errors.is_empty() {
        out["stage_seconds"] = crate::io::json::to_value(&stages);
        // A failed command writes no file: print what there is, then fail.
        out["seconds"] = json!(t0.elapsed().as_secs_f64());
        if args.json {
            super::print_json(&out)?;
        }
        return Err(crate::Error::Failed {
            what: format!(
                "{} step(s) of the plan failed (listed above)",
                report.errors.len()
            ),
        });
    }
    if let Some(dir) = &args.report {
        let command = std::env::args().collect::<Vec<_>>().join(" ");
        let clock = Instant::now();
        let index = report.write_report(&plan, &args.plan, dir, &command)?;
        stages.report = clock.elapsed().as_secs_f64();
        out["report"] = json!(index.display().to_string());
        if !args.json {
            eprintln!("report: {}", index.display());
        }
    }
    out["stage_seconds"] = crate::io::json::to_value(&stages);
    out["seconds"] = json!(t0.elapsed().as_secs_f64());
    if let Some(path) = &args.out {
        super::write_json(path, &out)?;
    }
    if args.json {
        super::print_json(&out)?;
    } else {
        let t = &stages;
        eprintln!(
            "done in {:.1} s (ingest {:.1} s, fit {:.1} s, then {:.1} s side by side: validate {:.1} s and batch {:.1} s; report {:.1} s)",
            t0.elapsed().as_secs_f64(),
            t.ingest,
            t.fit,
            t.side_by_side,
            t.validate,
            t.batch,
            t.report
        );
    }
    Ok(())
}
