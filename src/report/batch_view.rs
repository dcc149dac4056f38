//! View model of the batch section: a [`Batch`] turned into the display
//! rows of [`super::html::BatchView`] (headline lines, the comparison table
//! of the normal-force settings, the figure, warnings).

use super::html::{fmt, fmt_interval, BatchView, KeyValue};
use crate::batch::{Batch, StaticObs};

/// The headline lines of a batch (also printed by `stickslip batch`).
pub fn batch_summary(b: &Batch) -> Vec<KeyValue> {
    let mu = |m: &crate::batch::MuFit| {
        let mut s = format!(
            "{:.4}, 95 % {} (statistical {}, common calibration ±{:.1} %)",
            m.mu,
            fmt_interval(Some(m.interval), 4),
            fmt_interval(Some(m.stat_interval), 4),
            100.0 * m.systematic_rel
        );
        s.push_str(&format!("; {} measured, {} censored", m.points, m.censored));
        if let Some((slope, a, hw)) = m.free {
            s.push_str(&format!(
                "; free fit: slope {slope:.4}, intercept {a:+.4} ± {hw:.4} N"
            ));
        }
        s
    };
    let aside = |pick: fn(&crate::batch::BatchLog) -> bool| -> Vec<String> {
        b.logs
            .iter()
            .filter(|l| pick(l))
            .map(|l| l.log.display().to_string())
            .collect()
    };
    let mut v = vec![KeyValue::new(
        "μs (Rs = μs·N, through the origin)",
        mu(&b.mu_s),
    )];
    let aside_s = aside(|l| l.set_aside.0);
    if !aside_s.is_empty() {
        v.push(KeyValue::new(
            format!("μs with every log (incl. {})", aside_s.join(", ")),
            mu(&b.mu_s_all),
        ));
    }
    v.push(KeyValue::new("μd (Rd = μd·N)", mu(&b.mu_d)));
    let aside_d = aside(|l| l.set_aside.1);
    if !aside_d.is_empty() {
        v.push(KeyValue::new(
            format!("μd with every log (incl. {})", aside_d.join(", ")),
            mu(&b.mu_d_all),
        ));
    }
    if !b.conflicts.is_empty() {
        v.push(KeyValue::new(
            "conflicts between logs",
            format!(
                "{} (see below){}",
                b.conflicts.len(),
                if aside_s.is_empty() && aside_d.is_empty() {
                    String::new()
                } else {
                    "; μ above without the logs set aside".to_string()
                }
            ),
        ));
    }
    match &b.recommendation {
        Some(r) => {
            v.push(KeyValue::new(
                "recommended normal force",
                format!(
                    "{:.3} N (ρs = {:.4}, ρd = {:.4}); window {}",
                    r.normal_force_n,
                    r.rho_s,
                    r.rho_d,
                    fmt_interval(Some(r.interval_n), 3)
                ) + &format!(
                    " N (robust worst case within {:.0} % of the best)",
                    100.0 * b.window
                ),
            ));
            v.push(KeyValue::new(
                "worst case at the recommendation",
                format!(
                    "max A1/A = {:.3} at η = {:.4} ({}); over μ intervals and ±{:.0} % setting: {} ",
                    r.worst.amplitude1,
                    r.worst.eta,
                    r.worst.branch.as_str(),
                    100.0 * b.setting_tolerance,
                    fmt_interval(Some(r.worst_interval), 3)
                ),
            ));
            if r.worst.coexisting > 0 {
                v.push(KeyValue::new(
                    "coexisting stable states at the recommendation",
                    format!(
                        "at {} of the η nodes evaluated (first at η = {:.4}) the up, down and from-rest branches settle to different steady states (> 1e-6 relative); the worst case takes the worst of them, on this grid",
                        r.worst.coexisting, r.worst.coexisting_eta
                    ),
                ));
            }
        }
        None => v.push(KeyValue::new(
            "recommended normal force",
            format!(
                "none: {}",
                b.recommendation_reason
                    .as_deref()
                    .unwrap_or("no reason recorded")
            ),
        )),
    }
    v.push(KeyValue::new(
        "cliff (η1 peak returns below)",
        match &b.cliff {
            Some(c) => format!(
                "ρs = {:.4} ({:.3} N): max A1/A = {:.2} at η = {:.4} just below; margin {:.4} in ρs, {:.3} N, {:.1} % of the recommendation",
                c.rho_s,
                c.normal_force_n,
                c.worst_below.amplitude1,
                c.worst_below.eta,
                c.margin_rho_s,
                c.margin_n,
                100.0 * c.margin_rel
            ),
            None => "none found on the grid".into(),
        },
    ));
    v.push(KeyValue::new("pad simulated", pad_words(&b.pad)));
    v.push(KeyValue::new(
        "model",
        format!(
            "m = {:.4}, k = {:.4}, D = {:.5}; ρ = R/(A·K2) with A = {:.4} mm ({}; logs' median measured {:.4} mm); η ∈ [{:.4}, {:.4}], a grid of {} points per branch ({} coarse, evaluated at every ρs; the others next to a branch's maxima, {} to {} per ρs); {} worst-case evaluations",
            b.absorber.m,
            b.absorber.k,
            b.absorber.damping,
            b.drive_amplitude_m * 1e3,
            b.drive_amplitude_source,
            b.measured_drive_amplitude_m * 1e3,
            b.eta_range.0,
            b.eta_range.1,
            b.eta_points,
            b.eta_coarse_points,
            b.curve.iter().map(|c| c.worst.points).min().unwrap_or(0),
            b.curve.iter().map(|c| c.worst.points).max().unwrap_or(0),
            b.evaluations
        ),
    ));
    v
}

