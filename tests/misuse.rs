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

/// 60 curves (for a family over the memory budget).
const RHO60: &str = "0.3,0.3,0.3,0.3,0.3,0.3,0.3,0.3,0.3,0.3,0.3,0.3,0.3,0.3,0.3,0.3,0.3,0.3,0.3,0.3,0.3,0.3,0.3,0.3,0.3,0.3,0.3,0.3,0.3,0.3,0.3,0.3,0.3,0.3,0.3,0.3,0.3,0.3,0.3,0.3,0.3,0.3,0.3,0.3,0.3,0.3,0.3,0.3,0.3,0.3,0.3,0.3,0.3,0.3,0.3,0.3,0.3,0.3,0.3,0.3";
/// A 256-byte output name (one byte over NAME_MAX).
const NAME256: &str = "aaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaa.csv";

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
        // Issue 33: fit parts and saved fits.
        Case {
            name: "fit --shard 0/8 (a job array numbered from 0)",
            inputs: &[CHAR],
            setup: &[],
            args: &["fit", CHAR, "--shard", "0/8", "--out", "p.json"],
            code: 1,
            says: "K is 1-based",
        },
        Case {
            name: "merge of a fits file that is not a part",
            inputs: &[],
            setup: &[("file:{\"fits\": []}", "p.json")],
            args: &["merge", "p.json", "--out", "m.json"],
            code: 1,
            says: "not a fit part written by `stickslip fit --shard K/N --out`",
        },
        Case {
            name: "merge of one of two fit shards",
            inputs: &[],
            setup: &[("file:{\"shard\": 1, \"shards\": 2, \"log_sha256s\": [], \"fits\": []}", "p1.json")],
            args: &["merge", "p1.json", "--out", "m.json"],
            code: 1,
            says: "1 of 2 missing (2/2)",
        },
        Case {
            name: "merge of fit parts of different log lists",
            inputs: &[],
            setup: &[
                ("file:{\"shard\": 1, \"shards\": 2, \"log_sha256s\": [], \"fits\": []}", "p1.json"),
                ("file:{\"shard\": 2, \"shards\": 2, \"log_sha256s\": [null], \"fits\": []}", "p2.json"),
            ],
            args: &["merge", "p1.json", "p2.json", "--out", "m.json"],
            code: 1,
            says: "different log lists",
        },
        Case {
            name: "merge of an edited fit part (a record left out)",
            inputs: &[],
            setup: &[("file:{\"shard\": 1, \"shards\": 1, \"log_sha256s\": [null], \"fits\": []}", "p1.json")],
            args: &["merge", "p1.json", "--out", "m.json"],
            code: 1,
            says: "an edited part?",
        },
        Case {
            name: "merge of a fit part with a sweep table",
            inputs: &[],
            setup: &[("file:{}", "p1.json"), ("file:x", "p2.csv")],
            args: &["merge", "p1.json", "p2.csv", "--out", "m.csv"],
            code: 1,
            says: "not both",
        },
        Case {
            name: "batch --fits of one shard",
            inputs: &[],
            setup: &[("file:{\"shard\": 1, \"shards\": 2, \"log_sha256s\": [], \"fits\": []}", "p1.json")],
            args: &["batch", "--fits", "p1.json", "--out", "b.json"],
            code: 1,
            says: "merge every shard first",
        },
        Case {
            name: "batch --fits of a record without artifact (a batch output)",
            inputs: &[],
            setup: &[("file:{\"fits\": [{\"log\": \"a.mcap\", \"log_sha256\": \"0000000000000000000000000000000000000000000000000000000000000000\"}]}", "f.json")],
            args: &["batch", "--fits", "f.json", "--out", "b.json"],
            code: 1,
            says: "has no `artifact`",
        },
        Case {
            name: "validate --fit of another artifact format",
            inputs: &[SWEEP],
            setup: &[("file:{\"fits\": [{\"log\": \"a.mcap\", \"log_sha256\": \"0000000000000000000000000000000000000000000000000000000000000000\", \"artifact\": {\"format\": 2}}]}", "f.json")],
            args: &["validate", "--fit", "f.json", "--sweep", SWEEP, "--out", "v.json"],
            code: 1,
            says: "artifact format 2",
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
        // Issue 29: a user's data lost or overwritten.
        Case {
            name: "run --report whose index.html links to a user's file",
            inputs: &[CHAR],
            setup: &[
                ("file:fit = [\"char_N4.mcap\"]\n", "plan.toml"),
                ("file:mine", "user.txt"),
                ("dir", "rep"),
                ("symlink:user.txt", "rep/index.html"),
            ],
            args: &["run", "plan.toml", "--report", "rep"],
            code: 1,
            says: "symlink inside the report directory",
        },
        Case {
            name: "validate --report whose index.html links to an input",
            inputs: &[CHAR, SWEEP],
            setup: &[("dir", "rep"), ("symlink:char_N4.mcap", "rep/index.html")],
            args: &["validate", "--characteristic", CHAR, "--sweep", SWEEP, "--samples", "0", "--report", "rep"],
            code: 1,
            says: "symlink inside the report directory",
        },
        Case {
            name: "sweep --out onto an existing rig log (no --force)",
            inputs: &[CSV],
            setup: &[],
            args: &["sweep", "--points", "5", "--rho-s", "0.3", "--out", CSV],
            code: 1,
            says: "not a sweep table",
        },
        // Issue 29: crashes on sizes claimed by headers and flags.
        Case {
            name: "merge of a part claiming shard 1 of 10^12",
            inputs: &[],
            setup: &[("file:# stickslip sweep table: shard=1/1000000000000 curves=1 points=1\ncurve,point\n0,0\n", "p.csv")],
            args: &["merge", "p.csv", "--out", "m.csv"],
            code: 1,
            says: "shards",
        },
        Case {
            name: "merge of a part claiming 4294967297 curves",
            inputs: &[],
            setup: &[("file:# stickslip sweep table: shard=1/1 curves=4294967297 points=1\ncurve,point\n0,0\n", "p.csv")],
            args: &["merge", "p.csv", "--out", "m.csv"],
            code: 1,
            says: "steady states",
        },
        Case {
            name: "sweep --shard 1/18446744073709551615",
            inputs: &[],
            setup: &[],
            args: &["sweep", "--points", "5", "--rho-s", "0.3", "--shard", "1/18446744073709551615"],
            code: 1,
            says: "shards",
        },
        Case {
            name: "sweep --shard -1/4 reaches the shard check",
            inputs: &[],
            setup: &[],
            args: &["sweep", "--points", "5", "--rho-s", "0.3", "--shard", "-1/4"],
            code: 1,
            says: "K/N",
        },
        Case {
            name: "sweep of 60 curves x 100000 points (over the memory budget)",
            inputs: &[],
            setup: &[],
            args: &["sweep", "--points", "100000", "--rho-s", RHO60],
            code: 1,
            says: "steady states",
        },
        Case {
            name: "run with a plan whose sweep is also a batch log (was a panic)",
            inputs: &[CHAR],
            setup: &[(
                "file:batch = [\"char_N4.mcap\"]\n[[validate]]\ncharacteristic = \"char_N4.mcap\"\nsweep = \"char_N4.mcap\"\n",
                "plan.toml",
            )],
            args: &["run", "plan.toml"],
            code: 1,
            says: "fitted or predicted, not both",
        },
        Case {
            name: "a plan of 10000 entries",
            inputs: &[],
            setup: &[("plan10000", "plan.toml")],
            args: &["run", "plan.toml"],
            code: 1,
            says: "entries",
        },
        // Issue 29: hangs and runaway memory.
        Case {
            name: "run with a plan that is a FIFO",
            inputs: &[],
            setup: &[("fifo", "plan.toml")],
            args: &["run", "plan.toml"],
            code: 1,
            says: "FIFO",
        },
        Case {
            name: "run with a plan that is a device",
            inputs: &[],
            setup: &[("chardev", "plan.toml")],
            args: &["run", "plan.toml"],
            code: 1,
            says: "device",
        },
        Case {
            name: "ingest of a CSV whose channel map is a FIFO",
            inputs: &[CSV],
            setup: &[("fifo", "m.toml")],
            args: &["ingest", CSV, "--map", "m.toml"],
            code: 1,
            says: "FIFO",
        },
        Case {
            name: "ingest of a CSV whose channel map is a device",
            inputs: &[CSV],
            setup: &[("chardev", "m.toml")],
            args: &["ingest", CSV, "--map", "m.toml"],
            code: 1,
            says: "device",
        },
        Case {
            name: "ingest of a CSV padded (sparsely) to 2 GB: refused at the padding's first MB",
            inputs: &[MAP],
            setup: &[("sparse:char_N2.2.csv|2000000000", "big.csv"), ("symlink:char_N2.2.map.toml", "big.map.toml")],
            args: &["ingest", "big.csv"],
            code: 1,
            says: "not a row of a table",
        },
        Case {
            name: "fit of a CSV of 8 million rows (empty): over the budget, refused before any column",
            inputs: &[MAP],
            setup: &[("newlines:char_N2.2.csv|8000000", "big.csv"), ("symlink:char_N2.2.map.toml", "big.map.toml")],
            args: &["fit", "big.csv"],
            code: 1,
            says: "split the log into shorter ones",
        },
        Case {
            name: "synth with K2 = 1e12 N/m",
            inputs: &[],
            setup: &[],
            args: &["synth", "--out", "a.mcap", "--k2-n-per-m", "1e12"],
            code: 1,
            says: "K1/K2",
        },
        // Issue 29: nonsense accepted.
        Case {
            name: "fit of an all-zero log",
            inputs: &[MAP],
            setup: &[("zerocsv:char_N2.2.csv", "z.csv"), ("symlink:char_N2.2.map.toml", "z.map.toml")],
            args: &["fit", "z.csv"],
            code: 1,
            says: "no signal",
        },
        Case {
            name: "batch with a negative normal force",
            inputs: &[CHAR, MAP],
            setup: &[("colset:char_N2.2.csv|Fn [N]|-2.2", "n.csv"), ("symlink:char_N2.2.map.toml", "n.map.toml")],
            args: &["batch", "--bootstrap", "0", "n.csv", CHAR],
            code: 1,
            says: "negative",
        },
        Case {
            name: "simulate --tol NaN",
            inputs: &[],
            setup: &[],
            args: sim(&["--periods", "5", "--method", "dopri", "--tol", "NaN"]),
            code: 2,
            says: "--help",
        },
        // Issue 29: names and messages.
        Case {
            name: "simulate --events with a 256-byte name: refused before the run",
            inputs: &[],
            setup: &[],
            args: sim(&["--periods", "5", "--events", NAME256]),
            code: 1,
            says: "256 bytes",
        },
        Case {
            name: "fit --gain-uncertainty -0.1 reaches the flag's check",
            inputs: &[CHAR],
            setup: &[],
            args: &["fit", CHAR, "--gain-uncertainty", "-0.1"],
            code: 2,
            says: "--help",
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

/// A file's contents, or for a large (sparse) file its length and
/// modification time: enough to see a change, without reading gigabytes.
fn contents(p: &Path) -> Vec<u8> {
    let m = std::fs::metadata(p).unwrap();
    if m.len() > 64 << 20 {
        format!("{} bytes, modified {:?}", m.len(), m.modified().ok()).into_bytes()
    } else {
        std::fs::read(p).unwrap()
    }
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
                out.insert(rel, Some(contents(&p)));
            } else {
                // FIFOs and symlinks: present, never read.
                out.insert(rel, None);
            }
        }
    }
    out
}

