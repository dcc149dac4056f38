//! The static threshold's profile behind a contact spring: where the log
//! does not resolve Rs above Rd, the local (sandwich) interval of κ is
//! conditional on the threshold sitting where the fit left it (often at
//! Rs = Rd, the family's bound), and misses when the true threshold is
//! higher. The profile holds Rs at a ladder of values, refits the rest,
//! keeps the values the criterion's deviance admits, and gives Rs's upper
//! bound (with the calibration budget: the gains' linear response, and the
//! profile again on the records shifted by their alignment's uncertainty)
//! and κ's interval over every admitted threshold.

use super::*;
use crate::identify::Interval;

/// Steps out from the fitted threshold, each twice the last (the first
/// half a noise unit: see [`Refinement::profile_threshold`]).
const MAX_STEPS: usize = 10;

/// Bisections between the last admitted and the first refused threshold.
const BISECTIONS: usize = 3;

/// What the profile in Rs says (see the module comment).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct ThresholdProfile {
    /// The largest Rs (N) the log admits; None where the ladder never
    /// reached a refused value (no upper bound within 2^MAX_STEPS noise
    /// units), on the log or on it with a channel shifted by its
    /// alignment's uncertainty.
    pub rs_upper_n: Option<f64>,
    /// κ's 95 % interval: the union of its intervals conditional on each
    /// admitted Rs.
    pub kappa_interval: Option<Interval>,
}

