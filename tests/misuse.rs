//! The command-line contract under careless and adversarial use (issue 16),
//! one row per case. Each row runs the binary in a fresh temp directory
//! holding copies of the inputs, and checks: the exit code; the last stderr
//! line is the `error:` (or clap's usage error for exit 2) and says what
//! the row expects; no new file appeared (no output, no temp file); every
//! input is byte-identical afterwards; the run ended within a generous
//! limit (a hang guard, not a speed target).

mod common;

use common::{bin, data};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Stdio;
use std::time::{Duration, Instant};

/// One misuse case.
struct Case {
    /// What the row shows.
    name: &'static str,
    /// Files copied into the temp directory first (from `datasets/`).
    inputs: &'static [&'static str],
    /// Shell-free set-up in the temp dir: (kind, name), kind one of
    /// "fifo", "chardev" (a node of the null device, 1:3, made with
    /// `mknod` inside the temp dir: never a write to `/dev`), "file:TEXT", "dir", "symlink:TARGET", "edit:SRC|OLD|NEW"
    /// (a dataset file with one text replaced), "head:SRC|N" (its first N
    /// lines).
    setup: &'static [(&'static str, &'static str)],
    /// Arguments (relative paths are inside the temp dir).
    args: &'static [&'static str],
    /// Expected exit code.
    code: i32,
    /// Text the last stderr line must contain.
    says: &'static str,
}

const CHAR: &str = "char_N4.mcap";
const CHAR2: &str = "char_N7.2.mcap";
const SWEEP: &str = "sweep_stepped_N4.mcap";
const CSV: &str = "char_N2.2.csv";
const MAP: &str = "char_N2.2.map.toml";

const SIM: &[&str] = &["simulate", "--eta", "1", "--rho-s", "0.3", "--rho-d", "0.3"];

