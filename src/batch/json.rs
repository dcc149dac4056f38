//! The JSON form of a batch comparison (the `batch` contract's keys plus
//! details), as typed structs serialised by serde. The per-coefficient keys
//! (`mu_s`, `mu_s_interval`, …, `mu_d_…`) are one [`MuOut`] struct written
//! twice under a prefix (`serde_with::with_prefix!`); non-finite floats are
//! written as `null`.

use super::{Batch, BatchLog, CurvePoint, MuFit, Worst};
use crate::io::json::Interval;
use serde::Serialize;
use serde_json::Value;

serde_with::with_prefix!(prefix_mu_s "mu_s");
serde_with::with_prefix!(prefix_mu_d "mu_d");

/// One friction coefficient's fit. Field names are the key suffixes: the
/// estimate itself is the bare prefix (`mu_s`), the rest `mu_s_interval`,
/// `mu_s_birge`, ….
#[derive(Serialize)]
struct MuOut {
    #[serde(rename = "")]
    mu: f64,
    #[serde(rename = "_interval")]
    interval: Interval,
    #[serde(rename = "_stat_interval")]
    stat_interval: Interval,
    #[serde(rename = "_systematic_rel")]
    systematic_rel: f64,
    #[serde(rename = "_birge")]
    birge: f64,
    #[serde(rename = "_chi2_per_dof")]
    chi2_per_dof: Option<f64>,
    #[serde(rename = "_points")]
    points: usize,
    #[serde(rename = "_censored")]
    censored: usize,
    #[serde(rename = "_free_slope")]
    free_slope: f64,
    #[serde(rename = "_intercept_n")]
    intercept_n: f64,
    #[serde(rename = "_intercept_interval_n")]
    intercept_interval_n: Interval,
}

impl From<&MuFit> for MuOut {
    fn from(m: &MuFit) -> Self {
        let (slope, a, hw) = m.free.unwrap_or((f64::NAN, f64::NAN, f64::NAN));
        MuOut {
            mu: m.mu,
            interval: m.interval.into(),
            stat_interval: m.stat_interval.into(),
            systematic_rel: m.systematic_rel,
            birge: m.birge,
            chi2_per_dof: m.chi2_per_dof,
            points: m.points,
            censored: m.censored,
            free_slope: slope,
            intercept_n: a,
            intercept_interval_n: (a - hw, a + hw).into(),
        }
    }
}

/// Both coefficients, flat (`mu_s…`, `mu_d…`).
#[derive(Serialize)]
struct Coefficients {
    #[serde(flatten, with = "prefix_mu_s")]
    mu_s: MuOut,
    #[serde(flatten, with = "prefix_mu_d")]
    mu_d: MuOut,
}

/// A conflict between logs.
#[derive(Serialize)]
struct ConflictOut<'a> {
    logs: Vec<String>,
    quantity: &'static str,
    kind: &'static str,
    what: &'a str,
    size_sigma: f64,
    size_rel: f64,
    set_aside: bool,
}

/// The recommended setting; every key `null` where none is given.
#[derive(Serialize, Default)]
struct RecommendationOut {
    recommended_normal_force_n: Option<f64>,
    recommended_normal_force_interval_n: Option<Interval>,
    recommended_rho_s: Option<f64>,
    recommended_rho_d: Option<f64>,
    recommended_rho_s_box: Option<Interval>,
    worst_amplitude1: Option<f64>,
    worst_amplitude1_interval: Option<Interval>,
    worst_amplitude1_robust: Option<f64>,
    worst_eta: Option<f64>,
    worst_branch: Option<&'static str>,
    worst_coexisting_points: Option<usize>,
    worst_coexisting_eta: Option<f64>,
}

/// The stability cliff; every key `null` where none was found.
#[derive(Serialize, Default)]
struct CliffOut {
    cliff_rho_s: Option<f64>,
    cliff_rho_s_bracket: Option<Interval>,
    cliff_normal_force_n: Option<f64>,
    cliff_threshold: Option<f64>,
    cliff_worst_amplitude1: Option<f64>,
    cliff_eta: Option<f64>,
    margin_to_cliff: Option<f64>,
    margin_to_cliff_rho_s: Option<f64>,
    margin_to_cliff_n: Option<f64>,
}

/// One normal-force setting (one log).
#[derive(Serialize)]
struct SettingOut {
    log: String,
    normal_force_n: f64,
    #[serde(rename = "static")]
    static_obs: &'static str,
    mu_s_log: Option<f64>,
    /// `[lower, upper]` bounds on μs where only bounds are known (either may
    /// be `null`), `null` where neither is.
    mu_s_log_bounds: Option<(Option<f64>, Option<f64>)>,
    mu_d_log: Option<f64>,
    rho_s_log: Option<f64>,
    rho_s_model: f64,
    worst_amplitude1: Option<f64>,
    worst_eta: Option<f64>,
    worst_branch: Option<&'static str>,
    consistent: Option<bool>,
    set_aside_mu_s: bool,
    set_aside_mu_d: bool,
    estimate_disagreement_rs_sigma: f64,
    estimate_disagreement_rd_sigma: f64,
    drive_amplitude_m: f64,
}

