//! `stickslip batch LOG...`: one pad at several normal forces. Fits every
//! log (in parallel), estimates μs and μd through the origin (stuck and
//! never-sticking logs as censored data), and recommends the normal force
//! whose worst-case main-mass amplitude over the drive range, robust to its
//! own uncertainty, is smallest (see [`crate::batch`]). A log that
//! cannot be read or fitted gives its `error:` line and an entry with
//! `error`; the batch is computed from the others and the exit status is 1.
//! Logs whose rig constants differ by more than 1 % are refused unless
//! `--allow-mixed-rigs`; the same test given twice (the same file, or the
//! same test in another format) counts once, with a warning. Conflicting
//! logs are named in `conflicts` and μ is reported with and without them.
//! The work is [`crate::pipeline::batch`]'s job; this module parses,
//! checks the paths, shows progress and prints.

use crate::batch::{self as vb, BatchOptions};
use crate::identify::{self, IdentifyOptions};
use crate::pipeline::batch::{BatchJob, BatchOutcome};
use crate::report::batch_view;
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use std::io::IsTerminal;
use std::path::PathBuf;

/// Arguments of `stickslip batch`.
#[derive(Debug, Args)]
pub struct BatchArgs {
    /// Characteristic logs of one pad at several normal forces.
    #[arg(required_unless_present = "fits")]
    pub logs: Vec<PathBuf>,
    /// Reuse the fits in this file (`fit --out` or `merge` of fit parts)
    /// instead of refitting: its fits join the batch first; a log also
    /// given is fitted only if no record has its sha256 (a record of the
    /// same file with another sha256 is refused).
    #[arg(long, value_name = "FITS.json")]
    pub fits: Option<PathBuf>,
    /// Write the HTML report (index.html and the figure) into this directory.
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// Write the JSON result to this file (atomically).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Relative gain uncertainty of each motion sensor in the calibration budget.
    #[arg(long, default_value_t = 0.01, value_parser = super::args::gain_fraction, allow_hyphen_values = true)]
    pub gain_uncertainty: f64,
    /// Relative gain uncertainty of the normal-force sensor (common to the batch).
    #[arg(long, default_value_t = 0.01, value_parser = super::args::gain_fraction, allow_hyphen_values = true)]
    pub normal_force_gain_uncertainty: f64,
    /// Bootstrap replicates over drive periods (per log; 0 to 100000).
    #[arg(long, default_value_t = 400, value_parser = super::args::bootstrap_replicates, allow_hyphen_values = true)]
    pub bootstrap: usize,
    /// Tolerance of a normal-force setting (±, relative).
    #[arg(long, default_value_t = 0.05, allow_hyphen_values = true)]
    pub setting_tolerance: f64,
    /// The recommended window: settings whose robust worst case is within this fraction of the best.
    #[arg(long, default_value_t = 0.10, allow_hyphen_values = true)]
    pub window: f64,
    /// Drive range: smallest η (with --eta-max; default 0.5·η1 of the rig).
    #[arg(long, requires = "eta_max", allow_hyphen_values = true)]
    pub eta_min: Option<f64>,
    /// Drive range: largest η (with --eta-min; default 1.4·η2 of the rig).
    #[arg(long, requires = "eta_min", allow_hyphen_values = true)]
    pub eta_max: Option<f64>,
    /// Uniform η points over the drive range (plus fine windows around η1, η0, η2).
    #[arg(long, default_value_t = 141, allow_hyphen_values = true)]
    pub eta_points: usize,
    /// Step of the fine η windows around η1, η0, η2 (0: none).
    #[arg(long, default_value_t = vb::DEFAULT_ETA_FINE_STEP, allow_hyphen_values = true)]
    pub eta_fine_step: f64,
    /// Half-width of each fine η window.
    #[arg(long, default_value_t = 0.025, allow_hyphen_values = true)]
    pub eta_fine_halfwidth: f64,
    /// Evaluate every this-many uniform η at each ρs (with the fine
    /// windows), the others only next to a branch's local maximum (1: every η).
    #[arg(long, default_value_t = vb::DEFAULT_ETA_COARSE_STRIDE, allow_hyphen_values = true)]
    pub eta_coarse_stride: usize,
    /// Smallest ρs of the worst-case grid.
    #[arg(long, default_value_t = 0.2, allow_hyphen_values = true)]
    pub rho_min: f64,
    /// Largest ρs of the grid (default: covers every measured setting, at least 3).
    #[arg(long, allow_hyphen_values = true)]
    pub rho_max: Option<f64>,
    /// Nodes of the coarse geometric ρs grid.
    #[arg(long, default_value_t = 40, allow_hyphen_values = true)]
    pub rho_points: usize,
    /// Do not refine the ρs grid around the best candidates.
    #[arg(long)]
    pub no_refine: bool,
    /// Leave the μd/μs interval, and the simulated pad's κ and ρs⁻/ρs⁺
    /// intervals, out of the robust worst case (estimates only).
    #[arg(long)]
    pub no_ratio_variants: bool,
    /// Drive amplitude (mm) for ρ = R/(A·K2) (default: the rig's nominal amplitude).
    #[arg(long, allow_hyphen_values = true)]
    pub drive_amplitude_mm: Option<f64>,
    /// Period budget of the time-marching fallback per steady state.
    #[arg(long, default_value_t = vb::DEFAULT_MAX_PERIODS, value_parser = super::args::periods(), allow_hyphen_values = true)]
    pub max_periods: u64,
    /// Use logs whose rig constants (M1, M2, K1, K2, d) differ by more than 1 %.
    #[arg(long)]
    pub allow_mixed_rigs: bool,
    /// Print one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
}

