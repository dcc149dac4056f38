//! JSON number helpers shared by every output: a non-finite float is
//! written as `null` (JSON has no NaN or infinity), an interval as a
//! two-element list.

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
