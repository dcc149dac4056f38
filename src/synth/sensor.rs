//! Sensor models: gain (and its linear drift), offset (and its linear
//! drift), noise (white or correlated), time delay, low-pass (Butterworth
//! of any order), clipping, quantisation, rate, jitter, dropouts and lost
//! buffers, per channel.

use super::*;

/// Highest Butterworth order a sensor's low-pass may have.
pub const MAX_LOWPASS_ORDER: u32 = 8;

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
    /// Correlation time of the noise (s; 0: white). Noise that passed
    /// the sensor's own filter: a first-order (AR(1)) process with this
    /// time constant and stationary σ = `noise`, sample to sample
    /// correlation e^(−dt/τ).
    #[serde(default)]
    pub noise_correlation_s: f64,
    /// Order of the Butterworth low-pass at `lowpass_hz` (1: the
    /// first-order filter, bit for bit as before this field existed).
    #[serde(default = "one")]
    pub lowpass_order: u32,
    /// Linear gain drift (1/s): the gain at t seconds after the log start
    /// is `gain·(1 + gain_drift_per_s·t)`.
    #[serde(default)]
    pub gain_drift_per_s: f64,
    /// Saturation: the lowest value the sensor can report (SI); values
    /// below read exactly this (before quantisation).
    #[serde(default)]
    pub clip_low: Option<f64>,
    /// Saturation: the highest value the sensor can report (SI).
    #[serde(default)]
    pub clip_high: Option<f64>,
    /// Saturation relative to the channel's swing: the high side is clipped
    /// at mid + f·(max − mid) of the noise-free sensed signal over the log
    /// (mid = (max + min)/2), e.g. 0.85 flat-tops x1 at 85 % of its peak.
    /// Tighter of this and `clip_high` applies.
    #[serde(default)]
    pub clip_high_fraction: Option<f64>,
    /// The same for the low side: clipped at mid − f·(mid − min).
    #[serde(default)]
    pub clip_low_fraction: Option<f64>,
    /// Time delay of the channel (s): the value stamped t was measured at
    /// t − `delay_s` (the channel lags; negative: it leads). The shift a
    /// reader must apply to re-align it is −`delay_s` (a channel map's
    /// `shift_s` convention). Default 0.
    #[serde(default)]
    pub delay_s: f64,
    /// Linear drift of the offset (SI per second): the offset at time t
    /// from the log start is `offset + offset_drift_per_s·t`. Default 0.
    #[serde(default)]
    pub offset_drift_per_s: f64,
}

fn one() -> u32 {
    1
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
            noise_correlation_s: 0.0,
            lowpass_order: 1,
            gain_drift_per_s: 0.0,
            clip_low: None,
            clip_high: None,
            clip_high_fraction: None,
            clip_low_fraction: None,
            delay_s: 0.0,
            offset_drift_per_s: 0.0,
        }
    }

    /// Sample interval in ns.
    pub fn dt_ns(&self) -> u64 {
        (1e9 / self.rate_hz).round() as u64
    }

    pub(super) fn validate(&self, q: Quantity) -> Result<(), SynthError> {
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
        if !(self.delay_s.is_finite() && self.delay_s.abs() <= 1.0) {
            return Err(bad(p(&format!(
                "delay_s must be within ±1 s (got {})",
                self.delay_s
            ))));
        }
        if !self.offset_drift_per_s.is_finite() {
            return Err(bad(p("offset_drift_per_s must be finite")));
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
        if !(1..=MAX_LOWPASS_ORDER).contains(&self.lowpass_order) {
            return Err(bad(p(&format!(
                "lowpass_order must be 1..={MAX_LOWPASS_ORDER} (got {})",
                self.lowpass_order
            ))));
        }
        if !self.gain_drift_per_s.is_finite() {
            return Err(bad(p("gain_drift_per_s must be finite")));
        }
        for (what, v) in [("clip_low", self.clip_low), ("clip_high", self.clip_high)] {
            if let Some(v) = v {
                if !v.is_finite() {
                    return Err(bad(p(&format!("{what} must be finite"))));
                }
            }
        }
        if let (Some(lo), Some(hi)) = (self.clip_low, self.clip_high) {
            if lo >= hi {
                return Err(bad(p(&format!(
                    "clip_low ({lo}) must be below clip_high ({hi})"
                ))));
            }
        }
        for (what, v) in [
            ("clip_high_fraction", self.clip_high_fraction),
            ("clip_low_fraction", self.clip_low_fraction),
        ] {
            if let Some(v) = v {
                if !(v.is_finite() && v > 0.0 && v <= 1.0) {
                    return Err(bad(p(&format!("{what} must be in (0, 1] (got {v})"))));
                }
            }
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
            // White noise, first-order filter, no drifts, clipping or delay.
            ..SensorModel::ideal(rate)
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

    /// The model of a channel by its canonical name (`x0`, `x1`, `x2`,
    /// `v2`, `a2`, `normal_force`): `None` for an unknown name,
    /// `Some(None)` for a channel this rig does not write.
    pub fn channel_mut(&mut self, name: &str) -> Option<Option<&mut SensorModel>> {
        Some(match name {
            "x0" => Some(&mut self.x0),
            "x1" => Some(&mut self.x1),
            "x2" => Some(&mut self.x2),
            "v2" => Some(&mut self.v2),
            "a2" => self.a2.as_mut(),
            "normal_force" => self.normal_force.as_mut(),
            _ => return None,
        })
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
