//! View models of the HTML report: the typed results of the stages (a
//! [`LogFit`], a [`Validation`]) turned into the display rows of
//! [`super::html`]. Numbers are formatted here, once.

use super::html::{fmt, fmt_interval, FitView, KeyValue, ParamRow, ValidationView};
use crate::identify::LogFit;
use crate::validate::Validation;
use std::path::Path;

/// The fit section of one characteristic log.
pub fn fit_view(
    log: &Path,
    f: &LogFit,
    rig_notes: Option<&str>,
    figure: Option<String>,
) -> FitView {
    let e = &f.fit;
    let law = f.law();
    let mut flags = vec![
        format!("law: {}", f.kind().as_str()),
        format!("{} estimate", f.estimate.as_str()),
    ];
    if e.stuck {
        flags.push("stuck: only a lower bound on Rs".into());
    }
    if f.never_sticks() {
        flags.push("never sticks: Rs only bounded".into());
    }
    flags.push(adequacy_flag(f));
    flags.push(format!("N = {:.3} N", f.normal_force_n));
    flags.push(format!(
        "A = {:.4} mm (measured)",
        f.drive.amplitude_m * 1e3
    ));
    flags.push(format!("η = {:.4}", f.eta));
    let finite = |x: f64| x.is_finite().then_some(x);
    let mut rows = Vec::new();
    let mut row = |name: &str, v: Option<f64>, iv: Option<(f64, f64)>, unit: &str, d: usize| {
        rows.push(ParamRow {
            name: name.into(),
            value: fmt(v, d),
            interval: fmt_interval(iv, d),
            unit: unit.into(),
        });
    };
    if e.stuck {
        row("Rs lower bound", f.rs_lower_bound_n(), None, "N", 4);
        row("ρs lower bound", f.rho_s_lower_bound(), None, "–", 4);
    } else {
        row("Rs", f.rs_n(), f.rs_interval_n, "N", 4);
        row("Rd", law.map(|l| l.rd_n), f.rd_interval_n, "N", 4);
        row(
            "slope a",
            law.map(|l| l.slope_n_s_per_m),
            f.slope_interval_n_s_per_m,
            "N·s/m",
            3,
        );
        row("ρs", f.rho_s(), f.rho_s_interval, "–", 4);
        row("ρd", f.rho_d(), f.rho_d_interval, "–", 4);
        row("D*", f.dstar(), f.dstar_interval, "–", 4);
        row("residual RMS", finite(e.residual_rms_n), None, "N", 4);
    }
    if let Some(s) = &e.stribeck {
        row("Stribeck Rs", finite(s.rs_n), None, "N", 4);
        row("Stribeck Rd", finite(s.rd_n), None, "N", 4);
        row(
            "Stribeck slope",
            finite(s.slope_n_s_per_m),
            None,
            "N·s/m",
            3,
        );
        row("Stribeck v_s", s.vs_m_per_s, None, "m/s", 5);
    }
    FitView {
        log: log.display().to_string(),
        flags,
        error: None,
        rows,
        figure,
        warnings: crate::warning::messages(&f.warnings),
        notes: f.notes.clone(),
        rig_notes: rig_notes.map(str::to_string),
    }
}

/// The fit section of a log that could not be fitted.
pub fn fit_error_view(log: &Path, error: &str) -> FitView {
    FitView {
        log: log.display().to_string(),
        error: Some(error.to_string()),
        ..FitView::default()
    }
}

fn pct(x: Option<f64>) -> String {
    x.map_or("–".into(), |v| format!("{:.1} %", 100.0 * v))
}

/// A fraction in percentage points, one decimal ("–" if none).
fn pp(x: Option<f64>) -> String {
    x.map_or("–".into(), |v| format!("{:.1}", 100.0 * v))
}

