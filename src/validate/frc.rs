//! Measured frequency response of a sweep log (paper §4.2, Fig. 10).
//!
//! What this module owns: turning a sweep [`Run`] into the points of a
//! frequency-response curve (η, A1/A, A2/A per step or per drive period),
//! the data's own call whether each step settled, and the drive-frequency
//! plan *as it was run* (for the replay prediction).
//!
//! * **Drive**: every frequency, phase and the drive amplitude come from the
//!   drive channel (least-squares sinusoids on its raw samples, frequency
//!   refined around the commanded one), not from the metadata. The log's
//!   drive amplitude is the median over steps (periods) of the per-window
//!   amplitudes.
//! * **Stepped sweeps**: the `/drive/setpoint` messages give the steps (a
//!   repeated frequency, such as a pre-roll, is one hold). Between two holds
//!   the frequency changes linearly over a ramp whose start and duration are
//!   *fitted to the drive signal* (phase continuous with the previous hold;
//!   coarse grid, then Nelder–Mead via argmin), so the plan does not depend
//!   on a controller convention. Each step's amplitude is taken over its
//!   last whole drive periods (at least [`FrcOptions::window_s`], at most
//!   half of the hold); the relative change between the two halves of that
//!   tail is the data's trend, and a step whose trend exceeds
//!   [`FrcOptions::settle_tolerance`] has visibly not settled.
//! * **Continuous sweeps**: the instantaneous frequency at each setpoint
//!   message (and at the log's ends) is fitted to the drive signal with the
//!   commanded chirp rate; the plan ramps linearly between these nodes; one
//!   point per drive period (period boundaries from the plan's phase).
//! * **Amplitudes** (paper eq. 6, made robust to noise): (max − min)/2 over
//!   the window of a local-polynomial reconstruction of x1 and x2
//!   (Savitzky–Golay, degree 4, half-width 1/16 of the drive period), with
//!   the extremes refined by a parabola through the three samples around
//!   them — not the raw extremes of noisy samples, which are biased upwards
//!   by about two noise σ. A mass that stands still measures 0: where the
//!   window's spread about a straight line is what its own noise gives
//!   (95 % test), the extremes would only be the noise's half-range.
//! * **Error bars**: each amplitude carries its own 95 % error bar (the
//!   estimator's noise and the x1 or x2 gain budget); the drive's
//!   uncertainty (its amplitude with the x0 gain, phase, frequency) belongs
//!   to the prediction's band (`predict`), not here.

use super::ValidateError;
use crate::identify::smooth::savgol;
use crate::ingest::{Quantity, Run, SweepKind as LogSweepKind};
use crate::sim::sweep::Direction;
use crate::stats::golden_section;
use crate::stats::median;
use crate::{Error, Result};
use argmin::core::{CostFunction, Executor, State};
use argmin::solver::neldermead::NelderMead;
use std::f64::consts::PI;

/// Stepped or continuous sweep.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SweepKind {
    /// Setpoints held for a dwell, ramps between them.
    Stepped,
    /// A slow continuous chirp.
    Continuous,
}

impl SweepKind {
    /// Name in JSON and reports.
    pub fn as_str(self) -> &'static str {
        match self {
            SweepKind::Stepped => "stepped",
            SweepKind::Continuous => "continuous",
        }
    }
}

/// One piece of the drive-frequency plan as it was run (SI, seconds from
/// log start). A hold has `f_start_hz == f_end_hz`; a ramp is linear in
/// frequency (continuous drive phase).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlanSegment {
    /// Start (s).
    pub start_s: f64,
    /// End (s).
    pub end_s: f64,
    /// Frequency at the start (Hz).
    pub f_start_hz: f64,
    /// Frequency at the end (Hz).
    pub f_end_hz: f64,
}

/// One measured point of the response.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MeasuredPoint {
    /// Drive frequency (Hz), measured from the drive channel.
    pub frequency_hz: f64,
    /// η = 2πf/√(K2/M2).
    pub eta: f64,
    /// Start of the step's dwell / the drive period (s).
    pub t_start_s: f64,
    /// End of the step's dwell / the drive period (s).
    pub t_end_s: f64,
    /// The part used for the amplitude (whole drive periods).
    pub window_s: (f64, f64),
    /// A1/A with the measured drive amplitude (paper eq. 6).
    pub amplitude1: f64,
    /// A2/A.
    pub amplitude2: f64,
    /// A1 (m).
    pub amplitude1_m: f64,
    /// A2 (m).
    pub amplitude2_m: f64,
    /// 95 % measurement uncertainty of A1/A (absolute), the measured
    /// value's own error bar: the amplitude estimator's noise (from the
    /// sensor noise measured in the log) and the x1 sensor's gain budget,
    /// combined in quadrature. The drive's uncertainty (its amplitude, with
    /// the x0 gain, phase and frequency) is not here: it is in the
    /// prediction's band.
    pub amplitude1_u: f64,
    /// The same for A2/A (x2's gain).
    pub amplitude2_u: f64,
    /// 95 % half-width of the amplitude estimator's noise for A1 (m).
    pub amplitude1_noise_m: f64,
    /// The same for A2 (m).
    pub amplitude2_noise_m: f64,
    /// Relative amplitude change between the two halves of the window
    /// (stepped sweeps).
    pub rel_change: Option<f64>,
    /// The data's own call whether the step settled: `Some(false)` when its
    /// trend says it had not, `Some(true)` when the trend is flat (a slow
    /// transient on a lightly damped rig can still hide there: the
    /// prediction's replay makes the final call), `None` if it cannot tell.
    pub settled: Option<bool>,
}

/// The drive's measurement uncertainty (1σ each): what the replay band
/// carries besides the law's (see `predict`).
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct DriveUncertainty {
    /// Relative standard uncertainty of the drive amplitude from the data
    /// (the scatter of the per-step or per-node amplitudes over their
    /// number, and each fit's noise). The x0 sensor's gain is not here: it
    /// is drawn with the law (`predict::draw_laws`).
    pub amplitude_rel: f64,
    /// Standard uncertainty of the drive phase φ(0) (rad).
    pub phase_rad: f64,
    /// Relative standard uncertainty of the drive frequencies (common to
    /// the plan).
    pub frequency_rel: f64,
    /// Standard uncertainty of the drive channel's timing against x1 (s):
    /// the ingest's delay estimate for x0 (its interval, and the estimate
    /// itself where it was not applied); 0 where it was not estimated.
    pub delay_s: f64,
}

/// The measured frequency response of one sweep log.
#[derive(Debug, Clone, PartialEq)]
pub struct MeasuredFrc {
    /// Stepped or continuous.
    pub kind: SweepKind,
    /// Order of the setpoints.
    pub direction: Direction,
    /// Drive amplitude measured from the drive channel (m).
    pub drive_amplitude_m: f64,
    /// φ(0): x0(t) ≈ offset + A·sin(φ(t)), φ' = 2πf(t).
    pub drive_phase_rad: f64,
    /// The drive's measurement uncertainty (amplitude, phase, frequency,
    /// timing).
    pub drive_uncertainty: DriveUncertainty,
    /// √(K2/M2) (rad/s).
    pub omega_ref_rad_s: f64,
    /// The drive-frequency plan as run, covering the log.
    pub plan: Vec<PlanSegment>,
    /// White-noise level of the x1 and x2 sensors measured in the log (m,
    /// 1σ, from third differences).
    pub noise_m: (f64, f64),
    /// One per step (stepped) or drive period (continuous).
    pub points: Vec<MeasuredPoint>,
    /// The rig's state at each step's start as measured (stepped sweeps;
    /// see [`super::sensitive::start_states`]).
    pub start_states: Vec<Option<super::sensitive::StartState>>,
    /// Things the user should know.
    pub warnings: Vec<crate::warning::Warning>,
}

