//! The golden record of every command's `--json` output on `datasets/`
//! (the main job, `fit` of every characteristic log, `validate` of the
//! three sweeps, `batch`, the `sweep` of Fig. 3), taken right before the
//! restructuring of issue 15 and compared after each of its steps.
//!
//! * Run: `just golden` (release build, about 1.5 min on 2 cores; the
//!   tests are ignored in the debug suite because the main job alone takes
//!   minutes there).
//! * Parsed values are compared, not bytes (key order may change). Keys
//!   named `seconds` and `stage_seconds` (wall times) are left out; paths are written relative to
//!   `<datasets>` and `<out>` (the test's temporary directory).
//! * Numbers must agree to `GOLDEN_RTOL` relative (default 1e-12: a pure
//!   move changes nothing). After a numeric change, every difference is
//!   listed (path, recorded, now); explain them, then re-make the record
//!   with `GOLDEN_RECORD=1 just golden` and commit it with the explanation.

use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::Command;

fn datasets() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("datasets")
}

fn record_path(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/golden")
        .join(format!("{name}.json"))
}

/// Drops `seconds` and `stage_seconds` keys (wall times) and writes paths relative to the data and output
/// directories.
fn normalise(v: &mut Value, data: &str, out: &str) {
    match v {
        Value::Object(m) => {
            m.remove("seconds");
            m.remove("stage_seconds");
            for x in m.values_mut() {
                normalise(x, data, out);
            }
        }
        Value::Array(a) => a.iter_mut().for_each(|x| normalise(x, data, out)),
        Value::String(s) if s.contains(data) || s.contains(out) => {
            *s = s.replace(data, "<datasets>").replace(out, "<out>");
        }
        _ => {}
    }
}

/// The differences between the record `a` and the output `b`.
fn differences(a: &Value, b: &Value, path: &str, rtol: f64, out: &mut Vec<String>) {
    match (a, b) {
        (Value::Object(x), Value::Object(y)) => {
            for (k, va) in x {
                match y.get(k) {
                    Some(vb) => differences(va, vb, &format!("{path}/{k}"), rtol, out),
                    None => out.push(format!("{path}/{k}: recorded, now missing")),
                }
            }
            for k in y.keys().filter(|k| !x.contains_key(*k)) {
                out.push(format!("{path}/{k}: new key"));
            }
        }
        (Value::Array(x), Value::Array(y)) => {
            if x.len() != y.len() {
                out.push(format!(
                    "{path}: {} items recorded, {} now",
                    x.len(),
                    y.len()
                ));
            }
            for (i, (va, vb)) in x.iter().zip(y).enumerate() {
                differences(va, vb, &format!("{path}[{i}]"), rtol, out);
            }
        }
        (Value::Number(x), Value::Number(y)) => {
            let (p, q) = (
                x.as_f64().unwrap_or(f64::NAN),
                y.as_f64().unwrap_or(f64::NAN),
            );
            if (p - q).abs() > rtol * p.abs().max(q.abs()) {
                out.push(format!("{path}: {p} recorded, {q} now"));
            }
        }
        _ => {
            if a != b {
                out.push(format!("{path}: {a} recorded, {b} now"));
            }
        }
    }
}

/// Runs `stickslip ARGS` (ARGS may name `{out}` for a temporary output
/// directory), normalises its JSON and records it or compares it with the
/// record `name`.
fn golden(name: &str, args: &[&str]) {
    let tmp = tempfile::tempdir().expect("tempdir");
    let data = datasets();
    let (data_s, out_s) = (
        data.to_string_lossy().into_owned(),
        tmp.path().to_string_lossy().into_owned(),
    );
    let args: Vec<String> = args
        .iter()
        .map(|a| a.replace("{data}", &data_s).replace("{out}", &out_s))
        .collect();
    let out = Command::new(env!("CARGO_BIN_EXE_stickslip"))
        .args(&args)
        .output()
        .expect("run stickslip");
    assert!(
        out.status.success(),
        "{name}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let mut now: Value = serde_json::from_slice(&out.stdout).expect("one JSON object");
    normalise(&mut now, &data_s, &out_s);
    let path = record_path(name);
    if std::env::var_os("GOLDEN_RECORD").is_some() {
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        let text = serde_json::to_string_pretty(&now).unwrap();
        std::fs::write(&path, text + "\n").unwrap();
        eprintln!("{name}: recorded {}", path.display());
        return;
    }
    let recorded: Value = serde_json::from_str(
        &std::fs::read_to_string(&path)
            .unwrap_or_else(|e| panic!("{}: {e} (GOLDEN_RECORD=1 makes it)", path.display())),
    )
    .expect("record is JSON");
    let rtol = std::env::var("GOLDEN_RTOL")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1e-12);
    let mut diff = Vec::new();
    differences(&recorded, &now, "", rtol, &mut diff);
    assert!(
        diff.is_empty(),
        "{name}: {} differences from the record (rtol {rtol:e}):\n{}",
        diff.len(),
        diff.iter()
            .take(200)
            .cloned()
            .collect::<Vec<_>>()
            .join("\n")
    );
}

