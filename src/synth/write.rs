//! Writers of a [`SynthLog`]: MCAP (`mcap` crate; JSON DAQ buffers),
//! DAQ CSV + TOML channel map (mm, mm/s), Parquet (polars, rig metadata as
//! key-value metadata), and the `truth.json` beside them. Every file is
//! written atomically: a failure leaves no partial file.

use super::{LogFormat, SynthLog, LOG_START_NS};
use crate::error::{Error, Result};
use crate::ingest::Quantity;
use crate::io::AtomicFile;
use mcap::records::{MessageHeader, Metadata};
use mcap::{Compression, WriteOptions};
use serde_json::{json, Value};
use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};

/// The files [`write()`] produced.
#[derive(Debug, Clone, PartialEq)]
pub struct Written {
    /// The log.
    pub log: PathBuf,
    /// The CSV's channel map.
    pub map: Option<PathBuf>,
    /// The truth file (shared by every log of the directory).
    pub truth: PathBuf,
    /// Bytes of the log.
    pub bytes: u64,
}

/// JSON schema of a DAQ buffer message.
const BUFFER_SCHEMA: &str = r#"{"type":"object","properties":{"t0_ns":{"type":"integer"},"dt_ns":{"type":"integer"},"value":{"type":"array","items":{"type":["number","null"]}}},"required":["t0_ns","dt_ns","value"]}"#;
/// JSON schema of a setpoint message.
const SETPOINT_SCHEMA: &str = r#"{"type":"object","properties":{"t_ns":{"type":"integer"},"frequency_hz":{"type":"number"},"amplitude_m":{"type":"number"}},"required":["t_ns","frequency_hz"]}"#;

/// Writes `log` to `path` in its configured format, and merges its truth
/// into `truth.json` in the same directory (`{"set", "files": {name: entry}}`,
/// as the public data set). A CSV's map goes to `NAME.map.toml`.
pub fn write(log: &SynthLog, path: &Path) -> Result<Written> {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .ok_or_else(|| Error::Input {
            path: path.to_path_buf(),
            msg: "output path names no file".into(),
        })?;
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let truth_path = dir.join("truth.json");
    // Read the existing truth first: a bad one stops us before any output.
    read_truth(&truth_path)?;
    let mut entry = log.truth.clone();
    let mut map = None;
    match log.config.format {
        LogFormat::Mcap | LogFormat::McapLz4 | LogFormat::McapPlain => write_mcap(log, path)?,
        LogFormat::Csv => {
            let stem = path
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_default();
            let map_path = dir.join(format!("{stem}.map.toml"));
            write_csv(log, path, &map_path)?;
            if let Some(o) = entry.as_object_mut() {
                o.insert(
                    "map_file".into(),
                    json!(map_path.file_name().map(|n| n.to_string_lossy())),
                );
                o.insert("columns".into(), json!(csv_columns(log)));
            }
            map = Some(map_path);
        }
        LogFormat::Parquet => write_parquet(log, path)?,
    }
    // Several runs may write into one folder at once: read, merge and
    // write truth.json under the folder's lock, held until the renames
    // (inside the CLI's transaction) or to the end of this function.
    let _lock = crate::io::txn::lock_beside(&truth_path)?;
    let mut truth = read_truth(&truth_path)?;
    truth["files"]
        .as_object_mut()
        .expect("checked by read_truth")
        .insert(name, entry);
    let text = serde_json::to_string_pretty(&truth).expect("JSON values serialise");
    crate::io::write_atomic(&truth_path, text.as_bytes())?;
    let bytes = crate::io::txn::written_len(path).unwrap_or(0);
    Ok(Written {
        log: path.to_path_buf(),
        map,
        truth: truth_path,
        bytes,
    })
}

/// The truth file of a folder (`{"set", "files": {...}}`), or a new one.
fn read_truth(truth_path: &Path) -> Result<Value> {
    match std::fs::read(truth_path) {
        Ok(bytes) => serde_json::from_slice::<Value>(&bytes)
            .ok()
            .filter(|v| v.get("files").is_some_and(Value::is_object))
            .ok_or_else(|| Error::Input {
                path: truth_path.to_path_buf(),
                msg: "exists but is not a truth file ({\"files\": {...}}); move it away".into(),
            }),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            Ok(json!({"set": "synthetic", "generator": "stickslip synth", "files": {}}))
        }
        Err(source) => Err(Error::Io {
            path: truth_path.to_path_buf(),
            source,
        }),
    }
}

fn mcap_err(path: &Path, e: mcap::McapError) -> Error {
    Error::Input {
        path: path.to_path_buf(),
        msg: format!("cannot write MCAP: {e}"),
    }
}

