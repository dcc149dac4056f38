//! Issue 33: NI TDMS and MATLAB MAT level-5 logs (fixtures written by npTDMS
//! and scipy.io.savemat, `scripts/make_format_fixtures.py`) read through the
//! same door as MCAP, CSV and Parquet logs give the same run and fit as the
//! logs they copy; broken TDMS/MAT files give one `error:` line.

mod common;

use common::{bin, data, json_of};
use serde_json::Value;
use std::path::Path;

fn ingest(p: &Path, extra: &[&str]) -> Value {
    json_of(bin().arg("ingest").arg(p).args(extra).arg("--json"))
}

fn fit(p: &Path) -> Value {
    json_of(bin().arg("fit").arg(p).arg("--json"))
}

/// Every number of `a` and `b` agrees within `rel` (relative), every other
/// value exactly, except under the keys in `skip`; the differences found.
fn differences(a: &Value, b: &Value, rel: f64, skip: &[&str], at: &str, out: &mut Vec<String>) {
    match (a, b) {
        (Value::Object(x), Value::Object(y)) => {
            for k in x.keys().chain(y.keys().filter(|k| !x.contains_key(*k))) {
                if skip.contains(&k.as_str()) {
                    continue;
                }
                match (x.get(k), y.get(k)) {
                    (Some(u), Some(v)) => differences(u, v, rel, skip, &format!("{at}/{k}"), out),
                    _ => out.push(format!("{at}/{k}: on one side only")),
                }
            }
        }
        (Value::Array(x), Value::Array(y)) => {
            if x.len() != y.len() {
                out.push(format!("{at}: {} vs {} entries", x.len(), y.len()));
                return;
            }
            for (i, (u, v)) in x.iter().zip(y).enumerate() {
                differences(u, v, rel, skip, &format!("{at}[{i}]"), out);
            }
        }
        (Value::Number(x), Value::Number(y)) => {
            let (x, y) = (
                x.as_f64().unwrap_or(f64::NAN),
                y.as_f64().unwrap_or(f64::NAN),
            );
            let scale = x.abs().max(y.abs());
            // NaN (a number that is not one) fails too.
            let within = (x - y).abs() <= rel * scale;
            if !within {
                out.push(format!(
                    "{at}: {x} vs {y} ({:.2e} relative)",
                    (x - y).abs() / scale
                ));
            }
        }
        _ if a != b => out.push(format!("{at}: {a} vs {b}")),
        _ => {}
    }
}

fn assert_same(a: &Value, b: &Value, rel: f64, skip: &[&str], what: &str) {
    let mut d = Vec::new();
    differences(a, b, rel, skip, "", &mut d);
    assert!(
        d.is_empty(),
        "{what}: {} differences:\n{}",
        d.len(),
        d.join("\n")
    );
}

/// What differs by nature between a log and its copy in another format:
/// the file name and format, the channels' source names (MCAP topics vs
/// `Group/Channel`), the file's sha256 and run times of the fit.
const NOT_COMPARED: &[&str] = &["log", "format", "source", "log_sha256", "seconds"];

/// The fit keys of the interface (docs/interface.md, `stickslip fit`).
const FIT_KEYS: &[&str] = &[
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
    "adequate",
    "channel_delays_s",
    "channel_delays_interval_s",
];

fn fit_keys(v: &Value) -> Value {
    let f = &v["fits"][0];
    Value::Object(
        FIT_KEYS
            .iter()
            .map(|k| (k.to_string(), f.get(*k).cloned().unwrap_or(Value::Null)))
            .collect(),
    )
}

