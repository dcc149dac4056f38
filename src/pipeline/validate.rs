//! The `validate` job: read a characteristic log and a sweep (together
//! where they fit the memory budget), fit the law (or take a saved fit),
//! predict and score the sweep, and write the report and the JSON result
//! ([`ValidateJson`]) through the write transaction ([`crate::io::txn`]).

use super::Progress;
use crate::identify::artifact::{FitArtifact, FitEntry, FitSet};
use crate::identify::{self, IdentifyOptions};
use crate::ingest::{self, IngestOptions, Run};
use crate::report::{html, sections};
use crate::validate::{self as vd, ValidateOptions, Validation};
use serde::Serialize;
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// One validation: the law of a characteristic log (fitted now, or a
/// saved fit) against a sweep log.
#[derive(Debug, Clone)]
pub struct ValidateJob {
    /// The characteristic log (with `fit`: picks the record with its
    /// sha256; optional if the file holds one fit).
    pub characteristic: Option<PathBuf>,
    /// A saved fit (`fit --out` or `merge` of fit parts) used instead of
    /// fitting the characteristic log.
    pub fit: Option<PathBuf>,
    /// The sweep log to predict.
    pub sweep: PathBuf,
    /// Write the HTML report into this directory.
    pub report: Option<PathBuf>,
    /// Write the JSON result to this file.
    pub out: Option<PathBuf>,
    /// The prediction's options; `frc.gain_uncertainty` is also the fit's
    /// sensor gain uncertainty.
    pub options: ValidateOptions,
    /// Use logs whose rig constants differ by more than 1 %.
    pub allow_mixed_rigs: bool,
    /// The command line shown on the report.
    pub command: String,
}

/// Wall seconds per stage of a validation.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct ValidateSeconds {
    /// Reading both logs.
    pub ingest: f64,
    /// Fitting the law (and drawing the characteristic for the report).
    pub fit: f64,
    /// Predicting and scoring the sweep.
    pub validate: f64,
}

/// The `validate --json` object: the validation's keys
/// ([`Validation::to_json`]) with the stage and total wall seconds.
#[derive(Debug, Clone, Serialize)]
pub struct ValidateJson {
    /// The validation (its JSON object's keys, flattened).
    #[serde(flatten)]
    pub validation: Value,
    /// Wall seconds per stage.
    pub stage_seconds: ValidateSeconds,
    /// Wall seconds of the job up to the validation's end.
    pub seconds: f64,
}

/// What [`run_validate`] produced.
#[derive(Debug)]
pub struct ValidateOutcome {
    /// The validation.
    pub validation: Validation,
    /// The JSON result (as written to `out`).
    pub json: ValidateJson,
    /// The report's index page, where one was written.
    pub report: Option<PathBuf>,
}

/// How the characteristic log is read: one too long to fit is refused
/// before it is decoded.
fn fit_read() -> IngestOptions {
    IngestOptions {
        max_samples: Some(crate::limits::MAX_FIT_SAMPLES),
        ..IngestOptions::default()
    }
}

/// Reads the characteristic log `a` (as [`fit_read`]) and the sweep `b`
/// in parallel.
fn read_pair(a: &Path, b: &Path) -> crate::Result<(Run, Run)> {
    let (ra, rb) = rayon::join(
        || ingest::read(a, &fit_read()),
        || ingest::read(b, &IngestOptions::default()),
    );
    Ok((ra?, rb?))
}

/// The saved fit a validation uses: the record whose `log_sha256` is
/// the `characteristic` file's, or the only record.
pub fn saved_fit(path: &Path, characteristic: Option<&Path>) -> crate::Result<FitArtifact> {
    let set = FitSet::read(path)?;
    let bad = |msg: String| crate::Error::Input {
        path: path.to_path_buf(),
        msg,
    };
    let i = match characteristic {
        Some(c) => set.match_logs(&[c.to_path_buf()])?[0].ok_or_else(|| {
            bad(format!(
                "holds no fit of {} (no record has its sha256): fit it, or give the log that was fitted",
                c.display()
            ))
        })?,
        None if set.entries.len() == 1 => 0,
        None => {
            return Err(bad(format!(
                "holds {} fits: name the one to validate with --characteristic LOG",
                set.entries.len()
            )))
        }
    };
    match set.entries.into_iter().nth(i) {
        Some(FitEntry::Fitted(a)) => Ok(*a),
        Some(FitEntry::Failed(f)) => Err(bad(format!(
            "records that the fit of {} failed ({}): nothing to validate",
            f.log.display(),
            f.error
        ))),
        None => Err(bad("holds no fits".into())),
    }
}

