//! The paper's qualitative claims on Figs. 3–5 (m = 4, k = 1, D = 0.005),
//! each checked against families computed by the steady-state solver. The
//! paper's dimensionless values are the references. Where a claim does not
//! hold for the model's steady states, the test states what the model gives,
//! with numbers, instead of bending the model.

use stickslip::model::{Absorber, Law, Model};
use stickslip::sim::linear;
use stickslip::sim::sweep::{curve, eta_grid, Direction, Point, SteadyConfig};

fn model(law: Law, stop_below: Option<f64>) -> Model {
    Model {
        absorber: Absorber::default(),
        law,
        stop_below,
        contact_stiffness: None,
    }
}

fn coulomb(rs: f64) -> Model {
    model(Law::coulomb(rs), None)
}

fn run(m: &Model, lo: f64, hi: f64, n: usize, dir: Direction) -> Vec<Point> {
    curve(m, &eta_grid(lo, hi, n), dir, &SteadyConfig::default()).unwrap()
}

fn max_a1(c: &[Point]) -> (f64, f64) {
    c.iter()
        .filter_map(|p| p.amplitude1.map(|a| (a, p.eta)))
        .fold((0.0, 0.0), |m, x| if x.0 > m.0 { x } else { m })
}

/// Fig. 3b: "the antiresonance A1/A = 0 at η = 1.0 disappears even for very
/// low values of ρs". Frictionless (closed form): A1(1) = 0.0050 (D > 0);
/// at ρs = 0.05 the model gives A1(1) = 0.069, fourteen times more.
#[test]
fn antiresonance_disappears_at_small_rho_s() {
    let free = linear::free_amplitudes(&Absorber::default(), 0.0, 1.0).0;
    let c = run(&coulomb(0.05), 0.99, 1.01, 3, Direction::Up);
    let a = c[1].amplitude1.unwrap();
    assert!(free < 0.006, "{free}");
    assert!(a > 10.0 * free, "A1(1) = {a} vs frictionless {free}");
}

/// Fig. 3c: a moderate ρs removes the η2 resonance peak, and above η2 the
/// absorber no longer moves. Model: max A1 on η ∈ [1.05, 1.25] falls from
/// 5.7 (ρs = 0, on this grid) to 0.40 at ρs = 0.3, and M2 sticks throughout
/// for η ≥ 1.25.
#[test]
fn eta2_peak_removed_at_moderate_rho_s() {
    let free = run(&coulomb(0.0), 1.05, 1.25, 41, Direction::Up);
    let fric = run(&coulomb(0.3), 1.05, 1.6, 111, Direction::Up);
    let (pk0, _) = max_a1(&free);
    let near: Vec<Point> = fric.iter().copied().filter(|p| p.eta <= 1.25).collect();
    let (pk, _) = max_a1(&near);
    assert!(pk < 0.1 * pk0, "eta2 peak {pk} vs frictionless {pk0}");
    for p in fric.iter().filter(|p| p.eta >= 1.25) {
        assert_eq!(p.stick_fraction, 1.0, "M2 moves at eta {}", p.eta);
    }
}

/// Figs. 3d–e claim that the η1 peak vanishes suddenly between ρs = 0.33 and
/// 0.375. **The model's steady states do not show this** (continued up, down
/// or from rest alike): on a 0.001 grid around η1 = 0.4370 the peak of A1/A
/// is 3616 at ρs = 0.33, 3120 at ρs = 0.375 and 453 at ρs = 0.6 (the
/// frictionless peak there is 6900; on the 0.01 grid of Fig. 3 the curves
/// show 58 and 55 at η = 0.44).
/// It vanishes only between ρs = 0.6 and 0.7 (max A1 = 0.96 at ρs = 0.7).
///
/// Why: stuck, the absorber is the 1-DOF system, whose contact force near
/// η1 has amplitude |X1|·|1 + iηD| ≈ 0.81; any ρs below that lets M2 break
/// away. Once it slides in the η1 mode (X2/X1 = 1/(1 − η1²) = 1.24) the
/// Coulomb work per cycle, 4ρd·|X2 − X1| ≈ 0.94·ρd·A1, grows like the drive's
/// input π·A1 and cannot limit the resonance for ρd below about 3; only the
/// small viscous damping of the relative motion does. The threshold is thus
/// set by the stuck orbit's contact force (≈ 0.6–0.7 here), not 0.33–0.375.
/// A finite run from rest does not explain the paper either: after 10
/// periods A1 is already 12–15 for ρs = 0.3–0.4 and still growing.
#[test]
fn eta1_peak_threshold_is_not_the_papers() {
    let fine = |rs: f64| max_a1(&run(&coulomb(rs), 0.43, 0.445, 16, Direction::Rest)).0;
    let (p033, p0375, p06, p07) = (fine(0.33), fine(0.375), fine(0.6), fine(0.7));
    eprintln!("eta1 peak A1: rho_s 0.33 {p033}, 0.375 {p0375}, 0.6 {p06}, 0.7 {p07}");
    // The paper's threshold: no sudden drop between 0.33 and 0.375.
    assert!(p0375 > 0.8 * p033, "{p0375} vs {p033}");
    // The model's threshold lies between 0.6 and 0.7.
    assert!(p06 > 10.0 && p07 < 1.5, "{p06} {p07}");
}

