//! Fitting many logs: in parallel (rayon; results in input order, the
//! same whatever the thread count), each panic-guarded, in rounds whose
//! planned memory fits the budget.

use super::{fit_log, IdentifyError, IdentifyOptions, LogFit};
use crate::error::{Error, Result};
use crate::ingest::{RigMeta, Run};
use rayon::prelude::*;
use std::path::{Path, PathBuf};

/// Runs `f` for the log at `path`; a panic inside it becomes that log's
/// error (naming it) instead of ending the program.
fn guarded<T>(path: &Path, f: impl FnOnce() -> Result<T>) -> Result<T> {
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)).unwrap_or_else(|_| {
        Err(Error::Identify {
            path: path.to_path_buf(),
            source: IdentifyError::Internal,
        })
    })
}

/// Reads and fits several logs in parallel (rayon; results in the order
/// of `paths`, the same whatever the thread count). A log that cannot be
/// read or fitted, or whose fit panics, gives its own error; the others
/// complete. `tick` is called once per log done (progress).
///
/// Memory: each log's samples are counted before any log is decoded
/// ([`crate::ingest::planned_samples`], one log at a time), and the logs
/// are fitted in consecutive rounds whose planned memory
/// ([`crate::limits::planned_fit_bytes`]) fits `opts.memory_bytes`
/// together, each fit given its plan and an equal part of what the round
/// leaves ([`IdentifyOptions::memory_bytes`]). Rounds do not wait inside
/// rayon jobs, so nothing can deadlock, and the results do not depend on
/// them.
pub fn fit_logs(
    paths: &[PathBuf],
    opts: &IdentifyOptions,
    tick: &(dyn Fn() + Sync),
) -> Vec<Result<(RigMeta, LogFit)>> {
    // A log too long to fit is refused by its reader before it is decoded.
    let ingest = crate::ingest::IngestOptions {
        max_samples: Some(crate::limits::MAX_FIT_SAMPLES),
        ..Default::default()
    };
    let budget = opts.memory_bytes;
    let planned = planned_fit_memory(paths, budget);
    in_rounds(&planned, budget, opts, |i, o| {
        let p = &paths[i];
        let r = guarded(p, || {
            let mut run = crate::ingest::read(p, &ingest)?;
            // The fit reads the common grid only: the channels as recorded
            // (times and values, about a fifth of the fit's memory) go.
            run.channels = Vec::new();
            let f = fit_log(&run, o)?;
            Ok((run.rig, f))
        });
        tick();
        r
    })
}

/// The planned memory of fitting each log of `paths` within `budget`
/// ([`crate::limits::planned_fit_bytes`] of its samples, counted before it
/// is decoded by [`crate::ingest::planned_samples`], one log at a time).
/// A single log gets the whole budget whatever its size: nothing is
/// counted (0).
pub fn planned_fit_memory(paths: &[PathBuf], budget: u64) -> Vec<u64> {
    if paths.len() <= 1 {
        return vec![0; paths.len()];
    }
    let ingest = crate::ingest::IngestOptions {
        max_samples: Some(crate::limits::MAX_FIT_SAMPLES),
        ..Default::default()
    };
    paths
        .iter()
        .map(|p| {
            let n = crate::ingest::planned_samples(p, &ingest);
            crate::limits::planned_fit_bytes(n, budget)
        })
        .collect()
}

/// Fits logs already read, in parallel, panic-guarded and in rounds that
/// fit the memory, as [`fit_logs`].
pub fn fit_runs(
    runs: &[&Run],
    opts: &IdentifyOptions,
    tick: &(dyn Fn() + Sync),
) -> Vec<Result<LogFit>> {
    let budget = opts.memory_bytes;
    let planned: Vec<u64> = runs
        .iter()
        .map(|r| crate::limits::planned_fit_bytes(Some(r.samples() as u64), budget))
        .collect();
    in_rounds(&planned, budget, opts, |i, o| {
        let r = guarded(&runs[i].source, || fit_log(runs[i], o));
        tick();
        r
    })
}

/// Runs `job(i, options)` for every item, the items of each
/// [`crate::limits::rounds`] group of `planned` at once (rayon), the
/// groups one after the other; each job's options carry its memory share.
/// Results in item order.
fn in_rounds<T: Send>(
    planned: &[u64],
    budget: u64,
    opts: &IdentifyOptions,
    job: impl Fn(usize, &IdentifyOptions) -> T + Sync,
) -> Vec<T> {
    let mut out = Vec::with_capacity(planned.len());
    for round in crate::limits::rounds(planned, budget) {
        let sum = planned[round.clone()]
            .iter()
            .fold(0u64, |a, &b| a.saturating_add(b));
        let spare = budget.saturating_sub(sum) / round.len() as u64;
        let done: Vec<T> = round
            .into_par_iter()
            .map(|i| {
                let o = IdentifyOptions {
                    memory_bytes: planned[i].saturating_add(spare).min(budget),
                    ..opts.clone()
                };
                job(i, &o)
            })
            .collect();
        out.extend(done);
    }
    out
}
