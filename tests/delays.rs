//! Channel delays and velocity-sensor consistency (issue 30, items 1–2):
//! the binary on synthetic logs with known delays and drifts (a few cases,
//! fast), every bundled log (no delay warning on clean data), and the seed
//! studies (`#[ignore]`; `cargo test --release --test delays -- --ignored
//! --nocapture`), whose figures are in `docs/measurements.md`.

mod common;

use common::{bin, data, env_or, f, json_of};
use serde_json::Value;
use std::path::{Path, PathBuf};
use stickslip::identify::{self, IdentifyOptions, Interval};
use stickslip::ingest::{self, IngestOptions, Quantity};
use stickslip::stats::Rng;
use stickslip::synth::{self, FrictionSpec, RigSpec, Sensors, SynthConfig, TestSpec};

/// A test rig other than the bundled one: (m1, m2, k1 = k2, drive Hz,
/// normal force) chosen so that the absorber sticks and slips.
#[derive(Clone, Copy, Debug)]
struct TestRig {
    name: &'static str,
    m1: f64,
    m2: f64,
    k: f64,
    freq: f64,
    normal: f64,
}

const RIG_A: TestRig = TestRig {
    name: "A (5 kg, 1 kg, 400 N/m, 2.3 Hz)",
    m1: 5.0,
    m2: 1.0,
    k: 400.0,
    freq: 2.3,
    normal: 1.5,
};
const RIG_B: TestRig = TestRig {
    name: "B (12 kg, 2.5 kg, 1000 N/m, 1.9 Hz)",
    m1: 12.0,
    m2: 2.5,
    k: 1000.0,
    freq: 1.9,
    normal: 3.5,
};

/// The rig's synth configuration with typical sensors (static/dynamic pad,
/// μs 0.42, μd 0.34).
fn config(rig: TestRig, seed: u64) -> SynthConfig {
    let n = rig.normal;
    SynthConfig {
        rig: RigSpec {
            m1_kg: rig.m1,
            m2_kg: rig.m2,
            k1_n_per_m: rig.k,
            k2_n_per_m: rig.k,
            d_n_s_per_m: 0.003 * (rig.k * rig.m2).sqrt(),
            drive_amplitude_nominal_m: 0.0025,
            drive_amplitude_true_m: 0.0025,
        },
        friction: FrictionSpec {
            rs_n: 0.42 * n,
            rd_n: 0.34 * n,
            slope_n_s_per_m: 0.0,
            stribeck_velocity_m_per_s: None,
            law: None,
        },
        normal_force_n: n,
        test: TestSpec::Characteristic {
            frequency_hz: rig.freq,
            warmup_s: 30.0,
            duration_s: 20.0,
        },
        sensors: Sensors::typical(seed),
        ..SynthConfig::paper(seed)
    }
}

/// Runs `stickslip synth` on rig A with extra flags; returns the log path.
fn synth_cli(dir: &Path, name: &str, seed: u64, extra: &[&str]) -> PathBuf {
    let out = dir.join(name);
    let r = RIG_A;
    let mut cmd = bin();
    cmd.args(["synth", "--json", "--out"])
        .arg(&out)
        .args(["--m1-kg", &r.m1.to_string(), "--m2-kg", &r.m2.to_string()])
        .args([
            "--k1-n-per-m",
            &r.k.to_string(),
            "--k2-n-per-m",
            &r.k.to_string(),
        ])
        .args(["--frequency-hz", &r.freq.to_string()])
        .args(["--normal-force", &r.normal.to_string()])
        .args(["--warmup-s", "30", "--seed", &seed.to_string()])
        .args(extra);
    json_of(&mut cmd);
    out
}

fn truth_of(dir: &Path, log: &str) -> Value {
    let t: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("truth.json")).unwrap()).unwrap();
    t["files"][log].clone()
}

