//! `stickslip ingest`: read one rig log, report it, optionally write the
//! canonical run as Parquet.

use crate::ingest::{self, IngestOptions, Run};
use crate::io::json::num;
use clap::Args;
use serde_json::{json, Value};
use std::path::PathBuf;

/// Arguments of `stickslip ingest`.
#[derive(Debug, Args)]
pub struct IngestArgs {
    /// The rig log: `.mcap`, `.csv` (with a channel map) or `.parquet`.
    pub log: PathBuf,
    /// Channel map of a CSV log (default: NAME.map.toml beside NAME.csv).
    #[arg(long)]
    pub map: Option<PathBuf>,
    /// Write the canonical run (common time base, SI) to this Parquet file.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Print one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
}

/// The JSON report of an ingested run (keys fixed by `interface.md`).
pub fn report(run: &Run, out: Option<&std::path::Path>) -> Value {
    let channels: Vec<Value> = run
        .channels
        .iter()
        .map(|c| {
            json!({
                "name": c.name(),
                "rate_hz": num(c.rate_hz),
                "samples": c.t.len(),
                "unit": c.unit(),
                "source": c.source,
                "dropouts": c.dropouts,
                "start_s": c.t.first().copied().map_or(Value::Null, num),
                "end_s": c.t.last().copied().map_or(Value::Null, num),
            })
        })
        .collect();
    let gaps: Vec<Value> = run
        .gaps
        .iter()
        .map(|g| {
            json!({
                "channel": g.channel,
                "start_s": num(g.start_s),
                "end_s": num(g.end_s),
                "kind": g.kind.as_str(),
            })
        })
        .collect();
    let setpoints: Vec<Value> = run
        .setpoints
        .iter()
        .map(|s| {
            json!({
                "t_s": num(s.t_s),
                "frequency_hz": num(s.frequency_hz),
                "amplitude_m": s.amplitude_m.map_or(Value::Null, num),
            })
        })
        .collect();
    json!({
        "log": run.source.display().to_string(),
        "format": run.format.as_str(),
        "test": run.rig.test.as_str(),
        "samples": run.samples(),
        "rate_hz": num(run.resampled.rate_hz),
        "duration_s": num(run.duration_s()),
        "channels": channels,
        "has_acceleration": run.has_acceleration,
        "rig": run.rig.to_json(),
        "gaps": gaps,
        "setpoints": setpoints,
        "warnings": run.warnings,
        "out": out.map(|p| p.display().to_string()),
    })
}

/// Runs `ingest`.
pub fn run(args: IngestArgs) -> crate::Result<()> {
    if let Some(out) = &args.out {
        let ext = out
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase());
        if ext.as_deref() != Some("parquet") {
            return Err(crate::Error::Input {
                path: out.clone(),
                msg: "--out writes Parquet only: give a .parquet file".into(),
            });
        }
    }
    crate::io::ensure_not_inputs(
        [args.log.as_path()].into_iter().chain(args.map.as_deref()),
        args.out.as_deref(),
    )?;
    let opts = IngestOptions {
        map: args.map.clone(),
    };
    let run = ingest::read(&args.log, &opts)?;
    if let Some(out) = &args.out {
        crate::io::write_parquet(&run, out)?;
    }
    if args.json {
        super::print_json(&report(&run, args.out.as_deref()));
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
