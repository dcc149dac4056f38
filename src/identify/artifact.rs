//! Fits as artifacts (issue 33): a fit computed once (`stickslip fit`,
//! possibly `--shard K/N` on many machines, joined by `merge`) and reused by
//! `batch --fits`, `validate --fit` and a plan's `fits =`, with results
//! identical to fitting the same logs in the same run.
//!
//! A fit record (one `fits` entry, [`FitRecord`]) carries the interface
//! keys of [`LogFit::json`], the `log_sha256` of the file it was fitted on, the
//! log's `rig` record and `recorded_at`, and — in the records `fit` writes —
//! `artifact`: `{"format": 1, "rig": …, "fit": …}`, the whole [`RigMeta`]
//! and [`LogFit`] as typed serde values. Its floats are written so that they
//! read back bit for bit: finite numbers as JSON numbers (shortest
//! round-trip text, read with `serde_json`'s `float_roundtrip`), NaN and
//! infinities as `{"$non_finite_f64": "NaN" | "inf" | "-inf"}` (JSON has
//! none). The conversion goes through CBOR's value tree
//! ([`ciborium::Value`]), which keeps every float as it is.
//!
//! [`FitSet`] reads a `{"fits": [...]}` file and pairs its records with the
//! logs also given: by `log_sha256`, refusing a record whose log is given
//! (the same file path) but whose `log_sha256` differs from that file.

use super::json::LogFitJson;
use super::LogFit;
use crate::error::{Error, Result};
use crate::ingest::RigMeta;
use ciborium::Value as Cbor;
use serde::{de::DeserializeOwned, Deserialize, Serialize};
use serde_json::{json, Map, Value};
use std::path::{Path, PathBuf};

/// Format version of the `artifact` object; a reader refuses any other.
pub const FORMAT: u32 = 1;

/// The key of a non-finite float in the exact JSON form.
const NON_FINITE: &str = "$non_finite_f64";

/// Largest fits file read (bytes): a record with its artifact is about
/// 20–60 kB, so this holds some thousands of fits well inside the memory
/// budget (the JSON tree takes a few times the text).
pub const MAX_FITS_BYTES: u64 = 256_000_000;

/// Why a fit record cannot be read back ([`FitArtifact::from_record`],
/// [`entry_of`]).
#[derive(Debug, thiserror::Error)]
pub enum RecordError {
    /// The record has no `log`.
    #[error("a record without `log`")]
    NoLog,
    /// The record has no valid `log_sha256`.
    #[error("the record of {log} has no `log_sha256` (64 hex digits)")]
    NoSha256 {
        /// The log as the record names it.
        log: String,
    },
    /// The record has no `artifact`.
    #[error("the record of {log} has no `artifact` (records written by `stickslip fit` have one; `batch` and `run` records do not)")]
    NoArtifact {
        /// The log as the record names it.
        log: String,
    },
    /// The artifact is of another format than [`FORMAT`].
    #[error("the record of {log} is artifact format {}, this stickslip reads format {FORMAT}: refit with this version", .format.map_or("?".into(), |f| f.to_string()))]
    Format {
        /// The log as the record names it.
        log: String,
        /// The artifact's format (None: missing or not a number).
        format: Option<u64>,
    },
    /// The artifact does not read back as a fit.
    #[error("the artifact of {log} cannot be read: {source}")]
    Unreadable {
        /// The log as the record names it.
        log: String,
        /// Why.
        source: ExactJsonError,
    },
}

/// Why a value has no exact JSON form ([`to_exact_json`]) or cannot be
/// read back from it ([`from_exact_json`]).
#[derive(Debug, thiserror::Error)]
pub enum ExactJsonError {
    /// The value could not be serialized (what serde said).
    #[error(transparent)]
    Serialize(ciborium::value::Error),
    /// The JSON does not deserialize to the type asked for (what serde said).
    #[error(transparent)]
    Deserialize(ciborium::value::Error),
    /// An integer beyond the range of JSON's (i64 and u64).
    #[error("integer {0} out of range")]
    IntegerOutOfRange(i128),
    /// A map key that is not text.
    #[error("a map key that is not text")]
    NonTextKey,
    /// A value JSON cannot hold (bytes, tags; its debug form).
    #[error("a value JSON cannot hold ({0})")]
    Unrepresentable(String),
    /// A JSON number that is not an f64.
    #[error("a number out of range")]
    NumberOutOfRange,
    /// A non-finite float's name that is not `NaN`, `inf` or `-inf`.
    #[error("`{0}` is not a non-finite float")]
    NotNonFinite(String),
}

