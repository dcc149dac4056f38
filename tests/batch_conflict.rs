//! Batches that survive conflict (issue 14, item 6), built with the virtual
//! rig `stickslip synth` on a rig other than the bundled one (M1 = 6 kg,
//! M2 = 1.5 kg, K1 = 900 N/m, K2 = 600 N/m, drive 2 mm at 1.72 Hz, velocity
//! noise 1 mm/s, no accelerometer) and one static/dynamic pad
//! (μs = 0.42, μd = 0.34). At this drive the pad never sticks below about
//! 2.93 N, sticks briefly at every reversal just above (2.96 N: 11 % of the
//! time, about 30 ms per stick), sticks and slips clearly at 3.5 N and is
//! stuck at 8 N.
//!
//! * Five normal forces with one log near the stick threshold: μs and μd
//!   within 3 % of the truth, a recommendation, every conflict named with
//!   its logs and size.
//! * A never-sticking log of another pad (μs = 0.7, μd = 0.6) beside five
//!   logs of the pad, whose never-sticks bound (Rs ≥ its Rd = 0.6·N)
//!   contradicts the measured Rs of the pad's logs: the conflict is named
//!   and that log set aside (from μs and, as its Rd is 70 % off four
//!   others, from μd); μ from the others, shown with and without it; a
//!   recommendation. (With only two other Rd values the data could not say
//!   which of three is off: Dixon's Q is 0.95 against 0.994 at 99 %.)
//! * The same test twice (the same file; char_N2.2 as .mcap, .csv and
//!   .parquet) counts once, with a warning.
//! * Logs of two rigs are refused by `batch`, `validate` and `run` (one
//!   `error:` line naming the logs and the constant) and accepted by
//!   `batch` with `--allow-mixed-rigs`.

mod common;

use common::{data, f};
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::Command;

/// Sensors of the other rig: typical noise, velocity noise 1 mm/s, no
/// accelerometer, small gain and offset errors.
const SENSORS: &str = r#"{
 "x0": {"rate_hz":1000,"noise":1.5e-6,"quant":5e-7,"gain":1.002,"offset":1e-5,"lowpass_hz":null,"buffer_s":0.1,"start_offset_ns":null,"jitter_ns":3000,"p_lost_buffer":0.005,"p_dropout":2e-4,"dropout_burst_max":4},
 "x1": {"rate_hz":1000,"noise":3e-6,"quant":1e-6,"gain":0.995,"offset":5e-5,"lowpass_hz":null,"buffer_s":0.1,"start_offset_ns":null,"jitter_ns":3000,"p_lost_buffer":0.005,"p_dropout":2e-4,"dropout_burst_max":4},
 "x2": {"rate_hz":1000,"noise":3e-6,"quant":1e-6,"gain":1.004,"offset":-6e-5,"lowpass_hz":null,"buffer_s":0.1,"start_offset_ns":null,"jitter_ns":3000,"p_lost_buffer":0.005,"p_dropout":2e-4,"dropout_burst_max":4},
 "v2": {"rate_hz":1000,"noise":1e-3,"quant":1e-5,"gain":1.003,"offset":5e-5,"lowpass_hz":200,"buffer_s":0.1,"start_offset_ns":null,"jitter_ns":3000,"p_lost_buffer":0.005,"p_dropout":2e-4,"dropout_burst_max":4},
 "a2": null,
 "normal_force": {"rate_hz":10,"noise":0,"quant":0.01,"gain":1.004,"offset":0.01,"lowpass_hz":null,"buffer_s":0.5,"start_offset_ns":null,"jitter_ns":3000,"p_lost_buffer":0.005,"p_dropout":0,"dropout_burst_max":4}
}"#;

const MU_S: f64 = 0.42;
const MU_D: f64 = 0.34;

