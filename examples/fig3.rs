use stickslip::model::{Absorber, Law, Model};
use stickslip::sim::sweep::{curve, eta_grid, Direction, SteadyConfig};
fn main() {
    let rhos = [
        0.0, 0.05, 0.1, 0.2, 0.3, 0.33, 0.35, 0.375, 0.4, 0.6, 1.0, 2.0, 5.0,
    ];
    let etas = eta_grid(0.2, 1.6, 141);
    let t = std::time::Instant::now();
    let mut counts = std::collections::BTreeMap::new();
    let mut periods = 0;
    for &rs in &rhos {
        let m = Model {
            absorber: Absorber::default(),
            law: Law::coulomb(rs),
            stop_below: None,
        };
        let c = curve(&m, &etas, Direction::Up, &SteadyConfig::default()).unwrap();
        let amax = c.iter().filter_map(|p| p.amplitude1).fold(0.0, f64::max);
        let ns = c.iter().filter(|p| !p.steady).count();
        for p in &c {
            *counts.entry(p.method).or_insert(0) += 1;
            periods += p.periods;
        }
        println!(
            "rho_s {rs}: max A1 {amax:.3}, not steady {ns}, periods {}",
            c.iter().map(|p| p.periods).sum::<u64>()
        );
    }
    println!("{:?} total periods {periods} in {:?}", counts, t.elapsed());
}
