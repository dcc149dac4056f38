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

mod bootstrap;
mod bounds;
pub(crate) use bounds::held_force_lower_bound;
mod select;
mod slip;
mod velocity;

use super::contact::Contact;
use super::segment::Segmentation;
use slip::Sample;

use crate::model::{LawKind, Selection, SiLaw};
use crate::warning::Warning;

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
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct StatIntervals {
    /// Rs (N).
    pub rs: Option<(f64, f64)>,
    /// Rd (N).
    pub rd: Option<(f64, f64)>,
    /// a (N·s/m).
    pub slope: Option<(f64, f64)>,
}

/// What the equation-error fit found in one log (SI).
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
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
    /// The direction (±1) of the slip after each breakaway, in the order
    /// of `breakaway_forces_n`.
    #[serde(default)]
    pub breakaway_directions: Vec<f64>,
    /// BIC of every family considered (lower is better).
    pub criteria: Vec<(LawKind, f64)>,
    /// The equation-error law of every simple family that could be fitted
    /// (start values of the output-error refinement; for static-dynamic
    /// also when its breakaway level is not above the slip level).
    pub candidates: Vec<SiLaw>,
    /// Things the user should know.
    // In a saved fit (artifact) the typed variants, named apart from the
    // JSON outputs' `warnings` (messages, with `warning_codes` beside).
    #[serde(rename = "warning_variants")]
    pub warnings: Vec<Warning>,
}

/// Regressors of a slip sample: bias, the law's terms, then K2·x1 and K2·x2.
///
/// The last two absorb the position sensors' gain errors: a gain error ε
/// on x_i adds K2·ε·x_i to the computed force, a shape that neither the
/// bias nor the law can take, so the slip data identify it ("what the
/// physics gives for free"); only a common scale of both remains, and that
/// stays in the calibration budget.
/// The law's terms are its family's ([`crate::model::LawFamily::basis`]).
fn basis(kind: LawKind, smp: &Sample, vs: f64) -> Row {
    let (x, n) = kind.family().basis(smp.s, smp.u, smp.k1, smp.k2, vs);
    Row(x, n)
}

/// One row of regressors, on the stack (at most six).
#[derive(Clone, Copy)]
struct Row([f64; 6], usize);

impl std::ops::Deref for Row {
    type Target = [f64];
    fn deref(&self) -> &[f64] {
        &self.0[..self.1]
    }
}

/// Slip samples up to which a fit at one velocity scale keeps its rows
/// between the passes over them (56 bytes each: at most 5.6 MB per fit)
/// instead of evaluating them again: the same numbers, bit for bit, with
/// a law's exponential evaluated once per sample instead of twice (the
/// velocity-scale search) or sixteen times (the robust fit's eight
/// rounds). Longer logs evaluate them where they are used, as the
/// per-sample budget (`limits::FIT_BYTES_PER_SAMPLE`, measured on
/// two-hour logs) assumes. Each concurrent calibration re-fit may hold
/// such rows too (at most 5 × 5.6 MB, beyond
/// `limits::REFIT_BYTES_PER_SAMPLE`'s measured margin on logs that slide
/// most of the time). Measured (session 40, docs/real-pads.md): a 130-s
/// log with 81 876 slip samples peaked at 61–71 MiB (one and two threads)
/// against its planned 81.8 MiB and 91 MiB before the rows were kept; a
/// budget of tens of megabytes is where the re-fits' rows would count.
const STORED_ROWS_MAX: usize = 100_000;

/// Bias plus gain-error correction of a model at positions (k1, k2).
fn offset_at(coef: &[f64], k1: f64, k2: f64) -> f64 {
    let p = coef.len();
    coef[0] + coef[p - 2] * k1 + coef[p - 1] * k2
}

