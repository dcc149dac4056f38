//! Fit time of one characteristic log (`datasets/char_N4.mcap`, 20 s at
//! 1 kHz): the whole `fit` of one log (equation-error fit with its
//! bootstrap and calibration budget, the output-error refinement of three
//! families with the static-threshold screen, the adequacy tests and the
//! intervals), ingest excluded. `just bench` runs it.

use criterion::{criterion_group, criterion_main, Criterion};
use std::hint::black_box;
use std::path::PathBuf;
use stickslip::identify::{self, IdentifyOptions};
use stickslip::ingest::{self, IngestOptions};

fn fit_one_log(c: &mut Criterion) {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("datasets/char_N4.mcap");
    let run = ingest::read(&path, &IngestOptions::default()).expect("ingest");
    let mut g = c.benchmark_group("fit");
    g.sample_size(10);
    g.bench_function("char_N4.mcap (one log, adequacy included)", |b| {
        b.iter(|| identify::fit_log(black_box(&run), &IdentifyOptions::default()).expect("fit"))
    });
    g.finish();
}

criterion_group!(benches, fit_one_log);
criterion_main!(benches);