/// The saved state of one fit.
#[derive(Serialize, Deserialize)]
struct Saved {
    format: u32,
    rig: RigMeta,
    fit: LogFit,
}

/// One fitted log as saved: what `batch` and `validate` read from a log
/// besides the fit (its rig record, with `recorded_at`; the measured drive
/// and normal force are in the fit), the fit, and the identity of the file.
#[derive(Debug, Clone)]
pub struct FitArtifact {
    /// The log as named when it was fitted.
    pub log: PathBuf,
    /// SHA-256 (hex) of the log file it was fitted on.
    pub log_sha256: String,
    /// The log's rig record.
    pub rig: RigMeta,
    /// The fit.
    pub fit: LogFit,
}

/// A record of a log that could not be fitted (kept through shards and
/// merges; `batch --fits` reports it as a failed log).
#[derive(Debug, Clone, Serialize)]
pub struct FailedFit {
    /// The log as named.
    #[serde(serialize_with = "path_display")]
    pub log: PathBuf,
    /// Its SHA-256 where the file could be read.
    pub log_sha256: Option<String>,
    /// The error.
    pub error: String,
}

/// One entry of a fits file.
#[derive(Debug, Clone)]
pub enum FitEntry {
    /// A fit, reusable.
    Fitted(Box<FitArtifact>),
    /// A log that failed.
    Failed(FailedFit),
}

impl FitEntry {
    /// The log as named in the record.
    pub fn log(&self) -> &Path {
        match self {
            FitEntry::Fitted(a) => &a.log,
            FitEntry::Failed(f) => &f.log,
        }
    }
    /// The record's `log_sha256` (None: a failed log that could not be read).
    pub fn log_sha256(&self) -> Option<&str> {
        match self {
            FitEntry::Fitted(a) => Some(&a.log_sha256),
            FitEntry::Failed(f) => f.log_sha256.as_deref(),
        }
    }
}

/// One `fits` entry as written (`fit`, `batch`, `run`): a fitted log's
/// record, a failed log's, or a saved fit's keys alone. Untagged: each
/// variant serialises as its own keys.
#[derive(Debug, Clone, Serialize)]
#[serde(untagged)]
pub enum FitRecord {
    /// A fitted log ([`record`], [`FitArtifact::fit_record`]).
    Fitted(Box<FittedRecord>),
    /// A log that failed ([`failed_record`]).
    Failed(FailedFit),
    /// A fit without its log's record: a plan's saved fit whose log could
    /// not be read again ([`LogFit::json`]'s keys only).
    FitOnly(Box<LogFitJson>),
}

/// The record of a fitted log: the interface keys of [`LogFit::json`]
/// plus `log_sha256`, `rig` and `recorded_at` (`null` where unknown), and
/// in the records `fit` writes, `artifact`.
#[derive(Debug, Clone, Serialize)]
pub struct FittedRecord {
    /// The fit's keys (flattened).
    #[serde(flatten)]
    pub fit: LogFitJson,
    /// SHA-256 (hex) of the log file it was fitted on (`null`: unknown).
    pub log_sha256: Option<String>,
    /// The log's rig record (as [`RigMeta::to_json`] writes it).
    #[serde(serialize_with = "rig_json")]
    pub rig: RigMeta,
    /// When the log was recorded (the rig record's).
    pub recorded_at: Option<String>,
    /// The saved fit in exact JSON (`{"format": 1, "rig": …, "fit": …}`,
    /// see the module doc); absent from `batch` and `run` records.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub artifact: Option<Value>,
}

