//! The replay of a sweep as it was run: the measured drive plan as a
//! schedule, and the amplitudes over each step's window recorded from the
//! exact trajectory.

use super::*;

/// The measured frequency plan as a dimensionless [`Schedule`] (τ = ω_ref·t,
/// ζ0 = x0/A). The rig's x0 = A·sin φ is the engine's cos(φ − π/2).
pub fn schedule(frc: &MeasuredFrc) -> Result<Schedule, PredictError> {
    let w = frc.omega_ref_rad_s;
    let eta = |f: f64| 2.0 * PI * f / w;
    let mut segments = Vec::with_capacity(frc.plan.len());
    for (i, s) in frc.plan.iter().enumerate() {
        let dur = (s.end_s - s.start_s) * w;
        if dur.is_nan() || dur <= 0.0 {
            continue;
        }
        let seg = if s.f_start_hz == s.f_end_hz || i == 0 {
            Segment::Dwell {
                eta: eta(0.5 * (s.f_start_hz + s.f_end_hz)),
                duration: dur,
            }
        } else {
            Segment::Ramp {
                eta: eta(s.f_end_hz),
                duration: dur,
            }
        };
        segments.push(seg);
    }
    if segments.is_empty() {
        return Err(ValidateError::EmptyPlan.into());
    }
    Ok(Schedule {
        segments,
        phase: frc.drive_phase_rad - 0.5 * PI,
        amplitude: 1.0,
    })
}

/// Records (max − min)/2 of ζ1 and ζ2 over a list of windows (τ), sampling
/// the exact trajectory and refining each interior extremum with the cubic
/// Hermite interpolant of the two bracketing samples.
pub(super) struct Windows {
    /// (τ start, τ end, sample spacing) per window, in time order.
    pub(super) windows: Vec<(f64, f64, f64)>,
    /// Current window and sample index.
    pub(super) w: usize,
    pub(super) j: u64,
    /// Per window: [min1, max1, min2, max2].
    pub(super) ext: Vec<[f64; 4]>,
    pub(super) prev: Option<(f64, [f64; 4])>,
}

impl Windows {
    pub(super) fn new(windows: Vec<(f64, f64, f64)>) -> Self {
        let n = windows.len();
        Self {
            windows,
            w: 0,
            j: 0,
            ext: vec![
                [
                    f64::INFINITY,
                    f64::NEG_INFINITY,
                    f64::INFINITY,
                    f64::NEG_INFINITY
                ];
                n
            ],
            prev: None,
        }
    }

    /// Per window: [min ζ1, max ζ1, min ζ2, max ζ2] (±∞ where empty).
    pub(super) fn extremes(&self) -> &[[f64; 4]] {
        &self.ext
    }

    pub(super) fn amplitudes(&self) -> Vec<Option<(f64, f64)>> {
        self.ext
            .iter()
            .map(|e| {
                let (a1, a2) = (0.5 * (e[1] - e[0]), 0.5 * (e[3] - e[2]));
                (a1.is_finite() && a2.is_finite()).then_some((a1, a2))
            })
            .collect()
    }
}

/// Extremes of the cubic Hermite interpolant on [t0, t1] (interior roots
/// of its derivative).
pub(super) fn hermite_extremes(
    t0: f64,
    y0: f64,
    d0: f64,
    t1: f64,
    y1: f64,
    d1: f64,
) -> [Option<f64>; 2] {
    let h = t1 - t0;
    // p(s) = y0 h00 + h d0 h10 + y1 h01 + h d1 h11, s ∈ [0, 1];
    // p'(s)/… = a s² + b s + c with
    let (m0, m1) = (h * d0, h * d1);
    let a = 6.0 * (y0 - y1) + 3.0 * (m0 + m1);
    let b = -6.0 * (y0 - y1) - 4.0 * m0 - 2.0 * m1;
    let c = m0;
    let eval = |s: f64| {
        let (s2, s3) = (s * s, s * s * s);
        y0 * (2.0 * s3 - 3.0 * s2 + 1.0)
            + m0 * (s3 - 2.0 * s2 + s)
            + y1 * (-2.0 * s3 + 3.0 * s2)
            + m1 * (s3 - s2)
    };
    let mut out = [None, None];
    let mut push = |s: f64, k: usize| {
        if s > 0.0 && s < 1.0 {
            out[k] = Some(eval(s));
        }
    };
    if a.abs() < 1e-14 * (b.abs() + c.abs()).max(1e-300) {
        if b != 0.0 {
            push(-c / b, 0);
        }
    } else {
        let disc = b * b - 4.0 * a * c;
        if disc >= 0.0 {
            let q = -0.5 * (b + b.signum() * disc.sqrt());
            push(q / a, 0);
            if q != 0.0 {
                push(c / q, 1);
            }
        }
    }
    out
}

