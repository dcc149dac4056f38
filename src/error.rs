//! The crate's error type: one enum over the stages' own errors, so the binary
//! can print a single `error: ...` line for any failure. The small error
//! enums of the identify, validate and batch stages live here too (each
//! stage re-exports its own), so that this module depends only on the
//! stages below them (ingest, model, sim) and no import circle forms.

use std::path::PathBuf;

/// Any failure of a stickslip job.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// Model parameters that describe no physical absorber.
    #[error(transparent)]
    Param(#[from] crate::model::ParamError),
    /// The simulation could not be carried out as asked.
    #[error(transparent)]
    Sim(#[from] crate::sim::SimError),
    /// A rig log could not be ingested.
    #[error(transparent)]
    Ingest(#[from] crate::ingest::IngestError),
    /// The friction law of a characteristic log could not be identified.
    #[error("{}: {source}", path.display())]
    Identify {
        /// The log.
        path: PathBuf,
        /// Why.
        source: IdentifyError,
    },
    /// A sweep could not be validated against a fitted law.
    #[error("{}: {source}", path.display())]
    Validate {
        /// The log concerned (the sweep, or the characteristic log).
        path: PathBuf,
        /// Why.
        source: ValidateError,
    },
    /// The batch comparison could not be made.
    #[error("batch: {0}")]
    Batch(#[from] BatchError),
    /// A stage did not run on an input because an earlier stage failed on
    /// it (that failure is reported on its own as well).
    #[error("{}: {stage}: {cause}", path.display())]
    Skipped {
        /// The input.
        path: PathBuf,
        /// What was not done (`not read`, `not validated`).
        stage: &'static str,
        /// The earlier failure, as reported.
        cause: String,
    },
    /// A file could not be read or written.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file concerned.
        path: PathBuf,
        /// What the operating system said.
        source: std::io::Error,
    },
    /// Anything else that is wrong with an input, with the file it came from.
    #[error("{}: {msg}", path.display())]
    Input {
        /// The offending file.
        path: PathBuf,
        /// What is wrong with it.
        msg: String,
    },
    /// A job that computed but failed in part (the parts are reported
    /// above this line): it writes no output file.
    #[error("{what}; no output written")]
    Failed {
        /// What failed, e.g. "2 of 5 logs could not be fitted (a.mcap, b.mcap)".
        what: String,
    },
    /// SIGINT or SIGTERM came while the outputs were being renamed into
    /// place: every rename was undone (exit 130).
    #[error(
        "interrupted; the outputs being written were removed and the files they replaced restored"
    )]
    Interrupted,
}

/// Result with the crate's [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// Why a characteristic log gives no friction law (the doors,
/// [`crate::identify::characteristic`] and [`crate::identify::fit_log`],
/// name the log).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum IdentifyError {
    /// The log is a sweep.
    #[error("not a characteristic test (rig test = sweep): fit needs a fixed-frequency characteristic log")]
    NotCharacteristic,
    /// No drive sinusoid fits the drive channel.
    #[error("the drive channel does not determine a drive sinusoid")]
    NoDriveSinusoid,
    /// Less than two drive periods of usable data.
    #[error("only {usable_s:.3} s of usable data (x1, x2, v2 together); a characteristic needs at least two drive periods ({needed_s:.3} s)")]
    TooShort {
        /// Usable data (s).
        usable_s: f64,
        /// Two drive periods (s).
        needed_s: f64,
    },
    /// The slip samples do not determine a law.
    #[error("the slip samples do not determine a friction law")]
    Undetermined,
    /// The fit panicked (a bug): the log is reported, the others go on.
    #[error("internal error while fitting this log")]
    Internal,
    /// The fit of this many samples would not fit the memory budget.
    #[error("{samples} samples ({duration_s:.0} s at {rate_hz} Hz): fitting takes about {} ({} bytes per sample), over {}: at most {} samples ({:.0} s at this rate) are fitted; split the log into shorter ones", crate::limits::human(*.samples as f64 * crate::limits::FIT_BYTES_PER_SAMPLE as f64), crate::limits::FIT_BYTES_PER_SAMPLE, crate::limits::budget_text(), crate::limits::MAX_FIT_SAMPLES, crate::limits::MAX_FIT_SAMPLES as f64 / .rate_hz)]
    TooLong {
        /// Samples of the log's common grid.
        samples: usize,
        /// Its duration (s).
        duration_s: f64,
        /// Its rate (Hz).
        rate_hz: f64,
    },
}