/// Options of [`measure`].
#[derive(Debug, Clone)]
pub struct FrcOptions {
    /// Amplitude window at the end of a step (s): the last whole drive
    /// periods covering at least this long (and three periods), but never
    /// more than half of the hold (down to one period).
    pub window_s: f64,
    /// Relative amplitude change between the two halves of a step's window
    /// above which the step has visibly not settled.
    pub settle_tolerance: f64,
    /// Amplitudes below this fraction of the drive amplitude count as zero
    /// when relative changes are computed (a stuck mass).
    pub zero_amplitude: f64,
    /// Longest ramp between two holds searched for (s).
    pub max_ramp_s: f64,
    /// Drive periods per point of a continuous sweep.
    pub periods_per_point: usize,
    /// Relative gain uncertainty of each position sensor (a bound,
    /// rectangular): the measured A_i/A carries the gain of x_i in its own
    /// error bar (95 %: 1.96·u/√3); the drive's (x0) gain is the drive
    /// amplitude's uncertainty and belongs to the prediction's band.
    pub gain_uncertainty: f64,
}

impl Default for FrcOptions {
    fn default() -> Self {
        Self {
            window_s: 4.0,
            settle_tolerance: 0.005,
            zero_amplitude: 0.01,
            max_ramp_s: 3.0,
            periods_per_point: 1,
            gain_uncertainty: 0.01,
        }
    }
}

/// The error `kind` of the sweep log `run`.
fn bad(run: &Run, kind: ValidateError) -> Error {
    Error::Validate {
        path: run.source.clone(),
        source: kind,
    }
}

/// A sinusoid `offset + amplitude·sin(phase + 2π·f·(t − t_ref))`.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Sine {
    offset: f64,
    amplitude: f64,
    frequency_hz: f64,
    /// Phase at `t_ref`.
    phase: f64,
    t_ref: f64,
    rms: f64,
}

impl Sine {
    fn phase_at(&self, t: f64) -> f64 {
        self.phase + 2.0 * PI * self.frequency_hz * (t - self.t_ref)
    }
}

/// Raw (t, v) samples of a channel, finite values only.
fn raw(run: &Run, q: Quantity) -> Option<(Vec<f64>, Vec<f64>)> {
    let c = run.channel(q)?;
    let (t, v): (Vec<f64>, Vec<f64>) =
        c.t.iter()
            .zip(&c.v)
            .filter(|(_, v)| v.is_finite())
            .map(|(t, v)| (*t, *v))
            .unzip();
    (t.len() >= 8).then_some((t, v))
}

/// Index range of `t` within [a, b).
fn span(t: &[f64], a: f64, b: f64) -> std::ops::Range<usize> {
    let i = t.partition_point(|&x| x < a);
    let j = t.partition_point(|&x| x < b);
    i..j.max(i)
}

/// Least-squares `c + a·cos(ω(t − tr)) + b·sin(ω(t − tr))` with a linear
/// chirp `rate` (Hz/s) in the phase; returns (c, a, b, rss, n).
fn lsq_sine(t: &[f64], x: &[f64], f: f64, rate: f64, tr: f64) -> Option<(f64, f64, f64, f64)> {
    let mut m = [[0.0f64; 3]; 3];
    let mut r = [0.0f64; 3];
    let mut yy = 0.0;
    for (&ti, &xi) in t.iter().zip(x) {
        let s = ti - tr;
        let ph = 2.0 * PI * (f * s + 0.5 * rate * s * s);
        let (sn, cs) = ph.sin_cos();
        let row = [1.0, cs, sn];
        for p in 0..3 {
            for q in 0..3 {
                m[p][q] += row[p] * row[q];
            }
            r[p] += row[p] * xi;
        }
        yy += xi * xi;
    }
    let a: Vec<Vec<f64>> = m.iter().map(|row| row.to_vec()).collect();
    let p = crate::identify::smooth::solve_small(&a, &r)?;
    let rss = (yy - p.iter().zip(&r).map(|(a, b)| a * b).sum::<f64>()).max(0.0);
    Some((p[0], p[1], p[2], rss))
}

/// Fits the drive sinusoid on [a, b) around the frequency `f0` (±`rel`),
/// with chirp rate `rate`; phase referred to `tr`.
fn fit_sine(
    t: &[f64],
    x: &[f64],
    (a, b): (f64, f64),
    f0: f64,
    rel: f64,
    rate: f64,
    tr: f64,
) -> Option<Sine> {
    let r = span(t, a, b);
    let (t, x) = (&t[r.clone()], &x[r]);
    if t.len() < 8 {
        return None;
    }
    let rss = |f: f64| lsq_sine(t, x, f, rate, tr).map_or(f64::INFINITY, |v| v.3);
    // A coarse scan first (the residual is not unimodal over a wide range).
    let n = 24;
    let (lo, hi) = (f0 * (1.0 - rel), f0 * (1.0 + rel));
    let step = (hi - lo) / n as f64;
    let best = (0..=n)
        .map(|k| lo + k as f64 * step)
        .min_by(|p, q| rss(*p).total_cmp(&rss(*q)))?;
    let f = golden_section(best - step, best + step, 50, rss);
    let (c, ca, sb, rss) = lsq_sine(t, x, f, rate, tr)?;
    // c + ca·cos θ + sb·sin θ = c + R·sin(θ + atan2(ca, sb)).
    Some(Sine {
        offset: c,
        amplitude: ca.hypot(sb),
        frequency_hz: f,
        phase: ca.atan2(sb),
        t_ref: tr,
        rms: (rss / t.len() as f64).sqrt(),
    })
}

/// The drive phase through a linear ramp from `f_a` (phase `phase_a(t)`
/// before `t0`) to `f_b` over `dur` seconds.
fn ramp_phase(prev: &Sine, f_b: f64, t0: f64, dur: f64, t: f64) -> f64 {
    let f_a = prev.frequency_hz;
    let p0 = prev.phase_at(t0);
    if t <= t0 {
        return prev.phase_at(t);
    }
    let s = t - t0;
    if s <= dur {
        p0 + 2.0 * PI * (f_a * s + 0.5 * (f_b - f_a) * s * s / dur.max(1e-12))
    } else {
        p0 + 2.0 * PI * (0.5 * (f_a + f_b) * dur + f_b * (s - dur))
    }
}

/// The squared residual of the drive samples against the ramp model.
struct RampCost<'a> {
    t: &'a [f64],
    x: &'a [f64],
    prev: Sine,
    next: Sine,
    max_ramp: f64,
}

impl RampCost<'_> {
    fn eval(&self, t0: f64, dur: f64) -> f64 {
        if !(0.0..=self.max_ramp).contains(&dur) {
            return f64::INFINITY;
        }
        let mut s = 0.0;
        for (&ti, &xi) in self.t.iter().zip(self.x) {
            let (off, amp) = if ti < t0 + dur {
                (self.prev.offset, self.prev.amplitude)
            } else {
                (self.next.offset, self.next.amplitude)
            };
            let ph = ramp_phase(&self.prev, self.next.frequency_hz, t0, dur, ti);
            s += (xi - off - amp * ph.sin()).powi(2);
        }
        s
    }
}

