//! Channel delays and velocity-sensor consistency, estimated from the log
//! itself (issue 30).
//!
//! Every shift here has the meaning and sign of a channel map's `shift_s`:
//! the value stamped t was taken at t + shift, so a channel that lags by
//! 3 ms needs the shift −3 ms. All shifts are relative to x1 (the
//! reference: the tool cannot tell a delay common to every channel from a
//! later log start, and it does not matter for the fit).
//!
//! * **x0 and x2 against x1, through the physics.** M1's equation of motion
//!   `M1 ẍ1 + d(ẋ1 − ẋ2) + K1(x1 − x0) + K2(x1 − x2) = 0` holds without the
//!   friction force, and it is linear: every term filtered by the same
//!   zero-phase low-pass still satisfies it. With the rig's constants, the
//!   known part `y = M1 ẍ1 + d ẋ1 + (K1 + K2) x1 − d ẋ2` is regressed on
//!   `K1 x0, K1 ẋ0, K2 x2, K2 ẋ2, 1, t`: a shifted channel x(t + s) ≈ x + s·ẋ,
//!   so the coefficient ratio of ẋ to x is the shift (the gains of x0 and x2
//!   relative to x1 are the other coefficients, the sensor offsets the
//!   constant, a slow drift the line). The stick-slip harmonics of x2 pin
//!   x2's gain and shift; what is left of the fundamental pins the drive's.
//!   Gauss–Newton: the shifted channels are re-aligned and the remaining
//!   shift re-estimated until it is below a microsecond (at most 5 rounds).
//! * **v2 against d/dt x2, a2 against d/dt v2** (or d²/dt² x2 without a
//!   velocity channel): the same linearised regression on the derivative,
//!   with gain, offset and linear offset drift as nuisance parameters (the
//!   velocity's are reported as its consistency with x2). Their shifts are
//!   relative to the reference channel, so x2's (v2's) shift is added.
//! * **Uncertainty**: a cluster-robust sandwich over contiguous blocks of
//!   half a drive period (residuals of filtered signals are correlated
//!   within a block), Student's t with blocks − parameters degrees of
//!   freedom, the delta method for the ratio; a relative shift's variance
//!   adds the reference channel's.
//! * **A channel that does not move** (its filtered range within 20 times
//!   its noise) has no shift (`None`, `null` in JSON); a still x2 leaves its
//!   terms out of M1's regression.
//! * **Applied**: a shift whose 95 % interval excludes zero, that is at
//!   least twice its 95 % half-width; the channel's samples are re-stamped
//!   and the common grid rebuilt, with a warning that gives the numbers.
//!   The positions x0 and x2 get such a shift from a tenth of a sample
//!   (below that the estimator's own bias; the rest enters the fit's
//!   intervals as the alignment's uncertainty): behind a
//!   compliant contact the threshold shows only as a deflection of tens of
//!   µm, and a sub-sample lag between x1 and x2 (a sensor's low-pass
//!   filter) of 1 ms biased Rs by −7 % with an interval that missed, the
//!   law adequate (docs/measurements.md, session 27). v2 and a2, which
//!   only decide stick and slip, get their own shift (beyond x2's) only
//!   from one sample of the grid: below that it is typical of the
//!   transducer's filter, reported (`channel_delays_interval_s`) and left
//!   to the identification's own alignment of v2 with d/dt x2. A velocity
//!   offset drift is removed where it is significant and its size over the
//!   log exceeds half the velocity's noise.

// Index loops mirror the formulas (several arrays indexed together).
#![allow(clippy::needless_range_loop)]

use super::{Quantity, Resampled, RigMeta};
use crate::stats::regress::{deriv, gauss_smooth, ols, ratio, Ols, Scales};
use crate::stats::{mad_sigma, quantile};
use crate::warning::Warning;

