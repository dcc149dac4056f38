//! The drive of a test as closed-form pieces (and the stepped sweep's
//! schedule and setpoints).

use super::*;

/// The drive as pieces (start τ, drive, duration) with x0/A_true = ζ0.
pub(super) struct Drives(pub(super) Vec<(f64, Drive, f64)>);

impl Drives {
    pub(super) fn zeta0(&self, tau: f64) -> f64 {
        let i = self.0.partition_point(|(t0, _, _)| *t0 <= tau).max(1) - 1;
        let (t0, d, _) = &self.0[i];
        d.eval(tau - t0).0
    }
}

/// The drive pieces, the schedule (sweeps) and the setpoint messages.
pub(super) fn drives_of(
    cfg: &SynthConfig,
    w: f64,
) -> (Drives, Option<Schedule>, Vec<SynthSetpoint>) {
    let eta = |f: f64| 2.0 * PI * f / w;
    let a_nom = cfg.rig.drive_amplitude_nominal_m;
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
        } => stepped(setpoints_hz, dwell_s, *ramp_s, *preroll_s, w, a_nom),
        TestSpec::Continuous {
            from_hz,
            to_hz,
            sweep_s,
            hold_before_s,
            hold_after_s,
        } => continuous(
            *from_hz,
            *to_hz,
            *sweep_s,
            *hold_before_s,
            *hold_after_s,
            w,
            a_nom,
        ),
    }
}

/// The log time `t_s` (s from the log start) in ns.
fn at(t_s: f64) -> u64 {
    LOG_START_NS + (t_s * 1e9).round() as u64
}

/// The stepped sweep: pre-roll, then per setpoint a ramp (but the first)
/// and a dwell; one setpoint message per setpoint (and at the log start
/// before a pre-roll).
fn stepped(
    setpoints_hz: &[f64],
    dwell_s: &[f64],
    ramp_s: f64,
    preroll_s: f64,
    w: f64,
    a_nom: f64,
) -> (Drives, Option<Schedule>, Vec<SynthSetpoint>) {
    let eta = |f: f64| 2.0 * PI * f / w;
    let mut segs = Vec::new();
    let mut sps = Vec::new();
    let mut t = 0.0;
    if preroll_s > 0.0 {
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

/// The continuous sweep: hold, linear chirp, hold; a setpoint message each
/// second with the frequency of the chirp then.
fn continuous(
    from_hz: f64,
    to_hz: f64,
    sweep_s: f64,
    hold_before_s: f64,
    hold_after_s: f64,
    w: f64,
    a_nom: f64,
) -> (Drives, Option<Schedule>, Vec<SynthSetpoint>) {
    let eta = |f: f64| 2.0 * PI * f / w;
    let mut segs = vec![
        Segment::Dwell {
            eta: eta(from_hz),
            duration: hold_before_s * w,
        },
        Segment::Ramp {
            eta: eta(to_hz),
            duration: sweep_s * w,
        },
    ];
    if hold_after_s > 0.0 {
        segs.push(Segment::Dwell {
            eta: eta(to_hz),
            duration: hold_after_s * w,
        });
    }
    let total = hold_before_s + sweep_s + hold_after_s;
    let sps = (0..)
        .map(|k| k as f64)
        .take_while(|&t| t < total)
        .map(|t| {
            let f = if t <= hold_before_s {
                from_hz
            } else if t >= hold_before_s + sweep_s {
                to_hz
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
