//! `stickslip characteristic`: the contact force R(t) of a characteristic log
//! (paper eq. 7) with ẋ2 and the stick flag, as a CSV table. The work is
//! [`crate::pipeline::characteristic`]'s job; this module parses, checks
//! the paths and prints.

use crate::io::Output;
use crate::pipeline::characteristic::{CharacteristicJob, CharacteristicOutcome};
use clap::Args;
use std::path::PathBuf;

/// Arguments of `stickslip characteristic`.
#[derive(Debug, Args)]
pub struct CharacteristicArgs {
    /// The characteristic log.
    pub log: PathBuf,
    /// Write the table (CSV: t_s, r_n, v2_m_per_s, stick, rho, v2_dimless);
    /// R has the estimated force bias removed.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Write the figure (SVG).
    #[arg(long)]
    pub plot: Option<PathBuf>,
    /// Print one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
}

/// The `characteristic` request: the paths checked.
pub fn request(args: CharacteristicArgs) -> crate::Result<super::Request> {
    let mut outputs = Vec::new();
    if let Some(p) = &args.out {
        outputs.push(Output::file("--out", p, super::ext::CSV));
    }
    if let Some(p) = &args.plot {
        outputs.push(Output::file("--plot", p, super::ext::SVG));
    }
    super::check_paths([args.log.as_path()], &outputs)?;
    let job = CharacteristicJob {
        log: args.log,
        out: args.out,
        plot: args.plot,
    };
    Ok(super::Request::quiet(
        crate::pipeline::Job::Characteristic(job),
        args.json,
    ))
}

/// Prints the log's summary.
pub fn print(done: &CharacteristicOutcome, view: &super::View) -> crate::Result<()> {
    let j = &done.json;
    if view.json {
        return super::print_json(&crate::io::json::to_value(j));
    }
    eprintln!(
        "{}: {} samples, {} sticks, {} reversals, acceleration from {}",
        j.log, j.samples, j.sticks, j.reversals, j.acceleration_source
    );
    Ok(())
}
