//! # Batch: one pad at several normal forces → μs, μd and the recommended setting
//!
//! Files: `mod.rs` (options, results, the door [`batch`]), `observations`
//! (what each log says, the coefficient fit), `mu` (the censored
//! likelihood and μ intervals), `conflicts` (logs that contradict each
//! other, robust selection), `worst` (worst-case response, drive grid).
//!
//! This module owns the batch comparison of normal-force settings
//! (`stickslip batch`, the batch section of `stickslip run`): from the fitted
//! laws of the characteristic logs of one pad it estimates the friction
//! coefficients, and from them and the rig's own m, k, D the normal force
//! that keeps the main mass quietest over the whole drive range.
//!
//! ## Friction coefficients (Amontons through the origin)
//!
//! Rs = μs·N and Rd = μd·N with the measured normal force N of each log.
//!
//! * **Observations.** A log whose mass stuck and slid gives a *point* Rs
//!   of the estimate its fit reports, with the σ of the interval's part
//!   that is the log's own: for the output-error refinement its interval
//!   less the sensors' gains' part (statistical, misfit and channel
//!   alignment remain), for the equation-error estimate the bootstrap
//!   half-width / 1.96. (The batch once read the equation-error estimates
//!   always: on the public batch their per-log biases scattered 6.3× their
//!   bootstrap σ, raised false conflicts and put μs at 0.4256 for a true
//!   0.42.) A contact threshold the refinement did not resolve enters as
//!   Rd ≤ Rs < the profile's bound, like a never-sticking log. A **stuck**
//!   log (the mass never slid) only says Rs > its lower bound; a
//!   **never-sticking** log says Rd ≤ Rs < the reversal bound. These enter
//!   as censored data, never as points: the log-likelihood is
//!   Σ −½((Rs_i − μN_i)/σ_i)² over points plus Σ log Φ((μN_i − LB_i)/σ_b)
//!   over stuck logs plus Σ log[Φ((UB_i − μN_i)/σ_b) · Φ((μN_i − Rd_i)/σ_d)]
//!   over never-sticking logs (both bounds measured independently; the
//!   former form Φ(UB…) − Φ(Rd…) turned negative, i.e. a log-likelihood of
//!   −∞, when a bound contradicted the points, and the fit collapsed into a
//!   μ interval of [0, 2e18]) (σ_b of a bound: the bound times the median
//!   relative σ of the points — a bound is taken as known as well as a
//!   typical point). It is concave in μ: the maximum is found by
//!   golden-section search and the 95 % interval by the profile likelihood
//!   (drop of 1.92). Rd is a point in every log that slid (μd is the
//!   weighted fit through the origin, the same code without censoring).
//! * **Scatter check.** If the points scatter more than their σ
//!   (χ²/dof > 1) every σ is inflated by √(χ²/dof) (Birge ratio) and the
//!   interval uses Student's t with n − 1 degrees of freedom (the scale is
//!   then estimated from a few points). On the public batch the four Rd
//!   points scatter 3.3× their statistical σ (χ²/dof 11.2; the Rs points
//!   0.23): each log's sensors have their own gains (the normal force's
//!   differ by up to 1.6 %), which the statistical σ leave out.
//! * **Free fit.** A weighted straight line with intercept through the
//!   points is reported as a check (`mu_s_intercept_n`): Amontons' law says
//!   the intercept is zero; a significant one (95 %) is a warning (a
//!   normal-force offset, or a law that is not proportional).
//! * **Systematic part.** The per-log intervals of `fit` combine the
//!   bootstrap with a calibration budget (sensor gains). On one rig the logs
//!   share their sensors, so a gain error scales every log's force the same
//!   way: averaging logs does **not** shrink it. The batch therefore fits
//!   with the statistical σ only and adds the calibration part afterwards as
//!   one common relative error (the fit-weighted mean of the logs' relative
//!   calibration half-widths), together with the normal-force sensor's gain
//!   budget (default ±1 %, rectangular, 95 % half-width 1.96·u/√3), in
//!   quadrature on each side. This is conservative if the sensors were in
//!   fact re-calibrated between logs (then that part would average down).
//!   Whether logs *contradict* each other is judged on their whole
//!   intervals instead (each σ widened by its calibration part and the
//!   normal-force gain): gains that differ from log to log are no
//!   conflict, and a conflict is a disagreement the logs' own intervals
//!   do not allow.
//!
//! ## Conflicting logs
//!
//! Logs can contradict each other: a never-sticks or stuck bound of one log
//! against the measured Rs of others, or a measured value far off the rest
//! (a misread log, a log of another pad, a short-stick log whose breakaways
//! are biased). The batch finds, names and sizes these conflicts and
//! combines the logs robustly.
//!
//! * **Tension.** Each observation is compared with the fit of the *other*
//!   logs (leave one out): its distance from their μ·N in σ of the combined
//!   uncertainty (every σ with its calibration part, above), the
//!   observation's σ scaled by the others' own scatter
//!   (Birge ratio) and the others' μ interval on the side facing it. A
//!   conflict is a tension beyond the 3σ quantile (Student's t with the
//!   others' n − 1 degrees of freedom when their scatter was estimated,
//!   else 3). Because three or four logs estimate their own scatter poorly
//!   (t with 2 degrees of freedom needs 19σ), a measured point is also in
//!   conflict when Dixon's Q test at 99 % calls it an outlier among the
//!   points' R/N and its gap exceeds 3σ of its own and its neighbour's σ
//!   (a log of another pad 70 % off three logs that scatter 1 %).
//!   The conflict names the log, the logs it disagrees with one to
//!   one (else the others' measured logs), the size in σ and relative to
//!   μ·N. Measured points that scatter beyond their whole intervals (Birge
//!   ratio above 1.5, and their χ² beyond its 99.73 % point: the 3σ of the
//!   tension) are a `scatter` conflict of all of them.
//! * **Robust combination.** Repeatedly, among the logs in conflict and
//!   those they contradict one to one, the log whose removal leaves the least
//!   misfit (−2 log-likelihood of the rest at its own maximum, with the
//!   logs' own σ: a χ² for points) is set aside; when two removals are
//!   equally good (within 1 or 5 %; a pair of points is symmetric), the one whose own fit casts doubt on it
//!   goes (its equation-error and output-error estimates disagree by more
//!   than 1.96σ, the more so), else a bound before a measured point;
//!   otherwise nothing more is set aside: the conflict stays named, the
//!   scatter inflation (Birge, Student's t) widens the interval, and no
//!   normal force is recommended (the premise of one pad with friction
//!   proportional to N does not hold for these logs). At least
//!   one measured point and more than half of the observations stay.
//!   μs and μd are reported both ways: without the logs set aside (the
//!   result used) and from every log.
//! * **No recommendation.** When μs's interval reaches zero, is unbounded
//!   or spans more than a factor of 1000, or no setting's uncertainty box
//!   fits the ρs grid, the batch says why in plain words instead of
//!   recommending (μ and the worst-case curve are still reported). Without
//!   `--rho-max` the grid reaches at least 8·ρmin times the box's width
//!   factor, so a wide but finite box still finds candidates.
//!
//! ## Worst-case amplitude and the recommendation
//!
//! * **W(ρs)** = max over η in the drive range of A1/A, the worse of the
//!   steady states continued upwards, downwards and from rest
//!   ([`worst_case`]), with ρd = (μd/μs)·ρs and the rig's own m, k, D. The
//!   η grid is uniform plus fine windows (step 0.002) around η1, η0 and η2,
//!   where the peaks are narrow ([`drive_etas`]). Only a coarse part of it
//!   (every 4th point, counted from each window's centre) is evaluated at
//!   every ρs; intervals next to a branch's local maxima are refined down to
//!   the grid's spacing ([`worst_case_on`]). On the public batch this
//!   evaluates 59–91 of the 222 η per node with the same recommendation,
//!   window and cliff as the uniform search; W agrees to 0.03 % where the
//!   worst case is periodic and to 0.8 % where it is not (the wander below)
//!   (test `refined_search_matches_uniform`). Default range
//!   [0.5·η1, 1.4·η2] (the paper's Fig. 3 range at m = 4, k = 1). The
//!   steady-state solver runs with a 200-period marching budget (points
//!   that do not repeat by then — lightly damped stick-slip near η0 —
//!   contribute the amplitude of their last 50 periods; such a response
//!   itself wanders by ±2 % over 200…20 000 periods, e.g. ρs = 1.8,
//!   ρd = 1.44, η = 0.70 at D = 0.003). Measured against a dense
//!   reference (fine step 0.001, 2000 periods) at 30 nodes ρs ∈ [0.7, 2.1],
//!   ratio 0.8, m = 4, k = 1, D = 0.003: W within 0.1 % where the worst
//!   case is periodic, within 0.9 % (1.8 % at one more node) where it is
//!   non-periodic (inside the wander above), 10× faster
//!   (2.1 s against 20.8 s); on the public batch the same recommendation
//!   (3.931 N), window and cliff (ρs 0.8606 against 0.8608) as the
//!   reference, 7.5 s against 58 s (test `default_grid_matches_dense_reference`).
//! * **Grid.** W is evaluated once on a coarse geometric ρs grid at the
//!   estimated ratio (in parallel, deterministic order); the candidates whose
//!   coarse robust value is within 25 % of the best are then re-evaluated,
//!   over their whole boxes, on a four times finer grid with every ratio.
//!   Every candidate setting and its uncertainty box reuse these values; a
//!   candidate counts only if every node of its box has every ratio.
//! * **Robust worst case.** A setting N is really ρs ∈ [μs_lo·N(1−t),
//!   μs_hi·N(1+t)]/(A·K2) (the μs interval and the setting tolerance t,
//!   default ±5 %) with the ratio μd/μs anywhere in its (statistical)
//!   interval. Its robust worst case is the largest W over that box (grid
//!   nodes inside; W interpolated in log ρs at the box ends; the ratio at
//!   its estimate and both interval ends). The recommendation minimises it.
//!   At the recommendation the box ends are then evaluated directly.
//! * **Drive amplitude.** ρ = R/(A·K2) with the rig's *nominal* drive
//!   amplitude (the amplitude the absorber is specified for; option to
//!   override). The logs' measured amplitudes are reported beside it.
//! * **Window.** `recommended_normal_force_interval_n` is the contiguous
//!   range of settings around the recommendation whose robust worst case
//!   stays within `window` (default 10 %) of the recommendation's.
//! * **Cliff.** Below the recommendation W jumps up where the η1 peak
//!   returns. The cliff is the largest ρs below the recommendation whose
//!   W exceeds twice the recommendation's W, located on the grid and refined
//!   by bisection (7 steps); the margin is reported in ρs, newtons and
//!   relative to the recommendation.

