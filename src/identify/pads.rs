//! Real pads, the cheap screen: evidence in the equation-error data, before
//! any richer model is refined, for a pad whose friction depends on the
//! sliding direction and for a compliant contact (pre-sliding, the Jenkins
//! element of `docs/real-pads.md`).
//!
//! * **Direction** ([`direction_screen`]): the equation-error fit removes
//!   the force bias by the symmetry of the slip levels (+Rd forward, −Rd
//!   backward), so its per-breakaway forces are the static thresholds in
//!   the gauge "equal dynamic levels". The difference of their means by
//!   direction is the drop asymmetry Δ = (Rs⁺ − Rd⁺) − (Rs⁻ − Rd⁻), the one
//!   combination of direction-dependent levels that unknown sensor zero
//!   offsets leave identifiable (a common shift of one direction's levels
//!   is a constant force on M2, i.e. an x2 offset: `docs/real-pads.md`).
//!   Effects that act alike in both directions (channel lags, gain errors,
//!   the breakaway's location) cancel in Δ.
//! * **Contact compliance** ([`compliance_screen`]): while the slider
//!   sticks, M2 rides on the contact spring, x2 = xs + P/kt, and M2's
//!   equation gives P = q − K2·x2 with q = K2·x1 + d(ẋ1 − ẋ2) − M2·ẍ2, so
//!   x2 = α + q/(kt + K2) within each stick. A rigid stick has x2 flat
//!   (slope 0). The slope β is regressed within the inner part of every
//!   stick (one intercept per stick; q holds no x2 sample, so x2's noise
//!   does not bias β), with a cluster-robust standard error over sticks;
//!   kt = 1/β − K2 where β is resolved, else a one-sided 95 % lower bound.

use super::contact::Contact;
use super::segment::Segmentation;
use crate::stats::{normal_quantile, student_t_quantile};

/// Smallest number of breakaways per direction for the direction screen.
pub const MIN_BREAKAWAYS_PER_DIRECTION: usize = 3;

/// z above which a screen calls an effect present (the richer model is
/// then refined and must still win by the criterion).
pub const SCREEN_Z: f64 = 3.0;

/// The direction screen of one log.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct DirectionScreen {
    /// Drop asymmetry Δ = (Rs⁺ − Rd⁺) − (Rs⁻ − Rd⁻) (N), where both
    /// directions have [`MIN_BREAKAWAYS_PER_DIRECTION`] breakaways.
    pub drop_asymmetry_n: Option<f64>,
    /// Its standard error (N).
    pub se_n: Option<f64>,
    /// Its 95 % interval (N; Student's t with Welch's degrees of freedom).
    pub interval_n: Option<(f64, f64)>,
    /// |Δ| / se.
    pub z: Option<f64>,
    /// Breakaways towards + and towards −.
    pub breakaways: (usize, usize),
    /// Two-sided binomial p-value of that split under equal chances: a
    /// symmetric pad in a symmetric motion sticks alike at both reversals,
    /// a pad whose threshold is lower in one direction may stick only at
    /// one of them.
    pub imbalance_p: f64,
    /// The screen calls the pad direction-dependent (z above
    /// [`SCREEN_Z`], or the imbalance's p below [`SCREEN_P`]).
    pub flagged: bool,
}

/// Smallest drop asymmetry, as a fraction of the mean drop Rs − Rd, that
/// the z test flags: a significant but negligible Δ (char_N7.2: 1.7 % of
/// its drop at z = 6.2, a systematic effect of the breakaway location) is
/// not worth an extra refinement.
pub const MIN_DROP_FRACTION: f64 = 0.03;

/// p-value below which the breakaway counts' imbalance flags a pad.
pub const SCREEN_P: f64 = 1e-3;

/// Two-sided p-value of `k` successes in `n` fair trials (twice the
/// smaller tail, at most 1).
fn binomial_two_sided(k: usize, n: usize) -> f64 {
    if n == 0 {
        return 1.0;
    }
    let k = k.min(n - k);
    // ln C(n, j) summed in the log domain, term by term.
    let mut term = -(n as f64) * std::f64::consts::LN_2; // j = 0
    let mut tail = term.exp();
    for j in 1..=k {
        term += ((n - j + 1) as f64).ln() - (j as f64).ln();
        tail += term.exp();
    }
    (2.0 * tail).min(1.0)
}

