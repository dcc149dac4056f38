//! Helpers shared by the integration tests. Each test crate includes this
//! module (`mod common;`) and uses what it needs, so some helpers are
//! unused in some crates.
#![allow(dead_code)]

use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

/// A file of the bundled data set (`datasets/`).
pub fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("datasets")
        .join(name)
}

/// `datasets/truth.json`, parsed once per test crate.
pub fn truth() -> &'static Value {
    static T: OnceLock<Value> = OnceLock::new();
    T.get_or_init(|| {
        let text = std::fs::read_to_string(data("truth.json")).expect("truth.json");
        serde_json::from_str(&text).expect("truth.json parses")
    })
}

/// The `stickslip` binary of this build.
pub fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_stickslip"))
}

/// Runs `cmd`, asserts that it succeeded (else panics with its stderr)
/// and parses its stdout as one JSON value.
pub fn json_of(cmd: &mut Command) -> Value {
    let out = cmd.output().expect("runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("one JSON object on stdout")
}

/// A JSON number (panics with the value otherwise).
pub fn f(v: &Value) -> f64 {
    v.as_f64().unwrap_or_else(|| panic!("not a number: {v}"))
}

/// The environment variable `name` parsed as `T` (study sizes such as
/// `STUDY_N`), or `default` when unset or unparsable.
pub fn env_or<T: std::str::FromStr>(name: &str, default: T) -> T {
    std::env::var(name)
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(default)
}

/// The `warning_codes` of a JSON object (empty when it has none).
pub fn codes_of(v: &Value) -> Vec<&str> {
    v["warning_codes"]
        .as_array()
        .map(|a| a.iter().filter_map(Value::as_str).collect())
        .unwrap_or_default()
}

/// Runs `stickslip synth --out LOG` with `args` (and `--sensors SENSORS`
/// written into LOG's folder when given); panics with stderr on failure.
pub fn synth_log(log: &Path, sensors: Option<&str>, args: &[&str]) {
    let mut cmd = bin();
    cmd.arg("synth").arg("--out").arg(log);
    if let Some(s) = sensors {
        let sj = log.with_extension("sensors.json");
        std::fs::write(&sj, s).expect("write the sensors file");
        cmd.arg("--sensors").arg(sj);
    }
    let out = cmd.args(args).output().expect("runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// The rig of the adequacy study's first family (`scripts/adequacy_study.py`:
/// M1 3 kg, M2 1 kg, K1 200 N/m, K2 500 N/m, drive 2 mm, 2 N) as `synth`
/// arguments; a test adds seed, frequency and pad.
pub const STUDY_RIG: [&str; 14] = [
    "--m1-kg",
    "3",
    "--m2-kg",
    "1",
    "--k1-n-per-m",
    "200",
    "--k2-n-per-m",
    "500",
    "--d-n-s-per-m",
    "0.08944271909999159",
    "--amplitude-m",
    "0.002",
    "--normal-force",
    "2.0",
];

/// Drops wall-time keys (`seconds`, `stage_seconds`, …) from a JSON value.
pub fn without_seconds(v: &mut Value) {
    match v {
        Value::Object(m) => {
            m.retain(|k, _| !k.contains("seconds"));
            m.values_mut().for_each(without_seconds);
        }
        Value::Array(a) => a.iter_mut().for_each(without_seconds),
        _ => {}
    }
}

/// The public rig's absorber (m 4, k 1, D 0.003) and the batch's default η
/// grid on it (uniform coarse grid plus the fine window, unrefined).
pub fn public_batch_grid() -> (stickslip::model::Absorber, Vec<f64>) {
    use stickslip::batch::{default_eta_range, drive_etas, BatchOptions};
    let ab = stickslip::model::Absorber {
        m: 4.0,
        k: 1.0,
        damping: 0.003,
    };
    let o = BatchOptions::default();
    let etas = drive_etas(
        &ab,
        default_eta_range(&ab),
        o.eta_points,
        o.eta_fine_step,
        o.eta_fine_halfwidth,
    );
    (ab, etas)
}
