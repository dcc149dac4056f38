//! Amplitudes of a measured window (paper eq. 6 made robust to noise):
//! local-polynomial reconstruction, the stand-still test, and the
//! estimator's noise and bias.

use crate::identify::smooth::savgol_within;
use crate::ingest::{Quantity, Run};
use crate::stats::median;

/// (max − min)/2 over [a, b] of a signal on a uniform grid, from its local
/// polynomial reconstruction (degree 4, half-width `half` samples),
/// extremes refined by a parabola through three samples.
pub(super) fn amplitude(
    y: &[f64],
    dt: f64,
    t0: f64,
    (a, b): (f64, f64),
    half: usize,
) -> Option<f64> {
    let n = y.len();
    let idx = |t: f64| ((t - t0) / dt).round();
    let (ia, ib) = (idx(a), idx(b));
    if !(ia.is_finite() && ib.is_finite()) || ib < 0.0 || ia >= n as f64 {
        return None;
    }
    let (ia, ib) = (ia.max(0.0) as usize, (ib as usize).min(n - 1));
    if ib <= ia + 4 {
        return None;
    }
    // Smooth a slice with a margin so the window sees interior weights.
    let (sa, sb) = (ia.saturating_sub(half + 1), (ib + half + 2).min(n));
    let s = savgol_within(&y[sa..sb], dt, half, 4, 0, ia - sa..ib - sa + 1);
    let w = &s[ia - sa..=ib - sa];
    let finite = w.iter().filter(|v| v.is_finite()).count();
    if finite * 2 < w.len() {
        return None;
    }
    let refine = |k: usize, sign: f64| -> f64 {
        let v = w[k];
        if k == 0 || k + 1 >= w.len() {
            return v;
        }
        let (l, r) = (w[k - 1], w[k + 1]);
        if !(l.is_finite() && r.is_finite()) {
            return v;
        }
        let den = l - 2.0 * v + r;
        if sign * den >= 0.0 {
            return v;
        }
        let d = 0.5 * (l - r) / den;
        v - 0.25 * (l - r) * d
    };
    let (mut kmin, mut kmax) = (None::<usize>, None::<usize>);
    for (k, v) in w.iter().enumerate() {
        if !v.is_finite() {
            continue;
        }
        if kmin.is_none_or(|j| *v < w[j]) {
            kmin = Some(k);
        }
        if kmax.is_none_or(|j| *v > w[j]) {
            kmax = Some(k);
        }
    }
    let (lo, hi) = (refine(kmin?, 1.0), refine(kmax?, -1.0));
    Some(0.5 * (hi - lo))
}

/// Smoothing half-width (samples) for a drive period: 1/16 of it.
pub(super) fn half_width(period: f64, dt: f64) -> usize {
    ((period / 16.0 / dt).round() as usize).max(3)
}

/// One window's amplitude (see [`window_amplitude`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Fitted {
    /// (max − min)/2 (m); 0 where the mass stands still.
    pub(super) amp: f64,
    /// 95 % half-width of the estimator's noise (m).
    pub(super) noise95: f64,
}

