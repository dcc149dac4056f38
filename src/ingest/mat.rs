//! MATLAB MAT-files of level 5 (`.mat`, MATLAB's `-v6` and `-v7`; `-v7`
//! compresses each variable with zlib): each quantity a real numeric vector
//! variable named by the channel map (the CSV map's keys, plus `rate_hz` and
//! `t0_s` for a variable with its own uniform sampling), the `rig` metadata
//! a struct variable `rig` of char arrays (numeric fields read as their
//! decimal values). `-v7.3` files (HDF5) are refused with how to save them
//! as `-v7`.
//!
//! This module owns the MAT reader itself, hand-written rather than a crate
//! (evaluation in docs/measurements.md, issue 33): `matfile` 0.5 reads
//! numeric arrays only (no char arrays, no structs, so no `rig`), prints to
//! stdout on unsupported variables (which would break `--json`) and
//! pre-allocates element counts read from the file; `matrw` 0.1 reads
//! structs but unwraps the zlib decoder (a corrupt `-v7` file panics) and
//! decompresses without a bound.
//!
//! Safety on bad bytes: the file is read whole (its size checked against the
//! memory budget first); every tag length is checked against the bytes that
//! remain, counts with checked arithmetic; a compressed variable is
//! inflated only up to the size its own tag declares, and that size is
//! bounded by the deflate limit of its compressed bytes (1032:1) and the
//! memory budget; structs nest at most [`MAX_DEPTH`] deep. zlib errors are
//! errors (flate2 returns them; it does not panic).

use super::csv::{self, ColumnSpec, MapKind};
use super::rig::RigMeta;
use super::run::median_interval;
use super::{ContentError, IngestError, LogFormat, Quantity, RawChannel, RawLog, SampleCount};
use std::collections::BTreeMap;
use std::io::Read;
use std::path::Path;

/// Largest MAT log read: held whole, with the decoded vectors (up to 8
/// bytes per stored byte) and one inflated variable at a time.
pub(crate) const MAX_MAT_BYTES: u64 = crate::limits::MEMORY_BUDGET_BYTES / 10;

/// Largest inflated variable of a `-v7` file.
const MAX_INFLATED: u64 = crate::limits::MEMORY_BUDGET_BYTES / 4;

/// Deepest nesting of structs and cells followed.
const MAX_DEPTH: usize = 8;

const MI_INT8: u32 = 1;
const MI_UINT8: u32 = 2;
const MI_INT16: u32 = 3;
const MI_UINT16: u32 = 4;
const MI_INT32: u32 = 5;
const MI_UINT32: u32 = 6;
const MI_SINGLE: u32 = 7;
const MI_DOUBLE: u32 = 9;
const MI_INT64: u32 = 12;
const MI_UINT64: u32 = 13;
const MI_MATRIX: u32 = 14;
const MI_COMPRESSED: u32 = 15;
const MI_UTF8: u32 = 16;
const MI_UTF16: u32 = 17;
const MI_UTF32: u32 = 18;

const MX_CELL: u8 = 1;
const MX_STRUCT: u8 = 2;
const MX_CHAR: u8 = 4;

/// The class of an array, for messages.
fn class_name(c: u8) -> &'static str {
    match c {
        MX_CELL => "cell array",
        MX_STRUCT => "struct",
        3 => "object",
        MX_CHAR => "char array",
        5 => "sparse matrix",
        6..=15 => "numeric array",
        16 => "function handle",
        17 => "opaque object",
        _ => "array of unknown class",
    }
}

/// A decoded variable (what this reader needs of it).
#[derive(Debug)]
enum Value {
    Numeric(Vec<f64>),
    Char(String),
    Struct(Vec<(String, Value)>),
    /// Not decoded: its class.
    Other(u8),
}

#[derive(Debug)]
struct Var {
    name: String,
    class: u8,
    dims: Vec<usize>,
    complex: bool,
    value: Value,
}

impl Var {
    fn dims_text(&self) -> String {
        self.dims
            .iter()
            .map(|d| d.to_string())
            .collect::<Vec<_>>()
            .join("x")
    }
}

