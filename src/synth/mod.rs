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
//! per sample). A value is `quantise(gain·lowpass(u) + offset + noise)` with
//! Gaussian noise of σ = `noise` and rounding to multiples of `quant`.
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
//! Everything random comes from one seed (xoshiro256**, [`crate::stats::Rng`]), one stream
//! per channel: the same configuration and seed give the same bytes.

mod write;

use crate::ingest::{Quantity, RigMeta, SweepKind, TestKind, FORMAT_VERSION};
use crate::io::json::num;
use crate::model::{Absorber, Drive, Law, LawKind, Model, RigConstants, Scales, Schedule, Segment};
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

/// Rig constants in SI.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RigSpec {
    /// Main mass M1 (kg).
    pub m1_kg: f64,
    /// Absorber mass M2 (kg).
    pub m2_kg: f64,
    /// Spring K1 (base to M1, N/m).
    pub k1_n_per_m: f64,
    /// Spring K2 (M1 to M2, N/m).
    pub k2_n_per_m: f64,
    /// Viscous damping d between the masses (N s/m).
    pub d_n_s_per_m: f64,
    /// Nominal drive amplitude A written in the `rig` record (m).
    pub drive_amplitude_nominal_m: f64,
    /// The amplitude the shaker really moves with (m).
    pub drive_amplitude_true_m: f64,
}

impl RigSpec {
    /// The paper's rig: M1 = 8.35 kg, M2 = 2.0875 kg, K1 = K2 = 670 N/m,
    /// D = 0.003, A = 2.5 mm.
    pub fn paper() -> Self {
        let (m2, k2) = (2.0875, 670.0);
        Self {
            m1_kg: 8.35,
            m2_kg: m2,
            k1_n_per_m: 670.0,
            k2_n_per_m: k2,
            d_n_s_per_m: 0.003 * (k2 * m2).sqrt(),
            drive_amplitude_nominal_m: 0.0025,
            drive_amplitude_true_m: 0.0025,
        }
    }

    /// The rig's constants (masses, springs, damper).
    pub fn constants(&self) -> RigConstants {
        RigConstants {
            m1_kg: self.m1_kg,
            m2_kg: self.m2_kg,
            k1_n_per_m: self.k1_n_per_m,
            k2_n_per_m: self.k2_n_per_m,
            d_n_s_per_m: self.d_n_s_per_m,
        }
    }

    /// ω = √(K2/M2) (rad/s): τ = ω·t.
    pub fn omega_ref(&self) -> f64 {
        self.constants().omega_ref()
    }

    /// The dimensionless absorber (m, k, D).
    pub fn absorber(&self) -> Absorber {
        self.constants().absorber()
    }

    /// Checks every constant.
    pub fn validate(&self) -> Result<(), SynthError> {
        positive("M1 (m1_kg)", self.m1_kg)?;
        positive("M2 (m2_kg)", self.m2_kg)?;
        positive("K1 (k1_n_per_m)", self.k1_n_per_m)?;
        positive("K2 (k2_n_per_m)", self.k2_n_per_m)?;
        non_negative("d (d_n_s_per_m)", self.d_n_s_per_m)?;
        positive("nominal drive amplitude", self.drive_amplitude_nominal_m)?;
        positive("true drive amplitude", self.drive_amplitude_true_m)
    }
}

/// Family of a friction law as the truth files spell it (`static_dynamic`,
/// plus `linear` for any other affine law). Test data keep their spelling;
/// everything else speaks [`LawKind`] ([`LawFamily::kind`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LawFamily {
    /// Rd = Rs, a = 0.
    Coulomb,
    /// Rd = Rs, a < 0.
    Decreasing,
    /// Rd < Rs, a = 0.
    StaticDynamic,
    /// Rd + (Rs − Rd)·exp(−(v/vs)²) + a·v.
    Stribeck,
    /// Any other affine law Rd + a·v.
    Linear,
}

impl LawFamily {
    /// The shared family (None for `linear`, which has no family of its own).
    pub fn kind(self) -> Option<LawKind> {
        match self {
            LawFamily::Coulomb => Some(LawKind::Coulomb),
            LawFamily::Decreasing => Some(LawKind::Decreasing),
            LawFamily::StaticDynamic => Some(LawKind::StaticDynamic),
            LawFamily::Stribeck => Some(LawKind::Stribeck),
            LawFamily::Linear => None,
        }
    }

    /// The family's name.
    pub fn as_str(self) -> &'static str {
        match self {
            LawFamily::Coulomb => "coulomb",
            LawFamily::Decreasing => "decreasing",
            LawFamily::StaticDynamic => "static_dynamic",
            LawFamily::Stribeck => "stribeck",
            LawFamily::Linear => "linear",
        }
    }
}

/// A friction law in SI: sliding magnitude g(v) = Rd + a·v
/// (+ (Rs − Rd)·exp(−(v/vs)²) with a Stribeck velocity), static threshold Rs.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct FrictionSpec {
    /// Static threshold Rs (N).
    pub rs_n: f64,
    /// Dynamic level Rd ≤ Rs (N).
    pub rd_n: f64,
    /// Slope a of the characteristic (N s/m).
    pub slope_n_s_per_m: f64,
    /// Stribeck velocity vs (m/s), if any.
    pub stribeck_velocity_m_per_s: Option<f64>,
}

impl FrictionSpec {
    /// The family this law belongs to.
    pub fn family(&self) -> LawFamily {
        if self.stribeck_velocity_m_per_s.is_some() {
            LawFamily::Stribeck
        } else if self.rd_n == self.rs_n && self.slope_n_s_per_m == 0.0 {
            LawFamily::Coulomb
        } else if self.rd_n == self.rs_n && self.slope_n_s_per_m < 0.0 {
            LawFamily::Decreasing
        } else if self.rd_n < self.rs_n && self.slope_n_s_per_m == 0.0 {
            LawFamily::StaticDynamic
        } else {
            LawFamily::Linear
        }
    }

    /// The dimensionless law for the rig, with forces divided by A·K2 for
    /// amplitude `a_m` and velocities by A·ω (unchecked: the model checks
    /// it).
    pub fn law(&self, rig: &RigSpec, a_m: f64) -> Law {
        let s = Scales::from_rig(&rig.constants(), a_m);
        let (rho_s, rho_d) = (self.rs_n / s.force_n, self.rd_n / s.force_n);
        let slope = self.slope_n_s_per_m / s.slope_n_s_per_m;
        match self.stribeck_velocity_m_per_s {
            None => Law::Linear {
                rho_s,
                rho_d,
                slope,
            },
            Some(vs) => Law::Stribeck {
                rho_s,
                rho_d,
                slope,
                v_s: vs / s.velocity_m_per_s,
            },
        }
    }

