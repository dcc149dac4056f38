//! `stickslip merge`: joins the partial tables of a sharded sweep
//! (`sweep --shard K/N --out part-K.parquet`) into the family's table,
//! exactly as an unsharded run writes it.

use crate::report::{plot, table};
use crate::sim::SimError;
use clap::Args;
use serde_json::json;
use std::path::PathBuf;

/// Arguments of `stickslip merge`.
#[derive(Debug, Args)]
pub struct MergeArgs {
    /// Partial tables (.parquet or .csv).
    #[arg(required = true)]
    pub parts: Vec<PathBuf>,
    /// The merged table (.parquet or .csv).
    #[arg(long)]
    pub out: PathBuf,
    /// Also draw the family (.svg or .png).
    #[arg(long)]
    pub plot: Option<PathBuf>,
    /// Print one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
}

/// Runs `merge`.
pub fn run(args: MergeArgs) -> crate::Result<()> {
    crate::io::ensure_not_inputs(
        args.parts.iter().map(PathBuf::as_path),
        std::iter::once(args.out.as_path()).chain(args.plot.as_deref()),
    )?;
    let mut rows = Vec::new();
    for p in &args.parts {
        rows.extend(table::read_frc(p)?);
    }
    rows.sort_by_key(|r| (r.curve, r.point));
    for w in rows.windows(2) {
        if (w[0].curve, w[0].point) == (w[1].curve, w[1].point) {
            return Err(SimError::Unsupported(format!(
                "curve {} point {} appears in more than one part (overlapping shards?)",
                w[0].curve, w[0].point
            ))
            .into());
        }
    }
    // Branches of one model may come from different shards.
    table::mark_coexisting(&mut rows);
    table::write_frc(&rows, &args.out)?;
    if let Some(p) = &args.plot {
        plot::frc(&super::sweep::figure(&rows, "Frequency response".into()), p)?;
    }
    if args.json {
        super::print_json(
            &json!({ "rows": rows.len(), "parts": args.parts.len(), "out": args.out }),
        );
    } else {
        eprintln!(
            "merged {} rows from {} parts into {}",
            rows.len(),
            args.parts.len(),
            args.out.display()
        );
    }
    Ok(())
}
