//! The contact force of paper eq. 7, with the damper term the paper drops:
//!
//! ```text
//! R(t) = −( M2·ẍ2 + K2·(x2 − x1) + d·(ẋ2 − ẋ1) )
//! ```
//!
//! (rig-log-format: `M2 x2'' + d (x2' − x1') + K2 (x2 − x1) + R = 0`, R the
//! friction force on M2). What this module does with the raw channels first:
//!
//! * **Drive amplitude**: a least-squares sinusoid (offset, cosine, sine) fitted
//!   to `x0`, its frequency refined by golden-section search around the
//!   commanded one; the amplitude is the scale of every ρ.
//! * **Velocity offset**: the velocity transducer's zero is taken from the
//!   physics: over every contiguous block, `∫ẋ2 dt = Δx2`, so the offset is
//!   `(∫v2 dt − Δx2) / T` summed over blocks (independent of the unknown
//!   position offsets and of where the log cuts the period).
//! * **Channel time offsets**: `v2` is compared with the smoothed derivative
//!   of `x2`, and `a2` with the smoothed derivative of `v2`; the lag that
//!   minimises the squared difference (golden section over ±10 ms, linear
//!   interpolation) is removed when it is significant (a first-order sensor
//!   low-pass shows up as such a lag too).
//! * **Acceleration**: the accelerometer where it has data, else a cubic
//!   Savitzky–Golay derivative of the velocity (edge-correct at gaps).
//!
//! The constant force bias from unknown position offsets (the spring's rest
//! length in sensor coordinates) is *not* removed here: the fit estimates it
//! from the symmetry of the slip levels (see `fit`).

use super::smooth::{finite_blocks, savgol};
use crate::ingest::Run;
use crate::sim::linalg::C64;
use crate::stats::golden_section;
use crate::warning::Warning;

/// Multipliers applied to the sensor channels before identification: 1 for
/// the data as logged; the calibration budget re-runs the identification
/// with one of them perturbed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Gains {
    /// Drive position x0.
    pub x0: f64,
    /// Main mass position x1.
    pub x1: f64,
    /// Absorber mass position x2.
    pub x2: f64,
    /// Absorber velocity v2.
    pub v2: f64,
    /// Absorber acceleration a2.
    pub a2: f64,
}

impl Default for Gains {
    fn default() -> Self {
        Self {
            x0: 1.0,
            x1: 1.0,
            x2: 1.0,
            v2: 1.0,
            a2: 1.0,
        }
    }
}

/// The sinusoid fitted to the drive channel.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct DriveFit {
    /// Measured drive amplitude A (m).
    pub amplitude_m: f64,
    /// Measured drive frequency (Hz).
    pub frequency_hz: f64,
    /// Phase φ of `x0 ≈ c + A·cos(2πf·t − φ)` (rad).
    pub phase_rad: f64,
    /// RMS of the fit residual (m).
    pub residual_rms_m: f64,
    /// The metadata's drive frequency (Hz) where the drive channel
    /// contradicts it by more than [`DRIVE_FREQUENCY_TOLERANCE`] (the
    /// measured frequency is used), else `None`.
    pub metadata_frequency_hz: Option<f64>,
}

/// Relative difference between the metadata's and the measured drive
/// frequency beyond which the metadata are set aside (with a warning).
pub const DRIVE_FREQUENCY_TOLERANCE: f64 = 0.02;

/// A sample column of a [`Contact`], shared (not copied) with the grid,
/// with the re-fits whose gains leave it unchanged and with the
/// output-error data.
pub use crate::ingest::Column;

