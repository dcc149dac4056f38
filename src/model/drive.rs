//! Drives: the base motion ζ0(τ) = x0(t)/A that forces the absorber
//! (k·ζ0 acts on M1).
//!
//! * [`Drive::Harmonic`]: cos(ητ + φ), the paper's drive; the exact engine
//!   solves it in closed form.
//! * [`Drive::Chirp`]: a linear frequency ramp with continuous phase (the
//!   short ramps between the steps of a stepped sweep, a slow continuous
//!   sweep); numerical integration.
//! * [`Drive::Sampled`]: a measured drive signal, uniformly sampled and
//!   interpolated by a C¹ cubic (Catmull–Rom); numerical integration.
//!
//! A stepped sweep is a [`Schedule`] of harmonic dwells and chirp ramps with
//! continuous phase.

/// A base motion ζ0(τ), with τ measured from the drive's own start.
#[derive(Debug, Clone, PartialEq)]
pub enum Drive {
    /// ζ0 = amplitude·cos(η·τ + phase).
    Harmonic {
        /// Frequency ratio η.
        eta: f64,
        /// Phase φ at τ = 0.
        phase: f64,
        /// Amplitude (1 for the paper's normalisation ζ0 = x0/A).
        amplitude: f64,
    },
    /// ζ0 = amplitude·cos(φ(τ)), φ = phase + η0·τ + (η1 − η0)·τ²/(2L):
    /// the instantaneous frequency ramps linearly from η0 to η1 over L.
    Chirp {
        /// Start frequency η0.
        eta0: f64,
        /// End frequency η1 (reached at τ = L).
        eta1: f64,
        /// Ramp duration L.
        duration: f64,
        /// Phase at τ = 0.
        phase: f64,
        /// Amplitude.
        amplitude: f64,
    },
    /// A sampled signal: values at τ = j·dt, j = 0..n.
    Sampled {
        /// Sample spacing.
        dt: f64,
        /// ζ0 samples.
        values: Vec<f64>,
    },
}

impl Drive {
    /// ζ0 alone at τ (what a right-hand side needs): one cosine for the
    /// harmonic and chirp drives instead of [`Drive::eval`]'s sine and
    /// cosine; the same value as `eval(τ).0`.
    #[inline]
    pub fn position(&self, tau: f64) -> f64 {
        match self {
            Drive::Harmonic {
                eta,
                phase,
                amplitude,
            } => amplitude * (eta * tau + phase).cos(),
            Drive::Chirp {
                eta0,
                eta1,
                duration,
                phase,
                amplitude,
            } => {
                let rate = (eta1 - eta0) / duration;
                amplitude * (phase + eta0 * tau + 0.5 * rate * tau * tau).cos()
            }
            Drive::Sampled { .. } => self.eval(tau).0,
        }
    }

    /// ζ0, ζ0' and ζ0'' at τ.
    #[inline]
    pub fn eval(&self, tau: f64) -> (f64, f64, f64) {
        match self {
            Drive::Harmonic {
                eta,
                phase,
                amplitude,
            } => {
                let (s, c) = (eta * tau + phase).sin_cos();
                (
                    amplitude * c,
                    -amplitude * eta * s,
                    -amplitude * eta * eta * c,
                )
            }
            Drive::Chirp {
                eta0,
                eta1,
                duration,
                phase,
                amplitude,
            } => {
                let rate = (eta1 - eta0) / duration;
                let w = eta0 + rate * tau;
                let (s, c) = (phase + eta0 * tau + 0.5 * rate * tau * tau).sin_cos();
                (
                    amplitude * c,
                    -amplitude * w * s,
                    -amplitude * (rate * s + w * w * c),
                )
            }
            Drive::Sampled { dt, values } => sampled(values, *dt, tau),
        }
    }

    /// Phase (radians) reached at τ, for harmonic and chirp drives: the
    /// phase the next segment of a schedule continues from.
    pub fn phase_at(&self, tau: f64) -> Option<f64> {
        match self {
            Drive::Harmonic { eta, phase, .. } => Some(phase + eta * tau),
            Drive::Chirp {
                eta0,
                eta1,
                duration,
                phase,
                ..
            } => Some(phase + eta0 * tau + 0.5 * (eta1 - eta0) / duration * tau * tau),
            Drive::Sampled { .. } => None,
        }
    }

