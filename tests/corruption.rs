//! Property test: random corruptions of a valid log (truncation at any
//! point, flipped bytes, both) never make ingest panic; it returns an error
//! naming the file, or a run that satisfies the `Run` invariants.

use proptest::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;
use stickslip::ingest::{self, IngestOptions, Quantity, Run};
use stickslip::synth::{self, LogFormat, SynthConfig, TestSpec};

/// The directory of the valid logs and (path, bytes) of each.
type Logs = (tempfile::TempDir, Vec<(PathBuf, Vec<u8>)>);

/// Small valid logs, written once: MCAP (zstd, summary), MCAP (plain, no
/// summary), CSV + map, Parquet.
fn logs() -> &'static Logs {
    static LOGS: OnceLock<Logs> = OnceLock::new();
    LOGS.get_or_init(|| {
        let dir = tempfile::tempdir().expect("tempdir");
        let mut out = Vec::new();
        for (format, name) in [
            (LogFormat::Mcap, "z.mcap"),
            (LogFormat::McapPlain, "p.mcap"),
            (LogFormat::Csv, "c.csv"),
            (LogFormat::Parquet, "q.parquet"),
        ] {
            let mut c = SynthConfig::paper(7);
            c.format = format;
            c.test = TestSpec::Stepped {
                setpoints_hz: vec![1.5, 2.0],
                dwell_s: vec![0.6],
                ramp_s: 0.5,
                preroll_s: 0.2,
            };
            let log = synth::generate(&c).expect("generate");
            let p = dir.path().join(name);
            synth::write(&log, &p).expect("write");
            let bytes = std::fs::read(&p).expect("read");
            out.push((p, bytes));
        }
        (dir, out)
    })
}

/// What every run that ingest accepts must satisfy.
fn check_run(run: &Run) {
    // The velocity v2 is optional (rig-log-format: displacement-only rigs).
    for q in [Quantity::X0, Quantity::X1, Quantity::X2] {
        assert!(
            run.channel(q).is_some(),
            "accepted run without {}",
            q.name()
        );
    }
    for c in &run.channels {
        assert_eq!(c.t.len(), c.v.len());
        assert!(c.t.iter().all(|t| t.is_finite()));
        assert!(
            c.t.windows(2).all(|w| w[1] > w[0]),
            "{}: time not increasing",
            c.name()
        );
        assert!(c.v.iter().all(|v| !v.is_infinite()));
        assert!(c.rate_hz.is_finite() && c.rate_hz > 0.0);
    }
    let r = &run.resampled;
    let n = r.t.len();
    assert_eq!(r.x0.len(), n);
    assert_eq!(r.x1.len(), n);
    assert_eq!(r.x2.len(), n);
    assert_eq!(r.v2.len(), n);
    assert!(r.t.windows(2).all(|w| w[1] > w[0]));
    for g in &run.gaps {
        assert!(g.end_s >= g.start_s);
    }
    assert!(run.rig.m2_kg > 0.0 && run.rig.k2_n_per_m > 0.0);
}

fn corrupt_and_read(src: &Path, bytes: &[u8], cut: usize, flips: &[(usize, u8)]) {
    let mut b = bytes[..cut.min(bytes.len())].to_vec();
    for &(pos, x) in flips {
        if !b.is_empty() {
            let i = pos % b.len();
            b[i] ^= x.max(1);
        }
    }
    let dir = tempfile::tempdir().expect("tempdir");
    let name = src.file_name().expect("name");
    let p = dir.path().join(name);
    std::fs::write(&p, &b).expect("write");
    if src.extension().is_some_and(|e| e == "csv") {
        // The CSV keeps its (intact) map beside it.
        let map = src.with_extension("map.toml");
        std::fs::copy(&map, p.with_extension("map.toml")).expect("map");
    }
    match ingest::read(&p, &IngestOptions::default()) {
        Ok(run) => check_run(&run),
        Err(e) => {
            let msg = e.to_string();
            assert!(msg.contains(&*name.to_string_lossy()), "{msg}");
            assert!(!msg.contains('\n'), "multi-line error: {msg}");
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    /// Truncated anywhere, with up to 6 flipped bytes anywhere.
    #[test]
    fn corrupted_logs_never_panic(
        which in 0usize..4,
        cut_frac in 0.0f64..=1.0,
        flips in prop::collection::vec((any::<usize>(), any::<u8>()), 0..6),
    ) {
        let (_, logs) = logs();
        let (path, bytes) = &logs[which];
        let cut = (cut_frac * bytes.len() as f64) as usize;
        corrupt_and_read(path, bytes, cut, &flips);
    }

    /// Whole file, a few flipped bytes only (the harder case: structure
    /// intact, content wrong).
    #[test]
    fn flipped_bytes_never_panic(
        which in 0usize..4,
        flips in prop::collection::vec((any::<usize>(), any::<u8>()), 1..4),
    ) {
        let (_, logs) = logs();
        let (path, bytes) = &logs[which];
        corrupt_and_read(path, bytes, bytes.len(), &flips);
    }
}

/// The uncorrupted logs are accepted (so the properties above exercise
/// both outcomes).
#[test]
fn the_valid_logs_ingest() {
    let (_, logs) = logs();
    for (p, _) in logs {
        let run = ingest::read(p, &IngestOptions::default()).expect("valid log");
        check_run(&run);
    }
}
