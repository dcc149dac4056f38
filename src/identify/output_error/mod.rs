//! Output-error refinement: the law (and the nuisance parameters) such that
//! the simulator, driven by the measured drive, reproduces the measured x1
//! and x2.
//!
//! * **Model**: the rig's equations of motion (rig-log-format) in the
//!   engine's dimensionless form with the measured drive amplitude A as the
//!   length scale: `ζ = (x/g − p)/A` for the positions, `ζ0` the fitted drive
//!   sinusoid (the exact event-driven engine, [`crate::sim::engine::Sim`]),
//!   or, when the drive's residual from that sinusoid exceeds three times
//!   its noise, the sampled drive channel on the numerical engine
//!   ([`crate::model::Drive::Sampled`]; its steps are bounded by the
//!   sampling rate, so it is about 25× slower).
//! * **Multiple shooting**: a stick-slip trajectory is sensitive to its
//!   initial state, so the log is cut into segments that each restart near
//!   the measured state. Anchors sit at the middle of every stick phase (M2
//!   at rest: ẋ2 = 0 exactly, ζ2 from the mean of x2 over the stick's inner
//!   half, x1 and ẋ1 from a cubic Savitzky–Golay fit over ±1/20 of a drive
//!   period) and, where sticks are further apart than 3/4 of a period (a
//!   log that never sticks), at the velocity peaks of the slips (ẋ2 from
//!   the derivative of x2: its gain is estimated here, the velocity
//!   channel's is not). A segment spans [`OeOptions::span`] anchor
//!   intervals (three: 1.5 drive periods, three breakaways and slips).
//! * **Free segment starts**: the measured start states are noisy, and a
//!   noisy start biases the law (errors in variables: a rising slope damps
//!   the propagated start error, so a slope came out 10–40 % too positive
//!   in high-ρs logs, and a smoothed ζ1 biased ρs by −0.014 % even on
//!   ideal sensors). The starts are therefore free parameters of each
//!   segment (ζ1, ζ1', ζ2; plus ζ2' at a slip anchor), eliminated by
//!   linearised variable projection: the residual directions of each free
//!   component (one extra simulation each) are projected out of the
//!   segment's residuals, and the starts are moved to their least-squares
//!   values before each minimisation pass (two passes). Per-segment
//!   nuisance parameters carry an incidental-parameter bias that shrinks
//!   with the data per segment: −0.027 % in ρs with one anchor interval per
//!   segment, +0.004 % (sd 0.025 %) with three (200 synthetic repeats).
//! * **Nuisance parameters**: the sensors' zero offsets p1, p2 (they act as
//!   constant forces) and the gains g1, g2 of x1 and x2 relative to the
//!   drive channel. The bias b = K2·(p1 − p2) and the gains are fitted with
//!   the law; p1 follows from the time average of M1's equation of motion
//!   over the samples where every term is known (exact, gaps or not:
//!   `K1(x1 − p1 − x0) + K2(x1 − x2 − b/K2) + M1ẍ1 + d(ẋ1 − ẋ2) = 0`).
//!   Because the position gains are estimated against the drive, ρ and D*
//!   do not depend on any sensor gain; forces in newtons carry the drive
//!   channel's gain (ρ·A·K2 with the measured A).
//! * **Cost**: the squared residuals of x1 and x2, each in units of its
//!   noise (from second differences), at every `stride`-th sample (4: the
//!   estimates move by < 0.05 % against every sample), start directions
//!   projected out. Minimised by Levenberg–Marquardt on the residual
//!   vector (forward-difference Jacobians; notes in `lm.rs`) from the best of
//!   the equation-error law and, for the richer families, the Coulomb
//!   optimum (nested starts). Nelder–Mead on the cost (argmin), the
//!   minimiser until session 13, stays selectable
//!   ([`OeOptions::minimiser`]): the same optimum within 0.003 of an
//!   interval's half-width on every bundled log, with about four times the
//!   simulations.
//! * **Family selection**: each simple family (Coulomb, `decreasing`,
//!   static-dynamic) is refined, static-dynamic also where the
//!   segmentation saw no stick (from the best of a screen of thresholds
//!   above the Coulomb optimum: the simulator says where sticks happen);
//!   where the chosen simple family fails the adequacy test (below), or
//!   static/dynamic passes it but x2's residuals follow the motion (z >
//!   3.7, at least 0.02 of the noise), the
//!   Stribeck family `Rd + (Rs − Rd)·exp(−(v/v_s)²) + a·v` is refined too
//!   (from the equation-error Stribeck law and from the static-dynamic
//!   optimum with v_s at 3, 10 and 30 % of A·ω) on the numerical engine,
//!   and competes by the same criterion; the criterion is BIC, `n_eff·ln(S/N) + k·ln(n_eff)` (k law
//!   parameters), with the honest effective sample size n_eff = n/τ_int,
//!   τ_int the integrated autocorrelation time of the richest family's
//!   residuals within segments. The simplest family within 2 of the lowest
//!   BIC is chosen, and one whose extra parameter's interval holds the
//!   nested value gives way to Coulomb. A threshold the segmentation did
//!   not see must beat every stick-free family by more than 10. A chosen
//!   static/dynamic law gets the profile of `drop.rs`: how low a Stribeck
//!   drop the log cannot resolve would put Rs.
//! * **Real pads** (`docs/real-pads.md`): a static threshold split by
//!   direction (Δ, in the gauge "equal dynamic levels": unknown sensor
//!   zeros leave only that identifiable) and a contact spring (ln κ) are
//!   extra parameters at the end of θ ([`Ext`]), refined where the screen
//!   (`identify::pads`) saw them or the law fails the adequacy test, from
//!   the optimum they extend, and chosen by the same criterion. A side the
//!   simulated law never breaks away towards is only bounded; behind a
//!   contact spring an unresolved threshold is Rs ≥ Rd only, bounded above
//!   by its profile (`profile.rs`), which also widens κ's interval.
//! * **Adequacy** ([`Adequacy`]): the chosen law's residuals against the
//!   sensor noise (ratio ≤ 1.4) and binned against drive phase, velocity,
//!   position and time (flagged when z > 3.7 and the structure exceeds half
//!   the noise); an inadequate law's statistical half-widths are multiplied
//!   by the misfit.
//! * **Intervals**: a cluster-robust sandwich over segments (each segment
//!   has its own start, so segments are the independent units):
//!   `Cov = H⁻¹ (Σ_k g_k g_kᵀ) H⁻¹ · K/(K − p)` with `H = JᵀJ`,
//!   `g_k = J_kᵀ r_k`, J by central differences on the projected
//!   residuals, and Student's t with K − p degrees of freedom; plus the
//!   calibration budget by linear response: with a sensor's gain at 1 + u
//!   the parameters move by `−H⁻¹ Jᵀ Δr` (one simulation per sensor, x0,
//!   x1, x2, v2; a rectangular bound, σ = |δ|/√3, as in the equation-error
//!   budget).
//! * **Cost of a fit**: 0.1–0.2 s per 20-s log in release (three
//!   families, 220–480 evaluations of the cost with Levenberg–Marquardt,
//!   960–1390 with Nelder–Mead, each a simulation of the 22 segments: about
//!   1 µs per drive period of the exact engine plus the samples). The sampled drive is about 25× slower (5.5 s for an 8-s
//!   log): the numerical engine's step is bounded by the drive's sampling.
//!   A Stribeck pad costs 6–15 s: the three simple families, then the
//!   Stribeck family on the numerical engine (no closed form per phase;
//!   560 evaluations of seven parameters for `law_stribeck.mcap`, 2470
//!   with Nelder–Mead).
//!
//! Against the equation-error fit (`fit`), which differentiates noisy
//! signals and therefore has to smooth them (Rs, Rd within 2 %, ρ within
//! 1.4 % on the public logs), the refinement compares positions (3–4 µm
//! noise on ~3 mm) with the exact solution: ρs, ρd within 0.05 % and D*
//! within 0.0001 on the public logs; the equation-error law is its start.

mod adequacy;
mod anchors;
mod data;
mod drop;
mod intervals;
mod lm;
mod problem;
mod profile;
mod select;

use adequacy::*;
pub use adequacy::{
    motion_structure, Adequacy, Evidence, Structure, MAX_NOISE_RATIO, MAX_STRUCTURE_EFFECT,
    MAX_STRUCTURE_Z,
};
use anchors::{m1_sums, shooting_segments, slip_anchors, stick_anchors};
use data::*;
pub use drop::{DropProfile, THRESHOLD_EVIDENCE_BIC};
pub use intervals::{CalibratedLevels, PadFit};
use intervals::{CalibrationPart, IntervalsFailure, MAX_SECANT_RATIO};
pub use lm::Minimiser;
pub use problem::Ext;
use problem::*;

use super::contact::{Contact, Gains};
use super::segment::Segmentation;
use super::smooth::{savgol, solve_small};
use super::{Interval, Intervals};
use crate::ingest::RigMeta;
use crate::model::{Absorber, Drive, Model};
use crate::model::{LawKind, Selection, SiLaw};
use crate::sim::engine::{Init, Mode, Observer};
use crate::sim::numeric::{NumericOptions, NumericSim};
use crate::sim::Engine;
use crate::sim::Status;
use crate::stats::mad_sigma;
use argmin::core::{CostFunction, Executor};
use argmin::solver::neldermead::NelderMead;
use std::f64::consts::PI;

/// Why the output-error refinement, or one family of it, failed (the
/// text of the `refinement_failed` warnings).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RefineError {
    /// Fewer usable samples than the refinement needs.
    #[error("too few samples")]
    TooFewSamples,
    /// Too few anchors (sticks or slips) to cut the log into segments.
    #[error("only {segments} shooting segments (the log needs repeated sticks or slips)")]
    TooFewSegments {
        /// The segments found.
        segments: usize,
    },
    /// The equation-error start cannot be simulated.
    #[error("the equation-error law cannot be simulated")]
    StartNotSimulable,
    /// No start of a family can be simulated.
    #[error("no simulable law found")]
    NoSimulableLaw,
    /// The minimiser reached a law that cannot be simulated.
    #[error("the refined law cannot be simulated")]
    NotSimulable,
    /// The minimiser (Nelder–Mead, argmin) failed; its message.
    #[error("{0}")]
    Minimiser(String),
    /// The minimiser returned no optimum.
    #[error("no optimum")]
    NoOptimum,
    /// No family could be refined.
    #[error("no family to refine")]
    NoFamily,
    /// The chosen fit's intervals could not be formed.
    #[error("no intervals: {0}")]
    Intervals(#[from] IntervalsFailure),
    /// The residuals do not line up with the samples compared.
    #[error("residual bookkeeping failed")]
    Bookkeeping,
}

