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
use crate::ingest::{Quantity, Run, SweepKind as LogSweepKind};
use crate::sim::sweep::Direction;
use crate::stats::golden_section;
use crate::stats::median;
use crate::{Error, Result};
use argmin::core::{CostFunction, Executor, State};
use argmin::solver::neldermead::NelderMead;
use std::f64::consts::PI;

mod amplitude;
mod plan;
mod start;

use amplitude::*;
use plan::*;
pub use start::{start_states, StartState};

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
    /// see [`start_states`]).
    pub start_states: Vec<Option<StartState>>,
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
    m.start_states = start_states(run, &m);
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
