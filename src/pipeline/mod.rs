//! The whole pipeline on an experiment plan: ingest → fit → validate →
//! batch, with its report. The plan says which logs belong together, which
//! the logs themselves cannot:
//!
//! ```toml
//! title = "Rig A, pad 1"
//! # Paths are relative to the plan file.
//! fit = ["law_coulomb.mcap"]            # characteristic logs fitted on their own
//! batch = ["char_N1.2.mcap", "char_N4.mcap"]   # one pad at several normal forces
//! [[validate]]
//! characteristic = "char_N4.mcap"
//! sweep = "sweep_stepped_N4.mcap"
//! # fits = "fits.json"   # reuse earlier fits (`fit --out`, `merge`)
//! ```
//!
//! [`Plan::read`] is the plan stage (parse, check, resolve paths);
//! [`run`] reads and fits every log once, in parallel, then validates and
//! compares in parallel. A log that fails keeps its error in the
//! [`PipelineReport`] and the rest completes; results do not depend on the
//! thread count.
//!
//! Every command's work is a typed job here, run by one door that reports
//! through [`Progress`] and writes through the write transaction
//! ([`crate::io::txn`]): [`job::run_job`] (a plan, with its report),
//! [`validate::run_validate`], [`batch::run_batch`], [`sweep::run_sweep`],
//! [`merge::run_merge`], [`fit::run_fit`], [`synth::run_synth`],
//! [`simulate::run_simulate`], [`characteristic::run_characteristic`],
//! [`read::run_ingest`] and [`bench::run_bench`], each with its JSON
//! object. [`Job`] names any of them and [`execute`] is the one dispatch
//! the command line calls.

pub mod batch;
pub mod bench;
pub mod characteristic;
pub mod checks;
pub mod dispatch;
pub mod fit;
pub mod job;
pub mod merge;
pub mod read;
pub mod shape;
pub mod simulate;
pub mod sweep;
pub mod synth;
pub mod validate;

pub use dispatch::{execute, Job, Outcome};

use crate::batch::{self as vb, Batch};
use crate::identify::artifact::FitRecord;
use crate::identify::{self, IdentifyOptions, LogFit};
use crate::ingest::{self, IngestOptions, RigMeta, Run};
use crate::report::characteristic_plot::CharacteristicPoints;
use crate::report::{batch_plot, batch_view, html, sections, views};
use crate::validate::{self as vd, ValidateOptions, Validation};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use serde_json::Value;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// One validation of the plan: a characteristic log's law against a sweep.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Pair {
    /// The characteristic log whose law predicts the sweep.
    pub characteristic: PathBuf,
    /// The sweep log.
    pub sweep: PathBuf,
}

/// An experiment plan (paths resolved against the plan's folder).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Plan {
    /// Report title.
    #[serde(default)]
    pub title: Option<String>,
    /// Characteristic logs fitted on their own.
    #[serde(default)]
    pub fit: Vec<PathBuf>,
    /// One pad at several normal forces.
    #[serde(default)]
    pub batch: Vec<PathBuf>,
    /// Validations.
    #[serde(default)]
    pub validate: Vec<Pair>,
    /// Earlier fits to reuse (`fit --out` or `merge` of fit parts): a
    /// characteristic log of the plan whose sha256 one of its records has is
    /// not refitted.
    #[serde(default)]
    pub fits: Option<PathBuf>,
}

/// Largest plan file (bytes): a plan names logs, it is never this large.
pub const MAX_PLAN_BYTES: u64 = 4_000_000;

/// Most entries of a plan (fit, batch and [[validate]] together): each
/// keeps a log's rig record, fit, figure points and predictions to the end
/// (a plan of 10 000 entries grew to 7.8 GB when each kept its log), so
/// this many fit the memory budget.
pub const MAX_PLAN_ENTRIES: usize = 1000;

fn plan_err(path: &Path, msg: impl Into<String>) -> crate::Error {
    crate::Error::Input {
        path: path.to_path_buf(),
        msg: msg.into(),
    }
}