/// Contact force and the corrected signals it was computed from, on the
/// run's common time base (NaN where data are missing).
#[derive(Debug, Clone)]
pub struct Contact {
    /// Grid times (s).
    pub t: Column,
    /// Grid spacing (s).
    pub dt: f64,
    /// Spring rate K2 (N/m).
    pub k2_n_per_m: f64,
    /// Position of M1 as used (m).
    pub x1: Column,
    /// Position of M2 as used (m).
    pub x2: Column,
    /// Velocity of M2 after offset and lag correction (m/s).
    pub v2: Column,
    /// Smoothed velocity of M2 (m/s).
    pub v2_smooth: Column,
    /// Acceleration of M2 used in eq. 7 (m/s²).
    pub a2: Column,
    /// Velocity of M1 (smoothed derivative of x1, m/s).
    pub v1: Column,
    /// Damping d of the rig (N·s/m), for the passive force
    /// ([`Contact::passive_at`]).
    pub d_n_s_per_m: f64,
    /// Mass M2 of the rig (kg).
    pub m2_kg: f64,
    /// Contact force by eq. 7 (N, bias included).
    pub r: Column,
    /// The drive fit.
    pub drive: DriveFit,
    /// Velocity offset removed (m/s).
    pub v2_offset: f64,
    /// Accelerometer offset removed (m/s²).
    pub a2_offset: f64,
    /// Lag removed from v2 relative to x2 (s; positive: v2 was late).
    pub v2_lag_s: f64,
    /// The accelerometer alone (offset and lag removed; NaN where it has no
    /// data), if there is one: the model-adequacy test compares it with
    /// the simulated acceleration.
    pub a2_sensor: Option<Column>,
    /// Lag removed from a2 relative to v2 (s), if there is an accelerometer.
    pub a2_lag_s: Option<f64>,
    /// Where ẍ2 came from: `accelerometer` or `savitzky-golay`.
    pub acceleration_source: &'static str,
    /// Half-width (samples) of the smoothing/differentiating window.
    pub half_window: usize,
    /// Things the user should know.
    pub warnings: Vec<Warning>,
    /// How many of `warnings` the velocity stage gave (the acceleration
    /// stage's follow): what [`compute_reusing`] keeps of a base.
    pub(crate) velocity_warnings: usize,
}

impl Contact {
    /// Passive force `−K2·(x2 − x1) + d·ẋ1` at sample `i` (N, bias
    /// included): the contact force while M2 sticks (ẋ2 = ẍ2 = 0).
    /// Computed where it is used, not stored (one column less per contact).
    pub fn passive_at(&self, i: usize) -> f64 {
        -self.k2_n_per_m * (self.x2[i] - self.x1[i]) + self.d_n_s_per_m * self.v1[i]
    }

    /// The passive force of every sample ([`Contact::passive_at`]).
    pub fn passive(&self) -> Vec<f64> {
        (0..self.t.len()).map(|i| self.passive_at(i)).collect()
    }
}

/// Fits `x ≈ c + a·cos ωt + b·sin ωt` at angular frequency `w`; returns
/// (c, a, b, residual sum of squares, n).
///
/// The phasor e^{iωt} is advanced by a rotation e^{iω·Δ} between samples
/// Δ apart (re-anchored with libm every [`ROTATION_RUN`] samples and
/// wherever the spacing changes by more than the rounding of t itself), so
/// the ~40 evaluations of the drive fit's frequency search cost a few
/// multiplications per sample instead of a sine and a cosine.
fn sine_fit(t: &[f64], x: &[f64], w: f64) -> Option<(f64, f64, f64, f64, usize)> {
    // Sums of XᵀX (rows [1, c, s]), Xᵀy and yᵀy.
    let (mut sc, mut ss, mut scc, mut scs, mut sss) = (0.0, 0.0, 0.0, 0.0, 0.0);
    let (mut sy, mut scy, mut ssy, mut syy) = (0.0, 0.0, 0.0, 0.0);
    let mut n = 0usize;
    let mut rot = Rotation::new(w);
    for (&ti, &xi) in t.iter().zip(x) {
        if xi.is_finite() {
            let e = rot.at(ti);
            let (c, s) = (e.re, e.im);
            sc += c;
            ss += s;
            scc += c * c;
            scs += c * s;
            sss += s * s;
            sy += xi;
            scy += c * xi;
            ssy += s * xi;
            syy += xi * xi;
            n += 1;
        }
    }
    // The normal equations of the three-parameter fit, solved as
    // `smooth::Normal` would (symmetric XᵀX, small dense solve).
    let xtx = vec![
        vec![n as f64, sc, ss],
        vec![sc, scc, scs],
        vec![ss, scs, sss],
    ];
    let xty = [sy, scy, ssy];
    let p = super::smooth::solve_small(&xtx, &xty)?;
    let rss = (syy - p.iter().zip(&xty).map(|(a, b)| a * b).sum::<f64>()).max(0.0);
    Some((p[0], p[1], p[2], rss, n))
}