impl CostFunction for RampCost<'_> {
    type Param = Vec<f64>;
    type Output = f64;
    fn cost(&self, p: &Self::Param) -> std::result::Result<f64, argmin::core::Error> {
        Ok(self.eval(p[0], p[1]))
    }
}

/// Locates the ramp between two holds: start `t0` and duration, fitted to
/// the drive samples in `[lo, hi)` (the previous hold's tail through the
/// next hold's head) with the phase continuous from the previous hold.
fn locate_ramp(
    t: &[f64],
    x: &[f64],
    prev: Sine,
    next: Sine,
    (lo, hi): (f64, f64),
    max_ramp: f64,
) -> Option<(f64, f64)> {
    let r = span(t, lo, hi);
    let cost = RampCost {
        t: &t[r.clone()],
        x: &x[r],
        prev,
        next,
        max_ramp,
    };
    if cost.t.len() < 16 {
        return None;
    }
    // The phase after the ramp must continue the next hold's sinusoid:
    // ψa(t0) + π(fa + fb)·T = ψb(t0 + T) (mod 2π) gives, for each start t0,
    // the discrete durations T = (2πk + ψb(t0) − ψa(t0)) / (π(fa − fb)).
    // Scan t0 over those candidates, then refine both with Nelder–Mead.
    let df = prev.frequency_hz - next.frequency_hz;
    if df.abs() < 1e-9 * prev.frequency_hz {
        return None;
    }
    let h = 0.02f64.min((hi - lo) / 40.0);
    let (mut best, mut fbest) = ((lo, 0.0), f64::INFINITY);
    let nt = ((hi - lo) / h).ceil() as usize;
    for i in 0..=nt {
        let t0 = lo + i as f64 * h;
        let dpsi = next.phase_at(t0) - prev.phase_at(t0);
        // T ∈ [0, max_ramp]: k between the bounds (either sign of df).
        let k_at = |tt: f64| (tt * PI * df - dpsi) / (2.0 * PI);
        let (ka, kb) = (k_at(0.0), k_at(max_ramp));
        let (k0, k1) = (ka.min(kb).ceil() as i64, ka.max(kb).floor() as i64);
        for k in k0..=k1 {
            let d = (2.0 * PI * k as f64 + dpsi) / (PI * df);
            if !(0.0..=max_ramp).contains(&d) || t0 + d > hi {
                continue;
            }
            let c = cost.eval(t0, d);
            if c < fbest {
                fbest = c;
                best = (t0, d);
            }
        }
    }
    if !fbest.is_finite() {
        return None;
    }
    let simplex = vec![
        vec![best.0, best.1],
        vec![best.0 + 0.5 * h, best.1],
        vec![best.0, best.1 + 0.5 * h],
    ];
    let solver = NelderMead::new(simplex).with_sd_tolerance(1e-10).ok()?;
    let res = Executor::new(cost, solver)
        .configure(|s| s.max_iters(200))
        .run()
        .ok()?;
    let p = res.state().get_best_param()?.clone();
    let (t0, d) = if res.state().get_best_cost() <= fbest {
        (p[0], p[1].max(0.0))
    } else {
        best
    };
    Some((t0, d))
}

/// (max − min)/2 over [a, b] of a signal on a uniform grid, from its local
/// polynomial reconstruction (degree 4, half-width `half` samples),
/// extremes refined by a parabola through three samples.
fn amplitude(y: &[f64], dt: f64, t0: f64, (a, b): (f64, f64), half: usize) -> Option<f64> {
    let n = y.len();
    let idx = |t: f64| ((t - t0) / dt).round();
    let (ia, ib) = (idx(a), idx(b));
    if !(ia.is_finite() && ib.is_finite()) || ib < 0.0 || ia >= n as f64 {
        return None;
    }
    let (ia, ib) = (ia.max(0.0) as usize, (ib as usize).min(n - 1));
    if ib <= ia + 4 {
        return None;
    }
    // Smooth a slice with a margin so the window sees interior weights.
    let (sa, sb) = (ia.saturating_sub(half + 1), (ib + half + 2).min(n));
    let s = savgol(&y[sa..sb], dt, half, 4, 0);
    let w = &s[ia - sa..=ib - sa];
    let finite = w.iter().filter(|v| v.is_finite()).count();
    if finite * 2 < w.len() {
        return None;
    }
    let refine = |k: usize, sign: f64| -> f64 {
        let v = w[k];
        if k == 0 || k + 1 >= w.len() {
            return v;
        }
        let (l, r) = (w[k - 1], w[k + 1]);
        if !(l.is_finite() && r.is_finite()) {
            return v;
        }
        let den = l - 2.0 * v + r;
        if sign * den >= 0.0 {
            return v;
        }
        let d = 0.5 * (l - r) / den;
        v - 0.25 * (l - r) * d
    };
    let (mut kmin, mut kmax) = (None::<usize>, None::<usize>);
    for (k, v) in w.iter().enumerate() {
        if !v.is_finite() {
            continue;
        }
        if kmin.is_none_or(|j| *v < w[j]) {
            kmin = Some(k);
        }
        if kmax.is_none_or(|j| *v > w[j]) {
            kmax = Some(k);
        }
    }
    let (lo, hi) = (refine(kmin?, 1.0), refine(kmax?, -1.0));
    Some(0.5 * (hi - lo))
}

/// Smoothing half-width (samples) for a drive period: 1/16 of it.
fn half_width(period: f64, dt: f64) -> usize {
    ((period / 16.0 / dt).round() as usize).max(3)
}

/// One window's amplitude (see [`window_amplitude`]).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Fitted {
    /// (max − min)/2 (m); 0 where the mass stands still.
    amp: f64,
    /// 95 % half-width of the estimator's noise (m).
    noise95: f64,
}

/// Whether a signal stands still over [a, b] (a window of whole periods
/// `period`): the spread of its samples about a straight line (an offset
/// and a slow drift) is no more than the window's own noise gives, at 95 %.
/// The noise variance is half the mean square of differences `lag` samples
/// apart (`lag`: 1/64 of the period, at least 8 samples): that sees the
/// sensor's noise whatever its colour over a few samples (an interpolated
/// grid's noise is not white; third differences would underrate it), while
/// any motion at the drive's time scale adds its own variance to the spread
/// (a sine of amplitude c adds c²/2) and almost none to those differences.
/// The threshold 1 + 1.645·√(5/n) is the statistic's 95 % point for n
/// samples (the spread's variance 2/n and the overlapping differences'
/// about 3/n).
fn stands_still(y: &[f64], dt: f64, t0: f64, (a, b): (f64, f64), period: f64) -> (bool, f64) {
    let n = y.len();
    let idx = |t: f64| ((t - t0) / dt).round();
    let (ia, ib) = (idx(a), idx(b));
    if !(ia.is_finite() && ib.is_finite()) || ib < 0.0 || ia >= n as f64 {
        return (false, f64::NAN);
    }
    let (ia, ib) = (ia.max(0.0) as usize, (ib as usize).min(n - 1));
    let w = &y[ia..=ib];
    let lag = ((period / dt / 64.0).round() as usize).max(8);
    if w.len() < 4 * lag {
        return (false, f64::NAN);
    }
    let (mut sx, mut sy, mut m) = (0.0, 0.0, 0usize);
    for (k, v) in w.iter().enumerate() {
        if v.is_finite() {
            sx += k as f64;
            sy += v;
            m += 1;
        }
    }
    if m < 16 || 2 * m < w.len() {
        return (false, f64::NAN);
    }
    let (mx, my) = (sx / m as f64, sy / m as f64);
    let (mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0);
    for (k, v) in w.iter().enumerate().filter(|(_, v)| v.is_finite()) {
        let (dx, dy) = (k as f64 - mx, v - my);
        sxx += dx * dx;
        sxy += dx * dy;
        syy += dy * dy;
    }
    let spread = (syy - if sxx > 0.0 { sxy * sxy / sxx } else { 0.0 }) / (m - 2) as f64;
    let (mut dd, mut nd) = (0.0, 0usize);
    for k in lag..w.len() {
        let d = w[k] - w[k - lag];
        if d.is_finite() {
            dd += d * d;
            nd += 1;
        }
    }
    if nd < 8 {
        return (false, f64::NAN);
    }
    let noise = 0.5 * dd / nd as f64;
    (
        spread <= noise * (1.0 + 1.645 * (5.0 / m as f64).sqrt()),
        noise,
    )
}