impl Plan {
    /// Reads and checks the plan at `path`; relative paths become relative
    /// to the plan's folder.
    ///
    /// ```
    /// let plan = stickslip::pipeline::Plan::read("datasets/plan.toml".as_ref())?;
    /// assert!(plan.logs().iter().all(|p| p.starts_with("datasets")));
    /// assert!(!plan.batch.is_empty() && !plan.validate.is_empty());
    /// # Ok::<(), stickslip::Error>(())
    /// ```
    pub fn read(path: &Path) -> crate::Result<Plan> {
        let text = crate::io::paths::read_small_text(path, "plan", MAX_PLAN_BYTES)?;
        let mut plan: Plan = toml::from_str(&text)
            .map_err(|e| plan_err(path, format!("not a valid plan: {}", e.message())))?;
        let base = path.parent().unwrap_or(Path::new(""));
        let fix = |p: &mut PathBuf| {
            if p.is_relative() {
                *p = base.join(&*p);
            }
        };
        plan.fit.iter_mut().for_each(fix);
        plan.batch.iter_mut().for_each(fix);
        plan.fits.iter_mut().for_each(fix);
        for v in &mut plan.validate {
            fix(&mut v.characteristic);
            fix(&mut v.sweep);
        }
        let entries = plan.fit.len() + plan.batch.len() + plan.validate.len();
        if entries > MAX_PLAN_ENTRIES {
            return Err(plan_err(
                path,
                format!(
                    "the plan has {entries} entries (fit, batch, [[validate]]); at most {MAX_PLAN_ENTRIES} fit {} (each keeps a log's rig record, fit, figure points and prediction, up to about {} MB): split it into several plans",
                    crate::io::budget::budget_text(),
                    crate::io::budget::MEMORY_BUDGET_BYTES / MAX_PLAN_ENTRIES as u64 / 1_000_000
                ),
            ));
        }
        // A sweep is predicted, not fitted: a log named as both would have
        // no fit where the plan asks for one.
        let characteristic: Vec<&PathBuf> = plan
            .fit
            .iter()
            .chain(&plan.batch)
            .chain(plan.validate.iter().map(|v| &v.characteristic))
            .collect();
        if let Some(v) = plan
            .validate
            .iter()
            .find(|v| characteristic.contains(&&v.sweep))
        {
            return Err(plan_err(
                path,
                format!(
                    "{} is a [[validate]] sweep and also a characteristic log (fit, batch or a characteristic): a log is fitted or predicted, not both",
                    v.sweep.display()
                ),
            ));
        }
        if plan.fit.is_empty() && plan.batch.is_empty() && plan.validate.is_empty() {
            return Err(plan_err(
                path,
                "the plan names no logs (keys: fit, batch, [[validate]])",
            ));
        }
        Ok(plan)
    }

    /// Every log of the plan once, in plan order (batch, fit, validations).
    pub fn logs(&self) -> Vec<PathBuf> {
        let mut logs: Vec<PathBuf> = Vec::new();
        let mut add = |p: &PathBuf| {
            if !logs.contains(p) {
                logs.push(p.clone());
            }
        };
        self.batch.iter().for_each(&mut add);
        self.fit.iter().for_each(&mut add);
        for v in &self.validate {
            add(&v.characteristic);
            add(&v.sweep);
        }
        logs
    }

    /// The logs that are fitted: every log but the sweeps, in plan order.
    pub fn characteristic_logs(&self) -> Vec<PathBuf> {
        let sweeps: Vec<&PathBuf> = self.validate.iter().map(|v| &v.sweep).collect();
        self.logs()
            .into_iter()
            .filter(|p| !sweeps.contains(&p))
            .collect()
    }

    /// Units of work [`run`] reports to its [`Progress`]: one per log read,
    /// per fit, per validation, and one for the batch.
    pub fn steps(&self) -> u64 {
        (self.logs().len()
            + self.characteristic_logs().len()
            + self.validate.len()
            + usize::from(!self.batch.is_empty())) as u64
    }
}