/// The M2 channels lag by 3 ms (the issue's first case): `ingest --json`
/// finds x2's and v2's shift within 0.2 ms with an interval that holds the
/// truth, leaves x0 and a2 alone within their intervals, and warns with
/// the numbers; `fit --json` carries the same keys and gets Rs and Rd
/// within 3 %.
#[test]
fn m2_channels_lagging_3_ms_are_found_and_corrected() {
    let dir = tempfile::tempdir().unwrap();
    let log = synth_cli(
        dir.path(),
        "lag.mcap",
        3,
        &["--channel-delay-s", "x2=0.003,v2=0.003"],
    );
    let truth = truth_of(dir.path(), "lag.mcap");
    assert_eq!(f(&truth["channel_delays_s"]["x2"]), -0.003);
    let ing = json_of(bin().args(["ingest", "--json"]).arg(&log));
    let d = &ing["channel_delays_s"];
    let iv = &ing["channel_delays_interval_s"];
    // The truth with each sensor low-pass's lag (v2 and a2 are filtered).
    for ch in ["x0", "x2", "v2", "a2"] {
        let want = f(&truth["channel_lags_s"][ch]);
        let (lo, hi) = (f(&iv[ch][0]), f(&iv[ch][1]));
        assert!(
            lo <= want && want <= hi,
            "{ch}: truth {want} outside [{lo}, {hi}]"
        );
        if want.abs() > 1e-3 {
            // The estimate (the interval's centre); sub-sample lags of v2
            // and a2 against their reference are left to the fit's own
            // alignment, so the applied shift may differ by < 1 sample.
            let got = 0.5 * (lo + hi);
            assert!((f(&d[ch]) - want).abs() < 1e-3, "{ch}: applied {}", d[ch]);
            assert!((got - want).abs() < 2e-4, "{ch}: {got} vs {want}");
        }
    }
    assert_eq!(f(&d["x1"]), 0.0);
    let warnings = ing["warnings"].to_string();
    assert!(warnings.contains("channel x2 lags x1 by 3."), "{warnings}");
    assert!(
        ing["warning_codes"]
            .as_array()
            .unwrap()
            .iter()
            .any(|c| c == "channel_delay"),
        "{}",
        ing["warning_codes"]
    );
    let fit = json_of(bin().args(["fit", "--json"]).arg(&log));
    let e = &fit["fits"][0];
    assert_eq!(e["channel_delays_s"], ing["channel_delays_s"]);
    let (rs, rd) = (0.42 * RIG_A.normal, 0.34 * RIG_A.normal);
    assert!(
        (f(&e["r_s_n"]) / rs - 1.0).abs() < 0.03,
        "Rs {}",
        e["r_s_n"]
    );
    assert!(
        (f(&e["r_d_n"]) / rd - 1.0).abs() < 0.03,
        "Rd {}",
        e["r_d_n"]
    );
}

/// A drive channel that leads by 4 ms (negative delay) comes back with the
/// sign of a channel map's `shift_s` (+4 ms).
#[test]
fn a_leading_drive_gets_a_positive_shift() {
    let dir = tempfile::tempdir().unwrap();
    let log = synth_cli(
        dir.path(),
        "lead.mcap",
        5,
        &["--channel-delay-s", "x0=-0.004"],
    );
    let ing = json_of(bin().args(["ingest", "--json"]).arg(&log));
    let got = f(&ing["channel_delays_s"]["x0"]);
    assert!((got - 0.004).abs() < 2e-4, "x0 shift {got}");
    let iv = &ing["channel_delays_interval_s"]["x0"];
    assert!(f(&iv[0]) <= 0.004 && 0.004 <= f(&iv[1]), "{iv}");
}

/// A velocity transducer whose offset drifts by 8 mm/s over the log (the
/// issue's second case): the drift is measured against d/dt x2 and
/// removed, the log is not called stuck, Rs and Rd come back within 3 %.
#[test]
fn a_drifting_velocity_offset_is_removed() {
    let dir = tempfile::tempdir().unwrap();
    let log = synth_cli(
        dir.path(),
        "drift.mcap",
        7,
        &["--offset-drift-per-s", "v2=0.0004"],
    );
    let ing = json_of(bin().args(["ingest", "--json"]).arg(&log));
    let v = &ing["velocity_consistency"];
    assert_eq!(v["drift_corrected"], true, "{v}");
    assert!((f(&v["drift_m_per_s2"]) - 4e-4).abs() < 3e-5, "{v}");
    let fit = json_of(bin().args(["fit", "--json"]).arg(&log));
    let e = &fit["fits"][0];
    assert_eq!(e["stuck"], false);
    let (rs, rd) = (0.42 * RIG_A.normal, 0.34 * RIG_A.normal);
    assert!(
        (f(&e["r_s_n"]) / rs - 1.0).abs() < 0.03,
        "Rs {}",
        e["r_s_n"]
    );
    assert!(
        (f(&e["r_d_n"]) / rd - 1.0).abs() < 0.03,
        "Rd {}",
        e["r_d_n"]
    );
}