/// Samples a rotation is carried over before it is re-anchored with libm
/// (its rounding grows by a few ε per sample).
const ROTATION_RUN: u32 = 32;

/// The phasor e^{iωt} at increasing sample times t, by rotation between
/// equally spaced samples.
struct Rotation {
    w: f64,
    /// The anchor (a time with its libm phasor), the samples k rotated on
    /// from it and the phasor at anchor + k·gap.
    anchor: f64,
    k: u32,
    phasor: C64,
    /// The previous time, the spacing and its rotation (made when the
    /// spacing repeats).
    prev: f64,
    gap: f64,
    step: Option<C64>,
}

impl Rotation {
    fn new(w: f64) -> Self {
        Self {
            w,
            anchor: f64::NAN,
            k: ROTATION_RUN,
            phasor: C64::new(1.0, 0.0),
            prev: f64::NAN,
            gap: f64::NAN,
            step: None,
        }
    }

    /// e^{iωt}: rotated on from the anchor where t = anchor + (k+1)·gap up
    /// to the rounding of t and of the spacing (an argument error of at
    /// most 4(k+1)·ε·ω·t, k < [`ROTATION_RUN`]: about 1e-11 rad at ω·t =
    /// 500, far below any drive signal's noise), else from libm (a new
    /// anchor).
    /// The rotation is made once a spacing repeats, so jittered times cost
    /// one sincos each, as without it.
    #[inline]
    fn at(&mut self, t: f64) -> C64 {
        let next = self.anchor + f64::from(self.k + 1) * self.gap;
        // The spacing itself carries the rounding of t (ε·t): k spacings on,
        // the grid point is known to k·ε·t.
        let tol = 4.0 * f64::EPSILON * t.abs() * f64::from(self.k + 1);
        let e = if self.k < ROTATION_RUN && (t - next).abs() <= tol {
            let (w, gap) = (self.w, self.gap);
            let step = *self
                .step
                .get_or_insert_with(|| C64::from_polar(1.0, w * gap));
            self.k += 1;
            self.phasor * step
        } else {
            let g = t - self.prev;
            // (NaN at the first sample: a new spacing.)
            let same = (g - self.gap).abs() <= 4.0 * f64::EPSILON * t.abs();
            if !same {
                self.gap = g;
                self.step = None;
            }
            self.anchor = t;
            self.k = 0;
            C64::from_polar(1.0, self.w * t)
        };
        self.phasor = e;
        self.prev = t;
        e
    }
}

/// Fits the drive sinusoid; `f0` is the commanded frequency if known.
pub fn fit_drive(t: &[f64], x0: &[f64], f0: Option<f64>) -> Option<DriveFit> {
    let fit_near = |f0: f64| -> Option<(DriveFit, f64)> {
        let rss =
            |f: f64| sine_fit(t, x0, 2.0 * std::f64::consts::PI * f).map_or(f64::INFINITY, |r| r.3);
        let f = golden_section(0.98 * f0, 1.02 * f0, 40, rss);
        let (_, a, b, rss, n) = sine_fit(t, x0, 2.0 * std::f64::consts::PI * f)?;
        Some((
            DriveFit {
                amplitude_m: a.hypot(b),
                frequency_hz: f,
                phase_rad: b.atan2(a),
                residual_rms_m: (rss / n.max(1) as f64).sqrt(),
                metadata_frequency_hz: None,
            },
            rss,
        ))
    };
    let Some(meta) = f0.filter(|f| f.is_finite() && *f > 0.0) else {
        return fit_near(estimate_frequency(t, x0)?).map(|r| r.0);
    };
    let at_meta = fit_near(meta);
    // Metadata that the drive channel contradicts (by more than 2 %, and
    // the measured frequency fits the channel at least twice as well) are
    // set aside: the measured frequency is used, and the fit says so.
    if let Some(measured) = estimate_frequency(t, x0) {
        if (measured / meta - 1.0).abs() > DRIVE_FREQUENCY_TOLERANCE {
            if let Some((mut fit, rss)) = fit_near(measured) {
                let better = at_meta.as_ref().is_none_or(|(_, r)| rss < 0.5 * r);
                if better {
                    fit.metadata_frequency_hz = Some(meta);
                    return Some(fit);
                }
            }
        }
    }
    at_meta.map(|r| r.0)
}

