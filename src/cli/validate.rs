//! `stickslip validate`: fit the law of a characteristic log, predict a
//! sweep log's frequency response with it (steady state and replay, with
//! 95 % bands), score it, and optionally write an HTML report.

use crate::identify::{self, IdentifyOptions, LogFit};
use crate::ingest::{self, IngestOptions, Run};
use crate::report::{html, validation_plot, views};
use crate::validate::{self, ValidateOptions, Validation};
use clap::Args;
use serde_json::{json, Value};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Arguments of `stickslip validate`.
#[derive(Debug, Args)]
pub struct ValidateArgs {
    /// Characteristic log whose fitted law is validated.
    #[arg(long)]
    pub characteristic: PathBuf,
    /// Sweep log (stepped or continuous) to predict.
    #[arg(long)]
    pub sweep: PathBuf,
    /// Write an HTML report (index.html and SVG figures) into this directory.
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// Write the JSON result to this file (atomically).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Laws drawn from the fit's uncertainty for the 95 % bands (0: none).
    #[arg(long, default_value_t = 40)]
    pub samples: usize,
    /// Relative gain uncertainty of each sensor in the calibration budget.
    #[arg(long, default_value_t = 0.01, value_parser = super::args::gain_fraction)]
    pub gain_uncertainty: f64,
    /// Period budget of the fitted law's steady state at each point (points
    /// with no periodic response by then are reported without one).
    #[arg(long, default_value_t = validate::predict::DEFAULT_STEADY_PERIODS, value_parser = super::args::periods())]
    pub max_periods: u64,
    /// Use a characteristic log and a sweep whose rig constants (M1, M2, K1, K2, d) differ by more than 1 %.
    #[arg(long)]
    pub allow_mixed_rigs: bool,
    /// Print one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
}

fn list(v: &[Option<f64>]) -> Value {
    Value::Array(
        v.iter()
            .map(|x| x.map_or(Value::Null, super::fit::num))
            .collect(),
    )
}

fn predicted_json(p: &validate::predict::Predicted) -> Value {
    json!({
        "eta": p.eta.iter().map(|&x| super::fit::num(x)).collect::<Vec<_>>(),
        "amplitude1": list(&p.amplitude1),
        "amplitude2": list(&p.amplitude2),
        "amplitude1_low": list(&p.amplitude1_low),
        "amplitude1_high": list(&p.amplitude1_high),
        "amplitude2_low": list(&p.amplitude2_low),
        "amplitude2_high": list(&p.amplitude2_high),
    })
}

