//! The JSON entry of one fitted log (one element of `fits` in `stickslip
//! fit --json`, and the `fit` object of `validate`/`run`). Interface keys
//! (`interface.md`) are those of the estimate used (`estimate`:
//! `output-error` or `equation-error`, [`LogFit::estimate`]); both
//! estimates are kept in full under `equation_error` and `output_error`
//! (null where not computed), each with its law, intervals and
//! diagnostics. `residual_rms` (an interface key) and the top-level
//! `criteria` stay those of the equation-error fit (the scatter of the
//! characteristic R(ẋ2) about the law); the output-error residuals are
//! `output_error.rms_x1_m`, `rms_x2_m` and its criteria
//! `output_error.criteria`. `bias_n` is the estimate used's.
//!
//! `adequate` (interface key, [`LogFit::adequate`]) with its numbers under
//! `adequacy` (residual/noise ratios of x1, x2, the structure tests, the
//! interval inflation; null where only the equation-error estimate was
//! computed), `contradictions` (bounds that contradict each other) and
//! `law_evidence` (the BIC difference to the best other family and its
//! Kass–Raftery grade).

use super::output_error::Adequacy;
use super::{Estimate, Intervals, LogFit, SiLaw};
use crate::io::json::Interval as Iv;
use serde::Serialize;
use serde_json::Value;
use std::path::Path;

/// A law in SI and dimensionless with the log's scales (non-finite: null).
#[derive(Debug, Clone, Serialize)]
pub struct LawJson {
    /// The family ([`crate::model::LawKind::as_str`]).
    pub law: &'static str,
    /// Static threshold ρs.
    pub rho_s: f64,
    /// Dynamic level ρd.
    pub rho_d: f64,
    /// Slope D* of the characteristic.
    pub slope: f64,
    /// Velocity scale v_s (dimensionless) of a family that has one.
    pub v_s: Option<f64>,
    /// Static friction force Rs (N).
    pub r_s_n: f64,
    /// Dynamic friction force Rd (N).
    pub r_d_n: f64,
    /// Slope a of the characteristic (N s/m).
    pub slope_n_s_per_m: f64,
    /// Velocity scale v_s (m/s) of a family that has one.
    pub v_s_m_per_s: Option<f64>,
}

/// A law with its 95 % intervals.
#[derive(Debug, Clone, Serialize)]
pub struct EstimateJson {
    /// The law (its keys, flattened).
    #[serde(flatten)]
    pub law: LawJson,
    /// Interval of ρs.
    pub rho_s_interval: Iv,
    /// Interval of ρd.
    pub rho_d_interval: Iv,
    /// Interval of D*.
    pub slope_interval: Iv,
    /// Interval of Rs (N).
    pub r_s_interval_n: Iv,
    /// Interval of Rd (N).
    pub r_d_interval_n: Iv,
    /// Interval of the slope (N s/m).
    pub slope_interval_n_s_per_m: Iv,
}

/// One family's information criterion.
#[derive(Debug, Clone, Serialize)]
pub struct CriterionJson {
    /// The family.
    pub law: &'static str,
    /// Its BIC.
    pub bic: f64,
}

/// The equation-error estimate.
#[derive(Debug, Clone, Serialize)]
pub struct EquationErrorJson {
    /// The law with its intervals (flattened).
    #[serde(flatten)]
    pub estimate: EstimateJson,
    /// RMS of the characteristic R(ẋ2) about the law (N).
    pub residual_rms_n: f64,
    /// Force bias (N).
    pub bias_n: f64,
    /// Every family's criterion.
    pub criteria: Vec<CriterionJson>,
}

/// One family of the output-error refinement.
#[derive(Debug, Clone, Serialize)]
pub struct FamilyJson {
    /// The family.
    pub law: &'static str,
    /// Its BIC.
    pub bic: f64,
    /// Fraction of the time M2 sticks in the simulation.
    pub stick_fraction: f64,
    /// Stick phases in the simulation.
    pub stick_phases: usize,
    /// RMS residual of x1 (m).
    pub rms_x1_m: f64,
    /// RMS residual of x2 (m).
    pub rms_x2_m: f64,
    /// Whether the levels split by sliding direction.
    pub direction_dependent: bool,
    /// Contact stiffness κ, where fitted.
    pub contact_stiffness: Option<f64>,
    /// Static friction force Rs (N).
    pub r_s_n: f64,
    /// Dynamic friction force Rd (N).
    pub r_d_n: f64,
    /// Static threshold towards − (N), where split.
    pub r_s_minus_n: Option<f64>,
    /// Slope a of the characteristic (N s/m).
    pub slope_n_s_per_m: f64,
    /// Simulated breakaways towards + and towards −.
    pub breakaways: (usize, usize),
    /// Upper bounds (N) on the thresholds towards + and − from simulated
    /// reversals without stick.
    pub reversal_bound_n: (Option<f64>, Option<f64>),
}