use crate::identify::LogFit;
use crate::ingest::RigMeta;
use crate::model::{Absorber, Law, Model};
use crate::sim::engine::Init;
use crate::sim::sweep::{curve, steady_state_with, Direction, SteadyConfig};
use crate::sim::SimError;
use crate::stats::golden_section;
use crate::warning::Warning;
use crate::Result;
use rayon::prelude::*;
use std::path::{Path, PathBuf};

mod conflicts;
mod json;
mod mu;
mod observations;
mod pad;
mod recommend;
mod worst;
pub use crate::error::BatchError;

use conflicts::*;
pub use mu::ln_norm_cdf;
use mu::*;
use observations::*;
pub use pad::{BatchPad, Combined, PadShape};
use worst::*;
pub use worst::{
    default_eta_range, drive_etas, drive_grid, rig_warnings, worst_case, worst_case_on, DriveGrid,
    REFINE_FRACTION,
};

/// Default step of the fine η windows (see the module notes for the
/// measurement behind it).
pub const DEFAULT_ETA_FINE_STEP: f64 = 0.002;
/// Default stride of the coarse η grid of the worst case.
pub const DEFAULT_ETA_COARSE_STRIDE: usize = 4;
/// Default marching budget (periods) of a worst-case steady state.
pub const DEFAULT_MAX_PERIODS: u64 = 200;

/// Options of [`batch`].
#[derive(Debug, Clone)]
pub struct BatchOptions {
    /// Drive range in η (default [0.5·η1, 1.4·η2] of the rig).
    pub eta_range: Option<(f64, f64)>,
    /// Uniform η points over the range.
    pub eta_points: usize,
    /// Step of the fine η windows around η1, η0, η2 (0: none).
    pub eta_fine_step: f64,
    /// Half-width of each fine window.
    pub eta_fine_halfwidth: f64,
    /// Every this-many uniform η is evaluated in any case (with the fine
    /// windows); the others only next to a branch's local maximum
    /// ([`worst_case_on`]). 1: every η (the uniform search).
    pub eta_coarse_stride: usize,
    /// Smallest ρs of the grid.
    pub rho_min: f64,
    /// Largest ρs of the grid (default: covers every measured setting, at least 3).
    pub rho_max: Option<f64>,
    /// Nodes of the coarse geometric ρs grid.
    pub rho_points: usize,
    /// Refine the grid (4× finer) around the best candidates.
    pub refine: bool,
    /// Relative tolerance of a normal-force setting (±).
    pub setting_tolerance: f64,
    /// Relative increase of the robust worst case that bounds the window.
    pub window: f64,
    /// Drive amplitude for ρ = R/(A·K2) (default: the rig's nominal one).
    pub drive_amplitude_m: Option<f64>,
    /// Gain budget of the normal-force sensor (bound, rectangular).
    pub normal_force_gain_uncertainty: f64,
    /// Include the ends of the μd/μs interval, and of the simulated pad's
    /// κ and ρs⁻/ρs⁺ intervals, in the robust worst case.
    pub ratio_variants: bool,
    /// Steady-state solver.
    pub steady: SteadyConfig,
}

impl Default for BatchOptions {
    fn default() -> Self {
        Self {
            eta_range: None,
            eta_points: 141,
            eta_fine_step: DEFAULT_ETA_FINE_STEP,
            eta_fine_halfwidth: 0.025,
            eta_coarse_stride: DEFAULT_ETA_COARSE_STRIDE,
            rho_min: 0.2,
            rho_max: None,
            rho_points: 40,
            refine: true,
            setting_tolerance: 0.05,
            window: 0.10,
            drive_amplitude_m: None,
            normal_force_gain_uncertainty: 0.01,
            ratio_variants: true,
            steady: SteadyConfig {
                max_periods: DEFAULT_MAX_PERIODS,
                // The worst case reads amplitudes only, not their ranges.
                ranges: false,
                ..SteadyConfig::default()
            },
        }
    }
}

/// What is wrong with [`BatchOptions`] ([`BatchOptions::check`]).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum OptionsError {
    /// The η range is not 0 < min < max.
    #[error("eta range [{min}, {max}] must be 0 < min < max")]
    EtaRange {
        /// Its lower end.
        min: f64,
        /// Its upper end.
        max: f64,
    },
    /// Too few or too many η points.
    #[error("eta points must be between 2 and 100000")]
    EtaPoints,
    /// The coarse η stride is outside 1..=the η points.
    #[error(
        "eta coarse stride {stride} must be between 1 (every point) and the eta points ({points})"
    )]
    EtaCoarseStride {
        /// The stride.
        stride: usize,
        /// The η points.
        points: usize,
    },
    /// The fine η step or half-width is negative or not finite.
    #[error("fine eta step and half-width must be finite and >= 0")]
    EtaFine,
    /// The fine η windows would be too long.
    #[error("fine eta windows of more than 10000 points")]
    EtaFineTooLong,
    /// ρ-min is not finite and positive.
    #[error("rho-min must be finite and > 0")]
    RhoMin,
    /// ρ-max is not finite and above ρ-min.
    #[error("rho-max must be finite and > rho-min")]
    RhoMax,
    /// Too few or too many ρ points.
    #[error("rho points must be between 4 and 10000")]
    RhoPoints,
    /// The setting tolerance is not a fraction in [0, 0.5).
    #[error("setting tolerance must be a fraction in [0, 0.5)")]
    SettingTolerance,
    /// The window is negative or not finite.
    #[error("window must be finite and >= 0")]
    Window,
    /// The drive amplitude is not finite and positive.
    #[error("drive amplitude must be finite and > 0")]
    DriveAmplitude,
    /// The normal-force gain uncertainty is not a fraction in [0, 0.5).
    #[error("normal-force gain uncertainty must be a fraction in [0, 0.5)")]
    NormalForceGainUncertainty,
}

