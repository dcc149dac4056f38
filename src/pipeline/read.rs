//! The `ingest` job: read one rig log into its clean run and write it as
//! Parquet where asked, through the write transaction
//! ([`crate::io::txn`]).

use super::Progress;
use crate::ingest::{self, IngestOptions, Run};
use serde_json::Value;
use std::path::PathBuf;

/// One log to read.
#[derive(Debug, Clone, PartialEq)]
pub struct IngestJob {
    /// The rig log.
    pub log: PathBuf,
    /// Channel map of a CSV, TDMS or MAT log (None: NAME.map.toml beside
    /// the log).
    pub map: Option<PathBuf>,
    /// Write the canonical run (common time base, SI) to this Parquet
    /// file.
    pub out: Option<PathBuf>,
}

/// What [`run_ingest`] produced.
#[derive(Debug, Clone)]
pub struct IngestOutcome {
    /// The run as read.
    pub run: Run,
    /// Where it was written, if it was.
    pub out: Option<PathBuf>,
    /// The `ingest --json` object ([`Run::to_json`]).
    pub json: Value,
}

/// Reads the log, then writes `out`.
pub fn run_ingest(job: &IngestJob, _progress: &dyn Progress) -> crate::Result<IngestOutcome> {
    let opts = IngestOptions {
        map: job.map.clone(),
        ..IngestOptions::default()
    };
    let run = ingest::read(&job.log, &opts)?;
    if let Some(out) = &job.out {
        crate::io::write_parquet(&run, out)?;
    }
    let json = run.to_json(job.out.as_deref());
    Ok(IngestOutcome {
        run,
        out: job.out.clone(),
        json,
    })
}
