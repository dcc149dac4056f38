//! Ingest throughput on the largest public log (`datasets/sweep_stepped_N4.mcap`),
//! in bytes of **uncompressed message payload** per second (criterion's
//! `Throughput::Bytes`; the payload size is summed once from the file's
//! messages). Peak memory is measured separately with
//! `/usr/bin/time -v target/release/stickslip ingest LOG --json`.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use std::hint::black_box;
use std::path::PathBuf;
use stickslip::ingest::{self, IngestOptions};

fn largest_log() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("datasets/sweep_stepped_N4.mcap")
}

/// Total uncompressed payload of every message (bytes).
fn payload_bytes(path: &std::path::Path) -> u64 {
    let bytes = std::fs::read(path).expect("read log");
    mcap::MessageStream::new(&bytes)
        .expect("mcap")
        .map(|m| m.expect("message").data.len() as u64)
        .sum()
}

fn ingest_throughput(c: &mut Criterion) {
    let path = largest_log();
    let payload = payload_bytes(&path);
    let file = std::fs::metadata(&path).expect("log").len();
    eprintln!(
        "{}: {file} bytes on disk, {payload} bytes of uncompressed payload",
        path.display()
    );
    let mut g = c.benchmark_group("ingest");
    g.sample_size(20);
    g.throughput(Throughput::Bytes(payload));
    g.bench_function("sweep_stepped_N4.mcap (payload)", |b| {
        b.iter(|| ingest::read(black_box(&path), &IngestOptions::default()).expect("ingest"))
    });
    g.finish();
}

criterion_group!(benches, ingest_throughput);
criterion_main!(benches);
