//! # Identify: ingested characteristic log → friction characteristic → fitted law
//!
//! This stage owns everything between a clean [`Run`] of a characteristic
//! test and the friction law with its uncertainty:
//!
//! * `contact`: the contact force R(t) of paper eq. 7 (plus the damper
//!   term), with the corrections the raw channels need (drive amplitude,
//!   velocity offset, channel time offsets, acceleration from the
//!   accelerometer or a Savitzky–Golay differentiator).
//! * `segment`: stick/slip separation under noise (noise level from the
//!   data, hysteresis, flatness/minimum-duration rule, breakaway location).
//! * `fit`: the equation-error fit (robust regression on slips, breakaway
//!   forces, law selection by BIC with an effective sample size, Stribeck
//!   by variable projection, bootstrap over periods).
//! * `output_error`: the output-error refinement (the simulator driven by
//!   the measured drive reproduces the measured x1, x2; multiple shooting
//!   from the stick phases; family selection by BIC with an effective
//!   sample size; sandwich intervals over segments).
//! * `pads`: the real-pad screen (a threshold that depends on the sliding
//!   direction, a compliant contact; `docs/real-pads.md`), whose findings
//!   the output-error refinement then tries as extensions of the law.
//! * `json`: the JSON entry of one fitted log ([`LogFit::to_json`]).
//! * this module: the calibration budget of the equation-error estimate
//!   (sensor gain errors are systematic: the identification is re-run with
//!   each sensor's gain perturbed, and the spread is combined with the
//!   bootstrap), the choice of the estimate used, and the conversion to the
//!   dimensionless ρ with the log's *measured* drive amplitude.
//!
//! Doors: [`characteristic`] (R, ẋ2, stick flag per sample) and [`fit_log`]
//! (the law of one log with 95 % intervals).
//!
//! ## Which estimate is used
//!
//! Both estimates are kept in a [`LogFit`]: `fit` (equation error, with its
//! intervals in `equation_error`) and `output_error`. [`LogFit::estimate`]
//! says which one [`LogFit::law`], `rho_s()`… and the flat interval fields
//! are, i.e. what validation and batch use and what the interface keys of
//! the JSON report. It is the **output-error** refinement wherever it
//! applies (M2 slides: every log but a stuck one; a simple family: not
//! the Stribeck type), else the equation-error fit; `--estimate
//! equation-error` (`IdentifyOptions::output_error = false`) keeps the
//! latter. The evidence, on every public characteristic log (error against
//! `truth.json`; ρ with the true drive amplitude):
//!
//! | log | EE Rs | EE Rd | EE ρs | EE ρd | OE Rs | OE Rd | OE ρs | OE ρd |
//! | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |
//! | char_N1.2 (never sticks) | – | −0.98 % | – | −1.09 % | – | +0.10 % | – | −0.01 % |
//! | char_N2.2.mcap | −0.30 % | +0.68 % | −0.18 % | +0.80 % | −0.15 % | −0.11 % | −0.03 % | +0.00 % |
//! | char_N2.2.csv | −1.80 % | −1.11 % | −1.36 % | −0.67 % | −0.42 % | −0.44 % | +0.02 % | +0.00 % |
//! | char_N2.2.parquet | −1.71 % | −0.74 % | −1.31 % | −0.33 % | −0.45 % | −0.40 % | −0.04 % | +0.00 % |
//! | char_N4 | +0.85 % | +0.66 % | +1.17 % | +0.97 % | −0.31 % | −0.31 % | +0.00 % | +0.00 % |
//! | char_N7.2 | +0.77 % | +0.64 % | +1.28 % | +1.15 % | −0.51 % | −0.51 % | −0.01 % | −0.01 % |
//! | law_coulomb | +0.33 % | +0.33 % | +0.49 % | +0.49 % | −0.16 % | −0.16 % | +0.00 % | +0.00 % |
//! | law_decreasing (D* −0.15) | +0.40 % | +0.40 % | +0.83 % | +0.83 % | −0.43 % | −0.43 % | −0.00 % | −0.00 % |
//!
//! D* of law_decreasing: +0.0056 (EE), +0.0001 (OE). The output-error
//! forces in newtons carry the drive channel's gain error (ρ·A·K2 with the
//! measured A; the drive gains of these logs are 0.995–1.001), which the
//! calibration budget covers; ρ does not. On 200 random synthetic logs
//! (`tests/fit_synth.rs`: random laws, rig constants, normal forces, noise
//! levels, with and without an accelerometer) the intervals of the
//! estimate used hold the truth for 511/522 parameters in newtons and
//! 493/522 in ρ, D* (equation error alone: 412/522), and the family is
//! right in 171/174 (the equation-error criterion alone: 135/174).
//!
//! ## Stick or no stick, adequacy, parsimony (issue 14)
//!
//! * The segmentation's never-sticks verdict is not final: the output-error
//!   refinement always tries the static-dynamic family (a screen of
//!   thresholds above the Coulomb optimum finds the narrow basin of short
//!   sticks at reversal), and where the simulated law sticks (≥ 0.5 % of
//!   the compared samples in ≥ 4 phases, with a criterion better than every
//!   stick-free family by more than 10) ρs is measured and `never_sticks`
//!   is false ([`LogFit::never_sticks`]); the reversal bound, which assumed
//!   no stick, is dropped. The positions decide (x2 flat while sticking),
//!   not the noisy velocity.
//! * Adequacy ([`LogFit::adequate`], `output_error::Adequacy`): residuals of
//!   x1, x2 against the noise measured in the same log, binned against
//!   drive phase, velocity, position and time. An inadequate law gets the
//!   numbers in `warnings` and its statistical half-widths multiplied by
//!   the misfit (largest residual/noise ratio or √(χ²/dof)). Bounds that
//!   contradict each other give no interval (never an inverted one) and
//!   make the fit inadequate. The force residual of the equation-error fit
//!   is not part of the verdict (its noise is not measured separately).
//! * Parsimony: the simplest family within a BIC difference of 2; a family
//!   whose extra parameter's interval holds the nested value (D* = 0,
//!   Rs = Rd) gives way to Coulomb; the BIC difference to the best other
//!   family is reported (`law_evidence`).
//! * ρ is the physics' ratio R/(A·K2) with the amplitude the drive really
//!   moved: the output error sees it free of sensor gains. Forces in
//!   newtons are ρ·A_measured·K2 and carry the drive gain (budget in their
//!   intervals). The tables above and the tests compare ρ with the true A.
//! * A log without a velocity channel: ẋ2 from x2 (`contact`), with a
//!   warning.
//!
//! ## Calibration budget
//!
//! Sensor gain errors are systematic: no resampling sees them. The budget
//! (default ±1 % per sensor, `IdentifyOptions::gain_uncertainty`, treated as
//! a rectangular bound, σ = u/√3) is propagated, for the equation-error
//! estimate, by re-running the whole identification with each sensor's
//! gain (x0, x1, x2, v2, a2) at 1 + u and the chosen law held fixed; the
//! half-widths of the bootstrap percentile interval and 1.96·σ_cal are
//! added in quadrature on each side. The relative gain of x1 against x2 is
//! *estimated* in the slip regression (see `fit`), so only the common scale
//! of the positions, the drive amplitude's gain (ρ = R/(A·K2)) and the
//! velocity/acceleration gains remain in the budget. The output-error
//! refinement estimates both position gains against the drive channel, so
//! its budget (linear response to each gain, see `output_error`) leaves ρ
//! and D* untouched and puts the drive gain on the forces in newtons. Rig
//! constants (M1, M2, K1, K2, d) are taken as exact.
//!
//! ## Against the simple approach
//!
//! Finite-difference acceleration, a fixed 2 mm/s velocity threshold, a
//! least-squares slip level and the largest stick force give, on the public
//! logs, slip levels within about 1 % for flat laws (the sign average
//! cancels offsets) but Rd 9 % low on the decreasing law (the slope is
//! ignored), and a "static" force 1.5–4.8 × the true Rs (the
//! finite-difference acceleration noise times M2 and the offsets dominate
//! the maximum; on the never-sticking log it reports a stick force that
//! does not exist). The equation-error fit here: Rs and Rd within 2 %
//! wherever the log measures them; the output-error refinement: ρs, ρd
//! within 0.05 % and forces within the drive sensor's gain error.
//!
//! ## Not done
//!
//! The Stribeck type is not refined by output error (no closed form: the
//! numerical engine would take seconds per log); its equation-error fit is
//! used. A stuck log has nothing to refine (only the lower bound on Rs).
//! The equation-error criterion's choice of the Stribeck type is final
//! (on 2 of 174 random logs it took a simple law for one).

// Index loops mirror the formulas (several arrays indexed together).
#![allow(clippy::needless_range_loop)]

pub mod artifact;
pub mod contact;
pub mod fit;
pub mod json;
mod many;
pub mod noise;
pub mod output_error;
pub mod pads;
pub mod positions;
pub mod segment;
pub mod smooth;
pub mod springs;

