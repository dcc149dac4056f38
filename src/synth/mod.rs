//! # Synth: a virtual rig that writes rig logs with known truth
//!
//! [`generate`] runs the simulator on a rig given in SI units
//! ([`RigSpec`], [`FrictionSpec`], a normal force) through a test
//! ([`TestSpec`]: a characteristic test at one frequency after a warm-up, a
//! stepped sweep with dwells and 0.5 s ramps, or a continuous linear chirp),
//! samples the **exact** trajectory at each sensor's own sample times and
//! passes it through a sensor model per channel ([`SensorModel`]). [`write()`]
//! then writes the log as MCAP, DAQ CSV + channel map, or Parquet (the
//! formats of `docs/rig-log-format.md`), atomically, and the ground
//! truth into `truth.json` beside it.
//!
//! ## The physics
//! The engine works in the paper's dimensionless variables with the **true**
//! drive amplitude as length scale (the rig really moves with it):
//! τ = t·ω, ω = √(K2/M2); ζ = x/A_true; ρ = R/(A_true·K2); D* = a/√(K2·M2);
//! a Stribeck velocity v_s becomes v_s/(A_true·ω). The logged signals are
//! x0 = A_true·ζ0(τ) (the drive), x1 = A_true·ζ1, x2 = A_true·ζ2,
//! v2 = A_true·ω·ζ2', a2 = A_true·ω²·ζ2'' (the state derivative the engine
//! hands to its observer), normal force = N. A characteristic test with an
//! affine law uses the exact event-driven engine; a Stribeck law and every
//! sweep ramp or chirp use the numerical engine (Dormand–Prince, tolerance
//! [`SynthConfig::rtol`]); stepped-sweep dwells with affine laws are exact.
//! The rig starts at rest (M2 sticking at 0); a characteristic test runs
//! `warmup_s` before the log starts, sweeps start logging at rest.
//!
//! ## The sensors
//! Per channel: sample rate, DAQ buffers of `buffer_s`, a start offset
//! within the first sample interval, buffer starts jittered uniformly by up
//! to ±`jitter_ns`, lost buffers (probability per buffer), dropouts (a burst
//! of 1..=`dropout_burst_max` nulls starting with probability `p_dropout`
//! per sample). A value is
//! `quantise(clip(gain·(1 + drift·t)·lowpass(u) + offset + noise))` with
//! Gaussian noise of σ = `noise`, saturation at `clip_low`/`clip_high`
//! (or at fractions of the channel's swing) and rounding to multiples of
//! `quant`; t is the time from the log start. A low-pass of order ≥ 2 is a
//! Butterworth filter (see `butterworth`).
//! The first-order low-pass y' = (u − y)/T (T = 1/(2π f_c)) is integrated
//! exactly for an input that is linear between points of a grid
//! [`LOWPASS_SUBSTEPS`] times finer than the channel's sampling (first-order
//! hold); the input on that grid is the exact trajectory, so the only
//! approximation is the linear interpolation of u over dt/8. The filter
//! starts 10·T before the channel's first sample (or at the rig's start)
//! with y = u.
//!
//! Tables (CSV, Parquet) are written on one common time base at
//! [`SynthConfig::table_rate_hz`]: every column is sampled at the row times
//! (plus the column's `shift_s` for CSV maps) with its own sensor model; DAQ
//! buffers, jitter and lost buffers do not apply there (dropouts are empty
//! cells / nulls).
//!
//! ## Physics defects (tests only)
//! [`PhysicsDefects`]: friction levels that change along the stroke, a
//! hardening coupling spring and direction-dependent friction levels. With
//! any of them the trajectory comes from a dedicated Runge–Kutta
//! integrator with event location (`defects`); the engines are untouched.
//! The truth entry gets a `defects` object.
//!
//! Everything random comes from one seed (xoshiro256**, [`crate::stats::Rng`]), one stream
//! per channel: the same configuration and seed give the same bytes.

mod butterworth;
mod config;
mod defects;
mod drive;
mod generate;
mod sensor;
mod truth;
mod write;

use config::*;
pub use config::{FrictionSpec, LawFamily, LogFormat, RigSpec, SynthConfig, TestSpec};
pub use defects::PhysicsDefects;
use defects::*;
use drive::*;
pub use generate::generate;
use generate::*;
pub use sensor::{SensorModel, Sensors};
use truth::*;