/// The JSON object of one validation (interface keys plus details).
pub(crate) fn validation_json(
    char_log: &Path,
    sweep_log: &Path,
    f: &LogFit,
    v: &Validation,
) -> Value {
    let m = &v.measured;
    let p = &v.prediction;
    let s = &p.score;
    let opt = |x: Option<f64>| x.map_or(Value::Null, super::fit::num);
    let bools = |b: &[Option<bool>]| {
        b.iter()
            .map(|x| x.map_or(Value::Null, Value::Bool))
            .collect::<Vec<_>>()
    };
    json!({
        "characteristic": char_log.display().to_string(),
        "sweep": sweep_log.display().to_string(),
        "fit": super::fit::entry(char_log, f),
        "sweep_kind": match m.kind { validate::frc::SweepKind::Stepped => "stepped", validate::frc::SweepKind::Continuous => "continuous" },
        "direction": m.direction.as_str(),
        "drive_amplitude_m": super::fit::num(m.drive_amplitude_m),
        "law_at_sweep": {
            "law": p.law.name(),
            "rho_s": super::fit::num(p.law.rho_s()),
            "rho_d": super::fit::num(p.law.rho_d()),
            "slope": super::fit::num(p.law.slope()),
        },
        "measured": {
            "eta": m.points.iter().map(|q| super::fit::num(q.eta)).collect::<Vec<_>>(),
            "frequency_hz": m.points.iter().map(|q| super::fit::num(q.frequency_hz)).collect::<Vec<_>>(),
            "amplitude1": m.points.iter().map(|q| super::fit::num(q.amplitude1)).collect::<Vec<_>>(),
            "amplitude2": m.points.iter().map(|q| super::fit::num(q.amplitude2)).collect::<Vec<_>>(),
            "steady_reached": bools(&p.steady_reached),
            "settled_data": bools(&m.points.iter().map(|q| q.settled).collect::<Vec<_>>()),
            "rel_change": list(&m.points.iter().map(|q| q.rel_change).collect::<Vec<_>>()),
            "amplitude1_uncertainty": m.points.iter().map(|q| super::fit::num(q.amplitude1_u)).collect::<Vec<_>>(),
            "amplitude2_uncertainty": m.points.iter().map(|q| super::fit::num(q.amplitude2_u)).collect::<Vec<_>>(),
            "noise_x1_m": super::fit::num(m.noise_m.0),
            "noise_x2_m": super::fit::num(m.noise_m.1),
            "window_s": m.points.iter().map(|q| json!([q.window_s.0, q.window_s.1])).collect::<Vec<_>>(),
        },
        "predicted": predicted_json(&p.steady),
        "replay": predicted_json(&p.replay),
        "replay_settled": bools(&p.replay_settled),
        "score": {
            "rms_amplitude1": opt(s.rms_amplitude1),
            "rms_amplitude2": opt(s.rms_amplitude2),
            "nrms_amplitude1": opt(s.nrms_amplitude1),
            "nrms_amplitude2": opt(s.nrms_amplitude2),
            "peak_eta_error": opt(s.peak_eta_error),
            "replay_nrms_amplitude1": opt(s.replay_nrms_amplitude1),
            "replay_nrms_amplitude2": opt(s.replay_nrms_amplitude2),
            "replay_coverage_amplitude1": opt(s.replay_coverage_amplitude1),
            "replay_coverage_amplitude2": opt(s.replay_coverage_amplitude2),
            "replay_coverage_strict_amplitude1": opt(s.replay_coverage_strict_amplitude1),
            "replay_coverage_strict_amplitude2": opt(s.replay_coverage_strict_amplitude2),
            "band_median_rel_halfwidth1": opt(s.band_median_rel_halfwidth1),
            "steady_points": s.steady_points,
            "points": m.points.len(),
        },
        "draws": p.draws,
        "warnings": v.warnings,
    })
}

/// Reads two logs in parallel.
pub(crate) fn read_pair(a: &Path, b: &Path) -> crate::Result<(Run, Run)> {
    let (ra, rb) = rayon::join(
        || ingest::read(a, &IngestOptions::default()),
        || ingest::read(b, &IngestOptions::default()),
    );
    Ok((ra?, rb?))
}

/// Writes the characteristic figure of a fitted log (paper Figs. 8–9) and
/// returns its fit section for the report.
pub(crate) fn fit_section(
    dir: &html::ReportDir,
    log: &Path,
    run: &Run,
    f: &LogFit,
) -> crate::Result<html::FitView> {
    let name = format!("characteristic_{}.svg", html::stem(log));
    let ch = identify::characteristic(run, &identify::Gains::default())?;
    let e = &f.fit;
    // The law used downstream, and beside it the equation-error law (the
    // one fitted to these very points) where the output error refined it,
    // else the Stribeck alternative.
    let (law, law_label, alternative, alternative_label) = if e.stuck {
        (None, "fitted", None, "alternative")
    } else if f.estimate == identify::Estimate::OutputError {
        (
            f.law(),
            "output error (used)",
            Some(e.law),
            "equation error",
        )
    } else {
        let alt = e.stribeck.filter(|s| s.kind != e.law.kind);
        (Some(e.law), "fitted", alt, "alternative")
    };
    let bias = if e.bias_n.is_finite() { e.bias_n } else { 0.0 };
    let title = format!(
        "Characteristic of {}",
        log.file_name()
            .map_or("log".into(), |n| n.to_string_lossy())
    );
    crate::report::characteristic_plot::characteristic_figure(
        &crate::report::characteristic_plot::CharacteristicFigure {
            title: &title,
            contact: &ch.contact,
            stick: &ch.segmentation.stick,
            bias_n: bias,
            law,
            law_label,
            threshold: !f.never_sticks(),
            alternative,
            alternative_label,
        },
        &dir.file(&name)?,
    )?;
    Ok(views::fit_view(
        log,
        f,
        run.rig.notes.as_deref(),
        Some(name),
    ))
}

