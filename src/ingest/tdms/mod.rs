//! NI TDMS logs (`.tdms`, little-endian, version 4712/4713): the `rig`
//! metadata as file-level properties, channels named `Group/Channel` in a
//! channel map (the CSV map's keys), each channel either a waveform
//! (`wf_start_time`, `wf_increment`, optional `wf_start_offset` and
//! `unit_string`) or a value channel on the `time` channel of its group.
//!
//! This module owns the TDMS reader itself: a small hand-written parser of
//! the segment structure (lead-in, metadata, raw data index, contiguous and
//! interleaved raw data, incremental object lists), not a crate. The two
//! TDMS crates were evaluated (docs/measurements.md, issue 33): `tdms-rs`
//! 2.0 allocates `vec![0; len]` for every u32 length it reads (4 GB from one
//! corrupt string length; 1.7 GB from a DAQmx raw data index), reads
//! interleaved segments as contiguous and big-endian segments as
//! little-endian without a word; `tdms` 0.3 (unmaintained since 2023)
//! allocates the same way, adds offsets without overflow checks (a panic
//! in debug builds) and reads raw data as bytes only. Neither refuses DAQmx
//! raw data by name.
//!
//! Safety on bad bytes: the file is read whole (its size checked against
//! the memory budget first) and every length, count and offset in it is
//! checked against the bytes that remain before it is used, with checked
//! arithmetic; only the mapped channels' values are decoded, at most one
//! value per byte of raw data. Big-endian segments and DAQmx raw data are
//! refused by name.
//!
//! The segment parser is `parser.rs`; this file holds the parsed file's
//! objects and assembles the mapped channels from them.

mod parser;

use super::csv::{self, ChannelMap, ColumnSpec, MapKind};
use super::rig::RigMeta;
use super::run::median_interval;
use super::{
    unit_factor, ContentError, IngestError, LogFormat, Quantity, RawChannel, RawLog, SampleCount,
};
use crate::warning::Warning;
use parser::{decode, first_timestamp, parse, ticks_to_s, T_TIMESTAMP};
use std::collections::BTreeMap;
use std::path::Path;

/// Largest TDMS log read: it is held whole, and the decoded channels take
/// up to 8 times its raw bytes (one f64 per byte of `u8` data).
pub(crate) const MAX_TDMS_BYTES: u64 = crate::limits::MEMORY_BUDGET_BYTES / 10;

/// A property value (what this reader needs of it).
#[derive(Debug, Clone)]
enum Prop {
    Str(String),
    Num(f64),
    /// A TDMS timestamp: 2^-64 s since 1904-01-01 UTC.
    Time(i128),
    /// A value of another type (complex numbers).
    Other,
}

/// The raw data index of an object in a segment.
#[derive(Debug, Clone, Copy)]
struct Index {
    dtype: u32,
    count: u64,
    /// Bytes of the object's data in one chunk.
    bytes: u64,
}

/// Where one segment holds values of a wanted channel: `count` values,
/// `stride` bytes apart, from `start`, repeated in `chunks` chunks
/// `chunk_step` bytes apart.
#[derive(Debug, Clone, Copy)]
struct Piece {
    dtype: u32,
    start: usize,
    count: usize,
    stride: usize,
    chunks: usize,
    chunk_step: usize,
}

/// One object of the file (root, group or channel).
#[derive(Debug, Default)]
struct Object {
    /// `Group/Channel`, `Group` or `` for the root.
    name: String,
    is_channel: bool,
    /// Whether the map names it (its properties and data are kept).
    wanted: bool,
    props: BTreeMap<String, Prop>,
    last_index: Option<Index>,
    pieces: Vec<Piece>,
    values: u64,
}

/// The parsed file: objects by first appearance.
struct File {
    objects: Vec<Object>,
    warnings: Vec<Warning>,
}

/// A mapped channel's timing.
enum Timing {
    /// Waveform: start (2^-64 s since 1904, offset included in `offset_s`),
    /// sample interval (s).
    Waveform {
        start: i128,
        offset_s: f64,
        dt_s: f64,
    },
    /// On the group's `time` channel.
    Table,
}

