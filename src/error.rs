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
