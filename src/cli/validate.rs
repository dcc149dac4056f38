//! `stickslip validate`: fit the law of a characteristic log, predict a
//! sweep log's frequency response with it (steady state and replay, with
//! 95 % bands), score it, and optionally write an HTML report. The work is
//! [`crate::pipeline::validate`]'s job; this module parses, checks the
//! paths and prints.

use crate::pipeline::validate::{ValidateJob, ValidateOutcome};
use crate::validate::{self, ValidateOptions};
use clap::Args;
use std::path::PathBuf;

/// Arguments of `stickslip validate`.
#[derive(Debug, Args)]
pub struct ValidateArgs {
    /// Characteristic log whose fitted law is validated (with --fit: picks
    /// the record with its sha256; optional if the file holds one fit).
    #[arg(long, required_unless_present = "fit")]
    pub characteristic: Option<PathBuf>,
    /// Reuse a saved fit (`fit --out` or `merge` of fit parts) instead of
    /// fitting the characteristic log.
    #[arg(long, value_name = "FITS.json")]
    pub fit: Option<PathBuf>,
    /// Sweep log (stepped or continuous) to predict.
    #[arg(long)]
    pub sweep: PathBuf,
    /// Write an HTML report (index.html and SVG figures) into this directory.
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// Write the JSON result to this file (atomically).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Most laws drawn from the fit's uncertainty for the 95 % bands (0:
    /// none; at most 2000: each is a whole predicted sweep): drawn in rounds
    /// (40, then doubling) until the replay coverages are known to
    /// --band-coverage-se.
    #[arg(long, default_value_t = validate::predict::DEFAULT_BAND_SAMPLES, value_parser = super::args::band_samples, allow_hyphen_values = true)]
    pub samples: usize,
    /// Bootstrap standard error to which the draws must fix every replay
    /// coverage (a fraction, 0 to 0.5; 0: draw all --samples).
    #[arg(long, default_value_t = 0.025, value_parser = super::args::coverage_se, allow_hyphen_values = true)]
    pub band_coverage_se: f64,
    /// Relative gain uncertainty of each sensor in the calibration budget.
    #[arg(long, default_value_t = 0.01, value_parser = super::args::gain_fraction, allow_hyphen_values = true)]
    pub gain_uncertainty: f64,
    /// Period budget of the fitted law's steady state at each point (points
    /// with no periodic response by then are reported without one).
    #[arg(long, default_value_t = validate::predict::DEFAULT_STEADY_PERIODS, value_parser = super::args::periods(), allow_hyphen_values = true)]
    pub max_periods: u64,
    /// Use a characteristic log and a sweep whose rig constants (M1, M2, K1, K2, d) differ by more than 1 %.
    #[arg(long)]
    pub allow_mixed_rigs: bool,
    /// Print one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
}

/// The job of the arguments.
fn job(args: ValidateArgs) -> ValidateJob {
    let mut options = ValidateOptions::default();
    options.predict.samples = args.samples;
    options.predict.band_coverage_se = args.band_coverage_se;
    options.predict.steady.max_periods = args.max_periods;
    options.frc.gain_uncertainty = args.gain_uncertainty;
    ValidateJob {
        characteristic: args.characteristic,
        fit: args.fit,
        sweep: args.sweep,
        report: args.report,
        out: args.out,
        options,
        allow_mixed_rigs: args.allow_mixed_rigs,
        command: std::env::args().collect::<Vec<_>>().join(" "),
    }
}

/// The `validate` request: the paths checked.
pub fn request(args: ValidateArgs) -> crate::Result<super::Request> {
    let outputs = super::json_and_report(args.out.as_deref(), args.report.as_deref());
    super::check_paths(
        args.characteristic
            .iter()
            .chain(&args.fit)
            .map(PathBuf::as_path)
            .chain([args.sweep.as_path()]),
        &outputs,
    )?;
    let json = args.json;
    Ok(super::Request {
        view: super::View::new(json),
        job: crate::pipeline::Job::Validate(Box::new(job(args))),
        progress: Box::new(super::Say(json)),
    })
}

/// Prints the scores and the warnings.
pub fn print(done: &ValidateOutcome, view: &super::View) -> crate::Result<()> {
    if view.json {
        return super::print_json(&crate::io::json::to_value(&done.json));
    }
    let v = &done.validation;
    let s = &v.prediction.score;
    let pc = |x: Option<f64>| x.map_or("-".into(), |v| format!("{:.1} %", v * 100.0));
    eprintln!(
        "{} steps, {} reached steady state; steady nrms A1 {}, A2 {}; replay nrms A1 {}, A2 {}; replay band coverage A1 {}, A2 {} ({:.2} s)",
        v.measured.points.len(),
        s.steady_points,
        pc(s.nrms_amplitude1),
        pc(s.nrms_amplitude2),
        pc(s.replay_nrms_amplitude1),
        pc(s.replay_nrms_amplitude2),
        pc(s.replay_coverage_amplitude1),
        pc(s.replay_coverage_amplitude2),
        view.started.elapsed().as_secs_f64()
    );
    for w in &v.warnings {
        eprintln!("warning: {w}");
    }
    Ok(())
}