impl BatchOptions {
    /// Checks the options: the first thing wrong with them.
    pub fn check(&self) -> std::result::Result<(), OptionsError> {
        let pos = |x: f64| x.is_finite() && x > 0.0;
        if let Some((a, b)) = self.eta_range {
            if !(pos(a) && pos(b) && a < b) {
                return Err(OptionsError::EtaRange { min: a, max: b });
            }
        }
        if !(2..=100_000).contains(&self.eta_points) {
            return Err(OptionsError::EtaPoints);
        }
        if !(1..=self.eta_points).contains(&self.eta_coarse_stride) {
            return Err(OptionsError::EtaCoarseStride {
                stride: self.eta_coarse_stride,
                points: self.eta_points,
            });
        }
        let nonneg = |x: f64| x.is_finite() && x >= 0.0;
        if !(nonneg(self.eta_fine_step) && nonneg(self.eta_fine_halfwidth)) {
            return Err(OptionsError::EtaFine);
        }
        if self.eta_fine_step > 0.0 && self.eta_fine_halfwidth / self.eta_fine_step > 5000.0 {
            return Err(OptionsError::EtaFineTooLong);
        }
        if !pos(self.rho_min) {
            return Err(OptionsError::RhoMin);
        }
        if let Some(m) = self.rho_max {
            if !(pos(m) && m > self.rho_min) {
                return Err(OptionsError::RhoMax);
            }
        }
        if !(4..=10_000).contains(&self.rho_points) {
            return Err(OptionsError::RhoPoints);
        }
        if !(self.setting_tolerance.is_finite() && (0.0..0.5).contains(&self.setting_tolerance)) {
            return Err(OptionsError::SettingTolerance);
        }
        if !(self.window.is_finite() && self.window >= 0.0) {
            return Err(OptionsError::Window);
        }
        if let Some(a) = self.drive_amplitude_m {
            if !pos(a) {
                return Err(OptionsError::DriveAmplitude);
            }
        }
        if !(self.normal_force_gain_uncertainty.is_finite()
            && (0.0..0.5).contains(&self.normal_force_gain_uncertainty))
        {
            return Err(OptionsError::NormalForceGainUncertainty);
        }
        Ok(())
    }
}

/// How one log informs the static threshold Rs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum StaticObs {
    /// Rs measured (N) with its statistical σ (N).
    Point {
        /// Estimate.
        rs_n: f64,
        /// Statistical σ.
        sigma_n: f64,
    },
    /// Stuck: Rs above `bound_n`.
    Above {
        /// Lower bound (N), without calibration margin.
        bound_n: f64,
    },
    /// Never sticks: `low_n` (= Rd) ≤ Rs < `high_n`.
    Between {
        /// Rd (N).
        low_n: f64,
        /// σ of Rd.
        low_sigma_n: f64,
        /// Upper bound (N) from the reversals, without calibration margin.
        high_n: f64,
    },
    /// Nothing usable on Rs.
    Unknown,
}

impl StaticObs {
    /// Name in tables and JSON.
    pub fn as_str(&self) -> &'static str {
        match self {
            StaticObs::Point { .. } => "point",
            StaticObs::Above { .. } => "lower-bound",
            StaticObs::Between { .. } => "bounded",
            StaticObs::Unknown => "unknown",
        }
    }
}

/// One log of the batch as the μ fits see it.
#[derive(Debug, Clone, PartialEq)]
pub struct BatchLog {
    /// Log path.
    pub log: PathBuf,
    /// Measured normal force (N).
    pub normal_force_n: f64,
    /// What the log says about Rs.
    pub static_obs: StaticObs,
    /// Rd (N) and its statistical σ, where the mass slid.
    pub rd_n: Option<(f64, f64)>,
    /// Relative calibration (systematic) 95 % half-width of Rs and of Rd.
    pub calibration_rel: (Option<f64>, Option<f64>),
    /// Measured drive amplitude of the log (m).
    pub drive_amplitude_m: f64,
    /// The log's own ρs (its measured amplitude), or its bounds.
    pub rho_s: Option<f64>,
    /// ρs lower bound of a stuck log (calibration margin included).
    pub rho_s_lower_bound: Option<f64>,
    /// ρs interval (bounds of a never-sticking log).
    pub rho_s_interval: Option<(f64, f64)>,
    /// Rs/N or its bounds: (estimate, low, high) where known.
    pub mu_s: (Option<f64>, Option<f64>, Option<f64>),
    /// Rd/N.
    pub mu_d: Option<f64>,
    /// ρs of this setting under the batch model (μs·N/(A·K2), nominal A).
    pub model_rho_s: f64,
    /// Worst case at that ρs.
    pub worst: Option<Worst>,
    /// A censored log whose bound agrees with the fitted μs interval.
    pub consistent: Option<bool>,
    /// How far the log's own equation-error and output-error estimates of
    /// Rs and Rd lie apart (σ of their combined intervals; 0 when only one
    /// exists): doubt the log casts on itself.
    pub estimate_disagreement: (f64, f64),
    /// Set aside from the robust μs and μd (in conflict with the others).
    pub set_aside: (bool, bool),
}

/// A friction coefficient with its intervals.
#[derive(Debug, Clone, PartialEq)]
pub struct MuFit {
    /// Estimate (maximum likelihood, through the origin).
    pub mu: f64,
    /// 95 % interval: statistical (profile likelihood) and systematic.
    pub interval: (f64, f64),
    /// Statistical 95 % interval alone.
    pub stat_interval: (f64, f64),
    /// Relative 95 % half-width of the common calibration part.
    pub systematic_rel: f64,
    /// Factor the σ were inflated by (√(χ²/dof) when > 1, else 1).
    pub birge: f64,
    /// χ²/dof of the points at the estimate (before inflation).
    pub chi2_per_dof: Option<f64>,
    /// Points and censored observations used.
    pub points: usize,
    /// Censored observations used.
    pub censored: usize,
    /// Free fit with intercept over the points: (slope, intercept N,
    /// intercept 95 % half-width N).
    pub free: Option<(f64, f64, f64)>,
}

/// The worst case W = max_η A1/A at one law, over three branches.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Worst {
    /// ρs.
    pub rho_s: f64,
    /// ρd.
    pub rho_d: f64,
    /// max over η and branches of A1/A.
    pub amplitude1: f64,
    /// η where it occurs.
    pub eta: f64,
    /// Branch where it occurs.
    pub branch: Direction,
    /// Points that did not settle within the period budget.
    pub unsettled: usize,
    /// Points without amplitude (interrupted, resonant limit).
    pub missing: usize,
    /// η nodes where the settled steady states of the branches differ by
    /// more than 1e-6 relative (coexisting stable states on this grid;
    /// [`crate::sim::sweep::distinct_states`]).
    pub coexisting: usize,
    /// The η (lowest) of the first such node, NaN if none.
    pub coexisting_eta: f64,
    /// η evaluated (per branch).
    pub points: usize,
    /// Forcing periods integrated for it (every branch and point, points
    /// continued again after a refinement included).
    pub periods: u64,
}

/// One node of the worst-case curve.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CurvePoint {
    /// Normal force (N) of this ρs with the estimated μs.
    pub normal_force_n: f64,
    /// W at the estimated ratio μd/μs.
    pub worst: Worst,
    /// Robust worst case (uncertainty box), None where the box leaves the grid.
    pub robust: Option<f64>,
}

/// The recommended setting.
#[derive(Debug, Clone, PartialEq)]
pub struct Recommendation {
    /// Normal force (N).
    pub normal_force_n: f64,
    /// Window of settings within `window` of its robust worst case (N).
    pub interval_n: (f64, f64),
    /// ρs (nominal drive amplitude) and ρd.
    pub rho_s: f64,
    /// ρd.
    pub rho_d: f64,
    /// W at the estimate.
    pub worst: Worst,
    /// [min, max] of W over the uncertainty box (max = robust worst case).
    pub worst_interval: (f64, f64),
    /// The uncertainty box in ρs.
    pub rho_s_box: (f64, f64),
}

