//! Fits as artifacts (issue 33, item 2) on the public batch in `datasets/`:
//!
//! * `fit --shard K/3` of the five batch logs, the parts merged (in any
//!   order) and given to `batch --fits`: the same μ, intervals,
//!   recommendation and fit records (bit for bit, every key but wall
//!   times) as `batch` on the logs; with the logs also given, nothing is
//!   refitted and the result is the same again.
//! * A missing shard is named by `merge`; a log changed since it was fitted
//!   is refused by `batch --fits` and `validate --fit`.
//! * `validate --fit` equals `validate --characteristic`.
//!
//! The binary runs with 100 bootstrap replicates and a coarse worst-case
//! grid (as `tests/batch.rs`) so the debug build stays fast.

mod common;

use common::data;
use serde_json::Value;
use std::path::Path;
use std::process::{Command, Output};

const BATCH: [&str; 5] = [
    "char_N1.2.mcap",
    "char_N2.2.mcap",
    "char_N4.mcap",
    "char_N7.2.mcap",
    "char_N30.mcap",
];

/// Coarse batch grid, no ratio variants.
const FAST: [&str; 10] = [
    "--eta-points",
    "41",
    "--eta-fine-step",
    "0.005",
    "--no-ratio-variants",
    "--max-periods",
    "300",
    "--rho-points",
    "12",
    "--json",
];

fn stickslip(args: &[&str], dir: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_stickslip"))
        .current_dir(dir)
        .args(args)
        .output()
        .expect("runs")
}

fn ok_json(out: &Output) -> Value {
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{stderr}");
    serde_json::from_slice(&out.stdout).unwrap_or_else(|e| panic!("JSON on stdout ({e}): {stderr}"))
}

fn last_line(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr)
        .lines()
        .last()
        .unwrap_or("")
        .to_string()
}

/// Drops the wall times (`seconds` anywhere), which differ run to run.
fn without_times(v: &Value) -> Value {
    match v {
        Value::Object(m) => Value::Object(
            m.iter()
                .filter(|(k, _)| k.as_str() != "seconds" && k.as_str() != "stage_seconds")
                .map(|(k, v)| (k.clone(), without_times(v)))
                .collect(),
        ),
        Value::Array(a) => Value::Array(a.iter().map(without_times).collect()),
        v => v.clone(),
    }
}

/// Copies the batch logs into `dir` (so the test may change one).
fn copy_logs(dir: &Path) -> Vec<String> {
    BATCH
        .iter()
        .map(|n| {
            std::fs::copy(data(n), dir.join(n)).unwrap();
            n.to_string()
        })
        .collect()
}

