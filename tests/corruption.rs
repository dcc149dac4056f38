//! Property test: random corruptions of a valid log (truncation at any
//! point, flipped bytes, both) never make ingest panic; it returns an error
//! naming the file, or a run that satisfies the `Run` invariants.

use proptest::prelude::*;
use std::path::PathBuf;
use std::sync::OnceLock;
use stickslip::ingest::{self, IngestOptions, Quantity, Run};
use stickslip::synth::{self, LogFormat, SynthConfig, TestSpec};

/// One valid log: its file name, its bytes and (a CSV's) its channel map.
struct Log {
    name: &'static str,
    bytes: Vec<u8>,
    map: Option<Vec<u8>>,
}

/// Small valid logs, made once and kept in memory (each case writes its
/// own copy into its own temporary directory, so nothing outlives the
/// test run): MCAP (zstd, summary), MCAP (plain, no summary), CSV + map,
/// Parquet, and the TDMS (waveforms, two segments) and MAT (-v7,
/// compressed) fixtures of `datasets/formats/` with their maps.
fn logs() -> &'static [Log] {
    static LOGS: OnceLock<Vec<Log>> = OnceLock::new();
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
            let map = (format == LogFormat::Csv)
                .then(|| std::fs::read(p.with_extension("map.toml")).expect("map"));
            out.push(Log { name, bytes, map });
        }
        let formats = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("datasets/formats");
        for (file, map, name) in [
            ("synth_wf.tdms", "synth_wf.map.toml", "w.tdms"),
            ("synth_table_v7.mat", "synth_table_v7.map.toml", "m.mat"),
        ] {
            out.push(Log {
                name,
                bytes: std::fs::read(formats.join(file)).expect("fixture"),
                map: Some(std::fs::read(formats.join(map)).expect("map")),
            });
        }
        out
    })
}

/// Writes `bytes` as the log `log.name` (with its map) into a fresh
/// temporary directory, removed when the returned guard is dropped.
fn materialise(log: &Log, bytes: &[u8]) -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().expect("tempdir");
    let p = dir.path().join(log.name);
    std::fs::write(&p, bytes).expect("write");
    if let Some(map) = &log.map {
        // A CSV, TDMS or MAT log keeps its (intact) map beside it.
        std::fs::write(p.with_extension("map.toml"), map).expect("map");
    }
    (dir, p)
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

fn corrupt_and_read(log: &Log, cut: usize, flips: &[(usize, u8)]) {
    let mut b = log.bytes[..cut.min(log.bytes.len())].to_vec();
    for &(pos, x) in flips {
        if !b.is_empty() {
            let i = pos % b.len();
            b[i] ^= x.max(1);
        }
    }
    let (_dir, p) = materialise(log, &b);
    let name = log.name;
    match ingest::read(&p, &IngestOptions::default()) {
        Ok(run) => check_run(&run),
        Err(e) => {
            let msg = e.to_string();
            assert!(msg.contains(name), "{msg}");
            assert!(!msg.contains('\n'), "multi-line error: {msg}");
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    /// Truncated anywhere, with up to 6 flipped bytes anywhere.
    #[test]
    fn corrupted_logs_never_panic(
        which in 0usize..6,
        cut_frac in 0.0f64..=1.0,
        flips in prop::collection::vec((any::<usize>(), any::<u8>()), 0..6),
    ) {
        let log = &logs()[which];
        let cut = (cut_frac * log.bytes.len() as f64) as usize;
        corrupt_and_read(log, cut, &flips);
    }

    /// Whole file, a few flipped bytes only (the harder case: structure
    /// intact, content wrong).
    #[test]
    fn flipped_bytes_never_panic(
        which in 0usize..6,
        flips in prop::collection::vec((any::<usize>(), any::<u8>()), 1..4),
    ) {
        let log = &logs()[which];
        corrupt_and_read(log, log.bytes.len(), &flips);
    }
}

/// The uncorrupted logs are accepted (so the properties above exercise
/// both outcomes).
#[test]
fn the_valid_logs_ingest() {
    for log in logs() {
        let (_dir, p) = materialise(log, &log.bytes);
        let run = ingest::read(&p, &IngestOptions::default()).expect("valid log");
        check_run(&run);
    }
}