/// The direction screen from the per-breakaway static forces `forces_n`
/// (bias removed, magnitudes in the slip's direction), their directions
/// `dirs` (±1) and the sliding level `rd_n` (N; the z test needs |Δ| above
/// [`MIN_DROP_FRACTION`] of the mean drop). None without any breakaway.
pub fn direction_screen(forces_n: &[f64], dirs: &[f64], rd_n: f64) -> Option<DirectionScreen> {
    let side = |s: f64| -> Vec<f64> {
        forces_n
            .iter()
            .zip(dirs)
            .filter(|(f, d)| f.is_finite() && d.signum() == s)
            .map(|(f, _)| *f)
            .collect()
    };
    let (p, m) = (side(1.0), side(-1.0));
    if p.is_empty() && m.is_empty() {
        return None;
    }
    let imbalance_p = binomial_two_sided(p.len(), p.len() + m.len());
    let mut out = DirectionScreen {
        drop_asymmetry_n: None,
        se_n: None,
        interval_n: None,
        z: None,
        breakaways: (p.len(), m.len()),
        imbalance_p,
        flagged: imbalance_p < SCREEN_P,
    };
    if p.len() < MIN_BREAKAWAYS_PER_DIRECTION || m.len() < MIN_BREAKAWAYS_PER_DIRECTION {
        return Some(out);
    }
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    let var_mean = |v: &[f64]| crate::stats::sample_sd(v).powi(2) / v.len() as f64;
    let (vp, vm) = (var_mean(&p), var_mean(&m));
    let delta = mean(&p) - mean(&m);
    let se = (vp + vm).sqrt();
    // Welch–Satterthwaite degrees of freedom.
    let dof = if se > 0.0 {
        (vp + vm).powi(2)
            / (vp * vp / (p.len() - 1) as f64 + vm * vm / (m.len() - 1) as f64).max(1e-300)
    } else {
        (p.len() + m.len() - 2) as f64
    };
    let t = student_t_quantile(0.975, dof.max(1.0));
    let z = if se > 0.0 {
        delta.abs() / se
    } else if delta == 0.0 {
        0.0
    } else {
        f64::INFINITY
    };
    out.drop_asymmetry_n = Some(delta);
    out.se_n = Some(se);
    out.interval_n = Some((delta - t * se, delta + t * se));
    out.z = Some(z);
    let all: Vec<f64> = p.iter().chain(&m).copied().collect();
    let drop = mean(&all) - rd_n;
    let sizeable = drop.is_nan() || drop <= 0.0 || delta.abs() > MIN_DROP_FRACTION * drop;
    out.flagged |= z > SCREEN_Z && sizeable;
    Some(out)
}

/// The contact-compliance screen of one log.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ComplianceScreen {
    /// Slope β = 1/(kt + K2) of x2 against q within the sticks (m/N).
    pub slope_m_per_n: f64,
    /// Its cluster-robust standard error (m/N).
    pub se_m_per_n: f64,
    /// Sticks and samples used.
    pub sticks: usize,
    /// Samples used.
    pub samples: usize,
    /// β / se.
    pub z: f64,
    /// Contact stiffness kt (N/m) where the slope is resolved (z above
    /// [`SCREEN_Z`]), with its 95 % interval (upper end infinite where the
    /// slope's interval reaches 0).
    pub kt_n_per_m: Option<(f64, (f64, f64))>,
    /// One-sided 95 % lower bound on kt (N/m; infinite only where the slope
    /// and its standard error are both 0).
    pub kt_lower_bound_n_per_m: f64,
    /// Largest pre-sliding displacement the fit implies over the sticks
    /// (m): β times the largest within-stick range of q.
    pub presliding_m: f64,
    /// The screen calls the contact compliant.
    pub flagged: bool,
}

/// Sums of one stick's centred regression.
struct StickSums {
    sxx: f64,
    sxy: f64,
    n: usize,
    range: f64,
    /// Centred (q, x2) pairs, for the residual pass.
    pairs: Vec<(f64, f64)>,
}

