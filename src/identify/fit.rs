//! Equation-error fit of the friction law to the characteristic R(ẋ2).
//!
//! * **Slip samples** (M2 slides, |ẋ2| above the upper hysteresis threshold,
//!   away from transitions by one smoothing window) are regressed as
//!   `R = b + sgn(v)·(Rd + a·|v|)` by iteratively re-weighted least squares
//!   with Huber weights (k = 1.345 robust σ). The constant `b` is the force
//!   bias from the unknown position offsets: it is identified by the
//!   symmetry of the slip levels (+Rd on forward, −Rd on backward slips).
//! * **Breakaways**: at each located stick → slip transition the passive
//!   force (a straight line fitted over the last smoothing window of the
//!   stick, evaluated at the breakaway time) minus the bias, in the slip's
//!   direction, is one observation of Rs. Averaging over transitions and the
//!   hinge location of the breakaway keep it robust to noise and spikes.
//! * **Law selection**: Coulomb (Rs = Rd, a = 0), `decreasing` (Rs = Rd,
//!   a ≠ 0 of either sign), `static-dynamic` (Rs > Rd, a = 0), and the
//!   Stribeck-type law, by BIC. The slip part uses an honest effective
//!   sample size n_eff = min(n / τ_int, n / (2h + 1)): τ_int is the integrated
//!   autocorrelation time of the residuals of the richest model, and no more
//!   than one observation per smoothing window of 2h + 1 samples (the
//!   smoothed velocity and a differentiated acceleration share their
//!   samples); the breakaway part counts transitions. Static-dynamic is only
//!   a candidate when its breakaway level exceeds the slip level, the
//!   Stribeck type only with a peak (ρs > ρd); its velocity v_s counts as
//!   a parameter. Where the output-error refinement applies, its own
//!   criterion decides the family (see `output_error`); every simple
//!   family's law here is kept as its start (`candidates`).
//! * **Stribeck**: `g(v) = Rd + (Rs − Rd)·exp(−(v/v_s)²) + a·v` by variable
//!   projection: for given v_s the law is linear in (b, Rd, Rs − Rd, a);
//!   v_s by golden-section search on log v_s.
//! * **Statistical intervals**: bootstrap over drive periods (slip samples
//!   and transitions of a period are resampled together; the normal
//!   equations are accumulated per period so each replicate is a small
//!   solve). The Stribeck velocity is held at its estimate in the bootstrap.
//! * **Bounds instead of inventions**: a stuck log gives only a lower bound
//!   on Rs (half the peak-to-peak passive force: the bias is unknown, and the
//!   largest true force is at least that); a never-sticking log bounds Rs
//!   from above by the passive force at each reversal (the mass did not stick
//!   there, so it exceeded Rs) and from below by Rd.

use super::contact::Contact;
use super::segment::Segmentation;
use super::smooth::{savgol, Normal};
use crate::stats::golden_section;
use crate::stats::Rng;
use crate::stats::{mad_sigma, median, quantile};

use crate::model::{LawKind, SiLaw};

/// Options of the equation-error fit.
#[derive(Debug, Clone)]
pub struct FitOptions {
    /// Force a family (None: choose by BIC).
    pub law: Option<LawKind>,
    /// Bootstrap replicates (0: no statistical intervals).
    pub bootstrap: usize,
    /// Seed of the bootstrap.
    pub seed: u64,
}

impl Default for FitOptions {
    fn default() -> Self {
        Self {
            law: None,
            bootstrap: 400,
            seed: 0x5eed,
        }
    }
}

/// 2.5 % and 97.5 % bootstrap percentiles of the parameters (SI).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct StatIntervals {
    /// Rs (N).
    pub rs: Option<(f64, f64)>,
    /// Rd (N).
    pub rd: Option<(f64, f64)>,
    /// a (N·s/m).
    pub slope: Option<(f64, f64)>,
}

