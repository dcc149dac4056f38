//! MCAP rig logs: one linear, streaming pass over the file's records (chunks
//! decompressed one at a time; zstd, lz4 or none), so files without a summary
//! section read the same as indexed ones and memory stays bounded by the
//! largest chunk plus the decoded samples.

use super::rig::RigMeta;
use super::run::Setpoint;
use super::{unit_factor, IngestError, LogFormat, Quantity, RawChannel, RawLog};
use mcap::records::Record;
use mcap::sans_io::linear_reader::{LinearReadEvent, LinearReader, LinearReaderOptions};
use serde::Deserialize;
use std::collections::{BTreeMap, HashMap};
use std::io::Read;
use std::path::Path;

/// Largest record or (de)compressed chunk accepted. A DAQ writes chunks of a
/// few MiB at most; a larger length field is corruption and must not make us
/// allocate it.
const RECORD_LIMIT: usize = 64 << 20;

/// The setpoint topic.
const SETPOINT_TOPIC: &str = "/drive/setpoint";

/// A DAQ buffer message.
#[derive(Deserialize)]
struct BufferMsg {
    t0_ns: u64,
    dt_ns: u64,
    value: Vec<Option<f64>>,
}

/// A setpoint message.
#[derive(Deserialize)]
struct SetpointMsg {
    t_ns: u64,
    frequency_hz: f64,
    amplitude_m: Option<f64>,
}

/// What a channel id carries.
#[derive(Debug, Clone)]
enum Role {
    Sensor(Quantity),
    Setpoint,
    Ignored,
}

#[derive(Debug, Clone)]
struct ChannelInfo {
    topic: String,
    role: Role,
    /// Factor from the channel's unit to SI.
    scale: f64,
    rate_hz: Option<f64>,
}

/// Samples of one sensor channel, buffer by buffer.
#[derive(Debug, Default)]
struct Acc {
    topic: String,
    /// (t0_ns, dt_ns, index of its first value in `values`).
    buffers: Vec<(u64, u64, usize)>,
    values: Vec<f64>,
    rate_hz: Option<f64>,
}

fn mcap_error(path: &Path, e: mcap::McapError) -> IngestError {
    use mcap::McapError as E;
    let msg = match e {
        E::BadMagic => "not an MCAP file (bad magic bytes)".to_string(),
        E::UnexpectedEof => {
            "truncated MCAP: the file ends in the middle of a record (no footer)".to_string()
        }
        E::UnexpectedEoc => "corrupt MCAP: a chunk ends in the middle of a record".to_string(),
        E::BadChunkCrc { .. } | E::BadDataCrc { .. } | E::BadSummaryCrc { .. } => {
            format!("corrupt MCAP: {e}")
        }
        E::RecordTooLarge { .. } | E::ChunkTooLarge(_) | E::ChunkBufferTooLarge(_) => {
            format!("corrupt MCAP (implausible record length): {e}")
        }
        other => format!("corrupt MCAP: {other}"),
    };
    IngestError::invalid(path, msg)
}

