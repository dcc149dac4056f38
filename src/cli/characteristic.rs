//! `stickslip characteristic`: the contact force R(t) of a characteristic log
//! (paper eq. 7) with ẋ2 and the stick flag, as a CSV table.

use crate::identify::{self, Gains};
use crate::ingest::{self, IngestOptions};
use crate::io::AtomicFile;
use crate::io::Output;
use clap::Args;
use std::io::Write;
use std::path::PathBuf;

/// Arguments of `stickslip characteristic`.
#[derive(Debug, Args)]
pub struct CharacteristicArgs {
    /// The characteristic log.
    pub log: PathBuf,
    /// Write the table (CSV: t_s, r_n, v2_m_per_s, stick, rho, v2_dimless);
    /// R has the estimated force bias removed.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Write the figure (SVG).
    #[arg(long)]
    pub plot: Option<PathBuf>,
    /// Print one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
}

/// The `characteristic --json` object (non-finite numbers: null).
#[derive(serde::Serialize)]
struct CharacteristicOut<'a> {
    log: String,
    samples: usize,
    drive_amplitude_m: f64,
    drive_frequency_hz: f64,
    acceleration_source: &'a str,
    sticks: usize,
    breakaways: usize,
    reversals: usize,
    stuck: bool,
    never_sticks: bool,
    velocity_noise_m_per_s: f64,
    out: Option<String>,
    bias_n: f64,
    #[serde(serialize_with = "crate::warning::as_messages")]
    warnings: &'a [crate::warning::Warning],
    /// One stable code per warning (`crate::warning::Warning::code`).
    warning_codes: Vec<&'static str>,
}

/// Writes the characteristic table: time, R (bias removed), ẋ2 (0 where
/// sticking), the stick flag, and both dimensionless (`scales`: force and
/// velocity scales).
fn write_table(
    out: &std::path::Path,
    ch: &identify::Characteristic,
    bias: f64,
    (fs, vs): (f64, f64),
) -> crate::Result<()> {
    let c = &ch.contact;
    let mut f = AtomicFile::create(out)?;
    let mut text = String::from("t_s,r_n,v2_m_per_s,stick,rho,v2_dimless\n");
    for i in 0..c.t.len() {
        let (r, v) = (
            c.r[i] - bias,
            if ch.segmentation.stick[i] {
                0.0
            } else {
                c.v2[i]
            },
        );
        let cell = |x: f64| {
            if x.is_finite() {
                format!("{x:.9e}")
            } else {
                String::new()
            }
        };
        text.push_str(&format!(
            "{},{},{},{},{},{}\n",
            c.t[i],
            cell(r),
            cell(v),
            u8::from(ch.segmentation.stick[i]),
            cell(r / fs),
            cell(v / vs)
        ));
    }
    f.writer()
        .write_all(text.as_bytes())
        .map_err(|e| f.io_err(e))?;
    f.commit()
}

/// Runs `characteristic`.
pub fn run(args: CharacteristicArgs) -> crate::Result<()> {
    let mut outputs = Vec::new();
    if let Some(p) = &args.out {
        outputs.push(Output::file("--out", p, super::ext::CSV));
    }
    if let Some(p) = &args.plot {
        outputs.push(Output::file("--plot", p, super::ext::SVG));
    }
    super::check_paths([args.log.as_path()], &outputs)?;
    let run = ingest::read(&args.log, &IngestOptions::default())?;
    let ch = identify::characteristic(&run, &Gains::default())?;
    let c = &ch.contact;
    // The force bias (unknown position offsets) as the fit estimates it.
    let fit = identify::fit::fit(
        c,
        &ch.segmentation,
        &identify::FitOptions {
            bootstrap: 0,
            ..Default::default()
        },
    )
    .ok();
    let mut warnings = c.warnings.clone();
    let bias = match fit.as_ref().map(|f| f.bias_n) {
        Some(b) if b.is_finite() => b,
        _ => {
            warnings.push(crate::warning::Warning::BiasUnknown);
            0.0
        }
    };
    let fs = c.drive.amplitude_m * run.rig.k2_n_per_m;
    let vs = c.drive.amplitude_m * run.rig.omega_ref();
    if let Some(out) = &args.out {
        write_table(out, &ch, bias, (fs, vs))?;
    }
    if let Some(path) = &args.plot {
        let law = fit.as_ref().filter(|f| !f.stuck).map(|f| f.law);
        let alternative = fit
            .as_ref()
            .and_then(|f| f.stribeck)
            .filter(|s| Some(s.kind) != law.map(|l| l.kind));
        let title = format!("Characteristic of {}", args.log.display());
        crate::report::characteristic_plot::characteristic_figure(
            &crate::report::characteristic_plot::CharacteristicFigure {
                title: &title,
                points: &crate::report::characteristic_plot::CharacteristicPoints::new(
                    c,
                    &ch.segmentation.stick,
                    bias,
                ),
                law,
                law_label: "fitted",
                // The equation-error law's Rs is NaN where only bounded.
                threshold: true,
                minus_threshold_n: None,
                alternative,
                alternative_label: "alternative",
            },
            path,
        )?;
    }
    let seg = &ch.segmentation;
    if args.json {
        super::print_json(&crate::io::json::to_value(CharacteristicOut {
            log: args.log.display().to_string(),
            samples: c.t.len(),
            drive_amplitude_m: c.drive.amplitude_m,
            drive_frequency_hz: c.drive.frequency_hz,
            acceleration_source: c.acceleration_source,
            sticks: seg.sticks.len(),
            breakaways: seg.breakaways.len(),
            reversals: seg.reversals.len(),
            stuck: seg.stuck(),
            never_sticks: seg.never_sticks(),
            velocity_noise_m_per_s: seg.noise_v_raw,
            out: args.out.as_ref().map(|p| p.display().to_string()),
            bias_n: bias,
            warnings: &warnings,
            warning_codes: crate::warning::codes(&warnings),
        }))?;
    } else {
        eprintln!(
            "{}: {} samples, {} sticks, {} reversals, acceleration from {}",
            args.log.display(),
            c.t.len(),
            seg.sticks.len(),
            seg.reversals.len(),
            c.acceleration_source
        );
    }
    Ok(())
}
