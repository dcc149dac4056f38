//! Warnings: things the user should know that did not stop a job.
//!
//! Every stage pushes [`Warning`]s, one variant per condition, carrying its
//! numbers. [`Warning`]'s `Display` renders the message users read (and
//! JSON's `warnings` holds); [`Warning::code`] gives a stable snake_case
//! code (JSON's `warning_codes`, one per warning, in the same order) that
//! scripts and the code itself match instead of the text. Several variants
//! share a code where they are one kind of condition (every missing
//! channel is `channel_absent`, every corrected lag `channel_delay`); the
//! codes are listed in [`CODES`] and documented in `docs/interface.md`.
//!
//! The module depends on nothing above the model (it names a law by its
//! [`LawKind`] and a channel by its name), so every stage can use it.

use crate::model::LawKind;
use std::path::PathBuf;

mod render;

/// Serde for the `&'static str` fields (channel names, units, rig
/// constants): written as strings; read back interned, each distinct
/// string leaked once (a handful of names, as saved fit artifacts carry
/// them).
/// A name the code spells (`&'static str`; an alias, so serde does not
/// take it for a string borrowed from its input).
type StaticStr = &'static str;

mod static_str {
    use std::collections::HashSet;
    use std::sync::{Mutex, OnceLock};

    pub fn serialize<S: serde::Serializer>(v: &&'static str, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(v)
    }

    pub fn deserialize<'de, D: serde::Deserializer<'de>>(d: D) -> Result<&'static str, D::Error> {
        let v: String = serde::Deserialize::deserialize(d)?;
        static SEEN: OnceLock<Mutex<HashSet<&'static str>>> = OnceLock::new();
        let mut seen = SEEN
            .get_or_init(|| Mutex::new(HashSet::new()))
            .lock()
            .unwrap_or_else(|e| e.into_inner());
        if let Some(s) = seen.get(v.as_str()) {
            return Ok(s);
        }
        let s: &'static str = Box::leak(v.into_boxed_str());
        seen.insert(s);
        Ok(s)
    }
}

/// Every code [`Warning::code`] gives, each once.
pub const CODES: &[&str] = &[
    "option_ignored",
    "channel_absent",
    "dropouts",
    "unknown_topic",
    "unit_assumed",
    "unfinished_segment",
    "sample_rate",
    "clipped",
    "velocity_drift",
    "velocity_gain",
    "acceleration_gain",
    "channel_delay",
    "velocity_derived",
    "acceleration_filled",
    "velocity_distrusted",
    "stuck",
    "slider_held",
    "rough_cost",
    "law_not_fitted",
    "no_simple_law",
    "never_sticks",
    "no_breakaway",
    "position_delay",
    "refinement_failed",
    "short_sticks",
    "contradiction",
    "law_changed",
    "threshold_not_identified",
    "velocity_scale_not_identified",
    "parsimony",
    "direction_dependent",
    "contact_compliance",
    "nonlinear_spring",
    "untested",
    "inadequate",
    "normal_force",
    "drive_amplitude",
    "drive_frequency",
    "bias_unknown",
    "step_skipped",
    "drive_shape",
    "rig_mismatch",
    "invalid_draws",
    "band_precision",
    "no_steady_state",
    "recommendation_edge",
    "no_cliff",
    "no_recommendation",
    "missing_steady_states",
    "log_left_out",
    "estimates_disagree",
    "conflict",
    "few_points",
    "intercept",
    "mu_d_above_mu_s",
    "censored_disagrees",
    "pad_not_simulated",
    "pad_scatter",
    "duplicate",
    "same_record",
];

/// The largest residual structure named by [`Warning::Inadequate`].
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct WorstStructure {
    /// `x1` or `x2`.
    #[serde(with = "static_str")]
    pub channel: StaticStr,
    /// What the residuals were binned against (`drive phase`, `velocity`, ...).
    #[serde(with = "static_str")]
    pub against: StaticStr,
    /// Size of the structure in units of the noise.
    pub effect: f64,
    /// χ² of the bin means per degree of freedom.
    pub chi2_per_dof: f64,
    /// Standard score of that χ².
    pub z: f64,
}

