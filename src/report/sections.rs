//! The report sections of the pipeline's results: each writes its figure
//! into the report directory and returns the view the HTML page shows.

use super::{characteristic_plot, html, validation_plot, views};
use crate::identify::{self, LogFit};
use crate::ingest::Run;
use crate::validate::Validation;
use std::path::Path;

/// What the fit section of `run` (fitted as `f`) draws: its characteristic
/// (at unit gains), a few thousand points.
pub fn fit_points(
    run: &Run,
    f: &LogFit,
) -> crate::Result<characteristic_plot::CharacteristicPoints> {
    let ch = identify::characteristic(run, &identify::Gains::default())?;
    Ok(characteristic_plot::fit_points(&ch, f))
}

/// Writes the characteristic figure of a fitted log (paper Figs. 8–9; what
/// it shows is [`characteristic_plot::fit_figure`]'s call) from the points
/// kept of it ([`fit_points`]) and returns its fit section for the report,
/// with its rig record's notes.
pub fn fit_section(
    dir: &html::ReportDir,
    log: &Path,
    points: &characteristic_plot::CharacteristicPoints,
    notes: Option<&str>,
    f: &LogFit,
) -> crate::Result<html::FitView> {
    let name = format!("characteristic_{}.svg", html::stem(log));
    characteristic_plot::fit_figure(log, points, f, &dir.file(&name)?)?;
    Ok(views::fit_view(log, f, notes, Some(name)))
}

/// Writes the validation figure and returns its view for the report.
pub fn validation_section(
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
