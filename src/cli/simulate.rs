//! `stickslip simulate`: one forcing frequency with the exact engine (or the
//! paper's RK4 for cross-checks), optional event and trajectory files
//! streamed to disk in constant memory and written atomically. The work
//! is [`crate::pipeline::simulate`]'s job; this module parses, builds the
//! model into the job and prints its outcome.

use super::ModelArgs;
use crate::pipeline::simulate::{self as job, SimulateJob, SimulateOutcome, MAX_PERIODS};
use clap::{Args, ValueEnum};
use std::path::PathBuf;

/// Integration method.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Method {
    /// Exact event-driven closed-form engine.
    Exact,
    /// The paper's classical RK4 with switching-time determination.
    Rk4,
    /// Dormand–Prince 5(4) with events on its dense output (any law).
    Dopri,
}

/// Arguments of `stickslip simulate`.
#[derive(Debug, Args)]
pub struct SimulateArgs {
    /// Model options.
    #[command(flatten)]
    pub model: ModelArgs,
    /// Forcing frequency ratio η = Ω·sqrt(M2/K2).
    #[arg(long, allow_hyphen_values = true)]
    pub eta: f64,
    /// Integrate exactly N forcing periods.
    #[arg(long, conflicts_with = "steady", required_unless_present = "steady", value_parser = clap::value_parser!(u64).range(1..=MAX_PERIODS), allow_hyphen_values = true)]
    pub periods: Option<u64>,
    /// Integrate until the response is periodic (or declared not periodic).
    #[arg(long)]
    pub steady: bool,
    /// Longest run with --steady, in forcing periods (1 to 1e8).
    #[arg(long, default_value_t = 20_000, value_parser = clap::value_parser!(u64).range(1..=100_000_000), allow_hyphen_values = true)]
    pub max_periods: u64,
    /// Start at rest with M2 sticking (the default initial state).
    #[arg(long)]
    pub from_rest: bool,
    /// Write every switching event to this CSV.
    #[arg(long)]
    pub events: Option<PathBuf>,
    /// Write the trajectory (uniform samples) to this CSV.
    #[arg(long)]
    pub trajectory: Option<PathBuf>,
    /// Trajectory samples per forcing period (1 to 1e6).
    #[arg(long, default_value_t = 64, value_parser = clap::value_parser!(u32).range(1..=1_000_000), allow_hyphen_values = true)]
    pub samples_per_period: u32,
    /// Largest event or trajectory file to write (MB; the estimate is
    /// checked before the run).
    #[arg(long, default_value_t = 2048, value_parser = clap::value_parser!(u64).range(1..), allow_hyphen_values = true)]
    pub max_output_mb: u64,
    /// Integration method.
    #[arg(long, value_enum, default_value_t = Method::Exact)]
    pub method: Method,
    /// RK4 step size H (dimensionless time), with --method rk4.
    #[arg(long, default_value_t = 1e-2, allow_hyphen_values = true)]
    pub step: f64,
    /// Relative tolerance of --method dopri (the default method of laws
    /// without a closed form, e.g. stribeck).
    #[arg(long, default_value_t = 1e-10, allow_hyphen_values = true, value_parser = super::args::tolerance)]
    pub tol: f64,
    /// Print one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
}

impl From<Method> for job::Method {
    fn from(m: Method) -> Self {
        match m {
            Method::Exact => job::Method::Exact,
            Method::Rk4 => job::Method::Rk4,
            Method::Dopri => job::Method::Dopri,
        }
    }
}

impl SimulateArgs {
    /// The job these options describe (the model checked).
    pub fn job(self) -> crate::Result<SimulateJob> {
        Ok(SimulateJob {
            model: self.model.model()?,
            eta: self.eta,
            periods: self.periods,
            max_periods: self.max_periods,
            events: self.events,
            trajectory: self.trajectory,
            samples_per_period: self.samples_per_period,
            max_output_mb: self.max_output_mb,
            method: self.method.into(),
            step: self.step,
            tol: self.tol,
        })
    }
}

/// The `simulate` request: the model checked.
pub fn request(args: SimulateArgs) -> crate::Result<super::Request> {
    let json = args.json;
    Ok(super::Request::quiet(
        crate::pipeline::Job::Simulate(args.job()?),
        json,
    ))
}

/// Prints the run's summary.
pub fn print(done: &SimulateOutcome, view: &super::View) -> crate::Result<()> {
    if view.json {
        return super::print_json(&crate::io::json::to_value(&done.json));
    }
    let s = &done.json.summary;
    let f = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{v:.6}"));
    eprintln!(
        "eta {:.4}  {}  A1/A {}  A2/A {}  stick {:.3}  events {}  periods {}  status {}{}",
        s.eta,
        done.model.law,
        f(s.amplitude1),
        f(s.amplitude2),
        s.stick_fraction,
        s.events,
        s.periods,
        s.status,
        s.reason
            .as_ref()
            .map_or(String::new(), |r| format!(" ({r})")),
    );
    Ok(())
}
