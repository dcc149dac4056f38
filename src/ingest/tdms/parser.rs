//! The TDMS segment parser: lead-ins, metadata (object lists,
//! properties, raw data indexes), where each wanted channel's values lie in
//! the raw data (contiguous or interleaved), and their decoding; every
//! length and offset checked against the bytes that remain.

use super::*;

const TOC_META_DATA: u32 = 1 << 1;
const TOC_NEW_OBJ_LIST: u32 = 1 << 2;
const TOC_RAW_DATA: u32 = 1 << 3;
const TOC_INTERLEAVED: u32 = 1 << 5;
const TOC_BIG_ENDIAN: u32 = 1 << 6;
const TOC_DAQMX: u32 = 1 << 7;

const LEAD_IN: usize = 28;

/// TDMS data type codes used here.
const T_STRING: u32 = 0x20;
pub(super) const T_TIMESTAMP: u32 = 0x44;
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

/// What is wrong with a segment's metadata where a [`Cur`] reads it
/// (within [`TdmsError::Metadata`]).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub(super) enum MetaFault {
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
pub(super) enum TdmsError {
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
pub(super) fn parse(path: &Path, buf: &[u8], wanted: &[&str]) -> Result<File, IngestError> {
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
pub(super) fn decode(
    buf: &[u8],
    obj: &Object,
    time_origin: Option<i128>,
) -> Result<Vec<f64>, TdmsError> {
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
pub(super) fn ticks_to_s(ticks: i128) -> f64 {
    let whole = ticks >> 64;
    let frac = (ticks - (whole << 64)) as u64;
    whole as f64 + frac as f64 / 18_446_744_073_709_551_616.0
}

/// The first timestamp of a timestamp channel.
pub(super) fn first_timestamp(buf: &[u8], obj: &Object) -> Option<i128> {
    let p = obj.pieces.iter().find(|p| p.chunks > 0 && p.count > 0)?;
    if p.dtype != T_TIMESTAMP {
        return None;
    }
    let b = &buf[p.start..p.start + 16];
    Some(((le_u64(b, 8) as i64 as i128) << 64) + le_u64(b, 0) as i128)
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
