//! Stepped and continuous sweeps: the drive plan as it was run (holds,
//! ramps and chirp nodes fitted to the drive signal) and the measured
//! points along it.

use super::*;
use crate::ingest::Run;
use crate::sim::sweep::Direction;
use crate::stats::median;
use crate::Result;
use std::f64::consts::PI;

/// The steps of a stepped sweep: (start time, commanded frequency); a
/// repeated frequency continues the previous hold (e.g. a pre-roll), the
/// step starting at its last message.
pub(super) fn distinct_steps(run: &Run) -> Vec<(f64, f64)> {
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

pub(super) fn direction_of(f: &[f64]) -> Direction {
    match (f.first(), f.last()) {
        (Some(a), Some(b)) if b < a => Direction::Down,
        _ => Direction::Up,
    }
}

/// Stepped sweep: one hold per distinct setpoint, its drive sinusoid
/// fitted, ramps between holds located in the drive signal, and one point
/// per hold from the whole drive periods at its end.
pub(super) fn stepped(
    run: &Run,
    td: &[f64],
    xd: &[f64],
    grid: &Grid,
    opts: &FrcOptions,
) -> Result<Parts> {
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
pub(super) fn hold_bounds(run: &Run, steps: &[(f64, f64)], t_log_end: f64) -> Vec<(f64, f64)> {
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
pub(super) fn hold_ramps(
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
pub(super) fn stepped_plan(
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
pub(super) struct Hold {
    /// Its number (1-based, for warnings).
    pub(super) step: usize,
    pub(super) sine: Sine,
    /// Its first message and the next step's.
    pub(super) bounds: (f64, f64),
    /// The ramp into it (start, duration).
    pub(super) ramp: Option<(f64, f64)>,
}

/// The measured point of one hold and its window: whole drive periods at
/// the end of the hold (never more than half of it), with the trend over
/// the window's two halves; None (with a warning) where the hold is too
/// short or x1/x2 have too few samples.
pub(super) fn step_point(
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
pub(super) fn seg_cycles(seg: &PlanSegment, t: f64) -> f64 {
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
pub(super) fn seg_time(seg: &PlanSegment, c: f64) -> f64 {
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
pub(super) fn continuous(
    run: &Run,
    td: &[f64],
    xd: &[f64],
    grid: &Grid,
    opts: &FrcOptions,
) -> Result<Parts> {
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
pub(super) fn command_nodes(run: &Run) -> Vec<(f64, f64)> {
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
pub(super) fn rate_cmd(nodes: &[(f64, f64)], k: usize) -> f64 {
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
pub(super) fn continuous_plan(
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
pub(super) fn sweep_points(
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
