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
#[derive(Serialize)]
struct LawOut {
    law: &'static str,
    rho_s: f64,
    rho_d: f64,
    slope: f64,
    v_s: Option<f64>,
    r_s_n: f64,
    r_d_n: f64,
    slope_n_s_per_m: f64,
    v_s_m_per_s: Option<f64>,
}

/// A law with its intervals.
#[derive(Serialize)]
struct EstimateOut {
    #[serde(flatten)]
    law: LawOut,
    rho_s_interval: Iv,
    rho_d_interval: Iv,
    slope_interval: Iv,
    r_s_interval_n: Iv,
    r_d_interval_n: Iv,
    slope_interval_n_s_per_m: Iv,
}

/// One family's information criterion.
#[derive(Serialize)]
struct Criterion {
    law: &'static str,
    bic: f64,
}

/// The equation-error estimate.
#[derive(Serialize)]
struct EquationErrorOut {
    #[serde(flatten)]
    estimate: EstimateOut,
    residual_rms_n: f64,
    bias_n: f64,
    criteria: Vec<Criterion>,
}

/// One family of the output-error refinement.
#[derive(Serialize)]
struct FamilyOut {
    law: &'static str,
    bic: f64,
    stick_fraction: f64,
    stick_phases: usize,
    rms_x1_m: f64,
    rms_x2_m: f64,
    direction_dependent: bool,
    contact_stiffness: Option<f64>,
    r_s_n: f64,
    r_d_n: f64,
    r_s_minus_n: Option<f64>,
    slope_n_s_per_m: f64,
    /// Simulated breakaways towards + and towards −.
    breakaways: (usize, usize),
    /// Upper bounds (N) on the thresholds towards + and − from simulated
    /// reversals without stick.
    reversal_bound_n: (Option<f64>, Option<f64>),
}

/// The output-error estimate.
#[derive(Serialize)]
struct OutputErrorOut {
    #[serde(flatten)]
    estimate: EstimateOut,
    rms_x1_m: f64,
    rms_x2_m: f64,
    start_rms_x1_m: f64,
    start_rms_x2_m: f64,
    bias_n: f64,
    gains: (f64, f64),
    /// Lags (s) of x1 and x2 behind the drive, fitted with the law
    /// (`null` where they were not fitted).
    position_delays_s: Option<(f64, f64)>,
    /// Their 95 % intervals (s).
    position_delays_interval_s: Option<((f64, f64), (f64, f64))>,
    iterations: u64,
    evaluations: usize,
    segments: usize,
    samples: usize,
    effective_samples: f64,
    drive: &'static str,
    seconds: f64,
    criteria: Vec<FamilyOut>,
    /// The chosen static/dynamic law's profile against an unresolved
    /// Stribeck drop (`null` for other laws).
    drop_profile: Option<super::output_error::DropProfile>,
}

/// One structure test of the residuals.
#[derive(Serialize)]
struct StructureOut {
    channel: &'static str,
    against: &'static str,
    chi2_per_dof: f64,
    z: f64,
    effect: f64,
}

/// The adequacy verdict's numbers.
#[derive(Serialize)]
struct AdequacyOut {
    noise_ratio_x1: f64,
    noise_ratio_x2: f64,
    robust_ratio_x1: f64,
    robust_ratio_x2: f64,
    noise_ratio_force: Option<f64>,
    robust_ratio_force: Option<f64>,
    max_noise_ratio: f64,
    max_structure_z: f64,
    max_structure_effect: f64,
    interval_inflation: f64,
    structure: Vec<StructureOut>,
}