/// Options of the refinement.
#[derive(Debug, Clone)]
pub struct OeOptions {
    /// Compare every `stride`-th sample (positions are smooth: at 1 kHz,
    /// every 4th sample changes the estimates by < 0.05 %).
    pub stride: usize,
    /// Largest number of iterations (Levenberg–Marquardt Jacobians or
    /// Nelder–Mead steps) per family and pass.
    pub max_iters: u64,
    /// Anchor intervals per shooting segment (about half a drive period
    /// each). Longer segments carry fewer free start states per datum: the
    /// incidental-parameter bias of the estimate (≈ −0.03 % in ρs at one
    /// interval under typical noise, see the module docs) vanishes at 3.
    pub span: usize,
    /// The minimiser of each pass (Levenberg–Marquardt by default).
    pub minimiser: Minimiser,
    /// Fit the lags of the x1 and x2 records behind the drive (profiled
    /// out of every evaluation by least squares; see `profile_delays`).
    /// Off by default: `IdentifyOptions::lag_fallback` turns them on where
    /// the law without them is not adequate.
    pub position_delays: bool,
    /// A refined family keeps its start-state projection where it has at
    /// most this many column values (8 bytes each); a larger one is
    /// computed again where it is used (the same projection, bit for bit;
    /// five evaluations each time), so that a long log's families do not
    /// each hold one. 0: always computed again.
    pub keep_projection_values: usize,
    /// The bound (m) within which the position channels read zero at the
    /// rig's rest state, declared by the user (`fit
    /// --position-zero-uncertainty-m`): overrides the log's
    /// `position_zero_uncertainty_m`; None: the log's key, if any.
    pub position_zero_uncertainty_m: Option<f64>,
}

impl Default for OeOptions {
    fn default() -> Self {
        Self {
            stride: 4,
            max_iters: 600,
            span: 3,
            minimiser: Minimiser::default(),
            position_delays: false,
            // 2 MB a family: logs of up to about two minutes at 1 kHz.
            keep_projection_values: 1 << 18,
            position_zero_uncertainty_m: None,
        }
    }
}

/// How the drive was simulated.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum DriveModel {
    /// The fitted sinusoid, exact engine.
    Harmonic,
    /// The sampled drive channel, numerical engine.
    Sampled,
}

impl DriveModel {
    /// Name in the JSON.
    pub fn as_str(self) -> &'static str {
        match self {
            DriveModel::Harmonic => "harmonic",
            DriveModel::Sampled => "sampled",
        }
    }
}

/// One family refined by output error.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct FamilyFit {
    /// The refined law.
    pub law: SiLaw,
    /// Force bias K2·(p1 − p2) (N).
    pub bias_n: f64,
    /// Gains of x1 and x2 relative to the drive channel.
    pub gains: (f64, f64),
    /// Weighted sum of squared residuals at the optimum.
    pub cost: f64,
    /// Information criterion (lower is better).
    pub bic: f64,
    /// RMS residuals of x1, x2 (m).
    pub rms_m: (f64, f64),
    /// Minimiser iterations (Levenberg–Marquardt Jacobians or Nelder–Mead
    /// steps).
    pub iterations: u64,
    /// Fraction of the compared samples at which the simulated M2 sticks.
    pub stick_fraction: f64,
    /// Number of simulated stick phases among the compared samples.
    pub stick_runs: usize,
    /// Lags (s) of the x1 and x2 records behind the drive's time base,
    /// profiled out of the residuals (0, 0 when not fitted).
    pub delays_s: (f64, f64),
    /// Their 95 % intervals (s).
    pub delays_interval_s: ((f64, f64), (f64, f64)),
    /// Real-pad extensions refined with the law (`law.rs_n` is then the
    /// threshold towards +).
    #[serde(default)]
    pub ext: Ext,
    /// Rs⁻ (N) of a split threshold (gauge: equal dynamic levels).
    #[serde(default)]
    pub rs_minus_n: Option<f64>,
    /// Contact stiffness κ = kt/K2 (None: rigid stick).
    #[serde(default)]
    pub contact_stiffness: Option<f64>,
    /// Simulated breakaways towards + and towards − over the compared
    /// segments.
    #[serde(default)]
    pub breakaways: (usize, usize),
    /// Upper bounds (N) on the thresholds towards + and towards − from the
    /// simulated reversals without stick (None: no such reversal).
    #[serde(default)]
    pub reversal_bound_n: (Option<f64>, Option<f64>),
}

impl FamilyFit {
    /// Parameters the criterion counts.
    pub fn n_params(&self) -> usize {
        n_params(self.law.kind) + self.ext.len()
    }
}

/// A refinement pass before its finish ([`Refinement::run_core`]): the
/// refined fits and their conclusion, whose intervals still lack the
/// profile in Rs behind an unresolved contact and the levels of each
/// direction, and which has not yet tried the Stribeck law behind the
/// contact.
pub struct Pass {
    fits: Vec<Refined>,
    out: OutputErrorFit,
    forced: Option<LawKind>,
    u: f64,
    t0: std::time::Instant,
}

impl Pass {
    /// The pass's conclusion so far (its law, cost, adequacy and families
    /// are final unless the finish finds a Stribeck law behind the
    /// contact).
    pub fn fit(&self) -> &OutputErrorFit {
        &self.out
    }
}

/// What the refinement found.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct OutputErrorFit {
    /// The chosen (or forced) family's refined law.
    pub law: SiLaw,
    /// Its bias, gains, cost and residuals.
    pub chosen: FamilyFit,
    /// Every family refined (for the criterion).
    pub families: Vec<FamilyFit>,
    /// RMS residuals of x1, x2 (m) at the equation-error law of the chosen
    /// family (start of the refinement).
    pub start_rms_m: (f64, f64),
    /// 95 % intervals (sandwich over segments + calibration budget; for a
    /// never-sticking log Rs holds the bounds, as in [`super::LogFit`]).
    pub intervals: Intervals,
    /// The sensors' gains' part of the Rs and Rd intervals: its 95 %
    /// half-widths (N; Rs's None where the law does not stick). It is
    /// common to logs recorded with the same sensors; the rest of each
    /// interval (statistical, misfit, channel alignment) is the log's own.
    /// Rs's is the chosen law's, before any widening or bounding of the
    /// Rs interval.
    #[serde(default)]
    pub calibration_half_width_n: (Option<f64>, Option<f64>),
    /// How far the chosen law's statistical widths from the residuals'
    /// secants over its intervals stray from the tangent's (the largest
    /// ratio either way; 1 on a smooth cost). From 1.25 on the cost is
    /// not linear at the intervals' scale (short sticks switching with
    /// the parameters), and each interval is the widest of the secants'
    /// (warning `rough_cost`). Older saved fits: 1.
    #[serde(default = "one")]
    pub interval_secant_ratio: f64,
    /// The real-pad parameters of the chosen law with their intervals
    /// (all None for the paper's symmetric, rigid pad).
    #[serde(default)]
    pub pads: PadFit,
    /// Shooting segments.
    pub segments: usize,
    /// Residual samples compared (per channel).
    pub samples: usize,
    /// Effective number of independent samples used in the criterion.
    pub n_eff: f64,
    /// Cost evaluations over all families (simulations of the log).
    pub evaluations: usize,
    /// How the drive was simulated.
    pub drive: DriveModel,
    /// Wall time (s).
    pub seconds: f64,
    /// The simulated law sticks (always true where the segmentation saw
    /// sticks; else at least 0.5 % of the time in four or more phases):
    /// ρs is measured, not only bounded.
    pub sticks_found: bool,
    /// Whether the lags of x1 and x2 were fitted (`FamilyFit::delays_s`).
    pub position_delays: bool,
    /// The adequacy verdict of the chosen law.
    pub adequacy: Adequacy,
    /// How strongly the data prefer the chosen family (None: one family).
    pub evidence: Option<Evidence>,
    /// Notes on the choice (parsimony), as warnings.
    pub notes: Vec<crate::warning::Warning>,
    /// The chosen static/dynamic law's threshold against an unresolved
    /// Stribeck drop ([`DropProfile`]; None for other laws and forced
    /// ones).
    #[serde(default)]
    pub drop_profile: Option<DropProfile>,
}

/// The secants' ratio of a smooth cost (older saved fits).
fn one() -> f64 {
    1.0
}

/// The prepared refinement of one log.
pub struct Refinement {
    data: Data,
    rig: Rig,
    max_iters: u64,
    minimiser: Minimiser,
    never_sticks: bool,
    evals: std::cell::Cell<usize>,
    /// A forced shaped law's limit-family fit behind a contact spring
    /// ([`Refinement::forced_behind_contact`]): it does not compete, but
    /// profiles an unresolved threshold (`profile_unresolved`).
    profile_helper: std::cell::RefCell<Option<Refined>>,
    hints: PadHints,
    keep_projection_values: usize,
    /// Standard uncertainty (s) of the drive's and of x2's alignment with
    /// x1 ([`Refinement::with_alignment_uncertainty`]).
    alignment_sigma: (f64, f64),
    /// The bound (m) on the position channels' zeros where the log
    /// declares them calibrated: the levels per direction are then
    /// reported ([`CalibratedLevels`]).
    zero_uncertainty_m: Option<f64>,
}

/// What the real-pad screen (`crate::identify::pads`) saw: the extensions
/// the refinement then tries (each must still win by the criterion), with
/// their start values.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct PadHints {
    /// The direction screen fired: try a split threshold.
    pub split: bool,
    /// The drop asymmetry Δ (N) it measured, where it could (a start).
    pub split_n: Option<f64>,
    /// The contact stiffness kt (N/m) where the compliance screen fired:
    /// try a contact spring from there.
    pub kt_n_per_m: Option<f64>,
}

/// Breakaways towards a direction a split threshold needs to count as
/// measured there (as sticks: four phases).
const MIN_DIRECTION_BREAKAWAYS: usize = 4;

/// What a shaped law behind a contact spring (`to`, chosen by the
/// criterion over the law `from`) explains of what it was tried for
/// ([`Refinement::shaped_behind_contact`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum DropVerdict {
    /// x2's largest significant structure against the velocity or the
    /// drive phase does not shrink: the shaped law took something else.
    Unexplained,
    /// It shrinks, and the accelerometer's force record (an independent
    /// measurement of the contact force) is explained no worse (its
    /// residual over its noise).
    Confirmed,
    /// It shrinks, and the force record is explained worse.
    Refuted,
    /// It shrinks, and the log has no accelerometer: the positions alone
    /// do not tell the shaped law from a position sensor's filter.
    Unconfirmed,
}

