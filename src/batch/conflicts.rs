//! Conflicts between logs: bounds against measured points, points far off
//! the others, scatter beyond the intervals; the robust choice of logs.

use super::*;

/// The two-sided 99.73 % ("3σ") quantile of Student's t with `dof` degrees
/// of freedom (the normal 3.0 for dof = 0, meaning σ known).
pub(super) fn t9973(dof: usize) -> f64 {
    crate::stats::student_t_quantile(0.998_65, dof as f64)
}

/// A limit on R (value, σ), in newtons, if there is one.
pub(super) type Limit = Option<(f64, f64)>;

/// What one observation says about R = μN, as a lower and an upper limit
/// (value, σ), both in newtons; a point is both.
pub(super) fn limits(o: &Obs) -> (f64, Limit, Limit) {
    match *o {
        Obs::Point { n, r, s } => (n, Some((r, s)), Some((r, s))),
        Obs::Above { n, lb, s } => (n, Some((lb, s)), None),
        Obs::Between {
            n,
            lo,
            slo,
            hi,
            shi,
        } => (n, Some((lo, slo)), Some((hi, shi))),
    }
}

/// How far one observation lies outside a prediction of μ (σ of the
/// prediction below and above it): the tension in σ (0 inside) and the
/// signed relative distance from μN (positive: the observation asks for a
/// larger μ). `scale` multiplies the observation's own σ.
pub(super) fn tension_against(o: &Obs, mu: f64, sigma_mu: (f64, f64), scale: f64) -> (f64, f64) {
    let (n, lo, hi) = limits(o);
    let pred = mu * n;
    let mut t = (0.0, 0.0);
    if let Some((l, s)) = lo {
        // The observation asks for a larger μ: the prediction's upper side.
        let z = (l - pred) / (s * scale).hypot(sigma_mu.1 * n);
        if z > t.0 {
            t = (z, l / pred - 1.0);
        }
    }
    if let Some((u, s)) = hi {
        let z = (pred - u) / (s * scale).hypot(sigma_mu.0 * n);
        if z > t.0 {
            t = (z, u / pred - 1.0);
        }
    }
    t
}

/// Tension between two observations' own limits on μ (σ, 0 if they overlap).
pub(super) fn pair_tension(a: &Obs, b: &Obs) -> f64 {
    let (na, la, ua) = limits(a);
    let (nb, lb, ub) = limits(b);
    let one = |l: Option<(f64, f64)>, nl: f64, u: Option<(f64, f64)>, nu: f64| match (l, u) {
        (Some((l, sl)), Some((u, su))) => (l / nl - u / nu) / (sl / nl).hypot(su / nu),
        _ => 0.0,
    };
    one(la, na, ub, nb).max(one(lb, nb, ua, na)).max(0.0)
}

/// The tension of observation `k` against the fit of the other kept
/// observations: (tension in σ, its 3σ threshold, signed relative size, μ
/// of the others). The scale of the points is the others' own scatter (σ
/// inflated by their Birge ratio, Student's t with their n − 1 degrees of
/// freedom). None when the others measure nothing.
pub(super) fn loo(obs: &[Obs], kept: &[bool], k: usize) -> Option<(f64, f64, f64, f64)> {
    let others: Vec<Obs> = obs
        .iter()
        .zip(kept)
        .enumerate()
        .filter(|&(i, (_, &keep))| keep && i != k)
        .map(|(_, (o, _))| *o)
        .collect();
    let (mu, (lo, hi), inflate, _) = fit_mu(&others)?;
    let pts = point_obs(&others).len();
    let (q, dof) = if inflate > 1.0 {
        (t975(pts - 1), pts - 1)
    } else {
        (t975(0), 0)
    };
    let sigma_mu = ((mu - lo) / q, (hi - mu) / q);
    let (t, rel) = tension_against(&obs[k], mu, sigma_mu, inflate);
    Some((t, t9973(dof), rel, mu))
}

