//! MCAP rig logs: one linear, streaming pass over the file's records, so
//! files without a summary section read the same as indexed ones. A reader
//! thread reads the file and decompresses its chunks one at a time (zstd,
//! lz4 or none; mcap's sans-io reader, CRCs checked) and hands the records
//! over in batches of about [`BATCH_BYTES`] through a bounded queue; this
//! thread decodes them in file order (DAQ buffers by the fast path of
//! `buffer_json`, serde_json otherwise). Results and errors are those of a
//! single pass, and memory stays bounded by the largest chunk, a few
//! batches and the decoded samples. Before that pass, the message counts of
//! the summary section's Statistics record (when the footer points to one)
//! size each channel's sample vectors after its first buffer, so they do not
//! regrow; they are only a hint, bounded by the file's length.

use super::rig::RigMeta;
use super::run::Setpoint;
use super::{
    buffer_json, unit_factor, ContentError, IngestError, LogFormat, Quantity, RawChannel, RawLog,
    SampleCount,
};
use crate::warning::Warning;
use mcap::records::Record;
use mcap::sans_io::linear_reader::{LinearReadEvent, LinearReader, LinearReaderOptions};
use serde::Deserialize;
use std::collections::{BTreeMap, HashMap};
use std::io::Read;
use std::path::Path;
use std::sync::mpsc::{Receiver, SyncSender};

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
        E::RecordTooLarge { opcode, len } if opcode == 0x05 || opcode == 0x06 => oversize(
            path,
            len,
            if opcode == 0x05 { "message" } else { "chunk" },
            &e,
        ),
        E::ChunkTooLarge(len) => oversize(path, len, "chunk", &e),
        E::RecordTooLarge { .. } | E::ChunkBufferTooLarge(_) => {
            format!("corrupt MCAP (implausible record length): {e}")
        }
        other => format!("corrupt MCAP: {other}"),
    };
    IngestError::invalid(path, msg)
}

/// The message for a record or chunk of `len` bytes over [`RECORD_LIMIT`]:
/// where the file can hold it (a chunk compressed at most 64-fold), it is
/// an oversize DAQ buffer, named as such with the numbers; else the length
/// field is corrupt.
fn oversize(path: &Path, len: u64, what: &str, e: &mcap::McapError) -> String {
    let file_len = std::fs::metadata(path).map_or(0, |m| m.len());
    let plausible = if what == "chunk" {
        file_len.saturating_mul(64)
    } else {
        file_len
    };
    if len <= plausible {
        format!(
            "a {what} of {len} bytes, over the {} MiB a record may have: an oversize DAQ buffer (about {:.1e} samples as JSON; a DAQ writes buffers of a few MiB): split the channel into buffers of at most about 3 million samples",
            RECORD_LIMIT >> 20,
            len as f64 / 20.0
        )
    } else {
        format!("corrupt MCAP (implausible record length): {e}")
    }
}

/// Bytes of records the reader thread gathers before handing them over.
const BATCH_BYTES: usize = 256 << 10;

/// Batches in flight between the reader thread and the decoder (queued,
/// besides the one being filled and the one being decoded): with
/// [`BATCH_BYTES`] this bounds the read-ahead to about a MiB.
const BATCHES_QUEUED: usize = 2;

/// Records read ahead by the reader thread, in file order: their bytes back
/// to back, then how the reading ended if it did.
#[derive(Default)]
struct Batch {
    data: Vec<u8>,
    /// (opcode, end of its bytes in `data`), in file order.
    records: Vec<(u8, usize)>,
    /// `Some` in the last batch: the end of the file or the error that
    /// stopped the reader (after the records of this batch).
    end: Option<Result<(), ReadError>>,
}

/// Why the reader thread stopped early.
enum ReadError {
    Mcap(mcap::McapError),
    Io(std::io::Error),
}

/// The reader thread: one linear pass over the file's records (chunks
/// decompressed and CRC-checked by mcap's sans-io reader), sent in batches.
/// Returns when the file ends, on the first error, or when the decoder
/// hangs up.
fn read_records(mut file: std::fs::File, tx: SyncSender<Batch>, pool: Receiver<Batch>) {
    let options = LinearReaderOptions::default()
        .with_record_length_limit(RECORD_LIMIT)
        .with_prevalidate_chunk_crcs(true);
    let mut reader = LinearReader::new_with_options(options);
    let mut batch = Batch::default();
    let end = loop {
        match reader.next_event() {
            None => break Ok(()),
            Some(Err(e)) => break Err(ReadError::Mcap(e)),
            Some(Ok(LinearReadEvent::ReadRequest(need))) => {
                let buf = reader.insert(need);
                let n = loop {
                    match file.read(buf) {
                        Ok(n) => break Ok(n),
                        Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
                        Err(e) => break Err(e),
                    }
                };
                match n {
                    Ok(n) => reader.notify_read(n),
                    Err(e) => break Err(ReadError::Io(e)),
                }
            }
            Some(Ok(LinearReadEvent::Record { opcode, data })) => {
                batch.data.extend_from_slice(data);
                batch.records.push((opcode, batch.data.len()));
                if batch.data.len() >= BATCH_BYTES {
                    let next = pool.try_recv().unwrap_or_default();
                    if tx.send(std::mem::replace(&mut batch, next)).is_err() {
                        return; // the decoder stopped (an error of its own)
                    }
                }
            }
        }
    };
    batch.end = Some(end);
    let _ = tx.send(batch);
}