pub use crate::error::IdentifyError;
use crate::model::{LawKind, SiLaw};
pub use contact::{Contact, DriveFit, Gains};
pub use fit::{EquationFit, FitOptions, StatIntervals};
pub use many::{fit_logs, fit_runs, planned_fit_memory};
pub use output_error::{OeOptions, OutputErrorFit};
pub use segment::Segmentation;

use crate::error::{Error, Result};
use crate::ingest::{Run, TestKind};
use crate::warning::Warning;
use rayon::prelude::*;

/// Half-width (samples) of the velocity smoothing used for segmentation.
const SMOOTH_DEGREE: usize = 3;

/// The friction characteristic of one log: R(t) and ẋ2(t) on the run's
/// time base, the stick flag, and how they were obtained.
#[derive(Debug, Clone)]
pub struct Characteristic {
    /// The contact force and corrected signals (R here has the stick
    /// samples replaced by the passive force, ẋ2 = ẍ2 = 0 there).
    pub contact: Contact,
    /// The stick/slip segmentation.
    pub segmentation: Segmentation,
}

/// Computes the friction characteristic of `run` (sensor gains `gains`).
pub fn characteristic(run: &Run, gains: &Gains) -> Result<Characteristic> {
    characteristic_reusing(run, gains, None)
}

/// [`characteristic`], reusing the stages of `base` (the characteristic of
/// the same run with gains `base.0`) whose inputs are unchanged (see
/// [`contact::compute_reusing`]; the segmentation where its inputs are
/// bitwise the same). Bit for bit [`characteristic`]'s result.
fn characteristic_reusing(
    run: &Run,
    gains: &Gains,
    base: Option<(&Gains, &Characteristic)>,
) -> Result<Characteristic> {
    let bad = |source: IdentifyError| Error::Identify {
        path: run.source.clone(),
        source,
    };
    if run.rig.test != TestKind::Characteristic {
        return Err(bad(IdentifyError::NotCharacteristic));
    }
    let base_contact = base.map(|(g, ch)| (g, &ch.contact));
    let mut contact = contact::compute_reusing(run, gains, base_contact).ok_or_else(|| {
        // A log shorter than two periods of its nominal drive cannot show
        // the sinusoid: say so rather than blame the drive channel.
        let duration = run.duration_s();
        match run.rig.drive_frequency_hz {
            Some(f) if f > 0.0 && duration < 2.0 / f => bad(IdentifyError::TooShort {
                usable_s: duration,
                needed_s: 2.0 / f,
            }),
            _ => bad(IdentifyError::NoDriveSinusoid),
        }
    })?;
    // At least two drive periods of usable data: less cannot tell a stuck
    // mass from a log that is simply too short.
    let usable = (0..contact.r.len())
        .filter(|&i| contact.r[i].is_finite() && contact.v2_smooth[i].is_finite())
        .count() as f64
        * contact.dt;
    let period = 1.0 / contact.drive.frequency_hz;
    if usable < 2.0 * period || !period.is_finite() {
        return Err(bad(IdentifyError::TooShort {
            usable_s: usable,
            needed_s: 2.0 * period,
        }));
    }
    // The segmentation's inputs: ẋ2, its smoothed form, ẍ2 from an
    // accelerometer, the window. Reused where they are bitwise the base's.
    fn accel(c: &contact::Contact) -> Option<&[f64]> {
        (c.acceleration_source == "accelerometer").then_some(&c.a2[..])
    }
    let same = |a: &[f64], b: &[f64]| {
        a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits())
    };
    let reused = base.and_then(|(_, ch)| {
        let c = &ch.contact;
        let inputs_same = c.half_window == contact.half_window
            && same(&c.v2, &contact.v2)
            && same(&c.v2_smooth, &contact.v2_smooth)
            && match (accel(c), accel(&contact)) {
                (Some(a), Some(b)) => same(a, b),
                (None, None) => true,
                _ => false,
            };
        inputs_same.then(|| ch.segmentation.clone())
    });
    let seg = reused.unwrap_or_else(|| {
        segment::segment(
            &contact.v2,
            &contact.v2_smooth,
            accel(&contact),
            contact.half_window,
            SMOOTH_DEGREE,
        )
    });
    // The positions overrule a velocity channel whose verdict (stuck, or
    // never sticking) they contradict: identify from x2 instead.
    if run.has_velocity() {
        if let Some(why) = positions::check(&contact, &seg, SMOOTH_DEGREE) {
            let mut no_velocity = run.clone();
            no_velocity
                .resampled
                .v2
                .iter_mut()
                .for_each(|v| *v = f64::NAN);
            let mut ch = characteristic_reusing(&no_velocity, gains, None)?;
            ch.contact
                .warnings
                .insert(0, Warning::VelocityDistrusted { why: why.what });
            ch.contact.velocity_warnings += 1;
            return Ok(ch);
        }
    }
    // (The contact force is this contact's own column: changed in place.)
    let (k2, d) = (contact.k2_n_per_m, contact.d_n_s_per_m);
    let (x1, x2, v1) = (&contact.x1, &contact.x2, &contact.v1);
    let passive_at = |i: usize| -k2 * (x2[i] - x1[i]) + d * v1[i];
    let r = std::sync::Arc::make_mut(&mut contact.r);
    for (i, st) in seg.stick.iter().enumerate() {
        if *st {
            // The physics gives ẋ2 = ẍ2 = 0 while sticking.
            r[i] = passive_at(i);
        }
    }
    Ok(Characteristic {
        contact,
        segmentation: seg,
    })
}

/// Options of [`fit_log`].
#[derive(Debug, Clone)]
pub struct IdentifyOptions {
    /// Equation-error fit options (law, bootstrap).
    pub fit: FitOptions,
    /// Calibration budget: relative gain uncertainty of each sensor (x0,
    /// x1, x2, v2, a2), as a bound (rectangular distribution, σ = u/√3).
    /// Default 1 %.
    pub gain_uncertainty: f64,
    /// Refine by output error (the estimate then used downstream, where it
    /// applies); `false` keeps the equation-error estimate.
    pub output_error: bool,
    /// Options of the output-error refinement.
    pub oe: OeOptions,
    /// Where the law refined without position lags is not adequate, refit
    /// with the lags of x1 and x2 behind the drive, and keep that fit if it
    /// is adequate (see `OeOptions::position_delays`, which fits them
    /// always).
    pub lag_fallback: bool,
    /// Pass the real-pad screen's findings (a direction-dependent
    /// threshold, a compliant contact; `pads`) to the output-error
    /// refinement, which then tries those extensions (the criterion still
    /// decides). `false` passes none: the extensions are then tried only
    /// where the law fails the adequacy test.
    pub real_pads: bool,
    /// The memory this fit may plan to hold (bytes): the calibration
    /// re-fits run only as many at once as fit in it beside the fit
    /// (`limits::concurrent_refits`), so the peak does not grow with the
    /// thread count. Default: the whole budget
    /// ([`crate::limits::MEMORY_BUDGET_BYTES`]); [`fit_logs`] gives each of
    /// the logs it fits at once its share.
    pub memory_bytes: u64,
}

impl Default for IdentifyOptions {
    fn default() -> Self {
        Self {
            fit: FitOptions::default(),
            gain_uncertainty: 0.01,
            output_error: true,
            oe: OeOptions::default(),
            lag_fallback: true,
            real_pads: true,
            memory_bytes: crate::limits::MEMORY_BUDGET_BYTES,
        }
    }
}

/// BIC evidence (very strong) the lags of x1 and x2 must bring before
/// they are fitted on a log whose law explains it without them.
const LAG_EVIDENCE_BIC: f64 = 10.0;

use output_error::THRESHOLD_EVIDENCE_BIC;

/// Which estimate a [`LogFit`]'s law and intervals are.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum Estimate {
    /// The equation-error fit of the characteristic R(ẋ2).
    EquationError,
    /// The output-error refinement (simulated x1, x2 against the measured).
    OutputError,
}

impl Estimate {
    /// Name in the JSON (`estimate` key).
    pub fn as_str(self) -> &'static str {
        match self {
            Estimate::EquationError => "equation-error",
            Estimate::OutputError => "output-error",
        }
    }
}

/// 95 % intervals of one estimate, in SI and dimensionless.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Intervals {
    /// Rs (N); for a never-sticking log, the bounds.
    pub rs_n: Option<Interval>,
    /// Rd (N).
    pub rd_n: Option<Interval>,
    /// a (N·s/m).
    pub slope_n_s_per_m: Option<Interval>,
    /// ρs (measured A); for a never-sticking log, the bounds.
    pub rho_s: Option<Interval>,
    /// ρd.
    pub rho_d: Option<Interval>,
    /// D*.
    pub dstar: Option<Interval>,
}

/// A 95 % interval `[low, high]`.
pub type Interval = (f64, f64);

impl Intervals {
    /// The friction levels' intervals (Rs, Rd, ρs, ρd) cut at zero: a
    /// level is never negative, and an interval widened for an inadequate
    /// law (or a never-sticking log's bounds) once reached below zero
    /// (Rs in (−0.87, 0.99) N on a clipped rig-B log). The slope keeps its
    /// sign.
    pub fn levels_nonnegative(self) -> Self {
        let cut = |iv: Option<Interval>| iv.map(|(lo, hi)| (lo.max(0.0), hi.max(0.0)));
        Intervals {
            rs_n: cut(self.rs_n),
            rd_n: cut(self.rd_n),
            rho_s: cut(self.rho_s),
            rho_d: cut(self.rho_d),
            ..self
        }
    }
}

