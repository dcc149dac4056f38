//! DAQ CSV exports: a `#key,value` preamble (the rig metadata), one header
//! row, one row per sample on a common time base, and a TOML channel map that
//! says which column holds which quantity (with scale to SI and time shift).
//!
//! The preamble is parsed here, then the table is streamed line by line
//! into the mapped columns only (f64, allocated once at the row count a
//! first pass found): a long log takes the memory of its columns, not a
//! multiple of its file size. A malformed number is reported with its line
//! and column.

use super::rig::RigMeta;
use super::run::{median_interval, Setpoint};
use super::{
    Column, ContentError, IngestError, LogFormat, Quantity, RawChannel, RawLog, SampleCount,
};
use serde::Deserialize;
use std::collections::BTreeMap;
use std::io::{BufRead, Read};
use std::path::{Path, PathBuf};

/// Longest preamble line accepted (guards against a binary file read as text).
const MAX_PREAMBLE_LINE: usize = 1 << 20;

/// One column entry of a channel map (CSV, TDMS and MAT logs share the
/// keys; `rate_hz` and `t0_s` are for MAT variables only).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct ColumnSpec {
    /// Column name in the CSV header (TDMS: `Group/Channel`; MAT: the
    /// variable).
    pub name: String,
    /// Factor to SI as written in the map (`None`: not given).
    #[serde(default, rename = "scale")]
    pub scale_given: Option<f64>,
    /// The row's value was taken at row time + shift_s (default 0).
    #[serde(default)]
    pub shift_s: f64,
    /// MAT: the variable's own uniform sample rate (Hz).
    #[serde(default)]
    pub rate_hz: Option<f64>,
    /// MAT: the time of the variable's first sample (s; with `rate_hz`).
    #[serde(default)]
    pub t0_s: Option<f64>,
}

impl ColumnSpec {
    /// Factor to SI (default 1).
    pub fn scale(&self) -> f64 {
        self.scale_given.unwrap_or(1.0)
    }
}

/// The log kind a channel map is read for (what its entries name and
/// which keys apply).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum MapKind {
    /// CSV columns: `time` required.
    Csv,
    /// TDMS `Group/Channel`s: `time` only where a mapped channel is not a
    /// waveform (checked by the reader).
    Tdms,
    /// MAT variables: `time` unless every entry has its own `rate_hz`.
    Mat,
}