/// The [`DropVerdict`] of `to` over `from`. On a static/dynamic pad
/// behind a contact (the compliant study's c003, x2 behind a 131-Hz
/// filter) the Stribeck law took x2's structure (z 6.8 to below 3.7) with
/// a hump 27 % below the true threshold, and the force record's residual
/// rose from 1.15 to 1.38 of its noise (its structure against position
/// from z 3.0 to 14.9); on the Stribeck pads with an accelerometer it
/// fell (1.70 → 1.53, 2.79 → 1.42, 21.6 → 1.98). Without its
/// accelerometer c003 read as a Stribeck pad, Rs 0.372 N [0.366, 0.378]
/// for 0.507 (docs/real-pads.md).
fn drop_verdict(from: &OutputErrorFit, to: &OutputErrorFit) -> DropVerdict {
    let x2 = |o: &OutputErrorFit| {
        o.adequacy
            .structure
            .iter()
            .filter(|s| s.channel == "x2" && s.follows_the_motion())
            .map(|s| s.effect)
            .fold(0.0, f64::max)
    };
    if x2(to) >= x2(from) {
        return DropVerdict::Unexplained;
    }
    match (from.adequacy.force_ratio, to.adequacy.force_ratio) {
        (Some(a), Some(b)) if b <= a => DropVerdict::Confirmed,
        (Some(_), Some(_)) => DropVerdict::Refuted,
        _ => DropVerdict::Unconfirmed,
    }
}

/// Where the positions prefer a shaped law behind the contact (`other`)
/// that no accelerometer confirms ([`DropVerdict::Unconfirmed`]): the
/// chosen law `out` is kept, its Rs, Rd, ρs, ρd and κ intervals widened
/// to the union with `other`'s, with a warning giving both readings.
/// Where the readings disagree on Rs or κ beyond their intervals (either
/// point outside the other's interval), the log does not tell which is
/// right: that quantity is reported as the union without a number
/// ([`PadFit::rs_between_readings`], [`PadFit::kappa_between_readings`];
/// the simulated law stays the chosen one).
fn hold_both_readings(out: &mut OutputErrorFit, other: &OutputErrorFit) {
    let inside = |x: f64, iv: Option<Interval>| iv.is_some_and(|(l, h)| l <= x && x <= h);
    let disagree = |a: Option<f64>, ia: Option<Interval>, b: Option<f64>, ib: Option<Interval>| {
        let (Some(a), Some(b)) = (a, b) else {
            return false;
        };
        !inside(a, ib) || !inside(b, ia)
    };
    let rs_between = disagree(
        Some(out.law.rs_n),
        out.intervals.rs_n,
        Some(other.law.rs_n),
        other.intervals.rs_n,
    ) && !out.pads.threshold_unresolved;
    let kappa_between = disagree(
        out.pads.contact_stiffness,
        out.pads.contact_stiffness_interval,
        other.pads.contact_stiffness,
        other.pads.contact_stiffness_interval,
    );
    let union = |a: Option<Interval>, b: Option<Interval>| match (a, b) {
        (Some((l, h)), Some((c, d))) => Some((l.min(c), h.max(d))),
        (a, _) => a,
    };
    let delta_bic = {
        let bic = |kind: LawKind| {
            other
                .families
                .iter()
                .find(|f| f.law.kind == kind && f.ext == out.chosen.ext)
                .map(|f| f.bic)
        };
        match (bic(other.chosen.law.kind), bic(out.chosen.law.kind)) {
            (Some(a), Some(b)) => a - b,
            _ => other.chosen.bic - out.chosen.bic,
        }
    };
    out.notes
        .push(crate::warning::Warning::StribeckUnconfirmed {
            delta_bic,
            rs_n: other.law.rs_n,
            rs_interval_n: other.intervals.rs_n,
            rd_n: other.law.rd_n,
            rd_interval_n: other.intervals.rd_n,
            vs_m_per_s: other.law.vs_m_per_s,
            kappa: other.pads.contact_stiffness,
            kappa_interval: other.pads.contact_stiffness_interval,
            own_rs_interval_n: out.intervals.rs_n,
            own_kappa_interval: out.pads.contact_stiffness_interval,
            rs_not_identified: rs_between,
            kappa_not_identified: kappa_between,
        });
    out.pads.rs_between_readings = rs_between;
    out.pads.kappa_between_readings = kappa_between;
    let (o, iv) = (&other.intervals, &mut out.intervals);
    iv.rs_n = union(iv.rs_n, o.rs_n);
    iv.rd_n = union(iv.rd_n, o.rd_n);
    iv.rho_s = union(iv.rho_s, o.rho_s);
    iv.rho_d = union(iv.rho_d, o.rho_d);
    out.pads.contact_stiffness_interval = union(
        out.pads.contact_stiffness_interval,
        other.pads.contact_stiffness_interval,
    );
}

/// A minimiser's result: θ̂, its cost, the iterations and where its
/// start-state projection was computed.
type Minimum = (Vec<f64>, f64, u64, ProjAt);

/// Times [`Refinement::minimise_restarted`] minimises an optimum again.
const MAX_RESTARTS: usize = 3;

/// Contact stiffnesses κ tried as starts where the screen gave none (the
/// best of them by the cost starts the minimiser).
const KAPPA_GRID: [f64; 6] = [3.0, 10.0, 30.0, 100.0, 300.0, 1000.0];

/// The κ starts of the contact extension: the compliance screen's, or
/// the grid where it did not fire.
fn kappa_starts(screen: Option<f64>) -> Vec<f64> {
    screen.map_or(KAPPA_GRID.to_vec(), |k| vec![k])
}

impl Refinement {
    /// Prepares the shooting segments and the nuisance averages of a log
    /// (`x0` is the drive channel as used, on the contact's time base).
    pub fn new(
        c: &Contact,
        x0: &[f64],
        seg: &Segmentation,
        rig: &RigMeta,
        opts: &OeOptions,
    ) -> Result<Self, RefineError> {
        let n = c.t.len();
        if n < 10 || x0.len() != n {
            return Err(RefineError::TooFewSamples);
        }
        let per_n = (1.0 / (c.drive.frequency_hz * c.dt)).round().max(8.0) as usize;
        // Initial states of M1: a cubic fit over ±1/20 of a period.
        let h = (per_n / 20).max(3);
        // Sensor noise of a position record past its correlation length
        // (interpolation onto the grid, sensor filters): super::noise.
        // Friction jumps (stick, breakaway, reversal) are kept out of it.
        let events: Vec<usize> = seg
            .sticks
            .iter()
            .flat_map(|&(a, b)| [a, b])
            .chain(seg.reversals.iter().map(|r| r.at.round().max(0.0) as usize))
            .collect();
        let pos_noise = |x: &[f64]| {
            let spp = 1.0 / (c.drive.frequency_hz * c.dt);
            super::noise::position_noise_between_events(x, spp, &events, c.half_window)
                .map_or_else(|| noise(x), |e| e.sigma)
        };
        let x1s = savgol(&c.x1, c.dt, h, 3, 0);
        let v1s = savgol(&c.x1, c.dt, h, 3, 1);
        let a1 = savgol(&c.x1, c.dt, h, 3, 2);
        let x2s = savgol(&c.x2, c.dt, c.half_window, 3, 0);
        let v2p = savgol(&c.x2, c.dt, c.half_window, 3, 1);
        let ok_state = |j: usize| x1s[j].is_finite() && v1s[j].is_finite() && x2s[j].is_finite();
        let mut anchors = stick_anchors(c, seg, &ok_state);
        let extra = slip_anchors(c, seg, &anchors, per_n, &ok_state);
        anchors.extend(extra);
        anchors.sort_by_key(|a| a.i);
        anchors.dedup_by(|a, b| a.i.abs_diff(b.i) < per_n / 8);
        let segs = shooting_segments(&anchors, opts.span, per_n);
        if segs.len() < 4 {
            return Err(RefineError::TooFewSegments {
                segments: segs.len(),
            });
        }
        let stride = opts.stride.max(1);
        let omega = rig.omega_ref();
        let compared = segs
            .iter()
            .map(|&(k0, k1)| {
                let (i, end) = (anchors[k0].i, anchors[k1].i);
                (i + stride..=end)
                    .step_by(stride)
                    .filter(|&j| c.x1[j].is_finite() && c.x2[j].is_finite())
                    .map(|j| (j, (c.t[j] - c.t[i]) * omega))
                    .collect()
            })
            .collect();
        let w_d = 2.0 * PI * c.drive.frequency_hz;
        let harmonic = |t: f64| c.drive.amplitude_m * (w_d * t - c.drive.phase_rad).cos();
        let (mut sums, cnt) = m1_sums(c, rig, &a1, &v1s, &v2p, &harmonic);
        let cn = cnt.max(1) as f64;
        // The drive: the sinusoid if its residual is at the channel's noise
        // level, else the sampled signal (its offset removed; gaps filled
        // by the sinusoid).
        let x0_noise = pos_noise(x0);
        let sampled = c.drive.residual_rms_m > 3.0 * x0_noise.max(1e-3 * c.drive.amplitude_m);
        let offset = {
            let r: Vec<f64> = (0..n)
                .filter(|&i| x0[i].is_finite())
                .map(|i| x0[i] - harmonic(c.t[i]))
                .collect();
            crate::stats::median(&r)
        };
        let x0c: Vec<f64> = (0..n)
            .map(|i| {
                if x0[i].is_finite() {
                    x0[i] - offset
                } else {
                    harmonic(c.t[i])
                }
            })
            .collect();
        let drive = if sampled {
            DriveModel::Sampled
        } else {
            DriveModel::Harmonic
        };
        if sampled {
            sums[4] = (0..n)
                .filter(|&i| {
                    [c.x1[i], c.x2[i], a1[i], v1s[i], v2p[i]]
                        .iter()
                        .all(|v| v.is_finite())
                })
                .map(|i| x0c[i])
                .sum();
        }
        let data = Data {
            t: c.t.clone(),
            x1: c.x1.clone(),
            x2: c.x2.clone(),
            x1s: x1s.into(),
            v1s: v1s.into(),
            x2s: x2s.into(),
            // Slip starts take ẋ2 from x2 (its gain is estimated with the
            // law; the velocity channel's is not).
            v2s: savgol(&c.x2, c.dt, h, 3, 1).into(),
            x0: x0c.into(),
            anchors,
            segs,
            compared,
            a: c.drive.amplitude_m,
            freq: c.drive.frequency_hz,
            phase: c.drive.phase_rad,
            drive,
            dt: c.dt,
            means: sums.map(|s| s / cn),
            delays: opts.position_delays,
            gains: Gains::default(),
            sig: (pos_noise(&c.x1).max(1e-8), pos_noise(&c.x2).max(1e-8)),
            a2: c
                .a2_sensor
                .as_ref()
                .map(|a| (a.clone(), noise(a)))
                .filter(|(_, s)| *s > 0.0),
        };
        Ok(Self {
            data,
            rig: Rig {
                absorber: Absorber {
                    m: rig.mass_ratio(),
                    k: rig.stiffness_ratio(),
                    damping: rig.damping_ratio(),
                },
                k1: rig.k1_n_per_m,
                k2: rig.k2_n_per_m,
                omega,
            },
            max_iters: opts.max_iters,
            minimiser: opts.minimiser,
            never_sticks: seg.never_sticks(),
            evals: std::cell::Cell::new(0),
            profile_helper: std::cell::RefCell::new(None),
            hints: PadHints::default(),
            keep_projection_values: opts.keep_projection_values,
            alignment_sigma: (0.0, 0.0),
            zero_uncertainty_m: opts
                .position_zero_uncertainty_m
                .or_else(|| rig.position_zero_uncertainty_m()),
        })
    }