/// The fitted law of one log with its 95 % intervals, in SI and
/// dimensionless (ρ = R/(A·K2) with the measured A, D* = a/√(K2·M2)).
///
/// Two estimates are kept: the equation-error fit ([`LogFit::fit`], with
/// its intervals in [`LogFit::equation_error`]) and, where it applies, the
/// output-error refinement ([`LogFit::output_error`]). [`LogFit::estimate`]
/// says which one is *used*: [`LogFit::law`], [`LogFit::rho_s`] etc. and
/// the flat interval fields (`rs_interval_n`, …) are that estimate's, and
/// they are what validation and batch read.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct LogFit {
    /// The equation-error fit (point estimates, bootstrap, diagnostics).
    pub fit: EquationFit,
    /// The equation-error intervals (bootstrap ⊕ calibration budget).
    pub equation_error: Intervals,
    /// The output-error refinement, when it ran.
    pub output_error: Option<OutputErrorFit>,
    /// Which estimate the law and the flat intervals below are.
    pub estimate: Estimate,
    /// What the log measured of the law used (the chosen estimate's).
    pub measured: Measured,
    /// The drive fit (measured amplitude and frequency).
    pub drive: DriveFit,
    /// Normal force (N): median of the normal-force channel, else the metadata.
    pub normal_force_n: f64,
    /// Forcing frequency ratio η = 2πf·√(M2/K2) with the measured f.
    pub eta: f64,
    /// Force scale A·K2 (N) with the measured amplitude.
    pub force_scale_n: f64,
    /// Slope scale √(K2·M2) (N·s/m).
    pub slope_scale: f64,
    /// Velocity scale A·√(K2/M2) (m/s) of the dimensionless v_s.
    pub velocity_scale_m_per_s: f64,
    /// Rs interval (N) of the estimate used; for a never-sticking log, the
    /// bounds. Where the log does not identify the breakaway threshold
    /// (another family, or a Stribeck drop it cannot resolve, explains it
    /// with Rs outside the chosen law's interval: `threshold_not_identified`)
    /// it is widened to hold them.
    pub rs_interval_n: Option<Interval>,
    /// The chosen law's own Rs interval (N) and ρs interval where
    /// `rs_interval_n` was widened for the threshold's identifiability
    /// (None: not widened). Draws of the chosen law (validation bands) use
    /// these: the log pins that law's threshold to them (the static/dynamic
    /// law with a widened low Rs is refused by the log; only a law with a
    /// drop explains it).
    #[serde(default)]
    pub law_threshold_interval: Option<(Interval, Option<Interval>)>,
    /// Rd interval (N) of the estimate used.
    pub rd_interval_n: Option<Interval>,
    /// a interval (N·s/m) of the estimate used.
    pub slope_interval_n_s_per_m: Option<Interval>,
    /// ρs interval (measured A) of the estimate used.
    pub rho_s_interval: Option<Interval>,
    /// ρd interval of the estimate used.
    pub rho_d_interval: Option<Interval>,
    /// D* interval of the estimate used.
    pub dstar_interval: Option<Interval>,
    /// Relative gain uncertainty used in the budget.
    pub gain_uncertainty: f64,
    /// Characteristic details (noise, lags, offsets) for reports.
    pub notes: Vec<String>,
    /// Warnings (ingest, contact, fit).
    // In a saved fit (artifact) the typed variants, named apart from the
    // JSON outputs' `warnings` (messages, with `warning_codes` beside).
    #[serde(rename = "warning_variants")]
    pub warnings: Vec<Warning>,
    /// The adequacy verdict of the law used (see [`LogFit::adequate`]).
    pub adequacy: Option<output_error::Adequacy>,
    /// Contradictions found among the bounds (each makes the fit inadequate).
    pub contradictions: Vec<Warning>,
    /// A sliding log whose law was not tested against the positions (the
    /// equation-error estimate: the Stribeck type, or a failed refinement).
    untested: bool,
    /// The log's channel delays (declared, estimated, applied at ingest)
    /// and its velocity channel's consistency with x2.
    pub channel_delays: crate::ingest::ChannelDelays,
    /// The real-pad screen (direction dependence, contact compliance).
    #[serde(default)]
    pub pad_screen: pads::PadScreen,
    /// The coupling spring's linearity by M1's equation (`None` where it
    /// cannot be measured; a nonlinear spring is a contradiction).
    #[serde(default)]
    pub spring_screen: Option<springs::SpringScreen>,
}

/// What a log measured of its friction law.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum Measured {
    /// M2 sticks and slips: every parameter of the law is measured.
    StickSlip(SiLaw),
    /// M2 never sticks: the sliding law is measured, Rs only bounded (the
    /// bounds are the `rs_interval_n`). The law carries Rs = Rd, the lowest
    /// threshold the bounds allow, so that it is a law one can simulate.
    /// The segmentation's verdict, unless the output-error simulation finds
    /// sticks (short sticks at reversal the velocity could not show).
    NeverSticks(SiLaw),
    /// M2 never slid: no sliding law, only a lower bound on Rs.
    Stuck {
        /// The family the fit was asked for (or the default) — no family
        /// is measured.
        kind: LawKind,
        /// Lower bound on Rs (N), calibration margin included.
        rs_lower_bound_n: f64,
        /// The same in ρ.
        rho_s_lower_bound: f64,
    },
}

impl LogFit {
    /// The law used downstream (SI): the output-error law where that is
    /// the estimate, else the equation-error one. None for a stuck log;
    /// for a never-sticking log Rs = Rd (see [`Measured::NeverSticks`]).
    pub fn law(&self) -> Option<SiLaw> {
        match self.measured {
            Measured::StickSlip(l) | Measured::NeverSticks(l) => Some(l),
            Measured::Stuck { .. } => None,
        }
    }
    /// The family reported in `law` (a stuck log: the family asked for).
    pub fn kind(&self) -> LawKind {
        match self.measured {
            Measured::StickSlip(l) | Measured::NeverSticks(l) => l.kind,
            Measured::Stuck { kind, .. } => kind,
        }
    }
    /// The intervals of the estimate used.
    pub fn intervals(&self) -> Intervals {
        Intervals {
            rs_n: self.rs_interval_n,
            rd_n: self.rd_interval_n,
            slope_n_s_per_m: self.slope_interval_n_s_per_m,
            rho_s: self.rho_s_interval,
            rho_d: self.rho_d_interval,
            dstar: self.dstar_interval,
        }
    }
    /// Rs (N), where measured (towards + where the threshold is split: a
    /// law that never breaks away towards + only bounds it).
    pub fn rs_n(&self) -> Option<f64> {
        match self.measured {
            Measured::StickSlip(_)
                if self.pads().is_some_and(output_error::PadFit::rs_unmeasured) =>
            {
                None
            }
            Measured::StickSlip(l) => Some(l.rs_n),
            _ => None,
        }
    }
    /// ρs (None where only bounded).
    pub fn rho_s(&self) -> Option<f64> {
        self.rs_n().map(|r| r / self.force_scale_n)
    }
    /// ρd (None for a stuck log).
    pub fn rho_d(&self) -> Option<f64> {
        self.law().map(|l| l.rd_n / self.force_scale_n)
    }
    /// D* (None for a stuck log).
    pub fn dstar(&self) -> Option<f64> {
        self.law().map(|l| l.slope_n_s_per_m / self.slope_scale)
    }
    /// The real-pad parameters of the estimate used (the output-error
    /// refinement's; None for the equation-error estimate).
    pub fn pads(&self) -> Option<&output_error::PadFit> {
        self.output_error
            .as_ref()
            .filter(|_| self.estimate == Estimate::OutputError)
            .map(|o| &o.pads)
    }
    /// The output-error law's force bias b where calibrated position
    /// zeros resolve the levels of each direction (`levels_gauge`
    /// "calibrated zeros"): the equivalent symmetric law plus b is the law
    /// in the zeros' gauge (Rd⁺ = Rd + b, Rd⁻ = Rd − b). None elsewhere.
    pub fn calibrated_bias_n(&self) -> Option<f64> {
        self.pads()
            .and_then(|p| p.calibrated)
            .filter(|c| c.resolved)
            .map(|c| 0.5 * c.dynamic_split_n)
    }
    /// The law's static threshold depends on the sliding direction (a
    /// split was chosen); `rho_s` is then towards +, `rho_s_minus` towards
    /// −, with equal dynamic levels (see [`output_error::Ext`]).
    pub fn direction_dependent(&self) -> bool {
        self.output_error
            .as_ref()
            .filter(|_| self.estimate == Estimate::OutputError)
            .is_some_and(|o| o.chosen.ext.split)
            && !self.never_sticks()
    }
    /// ρs⁻ where the threshold is split.
    pub fn rho_s_minus(&self) -> Option<f64> {
        self.pads()
            .filter(|_| self.direction_dependent())
            .and_then(|p| p.rho_s_minus)
    }
    /// The contact stiffness κ = kt/K2 of a compliant contact (None: rigid).
    pub fn contact_stiffness(&self) -> Option<f64> {
        self.pads().and_then(|p| p.contact_stiffness)
    }
    /// κ as reported: None also where two readings the log cannot tell
    /// apart disagree on it ([`PadFit::kappa_between_readings`]; the
    /// interval holds both). [`Self::contact_stiffness`] stays the
    /// simulated pad's.
    ///
    /// [`PadFit::kappa_between_readings`]: output_error::PadFit::kappa_between_readings
    pub fn contact_stiffness_reported(&self) -> Option<f64> {
        self.contact_stiffness()
            .filter(|_| !self.pads().is_some_and(|p| p.kappa_between_readings))
    }
    /// K2 (N/m) of the log's rig (from the force scale A·K2).
    pub fn k2_n_per_m(&self) -> f64 {
        self.force_scale_n / self.drive.amplitude_m
    }
    /// A lower bound (one-sided 95 %) on κ where the contact was taken as
    /// rigid and the log has sticks to bound it: the pre-sliding the
    /// sticks could hide below the position noise.
    pub fn contact_stiffness_lower_bound(&self) -> Option<f64> {
        if self.contact_stiffness().is_some() {
            return None;
        }
        self.pad_screen
            .compliance
            .map(|c| c.kt_lower_bound_n_per_m / self.k2_n_per_m())
            .filter(|k| k.is_finite())
    }
    /// The M2 never slid: only a lower bound on Rs is known.
    pub fn stuck(&self) -> bool {
        matches!(self.measured, Measured::Stuck { .. })
    }
    /// M2 never stuck: Rs is only bounded (see [`Measured::NeverSticks`]).
    pub fn never_sticks(&self) -> bool {
        matches!(self.measured, Measured::NeverSticks(_))
    }
    /// Lower bound on Rs of a stuck log (N), calibration margin included.
    pub fn rs_lower_bound_n(&self) -> Option<f64> {
        match self.measured {
            Measured::Stuck {
                rs_lower_bound_n, ..
            } => Some(rs_lower_bound_n),
            _ => None,
        }
    }
    /// The same in ρ.
    pub fn rho_s_lower_bound(&self) -> Option<f64> {
        match self.measured {
            Measured::Stuck {
                rho_s_lower_bound, ..
            } => Some(rho_s_lower_bound),
            _ => None,
        }
    }
    /// The law explains the log down to its sensor noise, without
    /// structured residuals, and its bounds do not contradict each other.
    /// Only the output-error estimate is tested: a stuck log (nothing
    /// slides) counts as adequate unless a contradiction was found; the
    /// equation-error estimate of a sliding log (the Stribeck type, a
    /// failed refinement) is not shown adequate, so it is not.
    pub fn adequate(&self) -> bool {
        self.contradictions.is_empty()
            && match &self.adequacy {
                Some(a) => a.adequate,
                None => !self.untested,
            }
    }
}