/// Where the η1 peak returns below the recommendation.
#[derive(Debug, Clone, PartialEq)]
pub struct Cliff {
    /// ρs of the cliff (middle of the final bisection bracket).
    pub rho_s: f64,
    /// The bracket [ρ with W above the threshold, ρ with W below].
    pub bracket: (f64, f64),
    /// Normal force of the cliff (N) with the estimated μs.
    pub normal_force_n: f64,
    /// Threshold: twice the recommendation's W.
    pub threshold: f64,
    /// W just below the cliff.
    pub worst_below: Worst,
    /// ρs_rec − ρs_cliff.
    pub margin_rho_s: f64,
    /// N_rec − N_cliff.
    pub margin_n: f64,
    /// ρs_rec / ρs_cliff − 1.
    pub margin_rel: f64,
}

/// The result of a batch.
#[derive(Debug, Clone, PartialEq)]
pub struct Batch {
    /// The logs, in input order.
    pub logs: Vec<BatchLog>,
    /// μs (robust: logs in conflict set aside where the data say which).
    pub mu_s: MuFit,
    /// μd (robust).
    pub mu_d: MuFit,
    /// μs from every log (equal to `mu_s` when nothing was set aside).
    pub mu_s_all: MuFit,
    /// μd from every log.
    pub mu_d_all: MuFit,
    /// Contradictions between logs (named, with their size).
    pub conflicts: Vec<Conflict>,
    /// μd/μs and its statistical 95 % interval.
    pub ratio: f64,
    /// Interval of the ratio.
    pub ratio_interval: (f64, f64),
    /// The rig's absorber (m, k, D).
    pub absorber: Absorber,
    /// The pad the worst cases simulate (the real-pad extensions the logs
    /// chose, combined over them).
    pub pad: BatchPad,
    /// Drive amplitude of ρ (m) and where it came from.
    pub drive_amplitude_m: f64,
    /// `nominal` or `option`.
    pub drive_amplitude_source: &'static str,
    /// Median measured drive amplitude of the logs (m).
    pub measured_drive_amplitude_m: f64,
    /// A·K2 (N).
    pub force_scale_n: f64,
    /// Drive range (η).
    pub eta_range: (f64, f64),
    /// η points of the grid per branch (uniform and fine windows).
    pub eta_points: usize,
    /// Of them, the coarse ones evaluated at every ρs node (the others
    /// next to a branch's maximum only; see [`worst_case_on`]).
    pub eta_coarse_points: usize,
    /// Setting tolerance used.
    pub setting_tolerance: f64,
    /// Window fraction used.
    pub window: f64,
    /// The worst-case curve (grid nodes, ascending ρs).
    pub curve: Vec<CurvePoint>,
    /// The recommendation, when one can be made.
    pub recommendation: Option<Recommendation>,
    /// Why no normal force is recommended (plain words), when none is.
    pub recommendation_reason: Option<String>,
    /// The cliff below it.
    pub cliff: Option<Cliff>,
    /// Worst-case evaluations (each: three branches over the η grid).
    pub evaluations: usize,
    /// Forcing periods integrated by all of them.
    pub periods: u64,
    /// Things the user should know.
    pub warnings: Vec<crate::warning::Warning>,
}

/// The drive amplitude the batch's ρ uses and its force scale A·K2.
struct DriveScale {
    amplitude_m: f64,
    source: &'static str,
    /// The logs' median measured amplitude (NaN if none).
    measured_m: f64,
    force_scale_n: f64,
}

/// The amplitude for ρ (the option, else the rig's nominal one), with a
/// warning where the logs' median measured amplitude differs by > 3 %.
fn drive_scale(
    rig: &RigMeta,
    opts: &BatchOptions,
    logs: &[BatchLog],
    warnings: &mut Vec<crate::warning::Warning>,
) -> Result<DriveScale> {
    let (amp, amp_source) = match opts.drive_amplitude_m {
        Some(a) => (a, "option"),
        None => (rig.drive_amplitude_m, "nominal"),
    };
    if !(amp.is_finite() && amp > 0.0 && rig.k2_n_per_m > 0.0) {
        return Err(BatchError::Scale {
            amplitude_m: amp,
            k2_n_per_m: rig.k2_n_per_m,
        }
        .into());
    }
    let fs = amp * rig.k2_n_per_m;
    let mut measured: Vec<f64> = logs
        .iter()
        .map(|l| l.drive_amplitude_m)
        .filter(|a| a.is_finite())
        .collect();
    measured.sort_by(f64::total_cmp);
    let measured_amp = measured
        .get(measured.len() / 2)
        .copied()
        .unwrap_or(f64::NAN);
    if measured_amp.is_finite() && (measured_amp / amp - 1.0).abs() > 0.03 {
        warnings.push(crate::warning::Warning::BatchDriveAmplitude {
            measured_m: measured_amp,
            used_m: amp,
        });
    }
    Ok(DriveScale {
        amplitude_m: amp,
        source: amp_source,
        measured_m: measured_amp,
        force_scale_n: fs,
    })
}

/// Stage 1's measured settings: the worst case of each log's model ρs (in
/// parallel), stored in the log.
fn settings_worst(
    logs: &mut [BatchLog],
    ab: &Absorber,
    shape: PadShape,
    ratio: f64,
    etas: &DriveGrid,
    opts: &BatchOptions,
    tick: &(dyn Fn(u64) + Sync),
) -> std::result::Result<(usize, u64), SimError> {
    let settings: Vec<f64> = logs
        .iter()
        .map(|l| l.model_rho_s)
        .filter(|r| r.is_finite() && *r > 0.0)
        .collect();
    let setting_w: Vec<Worst> = settings
        .par_iter()
        .map(|&r| {
            let w = worst_case_on(ab, shape, r, ratio * r, etas, &opts.steady);
            tick(1);
            w
        })
        .collect::<std::result::Result<_, _>>()?;
    let mut k = 0;
    for l in logs.iter_mut() {
        if l.model_rho_s.is_finite() && l.model_rho_s > 0.0 {
            l.worst = Some(setting_w[k]);
            k += 1;
        }
    }
    Ok((setting_w.len(), setting_w.iter().map(|w| w.periods).sum()))
}

/// The batch comparison: μs, μd with intervals from the fitted logs, the
/// worst-case curve, the recommended normal force and the cliff below it.
/// `rig` gives m, k, D and the nominal drive amplitude (see
/// [`rig_warnings`] for checking that the logs share it).
///
/// ```
/// use stickslip::batch::{batch, BatchOptions};
/// use stickslip::identify::{fit_logs, FitOptions, IdentifyOptions};
/// use std::path::PathBuf;
/// let paths: Vec<PathBuf> = ["char_N2.2.mcap", "char_N4.mcap", "char_N7.2.mcap"]
///     .iter()
///     .map(|f| PathBuf::from("datasets").join(f))
///     .collect();
/// let opts = IdentifyOptions {
///     fit: FitOptions { bootstrap: 0, ..Default::default() },
///     ..Default::default()
/// };
/// let mut fits = Vec::new();
/// let mut rig = None;
/// for (p, r) in paths.iter().zip(fit_logs(&paths, &opts, &|| {})) {
///     let (meta, fit) = r?;
///     rig.get_or_insert(meta);
///     fits.push((p.clone(), fit));
/// }
/// // A coarse grid keeps the example short.
/// let bopts = BatchOptions { eta_points: 41, rho_points: 8, refine: false, ..Default::default() };
/// let b = batch(&fits, &rig.unwrap(), &bopts)?;
/// // One pad: μs ≥ μd, each with an interval around it.
/// let (lo, hi) = b.mu_s.interval;
/// assert!(lo <= b.mu_s.mu && b.mu_s.mu <= hi && b.mu_d.mu <= b.mu_s.mu);
/// # Ok::<(), stickslip::Error>(())
/// ```
pub fn batch(fits: &[(PathBuf, LogFit)], rig: &RigMeta, opts: &BatchOptions) -> Result<Batch> {
    batch_with_progress(fits, rig, opts, &|_| {})
}

/// Refinement factor of the ρs grid around the best candidates.
const REFINE: usize = 4;

