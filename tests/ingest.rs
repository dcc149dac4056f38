//! Integration tests of the ingest stage on the public rig logs in
//! `datasets/` (copied from the shared data set; `truth.json` holds the
//! ground truth of every file). The CLI is exercised through the built
//! binary; numeric comparisons use the library's `ingest::read`.

mod common;

use common::{data, f, truth};
use serde_json::Value;
use std::path::Path;
use std::process::Command;
use stickslip::ingest::{self, IngestOptions, Quantity, Run};

fn entry(file: &str) -> &'static Value {
    &truth()["files"][file]
}

fn u(v: &Value) -> usize {
    v.as_u64().unwrap_or_else(|| panic!("not an integer: {v}")) as usize
}

fn stickslip(args: &[&std::ffi::OsStr]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_stickslip"))
        .args(args)
        .output()
        .expect("run stickslip")
}

/// Runs `stickslip ingest PATH [extra] --json`, asserts success, returns the JSON.
fn ingest_json(path: &Path, extra: &[&str]) -> Value {
    let mut args: Vec<&std::ffi::OsStr> = vec!["ingest".as_ref(), path.as_os_str()];
    args.extend(extra.iter().map(|a| std::ffi::OsStr::new(*a)));
    args.push("--json".as_ref());
    let out = stickslip(&args);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{} failed: {stderr}", path.display());
    let stdout = String::from_utf8(out.stdout).expect("utf-8 stdout");
    assert_eq!(
        stdout.trim().lines().count(),
        1,
        "one JSON object: {stdout}"
    );
    serde_json::from_str(stdout.trim()).expect("stdout is JSON")
}

/// Runs `stickslip ingest PATH [extra]`, asserts exit 1 and exactly one
/// `error:` line on stderr; returns that line.
fn ingest_error(path: &Path, extra: &[&str]) -> String {
    let mut args: Vec<&std::ffi::OsStr> = vec!["ingest".as_ref(), path.as_os_str()];
    args.extend(extra.iter().map(|a| std::ffi::OsStr::new(*a)));
    let out = stickslip(&args);
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(1), "{}: {stderr}", path.display());
    assert!(out.stdout.is_empty(), "nothing on stdout on error");
    let lines: Vec<&str> = stderr.lines().collect();
    assert_eq!(lines.len(), 1, "exactly one stderr line: {stderr:?}");
    assert!(lines[0].starts_with("error: "), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    lines[0].to_string()
}

fn quantity_of_topic(topic: &str) -> &'static str {
    match topic {
        "/drive/position" => "x0",
        "/mass1/position" => "x1",
        "/mass2/position" => "x2",
        "/mass2/velocity" => "v2",
        "/mass2/acceleration" => "a2",
        "/friction/normal_force" => "normal_force",
        other => panic!("unexpected topic {other}"),
    }
}

fn public_mcaps() -> Vec<&'static str> {
    let files = truth()["files"].as_object().expect("files");
    let list: Vec<&str> = files
        .iter()
        .filter(|(name, e)| e["test"] != "broken" && name.ends_with(".mcap"))
        .map(|(name, _)| name.as_str())
        .collect();
    assert!(list.len() >= 10, "the public set has its MCAP logs");
    list
}