/// The pad the worst cases simulate, in words: each real-pad extension
/// the logs chose, combined over them, and whether it is simulated.
fn pad_words(pad: &crate::batch::BatchPad) -> String {
    let one = |name: &str, c: &crate::batch::Combined| {
        format!(
            "{name} {:.4} {} from {} of {} logs that slid{}, {}",
            c.value,
            c.interval
                .map_or("(no interval)".into(), |(lo, hi)| format!(
                    "[{lo:.4}, {hi:.4}]"
                )),
            c.chosen,
            c.eligible,
            c.chi2_per_dof
                .map_or(String::new(), |x| format!(" (χ²/dof {x:.2})")),
            if c.used {
                "simulated"
            } else {
                "not simulated (fewer than half)"
            }
        )
    };
    let power = |c: &crate::batch::Combined| {
        c.by_normal_force.map_or(String::new(), |l| {
            format!(
                "; that κ at N_ref {:.3} N, κ ∝ N^γ with γ {:.3} [{:.3}, {:.3}] (χ² {:.1} below one κ's)",
                l.reference_n,
                l.exponent,
                l.exponent_interval.0,
                l.exponent_interval.1,
                l.delta_chi2
            )
        })
    };
    let parts: Vec<String> = [
        pad.contact
            .as_ref()
            .map(|c| one("contact stiffness κ", c) + &power(c)),
        pad.split
            .as_ref()
            .map(|c| one("split threshold ρs⁻/ρs⁺", c)),
    ]
    .into_iter()
    .flatten()
    .collect();
    if parts.is_empty() {
        "the paper's pad (symmetric, rigid stick): no log chose an extension".into()
    } else {
        parts.join("; ")
    }
}

/// The batch section of the report (settings ordered by normal force);
/// `figure` is the figure's file name.
pub fn batch_view(b: &Batch, figure: Option<String>) -> BatchView {
    let mut logs: Vec<&crate::batch::BatchLog> = b.logs.iter().collect();
    logs.sort_by(|x, y| x.normal_force_n.total_cmp(&y.normal_force_n));
    let header = [
        "log",
        "N (N)",
        "Rs information",
        "Rs/N",
        "Rd/N",
        "ρs (batch μs, nominal A)",
        "worst max A1/A",
        "at η",
        "branch",
        "bound consistent",
        "set aside (conflict)",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    let rows = logs
        .iter()
        .map(|l| {
            let info = match l.static_obs {
                StaticObs::Point { rs_n, sigma_n } => {
                    format!("{rs_n:.4} N ± {:.4} (stat. 95 %)", 1.96 * sigma_n)
                }
                StaticObs::Above { .. } => format!(
                    "stuck: Rs ≥ {} N",
                    fmt(l.mu_s.1.map(|m| m * l.normal_force_n), 4)
                ),
                StaticObs::Between { .. } => format!(
                    "never sticks: Rs in [{}, {}] N",
                    fmt(l.mu_s.1.map(|m| m * l.normal_force_n), 4),
                    fmt(l.mu_s.2.map(|m| m * l.normal_force_n), 4)
                ),
                StaticObs::Unknown => "–".into(),
            };
            let mu_s = match l.static_obs {
                StaticObs::Point { .. } => fmt(l.mu_s.0, 4),
                StaticObs::Above { .. } => format!("≥ {}", fmt(l.mu_s.1, 4)),
                StaticObs::Between { .. } => {
                    format!("[{}, {}]", fmt(l.mu_s.1, 4), fmt(l.mu_s.2, 4))
                }
                StaticObs::Unknown => "–".into(),
            };
            vec![
                l.log.display().to_string(),
                format!("{:.3}", l.normal_force_n),
                info,
                mu_s,
                fmt(l.mu_d, 4),
                fmt(Some(l.model_rho_s), 4),
                fmt(l.worst.map(|w| w.amplitude1), 3),
                fmt(l.worst.map(|w| w.eta), 4),
                l.worst
                    .map_or("–".into(), |w| w.branch.as_str().to_string()),
                match l.consistent {
                    Some(true) => "yes".into(),
                    Some(false) => "no".into(),
                    None => "–".into(),
                },
                match l.set_aside {
                    (true, true) => "from μs and μd".into(),
                    (true, false) => "from μs".into(),
                    (false, true) => "from μd".into(),
                    (false, false) => "–".into(),
                },
            ]
        })
        .collect();
    BatchView {
        summary: batch_summary(b),
        header,
        rows,
        figure,
        conflicts: b.conflicts.iter().map(|c| c.what.clone()).collect(),
        warnings: b
            .warnings
            .iter()
            // The conflicts are listed above on their own.
            .filter(|w| !matches!(w, crate::warning::Warning::Conflict { .. }))
            .map(ToString::to_string)
            .collect(),
    }
}