impl From<&BatchLog> for SettingOut {
    fn from(l: &BatchLog) -> Self {
        SettingOut {
            log: l.log.display().to_string(),
            normal_force_n: l.normal_force_n,
            static_obs: l.static_obs.as_str(),
            mu_s_log: l.mu_s.0,
            mu_s_log_bounds: match (l.mu_s.1, l.mu_s.2) {
                (None, None) => None,
                bounds => Some(bounds),
            },
            mu_d_log: l.mu_d,
            rho_s_log: l.rho_s,
            rho_s_model: l.model_rho_s,
            worst_amplitude1: l.worst.map(|w| w.amplitude1),
            worst_eta: l.worst.map(|w| w.eta),
            worst_branch: l.worst.map(|w| w.branch.as_str()),
            consistent: l.consistent,
            set_aside_mu_s: l.set_aside.0,
            set_aside_mu_d: l.set_aside.1,
            estimate_disagreement_rs_sigma: l.estimate_disagreement.0,
            estimate_disagreement_rd_sigma: l.estimate_disagreement.1,
            drive_amplitude_m: l.drive_amplitude_m,
        }
    }
}

/// The worst case at one model parameter set.
#[derive(Serialize)]
struct WorstOut {
    rho_s: f64,
    rho_d: f64,
    worst_amplitude1: f64,
    eta: f64,
    branch: &'static str,
    unsettled: usize,
    coexisting_points: usize,
    eta_evaluated: usize,
    periods: u64,
}

impl From<&Worst> for WorstOut {
    fn from(w: &Worst) -> Self {
        WorstOut {
            rho_s: w.rho_s,
            rho_d: w.rho_d,
            worst_amplitude1: w.amplitude1,
            eta: w.eta,
            branch: w.branch.as_str(),
            unsettled: w.unsettled,
            coexisting_points: w.coexisting,
            eta_evaluated: w.points,
            periods: w.periods,
        }
    }
}

/// One point of the worst-amplitude curve over the normal force.
#[derive(Serialize)]
struct CurveOut {
    #[serde(flatten)]
    worst: WorstOut,
    normal_force_n: f64,
    robust_worst_amplitude1: Option<f64>,
}

impl From<&CurvePoint> for CurveOut {
    fn from(c: &CurvePoint) -> Self {
        CurveOut {
            worst: (&c.worst).into(),
            normal_force_n: c.normal_force_n,
            robust_worst_amplitude1: c.robust,
        }
    }
}

/// One real-pad extension over the logs.
#[derive(Serialize)]
struct CombinedOut {
    value: f64,
    interval: Interval,
    chi2_per_dof: Option<f64>,
    logs_chosen: usize,
    logs_eligible: usize,
    simulated: bool,
    /// The robust worst case includes the ends of `interval`.
    in_robust_worst_case: bool,
    /// κ's power law in N (`null`: one κ at every setting).
    by_normal_force: Option<NormalForceOut>,
}

/// κ = value·(N/reference_normal_force_n)^exponent.
#[derive(Serialize)]
struct NormalForceOut {
    reference_normal_force_n: f64,
    exponent: f64,
    exponent_interval: Interval,
    chi2_per_dof: f64,
    delta_chi2: f64,
}

impl From<&super::Combined> for CombinedOut {
    fn from(c: &super::Combined) -> Self {
        CombinedOut {
            value: c.value,
            interval: c.interval.into(),
            chi2_per_dof: c.chi2_per_dof,
            logs_chosen: c.chosen,
            logs_eligible: c.eligible,
            simulated: c.used,
            in_robust_worst_case: c.in_robust,
            by_normal_force: c.by_normal_force.map(|l| NormalForceOut {
                reference_normal_force_n: l.reference_n,
                exponent: l.exponent,
                exponent_interval: l.exponent_interval.into(),
                chi2_per_dof: l.chi2_per_dof,
                delta_chi2: l.delta_chi2,
            }),
        }
    }
}

/// The pad the worst cases simulate and the extensions the logs chose.
#[derive(Serialize)]
struct PadOut {
    /// κ simulated (`null`: rigid).
    contact_stiffness: Option<f64>,
    /// ρs⁻/ρs⁺ simulated (`null`: symmetric).
    rho_s_minus_ratio: Option<f64>,
    contact: Option<CombinedOut>,
    split: Option<CombinedOut>,
}