/// Replicates of the noise-bias estimate of [`window_amplitude`].
const BIAS_REPLICATES: u64 = 16;

/// The measured amplitude over [a, b] (paper eq. 6 with the noise's bias
/// removed): (max − min)/2 of the local-polynomial reconstruction
/// ([`amplitude`], smoothing over 1/16 of `period`) less the noise's
/// extreme-value bias, or 0 where the mass stands still
/// ([`stands_still`]). The bias is what noise of the window's own level
/// adds to the half-range of the reconstruction: the mean over
/// [`BIAS_REPLICATES`] replicates of the reconstruction plus noise of that
/// level and colour ([`noise_bias`]), less the reconstruction's own half-range (a parametric
/// bootstrap: it sees the waveform, so a sharp extreme gets a small bias, a
/// small or flat one a larger one). `noise95` is the estimator's noise
/// ([`estimator_noise`]).
fn window_amplitude(
    y: &[f64],
    dt: f64,
    t0: f64,
    window: (f64, f64),
    period: f64,
    sigma: f64,
    raw: Option<RawNoise<'_>>,
) -> Option<Fitted> {
    let half = half_width(period, dt);
    let eq6 = amplitude(y, dt, t0, window, half)?;
    let noise95 = estimator_noise(sigma, half, dt, window.1 - window.0);
    if stands_still(y, dt, t0, window, period).0 {
        return Some(Fitted { amp: 0.0, noise95 });
    }
    let amp = match noise_bias(y, dt, t0, window, half, raw) {
        Some(b) => (eq6 - b).max(0.0),
        None => eq6,
    };
    Some(Fitted { amp, noise95 })
}

/// The noise's bias of [`amplitude`] over `window` (see
/// [`window_amplitude`]). With the raw channel known (`raw`), the noise is
/// white noise of its σ at the raw sample times, interpolated onto the grid
/// as the ingest interpolates (so it has the grid noise's colour);
/// otherwise white on the grid at the window's own level: the residual of
/// the reconstruction, whose variance is σ²(1 − w₀) for white noise (w₀:
/// the smoother's centre weight).
fn noise_bias(
    y: &[f64],
    dt: f64,
    t0: f64,
    (a, b): (f64, f64),
    half: usize,
    raw: Option<RawNoise<'_>>,
) -> Option<f64> {
    let n = y.len();
    let idx = |t: f64| ((t - t0) / dt).round();
    let (ia, ib) = (idx(a), idx(b));
    if !(ia.is_finite() && ib.is_finite()) || ib < 0.0 || ia >= n as f64 {
        return None;
    }
    let (ia, ib) = (ia.max(0.0) as usize, (ib as usize).min(n - 1));
    let (sa, sb) = (ia.saturating_sub(2 * half + 2), (ib + 2 * half + 3).min(n));
    let smooth = savgol(&y[sa..sb], dt, half, 4, 0);
    let t_s = t0 + sa as f64 * dt;
    let h = half as i64;
    let w0 = crate::identify::smooth::savgol_weights(-h, h, 4, 0, dt)?[half];
    let (mut rr, mut nr) = (0.0, 0usize);
    for k in ia..=ib {
        let r = y[k] - smooth[k - sa];
        if r.is_finite() {
            rr += r * r;
            nr += 1;
        }
    }
    let sd = (rr / nr.max(1) as f64 / (1.0 - w0)).sqrt();
    if !(nr >= 8 && sd.is_finite() && sd > 0.0) {
        return None;
    }
    let base = amplitude(&smooth, dt, t_s, (a, b), half)?;
    let mut rng = crate::stats::Rng::with_stream(0xB1A5, ia as u64);
    let mut sum = 0.0;
    let mut z = smooth.clone();
    // The raw samples under the slice, with one interval of margin.
    let grid_t: Vec<f64> = (0..smooth.len()).map(|k| t_s + k as f64 * dt).collect();
    let raw = raw.and_then(|r| {
        let (g0, g1) = (grid_t[0], grid_t[grid_t.len() - 1]);
        let i = r.t.partition_point(|&t| t < g0 - 2.0 * r.dt);
        let j = r.t.partition_point(|&t| t <= g1 + 2.0 * r.dt);
        (j > i + 4).then_some((&r.t[i..j], r.dt, r.sigma))
    });
    let mut e = Vec::new();
    for _ in 0..BIAS_REPLICATES {
        match raw {
            Some((rt, rdt, rs)) => {
                e.clear();
                e.extend((0..rt.len()).map(|_| rs * rng.normal()));
                let g = crate::ingest::interpolate(rt, &e, rdt, &grid_t);
                for ((zk, sk), gk) in z.iter_mut().zip(&smooth).zip(&g) {
                    *zk = sk + if gk.is_finite() { *gk } else { 0.0 };
                }
            }
            None => {
                for (zk, sk) in z.iter_mut().zip(&smooth) {
                    *zk = sk + sd * rng.normal();
                }
            }
        }
        sum += amplitude(&z, dt, t_s, (a, b), half)?;
    }
    Some((sum / BIAS_REPLICATES as f64 - base).max(0.0))
}

/// White-noise σ of a smooth signal sampled densely: from the MAD of its
/// third differences (a smooth signal's third difference is O((ω·dt)³)
/// and vanishes against the noise; Var Δ³e = 20σ²).
fn noise_level(y: &[f64]) -> f64 {
    let d3: Vec<f64> = y
        .windows(4)
        .map(|w| w[3] - 3.0 * w[2] + 3.0 * w[1] - w[0])
        .filter(|v| v.is_finite())
        .collect();
    if d3.len() < 16 {
        return f64::NAN;
    }
    let mad = median(&d3.iter().map(|v| v.abs()).collect::<Vec<_>>());
    mad / 0.6745 / 20f64.sqrt()
}