/// The output-error estimate.
#[derive(Debug, Clone, Serialize)]
pub struct OutputErrorJson {
    /// The law with its intervals (flattened).
    #[serde(flatten)]
    pub estimate: EstimateJson,
    /// RMS residual of x1 (m).
    pub rms_x1_m: f64,
    /// RMS residual of x2 (m).
    pub rms_x2_m: f64,
    /// RMS residual of x1 at the start (m).
    pub start_rms_x1_m: f64,
    /// RMS residual of x2 at the start (m).
    pub start_rms_x2_m: f64,
    /// Force bias (N).
    pub bias_n: f64,
    /// Gains of x1 and x2 relative to the drive channel.
    pub gains: (f64, f64),
    /// Lags (s) of x1 and x2 behind the drive, fitted with the law
    /// (`null` where they were not fitted).
    pub position_delays_s: Option<(f64, f64)>,
    /// Their 95 % intervals (s).
    pub position_delays_interval_s: Option<((f64, f64), (f64, f64))>,
    /// Minimiser iterations of the chosen family.
    pub iterations: u64,
    /// Cost evaluations over all families (simulations of the log).
    pub evaluations: usize,
    /// Shooting segments.
    pub segments: usize,
    /// Residual samples compared (per channel).
    pub samples: usize,
    /// Effective number of independent samples in the criterion.
    pub effective_samples: f64,
    /// The largest ratio (either way) of a statistical width from the
    /// residuals' secants over the chosen law's intervals to the
    /// tangent's: 1 on a smooth cost; from 1.25 on the intervals are the
    /// widest of the tangent's and the secants' (warning `rough_cost`).
    pub interval_secant_ratio: f64,
    /// How the drive was simulated (`harmonic` or `sampled`).
    pub drive: &'static str,
    /// Wall seconds of the refinement.
    pub seconds: f64,
    /// Every family's fit.
    pub criteria: Vec<FamilyJson>,
    /// The chosen static/dynamic law's profile against an unresolved
    /// Stribeck drop (`null` for other laws).
    pub drop_profile: Option<super::output_error::DropProfile>,
}

/// One structure test of the residuals.
#[derive(Debug, Clone, Serialize)]
pub struct StructureJson {
    /// The channel tested.
    pub channel: &'static str,
    /// What its residuals are tested against.
    pub against: &'static str,
    /// χ² per degree of freedom.
    pub chi2_per_dof: f64,
    /// Its z score.
    pub z: f64,
    /// The effect's size.
    pub effect: f64,
}

/// The adequacy verdict's numbers.
#[derive(Debug, Clone, Serialize)]
pub struct AdequacyJson {
    /// Residual/noise ratio of x1.
    pub noise_ratio_x1: f64,
    /// Residual/noise ratio of x2.
    pub noise_ratio_x2: f64,
    /// Robust residual/noise ratio of x1.
    pub robust_ratio_x1: f64,
    /// Robust residual/noise ratio of x2.
    pub robust_ratio_x2: f64,
    /// Residual/noise ratio of the force, where measured.
    pub noise_ratio_force: Option<f64>,
    /// Robust residual/noise ratio of the force, where measured.
    pub robust_ratio_force: Option<f64>,
    /// The largest ratio still adequate.
    pub max_noise_ratio: f64,
    /// The largest structure z still adequate.
    pub max_structure_z: f64,
    /// The largest structure effect still adequate.
    pub max_structure_effect: f64,
    /// Factor applied to the statistical half-widths.
    pub interval_inflation: f64,
    /// The structure tests.
    pub structure: Vec<StructureJson>,
}

