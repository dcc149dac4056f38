//! `stickslip sweep` and `merge` through the binary: the interface's JSON,
//! figures, and a sharded study merged back to exactly the unsharded table.

mod common;

use common::bin;
use std::process::Command;
use stickslip::report::table::read_frc;

#[test]
fn json_curves_have_the_interface_keys() {
    let out = bin()
        .args([
            "sweep",
            "--rho-s",
            "0.2,0.5",
            "--points",
            "7",
            "--direction",
            "both",
            "--json",
        ])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let curves = v["curves"].as_array().unwrap();
    assert_eq!(curves.len(), 4);
    for c in curves {
        for k in [
            "rho_s",
            "rho_d",
            "slope",
            "direction",
            "eta",
            "amplitude1",
            "amplitude2",
            "steady",
        ] {
            assert!(c.get(k).is_some(), "missing {k}");
        }
        assert_eq!(c["eta"].as_array().unwrap().len(), 7);
    }
    assert!(v["seconds"].as_f64().unwrap() >= 0.0);
    assert_eq!(curves[0]["direction"], "up");
    assert_eq!(curves[1]["direction"], "down");
}

#[test]
fn sharded_study_merges_to_the_unsharded_table() {
    let dir = tempfile::tempdir().unwrap();
    let p = |n: &str| dir.path().join(n);
    let common = [
        "sweep",
        "--rho-s",
        "0,0.3,0.6",
        "--points",
        "9",
        "--direction",
        "both",
    ];
    let ok = |c: &mut Command| {
        let o = c.output().unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    };
    ok(bin().args(common).arg("--out").arg(p("all.parquet")));
    ok(bin()
        .args(common)
        .args(["--shard", "1/3", "--out"])
        .arg(p("a.parquet")));
    ok(bin()
        .args(common)
        .args(["--shard", "2/3", "--out"])
        .arg(p("b.csv")));
    ok(bin()
        .args(common)
        .args(["--shard", "3/3", "--out"])
        .arg(p("c.parquet")));
    ok(bin()
        .arg("merge")
        .arg(p("c.parquet"))
        .arg(p("a.parquet"))
        .arg(p("b.csv"))
        .arg("--out")
        .arg(p("merged.parquet"))
        .arg("--plot")
        .arg(p("merged.svg")));
    let all = read_frc(&p("all.parquet")).unwrap();
    let merged = read_frc(&p("merged.parquet")).unwrap();
    assert_eq!(all.len(), 6 * 9);
    assert_eq!(all, merged);
    // Overlapping parts are refused.
    let o = bin()
        .arg("merge")
        .arg(p("a.parquet"))
        .arg(p("a.parquet"))
        .arg("--out")
        .arg(p("x.csv"))
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1));
    assert!(!p("x.csv").exists());
}

