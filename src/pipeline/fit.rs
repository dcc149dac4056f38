//! The `fit` job: fit the friction law of each characteristic log, in
//! parallel (panic-guarded: a bad log does not stop the others), or of one
//! shard K/N of the log list; one record per log ([`FitJson`]), written
//! through the write transaction ([`crate::io::txn`]) even where some logs
//! failed (the others' fits are kept).

use super::Progress;
use crate::identify::artifact::{self, FitArtifact, FitRecord};
use crate::identify::{self, IdentifyOptions, LogFit};
use serde::Serialize;
use std::path::{Path, PathBuf};

/// Most shards of a fit (far more than logs one command is given).
pub const MAX_FIT_SHARDS: usize = 1_000_000;

/// Parses `--shard K/N` of `fit` (1 ≤ K ≤ N ≤ [`MAX_FIT_SHARDS`]).
pub fn parse_fit_shard(s: &str) -> crate::Result<(usize, usize)> {
    let parts: Vec<&str> = s.split('/').collect();
    let nums: Option<(usize, usize)> = match parts.as_slice() {
        [a, b] => a.trim().parse().ok().zip(b.trim().parse().ok()),
        _ => None,
    };
    let bad = |msg: String| crate::Error::Input {
        path: PathBuf::from("--shard"),
        msg,
    };
    match nums {
        Some((_, n)) if n > MAX_FIT_SHARDS => Err(bad(format!(
            "{s}: at most {MAX_FIT_SHARDS} shards"
        ))),
        Some((k, n)) if n >= 1 && (1..=n).contains(&k) => Ok((k, n)),
        Some((0, n)) if n >= 1 => Err(bad(format!(
            "must be K/N with 1 <= K <= N, got `{s}`: K is 1-based (a job array numbered from 0 gives K = task id - min task id + 1)"
        ))),
        _ => Err(bad(format!("must be K/N with 1 <= K <= N, got `{s}`"))),
    }
}

/// The logs of shard K of N among `n` logs: a contiguous slice, the
/// slices' sizes differing by at most one (some are empty when N > n).
pub fn shard_range(k: usize, shards: usize, n: usize) -> std::ops::Range<usize> {
    let at = |i: usize| (i as u128 * n as u128 / shards as u128) as usize;
    at(k - 1)..at(k)
}

/// One fit of a list of characteristic logs (or of one shard of it).
#[derive(Debug, Clone)]
pub struct FitJob {
    /// The characteristic logs.
    pub logs: Vec<PathBuf>,
    /// Fit only shard K of N (`(K, N)`, see [`shard_range`]).
    pub shard: Option<(usize, usize)>,
    /// How each log is fitted.
    pub options: IdentifyOptions,
    /// Write the JSON result to this file.
    pub out: Option<PathBuf>,
}

/// The shard keys of a fit part.
#[derive(Debug, Clone, Serialize)]
pub struct FitShardJson {
    /// K of K/N.
    pub shard: usize,
    /// N of K/N.
    pub shards: usize,
    /// The sha256 of every log of the whole list (`null`: unreadable).
    pub log_sha256s: Vec<Option<String>>,
}

/// The `fit --json` object (and the `--out` file).
#[derive(Debug, Clone, Serialize)]
pub struct FitJson {
    /// The shard computed, where one was (flattened).
    #[serde(flatten)]
    pub shard: Option<FitShardJson>,
    /// One record per log ([`FitArtifact::fit_record`]), or its error.
    pub fits: Vec<FitRecord>,
}

/// What [`run_fit`] produced.
#[derive(Debug)]
pub struct FitOutcome {
    /// The JSON result (as written to `out`).
    pub json: FitJson,
    /// The logs fitted (the shard's).
    pub logs: usize,
    /// The logs whose fit failed.
    pub failed: Vec<String>,
}

/// Runs the fit: one [`Progress::say`] line per fitted log (its summary)
/// and one [`Progress::error`] line per log that failed, in the logs'
/// order; then writes `out`.
pub fn run_fit(job: &FitJob, progress: &dyn Progress) -> crate::Result<FitOutcome> {
    // Every log's sha256 (a part records the whole list; a log that cannot
    // be read has none, and its fit fails below).
    let sha = |p: &PathBuf| artifact::sha256_file(p).ok();
    let (all_shas, logs): (Vec<Option<String>>, &[PathBuf]) = match job.shard {
        Some((k, n)) => (
            job.logs.iter().map(sha).collect(),
            &job.logs[shard_range(k, n, job.logs.len())],
        ),
        None => (Vec::new(), &job.logs),
    };
    // Parallel over logs, each panic-guarded (one failing log does not
    // stop the others).
    let results = identify::fit_logs(logs, &job.options, &|| {});
    let mut failed: Vec<String> = Vec::new();
    let mut fits = Vec::new();
    for (log, r) in logs.iter().zip(results) {
        let log_sha = r.as_ref().ok().and_then(|_| sha(log));
        match (r, log_sha) {
            (Ok((rig, f)), Some(log_sha256)) => {
                progress.say(&summary(log, &f));
                let a = FitArtifact {
                    log: log.clone(),
                    log_sha256,
                    rig,
                    fit: f,
                };
                fits.push(a.fit_record()?);
            }
            (r, _) => {
                let e = match r {
                    Err(e) => e.to_string(),
                    Ok(_) => format!("{}: cannot be read again for its sha256", log.display()),
                };
                progress.error(&e);
                failed.push(log.display().to_string());
                fits.push(artifact::failed_record(log, sha(log).as_deref(), &e));
            }
        }
    }
    let json = FitJson {
        shard: job.shard.map(|(k, n)| FitShardJson {
            shard: k,
            shards: n,
            log_sha256s: all_shas,
        }),
        fits,
    };
    if let Some(path) = &job.out {
        crate::io::json::write_pretty(path, &crate::io::json::to_value(&json))?;
    }
    Ok(FitOutcome {
        json,
        logs: logs.len(),
        failed,
    })
}

/// One human-readable line per log.
pub fn summary(log: &Path, f: &LogFit) -> String {
    let e = &f.fit;
    let law = f.law();
    let fmt = |x: Option<f64>| x.map_or("-".to_string(), |v| format!("{v:.4}"));
    let mut s = format!(
        "{}: law {}, rho_s {}, rho_d {}, D* {}, Rs {} N, Rd {} N, A {:.4} mm ({} estimate)",
        log.display(),
        f.kind().as_str(),
        fmt(f.rho_s()),
        fmt(f.rho_d()),
        fmt(f.dstar()),
        fmt(f.rs_n()),
        fmt(law.map(|l| l.rd_n)),
        f.drive.amplitude_m * 1e3,
        f.estimate.as_str()
    );
    if e.stuck {
        s.push_str(&format!(
            ", stuck (rho_s >= {})",
            fmt(f.rho_s_lower_bound())
        ));
    }
    if f.never_sticks() {
        s.push_str(", never sticks");
    }
    s.push_str(if f.adequate() {
        ", adequate"
    } else {
        ", NOT ADEQUATE"
    });
    for w in &f.warnings {
        s.push_str(&format!("\n  warning: {w}"));
    }
    s
}