/// The quantities whose calibration sensitivity is propagated.
fn quantities(f: &EquationFit, a: f64, k2: f64, ss: f64) -> [f64; 8] {
    let forced = fit::Forced {
        law: f.law,
        rs_lower_bound_n: f.rs_lower_bound_n,
        rs_upper_bound_n: f.rs_upper_bound_n,
    };
    quantities_of(&forced, a, k2, ss)
}

/// [`quantities`] of a law and its bounds on Rs.
fn quantities_of(f: &fit::Forced, a: f64, k2: f64, ss: f64) -> [f64; 8] {
    let [rs, rd, slope, rho_s, rho_d, dstar] = f.law.si_and_rho(a * k2, ss);
    [
        rs,
        rd,
        slope,
        rho_s,
        rho_d,
        dstar,
        f.rs_lower_bound_n.unwrap_or(f64::NAN),
        f.rs_upper_bound_n.unwrap_or(f64::NAN),
    ]
}

/// The calibration budget's variances of the [`quantities`] of `ef`: the
/// log re-fitted (same law, no bootstrap) with each sensor's gain at
/// 1 + u, each shift taken as a rectangular ±u error (σ = |δ|/√3).
fn calibration_variance(
    run: &Run,
    base: &Characteristic,
    ef: &EquationFit,
    opts: &IdentifyOptions,
    q0: &[f64; 8],
) -> [f64; 8] {
    let u = opts.gain_uncertainty;
    let rig = &run.rig;
    let k2 = rig.k2_n_per_m;
    let ss = (rig.k2_n_per_m * rig.m2_kg).sqrt();
    let mut var = [0.0f64; 8];
    if u > 0.0 {
        let mut perturbed = vec![
            Gains {
                x0: 1.0 + u,
                ..Gains::default()
            },
            Gains {
                x1: 1.0 + u,
                ..Gains::default()
            },
            Gains {
                x2: 1.0 + u,
                ..Gains::default()
            },
            Gains {
                v2: 1.0 + u,
                ..Gains::default()
            },
        ];
        if run.has_acceleration {
            perturbed.push(Gains {
                a2: 1.0 + u,
                ..Gains::default()
            });
        }
        // The perturbed re-fits are independent: in parallel, as many at
        // once as fit the memory (each holds its own characteristic),
        // booked in order (the same sums as one pass, whatever the
        // concurrency).
        let at_once = crate::limits::concurrent_refits(run.samples() as u64, opts.memory_bytes);
        let refit = |g: &Gains| {
            let ch = characteristic_reusing(run, g, Some((&Gains::default(), base))).ok()?;
            let f =
                fit::fit_forced(&ch.contact, &ch.segmentation, ef.law.kind, opts.fit.seed).ok()?;
            Some(quantities_of(&f, ch.contact.drive.amplitude_m, k2, ss))
        };
        let qs: Vec<Option<[f64; 8]>> = perturbed
            .chunks(at_once)
            .flat_map(|round| round.par_iter().map(refit).collect::<Vec<_>>())
            .collect();
        for q in qs.into_iter().flatten() {
            for k in 0..8 {
                let d = q[k] - q0[k];
                if d.is_finite() {
                    // Rectangular ±u: σ = |δ|/√3.
                    var[k] += d * d / 3.0;
                }
            }
        }
    }
    var
}

/// The warning of a law that does not explain its log down to the sensor
/// noise, naming the largest counted structure in the residuals.
fn inadequacy_warning(kind: LawKind, a: &output_error::Adequacy) -> Warning {
    let worst = a
        .structure
        .iter()
        .filter(|s| s.counted())
        .max_by(|p, q| p.effect.total_cmp(&q.effect))
        .map(|st| crate::warning::WorstStructure {
            channel: st.channel,
            against: st.against,
            effect: st.effect,
            chi2_per_dof: st.chi2_per_dof,
            z: st.z,
        });
    Warning::Inadequate {
        law: kind,
        noise_ratio: a.noise_ratio,
        force_ratio: a.force_ratio,
        max_noise_ratio: output_error::MAX_NOISE_RATIO,
        worst,
        inflation: a.inflation,
    }
}

/// The characteristic's details for reports: acceleration source, lags,
/// noise, counts of sticks, breakaways and reversals, slip samples.
fn characteristic_notes(base: &Characteristic, ef: &EquationFit) -> Vec<String> {
    let seg = &base.segmentation;
    vec![
        format!("acceleration from {}", base.contact.acceleration_source),
        format!(
            "velocity offset {:.4} mm/s, lag {:.3} ms; accelerometer lag {}",
            base.contact.v2_offset * 1e3,
            base.contact.v2_lag_s * 1e3,
            base.contact
                .a2_lag_s
                .map_or("-".to_string(), |l| format!("{:.3} ms", l * 1e3))
        ),
        format!(
            "velocity noise {:.3} mm/s raw, {:.3} mm/s smoothed; {} sticks, {} breakaways, {} reversals",
            seg.noise_v_raw * 1e3,
            seg.noise_v * 1e3,
            seg.sticks.len(),
            ef.n_breakaways,
            seg.reversals.len()
        ),
        format!(
            "{} slip samples, effective {:.0}; force bias {:.4} N",
            ef.n_slip, ef.n_eff, ef.bias_n
        ),
    ]
}

/// The lag-free refinement's outcome ([`refine`]): finished, or left
/// unfinished where its law is not adequate and the lagged pass's is.
enum LagFree {
    Finished(OutputErrorFit),
    LagsExplain(OutputErrorFit),
}

/// A lagged pass begun before the lag-free one was finished ([`refine`]):
/// finished (or failed), or its core with its refinement, to be finished
/// if the lag decision needs it from the same starts. (One per fit, on the
/// stack for a moment: the variants' sizes do not matter.)
#[allow(clippy::large_enum_variant)]
enum Tried {
    Finished(Result<OutputErrorFit, output_error::RefineError>),
    Core(output_error::Refinement, output_error::Pass),
}

