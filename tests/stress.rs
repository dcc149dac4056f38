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

// ---------------------------------------------------------------------------
// Dense event clusters (chattering, Zeno)
//
// Why genuine Zeno (infinitely many events before a finite time) cannot occur
// for the valid laws (ρs > 0, g(0⁺) = ρd ≤ ρs, g Lipschitz in v): on a finite
// time interval the state is bounded (linear phases, bounded drive), so
// |F'| ≤ C and |ζ2''| ≤ C there. Then
// * a reversal needs |F| > ρs at rest, and the next reversal needs F to
//   travel from beyond −ρs to beyond +ρs (or back): ≥ 2ρs/C apart;
// * with ρd < ρs a slip ends (ζ2' = 0, decelerating) with |F| ≤ ρd, and the
//   stick that follows lasts ≥ (ρs − ρd)/C before |F| reaches ρs again;
// * with ρd = ρs a slip of length δ from rest to rest needs the slip
//   acceleration F − g to change sign within δ, i.e. it starts within
//   O(δ) of a maximum of F (F' = O(δ) at breakaway); it ends with
//   F ≈ ρs − O(δ²), past that maximum (F' ≈ −F'(0) < 0), so the stick that
//   follows lasts until F comes back to ±ρs — a time of the order of the
//   forcing period, not of δ. Short slips cannot follow each other.
// So event times have no finite accumulation point. What remains are
// (a) physically dense but resolved clusters — a fast mode (here K1/K2 = 1e6)
// shakes M2 through the damper and it reverses twice per fast cycle; the
// engines stop those at MAX_EVENTS_PER_PERIOD = 1e5 events in one forcing
// period with `Status::Chatter` — and (b) states on the threshold to
// rounding, where a wrong tie-break would switch back and forth at one
// instant (the MAX_INSTANT_SWITCHES guard, and the regression test below).
// ---------------------------------------------------------------------------

use std::sync::mpsc;
use std::time::{Duration, Instant};
use stickslip::model::Drive;
use stickslip::sim::numeric::{NumericOptions, NumericSim};
use stickslip::sim::rk4::Rk4;
use stickslip::sim::RunEnd;

/// Runs `f` on a worker thread; a run that does not return within `secs`
/// fails the test instead of hanging it.
fn within<T: Send + 'static>(secs: u64, what: &str, f: impl FnOnce() -> T + Send + 'static) -> T {
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        let _ = tx.send(f());
    });
    match rx.recv_timeout(Duration::from_secs(secs)) {
        Ok(v) => v,
        Err(_) => panic!("{what}: no result within {secs} s (hang)"),
    }
}

/// Event statistics for the cluster tests.
#[derive(Default, Clone)]
struct Cluster {
    kinds: Vec<EventKind>,
    last_tau: f64,
    out_of_order: bool,
    nan: bool,
    in_period: u64,
    max_in_period: u64,
}

impl Observer for Cluster {
    fn event(&mut self, ev: &Event) {
        self.out_of_order |= ev.tau < self.last_tau;
        self.last_tau = ev.tau;
        self.nan |= ev.x.iter().any(|v| !v.is_finite());
        self.kinds.push(ev.kind);
        self.in_period += 1;
        self.max_in_period = self.max_in_period.max(self.in_period);
    }
    fn period(&mut self, _n: u64, x: &[f64; 4], _m: Mode, _s: &PeriodStats) -> Flow {
        self.nan |= x.iter().any(|v| !v.is_finite());
        self.in_period = 0;
        Flow::Continue
    }
}

fn harmonic(eta: f64) -> Drive {
    Drive::Harmonic {
        eta,
        phase: 0.0,
        amplitude: 1.0,
    }
}

fn run_exact(m: Model, eta: f64, init: Init, periods: u64) -> (RunEnd, Cluster) {
    let mut c = Cluster::default();
    let end = Sim::new(&m, eta).unwrap().run(init, periods, &mut c);
    (end, c)
}

fn run_numeric(m: Model, eta: f64, init: Init, periods: u64) -> (RunEnd, Cluster) {
    let mut c = Cluster::default();
    let sim = NumericSim::new(&m, harmonic(eta), NumericOptions::default()).unwrap();
    let end = sim.run(
        init,
        periods as f64 * (2.0 * std::f64::consts::PI / eta),
        &mut c,
    );
    (end, c)
}

