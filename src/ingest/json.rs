//! The JSON report of an ingested run (the `ingest` contract's keys), as
//! typed structs serialised by serde (non-finite floats are written as
//! `null`). The rig metadata stays a map: its extra keys come from the log.

use super::{Channel, Gap, Run, Setpoint};
use serde::Serialize;
use serde_json::Value;
use std::path::Path;

/// One channel as recorded (before resampling).
#[derive(Serialize)]
struct ChannelOut<'a> {
    name: &'a str,
    rate_hz: f64,
    samples: usize,
    unit: &'a str,
    source: &'a str,
    dropouts: usize,
    start_s: Option<f64>,
    end_s: Option<f64>,
}

impl<'a> From<&'a Channel> for ChannelOut<'a> {
    fn from(c: &'a Channel) -> Self {
        ChannelOut {
            name: c.name(),
            rate_hz: c.rate_hz,
            samples: c.t.len(),
            unit: c.unit(),
            source: &c.source,
            dropouts: c.dropouts,
            start_s: c.t.first().copied(),
            end_s: c.t.last().copied(),
        }
    }
}

/// One gap in a channel.
#[derive(Serialize)]
struct GapOut<'a> {
    channel: &'a str,
    start_s: f64,
    end_s: f64,
    kind: &'static str,
}

impl<'a> From<&'a Gap> for GapOut<'a> {
    fn from(g: &'a Gap) -> Self {
        GapOut {
            channel: &g.channel,
            start_s: g.start_s,
            end_s: g.end_s,
            kind: g.kind.as_str(),
        }
    }
}

/// One drive set point.
#[derive(Serialize)]
struct SetpointOut {
    t_s: f64,
    frequency_hz: f64,
    amplitude_m: Option<f64>,
}

impl From<&Setpoint> for SetpointOut {
    fn from(s: &Setpoint) -> Self {
        SetpointOut {
            t_s: s.t_s,
            frequency_hz: s.frequency_hz,
            amplitude_m: s.amplitude_m,
        }
    }
}

/// The whole report.
#[derive(Serialize)]
struct RunOut<'a> {
    log: String,
    format: &'static str,
    test: &'static str,
    samples: usize,
    rate_hz: f64,
    duration_s: f64,
    channels: Vec<ChannelOut<'a>>,
    has_acceleration: bool,
    rig: Value,
    gaps: Vec<GapOut<'a>>,
    setpoints: Vec<SetpointOut>,
    #[serde(serialize_with = "crate::warning::as_messages")]
    warnings: &'a [crate::warning::Warning],
    /// One stable code per warning (`crate::warning::Warning::code`).
    warning_codes: Vec<&'static str>,
    channel_delays_s: Value,
    channel_delays_interval_s: Value,
    velocity_consistency: Value,
    acceleration_consistency: Value,
    out: Option<String>,
}

impl Run {
    /// The JSON report of this run (keys fixed by `interface.md`); `out` is
    /// where its canonical Parquet copy was written, if anywhere.
    pub fn to_json(&self, out: Option<&Path>) -> Value {
        let report = RunOut {
            log: self.source.display().to_string(),
            format: self.format.as_str(),
            test: self.rig.test.as_str(),
            samples: self.samples(),
            rate_hz: self.resampled.rate_hz,
            duration_s: self.duration_s(),
            channels: self.channels.iter().map(ChannelOut::from).collect(),
            has_acceleration: self.has_acceleration,
            rig: self.rig.to_json(),
            gaps: self.gaps.iter().map(GapOut::from).collect(),
            setpoints: self.setpoints.iter().map(SetpointOut::from).collect(),
            warnings: &self.warnings,
            warning_codes: crate::warning::codes(&self.warnings),
            channel_delays_s: self.delays.shifts_json(),
            channel_delays_interval_s: self.delays.intervals_json(),
            velocity_consistency: self.delays.velocity_json(),
            acceleration_consistency: self.delays.acceleration_json(),
            out: out.map(|p| p.display().to_string()),
        };
        // Not `io::json::to_value`: `io` depends on `ingest` (it writes
        // runs as Parquet), so `ingest` must not depend on `io`.
        serde_json::to_value(report)
            .unwrap_or_else(|e| serde_json::json!({ "error": e.to_string() }))
    }
}

impl super::ChannelDelays {
    /// `channel_delays_s`: channel → the shift applied (s), `null` where it
    /// could not be estimated (the declared shift was still applied).
    pub fn shifts_json(&self) -> Value {
        let m: serde_json::Map<String, Value> = self
            .channels
            .iter()
            .map(|c| {
                let v = match c.estimated_s {
                    Some(_) => fin(c.shift_s),
                    None => Value::Null,
                };
                (c.quantity.name().to_string(), v)
            })
            .collect();
        Value::Object(m)
    }

    /// `channel_delays_interval_s`: channel → [low, high] (95 %) or `null`.
    pub fn intervals_json(&self) -> Value {
        let m: serde_json::Map<String, Value> = self
            .channels
            .iter()
            .map(|c| {
                let v = match c.interval_s {
                    Some([a, b]) if a.is_finite() && b.is_finite() => {
                        serde_json::json!([a.min(b), a.max(b)])
                    }
                    _ => Value::Null,
                };
                (c.quantity.name().to_string(), v)
            })
            .collect();
        Value::Object(m)
    }

    /// `velocity_consistency`: v2 against d/dt x2 (gain, offset, drift,
    /// residual over noise), `null` where it was not measured.
    pub fn velocity_json(&self) -> Value {
        match &self.velocity {
            None => Value::Null,
            Some(v) => serde_json::json!({
                "gain": fin(v.gain),
                "gain_se": fin(v.gain_se),
                "offset_m_per_s": fin(v.offset_m_per_s),
                "drift_m_per_s2": fin(v.drift_m_per_s2),
                "drift_se_m_per_s2": fin(v.drift_se),
                "residual_ratio": fin(v.residual_ratio),
                "drift_corrected": v.drift_corrected,
                "gain_corrected": v.gain_corrected,
            }),
        }
    }
    /// `acceleration_consistency`: a2's gain against x2 (through d/dt v2
    /// or d²/dt² x2), `null` where it was not measured.
    pub fn acceleration_json(&self) -> Value {
        match &self.acceleration {
            None => Value::Null,
            Some(a) => serde_json::json!({
                "gain": fin(a.gain),
                "gain_se": fin(a.gain_se),
                "gain_corrected": a.gain_corrected,
            }),
        }
    }
}

/// A finite number, or `null`.
fn fin(x: f64) -> Value {
    if x.is_finite() {
        serde_json::json!(x)
    } else {
        Value::Null
    }
}
