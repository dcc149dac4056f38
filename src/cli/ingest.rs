//! `stickslip ingest`: read one rig log, report it, optionally write the
//! canonical run as Parquet.

use crate::ingest::{self, IngestOptions};
use crate::io::Output;
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

/// Runs `ingest`.
pub fn run(args: IngestArgs) -> crate::Result<()> {
    let outputs: Vec<Output> = args
        .out
        .iter()
        .map(|p| Output::file("--out", p, super::ext::PARQUET))
        .collect();
    super::check_paths(
        [args.log.as_path()].into_iter().chain(args.map.as_deref()),
        &outputs,
    )?;
    let opts = IngestOptions {
        map: args.map.clone(),
        ..IngestOptions::default()
    };
    let run = ingest::read(&args.log, &opts)?;
    if let Some(out) = &args.out {
        crate::io::write_parquet(&run, out)?;
    }
    if args.json {
        super::print_json(&run.to_json(args.out.as_deref()))?;
    } else {
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
        if let Some(out) = &args.out {
            eprintln!("wrote {}", out.display());
        }
    }
    Ok(())
}
