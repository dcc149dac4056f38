//! `stickslip sweep`: frequency-response curves and families (paper
//! Figs. 3–5), in parallel, with tables, figures and sharding for large
//! studies. The family, its checks and the work are
//! [`crate::pipeline::sweep`]'s ([`SweepRequest`]); this module parses,
//! checks the paths, shows progress and prints.

use super::args::ShapeArgs;
use crate::io::Output;
use crate::pipeline::sweep::{
    parse_rho_list, Continuation, DynamicLevel, EtaRange, FamilySpec, SweepOutcome, SweepRequest,
};
use clap::{Args, ValueEnum};
use std::io::IsTerminal;
use std::path::PathBuf;

/// Continuation policy on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum DirectionArg {
    /// Increasing η, each from the previous steady state.
    Up,
    /// Decreasing η.
    Down,
    /// One curve each way.
    Both,
}

/// The paper's Fig. 3 family (the default `--rho-s`).
pub const FIG3_RHO_S: &str = "0,0.05,0.1,0.2,0.3,0.33,0.35,0.375,0.4,0.6,1,2,5";

/// Arguments of `stickslip sweep`.
#[derive(Debug, Args)]
pub struct SweepArgs {
    /// Absorber and law shape.
    #[command(flatten)]
    pub shape: ShapeArgs,
    /// Static thresholds, comma-separated: one curve each (`inf`: stuck).
    #[arg(long = "rho-s", default_value = FIG3_RHO_S, allow_hyphen_values = true)]
    pub rho_s: String,
    /// Dynamic level for every curve (default: ρs, or ratio·ρs).
    #[arg(
        long = "rho-d",
        allow_hyphen_values = true,
        conflicts_with = "rho_d_ratio"
    )]
    pub rho_d: Option<f64>,
    /// ρd = R·ρs for every curve (the paper's Fig. 5 uses 0.5).
    #[arg(long = "rho-d-ratio", allow_hyphen_values = true)]
    pub rho_d_ratio: Option<f64>,
    /// Smallest η.
    #[arg(long = "eta-min", default_value_t = 0.2, allow_hyphen_values = true)]
    pub eta_min: f64,
    /// Largest η.
    #[arg(long = "eta-max", default_value_t = 1.6, allow_hyphen_values = true)]
    pub eta_max: f64,
    /// Number of η points (1 to 100000).
    #[arg(long, default_value_t = 141, value_parser = super::args::sweep_points, allow_hyphen_values = true)]
    pub points: usize,
    /// Continuation direction.
    #[arg(long, value_enum, default_value_t = DirectionArg::Up, conflicts_with = "from_rest")]
    pub direction: DirectionArg,
    /// Start every η from rest instead of continuing.
    #[arg(long)]
    pub from_rest: bool,
    /// Period budget of the time-marching fallback per point (1 to 1e8).
    #[arg(long, default_value_t = 20_000, value_parser = clap::value_parser!(u64).range(1..=100_000_000), allow_hyphen_values = true)]
    pub max_periods: u64,
    /// March quasi-periodic points to the whole --max-periods budget (by
    /// default they stop after 4000–5000 periods as `not-settling`, once
    /// their section comes no closer to any orbit and their Lyapunov
    /// exponent is about zero).
    #[arg(long)]
    pub no_early_stop: bool,
    /// Compute slice K of N of the family (1-based K), for job arrays.
    #[arg(long, allow_hyphen_values = true)]
    pub shard: Option<String>,
    /// Write the table (.parquet or .csv).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Draw the family (.svg or .png).
    #[arg(long)]
    pub plot: Option<PathBuf>,
    /// Title of the figure.
    #[arg(long, allow_hyphen_values = true)]
    pub title: Option<String>,
    /// Replace an existing --out file that is not a sweep table (e.g. a
    /// rig log); without it such a file is refused (a sweep table is
    /// replaced).
    #[arg(long)]
    pub force: bool,
    /// Print one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
}

impl From<DirectionArg> for Continuation {
    fn from(d: DirectionArg) -> Self {
        match d {
            DirectionArg::Up => Continuation::Up,
            DirectionArg::Down => Continuation::Down,
            DirectionArg::Both => Continuation::Both,
        }
    }
}

/// The family's progress on an indicatif bar.
struct Bar(Option<indicatif::ProgressBar>);

impl crate::pipeline::Progress for Bar {
    fn advance(&self, n: u64) {
        if let Some(b) = &self.0 {
            b.inc(n);
        }
    }
    fn done(&self) {
        if let Some(b) = &self.0 {
            b.finish_and_clear();
        }
    }
}

/// The `sweep` request: the list and range parsed, the paths checked,
/// the job built ([`SweepRequest::job`]).
pub(crate) fn request(args: SweepArgs) -> crate::Result<super::Request> {
    let rho_s = parse_rho_list(&args.rho_s)?;
    let etas = EtaRange::new(args.eta_min, args.eta_max, args.points)?;
    let mut outputs = Vec::new();
    if let Some(p) = &args.out {
        outputs.push(Output::file("--out", p, super::ext::TABLE));
    }
    if let Some(p) = &args.plot {
        outputs.push(Output::file("--plot", p, super::ext::FIGURE));
    }
    super::check_paths([], &outputs)?;
    let job = SweepRequest {
        family: FamilySpec {
            shape: args.shape.spec(),
            rho_s,
            rho_d: DynamicLevel::of(args.rho_d, args.rho_d_ratio),
            continuation: args.direction.into(),
            from_rest: args.from_rest,
        },
        etas,
        max_periods: args.max_periods,
        early_stop: !args.no_early_stop,
        shard: args.shard,
        out: args.out,
        force: args.force,
        plot: args.plot,
        title: args.title,
    }
    .job()?;
    let bar = (!args.json && std::io::stderr().is_terminal()).then(|| {
        let b = indicatif::ProgressBar::new(job.steady_states().max(1));
        if let Ok(style) = indicatif::ProgressStyle::with_template(
            "{bar:40} {pos}/{len} steady states, {elapsed} elapsed, eta {eta}",
        ) {
            b.set_style(style);
        }
        b
    });
    Ok(super::Request {
        job: crate::pipeline::Job::Sweep(job),
        progress: Box::new(Bar(bar)),
        view: super::View::new(args.json),
    })
}

/// Prints the JSON object or the family's summary.
pub(crate) fn print(done: &SweepOutcome, view: &super::View) -> crate::Result<()> {
    if view.json {
        return super::print_json(&crate::io::json::to_value(&done.json));
    }
    let table = &done.table;
    let not_steady = table.iter().filter(|r| !r.steady && !r.interrupted).count();
    let interrupted = table.iter().filter(|r| r.interrupted).count();
    let coexisting = table.iter().filter(|r| r.coexisting).count();
    eprintln!(
        "{} curves, {} steady states in {:.2} s ({} not settled, {} interrupted, {} where the branches settle to different stable states)",
        done.curves,
        table.len(),
        done.seconds,
        not_steady,
        interrupted,
        coexisting
    );
    Ok(())
}