/// A mapped channel (or the set point, `None`) with its map entry, its
/// object in the file and its timing.
type Entry<'a> = (Option<Quantity>, &'a ColumnSpec, &'a Object, Timing);

/// The `time` channel of the table channels, read and checked.
struct TimeTable<'a> {
    /// Its map entry.
    spec: &'a ColumnSpec,
    /// Its object in the file.
    obj: &'a Object,
    /// Its values (s, the map's scale applied; the shift not).
    time: Vec<f64>,
    /// Its median sample interval (s).
    dt_s: f64,
    /// The absolute time of its first row when it holds TDMS timestamps
    /// (2^-64 s since 1904).
    first_stamp: Option<i128>,
}

/// Reads a TDMS log with its channel map (`map`, or the default).
/// `max_samples`: the caller's budget ([`super::IngestOptions::max_samples`]):
/// a position channel with more values is refused from the segments'
/// raw data indexes, before any value is decoded.
pub(crate) fn read(
    path: &Path,
    map: Option<&Path>,
    max_samples: Option<u64>,
) -> Result<RawLog, IngestError> {
    let (map_path, cmap) = csv::read_map(path, map, MapKind::Tdms)?;
    let buf = std::fs::read(path).map_err(|e| IngestError::io(path, e))?;
    let mut wanted: Vec<&str> = cmap.channels.iter().map(|(_, s)| s.name.as_str()).collect();
    wanted.extend(cmap.time.iter().map(|s| s.name.as_str()));
    wanted.extend(cmap.setpoint_hz.iter().map(|s| s.name.as_str()));
    let file = parse(path, &buf, &wanted)?;
    let bad = |m: String| IngestError::invalid(path, m);
    let rig = rig_meta(path, &file.objects[0])?;
    let entries = mapped_entries(path, &map_path, &cmap, &file.objects)?;
    if let Some(max) = max_samples {
        // The common grid runs at the fastest position channel's rate: it
        // has at least as many samples as each of them.
        let position =
            |q: &Option<Quantity>| matches!(q, Some(Quantity::X0 | Quantity::X1 | Quantity::X2));
        if let Some((_, _, obj, _)) = entries
            .iter()
            .filter(|e| position(&e.0))
            .max_by_key(|e| e.2.values)
            .filter(|e| e.2.values > max)
        {
            return Err(IngestError::content(
                path,
                ContentError::OverFitBudget {
                    subject: format!("channel {:?} holds {} values", obj.name, obj.values),
                    samples: obj.values,
                    max,
                    count: SampleCount::Grid,
                },
            ));
        }
    }
    let any_table = entries.iter().any(|e| matches!(e.3, Timing::Table));
    // The `time` channel, when a table channel needs it.
    let table = if any_table {
        Some(time_table(
            path,
            &map_path,
            &cmap,
            &file.objects,
            &buf,
            &entries,
        )?)
    } else {
        None
    };
    let any_wave = entries
        .iter()
        .any(|e| matches!(e.3, Timing::Waveform { .. }));
    if any_wave {
        if let Some(t) = table.as_ref().filter(|t| t.first_stamp.is_none()) {
            return Err(bad(format!(
                "the map mixes waveform channels with table channels on the time channel {:?}, whose values are not TDMS timestamps: their clocks cannot be lined up",
                t.obj.name
            )));
        }
    }
    // The clock origin: the earliest waveform start, else the table's.
    let reference: i128 = entries
        .iter()
        .filter_map(|e| match e.3 {
            Timing::Waveform { start, .. } => Some(start),
            Timing::Table => None,
        })
        .chain(table.as_ref().and_then(|t| t.first_stamp))
        .min()
        .unwrap_or(0);
    let mut channels = Vec::new();
    let mut setpoints = Vec::new();
    for (q, spec, obj, timing) in &entries {
        let raw = decode(&buf, obj, None).map_err(|e| bad(e.to_string()))?;
        let factor = unit_scale(path, &map_path, *q, spec, obj)?;
        let (t, dt_s) = sample_times(path, timing, obj, raw.len(), table.as_ref(), reference)?;
        match q {
            Some(q) => {
                let v: Vec<f64> = raw.iter().map(|x| x * factor).collect();
                channels.push(RawChannel {
                    quantity: *q,
                    source: obj.name.clone(),
                    dt_s,
                    t: t.iter().map(|t| t + spec.shift_s).collect(),
                    v,
                });
            }
            None => {
                let v: Vec<f64> = raw.iter().map(|x| x * factor).collect();
                setpoints = csv::setpoints(path, spec, &t, &v, (0.0, 0.0))?;
            }
        }
    }
    check_finite_times(path, &channels)?;
    csv::check_drive_amplitude(&map_path, &cmap, &channels).map_err(|e| in_log(path, e))?;
    // Tables start at their first row (as CSV logs); waveforms at the
    // earliest sample of any channel.
    let origin = match &table {
        Some(t) if !any_wave => Some(
            t.time[0] + t.first_stamp.map_or(0.0, |f| ticks_to_s(f - reference)) + t.spec.shift_s,
        ),
        _ => None,
    };
    Ok(RawLog {
        format: LogFormat::Tdms,
        rig,
        channels,
        origin,
        setpoints,
        warnings: file.warnings,
        declared_shifts: declared(&cmap),
    })
}

