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

use super::csv::{self, ChannelMap, ColumnSpec, MapKind};
use super::rig::RigMeta;
use super::run::median_interval;
use super::{
    unit_factor, ContentError, IngestError, LogFormat, Quantity, RawChannel, RawLog, SampleCount,
};
use crate::warning::Warning;
use std::collections::BTreeMap;
use std::path::Path;

/// Largest TDMS log read: it is held whole, and the decoded channels take
/// up to 8 times its raw bytes (one f64 per byte of `u8` data).
pub(crate) const MAX_TDMS_BYTES: u64 = crate::limits::MEMORY_BUDGET_BYTES / 10;

const TOC_META_DATA: u32 = 1 << 1;
const TOC_NEW_OBJ_LIST: u32 = 1 << 2;
const TOC_RAW_DATA: u32 = 1 << 3;
const TOC_INTERLEAVED: u32 = 1 << 5;
const TOC_BIG_ENDIAN: u32 = 1 << 6;
const TOC_DAQMX: u32 = 1 << 7;

const LEAD_IN: usize = 28;

/// TDMS data type codes used here.
const T_STRING: u32 = 0x20;
const T_TIMESTAMP: u32 = 0x44;
const T_DAQMX: u32 = 0xFFFF_FFFF;

/// Bytes per value of a fixed-size TDMS data type (`None`: variable size or
/// not a data type this reader knows).
fn type_size(t: u32) -> Option<usize> {
    Some(match t {
        1 | 5 | 0x21 => 1,
        2 | 6 => 2,
        3 | 7 | 9 | 0x19 => 4,
        4 | 8 | 10 | 0x1A | 0x08_000C => 8,
        T_TIMESTAMP | 0x10_000D => 16,
        _ => return None,
    })
}

/// A TDMS data type's name, for messages.
fn type_name(t: u32) -> String {
    match t {
        0 => "void".into(),
        1 => "I8".into(),
        2 => "I16".into(),
        3 => "I32".into(),
        4 => "I64".into(),
        5 => "U8".into(),
        6 => "U16".into(),
        7 => "U32".into(),
        8 => "U64".into(),
        9 | 0x19 => "single float".into(),
        10 | 0x1A => "double float".into(),
        11 | 0x1B => "extended float".into(),
        T_STRING => "string".into(),
        0x21 => "boolean".into(),
        T_TIMESTAMP => "timestamp".into(),
        0x4F => "fixed point".into(),
        0x08_000C => "complex single float".into(),
        0x10_000D => "complex double float".into(),
        T_DAQMX => "DAQmx raw data".into(),
        other => format!("unknown type 0x{other:x}"),
    }
}

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

/// What is wrong with a segment's metadata where a [`Cur`] reads it
/// (within [`TdmsError::Metadata`]).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
enum MetaFault {
    /// A field runs past the metadata's bytes.
    #[error("{what} needs {n} bytes, only {remain} remain")]
    Short {
        what: &'static str,
        n: usize,
        remain: usize,
    },
    /// A property of a data type this reader does not know.
    #[error("property of unsupported type {}", type_name(*.dtype))]
    PropertyType { dtype: u32 },
    /// An array dimension other than 1.
    #[error("object {path:?} has array dimension {dim} (TDMS allows only 1)")]
    Dimension { path: String, dim: u32 },
    /// A value count whose bytes overflow.
    #[error("object {path:?}: {count} values overflow")]
    CountOverflow { path: String, count: u64 },
    /// Data of a type this reader does not read.
    #[error("object {path:?} holds {} data, which is not read", type_name(*.dtype))]
    DataType { path: String, dtype: u32 },
    /// A raw data index whose length does not match what it holds.
    #[error("object {path:?}: raw data index length {len} does not match its content")]
    IndexLength { path: String, len: u32 },
}

