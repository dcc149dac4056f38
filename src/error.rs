//! The crate's error type: one enum over the stages' own errors, so the binary
//! can print a single `error: ...` line for any failure.

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
        source: crate::identify::IdentifyError,
    },
    /// A sweep could not be validated against a fitted law.
    #[error("{}: {source}", path.display())]
    Validate {
        /// The log concerned (the sweep, or the characteristic log).
        path: PathBuf,
        /// Why.
        source: crate::validate::ValidateError,
    },
    /// The batch comparison could not be made.
    #[error("batch: {0}")]
    Batch(#[from] crate::batch::BatchError),
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
}

/// Result with the crate's [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;
