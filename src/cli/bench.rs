//! `stickslip bench`: the work-precision benchmark (see
//! [`crate::sim::workprec`]); the full run also writes `reports/bench.svg`.
//! The work is [`crate::pipeline::bench`]'s job; this module parses and
//! prints.

use crate::pipeline::bench::{BenchJob, BenchOutcome};
use clap::Args;
use std::path::PathBuf;

/// Arguments of `stickslip bench`.
#[derive(Debug, Args)]
pub struct BenchArgs {
    /// Fewer scenarios and settings (finishes in well under 30 s).
    #[arg(long)]
    pub quick: bool,
    /// Work-precision figure of the full run (.svg; default
    /// reports/bench.svg). `--quick` draws none.
    #[arg(long, conflicts_with = "quick")]
    pub plot: Option<PathBuf>,
    /// Print one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
}

/// The `bench` request.
pub fn request(args: BenchArgs) -> crate::Result<super::Request> {
    let job = BenchJob {
        quick: args.quick,
        plot: args.plot,
    };
    Ok(super::Request::quiet(
        crate::pipeline::Job::Bench(job),
        args.json,
    ))
}

/// Prints the study's table.
pub fn print(done: &BenchOutcome, view: &super::View) -> crate::Result<()> {
    if view.json {
        return super::print_json(&crate::io::json::to_value(&done.json));
    }
    eprintln!(
        "{:<12} {:<28} {:>10} {:>12}",
        "method", "setting", "seconds", "error"
    );
    for r in &done.rows {
        let e = r.error.map_or("-".to_string(), |e| format!("{e:.2e}"));
        eprintln!(
            "{:<12} {:<28} {:>10.4} {:>12}",
            r.method, r.setting, r.seconds, e
        );
    }
    Ok(())
}
