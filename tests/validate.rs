//! Validation against the public sweeps (issue 7), with `truth.json`:
//!
//! * machinery with the TRUE law (not the fit): the steady-state prediction
//!   equals the truth's `steady_a1`, `steady_a2` (the exact steady state of
//!   the true law, continued step to step from rest) to 1e-6, and the replay
//!   of the sweep as it was run matches the rig's `a1`, `a2` over the
//!   truth's settle windows with an nrms under 2 %;
//! * `stickslip validate` with the fitted law: JSON keys of the interface,
//!   at least 80 % of the measured steps inside the 95 % replay band on
//!   sweeps whose characteristic log sticks, and the steady-state call
//!   right wherever the rig's amplitude is more than 10 % from its steady
//!   state;
//! * the HTML report: written, escaped, offline; `stickslip run` on the
//!   bundled plan.

use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;
use stickslip::identify::{LawKind, SiLaw};
use stickslip::ingest::{self, IngestOptions};
use stickslip::validate::frc::{self, FrcOptions};
use stickslip::validate::predict::{predict_with, PredictOptions};

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("datasets")
        .join(name)
}

fn truth() -> &'static Value {
    static T: OnceLock<Value> = OnceLock::new();
    T.get_or_init(|| {
        let text = std::fs::read_to_string(data("truth.json")).expect("truth.json");
        serde_json::from_str(&text).expect("truth.json parses")
    })
}

fn f(v: &Value) -> f64 {
    v.as_f64().unwrap_or_else(|| panic!("not a number: {v}"))
}

/// The true law of a truth entry, in SI.
fn true_law(t: &Value) -> SiLaw {
    let l = &t["law"];
    let kind = match l["family"].as_str().unwrap() {
        "coulomb" => LawKind::Coulomb,
        "decreasing" | "viscous" => LawKind::Decreasing,
        "static_dynamic" => LawKind::StaticDynamic,
        _ => LawKind::Stribeck,
    };
    SiLaw {
        kind,
        rs_n: f(&l["rs_n"]),
        rd_n: f(&l["rd_n"]),
        slope_n_s_per_m: f(&l["slope_n_s_per_m"]),
        vs_m_per_s: l["stribeck_velocity_m_per_s"].as_f64(),
    }
}

/// With the true law and the truth's η and rig constants, the steady-state
/// prediction is the truth's `steady_a*` to 1e-6, and the replay through
/// the measured plan matches the rig's amplitudes over the truth's settle
/// windows (nrms < 2 %).
#[test]
fn true_law_reproduces_the_truth() {
    for name in ["sweep_stepped_N4.mcap", "sweep_stepped_N7.2.mcap"] {
        let t = &truth()["files"][name];
        let mut run = ingest::read(&data(name), &IngestOptions::default()).unwrap();
        // The metadata rounds d to 6 digits; the truth's D is exact.
        run.rig.d_n_s_per_m = f(&t["rig"]["d_n_s_per_m"]);
        let mut m = frc::measure(&run, &FrcOptions::default()).unwrap();
        let resp = t["response"].as_array().unwrap();
        assert_eq!(m.points.len(), resp.len(), "{name}: one point per setpoint");
        m.drive_amplitude_m = f(&t["drive_amplitude_true_m"]);
        for (p, r) in m.points.iter_mut().zip(resp) {
            p.eta = f(&r["eta"]);
            let w = r["settle_window_s"].as_array().unwrap();
            p.window_s = (f(&w[0]), f(&w[1]));
        }
        let opts = PredictOptions {
            samples: 0,
            ..PredictOptions::default()
        };
        let pred = predict_with(&true_law(t), &[], &run.rig, &m, &opts).unwrap();
        let (mut worst, mut sq, mut peak) = (0.0f64, 0.0, 0.0f64);
        for (i, r) in resp.iter().enumerate() {
            if let (Some(s1), Some(s2)) = (r["steady_a1"].as_f64(), r["steady_a2"].as_f64()) {
                let (p1, p2) = (
                    pred.steady.amplitude1[i].unwrap(),
                    pred.steady.amplitude2[i].unwrap(),
                );
                worst = worst.max((p1 - s1).abs()).max((p2 - s2).abs());
            }
            let a1 = pred.replay.amplitude1[i].expect("replay amplitude");
            sq += (a1 - f(&r["a1"])).powi(2);
            peak = peak.max(f(&r["a1"]));
        }
        let nrms = (sq / resp.len() as f64).sqrt() / peak;
        eprintln!(
            "{name}: steady worst |Δ| {worst:.2e}, replay nrms A1 {:.3} %",
            nrms * 100.0
        );
        assert!(worst < 1e-6, "{name}: steady state vs truth {worst:e}");
        assert!(nrms < 0.02, "{name}: replay nrms {nrms}");
    }
}