/// The compliance slope of x2 on q = K2·x1 + d(ẋ1 − ẋ2) − M2·ẍ2 within the
/// inner part of every stick (one smoothing half-window in from each end,
/// at least 5 samples). `m2`, `d`: rig constants. None with fewer than 4
/// usable sticks.
pub fn compliance_screen(
    c: &Contact,
    seg: &Segmentation,
    m2: f64,
    d: f64,
) -> Option<ComplianceScreen> {
    let k2 = c.k2_n_per_m;
    let h = c.half_window.max(2);
    let q = |i: usize| k2 * c.x1[i] + d * (c.v1[i] - c.v2[i]) - m2 * c.a2[i];
    let mut sums: Vec<StickSums> = Vec::new();
    for &(s, e) in &seg.sticks {
        if e <= s + 2 * h + 5 || s == 0 || e >= c.t.len() {
            continue;
        }
        let idx: Vec<usize> = (s + h..e - h)
            .filter(|&i| q(i).is_finite() && c.x2[i].is_finite())
            .collect();
        if idx.len() < 5 {
            continue;
        }
        let n = idx.len() as f64;
        let mq = idx.iter().map(|&i| q(i)).sum::<f64>() / n;
        let mx = idx.iter().map(|&i| c.x2[i]).sum::<f64>() / n;
        let pairs: Vec<(f64, f64)> = idx.iter().map(|&i| (q(i) - mq, c.x2[i] - mx)).collect();
        let sxx = pairs.iter().map(|p| p.0 * p.0).sum();
        let sxy = pairs.iter().map(|p| p.0 * p.1).sum();
        let (lo, hi) = pairs
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |a, p| {
                (a.0.min(p.0), a.1.max(p.0))
            });
        sums.push(StickSums {
            sxx,
            sxy,
            n: pairs.len(),
            range: hi - lo,
            pairs,
        });
    }
    let k = sums.len();
    if k < 4 {
        return None;
    }
    let sxx: f64 = sums.iter().map(|s| s.sxx).sum();
    if sxx <= 0.0 {
        return None;
    }
    let beta = sums.iter().map(|s| s.sxy).sum::<f64>() / sxx;
    // Cluster-robust (sandwich) variance over sticks: the samples within a
    // stick share smoothing and sensor filters.
    let meat: f64 = sums
        .iter()
        .map(|s| {
            let g: f64 = s.pairs.iter().map(|(x, y)| x * (y - beta * x)).sum();
            g * g
        })
        .sum();
    let var = meat / (sxx * sxx) * k as f64 / (k - 1) as f64;
    let se = var.sqrt();
    let z = if se > 0.0 { beta / se } else { 0.0 };
    let kt_of = |b: f64| if b > 0.0 { 1.0 / b - k2 } else { f64::INFINITY };
    let t = student_t_quantile(0.975, (k - 1) as f64);
    let flagged = z > SCREEN_Z;
    let kt_n_per_m = flagged.then(|| (kt_of(beta), (kt_of(beta + t * se), kt_of(beta - t * se))));
    let upper = beta.max(0.0) + normal_quantile(0.95) * se;
    let range = sums.iter().map(|s| s.range).fold(0.0, f64::max);
    Some(ComplianceScreen {
        slope_m_per_n: beta,
        se_m_per_n: se,
        sticks: k,
        samples: sums.iter().map(|s| s.n).sum(),
        z,
        kt_n_per_m,
        kt_lower_bound_n_per_m: kt_of(upper).max(0.0),
        presliding_m: beta.max(0.0) * range,
        flagged,
    })
}

/// A slider that never broke away behind a compliant contact
/// ([`slider_held`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Held {
    /// Contact stiffness kt (N/m) of the whole-log regression.
    pub kt_n_per_m: f64,
    /// Range of x2 (1 % to 99 % of the smoothed record, m): M2 rides on
    /// the contact spring.
    pub x2_range_m: f64,
    /// Range of the smoothed contact force about its line in x2, over kt
    /// (m): what a slip of the slider would move.
    pub slider_range_m: f64,
    /// x2's noise σ (m).
    pub noise_m: f64,
    /// The contact force's amplitude (N; half its smoothed peak-to-peak
    /// less twice its smoothed noise, [`super::fit::held_force_lower_bound`]):
    /// the slider held it, so Rs is above.
    pub force_amplitude_n: f64,
}