/// Reads an MCAP rig log. A reader thread reads and decompresses the
/// records while this thread decodes them, in file order; the result (or
/// the first error) is the same as a single pass's.
pub(crate) fn read(path: &Path, max_samples: Option<u64>) -> Result<RawLog, IngestError> {
    let file = std::fs::File::open(path).map_err(|e| IngestError::io(path, e))?;
    let expected = expected_counts(path).unwrap_or_default();
    let mut log = Collector {
        path,
        channels: HashMap::new(),
        rig: None,
        accs: BTreeMap::new(),
        setpoints: Vec::new(),
        warnings: Vec::new(),
        n_messages: 0,
        expected,
        max_samples,
        over: None,
    };
    std::thread::scope(|s| {
        let (tx, rx) = std::sync::mpsc::sync_channel(BATCHES_QUEUED);
        let (pool_tx, pool_rx) = std::sync::mpsc::channel();
        std::thread::Builder::new()
            .name("mcap-reader".into())
            .spawn_scoped(s, move || read_records(file, tx, pool_rx))
            .map_err(|e| IngestError::io(path, e))?;
        // Dropping `rx` on an early return stops the reader thread.
        for mut batch in rx.iter() {
            let mut start = 0;
            for &(opcode, end) in &batch.records {
                log.record(opcode, &batch.data[start..end])?;
                start = end;
            }
            match batch.end.take() {
                None => {}
                Some(Ok(())) => break,
                Some(Err(ReadError::Mcap(e))) => return Err(mcap_error(path, e)),
                Some(Err(ReadError::Io(e))) => return Err(IngestError::io(path, e)),
            }
            // Recycle the buffers, unless a huge record inflated them.
            if batch.data.capacity() <= 2 * BATCH_BYTES {
                batch.data.clear();
                batch.records.clear();
                let _ = pool_tx.send(batch);
            }
        }
        Ok(())
    })?;
    log.finish()
}

/// What the records of an MCAP log delivered so far.
struct Collector<'a> {
    path: &'a Path,
    channels: HashMap<u16, ChannelInfo>,
    rig: Option<BTreeMap<String, String>>,
    accs: BTreeMap<Quantity, Acc>,
    setpoints: Vec<(u64, f64, Option<f64>)>,
    warnings: Vec<Warning>,
    n_messages: u64,
    /// Messages per channel id announced by the summary section (a hint
    /// for reserving sample vectors, see [`expected_counts`]).
    expected: ExpectedCounts,
    /// Samples the caller can fit ([`super::IngestOptions::max_samples`]):
    /// a position channel with more is refused as soon as that is known
    /// (from the summary's message count times the first buffer's length,
    /// else when its samples pass the limit), before the rest is decoded.
    max_samples: Option<u64>,
    /// The longest position channel over `max_samples` so far (its
    /// refusal is pending until the other position channels announced
    /// theirs).
    over: Option<Over>,
}

/// Buffers of one channel decoded at most while a refusal waits for the
/// other position channels' announcements.
const ANNOUNCE_WAIT: usize = 64;

/// A position channel over the caller's sample budget.
struct Over {
    /// What was counted (`/x1 announces 12000000 samples`).
    subject: String,
    /// The count.
    samples: u64,
    /// Whether the count is the summary's (else: samples decoded so far).
    announced: bool,
}

impl Collector<'_> {
    /// The refusal of a pending [`Over`] (`all_seen`: every position
    /// channel announced its count, so the longest is known).
    fn refusal(&self, o: Over, max: u64, all_seen: bool) -> IngestError {
        IngestError::content(
            self.path,
            ContentError::OverFitBudget {
                subject: o.subject,
                samples: o.samples,
                max,
                count: if o.announced && all_seen {
                    SampleCount::Grid
                } else {
                    SampleCount::AtLeast
                },
            },
        )
    }
}

/// Messages per channel id as a log's summary section states them, and the
/// file's length (which bounds what is reserved on their word).
#[derive(Default)]
struct ExpectedCounts {
    messages: BTreeMap<u16, u64>,
    file_len: u64,
}

/// Largest summary section read for [`expected_counts`].
const SUMMARY_LIMIT: u64 = 16 << 20;