    /// Checks the values (the dimensionless law is checked by the model).
    pub fn validate(&self) -> Result<(), SynthError> {
        non_negative("Rs (static friction)", self.rs_n)?;
        non_negative("Rd (dynamic friction)", self.rd_n)?;
        if self.rd_n > self.rs_n {
            return Err(bad(format!(
                "Rd ({} N) must not exceed Rs ({} N)",
                self.rd_n, self.rs_n
            )));
        }
        if !self.slope_n_s_per_m.is_finite() {
            return Err(bad("slope a must be finite"));
        }
        if let Some(vs) = self.stribeck_velocity_m_per_s {
            positive("Stribeck velocity", vs)?;
        }
        Ok(())
    }
}

/// The test the virtual rig runs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum TestSpec {
    /// Fixed drive frequency; the rig runs `warmup_s` from rest before the
    /// log starts, then logs `duration_s`.
    Characteristic {
        /// Drive frequency (Hz).
        frequency_hz: f64,
        /// Unlogged run-in from rest (s).
        warmup_s: f64,
        /// Logged time (s).
        duration_s: f64,
    },
    /// Stepped sweep from rest: `preroll_s` at the first setpoint, then for
    /// each setpoint a `ramp_s` linear ramp (continuous phase; none before
    /// the first) and a dwell.
    Stepped {
        /// The setpoints (Hz), in sweep order.
        setpoints_hz: Vec<f64>,
        /// Dwell per setpoint (s): one value for all, or one per setpoint.
        dwell_s: Vec<f64>,
        /// Ramp between setpoints (s).
        ramp_s: f64,
        /// Hold at the first setpoint before its dwell (s).
        preroll_s: f64,
    },
    /// Continuous linear chirp from rest: hold at `from_hz`, ramp linearly
    /// to `to_hz` over `sweep_s`, hold at `to_hz`.
    Continuous {
        /// Start frequency (Hz).
        from_hz: f64,
        /// End frequency (Hz).
        to_hz: f64,
        /// Chirp duration (s).
        sweep_s: f64,
        /// Hold before the chirp (s).
        hold_before_s: f64,
        /// Hold after the chirp (s).
        hold_after_s: f64,
    },
}

impl TestSpec {
    /// The paper's characteristic test: 1.72 Hz, 40 s warm-up, 20 s logged.
    pub fn characteristic() -> Self {
        TestSpec::Characteristic {
            frequency_hz: 1.72,
            warmup_s: 40.0,
            duration_s: 20.0,
        }
    }

    /// A stepped sweep over `n` equally spaced setpoints in [from, to] Hz.
    pub fn stepped(from_hz: f64, to_hz: f64, n: usize, dwell_s: f64) -> Self {
        let setpoints_hz = (0..n)
            .map(|i| {
                if n == 1 {
                    from_hz
                } else {
                    from_hz + (to_hz - from_hz) * i as f64 / (n - 1) as f64
                }
            })
            .collect();
        TestSpec::Stepped {
            setpoints_hz,
            dwell_s: vec![dwell_s],
            ramp_s: 0.5,
            preroll_s: 2.0,
        }
    }

    /// The test's name in the `rig` record (`characteristic` or `sweep`).
    pub fn kind(&self) -> TestKind {
        match self {
            TestSpec::Characteristic { .. } => TestKind::Characteristic,
            _ => TestKind::Sweep,
        }
    }

    fn validate(&self) -> Result<(), SynthError> {
        match self {
            TestSpec::Characteristic {
                frequency_hz,
                warmup_s,
                duration_s,
            } => {
                positive("drive frequency", *frequency_hz)?;
                non_negative("warm-up", *warmup_s)?;
                positive("duration", *duration_s)
            }
            TestSpec::Stepped {
                setpoints_hz,
                dwell_s,
                ramp_s,
                preroll_s,
            } => {
                if setpoints_hz.is_empty() {
                    return Err(bad("a stepped sweep needs at least one setpoint"));
                }
                for f in setpoints_hz {
                    positive("setpoint frequency", *f)?;
                }
                if !(dwell_s.len() == 1 || dwell_s.len() == setpoints_hz.len()) {
                    return Err(bad(format!(
                        "give one dwell time or one per setpoint ({} setpoints, {} dwell times)",
                        setpoints_hz.len(),
                        dwell_s.len()
                    )));
                }
                for d in dwell_s {
                    positive("dwell time", *d)?;
                }
                positive("ramp time", *ramp_s)?;
                non_negative("pre-roll", *preroll_s)
            }
            TestSpec::Continuous {
                from_hz,
                to_hz,
                sweep_s,
                hold_before_s,
                hold_after_s,
            } => {
                positive("sweep start frequency", *from_hz)?;
                positive("sweep end frequency", *to_hz)?;
                positive("sweep duration", *sweep_s)?;
                positive("hold before the sweep", *hold_before_s)?;
                non_negative("hold after the sweep", *hold_after_s)
            }
        }
    }

    /// Logged duration (s).
    pub fn duration_s(&self) -> f64 {
        match self {
            TestSpec::Characteristic { duration_s, .. } => *duration_s,
            TestSpec::Stepped {
                setpoints_hz,
                dwell_s,
                ramp_s,
                preroll_s,
            } => {
                let n = setpoints_hz.len();
                preroll_s
                    + (0..n).map(|i| dwell_of(dwell_s, i)).sum::<f64>()
                    + (n.saturating_sub(1)) as f64 * ramp_s
            }
            TestSpec::Continuous {
                sweep_s,
                hold_before_s,
                hold_after_s,
                ..
            } => hold_before_s + sweep_s + hold_after_s,
        }
    }

    /// Unlogged run-in before the log starts (s).
    pub fn warmup_s(&self) -> f64 {
        match self {
            TestSpec::Characteristic { warmup_s, .. } => *warmup_s,
            _ => 0.0,
        }
    }
}

fn dwell_of(dwell_s: &[f64], i: usize) -> f64 {
    if dwell_s.len() == 1 {
        dwell_s[0]
    } else {
        dwell_s[i]
    }
}

/// The sensor model of one channel.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SensorModel {
    /// Sample rate (Hz); the sample interval is rounded to whole ns.
    pub rate_hz: f64,
    /// Gaussian noise σ (SI unit of the channel).
    pub noise: f64,
    /// Quantisation step (0: none).
    pub quant: f64,
    /// Gain (1: exact).
    pub gain: f64,
    /// Offset (SI).
    pub offset: f64,
    /// Cut-off of a first-order low-pass (Hz), if any.
    pub lowpass_hz: Option<f64>,
    /// DAQ buffer length (s; rounded to whole samples, at least one).
    pub buffer_s: f64,
    /// First sample's offset after the log start (ns); `None`: drawn
    /// uniformly within one sample interval (at least `jitter_ns`).
    pub start_offset_ns: Option<u64>,
    /// Buffer start jitter: uniform in ±`jitter_ns`.
    pub jitter_ns: u64,
    /// Probability that a buffer is lost.
    pub p_lost_buffer: f64,
    /// Probability per sample that a dropout burst starts.
    pub p_dropout: f64,
    /// Longest dropout burst (samples).
    pub dropout_burst_max: u32,
}