/// The job needs a characteristic log or a saved fit; said again rather
/// than assumed.
fn need_one() -> crate::Error {
    crate::Error::Input {
        path: PathBuf::from("--characteristic"),
        msg: "or --fit is needed".into(),
    }
}

/// Whether the characteristic log `c` and the sweep fit the fit's memory
/// budget together (planned before either is decoded, as the plan runner
/// plans its rounds).
fn fit_together(c: &Path, sweep: &Path) -> bool {
    let budget = IdentifyOptions::default().memory_bytes;
    let planned = identify::planned_fit_memory(&[c.to_path_buf(), sweep.to_path_buf()], budget);
    crate::limits::rounds(&planned, budget).len() <= 1
}

/// What the report draws of the characteristic log (its points and notes).
type Figure = (
    crate::report::characteristic_plot::CharacteristicPoints,
    Option<String>,
);

/// Runs the validation: reads both logs at once where their planned
/// memory fits the budget together (otherwise the sweep is read for its
/// rig, let go, and read again once the characteristic log is fitted and
/// let go), refuses mixed rigs, fits (or takes the saved fit), predicts and
/// scores the sweep, then writes the report and `out`.
pub fn run_validate(job: &ValidateJob, progress: &dyn Progress) -> crate::Result<ValidateOutcome> {
    let t0 = Instant::now();
    let saved = job
        .fit
        .as_deref()
        .map(|p| saved_fit(p, job.characteristic.as_deref()))
        .transpose()?;
    progress.say("reading logs");
    let clock = Instant::now();
    let together = job
        .characteristic
        .as_ref()
        .is_none_or(|c| fit_together(c, &job.sweep));
    let (char_run, sweep_run, sweep_rig) = match &job.characteristic {
        Some(c) if together => {
            let (a, b) = read_pair(c, &job.sweep)?;
            let rig = b.rig.clone();
            (Some(a), Some(b), rig)
        }
        Some(c) => {
            let rig = ingest::read(&job.sweep, &IngestOptions::default())?.rig;
            (Some(ingest::read(c, &fit_read())?), None, rig)
        }
        None => {
            let b = ingest::read(&job.sweep, &IngestOptions::default())?;
            let rig = b.rig.clone();
            (None, Some(b), rig)
        }
    };
    // The fit and the figure read the characteristic log's common grid
    // only: its channels as recorded go.
    let char_run = char_run.map(|mut run| {
        run.channels = Vec::new();
        run
    });
    let mut t_ingest = clock.elapsed().as_secs_f64();
    let characteristic = job
        .characteristic
        .clone()
        .or_else(|| saved.as_ref().map(|a| a.log.clone()))
        .unwrap_or_default();
    let char_rig = match (&saved, &char_run) {
        (Some(a), _) => a.rig.clone(),
        (None, Some(r)) => r.rig.clone(),
        (None, None) => return Err(need_one()),
    };
    super::checks::refuse_mixed_rigs(
        &[
            (characteristic.clone(), char_rig.clone()),
            (job.sweep.clone(), sweep_rig),
        ],
        job.allow_mixed_rigs,
    )?;
    let clock = Instant::now();
    let fit = match (saved, &char_run) {
        (Some(a), _) => {
            progress.say(&format!("using the saved fit of {}", a.log.display()));
            a.fit
        }
        (None, Some(run)) => {
            progress.say("fitting the friction law");
            let opts = IdentifyOptions {
                gain_uncertainty: job.options.frc.gain_uncertainty,
                ..IdentifyOptions::default()
            };
            identify::fit_log(run, &opts)?
        }
        (None, None) => return Err(need_one()),
    };
    // What the report draws of the characteristic log; the log goes.
    let figure: Option<Figure> = match (&char_run, &job.report) {
        (Some(run), Some(_)) => Some((sections::fit_points(run, &fit)?, run.rig.notes.clone())),
        _ => None,
    };
    let had_char = char_run.is_some();
    drop(char_run);
    let t_fit = clock.elapsed().as_secs_f64();
    let sweep_run = match sweep_run {
        Some(run) => run,
        None => {
            let clock = Instant::now();
            let run = ingest::read(&job.sweep, &IngestOptions::default())?;
            t_ingest += clock.elapsed().as_secs_f64();
            run
        }
    };
    progress.say(&format!(
        "measuring the sweep and predicting it (at most {} laws for the bands)",
        job.options.predict.samples
    ));
    let clock = Instant::now();
    let v = vd::validate_fit(&fit, &characteristic, &char_rig, &sweep_run, &job.options)?;
    let t_validate = clock.elapsed().as_secs_f64();
    let json = ValidateJson {
        validation: v.to_json(&characteristic, &job.sweep, &fit),
        stage_seconds: ValidateSeconds {
            ingest: t_ingest,
            fit: t_fit,
            validate: t_validate,
        },
        seconds: t0.elapsed().as_secs_f64(),
    };
    let report = match &job.report {
        Some(dir) => {
            let r = Report {
                job,
                characteristic: &characteristic,
                fit: &fit,
                validation: &v,
                figure: figure.as_ref(),
                had_char,
                together,
                seconds: json.stage_seconds,
            };
            let index = r.write(dir)?;
            progress.say(&format!("report: {}", index.display()));
            Some(index)
        }
        None => None,
    };
    if let Some(path) = &job.out {
        crate::io::json::write_pretty(path, &crate::io::json::to_value(&json))?;
    }
    Ok(ValidateOutcome {
        validation: v,
        json,
        report,
    })
}

