//! `stickslip fit`: fit the friction law of each characteristic log, in
//! parallel; a bad log gives its `error:` line and an entry with `error`,
//! the others complete, and the exit status is 1 at the end. The work is
//! [`crate::pipeline::fit`]'s job; this module parses, checks the paths
//! and prints.

use crate::identify::{self, IdentifyOptions};
use crate::io::Output;
use crate::model::LawKind;
use crate::pipeline::fit::{parse_fit_shard, FitJob, FitOutcome};
use clap::{Args, ValueEnum};
use std::path::PathBuf;

/// `--law`: a family, or `auto` (None: choose by information criterion).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LawPick(pub Option<LawKind>);

/// The `--law` parser: `auto` or a [`LawKind`] name (the help and the
/// error list the names).
pub fn law_pick() -> impl clap::builder::TypedValueParser<Value = LawPick> {
    let names = std::iter::once("auto").chain(LawKind::all().iter().map(|k| k.as_str()));
    use clap::builder::TypedValueParser;
    clap::builder::PossibleValuesParser::new(names).map(|s: String| LawPick(LawKind::parse(&s)))
}

/// `--estimate` choices.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum EstimateChoice {
    /// The output-error refinement where it applies (default), else the
    /// equation-error estimate.
    OutputError,
    /// The equation-error estimate only (no refinement).
    EquationError,
}

/// Arguments of `stickslip fit`.
#[derive(Debug, Args)]
pub struct FitArgs {
    /// Characteristic logs (.mcap, .csv with channel map, .parquet).
    #[arg(required = true)]
    pub logs: Vec<PathBuf>,
    /// Law family.
    #[arg(long, default_value = "auto", value_parser = law_pick(), allow_hyphen_values = true)]
    pub law: LawPick,
    /// Write the JSON result to this file (atomically).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Relative gain uncertainty of each sensor in the calibration budget.
    #[arg(long, default_value_t = 0.01, value_parser = super::args::gain_fraction, allow_hyphen_values = true)]
    pub gain_uncertainty: f64,
    /// Bootstrap replicates over drive periods (0 to 100000).
    #[arg(long, default_value_t = 400, value_parser = super::args::bootstrap_replicates, allow_hyphen_values = true)]
    pub bootstrap: usize,
    /// Which estimate is reported as the law (and used downstream).
    #[arg(long, value_enum, default_value_t = EstimateChoice::OutputError)]
    pub estimate: EstimateChoice,
    /// Fit only slice K of N of the logs (K = 1..N; contiguous, balanced
    /// slices in the order given); the result records K/N and the sha256
    /// list of all the logs, for `merge`.
    #[arg(long, value_name = "K/N")]
    pub shard: Option<String>,
    /// Declare the position channels (x0, x1, x2) calibrated to read zero
    /// within ±E metres at the rig's rest state (drive centred, springs at
    /// their free length): the levels of each sliding direction are then
    /// identified (`levels_by_direction`). Overrides the logs'
    /// `position_zero_uncertainty_m` key.
    #[arg(long = "position-zero-uncertainty-m", value_name = "E", value_parser = super::args::length_bound, allow_hyphen_values = true)]
    pub position_zero_uncertainty: Option<f64>,
    /// Print one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
}

/// Per-log lines on stderr: a fit's summary (without `--json`), a
/// failure's `error:` line.
struct Lines(bool);

impl crate::pipeline::Progress for Lines {
    fn say(&self, line: &str) {
        if !self.0 {
            eprintln!("{line}");
        }
    }
    fn error(&self, line: &str) {
        eprintln!("error: {line}");
    }
}

/// The `fit` request: the paths and the shard checked.
pub fn request(args: FitArgs) -> crate::Result<super::Request> {
    // A missing or unreadable log is a per-log `error` entry (the
    // contract); a FIFO or device would hang the read, so it is refused
    // up front.
    crate::io::check_inputs(
        args.logs
            .iter()
            .map(PathBuf::as_path)
            .filter(|p| std::fs::metadata(p).is_ok_and(|m| !m.is_file())),
    )?;
    let outputs: Vec<Output> = args
        .out
        .iter()
        .map(|p| Output::file("--out", p, super::ext::JSON))
        .collect();
    crate::io::check_outputs(args.logs.iter().map(PathBuf::as_path), &outputs)?;
    let job = FitJob {
        shard: args.shard.as_deref().map(parse_fit_shard).transpose()?,
        logs: args.logs,
        options: IdentifyOptions {
            fit: identify::FitOptions {
                law: args.law.0,
                bootstrap: args.bootstrap,
                ..Default::default()
            },
            gain_uncertainty: args.gain_uncertainty,
            output_error: args.estimate == EstimateChoice::OutputError,
            oe: identify::OeOptions {
                position_zero_uncertainty_m: args.position_zero_uncertainty,
                ..Default::default()
            },
            ..Default::default()
        },
        out: args.out,
    };
    Ok(super::Request {
        job: crate::pipeline::Job::Fit(job),
        progress: Box::new(Lines(args.json)),
        view: super::View::new(args.json),
    })
}

/// Prints the JSON object and the line naming the logs that failed;
/// `Ok(false)` when some log failed (its error line is printed).
pub fn print(done: &FitOutcome, view: &super::View) -> crate::Result<bool> {
    if view.json {
        super::print_json(&crate::io::json::to_value(&done.json))?;
    }
    // The last line names every log that failed (the contract's one
    // exception to "a failed command writes nothing": the others' fits
    // are written).
    if !done.failed.is_empty() && done.logs > 1 {
        eprintln!(
            "error: {} of {} logs failed: {}",
            done.failed.len(),
            done.logs,
            done.failed.join(", ")
        );
    }
    Ok(done.failed.is_empty())
}