/// One warning with its numbers. `Display` gives the message; [`Self::code`]
/// its stable code.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[non_exhaustive]
pub enum Warning {
    // ---- ingest ----
    /// `--map` given for a log that is not CSV.
    MapIgnored,
    /// An optional channel of this quantity is absent (neither a2 nor v2).
    ChannelAbsent {
        /// The quantity's name.
        #[serde(with = "static_str")]
        channel: StaticStr,
    },
    /// No accelerometer channel.
    NoAccelerometer,
    /// No velocity channel.
    NoVelocityChannel,
    /// An optional channel without a valid sample, dropped.
    ChannelEmpty {
        /// The channel as the log names it.
        label: String,
    },
    /// An MCAP channel of an optional quantity without messages.
    ChannelNoMessages {
        /// The topic.
        topic: String,
        /// The quantity's name.
        #[serde(with = "static_str")]
        quantity: StaticStr,
    },
    /// More than 5 % of a channel's samples are null.
    ChannelNulls {
        /// The channel's name.
        #[serde(with = "static_str")]
        channel: StaticStr,
        /// Null samples.
        nulls: usize,
        /// All samples.
        samples: usize,
    },
    /// An MCAP topic that is no channel stickslip knows.
    UnknownTopic {
        /// The topic.
        topic: String,
    },
    /// An MCAP channel without a unit: the quantity's SI unit is assumed.
    UnitAssumed {
        /// The topic.
        topic: String,
        /// The unit assumed.
        #[serde(with = "static_str")]
        unit: StaticStr,
    },
    /// The last TDMS segment was not finished by its writer: the bytes of
    /// its incomplete chunk are ignored.
    UnfinishedSegment {
        /// Byte offset of the segment.
        byte: usize,
        /// Bytes ignored.
        ignored: u64,
    },
    /// An MCAP channel's buffers use different sample intervals.
    MixedSampleIntervals {
        /// The topic.
        topic: String,
        /// The shortest interval (ns).
        min_ns: u64,
        /// The longest interval (ns).
        max_ns: u64,
        /// The interval taken as nominal (the median, ns).
        nominal_ns: u64,
    },
    /// An MCAP channel's `sample_rate_hz` disagrees with its `dt_ns`.
    SampleRateMismatch {
        /// The topic.
        topic: String,
        /// The stated rate (Hz).
        rate_hz: f64,
        /// The buffers' interval (ns), which is used.
        dt_ns: u64,
    },
    /// A channel flat at one end of its range (a saturated sensor).
    Clipped {
        /// The channel's name.
        #[serde(with = "static_str")]
        channel: StaticStr,
        /// At its maximum (else its minimum).
        high: bool,
        /// The level (SI).
        level: f64,
        /// The channel's unit.
        #[serde(with = "static_str")]
        unit: StaticStr,
        /// Fraction of the samples clipped.
        fraction: f64,
        /// Samples clipped.
        samples: usize,
        /// Runs of clipped samples.
        runs: usize,
    },
    /// The velocity channel's offset drifts (removed).
    VelocityDrift {
        /// The drift (m/s per s).
        drift_m_per_s2: f64,
        /// The log's duration (s).
        span_s: f64,
        /// 95 % half-width of the drift (m/s per s).
        half_width_m_per_s2: f64,
    },
    /// The velocity channel's gain differs from that of d/dt x2: v2 was
    /// divided by it.
    VelocityGain {
        /// v2 over d/dt x2.
        gain: f64,
        /// Its 95 % half-width (0 in artifacts written before it existed).
        #[serde(default)]
        half_width: f64,
        /// The relative deviation from 1 beyond which the channel is
        /// rescaled (0: an artifact written before v2 was rescaled).
        #[serde(default)]
        tolerance: f64,
    },
    /// The accelerometer's gain differs from that of d²/dt² x2: a2 was
    /// divided by it.
    AccelerationGain {
        /// a2 over d²/dt² x2.
        gain: f64,
        /// Its 95 % half-width.
        half_width: f64,
        /// The relative deviation from 1 beyond which the channel is
        /// rescaled.
        tolerance: f64,
    },
    /// A channel's estimated shift against x1, applied.
    ChannelDelay {
        /// The channel's name.
        #[serde(with = "static_str")]
        channel: StaticStr,
        /// The shift applied beyond the declared one (s; negative: lags).
        shift_s: f64,
        /// 95 % interval of the channel's shift (s; NaN when unknown).
        interval_s: (f64, f64),
        /// The declared shift (s; 0: none).
        declared_s: f64,
    },
    /// The velocity channel lags x2 (corrected by the identification).
    VelocityLag {
        /// The lag (s).
        lag_s: f64,
    },
    /// The acceleration channel lags the velocity (corrected).
    AccelerationLag {
        /// The lag (s).
        lag_s: f64,
    },
    // ---- identify ----
    /// No velocity channel: ẋ2 is derived from x2.
    VelocityDerived {
        /// Savitzky–Golay half-window (samples).
        half_window: usize,
    },
    /// Samples without accelerometer data use the differentiated velocity.
    AccelerationFilled {
        /// How many.
        samples: usize,
    },
    /// The positions contradict the velocity channel's verdict.
    VelocityDistrusted {
        /// What the positions show.
        why: String,
    },
    /// Behind a compliant contact the slider never broke away: M2 rode on
    /// the contact spring (it moved, so its velocity showed no stick);
    /// the log is reported as stuck.
    SliderHeld {
        /// Contact stiffness kt (N/m) of the contact force against x2.
        kt_n_per_m: f64,
        /// Range of x2 (m): M2's motion on the contact spring.
        x2_range_m: f64,
        /// The contact force's amplitude (N): the lower bound on Rs.
        force_amplitude_n: f64,
    },
    /// The output-error cost is not smooth at the scale of the chosen
    /// law's intervals (short sticks switch with the parameters): its
    /// widths from the residuals' secants stray from the tangent's, and
    /// each interval is the widest of the tangent's and the secants'.
    RoughCost {
        /// The largest ratio (either way) of a secant's width to the
        /// tangent's.
        secant_ratio: f64,
    },
    /// Too few slip samples: the log is reported as stuck.
    FewSlipSamples {
        /// Usable slip samples.
        samples: usize,
    },
    /// The law asked for could not be fitted.
    LawNotFitted {
        /// The law asked for.
        law: LawKind,
    },
    /// None of the simple laws fits (Stribeck-like residuals).
    NoSimpleLaw {
        /// The Stribeck velocity (m/s), if found.
        stribeck_velocity_m_per_s: Option<f64>,
        /// The best simple law.
        best: LawKind,
    },
    /// M2 never sticks: Rs only bounded.
    NeverSticks,
    /// No stick → slip transition found.
    NoBreakaway,
    /// The position records lag the drive (fitted with the law).
    PositionDelays {
        /// x1's lag (s).
        x1_s: f64,
        /// Its 95 % interval (s).
        x1_interval_s: (f64, f64),
        /// x2's lag (s).
        x2_s: f64,
        /// Its 95 % interval (s).
        x2_interval_s: (f64, f64),
        /// `None`: fitted because the law without lags did not explain the
        /// log; `Some(ΔBIC)`: the law without lags explained it to the
        /// noise, but its residuals followed the velocity or the drive
        /// phase and the lags lowered the BIC by this much.
        delta_bic: Option<f64>,
    },
    /// The output-error refinement failed.
    RefinementFailed {
        /// Why.
        reason: String,
    },
    /// The Stribeck family could not be refined.
    StribeckFailed {
        /// Why.
        reason: String,
    },
    /// The output-error law sticks where the velocity showed no stick.
    ShortSticks {
        /// The output-error law.
        law: LawKind,
        /// Fraction of the time stuck.
        stick_fraction: f64,
        /// Stick phases.
        stick_runs: usize,
        /// Typical stick phase (s).
        run_s: f64,
    },
    /// The never-sticks bounds on Rs contradict each other.
    BoundsContradict {
        /// Upper bound from the reversal forces (N).
        upper_n: f64,
        /// Lower bound from the sliding level (N).
        lower_n: f64,
        /// From the output-error estimate (no stick-free law explains the log).
        output_error: bool,
    },
    /// The output-error refinement chose another law.
    LawChanged {
        /// The output-error law.
        output_error: LawKind,
        /// The equation-error law.
        equation_error: LawKind,
    },
    /// Another family explains the log almost as well (ΔBIC below 10) but
    /// puts the breakaway threshold Rs outside the chosen law's interval:
    /// the interval is widened to hold it.
    ThresholdNotIdentified {
        /// The other family.
        other: LawKind,
        /// Its BIC minus the chosen one's.
        delta_bic: f64,
        /// Its Rs (N).
        other_rs_n: f64,
        /// The chosen law's Rs interval before widening (N).
        interval_n: (f64, f64),
    },
    /// The chosen static/dynamic law's threshold is not identified against
    /// a Stribeck drop too fast for the log to resolve: with v_s held at a
    /// value the criterion does not tell from the chosen law, the Stribeck
    /// family puts Rs below the chosen law's interval, which is widened to
    /// hold that fit's interval.
    DropNotResolved {
        /// The v_s (m/s) of that fit.
        vs_m_per_s: f64,
        /// The largest v_s (m/s) the criterion admits.
        vs_admitted_m_per_s: f64,
        /// Its BIC minus the chosen law's.
        delta_bic: f64,
        /// Its Rs (N).
        other_rs_n: f64,
        /// The chosen law's Rs interval before widening (N).
        interval_n: (f64, f64),
        /// The widened interval's low end (N).
        low_n: f64,
    },
    /// A Stribeck law behind the contact spring explains the positions
    /// better than the chosen law, but the log has no accelerometer to
    /// confirm it: a position sensor's filter leaves x2's residuals the
    /// same structure a Stribeck drop removes, and the positions alone do
    /// not tell the two apart. The chosen law is kept; its Rs, Rd (and ρ)
    /// and κ intervals are widened to hold the Stribeck reading's.
    StribeckUnconfirmed {
        /// The Stribeck law's BIC minus the chosen law's (negative: the
        /// criterion prefers it).
        delta_bic: f64,
        /// Its Rs (N) and interval.
        rs_n: f64,
        /// Its Rs interval (N).
        rs_interval_n: Option<(f64, f64)>,
        /// Its Rd (N).
        rd_n: f64,
        /// Its Rd interval (N).
        rd_interval_n: Option<(f64, f64)>,
        /// Its velocity scale v_s (m/s).
        vs_m_per_s: Option<f64>,
        /// Its contact stiffness κ = kt/K2.
        kappa: Option<f64>,
        /// Its κ interval.
        kappa_interval: Option<(f64, f64)>,
        /// The chosen law's own Rs interval before widening (N).
        own_rs_interval_n: Option<(f64, f64)>,
        /// The chosen law's own κ interval before widening.
        own_kappa_interval: Option<(f64, f64)>,
        /// The readings disagree on Rs beyond their intervals: Rs is
        /// reported as the widened interval only.
        rs_not_identified: bool,
        /// The same for κ.
        kappa_not_identified: bool,
    },
    /// A forced law's velocity scale is below what the log resolves (its
    /// drop happens within one sample: a step to the data).
    VelocityScaleUnresolved {
        /// The law.
        law: LawKind,
        /// Its fitted v_s (m/s).
        vs_m_per_s: f64,
        /// The speed (m/s) the slider gains within one sample after
        /// breakaway, |Rs − Rd|/M2·dt.
        resolution_m_per_s: f64,
    },
    /// A real-pad extension (split threshold, contact spring) could not be
    /// refined.
    PadRefinementFailed {
        /// Why.
        reason: String,
    },
    /// The chosen law's static threshold depends on the sliding direction.
    DirectionDependent {
        /// The split Δ = Rs⁺ − Rs⁻ (N) the log identifies.
        split_n: f64,
        /// Its 95 % interval (N).
        interval_n: (f64, f64),
    },
    /// With calibrated position zeros the friction levels differ by
    /// sliding direction (the dynamic levels' difference resolved).
    LevelsByDirection {
        /// The declared bound on each position zero (m).
        zero_uncertainty_m: f64,
        /// Rd⁺ − Rd⁻ (N).
        rd_split_n: f64,
        /// Its 95 % interval (N).
        interval_n: (f64, f64),
        /// Rs⁺, Rd⁺, Rs⁻, Rd⁻ (N; a threshold None where only bounded).
        levels_n: [Option<f64>; 4],
    },
    /// The threshold is split by direction, but M2 never breaks away towards
    /// one side: that side's threshold is only bounded.
    DirectionBounded {
        /// The side whose threshold is bounded (`+` or `-`).
        side: char,
        /// Its bounds (N): above Rd, below the smallest net force at a
        /// reversal without stick towards it (None if they contradict).
        bounds_n: Option<(f64, f64)>,
    },
    /// The chosen law has a compliant contact (pre-sliding).
    ContactCompliance {
        /// κ = kt/K2.
        kappa: f64,
        /// Its 95 % interval.
        interval: (f64, f64),
        /// kt (N/m).
        kt_n_per_m: f64,
        /// Largest pre-sliding displacement Rs/kt (m).
        presliding_m: f64,
        /// The static threshold is not resolved above the sliding level
        /// behind the spring (Rs ≥ Rd only).
        threshold_unresolved: bool,
    },
    /// M1's equation shows a coupling spring that is not linear (the
    /// model's is): the fit is not adequate, whatever its residuals.
    NonlinearSpring {
        /// Stiffness change at the largest stretch (fraction of K2).
        change: f64,
        /// Its 95 % interval.
        interval: (f64, f64),
        /// The change over its standard error.
        z: f64,
        /// The largest stretch x1 − x2 (m).
        max_stretch_m: f64,
    },
    /// A family's extra parameter is consistent with Coulomb: Coulomb chosen.
    NestedCoulomb {
        /// The family set aside.
        law: LawKind,
    },
    /// The law was not checked against the positions.
    Untested {
        /// The law.
        law: LawKind,
    },
    /// The law does not explain the log down to its noise.
    Inadequate {
        /// The law.
        law: LawKind,
        /// Residual / noise of x1 and x2.
        noise_ratio: (f64, f64),
        /// Residual / noise of the force, where known.
        force_ratio: Option<f64>,
        /// The adequacy limit of the noise ratios.
        max_noise_ratio: f64,
        /// The largest residual structure, if any counts.
        worst: Option<WorstStructure>,
        /// Factor the intervals are widened by.
        inflation: f64,
    },
    /// The log's normal force is negative.
    NormalForceNegative {
        /// The normal force (N).
        normal_force_n: f64,
    },
    /// The log's normal force is zero.
    NormalForceZero,
    /// A characteristic log's drive amplitude differs from the nominal.
    DriveAmplitude {
        /// Measured (m).
        measured_m: f64,
        /// Nominal (m).
        nominal_m: f64,
    },
    /// The metadata's drive frequency contradicts the measured one.
    DriveFrequency {
        /// The metadata's (Hz).
        metadata_hz: f64,
        /// Measured (Hz).
        measured_hz: f64,
        /// The relative tolerance exceeded.
        tolerance: f64,
    },
    /// The force bias is unknown (`characteristic`).
    BiasUnknown,
    // ---- validate ----
    /// A sweep's drive amplitude differs from the nominal.
    SweepDriveAmplitude {
        /// Measured (m).
        measured_m: f64,
        /// Nominal (m).
        nominal_m: f64,
    },
    /// A step whose drive could not be measured.
    StepUnmeasured {
        /// The step (1-based).
        step: usize,
        /// Its frequency (Hz).
        frequency_hz: f64,
    },
    /// A step whose hold is shorter than one drive period.
    StepTooShort {
        /// The step (1-based).
        step: usize,
        /// Its frequency (Hz).
        frequency_hz: f64,
    },
    /// A step where x1/x2 have too few samples.
    StepFewSamples {
        /// The step (1-based).
        step: usize,
        /// Its frequency (Hz).
        frequency_hz: f64,
        /// The window (s).
        window_s: (f64, f64),
    },
    /// The drive departs from a slowly swept sinusoid.
    DriveShape {
        /// Residual (m RMS).
        rms_m: f64,
    },
    /// A rig constant differs between the characteristic log and the sweep.
    SweepRigMismatch {
        /// The constant (`M1`, `M2`, `K1`, `K2`).
        #[serde(with = "static_str")]
        constant: StaticStr,
        /// The characteristic log's value.
        characteristic: f64,
        /// The sweep's value.
        sweep: f64,
    },
    /// Drawn laws that were invalid.
    InvalidDraws {
        /// Invalid draws.
        invalid: usize,
        /// All draws.
        draws: usize,
    },
    /// The replay band's coverages are less precise than the target.
    BandImprecise {
        /// The worst standard error (fraction).
        standard_error: f64,
        /// Drawn laws.
        draws: usize,
        /// The target (fraction).
        target: f64,
    },
    /// No step reached its steady state.
    NoSteadyState,
    // ---- batch ----
    /// The recommendation lies at the edge of the candidates.
    RecommendationAtEdge,
    /// No cliff found below the recommendation.
    NoCliff {
        /// Twice the recommendation's worst amplitude.
        threshold: f64,
        /// The lowest ρs searched.
        rho_min: f64,
    },
    /// No normal force recommended.
    NoRecommendation {
        /// Why.
        reason: String,
    },
    /// Steady states without amplitude left out of the worst case.
    MissingSteadyStates {
        /// How many.
        missing: usize,
    },
    /// The logs' median drive amplitude differs from the one used for ρ.
    BatchDriveAmplitude {
        /// The logs' median measured amplitude (m).
        measured_m: f64,
        /// The amplitude used (m).
        used_m: f64,
    },
    /// A log of the batch with a zero normal force.
    LogNormalForceZero {
        /// The log.
        log: PathBuf,
    },
    /// A log without usable static-friction information.
    NoStaticInformation {
        /// The log.
        log: PathBuf,
    },
    /// A log without a sliding level with an interval (left out of μd).
    NoSlidingLevel {
        /// The log.
        log: PathBuf,
    },
    /// A log whose normal force is not positive (left out of the fits).
    NormalForceNotPositive {
        /// The log.
        log: PathBuf,
        /// Its normal force (N).
        normal_force_n: f64,
    },
    /// A log's static-friction bounds are empty (left out of μs).
    EmptyStaticBounds {
        /// The log.
        log: PathBuf,
        /// Lower bound (N).
        low_n: f64,
        /// Upper bound (N).
        high_n: f64,
    },
    /// Some logs chose a real-pad extension, fewer than half of those
    /// that could have: the batch simulates the pad without it.
    BatchPadNotSimulated {
        /// Which extension (in words).
        extension: String,
        /// Logs that chose it.
        chosen: usize,
        /// Logs that could have (M2 slid under a refined fit).
        eligible: usize,
        /// Its value combined over the logs that chose it.
        value: f64,
    },
    /// The logs' values of a simulated real-pad extension scatter beyond
    /// their intervals about the batch's model of it (one value, or κ's
    /// power law in N): χ²/dof above χ²'s 99 % point for its degrees of
    /// freedom. The simulated value's interval is Birge-widened.
    BatchPadScatter {
        /// Which extension (in words).
        extension: String,
        /// The model the logs scatter about (in words).
        model: String,
        /// χ² per degree of freedom about it.
        chi2_per_dof: f64,
        /// Its degrees of freedom.
        dof: usize,
        /// The logs' smallest and largest value.
        range: (f64, f64),
        /// The simulated value (κ at the reference force for a power law).
        value: f64,
        /// Its widened 95 % interval.
        interval: (f64, f64),
    },
    /// A log's equation-error and output-error estimates disagree.
    EstimatesDisagree {
        /// The log.
        log: PathBuf,
        /// `Rs` or `Rd`.
        #[serde(with = "static_str")]
        quantity: StaticStr,
        /// The difference in standard deviations.
        z: f64,
    },
    /// A conflict between the logs (also listed in `conflicts`).
    Conflict {
        /// What the conflict is.
        what: String,
    },
    /// The logs contradict each other and the data do not say which is off.
    UnresolvedConflict {
        /// `μs` or `μd`.
        #[serde(with = "static_str")]
        quantity: StaticStr,
    },
    /// μ without and with the conflicting logs.
    ConflictSetAside {
        /// `μs` or `μd`.
        #[serde(with = "static_str")]
        quantity: StaticStr,
        /// μ and its 95 % interval without the conflicting logs.
        robust: (f64, f64, f64),
        /// μ and its 95 % interval with every log.
        all: (f64, f64, f64),
    },
    /// μs rests on few measured logs.
    FewStaticPoints {
        /// Measured logs.
        points: usize,
    },
    /// A free fit's intercept is significant.
    Intercept {
        /// `μs` or `μd`.
        #[serde(with = "static_str")]
        quantity: StaticStr,
        /// The intercept (N).
        intercept_n: f64,
        /// Its 95 % half-width (N).
        half_width_n: f64,
    },
    /// μd exceeds μs.
    MuDAboveMuS {
        /// μd.
        mu_d: f64,
        /// μs.
        mu_s: f64,
    },
    /// A censored log's bound disagrees with the fitted μs.
    CensoredDisagrees {
        /// The log.
        log: PathBuf,
        /// The μs interval.
        interval: (f64, f64),
    },
    /// A rig constant differs between the logs of a batch.
    BatchRigMismatch {
        /// The constant.
        #[serde(with = "static_str")]
        constant: StaticStr,
        /// The log that differs.
        log: PathBuf,
        /// Its value.
        value: f64,
        /// The first log.
        reference_log: PathBuf,
        /// Its value.
        reference: f64,
    },
    // ---- pipeline ----
    /// A file given twice.
    DuplicateFile {
        /// The file.
        log: PathBuf,
    },
    /// Two files of the same test.
    DuplicateTest {
        /// The file set aside.
        log: PathBuf,
        /// The file kept.
        of: PathBuf,
        /// The shared `recorded_at`.
        recorded_at: Option<String>,
    },
    /// Two files with one rig record whose data differ (both kept).
    SameRecord {
        /// The first file.
        first: PathBuf,
        /// The second file.
        second: PathBuf,
        /// Their normal forces (N).
        normal_force_n: (f64, f64),
        /// Their drive amplitudes (m).
        drive_amplitude_m: (f64, f64),
    },
}

