//! In-process mutation fuzzer for the ingest parsers (MCAP, CSV + channel
//! map, Parquet), seeded from `datasets/` (public and broken logs). Runs on
//! stable: each execution mutates one seed file (bit flips, byte overwrites,
//! truncation, duplicated or deleted spans, random insertions; for CSV also
//! the TOML map), ingests it, and fails on a panic or on an execution slower
//! than 10 s. The run time comes from `STICKSLIP_FUZZ_SECS` (default 3 s, as
//! in CI; `just fuzz` runs 300 s). Deterministic for `STICKSLIP_FUZZ_SEED`.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};
use stickslip::ingest::{read, IngestOptions};

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
    for d in [dir.to_path_buf(), dir.join("broken")] {
        if let Ok(rd) = std::fs::read_dir(&d) {
            for e in rd.flatten() {
                let p = e.path();
                let ext = p.extension().and_then(|e| e.to_str()).unwrap_or("");
                let small = e.metadata().map(|m| m.len() < 1_200_000).unwrap_or(false);
                if small && matches!(ext, "mcap" | "csv" | "parquet") {
                    out.push(p);
                }
            }
        }
    }
    out.sort();
    out
}

#[test]
fn ingest_survives_mutated_logs() {
    let secs: u64 = std::env::var("STICKSLIP_FUZZ_SECS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(3);
    let seed: u64 = std::env::var("STICKSLIP_FUZZ_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(0x5eed);
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
        if ext == "csv" {
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
        let r = std::panic::catch_unwind(|| {
            read(&p, &IngestOptions::default()).map(|run| run.samples())
        });
        assert!(
            matches!(r, Ok(Err(_))),
            "{} did not give a clean error",
            p.display()
        );
        n += 1;
    }
    assert!(n >= 1);
}