/// The text of [`MatError::V73`].
const V73: &str = "is a MATLAB -v7.3 MAT-file (HDF5), which is not read: in MATLAB, save it as level 5 with save('NAME.mat', ..., '-v7') (or -v6)";

/// What is wrong with an element or array (within [`MatError::At`]).
#[derive(Debug, thiserror::Error)]
enum Fault {
    #[error("truncated element tag")]
    TruncatedTag,
    #[error("small element of {n} bytes (at most 4)")]
    SmallElement { n: usize },
    #[error("element of {n} bytes, only {remain} remain")]
    ElementLength { n: usize, remain: usize },
    #[error("data of element type {dtype} is not numeric")]
    NotNumeric { dtype: u32 },
    #[error("{bytes} data bytes are not a whole number of {size}-byte values")]
    PartialValues { bytes: usize, size: usize },
    #[error("odd number of UTF-16 bytes")]
    OddUtf16,
    #[error("char data of element type {dtype}")]
    CharType { dtype: u32 },
    #[error("structs nested more than {MAX_DEPTH} deep")]
    TooDeep,
    #[error("no array flags")]
    NoFlags,
    #[error("no dimensions")]
    NoDimensions,
    #[error("no array name")]
    NoName,
    #[error("dimensions overflow")]
    DimensionsOverflow,
    #[error("{values} values for dimensions {dims}")]
    ValueCount { values: usize, dims: String },
    #[error("no field name length")]
    NoFieldNameLength,
    #[error("bad field names")]
    BadFieldNames,
    #[error("field `{field}` is not an array")]
    FieldNotArray { field: String },
    #[error("corrupt zlib data ({0})")]
    Zlib(std::io::Error),
    #[error("declares {n} bytes, more than its {compressed} compressed bytes can hold (or over {})", crate::limits::human(MAX_INFLATED as f64))]
    Oversized { n: u64, compressed: usize },
    #[error("inflates to {got} bytes, its tag declares {n}")]
    ShortInflate { got: usize, n: u64 },
    #[error("compressed data of element type {dtype}, not an array")]
    CompressedNotArray { dtype: u32 },
}

/// Why the MAT parser refuses a file or a mapped variable; the reader
/// reports it as [`IngestError::Invalid`] with the file.
#[derive(Debug, thiserror::Error)]
enum MatError {
    /// An element or array of `what` (e.g. `variable `x``) is bad.
    #[error("{what}: {fault}")]
    At { what: String, fault: Fault },
    /// A -v7.3 (HDF5) file.
    #[error("{V73}")]
    V73,
    #[error("not a level-5 MAT-file: {len} bytes, shorter than its 128-byte header")]
    HeaderTooShort { len: usize },
    #[error("not a level-5 MAT-file (no IM/MI byte-order mark in its header; MATLAB 4 files are not read): save it with -v7 or -v6")]
    NoByteOrderMark,
    #[error("not a level-5 MAT-file: header version 0x{version:04x} (0x0100 expected)")]
    HeaderVersion { version: u16 },
    #[error("truncated MAT-file: {stray} stray bytes at byte {at}")]
    StrayBytes { stray: usize, at: usize },
    #[error("truncated or corrupt MAT-file: the variable at byte {at} claims {n} bytes, only {remain} remain")]
    VariableLength { at: usize, n: usize, remain: usize },
    #[error("corrupt MAT-file: element type {dtype} at byte {at} (a variable is type 14 or 15)")]
    ElementType { dtype: u32, at: usize },
    #[error("no rig metadata: the MAT-file has no struct variable `rig` (variables: {})", none_or_list(.names))]
    NoRig { names: Vec<String> },
    #[error("variable `rig` is a {}, not a struct of char arrays", class_name(*.class))]
    RigNotStruct { class: u8 },
    #[error("variable `rig` is a {dims} struct array; one struct is expected")]
    RigArray { dims: String },
    #[error("rig field `{key}` holds {n} numbers; a text or one number is expected")]
    RigFieldNumbers { key: String, n: usize },
    #[error("rig field `{key}` is a struct; a text or one number is expected")]
    RigFieldStruct { key: String },
    #[error("rig field `{key}` is a {}; a text or one number is expected", if *.class >= 6 && *.class <= 15 { "complex number" } else { class_name(*.class) })]
    RigFieldClass { key: String, class: u8 },
    #[error("variable {name:?} (mapped to {what} by {}) is not in the MAT-file (variables: {})", .map.display(), none_or_list(.names))]
    VariableMissing {
        name: String,
        what: String,
        map: std::path::PathBuf,
        names: Vec<String>,
    },
    #[error("variable {name:?} (mapped to {what}) is a {}, not a numeric vector", class_name(*.class))]
    NotNumericVariable {
        name: String,
        what: String,
        class: u8,
    },
    #[error("variable {name:?} (mapped to {what}) is complex")]
    Complex { name: String, what: String },
    #[error("variable {name:?} (mapped to {what}) is a {dims} matrix, not a vector")]
    Matrix {
        name: String,
        what: String,
        dims: String,
    },
}

