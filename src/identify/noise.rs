//! Sensor noise of a position record, measured from the record itself.
//!
//! The adequacy verdict compares residuals with the sensor noise, so the
//! noise must be measured without the model. The classical estimate, the
//! robust spread of second differences of neighbouring samples, is right
//! only for white noise. Two things make real records' noise correlated
//! between neighbours:
//!
//! * **The common time base.** A channel whose samples do not fall on the
//!   grid is interpolated linearly: y_i = (1 − w)·x_j + w·x_{j+1}. Its
//!   variance is ((1 − w)² + w²)·σ², but its second differences have
//!   variance ((1 − w)² + (3w − 2)² + (1 − 3w)² + w²)·σ², which falls from
//!   6σ² (w = 0) to σ² (w = ½): the classical estimate then reads
//!   σ/√6 where the record's noise is σ/√2, and a law that leaves exactly
//!   the noise shows a residual of up to √3 ≈ 1.73 "noise units"
//!   (measured on synth logs: 1.0–1.7, matching the offsets' w).
//! * **Sensor filters.** Noise that passes a sensor's low-pass filter is
//!   correlated over the filter's time constant, which differences of
//!   neighbours do not see.
//!
//! [`position_noise`] therefore takes fourth differences
//! x(i − 2h) − 4x(i − h) + 6x(i) − 4x(i + h) + x(i + 2h) (variance 70·C(0)
//! minus terms of the autocovariance at lags h…4h) at growing lags h,
//! robustly (MAD), and stops at the first plateau: once the lag is past the
//! noise's correlation length the estimate no longer grows. Fourth
//! differences leave a smooth motion's contribution at (ω·h·dt)⁴ of its
//! amplitude, so lags up to a small fraction of the drive period stay
//! clear of the signal. For white noise on the grid the plateau is reached
//! at once (the same value as the classical estimate, with the constant of
//! fourth differences).

use crate::stats::mad_sigma;
use std::f64::consts::PI;

/// Lags tried (in samples), each about √2 times the one before.
const LAGS: [usize; 10] = [1, 2, 3, 4, 6, 8, 11, 16, 23, 32];

/// A lag whose estimate grows by less than this factor over the one
/// before is on the plateau.
const PLATEAU: f64 = 1.05;

/// Variance of a fourth difference of white noise over its variance
/// (1 + 16 + 36 + 16 + 1).
const FOURTH_DIFF_VAR: f64 = 70.0;

/// Noise (1σ) of one position record at lag `h`: the MAD of its fourth
/// differences over √70 (NaN samples skipped; NaN when fewer than 16
/// differences are finite).
pub fn fourth_difference_noise(x: &[f64], h: usize) -> f64 {
    fourth_difference_noise_clear(x, h, None)
}

/// [`fourth_difference_noise`] over the differences whose whole span
/// (i − 2h … i + 2h) keeps `margin` samples clear of every event, where
/// `clear[i]` is the distance (samples) from sample i to the nearest event.
fn fourth_difference_noise_clear(x: &[f64], h: usize, clear: Option<(&[usize], usize)>) -> f64 {
    let h = h.max(1);
    if x.len() <= 4 * h {
        return f64::NAN;
    }
    let d: Vec<f64> = (2 * h..x.len() - 2 * h)
        .filter(|&i| clear.is_none_or(|(c, m)| c[i] > 2 * h + m))
        .map(|i| x[i - 2 * h] - 4.0 * x[i - h] + 6.0 * x[i] - 4.0 * x[i + h] + x[i + 2 * h])
        .filter(|v| v.is_finite())
        .collect();
    if d.len() < 16 {
        return f64::NAN;
    }
    mad_sigma(&d) / FOURTH_DIFF_VAR.sqrt()
}

/// What [`position_noise`] measured.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NoiseEstimate {
    /// The noise (1σ, the record's unit).
    pub sigma: f64,
    /// The lag (samples) at which the estimate reached its plateau.
    pub lag: usize,
    /// The estimate at lag 1 (what differences of neighbours see).
    pub sigma_lag1: f64,
}