/// A message of an MCAP log: buffer `.1` of channel `.0`, or setpoint
/// message `.0`.
#[derive(Clone, Copy)]
enum Message {
    Buffer(usize, usize),
    Setpoint(usize),
}

fn write_mcap(log: &SynthLog, path: &Path) -> Result<()> {
    let (compression, summary) = match log.config.format {
        LogFormat::McapLz4 => (Some(Compression::Lz4), true),
        LogFormat::McapPlain => (None, false),
        _ => (Some(Compression::Zstd), true),
    };
    let mut out = AtomicFile::create(path)?;
    {
        let mut w = WriteOptions::new()
            .compression(compression)
            .emit_summary_records(summary)
            .emit_summary_offsets(summary)
            .create(out.writer())
            .map_err(|e| mcap_err(path, e))?;
        let buf_schema = w
            .add_schema("daq_buffer", "jsonschema", BUFFER_SCHEMA.as_bytes())
            .map_err(|e| mcap_err(path, e))?;
        // (log time, channel id, message): what to write, in time order;
        // each payload is made only when it is written.
        let mut msgs: Vec<(u64, u16, Message)> = Vec::new();
        for (ci, c) in log.channels.iter().enumerate() {
            let q = c.quantity;
            let md: BTreeMap<String, String> = [
                ("sample_rate_hz".to_string(), c.sensor.rate_hz.to_string()),
                ("unit".to_string(), q.unit().to_string()),
            ]
            .into_iter()
            .collect();
            let id = w
                .add_channel(buf_schema, q.topic(), "json", &md)
                .map_err(|e| mcap_err(path, e))?;
            for (bi, b) in c.buffers.iter().enumerate() {
                msgs.push((b.t0_ns, id, Message::Buffer(ci, bi)));
            }
        }
        if !log.setpoints.is_empty() {
            let sp_schema = w
                .add_schema("setpoint", "jsonschema", SETPOINT_SCHEMA.as_bytes())
                .map_err(|e| mcap_err(path, e))?;
            let id = w
                .add_channel(sp_schema, "/drive/setpoint", "json", &BTreeMap::new())
                .map_err(|e| mcap_err(path, e))?;
            for (si, s) in log.setpoints.iter().enumerate() {
                msgs.push((s.t_ns, id, Message::Setpoint(si)));
            }
        }
        msgs.sort_by_key(|m| (m.0, m.1));
        for (i, (t, id, m)) in msgs.iter().enumerate() {
            let payload = match *m {
                Message::Buffer(ci, bi) => {
                    let (c, b) = (&log.channels[ci], &log.channels[ci].buffers[bi]);
                    json!({"t0_ns": b.t0_ns, "dt_ns": c.dt_ns, "value": b.values})
                }
                Message::Setpoint(si) => {
                    let s = &log.setpoints[si];
                    json!({"t_ns": s.t_ns, "frequency_hz": s.frequency_hz,
                           "amplitude_m": s.amplitude_m})
                }
            };
            let header = MessageHeader {
                channel_id: *id,
                sequence: i as u32,
                log_time: *t,
                publish_time: *t,
            };
            w.write_to_known_channel(&header, payload.to_string().as_bytes())
                .map_err(|e| mcap_err(path, e))?;
        }
        w.write_metadata(&Metadata {
            name: "rig".into(),
            metadata: log.rig_record.clone(),
        })
        .map_err(|e| mcap_err(path, e))?;
        w.finish().map_err(|e| mcap_err(path, e))?;
    }
    out.commit()
}

/// CSV column name and the factor from SI to the written unit.
fn csv_column(q: Quantity) -> (&'static str, f64) {
    match q {
        Quantity::X0 => ("drive [mm]", 1e3),
        Quantity::X1 => ("x1 [mm]", 1e3),
        Quantity::X2 => ("x2 [mm]", 1e3),
        Quantity::V2 => ("v2 [mm/s]", 1e3),
        Quantity::A2 => ("a2 [m/s^2]", 1.0),
        Quantity::NormalForce => ("Fn [N]", 1.0),
    }
}

/// The commanded frequency at each table row (the last setpoint message at
/// or before the row), for sweeps; `None` without setpoints.
fn setpoint_column(log: &SynthLog) -> Option<Vec<Option<f64>>> {
    let first = log.setpoints.first()?;
    let dt = log.channels[0].dt_ns;
    let mut k = 0;
    let mut f = first.frequency_hz;
    Some(
        (0..log.table_rows)
            .map(|i| {
                let t = LOG_START_NS + i as u64 * dt;
                while k < log.setpoints.len() && log.setpoints[k].t_ns <= t {
                    f = log.setpoints[k].frequency_hz;
                    k += 1;
                }
                Some(f)
            })
            .collect(),
    )
}

