//! Validation bands that cover what the rig measures (issue 32):
//!
//! * a mass that stands still measures 0 (not the noise's half-range), so a
//!   stuck M2 lies inside its replay band [0, 0];
//! * the replay band carries the drive's uncertainty (the x0 gain, drawn
//!   with the law), so where M2 is stuck and the law does not matter the
//!   A1 band is no longer a single number that the measured A1 misses;
//! * strict coverage (the measured value inside the band), loose coverage
//!   (its error bar overlapping the band) and the robust replay nrms on a
//!   small synthetic sweep of another rig.

mod common;

use common::{bin, data, f, json_of};
use serde_json::Value;
use std::path::Path;

/// `stickslip validate --json` of a characteristic log and a sweep.
fn validate(characteristic: &Path, sweep: &Path) -> Value {
    json_of(
        bin()
            .args(["validate", "--json", "--characteristic"])
            .arg(characteristic)
            .arg("--sweep")
            .arg(sweep),
    )
}

/// A rig other than the bundled one (M1 10 kg, M2 3 kg, K1 1200 N/m,
/// K2 800 N/m, Stribeck pad at 4.5 N): its characteristic log and a short
/// stepped sweep whose M2 is stuck at both ends. Returns the validation
/// and the sweep's truth entry.
fn other_rig(dir: &Path) -> (Value, Value) {
    let rig = [
        "--m1-kg",
        "10",
        "--m2-kg",
        "3",
        "--k1-n-per-m",
        "1200",
        "--k2-n-per-m",
        "800",
        "--law",
        "stribeck",
        "--normal-force",
        "4.5",
    ];
    let (ch, sw) = (dir.join("char.mcap"), dir.join("sweep.mcap"));
    let with_rig =
        |extra: &[&'static str]| -> Vec<&str> { extra.iter().chain(rig.iter()).copied().collect() };
    common::synth_log(&ch, None, &with_rig(&["--seed", "21"]));
    common::synth_log(
        &sw,
        None,
        &with_rig(&[
            "--seed",
            "22",
            "--test",
            "stepped",
            "--setpoints-hz",
            "0.9,1.3,1.7,2.1,2.5,2.9,3.4",
            "--dwell-s",
            "12",
        ]),
    );
    let truth: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("truth.json")).unwrap()).unwrap();
    (validate(&ch, &sw), truth["files"]["sweep.mcap"].clone())
}

/// On another rig's sweep, every step whose M2 truly stands still
/// (truth's A2 = 0) measures A2 about 0: within half its own error bar,
/// and inside the replay band [0, 0]. The eq. 6 extremes of the noisy
/// samples gave the noise's half-range (about 0.0009 with an error bar of
/// 0.0012, outside [0, 0]). Coverage: strict (measured value inside the
/// band) and loose (error bar overlapping it) at least 0.8 for A2, loose
/// at least 0.8 for A1, replay nrms (robust) within 5 %.
#[test]
fn a_mass_that_stands_still_measures_zero() {
    let dir = tempfile::tempdir().unwrap();
    let (v, truth) = other_rig(dir.path());
    let m = &v["measured"];
    let a2 = m["amplitude2"].as_array().unwrap();
    let u2 = m["amplitude2_uncertainty"].as_array().unwrap();
    let (lo, hi) = (
        v["replay"]["amplitude2_low"].as_array().unwrap(),
        v["replay"]["amplitude2_high"].as_array().unwrap(),
    );
    let resp = truth["response"].as_array().unwrap();
    assert_eq!(resp.len(), a2.len());
    let stuck: Vec<usize> = (0..resp.len())
        .filter(|&i| f(&resp[i]["a2"]) < 1e-6)
        .collect();
    assert!(stuck.len() >= 2, "stuck steps {stuck:?}");
    let near_zero = stuck
        .iter()
        .filter(|&&i| f(&a2[i]) <= 0.5 * f(&u2[i]))
        .count();
    let in_band = stuck
        .iter()
        .filter(|&&i| f(&a2[i]) >= f(&lo[i]) && f(&a2[i]) <= f(&hi[i]))
        .count();
    eprintln!(
        "stuck steps {}: about 0 {near_zero}, inside the band {in_band}; A2 {:?}",
        stuck.len(),
        stuck.iter().map(|&i| f(&a2[i])).collect::<Vec<_>>()
    );
    assert!(near_zero as f64 >= 0.9 * stuck.len() as f64);
    assert!(in_band as f64 >= 0.9 * stuck.len() as f64);
    // The measured error bar's keys bracket the value, never below 0.
    for (k, a) in a2.iter().enumerate() {
        let (l, h) = (f(&m["amplitude2_low"][k]), f(&m["amplitude2_high"][k]));
        assert!(l >= 0.0 && l <= f(a) && f(a) <= h, "step {k}: {l} {a} {h}");
    }
    let s = &v["score"];
    eprintln!("score {s}");
    for k in [
        "replay_coverage_strict_amplitude2",
        "replay_coverage_amplitude1",
        "replay_coverage_amplitude2",
    ] {
        assert!(f(&s[k]) >= 0.8, "{k} {}", s[k]);
    }
    for k in [
        "replay_nrms_robust_amplitude1",
        "replay_nrms_robust_amplitude2",
    ] {
        assert!(f(&s[k]) <= 0.05, "{k} {}", s[k]);
    }
    assert_eq!(
        v["replay_sensitive"].as_array().unwrap().len(),
        a2.len(),
        "one entry per step"
    );
}

