//! # Validate: measured frequency response, predictions, scores
//!
//! This stage owns the comparison of a fitted law with a measured sweep
//! (the comparison of several normal-force settings is [`crate::batch`]):
//!
//! * `frc`: the measured frequency-response curve of a sweep log (stepped
//!   or continuous), with the data's own call whether each step settled and
//!   the drive plan as it was run (for the replay).
//! * `predict`: the steady-state prediction at the measured η and the replay
//!   of the sweep as it was run, each with a 95 % band from the fit's
//!   uncertainty; the score against the measured response.
//! * `sensitive` (within `predict`): the steps whose replay hinges on
//!   details finer than the measurement resolves (ensembles from each
//!   step's measured start, [`frc::start_states`]).

pub mod frc;
pub use crate::error::ValidateError;
mod json;
pub mod predict;
pub use predict::sensitive;

use crate::identify::LogFit;
use crate::ingest::{RigMeta, Run};
use crate::Result;
use frc::{FrcOptions, MeasuredFrc};
use predict::{PredictOptions, Prediction};

/// Options of [`validate`].
#[derive(Debug, Clone, Default)]
pub struct ValidateOptions {
    /// Measuring the sweep.
    pub frc: FrcOptions,
    /// Predictions and bands.
    pub predict: PredictOptions,
}

/// A validated law: the measured response of a sweep and its predictions.
#[derive(Debug, Clone)]
pub struct Validation {
    /// The sweep's rig constants.
    pub rig: RigMeta,
    /// The measured response.
    pub measured: MeasuredFrc,
    /// Predictions, bands, steady-state call and score.
    pub prediction: Prediction,
    /// Things the user should know (rig mismatch, measurement, prediction).
    pub warnings: Vec<crate::warning::Warning>,
}

/// Relative difference above which the rig constants of the characteristic
/// log and the sweep are reported as different rigs.
const RIG_MISMATCH: f64 = 0.01;

/// Validates the law fitted on a characteristic log (`fit` of the log
/// `characteristic`) against a sweep log: measures the sweep's response
/// and predicts it (steady state and replay, with bands).
///
/// ```
/// use stickslip::identify::{fit_log, FitOptions, IdentifyOptions};
/// use stickslip::ingest::{read, IngestOptions};
/// use stickslip::validate::{validate, ValidateOptions};
/// let read = |p: &str| read(p.as_ref(), &IngestOptions::default());
/// let (char_log, sweep) = (read("datasets/char_N4.mcap")?, read("datasets/sweep_stepped_N4.mcap")?);
/// let opts = IdentifyOptions {
///     fit: FitOptions { bootstrap: 0, ..Default::default() },
///     ..Default::default()
/// };
/// let fit = fit_log(&char_log, &opts)?;
/// let mut vopts = ValidateOptions::default();
/// vopts.predict.samples = 0; // no bands: central prediction only
/// let v = validate(&fit, &char_log, &sweep, &vopts)?;
/// // Normalised RMS error of the predicted amplitudes of M1 and M2.
/// assert!(v.prediction.score.nrms_amplitude1.unwrap() < 0.2);
/// assert!(v.prediction.score.nrms_amplitude2.unwrap() < 0.2);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn validate(
    fit: &LogFit,
    characteristic: &Run,
    sweep: &Run,
    opts: &ValidateOptions,
) -> Result<Validation> {
    validate_fit(
        fit,
        &characteristic.source,
        &characteristic.rig,
        sweep,
        opts,
    )
}

/// [`validate`] with what it reads of the characteristic log given
/// directly: its path (for messages) and its rig record — e.g. from a saved
/// fit ([`crate::identify::artifact::FitArtifact`]), without the log.
pub fn validate_fit(
    fit: &LogFit,
    characteristic: &std::path::Path,
    fit_rig: &RigMeta,
    sweep: &Run,
    opts: &ValidateOptions,
) -> Result<Validation> {
    if fit.stuck() {
        return Err(crate::Error::Validate {
            path: characteristic.to_path_buf(),
            source: ValidateError::NeverSlid,
        });
    }
    let measured = frc::measure(sweep, &opts.frc)?;
    let rig = sweep.rig.clone();
    let mut warnings = Vec::new();
    for (name, a, b) in [
        ("M1", fit_rig.m1_kg, rig.m1_kg),
        ("M2", fit_rig.m2_kg, rig.m2_kg),
        ("K1", fit_rig.k1_n_per_m, rig.k1_n_per_m),
        ("K2", fit_rig.k2_n_per_m, rig.k2_n_per_m),
    ] {
        if (a - b).abs() > RIG_MISMATCH * a.abs().max(b.abs()) {
            warnings.push(crate::warning::Warning::SweepRigMismatch {
                constant: name,
                characteristic: a,
                sweep: b,
            });
        }
    }
    let prediction =
        predict::predict(fit, &rig, &measured, &opts.predict).map_err(|e| match e {
            predict::PredictError::Validate(source) => crate::Error::Validate {
                path: sweep.source.clone(),
                source,
            },
            predict::PredictError::Sim(e) => e.into(),
        })?;
    warnings.extend(measured.warnings.iter().cloned());
    warnings.extend(prediction.warnings.iter().cloned());
    Ok(Validation {
        rig,
        measured,
        prediction,
        warnings,
    })
}
