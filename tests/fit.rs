//! Integration tests of `stickslip fit` and `stickslip characteristic` on
//! every public characteristic log in `datasets/`, against `truth.json`.
//!
//! Tolerances come from issue 6: `r_s_n`, `r_d_n` within 3 % and D* within
//! 0.01 of the truth where the true law is in the model family and M2 both
//! sticks and slips; the family chosen correctly; the 95 % intervals contain
//! the truth with at most one miss over all public parameters; the stuck and
//! the never-sticking logs reported as bounds that contain the truth; the
//! Stribeck-like log flagged with its Stribeck fit.
//!
//! ρ in truth.json uses the nominal amplitude; the tool's ρ uses the
//! measured one, so ρ truths here are `rs_n / (A_true·K2)` (truth.json's
//! `rho_s_true_amplitude`), and the force checks use newtons.

mod common;

use common::{bin, data, f, json_of, truth, without_seconds};
use serde_json::Value;
use std::process::Command;
use std::sync::OnceLock;

/// Every public characteristic log (CSV and Parquet copies included).
fn characteristic_logs() -> Vec<String> {
    let mut v: Vec<String> = truth()["files"]
        .as_object()
        .expect("files")
        .iter()
        .filter(|(_, e)| e["test"] == "characteristic")
        .map(|(k, _)| k.clone())
        .collect();
    v.sort();
    v
}

/// One run of `fit --json` over all of them (parallel inside the binary).
fn fits() -> &'static Vec<(String, Value)> {
    static F: OnceLock<Vec<(String, Value)>> = OnceLock::new();
    F.get_or_init(|| {
        let logs = characteristic_logs();
        let mut cmd = Command::new(env!("CARGO_BIN_EXE_stickslip"));
        cmd.arg("fit").arg("--json");
        for l in &logs {
            cmd.arg(data(l));
        }
        let out = cmd.output().expect("run stickslip");
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "fit failed: {stderr}");
        let v: Value = serde_json::from_slice(&out.stdout).expect("one JSON object");
        let list = v["fits"].as_array().expect("fits").clone();
        assert_eq!(list.len(), logs.len());
        logs.into_iter().zip(list).collect()
    })
}

/// The truth entry of a log and its ground-truth quantities.
struct Truth {
    family: String,
    rs_n: f64,
    rd_n: f64,
    dstar: f64,
    rho_s: f64,
    rho_d: f64,
    stuck: bool,
    stick_fraction: f64,
}

fn truth_of(log: &str) -> Truth {
    let e = &truth()["files"][log];
    let law = &e["law"];
    let k2 = f(&e["rig"]["k2_n_per_m"]);
    let a = f(&e["drive_amplitude_true_m"]);
    Truth {
        family: law["family"].as_str().expect("family").to_string(),
        rs_n: f(&law["rs_n"]),
        rd_n: f(&law["rd_n"]),
        dstar: f(&law["Dstar"]),
        rho_s: f(&law["rs_n"]) / (a * k2),
        rho_d: f(&law["rd_n"]) / (a * k2),
        stuck: e["stuck"].as_bool().expect("stuck"),
        stick_fraction: f(&e["stick_fraction"]),
    }
}

/// The law name the tool should report for a truth family.
fn expected_law(family: &str) -> Option<&'static str> {
    match family {
        "static_dynamic" => Some("static-dynamic"),
        "coulomb" => Some("coulomb"),
        "decreasing" | "viscous" => Some("decreasing"),
        "stribeck" => Some("stribeck"),
        _ => None,
    }
}

fn in_family(t: &Truth) -> bool {
    matches!(
        t.family.as_str(),
        "static_dynamic" | "coulomb" | "decreasing" | "viscous"
    )
}

fn sticks_and_slips(t: &Truth) -> bool {
    !t.stuck && t.stick_fraction > 0.0 && t.stick_fraction < 1.0
}

fn interval(v: &Value) -> Option<(f64, f64)> {
    let a = v.as_array()?;
    Some((a[0].as_f64()?, a[1].as_f64()?))
}