/// What the equation-error fit found in one log (SI).
#[derive(Debug, Clone)]
pub struct EquationFit {
    /// The chosen law (for a never-sticking log Rs is NaN; for a stuck log
    /// everything but the lower bound is NaN).
    pub law: SiLaw,
    /// The best simple-family law when the Stribeck type was chosen.
    pub simple: Option<SiLaw>,
    /// The Stribeck fit, when computed and meaningful.
    pub stribeck: Option<SiLaw>,
    /// Bootstrap intervals.
    pub stat: StatIntervals,
    /// M2 never slid: only `rs_lower_bound_n` is known.
    pub stuck: bool,
    /// Lower bound on Rs of a stuck log (N).
    pub rs_lower_bound_n: Option<f64>,
    /// M2 never stuck: Rs is only bounded.
    pub never_sticks: bool,
    /// Upper bound on Rs from the reversals of a never-sticking log (N).
    pub rs_upper_bound_n: Option<f64>,
    /// Force bias removed (N).
    pub bias_n: f64,
    /// RMS of the slip residuals of the chosen law (N).
    pub residual_rms_n: f64,
    /// Slip samples used.
    pub n_slip: usize,
    /// Their effective number.
    pub n_eff: f64,
    /// Breakaways used.
    pub n_breakaways: usize,
    /// Per-breakaway Rs estimates (N, bias removed).
    pub breakaway_forces_n: Vec<f64>,
    /// BIC of every family considered (lower is better).
    pub criteria: Vec<(LawKind, f64)>,
    /// The equation-error law of every simple family that could be fitted
    /// (start values of the output-error refinement; for static-dynamic
    /// also when its breakaway level is not above the slip level).
    pub candidates: Vec<SiLaw>,
    /// Things the user should know.
    pub warnings: Vec<String>,
}

/// One slip sample.
struct Sample {
    r: f64,
    s: f64,
    u: f64,
    /// K2·x1 and K2·x2, centred (N): regressors of the position sensors'
    /// relative gain errors.
    k1: f64,
    k2: f64,
    period: usize,
}

/// One breakaway: direction·passive force (bias included) and its period.
struct Brk {
    f: f64,
    k1: f64,
    k2: f64,
    dir: f64,
    period: usize,
}

/// Regressors of a slip sample: bias, the law's terms, then K2·x1 and K2·x2.
///
/// The last two absorb the position sensors' gain errors: a gain error ε
/// on x_i adds K2·ε·x_i to the computed force, a shape that neither the
/// bias nor the law can take, so the slip data identify it ("what the
/// physics gives for free"); only a common scale of both remains, and that
/// stays in the calibration budget.
fn basis(kind: LawKind, smp: &Sample, vs: f64) -> Row {
    let (s, u) = (smp.s, smp.u);
    let (k1, k2) = (smp.k1, smp.k2);
    match kind {
        LawKind::Coulomb | LawKind::StaticDynamic => Row([1.0, s, k1, k2, 0.0, 0.0], 4),
        LawKind::Decreasing => Row([1.0, s, s * u, k1, k2, 0.0], 5),
        LawKind::Stribeck => Row([1.0, s, s * (-(u / vs).powi(2)).exp(), s * u, k1, k2], 6),
    }
}

/// One row of regressors, on the stack (at most six).
struct Row([f64; 6], usize);

impl std::ops::Deref for Row {
    type Target = [f64];
    fn deref(&self) -> &[f64] {
        &self.0[..self.1]
    }
}

/// Bias plus gain-error correction of a model at positions (k1, k2).
fn offset_at(coef: &[f64], k1: f64, k2: f64) -> f64 {
    let p = coef.len();
    coef[0] + coef[p - 2] * k1 + coef[p - 1] * k2
}

/// Robust (Huber IRLS) fit of one slip model; returns coefficients, final
/// weights and residuals.
fn irls(samples: &[Sample], kind: LawKind, vs: f64) -> Option<(Vec<f64>, Vec<f64>, Vec<f64>)> {
    let mut w = vec![1.0; samples.len()];
    let mut coef = Vec::new();
    let mut res = vec![0.0; samples.len()];
    let mut prev: Option<Vec<f64>> = None;
    for _ in 0..8 {
        let p = basis(kind, &samples[0], vs).len();
        let mut ne = Normal::new(p);
        for (smp, wi) in samples.iter().zip(&w) {
            ne.add(&basis(kind, smp, vs), smp.r, *wi);
        }
        coef = ne.solve()?;
        // Converged: the weights would not change the fit any more.
        let done = prev.as_ref().is_some_and(|q: &Vec<f64>| {
            q.iter()
                .zip(&coef)
                .all(|(a, b)| (a - b).abs() <= 1e-9 * (1.0 + b.abs()))
        });
        prev = Some(coef.clone());
        for (k, smp) in samples.iter().enumerate() {
            let x = basis(kind, smp, vs);
            res[k] = smp.r - x.iter().zip(&coef).map(|(a, b)| a * b).sum::<f64>();
        }
        let sigma = mad_sigma(&res).max(1e-12);
        let c = 1.345 * sigma;
        if done {
            break;
        }
        for (wi, r) in w.iter_mut().zip(&res) {
            *wi = if r.abs() <= c { 1.0 } else { c / r.abs() };
        }
    }
    Some((coef, w, res))
}