fn validate_json(characteristic: &str, sweep: &str, report: Option<&Path>) -> Value {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_stickslip"));
    cmd.arg("validate")
        .arg("--characteristic")
        .arg(data(characteristic))
        .arg("--sweep")
        .arg(data(sweep))
        .arg("--json");
    if let Some(r) = report {
        cmd.arg("--report").arg(r);
    }
    let out = cmd.output().unwrap();
    assert!(
        out.status.success(),
        "validate failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("one JSON object on stdout")
}

/// The fitted law predicts the stepped sweeps within its band, and the
/// steady-state call is right where the rig is far from its steady state.
#[test]
fn fitted_law_validates_on_stepped_sweeps() {
    for (ch, sw) in [
        ("char_N4.mcap", "sweep_stepped_N4.mcap"),
        ("char_N7.2.mcap", "sweep_stepped_N7.2.mcap"),
    ] {
        let dir = tempfile::tempdir().unwrap();
        let v = validate_json(ch, sw, Some(dir.path()));
        for key in ["fit", "measured", "predicted", "replay", "score"] {
            assert!(v.get(key).is_some(), "missing key {key}");
        }
        for key in [
            "rms_amplitude1",
            "rms_amplitude2",
            "nrms_amplitude1",
            "nrms_amplitude2",
            "peak_eta_error",
            "replay_nrms_amplitude1",
            "replay_nrms_amplitude2",
            "replay_coverage_amplitude1",
            "replay_coverage_amplitude2",
        ] {
            assert!(v["score"].get(key).is_some(), "missing score key {key}");
        }
        for key in [
            "amplitude1_low",
            "amplitude1_high",
            "amplitude2_low",
            "amplitude2_high",
        ] {
            assert!(v["replay"][key].is_array() && v["predicted"][key].is_array());
        }
        let s = &v["score"];
        eprintln!("{sw}: {s}");
        let cov = f(&s["replay_coverage_amplitude1"]);
        assert!(cov >= 0.8, "{sw}: replay band coverage A1 {cov}");
        // The steady-state call wherever the rig is > 10 % from its steady state.
        let resp = truth()["files"][sw]["response"].as_array().unwrap();
        let calls = v["measured"]["steady_reached"].as_array().unwrap();
        assert_eq!(calls.len(), resp.len());
        for (r, c) in resp.iter().zip(calls) {
            if let Some(s1) = r["steady_a1"].as_f64() {
                let off = (f(&r["a1"]) - s1).abs() / s1.max(1e-9);
                if off > 0.10 {
                    assert_eq!(
                        c,
                        &Value::Bool(false),
                        "{sw}: step at {} Hz is {off:.2} off its steady state",
                        r["frequency_hz"]
                    );
                }
            }
        }
        // The report: written, the notes of the log escaped, offline.
        let html = std::fs::read_to_string(dir.path().join("index.html")).unwrap();
        assert!(html.contains("<img src=\"frc_"), "figure referenced");
        assert!(!html.contains("<tags/>") && !html.contains("<b>check</b>"));
        assert!(!html.contains("https://") && !html.contains("http://"));
        for entry in std::fs::read_dir(dir.path()).unwrap() {
            let p = entry.unwrap().path();
            let name = p.file_name().unwrap().to_string_lossy().into_owned();
            assert!(!name.starts_with('.'), "temporary file left: {name}");
        }
    }
}

/// The continuous sweep: one point per drive period, predictions at each.
#[test]
fn continuous_sweep_validates() {
    let v = validate_json("char_N4.mcap", "sweep_continuous_N4.mcap", None);
    let n = v["measured"]["eta"].as_array().unwrap().len();
    // 0.9 → 3.4 Hz over 240 s plus holds: hundreds of drive periods.
    assert!(n > 300, "{n} points");
    assert_eq!(v["replay"]["amplitude1"].as_array().unwrap().len(), n);
    eprintln!("continuous: {}", v["score"]);
    assert!(f(&v["score"]["replay_coverage_amplitude1"]) >= 0.8);
}

/// A characteristic log whose mass never slid cannot predict a sweep: a
/// clear error, exit 1, no panic.
#[test]
fn stuck_characteristic_is_a_clear_error() {
    let out = Command::new(env!("CARGO_BIN_EXE_stickslip"))
        .args(["validate", "--json", "--characteristic"])
        .arg(data("char_N30.mcap"))
        .arg("--sweep")
        .arg(data("sweep_stepped_N4.mcap"))
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.starts_with("error: ") && err.contains("never slid"),
        "{err}"
    );
    assert!(out.stdout.is_empty());
}