/// Frequency from the mean spacing of upward mean crossings.
fn estimate_frequency(t: &[f64], x: &[f64]) -> Option<f64> {
    let m = crate::stats::median(x);
    let mut ups = Vec::new();
    let mut prev: Option<(f64, f64)> = None;
    for (ti, xi) in t.iter().zip(x) {
        if !xi.is_finite() {
            continue;
        }
        if let Some((tp, xp)) = prev {
            if xp < m && *xi >= m {
                ups.push(tp + (ti - tp) * (m - xp) / (xi - xp));
            }
        }
        prev = Some((*ti, *xi));
    }
    if ups.len() < 2 {
        return None;
    }
    Some((ups.len() - 1) as f64 / (ups[ups.len() - 1] - ups[0]))
}

/// Shifts a uniformly sampled signal by `lag` seconds: out(t) = y(t + lag)
/// (linear interpolation; NaN where a neighbour is missing).
pub(crate) fn shift(y: &[f64], dt: f64, lag: f64) -> Vec<f64> {
    let (k, f) = shift_split(dt, lag);
    (0..y.len() as i64).map(|i| shifted(y, k, f, i)).collect()
}

/// A shift of `lag` seconds as whole samples k and a fraction f in [0, 1).
#[inline]
fn shift_split(dt: f64, lag: f64) -> (i64, f64) {
    let s = lag / dt;
    let k = s.floor();
    (k as i64, s - k)
}

/// Sample i of [`shift`]'s output for the split (k, f).
#[inline]
fn shifted(y: &[f64], k: i64, f: f64, i: i64) -> f64 {
    let j = i + k;
    if j < 0 || j + 1 >= y.len() as i64 {
        return f64::NAN;
    }
    let (a, b) = (y[j as usize], y[j as usize + 1]);
    if f == 0.0 {
        a
    } else {
        a * (1.0 - f) + b * f
    }
}

/// The lag (s) of `y` against the reference `r` that minimises
/// Σ(y(t + lag) − r(t))² over ±`max_lag`, with an approximate standard
/// error; None if there is too little overlapping data.
fn estimate_lag(y: &[f64], r: &[f64], dt: f64, max_lag: f64) -> Option<(f64, f64)> {
    let sse = |lag: f64| {
        // `shift`'s samples, computed in place (no vector per lag).
        let (k, f) = shift_split(dt, lag);
        let (mut s, mut n) = (0.0, 0usize);
        for (i, b) in r.iter().enumerate().take(y.len()) {
            let a = shifted(y, k, f, i as i64);
            if a.is_finite() && b.is_finite() {
                s += (a - b).powi(2);
                n += 1;
            }
        }
        if n < 100 {
            f64::INFINITY
        } else {
            s / n as f64
        }
    };
    // Coarse scan on the grid (the SSE is not unimodal far from the optimum),
    // then golden section inside the best cell.
    let kmax = (max_lag / dt).round() as i64;
    let (mut best, mut fbest) = (0i64, f64::INFINITY);
    for k in -kmax..=kmax {
        let v = sse(k as f64 * dt);
        if v < fbest {
            best = k;
            fbest = v;
        }
    }
    if !fbest.is_finite() {
        return None;
    }
    let lag = golden_section((best - 1) as f64 * dt, (best + 1) as f64 * dt, 30, sse);
    // Only meaningful when the aligned signals agree well: the residual must
    // be small against the reference's own spread (a stuck mass gives two
    // noise records, whose "lag" means nothing).
    let fin: Vec<f64> = r.iter().copied().filter(|v| v.is_finite()).collect();
    let mean = fin.iter().sum::<f64>() / fin.len().max(1) as f64;
    let var_r = fin.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / fin.len().max(1) as f64;
    if sse(lag).partial_cmp(&(0.25 * var_r)) != Some(std::cmp::Ordering::Less) {
        return None;
    }
    // Standard error from the curvature of the mean squared difference and
    // the residual level: var(lag) ≈ 2·σ²/(n·SSE''), with n an effective count.
    let h = 0.25 * dt;
    let (f0, fp, fm) = (sse(lag), sse(lag + h), sse(lag - h));
    let curv = (fp + fm - 2.0 * f0) / (h * h);
    let n = y.iter().filter(|v| v.is_finite()).count() as f64;
    let se = if curv > 0.0 {
        (2.0 * f0 / (curv * n / 20.0)).sqrt()
    } else {
        f64::INFINITY
    };
    Some((lag, se))
}