impl Warning {
    /// The stable snake_case code of this warning's kind (one of [`CODES`]).
    pub fn code(&self) -> &'static str {
        use Warning::*;
        match self {
            MapIgnored => "option_ignored",
            ChannelAbsent { .. }
            | NoAccelerometer
            | NoVelocityChannel
            | ChannelEmpty { .. }
            | ChannelNoMessages { .. } => "channel_absent",
            ChannelNulls { .. } => "dropouts",
            UnknownTopic { .. } => "unknown_topic",
            UnitAssumed { .. } => "unit_assumed",
            UnfinishedSegment { .. } => "unfinished_segment",
            MixedSampleIntervals { .. } | SampleRateMismatch { .. } => "sample_rate",
            Clipped { .. } => "clipped",
            VelocityDrift { .. } => "velocity_drift",
            VelocityGain { .. } => "velocity_gain",
            AccelerationGain { .. } => "acceleration_gain",
            ChannelDelay { .. } | VelocityLag { .. } | AccelerationLag { .. } => "channel_delay",
            VelocityDerived { .. } => "velocity_derived",
            AccelerationFilled { .. } => "acceleration_filled",
            VelocityDistrusted { .. } => "velocity_distrusted",
            FewSlipSamples { .. } => "stuck",
            SliderHeld { .. } => "slider_held",
            RoughCost { .. } => "rough_cost",
            LawNotFitted { .. } => "law_not_fitted",
            NoSimpleLaw { .. } => "no_simple_law",
            NeverSticks => "never_sticks",
            NoBreakaway => "no_breakaway",
            PositionDelays { .. } => "position_delay",
            RefinementFailed { .. } | StribeckFailed { .. } => "refinement_failed",
            ShortSticks { .. } => "short_sticks",
            BoundsContradict { .. } => "contradiction",
            LawChanged { .. } => "law_changed",
            ThresholdNotIdentified { .. } | DropNotResolved { .. } | StribeckUnconfirmed { .. } => {
                "threshold_not_identified"
            }
            VelocityScaleUnresolved { .. } => "velocity_scale_not_identified",
            NestedCoulomb { .. } => "parsimony",
            PadRefinementFailed { .. } => "refinement_failed",
            DirectionDependent { .. } | DirectionBounded { .. } | LevelsByDirection { .. } => {
                "direction_dependent"
            }
            ContactCompliance { .. } => "contact_compliance",
            NonlinearSpring { .. } => "nonlinear_spring",
            Untested { .. } => "untested",
            Inadequate { .. } => "inadequate",
            NormalForceNegative { .. } | NormalForceZero | LogNormalForceZero { .. } => {
                "normal_force"
            }
            DriveAmplitude { .. } | SweepDriveAmplitude { .. } | BatchDriveAmplitude { .. } => {
                "drive_amplitude"
            }
            DriveFrequency { .. } => "drive_frequency",
            BiasUnknown => "bias_unknown",
            StepUnmeasured { .. } | StepTooShort { .. } | StepFewSamples { .. } => "step_skipped",
            DriveShape { .. } => "drive_shape",
            SweepRigMismatch { .. } | BatchRigMismatch { .. } => "rig_mismatch",
            InvalidDraws { .. } => "invalid_draws",
            BandImprecise { .. } => "band_precision",
            NoSteadyState => "no_steady_state",
            RecommendationAtEdge => "recommendation_edge",
            NoCliff { .. } => "no_cliff",
            NoRecommendation { .. } => "no_recommendation",
            MissingSteadyStates { .. } => "missing_steady_states",
            NoStaticInformation { .. }
            | NoSlidingLevel { .. }
            | NormalForceNotPositive { .. }
            | EmptyStaticBounds { .. } => "log_left_out",
            EstimatesDisagree { .. } => "estimates_disagree",
            Conflict { .. } | UnresolvedConflict { .. } | ConflictSetAside { .. } => "conflict",
            FewStaticPoints { .. } => "few_points",
            Intercept { .. } => "intercept",
            MuDAboveMuS { .. } => "mu_d_above_mu_s",
            CensoredDisagrees { .. } => "censored_disagrees",
            BatchPadNotSimulated { .. } => "pad_not_simulated",
            BatchPadScatter { .. } => "pad_scatter",
            DuplicateFile { .. } | DuplicateTest { .. } => "duplicate",
            SameRecord { .. } => "same_record",
        }
    }
}