/// Options of [`run`].
#[derive(Debug, Clone)]
pub struct Options {
    /// Most laws drawn from each fit's uncertainty for the prediction
    /// bands.
    pub samples: usize,
    /// Bootstrap standard error to which the draws fix the replay
    /// coverages (see [`crate::validate::predict::BandPrecision`]).
    pub band_coverage_se: f64,
    /// Use logs whose rig constants differ by more than 1 % together.
    pub allow_mixed_rigs: bool,
    /// Keep what the report's characteristic figures draw of each fitted
    /// log ([`LogRecord::figure`]); without it [`PipelineReport::write_report`]
    /// shows the fits without figures.
    pub figures: bool,
    /// Keep the sweeps from their reading to their validation where the
    /// plan's logs fit the memory budget together (one round of reads);
    /// otherwise, or without it, each sweep is read again when validated.
    pub hold_sweeps: bool,
}

impl Default for Options {
    fn default() -> Self {
        Self {
            samples: ValidateOptions::default().predict.samples,
            band_coverage_se: ValidateOptions::default().predict.band_coverage_se,
            allow_mixed_rigs: false,
            figures: true,
            hold_sweeps: true,
        }
    }
}

/// Where a job ([`run`], [`validate::run_validate`], [`batch::run_batch`],
/// …) reports its progress (e.g. a progress bar) and the lines it has for
/// a person.
pub trait Progress: Sync {
    /// A new stage starts.
    fn stage(&self, _what: &str) {}
    /// `n` units of work (see [`Plan::steps`]) are done.
    fn advance(&self, _n: u64) {}
    /// `n` more units of work are planned from here on (a job that learns
    /// its work as it goes: the batch's worst-case grid once its logs are
    /// fitted).
    fn more(&self, _n: u64) {}
    /// The work a display counts is done: it may go (the job's last lines
    /// follow).
    fn done(&self) {}
    /// One line for a person (e.g. `reading logs`, `report: …`); a quiet
    /// display (`--json`) drops it.
    fn say(&self, _line: &str) {}
    /// A failure that does not stop the job (a log that could not be
    /// fitted), said where it happens; every display shows it.
    fn error(&self, _line: &str) {}
}

/// No progress display.
impl Progress for () {}

/// Wall seconds per stage of [`run`] (and of the report, when written).
/// `validate` and `batch` run side by side: each is its own wall time from
/// when a thread takes it up, and together they overlap (`overlapping`
/// names them; `side_by_side` is their joint wall time), so the stages do
/// not add up to the total.
#[derive(Debug, Clone, Default, serde::Serialize)]
pub struct StageSeconds {
    /// Reading every log (in parallel, in rounds that fit the memory).
    pub ingest: f64,
    /// Fitting every characteristic log once (in parallel, each round's
    /// logs right after their reading).
    pub fit: f64,
    /// All validations (beside the batch).
    pub validate: f64,
    /// The batch comparison (beside the validations).
    pub batch: f64,
    /// Wall time of the overlapping stages together (from their start to
    /// the last one's end).
    pub side_by_side: f64,
    /// Writing the report (figures and page); 0 without `--report`.
    pub report: f64,
    /// Stages that run at the same time.
    pub overlapping: Vec<&'static str>,
}

/// What [`run`] keeps of a log once it is read (and fitted): its rig
/// record and what its report figure draws; the log's samples go.
#[derive(Debug, Clone)]
pub struct LogRecord {
    /// The log's rig record.
    pub rig: RigMeta,
    /// What the characteristic figure draws (a fitted characteristic log,
    /// with [`Options::figures`]).
    pub figure: Option<CharacteristicPoints>,
}

/// Everything [`run`] produced, per log and per validation, with the
/// errors of what failed (each reported once).
#[derive(Debug)]
pub struct PipelineReport {
    /// Wall seconds per stage.
    pub seconds: StageSeconds,
    /// Every log of the plan as read (what is kept of it).
    pub logs: BTreeMap<PathBuf, crate::Result<LogRecord>>,
    /// The fit of every characteristic log.
    pub fits: BTreeMap<PathBuf, crate::Result<LogFit>>,
    /// The validations, in plan order.
    pub validations: Vec<(Pair, crate::Result<Validation>)>,
    /// The batch comparison (None: the plan has no batch).
    pub batch: Option<crate::Result<Batch>>,
    /// One line per failure (read, fit, validation, batch), each once.
    pub errors: Vec<String>,
    /// The sha256 of every characteristic log (None: it could not be read).
    pub log_sha256: BTreeMap<PathBuf, Option<String>>,
}

