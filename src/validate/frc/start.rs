//! The rig's state at each step's start as measured (ζ1, ζ1', ζ2, ζ2'
//! from local cubic fits of x1 and x2 over ±1/20 of a drive period, the
//! sensor offsets from the steps where M2 slides), with standard
//! uncertainties: where the sensitivity assessment
//! ([`crate::validate::sensitive`]) starts its re-runs.

use super::{MeasuredFrc, SweepKind};
use crate::ingest::Run;
use crate::stats::sample_sd;

/// The rig's state at a step's start as measured, dimensionless
/// (ζ = x/A, ζ' = ẋ/(A·ω_ref); A the sweep's measured drive amplitude),
/// with standard uncertainties.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct StartState {
    /// When (s from log start): the start of the hold that holds the
    /// step's window (after the frequency ramp into it).
    pub t_s: f64,
    /// `[ζ1, ζ1', ζ2, ζ2']`.
    pub x: [f64; 4],
    /// Their standard uncertainties (the fit's noise and the offsets').
    pub sigma: [f64; 4],
    /// M2 measured at rest (ζ2' within 2σ of 0): the re-runs start stuck.
    pub stuck: bool,
}

/// Least-squares cubic through (s, y) with s scaled by `h`: value and
/// slope at s = 0 with their standard errors (noise from the residuals,
/// at least `floor`). None with fewer than 8 samples.
fn cubic_at_zero(s: &[f64], y: &[f64], h: f64, floor: f64) -> Option<(f64, f64, f64, f64)> {
    if s.len() < 8 {
        return None;
    }
    let mut m = vec![vec![0.0f64; 4]; 4];
    let mut r = vec![0.0f64; 4];
    for (&si, &yi) in s.iter().zip(y) {
        let u = si / h;
        let row = [1.0, u, u * u, u * u * u];
        for p in 0..4 {
            for q in 0..4 {
                m[p][q] += row[p] * row[q];
            }
            r[p] += row[p] * yi;
        }
    }
    let c = crate::identify::smooth::solve_small(&m, &r)?;
    let rss: f64 = s
        .iter()
        .zip(y)
        .map(|(&si, &yi)| {
            let u = si / h;
            let f = c[0] + u * (c[1] + u * (c[2] + u * c[3]));
            (yi - f).powi(2)
        })
        .sum();
    let sigma = (rss / (s.len() - 4) as f64).sqrt().max(floor);
    // Variances of c0 and c1: the diagonal of (XᵀX)⁻¹ times σ².
    let e0 = crate::identify::smooth::solve_small(&m, &[1.0, 0.0, 0.0, 0.0])?;
    let e1 = crate::identify::smooth::solve_small(&m, &[0.0, 1.0, 0.0, 0.0])?;
    Some((
        c[0],
        sigma * e0[0].max(0.0).sqrt(),
        c[1] / h,
        sigma * e1[1].max(0.0).sqrt() / h,
    ))
}

/// Mean of the finite values of `x` over the grid times in [a, b).
fn mean_over(t: &[f64], x: &[f64], (a, b): (f64, f64)) -> Option<f64> {
    let i = t.partition_point(|&v| v < a);
    let j = t.partition_point(|&v| v < b);
    let (s, n) = x[i..j.max(i)]
        .iter()
        .filter(|v| v.is_finite())
        .fold((0.0, 0usize), |(s, n), v| (s + v, n + 1));
    (n > 0).then(|| s / n as f64)
}

/// Median and standard error of the median (1.2533·sd/√n) of `v`.
fn median_se(v: Vec<f64>) -> Option<(f64, f64)> {
    if v.is_empty() {
        return None;
    }
    let se = 1.2533 * sample_sd(&v) / (v.len() as f64).sqrt();
    Some((crate::stats::median(&v), se))
}