/// A characteristic log of the other rig: `pad` = (μs, μd), normal force `n`.
fn synth(dir: &Path, name: &str, n: f64, pad: (f64, f64), extra: &[&str]) -> (PathBuf, Value) {
    let sensors = dir.join("sensors.json");
    if !sensors.exists() {
        std::fs::write(&sensors, SENSORS).unwrap();
    }
    let sub = dir.join(name);
    std::fs::create_dir_all(&sub).unwrap();
    let out = sub.join(format!("{name}.mcap"));
    let o = Command::new(env!("CARGO_BIN_EXE_stickslip"))
        .arg("synth")
        .args(["--out", out.to_str().unwrap()])
        .args(["--normal-force", &n.to_string()])
        .args(["--mu-s", &pad.0.to_string(), "--mu-d", &pad.1.to_string()])
        .args(["--m1-kg", "6", "--m2-kg", "1.5"])
        .args(["--k1-n-per-m", "900", "--k2-n-per-m", "600"])
        .args(["--amplitude-m", "0.002"])
        .args(["--sensors", sensors.to_str().unwrap()])
        .args(extra)
        .arg("--json")
        .output()
        .expect("synth runs");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: Value = serde_json::from_slice(&o.stdout).expect("synth JSON");
    (out, v)
}

/// Fast options: coarse grids, no ratio variants, 100 bootstrap replicates.
const FAST: [&str; 12] = [
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
    "--rho-points",
    "12",
];

fn batch(logs: &[PathBuf], extra: &[&str]) -> (Option<i32>, Value, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_stickslip"))
        .arg("batch")
        .args(logs)
        .args(FAST)
        .args(extra)
        .output()
        .expect("runs");
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    let v: Value = if out.status.success() || !stdout.trim().is_empty() {
        serde_json::from_str(stdout.trim())
            .unwrap_or_else(|e| panic!("one JSON object on stdout ({e}): {stdout}\n{stderr}"))
    } else {
        Value::Null
    };
    (out.status.code(), v, stderr)
}

fn show(v: &Value) {
    eprintln!(
        "mu_s {} {} mu_d {} {} (all logs: mu_s {} {}, mu_d {} {}); rec {} N {}; reason {}",
        v["mu_s"],
        v["mu_s_interval"],
        v["mu_d"],
        v["mu_d_interval"],
        v["all_logs"]["mu_s"],
        v["all_logs"]["mu_s_interval"],
        v["all_logs"]["mu_d"],
        v["all_logs"]["mu_d_interval"],
        v["recommended_normal_force_n"],
        v["recommended_normal_force_interval_n"],
        v["recommendation_reason"]
    );
    for c in v["conflicts"].as_array().into_iter().flatten() {
        eprintln!("conflict: {}", c["what"]);
    }
    for s in v["settings"].as_array().into_iter().flatten() {
        eprintln!(
            "setting {}: N {} static {} mu_s_log {} bounds {} mu_d_log {} doubt Rs {} Rd {}",
            s["log"],
            s["normal_force_n"],
            s["static"],
            s["mu_s_log"],
            s["mu_s_log_bounds"],
            s["mu_d_log"],
            s["estimate_disagreement_rs_sigma"],
            s["estimate_disagreement_rd_sigma"]
        );
    }
}

/// Every conflict names its logs and its size; returns the list.
fn checked_conflicts(v: &Value) -> Vec<Value> {
    let cs = v["conflicts"].as_array().expect("conflicts list").clone();
    for c in &cs {
        let logs = c["logs"].as_array().expect("logs");
        assert!(!logs.is_empty(), "{c}");
        assert!(logs
            .iter()
            .all(|l| l.as_str().is_some_and(|s| !s.is_empty())));
        assert!(
            f(&c["size_sigma"]).is_finite() && f(&c["size_sigma"]) > 0.0,
            "{c}"
        );
        assert!(f(&c["size_rel"]).is_finite(), "{c}");
        assert!(c["what"].as_str().is_some_and(|s| !s.is_empty()), "{c}");
        assert!(["mu_s", "mu_d"].contains(&c["quantity"].as_str().unwrap()));
        assert!(c["set_aside"].is_boolean());
    }
    cs
}