impl SensorModel {
    /// An ideal sensor at `rate_hz`: no noise, no quantisation, gain 1,
    /// offset 0, no filter, 100 ms buffers starting on the log start, no
    /// jitter, no losses.
    pub fn ideal(rate_hz: f64) -> Self {
        Self {
            rate_hz,
            noise: 0.0,
            quant: 0.0,
            gain: 1.0,
            offset: 0.0,
            lowpass_hz: None,
            buffer_s: 0.1,
            start_offset_ns: Some(0),
            jitter_ns: 0,
            p_lost_buffer: 0.0,
            p_dropout: 0.0,
            dropout_burst_max: 1,
        }
    }

    /// Sample interval in ns.
    pub fn dt_ns(&self) -> u64 {
        (1e9 / self.rate_hz).round() as u64
    }

    fn validate(&self, q: Quantity) -> Result<(), SynthError> {
        let name = q.name();
        let p = |what: &str| format!("sensor {name}: {what}");
        positive(&p("rate_hz"), self.rate_hz)?;
        if self.rate_hz > 1e6 {
            return Err(bad(p("rate_hz above 1 MHz is not a DAQ rate")));
        }
        non_negative(&p("noise"), self.noise)?;
        non_negative(&p("quant"), self.quant)?;
        positive(&p("gain"), self.gain)?;
        if !self.offset.is_finite() {
            return Err(bad(p("offset must be finite")));
        }
        if let Some(fc) = self.lowpass_hz {
            positive(&p("lowpass_hz"), fc)?;
        }
        positive(&p("buffer_s"), self.buffer_s)?;
        if self.jitter_ns.saturating_mul(2) >= self.dt_ns() {
            return Err(bad(p("jitter_ns must be below half the sample interval")));
        }
        for (what, v) in [
            ("p_lost_buffer", self.p_lost_buffer),
            ("p_dropout", self.p_dropout),
        ] {
            if !(v.is_finite() && (0.0..1.0).contains(&v)) {
                return Err(bad(p(&format!("{what} must be in [0, 1) (got {v})"))));
            }
        }
        if self.dropout_burst_max == 0 {
            return Err(bad(p("dropout_burst_max must be >= 1")));
        }
        Ok(())
    }
}

/// Sensor models of every channel; `a2: None` = no accelerometer,
/// `normal_force: None` = no force channel.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Sensors {
    /// `/drive/position`.
    pub x0: SensorModel,
    /// `/mass1/position`.
    pub x1: SensorModel,
    /// `/mass2/position`.
    pub x2: SensorModel,
    /// `/mass2/velocity`.
    pub v2: SensorModel,
    /// `/mass2/acceleration`.
    pub a2: Option<SensorModel>,
    /// `/friction/normal_force`.
    pub normal_force: Option<SensorModel>,
}

impl Sensors {
    /// Ideal sensors (see [`SensorModel::ideal`]): positions, velocity at
    /// 1 kHz, accelerometer at 2 kHz, normal force at 10 Hz.
    pub fn ideal() -> Self {
        Self {
            x0: SensorModel::ideal(1000.0),
            x1: SensorModel::ideal(1000.0),
            x2: SensorModel::ideal(1000.0),
            v2: SensorModel::ideal(1000.0),
            a2: Some(SensorModel::ideal(2000.0)),
            normal_force: Some(SensorModel {
                buffer_s: 0.5,
                ..SensorModel::ideal(10.0)
            }),
        }
    }

    /// A typical DAQ: noise, quantisation, ±3 µs jitter, 0.5 % lost
    /// buffers, rare short dropouts, low-passed velocity and acceleration;
    /// gains within ±1 % and offsets drawn from `seed` (a rig whose
    /// calibration errors are unknown to the analyst).
    pub fn typical(seed: u64) -> Self {
        let mut r = Rng::with_stream(seed, 0xCA11_B8A7);
        let mut s = |rate: f64, noise: f64, quant: f64, gain_err: f64, off: f64| SensorModel {
            rate_hz: rate,
            noise,
            quant,
            gain: 1.0 + r.range(-gain_err, gain_err),
            offset: r.range(-off, off),
            lowpass_hz: None,
            buffer_s: 0.1,
            start_offset_ns: None,
            jitter_ns: 3000,
            p_lost_buffer: 0.005,
            p_dropout: 2e-4,
            dropout_burst_max: 4,
        };
        let x0 = s(1000.0, 1.5e-6, 0.5e-6, 0.004, 1.5e-5);
        let x1 = s(1000.0, 3e-6, 1e-6, 0.008, 1e-4);
        let x2 = s(1000.0, 3e-6, 1e-6, 0.008, 1e-4);
        let v2 = SensorModel {
            lowpass_hz: Some(200.0),
            ..s(1000.0, 4e-4, 1e-5, 0.008, 8e-5)
        };
        let a2 = SensorModel {
            lowpass_hz: Some(250.0),
            ..s(2000.0, 0.02, 1e-3, 0.008, 0.01)
        };
        let nf = SensorModel {
            buffer_s: 0.5,
            p_dropout: 0.0,
            ..s(10.0, 0.0, 0.01, 0.008, 0.02)
        };
        Self {
            x0,
            x1,
            x2,
            v2,
            a2: Some(a2),
            normal_force: Some(nf),
        }
    }

    /// The present channels with their models, in canonical order.
    pub fn channels(&self) -> Vec<(Quantity, SensorModel)> {
        let mut v = vec![
            (Quantity::X0, self.x0),
            (Quantity::X1, self.x1),
            (Quantity::X2, self.x2),
            (Quantity::V2, self.v2),
        ];
        if let Some(a) = self.a2 {
            v.push((Quantity::A2, a));
        }
        if let Some(n) = self.normal_force {
            v.push((Quantity::NormalForce, n));
        }
        v
    }
}

/// The file format of a synthetic log.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LogFormat {
    /// MCAP, zstd chunks, summary section.
    Mcap,
    /// MCAP with lz4 chunks.
    McapLz4,
    /// MCAP with uncompressed chunks and no summary section.
    McapPlain,
    /// DAQ CSV (mm, mm/s) + `NAME.map.toml`.
    Csv,
    /// Parquet table (SI) with the rig metadata as key-value metadata.
    Parquet,
}