/// The warning of lags kept: the lagged fit `o2`'s delays, and how much
/// lower its BIC is than an adequate lag-free law's (None where the
/// lag-free law was not adequate).
fn position_delays(o2: &OutputErrorFit, delta_bic: Option<f64>) -> Warning {
    let (d1, d2) = o2.chosen.delays_s;
    let (i1, i2) = o2.chosen.delays_interval_s;
    Warning::PositionDelays {
        x1_s: d1,
        x1_interval_s: i1,
        x2_s: d2,
        x2_interval_s: i2,
        delta_bic,
    }
}

/// The output-error refinement of `ef` (not for a stuck log: nothing
/// slides; the Stribeck family only where no simple family explains the
/// log, or when asked for), and the final never-sticks verdict: the
/// simulated law overrules the velocity where it sticks (short sticks at
/// reversal), which also voids the reversal bound.
fn refine(
    run: &Run,
    base: &Characteristic,
    ef: &mut EquationFit,
    opts: &IdentifyOptions,
    hints: output_error::PadHints,
    warnings: &mut Vec<Warning>,
) -> (Option<OutputErrorFit>, bool) {
    // Output-error refinement (not for a stuck log: nothing slides). The
    // Stribeck family is refined there only where no simple family
    // explains the log, or when it is asked for.
    let mut output_error = None;
    let u = opts.gain_uncertainty;
    if opts.output_error && !ef.stuck {
        let forced = opts.fit.law;
        let refinement = |oe: &output_error::OeOptions| {
            output_error::Refinement::new(
                &base.contact,
                &run.resampled.x0,
                &base.segmentation,
                &run.rig,
                oe,
            )
            .map(|r| {
                let (s0, s2) = run.delays.alignment_sigma();
                r.with_pad_hints(hints).with_alignment_uncertainty(s0, s2)
            })
        };
        // The lagged pass starts from the lag-free conclusion's family
        // optima (nested: lags of zero are feasible, so the search starts
        // where the lag-free one ended); the equation-error laws where a
        // family has none.
        let lagged_starts = |from: Option<&OutputErrorFit>| {
            let mut starts: Vec<SiLaw> =
                from.map_or(Vec::new(), |o| o.families.iter().map(|f| f.law).collect());
            starts.extend(
                ef.candidates
                    .iter()
                    .filter(|c| !starts.iter().any(|s| s.kind == c.kind))
                    .copied()
                    .collect::<Vec<_>>(),
            );
            (starts, from.map_or(ef.bias_n, |o| o.chosen.bias_n))
        };
        let lagged_oe = output_error::OeOptions {
            position_delays: true,
            ..opts.oe.clone()
        };
        let run_lagged = |(starts, bias): &(Vec<SiLaw>, f64)| {
            refinement(&lagged_oe).and_then(|r| r.run(starts, *bias, forced, u))
        };
        let lags_apply = opts.lag_fallback && !opts.oe.position_delays;
        // The lag-free pass up to its real-pad extensions. Where its law
        // is not adequate and the lagged families alone are (a screen, a
        // tenth of a pass), the lagged pass up to its extensions; where
        // that is adequate, and stays so finished, the lags are kept and
        // the lag-free pass is never finished: its finish (the profile in
        // Rs behind an unresolved contact; the Stribeck law behind the
        // contact, tried where x2's residuals follow the motion, which is
        // what a lag leaves) would only offer a second reading of what
        // the lags explain. (On a never-sticking log whose x2 lagged, the
        // calibrated study's z022, the finish took 385 s of a 385-s fit
        // and left the law inadequate, its cost 43 times the lagged
        // Coulomb law's.) Elsewhere the lag-free pass is finished and the
        // lags decided as below, the lagged core begun from the same
        // starts finished rather than run again. (Without the screen the
        // early lagged core cost s007, whose lagged laws are not adequate,
        // 18 s: 126 → 144 s.)
        let mut tried: Option<((Vec<SiLaw>, f64), Tried)> = None;
        let outcome = refinement(&opts.oe).and_then(|r| {
            let p = r.run_core(&ef.candidates, ef.bias_n, forced, u)?;
            let from = lagged_starts(Some(p.fit()));
            let screened = || {
                refinement(&lagged_oe)
                    .is_ok_and(|r2| r2.families_adequate(&from.0, from.1, forced, u))
            };
            if lags_apply && !p.fit().adequacy.adequate && screened() {
                let core = refinement(&lagged_oe)
                    .and_then(|r2| Ok((r2.run_core(&from.0, from.1, forced, u)?, r2)));
                let t = match core {
                    Ok((p2, r2)) if p2.fit().adequacy.adequate => match r2.finish(p2) {
                        o2 if o2.adequacy.adequate => return Ok(LagFree::LagsExplain(o2)),
                        o2 => Tried::Finished(Ok(o2)),
                    },
                    Ok((p2, r2)) => Tried::Core(r2, p2),
                    Err(e) => Tried::Finished(Err(e)),
                };
                tried = Some((from, t));
            }
            Ok(LagFree::Finished(r.finish(p)))
        });
        let (mut first, decided) = match outcome {
            Ok(LagFree::Finished(o)) => (Ok(o), false),
            Ok(LagFree::LagsExplain(o2)) => {
                warnings.push(position_delays(&o2, None));
                (Ok(o2), true)
            }
            Err(e) => (Err(e), false),
        };
        // Position records that lag the drive (sensor filters, DAQ
        // channels) leave residuals that follow the velocity (a lag δ
        // leaves −δ·ẋ). Where the law without lags is not adequate, or is
        // but its residuals carry that signature (a significant structure
        // against velocity or drive phase, however small), the lags of x1
        // and x2 are fitted with it. An inadequate law gives way to an
        // adequate lagged one; an adequate law only where the lags lower
        // the BIC (n_eff·ln S + k·ln n_eff, two more parameters, the
        // lag-free fit's n_eff) by more than 10 and shrink the signature.
        // (Fitted on every log the lags are not neutral: on a lag-free log
        // with a decreasing law the lagged search ended at a higher cost,
        // D* 1.3 % off.)
        // A lag-free refinement that failed (a forced Stribeck law on a
        // log whose x2 lags: the rigid fit's intervals not formed, and its
        // contact extension collapsing to a step) is tried with the lags
        // as an inadequate one is: kept where the lagged law is adequate.
        let retry = !decided
            && match &first {
                Ok(o) => {
                    !o.adequacy.adequate
                        || o.adequacy.structure.iter().any(|s| s.follows_the_motion())
                }
                Err(_) => true,
            };
        if retry && lags_apply {
            let from = lagged_starts(first.as_ref().ok());
            let o2 = match tried {
                Some((f, Tried::Finished(o2))) if f == from => o2,
                Some((f, Tried::Core(r2, p2))) if f == from => Ok(r2.finish(p2)),
                _ => run_lagged(&from),
            };
            if let Ok(o2) = o2 {
                // The BIC difference (n_eff·ln S + k·ln n_eff, two more
                // parameters, the lag-free fit's n_eff) and whether the
                // lags explain the signature they were fitted for: the
                // largest significant structure against velocity or drive
                // phase shrinks. An adequate law keeps lags only where
                // both hold. (On slow-sliding logs without any delay a
                // non-periodic x1 misfit — as strong against time as
                // against velocity — was read as x1 lagging by −1.5 to
                // −3 ms: BIC 15–61 lower, the structures as large or
                // larger, Rd −3 to −5.5 % with intervals that missed.)
                let against = first.as_ref().ok().map(|o| {
                    let n = o.n_eff.max(2.0);
                    let k = |f: &output_error::FamilyFit| f.law.kind.family().params().len() as f64;
                    let delta_bic = n * (o2.chosen.cost / o.chosen.cost).ln()
                        + (k(&o2.chosen) + 2.0 - k(&o.chosen)) * n.ln();
                    let explains = output_error::motion_structure(&o2.adequacy.structure)
                        < output_error::motion_structure(&o.adequacy.structure);
                    (o.adequacy.adequate, delta_bic, explains)
                });
                let keep = o2.adequacy.adequate
                    && match against {
                        None | Some((false, ..)) => true,
                        Some((true, delta_bic, explains)) => {
                            delta_bic < -LAG_EVIDENCE_BIC && explains
                        }
                    };
                if keep {
                    let delta_bic = against.filter(|a| a.0).map(|(_, delta_bic, _)| -delta_bic);
                    warnings.push(position_delays(&o2, delta_bic));
                    first = Ok(o2);
                }
            }
        }
        match first {
            Ok(o) => output_error = Some(o),
            Err(e) => warnings.push(Warning::RefinementFailed {
                reason: e.to_string(),
            }),
        }
    }
    // The evidence decides stick or no stick: the simulated law sticks
    // where the segmentation saw none (short sticks at reversal).
    let mut no_stick = ef.never_sticks;
    if let Some(o) = output_error
        .as_ref()
        .filter(|o| ef.never_sticks && o.sticks_found)
    {
        let c = &o.chosen;
        // Behind a contact spring M2 rings after every slip: the velocity
        // cannot show sticks (the contact warning says what was measured).
        let contact = c.ext.contact;
        let per_run = c.stick_fraction * o.samples as f64 / c.stick_runs.max(1) as f64
            * opts.oe.stride as f64
            * base.contact.dt;
        if !contact {
            warnings.push(Warning::ShortSticks {
                law: c.law.kind,
                stick_fraction: c.stick_fraction,
                stick_runs: c.stick_runs,
                run_s: per_run,
            });
        }
        no_stick = false;
        warnings.retain(|w| *w != Warning::NeverSticks);
        // The reversal bound assumed no stick there: it does not hold.
        ef.rs_upper_bound_n = None;
    }
    (output_error, no_stick)
}