#[test]
fn every_fit_has_the_interface_keys() {
    let keys = [
        "log",
        "law",
        "rho_s",
        "rho_d",
        "slope",
        "rho_s_interval",
        "rho_d_interval",
        "slope_interval",
        "r_s_n",
        "r_d_n",
        "normal_force_n",
        "eta",
        "stuck",
        "rho_s_lower_bound",
        "never_sticks",
        "drive_amplitude_m",
        "residual_rms",
        "warnings",
    ];
    for (log, fit) in fits() {
        for k in keys {
            assert!(fit.get(k).is_some(), "{log}: key {k} missing");
        }
        assert!(fit["log"].as_str().unwrap().ends_with(log.as_str()));
        let e = &truth()["files"][log.as_str()];
        // Normal force and η measured within the channel's calibration.
        let n = f(&e["normal_force_n"]);
        assert!((f(&fit["normal_force_n"]) / n - 1.0).abs() < 0.03, "{log}");
        assert!((f(&fit["eta"]) / f(&e["eta"]) - 1.0).abs() < 1e-3, "{log}");
        // Drive amplitude from the drive channel, within its gain error
        // (≤ 0.5 % by the data set README) plus noise.
        let a = f(&e["drive_amplitude_true_m"]);
        assert!(
            (f(&fit["drive_amplitude_m"]) / a - 1.0).abs() < 0.006,
            "{log}: A {} vs {a}",
            fit["drive_amplitude_m"]
        );
    }
}

#[test]
fn forces_and_slope_within_the_issue_tolerances() {
    let mut checked = 0;
    for (log, fit) in fits() {
        let t = truth_of(log);
        if !(in_family(&t) && sticks_and_slips(&t)) {
            continue;
        }
        checked += 1;
        let rs = f(&fit["r_s_n"]);
        let rd = f(&fit["r_d_n"]);
        let ds = f(&fit["slope"]);
        assert!(
            (rs / t.rs_n - 1.0).abs() <= 0.03,
            "{log}: Rs {rs} vs {}",
            t.rs_n
        );
        assert!(
            (rd / t.rd_n - 1.0).abs() <= 0.03,
            "{log}: Rd {rd} vs {}",
            t.rd_n
        );
        assert!(
            (ds - t.dstar).abs() <= 0.01,
            "{log}: D* {ds} vs {}",
            t.dstar
        );
    }
    assert!(checked >= 6, "only {checked} logs checked");
}

#[test]
fn the_family_is_chosen_correctly() {
    for (log, fit) in fits() {
        let t = truth_of(log);
        if !sticks_and_slips(&t) {
            continue;
        }
        let want = expected_law(&t.family).expect("known family");
        assert_eq!(fit["law"].as_str(), Some(want), "{log}");
    }
}

#[test]
fn intervals_contain_the_truth_with_at_most_one_miss() {
    let mut misses = Vec::new();
    let mut count = 0;
    for (log, fit) in fits() {
        let t = truth_of(log);
        if t.stuck {
            continue;
        }
        let mut check = |name: &str, iv: Option<(f64, f64)>, x: f64| {
            count += 1;
            match iv {
                Some((a, b)) if a <= x && x <= b => {}
                _ => misses.push(format!("{log} {name}: {iv:?} vs {x}")),
            }
        };
        check("rho_s", interval(&fit["rho_s_interval"]), t.rho_s);
        check("rho_d", interval(&fit["rho_d_interval"]), t.rho_d);
        if fit["slope"].is_number() {
            check("slope", interval(&fit["slope_interval"]), t.dstar);
        }
    }
    assert!(count >= 25, "only {count} parameters checked");
    assert!(
        misses.len() <= 1,
        "{} misses of {count}: {misses:#?}",
        misses.len()
    );
}

#[test]
fn the_stuck_log_gives_only_a_lower_bound() {
    let mut seen = 0;
    for (log, fit) in fits() {
        let t = truth_of(log);
        if !t.stuck {
            assert_eq!(fit["stuck"], false, "{log}");
            continue;
        }
        seen += 1;
        assert_eq!(fit["stuck"], true, "{log}");
        for k in ["rho_s", "r_s_n", "rho_d", "r_d_n", "slope"] {
            assert!(fit[k].is_null(), "{log}: {k} = {}", fit[k]);
        }
        let lb = f(&fit["rho_s_lower_bound"]);
        assert!(lb > 0.0 && lb < t.rho_s, "{log}: bound {lb} vs {}", t.rho_s);
        // And no higher than the largest friction force that really acted.
        let max_f = f(&truth()["files"][log.as_str()]["max_abs_friction_n"]);
        assert!(lb * f(&fit["drive_amplitude_m"]) * 670.0 <= max_f * 1.02);
    }
    assert_eq!(seen, 1);
}