/// [`batch`] with a progress callback (`tick(n)`: n more worst-case
/// evaluations done).
///
/// Read top to bottom it is the batch's stages: the logs' observations
/// and coefficients (`observations.rs`), the ratio μd/μs, the force scale,
/// the η and ρs grids with the settings' uncertainty box (`rho_grid`),
/// stage 1 (coarse grid and the measured settings), the recommendation
/// search (`recommend.rs`) and the curve (`curve_points`).
pub fn batch_with_progress(
    fits: &[(PathBuf, LogFit)],
    rig: &RigMeta,
    opts: &BatchOptions,
    tick: &(dyn Fn(u64) + Sync),
) -> Result<Batch> {
    opts.check()
        .map_err(|e| BatchError::Options(e.to_string()))?;
    if fits.is_empty() {
        return Err(BatchError::Empty.into());
    }
    let mut warnings = Vec::new();
    let mut logs = observe_logs(fits, &mut warnings)?;
    let Coefficients {
        mu_s,
        mu_d,
        mu_s_all,
        mu_d_all,
        conflicts,
    } = fit_coefficients(&mut logs, opts.normal_force_gain_uncertainty, &mut warnings)?;
    let (ratio, ratio_interval) = ratio_estimate(&mu_s, &mu_d);
    let mut pad = pad::batch_pad(fits, &mut warnings);

    let ab = rig.constants().absorber();
    ab.validate().map_err(BatchError::Rig)?;
    let DriveScale {
        amplitude_m: amp,
        source: amp_source,
        measured_m: measured_amp,
        force_scale_n: fs,
    } = drive_scale(rig, opts, &logs, &mut warnings)?;
    let rho_of = |n: f64| mu_s.mu * n / fs;
    let n_of = |rho: f64| rho * fs / mu_s.mu;
    for l in logs.iter_mut() {
        l.model_rho_s = rho_of(l.normal_force_n);
    }

    let eta_range = opts.eta_range.unwrap_or_else(|| default_eta_range(&ab));
    let etas = drive_grid(
        &ab,
        eta_range,
        opts.eta_points,
        opts.eta_fine_step,
        opts.eta_fine_halfwidth,
        opts.eta_coarse_stride,
    );
    pad.set_reference(rho_of);
    let shape = pad.shape;
    // The robust worst case's variants: the corners of μd/μs's interval
    // and of the simulated pad's κ (and γ where κ depends on N) and
    // ρs⁻/ρs⁺ (their point values alone said nothing of how well the logs
    // know them).
    let mut variants = vec![(ratio, shape)];
    if opts.ratio_variants {
        let ratios = if ratio_interval.1 - ratio_interval.0 > 1e-12 {
            vec![ratio_interval.0, ratio_interval.1]
        } else {
            vec![ratio]
        };
        let mut corners = pad.shape_variants();
        if let Some(c) = pad.contact.as_mut() {
            c.in_robust = corners.iter().any(|s| {
                s.contact_stiffness != shape.contact_stiffness
                    || s.contact_power != shape.contact_power
            });
        }
        if let Some(c) = pad.split.as_mut() {
            c.in_robust = corners
                .iter()
                .any(|s| s.rs_minus_ratio != shape.rs_minus_ratio);
        }
        if corners.is_empty() {
            corners.push(shape);
        }
        for &r in &ratios {
            variants.extend(
                corners
                    .iter()
                    .filter(|&&s| (r, s) != (ratio, shape))
                    .map(|&s| (r, s)),
            );
        }
    }
    let RhoGrid {
        fa,
        fb,
        box_ok,
        rho_min,
        rho_max,
    } = rho_grid(opts, &mu_s, &logs)?;
    let mut table = Table {
        ab,
        etas: &etas,
        cfg: opts.steady,
        variants,
        nodes: Vec::new(),
        evaluations: 0,
        periods: 0,
        tick,
    };
    let sim_err = BatchError::Sim;
    // Stage 1: the coarse grid at the estimated ratio, and the measured
    // settings.
    let steps = opts.rho_points - 1;
    let coarse: Vec<f64> = (0..=steps)
        .map(|k| geom_node(rho_min, rho_max, steps, k))
        .collect();
    table.add(&coarse, false).map_err(sim_err)?;
    let (n, periods) =
        settings_worst(&mut logs, &ab, shape, ratio, &etas, opts, tick).map_err(sim_err)?;
    table.evaluations += n;
    table.periods += periods;
    let search = recommend::Search {
        ab,
        shape,
        etas: &etas,
        opts,
        ratio,
        coarse: &coarse,
        steps,
        rho_min,
        rho_max,
        fa,
        fb,
        box_ok,
        mu_words: format!(
            "μs = {:.4} with the 95 % interval [{:.4}, {:.4}]",
            mu_s.mu, mu_s.interval.0, mu_s.interval.1
        ),
        mu_s_interval: mu_s.interval,
        unresolved: conflicts
            .iter()
            .any(|c| c.quantity == "mu_s" && c.kind != "scatter" && !c.set_aside),
        n_of: &n_of,
        tick,
    };
    let outcome = search.run(&mut table, &mut warnings).map_err(sim_err)?;
    let (recommendation, cliff, recommendation_reason) = match outcome {
        Ok((r, c)) => (Some(r), c, None),
        Err(reason) => {
            let reason = reason.to_string();
            warnings.push(crate::warning::Warning::NoRecommendation {
                reason: reason.clone(),
            });
            (None, None, Some(reason))
        }
    };

    let curve = curve_points(&table, box_ok.then_some((fa, fb)), &n_of, &mut warnings);
    Ok(Batch {
        logs,
        mu_s,
        mu_d,
        mu_s_all,
        mu_d_all,
        conflicts,
        ratio,
        ratio_interval,
        absorber: ab,
        pad,
        drive_amplitude_m: amp,
        drive_amplitude_source: amp_source,
        measured_drive_amplitude_m: measured_amp,
        force_scale_n: fs,
        eta_range,
        eta_points: etas.etas.len(),
        eta_coarse_points: etas.coarse.iter().filter(|&&c| c).count(),
        setting_tolerance: opts.setting_tolerance,
        window: opts.window,
        curve,
        recommendation,
        recommendation_reason,
        cliff,
        evaluations: table.evaluations,
        periods: table.periods,
        warnings,
    })
}

/// What each log says ([`log_obs`]), after refusing a negative (or NaN)
/// normal force, the first such log named; a zero normal force is a
/// warning per log (its μ is null).
fn observe_logs(fits: &[(PathBuf, LogFit)], warnings: &mut Vec<Warning>) -> Result<Vec<BatchLog>> {
    // A negative normal force is a sign or unit mistake: μ from it would
    // be meaningless (a zero one gives μ null and a warning, below).
    if let Some((p, f)) = fits
        .iter()
        .find(|(_, f)| f.normal_force_n < 0.0 || f.normal_force_n.is_nan())
    {
        return Err(BatchError::Options(format!(
            "{}: the normal force is {} N (negative): a sign or unit mistake in the log? batch compares settings by μ = R/N and cannot use it",
            p.display(),
            f.normal_force_n
        ))
        .into());
    }
    for (p, _) in fits.iter().filter(|(_, f)| f.normal_force_n == 0.0) {
        warnings.push(crate::warning::Warning::LogNormalForceZero { log: p.clone() });
    }
    Ok(fits.iter().map(|(p, f)| log_obs(p, f, warnings)).collect())
}

/// The ratio μd/μs (at most 1) and its interval: the common calibration
/// cancels; the statistical parts add in quadrature.
fn ratio_estimate(mu_s: &MuFit, mu_d: &MuFit) -> (f64, (f64, f64)) {
    let ratio = (mu_d.mu / mu_s.mu).min(1.0);
    let rel = |m: &MuFit| 0.5 * (m.stat_interval.1 - m.stat_interval.0) / m.mu;
    let rr = rel(mu_s).hypot(rel(mu_d));
    let ratio_interval = ((ratio * (1.0 - rr)).max(0.0), (ratio * (1.0 + rr)).min(1.0));
    (ratio, ratio_interval)
}

