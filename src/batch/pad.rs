//! The pad the batch simulates: the real-pad extensions the logs' fits
//! chose (a compliant contact κ = kt/K2, a static threshold that depends
//! on the sliding direction), combined over the logs.
//!
//! Both are properties of the pad. With friction proportional to N
//! (Amontons, the premise of the batch) the split is a fixed ratio
//! ρs⁻/ρs⁺. The contact's tangential stiffness kt is first taken as
//! independent of N (the Jenkins element with one spring: the pre-sliding
//! displacement Rs/kt then grows with N, which is why the low settings'
//! logs often bound κ only from below); where the logs' κ grow or fall
//! with N beyond their intervals and a power law κ = κ_ref·(N/N_ref)^γ
//! explains them (the constant's χ² falls by more than χ²₁'s 99 % point,
//! in units of the power law's own χ²/dof where that exceeds 1), the batch
//! simulates κ at each setting from that law (Hertz–Mindlin contacts give
//! γ = 1/3, rough contacts up to about 1). Each is combined in log space,
//! weighted by the logs' intervals (σ of ln κ from the 95 % interval),
//! with the Birge ratio where the logs scatter beyond their intervals (the
//! χ² per degree of freedom is reported). An extension is simulated when
//! at least half of the logs that slid under a refined fit chose it;
//! where fewer did, the batch simulates the paper's pad and says so (a
//! warning with the count and the value), since a single log choosing an
//! extension is what parsimony lets through in a few per cent of rigid,
//! symmetric logs.

use super::*;

/// The pad shape a worst case simulates besides (ρs, ρd).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PadShape {
    /// ρs⁻/ρs⁺ of a static threshold split by direction (equal dynamic
    /// levels, as `fit` identifies it); `None`: symmetric.
    pub rs_minus_ratio: Option<f64>,
    /// κ = kt/K2 of a compliant contact; `None`: the rigid stick. With
    /// `contact_power`, κ at its reference setting.
    pub contact_stiffness: Option<f64>,
    /// κ depending on the normal force (`None`: the same κ at every
    /// setting).
    pub contact_power: Option<ContactPower>,
}

/// κ(ρs) = κ_ref·(ρs/ρs_ref)^γ: ρs is proportional to N at a fixed μs,
/// so this is κ's power law in N (extrapolated by the law beyond the
/// logs' normal forces).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactPower {
    /// ρs at the reference normal force N_ref.
    pub rho_s_ref: f64,
    /// The exponent γ.
    pub exponent: f64,
}

impl PadShape {
    /// The paper's pad: symmetric, rigid.
    pub const PAPER: PadShape = PadShape {
        rs_minus_ratio: None,
        contact_stiffness: None,
        contact_power: None,
    };

    /// κ at a setting of static level `rho_s` (`None`: rigid).
    pub fn contact_at(&self, rho_s: f64) -> Option<f64> {
        let k = self.contact_stiffness?;
        Some(match self.contact_power {
            Some(p) if p.rho_s_ref > 0.0 && rho_s > 0.0 => {
                k * (rho_s / p.rho_s_ref).powf(p.exponent)
            }
            _ => k,
        })
    }
}

/// κ's power law in the normal force, fitted over the logs where a
/// constant κ does not explain them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NormalForceLaw {
    /// N_ref (N): the logs' weighted geometric mean normal force, where
    /// κ_ref's error is uncorrelated with γ's.
    pub reference_n: f64,
    /// The exponent γ of κ ∝ N^γ.
    pub exponent: f64,
    /// γ's 95 % interval (Birge-widened where the logs scatter about the
    /// power law beyond their intervals).
    pub exponent_interval: (f64, f64),
    /// χ² per degree of freedom of the logs about the power law.
    pub chi2_per_dof: f64,
    /// The constant κ's χ² minus the power law's.
    pub delta_chi2: f64,
}