/// Identifiability of the threshold: a family the data hardly tell from
/// the chosen one (ΔBIC below 10) that puts Rs outside its interval widens
/// the interval to hold it (the union), with a warning; so does a Stribeck
/// drop the log does not resolve (the lowest Rs its profile in v_s
/// admits). Returns the intervals and, where Rs's was widened, the chosen
/// law's own (Rs, ρs) intervals.
fn threshold_identifiability(
    o: &output_error::OutputErrorFit,
    used: Intervals,
    no_stick: bool,
    warnings: &mut Vec<Warning>,
) -> (Intervals, Option<(Interval, Option<Interval>)>) {
    let mut widened = None;
    let mut used = used;
    if let (false, Some(iv)) = (no_stick, used.rs_n) {
        let (mut lo, mut hi) = iv;
        for f in o
            .families
            .iter()
            .filter(|f| f.law.kind != o.chosen.law.kind)
        {
            let d = f.bic - o.chosen.bic;
            let rs = f.law.rs_n;
            if d < THRESHOLD_EVIDENCE_BIC && rs.is_finite() && !(lo..=hi).contains(&rs) {
                warnings.push(Warning::ThresholdNotIdentified {
                    other: f.law.kind,
                    delta_bic: d,
                    other_rs_n: rs,
                    interval_n: iv,
                });
                lo = lo.min(rs);
                hi = hi.max(rs);
            }
        }
        // A Stribeck drop the log does not resolve: the lowest Rs
        // the profile in v_s admits, with its interval.
        if let Some(dp) = o.drop_profile {
            if let (Some(rs), Some((a, _)), Some(vs), Some(vmax), Some(d)) = (
                dp.rs_n,
                dp.rs_interval_n,
                dp.vs_m_per_s,
                dp.vs_admitted_m_per_s,
                dp.delta_bic,
            ) {
                if rs < iv.0 {
                    let low = a.min(rs).min(lo);
                    warnings.push(Warning::DropNotResolved {
                        vs_m_per_s: vs,
                        vs_admitted_m_per_s: vmax,
                        delta_bic: d,
                        other_rs_n: rs,
                        interval_n: iv,
                        low_n: low,
                    });
                    lo = low;
                }
            }
        }
        if (lo, hi) != iv && iv.0 > 0.0 && iv.1 > 0.0 {
            widened = Some((iv, used.rho_s));
            used.rs_n = Some((lo, hi));
            used.rho_s = used.rho_s.map(|(l, h)| (l * lo / iv.0, h * hi / iv.1));
        }
    }
    (used, widened)
}

/// The normal force (the channel's median, else the rig's constant) and
/// the drive's η, with the warnings on a force that is negative or zero
/// and on a drive whose amplitude or frequency disagrees with the metadata.
fn force_and_drive_checks(
    run: &Run,
    base: &Characteristic,
    warnings: &mut Vec<Warning>,
) -> (f64, f64) {
    let normal_force_n = run
        .resampled
        .normal_force
        .as_ref()
        .map(|v| crate::stats::median(v))
        .filter(|v| v.is_finite())
        .unwrap_or(run.rig.normal_force_n);
    if normal_force_n < 0.0 {
        warnings.push(Warning::NormalForceNegative { normal_force_n });
    } else if normal_force_n == 0.0 {
        warnings.push(Warning::NormalForceZero);
    }
    let eta = 2.0 * std::f64::consts::PI * base.contact.drive.frequency_hz / run.rig.omega_ref();
    let rel = base.contact.drive.amplitude_m / run.rig.drive_amplitude_m - 1.0;
    if rel.abs() > 0.005 {
        warnings.push(Warning::DriveAmplitude {
            measured_m: base.contact.drive.amplitude_m,
            nominal_m: run.rig.drive_amplitude_m,
        });
    }
    if let Some(meta) = base.contact.drive.metadata_frequency_hz {
        let measured = base.contact.drive.frequency_hz;
        warnings.push(Warning::DriveFrequency {
            metadata_hz: meta,
            measured_hz: measured,
            tolerance: contact::DRIVE_FREQUENCY_TOLERANCE,
        });
    }
    (normal_force_n, eta)
}

/// The equation-error fit's 95 % intervals (each quantity's statistical
/// interval widened by its calibration part, `1.96·√var`; `fs` and `ss`
/// scale forces and slopes to ρ and D*), the reversal bound on Rs of a log
/// that never sticks (with its calibration part) and the lower bound on Rs.
fn equation_error_intervals(
    ef: &EquationFit,
    q0: &[f64; 8],
    var: &[f64; 8],
    fs: f64,
    ss: f64,
) -> (Intervals, Option<f64>, Option<f64>) {
    let cal = |k: usize| 1.96 * var[k].sqrt();
    let combine = |est: f64, stat: Option<(f64, f64)>, scale: f64, k: usize| -> Option<Interval> {
        if !est.is_finite() {
            return None;
        }
        let (lo, hi) = stat.map_or((0.0, 0.0), |(l, h)| {
            ((est - l / scale).max(0.0), (h / scale - est).max(0.0))
        });
        let c = cal(k);
        Some((est - lo.hypot(c), est + hi.hypot(c)))
    };
    let rd_iv = combine(q0[1], ef.stat.rd, 1.0, 1);
    let rho_d_iv = combine(q0[4], ef.stat.rd, fs, 4);
    // Never sticking: Rs ≥ Rd (its interval's low end), Rs ≤ the reversal bound.
    let ub = ef.rs_upper_bound_n.map(|b| b + cal(7));
    // An interval is never inverted: bounds that contradict each other
    // give none (and a contradiction, below).
    let bounds = |rd: Option<Interval>| match (rd, ub) {
        (Some((lo, _)), Some(ub)) if lo <= ub => Some((lo, ub)),
        _ => None,
    };
    let equation_error = Intervals {
        rs_n: if ef.never_sticks {
            bounds(rd_iv)
        } else {
            combine(q0[0], ef.stat.rs, 1.0, 0)
        },
        rd_n: rd_iv,
        slope_n_s_per_m: combine(q0[2], ef.stat.slope, 1.0, 2),
        rho_s: if ef.never_sticks {
            bounds(rd_iv).map(|(l, h)| (l / fs, h / fs))
        } else {
            combine(q0[3], ef.stat.rs, fs, 3)
        },
        rho_d: rho_d_iv,
        dstar: combine(q0[5], ef.stat.slope, ss, 5),
    };
    let rs_lower_bound_n = ef.rs_lower_bound_n.map(|lb| (lb - cal(6)).max(0.0));
    (equation_error, ub, rs_lower_bound_n)
}

/// The real-pad warnings of the output-error law `o` (a split threshold,
/// a side only bounded, a compliant contact); `k2` in N/m.
fn pad_warnings(o: &OutputErrorFit, k2: f64, warnings: &mut Vec<Warning>) {
    let iv = &o.intervals;
    let calibrated = o.pads.calibrated.filter(|c| c.resolved);
    if let Some(c) = calibrated {
        warnings.push(Warning::LevelsByDirection {
            zero_uncertainty_m: c.zero_uncertainty_m,
            rd_split_n: c.dynamic_split_n,
            interval_n: c.dynamic_split_interval_n.unwrap_or((f64::NAN, f64::NAN)),
            levels_n: [
                c.rs_plus_n,
                Some(c.rd_plus_n),
                c.rs_minus_n,
                Some(c.rd_minus_n),
            ],
        });
        // One side only bounded (M2 breaks away towards the other side
        // only), with the bounds of its own direction's levels; where
        // neither side is measured (a log that never sticks, a threshold
        // behind a contact) their own warnings say so.
        for (side, own, bounds_n, other) in [
            ('-', c.rs_minus_n, c.rs_minus_interval_n, c.rs_plus_n),
            ('+', c.rs_plus_n, c.rs_plus_interval_n, c.rs_minus_n),
        ] {
            if own.is_none() && other.is_some() && bounds_n.is_some() {
                warnings.push(Warning::DirectionBounded { side, bounds_n });
            }
        }
    } else if let (Some(split_n), Some(interval_n)) = (o.pads.split_n, o.pads.split_interval_n) {
        warnings.push(Warning::DirectionDependent {
            split_n,
            interval_n,
        });
    }
    if o.pads.minus_bounded && calibrated.is_none() {
        warnings.push(Warning::DirectionBounded {
            side: '-',
            bounds_n: o.pads.rs_minus_interval_n,
        });
    }
    if o.pads.plus_bounded && calibrated.is_none() {
        warnings.push(Warning::DirectionBounded {
            side: '+',
            bounds_n: iv.rs_n,
        });
    }
    if let (Some(kappa), Some(interval)) =
        (o.pads.contact_stiffness, o.pads.contact_stiffness_interval)
    {
        let kt = kappa * k2;
        warnings.push(Warning::ContactCompliance {
            kappa,
            interval,
            kt_n_per_m: kt,
            presliding_m: o.law.rs_n.max(o.pads.rs_minus_n.unwrap_or(0.0)) / kt,
            threshold_unresolved: o.pads.threshold_unresolved,
        });
    }
}