/// The ρs grid's ends and a setting's uncertainty box.
struct RhoGrid {
    /// The box as factors (fa, fb) on a setting's nominal ρs.
    fa: f64,
    /// See `fa`.
    fb: f64,
    /// The box is narrow enough to search for.
    box_ok: bool,
    /// The grid's lower end.
    rho_min: f64,
    /// The grid's upper end.
    rho_max: f64,
}

/// A setting's uncertainty box (μs's interval and the setting tolerance)
/// and the ρs grid: from the option, else covering every measured setting
/// (at least ρs = 3) and room for a few candidates whose whole box fits;
/// an empty grid is the error.
fn rho_grid(opts: &BatchOptions, mu_s: &MuFit, logs: &[BatchLog]) -> Result<RhoGrid> {
    // The uncertainty box of a setting, as factors on its nominal ρs.
    let t = opts.setting_tolerance;
    let (fa, fb) = (
        mu_s.interval.0 / mu_s.mu * (1.0 - t),
        mu_s.interval.1 / mu_s.mu * (1.0 + t),
    );
    // A box wider than this factor is not searched for (the grid would be
    // meaningless); the batch then says so instead of recommending.
    const MAX_BOX: f64 = 1e3;
    let box_ok = fa > 0.0 && fb.is_finite() && fb / fa <= MAX_BOX;
    let measured_max = logs
        .iter()
        .map(|l| l.model_rho_s)
        .filter(|r| r.is_finite())
        .fold(0.0f64, f64::max);
    let rho_min = opts.rho_min;
    // The default grid covers every measured setting (at least ρs = 3) and
    // room for a few candidates whose whole box fits.
    let rho_max = opts.rho_max.unwrap_or_else(|| {
        let need = if box_ok { 8.0 * rho_min * fb / fa } else { 0.0 };
        (1.1 * measured_max).max(3.0).max(need)
    });
    if rho_max <= rho_min {
        return Err(BatchError::RhoRange {
            min: rho_min,
            max: rho_max,
        }
        .into());
    }
    Ok(RhoGrid {
        fa,
        fb,
        box_ok,
        rho_min,
        rho_max,
    })
}

/// The worst-case curve over the table's nodes in normal force (`n_of`),
/// with the robust worst case where the uncertainty box `(fa, fb)` is
/// searched for; a warning counts the steady states without amplitude.
fn curve_points(
    table: &Table<'_>,
    box_factors: Option<(f64, f64)>,
    n_of: &dyn Fn(f64) -> f64,
    warnings: &mut Vec<Warning>,
) -> Vec<CurvePoint> {
    let rob: Vec<Option<f64>> = match box_factors {
        Some((fa, fb)) => recommend::robust_all(table, fa, fb),
        None => vec![None; table.nodes.len()],
    };
    let curve: Vec<CurvePoint> = table
        .nodes
        .iter()
        .zip(&rob)
        .map(|((r, w), rb)| CurvePoint {
            normal_force_n: n_of(*r),
            worst: w[0],
            robust: *rb,
        })
        .collect();
    let missing: usize = table
        .nodes
        .iter()
        .flat_map(|(_, w)| w.iter().map(|w| w.missing))
        .sum();
    if missing > 0 {
        warnings.push(crate::warning::Warning::MissingSteadyStates { missing });
    }
    curve
}

#[cfg(test)]
mod tests {
    use super::*;

    /// ln Φ against known values, including the far tails.
    #[test]
    fn normal_cdf_log() {
        let cases = [
            (0.0, 0.5f64.ln()),
            (1.959_963_985, 0.975f64.ln()),
            (-1.959_963_985, 0.025f64.ln()),
            // Φ(−10) = 7.6198530241605e−24.
            (-10.0, 7.619_853_024_160_5e-24f64.ln()),
            // Φ(−30) = 4.906713927148187e−198.
            (-30.0, 4.906_713_927_148_187e-198f64.ln()),
        ];
        for (z, want) in cases {
            let got = ln_norm_cdf(z);
            assert!(
                (got - want).abs() < 2e-7 * want.abs().max(1e-7) + 1e-9,
                "z {z}: {got} vs {want}"
            );
        }
        assert!(ln_norm_cdf(12.0) < 0.0 && ln_norm_cdf(12.0) > -1e-30);
    }

    /// Exact points: the estimate is the common ratio; a consistent stuck
    /// bound does not move it, an inconsistent one pulls it up.
    #[test]
    fn censored_fit() {
        let pts = [(2.0, 0.84, 0.01), (4.0, 1.68, 0.02), (7.0, 2.94, 0.03)];
        let mut obs: Vec<Obs> = pts
            .iter()
            .map(|&(n, r, s)| Obs::Point { n, r, s })
            .collect();
        let (mu, (lo, hi), birge, chi2) = fit_mu(&obs).unwrap();
        assert!((mu - 0.42).abs() < 1e-9, "{mu}");
        // σ_μ = 1/√Σ(N/σ)² = 0.002727: the interval is ±1.96 σ_μ.
        let s_mu = 1.0 / (40000.0f64 + 40000.0 + 49.0 / 9e-4).sqrt();
        assert!(
            (hi - lo - 2.0 * 1.96 * s_mu).abs() < 1e-3 * s_mu,
            "{lo} {hi}"
        );
        assert_eq!(birge, 1.0);
        assert!(chi2.unwrap() < 1e-12);
        // Stuck at 30 N with a bound of 5 N (μ > 0.167): no information.
        obs.push(Obs::Above {
            n: 30.0,
            lb: 5.0,
            s: 0.1,
        });
        let (mu2, ..) = fit_mu(&obs).unwrap();
        assert!((mu2 - 0.42).abs() < 1e-6, "{mu2}");
        // A bound at 14 N (μ > 0.467) contradicts the points and pulls μ up.
        obs.pop();
        obs.push(Obs::Above {
            n: 30.0,
            lb: 14.0,
            s: 0.1,
        });
        let (mu3, ..) = fit_mu(&obs).unwrap();
        assert!(mu3 > 0.425, "{mu3}");
        // Never sticking at 1.2 N: Rs ∈ [0.40, 0.89] → no information.
        obs.pop();
        obs.push(Obs::Between {
            n: 1.2,
            lo: 0.40,
            slo: 0.005,
            hi: 0.89,
            shi: 0.01,
        });
        let (mu4, ..) = fit_mu(&obs).unwrap();
        assert!((mu4 - 0.42).abs() < 1e-6, "{mu4}");
        // The free fit recovers a zero intercept.
        let (s, a, hw) = free_fit(&pts).unwrap();
        assert!((s - 0.42).abs() < 1e-12 && a.abs() < 1e-12 && hw > 0.0);
    }

    /// A never-sticks bound that contradicts the points (its Rd far above
    /// μN) keeps the likelihood finite (it was −∞ with the difference
    /// form, which produced a μ interval of [0, 2e18]); the robust
    /// selection sets the bound aside, not the two points that agree.
    #[test]
    fn contradicting_bound_is_set_aside() {
        let obs = [
            Obs::Point {
                n: 3.2,
                r: 0.42 * 3.2,
                s: 0.005,
            },
            Obs::Point {
                n: 3.6,
                r: 0.42 * 3.6 * 1.002,
                s: 0.005,
            },
            Obs::Between {
                n: 1.2,
                lo: 0.60 * 1.2,
                slo: 0.002,
                hi: 3.0,
                shi: 0.01,
            },
        ];
        // With every observation: a compromise with a wide (Birge-inflated)
        // but finite interval.
        let (mu, (lo, hi), ..) = fit_mu(&obs).unwrap();
        assert!(
            mu > 0.42 && mu < 0.6 && lo >= 0.0 && hi < 2.0,
            "{mu} [{lo}, {hi}]"
        );
        let all = [true; 3];
        let (t, thr, rel, _) = loo(&obs, &all, 2).unwrap();
        assert!(t > thr && rel > 0.3, "{t} {thr} {rel}");
        let (kept, resolved) = robust_keep(&obs, &[0.0; 3]);
        assert_eq!(kept, vec![true, true, false]);
        assert!(resolved);
        let (mu2, ..) = fit_mu(&obs[..2]).unwrap();
        assert!((mu2 / 0.42 - 1.0).abs() < 0.002, "{mu2}");
    }

