//! The `characteristic` job: the contact force R(t) of a characteristic
//! log (paper eq. 7) with ẋ2 and the stick flag, as a CSV table and a
//! figure, written through the write transaction ([`crate::io::txn`]),
//! with its JSON object ([`CharacteristicJson`]).

use super::Progress;
use crate::identify::{self, Gains};
use crate::ingest::{self, IngestOptions};
use crate::io::AtomicFile;
use serde::Serialize;
use std::io::Write;
use std::path::PathBuf;

/// The contact-force table and figure of one characteristic log.
#[derive(Debug, Clone, PartialEq)]
pub struct CharacteristicJob {
    /// The characteristic log.
    pub log: PathBuf,
    /// Write the table (CSV: t_s, r_n, v2_m_per_s, stick, rho,
    /// v2_dimless) here; R has the estimated force bias removed.
    pub out: Option<PathBuf>,
    /// Write the figure (SVG) here.
    pub plot: Option<PathBuf>,
}

/// The `characteristic --json` object (non-finite numbers: null).
#[derive(Debug, Clone, Serialize)]
pub struct CharacteristicJson {
    /// The log.
    pub log: String,
    /// Samples of the contact force.
    pub samples: usize,
    /// Drive amplitude (m).
    pub drive_amplitude_m: f64,
    /// Drive frequency (Hz).
    pub drive_frequency_hz: f64,
    /// Where the acceleration comes from.
    pub acceleration_source: &'static str,
    /// Stick phases.
    pub sticks: usize,
    /// Breakaways.
    pub breakaways: usize,
    /// Velocity reversals.
    pub reversals: usize,
    /// M2 sticks throughout.
    pub stuck: bool,
    /// M2 never sticks.
    pub never_sticks: bool,
    /// Noise of the raw velocity (m/s).
    pub velocity_noise_m_per_s: f64,
    /// The table written, if one was.
    pub out: Option<String>,
    /// The force bias removed (N).
    pub bias_n: f64,
    /// The warnings, as messages.
    #[serde(serialize_with = "crate::warning::as_messages")]
    pub warnings: Vec<crate::warning::Warning>,
    /// One stable code per warning (`crate::warning::Warning::code`).
    pub warning_codes: Vec<&'static str>,
}

/// What [`run_characteristic`] produced.
#[derive(Debug, Clone)]
pub struct CharacteristicOutcome {
    /// The JSON result.
    pub json: CharacteristicJson,
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

/// Runs the job: reads the log, computes the contact force and its
/// segmentation, estimates the force bias (as the fit does) and writes
/// the table and the figure.
pub fn run_characteristic(
    job: &CharacteristicJob,
    _progress: &dyn Progress,
) -> crate::Result<CharacteristicOutcome> {
    let run = ingest::read(&job.log, &IngestOptions::default())?;
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
    if let Some(out) = &job.out {
        write_table(out, &ch, bias, (fs, vs))?;
    }
    if let Some(path) = &job.plot {
        let law = fit.as_ref().filter(|f| !f.stuck).map(|f| f.law);
        let alternative = fit
            .as_ref()
            .and_then(|f| f.stribeck)
            .filter(|s| Some(s.kind) != law.map(|l| l.kind));
        let title = format!("Characteristic of {}", job.log.display());
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
                law_offset_n: 0.0,
                alternative,
                alternative_label: "alternative",
                alternative_offset_n: 0.0,
            },
            path,
        )?;
    }
    let seg = &ch.segmentation;
    let json = CharacteristicJson {
        log: job.log.display().to_string(),
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
        out: job.out.as_ref().map(|p| p.display().to_string()),
        bias_n: bias,
        warning_codes: crate::warning::codes(&warnings),
        warnings,
    };
    Ok(CharacteristicOutcome { json })
}