/// The JSON result of a plan ([`PipelineReport::plan_json`]; the keys
/// of `run --json` besides the report and the seconds).
#[derive(Debug, Clone, Serialize)]
pub struct PlanJson {
    /// The plan file.
    pub plan: String,
    /// One record per characteristic log, in plan order (a fit's record,
    /// or its `error`).
    pub fits: Vec<FitRecord>,
    /// One entry per validation, in plan order.
    pub validations: Vec<ValidationEntryJson>,
    /// The batch comparison (absent: the plan has no batch).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub batch: Option<PlanBatchJson>,
}

/// One validation of a plan in its JSON result.
#[derive(Debug, Clone, Serialize)]
#[serde(untagged)]
pub enum ValidationEntryJson {
    /// The validation's object ([`Validation::to_json`]).
    Done(Value),
    /// A validation that failed (or whose characteristic log failed).
    Failed(FailedPairJson),
}

/// A validation that failed, in a plan's JSON result.
#[derive(Debug, Clone, Serialize)]
pub struct FailedPairJson {
    /// The characteristic log.
    pub characteristic: String,
    /// The sweep.
    pub sweep: String,
    /// Why it failed.
    pub error: String,
}

/// A plan's batch comparison in its JSON result.
#[derive(Debug, Clone, Serialize)]
#[serde(untagged)]
pub enum PlanBatchJson {
    /// The comparison's keys ([`Batch::to_json_map`]) with the plan's
    /// batch logs.
    Done {
        /// The comparison's keys (flattened).
        #[serde(flatten)]
        batch: serde_json::Map<String, Value>,
        /// The plan's batch logs, in plan order (this key replaces one of
        /// the comparison's of the same name).
        logs: Vec<String>,
    },
    /// The comparison failed.
    Failed {
        /// Why.
        error: String,
    },
}