fn rig_json<S: serde::Serializer>(rig: &RigMeta, s: S) -> std::result::Result<S::Ok, S::Error> {
    rig.to_json().serialize(s)
}

fn path_display<S: serde::Serializer>(p: &Path, s: S) -> std::result::Result<S::Ok, S::Error> {
    s.collect_str(&p.display())
}

/// The record of a fitted log `log` (without `artifact`).
pub fn record(fit: &LogFit, log: &Path, log_sha256: Option<&str>, rig: &RigMeta) -> FitRecord {
    FitRecord::Fitted(Box::new(FittedRecord {
        fit: fit.json(log),
        log_sha256: log_sha256.map(str::to_string),
        rig: rig.clone(),
        recorded_at: rig.recorded_at.clone(),
        artifact: None,
    }))
}

/// The record of a log that failed: `log`, `log_sha256` and `error`.
pub fn failed_record(log: &Path, log_sha256: Option<&str>, error: &str) -> FitRecord {
    FitRecord::Failed(FailedFit {
        log: log.to_path_buf(),
        log_sha256: log_sha256.map(str::to_string),
        error: error.to_string(),
    })
}

impl FitArtifact {
    /// The full record: [`record`]'s keys and `artifact`.
    pub fn fit_record(&self) -> Result<FitRecord> {
        let saved = Saved {
            format: FORMAT,
            rig: self.rig.clone(),
            fit: self.fit.clone(),
        };
        let exact = to_exact_json(&saved).map_err(|msg| Error::Input {
            path: self.log.clone(),
            msg: format!("its fit cannot be saved: {msg}"),
        })?;
        let mut r = record(&self.fit, &self.log, Some(&self.log_sha256), &self.rig);
        if let FitRecord::Fitted(f) = &mut r {
            f.artifact = Some(exact);
        }
        Ok(r)
    }

    /// [`FitArtifact::fit_record`] as a JSON value.
    pub fn to_record(&self) -> Result<Value> {
        Ok(crate::io::json::to_value(self.fit_record()?))
    }

    /// Reads one record back (`Err`: what is wrong with it).
    pub fn from_record(v: &Value) -> std::result::Result<Self, RecordError> {
        let log = v
            .get("log")
            .and_then(Value::as_str)
            .ok_or(RecordError::NoLog)?;
        let sha = v
            .get("log_sha256")
            .and_then(Value::as_str)
            .filter(|s| is_sha256(s))
            .ok_or_else(|| RecordError::NoSha256 { log: log.into() })?;
        let art = v
            .get("artifact")
            .ok_or_else(|| RecordError::NoArtifact { log: log.into() })?;
        match art.get("format").and_then(Value::as_u64) {
            Some(f) if f == u64::from(FORMAT) => {}
            format => {
                return Err(RecordError::Format {
                    log: log.into(),
                    format,
                })
            }
        }
        let saved: Saved = from_exact_json(art).map_err(|source| RecordError::Unreadable {
            log: log.into(),
            source,
        })?;
        Ok(FitArtifact {
            log: PathBuf::from(log),
            log_sha256: sha.to_string(),
            rig: saved.rig,
            fit: saved.fit,
        })
    }
}

fn is_sha256(s: &str) -> bool {
    s.len() == 64 && s.bytes().all(|b| b.is_ascii_hexdigit())
}

/// SHA-256 (hex) of a file, streamed (a long log in constant memory).
pub fn sha256_file(path: &Path) -> Result<String> {
    Ok(crate::io::sha256_file(path)?.0)
}

/// The records of a fits file (`{"fits": [...]}` from `fit --out` or
/// `merge`), in file order.
#[derive(Debug, Clone)]
pub struct FitSet {
    /// The file.
    pub source: PathBuf,
    /// Its records.
    pub entries: Vec<FitEntry>,
}