/// One extension combined over the logs.
#[derive(Debug, Clone, PartialEq)]
pub struct Combined {
    /// The combined value (κ, or the ratio ρs⁻/ρs⁺; κ at N_ref where
    /// `by_normal_force` holds a power law).
    pub value: f64,
    /// Its 95 % interval (`None`: one log, without an interval of its
    /// own: nothing says how well it is known).
    pub interval: Option<(f64, f64)>,
    /// χ² per degree of freedom of the logs about one value (None: one
    /// log).
    pub chi2_per_dof: Option<f64>,
    /// κ's power law in N, where it explains the logs and one κ does not
    /// (the contact only).
    pub by_normal_force: Option<NormalForceLaw>,
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
    /// The corners of the simulated extensions' 95 % intervals, for the
    /// robust worst case: every combination of κ's ends, γ's ends (where κ
    /// depends on N) and ρs⁻/ρs⁺'s ends (an end that equals its value
    /// stands for itself; an extension without an interval, at its value).
    /// Empty for the rigid symmetric pad, or where no simulated extension
    /// has an interval.
    pub fn shape_variants(&self) -> Vec<PadShape> {
        let ends = |c: Option<&Combined>, interval: Option<(f64, f64)>, value: f64| -> Vec<f64> {
            c.filter(|c| c.used)
                .and(interval)
                .map_or(Vec::new(), |(lo, hi)| {
                    [lo, hi]
                        .into_iter()
                        .filter(|e| e.is_finite() && (e - value).abs() > 1e-12 * value.abs())
                        .collect()
                })
        };
        let contact = self.contact.as_ref();
        let power = contact.and_then(|c| c.by_normal_force);
        let kappas = ends(
            contact,
            contact.and_then(|c| c.interval).filter(|iv| iv.0 > 0.0),
            self.shape.contact_stiffness.unwrap_or(f64::NAN),
        );
        let gammas = ends(
            contact,
            power.map(|p| p.exponent_interval),
            power.map_or(f64::NAN, |p| p.exponent),
        );
        let split = self.split.as_ref();
        let ratios = ends(
            split,
            split.and_then(|c| c.interval).filter(|iv| iv.0 > 0.0),
            self.shape.rs_minus_ratio.unwrap_or(f64::NAN),
        );
        if kappas.is_empty() && gammas.is_empty() && ratios.is_empty() {
            return Vec::new();
        }
        let or_value = |e: Vec<f64>, v: Option<f64>| {
            if e.is_empty() {
                vec![v]
            } else {
                e.into_iter().map(Some).collect()
            }
        };
        let mut out = Vec::new();
        for k in or_value(kappas, self.shape.contact_stiffness) {
            for g in or_value(gammas.clone(), power.map(|p| p.exponent)) {
                for r in or_value(ratios.clone(), self.shape.rs_minus_ratio) {
                    out.push(PadShape {
                        contact_stiffness: k,
                        contact_power: self
                            .shape
                            .contact_power
                            .zip(g)
                            .map(|(p, exponent)| ContactPower { exponent, ..p }),
                        rs_minus_ratio: r,
                    });
                }
            }
        }
        out
    }

    /// Sets ρs_ref of κ's power law from N_ref (`rho_of`: N → ρs at the
    /// batch's μs and force scale).
    pub(super) fn set_reference(&mut self, rho_of: impl Fn(f64) -> f64) {
        let law = self.contact.as_ref().and_then(|c| c.by_normal_force);
        if let (Some(p), Some(law)) = (self.shape.contact_power.as_mut(), law) {
            p.rho_s_ref = rho_of(law.reference_n);
        }
    }
}

/// χ²₁'s 99 % point: κ's power law in N replaces one κ when the χ² falls
/// by more than this (in units of the power law's χ²/dof where above 1).
const CHI2_1_99: f64 = 6.635;

/// Per-log points of `combine`: ln v and its weight 1/σ², with how many
/// logs had an interval (logs without one count with the median weight of
/// the others, or all equally when none has one).
fn log_points(values: &[(f64, Option<(f64, f64)>)]) -> (Vec<(f64, f64)>, usize) {
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
    let mut known: Vec<f64> = pts.iter().filter_map(|p| p.1).collect();
    known.sort_by(f64::total_cmp);
    let fallback = known.get(known.len() / 2).copied().unwrap_or(1.0);
    let out = pts
        .iter()
        .map(|p| (p.0, 1.0 / p.1.unwrap_or(fallback).powi(2)))
        .collect();
    (out, known.len())
}