/// Fits the friction law of one characteristic log with 95 % intervals
/// (bootstrap over periods combined with the calibration budget).
///
/// It reads the run's common grid, rig metadata, gaps, warnings and
/// delays, never its channels as recorded ([`Run::channels`]), which
/// [`fit_logs`] therefore drops before fitting (test
/// `the_fit_does_not_read_the_recorded_channels`).
///
/// ```
/// use stickslip::identify::{fit_log, FitOptions, IdentifyOptions};
/// use stickslip::ingest::{read, IngestOptions};
/// let run = read("datasets/char_N4.mcap".as_ref(), &IngestOptions::default())?;
/// let opts = IdentifyOptions {
///     fit: FitOptions { bootstrap: 0, ..Default::default() },
///     ..Default::default()
/// };
/// let fit = fit_log(&run, &opts)?;
/// // A static-dynamic pad that sticks and slips: ρs measured, with an
/// // interval around it, and the law explains the positions.
/// assert!(!fit.stuck() && !fit.never_sticks());
/// let (rho_s, (lo, hi)) = (fit.rho_s().unwrap(), fit.rho_s_interval.unwrap());
/// assert!(lo <= rho_s && rho_s <= hi);
/// assert!(fit.rho_d().unwrap() <= rho_s);
/// # Ok::<(), stickslip::Error>(())
/// ```
///
/// Its stages: the characteristic and the equation-error fit, the
/// calibration budget (`calibration_variance`), the
/// output-error refinement (`refine`), the estimate used with its
/// contradictions and adequacy, and the log's scales and notes. It stays
/// ~200 lines because the intervals of both estimates share the budget's
/// closures with the contradiction checks.
///
/// The fit runs inside rayon's pool (the caller's, when called from one of
/// its threads; the global pool otherwise), so that the parallel loop over
/// segments inside each of the refinement's cost evaluations (hundreds per
/// log) is split on a pool thread instead of handing the work over to the
/// pool and waiting for it (a sleep and a wake-up each time): fitting
/// `char_N4.mcap` repeatedly for 3 s from outside the pool at one thread
/// (`benches/fit.rs`, criterion's profiling mode, strace) made 5059 futex
/// calls, 205 since. The result does not depend on where it runs.
pub fn fit_log(run: &Run, opts: &IdentifyOptions) -> Result<LogFit> {
    rayon::scope(|_| fit_log_in_pool(run, opts))
}