/// Integrated autocorrelation time of residuals over contiguous sample runs
/// (`idx`: each residual's sample index).
fn tau_int(res: &[f64], idx: &[usize]) -> f64 {
    super::smooth::tau_int(res, 2000, 10, |k, lag| idx[k + lag] == idx[k] + lag)
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

fn bic(rss: f64, n: usize, n_eff: f64, k: usize) -> f64 {
    let n_eff = n_eff.max(k as f64 + 1.0);
    n_eff * (rss / n as f64).max(1e-300).ln() + k as f64 * n_eff.ln()
}

/// Fits the friction law of one log (equation error).
pub fn fit(
    c: &Contact,
    seg: &Segmentation,
    opts: &FitOptions,
) -> Result<EquationFit, super::IdentifyError> {
    let n = c.r.len();
    let half = c.half_window;
    let f_drive = c.drive.frequency_hz;
    let period_of = |i: f64| ((i * c.dt * f_drive).max(0.0)) as usize;
    let mut warnings = Vec::new();

    // Distance (samples) to the nearest stick, to keep slip samples away
    // from transitions by one smoothing window.
    let mut near = vec![usize::MAX; n];
    let mut last = None;
    for i in 0..n {
        if seg.stick[i] {
            last = Some(i);
        }
        if let Some(l) = last {
            near[i] = i - l;
        }
    }
    last = None;
    for i in (0..n).rev() {
        if seg.stick[i] {
            last = Some(i);
        }
        if let Some(l) = last {
            near[i] = near[i].min(l - i);
        }
    }
    // Centres of K2·x1, K2·x2 over the log (the gain-error regressors).
    let k2c = |x: &[f64]| -> f64 {
        let fin: Vec<f64> = x.iter().copied().filter(|v| v.is_finite()).collect();
        fin.iter().sum::<f64>() / fin.len().max(1) as f64
    };
    let (m1, m2) = (k2c(&c.x1), k2c(&c.x2));
    let kk = c.k2_n_per_m;
    let kx = |i: usize| -> (f64, f64) { (kk * (c.x1[i] - m1), kk * (c.x2[i] - m2)) };
    let mut samples = Vec::new();
    let mut idx = Vec::new();
    for i in 0..n {
        let (r, v) = (c.r[i], c.v2_smooth[i]);
        if seg.stick[i] || !r.is_finite() || !v.is_finite() || v.abs() <= seg.hi || near[i] <= half
        {
            continue;
        }
        let (k1, k2) = kx(i);
        if !(k1.is_finite() && k2.is_finite()) {
            continue;
        }
        samples.push(Sample {
            r,
            s: v.signum(),
            u: v.abs(),
            k1,
            k2,
            period: period_of(i as f64),
        });
        idx.push(i);
    }
    let n_periods = period_of(n as f64) + 1;

    if seg.stuck() || samples.len() < 20 {
        // Only a lower bound: half the peak-to-peak smoothed passive force,
        // minus two noise levels so noise cannot inflate it.
        let p = savgol(&c.passive, c.dt, half, 3, 0);
        let noise = mad_sigma(
            &c.passive
                .iter()
                .zip(&p)
                .map(|(a, b)| a - b)
                .collect::<Vec<_>>(),
        );
        let h = half as f64;
        let noise_s = noise / (2.0 * h + 1.0).sqrt();
        let hi = quantile(&p, 1.0);
        let lo = quantile(&p, 0.0);
        let lb = ((hi - lo) / 2.0 - 2.0 * noise_s).max(0.0);
        if !seg.stuck() {
            warnings.push(format!(
                "M2 slid in only {} usable samples: reported as stuck",
                samples.len()
            ));
        }
        let nan = f64::NAN;
        return Ok(EquationFit {
            law: SiLaw {
                kind: opts.law.unwrap_or(LawKind::StaticDynamic),
                rs_n: nan,
                rd_n: nan,
                slope_n_s_per_m: nan,
                vs_m_per_s: None,
            },
            simple: None,
            stribeck: None,
            stat: StatIntervals::default(),
            stuck: true,
            rs_lower_bound_n: Some(lb),
            never_sticks: false,
            rs_upper_bound_n: None,
            bias_n: nan,
            residual_rms_n: nan,
            n_slip: samples.len(),
            n_eff: 0.0,
            n_breakaways: 0,
            breakaway_forces_n: Vec::new(),
            criteria: Vec::new(),
            candidates: Vec::new(),
            warnings,
        });
    }

    // Breakaway observations.
    let mut brks = Vec::new();
    for b in &seg.breakaways {
        let end = b.at.floor() as usize;
        let start = b.stick.0.max(end.saturating_sub(2 * half + 1));
        if end <= start + 3 {
            continue;
        }
        let at = (b.at.round().max(0.0) as usize).min(n - 1);
        let (k1, k2) = kx(at);
        if !(k1.is_finite() && k2.is_finite()) {
            continue;
        }
        if let Some((p, _)) = line_at(&c.passive, start, end.min(n - 1), b.at) {
            brks.push(Brk {
                f: b.direction * p,
                k1,
                k2,
                dir: b.direction,
                period: period_of(b.at),
            });
        }
    }
    let never_sticks = seg.never_sticks();

    // Stribeck fit by variable projection over log v_s.
    let umax = samples.iter().map(|s| s.u).fold(0.0, f64::max);
    let umin = seg.hi.max(1e-9);
    let rss_of = |coef: &[f64], w: &[f64], kind: LawKind, vs: f64| -> f64 {
        samples
            .iter()
            .zip(w)
            .map(|(smp, wi)| {
                let x = basis(kind, smp, vs);
                wi * (smp.r - x.iter().zip(coef).map(|(a, b)| a * b).sum::<f64>()).powi(2)
            })
            .sum()
    };
    let plain_rss = |coef: &[f64], kind: LawKind, vs: f64| -> f64 {
        samples
            .iter()
            .map(|smp| {
                let x = basis(kind, smp, vs);
                (smp.r - x.iter().zip(coef).map(|(a, b)| a * b).sum::<f64>()).powi(2)
            })
            .sum()
    };
    let mut stribeck_vs = None;
    let want_stribeck = matches!(opts.law, None | Some(LawKind::Stribeck)) && !never_sticks;
    if want_stribeck && umax > 4.0 * umin {
        let cost = |lv: f64| {
            let vs = lv.exp();
            let mut ne = Normal::new(basis(LawKind::Stribeck, &samples[0], vs).len());
            for smp in &samples {
                ne.add(&basis(LawKind::Stribeck, smp, vs), smp.r, 1.0);
            }
            match ne.solve() {
                Some(c) => plain_rss(&c, LawKind::Stribeck, vs),
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
        // At the bounds it is not a Stribeck peak the data resolve.
        if lv > a + 0.5 * step && lv < b - 0.5 * step {
            stribeck_vs = Some(lv.exp());
        }
    }

    // Candidate models.
    struct Cand {
        kind: LawKind,
        coef: Vec<f64>,
        w: Vec<f64>,
        res: Vec<f64>,
        vs: f64,
    }
    let mut cands: Vec<Cand> = Vec::new();
    let mut kinds = vec![
        LawKind::Coulomb,
        LawKind::Decreasing,
        LawKind::StaticDynamic,
    ];
    if stribeck_vs.is_some() {
        kinds.push(LawKind::Stribeck);
    }
    for kind in kinds {
        let vs = stribeck_vs.unwrap_or(1.0);
        if let Some((coef, w, res)) = irls(&samples, kind, vs) {
            cands.push(Cand {
                kind,
                coef,
                w,
                res,
                vs,
            });
        }
    }
    if cands.is_empty() {
        return Err(super::IdentifyError::Undetermined);
    }
    let richest = cands.last().expect("non-empty");
    let tau = tau_int(&richest.res, &idx);
    // Effective sample size: the residuals are correlated (τ_int, their
    // integrated autocorrelation time), and the acceleration and smoothed
    // velocity share samples over one smoothing window, so the slip data
    // count at most one observation per window: n_eff = min(n/τ, n/(2h+1)).
    let n_eff = (samples.len() as f64 / tau).min(samples.len() as f64 / (2 * half + 1) as f64);

    // Rs and criterion of each candidate.
    let rs_of = |cand: &Cand, brks: &[Brk]| -> f64 {
        match cand.kind {
            LawKind::StaticDynamic => {
                // Median: robust to a mislocated breakaway or a spike.
                median(
                    &brks
                        .iter()
                        .map(|k| k.f - k.dir * offset_at(&cand.coef, k.k1, k.k2))
                        .collect::<Vec<_>>(),
                )
            }
            LawKind::Stribeck => cand.coef[1] + cand.coef[2],
            _ => cand.coef[1],
        }
    };
    let mut criteria = Vec::new();
    for cand in &cands {
        // Static > dynamic is the family's definition: a breakaway level at
        // or below the slip level is not this family.
        if cand.kind == LawKind::StaticDynamic
            && rs_of(cand, &brks).partial_cmp(&cand.coef[1]) != Some(std::cmp::Ordering::Greater)
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
        let rss = rss_of(&cand.coef, &cand.w, cand.kind, cand.vs);
        let wsum: f64 = cand.w.iter().sum();
        let mut crit = bic(
            rss,
            wsum.round().max(1.0) as usize,
            n_eff * wsum / samples.len() as f64,
            k_slip,
        );
        if !never_sticks && !brks.is_empty() {
            let rs = rs_of(cand, &brks);
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
    let chosen_kind = match opts.law {
        Some(k) if cands.iter().any(|c| c.kind == k) => k,
        Some(_) | None if criteria.is_empty() => LawKind::Coulomb,
        Some(k) => {
            warnings.push(format!(
                "law {} could not be fitted to this log; chose by BIC instead",
                k.as_str()
            ));
            best_kind(&criteria)
        }
        None => best_kind(&criteria),
    };
    // In a never-sticking log Rs is not observed, so static-dynamic cannot
    // be told from Coulomb: choose among the slip-only families.
    let chosen_kind = if never_sticks && chosen_kind == LawKind::StaticDynamic && opts.law.is_none()
    {
        LawKind::Coulomb
    } else {
        chosen_kind
    };
    let chosen = cands
        .iter()
        .find(|c| c.kind == chosen_kind)
        .expect("present");
    let bias = chosen.coef[0];
    let vs = stribeck_vs.unwrap_or(f64::NAN);
    let to_law = |cand: &Cand| -> SiLaw {
        let rs = rs_of(cand, &brks);
        match cand.kind {
            LawKind::Coulomb => SiLaw {
                kind: cand.kind,
                rs_n: cand.coef[1],
                rd_n: cand.coef[1],
                slope_n_s_per_m: 0.0,
                vs_m_per_s: None,
            },
            LawKind::Decreasing => SiLaw {
                kind: cand.kind,
                rs_n: cand.coef[1],
                rd_n: cand.coef[1],
                slope_n_s_per_m: cand.coef[2],
                vs_m_per_s: None,
            },
            LawKind::StaticDynamic => SiLaw {
                kind: cand.kind,
                rs_n: rs,
                rd_n: cand.coef[1],
                slope_n_s_per_m: 0.0,
                vs_m_per_s: None,
            },
            LawKind::Stribeck => SiLaw {
                kind: cand.kind,
                rs_n: rs,
                rd_n: cand.coef[1],
                slope_n_s_per_m: cand.coef[3],
                vs_m_per_s: Some(cand.vs),
            },
        }
    };
    let mut law = to_law(chosen);
    // Reported only when chosen (or asked for): otherwise it is a candidate
    // the criterion rejected, not a result.
    let stribeck = cands
        .iter()
        .find(|c| c.kind == LawKind::Stribeck && chosen_kind == LawKind::Stribeck)
        .map(to_law);
    let simple = if chosen_kind == LawKind::Stribeck {
        let mut simple_crit: Vec<(LawKind, f64)> = criteria
            .iter()
            .copied()
            .filter(|(k, _)| *k != LawKind::Stribeck)
            .collect();
        simple_crit.sort_by(|a, b| a.1.total_cmp(&b.1));
        let k = simple_crit[0].0;
        warnings.push(format!(
            "none of the simple laws fits: residuals are structured (Stribeck-like peak near zero velocity, v_s = {:.2} mm/s); best simple law {}",
            vs * 1e3,
            k.as_str()
        ));
        cands.iter().find(|c| c.kind == k).map(to_law)
    } else {
        None
    };
    let residual_rms_n =
        (plain_rss(&chosen.coef, chosen.kind, chosen.vs) / samples.len() as f64).sqrt();
    let candidates: Vec<SiLaw> = cands
        .iter()
        .map(to_law)
        .filter(|l| l.rd_n.is_finite() && l.rs_n.is_finite())
        .collect();

    // Never sticking: bounds on Rs from the reversals.
    let mut rs_upper = None;
    if never_sticks {
        let mut best = f64::INFINITY;
        for rv in &seg.reversals {
            let i = rv.at.round() as usize;
            let (a, b) = (i.saturating_sub(half), (i + half).min(n - 1));
            let Some((p, dp)) = line_at(&c.passive, a, b, rv.at) else {
                continue;
            };
            let acc = c.a2[i.min(n - 1)].abs();
            // Timing uncertainty of the crossing: σ_v / |a|, times dP/dt.
            let sig_t = if acc > 0.0 {
                seg.noise_v / acc / c.dt
            } else {
                0.0
            };
            let sig =
                (dp * sig_t).abs() + mad_sigma(&c.passive[a..=b]) / ((b - a + 1) as f64).sqrt();
            let (k1, k2) = kx(i.min(n - 1));
            let bound = rv.direction * (p - offset_at(&chosen.coef, k1, k2)) + 2.0 * sig;
            if bound.is_finite() {
                best = best.min(bound);
            }
        }
        if best.is_finite() {
            rs_upper = Some(best);
        }
        law.rs_n = f64::NAN;
        warnings.push(
            "M2 never sticks in this log: the static threshold is only bounded (rho_s_interval holds the bounds)"
                .into(),
        );
    }

    // Bootstrap over periods.
    let mut stat = StatIntervals::default();
    if opts.bootstrap > 0 {
        let p = chosen.coef.len();
        let mut per: Vec<Normal> = (0..n_periods).map(|_| Normal::new(p)).collect();
        for (smp, wi) in samples.iter().zip(&chosen.w) {
            per[smp.period.min(n_periods - 1)].add(&basis(chosen.kind, smp, chosen.vs), smp.r, *wi);
        }
        let mut per_brk: Vec<Vec<&Brk>> = vec![Vec::new(); n_periods];
        for k in &brks {
            per_brk[k.period.min(n_periods - 1)].push(k);
        }
        let used: Vec<usize> = (0..n_periods)
            .filter(|&i| per[i].n > 0 || !per_brk[i].is_empty())
            .collect();
        let mut rng = Rng::new(opts.seed);
        let (mut rs_b, mut rd_b, mut a_b) = (Vec::new(), Vec::new(), Vec::new());
        for _ in 0..opts.bootstrap {
            let mut ne = Normal::new(p);
            let mut fd: Vec<&Brk> = Vec::new();
            for _ in 0..used.len() {
                let q = used[rng.below(used.len())];
                ne.add_all(&per[q]);
                fd.extend(per_brk[q].iter().copied());
            }
            let Some(cf) = ne.solve() else { continue };
            let rd = cf[1];
            let (rs, a) = match chosen.kind {
                LawKind::Coulomb => (rd, 0.0),
                LawKind::Decreasing => (rd, cf[2]),
                LawKind::StaticDynamic => {
                    if fd.is_empty() {
                        continue;
                    }
                    let v: Vec<f64> = fd
                        .iter()
                        .map(|k| k.f - k.dir * offset_at(&cf, k.k1, k.k2))
                        .collect();
                    (median(&v), 0.0)
                }
                LawKind::Stribeck => (cf[1] + cf[2], cf[3]),
            };
            rs_b.push(rs);
            rd_b.push(rd);
            a_b.push(a);
        }
        let pct = |v: &[f64]| -> Option<(f64, f64)> {
            (v.len() >= 20).then(|| (quantile(v, 0.025), quantile(v, 0.975)))
        };
        stat.rd = pct(&rd_b);
        stat.slope = pct(&a_b);
        stat.rs = if never_sticks { None } else { pct(&rs_b) };
    }

    let breakaway_forces_n = brks
        .iter()
        .map(|k| k.f - k.dir * offset_at(&chosen.coef, k.k1, k.k2))
        .collect();
    if !never_sticks && brks.is_empty() {
        warnings.push("no stick → slip transition could be located".into());
    }
    Ok(EquationFit {
        law,
        simple,
        stribeck,
        stat,
        stuck: false,
        rs_lower_bound_n: None,
        never_sticks,
        rs_upper_bound_n: rs_upper,
        bias_n: bias,
        residual_rms_n,
        n_slip: samples.len(),
        n_eff,
        n_breakaways: brks.len(),
        breakaway_forces_n,
        criteria,
        candidates,
        warnings,
    })
}

fn best_kind(criteria: &[(LawKind, f64)]) -> LawKind {
    criteria
        .iter()
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|c| c.0)
        .unwrap_or(LawKind::Coulomb)
}