#[test]
fn the_never_sticking_log_bounds_rho_s() {
    let mut seen = 0;
    for (log, fit) in fits() {
        let t = truth_of(log);
        if t.stuck || t.stick_fraction > 0.0 {
            assert_eq!(fit["never_sticks"], false, "{log}");
            continue;
        }
        seen += 1;
        assert_eq!(fit["never_sticks"], true, "{log}");
        assert!(fit["rho_s"].is_null() && fit["r_s_n"].is_null(), "{log}");
        let (a, b) = interval(&fit["rho_s_interval"]).expect("bounds");
        assert!(
            a <= t.rho_s && t.rho_s <= b,
            "{log}: [{a}, {b}] vs {}",
            t.rho_s
        );
        // ρd is measured there and within tolerance.
        let rd = f(&fit["r_d_n"]);
        assert!(
            (rd / t.rd_n - 1.0).abs() <= 0.03,
            "{log}: Rd {rd} vs {}",
            t.rd_n
        );
    }
    assert_eq!(seen, 1);
}

#[test]
fn the_stribeck_log_is_flagged_with_its_stribeck_fit() {
    let (log, fit) = fits()
        .iter()
        .find(|(l, _)| l == "law_stribeck.mcap")
        .expect("law_stribeck.mcap");
    let t = truth_of(log);
    assert_eq!(fit["law"], "stribeck");
    assert!(
        fit["warning_codes"]
            .as_array()
            .unwrap()
            .iter()
            .any(|c| c == "no_simple_law"),
        "{}",
        fit["warnings"]
    );
    let s = &fit["stribeck"];
    for k in ["rho_s", "rho_d", "slope", "v_s"] {
        assert!(s[k].is_number(), "stribeck.{k}");
    }
    // The Stribeck parameters (issue tolerances applied to this law too).
    assert!((f(&s["r_s_n"]) / t.rs_n - 1.0).abs() <= 0.03);
    assert!((f(&s["r_d_n"]) / t.rd_n - 1.0).abs() <= 0.03);
    assert!((f(&s["slope"]) - t.dstar).abs() <= 0.01);
    let vs = f(&truth()["files"][log.as_str()]["law"]["stribeck_velocity_m_per_s"]);
    assert!(
        (f(&s["v_s_m_per_s"]) / vs - 1.0).abs() < 0.2,
        "v_s {}",
        s["v_s_m_per_s"]
    );
    // No other log gets a Stribeck fit.
    for (l, other) in fits() {
        if l != log {
            assert!(other["stribeck"].is_null(), "{l}");
        }
    }
}

#[test]
fn a_bad_log_fails_alone_and_the_others_complete() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("fit.json");
    let res = Command::new(env!("CARGO_BIN_EXE_stickslip"))
        .args(["fit", "--json", "--bootstrap", "50", "--out"])
        .arg(&out)
        .arg(data("law_coulomb.mcap"))
        .arg(data("broken/not_mcap.mcap"))
        .output()
        .unwrap();
    assert_eq!(res.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&res.stderr);
    // The log's own error line, then the last line naming every failed log.
    let errors: Vec<&str> = stderr.lines().filter(|l| l.starts_with("error:")).collect();
    assert_eq!(errors.len(), 2, "{stderr}");
    assert!(errors[0].contains("not_mcap.mcap"), "{stderr}");
    assert_eq!(stderr.lines().last(), Some(errors[1]), "{stderr}");
    assert!(errors[1].contains("1 of 2 logs failed") && errors[1].contains("not_mcap.mcap"));
    let v: Value = serde_json::from_slice(&res.stdout).unwrap();
    let fits = v["fits"].as_array().unwrap();
    assert_eq!(fits.len(), 2);
    assert_eq!(fits[0]["law"], "coulomb");
    assert!(fits[1]["error"].as_str().unwrap().contains("not_mcap.mcap"));
    assert!(fits[1]["log"].as_str().unwrap().ends_with("not_mcap.mcap"));
    // The file holds the same object.
    let file: Value = serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    assert_eq!(file, v);
}