/// Runs the plan: reads every log once, in rounds whose planned memory
/// fits the budget, and fits each round's characteristic logs as soon as
/// they are read, keeping only their fits and [`LogRecord`]s (so a plan of
/// many long logs streams); then validates and compares (batch) side by
/// side. Fails as a whole only where the logs that could be read come from
/// different rigs (unless `opts.allow_mixed_rigs`): refused once such a log
/// is read, before its round is fitted.
pub fn run(plan: &Plan, opts: &Options, progress: &dyn Progress) -> crate::Result<PipelineReport> {
    let logs = plan.logs();
    let chars = plan.characteristic_logs();
    // Earlier fits: the characteristic logs they cover are not refitted.
    let mut saved: BTreeMap<PathBuf, std::result::Result<LogFit, String>> = BTreeMap::new();
    if let Some(path) = &plan.fits {
        let set = identify::artifact::FitSet::read(path)?;
        let covered = set.match_logs(&chars)?;
        for (p, i) in chars.iter().zip(covered) {
            if let Some(e) = i.and_then(|i| set.entries.get(i)) {
                saved.insert(
                    p.clone(),
                    match e {
                        identify::artifact::FitEntry::Fitted(a) => Ok(a.fit.clone()),
                        identify::artifact::FitEntry::Failed(f) => Err(f.error.clone()),
                    },
                );
            }
        }
    }
    let log_sha256: BTreeMap<PathBuf, Option<String>> = chars
        .par_iter()
        .map(|p| (p.clone(), identify::artifact::sha256_file(p).ok()))
        .collect();
    let mut seconds = StageSeconds {
        overlapping: vec!["validate", "batch"],
        ..StageSeconds::default()
    };
    // Only a validation's sweep is read again as recorded (its amplitudes);
    // every other log is used on its common grid (the fit, the report's
    // characteristic), so its channels as recorded go once it is read.
    let sweeps: std::collections::BTreeSet<&PathBuf> =
        plan.validate.iter().map(|v| &v.sweep).collect();
    // Read in consecutive rounds whose planned memory fits the budget
    // together (each log's samples counted before it is decoded, as `fit`
    // does; a log of unknown length plans the whole budget), the logs of a
    // round in parallel, then fitted: long logs are not all held at once.
    let budget = IdentifyOptions::default().memory_bytes;
    let planned = identify::planned_fit_memory(&logs, budget);
    let mut records: BTreeMap<PathBuf, crate::Result<LogRecord>> = BTreeMap::new();
    let mut fits: BTreeMap<PathBuf, crate::Result<LogFit>> = BTreeMap::new();
    let mut figure_errors: Vec<String> = Vec::new();
    let rounds = crate::limits::rounds(&planned, budget);
    // Sweeps kept from their reading to their validation: only where every
    // log fits the budget together (their planned memory counted in it);
    // the others are read again when validated.
    let hold = opts.hold_sweeps && rounds.len() <= 1;
    let mut held: BTreeMap<PathBuf, Run> = BTreeMap::new();
    let mut read_rigs: Vec<(PathBuf, RigMeta)> = Vec::new();
    for round in rounds {
        let clock = std::time::Instant::now();
        progress.stage("reading logs");
        let read: Vec<(PathBuf, crate::Result<Run>)> = logs[round]
            .par_iter()
            .map(|p| {
                let mut r = ingest::read(p, &IngestOptions::default()).map_err(crate::Error::from);
                if let (Ok(run), false) = (&mut r, sweeps.contains(p)) {
                    run.channels = Vec::new();
                }
                progress.advance(1);
                (p.clone(), r)
            })
            .collect();
        // One rig: every log of the plan read so far (refused before the
        // round is fitted).
        read_rigs.extend(
            read.iter()
                .filter_map(|(p, r)| r.as_ref().ok().map(|r| (p.clone(), r.rig.clone()))),
        );
        checks::refuse_mixed_rigs(&read_rigs, opts.allow_mixed_rigs)?;
        seconds.ingest += clock.elapsed().as_secs_f64();

        let clock = std::time::Instant::now();
        progress.stage("fitting friction laws");
        let round_fits = fit_round(&read, &sweeps, &saved, progress);
        // What is kept of each log: its rig record and, for a fitted
        // characteristic log, what its figure draws (in parallel).
        let figures: Vec<(Option<CharacteristicPoints>, Option<String>)> = read
            .par_iter()
            .map(|(p, r)| match (r, round_fits.get(p)) {
                (Ok(run), Some(Ok(f))) if opts.figures => match sections::fit_points(run, f) {
                    Ok(points) => (Some(points), None),
                    Err(e) => (None, Some(e.to_string())),
                },
                _ => (None, None),
            })
            .collect();
        fits.extend(round_fits);
        for ((p, r), (figure, error)) in read.into_iter().zip(figures) {
            figure_errors.extend(error);
            let rec = r.map(|run| {
                let rig = run.rig.clone();
                if hold && sweeps.contains(&p) {
                    held.insert(p.clone(), run);
                }
                LogRecord { rig, figure }
            });
            records.insert(p, rec);
        }
        seconds.fit += clock.elapsed().as_secs_f64();
    }

    // The validations and the batch need nothing from each other: they run
    // side by side (each collected in order).
    progress.stage("validating against sweeps; batch: worst-case amplitudes");
    let mut vopts = ValidateOptions::default();
    vopts.predict.samples = opts.samples;
    vopts.predict.band_coverage_se = opts.band_coverage_se;
    let validate_all = || -> (Vec<(Pair, crate::Result<Validation>)>, f64) {
        let clock = std::time::Instant::now();
        // Sweeps not held are read again, in rounds that fit the memory.
        let planned_v: Vec<u64> = plan
            .validate
            .iter()
            .map(|v| match logs.iter().position(|p| p == &v.sweep) {
                Some(i) if !held.contains_key(&v.sweep) => planned[i],
                _ => 0,
            })
            .collect();
        let mut out = Vec::with_capacity(plan.validate.len());
        for round in crate::limits::rounds(&planned_v, budget) {
            let done: Vec<(Pair, crate::Result<Validation>)> = plan.validate[round]
                .par_iter()
                .map(|pair| {
                    let r = validate_pair(pair, &records, &fits, &held, &vopts);
                    progress.advance(1);
                    (pair.clone(), r)
                })
                .collect();
            out.extend(done);
        }
        (out, clock.elapsed().as_secs_f64())
    };
    let run_batch = || {
        let clock = std::time::Instant::now();
        let b = (!plan.batch.is_empty()).then(|| batch_of(plan, &records, &fits));
        (b, clock.elapsed().as_secs_f64())
    };
    let clock = std::time::Instant::now();
    let ((validations, tv), (batch, tb)) = rayon::join(validate_all, run_batch);
    seconds.side_by_side = clock.elapsed().as_secs_f64();
    (seconds.validate, seconds.batch) = (tv, tb);
    drop(held);
    let mut errors: Vec<String> = records
        .values()
        .filter_map(|r| r.as_ref().err().map(|e| e.to_string()))
        .collect();
    // A log that was not read is reported once, by its read error.
    errors.extend(fits.values().filter_map(|r| match r {
        Err(crate::Error::Skipped { .. }) | Ok(_) => None,
        Err(e) => Some(e.to_string()),
    }));
    errors.extend(figure_errors);
    progress.advance(1);
    errors.extend(
        validations
            .iter()
            .filter_map(|(_, r)| r.as_ref().err().map(|e| e.to_string())),
    );
    if let Some(Err(e)) = &batch {
        errors.push(e.to_string());
    }
    Ok(PipelineReport {
        seconds,
        logs: records,
        fits,
        validations,
        batch,
        errors,
        log_sha256,
    })
}

