//! `stickslip merge`: joins the partial tables of a sharded sweep
//! (`sweep --shard K/N --out part-K.parquet`) into the family's table,
//! exactly as an unsharded run writes it.

use crate::io::Output;
use crate::report::table::FrcRow;
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
    let mut outputs = vec![Output::file("--out", &args.out, super::ext::TABLE)];
    if let Some(p) = &args.plot {
        outputs.push(Output::file("--plot", p, super::ext::FIGURE));
    }
    super::check_paths(args.parts.iter().map(PathBuf::as_path), &outputs)?;
    let mut rows = Vec::new();
    let mut part_of = Vec::new();
    for (i, p) in args.parts.iter().enumerate() {
        let part = table::read_frc(p).map_err(|e| crate::Error::Input {
            path: p.clone(),
            msg: format!("not a sweep table written by `stickslip sweep --out` ({e})"),
        })?;
        part_of.extend(std::iter::repeat_n(i, part.len()));
        rows.extend(part);
    }
    check_parts(&args.parts, &rows, &part_of)?;
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
    check_complete(&rows)?;
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

/// Refuses parts that do not come from one sweep: every row must share the
/// absorber (m, k, D), each curve one model (law and direction) and each η
/// index one η, whichever part it is in.
fn check_parts(parts: &[PathBuf], rows: &[FrcRow], part_of: &[usize]) -> crate::Result<()> {
    let Some(first) = rows.first() else {
        return Err(SimError::Unsupported("the parts hold no rows".into()).into());
    };
    let differ = |i: usize, what: String| -> crate::Error {
        crate::Error::Input {
            path: parts[part_of[i]].clone(),
            msg: format!(
                "{what} than in {}: the parts come from different sweeps",
                parts[part_of[0]].display()
            ),
        }
    };
    let same = |a: f64, b: f64| a == b || (a.is_nan() && b.is_nan());
    let same_opt = |a: Option<f64>, b: Option<f64>| match (a, b) {
        (Some(a), Some(b)) => same(a, b),
        (None, None) => true,
        _ => false,
    };
    let mut curve_model: std::collections::BTreeMap<u32, usize> = Default::default();
    let mut point_eta: std::collections::BTreeMap<u32, usize> = Default::default();
    for (i, r) in rows.iter().enumerate() {
        if !(same(r.m, first.m) && same(r.k, first.k) && same(r.damping, first.damping)) {
            return Err(differ(
                i,
                format!("another absorber (m {}, k {}, D {})", r.m, r.k, r.damping),
            ));
        }
        let c = &rows[*curve_model.entry(r.curve).or_insert(i)];
        if !(same(r.rho_s, c.rho_s)
            && same(r.rho_d, c.rho_d)
            && same(r.slope, c.slope)
            && same_opt(r.v_s, c.v_s)
            && same_opt(r.stop_below, c.stop_below)
            && r.direction == c.direction)
        {
            return Err(differ(i, format!("curve {} has another model", r.curve)));
        }
        let e = &rows[*point_eta.entry(r.point).or_insert(i)];
        if !same(r.eta, e.eta) {
            return Err(differ(
                i,
                format!(
                    "point {} has eta {} rather than {}: another grid",
                    r.point, r.eta, e.eta
                ),
            ));
        }
    }
    Ok(())
}

/// Refuses an incomplete set of shards: every curve 0..C must hold every
/// point 0..P of the grid (sorted rows, no duplicates). A missing shard
/// of whole curves at the end of the family cannot be seen from the rows.
fn check_complete(rows: &[FrcRow]) -> crate::Result<()> {
    let curves = rows.iter().map(|r| r.curve).max().map_or(0, |c| c + 1);
    let points = rows.iter().map(|r| r.point).max().map_or(0, |p| p + 1);
    let expected = curves as usize * points as usize;
    if rows.len() != expected {
        let mut missing = Vec::new();
        let mut it = rows.iter().peekable();
        'outer: for c in 0..curves {
            for p in 0..points {
                match it.peek() {
                    Some(r) if (r.curve, r.point) == (c, p) => {
                        it.next();
                    }
                    _ => {
                        missing.push(format!("curve {c} point {p}"));
                        if missing.len() == 5 {
                            break 'outer;
                        }
                    }
                }
            }
        }
        return Err(SimError::Unsupported(format!(
            "incomplete set of shards: {} of {expected} points ({curves} curves x {points} etas) are missing, e.g. {}: merge every shard K/N",
            expected - rows.len(),
            missing.join(", ")
        ))
        .into());
    }
    Ok(())
}
