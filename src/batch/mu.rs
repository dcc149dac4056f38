//! Statistics of the friction coefficients: the censored likelihood of
//! measured points and bounds, μ fits with their intervals.

use super::*;

/// ln erfc(x) for x ≥ 0 (Chebyshev-fitted form of Numerical Recipes'
/// `erfcc`, relative error of erfc < 1.2e-7), exact in its exponent so it
/// works far into the tail.
pub(super) fn ln_erfc_pos(x: f64) -> f64 {
    let t = 1.0 / (1.0 + 0.5 * x);
    let p = -1.265_512_23
        + t * (1.000_023_68
            + t * (0.374_091_96
                + t * (0.096_784_18
                    + t * (-0.186_288_06
                        + t * (0.278_868_07
                            + t * (-1.135_203_98
                                + t * (1.488_515_87 + t * (-0.822_152_23 + t * 0.170_872_77))))))));
    t.ln() - x * x + p
}

/// ln Φ(z) of the standard normal distribution, accurate in both tails.
pub fn ln_norm_cdf(z: f64) -> f64 {
    let s = std::f64::consts::FRAC_1_SQRT_2;
    if z < 0.0 {
        0.5f64.ln() + ln_erfc_pos(-z * s)
    } else {
        (-0.5 * ln_erfc_pos(z * s).exp()).ln_1p()
    }
}

/// An observation of one log for a through-the-origin fit R = μ·N.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Obs {
    Point {
        n: f64,
        r: f64,
        s: f64,
    },
    Above {
        n: f64,
        lb: f64,
        s: f64,
    },
    Between {
        n: f64,
        lo: f64,
        slo: f64,
        hi: f64,
        shi: f64,
    },
}

pub(super) fn loglik(obs: &[Obs], mu: f64, inflate: f64) -> f64 {
    obs.iter()
        .map(|o| match *o {
            Obs::Point { n, r, s } => {
                let z = (r - mu * n) / (s * inflate);
                -0.5 * z * z
            }
            Obs::Above { n, lb, s } => ln_norm_cdf((mu * n - lb) / (s * inflate)),
            Obs::Between {
                n,
                lo,
                slo,
                hi,
                shi,
            } => {
                // Both bounds are measured independently: the probability
                // of the observed lower bound lying below Rs = μN times that
                // of the observed upper bound lying above it. Never zero, so
                // a bound that contradicts the points pulls on μ with a
                // finite force (and is found by the conflict check) instead
                // of making the likelihood −∞.
                ln_norm_cdf((mu * n - lo) / (slo * inflate))
                    + ln_norm_cdf((hi - mu * n) / (shi * inflate))
            }
        })
        .sum()
}

/// Bisection for the crossing of a monotone predicate between `good` (false)
/// and `bad` (true).
pub(super) fn bisect(mut good: f64, mut bad: f64, iters: usize, pred: impl Fn(f64) -> bool) -> f64 {
    for _ in 0..iters {
        let m = 0.5 * (good + bad);
        if pred(m) {
            bad = m;
        } else {
            good = m;
        }
    }
    0.5 * (good + bad)
}

/// The 97.5 % quantile of Student's t with `dof` degrees of freedom (the
/// normal 1.96 for dof = 0, meaning σ known).
pub(super) fn t975(dof: usize) -> f64 {
    crate::stats::student_t_quantile(0.975, dof as f64)
}