/// A channel moves when its filtered range exceeds this many noise σ.
const MOVES_FACTOR: f64 = 20.0;
/// v2's and a2's own shifts (beyond x2's) below this many sample
/// intervals of the grid are not applied: sub-sample lags of a transducer's
/// filter are left to the identification's alignment of v2 with d/dt x2.
/// The positions have a lower floor, [`MIN_POSITION_SHIFT_SAMPLES`]
/// (until session 27 they had this one: the output-error fit was to take
/// up their sub-sample lags, but it fits them only where the residuals
/// show them, and behind a compliant contact a 1-ms lag biased Rs by −7 %
/// with adequate residuals). (A correct
/// sub-sample shift once made a synth log inadequate, 8× its noise: not
/// the shift but the stick segmentation, which carried a stick across a
/// lost buffer and anchored a shooting segment at rest where M2 slid;
/// fixed in `identify::segment`, docs/measurements.md.)
const MIN_SHIFT_SAMPLES: f64 = 1.0;
/// x0's and x2's shifts below this many sample intervals are not applied:
/// the estimator's own bias (x0 read 18.1 ± 0.02 µs on a 12-s ideal-sensor
/// log at 1 kHz, where nothing lags: 0.02 samples; applied, it moved ρs by
/// 4e-4). What is left enters the fit's intervals (the alignment budget,
/// `identify::output_error::Refinement::with_alignment_uncertainty`).
const MIN_POSITION_SHIFT_SAMPLES: f64 = 0.1;
/// A shift is applied only when it is at least this many times its 95 %
/// half-width.
const PRECISION: f64 = 2.0;

/// The delay of one channel.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ChannelDelay {
    /// Which channel.
    pub quantity: Quantity,
    /// The shift applied (s): the declared one plus the estimated one
    /// where that was applied.
    pub shift_s: f64,
    /// The shift declared by a channel map (s).
    pub declared_s: f64,
    /// The estimated shift beyond the declared one (s), `None` where it
    /// cannot be estimated (the channel does not move).
    pub estimated_s: Option<f64>,
    /// 95 % interval of the total shift (declared + estimated), if estimated.
    pub interval_s: Option<[f64; 2]>,
    /// Whether the estimated part was applied.
    pub applied: bool,
}

/// The velocity channel against the derivative of x2:
/// `v2 = gain·ẋ2(t + shift) + offset + drift·(t − t_mid)`.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct VelocityConsistency {
    /// Gain of v2 relative to x2.
    pub gain: f64,
    /// Its standard error.
    pub gain_se: f64,
    /// Offset at the middle of the log (m/s).
    pub offset_m_per_s: f64,
    /// Linear drift of the offset (m/s per s).
    pub drift_m_per_s2: f64,
    /// Its standard error.
    pub drift_se: f64,
    /// RMS of the regression's residual over the filtered velocity's noise.
    pub residual_ratio: f64,
    /// Whether the drift was removed from v2.
    pub drift_corrected: bool,
    /// Whether v2 was divided by the gain (x2 sets the scale): significant
    /// and more than [`VELOCITY_GAIN_TOLERANCE`] off 1 (false in
    /// artifacts written before it existed).
    #[serde(default)]
    pub gain_corrected: bool,
}

/// How far v2's gain may sit from d/dt x2's before v2 is rescaled: two
/// sensors within the default calibration budget (1 % each) differ by up
/// to 2 %; beyond that the velocity channel is miscalibrated and, left
/// alone, scales every force computed from it (the inertia M2·ẍ2 from a
/// differentiated v2: a 10 % gain moved the equation-error Rd by 10 %).
pub const VELOCITY_GAIN_TOLERANCE: f64 = 0.02;

/// Whether a rate channel with `gain` (standard error `se`, Student-t
/// quantile `tq`) against x2 is rescaled: significant and more than
/// [`VELOCITY_GAIN_TOLERANCE`] off 1.
fn rescaled(gain: f64, se: f64, tq: f64) -> bool {
    let off = (gain - 1.0).abs();
    gain.is_finite() && gain > 0.0 && off > VELOCITY_GAIN_TOLERANCE && off > tq * se
}

/// The accelerometer against d/dt v2 (or d²/dt² x2), on x2's scale:
/// `a2 = gain·ẍ2(t + shift) + offset + drift·(t − t_mid)`, the gain of a
/// v2 reference multiplied in.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct AccelerationConsistency {
    /// Gain of a2 relative to x2.
    pub gain: f64,
    /// Its standard error.
    pub gain_se: f64,
    /// Whether a2 was divided by the gain: significant and more than
    /// [`VELOCITY_GAIN_TOLERANCE`] off 1.
    pub gain_corrected: bool,
}

/// What the estimator found and did.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ChannelDelays {
    /// Per present channel among x0, x1, x2, v2, a2 (x1: the reference,
    /// its declared shift only).
    pub channels: Vec<ChannelDelay>,
    /// The velocity channel's consistency with x2, where both move.
    pub velocity: Option<VelocityConsistency>,
    /// The accelerometer's gain against x2, where both move (absent in
    /// artifacts written before it existed).
    #[serde(default)]
    pub acceleration: Option<AccelerationConsistency>,
}

