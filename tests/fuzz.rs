//! In-process mutation fuzzers for the ingest parsers, on stable (a
//! cargo-fuzz/libFuzzer target needs a nightly toolchain):
//! * `ingest_survives_mutated_logs`: whole logs (MCAP, CSV + channel map,
//!   Parquet, TDMS and MAT + channel map), seeded from `datasets/` (public,
//!   `formats/` and broken logs); each
//!   execution mutates one seed file (bit flips, byte overwrites, truncation,
//!   duplicated or deleted spans, random insertions; for CSV, TDMS and MAT
//!   also the TOML map), ingests it, and fails on a panic or an execution slower than 10 s;
//! * `channel_map_parser_survives_mutations`: the CSV channel-map (TOML)
//!   parser alone, seeded from `datasets/*.map.toml` and
//!   `datasets/broken/*.map.toml`, with the byte mutations and TOML-aware
//!   ones (structural tokens, extreme and non-finite numbers, deep nesting,
//!   odd strings and keys, duplicated or swapped lines); fails on a panic or
//!   an execution slower than 1 s.
//!
//! Each runs `STICKSLIP_FUZZ_SECS` (default 3 s, as in CI; `just fuzz` runs
//! 300 s). Deterministic for `STICKSLIP_FUZZ_SEED`. Inputs that once crashed
//! are kept in `tests/fuzz-regressions/` and replayed by
//! `fuzz_regressions_are_clean_errors`.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};
use stickslip::ingest::{check_channel_map, read, IngestOptions};