/// Dixon's Q test at 99 % on the measured points' R/N among the kept
/// observations: is point `k` the extreme value with a gap to its nearest
/// neighbour larger than the critical fraction of the range (3 to 10
/// points; Rorabacher 1991)? Scale-free, so it still finds a log far off
/// the others when those scatter beyond their own σ and are too few to
/// estimate that scatter well; the gap must also exceed 3σ of the two
/// points' own σ.
pub(super) fn dixon_outlier(obs: &[Obs], kept: &[bool], k: usize) -> bool {
    const Q99: [f64; 8] = [0.994, 0.926, 0.821, 0.740, 0.680, 0.634, 0.598, 0.568];
    let Obs::Point { n, r, s } = obs[k] else {
        return false;
    };
    let x = r / n;
    let pts: Vec<(f64, f64)> = (0..obs.len())
        .filter(|&i| kept[i] && i != k)
        .filter_map(|i| match obs[i] {
            Obs::Point { n, r, s } => Some((r / n, s / n)),
            _ => None,
        })
        .collect();
    let m = pts.len() + 1;
    if !(3..=10).contains(&m) {
        return false;
    }
    let lo = pts.iter().map(|p| p.0).fold(f64::INFINITY, f64::min);
    let hi = pts.iter().map(|p| p.0).fold(f64::NEG_INFINITY, f64::max);
    let (near, range) = if x > hi {
        (pts.iter().copied().find(|p| p.0 == hi), x - lo)
    } else if x < lo {
        (pts.iter().copied().find(|p| p.0 == lo), hi - x)
    } else {
        return false;
    };
    let Some((xn, sn)) = near else { return false };
    let gap = (x - xn).abs();
    range > 0.0 && gap / range > Q99[m - 3] && gap > 3.0 * (s / n).hypot(sn)
}

/// A contradiction between logs of the batch.
#[derive(Debug, Clone, PartialEq)]
pub struct Conflict {
    /// `mu_s` or `mu_d`.
    pub quantity: &'static str,
    /// `point` (a measured value far off the others), `never-sticks bound`,
    /// `stuck bound` (a bound against the others' values) or `scatter`
    /// (the measured values scatter beyond their intervals).
    pub kind: &'static str,
    /// The logs: the one that disagrees first, then those it disagrees with.
    pub logs: Vec<PathBuf>,
    /// Size in σ of the combined uncertainty, calibration parts included
    /// (for `scatter`: the Birge ratio against the whole intervals).
    pub size_sigma: f64,
    /// Size relative to the others' μN (for `scatter`: the relative RMS
    /// spread of the points' R/N).
    pub size_rel: f64,
    /// The first log was set aside from the robust estimate.
    pub set_aside: bool,
    /// The conflict in words.
    pub what: String,
}

/// Relative doubt a log's own fit casts on its observation: how far its
/// equation-error and output-error estimates lie apart, in σ of their
/// combined 95 % intervals (0 when only one exists).
pub(super) fn estimate_disagreement(
    ee: f64,
    ee_iv: Option<(f64, f64)>,
    oe: Option<(f64, Option<(f64, f64)>)>,
) -> f64 {
    let Some((oe, oe_iv)) = oe else { return 0.0 };
    match (half_width(ee, ee_iv), half_width(oe, oe_iv)) {
        (Some(a), Some(b)) if a.hypot(b) > 0.0 && ee.is_finite() && oe.is_finite() => {
            (ee - oe).abs() / (a.hypot(b) / 1.96)
        }
        _ => 0.0,
    }
}

/// Is observation `k` in conflict with the other kept ones: beyond the 3σ
/// quantile of [`loo`], or a Dixon outlier ([`dixon_outlier`])?
pub(super) fn in_conflict(obs: &[Obs], kept: &[bool], k: usize) -> bool {
    loo(obs, kept, k).is_some_and(|(t, thr, ..)| t > thr) || dixon_outlier(obs, kept, k)
}