/// The codes of `warnings`, in order (JSON's `warning_codes`).
pub fn codes(warnings: &[Warning]) -> Vec<&'static str> {
    warnings.iter().map(Warning::code).collect()
}

/// The messages of `warnings`, in order (JSON's `warnings`, the report's).
pub fn messages(warnings: &[Warning]) -> Vec<String> {
    warnings.iter().map(ToString::to_string).collect()
}

/// Serialises warnings as their messages: the JSON outputs' `warnings`
/// lists (`#[serde(serialize_with = ...)]`; the codes go beside them as
/// `warning_codes`). The derived serde form (a tagged variant with its
/// numbers) is what saved fit artifacts carry, so a fit read back has the
/// same warnings, variants and all.
pub fn as_messages<S: serde::Serializer>(w: &[Warning], s: S) -> Result<S::Ok, S::Error> {
    s.collect_seq(w.iter().map(|w| w.to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::{BTreeMap, BTreeSet};

    /// One of each variant, with the message the stages wrote before the
    /// warnings were typed (their format strings and arguments, copied):
    /// the messages must not change. (The old arguments are kept as they
    /// were written, nested `format!`s and casts included.)
    #[allow(
        clippy::format_in_format_args,
        clippy::unnecessary_cast,
        clippy::unnecessary_literal_unwrap
    )]
    fn examples() -> Vec<(Warning, String)> {
        let mut all = examples_a();
        all.extend(examples_b());
        all.extend(examples_c());
        all
    }

    /// The values the examples' messages are made of.
    struct Fx {
        p: PathBuf,
        q: PathBuf,
        x: f64,
        y: f64,
        z: f64,
        s: LawKind,
        c: LawKind,
        topic: &'static str,
        label: &'static str,
        half: usize,
        filled: usize,
        n: usize,
    }

    fn fx() -> Fx {
        Fx {
            p: PathBuf::from("logs/a.mcap"),
            q: PathBuf::from("logs/b.mcap"),
            x: 1.234_567_8,
            y: -0.004_321,
            z: 2.5e-3,
            s: LawKind::StaticDynamic,
            c: LawKind::Coulomb,
            topic: "/mass2/velocity",
            label: "/daq/v2",
            half: 7,
            filled: 101,
            n: 12,
        }
    }

    /// A third of [`examples`] (one function would be over 200 lines).
    #[allow(
        clippy::format_in_format_args,
        clippy::unnecessary_cast,
        clippy::unnecessary_literal_unwrap,
        unused_variables
    )]
    fn examples_a() -> Vec<(Warning, String)> {
        use Warning::*;
        let Fx {
            p,
            q,
            x,
            y,
            z,
            s,
            c,
            topic,
            label,
            half,
            filled,
            n,
        } = fx();
        vec![
            (MapIgnored, "--map applies to CSV, TDMS and MAT logs only; ignored".to_string()),
            (
                UnfinishedSegment {
                    byte: 1234,
                    ignored: 12,
                },
                "the last TDMS segment (at byte 1234) was not finished by its writer: 12 bytes of an incomplete chunk ignored".to_string(),
            ),
            (ChannelAbsent { channel: "x0" }, format!("no {} channel", "x0")),
            (
                NoAccelerometer,
                "no accelerometer channel (a2): acceleration must be derived from velocity"
                    .to_string(),
            ),
            (
                NoVelocityChannel,
                "no velocity channel (v2): identification derives the velocity of M2 from x2"
                    .to_string(),
            ),
            (
                ChannelEmpty { label: label.into() },
                format!("channel {label} has no valid sample; treated as absent"),
            ),
            (
                ChannelNoMessages { topic: topic.into(), quantity: "v2" },
                format!("channel {} ({}) has no messages", topic, "v2"),
            ),
            (
                ChannelNulls { channel: "x1", nulls: n, samples: 200 },
                format!("channel {} is null in {n} of {} samples", "x1", 200),
            ),
            (
                UnknownTopic { topic: topic.into() },
                format!("ignored unknown topic {topic}"),
            ),
            (
                UnitAssumed { topic: topic.into(), unit: "m/s" },
                format!("channel {topic} states no unit; {} assumed", "m/s"),
            ),
            (
                MixedSampleIntervals { topic: topic.into(), min_ns: 999_000, max_ns: 1_001_000, nominal_ns: 1_000_000 },
                format!(
                    "channel {}: buffers use different sample intervals ({}..{} ns); {} ns taken as nominal",
                    topic, 999_000u64, 1_001_000u64, 1_000_000u64
                ),
            ),
            (
                SampleRateMismatch { topic: topic.into(), rate_hz: 1000.0, dt_ns: 1_100_000 },
                format!(
                    "channel {}: sample_rate_hz {} disagrees with dt_ns {} ({} Hz); dt_ns used",
                    topic,
                    1000.0,
                    1_100_000u64,
                    1.0 / (1_100_000u64 as f64 * 1e-9)
                ),
            ),
            (
                Clipped { channel: "x1", high: true, level: x, unit: "m", fraction: 0.15, samples: 300, runs: 4 },
                format!(
                    "clipped: {} flat at its {} ({:.4e} {}) in {:.1} % of the samples ({} samples in {} runs): saturated sensor or DAQ input; those samples are left out of every fit",
                    "x1", "maximum", x, "m", 100.0 * 0.15, 300, 4
                ),
            ),
            (
                VelocityDrift { drift_m_per_s2: y, span_s: 20.0, half_width_m_per_s2: z },
                format!(
                    "velocity channel v2: its offset drifts by {:.3} mm/s over the log ({:.4} ± {:.4} mm/s per s against d/dt x2); removed",
                    y * 20.0 * 1e3,
                    y * 1e3,
                    z * 1e3
                ),
            ),
            (
                VelocityGain { gain: x, half_width: 0.0004, tolerance: 0.02 },
                format!(
                    "velocity channel v2: its gain is {:.4} ± {:.4} times that of d/dt x2 (more than 2 % off); v2 divided by it (x2 sets the scale)",
                    x, 0.0004
                ),
            ),
            (
                AccelerationGain { gain: 0.95, half_width: 0.001, tolerance: 0.02 },
                format!(
                    "accelerometer a2: its gain is {:.4} ± {:.4} times that of d²/dt² x2 (more than 2 % off); a2 divided by it (x2 sets the scale)",
                    0.95, 0.001
                ),
            ),
            (
                ChannelDelay { channel: "x2", shift_s: -0.003, interval_s: (-0.0035, -0.0025), declared_s: 0.001 },
                format!(
                    "channel {} {} x1 by {:.2} ms (95 % interval of its shift {:.2} to {:.2} ms){}; corrected",
                    "x2",
                    "lags",
                    0.003 * 1e3,
                    -0.0035 * 1e3,
                    -0.0025 * 1e3,
                    format!(" beyond the declared shift_s {:.2} ms", 0.001 * 1e3)
                ),
            ),
            (
                VelocityLag { lag_s: z },
                format!("velocity channel lags the position x2 by {:.2} ms; corrected", z * 1e3),
            ),
            (
                AccelerationLag { lag_s: z },
                format!("acceleration channel lags the velocity by {:.2} ms; corrected", z * 1e3),
            ),
            (
                VelocityDerived { half_window: half },
                format!("no velocity channel: ẋ2 derived from x2 (Savitzky–Golay derivative over ±{half} samples); its noise sets the stick detection threshold"),
            ),
            (
                AccelerationFilled { samples: filled },
                format!("{filled} samples without accelerometer data use the differentiated velocity"),
            ),
            (
                VelocityDistrusted { why: "x2 moves".into() },
                format!("{}: the velocity channel is distrusted; stick, slip and ẋ2 come from x2", "x2 moves"),
            ),
            (
                SliderHeld {
                    kt_n_per_m: 12070.0,
                    x2_range_m: 3.75e-4,
                    force_amplitude_n: 2.26,
                },
                "M2 rode on a contact spring (kt 12070 N/m; x2 moved 375 µm, the contact force in proportion) and the slider never broke away: reported as stuck behind a compliant contact (Rs ≥ 2.260 N, the contact force's amplitude)".to_string(),
            ),
            (
                RoughCost { secant_ratio: 4.81 },
                "the fit's cost is not smooth at the scale of its intervals (short sticks switch with the parameters): widths from secants over the intervals stray from the tangent's by up to ×4.81; each interval is the widest of them".to_string(),
            ),
            (
                FewSlipSamples { samples: n },
                format!("M2 slid in only {} usable samples: reported as stuck", n),
            ),
            (
                LawNotFitted { law: s },
                format!("law {} could not be fitted to this log; chose by BIC instead", s.as_str()),
            ),
            (
                NoSimpleLaw { stribeck_velocity_m_per_s: Some(0.008), best: s },
                format!(
                    "none of the simple laws fits: residuals are structured (Stribeck-like peak near zero velocity, v_s = {:.2} mm/s); best simple law {}",
                    Some(0.008).unwrap_or(f64::NAN) * 1e3,
                    s.as_str()
                ),
            ),
        ]
    }

    /// A third of [`examples`] (one function would be over 200 lines).
    #[allow(
        clippy::format_in_format_args,
        clippy::unnecessary_cast,
        clippy::unnecessary_literal_unwrap,
        unused_variables
    )]
    fn examples_b() -> Vec<(Warning, String)> {
        use Warning::*;
        let Fx {
            p,
            q,
            x,
            y,
            z,
            s,
            c,
            topic,
            label,
            half,
            filled,
            n,
        } = fx();
        vec![
            (
                NeverSticks,
                "M2 never sticks in this log: the static threshold is only bounded (rho_s_interval holds the bounds)".to_string(),
            ),
            (NoBreakaway, "no stick → slip transition could be located".to_string()),
            (
                PositionDelays { x1_s: z, x1_interval_s: (0.002, 0.003), x2_s: y, x2_interval_s: (-0.005, -0.004), delta_bic: None },
                format!(
                    "position records lag the drive: x1 by {:.3} ms [{:.3}, {:.3}], x2 by {:.3} ms [{:.3}, {:.3}] \
                     (fitted with the law: without these lags it does not explain the log; a sensor filter at f_c lags by about 1/(2π·f_c))",
                    z * 1e3, 0.002 * 1e3, 0.003 * 1e3, y * 1e3, -0.005 * 1e3, -0.004 * 1e3
                ),
            ),
            (
                RefinementFailed { reason: "too few sticks".into() },
                format!("output-error refinement not possible ({}); the equation-error estimate is used", "too few sticks"),
            ),
            (
                StribeckFailed { reason: "no data".into() },
                format!("the Stribeck family could not be refined ({}); the best simple law is kept", "no data"),
            ),
            (
                ShortSticks { law: s, stick_fraction: 0.0312, stick_runs: 40, run_s: 0.0123 },
                format!(
                    "the velocity shows no stick, but the output-error law ({}) sticks {:.1} % of the time in {} phases of about {:.0} ms (short sticks at reversal): ρs is measured, not bounded",
                    s.as_str(),
                    100.0 * 0.0312,
                    40,
                    0.0123 * 1e3
                ),
            ),
            (
                BoundsContradict { upper_n: x, lower_n: 1.3, output_error: true },
                format!(
                    "the never-sticks bounds contradict each other: the reversal forces bound Rs above by {:.4} N, the sliding level below by {:.4} N; no stick-free law explains this log",
                    x, 1.3
                ),
            ),
            (
                BoundsContradict { upper_n: x, lower_n: 1.3, output_error: false },
                format!(
                    "the never-sticks bounds contradict each other: the reversal forces bound Rs above by {:.4} N, the sliding level below by {:.4} N",
                    x, 1.3
                ),
            ),
            (
                DropNotResolved {
                    vs_m_per_s: 4e-4,
                    vs_admitted_m_per_s: 8e-4,
                    delta_bic: 2.5,
                    other_rs_n: 1.1,
                    interval_n: (1.2, 1.3),
                    low_n: 1.05,
                },
                format!(
                    "this log does not identify the breakaway threshold: a Stribeck drop within a few samples of breakaway (v_s {:.3} mm/s; the criterion admits v_s up to {:.3} mm/s) explains it almost as well (ΔBIC {:.1}) with Rs {:.4} N, below the chosen law's interval [{:.4}, {:.4}] N; the Rs interval is widened down to {:.4} N",
                    0.4, 0.8, 2.5, 1.1, 1.2, 1.3, 1.05
                ),
            ),
            (
                VelocityScaleUnresolved { law: s, vs_m_per_s: 2e-15, resolution_m_per_s: 1.5e-4 },
                format!(
                    "the {} law's velocity scale v_s = {:.2e} m/s is below what this log resolves (the slider gains {:.2e} m/s within one sample after breakaway): its drop is a step to the data, so v_s is not identified and the law acts as a step from Rs to Rd",
                    s.as_str(), 2e-15, 1.5e-4
                ),
            ),
            (
                StribeckUnconfirmed {
                    delta_bic: -19.7,
                    rs_n: 0.372,
                    rs_interval_n: Some((0.366, 0.378)),
                    rd_n: 0.353,
                    rd_interval_n: Some((0.345, 0.361)),
                    vs_m_per_s: Some(0.0021),
                    kappa: Some(41.9),
                    kappa_interval: Some((40.3, 43.5)),
                    own_rs_interval_n: Some((0.49, 0.53)),
                    own_kappa_interval: Some((40.3, 42.0)),
                    rs_not_identified: true,
                    kappa_not_identified: false,
                },
                "the positions are explained better by a Stribeck law behind the contact (ΔBIC -19.7: Rs 0.3720 N [0.3660, 0.3780], Rd 0.3530 N [0.3450, 0.3610], v_s 2.100 mm/s, κ 41.90 [40.30, 43.50]), but the log has no accelerometer to confirm it (a position sensor's filter leaves x2 the same residuals); the chosen law is kept and its Rs, Rd and κ intervals (its own: Rs [0.4900, 0.5300] N, κ [40.30, 42.00]) are widened to hold both readings; the readings disagree on Rs beyond their intervals: this log does not identify Rs, reported as its interval only".to_string(),
            ),
            (
                ThresholdNotIdentified { other: s, delta_bic: 3.25, other_rs_n: 1.5, interval_n: (1.2, 1.3) },
                format!(
                    "this log does not identify the breakaway threshold: the {} law explains it almost as well (ΔBIC {:.1}) with Rs {:.4} N, outside the chosen law's interval [{:.4}, {:.4}] N; the Rs interval is widened to hold it",
                    s.as_str(), 3.25, 1.5, 1.2, 1.3
                ),
            ),
            (
                LawChanged { output_error: c, equation_error: s },
                format!(
                    "the output-error refinement chose the law {} (equation error: {})",
                    c.as_str(),
                    s.as_str()
                ),
            ),
            (
                NestedCoulomb { law: s },
                format!(
                    "the {} family's extra parameter is consistent with Coulomb friction (its 95 % interval holds the nested value): Coulomb chosen",
                    s.as_str()
                ),
            ),
            (
                Untested { law: s },
                format!(
                    "adequacy not tested: the {} law is the equation-error estimate, not checked against the positions (adequate: false); its intervals carry no model error",
                    s.as_str()
                ),
            ),
            (
                Inadequate {
                    law: s,
                    noise_ratio: (2.5, 1.25),
                    force_ratio: Some(3.125),
                    max_noise_ratio: 2.0,
                    worst: Some(WorstStructure { channel: "x2", against: "velocity", effect: 0.75, chi2_per_dof: 4.25, z: 9.5 }),
                    inflation: 1.875,
                },
                format!(
                    "the law {} does not explain the log down to its sensor noise: residual/noise x1 {:.2}, x2 {:.2}{} (adequate: ≤ {:.1}){}; the statistical intervals are widened ×{:.2}",
                    s.as_str(),
                    2.5,
                    1.25,
                    format!(", force {:.2}", 3.125),
                    2.0,
                    format!(
                        "; largest structure: {} residuals against {}, {:.2} of the noise (χ²/dof {:.1}, z {:.1})",
                        "x2", "velocity", 0.75, 4.25, 9.5
                    ),
                    1.875
                ),
            ),
            (
                Inadequate { law: c, noise_ratio: (2.5, 1.25), force_ratio: None, max_noise_ratio: 2.0, worst: None, inflation: 1.875 },
                format!(
                    "the law {} does not explain the log down to its sensor noise: residual/noise x1 {:.2}, x2 {:.2}{} (adequate: ≤ {:.1}){}; the statistical intervals are widened ×{:.2}",
                    c.as_str(), 2.5, 1.25, "", 2.0, "", 1.875
                ),
            ),
            (
                NormalForceNegative { normal_force_n: -x },
                format!(
                    "the normal force is negative ({} N): a sign or unit mistake in the log? Friction coefficients from it would be meaningless (batch refuses it)",
                    -x
                ),
            ),
            (
                NormalForceZero,
                "the normal force is zero: the friction member may be off; no friction coefficient (μ) can be formed".to_string(),
            ),
            (
                DriveAmplitude { measured_m: 0.002_527, nominal_m: 0.0025 },
                format!(
                    "measured drive amplitude {:.4} mm differs from the nominal {:.4} mm by {:+.1} %; ρ uses the measured one",
                    0.002_527 * 1e3,
                    0.0025 * 1e3,
                    (0.002_527 / 0.0025 - 1.0) * 100.0
                ),
            ),
            (
                DriveFrequency { metadata_hz: 10.0, measured_hz: 10.5, tolerance: 0.02 },
                format!(
                    "the metadata's drive frequency {} Hz contradicts the measured {:.4} Hz (by {:+.1} %, more than {} %); η and the fit use the measured one",
                    10.0,
                    10.5,
                    (10.0 / 10.5 - 1.0) * 100.0,
                    0.02 * 100.0
                ),
            ),
            (BiasUnknown, "force bias unknown (M2 never slid): R includes the sensors' offsets".to_string()),
            (
                SweepDriveAmplitude { measured_m: 0.002_454_8, nominal_m: 0.0025 },
                format!(
                    "measured drive amplitude {:.4} mm differs from the nominal {:.4} mm by {:+.1} %; A_i/A uses the measured one",
                    0.002_454_8 * 1e3,
                    0.0025 * 1e3,
                    (0.002_454_8 / 0.0025 - 1.0) * 100.0
                ),
            ),
            (
                StepUnmeasured { step: 3, frequency_hz: 10.25 },
                format!("step {} ({} Hz): the drive channel has too few samples to measure it", 3, 10.25),
            ),
            (
                StepTooShort { step: 3, frequency_hz: x },
                format!("step {} ({:.3} Hz): the hold is shorter than one drive period", 3, x),
            ),
            (
                StepFewSamples { step: 3, frequency_hz: x, window_s: (1.5, 2.25) },
                format!("step {} ({:.3} Hz): x1/x2 have too few samples in the window {:.2}-{:.2} s", 3, x, 1.5, 2.25),
            ),
            (
                DriveShape { rms_m: z },
                format!(
                    "the drive signal departs from a slowly swept sinusoid (residual {:.1} µm RMS): the measured frequency plan may be off",
                    z * 1e6
                ),
            ),
            (
                SweepRigMismatch { constant: "K2", characteristic: 1000.0, sweep: 1100.5 },
                format!(
                    "rig constant {} differs between the characteristic log ({}) and the sweep ({}): are they from the same rig?",
                    "K2", 1000.0, 1100.5
                ),
            ),
        ]
    }

    /// A third of [`examples`] (one function would be over 200 lines).
    #[allow(
        clippy::format_in_format_args,
        clippy::unnecessary_cast,
        clippy::unnecessary_literal_unwrap,
        unused_variables
    )]
    fn examples_c() -> Vec<(Warning, String)> {
        use Warning::*;
        let Fx {
            p,
            q,
            x,
            y,
            z,
            s,
            c,
            topic,
            label,
            half,
            filled,
            n,
        } = fx();
        vec![
            (
                PadRefinementFailed { reason: "no data".into() },
                format!("a real-pad extension could not be refined ({}); the law without it is kept", "no data"),
            ),
            (
                LevelsByDirection {
                    zero_uncertainty_m: 1e-5,
                    rd_split_n: 0.06,
                    interval_n: (0.04, 0.08),
                    levels_n: [Some(0.918), Some(0.742), None, Some(0.682)],
                },
                "the friction levels depend on the sliding direction (position zeros calibrated to ±10.0 µm): \
                 Rs⁺ 0.9180, Rd⁺ 0.7420, Rs⁻ only bounded, Rd⁻ 0.6820 N; Rd⁺ − Rd⁻ = 0.0600 N [0.0400, 0.0800]"
                    .to_string(),
            ),
            (
                DirectionDependent { split_n: 0.05, interval_n: (0.03, 0.07) },
                format!(
                    "the static threshold depends on the sliding direction: Rs⁺ − Rs⁻ = {:.4} N [{:.4}, {:.4}] with equal dynamic levels; \
                     with unknown sensor zero offsets only this difference of the drops Rs − Rd is identified \
                     (shifting one direction's levels against the other's is an x2 offset): calibrate the zeros to split the levels",
                    0.05, 0.03, 0.07
                ),
            ),
            (
                DirectionBounded { side: '-', bounds_n: Some((0.74, 0.83)) },
                format!(
                    "the static threshold depends on the sliding direction: M2 sticks and breaks away towards the other side only, \
                     and reverses towards {} without sticking, so the threshold there is only bounded: {:.4}–{:.4} N (null value, the interval holds the bounds)",
                    '-', 0.74, 0.83
                ),
            ),
            (
                NonlinearSpring { change: 0.075, interval: (0.049, 0.101), z: 5.8, max_stretch_m: 2.2e-3 },
                "the coupling spring is not linear: by M1's equation of motion (friction-free) its stiffness changes by +7.5 % [+4.9, +10.1] (z 5.8) at the largest stretch x1 − x2 of 2.200 mm; \
                 the model's springs are linear, so the fitted law absorbs the difference (adequate: false)"
                    .to_string(),
            ),
            (
                ContactCompliance { kappa: 20.0, interval: (15.0, 27.0), kt_n_per_m: 13400.0, presliding_m: 4e-5, threshold_unresolved: true },
                format!(
                    "the contact is compliant (pre-sliding): κ = kt/K2 = {:.3} [{:.3}, {:.3}], kt = {:.0} N/m, up to {:.1} µm before sliding{}",
                    20.0, 15.0, 27.0, 13400.0, 40.0,
                    "; behind it the static threshold shows only as the extra deflection (Rs − Rd)/kt before each breakaway, \
                     which this log does not resolve: Rs ≥ Rd only (rho_s null; its interval holds the bounds the log admits, \
                     and κ's interval every admitted threshold)"
                ),
            ),
            (
                InvalidDraws { invalid: 2, draws: 200 },
                format!("{} of {} drawn laws were invalid and skipped", 2, 200),
            ),
            (
                BandImprecise { standard_error: 0.0234, draws: 60, target: 0.01 },
                format!(
                    "the replay band's coverages are known to ±{:.1} percentage points (bootstrap standard error over {} drawn laws), more than the target ±{:.1}: draw more laws (--samples) for a more precise band",
                    100.0 * 0.0234,
                    60,
                    100.0 * 0.01
                ),
            ),
            (NoSteadyState, "no step reached its steady state: the steady-state scores are null".to_string()),
            (
                RecommendationAtEdge,
                "the recommendation lies at the edge of the candidates whose box fits the grid: widen --rho-min/--rho-max".to_string(),
            ),
            (
                NoCliff { threshold: x, rho_min: 0.05 },
                format!(
                    "no cliff found: W stays below twice the recommendation's ({:.3}) down to ρs = {}",
                    x, 0.05
                ),
            ),
            (
                NoRecommendation { reason: "no box".into() },
                format!("no normal force recommended: {}", "no box"),
            ),
            (
                MissingSteadyStates { missing: 5 },
                format!("{} steady states without amplitude (interrupted or resonant) were left out of the worst case", 5),
            ),
            (
                BatchDriveAmplitude { measured_m: 0.0026, used_m: 0.0025 },
                format!(
                    "the logs' median measured drive amplitude {:.4} mm differs from the amplitude used for ρ ({:.4} mm) by more than 3 %",
                    0.0026 * 1e3,
                    0.0025 * 1e3
                ),
            ),
            (
                LogNormalForceZero { log: p.clone() },
                format!("{}: the normal force is zero (the friction member may be off): its μ is null", p.display()),
            ),
            (
                NoStaticInformation { log: p.clone() },
                format!("{}: no usable static-friction information (no estimate, bound or interval)", p.display()),
            ),
            (
                NoSlidingLevel { log: p.clone() },
                format!("{}: no usable sliding level with an interval: left out of μd", p.display()),
            ),
            (
                NormalForceNotPositive { log: p.clone(), normal_force_n: -x },
                format!("{}: measured normal force {} N is not positive: left out of the fits", p.display(), -x),
            ),
            (
                EmptyStaticBounds { log: p.clone(), low_n: 1.5, high_n: x },
                format!(
                    "{}: static-friction bounds are empty ({:.4} N ≥ {:.4} N): the log contradicts its own never-sticks call; left out of μs",
                    p.display(), 1.5, x
                ),
            ),
            (
                BatchPadNotSimulated {
                    extension: "a contact spring κ".into(),
                    chosen: 1,
                    eligible: 4,
                    value: 41.5,
                },
                format!(
                    "{} of {} logs that slid chose {} (combined {:.4}); fewer than half: the worst cases simulate the pad without it",
                    1, 4, "a contact spring κ", 41.5
                ),
            ),
            (
                BatchPadScatter {
                    extension: "a contact spring κ".into(),
                    model: "one value".into(),
                    chi2_per_dof: 12.5,
                    dof: 3,
                    range: (13.5, 24.0),
                    value: 17.2,
                    interval: (14.1, 21.0),
                },
                format!(
                    "{}: the logs' values ({:.4} to {:.4}) scatter beyond their intervals about {} (χ²/dof {:.2} on {} degrees of freedom, above χ²'s 99 % point {:.2}); the worst cases simulate {:.4} with its 95 % interval widened to [{:.4}, {:.4}]: something the logs do not record (wear, temperature, settling of the contact) differs between them, or one log is off",
                    "a contact spring κ", 13.5, 24.0, "one value", 12.5, 3, 3.78, 17.2, 14.1, 21.0
                ),
            ),
            (
                EstimatesDisagree { log: p.clone(), quantity: "Rs", z: 2.345 },
                format!(
                    "{}: its equation-error and output-error {q} differ by {:.1}σ: the log's {q} is in doubt",
                    p.display(),
                    2.345,
                    q = "Rs"
                ),
            ),
            (
                Conflict { what: "μs: scatter".into() },
                format!("conflict: {}", "μs: scatter"),
            ),
            (
                UnresolvedConflict { quantity: "μd" },
                format!(
                    "{sym}: the logs contradict each other and the data do not say which log is off: {sym} uses every log, its interval widened by their scatter",
                    sym = "μd"
                ),
            ),
            (
                ConflictSetAside { quantity: "μs", robust: (0.41, 0.4, 0.42), all: (0.43, 0.39, 0.47) },
                format!(
                    "{}: {:.4}, 95 % [{:.4}, {:.4}] without the conflicting log(s); {:.4}, 95 % [{:.4}, {:.4}] with every log",
                    "μs", 0.41, 0.4, 0.42, 0.43, 0.39, 0.47
                ),
            ),
            (
                FewStaticPoints { points: 1 },
                format!("μs rests on {} measured log(s) (the others only bound it): its interval is wide", 1),
            ),
            (
                Intercept { quantity: "μd", intercept_n: y, half_width_n: z },
                format!(
                    "{}: the free fit's intercept {:.4} N is significant (95 % half-width {:.4} N): the forces are not proportional to the measured normal force (normal-force offset?)",
                    "μd", y, z
                ),
            ),
            (
                MuDAboveMuS { mu_d: 0.45, mu_s: 0.4 },
                format!("μd = {:.4} exceeds μs = {:.4}: the recommendation uses ρd = ρs", 0.45, 0.4),
            ),
            (
                CensoredDisagrees { log: p.clone(), interval: (0.4, 0.42) },
                format!(
                    "{}: its bound on Rs disagrees with the fitted μs interval [{:.4}, {:.4}]",
                    p.display(), 0.4, 0.42
                ),
            ),
            (
                BatchRigMismatch { constant: "nominal A", log: q.clone(), value: 0.0026, reference_log: p.clone(), reference: 0.0025 },
                format!(
                    "rig constant {} of {} ({}) differs from {} ({}): a batch should be one pad on one rig",
                    "nominal A", q.display(), 0.0026, p.display(), 0.0025
                ),
            ),
            (DuplicateFile { log: q.clone() }, format!("{} is given twice: counted once", q.display())),
            (
                DuplicateTest { log: q.clone(), of: p.clone(), recorded_at: None },
                format!(
                    "{} is the same test as {} (same rig record, recorded_at {}, same measured normal force and drive): counted once",
                    q.display(), p.display(), "?"
                ),
            ),
            (
                SameRecord { first: p.clone(), second: q.clone(), normal_force_n: (4.0, 4.5), drive_amplitude_m: (0.0025, 0.0026) },
                format!(
                    "{} and {} carry the same rig record and recorded_at but their data differ (normal force {:.3} / {:.3} N, drive {:.4} / {:.4} mm): kept as two tests",
                    p.display(), q.display(), 4.0, 4.5, 0.0025 * 1e3, 0.0026 * 1e3
                ),
            ),
        ]
    }

    #[test]
    fn every_variant_renders_its_old_message() {
        for (w, old) in examples() {
            assert_eq!(w.to_string(), old, "{w:?}");
            // The JSON outputs' `warnings` are the messages.
            let mut out = Vec::new();
            as_messages(
                std::slice::from_ref(&w),
                &mut serde_json::Serializer::new(&mut out),
            )
            .unwrap();
            let v: serde_json::Value = serde_json::from_slice(&out).unwrap();
            assert_eq!(v, serde_json::json!([old]));
            // A saved fit carries the variant with its numbers: read back,
            // it is the same warning (same code, same message).
            let back: Warning = serde_json::from_value(serde_json::to_value(&w).unwrap()).unwrap();
            assert_eq!(back, w);
        }
    }

    /// A fit artifact written before v2 was rescaled holds the velocity's
    /// gain alone: it reads back and says what was done then.
    #[test]
    fn an_old_velocity_gain_warning_reads_back_as_not_corrected() {
        let mut v = serde_json::to_value(Warning::VelocityGain {
            gain: 1.091,
            half_width: 0.0004,
            tolerance: 0.02,
        })
        .unwrap();
        let fields = v
            .as_object_mut()
            .and_then(|o| o.values_mut().next())
            .and_then(|f| f.as_object_mut())
            .expect("an externally tagged variant");
        fields.remove("half_width");
        fields.remove("tolerance");
        let w: Warning = serde_json::from_value(v).unwrap();
        assert_eq!(
            w.to_string(),
            "velocity channel v2: its gain is 1.091 times that of d/dt x2; not corrected (x2 sets the scale)"
        );
    }

    #[test]
    fn codes_are_snake_case_listed_once_and_all_used() {
        let snake = |c: &str| {
            !c.is_empty()
                && c.starts_with(|ch: char| ch.is_ascii_lowercase())
                && !c.ends_with('_')
                && !c.contains("__")
                && c.chars().all(|ch| ch.is_ascii_lowercase() || ch == '_')
        };
        let listed: BTreeSet<&str> = CODES.iter().copied().collect();
        assert_eq!(listed.len(), CODES.len(), "a code is listed twice");
        for c in CODES {
            assert!(snake(c), "{c} is not snake_case");
        }
        // Every variant (the examples hold one of each: counted by their
        // discriminants) has a listed code, and every listed code is used.
        let ex = examples();
        let kinds: BTreeMap<String, &str> = ex
            .iter()
            .map(|(w, _)| {
                let name = format!("{w:?}");
                let name = name
                    .split(|c: char| !c.is_alphanumeric())
                    .next()
                    .unwrap_or_default()
                    .to_string();
                (name, w.code())
            })
            .collect();
        assert_eq!(kinds.len(), VARIANTS, "one example per variant");
        let used: BTreeSet<&str> = kinds.values().copied().collect();
        for c in &used {
            assert!(listed.contains(c), "{c} is not in CODES");
        }
        assert_eq!(used, listed, "listed codes that no variant gives");
    }

    /// The number of variants of [`Warning`] (a new variant needs an
    /// example above, a code, and a line in `docs/interface.md`).
    const VARIANTS: usize = 86;

    #[test]
    fn every_code_is_documented() {
        let doc = std::fs::read_to_string(
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/interface.md"),
        )
        .expect("docs/interface.md");
        for c in CODES {
            assert!(
                doc.contains(&format!("| `{c}` |")),
                "{c} has no row in docs/interface.md's table of warning codes"
            );
        }
    }
}
