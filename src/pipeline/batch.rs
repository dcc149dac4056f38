//! The `batch` job: one pad at several normal forces. Checks and fits
//! every log ([`super::checks::fit_characteristic_logs`], in memory-planned
//! rounds), takes saved fits as they are, refuses mixed rigs, counts the
//! same test once, compares ([`crate::batch`]), and writes the report and
//! the JSON result ([`BatchJson`]) through the write transaction
//! ([`crate::io::txn`]) — nothing where a log or the batch failed.

use super::checks;
use super::Progress;
use crate::batch::{self as vb, Batch, BatchOptions};
use crate::identify::artifact::{self, FitEntry, FitRecord, FitSet};
use crate::identify::{IdentifyOptions, LogFit};
use crate::ingest::RigMeta;
use crate::report::{batch_plot, batch_view, html, views};
use serde::Serialize;
use serde_json::{Map, Value};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// One batch comparison.
#[derive(Debug, Clone)]
pub struct BatchJob {
    /// Characteristic logs of one pad at several normal forces.
    pub logs: Vec<PathBuf>,
    /// Saved fits (`fit --out` or `merge` of fit parts): they join the
    /// batch first; a log also given is fitted only if no record has its
    /// sha256.
    pub fits: Option<PathBuf>,
    /// Write the HTML report into this directory.
    pub report: Option<PathBuf>,
    /// Write the JSON result to this file.
    pub out: Option<PathBuf>,
    /// How each log is fitted.
    pub identify: IdentifyOptions,
    /// The comparison's options (checked first by [`run_batch`]).
    pub options: BatchOptions,
    /// Use logs whose rig constants differ by more than 1 %.
    pub allow_mixed_rigs: bool,
    /// The command line shown on the report.
    pub command: String,
}

/// The batch keys of a batch that failed: each `null`, with the reason.
#[derive(Debug, Clone, Serialize)]
pub struct FailedBatchJson {
    /// `null`.
    pub mu_s: Option<f64>,
    /// `null`.
    pub mu_d: Option<f64>,
    /// `null`.
    pub mu_s_interval: Option<f64>,
    /// `null`.
    pub mu_d_interval: Option<f64>,
    /// `null`.
    pub recommended_normal_force_n: Option<f64>,
    /// `null`.
    pub recommended_normal_force_interval_n: Option<f64>,
    /// `null`.
    pub recommended_rho_s: Option<f64>,
    /// `null`.
    pub worst_amplitude1: Option<f64>,
    /// `null`.
    pub cliff_rho_s: Option<f64>,
    /// Why the batch failed.
    pub error: String,
}

/// The batch keys of the `batch` object.
#[derive(Debug, Clone, Serialize)]
#[serde(untagged)]
pub enum BatchKeys {
    /// The comparison's keys ([`Batch::to_json_map`]).
    Done(Map<String, Value>),
    /// The comparison failed.
    Failed(FailedBatchJson),
}

/// The `batch --json` object.
#[derive(Debug, Clone, Serialize)]
pub struct BatchJson {
    /// One fit record per log (saved fits first), or its error.
    pub fits: Vec<FitRecord>,
    /// The logs counted once already (the same test given twice).
    pub duplicates: Vec<String>,
    /// The comparison's keys (flattened).
    #[serde(flatten)]
    pub batch: BatchKeys,
    /// The report's index page, where one was written.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub report: Option<String>,
    /// Wall seconds of the job.
    pub seconds: f64,
}

/// What [`run_batch`] produced. Where `failure` is set, nothing was
/// written.
#[derive(Debug)]
pub struct BatchOutcome {
    /// The JSON result (as written to `out`).
    pub json: BatchJson,
    /// The comparison (None: it failed).
    pub batch: Option<Batch>,
    /// One line per failure: each log that could not be fitted, then the
    /// comparison's own.
    pub errors: Vec<String>,
    /// Why the job failed (which logs could not be fitted, or the
    /// comparison), if it did.
    pub failure: Option<crate::Error>,
}

/// The fit of one log of a batch, with its rig record.
type Fitted = (PathBuf, crate::Result<(RigMeta, LogFit)>);