/// Reads an MCAP rig log.
pub(crate) fn read(path: &Path) -> Result<RawLog, IngestError> {
    let mut file = std::fs::File::open(path).map_err(|e| IngestError::io(path, e))?;
    let options = LinearReaderOptions::default()
        .with_record_length_limit(RECORD_LIMIT)
        .with_prevalidate_chunk_crcs(true);
    let mut reader = LinearReader::new_with_options(options);

    let mut channels: HashMap<u16, ChannelInfo> = HashMap::new();
    let mut rig: Option<BTreeMap<String, String>> = None;
    let mut accs: BTreeMap<Quantity, Acc> = BTreeMap::new();
    let mut setpoints: Vec<(u64, f64, Option<f64>)> = Vec::new();
    let mut warnings: Vec<String> = Vec::new();
    let mut n_messages: u64 = 0;

    while let Some(event) = reader.next_event() {
        match event.map_err(|e| mcap_error(path, e))? {
            LinearReadEvent::ReadRequest(need) => {
                let buf = reader.insert(need);
                let n = loop {
                    match file.read(buf) {
                        Ok(n) => break n,
                        Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
                        Err(e) => return Err(IngestError::io(path, e)),
                    }
                };
                reader.notify_read(n);
            }
            LinearReadEvent::Record { opcode, data } => {
                let record = mcap::parse_record(opcode, data).map_err(|e| mcap_error(path, e))?;
                match record {
                    Record::Channel(ch) => {
                        let info = channel_info(path, &ch, &mut warnings)?;
                        if let Some(old) = channels.get(&ch.id) {
                            if old.topic != info.topic {
                                return Err(IngestError::invalid(
                                    path,
                                    format!(
                                        "corrupt MCAP: channel id {} is both {} and {}",
                                        ch.id, old.topic, info.topic
                                    ),
                                ));
                            }
                            continue; // the summary section repeats channels
                        }
                        if let Role::Sensor(q) = info.role {
                            if let Some(other) = channels
                                .values()
                                .find(|c| matches!(c.role, Role::Sensor(p) if p == q))
                            {
                                return Err(IngestError::invalid(
                                    path,
                                    format!(
                                        "two channels carry {} ({} and {})",
                                        q.name(),
                                        other.topic,
                                        info.topic
                                    ),
                                ));
                            }
                            accs.insert(
                                q,
                                Acc {
                                    topic: info.topic.clone(),
                                    rate_hz: info.rate_hz,
                                    ..Acc::default()
                                },
                            );
                        }
                        channels.insert(ch.id, info);
                    }
                    Record::Metadata(m) if m.name == "rig" => {
                        if rig.is_some() {
                            return Err(IngestError::invalid(
                                path,
                                "more than one `rig` metadata record",
                            ));
                        }
                        rig = Some(m.metadata);
                    }
                    Record::Message { header, data } => {
                        n_messages += 1;
                        let Some(info) = channels.get(&header.channel_id) else {
                            return Err(IngestError::invalid(
                                path,
                                format!(
                                    "corrupt MCAP: message at log time {} ns refers to unknown channel id {}",
                                    header.log_time, header.channel_id
                                ),
                            ));
                        };
                        let where_ = || {
                            format!(
                                "message on {} at log time {} ns",
                                info.topic, header.log_time
                            )
                        };
                        match info.role {
                            Role::Ignored => {}
                            Role::Setpoint => {
                                let m: SetpointMsg = decode(path, &data, &where_)?;
                                if !(m.frequency_hz.is_finite() && m.frequency_hz >= 0.0) {
                                    return Err(IngestError::invalid(
                                        path,
                                        format!(
                                            "{}: frequency_hz {} is not a valid frequency",
                                            where_(),
                                            m.frequency_hz
                                        ),
                                    ));
                                }
                                if let Some(a) = m.amplitude_m {
                                    if !a.is_finite() || a < 0.0 {
                                        return Err(IngestError::invalid(
                                            path,
                                            format!(
                                                "{}: amplitude_m {a} is not a valid amplitude",
                                                where_()
                                            ),
                                        ));
                                    }
                                }
                                setpoints.push((m.t_ns, m.frequency_hz, m.amplitude_m));
                            }
                            Role::Sensor(q) => {
                                let m: BufferMsg = decode(path, &data, &where_)?;
                                let scale = info.scale;
                                let acc = accs.entry(q).or_default();
                                push_buffer(path, acc, m, scale, &where_)?;
                            }
                        }
                    }
                    _ => {}
                }
            }
        }
    }

    let Some(rig_map) = rig else {
        return Err(IngestError::invalid(
            path,
            "no `rig` metadata record: the log does not describe its rig",
        ));
    };
    let rig = RigMeta::from_map(&rig_map).map_err(|e| IngestError::rig(path, e))?;
    if n_messages == 0 {
        return Err(IngestError::invalid(
            path,
            "no data: the log holds zero messages",
        ));
    }
    let origin = accs
        .values()
        .filter_map(|a| a.buffers.first().map(|b| b.0))
        .min()
        .ok_or_else(|| IngestError::invalid(path, "no data: the log holds no sensor samples"))?;

    let mut raw_channels = Vec::new();
    for (q, acc) in accs {
        if acc.values.is_empty() {
            if q.required() {
                return Err(IngestError::invalid(
                    path,
                    format!(
                        "no data: channel {} ({}) has no messages",
                        acc.topic,
                        q.name()
                    ),
                ));
            }
            warnings.push(format!(
                "channel {} ({}) has no messages",
                acc.topic,
                q.name()
            ));
            continue;
        }
        raw_channels.push(expand(q, acc, origin, &mut warnings));
    }
    let setpoints = setpoints
        .into_iter()
        .map(|(t_ns, frequency_hz, amplitude_m)| Setpoint {
            t_s: ns_diff_s(t_ns, origin),
            frequency_hz,
            amplitude_m,
        })
        .collect();
    Ok(RawLog {
        format: LogFormat::Mcap,
        rig,
        channels: raw_channels,
        origin: None,
        setpoints,
        warnings,
    })
}

/// Classifies a channel record and reads its metadata.
fn channel_info(
    path: &Path,
    ch: &mcap::records::Channel,
    warnings: &mut Vec<String>,
) -> Result<ChannelInfo, IngestError> {
    let topic = ch.topic.clone();
    let role = if topic == SETPOINT_TOPIC {
        Role::Setpoint
    } else if let Some(q) = Quantity::from_topic(&topic) {
        Role::Sensor(q)
    } else {
        warnings.push(format!("ignored unknown topic {topic}"));
        Role::Ignored
    };
    if !matches!(role, Role::Ignored) && ch.message_encoding != "json" {
        return Err(IngestError::invalid(
            path,
            format!(
                "channel {topic}: message encoding {:?} is not supported (expected json)",
                ch.message_encoding
            ),
        ));
    }
    let mut scale = 1.0;
    if let Role::Sensor(q) = role {
        match ch.metadata.get("unit") {
            Some(unit) => {
                scale = unit_factor(q, unit).ok_or_else(|| {
                    IngestError::invalid(
                        path,
                        format!(
                            "channel {topic}: unit {unit:?} is not a unit of {} (expected {})",
                            q.name(),
                            q.unit()
                        ),
                    )
                })?;
            }
            None => warnings.push(format!(
                "channel {topic} states no unit; {} assumed",
                q.unit()
            )),
        }
    }
    let rate_hz = match ch.metadata.get("sample_rate_hz") {
        Some(_) if !matches!(role, Role::Sensor(_)) => None,
        Some(r) => match r.trim().parse::<f64>() {
            Ok(v) if v.is_finite() && v > 0.0 => Some(v),
            _ => {
                return Err(IngestError::invalid(
                    path,
                    format!("channel {topic}: sample_rate_hz {r:?} is not a positive number"),
                ))
            }
        },
        None => None,
    };
    Ok(ChannelInfo {
        topic,
        role,
        scale,
        rate_hz,
    })
}