/// 95 % uncertainty (m) of (max − min)/2 of a signal with white noise σ
/// after Savitzky–Golay smoothing (degree 4, half-width `half`) over a
/// window of `win` seconds: each extreme is a maximum over about
/// win/((2·half + 1)·dt) nearly independent smoothed values, which biases
/// it by up to σ_s·√(2 ln n); plus 1.96 σ_s of scatter.
fn estimator_noise(sigma: f64, half: usize, dt: f64, win: f64) -> f64 {
    let h = half as i64;
    let gain = crate::identify::smooth::savgol_weights(-h, h, 4, 0, dt)
        .map_or(1.0, |w| w.iter().map(|x| x * x).sum::<f64>().sqrt());
    let s = sigma * gain;
    let n = (win / ((2 * half + 1) as f64 * dt)).max(2.0);
    if s.is_finite() {
        s * ((2.0 * n.ln()).sqrt() + 1.96)
    } else {
        0.0
    }
}

/// The grid signals used for amplitudes, with their white-noise σ (m).
struct Grid<'a> {
    t0: f64,
    dt: f64,
    x1: &'a [f64],
    x2: &'a [f64],
    noise: (f64, f64),
    /// The raw channels' sample times and white-noise σ (m), x1 then x2:
    /// the noise-bias bootstrap draws white noise at the raw samples and
    /// interpolates it onto the grid as the ingest did, so its colour on the
    /// grid is the data's.
    raw: [Option<RawNoise<'a>>; 2],
}

/// A raw channel's sample times, interval and white-noise σ.
#[derive(Clone, Copy)]
struct RawNoise<'a> {
    t: &'a [f64],
    dt: f64,
    sigma: f64,
}

impl<'a> Grid<'a> {
    /// The grid of a run's resampled x1 and x2 (None: no rows).
    fn of(run: &'a Run) -> Option<Self> {
        let rs = &run.resampled;
        Some(Grid {
            t0: *rs.t.first()?,
            dt: 1.0 / rs.rate_hz,
            x1: &rs.x1,
            x2: &rs.x2,
            noise: (noise_level(&rs.x1), noise_level(&rs.x2)),
            raw: [Quantity::X1, Quantity::X2].map(|q| {
                let c = run.channel(q)?;
                let sigma = noise_level(&c.v);
                (sigma.is_finite() && sigma > 0.0 && c.rate_hz > 0.0).then_some(RawNoise {
                    t: &c.t,
                    dt: 1.0 / c.rate_hz,
                    sigma,
                })
            }),
        })
    }

    /// The grid's last time (s).
    fn end(&self) -> f64 {
        self.t0 + self.x1.len().saturating_sub(1) as f64 * self.dt
    }

    /// The fitted amplitudes of x1 and x2 over a window of whole drive
    /// periods of length `period`.
    fn fitted(&self, window: (f64, f64), period: f64) -> Option<(Fitted, Fitted)> {
        Some((
            window_amplitude(
                self.x1,
                self.dt,
                self.t0,
                window,
                period,
                self.noise.0,
                self.raw[0],
            )?,
            window_amplitude(
                self.x2,
                self.dt,
                self.t0,
                window,
                period,
                self.noise.1,
                self.raw[1],
            )?,
        ))
    }

    /// (A1, A2) in metres over a window of whole drive periods.
    fn amplitudes(&self, window: (f64, f64), period: f64) -> Option<(f64, f64)> {
        self.fitted(window, period).map(|(a, b)| (a.amp, b.amp))
    }
}

/// A1 and A2 (metres) of a log over an arbitrary window of whole drive
/// periods `period_s` with the same estimator as [`measure`] (the
/// half peak-to-peak of the fitted waveform, 0 for a mass that stands
/// still), e.g. to compare with a reference taken over other windows. None
/// where x1 or x2 has too few samples there.
pub fn window_amplitudes(run: &Run, window: (f64, f64), period_s: f64) -> Option<(f64, f64)> {
    Grid::of(run)?.amplitudes(window, period_s)
}

/// What the stepped and continuous measurements produce; [`measure`]
/// assembles the [`MeasuredFrc`] (direction, noise, uncertainties) once.
struct Parts {
    drive_amplitude_m: f64,
    drive_phase_rad: f64,
    drive_uncertainty: DriveUncertainty,
    plan: Vec<PlanSegment>,
    points: Vec<MeasuredPoint>,
    warnings: Vec<crate::warning::Warning>,
}

/// Measures the frequency response of a sweep log.
pub fn measure(run: &Run, opts: &FrcOptions) -> Result<MeasuredFrc> {
    if run.rig.test != crate::ingest::TestKind::Sweep {
        return Err(bad(run, ValidateError::NotASweep));
    }
    let (td, xd) = raw(run, Quantity::X0).ok_or_else(|| bad(run, ValidateError::NoDriveSamples))?;
    let rs = &run.resampled;
    if rs.t.len() < 16 {
        return Err(bad(run, ValidateError::TooShort));
    }
    let grid = Grid::of(run).ok_or_else(|| bad(run, ValidateError::TooShort))?;
    let kind = match run.rig.sweep_kind {
        Some(LogSweepKind::Continuous) => SweepKind::Continuous,
        Some(LogSweepKind::Stepped) => SweepKind::Stepped,
        None => {
            // Not declared: a stepped sweep repeats few frequencies for long.
            if run.setpoints.len() > 2 * distinct_steps(run).len() {
                SweepKind::Continuous
            } else {
                SweepKind::Stepped
            }
        }
    };
    let parts = match kind {
        SweepKind::Stepped => stepped(run, &td, &xd, &grid, opts)?,
        SweepKind::Continuous => continuous(run, &td, &xd, &grid, opts)?,
    };
    if parts.points.is_empty() {
        return Err(bad(
            run,
            match kind {
                SweepKind::Stepped => ValidateError::NoStepMeasured,
                SweepKind::Continuous => ValidateError::NoPeriodMeasured,
            },
        ));
    }
    let a = parts.drive_amplitude_m;
    if !(a.is_finite() && a > 0.0) {
        return Err(bad(run, ValidateError::DriveAmplitudeUnmeasured));
    }
    let freqs: Vec<f64> = parts.points.iter().map(|p| p.frequency_hz).collect();
    let mut m = MeasuredFrc {
        kind,
        direction: direction_of(&freqs),
        drive_amplitude_m: a,
        drive_phase_rad: parts.drive_phase_rad,
        drive_uncertainty: DriveUncertainty {
            delay_s: drive_delay_uncertainty(run),
            ..parts.drive_uncertainty
        },
        omega_ref_rad_s: run.rig.omega_ref(),
        plan: parts.plan,
        noise_m: (f64::NAN, f64::NAN),
        points: parts.points,
        start_states: Vec::new(),
        warnings: parts.warnings,
    };
    let nominal = run.rig.drive_amplitude_m;
    if (a / nominal - 1.0).abs() > 0.005 {
        m.warnings
            .push(crate::warning::Warning::SweepDriveAmplitude {
                measured_m: a,
                nominal_m: nominal,
            });
    }
    // Noise of the raw sensor samples (the common grid interpolates some
    // channels, which averages their noise).
    let raw_noise = |q: Quantity| raw(run, q).map_or(f64::NAN, |(_, v)| noise_level(&v));
    let noise = (raw_noise(Quantity::X1), raw_noise(Quantity::X2));
    m.noise_m = noise;
    let cal = 1.96 * opts.gain_uncertainty / 3f64.sqrt();
    for p in &mut m.points {
        p.amplitude1 = p.amplitude1_m / a;
        p.amplitude2 = p.amplitude2_m / a;
        p.amplitude1_u = (p.amplitude1_noise_m / a).hypot(cal * p.amplitude1);
        p.amplitude2_u = (p.amplitude2_noise_m / a).hypot(cal * p.amplitude2);
    }
    m.start_states = super::sensitive::start_states(run, &m);
    Ok(m)
}