/// The measured state at each step's start (`None` for a continuous sweep,
/// or where the log has too few samples there).
///
/// The sensors' offsets are the median of the window means of x1 and x2
/// over the steps where M2 clearly slides (A2 above three times its own
/// uncertainty; a symmetric periodic motion is centred on the rest
/// position), or over every step where fewer than three slide.
pub fn start_states(run: &Run, frc: &MeasuredFrc) -> Vec<Option<StartState>> {
    let n = frc.points.len();
    if frc.kind != SweepKind::Stepped || n == 0 {
        return vec![None; n];
    }
    let rs = &run.resampled;
    let (a, w) = (frc.drive_amplitude_m, frc.omega_ref_rad_s);
    let sliding: Vec<usize> = (0..n)
        .filter(|&i| frc.points[i].amplitude2 > 3.0 * frc.points[i].amplitude2_u)
        .collect();
    let used: Vec<usize> = if sliding.len() >= 3 {
        sliding
    } else {
        (0..n).collect()
    };
    let offset = |x: &[f64]| {
        median_se(
            used.iter()
                .filter_map(|&i| mean_over(&rs.t, x, frc.points[i].window_s))
                .collect(),
        )
    };
    let (Some((c1, u1)), Some((c2, u2))) = (offset(&rs.x1), offset(&rs.x2)) else {
        return vec![None; n];
    };
    let floor = (
        if frc.noise_m.0.is_finite() {
            frc.noise_m.0
        } else {
            0.0
        },
        if frc.noise_m.1.is_finite() {
            frc.noise_m.1
        } else {
            0.0
        },
    );
    frc.points
        .iter()
        .map(|p| {
            let ts = frc
                .plan
                .iter()
                .rev()
                .find(|g| g.start_s <= p.window_s.0)
                .filter(|g| g.f_start_hz == g.f_end_hz)
                .map_or(p.t_start_s, |g| g.start_s.max(p.t_start_s));
            let half = 0.05 / p.frequency_hz;
            let i = rs.t.partition_point(|&v| v < ts - half);
            let j = rs.t.partition_point(|&v| v <= ts + half);
            let fit = |x: &[f64], floor: f64| {
                let (s, y): (Vec<f64>, Vec<f64>) = (i..j)
                    .filter(|&k| x[k].is_finite())
                    .map(|k| (rs.t[k] - ts, x[k]))
                    .unzip();
                cubic_at_zero(&s, &y, half, floor)
            };
            let (x1, sx1, v1, sv1) = fit(&rs.x1, floor.0)?;
            let (x2, sx2, v2, sv2) = fit(&rs.x2, floor.1)?;
            let x = [(x1 - c1) / a, v1 / (a * w), (x2 - c2) / a, v2 / (a * w)];
            let sigma = [
                sx1.hypot(u1) / a,
                sv1 / (a * w),
                sx2.hypot(u2) / a,
                sv2 / (a * w),
            ];
            x.iter()
                .chain(&sigma)
                .all(|v| v.is_finite())
                .then_some(StartState {
                    t_s: ts,
                    x,
                    sigma,
                    stuck: x[3].abs() <= 2.0 * sigma[3],
                })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cubic_fit_gives_value_and_slope_at_zero() {
        // y = 2 − 3s + 0.5s² + 4s³ on ±0.1 (exact: the errors are the floor's).
        let s: Vec<f64> = (-20..=20).map(|k| k as f64 * 0.005).collect();
        let y: Vec<f64> = s
            .iter()
            .map(|&t| 2.0 - 3.0 * t + 0.5 * t * t + 4.0 * t * t * t)
            .collect();
        let (v, sv, d, sd) = cubic_at_zero(&s, &y, 0.1, 1e-6).unwrap();
        assert!(
            (v - 2.0).abs() < 1e-12 && (d + 3.0).abs() < 1e-10,
            "{v} {d}"
        );
        // σ = the floor: the value's error about σ/√n·1.4, the slope's larger.
        assert!(sv > 1e-7 && sv < 1e-6 && sd > sv, "{sv} {sd}");
        assert!(cubic_at_zero(&s[..7], &y[..7], 0.1, 0.0).is_none());
    }
}
