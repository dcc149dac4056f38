//! The pad the batch simulates: the real-pad extensions the logs' fits
//! chose (a compliant contact κ = kt/K2, a static threshold that depends
//! on the sliding direction), combined over the logs.
//!
//! Both are properties of the pad, not of the normal force: with friction
//! proportional to N (Amontons, the premise of the batch) the split is a
//! fixed ratio ρs⁻/ρs⁺, and the contact's tangential stiffness kt is taken
//! as independent of N (the Jenkins element with one spring: the
//! pre-sliding displacement Rs/kt then grows with N, which is why the low
//! settings' logs often bound κ only from below). Each is combined in log
//! space, weighted by the logs' intervals (σ of ln κ from the 95 %
//! interval), with the Birge ratio where the logs scatter beyond their
//! intervals (the χ² per degree of freedom is reported: a large one says
//! that κ does depend on N, or that a log misread it). An extension is
//! simulated when at least half of the logs that slid under a refined fit
//! chose it; where fewer did, the batch simulates the paper's pad and
//! says so (a warning with the count and the value), since a single log
//! choosing an extension is what parsimony lets through in a few per cent
//! of rigid, symmetric logs.

use super::*;

/// The pad shape a worst case simulates besides (ρs, ρd).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PadShape {
    /// ρs⁻/ρs⁺ of a static threshold split by direction (equal dynamic
    /// levels, as `fit` identifies it); `None`: symmetric.
    pub rs_minus_ratio: Option<f64>,
    /// κ = kt/K2 of a compliant contact; `None`: the rigid stick.
    pub contact_stiffness: Option<f64>,
}

impl PadShape {
    /// The paper's pad: symmetric, rigid.
    pub const PAPER: PadShape = PadShape {
        rs_minus_ratio: None,
        contact_stiffness: None,
    };
}

/// One extension combined over the logs.
#[derive(Debug, Clone, PartialEq)]
pub struct Combined {
    /// The combined value (κ, or the ratio ρs⁻/ρs⁺).
    pub value: f64,
    /// Its 95 % interval (`None`: one log, without an interval of its
    /// own: nothing says how well it is known).
    pub interval: Option<(f64, f64)>,
    /// χ² per degree of freedom of the logs about it (None: one log).
    pub chi2_per_dof: Option<f64>,
    /// The logs that chose the extension.
    pub chosen: usize,
    /// The logs that could have (M2 slid under a refined fit).
    pub eligible: usize,
    /// Simulated (chosen by at least half of the eligible logs).
    pub used: bool,
    /// The ends of its interval are among the robust worst case's
    /// variants ([`BatchPad::shape_variants`]; set by the batch).
    pub in_robust: bool,
}

/// The extensions the logs' fits chose, and the shape simulated.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct BatchPad {
    /// What the worst cases simulate.
    pub shape: PadShape,
    /// The contact stiffness over the logs (None: no log chose one).
    pub contact: Option<Combined>,
    /// The split ratio ρs⁻/ρs⁺ over the logs (None: no log chose one).
    pub split: Option<Combined>,
}

impl BatchPad {
    /// The simulated shape with one extension at an end of its 95 %
    /// interval (κ's, then ρs⁻/ρs⁺'s; each end that differs from the
    /// value), for the robust worst case. Empty for the rigid symmetric
    /// pad, or where the logs give no interval.
    pub fn shape_variants(&self) -> Vec<PadShape> {
        let ends = |c: &Option<Combined>| -> Vec<f64> {
            c.as_ref()
                .filter(|c| c.used)
                .and_then(|c| c.interval.map(|(lo, hi)| (c.value, lo, hi)))
                .map_or(Vec::new(), |(v, lo, hi)| {
                    [lo, hi]
                        .into_iter()
                        .filter(|e| e.is_finite() && *e > 0.0 && (e - v).abs() > 1e-12 * v)
                        .collect()
                })
        };
        let mut out: Vec<PadShape> = ends(&self.contact)
            .into_iter()
            .map(|k| PadShape {
                contact_stiffness: Some(k),
                ..self.shape
            })
            .collect();
        out.extend(ends(&self.split).into_iter().map(|r| PadShape {
            rs_minus_ratio: Some(r),
            ..self.shape
        }));
        out
    }
}