    /// A measured point of another pad among points that scatter beyond
    /// their own σ (as real logs do): the outlier goes, not a good point.
    #[test]
    fn outlier_among_scattered_points() {
        let obs = [
            Obs::Point {
                n: 1.21,
                r: 0.71,
                s: 0.001,
            },
            Obs::Point {
                n: 2.22,
                r: 0.34 * 2.22,
                s: 0.0005,
            },
            Obs::Point {
                n: 3.22,
                r: 0.34 * 3.22 * 1.01,
                s: 0.0006,
            },
            Obs::Point {
                n: 3.62,
                r: 0.34 * 3.62 * 0.995,
                s: 0.0007,
            },
        ];
        let all = [true; 4];
        assert!(dixon_outlier(&obs, &all, 0));
        assert!((1..4).all(|k| !dixon_outlier(&obs, &all, k)));
        let (kept, resolved) = robust_keep(&obs, &[0.0; 4]);
        assert_eq!(kept, vec![false, true, true, true]);
        assert!(resolved);
    }

    /// Two measured points that contradict each other, and nothing else:
    /// the data cannot say which is off (with three observations one may
    /// go). Only when one log's own estimates disagree is it set aside.
    #[test]
    fn symmetric_pair_needs_a_reason() {
        let obs = [
            Obs::Point {
                n: 3.0,
                r: 0.36 * 3.0,
                s: 0.01,
            },
            Obs::Point {
                n: 3.5,
                r: 0.42 * 3.5,
                s: 0.01,
            },
            Obs::Above {
                n: 8.0,
                lb: 0.2 * 8.0,
                s: 0.01,
            },
        ];
        let (kept, resolved) = robust_keep(&obs, &[0.0; 3]);
        assert_eq!(kept, vec![true; 3]);
        assert!(!resolved);
        let (kept, resolved) = robust_keep(&obs, &[2.5, 0.5, 0.0]);
        assert_eq!(kept, vec![false, true, true]);
        assert!(resolved);
        // The pair tension is symmetric.
        let (a, b) = (
            pair_tension(&obs[0], &obs[1]),
            pair_tension(&obs[1], &obs[0]),
        );
        assert!((a - b).abs() < 1e-12 && a > 3.0, "{a} {b}");
    }

    /// Scattered points inflate σ (Birge) and the interval grows with it;
    /// the profile interval of exact Gaussian points is ±1.96 σ_μ.
    #[test]
    fn profile_interval_and_scatter() {
        let obs = [
            Obs::Point {
                n: 1.0,
                r: 1.0,
                s: 0.1,
            },
            Obs::Point {
                n: 2.0,
                r: 2.0,
                s: 0.1,
            },
        ];
        let (mu, (lo, hi), _, _) = fit_mu(&obs).unwrap();
        let s_mu = 0.1 / 5f64.sqrt();
        assert!((mu - 1.0).abs() < 1e-12);
        assert!((hi - mu - 1.96 * s_mu).abs() < 1e-3 * s_mu, "{hi}");
        assert!((mu - lo - 1.96 * s_mu).abs() < 1e-3 * s_mu, "{lo}");
        let scattered = [
            Obs::Point {
                n: 1.0,
                r: 1.2,
                s: 0.01,
            },
            Obs::Point {
                n: 2.0,
                r: 1.8,
                s: 0.01,
            },
            Obs::Point {
                n: 3.0,
                r: 3.3,
                s: 0.01,
            },
        ];
        let (_, (lo, hi), birge, chi2) = fit_mu(&scattered).unwrap();
        assert!(birge > 5.0, "{birge} {chi2:?}");
        assert!(hi - lo > 0.05);
    }

    /// Logs whose sensors' gains differ (each log's Rd off by up to 0.8 %,
    /// within its 1 % calibration half-width, but 8σ of its statistical
    /// σ apart): no conflict and no scatter beyond the whole intervals; a
    /// log 10 % off (another pad) is still in conflict and set aside. (One
    /// 6 % off is not found: against four others that scatter 1.6 %
    /// end to end, Dixon's Q is 0.76 < 0.82 at 99 %, and the others'
    /// own scatter, from three degrees of freedom, puts the 3σ quantile at
    /// t = 9.2.)
    #[test]
    fn per_log_gains_are_no_conflict() {
        let gains = [1.008, 0.994, 1.0, 0.992, 1.006];
        let items: Vec<Item> = gains
            .iter()
            .enumerate()
            .map(|(i, g)| {
                let n = 1.0 + 1.5 * i as f64;
                let r = 0.34 * n * g;
                (i, Obs::Point { n, r, s: 0.001 * r }, Some(0.01))
            })
            .collect();
        // Statistical σ alone: the gains look like conflicts.
        let stat: Vec<Obs> = items.iter().map(|x| x.1).collect();
        let (_, _, birge, _) = fit_mu(&stat).unwrap();
        assert!(birge > 5.0, "{birge}");
        let obs = tension_obs(&items, 0.0);
        let all = [true; 5];
        assert!((0..5).all(|k| !in_conflict(&obs, &all, k)));
        assert_eq!(robust_keep(&obs, &[0.0; 5]).0, vec![true; 5]);
        let (_, _, scatter, _) = fit_mu(&obs).unwrap();
        assert!(scatter < 1.5, "{scatter}");
        // One log of another pad, 10 % off.
        let mut other = items.clone();
        if let Obs::Point { r, s, .. } = &mut other[2].1 {
            *r *= 1.10;
            *s *= 1.10;
        }
        let obs = tension_obs(&other, 0.0);
        assert!(in_conflict(&obs, &all, 2));
        let (kept, resolved) = robust_keep(&obs, &[0.0; 5]);
        assert_eq!(kept, vec![true, true, false, true, true]);
        assert!(resolved);
    }

    /// An interval split into its calibration part and the log's own.
    #[test]
    fn calibration_split() {
        // Combined half-width 5, calibration 3: own 4 (σ 4/1.96).
        let (s, c) = split_by_calibration(100.0, Some((95.0, 105.0)), Some(3.0));
        assert!((s.unwrap() - 4.0 / 1.96).abs() < 1e-12 && (c.unwrap() - 0.03).abs() < 1e-15);
        // Unknown calibration part: the whole interval is the log's own.
        let (s, c) = split_by_calibration(100.0, Some((95.0, 105.0)), None);
        assert!((s.unwrap() - 5.0 / 1.96).abs() < 1e-12 && c.is_none());
        // All calibration: no statistical σ (the log is not a point).
        let (s, _) = split_by_calibration(100.0, Some((95.0, 105.0)), Some(6.0));
        assert!(s.is_none());
    }

    /// The systematic part adds in quadrature.
    #[test]
    fn systematic_in_quadrature() {
        let (lo, hi) = with_systematic(1.0, (0.97, 1.04), 0.03);
        assert!((1.0 - lo - 0.03f64.hypot(0.03)).abs() < 1e-12);
        assert!((hi - 1.0 - 0.04f64.hypot(0.03)).abs() < 1e-12);
    }

    /// The η grid contains the fine windows and stays sorted and unique.
    #[test]
    fn eta_grid_windows() {
        let ab = Absorber::default();
        let r = default_eta_range(&ab);
        assert!(
            (r.0 - 0.2185).abs() < 1e-3 && (r.1 - 1.6015).abs() < 1e-3,
            "{r:?}"
        );
        let v = drive_etas(&ab, r, 141, 0.001, 0.025);
        assert!(v.windows(2).all(|w| w[1] > w[0]));
        let (e1, _) = ab.eta_linear();
        assert!(v.iter().any(|e| (e - e1).abs() < 1e-12));
        assert!(v.len() > 141 + 3 * 45);
    }