    /// The same refinement, its intervals also carrying the uncertainty of
    /// the channels' alignment with x1: standard uncertainties `sigma_x0_s`
    /// of the drive record and `sigma_x2_s` of x2's records (s), each
    /// propagated as a shift of that size (the channel delays' estimates,
    /// `crate::ingest::ChannelDelays`; a sub-millisecond misalignment moved
    /// the levels behind a compliant contact by 1–3 %).
    pub fn with_alignment_uncertainty(mut self, sigma_x0_s: f64, sigma_x2_s: f64) -> Self {
        self.alignment_sigma = (sigma_x0_s, sigma_x2_s);
        self
    }

    /// The same refinement, also trying the real-pad extensions `hints`.
    pub fn with_pad_hints(mut self, hints: PadHints) -> Self {
        self.hints = hints;
        self
    }

    /// Number of shooting segments.
    pub fn segments(&self) -> usize {
        self.data.segs.len()
    }

    fn problem<'a>(&'a self, d: &'a Data, fam: impl Into<Fam>) -> Problem<'a> {
        let Fam { kind, ext } = fam.into();
        Problem {
            d,
            rig: self.rig,
            kind,
            ext,
            never_sticks: self.never_sticks,
            evals: &self.evals,
            sticks: std::cell::Cell::new((0, 0)),
            dirs: std::cell::Cell::new(DirStats::default()),
            idx: std::cell::RefCell::new(None),
            delays: std::cell::Cell::new(DelayFit::default()),
        }
    }

    /// θ and Nelder–Mead steps of a family from its equation-error law.
    fn start(kind: LawKind, l: &SiLaw, bias: f64) -> (Vec<f64>, Vec<f64>) {
        let f = l.rd_n.abs().max(1e-3);
        // The family's parameters (its own order), with a threshold just
        // above the sliding level where the family has one.
        let start = SiLaw {
            rs_n: l.rs_n.max(1.01 * l.rd_n),
            ..*l
        };
        let mut th = kind.family().pack(&start);
        let rs_step = 0.01 * l.rs_n.abs().max(f);
        let mut step = kind.family().oe_steps(&th, f, rs_step);
        th.extend([bias, 1.0, 1.0]);
        step.extend([0.01 * f, 0.003, 0.003]);
        (th, step)
    }

    /// Refines one family from the best of the start points `starts`
    /// (the minimiser with the parameter scales `step`), in two passes: the
    /// start-velocity projection is computed at the start, then again at
    /// the first optimum. Returns θ̂, its cost, the iterations and the
    /// projection the cost refers to.
    fn minimise(
        &self,
        fam: Fam,
        starts: &[Vec<f64>],
        step: &[f64],
    ) -> Result<(Vec<f64>, f64, u64, ProjAt), RefineError> {
        self.minimise_on(&self.data, fam, starts, step)
    }

    /// [`Self::minimise`] on `data` (the log's own, or a copy with a
    /// channel shifted or scaled).
    fn minimise_on(
        &self,
        data: &Data,
        fam: Fam,
        starts: &[Vec<f64>],
        step: &[f64],
    ) -> Result<(Vec<f64>, f64, u64, ProjAt), RefineError> {
        let (th, proj, _) = self
            .evaluated_starts(data, fam, starts)
            .into_iter()
            .min_by(|a, b| a.2.total_cmp(&b.2))
            .ok_or(RefineError::StartNotSimulable)?;
        self.minimise_from(data, fam, th, proj, step)
    }

    /// The simulable starts among `starts`, each with its start-state
    /// projection and its cost on `data`.
    fn evaluated_starts(
        &self,
        data: &Data,
        fam: Fam,
        starts: &[Vec<f64>],
    ) -> Vec<(Vec<f64>, Proj, f64)> {
        let prob = self.problem(data, fam);
        starts
            .iter()
            .filter_map(|t| {
                let p = prob.projection(t, None)?;
                let c = prob.eval(t, Some(&p), None)?;
                Some((t.clone(), p, c))
            })
            .collect()
    }

    /// [`Self::minimise_on`] from the start `th` with its projection `proj`.
    fn minimise_from(
        &self,
        data: &Data,
        fam: Fam,
        mut th: Vec<f64>,
        proj: Proj,
        step: &[f64],
    ) -> Result<(Vec<f64>, f64, u64, ProjAt), RefineError> {
        let prob = self.problem(data, fam);
        let fail = RefineError::NotSimulable;
        // The segment starts move to their least-squares values (free
        // multiple-shooting nodes), so the linearised projection holds.
        let mut proj = prob
            .projection(&th, Some(&proj.corrected()))
            .ok_or(fail.clone())?;
        let mut at = ProjAt {
            th: th.clone(),
            dx: proj.current(),
            kept: None,
        };
        let mut iterations = 0;
        let mut cost = f64::INFINITY;
        for pass in 0..2 {
            let scale = if pass == 0 { 1.0 } else { 0.3 };
            let steps: Vec<f64> = step.iter().map(|s| scale * s).collect();
            let (t, c, it) = match self.minimiser {
                Minimiser::NelderMead => self.nm(&prob, &proj, &th, &steps, self.max_iters)?,
                Minimiser::LevenbergMarquardt => {
                    self.lm(&prob, &proj, &th, &steps, self.max_iters)?
                }
            };
            th = t;
            cost = c;
            iterations += it;
            if !(cost.is_finite() && cost < 1e299) {
                return Err(RefineError::NoSimulableLaw);
            }
            if pass == 0 {
                let q = prob
                    .projection(&th, Some(&proj.current()))
                    .ok_or(fail.clone())?;
                let dx = q.corrected();
                proj = prob.projection(&th, Some(&dx)).ok_or(fail.clone())?;
                at = ProjAt {
                    th: th.clone(),
                    dx,
                    kept: None,
                };
            }
        }
        if proj.values() <= self.keep_projection_values {
            at.kept = Some(std::sync::Arc::new(proj));
        }
        Ok((th, cost, iterations, at))
    }

    /// A refined family's start-state projection: kept, or computed again
    /// where it was (see [`ProjAt`]).
    fn proj(&self, f: &Refined) -> Result<std::sync::Arc<Proj>, RefineError> {
        self.proj_of(f.fam(), &f.proj_at)
            .ok_or(RefineError::NotSimulable)
    }

    /// The start-state projection of `fam` at `at`: kept, or computed again.
    fn proj_of(&self, fam: Fam, at: &ProjAt) -> Option<std::sync::Arc<Proj>> {
        if let Some(p) = &at.kept {
            return Some(p.clone());
        }
        self.problem(&self.data, fam)
            .projection(&at.th, Some(&at.dx))
            .map(std::sync::Arc::new)
    }

    /// Nelder–Mead from `th` with simplex steps `steps`.
    fn nm(
        &self,
        prob: &Problem<'_>,
        proj: &Proj,
        th: &[f64],
        steps: &[f64],
        max_iters: u64,
    ) -> Result<(Vec<f64>, f64, u64), RefineError> {
        let mut simplex = vec![th.to_vec()];
        for (k, s) in steps.iter().enumerate() {
            let mut p = th.to_vec();
            p[k] += s;
            simplex.push(p);
        }
        let c0 = prob.eval(th, Some(proj), None).unwrap_or(1.0);
        let solver = NelderMead::new(simplex)
            .with_sd_tolerance(1e-8 * c0.max(1.0))
            .map_err(|e| RefineError::Minimiser(e.to_string()))?;
        let res = Executor::new(Cost(prob, Some(proj)), solver)
            .configure(|s| s.max_iters(max_iters))
            .run()
            .map_err(|e| RefineError::Minimiser(e.to_string()))?;
        let th = res.state.best_param.clone().ok_or(RefineError::NoOptimum)?;
        Ok((th, res.state.best_cost, res.state.iter))
    }

    /// Refines the families of `starts` (each with its equation-error law),
    /// chooses among them by the criterion unless `forced`, and computes
    /// the chosen law's intervals with the calibration budget `u`.
    ///
    /// The static-dynamic family (a static threshold above the sliding
    /// level) is tried whatever the segmentation saw: where it found no
    /// stick, the family starts from the Coulomb optimum with thresholds
    /// 3–25 % above it, and the simulator decides where sticks happen.
    pub fn run(
        &self,
        starts: &[SiLaw],
        bias: f64,
        forced: Option<LawKind>,
        u: f64,
    ) -> Result<OutputErrorFit, RefineError> {
        Ok(self.finish(self.run_core(starts, bias, forced, u)?))
    }