impl ChannelDelays {
    /// The entry of a channel.
    pub fn get(&self, q: Quantity) -> Option<&ChannelDelay> {
        self.channels.iter().find(|c| c.quantity == q)
    }

    /// The standard uncertainty (s) of the drive's and of x2's alignment
    /// with x1 that these shifts leave (s = half-width/1.96 of a shift's
    /// interval): an applied shift is known to s; a precise one left
    /// unapplied (below [`MIN_POSITION_SHIFT_SAMPLES`], the estimator's own
    /// bias) is a misalignment within ±shift, σ² = shift²/3 + s²; an
    /// imprecise one leaves its whole estimate, σ² = shift² + s²; a channel
    /// without an estimate (it does not move) none. The output-error
    /// intervals carry it (`identify::output_error::Refinement::with_alignment_uncertainty`).
    pub fn alignment_sigma(&self) -> (f64, f64) {
        let sigma = |q: Quantity| -> f64 {
            let Some(c) = self.get(q) else {
                return 0.0;
            };
            let (Some(e), Some([lo, hi])) = (c.estimated_s, c.interval_s) else {
                return 0.0;
            };
            let half = 0.5 * (hi - lo);
            let s = half / 1.96;
            let v = if c.applied {
                s * s
            } else if e.abs() >= PRECISION * half {
                e * e / 3.0 + s * s
            } else {
                e * e + s * s
            };
            if v.is_finite() {
                v.sqrt()
            } else {
                0.0
            }
        };
        (sigma(Quantity::X0), sigma(Quantity::X2))
    }
}

/// One estimated shift (relative to its reference) with its variance.
#[derive(Debug, Clone, Copy)]
struct Shift {
    s: f64,
    var: f64,
    /// t quantile for the 95 % interval (its degrees of freedom).
    tq: f64,
}

impl Shift {
    fn half(&self) -> f64 {
        self.tq * self.var.sqrt()
    }
    fn significant(&self) -> bool {
        self.var.is_finite() && self.s.abs() > self.half()
    }
}

/// `out(t) = y(t + s)` by linear interpolation on the grid (NaN outside).
pub(crate) fn shift_grid(y: &[f64], dt: f64, s: f64) -> Vec<f64> {
    let q = s / dt;
    let k = q.floor();
    let f = q - k;
    let k = k as i64;
    let n = y.len() as i64;
    (0..n)
        .map(|i| {
            let j = i + k;
            if j < 0 || j + 1 >= n {
                f64::NAN
            } else {
                let (a, b) = (y[j as usize], y[j as usize + 1]);
                a + f * (b - a)
            }
        })
        .collect()
}

/// Noise σ of a raw record from its second differences (white noise).
fn noise_of(y: &[f64]) -> f64 {
    let d2: Vec<f64> = y
        .windows(3)
        .map(|w| w[2] - 2.0 * w[1] + w[0])
        .filter(|v| v.is_finite())
        .collect();
    if d2.len() < 10 {
        return f64::NAN;
    }
    mad_sigma(&d2) / 6f64.sqrt()
}

/// Whether a filtered record moves far beyond the raw record's noise.
fn moves(raw: &[f64], smooth: &[f64]) -> bool {
    let fin: Vec<f64> = smooth.iter().copied().filter(|v| v.is_finite()).collect();
    if fin.len() < 100 {
        return false;
    }
    let range = quantile(&fin, 0.99) - quantile(&fin, 0.01);
    let noise = noise_of(raw);
    range.is_finite() && noise.is_finite() && range > MOVES_FACTOR * noise.max(f64::MIN_POSITIVE)
}

/// The smoothed signals and their derivatives the regressions use.
struct Prepared {
    dt: f64,
    block: usize,
    tau: Vec<f64>,
}

