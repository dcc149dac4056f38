#!/usr/bin/env python3
"""Reliability sweep of issue 29: careless and adversarial use of the
`stickslip` binary, beyond the rows of tests/misuse.rs.

Each case runs the release binary in a fresh temporary directory (under
$SWEEP_TMP, default the system's) holding copies of the inputs it needs,
under `/usr/bin/time -v` (peak memory), with a hang guard. A case that
must be refused passes when: the exit code is the expected one, the last
stderr line is the `error:` (clap's usage error for exit 2) and says what
the case expects, nothing panicked, no file appeared or changed (inputs
byte-identical, no temporary left), and its peak memory is under 500 MB. A
case that must run passes when it exits 0, says what it expects on stderr
(a warning) and leaves no temporary. Full-disk cases mount a small tmpfs
inside the case's directory (root only; skipped otherwise) and always
unmount it. Nothing writes to /dev.

Usage: scripts/reliability_sweep.py [--bin target/release/stickslip]
       [--only SUBSTRING] [--tsv results.tsv]
Prints one line per case and a summary by kind; exit 1 if a case fails.
"""

import argparse
import hashlib
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DATA = os.path.join(ROOT, "datasets")
LIMIT_S = 300
MEMORY_LIMIT_KB = 500 * 1024
IS_ROOT = os.geteuid() == 0

CHAR = "char_N4.mcap"
CHAR2 = "char_N7.2.mcap"
SWEEP = "sweep_stepped_N4.mcap"
CSV = "char_N2.2.csv"
MAP = "char_N2.2.map.toml"
PQ = "char_N2.2.parquet"
SIM = ["simulate", "--eta", "1", "--rho-s", "0.3", "--rho-d", "0.3"]
FAST_SWEEP = ["sweep", "--points", "5", "--rho-s", "0.3"]
FIT = ["fit", "--bootstrap", "0", "--estimate", "equation-error"]


def case(kind, name, args, setup=(), code=1, says="", ok=False, env=None,
         check=None, stdout=None, root=False):
    return dict(kind=kind, name=name, args=list(args), setup=list(setup),
                code=0 if ok else code, says=says, ok=ok, env=env or {},
                check=check, stdout=stdout, root=root)


def csv_rows(transform):
    """The bundled CSV with `transform(fields) -> fields` applied to every
    data row (header and preamble kept)."""
    out = []
    with open(os.path.join(DATA, CSV)) as f:
        header_seen = False
        for line in f:
            if line.startswith("#"):
                out.append(line)
            elif not header_seen:
                header_seen = True
                out.append(line)
                cols = [c.strip() for c in line.strip().split(",")]
            else:
                fields = line.rstrip("\n").split(",")
                out.append(",".join(transform(cols, fields)) + "\n")
    return "".join(out)


def zero_all(cols, f):
    return [f[0]] + ["0" for _ in f[1:]]


def scale_col(name, k):
    def t(cols, f):
        i = cols.index(name)
        if f[i] not in ("", "nan", "NaN"):
            f[i] = repr(float(f[i]) * k)
        return f
    return t


def const_col(name, v):
    def t(cols, f):
        f[cols.index(name)] = v
        return f
    return t


def pre(key, value):
    """The bundled CSV with one preamble entry replaced."""
    text = open(os.path.join(DATA, CSV)).read()
    new, n = re.subn(rf"^#{key},.*$", f"#{key},{value}", text, count=1, flags=re.M)
    assert n == 1, key
    return new


def table_header(shard, curves, points):
    return (f"# stickslip sweep table: shard={shard} curves={curves} points={points}\n"
            "curve,point,m,k,damping,rho_s,rho_d,slope,v_s,stop_below,direction,eta,"
            "amplitude1,amplitude2,steady,period_multiple,stick_fraction,interrupted,"
            "method,periods,coexisting,amplitude1_min,amplitude1_max,amplitude2_min,"
            "amplitude2_max\n"
            "0,0,4,1,0.005,0.3,0.3,0,,,up,0.5,1,1,true,1,0.5,false,exact,10,false,,,,\n")


def truth_has(n):
    def check(d, out, err):
        t = json.load(open(os.path.join(d, "out", "truth.json")))
        got = len(t["files"])
        return None if got == n else f"truth.json holds {got} entries, not {n}"
    return check


