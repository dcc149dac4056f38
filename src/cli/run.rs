//! `stickslip run PLAN.toml`: the whole pipeline on an experiment plan
//! (ingest → fit → validate → batch) with one HTML report. The plan says
//! which logs belong together, which the logs themselves cannot:
//!
//! ```toml
//! title = "Rig A, pad 1"
//! # Paths are relative to the plan file.
//! fit = ["law_coulomb.mcap"]            # characteristic logs fitted on their own
//! batch = ["char_N1.2.mcap", "char_N4.mcap"]   # one pad at several normal forces
//! [[validate]]
//! characteristic = "char_N4.mcap"
//! sweep = "sweep_stepped_N4.mcap"
//! ```
//!
//! Every log is read and fitted once, in parallel; a log that fails gives
//! its `error:` line and the rest completes (exit 1 at the end).

use crate::batch as vb;
use crate::identify::{self, IdentifyOptions, LogFit};
use crate::ingest::{self, IngestOptions, Run};
use crate::report::{batch_plot, batch_view, html, views};
use crate::validate::{self, ValidateOptions, Validation};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;
use serde::Deserialize;
use serde_json::{json, Value};
use std::collections::BTreeMap;
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Arguments of `stickslip run`.
#[derive(Debug, Args)]
pub struct RunArgs {
    /// The experiment plan (TOML; see `stickslip run --help` and datasets/plan.toml).
    pub plan: PathBuf,
    /// Write the HTML report (index.html and SVG figures) into this directory.
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// Write the JSON result to this file (atomically).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Laws drawn from each fit's uncertainty for the prediction bands.
    #[arg(long, default_value_t = 40)]
    pub samples: usize,
    /// Use logs whose rig constants (M1, M2, K1, K2, d) differ by more than 1 %.
    #[arg(long)]
    pub allow_mixed_rigs: bool,
    /// Print one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
}

/// One validation of the plan.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct Pair {
    characteristic: PathBuf,
    sweep: PathBuf,
}

/// The plan file.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct Plan {
    #[serde(default)]
    title: Option<String>,
    #[serde(default)]
    fit: Vec<PathBuf>,
    #[serde(default)]
    batch: Vec<PathBuf>,
    #[serde(default)]
    validate: Vec<Pair>,
}

fn plan_err(path: &Path, msg: impl Into<String>) -> crate::Error {
    crate::Error::Input {
        path: path.to_path_buf(),
        msg: msg.into(),
    }
}

/// Reads and checks the plan; paths become relative to the plan's folder.
fn read_plan(path: &Path) -> crate::Result<Plan> {
    let text = std::fs::read_to_string(path).map_err(|source| crate::Error::Io {
        path: path.to_path_buf(),
        source,
    })?;
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
    for v in &mut plan.validate {
        fix(&mut v.characteristic);
        fix(&mut v.sweep);
    }
    if plan.fit.is_empty() && plan.batch.is_empty() && plan.validate.is_empty() {
        return Err(plan_err(
            path,
            "the plan names no logs (keys: fit, batch, [[validate]])",
        ));
    }
    Ok(plan)
}

