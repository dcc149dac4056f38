//! Sensitive steps of a stepped sweep (issue 32): does a step's replayed
//! amplitude hinge on details finer than the measurement resolves?
//!
//! * [`start_states`](crate::validate::frc::start_states): the rig's state at each step's start as measured
//!   (ζ1, ζ1', ζ2, ζ2' from local cubic fits of x1 and x2 over ±1/20 of a
//!   drive period, the sensor offsets from the steps where M2 slides), with
//!   standard uncertainties.
//! * [`assess`]: each step is re-run from that state alone (not chained
//!   from the sweep's start) by an ensemble perturbed within the
//!   measurement's uncertainty: the state, the drive amplitude and the drive
//!   phase. The step is sensitive (`replay_sensitive`, rule of
//!   `docs/interface.md`) when the ensemble lands on more than one branch
//!   (some members settle within the window and others do not), or spreads
//!   by more than 3× the linear propagation of the same uncertainties
//!   (central differences of ±1 % of each standard uncertainty), in A1/A,
//!   A2/A or their change between the window's halves (how far from
//!   settled: members that settle and members that do not are two
//!   branches). Also sensitive: a step whose linear propagation of A1/A or
//!   A2/A exceeds 3× the ensemble's spread (a jump right at the measured
//!   start, which the central difference straddles), and a step with an
//!   interrupted member. Spreads under the measured amplitude's own
//!   standard uncertainty (its 95 % error bar / 1.96) are added to the
//!   threshold: what the measurement cannot see does not count. The
//!   ensemble's range then joins the step's replay band.
//!
//! Continuous sweeps have no steps (every drive period is a transient):
//! not assessed (`None`). The ensembles are seeded per step, so the result
//! does not depend on the thread count.

use super::{PredictOptions, Windows};
use crate::model::{Drive, Model, Schedule, Segment};
use crate::sim::engine::{Init, Mode};
use crate::sim::schedule::run_schedule;
use crate::stats::{sample_sd, Rng};
use crate::validate::frc::MeasuredFrc;
use rayon::prelude::*;

/// Members of a step's ensemble.
pub const ENSEMBLE: usize = 16;
/// Ensemble spread over linear propagation above which a step is
/// sensitive.
pub const SPREAD_FACTOR: f64 = 3.0;
/// Central-difference step of the linear propagation, in standard
/// uncertainties.
const DIFF_STEP: f64 = 0.01;

/// The sensitivity of one step.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Sensitivity {
    /// The rule's verdict.
    pub sensitive: bool,
    /// Standard deviation of A1/A and A2/A over the ensemble.
    pub spread: (f64, f64),
    /// Their linear propagation (root sum of squares of each input's
    /// standard uncertainty times the amplitude's derivative).
    pub linear: (f64, f64),
    /// Standard deviation over the ensemble of the change of A1/A and A2/A
    /// between the window's two halves (how far from settled).
    pub settle_spread: (f64, f64),
    /// Its linear propagation.
    pub settle_linear: (f64, f64),
    /// Members that did not settle within the step's window (the amplitude
    /// of the window's two halves differs by more than the steady
    /// tolerance) or were interrupted.
    pub unsettled: usize,
    /// Members run.
    pub members: usize,
    /// Range of A1/A over the ensemble and the unperturbed re-run.
    pub range1: (f64, f64),
    /// The same for A2/A.
    pub range2: (f64, f64),
}

/// One re-run of a step: amplitudes (A1/A, A2/A) over the whole window and
/// over its two halves. None where the step starts in a ramp or the run is
/// interrupted.
type Halves = [(f64, f64); 3];

/// The step's schedule from τ `ts` (the sweep's schedule with amplitude
/// `amp` and the phase shifted by `dphase`), up to τ `end`.
fn from_start(sched: &Schedule, ts: f64, end: f64, amp: f64, dphase: f64) -> Option<Schedule> {
    let shifted = Schedule {
        phase: sched.phase + dphase,
        amplitude: amp,
        ..sched.clone()
    };
    let drives = shifted.drives().ok()?;
    let j = drives
        .iter()
        .rposition(|(t0, _, _)| *t0 <= ts + 1e-9 * ts.abs().max(1.0))?;
    let (t0, ref drive, dur) = drives[j];
    let Drive::Harmonic { eta, .. } = *drive else {
        return None;
    };
    let phase = drive.phase_at(ts - t0)?;
    let mut segments = vec![Segment::Dwell {
        eta,
        duration: (t0 + dur - ts).max(0.0),
    }];
    let mut t = t0 + dur;
    for s in &sched.segments[j + 1..] {
        if t >= end {
            break;
        }
        segments.push(*s);
        t += match s {
            Segment::Dwell { duration, .. } | Segment::Ramp { duration, .. } => *duration,
        };
    }
    if t0 + dur - ts <= 0.0 {
        segments.remove(0);
    }
    (!segments.is_empty()).then_some(Schedule {
        segments,
        phase,
        amplitude: amp,
    })
}