/// The fits of a batch, per log.
type Fits = [Fitted];

/// The batch keys of the JSON object (`null` with an `error` where the
/// batch failed).
fn batch_keys(result: &crate::Result<Batch>) -> BatchKeys {
    match result {
        Ok(b) => BatchKeys::Done(b.to_json_map()),
        Err(e) => BatchKeys::Failed(FailedBatchJson {
            mu_s: None,
            mu_d: None,
            mu_s_interval: None,
            mu_d_interval: None,
            recommended_normal_force_n: None,
            recommended_normal_force_interval_n: None,
            recommended_rho_s: None,
            worst_amplitude1: None,
            cliff_rho_s: None,
            error: e.to_string(),
        }),
    }
}

/// The error of a batch that failed: which logs could not be fitted.
fn failure(fits: &Fits, why: Option<&crate::Error>) -> crate::Error {
    let failed_logs: Vec<String> = fits
        .iter()
        .filter(|(_, r)| r.is_err())
        .map(|(p, _)| p.display().to_string())
        .collect();
    let what = if failed_logs.is_empty() {
        // The last line says why (it is also reported above).
        match why {
            Some(e) => format!("the batch comparison failed ({e})"),
            None => "the batch comparison failed".to_string(),
        }
    } else {
        format!(
            "{} of {} logs could not be fitted ({})",
            failed_logs.len(),
            fits.len(),
            failed_logs.join(", ")
        )
    };
    crate::Error::Failed { what }
}

/// The fits of the batch, saved ones first (in their file's order), then
/// the logs fitted now, with each log's sha256.
fn fits_of(
    job: &BatchJob,
    progress: &dyn Progress,
) -> crate::Result<(Vec<Fitted>, Vec<Option<String>>)> {
    // Earlier fits, and which of the logs given they cover.
    let (saved, covered) = match &job.fits {
        Some(path) => {
            let set = FitSet::read(path)?;
            let covered = set.match_logs(&job.logs)?;
            (set.entries, covered)
        }
        None => (Vec::new(), vec![None; job.logs.len()]),
    };
    let to_fit: Vec<PathBuf> = job
        .logs
        .iter()
        .zip(&covered)
        .filter(|(_, c)| c.is_none())
        .map(|(p, _)| p.clone())
        .collect();
    progress.more(to_fit.len() as u64);
    progress.stage("fitting logs");
    // Every log is checked first: a log that cannot be read or is not a
    // characteristic test stops the batch before any fitting.
    progress.stage("reading and fitting logs");
    let fitted = checks::fit_characteristic_logs(&to_fit, &job.identify, &|| progress.advance(1))
        .inspect_err(|_| progress.done())?;
    let mut fits: Vec<Fitted> = Vec::new();
    let mut shas: Vec<Option<String>> = Vec::new();
    for e in saved {
        shas.push(e.log_sha256().map(str::to_string));
        fits.push(match e {
            FitEntry::Fitted(a) => (a.log, Ok((a.rig, a.fit))),
            FitEntry::Failed(f) => (
                f.log.clone(),
                Err(crate::Error::Skipped {
                    path: f.log,
                    stage: "its saved fit failed",
                    cause: f.error,
                }),
            ),
        });
    }
    for (p, f) in to_fit.iter().zip(fitted) {
        shas.push(artifact::sha256_file(p).ok());
        fits.push((p.clone(), f));
    }
    Ok((fits, shas))
}