/// Why the TDMS parser refuses a file ([`parse`], [`decode`]); the reader
/// reports it as [`IngestError::Invalid`] with the file.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
enum TdmsError {
    /// The file is the index file, not the data.
    #[error("is a TDMS index file (.tdms_index), not the data: give the .tdms file")]
    IndexFile,
    /// The file does not start with a segment tag.
    #[error("not a TDMS file (no `TDSm` segment tag at its start)")]
    NotTdms,
    /// Bytes after the last segment too few for a lead-in.
    #[error("truncated TDMS file: {stray} stray bytes at byte {seg} where segment {segment} should start (a segment lead-in is {LEAD_IN} bytes)")]
    StrayBytes {
        stray: usize,
        seg: usize,
        segment: usize,
    },
    /// A segment without its tag.
    #[error("corrupt TDMS file: segment {segment} at byte {seg} does not start with `TDSm`")]
    NoTag { segment: usize, seg: usize },
    /// A big-endian segment.
    #[error("segment {segment} at byte {seg} is big-endian: only little-endian TDMS files are read (docs/rig-log-format.md); save the file as little-endian")]
    BigEndian { segment: usize, seg: usize },
    /// A segment of DAQmx raw data.
    #[error("segment {segment} at byte {seg} holds DAQmx raw data, which is not read: export the channels as plain TDMS data (scaled values) instead")]
    DaqmxSegment { segment: usize, seg: usize },
    /// A TDMS version other than 4712 or 4713.
    #[error("segment {segment} at byte {seg}: TDMS version {version} is not 4712 or 4713")]
    Version {
        segment: usize,
        seg: usize,
        version: u32,
    },
    /// A segment longer than the bytes after it.
    #[error("truncated or corrupt TDMS file: segment {segment} at byte {seg} claims {seg_len} bytes after its lead-in, only {room} remain")]
    SegmentLength {
        segment: usize,
        seg: usize,
        seg_len: u64,
        room: u64,
    },
    /// Raw data beyond the segment's end.
    #[error("corrupt TDMS file: segment {segment} at byte {seg} puts its raw data {raw_off} bytes in, beyond its {seg_len} bytes")]
    RawOffset {
        segment: usize,
        seg: usize,
        raw_off: u64,
        seg_len: u64,
    },
    /// Corrupt metadata where a [`Cur`] reads it.
    #[error("corrupt TDMS metadata in the segment at byte {seg}: {fault} at byte {pos}")]
    Metadata {
        seg: usize,
        pos: usize,
        fault: MetaFault,
    },
    /// An object path that is not `/'group'/'channel'`.
    #[error("corrupt TDMS metadata in segment {segment} at byte {seg}: object path {path:?} is not /'group'/'channel'")]
    ObjectPath {
        segment: usize,
        seg: usize,
        path: String,
    },
    /// An object reusing a raw data index it never had.
    #[error("corrupt TDMS metadata in segment {segment} at byte {seg}: object {path:?} reuses a raw data index it never had")]
    ReusedIndex {
        segment: usize,
        seg: usize,
        path: String,
    },
    /// A channel of DAQmx raw data.
    #[error("channel {path:?} (segment {segment} at byte {seg}) holds DAQmx raw data, which is not read: export the channels as plain TDMS data (scaled values) instead")]
    DaqmxChannel {
        path: String,
        segment: usize,
        seg: usize,
    },
    /// Raw data sizes that overflow.
    #[error("corrupt TDMS file: segment {segment} at byte {seg}: raw data sizes overflow")]
    SizeOverflow { segment: usize, seg: usize },
    /// A string channel in interleaved data.
    #[error("segment {segment} at byte {seg}: string channel {name:?} in interleaved data")]
    InterleavedString {
        segment: usize,
        seg: usize,
        name: String,
    },
    /// Interleaved channels of different lengths.
    #[error("corrupt TDMS file: segment {segment} at byte {seg} interleaves channels of different lengths")]
    InterleavedLengths { segment: usize, seg: usize },
    /// Raw data that is not a whole number of chunks.
    #[error("corrupt TDMS file: segment {segment} at byte {seg} has {len} bytes of raw data, not a whole number of {chunk}-byte chunks")]
    PartialChunk {
        segment: usize,
        seg: usize,
        len: usize,
        chunk: u64,
    },
    /// A mapped channel whose data are not numbers.
    #[error("channel {name:?} holds {} data, not numbers", type_name(*.dtype))]
    NotNumbers { name: String, dtype: u32 },
    /// More values than memory can index.
    #[error("too many values")]
    TooManyValues,
}