/// Offset of a rate sensor `v` from `∫v dt = Δx` over every block where
/// both are finite (the same rule serves a velocity against its position
/// and an acceleration against its velocity).
fn rate_offset(x: &[f64], v: &[f64], dt: f64) -> f64 {
    let both: Vec<f64> = x
        .iter()
        .zip(v)
        .map(|(a, b)| {
            if a.is_finite() && b.is_finite() {
                0.0
            } else {
                f64::NAN
            }
        })
        .collect();
    let (mut int_v, mut dx, mut time) = (0.0, 0.0, 0.0);
    for (s, e) in finite_blocks(&both) {
        if e - s < 10 {
            continue;
        }
        // Positions are noisy: take Δx from short averages at the block ends.
        let k = ((e - s) / 20).clamp(1, 10);
        let x_a: f64 = x[s..s + k].iter().sum::<f64>() / k as f64;
        let x_b: f64 = x[e - k..e].iter().sum::<f64>() / k as f64;
        // The averages sit at the centres of the end windows.
        let ia = s as f64 + (k as f64 - 1.0) / 2.0;
        let ib = (e - k) as f64 + (k as f64 - 1.0) / 2.0;
        // Trapezoid of v between the two centres.
        let (ca, cb) = (ia.ceil() as usize, ib.floor() as usize);
        let mut s_v = 0.0;
        for i in ca..cb {
            s_v += 0.5 * (v[i] + v[i + 1]) * dt;
        }
        // Fractional ends (k odd: centres on samples; k even: half steps).
        s_v += (ca as f64 - ia) * dt * v[ca];
        s_v += (ib - cb as f64) * dt * v[cb];
        int_v += s_v;
        dx += x_b - x_a;
        time += (ib - ia) * dt;
    }
    if time > 0.0 {
        (int_v - dx) / time
    } else {
        0.0
    }
}

