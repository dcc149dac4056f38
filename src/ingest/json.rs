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
    warnings: &'a [String],
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
            out: out.map(|p| p.display().to_string()),
        };
        // Not `io::json::to_value`: `io` depends on `ingest` (it writes
        // runs as Parquet), so `ingest` must not depend on `io`.
        serde_json::to_value(report)
            .unwrap_or_else(|e| serde_json::json!({ "error": e.to_string() }))
    }
}