/// A bounds-checked little-endian reader over a byte range of the file.
struct Cur<'a> {
    buf: &'a [u8],
    pos: usize,
    end: usize,
    /// File offset of the segment (for messages).
    seg: usize,
}

impl<'a> Cur<'a> {
    fn err(&self, fault: MetaFault) -> TdmsError {
        TdmsError::Metadata {
            seg: self.seg,
            pos: self.pos,
            fault,
        }
    }
    fn take(&mut self, n: usize, what: &'static str) -> Result<&'a [u8], TdmsError> {
        if n > self.end - self.pos {
            return Err(self.err(MetaFault::Short {
                what,
                n,
                remain: self.end - self.pos,
            }));
        }
        let s = &self.buf[self.pos..self.pos + n];
        self.pos += n;
        Ok(s)
    }
    fn u32(&mut self, what: &'static str) -> Result<u32, TdmsError> {
        let b = self.take(4, what)?;
        Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    }
    fn u64(&mut self, what: &'static str) -> Result<u64, TdmsError> {
        let b = self.take(8, what)?;
        let mut a = [0u8; 8];
        a.copy_from_slice(b);
        Ok(u64::from_le_bytes(a))
    }
    fn string(&mut self, what: &'static str) -> Result<String, TdmsError> {
        let n = self.u32(what)? as usize;
        let b = self.take(n, what)?;
        Ok(String::from_utf8_lossy(b).into_owned())
    }
}

/// The value of a numeric TDMS data type `t` (integers, single and
/// double; the extended-unit forms 0x19/0x1A) from its little-endian bytes
/// `b` (at least [`type_size`] long); `None` for any other type.
fn number(t: u32, b: &[u8]) -> Option<f64> {
    Some(match t {
        1 => b[0] as i8 as f64,
        5 => b[0] as f64,
        2 => i16::from_le_bytes([b[0], b[1]]) as f64,
        6 => u16::from_le_bytes([b[0], b[1]]) as f64,
        3 => le_u32(b, 0) as i32 as f64,
        7 => le_u32(b, 0) as f64,
        4 => le_u64(b, 0) as i64 as f64,
        8 => le_u64(b, 0) as f64,
        9 | 0x19 => f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
        10 | 0x1A => f64::from_bits(le_u64(b, 0)),
        _ => return None,
    })
}

fn le_u32(b: &[u8], at: usize) -> u32 {
    u32::from_le_bytes([b[at], b[at + 1], b[at + 2], b[at + 3]])
}

fn le_u64(b: &[u8], at: usize) -> u64 {
    let mut a = [0u8; 8];
    a.copy_from_slice(&b[at..at + 8]);
    u64::from_le_bytes(a)
}

/// `/'Group'/'Channel'` → ["Group", "Channel"] (`''` is a quote).
fn split_path(path: &str) -> Option<Vec<String>> {
    if path == "/" {
        return Some(Vec::new());
    }
    let mut parts = Vec::new();
    let mut chars = path.chars().peekable();
    while let Some(c) = chars.next() {
        if c != '/' || chars.next() != Some('\'') {
            return None;
        }
        let mut part = String::new();
        loop {
            match chars.next()? {
                '\'' if chars.peek() == Some(&'\'') => {
                    chars.next();
                    part.push('\'');
                }
                '\'' => break,
                other => part.push(other),
            }
        }
        parts.push(part);
    }
    Some(parts)
}

/// Reads a property value of type `t`.
fn read_prop(c: &mut Cur, t: u32) -> Result<Prop, TdmsError> {
    // A boolean property (0x21) reads as its byte.
    let num = |b: &[u8]| -> f64 {
        if t == 0x21 {
            b[0] as f64
        } else {
            number(t, b).unwrap_or(f64::NAN)
        }
    };
    match t {
        T_STRING => Ok(Prop::Str(c.string("a string property")?)),
        T_TIMESTAMP => {
            let b = c.take(16, "a timestamp property")?;
            let frac = le_u64(b, 0) as i128;
            let secs = le_u64(b, 8) as i64 as i128;
            Ok(Prop::Time((secs << 64) + frac))
        }
        0x08_000C | 0x10_000D => {
            let n = type_size(t).unwrap_or(16);
            c.take(n, "a complex property")?;
            Ok(Prop::Other)
        }
        _ => match type_size(t) {
            Some(n) => {
                let b = c.take(n, "a property value")?;
                Ok(Prop::Num(num(b)))
            }
            None => Err(c.err(MetaFault::PropertyType { dtype: t })),
        },
    }
}

/// Parses the segments of a whole TDMS file, keeping properties of the root
/// and of wanted channels, and where the wanted channels' values are.
fn parse(path: &Path, buf: &[u8], wanted: &[&str]) -> Result<File, IngestError> {
    let bad = |e: TdmsError| IngestError::invalid(path, e.to_string());
    if buf.len() < 4 || &buf[..4] != b"TDSm" {
        return Err(bad(if buf.starts_with(b"TDSh") {
            TdmsError::IndexFile
        } else {
            TdmsError::NotTdms
        }));
    }
    let mut objects: Vec<Object> = vec![Object {
        name: String::new(),
        wanted: true,
        ..Object::default()
    }];
    let mut by_path: BTreeMap<String, usize> = BTreeMap::new();
    by_path.insert("/".into(), 0);
    // The active object list: object and its index in the current segment
    // (`None`: no data in it).
    let mut active: Vec<(usize, Option<Index>)> = Vec::new();
    let mut warnings = Vec::new();
    let mut pos = 0usize;
    let mut segment = 0usize;
    while pos < buf.len() {
        segment += 1;
        let seg = pos;
        let LeadIn {
            toc,
            seg_len,
            raw_off,
            unfinished,
        } = lead_in(buf, pos, segment).map_err(bad)?;
        let body = pos + LEAD_IN;
        if toc & TOC_META_DATA != 0 {
            let mut c = Cur {
                buf,
                pos: body,
                end: body + raw_off,
                seg,
            };
            if toc & TOC_NEW_OBJ_LIST != 0 {
                active.clear();
            }
            let n = c.u32("the object count").map_err(bad)?;
            for _ in 0..n {
                let p = c.string("an object path").map_err(bad)?;
                let id = object_id(&mut objects, &mut by_path, &p, wanted, (segment, seg))
                    .map_err(bad)?;
                let index = raw_index(&mut c, &mut objects[id], &p, (segment, seg)).map_err(bad)?;
                let nprops = c.u32("a property count").map_err(bad)?;
                for _ in 0..nprops {
                    let key = c.string("a property name").map_err(bad)?;
                    let t = c.u32("a property type").map_err(bad)?;
                    let v = read_prop(&mut c, t).map_err(bad)?;
                    if objects[id].wanted {
                        objects[id].props.insert(key, v);
                    }
                }
                match active.iter_mut().find(|(o, _)| *o == id) {
                    Some(slot) => slot.1 = index,
                    None => active.push((id, index)),
                }
            }
        }
        if toc & TOC_RAW_DATA != 0 {
            let data_start = body + raw_off;
            let data_len = seg_len - raw_off;
            place_data(
                &mut objects,
                &active,
                (segment, seg),
                (data_start, data_len),
                toc & TOC_INTERLEAVED != 0,
                unfinished,
                &mut warnings,
            )
            .map_err(bad)?;
        }
        pos = body + seg_len;
    }
    Ok(File { objects, warnings })
}

/// What a segment's lead-in says of it, checked against the file.
struct LeadIn {
    /// The table of contents flags.
    toc: u32,
    /// Bytes of the segment after its lead-in.
    seg_len: usize,
    /// Offset of the raw data from the end of the lead-in.
    raw_off: usize,
    /// The writer stopped before filling in the length: the segment runs
    /// to the end of the file.
    unfinished: bool,
}

/// Reads and checks the lead-in of segment number `segment` at byte `pos`
/// of `buf`: its tag, byte order, DAQmx flag, version, and that its length
/// and raw data offset fit in the file.
fn lead_in(buf: &[u8], pos: usize, segment: usize) -> Result<LeadIn, TdmsError> {
    let seg = pos;
    if buf.len() - pos < LEAD_IN {
        return Err(TdmsError::StrayBytes {
            stray: buf.len() - pos,
            seg,
            segment,
        });
    }
    if &buf[pos..pos + 4] != b"TDSm" {
        return Err(TdmsError::NoTag { segment, seg });
    }
    let toc = le_u32(buf, pos + 4);
    if toc & TOC_BIG_ENDIAN != 0 {
        return Err(TdmsError::BigEndian { segment, seg });
    }
    if toc & TOC_DAQMX != 0 {
        return Err(TdmsError::DaqmxSegment { segment, seg });
    }
    let version = le_u32(buf, pos + 8);
    if version != 4712 && version != 4713 {
        return Err(TdmsError::Version {
            segment,
            seg,
            version,
        });
    }
    let next = le_u64(buf, pos + 12);
    let raw_off = le_u64(buf, pos + 20);
    let body = pos + LEAD_IN;
    let room = (buf.len() - body) as u64;
    // 0xFFFF_FFFF_FFFF_FFFF: the writer stopped before it could fill in
    // the length (a crashed recording): the segment runs to the end.
    let unfinished = next == u64::MAX;
    let seg_len = if unfinished { room } else { next };
    if seg_len > room {
        return Err(TdmsError::SegmentLength {
            segment,
            seg,
            seg_len,
            room,
        });
    }
    if raw_off > seg_len {
        return Err(TdmsError::RawOffset {
            segment,
            seg,
            raw_off,
            seg_len,
        });
    }
    Ok(LeadIn {
        toc,
        seg_len: seg_len as usize,
        raw_off: raw_off as usize,
        unfinished,
    })
}

/// The index in `objects` of the object at TDMS path `p`, added (wanted if
/// it is a channel `wanted` names) when the file has not named it before.
fn object_id(
    objects: &mut Vec<Object>,
    by_path: &mut BTreeMap<String, usize>,
    p: &str,
    wanted: &[&str],
    (segment, seg): (usize, usize),
) -> Result<usize, TdmsError> {
    if let Some(&id) = by_path.get(p) {
        return Ok(id);
    }
    let parts = split_path(p).ok_or_else(|| TdmsError::ObjectPath {
        segment,
        seg,
        path: p.to_string(),
    })?;
    let name = parts.join("/");
    let is_channel = parts.len() == 2;
    let id = objects.len();
    objects.push(Object {
        wanted: is_channel && wanted.contains(&name.as_str()),
        name,
        is_channel,
        ..Object::default()
    });
    by_path.insert(p.to_string(), id);
    Ok(id)
}

/// Reads the raw data index of object `obj` (path `p`) from the metadata:
/// `None` when it has no data in this segment, else its new index or the
/// one it had before; DAQmx raw data and data types this reader does not
/// know are refused.
fn raw_index(
    c: &mut Cur,
    obj: &mut Object,
    p: &str,
    (segment, seg): (usize, usize),
) -> Result<Option<Index>, TdmsError> {
    let raw_index = c.u32("a raw data index")?;
    Ok(match raw_index {
        0xFFFF_FFFF => None,
        0 => match obj.last_index {
            Some(ix) => Some(ix),
            None => {
                return Err(TdmsError::ReusedIndex {
                    segment,
                    seg,
                    path: p.to_string(),
                })
            }
        },
        0x6912_0000 | 0x6913_0000 | 0x0000_1269 | 0x0000_126A => {
            return Err(TdmsError::DaqmxChannel {
                path: p.to_string(),
                segment,
                seg,
            })
        }
        len => {
            let start = c.pos;
            let dtype = c.u32("a data type")?;
            if dtype == T_DAQMX {
                return Err(TdmsError::DaqmxChannel {
                    path: p.to_string(),
                    segment,
                    seg,
                });
            }
            let dim = c.u32("an array dimension")?;
            if dim != 1 {
                return Err(c.err(MetaFault::Dimension {
                    path: p.to_string(),
                    dim,
                }));
            }
            let count = c.u64("a value count")?;
            let bytes = if dtype == T_STRING {
                c.u64("a string data size")?
            } else {
                match type_size(dtype) {
                    Some(s) => count.checked_mul(s as u64).ok_or_else(|| {
                        c.err(MetaFault::CountOverflow {
                            path: p.to_string(),
                            count,
                        })
                    })?,
                    None if count == 0 => 0,
                    None => {
                        return Err(c.err(MetaFault::DataType {
                            path: p.to_string(),
                            dtype,
                        }))
                    }
                }
            };
            // The index length counts its own 4 bytes.
            if (c.pos - start + 4) as u64 != u64::from(len) {
                return Err(c.err(MetaFault::IndexLength {
                    path: p.to_string(),
                    len,
                }));
            }
            let ix = Index {
                dtype,
                count,
                bytes,
            };
            obj.last_index = Some(ix);
            Some(ix)
        }
    })
}

/// Records where a segment's raw data holds each wanted channel's values.
fn place_data(
    objects: &mut [Object],
    active: &[(usize, Option<Index>)],
    (segment, seg): (usize, usize),
    (start, len): (usize, usize),
    interleaved: bool,
    unfinished: bool,
    warnings: &mut Vec<Warning>,
) -> Result<(), TdmsError> {
    let with_data: Vec<(usize, Index)> = active
        .iter()
        .filter_map(|&(id, ix)| ix.filter(|i| i.count > 0).map(|i| (id, i)))
        .collect();
    if with_data.is_empty() {
        return Ok(());
    }
    let overflow = || TdmsError::SizeOverflow { segment, seg };
    let chunk: u64 = if interleaved {
        let n = with_data[0].1.count;
        let mut stride = 0u64;
        for (id, ix) in &with_data {
            if ix.dtype == T_STRING {
                return Err(TdmsError::InterleavedString {
                    segment,
                    seg,
                    name: objects[*id].name.clone(),
                });
            }
            if ix.count != n {
                return Err(TdmsError::InterleavedLengths { segment, seg });
            }
            stride = stride
                .checked_add(type_size(ix.dtype).unwrap_or(0) as u64)
                .ok_or_else(overflow)?;
        }
        n.checked_mul(stride).ok_or_else(overflow)?
    } else {
        with_data
            .iter()
            .try_fold(0u64, |a, (_, ix)| a.checked_add(ix.bytes))
            .ok_or_else(overflow)?
    };
    if chunk == 0 {
        return Ok(());
    }
    let len64 = len as u64;
    let chunks = len64 / chunk;
    if chunks == 0 || !len64.is_multiple_of(chunk) {
        if !unfinished {
            return Err(TdmsError::PartialChunk {
                segment,
                seg,
                len,
                chunk,
            });
        }
        warnings.push(Warning::UnfinishedSegment {
            byte: seg,
            ignored: len64 % chunk,
        });
    }
    // All below fit in usize: they are at most `len`.
    let chunks = chunks as usize;
    let chunk = chunk as usize;
    let mut offset = 0usize;
    for (id, ix) in &with_data {
        let size = type_size(ix.dtype).unwrap_or(0);
        let obj = &mut objects[*id];
        if obj.wanted && chunks > 0 {
            if ix.dtype == T_STRING || size == 0 {
                return Err(TdmsError::NotNumbers {
                    name: obj.name.clone(),
                    dtype: ix.dtype,
                });
            }
            let (piece_start, stride) = if interleaved {
                (start + offset, chunk / ix.count as usize)
            } else {
                (start + offset, size)
            };
            obj.pieces.push(Piece {
                dtype: ix.dtype,
                start: piece_start,
                count: ix.count as usize,
                stride,
                chunks,
                chunk_step: chunk,
            });
            obj.values = obj
                .values
                .saturating_add(ix.count.saturating_mul(chunks as u64));
        }
        offset += if interleaved { size } else { ix.bytes as usize };
    }
    Ok(())
}

/// The values of a channel: numbers as f64; timestamps as seconds after
/// `time_origin` (2^-64 s since 1904), or after the channel's first one.
fn decode(buf: &[u8], obj: &Object, time_origin: Option<i128>) -> Result<Vec<f64>, TdmsError> {
    let n = usize::try_from(obj.values).map_err(|_| TdmsError::TooManyValues)?;
    let mut out = Vec::with_capacity(n);
    let mut origin = time_origin;
    for p in &obj.pieces {
        for k in 0..p.chunks {
            let base = p.start + k * p.chunk_step;
            for i in 0..p.count {
                let at = base + i * p.stride;
                let b = &buf[at..at + type_size(p.dtype).unwrap_or(0)];
                let v = match (p.dtype, number(p.dtype, b)) {
                    (_, Some(v)) => v,
                    (T_TIMESTAMP, None) => {
                        let ts = ((le_u64(b, 8) as i64 as i128) << 64) + le_u64(b, 0) as i128;
                        let o = *origin.get_or_insert(ts);
                        ticks_to_s(ts - o)
                    }
                    (other, None) => {
                        return Err(TdmsError::NotNumbers {
                            name: obj.name.clone(),
                            dtype: other,
                        })
                    }
                };
                out.push(v);
            }
        }
    }
    Ok(out)
}

/// 2^-64 s ticks → seconds, exact to f64 rounding for any span.
fn ticks_to_s(ticks: i128) -> f64 {
    let whole = ticks >> 64;
    let frac = (ticks - (whole << 64)) as u64;
    whole as f64 + frac as f64 / 18_446_744_073_709_551_616.0
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

/// The first timestamp of a timestamp channel.
fn first_timestamp(buf: &[u8], obj: &Object) -> Option<i128> {
    let p = obj.pieces.iter().find(|p| p.chunks > 0 && p.count > 0)?;
    if p.dtype != T_TIMESTAMP {
        return None;
    }
    let b = &buf[p.start..p.start + 16];
    Some(((le_u64(b, 8) as i64 as i128) << 64) + le_u64(b, 0) as i128)
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn object_paths_split() {
        assert_eq!(split_path("/"), Some(vec![]));
        assert_eq!(split_path("/'g'"), Some(vec!["g".to_string()]));
        assert_eq!(
            split_path("/'a/b'/'it''s'"),
            Some(vec!["a/b".to_string(), "it's".to_string()])
        );
        assert_eq!(split_path("/g"), None);
        assert_eq!(split_path("/'g"), None);
    }

    #[test]
    fn ticks_convert_exactly() {
        assert_eq!(ticks_to_s(3i128 << 64), 3.0);
        assert_eq!(ticks_to_s((-1i128) << 63), -0.5);
        assert_eq!(ticks_to_s(1i128 << 62), 0.25);
    }
}