#[test]
fn sharded_fits_merged_reuse_equals_batch_on_logs() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let logs = copy_logs(dir);
    let log_args: Vec<&str> = logs.iter().map(String::as_str).collect();
    // Three shards, in parallel as on three machines.
    let children: Vec<_> = (1..=3)
        .map(|k| {
            let mut args = vec!["fit"];
            args.extend(&log_args);
            let shard = format!("{k}/3");
            let out = format!("part-{k}.json");
            Command::new(env!("CARGO_BIN_EXE_stickslip"))
                .current_dir(dir)
                .args(&args)
                .args(["--bootstrap", "100", "--shard", &shard, "--out", &out])
                .output()
                .expect("runs")
        })
        .collect();
    for (k, c) in children.iter().enumerate() {
        assert_eq!(
            c.status.code(),
            Some(0),
            "shard {}: {}",
            k + 1,
            last_line(c)
        );
    }
    let part: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("part-2.json")).unwrap()).unwrap();
    assert_eq!(
        (part["shard"].as_u64(), part["shards"].as_u64()),
        (Some(2), Some(3))
    );
    assert_eq!(part["log_sha256s"].as_array().unwrap().len(), 5);
    assert_eq!(
        part["fits"].as_array().unwrap().len(),
        2,
        "5 logs in 3 shards: 1, 2, 2"
    );

    // A missing shard is named.
    let out = stickslip(
        &["merge", "part-3.json", "part-1.json", "--out", "fits.json"],
        dir,
    );
    assert_eq!(out.status.code(), Some(1));
    assert!(
        last_line(&out).contains("1 of 3 missing (2/3)"),
        "{}",
        last_line(&out)
    );
    assert!(
        !dir.join("fits.json").exists(),
        "a failed merge writes nothing"
    );
    // A repeated one too.
    let out = stickslip(
        &[
            "merge",
            "part-1.json",
            "part-2.json",
            "part-1.json",
            "--out",
            "fits.json",
        ],
        dir,
    );
    assert!(
        last_line(&out).contains("is shard 1/3 again"),
        "{}",
        last_line(&out)
    );

    let out = stickslip(
        &[
            "merge",
            "part-3.json",
            "part-1.json",
            "part-2.json",
            "--out",
            "fits.json",
        ],
        dir,
    );
    assert_eq!(out.status.code(), Some(0), "{}", last_line(&out));
    let merged: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("fits.json")).unwrap()).unwrap();
    let merged_logs: Vec<&str> = merged["fits"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| f["log"].as_str().unwrap())
        .collect();
    assert_eq!(merged_logs, log_args, "the records in the log list's order");
    for f in merged["fits"].as_array().unwrap() {
        assert_eq!(f["log_sha256"].as_str().unwrap().len(), 64);
        assert!(f["rig"]["m1_kg"].is_number() && f["recorded_at"].is_string());
        assert_eq!(f["artifact"]["format"], 1);
    }

    // batch on the logs, batch on the merged fits, batch on both.
    let mut args = vec!["batch", "--bootstrap", "100"];
    args.extend(&log_args);
    args.extend(FAST);
    let on_logs = ok_json(&stickslip(&args, dir));
    let mut args = vec!["batch", "--fits", "fits.json"];
    args.extend(FAST);
    let on_fits = ok_json(&stickslip(&args, dir));
    let mut args = vec!["batch", "--fits", "fits.json"];
    args.extend(&log_args);
    args.extend(FAST);
    let on_both = ok_json(&stickslip(&args, dir));
    eprintln!(
        "mu_s {} {} mu_d {} {} recommended {} N {}",
        on_fits["mu_s"],
        on_fits["mu_s_interval"],
        on_fits["mu_d"],
        on_fits["mu_d_interval"],
        on_fits["recommended_normal_force_n"],
        on_fits["recommended_normal_force_interval_n"]
    );
    for k in [
        "mu_s",
        "mu_d",
        "mu_s_interval",
        "mu_d_interval",
        "recommended_normal_force_n",
        "recommended_normal_force_interval_n",
        "recommended_rho_s",
        "worst_amplitude1",
    ] {
        assert!(!on_logs[k].is_null(), "{k}");
        assert_eq!(on_fits[k], on_logs[k], "{k}");
    }
    assert_eq!(without_times(&on_fits), without_times(&on_logs));
    assert_eq!(without_times(&on_both), without_times(&on_logs));
    // The batch's own records carry the log's identity too.
    for (f, n) in on_logs["fits"].as_array().unwrap().iter().zip(BATCH) {
        let want = stickslip::identify::artifact::sha256_file(&dir.join(n)).unwrap();
        assert_eq!(f["log_sha256"].as_str(), Some(want.as_str()));
    }

    // A log changed since it was fitted is refused, not refitted.
    std::fs::copy(data("char_N7.2.mcap"), dir.join("char_N4.mcap")).unwrap();
    let mut args = vec!["batch", "--fits", "fits.json", "char_N4.mcap"];
    args.extend(FAST);
    let out = stickslip(&args, dir);
    assert_eq!(out.status.code(), Some(1));
    assert!(
        last_line(&out)
            .contains("char_N4.mcap: differs from the file its fit in fits.json was made on"),
        "{}",
        last_line(&out)
    );
    std::fs::copy(data("sweep_stepped_N4.mcap"), dir.join("sweep.mcap")).unwrap();
    let out = stickslip(
        &[
            "validate",
            "--fit",
            "fits.json",
            "--characteristic",
            "char_N4.mcap",
            "--sweep",
            "sweep.mcap",
            "--samples",
            "0",
        ],
        dir,
    );
    assert_eq!(out.status.code(), Some(1));
    assert!(
        last_line(&out).contains("differs from the file"),
        "{}",
        last_line(&out)
    );
}

