//! The Fig. 3 workload: 13 Coulomb curves (ρs ∈ {0, 0.05, 0.1, 0.2, 0.3,
//! 0.33, 0.35, 0.375, 0.4, 0.6, 1, 2, 5}) × 141 η in [0.2, 1.6], steady
//! states continued upwards and the same grid from rest, all cores
//! (rayon), against a baseline of the same family evaluated by the closed
//! forms only (ρs = 0 for every curve).

use criterion::{criterion_group, criterion_main, Criterion};
use stickslip::model::{Absorber, Law, Model};
use stickslip::sim::sweep::{eta_grid, family, CurveSpec, Direction, Shard, SteadyConfig};

fn specs(rhos: &[f64]) -> Vec<CurveSpec> {
    specs_dir(rhos, Direction::Up)
}

fn specs_dir(rhos: &[f64], direction: Direction) -> Vec<CurveSpec> {
    rhos.iter()
        .map(|&rs| CurveSpec {
            model: Model {
                absorber: Absorber::default(),
                law: Law::coulomb(rs),
                stop_below: None,
                contact_stiffness: None,
            },
            direction,
        })
        .collect()
}

fn fig3(c: &mut Criterion) {
    let rhos = [
        0.0, 0.05, 0.1, 0.2, 0.3, 0.33, 0.35, 0.375, 0.4, 0.6, 1.0, 2.0, 5.0,
    ];
    let etas = eta_grid(0.2, 1.6, 141);
    let cfg = SteadyConfig::default();
    let mut g = c.benchmark_group("fig3");
    g.sample_size(10);
    let s = specs(&rhos);
    g.bench_function("13 curves x 141 eta, coulomb, steady", |b| {
        b.iter(|| family(&s, &etas, &cfg, Shard::ALL, &|_| {}).unwrap())
    });
    let rest = specs_dir(&rhos, Direction::Rest);
    g.bench_function("13 curves x 141 eta, coulomb, from rest", |b| {
        b.iter(|| family(&rest, &etas, &cfg, Shard::ALL, &|_| {}).unwrap())
    });
    let base = specs(&[0.0; 13]);
    g.bench_function("baseline: same grid, closed forms", |b| {
        b.iter(|| family(&base, &etas, &cfg, Shard::ALL, &|_| {}).unwrap())
    });
    g.finish();
}

criterion_group!(benches, fig3);
criterion_main!(benches);
