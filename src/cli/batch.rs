//! `stickslip batch LOG...`: one pad at several normal forces. Fits every
//! log (in parallel), estimates μs and μd through the origin (stuck and
//! never-sticking logs as censored data), and recommends the normal force
//! whose worst-case main-mass amplitude over the drive range, robust to its
//! own uncertainty, is smallest (see [`crate::batch`]). A log that
//! cannot be read or fitted gives its `error:` line and an entry with
//! `error`; the batch is computed from the others and the exit status is 1.
//! Logs whose rig constants differ by more than 1 % are refused unless
//! `--allow-mixed-rigs`; the same test given twice (the same file, or the
//! same test in another format) counts once, with a warning. Conflicting
//! logs are named in `conflicts` and μ is reported with and without them.

use crate::batch::{self as vb, Batch, BatchOptions};
use crate::identify::artifact::{self, FitEntry, FitSet};
use crate::identify::{self, IdentifyOptions, LogFit};
use crate::ingest::RigMeta;
use crate::report::{batch_plot, batch_view, html, views};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use serde_json::{json, Value};
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Arguments of `stickslip batch`.
#[derive(Debug, Args)]
pub struct BatchArgs {
    /// Characteristic logs of one pad at several normal forces.
    #[arg(required_unless_present = "fits")]
    pub logs: Vec<PathBuf>,
    /// Reuse the fits in this file (`fit --out` or `merge` of fit parts)
    /// instead of refitting: its fits join the batch first; a log also
    /// given is fitted only if no record has its sha256 (a record of the
    /// same file with another sha256 is refused).
    #[arg(long, value_name = "FITS.json")]
    pub fits: Option<PathBuf>,
    /// Write the HTML report (index.html and the figure) into this directory.
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// Write the JSON result to this file (atomically).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Relative gain uncertainty of each motion sensor in the calibration budget.
    #[arg(long, default_value_t = 0.01, value_parser = super::args::gain_fraction, allow_hyphen_values = true)]
    pub gain_uncertainty: f64,
    /// Relative gain uncertainty of the normal-force sensor (common to the batch).
    #[arg(long, default_value_t = 0.01, value_parser = super::args::gain_fraction, allow_hyphen_values = true)]
    pub normal_force_gain_uncertainty: f64,
    /// Bootstrap replicates over drive periods (per log; 0 to 100000).
    #[arg(long, default_value_t = 400, value_parser = super::args::bootstrap_replicates, allow_hyphen_values = true)]
    pub bootstrap: usize,
    /// Tolerance of a normal-force setting (±, relative).
    #[arg(long, default_value_t = 0.05, allow_hyphen_values = true)]
    pub setting_tolerance: f64,
    /// The recommended window: settings whose robust worst case is within this fraction of the best.
    #[arg(long, default_value_t = 0.10, allow_hyphen_values = true)]
    pub window: f64,
    /// Drive range: smallest η (with --eta-max; default 0.5·η1 of the rig).
    #[arg(long, requires = "eta_max", allow_hyphen_values = true)]
    pub eta_min: Option<f64>,
    /// Drive range: largest η (with --eta-min; default 1.4·η2 of the rig).
    #[arg(long, requires = "eta_min", allow_hyphen_values = true)]
    pub eta_max: Option<f64>,
    /// Uniform η points over the drive range (plus fine windows around η1, η0, η2).
    #[arg(long, default_value_t = 141, allow_hyphen_values = true)]
    pub eta_points: usize,
    /// Step of the fine η windows around η1, η0, η2 (0: none).
    #[arg(long, default_value_t = vb::DEFAULT_ETA_FINE_STEP, allow_hyphen_values = true)]
    pub eta_fine_step: f64,
    /// Half-width of each fine η window.
    #[arg(long, default_value_t = 0.025, allow_hyphen_values = true)]
    pub eta_fine_halfwidth: f64,
    /// Evaluate every this-many uniform η at each ρs (with the fine
    /// windows), the others only next to a branch's local maximum (1: every η).
    #[arg(long, default_value_t = vb::DEFAULT_ETA_COARSE_STRIDE, allow_hyphen_values = true)]
    pub eta_coarse_stride: usize,
    /// Smallest ρs of the worst-case grid.
    #[arg(long, default_value_t = 0.2, allow_hyphen_values = true)]
    pub rho_min: f64,
    /// Largest ρs of the grid (default: covers every measured setting, at least 3).
    #[arg(long, allow_hyphen_values = true)]
    pub rho_max: Option<f64>,
    /// Nodes of the coarse geometric ρs grid.
    #[arg(long, default_value_t = 40, allow_hyphen_values = true)]
    pub rho_points: usize,
    /// Do not refine the ρs grid around the best candidates.
    #[arg(long)]
    pub no_refine: bool,
    /// Leave the μd/μs interval out of the robust worst case (estimate only).
    #[arg(long)]
    pub no_ratio_variants: bool,
    /// Drive amplitude (mm) for ρ = R/(A·K2) (default: the rig's nominal amplitude).
    #[arg(long, allow_hyphen_values = true)]
    pub drive_amplitude_mm: Option<f64>,
    /// Period budget of the time-marching fallback per steady state.
    #[arg(long, default_value_t = vb::DEFAULT_MAX_PERIODS, value_parser = super::args::periods(), allow_hyphen_values = true)]
    pub max_periods: u64,
    /// Use logs whose rig constants (M1, M2, K1, K2, d) differ by more than 1 %.
    #[arg(long)]
    pub allow_mixed_rigs: bool,
    /// Print one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
}