#[test]
fn a_sweep_log_is_refused_with_one_error_line() {
    let res = Command::new(env!("CARGO_BIN_EXE_stickslip"))
        .args(["fit", "--json"])
        .arg(data("sweep_stepped_N4.mcap"))
        .output()
        .unwrap();
    assert_eq!(res.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&res.stderr);
    assert!(stderr
        .lines()
        .any(|l| l.starts_with("error:") && l.contains("not a characteristic test")));
}

#[test]
fn characteristic_writes_the_table() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("char.csv");
    let plot = dir.path().join("char.svg");
    let res = Command::new(env!("CARGO_BIN_EXE_stickslip"))
        .args(["characteristic", "--json", "--out"])
        .arg(&out)
        .arg("--plot")
        .arg(&plot)
        .arg(data("char_N4.mcap"))
        .output()
        .unwrap();
    assert!(
        res.status.success(),
        "{}",
        String::from_utf8_lossy(&res.stderr)
    );
    let v: Value = serde_json::from_slice(&res.stdout).unwrap();
    assert_eq!(v["stuck"], false);
    let svg = std::fs::read_to_string(&plot).unwrap();
    assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
    assert!(
        svg.contains("fitted: static-dynamic"),
        "legend names the law"
    );
    let text = std::fs::read_to_string(&out).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next(),
        Some("t_s,r_n,v2_m_per_s,stick,rho,v2_dimless")
    );
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), v["samples"].as_u64().unwrap() as usize);
    // Stick fraction of the table against the truth (0.318 for char_N4).
    let sticks = rows.iter().filter(|r| r[3] == "1").count() as f64 / rows.len() as f64;
    let sf = f(&truth()["files"]["char_N4.mcap"]["stick_fraction"]);
    assert!((sticks - sf).abs() < 0.05, "{sticks} vs {sf}");
    // While sticking, the friction force stays within the static threshold
    // (plus the force noise of a few samples).
    let rs = f(&truth()["files"]["char_N4.mcap"]["law"]["rs_n"]);
    let max_stick = rows
        .iter()
        .filter(|r| r[3] == "1" && !r[1].is_empty())
        .map(|r| r[1].parse::<f64>().unwrap().abs())
        .fold(0.0, f64::max);
    assert!(max_stick < rs * 1.15, "{max_stick} vs {rs}");
}

/// Both estimates are reported; the interface keys are those of the
/// output-error refinement wherever M2 slides (it sticks and slips or never
/// sticks), and it meets the issue's tolerances on
/// its own (checked above through the interface keys). The stuck log keeps
/// the equation-error estimate. The Stribeck-type log is refined too: no
/// simple family explains it, so the Stribeck family is refined on the
/// numerical engine.
#[test]
fn the_output_error_estimate_is_used_and_both_are_reported() {
    for (log, fit) in fits() {
        let t = truth_of(log);
        let ee = &fit["equation_error"];
        let oe = &fit["output_error"];
        if t.stuck {
            assert_eq!(fit["estimate"], "equation-error", "{log}");
            assert!(oe.is_null() && ee.is_null(), "{log}");
            continue;
        }
        assert!(ee["rho_d"].is_number(), "{log}: {ee}");
        assert_eq!(fit["estimate"], "output-error", "{log}");
        for k in [
            "law",
            "rho_s",
            "rho_d",
            "slope",
            "rho_s_interval",
            "rho_d_interval",
            "slope_interval",
            "r_s_n",
            "r_d_n",
        ] {
            assert_eq!(fit[k], oe[k], "{log}: {k}");
        }
        for k in ["rms_x1_m", "rms_x2_m", "seconds", "effective_samples"] {
            assert!(
                oe[k].as_f64().is_some_and(|x| x > 0.0),
                "{log}: {k} = {}",
                oe[k]
            );
        }
        assert!(oe["iterations"].as_u64().is_some_and(|n| n > 0), "{log}");
        assert!(oe["segments"].as_u64().is_some_and(|n| n >= 12), "{log}");
        assert_eq!(oe["drive"], "harmonic", "{log}");
        // The simulated positions follow the measured ones to a few sensor
        // noise levels (3–4 µm here).
        for k in ["rms_x1_m", "rms_x2_m"] {
            assert!(oe[k].as_f64().unwrap() < 15e-6, "{log}: {k} = {}", oe[k]);
        }
        // More accurate than the equation-error estimate on ρd (the slip
        // level is measured in every log that slides).
        let err = |v: &Value| (f(&v["rho_d"]) / t.rho_d - 1.0).abs();
        assert!(
            err(oe) <= err(ee) + 1e-4,
            "{log}: {} vs {}",
            err(oe),
            err(ee)
        );
    }
}