impl AdequacyJson {
    fn of(a: &Adequacy) -> Self {
        Self {
            noise_ratio_x1: a.noise_ratio.0,
            noise_ratio_x2: a.noise_ratio.1,
            robust_ratio_x1: a.robust_ratio.0,
            robust_ratio_x2: a.robust_ratio.1,
            noise_ratio_force: a.force_ratio,
            robust_ratio_force: a.robust_force_ratio,
            max_noise_ratio: super::output_error::MAX_NOISE_RATIO,
            max_structure_z: super::output_error::MAX_STRUCTURE_Z,
            max_structure_effect: super::output_error::MAX_STRUCTURE_EFFECT,
            interval_inflation: a.inflation,
            structure: a
                .structure
                .iter()
                .map(|s| StructureJson {
                    channel: s.channel,
                    against: s.against,
                    chi2_per_dof: s.chi2_per_dof,
                    z: s.z,
                    effect: s.effect,
                })
                .collect(),
        }
    }
}

/// The evidence for the family chosen.
#[derive(Debug, Clone, Serialize)]
pub struct EvidenceJson {
    /// The best other family.
    pub against: &'static str,
    /// Its BIC difference to the chosen one.
    pub delta_bic: f64,
    /// The Kass–Raftery grade of the difference.
    pub strength: &'static str,
}

/// One fitted log: the keys of a `fits` entry ([`LogFit::json`]; the
/// module doc says which estimate the interface keys are).
#[derive(Debug, Clone, Serialize)]
pub struct LogFitJson {
    /// The log as named.
    pub log: String,
    /// The family of the law used.
    pub law: &'static str,
    /// Static threshold ρs (null: only bounded).
    pub rho_s: Option<f64>,
    /// Dynamic level ρd.
    pub rho_d: Option<f64>,
    /// Slope D*.
    pub slope: Option<f64>,
    /// Interval of ρs.
    pub rho_s_interval: Iv,
    /// Interval of ρd.
    pub rho_d_interval: Iv,
    /// Interval of D*.
    pub slope_interval: Iv,
    /// Static friction force Rs (N).
    pub r_s_n: Option<f64>,
    /// Dynamic friction force Rd (N).
    pub r_d_n: Option<f64>,
    /// Slope a (N s/m).
    pub slope_n_s_per_m: Option<f64>,
    /// Interval of Rs (N).
    pub r_s_interval_n: Iv,
    /// Interval of Rd (N).
    pub r_d_interval_n: Iv,
    /// Interval of the slope (N s/m).
    pub slope_interval_n_s_per_m: Iv,
    /// Measured normal force (N).
    pub normal_force_n: f64,
    /// Drive frequency ratio η.
    pub eta: f64,
    /// Drive frequency (Hz).
    pub drive_frequency_hz: f64,
    /// M2 never slid.
    pub stuck: bool,
    /// Lower bound on ρs of a stuck log.
    pub rho_s_lower_bound: Option<f64>,
    /// Lower bound on Rs (N) of a stuck log.
    pub r_s_lower_bound_n: Option<f64>,
    /// M2 never stuck (Rs only bounded).
    pub never_sticks: bool,
    /// The adequacy verdict ([`LogFit::adequate`]).
    pub adequate: bool,
    /// Its numbers (null: only the equation-error estimate).
    pub adequacy: Option<AdequacyJson>,
    /// Bounds that contradict each other.
    pub contradictions: Vec<crate::warning::Warning>,
    /// The evidence for the family chosen.
    pub law_evidence: Option<EvidenceJson>,
    /// Measured drive amplitude (m).
    pub drive_amplitude_m: f64,
    /// RMS of the characteristic about the equation-error law (ρ units).
    pub residual_rms: f64,
    /// The same in N.
    pub residual_rms_n: f64,
    /// The warnings, as messages.
    #[serde(serialize_with = "crate::warning::as_messages")]
    pub warnings: Vec<crate::warning::Warning>,
    /// One stable code per warning (`crate::warning::Warning::code`).
    pub warning_codes: Vec<&'static str>,
    /// The Stribeck law where it is the estimate, else the equation-error
    /// Stribeck fit where one was made.
    pub stribeck: Option<LawJson>,
    /// The best simple-family law where the Stribeck type was chosen.
    pub simple_law: Option<LawJson>,
    /// The equation-error criteria.
    pub criteria: Vec<CriterionJson>,
    /// The estimate used (`output-error` or `equation-error`).
    pub estimate: &'static str,
    /// The equation-error estimate (null for a stuck log).
    pub equation_error: Option<EquationErrorJson>,
    /// The output-error estimate (null where not computed).
    pub output_error: Option<OutputErrorJson>,
    /// Relative gain uncertainty of each sensor.
    pub gain_uncertainty: f64,
    /// Force bias of the estimate used (N).
    pub bias_n: f64,
    /// Slip samples used by the equation-error fit.
    pub slip_samples: usize,
    /// Their effective number.
    pub effective_samples: f64,
    /// Breakaways used by the equation-error fit.
    pub breakaways: usize,
    /// Characteristic details (noise, lags, offsets).
    pub notes: Vec<String>,
    /// Channel delays (s), by channel.
    pub channel_delays_s: Value,
    /// Their intervals (s), by channel.
    pub channel_delays_interval_s: Value,
    /// The velocity channel's consistency with the positions.
    pub velocity_consistency: Value,
    /// The acceleration channel's consistency with the positions.
    pub acceleration_consistency: Value,
    /// Whether the levels split by sliding direction.
    pub direction_dependent: bool,
    /// ρs towards −, where split.
    pub rho_s_minus: Option<f64>,
    /// ρd towards −, where split.
    pub rho_d_minus: Option<f64>,
    /// Rs towards − (N), where split.
    pub r_s_minus_n: Option<f64>,
    /// Rd towards − (N), where split.
    pub r_d_minus_n: Option<f64>,
    /// Interval of ρs towards −.
    pub rho_s_minus_interval: Iv,
    /// Interval of ρd towards −.
    pub rho_d_minus_interval: Iv,
    /// Interval of Rs towards − (N).
    pub r_s_minus_interval_n: Iv,
    /// Interval of Rd towards − (N).
    pub r_d_minus_interval_n: Iv,
    /// Rs⁺ − Rs⁻ (N) with equal dynamic levels: what the log identifies of
    /// the direction dependence (see the warning `direction_dependent`).
    pub direction_split_n: Option<f64>,
    /// Its interval (N).
    pub direction_split_interval_n: Iv,
    /// Contact stiffness κ = kt/K2, where fitted.
    pub contact_stiffness: Option<f64>,
    /// Its interval.
    pub contact_stiffness_interval: Iv,
    /// Tangential contact stiffness kt (N/m).
    pub kt_n_per_m: Option<f64>,
    /// Its interval (N/m).
    pub kt_interval_n_per_m: Iv,
    /// One-sided 95 % lower bound on κ where the contact was taken as
    /// rigid.
    pub contact_stiffness_lower_bound: Option<f64>,
    /// The pad screen.
    pub pad_screen: super::pads::PadScreen,
    /// The coupling spring's screen.
    pub spring_screen: Option<super::springs::SpringScreen>,
    /// How the levels of the two directions are fixed: `"equal dynamic
    /// levels"` (a split threshold with unknown zeros), `"calibrated
    /// zeros"` (every level of each direction), null (symmetric).
    pub levels_gauge: Option<&'static str>,
    /// The levels of each direction where the log declares calibrated
    /// position zeros, resolved or not (null: zeros unknown).
    pub levels_by_direction: Option<super::output_error::CalibratedLevels>,
}