fn arg_err(name: &str, msg: &str) -> crate::Error {
    crate::Error::Input {
        path: PathBuf::from(name),
        msg: msg.into(),
    }
}

fn options(a: &BatchArgs) -> crate::Result<BatchOptions> {
    let d = BatchOptions::default();
    let o = BatchOptions {
        eta_range: a.eta_min.zip(a.eta_max),
        eta_points: a.eta_points,
        eta_fine_step: a.eta_fine_step,
        eta_fine_halfwidth: a.eta_fine_halfwidth,
        eta_coarse_stride: a.eta_coarse_stride,
        rho_min: a.rho_min,
        rho_max: a.rho_max,
        rho_points: a.rho_points,
        refine: !a.no_refine,
        setting_tolerance: a.setting_tolerance,
        window: a.window,
        drive_amplitude_m: a.drive_amplitude_mm.map(|x| x * 1e-3),
        normal_force_gain_uncertainty: a.normal_force_gain_uncertainty,
        ratio_variants: !a.no_ratio_variants,
        steady: crate::sim::sweep::SteadyConfig {
            max_periods: a.max_periods,
            ..d.steady
        },
    };
    o.check()
        .map_err(|m| arg_err("batch options", &m.to_string()))?;
    Ok(o)
}

/// Writes the report directory: the batch section with its figure and one
/// section per fit.
fn write_report(
    dir: &Path,
    args: &BatchArgs,
    fits: &[(PathBuf, crate::Result<(RigMeta, LogFit)>)],
    batch: Option<&Batch>,
    errors: &[String],
) -> crate::Result<PathBuf> {
    let inputs: Vec<PathBuf> = args.logs.iter().chain(&args.fits).cloned().collect();
    let rd = html::ReportDir::create(dir, &inputs)?;
    let mut page = html::Page {
        title: "Normal-force settings of one pad".into(),
        version: env!("CARGO_PKG_VERSION").into(),
        command: std::env::args().collect::<Vec<_>>().join(" "),
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

/// The fits of a batch, per log.
type Fits = [(PathBuf, crate::Result<(RigMeta, LogFit)>)];

/// Keeps one of each test given twice (same rig, normal force and drive):
/// the names set aside and the warnings saying so.
fn drop_duplicates(
    good: &mut Vec<(PathBuf, LogFit)>,
    rigs: &mut Vec<(PathBuf, RigMeta)>,
) -> (Vec<String>, Vec<crate::warning::Warning>) {
    let (keep, dup_warnings) = {
        let ids: Vec<crate::pipeline::checks::TestId<'_>> = good
            .iter()
            .zip(rigs.iter())
            .map(|((p, f), (_, rig))| crate::pipeline::checks::TestId {
                path: p,
                rig,
                normal_force_n: f.normal_force_n,
                drive_amplitude_m: f.drive.amplitude_m,
                drive_frequency_hz: f.drive.frequency_hz,
            })
            .collect();
        crate::pipeline::checks::find_duplicates(&ids)
    };
    let duplicates: Vec<String> = good
        .iter()
        .zip(&keep)
        .filter(|(_, k)| !**k)
        .map(|((p, _), _)| p.display().to_string())
        .collect();
    let mut k = keep.iter();
    good.retain(|_| *k.next().unwrap_or(&true));
    let mut k = keep.iter();
    rigs.retain(|_| *k.next().unwrap_or(&true));
    (duplicates, dup_warnings)
}

/// The JSON object: `fits` (per-log entries or errors), `duplicates`, and
/// the batch keys (`null` with an `error` where the batch failed).
fn batch_json(
    fits: &Fits,
    shas: &[Option<String>],
    duplicates: &[String],
    result: &crate::Result<Batch>,
) -> serde_json::Map<String, Value> {
    let fit_entries: Vec<Value> = fits
        .iter()
        .zip(shas)
        .map(|((p, r), sha)| match r {
            Ok((rig, f)) => artifact::record(f, p, sha.as_deref(), rig),
            Err(e) => artifact::failed_record(p, sha.as_deref(), &e.to_string()),
        })
        .collect();
    let mut out = serde_json::Map::new();
    out.insert("fits".into(), json!(fit_entries));
    out.insert("duplicates".into(), json!(duplicates));
    match result {
        Ok(b) => out.extend(b.to_json_map()),
        Err(e) => {
            for k in [
                "mu_s",
                "mu_d",
                "mu_s_interval",
                "mu_d_interval",
                "recommended_normal_force_n",
                "recommended_normal_force_interval_n",
                "recommended_rho_s",
                "worst_amplitude1",
                "cliff_rho_s",
            ] {
                out.insert(k.into(), Value::Null);
            }
            out.insert("error".into(), json!(e.to_string()));
        }
    }
    out
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

/// Runs `batch`. A log that cannot be read, or is not a characteristic
/// test, stops it before any fitting; a log that cannot be fitted, or a
/// batch that fails, makes it fail without writing a file (the JSON still
/// goes to stdout with `--json`). It stays one function of about 130
/// lines: its steps (check, read, fit, drop duplicates, compare, print)
/// share one progress bar; the parts with logic of their own are
/// [`drop_duplicates`], [`batch_json`] and [`failure`].
pub fn run(args: BatchArgs) -> crate::Result<()> {
    let outputs = super::json_and_report(args.out.as_deref(), args.report.as_deref());
    super::check_paths(
        args.logs.iter().chain(&args.fits).map(PathBuf::as_path),
        &outputs,
    )?;
    let t0 = Instant::now();
    let bopts = options(&args)?;
    // Earlier fits, and which of the logs given they cover.
    let (saved, covered) = match &args.fits {
        Some(path) => {
            let set = FitSet::read(path)?;
            let covered = set.match_logs(&args.logs)?;
            (set.entries, covered)
        }
        None => (Vec::new(), vec![None; args.logs.len()]),
    };
    let to_fit: Vec<PathBuf> = args
        .logs
        .iter()
        .zip(&covered)
        .filter(|(_, c)| c.is_none())
        .map(|(p, _)| p.clone())
        .collect();
    let iopts = IdentifyOptions {
        fit: identify::FitOptions {
            bootstrap: args.bootstrap,
            ..Default::default()
        },
        gain_uncertainty: args.gain_uncertainty,
        ..IdentifyOptions::default()
    };
    let show = !args.json && std::io::stderr().is_terminal();
    let bar = if show {
        let b = ProgressBar::new(to_fit.len() as u64);
        b.set_style(
            ProgressStyle::with_template("{elapsed_precise} [{bar:30}] {pos}/{len} {msg}")
                .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
        b
    } else {
        ProgressBar::hidden()
    };
    bar.set_message("fitting logs");
    // Every log is checked first: a log that cannot be read or is not a
    // characteristic test stops the batch before any fitting.
    bar.set_message("reading and fitting logs");
    let fitted =
        match crate::pipeline::checks::fit_characteristic_logs(&to_fit, &iopts, &|| bar.inc(1)) {
            Ok(f) => f,
            Err(e) => {
                bar.finish_and_clear();
                return Err(e);
            }
        };
    // The saved fits first (in their file's order), then the logs fitted now.
    let mut fits: Vec<(PathBuf, crate::Result<(RigMeta, LogFit)>)> = Vec::new();
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
    if let Err(e) = crate::pipeline::checks::refuse_mixed_rigs(&rigs, args.allow_mixed_rigs) {
        bar.finish_and_clear();
        return Err(e);
    }
    // The same test given twice counts once.
    let (duplicates, dup_warnings) = drop_duplicates(&mut good, &mut rigs);
    // Results.
    let result: crate::Result<Batch> = if good.is_empty() {
        Err(crate::batch::BatchError::NothingFitted.into())
    } else {
        let rig = &rigs[0].1;
        bar.set_message("worst-case amplitudes");
        bar.set_length(bar.position() + (bopts.rho_points * 3 + good.len() + 9) as u64);
        let tick = |n: u64| {
            if bar.position() + n > bar.length().unwrap_or(0) {
                bar.inc_length(n);
            }
            bar.inc(n);
        };
        vb::batch_with_progress(&good, rig, &bopts, &tick).map(|mut b| {
            let mut w = dup_warnings.clone();
            w.extend(vb::rig_warnings(&rigs));
            w.append(&mut b.warnings);
            b.warnings = w;
            b
        })
    };
    bar.finish_and_clear();
    for e in &errors {
        eprintln!("error: {e}");
    }
    if let Err(e) = &result {
        eprintln!("error: {e}");
    }
    let mut out = batch_json(&fits, &shas, &duplicates, &result);
    if !errors.is_empty() || result.is_err() {
        // A failed command writes no file: print what there is, then fail.
        if args.json {
            out.insert("seconds".into(), json!(t0.elapsed().as_secs_f64()));
            super::print_json(&Value::Object(out))?;
        }
        return Err(failure(&fits, result.as_ref().err()));
    }
    if let Some(dir) = &args.report {
        let index = write_report(dir, &args, &fits, result.as_ref().ok(), &errors)?;
        out.insert("report".into(), json!(index.display().to_string()));
        if !args.json {
            eprintln!("report: {}", index.display());
        }
    }
    out.insert("seconds".into(), json!(t0.elapsed().as_secs_f64()));
    let out = Value::Object(out);
    if let Some(path) = &args.out {
        super::write_json(path, &out)?;
    }
    if args.json {
        super::print_json(&out)?;
    } else if let Ok(b) = &result {
        for line in batch_view::batch_summary(b) {
            eprintln!("{}: {}", line.key, line.value);
        }
        for w in &b.warnings {
            eprintln!("warning: {w}");
        }
        eprintln!("done in {:.1} s", t0.elapsed().as_secs_f64());
    }
    Ok(())
}