impl AdequacyOut {
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
                .map(|s| StructureOut {
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
#[derive(Serialize)]
struct EvidenceOut {
    against: &'static str,
    delta_bic: f64,
    strength: &'static str,
}

/// One fitted log (the `fits` entries' keys).
#[derive(Serialize)]
struct FitOut<'a> {
    log: String,
    law: &'static str,
    rho_s: Option<f64>,
    rho_d: Option<f64>,
    slope: Option<f64>,
    rho_s_interval: Iv,
    rho_d_interval: Iv,
    slope_interval: Iv,
    r_s_n: Option<f64>,
    r_d_n: Option<f64>,
    slope_n_s_per_m: Option<f64>,
    r_s_interval_n: Iv,
    r_d_interval_n: Iv,
    slope_interval_n_s_per_m: Iv,
    normal_force_n: f64,
    eta: f64,
    drive_frequency_hz: f64,
    stuck: bool,
    rho_s_lower_bound: Option<f64>,
    r_s_lower_bound_n: Option<f64>,
    never_sticks: bool,
    adequate: bool,
    adequacy: Option<AdequacyOut>,
    contradictions: &'a [crate::warning::Warning],
    law_evidence: Option<EvidenceOut>,
    drive_amplitude_m: f64,
    residual_rms: f64,
    residual_rms_n: f64,
    #[serde(serialize_with = "crate::warning::as_messages")]
    warnings: &'a [crate::warning::Warning],
    /// One stable code per warning (`crate::warning::Warning::code`).
    warning_codes: Vec<&'static str>,
    stribeck: Option<LawOut>,
    simple_law: Option<LawOut>,
    criteria: Vec<Criterion>,
    estimate: &'static str,
    equation_error: Option<EquationErrorOut>,
    output_error: Option<OutputErrorOut>,
    gain_uncertainty: f64,
    bias_n: f64,
    slip_samples: usize,
    effective_samples: f64,
    breakaways: usize,
    notes: &'a [String],
    channel_delays_s: Value,
    channel_delays_interval_s: Value,
    velocity_consistency: Value,
    acceleration_consistency: Value,
    direction_dependent: bool,
    rho_s_minus: Option<f64>,
    rho_d_minus: Option<f64>,
    r_s_minus_n: Option<f64>,
    r_d_minus_n: Option<f64>,
    rho_s_minus_interval: Iv,
    rho_d_minus_interval: Iv,
    r_s_minus_interval_n: Iv,
    r_d_minus_interval_n: Iv,
    /// Rs⁺ − Rs⁻ (N) with equal dynamic levels: what the log identifies of
    /// the direction dependence (see the warning `direction_dependent`).
    direction_split_n: Option<f64>,
    direction_split_interval_n: Iv,
    contact_stiffness: Option<f64>,
    contact_stiffness_interval: Iv,
    kt_n_per_m: Option<f64>,
    kt_interval_n_per_m: Iv,
    contact_stiffness_lower_bound: Option<f64>,
    pad_screen: &'a super::pads::PadScreen,
    spring_screen: Option<&'a super::springs::SpringScreen>,
}

impl LogFit {
    /// A law in SI and dimensionless with this log's scales.
    fn law_out(&self, l: &SiLaw) -> LawOut {
        let fs = self.force_scale_n;
        let vel = self.velocity_scale_m_per_s;
        LawOut {
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
    fn estimate_out(&self, l: &SiLaw, iv: &Intervals) -> EstimateOut {
        let mut l = *l;
        if self.never_sticks() {
            l.rs_n = f64::NAN;
        }
        EstimateOut {
            law: self.law_out(&l),
            rho_s_interval: Iv(iv.rho_s),
            rho_d_interval: Iv(iv.rho_d),
            slope_interval: Iv(iv.dstar),
            r_s_interval_n: Iv(iv.rs_n),
            r_d_interval_n: Iv(iv.rd_n),
            slope_interval_n_s_per_m: Iv(iv.slope_n_s_per_m),
        }
    }

    /// The JSON entry of this fit for `log` (interface keys plus details).
    pub fn to_json(&self, log: &Path) -> Value {
        let e = &self.fit;
        let law = self.law();
        let criteria = |c: &[(super::LawKind, f64)]| -> Vec<Criterion> {
            c.iter()
                .map(|(k, b)| Criterion {
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
        let out = FitOut {
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
            adequacy: self.adequacy.as_ref().map(AdequacyOut::of),
            contradictions: &self.contradictions,
            law_evidence: used_oe.and_then(|o| o.evidence).map(|ev| EvidenceOut {
                against: ev.against.as_str(),
                delta_bic: ev.delta_bic,
                strength: ev.strength(),
            }),
            drive_amplitude_m: self.drive.amplitude_m,
            residual_rms: e.residual_rms_n / self.force_scale_n,
            residual_rms_n: e.residual_rms_n,
            warnings: &self.warnings,
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
            equation_error: (!e.stuck).then(|| EquationErrorOut {
                estimate: self.estimate_out(&e.law, &self.equation_error),
                residual_rms_n: e.residual_rms_n,
                bias_n: e.bias_n,
                criteria: criteria(&e.criteria),
            }),
            output_error: self.output_error.as_ref().map(|o| {
                let c = &o.chosen;
                OutputErrorOut {
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
                    drive: o.drive.as_str(),
                    seconds: o.seconds,
                    criteria: o
                        .families
                        .iter()
                        .map(|f| FamilyOut {
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
            notes: &self.notes,
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
            contact_stiffness: self.contact_stiffness(),
            contact_stiffness_interval: Iv(pads.and_then(|p| p.contact_stiffness_interval)),
            kt_n_per_m: self.contact_stiffness().map(|k| k * self.k2_n_per_m()),
            kt_interval_n_per_m: Iv(pads
                .and_then(|p| p.contact_stiffness_interval)
                .map(|(l, h)| (l * self.k2_n_per_m(), h * self.k2_n_per_m()))),
            contact_stiffness_lower_bound: self.contact_stiffness_lower_bound(),
            pad_screen: &self.pad_screen,
            spring_screen: self.spring_screen.as_ref(),
        };
        crate::io::json::to_value(out)
    }
}