impl FitSet {
    /// Reads a fits file: every record must be a fit with its artifact or
    /// a failed log with its `error`. A part of a sharded fit (`shard` K/N
    /// with N > 1) is refused: merge the parts first.
    pub fn read(path: &Path) -> Result<FitSet> {
        let bad = |msg: String| Error::Input {
            path: path.to_path_buf(),
            msg,
        };
        let text = crate::io::paths::read_small_text(path, "fits file", MAX_FITS_BYTES)?;
        let v: Value = serde_json::from_str(&text).map_err(|e| {
            bad(format!(
                "not a fits file written by `stickslip fit --out` or `merge` ({e})"
            ))
        })?;
        if let (Some(k), Some(n)) = (
            v.get("shard").and_then(Value::as_u64),
            v.get("shards").and_then(Value::as_u64),
        ) {
            if n > 1 {
                return Err(bad(format!(
                    "is shard {k}/{n} of a sharded fit: merge every shard first (`stickslip merge PART.json... --out FITS.json`)"
                )));
            }
        }
        let records = v.get("fits").and_then(Value::as_array).ok_or_else(|| {
            bad(
                "not a fits file: no `fits` list (write one with `stickslip fit --out` or `merge`)"
                    .into(),
            )
        })?;
        let entries = records
            .iter()
            .map(entry_of)
            .collect::<std::result::Result<Vec<_>, RecordError>>()
            .map_err(|e| bad(e.to_string()))?;
        if entries.is_empty() {
            return Err(bad("holds no fits".into()));
        }
        Ok(FitSet {
            source: path.to_path_buf(),
            entries,
        })
    }

    /// Pairs the records with `logs` (also given): for each log, the index
    /// of the record with its `log_sha256`, or None (the log is to be
    /// fitted). A record naming one of the logs (the same file) whose
    /// `log_sha256` differs from that file is refused, even where another
    /// record has the file's sha256 (the file was replaced).
    pub fn match_logs(&self, logs: &[PathBuf]) -> Result<Vec<Option<usize>>> {
        logs.iter()
            .map(|log| {
                let sha = sha256_file(log)?;
                let changed = self
                    .entries
                    .iter()
                    .find(|e| same_path(e.log(), log) && e.log_sha256() != Some(sha.as_str()));
                if let Some(e) = changed {
                    return Err(Error::Input {
                        path: log.clone(),
                        msg: format!(
                            "differs from the file its fit in {} was made on (log_sha256 {}, this file {}): refit it, or give the log it was fitted on",
                            self.source.display(),
                            short(e.log_sha256().unwrap_or("unknown")),
                            short(&sha)
                        ),
                    });
                }
                Ok(self
                    .entries
                    .iter()
                    .position(|e| e.log_sha256() == Some(sha.as_str())))
            })
            .collect()
    }
}

fn short(sha: &str) -> String {
    sha.chars().take(12).collect::<String>() + "…"
}

/// Whether two paths name one file (the same text, or the same file on disk).
fn same_path(a: &Path, b: &Path) -> bool {
    a == b
        || matches!(
            (std::fs::canonicalize(a), std::fs::canonicalize(b)),
            (Ok(x), Ok(y)) if x == y
        )
}

/// Reads one record: a fit with its artifact, or a failed log.
pub fn entry_of(v: &Value) -> std::result::Result<FitEntry, RecordError> {
    if let Some(err) = v.get("error").and_then(Value::as_str) {
        let log = v
            .get("log")
            .and_then(Value::as_str)
            .ok_or(RecordError::NoLog)?;
        return Ok(FitEntry::Failed(FailedFit {
            log: PathBuf::from(log),
            log_sha256: v
                .get("log_sha256")
                .and_then(Value::as_str)
                .map(str::to_string),
            error: err.to_string(),
        }));
    }
    FitArtifact::from_record(v).map(|a| FitEntry::Fitted(Box::new(a)))
}

/// A value as exact JSON (see the module doc): `Err` names what JSON
/// cannot hold (a map with keys that are not text, bytes, tags).
pub fn to_exact_json<T: Serialize>(x: &T) -> std::result::Result<Value, ExactJsonError> {
    let c = Cbor::serialized(x).map_err(ExactJsonError::Serialize)?;
    cbor_to_json(c)
}