/// Standard uncertainty of the drive channel's timing against x1 (s),
/// from the ingest's delay estimate of x0 (see [`DriveUncertainty`]).
fn drive_delay_uncertainty(run: &Run) -> f64 {
    let Some(d) = run.delays.get(Quantity::X0) else {
        return 0.0;
    };
    let half = d.interval_s.map_or(0.0, |[lo, hi]| 0.5 * (hi - lo) / 1.96);
    let unapplied = if d.applied {
        0.0
    } else {
        d.estimated_s.unwrap_or(0.0)
    };
    let u = half.hypot(unapplied);
    if u.is_finite() {
        u
    } else {
        0.0
    }
}

/// The drive's amplitude, phase and frequency uncertainty from its fitted
/// sinusoids: the amplitude's from the scatter of the per-window
/// amplitudes `amps` (the median's standard error, 1.2533·σ/√n) and each
/// fit's noise; the phase's and frequency's from the fit `s` over `n`
/// samples spanning `span` seconds (least squares of a sinusoid in white
/// noise: σ_φ = rms·√(2/n)/A, σ_f = √24·rms/(2π·A·span·√n)).
fn drive_uncertainty(amps: &[f64], s: &Sine, n: usize, span: f64) -> DriveUncertainty {
    let a = median(amps);
    let k = amps.len().max(1) as f64;
    let scatter = if amps.len() >= 3 {
        1.2533 * crate::stats::mad_sigma(amps) / k.sqrt()
    } else {
        0.0
    };
    let nf = n.max(8) as f64;
    let fit = s.rms * (2.0 / nf).sqrt();
    let fin = |v: f64| if v.is_finite() { v } else { 0.0 };
    DriveUncertainty {
        amplitude_rel: fin(scatter.hypot(fit / k.sqrt()) / a),
        phase_rad: fin(fit / s.amplitude),
        frequency_rel: fin(24f64.sqrt() * s.rms
            / (2.0 * PI * s.amplitude * span.max(1e-9) * nf.sqrt())
            / s.frequency_hz),
        delay_s: 0.0,
    }
}

/// The steps of a stepped sweep: (start time, commanded frequency); a
/// repeated frequency continues the previous hold (e.g. a pre-roll), the
/// step starting at its last message.
fn distinct_steps(run: &Run) -> Vec<(f64, f64)> {
    let mut out: Vec<(f64, f64)> = Vec::new();
    for s in &run.setpoints {
        if !(s.frequency_hz.is_finite() && s.frequency_hz > 0.0 && s.t_s.is_finite()) {
            continue;
        }
        match out.last_mut() {
            Some(last) if last.1 == s.frequency_hz => last.0 = s.t_s,
            _ => out.push((s.t_s, s.frequency_hz)),
        }
    }
    out
}

fn direction_of(f: &[f64]) -> Direction {
    match (f.first(), f.last()) {
        (Some(a), Some(b)) if b < a => Direction::Down,
        _ => Direction::Up,
    }
}

/// Stepped sweep: one hold per distinct setpoint, its drive sinusoid
/// fitted, ramps between holds located in the drive signal, and one point
/// per hold from the whole drive periods at its end.
fn stepped(run: &Run, td: &[f64], xd: &[f64], grid: &Grid, opts: &FrcOptions) -> Result<Parts> {
    let steps = distinct_steps(run);
    if steps.is_empty() {
        return Err(bad(run, ValidateError::NoSteps));
    }
    let t_log_end = td[td.len() - 1].max(grid.end());
    let omega_ref = run.rig.omega_ref();
    let mut warnings = Vec::new();
    let n = steps.len();
    let bounds = hold_bounds(run, &steps, t_log_end);
    // Each hold's sinusoid, fitted over the second half of the hold (clear
    // of the ramp into it).
    let mut sines: Vec<Option<Sine>> = Vec::with_capacity(n);
    for (i, &(a, b)) in bounds.iter().enumerate() {
        let f0 = steps[i].1;
        let mid = a + 0.5 * (b - a);
        let s = fit_sine(td, xd, (mid, b), f0, 0.05, 0.0, mid);
        if s.is_none() {
            warnings.push(crate::warning::Warning::StepUnmeasured {
                step: i + 1,
                frequency_hz: f0,
            });
        }
        sines.push(s);
    }
    let ramps = hold_ramps(td, xd, &sines, &bounds, opts.max_ramp_s);
    let plan = stepped_plan(&steps, &sines, &ramps, &bounds, t_log_end);
    // φ(0) from the first hold, carried back to t = 0.
    let drive_phase_rad = sines[0]
        .map(|s| s.phase_at(0.0))
        .ok_or_else(|| bad(run, ValidateError::FirstStepUnmeasured))?;

    let mut points = Vec::with_capacity(n);
    let mut amps = Vec::new();
    for i in 0..n {
        let Some(s) = sines[i] else { continue };
        let hold = Hold {
            step: i + 1,
            sine: s,
            bounds: bounds[i],
            ramp: ramps[i],
        };
        let Some((point, window)) = step_point(&hold, grid, opts, omega_ref, &mut warnings) else {
            continue;
        };
        if let Some(w) = fit_sine(td, xd, window, s.frequency_hz, 0.001, 0.0, window.0) {
            amps.push(w.amplitude);
        }
        points.push(point);
    }
    let first = sines.iter().flatten().next().copied();
    let drive_uncertainty = first.map_or(DriveUncertainty::default(), |s0| {
        let (a, b) = bounds[0];
        let mid = a + 0.5 * (b - a);
        drive_uncertainty(&amps, &s0, span(td, mid, b).len(), b - mid)
    });
    Ok(Parts {
        drive_amplitude_m: median(&amps),
        drive_phase_rad,
        drive_uncertainty,
        plan,
        points,
        warnings,
    })
}

/// The time span of each hold: [its first message, the next step's
/// message), the last one to the end of the log.
fn hold_bounds(run: &Run, steps: &[(f64, f64)], t_log_end: f64) -> Vec<(f64, f64)> {
    // Hold i: [its first message, the next step's message).
    let first_msg = run
        .setpoints
        .iter()
        .map(|s| s.t_s)
        .fold(f64::INFINITY, f64::min)
        .min(steps[0].0);
    let n = steps.len();
    (0..n)
        .map(|i| {
            let a = if i == 0 {
                first_msg.max(0.0)
            } else {
                steps[i].0
            };
            let b = if i + 1 < n { steps[i + 1].0 } else { t_log_end };
            (a, b)
        })
        .collect()
}

/// Ramps between holds, fitted to the drive signal: (start, duration) of
/// the ramp into each hold (None for the first hold and where either
/// hold's sinusoid is unknown or no ramp is found).
fn hold_ramps(
    td: &[f64],
    xd: &[f64],
    sines: &[Option<Sine>],
    bounds: &[(f64, f64)],
    max_ramp_s: f64,
) -> Vec<Option<(f64, f64)>> {
    let n = bounds.len();
    let mut ramps: Vec<Option<(f64, f64)>> = vec![None; n];
    for i in 1..n {
        let (Some(prev), Some(next)) = (sines[i - 1], sines[i]) else {
            continue;
        };
        let (pa, pb) = bounds[i - 1];
        let (na, nb) = bounds[i];
        let lo = (na - 2.0).max(pa + 0.5 * (pb - pa));
        let hi = (na + max_ramp_s + 2.0).min(na + 0.5 * (nb - na));
        if hi <= lo {
            continue;
        }
        ramps[i] = locate_ramp(td, xd, prev, next, (lo, hi), max_ramp_s);
    }
    ramps
}

