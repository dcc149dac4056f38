//! The batch comparison of normal-force settings (issue 7), against
//! `truth.json`:
//!
//! * `stickslip batch` on the public batch (four logs that stick and slip or
//!   never stick, one stuck log): μs and μd within 3 % of the truth and
//!   their intervals containing it; the stuck log as a lower bound and the
//!   never-sticking one as bounds, both consistent with the truth; a
//!   recommended normal force with its window, worst case and interval, and
//!   a cliff below it; the interface's JSON keys; the HTML report.
//! * A bad log among good ones: its `error:` line and entry, exit 1, the
//!   batch from the others.
//! * The claim on the worst case at the paper's parameters
//!   (m = 4, k = 1, D = 0.005, Coulomb): W ≈ 0.9 at ρs = 0.75, ≈ 7 at 0.65.
//!
//! The binary runs with a coarse worst-case grid (fewer η and ρs nodes, no
//! ratio variants) and 100 bootstrap replicates so the debug build stays
//! fast; the μ fits do not depend on the grid.

mod common;

use common::{data, f, truth};
use serde_json::Value;
use std::path::PathBuf;
use std::process::Command;
use stickslip::batch::{default_eta_range, drive_etas, worst_case, PadShape};
use stickslip::model::Absorber;
use stickslip::sim::sweep::SteadyConfig;

fn pair(v: &Value) -> (f64, f64) {
    (f(&v[0]), f(&v[1]))
}

const BATCH: [&str; 5] = [
    "char_N1.2.mcap",
    "char_N2.2.mcap",
    "char_N4.mcap",
    "char_N7.2.mcap",
    "char_N30.mcap",
];

/// Fast options: coarse grids, no ratio variants, 100 bootstrap replicates.
const FAST: [&str; 10] = [
    "--bootstrap",
    "100",
    "--eta-points",
    "41",
    "--eta-fine-step",
    "0.005",
    "--no-ratio-variants",
    "--json",
    "--max-periods",
    "300",
];

fn run_batch(logs: &[PathBuf], rho_points: usize, extra: &[&str]) -> (Option<i32>, Value, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_stickslip"))
        .arg("batch")
        .args(logs)
        .args(FAST)
        .args(["--rho-points", &rho_points.to_string()])
        .args(extra)
        .output()
        .expect("runs");
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    let v: Value = serde_json::from_str(stdout.trim())
        .unwrap_or_else(|e| panic!("one JSON object on stdout ({e}): {stdout}\n{stderr}"));
    (out.status.code(), v, stderr)
}