#[test]
#[ignore = "golden record: release build (`just golden`)"]
fn golden_main_job() {
    golden(
        "run",
        &[
            "run",
            "{data}/plan.toml",
            "--json",
            "--report",
            "{out}/report",
        ],
    );
}

#[test]
#[ignore = "golden record: release build (`just golden`)"]
fn golden_fit_every_log() {
    golden(
        "fit",
        &[
            "fit",
            "--json",
            "{data}/char_N1.2.mcap",
            "{data}/char_N2.2.mcap",
            "{data}/char_N2.2.csv",
            "{data}/char_N2.2.parquet",
            "{data}/char_N4.mcap",
            "{data}/char_N7.2.mcap",
            "{data}/char_N30.mcap",
            "{data}/law_coulomb.mcap",
            "{data}/law_decreasing.mcap",
            "{data}/law_stribeck.mcap",
        ],
    );
}

#[test]
#[ignore = "golden record: release build (`just golden`)"]
fn golden_validate_stepped_n4() {
    golden(
        "validate_stepped_N4",
        &[
            "validate",
            "--json",
            "--characteristic",
            "{data}/char_N4.mcap",
            "--sweep",
            "{data}/sweep_stepped_N4.mcap",
        ],
    );
}

#[test]
#[ignore = "golden record: release build (`just golden`)"]
fn golden_validate_stepped_n7_2() {
    golden(
        "validate_stepped_N7.2",
        &[
            "validate",
            "--json",
            "--characteristic",
            "{data}/char_N7.2.mcap",
            "--sweep",
            "{data}/sweep_stepped_N7.2.mcap",
        ],
    );
}

#[test]
#[ignore = "golden record: release build (`just golden`)"]
fn golden_validate_continuous_n4() {
    golden(
        "validate_continuous_N4",
        &[
            "validate",
            "--json",
            "--characteristic",
            "{data}/char_N4.mcap",
            "--sweep",
            "{data}/sweep_continuous_N4.mcap",
        ],
    );
}

#[test]
#[ignore = "golden record: release build (`just golden`)"]
fn golden_batch() {
    golden(
        "batch",
        &[
            "batch",
            "--json",
            "{data}/char_N1.2.mcap",
            "{data}/char_N2.2.mcap",
            "{data}/char_N4.mcap",
            "{data}/char_N7.2.mcap",
            "{data}/char_N30.mcap",
        ],
    );
}

#[test]
#[ignore = "golden record: release build (`just golden`)"]
fn golden_sweep_fig3() {
    golden("sweep_fig3", &["sweep", "--json"]);
}

/// The comparison itself: a changed number, a missing key and a new key
/// are each reported; equal values are not.
#[test]
fn differences_are_found() {
    let a: Value = serde_json::json!({"x": 1.0, "y": [1, 2], "z": "a", "seconds": 3});
    let mut b: Value = serde_json::json!({"x": 1.0 + 1e-9, "y": [1, 2], "w": true, "seconds": 4});
    normalise(&mut b, "/nowhere", "/nowhere");
    let mut d = Vec::new();
    differences(&a, &a, "", 1e-12, &mut d);
    assert!(d.is_empty());
    differences(&a, &b, "", 1e-12, &mut d);
    assert_eq!(d.len(), 4, "{d:?}"); // x, z missing, seconds missing, w new
    let mut d = Vec::new();
    differences(&a, &b, "", 1e-6, &mut d);
    assert_eq!(d.len(), 3, "{d:?}");
    let mut s = Value::String("/data/x/char.mcap in /tmp/o/r".into());
    normalise(&mut s, "/data/x", "/tmp/o");
    assert_eq!(s, "<datasets>/char.mcap in <out>/r");
}