/// `none`, or the names joined by `, `.
fn none_or_list(names: &[String]) -> String {
    if names.is_empty() {
        "none".to_string()
    } else {
        names.join(", ")
    }
}

/// A [`MatError::At`] of `what`.
fn at(what: &str, fault: Fault) -> MatError {
    MatError::At {
        what: what.to_string(),
        fault,
    }
}

/// Byte order of the file.
#[derive(Debug, Clone, Copy)]
struct Endian(bool /* little */);

impl Endian {
    fn u32(self, b: &[u8]) -> u32 {
        let a = [b[0], b[1], b[2], b[3]];
        if self.0 {
            u32::from_le_bytes(a)
        } else {
            u32::from_be_bytes(a)
        }
    }
    fn u16(self, b: &[u8]) -> u16 {
        if self.0 {
            u16::from_le_bytes([b[0], b[1]])
        } else {
            u16::from_be_bytes([b[0], b[1]])
        }
    }
    fn u64(self, b: &[u8]) -> u64 {
        let mut a = [0u8; 8];
        a.copy_from_slice(&b[..8]);
        if self.0 {
            u64::from_le_bytes(a)
        } else {
            u64::from_be_bytes(a)
        }
    }
}

/// One data element: its type, its data, and where the next one starts.
fn element(
    b: &[u8],
    pos: usize,
    e: Endian,
    what: &str,
) -> Result<(u32, std::ops::Range<usize>, usize), MatError> {
    if b.len().saturating_sub(pos) < 8 {
        return Err(at(what, Fault::TruncatedTag));
    }
    let first = e.u32(&b[pos..]);
    if first >> 16 != 0 {
        // Small element: type and size in one word, data in the next 4 bytes.
        let n = (first >> 16) as usize;
        if n > 4 {
            return Err(at(what, Fault::SmallElement { n }));
        }
        return Ok((first & 0xFFFF, pos + 4..pos + 4 + n, pos + 8));
    }
    let n = e.u32(&b[pos + 4..]) as usize;
    let start = pos + 8;
    if n > b.len() - start {
        return Err(at(
            what,
            Fault::ElementLength {
                n,
                remain: b.len() - start,
            },
        ));
    }
    let next = start + n.div_ceil(8) * 8;
    Ok((first, start..start + n, next.min(b.len())))
}

/// Numbers of a numeric element as f64.
fn numbers(t: u32, d: &[u8], e: Endian, what: &str) -> Result<Vec<f64>, MatError> {
    let size = match t {
        MI_INT8 | MI_UINT8 => 1,
        MI_INT16 | MI_UINT16 => 2,
        MI_INT32 | MI_UINT32 | MI_SINGLE => 4,
        MI_DOUBLE | MI_INT64 | MI_UINT64 => 8,
        other => return Err(at(what, Fault::NotNumeric { dtype: other })),
    };
    if !d.len().is_multiple_of(size) {
        return Err(at(
            what,
            Fault::PartialValues {
                bytes: d.len(),
                size,
            },
        ));
    }
    Ok(d.chunks_exact(size)
        .map(|c| match t {
            MI_INT8 => c[0] as i8 as f64,
            MI_UINT8 => c[0] as f64,
            MI_INT16 => e.u16(c) as i16 as f64,
            MI_UINT16 => e.u16(c) as f64,
            MI_INT32 => e.u32(c) as i32 as f64,
            MI_UINT32 => e.u32(c) as f64,
            MI_SINGLE => f32::from_bits(e.u32(c)) as f64,
            MI_DOUBLE => f64::from_bits(e.u64(c)),
            MI_INT64 => e.u64(c) as i64 as f64,
            _ => e.u64(c) as f64,
        })
        .collect())
}