/// The job of the arguments (its options are checked by the job).
fn job(a: BatchArgs) -> BatchJob {
    let d = BatchOptions::default();
    let options = BatchOptions {
        eta_range: a.eta_min.zip(a.eta_max),
        eta_points: a.eta_points,
        eta_fine_step: a.eta_fine_step,
        eta_fine_halfwidth: a.eta_fine_halfwidth,
        eta_coarse_stride: a.eta_coarse_stride,
        rho_min: a.rho_min,
        rho_max: a.rho_max,
        rho_points: a.rho_points,
        refine: !a.no_refine,
        setting_tolerance: a.setting_tolerance,
        window: a.window,
        drive_amplitude_m: a.drive_amplitude_mm.map(|x| x * 1e-3),
        normal_force_gain_uncertainty: a.normal_force_gain_uncertainty,
        ratio_variants: !a.no_ratio_variants,
        steady: crate::sim::sweep::SteadyConfig {
            max_periods: a.max_periods,
            ..d.steady
        },
    };
    BatchJob {
        logs: a.logs,
        fits: a.fits,
        report: a.report,
        out: a.out,
        identify: IdentifyOptions {
            fit: identify::FitOptions {
                bootstrap: a.bootstrap,
                ..Default::default()
            },
            gain_uncertainty: a.gain_uncertainty,
            ..IdentifyOptions::default()
        },
        options,
        allow_mixed_rigs: a.allow_mixed_rigs,
        command: std::env::args().collect::<Vec<_>>().join(" "),
    }
}

/// The job's progress on an indicatif bar (shown on a terminal without
/// `--json`), its lines on stderr (without `--json`).
struct Bar {
    bar: ProgressBar,
    json: bool,
}

impl crate::pipeline::Progress for Bar {
    fn stage(&self, what: &str) {
        self.bar.set_message(what.to_string());
    }
    fn advance(&self, n: u64) {
        if self.bar.position() + n > self.bar.length().unwrap_or(0) {
            self.bar.inc_length(n);
        }
        self.bar.inc(n);
    }
    fn more(&self, n: u64) {
        self.bar.set_length(self.bar.position() + n);
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

/// The `batch` request: the paths checked.
pub fn request(args: BatchArgs) -> crate::Result<super::Request> {
    let outputs = super::json_and_report(args.out.as_deref(), args.report.as_deref());
    super::check_paths(
        args.logs.iter().chain(&args.fits).map(PathBuf::as_path),
        &outputs,
    )?;
    let view = super::View::new(args.json);
    let json = args.json;
    let bar = if !json && std::io::stderr().is_terminal() {
        let b = ProgressBar::new(0);
        b.set_style(
            ProgressStyle::with_template("{elapsed_precise} [{bar:30}] {pos}/{len} {msg}")
                .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
        b
    } else {
        ProgressBar::hidden()
    };
    Ok(super::Request {
        job: crate::pipeline::Job::Batch(Box::new(job(args))),
        progress: Box::new(Bar { bar, json }),
        view,
    })
}

/// Prints the errors, then the JSON object or the summary. A log that
/// could not be fitted, or a batch that failed, makes the command fail
/// without writing a file (the JSON still goes to stdout with `--json`).
pub fn print(done: BatchOutcome, view: &super::View) -> crate::Result<()> {
    let json = view.json;
    for e in &done.errors {
        eprintln!("error: {e}");
    }
    if let Some(e) = done.failure {
        // A failed command writes no file: print what there is, then fail.
        if json {
            super::print_json(&crate::io::json::to_value(&done.json))?;
        }
        return Err(e);
    }
    if json {
        super::print_json(&crate::io::json::to_value(&done.json))?;
    } else if let Some(b) = &done.batch {
        for line in batch_view::batch_summary(b) {
            eprintln!("{}: {}", line.key, line.value);
        }
        for w in &b.warnings {
            eprintln!("warning: {w}");
        }
        eprintln!("done in {:.1} s", view.started.elapsed().as_secs_f64());
    }
    Ok(())
}