/// The bundled N7.2 sweep: M2 stands still at most steps, where A1/A does
/// not depend on the law, and the band carried the law's uncertainty only:
/// it was a single number and the measured A1 sat 0.3 % below it (strict
/// A1 coverage 0.57, A2 0.24). With the drive's amplitude uncertainty in
/// the band (its x0 gain, drawn jointly with the law) and still masses at
/// 0, both are at least 0.8; the A1 band is never a single number.
#[test]
fn the_band_carries_the_drive() {
    let v = validate(&data("char_N7.2.mcap"), &data("sweep_stepped_N7.2.mcap"));
    let s = &v["score"];
    eprintln!("score {s}");
    for k in [
        "replay_coverage_strict_amplitude1",
        "replay_coverage_strict_amplitude2",
    ] {
        assert!(f(&s[k]) >= 0.8, "{k} {}", s[k]);
    }
    let r = &v["replay"];
    for (l, h) in r["amplitude1_low"]
        .as_array()
        .unwrap()
        .iter()
        .zip(r["amplitude1_high"].as_array().unwrap())
    {
        assert!(f(h) - f(l) > 1e-3 * f(h), "a single-number band {l} {h}");
    }
    let d = &v["measured"]["drive_uncertainty"];
    assert!(f(&d["amplitude_rel"]) < 1e-3, "{d}");
    sensitive_steps(&v);
}

/// Sensitive steps (issue 32, item 3) of the bundled N7.2 sweep: every
/// step is assessed (a stepped sweep); where the replay does not hinge on
/// the start (the step is not sensitive), the ensemble's spread agrees
/// with the linear propagation (within 3× either way, the rule itself, in
/// at least 80 % of the amplitudes that move); at most 20 % of the steps
/// are sensitive but some are (M2's breakaway between η 0.58 and 0.71:
/// measured 3 of 21), each sensitive step's band holds its ensemble's
/// range, and the robust replay nrms are within 5 %.
fn sensitive_steps(v: &Value) {
    let flags = v["replay_sensitive"].as_array().unwrap();
    let detail = v["replay_sensitivity"].as_array().unwrap();
    assert!(flags.iter().all(|x| x.is_boolean()), "{flags:?}");
    let n = flags.len();
    let k = flags.iter().filter(|x| **x == true).count();
    assert!(k >= 1 && 5 * k <= n, "{k} of {n} sensitive");
    let r = &v["replay"];
    let (mut agree, mut moving) = (0, 0);
    for (i, s) in detail.iter().enumerate() {
        for (a, key) in [(0, "1"), (1, "2")] {
            let (sp, li) = (f(&s["spread"][a]), f(&s["linear"][a]));
            if s["sensitive"] == false && li > 1e-6 {
                moving += 1;
                agree += usize::from(sp <= 3.0 * li && li <= 3.0 * sp);
            }
            if s["sensitive"] == true {
                let lo = f(&r[format!("amplitude{key}_low")][i]);
                let hi = f(&r[format!("amplitude{key}_high")][i]);
                let (a0, a1) = (
                    f(&s[format!("range{key}")][0]),
                    f(&s[format!("range{key}")][1]),
                );
                assert!(
                    lo <= a0 && a1 <= hi,
                    "step {i}: band [{lo}, {hi}], ensemble [{a0}, {a1}]"
                );
            }
        }
    }
    assert!(5 * agree >= 4 * moving, "linear agrees {agree} of {moving}");
    let s = &v["score"];
    for key in [
        "replay_nrms_robust_amplitude1",
        "replay_nrms_robust_amplitude2",
    ] {
        assert!(f(&s[key]) <= 0.05, "{key} {}", s[key]);
    }
}