use crate::ingest::{Quantity, RigMeta, SweepKind, TestKind, FORMAT_VERSION};
use crate::io::json::num;
use crate::model::{Absorber, Drive, Law, Model, RigConstants, Scales, Schedule, Segment};
use crate::sim::engine::{Event, EventKind, Init, Observer, RunEnd, Sim, Status};
use crate::sim::numeric::{NumericOptions, NumericSim};
use crate::sim::schedule::{run_schedule, SegmentObserver};
use crate::stats::Rng;
use serde::{Deserialize, Serialize};
use serde_json::{json, Value};
use std::collections::BTreeMap;
use std::f64::consts::PI;

pub use write::{write, Written};

/// Rig clock (ns) of the log start: 2023-11-14T22:13:20Z.
pub const LOG_START_NS: u64 = 1_700_000_000_000_000_000;
/// The log start as text (the `recorded_at` of the `rig` record).
const LOG_START_TEXT: &str = "2023-11-14T22:13:20Z";
/// Fine-grid points per sample interval of a low-passed channel.
pub const LOWPASS_SUBSTEPS: usize = 8;

/// Why a synthetic log could not be made.
#[derive(Debug, thiserror::Error)]
pub enum SynthError {
    /// A configuration value is out of range.
    #[error("{0}")]
    Config(String),
    /// The simulation failed or ended early.
    #[error("simulation: {0}")]
    Sim(String),
}

fn bad(msg: impl Into<String>) -> SynthError {
    SynthError::Config(msg.into())
}

fn positive(name: &str, v: f64) -> Result<(), SynthError> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(bad(format!("{name} must be finite and > 0 (got {v})")))
    }
}

fn non_negative(name: &str, v: f64) -> Result<(), SynthError> {
    if v.is_finite() && v >= 0.0 {
        Ok(())
    } else {
        Err(bad(format!("{name} must be finite and >= 0 (got {v})")))
    }
}

/// One DAQ buffer: values (SI) at `t0_ns + i·dt_ns`, `None` = dropout.
#[derive(Debug, Clone, PartialEq)]
pub struct Buffer {
    /// Rig clock of the first sample (ns).
    pub t0_ns: u64,
    /// Values in SI.
    pub values: Vec<Option<f64>>,
}

/// One written channel.
#[derive(Debug, Clone, PartialEq)]
pub struct SynthChannel {
    /// What it measures.
    pub quantity: Quantity,
    /// Its sensor model.
    pub sensor: SensorModel,
    /// Sample interval (ns).
    pub dt_ns: u64,
    /// Time shift of a CSV column (s; 0 elsewhere).
    pub shift_s: f64,
    /// The buffers written (lost ones are absent). Tables: one buffer.
    pub buffers: Vec<Buffer>,
    /// Buffers lost.
    pub lost_buffers: usize,
    /// Null samples written.
    pub null_samples: usize,
    /// Offset of the first sample after the log start (ns).
    pub first_sample_offset_ns: u64,
    /// Saturation levels applied (SI; −∞/+∞: none) and the number of
    /// written samples at one of them.
    pub clip: (f64, f64, usize),
}

impl SynthChannel {
    /// Every written sample: (seconds from the log start, value in SI with
    /// NaN for a dropout). Tables include the column's time shift.
    pub fn samples(&self) -> (Vec<f64>, Vec<f64>) {
        let mut t = Vec::new();
        let mut v = Vec::new();
        for b in &self.buffers {
            for (i, x) in b.values.iter().enumerate() {
                let ns = (b.t0_ns - LOG_START_NS) + i as u64 * self.dt_ns;
                t.push(ns as f64 * 1e-9 + self.shift_s);
                v.push(x.unwrap_or(f64::NAN));
            }
        }
        (t, v)
    }
}

/// A `/drive/setpoint` message.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SynthSetpoint {
    /// Rig clock (ns).
    pub t_ns: u64,
    /// Commanded frequency (Hz).
    pub frequency_hz: f64,
    /// Commanded (nominal) amplitude (m).
    pub amplitude_m: f64,
}