/// x0's and x2's shifts against x1 from M1's equation (`None` for a
/// channel that does not move or where the regression fails).
fn physics_shifts(
    r: &Resampled,
    rig: &RigMeta,
    pre: &Prepared,
    sigma: f64,
    x2_moves: bool,
) -> (Option<Shift>, Option<Shift>) {
    let dt = pre.dt;
    let sm = |y: &[f64]| gauss_smooth(y, sigma);
    // M1's side of the equation without x2's damping term, once (the same
    // sum as term by term below: a long log holds two columns fewer).
    let x1_side: Vec<f64> = {
        let (m1, k1, k2, d) = (rig.m1_kg, rig.k1_n_per_m, rig.k2_n_per_m, rig.d_n_s_per_m);
        let x1s = sm(&r.x1);
        let x1d = deriv(&x1s, dt);
        let x1dd = deriv(&x1d, dt);
        (0..r.len())
            .map(|i| m1 * x1dd[i] + d * x1d[i] + (k1 + k2) * x1s[i])
            .collect()
    };
    let x0s0 = sm(&r.x0);
    let x2s0 = sm(&r.x2);
    let (k1, k2, d) = (rig.k1_n_per_m, rig.k2_n_per_m, rig.d_n_s_per_m);
    let ones = vec![1.0; r.len()];
    let (mut s0, mut s2) = (0.0, 0.0);
    let mut last: Option<(Shift, Option<Shift>)> = None;
    for _ in 0..5 {
        let x0s = shift_grid(&x0s0, dt, s0);
        let x2s = shift_grid(&x2s0, dt, s2);
        let x0d = deriv(&x0s, dt);
        let x2d = deriv(&x2s, dt);
        let y: Vec<f64> = (0..r.len()).map(|i| x1_side[i] - d * x2d[i]).collect();
        // The scaled columns in the buffers of the signals they scale (a
        // long log holds four columns fewer; the same products).
        let scaled = |mut v: Vec<f64>, k: f64| {
            v.iter_mut().for_each(|x| *x *= k);
            v
        };
        let kx0 = scaled(x0s, k1);
        let kx0d = scaled(x0d, k1);
        let kx2 = scaled(x2s, k2);
        let kx2d = scaled(x2d, k2);
        let mut cols: Vec<&[f64]> = vec![&kx0, &kx0d, &kx2];
        if x2_moves {
            cols.push(&kx2d);
        }
        cols.push(&ones);
        cols.push(&pre.tau);
        let Some(o) = ols(&cols, &y, pre.block) else {
            return (None, None);
        };
        let Some((d0, v0)) = ratio(&o, 1, 0) else {
            return (None, None);
        };
        let d2 = if x2_moves { ratio(&o, 3, 2) } else { None };
        s0 += d0;
        let mut done = d0.abs() < 1e-6;
        if let Some((d2, _)) = d2 {
            s2 += d2;
            done &= d2.abs() < 1e-6;
        }
        let sh0 = Shift {
            s: s0,
            var: v0,
            tq: o.tq,
        };
        let sh2 = d2.map(|(_, v)| Shift {
            s: s2,
            var: v,
            tq: o.tq,
        });
        last = Some((sh0, sh2));
        if done || s0.abs() > 0.1 || s2.abs() > 0.1 {
            break;
        }
    }
    // The regression reads a channel ahead by s (x(t + s) is the value at
    // t): the channel's stamps are late by s, its shift is −s. Beyond
    // ±100 ms the linearisation is meaningless: no estimate.
    let flip = |sh: Shift| Shift { s: -sh.s, ..sh };
    match last {
        Some((a, b)) => (
            (a.s.abs() <= 0.1).then_some(flip(a)),
            b.filter(|b| b.s.abs() <= 0.1).map(flip),
        ),
        None => (None, None),
    }
}

/// The shift of `y` (filtered) against the reference rate `reference`
/// (filtered, already a derivative): `y = g·ref(t + s) + c0 + c1·τ`.
/// Returns the shift and the regression (for its gain, offset, drift).
fn rate_shift(y_s: &[f64], reference: &[f64], pre: &Prepared) -> Option<(Shift, Ols)> {
    let dt = pre.dt;
    let ones = vec![1.0; y_s.len()];
    let mut s = 0.0;
    let mut out = None;
    for _ in 0..5 {
        let rf = shift_grid(reference, dt, s);
        let rd = deriv(&rf, dt);
        let o = ols(&[&rf, &rd, &ones, &pre.tau], y_s, pre.block)?;
        let (ds, var) = ratio(&o, 1, 0)?;
        s += ds;
        let tq = o.tq;
        out = Some((Shift { s, var, tq }, o));
        if ds.abs() < 1e-6 || s.abs() > 0.1 {
            break;
        }
    }
    out.filter(|(sh, _)| sh.s.abs() <= 0.1)
}