/// The rig metadata: the file-level (root object's) string and number
/// properties.
fn rig_meta(path: &Path, root: &Object) -> Result<RigMeta, IngestError> {
    let rig_map: BTreeMap<String, String> = root
        .props
        .iter()
        .filter_map(|(k, v)| match v {
            Prop::Str(s) => Some((k.clone(), s.clone())),
            Prop::Num(x) => Some((k.clone(), format!("{x}"))),
            _ => None,
        })
        .collect();
    if rig_map.is_empty() {
        return Err(IngestError::invalid(
            path,
            "no rig metadata: the TDMS file has no file-level properties",
        ));
    }
    RigMeta::from_map(&rig_map).map_err(|e| IngestError::rig(path, e))
}

/// The channel object the map entry `spec` (mapped to `what`) names; an
/// error listing the file's channels when it is not there.
fn find_channel<'a>(
    path: &Path,
    map_path: &Path,
    objects: &'a [Object],
    spec: &ColumnSpec,
    what: &str,
) -> Result<&'a Object, IngestError> {
    objects
        .iter()
        .find(|o| o.is_channel && o.name == spec.name)
        .ok_or_else(|| {
            let names: Vec<String> = objects
                .iter()
                .filter(|o| o.is_channel)
                .take(20)
                .map(|o| format!("{:?}", o.name))
                .collect();
            IngestError::invalid(
                path,
                format!(
                    "channel {:?} (mapped to {what} by {}) is not in the TDMS file (channels: {})",
                    spec.name,
                    map_path.display(),
                    if names.is_empty() {
                        "none".to_string()
                    } else {
                        names.join(", ")
                    }
                ),
            )
        })
}