#[test]
fn every_public_mcap_log_ingests_with_the_recorded_channels() {
    for file in public_mcaps() {
        let e = entry(file);
        let j = ingest_json(&data(file), &[]);
        assert_eq!(j["test"], e["test"], "{file}");
        // Rig metadata: numbers as numbers, equal to the record written.
        let meta = &e["metadata"];
        for key in ["m1_kg", "m2_kg", "k1_n_per_m", "k2_n_per_m", "d_n_s_per_m"] {
            let written: f64 = meta[key].as_str().expect("string").parse().expect("number");
            assert_eq!(f(&j["rig"][key]), written, "{file} {key}");
        }
        assert!(
            (f(&j["rig"]["m"]) - f(&e["rig"]["m"])).abs() < 1e-9,
            "{file}"
        );
        assert!(
            (f(&j["rig"]["k"]) - f(&e["rig"]["k"])).abs() < 1e-9,
            "{file}"
        );
        // d is written rounded to 6 digits in the record: D agrees to that.
        assert!(
            (f(&j["rig"]["D"]) - f(&e["rig"]["D"])).abs() < 1e-5,
            "{file}"
        );
        assert_eq!(
            j["rig"]["notes"], meta["notes"],
            "{file}: free text kept verbatim"
        );

        let sensors = e["sensors"].as_object().expect("sensors");
        let channels = j["channels"].as_array().expect("channels");
        assert_eq!(channels.len(), sensors.len(), "{file}: channel count");
        let gaps = j["gaps"].as_array().expect("gaps");
        for (topic, s) in sensors {
            let name = quantity_of_topic(topic);
            let c = channels
                .iter()
                .find(|c| c["name"] == name)
                .unwrap_or_else(|| panic!("{file}: no channel {name}"));
            assert_eq!(c["source"], topic.as_str());
            assert!(
                (f(&c["rate_hz"]) - f(&s["rate_hz"])).abs() < 1e-9,
                "{file} {name} rate"
            );
            let lost = u(&s["lost_buffers"]);
            let expected = u(&s["n_samples"]) - lost * u(&s["samples_per_buffer"]);
            assert_eq!(u(&c["samples"]), expected, "{file} {name} samples");
            assert_eq!(
                u(&c["dropouts"]),
                u(&s["null_samples"]),
                "{file} {name} nulls"
            );
            let missing = gaps
                .iter()
                .filter(|g| g["channel"] == name && g["kind"] == "missing")
                .count();
            if lost == 0 {
                assert_eq!(missing, 0, "{file} {name}: gaps without lost buffers");
            } else {
                // Adjacent lost buffers make one gap.
                assert!(
                    (1..=lost).contains(&missing),
                    "{file} {name}: {missing} gaps for {lost} lost buffers"
                );
            }
            // Null bursts no longer than the bridge limit are not gaps.
            if u(&s["dropout_burst_max"]) <= ingest::MAX_BRIDGE_SAMPLES {
                let dropout_gaps = gaps
                    .iter()
                    .filter(|g| g["channel"] == name && g["kind"] == "dropout")
                    .count();
                assert_eq!(dropout_gaps, 0, "{file} {name}");
            }
            let unit = c["unit"].as_str().expect("unit");
            assert_eq!(unit, s["unit"].as_str().expect("unit"), "{file} {name}");
        }
        for g in gaps {
            assert!(f(&g["end_s"]) > f(&g["start_s"]), "{file}: gap {g}");
        }
        // The canonical run covers the log: as many rows as the fastest
        // position channel has samples, less at most one buffer (if its last
        // one was lost).
        let rate = f(&j["rate_hz"]);
        let (n_fast, buffer_s) = sensors
            .iter()
            .filter(|(t, _)| t.ends_with("/position"))
            .map(|(_, s)| (u(&s["n_samples"]), f(&s["buffer_s"])))
            .max_by_key(|(n, _)| *n)
            .expect("position sensors");
        let expected = n_fast as f64 / rate;
        let jd = f(&j["duration_s"]);
        assert!(
            jd <= expected + 1.0 / rate + 1e-9 && jd >= expected - buffer_s,
            "{file}: duration {jd} vs {expected}"
        );
        assert!((u(&j["samples"]) as f64 - jd * rate).abs() < 0.5);

        let has_acc = sensors.contains_key("/mass2/acceleration");
        assert_eq!(j["has_acceleration"], has_acc, "{file}");
        let warned = j["warnings"]
            .as_array()
            .expect("warnings")
            .iter()
            .any(|w| w.as_str().is_some_and(|w| w.contains("accelerometer")));
        assert_eq!(warned, !has_acc, "{file}: missing accelerometer warned");
    }
}