/// A recommendation, or a plain reason why none: never both, never neither.
fn recommendation_or_reason(v: &Value) {
    let rec = v["recommended_normal_force_n"].as_f64();
    let reason = v.get("recommendation_reason").and_then(Value::as_str);
    assert!(rec.is_some() != reason.is_some(), "{v}");
    if let Some(r) = reason {
        assert!(!r.contains('×') && !r.contains("e18"), "{r}");
    }
}

/// Five normal forces of one pad, one log near the stick threshold.
#[test]
fn five_forces_near_threshold() {
    let dir = tempfile::tempdir().unwrap();
    let mut logs = Vec::new();
    for (name, n) in [
        ("n1.5", 1.5),
        ("n2.2", 2.2),
        ("n2.96", 2.96),
        ("n3.5", 3.5),
        ("n8", 8.0),
    ] {
        let (p, t) = synth(dir.path(), name, n, (MU_S, MU_D), &[]);
        eprintln!("{name}: stick fraction {}", t["stick_fraction"]);
        if name == "n2.96" {
            // Short sticks at every reversal: near the threshold.
            let sf = f(&t["stick_fraction"]);
            assert!(sf > 0.02 && sf < 0.2, "{sf}");
        }
        logs.push(p);
    }
    let (code, v, stderr) = batch(&logs, &[]);
    show(&v);
    assert_eq!(code, Some(0), "{stderr}");
    assert!(!stderr.contains("panicked"));
    let (mu_s, mu_d) = (f(&v["mu_s"]), f(&v["mu_d"]));
    assert!((mu_s / MU_S - 1.0).abs() < 0.03, "mu_s {mu_s}");
    assert!((mu_d / MU_D - 1.0).abs() < 0.03, "mu_d {mu_d}");
    for (k, truth) in [("mu_s_interval", MU_S), ("mu_d_interval", MU_D)] {
        let (a, b) = (f(&v[k][0]), f(&v[k][1]));
        assert!(a > 0.0 && a <= truth && truth <= b, "{k} [{a}, {b}]");
    }
    recommendation_or_reason(&v);
    assert!(v["recommended_normal_force_n"].is_number(), "{v}");
    let cs = checked_conflicts(&v);
    // The logs named by a conflict are logs of the batch.
    let names: Vec<String> = logs.iter().map(|p| p.display().to_string()).collect();
    for c in &cs {
        for l in c["logs"].as_array().unwrap() {
            assert!(names.contains(&l.as_str().unwrap().to_string()), "{c}");
        }
    }
    // Both ways: the every-log keys exist.
    assert!(v["all_logs"]["mu_s"].is_number() && v["all_logs"]["mu_d"].is_number());
}