/// Everything [`estimate`] found, before it is applied.
#[derive(Debug, Clone)]
pub(crate) struct Estimate {
    /// Estimated shifts (relative to x1) with variance, per quantity.
    shifts: Vec<(Quantity, Option<Shift>)>,
    /// The applied estimated shift per quantity.
    pub(crate) applied: Vec<(Quantity, f64)>,
    /// The velocity's consistency and its drift to remove (m/s per s).
    pub(crate) velocity: Option<VelocityConsistency>,
    /// The accelerometer's gain (to divide a2 by where corrected).
    pub(crate) acceleration: Option<AccelerationConsistency>,
    /// Warnings with the numbers.
    pub(crate) warnings: Vec<Warning>,
}

/// Estimates the shifts of x0, x2, v2 and a2 against x1 (and the velocity's
/// consistency with x2) on the common grid `r` of a log with rig `rig`.
pub(crate) fn estimate(r: &Resampled, rig: &RigMeta) -> Estimate {
    let n = r.len();
    let Scales { dt, sigma, block } = Scales::of(r.rate_hz, rig.drive_frequency_hz);
    let tm = r.t.get(n / 2).copied().unwrap_or(0.0);
    let pre = Prepared {
        dt,
        block,
        tau: r.t.iter().map(|t| t - tm).collect(),
    };
    let mut warnings = Vec::new();
    let x2s = gauss_smooth(&r.x2, sigma);
    let x2d = deriv(&x2s, dt);
    let x2_moves = moves(&r.x2, &x2s);
    drop(x2s);
    let x0_moves = moves(&r.x0, &gauss_smooth(&r.x0, sigma));
    let (sh0, sh2) = if x0_moves {
        physics_shifts(r, rig, &pre, sigma, x2_moves)
    } else {
        (None, None)
    };
    let min_shift = MIN_SHIFT_SAMPLES * dt;
    // Applied only where known to within half its size (95 %): then the
    // correction cannot leave a larger misalignment than it removes. An
    // imprecise sub-millisecond estimate (a sensor filter's lag, ±0.9 ms
    // on some synth logs) applied as it stands misaligned the log further;
    // what is left unapplied enters the output-error intervals
    // (`ChannelDelays::alignment_sigma`), and the fit's own lags of x1 and
    // x2 take it up where the residuals show it.
    let precise = |s: &Shift| s.significant() && s.s.abs() >= PRECISION * s.half();
    let applies = |s: &Shift| precise(s) && s.s.abs() > min_shift;
    let applies_position = |s: &Shift| precise(s) && s.s.abs() > MIN_POSITION_SHIFT_SAMPLES * dt;
    let mut applied = Vec::new();
    let mut shifts = Vec::new();
    let mut record =
        |q: Quantity, est: Option<Shift>, applied_s: f64, applied: &mut Vec<(Quantity, f64)>| {
            shifts.push((q, est));
            applied.push((q, applied_s));
        };
    // The positions: every precise shift from a tenth of a sample.
    let a0 = sh0.filter(applies_position).map_or(0.0, |s| s.s);
    record(Quantity::X0, sh0, a0, &mut applied);
    let a2x = sh2.filter(applies_position).map_or(0.0, |s| s.s);
    record(Quantity::X2, sh2, a2x, &mut applied);

    // v2 against d/dt x2.
    let has_v = r.v2.iter().any(|v| v.is_finite());
    let mut v_total: Option<Shift> = None;
    let mut v_applied = a2x;
    let mut velocity = None;
    let v2s = gauss_smooth(&r.v2, sigma);
    if has_v && x2_moves {
        if let Some((rel, o)) = rate_shift(&v2s, &x2d, &pre) {
            let base = sh2.unwrap_or(Shift {
                s: 0.0,
                var: 0.0,
                tq: rel.tq,
            });
            v_total = Some(Shift {
                s: base.s + rel.s,
                var: base.var + rel.var,
                tq: rel.tq.max(base.tq),
            });
            // Sub-sample lags of v2 against x2 (a sensor low-pass) are left
            // to the identification's own alignment of v2 with d/dt x2.
            if applies(&rel) && rel.s.abs() >= dt {
                v_applied = a2x + rel.s;
            }
            let noise_v = noise_of(&r.v2);
            // The filtered velocity's noise: σ·sqrt(Σw²)/Σw for the Gaussian.
            let noise_vs = noise_v / (2.0 * sigma * std::f64::consts::PI.sqrt()).sqrt();
            let fin: Vec<f64> = o.resid.iter().copied().filter(|v| v.is_finite()).collect();
            let rms = (fin.iter().map(|v| v * v).sum::<f64>() / fin.len().max(1) as f64).sqrt();
            let (gain, drift) = (o.beta[0], o.beta[3]);
            let drift_se = o.cov[3][3].sqrt();
            let span = r.duration_s();
            let drift_corrected =
                drift.abs() > o.tq * drift_se && drift.abs() * span > 0.5 * noise_v;
            let gain_se = o.cov[0][0].sqrt();
            let gain_corrected = rescaled(gain, gain_se, o.tq);
            velocity = Some(VelocityConsistency {
                gain,
                gain_se,
                offset_m_per_s: o.beta[2],
                drift_m_per_s2: drift,
                drift_se,
                residual_ratio: rms / noise_vs,
                drift_corrected,
                gain_corrected,
            });
            if drift_corrected {
                warnings.push(Warning::VelocityDrift {
                    drift_m_per_s2: drift,
                    span_s: span,
                    half_width_m_per_s2: o.tq * drift_se,
                });
            }
            if gain_corrected {
                warnings.push(Warning::VelocityGain {
                    gain,
                    half_width: o.tq * gain_se,
                    tolerance: VELOCITY_GAIN_TOLERANCE,
                });
            }
        }
    }
    let v_present = has_v;
    if v_present {
        record(Quantity::V2, v_total, v_applied, &mut applied);
    }

    let mut acceleration = None;
    // a2 against d/dt v2 (or d²/dt² x2).
    if let Some(a2) = &r.a2 {
        let a2s = gauss_smooth(a2, sigma);
        // The reference's gain against x2 (v2's where v2 is the reference).
        let (reference, base, base_applied, ref_gain) = match velocity {
            Some(v) if has_v && v_total.is_some() => (deriv(&v2s, dt), v_total, v_applied, v.gain),
            _ => (deriv(&x2d, dt), sh2, a2x, 1.0),
        };
        let mut total = None;
        let mut a_applied = base_applied;
        if x2_moves {
            if let Some((rel, o)) = rate_shift(&a2s, &reference, &pre) {
                let gain = o.beta[0] * ref_gain;
                let gain_se = o.cov[0][0].sqrt() * ref_gain.abs();
                let gain_corrected = rescaled(gain, gain_se, o.tq);
                acceleration = Some(AccelerationConsistency {
                    gain,
                    gain_se,
                    gain_corrected,
                });
                if gain_corrected {
                    warnings.push(Warning::AccelerationGain {
                        gain,
                        half_width: o.tq * gain_se,
                        tolerance: VELOCITY_GAIN_TOLERANCE,
                    });
                }
                let b = base.unwrap_or(Shift {
                    s: 0.0,
                    var: 0.0,
                    tq: rel.tq,
                });
                total = Some(Shift {
                    s: b.s + rel.s,
                    var: b.var + rel.var,
                    tq: rel.tq.max(b.tq),
                });
                if applies(&rel) && rel.s.abs() >= dt {
                    a_applied = base_applied + rel.s;
                }
            }
        }
        record(Quantity::A2, total, a_applied, &mut applied);
    }
    Estimate {
        shifts,
        applied,
        velocity,
        acceleration,
        warnings,
    }
}

