//! Parquet tables: columns `t`, `x0`, `x1`, `x2`, `v2` and optionally `a2`,
//! `normal_force`, `setpoint_hz` (SI, common time base, null = dropout), with
//! the `rig` metadata as the file's key-value metadata. The same layout is
//! what [`crate::io::write_parquet`] writes for a canonical [`Run`](super::Run).

use super::rig::RigMeta;
use super::run::{median_interval, Setpoint};
use super::{ContentError, IngestError, LogFormat, Quantity, RawChannel, RawLog, SampleCount};
use polars::prelude::*;
use std::collections::BTreeMap;
use std::path::Path;

/// Key-value metadata keys written by Arrow/Parquet tools, not rig metadata.
fn is_tool_key(key: &str) -> bool {
    key.starts_with("ARROW:") || key == "pandas" || key.starts_with("polars")
}

fn pq_err(path: &Path, what: &str, e: PolarsError) -> IngestError {
    IngestError::invalid(path, format!("{what}: {e}"))
}

/// Reads a Parquet rig table.
/// Reads a Parquet log. The Parquet decoder can panic on corrupt metadata
/// (found by `tests/fuzz.rs`): such a panic is caught and reported as a
/// corrupt file, never shown to the user as a crash.
/// `max_samples`: the caller's budget ([`super::IngestOptions::max_samples`]):
/// a table with more rows is refused from its footer, before any column
/// is decoded.
pub(crate) fn read(path: &Path, max_samples: Option<u64>) -> Result<RawLog, IngestError> {
    match crate::guard::guarded(|| read_inner(path, max_samples)) {
        Ok(r) => r,
        Err(msg) => Err(IngestError::invalid(
            path,
            format!("corrupt Parquet file (the decoder failed: {msg})"),
        )),
    }
}

fn read_inner(path: &Path, max_samples: Option<u64>) -> Result<RawLog, IngestError> {
    check_magic(path)?;
    let file = std::fs::File::open(path).map_err(|e| IngestError::io(path, e))?;
    let mut reader = ParquetReader::new(file);
    let meta = reader.get_metadata().map_err(|e| {
        pq_err(
            path,
            "unreadable Parquet footer (truncated or corrupt file?)",
            e,
        )
    })?;
    let rows = meta.num_rows as u64;
    if let Some(max) = max_samples.filter(|m| rows > *m) {
        return Err(IngestError::content(
            path,
            ContentError::OverFitBudget {
                subject: format!("{rows} rows"),
                samples: rows,
                max,
                count: SampleCount::Grid,
            },
        ));
    }
    let mut rig_map = BTreeMap::new();
    if let Some(kvs) = meta.key_value_metadata() {
        for kv in kvs {
            if is_tool_key(&kv.key) {
                continue;
            }
            if let Some(v) = &kv.value {
                rig_map.insert(kv.key.clone(), v.clone());
            }
        }
    }
    if rig_map.is_empty() {
        return Err(IngestError::invalid(
            path,
            "no rig metadata: the Parquet file has no key-value metadata",
        ));
    }
    let rig = RigMeta::from_map(&rig_map).map_err(|e| IngestError::rig(path, e))?;
    let schema = reader
        .schema()
        .map_err(|e| pq_err(path, "unreadable Parquet schema", e))?;
    let names: Vec<String> = schema.iter_names().map(|n| n.to_string()).collect();
    for q in ["t", "x0", "x1", "x2"] {
        if !names.iter().any(|n| n == q) {
            return Err(IngestError::invalid(
                path,
                format!(
                    "missing required column `{q}` (columns: {})",
                    names.join(", ")
                ),
            ));
        }
    }
    let wanted: Vec<String> = [
        "t",
        "x0",
        "x1",
        "x2",
        "v2",
        "a2",
        "normal_force",
        "setpoint_hz",
    ]
    .into_iter()
    .filter(|c| names.iter().any(|n| n == c))
    .map(String::from)
    .collect();
    let df = reader
        .with_columns(Some(wanted))
        .finish()
        .map_err(|e| pq_err(path, "unreadable Parquet data", e))?;
    let time = time_column(path, &df)?;
    let dt_s = median_interval(&time)
        .ok_or_else(|| IngestError::invalid(path, "too little data: the table has a single row"))?;
    // Time in other units than seconds (integer nanoseconds read as
    // seconds) makes the log absurd: refused with the rate it implies.
    let rate = 1.0 / dt_s;
    let (lo, hi) = super::csv::RATE_RANGE_HZ;
    if !(rate >= lo && rate <= hi) {
        return Err(IngestError::invalid(
            path,
            format!(
                "column `t`: the rows come every {dt_s:e} s ({rate:.4e} Hz), outside the plausible {lo:.0}-{hi:.0e} Hz of a rig log: `t` must be in seconds (integer nanoseconds or milliseconds read as seconds give this)"
            ),
        ));
    }
    let mut channels = Vec::new();
    // One time column, shared by every channel.
    let shared: super::Column = time.as_slice().into();
    for q in Quantity::ALL {
        if let Some(v) = column(path, &df, q.name())? {
            channels.push(RawChannel {
                quantity: q,
                source: q.name().to_string(),
                dt_s,
                t: shared.clone(),
                v,
            });
        }
    }
    let mut setpoints = Vec::new();
    if let Some(v) = column(path, &df, "setpoint_hz")? {
        let mut last = f64::NAN;
        for (t, f) in time.iter().zip(v) {
            if f.is_finite() && f != last {
                setpoints.push(Setpoint {
                    t_s: *t,
                    frequency_hz: f,
                    amplitude_m: None,
                });
                last = f;
            }
        }
    }
    Ok(RawLog {
        format: LogFormat::Parquet,
        rig,
        channels,
        origin: Some(time[0]),
        setpoints,
        warnings: Vec::new(),
        declared_shifts: Vec::new(),
    })
}