#[test]
fn sweep_setpoints_are_kept() {
    for file in ["sweep_stepped_N4.mcap", "sweep_stepped_N7.2.mcap"] {
        let e = entry(file);
        let j = ingest_json(&data(file), &[]);
        assert_eq!(j["rig"]["sweep_kind"], "stepped");
        let sp = j["setpoints"].as_array().expect("setpoints");
        let steps = e["response"].as_array().expect("response");
        // One message per setpoint plus the one marking the log start.
        assert_eq!(sp.len(), steps.len() + 1, "{file}");
        for (s, step) in sp[1..].iter().zip(steps) {
            assert!((f(&s["frequency_hz"]) - f(&step["frequency_hz"])).abs() < 1e-9);
            assert!(
                (f(&s["t_s"]) - f(&step["t_setpoint_s"])).abs() < 0.01,
                "{file}: {s}"
            );
            assert!(f(&s["amplitude_m"]) > 0.0);
        }
    }
    let j = ingest_json(&data("sweep_continuous_N4.mcap"), &[]);
    assert_eq!(j["rig"]["sweep_kind"], "continuous");
    let rate = &entry("sweep_continuous_N4.mcap")["metadata"]["sweep_rate_hz_per_s"];
    let rate: f64 = rate.as_str().expect("text").parse().expect("number");
    assert_eq!(
        f(&j["rig"]["sweep_rate_hz_per_s"]),
        rate,
        "numbers as numbers"
    );
    let sp = j["setpoints"].as_array().expect("setpoints");
    let dur = f(&j["duration_s"]);
    // Published once per second.
    assert!(
        (sp.len() as f64 - dur).abs() <= 2.0,
        "{} setpoints in {dur} s",
        sp.len()
    );
    assert!(sp
        .windows(2)
        .all(|w| f(&w[1]["frequency_hz"]) >= f(&w[0]["frequency_hz"])));
}

/// Number of empty cells per column of a CSV export (independent of the reader).
fn csv_empty_cells(path: &Path) -> (Vec<String>, Vec<usize>, usize) {
    let text = std::fs::read_to_string(path).expect("csv");
    let mut lines = text.lines().skip_while(|l| l.starts_with('#'));
    let header: Vec<String> = lines
        .next()
        .expect("header")
        .split(',')
        .map(String::from)
        .collect();
    let mut empty = vec![0; header.len()];
    let mut rows = 0;
    for l in lines {
        rows += 1;
        for (i, cell) in l.split(',').enumerate() {
            if cell.trim().is_empty() {
                empty[i] += 1;
            }
        }
    }
    (header, empty, rows)
}

#[test]
fn csv_and_parquet_exports_ingest() {
    let csv = data("char_N2.2.csv");
    let j = ingest_json(&csv, &[]);
    let e = entry("char_N2.2.csv");
    assert_eq!(j["test"], e["test"]);
    let (header, empty, rows) = csv_empty_cells(&csv);
    let cols = e["columns"].as_object().expect("columns");
    let rate = f(&e["common_rate_hz"]);
    for (q, spec) in cols {
        if q == "t" {
            continue;
        }
        let c = j["channels"]
            .as_array()
            .expect("channels")
            .iter()
            .find(|c| c["name"] == q.as_str())
            .unwrap_or_else(|| panic!("csv: no channel {q}"));
        let col = header
            .iter()
            .position(|h| h == spec["name"].as_str().expect("name"))
            .expect("column in header");
        assert_eq!(u(&c["samples"]), rows, "csv {q}");
        assert_eq!(u(&c["dropouts"]), empty[col], "csv {q}");
        assert!((f(&c["rate_hz"]) - rate).abs() < 1e-6, "csv {q}");
    }
    assert_eq!(j["has_acceleration"], true);

    let pq = data("char_N2.2.parquet");
    let j = ingest_json(&pq, &[]);
    assert_eq!(j["test"], "characteristic");
    assert_eq!(j["rig"]["normal_force_n"], 2.2);
    let names: Vec<&str> = j["channels"]
        .as_array()
        .expect("channels")
        .iter()
        .map(|c| c["name"].as_str().expect("name"))
        .collect();
    assert_eq!(names, ["x0", "x1", "x2", "v2", "a2", "normal_force"]);
    assert!((f(&j["duration_s"]) - f(&entry("char_N2.2.parquet")["duration_s"])).abs() < 0.01);
}

// ---------------------------------------------------------------------------
// CSV / Parquet against the MCAP of the same simulation, within sensor errors.

/// One recording of a channel reduced to the true quantity on the rig's
/// simulation clock: x = (y − offset)/gain, t_sim = t + clock shift.
struct Corrected {
    t: Vec<f64>,
    x: Vec<f64>,
    /// Standard deviation of the corrected value's error (noise and
    /// quantisation divided by the gain).
    sigma: f64,
}

fn sensor(file: &str, key: &str) -> &'static Value {
    let s = &entry(file)["sensors"][key];
    assert!(s.is_object(), "{file}: no sensor {key}");
    s
}

