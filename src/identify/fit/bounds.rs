//! What the transitions say about Rs: the breakaway observations of a log
//! that sticks, the lower bound of a stuck log, and the reversal upper
//! bound of a log that never sticks.

use super::offset_at;
use super::slip::{period_of, Gauge};
use crate::identify::contact::Contact;
use crate::identify::segment::Segmentation;
use crate::identify::smooth::{savgol, Normal};
use crate::stats::{mad_sigma, quantile};

/// One breakaway: direction·passive force (bias included) and its period.
pub(super) struct Brk {
    /// direction · passive force at the breakaway (N).
    pub f: f64,
    /// K2·x1 there (centred, N).
    pub k1: f64,
    /// K2·x2 there (centred, N).
    pub k2: f64,
    /// Slip direction after the breakaway (±1).
    pub dir: f64,
    /// The drive period it lies in.
    pub period: usize,
}

/// Passive force at fractional sample `at` from a line fitted to `p[a..=b]`.
fn line_at(p: &[f64], a: usize, b: usize, at: f64) -> Option<(f64, f64)> {
    let mut ne = Normal::new(2);
    for (i, x) in p.iter().enumerate().take(b + 1).skip(a) {
        if x.is_finite() {
            ne.add(&[1.0, i as f64 - at], *x, 1.0);
        }
    }
    if ne.n < 3 {
        return None;
    }
    let c = ne.solve()?;
    Some((c[0], c[1]))
}

/// A stuck log's lower bound on Rs: half the peak-to-peak smoothed passive
/// force, minus two noise levels so noise cannot inflate it.
pub(super) fn stuck_lower_bound(c: &Contact) -> f64 {
    held_force_lower_bound(&c.passive(), c.dt, c.half_window)
}

/// A lower bound on the force a stuck contact held, from the record of
/// that force: half the peak-to-peak of its smoothed record (a bias
/// cancels), minus two of the smoothed record's noise levels so noise
/// cannot inflate it. (Also the bound of a slider held behind a compliant
/// contact: [`crate::identify::pads::slider_held`].)
pub(crate) fn held_force_lower_bound(force: &[f64], dt: f64, half: usize) -> f64 {
    let p = savgol(force, dt, half, 3, 0);
    let noise = mad_sigma(&force.iter().zip(&p).map(|(a, b)| a - b).collect::<Vec<_>>());
    let h = half as f64;
    let noise_s = noise / (2.0 * h + 1.0).sqrt();
    let hi = quantile(&p, 1.0);
    let lo = quantile(&p, 0.0);
    ((hi - lo) / 2.0 - 2.0 * noise_s).max(0.0)
}

/// The breakaway observations: at each located stick → slip transition, the
/// passive force from a line over the last smoothing window of the stick,
/// evaluated at the breakaway time, in the slip's direction.
pub(super) fn breakaways(c: &Contact, seg: &Segmentation, gauge: &Gauge<'_>) -> Vec<Brk> {
    let n = c.r.len();
    let half = c.half_window;
    let passive = c.passive();
    let mut brks = Vec::new();
    for b in &seg.breakaways {
        let end = b.at.floor() as usize;
        let start = b.stick.0.max(end.saturating_sub(2 * half + 1));
        if end <= start + 3 {
            continue;
        }
        let at = (b.at.round().max(0.0) as usize).min(n - 1);
        let (k1, k2) = gauge.at(at);
        if !(k1.is_finite() && k2.is_finite()) {
            continue;
        }
        if let Some((p, _)) = line_at(&passive, start, end.min(n - 1), b.at) {
            brks.push(Brk {
                f: b.direction * p,
                k1,
                k2,
                dir: b.direction,
                period: period_of(c, b.at),
            });
        }
    }
    brks
}

/// A never-sticking log's upper bound on Rs: the least passive force (bias
/// and gain corrections of the slip model `coef` removed, plus two timing
/// and noise σ) at a velocity reversal, where the mass did not stick.
pub(super) fn reversal_upper_bound(
    c: &Contact,
    seg: &Segmentation,
    gauge: &Gauge<'_>,
    coef: &[f64],
) -> Option<f64> {
    let n = c.r.len();
    let half = c.half_window;
    let passive = c.passive();
    let mut best = f64::INFINITY;
    for rv in &seg.reversals {
        let i = rv.at.round() as usize;
        let (a, b) = (i.saturating_sub(half), (i + half).min(n - 1));
        let Some((p, dp)) = line_at(&passive, a, b, rv.at) else {
            continue;
        };
        let acc = c.a2[i.min(n - 1)].abs();
        // Timing uncertainty of the crossing: σ_v / |a|, times dP/dt.
        let sig_t = if acc > 0.0 {
            seg.noise_v / acc / c.dt
        } else {
            0.0
        };
        let sig = (dp * sig_t).abs() + mad_sigma(&passive[a..=b]) / ((b - a + 1) as f64).sqrt();
        let (k1, k2) = gauge.at(i.min(n - 1));
        let bound = rv.direction * (p - offset_at(coef, k1, k2)) + 2.0 * sig;
        if bound.is_finite() {
            best = best.min(bound);
        }
    }
    best.is_finite().then_some(best)
}
