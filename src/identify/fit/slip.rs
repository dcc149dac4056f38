//! The slip samples of a log and the robust (Huber IRLS) regression of one
//! law family on them.

use super::{basis, Row, STORED_ROWS_MAX};
use crate::identify::contact::Contact;
use crate::identify::segment::Segmentation;
use crate::identify::smooth::Normal;
use crate::model::LawKind;
use crate::stats::mad_sigma;

/// One slip sample.
pub(super) struct Sample {
    /// Contact force R (N).
    pub r: f64,
    /// Slip direction sgn(ẋ2).
    pub s: f64,
    /// Slip speed |ẋ2| (m/s).
    pub u: f64,
    /// K2·x1 and K2·x2, centred (N): regressors of the position sensors'
    /// relative gain errors.
    pub k1: f64,
    /// See `k1`.
    pub k2: f64,
    /// The drive period the sample lies in.
    pub period: usize,
}

/// K2·x1 and K2·x2 centred over the log: the gain-error regressors.
pub(super) struct Gauge<'a> {
    c: &'a Contact,
    m1: f64,
    m2: f64,
}

impl<'a> Gauge<'a> {
    /// The centres of K2·x1, K2·x2 over the log `c`.
    pub fn new(c: &'a Contact) -> Self {
        let centre = |x: &[f64]| -> f64 {
            let fin: Vec<f64> = x.iter().copied().filter(|v| v.is_finite()).collect();
            fin.iter().sum::<f64>() / fin.len().max(1) as f64
        };
        Self {
            c,
            m1: centre(&c.x1),
            m2: centre(&c.x2),
        }
    }

    /// (K2·(x1 − m1), K2·(x2 − m2)) at sample `i`.
    pub fn at(&self, i: usize) -> (f64, f64) {
        let kk = self.c.k2_n_per_m;
        (kk * (self.c.x1[i] - self.m1), kk * (self.c.x2[i] - self.m2))
    }
}

/// The drive period of (fractional) sample `i`.
pub(super) fn period_of(c: &Contact, i: f64) -> usize {
    ((i * c.dt * c.drive.frequency_hz).max(0.0)) as usize
}

/// The slip samples (M2 slides, |ẋ2| above the upper hysteresis threshold,
/// away from every stick by more than one smoothing window) and their
/// sample indices.
pub(super) fn slip_samples(
    c: &Contact,
    seg: &Segmentation,
    gauge: &Gauge<'_>,
) -> (Vec<Sample>, Vec<usize>) {
    let n = c.r.len();
    let half = c.half_window;
    // Distance (samples) to the nearest stick, to keep slip samples away
    // from transitions by one smoothing window.
    let mut near = vec![usize::MAX; n];
    let mut last = None;
    for i in 0..n {
        if seg.stick[i] {
            last = Some(i);
        }
        if let Some(l) = last {
            near[i] = i - l;
        }
    }
    last = None;
    for i in (0..n).rev() {
        if seg.stick[i] {
            last = Some(i);
        }
        if let Some(l) = last {
            near[i] = near[i].min(l - i);
        }
    }
    let mut samples = Vec::new();
    let mut idx = Vec::new();
    for i in 0..n {
        let (r, v) = (c.r[i], c.v2_smooth[i]);
        if seg.stick[i] || !r.is_finite() || !v.is_finite() || v.abs() <= seg.hi || near[i] <= half
        {
            continue;
        }
        let (k1, k2) = gauge.at(i);
        if !(k1.is_finite() && k2.is_finite()) {
            continue;
        }
        samples.push(Sample {
            r,
            s: v.signum(),
            u: v.abs(),
            k1,
            k2,
            period: period_of(c, i as f64),
        });
        idx.push(i);
    }
    (samples, idx)
}

/// Σ w·(R − basis·coef)² over the samples (weights `w`, or 1 where None).
pub(super) fn rss(
    samples: &[Sample],
    coef: &[f64],
    w: Option<&[f64]>,
    kind: LawKind,
    vs: f64,
) -> f64 {
    samples
        .iter()
        .enumerate()
        .map(|(k, smp)| {
            let x: Row = basis(kind, smp, vs);
            let wi = w.map_or(1.0, |w| w[k]);
            wi * (smp.r - x.iter().zip(coef).map(|(a, b)| a * b).sum::<f64>()).powi(2)
        })
        .sum()
}

/// [`rss`] without weights over rows already evaluated (`rows[k]` is
/// sample k's): the same sum, bit for bit.
pub(super) fn rss_of_rows(samples: &[Sample], rows: &[Row], coef: &[f64]) -> f64 {
    samples
        .iter()
        .zip(rows)
        .map(|(smp, x)| (smp.r - x.iter().zip(coef).map(|(a, b)| a * b).sum::<f64>()).powi(2))
        .sum()
}

/// Robust (Huber IRLS) fit of one slip model; returns coefficients, final
/// weights and residuals.
pub(super) fn irls(
    samples: &[Sample],
    kind: LawKind,
    vs: f64,
) -> Option<(Vec<f64>, Vec<f64>, Vec<f64>)> {
    let mut w = vec![1.0; samples.len()];
    let mut coef = Vec::new();
    let mut res = vec![0.0; samples.len()];
    let mut prev: Option<Vec<f64>> = None;
    // The regressors, evaluated once and kept up to `STORED_ROWS_MAX`
    // samples; beyond, evaluated where they are used (a row per slip
    // sample would be the largest array of a long log's fit).
    let stored: Option<Vec<Row>> = (samples.len() <= STORED_ROWS_MAX)
        .then(|| samples.iter().map(|smp| basis(kind, smp, vs)).collect());
    let row = |k: usize| -> Row {
        match &stored {
            Some(rows) => rows[k],
            None => basis(kind, &samples[k], vs),
        }
    };
    let p = samples.first().map_or(0, |smp| basis(kind, smp, vs).len());
    for _ in 0..8 {
        let mut ne = Normal::new(p);
        for (k, (smp, wi)) in samples.iter().zip(&w).enumerate() {
            ne.add(&row(k), smp.r, *wi);
        }
        coef = ne.solve()?;
        // Converged: the weights would not change the fit any more.
        let done = prev.as_ref().is_some_and(|q: &Vec<f64>| {
            q.iter()
                .zip(&coef)
                .all(|(a, b)| (a - b).abs() <= 1e-9 * (1.0 + b.abs()))
        });
        prev = Some(coef.clone());
        for (k, (rk, smp)) in res.iter_mut().zip(samples).enumerate() {
            let x = row(k);
            *rk = smp.r - x.iter().zip(&coef).map(|(a, b)| a * b).sum::<f64>();
        }
        let sigma = mad_sigma(&res).max(1e-12);
        let c = 1.345 * sigma;
        if done {
            break;
        }
        for (wi, r) in w.iter_mut().zip(&res) {
            *wi = if r.abs() <= c { 1.0 } else { c / r.abs() };
        }
    }
    Some((coef, w, res))
}

/// Integrated autocorrelation time of residuals over contiguous sample runs
/// (`idx`: each residual's sample index).
pub(super) fn tau_int(res: &[f64], idx: &[usize]) -> f64 {
    crate::identify::smooth::tau_int(res, 2000, 10, |k, lag| idx[k + lag] == idx[k] + lag)
}
