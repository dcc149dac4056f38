//! Stepped sweeps as the rig runs them: a [`Schedule`] of harmonic dwells
//! (exact engine, closed form per segment, continuous phase) and frequency
//! ramps (numerical engine), with the state and contact mode carried across.

use super::engine::{Event, Flow, Init, Mode, Observer, PeriodStats, RunEnd, Status};
use super::numeric::NumericOptions;
use super::Engine;
use super::SimError;
use crate::model::{Model, Schedule};

/// Shifts the times an inner observer sees by the segment's start, and
/// tells it which segment runs.
struct Offset<'a, O: Observer> {
    inner: &'a mut O,
    t0: f64,
}

impl<O: Observer> Observer for Offset<'_, O> {
    fn event(&mut self, ev: &Event) {
        self.inner.event(&Event {
            tau: ev.tau + self.t0,
            ..*ev
        });
    }
    fn period(&mut self, n: u64, x: &[f64; 4], mode: Mode, stats: &PeriodStats) -> Flow {
        self.inner.period(n, x, mode, stats)
    }
    fn next_sample(&mut self) -> Option<f64> {
        self.inner.next_sample().map(|t| t - self.t0)
    }
    fn sample(&mut self, tau: f64, x: &[f64; 4], dx: &[f64; 4]) {
        self.inner.sample(tau + self.t0, x, dx);
    }
    fn wants_extremes(&self) -> bool {
        self.inner.wants_extremes()
    }
}

/// Receives segment boundaries of a schedule run.
pub trait SegmentObserver: Observer {
    /// Segment `i` starts at τ = `tau` with state `x`.
    fn segment(&mut self, _i: usize, _tau: f64, _x: &[f64; 4]) {}
}

impl SegmentObserver for () {}

/// Runs the whole schedule from `init`. Period callbacks count whole
/// periods within each dwell. Returns where the run ended (τ from the
/// schedule's start); an interruption ends it early.
pub fn run_schedule<O: SegmentObserver>(
    model: &Model,
    schedule: &Schedule,
    init: Init,
    opts: NumericOptions,
    obs: &mut O,
) -> Result<RunEnd, SimError> {
    let drives = schedule.drives()?;
    let mut state = init;
    let (mut events, mut stick_time, mut periods) = (0u64, 0.0, 0u64);
    let mut last = RunEnd {
        status: Status::Completed,
        periods: 0,
        tau: 0.0,
        x: init.x,
        mode: init.mode,
        events: 0,
        stick_time: 0.0,
    };
    for (i, (t0, drive, dur)) in drives.into_iter().enumerate() {
        obs.segment(i, t0, &state.x);
        let mut off = Offset { inner: obs, t0 };
        let end = Engine::new(model, drive, opts)?.run(state, dur, &mut off);
        events += end.events;
        stick_time += end.stick_time;
        periods += end.periods;
        state = Init {
            x: end.x,
            mode: end.mode,
        };
        last = RunEnd {
            tau: t0 + end.tau,
            events,
            stick_time,
            periods,
            ..end
        };
        if !matches!(last.status, Status::Completed) {
            break;
        }
    }
    Ok(last)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{Absorber, Law, Segment};

    fn model() -> Model {
        Model {
            absorber: Absorber::default(),
            law: Law::coulomb(0.375),
            stop_below: None,
            contact_stiffness: None,
        }
    }

    /// Two dwells at the same η with continuous phase are one harmonic run
    /// (the H1 case), cut at an arbitrary non-period time: the same final
    /// state to rounding.
    #[test]
    fn split_dwell_equals_one_run() {
        let m = model();
        let t = 2.0 * std::f64::consts::PI / 0.6;
        let one = crate::sim::Sim::new(&m, 0.6)
            .unwrap()
            .run(Init::rest(), 20, &mut ());
        let s = Schedule {
            segments: vec![
                Segment::Dwell {
                    eta: 0.6,
                    duration: 7.3 * t,
                },
                Segment::Dwell {
                    eta: 0.6,
                    duration: 12.7 * t,
                },
            ],
            phase: 0.0,
            amplitude: 1.0,
        };
        let two = run_schedule(&m, &s, Init::rest(), NumericOptions::default(), &mut ()).unwrap();
        assert_eq!(one.events, two.events);
        for i in 0..4 {
            assert!(
                (one.x[i] - two.x[i]).abs() < 1e-12,
                "{:?} vs {:?}",
                one.x,
                two.x
            );
        }
    }

    /// A ramp whose end frequency equals its start is a harmonic drive: the
    /// numerical engine on it agrees with the exact engine to its tolerance.
    #[test]
    fn flat_ramp_equals_dwell() {
        let m = model();
        let t = 2.0 * std::f64::consts::PI / 0.6;
        let s = |ramp: bool| Schedule {
            segments: vec![
                Segment::Dwell {
                    eta: 0.6,
                    duration: 3.0 * t,
                },
                if ramp {
                    Segment::Ramp {
                        eta: 0.6,
                        duration: 5.0 * t,
                    }
                } else {
                    Segment::Dwell {
                        eta: 0.6,
                        duration: 5.0 * t,
                    }
                },
            ],
            phase: 0.2,
            amplitude: 1.0,
        };
        let opts = NumericOptions {
            rtol: 1e-12,
            atol: 1e-14,
        };
        let a = run_schedule(&m, &s(false), Init::rest(), opts, &mut ()).unwrap();
        let b = run_schedule(&m, &s(true), Init::rest(), opts, &mut ()).unwrap();
        assert_eq!(a.events, b.events);
        for i in 0..4 {
            assert!((a.x[i] - b.x[i]).abs() < 1e-9, "{:?} vs {:?}", a.x, b.x);
        }
    }

    /// A real stepped sweep (dwell, ramp, dwell): tightening the numerical
    /// tolerance converges the final state (self-consistency of the ramp).
    #[test]
    fn stepped_sweep_converges_with_tolerance() {
        let m = model();
        let s = Schedule {
            segments: vec![
                Segment::Dwell {
                    eta: 0.5,
                    duration: 40.0,
                },
                Segment::Ramp {
                    eta: 0.7,
                    duration: 5.0,
                },
                Segment::Dwell {
                    eta: 0.7,
                    duration: 40.0,
                },
            ],
            phase: 0.0,
            amplitude: 1.0,
        };
        let run = |rtol: f64| {
            run_schedule(
                &m,
                &s,
                Init::rest(),
                NumericOptions {
                    rtol,
                    atol: rtol * 1e-2,
                },
                &mut (),
            )
            .unwrap()
        };
        let (a, b, c) = (run(1e-7), run(1e-10), run(1e-13));
        let d =
            |p: &RunEnd, q: &RunEnd| (0..4).map(|i| (p.x[i] - q.x[i]).abs()).fold(0.0, f64::max);
        assert!(
            d(&b, &c) < 1e-7 && d(&b, &c) < d(&a, &c),
            "{} {}",
            d(&a, &c),
            d(&b, &c)
        );
        assert!((c.tau - 85.0).abs() < 1e-12);
    }
}