    /// [`Self::run`] up to and including the real-pad extensions: every
    /// step that decides which laws compete, without the two costly ones
    /// that only a finished pass needs ([`Self::finish`]). The lag
    /// decision of `identify` reads the conclusion ([`Pass::fit`]) and
    /// finishes only the pass it keeps.
    pub fn run_core(
        &self,
        starts: &[SiLaw],
        bias: f64,
        forced: Option<LawKind>,
        u: f64,
    ) -> Result<Pass, RefineError> {
        let t0 = std::time::Instant::now();
        let mut fits = self.refine_families(starts, bias, forced)?;
        let mut concluded = self.conclude(&fits, forced, u, t0);
        if let Some(k) = forced.filter(|k| k.family().has_velocity_scale()) {
            let wants = match &concluded {
                Ok(o) => self.hints.kt_n_per_m.is_some() || !o.adequacy.adequate,
                Err(_) => true,
            };
            if wants {
                let n = fits.len();
                let tried = self.forced_behind_contact(k, &mut fits, (starts, bias));
                if fits.len() > n {
                    match self.conclude(&fits, forced, u, t0) {
                        Ok(o) => concluded = Ok(o),
                        Err(e) => {
                            fits.truncate(n);
                            if concluded.is_err() {
                                concluded = Err(e);
                            }
                        }
                    }
                }
                if let (Ok(o), Err(e)) = (&mut concluded, tried) {
                    o.notes.push(crate::warning::Warning::PadRefinementFailed {
                        reason: e.to_string(),
                    });
                }
            }
        }
        let mut out = concluded?;
        // A Stribeck pad: none of the simple families explains the log, or
        // the static/dynamic law (the Stribeck family's limit v_s → 0)
        // does, but x2's residuals follow the velocity or the drive phase
        // significantly (z > 3.7) by at least `MIN_RESCUE_EFFECT` of the
        // noise (`Structure::suggests_a_sharper_drop`): a sharp Stribeck
        // drop is read as a static/dynamic law with Rs 12 % high otherwise.
        // The Stribeck family (no closed form: the numerical engine, about
        // ten times the cost) is refined only then, and competes by the
        // same criterion. (z grows as √n
        // whatever the size: on a 3-million-sample log an x2 structure of
        // 0.006 noise units reached z 4 and the rescue, tried and
        // rejected, took 95 % of a 419-s fit. A drop too small to show
        // above the floor is the drop profile's case: `drop.rs`.)
        let follows = out.adequacy.suggests_a_sharper_drop();
        for &rescue in LawKind::all() {
            let Selection::Rescue { limit } = rescue.family().selection() else {
                continue;
            };
            let sharp = out.chosen.law.kind == limit && follows;
            if forced.is_none() && (!out.adequacy.adequate || sharp) {
                match self.refine(rescue, starts, bias, &fits) {
                    // Screened in by an adequate limit law, the family must
                    // show the drop it claims: with a characteristic
                    // velocity the log cannot tell from a step it is the
                    // limit law plus a slope, which then only absorbs
                    // sensor effects (on static/dynamic truths with lags
                    // fitted: v_s 1e-8 m/s, a spurious slope, ΔBIC 44 and
                    // 115, Rs intervals missing).
                    Ok(Some(f)) if out.adequacy.adequate && !self.resolves_drop(&f) => {}
                    Ok(Some(f)) => {
                        fits.push(f);
                        // An optimum whose intervals cannot be formed must
                        // not sink the simple families' result.
                        match self.conclude(&fits, forced, u, t0) {
                            Ok(o) => out = o,
                            Err(e) => {
                                fits.pop();
                                out.notes.push(crate::warning::Warning::StribeckFailed {
                                    reason: e.to_string(),
                                });
                            }
                        }
                    }
                    Ok(None) => {}
                    Err(e) => out.notes.push(crate::warning::Warning::StribeckFailed {
                        reason: e.to_string(),
                    }),
                }
            }
        }
        self.real_pads(&mut fits, &mut out, forced, u, t0);
        Ok(Pass {
            fits,
            out,
            forced,
            u,
            t0,
        })
    }

    /// The families of a pass (the simple ones, or the forced one), each
    /// refined from its equation-error start ([`Self::run_core`]'s first
    /// step).
    fn refine_families(
        &self,
        starts: &[SiLaw],
        bias: f64,
        forced: Option<LawKind>,
    ) -> Result<Vec<Refined>, RefineError> {
        let mut fits: Vec<Refined> = Vec::new();
        let kinds: Vec<LawKind> = match forced {
            Some(k) => vec![k],
            None => LawKind::all()
                .iter()
                .copied()
                .filter(|k| k.family().selection() == Selection::Simple)
                .collect(),
        };
        let mut last_err = RefineError::NoFamily;
        for kind in kinds {
            match self.refine(kind, starts, bias, &fits) {
                Ok(Some(f)) => fits.push(f),
                Ok(None) => {}
                Err(e) => last_err = e,
            }
        }
        // A forced family without an equation-error start (the
        // segmentation saw no stick; no Stribeck drop in the equation
        // error) starts, as in `--law auto`, from the optima of the simple
        // families it nests; those are refined for that only and do not
        // compete.
        if let (Some(k), true) = (forced, fits.is_empty()) {
            let helpers = self.simple_helpers(starts, bias, k);
            match self.refine(k, starts, bias, &helpers) {
                Ok(Some(f)) => fits.push(f),
                Ok(None) => {}
                Err(e) => last_err = e,
            }
        }
        if fits.is_empty() {
            return Err(last_err);
        }
        Ok(fits)
    }

    /// Whether the families of [`Self::refine_families`] already explain
    /// the log (the conclusion's adequacy; false where it fails): a cheap
    /// screen before a whole pass (`identify`'s lag shortcut).
    pub fn families_adequate(
        &self,
        starts: &[SiLaw],
        bias: f64,
        forced: Option<LawKind>,
        u: f64,
    ) -> bool {
        let t0 = std::time::Instant::now();
        self.refine_families(starts, bias, forced)
            .and_then(|fits| self.conclude(&fits, forced, u, t0))
            .is_ok_and(|o| o.adequacy.adequate)
    }

    /// Finishes a pass of [`Self::run_core`]: the profile in Rs behind a
    /// contact whose threshold the log does not resolve and the levels of
    /// each direction ([`Self::settle`]), the Stribeck law behind the
    /// contact where the residuals ask for it
    /// ([`Self::shaped_behind_contact`]), and the drop profile.
    pub fn finish(&self, pass: Pass) -> OutputErrorFit {
        let Pass {
            mut fits,
            mut out,
            forced,
            u,
            t0,
        } = pass;
        self.settle(&fits, &mut out, u);
        if forced.is_none() {
            self.shaped_behind_contact(&mut fits, &mut out, u, t0);
        }
        // A forced law with a velocity scale the log does not resolve (a
        // drop within one sample: a step to the data) is said to be one.
        if let Some(f) = forced
            .filter(|k| k.family().has_velocity_scale())
            .and_then(|k| fits.iter().find(|f| f.kind == k && f.ext.is_empty()))
        {
            let law = f.kind.family().unpack(&f.th);
            if let (false, Some(vs)) = (self.resolves_drop(f), law.vs_m_per_s) {
                let m2 = self.rig.k2 / (self.rig.omega * self.rig.omega);
                out.notes
                    .push(crate::warning::Warning::VelocityScaleUnresolved {
                        law: f.kind,
                        vs_m_per_s: vs,
                        resolution_m_per_s: (law.rs_n - law.rd_n).abs() / m2 * self.data.dt,
                    });
            }
        }
        if let (None, true, Some(iv)) = (forced, out.sticks_found, out.intervals.rs_n) {
            if let Some(sd) = fits.iter().find(|f| {
                f.kind == out.chosen.law.kind && f.ext == out.chosen.ext && f.ext.is_empty()
            }) {
                out.drop_profile = self.profile_drop(sd, iv, out.n_eff);
            }
        }
        out.evaluations = self.evals.get();
        out.seconds = t0.elapsed().as_secs_f64();
        out
    }

    /// The real-pad extensions, each refined from the optimum it extends
    /// and chosen only by the criterion: the split threshold on the simple
    /// family with a threshold where the direction screen fired or the law
    /// so far does not explain the log (a short log may hold too few
    /// one-sided breakaways for the screen), and on a shaped law's rigid
    /// fit (the Stribeck family, kept only where chosen); then a
    /// contact spring where the compliance screen fired or the law so far
    /// does not explain the log (a compliant contact rings on its spring
    /// after every slip, so the velocity may show no stick at all and the
    /// screen has nothing to read), on the law chosen so far and on the
    /// static-dynamic family.
    fn real_pads(
        &self,
        fits: &mut Vec<Refined>,
        out: &mut OutputErrorFit,
        forced: Option<LawKind>,
        u: f64,
        t0: std::time::Instant,
    ) {
        let h = self.hints;
        let fail = |e: RefineError| crate::warning::Warning::PadRefinementFailed {
            reason: e.to_string(),
        };
        let try_ext = |i: usize,
                       ext: Ext,
                       (splits, kappas, extra): (&[f64], &[f64], &[Vec<f64>]),
                       fits: &mut Vec<Refined>,
                       out: &mut OutputErrorFit| {
            match self.refine_ext(&fits[i], ext, splits, kappas, extra) {
                Ok(f) => {
                    fits.push(f);
                    match self.conclude(fits, forced, u, t0) {
                        Ok(o) => *out = o,
                        Err(e) => {
                            fits.pop();
                            out.notes.push(fail(e));
                        }
                    }
                }
                Err(e) => out.notes.push(fail(e)),
            }
        };
        let simple_threshold = |fits: &[Refined]| {
            fits.iter().position(|f| {
                f.ext.is_empty()
                    && f.kind.family().has_threshold()
                    && f.kind.family().selection() == Selection::Simple
            })
        };
        // Calibrated zeros that resolve a difference of the dynamic levels
        // are a screen of their own: the static thresholds may differ by
        // direction by another amount, wherever the log sticks (the chosen
        // law may stand in for a split threshold: on a Parquet export of a
        // pad with Rs⁻ 0.84 N against Rs⁺ 0.924 N a Stribeck law that
        // never sticks towards − won, Rs⁺ 0.849 N, 8 % low and missed;
        // requiring the chosen law to break away both ways kept the split
        // away from it).
        let calibrated_split = out.pads.calibrated.is_some_and(|c| c.resolved) && out.sticks_found;
        if h.split || !out.adequacy.adequate || calibrated_split {
            if let Some(i) = simple_threshold(fits) {
                let law = fits[i].kind.family().unpack(&fits[i].th);
                // Either sign: a pad that sticks at one reversal only does
                // not say which threshold is the lower one.
                let d = 0.5 * (law.rs_n - law.rd_n).max(0.02 * law.rd_n.abs());
                let mut splits: Vec<f64> = h.split_n.into_iter().collect();
                splits.extend([0.0, d, -d]);
                let ext = Ext {
                    split: true,
                    contact: false,
                };
                try_ext(i, ext, (&splits, &[], &[]), fits, out);
            }
        }
        // A shaped law (refined by the rescue, or forced) splits the same
        // way, its velocity scale shared, where the screen fired or the
        // laws so far still do not explain the log: from its own optimum,
        // with the simple family's split asymmetry among the starts.
        let split = Ext {
            split: true,
            contact: false,
        };
        let shaped_rigid = fits
            .iter()
            .position(|f| f.ext.is_empty() && f.kind.family().has_velocity_scale());
        if let (Some(i), true) = (
            shaped_rigid,
            h.split || !out.adequacy.adequate || calibrated_split,
        ) {
            if !fits
                .iter()
                .any(|f| f.kind == fits[i].kind && f.ext == split)
            {
                let law = fits[i].kind.family().unpack(&fits[i].th);
                let d = 0.5 * (law.rs_n - law.rd_n).max(0.02 * law.rd_n.abs());
                let mut splits: Vec<f64> = fits
                    .iter()
                    .filter(|f| f.ext == split)
                    .map(|f| f.th[n_params(f.kind) + 3])
                    .chain(h.split_n)
                    .collect();
                splits.extend([0.0, d, -d]);
                // Kept only where chosen: an unchosen fit would still move
                // the effective sample size over the fits, and with it the
                // later steps (on a Stribeck pad behind a contact, s005 of
                // the Stribeck compliant study, the Stribeck law's contact
                // fit then stopped at κ 49 for 18.2 and lost to the
                // static/dynamic one: Rs +125 %, missed).
                match self.refine_ext(&fits[i], split, &splits, &[], &[]) {
                    Ok(f) => {
                        let kind = f.kind;
                        fits.push(f);
                        match self.conclude(fits, forced, u, t0) {
                            Ok(o) if o.chosen.law.kind == kind && o.chosen.ext == split => *out = o,
                            Ok(_) => {
                                fits.pop();
                            }
                            Err(e) => {
                                fits.pop();
                                out.notes.push(fail(e));
                            }
                        }
                    }
                    Err(e) => out.notes.push(fail(e)),
                }
            }
        }
        if h.kt_n_per_m.is_some() || !out.adequacy.adequate {
            let screen = h.kt_n_per_m.map(|kt| kt / self.rig.k2);
            let kappas = kappa_starts(screen);
            let chosen = fits
                .iter()
                .position(|f| f.kind == out.chosen.law.kind && f.ext == out.chosen.ext);
            let mut bases: Vec<usize> = chosen.into_iter().collect();
            if let Some(i) = simple_threshold(fits).filter(|i| !bases.contains(i)) {
                bases.push(i);
            }
            // A shaped law (the numerical engine, about ten times the
            // cost) comes last: the closed-form families' contact fits
            // probe the contact first (`Self::shaped_contact_kappas`).
            let shaped = |f: &Refined| f.kind.family().has_velocity_scale();
            bases.sort_by_key(|&i| shaped(&fits[i]));
            for i in bases {
                let ext = Ext {
                    contact: true,
                    ..fits[i].ext
                };
                // (A forced shaped law's contact fit may be refined
                // already: `Self::forced_behind_contact`.)
                if fits.iter().any(|f| f.kind == fits[i].kind && f.ext == ext) {
                    continue;
                }
                if shaped(&fits[i]) {
                    let Some(kappas) = self.shaped_contact_kappas(fits, screen, out.n_eff) else {
                        continue;
                    };
                    try_ext(i, ext, (&[], &kappas, &[]), fits, out);
                } else {
                    let extra = self.contact_donor_starts(fits, i);
                    try_ext(i, ext, (&[], &kappas, &extra), fits, out);
                }
            }
        }
    }