/// A grid that starts just below the recommendation's box: the next
/// setting's box would leave the grid, so the recommendation is at the
/// grid's edge and says so. With the default options the grid reaches far
/// below the box: no edge warning (the former rule, on the refined
/// region, fired there, at its low end next to the cliff; with the fast
/// options of the other tests it did not, so this run uses the defaults).
#[test]
fn recommendation_at_the_grid_edge() {
    let logs: Vec<PathBuf> = BATCH.iter().map(|n| data(n)).collect();
    let out = Command::new(env!("CARGO_BIN_EXE_stickslip"))
        .arg("batch")
        .args(&logs)
        .arg("--json")
        .output()
        .expect("runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: Value = serde_json::from_slice(&out.stdout).expect("JSON");
    let codes = v["warning_codes"].as_array().unwrap();
    assert!(
        !codes.iter().any(|c| c == "recommendation_edge"),
        "{codes:?}"
    );
    let (code, v, stderr) = run_batch(&logs, 12, &["--rho-min", "0.85"]);
    assert_eq!(code, Some(0), "{stderr}");
    let (a, _) = pair(&v["recommended_rho_s_box"]);
    assert!(a >= 0.85, "the box fits the grid: {a}");
    let codes = v["warning_codes"].as_array().unwrap();
    assert!(
        codes.iter().any(|c| c == "recommendation_edge"),
        "{codes:?}"
    );
}

/// The public batch: coefficients, censored logs, recommendation, keys, report.
#[test]
fn public_batch() {
    let t = truth();
    let files = &t["files"];
    let mu_s_true = f(&files["char_N4.mcap"]["mu_s"]);
    let mu_d_true = f(&files["char_N4.mcap"]["mu_d"]);
    for name in BATCH {
        assert!(
            (f(&files[name]["mu_s"]) - mu_s_true).abs() < 1e-12,
            "one pad: {name}"
        );
    }
    let dir = tempfile::tempdir().unwrap();
    let report = dir.path().join("report");
    let logs: Vec<PathBuf> = BATCH.iter().map(|n| data(n)).collect();
    let (code, v, stderr) = run_batch(&logs, 12, &["--report", report.to_str().unwrap()]);
    assert_eq!(code, Some(0), "{stderr}");
    eprintln!(
        "mu_s {} {} mu_d {} {} rec {} N {} W {} {} cliff {} margin {} ({} s)",
        v["mu_s"],
        v["mu_s_interval"],
        v["mu_d"],
        v["mu_d_interval"],
        v["recommended_normal_force_n"],
        v["recommended_normal_force_interval_n"],
        v["worst_amplitude1"],
        v["worst_amplitude1_interval"],
        v["cliff_rho_s"],
        v["margin_to_cliff"],
        v["seconds"]
    );
    // The interface's keys.
    for k in [
        "fits",
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
        assert!(v.get(k).is_some_and(|x| !x.is_null()), "key {k}: {v}");
    }
    // Each fit entry is what `fit` writes.
    let fits = v["fits"].as_array().unwrap();
    assert_eq!(fits.len(), 5);
    for e in fits {
        for k in [
            "log",
            "law",
            "rho_s_interval",
            "normal_force_n",
            "stuck",
            "never_sticks",
        ] {
            assert!(e.get(k).is_some(), "fit key {k}: {e}");
        }
    }
    // μs, μd within 3 % of the truth, their intervals containing it.
    let (mu_s, mu_d) = (f(&v["mu_s"]), f(&v["mu_d"]));
    assert!((mu_s / mu_s_true - 1.0).abs() < 0.03, "mu_s {mu_s}");
    assert!((mu_d / mu_d_true - 1.0).abs() < 0.03, "mu_d {mu_d}");
    let (a, b) = pair(&v["mu_s_interval"]);
    assert!(
        a < mu_s && mu_s < b && a <= mu_s_true && mu_s_true <= b,
        "{a} {b}"
    );
    let (a, b) = pair(&v["mu_d_interval"]);
    assert!(
        a < mu_d && mu_d < b && a <= mu_d_true && mu_d_true <= b,
        "{a} {b}"
    );
    assert_eq!(v["mu_s_points"], 3);
    assert_eq!(v["mu_s_censored"], 2);
    // The free fit's intercept is reported as a check.
    assert!(v["mu_s_intercept_n"].is_number() && v["mu_d_intercept_n"].is_number());
    // The censored logs: bounds, not points, and consistent with the truth.
    let settings = v["settings"].as_array().unwrap();
    let by_log = |name: &str| {
        settings
            .iter()
            .find(|s| s["log"].as_str().unwrap().ends_with(name))
            .unwrap_or_else(|| panic!("{name} in settings"))
    };
    let stuck = by_log("char_N30.mcap");
    assert_eq!(stuck["static"], "lower-bound");
    assert!(stuck["mu_s_log"].is_null());
    assert_eq!(stuck["consistent"], true);
    let lb = f(&stuck["mu_s_log_bounds"][0]);
    assert!(lb > 0.0 && lb <= mu_s_true, "stuck bound {lb}");
    assert!(stuck["mu_s_log_bounds"][1].is_null());
    let never = by_log("char_N1.2.mcap");
    assert_eq!(never["static"], "bounded");
    assert_eq!(never["consistent"], true);
    let (lo, hi) = pair(&never["mu_s_log_bounds"]);
    assert!(
        lo <= mu_s_true && mu_s_true <= hi,
        "never-sticking bounds {lo} {hi}"
    );
    let fit_of = |name: &str| {
        fits.iter()
            .find(|e| e["log"].as_str().unwrap().ends_with(name))
            .unwrap()
    };
    assert_eq!(fit_of("char_N30.mcap")["stuck"], true);
    assert_eq!(fit_of("char_N1.2.mcap")["never_sticks"], true);
    for name in ["char_N2.2.mcap", "char_N4.mcap", "char_N7.2.mcap"] {
        assert_eq!(by_log(name)["static"], "point", "{name}");
        // The points are the estimates the fits report (the refined ones).
        let e = fit_of(name);
        assert_eq!(e["estimate"], "output-error", "{name}");
        let n = f(&e["normal_force_n"]);
        for (q, r) in [("mu_s_log", "r_s_n"), ("mu_d_log", "r_d_n")] {
            let want = f(&e[r]) / n;
            assert!(
                (f(&by_log(name)[q]) - want).abs() < 1e-12 * want,
                "{name} {q}"
            );
        }
    }
    // The logs agree within their intervals (their sensors' gains differ
    // from log to log, which the conflict check allows): no conflict.
    assert_eq!(v["conflicts"], serde_json::json!([]), "{}", v["conflicts"]);
    // The recommendation: inside its window, with a worst case inside its
    // interval and a cliff below it.
    let n = f(&v["recommended_normal_force_n"]);
    let (wa, wb) = pair(&v["recommended_normal_force_interval_n"]);
    assert!(wa <= n && n <= wb && wa > 0.0, "{wa} {n} {wb}");
    let w = f(&v["worst_amplitude1"]);
    let (la, lb) = pair(&v["worst_amplitude1_interval"]);
    assert!(la <= w && w <= lb && w > 0.0, "{la} {w} {lb}");
    let rho = f(&v["recommended_rho_s"]);
    assert!((rho - mu_s * n / f(&v["force_scale_n"])).abs() < 1e-9 * rho);
    let cliff = f(&v["cliff_rho_s"]);
    assert!(cliff < rho, "cliff {cliff} vs recommendation {rho}");
    assert!(f(&v["margin_to_cliff"]) > 0.0);
    // Far below the cliff the η1 peak dominates: the weakest setting is worse.
    let w_low = f(&by_log("char_N1.2.mcap")["worst_amplitude1"]);
    assert!(w_low > 10.0 * w, "{w_low} vs {w}");
    let curve = v["curve"].as_array().unwrap();
    assert!(curve.len() >= 12);
    // The report.
    let html = std::fs::read_to_string(report.join("index.html")).unwrap();
    assert!(html.contains("Normal-force settings (batch)"));
    assert!(html.contains("batch.svg") && report.join("batch.svg").exists());
    assert!(!html.contains("http://") && !html.contains("https://"));
}

/// A bad log among good ones: every input is read before any fitting, so
/// the unreadable one stops the batch at once (issue 16's rule: check every
/// input, then compute): exit 1, one `error:` line naming it, last, and no
/// JSON object (nothing was computed).
#[test]
fn bad_log_among_good_ones() {
    let logs = vec![
        data("char_N4.mcap"),
        data("broken/not_mcap.mcap"),
        data("char_N7.2.mcap"),
    ];
    let out = Command::new(env!("CARGO_BIN_EXE_stickslip"))
        .arg("batch")
        .args(&logs)
        .args(FAST)
        .output()
        .expect("runs");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    let errors: Vec<&str> = stderr
        .lines()
        .filter(|l| l.starts_with("error: "))
        .collect();
    assert_eq!(errors.len(), 1, "{stderr}");
    assert!(errors[0].contains("not_mcap.mcap"), "{stderr}");
    assert_eq!(stderr.lines().last(), Some(errors[0]), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert!(out.stdout.is_empty(), "nothing computed, nothing printed");
}

/// Only a stuck log: no measured static friction, an error naming the batch,
/// exit 1, still one JSON object.
#[test]
fn only_bounds_is_an_error() {
    let (code, v, stderr) = run_batch(&[data("char_N30.mcap")], 8, &[]);
    assert_eq!(code, Some(1));
    assert!(
        stderr.lines().any(|l| l.starts_with("error: batch")),
        "{stderr}"
    );
    assert!(v["mu_s"].is_null() && v["error"].is_string());
}

/// The numbers at the paper's parameters (m = 4, k = 1, D = 0.005,
/// Coulomb), over the default drive range with its fine windows: measured
/// W = 0.908 at ρs = 0.75 and 6.70 at ρs = 0.65 (the η1 peak, at η ≈ 0.43).
#[test]
fn paper_worst_case_cliff() {
    let ab = Absorber::default();
    let etas = drive_etas(&ab, default_eta_range(&ab), 141, 0.001, 0.025);
    let cfg = SteadyConfig {
        max_periods: 500,
        ..SteadyConfig::default()
    };
    let hi = worst_case(&ab, PadShape::PAPER, 0.75, 0.75, &etas, &cfg).unwrap();
    let lo = worst_case(&ab, PadShape::PAPER, 0.65, 0.65, &etas, &cfg).unwrap();
    eprintln!(
        "W(0.75) = {} at {}, W(0.65) = {} at {}",
        hi.amplitude1, hi.eta, lo.amplitude1, lo.eta
    );
    assert!((hi.amplitude1 - 0.9).abs() < 0.05, "{hi:?}");
    assert!((lo.amplitude1 - 7.0).abs() < 1.0, "{lo:?}");
    let (e1, _) = ab.eta_linear();
    assert!((lo.eta - e1).abs() < 0.03, "the η1 peak: {lo:?}");
}

/// Logs whose planned memory does not fit the budget together are checked
/// in rounds, let go, then read again and fitted in rounds: the fits are
/// those of the logs read once (a budget of 60 MB makes two rounds of
/// char_N4 and char_N7.2, planned at 50 MB plus 275 bytes per sample each),
/// and a sweep among them still stops the batch before any fitting.
#[test]
fn logs_over_the_budget_together_are_checked_then_fitted_in_rounds() {
    use stickslip::identify::IdentifyOptions;
    use stickslip::pipeline::checks::fit_characteristic_logs;
    let logs = [data("char_N4.mcap"), data("char_N7.2.mcap")];
    let fits = |memory_bytes: u64| {
        let opts = IdentifyOptions {
            memory_bytes,
            ..IdentifyOptions::default()
        };
        fit_characteristic_logs(&logs, &opts, &|| {}).unwrap()
    };
    let once = fits(IdentifyOptions::default().memory_bytes);
    let rounds = fits(60_000_000);
    assert_eq!(once.len(), 2);
    for (a, b) in once.iter().zip(&rounds) {
        let (a, b) = (&a.as_ref().unwrap().1, &b.as_ref().unwrap().1);
        assert_eq!(a.law(), b.law());
        assert_eq!(a.rs_interval_n, b.rs_interval_n);
        assert_eq!(a.rd_interval_n, b.rd_interval_n);
    }
    let with_sweep = [data("char_N4.mcap"), data("sweep_stepped_N4.mcap")];
    let opts = IdentifyOptions {
        memory_bytes: 60_000_000,
        ..IdentifyOptions::default()
    };
    let e = fit_characteristic_logs(&with_sweep, &opts, &|| panic!("fitted"))
        .expect_err("a sweep is refused");
    assert!(
        e.to_string()
            .contains("a batch compares characteristic logs only"),
        "{e}"
    );
}
