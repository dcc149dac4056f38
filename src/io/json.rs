//! JSON number helpers shared by every output: a non-finite float is
//! written as `null` (JSON has no NaN or infinity), an interval as a
//! two-element list; a result is written pretty and atomically
//! ([`write_pretty`]).

use serde_json::{json, Value};

/// A float for JSON: non-finite values become `null`.
pub fn num(x: f64) -> Value {
    if x.is_finite() {
        json!(x)
    } else {
        Value::Null
    }
}

/// An interval for JSON: `[low, high]`, or `null` where absent or not
/// finite.
pub fn interval(i: Option<(f64, f64)>) -> Value {
    match i {
        Some((a, b)) if a.is_finite() && b.is_finite() => json!([a, b]),
        _ => Value::Null,
    }
}

/// An interval for typed JSON structs: serialises as [`interval`] does
/// (`[low, high]`, or `null` where absent or not finite).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Interval(pub Option<(f64, f64)>);

impl From<(f64, f64)> for Interval {
    fn from(i: (f64, f64)) -> Self {
        Interval(Some(i))
    }
}

impl From<Option<(f64, f64)>> for Interval {
    fn from(i: Option<(f64, f64)>) -> Self {
        Interval(i)
    }
}

impl serde::Serialize for Interval {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        interval(self.0).serialize(s)
    }
}

/// A typed output struct as a JSON value. Our output structs hold only
/// numbers, strings, lists and string-keyed maps, which always serialise;
/// should one ever fail, the value says so (`{"error": …}`) rather than
/// abort the command.
pub fn to_value<T: serde::Serialize>(out: T) -> Value {
    serde_json::to_value(out).unwrap_or_else(|e| json!({ "error": e.to_string() }))
}

/// Writes a JSON result to `path` (pretty, atomically, through the write
/// transaction: `--out`).
pub fn write_pretty(path: &std::path::Path, value: &Value) -> crate::Result<()> {
    let text = serde_json::to_string_pretty(value).map_err(|e| crate::Error::Input {
        path: path.to_path_buf(),
        msg: e.to_string(),
    })?;
    super::write_atomic(path, text.as_bytes())
}