/// BIC with `n` residuals, `n_eff` effective samples and `k` parameters.
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
    let mut warnings = Vec::new();
    let gauge = slip::Gauge::new(c);
    let (samples, idx) = slip::slip_samples(c, seg, &gauge);
    // Behind a compliant contact a slider that never broke away: M2 rode
    // on the contact spring, so the velocity showed motion and no stick.
    let held = if seg.stuck() {
        None
    } else {
        super::pads::slider_held(c)
    };
    if seg.stuck() || samples.len() < 20 || held.is_some() {
        let lower_bound = match held {
            Some(h) => {
                warnings.push(Warning::SliderHeld {
                    kt_n_per_m: h.kt_n_per_m,
                    x2_range_m: h.x2_range_m,
                    force_amplitude_n: h.force_amplitude_n,
                });
                h.force_amplitude_n
            }
            None => {
                if !seg.stuck() {
                    warnings.push(Warning::FewSlipSamples {
                        samples: samples.len(),
                    });
                }
                bounds::stuck_lower_bound(c)
            }
        };
        return Ok(EquationFit::stuck(
            opts.law.unwrap_or(LawKind::StaticDynamic),
            lower_bound,
            samples.len(),
            warnings,
        ));
    }
    let brks = bounds::breakaways(c, seg, &gauge);
    let never_sticks = seg.never_sticks();
    // The families of `--law auto`, and the one asked for; a family with a
    // velocity scale only where the log sticks and the scale is resolved.
    let kinds: Vec<(LawKind, f64)> = crate::model::LawKind::all()
        .iter()
        .copied()
        .filter(|&k| match k.family().selection() {
            Selection::Simple => true,
            Selection::Rescue { .. } => opts.law.is_none() || opts.law == Some(k),
            Selection::OnRequest => opts.law == Some(k),
        })
        .filter_map(|k| {
            if !k.family().has_velocity_scale() {
                return Some((k, 1.0));
            }
            if never_sticks {
                return None;
            }
            velocity::velocity_scale(k, &samples, seg.hi).map(|vs| (k, vs))
        })
        .collect();

    let cands = select::candidates(&samples, &kinds);
    let Some(richest) = cands.last() else {
        return Err(super::IdentifyError::Undetermined);
    };
    let tau = slip::tau_int(&richest.res, &idx);
    // Effective sample size: the residuals are correlated (τ_int, their
    // integrated autocorrelation time), and the acceleration and smoothed
    // velocity share samples over one smoothing window, so the slip data
    // count at most one observation per window: n_eff = min(n/τ, n/(2h+1)).
    let half = c.half_window;
    let n_eff = (samples.len() as f64 / tau).min(samples.len() as f64 / (2 * half + 1) as f64);
    let criteria = select::criteria(&cands, &samples, &brks, n_eff, never_sticks);
    let chosen_kind = select::choose(opts.law, &cands, &criteria, never_sticks, &mut warnings);
    let Some(chosen) = cands.iter().find(|c| c.kind == chosen_kind) else {
        return Err(super::IdentifyError::Undetermined);
    };
    let to_law = |cand: &select::Cand| select::to_law(cand, &brks);
    let mut law = to_law(chosen);
    // Reported only when chosen (or asked for): otherwise it is a candidate
    // the criterion rejected, not a result.
    // A rescue family (the Stribeck type) chosen: no simple law fits.
    let rescued = matches!(chosen_kind.family().selection(), Selection::Rescue { .. });
    let stribeck = rescued.then(|| to_law(chosen));
    let simple = if rescued {
        let mut simple_crit: Vec<(LawKind, f64)> = criteria
            .iter()
            .copied()
            .filter(|(k, _)| k.family().selection() == Selection::Simple)
            .collect();
        simple_crit.sort_by(|a, b| a.1.total_cmp(&b.1));
        let k = simple_crit[0].0;
        warnings.push(Warning::NoSimpleLaw {
            stribeck_velocity_m_per_s: Some(chosen.vs),
            best: k,
        });
        cands.iter().find(|c| c.kind == k).map(to_law)
    } else {
        None
    };
    let residual_rms_n = (slip::rss(&samples, &chosen.coef, None, chosen.kind, chosen.vs)
        / samples.len() as f64)
        .sqrt();
    let candidates: Vec<SiLaw> = cands
        .iter()
        .map(to_law)
        .filter(|l| l.rd_n.is_finite() && l.rs_n.is_finite())
        .collect();

    // Never sticking: bounds on Rs from the reversals.
    let mut rs_upper = None;
    if never_sticks {
        rs_upper = bounds::reversal_upper_bound(c, seg, &gauge, &chosen.coef);
        law.rs_n = f64::NAN;
        warnings.push(Warning::NeverSticks);
    }
    let n_periods = slip::period_of(c, c.r.len() as f64) + 1;
    let stat = bootstrap::bootstrap(&samples, &brks, chosen, n_periods, opts, never_sticks);

    let breakaway_forces_n = brks
        .iter()
        .map(|k| k.f - k.dir * offset_at(&chosen.coef, k.k1, k.k2))
        .collect();
    if !never_sticks && brks.is_empty() {
        warnings.push(Warning::NoBreakaway);
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
        bias_n: chosen.coef[0],
        residual_rms_n,
        n_slip: samples.len(),
        n_eff,
        n_breakaways: brks.len(),
        breakaway_directions: brks.iter().map(|k| k.dir).collect(),
        breakaway_forces_n,
        criteria,
        candidates,
        warnings,
    })
}