def cases():
    c = []
    # --- 1. A user's data lost or overwritten -------------------------
    for cmd, extra, inputs in [
        ("run", ["plan.toml"], [("file", "plan.toml", 'fit = ["char_N4.mcap"]\n'), ("copy", CHAR)]),
        ("batch", [CHAR, CHAR2], [("copy", CHAR), ("copy", CHAR2)]),
        ("validate", ["--characteristic", CHAR, "--sweep", SWEEP], [("copy", CHAR), ("copy", SWEEP)]),
    ]:
        base = {"run": ["run"], "batch": ["batch", "--bootstrap", "0", "--eta-points", "41", "--rho-points", "8"],
                "validate": ["validate", "--samples", "0"]}[cmd]
        for target in ["user.txt", "user.html", CHAR if cmd != "validate" else "user.svg"]:
            setup = list(inputs) + [("dir", "rep"), ("file", "user.txt", "mine"), ("file", "user.html", "mine"),
                                    ("file", "user.svg", "mine"), ("symlink", "rep/index.html", target)]
            c.append(case("data loss", f"{cmd} --report whose index.html links to {target}",
                          base + extra + ["--report", "rep"], setup, says="symlink inside the report directory"))
        setup = list(inputs) + [("dir", "rep"), ("fifo", "rep/index.html")]
        c.append(case("data loss", f"{cmd} --report whose index.html is a FIFO",
                      base + extra + ["--report", "rep"], setup, says="FIFO"))
        setup = list(inputs) + [("dir", "rep"), ("dir", "rep/index.html")]
        c.append(case("data loss", f"{cmd} --report whose index.html is a directory",
                      base + extra + ["--report", "rep"], setup, says="directory"))
    # A figure of the report a symlink (checked when the figure is named;
    # nothing is written).
    c.append(case("data loss", "batch --report with its figure a symlink to a user file",
                  ["batch", "--bootstrap", "0", "--eta-points", "41", "--rho-points", "8", CHAR, CHAR2, "--report", "rep"],
                  [("copy", CHAR), ("copy", CHAR2), ("dir", "rep"), ("file", "mine.svg", "mine"),
                   ("symlink", "rep/batch.svg", "mine.svg")], says="symlink inside the report directory"))
    for log in [CHAR, PQ, CSV]:
        ext = log.rsplit(".", 1)[1]
        out = "old." + ("parquet" if ext == "parquet" else "csv")
        src = log
        c.append(case("data loss", f"sweep --out onto an existing rig log ({out} from {src})",
                      FAST_SWEEP + ["--out", out], [("copyas", src, out)], says="not a sweep table"))
        c.append(case("data loss", f"merge --out onto an existing rig log ({out})",
                      ["merge", "p.csv", "--out", out], [("file", "p.csv", table_header("1/1", 1, 1)), ("copyas", src, out)],
                      says="not a sweep table"))
    c.append(case("data loss", "sweep --out onto a rig log with --force replaces it",
                  FAST_SWEEP + ["--out", "old.csv", "--force"], [("copyas", CSV, "old.csv")], ok=True))
    c.append(case("data loss", "sweep --out onto an earlier sweep table replaces it",
                  FAST_SWEEP + ["--out", "old.csv"], [("file", "old.csv", table_header("1/1", 1, 1))], ok=True))
    for fmt in ["mcap", "csv", "parquet"]:
        c.append(case("data loss", f"synth --out over an existing .{fmt}",
                      ["synth", "--out", f"a.{fmt}", "--duration-s", "5", "--warmup-s", "1"],
                      [("file", f"a.{fmt}", "mine")], says="without --force"))
    c.append(case("data loss", "synth --out a symlink to a user file of another kind",
                  ["synth", "--out", "a.mcap", "--force"], [("file", "mine.txt", "x"), ("symlink", "a.mcap", "mine.txt")],
                  says="another kind"))
    c.append(case("data loss", "four synth runs into one folder keep all four truth entries",
                  ["__parallel_synth__"], [("dir", "out")], ok=True, check=truth_has(4)))
    c.append(case("data loss", "eight synth runs into one folder keep all eight truth entries",
                  ["__parallel_synth8__"], [("dir", "out")], ok=True, check=truth_has(8)))
    for cmd in [["fit", "--bootstrap", "0", CHAR, "--out", "o.json"],
                ["ingest", CHAR, "--out", "o.parquet"]]:
        c.append(case("data loss", f"{cmd[0]} --out onto its input",
                      [x if x != "o.json" and x != "o.parquet" else CHAR for x in cmd],
                      [("copy", CHAR)], says="overwrite the input"))
    # --- 2. Half-written results (full disk) --------------------------
    full = [("tmpfs", "fs", "64k")]
    c.append(case("half-written", "sweep --out and --plot on a full disk", FAST_SWEEP + ["--out", "fs/t.parquet", "--plot", "fs/t.svg"],
                  full + [("fill", "fs")], says="", root=True))
    c.append(case("half-written", "simulate --events and --trajectory, disk fills at the second",
                  SIM + ["--periods", "2000", "--events", "fs/e.csv", "--trajectory", "fs/t.csv"], full, says="", root=True))
    c.append(case("half-written", "synth log + truth.json on a full disk",
                  ["synth", "--out", "fs/a.mcap", "--duration-s", "20"], full, says="", root=True))
    c.append(case("half-written", "synth CSV + map + truth on a full disk",
                  ["synth", "--out", "fs/a.csv", "--duration-s", "20"], full, says="", root=True))
    c.append(case("half-written", "run --report into a full disk (directory removed again)",
                  ["run", "plan.toml", "--report", "fs/rep"], full + [("file", "plan.toml", 'fit = ["char_N4.mcap"]\n'), ("copy", CHAR)],
                  says="", root=True))
    c.append(case("half-written", "batch --out + --report, report on a full disk: --out not written",
                  ["batch", "--bootstrap", "0", "--eta-points", "41", "--rho-points", "8", CHAR, CHAR2, "--out", "b.json", "--report", "fs/rep"],
                  full + [("fill", "fs"), ("copy", CHAR), ("copy", CHAR2)], says="", root=True))
    for cmd in [SIM + ["--periods", "10"], FAST_SWEEP, ["fit", "--bootstrap", "0", CHAR], ["ingest", CHAR]]:
        c.append(case("half-written", f"{cmd[0]} --json to a full disk fails", cmd + ["--json"],
                      full + [("fill", "fs"), ("copy", CHAR)], says="stdout", stdout="fs/out.json", root=True))
    c.append(case("half-written", "sweep --out + --json to a full disk: the table is not written",
                  FAST_SWEEP + ["--out", "t.csv", "--json"], full + [("fill", "fs")], says="stdout", stdout="fs/out.json", root=True))
    c.append(case("half-written", "simulate --json to a closed pipe is fine", SIM + ["--periods", "10", "--json"],
                  [], ok=True, stdout="|closed"))
    # --- 3. Crashes: sizes claimed by headers and flags -----------------
    for shard, curves, points, says in [
        ("1/1000000000000", 1, 1, "shards"), ("1/18446744073709551615", 1, 1, "shards"),
        ("1/1", 4294967297, 1, "steady states"), ("1/1", 1, 4294967297, "steady states"),
        ("1/1", 100000, 100000, "steady states"), ("1/1", 18446744073709551615, 2, "steady states"),
        ("1/3", 1, 1, "shards"), ("0/1", 1, 1, "bad shard"), ("2/1", 1, 1, "bad shard"),
        ("1/1", -1, 1, "bad curves"), ("1/1", "1e9", 1, "bad curves"), ("x/y", 1, 1, "bad shard"),
        ("1/99999999999999999999999", 1, 1, "bad shard"), ("1/1", 5000001, 1, "steady states"),
        ("1/1", 3000, 3000, "steady states"),
    ]:
        c.append(case("crash", f"merge of a part claiming shard {shard}, {curves} curves x {points} points",
                      ["merge", "p.csv", "--out", "m.csv"], [("file", "p.csv", table_header(shard, curves, points))],
                      says=says))
    for shard, code, says in [
        ("1/18446744073709551615", 1, "shards"), ("1/1000000000000", 1, "shards"), ("-1/4", 1, "K/N"),
        ("0/4", 1, "K/N"), ("5/4", 1, "K/N"), ("1/0", 1, "K/N"), ("abc", 1, "K/N"), ("1/2/3", 1, "K/N"),
        ("1/99999999999999999999", 1, "K/N"), ("-0/4", 1, "K/N"), ("1/-4", 1, "K/N"), ("1.5/4", 1, "K/N"),
        ("1/6", 1, "shards"),
    ]:
        c.append(case("crash", f"sweep --shard {shard}", FAST_SWEEP + ["--shard", shard], code=code, says=says))
    for rhos, points in [(",".join(["0.3"] * 10000), 100000), (",".join(["0.3"] * 100), 100000),
                         (",".join(["0.3"] * 51), 100000), (",".join(["0.1"] * 5001), 1000)]:
        c.append(case("crash", f"sweep of {rhos.count(',') + 1} curves x {points} points",
                      ["sweep", "--rho-s", rhos, "--points", str(points)], says="steady states"))
    c.append(case("crash", "a plan of 10000 entries", ["run", "plan.toml"],
                  [("file", "plan.toml", "fit = [" + ", ".join(['"char_N4.mcap"'] * 10000) + "]\n"), ("copy", CHAR)],
                  says="entries"))
    c.append(case("crash", "a plan of 1001 validations", ["run", "plan.toml"],
                  [("file", "plan.toml", '[[validate]]\ncharacteristic = "a.mcap"\nsweep = "b.mcap"\n' * 1001)],
                  says="entries"))
    # --- 4. Hangs and runaway memory ------------------------------------
    for kind, extra in [("fifo", ()), ("chardev", ()), ("dir", ()), ("sparse", ("8000000",)), ("binary", ())]:
        c.append(case("hang", f"run with a plan that is a {kind}", ["run", "plan.toml"],
                      [(kind, "plan.toml") + extra], says={"fifo": "FIFO", "chardev": "device", "dir": "directory",
                                                           "sparse": "bytes", "binary": "plan"}[kind]))
        c.append(case("hang", f"ingest of a CSV whose channel map is a {kind}", ["ingest", CSV],
                      [("copyas", CSV, CSV), (kind, MAP) + extra], says={"fifo": "FIFO", "chardev": "device",
                                                                    "dir": "directory", "sparse": "bytes",
                                                                    "binary": "map"}[kind]))
        c.append(case("hang", f"ingest --map that is a {kind}", ["ingest", CSV, "--map", "m.toml"],
                      [("copy", CSV), (kind, "m.toml") + extra], says={"fifo": "FIFO", "chardev": "device",
                                                                         "dir": "directory", "sparse": "bytes",
                                                                         "binary": "map"}[kind]))
        c.append(case("hang", f"synth --sensors that is a {kind}", ["synth", "--out", "a.mcap", "--sensors", "s.json"],
                      [(kind, "s.json") + extra], says={"fifo": "FIFO", "chardev": "device", "dir": "directory",
                                                        "sparse": "bytes", "binary": "sensor"}[kind]))
    for size in ["400000000", "2000000000", "12000000000"]:
        for cmd in [["ingest"], FIT, ["characteristic"]]:
            # Streamed: the padding's first line over 1 MB is refused.
            c.append(case("hang", f"{cmd[0]} of a CSV padded to {int(size) / 1e9:g} GB", cmd + ["big.csv"],
                          [("sparse", "big.csv", size), ("copyas", MAP, "big.map.toml")], says="not a row of a table"))
    for rows in [8_000_000, 20_000_000]:
        for cmd in [["ingest"], FIT]:
            # Rows counted before any column: over the budget, refused.
            c.append(case("hang", f"{cmd[0]} of a CSV of {rows / 1e6:g} million (empty) rows", cmd + ["big.csv"],
                          [("emptyrows", "big.csv", rows), ("copyas", MAP, "big.map.toml")], says="into shorter logs" if cmd == ["ingest"] else "split the log"))
    if os.environ.get("SWEEP_LONG"):
        # Long logs (issue 29; SWEEP_LONG=1, 400 MB of disk each): a
        # two-hour 1 kHz CSV is ingested and fitted within the budget
        # (about 1 and 5 min; peaks in docs/measurements.md).
        c.append(case("hang", "ingest of a two-hour 1 kHz CSV (7.2 million rows, 380 MB)", ["ingest", "long.csv", "--json"],
                      [("tiled", "long.csv", 360)], ok=True))
        c.append(case("hang", "fit of a two-hour 1 kHz CSV: fitted within the budget", FIT + ["long.csv"],
                      [("tiled", "long.csv", 360)], ok=True))
        # A two-hour synthetic log is written (streamed synth; about 20 s,
        # 0.7-1.2 GB peak and 90-410 MB of disk each; peaks in
        # docs/measurements.md, not checked here).
        for ext in ["mcap", "csv", "parquet"]:
            c.append(case("hang", f"synth --duration-s 7200 ({ext}): a two-hour log is written",
                          ["synth", "--out", f"long.{ext}", "--duration-s", "7200"], ok=True))
    c.append(case("hang", "ingest of a CSV with a 50 MB line (error line cut)", ["ingest", "long.csv"],
                  [("longline", "long.csv", 50_000_000), ("copyas", MAP, "long.map.toml")], says=""))
    for n in ["100000", "1000000", "18446744073709551615"]:
        c.append(case("hang", f"sweep with RAYON_NUM_THREADS={n} runs, with a warning", FAST_SWEEP,
                      env={"RAYON_NUM_THREADS": n}, ok=True, says="warning: RAYON_NUM_THREADS"
                      if n != "18446744073709551615" else "warning: RAYON_NUM_THREADS"))
    c.append(case("hang", "sweep with RAYON_NUM_THREADS=2 runs without a warning", FAST_SWEEP,
                  env={"RAYON_NUM_THREADS": "2"}, ok=True))
    for k2, k1 in [("1e12", "670"), ("670", "1e12"), ("1e9", "670"), ("1e12", "1e12"), ("1e-6", "670")]:
        c.append(case("hang", f"synth with K1 = {k1}, K2 = {k2} N/m", ["synth", "--out", "a.mcap", "--k1-n-per-m", k1,
                                                                    "--k2-n-per-m", k2, "--duration-s", "5"],
                      says="stiffness"))
    # (7200 s is written since synth streams: SWEEP_LONG above; 20000 s is
    # over the memory budget by the estimate.)
    for dur, rate in [("20000", None), ("100000", None), ("1e9", None), ("60", "1e7")]:
        args = ["synth", "--out", "a.parquet", "--duration-s", dur]
        if rate:
            args += ["--table-rate-hz", rate]
        c.append(case("hang", f"synth --duration-s {dur}" + (f" --table-rate-hz {rate}" if rate else ""), args,
                      says="memory" if dur == "20000" else ""))
    # --- 5. Nonsense accepted -------------------------------------------
    c.append(case("nonsense", "an all-zero CSV log", FIT + ["z.csv"],
                  [("text", "z.csv", csv_rows(zero_all)), ("copyas", MAP, "z.map.toml")], says="no signal"))
    for col in ["drive [mm]", "x1 [mm]", "x2 [mm]"]:
        c.append(case("nonsense", f"a CSV log whose {col} is constant", ["ingest", "z.csv"],
                      [("text", "z.csv", csv_rows(const_col(col, "1.5"))), ("copyas", MAP, "z.map.toml")],
                      says="no signal"))
    for cmd in [["ingest"], FIT, ["characteristic"]]:
        c.append(case("nonsense", f"{cmd[0]} of an all-zero log", cmd + ["z.csv"],
                      [("text", "z.csv", csv_rows(zero_all)), ("copyas", MAP, "z.map.toml")], says="no signal"))
    for f in ["500", "1.80", "1.50", "3.44", "0.86"]:
        c.append(case("nonsense", f"metadata drive frequency {f} Hz, drive at 1.72 Hz: a warning", FIT + ["f.csv"],
                      [("text", "f.csv", pre("drive_frequency_hz", f)), ("copyas", MAP, "f.map.toml")],
                      ok=True, says="contradicts the measured"))
    for f in ["1.72", "1.73", "1.70"]:
        c.append(case("nonsense", f"metadata drive frequency {f} Hz within 2 %: no frequency warning", FIT + ["f.csv"],
                      [("text", "f.csv", pre("drive_frequency_hz", f)), ("copyas", MAP, "f.map.toml")],
                      ok=True, check=lambda d, o, e: "contradicts" in e and "frequency warning given" or None))
    c.append(case("nonsense", "drive amplitude 6 % off its metadata: one amplitude warning", FIT + ["f.csv"],
                  [("text", "f.csv", pre("drive_amplitude_m", "0.00265")), ("copyas", MAP, "f.map.toml")],
                  ok=True, says="differs from the nominal",
                  check=lambda d, o, e: None if e.count("differs from the nominal") == 1 and "contradicts" not in e
                  else "not exactly one amplitude warning (or a frequency warning too)"))
    for n in ["-2.2", "-0.001"]:
        c.append(case("nonsense", f"batch with a normal force of {n} N refused",
                      ["batch", "--bootstrap", "0", "--eta-points", "41", "--rho-points", "8", "n.csv", CHAR],
                      [("text", "n.csv", csv_rows(const_col("Fn [N]", n))), ("copyas", MAP, "n.map.toml"), ("copy", CHAR)],
                      says="negative"))
        c.append(case("nonsense", f"fit with a normal force of {n} N warns", FIT + ["n.csv"],
                      [("text", "n.csv", csv_rows(const_col("Fn [N]", n))), ("copyas", MAP, "n.map.toml")],
                      ok=True, says="negative"))
    c.append(case("nonsense", "fit with a zero normal force warns", FIT + ["n.csv"],
                  [("text", "n.csv", csv_rows(const_col("Fn [N]", "0"))), ("copyas", MAP, "n.map.toml")],
                  ok=True, says="normal force is zero"))
    for tol in ["NaN", "nan", "inf", "-inf", "0", "-1e-10", "1", "1e300", "-0"]:
        c.append(case("nonsense", f"simulate --tol {tol}", SIM + ["--periods", "5", "--method", "dopri", "--tol", tol],
                      code=2, says="tolerance"))
    for scale in ["1e9", "1e6", "1e-4"]:
        c.append(case("nonsense", f"CSV time column scaled by {scale}", ["ingest", "t.csv"],
                      [("copyas", CSV, "t.csv"), ("edit", "t.map.toml", MAP, 'time         = { name = "t [s]" }',
                                                 f'time         = {{ name = "t [s]", scale = {scale} }}')],
                      says="time scale"))
    # --- 6. Names -------------------------------------------------------
    for n in [200, 250, 255]:
        name = "a" * (n - 4) + ".csv"
        c.append(case("names", f"simulate --events with a {n}-byte name works", SIM + ["--periods", "5", "--events", name],
                      ok=True, check=lambda d, o, e, name=name: None if os.path.exists(os.path.join(d, name)) else "not written"))
        namej = "a" * (n - 5) + ".json"
        c.append(case("names", f"fit --out with a {n}-byte name works", ["fit", "--bootstrap", "0", CHAR, "--out", namej],
                      [("copy", CHAR)], ok=True,
                      check=lambda d, o, e, n=namej: None if os.path.exists(os.path.join(d, n)) else "not written"))
        namep = "a" * (n - 8) + ".parquet"
        c.append(case("names", f"sweep --out with a {n}-byte name works", FAST_SWEEP + ["--out", namep], ok=True,
                      check=lambda d, o, e, n=namep: None if os.path.exists(os.path.join(d, n)) else "not written"))
        names = "a" * (n - 4) + ".svg"
        c.append(case("names", f"sweep --plot with a {n}-byte name works", FAST_SWEEP + ["--plot", names], ok=True,
                      check=lambda d, o, e, n=names: None if os.path.exists(os.path.join(d, n)) else "not written"))
    for n in [256, 300]:
        c.append(case("names", f"simulate --events with a {n}-byte name refused before the run",
                      SIM + ["--periods", "5", "--events", "a" * (n - 4) + ".csv"], says="bytes"))
        c.append(case("names", f"fit --out with a {n}-byte name refused before the fit",
                      ["fit", CHAR, "--out", "a" * (n - 5) + ".json"], [("copy", CHAR)], says="bytes"))
    c.append(case("names", "synth CSV whose 252-byte name gives a 257-byte map name",
                  ["synth", "--out", "a" * 248 + ".csv", "--duration-s", "5", "--warmup-s", "1"], says="bytes"))
    c.append(case("names", "synth CSV whose 250-byte name gives a 255-byte map name works",
                  ["synth", "--out", "a" * 246 + ".csv", "--duration-s", "5", "--warmup-s", "1"], ok=True))
    c.append(case("names", "synth MCAP with a 250-byte name works",
                  ["synth", "--out", "a" * 245 + ".mcap", "--duration-s", "5", "--warmup-s", "1"], ok=True))
    # --- 7. Messages ------------------------------------------------------
    for flag, v, code, says in [
        ("--gain-uncertainty", "-0", 0, ""), ("--gain-uncertainty", "-0.1", 2, "fraction"),
        ("--gain-uncertainty", "-1e-9", 2, "fraction"), ("--gain-uncertainty", "-inf", 2, "fraction"),
        ("--bootstrap", "-1", 2, "not a whole number"),
    ]:
        cmd = ["fit", "--bootstrap", "0", CHAR, flag, v] if flag != "--bootstrap" else ["fit", CHAR, flag, v]
        c.append(case("messages", f"fit {flag} {v}", cmd, [("copy", CHAR)], code=code, ok=code == 0, says=says))
    for args, says in [
        (SIM + ["--periods", "-5"], "-5"), (SIM + ["--max-periods", "-1", "--steady"], "-1"),
        (SIM + ["--periods", "5", "--samples-per-period", "-3"], "-3"),
        (["sweep", "--points", "-4"], "not a whole number"), (["validate", "--samples", "-1", "--characteristic", "a", "--sweep", "b"], "not a whole number"),
        (["synth", "--out", "a.mcap", "--seed", "-1"], "-1"), (["run", "p.toml", "--samples", "-2"], "not a whole number"),
        (["batch", CHAR, "--eta-points", "-3"], "-3"),
    ]:
        c.append(case("messages", " ".join(args[:1] + args[-2:]), args, code=2, says=says))
    c.append(case("messages", "a 20-million-sample DAQ buffer named as such", ["ingest", "big.mcap"],
                  [("bigbuffer", "big.mcap", 20_000_000)], says="oversize DAQ buffer"))
    c.append(case("messages", "a 12-million-sample DAQ buffer named as such", ["ingest", "big.mcap"],
                  [("bigbuffer", "big.mcap", 12_000_000)], says="oversize DAQ buffer"))
    return c