/// A velocity transducer whose gain is 10 % high or low (x2's own gain 1;
/// no accelerometer, so M2's inertia comes from the differentiated v2),
/// and an accelerometer 10 % low: each gain is measured against x2's
/// derivatives (within its interval) and the channel divided by it, with a
/// warning. Without the correction the equation-error Rd came out 10 %
/// off (1.018 N for 0.918 N on the public rig); now within 3 %. Gains
/// within 2 % of 1 (the typical sensors) are left alone.
#[test]
fn miscalibrated_velocity_and_acceleration_gains_are_corrected() {
    let dir = tempfile::tempdir().unwrap();
    // (v2's gain, a2's gain or no accelerometer, v2 corrected, a2 corrected.)
    for (v2_gain, a2_gain, v_fixed, a_fixed) in [
        (1.1, None, true, false),
        (0.9, None, true, false),
        (1.01, None, false, false),
        (1.0, Some(0.9), false, true),
        (1.1, Some(1.0), true, false),
    ] {
        let mut sensors = Sensors::typical(11);
        sensors.x2.gain = 1.0;
        sensors.v2.gain = v2_gain;
        match a2_gain {
            Some(g) => sensors.a2.as_mut().unwrap().gain = g,
            None => sensors.a2 = None,
        }
        let label = format!("v2 {v2_gain}, a2 {a2_gain:?}");
        let sj = dir.path().join("s.json");
        std::fs::write(&sj, serde_json::to_string(&sensors).unwrap()).unwrap();
        let name = format!("gain{v2_gain}_{}.mcap", a2_gain.unwrap_or(0.0));
        let log = synth_cli(dir.path(), &name, 11, &["--sensors", sj.to_str().unwrap()]);
        let ing = json_of(bin().args(["ingest", "--json"]).arg(&log));
        let codes = ing["warning_codes"].as_array().unwrap();
        for (key, code, truth, fixed) in [
            (
                "velocity_consistency",
                "velocity_gain",
                Some(v2_gain),
                v_fixed,
            ),
            (
                "acceleration_consistency",
                "acceleration_gain",
                a2_gain,
                a_fixed,
            ),
        ] {
            let v = &ing[key];
            let Some(truth) = truth else {
                assert!(v.is_null(), "{label}: {v}");
                continue;
            };
            assert_eq!(v["gain_corrected"], fixed, "{label}: {v}");
            let (g, se) = (f(&v["gain"]), f(&v["gain_se"]));
            assert!((g - truth).abs() < 4.0 * se + 1e-3, "{label}: {v}");
            assert_eq!(codes.iter().any(|c| c == code), fixed, "{label}");
        }
        let fit = json_of(bin().args(["fit", "--json"]).arg(&log));
        let e = &fit["fits"][0];
        let (rs, rd) = (0.42 * RIG_A.normal, 0.34 * RIG_A.normal);
        for (key, truth) in [("r_s_n", rs), ("r_d_n", rd)] {
            for est in [&e[key], &e["equation_error"][key]] {
                assert!((f(est) / truth - 1.0).abs() < 0.03, "{label}: {key} {est}");
            }
        }
    }
}