/// A never-sticking log of another pad contradicts the measured Rs.
#[test]
fn never_sticks_bound_against_measured() {
    let dir = tempfile::tempdir().unwrap();
    let mut logs = Vec::new();
    // Five forces of the pad: three never stick (each measures Rd), one
    // sticks and slips, one is stuck.
    for (name, n) in [
        ("n1.6", 1.6),
        ("n2.2", 2.2),
        ("n2.7", 2.7),
        ("n3.2", 3.2),
        ("n8", 8.0),
    ] {
        logs.push(synth(dir.path(), name, n, (MU_S, MU_D), &[]).0);
    }
    // Another pad (μs 0.7, μd 0.6) at 1.2 N: it never sticks (ρs = 0.7),
    // so its bound says Rs ≥ Rd ≈ 0.6·N, against μs = 0.42 of the others.
    let (other, t) = synth(
        dir.path(),
        "other_pad_n1.2",
        1.2,
        (0.7, 0.6),
        &["--seed", "7"],
    );
    assert_eq!(f(&t["stick_fraction"]), 0.0);
    logs.insert(0, other.clone());
    let (code, v, stderr) = batch(&logs, &[]);
    show(&v);
    assert_eq!(code, Some(0), "{stderr}");
    let fit_other = &v["fits"][0];
    assert_eq!(fit_other["never_sticks"], true, "{fit_other}");
    let cs = checked_conflicts(&v);
    let other_s = other.display().to_string();
    let c = cs
        .iter()
        .find(|c| c["logs"][0] == other_s.as_str() && c["quantity"] == "mu_s")
        .unwrap_or_else(|| panic!("the other pad's bound is named: {cs:?}"));
    assert_eq!(c["kind"], "never-sticks bound");
    assert_eq!(c["set_aside"], true);
    assert!(
        c["logs"].as_array().unwrap().len() >= 2,
        "names the logs it contradicts"
    );
    assert!(f(&c["size_rel"]) > 0.2 && f(&c["size_sigma"]) > 3.0, "{c}");
    assert!(v["mu_s_set_aside"]
        .as_array()
        .unwrap()
        .iter()
        .any(|l| l == other_s.as_str()));
    // Its Rd also contradicts μd: named as well.
    assert!(
        cs.iter()
            .any(|c| c["logs"][0] == other_s.as_str() && c["quantity"] == "mu_d"),
        "{cs:?}"
    );
    // The robust μ is the pad's; every log's μ is pulled up by the other pad.
    let (mu_s, mu_d) = (f(&v["mu_s"]), f(&v["mu_d"]));
    assert!((mu_s / MU_S - 1.0).abs() < 0.03, "mu_s {mu_s}");
    assert!((mu_d / MU_D - 1.0).abs() < 0.03, "mu_d {mu_d}");
    assert!(f(&v["all_logs"]["mu_d"]) > mu_d, "{}", v["all_logs"]);
    recommendation_or_reason(&v);
    assert!(v["recommended_normal_force_n"].is_number(), "{v}");
    // The settings table marks it.
    let s = v["settings"]
        .as_array()
        .unwrap()
        .iter()
        .find(|s| s["log"] == other_s.as_str())
        .unwrap();
    assert_eq!(s["set_aside_mu_s"], true);
}

/// The same test given twice, in one format or in three, counts once.
#[test]
fn duplicates_count_once() {
    let logs = vec![
        data("char_N2.2.mcap"),
        data("char_N4.mcap"),
        data("char_N2.2.csv"),
        data("char_N2.2.parquet"),
        data("char_N4.mcap"),
    ];
    let (code, v, stderr) = batch(&logs, &[]);
    assert_eq!(code, Some(0), "{stderr}");
    let dups: Vec<&str> = v["duplicates"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_str().unwrap())
        .collect();
    assert_eq!(dups.len(), 3, "{dups:?}");
    assert!(dups.iter().any(|d| d.ends_with("char_N2.2.csv")));
    assert!(dups.iter().any(|d| d.ends_with("char_N2.2.parquet")));
    assert!(dups.iter().any(|d| d.ends_with("char_N4.mcap")));
    assert_eq!(v["mu_s_points"], 2, "two tests measure Rs");
    assert_eq!(v["settings"].as_array().unwrap().len(), 2);
    let codes = v["warning_codes"].as_array().unwrap();
    assert_eq!(
        codes.iter().filter(|c| *c == "duplicate").count(),
        3,
        "{}",
        v["warnings"]
    );
    // Every given log still has its fit entry.
    assert_eq!(v["fits"].as_array().unwrap().len(), 5);
}

/// Logs of two rigs: refused with one error line, accepted with the flag.
/// The one `error: …` line of a failed command's stderr (asserted to be
/// exactly one).
fn single_error(stderr: &str) -> &str {
    let errors: Vec<&str> = stderr
        .lines()
        .filter(|l| l.starts_with("error: "))
        .collect();
    assert_eq!(errors.len(), 1, "{stderr}");
    errors[0]
}