impl Estimate {
    /// The report: declared shifts (per quantity) plus what was estimated
    /// and applied.
    pub(crate) fn report(&self, declared: &[(Quantity, f64)]) -> ChannelDelays {
        let dec = |q: Quantity| {
            declared
                .iter()
                .find(|(d, _)| *d == q)
                .map_or(0.0, |(_, s)| *s)
        };
        let mut channels = vec![ChannelDelay {
            quantity: Quantity::X1,
            shift_s: dec(Quantity::X1),
            declared_s: dec(Quantity::X1),
            estimated_s: Some(0.0),
            interval_s: Some([dec(Quantity::X1); 2]),
            applied: false,
        }];
        for ((q, est), (_, ap)) in self.shifts.iter().zip(&self.applied) {
            let d = dec(*q);
            channels.push(ChannelDelay {
                quantity: *q,
                shift_s: d + ap,
                declared_s: d,
                estimated_s: est.map(|e| e.s),
                interval_s: est.map(|e| [d + e.s - e.half(), d + e.s + e.half()]),
                applied: *ap != 0.0,
            });
        }
        channels.sort_by_key(|c| c.quantity);
        ChannelDelays {
            channels,
            velocity: self.velocity,
            acceleration: self.acceleration,
        }
    }
}

/// Warnings for the shifts applied that exceed one grid sample.
pub(crate) fn shift_warnings(d: &ChannelDelays, dt: f64) -> Vec<Warning> {
    let mut w = Vec::new();
    for c in &d.channels {
        let est = c.shift_s - c.declared_s;
        if c.applied && est.abs() >= dt {
            let (lo, hi) = c.interval_s.map_or((f64::NAN, f64::NAN), |i| (i[0], i[1]));
            w.push(Warning::ChannelDelay {
                channel: c.quantity.name(),
                shift_s: est,
                interval_s: (lo, hi),
                declared_s: c.declared_s,
            });
        }
    }
    w
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shift_grid_moves_forward() {
        let y: Vec<f64> = (0..10).map(|i| i as f64).collect();
        let s = shift_grid(&y, 0.5, 0.25);
        assert!((s[2] - 2.5).abs() < 1e-12);
        assert!(s[9].is_nan());
    }

    #[test]
    fn gauss_smooth_keeps_lines() {
        let y: Vec<f64> = (0..100).map(|i| 3.0 * i as f64 + 1.0).collect();
        let s = gauss_smooth(&y, 2.0);
        for i in 10..90 {
            assert!((s[i] - y[i]).abs() < 1e-9);
        }
        assert!(s[0].is_nan() && s[99].is_nan());
    }

    /// A rate signal that is the derivative of a reference taken 2.5 ms
    /// later (it leads: shift +2.5 ms), with gain, offset, drift and
    /// noise: the shift, gain and drift come back within their intervals;
    /// the sign follows `shift_s`.
    #[test]
    fn rate_shift_recovers_known_shift_and_sign() {
        let dt = 1e-3;
        let n = 20_000;
        let t: Vec<f64> = (0..n).map(|i| i as f64 * dt).collect();
        let x = |t: f64| (2.0 * t).sin() * 1e-3 + 2e-4 * (7.0 * t).sin() + 1e-4 * (13.0 * t).cos();
        let xd = |t: f64| {
            2e-3 * (2.0 * t).cos() + 7.0 * 2e-4 * (7.0 * t).cos() - 13.0 * 1e-4 * (13.0 * t).sin()
        };
        let mut rng = crate::stats::Rng::new(1);
        for shift in [0.0025, -0.004, 0.0] {
            let v: Vec<f64> = t
                .iter()
                .map(|&t| 1.02 * xd(t + shift) + 1e-4 + 2e-5 * (t - 10.0) + 1e-5 * rng.normal())
                .collect();
            let xr: Vec<f64> = t.iter().map(|&t| x(t)).collect();
            let pre = Prepared {
                dt,
                block: 250,
                tau: t.iter().map(|t| t - 10.0).collect(),
            };
            let xs = gauss_smooth(&xr, 3.0);
            let xd_s = deriv(&xs, dt);
            let vs = gauss_smooth(&v, 3.0);
            let (sh, o) = rate_shift(&vs, &xd_s, &pre).unwrap();
            assert!((sh.s - shift).abs() < 2e-5, "{shift}: {}", sh.s);
            assert!(
                (sh.s - shift).abs() < sh.half() + 2e-6,
                "{shift}: {} ± {}",
                sh.s,
                sh.half()
            );
            assert!((o.beta[0] - 1.02).abs() < 1e-3);
            assert!((o.beta[3] - 2e-5).abs() < 2e-6);
        }
    }

    /// A still channel does not move; a moving one does.
    #[test]
    fn still_channels_do_not_move() {
        let mut rng = crate::stats::Rng::new(1);
        let still: Vec<f64> = (0..5000).map(|_| 1e-6 * rng.normal()).collect();
        assert!(!moves(&still, &gauss_smooth(&still, 3.0)));
        let moving: Vec<f64> = (0..5000)
            .map(|i| 1e-3 * (i as f64 * 0.01).sin() + 1e-6 * rng.normal())
            .collect();
        assert!(moves(&moving, &gauss_smooth(&moving, 3.0)));
    }
}