/// Why a sweep could not be validated (the door, [`crate::validate::validate`], names the
/// log concerned).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ValidateError {
    /// The characteristic log never slid: no sliding level to predict with.
    #[error("the mass never slid in this characteristic log: only a lower bound on the static friction is known, no sliding level to predict a sweep with")]
    NeverSlid,
    /// The log is a characteristic test, not a sweep.
    #[error("not a sweep log (rig test = characteristic): a frequency response needs a sweep")]
    NotASweep,
    /// The drive channel has too few samples.
    #[error("the drive channel /drive/position has too few samples")]
    NoDriveSamples,
    /// The log is too short for a frequency response.
    #[error("the log is too short for a frequency response")]
    TooShort,
    /// A stepped sweep without setpoints to tell its steps.
    #[error("a stepped sweep needs /drive/setpoint messages (or a setpoint_hz column) to tell its steps")]
    NoSteps,
    /// A continuous sweep without its commanded frequency at two times.
    #[error("a continuous sweep needs its commanded frequency (/drive/setpoint messages or a setpoint_hz column) at two times at least")]
    NoCommandedFrequency,
    /// The first step's drive signal cannot be measured.
    #[error("the first step's drive signal cannot be measured")]
    FirstStepUnmeasured,
    /// A continuous sweep's drive signal cannot be measured.
    #[error("the drive signal of the sweep cannot be measured")]
    DriveUnmeasured,
    /// No step of a stepped sweep could be measured.
    #[error("no step of the sweep could be measured")]
    NoStepMeasured,
    /// No drive period of a continuous sweep could be measured.
    #[error("no drive period of the sweep could be measured")]
    NoPeriodMeasured,
    /// The drive amplitude cannot be measured.
    #[error("the drive amplitude cannot be measured")]
    DriveAmplitudeUnmeasured,
    /// The sweep's frequency plan has no segment.
    #[error("the sweep's frequency plan is empty")]
    EmptyPlan,
    /// The sweep has no measured point.
    #[error("the sweep has no measured points")]
    NoPoints,
    /// The fitted law is not a friction law at the sweep's amplitude.
    #[error("the fitted law is not a valid friction law at the sweep's drive amplitude")]
    InvalidLaw,
}

/// Why the batch comparison could not be made.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum BatchError {
    /// An option is out of range (what is wrong).
    #[error("{0}")]
    Options(String),
    /// No log of the batch was fitted.
    #[error("no fitted log in the batch")]
    Empty,
    /// No log of the batch could be read.
    #[error("no log of the batch could be read")]
    NothingRead,
    /// No log of the batch that was read could be fitted.
    #[error("no log of the batch could be fitted")]
    NothingFitted,
    /// The rig's constants describe no absorber.
    #[error("rig: {0}")]
    Rig(crate::model::ParamError),
    /// The force scale A·K2 is not positive.
    #[error("drive amplitude {amplitude_m} m or K2 {k2_n_per_m} N/m is not positive")]
    Scale {
        /// Drive amplitude A (m).
        amplitude_m: f64,
        /// K2 (N/m).
        k2_n_per_m: f64,
    },
    /// The ρ grid is empty.
    #[error("rho-max {max} is not above rho-min {min}")]
    RhoRange {
        /// Lower end.
        min: f64,
        /// Upper end.
        max: f64,
    },
    /// No log measures a coefficient (μs or μd).
    #[error(
        "no log measures {0} (every log only bounds it, or none has an interval): cannot fit it"
    )]
    Unmeasured(&'static str),
    /// The worst-case simulation failed.
    #[error("worst-case simulation: {0}")]
    Sim(crate::sim::SimError),
}