/// Re-runs one step from state `x` (stuck or sliding as `stuck` and the
/// sign of ζ2' say).
fn rerun(
    model: &Model,
    sched: &Schedule,
    (ts, window): (f64, (f64, f64, f64)),
    x: [f64; 4],
    stuck: bool,
    (amp, dphase): (f64, f64),
    opts: &PredictOptions,
) -> Option<Halves> {
    let (a, b, h) = window;
    let sub = from_start(sched, ts, b, amp, dphase)?;
    let m = 0.5 * (a + b);
    let mut obs = Windows::new(vec![(a - ts, m - ts, h), (m - ts, b - ts, h)]);
    let mode = if stuck {
        Mode::Stick { z2: x[2] }
    } else {
        Mode::Slip {
            dir: if x[3] >= 0.0 { 1.0 } else { -1.0 },
        }
    };
    let x = if stuck { [x[0], x[1], x[2], 0.0] } else { x };
    run_schedule(model, &sub, Init { x, mode }, opts.numeric, &mut obs).ok()?;
    let amps = obs.amplitudes();
    let e = obs.extremes();
    let whole =
        |k: usize| 0.5 * (e[0][2 * k + 1].max(e[1][2 * k + 1]) - e[0][2 * k].min(e[1][2 * k]));
    Some([(whole(0), whole(1)), amps[0]?, amps[1]?])
}

/// True when the amplitudes of a re-run's two halves differ by more than
/// `tol` of its A1 (M2's amplitude can be 0).
fn unsettled(r: &Halves, tol: f64) -> bool {
    let scale = r[0].0.max(r[0].1).max(1e-12);
    (r[2].0 - r[1].0).abs().max((r[2].1 - r[1].1).abs()) > tol * scale
}

/// The outputs compared: A1/A, A2/A over the window and their changes
/// between its two halves.
fn outputs(r: &Halves) -> [f64; 4] {
    [r[0].0, r[0].1, r[2].0 - r[1].0, r[2].1 - r[1].1]
}