/// Text of a char array's data element (column-major rows joined by `\n`).
fn text(t: u32, d: &[u8], e: Endian, dims: &[usize], what: &str) -> Result<String, MatError> {
    let chars: Vec<char> = match t {
        MI_UTF8 => return Ok(String::from_utf8_lossy(d).into_owned()),
        MI_UINT16 | MI_UTF16 => {
            if !d.len().is_multiple_of(2) {
                return Err(at(what, Fault::OddUtf16));
            }
            let units: Vec<u16> = d.chunks_exact(2).map(|c| e.u16(c)).collect();
            char::decode_utf16(units)
                .map(|c| c.unwrap_or(char::REPLACEMENT_CHARACTER))
                .collect()
        }
        MI_UTF32 | MI_UINT32 | MI_INT32 => d
            .chunks_exact(4)
            .map(|c| char::from_u32(e.u32(c)).unwrap_or(char::REPLACEMENT_CHARACTER))
            .collect(),
        MI_UINT8 | MI_INT8 => d.iter().map(|&c| c as char).collect(),
        other => return Err(at(what, Fault::CharType { dtype: other })),
    };
    let rows = dims.first().copied().unwrap_or(1).max(1);
    if rows == 1 || !chars.len().is_multiple_of(rows) {
        return Ok(chars.into_iter().collect());
    }
    let cols = chars.len() / rows;
    Ok((0..rows)
        .map(|r| (0..cols).map(|c| chars[r + rows * c]).collect::<String>())
        .collect::<Vec<_>>()
        .join("\n"))
}

/// Parses the body of a miMATRIX element. `keep(name)` says whether the
/// data of a top-level variable is decoded (struct fields always are).
fn matrix(
    b: &[u8],
    e: Endian,
    depth: usize,
    keep: &dyn Fn(&str) -> bool,
    what: &str,
) -> Result<Var, MatError> {
    if depth > MAX_DEPTH {
        return Err(at(what, Fault::TooDeep));
    }
    let (t, flags, mut pos) = element(b, 0, e, what)?;
    if t != MI_UINT32 || flags.len() < 8 {
        return Err(at(what, Fault::NoFlags));
    }
    let f = e.u32(&b[flags.start..]);
    let class = (f & 0xFF) as u8;
    let complex = f & 0x0800 != 0;
    let (t, d, next) = element(b, pos, e, what)?;
    pos = next;
    if t != MI_INT32 || d.is_empty() || d.len() % 4 != 0 {
        return Err(at(what, Fault::NoDimensions));
    }
    let dims: Vec<usize> = b[d]
        .chunks_exact(4)
        .map(|c| (e.u32(c) as i32).max(0) as usize)
        .collect();
    let (t, d, next) = element(b, pos, e, what)?;
    pos = next;
    if t != MI_INT8 && t != MI_UINT8 {
        return Err(at(what, Fault::NoName));
    }
    let name = String::from_utf8_lossy(&b[d]).into_owned();
    let what = if name.is_empty() {
        what.to_string()
    } else {
        format!("variable `{name}`")
    };
    let what = what.as_str();
    let elements = dims
        .iter()
        .try_fold(1usize, |a, &d| a.checked_mul(d))
        .ok_or_else(|| at(what, Fault::DimensionsOverflow))?;
    let decode = depth > 0 || keep(&name);
    let value = match class {
        _ if !decode => Value::Other(class),
        6..=15 => {
            let (t, d, next) = element(b, pos, e, what)?;
            let v = numbers(t, &b[d], e, what)?;
            if v.len() != elements {
                return Err(at(
                    what,
                    Fault::ValueCount {
                        values: v.len(),
                        dims: dims
                            .iter()
                            .map(|d| d.to_string())
                            .collect::<Vec<_>>()
                            .join("x"),
                    },
                ));
            }
            if complex {
                // The imaginary part must be there too.
                element(b, next, e, what)?;
            }
            Value::Numeric(v)
        }
        MX_CHAR => {
            let (t, d, _) = element(b, pos, e, what)?;
            Value::Char(text(t, &b[d], e, &dims, what)?)
        }
        MX_STRUCT => {
            let (t, d, next) = element(b, pos, e, what)?;
            pos = next;
            if t != MI_INT32 || d.len() != 4 {
                return Err(at(what, Fault::NoFieldNameLength));
            }
            let len = e.u32(&b[d.start..]) as usize;
            let (t, d, next) = element(b, pos, e, what)?;
            pos = next;
            if (t != MI_INT8 && t != MI_UINT8) || len == 0 || d.len() % len != 0 {
                return Err(at(what, Fault::BadFieldNames));
            }
            let names: Vec<String> = b[d]
                .chunks_exact(len)
                .map(|c| {
                    let end = c.iter().position(|&x| x == 0).unwrap_or(c.len());
                    String::from_utf8_lossy(&c[..end]).into_owned()
                })
                .collect();
            let mut fields = Vec::new();
            // Only a 1x1 struct's fields are kept (the `rig` record).
            if elements == 1 {
                for n in &names {
                    let (t, d, next) = element(b, pos, e, what)?;
                    pos = next;
                    if t != MI_MATRIX {
                        return Err(at(what, Fault::FieldNotArray { field: n.clone() }));
                    }
                    let fw = format!("{what}, field `{n}`");
                    let v = if d.is_empty() {
                        Var {
                            name: String::new(),
                            class: 6,
                            dims: vec![0, 0],
                            complex: false,
                            value: Value::Numeric(Vec::new()),
                        }
                    } else {
                        matrix(&b[d], e, depth + 1, keep, &fw)?
                    };
                    fields.push((n.clone(), v));
                }
            }
            Value::Struct(
                fields
                    .into_iter()
                    .map(|(n, v)| (n, field_value(v)))
                    .collect(),
            )
        }
        other => Value::Other(other),
    };
    Ok(Var {
        name,
        class,
        dims,
        complex,
        value,
    })
}

