//! Measured frequency response of a sweep log (types; the measurement is
//! being written on the `frc` branch).

use crate::sim::sweep::Direction;

/// Stepped or continuous sweep.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SweepKind {
    /// Setpoints held for a dwell, ramps between them.
    Stepped,
    /// A slow continuous chirp.
    Continuous,
}

/// One piece of the drive-frequency plan as it was run (SI, seconds from
/// log start). A hold has `f_start_hz == f_end_hz`; a ramp is linear in
/// frequency (continuous drive phase).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlanSegment {
    /// Start (s).
    pub start_s: f64,
    /// End (s).
    pub end_s: f64,
    /// Frequency at the start (Hz).
    pub f_start_hz: f64,
    /// Frequency at the end (Hz).
    pub f_end_hz: f64,
}

/// One measured point of the response.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MeasuredPoint {
    /// Drive frequency (Hz), measured from the drive channel.
    pub frequency_hz: f64,
    /// η = 2πf/√(K2/M2).
    pub eta: f64,
    /// Start of the step's dwell / the drive period (s).
    pub t_start_s: f64,
    /// End of the step's dwell / the drive period (s).
    pub t_end_s: f64,
    /// The part used for the amplitude (whole drive periods).
    pub window_s: (f64, f64),
    /// A1/A with the measured drive amplitude (paper eq. 6).
    pub amplitude1: f64,
    /// A2/A.
    pub amplitude2: f64,
    /// A1 (m).
    pub amplitude1_m: f64,
    /// A2 (m).
    pub amplitude2_m: f64,
    /// Relative amplitude change between the last two windows of a step.
    pub rel_change: Option<f64>,
    /// The data's own call whether the step settled.
    pub settled: Option<bool>,
}

/// The measured frequency response of one sweep log.
#[derive(Debug, Clone, PartialEq)]
pub struct MeasuredFrc {
    /// Stepped or continuous.
    pub kind: SweepKind,
    /// Order of the setpoints.
    pub direction: Direction,
    /// Drive amplitude measured from the drive channel (m).
    pub drive_amplitude_m: f64,
    /// φ(0): x0(t) ≈ offset + A·sin(φ(t)), φ' = 2πf(t).
    pub drive_phase_rad: f64,
    /// √(K2/M2) (rad/s).
    pub omega_ref_rad_s: f64,
    /// The drive-frequency plan as run, covering the log.
    pub plan: Vec<PlanSegment>,
    /// One per step (stepped) or drive period (continuous).
    pub points: Vec<MeasuredPoint>,
    /// Things the user should know.
    pub warnings: Vec<String>,
}

/// Options of [`measure`] (placeholder until the `frc` branch lands).
#[derive(Debug, Clone, Default)]
pub struct FrcOptions {}

/// Measures the frequency response of a sweep log (placeholder until the
/// `frc` branch lands: always an error).
pub fn measure(run: &crate::ingest::Run, _opts: &FrcOptions) -> crate::Result<MeasuredFrc> {
    Err(crate::Error::Input {
        path: run.source.clone(),
        msg: "sweep measurement not implemented yet".into(),
    })
}