def big_buffer_mcap(path, n):
    """An MCAP whose x0 channel is one buffer of n samples (written through
    the binary: synth a tiny log, then append nothing: we build the record
    by hand, uncompressed, with the mcap layout)."""
    import struct

    def rec(op, body):
        return bytes([op]) + struct.pack("<Q", len(body)) + body

    def s(x):
        b = x.encode()
        return struct.pack("<I", len(b)) + b

    def m(d):
        body = b"".join(s(k) + s(v) for k, v in d.items())
        return struct.pack("<I", len(body)) + body

    out = bytearray(b"\x89MCAP0\r\n")
    out += rec(0x01, s("") + s("stickslip-test"))
    out += rec(0x03, struct.pack("<H", 1) + s("daq_buffer") + s("jsonschema") + struct.pack("<I", 2) + b"{}")
    out += rec(0x04, struct.pack("<HH", 1, 1) + s("/x0") + s("json") + m({"unit": "m", "quantity": "x0"}))
    value = "[" + ",".join(["0.001"] * n) + "]"
    payload = ('{"t0_ns":0,"dt_ns":1000000,"value":' + value + "}").encode()
    out += rec(0x05, struct.pack("<HIQQ", 1, 0, 0, 0) + payload)
    out += rec(0x0F, b"")
    out += rec(0x02, struct.pack("<QQI", 0, 0, 0))
    out += b"\x89MCAP0\r\n"
    open(path, "wb").write(out)