/// The noise (1σ) of a position record sampled `samples_per_period` times
/// per drive period: the fourth-difference estimate at the first lag
/// where it stops growing (see the module documentation). Lags are kept to
/// at most a sixteenth of a period (at least 2), so the motion adds at most
/// (2π/16)⁴ ≈ 2 % of its amplitude to a difference before the MAD, which
/// ignores the few samples next to a stick or slip event. `None` when the
/// record has too few finite samples, or shows no noise (the estimate
/// grows like the motion's share up to the last lag).
pub fn position_noise(x: &[f64], samples_per_period: f64) -> Option<NoiseEstimate> {
    position_noise_between_events(x, samples_per_period, &[], 0)
}

/// [`position_noise`] from the differences that keep `margin` samples
/// clear of every event in `events` (sample indices, any order): a
/// friction force that jumps (stick, breakaway, reversal in slip) puts a
/// kink into the acceleration, and a fourth difference spanning it sees
/// J·(h·dt)² for a jump J, far above the noise at the longer lags.
pub fn position_noise_between_events(
    x: &[f64],
    samples_per_period: f64,
    events: &[usize],
    margin: usize,
) -> Option<NoiseEstimate> {
    let clear = distance_to_events(x.len(), events);
    let clear = (!events.is_empty()).then_some((clear.as_slice(), margin));
    // The motion's share of a fourth difference at lag h is about
    // amp·(2π·h/period)⁴: lags keep it below a quarter of the noise's
    // share (√70·σ, σ at least the lag-1 estimate), which adds at most
    // 3 % in quadrature.
    let first = fourth_difference_noise_clear(x, 1, clear);
    let amp = half_range(x);
    let signal_lag = if first > 0.0 && amp > 0.0 {
        samples_per_period / (2.0 * PI) * (0.25 * FOURTH_DIFF_VAR.sqrt() * first / amp).powf(0.25)
    } else {
        f64::INFINITY
    };
    let max_lag = ((samples_per_period / 16.0).min(signal_lag).floor() as usize).max(2);
    let mut prev: Option<(usize, f64)> = None;
    for &h in LAGS.iter().filter(|&&h| h <= max_lag) {
        let s = if h == 1 {
            first
        } else {
            fourth_difference_noise_clear(x, h, clear)
        };
        if !s.is_finite() {
            break;
        }
        if let Some((_, p)) = prev {
            if s <= PLATEAU * p {
                return Some(NoiseEstimate {
                    sigma: s.max(p),
                    lag: h,
                    sigma_lag1: first,
                });
            }
        }
        prev = Some((h, s));
    }
    // No plateau within the lags the motion allows. Where the estimate
    // still grew like the motion's share (×(√2)⁴ = 4 per step of the lag,
    // against at most about 1.5 for filtered noise), the record shows no
    // noise at all (a noise-free or synthetic record): nothing to measure.
    // Otherwise the largest lag's estimate, a lower bound on the noise.
    let last_growth = match (
        prev,
        LAGS.iter().position(|&h| Some(h) == prev.map(|p| p.0)),
    ) {
        (Some((_, s)), Some(k)) if k > 0 => {
            s / fourth_difference_noise_clear(x, LAGS[k - 1], clear)
        }
        _ => 1.0,
    };
    if last_growth > MOTION_GROWTH {
        return None;
    }
    prev.map(|(lag, sigma)| NoiseEstimate {
        sigma,
        lag,
        sigma_lag1: first,
    })
}

/// Growth of the estimate from one lag to the next beyond which the
/// motion, not noise, is being measured (the motion's share grows by
/// about 4, noise's by at most about 1.5 per step).
const MOTION_GROWTH: f64 = 2.5;

/// Half the range between the 1 % and 99 % quantiles of the finite samples.
fn half_range(x: &[f64]) -> f64 {
    let mut v: Vec<f64> = x.iter().copied().filter(|v| v.is_finite()).collect();
    if v.len() < 2 {
        return 0.0;
    }
    v.sort_by(f64::total_cmp);
    let q = |p: f64| v[((v.len() - 1) as f64 * p).round() as usize];
    0.5 * (q(0.99) - q(0.01))
}

