//! Numerical stress suite: the edges of the parameter space and long-run
//! invariants. Every run must end with a clear status (completed, steady,
//! interrupted, chatter), never hang, never produce NaN.
#![allow(clippy::needless_range_loop)]

use stickslip::model::{Absorber, Law, Model};
use stickslip::sim::engine::net_force;
use stickslip::sim::{
    simulate, Event, EventKind, Flow, Init, Mode, Observer, PeriodStats, Sim, SimOptions, Status,
};

fn model(m: f64, k: f64, d: f64, law: Law) -> Model {
    Model {
        absorber: Absorber { m, k, damping: d },
        law,
        stop_below: None,
    }
}

#[derive(Default)]
struct Watch {
    last_tau: f64,
    events: u64,
    out_of_order: bool,
    nan: bool,
    worst_stick_excess: f64,
    model: Option<Model>,
}

impl Observer for Watch {
    fn event(&mut self, ev: &Event) {
        self.out_of_order |= ev.tau < self.last_tau;
        self.last_tau = ev.tau;
        self.events += 1;
        self.nan |= ev.x.iter().any(|v| !v.is_finite());
        if ev.kind == EventKind::Stick {
            if let Some(m) = &self.model {
                let f = net_force(m, &ev.x).abs() - m.law.rho_s();
                self.worst_stick_excess = self.worst_stick_excess.max(f);
            }
        }
    }
    fn period(&mut self, _n: u64, x: &[f64; 4], _m: Mode, _s: &PeriodStats) -> Flow {
        self.nan |= x.iter().any(|v| !v.is_finite());
        Flow::Continue
    }
}

fn check(m: Model, eta: f64, periods: u64) -> (Status, Watch) {
    let sim = Sim::new(&m, eta).unwrap();
    let mut w = Watch {
        model: Some(m),
        worst_stick_excess: f64::NEG_INFINITY,
        ..Watch::default()
    };
    let end = sim.run(Init::rest(), periods, &mut w);
    assert!(!w.nan, "NaN for {m:?} eta {eta}");
    assert!(!w.out_of_order, "events out of order for {m:?} eta {eta}");
    assert!(
        w.worst_stick_excess <= 1e-12 * (1.0 + m.law.rho_s()),
        "stick force exceeds rho_s by {}",
        w.worst_stick_excess
    );
    (end.status, w)
}

/// Edges: D = 0, ρs → 0⁺ (near-linear, a reversal at every velocity zero),
/// ρs huge (never slides), η tiny and large, extreme m and k.
#[test]
fn edges_of_the_parameter_space() {
    let cases = [
        (model(4.0, 1.0, 0.0, Law::coulomb(0.375)), 0.6),
        (model(4.0, 1.0, 0.005, Law::coulomb(1e-9)), 0.6),
        (model(4.0, 1.0, 0.005, Law::coulomb(1e6)), 0.7),
        (model(4.0, 1.0, 0.005, Law::coulomb(0.375)), 0.01),
        (model(4.0, 1.0, 0.005, Law::coulomb(0.375)), 20.0),
        (model(0.01, 1.0, 0.005, Law::coulomb(0.375)), 0.6),
        (model(1000.0, 1.0, 0.005, Law::coulomb(0.375)), 0.6),
        (model(4.0, 1e-3, 0.005, Law::coulomb(0.375)), 0.6),
        (model(4.0, 1e3, 0.005, Law::coulomb(0.375)), 0.6),
    ];
    for (m, eta) in cases {
        let periods = if eta < 0.1 { 3 } else { 50 };
        let (status, w) = check(m, eta, periods);
        assert_eq!(status, Status::Completed, "{m:?} eta {eta}");
        if m.law.rho_s() >= 1e6 {
            assert_eq!(w.events, 0, "huge rho_s slid");
        }
    }
}

/// Negative slip damping (D* < −D): the slip is unstable; the run must end
/// with the interruption (friction turning negative), not hang or overflow.
#[test]
fn negative_slip_damping_interrupts() {
    let m = model(
        4.0,
        1.0,
        0.005,
        Law::Linear {
            rho_s: 0.3,
            rho_d: 0.3,
            slope: -0.05,
        },
    );
    let (status, _) = check(m, 0.45, 100_000);
    assert!(matches!(status, Status::Interrupted(_)), "{status:?}");
}

/// Long runs (10⁵ periods): event times monotone, stick force within ρs,
/// no NaN, and a periodic orbit does not drift: after 10⁵ further periods
/// from a steady state (converged to 1e-13 on the section) the section
/// state is unchanged to 1e-10.
#[test]
fn long_run_invariants() {
    for (law, eta) in [
        (Law::coulomb(0.375), 0.6),
        (
            Law::Linear {
                rho_s: 0.5,
                rho_d: 0.25,
                slope: 0.0,
            },
            0.6,
        ),
    ] {
        let m = model(4.0, 1.0, 0.005, law);
        let sim = Sim::new(&m, eta).unwrap();
        // Start on the orbit as precisely as the section test allows.
        let opts = SimOptions {
            tol: 1e-13,
            max_periods: 200_000,
            ..SimOptions::default()
        };
        let s = simulate(&sim, &opts, &mut ());
        assert!(s.steady);
        let p = s.period_multiple.unwrap() as u64;
        let x0 = s.final_state;
        let mode = if x0[3] == 0.0 && net_force(&m, &x0).abs() < law.rho_s() {
            Mode::Stick { z2: x0[2] }
        } else {
            Mode::Slip {
                dir: x0[3].signum(),
            }
        };
        let n = 100_000 / p * p;
        let mut w = Watch {
            model: Some(m),
            worst_stick_excess: f64::NEG_INFINITY,
            ..Watch::default()
        };
        let end = sim.run(Init { x: x0, mode }, n, &mut w);
        assert!(!w.nan && !w.out_of_order);
        assert!(w.worst_stick_excess <= 1e-12);
        for i in 0..4 {
            assert!(
                (end.x[i] - x0[i]).abs() < 1e-10,
                "{law}: drift in x[{i}]: {} vs {}",
                end.x[i],
                x0[i]
            );
        }
    }
}

/// Grazing: the stuck orbit's contact force touches ρs tangentially. With
/// ρs a relative 1e-10 below its peak, |F| exceeds ρs only for a time of
/// order √(2e-10)/η ≈ 2e-5 per period — invisible to a sign test at step
/// ends — and M2 must break away; with ρs 1e-10 above the peak it must not.
#[test]
fn grazing_contact_force_is_detected() {
    use stickslip::sim::linear;
    let ab = Absorber::default();
    for eta in [0.3, 0.9, 1.3] {
        let x1 = linear::stuck_response(&ab, eta);
        let fmax = (x1 * num_complex::Complex::new(1.0, eta * ab.damping)).norm();
        let x0 = linear::stuck_state(&ab, eta, 0.0);
        let run = |rs: f64| {
            let m = model(4.0, 1.0, 0.005, Law::coulomb(rs));
            let mut w = Watch::default();
            Sim::new(&m, eta).unwrap().run(
                Init {
                    x: x0,
                    mode: Mode::Stick { z2: 0.0 },
                },
                3,
                &mut w,
            );
            w.events
        };
        assert!(
            run(fmax * (1.0 - 1e-10)) > 0,
            "eta {eta}: grazing breakaway missed"
        );
        assert_eq!(
            run(fmax * (1.0 + 1e-10)),
            0,
            "eta {eta}: broke away below the threshold"
        );
    }
}