def setup(d, c):
    for step in c["setup"]:
        op, name = step[0], step[1]
        p = os.path.join(d, name)
        if op == "copy":
            shutil.copy(os.path.join(DATA, name), p)
            if name.endswith(".csv"):
                shutil.copy(os.path.join(DATA, name[:-4] + ".map.toml"), os.path.join(d, name[:-4] + ".map.toml"))
        elif op == "copyas":
            shutil.copy(os.path.join(DATA, name), os.path.join(d, step[2]))
        elif op == "file" or op == "text":
            open(p, "w").write(step[2])
        elif op == "binary":
            open(p, "wb").write(os.urandom(4096))
        elif op == "dir":
            os.mkdir(p)
        elif op == "fifo":
            os.mkfifo(p)
        elif op == "chardev":
            os.mknod(p, 0o600 | 0o020000, os.makedev(1, 3))
        elif op == "symlink":
            os.symlink(os.path.join(d, step[2]), p)
        elif op == "sparse":
            with open(p, "wb") as f:
                f.write(open(os.path.join(DATA, CSV), "rb").read())
                f.truncate(int(step[2]))
        elif op == "emptyrows":
            lines = open(os.path.join(DATA, CSV)).read().split("\n")
            head = [l for l in lines if l.startswith("#")]
            with open(p, "w") as f:
                f.write("\n".join(head + [lines[len(head)]]) + "\n" + "\n" * step[2])
            shutil.copy(os.path.join(DATA, MAP), os.path.join(d, name[:-4] + ".map.toml"))
        elif op == "tiled":
            # The bundled CSV's rows step[2] times, 20 s later each time.
            lines = open(os.path.join(DATA, CSV)).read().rstrip("\n").split("\n")
            head = [l for l in lines if l.startswith("#")]
            rows = [l.split(",", 1) for l in lines[len(head) + 1:]]
            with open(p, "w") as f:
                f.write("\n".join(head + [lines[len(head)]]) + "\n")
                for k in range(step[2]):
                    f.write("".join(f"{float(t) + 20 * k:.3f},{r}\n" for t, r in rows))
            shutil.copy(os.path.join(DATA, MAP), os.path.join(d, name[:-4] + ".map.toml"))
        elif op == "longline":
            with open(p, "w") as f:
                f.write(open(os.path.join(DATA, CSV)).read())
                f.write("9" * step[2] + "\n")
        elif op == "edit":
            text = open(os.path.join(DATA, step[2])).read()
            assert step[3] in text, step
            open(p, "w").write(text.replace(step[3], step[4], 1))
        elif op == "tmpfs":
            os.mkdir(p)
            subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={step[2]}", "tmpfs", p], check=True)
        elif op == "fill":
            fd = os.open(os.path.join(p, "filler"), os.O_WRONLY | os.O_CREAT, 0o644)
            try:
                while os.write(fd, b"\0" * 4096) > 0:
                    pass
            except OSError:
                pass
            os.close(fd)
        elif op == "bigbuffer":
            big_buffer_mcap(p, step[2])
        else:
            raise ValueError(op)