/// Whether a signal stands still over [a, b] (a window of whole periods
/// `period`): the spread of its samples about a straight line (an offset
/// and a slow drift) is no more than the window's own noise gives, at 95 %.
/// The noise variance is half the mean square of differences `lag` samples
/// apart (`lag`: 1/64 of the period, at least 8 samples): that sees the
/// sensor's noise whatever its colour over a few samples (an interpolated
/// grid's noise is not white; third differences would underrate it), while
/// any motion at the drive's time scale adds its own variance to the spread
/// (a sine of amplitude c adds c²/2) and almost none to those differences.
/// The threshold 1 + 1.645·√(5/n) is the statistic's 95 % point for n
/// samples (the spread's variance 2/n and the overlapping differences'
/// about 3/n).
pub(super) fn stands_still(
    y: &[f64],
    dt: f64,
    t0: f64,
    (a, b): (f64, f64),
    period: f64,
) -> (bool, f64) {
    let n = y.len();
    let idx = |t: f64| ((t - t0) / dt).round();
    let (ia, ib) = (idx(a), idx(b));
    if !(ia.is_finite() && ib.is_finite()) || ib < 0.0 || ia >= n as f64 {
        return (false, f64::NAN);
    }
    let (ia, ib) = (ia.max(0.0) as usize, (ib as usize).min(n - 1));
    let w = &y[ia..=ib];
    let lag = ((period / dt / 64.0).round() as usize).max(8);
    if w.len() < 4 * lag {
        return (false, f64::NAN);
    }
    let (mut sx, mut sy, mut m) = (0.0, 0.0, 0usize);
    for (k, v) in w.iter().enumerate() {
        if v.is_finite() {
            sx += k as f64;
            sy += v;
            m += 1;
        }
    }
    if m < 16 || 2 * m < w.len() {
        return (false, f64::NAN);
    }
    let (mx, my) = (sx / m as f64, sy / m as f64);
    let (mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0);
    for (k, v) in w.iter().enumerate().filter(|(_, v)| v.is_finite()) {
        let (dx, dy) = (k as f64 - mx, v - my);
        sxx += dx * dx;
        sxy += dx * dy;
        syy += dy * dy;
    }
    let spread = (syy - if sxx > 0.0 { sxy * sxy / sxx } else { 0.0 }) / (m - 2) as f64;
    let (mut dd, mut nd) = (0.0, 0usize);
    for k in lag..w.len() {
        let d = w[k] - w[k - lag];
        if d.is_finite() {
            dd += d * d;
            nd += 1;
        }
    }
    if nd < 8 {
        return (false, f64::NAN);
    }
    let noise = 0.5 * dd / nd as f64;
    (
        spread <= noise * (1.0 + 1.645 * (5.0 / m as f64).sqrt()),
        noise,
    )
}

/// Replicates of the noise-bias estimate of [`window_amplitude`].
pub(super) const BIAS_REPLICATES: u64 = 16;

/// The measured amplitude over [a, b] (paper eq. 6 with the noise's bias
/// removed): (max − min)/2 of the local-polynomial reconstruction
/// ([`amplitude`], smoothing over 1/16 of `period`) less the noise's
/// extreme-value bias, or 0 where the mass stands still
/// ([`stands_still`]). The bias is what noise of the window's own level
/// adds to the half-range of the reconstruction: the mean over
/// [`BIAS_REPLICATES`] replicates of the reconstruction plus noise of that
/// level and colour ([`noise_bias`]), less the reconstruction's own half-range (a parametric
/// bootstrap: it sees the waveform, so a sharp extreme gets a small bias, a
/// small or flat one a larger one). `noise95` is the estimator's noise
/// ([`estimator_noise`]).
pub(super) fn window_amplitude(
    y: &[f64],
    dt: f64,
    t0: f64,
    window: (f64, f64),
    period: f64,
    sigma: f64,
    raw: Option<RawNoise<'_>>,
) -> Option<Fitted> {
    let half = half_width(period, dt);
    let eq6 = amplitude(y, dt, t0, window, half)?;
    let noise95 = estimator_noise(sigma, half, dt, window.1 - window.0);
    if stands_still(y, dt, t0, window, period).0 {
        return Some(Fitted { amp: 0.0, noise95 });
    }
    let amp = match noise_bias(y, dt, t0, window, half, raw) {
        Some(b) => (eq6 - b).max(0.0),
        None => eq6,
    };
    Some(Fitted { amp, noise95 })
}