/// Combines per-log values with 95 % intervals in log space (weights from
/// the intervals; logs without a finite interval count with the median
/// weight of the others, or all equally when none has one). `chosen` logs
/// chose the extension (some may only bound it), of `eligible`.
fn combine(
    values: &[(f64, Option<(f64, f64)>)],
    chosen: usize,
    eligible: usize,
) -> Option<Combined> {
    let pts: Vec<(f64, Option<f64>)> = values
        .iter()
        .filter(|(v, _)| v.is_finite() && *v > 0.0)
        .map(|&(v, iv)| {
            let sigma = iv
                .filter(|&(lo, hi)| lo > 0.0 && hi.is_finite() && hi > lo)
                .map(|(lo, hi)| (hi.ln() - lo.ln()) / (2.0 * 1.96));
            (v.ln(), sigma)
        })
        .collect();
    if pts.is_empty() {
        return None;
    }
    let mut known: Vec<f64> = pts.iter().filter_map(|p| p.1).collect();
    known.sort_by(f64::total_cmp);
    let fallback = known.get(known.len() / 2).copied().unwrap_or(1.0);
    let w: Vec<f64> = pts
        .iter()
        .map(|p| 1.0 / p.1.unwrap_or(fallback).powi(2))
        .collect();
    let sw: f64 = w.iter().sum();
    let mean = pts.iter().zip(&w).map(|(p, w)| p.0 * w).sum::<f64>() / sw;
    let mut sigma = 1.0 / sw.sqrt();
    let chi2_per_dof = (pts.len() > 1).then(|| {
        pts.iter()
            .zip(&w)
            .map(|(p, w)| (p.0 - mean).powi(2) * w)
            .sum::<f64>()
            / (pts.len() - 1) as f64
    });
    if known.is_empty() {
        // No log gave an interval: the values' own spread (none for one).
        let (lo, hi) = pts.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |a, p| {
            (a.0.min(p.0), a.1.max(p.0))
        });
        sigma = if pts.len() > 1 {
            0.5 * (hi - lo) / 1.96
        } else {
            f64::NAN
        };
    } else if let Some(c) = chi2_per_dof.filter(|c| *c > 1.0) {
        sigma *= c.sqrt();
    }
    let chosen = chosen.max(pts.len());
    Some(Combined {
        value: mean.exp(),
        interval: sigma
            .is_finite()
            .then(|| ((mean - 1.96 * sigma).exp(), (mean + 1.96 * sigma).exp())),
        chi2_per_dof: chi2_per_dof.filter(|_| !known.is_empty()),
        chosen,
        eligible,
        used: 2 * chosen >= eligible.max(1),
        in_robust: false,
    })
}