/// The validation section of one sweep.
pub fn validation_view(
    sweep: &Path,
    characteristic: &Path,
    f: &LogFit,
    v: &Validation,
    estimate: &str,
    figure: String,
) -> ValidationView {
    let p = &v.prediction;
    let s = &p.score;
    let scores = vec![
        KeyValue::new(
            "steps that reached their steady state (tool's call)",
            format!("{} of {}", s.steady_points, v.measured.points.len()),
        ),
        KeyValue::new(
            "steady state: nrms A1 / A2",
            format!("{} / {}", pct(s.nrms_amplitude1), pct(s.nrms_amplitude2)),
        ),
        KeyValue::new(
            "steady state: rms A1 / A2",
            format!(
                "{} / {}",
                fmt(s.rms_amplitude1, 4),
                fmt(s.rms_amplitude2, 4)
            ),
        ),
        KeyValue::new(
            "peak η error (predicted − measured)",
            fmt(s.peak_eta_error, 4),
        ),
        KeyValue::new(
            "replay: nrms A1 / A2",
            format!(
                "{} / {}",
                pct(s.replay_nrms_amplitude1),
                pct(s.replay_nrms_amplitude2)
            ),
        ),
        KeyValue::new(
            "replay: robust nrms A1 / A2 (steps not marked sensitive)",
            format!(
                "{} / {}",
                pct(s.replay_nrms_robust_amplitude1),
                pct(s.replay_nrms_robust_amplitude2)
            ),
        ),
        KeyValue::new(
            "replay: measured value inside the 95 % band (strict coverage), A1 / A2",
            format!(
                "{} / {}",
                pct(s.replay_coverage_strict_amplitude1),
                pct(s.replay_coverage_strict_amplitude2)
            ),
        ),
        KeyValue::new(
            "replay: measured error bar overlaps the 95 % band (loose coverage), A1 / A2",
            format!(
                "{} / {}",
                pct(s.replay_coverage_amplitude1),
                pct(s.replay_coverage_amplitude2)
            ),
        ),
        KeyValue::new(
            "replay band: median relative half-width of A1",
            pct(s.band_median_rel_halfwidth1),
        ),
        KeyValue::new(
            "laws drawn for the bands",
            format!(
                "{} (at most {}; the coverages A1 / A2 are known to ±{} / ±{} percentage points, bootstrap standard error, target ±{}{})",
                p.draws,
                p.band.draws_max,
                pp(p.band.coverage_se_amplitude1),
                pp(p.band.coverage_se_amplitude2),
                pp(Some(p.band.target)),
                if p.band.reached || p.draws == 0 { "" } else { ": not reached" }
            ),
        ),
        KeyValue::new("law at the sweep's amplitude", law_text(&p.law)),
    ];
    let header = [
        "η",
        "f (Hz)",
        "A1/A meas",
        "A1/A steady",
        "A1/A replay",
        "replay band",
        "A2/A meas",
        "A2/A steady",
        "A2/A replay",
        "data trend",
        "replay settled",
        "steady reached",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    let yn = |b: Option<bool>| match b {
        Some(true) => "yes".to_string(),
        Some(false) => "no".to_string(),
        None => "–".to_string(),
    };
    let steps = v
        .measured
        .points
        .iter()
        .enumerate()
        .map(|(i, m)| {
            vec![
                format!("{:.4}", m.eta),
                format!("{:.3}", m.frequency_hz),
                format!("{:.4}", m.amplitude1),
                fmt(p.steady.amplitude1[i], 4),
                fmt(p.replay.amplitude1[i], 4),
                match (p.replay.amplitude1_low[i], p.replay.amplitude1_high[i]) {
                    (Some(l), Some(h)) => format!("[{l:.3}, {h:.3}]"),
                    _ => "–".into(),
                },
                format!("{:.4}", m.amplitude2),
                fmt(p.steady.amplitude2[i], 4),
                fmt(p.replay.amplitude2[i], 4),
                yn(m.settled),
                yn(p.replay_settled[i]),
                yn(p.steady_reached[i]),
            ]
        })
        .collect();
    ValidationView {
        sweep: sweep.display().to_string(),
        characteristic: characteristic.display().to_string(),
        law: f.kind().as_str().to_string(),
        estimate: estimate.to_string(),
        amplitude: format!("{:.4} mm", v.measured.drive_amplitude_m * 1e3),
        scores,
        figure,
        header,
        steps,
        warnings: crate::warning::messages(&v.warnings),
    }
}

/// A dimensionless law in one line.
pub fn law_text(l: &crate::model::Law) -> String {
    let base = format!(
        "ρs = {:.4}, ρd = {:.4}, D* = {:.4}",
        l.rho_s(),
        l.rho_d(),
        l.slope()
    );
    match l.v_s() {
        Some(v_s) => format!("{base}, v_s = {v_s:.4}"),
        None => base,
    }
}

/// The adequacy verdict of a fit, as one flag of the report.
pub fn adequacy_flag(f: &LogFit) -> String {
    let mut s = if f.adequate() {
        "adequate".to_string()
    } else {
        "NOT ADEQUATE".to_string()
    };
    if let Some(a) = &f.adequacy {
        s.push_str(&format!(
            ": residual/noise x1 {:.2}, x2 {:.2}",
            a.noise_ratio.0, a.noise_ratio.1
        ));
        if let Some(r) = a.force_ratio {
            s.push_str(&format!(", force {r:.2}"));
        }
        if let Some(st) = a
            .structure
            .iter()
            .filter(|s| s.counted())
            .max_by(|p, q| p.effect.total_cmp(&q.effect))
        {
            s.push_str(&format!(
                "; largest structure {:.2} of the noise ({} vs {}, z {:.1})",
                st.effect, st.channel, st.against, st.z
            ));
        }
        if a.inflation > 1.0 {
            s.push_str(&format!("; intervals widened ×{:.2}", a.inflation));
        }
    } else if f.adequate() {
        s.push_str(" (stuck: nothing slides to test)");
    } else {
        s.push_str(" (not tested: equation-error estimate)");
    }
    if !f.contradictions.is_empty() {
        s.push_str("; contradicting bounds");
    }
    s
}