impl Refinement {
    /// The profile in Rs of `base`, a static-dynamic fit behind a contact
    /// spring, whose cost is the lowest of its extension. The deviance
    /// is calibrated to the sandwich (the intervals' own variance, robust
    /// to correlated residuals): Δcost·(H⁻¹)κκ/Var(ln κ), with Rs held at
    /// the base, admits up to (t₀.₉₇₅·inflation)², as the Student-t
    /// interval does. The ladder's unit is the force that deflects the
    /// contact by one noise σ of x2, kt·σ₂ (the threshold shows only as
    /// the extra deflection (Rs − Rd)/kt).
    pub(super) fn profile_threshold(
        &self,
        base: &Refined,
        inflation: f64,
        u: f64,
    ) -> Option<ThresholdProfile> {
        if base.kind != LawKind::StaticDynamic || !base.ext.contact {
            return None;
        }
        let fam = base.fam();
        let kappa = self.problem(&self.data, fam).ext_values(&base.th).kappa?;
        let unit = kappa * self.rig.k2 * self.data.sig.1;
        if !(unit.is_finite() && unit > 0.0) {
            return None;
        }
        let (rs0, rd0) = (base.th[0], base.th[1]);
        // The minimiser's steps: all free (`free`), and with Rs held.
        let free = Self::ext_steps(fam, &base.th);
        let mut step = free.clone();
        step[0] = 0.0;
        // The calibration of the deviance, along ln κ (the last of θ).
        let base_proj = self.proj_of(fam, &base.proj_at)?;
        let v = self
            .variances(fam, &base.th, &base_proj, u, inflation, &[0])
            .ok()?;
        let k = base.th.len() - 1;
        let scale = v.naive_stat[k] / v.stat[k];
        if !(scale.is_finite() && scale > 0.0) {
            return None;
        }
        let crit = (v.t975 * inflation.max(1.0)).powi(2);
        // (Rs, cost, θ, projection; None: the base's own.)
        type Point = (f64, f64, Vec<f64>, Option<ProjAt>);
        let cmin = |pts: &[Point]| pts.iter().map(|p| p.1).fold(f64::INFINITY, f64::min);
        let deviance = |c: f64, cm: f64| (c - cm) * scale;
        let admitted = |c: f64, cm: f64| deviance(c, cm) <= crit;
        let fit = |data: &Data, rs: f64, from: &[f64]| -> Option<Point> {
            let mut th = from.to_vec();
            th[0] = rs;
            let (th, cost, _, proj) = self.minimise_on(data, fam, &[th], &step).ok()?;
            Some((rs, cost, th, Some(proj)))
        };
        let floor = rs0.max(rd0);
        // Up from `start` on `data`: doubling steps until the deviance
        // refuses, then bisections. Every point fitted, and the first
        // refused threshold (None: none refused).
        let ladder = |data: &Data, start: Point| -> (Vec<Point>, Option<f64>) {
            let mut lo = (floor, start.2.clone());
            let mut points = vec![start];
            let mut hi = None;
            // Refits at Rs = r from the last admitted θ and records the
            // point; an admitted one becomes the last admitted.
            let step_to = |r: f64, lo: &mut (f64, Vec<f64>), points: &mut Vec<Point>| -> bool {
                let pt = fit(data, r, &lo.1);
                let ok = pt
                    .as_ref()
                    .is_some_and(|p| admitted(p.1, cmin(points).min(p.1)));
                if let (true, Some(p)) = (ok, pt.as_ref()) {
                    *lo = (r, p.2.clone());
                }
                points.extend(pt);
                ok
            };
            let mut c = 0.5;
            for _ in 0..MAX_STEPS {
                let r = floor + c * unit;
                if !step_to(r, &mut lo, &mut points) {
                    hi = Some(r);
                    break;
                }
                c *= 2.0;
            }
            if let Some(mut h) = hi {
                for _ in 0..BISECTIONS {
                    let r = 0.5 * (lo.0 + h);
                    if !step_to(r, &mut lo, &mut points) {
                        h = r;
                    }
                }
            }
            (points, hi)
        };
        let (mut points, hi) = ladder(&self.data, (rs0, base.cost, base.th.clone(), None));
        // Down to the sliding level, where the fit left the threshold above
        // it by more than a quarter unit.
        if rs0 - rd0 > 0.25 * unit {
            for r in [rd0 + 0.5 * (rs0 - rd0), rd0] {
                points.extend(fit(&self.data, r, &base.th));
            }
        }
        let cm = cmin(&points);
        let kept: Vec<&Point> = points.iter().filter(|p| admitted(p.1, cm)).collect();
        // The highest admitted threshold, plus the calibration budget's
        // part of Rs there (in quadrature, as the intervals add them): the
        // gains' part by its linear response; the alignment's by the
        // profile again on the log with the drive's, then x2's record
        // shifted by ± its standard uncertainty (how far the highest
        // admitted threshold rises there; no bound where it has none).
        // (The linear response is no small perturbation to the alignment
        // at a threshold the log does not resolve: on a 20-µm contact it
        // put the bound at 3.7 N for a true 0.924 N; the deviance's change
        // over its slope at the top, by refits or to second order, put
        // c004's at 10.5 N for 0.619 N.)
        let top = kept.iter().max_by(|a, b| a.0.total_cmp(&b.0))?;
        let rs_upper_n = match hi {
            Some(_) => {
                let proj = match &top.3 {
                    Some(at) => self.proj_of(fam, at)?,
                    None => self.proj_of(fam, &base.proj_at)?,
                };
                let cal = self
                    .variances(fam, &top.2, &proj, u, inflation, &[])
                    .ok()?
                    .var_cal[0];
                // The highest admitted threshold on `data` (infinite where
                // the ladder never refuses; None where the base cannot be
                // refitted).
                let top_on = |data: &Data| -> Option<f64> {
                    let (th, cost, _, at) = self
                        .minimise_on(data, fam, std::slice::from_ref(&base.th), &free)
                        .ok()?;
                    let (pts, hi) = ladder(data, (th[0], cost, th, Some(at)));
                    if hi.is_none() {
                        return Some(f64::INFINITY);
                    }
                    let cm = cmin(&pts);
                    pts.iter()
                        .filter(|p| admitted(p.1, cm))
                        .map(|p| p.0)
                        .max_by(f64::total_cmp)
                };
                // An upper bound: each channel's larger rise of the two
                // signs of its shift.
                let (s0, s2) = self.alignment_sigma;
                let align: f64 = [(s0, 0.0), (0.0, s2)]
                    .into_iter()
                    .filter(|(a, b)| a + b > 0.0)
                    .map(|(a, b)| {
                        [1.0, -1.0]
                            .into_iter()
                            .filter_map(|sg| top_on(&self.data.shifted(sg * a, sg * b)))
                            .map(|t| (t - top.0).max(0.0))
                            .fold(0.0, f64::max)
                            .powi(2)
                    })
                    .sum();
                Some(floor + ((top.0 - floor).powi(2) + 1.96 * 1.96 * (cal + align)).sqrt())
                    .filter(|b| b.is_finite())
            }
            None => None,
        };
        let mut kappa_interval: Option<Interval> = None;
        for (_, _, th, proj) in &kept {
            let Some(proj) = self.proj_of(fam, proj.as_ref().unwrap_or(&base.proj_at)) else {
                continue;
            };
            let Ok((_, pads, ..)) = self.intervals(fam, th, &proj, u, true, inflation, &[0]) else {
                continue;
            };
            if let Some((a, b)) = pads.contact_stiffness_interval {
                kappa_interval = Some(match kappa_interval {
                    Some((l, h)) => (l.min(a), h.max(b)),
                    None => (a, b),
                });
            }
        }
        Some(ThresholdProfile {
            rs_upper_n,
            kappa_interval,
        })
    }
}