#[test]
fn law_names_are_the_contract_spelling() {
    // `--law` takes `auto` or a law name as the `law` key spells it; any
    // other spelling is refused by the parser, with the names listed.
    let res = Command::new(env!("CARGO_BIN_EXE_stickslip"))
        .args(["fit", "--law", "static_dynamic"])
        .arg(data("char_N4.mcap"))
        .output()
        .unwrap();
    assert_eq!(res.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&res.stderr);
    for name in [
        "auto",
        "coulomb",
        "decreasing",
        "static-dynamic",
        "stribeck",
    ] {
        assert!(stderr.contains(name), "{name} not listed: {stderr}");
    }
    let res = Command::new(env!("CARGO_BIN_EXE_stickslip"))
        .args(["fit", "--json", "--bootstrap", "0", "--law", "coulomb"])
        .arg(data("char_N4.mcap"))
        .output()
        .unwrap();
    assert!(
        res.status.success(),
        "{}",
        String::from_utf8_lossy(&res.stderr)
    );
    let v: Value = serde_json::from_slice(&res.stdout).unwrap();
    assert_eq!(v["fits"][0]["law"], "coulomb");
}

/// The output-error refinement simulates a log's segments in parallel and
/// books them in order, so a fit is the same whatever the thread count
/// (every number equal, not merely close).
#[test]
fn fit_does_not_depend_on_thread_count() {
    let run = |threads: &str| -> Value {
        let mut v = json_of(
            bin()
                .env("RAYON_NUM_THREADS", threads)
                .args(["fit", "--json"])
                .arg(data("char_N4.mcap")),
        );
        without_seconds(&mut v);
        v
    };
    assert_eq!(run("1"), run("3"));
}

/// A Stribeck law forced on a log whose slip samples never come near the
/// drop (`char_N7.2.mcap`, a static/dynamic pad): the equation-error scan
/// found v_s 0.68 mm/s below slip speeds of several mm/s and reported Rs
/// 6.4e7 N (the coefficient of a column of values about 1e-8). A velocity
/// scale below half the slowest slip sample is not one the data resolve:
/// the equation error has no Stribeck candidate. The output error, started
/// from the simple families' optima (it said "no family to refine"
/// before), collapses v_s below the one-sample resolution, and says that
/// v_s is not identified; Rs stays the static/dynamic threshold.
#[test]
fn a_stribeck_drop_below_every_slip_speed_is_not_extrapolated() {
    let j = json_of(
        bin()
            .args(["fit", "--law", "stribeck"])
            .arg(data("char_N7.2.mcap"))
            .arg("--json"),
    );
    let fit = &j["fits"][0];
    let codes = common::codes_of(fit);
    assert!(
        codes.contains(&"velocity_scale_not_identified") && !codes.contains(&"law_not_fitted"),
        "{}",
        fit["warnings"]
    );
    assert_eq!(fit["law"], "stribeck");
    assert_eq!(fit["estimate"], "output-error");
    let ee = fit["equation_error"]["criteria"].as_array().unwrap();
    assert!(
        ee.iter().all(|c| c["law"] != "stribeck"),
        "{}",
        fit["equation_error"]["criteria"]
    );
    let (rs, rd) = (f(&fit["r_s_n"]), f(&fit["r_d_n"]));
    assert!(rs < 2.0 * rd, "Rs {rs} against Rd {rd}");
    // The static/dynamic threshold of the same log (auto) is inside Rs's
    // interval.
    let auto = json_of(bin().arg("fit").arg(data("char_N7.2.mcap")).arg("--json"));
    let sd = f(&auto["fits"][0]["r_s_n"]);
    let iv = &fit["r_s_interval_n"];
    assert!(f(&iv[0]) <= sd && sd <= f(&iv[1]), "{sd} {iv}");
}