/// Behind a compliant contact a slider that never breaks away leaves M2
/// riding on the contact spring: M2 moves (its velocity shows no stick)
/// while nothing slips. Then the contact force P = K2(x1 − x2) + d(ẋ1 −
/// ẋ2) − M2ẍ2 = kt·(x2 − xs) with one slider position xs over the whole
/// log; a slip would move xs. Returns the regression of P on x2 where x2
/// moves (its smoothed range above [`super::positions::MOVES_FACTOR`]
/// noise σ), kt > 0, and P's smoothed range about the line is below
/// [`HELD_FRACTION`] of its own. (Held logs, three contact stiffnesses,
/// with and without accelerometer: 0.016–0.079; sliding logs, rigid and
/// compliant, the bundled ones and 24 of the compliant study: 0.65 and
/// above, or kt ≤ 0.)
pub fn slider_held(c: &Contact) -> Option<Held> {
    use super::smooth::savgol;
    use crate::stats::quantile;
    let (k2, d, m2) = (c.k2_n_per_m, c.d_n_s_per_m, c.m2_kg);
    let h = c.half_window.max(2);
    let n = c.t.len();
    if n < 4 * h + 20 {
        return None;
    }
    // The contact force P = K2(x1 − x2) + d(ẋ1 − ẋ2) − M2ẍ2.
    let p = |i: usize| k2 * (c.x1[i] - c.x2[i]) + d * (c.v1[i] - c.v2[i]) - m2 * c.a2[i];
    let idx: Vec<usize> = (h..n - h)
        .filter(|&i| p(i).is_finite() && c.x2[i].is_finite())
        .collect();
    if idx.len() < 20 {
        return None;
    }
    let m = idx.len() as f64;
    let mp = idx.iter().map(|&i| p(i)).sum::<f64>() / m;
    let mx = idx.iter().map(|&i| c.x2[i]).sum::<f64>() / m;
    let (mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0);
    for &i in &idx {
        let (a, b) = (c.x2[i] - mx, p(i) - mp);
        sxx += a * a;
        sxy += a * b;
        syy += b * b;
    }
    let kt = sxy / sxx;
    // A cheap first test, before any smoothing: a held slider leaves P on
    // its line up to noise (R² 0.989–0.9997 on the held logs below; the
    // sliding ones 0.33 at most, most with kt < 0).
    let r2 = sxy * sxy / (sxx * syy);
    if !(kt > 0.0 && kt.is_finite() && r2 > 0.5) {
        return None;
    }
    let force: Vec<f64> = idx.iter().map(|&i| p(i)).collect();
    let resid: Vec<f64> = idx
        .iter()
        .map(|&i| p(i) - mp - kt * (c.x2[i] - mx))
        .collect();
    let x2: Vec<f64> = idx.iter().map(|&i| c.x2[i]).collect();
    let range = |v: &[f64]| {
        let s = savgol(v, c.dt, h, 3, 0);
        quantile(&s, 0.99) - quantile(&s, 0.01)
    };
    let (x2_range, noise) = super::positions::range_and_noise(&x2, c.dt, h);
    let (force_range, resid_range) = (range(&force), range(&resid));
    let moves = x2_range > super::positions::MOVES_FACTOR * noise;
    let held = resid_range < HELD_FRACTION * force_range;
    (moves && held).then(|| Held {
        kt_n_per_m: kt,
        x2_range_m: x2_range,
        slider_range_m: resid_range / kt,
        noise_m: noise,
        // The force the slider held, bounded as a rigid stuck log's.
        force_amplitude_n: super::fit::held_force_lower_bound(&force, c.dt, h),
    })
}

/// The slider is held when the smoothed range of the contact force about
/// its line in x2 is below this fraction of the force's own range.
pub const HELD_FRACTION: f64 = 0.25;

/// Both screens of one log (None where the log cannot tell: too few
/// breakaways in a direction, too few sticks).
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PadScreen {
    /// The direction screen.
    pub direction: Option<DirectionScreen>,
    /// The compliance screen.
    pub compliance: Option<ComplianceScreen>,
}

impl PadScreen {
    /// Both screens of a log from its characteristic and equation-error
    /// fit.
    pub fn of(
        c: &Contact,
        seg: &Segmentation,
        ef: &super::EquationFit,
        rig: &crate::ingest::RigMeta,
    ) -> Self {
        PadScreen {
            direction: direction_screen(
                &ef.breakaway_forces_n,
                &ef.breakaway_directions,
                ef.law.rd_n,
            ),
            compliance: compliance_screen(c, seg, rig.m2_kg, rig.d_n_s_per_m),
        }
    }