#[test]
fn validate_with_a_saved_fit_equals_validate_on_the_log() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let (char_log, sweep) = (data("char_N4.mcap"), data("sweep_stepped_N4.mcap"));
    let (c, s) = (char_log.to_str().unwrap(), sweep.to_str().unwrap());
    let fits = dir.join("f.json");
    let out = stickslip(&["fit", c, "--out", fits.to_str().unwrap()], dir);
    assert_eq!(out.status.code(), Some(0), "{}", last_line(&out));
    let common = ["--sweep", s, "--samples", "0", "--json"];
    let mut a = vec!["validate", "--characteristic", c];
    a.extend(common);
    let on_log = ok_json(&stickslip(&a, dir));
    let mut a = vec!["validate", "--fit", fits.to_str().unwrap()];
    a.extend(common);
    let on_fit = ok_json(&stickslip(&a, dir));
    assert_eq!(without_times(&on_fit), without_times(&on_log));
    // With the characteristic log named, the record is chosen by its sha256.
    let mut a = vec![
        "validate",
        "--fit",
        fits.to_str().unwrap(),
        "--characteristic",
        c,
    ];
    a.extend(common);
    assert_eq!(
        without_times(&ok_json(&stickslip(&a, dir))),
        without_times(&on_log)
    );
    // A fits file that holds no fit of the log named is refused.
    let other = data("char_N7.2.mcap");
    let mut a = vec![
        "validate",
        "--fit",
        fits.to_str().unwrap(),
        "--characteristic",
    ];
    a.push(other.to_str().unwrap());
    a.extend(common);
    let out = stickslip(&a, dir);
    assert_eq!(out.status.code(), Some(1));
    assert!(
        last_line(&out).contains("holds no fit of"),
        "{}",
        last_line(&out)
    );
}

/// A plan's `fits =`: the covered log is not refitted and `run` gives the
/// same result; a log changed since its fit is refused.
#[test]
fn a_plans_saved_fits_are_reused_and_a_changed_log_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    std::fs::copy(data("char_N4.mcap"), dir.join("a.mcap")).unwrap();
    let out = stickslip(&["fit", "a.mcap", "--out", "fits.json"], dir);
    assert_eq!(out.status.code(), Some(0), "{}", last_line(&out));
    std::fs::write(dir.join("plain.toml"), "fit = [\"a.mcap\"]\n").unwrap();
    std::fs::write(
        dir.join("reuse.toml"),
        "fit = [\"a.mcap\"]\nfits = \"fits.json\"\n",
    )
    .unwrap();
    let plain = ok_json(&stickslip(&["run", "plain.toml", "--json"], dir));
    let reuse = ok_json(&stickslip(&["run", "reuse.toml", "--json"], dir));
    let strip = |v: &Value| {
        let mut v = without_times(v);
        v.as_object_mut().unwrap().remove("plan");
        v
    };
    assert_eq!(strip(&reuse), strip(&plain));
    assert_eq!(
        reuse["fits"][0]["log_sha256"],
        plain["fits"][0]["log_sha256"]
    );
    std::fs::copy(data("char_N7.2.mcap"), dir.join("a.mcap")).unwrap();
    let out = stickslip(&["run", "reuse.toml", "--json"], dir);
    assert_eq!(out.status.code(), Some(1));
    assert!(
        last_line(&out).contains("a.mcap: differs from the file its fit in"),
        "{}",
        last_line(&out)
    );
}

/// The artifact reads back to the same fit: its record, rebuilt from the
/// saved state, is the record it was saved from (every float bit for bit).
#[test]
fn an_artifact_reads_back_to_the_same_record() {
    use stickslip::identify::artifact::{FitArtifact, FitEntry};
    let opts = stickslip::identify::IdentifyOptions {
        fit: stickslip::identify::FitOptions {
            bootstrap: 50,
            ..Default::default()
        },
        ..Default::default()
    };
    // A stuck log (NaN in its law) and one that sticks and slips.
    for path in [data("char_N30.mcap"), data("char_N2.2.mcap")] {
        let run = stickslip::ingest::read(&path, &Default::default()).unwrap();
        let fit = stickslip::identify::fit_log(&run, &opts).unwrap();
        let a = FitArtifact {
            log: path.clone(),
            log_sha256: stickslip::identify::artifact::sha256_file(&path).unwrap(),
            rig: run.rig.clone(),
            fit,
        };
        let rec = a.to_record().unwrap();
        let text = serde_json::to_string(&rec).unwrap();
        let back =
            match stickslip::identify::artifact::entry_of(&serde_json::from_str(&text).unwrap()) {
                Ok(FitEntry::Fitted(b)) => b,
                other => panic!("{other:?}"),
            };
        assert_eq!(back.rig, a.rig);
        assert_eq!(back.to_record().unwrap(), rec, "{}", path.display());
        // Every float of the state (Debug prints the shortest text that
        // reads back to the same float; NaN as NaN).
        let bits = |x: &FitArtifact| format!("{:?}", x.fit);
        assert_eq!(bits(&back), bits(&a));
    }
}