/// The fits of the characteristic logs of one round of reads (`read`, in
/// plan order): a saved fit is used as it is, a log that was read is
/// fitted (in parallel, panic-guarded), one that was not keeps its read
/// error.
fn fit_round(
    read: &[(PathBuf, crate::Result<Run>)],
    sweeps: &std::collections::BTreeSet<&PathBuf>,
    saved: &BTreeMap<PathBuf, std::result::Result<LogFit, String>>,
    progress: &dyn Progress,
) -> BTreeMap<PathBuf, crate::Result<LogFit>> {
    let chars: Vec<&(PathBuf, crate::Result<Run>)> =
        read.iter().filter(|(p, _)| !sweeps.contains(p)).collect();
    let to_fit: Vec<&Run> = chars
        .iter()
        .filter(|(p, _)| !saved.contains_key(p))
        .filter_map(|(_, r)| r.as_ref().ok())
        .collect();
    let mut fitted = identify::fit_runs(&to_fit, &IdentifyOptions::default(), &|| {
        progress.advance(1)
    })
    .into_iter();
    let mut fits = BTreeMap::new();
    for (p, r) in chars {
        let f = if let Some(s) = saved.get(p) {
            progress.advance(1);
            s.clone().map_err(|cause| crate::Error::Skipped {
                path: p.clone(),
                stage: "its saved fit failed",
                cause,
            })
        } else {
            match r {
                // One fit per log read, in order: only a log that was read
                // takes the next fit.
                Ok(_) => fitted.next().unwrap_or_else(|| {
                    Err(crate::Error::Identify {
                        path: p.clone(),
                        source: identify::IdentifyError::Internal,
                    })
                }),
                Err(e) => {
                    progress.advance(1);
                    Err(crate::Error::Skipped {
                        path: p.clone(),
                        stage: "not read",
                        cause: e.to_string(),
                    })
                }
            }
        };
        fits.insert(p.clone(), f);
    }
    fits
}

