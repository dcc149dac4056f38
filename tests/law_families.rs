//! Friction-law families added through the registry alone (issue 31): the
//! velocity-weakening family `exponential`,
//! g(v) = Rd + (Rs − Rd)·exp(−|v|/v_s), is synthesised, fitted with
//! `--law exponential`, kept out of `--law auto`, simulated, and predicted
//! over a sweep, with no code outside its file and its registry lines.
//!
//! The truth is what `synth` was given (Rs 1.2 N, Rd 0.8 N, v_s 4 mm/s on
//! the paper's rig at 2.2 N normal force), as `truth.json` records it.

mod common;

use common::{bin, f, json_of, synth_log};
use serde_json::Value;
use std::path::Path;

/// The pad of every test here (SI, as given to `synth`).
const RS_N: f64 = 1.2;
const RD_N: f64 = 0.8;
const VS_M_PER_S: f64 = 0.004;

/// `synth` arguments of the exponential pad, with `seed` and `extra`.
fn synth_exponential(log: &Path, seed: &str, extra: &[&str]) {
    let mut args = vec![
        "--law",
        "exponential",
        "--rs-n",
        "1.2",
        "--rd-n",
        "0.8",
        "--stribeck-velocity-m-per-s",
        "0.004",
        "--seed",
        seed,
    ];
    args.extend_from_slice(extra);
    synth_log(log, None, &args);
}

/// The truth entry `synth` wrote beside `log`.
fn truth_of(log: &Path) -> Value {
    let text = std::fs::read_to_string(log.with_file_name("truth.json")).expect("truth.json");
    let t: Value = serde_json::from_str(&text).expect("parses");
    let name = log.file_name().unwrap().to_str().unwrap();
    t["files"][name].clone()
}

fn covers(iv: &Value, x: f64) -> bool {
    f(&iv[0]) <= x && x <= f(&iv[1])
}

/// Synth → `fit --law exponential` recovers Rs, Rd (and ρs, ρd) within 2 %
/// with 95 % intervals that cover the truth, and v_s within 5 %, on three
/// seeds of the default (realistic) sensors, fixed before the first run.
#[test]
fn exponential_round_trip_through_synth_and_fit() {
    let dir = tempfile::tempdir().expect("tempdir");
    for seed in ["11", "12", "13"] {
        let log = dir.path().join(format!("exp_{seed}.mcap"));
        synth_exponential(&log, seed, &[]);
        let truth = truth_of(&log);
        assert_eq!(truth["law"]["family"], "exponential", "{truth}");
        let out = json_of(
            bin()
                .arg("fit")
                .arg(&log)
                .args(["--law", "exponential", "--json"]),
        );
        let fit = &out["fits"][0];
        assert_eq!(fit["law"], "exponential", "seed {seed}: {fit}");
        assert_eq!(fit["estimate"], "output-error", "seed {seed}");
        let (rs, rd) = (f(&fit["r_s_n"]), f(&fit["r_d_n"]));
        let oe = &fit["output_error"];
        let vs = f(&oe["v_s_m_per_s"]);
        let rel = |x: f64, t: f64| (x - t).abs() / t;
        eprintln!(
            "seed {seed}: Rs {rs:.4} ({:.2} %), Rd {rd:.4} ({:.2} %), v_s {:.3} mm/s ({:.2} %)",
            100.0 * rel(rs, RS_N),
            100.0 * rel(rd, RD_N),
            1e3 * vs,
            100.0 * rel(vs, VS_M_PER_S)
        );
        assert!(rel(rs, RS_N) < 0.02, "seed {seed}: Rs {rs}");
        assert!(rel(rd, RD_N) < 0.02, "seed {seed}: Rd {rd}");
        assert!(rel(vs, VS_M_PER_S) < 0.05, "seed {seed}: v_s {vs}");
        assert!(covers(&fit["r_s_interval_n"], RS_N), "seed {seed}: {fit}");
        assert!(covers(&fit["r_d_interval_n"], RD_N), "seed {seed}: {fit}");
        let (rho_s, rho_d) = (
            f(&truth["law"]["rho_s_true_amplitude"]),
            f(&truth["law"]["rho_d_true_amplitude"]),
        );
        assert!(covers(&fit["rho_s_interval"], rho_s), "seed {seed}: {fit}");
        assert!(covers(&fit["rho_d_interval"], rho_d), "seed {seed}: {fit}");
        // v_s dimensionless at the fitted amplitude, against the truth's at
        // the true amplitude (the amplitude is measured to about 0.3 %).
        let vs_rho = f(&truth["law"]["v_s_dimensionless_true_amplitude"]);
        assert!(rel(f(&oe["v_s"]), vs_rho) < 0.05, "seed {seed}: {oe}");
    }
}