#[test]
fn waveform_tdms_gives_the_run_and_fit_of_its_mcap() {
    // synth_wf.mcap: no jitter, no lost buffers, channels at their own
    // start offsets and rates (1 kHz, a2 2 kHz, normal force 10 Hz);
    // synth_wf.tdms: its samples as waveforms, in two segments.
    let (mcap, tdms) = (data("formats/synth_wf.mcap"), data("formats/synth_wf.tdms"));
    let (a, b) = (ingest(&mcap, &[]), ingest(&tdms, &[]));
    assert_eq!(b["format"], "tdms");
    assert_eq!(a["channels"].as_array().map(Vec::len), Some(6));
    assert_same(&a, &b, 1e-9, NOT_COMPARED, "ingest");
    let (fa, fb) = (fit(&mcap), fit(&tdms));
    assert!(fa["fits"][0]["rho_s"].as_f64().is_some(), "{fa}");
    assert_same(&fit_keys(&fa), &fit_keys(&fb), 1e-9, &[], "fit");
}

#[test]
fn table_tdms_and_mat_give_the_run_and_fit_of_their_parquet() {
    let pq = data("formats/synth_table.parquet");
    let (a, fa) = (ingest(&pq, &[]), fit(&pq));
    assert!(fa["fits"][0]["rho_s"].as_f64().is_some(), "{fa}");
    // A TDMS table on a `Time` channel, a -v7 (compressed) MAT table on the
    // variable `t`, and a -v6 MAT of row vectors with rate_hz in the map
    // and numbers in the `rig` struct.
    for copy in ["synth_table.tdms", "synth_table_v7.mat", "synth_rate.mat"] {
        let p = data(&format!("formats/{copy}"));
        assert_same(&a, &ingest(&p, &[]), 1e-9, NOT_COMPARED, copy);
        assert_same(&fa, &fit(&p), 1e-9, NOT_COMPARED, copy);
    }
}

#[test]
fn waveform_copy_with_jitter_and_lost_buffers_fits_within_one_percent() {
    // char_N2.2.mcap has ±3 µs buffer jitter and lost buffers; its TDMS copy
    // holds single-float waveforms on the nominal grid, lost buffers NaN.
    let (fa, fb) = (
        fit(&data("char_N2.2.mcap")),
        fit(&data("formats/char_N2.2_wf.tdms")),
    );
    let (a, b) = (&fa["fits"][0], &fb["fits"][0]);
    assert_eq!(a["law"], b["law"]);
    for k in ["rho_s", "rho_d", "r_s_n", "r_d_n", "drive_amplitude_m"] {
        let (x, y) = (a[k].as_f64().expect(k), b[k].as_f64().expect(k));
        assert!(
            ((x - y) / x).abs() < 0.01,
            "{k}: mcap {x}, tdms {y} ({:.3} %)",
            100.0 * (y / x - 1.0)
        );
    }
    let run = ingest(&data("formats/char_N2.2_wf.tdms"), &[]);
    assert!(
        run["gaps"].as_array().is_some_and(|g| !g.is_empty()),
        "the NaN-filled lost buffers are gaps"
    );
}

#[test]
fn map_given_with_option_and_unit_strings() {
    // --map is honoured for TDMS (no warning that it is ignored).
    let dir = tempfile::tempdir().expect("tempdir");
    let tdms = dir.path().join("log.tdms");
    std::fs::copy(data("formats/synth_wf.tdms"), &tdms).expect("copy");
    let map = data("formats/synth_wf.map.toml");
    let run = ingest(&tdms, &["--map", map.to_str().expect("utf-8")]);
    assert!(
        run["warnings"]
            .as_array()
            .is_some_and(|w| w.iter().all(|w| !w.to_string().contains("--map"))),
        "{}",
        run["warnings"]
    );
    // A scale in the map overrides unit_string; an explicit scale of 1000
    // puts the drive out of the plausible range and is refused.
    let text = std::fs::read_to_string(&map).expect("map");
    let bad = text.replace(
        "x0 = { name = \"Drive/position\" }",
        "x0 = { name = \"Drive/position\", scale = 1000.0 }",
    );
    assert_ne!(bad, text);
    let mp = dir.path().join("log.map.toml");
    std::fs::write(&mp, bad).expect("map");
    let out = bin()
        .arg("ingest")
        .arg(&tdms)
        .arg("--json")
        .output()
        .expect("runs");
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("log.map.toml") && err.contains("x0"), "{err}");
}