fn cases() -> Vec<Case> {
    let sim = |extra: &'static [&'static str]| -> &'static [&'static str] {
        Box::leak([SIM, extra].concat().into_boxed_slice())
    };
    vec![
        // 1. Crashes.
        Case {
            name: "sweep --max-periods 0 (was a panic)",
            inputs: &[],
            setup: &[],
            args: &["sweep", "--points", "5", "--rho-s", "0.3", "--max-periods", "0"],
            code: 2,
            says: "--help",
        },
        Case {
            name: "validate --samples 4e9 (was a 192 GB allocation)",
            inputs: &[CHAR, SWEEP],
            setup: &[],
            args: &["validate", "--characteristic", CHAR, "--sweep", SWEEP, "--samples", "4000000000"],
            code: 2,
            says: "--help",
        },
        Case {
            name: "run --samples 4e9",
            inputs: &[],
            setup: &[("file:fit = [\"char_N4.mcap\"]\n", "plan.toml")],
            args: &["run", "plan.toml", "--samples", "4000000000"],
            code: 2,
            says: "--help",
        },
        // 2. Destroyed files.
        Case {
            name: "bench --plot over a rig log",
            inputs: &[CHAR],
            setup: &[],
            args: &["bench", "--plot", CHAR],
            code: 1,
            says: "--plot writes SVG",
        },
        Case {
            name: "bench --plot b.png (SVG only)",
            inputs: &[],
            setup: &[],
            args: &["bench", "--plot", "b.png"],
            code: 1,
            says: "--plot writes SVG",
        },
        Case {
            name: "bench with its default figure reports/bench.svg a FIFO: checked before the study",
            inputs: &[],
            setup: &[("dir", "reports"), ("fifo", "reports/bench.svg")],
            args: &["bench"],
            code: 1,
            says: "reports/bench.svg",
        },
        Case {
            name: "bench --quick --plot (no figure to draw)",
            inputs: &[],
            setup: &[],
            args: &["bench", "--quick", "--plot", "b.svg"],
            code: 2,
            says: "--help",
        },
        Case {
            name: "simulate --events to a character device",
            inputs: &[],
            setup: &[("chardev", "ev.csv")],
            args: sim(&["--periods", "10", "--events", "ev.csv"]),
            code: 1,
            says: "is a device",
        },
        Case {
            name: "ingest of a character device",
            inputs: &[],
            setup: &[("chardev", "log.mcap")],
            args: &["ingest", "log.mcap"],
            code: 1,
            says: "is a device",
        },
        Case {
            name: "simulate --events to a FIFO",
            inputs: &[],
            setup: &[("fifo", "ev.csv")],
            args: sim(&["--periods", "5", "--events", "ev.csv"]),
            code: 1,
            says: "FIFO",
        },
        Case {
            name: "simulate --trajectory to a directory",
            inputs: &[],
            setup: &[("dir", "out.csv")],
            args: sim(&["--periods", "5", "--trajectory", "out.csv"]),
            code: 1,
            says: "is a directory",
        },
        Case {
            name: "simulate --events over a symlink to a log (another kind)",
            inputs: &[CHAR],
            setup: &[("symlink:char_N4.mcap", "ev.csv")],
            args: sim(&["--periods", "5", "--events", "ev.csv"]),
            code: 1,
            says: "another kind",
        },
        Case {
            name: "simulate --events and --trajectory on one file",
            inputs: &[],
            setup: &[],
            args: sim(&["--periods", "5", "--events", "same.csv", "--trajectory", "same.csv"]),
            code: 1,
            says: "name the same file",
        },
        Case {
            name: "characteristic --out and --plot on one file",
            inputs: &[CHAR],
            setup: &[],
            args: &["characteristic", CHAR, "--out", "a.csv", "--plot", "a.csv"],
            code: 1,
            says: "--plot writes SVG",
        },
        Case {
            name: "characteristic --out c.parquet (writes CSV)",
            inputs: &[CHAR],
            setup: &[],
            args: &["characteristic", CHAR, "--out", "c.parquet"],
            code: 1,
            says: "--out writes CSV",
        },
        Case {
            name: "characteristic --plot c.png (no PNG: says what to give)",
            inputs: &[CHAR],
            setup: &[],
            args: &["characteristic", CHAR, "--plot", "c.png"],
            code: 1,
            says: "give a file name ending in .svg",
        },
        Case {
            name: "synth --out an existing log without --force",
            inputs: &[CHAR],
            setup: &[],
            args: &["synth", "--out", CHAR],
            code: 1,
            says: "without --force",
        },
        Case {
            name: "fit --out the input log",
            inputs: &[CHAR],
            setup: &[],
            args: &["fit", CHAR, "--out", CHAR],
            code: 1,
            says: "would overwrite the input",
        },
        Case {
            name: "ingest --out the input (renamed .parquet)",
            inputs: &[],
            setup: &[("file:PAR1", "in.parquet")],
            args: &["ingest", "in.parquet", "--out", "in.parquet"],
            code: 1,
            says: "overwrite the input",
        },
        Case {
            name: "fit --out DIR/ fails before the fit",
            inputs: &[CHAR],
            setup: &[],
            args: &["fit", CHAR, "--out", "nodir/"],
            code: 1,
            says: "names a directory",
        },
        Case {
            name: "fit --out in a missing directory",
            inputs: &[CHAR],
            setup: &[],
            args: &["fit", CHAR, "--out", "nodir/f.json"],
            code: 1,
            says: "does not exist",
        },
        Case {
            name: "run --report over a file",
            inputs: &[CHAR],
            setup: &[("file:fit = [\"char_N4.mcap\"]\n", "plan.toml"), ("file:x", "rep")],
            args: &["run", "plan.toml", "--report", "rep"],
            code: 1,
            says: "must be a directory",
        },
        // Inputs that are not regular files.
        Case {
            name: "ingest of a FIFO (was: file is empty)",
            inputs: &[],
            setup: &[("fifo", "log.mcap")],
            args: &["ingest", "log.mcap"],
            code: 1,
            says: "FIFO",
        },
        Case {
            name: "fit of a FIFO (would hang)",
            inputs: &[],
            setup: &[("fifo", "log.mcap")],
            args: &["fit", "log.mcap"],
            code: 1,
            says: "FIFO",
        },
        Case {
            name: "validate of a directory",
            inputs: &[SWEEP],
            setup: &[("dir", "d.mcap")],
            args: &["validate", "--characteristic", "d.mcap", "--sweep", SWEEP],
            code: 1,
            says: "is a directory",
        },
        // 3. Limits.
        Case {
            name: "simulate --periods 1e12 (over the 1e8 limit)",
            inputs: &[],
            setup: &[],
            args: sim(&["--periods", "1000000000000", "--trajectory", "t.csv"]),
            code: 2,
            says: "--help",
        },
        Case {
            name: "simulate --trajectory of 700 GB",
            inputs: &[],
            setup: &[],
            args: sim(&["--periods", "100000000", "--trajectory", "t.csv"]),
            code: 1,
            says: "--max-output-mb",
        },
        Case {
            name: "simulate --method rk4 --step 1e-9 (6e16 steps)",
            inputs: &[],
            setup: &[],
            args: sim(&["--periods", "10000000", "--method", "rk4", "--step", "1e-9"]),
            code: 1,
            says: "raise --step",
        },
        Case {
            name: "sweep --points 1e9",
            inputs: &[],
            setup: &[],
            args: &["sweep", "--points", "1000000000", "--rho-s", "0.3"],
            code: 2,
            says: "--help",
        },
        Case {
            name: "synth --duration-s 1e9",
            inputs: &[],
            setup: &[],
            args: &["synth", "--out", "y.mcap", "--duration-s", "1e9"],
            code: 1,
            says: "drive periods; the limit is 1e6",
        },
        Case {
            name: "synth --warmup-s 1e12",
            inputs: &[],
            setup: &[],
            args: &["synth", "--out", "y.mcap", "--warmup-s", "1e12"],
            code: 1,
            says: "the limit is 1e6",
        },
        Case {
            name: "synth --table-rate-hz 1e9",
            inputs: &[],
            setup: &[],
            args: &["synth", "--out", "y.csv", "--table-rate-hz", "1e9"],
            code: 1,
            says: "--table-rate-hz",
        },
        Case {
            name: "fit --bootstrap 4e9",
            inputs: &[CHAR],
            setup: &[],
            args: &["fit", CHAR, "--bootstrap", "4000000000"],
            code: 2,
            says: "--help",
        },
        Case {
            name: "validate --samples 1e7",
            inputs: &[CHAR, SWEEP],
            setup: &[],
            args: &["validate", "--characteristic", CHAR, "--sweep", SWEEP, "--samples", "10000000"],
            code: 2,
            says: "--help",
        },
        // 4. Nonsense.
        Case {
            name: "simulate --method rk4 --step 1e6 (was A1/A = 3.5e42, completed)",
            inputs: &[],
            setup: &[],
            args: sim(&["--periods", "10", "--method", "rk4", "--step", "1e6"]),
            code: 1,
            says: "unstable",
        },
        Case {
            name: "simulate --step -0.01 (was a clap error about -0)",
            inputs: &[],
            setup: &[],
            args: sim(&["--periods", "10", "--method", "rk4", "--step", "-0.01"]),
            code: 1,
            says: "step must be finite and > 0",
        },
        Case {
            name: "simulate --eta 1e308 (was: raise eta)",
            inputs: &[],
            setup: &[],
            args: &["simulate", "--eta", "1e308", "--rho-s", "0.3", "--rho-d", "0.3", "--periods", "5"],
            code: 1,
            says: "eta = 1e308",
        },
        Case {
            name: "channel map with x1 and x2 on one column",
            inputs: &[CSV],
            setup: &[(
                "file:[columns]\ntime = { name = \"t [s]\" }\nx0 = { name = \"drive [mm]\", scale = 0.001 }\nx1 = { name = \"x2 [mm]\", scale = 0.001 }\nx2 = { name = \"x2 [mm]\", scale = 0.001 }\n",
                "m.toml",
            )],
            args: &["ingest", CSV, "--map", "m.toml"],
            code: 1,
            says: "one column carries one quantity",
        },
        Case {
            name: "channel map scale = 1000 for mm (a 2.5 km drive)",
            inputs: &[CSV],
            setup: &[(
                "file:[columns]\ntime = { name = \"t [s]\" }\nx0 = { name = \"drive [mm]\", scale = 1000 }\nx1 = { name = \"x1 [mm]\", scale = 0.001 }\nx2 = { name = \"x2 [mm]\", scale = 0.001 }\n",
                "m.toml",
            )],
            args: &["ingest", CSV, "--map", "m.toml"],
            code: 1,
            says: "is the scale right",
        },
        Case {
            name: "channel map time scale 1e-300 (a 1e303 Hz rate)",
            inputs: &[CSV],
            setup: &[(
                "file:[columns]\ntime = { name = \"t [s]\", scale = 1e-300 }\nx0 = { name = \"drive [mm]\", scale = 0.001 }\nx1 = { name = \"x1 [mm]\", scale = 0.001 }\nx2 = { name = \"x2 [mm]\", scale = 0.001 }\n",
                "m.toml",
            )],
            args: &["ingest", CSV, "--map", "m.toml"],
            code: 1,
            says: "is the time scale right",
        },
        Case {
            name: "merge of a rig log CSV (was a three-line polars error)",
            inputs: &[CSV, MAP],
            setup: &[],
            args: &["merge", CSV, "--out", "m.csv"],
            code: 1,
            says: "not a sweep table",
        },
        Case {
            name: "validate across two rigs (M1 12 kg against 8.35 kg)",
            inputs: &[SWEEP, MAP],
            setup: &[("edit:char_N2.2.csv|#m1_kg,8.35|#m1_kg,12.0", CSV)],
            args: &["validate", "--characteristic", CSV, "--sweep", SWEEP, "--samples", "0"],
            code: 1,
            says: "--allow-mixed-rigs",
        },
        Case {
            name: "batch across two rigs",
            inputs: &[CHAR, MAP],
            setup: &[("edit:char_N2.2.csv|#m1_kg,8.35|#m1_kg,12.0", CSV)],
            args: &["batch", CSV, CHAR, "--out", "b.json"],
            code: 1,
            says: "--allow-mixed-rigs",
        },
        Case {
            name: "a 6-row CSV says too short (was: no drive sinusoid)",
            inputs: &[MAP],
            setup: &[("head:char_N2.2.csv|21", CSV)],
            args: &["fit", CSV],
            code: 1,
            says: "needs at least two drive periods",
        },
        Case {
            name: "fit of two logs, one corrupt: per-log entries, the last line names it",
            inputs: &[CHAR],
            setup: &[("file:not an mcap", "bad.mcap")],
            args: &["fit", CHAR, "bad.mcap", "--bootstrap", "0", "--estimate", "equation-error"],
            code: 1,
            says: "1 of 2 logs failed: bad.mcap",
        },
        // 5. Failed commands write nothing.
        Case {
            name: "batch with a sweep log: refused before any fit, nothing written",
            inputs: &[CHAR, CHAR2, SWEEP],
            setup: &[],
            args: &["batch", CHAR, CHAR2, SWEEP, "--out", "b.json", "--report", "rep"],
            code: 1,
            says: "a batch compares characteristic logs only",
        },
        Case {
            name: "batch with an unreadable log: nothing written",
            inputs: &[CHAR],
            setup: &[("file:not an mcap", "bad.mcap")],
            args: &["batch", CHAR, "bad.mcap", "--out", "b.json", "--report", "rep"],
            code: 1,
            says: "bad.mcap",
        },
        Case {
            name: "run with a missing log in the plan: nothing written",
            inputs: &[CHAR],
            setup: &[(
                "file:fit = [\"char_N4.mcap\", \"missing.mcap\"]\n",
                "plan.toml",
            )],
            args: &["run", "plan.toml", "--out", "r.json", "--report", "rep"],
            code: 1,
            says: "missing.mcap",
        },
        Case {
            name: "merge --plot x.pdf: checked before ok.parquet is written",
            inputs: &[],
            setup: &[("file:x", "p.csv")],
            args: &["merge", "p.csv", "--out", "ok.parquet", "--plot", "x.pdf"],
            code: 1,
            says: "--plot writes SVG",
        },
    ]
}