impl Windows {
    /// A state of the trajectory at τ (a sample or an event): updates the
    /// current window's extremes, with the cubic Hermite interpolant from
    /// the previous state (positions and velocities are continuous, so the
    /// interpolant is valid between consecutive states; events split it
    /// where accelerations jump).
    pub(super) fn visit(&mut self, tau: f64, x: &[f64; 4]) {
        let Some(&(t0, _, _)) = self.windows.get(self.w) else {
            return;
        };
        if tau < t0 {
            return;
        }
        let e = &mut self.ext[self.w];
        for k in 0..2 {
            let y = x[2 * k];
            e[2 * k] = e[2 * k].min(y);
            e[2 * k + 1] = e[2 * k + 1].max(y);
        }
        if let Some((tp, xp)) = self.prev {
            if tau > tp {
                for k in 0..2 {
                    let (i, d) = (2 * k, 2 * k + 1);
                    for v in hermite_extremes(tp, xp[i], xp[d], tau, x[i], x[d])
                        .into_iter()
                        .flatten()
                    {
                        e[2 * k] = e[2 * k].min(v);
                        e[2 * k + 1] = e[2 * k + 1].max(v);
                    }
                }
            }
        }
        self.prev = Some((tau, *x));
    }
}

impl Observer for Windows {
    fn event(&mut self, ev: &Event) {
        self.visit(ev.tau, &ev.x);
    }
    fn next_sample(&mut self) -> Option<f64> {
        let (t0, t1, h) = *self.windows.get(self.w)?;
        let t = t0 + self.j as f64 * h;
        Some(t.min(t1))
    }
    fn sample(&mut self, tau: f64, x: &[f64; 4], _dx: &[f64; 4]) {
        let Some(&(_, t1, _)) = self.windows.get(self.w) else {
            return;
        };
        self.visit(tau, x);
        if tau >= t1 {
            self.w += 1;
            self.j = 0;
            self.prev = None;
        } else {
            self.j += 1;
        }
    }
    fn wants_extremes(&self) -> bool {
        false
    }
}

impl SegmentObserver for Windows {}

/// Amplitudes (A1/A, A2/A) per point; None where the model gives none.
pub(super) type Amps = Vec<Option<(f64, f64)>>;

/// Replays the sweep with one law: amplitudes over each point's window.
pub(super) fn replay_one(
    model: &Model,
    sched: &Schedule,
    windows: &[(f64, f64, f64)],
    opts: &PredictOptions,
) -> Vec<Option<(f64, f64)>> {
    let mut obs = Windows::new(windows.to_vec());
    let shown = shown_part(sched, windows);
    match run_schedule(model, &shown, Init::rest(), opts.numeric, &mut obs) {
        // An interruption ends the run: the windows after it stay empty.
        Ok(_) => obs.amplitudes(),
        Err(_) => vec![None; windows.len()],
    }
}

/// The schedule up to the segment that holds the end of the last window:
/// the segments after it change no amplitude shown (the replay runs
/// forwards from rest), so they are not simulated.
pub(super) fn shown_part(sched: &Schedule, windows: &[(f64, f64, f64)]) -> Schedule {
    let end = windows
        .iter()
        .map(|w| w.1)
        .fold(f64::NEG_INFINITY, f64::max);
    let mut start = 0.0;
    let mut keep = 0;
    for s in &sched.segments {
        if start > end {
            break;
        }
        keep += 1;
        start += match s {
            Segment::Dwell { duration, .. } | Segment::Ramp { duration, .. } => *duration,
        };
    }
    Schedule {
        segments: sched.segments[..keep.max(1)].to_vec(),
        ..sched.clone()
    }
}

/// The schedule of a drawn drive: its phase error added, every frequency
/// scaled by its relative error.
pub(super) fn drawn_schedule(sched: &Schedule, d: &DriveDraw) -> Schedule {
    if d.phase_rad == 0.0 && d.frequency_rel == 0.0 {
        return sched.clone();
    }
    let k = 1.0 + d.frequency_rel;
    Schedule {
        segments: sched
            .segments
            .iter()
            .map(|s| match *s {
                Segment::Dwell { eta, duration } => Segment::Dwell {
                    eta: eta * k,
                    duration,
                },
                Segment::Ramp { eta, duration } => Segment::Ramp {
                    eta: eta * k,
                    duration,
                },
            })
            .collect(),
        phase: sched.phase + d.phase_rad,
        ..sched.clone()
    }
}

/// Each point's window in engine time τ and the output step of the replay
/// (`samples_per_period`, at least 8, per drive period at the point's η).
pub(super) fn replay_windows(frc: &MeasuredFrc, opts: &PredictOptions) -> Vec<(f64, f64, f64)> {
    let w = frc.omega_ref_rad_s;
    let per = opts.samples_per_period.max(8) as f64;
    frc.points
        .iter()
        .map(|p| {
            let h = 2.0 * PI / p.eta / per;
            (p.window_s.0 * w, p.window_s.1 * w, h)
        })
        .collect()
}