/// One log's κ at its normal force: (N, κ, κ's 95 % interval).
type KappaAt = (f64, f64, Option<(f64, f64)>);

/// κ's power law in N over the logs `(N, κ, interval)`, with κ at N_ref
/// and its 95 % interval; `None` unless at least three logs with
/// intervals at two or more normal forces explain a power law better than
/// one κ by [`CHI2_1_99`].
fn power_in_normal_force(values: &[KappaAt]) -> Option<(NormalForceLaw, f64, (f64, f64))> {
    let usable: Vec<&KappaAt> = values
        .iter()
        .filter(|(n, k, _)| n.is_finite() && *n > 0.0 && k.is_finite() && *k > 0.0)
        .collect();
    let (pts, known) = log_points(&usable.iter().map(|v| (v.1, v.2)).collect::<Vec<_>>());
    if known < 3 || pts.len() < 3 {
        return None;
    }
    let x: Vec<f64> = usable.iter().map(|v| v.0.ln()).collect();
    let sw: f64 = pts.iter().map(|p| p.1).sum();
    let xm = x.iter().zip(&pts).map(|(x, p)| x * p.1).sum::<f64>() / sw;
    let ym = pts.iter().map(|p| p.0 * p.1).sum::<f64>() / sw;
    let sxx: f64 = x
        .iter()
        .zip(&pts)
        .map(|(x, p)| p.1 * (x - xm).powi(2))
        .sum();
    if sxx.is_nan() || sxx <= 0.0 || sxx.is_infinite() {
        return None;
    }
    let sxy: f64 = x
        .iter()
        .zip(&pts)
        .map(|(x, p)| p.1 * (x - xm) * (p.0 - ym))
        .sum();
    let gamma = sxy / sxx;
    let chi2_const: f64 = pts.iter().map(|p| p.1 * (p.0 - ym).powi(2)).sum();
    let chi2_pow: f64 = x
        .iter()
        .zip(&pts)
        .map(|(x, p)| p.1 * (p.0 - ym - gamma * (x - xm)).powi(2))
        .sum();
    let dof = (pts.len() - 2) as f64;
    let birge = (chi2_pow / dof).max(1.0);
    let delta = chi2_const - chi2_pow;
    if delta.is_nan() || delta / birge <= CHI2_1_99 {
        return None;
    }
    let (s_g, s_a) = ((birge / sxx).sqrt(), (birge / sw).sqrt());
    let law = NormalForceLaw {
        reference_n: xm.exp(),
        exponent: gamma,
        exponent_interval: (gamma - 1.96 * s_g, gamma + 1.96 * s_g),
        chi2_per_dof: chi2_pow / dof,
        delta_chi2: delta,
    };
    Some((
        law,
        ym.exp(),
        ((ym - 1.96 * s_a).exp(), (ym + 1.96 * s_a).exp()),
    ))
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
    let (pts, known) = log_points(values);
    if pts.is_empty() {
        return None;
    }
    let w: Vec<f64> = pts.iter().map(|p| p.1).collect();
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
    if known == 0 {
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
        chi2_per_dof: chi2_per_dof.filter(|_| known > 0),
        by_normal_force: None,
        chosen,
        eligible,
        used: 2 * chosen >= eligible.max(1),
        in_robust: false,
    })
}

/// The contact stiffness over the logs that chose one (`kappas_at`, the
/// same as `kappas` without the normal force), of `eligible`: one κ, or
/// κ's power law in N where it explains the logs and one κ does not.
fn contact_model(
    kappas_at: &[KappaAt],
    kappas: &[(f64, Option<(f64, f64)>)],
    eligible: usize,
) -> Option<Combined> {
    let mut contact = combine(kappas, kappas.len(), eligible);
    if let (Some(c), Some((law, value, interval))) =
        (contact.as_mut(), power_in_normal_force(kappas_at))
    {
        c.by_normal_force = Some(law);
        c.value = value;
        c.interval = Some(interval);
    }
    contact
}