fn refused(log: &Path, extra: &[&str], needles: &[&str]) {
    let out = bin()
        .arg("ingest")
        .arg(log)
        .args(extra)
        .arg("--json")
        .output()
        .expect("runs");
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{}: {err}", log.display());
    assert!(out.stdout.is_empty() || !String::from_utf8_lossy(&out.stdout).contains("panicked"));
    let lines: Vec<&str> = err.lines().filter(|l| !l.trim().is_empty()).collect();
    assert_eq!(lines.len(), 1, "one line: {err}");
    assert!(lines[0].starts_with("error: "), "{err}");
    for n in needles {
        assert!(lines[0].contains(n), "{n:?} not in: {err}");
    }
}

#[test]
fn broken_tdms_and_mat_files_give_one_error_line() {
    for (name, needles) in [
        ("tdms_truncated.tdms", &["truncated", "segment 1"][..]),
        ("tdms_big_endian.tdms", &["big-endian", "little-endian"]),
        ("tdms_daqmx.tdms", &["DAQmx raw data"]),
        ("tdms_corrupt_length.tdms", &["corrupt", "2147483648 bytes"]),
        (
            "tdms_no_map.tdms",
            &["no channel map", "tdms_no_map.map.toml"],
        ),
        ("mat_truncated.mat", &["truncated", "byte"]),
        ("mat_corrupt_length.mat", &["corrupt", "2147483648 bytes"]),
        ("mat_no_map.mat", &["no channel map", "mat_no_map.map.toml"]),
        (
            "mat_wrong_type.mat",
            &["log_x1", "char array", "not a numeric vector"],
        ),
        ("mat_v73.mat", &["-v7.3", "HDF5", "'-v7'"]),
    ] {
        let p = data(&format!("broken/{name}"));
        let mut n = needles.to_vec();
        n.push(name);
        refused(&p, &[], &n);
    }
}

#[test]
fn maps_that_do_not_fit_the_format_are_refused() {
    let dir = tempfile::tempdir().expect("tempdir");
    // A table TDMS without `time` in its map.
    let tdms = dir.path().join("t.tdms");
    std::fs::copy(data("formats/synth_table.tdms"), &tdms).expect("copy");
    let map = std::fs::read_to_string(data("formats/synth_table.map.toml")).expect("map");
    let no_time: String = map
        .lines()
        .filter(|l| !l.starts_with("time"))
        .map(|l| format!("{l}\n"))
        .collect();
    std::fs::write(dir.path().join("t.map.toml"), &no_time).expect("map");
    refused(&tdms, &[], &["t.map.toml", "`time`", "Table/X0"]);
    // rate_hz is for MAT variables only.
    let with_rate = map.replace(
        "name = \"Table/X1\"",
        "name = \"Table/X1\", rate_hz = 1000.0",
    );
    std::fs::write(dir.path().join("t.map.toml"), with_rate).expect("map");
    refused(&tdms, &[], &["rate_hz", "MAT variables only"]);
    // A MAT map without `time` where a variable has no rate_hz.
    let mat = dir.path().join("m.mat");
    std::fs::copy(data("formats/synth_rate.mat"), &mat).expect("copy");
    let rate = std::fs::read_to_string(data("formats/synth_rate.map.toml")).expect("map");
    let one_without = rate.replace(
        "x1 = { name = \"x1\", rate_hz = 1000.0, t0_s = 0.0 }",
        "x1 = { name = \"x1\" }",
    );
    assert_ne!(one_without, rate);
    std::fs::write(dir.path().join("m.map.toml"), one_without).expect("map");
    refused(&mat, &[], &["m.map.toml", "`time`", "rate_hz"]);
    // A mapped channel that is not in the file.
    let missing = map.replace("Table/X2", "Table/nope");
    std::fs::write(dir.path().join("t.map.toml"), missing).expect("map");
    refused(
        &tdms,
        &[],
        &["\"Table/nope\"", "not in the TDMS file", "Table/X2"],
    );
}