/// Per sample, the distance (samples) to the nearest of `events`
/// (`usize::MAX` without events).
fn distance_to_events(n: usize, events: &[usize]) -> Vec<usize> {
    let mut d = vec![usize::MAX; n];
    for &e in events.iter().filter(|&&e| e < n) {
        d[e] = 0;
    }
    for i in 1..n {
        d[i] = d[i].min(d[i - 1].saturating_add(1));
    }
    for i in (0..n.saturating_sub(1)).rev() {
        d[i] = d[i].min(d[i + 1].saturating_add(1));
    }
    d
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand_core::{RngCore, SeedableRng};
    use rand_xoshiro::Xoshiro256PlusPlus;

    fn gauss(rng: &mut Xoshiro256PlusPlus) -> f64 {
        // Box–Muller from two uniforms in (0, 1].
        let u =
            |r: &mut Xoshiro256PlusPlus| ((r.next_u64() >> 11) as f64 + 1.0) / (1u64 << 53) as f64;
        let (a, b) = (u(rng), u(rng));
        (-2.0 * a.ln()).sqrt() * (2.0 * std::f64::consts::PI * b).cos()
    }

    /// A 2 Hz motion of 2 mm sampled at 1 kHz with noise `noise[i]`.
    fn record(noise: &[f64]) -> Vec<f64> {
        noise
            .iter()
            .enumerate()
            .map(|(i, n)| 2e-3 * (2.0 * std::f64::consts::PI * 2.0 * i as f64 * 1e-3).sin() + n)
            .collect()
    }

    fn white(n: usize, sigma: f64, seed: u64) -> Vec<f64> {
        let mut r = Xoshiro256PlusPlus::seed_from_u64(seed);
        (0..n).map(|_| sigma * gauss(&mut r)).collect()
    }

    #[test]
    fn white_noise_is_measured_at_once() {
        let x = record(&white(20_000, 3e-6, 1));
        let e = position_noise(&x, 500.0).unwrap();
        assert!((e.sigma / 3e-6 - 1.0).abs() < 0.04, "{e:?}");
        assert!(e.lag <= 3, "{e:?}");
    }

    #[test]
    fn interpolated_noise_is_the_grid_noise_not_the_neighbours() {
        // Linear interpolation half-way between samples: the grid noise is
        // σ/√2, neighbour differences see σ/√6 (module doc).
        let raw = white(20_001, 3e-6, 2);
        let y: Vec<f64> = (0..20_000).map(|i| 0.5 * (raw[i] + raw[i + 1])).collect();
        let x = record(&y);
        let e = position_noise(&x, 500.0).unwrap();
        let want = 3e-6 / 2f64.sqrt();
        assert!((e.sigma / want - 1.0).abs() < 0.05, "{e:?} want {want}");
        // Neighbours see σ/√10 here: the half-sums' fourth differences
        // have coefficients ½·(1, −3, 2, 2, −3, 1), squares summing to 7
        // against 70 for white noise.
        let lag1 = 3e-6 / 10f64.sqrt();
        assert!((e.sigma_lag1 / lag1 - 1.0).abs() < 0.1, "{e:?}");
    }

    #[test]
    fn filtered_noise_reaches_its_plateau() {
        // First-order low-pass with a time constant of 3 samples, scaled
        // to unit variance afterwards: the record's noise is 3 µm.
        let w = white(40_000, 1.0, 3);
        let a = (-1.0f64 / 3.0).exp();
        let mut y = vec![0.0; w.len()];
        for i in 1..w.len() {
            y[i] = a * y[i - 1] + (1.0 - a) * w[i];
        }
        let y = &y[1000..];
        let sd = (y.iter().map(|v| v * v).sum::<f64>() / y.len() as f64).sqrt();
        let n: Vec<f64> = y.iter().map(|v| 3e-6 * v / sd).collect();
        let x = record(&n);
        let e = position_noise(&x, 500.0).unwrap();
        assert!(e.sigma / 3e-6 > 0.9 && e.sigma / 3e-6 < 1.05, "{e:?}");
        assert!(e.sigma_lag1 / 3e-6 < 0.5, "{e:?}");
    }

    #[test]
    fn a_noise_free_record_has_no_noise_to_measure() {
        assert!(position_noise(&record(&vec![0.0; 20_000]), 500.0).is_none());
    }

    #[test]
    fn too_short_is_none() {
        assert!(position_noise(&[1.0; 10], 500.0).is_none());
    }
}
