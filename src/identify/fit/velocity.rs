//! The velocity scale v_s of a family that has one (the Stribeck velocity)
//! by variable projection: for a given v_s the law is linear in its
//! coefficients (for the Stribeck type b, Rd, Rs − Rd, a), so v_s is found
//! by a coarse scan and a golden-section search over log v_s of the
//! profiled residual sum.

use super::slip::{rss, rss_of_rows, Sample};
use super::{basis, STORED_ROWS_MAX};
use crate::identify::smooth::Normal;
use crate::model::LawKind;
use crate::stats::golden_section;
use std::cell::RefCell;

/// The velocity scale (m/s) of family `kind` the slip samples resolve, if
/// any: None where the speeds span less than a factor 4 above `u_min` (the
/// hysteresis threshold), or where the optimum sits at the scanned range's
/// edge or below half the slowest slip sample's speed (not a peak the data
/// resolve).
pub(super) fn velocity_scale(kind: LawKind, samples: &[Sample], u_min: f64) -> Option<f64> {
    let umax = samples.iter().map(|s| s.u).fold(0.0, f64::max);
    // The slowest slip sample: a scale below it is an extrapolation (on
    // `char_N7.2.mcap` forced to Stribeck, v_s 0.68 mm/s under slip
    // samples of several mm/s gave Rs − Rd = 6.4e7 N from a column of
    // values about 1e-8).
    let uslow = samples.iter().map(|s| s.u).fold(f64::INFINITY, f64::min);
    let umin = u_min.max(1e-9);
    if umax <= 4.0 * umin {
        return None;
    }
    // The regressors at one v_s: the normal equations, then the residual
    // sum over the same rows (kept between the two passes up to
    // `STORED_ROWS_MAX` samples, evaluated again beyond). The entries of
    // the normal equations that do not involve the scale's column are the
    // same at every v_s: accumulated once (the same sums, bit for bit).
    let p = basis(kind, &samples[0], 1.0).len();
    let col = kind.family().scale_column();
    let fixed = col.map(|c| {
        let mut ne = Normal::new(p);
        for smp in samples {
            ne.add_except(c, &basis(kind, smp, 1.0), smp.r, 1.0);
        }
        ne
    });
    let store = samples.len() <= STORED_ROWS_MAX;
    let rows = RefCell::new(Vec::with_capacity(if store { samples.len() } else { 0 }));
    let cost = |lv: f64| {
        let vs = lv.exp();
        let mut rows = rows.borrow_mut();
        rows.clear();
        let mut ne = fixed.clone().unwrap_or_else(|| Normal::new(p));
        for smp in samples {
            let x = basis(kind, smp, vs);
            match col {
                Some(c) => ne.add_column(c, &x, smp.r, 1.0),
                None => ne.add(&x, smp.r, 1.0),
            }
            if store {
                rows.push(x);
            }
        }
        match ne.solve() {
            Some(c) if store => rss_of_rows(samples, &rows, &c),
            Some(c) => rss(samples, &c, None, kind, vs),
            None => f64::INFINITY,
        }
    };
    let (a, b) = ((0.5 * umin).ln(), (0.5 * umax).ln());
    // Coarse scan, then golden section around the best point.
    let m = 24;
    let mut best = (a, f64::INFINITY);
    for k in 0..=m {
        let lv = a + (b - a) * k as f64 / m as f64;
        let f = cost(lv);
        if f < best.1 {
            best = (lv, f);
        }
    }
    let step = (b - a) / m as f64;
    let lv = golden_section((best.0 - step).max(a), (best.0 + step).min(b), 30, cost);
    // At the bounds it is not a scale the data resolve.
    (lv > a + 0.5 * step && lv < b - 0.5 * step && lv.exp() >= 0.5 * uslow).then(|| lv.exp())
}