/// A struct field as kept: text, a real number, or what it is.
fn field_value(v: Var) -> Value {
    match v.value {
        Value::Numeric(_) if v.complex => Value::Other(v.class),
        other => other,
    }
}

/// The header's verdict: byte order, or why the file is not read.
fn header(buf: &[u8]) -> Result<Endian, MatError> {
    const HDF5: &[u8] = b"\x89HDF\r\n\x1a\n";
    if buf.starts_with(HDF5) || buf.get(512..520) == Some(HDF5) {
        return Err(MatError::V73);
    }
    if buf.len() < 128 {
        return Err(MatError::HeaderTooShort { len: buf.len() });
    }
    if buf.starts_with(b"MATLAB 7.3") {
        return Err(MatError::V73);
    }
    let e = match &buf[126..128] {
        b"IM" => Endian(true),
        b"MI" => Endian(false),
        _ => return Err(MatError::NoByteOrderMark),
    };
    match e.u16(&buf[124..126]) {
        0x0100 => Ok(e),
        0x0200 => Err(MatError::V73),
        version => Err(MatError::HeaderVersion { version }),
    }
}

/// Inflates a `-v7` variable: at most what its own tag declares.
fn inflate(data: &[u8], e: Endian, byte: usize) -> Result<Vec<u8>, MatError> {
    let what = format!("compressed variable at byte {byte}");
    let mut z = flate2::read::ZlibDecoder::new(data);
    let mut tag = [0u8; 8];
    z.read_exact(&mut tag)
        .map_err(|err| at(&what, Fault::Zlib(err)))?;
    let n = u64::from(e.u32(&tag[4..]));
    let limit = (data.len() as u64)
        .saturating_mul(1032)
        .saturating_add(64)
        .min(MAX_INFLATED);
    if n > limit {
        return Err(at(
            &what,
            Fault::Oversized {
                n,
                compressed: data.len(),
            },
        ));
    }
    let mut out = tag.to_vec();
    let got = (&mut z)
        .take(n)
        .read_to_end(&mut out)
        .map_err(|err| at(&what, Fault::Zlib(err)))?;
    if (got as u64) < n {
        return Err(at(&what, Fault::ShortInflate { got, n }));
    }
    Ok(out)
}