fn corrected(run: &Run, q: Quantity, s: &Value, clock_shift: f64) -> Corrected {
    let c = run.channel(q).expect("channel");
    let (g, o) = (f(&s["gain"]), f(&s["offset"]));
    let sigma = (f(&s["noise"]).powi(2) + f(&s["quant"]).powi(2) / 12.0).sqrt() / g;
    Corrected {
        t: c.t.iter().map(|t| t + clock_shift).collect(),
        x: c.v.iter().map(|y| (y - o) / g).collect(),
        sigma,
    }
}

/// Residuals of `b` against `a` linearly interpolated at `b`'s times
/// (only between neighbouring valid samples of `a`).
fn residuals(a: &Corrected, b: &Corrected, dt_a: f64) -> Vec<f64> {
    let mut out = Vec::new();
    let mut j = 0;
    for (&t, &x) in b.t.iter().zip(&b.x) {
        if !x.is_finite() {
            continue;
        }
        while j + 1 < a.t.len() && a.t[j + 1] <= t {
            j += 1;
        }
        if j + 1 >= a.t.len() || a.t[j] > t {
            continue;
        }
        let (t0, t1, x0, x1) = (a.t[j], a.t[j + 1], a.x[j], a.x[j + 1]);
        if !(x0.is_finite() && x1.is_finite()) || t1 - t0 > 1.5 * dt_a {
            continue;
        }
        let xa = x0 + (t - t0) / (t1 - t0) * (x1 - x0);
        out.push(x - xa);
    }
    out
}