/// Assesses every step (see the module doc); `None` where not assessed.
pub fn assess(
    model: &Model,
    sched: &Schedule,
    frc: &MeasuredFrc,
    windows: &[(f64, f64, f64)],
    opts: &PredictOptions,
) -> Vec<Option<Sensitivity>> {
    let w = frc.omega_ref_rad_s;
    let du = frc.drive_uncertainty;
    (0..frc.points.len())
        .into_par_iter()
        .map(|i| {
            let s = frc.start_states.get(i).copied().flatten()?;
            let p = &frc.points[i];
            let step = (s.t_s * w, windows[i]);
            // The drive phase's uncertainty with the x0 channel's timing.
            let sd_phase = du
                .phase_rad
                .hypot(2.0 * std::f64::consts::PI * p.frequency_hz * du.delay_s);
            let sd_amp = du.amplitude_rel;
            let run = |x: [f64; 4], stuck: bool, amp: f64, dph: f64| {
                rerun(model, sched, step, x, stuck, (amp, dph), opts)
            };
            let nominal = run(s.x, s.stuck, 1.0, 0.0)?;
            // Linear propagation: central differences in each input.
            let mut lin = [0.0f64; 4];
            let mut add = |plus: Option<Halves>, minus: Option<Halves>| {
                if let (Some(pl), Some(mi)) = (plus, minus) {
                    let (op, om) = (outputs(&pl), outputs(&mi));
                    for k in 0..4 {
                        lin[k] += ((op[k] - om[k]) / (2.0 * DIFF_STEP)).powi(2);
                    }
                }
            };
            for k in 0..4 {
                if s.stuck && k == 3 {
                    continue;
                }
                let d = DIFF_STEP * s.sigma[k];
                let (mut xp, mut xm) = (s.x, s.x);
                xp[k] += d;
                xm[k] -= d;
                add(run(xp, s.stuck, 1.0, 0.0), run(xm, s.stuck, 1.0, 0.0));
            }
            let da = DIFF_STEP * sd_amp;
            add(
                run(s.x, s.stuck, 1.0 + da, 0.0),
                run(s.x, s.stuck, 1.0 - da, 0.0),
            );
            let dp = DIFF_STEP * sd_phase;
            add(run(s.x, s.stuck, 1.0, dp), run(s.x, s.stuck, 1.0, -dp));
            let linear = lin.map(f64::sqrt);
            // The ensemble (its own seeded stream per step).
            let mut rng = Rng::with_stream(opts.seed ^ 0x5E75_17FE, i as u64);
            let mut members = Vec::with_capacity(ENSEMBLE);
            let mut failed = 0usize;
            for _ in 0..ENSEMBLE {
                let mut x = s.x;
                for (k, (xk, sk)) in x.iter_mut().zip(s.sigma).enumerate() {
                    if !(s.stuck && k == 3) {
                        *xk += sk * rng.normal();
                    }
                }
                let amp = 1.0 + sd_amp * rng.normal();
                let dph = sd_phase * rng.normal();
                match run(x, s.stuck, amp, dph) {
                    Some(r) => members.push(r),
                    None => failed += 1,
                }
            }
            let tol = opts.steady_tolerance;
            let unsettled_n = failed + members.iter().filter(|r| unsettled(r, tol)).count();
            let outs: Vec<[f64; 4]> = members.iter().map(outputs).collect();
            let spread: [f64; 4] = std::array::from_fn(|k| {
                let v: Vec<f64> = outs.iter().map(|o| o[k]).collect();
                sample_sd(&v)
            });
            let range = |k: usize| {
                outs.iter()
                    .chain(std::iter::once(&outputs(&nominal)))
                    .map(|o| o[k])
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
                        (lo.min(v), hi.max(v))
                    })
            };
            // Spreads below the measured amplitude's own standard
            // uncertainty do not matter (and amplitudes agree to about
            // 1e-9 of A1 numerically): the floor of A1's outputs and A2's.
            let num = 1e-9 * nominal[0].0;
            let fl = [p.amplitude1_u / 1.96, p.amplitude2_u / 1.96].map(|u| u.max(num));
            let floor = |k: usize| fl[k % 2];
            // An interrupted member is a branch of its own. A linear
            // propagation of an amplitude far above the ensemble's spread
            // means a jump within ±1 % of a standard uncertainty of the
            // measured start (the derivative straddles it): the amplitude
            // hinges on it as much.
            let sensitive = failed > 0
                || (0..4).any(|k| spread[k] > SPREAD_FACTOR * linear[k] + floor(k))
                || (0..2).any(|k| linear[k] > SPREAD_FACTOR * spread[k] + floor(k));
            Some(Sensitivity {
                sensitive,
                spread: (spread[0], spread[1]),
                linear: (linear[0], linear[1]),
                settle_spread: (spread[2], spread[3]),
                settle_linear: (linear[2], linear[3]),
                unsettled: unsettled_n,
                members: members.len() + failed,
                range1: range(0),
                range2: range(1),
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_step_starts_with_the_sweeps_drive() {
        let sched = Schedule {
            segments: vec![
                Segment::Dwell {
                    eta: 0.7,
                    duration: 30.0,
                },
                Segment::Ramp {
                    eta: 0.8,
                    duration: 5.0,
                },
                Segment::Dwell {
                    eta: 0.8,
                    duration: 40.0,
                },
            ],
            phase: 0.3,
            amplitude: 1.0,
        };
        // From inside the last dwell: its drive, phase continued.
        let sub = from_start(&sched, 50.0, 70.0, 1.0, 0.0).unwrap();
        let (t0, ref d, _) = sched.drives().unwrap()[2];
        assert_eq!(sub.segments.len(), 1);
        assert_eq!(
            sub.segments[0],
            Segment::Dwell {
                eta: 0.8,
                duration: 25.0
            }
        );
        let want = d.phase_at(50.0 - t0).unwrap();
        assert!((sub.phase - want).abs() < 1e-12);
        // From inside the first dwell up to the last: the ramp follows.
        let sub = from_start(&sched, 10.0, 50.0, 1.02, 0.1).unwrap();
        assert_eq!(sub.segments.len(), 3);
        assert_eq!(sub.amplitude, 1.02);
        assert!((sub.phase - (0.4 + 0.7 * 10.0)).abs() < 1e-12);
        // Not from a ramp.
        assert!(from_start(&sched, 32.0, 50.0, 1.0, 0.0).is_none());
    }
}