/// The pad of the batch from its logs' fits; a warning for an extension
/// that some logs chose and the batch does not simulate.
pub(super) fn batch_pad(fits: &[(PathBuf, LogFit)], warnings: &mut Vec<Warning>) -> BatchPad {
    // Logs whose refined fit saw M2 slide: they could have chosen either.
    let eligible: Vec<&LogFit> = fits
        .iter()
        .map(|(_, f)| f)
        .filter(|f| f.pads().is_some() && !f.stuck())
        .collect();
    let kappas: Vec<(f64, Option<(f64, f64)>)> = eligible
        .iter()
        .filter_map(|f| {
            let k = f.contact_stiffness()?;
            Some((k, f.pads().and_then(|p| p.contact_stiffness_interval)))
        })
        .collect();
    let splits: Vec<(f64, Option<(f64, f64)>)> = eligible
        .iter()
        .filter_map(|f| {
            let (minus, plus) = (f.rho_s_minus()?, f.rho_s()?);
            let p = f.pads()?;
            if p.minus_bounded || p.plus_bounded || plus <= 0.0 {
                return None;
            }
            let iv = p
                .rho_s_minus_interval
                .map(|(lo, hi)| (lo / plus, hi / plus));
            Some((minus / plus, iv))
        })
        .collect();
    // (A split whose threshold towards − is only bounded was chosen too.)
    let split_chosen = eligible.iter().filter(|f| f.direction_dependent()).count();
    let contact = combine(&kappas, kappas.len(), eligible.len());
    let split = combine(&splits, split_chosen, eligible.len());
    for (c, what) in [
        (&contact, "a contact spring κ"),
        (&split, "a split static threshold ρs⁻/ρs⁺"),
    ] {
        if let Some(c) = c.as_ref().filter(|c| !c.used) {
            warnings.push(Warning::BatchPadNotSimulated {
                extension: what.to_string(),
                chosen: c.chosen,
                eligible: c.eligible,
                value: c.value,
            });
        }
    }
    BatchPad {
        shape: PadShape {
            rs_minus_ratio: split.as_ref().filter(|c| c.used).map(|c| c.value),
            contact_stiffness: contact.as_ref().filter(|c| c.used).map(|c| c.value),
        },
        contact,
        split,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The robust variants: each simulated extension at each end of its
    /// interval, the other at its value; none for an extension not
    /// simulated or without an interval, nor for the rigid symmetric pad.
    #[test]
    fn shape_variants_are_the_interval_ends() {
        let c = |value: f64, interval: Option<(f64, f64)>, used: bool| Combined {
            value,
            interval,
            chi2_per_dof: None,
            chosen: 2,
            eligible: 3,
            used,
            in_robust: false,
        };
        let shape = PadShape {
            rs_minus_ratio: Some(0.88),
            contact_stiffness: Some(17.2),
        };
        let pad = BatchPad {
            shape,
            contact: Some(c(17.2, Some((16.0, 18.5)), true)),
            split: Some(c(0.88, Some((0.85, 0.91)), true)),
        };
        let v = pad.shape_variants();
        let k = |k: f64| PadShape {
            contact_stiffness: Some(k),
            ..shape
        };
        let r = |r: f64| PadShape {
            rs_minus_ratio: Some(r),
            ..shape
        };
        assert_eq!(v, vec![k(16.0), k(18.5), r(0.85), r(0.91)]);
        let unused = BatchPad {
            shape: PadShape {
                contact_stiffness: None,
                ..shape
            },
            contact: Some(c(17.2, Some((16.0, 18.5)), false)),
            split: Some(c(0.88, None, true)),
        };
        assert!(unused.shape_variants().is_empty());
        assert!(BatchPad::default().shape_variants().is_empty());
    }

    /// Equal intervals: the geometric mean; a scatter beyond the intervals
    /// widens the interval by the Birge ratio; half the logs is enough.
    #[test]
    fn combine_in_log_space() {
        let iv = |v: f64| Some((v / 1.1, v * 1.1));
        let c = combine(&[(20.0, iv(20.0)), (80.0, iv(80.0))], 2, 4).unwrap();
        assert!((c.value - 40.0).abs() < 1e-9);
        assert!(c.used && c.chosen == 2);
        let chi = c.chi2_per_dof.unwrap();
        assert!(chi > 100.0, "{chi}");
        let s = (1.1f64.ln() / 1.96) / 2f64.sqrt() * chi.sqrt();
        assert!((c.interval.unwrap().1 / 40.0 - (1.96 * s).exp()).abs() < 1e-9);
        // Agreeing logs: no widening.
        let c = combine(&[(40.0, iv(40.0)), (40.4, iv(40.4))], 2, 5).unwrap();
        assert!(c.chi2_per_dof.unwrap() < 1.0);
        assert!(!c.used, "2 of 5 logs");
        assert!(combine(&[], 1, 3).is_none());
        // A log that chose it but only bounds it counts towards the half.
        assert!(combine(&[(40.0, iv(40.0))], 2, 4).unwrap().used);
        // One log without an interval: no interval claimed.
        assert_eq!(combine(&[(40.0, None)], 1, 1).unwrap().interval, None);
    }
}