fn rms(v: &[f64]) -> f64 {
    (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt()
}

/// The clock shift that puts an MCAP run on the simulation clock, from the
/// first-sample offsets in truth.json (checked consistent over x1 and x2).
fn mcap_clock_shift(run: &Run, file: &str) -> f64 {
    let shifts: Vec<f64> = [
        (Quantity::X1, "/mass1/position"),
        (Quantity::X2, "/mass2/position"),
    ]
    .iter()
    .map(|(q, topic)| {
        let off = f(&sensor(file, topic)["first_sample_offset_ns"]) * 1e-9;
        off - run.channel(*q).expect("channel").t[0]
    })
    .collect();
    assert!(
        (shifts[0] - shifts[1]).abs() < 1e-5,
        "first buffers present: {shifts:?}"
    );
    shifts[0]
}

/// For a table export (row 0 at simulation time 0), the shift that maps run
/// times back to row times: x1 is unshifted in both exports.
fn table_clock_shift(run: &Run) -> f64 {
    -run.channel(Quantity::X1).expect("x1").t[0]
}

fn compare_with_mcap(table_file: &str, table: &Run) -> Vec<(Quantity, f64, f64)> {
    let mfile = "char_N2.2.mcap";
    let mrun = ingest::read(&data(mfile), &IngestOptions::default()).expect("mcap");
    let mshift = mcap_clock_shift(&mrun, mfile);
    let tshift = table_clock_shift(table);
    let mut out = Vec::new();
    for (q, topic, col) in [
        (Quantity::X0, "/drive/position", "x0"),
        (Quantity::X1, "/mass1/position", "x1"),
        (Quantity::X2, "/mass2/position", "x2"),
    ] {
        let a = corrected(&mrun, q, sensor(mfile, topic), mshift);
        let b = corrected(table, q, sensor(table_file, col), tshift);
        let dt_a = 1.0 / mrun.channel(q).expect("channel").rate_hz;
        let r = residuals(&a, &b, dt_a);
        assert!(
            r.len() > 15_000,
            "{table_file} {}: {} points compared",
            q.name(),
            r.len()
        );
        // Independent errors of the two recordings (interpolating `a`
        // between two samples only lowers its noise).
        let sigma = (a.sigma.powi(2) + b.sigma.powi(2)).sqrt();
        eprintln!(
            "{table_file} {}: rms {:.3e} m, σ {sigma:.3e} m over {} points",
            q.name(),
            rms(&r),
            r.len()
        );
        out.push((q, rms(&r), sigma));
        let mean = r.iter().sum::<f64>() / r.len() as f64;
        // The mean of n independent errors has σ/√n: allow 6 of those.
        assert!(
            mean.abs() < 6.0 * sigma / (r.len() as f64).sqrt(),
            "{table_file} {}: bias {mean:e} (σ {sigma:e})",
            q.name()
        );
    }
    out
}

/// The RMS of ~2·10^4 residuals estimates σ to about 1/√(2n) = 0.5 %;
/// 10 % covers that many times over while still catching any systematic
/// error (a gain or time error shows up at the 10⁻⁵ m level, ≥ 3σ here).
const RMS_SLACK: f64 = 1.10;

#[test]
fn csv_export_agrees_with_the_mcap_within_sensor_errors() {
    let file = "char_N2.2.csv";
    let run = ingest::read(&data(file), &IngestOptions::default()).expect("csv");
    for (q, r, sigma) in compare_with_mcap(file, &run) {
        assert!(
            r < RMS_SLACK * sigma,
            "csv {}: rms {r:e} vs σ {sigma:e}",
            q.name()
        );
    }
}

#[test]
fn parquet_export_agrees_with_the_mcap_within_sensor_errors() {
    let file = "char_N2.2.parquet";
    let run = ingest::read(&data(file), &IngestOptions::default()).expect("parquet");
    for (q, r, sigma) in compare_with_mcap(file, &run) {
        assert!(
            r < RMS_SLACK * sigma,
            "parquet {}: rms {r:e} vs σ {sigma:e}",
            q.name()
        );
    }
}

#[test]
fn csv_map_shift_is_honoured() {
    let file = "char_N2.2.csv";
    let dir = tempfile::tempdir().expect("tempdir");
    let map = std::fs::read_to_string(data("char_N2.2.map.toml")).expect("map");
    assert!(map.contains("shift_s = -0.004"));
    let unshifted = dir.path().join("noshift.map.toml");
    std::fs::write(&unshifted, map.replace(", shift_s = -0.004", "")).expect("write");
    let opts = IngestOptions {
        map: Some(unshifted.clone()),
        ..IngestOptions::default()
    };
    let plain = ingest::read(&data(file), &opts).expect("csv without shift");
    let shifted = ingest::read(&data(file), &IngestOptions::default()).expect("csv");
    // The drive samples sit 4 ms earlier than the position samples of their row.
    let gap = |r: &Run| {
        r.channel(Quantity::X1).expect("x1").t[0] - r.channel(Quantity::X0).expect("x0").t[0]
    };
    assert!((gap(&shifted) - 0.004).abs() < 1e-9);
    // Undeclared, the 4 ms is estimated from the data (M1's equation of
    // motion) and applied: within the 0.2 ms the real-lab issue asks for.
    assert!(
        (gap(&plain) - 0.004).abs() < 2e-4,
        "estimated drive shift {}",
        gap(&plain)
    );
    // Against the MCAP: with the declared shift the drive agrees within its
    // noise; with the estimated one it is far closer than without any
    // (off by the drive's motion in 4 ms, v·4 ms ≈ 0.1 mm ≫ σ).
    let with = compare_with_mcap(file, &shifted);
    let (_, r, sigma) = with[0];
    assert!(r < RMS_SLACK * sigma, "shifted x0: {r:e} vs {sigma:e}");
    let estimated = compare_with_mcap_loose(file, &plain);
    assert!(
        estimated < 10.0 * sigma,
        "estimated shift leaves x0 off by {estimated:e}"
    );
    // The CLI takes the map too.
    let j = ingest_json(&data(file), &["--map", unshifted.to_str().expect("utf-8")]);
    assert_eq!(j["test"], "characteristic");
}

/// RMS of x0 residuals of a table run against the MCAP (no assertions).
fn compare_with_mcap_loose(table_file: &str, table: &Run) -> f64 {
    let mfile = "char_N2.2.mcap";
    let mrun = ingest::read(&data(mfile), &IngestOptions::default()).expect("mcap");
    let a = corrected(
        &mrun,
        Quantity::X0,
        sensor(mfile, "/drive/position"),
        mcap_clock_shift(&mrun, mfile),
    );
    let b = corrected(
        table,
        Quantity::X0,
        sensor(table_file, "x0"),
        table_clock_shift(table),
    );
    rms(&residuals(&a, &b, 1e-3))
}

#[test]
fn out_parquet_round_trips() {
    let dir = tempfile::tempdir().expect("tempdir");
    for file in [
        "char_N4.mcap",
        "law_decreasing.mcap",
        "char_N2.2.csv",
        "sweep_stepped_N4.mcap",
    ] {
        let out = dir.path().join(format!("{file}.run.parquet"));
        let out_s = out.to_str().expect("utf-8");
        let j = ingest_json(&data(file), &["--out", out_s]);
        assert!(out.exists());
        let original = ingest::read(&data(file), &IngestOptions::default()).expect("original");
        let again = ingest::read(&out, &IngestOptions::default()).expect("round trip");
        assert_eq!(again.rig, original.rig, "{file}: metadata");
        let (a, b) = (&original.resampled, &again.resampled);
        assert_eq!(a.len(), b.len(), "{file}: rows");
        assert_eq!(u(&j["samples"]), b.len());
        assert!(
            (a.rate_hz - b.rate_hz).abs() < 1e-9 * a.rate_hz,
            "{file}: rate"
        );
        for q in Quantity::ALL {
            match (a.column(q), b.column(q)) {
                (Some(x), Some(y)) => {
                    for (i, (p, r)) in x.iter().zip(y).enumerate() {
                        assert!(
                            p == r || (p.is_nan() && r.is_nan()),
                            "{file} {} row {i}: {p} vs {r}",
                            q.name()
                        );
                    }
                }
                (None, None) => {}
                _ => panic!("{file}: column {} present on one side only", q.name()),
            }
        }
        match (&a.setpoint_hz, &b.setpoint_hz) {
            (Some(x), Some(y)) => {
                assert!(x
                    .iter()
                    .zip(y)
                    .all(|(p, r)| p == r || (p.is_nan() && r.is_nan())));
                // A table keeps the frequency in force, so setpoints that
                // repeat the previous frequency are not seen again.
                let mut changes = original.setpoints.clone();
                changes.dedup_by(|b, a| a.frequency_hz == b.frequency_hz);
                assert_eq!(again.setpoints.len(), changes.len(), "{file}");
            }
            (None, None) => {}
            _ => panic!("{file}: setpoint column on one side only"),
        }
        assert_eq!(again.has_acceleration, original.has_acceleration);
    }
}

#[test]
fn failed_out_leaves_no_file() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("run.parquet");
    let e = ingest_error(
        &data("broken/truncated.mcap"),
        &["--out", out.to_str().expect("utf-8")],
    );
    assert!(e.contains("truncated"), "{e}");
    assert_eq!(std::fs::read_dir(dir.path()).expect("dir").count(), 0);
    let e = ingest_error(&data("char_N4.mcap"), &["--out", "x.csv"]);
    assert!(e.contains("x.csv") && e.contains("Parquet"), "{e}");
}