/// The batch keys (everything but `fits`).
#[derive(Serialize)]
struct BatchOut<'a> {
    /// Without the conflicting logs.
    #[serde(flatten)]
    coefficients: Coefficients,
    /// With every log.
    all_logs: Coefficients,
    mu_s_set_aside: Vec<String>,
    mu_d_set_aside: Vec<String>,
    conflicts: Vec<ConflictOut<'a>>,
    mu_ratio: f64,
    mu_ratio_interval: Interval,
    pad_model: PadOut,
    #[serde(flatten)]
    recommendation: RecommendationOut,
    #[serde(skip_serializing_if = "Option::is_none")]
    recommendation_reason: Option<&'a str>,
    #[serde(flatten)]
    cliff: CliffOut,
    settings: Vec<SettingOut>,
    curve: Vec<CurveOut>,
    drive_amplitude_m: f64,
    drive_amplitude_source: &'static str,
    measured_drive_amplitude_m: f64,
    force_scale_n: f64,
    m: f64,
    k: f64,
    damping: f64,
    eta_range: Interval,
    eta_points: usize,
    eta_coarse_points: usize,
    setting_tolerance: f64,
    evaluations: usize,
    periods: u64,
    #[serde(serialize_with = "crate::warning::as_messages")]
    warnings: &'a [crate::warning::Warning],
    /// One stable code per warning (`crate::warning::Warning::code`).
    warning_codes: Vec<&'static str>,
}

impl Batch {
    /// The batch keys of the JSON output (everything but `fits`).
    pub fn to_json_map(&self) -> serde_json::Map<String, Value> {
        let b = self;
        let set_aside = |pick: fn(&BatchLog) -> bool| -> Vec<String> {
            b.logs
                .iter()
                .filter(|l| pick(l))
                .map(|l| l.log.display().to_string())
                .collect()
        };
        let recommendation =
            b.recommendation
                .as_ref()
                .map_or_else(RecommendationOut::default, |r| RecommendationOut {
                    recommended_normal_force_n: Some(r.normal_force_n),
                    recommended_normal_force_interval_n: Some(r.interval_n.into()),
                    recommended_rho_s: Some(r.rho_s),
                    recommended_rho_d: Some(r.rho_d),
                    recommended_rho_s_box: Some(r.rho_s_box.into()),
                    worst_amplitude1: Some(r.worst.amplitude1),
                    worst_amplitude1_interval: Some(r.worst_interval.into()),
                    worst_amplitude1_robust: Some(r.worst_interval.1),
                    worst_eta: Some(r.worst.eta),
                    worst_branch: Some(r.worst.branch.as_str()),
                    worst_coexisting_points: Some(r.worst.coexisting),
                    worst_coexisting_eta: Some(r.worst.coexisting_eta),
                });
        let cliff = b
            .cliff
            .as_ref()
            .map_or_else(CliffOut::default, |c| CliffOut {
                cliff_rho_s: Some(c.rho_s),
                cliff_rho_s_bracket: Some(c.bracket.into()),
                cliff_normal_force_n: Some(c.normal_force_n),
                cliff_threshold: Some(c.threshold),
                cliff_worst_amplitude1: Some(c.worst_below.amplitude1),
                cliff_eta: Some(c.worst_below.eta),
                margin_to_cliff: Some(c.margin_rel),
                margin_to_cliff_rho_s: Some(c.margin_rho_s),
                margin_to_cliff_n: Some(c.margin_n),
            });
        let out = BatchOut {
            coefficients: Coefficients {
                mu_s: (&b.mu_s).into(),
                mu_d: (&b.mu_d).into(),
            },
            all_logs: Coefficients {
                mu_s: (&b.mu_s_all).into(),
                mu_d: (&b.mu_d_all).into(),
            },
            mu_s_set_aside: set_aside(|l| l.set_aside.0),
            mu_d_set_aside: set_aside(|l| l.set_aside.1),
            conflicts: b
                .conflicts
                .iter()
                .map(|c| ConflictOut {
                    logs: c.logs.iter().map(|p| p.display().to_string()).collect(),
                    quantity: c.quantity,
                    kind: c.kind,
                    what: &c.what,
                    size_sigma: c.size_sigma,
                    size_rel: c.size_rel,
                    set_aside: c.set_aside,
                })
                .collect(),
            mu_ratio: b.ratio,
            mu_ratio_interval: b.ratio_interval.into(),
            pad_model: PadOut {
                contact_stiffness: b.pad.shape.contact_stiffness,
                rho_s_minus_ratio: b.pad.shape.rs_minus_ratio,
                contact: b.pad.contact.as_ref().map(CombinedOut::from),
                split: b.pad.split.as_ref().map(CombinedOut::from),
            },
            recommendation,
            recommendation_reason: b.recommendation_reason.as_deref(),
            cliff,
            settings: b.logs.iter().map(SettingOut::from).collect(),
            curve: b.curve.iter().map(CurveOut::from).collect(),
            drive_amplitude_m: b.drive_amplitude_m,
            drive_amplitude_source: b.drive_amplitude_source,
            measured_drive_amplitude_m: b.measured_drive_amplitude_m,
            force_scale_n: b.force_scale_n,
            m: b.absorber.m,
            k: b.absorber.k,
            damping: b.absorber.damping,
            eta_range: b.eta_range.into(),
            eta_points: b.eta_points,
            eta_coarse_points: b.eta_coarse_points,
            setting_tolerance: b.setting_tolerance,
            evaluations: b.evaluations,
            periods: b.periods,
            warnings: &b.warnings,
            warning_codes: crate::warning::codes(&b.warnings),
        };
        match crate::io::json::to_value(out) {
            Value::Object(map) => map,
            other => serde_json::Map::from_iter([("error".to_string(), other)]),
        }
    }
}