/// Runs the batch. A log that cannot be read, or is not a characteristic
/// test, stops it before any fitting (an error); a log that cannot be
/// fitted, or a comparison that fails, gives an outcome with `failure`
/// and writes nothing. Otherwise the report and `out` are written.
pub fn run_batch(job: &BatchJob, progress: &dyn Progress) -> crate::Result<BatchOutcome> {
    let t0 = Instant::now();
    job.options.check().map_err(|m| crate::Error::Input {
        path: PathBuf::from("batch options"),
        msg: m.to_string(),
    })?;
    let (fits, shas) = fits_of(job, progress)?;
    let mut errors = Vec::new();
    let mut good: Vec<(PathBuf, LogFit)> = Vec::new();
    let mut rigs: Vec<(PathBuf, RigMeta)> = Vec::new();
    for (p, r) in &fits {
        match r {
            Ok((rig, f)) => {
                good.push((p.clone(), f.clone()));
                rigs.push((p.clone(), rig.clone()));
            }
            Err(e) => errors.push(e.to_string()),
        }
    }
    checks::refuse_mixed_rigs(&rigs, job.allow_mixed_rigs).inspect_err(|_| progress.done())?;
    // The same test given twice counts once.
    let (duplicates, dup_warnings) = checks::drop_duplicates(&mut good, &mut rigs);
    let result: crate::Result<Batch> = if good.is_empty() {
        Err(vb::BatchError::NothingFitted.into())
    } else {
        let rig = &rigs[0].1;
        progress.stage("worst-case amplitudes");
        progress.more((job.options.rho_points * 3 + good.len() + 9) as u64);
        vb::batch_with_progress(&good, rig, &job.options, &|n| progress.advance(n)).map(|mut b| {
            let mut w = dup_warnings;
            w.extend(vb::rig_warnings(&rigs));
            w.append(&mut b.warnings);
            b.warnings = w;
            b
        })
    };
    progress.done();
    let fit_entries: Vec<FitRecord> = fits
        .iter()
        .zip(&shas)
        .map(|((p, r), sha)| match r {
            Ok((rig, f)) => artifact::record(f, p, sha.as_deref(), rig),
            Err(e) => artifact::failed_record(p, sha.as_deref(), &e.to_string()),
        })
        .collect();
    let mut json = BatchJson {
        fits: fit_entries,
        duplicates,
        batch: batch_keys(&result),
        report: None,
        seconds: 0.0,
    };
    if !errors.is_empty() || result.is_err() {
        // A failed job writes no file.
        let failure = failure(&fits, result.as_ref().err());
        errors.extend(result.err().map(|e| e.to_string()));
        json.seconds = t0.elapsed().as_secs_f64();
        return Ok(BatchOutcome {
            json,
            batch: None,
            errors,
            failure: Some(failure),
        });
    }
    let batch = result.ok();
    if let Some(dir) = &job.report {
        let index = write_report(dir, job, &fits, batch.as_ref(), &errors)?;
        progress.say(&format!("report: {}", index.display()));
        json.report = Some(index.display().to_string());
    }
    json.seconds = t0.elapsed().as_secs_f64();
    if let Some(path) = &job.out {
        crate::io::json::write_pretty(path, &crate::io::json::to_value(&json))?;
    }
    Ok(BatchOutcome {
        json,
        batch,
        errors,
        failure: None,
    })
}

/// Writes the report directory: the batch section with its figure and one
/// section per fit.
fn write_report(
    dir: &Path,
    job: &BatchJob,
    fits: &Fits,
    batch: Option<&Batch>,
    errors: &[String],
) -> crate::Result<PathBuf> {
    let inputs: Vec<PathBuf> = job.logs.iter().chain(&job.fits).cloned().collect();
    let rd = html::ReportDir::create(dir, &inputs)?;
    let mut page = html::Page {
        title: "Normal-force settings of one pad".into(),
        version: env!("CARGO_PKG_VERSION").into(),
        command: job.command.clone(),
        ..html::Page::default()
    };
    if let Some(b) = batch {
        let name = "batch.svg";
        batch_plot::batch_figure(
            b,
            "Worst-case main-mass amplitude against normal force",
            &rd.file(name)?,
        )?;
        page.batch = Some(batch_view::batch_view(b, Some(name.to_string())));
    }
    for (p, r) in fits {
        page.fits.push(match r {
            Ok((rig, f)) => views::fit_view(p, f, rig.notes.as_deref(), None),
            Err(e) => views::fit_error_view(p, &e.to_string()),
        });
    }
    page.warnings = errors.to_vec();
    page.inputs = inputs
        .iter()
        .filter_map(|p| html::input_file(p).ok())
        .collect();
    rd.write_page(&page)
}