    /// The robust worst case takes every variant of the pad: a node
    /// evaluated with `all` holds W of each (ratio, shape) variant, the
    /// same as the worst case of that pad alone, and the robust value at
    /// the node is their maximum (a softer contact at the interval's low
    /// end raises it here).
    #[test]
    fn the_robust_worst_case_holds_every_pad_variant() {
        let ab = Absorber::default();
        let etas = drive_grid(&ab, default_eta_range(&ab), 41, 0.0, 0.0, 1);
        let shape = |k: f64| PadShape {
            contact_stiffness: Some(k),
            ..PadShape::PAPER
        };
        let variants = vec![(0.8, shape(20.0)), (0.8, shape(2.0)), (0.8, shape(200.0))];
        let tick = |_: u64| {};
        let mut table = Table {
            ab,
            etas: &etas,
            cfg: BatchOptions::default().steady,
            variants: variants.clone(),
            nodes: Vec::new(),
            evaluations: 0,
            periods: 0,
            tick: &tick,
        };
        let rho = 1.0;
        table.add(&[rho], false).unwrap();
        assert_eq!(table.robust(rho, rho, false), None);
        table.add(&[rho], true).unwrap();
        assert_eq!(table.evaluations, 3);
        let table_cfg = BatchOptions::default().steady;
        let alone: Vec<f64> = variants
            .iter()
            .map(|&(r, s)| {
                worst_case_on(&ab, s, rho, r * rho, &etas, &table_cfg)
                    .unwrap()
                    .amplitude1
            })
            .collect();
        let at: Vec<f64> = table.nodes[0].1.iter().map(|w| w.amplitude1).collect();
        assert_eq!(at, alone);
        let robust = table.robust(rho, rho, false).unwrap();
        assert_eq!(robust, alone.iter().copied().fold(0.0, f64::max));
        assert_eq!(table.robust(rho, rho, true), Some(alone[0]));
        assert!(robust > alone[0], "{alone:?}");
    }

    /// The coarse part of the drive grid: stride 1 is the whole grid of
    /// `drive_etas`; stride 4 keeps both ends, the window centres (η1, η0,
    /// η2) and every 4th point, and the same η values.
    #[test]
    fn drive_grid_coarse_part() {
        let ab = Absorber::default();
        let r = default_eta_range(&ab);
        let all = drive_etas(&ab, r, 141, 0.002, 0.025);
        let g1 = drive_grid(&ab, r, 141, 0.002, 0.025, 1);
        assert_eq!(g1.etas, all);
        assert!(g1.is_uniform());
        let g4 = drive_grid(&ab, r, 141, 0.002, 0.025, 4);
        assert_eq!(g4.etas, all);
        assert!(!g4.is_uniform());
        let coarse: Vec<f64> = g4
            .etas
            .iter()
            .zip(&g4.coarse)
            .filter_map(|(e, c)| c.then_some(*e))
            .collect();
        assert_eq!(coarse.first(), all.first());
        assert_eq!(coarse.last(), all.last());
        let (e1, e2) = ab.eta_linear();
        for c in [e1, ab.eta_stuck(), e2] {
            assert!(coarse.iter().any(|e| (e - c).abs() < 1e-12), "{c}");
        }
        // 36 of the 141 uniform points, 7 of each window's 27.
        assert!(
            coarse.len() < all.len() / 3,
            "{} of {}",
            coarse.len(),
            all.len()
        );
        // No gap of the coarse grid is wider than 4 uniform steps.
        let h = (r.1 - r.0) / 140.0;
        assert!(coarse
            .windows(2)
            .all(|w| w[1] - w[0] <= 4.0 * h * (1.0 + 1e-9)));
    }

    /// The refined search against the uniform one on the same grid (m 4,
    /// k 1, D 0.003 and m 2, k 0.5, D 0.01; ratios 0.8 and 0.6): where the
    /// uniform search's worst case settled, W agrees to 1e-3 (the refinement
    /// finds the same maximum); elsewhere the maximum is that of a
    /// non-periodic response, whose amplitude wanders with the path and run
    /// length (documented at ±2 %), so the two agree to 3 %. The refined
    /// search evaluates at most half the points.
    #[test]
    fn refined_search_matches_uniform() {
        let o = BatchOptions::default();
        let cases = [
            (
                Absorber {
                    m: 4.0,
                    k: 1.0,
                    damping: 0.003,
                },
                0.8,
                [0.3, 0.85, 1.0, 1.3, 3.0],
            ),
            (
                Absorber {
                    m: 2.0,
                    k: 0.5,
                    damping: 0.01,
                },
                0.6,
                [0.2, 0.5, 0.8, 1.2, 2.5],
            ),
        ];
        for (ab, ratio, rhos) in cases {
            let r = default_eta_range(&ab);
            let grid = drive_grid(
                &ab,
                r,
                o.eta_points,
                o.eta_fine_step,
                o.eta_fine_halfwidth,
                o.eta_coarse_stride,
            );
            for rho in rhos {
                let u = worst_case(
                    &ab,
                    PadShape::PAPER,
                    rho,
                    ratio * rho,
                    &grid.etas,
                    &o.steady,
                )
                .unwrap();
                let a = worst_case_on(&ab, PadShape::PAPER, rho, ratio * rho, &grid, &o.steady)
                    .unwrap();
                // Whether the uniform maximum is a settled steady state.
                let m = worst_model(&ab, PadShape::PAPER, rho, ratio * rho).unwrap();
                let branch = curve(&m, &grid.etas, u.branch, &o.steady).unwrap();
                let settled = branch.iter().any(|p| p.eta == u.eta && p.steady);
                let tol = if settled { 1e-3 } else { 0.03 };
                let e = a.amplitude1 / u.amplitude1 - 1.0;
                assert!(
                    e.abs() < tol,
                    "{ab:?} ρs {rho}: refined W {} at η {} against uniform {} at η {} ({})",
                    a.amplitude1,
                    a.eta,
                    u.amplitude1,
                    u.eta,
                    if settled { "settled" } else { "not settled" }
                );
                assert!(a.points <= grid.etas.len() / 2, "{} points", a.points);
                assert_eq!(u.points, grid.etas.len());
            }
        }
    }

    /// The default worst-case grid and budget (fine step 0.002, 200
    /// periods) against a dense reference (fine step 0.001, 2000 periods)
    /// at m = 4, k = 1, D = 0.003 (the public rig), ratio 0.8. Where the
    /// worst case is a periodic response (the η1 peak back, the optimum,
    /// the start of stick-slip near η0) W agrees to 0.1 %. Where it is the
    /// non-periodic stick-slip near η0, W is itself uncertain: the amplitude
    /// there wanders with the run length (ρs = 1.8, ρd = 1.44, η = 0.70:
    /// 2.424, 2.502, 2.464, 2.450 after 200, 500, 2000, 20 000 periods,
    /// 3.2 % peak to peak), so the two agree only to that spread (measured:
    /// 1.8 % at ρs = 1.673, below 0.9 % at 30 other nodes).
    #[test]
    fn default_grid_matches_dense_reference() {
        let ab = Absorber {
            m: 4.0,
            k: 1.0,
            damping: 0.003,
        };
        let r = default_eta_range(&ab);
        let o = BatchOptions::default();
        let dense = drive_etas(&ab, r, o.eta_points, 0.001, o.eta_fine_halfwidth);
        let fast = drive_etas(&ab, r, o.eta_points, o.eta_fine_step, o.eta_fine_halfwidth);
        let refined = drive_grid(
            &ab,
            r,
            o.eta_points,
            o.eta_fine_step,
            o.eta_fine_halfwidth,
            o.eta_coarse_stride,
        );
        let reference = SteadyConfig {
            max_periods: 2000,
            ..o.steady
        };
        for (rho, tol) in [
            (0.8145, 1e-3),
            (0.9478, 1e-3),
            (1.1455, 1e-3),
            (1.2833, 0.032),
            (1.673, 0.032),
            (2.0219, 0.032),
        ] {
            let a = worst_case(&ab, PadShape::PAPER, rho, 0.8 * rho, &dense, &reference).unwrap();
            let b = worst_case(&ab, PadShape::PAPER, rho, 0.8 * rho, &fast, &o.steady).unwrap();
            let c =
                worst_case_on(&ab, PadShape::PAPER, rho, 0.8 * rho, &refined, &o.steady).unwrap();
            for (w, what) in [(b, "uniform"), (c, "refined")] {
                let e = w.amplitude1 / a.amplitude1 - 1.0;
                assert!(
                    e.abs() < tol,
                    "ρs {rho}: {what} W {} against the reference {}",
                    w.amplitude1,
                    a.amplitude1
                );
            }
        }
    }
}