impl LogFormat {
    /// The `format` field of truth.json.
    pub fn as_str(self) -> &'static str {
        match self {
            LogFormat::Mcap => "mcap/zstd",
            LogFormat::McapLz4 => "mcap/lz4",
            LogFormat::McapPlain => "mcap/none/no-summary",
            LogFormat::Csv => "csv",
            LogFormat::Parquet => "parquet",
        }
    }

    /// Whether it is a table on a common time base.
    pub fn is_table(self) -> bool {
        matches!(self, LogFormat::Csv | LogFormat::Parquet)
    }
}

/// Everything the virtual rig needs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SynthConfig {
    /// Rig constants.
    pub rig: RigSpec,
    /// Friction law.
    pub friction: FrictionSpec,
    /// Normal force at the friction member (N), logged and recorded.
    pub normal_force_n: f64,
    /// The test.
    pub test: TestSpec,
    /// Sensor models.
    pub sensors: Sensors,
    /// Seed of every random choice.
    pub seed: u64,
    /// Output format (decides buffers vs a common time base).
    pub format: LogFormat,
    /// Row rate of CSV/Parquet tables (Hz).
    pub table_rate_hz: f64,
    /// CSV only: column time shifts (s) by quantity name (`x0`, …): the
    /// value in a row was taken at row time + shift.
    pub csv_shift_s: BTreeMap<String, f64>,
    /// Relative tolerance of the numerical engine (ramps, chirps, Stribeck).
    pub rtol: f64,
}

impl SynthConfig {
    /// The paper's rig with a static/dynamic pad at 2.2 N (μs = 0.42,
    /// μd = 0.34), the characteristic test at 1.72 Hz, typical sensors.
    pub fn paper(seed: u64) -> Self {
        let n = 2.2;
        Self {
            rig: RigSpec::paper(),
            friction: FrictionSpec {
                rs_n: 0.42 * n,
                rd_n: 0.34 * n,
                slope_n_s_per_m: 0.0,
                stribeck_velocity_m_per_s: None,
            },
            normal_force_n: n,
            test: TestSpec::characteristic(),
            sensors: Sensors::typical(seed),
            seed,
            format: LogFormat::Mcap,
            table_rate_hz: 1000.0,
            csv_shift_s: BTreeMap::new(),
            rtol: 1e-10,
        }
    }

    /// Checks the whole configuration.
    pub fn validate(&self) -> Result<(), SynthError> {
        self.rig.validate()?;
        non_negative("normal force", self.normal_force_n)?;
        self.friction.validate()?;
        self.test.validate()?;
        for (q, s) in self.sensors.channels() {
            s.validate(q)?;
        }
        positive("table rate", self.table_rate_hz)?;
        if !(self.rtol > 0.0 && self.rtol < 1e-3) {
            return Err(bad("rtol must be in (0, 1e-3)"));
        }
        for (k, v) in &self.csv_shift_s {
            let q = Quantity::from_name(k)
                .ok_or_else(|| bad(format!("csv shift for unknown column {k:?}")))?;
            if !v.is_finite() || v.abs() > 1.0 {
                return Err(bad(format!(
                    "csv shift of {} must be within ±1 s",
                    q.name()
                )));
            }
            if *v != 0.0 && self.format != LogFormat::Csv {
                return Err(bad("column time shifts exist in CSV channel maps only"));
            }
        }
        let model = self.model();
        model
            .validate()
            .map_err(|e| bad(format!("friction law: {e}")))?;
        Ok(())
    }

    /// The dimensionless model the engine runs (true amplitude).
    pub fn model(&self) -> Model {
        Model {
            absorber: self.rig.absorber(),
            law: self
                .friction
                .law(&self.rig, self.rig.drive_amplitude_true_m),
            stop_below: None,
        }
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

/// The drive as pieces (start τ, drive, duration) with x0/A_true = ζ0.
struct Drives(Vec<(f64, Drive, f64)>);

impl Drives {
    fn zeta0(&self, tau: f64) -> f64 {
        let i = self.0.partition_point(|(t0, _, _)| *t0 <= tau).max(1) - 1;
        let (t0, d, _) = &self.0[i];
        d.eval(tau - t0).0
    }
}

/// A sample request: engine time and the channel/point it belongs to.
#[derive(Clone, Copy)]
struct Request {
    tau: f64,
    chan: u32,
}

/// The observer: hands out the merged request times, stores each
/// channel's exact signal, and tracks the contact mode over the log.
struct Collector<'a> {
    requests: &'a [Request],
    next: usize,
    /// Per channel: exact signal at its requests, in order.
    out: Vec<Vec<f64>>,
    quantities: Vec<Quantity>,
    drives: &'a Drives,
    a: f64,
    w: f64,
    normal_force: f64,
    /// Logged window in τ.
    log: (f64, f64),
    stick_since: Option<f64>,
    stick_time: f64,
    events_in_log: u64,
    slid_in_log: bool,
    slid_before_log: bool,
}

impl Collector<'_> {
    fn add_stick(&mut self, from: f64, to: f64) {
        let (a, b) = (from.max(self.log.0), to.min(self.log.1));
        if b > a {
            self.stick_time += b - a;
        }
    }
}

impl Observer for Collector<'_> {
    fn event(&mut self, ev: &Event) {
        let in_log = ev.tau >= self.log.0 && ev.tau <= self.log.1;
        if in_log {
            self.events_in_log += 1;
        }
        match ev.kind {
            EventKind::Stick => {
                if self.stick_since.is_none() {
                    self.stick_since = Some(ev.tau);
                }
            }
            _ => {
                if let Some(s) = self.stick_since.take() {
                    self.add_stick(s, ev.tau);
                }
                if in_log {
                    self.slid_in_log = true;
                } else if ev.tau < self.log.0 {
                    self.slid_before_log = true;
                }
            }
        }
    }
    fn next_sample(&mut self) -> Option<f64> {
        self.requests.get(self.next).map(|r| r.tau)
    }
    fn sample(&mut self, tau: f64, x: &[f64; 4], dx: &[f64; 4]) {
        let r = self.requests[self.next];
        self.next += 1;
        let q = self.quantities[r.chan as usize];
        let (a, w) = (self.a, self.w);
        let u = match q {
            Quantity::X0 => a * self.drives.zeta0(tau),
            Quantity::X1 => a * x[0],
            Quantity::X2 => a * x[2],
            Quantity::V2 => a * w * x[3],
            Quantity::A2 => a * w * w * dx[3],
            Quantity::NormalForce => self.normal_force,
        };
        self.out[r.chan as usize].push(u);
    }
    fn wants_extremes(&self) -> bool {
        false
    }
}

impl SegmentObserver for Collector<'_> {}