/// What the calibration budget reads of a re-fit with the law forced to
/// `kind` and no bootstrap: the law and the bounds on Rs, as [`fit`] would
/// report them.
pub(crate) struct Forced {
    /// The law ([`EquationFit::law`]).
    pub law: SiLaw,
    /// [`EquationFit::rs_lower_bound_n`].
    pub rs_lower_bound_n: Option<f64>,
    /// [`EquationFit::rs_upper_bound_n`].
    pub rs_upper_bound_n: Option<f64>,
}

/// [`fit`] with the law forced to `kind` and no bootstrap, reduced to what
/// [`Forced`] holds: only that family's candidate is fitted (the others,
/// the criteria and the effective sample size only inform a choice that is
/// already made). The numbers are [`fit`]'s, bit for bit; where the family
/// cannot be fitted (the choice then falls to BIC) it is [`fit`] itself.
pub(crate) fn fit_forced(
    c: &Contact,
    seg: &Segmentation,
    kind: LawKind,
    seed: u64,
) -> Result<Forced, super::IdentifyError> {
    let opts = FitOptions {
        law: Some(kind),
        bootstrap: 0,
        seed,
    };
    let full = |opts: &FitOptions| {
        fit(c, seg, opts).map(|f| Forced {
            law: f.law,
            rs_lower_bound_n: f.rs_lower_bound_n,
            rs_upper_bound_n: f.rs_upper_bound_n,
        })
    };
    let gauge = slip::Gauge::new(c);
    let (samples, _) = slip::slip_samples(c, seg, &gauge);
    if seg.stuck() || samples.len() < 20 || super::pads::slider_held(c).is_some() {
        return full(&opts);
    }
    let never_sticks = seg.never_sticks();
    let velocity_scale = kind.family().has_velocity_scale();
    let scale = (velocity_scale && !never_sticks)
        .then(|| velocity::velocity_scale(kind, &samples, seg.hi))
        .flatten();
    let vs = scale.unwrap_or(1.0);
    if velocity_scale && scale.is_none() {
        return full(&opts); // no candidate of this family: fit chooses by BIC
    }
    let Some((coef, w, res)) = slip::irls(&samples, kind, vs) else {
        return full(&opts);
    };
    let chosen = select::Cand {
        kind,
        coef,
        w,
        res,
        vs,
    };
    let brks = bounds::breakaways(c, seg, &gauge);
    let mut law = select::to_law(&chosen, &brks);
    let mut rs_upper = None;
    if never_sticks {
        rs_upper = bounds::reversal_upper_bound(c, seg, &gauge, &chosen.coef);
        law.rs_n = f64::NAN;
    }
    Ok(Forced {
        law,
        rs_lower_bound_n: None,
        rs_upper_bound_n: rs_upper,
    })
}

impl EquationFit {
    /// The fit of a stuck log: only a lower bound on Rs (every other
    /// parameter NaN); `kind` is the family asked for.
    fn stuck(kind: LawKind, lower_bound_n: f64, n_slip: usize, warnings: Vec<Warning>) -> Self {
        let nan = f64::NAN;
        EquationFit {
            law: SiLaw {
                kind,
                rs_n: nan,
                rd_n: nan,
                slope_n_s_per_m: nan,
                vs_m_per_s: None,
            },
            simple: None,
            stribeck: None,
            stat: StatIntervals::default(),
            stuck: true,
            rs_lower_bound_n: Some(lower_bound_n),
            never_sticks: false,
            rs_upper_bound_n: None,
            bias_n: nan,
            residual_rms_n: nan,
            n_slip,
            n_eff: 0.0,
            n_breakaways: 0,
            breakaway_forces_n: Vec::new(),
            breakaway_directions: Vec::new(),
            criteria: Vec::new(),
            candidates: Vec::new(),
            warnings,
        }
    }
}