/// The message counts of the summary section's Statistics record, if the
/// file has a footer pointing to a summary with one. Only a sizing hint:
/// anything unexpected gives `None` (the linear pass then judges the file,
/// through a handle of its own).
fn expected_counts(path: &Path) -> Option<ExpectedCounts> {
    use std::io::{Seek, SeekFrom};
    let mut file = std::fs::File::open(path).ok()?;
    let file_len = file.metadata().ok()?.len();
    // Footer record (opcode, length, 20 bytes) and the end magic.
    let tail_len = 1 + 8 + 20 + mcap::MAGIC.len() as u64;
    file.seek(SeekFrom::Start(file_len.checked_sub(tail_len)?))
        .ok()?;
    let mut tail = vec![0u8; tail_len as usize];
    file.read_exact(&mut tail).ok()?;
    let (footer, magic) = tail.split_at(1 + 8 + 20);
    if magic != mcap::MAGIC || footer[0] != mcap::records::op::FOOTER {
        return None;
    }
    let Ok(Record::Footer(f)) = mcap::parse_record(footer[0], &footer[9..]) else {
        return None;
    };
    let summary_end = file_len - tail_len;
    if f.summary_start == 0
        || f.summary_start >= summary_end
        || summary_end - f.summary_start > SUMMARY_LIMIT
    {
        return None;
    }
    file.seek(SeekFrom::Start(f.summary_start)).ok()?;
    let mut summary = vec![0u8; (summary_end - f.summary_start) as usize];
    file.read_exact(&mut summary).ok()?;
    let mut rest = summary.as_slice();
    while rest.len() >= 9 {
        let (head, body) = rest.split_at(9);
        let len = usize::try_from(u64::from_le_bytes(head[1..].try_into().ok()?)).ok()?;
        if len > body.len() {
            return None;
        }
        let (data, next) = body.split_at(len);
        if head[0] == mcap::records::op::STATISTICS {
            let Ok(Record::Statistics(st)) = mcap::parse_record(head[0], data) else {
                return None;
            };
            return Some(ExpectedCounts {
                messages: st.channel_message_counts,
                file_len,
            });
        }
        rest = next;
    }
    None
}