/// Reads a value back from [`to_exact_json`]'s form.
pub fn from_exact_json<T: DeserializeOwned>(v: &Value) -> std::result::Result<T, ExactJsonError> {
    json_to_cbor(v)?
        .deserialized()
        .map_err(ExactJsonError::Deserialize)
}

fn cbor_to_json(c: Cbor) -> std::result::Result<Value, ExactJsonError> {
    Ok(match c {
        Cbor::Null => Value::Null,
        Cbor::Bool(b) => Value::Bool(b),
        Cbor::Text(s) => Value::String(s),
        Cbor::Integer(i) => {
            let i = i128::from(i);
            if let Ok(u) = u64::try_from(i) {
                json!(u)
            } else if let Ok(s) = i64::try_from(i) {
                json!(s)
            } else {
                return Err(ExactJsonError::IntegerOutOfRange(i));
            }
        }
        Cbor::Float(x) if x.is_finite() => json!(x),
        Cbor::Float(x) => {
            let name = if x.is_nan() {
                "NaN"
            } else if x > 0.0 {
                "inf"
            } else {
                "-inf"
            };
            json!({ NON_FINITE: name })
        }
        Cbor::Array(a) => Value::Array(
            a.into_iter()
                .map(cbor_to_json)
                .collect::<std::result::Result<_, _>>()?,
        ),
        Cbor::Map(m) => {
            let mut out = Map::new();
            for (k, v) in m {
                let Cbor::Text(k) = k else {
                    return Err(ExactJsonError::NonTextKey);
                };
                out.insert(k, cbor_to_json(v)?);
            }
            Value::Object(out)
        }
        other => return Err(ExactJsonError::Unrepresentable(format!("{other:?}"))),
    })
}

fn json_to_cbor(v: &Value) -> std::result::Result<Cbor, ExactJsonError> {
    Ok(match v {
        Value::Null => Cbor::Null,
        Value::Bool(b) => Cbor::Bool(*b),
        Value::String(s) => Cbor::Text(s.clone()),
        Value::Number(n) => {
            if let Some(u) = n.as_u64() {
                Cbor::Integer(u.into())
            } else if let Some(i) = n.as_i64() {
                Cbor::Integer(i.into())
            } else {
                Cbor::Float(n.as_f64().ok_or(ExactJsonError::NumberOutOfRange)?)
            }
        }
        Value::Array(a) => Cbor::Array(
            a.iter()
                .map(json_to_cbor)
                .collect::<std::result::Result<_, _>>()?,
        ),
        Value::Object(m) => {
            if m.len() == 1 {
                if let Some(Value::String(name)) = m.get(NON_FINITE) {
                    return Ok(Cbor::Float(match name.as_str() {
                        "NaN" => f64::NAN,
                        "inf" => f64::INFINITY,
                        "-inf" => f64::NEG_INFINITY,
                        _ => return Err(ExactJsonError::NotNonFinite(name.clone())),
                    }));
                }
            }
            Cbor::Map(
                m.iter()
                    .map(|(k, v)| Ok((Cbor::Text(k.clone()), json_to_cbor(v)?)))
                    .collect::<std::result::Result<_, ExactJsonError>>()?,
            )
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exact_json_keeps_every_float() {
        let xs = vec![
            0.1,
            -0.0,
            f64::MIN_POSITIVE,
            5e-324,
            1.0 / 3.0,
            f64::MAX,
            f64::INFINITY,
            f64::NEG_INFINITY,
            1e300,
        ];
        let v = to_exact_json(&(xs.clone(), Some(f64::NAN), 7u64, "x")).unwrap();
        let text = serde_json::to_string(&v).unwrap();
        let back: (Vec<f64>, Option<f64>, u64, String) =
            from_exact_json(&serde_json::from_str(&text).unwrap()).unwrap();
        for (a, b) in xs.iter().zip(&back.0) {
            assert_eq!(a.to_bits(), b.to_bits(), "{a} came back as {b}");
        }
        assert!(back.1.unwrap().is_nan());
        assert_eq!((back.2, back.3.as_str()), (7, "x"));
    }
}