/// The warning for a simulated extension whose logs scatter about its
/// model (one value, or κ's power law in N) beyond their intervals: χ²/dof
/// above χ²'s 99 % point for the model's degrees of freedom (the logs'
/// count less one, or less two for the power law). Logs that agree within
/// their intervals pass it 99 times in 100.
fn scatter_warning(
    c: &Combined,
    values: &[(f64, Option<(f64, f64)>)],
    what: &str,
) -> Option<Warning> {
    let usable: Vec<f64> = values
        .iter()
        .map(|v| v.0)
        .filter(|v| v.is_finite() && *v > 0.0)
        .collect();
    let n = usable.len();
    let (chi2, dof, model) = match c.by_normal_force {
        Some(law) => (law.chi2_per_dof, n.checked_sub(2)?, "κ's power law in N"),
        None => (c.chi2_per_dof?, n.checked_sub(1)?, "one value"),
    };
    let interval = c.interval?;
    if dof == 0 || chi2.is_nan() {
        return None;
    }
    if chi2 <= crate::stats::chi_squared_quantile(0.99, dof as f64) / dof as f64 {
        return None;
    }
    Some(Warning::BatchPadScatter {
        extension: what.to_string(),
        model: model.to_string(),
        chi2_per_dof: chi2,
        dof,
        range: usable
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |a, &v| {
                (a.0.min(v), a.1.max(v))
            }),
        value: c.value,
        interval,
    })
}

