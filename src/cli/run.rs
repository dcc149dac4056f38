//! `stickslip run PLAN.toml`: the whole pipeline on an experiment plan
//! (ingest → fit → validate → batch) with one HTML report; the plan format
//! and the work are [`crate::pipeline`]'s ([`crate::pipeline::job`]). This
//! module parses, checks the paths, shows progress and prints. A log that
//! fails gives its `error:` line and the rest completes (exit 1 at the
//! end).

use crate::pipeline::job::{RunJob, RunOutcome};
use crate::pipeline::{self, Plan, Progress};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use std::io::IsTerminal;
use std::path::PathBuf;

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

/// The pipeline's progress on an indicatif bar; its lines on stderr
/// (without `--json`).
struct Bar {
    bar: ProgressBar,
    json: bool,
}

impl Progress for Bar {
    fn stage(&self, what: &str) {
        self.bar.set_message(what.to_string());
    }
    fn advance(&self, n: u64) {
        self.bar.inc(n);
    }
    fn done(&self) {
        self.bar.finish_and_clear();
    }
    fn say(&self, line: &str) {
        if !self.json {
            eprintln!("{line}");
        }
    }
}

/// The `run` request: the plan read, the paths checked.
pub fn request(args: RunArgs) -> crate::Result<super::Request> {
    let view = super::View::new(args.json);
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
    let job = RunJob {
        options: pipeline::Options {
            samples: args.samples,
            band_coverage_se: args.band_coverage_se,
            allow_mixed_rigs: args.allow_mixed_rigs,
            figures: args.report.is_some(),
            ..pipeline::Options::default()
        },
        plan,
        plan_path: args.plan,
        report: args.report,
        out: args.out,
        command: std::env::args().collect::<Vec<_>>().join(" "),
    };
    Ok(super::Request {
        job: pipeline::Job::Run(Box::new(job)),
        progress: Box::new(Bar {
            bar,
            json: args.json,
        }),
        view,
    })
}

/// Prints the errors, the JSON object and the timings. A step that
/// failed (a log that cannot be fitted, a validation) makes the command
/// fail without writing a file.
pub fn print(done: RunOutcome, view: &super::View) -> crate::Result<()> {
    for e in &done.report.errors {
        eprintln!("error: {e}");
    }
    if view.json {
        super::print_json(&crate::io::json::to_value(&done.json))?;
    }
    if let Some(e) = done.failure {
        // A failed command writes no file: what there is was printed.
        return Err(e);
    }
    if !view.json {
        let t = &done.json.stage_seconds;
        eprintln!(
            "done in {:.1} s (ingest {:.1} s, fit {:.1} s, then {:.1} s side by side: validate {:.1} s and batch {:.1} s; report {:.1} s)",
            view.started.elapsed().as_secs_f64(),
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