/// Runs the plan.
pub fn run(args: RunArgs) -> crate::Result<bool> {
    let t0 = Instant::now();
    let plan = read_plan(&args.plan)?;
    // Every log once, in plan order.
    let mut logs: Vec<PathBuf> = Vec::new();
    let mut add = |p: &PathBuf| {
        if !logs.contains(p) {
            logs.push(p.clone());
        }
    };
    plan.batch.iter().for_each(&mut add);
    plan.fit.iter().for_each(&mut add);
    for v in &plan.validate {
        add(&v.characteristic);
        add(&v.sweep);
    }
    crate::io::ensure_not_inputs(
        logs.iter()
            .map(PathBuf::as_path)
            .chain([args.plan.as_path()]),
        args.out.as_deref(),
    )?;
    let sweeps: Vec<&PathBuf> = plan.validate.iter().map(|v| &v.sweep).collect();
    let chars: Vec<&PathBuf> = logs.iter().filter(|p| !sweeps.contains(p)).collect();

    let show = !args.json && std::io::stderr().is_terminal();
    let steps =
        logs.len() + chars.len() + plan.validate.len() + usize::from(!plan.batch.is_empty());
    let bar = if show {
        let b = ProgressBar::new(steps as u64);
        b.set_style(
            ProgressStyle::with_template("{elapsed_precise} [{bar:30}] {pos}/{len} {msg}")
                .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
        b
    } else {
        ProgressBar::hidden()
    };

    bar.set_message("reading logs");
    let runs: BTreeMap<PathBuf, crate::Result<Run>> = logs
        .par_iter()
        .map(|p| {
            let r = ingest::read(p, &IngestOptions::default()).map_err(crate::Error::from);
            bar.inc(1);
            (p.clone(), r)
        })
        .collect();
    // One rig: every log of the plan that could be read.
    let read_rigs: Vec<(PathBuf, crate::ingest::RigMeta)> = logs
        .iter()
        .filter_map(|p| runs[p].as_ref().ok().map(|r| (p.clone(), r.rig.clone())))
        .collect();
    if let Err(e) = super::refuse_mixed_rigs(&read_rigs, args.allow_mixed_rigs) {
        bar.finish_and_clear();
        return Err(e);
    }
    bar.set_message("fitting friction laws");
    let opts = IdentifyOptions::default();
    // The logs that were read are fitted (in parallel, panic-guarded);
    // the others keep their read error.
    let read: Vec<&Run> = chars
        .iter()
        .filter_map(|p| runs[*p].as_ref().ok())
        .collect();
    let mut fitted = identify::fit_runs(&read, &opts, &|| bar.inc(1)).into_iter();
    let fits: BTreeMap<PathBuf, crate::Result<LogFit>> = chars
        .iter()
        .map(|p| {
            let f = match &runs[*p] {
                Ok(_) => fitted.next().expect("one fit per log read"),
                Err(e) => {
                    bar.inc(1);
                    Err(crate::Error::Skipped {
                        path: (*p).clone(),
                        stage: "not read",
                        cause: e.to_string(),
                    })
                }
            };
            ((*p).clone(), f)
        })
        .collect();

    let mut failed = false;
    let mut errors: Vec<String> = Vec::new();
    for (p, r) in &runs {
        if let Err(e) = r {
            errors.push(format!("{e}"));
            let _ = p;
        }
    }
    for r in fits.values() {
        if let Err(e) = r {
            // A log that was not read is reported once, by its read error.
            if !matches!(e, crate::Error::Skipped { .. }) {
                errors.push(format!("{e}"));
            }
        }
    }

    // The validations and the batch need nothing from each other: they run
    // side by side (each collected in order, so the output does not depend
    // on the thread count).
    bar.set_message("validating against sweeps; batch: worst-case amplitudes");
    let mut vopts = ValidateOptions::default();
    vopts.predict.samples = args.samples;
    let validate_all = || -> Vec<(Pair, crate::Result<Validation>)> {
        plan.validate
            .par_iter()
            .map(|pair| {
                let r = match (
                    &fits[&pair.characteristic],
                    &runs[&pair.characteristic],
                    &runs[&pair.sweep],
                ) {
                    (Ok(f), Ok(cr), Ok(sr)) => validate::validate(f, cr, sr, &vopts),
                    (Err(e), _, _) | (_, Err(e), _) | (_, _, Err(e)) => {
                        Err(crate::Error::Skipped {
                            path: pair.sweep.clone(),
                            stage: "not validated",
                            cause: e.to_string(),
                        })
                    }
                };
                bar.inc(1);
                (pair.clone(), r)
            })
            .collect()
    };
    // The batch: the plan's batch logs that fitted (a stuck or
    // never-sticking log enters as a bound).
    let run_batch = || -> Option<crate::Result<vb::Batch>> {
        (!plan.batch.is_empty()).then(|| {
            // The logs that were read and fitted, each test once.
            let both: Vec<(PathBuf, LogFit, crate::ingest::RigMeta)> = plan
                .batch
                .iter()
                .filter_map(|p| match (&fits[p], &runs[p]) {
                    (Ok(f), Ok(r)) => Some((p.clone(), f.clone(), r.rig.clone())),
                    _ => None,
                })
                .collect();
            let (keep, dup_warnings) = super::find_duplicates(
                &both
                    .iter()
                    .map(|(p, f, rig)| super::TestId {
                        path: p,
                        rig,
                        normal_force_n: f.normal_force_n,
                        drive_amplitude_m: f.drive.amplitude_m,
                        drive_frequency_hz: f.drive.frequency_hz,
                    })
                    .collect::<Vec<_>>(),
            );
            let kept: Vec<&(PathBuf, LogFit, crate::ingest::RigMeta)> = both
                .iter()
                .zip(&keep)
                .filter(|(_, k)| **k)
                .map(|(x, _)| x)
                .collect();
            let good: Vec<(PathBuf, LogFit)> = kept
                .iter()
                .map(|(p, f, _)| (p.clone(), f.clone()))
                .collect();
            let mut rigs: Vec<(PathBuf, crate::ingest::RigMeta)> = kept
                .iter()
                .map(|(p, _, r)| (p.clone(), r.clone()))
                .collect();
            if rigs.is_empty() {
                rigs = plan
                    .batch
                    .iter()
                    .filter_map(|p| runs[p].as_ref().ok().map(|r| (p.clone(), r.rig.clone())))
                    .collect();
            }
            let Some((_, rig)) = rigs.first() else {
                return Err(crate::Error::Input {
                    path: args.plan.clone(),
                    msg: "no log of the batch could be read".into(),
                });
            };
            if good.is_empty() {
                return Err(crate::Error::Input {
                    path: args.plan.clone(),
                    msg: "no log of the batch could be fitted".into(),
                });
            }
            let tick = |_: u64| {};
            vb::batch_with_progress(&good, rig, &vb::BatchOptions::default(), &tick).map(|mut b| {
                let mut w = dup_warnings.clone();
                w.extend(vb::rig_warnings(&rigs));
                w.append(&mut b.warnings);
                b.warnings = w;
                b
            })
        })
    };
    let (validations, batch) = rayon::join(validate_all, run_batch);
    for (_, r) in &validations {
        if let Err(e) = r {
            errors.push(format!("{e}"));
        }
    }
    if let Some(Err(e)) = &batch {
        errors.push(format!("{e}"));
    }
    bar.inc(1);
    bar.finish_and_clear();
    for e in &errors {
        eprintln!("error: {e}");
        failed = true;
    }

    // JSON.
    let fit_entries: Vec<Value> = chars
        .iter()
        .map(|p| match &fits[*p] {
            Ok(f) => f.to_json(p),
            Err(e) => json!({"log": p.display().to_string(), "error": e.to_string()}),
        })
        .collect();
    let val_entries: Vec<Value> = validations
        .iter()
        .map(|(pair, r)| match (r, &fits[&pair.characteristic]) {
            (Ok(v), Ok(f)) => v.to_json(&pair.characteristic, &pair.sweep, f),
            (Err(e), _) | (_, Err(e)) => json!({
                "characteristic": pair.characteristic.display().to_string(),
                "sweep": pair.sweep.display().to_string(),
                "error": e.to_string(),
            }),
        })
        .collect();
    let mut out = json!({
        "plan": args.plan.display().to_string(),
        "fits": fit_entries,
        "validations": val_entries,
        "seconds": t0.elapsed().as_secs_f64(),
    });
    match &batch {
        Some(Ok(b)) => {
            let mut m = b.to_json_map();
            m.insert(
                "logs".into(),
                json!(plan
                    .batch
                    .iter()
                    .map(|p| p.display().to_string())
                    .collect::<Vec<_>>()),
            );
            out["batch"] = Value::Object(m);
        }
        Some(Err(e)) => out["batch"] = json!({"error": e.to_string()}),
        None => {}
    }

    if let Some(dir) = &args.report {
        let rd = html::ReportDir::create(dir, &logs)?;
        let mut page = html::Page {
            title: plan
                .title
                .clone()
                .unwrap_or_else(|| format!("stickslip report: {}", args.plan.display())),
            version: env!("CARGO_PKG_VERSION").into(),
            command: std::env::args().collect::<Vec<_>>().join(" "),
            ..html::Page::default()
        };
        for (pair, r) in &validations {
            if let (Ok(v), Ok(f)) = (r, &fits[&pair.characteristic]) {
                page.validations.push(crate::report::sections::validation_section(
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
        if let Some(Ok(b)) = &batch {
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
        for p in &chars {
            page.fits.push(match (&fits[*p], &runs[*p]) {
                (Ok(f), Ok(run)) => crate::report::sections::fit_section(&rd, p, run, f)?,
                (Err(e), _) | (_, Err(e)) => views::fit_error_view(p, &e.to_string()),
            });
        }
        page.warnings = errors.clone();
        page.inputs = logs
            .iter()
            .filter_map(|p| html::input_file(p).ok())
            .collect();
        let index = rd.write_page(&page)?;
        out["report"] = json!(index.display().to_string());
        if !args.json {
            eprintln!("report: {}", index.display());
        }
    }
    out["seconds"] = json!(t0.elapsed().as_secs_f64());
    if let Some(path) = &args.out {
        super::write_json(path, &out)?;
    }
    if args.json {
        super::print_json(&out);
    } else {
        eprintln!("done in {:.1} s", t0.elapsed().as_secs_f64());
    }
    Ok(!failed)
}