/// The pad of the batch from its logs' fits; a warning for an extension
/// that some logs chose and the batch does not simulate, or whose logs
/// scatter beyond their intervals.
pub(super) fn batch_pad(fits: &[(PathBuf, LogFit)], warnings: &mut Vec<Warning>) -> BatchPad {
    // Logs whose refined fit saw M2 slide: they could have chosen either.
    let eligible: Vec<&LogFit> = fits
        .iter()
        .map(|(_, f)| f)
        .filter(|f| f.pads().is_some() && !f.stuck())
        .collect();
    let kappas_at: Vec<KappaAt> = eligible
        .iter()
        .filter_map(|f| {
            let k = f.contact_stiffness()?;
            let iv = f.pads().and_then(|p| p.contact_stiffness_interval);
            Some((f.normal_force_n, k, iv))
        })
        .collect();
    let kappas: Vec<(f64, Option<(f64, f64)>)> =
        kappas_at.iter().map(|&(_, k, iv)| (k, iv)).collect();
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
    let contact = contact_model(&kappas_at, &kappas, eligible.len());
    let split = combine(&splits, split_chosen, eligible.len());
    for (c, values, what) in [
        (&contact, &kappas, "a contact spring κ"),
        (&split, &splits, "a split static threshold ρs⁻/ρs⁺"),
    ] {
        if let Some(c) = c.as_ref().filter(|c| !c.used) {
            warnings.push(Warning::BatchPadNotSimulated {
                extension: what.to_string(),
                chosen: c.chosen,
                eligible: c.eligible,
                value: c.value,
            });
        }
        if let Some(w) = c
            .as_ref()
            .filter(|c| c.used)
            .and_then(|c| scatter_warning(c, values, what))
        {
            warnings.push(w);
        }
    }
    BatchPad {
        shape: PadShape {
            rs_minus_ratio: split.as_ref().filter(|c| c.used).map(|c| c.value),
            contact_stiffness: contact.as_ref().filter(|c| c.used).map(|c| c.value),
            contact_power: contact
                .as_ref()
                .filter(|c| c.used)
                .and_then(|c| c.by_normal_force)
                .map(|law| ContactPower {
                    rho_s_ref: f64::NAN,
                    exponent: law.exponent,
                }),
        },
        contact,
        split,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn combined(value: f64, interval: Option<(f64, f64)>, used: bool) -> Combined {
        Combined {
            value,
            interval,
            chi2_per_dof: None,
            by_normal_force: None,
            chosen: 2,
            eligible: 3,
            used,
            in_robust: false,
        }
    }

    /// The robust variants: the corners of the simulated extensions'
    /// intervals; an extension without an interval at its value; none for
    /// an extension not simulated, nor for the rigid symmetric pad.
    #[test]
    fn shape_variants_are_the_corners_of_the_intervals() {
        let c = combined;
        let shape = PadShape {
            rs_minus_ratio: Some(0.88),
            contact_stiffness: Some(17.2),
            contact_power: None,
        };
        let pad = BatchPad {
            shape,
            contact: Some(c(17.2, Some((16.0, 18.5)), true)),
            split: Some(c(0.88, Some((0.85, 0.91)), true)),
        };
        let v = pad.shape_variants();
        let kr = |k: f64, r: f64| PadShape {
            contact_stiffness: Some(k),
            rs_minus_ratio: Some(r),
            ..shape
        };
        assert_eq!(
            v,
            vec![
                kr(16.0, 0.85),
                kr(16.0, 0.91),
                kr(18.5, 0.85),
                kr(18.5, 0.91)
            ]
        );
        // The split without an interval: κ's ends at the split's value.
        let one = BatchPad {
            split: Some(c(0.88, None, true)),
            ..pad.clone()
        };
        assert_eq!(one.shape_variants(), vec![kr(16.0, 0.88), kr(18.5, 0.88)]);
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

    /// κ's power law in N: recovered from logs that follow one, with γ's
    /// interval holding it; refused for logs that agree on one κ, for
    /// logs that scatter about one κ without a trend, and for two logs.
    #[test]
    fn kappa_follows_the_normal_force_only_where_the_logs_say_so() {
        // κ = 17·(N/4)^0.5, known to ±3 % (95 %), slightly off the law.
        let iv = |k: f64| Some((k / 1.03, k * 1.03));
        let logs: Vec<KappaAt> = [(2.2, 1.004), (4.0, 0.997), (7.2, 1.002)]
            .iter()
            .map(|&(n, e)| {
                let k = 17.0 * (n / 4.0f64).powf(0.5) * e;
                (n, k, iv(k))
            })
            .collect();
        let (law, k_ref, (lo, hi)) = power_in_normal_force(&logs).expect("a power law");
        let (g_lo, g_hi) = law.exponent_interval;
        assert!(g_lo < 0.5 && 0.5 < g_hi, "{law:?}");
        assert!((law.exponent - 0.5).abs() < 0.05, "{law:?}");
        let truth = 17.0 * (law.reference_n / 4.0).powf(0.5);
        assert!(lo < truth && truth < hi && (k_ref / truth - 1.0).abs() < 0.02);
        assert!(law.delta_chi2 > CHI2_1_99, "{law:?}");
        // The shape simulates κ at each setting from it.
        let shape = PadShape {
            contact_stiffness: Some(k_ref),
            contact_power: Some(ContactPower {
                rho_s_ref: 0.5,
                exponent: law.exponent,
            }),
            ..PadShape::PAPER
        };
        let at = shape.contact_at(1.0).unwrap();
        assert!((at / (k_ref * 2f64.powf(law.exponent)) - 1.0).abs() < 1e-12);
        // One κ within the intervals: no law.
        let flat: Vec<_> = [(2.2, 17.1), (4.0, 16.9), (7.2, 17.05)]
            .iter()
            .map(|&(n, k)| (n, k, iv(k)))
            .collect();
        assert!(power_in_normal_force(&flat).is_none());
        // Scatter beyond the intervals without a trend: the power law
        // explains it no better (its own χ²/dof sets the scale).
        let scatter: Vec<_> = [
            (2.0, 17.0),
            (3.0, 22.0),
            (4.0, 14.0),
            (5.0, 22.0),
            (6.0, 17.0),
        ]
        .iter()
        .map(|&(n, k)| (n, k, iv(k)))
        .collect();
        assert!(power_in_normal_force(&scatter).is_none());
        // Two logs cannot tell a law from a misread log.
        assert!(power_in_normal_force(&logs[..2]).is_none());
        // Equal normal forces: no exponent.
        let same: Vec<_> = logs.iter().map(|&(_, k, iv)| (4.0, k, iv)).collect();
        assert!(power_in_normal_force(&same).is_none());
    }

    /// The batch says so where the logs scatter beyond their intervals
    /// about the simulated model, and stays silent where they agree.
    #[test]
    fn scattered_logs_are_said_to_scatter() {
        let iv = |k: f64| Some((k / 1.03, k * 1.03));
        // The contact model `batch_pad` builds: one value, or the power
        // law where it explains the logs.
        type Values = Vec<(f64, Option<(f64, f64)>)>;
        let model = |logs: &[KappaAt]| -> (Combined, Values) {
            let values: Vec<_> = logs.iter().map(|&(_, k, iv)| (k, iv)).collect();
            (contact_model(logs, &values, values.len()).unwrap(), values)
        };
        let warn = |logs: &[KappaAt]| {
            let (c, values) = model(logs);
            scatter_warning(&c, &values, "a contact spring κ")
        };
        let at = |pts: &[(f64, f64)]| -> Vec<KappaAt> {
            pts.iter().map(|&(n, k)| (n, k, iv(k))).collect()
        };
        // Agreeing logs; logs on a power law: silent.
        assert!(warn(&at(&[(2.2, 17.1), (4.0, 16.9), (7.2, 17.05)])).is_none());
        let law: Vec<(f64, f64)> = [(2.2, 1.004), (4.0, 0.997), (7.2, 1.002)]
            .iter()
            .map(|&(n, e)| (n, 17.0 * (n / 4.0f64).powf(0.5) * e))
            .collect();
        assert!(model(&at(&law)).0.by_normal_force.is_some());
        assert!(warn(&at(&law)).is_none());
        // Trendless scatter beyond the intervals: about one value.
        let scatter = at(&[
            (2.0, 17.0),
            (3.0, 22.0),
            (4.0, 14.0),
            (5.0, 22.0),
            (6.0, 17.0),
        ]);
        match warn(&scatter) {
            Some(Warning::BatchPadScatter {
                model,
                dof,
                chi2_per_dof,
                interval,
                ..
            }) => {
                assert_eq!((model.as_str(), dof), ("one value", 4));
                assert!(chi2_per_dof > 50.0, "{chi2_per_dof}");
                // Birge-widened: the logs' own ±3 % would give ±1.3 %.
                assert!(interval.1 / interval.0 > 1.3, "{interval:?}");
            }
            w => panic!("{w:?}"),
        }
        // A trend with scatter about it: the power law is simulated and
        // the logs scatter about it.
        let rough: Vec<(f64, f64)> = [(2.0, 1.0), (3.0, 1.12), (4.0, 0.9), (5.0, 1.1), (6.0, 0.92)]
            .iter()
            .map(|&(n, e)| (n, 17.0 * (n / 4.0f64).powf(1.0) * e))
            .collect();
        assert!(model(&at(&rough)).0.by_normal_force.is_some());
        match warn(&at(&rough)) {
            Some(Warning::BatchPadScatter { model, dof, .. }) => {
                assert_eq!((model.as_str(), dof), ("κ's power law in N", 3));
            }
            w => panic!("{w:?}"),
        }
        // One log: nothing to scatter.
        assert!(warn(&at(&[(4.0, 17.0)])).is_none());
    }

    /// Where κ depends on N, the corners also take γ's ends.
    #[test]
    fn the_corners_take_the_exponents_ends() {
        let mut contact = combined(17.0, Some((16.5, 17.5)), true);
        contact.by_normal_force = Some(NormalForceLaw {
            reference_n: 4.0,
            exponent: 0.5,
            exponent_interval: (0.4, 0.6),
            chi2_per_dof: 0.3,
            delta_chi2: 40.0,
        });
        let mut pad = BatchPad {
            shape: PadShape {
                contact_stiffness: Some(17.0),
                contact_power: Some(ContactPower {
                    rho_s_ref: f64::NAN,
                    exponent: 0.5,
                }),
                rs_minus_ratio: None,
            },
            contact: Some(contact),
            split: None,
        };
        pad.set_reference(|n| 0.25 * n);
        assert_eq!(pad.shape.contact_power.unwrap().rho_s_ref, 1.0);
        let v: Vec<(f64, f64)> = pad
            .shape_variants()
            .iter()
            .map(|s| {
                (
                    s.contact_stiffness.unwrap(),
                    s.contact_power.unwrap().exponent,
                )
            })
            .collect();
        assert_eq!(v, vec![(16.5, 0.4), (16.5, 0.6), (17.5, 0.4), (17.5, 0.6)]);
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