/// The plan of a stepped sweep: holds and ramps.
fn stepped_plan(
    steps: &[(f64, f64)],
    sines: &[Option<Sine>],
    ramps: &[Option<(f64, f64)>],
    bounds: &[(f64, f64)],
    t_log_end: f64,
) -> Vec<PlanSegment> {
    let n = steps.len();
    let mut plan = Vec::new();
    let mut t = 0.0f64;
    let f_of = |i: usize| sines[i].map_or(steps[i].1, |s| s.frequency_hz);
    for i in 0..n {
        if i > 0 {
            let (t0, d) = ramps[i].unwrap_or((bounds[i].0, 0.0));
            let t0 = t0.max(t);
            if t0 > t {
                plan.push(PlanSegment {
                    start_s: t,
                    end_s: t0,
                    f_start_hz: f_of(i - 1),
                    f_end_hz: f_of(i - 1),
                });
            }
            if d > 0.0 {
                plan.push(PlanSegment {
                    start_s: t0,
                    end_s: t0 + d,
                    f_start_hz: f_of(i - 1),
                    f_end_hz: f_of(i),
                });
            }
            t = t0 + d;
        }
    }
    plan.push(PlanSegment {
        start_s: t,
        end_s: t_log_end.max(t),
        f_start_hz: f_of(n - 1),
        f_end_hz: f_of(n - 1),
    });
    plan
}

/// One hold of a stepped sweep whose drive sinusoid is known.
struct Hold {
    /// Its number (1-based, for warnings).
    step: usize,
    sine: Sine,
    /// Its first message and the next step's.
    bounds: (f64, f64),
    /// The ramp into it (start, duration).
    ramp: Option<(f64, f64)>,
}

/// The measured point of one hold and its window: whole drive periods at
/// the end of the hold (never more than half of it), with the trend over
/// the window's two halves; None (with a warning) where the hold is too
/// short or x1/x2 have too few samples.
fn step_point(
    hold: &Hold,
    grid: &Grid,
    opts: &FrcOptions,
    omega_ref: f64,
    warnings: &mut Vec<crate::warning::Warning>,
) -> Option<(MeasuredPoint, (f64, f64))> {
    let (i1, s) = (hold.step, hold.sine);
    let f = s.frequency_hz;
    let period = 1.0 / f;
    let (a, b) = hold.bounds;
    let hold_start = hold.ramp.map_or(a, |(t0, d)| t0 + d).max(a);
    let avail = b - hold_start;
    let mut k = (opts.window_s / period).ceil().max(3.0);
    // Never more than half of the hold (its start holds the transient).
    while k > 1.0 && k * period > 0.5 * avail.max(0.0) {
        k -= 1.0;
    }
    let k = k.max(1.0);
    let window = (b - k * period, b);
    if window.0 < hold_start - 1e-9 {
        warnings.push(crate::warning::Warning::StepTooShort {
            step: i1,
            frequency_hz: f,
        });
        return None;
    }
    let Some((a1, a2)) = grid.fitted(window, period) else {
        warnings.push(crate::warning::Warning::StepFewSamples {
            step: i1,
            frequency_hz: f,
            window_s: window,
        });
        return None;
    };
    // Trend: the two halves of the window (whole periods each).
    let kh = (k / 2.0).floor();
    let rel_change = if kh >= 1.0 {
        let h1 = grid.amplitudes((b - 2.0 * kh * period, b - kh * period), period);
        let h2 = grid.amplitudes((b - kh * period, b), period);
        match (h1, h2) {
            (Some(p), Some(q)) => {
                let floor = opts.zero_amplitude * s.amplitude;
                let rel = |x: f64, y: f64| {
                    if x.max(y) < floor {
                        0.0
                    } else {
                        (y - x).abs() / y.max(floor)
                    }
                };
                Some(rel(p.0, q.0).max(rel(p.1, q.1)))
            }
            _ => None,
        }
    } else {
        None
    };
    let point = MeasuredPoint {
        frequency_hz: f,
        eta: 2.0 * PI * f / omega_ref,
        t_start_s: a,
        t_end_s: b,
        window_s: window,
        amplitude1: f64::NAN,
        amplitude2: f64::NAN,
        amplitude1_m: a1.amp,
        amplitude2_m: a2.amp,
        amplitude1_u: f64::NAN,
        amplitude2_u: f64::NAN,
        amplitude1_noise_m: a1.noise95,
        amplitude2_noise_m: a2.noise95,
        rel_change,
        settled: rel_change.map(|r| r <= opts.settle_tolerance),
    };
    Some((point, window))
}

/// Drive cycles completed from `seg.start_s` to `t` within a plan segment.
fn seg_cycles(seg: &PlanSegment, t: f64) -> f64 {
    let d = seg.end_s - seg.start_s;
    let s = t - seg.start_s;
    let rate = if d > 0.0 {
        (seg.f_end_hz - seg.f_start_hz) / d
    } else {
        0.0
    };
    seg.f_start_hz * s + 0.5 * rate * s * s
}

/// The time within `seg` at which `c` cycles have passed since its start.
fn seg_time(seg: &PlanSegment, c: f64) -> f64 {
    let d = seg.end_s - seg.start_s;
    let rate = if d > 0.0 {
        (seg.f_end_hz - seg.f_start_hz) / d
    } else {
        0.0
    };
    let f0 = seg.f_start_hz;
    // 0.5·r·s² + f0·s − c = 0, the root with s ≥ 0 (stable form).
    let s = if rate.abs() * c < 1e-12 * f0 * f0 {
        c / f0
    } else {
        2.0 * c / (f0 + (f0 * f0 + 2.0 * rate * c).max(0.0).sqrt())
    };
    seg.start_s + s
}