/// Every top-level variable of the file (data decoded where `keep` says).
fn variables(buf: &[u8], keep: &dyn Fn(&str) -> bool) -> Result<Vec<Var>, MatError> {
    let e = header(buf)?;
    let mut vars = Vec::new();
    let mut pos = 128;
    while pos < buf.len() {
        let byte = pos;
        if buf.len() - pos < 8 {
            // Trailing padding.
            if buf[pos..].iter().all(|&x| x == 0) {
                break;
            }
            return Err(MatError::StrayBytes {
                stray: buf.len() - pos,
                at: byte,
            });
        }
        let t = e.u32(&buf[pos..]);
        let n = e.u32(&buf[pos + 4..]) as usize;
        let start = pos + 8;
        if n > buf.len() - start {
            return Err(MatError::VariableLength {
                at: byte,
                n,
                remain: buf.len() - start,
            });
        }
        let body = &buf[start..start + n];
        let what = format!("variable at byte {byte}");
        match t {
            MI_MATRIX => {
                vars.push(matrix(body, e, 0, keep, &what)?);
                pos = (start + n.div_ceil(8) * 8).min(buf.len());
            }
            MI_COMPRESSED => {
                let inner = inflate(body, e, byte)?;
                let (t, d, _) = element(&inner, 0, e, &what)?;
                if t != MI_MATRIX {
                    return Err(at(&what, Fault::CompressedNotArray { dtype: t }));
                }
                vars.push(matrix(&inner[d], e, 0, keep, &what)?);
                pos = start + n;
            }
            0 if buf[pos..].iter().all(|&x| x == 0) => break,
            other => {
                return Err(MatError::ElementType {
                    dtype: other,
                    at: byte,
                })
            }
        }
    }
    Ok(vars)
}

/// The `rig` struct as key/value strings.
fn rig_map(vars: &[Var]) -> Result<BTreeMap<String, String>, MatError> {
    let Some(rig) = vars.iter().find(|v| v.name == "rig") else {
        let names: Vec<String> = vars.iter().map(|v| v.name.clone()).take(20).collect();
        return Err(MatError::NoRig { names });
    };
    let Value::Struct(fields) = &rig.value else {
        return Err(MatError::RigNotStruct { class: rig.class });
    };
    if rig.dims.iter().product::<usize>() != 1 {
        return Err(MatError::RigArray {
            dims: rig.dims_text(),
        });
    }
    let mut out = BTreeMap::new();
    for (k, v) in fields {
        let s = match v {
            Value::Char(s) => s.clone(),
            Value::Numeric(x) if x.len() == 1 => format!("{}", x[0]),
            Value::Numeric(x) if x.is_empty() => String::new(),
            Value::Numeric(x) => {
                return Err(MatError::RigFieldNumbers {
                    key: k.clone(),
                    n: x.len(),
                })
            }
            Value::Struct(_) => return Err(MatError::RigFieldStruct { key: k.clone() }),
            Value::Other(c) => {
                return Err(MatError::RigFieldClass {
                    key: k.clone(),
                    class: *c,
                })
            }
        };
        out.insert(k.clone(), s);
    }
    Ok(out)
}

/// A mapped variable's values (scaled), refusing what is not a real numeric
/// vector.
fn vector(vars: &[Var], spec: &ColumnSpec, what: &str, map: &Path) -> Result<Vec<f64>, MatError> {
    let Some(v) = vars.iter().find(|v| v.name == spec.name) else {
        let names: Vec<String> = vars
            .iter()
            .take(20)
            .map(|v| format!("{:?}", v.name))
            .collect();
        return Err(MatError::VariableMissing {
            name: spec.name.clone(),
            what: what.to_string(),
            map: map.to_path_buf(),
            names,
        });
    };
    let Value::Numeric(x) = &v.value else {
        return Err(MatError::NotNumericVariable {
            name: spec.name.clone(),
            what: what.to_string(),
            class: v.class,
        });
    };
    if v.complex {
        return Err(MatError::Complex {
            name: spec.name.clone(),
            what: what.to_string(),
        });
    }
    if v.dims.iter().filter(|&&d| d > 1).count() > 1 {
        return Err(MatError::Matrix {
            name: spec.name.clone(),
            what: what.to_string(),
            dims: v.dims_text(),
        });
    }
    Ok(x.iter().map(|v| v * spec.scale()).collect())
}