/// A dead velocity transducer (a constant 10 mm/s plus a little ripple,
/// whatever the motion) must not make a sliding absorber "stuck": the
/// positions overrule it, and the fit says so.
#[test]
fn positions_overrule_a_velocity_that_says_stuck() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = config(RIG_A, 11);
    let mut log = synth::generate(&cfg).unwrap();
    for c in log
        .channels
        .iter_mut()
        .filter(|c| c.quantity == Quantity::V2)
    {
        let mut i = 0.0f64;
        for b in c.buffers.iter_mut() {
            for v in b.values.iter_mut().flatten() {
                *v = 0.01 + 1e-4 * (1.7 * i).sin();
                i += 1.0;
            }
        }
    }
    let path = dir.path().join("broken_v2.mcap");
    synth::write(&log, &path).unwrap();
    let fit = json_of(bin().args(["fit", "--json"]).arg(&path));
    let e = &fit["fits"][0];
    assert_eq!(e["stuck"], false, "{}", e["warnings"]);
    assert!(
        e["warning_codes"]
            .as_array()
            .unwrap()
            .iter()
            .any(|c| c == "velocity_distrusted"),
        "{}",
        e["warnings"]
    );
}

/// Every bundled log: the keys are there, and no delay or drift warning
/// fires on these clean logs (a warning on good data is a defect).
/// Sensors of log019 of the adequacy study (`scripts/adequacy_study.py`,
/// seed 2026): filters at 143 Hz (x0), 417 Hz (x1), 232 Hz (x2), so x2
/// lags x1 by about 0.3 ms, below one sample at 2 kHz (not re-stamped).
const LAGGING_SENSORS: &str = r#"{"x0": {"rate_hz": 2000.0, "noise": 3.6343559006557145e-06, "quant": 2.5e-06, "gain": 1.0016870201117454, "offset": 0.0002775947862091446, "lowpass_hz": 142.60178201105305, "buffer_s": 0.1, "start_offset_ns": null, "jitter_ns": 0, "p_lost_buffer": 0.005, "p_dropout": 0.0002, "dropout_burst_max": 4, "noise_correlation_s": 0.0}, "x1": {"rate_hz": 2000.0, "noise": 6.14841407131401e-06, "quant": 2.5e-06, "gain": 0.9908803954129204, "offset": -0.0019074407558538429, "lowpass_hz": 416.9379867645772, "buffer_s": 0.2, "start_offset_ns": null, "jitter_ns": 2000, "p_lost_buffer": 0.01, "p_dropout": 0.0, "dropout_burst_max": 4, "noise_correlation_s": 0.0}, "x2": {"rate_hz": 2000.0, "noise": 1.8130941568876397e-06, "quant": 1e-06, "gain": 0.9900446190247297, "offset": -0.0011268672627905117, "lowpass_hz": 232.3433739893301, "buffer_s": 0.05, "start_offset_ns": null, "jitter_ns": 0, "p_lost_buffer": 0.0, "p_dropout": 0.0, "dropout_burst_max": 4, "noise_correlation_s": 0.000891076990515427}, "v2": {"rate_hz": 1000.0, "noise": 0.0005675718690061364, "quant": 1e-05, "gain": 1.0007940610432822, "offset": -7.937459099912205e-05, "lowpass_hz": 292.20012965622425, "buffer_s": 0.2, "start_offset_ns": null, "jitter_ns": 10000, "p_lost_buffer": 0.01, "p_dropout": 0.0, "dropout_burst_max": 4, "noise_correlation_s": 0.0}, "a2": null, "normal_force": {"rate_hz": 10.0, "noise": 0.0, "quant": 0.01, "gain": 1.0047078273049337, "offset": -0.01712694197926948, "lowpass_hz": null, "buffer_s": 0.5, "start_offset_ns": null, "jitter_ns": 10000, "p_lost_buffer": 0.01, "p_dropout": 0.0, "dropout_burst_max": 4, "noise_correlation_s": 0.0}}"#;