/// The files of a directory (recursively, relative names) with contents.
fn snapshot(dir: &Path) -> BTreeMap<PathBuf, Option<Vec<u8>>> {
    let mut out = BTreeMap::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap().flatten() {
            let p = e.path();
            let t = std::fs::symlink_metadata(&p).unwrap().file_type();
            let rel = p.strip_prefix(dir).unwrap().to_path_buf();
            if t.is_dir() {
                out.insert(rel, None);
                stack.push(p);
            } else if t.is_file() {
                out.insert(rel, Some(std::fs::read(&p).unwrap()));
            } else {
                // FIFOs and symlinks: present, never read.
                out.insert(rel, None);
            }
        }
    }
    out
}

fn setup(dir: &Path, c: &Case) {
    for name in c.inputs {
        std::fs::copy(data(name), dir.join(name)).unwrap();
    }
    for (kind, name) in c.setup {
        let p = dir.join(name);
        if *kind == "fifo" {
            let ok = std::process::Command::new("mkfifo")
                .arg(&p)
                .status()
                .unwrap();
            assert!(ok.success(), "mkfifo");
        } else if *kind == "chardev" {
            let ok = std::process::Command::new("mknod")
                .arg(&p)
                .args(["c", "1", "3"])
                .status()
                .unwrap();
            assert!(ok.success(), "mknod (needs root)");
        } else if *kind == "dir" {
            std::fs::create_dir(&p).unwrap();
        } else if let Some(text) = kind.strip_prefix("file:") {
            std::fs::write(&p, text).unwrap();
        } else if let Some(spec) = kind.strip_prefix("edit:") {
            // SRC|OLD|NEW: a dataset file with one text replaced.
            let parts: Vec<&str> = spec.split('|').collect();
            let text = std::fs::read_to_string(data(parts[0])).unwrap();
            assert!(text.contains(parts[1]), "{spec}");
            std::fs::write(&p, text.replacen(parts[1], parts[2], 1)).unwrap();
        } else if let Some(spec) = kind.strip_prefix("head:") {
            // SRC|N: the first N lines of a dataset file.
            let (src, n) = spec.split_once('|').unwrap();
            let text = std::fs::read_to_string(data(src)).unwrap();
            let n: usize = n.parse().unwrap();
            let head: Vec<&str> = text.lines().take(n).collect();
            std::fs::write(&p, head.join("\n") + "\n").unwrap();
        } else if let Some(target) = kind.strip_prefix("symlink:") {
            std::os::unix::fs::symlink(dir.join(target), &p).unwrap();
        } else {
            panic!("unknown set-up kind {kind}");
        }
    }
}