impl MapKind {
    fn what(self) -> &'static str {
        match self {
            MapKind::Csv => "CSV",
            MapKind::Tdms => "TDMS",
            MapKind::Mat => "MAT",
        }
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct MapFile {
    columns: BTreeMap<String, ColumnSpec>,
}

/// A parsed and checked channel map.
#[derive(Debug, Clone)]
pub(crate) struct ChannelMap {
    /// The `time` entry (always present in a CSV map).
    pub time: Option<ColumnSpec>,
    pub channels: Vec<(Quantity, ColumnSpec)>,
    pub setpoint_hz: Option<ColumnSpec>,
}

/// Parses a CSV channel map (TOML text); `map_path` names it in errors.
pub(crate) fn parse_map(map_path: &Path, text: &str) -> Result<ChannelMap, IngestError> {
    parse_map_for(map_path, text, MapKind::Csv)
}

/// Parses a channel map for a log of `kind`; `map_path` names it in errors.
pub(crate) fn parse_map_for(
    map_path: &Path,
    text: &str,
    kind: MapKind,
) -> Result<ChannelMap, IngestError> {
    let bad = |msg: String| IngestError::invalid(map_path, msg);
    let file: MapFile = toml::from_str(text).map_err(|e| {
        let at = e.span().map_or(String::new(), |span| {
            let before = text.get(..span.start).unwrap_or(text);
            let line = before.matches('\n').count() + 1;
            let col = before.len() - before.rfind('\n').map_or(0, |i| i + 1) + 1;
            format!(" at line {line}, column {col}")
        });
        bad(format!(
            "not a valid channel map{at}: {}",
            e.message().trim()
        ))
    })?;
    let mut time = None;
    let mut setpoint_hz = None;
    let mut channels = Vec::new();
    for (key, spec) in file.columns {
        if !(spec.scale().is_finite() && spec.scale() != 0.0) {
            return Err(bad(format!(
                "column entry `{key}`: scale {} must be finite and non-zero",
                spec.scale()
            )));
        }
        if !spec.shift_s.is_finite() {
            return Err(bad(format!("column entry `{key}`: shift_s must be finite")));
        }
        check_own_rate(&key, &spec, kind).map_err(|e| bad(e.to_string()))?;
        match key.as_str() {
            "time" => time = Some(spec),
            "setpoint_hz" => setpoint_hz = Some(spec),
            other => match Quantity::from_name(other) {
                Some(q) => channels.push((q, spec)),
                None => {
                    return Err(bad(format!(
                        "unknown quantity `{other}` in [columns] (expected time, x0, x1, x2, v2, a2, normal_force, setpoint_hz)"
                    )))
                }
            },
        }
    }
    let all_own_rate = channels.iter().all(|(_, s)| s.rate_hz.is_some())
        && setpoint_hz.as_ref().is_none_or(|s| s.rate_hz.is_some());
    let time_needed = match kind {
        MapKind::Csv => true,
        MapKind::Tdms => false,
        MapKind::Mat => !all_own_rate,
    };
    if time.is_none() && time_needed {
        return Err(bad(match kind {
            MapKind::Mat => {
                "[columns] lacks the entry `time` (needed unless every entry has its own `rate_hz`)"
                    .into()
            }
            _ => "[columns] lacks the required entry `time`".into(),
        }));
    }
    if let Some(time) = &time {
        if time.scale() <= 0.0 {
            return Err(bad("column entry `time`: scale must be positive".into()));
        }
    }
    for q in Quantity::ALL.into_iter().filter(|q| q.required()) {
        if !channels.iter().any(|(p, _)| *p == q) {
            return Err(bad(format!(
                "[columns] lacks the required entry `{}`",
                q.name()
            )));
        }
    }
    // One column carries one quantity.
    let mut entries: Vec<(&str, &str)> = time.iter().map(|t| ("time", t.name.as_str())).collect();
    entries.extend(channels.iter().map(|(q, s)| (q.name(), s.name.as_str())));
    entries.extend(setpoint_hz.iter().map(|s| ("setpoint_hz", s.name.as_str())));
    for (i, (a, col)) in entries.iter().enumerate() {
        if let Some((b, _)) = entries[i + 1..].iter().find(|(_, c)| c == col) {
            return Err(bad(format!(
                "entries `{a}` and `{b}` both read column {col:?}: one column carries one quantity"
            )));
        }
    }
    Ok(ChannelMap {
        time,
        channels,
        setpoint_hz,
    })
}

/// What is wrong with the MAT-only keys `rate_hz` and `t0_s` of a map
/// entry ([`check_own_rate`]).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
enum OwnRateError {
    /// The keys in a map of a log that carries its own times.
    #[error("column entry `{key}`: rate_hz and t0_s apply to MAT variables only (a {} log carries its own times)", .kind.what())]
    NotMat { key: String, kind: MapKind },
    /// The keys on the `time` entry.
    #[error("column entry `time`: rate_hz and t0_s belong to the variables, not to `time`")]
    OnTime,
    /// `t0_s` without `rate_hz`.
    #[error("column entry `{key}`: t0_s needs rate_hz")]
    T0WithoutRate { key: String },
    /// An implausible rate.
    #[error("column entry `{key}`: rate_hz {rate} is outside the plausible {:.0}-{:.0e} Hz of a rig log", RATE_RANGE_HZ.0, RATE_RANGE_HZ.1)]
    Rate { key: String, rate: f64 },
    /// A `t0_s` that is not finite.
    #[error("column entry `{key}`: t0_s must be finite")]
    T0NotFinite { key: String },
}

/// Checks the MAT-only keys `rate_hz` and `t0_s` of entry `key`.
fn check_own_rate(key: &str, spec: &ColumnSpec, kind: MapKind) -> Result<(), OwnRateError> {
    if spec.rate_hz.is_none() && spec.t0_s.is_none() {
        return Ok(());
    }
    let owned = || key.to_string();
    if kind != MapKind::Mat {
        return Err(OwnRateError::NotMat { key: owned(), kind });
    }
    if key == "time" {
        return Err(OwnRateError::OnTime);
    }
    let Some(rate) = spec.rate_hz else {
        return Err(OwnRateError::T0WithoutRate { key: owned() });
    };
    let (lo, hi) = RATE_RANGE_HZ;
    if !(rate >= lo && rate <= hi) {
        return Err(OwnRateError::Rate { key: owned(), rate });
    }
    if spec.t0_s.is_some_and(|t| !t.is_finite()) {
        return Err(OwnRateError::T0NotFinite { key: owned() });
    }
    Ok(())
}

/// The default map of `NAME.csv`: `NAME.map.toml` beside it.
pub(crate) fn default_map_path(path: &Path) -> PathBuf {
    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    path.with_file_name(format!("{stem}.map.toml"))
}

/// What precedes the data rows of a DAQ export.
struct Head {
    /// The `#key,value` metadata.
    meta: BTreeMap<String, String>,
    /// Number of preamble lines.
    lines: usize,
    /// The header line (column names), if the file has one.
    header: Option<String>,
}

/// The field separator of a header line: `,` if it has any, else `;`, else
/// a tab (European DAQ exports write `;` with decimal commas).
fn detect_separator(header: &str) -> u8 {
    for sep in [b',', b';', b'\t'] {
        if header.as_bytes().contains(&sep) {
            return sep;
        }
    }
    b','
}

/// Reads the `#key,value` preamble and the header line.
fn read_preamble(path: &Path) -> Result<Head, IngestError> {
    let file = std::fs::File::open(path).map_err(|e| IngestError::io(path, e))?;
    let mut reader = std::io::BufReader::new(file);
    let mut map = BTreeMap::new();
    let mut lines = 0;
    let mut header = None;
    let mut buf = Vec::new();
    loop {
        buf.clear();
        let n = (&mut reader)
            .take(MAX_PREAMBLE_LINE as u64 + 1)
            .read_until(b'\n', &mut buf)
            .map_err(|e| IngestError::io(path, e))?;
        if lines == 0 && buf.starts_with(b"\xef\xbb\xbf") {
            buf.drain(..3); // UTF-8 byte-order mark, as some exporters write
        }
        if n == 0 {
            break;
        }
        if buf.first() != Some(&b'#') {
            if n <= MAX_PREAMBLE_LINE {
                let text = String::from_utf8_lossy(&buf);
                header = Some(text.trim_end_matches(['\n', '\r']).to_string());
            }
            break;
        }
        if n > MAX_PREAMBLE_LINE {
            return Err(IngestError::invalid(
                path,
                format!("line {}: preamble line too long", lines + 1),
            ));
        }
        lines += 1;
        let line = std::str::from_utf8(&buf).map_err(|_| {
            IngestError::invalid(path, format!("line {lines}: preamble is not UTF-8 text"))
        })?;
        let line = line.trim_end_matches(['\n', '\r']);
        let body = line.trim_start_matches('#').trim_start();
        // `key,value`: the value is everything after the first separator
        // (`,`, or `;`/tab in exports that use those).
        if let Some((k, v)) = body.split_once([',', ';', '\t']) {
            let k = k.trim();
            if !k.is_empty() && map.insert(k.to_string(), v.trim().to_string()).is_some() {
                return Err(IngestError::invalid(
                    path,
                    format!("line {lines}: preamble key `{k}` appears twice"),
                ));
            }
        }
    }
    Ok(Head {
        meta: map,
        lines,
        header,
    })
}

/// Reads a DAQ CSV export with its channel map (`map`, or the default).
pub(crate) fn read(
    path: &Path,
    map: Option<&Path>,
    max_samples: Option<u64>,
) -> Result<RawLog, IngestError> {
    let (map_path, cmap) = read_map(path, map, MapKind::Csv)?;
    let Some(time_spec) = cmap.time.clone() else {
        return Err(IngestError::invalid(
            &map_path,
            "[columns] lacks the required entry `time`",
        ));
    };
    let Head {
        meta,
        lines: preamble,
        header,
    } = read_preamble(path)?;
    if meta.is_empty() {
        return Err(IngestError::invalid(
            path,
            "no rig metadata: the CSV has no `#key,value` preamble",
        ));
    }
    let rig = RigMeta::from_map(&meta).map_err(|e| IngestError::rig(path, e))?;
    let header = header.ok_or_else(|| {
        IngestError::invalid(
            path,
            "no data: the CSV has no header line after its preamble",
        )
    })?;
    let sep = detect_separator(&header);
    let names: Vec<String> = split_fields(&header, sep)
        .into_iter()
        .map(|f| f.trim().trim_matches('"').trim().to_string())
        .collect();
    check_unique_columns(path, &cmap, &names)?;
    // The columns read: time, the channels in map order, the set point.
    let mut specs: Vec<(&ColumnSpec, &str)> = vec![(&time_spec, "time")];
    specs.extend(cmap.channels.iter().map(|(q, s)| (s, q.name())));
    specs.extend(cmap.setpoint_hz.iter().map(|s| (s, "setpoint_hz")));
    let table = read_table(
        path,
        &map_path,
        (preamble, sep, max_samples),
        &names,
        &specs,
    )?;
    let mut columns = table.columns.into_iter();
    let time = columns.next().expect("the time column");
    let dt_s = median_interval(&time).unwrap_or(f64::NAN);
    check_rate(&map_path, &time_spec, dt_s)?;
    let t0 = time[0] + time_spec.shift_s;
    let mut channels = Vec::new();
    // Channels of one shift share their times (one column, not one each).
    let mut times: Vec<(f64, Column)> = Vec::new();
    for (q, spec) in &cmap.channels {
        let v = columns.next().expect("one column per channel");
        let t = match times
            .iter()
            .find(|(s, _)| s.to_bits() == spec.shift_s.to_bits())
        {
            Some((_, t)) => t.clone(),
            None => {
                let t: Column = time
                    .iter()
                    .map(|t| t + time_spec.shift_s + spec.shift_s - t0)
                    .collect();
                times.push((spec.shift_s, t.clone()));
                t
            }
        };
        channels.push(RawChannel {
            quantity: *q,
            source: spec.name.clone(),
            dt_s,
            t,
            v,
        });
    }
    check_drive_amplitude(&map_path, &cmap, &channels)?;
    let setpoints = match &cmap.setpoint_hz {
        Some(spec) => {
            let v = columns.next().expect("the set-point column");
            setpoints(path, spec, &time, &v, (time_spec.shift_s, t0))?
        }
        None => Vec::new(),
    };
    Ok(RawLog {
        format: LogFormat::Csv,
        rig,
        channels,
        origin: Some(0.0),
        setpoints,
        warnings: Vec::new(),
        declared_shifts: cmap.channels.iter().map(|(q, s)| (*q, s.shift_s)).collect(),
    })
}

/// Plausible sample rates of a rig log (Hz): a map's time scale that puts
/// the rate outside is a unit mistake (ms read as s, or the reverse).
pub(crate) const RATE_RANGE_HZ: (f64, f64) = (1.0, 1e6);
/// Plausible drive amplitudes (m): a position scale that puts the drive
/// outside is a unit mistake (`scale = 1000` for mm instead of 0.001).
pub(crate) const DRIVE_RANGE_M: (f64, f64) = (1e-6, 0.5);

/// Refuses a time scale that gives an implausible sample rate.
pub(crate) fn check_rate(map_path: &Path, time: &ColumnSpec, dt_s: f64) -> Result<(), IngestError> {
    let rate = 1.0 / dt_s;
    let (lo, hi) = RATE_RANGE_HZ;
    if !(rate >= lo && rate <= hi) {
        return Err(IngestError::invalid(
            map_path,
            format!(
                "column entry `time` (scale {:e}): the rows come at {rate:.4e} Hz, outside the plausible {lo:.0}-{hi:.0e} Hz of a rig log: is the time scale right (1 for s, 0.001 for ms)?",
                time.scale()
            ),
        ));
    }
    Ok(())
}

/// Refuses a drive scale that gives an implausible drive amplitude (half
/// the range of x0, the robust 1st-99th percentiles).
pub(crate) fn check_drive_amplitude(
    map_path: &Path,
    cmap: &ChannelMap,
    channels: &[RawChannel],
) -> Result<(), IngestError> {
    let Some(x0) = channels.iter().find(|c| c.quantity == Quantity::X0) else {
        return Ok(());
    };
    let mut v: Vec<f64> = x0.v.iter().copied().filter(|x| x.is_finite()).collect();
    if v.len() < 10 {
        return Ok(());
    }
    v.sort_by(f64::total_cmp);
    let q = |p: f64| v[((v.len() - 1) as f64 * p).round() as usize];
    let amplitude = (q(0.99) - q(0.01)) / 2.0;
    let (lo, hi) = DRIVE_RANGE_M;
    // A drive at rest (or nearly so: a short log) says nothing of the
    // scale; identification reports the missing drive.
    if amplitude > 0.0 && !(amplitude >= lo && amplitude <= hi) {
        let scale = cmap
            .channels
            .iter()
            .find(|(q, _)| *q == Quantity::X0)
            .map_or(1.0, |(_, s)| s.scale());
        return Err(IngestError::invalid(
            map_path,
            format!(
                "column entry `x0` (scale {scale:e}): the drive moves {amplitude:.4e} m, outside the plausible {lo:.0e}-{hi} m: is the scale right (0.001 for mm, 1e-6 for µm)?"
            ),
        ));
    }
    Ok(())
}

/// Largest channel map (bytes): a map names a few columns.
const MAX_MAP_BYTES: u64 = 1_000_000;

/// The channel map of `path` (a log of `kind`): `map`, or `NAME.map.toml`
/// beside it.
pub(crate) fn read_map(
    path: &Path,
    map: Option<&Path>,
    kind: MapKind,
) -> Result<(PathBuf, ChannelMap), IngestError> {
    let map_path = map.map_or_else(|| default_map_path(path), Path::to_path_buf);
    let map_text = match std::fs::metadata(&map_path) {
        // The checks logs get (FIFO, device, directory, size) before any read.
        Ok(_) => crate::limits::read_small_text(&map_path, "channel map", MAX_MAP_BYTES).map_err(
            |e| match e {
                crate::limits::SmallReadError::Io(e) => IngestError::io(&map_path, e),
                crate::limits::SmallReadError::Refused(m) => IngestError::invalid(&map_path, m),
            },
        )?,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound && map.is_none() => {
            return Err(IngestError::invalid(
                path,
                format!(
                    "no channel map: {} not found (give one with --map)",
                    map_path.display()
                ),
            ))
        }
        Err(e) => return Err(IngestError::io(&map_path, e)),
    };
    let cmap = parse_map_for(&map_path, &map_text, kind)?;
    Ok((map_path, cmap))
}

/// Refuses a header that names a mapped column more than once.
fn check_unique_columns(
    path: &Path,
    cmap: &ChannelMap,
    names: &[String],
) -> Result<(), IngestError> {
    let specs = cmap
        .time
        .iter()
        .chain(cmap.channels.iter().map(|(_, s)| s))
        .chain(cmap.setpoint_hz.iter());
    for spec in specs {
        let count = names.iter().filter(|n| **n == spec.name).count();
        if count > 1 {
            return Err(IngestError::invalid(
                path,
                format!(
                    "column {:?} appears {count} times in the header: which one is meant?",
                    spec.name
                ),
            ));
        }
    }
    Ok(())
}

/// Longest data line accepted (bytes): a DAQ row is well under a kilobyte;
/// a longer "line" is not a row of the table (a padded or binary file),
/// refused before more of it is read.
const MAX_DATA_LINE: usize = 1 << 20;

/// Memory the ingest of a CSV log takes per data row and mapped column
/// (bytes, all copies counted: the column, each channel's own time stamps,
/// the resampled grid and columns, the channel-delay estimate's smoothed
/// signals). Measured: a 7-column 1 kHz log of 3600 s (3.6 million rows)
/// peaked at 912 MB (36 bytes per value), of 7200 s at 1.84 GB; rounded
/// up (`docs/measurements.md`, issue 29).
pub const CSV_BYTES_PER_VALUE: u64 = 38;

/// The data rows of a CSV log (upper bound: every line after the header),
/// counted before any column is allocated; refuses a line longer than
/// [`MAX_DATA_LINE`] (naming it) without reading further.
fn count_rows(path: &Path, skip: usize) -> Result<usize, IngestError> {
    let file = std::fs::File::open(path).map_err(|e| IngestError::io(path, e))?;
    let mut reader = std::io::BufReader::with_capacity(1 << 20, file);
    let mut buf = Vec::new();
    let (mut line, mut rows) = (0usize, 0usize);
    loop {
        buf.clear();
        let n = (&mut reader)
            .take(MAX_DATA_LINE as u64 + 1)
            .read_until(b'\n', &mut buf)
            .map_err(|e| IngestError::io(path, e))?;
        if n == 0 {
            return Ok(rows);
        }
        line += 1;
        if n > MAX_DATA_LINE {
            return Err(IngestError::invalid(
                path,
                format!(
                    "line {line} is longer than {MAX_DATA_LINE} bytes: not a row of a table (a padded or binary file?)"
                ),
            ));
        }
        if line > skip + 1 {
            rows += 1;
        }
    }
}

/// Splits a line into its fields: `sep`-separated; a field that starts
/// with `"` runs to its closing quote (the separator may occur inside) and
/// is given without the quotes.
fn split_fields(line: &str, sep: u8) -> Vec<&str> {
    let mut out = Vec::new();
    split_into(line, sep, &mut out);
    out.into_iter().map(|(a, b)| &line[a..b]).collect()
}

/// [`split_fields`] as byte ranges of `line`, into a reused vector.
fn split_into(line: &str, sep: u8, out: &mut Vec<(usize, usize)>) {
    out.clear();
    let b = line.as_bytes();
    let mut i = 0;
    loop {
        if b.get(i) == Some(&b'"') {
            // Quoted: to the closing quote ("" is a quote inside), then to
            // the separator.
            let start = i + 1;
            let mut j = start;
            let end = loop {
                match b.get(j) {
                    None => break j,
                    Some(&b'"') if b.get(j + 1) == Some(&b'"') => j += 2,
                    Some(&b'"') => break j,
                    Some(_) => j += 1,
                }
            };
            out.push((start, end.min(b.len())));
            match b[end.min(b.len())..].iter().position(|&c| c == sep) {
                Some(k) => i = end + k + 1,
                None => return,
            }
        } else {
            match b[i..].iter().position(|&c| c == sep) {
                Some(k) => {
                    out.push((i, i + k));
                    i += k + 1;
                }
                None => {
                    out.push((i, b.len()));
                    return;
                }
            }
        }
    }
}

/// The mapped columns of a CSV log's data table.
struct Table {
    /// One per spec, in the order asked, in SI (scaled; empty cells NaN).
    columns: Vec<Vec<f64>>,
}

/// Streams the data table (after `preamble` lines and the header) into
/// the columns of `specs` (spec, the quantity it is mapped to). Checks
/// first that every mapped column is in the header and that the rows fit
/// the memory budget; then refuses a line that is not UTF-8 or has more
/// fields than the header, a cell that is not a finite number (with its
/// line and column), and a time column with an empty cell, going backwards
/// or of one row.
fn read_table(
    path: &Path,
    map_path: &Path,
    (preamble, sep, max_samples): (usize, u8, Option<u64>),
    names: &[String],
    specs: &[(&ColumnSpec, &str)],
) -> Result<Table, IngestError> {
    let mut index = Vec::with_capacity(specs.len());
    for (spec, what) in specs {
        let k = names.iter().position(|n| *n == spec.name).ok_or_else(|| {
            IngestError::invalid(
                path,
                format!(
                    "column {:?} (mapped to {what} by {}) is not in the CSV header ({})",
                    spec.name,
                    map_path.display(),
                    names
                        .iter()
                        .map(|n| format!("{n:?}"))
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            )
        })?;
        index.push(k);
    }
    let rows = count_rows(path, preamble)?;
    if rows == 0 {
        return Err(IngestError::invalid(
            path,
            "no data: the CSV has no data rows",
        ));
    }
    if let Some(max) = max_samples.filter(|m| rows as u64 > *m) {
        return Err(IngestError::content(
            path,
            ContentError::OverFitBudget {
                subject: format!("{rows} data rows"),
                samples: rows as u64,
                max,
                count: SampleCount::Grid,
            },
        ));
    }
    let per_row = CSV_BYTES_PER_VALUE * specs.len() as u64;
    if !crate::limits::fits(rows as u64, per_row) {
        let max_rows = crate::limits::MEMORY_BUDGET_BYTES / per_row;
        return Err(IngestError::invalid(
            path,
            format!(
                "{rows} data rows x {} mapped columns would take about {} in memory ({CSV_BYTES_PER_VALUE} bytes per value read), over {}: at most {max_rows} rows with these columns; split it into shorter logs",
                specs.len(),
                crate::limits::human(rows as f64 * per_row as f64),
                crate::limits::budget_text()
            ),
        ));
    }
    let mut columns: Vec<Vec<f64>> = specs.iter().map(|_| Vec::with_capacity(rows)).collect();
    // The first bad cell of each column (line, data row, cell, finite?):
    // reported in column order, time first, as a column-wise reader would.
    let mut bad: Vec<Option<(usize, usize, String, bool)>> = vec![None; specs.len()];
    let file = std::fs::File::open(path).map_err(|e| IngestError::io(path, e))?;
    let mut reader = std::io::BufReader::with_capacity(1 << 20, file);
    let mut buf = Vec::new();
    let mut fields = Vec::new();
    let mut line = 0usize;
    let unreadable =
        |msg: String| IngestError::invalid(path, format!("unreadable CSV table: {msg}"));
    while columns[0].len() < rows {
        buf.clear();
        let n = (&mut reader)
            .take(MAX_DATA_LINE as u64 + 1)
            .read_until(b'\n', &mut buf)
            .map_err(|e| IngestError::io(path, e))?;
        if n == 0 {
            break;
        }
        line += 1;
        if line <= preamble + 1 {
            continue;
        }
        if n > MAX_DATA_LINE {
            return Err(unreadable(format!(
                "line {line} is longer than {MAX_DATA_LINE} bytes"
            )));
        }
        let text = std::str::from_utf8(&buf)
            .map_err(|_| unreadable(format!("line {line} is not UTF-8 text")))?;
        let text = text.strip_suffix('\n').unwrap_or(text);
        let text = text.strip_suffix('\r').unwrap_or(text);
        split_into(text, sep, &mut fields);
        if fields.len() > names.len() {
            return Err(unreadable(format!(
                "line {line} has more fields than the header ({} > {})",
                fields.len(),
                names.len()
            )));
        }
        let row = columns[0].len();
        for (c, ((spec, _), &k)) in specs.iter().zip(&index).enumerate() {
            // A row with fewer fields than the header: the rest are empty.
            let cell = fields.get(k).map_or("", |&(a, b)| text[a..b].trim());
            let value = if cell.is_empty() {
                f64::NAN
            } else {
                let parsed = match cell.parse::<f64>() {
                    // A `;`- or tab-separated export may write decimal commas.
                    Err(_) if sep != b',' && cell.contains(',') => cell.replace(',', ".").parse(),
                    other => other,
                };
                match parsed {
                    Ok(v) if v.is_finite() => v * spec.scale(),
                    other => {
                        if bad[c].is_none() {
                            bad[c] = Some((line, row + 1, cell.to_string(), other.is_ok()));
                        }
                        f64::NAN
                    }
                }
            };
            columns[c].push(value);
        }
    }
    for (c, b) in bad.iter().enumerate() {
        if let Some((line, row, cell, parsed)) = b {
            let what = if *parsed {
                "is not a finite number"
            } else {
                "is not a number"
            };
            return Err(IngestError::invalid(
                path,
                format!(
                    "line {line} (data row {row}), column {:?}: {cell:?} {what}",
                    specs[c].0.name
                ),
            ));
        }
        if c == 0 {
            check_time(path, specs[0].0, &columns[0], preamble + 2)?;
        }
    }
    Ok(Table { columns })
}

/// The time column: no empty cell, strictly increasing, two rows at
/// least (`first_data_line`: the file line of data row 0).
fn check_time(
    path: &Path,
    spec: &ColumnSpec,
    time: &[f64],
    first_data_line: usize,
) -> Result<(), IngestError> {
    if let Some(i) = time.iter().position(|t| t.is_nan()) {
        return Err(IngestError::invalid(
            path,
            format!(
                "line {}, column {:?}: empty time cell",
                first_data_line + i,
                spec.name
            ),
        ));
    }
    if let Some(i) = time.windows(2).position(|w| w[1] <= w[0]) {
        return Err(IngestError::invalid(
            path,
            format!(
                "non-monotonic time: line {}, column {:?}: {} s does not follow {} s",
                first_data_line + i + 1,
                spec.name,
                time[i + 1],
                time[i]
            ),
        ));
    }
    if time.len() < 2 {
        return Err(IngestError::invalid(
            path,
            "too little data: the CSV has a single data row",
        ));
    }
    Ok(())
}

/// The drive set points of a set-point column: one per change of its
/// value, at the row's time shifted as the channels are (`time_shift_s`,
/// the column's own shift, relative to the origin `t0`). Refuses negative
/// frequencies.
pub(crate) fn setpoints(
    path: &Path,
    spec: &ColumnSpec,
    time: &[f64],
    v: &[f64],
    (time_shift_s, t0): (f64, f64),
) -> Result<Vec<Setpoint>, IngestError> {
    let mut out = Vec::new();
    let mut last = f64::NAN;
    for (t, &f) in time.iter().zip(v) {
        if f.is_finite() && f != last {
            if f < 0.0 {
                return Err(IngestError::invalid(
                    path,
                    format!("column {:?}: negative setpoint frequency {f}", spec.name),
                ));
            }
            out.push(Setpoint {
                t_s: t + time_shift_s + spec.shift_s - t0,
                frequency_hz: f,
                amplitude_m: None,
            });
            last = f;
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    const MAP: &str = r#"
[columns]
time = { name = "t [s]" }
x0   = { name = "drive [mm]", scale = 0.001, shift_s = -0.004 }
x1   = { name = "x1 [mm]", scale = 0.001 }
x2   = { name = "x2 [mm]", scale = 0.001 }
v2   = { name = "v2 [mm/s]", scale = 0.001 }
"#;

    #[test]
    fn splits_quoted_fields_and_short_rows() {
        assert_eq!(split_fields("1,2.5,x", b','), ["1", "2.5", "x"]);
        assert_eq!(
            split_fields("\"0,5\";2;\"a\"\"b\"", b';'),
            ["0,5", "2", "a\"\"b"]
        );
        assert_eq!(split_fields("1,,", b','), ["1", "", ""]);
        assert_eq!(split_fields("", b','), [""]);
        assert_eq!(split_fields("\"open", b','), ["open"]);
    }

    #[test]
    fn parses_a_map() {
        let m = parse_map(Path::new("m.toml"), MAP).expect("valid map");
        assert_eq!(m.time.as_ref().map(|t| t.name.as_str()), Some("t [s]"));
        let x0 = m
            .channels
            .iter()
            .find(|(q, _)| *q == Quantity::X0)
            .expect("x0");
        assert_eq!(x0.1.scale(), 0.001);
        assert_eq!(x0.1.shift_s, -0.004);
        assert!(m.setpoint_hz.is_none());
    }

    #[test]
    fn refuses_bad_maps() {
        let p = Path::new("bad.map.toml");
        for (text, needle) in [
            ("[columns\ntime = 1", "not a valid channel map"),
            (
                &MAP.replace("x2   = { name = \"x2 [mm]\", scale = 0.001 }\n", ""),
                "`x2`",
            ),
            (&MAP.replace("time =", "tiem ="), "tiem"),
            (
                &MAP.replace("scale = 0.001 }\nx2", "scale = 0.0 }\nx2"),
                "scale",
            ),
            (&MAP.replace("name = \"t [s]\"", "nmae = \"t [s]\""), "nmae"),
        ] {
            let e = parse_map(p, text).unwrap_err().to_string();
            assert!(e.contains("bad.map.toml") && e.contains(needle), "{e}");
        }
    }

    fn write_csv(dir: &Path, body: &str) -> PathBuf {
        let csv = dir.join("log.csv");
        std::fs::write(&csv, body).expect("write csv");
        std::fs::write(dir.join("log.map.toml"), MAP).expect("write map");
        csv
    }

    const PREAMBLE: &str = "#format,stickslip-rig-log/1\n#test,characteristic\n#m1_kg,8\n#m2_kg,2\n#k1_n_per_m,600\n#k2_n_per_m,700\n#d_n_s_per_m,0.1\n#drive_amplitude_m,0.002\n#normal_force_n,3\n#notes,a, b #c\n";

    #[test]
    fn reads_preamble_shift_and_dropouts() {
        let dir = tempfile::tempdir().expect("tempdir");
        let mut body = String::from(PREAMBLE);
        body.push_str("t [s],drive [mm],x1 [mm],x2 [mm],v2 [mm/s]\n");
        for i in 0..50 {
            let x1 = if i == 7 {
                String::new()
            } else {
                format!("{}", i)
            };
            body.push_str(&format!("{:.3},{i},{x1},2,3\n", i as f64 * 0.001));
        }
        let csv = write_csv(dir.path(), &body);
        let raw = read(&csv, None, None).expect("reads");
        assert_eq!(raw.rig.notes.as_deref(), Some("a, b #c"));
        let x0 = raw
            .channels
            .iter()
            .find(|c| c.quantity == Quantity::X0)
            .expect("x0");
        let x1 = raw
            .channels
            .iter()
            .find(|c| c.quantity == Quantity::X1)
            .expect("x1");
        // x0 was taken 4 ms before its row: 4 ms earlier than x1 of the same row.
        assert!((x1.t[10] - x0.t[10] - 0.004).abs() < 1e-12);
        assert!(x1.v[7].is_nan());
        assert!((x1.v[8] - 0.008).abs() < 1e-15);
        assert!((raw.channels[0].dt_s - 0.001).abs() < 1e-12);
    }

    #[test]
    fn accepts_bom_and_crlf() {
        let dir = tempfile::tempdir().expect("tempdir");
        let mut body = String::from("\u{feff}");
        body.push_str(PREAMBLE);
        body.push_str("t [s],drive [mm],x1 [mm],x2 [mm],v2 [mm/s]\n");
        for i in 0..20 {
            body.push_str(&format!("{:.3},1,2,3,4\n", i as f64 * 0.001));
        }
        let csv = write_csv(dir.path(), &body.replace('\n', "\r\n"));
        let raw = read(&csv, None, None).expect("reads");
        assert_eq!(raw.rig.m1_kg, 8.0);
        let v2 = raw
            .channels
            .iter()
            .find(|c| c.quantity == Quantity::V2)
            .expect("v2");
        assert!(v2.v.iter().all(|v| (v - 0.004).abs() < 1e-15));
    }

    #[test]
    fn setpoint_column_becomes_setpoints() {
        let dir = tempfile::tempdir().expect("tempdir");
        let mut body = String::from(PREAMBLE);
        body.push_str("t [s],drive [mm],x1 [mm],x2 [mm],v2 [mm/s],f_set\n");
        for i in 0..30 {
            let f = if i < 3 {
                String::new()
            } else if i < 12 {
                "1.5".into()
            } else {
                "2".into()
            };
            body.push_str(&format!("{:.3},1,2,3,4,{f}\n", i as f64 * 0.01));
        }
        let csv = write_csv(dir.path(), &body);
        let map = format!("{MAP}setpoint_hz = {{ name = \"f_set\" }}\n");
        std::fs::write(dir.path().join("log.map.toml"), map).expect("map");
        let raw = read(&csv, None, None).expect("reads");
        let sp: Vec<(f64, f64)> = raw
            .setpoints
            .iter()
            .map(|s| (s.t_s, s.frequency_hz))
            .collect();
        assert_eq!(sp.len(), 2, "{sp:?}");
        assert!((sp[0].0 - 0.03).abs() < 1e-12 && sp[0].1 == 1.5);
        assert!((sp[1].0 - 0.12).abs() < 1e-12 && sp[1].1 == 2.0);
    }

    #[test]
    fn accepts_semicolons_with_decimal_commas() {
        let dir = tempfile::tempdir().expect("tempdir");
        let mut body = PREAMBLE
            .replace(',', ";")
            .replace("#notes;a; b #c", "#notes;a, b #c");
        body.push_str("t [s];drive [mm];x1 [mm];x2 [mm];v2 [mm/s]\n");
        for i in 0..20 {
            body.push_str(&format!(
                "{};1,5;2;3;4\n",
                format!("{:.3}", i as f64 * 0.001).replace('.', ",")
            ));
        }
        let csv = write_csv(dir.path(), &body);
        let raw = read(&csv, None, None).expect("reads");
        assert_eq!(raw.rig.notes.as_deref(), Some("a, b #c"));
        let x0 = raw
            .channels
            .iter()
            .find(|c| c.quantity == Quantity::X0)
            .expect("x0");
        assert!(x0.v.iter().all(|v| (v - 0.0015).abs() < 1e-15));
        assert!((raw.channels[0].dt_s - 0.001).abs() < 1e-12);
    }

    #[test]
    fn refuses_ambiguous_and_ragged_tables() {
        let dir = tempfile::tempdir().expect("tempdir");
        let head = format!("{PREAMBLE}t [s],drive [mm],x1 [mm],x1 [mm],x2 [mm],v2 [mm/s]\n");
        let csv = write_csv(dir.path(), &format!("{head}0,1,2,2,3,4\n"));
        let e = read(&csv, None, None).unwrap_err().to_string();
        assert!(e.contains("\"x1 [mm]\" appears 2 times"), "{e}");
        let head = format!("{PREAMBLE}t [s],drive [mm],x1 [mm],x2 [mm],v2 [mm/s]\n");
        let csv = write_csv(dir.path(), &format!("{head}0,1,2,3,4\n0.001,1,2,3,4,5,6\n"));
        let e = read(&csv, None, None).unwrap_err().to_string();
        assert!(e.contains("line 13"), "{e}");
    }

    #[test]
    fn points_at_a_line_that_is_not_utf8() {
        let dir = tempfile::tempdir().expect("tempdir");
        let mut body = PREAMBLE.as_bytes().to_vec();
        body.extend_from_slice(
            b"t [s],drive [mm],x1 [mm],x2 [mm],v2 [mm/s]\n0,1,2,3,4\n0.001,1,\xff\xfe,3,4\n",
        );
        let csv = dir.path().join("log.csv");
        std::fs::write(&csv, body).expect("write");
        std::fs::write(dir.path().join("log.map.toml"), MAP).expect("map");
        let e = read(&csv, None, None).unwrap_err().to_string();
        assert!(e.contains("log.csv") && e.contains("line 13"), "{e}");
    }

    #[test]
    fn names_line_and_column_of_garbage() {
        let dir = tempfile::tempdir().expect("tempdir");
        let mut body = String::from(PREAMBLE);
        body.push_str("t [s],drive [mm],x1 [mm],x2 [mm],v2 [mm/s]\n");
        for i in 0..20 {
            let x2 = if i == 12 {
                "1.2.7e".into()
            } else {
                format!("{i}")
            };
            body.push_str(&format!("{:.3},1,2,{x2},3\n", i as f64 * 0.001));
        }
        let csv = write_csv(dir.path(), &body);
        let e = read(&csv, None, None).unwrap_err().to_string();
        // 10 preamble lines, a header, then data row 13 is line 24.
        assert!(
            e.contains("line 24") && e.contains("x2 [mm]") && e.contains("1.2.7e"),
            "{e}"
        );
    }

    #[test]
    fn refuses_nan_tokens_backwards_time_and_missing_map() {
        let dir = tempfile::tempdir().expect("tempdir");
        let head = format!("{PREAMBLE}t [s],drive [mm],x1 [mm],x2 [mm],v2 [mm/s]\n");
        let csv = write_csv(dir.path(), &format!("{head}0,1,2,3,4\n0.001,1,NaN,3,4\n"));
        let e = read(&csv, None, None).unwrap_err().to_string();
        assert!(e.contains("NaN") && e.contains("x1 [mm]"), "{e}");
        let csv = write_csv(
            dir.path(),
            &format!("{head}0,1,2,3,4\n0.002,1,2,3,4\n0.001,1,2,3,4\n"),
        );
        let e = read(&csv, None, None).unwrap_err().to_string();
        assert!(e.contains("non-monotonic time"), "{e}");
        std::fs::remove_file(dir.path().join("log.map.toml")).expect("rm");
        let e = read(&csv, None, None).unwrap_err().to_string();
        assert!(e.contains("log.csv") && e.contains("log.map.toml"), "{e}");
    }
}