/// CSV column of the commanded frequency.
const CSV_SETPOINT: &str = "setpoint [Hz]";

fn csv_columns(log: &SynthLog) -> BTreeMap<&'static str, &'static str> {
    let mut m: BTreeMap<&str, &str> = log
        .channels
        .iter()
        .map(|c| (c.quantity.name(), csv_column(c.quantity).0))
        .collect();
    m.insert("time", "t [s]");
    if !log.setpoints.is_empty() {
        m.insert("setpoint_hz", CSV_SETPOINT);
    }
    m
}

fn write_csv(log: &SynthLog, path: &Path, map_path: &Path) -> Result<()> {
    let io = |source| Error::Io {
        path: path.to_path_buf(),
        source,
    };
    let mut map_text = String::from(
        "# channel map written by stickslip synth; shift_s: the value in a row was taken at row time + shift_s\n[columns]\ntime = { name = \"t [s]\" }\n",
    );
    for c in &log.channels {
        let (name, factor) = csv_column(c.quantity);
        let mut entry = format!("{} = {{ name = \"{name}\"", c.quantity.name());
        if factor != 1.0 {
            entry += &format!(", scale = {}", 1.0 / factor);
        }
        if c.shift_s != 0.0 {
            entry += &format!(", shift_s = {}", c.shift_s);
        }
        map_text += &entry;
        map_text += " }\n";
    }
    let setpoint = setpoint_column(log);
    if setpoint.is_some() {
        map_text += &format!("setpoint_hz = {{ name = \"{CSV_SETPOINT}\" }}\n");
    }
    let mut out = AtomicFile::create(path)?;
    {
        let w = out.writer();
        for (k, v) in &log.rig_record {
            // One header line each; keep values on one line.
            let v = v.replace(['\n', '\r'], " ");
            writeln!(w, "#{k},{v}").map_err(io)?;
        }
        let names: Vec<&str> = std::iter::once("t [s]")
            .chain(log.channels.iter().map(|c| csv_column(c.quantity).0))
            .chain(setpoint.iter().map(|_| CSV_SETPOINT))
            .collect();
        writeln!(w, "{}", names.join(",")).map_err(io)?;
        let dt = log.channels[0].dt_ns;
        // Quantised channels are written as the DAQ shows them: one digit
        // more than the quantisation step needs (exact to a few ulps);
        // others with the shortest representation that reads back exactly.
        let decimals: Vec<Option<usize>> = log
            .channels
            .iter()
            .map(|c| {
                let q = c.sensor.quant * csv_column(c.quantity).1;
                (q > 0.0).then(|| (-q.log10() - 1e-9).ceil().max(0.0) as usize + 1)
            })
            .collect();
        let mut line = String::new();
        for i in 0..log.table_rows {
            line.clear();
            line += &((i as u64 * dt) as f64 * 1e-9).to_string();
            for (ci, c) in log.channels.iter().enumerate() {
                line.push(',');
                if let Some(v) = c.buffers[0].values[i] {
                    let x = v * csv_column(c.quantity).1;
                    match decimals[ci] {
                        Some(d) => line += &format!("{x:.d$}"),
                        None => line += &x.to_string(),
                    }
                }
            }
            if let Some(Some(f)) = setpoint.as_ref().map(|s| s[i]) {
                line.push(',');
                line += &f.to_string();
            }
            line.push('\n');
            w.write_all(line.as_bytes()).map_err(io)?;
        }
    }
    let mut map_out = AtomicFile::create(map_path)?;
    map_out
        .writer()
        .write_all(map_text.as_bytes())
        .map_err(|source| Error::Io {
            path: map_path.to_path_buf(),
            source,
        })?;
    out.commit()?;
    map_out.commit()
}

fn write_parquet(log: &SynthLog, path: &Path) -> Result<()> {
    let dt = log.channels[0].dt_ns;
    let t: Vec<f64> = (0..log.table_rows)
        .map(|i| (i as u64 * dt) as f64 * 1e-9)
        .collect();
    let setpoint = setpoint_column(log);
    let mut cols: Vec<(&str, &[Option<f64>])> = Vec::new();
    for c in &log.channels {
        cols.push((c.quantity.name(), &c.buffers[0].values));
    }
    if let Some(s) = &setpoint {
        cols.push(("setpoint_hz", s));
    }
    debug_assert!(log
        .channels
        .iter()
        .all(|c| c.buffers.len() == 1 && c.buffers[0].t0_ns == LOG_START_NS));
    crate::io::write_table(path, &t, &cols, &log.rig_record)
}
