//! Stick and slip from the positions as well as the velocity (issue 30).
//!
//! The segmentation reads the velocity channel. A velocity transducer whose
//! zero drifts, or that is otherwise broken, can make a sliding mass look
//! stuck (or a sticking one look as if it never stopped). The position x2
//! says what happened independently: it moves far beyond its noise when M2
//! slides, and it is flat (relative to the motion of x1) while M2 sticks.
//! This module compares the velocity's verdict with the one the derivative
//! of x2 gives (the same segmentation on the Savitzky–Golay derivative of
//! x2), and names a contradiction:
//!
//! * the velocity says **stuck** (or slid in fewer than 20 samples) while
//!   x2 ranges over more than [`MOVES_FACTOR`] times its noise and the
//!   derivative of x2 shows slip;
//! * the velocity says **never sticks** while the derivative of x2 shows at
//!   least two stick phases.
//!
//! The caller then distrusts the velocity channel and identifies from x2.

use super::segment::{segment, Segmentation};
use super::smooth::savgol;
use super::Contact;
use crate::stats::{mad_sigma, quantile};

/// x2 moves when its smoothed range exceeds this many noise σ.
pub const MOVES_FACTOR: f64 = 20.0;

/// What the positions say that the velocity's segmentation contradicts.
#[derive(Debug, Clone, PartialEq)]
pub struct Contradiction {
    /// In words, with the numbers.
    pub what: String,
}

/// Range of the smoothed x2 (1 % to 99 % quantiles) and x2's noise σ
/// (second differences).
pub(super) fn range_and_noise(x2: &[f64], dt: f64, half: usize) -> (f64, f64) {
    let s = savgol(x2, dt, half, 3, 0);
    let range = quantile(&s, 0.99) - quantile(&s, 0.01);
    let d2: Vec<f64> = x2
        .windows(3)
        .map(|w| w[2] - 2.0 * w[1] + w[0])
        .filter(|v| v.is_finite())
        .collect();
    (range, mad_sigma(&d2) / 6f64.sqrt())
}

/// Compares the velocity's segmentation `seg` of `c` with what x2 shows;
/// `degree`: the smoothing degree of the segmentation.
pub fn check(c: &Contact, seg: &Segmentation, degree: usize) -> Option<Contradiction> {
    let says_stuck = seg.stuck() || seg.slip_samples < 20;
    let says_never = seg.never_sticks();
    if !says_stuck && !says_never {
        return None;
    }
    let (dt, half) = (c.dt, c.half_window);
    let (range, noise) = range_and_noise(&c.x2, dt, half);
    let dx2 = savgol(&c.x2, dt, half, 3, 1);
    let dx2_s = savgol(&dx2, dt, half, degree, 0);
    let by_x2 = segment(&dx2, &dx2_s, None, half, degree);
    if says_stuck {
        let moves = range.is_finite() && noise.is_finite() && range > MOVES_FACTOR * noise;
        let slid = !by_x2.stuck() && by_x2.slip_samples >= 20;
        if moves && slid {
            let n = by_x2.stick.len().max(1);
            return Some(Contradiction {
                what: format!(
                    "the velocity channel says M2 is stuck (slid in {} samples), but x2 moved {:.3} mm ({:.0}× its noise of {:.1} µm) and slid in {:.0} % of the log by its derivative",
                    seg.slip_samples,
                    range * 1e3,
                    range / noise,
                    noise * 1e6,
                    100.0 * by_x2.slip_samples as f64 / n as f64
                ),
            });
        }
    } else if by_x2.sticks.len() >= 2 {
        let stuck: usize = by_x2.sticks.iter().map(|(s, e)| e - s).sum();
        return Some(Contradiction {
            what: format!(
                "the velocity channel says M2 never sticks, but x2 is flat in {} stretches ({:.1} % of the log)",
                by_x2.sticks.len(),
                100.0 * stuck as f64 / by_x2.stick.len().max(1) as f64
            ),
        });
    }
    None
}