/// The sample plan of one channel.
struct Plan {
    quantity: Quantity,
    sensor: SensorModel,
    dt_ns: u64,
    shift_s: f64,
    /// Per kept buffer: t0 (ns from the log start) and sample count.
    buffers: Vec<(u64, usize)>,
    lost: usize,
    first_offset_ns: u64,
    /// Request times in seconds from the log start (with fine low-pass
    /// points); `real[i]`: whether request i is a logged sample.
    req_t: Vec<f64>,
    real: Vec<bool>,
}

fn plan_channel(
    cfg: &SynthConfig,
    q: Quantity,
    sensor: SensorModel,
    duration_s: f64,
    rng: &mut Rng,
) -> Plan {
    let mut buffers = Vec::new();
    let mut lost = 0;
    let (dt_ns, shift_s, first_offset_ns);
    if cfg.format.is_table() {
        dt_ns = (1e9 / cfg.table_rate_hz).round() as u64;
        let n = (duration_s * 1e9 / dt_ns as f64).floor() as usize;
        buffers.push((0, n.max(1)));
        shift_s = cfg.csv_shift_s.get(q.name()).copied().unwrap_or(0.0);
        first_offset_ns = 0;
    } else {
        dt_ns = sensor.dt_ns();
        shift_s = 0.0;
        let offset = match sensor.start_offset_ns {
            Some(o) => o,
            None => rng.int(sensor.jitter_ns as i64, dt_ns as i64 - 1) as u64,
        };
        first_offset_ns = offset;
        let n_total = ((duration_s * 1e9 - offset as f64) / dt_ns as f64)
            .ceil()
            .max(1.0) as usize;
        let per = ((sensor.buffer_s * 1e9 / dt_ns as f64).round() as usize).max(1);
        let mut start = 0;
        while start < n_total {
            let n = per.min(n_total - start);
            let nominal = offset + start as u64 * dt_ns;
            let j = if sensor.jitter_ns > 0 {
                rng.int(-(sensor.jitter_ns as i64), sensor.jitter_ns as i64)
            } else {
                0
            };
            let t0 = (nominal as i64 + j).max(0) as u64;
            let lose = rng.uniform() < sensor.p_lost_buffer;
            if lose {
                lost += 1;
            } else {
                buffers.push((t0, n));
            }
            start += n;
        }
    }
    // Request times: the samples, with fine points before each sample of a
    // low-passed channel (first-order hold on a grid of dt/LOWPASS_SUBSTEPS).
    let mut req_t = Vec::new();
    let mut real = Vec::new();
    let dt = dt_ns as f64 * 1e-9;
    let lp_tc = sensor.lowpass_hz.map(|fc| 1.0 / (2.0 * PI * fc));
    let warm = cfg.test.warmup_s();
    let mut prev: Option<f64> = None;
    for &(t0, n) in &buffers {
        for i in 0..n {
            let t = (t0 + i as u64 * dt_ns) as f64 * 1e-9 + shift_s;
            if let Some(tc) = lp_tc {
                let start = match prev {
                    Some(p) => p,
                    None => (t - 10.0 * tc).max(-warm),
                };
                let h = dt / LOWPASS_SUBSTEPS as f64;
                let k = ((t - start) / h).ceil() as usize;
                if prev.is_none() {
                    req_t.push(start);
                    real.push(false);
                }
                for j in 1..k {
                    req_t.push(start + (t - start) * j as f64 / k as f64);
                    real.push(false);
                }
            }
            req_t.push(t);
            real.push(true);
            prev = Some(t);
        }
    }
    Plan {
        quantity: q,
        sensor,
        dt_ns,
        shift_s,
        buffers,
        lost,
        first_offset_ns,
        req_t,
        real,
    }
}

/// The first-order low-pass y' = (u − y)/tc over points (t, u), exact for
/// u linear between points; y starts at u(t_0).
fn lowpass(t: &[f64], u: &[f64], tc: f64) -> Vec<f64> {
    let mut y = Vec::with_capacity(u.len());
    let Some(&u0) = u.first() else {
        return y;
    };
    let mut yn = u0;
    y.push(yn);
    for i in 1..u.len() {
        let h = t[i] - t[i - 1];
        if h <= 0.0 {
            y.push(yn);
            continue;
        }
        let alpha = (-h / tc).exp();
        let b = (u[i] - u[i - 1]) / h;
        yn = u[i] - b * tc + alpha * (yn - u[i - 1] + b * tc);
        y.push(yn);
    }
    y
}

fn quantise(v: f64, q: f64) -> f64 {
    if q > 0.0 {
        (v / q).round() * q
    } else {
        v
    }
}

/// The drive pieces, the schedule (sweeps) and the setpoint messages.
fn drives_of(cfg: &SynthConfig, w: f64) -> (Drives, Option<Schedule>, Vec<SynthSetpoint>) {
    let eta = |f: f64| 2.0 * PI * f / w;
    let a_nom = cfg.rig.drive_amplitude_nominal_m;
    let at = |t_s: f64| LOG_START_NS + (t_s * 1e9).round() as u64;
    match &cfg.test {
        TestSpec::Characteristic {
            frequency_hz,
            warmup_s,
            duration_s,
        } => (
            Drives(vec![(
                0.0,
                Drive::Harmonic {
                    eta: eta(*frequency_hz),
                    phase: 0.0,
                    amplitude: 1.0,
                },
                (warmup_s + duration_s) * w,
            )]),
            None,
            Vec::new(),
        ),
        TestSpec::Stepped {
            setpoints_hz,
            dwell_s,
            ramp_s,
            preroll_s,
        } => {
            let mut segs = Vec::new();
            let mut sps = Vec::new();
            let mut t = 0.0;
            if *preroll_s > 0.0 {
                // The log start, then the first setpoint again after the pre-roll.
                sps.push(SynthSetpoint {
                    t_ns: at(0.0),
                    frequency_hz: setpoints_hz[0],
                    amplitude_m: a_nom,
                });
                segs.push(Segment::Dwell {
                    eta: eta(setpoints_hz[0]),
                    duration: preroll_s * w,
                });
                t += preroll_s;
            }
            for (i, &f) in setpoints_hz.iter().enumerate() {
                if i > 0 {
                    segs.push(Segment::Ramp {
                        eta: eta(f),
                        duration: ramp_s * w,
                    });
                }
                sps.push(SynthSetpoint {
                    t_ns: at(t),
                    frequency_hz: f,
                    amplitude_m: a_nom,
                });
                if i > 0 {
                    t += ramp_s;
                }
                let d = dwell_of(dwell_s, i);
                segs.push(Segment::Dwell {
                    eta: eta(f),
                    duration: d * w,
                });
                t += d;
            }
            let s = Schedule {
                segments: segs,
                phase: 0.0,
                amplitude: 1.0,
            };
            let d = s.drives().expect("validated schedule");
            (Drives(d), Some(s), sps)
        }
        TestSpec::Continuous {
            from_hz,
            to_hz,
            sweep_s,
            hold_before_s,
            hold_after_s,
        } => {
            let mut segs = vec![
                Segment::Dwell {
                    eta: eta(*from_hz),
                    duration: hold_before_s * w,
                },
                Segment::Ramp {
                    eta: eta(*to_hz),
                    duration: sweep_s * w,
                },
            ];
            if *hold_after_s > 0.0 {
                segs.push(Segment::Dwell {
                    eta: eta(*to_hz),
                    duration: hold_after_s * w,
                });
            }
            let total = hold_before_s + sweep_s + hold_after_s;
            let sps = (0..)
                .map(|k| k as f64)
                .take_while(|&t| t < total)
                .map(|t| {
                    let f = if t <= *hold_before_s {
                        *from_hz
                    } else if t >= hold_before_s + sweep_s {
                        *to_hz
                    } else {
                        from_hz + (to_hz - from_hz) * (t - hold_before_s) / sweep_s
                    };
                    SynthSetpoint {
                        t_ns: at(t),
                        frequency_hz: f,
                        amplitude_m: a_nom,
                    }
                })
                .collect();
            let s = Schedule {
                segments: segs,
                phase: 0.0,
                amplitude: 1.0,
            };
            let d = s.drives().expect("validated schedule");
            (Drives(d), Some(s), sps)
        }
    }
}

