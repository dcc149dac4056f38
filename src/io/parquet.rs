//! Parquet output: the canonical rig table a [`Run`] or a synthetic log is
//! written as (the layout `ingest` reads back), atomically.

use super::AtomicFile;
use crate::error::{Error, Result};
use crate::ingest::{Quantity, Run};
use polars::prelude::*;
use std::collections::BTreeMap;
use std::path::Path;

/// Writes the canonical table of `run` (columns `t`, `x0`, `x1`, `x2`,
/// `v2` and, where present, `a2`, `normal_force`, `setpoint_hz`; NaN written
/// as null) with the rig metadata as key-value metadata, atomically.
pub fn write_parquet(run: &Run, target: &Path) -> Result<()> {
    let r = &run.resampled;
    let to_col =
        |v: &[f64]| -> Vec<Option<f64>> { v.iter().map(|x| x.is_finite().then_some(*x)).collect() };
    let mut cols = Vec::new();
    for q in Quantity::ALL {
        if let Some(v) = r.column(q) {
            cols.push((q.name(), to_col(v)));
        }
    }
    if let Some(v) = &r.setpoint_hz {
        cols.push(("setpoint_hz", to_col(v)));
    }
    write_table(target, &r.t, &cols, &run.rig.to_map())
}

/// Writes a rig table atomically: column `t` (s), then the named value
/// columns (`None` written as null), with `meta` as the file's key-value
/// metadata (the layout the Parquet ingest, [`crate::ingest::read`], expects).
/// The columns are borrowed (a `Vec` or a slice each): only the table
/// polars builds is a copy.
pub fn write_table<C: AsRef<[Option<f64>]>>(
    target: &Path,
    t: &[f64],
    columns: &[(&str, C)],
    meta: &BTreeMap<String, String>,
) -> Result<()> {
    let fail = |e: PolarsError| Error::Input {
        path: target.to_path_buf(),
        msg: format!("cannot write Parquet: {e}"),
    };
    let mut cols = vec![Column::new("t".into(), t.to_vec())];
    for (name, v) in columns {
        let v = v.as_ref();
        if v.len() != t.len() {
            return Err(Error::Input {
                path: target.to_path_buf(),
                msg: format!("column {name} has {} rows, t has {}", v.len(), t.len()),
            });
        }
        cols.push(Column::new((*name).into(), v));
    }
    let mut df = DataFrame::new(t.len(), cols).map_err(fail)?;
    let kv: Vec<(String, String)> = meta.clone().into_iter().collect();
    let mut out = AtomicFile::create(target)?;
    ParquetWriter::new(out.writer())
        .with_key_value_metadata(Some(KeyValueMetadata::from_static(kv)))
        .finish(&mut df)
        .map_err(fail)?;
    out.commit()
}
