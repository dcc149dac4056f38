//! The `merge` job: joins the partial tables of a sharded sweep (`sweep
//! --shard K/N --out part-K.parquet`) into the family's table, exactly as
//! an unsharded run writes it; or the parts of a sharded fit (`fit --shard
//! K/N --out part-K.json`) into one `{"fits": [...]}` object, the records
//! in the order of the log list. Each is written through the write
//! transaction ([`crate::io::txn`]); the JSON objects are
//! [`MergeTableJson`] and [`MergeFitsJson`].

use crate::report::table::FrcRow;
use crate::report::{plot, table};
use crate::sim::SimError;
use serde::Serialize;
use std::path::{Path, PathBuf};

/// What the parts of a merge are.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PartKind {
    /// Partial tables of a sharded sweep (.parquet or .csv).
    Tables,
    /// Parts of a sharded fit (.json).
    Fits,
}

fn is_json(p: &Path) -> bool {
    p.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("json"))
}

/// What `parts` are: all fit parts (.json), or all tables; a mix is
/// refused (`out` named where no part is at fault).
pub fn part_kind(parts: &[PathBuf], out: &Path) -> crate::Result<PartKind> {
    let json_parts = parts.iter().filter(|p| is_json(p)).count();
    if json_parts == parts.len() {
        return Ok(PartKind::Fits);
    }
    if json_parts > 0 {
        let p = parts
            .iter()
            .find(|p| is_json(p))
            .map_or(out, PathBuf::as_path);
        return Err(crate::Error::Input {
            path: p.to_path_buf(),
            msg: "is a fit part (.json) among sweep tables: merge takes sweep tables or fit parts, not both".into(),
        });
    }
    Ok(PartKind::Tables)
}

/// One merge.
#[derive(Debug, Clone)]
pub struct MergeJob {
    /// What the parts are ([`part_kind`]).
    pub kind: PartKind,
    /// The parts.
    pub parts: Vec<PathBuf>,
    /// The merged table (.parquet or .csv), or the merged fits (.json).
    pub out: PathBuf,
    /// Also draw the family (tables only).
    pub plot: Option<PathBuf>,
    /// Replace an `out` file that is not a sweep table.
    pub force: bool,
}

/// The `merge --json` object of merged tables.
#[derive(Debug, Clone, Serialize)]
pub struct MergeTableJson {
    /// Rows of the merged table.
    pub rows: usize,
    /// Parts merged.
    pub parts: usize,
    /// The merged table.
    pub out: PathBuf,
}

/// The `merge --json` object of merged fit parts.
#[derive(Debug, Clone, Serialize)]
pub struct MergeFitsJson {
    /// Fit records merged.
    pub fits: usize,
    /// Of which failed fits.
    pub failed: usize,
    /// Parts merged.
    pub parts: usize,
    /// The merged fits.
    pub out: PathBuf,
}

/// The merged fits file: `{"fits": [...]}`.
#[derive(Debug, Clone, Serialize)]
pub struct MergedFits {
    /// The fit records, in the order of the log list.
    pub fits: Vec<serde_json::Value>,
}

/// What [`run_merge`] wrote.
#[derive(Debug, Clone)]
pub enum MergeOutcome {
    /// The family's table.
    Table(MergeTableJson),
    /// The fits of the log list.
    Fits(MergeFitsJson),
}

/// Runs the merge (the parts' paths are checked by the caller).
pub fn run_merge(job: &MergeJob) -> crate::Result<MergeOutcome> {
    match job.kind {
        PartKind::Tables => merge_tables(job).map(MergeOutcome::Table),
        PartKind::Fits => merge_fits(job).map(MergeOutcome::Fits),
    }
}