/// A dataset CSV log with `f(columns, fields)` applied to each data row.
fn map_rows(src: &str, f: impl Fn(&[String], &mut Vec<String>)) -> String {
    let text = std::fs::read_to_string(data(src)).unwrap();
    let mut cols: Option<Vec<String>> = None;
    let mut out = String::new();
    for line in text.lines() {
        if line.starts_with('#') {
        } else if let Some(cols) = &cols {
            let mut fields: Vec<String> = line.split(',').map(str::to_string).collect();
            f(cols, &mut fields);
            out += &fields.join(",");
            out.push('\n');
            continue;
        } else {
            cols = Some(line.split(',').map(|c| c.trim().to_string()).collect());
        }
        out += line;
        out.push('\n');
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
        } else if *kind == "plan10000" {
            let entries = vec!["\"char_N4.mcap\""; 10_000].join(", ");
            std::fs::write(&p, format!("fit = [{entries}]\n")).unwrap();
        } else if let Some(spec) = kind.strip_prefix("sparse:") {
            // SRC|N: a dataset file padded (sparsely) to N bytes.
            let (src, n) = spec.split_once('|').unwrap();
            std::fs::copy(data(src), &p).unwrap();
            let f = std::fs::OpenOptions::new().write(true).open(&p).unwrap();
            f.set_len(n.parse().unwrap()).unwrap();
        } else if let Some(spec) = kind.strip_prefix("newlines:") {
            // SRC|N: a dataset file's preamble and header, then N empty lines.
            let (src, n) = spec.split_once('|').unwrap();
            let text = std::fs::read_to_string(data(src)).unwrap();
            let head: Vec<&str> = text.lines().take_while(|l| l.starts_with('#')).collect();
            let header = text.lines().nth(head.len()).unwrap();
            let n: usize = n.parse().unwrap();
            let body = format!("{}\n{header}\n{}", head.join("\n"), "\n".repeat(n));
            std::fs::write(&p, body).unwrap();
        } else if let Some(src) = kind.strip_prefix("zerocsv:") {
            // A CSV log with every data column but time set to 0.
            std::fs::write(
                &p,
                map_rows(src, |_, f| {
                    for v in f.iter_mut().skip(1) {
                        *v = "0".into();
                    }
                }),
            )
            .unwrap();
        } else if let Some(spec) = kind.strip_prefix("colset:") {
            // SRC|COLUMN|VALUE: a CSV log with one column set to VALUE.
            let parts: Vec<&str> = spec.split('|').collect();
            let (col, val) = (parts[1].to_string(), parts[2].to_string());
            std::fs::write(
                &p,
                map_rows(parts[0], move |cols, f| {
                    let i = cols.iter().position(|c| *c == col).expect("column");
                    f[i] = val.clone();
                }),
            )
            .unwrap();
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

/// A small tmpfs mounted inside a temp directory (root only), always
/// unmounted when dropped.
struct SmallDisk {
    dir: PathBuf,
}

impl SmallDisk {
    /// Mounts `size` (e.g. "64k") at `dir`; `None` when not root or mount
    /// fails (the rows are then skipped).
    fn mount(dir: PathBuf, size: &str) -> Option<Self> {
        let root = std::process::Command::new("id")
            .arg("-u")
            .output()
            .is_ok_and(|o| String::from_utf8_lossy(&o.stdout).trim() == "0");
        if !root {
            return None;
        }
        std::fs::create_dir(&dir).unwrap();
        let ok = std::process::Command::new("mount")
            .args(["-t", "tmpfs", "-o", &format!("size={size}"), "tmpfs"])
            .arg(&dir)
            .status()
            .is_ok_and(|s| s.success());
        ok.then_some(Self { dir })
    }

    /// Fills the disk with one file, `filler`.
    fn fill(&self) {
        use std::io::Write;
        let mut f = std::fs::File::create(self.dir.join("filler")).unwrap();
        while f.write_all(&[0u8; 4096]).is_ok() {}
        let _ = f.flush();
    }
}

impl Drop for SmallDisk {
    fn drop(&mut self) {
        let _ = std::process::Command::new("umount")
            .arg("-l")
            .arg(&self.dir)
            .status();
    }
}

/// Runs the binary in `dir` with stdout to `stdout` (a file) and returns
/// the exit code and the last stderr line.
fn run_in(dir: &Path, args: &[&str], stdout: Option<&Path>) -> (Option<i32>, String) {
    let out = match stdout {
        Some(p) => Stdio::from(std::fs::File::create(p).unwrap()),
        None => Stdio::null(),
    };
    let o = bin()
        .args(args)
        .current_dir(dir)
        .stdin(Stdio::null())
        .stdout(out)
        .stderr(Stdio::piped())
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!err.contains("panicked"), "{err}");
    let last = err
        .lines()
        .rev()
        .find(|l| !l.trim().is_empty())
        .unwrap_or("");
    (o.status.code(), last.to_string())
}

/// Full-disk rows (issue 29), on a 64 kB tmpfs inside the temp directory
/// (skipped unless root): every multi-output command fails with one
/// `error:` line and leaves nothing, neither on the full disk nor beside it.
#[test]
fn full_disk_leaves_nothing_behind() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let Some(disk) = SmallDisk::mount(dir.join("fs"), "64k") else {
        eprintln!("not root (or no tmpfs): full-disk rows skipped");
        return;
    };
    let sweep = ["sweep", "--points", "5", "--rho-s", "0.3"];
    let rows: Vec<(&str, Vec<&str>, Option<&str>, bool)> = vec![
        // (name, args, stdout file, fill the disk first)
        (
            "sweep table + figure onto a full disk",
            [&sweep[..], &["--out", "fs/t.parquet", "--plot", "fs/t.svg"]].concat(),
            None,
            true,
        ),
        (
            "simulate events + trajectory: the disk fills at the second",
            [
                SIM,
                &[
                    "--periods",
                    "2000",
                    "--events",
                    "fs/e.csv",
                    "--trajectory",
                    "fs/t.csv",
                ],
            ]
            .concat(),
            None,
            false,
        ),
        (
            "synth log + truth.json onto a small disk",
            vec!["synth", "--out", "fs/a.mcap", "--duration-s", "20"],
            None,
            false,
        ),
        (
            "sweep --out beside, --json onto the full disk: the table is not written",
            [&sweep[..], &["--out", "t.csv", "--json"]].concat(),
            Some("fs/out.json"),
            true,
        ),
    ];
    let mut failures = Vec::new();
    for (name, args, stdout, fill) in rows {
        let _ = std::fs::remove_file(disk.dir.join("filler"));
        if fill {
            disk.fill();
        }
        let list = || {
            let mut v: Vec<_> = std::fs::read_dir(dir)
                .unwrap()
                .flatten()
                .map(|e| e.path())
                .collect();
            v.sort();
            v
        };
        let before = list();
        let stdout = stdout.map(|s| dir.join(s));
        let (code, last) = run_in(dir, &args, stdout.as_deref());
        let mut why = Vec::new();
        if code != Some(1) {
            why.push(format!("exit {code:?}"));
        }
        if !last.starts_with("error: ") {
            why.push(format!("last line {last:?}"));
        }
        let after = list();
        if after != before {
            why.push(format!("new files beside the disk: {after:?}"));
        }
        let on_disk: Vec<_> = std::fs::read_dir(&disk.dir)
            .unwrap()
            .flatten()
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .filter(|n| n != "filler" && n != "out.json")
            .collect();
        if !on_disk.is_empty() {
            why.push(format!("left on the disk: {on_disk:?}"));
        }
        if !why.is_empty() {
            failures.push(format!("{name}: {}", why.join("; ")));
        }
        let _ = std::fs::remove_file(disk.dir.join("out.json"));
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// SIGINT during the final renames (issue 29): the process sends itself
/// SIGINT after the k-th of the two renames of `simulate --events
/// --trajectory` (a debug-build failpoint, `STICKSLIP_FAILPOINT`, that
/// waits until the handler has recorded the signal: no timing involved)
/// and must undo both: exit 130, `error: interrupted`, the replaced events
/// file holds the user's bytes, the new trajectory is gone, no temporary
/// or backup is left. Without the failpoint the same run writes both.
#[test]
#[cfg_attr(
    not(debug_assertions),
    ignore = "the failpoint exists in debug builds only"
)]
fn sigint_during_the_final_renames_undoes_them_all() {
    let run = |dir: &Path, failpoint: Option<&str>| {
        let mut cmd = bin();
        cmd.args(SIM)
            .args([
                "--periods",
                "20",
                "--events",
                "e.csv",
                "--trajectory",
                "t.csv",
            ])
            .current_dir(dir)
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::piped());
        if let Some(f) = failpoint {
            cmd.env("STICKSLIP_FAILPOINT", f);
        }
        let out = cmd.output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr).into_owned();
        assert!(!err.contains("panicked"), "{err}");
        (out.status.code(), err)
    };
    let list = |dir: &Path| {
        let mut v: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .flatten()
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    };
    for k in ["1", "2"] {
        let tmp = tempfile::tempdir().unwrap();
        let dir = tmp.path();
        std::fs::write(dir.join("e.csv"), b"the user's events").unwrap();
        let (code, err) = run(dir, Some(&format!("interrupt-after-rename:{k}")));
        let last = err
            .lines()
            .rev()
            .find(|l| !l.trim().is_empty())
            .unwrap_or("");
        assert_eq!(code, Some(130), "after rename {k}: {err}");
        assert!(last.starts_with("error: interrupted"), "{last}");
        assert_eq!(
            std::fs::read(dir.join("e.csv")).unwrap(),
            b"the user's events",
            "after rename {k}"
        );
        assert_eq!(list(dir), ["e.csv"], "after rename {k}");
    }
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    std::fs::write(dir.join("e.csv"), b"the user's events").unwrap();
    let (code, err) = run(dir, None);
    assert_eq!(code, Some(0), "{err}");
    assert_eq!(list(dir), ["e.csv", "t.csv"]);
    assert_ne!(
        std::fs::read(dir.join("e.csv")).unwrap(),
        b"the user's events"
    );
}
