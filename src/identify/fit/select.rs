//! The candidate laws of a log and the choice among them: each family's
//! robust slip fit, its Rs (breakaways, or the slip level), its BIC with an
//! honest effective sample size, and the law it stands for.

use super::bounds::Brk;
use super::slip::{irls, rss, Sample};
use super::{bic, offset_at};
use crate::model::{LawKind, SiLaw};
use crate::stats::median;
use crate::warning::Warning;

/// One family's robust slip fit.
pub(super) struct Cand {
    /// The family.
    pub kind: LawKind,
    /// Coefficients: bias, the law's terms, the two gain-error terms.
    pub coef: Vec<f64>,
    /// Final Huber weights.
    pub w: Vec<f64>,
    /// Residuals.
    pub res: Vec<f64>,
    /// The velocity scale it was fitted with (1.0 where unused).
    pub vs: f64,
}

/// The candidates: each family of `kinds` with its velocity scale (1.0
/// where unused), fitted by IRLS.
pub(super) fn candidates(samples: &[Sample], kinds: &[(LawKind, f64)]) -> Vec<Cand> {
    kinds
        .iter()
        .filter_map(|&(kind, vs)| {
            irls(samples, kind, vs).map(|(coef, w, res)| Cand {
                kind,
                coef,
                w,
                res,
                vs,
            })
        })
        .collect()
}

/// Rs of a candidate ([`crate::model::LawFamily::ee_rs`]): for a family
/// whose threshold is the breakaway level, the median breakaway level (bias
/// and gain terms removed; robust to a mislocated breakaway or a spike).
pub(super) fn rs_of(cand: &Cand, brks: &[Brk]) -> f64 {
    let family = cand.kind.family();
    let breakaway = if family.rs_from_breakaways() {
        median(
            &brks
                .iter()
                .map(|k| k.f - k.dir * offset_at(&cand.coef, k.k1, k.k2))
                .collect::<Vec<_>>(),
        )
    } else {
        f64::NAN
    };
    family.ee_rs(&cand.coef, breakaway)
}

/// BIC of each admissible candidate: its slip part with `n_eff` effective
/// samples, plus its breakaway part (one observation per transition)
/// where the log sticks. A family's coefficients must be the family's
/// ([`crate::model::LawFamily::ee_admissible`]: static-dynamic needs
/// Rs > Rd, the Stribeck type a peak): otherwise it is no candidate.
pub(super) fn criteria(
    cands: &[Cand],
    samples: &[Sample],
    brks: &[Brk],
    n_eff: f64,
    never_sticks: bool,
) -> Vec<(LawKind, f64)> {
    let mut criteria = Vec::new();
    for cand in cands {
        let family = cand.kind.family();
        if !family.ee_admissible(&cand.coef, rs_of(cand, brks)) {
            continue;
        }
        // A velocity scale is fitted too (profiled by the scan).
        let k_slip = cand.coef.len() + usize::from(family.has_velocity_scale());
        let rss = rss(samples, &cand.coef, Some(&cand.w), cand.kind, cand.vs);
        let wsum: f64 = cand.w.iter().sum();
        let mut crit = bic(
            rss,
            wsum.round().max(1.0) as usize,
            n_eff * wsum / samples.len() as f64,
            k_slip,
        );
        if !never_sticks && !brks.is_empty() {
            let rs = rs_of(cand, brks);
            let rss_b: f64 = brks
                .iter()
                .map(|k| (k.f - k.dir * offset_at(&cand.coef, k.k1, k.k2) - rs).powi(2))
                .sum();
            let kb = usize::from(family.rs_from_breakaways());
            let m = brks.len();
            crit += bic(rss_b, m, m as f64, kb);
        }
        criteria.push((cand.kind, crit));
    }
    criteria
}

/// The family with the least criterion (Coulomb where none).
pub(super) fn best_kind(criteria: &[(LawKind, f64)]) -> LawKind {
    criteria
        .iter()
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|c| c.0)
        .unwrap_or(LawKind::Coulomb)
}

/// The family reported: the one asked for where it could be fitted (a
/// warning where not), else the least BIC. In a never-sticking log Rs is
/// not observed, so a family whose threshold is the breakaway level
/// (static-dynamic) cannot be told from Coulomb: the choice is among the
/// slip-only families.
pub(super) fn choose(
    asked: Option<LawKind>,
    cands: &[Cand],
    criteria: &[(LawKind, f64)],
    never_sticks: bool,
    warnings: &mut Vec<Warning>,
) -> LawKind {
    let chosen = match asked {
        Some(k) if cands.iter().any(|c| c.kind == k) => k,
        Some(_) | None if criteria.is_empty() => LawKind::Coulomb,
        Some(k) => {
            warnings.push(Warning::LawNotFitted { law: k });
            best_kind(criteria)
        }
        None => best_kind(criteria),
    };
    if never_sticks && chosen.family().rs_from_breakaways() && asked.is_none() {
        LawKind::Coulomb
    } else {
        chosen
    }
}

/// The SI law a candidate stands for.
pub(super) fn to_law(cand: &Cand, brks: &[Brk]) -> SiLaw {
    cand.kind
        .family()
        .ee_law(&cand.coef, rs_of(cand, brks), cand.vs)
}