/// Joins partial tables: one family, each shard once, none missing.
fn merge_tables(job: &MergeJob) -> crate::Result<MergeTableJson> {
    super::sweep::refuse_replacing_other(&job.out, job.force)?;
    let mut rows = Vec::new();
    let mut part_of = Vec::new();
    let mut metas = Vec::new();
    for (i, p) in job.parts.iter().enumerate() {
        let part = table::read_table(p).map_err(|e| crate::Error::Input {
            path: p.clone(),
            msg: format!("not a sweep table written by `stickslip sweep --out` ({e})"),
        })?;
        part_of.extend(std::iter::repeat_n(i, part.rows.len()));
        rows.extend(part.rows);
        metas.push(part.meta);
    }
    let family = check_shards(&job.parts, &metas)?;
    check_parts(&job.parts, &rows, &part_of)?;
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
    let meta = check_complete(&rows, family)?;
    // Branches of one model may come from different shards.
    table::mark_coexisting(&mut rows);
    table::write_frc(&rows, &meta, &job.out)?;
    if let Some(p) = &job.plot {
        plot::frc(
            &crate::report::frc_json::figure(&rows, "Frequency response".into()),
            p,
        )?;
    }
    Ok(MergeTableJson {
        rows: rows.len(),
        parts: job.parts.len(),
        out: job.out.clone(),
    })
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
            && same_opt(r.rho_s_minus, c.rho_s_minus)
            && same_opt(r.rho_d_minus, c.rho_d_minus)
            && same_opt(r.contact_stiffness, c.contact_stiffness)
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

/// Checks the parts' shard metadata: one family (same N, curves and
/// points), each shard K/N once, none missing. Returns the family's size
/// (curves, points), or `None` if no part records it (tables written
/// before the metadata existed: then only the rows can be checked).
fn check_shards(
    parts: &[PathBuf],
    metas: &[Option<table::TableMeta>],
) -> crate::Result<Option<(usize, usize)>> {
    let known: Vec<(usize, &table::TableMeta)> = metas
        .iter()
        .enumerate()
        .filter_map(|(i, m)| m.as_ref().map(|m| (i, m)))
        .collect();
    let Some(&(i0, first)) = known.first() else {
        return Ok(None);
    };
    if known.len() < parts.len() {
        let i = metas.iter().position(Option::is_none).unwrap_or(0);
        return Err(crate::Error::Input {
            path: parts[i].clone(),
            msg: format!(
                "records no shard K/N while {} does: the parts come from different sweeps or stickslip versions",
                parts[i0].display()
            ),
        });
    }
    let mut seen: Vec<Option<usize>> = vec![None; first.shards];
    for &(i, m) in &known {
        if (m.shards, m.curves, m.points) != (first.shards, first.curves, first.points) {
            return Err(crate::Error::Input {
                path: parts[i].clone(),
                msg: format!(
                    "is shard {}/{} of {} curves x {} etas, but {} is shard {}/{} of {} curves x {} etas: the parts come from different sweeps",
                    m.shard, m.shards, m.curves, m.points,
                    parts[i0].display(), first.shard, first.shards, first.curves, first.points
                ),
            });
        }
        if let Some(j) = seen[m.shard - 1].replace(i) {
            return Err(crate::Error::Input {
                path: parts[i].clone(),
                msg: format!(
                    "is shard {}/{} again (also {}): give each shard once",
                    m.shard,
                    m.shards,
                    parts[j].display()
                ),
            });
        }
    }
    all_shards_present(&seen, first.shards)?;
    Ok(Some((first.curves, first.points)))
}

/// Refuses an incomplete set of rows: every curve 0..C must hold every
/// point 0..P of the grid (sorted rows, no duplicates), with C × P from the
/// shard metadata where the parts record it, else from the rows (then a
/// missing shard of whole curves at the end of the family cannot be seen).
/// Returns the merged table's metadata (shard 1/1).
fn check_complete(
    rows: &[FrcRow],
    family: Option<(usize, usize)>,
) -> crate::Result<table::TableMeta> {
    let seen_curves = rows.iter().map(|r| r.curve).max().map_or(0, |c| c + 1);
    let seen_points = rows.iter().map(|r| r.point).max().map_or(0, |p| p + 1);
    let (curves, points) = family.unwrap_or((seen_curves as usize, seen_points as usize));
    if seen_curves as usize > curves || seen_points as usize > points {
        return Err(SimError::Unsupported(format!(
            "rows reach curve {} point {}, beyond the {curves} curves x {points} etas the parts record",
            seen_curves - 1,
            seen_points - 1
        ))
        .into());
    }
    let (curves, points) = (curves as u32, points as u32);
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
    Ok(table::TableMeta {
        shard: 1,
        shards: 1,
        curves: curves as usize,
        points: points as usize,
    })
}

/// One fit part as read: its shard, the log list's sha256s, its records.
struct FitPart {
    shard: usize,
    shards: usize,
    shas: Vec<Option<String>>,
    fits: Vec<serde_json::Value>,
}

/// Reads a fit part (`fit --shard K/N --out`).
fn read_fit_part(p: &std::path::Path) -> crate::Result<FitPart> {
    let bad = |msg: String| crate::Error::Input {
        path: p.to_path_buf(),
        msg,
    };
    let not_part = |why: &str| {
        bad(format!(
            "not a fit part written by `stickslip fit --shard K/N --out` ({why})"
        ))
    };
    let text = crate::io::paths::read_small_text(
        p,
        "fit part",
        crate::identify::artifact::MAX_FITS_BYTES,
    )?;
    let v: serde_json::Value = serde_json::from_str(&text).map_err(|e| not_part(&e.to_string()))?;
    let num = |k: &str| v.get(k).and_then(serde_json::Value::as_u64);
    let (Some(shard), Some(shards)) = (num("shard"), num("shards")) else {
        return Err(not_part("no `shard` and `shards`"));
    };
    if shards == 0 || shard == 0 || shard > shards || shards > super::fit::MAX_FIT_SHARDS as u64 {
        return Err(not_part(&format!("shard {shard}/{shards}")));
    }
    let shas = v
        .get("log_sha256s")
        .and_then(serde_json::Value::as_array)
        .ok_or_else(|| not_part("no `log_sha256s` list"))?
        .iter()
        .map(|s| s.as_str().map(str::to_string))
        .collect();
    let fits = v
        .get("fits")
        .and_then(serde_json::Value::as_array)
        .ok_or_else(|| not_part("no `fits` list"))?
        .clone();
    Ok(FitPart {
        shard: shard as usize,
        shards: shards as usize,
        shas,
        fits,
    })
}

/// Joins the parts of a sharded fit: every part of one log list (the same
/// N and sha256 list), each shard K/N once, none missing, each part's
/// records those of its slice (their `log_sha256` in the list's order);
/// writes `{"fits": [...]}` in the log list's order.
fn merge_fits(args: &MergeJob) -> crate::Result<MergeFitsJson> {
    if args.plot.is_some() {
        return Err(no_plot());
    }
    let parts: Vec<FitPart> = args
        .parts
        .iter()
        .map(|p| read_fit_part(p))
        .collect::<crate::Result<_>>()?;
    let first = &parts[0];
    let mut seen: Vec<Option<usize>> = vec![None; first.shards];
    for (i, part) in parts.iter().enumerate() {
        if part.shards != first.shards || part.shas != first.shas {
            return Err(crate::Error::Input {
                path: args.parts[i].clone(),
                msg: format!(
                    "is shard {}/{} of a list of {} logs, {} shard {}/{} of a list of {} logs: the parts come from different log lists (merge the parts of one `fit --shard` run)",
                    part.shard,
                    part.shards,
                    part.shas.len(),
                    args.parts[0].display(),
                    first.shard,
                    first.shards,
                    first.shas.len()
                ),
            });
        }
        if let Some(j) = seen[part.shard - 1].replace(i) {
            return Err(crate::Error::Input {
                path: args.parts[i].clone(),
                msg: format!(
                    "is shard {}/{} again (also {}): give each shard once",
                    part.shard,
                    part.shards,
                    args.parts[j].display()
                ),
            });
        }
        let range = super::fit::shard_range(part.shard, part.shards, part.shas.len());
        let got: Vec<Option<&str>> = part
            .fits
            .iter()
            .map(|f| f.get("log_sha256").and_then(serde_json::Value::as_str))
            .collect();
        let want: Vec<Option<&str>> = first.shas[range].iter().map(Option::as_deref).collect();
        if got != want {
            return Err(crate::Error::Input {
                path: args.parts[i].clone(),
                msg: format!(
                    "its {} records are not the logs of shard {}/{} of its list ({} logs): an edited part?",
                    got.len(),
                    part.shard,
                    part.shards,
                    want.len()
                ),
            });
        }
        for f in &part.fits {
            crate::identify::artifact::entry_of(f).map_err(|e| crate::Error::Input {
                path: args.parts[i].clone(),
                msg: e.to_string(),
            })?;
        }
    }
    all_shards_present(&seen, first.shards)?;
    let mut ordered: Vec<&FitPart> = parts.iter().collect();
    ordered.sort_by_key(|p| p.shard);
    let fits: Vec<serde_json::Value> = ordered
        .iter()
        .flat_map(|p| p.fits.iter().cloned())
        .collect();
    let failed = fits.iter().filter(|f| f.get("error").is_some()).count();
    let n = fits.len();
    crate::io::json::write_pretty(&args.out, &crate::io::json::to_value(MergedFits { fits }))?;
    Ok(MergeFitsJson {
        fits: n,
        failed,
        parts: args.parts.len(),
        out: args.out.clone(),
    })
}

/// Fit parts have no figure: `--plot` is refused.
pub fn no_plot() -> crate::Error {
    crate::Error::Input {
        path: PathBuf::from("--plot"),
        msg: "draws a sweep family: fit parts have no figure".into(),
    }
}

/// Refuses an incomplete set of shards, naming every missing K/N (`seen`
/// holds one entry per shard, `None` where no part had it).
fn all_shards_present<T>(seen: &[Option<T>], shards: usize) -> Result<(), crate::Error> {
    let missing: Vec<String> = seen
        .iter()
        .enumerate()
        .filter(|(_, s)| s.is_none())
        .map(|(k, _)| format!("{}/{}", k + 1, shards))
        .collect();
    if missing.is_empty() {
        return Ok(());
    }
    Err(SimError::Unsupported(format!(
        "incomplete set of shards: {} of {} missing ({}): merge every shard K/N",
        missing.len(),
        shards,
        missing.join(", ")
    ))
    .into())
}
