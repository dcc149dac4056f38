//! # Validate: measured frequency response, predictions, scores, batches
//!
//! This stage owns everything after a fitted law exists:
//!
//! * `frc`: the measured frequency-response curve of a sweep log (stepped
//!   or continuous), with the data's own call whether each step settled and
//!   the drive plan as it was run (for the replay).
//! * `predict`: the steady-state prediction at the measured η and the replay
//!   of the sweep as it was run, each with a 95 % band from the fit's
//!   uncertainty; the score against the measured response.
//! * `batch`: friction coefficients from several normal-force settings of one
//!   pad (censored where a log only bounds ρs) and the recommended setting.

pub mod batch;
pub mod frc;
pub mod predict;
