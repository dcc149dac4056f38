//! The HTML report end to end: `stickslip run` on a plan whose log carries
//! markup in its metadata (`notes` with a `<script>`): the page shows it as
//! text, never as markup; the report opens offline, leaves no temporary
//! files, and refuses to overwrite an input.

mod common;

use common::data;
use std::path::{Path, PathBuf};
use std::process::Command;

/// A copy of the CSV characteristic log whose `notes` hold a script.
fn log_with_script(dir: &Path) -> PathBuf {
    let text = std::fs::read_to_string(data("char_N2.2.csv")).unwrap();
    let text = text.replace(
        "#notes,friction member re-torqued; see log #12 -> fine",
        "#notes,<script>alert('pwned')</script> & <b>bold</b>",
    );
    assert!(text.contains("<script>"), "the notes line was replaced");
    let csv = dir.join("evil.csv");
    std::fs::write(&csv, text).unwrap();
    std::fs::copy(data("char_N2.2.map.toml"), dir.join("evil.map.toml")).unwrap();
    csv
}

#[test]
fn script_in_metadata_is_escaped() {
    let dir = tempfile::tempdir().unwrap();
    log_with_script(dir.path());
    let plan = dir.path().join("plan.toml");
    std::fs::write(&plan, "title = \"<i>plan</i>\"\nfit = [\"evil.csv\"]\n").unwrap();
    let report = dir.path().join("report");
    let out = Command::new(env!("CARGO_BIN_EXE_stickslip"))
        .arg("run")
        .arg(&plan)
        .arg("--report")
        .arg(&report)
        .arg("--json")
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let html = std::fs::read_to_string(report.join("index.html")).unwrap();
    assert!(!html.contains("<script"), "a script tag reached the page");
    assert!(!html.contains("<b>bold</b>") && !html.contains("<i>plan</i>"));
    assert!(
        html.contains("&lt;script&gt;alert(&#x27;pwned&#x27;)&lt;&#x2f;script&gt;")
            || html.contains("&lt;script&gt;alert(&#39;pwned&#39;)&lt;/script&gt;"),
        "the notes are shown as text"
    );
    assert!(!html.contains("http://") && !html.contains("https://"));
    for entry in std::fs::read_dir(&report).unwrap() {
        let name = entry.unwrap().file_name().to_string_lossy().into_owned();
        assert!(!name.starts_with('.'), "temporary file left: {name}");
    }
}

/// An output path that names an input is refused before any work, and the
/// input is left as it was (fit, validate, characteristic, ingest).
#[test]
fn outputs_never_overwrite_inputs() {
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("log.mcap");
    std::fs::copy(data("char_N1.2.mcap"), &log).unwrap();
    let csv = log_with_script(dir.path());
    let map = dir.path().join("evil.map.toml");
    let pq = dir.path().join("log.parquet");
    std::fs::copy(data("char_N2.2.parquet"), &pq).unwrap();
    let pq_before = std::fs::read(&pq).unwrap();
    let before = std::fs::read(&log).unwrap();
    let map_before = std::fs::read(&map).unwrap();
    let s = |p: &Path| p.display().to_string();
    let cases: Vec<Vec<String>> = vec![
        vec!["fit".into(), s(&log), "--out".into(), s(&log)],
        vec!["fit".into(), s(&csv), "--out".into(), s(&map)],
        vec![
            "validate".into(),
            "--characteristic".into(),
            s(&log),
            "--sweep".into(),
            s(&data("sweep_stepped_N4.mcap")),
            "--out".into(),
            s(&log),
        ],
        vec!["characteristic".into(), s(&log), "--out".into(), s(&log)],
        vec!["ingest".into(), s(&pq), "--out".into(), s(&pq)],
    ];
    for args in cases {
        let out = Command::new(env!("CARGO_BIN_EXE_stickslip"))
            .args(&args)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{args:?}: {err}");
        assert!(
            err.starts_with("error: ") && err.contains("would overwrite the input"),
            "{args:?}: {err}"
        );
    }
    assert_eq!(std::fs::read(&log).unwrap(), before, "log overwritten");
    assert_eq!(std::fs::read(&map).unwrap(), map_before, "map overwritten");
    assert_eq!(
        std::fs::read(&pq).unwrap(),
        pq_before,
        "parquet overwritten"
    );
}

/// The main job: `stickslip run` on the bundled plan (ingest → fit →
/// validate → batch) writes one JSON object and a report with every figure.
#[test]
fn main_job_on_the_bundled_plan() {
    let dir = tempfile::tempdir().unwrap();
    let report = dir.path().join("report");
    let out = Command::new(env!("CARGO_BIN_EXE_stickslip"))
        .arg("run")
        .arg(data("plan.toml"))
        .args(["--samples", "10", "--json", "--report"])
        .arg(&report)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(
        v["fits"].as_array().unwrap().len(),
        8,
        "every characteristic log"
    );
    let vals = v["validations"].as_array().unwrap();
    assert_eq!(vals.len(), 3);
    for val in vals {
        assert!(val.get("error").is_none(), "{val}");
        assert!(val["score"]["replay_nrms_amplitude1"].as_f64().unwrap() < 0.1);
    }
    let b = &v["batch"];
    for key in [
        "mu_s",
        "mu_d",
        "recommended_normal_force_n",
        "worst_amplitude1",
        "cliff_rho_s",
    ] {
        assert!(b[key].as_f64().is_some(), "batch {key}: {b}");
    }
    let html = std::fs::read_to_string(report.join("index.html")).unwrap();
    for fig in [
        "batch.svg",
        "frc_sweep_stepped_N4.svg",
        "frc_sweep_continuous_N4.svg",
        "characteristic_char_N4.svg",
        "characteristic_law_stribeck.svg",
    ] {
        assert!(html.contains(fig), "{fig} referenced");
        assert!(report.join(fig).is_file(), "{fig} written");
    }
    // The characteristic figure draws the law used downstream (output
    // error) beside the equation-error law fitted to the plotted points;
    // the Stribeck log's output-error law is a Stribeck law too.
    let svg = |name: &str| std::fs::read_to_string(report.join(name)).unwrap();
    let n4 = svg("characteristic_char_N4.svg");
    assert!(n4.contains("output error (used)") && n4.contains("equation error"));
    let st = svg("characteristic_law_stribeck.svg");
    assert!(st.contains("output error (used)") && st.contains("stribeck"));
}
