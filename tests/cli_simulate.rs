//! `stickslip simulate` through the binary: the interface's JSON keys, the
//! exit codes, and the event/trajectory files.

mod common;

use common::bin;

fn tmpdir(name: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("stickslip-test-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

#[test]
fn json_has_the_interface_keys() {
    let out = bin()
        .args([
            "simulate", "--rho-s", "0.375", "--eta", "0.6", "--steady", "--json",
        ])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    for k in [
        "eta",
        "tau_end",
        "final_state",
        "events",
        "amplitude1",
        "amplitude2",
        "steady",
        "period_multiple",
        "stick_fraction",
        "interrupted",
    ] {
        assert!(v.get(k).is_some(), "missing key {k}");
    }
    assert_eq!(v["steady"], true);
    assert_eq!(v["final_state"].as_array().unwrap().len(), 4);
}

#[test]
fn events_and_trajectory_files() {
    let d = tmpdir("files");
    let (ev, tr) = (d.join("ev.csv"), d.join("tr.csv"));
    let out = bin()
        .args([
            "simulate",
            "--rho-s",
            "0.375",
            "--eta",
            "0.6",
            "--periods",
            "20",
            "--json",
        ])
        .arg("--events")
        .arg(&ev)
        .arg("--trajectory")
        .arg(&tr)
        .output()
        .unwrap();
    assert!(out.status.success());
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let ev = std::fs::read_to_string(ev).unwrap();
    let mut lines = ev.lines();
    assert_eq!(lines.next(), Some("tau,kind,zeta1,dzeta1,zeta2,dzeta2"));
    // One row per event, as counted in the JSON (43 for H1: datasets/reference).
    assert_eq!(lines.count() as u64, v["events"].as_u64().unwrap());
    assert_eq!(v["events"], 43);
    let tr = std::fs::read_to_string(tr).unwrap();
    // 64 samples per period plus the initial state.
    assert_eq!(tr.lines().count(), 1 + 20 * 64 + 1);
    std::fs::remove_dir_all(d).ok();
}

#[test]
fn bad_parameters_exit_1_with_one_error_line() {
    for args in [
        vec!["--rho-s", "0.3", "--rho-d", "0.4"],
        vec!["--rho-s", "-1"],
        vec!["--m", "0"],
        vec!["--damping", "nan"],
        vec!["--rho-s", "0.3", "--rho-d", "0.2", "--v-s", "0"],
    ] {
        let out = bin()
            .arg("simulate")
            .args(&args)
            .args(["--eta", "0.6", "--periods", "3"])
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(1), "{args:?}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(err.lines().count(), 1, "{err}");
        assert!(err.starts_with("error: "), "{err}");
        assert!(out.stdout.is_empty());
    }
    let out = bin()
        .args(["simulate", "--eta", "0"])
        .args(["--periods", "1"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    // Neither --periods nor --steady: a bad command line.
    let out = bin().args(["simulate", "--eta", "0.6"]).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
}

#[test]
fn unwritable_output_fails_cleanly() {
    let out = bin()
        .args([
            "simulate",
            "--rho-s",
            "0.3",
            "--eta",
            "0.6",
            "--periods",
            "2",
            "--events",
        ])
        .arg("/nonexistent-dir/ev.csv")
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).starts_with("error: /nonexistent-dir/ev.csv"));
}

/// A law without a closed form (stribeck) runs on the numerical engine.
#[test]
fn stribeck_runs_on_the_numerical_engine() {
    let out = bin()
        .args([
            "simulate", "--rho-s", "0.5", "--rho-d", "0.3", "--v-s", "0.05", "--eta", "0.6",
            "--steady", "--json",
        ])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["method"], "dopri");
    assert_eq!(v["law"], "stribeck");
    assert_eq!(v["steady"], true);
}

/// `stickslip bench --quick --json`: work-precision rows with the interface
/// keys; the exact engine at a tight root tolerance is the most accurate.
#[test]
fn bench_quick_rows() {
    let out = bin().args(["bench", "--quick", "--json"]).output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let rows = v["rows"].as_array().unwrap();
    for m in ["exact", "rk4", "dopri5"] {
        assert!(rows.iter().any(|r| r["method"] == m), "no {m} row");
    }
    for r in rows {
        for k in ["method", "setting", "seconds", "error"] {
            assert!(r.get(k).is_some());
        }
    }
    let tight = rows
        .iter()
        .find(|r| r["setting"] == "root tol 1e-12")
        .unwrap();
    // Against its own machine-precision run, through a different event
    // resolution: agreement to about the tolerance.
    assert!(tight["error"].as_f64().unwrap() < 1e-9);
}

/// Undamped forcing at the stuck system's eigenfrequency has no steady
/// state: said so, with null amplitudes, never a huge number.
#[test]
fn undamped_resonance_has_no_steady_state() {
    let eta0 = (2.0f64 / 4.0).sqrt().to_string();
    let out = bin()
        .args([
            "simulate",
            "--rho-s",
            "inf",
            "--damping",
            "0",
            "--eta",
            &eta0,
            "--steady",
            "--json",
        ])
        .output()
        .unwrap();
    assert!(out.status.success());
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["status"], "resonance");
    assert_eq!(v["steady"], false);
    assert!(v["amplitude1"].is_null());
}
