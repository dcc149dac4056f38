//! `stickslip ingest`: read one rig log, report it, optionally write the
//! canonical run as Parquet. The work is [`crate::pipeline::read`]'s job;
//! this module parses, checks the paths and prints.

use crate::io::Output;
use crate::pipeline::read::{IngestJob, IngestOutcome};
use clap::Args;
use std::path::PathBuf;

/// Arguments of `stickslip ingest`.
#[derive(Debug, Args)]
pub struct IngestArgs {
    /// The rig log: `.mcap`, `.csv`, `.parquet`, `.tdms` or `.mat` (CSV,
    /// TDMS and MAT with a channel map).
    pub log: PathBuf,
    /// Channel map of a CSV, TDMS or MAT log (default: NAME.map.toml beside
    /// the log).
    #[arg(long)]
    pub map: Option<PathBuf>,
    /// Write the canonical run (common time base, SI) to this Parquet file.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Print one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
}

/// The `ingest` request: the paths checked.
pub fn request(args: IngestArgs) -> crate::Result<super::Request> {
    let outputs: Vec<Output> = args
        .out
        .iter()
        .map(|p| Output::file("--out", p, super::ext::PARQUET))
        .collect();
    super::check_paths(
        [args.log.as_path()].into_iter().chain(args.map.as_deref()),
        &outputs,
    )?;
    let job = IngestJob {
        log: args.log,
        map: args.map,
        out: args.out,
    };
    Ok(super::Request::quiet(
        crate::pipeline::Job::Ingest(job),
        args.json,
    ))
}

/// Prints the run's summary, channels and warnings.
pub fn print(done: &IngestOutcome, view: &super::View) -> crate::Result<()> {
    if view.json {
        return super::print_json(&done.json);
    }
    let run = &done.run;
    eprintln!(
        "{}: {} test ({}), {} rows at {} Hz = {:.3} s, {} channels{}, {} gaps, {} setpoints",
        run.source.display(),
        run.rig.test.as_str(),
        run.format.as_str(),
        run.samples(),
        run.resampled.rate_hz,
        run.duration_s(),
        run.channels.len(),
        if run.has_acceleration {
            ""
        } else {
            " (no accelerometer)"
        },
        run.gaps.len(),
        run.setpoints.len(),
    );
    for c in &run.channels {
        eprintln!(
            "  {:<13} {:>8} samples at {:>7} Hz [{}] from {}, {} dropouts",
            c.name(),
            c.t.len(),
            c.rate_hz,
            c.unit(),
            c.source,
            c.dropouts
        );
    }
    for w in &run.warnings {
        eprintln!("warning: {w}");
    }
    if let Some(out) = &done.out {
        eprintln!("wrote {}", out.display());
    }
    Ok(())
}