#[test]
fn human_summary_goes_to_stderr() {
    let p = data("law_decreasing.mcap");
    let out = stickslip(&["ingest".as_ref(), p.as_os_str()]);
    assert!(out.status.success());
    assert!(out.stdout.is_empty(), "nothing on stdout without --json");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("law_decreasing.mcap") && err.contains("no accelerometer"),
        "{err}"
    );
}

// ---------------------------------------------------------------------------
// Broken inputs: exit 1, one `error:` line naming the file and the defect.

fn broken(name: &str, needles: &[&str]) {
    let line = ingest_error(&data(&format!("broken/{name}")), &[]);
    assert!(line.contains(name), "{name}: file not named: {line}");
    for n in needles {
        assert!(line.contains(n), "{name}: {n:?} not in: {line}");
    }
}

#[test]
fn broken_truncated() {
    broken("truncated.mcap", &["truncated"]);
}

#[test]
fn broken_not_mcap() {
    broken("not_mcap.mcap", &["not an MCAP"]);
}

#[test]
fn broken_no_rig_metadata() {
    broken("no_rig_metadata.mcap", &["no `rig` metadata"]);
}

#[test]
fn broken_rig_missing_k2() {
    broken("rig_missing_k2.mcap", &["k2_n_per_m", "lacks"]);
}

#[test]
fn broken_rig_mass_not_numeric() {
    broken(
        "rig_mass_not_numeric.mcap",
        &["m1_kg", "eight point three", "not a number"],
    );
}

#[test]
fn broken_rig_mass_negative() {
    broken("rig_mass_negative.mcap", &["m2_kg", "-2.0875", "positive"]);
}

#[test]
fn broken_payload_not_json() {
    broken(
        "payload_not_json.mcap",
        &["/drive/position", "log time", "not a valid message"],
    );
}

#[test]
fn broken_time_backwards() {
    broken(
        "time_backwards.mcap",
        &["non-monotonic time", "/mass1/position"],
    );
}

#[test]
fn broken_zero_messages() {
    broken("zero_messages.mcap", &["no data"]);
}

