//! `stickslip bench`: the work-precision benchmark (see
//! [`crate::sim::workprec`]); the full run also writes `reports/bench.svg`.

use crate::sim::workprec;
use clap::Args;
use serde_json::json;
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

/// Runs `bench`.
pub fn run(args: BenchArgs) -> crate::Result<()> {
    let plot = (!args.quick).then(|| {
        args.plot
            .clone()
            .unwrap_or_else(|| PathBuf::from("reports/bench.svg"))
    });
    if let Some(p) = &plot {
        // The default's directory is made for it (then nothing is there to
        // check); a given path's must exist. Either way an existing target
        // is checked like every output (no FIFO, device or directory).
        let made_later = args.plot.is_none() && p.parent().is_some_and(|d| !d.exists());
        if !made_later {
            super::check_paths([], &[crate::io::Output::file("--plot", p, super::ext::SVG)])?;
        }
    }
    let rows = workprec::study(args.quick);
    if let Some(plot) = &plot {
        if let Some(dir) = plot.parent() {
            if !dir.as_os_str().is_empty() && !dir.exists() {
                crate::io::txn::create_dir(dir)?;
            }
        }
        crate::report::plot::work_precision(&rows, plot)?;
    }
    if args.json {
        let r: Vec<serde_json::Value> = rows
            .iter()
            .map(|r| json!({"method": r.method, "setting": r.setting, "seconds": r.seconds, "error": r.error}))
            .collect();
        super::print_json(&json!({ "rows": r }))?;
    } else {
        eprintln!(
            "{:<12} {:<28} {:>10} {:>12}",
            "method", "setting", "seconds", "error"
        );
        for r in &rows {
            let e = r.error.map_or("-".to_string(), |e| format!("{e:.2e}"));
            eprintln!(
                "{:<12} {:<28} {:>10.4} {:>12}",
                r.method, r.setting, r.seconds, e
            );
        }
    }
    Ok(())
}