/// Reads a MAT log with its channel map (`map`, or the default).
/// `max_samples`: the caller's budget ([`super::IngestOptions::max_samples`]):
/// a position variable with more values is refused from its dimensions,
/// before the log's channels and time base are built.
pub(crate) fn read(
    path: &Path,
    map: Option<&Path>,
    max_samples: Option<u64>,
) -> Result<RawLog, IngestError> {
    let buf = std::fs::read(path).map_err(|e| IngestError::io(path, e))?;
    let bad = |m: String| IngestError::invalid(path, m);
    let mat = |e: MatError| IngestError::invalid(path, e.to_string());
    // The header first: a -v7.3 file is refused before its map is needed.
    header(&buf).map_err(mat)?;
    let (map_path, cmap) = csv::read_map(path, map, MapKind::Mat)?;
    let mut wanted: Vec<&str> = vec!["rig"];
    wanted.extend(cmap.channels.iter().map(|(_, s)| s.name.as_str()));
    wanted.extend(cmap.time.iter().map(|s| s.name.as_str()));
    wanted.extend(cmap.setpoint_hz.iter().map(|s| s.name.as_str()));
    let vars = variables(&buf, &|n: &str| wanted.contains(&n)).map_err(mat)?;
    for (i, v) in vars.iter().enumerate() {
        if wanted.contains(&v.name.as_str()) && vars[..i].iter().any(|w| w.name == v.name) {
            return Err(bad(format!("variable `{}` appears twice", v.name)));
        }
    }
    if let Some(max) = max_samples {
        let positions = cmap
            .channels
            .iter()
            .filter(|(q, _)| matches!(q, Quantity::X0 | Quantity::X1 | Quantity::X2));
        let longest = positions
            .filter_map(|(_, spec)| vars.iter().find(|v| v.name == spec.name))
            .map(|v| {
                let n = v
                    .dims
                    .iter()
                    .try_fold(1u64, |a, &d| a.checked_mul(d as u64))
                    .unwrap_or(u64::MAX);
                (n, v)
            })
            .max_by_key(|(n, _)| *n);
        if let Some((n, v)) = longest.filter(|(n, _)| *n > max) {
            return Err(IngestError::content(
                path,
                ContentError::OverFitBudget {
                    subject: format!("variable {:?} holds {n} values", v.name),
                    samples: n,
                    max,
                    count: SampleCount::Grid,
                },
            ));
        }
    }
    let rig =
        RigMeta::from_map(&rig_map(&vars).map_err(mat)?).map_err(|e| IngestError::rig(path, e))?;
    // The time base of the variables without their own rate.
    let time = match &cmap.time {
        Some(tspec) => {
            let time = vector(&vars, tspec, "time", &map_path).map_err(mat)?;
            if time.len() < 2 {
                return Err(bad(format!(
                    "too little data: the time variable {:?} has {} values",
                    tspec.name,
                    time.len()
                )));
            }
            if let Some(i) = time.iter().position(|t| !t.is_finite()) {
                return Err(bad(format!(
                    "time variable {:?}: value {} is not a finite number",
                    tspec.name,
                    i + 1
                )));
            }
            if let Some(i) = time.windows(2).position(|w| w[1] <= w[0]) {
                return Err(bad(format!(
                    "non-monotonic time: time variable {:?}, value {}: {} s does not follow {} s",
                    tspec.name,
                    i + 2,
                    time[i + 1],
                    time[i]
                )));
            }
            let dt_s = median_interval(&time).unwrap_or(f64::NAN);
            csv::check_rate(&map_path, tspec, dt_s).map_err(|e| in_log(path, e))?;
            Some((tspec, time, dt_s))
        }
        None => None,
    };
    // Times (before the entry's own shift) and sample interval of a variable.
    let timing = |spec: &ColumnSpec, n: usize| -> Result<(Vec<f64>, f64), IngestError> {
        if let Some(rate) = spec.rate_hz {
            let t0 = spec.t0_s.unwrap_or(0.0);
            return Ok(((0..n).map(|i| t0 + i as f64 / rate).collect(), 1.0 / rate));
        }
        let Some((tspec, time, dt_s)) = &time else {
            return Err(bad(format!("variable {:?} has no time base", spec.name)));
        };
        if n != time.len() {
            return Err(bad(format!(
                "variable {:?} has {n} values, the time variable {:?} {} (give the variable its own rate_hz in the map if it is sampled differently)",
                spec.name,
                tspec.name,
                time.len()
            )));
        }
        Ok((time.iter().map(|t| t + tspec.shift_s).collect(), *dt_s))
    };
    let mut channels = Vec::new();
    for (q, spec) in &cmap.channels {
        let v = vector(&vars, spec, q.name(), &map_path).map_err(mat)?;
        let (t, dt_s) = timing(spec, v.len())?;
        channels.push(RawChannel {
            quantity: *q,
            source: spec.name.clone(),
            dt_s,
            t: t.iter().map(|t| t + spec.shift_s).collect(),
            v,
        });
    }
    super::tdms::check_finite_times(path, &channels)?;
    csv::check_drive_amplitude(&map_path, &cmap, &channels).map_err(|e| in_log(path, e))?;
    let setpoints = match &cmap.setpoint_hz {
        Some(spec) => {
            let v = vector(&vars, spec, "setpoint_hz", &map_path).map_err(mat)?;
            let (t, _) = timing(spec, v.len())?;
            csv::setpoints(path, spec, &t, &v, (0.0, 0.0))?
        }
        None => Vec::new(),
    };
    // A table starts at its first row (as a CSV log); variables with their
    // own rates only at the earliest sample.
    let origin = time
        .as_ref()
        .map(|(tspec, time, _)| time[0] + tspec.shift_s);
    Ok(RawLog {
        format: LogFormat::Mat,
        rig,
        channels,
        origin,
        setpoints,
        warnings: Vec::new(),
        declared_shifts: super::tdms::declared(&cmap),
    })
}