/// A dense but resolved cluster: K1/K2 = 1e6 (fast mode √(k/m) = 500 per
/// unit τ, lightly damped) excited by the drive's start at ζ0 = 1, with a
/// slow drive (η = 0.001, period 6283). M2 reverses twice per fast cycle,
/// ~1e5 events every 630 τ: the first forcing period holds far more than
/// MAX_EVENTS_PER_PERIOD = 1e5 events. Both engines must stop with
/// `Status::Chatter` after exactly 1e5 + 1 events, inside the first period,
/// at the same time (same events), with finite states in order.
#[test]
fn dense_event_cluster_ends_with_chatter() {
    let m = model(4.0, 1e6, 0.005, Law::coulomb(0.375));
    let eta = 0.001;
    let period = 2.0 * std::f64::consts::PI / eta;
    let t0 = Instant::now();
    let (ex, ce) = within(120, "exact engine", move || {
        run_exact(m, eta, Init::rest(), 3)
    });
    let t_exact = t0.elapsed();
    let t0 = Instant::now();
    let (nu, cn) = within(300, "numerical engine", move || {
        run_numeric(m, eta, Init::rest(), 3)
    });
    let t_numeric = t0.elapsed();
    eprintln!(
        "dense cluster: exact {:?} at tau {} after {} events ({t_exact:?}); numeric {:?} at tau {} after {} events ({t_numeric:?})",
        ex.status, ex.tau, ex.events, nu.status, nu.tau, nu.events
    );
    for (name, end, c) in [("exact", &ex, &ce), ("numeric", &nu, &cn)] {
        match &end.status {
            Status::Chatter(why) => assert!(why.contains("events in one forcing period"), "{why}"),
            s => panic!("{name}: expected chatter, got {s:?}"),
        }
        assert_eq!(end.periods, 0, "{name}");
        assert!(end.tau < period, "{name}: {}", end.tau);
        assert_eq!(end.events, 100_001, "{name}");
        assert!(!c.nan && end.x.iter().all(|v| v.is_finite()), "{name}: NaN");
        assert!(!c.out_of_order, "{name}: events out of order");
    }
    // The same cluster: the numerical engine (rtol 1e-10) follows the exact one.
    assert_eq!(ce.kinds, cn.kinds);
    assert!(
        (ex.tau - nu.tau).abs() < 1e-6 * ex.tau,
        "{} vs {}",
        ex.tau,
        nu.tau
    );
}

/// M2 at rest with F = ρs − 5e-15 (inside the tie-break band of
/// `after_slip`, |F| < ρs: the pad holds), F' = 1e-15 > 0, at a maximum of F
/// (F'' < 0): F peaks below ρs, so M2 sticks. Started in slip mode (as a
/// slip that just came to rest there), the engines used to call it a slip
/// along F that cannot start (ζ2'' = F − ρs < 0), come back to rest at once,
/// and repeat: the exact and numerical engines ended at τ = 0 with a false
/// `Chatter`, and the paper's RK4 (no guard) hung. Now every integrator sticks
/// and continues exactly as from the same state started stuck.
#[test]
fn state_on_the_threshold_sticks_instead_of_chattering() {
    let (m, k, d, rs, eta) = (4.0, 1.0, 0.005, 0.375, 0.6);
    let model = model(m, k, d, Law::coulomb(rs));
    // ζ1 = 2 (so ζ1'' < 0: F at a maximum), ζ2 from F, ζ1' from F'.
    let (delta, df) = (5e-15, 1e-15);
    let z1 = 2.0f64;
    let (mut v1, mut z2) = (0.0f64, 0.0f64);
    for _ in 0..60 {
        z2 = z1 + d * v1 - (rs - delta);
        let dd1 = (k - d * v1 - (1.0 + k) * z1 + z2) / m;
        v1 = df - d * dd1;
    }
    let x = [z1, v1, z2, 0.0];
    let f = net_force(&model, &x);
    assert!(f < rs && rs - f < 1e-14, "F - rho_s = {:e}", f - rs);
    let slip = Init {
        x,
        mode: Mode::Slip { dir: 1.0 },
    };
    let stick = Init {
        x,
        mode: Mode::Stick { z2 },
    };
    type Runner = fn(Model, f64, Init, u64) -> (RunEnd, Cluster);
    let rk4: Runner = |m, eta, init, n| {
        let mut c = Cluster::default();
        let end = Rk4::new(&m, eta, 0.01).unwrap().run(init, n, &mut c);
        (end, c)
    };
    for (name, run, tol) in [
        ("exact", run_exact as Runner, 1e-12),
        ("numeric", run_numeric as Runner, 1e-8),
        ("rk4", rk4, 1e-6),
    ] {
        let (a, ca) = within(60, name, move || run(model, eta, slip, 3));
        let (b, cb) = within(60, name, move || run(model, eta, stick, 3));
        assert_eq!(a.status, Status::Completed, "{name}: {:?}", a.status);
        assert_eq!(b.status, Status::Completed, "{name}");
        // Started stuck, the first event is the breakaway; started in slip the
        // run first reports the stick (ζ2' = 0 with |F| < ρs), then the same.
        assert_eq!(ca.kinds.first(), Some(&EventKind::Stick), "{name}");
        assert_eq!(&ca.kinds[1..], &cb.kinds[..], "{name}");
        for i in 0..4 {
            assert!(
                (a.x[i] - b.x[i]).abs() < tol,
                "{name}: x[{i}] {} vs {}",
                a.x[i],
                b.x[i]
            );
        }
    }
}