#[test]
fn every_misuse_case_fails_cleanly_and_writes_nothing() {
    let limit = Duration::from_secs(common::env_or("STICKSLIP_MISUSE_LIMIT_S", 300));
    let mut failures = Vec::new();
    let all = cases();
    for c in &all {
        let tmp = tempfile::tempdir().unwrap();
        let dir = tmp.path();
        setup(dir, c);
        let before = snapshot(dir);
        let t0 = Instant::now();
        let mut child = bin()
            .args(c.args)
            .current_dir(dir)
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        // Hang guard.
        let status = loop {
            if let Some(s) = child.try_wait().unwrap() {
                break Some(s);
            }
            if t0.elapsed() > limit {
                let _ = child.kill();
                break None;
            }
            std::thread::sleep(Duration::from_millis(20));
        };
        let out = child.wait_with_output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        let last = stderr
            .lines()
            .rev()
            .find(|l| !l.trim().is_empty())
            .unwrap_or("");
        let mut why = Vec::new();
        match status {
            None => why.push(format!("still running after {limit:?}")),
            Some(s) if s.code() != Some(c.code) => {
                why.push(format!("exit {:?}, expected {}", s.code(), c.code))
            }
            _ => {}
        }
        if c.code == 1 && !last.starts_with("error: ") {
            why.push(format!("last stderr line is not `error:`: {last:?}"));
        }
        if c.code == 2 && !stderr.contains("error:") {
            why.push("clap printed no error".to_string());
        }
        if !last.contains(c.says) {
            why.push(format!("last line {last:?} does not say {:?}", c.says));
        }
        if stderr.contains("panicked") {
            why.push("a panic".to_string());
        }
        let after = snapshot(dir);
        if after != before {
            let new: Vec<_> = after.keys().filter(|k| !before.contains_key(*k)).collect();
            let changed: Vec<_> = before
                .iter()
                .filter(|(k, v)| after.get(*k) != Some(*v))
                .map(|(k, _)| k)
                .collect();
            why.push(format!(
                "files changed: new {new:?}, changed/removed {changed:?}"
            ));
        }
        if !why.is_empty() {
            failures.push(format!("{}: {}", c.name, why.join("; ")));
        }
    }
    assert!(
        failures.is_empty(),
        "{} of {} misuse cases failed:\n{}",
        failures.len(),
        all.len(),
        failures.join("\n")
    );
}