/// A channel's timing from its waveform properties (`wf_increment`,
/// `wf_start_time`, `wf_start_offset`), checked; [`Timing::Table`] when it
/// has no `wf_increment`.
fn timing(path: &Path, obj: &Object) -> Result<Timing, IngestError> {
    let bad = |m: String| IngestError::invalid(path, m);
    let Some(inc) = obj.props.get("wf_increment") else {
        return Ok(Timing::Table);
    };
    let Prop::Num(dt_s) = *inc else {
        return Err(bad(format!(
            "channel {:?}: wf_increment is not a number",
            obj.name
        )));
    };
    let (lo, hi) = csv::RATE_RANGE_HZ;
    let rate = 1.0 / dt_s;
    if !(rate >= lo && rate <= hi) {
        return Err(bad(format!(
            "channel {:?}: wf_increment {dt_s:e} s gives {rate:.4e} Hz, outside the plausible {lo:.0}-{hi:.0e} Hz of a rig log",
            obj.name
        )));
    }
    let start = match obj.props.get("wf_start_time") {
        Some(Prop::Time(t)) => *t,
        Some(_) => {
            return Err(bad(format!(
                "channel {:?}: wf_start_time is not a TDMS timestamp",
                obj.name
            )))
        }
        None => {
            return Err(bad(format!(
                "channel {:?} has wf_increment but no wf_start_time: a waveform needs both",
                obj.name
            )))
        }
    };
    let offset_s = match obj.props.get("wf_start_offset") {
        None => 0.0,
        Some(Prop::Num(x)) if x.is_finite() => *x,
        Some(_) => {
            return Err(bad(format!(
                "channel {:?}: wf_start_offset is not a finite number",
                obj.name
            )))
        }
    };
    Ok(Timing::Waveform {
        start,
        offset_s,
        dt_s,
    })
}

/// The mapped channels, then the set point, each with its object and
/// timing (in the map's order; the first missing channel or bad timing is
/// the error).
fn mapped_entries<'a>(
    path: &Path,
    map_path: &Path,
    cmap: &'a ChannelMap,
    objects: &'a [Object],
) -> Result<Vec<Entry<'a>>, IngestError> {
    let mut entries: Vec<Entry<'a>> = Vec::new();
    for (q, spec) in &cmap.channels {
        let obj = find_channel(path, map_path, objects, spec, q.name())?;
        entries.push((Some(*q), spec, obj, timing(path, obj)?));
    }
    if let Some(spec) = &cmap.setpoint_hz {
        let obj = find_channel(path, map_path, objects, spec, "setpoint_hz")?;
        entries.push((None, spec, obj, timing(path, obj)?));
    }
    Ok(entries)
}

/// The map's `time` channel for the table channels among `entries`: it
/// must exist and share their group; its values must be at least two,
/// increasing, and at a plausible rate.
fn time_table<'a>(
    path: &Path,
    map_path: &Path,
    cmap: &'a ChannelMap,
    objects: &'a [Object],
    buf: &[u8],
    entries: &[Entry<'a>],
) -> Result<TimeTable<'a>, IngestError> {
    let bad = |m: String| IngestError::invalid(path, m);
    let Some(tspec) = &cmap.time else {
        let names: Vec<&str> = entries
            .iter()
            .filter(|e| matches!(e.3, Timing::Table))
            .map(|e| e.1.name.as_str())
            .collect();
        // Named by the log: its channels lack the waveform properties
        // (a map that is fine for an intact file meets a damaged one).
        return Err(bad(format!(
            "{} carries no waveform properties (wf_increment/wf_start_time), and the channel map {} has no [columns] entry `time` for a table channel",
            names.join(", "),
            map_path.display()
        )));
    };
    let tobj = find_channel(path, map_path, objects, tspec, "time")?;
    let group = tobj.name.split('/').next().unwrap_or("");
    for e in entries.iter().filter(|e| matches!(e.3, Timing::Table)) {
        if e.2.name.split('/').next().unwrap_or("") != group {
            return Err(bad(format!(
                "channel {:?} is not a waveform and not in the group {group:?} of the time channel {:?}",
                e.2.name, tobj.name
            )));
        }
    }
    let is_stamp = tobj.pieces.iter().any(|p| p.dtype == T_TIMESTAMP);
    let raw = decode(buf, tobj, None).map_err(|e| bad(e.to_string()))?;
    let time: Vec<f64> = raw.iter().map(|t| t * tspec.scale()).collect();
    if time.len() < 2 {
        return Err(bad(format!(
            "too little data: the time channel {:?} has {} values",
            tobj.name,
            time.len()
        )));
    }
    if let Some(i) = time
        .windows(2)
        .position(|w| w[1].partial_cmp(&w[0]) != Some(std::cmp::Ordering::Greater))
    {
        return Err(bad(format!(
            "non-monotonic time: time channel {:?}, value {}: {} s does not follow {} s",
            tobj.name,
            i + 1,
            time[i + 1],
            time[i]
        )));
    }
    let dt_s = median_interval(&time).unwrap_or(f64::NAN);
    csv::check_rate(map_path, tspec, dt_s).map_err(|e| in_log(path, e))?;
    // The absolute time of the first row when the channel holds
    // timestamps (to line it up with waveforms).
    let first_stamp = if is_stamp {
        first_timestamp(buf, tobj)
    } else {
        None
    };
    Ok(TimeTable {
        spec: tspec,
        obj: tobj,
        time,
        dt_s,
        first_stamp,
    })
}

