//! `stickslip sweep` and `merge` through the binary: the interface's JSON,
//! figures, and a sharded study merged back to exactly the unsharded table.

use std::process::Command;
use stickslip::report::table::read_frc;

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_stickslip"))
}

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