#[test]
fn mixed_rigs_refused_unless_allowed() {
    let dir = tempfile::tempdir().unwrap();
    // The bundled rig's masses and springs, but K2 4.5 % stiffer.
    let other = dir.path().join("k2_700.mcap");
    let o = Command::new(env!("CARGO_BIN_EXE_stickslip"))
        .args(["synth", "--out", other.to_str().unwrap()])
        .args(["--normal-force", "4", "--k2-n-per-m", "700", "--json"])
        .output()
        .unwrap();
    assert!(o.status.success());
    let logs = vec![data("char_N4.mcap"), data("char_N7.2.mcap"), other.clone()];
    let (code, _, stderr) = batch(&logs, &[]);
    assert_eq!(code, Some(1), "{stderr}");
    let error = single_error(&stderr);
    assert!(
        error.contains("k2_700.mcap")
            && error.contains("char_N4.mcap")
            && error.contains("K2")
            && error.contains("--allow-mixed-rigs"),
        "{}",
        error
    );
    assert!(!stderr.contains("panicked"));
    // Accepted with the flag, with the difference as a warning.
    let (code, v, stderr) = batch(&logs, &["--allow-mixed-rigs"]);
    assert_eq!(code, Some(0), "{stderr}");
    assert!(v["mu_s"].is_number());
    assert!(v["warnings"]
        .as_array()
        .unwrap()
        .iter()
        .any(|w| w.as_str().unwrap().contains("K2")));
    assert!(v["warning_codes"]
        .as_array()
        .unwrap()
        .iter()
        .any(|c| c == "rig_mismatch"));
    // validate: the characteristic log against a sweep of the other rig.
    let o = Command::new(env!("CARGO_BIN_EXE_stickslip"))
        .args(["validate", "--characteristic", other.to_str().unwrap()])
        .args(["--sweep", data("sweep_stepped_N4.mcap").to_str().unwrap()])
        .args(["--samples", "0", "--json"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{stderr}");
    let error = single_error(&stderr);
    assert!(error.contains("K2") && error.contains("sweep_stepped_N4.mcap"));
    // run: a plan with both rigs.
    let plan = dir.path().join("plan.toml");
    std::fs::write(
        &plan,
        format!(
            "batch = [{:?}, {:?}]\n",
            data("char_N4.mcap").display().to_string(),
            other.display().to_string()
        ),
    )
    .unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_stickslip"))
        .args(["run", plan.to_str().unwrap(), "--json"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{stderr}");
    let error = single_error(&stderr);
    assert!(error.contains("K2") && error.contains("k2_700.mcap"));
}

/// Two logs of two pads, one measured Rs each, 67 % apart: nothing says
/// which is right (two observations: nothing is set aside), so μs's
/// interval is widened by their scatter with one degree of freedom (from
/// the refined estimates: [0.31, 1.08], holding both pads' values). μs and
/// μd are still reported with intervals; no normal force is recommended
/// (the conflict is unresolved) and `recommendation_reason` says why in
/// words.
#[test]
fn no_recommendation_says_why() {
    let dir = tempfile::tempdir().unwrap();
    let (a, ta) = synth(dir.path(), "pad_a_n3.2", 3.2, (MU_S, MU_D), &[]);
    let (b, tb) = synth(dir.path(), "pad_b_n2", 2.0, (0.7, 0.6), &["--seed", "9"]);
    for t in [&ta, &tb] {
        let sf = f(&t["stick_fraction"]);
        assert!(sf > 0.05 && sf < 0.95, "sticks and slips: {sf}");
    }
    let (code, v, stderr) = batch(&[a, b], &[]);
    show(&v);
    assert_eq!(code, Some(0), "{stderr}");
    assert!(!stderr.contains("panicked"));
    assert_eq!(v["mu_s_points"], 2);
    assert!(v["mu_s"].is_number() && v["mu_d"].is_number());
    assert!(v["mu_s_interval"][0].is_number() && v["mu_s_interval"][1].is_number());
    recommendation_or_reason(&v);
    assert!(v["recommended_normal_force_n"].is_null());
    let reason = v["recommendation_reason"].as_str().unwrap();
    assert!(
        reason.contains("μs") && reason.contains("interval") && reason.contains("contradict"),
        "{reason}"
    );
    let cs = checked_conflicts(&v);
    assert!(cs.iter().any(|c| c["quantity"] == "mu_s"), "{cs:?}");
}
