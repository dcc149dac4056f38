//! The JSON form of a validation (the `validate` contract's keys plus
//! details), as typed structs serialised by serde (non-finite floats are
//! written as `null`).

use super::predict::{Predicted, Score};
use super::Validation;
use crate::identify::LogFit;
use serde::Serialize;
use serde_json::Value;
use std::path::Path;

/// The law the prediction simulated, dimensionless at the sweep's amplitude.
#[derive(Serialize)]
struct LawAtSweep {
    law: &'static str,
    rho_s: f64,
    rho_d: f64,
    slope: f64,
    /// The threshold towards − where the fit split it (null: symmetric).
    rho_s_minus: Option<f64>,
    /// κ = kt/K2 of the sweep's rig where the fit chose a contact spring
    /// (null: rigid).
    contact_stiffness: Option<f64>,
}

/// The measured response, one entry per point.
#[derive(Serialize)]
struct Measured<'a> {
    eta: Vec<f64>,
    frequency_hz: Vec<f64>,
    amplitude1: Vec<f64>,
    amplitude2: Vec<f64>,
    steady_reached: &'a [Option<bool>],
    settled_data: Vec<Option<bool>>,
    rel_change: Vec<Option<f64>>,
    amplitude1_low: Vec<f64>,
    amplitude1_high: Vec<f64>,
    amplitude2_low: Vec<f64>,
    amplitude2_high: Vec<f64>,
    amplitude1_uncertainty: Vec<f64>,
    amplitude2_uncertainty: Vec<f64>,
    drive_uncertainty: crate::validate::frc::DriveUncertainty,
    noise_x1_m: f64,
    noise_x2_m: f64,
    window_s: Vec<(f64, f64)>,
}

/// The score with the number of measured points.
#[derive(Serialize)]
struct ScoreOut<'a> {
    #[serde(flatten)]
    score: &'a Score,
    points: usize,
}

#[derive(Serialize)]
struct ValidationOut<'a> {
    characteristic: String,
    sweep: String,
    fit: Value,
    sweep_kind: &'static str,
    direction: &'static str,
    drive_amplitude_m: f64,
    law_at_sweep: LawAtSweep,
    measured: Measured<'a>,
    predicted: &'a Predicted,
    replay: &'a Predicted,
    replay_settled: &'a [Option<bool>],
    /// Per step: sensitive to the measurement's uncertainty? (`null`: not
    /// assessed).
    replay_sensitive: &'a [Option<bool>],
    /// Per step: the assessment behind `replay_sensitive`.
    replay_sensitivity: &'a [Option<crate::validate::sensitive::Sensitivity>],
    score: ScoreOut<'a>,
    draws: usize,
    /// The first-round draws whose steady states make the `predicted` band.
    steady_band_draws: usize,
    band_precision: &'a crate::validate::predict::BandPrecision,
    #[serde(serialize_with = "crate::warning::as_messages")]
    warnings: &'a [crate::warning::Warning],
    /// One stable code per warning (`crate::warning::Warning::code`).
    warning_codes: Vec<&'static str>,
}

impl Validation {
    /// The JSON object of this validation of the sweep log `sweep` against
    /// the fit `fit` of the characteristic log `characteristic` (interface
    /// keys plus details).
    pub fn to_json(&self, characteristic: &Path, sweep: &Path, fit: &LogFit) -> Value {
        let m = &self.measured;
        let p = &self.prediction;
        let pts = &m.points;
        let out = ValidationOut {
            characteristic: characteristic.display().to_string(),
            sweep: sweep.display().to_string(),
            fit: fit.to_json(characteristic),
            sweep_kind: m.kind.as_str(),
            direction: m.direction.as_str(),
            drive_amplitude_m: m.drive_amplitude_m,
            law_at_sweep: LawAtSweep {
                law: p.law.name(),
                rho_s: p.law.rho_s(),
                rho_d: p.law.rho_d(),
                slope: p.law.slope(),
                rho_s_minus: p.law.minus().map(|l| l.rho_s),
                contact_stiffness: p.contact_stiffness,
            },
            measured: Measured {
                eta: pts.iter().map(|q| q.eta).collect(),
                frequency_hz: pts.iter().map(|q| q.frequency_hz).collect(),
                amplitude1: pts.iter().map(|q| q.amplitude1).collect(),
                amplitude2: pts.iter().map(|q| q.amplitude2).collect(),
                steady_reached: &p.steady_reached,
                settled_data: pts.iter().map(|q| q.settled).collect(),
                rel_change: pts.iter().map(|q| q.rel_change).collect(),
                amplitude1_low: pts
                    .iter()
                    .map(|q| (q.amplitude1 - q.amplitude1_u).max(0.0))
                    .collect(),
                amplitude1_high: pts.iter().map(|q| q.amplitude1 + q.amplitude1_u).collect(),
                amplitude2_low: pts
                    .iter()
                    .map(|q| (q.amplitude2 - q.amplitude2_u).max(0.0))
                    .collect(),
                amplitude2_high: pts.iter().map(|q| q.amplitude2 + q.amplitude2_u).collect(),
                drive_uncertainty: m.drive_uncertainty,
                amplitude1_uncertainty: pts.iter().map(|q| q.amplitude1_u).collect(),
                amplitude2_uncertainty: pts.iter().map(|q| q.amplitude2_u).collect(),
                noise_x1_m: m.noise_m.0,
                noise_x2_m: m.noise_m.1,
                window_s: pts.iter().map(|q| q.window_s).collect(),
            },
            predicted: &p.steady,
            replay: &p.replay,
            replay_settled: &p.replay_settled,
            replay_sensitive: &p.replay_sensitive,
            replay_sensitivity: &p.replay_sensitivity,
            score: ScoreOut {
                score: &p.score,
                points: pts.len(),
            },
            draws: p.draws,
            steady_band_draws: p.steady_band_draws,
            band_precision: &p.band,
            warnings: &self.warnings,
            warning_codes: crate::warning::codes(&self.warnings),
        };
        crate::io::json::to_value(out)
    }
}