/// The robust selection: which observations to set aside so that the rest
/// agree. Repeatedly, among the observations in tension with the others
/// (beyond 3σ of the others' own scatter), the one whose removal leaves the
/// least misfit (−2 log-likelihood of the rest at its maximum, own σ) is
/// set aside (candidates: those observations and the ones
/// they contradict one to one); where two removals are equally good, the
/// log whose own fit is most doubtful (its equation-error and output-error
/// estimates disagree, significant at 95 %) goes,
/// else a bound before a measured point; when nothing tells them apart,
/// nothing more is set aside (the conflict stays, named, and the scatter
/// inflation carries it). At least one point and more than half of the
/// observations always stay.
pub(super) fn robust_keep(obs: &[Obs], doubt: &[f64]) -> (Vec<bool>, bool) {
    let n = obs.len();
    let mut kept = vec![true; n];
    let max_out = (n.saturating_sub(1)) / 2;
    // The misfit left by a set: −2 × its log-likelihood at its own
    // maximum, with the observations' own σ (a χ² for points).
    let excess = |kept: &[bool]| -> f64 {
        let rest: Vec<Obs> = (0..n).filter(|&i| kept[i]).map(|i| obs[i]).collect();
        let Some(top) = rest
            .iter()
            .map(|o| {
                let (n, lo, hi) = limits(o);
                hi.or(lo).map_or(0.0, |x| x.0 / n)
            })
            .reduce(f64::max)
        else {
            return 0.0;
        };
        let mu = golden_section(0.0, 4.0 * top.max(1e-12), 200, |m| -loglik(&rest, m, 1.0));
        -2.0 * loglik(&rest, mu, 1.0)
    };
    let mut resolved = true;
    for _ in 0..max_out {
        let flagged: Vec<usize> = (0..n)
            .filter(|&i| kept[i])
            .filter(|&i| in_conflict(obs, &kept, i))
            .collect();
        if flagged.is_empty() {
            break;
        }
        // The candidates: the flagged observations and those they
        // contradict one to one (a pair of points is symmetric even when
        // only one side crosses the threshold against the fit of the rest).
        let mut candidates = flagged.clone();
        for j in 0..n {
            if kept[j]
                && !candidates.contains(&j)
                && flagged
                    .iter()
                    .any(|&i| pair_tension(&obs[i], &obs[j]) > 3.0)
            {
                candidates.push(j);
            }
        }
        let mut options: Vec<(usize, f64)> = candidates
            .iter()
            .filter_map(|&i| {
                let mut k = kept.clone();
                k[i] = false;
                let pts = (0..n)
                    .filter(|&j| k[j] && matches!(obs[j], Obs::Point { .. }))
                    .count();
                (pts > 0).then(|| (i, excess(&k)))
            })
            .collect();
        if options.is_empty() {
            resolved = false;
            break;
        }
        options.sort_by(|a, b| a.1.total_cmp(&b.1));
        let best = options[0].1;
        let tied: Vec<usize> = options
            .iter()
            .filter(|o| o.1 <= best + (0.05 * best).max(1.0))
            .map(|o| o.0)
            .collect();
        let pick = if tied.len() == 1 {
            Some(tied[0])
        } else {
            // Doubt from the log's own fit (its two estimates disagree,
            // significant at 95 %).
            let d = |i: usize| if doubt[i] > 1.96 { doubt[i] } else { 0.0 };
            let top = tied.iter().map(|&i| d(i)).fold(0.0, f64::max);
            let doubted: Vec<usize> = tied.iter().copied().filter(|&i| d(i) == top).collect();
            if top > 0.0 && doubted.len() == 1 {
                Some(doubted[0])
            } else {
                let bounds: Vec<usize> = tied
                    .iter()
                    .copied()
                    .filter(|&i| !matches!(obs[i], Obs::Point { .. }))
                    .collect();
                (bounds.len() == 1).then(|| bounds[0])
            }
        };
        match pick {
            Some(i) => kept[i] = false,
            None => {
                resolved = false;
                break;
            }
        }
    }
    if (0..n).any(|i| kept[i] && in_conflict(obs, &kept, i)) {
        resolved = false;
    }
    (kept, resolved)
}