    /// The rescue's rule applied again after the real-pad extensions: where
    /// the chosen law has a contact spring and x2's residuals follow the
    /// velocity or the drive phase ([`Structure::suggests_a_sharper_drop`]),
    /// the pad may be a Stribeck pad behind a contact spring, which the
    /// rigid rescue never reaches (its rigid law is a base of the contact
    /// extension only where it was chosen). Each rescue family is then
    /// refined with the chosen law's extensions, from its limit family's
    /// fit with those extensions (static/dynamic + contact: its levels,
    /// nuisance parameters and κ, with the family's nested velocity
    /// scales, [`Self::minimise_restarted`]), competes by the criterion
    /// where it resolves its drop ([`Self::resolves_drop`]), and replaces
    /// the chosen law only where it explains what it was tried for and the
    /// accelerometer confirms it ([`drop_verdict`]); without an
    /// accelerometer the chosen law is kept with intervals that hold both
    /// readings ([`hold_both_readings`]). The chosen
    /// law itself may be any family: a small Stribeck drop behind a
    /// contact reads as Coulomb + contact.
    fn shaped_behind_contact(
        &self,
        fits: &mut Vec<Refined>,
        out: &mut OutputErrorFit,
        u: f64,
        t0: std::time::Instant,
    ) {
        let follows = out.adequacy.suggests_a_sharper_drop();
        let ext = out.chosen.ext;
        if !ext.contact || !follows {
            return;
        }
        for &rescue in LawKind::all() {
            let Selection::Rescue { limit } = rescue.family().selection() else {
                continue;
            };
            let Some(base) = fits.iter().find(|f| f.kind == limit && f.ext == ext) else {
                continue;
            };
            if fits.iter().any(|f| f.kind == rescue && f.ext == ext) {
                continue;
            }
            let fail = |e: String| crate::warning::Warning::StribeckFailed { reason: e };
            match self.shaped_from(rescue, base, out.n_eff) {
                Ok(Some(f)) => {
                    fits.push(f);
                    match self.conclude(fits, None, u, t0) {
                        Ok(mut o) if o.chosen.law.kind == rescue => {
                            self.settle(fits, &mut o, u);
                            match drop_verdict(out, &o) {
                                DropVerdict::Confirmed => *out = o,
                                DropVerdict::Unconfirmed => {
                                    fits.pop();
                                    hold_both_readings(out, &o);
                                }
                                DropVerdict::Unexplained | DropVerdict::Refuted => {
                                    fits.pop();
                                }
                            }
                        }
                        // Not chosen: the conclusion stays as it was (the
                        // effective sample size is taken over the fits, so
                        // an unchosen fit would still move the intervals).
                        Ok(_) => {
                            fits.pop();
                        }
                        Err(e) => {
                            fits.pop();
                            out.notes.push(fail(e.to_string()));
                        }
                    }
                }
                Ok(None) => {}
                Err(e) => out.notes.push(fail(e.to_string())),
            }
        }
    }

    /// The shaped family `shaped` refined with `base`'s extensions from
    /// `base`, a fit of its limit family (static/dynamic + contact: its
    /// levels, nuisance parameters and κ, with the family's nested
    /// velocity scales, [`Self::minimise_restarted`] with the effective
    /// sample size `n_eff`). `Ok(None)`: no start, or the optimum does not
    /// resolve its drop ([`Self::resolves_drop`]).
    fn shaped_from(
        &self,
        shaped: LawKind,
        base: &Refined,
        n_eff: f64,
    ) -> Result<Option<Refined>, RefineError> {
        let va = self.data.a * self.rig.omega;
        let (limit, ext) = (base.kind, base.ext);
        let (head, tail) = base.th.split_at(n_params(limit) + 3);
        let optimum = |kd: LawKind| (kd == limit).then(|| head.to_vec());
        let starts: Vec<Vec<f64>> = shaped
            .family()
            .oe_nested(&[], &optimum, va)
            .into_iter()
            .map(|t| [&t[..], tail].concat())
            .collect();
        let Some(first) = starts.first() else {
            return Ok(None);
        };
        let fam = Fam { kind: shaped, ext };
        let step = Self::ext_steps(fam, first);
        let (start, (th, cost, iterations, proj_at)) =
            self.minimise_restarted(fam, &starts, &step, n_eff)?;
        let f = Refined {
            kind: shaped,
            ext,
            th,
            cost,
            iterations,
            proj_at,
            start,
        };
        Ok(self.resolves_drop(&f).then_some(f))
    }

    /// A forced shaped law (`fit --law stribeck`) behind a contact spring:
    /// its rigid fit alone cannot follow a pad that deflects before it
    /// slides (a Stribeck pad behind a contact: intervals not formed, the
    /// whole refinement given up). Where the compliance screen fired, the
    /// rigid fit is not adequate, or its conclusion failed, the family is
    /// refined with a contact spring as `--law auto` reaches it: the limit
    /// family's rigid fit, its contact extension (the screen's κ or the
    /// grid), and the shaped family from that ([`Self::shaped_from`]).
    /// The fit joins `fits` (the forced family's fits, which compete by
    /// the criterion); the simple families' fits are helpers only, and the
    /// limit family's contact fit profiles a threshold the shaped law
    /// leaves unresolved (as in `--law auto`).
    fn forced_behind_contact(
        &self,
        shaped: LawKind,
        fits: &mut Vec<Refined>,
        (starts, bias): (&[SiLaw], f64),
    ) -> Result<(), RefineError> {
        let Selection::Rescue { limit } = shaped.family().selection() else {
            return Ok(());
        };
        let contact = Ext {
            split: false,
            contact: true,
        };
        if fits.iter().any(|f| f.kind == shaped && f.ext == contact) {
            return Ok(());
        }
        // The simple families as helpers (the limit family may have no
        // equation-error start: it starts from their optima).
        let helpers = self.simple_helpers(starts, bias, shaped);
        let rigid = helpers
            .iter()
            .find(|f| f.kind == limit)
            .ok_or(RefineError::NoFamily)?;
        let kappas = kappa_starts(self.hints.kt_n_per_m.map(|kt| kt / self.rig.k2));
        let base = self.refine_ext(rigid, contact, &[], &kappas, &[])?;
        let (_, n_eff) = self.effective_samples(std::slice::from_ref(&base))?;
        if let Some(f) = self.shaped_from(shaped, &base, n_eff)? {
            fits.push(f);
        }
        // (Kept for the profile of a threshold the shaped law does not
        // resolve: in `--law auto` the same fit is among the families.)
        *self.profile_helper.borrow_mut() = Some(base);
        Ok(())
    }

    /// The simple families other than `except`, each refined from its
    /// equation-error law in `starts` or the optima of those before it
    /// (helpers for a forced family's starts; they do not compete).
    fn simple_helpers(&self, starts: &[SiLaw], bias: f64, except: LawKind) -> Vec<Refined> {
        let mut helpers: Vec<Refined> = Vec::new();
        for &kind in LawKind::all() {
            if kind != except && kind.family().selection() == Selection::Simple {
                if let Ok(Some(f)) = self.refine(kind, starts, bias, &helpers) {
                    helpers.push(f);
                }
            }
        }
        helpers
    }

    /// [`Self::minimise`] from each of `starts` on its own, each optimum
    /// minimised again from itself (a new start-state projection and
    /// simplex) until the deviance n_eff·ln(cost) falls by less than one,
    /// at most [`MAX_RESTARTS`] times; the lowest optimum kept (its
    /// iterations the sum) with the start it came from. A shaped law
    /// behind a contact spring moves far from its start (the static/dynamic
    /// law's threshold is not the Stribeck peak), and two passes of the
    /// projection do not follow it: on a Stribeck pad behind a contact the
    /// start at the true velocity scale stopped at a cost 1.7 % above the
    /// narrow-peak optimum (Rs +50 %) and ended, minimised again, 0.4 %
    /// below it at Rs −5 % (docs/real-pads.md).
    fn minimise_restarted(
        &self,
        fam: Fam,
        starts: &[Vec<f64>],
        step: &[f64],
        n_eff: f64,
    ) -> Result<(Vec<f64>, Minimum), RefineError> {
        let mut best: Option<(&Vec<f64>, Minimum)> = None;
        let mut iterations = 0;
        let mut last_err = RefineError::StartNotSimulable;
        for st in starts {
            let mut r = match self.minimise(fam, std::slice::from_ref(st), step) {
                Ok(r) => r,
                Err(e) => {
                    last_err = e;
                    continue;
                }
            };
            iterations += r.2;
            for _ in 0..MAX_RESTARTS {
                let Ok(again) = self.minimise(fam, std::slice::from_ref(&r.0), step) else {
                    break;
                };
                iterations += again.2;
                let gain = n_eff * (r.1 / again.1).ln();
                if again.1 < r.1 {
                    r = again;
                }
                if gain.is_nan() || gain < 1.0 {
                    break;
                }
            }
            if best.as_ref().is_none_or(|b| r.1 < b.1 .1) {
                best = Some((st, r));
            }
        }
        let (st, mut b) = best.ok_or(last_err)?;
        b.2 = iterations;
        Ok((st.clone(), b))
    }