/// A lag small enough that the law without it passes the adequacy test
/// (x2 residual 1.24× the noise; structure against velocity z 10.3,
/// effect 0.48 < 0.5) but large enough to bias it: a Coulomb pad was read
/// as static/dynamic with Rs 8.5 % high, 6.7 half-widths off. The lags'
/// signature (significant structure against velocity or drive phase)
/// makes the fit try them, and the BIC keeps them.
#[test]
fn lags_that_leave_the_law_adequate_but_biased_are_fitted() {
    let dir = tempfile::tempdir().expect("tempdir");
    let log = dir.path().join("lag.mcap");
    let truth_rs = 0.464_294_169_184_705_2;
    common::synth_log(
        &log,
        Some(LAGGING_SENSORS),
        &[
            &["--seed", "119", "--frequency-hz", "2.292181908284495"][..],
            &common::STUDY_RIG,
            &[
                "--rs-n",
                "0.46429416918470523",
                "--rd-n",
                "0.46429416918470523",
                "--law",
                "coulomb",
            ],
        ]
        .concat(),
    );
    let j = json_of(bin().arg("fit").arg(&log).arg("--json"));
    let fit = &j["fits"][0];
    let codes = common::codes_of(fit);
    assert!(
        codes.contains(&"position_delay"),
        "{codes:?}: {}",
        fit["warnings"]
    );
    assert_eq!(fit["law"], "coulomb", "{}", fit["warnings"]);
    assert_eq!(fit["adequate"], true);
    let iv = &fit["r_s_interval_n"];
    assert!(
        f(&iv[0]) <= truth_rs && truth_rs <= f(&iv[1]),
        "Rs {} [{}, {}] against {truth_rs}",
        fit["r_s_n"],
        iv[0],
        iv[1]
    );
    let lag2 = f(&fit["output_error"]["position_delays_s"][1]);
    assert!((0.2e-3..0.5e-3).contains(&lag2), "x2 lag {lag2}");
}

/// A slow-sliding log without any delay (rig B of
/// `scripts/slow_drift_study.py`, seed 12: 12 kg, 2.5 kg, 1000 N/m, 2 Hz,
/// A 0.35 mm, Rs 0.2 N, Rd 0.16 N, a v2 offset drifting by 0.37 mm/s per
/// s): the lag-free law is adequate, but x1's residuals carry a
/// non-periodic structure (as strong against time as against velocity)
/// that the lag fallback read as x1 lagging by −2.8 ms; the lags lowered
/// the BIC by 55 without shrinking the structures (x2's grew, 0.10 →
/// 0.15 of the noise) and moved Rd to −5.5 % with an interval that missed.
/// Lags are kept only where they shrink the signature they were fitted for.
#[test]
fn lags_that_do_not_explain_the_signature_are_not_kept() {
    let dir = tempfile::tempdir().expect("tempdir");
    let log = dir.path().join("slow.mcap");
    common::synth_log(
        &log,
        None,
        &[
            "--seed",
            "12",
            "--law",
            "static-dynamic",
            "--offset-drift-per-s",
            "v2=0.0003714930752643932",
            "--m1-kg",
            "12",
            "--m2-kg",
            "2.5",
            "--k1-n-per-m",
            "1000",
            "--k2-n-per-m",
            "1000",
            "--frequency-hz",
            "2.0",
            "--amplitude-m",
            "0.00035",
            "--rs-n",
            "0.2",
            "--rd-n",
            "0.16",
        ],
    );
    let j = json_of(bin().arg("fit").arg(&log).arg("--json"));
    let fit = &j["fits"][0];
    let codes = common::codes_of(fit);
    assert!(!codes.contains(&"position_delay"), "{}", fit["warnings"]);
    assert_eq!(fit["law"], "static-dynamic", "{}", fit["warnings"]);
    assert_eq!(fit["adequate"], true);
    let rd = f(&fit["r_d_n"]);
    let iv = &fit["r_d_interval_n"];
    assert!((rd / 0.16 - 1.0).abs() < 0.03, "Rd {rd}");
    assert!(f(&iv[0]) <= 0.16 && 0.16 <= f(&iv[1]), "Rd {rd} {iv}");
}