/// Refuses a file that does not start with Parquet's magic bytes.
fn check_magic(path: &Path) -> Result<(), IngestError> {
    use std::io::Read;
    let mut magic = [0u8; 4];
    let mut f = std::fs::File::open(path).map_err(|e| IngestError::io(path, e))?;
    let n = f.read(&mut magic).map_err(|e| IngestError::io(path, e))?;
    if n < 4 || &magic != b"PAR1" {
        return Err(IngestError::invalid(
            path,
            "not a Parquet file (bad magic bytes)",
        ));
    }
    Ok(())
}

/// A numeric column as floats (null and NaN: dropouts), `None` where the
/// table has no such column; refuses text columns and infinite values.
fn column(path: &Path, df: &DataFrame, name: &str) -> Result<Option<Vec<f64>>, IngestError> {
    let Ok(col) = df.column(name) else {
        return Ok(None);
    };
    if !col.dtype().is_primitive_numeric() {
        return Err(IngestError::invalid(
            path,
            format!("column `{name}` holds {} values, not numbers", col.dtype()),
        ));
    }
    let cast = col
        .cast(&DataType::Float64)
        .map_err(|e| pq_err(path, &format!("column `{name}`"), e))?;
    let ca = cast
        .f64()
        .map_err(|e| pq_err(path, &format!("column `{name}`"), e))?;
    let mut out = Vec::with_capacity(ca.len());
    for (i, v) in ca.iter().enumerate() {
        match v {
            None => out.push(f64::NAN),
            Some(x) if x.is_infinite() => {
                return Err(IngestError::invalid(
                    path,
                    format!("column `{name}`, row {i}: infinite value"),
                ))
            }
            Some(x) => out.push(x), // NaN is read as a dropout, like null
        }
    }
    Ok(Some(out))
}

/// The time column `t`: rows present, every time finite and increasing.
fn time_column(path: &Path, df: &DataFrame) -> Result<Vec<f64>, IngestError> {
    let time = column(path, df, "t")?.unwrap_or_default();
    if df.height() == 0 {
        return Err(IngestError::invalid(path, "no data: the table has no rows"));
    }
    if let Some(i) = time.iter().position(|t| !t.is_finite()) {
        return Err(IngestError::invalid(
            path,
            format!("column `t`, row {i}: no time"),
        ));
    }
    if let Some(i) = time.windows(2).position(|w| w[1] <= w[0]) {
        return Err(IngestError::invalid(
            path,
            format!(
                "non-monotonic time: column `t`, row {}: {} s does not follow {} s",
                i + 1,
                time[i + 1],
                time[i]
            ),
        ));
    }
    Ok(time)
}

#[cfg(test)]
mod tests {
    /// A `t` column in integer nanoseconds (read as seconds) is refused
    /// with the rate it implies, not ingested as a log of 1e-6 Hz.
    #[test]
    fn time_in_nanoseconds_is_refused() {
        let src =
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("datasets/char_N2.2.parquet");
        let run = crate::ingest::read(&src, &Default::default()).expect("bundled log");
        let r = &run.resampled;
        let t_ns: Vec<f64> = r.t.iter().map(|t| (t * 1e9).round()).collect();
        let col = |v: &[f64]| v.iter().map(|x| Some(*x)).collect::<Vec<_>>();
        let cols = [("x0", col(&r.x0)), ("x1", col(&r.x1)), ("x2", col(&r.x2))];
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("ns.parquet");
        crate::io::write_table(&p, &t_ns, &cols, &run.rig.to_map()).unwrap();
        let e = crate::ingest::read(&p, &Default::default())
            .unwrap_err()
            .to_string();
        assert!(e.contains("must be in seconds"), "{e}");
    }
}