/// The factor to SI of a channel's values: the map's `scale` if given,
/// else the one its `unit_string` names (for a quantity), else 1.
fn unit_scale(
    path: &Path,
    map_path: &Path,
    q: Option<Quantity>,
    spec: &ColumnSpec,
    obj: &Object,
) -> Result<f64, IngestError> {
    Ok(match (spec.scale_given, obj.props.get("unit_string"), q) {
        (Some(s), _, _) => s,
        (None, Some(Prop::Str(u)), Some(q)) if !u.trim().is_empty() => {
            unit_factor(q, u).ok_or_else(|| {
                IngestError::invalid(
                    path,
                    format!(
                        "channel {:?} has unit_string {u:?}, not a unit of {} ({}): give its factor to SI as `scale` in {}",
                        obj.name,
                        q.name(),
                        q.unit(),
                        map_path.display()
                    ),
                )
            })?
        }
        _ => 1.0,
    })
}

/// The sample times (s from the clock origin `reference`, the channel's
/// own shift not applied) of a channel with `len` values, and its sample
/// interval: from its waveform timing, or the time table's (whose length
/// it must have).
fn sample_times(
    path: &Path,
    timing: &Timing,
    obj: &Object,
    len: usize,
    table: Option<&TimeTable>,
    reference: i128,
) -> Result<(Vec<f64>, f64), IngestError> {
    let bad = |m: String| IngestError::invalid(path, m);
    Ok(match timing {
        Timing::Waveform {
            start,
            offset_s,
            dt_s,
        } => {
            let base = ticks_to_s(start - reference) + offset_s;
            let t: Vec<f64> = (0..len).map(|i| base + i as f64 * dt_s).collect();
            (t, *dt_s)
        }
        Timing::Table => {
            let Some(table) = table else {
                return Err(bad("internal: table channel without time".into()));
            };
            if len != table.time.len() {
                return Err(bad(format!(
                    "channel {:?} has {} values, its time channel {:?} {}",
                    obj.name,
                    len,
                    table.obj.name,
                    table.time.len()
                )));
            }
            let first = table.first_stamp;
            let base = first.map_or(0.0, |f| ticks_to_s(f - reference)) + table.spec.shift_s;
            (table.time.iter().map(|t| t + base).collect(), table.dt_s)
        }
    })
}

/// Refuses non-finite sample times (a wf_increment or scale that
/// overflows), naming the channel.
pub(crate) fn check_finite_times(path: &Path, channels: &[RawChannel]) -> Result<(), IngestError> {
    for c in channels {
        if let Some(i) = c.t.iter().position(|t| !t.is_finite()) {
            return Err(IngestError::invalid(
                path,
                format!("channel {}: sample {i} has no finite time", c.source),
            ));
        }
    }
    Ok(())
}

/// The declared shifts of a map's channel entries.
pub(crate) fn declared(cmap: &ChannelMap) -> Vec<(Quantity, f64)> {
    cmap.channels.iter().map(|(q, s)| (*q, s.shift_s)).collect()
}

/// A map check that failed on this file's data (a damaged file can put
/// its rate or drive amplitude out of range): named by the log first.
fn in_log(path: &Path, e: IngestError) -> IngestError {
    IngestError::invalid(path, e.to_string())
}