/// Writes the validation figure and returns its view for the report.
pub(crate) fn validation_section(
    dir: &html::ReportDir,
    char_log: &Path,
    sweep_log: &Path,
    f: &LogFit,
    v: &Validation,
) -> crate::Result<html::ValidationView> {
    let name = format!("frc_{}.svg", html::stem(sweep_log));
    let title = format!(
        "{} with the law of {}",
        sweep_log
            .file_name()
            .map_or("sweep".into(), |n| n.to_string_lossy()),
        char_log
            .file_name()
            .map_or("log".into(), |n| n.to_string_lossy())
    );
    validation_plot::validation_figure(&title, &v.measured, &v.prediction, &dir.file(&name)?)?;
    Ok(views::validation_view(
        sweep_log,
        char_log,
        f,
        v,
        f.estimate.as_str(),
        name,
    ))
}

/// Runs `validate`.
pub fn run(args: ValidateArgs) -> crate::Result<()> {
    crate::io::ensure_not_inputs(
        [args.characteristic.as_path(), args.sweep.as_path()],
        args.out.as_deref(),
    )?;
    let t0 = Instant::now();
    let say = |msg: &str| {
        if !args.json {
            eprintln!("{msg}");
        }
    };
    say("reading logs");
    let (char_run, sweep_run) = read_pair(&args.characteristic, &args.sweep)?;
    super::refuse_mixed_rigs(
        &[
            (args.characteristic.clone(), char_run.rig.clone()),
            (args.sweep.clone(), sweep_run.rig.clone()),
        ],
        args.allow_mixed_rigs,
    )?;
    say("fitting the friction law");
    let opts = IdentifyOptions {
        gain_uncertainty: args.gain_uncertainty,
        ..IdentifyOptions::default()
    };
    let fit = identify::fit_log(&char_run, &opts)?;
    say(&format!(
        "measuring the sweep and predicting it ({} laws for the bands)",
        args.samples
    ));
    let mut vo = ValidateOptions::default();
    vo.predict.samples = args.samples;
    vo.predict.steady.max_periods = args.max_periods;
    vo.frc.gain_uncertainty = args.gain_uncertainty;
    let v = validate::validate(&fit, &char_run, &sweep_run, &vo)?;
    let mut out = validation_json(&args.characteristic, &args.sweep, &fit, &v);
    out["seconds"] = json!(t0.elapsed().as_secs_f64());
    if let Some(dir) = &args.report {
        let inputs = [args.characteristic.clone(), args.sweep.clone()];
        let rd = html::ReportDir::create(dir, &inputs)?;
        let section = validation_section(&rd, &args.characteristic, &args.sweep, &fit, &v)?;
        let fv = fit_section(&rd, &args.characteristic, &char_run, &fit)?;
        let page = html::Page {
            title: format!("Validation of {}", args.sweep.display()),
            version: env!("CARGO_PKG_VERSION").into(),
            command: std::env::args().collect::<Vec<_>>().join(" "),
            summary: vec![],
            warnings: vec![],
            batch: None,
            validations: vec![section],
            fits: vec![fv],
            inputs: inputs
                .iter()
                .map(|p| html::input_file(p))
                .collect::<crate::Result<_>>()?,
        };
        let index = rd.write_page(&page)?;
        say(&format!("report: {}", index.display()));
    }
    if let Some(path) = &args.out {
        super::write_json(path, &out)?;
    }
    if args.json {
        super::print_json(&out);
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
