//! Numerical stress suite: the edges of the parameter space (D = 0, ρs → 0⁺
//! and huge, D* < −D, η tiny and large, extreme m and k, grazing), dense
//! event clusters (chatter; why genuine Zeno cannot occur), long-run
//! invariants over 10⁵ periods (energy balance, |stick force| ≤ ρs, event
//! order, no drift of a periodic orbit) and determinism for 1 and N threads.
//! Every run must end with a clear status (completed, steady, interrupted,
//! chatter), never hang, never produce NaN.
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
        contact_stiffness: None,
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
        // Further out: ρs at the bottom and top of the floating-point range,
        // η 1e-4 and 1e3, m and k over ±4 decades (ρs scaled to the response
        // so that M2 slides), D = 0 with a static > dynamic law.
        (model(4.0, 1.0, 0.005, Law::coulomb(1e-300)), 0.6),
        (model(4.0, 1.0, 0.005, Law::coulomb(1e300)), 0.6),
        (model(4.0, 1.0, 0.005, Law::coulomb(0.375)), 1e-4),
        (model(4.0, 1.0, 0.005, Law::coulomb(1e-9)), 1e3),
        (model(1e-4, 1.0, 0.005, Law::coulomb(0.375)), 0.6),
        (model(1e4, 1.0, 0.005, Law::coulomb(1e-5)), 0.6),
        (model(4.0, 1e-4, 0.005, Law::coulomb(1e-6)), 0.6),
        (model(4.0, 1e4, 0.005, Law::coulomb(0.375)), 0.6),
        (
            model(
                4.0,
                1.0,
                0.0,
                Law::Linear {
                    rho_s: 0.5,
                    rho_d: 0.25,
                    slope: 0.0,
                    minus: None,
                },
            ),
            0.6,
        ),
    ];
    for (m, eta) in cases {
        // Tens of natural periods of the absorber at least.
        let periods = if eta < 0.1 {
            3
        } else if eta > 100.0 {
            20_000
        } else {
            50
        };
        let (status, w) = check(m, eta, periods);
        assert_eq!(status, Status::Completed, "{m:?} eta {eta}");
        eprintln!("{m:?} eta {eta}: {} events", w.events);
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
            minus: None,
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
                minus: None,
            },
            0.6,
        ),
        (
            Law::Linear {
                rho_s: 0.375,
                rho_d: 0.375,
                slope: -0.04,
                minus: None,
            },
            0.9,
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

/// Determinism for 1 and N threads on the edges: frequency-response families
/// of edge models (D = 0, ρs → 0⁺, static > dynamic, negative slip damping
/// with the interruption rule, K1/K2 = 1e3: a fast mode), continued upwards
/// and from rest, settled by every method (shooting, marching, stick proof,
/// not settled, interrupted), are bit-identical on 1, 2 and 4 worker
/// threads.
#[test]
fn edge_families_do_not_depend_on_thread_count() {
    use stickslip::sim::sweep::{eta_grid, family, CurveSpec, Direction, Shard, SteadyConfig};
    let models = [
        model(4.0, 1.0, 0.0, Law::coulomb(0.375)),
        model(4.0, 1.0, 0.005, Law::coulomb(1e-9)),
        model(
            4.0,
            1.0,
            0.005,
            Law::Linear {
                rho_s: 0.6,
                rho_d: 0.3,
                slope: 0.0,
                minus: None,
            },
        ),
        Model {
            stop_below: Some(0.5),
            ..model(
                4.0,
                1.0,
                0.005,
                Law::Linear {
                    rho_s: 0.3,
                    rho_d: 0.3,
                    slope: -0.05,
                    minus: None,
                },
            )
        },
        model(4.0, 1e3, 0.005, Law::coulomb(0.375)),
    ];
    let specs: Vec<CurveSpec> = models
        .iter()
        .flat_map(|&model| {
            [Direction::Up, Direction::Rest].map(|direction| CurveSpec { model, direction })
        })
        .collect();
    let etas = eta_grid(0.45, 1.65, 7);
    let cfg = SteadyConfig {
        max_periods: 2_000,
        ..SteadyConfig::default()
    };
    let on = |n: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .unwrap()
            .install(|| family(&specs, &etas, &cfg, Shard::ALL, &|_| {}).unwrap())
    };
    let one = on(1);
    assert_eq!(one.len(), specs.len() * etas.len());
    // Bitwise: compare the f64 fields through their bits (NaN-safe).
    let bits = |rows: &[stickslip::sim::sweep::Row]| -> Vec<String> {
        rows.iter()
            .map(|r| {
                let v = &r.value;
                format!(
                    "{} {} {:x} {:?} {:?} {} {:?} {:x} {} {} {}",
                    r.curve,
                    r.point,
                    v.eta.to_bits(),
                    v.amplitude1.map(f64::to_bits),
                    v.amplitude2.map(f64::to_bits),
                    v.steady,
                    v.period_multiple,
                    v.stick_fraction.to_bits(),
                    v.interrupted,
                    v.periods,
                    v.method
                )
            })
            .collect()
    };
    let methods: std::collections::BTreeSet<&str> = one.iter().map(|r| r.value.method).collect();
    eprintln!("edge families: {} points, methods {methods:?}", one.len());
    assert!(methods.contains("interrupted"), "{methods:?}");
    for n in [2, 4] {
        assert_eq!(bits(&one), bits(&on(n)), "{n} threads");
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
    for eta in [0.3, 0.9, 1.3, 3.0, 8.0] {
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

/// The configurations one might suspect of Zeno behaviour all run to a clear
/// status in bounded time, with resolved (sparse) events: a Stribeck drop
/// from ρs = 0.5 to ρd = 0.02 within v_s = 1e-12 and 1e-300 (numerical
/// engine; with `stop_below` 0.5 the drop interrupts at once), a negative
/// slope exactly at −D (undamped relative slip: slips return to rest
/// tangentially), ρs → 0⁺ without damping (a reversal at every velocity zero),
/// a fast mode K1/K2 = 1e6 at an ordinary η. A law whose sliding force at
/// v → 0⁺ exceeds ρs (what the pad can hold at rest) would make M2 stick
/// and slip at once — the only source of Zeno switching here — and is
/// refused by validation.
#[test]
fn suspect_scenarios_end_cleanly() {
    type Case = (&'static str, Model, f64, u64, bool);
    let stribeck = |v_s: f64, stop: Option<f64>| Model {
        stop_below: stop,
        ..model(
            4.0,
            1.0,
            0.005,
            Law::Shaped {
                kind: stickslip::model::LawKind::Stribeck,
                rho_s: 0.5,
                rho_d: 0.02,
                slope: 0.0,
                v_s,
                minus: None,
            },
        )
    };
    let minus_d = |rs: f64| {
        model(
            4.0,
            1.0,
            0.005,
            Law::Linear {
                rho_s: rs,
                rho_d: rs,
                slope: -0.005,
                minus: None,
            },
        )
    };
    // (name, model, eta, periods, numerical engine only)
    let cases: [Case; 9] = [
        ("stribeck v_s 1e-12", stribeck(1e-12, None), 0.6, 50, true),
        ("stribeck v_s 1e-300", stribeck(1e-300, None), 0.3, 50, true),
        (
            "stribeck v_s 1e-300 stop 0.5",
            stribeck(1e-300, Some(0.5)),
            0.6,
            50,
            true,
        ),
        ("D* = -D rs 0.375 eta 0.3", minus_d(0.375), 0.3, 500, false),
        ("D* = -D rs 0.375 eta 0.8", minus_d(0.375), 0.8, 500, false),
        ("D* = -D rs 0.7 eta 0.6", minus_d(0.7), 0.6, 500, false),
        (
            "rs 1e-12, D = 0",
            model(4.0, 1.0, 0.0, Law::coulomb(1e-12)),
            0.6,
            500,
            false,
        ),
        (
            "k 1e6",
            model(4.0, 1e6, 0.005, Law::coulomb(0.375)),
            0.6,
            20,
            false,
        ),
        (
            "m 1e-4",
            model(1e-4, 1.0, 0.005, Law::coulomb(0.375)),
            0.6,
            20,
            false,
        ),
    ];
    for (name, m, eta, periods, numeric_only) in cases {
        let mut runs = vec![(
            "numeric",
            within(120, name, move || {
                run_numeric(m, eta, Init::rest(), periods)
            }),
        )];
        if !numeric_only {
            runs.push((
                "exact",
                within(120, name, move || run_exact(m, eta, Init::rest(), periods)),
            ));
        }
        for (engine, (end, c)) in runs {
            let per_period = c.max_in_period;
            eprintln!(
                "{name} ({engine}): {:?}, {} events, at most {per_period} in a period",
                end.status, end.events
            );
            let expect_interrupt = m.stop_below.is_some();
            match &end.status {
                Status::Completed => assert!(!expect_interrupt, "{name}"),
                Status::Interrupted(_) => assert!(expect_interrupt, "{name} ({engine})"),
                s => panic!("{name} ({engine}): {s:?}"),
            }
            assert!(!c.nan && end.x.iter().all(|v| v.is_finite()), "{name}: NaN");
            assert!(!c.out_of_order, "{name}: events out of order");
            // Resolved, sparse events: far below the chatter guard.
            assert!(
                per_period <= 20,
                "{name} ({engine}): {per_period} events in a period"
            );
        }
    }
    for law in [
        Law::Linear {
            rho_s: 0.3,
            rho_d: 0.4,
            slope: 0.0,
            minus: None,
        },
        Law::Shaped {
            kind: stickslip::model::LawKind::Stribeck,
            rho_s: 0.3,
            rho_d: 0.4,
            slope: 0.0,
            v_s: 0.01,
            minus: None,
        },
    ] {
        let m = model(4.0, 1.0, 0.005, law);
        assert!(NumericSim::new(&m, harmonic(0.6), NumericOptions::default()).is_err());
        assert!(Sim::new(&m, 0.6).is_err());
    }
}

// ---------------------------------------------------------------------------
// Energy balance over long runs
// ---------------------------------------------------------------------------

/// Gauss–Legendre nodes on [−1, 1] (10 points, ascending) and weights.
fn gl10() -> [(f64, f64); 10] {
    const H: [(f64, f64); 5] = [
        (0.148_874_338_981_631_2, 0.295_524_224_714_752_9),
        (0.433_395_394_129_247_2, 0.269_266_719_309_996_4),
        (0.679_409_568_299_024_4, 0.219_086_362_515_982_04),
        (0.865_063_366_688_984_5, 0.149_451_349_150_580_6),
        (0.973_906_528_517_171_7, 0.066_671_344_308_688_14),
    ];
    std::array::from_fn(|i| {
        if i < 5 {
            (-H[4 - i].0, H[4 - i].1)
        } else {
            H[i - 5]
        }
    })
}

/// Neumaier-compensated sum.
#[derive(Default, Clone, Copy)]
struct Sum {
    s: f64,
    c: f64,
}
impl Sum {
    fn add(&mut self, v: f64) {
        let t = self.s + v;
        self.c += if self.s.abs() >= v.abs() {
            (self.s - t) + v
        } else {
            (v - t) + self.s
        };
        self.s = t;
    }
    fn get(&self) -> f64 {
        self.s + self.c
    }
}

/// Pass 1: the event times.
#[derive(Default)]
struct EventTimes(Vec<f64>);
impl Observer for EventTimes {
    fn event(&mut self, ev: &Event) {
        self.0.push(ev.tau);
    }
    fn wants_extremes(&self) -> bool {
        false
    }
}

/// Pass 2: the power terms at Gauss–Legendre nodes of every phase of one
/// forcing period, accumulated over the run. The phases are known from pass
/// 1 (the engine is deterministic); each is cut into pieces of at most one
/// radian of the fastest rate present, 10 nodes each (exact to rounding for
/// the exponential-polynomial integrands of a linear phase: the neglected
/// term is below (ωh/2)^20/20! < 1e-18 relative).
struct Balance {
    m: Model,
    eta: f64,
    /// Phase boundaries in the current period (offsets), ascending.
    bounds: Vec<f64>,
    hmax: f64,
    gl: [(f64, f64); 10],
    // node generator
    j: usize,
    piece: usize,
    pieces: usize,
    node: usize,
    cur: Option<(f64, f64)>,
    // results
    w_drive: Sum,
    w_visc: Sum,
    w_fric: Sum,
    /// Σ w·(|drive| + visc + |fric|): the scale of evaluation rounding.
    abs: f64,
    /// Σ w·|Q'|·ulp(τ): the worst-case effect of sample-time rounding.
    jitter: f64,
    /// Largest |ζ1|, |ζ2| sampled.
    amplitude: f64,
    samples: u64,
}

impl Balance {
    fn new(m: Model, eta: f64, hmax: f64) -> Self {
        Self {
            m,
            eta,
            bounds: Vec::new(),
            hmax,
            gl: gl10(),
            j: 0,
            piece: 0,
            pieces: 0,
            node: 0,
            cur: None,
            w_drive: Sum::default(),
            w_visc: Sum::default(),
            w_fric: Sum::default(),
            abs: 0.0,
            jitter: 0.0,
            amplitude: 0.0,
            samples: 0,
        }
    }

    /// Starts a period whose events (offsets) are `events`.
    fn period_with(&mut self, events: &[f64]) {
        let t = 2.0 * std::f64::consts::PI / self.eta;
        self.bounds.clear();
        self.bounds.push(0.0);
        for &e in events {
            if e > *self.bounds.last().unwrap() && e < t {
                self.bounds.push(e);
            }
        }
        self.bounds.push(t);
        self.j = 0;
        self.piece = 0;
        self.node = 0;
        self.pieces = self.pieces_of(0);
    }

    fn pieces_of(&self, j: usize) -> usize {
        let len = self.bounds[j + 1] - self.bounds[j];
        ((len / self.hmax).ceil() as usize).max(1)
    }
}

fn ulp(x: f64) -> f64 {
    let x = x.abs();
    f64::from_bits(x.to_bits() + 1) - x
}

impl Observer for Balance {
    fn wants_extremes(&self) -> bool {
        false
    }
    fn next_sample(&mut self) -> Option<f64> {
        loop {
            if self.j + 1 >= self.bounds.len() {
                return None;
            }
            if self.node == 10 {
                self.node = 0;
                self.piece += 1;
            }
            if self.piece == self.pieces {
                self.j += 1;
                self.piece = 0;
                if self.j + 1 >= self.bounds.len() {
                    return None;
                }
                self.pieces = self.pieces_of(self.j);
                continue;
            }
            let (a, b) = (self.bounds[self.j], self.bounds[self.j + 1]);
            let h = (b - a) / self.pieces as f64;
            let mid = a + (self.piece as f64 + 0.5) * h;
            let (xi, wi) = self.gl[self.node];
            self.node += 1;
            let ts = mid + xi * 0.5 * h;
            self.cur = Some((ts, wi * 0.5 * h));
            return Some(ts);
        }
    }
    fn sample(&mut self, tau: f64, x: &[f64; 4], dx: &[f64; 4]) {
        let (ts, w) = self.cur.take().expect("a requested sample");
        assert_eq!(ts, tau);
        let ab = &self.m.absorber;
        let (k, d) = (ab.k, ab.damping);
        let z0 = (self.eta * tau).cos();
        let v = x[3];
        let (g, dg) = if v != 0.0 {
            (
                self.m.law.sliding(v.abs()),
                self.m.law.sliding_slope(v.abs()),
            )
        } else {
            (0.0, 0.0)
        };
        let drive = k * z0 * x[1];
        let rel = x[1] - x[3];
        let visc = d * rel * rel;
        let fric = g * v.abs();
        self.w_drive.add(w * drive);
        self.w_visc.add(w * visc);
        self.w_fric.add(w * fric);
        self.abs += w * (drive.abs() + visc + fric.abs());
        // The engine evaluates the phase at fl(τ − τ_phase start): off by up
        // to ulp(τ) from the node, which moves the state-dependent part of
        // the integrand by Q'·δ, Q' = d/dτ (kζ0ζ1' − D(ζ1' − ζ2')² − g|ζ2'|)
        // at fixed ζ0.
        let q1 = k * z0 * dx[1]
            - 2.0 * d * rel * (dx[1] - dx[3])
            - (dg * v.abs() + g) * v.signum() * dx[3];
        self.jitter += w * q1.abs() * ulp(tau);
        self.amplitude = self.amplitude.max(x[0].abs()).max(x[2].abs());
        self.samples += 1;
    }
}

fn energy(m: &Model, x: &[f64; 4]) -> f64 {
    let ab = &m.absorber;
    0.5 * (ab.m * x[1] * x[1] + x[3] * x[3] + ab.k * x[0] * x[0] + (x[0] - x[2]).powi(2))
}

/// Energy balance from rest over `periods` periods, for the three laws of
/// the paper: work of the drive force kζ0 on M1 = change of the mechanical
/// energy E = ½mζ1'² + ½ζ2'² + ½kζ1² + ½(ζ1 − ζ2)² + damper dissipation
/// ∫D(ζ1' − ζ2')² + friction dissipation ∫g(|ζ2'|)|ζ2'| (the energy equation
/// of eqs. 1–2; stick phases dissipate nothing since ζ2' ≡ 0).
///
/// The run is integrated one period per `run` call, each starting from the
/// previous end state and mode — bit for bit the trajectory of one long run
/// (asserted: the engine restarts its phases at every period start anyway) —
/// so that the observer's sample times are period offsets, not τ ≈ 1e6
/// (whose ulp, 1.2e-10, would shift the engine's evaluation point by a
/// rounding that repeats identically every period on a periodic orbit and
/// so accumulates to ~1e-11 W).
///
/// Error budget (the tolerance is computed from the run, not chosen): the
/// integrals are Gauss–Legendre sums (quadrature error < 1e-18 relative),
/// compensated (Neumaier), of the engine's closed-form phase solutions; what
/// remains is
/// * sample-time rounding: the engine evaluates at fl(τ − τ_start), off by
///   ≤ ulp(τ) (τ < 11), moving each node value by ≤ |Q'|·ulp(τ); on a
///   periodic orbit these repeat with the same sign every period, so they
///   are bounded by their absolute sum Σw|Q'|ulp(τ), not a random walk;
/// * evaluation rounding of the closed forms and the power terms: a few ε
///   relative to what the closed form adds up — the state and the phase's
///   forced (particular) response, whose amplitude A_p is the frictionless or
///   stuck steady response at η (near η2 = 1.144 it exceeds the orbit: at
///   η = 1.1 A_p = 2.47 while max|ζ| = 1.04) — again repeating every period:
///   ≤ 16ε·κ·Σw(|terms|), κ = 1 + A_p/max|ζ|;
/// * the end energy: ≤ 16ε·E.
fn energy_balance(periods: u64) {
    let decreasing = Law::Linear {
        rho_s: 0.375,
        rho_d: 0.375,
        slope: -0.04,
        minus: None,
    };
    let static_dynamic = Law::Linear {
        rho_s: 0.5,
        rho_d: 0.25,
        slope: 0.0,
        minus: None,
    };
    for (law, eta) in [
        (Law::coulomb(0.375), 0.6),
        (decreasing, 0.9),
        (static_dynamic, 1.1),
    ] {
        let m = model(4.0, 1.0, 0.005, law);
        let sim = Sim::new(&m, eta).unwrap();
        let t0 = Instant::now();
        // One radian of the fastest rate: the engine's bracketing step.
        let (_, e2) = m.absorber.eta_linear();
        let hmax = 1.0 / e2.max(eta);
        let mut bal = Balance::new(m, eta, hmax);
        let mut init = Init::rest();
        let mut events = 0;
        for _ in 0..periods {
            let mut ev = EventTimes::default();
            let e1 = sim.run(init, 1, &mut ev);
            assert_eq!(e1.status, Status::Completed, "{law}");
            bal.period_with(&ev.0);
            let e2 = sim.run(init, 1, &mut bal);
            assert_eq!((e1.x, e1.mode), (e2.x, e2.mode));
            events += e2.events;
            init = Init {
                x: e2.x,
                mode: e2.mode,
            };
        }
        // The same trajectory as one long run.
        let whole = sim.run(Init::rest(), periods, &mut ());
        assert_eq!(
            whole.x, init.x,
            "{law}: chained periods differ from one run"
        );
        assert_eq!(whole.events, events);
        let (w, dv, df) = (bal.w_drive.get(), bal.w_visc.get(), bal.w_fric.get());
        let e_end = energy(&m, &init.x);
        let res = w - e_end - dv - df;
        let ab = &m.absorber;
        let (f1, f2) = stickslip::sim::linear::free_amplitudes(ab, law.slope(), eta);
        let (s1, _) = stickslip::sim::linear::stuck_amplitudes(ab, eta);
        let kappa = 1.0 + f1.max(f2).max(s1) / bal.amplitude;
        let eval = 16.0 * f64::EPSILON * (kappa * bal.abs + e_end);
        let tol = bal.jitter + eval;
        eprintln!(
            "{law} eta {eta}, {periods} periods, {events} events, {} samples, {:.1?}: W {w:.9e} dE {e_end:.3e} visc {dv:.6e} fric {df:.9e}; residual {res:.3e} = {:.2e} W; bound: time rounding {:.2e} + evaluation {eval:.2e} (kappa {kappa:.2}) = {:.2e} W",
            bal.samples,
            t0.elapsed(),
            res / w,
            bal.jitter,
            tol / w
        );
        assert!(res.abs() <= tol, "{law}: energy residual {res:e} > {tol:e}");
    }
}

#[test]
fn energy_balance_over_2e4_periods() {
    energy_balance(20_000);
}

/// The 10⁵-period variant: 18 s in the debug test profile (2 cores), hence
/// ignored there; `cargo test --release --test stress -- --ignored` runs it.
#[test]
#[ignore]
fn energy_balance_over_1e5_periods() {
    energy_balance(100_000);
}

/// Extreme stiffness: m = 1e-6 with k = 1e6 puts the fastest mode near
/// 1e6 (τ units), about 1e7 bracketing steps per forcing period at η = 0.6
/// (a run measured at ~59 s per period) and 1e9 at η = 0.01. The exact
/// and the numerical engines refuse such a model at once with the numbers
/// instead of computing for hours; three decades less stiff still runs.
#[test]
fn extreme_stiffness_is_refused_not_computed() {
    use stickslip::sim::SimError;
    let t0 = std::time::Instant::now();
    for eta in [0.6, 0.01] {
        let m = model(1e-6, 1e6, 0.005, Law::coulomb(0.375));
        match Sim::new(&m, eta) {
            Err(SimError::Unsupported(msg)) => {
                assert!(msg.contains("too stiff"), "{msg}")
            }
            Err(e) => panic!("η {eta}: unexpected error {e}"),
            Ok(_) => panic!("η {eta}: an hours-long model was accepted"),
        }
        let num = NumericSim::new(
            &m,
            harmonic(eta),
            NumericOptions {
                rtol: 1e-8,
                atol: 1e-10,
            },
        );
        assert!(
            matches!(&num, Err(SimError::Unsupported(msg)) if msg.contains("too stiff")),
            "numerical engine, η {eta}: {:?}",
            num.err()
        );
    }
    assert!(
        t0.elapsed().as_secs_f64() < 5.0,
        "refusal must be immediate"
    );
    // Within the budget: m = 1e-3, k = 1e3 at η = 0.6 (~1e3·2π/0.6 ≈ 1e4 steps).
    let m = model(1e-3, 1e3, 0.005, Law::coulomb(0.375));
    let (status, w) = check(m, 0.6, 20);
    assert!(!matches!(status, Status::Chatter(_)), "{status:?}");
    assert!(w.events > 0);
}