    /// The contact stiffnesses the contact extension of a shaped law
    /// starts from, after the closed-form families' contact fits (the
    /// probe): none where the best of them does not beat its own rigid
    /// optimum by more than [`BIC_WEAK`] (the contact is then not what the
    /// law misses, and the shaped law's extension would cost minutes for
    /// nothing: on a never-sticking Stribeck pad whose first pass failed
    /// for a channel lag, six κ starts on the numerical engine took 668 s
    /// of a 675-s fit, docs/real-pads.md); else the probe's κ and the
    /// compliance screen's `screen` where it fired (each minimised).
    /// Without a probe: the screen's κ, or the grid.
    fn shaped_contact_kappas(
        &self,
        fits: &[Refined],
        screen: Option<f64>,
        n_eff: f64,
    ) -> Option<Vec<f64>> {
        let probe = fits
            .iter()
            .filter(|f| f.ext.contact && !f.kind.family().has_velocity_scale())
            .min_by(|a, b| a.cost.total_cmp(&b.cost));
        let Some(p) = probe else {
            return Some(kappa_starts(screen));
        };
        let rigid = fits.iter().find(|f| {
            f.kind == p.kind
                && f.ext
                    == Ext {
                        contact: false,
                        ..p.ext
                    }
        })?;
        let gain = n_eff * (rigid.cost / p.cost).ln() - n_eff.ln();
        if gain.is_nan() || gain <= BIC_WEAK {
            return None;
        }
        let kappa = self.problem(&self.data, p.fam()).ext_values(&p.th).kappa?;
        let mut kappas = vec![kappa];
        kappas.extend(screen.filter(|&k| k != kappa));
        Some(kappas)
    }

    /// True when a refined shaped law's drop is resolved by the log: its
    /// characteristic velocity v_s exceeds the speed the slider gains within one
    /// sample after breakaway, |Rs − Rd|/M2·dt (a narrower drop happens
    /// between two samples, a step to the data). Laws without v_s: true.
    fn resolves_drop(&self, f: &Refined) -> bool {
        let law = f.kind.family().unpack(&f.th);
        let Some(vs) = law.vs_m_per_s else {
            return true;
        };
        let m2 = self.rig.k2 / (self.rig.omega * self.rig.omega);
        vs.abs() > (law.rs_n - law.rd_n).abs() / m2 * self.data.dt
    }

    /// Refines one family from its equation-error law in `starts` and the
    /// optima of the simpler families already in `fits` (nested starts).
    /// `Ok(None)`: no start for this family.
    fn refine(
        &self,
        kind: LawKind,
        starts: &[SiLaw],
        bias: f64,
        fits: &[Refined],
    ) -> Result<Option<Refined>, RefineError> {
        let optimum = |k: LawKind| fits.iter().find(|f| f.kind == k).map(|f| f.th.clone());
        let family = kind.family();
        let law = match starts.iter().find(|l| l.kind == kind) {
            Some(l) => *l,
            // No equation-error start (a never-sticking segmentation, or
            // no Stribeck law there): from the simpler families' optima.
            None => match family.oe_fallback(&optimum, self.data.a, self.rig.omega) {
                Some(l) => l,
                None => return Ok(None),
            },
        };
        let (th_ee, step) = Self::start(kind, &law, bias);
        // Nested starts: the richer families also start from the optima
        // of the simpler ones they contain (their law at its boundary, and
        // with the equation-error law's extra parameter), so a richer
        // family never ends worse than the simpler one it contains.
        let mut cands = vec![th_ee.clone()];
        let va = self.data.a * self.rig.omega;
        cands.extend(family.oe_nested(&th_ee, &optimum, va));
        if family.oe_threshold_screen() {
            // Short sticks at reversal hide in a narrow basin of the
            // threshold (the sticks appear only above the reversal
            // force): the best of a screen of thresholds above the
            // Coulomb level is one more start.
            if let Some(g) =
                optimum(LawKind::Coulomb).and_then(|tc| self.screen_thresholds(kind, &tc))
            {
                cands.push(g);
            }
        }
        let (th, cost, it, proj_at) = self.minimise(kind.into(), &cands, &step)?;
        Ok(Some(Refined {
            kind,
            ext: Ext::default(),
            th,
            cost,
            iterations: it,
            proj_at,
            start: th_ee,
        }))
    }

    /// Refines `base`'s family with the real-pad extensions `ext` (a
    /// superset of its own) from its optimum, each new parameter at each of
    /// its start values (`splits`: Δ in N; `kappas`: κ); the best start by
    /// the cost is minimised.
    fn refine_ext(
        &self,
        base: &Refined,
        ext: Ext,
        splits: &[f64],
        kappas: &[f64],
        extra: &[Vec<f64>],
    ) -> Result<Refined, RefineError> {
        let fam = Fam {
            kind: base.kind,
            ext,
        };
        let own = self.problem(&self.data, base.fam()).ext_values(&base.th);
        let k = n_params(base.kind);
        let step = Self::ext_steps(fam, &base.th);
        let splits: Vec<f64> = if base.ext.split || !ext.split {
            vec![own.split_n]
        } else {
            splits.to_vec()
        };
        let kappas: Vec<f64> = match own.kappa {
            Some(kp) => vec![kp],
            None if ext.contact => kappas.to_vec(),
            None => vec![f64::NAN],
        };
        let mut cands = Vec::new();
        for &sp in &splits {
            for &kp in &kappas {
                let mut th = base.th[..k + 3].to_vec();
                if ext.split {
                    th.push(sp);
                }
                if ext.contact {
                    th.push(kp.ln());
                }
                cands.push(th);
            }
        }
        let len = cands[0].len();
        let (th, cost, it, proj_at) = if ext.contact {
            // Each donor start is minimised on its own: they share the
            // donor's κ, and the one with the lowest start cost is not the
            // one that ends lowest (a contact ringing after every slip
            // sticks briefly where its velocity grazes zero, so whether a
            // short stick happens switches with the threshold and the
            // cost jumps between the starts; docs/real-pads.md).
            let mut best = self.minimise_each_kappa(fam, &cands, &step);
            for t in extra.iter().filter(|t| t.len() == len) {
                if let Ok(r) = self.minimise(fam, std::slice::from_ref(t), &step) {
                    best = match best {
                        Ok(b) if b.1 <= r.1 => Ok((b.0, b.1, b.2 + r.2, b.3)),
                        Ok(b) => Ok((r.0, r.1, b.2 + r.2, r.3)),
                        Err(_) => Ok(r),
                    };
                }
            }
            best?
        } else {
            self.minimise(fam, &cands, &step)?
        };
        Ok(Refined {
            kind: base.kind,
            ext,
            th,
            cost,
            iterations: it,
            proj_at,
            start: cands[0].clone(),
        })
    }

    /// [`Self::minimise`] from the best start (by its cost) of each
    /// distinct contact stiffness among `starts` (θ ending in ln κ), the
    /// lowest optimum kept (its iterations the sum). The cost at the start
    /// does not rank the stiffnesses: on a log whose x1 lagged by 0.7 ms
    /// the start at κ = 10 (truth 9.06) ranked fourth of six and ended ten
    /// times lower than the best-ranked start, which stayed at κ 83 with a
    /// decreasing law 40 % below the true sliding level
    /// (docs/measurements.md, session 27).
    fn minimise_each_kappa(
        &self,
        fam: Fam,
        starts: &[Vec<f64>],
        step: &[f64],
    ) -> Result<(Vec<f64>, f64, u64, ProjAt), RefineError> {
        // The best start of each distinct ln κ (the last of θ), in order.
        let mut best_per_kappa: Vec<(Vec<f64>, Proj, f64)> = Vec::new();
        for (t, p, c) in self.evaluated_starts(&self.data, fam, starts) {
            let ln_k = t[t.len() - 1];
            match best_per_kappa
                .iter_mut()
                .find(|b| b.0[b.0.len() - 1] == ln_k)
            {
                Some(b) if c < b.2 => *b = (t, p, c),
                Some(_) => {}
                None => best_per_kappa.push((t, p, c)),
            }
        }
        let mut best: Option<(Vec<f64>, f64, u64, ProjAt)> = None;
        let mut iterations = 0;
        let mut last_err = RefineError::StartNotSimulable;
        for (t, p, _) in best_per_kappa {
            match self.minimise_from(&self.data, fam, t, p, step) {
                Ok(r) => {
                    iterations += r.2;
                    if best.as_ref().is_none_or(|b| r.1 < b.1) {
                        best = Some(r);
                    }
                }
                Err(e) => last_err = e,
            }
        }
        let mut b = best.ok_or(last_err)?;
        b.2 = iterations;
        Ok(b)
    }

    /// The minimiser's steps of `fam` near θ (of `fam` or of its family
    /// without extensions): the family's, then Δ's (a force) and ln κ's.
    fn ext_steps(fam: Fam, th: &[f64]) -> Vec<f64> {
        let k = n_params(fam.kind);
        let law = fam.kind.family().unpack(&th[..k]);
        let (_, mut step) = Self::start(fam.kind, &law, th[k]);
        if fam.ext.split {
            step.push(0.01 * law.rd_n.abs().max(1e-3));
        }
        if fam.ext.contact {
            step.push(0.1);
        }
        step
    }

    /// Starts for the contact extension of the family with a threshold
    /// `fits[i]` from the best contact fit so far (a contact ringing after
    /// every slip hides the sticks, so the family's own rigid optimum may
    /// sit far from its threshold): that fit's sliding level, nuisance
    /// parameters and κ, with thresholds 5–45 % above the sliding level.
    fn contact_donor_starts(&self, fits: &[Refined], i: usize) -> Vec<Vec<f64>> {
        let base = &fits[i];
        let family = base.kind.family();
        if !family.has_threshold() || base.ext.split {
            return Vec::new();
        }
        let Some(donor) = fits
            .iter()
            .filter(|f| f.ext.contact && !f.ext.split)
            .min_by(|a, b| a.cost.total_cmp(&b.cost))
        else {
            return Vec::new();
        };
        let dp = self.problem(&self.data, donor.fam());
        let kd = n_params(donor.kind);
        let (law, ..) = dp.unpack(&donor.th);
        let Some(kappa) = dp.ext_values(&donor.th).kappa else {
            return Vec::new();
        };
        [1.05, 1.12, 1.2, 1.3, 1.45]
            .iter()
            .map(|f| {
                let mut th = family.pack(&SiLaw {
                    kind: base.kind,
                    rs_n: f * law.rd_n,
                    ..law
                });
                th.extend_from_slice(&donor.th[kd..kd + 3]);
                th.push(kappa.ln());
                th
            })
            .collect()
    }