/// The velocity ẋ2 as used (`(v2, lag, offset)`): the velocity channel
/// `v2_raw` (or, without one, `dx2`, the derivative of x2), shifted by its
/// lag against `dx2` where that is significant, its offset against the
/// rate of x2 removed. `w`: the sample interval and the Savitzky–Golay
/// half-window.
fn velocity(
    run: &Run,
    v2_raw: Vec<f64>,
    x2: &[f64],
    dx2: Vec<f64>,
    w: (f64, usize),
    warnings: &mut Vec<Warning>,
) -> (Vec<f64>, f64, f64) {
    let (dt, half) = w;
    // A log without a velocity channel: ẋ2 from x2 (a cubic
    // Savitzky–Golay derivative over the same window; no lag, no offset).
    let v2_raw = if run.has_velocity() {
        v2_raw
    } else {
        warnings.push(Warning::VelocityDerived { half_window: half });
        dx2.clone()
    };
    // Time offset of v2 against the derivative of x2.
    let mut v2 = v2_raw.clone();
    let mut v2_lag_s = 0.0;
    // Compared smoothed: interpolating white noise at a fractional shift
    // lowers its variance, which would bias the lag toward half samples.
    let v2_raw_s = savgol(&v2_raw, dt, half, 3, 0);
    if let Some((lag, se)) = estimate_lag(&v2_raw_s, &dx2, dt, 0.01) {
        if lag.abs() > 3.0 * se && lag.abs() > 0.05 * dt {
            v2 = shift(&v2_raw, dt, lag);
            v2_lag_s = lag;
            if lag.abs() > 2.0 * dt {
                warnings.push(Warning::VelocityLag { lag_s: lag });
            }
        }
    }
    let v2_offset = rate_offset(x2, &v2, dt);
    for v in v2.iter_mut() {
        *v -= v2_offset;
    }
    (v2, v2_lag_s, v2_offset)
}

/// The accelerometer's ẍ2 as used (see [`acceleration`]).
struct Acceleration {
    /// The channel, gaps filled with dv2/dt.
    merged: Vec<f64>,
    /// Its lag against dv2/dt (s).
    lag: f64,
    /// The channel as corrected (zero and lag), gaps kept.
    sensor: Vec<f64>,
    /// Its zero offset (m/s²).
    offset: f64,
}

/// The accelerometer channel `a_raw` (gain applied): its zero from the
/// physics (∫a dt = Δv), its lag against `dv2` corrected where
/// significant, gaps filled with `dv2`. `w`: the sample interval and the
/// Savitzky–Golay half-window.
fn acceleration(
    mut a_raw: Vec<f64>,
    v2: &[f64],
    dv2: &[f64],
    w: (f64, usize),
    warnings: &mut Vec<Warning>,
) -> Acceleration {
    let (dt, half) = w;
    // Accelerometer zero from the physics: ∫a dt = Δv.
    let a_off = rate_offset(v2, &a_raw, dt);
    for x in a_raw.iter_mut() {
        *x -= a_off;
    }
    let a_s = savgol(&a_raw, dt, half, 3, 0);
    let (a_sh, lag) = match estimate_lag(&a_s, dv2, dt, 0.01) {
        Some((lag, se)) if lag.abs() > 3.0 * se && lag.abs() > 0.05 * dt => {
            if lag.abs() > 2.0 * dt {
                warnings.push(Warning::AccelerationLag { lag_s: lag });
            }
            (shift(&a_raw, dt, lag), lag)
        }
        _ => (a_raw, 0.0),
    };
    // Where the accelerometer has no data, fall back to dv2/dt.
    let mut filled = 0usize;
    let merged: Vec<f64> = a_sh
        .iter()
        .zip(dv2)
        .map(|(a, d)| {
            if a.is_finite() {
                *a
            } else {
                if d.is_finite() {
                    filled += 1;
                }
                *d
            }
        })
        .collect();
    if filled > 0 {
        warnings.push(Warning::AccelerationFilled { samples: filled });
    }
    Acceleration {
        merged,
        lag,
        sensor: a_sh,
        offset: a_off,
    }
}

/// Computes the contact force of `run` with the sensor gains `g` (1 = as
/// logged).
pub fn compute(run: &Run, g: &Gains) -> Option<Contact> {
    compute_reusing(run, g, None)
}