/// `--law auto` never names the family: not chosen, not among the
/// criteria, so the automatic outputs are those before it was added.
#[test]
fn exponential_stays_out_of_law_auto() {
    let dir = tempfile::tempdir().expect("tempdir");
    let log = dir.path().join("exp.mcap");
    synth_exponential(&log, "11", &[]);
    let out = json_of(bin().arg("fit").arg(&log).arg("--json"));
    let fit = &out["fits"][0];
    assert_ne!(fit["law"], "exponential", "{fit}");
    for c in fit["criteria"].as_array().into_iter().flatten().chain(
        fit["equation_error"]["criteria"]
            .as_array()
            .into_iter()
            .flatten(),
    ) {
        assert_ne!(c["law"], "exponential", "{fit}");
    }
}

/// `simulate` integrates the family on the numerical engine from the
/// registry alone (the default method falls back from the closed form to
/// Dormand–Prince for a law that is not affine); RK4 refuses it.
#[test]
fn exponential_is_simulated_numerically() {
    let out = json_of(bin().args([
        "simulate",
        "--rho-s",
        "0.7",
        "--rho-d",
        "0.45",
        "--v-s",
        "0.1",
        "--law",
        "exponential",
        "--eta",
        "0.6",
        "--periods",
        "40",
        "--json",
    ]));
    assert_eq!(out["law"], "exponential", "{out}");
    assert_eq!(out["method"], "dopri", "{out}");
    let (a1, a2) = (f(&out["amplitude1"]), f(&out["amplitude2"]));
    assert!(
        a1.is_finite() && a1 > 0.0 && a2.is_finite() && a2 > 0.0,
        "{out}"
    );
    // Sticks and slips: a stick fraction strictly between 0 and 1.
    let sf = f(&out["stick_fraction"]);
    assert!(sf > 0.0 && sf < 1.0, "{out}");
    let rk4 = bin()
        .args([
            "simulate", "--rho-s", "0.7", "--rho-d", "0.45", "--v-s", "0.1",
        ])
        .args(["--law", "exponential", "--eta", "0.6", "--periods", "4"])
        .args(["--method", "rk4", "--step", "0.01"])
        .output()
        .expect("runs");
    assert!(!rk4.status.success());
    let err = String::from_utf8_lossy(&rk4.stderr);
    assert!(err.contains("affine"), "{err}");
}