/// One validation: the characteristic log's fit and rig record against
/// its sweep (held, or read again).
fn validate_pair(
    pair: &Pair,
    records: &BTreeMap<PathBuf, crate::Result<LogRecord>>,
    fits: &BTreeMap<PathBuf, crate::Result<LogFit>>,
    held: &BTreeMap<PathBuf, Run>,
    vopts: &ValidateOptions,
) -> crate::Result<Validation> {
    let skipped = |e: &dyn std::fmt::Display| crate::Error::Skipped {
        path: pair.sweep.clone(),
        stage: "not validated",
        cause: e.to_string(),
    };
    let (f, cr) = match (
        &fits[&pair.characteristic],
        &records[&pair.characteristic],
        &records[&pair.sweep],
    ) {
        (Ok(f), Ok(cr), Ok(_)) => (f, cr),
        (Err(e), _, _) => return Err(skipped(e)),
        (_, Err(e), _) | (_, _, Err(e)) => return Err(skipped(e)),
    };
    let reread;
    let sweep = match held.get(&pair.sweep) {
        Some(run) => run,
        None => {
            reread =
                ingest::read(&pair.sweep, &IngestOptions::default()).map_err(crate::Error::from)?;
            &reread
        }
    };
    vd::validate_fit(f, &pair.characteristic, &cr.rig, sweep, vopts)
}

/// The batch of the plan: its logs that were read and fitted, each test
/// once (a stuck or never-sticking log enters as a bound).
fn batch_of(
    plan: &Plan,
    records: &BTreeMap<PathBuf, crate::Result<LogRecord>>,
    fits: &BTreeMap<PathBuf, crate::Result<LogFit>>,
) -> crate::Result<Batch> {
    // The logs read and fitted, each with its rig record.
    let (mut good, mut rigs): (Vec<_>, Vec<_>) = plan
        .batch
        .iter()
        .filter_map(|p| match (&fits[p], &records[p]) {
            (Ok(f), Ok(r)) => Some(((p.clone(), f.clone()), (p.clone(), r.rig.clone()))),
            _ => None,
        })
        .unzip();
    let (_, dup_warnings) = checks::drop_duplicates(&mut good, &mut rigs);
    if rigs.is_empty() {
        rigs = plan
            .batch
            .iter()
            .filter_map(|p| records[p].as_ref().ok().map(|r| (p.clone(), r.rig.clone())))
            .collect();
    }
    let Some((_, rig)) = rigs.first() else {
        return Err(vb::BatchError::NothingRead.into());
    };
    if good.is_empty() {
        return Err(vb::BatchError::NothingFitted.into());
    }
    let mut b = vb::batch(&good, rig, &vb::BatchOptions::default())?;
    let mut w = dup_warnings;
    w.extend(vb::rig_warnings(&rigs));
    w.append(&mut b.warnings);
    b.warnings = w;
    Ok(b)
}

impl PipelineReport {
    /// The JSON result of the plan at `plan_path` (`run`'s contract keys):
    /// [`PipelineReport::plan_json`] as a value.
    pub fn to_json(&self, plan: &Plan, plan_path: &Path) -> Value {
        crate::io::json::to_value(self.plan_json(plan, plan_path))
    }

    /// The typed JSON result of the plan at `plan_path`.
    pub fn plan_json(&self, plan: &Plan, plan_path: &Path) -> PlanJson {
        let fits: Vec<FitRecord> = plan
            .characteristic_logs()
            .iter()
            .map(|p| {
                let sha = self.log_sha256.get(p).cloned().flatten();
                match (&self.fits[p], &self.logs[p]) {
                    (Ok(f), Ok(log)) => identify::artifact::record(f, p, sha.as_deref(), &log.rig),
                    (Ok(f), Err(_)) => FitRecord::FitOnly(Box::new(f.json(p))),
                    (Err(e), _) => {
                        identify::artifact::failed_record(p, sha.as_deref(), &e.to_string())
                    }
                }
            })
            .collect();
        let validations: Vec<ValidationEntryJson> = self
            .validations
            .iter()
            .map(|(pair, r)| match (r, &self.fits[&pair.characteristic]) {
                (Ok(v), Ok(f)) => {
                    ValidationEntryJson::Done(v.to_json(&pair.characteristic, &pair.sweep, f))
                }
                (Err(e), _) | (_, Err(e)) => ValidationEntryJson::Failed(FailedPairJson {
                    characteristic: pair.characteristic.display().to_string(),
                    sweep: pair.sweep.display().to_string(),
                    error: e.to_string(),
                }),
            })
            .collect();
        let batch = self.batch.as_ref().map(|r| match r {
            Ok(b) => PlanBatchJson::Done {
                batch: b.to_json_map(),
                logs: plan.batch.iter().map(|p| p.display().to_string()).collect(),
            },
            Err(e) => PlanBatchJson::Failed {
                error: e.to_string(),
            },
        });
        PlanJson {
            plan: plan_path.display().to_string(),
            fits,
            validations,
            batch,
        }
    }

