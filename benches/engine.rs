//! Criterion benchmarks of the exact engine: one steady period of the
//! paper's absorber (Coulomb ρs = 0.375, η = 0.6), with and without exact
//! amplitude tracking, against a baseline of one period of the 1-DOF
//! closed form in the same run.

use criterion::{criterion_group, criterion_main, Criterion};
use std::hint::black_box;
use stickslip::model::{Absorber, Law, Model};
use stickslip::sim::{simulate, Init, Mode, Observer, Sim, SimOptions};

struct Amplitudes;
impl Observer for Amplitudes {}

fn steady_period(c: &mut Criterion) {
    let model = Model {
        absorber: Absorber::default(),
        law: Law::coulomb(0.375),
        stop_below: None,
        contact_stiffness: None,
    };
    let sim = Sim::new(&model, 0.6).unwrap();
    let s = simulate(&sim, &SimOptions::default(), &mut ());
    let init = Init {
        x: s.final_state,
        mode: Mode::Slip {
            dir: s.final_state[3].signum(),
        },
    };
    c.bench_function("steady period, coulomb 0.375, eta 0.6", |b| {
        b.iter(|| sim.run(black_box(init), 1, &mut ()))
    });
    // Per period in a run of 100 periods (divide the time by 100).
    c.bench_function("100 steady periods, coulomb 0.375, eta 0.6", |b| {
        b.iter(|| sim.run(black_box(init), 100, &mut ()))
    });
    c.bench_function("steady period + exact extremes", |b| {
        b.iter(|| sim.run(black_box(init), 1, &mut Amplitudes))
    });
    let stuck = Sim::new(
        &Model {
            law: Law::coulomb(f64::INFINITY),
            ..model
        },
        0.6,
    )
    .unwrap();
    c.bench_function("baseline: stuck 1-DOF period", |b| {
        b.iter(|| stuck.run(black_box(Init::rest()), 1, &mut ()))
    });
    c.bench_function("set-up: Sim::new (eigen-decompositions)", |b| {
        b.iter(|| Sim::new(black_box(&model), 0.6).unwrap())
    });
    // A sweep's next point: the same model retuned to another eta.
    let other = Sim::new(&model, 0.55).unwrap();
    c.bench_function("set-up: Sim::at_eta (next point of a sweep)", |b| {
        b.iter(|| black_box(&other).at_eta(black_box(0.6)).unwrap())
    });
}

criterion_group!(benches, steady_period);
criterion_main!(benches);