/// Decodes a JSON payload, naming the message on failure.
fn decode<T: for<'de> Deserialize<'de>>(
    path: &Path,
    data: &[u8],
    where_: &dyn Fn() -> String,
) -> Result<T, IngestError> {
    serde_json::from_slice(data).map_err(|e| {
        let non_finite = [b"NaN".as_slice(), b"Infinity".as_slice()]
            .iter()
            .any(|tok| data.windows(tok.len()).any(|w| w == *tok));
        let what = if non_finite {
            "payload holds a NaN/Infinity token (not JSON; dropouts must be null)".to_string()
        } else {
            format!("payload is not a valid message ({e})")
        };
        IngestError::invalid(path, format!("{}: {what}", where_()))
    })
}

/// Appends one DAQ buffer, checking that time moves forward.
fn push_buffer(
    path: &Path,
    acc: &mut Acc,
    m: BufferMsg,
    scale: f64,
    where_: &dyn Fn() -> String,
) -> Result<(), IngestError> {
    if m.dt_ns == 0 {
        return Err(IngestError::invalid(
            path,
            format!("{}: dt_ns is 0", where_()),
        ));
    }
    if m.value.is_empty() {
        return Ok(());
    }
    let n = m.value.len() as u128;
    let end = m.t0_ns as u128 + (n - 1) * m.dt_ns as u128;
    if end > u64::MAX as u128 {
        return Err(IngestError::invalid(
            path,
            format!("{}: buffer runs past the end of the clock", where_()),
        ));
    }
    if let Some(&(t0, dt, start)) = acc.buffers.last() {
        let prev_n = (acc.values.len() - start) as u128;
        let prev_last = t0 as u128 + (prev_n - 1) * dt as u128;
        if (m.t0_ns as u128) <= prev_last {
            return Err(IngestError::invalid(
                path,
                format!(
                    "non-monotonic time on channel {}: buffer t0_ns {} is {:.6} s before the previous sample ({})",
                    acc.topic,
                    m.t0_ns,
                    (prev_last - m.t0_ns as u128) as f64 * 1e-9,
                    where_()
                ),
            ));
        }
    }
    acc.buffers.push((m.t0_ns, m.dt_ns, acc.values.len()));
    acc.values.extend(
        m.value
            .into_iter()
            .map(|v| v.map_or(f64::NAN, |x| x * scale)),
    );
    Ok(())
}

/// Seconds from `origin` to `t` (both ns), exact in integers first.
fn ns_diff_s(t: u64, origin: u64) -> f64 {
    (t as i128 - origin as i128) as f64 * 1e-9
}

/// Expands a channel's buffers into per-sample times from `origin`.
fn expand(q: Quantity, acc: Acc, origin: u64, warnings: &mut Vec<String>) -> RawChannel {
    let mut t = Vec::with_capacity(acc.values.len());
    let mut dts: Vec<u64> = Vec::with_capacity(acc.buffers.len());
    for (k, &(t0, dt, start)) in acc.buffers.iter().enumerate() {
        let end = acc
            .buffers
            .get(k + 1)
            .map_or(acc.values.len(), |next| next.2);
        for i in 0..(end - start) {
            let ns = t0 as i128 - origin as i128 + i as i128 * dt as i128;
            t.push(ns as f64 * 1e-9);
        }
        dts.push(dt);
    }
    dts.sort_unstable();
    let dt_ns = dts[dts.len() / 2];
    let dt_s = dt_ns as f64 * 1e-9;
    if dts.first() != dts.last() {
        warnings.push(format!(
            "channel {}: buffers use different sample intervals ({}..{} ns); {} ns taken as nominal",
            acc.topic,
            dts.first().copied().unwrap_or(0),
            dts.last().copied().unwrap_or(0),
            dt_ns
        ));
    }
    if let Some(r) = acc.rate_hz {
        if ((1.0 / dt_s) / r - 1.0).abs() > 0.01 {
            warnings.push(format!(
                "channel {}: sample_rate_hz {} disagrees with dt_ns {} ({} Hz); dt_ns used",
                acc.topic,
                r,
                dt_ns,
                1.0 / dt_s
            ));
        }
    }
    RawChannel {
        quantity: q,
        source: acc.topic,
        dt_s,
        t,
        v: acc.values,
    }
}