#[test]
fn figures_and_bad_options() {
    let dir = tempfile::tempdir().unwrap();
    let svg = dir.path().join("f.svg");
    let png = dir.path().join("f.png");
    for f in [&svg, &png] {
        let o = bin()
            .args(["sweep", "--rho-s", "0.3", "--points", "5", "--plot"])
            .arg(f)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
    assert!(std::fs::read_to_string(&svg).unwrap().contains("<svg"));
    assert_eq!(&std::fs::read(&png).unwrap()[..8], b"\x89PNG\r\n\x1a\n");
    for bad in [
        vec!["--shard", "3/2"],
        vec!["--rho-s", "0.3,abc"],
        vec!["--eta-min", "0"],
        vec!["--rho-s", "0.3", "--rho-d", "0.5"],
    ] {
        let o = bin()
            .arg("sweep")
            .args(&bad)
            .args(["--points", "3"])
            .output()
            .unwrap();
        assert_eq!(o.status.code(), Some(1), "{bad:?}");
        let e = String::from_utf8_lossy(&o.stderr);
        assert!(e.starts_with("error: ") && e.lines().count() == 1, "{e}");
    }
}

/// Coexisting stable states: the paper's decreasing law (ρs 0.375,
/// D* −0.04, interrupted below ρs/2) at η = 0.29 settles to a period-1
/// orbit (A1/A 1.4005) continued upwards from η = 0.2 and to the period-3
/// orbit (A1/A 1.5648) from rest and continued downwards
/// (tests/attractor.rs). `--direction both` flags both branches there, a
/// single direction cannot, and `merge` flags them when the branches come
/// from different shards.
#[test]
fn coexisting_states_are_flagged_and_merge_finds_them_across_shards() {
    let dir = tempfile::tempdir().unwrap();
    let p = |n: &str| dir.path().join(n);
    let common = [
        "sweep",
        "--rho-s",
        "0.375",
        "--slope",
        "-0.04",
        "--stop-below",
        "0.5",
        "--eta-min",
        "0.2",
        "--eta-max",
        "0.5",
        "--points",
        "31",
        "--direction",
        "both",
    ];
    let out = bin().args(common).arg("--json").output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let flagged = |c: &serde_json::Value| -> Vec<(f64, f64)> {
        let eta = c["eta"].as_array().unwrap();
        let a1 = c["amplitude1"].as_array().unwrap();
        c["coexisting"]
            .as_array()
            .unwrap()
            .iter()
            .enumerate()
            .filter(|(_, f)| f.as_bool().unwrap())
            .map(|(i, _)| (eta[i].as_f64().unwrap(), a1[i].as_f64().unwrap()))
            .collect()
    };
    let curves = v["curves"].as_array().unwrap();
    let (up, down) = (flagged(&curves[0]), flagged(&curves[1]));
    assert_eq!(up.len(), down.len());
    let at = |c: &[(f64, f64)]| c.iter().find(|(e, _)| (e - 0.29).abs() < 1e-9).map(|x| x.1);
    let (a_up, a_down) = (at(&up).expect("η 0.29 flagged up"), at(&down).unwrap());
    assert!(
        (a_up - 1.4005).abs() < 1e-4 && (a_down - 1.5648).abs() < 1e-4,
        "{a_up} {a_down}"
    );
    assert_eq!(
        v["coexisting_points"].as_u64().unwrap() as usize,
        2 * up.len()
    );

    // One direction alone: nothing to compare with.
    let one = bin()
        .args(&common[..common.len() - 2])
        .arg("--json")
        .output()
        .unwrap();
    let v1: serde_json::Value = serde_json::from_slice(&one.stdout).unwrap();
    assert_eq!(v1["coexisting_points"], 0);

    // Shards 1/2 and 2/2 hold the up and the down curve; each alone sees no
    // other branch, the merged table flags the same points as the whole run.
    for k in [1, 2] {
        let st = bin()
            .args(common)
            .args(["--shard", &format!("{k}/2"), "--out"])
            .arg(p(&format!("part{k}.csv")))
            .status()
            .unwrap();
        assert!(st.success());
        assert!(read_frc(&p(&format!("part{k}.csv")))
            .unwrap()
            .iter()
            .all(|r| !r.coexisting));
    }
    let st = bin()
        .arg("merge")
        .arg(p("part1.csv"))
        .arg(p("part2.csv"))
        .arg("--out")
        .arg(p("all.csv"))
        .status()
        .unwrap();
    assert!(st.success());
    let merged = read_frc(&p("all.csv")).unwrap();
    let st = bin()
        .args(common)
        .arg("--out")
        .arg(p("whole.csv"))
        .status()
        .unwrap();
    assert!(st.success());
    let whole = read_frc(&p("whole.csv")).unwrap();
    let flags = |t: &[stickslip::report::table::FrcRow]| -> Vec<(u32, u32, bool)> {
        t.iter().map(|r| (r.curve, r.point, r.coexisting)).collect()
    };
    assert_eq!(flags(&merged), flags(&whole));
    assert!(merged.iter().any(|r| r.coexisting));
}

/// Each part records its shard K/N and the family's size, so `merge`
/// names a missing shard even when it held whole curves at the end of the
/// family, or nothing at all: `--shard 3/3` of 2 continuation curves is
/// empty, and without it the rows of 1/3 and 2/3 look complete. Also: a
/// shard given twice, and parts of two grids. Each refusal exits 1 and
/// writes nothing; the tables carry the metadata in CSV and Parquet alike.
#[test]
fn merge_names_missing_shards() {
    let dir = tempfile::tempdir().unwrap();
    let p = |s: &str| dir.path().join(s);
    let sweep = |points: &str, k: u32, out: &str| {
        let o = bin()
            .args(["sweep", "--rho-s", "0.3,0.4", "--points", points])
            .args(["--shard", &format!("{k}/3"), "--out"])
            .arg(p(out))
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    };
    for k in 1..=3 {
        sweep("4", k, &format!("p{k}.csv"));
        sweep("4", k, &format!("p{k}.parquet"));
    }
    sweep("5", 1, "q1.csv");
    assert_eq!(read_frc(&p("p3.csv")).unwrap().len(), 0);
    let meta = stickslip::report::table::read_table(&p("p2.parquet"))
        .unwrap()
        .meta
        .unwrap();
    assert_eq!(
        (meta.shard, meta.shards, meta.curves, meta.points),
        (2, 3, 2, 4)
    );
    let refused = |parts: &[&str], says: &str| {
        let o = bin()
            .arg("merge")
            .args(parts.iter().map(|s| p(s)))
            .arg("--out")
            .arg(p("m.csv"))
            .output()
            .unwrap();
        let e = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{parts:?}: {e}");
        assert!(e.trim_end().lines().last().unwrap().contains(says), "{e}");
        assert!(!p("m.csv").exists());
    };
    refused(&["p1.csv", "p2.csv"], "1 of 3 missing (3/3)");
    refused(&["p1.parquet", "p3.parquet"], "1 of 3 missing (2/3)");
    refused(&["p1.csv", "p2.csv", "p2.parquet"], "is shard 2/3 again");
    refused(&["q1.csv", "p2.csv", "p3.csv"], "different sweeps");
    // The whole set merges, in any order and mix of formats, to shard 1/1.
    let o = bin()
        .args(["merge", "--out"])
        .arg(p("m.csv"))
        .args(["p3.parquet", "p1.csv", "p2.parquet"].map(p))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let t = stickslip::report::table::read_table(&p("m.csv")).unwrap();
    assert_eq!(t.rows.len(), 8);
    let m = t.meta.unwrap();
    assert_eq!((m.shard, m.shards, m.curves, m.points), (1, 1, 2, 4));
}

/// A quasi-periodic point (the paper's absorber, ρs 1.004, ρd/ρs 0.8095,
/// η 0.74, from rest) stops early as `not-settling` with its amplitude
/// range; `--no-early-stop` marches the whole budget (`not-settled`).
#[test]
fn quasi_periodic_point_stops_early_unless_asked_not_to() {
    let run = |extra: &[&str]| {
        let mut args = vec![
            "sweep",
            "--rho-s",
            "1.0039651677740655",
            "--rho-d-ratio",
            "0.8095",
            "--eta-min",
            "0.74",
            "--eta-max",
            "0.74",
            "--points",
            "1",
            "--from-rest",
            "--json",
        ];
        args.extend_from_slice(extra);
        let out = bin().args(&args).output().unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        v["curves"][0].clone()
    };
    let early = run(&[]);
    assert_eq!(early["method"][0], "not-settling");
    assert_eq!(early["steady"][0], false);
    let (lo, hi) = (
        early["amplitude1_min"][0].as_f64().unwrap(),
        early["amplitude1_max"][0].as_f64().unwrap(),
    );
    assert!(0.0 < lo && lo < hi, "range [{lo}, {hi}]");
    let full = run(&["--no-early-stop", "--max-periods", "6000"]);
    assert_eq!(full["method"][0], "not-settled");
}

/// A shard that holds no curve of its family (one curve, three shards)
/// writes an empty table, an empty `curves` list and a figure with empty
/// axes; its `--plot` hung before (an infinite η axis).
#[test]
fn a_shard_without_curves_writes_an_empty_table_and_figure() {
    let dir = tempfile::tempdir().expect("tempdir");
    let (table, fig) = (dir.path().join("s.csv"), dir.path().join("s.svg"));
    let mut child = bin()
        .args([
            "sweep", "--rho-s", "0.4", "--points", "12", "--shard", "2/3", "--json",
        ])
        .arg("--out")
        .arg(&table)
        .arg("--plot")
        .arg(&fig)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("run");
    // Hang guard: a few seconds of work at most; killed after 120 s.
    let start = std::time::Instant::now();
    while child.try_wait().expect("wait").is_none() {
        if start.elapsed().as_secs() > 120 {
            child.kill().ok();
            panic!("sweep --shard 2/3 --plot hung");
        }
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
    let out = child.wait_with_output().expect("output");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let j: serde_json::Value = serde_json::from_slice(&out.stdout).expect("json");
    assert_eq!(j["curves"].as_array().map(Vec::len), Some(0), "{j}");
    assert_eq!(j["points"], 0);
    assert!(read_frc(&table).expect("table").is_empty());
    let svg = std::fs::read_to_string(&fig).expect("figure");
    assert!(
        svg.starts_with("<svg") || svg.starts_with("<?xml"),
        "{}",
        &svg[..80.min(svg.len())]
    );
}