#[test]
fn bundled_logs_get_no_delay_warning() {
    let mut names: Vec<String> = std::fs::read_dir(data(""))
        .unwrap()
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".mcap") || n.ends_with(".parquet") || n.ends_with(".csv"))
        .collect();
    names.sort();
    assert!(names.len() >= 10, "{names:?}");
    for n in &names {
        let ing = json_of(bin().args(["ingest", "--json"]).arg(data(n)));
        for key in ["channel_delays_s", "channel_delays_interval_s"] {
            assert!(ing[key].is_object(), "{n}: {key} missing");
        }
        let codes = ing["warning_codes"].as_array().unwrap();
        assert!(
            !codes
                .iter()
                .any(|c| c == "channel_delay" || c == "velocity_drift"),
            "{n}: {}",
            ing["warnings"]
        );
        // Each estimated shift applied is within one sample (a sensor
        // filter's lag); the CSV map declares x0's shift of −4 ms.
        for (ch, v) in ing["channel_delays_s"].as_object().unwrap() {
            let declared = if n.ends_with(".csv") && ch == "x0" {
                -0.004
            } else {
                0.0
            };
            if let Some(s) = v.as_f64() {
                assert!((s - declared).abs() < 1e-3, "{n}: {ch} shifted by {s}");
            }
        }
    }
}

/// A still x2 (a stuck absorber) has no x2 shift: `null`.
#[test]
fn a_still_channel_has_no_shift() {
    let ing = json_of(bin().args(["ingest", "--json"]).arg(data("char_N30.mcap")));
    assert!(
        ing["channel_delays_s"]["x2"].is_null(),
        "{}",
        ing["channel_delays_s"]
    );
    assert!(ing["channel_delays_interval_s"]["x2"].is_null());
    assert!(ing["channel_delays_s"]["x0"].is_number());
}

// ---------------------------------------------------------------- studies

fn inside(iv: Option<Interval>, x: f64) -> bool {
    matches!(iv, Some((lo, hi)) if lo <= x && x <= hi)
}

/// One study case: the estimates against the truth.
#[derive(Default, Clone)]
struct Case {
    /// Per channel x0, x2, v2, a2: (error s, half-width s, covered).
    delays: Vec<(f64, f64, bool)>,
    rs_ok: bool,
    rd_ok: bool,
    rs_cover: bool,
    rd_cover: bool,
    stuck_or_never: bool,
    line: String,
}

/// Generates, writes, ingests and fits one case of `defect` on `rig`.
fn study_case(rig: TestRig, defect: &str, seed: u64, dir: &Path) -> Case {
    let mut cfg = config(rig, seed);
    let mut r = Rng::new(seed ^ 0x00DE_1A75);
    match defect {
        "delays" => {
            for m in [
                &mut cfg.sensors.x0,
                &mut cfg.sensors.x2,
                &mut cfg.sensors.v2,
            ] {
                m.delay_s = 0.01 * r.uniform();
            }
            if let Some(a) = cfg.sensors.a2.as_mut() {
                a.delay_s = 0.01 * r.uniform();
            }
        }
        "drift" => {
            // Within a velocity transducer's specification: offset up to
            // ±2 mm/s, drifting by up to ±8 mm/s over the 20 s log.
            cfg.sensors.v2.offset = 0.002 * (2.0 * r.uniform() - 1.0);
            cfg.sensors.v2.offset_drift_per_s = 4e-4 * (2.0 * r.uniform() - 1.0);
        }
        _ => unreachable!(),
    }
    let log = synth::generate(&cfg).expect("generate");
    // One directory per case: each writes its own truth.json.
    let dir = dir.join(format!("{defect}_{}_{seed}", rig.m1));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("log.mcap");
    synth::write(&log, &path).expect("write");
    let run = ingest::read(&path, &IngestOptions::default()).expect("ingest");
    let mut case = Case::default();
    for q in [Quantity::X0, Quantity::X2, Quantity::V2, Quantity::A2] {
        let want = log.truth["channel_lags_s"][q.name()].as_f64().unwrap();
        if let Some(c) = run.delays.get(q) {
            match (c.estimated_s, c.interval_s) {
                (Some(_), Some([lo, hi])) => {
                    let est = 0.5 * (lo + hi);
                    case.delays
                        .push((est - want, 0.5 * (hi - lo), lo <= want && want <= hi));
                }
                _ => case.delays.push((f64::NAN, f64::NAN, false)),
            }
        }
    }
    let fit = identify::fit_log(&run, &IdentifyOptions::default()).expect("fit");
    let (rs, rd) = (cfg.friction.rs_n, cfg.friction.rd_n);
    case.stuck_or_never = fit.stuck() || fit.never_sticks();
    let law = fit.law();
    let (rs_hat, rd_hat) = (
        fit.rs_n().unwrap_or(f64::NAN),
        law.map_or(f64::NAN, |l| l.rd_n),
    );
    case.rs_ok = (rs_hat / rs - 1.0).abs() <= 0.03;
    case.rd_ok = (rd_hat / rd - 1.0).abs() <= 0.03;
    case.rs_cover = inside(fit.rs_interval_n, rs);
    case.rd_cover = inside(fit.rd_interval_n, rd);
    case.line =
        format!(
        "{defect} seed {seed}: Rs {:+.2} % Rd {:+.2} % cover {}/{} adequate {} delays(ms err) {}",
        100.0 * (rs_hat / rs - 1.0),
        100.0 * (rd_hat / rd - 1.0),
        case.rs_cover,
        case.rd_cover,
        fit.adequate(),
        case.delays
            .iter()
            .map(|(e, h, c)| format!("{:+.3}±{:.3}{}", e * 1e3, h * 1e3, if *c { "" } else { "!" }))
            .collect::<Vec<_>>()
            .join(" ")
    );
    case
}

