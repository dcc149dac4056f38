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
    /// The Stribeck velocity it was fitted with (1.0 where unused).
    pub vs: f64,
}

/// The candidates: Coulomb, decreasing, static-dynamic, and the Stribeck
/// type where a Stribeck velocity was resolved; each fitted by IRLS.
pub(super) fn candidates(samples: &[Sample], stribeck_vs: Option<f64>) -> Vec<Cand> {
    let mut kinds = vec![
        LawKind::Coulomb,
        LawKind::Decreasing,
        LawKind::StaticDynamic,
    ];
    if stribeck_vs.is_some() {
        kinds.push(LawKind::Stribeck);
    }
    let vs = stribeck_vs.unwrap_or(1.0);
    kinds
        .into_iter()
        .filter_map(|kind| {
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

/// Rs of a candidate: the median breakaway level (bias and gain terms
/// removed; robust to a mislocated breakaway or a spike) for static-dynamic,
/// g(0+) for the Stribeck type, the slip level otherwise.
pub(super) fn rs_of(cand: &Cand, brks: &[Brk]) -> f64 {
    match cand.kind {
        LawKind::StaticDynamic => median(
            &brks
                .iter()
                .map(|k| k.f - k.dir * offset_at(&cand.coef, k.k1, k.k2))
                .collect::<Vec<_>>(),
        ),
        LawKind::Stribeck => cand.coef[1] + cand.coef[2],
        _ => cand.coef[1],
    }
}

/// BIC of each admissible candidate: its slip part with `n_eff` effective
/// samples, plus its breakaway part (one observation per transition)
/// where the log sticks. Static-dynamic needs Rs > Rd, the Stribeck type a
/// peak: otherwise they are not candidates.
pub(super) fn criteria(
    cands: &[Cand],
    samples: &[Sample],
    brks: &[Brk],
    n_eff: f64,
    never_sticks: bool,
) -> Vec<(LawKind, f64)> {
    let mut criteria = Vec::new();
    for cand in cands {
        // Static > dynamic is the family's definition: a breakaway level at
        // or below the slip level is not this family.
        if cand.kind == LawKind::StaticDynamic
            && rs_of(cand, brks).partial_cmp(&cand.coef[1]) != Some(std::cmp::Ordering::Greater)
        {
            continue;
        }
        // Likewise the Stribeck type needs a peak (ρs > ρd): a dip or a
        // vanishing peak is a simple law with an idle extra term.
        if cand.kind == LawKind::Stribeck
            && cand.coef[2].partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater)
        {
            continue;
        }
        // The Stribeck velocity is fitted too (profiled by the scan).
        let k_slip = cand.coef.len() + usize::from(cand.kind == LawKind::Stribeck);
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
            let kb = usize::from(cand.kind == LawKind::StaticDynamic);
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
/// not observed, so static-dynamic cannot be told from Coulomb: the choice
/// is among the slip-only families.
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
    if never_sticks && chosen == LawKind::StaticDynamic && asked.is_none() {
        LawKind::Coulomb
    } else {
        chosen
    }
}

/// The SI law a candidate stands for.
pub(super) fn to_law(cand: &Cand, brks: &[Brk]) -> SiLaw {
    let rs = rs_of(cand, brks);
    let (rs_n, slope, vs) = match cand.kind {
        LawKind::Coulomb => (cand.coef[1], 0.0, None),
        LawKind::Decreasing => (cand.coef[1], cand.coef[2], None),
        LawKind::StaticDynamic => (rs, 0.0, None),
        LawKind::Stribeck => (rs, cand.coef[3], Some(cand.vs)),
    };
    SiLaw {
        kind: cand.kind,
        rs_n,
        rd_n: cand.coef[1],
        slope_n_s_per_m: slope,
        vs_m_per_s: vs,
    }
}