/// The noise's bias of [`amplitude`] over `window` (see
/// [`window_amplitude`]). With the raw channel known (`raw`), the noise is
/// white noise of its σ at the raw sample times, interpolated onto the grid
/// as the ingest interpolates (so it has the grid noise's colour);
/// otherwise white on the grid at the window's own level: the residual of
/// the reconstruction, whose variance is σ²(1 − w₀) for white noise (w₀:
/// the smoother's centre weight).
pub(super) fn noise_bias(
    y: &[f64],
    dt: f64,
    t0: f64,
    (a, b): (f64, f64),
    half: usize,
    raw: Option<RawNoise<'_>>,
) -> Option<f64> {
    let n = y.len();
    let idx = |t: f64| ((t - t0) / dt).round();
    let (ia, ib) = (idx(a), idx(b));
    if !(ia.is_finite() && ib.is_finite()) || ib < 0.0 || ia >= n as f64 {
        return None;
    }
    let (ia, ib) = (ia.max(0.0) as usize, (ib as usize).min(n - 1));
    let (sa, sb) = (ia.saturating_sub(2 * half + 2), (ib + 2 * half + 3).min(n));
    // Smoothed where `amplitude` below reads it (the window and its
    // margin of half + 1), one sample wider each side in case its own
    // rounding of the window's ends to samples differs by one (still
    // interior weights: the slice's margin is 2·half + 2).
    let keep = (ia - sa).saturating_sub(half + 2)..(ib - sa + half + 3).min(sb - sa);
    let smooth = savgol_within(&y[sa..sb], dt, half, 4, 0, keep);
    let t_s = t0 + sa as f64 * dt;
    let h = half as i64;
    let w0 = crate::identify::smooth::savgol_weights(-h, h, 4, 0, dt)?[half];
    let (mut rr, mut nr) = (0.0, 0usize);
    for k in ia..=ib {
        let r = y[k] - smooth[k - sa];
        if r.is_finite() {
            rr += r * r;
            nr += 1;
        }
    }
    let sd = (rr / nr.max(1) as f64 / (1.0 - w0)).sqrt();
    if !(nr >= 8 && sd.is_finite() && sd > 0.0) {
        return None;
    }
    let base = amplitude(&smooth, dt, t_s, (a, b), half)?;
    let mut rng = crate::stats::Rng::with_stream(0xB1A5, ia as u64);
    let mut sum = 0.0;
    let mut z = smooth.clone();
    // The raw samples under the slice, with one interval of margin.
    let grid_t: Vec<f64> = (0..smooth.len()).map(|k| t_s + k as f64 * dt).collect();
    let raw = raw.and_then(|r| {
        let (g0, g1) = (grid_t[0], grid_t[grid_t.len() - 1]);
        let i = r.t.partition_point(|&t| t < g0 - 2.0 * r.dt);
        let j = r.t.partition_point(|&t| t <= g1 + 2.0 * r.dt);
        (j > i + 4).then_some((&r.t[i..j], r.dt, r.sigma))
    });
    let mut e = Vec::new();
    for _ in 0..BIAS_REPLICATES {
        match raw {
            Some((rt, rdt, rs)) => {
                e.clear();
                e.extend((0..rt.len()).map(|_| rs * rng.normal()));
                let g = crate::ingest::interpolate(rt, &e, rdt, &grid_t);
                for ((zk, sk), gk) in z.iter_mut().zip(&smooth).zip(&g) {
                    *zk = sk + if gk.is_finite() { *gk } else { 0.0 };
                }
            }
            None => {
                for (zk, sk) in z.iter_mut().zip(&smooth) {
                    *zk = sk + sd * rng.normal();
                }
            }
        }
        sum += amplitude(&z, dt, t_s, (a, b), half)?;
    }
    Some((sum / BIAS_REPLICATES as f64 - base).max(0.0))
}

/// White-noise σ of a smooth signal sampled densely: from the MAD of its
/// third differences (a smooth signal's third difference is O((ω·dt)³)
/// and vanishes against the noise; Var Δ³e = 20σ²).
pub(super) fn noise_level(y: &[f64]) -> f64 {
    let d3: Vec<f64> = y
        .windows(4)
        .map(|w| w[3] - 3.0 * w[2] + 3.0 * w[1] - w[0])
        .filter(|v| v.is_finite())
        .collect();
    if d3.len() < 16 {
        return f64::NAN;
    }
    let mad = median(&d3.iter().map(|v| v.abs()).collect::<Vec<_>>());
    mad / 0.6745 / 20f64.sqrt()
}