    /// The fastest frequency in the drive (bounds integration steps).
    pub fn fastest(&self) -> f64 {
        match self {
            Drive::Harmonic { eta, .. } => *eta,
            Drive::Chirp { eta0, eta1, .. } => eta0.max(*eta1),
            Drive::Sampled { dt, .. } => std::f64::consts::PI / dt,
        }
    }
}

/// Catmull–Rom cubic through the samples (C¹, exact for quadratics),
/// clamped to the first/last sample outside the record.
fn sampled(v: &[f64], dt: f64, tau: f64) -> (f64, f64, f64) {
    let n = v.len();
    if n == 0 {
        return (0.0, 0.0, 0.0);
    }
    if n == 1 || tau <= 0.0 {
        return (v[0], 0.0, 0.0);
    }
    let u = tau / dt;
    if u >= (n - 1) as f64 {
        return (v[n - 1], 0.0, 0.0);
    }
    let j = (u.floor() as usize).min(n - 2);
    let t = u - j as f64;
    let p1 = v[j];
    let p2 = v[j + 1];
    let p0 = if j > 0 { v[j - 1] } else { 2.0 * p1 - p2 };
    let p3 = if j + 2 < n { v[j + 2] } else { 2.0 * p2 - p1 };
    let a = -0.5 * p0 + 1.5 * p1 - 1.5 * p2 + 0.5 * p3;
    let b = p0 - 2.5 * p1 + 2.0 * p2 - 0.5 * p3;
    let c = -0.5 * p0 + 0.5 * p2;
    let val = ((a * t + b) * t + c) * t + p1;
    let d1 = ((3.0 * a * t + 2.0 * b) * t + c) / dt;
    let d2 = (6.0 * a * t + 2.0 * b) / (dt * dt);
    (val, d1, d2)
}

/// One piece of a [`Schedule`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Segment {
    /// Dwell at frequency η for `duration`.
    Dwell {
        /// Frequency ratio η.
        eta: f64,
        /// Duration.
        duration: f64,
    },
    /// Linear frequency ramp from the previous frequency to `eta`.
    Ramp {
        /// Frequency at the ramp's end.
        eta: f64,
        /// Duration.
        duration: f64,
    },
}

/// A stepped sweep: dwells and ramps with continuous drive phase, starting
/// at phase `phase` and frequency of the first segment.
#[derive(Debug, Clone, PartialEq)]
pub struct Schedule {
    /// The segments in order.
    pub segments: Vec<Segment>,
    /// Drive phase at the start.
    pub phase: f64,
    /// Drive amplitude (1 for ζ0 = x0/A).
    pub amplitude: f64,
}

/// Why a [`Schedule`] gives no drives.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ScheduleError {
    /// A ramp with no segment before it to start from.
    #[error("segment {segment}: a schedule must start with a dwell")]
    StartsWithRamp {
        /// The segment (0-based).
        segment: usize,
    },
    /// A segment whose duration or η is not finite and positive.
    #[error("segment {segment}: duration and eta must be finite and > 0")]
    BadSegment {
        /// The segment (0-based).
        segment: usize,
    },
}