/// A generated log, in memory.
#[derive(Debug, Clone)]
pub struct SynthLog {
    /// Its configuration.
    pub config: SynthConfig,
    /// The `rig` metadata record (string values).
    pub rig_record: BTreeMap<String, String>,
    /// The channels, in canonical order.
    pub channels: Vec<SynthChannel>,
    /// Setpoint messages (sweeps).
    pub setpoints: Vec<SynthSetpoint>,
    /// Table row count (CSV/Parquet).
    pub table_rows: usize,
    /// The ground truth (the file's entry of truth.json).
    pub truth: Value,
}

impl SynthLog {
    /// The channel of `q`, if written.
    pub fn channel(&self, q: Quantity) -> Option<&SynthChannel> {
        self.channels.iter().find(|c| c.quantity == q)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The first-order-hold discretisation is exact for a ramp input
    /// (steady lag tc·slope) and for a step response sampled at the grid.
    #[test]
    fn lowpass_is_exact_for_linear_input() {
        let tc = 0.01;
        let t: Vec<f64> = (0..2000).map(|i| i as f64 * 1e-4).collect();
        let u: Vec<f64> = t.iter().map(|t| 3.0 * t).collect();
        let y = lowpass(&t, &u, tc);
        // Exact: y = 3(t − tc) + 3tc·exp(−t/tc) from y(0) = 0.
        for (i, ti) in t.iter().enumerate() {
            let ex = 3.0 * (ti - tc) + 3.0 * tc * (-ti / tc).exp();
            assert!((y[i] - ex).abs() < 1e-13, "{i}: {} vs {ex}", y[i]);
        }
        // Uneven steps give the same values at shared times.
        let t2: Vec<f64> = (0..200).map(|i| i as f64 * 1e-3).collect();
        let u2: Vec<f64> = t2.iter().map(|t| 3.0 * t).collect();
        let y2 = lowpass(&t2, &u2, tc);
        for k in 0..200 {
            assert!((y2[k] - y[10 * k]).abs() < 1e-13);
        }
    }

    /// A delayed channel repeats the undelayed one `delay` later; a
    /// drifting offset adds `drift·t`; the truth names the shift that
    /// re-aligns each channel with x1.
    #[test]
    fn delay_and_offset_drift() {
        let base = SynthConfig {
            test: TestSpec::Characteristic {
                frequency_hz: 1.72,
                warmup_s: 2.0,
                duration_s: 1.0,
            },
            sensors: Sensors::ideal(),
            ..SynthConfig::paper(5)
        };
        let mut cfg = base.clone();
        cfg.sensors.x2.delay_s = 0.003;
        cfg.sensors.v2.offset_drift_per_s = 0.002;
        let (a, b) = (generate(&base).unwrap(), generate(&cfg).unwrap());
        let (_, x2a) = a.channel(Quantity::X2).unwrap().samples();
        let (_, x2b) = b.channel(Quantity::X2).unwrap().samples();
        for i in 3..x2a.len() {
            assert!((x2b[i] - x2a[i - 3]).abs() < 1e-12, "{i}");
        }
        let (t, va) = a.channel(Quantity::V2).unwrap().samples();
        let (_, vb) = b.channel(Quantity::V2).unwrap().samples();
        for i in 0..va.len() {
            assert!((vb[i] - va[i] - 0.002 * t[i]).abs() < 1e-12, "{i}");
        }
        assert_eq!(b.truth["channel_delays_s"]["x2"], -0.003);
        assert_eq!(b.truth["channel_delays_s"]["v2"], 0.0);
        let mut c = base.clone();
        c.sensors.v2.delay_s = f64::NAN;
        assert!(generate(&c).unwrap_err().to_string().contains("delay_s"));
    }

    #[test]
    fn bad_configs_are_refused() {
        let mut c = SynthConfig::paper(1);
        c.rig.m2_kg = -1.0;
        assert!(generate(&c).unwrap_err().to_string().contains("M2"));
        let mut c = SynthConfig::paper(1);
        c.friction.rd_n = 2.0 * c.friction.rs_n;
        assert!(generate(&c).unwrap_err().to_string().contains("Rd"));
        let mut c = SynthConfig::paper(1);
        c.sensors.x1.jitter_ns = 600_000;
        assert!(generate(&c).unwrap_err().to_string().contains("jitter"));
        let mut c = SynthConfig::paper(1);
        c.csv_shift_s.insert("x0".into(), -0.004);
        assert!(generate(&c).unwrap_err().to_string().contains("CSV"));
    }
}