/// `sweep` marches a shaped law's steady states on the numerical engine.
/// Reference: an exponential pad with v_s = 10⁶ slides at ρs − (ρs − ρd)·v/v_s,
/// within 3e-7 of Coulomb friction at ρs for the speeds here (|ζ2'| < 2), so
/// its steady amplitudes must match the exact engine's Coulomb curve (which
/// shoots) to the numerical engine's accuracy; and for a pad with a real
/// drop (v_s = 0.1) each marched point matches `simulate --steady`.
#[test]
fn exponential_is_swept_numerically() {
    let sweep = |extra: &[&str]| {
        json_of(
            bin()
                .args(["sweep", "--rho-s", "0.7", "--points", "4"])
                .args(["--eta-min", "0.5", "--eta-max", "1.4", "--from-rest"])
                .args(extra)
                .arg("--json"),
        )
    };
    let flat = sweep(&["--rho-d", "0.45", "--v-s", "1e6", "--law", "exponential"]);
    let coulomb = sweep(&[]);
    let (cf, cc) = (&flat["curves"][0], &coulomb["curves"][0]);
    let mut compared = 0;
    for i in 0..4 {
        if cf["steady"][i] != true || cc["steady"][i] != true {
            continue;
        }
        for key in ["amplitude1", "amplitude2"] {
            let (a, b) = (f(&cf[key][i]), f(&cc[key][i]));
            assert!(
                (a - b).abs() <= 1e-5 * b.abs().max(0.1),
                "{key}[{i}]: exponential v_s = 1e6 {a}, Coulomb {b}"
            );
        }
        compared += 1;
    }
    assert!(compared >= 3, "{flat} {coulomb}");
    let shaped = sweep(&["--rho-d", "0.45", "--v-s", "0.1", "--law", "exponential"]);
    let c = &shaped["curves"][0];
    // Each point the sweep marched to a steady state (from rest) is the one
    // `simulate --steady --from-rest` reaches on its own path (2026-12-02:
    // 1.5065753613742 vs 1.5065753613738 at η = 0.5).
    let mut marched = 0;
    for i in 0..4 {
        if c["method"][i] != "marching" || c["steady"][i] != true {
            continue;
        }
        let eta = f(&c["eta"][i]).to_string();
        let sim = json_of(
            bin()
                .args(["simulate", "--rho-s", "0.7", "--rho-d", "0.45"])
                .args(["--v-s", "0.1", "--law", "exponential", "--eta", &eta])
                .args(["--steady", "--from-rest", "--json"]),
        );
        assert_eq!(sim["status"], "steady", "{sim}");
        for key in ["amplitude1", "amplitude2"] {
            let (a, b) = (f(&c[key][i]), f(&sim[key]));
            assert!(
                (a - b).abs() <= 1e-6 * b.abs().max(0.1),
                "{key} at eta {eta}: sweep {a}, simulate {b}"
            );
        }
        marched += 1;
    }
    assert!(marched >= 1, "{c}");
    // A real drop: far from the Coulomb curve at η = 0.5 (1.51 vs 0.90).
    assert!(
        f(&c["amplitude1"][0]) > 1.2 * f(&cc["amplitude1"][0]),
        "{c}"
    );
}

/// A stepped sweep of an exponential pad, predicted with the law fitted by
/// `--law exponential` on a characteristic log of the same pad: the replay
/// of the measured drive (numerical engine, the family's jet) reproduces
/// the measured amplitudes to 1 % at every step.
#[test]
fn exponential_sweep_is_predicted() {
    let dir = tempfile::tempdir().expect("tempdir");
    let char_log = dir.path().join("char.mcap");
    synth_exponential(&char_log, "21", &[]);
    let sweep_dir = dir.path().join("sweep");
    std::fs::create_dir(&sweep_dir).expect("mkdir");
    let sweep = sweep_dir.join("sweep.mcap");
    synth_exponential(&sweep, "22", &["--test", "stepped"]);
    let fit = dir.path().join("fit.json");
    let st = bin()
        .arg("fit")
        .arg(&char_log)
        .args(["--law", "exponential", "--out"])
        .arg(&fit)
        .output()
        .expect("runs");
    assert!(
        st.status.success(),
        "{}",
        String::from_utf8_lossy(&st.stderr)
    );
    let out = json_of(
        bin()
            .arg("validate")
            .arg("--fit")
            .arg(&fit)
            .arg("--sweep")
            .arg(&sweep)
            .args(["--samples", "0", "--json"]),
    );
    assert_eq!(out["law_at_sweep"]["law"], "exponential", "{out}");
    let score = &out["score"];
    assert!(f(&score["points"]) >= 10.0, "{score}");
    for k in ["replay_nrms_amplitude1", "replay_nrms_amplitude2"] {
        assert!(f(&score[k]) < 0.01, "{k}: {score}");
    }
}