    /// The extensions the output-error refinement should try, with start
    /// values: those whose screen fired.
    pub fn hints(&self) -> super::output_error::PadHints {
        let dir = self.direction.filter(|d| d.flagged);
        let kt = self
            .compliance
            .and_then(|c| c.kt_n_per_m)
            .map(|(kt, _)| kt)
            .filter(|kt| kt.is_finite() && *kt > 0.0);
        super::output_error::PadHints {
            split: dir.is_some(),
            split_n: dir.and_then(|d| d.drop_asymmetry_n),
            kt_n_per_m: kt,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn direction_screen_measures_the_difference_of_means() {
        // + breakaways at 0.60 ± 0.01, − at 0.50 ± 0.01 (alternating noise).
        let n = 12;
        let mut f = Vec::new();
        let mut d = Vec::new();
        for i in 0..n {
            let e = if i % 2 == 0 { 0.01 } else { -0.01 };
            f.push(0.60 + e);
            d.push(1.0);
            f.push(0.50 - e);
            d.push(-1.0);
        }
        let s = direction_screen(&f, &d, 0.4).unwrap();
        assert!((s.drop_asymmetry_n.unwrap() - 0.10).abs() < 1e-12);
        assert!(s.flagged);
        let iv = s.interval_n.unwrap();
        assert!(iv.0 > 0.09 && iv.1 < 0.11);
        assert_eq!(s.breakaways, (n, n));
        assert_eq!(s.imbalance_p, 1.0);
    }

    #[test]
    fn a_significant_but_negligible_asymmetry_is_not_flagged() {
        // Δ = 0.001 N at z ≈ 20, but 0.5 % of the drop 0.2 N.
        let mut f = Vec::new();
        let mut d = Vec::new();
        for i in 0..10 {
            let e = if i % 2 == 0 { 1e-4 } else { -1e-4 };
            f.extend([0.601 + e, 0.600 - e]);
            d.extend([1.0, -1.0]);
        }
        let s = direction_screen(&f, &d, 0.4).unwrap();
        assert!(s.z.unwrap() > 10.0 && !s.flagged);
        // The same Δ on a pad whose drop is 0.02 N (5 %) is flagged.
        let s = direction_screen(&f, &d, 0.58).unwrap();
        assert!(s.flagged);
    }

    #[test]
    fn direction_screen_needs_both_directions_for_the_drop() {
        let f = [0.5, 0.51, 0.49, 0.5, 0.5];
        let d = [1.0, 1.0, 1.0, -1.0, -1.0];
        let s = direction_screen(&f, &d, 0.4).unwrap();
        assert!(s.drop_asymmetry_n.is_none() && !s.flagged);
        assert!(direction_screen(&[], &[], 0.4).is_none());
    }

    #[test]
    fn one_sided_breakaways_flag_the_pad() {
        // 14 breakaways, all towards +: p = 2·2^-14.
        let f = [0.5; 14];
        let d = [1.0; 14];
        let s = direction_screen(&f, &d, 0.4).unwrap();
        assert!((s.imbalance_p - 2.0 * 0.5f64.powi(14)).abs() < 1e-15);
        assert!(s.flagged && s.drop_asymmetry_n.is_none());
        // 9 against 5 is no evidence.
        let d: Vec<f64> = (0..14).map(|i| if i < 9 { 1.0 } else { -1.0 }).collect();
        let s = direction_screen(&f, &d, 0.4).unwrap();
        assert!(s.imbalance_p > 0.4 && !s.flagged);
    }

    #[test]
    fn binomial_tail_matches_direct_sums() {
        // n = 10, k = 2: (1 + 10 + 45)/1024, two-sided.
        assert!((binomial_two_sided(2, 10) - 2.0 * 56.0 / 1024.0).abs() < 1e-14);
        assert!((binomial_two_sided(8, 10) - 2.0 * 56.0 / 1024.0).abs() < 1e-14);
        assert_eq!(binomial_two_sided(5, 10), 1.0);
    }

    #[test]
    fn symmetric_breakaways_are_not_flagged() {
        // Identical noise patterns in both directions: Δ = 0 exactly.
        let e = [0.01, -0.02, 0.005, 0.015, -0.01];
        let f: Vec<f64> = e.iter().chain(e.iter()).map(|x| 0.5 + x).collect();
        let d: Vec<f64> = (0..10).map(|i| if i < 5 { 1.0 } else { -1.0 }).collect();
        let s = direction_screen(&f, &d, 0.4).unwrap();
        assert!(s.drop_asymmetry_n.unwrap().abs() < 1e-15 && !s.flagged);
        let iv = s.interval_n.unwrap();
        assert!(iv.0 < 0.0 && iv.1 > 0.0);
    }
}