def snapshot(d):
    out = {}
    for root, dirs, files in os.walk(d):
        for n in dirs + files:
            p = os.path.join(root, n)
            rel = os.path.relpath(p, d)
            if os.path.islink(p) or not os.path.isfile(p):
                out[rel] = os.path.islink(p) and os.readlink(p) or None
            elif os.path.getsize(p) > 64 << 20:
                # Large (sparse) files: size and modification time.
                st = os.stat(p)
                out[rel] = (st.st_size, st.st_mtime_ns)
            else:
                h = hashlib.sha256()
                with open(p, "rb") as f:
                    for chunk in iter(lambda: f.read(1 << 20), b""):
                        h.update(chunk)
                out[rel] = h.hexdigest()
    return out


TEMP = re.compile(r"^\..*\.\d+\.\d+\.tmp(\..*)?$|\.tmp$|\.bak$")


def temps(d):
    return [os.path.join(r, n) for r, _, fs in os.walk(d) for n in fs if TEMP.search(n)]


def run_bin(binary, d, args, env, stdout_spec, rss_file):
    full_env = dict(os.environ, **env)
    cmd = ["/usr/bin/time", "-v", "-o", rss_file, binary] + args
    if stdout_spec == "|closed":
        r, w = os.pipe()
        os.close(r)
        out = w
    elif stdout_spec:
        out = open(os.path.join(d, stdout_spec), "wb")
    else:
        out = subprocess.PIPE
    t0 = time.time()
    p = subprocess.Popen(cmd, cwd=d, stdin=subprocess.DEVNULL, stdout=out, stderr=subprocess.PIPE, env=full_env)
    try:
        so, se = p.communicate(timeout=LIMIT_S)
        code = p.returncode
    except subprocess.TimeoutExpired:
        p.kill()
        so, se = p.communicate()
        code = None
    if stdout_spec == "|closed":
        os.close(out)
    elif stdout_spec:
        out.close()
    return code, (so or b"").decode(errors="replace"), se.decode(errors="replace"), time.time() - t0