impl LogFit {
    /// A law in SI and dimensionless with this log's scales.
    fn law_out(&self, l: &SiLaw) -> LawJson {
        let fs = self.force_scale_n;
        let vel = self.velocity_scale_m_per_s;
        LawJson {
            law: l.kind.as_str(),
            rho_s: l.rs_n / fs,
            rho_d: l.rd_n / fs,
            slope: l.slope_n_s_per_m / self.slope_scale,
            v_s: l.vs_m_per_s.map(|v| v / vel),
            r_s_n: l.rs_n,
            r_d_n: l.rd_n,
            slope_n_s_per_m: l.slope_n_s_per_m,
            v_s_m_per_s: l.vs_m_per_s,
        }
    }

    /// A law with its intervals (Rs null where only bounded).
    fn estimate_out(&self, l: &SiLaw, iv: &Intervals) -> EstimateJson {
        let mut l = *l;
        if self.never_sticks() {
            l.rs_n = f64::NAN;
        }
        EstimateJson {
            law: self.law_out(&l),
            rho_s_interval: Iv(iv.rho_s),
            rho_d_interval: Iv(iv.rho_d),
            slope_interval: Iv(iv.dstar),
            r_s_interval_n: Iv(iv.rs_n),
            r_d_interval_n: Iv(iv.rd_n),
            slope_interval_n_s_per_m: Iv(iv.slope_n_s_per_m),
        }
    }