impl Collector<'_> {
    /// One record of the file, in file order.
    fn record(&mut self, opcode: u8, data: &[u8]) -> Result<(), IngestError> {
        let path = self.path;
        match mcap::parse_record(opcode, data).map_err(|e| mcap_error(path, e))? {
            Record::Channel(ch) => self.channel(&ch)?,
            Record::Metadata(m) if m.name == "rig" => {
                if self.rig.is_some() {
                    return Err(IngestError::invalid(
                        path,
                        "more than one `rig` metadata record",
                    ));
                }
                self.rig = Some(m.metadata);
            }
            Record::Message { header, data } => self.message(&header, &data)?,
            _ => {}
        }
        Ok(())
    }

    /// A channel record: classified; one channel per sensor quantity (the
    /// summary section may repeat a record, never change it).
    fn channel(&mut self, ch: &mcap::records::Channel) -> Result<(), IngestError> {
        let path = self.path;
        let info = channel_info(path, ch, &mut self.warnings)?;
        if let Some(old) = self.channels.get(&ch.id) {
            if old.topic != info.topic {
                return Err(IngestError::invalid(
                    path,
                    format!(
                        "corrupt MCAP: channel id {} is both {} and {}",
                        ch.id, old.topic, info.topic
                    ),
                ));
            }
            return Ok(()); // the summary section repeats channels
        }
        if let Role::Sensor(q) = info.role {
            if let Some(other) = self
                .channels
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
            self.accs.insert(
                q,
                Acc {
                    topic: info.topic.clone(),
                    rate_hz: info.rate_hz,
                    ..Acc::default()
                },
            );
        }
        self.channels.insert(ch.id, info);
        Ok(())
    }

    /// A message: a set point or a sensor buffer, checked and collected.
    fn message(
        &mut self,
        header: &mcap::records::MessageHeader,
        data: &[u8],
    ) -> Result<(), IngestError> {
        let path = self.path;
        self.n_messages += 1;
        let Some(info) = self.channels.get(&header.channel_id) else {
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
                let m: SetpointMsg = decode(path, data, &where_)?;
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
                            format!("{}: amplitude_m {a} is not a valid amplitude", where_()),
                        ));
                    }
                }
                self.setpoints.push((m.t_ns, m.frequency_hz, m.amplitude_m));
            }
            Role::Sensor(q) => {
                let scale = info.scale;
                let acc = self.accs.entry(q).or_default();
                let first = acc.buffers.is_empty();
                let start = acc.values.len();
                let (t0_ns, dt_ns) = match buffer_json::parse_buffer(data, scale, &mut acc.values) {
                    Some(head) => head,
                    None => {
                        // Outside the fast path's subset: serde_json
                        // decides (and names what is wrong).
                        let m: BufferMsg = decode(path, data, &where_)?;
                        acc.values.extend(
                            m.value
                                .into_iter()
                                .map(|v| v.map_or(f64::NAN, |x| x * scale)),
                        );
                        (m.t0_ns, m.dt_ns)
                    }
                };
                push_buffer(path, acc, t0_ns, dt_ns, start, &where_)?;
                let position = matches!(q, Quantity::X0 | Quantity::X1 | Quantity::X2);
                if let Some(max) = self.max_samples.filter(|_| position) {
                    // The common grid runs at the fastest position channel's
                    // rate: it has at least as many samples as each of them.
                    let announced = first
                        .then(|| self.expected.messages.get(&header.channel_id))
                        .flatten()
                        .map_or(0, |m| m.saturating_mul(acc.values.len() as u64));
                    let n = announced.max(acc.values.len() as u64);
                    if n > max {
                        let announces = announced > acc.values.len() as u64;
                        let what = if announces {
                            "announces"
                        } else {
                            "holds more than"
                        };
                        if self.over.as_ref().is_none_or(|o| n > o.samples) {
                            self.over = Some(Over {
                                subject: format!("{} {what} {n} samples", info.topic),
                                samples: n,
                                announced: announces,
                            });
                        }
                    }
                }
                if first {
                    reserve(
                        acc,
                        self.expected.messages.get(&header.channel_id),
                        self.expected.file_len,
                    );
                }
                // A refusal waits for the other position channels'
                // announcements (their first messages, near the start of
                // the log: a lost first buffer delays one) so that it
                // names the longest; it comes at once where samples are
                // being decoded past the budget, and after at most
                // `ANNOUNCE_WAIT` buffers of a channel.
                if let (Some(max), Some(o)) = (self.max_samples, &self.over) {
                    let seen = [Quantity::X0, Quantity::X1, Quantity::X2]
                        .iter()
                        .all(|q| self.accs.get(q).is_some_and(|a| !a.buffers.is_empty()));
                    let waited = self.accs.get(&q).map_or(0, |a| a.buffers.len()) > ANNOUNCE_WAIT;
                    if seen || waited || !o.announced {
                        if let Some(o) = self.over.take() {
                            return Err(self.refusal(o, max, seen));
                        }
                    }
                }
            }
        }
        Ok(())
    }

    /// The raw log: rig metadata and data present, channels expanded on
    /// the log's origin (its first sensor sample).
    fn finish(mut self) -> Result<RawLog, IngestError> {
        if let (Some(max), Some(o)) = (self.max_samples, self.over.take()) {
            return Err(self.refusal(o, max, true));
        }
        let Collector {
            path,
            rig,
            accs,
            setpoints,
            mut warnings,
            n_messages,
            ..
        } = self;
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
            .ok_or_else(|| {
                IngestError::invalid(path, "no data: the log holds no sensor samples")
            })?;
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
                warnings.push(Warning::ChannelNoMessages {
                    topic: acc.topic,
                    quantity: q.name(),
                });
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
            declared_shifts: Vec::new(),
        })
    }
}