/// A map check that failed on this file's data (a damaged file can put
/// its rate or drive amplitude out of range): named by the log first.
fn in_log(path: &Path, e: IngestError) -> IngestError {
    IngestError::invalid(path, e.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn le_header() -> Vec<u8> {
        let mut h = vec![b' '; 128];
        h[..10].copy_from_slice(b"MATLAB 5.0");
        h[124..126].copy_from_slice(&0x0100u16.to_le_bytes());
        h[126..128].copy_from_slice(b"IM");
        h
    }

    #[test]
    fn header_verdicts() {
        assert!(header(&le_header()).is_ok());
        let mut v73 = le_header();
        v73[..10].copy_from_slice(b"MATLAB 7.3");
        assert!(header(&v73).unwrap_err().to_string().contains("-v7.3"));
        let mut hdf = vec![0u8; 600];
        hdf[512..520].copy_from_slice(b"\x89HDF\r\n\x1a\n");
        assert!(header(&hdf).unwrap_err().to_string().contains("-v7"));
        assert!(header(b"short")
            .unwrap_err()
            .to_string()
            .contains("128-byte"));
        let mut v4 = le_header();
        v4[126..128].copy_from_slice(b"xx");
        assert!(header(&v4).unwrap_err().to_string().contains("level-5"));
    }

    #[test]
    fn refuses_a_zlib_bomb_by_its_tag() {
        // A compressed variable whose inner tag declares 4 GB.
        let mut inner = Vec::new();
        inner.extend_from_slice(&MI_MATRIX.to_le_bytes());
        inner.extend_from_slice(&u32::MAX.to_le_bytes());
        let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::default());
        std::io::Write::write_all(&mut z, &inner).unwrap();
        let data = z.finish().unwrap();
        let e = inflate(&data, Endian(true), 128).unwrap_err().to_string();
        assert!(e.contains("declares 4294967295 bytes"), "{e}");
        // Garbage is an error, not a panic.
        let e = inflate(&[0x78, 0x9c, 1, 2, 3, 4, 5], Endian(true), 128)
            .unwrap_err()
            .to_string();
        assert!(e.contains("corrupt zlib"), "{e}");
    }
}