#[test]
fn broken_format_version_2() {
    broken(
        "format_version_2.mcap",
        &["unsupported format version", "stickslip-rig-log/2"],
    );
}

#[test]
fn broken_csv_map_missing_column() {
    broken(
        "csv_map_missing_column.csv",
        &["x2_pos [mm]", "not in the CSV header"],
    );
}

#[test]
fn broken_csv_garbage_number() {
    broken("csv_garbage_number.csv", &["line 135", "x1 [mm]", "1.2.7e"]);
}

#[test]
fn broken_parquet_missing_x2() {
    broken("parquet_missing_x2.parquet", &["column `x2`", "missing"]);
}

#[test]
fn every_broken_file_has_a_test() {
    let dir = data("broken");
    let tested = [
        "truncated.mcap",
        "not_mcap.mcap",
        "no_rig_metadata.mcap",
        "rig_missing_k2.mcap",
        "rig_mass_not_numeric.mcap",
        "rig_mass_negative.mcap",
        "payload_not_json.mcap",
        "time_backwards.mcap",
        "zero_messages.mcap",
        "format_version_2.mcap",
        "csv_map_missing_column.csv",
        "csv_garbage_number.csv",
        "parquet_missing_x2.parquet",
    ];
    for e in std::fs::read_dir(dir).expect("broken/") {
        let name = e.expect("entry").file_name().to_string_lossy().into_owned();
        if name.ends_with(".mcap") || name.ends_with(".csv") || name.ends_with(".parquet") {
            assert!(
                tested.contains(&name.as_str()),
                "untested broken file {name}"
            );
        }
    }
}

// ---------------------------------------------------------------------------
// More bad input, made on the fly.

#[test]
fn other_bad_inputs_give_one_error_line() {
    let dir = tempfile::tempdir().expect("tempdir");
    let p = |n: &str| dir.path().join(n);
    std::fs::write(p("empty.mcap"), b"").expect("write");
    assert!(ingest_error(&p("empty.mcap"), &[]).contains("empty"));
    std::fs::write(p("notes.txt"), b"hello").expect("write");
    assert!(ingest_error(&p("notes.txt"), &[]).contains("unknown log type"));
    assert!(ingest_error(&p("absent.mcap"), &[]).contains("absent.mcap"));
    // A map that is not TOML.
    std::fs::copy(data("char_N2.2.csv"), p("log.csv")).expect("copy");
    std::fs::write(p("log.map.toml"), b"[columns\ntime = ").expect("write");
    let e = ingest_error(&p("log.csv"), &[]);
    assert!(
        e.contains("log.map.toml") && e.contains("not a valid channel map"),
        "{e}"
    );
    // A CSV without a map.
    std::fs::remove_file(p("log.map.toml")).expect("rm");
    let e = ingest_error(&p("log.csv"), &[]);
    assert!(e.contains("no channel map"), "{e}");
    // A Parquet file that is not one.
    std::fs::write(p("fake.parquet"), b"PAR1 but not really").expect("write");
    let e = ingest_error(&p("fake.parquet"), &[]);
    assert!(e.contains("fake.parquet"), "{e}");
    // A directory.
    std::fs::create_dir(p("dir.mcap")).expect("mkdir");
    assert!(ingest_error(&p("dir.mcap"), &[]).contains("directory"));
}

#[test]
fn truncation_anywhere_is_an_error_not_a_crash() {
    let dir = tempfile::tempdir().expect("tempdir");
    for (name, ext) in [
        ("law_decreasing.mcap", "mcap"),
        ("char_N2.2.parquet", "parquet"),
    ] {
        let bytes = std::fs::read(data(name)).expect("read");
        for k in 1..8 {
            let cut = bytes.len() * k / 8;
            let p = dir.path().join(format!("cut{k}.{ext}"));
            std::fs::write(&p, &bytes[..cut]).expect("write");
            let e = ingest_error(&p, &[]);
            assert!(e.contains(&format!("cut{k}.{ext}")), "{e}");
        }
    }
}

