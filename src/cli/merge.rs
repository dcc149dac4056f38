//! `stickslip merge`: joins the partial tables of a sharded sweep
//! (`sweep --shard K/N --out part-K.parquet`) into the family's table,
//! exactly as an unsharded run writes it; or the parts of a sharded fit
//! (`fit --shard K/N --out part-K.json`) into one `{"fits": [...]}` object,
//! the records in the order of the log list. The work is
//! [`crate::pipeline::merge`]'s job; this module parses, checks the paths
//! and prints.

use crate::io::Output;
use crate::pipeline::merge::{self, MergeJob, MergeOutcome, PartKind};
use clap::Args;
use std::path::PathBuf;

/// Arguments of `stickslip merge`.
#[derive(Debug, Args)]
pub struct MergeArgs {
    /// Partial tables (.parquet or .csv), or fit parts (.json).
    #[arg(required = true)]
    pub parts: Vec<PathBuf>,
    /// The merged table (.parquet or .csv), or the merged fits (.json).
    #[arg(long)]
    pub out: PathBuf,
    /// Also draw the family (.svg or .png).
    #[arg(long)]
    pub plot: Option<PathBuf>,
    /// Replace an existing --out file that is not a sweep table (e.g. a
    /// rig log); without it such a file is refused.
    #[arg(long)]
    pub force: bool,
    /// Print one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
}

/// The `merge` request: the parts' kind found, the paths checked.
pub fn request(args: MergeArgs) -> crate::Result<super::Request> {
    let kind = merge::part_kind(&args.parts, &args.out)?;
    let mut outputs = Vec::new();
    match kind {
        PartKind::Fits => {
            outputs.push(Output::file("--out", &args.out, super::ext::JSON));
            if args.plot.is_some() {
                return Err(merge::no_plot());
            }
        }
        PartKind::Tables => {
            outputs.push(Output::file("--out", &args.out, super::ext::TABLE));
            if let Some(p) = &args.plot {
                outputs.push(Output::file("--plot", p, super::ext::FIGURE));
            }
        }
    }
    super::check_paths(args.parts.iter().map(PathBuf::as_path), &outputs)?;
    let job = MergeJob {
        kind,
        parts: args.parts,
        out: args.out,
        plot: args.plot,
        force: args.force,
    };
    Ok(super::Request::quiet(
        crate::pipeline::Job::Merge(job),
        args.json,
    ))
}

/// Prints what was merged.
pub fn print(done: &MergeOutcome, view: &super::View) -> crate::Result<()> {
    if view.json {
        return super::print_json(&match done {
            MergeOutcome::Table(t) => crate::io::json::to_value(t),
            MergeOutcome::Fits(f) => crate::io::json::to_value(f),
        });
    }
    match done {
        MergeOutcome::Table(t) => eprintln!(
            "merged {} rows from {} parts into {}",
            t.rows,
            t.parts,
            t.out.display()
        ),
        MergeOutcome::Fits(f) => eprintln!(
            "merged {} fits ({} failed) from {} parts into {}",
            f.fits,
            f.failed,
            f.parts,
            f.out.display()
        ),
    }
    Ok(())
}