/// Figs. 3e–f: a range of ρs with small amplitudes at every η (the
/// saturation). Model: at ρs = 1 the largest A1/A over η ∈ [0.2, 1.6]
/// (141 points, plus a 0.001 grid around η1) is 1.19, against 69 (grid) for
/// no friction and the rigid stick's resonance at η0.
#[test]
fn small_amplitudes_at_every_eta_for_some_rho_s() {
    let m = coulomb(1.0);
    let (a, _) = max_a1(&run(&m, 0.2, 1.6, 141, Direction::Up));
    let (b, _) = max_a1(&run(&m, 0.43, 0.445, 16, Direction::Up));
    let stuck_peak =
        linear::stuck_amplitudes(&Absorber::default(), Absorber::default().eta_stuck()).0;
    assert!(a < 1.5 && b < 1.5, "max A1 {a}, near eta1 {b}");
    assert!(stuck_peak > 50.0);
}

/// Fig. 3g: at large ρs the 1-DOF resonance at η0 = 0.7071 appears.
/// Model: the largest A1/A over η ∈ [0.2, 1.6] lies in the band around η0
/// (a broad stick-slip maximum: 2.31 at η = 0.775 for ρs = 2, 5.60 at 0.725
/// for ρs = 5), A1(η0) is within 5 % of it, and it grows with ρs toward the
/// rigid-stick resonance.
#[test]
fn eta0_peak_at_large_rho_s() {
    let eta0 = Absorber::default().eta_stuck();
    let at = |c: &[Point], e: f64| {
        c.iter()
            .min_by(|a, b| (a.eta - e).abs().total_cmp(&(b.eta - e).abs()))
            .and_then(|p| p.amplitude1)
            .unwrap()
    };
    let mut peaks = Vec::new();
    for rs in [2.0, 5.0] {
        let c = run(&coulomb(rs), 0.2, 1.6, 141, Direction::Up);
        let (a, e) = max_a1(&c);
        eprintln!("rho_s {rs}: peak {a} at {e}; A1(eta0) {}", at(&c, eta0));
        assert!((0.6..=0.8).contains(&e), "rho_s {rs}: peak at {e}");
        assert!(at(&c, eta0) > 0.95 * a);
        peaks.push(a);
    }
    assert!(peaks[1] > 2.0 * peaks[0], "{peaks:?}");
}

/// Fig. 5 (ρd = ρs/2): the suppression moves to larger ρs. Model: at
/// ρs = 0.3 the η2 peak is 2.9 with ρd = ρs/2 but 0.40 with Coulomb; the
/// η1 peak is gone at ρs = 0.7 with Coulomb but not with ρd = ρs/2.
#[test]
fn fig5_static_above_dynamic_shifts_suppression_up() {
    let half = |rs: f64| {
        model(
            Law::Linear {
                rho_s: rs,
                rho_d: 0.5 * rs,
                slope: 0.0,
                minus: None,
            },
            None,
        )
    };
    let (c2, _) = max_a1(&run(&coulomb(0.3), 1.05, 1.25, 21, Direction::Up));
    let (h2, _) = max_a1(&run(&half(0.3), 1.05, 1.25, 21, Direction::Up));
    assert!(h2 > 3.0 * c2, "eta2 peak: half {h2} vs coulomb {c2}");
    let (c1, _) = max_a1(&run(&coulomb(0.7), 0.43, 0.445, 16, Direction::Rest));
    let (h1, _) = max_a1(&run(&half(0.7), 0.43, 0.445, 16, Direction::Rest));
    assert!(h1 > 5.0 * c1, "eta1 peak: half {h1} vs coulomb {c1}");
}

/// Fig. 4 (D* = −0.04, interrupted below ρs/2): "interrupted … in Fig. 4b
/// and c at the resonance peaks"; otherwise as Coulomb, with the η2 peak
/// removed at the same ρs. Model: at ρs = 0.05 and 0.1 points near η1 are
/// interrupted (the sliding speed there exceeds ρs/2/0.04); at ρs = 0.3 the
/// η2 peak is below 0.5 as with Coulomb.
#[test]
fn fig4_decreasing_law_interrupts_at_peaks() {
    let dec = |rs: f64| {
        model(
            Law::Linear {
                rho_s: rs,
                rho_d: rs,
                slope: -0.04,
                minus: None,
            },
            Some(0.5),
        )
    };
    for rs in [0.05, 0.1] {
        let c = run(&dec(rs), 0.4, 0.48, 9, Direction::Up);
        assert!(
            c.iter().any(|p| p.interrupted),
            "rho_s {rs}: no interruption near eta1"
        );
        assert!(c.iter().all(|p| p.interrupted == p.amplitude1.is_none()));
    }
    let (pk, _) = max_a1(&run(&dec(0.3), 1.05, 1.25, 21, Direction::Up));
    assert!(pk < 0.5, "{pk}");
}

/// Coexisting stable steady states at the paper's parameters with the
/// Fig. 5 law (ρs = 0.6, ρd = 0.3) at η = 1: continued upwards (and from
/// rest) A1/A = 0.386, continued downwards 0.500; both periodic.
#[test]
fn policies_find_different_stable_states() {
    let m = model(
        Law::Linear {
            rho_s: 0.6,
            rho_d: 0.3,
            slope: 0.0,
            minus: None,
        },
        None,
    );
    let etas = eta_grid(0.3, 1.3, 51);
    let i = etas.iter().position(|e| (e - 1.0).abs() < 1e-12).unwrap();
    let up = curve(&m, &etas, Direction::Up, &SteadyConfig::default()).unwrap()[i];
    let down = curve(&m, &etas, Direction::Down, &SteadyConfig::default()).unwrap()[i];
    assert!(up.steady && down.steady);
    let (a, b) = (up.amplitude1.unwrap(), down.amplitude1.unwrap());
    eprintln!("eta 1: up {a} ({}), down {b} ({})", up.method, down.method);
    assert!((a - b).abs() > 0.05, "{a} vs {b}");
}