    /// The best start of `kind` (parameters [Rs, Rd]: the static-dynamic
    /// family, which asks for it) on a grid of thresholds ρs above and
    /// sliding levels ρd at or below the Coulomb optimum `tc` (θ of the
    /// Coulomb family), costs taken with the start-state projection of the
    /// Coulomb optimum (one simulation of the log per grid point).
    fn screen_thresholds(&self, kind: LawKind, tc: &[f64]) -> Option<Vec<f64>> {
        let prob = self.problem(&self.data, kind);
        let r = tc[0];
        let mut base = vec![r, r];
        base.extend_from_slice(&tc[1..]);
        let proj = prob.projection(&base, None)?;
        let proj = prob.projection(&base, Some(&proj.corrected()))?;
        let mut best: Option<(f64, Vec<f64>)> = None;
        for fs in [1.02, 1.05, 1.08, 1.12, 1.17, 1.23, 1.3, 1.4, 1.55] {
            for fd in [1.0, 0.98, 0.96, 0.93, 0.9, 0.86] {
                let mut th = vec![fs * r, fd * r];
                th.extend_from_slice(&tc[1..]);
                if let Some(c) = prob.eval(&th, Some(&proj), None) {
                    if best.as_ref().is_none_or(|b| c < b.0) {
                        best = Some((c, th));
                    }
                }
            }
        }
        best.map(|b| b.1)
    }

    /// The adequacy of a refined law: residuals of x1, x2 against the
    /// sensor noise of the same log, and their structure against drive
    /// phase, velocity, position along the stroke and time in the log.
    fn adequacy(&self, fam: Fam, th: &[f64], proj: &Proj) -> Result<Adequacy, RefineError> {
        let prob = self.problem(&self.data, fam);
        let mut res = Res::new();
        prob.idx.replace(Some(Vec::new()));
        let ok = prob.eval(th, Some(proj), Some(&mut res));
        let idx = prob.idx.take().unwrap_or_default();
        ok.ok_or(RefineError::NotSimulable)?;
        if idx.len() != res.len() || res.is_empty() {
            return Err(RefineError::Bookkeeping);
        }
        Ok(adequacy_of(&self.data, &res, &idx))
    }

    /// RMS residuals (m) of x1 and x2 at θ, simulated from the measured
    /// starts (nothing projected out).
    fn rms(&self, prob: &Problem, th: &[f64]) -> (f64, f64) {
        let mut res = Res::new();
        if prob.eval(th, None, Some(&mut res)).is_none() || res.is_empty() {
            return (f64::NAN, f64::NAN);
        }
        let n = res.len() as f64;
        let s1 = res.iter().map(|r| r.1 * r.1).sum::<f64>() / n;
        let s2 = res.iter().map(|r| r.2 * r.2).sum::<f64>() / n;
        (s1.sqrt() * self.data.sig.0, s2.sqrt() * self.data.sig.1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::identify::{fit_log, Estimate, IdentifyOptions};
    use crate::ingest::{self, IngestOptions};
    use crate::synth::{self, FrictionSpec, Sensors, SynthConfig, TestSpec};

    /// `stickslip synth --ideal-sensors` of a law (`duration_s` logged at
    /// 1.72 Hz), read back.
    fn ideal_run(friction: FrictionSpec, duration_s: f64) -> (SynthConfig, crate::ingest::Run) {
        let mut cfg = SynthConfig::paper(3);
        cfg.sensors = Sensors::ideal();
        cfg.friction = friction;
        cfg.test = TestSpec::Characteristic {
            frequency_hz: 1.72,
            warmup_s: 20.0,
            duration_s,
        };
        let log = synth::generate(&cfg).expect("generate");
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("ideal.mcap");
        synth::write(&log, &path).expect("write");
        let run = ingest::read(&path, &IngestOptions::default()).expect("ingest");
        (cfg, run)
    }

    /// The same, fitted (12 s logged).
    /// Ideal sensors have no lags: the lags are never fitted here (always
    /// fitted: `lags_of_an_ideal_log_are_tiny`).
    fn ideal_fit(friction: FrictionSpec) -> (SynthConfig, super::super::LogFit) {
        let (cfg, run) = ideal_run(friction, 12.0);
        let opts = IdentifyOptions {
            lag_fallback: false,
            ..IdentifyOptions::default()
        };
        let fit = fit_log(&run, &opts).expect("fit");
        (cfg, fit)
    }

    /// Fitted on an ideal log (no lag), the lags of x1 and x2 absorb part
    /// of what the refinement leaves at the 1e-7 m level: measured 13 µs
    /// and 7 µs on this 12-s log, and ρd then 4.2e-4 below the truth (2e-5
    /// without lags, `refinement_recovers_a_law_exactly...`). Not yet
    /// understood (open in docs/measurements.md); bounded here at 50 µs
    /// and 6e-4 so that a growth of this bias fails.
    #[test]
    fn lags_of_an_ideal_log_are_tiny() {
        let (rs, rd) = (1.68, 1.36);
        let (cfg, run) = ideal_run(
            FrictionSpec {
                rs_n: rs,
                rd_n: rd,
                slope_n_s_per_m: 0.0,
                stribeck_velocity_m_per_s: None,
                law: None,
            },
            12.0,
        );
        let opts = IdentifyOptions {
            oe: OeOptions {
                position_delays: true,
                ..OeOptions::default()
            },
            ..IdentifyOptions::default()
        };
        let fit = fit_log(&run, &opts).expect("fit");
        let o = fit.output_error.as_ref().expect("refined");
        let (d1, d2) = o.chosen.delays_s;
        assert!(d1.abs() < 5e-5 && d2.abs() < 5e-5, "{d1:e} {d2:e}");
        let fs = cfg.rig.drive_amplitude_true_m * cfg.rig.k2_n_per_m;
        let rho_s = fit.rho_s().expect("rho_s");
        let rho_d = fit.rho_d().expect("rho_d");
        assert!((rho_s / (rs / fs) - 1.0).abs() < 6e-4, "{rho_s}");
        assert!((rho_d / (rd / fs) - 1.0).abs() < 6e-4, "{rho_d}");
    }

    /// The numerical engine's path (Stribeck laws) simulates the log as the
    /// exact engine does: a Stribeck law without a peak (ρs = ρd) is the
    /// linear law ρd + D*·v, so both give the same positions at every
    /// compared sample (drive phase, time origin and velocity scale agree).
    #[test]
    fn the_numerical_path_reproduces_the_exact_one() {
        let friction = FrictionSpec {
            rs_n: 1.2,
            rd_n: 1.2,
            slope_n_s_per_m: -3.0,
            stribeck_velocity_m_per_s: None,
            law: None,
        };
        let (_, run) = ideal_run(friction, 6.0);
        let ch = crate::identify::characteristic(&run, &Gains::default()).expect("contact");
        let r = Refinement::new(
            &ch.contact,
            &run.resampled.x0,
            &ch.segmentation,
            &run.rig,
            &OeOptions::default(),
        )
        .expect("segments");
        let (mut rl, mut rs) = (Res::new(), Res::new());
        r.problem(&r.data, LawKind::Decreasing)
            .eval(&[1.2, -3.0, 0.0, 1.0, 1.0], None, Some(&mut rl))
            .expect("exact");
        r.problem(&r.data, LawKind::Stribeck)
            .eval(&[1.2, 1.2, -3.0, 0.01, 0.0, 1.0, 1.0], None, Some(&mut rs))
            .expect("numerical");
        assert_eq!(rl.len(), rs.len());
        assert!(rl.len() > 1000);
        let (s1, s2) = r.data.sig;
        let worst = rl
            .iter()
            .zip(&rs)
            .map(|(a, b)| ((a.1 - b.1) * s1).abs().max(((a.2 - b.2) * s2).abs()))
            .fold(0.0f64, f64::max);
        eprintln!("largest position difference {worst:.3e} m");
        assert!(worst < 1e-9, "{worst:e} m");
    }

    /// With ideal sensors the refinement recovers the law to the
    /// simulator's precision (the equation-error fit is 0.3–1 % off on
    /// the same data: smoothing and differentiation).
    #[test]
    fn refinement_recovers_a_law_exactly_from_ideal_sensors() {
        for (rs, rd, a, kind) in [
            (1.68, 1.36, 0.0, LawKind::StaticDynamic),
            (1.2, 1.2, -3.0, LawKind::Decreasing),
        ] {
            let (cfg, fit) = ideal_fit(FrictionSpec {
                rs_n: rs,
                rd_n: rd,
                slope_n_s_per_m: a,
                stribeck_velocity_m_per_s: None,
                law: None,
            });
            assert_eq!(
                fit.estimate,
                Estimate::OutputError,
                "{:?} {:?}",
                fit.warnings,
                fit.fit.law
            );
            let o = fit.output_error.as_ref().expect("refined");
            assert_eq!(o.law.kind, kind, "{:?}", o.families);
            let fs = cfg.rig.drive_amplitude_true_m * cfg.rig.k2_n_per_m;
            let ss = (cfg.rig.k2_n_per_m * cfg.rig.m2_kg).sqrt();
            let rel = |x: Option<f64>, t: f64| (x.expect("value") / t - 1.0).abs();
            assert!(
                rel(fit.rho_s(), rs / fs) < 2e-5,
                "ρs {:?} vs {}",
                fit.rho_s(),
                rs / fs
            );
            assert!(
                rel(fit.rho_d(), rd / fs) < 2e-5,
                "ρd {:?} vs {}",
                fit.rho_d(),
                rd / fs
            );
            assert!(
                (fit.dstar().expect("D*") - a / ss).abs() < 5e-5,
                "D* {:?}",
                fit.dstar()
            );
            // Gains and bias of ideal sensors: 1 and 0 (the bias, a
            // constant force, is the least sharply determined: 0.3 µm of
            // position offset is 2e-4 N).
            let g = o.chosen.gains;
            assert!(
                (g.0 - 1.0).abs() < 5e-5 && (g.1 - 1.0).abs() < 5e-5,
                "gains {g:?}"
            );
            assert!(o.chosen.bias_n.abs() < 1e-3, "bias {}", o.chosen.bias_n);
            // Every interval holds the truth and is narrow: under 1.5e-3
            // (it was under 1e-3 before the intervals carried the channels'
            // alignment; on this log the delay estimator leaves x0's
            // 18.1 µs, its own bias, unapplied, taken as a ±18 µs
            // misalignment: 1.14e-3 wide with it).
            let (lo, hi) = fit.rho_s_interval.expect("interval");
            assert!(
                lo <= rs / fs && rs / fs <= hi && hi - lo < 1.5e-3,
                "{lo} {hi} {}",
                rs / fs
            );
        }
    }
}