/// 95 % uncertainty (m) of (max − min)/2 of a signal with white noise σ
/// after Savitzky–Golay smoothing (degree 4, half-width `half`) over a
/// window of `win` seconds: each extreme is a maximum over about
/// win/((2·half + 1)·dt) nearly independent smoothed values, which biases
/// it by up to σ_s·√(2 ln n); plus 1.96 σ_s of scatter.
pub(super) fn estimator_noise(sigma: f64, half: usize, dt: f64, win: f64) -> f64 {
    let h = half as i64;
    let gain = crate::identify::smooth::savgol_weights(-h, h, 4, 0, dt)
        .map_or(1.0, |w| w.iter().map(|x| x * x).sum::<f64>().sqrt());
    let s = sigma * gain;
    let n = (win / ((2 * half + 1) as f64 * dt)).max(2.0);
    if s.is_finite() {
        s * ((2.0 * n.ln()).sqrt() + 1.96)
    } else {
        0.0
    }
}

/// The grid signals used for amplitudes, with their white-noise σ (m).
pub(super) struct Grid<'a> {
    pub(super) t0: f64,
    pub(super) dt: f64,
    pub(super) x1: &'a [f64],
    pub(super) x2: &'a [f64],
    pub(super) noise: (f64, f64),
    /// The raw channels' sample times and white-noise σ (m), x1 then x2:
    /// the noise-bias bootstrap draws white noise at the raw samples and
    /// interpolates it onto the grid as the ingest did, so its colour on the
    /// grid is the data's.
    pub(super) raw: [Option<RawNoise<'a>>; 2],
}

/// A raw channel's sample times, interval and white-noise σ.
#[derive(Clone, Copy)]
pub(super) struct RawNoise<'a> {
    pub(super) t: &'a [f64],
    pub(super) dt: f64,
    pub(super) sigma: f64,
}

impl<'a> Grid<'a> {
    /// The grid of a run's resampled x1 and x2 (None: no rows).
    pub(super) fn of(run: &'a Run) -> Option<Self> {
        let rs = &run.resampled;
        Some(Grid {
            t0: *rs.t.first()?,
            dt: 1.0 / rs.rate_hz,
            x1: &rs.x1,
            x2: &rs.x2,
            noise: (noise_level(&rs.x1), noise_level(&rs.x2)),
            raw: [Quantity::X1, Quantity::X2].map(|q| {
                let c = run.channel(q)?;
                let sigma = noise_level(&c.v);
                (sigma.is_finite() && sigma > 0.0 && c.rate_hz > 0.0).then_some(RawNoise {
                    t: &c.t,
                    dt: 1.0 / c.rate_hz,
                    sigma,
                })
            }),
        })
    }

    /// The grid's last time (s).
    pub(super) fn end(&self) -> f64 {
        self.t0 + self.x1.len().saturating_sub(1) as f64 * self.dt
    }

    /// The fitted amplitudes of x1 and x2 over a window of whole drive
    /// periods of length `period`.
    pub(super) fn fitted(&self, window: (f64, f64), period: f64) -> Option<(Fitted, Fitted)> {
        Some((
            window_amplitude(
                self.x1,
                self.dt,
                self.t0,
                window,
                period,
                self.noise.0,
                self.raw[0],
            )?,
            window_amplitude(
                self.x2,
                self.dt,
                self.t0,
                window,
                period,
                self.noise.1,
                self.raw[1],
            )?,
        ))
    }

    /// (A1, A2) in metres over a window of whole drive periods.
    pub(super) fn amplitudes(&self, window: (f64, f64), period: f64) -> Option<(f64, f64)> {
        self.fitted(window, period).map(|(a, b)| (a.amp, b.amp))
    }
}