/// What the validation's report page shows.
struct Report<'a> {
    job: &'a ValidateJob,
    characteristic: &'a Path,
    fit: &'a identify::LogFit,
    validation: &'a Validation,
    figure: Option<&'a Figure>,
    /// Whether the characteristic log was read (else: a saved fit only).
    had_char: bool,
    /// Whether both logs were read together.
    together: bool,
    seconds: ValidateSeconds,
}

impl Report<'_> {
    /// Writes the report into `dir` and returns its index page.
    fn write(&self, dir: &Path) -> crate::Result<PathBuf> {
        let job = self.job;
        let (characteristic, fit) = (self.characteristic, self.fit);
        let inputs: Vec<PathBuf> = job
            .characteristic
            .iter()
            .chain(&job.fit)
            .chain([&job.sweep])
            .cloned()
            .collect();
        let rd = html::ReportDir::create(dir, &inputs)?;
        let section =
            sections::validation_section(&rd, characteristic, &job.sweep, fit, self.validation)?;
        // The fit's section draws the characteristic (its points, taken
        // from the log).
        let fits = match self.figure {
            Some((points, notes)) => vec![sections::fit_section(
                &rd,
                characteristic,
                points,
                notes.as_deref(),
                fit,
            )?],
            None => Vec::new(),
        };
        let t = self.seconds;
        let page = html::Page {
            title: format!("Validation of {}", job.sweep.display()),
            version: env!("CARGO_PKG_VERSION").into(),
            command: job.command.clone(),
            summary: vec![],
            warnings: if self.had_char {
                vec![]
            } else {
                vec![format!(
                    "the fit of {} is from {}; give --characteristic to draw its characteristic",
                    characteristic.display(),
                    job.fit.as_deref().unwrap_or(Path::new("?")).display()
                )]
            },
            batch: None,
            validations: vec![section],
            fits,
            inputs: inputs
                .iter()
                .map(|p| html::input_file(p))
                .collect::<crate::Result<_>>()?,
            timings: [
                (
                    if self.together {
                        "ingest (both logs, in parallel)"
                    } else {
                        "ingest (one log at a time: too long to hold both)"
                    },
                    t.ingest,
                ),
                ("fit", t.fit),
                ("validate", t.validate),
            ]
            .into_iter()
            .map(|(k, v)| html::KeyValue::new(k, format!("{v:.2}")))
            .collect(),
        };
        rd.write_page(&page)
    }
}