/// Weighted straight line R = a + μN with the intercept's 95 % half-width
/// (inflated by √(χ²/dof) when > 1). Needs two distinct N.
pub(super) fn free_fit(points: &[(f64, f64, f64)]) -> Option<(f64, f64, f64)> {
    if points.len() < 2 {
        return None;
    }
    let (mut sw, mut sx, mut sy, mut sxx, mut sxy) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for &(x, y, s) in points {
        let w = 1.0 / (s * s);
        sw += w;
        sx += w * x;
        sy += w * y;
        sxx += w * x * x;
        sxy += w * x * y;
    }
    let det = sw * sxx - sx * sx;
    if !(det.is_finite() && det > 1e-12 * sw * sxx) {
        return None;
    }
    let slope = (sw * sxy - sx * sy) / det;
    let a = (sxx * sy - sx * sxy) / det;
    let var_a = sxx / det;
    let dof = points.len() as f64 - 2.0;
    let chi2: f64 = points
        .iter()
        .map(|&(x, y, s)| ((y - a - slope * x) / s).powi(2))
        .sum();
    // σ scaled from the residuals (when they scatter more than σ says):
    // Student's t with n − 2 degrees of freedom.
    let (inflate, q) = if dof >= 1.0 && chi2 / dof > 1.0 {
        ((chi2 / dof).sqrt(), t975(points.len() - 2))
    } else {
        (1.0, t975(0))
    };
    Some((slope, a, q * var_a.sqrt() * inflate))
}

/// Estimate, statistical 95 % interval, σ inflation factor, χ²/dof.
pub(super) type MuEstimate = (f64, (f64, f64), f64, Option<f64>);

/// The (N, R, σ) of the point observations (bounds left out).
pub(super) fn point_obs(obs: &[Obs]) -> Vec<(f64, f64, f64)> {
    obs.iter()
        .filter_map(|o| match *o {
            Obs::Point { n, r, s } => Some((n, r, s)),
            _ => None,
        })
        .collect()
}

/// Fits R = μ·N by maximum likelihood with censored observations; returns
/// the estimate, the statistical 95 % interval, the inflation factor and
/// χ²/dof of the points. When the points scatter more than their σ, the σ
/// are scaled by √(χ²/dof) and the interval uses Student's t with the
/// points' n − 1 degrees of freedom (the scale is then estimated).
pub(super) fn fit_mu(obs: &[Obs]) -> Option<MuEstimate> {
    let points = point_obs(obs);
    if points.is_empty() {
        return None;
    }
    let scale = obs
        .iter()
        .map(|o| match *o {
            Obs::Point { n, r, .. } => r / n,
            Obs::Above { n, lb, .. } => lb / n,
            Obs::Between { n, hi, .. } => hi / n,
        })
        .filter(|x| x.is_finite())
        .fold(0.0f64, f64::max);
    if scale.is_nan() || scale <= 0.0 {
        return None;
    }
    let top = 4.0 * scale;
    let mle = |inflate: f64| golden_section(0.0, top, 200, |m| -loglik(obs, m, inflate));
    let mut mu = mle(1.0);
    let dof = points.len() as f64 - 1.0;
    let chi2: f64 = points
        .iter()
        .map(|&(n, r, s)| ((r - mu * n) / s).powi(2))
        .sum();
    let chi2_dof = (dof >= 1.0).then(|| chi2 / dof);
    let inflate = chi2_dof.map_or(1.0, |c| c.max(1.0).sqrt());
    if inflate > 1.0 {
        mu = mle(inflate);
    }
    let q = if inflate > 1.0 {
        t975(points.len() - 1)
    } else {
        t975(0)
    };
    let drop = 0.5 * q * q;
    let l0 = loglik(obs, mu, inflate);
    if !(mu.is_finite() && l0.is_finite()) {
        return None;
    }
    let below = |m: f64| l0 - loglik(obs, m, inflate) > drop;
    let lo = if below(0.0) {
        bisect(mu, 0.0, 80, below)
    } else {
        0.0
    };
    let mut hi_bad = mu.max(1e-12) * 2.0;
    let mut k = 0;
    while !below(hi_bad) && k < 60 {
        hi_bad *= 2.0;
        k += 1;
    }
    let hi = bisect(mu, hi_bad, 80, below);
    Some((mu, (lo, hi), inflate, chi2_dof))
}

/// Adds the relative systematic half-width `sys` (of μ) to a statistical
/// interval, in quadrature on each side (a friction coefficient is not
/// negative: the lower end stops at 0).
pub(super) fn with_systematic(mu: f64, (lo, hi): (f64, f64), sys: f64) -> (f64, f64) {
    let s = sys * mu;
    ((mu - (mu - lo).hypot(s)).max(0.0), mu + (hi - mu).hypot(s))
}