impl Schedule {
    /// The drives of the segments with their start times, phases continued
    /// from segment to segment. A ramp starts at the previous segment's
    /// frequency (the first segment must be a dwell).
    pub fn drives(&self) -> Result<Vec<(f64, Drive, f64)>, ScheduleError> {
        let mut out = Vec::with_capacity(self.segments.len());
        let (mut t, mut phase, mut eta_prev) = (0.0, self.phase, None);
        for (i, seg) in self.segments.iter().enumerate() {
            let (drive, dur, eta_end) = match *seg {
                Segment::Dwell { eta, duration } => (
                    Drive::Harmonic {
                        eta,
                        phase,
                        amplitude: self.amplitude,
                    },
                    duration,
                    eta,
                ),
                Segment::Ramp { eta, duration } => {
                    let eta0 = eta_prev.ok_or(ScheduleError::StartsWithRamp { segment: i })?;
                    (
                        Drive::Chirp {
                            eta0,
                            eta1: eta,
                            duration,
                            phase,
                            amplitude: self.amplitude,
                        },
                        duration,
                        eta,
                    )
                }
            };
            if !(dur.is_finite() && dur > 0.0 && eta_end.is_finite() && eta_end > 0.0) {
                return Err(ScheduleError::BadSegment { segment: i });
            }
            let end_phase = drive.phase_at(dur).expect("harmonic or chirp");
            // Keep the phase small: only its value mod 2π matters.
            phase = end_phase.rem_euclid(2.0 * std::f64::consts::PI);
            out.push((t, drive, dur));
            t += dur;
            eta_prev = Some(eta_end);
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The chirp's phase derivative is its instantaneous frequency, and its
    /// value and derivatives agree with finite differences.
    #[test]
    fn chirp_derivatives() {
        let d = Drive::Chirp {
            eta0: 0.5,
            eta1: 1.5,
            duration: 100.0,
            phase: 0.3,
            amplitude: 1.0,
        };
        let h = 1e-5;
        for &t in &[0.0, 10.0, 73.3] {
            let (v, d1, d2) = d.eval(t);
            let (vp, d1p, _) = d.eval(t + h);
            let (vm, d1m, _) = d.eval(t - h);
            assert!(((vp - vm) / (2.0 * h) - d1).abs() < 1e-8);
            assert!(((d1p - d1m) / (2.0 * h) - d2).abs() < 1e-7);
            assert!(v.abs() <= 1.0);
        }
    }

    /// Catmull–Rom reproduces a quadratic exactly between interior samples.
    #[test]
    fn sampled_is_exact_for_quadratics() {
        let f = |t: f64| 0.3 + 0.2 * t - 0.05 * t * t;
        let dt = 0.5;
        let values: Vec<f64> = (0..20).map(|j| f(j as f64 * dt)).collect();
        let d = Drive::Sampled { dt, values };
        for &t in &[1.1, 3.3, 7.77] {
            let (v, d1, d2) = d.eval(t);
            assert!((v - f(t)).abs() < 1e-13);
            assert!((d1 - (0.2 - 0.1 * t)).abs() < 1e-12);
            assert!((d2 + 0.1).abs() < 1e-12);
        }
    }

    #[test]
    fn schedule_continues_phase() {
        let s = Schedule {
            segments: vec![
                Segment::Dwell {
                    eta: 0.5,
                    duration: 10.0,
                },
                Segment::Ramp {
                    eta: 0.7,
                    duration: 2.0,
                },
                Segment::Dwell {
                    eta: 0.7,
                    duration: 5.0,
                },
            ],
            phase: 0.0,
            amplitude: 1.0,
        };
        let d = s.drives().unwrap();
        assert_eq!(d.len(), 3);
        // Continuity of ζ0 at both joints.
        for w in d.windows(2) {
            let (t0, a, dur) = (&w[0].0, &w[0].1, w[0].2);
            let (t1, b) = (&w[1].0, &w[1].1);
            assert!((t0 + dur - t1).abs() < 1e-12);
            assert!((a.eval(dur).0 - b.eval(0.0).0).abs() < 1e-12);
            assert!((a.eval(dur).1 - b.eval(0.0).1).abs() < 1e-12);
        }
        let e = Schedule {
            segments: vec![Segment::Ramp {
                eta: 1.0,
                duration: 1.0,
            }],
            phase: 0.0,
            amplitude: 1.0,
        }
        .drives()
        .unwrap_err();
        assert_eq!(e, ScheduleError::StartsWithRamp { segment: 0 });
        assert_eq!(
            e.to_string(),
            "segment 0: a schedule must start with a dwell"
        );
        let e = Schedule {
            segments: vec![Segment::Dwell {
                eta: 1.0,
                duration: f64::NAN,
            }],
            phase: 0.0,
            amplitude: 1.0,
        }
        .drives()
        .unwrap_err();
        assert_eq!(e, ScheduleError::BadSegment { segment: 0 });
        assert_eq!(
            e.to_string(),
            "segment 0: duration and eta must be finite and > 0"
        );
    }
}