/// [`compute`], taking from `base` (the contact of the same run with gains
/// `base.0`) every stage whose inputs `g` leaves unchanged: the drive fit
/// (x0's gain), the velocity stage with its lag and offset search (x2's
/// and v2's gains, same window), the accelerometer stage (also a2's gain)
/// and ẋ1 (x1's gain). The result is [`compute`]'s, bit for bit: a reused
/// stage would repeat the same operations on the same numbers. The
/// calibration budget re-computes the contact with one gain perturbed at a
/// time, so most of each re-computation is reused.
pub(crate) fn compute_reusing(
    run: &Run,
    g: &Gains,
    base: Option<(&Gains, &Contact)>,
) -> Option<Contact> {
    let rs = &run.resampled;
    let rig = &run.rig;
    let dt = 1.0 / rs.rate_hz;
    let scale = |v: &[f64], k: f64| -> Vec<f64> { v.iter().map(|x| x * k).collect() };
    // A column whose gain the base shares is the base's (not a copy).
    let x1: Column = match base {
        Some((bg, c)) if bg.x1 == g.x1 => c.x1.clone(),
        _ if g.x1 == 1.0 => rs.x1.clone(),
        _ => scale(&rs.x1, g.x1).into(),
    };
    let x2: Column = match base {
        Some((bg, c)) if bg.x2 == g.x2 => c.x2.clone(),
        _ if g.x2 == 1.0 => rs.x2.clone(),
        _ => scale(&rs.x2, g.x2).into(),
    };

    let drive = match base {
        Some((bg, c)) if bg.x0 == g.x0 => c.drive,
        _ => fit_drive(&rs.t, &scale(&rs.x0, g.x0), rig.drive_frequency_hz)?,
    };
    // Window: about 1/60 of a drive period (≈ 10 ms at 1.72 Hz), at least 2.
    let half = ((rs.rate_hz / drive.frequency_hz / 60.0).round() as usize).max(2);
    // Later stages are reused only over the same window.
    let base = base.filter(|(_, c)| c.half_window == half);

    // Velocity stage (x2, v2).
    let same_velocity = base.filter(|(bg, _)| bg.x2 == g.x2 && bg.v2 == g.v2);
    let mut warnings;
    let (v2, v2_lag_s, v2_offset, v2_smooth) = match same_velocity {
        Some((_, c)) => {
            warnings = c.warnings[..c.velocity_warnings].to_vec();
            (c.v2.clone(), c.v2_lag_s, c.v2_offset, c.v2_smooth.clone())
        }
        None => {
            warnings = Vec::new();
            let dx2 = savgol(&x2, dt, half, 3, 1);
            let v2_raw = scale(&rs.v2, g.v2);
            let (v2, lag, offset) = velocity(run, v2_raw, &x2, dx2, (dt, half), &mut warnings);
            let v2_smooth = savgol(&v2, dt, half, 3, 0);
            (v2.into(), lag, offset, v2_smooth.into())
        }
    };
    let velocity_warnings = warnings.len();

    // Acceleration stage (a2, or the derivative of v2).
    let mut a2_offset = 0.0;
    let mut a2_sensor = None;
    let (a2, a2_lag_s, source) = match (same_velocity, &rs.a2) {
        (Some((bg, c)), Some(_)) if run.has_acceleration && bg.a2 == g.a2 => {
            warnings.extend_from_slice(&c.warnings[c.velocity_warnings..]);
            a2_offset = c.a2_offset;
            a2_sensor = c.a2_sensor.clone();
            (c.a2.clone(), c.a2_lag_s, c.acceleration_source)
        }
        (Some((_, c)), _) if !run.has_acceleration || rs.a2.is_none() => {
            (c.a2.clone(), None, "savitzky-golay")
        }
        (_, Some(a)) if run.has_acceleration => {
            let dv2 = savgol(&v2, dt, half, 3, 1);
            let acc = acceleration(scale(a, g.a2), &v2, &dv2, (dt, half), &mut warnings);
            a2_offset = acc.offset;
            a2_sensor = Some(acc.sensor.into());
            (acc.merged.into(), Some(acc.lag), "accelerometer")
        }
        _ => (savgol(&v2, dt, half, 3, 1).into(), None, "savitzky-golay"),
    };
    let v1 = match base {
        Some((bg, c)) if bg.x1 == g.x1 => c.v1.clone(),
        _ => savgol(&x1, dt, half, 3, 1).into(),
    };
    let (m2, k2, d) = (rig.m2_kg, rig.k2_n_per_m, rig.d_n_s_per_m);
    let r: Vec<f64> = (0..rs.len())
        .map(|i| {
            let passive = -k2 * (x2[i] - x1[i]) + d * v1[i];
            passive - m2 * a2[i] - d * v2[i]
        })
        .collect();
    Some(Contact {
        t: match base {
            Some((_, c)) => c.t.clone(),
            None => rs.t.clone(),
        },
        dt,
        k2_n_per_m: k2,
        x1,
        x2,
        v2,
        v2_smooth,
        a2,
        v1,
        d_n_s_per_m: d,
        m2_kg: m2,
        r: r.into(),
        drive,
        v2_offset,
        a2_offset,
        a2_sensor,
        v2_lag_s,
        a2_lag_s,
        acceleration_source: source,
        half_window: half,
        warnings,
        velocity_warnings,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The rotation agrees with libm to the rounding of ω·t on uniform,
    /// jittered and gapped sample times, and runs over re-anchors.
    #[test]
    fn rotation_matches_libm() {
        let w = 2.0 * std::f64::consts::PI * 3.7;
        let dt = 1.0 / 2000.0;
        let mut t: Vec<f64> = (0..20_000).map(|i| 10.0 + i as f64 * dt).collect();
        // A gap, then jitter, then uniform again.
        t.drain(5_000..5_100);
        for (i, ti) in t.iter_mut().enumerate().skip(9_000).take(500) {
            *ti += 1e-7 * ((i * 7919) % 13) as f64;
        }
        let mut rot = Rotation::new(w);
        let mut worst = 0.0f64;
        for &ti in &t {
            let e = rot.at(ti);
            let d = C64::from_polar(1.0, w * ti);
            // libm's own argument carries ε·ω·t, the accepted deviation of
            // t from the anchor's grid 4(k+1)·ε·ω·t; the rotation adds a few
            // ε per sample over at most ROTATION_RUN samples.
            let run = ROTATION_RUN as f64;
            let bound = 4.0 * f64::EPSILON * ((run + 2.0) * w * ti + run);
            worst = worst.max((e - d).norm() / bound);
        }
        assert!(worst <= 1.0, "rotation off by {worst} of its bound");
        assert!(worst > 0.0, "the rotation path was never taken");
    }

    #[test]
    fn drive_fit_recovers_amplitude_and_frequency() {
        let dt = 1e-3;
        let t: Vec<f64> = (0..20000).map(|i| i as f64 * dt).collect();
        let mut rng = crate::stats::Rng::new(3);
        let x: Vec<f64> = t
            .iter()
            .map(|&t| {
                1e-5 + 2.53e-3 * (2.0 * std::f64::consts::PI * 1.7213 * t - 0.4).cos()
                    + 2e-6 * rng.normal()
            })
            .collect();
        let d = fit_drive(&t, &x, Some(1.72)).unwrap();
        assert!((d.amplitude_m - 2.53e-3).abs() < 2e-7, "{}", d.amplitude_m);
        assert!((d.frequency_hz - 1.7213).abs() < 1e-5);
        let d2 = fit_drive(&t, &x, None).unwrap();
        assert!((d2.amplitude_m - 2.53e-3).abs() < 2e-7);
    }

    #[test]
    fn lag_and_velocity_offset_are_recovered() {
        let dt = 1e-3;
        let w = 2.0 * std::f64::consts::PI * 1.72;
        let n = 10000;
        let x: Vec<f64> = (0..n).map(|i| 0.003 * (w * i as f64 * dt).sin()).collect();
        // v lags by 0.7 ms and carries an offset of 0.1 mm/s.
        let v: Vec<f64> = (0..n)
            .map(|i| 0.003 * w * (w * (i as f64 * dt - 0.0007)).cos() + 1e-4)
            .collect();
        let dx = savgol(&x, dt, 10, 3, 1);
        let (lag, _) = estimate_lag(&v, &dx, dt, 0.01).unwrap();
        assert!((lag - 0.0007).abs() < 2e-5, "{lag}");
        let vs = shift(&v, dt, lag);
        let off = rate_offset(&x, &vs, dt);
        assert!((off - 1e-4).abs() < 2e-6, "{off}");
    }
}