/// [`fit_log`]'s work, on a thread of the pool.
fn fit_log_in_pool(run: &Run, opts: &IdentifyOptions) -> Result<LogFit> {
    // Refused before any copy when the fit cannot stay within the budget.
    if run.samples() as u64 > crate::limits::MAX_FIT_SAMPLES {
        return Err(Error::Identify {
            path: run.source.clone(),
            source: IdentifyError::TooLong {
                samples: run.samples(),
                duration_s: run.duration_s(),
                rate_hz: run.resampled.rate_hz,
            },
        });
    }
    let base = characteristic(run, &Gains::default())?;
    let mut ef = fit::fit(&base.contact, &base.segmentation, &opts.fit).map_err(|source| {
        Error::Identify {
            path: run.source.clone(),
            source,
        }
    })?;
    let rig = &run.rig;
    let k2 = rig.k2_n_per_m;
    let ss = (rig.k2_n_per_m * rig.m2_kg).sqrt();
    let a = base.contact.drive.amplitude_m;
    let q0 = quantities(&ef, a, k2, ss);

    // Calibration budget: re-run with each sensor's gain at +u, same law.
    let u = opts.gain_uncertainty;
    let var = calibration_variance(run, &base, &ef, opts, &q0);
    let fs = a * k2;
    let (equation_error, ub, rs_lower_bound_n) = equation_error_intervals(&ef, &q0, &var, fs, ss);
    // An interval is never inverted: bounds that contradict each other
    // give none (and a contradiction, below).
    let bounds = |rd: Option<Interval>| match (rd, ub) {
        (Some((lo, _)), Some(ub)) if lo <= ub => Some((lo, ub)),
        _ => None,
    };

    let mut warnings = run.warnings.clone();
    warnings.extend(base.contact.warnings.iter().cloned());
    warnings.extend(ef.warnings.iter().cloned());

    let pad_screen = pads::PadScreen::of(&base.contact, &base.segmentation, &ef, rig);
    let hints = if opts.real_pads {
        pad_screen.hints()
    } else {
        Default::default()
    };
    let (mut output_error, no_stick) = refine(run, &base, &mut ef, opts, hints, &mut warnings);
    let mut contradictions = Vec::new();
    // The model's springs are linear: a coupling spring that is not makes
    // the fit inadequate whatever its residuals (the law absorbs it).
    let spring_screen = springs::SpringScreen::of(&run.resampled, rig);
    if let Some(s) = spring_screen.filter(|s| s.flagged) {
        contradictions.push(Warning::NonlinearSpring {
            change: s.stiffness_change,
            interval: s.interval,
            z: s.z,
            max_stretch_m: s.max_stretch_m,
        });
    }
    if let Some(o) = output_error.as_ref() {
        warnings.extend(o.notes.iter().cloned());
    }
    let mut law_threshold_interval = None;
    let (estimate, law, used) = match &mut output_error {
        Some(o) => {
            let iv = &o.intervals;
            let rs_bounds = bounds(iv.rd_n);
            if no_stick && rs_bounds.is_none() {
                if let (Some((lo, _)), Some(ub)) = (iv.rd_n, ub) {
                    contradictions.push(Warning::BoundsContradict {
                        upper_n: ub,
                        lower_n: lo,
                        output_error: true,
                    });
                }
            }
            let used = Intervals {
                rs_n: if no_stick { rs_bounds } else { iv.rs_n },
                rd_n: iv.rd_n,
                slope_n_s_per_m: iv.slope_n_s_per_m,
                rho_s: if no_stick {
                    rs_bounds.map(|(l, h)| (l / fs, h / fs))
                } else {
                    iv.rho_s
                },
                rho_d: iv.rho_d,
                dstar: iv.dstar,
            };
            let (used, widened) = threshold_identifiability(o, used, no_stick, &mut warnings);
            law_threshold_interval = widened;
            pad_warnings(o, k2, &mut warnings);
            if o.law.kind != ef.law.kind {
                warnings.push(Warning::LawChanged {
                    output_error: o.law.kind,
                    equation_error: ef.law.kind,
                });
            }
            let used = used.levels_nonnegative();
            o.intervals = used;
            (Estimate::OutputError, o.law, used)
        }
        None => (
            Estimate::EquationError,
            ef.law,
            equation_error.levels_nonnegative(),
        ),
    };
    if estimate == Estimate::EquationError
        && ef.never_sticks
        && bounds(equation_error.rd_n).is_none()
    {
        if let (Some((lo, _)), Some(ub)) = (equation_error.rd_n, ub) {
            contradictions.push(Warning::BoundsContradict {
                upper_n: ub,
                lower_n: lo,
                output_error: false,
            });
        }
    }
    let adequacy = match (&output_error, estimate) {
        (Some(o), Estimate::OutputError) => Some(o.adequacy.clone()),
        _ => None,
    };
    let untested = adequacy.is_none() && !ef.stuck;
    if untested {
        warnings.push(Warning::Untested { law: law.kind });
    }
    if let Some(a) = adequacy.as_ref().filter(|a| !a.adequate) {
        warnings.push(inadequacy_warning(law.kind, a));
    }
    warnings.extend(contradictions.iter().cloned());

    let measured = if ef.stuck {
        // The fit returns a lower bound for every stuck log.
        let lb = rs_lower_bound_n.unwrap_or(0.0);
        Measured::Stuck {
            kind: law.kind,
            rs_lower_bound_n: lb,
            rho_s_lower_bound: lb / fs,
        }
    } else if no_stick {
        Measured::NeverSticks(SiLaw {
            rs_n: law.rd_n,
            ..law
        })
    } else {
        Measured::StickSlip(law)
    };
    let (normal_force_n, eta) = force_and_drive_checks(run, &base, &mut warnings);
    let mut notes = characteristic_notes(&base, &ef);
    // A forced law the equation error could not fit but the output error
    // refined (from the simple families' optima): it was fitted.
    if let (Some(k), Estimate::OutputError) = (opts.fit.law, estimate) {
        let not_fitted = Warning::LawNotFitted { law: k };
        if law.kind == k && warnings.contains(&not_fitted) {
            warnings.retain(|w| *w != not_fitted);
            notes.push(format!(
                "law {}: no equation-error fit; refined by output error from the simple families' optima",
                k.as_str()
            ));
        }
    }
    Ok(LogFit {
        normal_force_n,
        eta,
        force_scale_n: fs,
        slope_scale: ss,
        velocity_scale_m_per_s: a * rig.omega_ref(),
        rs_interval_n: used.rs_n,
        law_threshold_interval,
        rd_interval_n: used.rd_n,
        slope_interval_n_s_per_m: used.slope_n_s_per_m,
        rho_s_interval: used.rho_s,
        rho_d_interval: used.rho_d,
        dstar_interval: used.dstar,
        equation_error,
        output_error,
        estimate,
        measured,
        gain_uncertainty: u,
        drive: base.contact.drive,
        notes,
        warnings,
        channel_delays: run.delays.clone(),
        adequacy,
        contradictions,
        untested,
        fit: ef,
        pad_screen,
        spring_screen,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ingest::{IngestOptions, Quantity};

    /// Levels' intervals are cut at zero; the slope's keeps its sign.
    #[test]
    fn levels_are_never_negative() {
        let iv = Intervals {
            rs_n: Some((-0.87, 0.99)),
            rd_n: Some((-0.2, -0.1)),
            slope_n_s_per_m: Some((-3.0, -1.0)),
            rho_s: Some((-0.4, 0.5)),
            rho_d: Some((0.1, 0.2)),
            dstar: Some((-0.5, 0.1)),
        }
        .levels_nonnegative();
        assert_eq!(iv.rs_n, Some((0.0, 0.99)));
        assert_eq!(iv.rd_n, Some((0.0, 0.0)));
        assert_eq!(iv.slope_n_s_per_m, Some((-3.0, -1.0)));
        assert_eq!(iv.rho_s, Some((0.0, 0.5)));
        assert_eq!(iv.rho_d, Some((0.1, 0.2)));
        assert_eq!(iv.dstar, Some((-0.5, 0.1)));
    }

    /// The calibration re-fit of one family gives what the full fit with
    /// that law forced reports, bit for bit: every family on a log that
    /// sticks, one that never sticks (N1.2: the reversal bound), a stuck
    /// one (N30) and a Stribeck pad, with and without perturbed gains.
    #[test]
    fn forced_refit_matches_full_fit() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("datasets");
        let kinds = [
            LawKind::Coulomb,
            LawKind::Decreasing,
            LawKind::StaticDynamic,
            LawKind::Stribeck,
        ];
        let mut compared = 0;
        for name in [
            "char_N4.mcap",
            "char_N1.2.mcap",
            "char_N30.mcap",
            "law_stribeck.mcap",
        ] {
            let run = crate::ingest::read(&dir.join(name), &IngestOptions::default()).unwrap();
            for g in [
                Gains::default(),
                Gains {
                    x2: 1.01,
                    ..Gains::default()
                },
            ] {
                let ch = characteristic(&run, &g).unwrap();
                let (c, seg) = (&ch.contact, &ch.segmentation);
                for kind in kinds {
                    let opts = FitOptions {
                        law: Some(kind),
                        bootstrap: 0,
                        seed: 7,
                    };
                    let full = fit::fit(c, seg, &opts);
                    let forced = fit::fit_forced(c, seg, kind, 7);
                    match (full, forced) {
                        (Ok(f), Ok(r)) => {
                            let a = quantities(&f, 1e-3, 100.0, 2.0);
                            let b = quantities_of(&r, 1e-3, 100.0, 2.0);
                            assert_eq!(format!("{a:?}"), format!("{b:?}"), "{name} {kind:?}");
                            assert_eq!(f.law.kind, r.law.kind, "{name} {kind:?}");
                            compared += 1;
                        }
                        (Err(_), Err(_)) => {}
                        (f, r) => panic!("{name} {kind:?}: {:?} vs {:?}", f.is_ok(), r.is_ok()),
                    }
                }
            }
        }
        assert!(compared >= 28, "{compared}");
    }

    /// A fit's JSON without its wall times (keys holding "seconds") and
    /// the keys `also`.
    fn fit_json(f: &LogFit, also: &[&str]) -> String {
        fn strip(v: &mut serde_json::Value, also: &[&str]) {
            match v {
                serde_json::Value::Object(m) => {
                    m.retain(|k, _| !k.contains("seconds") && !also.contains(&k.as_str()));
                    m.values_mut().for_each(|v| strip(v, also));
                }
                serde_json::Value::Array(a) => a.iter_mut().for_each(|v| strip(v, also)),
                _ => {}
            }
        }
        let mut v = serde_json::to_value(f).unwrap();
        strip(&mut v, also);
        v.to_string()
    }

    /// A refined family's projection computed again where it is used (as
    /// on long logs) gives the fit of the projection kept (as on short
    /// ones), bit for bit, but for the evaluations the computing takes.
    /// char_N4 (sticks) and law_stribeck (the numerical engine, the
    /// Stribeck family refined).
    #[test]
    fn projections_computed_again_give_the_kept_ones_fit() {
        for log in ["char_N4.mcap", "law_stribeck.mcap"] {
            let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("datasets")
                .join(log);
            let run = crate::ingest::read(&path, &IngestOptions::default()).unwrap();
            let fit = |keep: usize| {
                let opts = IdentifyOptions {
                    fit: FitOptions {
                        bootstrap: 0,
                        ..Default::default()
                    },
                    oe: output_error::OeOptions {
                        keep_projection_values: keep,
                        ..Default::default()
                    },
                    ..Default::default()
                };
                let f = fit_log(&run, &opts).unwrap();
                let evals = f.output_error.as_ref().expect("refined").evaluations;
                (fit_json(&f, &["evaluations"]), evals)
            };
            let (kept, kept_evals) = fit(usize::MAX);
            let (again, again_evals) = fit(0);
            assert_eq!(kept, again, "{log}");
            assert!(
                again_evals > kept_evals,
                "{log}: {again_evals} {kept_evals}"
            );
        }
    }

    /// [`fit_log`] moves its work onto a pool thread when called from
    /// outside rayon's pool (as a library user's main thread does): the
    /// same fit from there as from inside a one-thread and a two-thread
    /// pool of the caller's.
    #[test]
    fn the_fit_is_the_same_from_outside_and_inside_a_pool() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("datasets/char_N2.2.mcap");
        let run = crate::ingest::read(&path, &IngestOptions::default()).unwrap();
        let opts = IdentifyOptions {
            fit: FitOptions {
                bootstrap: 0,
                ..Default::default()
            },
            ..Default::default()
        };
        let json = |f: LogFit| fit_json(&f, &[]);
        assert!(rayon::current_thread_index().is_none());
        let outside = json(fit_log(&run, &opts).unwrap());
        for threads in [1, 2] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let inside = pool.install(|| json(fit_log(&run, &opts).unwrap()));
            assert_eq!(outside, inside, "{threads} threads");
        }
    }

    /// [`fit_logs`] drops the channels as recorded before fitting: the
    /// fit must not read them (the same result, bit for bit, without them).
    #[test]
    fn the_fit_does_not_read_the_recorded_channels() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("datasets/char_N4.mcap");
        let full = crate::ingest::read(&path, &IngestOptions::default()).unwrap();
        let mut bare = full.clone();
        bare.channels = Vec::new();
        let opts = IdentifyOptions {
            fit: FitOptions {
                bootstrap: 0,
                ..Default::default()
            },
            ..Default::default()
        };
        let a = fit_log(&full, &opts).unwrap();
        let b = fit_log(&bare, &opts).unwrap();
        assert_eq!(fit_json(&a, &[]), fit_json(&b, &[]));
    }

    /// The calibration budget's re-computations reuse the base's stages
    /// and give the plain computation's characteristic bit for bit: every
    /// single-gain perturbation and a double one, with an accelerometer,
    /// without one, and without a velocity channel (the Debug form prints
    /// every f64 so that distinct values print differently).
    #[test]
    fn reusing_characteristic_is_bit_identical() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("datasets/char_N4.mcap");
        let full = crate::ingest::read(&path, &IngestOptions::default()).unwrap();
        let mut no_acc = full.clone();
        no_acc.has_acceleration = false;
        no_acc.resampled.a2 = None;
        let mut no_vel = no_acc.clone();
        no_vel.channels.retain(|c| c.quantity != Quantity::V2);
        no_vel.resampled.v2 = vec![f64::NAN; no_vel.resampled.v2.len()];
        assert!(full.has_acceleration && !no_vel.has_velocity());
        let u = 1.01;
        let one = Gains::default();
        let gains = [
            Gains { x0: u, ..one },
            Gains { x1: u, ..one },
            Gains { x2: u, ..one },
            Gains { v2: u, ..one },
            Gains { a2: u, ..one },
            Gains {
                x1: u,
                a2: u,
                ..one
            },
            one,
        ];
        for run in [&full, &no_acc, &no_vel] {
            let base = characteristic(run, &one).unwrap();
            for g in &gains {
                let plain = characteristic(run, g).unwrap();
                let reused = characteristic_reusing(run, g, Some((&one, &base))).unwrap();
                assert_eq!(
                    format!("{:?}", plain.contact),
                    format!("{:?}", reused.contact),
                    "{g:?}"
                );
                assert_eq!(
                    format!("{:?}", plain.segmentation),
                    format!("{:?}", reused.segmentation),
                    "{g:?}"
                );
            }
        }
    }
}