/// Classifies a channel record and reads its metadata.
fn channel_info(
    path: &Path,
    ch: &mcap::records::Channel,
    warnings: &mut Vec<Warning>,
) -> Result<ChannelInfo, IngestError> {
    let topic = ch.topic.clone();
    let role = if topic == SETPOINT_TOPIC {
        Role::Setpoint
    } else if let Some(q) = Quantity::from_topic(&topic) {
        Role::Sensor(q)
    } else {
        warnings.push(Warning::UnknownTopic {
            topic: topic.clone(),
        });
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
            None => warnings.push(Warning::UnitAssumed {
                topic: topic.clone(),
                unit: q.unit(),
            }),
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

/// Records one DAQ buffer whose values were appended to `acc.values` from
/// index `start`, checking that time moves forward.
fn push_buffer(
    path: &Path,
    acc: &mut Acc,
    t0_ns: u64,
    dt_ns: u64,
    start: usize,
    where_: &dyn Fn() -> String,
) -> Result<(), IngestError> {
    if dt_ns == 0 {
        return Err(IngestError::invalid(
            path,
            format!("{}: dt_ns is 0", where_()),
        ));
    }
    let n = (acc.values.len() - start) as u128;
    if n == 0 {
        return Ok(());
    }
    let end = t0_ns as u128 + (n - 1) * dt_ns as u128;
    if end > u64::MAX as u128 {
        return Err(IngestError::invalid(
            path,
            format!("{}: buffer runs past the end of the clock", where_()),
        ));
    }
    if let Some(&(t0, dt, prev_start)) = acc.buffers.last() {
        let prev_n = (start - prev_start) as u128;
        let prev_last = t0 as u128 + (prev_n - 1) * dt as u128;
        if (t0_ns as u128) <= prev_last {
            return Err(IngestError::invalid(
                path,
                format!(
                    "non-monotonic time on channel {}: buffer t0_ns {} is {:.6} s before the previous sample ({})",
                    acc.topic,
                    t0_ns,
                    (prev_last - t0_ns as u128) as f64 * 1e-9,
                    where_()
                ),
            ));
        }
    }
    acc.buffers.push((t0_ns, dt_ns, start));
    Ok(())
}

/// After a channel's first buffer: room for as many more as the summary
/// announces, each as long as the first, so its vectors do not regrow
/// (copying and touching fresh memory each time) while the log is read.
/// The hint is trusted only up to one value per byte of the file.
fn reserve(acc: &mut Acc, messages: Option<&u64>, file_len: u64) {
    let Some(&messages) = messages else {
        return;
    };
    let limit = usize::try_from(file_len).unwrap_or(usize::MAX);
    let more = usize::try_from(messages.saturating_sub(1))
        .unwrap_or(usize::MAX)
        .min(limit);
    acc.buffers.reserve(more);
    acc.values
        .reserve(more.saturating_mul(acc.values.len()).min(limit));
}

/// Seconds from `origin` to `t` (both ns), exact in integers first.
fn ns_diff_s(t: u64, origin: u64) -> f64 {
    (t as i128 - origin as i128) as f64 * 1e-9
}

/// Expands a channel's buffers into per-sample times from `origin`.
fn expand(q: Quantity, acc: Acc, origin: u64, warnings: &mut Vec<Warning>) -> RawChannel {
    let mut t = Vec::with_capacity(acc.values.len());
    let mut dts: Vec<u64> = Vec::with_capacity(acc.buffers.len());
    for (k, &(t0, dt, start)) in acc.buffers.iter().enumerate() {
        let end = acc
            .buffers
            .get(k + 1)
            .map_or(acc.values.len(), |next| next.2);
        let n = end - start;
        let base = t0 as i128 - origin as i128;
        let last = base + n.saturating_sub(1) as i128 * dt as i128;
        if i64::try_from(base).is_ok() && i64::try_from(last).is_ok() {
            // The same integers in i64 (an i64 converts to the same f64 as
            // the i128 of equal value, and much faster).
            // Each time from the one before by one addition (the same
            // integers as base + i * dt, without a multiplication each).
            let (mut ns, dt) = (base as i64, dt as i64);
            t.extend((0..n).map(|_| {
                let s = ns as f64 * 1e-9;
                ns = ns.wrapping_add(dt);
                s
            }));
        } else {
            for i in 0..n {
                let ns = base + i as i128 * dt as i128;
                t.push(ns as f64 * 1e-9);
            }
        }
        dts.push(dt);
    }
    dts.sort_unstable();
    let dt_ns = dts[dts.len() / 2];
    let dt_s = dt_ns as f64 * 1e-9;
    if dts.first() != dts.last() {
        warnings.push(Warning::MixedSampleIntervals {
            topic: acc.topic.clone(),
            min_ns: dts.first().copied().unwrap_or(0),
            max_ns: dts.last().copied().unwrap_or(0),
            nominal_ns: dt_ns,
        });
    }
    if let Some(r) = acc.rate_hz {
        if ((1.0 / dt_s) / r - 1.0).abs() > 0.01 {
            warnings.push(Warning::SampleRateMismatch {
                topic: acc.topic.clone(),
                rate_hz: r,
                dt_ns,
            });
        }
    }
    RawChannel {
        quantity: q,
        source: acc.topic,
        dt_s,
        t: t.into(),
        v: acc.values,
    }
}

#[cfg(test)]
mod tests {
    use super::super::{read as ingest, GapKind, IngestOptions, Quantity};
    use crate::warning::Warning;
    use mcap::records::{MessageHeader, Metadata};
    use mcap::{Compression, WriteOptions};
    use std::collections::BTreeMap;
    use std::path::{Path, PathBuf};

    const T0: u64 = 1_700_000_000_000_000_000;

    /// A small synthetic rig log, edited per test, then written to disk.
    struct Fixture {
        rig: Vec<BTreeMap<String, String>>,
        /// (topic, message encoding, channel metadata)
        channels: Vec<(String, String, BTreeMap<String, String>)>,
        /// (channel index, log time, payload)
        messages: Vec<(usize, u64, Vec<u8>)>,
        compression: Option<Compression>,
        summary: bool,
    }

    fn meta(pairs: &[(&str, &str)]) -> BTreeMap<String, String> {
        pairs
            .iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect()
    }

    fn buffer(t0: u64, dt: u64, values: &[Option<f64>]) -> Vec<u8> {
        serde_json::json!({"t0_ns": t0, "dt_ns": dt, "value": values})
            .to_string()
            .into_bytes()
    }

    impl Fixture {
        /// x0, x1, x2, v2 at 1 kHz: two 10-sample buffers each, value = t (s).
        fn good() -> Self {
            let rig = meta(&[
                ("format", "stickslip-rig-log/1"),
                ("test", "characteristic"),
                ("m1_kg", "8"),
                ("m2_kg", "2"),
                ("k1_n_per_m", "600"),
                ("k2_n_per_m", "700"),
                ("d_n_s_per_m", "0.1"),
                ("drive_amplitude_m", "0.002"),
                ("normal_force_n", "3"),
                ("drive_frequency_hz", "1.5"),
            ]);
            let mut f = Fixture {
                rig: vec![rig],
                channels: Vec::new(),
                messages: Vec::new(),
                compression: Some(Compression::Zstd),
                summary: true,
            };
            for q in [Quantity::X0, Quantity::X1, Quantity::X2, Quantity::V2] {
                f.channels.push((
                    q.topic().into(),
                    "json".into(),
                    meta(&[("sample_rate_hz", "1000"), ("unit", q.unit())]),
                ));
            }
            for c in 0..4 {
                for b in 0..2u64 {
                    let t0 = T0 + b * 10_000_000 + c as u64 * 100_000;
                    let vals: Vec<Option<f64>> = (0..10)
                        .map(|i| Some((t0 - T0 + i * 1_000_000) as f64 * 1e-9))
                        .collect();
                    f.messages.push((c, t0, buffer(t0, 1_000_000, &vals)));
                }
            }
            f
        }

        fn write(&self, dir: &Path, name: &str) -> PathBuf {
            let path = dir.join(name);
            let file = std::io::BufWriter::new(std::fs::File::create(&path).expect("create"));
            let mut w = WriteOptions::new()
                .compression(self.compression)
                .emit_summary_records(self.summary)
                .emit_summary_offsets(self.summary)
                .create(file)
                .expect("writer");
            let schema = w.add_schema("buffer", "jsonschema", b"{}").expect("schema");
            let ids: Vec<u16> = self
                .channels
                .iter()
                .map(|(topic, enc, md)| w.add_channel(schema, topic, enc, md).expect("channel"))
                .collect();
            for (i, (c, log_time, data)) in self.messages.iter().enumerate() {
                let header = MessageHeader {
                    channel_id: ids[*c],
                    sequence: i as u32,
                    log_time: *log_time,
                    publish_time: *log_time,
                };
                w.write_to_known_channel(&header, data).expect("message");
            }
            for r in &self.rig {
                w.write_metadata(&Metadata {
                    name: "rig".into(),
                    metadata: r.clone(),
                })
                .expect("metadata");
            }
            w.finish().expect("finish");
            path
        }

        fn read(&self) -> Result<super::super::Run, super::super::IngestError> {
            let dir = tempfile::tempdir().expect("tempdir");
            let p = self.write(dir.path(), "fixture.mcap");
            ingest(&p, &IngestOptions::default())
        }
    }

    /// The format-independent checks give their kinds with the numbers.
    #[test]
    fn content_errors_have_kinds() {
        use super::super::{ContentError, IngestError};
        let dir = tempfile::tempdir().expect("tempdir");
        let kind = |f: &Fixture, name: &str| match ingest(
            &f.write(dir.path(), name),
            &IngestOptions::default(),
        ) {
            Err(IngestError::Content { source, .. }) => source,
            other => panic!("{name}: not a content error: {:?}", other.err()),
        };
        // A clock jump of a day: the grid would be far larger than the data.
        let mut f = Fixture::good();
        let t = T0 + 86_400 * 1_000_000_000;
        f.messages.push((1, t, buffer(t, 1_000_000, &[Some(1.0)])));
        assert!(
            matches!(kind(&f, "jump.mcap"), ContentError::InconsistentTimes { samples, .. } if samples == 21),
            "{:?}",
            kind(&f, "jump.mcap")
        );
        // x2 renamed: the required channel is missing (named by its topic).
        let mut f = Fixture::good();
        f.messages.retain(|m| m.0 != 2);
        f.channels[2].0 = "/mass2/position_old".into();
        assert_eq!(
            kind(&f, "nox2.mcap"),
            ContentError::MissingChannel {
                quantity: "x2",
                source_name: "/mass2/position"
            }
        );
    }

    #[test]
    fn reads_every_compression_with_and_without_summary() {
        let reference = Fixture::good().read().expect("zstd");
        assert_eq!(reference.channels.len(), 4);
        assert_eq!(reference.channel(Quantity::X1).expect("x1").t.len(), 20);
        assert!(!reference.has_acceleration);
        assert!(reference.warnings.contains(&Warning::NoAccelerometer));
        assert!(reference.gaps.is_empty(), "{:?}", reference.gaps);
        for compression in [None, Some(Compression::Lz4), Some(Compression::Zstd)] {
            for summary in [true, false] {
                let mut f = Fixture::good();
                f.compression = compression;
                f.summary = summary;
                let run = f.read().expect("reads");
                for q in [Quantity::X0, Quantity::X1, Quantity::X2, Quantity::V2] {
                    let (a, b) = (run.channel(q).expect("q"), reference.channel(q).expect("q"));
                    assert_eq!(a.t, b.t);
                    assert_eq!(a.v, b.v);
                }
            }
        }
    }

    #[test]
    fn times_are_from_log_start_and_grid_interpolates() {
        let run = Fixture::good().read().expect("reads");
        // x0 starts the log; x1 starts 0.1 ms later.
        assert_eq!(run.channel(Quantity::X0).expect("x0").t[0], 0.0);
        assert!((run.channel(Quantity::X1).expect("x1").t[0] - 1e-4).abs() < 1e-12);
        let r = &run.resampled;
        assert_eq!(r.rate_hz, 1000.0);
        // value = time since T0, so on the grid x1(t) = t wherever defined.
        for (t, x) in r.t.iter().zip(r.x1.iter()) {
            if x.is_finite() {
                assert!((x - t).abs() < 1e-12, "{t}: {x}");
            }
        }
        assert!(
            r.x1[0].is_nan(),
            "no extrapolation before x1's first sample"
        );
        assert!(r.x1[1].is_finite());
    }

    #[test]
    fn units_are_converted_to_si() {
        let mut f = Fixture::good();
        f.channels[1].2.insert("unit".into(), "mm".into());
        let run = f.read().expect("reads");
        let x1 = run.channel(Quantity::X1).expect("x1");
        assert!((x1.v[5] - x1.t[5] * 1e-3).abs() < 1e-15);
        f.channels[1].2.insert("unit".into(), "furlong".into());
        let e = f.read().unwrap_err().to_string();
        assert!(
            e.contains("/mass1/position") && e.contains("furlong"),
            "{e}"
        );
    }

    #[test]
    fn non_finite_tokens_are_refused_clearly() {
        for token in ["NaN", "Infinity", "-Infinity"] {
            let mut f = Fixture::good();
            let text = format!(
                r#"{{"t0_ns":{},"dt_ns":1000000,"value":[1.0,{token}]}}"#,
                T0 + 50_000_000
            );
            f.messages.push((2, T0 + 50_000_000, text.into_bytes()));
            let e = f.read().unwrap_err().to_string();
            assert!(
                e.contains("NaN/Infinity") && e.contains("/mass2/position"),
                "{e}"
            );
        }
        let mut f = Fixture::good();
        let text = format!(
            r#"{{"t0_ns":{},"dt_ns":1000000,"value":[1e999]}}"#,
            T0 + 50_000_000
        );
        f.messages.push((2, T0 + 50_000_000, text.into_bytes()));
        let e = f.read().unwrap_err().to_string();
        assert!(
            e.contains("/mass2/position") && e.contains("log time"),
            "{e}"
        );
    }

    #[test]
    fn dropouts_lost_buffers_and_unknown_topics() {
        let mut f = Fixture::good();
        // x2: a null in the first buffer, and its second buffer lost (moved later).
        f.messages[4].2 = buffer(
            T0 + 200_000,
            1_000_000,
            &[
                Some(0.0),
                None,
                Some(0.002),
                Some(0.003),
                Some(0.004),
                Some(0.005),
                Some(0.006),
                Some(0.007),
                Some(0.008),
                Some(0.009),
            ],
        );
        let late = T0 + 40_000_000 + 200_000;
        f.messages[5] = (2, late, buffer(late, 1_000_000, &[Some(1.0); 10]));
        f.channels
            .push(("/daq/temperature".into(), "cdr".into(), BTreeMap::new()));
        f.messages.push((4, T0, b"\x00\x01 not json".to_vec()));
        let run = f.read().expect("reads");
        let x2 = run.channel(Quantity::X2).expect("x2");
        assert_eq!(x2.dropouts, 1);
        assert!(run
            .warnings
            .iter()
            .any(|w| matches!(w, Warning::UnknownTopic { topic } if topic == "/daq/temperature")));
        let gaps: Vec<_> = run.gaps.iter().filter(|g| g.channel == "x2").collect();
        assert_eq!(gaps.len(), 1, "{gaps:?}");
        assert_eq!(gaps[0].kind, GapKind::Missing);
        assert!((gaps[0].start_s - 0.0092).abs() < 1e-9, "{gaps:?}");
        assert!((gaps[0].end_s - 0.0402).abs() < 1e-9, "{gaps:?}");
        // The single null is bridged on the grid; the lost buffer is not.
        let r = &run.resampled;
        let at = |t: f64| r.x2[(t * 1000.0).round() as usize];
        // Grid 1 ms lies between samples at 0.2 ms (0.0) and 2.2 ms (0.002).
        assert!((at(0.001) - 0.0008).abs() < 1e-12, "{}", at(0.001));
        assert!(at(0.025).is_nan());
    }

    #[test]
    fn structural_problems_are_named() {
        type Edit = Box<dyn Fn(&mut Fixture)>;
        let cases: Vec<(Edit, &str)> = vec![
            (
                Box::new(|f| f.rig.push(f.rig[0].clone())),
                "more than one `rig`",
            ),
            (Box::new(|f| f.rig.clear()), "no `rig` metadata"),
            (Box::new(|f| f.channels[3].1 = "cdr".into()), "encoding"),
            (
                Box::new(|f| {
                    f.messages.retain(|m| m.0 != 2);
                }),
                "/mass2/position",
            ),
            (
                Box::new(|f| {
                    f.messages.retain(|m| m.0 != 2);
                    f.channels[2].0 = "/mass2/position_old".into();
                }),
                "required channel x2",
            ),
            (
                Box::new(|f| {
                    let t = T0 + 30_000_000;
                    f.messages.push((0, t, buffer(t, 0, &[Some(1.0)])));
                }),
                "dt_ns is 0",
            ),
            (
                Box::new(|f| {
                    // A clock jump of a day: refused, not a 86-million-row grid.
                    let t = T0 + 86_400 * 1_000_000_000;
                    f.messages.push((1, t, buffer(t, 1_000_000, &[Some(1.0)])));
                }),
                "time stamps inconsistent",
            ),
            (
                Box::new(|f| {
                    let t = T0 + 5_000_000;
                    f.messages.push((1, t, buffer(t, 1_000_000, &[Some(1.0)])));
                }),
                "non-monotonic time on channel /mass1/position",
            ),
            (
                Box::new(|f| {
                    f.channels
                        .push(("/drive/setpoint".into(), "json".into(), BTreeMap::new()));
                    let sp = format!(r#"{{"t_ns":{T0},"frequency_hz":-1.0,"amplitude_m":0.002}}"#);
                    f.messages.push((4, T0, sp.into_bytes()));
                }),
                "frequency_hz",
            ),
            (Box::new(|f| f.messages.clear()), "zero messages"),
        ];
        for (edit, needle) in cases {
            let mut f = Fixture::good();
            edit(&mut f);
            let e = f.read().unwrap_err().to_string();
            assert!(
                e.contains("fixture.mcap") && e.contains(needle),
                "{needle}: {e}"
            );
        }
    }

    #[test]
    fn setpoints_are_kept_in_order() {
        let mut f = Fixture::good();
        f.channels
            .push(("/drive/setpoint".into(), "json".into(), BTreeMap::new()));
        for (k, hz) in [(0u64, 1.0), (10, 1.5)] {
            let t = T0 + k * 1_000_000;
            let sp = format!(r#"{{"t_ns":{t},"frequency_hz":{hz},"amplitude_m":0.002}}"#);
            f.messages.push((4, t, sp.into_bytes()));
        }
        let run = f.read().expect("reads");
        assert_eq!(run.setpoints.len(), 2);
        assert_eq!(run.setpoints[1].frequency_hz, 1.5);
        assert!((run.setpoints[1].t_s - 0.01).abs() < 1e-12);
        let sp = run.resampled.setpoint_hz.as_ref().expect("column");
        assert_eq!(sp[5], 1.0);
        assert_eq!(sp[15], 1.5);
    }

    #[test]
    fn summary_message_counts_are_only_a_hint() {
        let dir = tempfile::tempdir().expect("tempdir");
        let with = Fixture::good().write(dir.path(), "with.mcap");
        let counts = super::expected_counts(&with).expect("statistics");
        assert_eq!(counts.messages.values().sum::<u64>(), 8);
        let mut f = Fixture::good();
        f.summary = false;
        let without = f.write(dir.path(), "without.mcap");
        assert!(super::expected_counts(&without).is_none());
        // A file cut short has no footer: no hint.
        let bytes = std::fs::read(&with).expect("read");
        let cut = dir.path().join("cut.mcap");
        std::fs::write(&cut, &bytes[..bytes.len() - 1]).expect("write");
        assert!(super::expected_counts(&cut).is_none());
    }

    #[test]
    fn corrupted_bytes_never_panic() {
        let dir = tempfile::tempdir().expect("tempdir");
        let good = Fixture::good().write(dir.path(), "good.mcap");
        let bytes = std::fs::read(&good).expect("read");
        let p = dir.path().join("bad.mcap");
        // Deterministic corruption: every position, a few byte values.
        for i in (0..bytes.len()).step_by(7) {
            for v in [0x00u8, 0xff, 0x7f] {
                let mut b = bytes.clone();
                b[i] = v;
                std::fs::write(&p, &b).expect("write");
                let _ = ingest(&p, &IngestOptions::default());
            }
        }
        for cut in (0..bytes.len()).step_by(11) {
            std::fs::write(&p, &bytes[..cut]).expect("write");
            assert!(
                ingest(&p, &IngestOptions::default()).is_err(),
                "cut at {cut}"
            );
        }
    }
}