/// SIGTERM during a long write removes the temporary file: nothing is left.
#[test]
fn sigterm_leaves_no_temp_file() {
    interrupted_write_leaves_nothing("-TERM");
}

/// SIGINT (Ctrl-C) likewise.
#[test]
fn sigint_leaves_no_temp_file() {
    interrupted_write_leaves_nothing("-INT");
}

/// Starts a long trajectory write, sends `signal` once the temp file
/// exists, and requires exit 130 and an empty directory.
fn interrupted_write_leaves_nothing(signal: &str) {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let child = bin()
        .args(SIM)
        .args([
            "--periods",
            "20000000",
            "--trajectory",
            "t.csv",
            "--max-output-mb",
            "1000000",
        ])
        .current_dir(dir)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Wait until the temp file exists (the run is writing).
    let t0 = Instant::now();
    loop {
        let any = std::fs::read_dir(dir).unwrap().flatten().count() > 0;
        if any || t0.elapsed() > Duration::from_secs(60) {
            break;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    std::thread::sleep(Duration::from_millis(300));
    let ok = std::process::Command::new("kill")
        .args([signal, &child.id().to_string()])
        .status()
        .unwrap();
    assert!(ok.success());
    let out = child.wait_with_output().unwrap();
    assert_eq!(
        out.status.code(),
        Some(130),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let left: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .collect();
    assert!(left.is_empty(), "left behind: {left:?}");
}