/// Runs the virtual rig: the whole log in memory with its truth.
///
/// ```
/// use stickslip::synth::{generate, SynthConfig, TestSpec};
/// // The paper's rig and a static-dynamic pad at 2.2 N, 2 s logged at 2.5 Hz.
/// let cfg = SynthConfig {
///     test: TestSpec::Characteristic { frequency_hz: 2.5, warmup_s: 4.0, duration_s: 2.0 },
///     ..SynthConfig::paper(7)
/// };
/// let log = generate(&cfg)?;
/// // The truth the log was made with travels with it.
/// assert_eq!(log.truth["law"]["family"], "static_dynamic");
/// assert!(!log.channels.is_empty());
/// # Ok::<(), stickslip::synth::SynthError>(())
/// ```
pub fn generate(cfg: &SynthConfig) -> Result<SynthLog, SynthError> {
    cfg.validate()?;
    let rig = &cfg.rig;
    let w = rig.omega_ref();
    let a_true = rig.drive_amplitude_true_m;
    let model = cfg.model();
    let duration_s = cfg.test.duration_s();
    let warm = cfg.test.warmup_s();
    let (mut drives, mut schedule, setpoints) = drives_of(cfg, w);

    // Sample plans, one RNG stream per channel.
    let sensors = cfg.sensors.channels();
    let mut rngs: Vec<Rng> = sensors
        .iter()
        .map(|(q, _)| Rng::with_stream(cfg.seed, 1 + *q as u64))
        .collect();
    let plans: Vec<Plan> = sensors
        .iter()
        .zip(rngs.iter_mut())
        .map(|((q, s), r)| plan_channel(cfg, *q, *s, duration_s, r))
        .collect();

    // One merged, sorted request stream (engine τ, clamped at the start).
    let total: usize = plans.iter().map(|p| p.req_t.len()).sum();
    let mut requests = Vec::with_capacity(total);
    for (c, p) in plans.iter().enumerate() {
        for &t in &p.req_t {
            requests.push(Request {
                tau: ((warm + t) * w).max(0.0),
                chan: c as u32,
            });
        }
    }
    requests.sort_by(|a, b| a.tau.total_cmp(&b.tau));
    let total_tau = (warm + duration_s) * w;
    // A CSV column shifted forward can ask past the end: run a bit longer.
    let run_tau = requests.last().map_or(total_tau, |r| r.tau.max(total_tau));
    if let Some(s) = schedule.as_mut() {
        if run_tau > total_tau {
            // Hold the last frequency for requests past the end.
            let eta_last = match s.segments.last() {
                Some(Segment::Dwell { eta, .. }) | Some(Segment::Ramp { eta, .. }) => *eta,
                None => unreachable!("validated schedule"),
            };
            s.segments.push(Segment::Dwell {
                eta: eta_last,
                // (past the last request: a span's end sample is not delivered)
                duration: run_tau - total_tau + 1.0,
            });
            drives = Drives(s.drives().map_err(SynthError::Sim)?);
        }
    }

    let mut col = Collector {
        requests: &requests,
        next: 0,
        out: plans
            .iter()
            .map(|p| Vec::with_capacity(p.req_t.len()))
            .collect(),
        quantities: plans.iter().map(|p| p.quantity).collect(),
        drives: &drives,
        a: a_true,
        w,
        normal_force: cfg.normal_force_n,
        log: (warm * w, (warm + duration_s) * w),
        stick_since: if model.law.is_frictionless() {
            None
        } else {
            Some(0.0)
        },
        stick_time: 0.0,
        events_in_log: 0,
        slid_in_log: false,
        slid_before_log: false,
    };
    let opts = NumericOptions {
        rtol: cfg.rtol,
        atol: cfg.rtol * 1e-2,
    };
    let sim_err = |e: crate::sim::SimError| SynthError::Sim(e.to_string());
    let end: RunEnd = match &schedule {
        None => {
            let (eta, extra) = match &drives.0[0].1 {
                Drive::Harmonic { eta, .. } => (*eta, run_tau - drives.0[0].2),
                _ => unreachable!("a characteristic test drives harmonically"),
            };
            // Extend the single harmonic piece if a request lies past it.
            let dur = drives.0[0].2 + if extra > 0.0 { extra + 1.0 } else { 0.0 };
            if model.law.affine().is_some() {
                Sim::new(&model, eta).map_err(sim_err)?.run_span(
                    Init::rest(),
                    0.0,
                    1.0,
                    dur,
                    &mut col,
                )
            } else {
                NumericSim::new(&model, drives.0[0].1.clone(), opts)
                    .map_err(sim_err)?
                    .run(Init::rest(), dur, &mut col)
            }
        }
        Some(s) => run_schedule(&model, s, Init::rest(), opts, &mut col).map_err(sim_err)?,
    };
    match &end.status {
        Status::Completed => {}
        Status::Stopped => {}
        Status::Interrupted(why) | Status::Chatter(why) => {
            return Err(SynthError::Sim(format!(
                "the motion cannot be simulated to the end of the log: {why}"
            )))
        }
    }
    if col.next != requests.len() {
        return Err(SynthError::Sim(format!(
            "the engine delivered {} of {} samples",
            col.next,
            requests.len()
        )));
    }
    if let Some(s) = col.stick_since.take() {
        col.add_stick(s, f64::INFINITY);
    }
    let exact = std::mem::take(&mut col.out);

    // Sensor models.
    let mut channels = Vec::new();
    for ((plan, u), rng) in plans.iter().zip(exact.iter()).zip(rngs.iter_mut()) {
        let s = &plan.sensor;
        let filtered = match s.lowpass_hz {
            Some(fc) => lowpass(&plan.req_t, u, 1.0 / (2.0 * PI * fc)),
            None => u.clone(),
        };
        let mut real = filtered
            .iter()
            .zip(&plan.real)
            .filter(|(_, r)| **r)
            .map(|(v, _)| *v);
        let mut buffers = Vec::with_capacity(plan.buffers.len());
        let mut nulls = 0;
        let mut burst = 0u32;
        for &(t0, n) in &plan.buffers {
            let mut values = Vec::with_capacity(n);
            for _ in 0..n {
                let y = real.next().expect("one value per sample");
                let noise = if s.noise > 0.0 {
                    s.noise * rng.normal()
                } else {
                    0.0
                };
                let v = quantise(s.gain * y + s.offset + noise, s.quant);
                if burst == 0 && s.p_dropout > 0.0 && rng.uniform() < s.p_dropout {
                    burst = rng.int(1, i64::from(s.dropout_burst_max)) as u32;
                }
                if burst > 0 {
                    burst -= 1;
                    nulls += 1;
                    values.push(None);
                } else {
                    values.push(Some(v));
                }
            }
            buffers.push(Buffer {
                t0_ns: LOG_START_NS + t0,
                values,
            });
        }
        channels.push(SynthChannel {
            quantity: plan.quantity,
            sensor: *s,
            dt_ns: plan.dt_ns,
            shift_s: plan.shift_s,
            buffers,
            lost_buffers: plan.lost,
            null_samples: nulls,
            first_sample_offset_ns: plan.first_offset_ns,
        });
    }

    let rig_record = rig_record(cfg);
    let table_rows = if cfg.format.is_table() {
        channels[0].buffers[0].values.len()
    } else {
        0
    };
    let truth = truth(
        cfg,
        &model,
        &plans,
        &exact,
        &channels,
        &rig_record,
        &col,
        &setpoints,
    );
    Ok(SynthLog {
        config: cfg.clone(),
        rig_record,
        channels,
        setpoints,
        table_rows,
        truth,
    })
}