/// Continuous sweep: nodes at the setpoint messages, a plan of linear
/// pieces through the measured instantaneous frequencies, and one point per
/// `periods_per_point` drive periods.
fn continuous(run: &Run, td: &[f64], xd: &[f64], grid: &Grid, opts: &FrcOptions) -> Result<Parts> {
    let mut nodes = command_nodes(run);
    if nodes.len() < 2 {
        return Err(bad(run, ValidateError::NoCommandedFrequency));
    }
    let t_end = td[td.len() - 1].max(grid.end());
    let omega_ref = run.rig.omega_ref();
    let mut warnings = Vec::new();
    // Commanded frequency at the log's ends (held beyond the messages).
    if nodes[0].0 > 0.0 {
        nodes.insert(0, (0.0, nodes[0].1));
    }
    if nodes[nodes.len() - 1].0 < t_end {
        let f = nodes[nodes.len() - 1].1;
        nodes.push((t_end, f));
    }
    let n = nodes.len();
    // Measured instantaneous frequency (and amplitude) at each node.
    let mut fit_nodes: Vec<(f64, Sine)> = Vec::with_capacity(n);
    for (k, &(tk, fk)) in nodes.iter().enumerate() {
        let w = (2.0 / fk).max(1.0);
        let (a, b) = ((tk - 0.5 * w).max(0.0), (tk + 0.5 * w).min(t_end));
        if let Some(s) = fit_sine(td, xd, (a, b), fk, 0.05, rate_cmd(&nodes, k), tk) {
            fit_nodes.push((tk, s));
        }
    }
    if fit_nodes.len() < 2 {
        return Err(bad(run, ValidateError::DriveUnmeasured));
    }
    let plan = continuous_plan(&nodes, &fit_nodes, td, xd);
    let first = &fit_nodes[0].1;
    let drive_phase_rad =
        first.phase_at(0.0) + PI * rate_cmd(&nodes, 0) * first.t_ref * first.t_ref;
    let drive_amplitude_m = median(
        &fit_nodes
            .iter()
            .map(|(_, s)| s.amplitude)
            .collect::<Vec<_>>(),
    );
    let rms = median(&fit_nodes.iter().map(|(_, s)| s.rms).collect::<Vec<_>>());
    if rms > 0.05 * drive_amplitude_m {
        warnings.push(crate::warning::Warning::DriveShape { rms_m: rms });
    }
    let points = sweep_points(&plan, grid, opts.periods_per_point, omega_ref);
    let amps: Vec<f64> = fit_nodes.iter().map(|(_, s)| s.amplitude).collect();
    let w0 = (2.0 / first.frequency_hz).max(1.0);
    let n0 = span(
        td,
        (first.t_ref - 0.5 * w0).max(0.0),
        first.t_ref + 0.5 * w0,
    )
    .len();
    let drive_uncertainty = drive_uncertainty(&amps, first, n0, w0);
    Ok(Parts {
        drive_amplitude_m,
        drive_phase_rad,
        drive_uncertainty,
        plan,
        points,
        warnings,
    })
}

/// The commanded frequency's nodes (time, frequency) of a continuous
/// sweep from its setpoint messages: valid ones, one per time, at least
/// half a second (or half a drive period) apart, and the last one.
fn command_nodes(run: &Run) -> Vec<(f64, f64)> {
    let mut nodes: Vec<(f64, f64)> = run
        .setpoints
        .iter()
        .filter(|s| s.frequency_hz.is_finite() && s.frequency_hz > 0.0 && s.t_s.is_finite())
        .map(|s| (s.t_s, s.frequency_hz))
        .collect();
    nodes.dedup_by(|b, a| b.0 == a.0);
    // A commanded-frequency column may change at every row: keep nodes at
    // least half a second (or half a drive period, if shorter) apart, and
    // the last one.
    if let Some(&last) = nodes.last() {
        let mut kept: Vec<(f64, f64)> = Vec::with_capacity(nodes.len());
        for &(t, f) in &nodes {
            match kept.last() {
                Some(&(tk, fk)) if t - tk < (0.5 / fk).min(0.5) => {}
                _ => kept.push((t, f)),
            }
        }
        if kept.last() != Some(&last) {
            kept.push(last);
        }
        nodes = kept;
    }
    nodes
}

/// The commanded sweep rate (Hz/s) at node `k`: the mean of the rates of
/// the pieces on either side (one-sided at the ends).
fn rate_cmd(nodes: &[(f64, f64)], k: usize) -> f64 {
    let n = nodes.len();
    let r = |a: usize, b: usize| (nodes[b].1 - nodes[a].1) / (nodes[b].0 - nodes[a].0);
    match k {
        0 => r(0, 1),
        k if k + 1 == n => r(n - 2, n - 1),
        k => 0.5 * (r(k - 1, k) + r(k, k + 1)),
    }
}

/// The plan of a continuous sweep: linear pieces through the measured
/// frequencies at the nodes `fit_nodes`; pieces whose commanded frequency
/// (`nodes`) does not change are holds, equal holds merged and their
/// frequency refitted over the whole hold.
fn continuous_plan(
    nodes: &[(f64, f64)],
    fit_nodes: &[(f64, Sine)],
    td: &[f64],
    xd: &[f64],
) -> Vec<PlanSegment> {
    let mut plan = Vec::with_capacity(fit_nodes.len());
    for w in fit_nodes.windows(2) {
        let ((ta, sa), (tb, sb)) = (w[0], w[1]);
        // Pieces whose commanded frequency does not change are holds at
        // their mean measured frequency.
        let cmd = |t: f64| {
            nodes
                .iter()
                .find(|(tn, _)| *tn == t)
                .map_or(f64::NAN, |(_, f)| *f)
        };
        let (fa, fb) = if cmd(ta) == cmd(tb) {
            let f = 0.5 * (sa.frequency_hz + sb.frequency_hz);
            (f, f)
        } else {
            (sa.frequency_hz, sb.frequency_hz)
        };
        plan.push(PlanSegment {
            start_s: ta,
            end_s: tb,
            f_start_hz: fa,
            f_end_hz: fb,
        });
    }
    // Consecutive equal holds merge into one.
    plan.dedup_by(|b, a| {
        let hold = |s: &PlanSegment| s.f_start_hz == s.f_end_hz;
        if hold(a) && hold(b) && (a.f_start_hz - b.f_start_hz).abs() < 1e-6 * a.f_start_hz {
            let (da, db) = (a.end_s - a.start_s, b.end_s - b.start_s);
            let f = (a.f_start_hz * da + b.f_start_hz * db) / (da + db);
            a.end_s = b.end_s;
            a.f_start_hz = f;
            a.f_end_hz = f;
            true
        } else {
            false
        }
    });
    // Holds: refit the frequency over the whole hold.
    for seg in plan.iter_mut() {
        if seg.f_start_hz == seg.f_end_hz && seg.end_s - seg.start_s > 2.0 / seg.f_start_hz {
            if let Some(s) = fit_sine(
                td,
                xd,
                (seg.start_s, seg.end_s),
                seg.f_start_hz,
                0.01,
                0.0,
                seg.start_s,
            ) {
                seg.f_start_hz = s.frequency_hz;
                seg.f_end_hz = s.frequency_hz;
            }
        }
    }
    plan
}

/// The points of a continuous sweep: one per `periods_per_point` drive
/// periods of the plan's phase.
fn sweep_points(
    plan: &[PlanSegment],
    grid: &Grid,
    periods_per_point: usize,
    omega_ref: f64,
) -> Vec<MeasuredPoint> {
    // Drive periods from the plan's phase.
    let per = periods_per_point.max(1) as f64;
    let mut points = Vec::new();
    let mut carry = 0.0; // cycles into the current point at a segment start
    let mut t_a = plan[0].start_s;
    for seg in plan {
        let total = seg_cycles(seg, seg.end_s);
        let mut c = per - carry;
        while c <= total + 1e-12 {
            let t_b = seg_time(seg, c);
            let window = (t_a, t_b);
            let period = (t_b - t_a) / per;
            if let Some((a1, a2)) = grid.fitted(window, period) {
                let f = 1.0 / period;
                points.push(MeasuredPoint {
                    frequency_hz: f,
                    eta: 2.0 * PI * f / omega_ref,
                    t_start_s: t_a,
                    t_end_s: t_b,
                    window_s: window,
                    amplitude1: f64::NAN,
                    amplitude2: f64::NAN,
                    amplitude1_m: a1.amp,
                    amplitude2_m: a2.amp,
                    amplitude1_u: f64::NAN,
                    amplitude2_u: f64::NAN,
                    amplitude1_noise_m: a1.noise95,
                    amplitude2_noise_m: a2.noise95,
                    rel_change: None,
                    settled: None,
                });
            }
            t_a = t_b;
            c += per;
        }
        carry = total - (c - per);
    }
    points
}