struct Rng(u64);
impl Rng {
    fn next(&mut self) -> u64 {
        // xorshift64*
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

fn mutate(rng: &mut Rng, data: &mut Vec<u8>) {
    let rounds = 1 + rng.below(4);
    for _ in 0..rounds {
        if data.is_empty() {
            data.push(rng.next() as u8);
            continue;
        }
        let n = data.len();
        match rng.below(6) {
            0 => {
                let i = rng.below(n);
                data[i] ^= 1 << rng.below(8);
            }
            1 => {
                let i = rng.below(n);
                data[i] = [
                    0u8,
                    0xFF,
                    0x7F,
                    0x80,
                    b'{',
                    b'"',
                    b',',
                    b'\n',
                    rng.next() as u8,
                ][rng.below(9)];
            }
            2 => data.truncate(rng.below(n)),
            3 => {
                let (a, len) = (rng.below(n), 1 + rng.below(256));
                let b = (a + len).min(n);
                let span: Vec<u8> = data[a..b].to_vec();
                let at = rng.below(n);
                data.splice(at..at, span);
            }
            4 => {
                let (a, len) = (rng.below(n), 1 + rng.below(256));
                let b = (a + len).min(n);
                data.drain(a..b);
            }
            _ => {
                let at = rng.below(n);
                let ins: Vec<u8> = (0..1 + rng.below(16)).map(|_| rng.next() as u8).collect();
                data.splice(at..at, ins);
            }
        }
    }
}

fn seeds(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for d in [dir.to_path_buf(), dir.join("broken"), dir.join("formats")] {
        if let Ok(rd) = std::fs::read_dir(&d) {
            for e in rd.flatten() {
                let p = e.path();
                let ext = p.extension().and_then(|e| e.to_str()).unwrap_or("");
                let small = e.metadata().map(|m| m.len() < 1_200_000).unwrap_or(false);
                if small && matches!(ext, "mcap" | "csv" | "parquet" | "tdms" | "mat") {
                    out.push(p);
                }
            }
        }
    }
    out.sort();
    out
}

fn budget() -> (u64, u64) {
    let secs: u64 = std::env::var("STICKSLIP_FUZZ_SECS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(3);
    let seed: u64 = std::env::var("STICKSLIP_FUZZ_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(0x5eed);
    (secs, seed)
}

#[test]
fn ingest_survives_mutated_logs() {
    let (secs, seed) = budget();
    let corpus = seeds(Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/datasets")));
    assert!(corpus.len() >= 10, "seed corpus missing");
    let bytes: Vec<Vec<u8>> = corpus.iter().map(|p| std::fs::read(p).unwrap()).collect();
    let tmp = tempfile::tempdir().unwrap();
    let mut rng = Rng(seed | 1);
    let (start, budget) = (Instant::now(), Duration::from_secs(secs));
    let (mut execs, mut errors) = (0u64, 0u64);
    while start.elapsed() < budget {
        let k = rng.below(corpus.len());
        let src = &corpus[k];
        let ext = src.extension().and_then(|e| e.to_str()).unwrap_or("bin");
        let mut data = bytes[k].clone();
        mutate(&mut rng, &mut data);
        let target = tmp.path().join(format!("case.{ext}"));
        std::fs::write(&target, &data).unwrap();
        let mut opts = IngestOptions::default();
        if matches!(ext, "csv" | "tdms" | "mat") {
            let map = src.with_extension("map.toml");
            let mut m = std::fs::read(&map).unwrap_or_default();
            if rng.below(4) == 0 {
                mutate(&mut rng, &mut m);
            }
            let mp = tmp.path().join("case.map.toml");
            std::fs::write(&mp, &m).unwrap();
            opts.map = Some(mp);
        }
        let t0 = Instant::now();
        let r = std::panic::catch_unwind(|| read(&target, &opts).map(|run| run.samples()));
        let dt = t0.elapsed();
        if r.is_err() || dt > Duration::from_secs(10) {
            let keep = std::env::temp_dir().join(format!("stickslip-fuzz-crash.{ext}"));
            std::fs::write(&keep, &data).unwrap();
            panic!(
                "ingest {} on a mutation of {} (kept at {}): took {dt:?}",
                if r.is_err() { "panicked" } else { "was slow" },
                src.display(),
                keep.display()
            );
        }
        if matches!(r, Ok(Err(_))) {
            errors += 1;
        }
        execs += 1;
    }
    eprintln!(
        "fuzz: {execs} executions in {:?} ({errors} rejected with an error), seed {seed}",
        start.elapsed()
    );
    assert!(execs > 0);
}

/// Tokens for the TOML-aware mutations of channel maps.
const TOML_TOKENS: &[&str] = &[
    "[",
    "]",
    "{",
    "}",
    "=",
    ",",
    ".",
    "\"",
    "'",
    "\"\"\"",
    "'''",
    "#",
    "\n",
    "\r\n",
    "\t",
    "[columns]",
    "[[columns]]",
    "[columns.time]",
    "columns.x1",
    "time",
    "x0",
    "x1",
    "x2",
    "v2",
    "a2",
    "normal_force",
    "setpoint_hz",
    "name",
    "scale",
    "shift_s",
    "= { name = \"t [s]\" }",
    "scale = 0",
    "scale = -1",
    "scale = 1e308",
    "shift_s = 1e308",
    "0",
    "-0.0",
    "+0.0",
    "1e999",
    "-1e999",
    "1e-400",
    "nan",
    "+nan",
    "-inf",
    "inf",
    "1_000",
    "0x7f",
    "0o17",
    "0b101",
    "9223372036854775808",
    "-9223372036854775809",
    "1979-05-27T07:32:00Z",
    "07:32:00",
    "true",
    "\\u0000",
    "\\uD800",
    "\\U0010FFFF",
    "\\",
    "\u{feff}",
    "\u{0}",
    "é",
    "\u{1F600}",
    "\u{202E}",
    "name = \"\"",
    "name = 1",
    "name = []",
    "name = {}",
    "time = 1",
];

fn mutate_toml(rng: &mut Rng, data: &mut Vec<u8>) {
    let rounds = 1 + rng.below(4);
    for _ in 0..rounds {
        let n = data.len();
        match rng.below(9) {
            0 => mutate(rng, data),
            7 => {
                // Replace the content of a quoted string (column names).
                let quotes: Vec<usize> = (0..n).filter(|&i| data[i] == b'"').collect();
                if quotes.len() >= 2 {
                    let q = rng.below(quotes.len() - 1);
                    let (a, b) = (quotes[q] + 1, quotes[q + 1]);
                    let long = "a".repeat(1 << rng.below(17));
                    let t = [
                        "", " ", "t [s]", "x1 [mm]", "\\u0000", "\\\"", "é", "\u{0}", &long,
                    ][rng.below(9)]
                    .as_bytes()
                    .to_vec();
                    data.splice(a..b, t);
                }
            }
            8 => {
                // Replace a key (a bare word before `=`) by another one.
                let eqs: Vec<usize> = (1..n).filter(|&i| data[i] == b'=').collect();
                if let Some(&e) = eqs.get(rng.below(eqs.len())) {
                    let mut b = e;
                    while b > 0 && data[b - 1] == b' ' {
                        b -= 1;
                    }
                    let mut a = b;
                    while a > 0 && (data[a - 1].is_ascii_alphanumeric() || data[a - 1] == b'_') {
                        a -= 1;
                    }
                    let keys = [
                        "time",
                        "x0",
                        "x1",
                        "x2",
                        "v2",
                        "a2",
                        "normal_force",
                        "setpoint_hz",
                        "name",
                        "scale",
                        "shift_s",
                        "x3",
                        "Time",
                        "columns",
                        "\"time\"",
                        "",
                    ];
                    let t = keys[rng.below(keys.len())].as_bytes().to_vec();
                    data.splice(a..b, t);
                }
            }
            1 | 2 => {
                let t = TOML_TOKENS[rng.below(TOML_TOKENS.len())].as_bytes();
                let at = rng.below(n + 1);
                data.splice(at..at, t.iter().copied());
            }
            3 => {
                // Replace a number (a run of digits) by an extreme one.
                let digits: Vec<usize> = (0..n).filter(|&i| data[i].is_ascii_digit()).collect();
                if let Some(&i) = digits.get(rng.below(digits.len())) {
                    let mut j = i;
                    while j < n && (data[j].is_ascii_digit() || data[j] == b'.') {
                        j += 1;
                    }
                    let t = [
                        "1e999",
                        "-0",
                        "nan",
                        "inf",
                        "1e-320",
                        "18446744073709551616",
                        "0.0",
                    ][rng.below(7)]
                    .as_bytes();
                    data.splice(i..j, t.iter().copied());
                }
            }
            4 => {
                // Deep or wide nesting.
                let scale = 1 << (1 + rng.below(14));
                let depth = 1 + rng.below(scale);
                let (open, close): (&[u8], &[u8]) = match rng.below(3) {
                    0 => (b"[", b"]"),
                    1 => (b"{a=", b"}"),
                    _ => (b"[{a=", b"}]"),
                };
                let at = rng.below(n + 1);
                let mut ins = Vec::with_capacity(depth * (open.len() + close.len()));
                for _ in 0..depth {
                    ins.extend_from_slice(open);
                }
                if rng.below(2) == 0 {
                    ins.push(b'1');
                    for _ in 0..depth {
                        ins.extend_from_slice(close);
                    }
                }
                data.splice(at..at, ins);
            }
            5 => {
                // Duplicate a line (duplicate keys, tables).
                let lines: Vec<&[u8]> = data.split(|&b| b == b'\n').collect();
                let l = lines[rng.below(lines.len())].to_vec();
                let at = rng.below(n + 1);
                let mut ins = l;
                ins.push(b'\n');
                data.splice(at..at, ins);
            }
            _ => {
                // Swap two lines.
                let mut lines: Vec<Vec<u8>> =
                    data.split(|&b| b == b'\n').map(<[u8]>::to_vec).collect();
                let (a, b) = (rng.below(lines.len()), rng.below(lines.len()));
                lines.swap(a, b);
                *data = lines.join(&b'\n');
            }
        }
    }
}

fn map_seeds(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for d in [dir.to_path_buf(), dir.join("broken"), dir.join("formats")] {
        if let Ok(rd) = std::fs::read_dir(&d) {
            for e in rd.flatten() {
                let p = e.path();
                if p.to_string_lossy().ends_with(".map.toml") {
                    out.push(p);
                }
            }
        }
    }
    out.sort();
    out
}

/// The channel-map parser alone: mutated maps give `Ok` or a clean error,
/// never a panic, within 1 s. The current input is written to
/// `$TMPDIR/stickslip-fuzz-map-<pid>.toml` before each execution, so that
/// an input that aborts the process (e.g. a stack overflow) is kept too.
#[test]
fn channel_map_parser_survives_mutations() {
    let (secs, seed) = budget();
    let corpus = map_seeds(Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/datasets")));
    assert!(corpus.len() >= 3, "map seed corpus missing");
    let bytes: Vec<Vec<u8>> = corpus.iter().map(|p| std::fs::read(p).unwrap()).collect();
    let current =
        std::env::temp_dir().join(format!("stickslip-fuzz-map-{}.toml", std::process::id()));
    let map_path = Path::new("case.map.toml");
    let mut rng = Rng(seed.rotate_left(17) | 1);
    let (start, budget) = (Instant::now(), Duration::from_secs(secs));
    let (mut execs, mut ok, mut slowest) = (0u64, 0u64, Duration::ZERO);
    while start.elapsed() < budget {
        let k = rng.below(corpus.len());
        let mut data = bytes[k].clone();
        mutate_toml(&mut rng, &mut data);
        std::fs::write(&current, &data).unwrap();
        // `read` takes the map with read_to_string: only UTF-8 reaches the
        // parser; feed the lossy decoding so that every mutation counts.
        let text = String::from_utf8_lossy(&data).into_owned();
        let t0 = Instant::now();
        let r = std::panic::catch_unwind(|| {
            check_channel_map(map_path, &text).map_err(|e| e.to_string())
        });
        let dt = t0.elapsed();
        slowest = slowest.max(dt);
        if r.is_err() || dt > Duration::from_secs(1) {
            let keep = std::env::temp_dir().join("stickslip-fuzz-crash.map.toml");
            std::fs::write(&keep, &data).unwrap();
            panic!(
                "channel-map parser {} on a mutation of {} (kept at {}): took {dt:?}",
                if r.is_err() { "panicked" } else { "was slow" },
                corpus[k].display(),
                keep.display()
            );
        }
        if let Ok(Err(msg)) = &r {
            // Errors name the map.
            assert!(msg.starts_with("case.map.toml"), "{msg}");
        } else {
            ok += 1;
        }
        execs += 1;
    }
    let _ = std::fs::remove_file(&current);
    eprintln!(
        "fuzz (channel map): {execs} executions in {:?} ({ok} accepted), slowest {slowest:?}, seed {seed}",
        start.elapsed()
    );
    assert!(execs > 0);
}

/// Every input the fuzzer once crashed on, kept in `tests/fuzz-regressions/`:
/// now a clean error.
#[test]
fn fuzz_regressions_are_clean_errors() {
    let dir = Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/fuzz-regressions"
    ));
    let mut n = 0;
    for e in std::fs::read_dir(dir).unwrap().flatten() {
        let p = e.path();
        let r = if p.to_string_lossy().ends_with(".map.toml") {
            // A channel map: the map parser alone.
            let text = String::from_utf8_lossy(&std::fs::read(&p).unwrap()).into_owned();
            std::panic::catch_unwind(|| check_channel_map(&p, &text).map(|()| 0))
        } else {
            std::panic::catch_unwind(|| {
                read(&p, &IngestOptions::default()).map(|run| run.samples())
            })
        };
        assert!(
            matches!(r, Ok(Err(_))),
            "{} did not give a clean error",
            p.display()
        );
        n += 1;
    }
    assert!(n >= 1);
}