    /// The JSON entry of this fit for `log` ([`LogFit::json`]) as a value.
    pub fn to_json(&self, log: &Path) -> Value {
        crate::io::json::to_value(self.json(log))
    }

    /// The JSON entry of this fit for `log` (interface keys plus details).
    pub fn json(&self, log: &Path) -> LogFitJson {
        let e = &self.fit;
        let law = self.law();
        let criteria = |c: &[(super::LawKind, f64)]| -> Vec<CriterionJson> {
            c.iter()
                .map(|(k, b)| CriterionJson {
                    law: k.as_str(),
                    bic: *b,
                })
                .collect()
        };
        let used_oe = self
            .output_error
            .as_ref()
            .filter(|_| self.estimate == Estimate::OutputError);
        let pads = self.pads();
        let split = pads.filter(|_| self.direction_dependent());
        let mut j = LogFitJson {
            log: log.display().to_string(),
            law: self.kind().as_str(),
            rho_s: self.rho_s(),
            rho_d: self.rho_d(),
            slope: self.dstar(),
            rho_s_interval: Iv(self.rho_s_interval),
            rho_d_interval: Iv(self.rho_d_interval),
            slope_interval: Iv(self.dstar_interval),
            r_s_n: self.rs_n(),
            r_d_n: law.map(|l| l.rd_n),
            slope_n_s_per_m: law.map(|l| l.slope_n_s_per_m),
            r_s_interval_n: Iv(self.rs_interval_n),
            r_d_interval_n: Iv(self.rd_interval_n),
            slope_interval_n_s_per_m: Iv(self.slope_interval_n_s_per_m),
            normal_force_n: self.normal_force_n,
            eta: self.eta,
            drive_frequency_hz: self.drive.frequency_hz,
            stuck: e.stuck,
            rho_s_lower_bound: self.rho_s_lower_bound(),
            r_s_lower_bound_n: self.rs_lower_bound_n(),
            never_sticks: self.never_sticks(),
            adequate: self.adequate(),
            adequacy: self.adequacy.as_ref().map(AdequacyJson::of),
            contradictions: self.contradictions.clone(),
            law_evidence: used_oe.and_then(|o| o.evidence).map(|ev| EvidenceJson {
                against: ev.against.as_str(),
                delta_bic: ev.delta_bic,
                strength: ev.strength(),
            }),
            drive_amplitude_m: self.drive.amplitude_m,
            residual_rms: e.residual_rms_n / self.force_scale_n,
            residual_rms_n: e.residual_rms_n,
            warnings: self.warnings.clone(),
            warning_codes: crate::warning::codes(&self.warnings),
            // The Stribeck law used when it is the estimate (its v_s is
            // nowhere else at the top level), else the equation-error
            // Stribeck fit when one was made.
            stribeck: law
                .as_ref()
                .filter(|l| l.kind == super::LawKind::Stribeck)
                .or(e.stribeck.as_ref())
                .map(|l| self.law_out(l)),
            simple_law: e.simple.as_ref().map(|l| self.law_out(l)),
            criteria: criteria(&e.criteria),
            estimate: self.estimate.as_str(),
            equation_error: (!e.stuck).then(|| EquationErrorJson {
                estimate: self.estimate_out(&e.law, &self.equation_error),
                residual_rms_n: e.residual_rms_n,
                bias_n: e.bias_n,
                criteria: criteria(&e.criteria),
            }),
            output_error: self.output_error.as_ref().map(|o| {
                let c = &o.chosen;
                OutputErrorJson {
                    estimate: self.estimate_out(&o.law, &o.intervals),
                    rms_x1_m: c.rms_m.0,
                    rms_x2_m: c.rms_m.1,
                    start_rms_x1_m: o.start_rms_m.0,
                    start_rms_x2_m: o.start_rms_m.1,
                    bias_n: c.bias_n,
                    gains: c.gains,
                    position_delays_s: o.position_delays.then_some(c.delays_s),
                    position_delays_interval_s: o.position_delays.then_some(c.delays_interval_s),
                    iterations: c.iterations,
                    evaluations: o.evaluations,
                    segments: o.segments,
                    samples: o.samples,
                    effective_samples: o.n_eff,
                    interval_secant_ratio: o.interval_secant_ratio,
                    drive: o.drive.as_str(),
                    seconds: o.seconds,
                    criteria: o
                        .families
                        .iter()
                        .map(|f| FamilyJson {
                            law: f.law.kind.as_str(),
                            bic: f.bic,
                            stick_fraction: f.stick_fraction,
                            stick_phases: f.stick_runs,
                            rms_x1_m: f.rms_m.0,
                            rms_x2_m: f.rms_m.1,
                            direction_dependent: f.ext.split,
                            contact_stiffness: f.contact_stiffness,
                            r_s_n: f.law.rs_n,
                            r_d_n: f.law.rd_n,
                            r_s_minus_n: f.rs_minus_n,
                            slope_n_s_per_m: f.law.slope_n_s_per_m,
                            breakaways: f.breakaways,
                            reversal_bound_n: f.reversal_bound_n,
                        })
                        .collect(),
                    drop_profile: o.drop_profile,
                }
            }),
            gain_uncertainty: self.gain_uncertainty,
            bias_n: match used_oe {
                Some(o) => o.chosen.bias_n,
                None => e.bias_n,
            },
            slip_samples: e.n_slip,
            effective_samples: e.n_eff,
            breakaways: e.n_breakaways,
            notes: self.notes.clone(),
            channel_delays_s: self.channel_delays.shifts_json(),
            channel_delays_interval_s: self.channel_delays.intervals_json(),
            velocity_consistency: self.channel_delays.velocity_json(),
            acceleration_consistency: self.channel_delays.acceleration_json(),
            direction_dependent: self.direction_dependent(),
            rho_s_minus: split.and_then(|p| p.rho_s_minus),
            rho_d_minus: split.and_then(|_| self.rho_d()),
            r_s_minus_n: split.and_then(|p| p.rs_minus_n),
            r_d_minus_n: split.and_then(|_| law.map(|l| l.rd_n)),
            rho_s_minus_interval: Iv(split.and_then(|p| p.rho_s_minus_interval)),
            rho_d_minus_interval: Iv(split.and(self.rho_d_interval)),
            r_s_minus_interval_n: Iv(split.and_then(|p| p.rs_minus_interval_n)),
            r_d_minus_interval_n: Iv(split.and(self.rd_interval_n)),
            direction_split_n: split.and_then(|p| p.split_n),
            direction_split_interval_n: Iv(split.and_then(|p| p.split_interval_n)),
            contact_stiffness: self.contact_stiffness_reported(),
            contact_stiffness_interval: Iv(pads.and_then(|p| p.contact_stiffness_interval)),
            kt_n_per_m: self
                .contact_stiffness_reported()
                .map(|k| k * self.k2_n_per_m()),
            kt_interval_n_per_m: Iv(pads
                .and_then(|p| p.contact_stiffness_interval)
                .map(|(l, h)| (l * self.k2_n_per_m(), h * self.k2_n_per_m()))),
            contact_stiffness_lower_bound: self.contact_stiffness_lower_bound(),
            pad_screen: self.pad_screen,
            spring_screen: self.spring_screen,
            levels_gauge: split.map(|_| "equal dynamic levels"),
            levels_by_direction: pads.and_then(|p| p.calibrated),
        };
        // Calibrated zeros that resolve the levels' difference between the
        // directions: the interface keys hold the levels of each direction
        // (the plain ones towards +), not the symmetric gauge's.
        if let Some(c) = pads.and_then(|p| p.calibrated).filter(|c| c.resolved) {
            j.direction_dependent = true;
            j.levels_gauge = Some("calibrated zeros");
            j.rho_s = c.rho[0];
            j.rho_d = c.rho[1];
            j.rho_s_interval = Iv(c.rho_intervals[0]);
            j.rho_d_interval = Iv(c.rho_intervals[1]);
            j.r_s_n = c.rs_plus_n;
            j.r_d_n = Some(c.rd_plus_n);
            j.r_s_interval_n = Iv(c.rs_plus_interval_n);
            j.r_d_interval_n = Iv(c.rd_plus_interval_n);
            j.rho_s_minus = c.rho[2];
            j.rho_d_minus = c.rho[3];
            j.rho_s_minus_interval = Iv(c.rho_intervals[2]);
            j.rho_d_minus_interval = Iv(c.rho_intervals[3]);
            j.r_s_minus_n = c.rs_minus_n;
            j.r_d_minus_n = Some(c.rd_minus_n);
            j.r_s_minus_interval_n = Iv(c.rs_minus_interval_n);
            j.r_d_minus_interval_n = Iv(c.rd_minus_interval_n);
        }
        j
    }
}