/// The fit's sample budget reaches the MCAP and Parquet readers: a log whose position
/// channel has more samples than the caller can fit is refused with the
/// numbers as soon as that is known — from the summary's message count
/// times the first buffer's length where the file has a summary (the
/// bundled logs do), before the rest is decoded — and a budget it fits is
/// read as before.
#[test]
fn a_log_longer_than_the_fit_budget_is_refused_early() {
    let path = data("char_N4.mcap");
    let full = ingest::read(&path, &IngestOptions::default()).expect("mcap");
    let samples = full.channels.iter().map(|c| c.t.len()).max().unwrap() as u64;
    let opts = |max| IngestOptions {
        max_samples: Some(max),
        ..IngestOptions::default()
    };
    let err = ingest::read(&path, &opts(samples / 4))
        .expect_err("a quarter of the samples")
        .to_string();
    assert!(
        err.contains("announces") && err.contains("split the log into shorter ones"),
        "{err}"
    );
    let run = ingest::read(&path, &opts(samples)).expect("within the budget");
    assert_eq!(run.samples(), full.samples());
    // A Parquet table: its footer's row count, before any column.
    let path = data("char_N2.2.parquet");
    let rows = ingest::read(&path, &IngestOptions::default())
        .expect("parquet")
        .channels[0]
        .t
        .len() as u64;
    let err = ingest::read(&path, &opts(rows - 1))
        .expect_err("one row over")
        .to_string();
    assert!(
        err.contains(&format!("{rows} rows")) && err.contains("split the log into shorter ones"),
        "{err}"
    );
    ingest::read(&path, &opts(rows)).expect("within the budget");
    // TDMS (waveform and table channels) and MAT (variables with a rate,
    // compressed variables): the position channel's value count, before
    // any value is decoded or the log's channels are built.
    for (log, what) in [
        ("formats/char_N2.2_wf.tdms", "values"),
        ("formats/synth_table.tdms", "values"),
        ("formats/synth_rate.mat", "values"),
        ("formats/synth_table_v7.mat", "values"),
    ] {
        let path = data(log);
        let full = ingest::read(&path, &IngestOptions::default()).expect(log);
        let longest = [Quantity::X0, Quantity::X1, Quantity::X2]
            .iter()
            .filter_map(|&q| full.channel(q))
            .map(|c| c.t.len() as u64)
            .max()
            .unwrap();
        let err = ingest::read(&path, &opts(longest - 1))
            .expect_err("one value over")
            .to_string();
        assert!(
            err.contains(&format!("holds {longest} {what}"))
                && err.contains("split the log into shorter ones"),
            "{log}: {err}"
        );
        let run = ingest::read(&path, &opts(longest)).expect("within the budget");
        assert_eq!(run.samples(), full.samples(), "{log}");
    }
}

/// The sample count planned before a log is decoded (for memory planning
/// of parallel fits) is its common grid's, for every format: the CSV and
/// Parquet row counts, the longest TDMS channel or MAT variable exactly;
/// the MCAP summary's announcement within its lost buffers.
#[test]
fn planned_samples_match_the_grid_in_every_format() {
    let mut logs: Vec<String> = [
        "char_N4.mcap",
        "char_N2.2.csv",
        "char_N2.2.parquet",
        "law_coulomb.mcap",
        "sweep_stepped_N4.mcap",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    for f in [
        "char_N2.2_wf.tdms",
        "synth_table.tdms",
        "synth_wf.tdms",
        "synth_rate.mat",
        "synth_table_v7.mat",
        "synth_table.parquet",
    ] {
        logs.push(format!("formats/{f}"));
    }
    for log in &logs {
        let path = data(log);
        let run = ingest::read(&path, &IngestOptions::default()).expect(log);
        let planned = ingest::planned_samples(&path, &IngestOptions::default())
            .unwrap_or_else(|| panic!("{log}: no count before decoding"));
        let grid = run.samples() as u64;
        if log.ends_with(".mcap") {
            // The summary counts the buffers written: a lost one is
            // missing (char_N4: 19900 of 20000; the stepped sweep 0.3 %).
            assert!(
                planned <= grid && grid - planned <= grid / 100,
                "{log}: planned {planned}, grid {grid}"
            );
        } else {
            assert_eq!(planned, grid, "{log}");
        }
    }
    // An MCAP log without a summary section announces nothing: only a
    // lower bound is known before decoding.
    for log in ["law_stribeck.mcap", "formats/synth_wf.mcap"] {
        assert_eq!(
            ingest::planned_samples(&data(log), &IngestOptions::default()),
            None,
            "{log}"
        );
    }
    // A log that cannot be read plans nothing (its read fails as early).
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("none.mcap");
    assert_eq!(
        ingest::planned_samples(&missing, &IngestOptions::default()),
        Some(0)
    );
}