/// The `rig` metadata record (string values, `rig-log-format.md`).
fn rig_record(cfg: &SynthConfig) -> BTreeMap<String, String> {
    let r = &cfg.rig;
    let (freq, sweep_kind) = match &cfg.test {
        TestSpec::Characteristic { frequency_hz, .. } => (Some(*frequency_hz), None),
        TestSpec::Stepped { .. } => (None, Some(SweepKind::Stepped)),
        TestSpec::Continuous { .. } => (None, Some(SweepKind::Continuous)),
    };
    let mut extra = BTreeMap::new();
    extra.insert("synth_seed".to_string(), cfg.seed.to_string());
    if let TestSpec::Continuous {
        from_hz,
        to_hz,
        sweep_s,
        ..
    } = &cfg.test
    {
        extra.insert(
            "sweep_rate_hz_per_s".to_string(),
            ((to_hz - from_hz) / sweep_s).to_string(),
        );
    }
    RigMeta {
        format: FORMAT_VERSION.to_string(),
        test: cfg.test.kind(),
        m1_kg: r.m1_kg,
        m2_kg: r.m2_kg,
        k1_n_per_m: r.k1_n_per_m,
        k2_n_per_m: r.k2_n_per_m,
        d_n_s_per_m: r.d_n_s_per_m,
        drive_amplitude_m: r.drive_amplitude_nominal_m,
        normal_force_n: cfg.normal_force_n,
        drive_frequency_hz: freq,
        sweep_kind,
        rig_id: Some("virtual-rig (stickslip synth)".into()),
        operator: Some("stickslip synth".into()),
        notes: Some(format!(
            "synthetic log, seed {}; law {}; truth in truth.json",
            cfg.seed,
            cfg.friction.family().as_str()
        )),
        recorded_at: Some(LOG_START_TEXT.into()),
        extra,
    }
    .to_map()
}

/// (max − min)/2 of the values at times in [t0, t1].
fn half_range(t: &[f64], u: &[f64], t0: f64, t1: f64) -> Option<f64> {
    let mut lo = f64::INFINITY;
    let mut hi = f64::NEG_INFINITY;
    for (ti, ui) in t.iter().zip(u) {
        if *ti >= t0 && *ti <= t1 {
            lo = lo.min(*ui);
            hi = hi.max(*ui);
        }
    }
    (hi >= lo).then_some(0.5 * (hi - lo))
}