def peak_kb(rss_file):
    try:
        m = re.search(r"Maximum resident set size \(kbytes\): (\d+)", open(rss_file).read())
        return int(m.group(1)) if m else None
    except OSError:
        return None


def parallel_synth(binary, d, n, rss_file):
    procs = []
    for i in range(n):
        procs.append(subprocess.Popen(
            [binary, "synth", "--out", f"out/l{i}.mcap", "--duration-s", "5", "--warmup-s", "1", "--seed", str(i + 1)],
            cwd=d, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE))
    errs, code = [], 0
    for p in procs:
        _, e = p.communicate(timeout=LIMIT_S)
        errs.append(e.decode(errors="replace"))
        code = code or p.returncode
    open(rss_file, "w").write("")
    return code, "", "".join(errs), 0.0


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--bin", default=os.path.join(ROOT, "target/release/stickslip"))
    ap.add_argument("--only", default="")
    ap.add_argument("--tsv", default="")
    a = ap.parse_args()
    binary = os.path.abspath(a.bin)
    results = []
    all_cases = [x for x in cases() if a.only in x["name"] or a.only == x["kind"]]
    meta = tempfile.mkdtemp(prefix="sweep-meta-")
    for i, c in enumerate(all_cases):
        if c["root"] and not IS_ROOT:
            results.append((c, "skip", "not root", None, 0.0))
            continue
        d = tempfile.mkdtemp(prefix="sweep-", dir=os.environ.get("SWEEP_TMP"))
        mounts = [os.path.join(d, s[1]) for s in c["setup"] if s[0] == "tmpfs"]
        try:
            try:
                setup(d, c)
            except Exception as e:  # a broken case, not a result of the binary
                results.append((c, "FAIL", f"set-up failed: {e!r}", None, 0.0))
                print(f"FAIL {c['kind']:12} set-up failed: {c['name']}: {e!r}", flush=True)
                continue
            before = snapshot(d)
            rss_file = os.path.join(meta, f"{i}.time")
            if c["args"][0] == "__parallel_synth__":
                code, out, err, secs = parallel_synth(binary, d, 4, rss_file)
            elif c["args"][0] == "__parallel_synth8__":
                code, out, err, secs = parallel_synth(binary, d, 8, rss_file)
            else:
                code, out, err, secs = run_bin(binary, d, c["args"], c["env"], c["stdout"], rss_file)
            last = next((l for l in reversed(err.splitlines()) if l.strip()), "")
            why = []
            if code is None:
                why.append(f"still running after {LIMIT_S} s")
            elif code != c["code"]:
                why.append(f"exit {code}, expected {c['code']}")
            if "panicked" in err:
                why.append("a panic")
            if c["code"] == 1 and not last.startswith("error: "):
                why.append(f"last line not error: {last[:200]!r}")
            if c["code"] == 2 and "error:" not in err:
                why.append("clap printed no error")
            # clap's usage errors end with a "--help" hint: search all of stderr.
            where = err if c["ok"] or c["code"] == 2 else last
            if c["says"] and c["says"] not in where:
                why.append(f"does not say {c['says']!r}: {last[:300]!r}")
            if len(last) > 5000:
                why.append(f"error line of {len(last)} bytes")
            left = temps(d)
            if left:
                why.append(f"temporaries left: {left[:3]}")
            after = snapshot(d)
            for k in ("out.json", os.path.join("fs", "out.json")):
                after.pop(k, None)
                before.pop(k, None)
            if not c["ok"] and after != before:
                new = sorted(set(after) - set(before))
                changed = sorted(k for k in before if after.get(k) != before[k])
                why.append(f"files changed: new {new[:5]}, changed {changed[:5]}")
            kb = peak_kb(rss_file)
            if not c["ok"] and kb is not None and kb > MEMORY_LIMIT_KB:
                why.append(f"peak memory {kb / 1024:.0f} MB")
            if c["check"]:
                msg = c["check"](d, out, err)
                if msg:
                    why.append(msg)
            status = "FAIL" if why else "ok"
            results.append((c, status, "; ".join(why) or last[:160], kb, secs))
        finally:
            for mnt in mounts:
                subprocess.run(["umount", "-l", mnt], check=False)
            shutil.rmtree(d, ignore_errors=True)
        c_, st, msg, kb, secs = results[-1]
        print(f"{st:4} {c['kind']:12} {secs:6.1f} s {(kb or 0) / 1024:7.1f} MB  {c['name']}: {msg}", flush=True)
    shutil.rmtree(meta, ignore_errors=True)
    kinds = sorted({c["kind"] for c, *_ in results})
    print("\nkind          cases  ok  fail  skip  max peak MB (refused)")
    for k in kinds:
        rs = [r for r in results if r[0]["kind"] == k]
        peaks = [r[3] for r in rs if r[3] and not r[0]["ok"]]
        print(f"{k:12} {len(rs):6} {sum(r[1] == 'ok' for r in rs):3} {sum(r[1] == 'FAIL' for r in rs):5}"
              f" {sum(r[1] == 'skip' for r in rs):5}  {max(peaks) / 1024 if peaks else 0:8.1f}")
    n_fail = sum(r[1] == "FAIL" for r in results)
    print(f"total {len(results)} cases, {sum(r[1] == 'ok' for r in results)} ok, {n_fail} failed, "
          f"{sum(r[1] == 'skip' for r in results)} skipped")
    if a.tsv:
        with open(a.tsv, "w") as f:
            f.write("kind\tcase\tstatus\tpeak_mb\tseconds\tdetail\n")
            for c, st, msg, kb, secs in results:
                f.write(f"{c['kind']}\t{c['name']}\t{st}\t{(kb or 0) / 1024:.1f}\t{secs:.2f}\t{msg}\n")
    sys.exit(1 if n_fail else 0)


if __name__ == "__main__":
    main()