fn study(defect: &str) {
    // STUDY_FROM..=STUDY_N, STUDY_CASE (A or B) and STUDY_DIR (kept logs)
    // look at one case again.
    let n: u64 = env_or("STUDY_N", 20);
    let from: u64 = env_or("STUDY_FROM", 1);
    let only = std::env::var("STUDY_CASE").unwrap_or_default();
    let tmp = tempfile::tempdir().unwrap();
    let kept = std::env::var_os("STUDY_DIR").filter(|d| !d.is_empty());
    let dir = kept.as_deref().map_or(tmp.path(), Path::new);
    for rig in [RIG_A, RIG_B] {
        if !rig.name.starts_with(only.as_str()) {
            continue;
        }
        let seeds: Vec<u64> = (from..=n).collect();
        let cases: Vec<Case> = std::thread::scope(|s| {
            let handles: Vec<_> = seeds
                .chunks(seeds.len().div_ceil(2).max(1))
                .map(|chunk| {
                    s.spawn(move || {
                        chunk
                            .iter()
                            .map(|&seed| study_case(rig, defect, seed, dir))
                            .collect::<Vec<_>>()
                    })
                })
                .collect();
            handles
                .into_iter()
                .flat_map(|h| h.join().unwrap())
                .collect()
        });
        for c in &cases {
            println!("{}", c.line);
        }
        let m = cases.len() as f64;
        let frac = |p: &dyn Fn(&Case) -> bool| cases.iter().filter(|c| p(c)).count() as f64 / m;
        let all: Vec<(f64, f64, bool)> = cases.iter().flat_map(|c| c.delays.clone()).collect();
        let k = all.len().max(1) as f64;
        let within = all.iter().filter(|d| d.0.abs() <= 2e-4).count() as f64 / k;
        let covered = all.iter().filter(|d| d.2).count() as f64 / k;
        let halves: Vec<f64> = all.iter().map(|d| d.1).filter(|h| h.is_finite()).collect();
        let median_half = stickslip::stats::median(&halves);
        println!(
            "SUMMARY {defect} rig {}: {} logs; Rs within 3 %: {:.0} %, Rd within 3 %: {:.0} %, Rs covered {:.0} %, Rd covered {:.0} %, stuck/never-sticks {:.0} %; delays within 0.2 ms {:.0} %, covered {:.0} %, median half-width {:.3} ms",
            rig.name,
            cases.len(),
            100.0 * frac(&|c| c.rs_ok),
            100.0 * frac(&|c| c.rd_ok),
            100.0 * frac(&|c| c.rs_cover),
            100.0 * frac(&|c| c.rd_cover),
            100.0 * frac(&|c| c.stuck_or_never),
            100.0 * within,
            100.0 * covered,
            median_half * 1e3
        );
    }
}

/// Delays 0–10 ms drawn per channel (x0, x2, v2, a2), 20 seeds per rig.
#[test]
#[ignore]
fn study_channel_delays() {
    study("delays");
}

/// Velocity offsets ±2 mm/s drifting by up to ±8 mm/s over the log.
#[test]
#[ignore]
fn study_velocity_drift() {
    study("drift");
}