    /// Writes the HTML report of the plan into `dir` (index.html and the
    /// figures; no input is overwritten) and returns the index's path.
    /// `command` is the command line shown on the page.
    pub fn write_report(
        &self,
        plan: &Plan,
        plan_path: &Path,
        dir: &Path,
        command: &str,
    ) -> crate::Result<PathBuf> {
        let clock = std::time::Instant::now();
        let logs = plan.logs();
        let rd = html::ReportDir::create(dir, &logs)?;
        let mut page = html::Page {
            title: plan
                .title
                .clone()
                .unwrap_or_else(|| format!("stickslip report: {}", plan_path.display())),
            version: env!("CARGO_PKG_VERSION").into(),
            command: command.into(),
            ..html::Page::default()
        };
        for (pair, r) in &self.validations {
            if let (Ok(v), Ok(f)) = (r, &self.fits[&pair.characteristic]) {
                page.validations.push(sections::validation_section(
                    &rd,
                    &pair.characteristic,
                    &pair.sweep,
                    f,
                    v,
                )?);
                let s = &v.prediction.score;
                let pc = |x: Option<f64>| x.map_or("–".into(), |v| format!("{:.1} %", v * 100.0));
                page.summary.push(html::KeyValue::new(
                    format!("{} (law of {})", pair.sweep.display(), pair.characteristic.display()),
                    format!(
                        "replay nrms A1 {}, band coverage A1 {}; steady-state nrms A1 {} over {} settled steps",
                        pc(s.replay_nrms_amplitude1),
                        pc(s.replay_coverage_amplitude1),
                        pc(s.nrms_amplitude1),
                        s.steady_points
                    ),
                ));
            }
        }
        if let Some(Ok(b)) = &self.batch {
            let fig = "batch.svg";
            batch_plot::batch_figure(
                b,
                &format!(
                    "{}: worst-case amplitude against the normal force",
                    plan.title.as_deref().unwrap_or("batch")
                ),
                &rd.file(fig)?,
            )?;
            page.batch = Some(batch_view::batch_view(b, Some(fig.into())));
            if let Some(kv) = batch_view::batch_summary(b)
                .into_iter()
                .find(|kv| kv.key.starts_with("recommended"))
            {
                page.summary.push(kv);
            }
        }
        for p in &plan.characteristic_logs() {
            page.fits.push(match (&self.fits[p], &self.logs[p]) {
                (Ok(f), Ok(log)) => match &log.figure {
                    Some(points) => {
                        sections::fit_section(&rd, p, points, log.rig.notes.as_deref(), f)?
                    }
                    None => views::fit_view(p, f, log.rig.notes.as_deref(), None),
                },
                (Err(e), _) | (_, Err(e)) => views::fit_error_view(p, &e.to_string()),
            });
        }
        page.warnings = self.errors.clone();
        page.inputs = logs
            .iter()
            .filter_map(|p| html::input_file(p).ok())
            .collect();
        let t = &self.seconds;
        let f = |s: f64| format!("{s:.2}");
        page.timings = vec![
            html::KeyValue::new("ingest (all logs, in parallel)", f(t.ingest)),
            html::KeyValue::new(
                "fit (every characteristic log once, in parallel, as it is read)",
                f(t.fit),
            ),
            html::KeyValue::new("validate (beside the batch)", f(t.validate)),
            html::KeyValue::new("batch (beside the validations)", f(t.batch)),
            html::KeyValue::new(
                "the two above together (wall, side by side on the cores)",
                f(t.side_by_side),
            ),
            html::KeyValue::new(
                "report (figures and this page, up to its writing)",
                f(clock.elapsed().as_secs_f64()),
            ),
        ];
        rd.write_page(&page)
    }
}
