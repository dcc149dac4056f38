//! `stickslip validate`: fit the law of a characteristic log, predict a
//! sweep log's frequency response with it (steady state and replay, with
//! 95 % bands), score it, and optionally write an HTML report.

use crate::identify::{self, IdentifyOptions};
use crate::ingest::{self, IngestOptions, Run};
use crate::report::{html, sections};
use crate::validate::{self, ValidateOptions};
use clap::Args;
use serde_json::json;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Arguments of `stickslip validate`.
#[derive(Debug, Args)]
pub struct ValidateArgs {
    /// Characteristic log whose fitted law is validated (with --fit: picks
    /// the record with its sha256; optional if the file holds one fit).
    #[arg(long, required_unless_present = "fit")]
    pub characteristic: Option<PathBuf>,
    /// Reuse a saved fit (`fit --out` or `merge` of fit parts) instead of
    /// fitting the characteristic log.
    #[arg(long, value_name = "FITS.json")]
    pub fit: Option<PathBuf>,
    /// Sweep log (stepped or continuous) to predict.
    #[arg(long)]
    pub sweep: PathBuf,
    /// Write an HTML report (index.html and SVG figures) into this directory.
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// Write the JSON result to this file (atomically).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Most laws drawn from the fit's uncertainty for the 95 % bands (0:
    /// none; at most 2000: each is a whole predicted sweep): drawn in rounds
    /// (40, then doubling) until the replay coverages are known to
    /// --band-coverage-se.
    #[arg(long, default_value_t = validate::predict::DEFAULT_BAND_SAMPLES, value_parser = super::args::band_samples, allow_hyphen_values = true)]
    pub samples: usize,
    /// Bootstrap standard error to which the draws must fix every replay
    /// coverage (a fraction, 0 to 0.5; 0: draw all --samples).
    #[arg(long, default_value_t = 0.025, value_parser = super::args::coverage_se, allow_hyphen_values = true)]
    pub band_coverage_se: f64,
    /// Relative gain uncertainty of each sensor in the calibration budget.
    #[arg(long, default_value_t = 0.01, value_parser = super::args::gain_fraction, allow_hyphen_values = true)]
    pub gain_uncertainty: f64,
    /// Period budget of the fitted law's steady state at each point (points
    /// with no periodic response by then are reported without one).
    #[arg(long, default_value_t = validate::predict::DEFAULT_STEADY_PERIODS, value_parser = super::args::periods(), allow_hyphen_values = true)]
    pub max_periods: u64,
    /// Use a characteristic log and a sweep whose rig constants (M1, M2, K1, K2, d) differ by more than 1 %.
    #[arg(long)]
    pub allow_mixed_rigs: bool,
    /// Print one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
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

/// The saved fit `validate --fit` uses: the record whose `log_sha256` is
/// the `--characteristic` file's, or the only record.
fn saved_fit(
    path: &Path,
    characteristic: Option<&Path>,
) -> crate::Result<crate::identify::artifact::FitArtifact> {
    use crate::identify::artifact::{FitEntry, FitSet};
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

/// Clap requires one of them; said again rather than assumed.
fn need_one() -> crate::Error {
    crate::Error::Input {
        path: PathBuf::from("--characteristic"),
        msg: "or --fit is needed".into(),
    }
}

/// Runs `validate`.
pub fn run(args: ValidateArgs) -> crate::Result<()> {
    let outputs = super::json_and_report(args.out.as_deref(), args.report.as_deref());
    super::check_paths(
        args.characteristic
            .iter()
            .chain(&args.fit)
            .map(PathBuf::as_path)
            .chain([args.sweep.as_path()]),
        &outputs,
    )?;
    let t0 = Instant::now();
    let say = |msg: &str| {
        if !args.json {
            eprintln!("{msg}");
        }
    };
    let saved = args
        .fit
        .as_deref()
        .map(|p| saved_fit(p, args.characteristic.as_deref()))
        .transpose()?;
    say("reading logs");
    let clock = Instant::now();
    // Both logs are read at once where their planned memory fits the
    // budget together; otherwise the sweep is read for its rig, let go,
    // and read again once the characteristic log is fitted and let go.
    let together = args.characteristic.as_ref().is_none_or(|c| {
        let budget = IdentifyOptions::default().memory_bytes;
        let planned = identify::planned_fit_memory(&[c.clone(), args.sweep.clone()], budget);
        planned.iter().fold(0u64, |a, &b| a.saturating_add(b)) <= budget
    });
    let (char_run, sweep_run, sweep_rig) = match &args.characteristic {
        Some(c) if together => {
            let (a, b) = read_pair(c, &args.sweep)?;
            let rig = b.rig.clone();
            (Some(a), Some(b), rig)
        }
        Some(c) => {
            let rig = ingest::read(&args.sweep, &IngestOptions::default())?.rig;
            (Some(ingest::read(c, &fit_read())?), None, rig)
        }
        None => {
            let b = ingest::read(&args.sweep, &IngestOptions::default())?;
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
    let characteristic = args
        .characteristic
        .clone()
        .or_else(|| saved.as_ref().map(|a| a.log.clone()))
        .unwrap_or_default();
    let char_rig = match (&saved, &char_run) {
        (Some(a), _) => a.rig.clone(),
        (None, Some(r)) => r.rig.clone(),
        (None, None) => return Err(need_one()),
    };
    crate::pipeline::checks::refuse_mixed_rigs(
        &[
            (characteristic.clone(), char_rig.clone()),
            (args.sweep.clone(), sweep_rig),
        ],
        args.allow_mixed_rigs,
    )?;
    let clock = Instant::now();
    let fit = match (saved, &char_run) {
        (Some(a), _) => {
            say(&format!("using the saved fit of {}", a.log.display()));
            a.fit
        }
        (None, Some(run)) => {
            say("fitting the friction law");
            let opts = IdentifyOptions {
                gain_uncertainty: args.gain_uncertainty,
                ..IdentifyOptions::default()
            };
            identify::fit_log(run, &opts)?
        }
        (None, None) => return Err(need_one()),
    };
    // What the report draws of the characteristic log; the log goes.
    let figure = match (&char_run, &args.report) {
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
            let run = ingest::read(&args.sweep, &IngestOptions::default())?;
            t_ingest += clock.elapsed().as_secs_f64();
            run
        }
    };
    say(&format!(
        "measuring the sweep and predicting it (at most {} laws for the bands)",
        args.samples
    ));
    let mut vo = ValidateOptions::default();
    vo.predict.samples = args.samples;
    vo.predict.band_coverage_se = args.band_coverage_se;
    vo.predict.steady.max_periods = args.max_periods;
    vo.frc.gain_uncertainty = args.gain_uncertainty;
    let clock = Instant::now();
    let v = validate::validate_fit(&fit, &characteristic, &char_rig, &sweep_run, &vo)?;
    let t_validate = clock.elapsed().as_secs_f64();
    let mut out = v.to_json(&characteristic, &args.sweep, &fit);
    out["stage_seconds"] = json!({"ingest": t_ingest, "fit": t_fit, "validate": t_validate});
    out["seconds"] = json!(t0.elapsed().as_secs_f64());
    if let Some(dir) = &args.report {
        let inputs: Vec<PathBuf> = args
            .characteristic
            .iter()
            .chain(&args.fit)
            .chain([&args.sweep])
            .cloned()
            .collect();
        let rd = html::ReportDir::create(dir, &inputs)?;
        let section = sections::validation_section(&rd, &characteristic, &args.sweep, &fit, &v)?;
        // The fit's section draws the characteristic (its points, taken
        // from the log).
        let fits = match &figure {
            Some((points, notes)) => vec![sections::fit_section(
                &rd,
                &characteristic,
                points,
                notes.as_deref(),
                &fit,
            )?],
            None => Vec::new(),
        };
        let page = html::Page {
            title: format!("Validation of {}", args.sweep.display()),
            version: env!("CARGO_PKG_VERSION").into(),
            command: std::env::args().collect::<Vec<_>>().join(" "),
            summary: vec![],
            warnings: if had_char {
                vec![]
            } else {
                vec![format!(
                    "the fit of {} is from {}; give --characteristic to draw its characteristic",
                    characteristic.display(),
                    args.fit.as_deref().unwrap_or(Path::new("?")).display()
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
                    if together {
                        "ingest (both logs, in parallel)"
                    } else {
                        "ingest (one log at a time: too long to hold both)"
                    },
                    t_ingest,
                ),
                ("fit", t_fit),
                ("validate", t_validate),
            ]
            .into_iter()
            .map(|(k, v)| html::KeyValue::new(k, format!("{v:.2}")))
            .collect(),
        };
        let index = rd.write_page(&page)?;
        say(&format!("report: {}", index.display()));
    }
    if let Some(path) = &args.out {
        super::write_json(path, &out)?;
    }
    if args.json {
        super::print_json(&out)?;
    } else {
        let s = &v.prediction.score;
        let pc = |x: Option<f64>| x.map_or("-".into(), |v| format!("{:.1} %", v * 100.0));
        eprintln!(
            "{} steps, {} reached steady state; steady nrms A1 {}, A2 {}; replay nrms A1 {}, A2 {}; replay band coverage A1 {}, A2 {} ({:.2} s)",
            v.measured.points.len(),
            s.steady_points,
            pc(s.nrms_amplitude1),
            pc(s.nrms_amplitude2),
            pc(s.replay_nrms_amplitude1),
            pc(s.replay_nrms_amplitude2),
            pc(s.replay_coverage_amplitude1),
            pc(s.replay_coverage_amplitude2),
            t0.elapsed().as_secs_f64()
        );
        for w in &v.warnings {
            eprintln!("warning: {w}");
        }
    }
    Ok(())
}