#[allow(clippy::too_many_arguments)]
fn truth(
    cfg: &SynthConfig,
    model: &Model,
    plans: &[Plan],
    exact: &[Vec<f64>],
    channels: &[SynthChannel],
    rig_record: &BTreeMap<String, String>,
    col: &Collector<'_>,
    setpoints: &[SynthSetpoint],
) -> Value {
    let r = &cfg.rig;
    let w = r.omega_ref();
    let (a_nom, a_true) = (r.drive_amplitude_nominal_m, r.drive_amplitude_true_m);
    let ab = r.absorber();
    let f = &cfg.friction;
    let law_nom = f.law(r, a_nom);
    let mu = |x: f64| {
        if cfg.normal_force_n > 0.0 {
            num(x / cfg.normal_force_n)
        } else {
            Value::Null
        }
    };
    let duration = cfg.test.duration_s();
    // Exact signals at the real samples of a channel.
    let exact_of = |q: Quantity| -> Option<(Vec<f64>, Vec<f64>)> {
        let i = plans.iter().position(|p| p.quantity == q)?;
        let p = &plans[i];
        let (t, u): (Vec<f64>, Vec<f64>) = p
            .req_t
            .iter()
            .zip(&exact[i])
            .zip(&p.real)
            .filter(|(_, r)| **r)
            .map(|((t, u), _)| (*t, *u))
            .unzip();
        Some((t, u))
    };
    let x1 = exact_of(Quantity::X1);
    let x2 = exact_of(Quantity::X2);
    let v2 = exact_of(Quantity::V2);
    let amp = |t0: f64, t1: f64| -> (Value, Value) {
        let a = |s: &Option<(Vec<f64>, Vec<f64>)>| {
            s.as_ref()
                .and_then(|(t, u)| half_range(t, u, t0, t1))
                .map_or(Value::Null, |v| num(v / a_true))
        };
        (a(&x1), a(&x2))
    };
    let sensors: serde_json::Map<String, Value> = channels
        .iter()
        .map(|c| {
            let s = &c.sensor;
            let n_samples: usize = c.buffers.iter().map(|b| b.values.len()).sum();
            (
                if cfg.format.is_table() {
                    c.quantity.name().to_string()
                } else {
                    c.quantity.topic().to_string()
                },
                json!({
                    "topic": c.quantity.topic(),
                    "quantity": c.quantity.name(),
                    "unit": c.quantity.unit(),
                    "rate_hz": if cfg.format.is_table() { cfg.table_rate_hz } else { s.rate_hz },
                    "noise": s.noise,
                    "quant": s.quant,
                    "gain": s.gain,
                    "offset": s.offset,
                    "lowpass_hz": s.lowpass_hz,
                    "buffer_s": if cfg.format.is_table() { Value::Null } else { json!(s.buffer_s) },
                    "jitter_ns": if cfg.format.is_table() { 0 } else { s.jitter_ns },
                    "p_lost_buffer": if cfg.format.is_table() { 0.0 } else { s.p_lost_buffer },
                    "p_dropout": s.p_dropout,
                    "dropout_burst_max": s.dropout_burst_max,
                    "dt_ns": c.dt_ns,
                    "n_samples": n_samples,
                    "n_buffers": c.buffers.len() + c.lost_buffers,
                    "lost_buffers": c.lost_buffers,
                    "null_samples": c.null_samples,
                    "first_sample_offset_ns": c.first_sample_offset_ns,
                    "shift_s": c.shift_s,
                }),
            )
        })
        .collect();
    let mut e = json!({
        "test": cfg.test.kind().as_str(),
        "format": cfg.format.as_str(),
        "generator": "stickslip synth",
        "rig": {
            "m1_kg": r.m1_kg, "m2_kg": r.m2_kg,
            "k1_n_per_m": r.k1_n_per_m, "k2_n_per_m": r.k2_n_per_m,
            "d_n_s_per_m": r.d_n_s_per_m,
            "drive_amplitude_nominal_m": a_nom,
            "omega_ref_rad_s": w,
            "m": ab.m, "k": ab.k, "D": ab.damping,
        },
        "law": {
            "family": f.family().as_str(),
            "rs_n": f.rs_n, "rd_n": f.rd_n,
            "slope_n_s_per_m": f.slope_n_s_per_m,
            "stribeck_velocity_m_per_s": f.stribeck_velocity_m_per_s,
            "mu_s": mu(f.rs_n), "mu_d": mu(f.rd_n),
            "rho_s": law_nom.rho_s(), "rho_d": law_nom.rho_d(), "Dstar": law_nom.slope(),
            "rho_s_true_amplitude": model.law.rho_s(),
            "rho_d_true_amplitude": model.law.rho_d(),
            "v_s_dimensionless_true_amplitude": match model.law {
                Law::Stribeck { v_s, .. } => num(v_s),
                Law::Linear { .. } => Value::Null,
            },
        },
        "drive_amplitude_true_m": a_true,
        "drive_amplitude_nominal_m": a_nom,
        "drive_amplitude_ratio": a_true / a_nom,
        "normal_force_n": cfg.normal_force_n,
        "mu_s": mu(f.rs_n), "mu_d": mu(f.rd_n),
        "stuck": !col.slid_in_log,
        "slid_during_warmup": col.slid_before_log,
        "warmup_s": cfg.test.warmup_s(),
        "duration_s": duration,
        "stick_fraction": col.stick_time / (duration * w),
        "n_stick_slip_events": col.events_in_log,
        "max_abs_v2_m_per_s": v2.as_ref().map_or(Value::Null, |(_, u)| num(u.iter().fold(0.0f64, |m, x| m.max(x.abs())))),
        "channels": channels.iter().map(|c| if cfg.format.is_table() { c.quantity.name() } else { c.quantity.topic() }).collect::<Vec<_>>(),
        "sensors": sensors,
        "seed": cfg.seed,
        "metadata": rig_record,
        "sample_times": "the exact trajectory is sampled at each written sample's time; amplitudes a1/a2 are (max-min)/2 of those exact samples over the window, divided by the true A",
    });
    let obj = e.as_object_mut().expect("object");
    if cfg.format.is_table() {
        obj.insert("common_rate_hz".into(), json!(cfg.table_rate_hz));
        let shifts: BTreeMap<&str, f64> = channels
            .iter()
            .map(|c| (c.quantity.name(), c.shift_s))
            .collect();
        obj.insert("column_time_shifts_s".into(), json!(shifts));
    }
    match &cfg.test {
        TestSpec::Characteristic { frequency_hz, .. } => {
            obj.insert("drive_frequency_hz".into(), json!(frequency_hz));
            obj.insert("eta".into(), json!(2.0 * PI * frequency_hz / w));
            let (a1, a2) = amp((duration - 5.0).max(0.0), duration);
            obj.insert("a1_last5s".into(), a1);
            obj.insert("a2_last5s".into(), a2);
        }
        TestSpec::Stepped {
            setpoints_hz,
            dwell_s,
            ramp_s,
            preroll_s,
        } => {
            obj.insert("sweep_kind".into(), json!("stepped"));
            let mut t = *preroll_s;
            let mut steps = Vec::new();
            for (i, &fr) in setpoints_hz.iter().enumerate() {
                let t_set = t;
                if i > 0 {
                    t += ramp_s;
                }
                let d = dwell_of(dwell_s, i);
                let t_end = t + d;
                // Settle window: the last whole drive periods, at most 5 s.
                let period = 1.0 / fr;
                let n = ((d.min(5.0)) / period).floor().max(1.0);
                let t0 = (t_end - n * period).max(t);
                let (a1, a2) = amp(t0, t_end);
                steps.push(json!({
                    "frequency_hz": fr,
                    "eta": 2.0 * PI * fr / w,
                    "t_setpoint_s": t_set,
                    "t_dwell_start_s": t,
                    "t_end_s": t_end,
                    "settle_window_s": [t0, t_end],
                    "a1": a1, "a2": a2,
                }));
                t = t_end;
            }
            obj.insert("response".into(), Value::Array(steps));
        }
        TestSpec::Continuous {
            from_hz,
            to_hz,
            sweep_s,
            ..
        } => {
            obj.insert("sweep_kind".into(), json!("continuous"));
            obj.insert(
                "sweep_rate_hz_per_s".into(),
                json!((to_hz - from_hz) / sweep_s),
            );
            let resp: Vec<Value> = setpoints
                .iter()
                .map(|sp| {
                    let t = (sp.t_ns - LOG_START_NS) as f64 * 1e-9;
                    let half = 1.5 / sp.frequency_hz;
                    let (a1, a2) = amp(t - half, t + half);
                    json!({"t_s": t, "frequency_hz": sp.frequency_hz,
                           "eta": 2.0 * PI * sp.frequency_hz / w, "a1": a1, "a2": a2})
                })
                .collect();
            obj.insert("response".into(), Value::Array(resp));
        }
    }
    e
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
