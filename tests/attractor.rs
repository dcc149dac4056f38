//! The steady state "from rest" is the one the absorber reaches from rest,
//! and continuation is a time-march of the documented plan.
//!
//! Reference in both tests: a plain time-march by the engine with its own
//! Poincaré-section detector (`sim::simulate`, tolerance 1e-9, period
//! n ≤ 8, at most 20 000 forcing periods). Wherever that march settles,
//! `sweep::steady_state` (closed forms, stick proof, Newton shooting
//! accepted only when the trajectory follows its linearisation, marching)
//! must give the same amplitudes to 1e-6 (relative) and the same period
//! multiple. Points where the march does not settle are counted, not
//! compared (their amplitudes are windows of a non-periodic response).

use stickslip::model::{Absorber, Law, Model};
use stickslip::sim::sweep::{curve, mode_of, steady_state, Direction, SteadyConfig};
use stickslip::sim::{simulate, Init, Sim, SimOptions, Summary};

fn model(law: Law, stop_below: Option<f64>) -> Model {
    Model {
        absorber: Absorber::default(),
        law,
        stop_below,
        contact_stiffness: None,
    }
}

/// Coulomb ρs 0.1–1, static/dynamic with ρd = ρs/2, and the paper's
/// decreasing law (D* = −0.04, interrupted below ρs/2): seven laws.
fn laws() -> Vec<(&'static str, Model)> {
    let sd = |rs: f64| Law::Linear {
        rho_s: rs,
        rho_d: 0.5 * rs,
        slope: 0.0,
        minus: None,
    };
    let dec = |rs: f64| Law::Linear {
        rho_s: rs,
        rho_d: rs,
        slope: -0.04,
        minus: None,
    };
    vec![
        ("coulomb 0.1", model(Law::coulomb(0.1), None)),
        ("coulomb 0.375", model(Law::coulomb(0.375), None)),
        ("coulomb 1", model(Law::coulomb(1.0), None)),
        ("static/dynamic 0.3/0.15", model(sd(0.3), None)),
        ("static/dynamic 0.8/0.4", model(sd(0.8), None)),
        ("decreasing 0.2", model(dec(0.2), Some(0.5))),
        ("decreasing 0.375", model(dec(0.375), Some(0.5))),
    ]
}

/// A static/dynamic pad behind a contact spring κ on the public rig's
/// absorber (m 4, k 1, D 0.003).
fn behind_a_contact(rho_s: f64, rho_d: f64, kappa: f64) -> Model {
    Model {
        absorber: Absorber {
            m: 4.0,
            k: 1.0,
            damping: 0.003,
        },
        law: Law::Linear {
            rho_s,
            rho_d,
            slope: 0.0,
            minus: None,
        },
        stop_below: None,
        contact_stiffness: Some(kappa),
    }
}

/// The plain march from `init` at η, as `simulate --steady` runs it.
fn march(m: &Model, eta: f64, init: Init) -> (Summary, Init) {
    let sim = Sim::new(m, eta).unwrap();
    let opts = SimOptions {
        init,
        shortcuts: false,
        ..SimOptions::default()
    };
    let s = simulate(&sim, &opts, &mut ());
    let x = s.final_state;
    let next = Init {
        x,
        mode: mode_of(m, &x),
    };
    (s, next)
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs().max(1e-12)
}

/// Compares steady_state from rest with the plain march at every η of
/// `etas`; returns (compared, not settled) counts.
fn check_from_rest(name: &str, m: &Model, etas: &[f64]) -> (usize, usize) {
    let cfg = SteadyConfig::default();
    let (mut compared, mut open) = (0, 0);
    for &eta in etas {
        let (r, _) = march(m, eta, Init::rest());
        let (p, _) = steady_state(m, eta, Init::rest(), &cfg).unwrap();
        if r.interrupted {
            assert!(
                p.interrupted,
                "{name} η {eta}: march interrupted, steady_state not"
            );
            continue;
        }
        if !r.steady {
            open += 1;
            continue;
        }
        compared += 1;
        let (a1, a2) = (r.amplitude1.unwrap(), r.amplitude2.unwrap());
        assert!(
            p.steady,
            "{name} η {eta}: march settles, steady_state ({}) not",
            p.method
        );
        let (b1, b2) = (p.amplitude1.unwrap(), p.amplitude2.unwrap());
        assert!(
            rel(b1, a1) <= 1e-6 && (rel(b2, a2) <= 1e-6 || (b2 - a2).abs() <= 1e-9),
            "{name} η {eta}: steady_state ({}) A1 {b1} A2 {b2}, period {:?}; march A1 {a1} A2 {a2}, period {:?}",
            p.method,
            p.period_multiple,
            r.period_multiple
        );
        assert_eq!(
            p.period_multiple, r.period_multiple,
            "{name} η {eta}: period multiple ({}; A1 {b1} vs {a1})",
            p.method
        );
    }
    (compared, open)
}

fn grid(lo: f64, hi: f64, step: f64) -> Vec<f64> {
    let n = ((hi - lo) / step).round() as usize;
    (0..=n).map(|i| lo + step * i as f64).collect()
}

/// The issue's own example: the paper's decreasing law (ρs 0.375,
/// D* −0.04, interrupted below ρs/2) at η = 0.29 reaches a period-3 orbit
/// from rest (A1/A = 1.5648 by a 3000-period march); shooting from the
/// transient used to return a coexisting period-1 orbit (A1/A = 1.4005).
#[test]
fn decreasing_law_at_0_29_from_rest_is_period_3() {
    let m = model(
        Law::Linear {
            rho_s: 0.375,
            rho_d: 0.375,
            slope: -0.04,
            minus: None,
        },
        Some(0.5),
    );
    let (p, _) = steady_state(&m, 0.29, Init::rest(), &SteadyConfig::default()).unwrap();
    assert_eq!(p.period_multiple, Some(3), "{p:?}");
    let (r, _) = march(&m, 0.29, Init::rest());
    assert_eq!(r.period_multiple, Some(3));
    assert!(rel(p.amplitude1.unwrap(), r.amplitude1.unwrap()) < 1e-6);
    assert!((p.amplitude1.unwrap() - 1.5648).abs() < 1e-4);
}

/// CI subset: every law on the low-η region where period-3 orbits live
/// (η 0.2–0.45 in steps of 0.01) and a coarser pass over the rest of the
/// range (0.5–1.6 in steps of 0.05).
#[test]
fn from_rest_equals_plain_march_subset() {
    let mut etas = grid(0.2, 0.45, 0.01);
    etas.extend(grid(0.5, 1.6, 0.05));
    let (mut compared, mut open) = (0, 0);
    for (name, m) in laws() {
        let (c, o) = check_from_rest(name, &m, &etas);
        compared += c;
        open += o;
    }
    eprintln!("compared {compared} points, {open} not settled within 20000 periods");
    assert!(compared > 200, "only {compared} points compared");
}

/// The full grid: seven laws × η 0.2–1.6 in steps of 0.01.
/// `cargo test --release --test attractor -- --ignored`.
#[test]
#[ignore = "long: seven laws x 141 eta with 20000-period marches (release: minutes)"]
fn from_rest_equals_plain_march_full_grid() {
    let etas = grid(0.2, 1.6, 0.01);
    let (mut compared, mut open) = (0, 0);
    for (name, m) in laws() {
        let (c, o) = check_from_rest(name, &m, &etas);
        eprintln!("{name}: compared {c}, not settled {o}");
        compared += c;
        open += o;
    }
    eprintln!("compared {compared} points, {open} not settled within 20000 periods");
    // 908 compared, 46 not settled (2026-11-24); the rest are interrupted.
    assert!(compared >= 850, "only {compared} points compared");
}

/// Continuation (`--direction up|down`) is the time-march of this plan:
/// at each η in turn, march from the carried state until the section
/// repeats (or the 20 000-period budget ends), march on to the next whole
/// multiple of the response's period, and carry that section state (the
/// drive at phase 0: displacement A, velocity 0, so switching η there adds
/// no ramp and no jump) to the next η; after an interrupted point, start
/// from rest.
#[test]
fn continuation_equals_time_march_of_the_plan() {
    let (compared, open) = check_continuation(&laws(), &grid(0.2, 1.6, 0.05));
    eprintln!("compared {compared} points; {open} curves stopped at a non-settled point");
    // 285 of the 14 curves' 406 points are compared today (6 curves reach a
    // non-settled point); a regression that stopped comparing would show.
    assert!(compared >= 250, "{compared}");
}

/// The same on the figures' grid (η 0.2–1.6 in steps of 0.01), with Fig. 5's
/// ρs = 1, ρd = 0.5 added (its upward curve changed with the attractor fix
/// at η 0.92–0.96). `cargo test --release --test attractor -- --ignored`.
#[test]
#[ignore = "long: eight laws x 141 eta, both directions, 20000-period marches"]
fn continuation_equals_time_march_of_the_plan_full_grid() {
    let mut l = laws();
    l.push((
        "static/dynamic 1/0.5",
        model(
            Law::Linear {
                rho_s: 1.0,
                rho_d: 0.5,
                slope: 0.0,
                minus: None,
            },
            None,
        ),
    ));
    let (compared, open) = check_continuation(&l, &grid(0.2, 1.6, 0.01));
    eprintln!("compared {compared} points; {open} curves stopped at a non-settled point");
}

/// Runs every law's curves up and down against the plain march of the
/// plan; returns (points compared, curves stopped at a non-settled point).
fn check_continuation(laws: &[(&str, Model)], etas: &[f64]) -> (usize, usize) {
    let cfg = SteadyConfig::default();
    let (mut compared, mut open) = (0, 0);
    for &(name, m) in laws {
        for dir in [Direction::Up, Direction::Down] {
            let pts = curve(&m, etas, dir, &cfg).unwrap();
            let mut order: Vec<usize> = (0..etas.len()).collect();
            if dir == Direction::Down {
                order.reverse();
            }
            let mut state = Init::rest();
            for i in order {
                let eta = etas[i];
                let (r, next) = march(&m, eta, state);
                let p = &pts[i];
                if r.interrupted {
                    assert!(p.interrupted, "{name} {dir:?} η {eta}");
                    state = Init::rest();
                    continue;
                }
                if !r.steady {
                    // A non-periodic response: the plan's later states depend
                    // on round-off along 20 000 periods; stop this curve.
                    open += 1;
                    break;
                }
                let q = r.period_multiple.unwrap() as u64;
                let extra = (q - r.periods % q) % q;
                state = if extra > 0 {
                    let sim = Sim::new(&m, eta).unwrap();
                    let opts = SimOptions {
                        periods: Some(extra),
                        init: next,
                        shortcuts: false,
                        ..SimOptions::default()
                    };
                    let s = simulate(&sim, &opts, &mut ());
                    Init {
                        x: s.final_state,
                        mode: mode_of(&m, &s.final_state),
                    }
                } else {
                    next
                };
                let (a1, b1) = (r.amplitude1.unwrap(), p.amplitude1.unwrap());
                assert!(
                    p.steady && rel(b1, a1) <= 1e-6 && p.period_multiple == r.period_multiple,
                    "{name} {dir:?} η {eta}: curve ({}) A1 {b1} period {:?}; march A1 {a1} period {:?}",
                    p.method,
                    p.period_multiple,
                    r.period_multiple
                );
                compared += 1;
            }
        }
    }
    (compared, open)
}

/// The marching fallback's early stop (`SteadyConfig::early_stop`, stage 5
/// of `steady_state`) may only classify a point as `not-settling` where
/// the plain 20 000-period march from the same state does not settle
/// either; where it fires it must save periods, and the range it reports
/// must hold the amplitudes of the periods it saw. Checked on `etas` for
/// every law of `laws` from rest; returns (early stops, points).
fn early_stop_only_where_march_does_not_settle(
    laws: &[(&str, Model)],
    etas: &[f64],
) -> (usize, usize) {
    let cfg = SteadyConfig {
        early_stop: true,
        ..SteadyConfig::default()
    };
    let (mut fired, mut points) = (0, 0);
    for &(name, m) in laws {
        for &eta in etas {
            points += 1;
            let (p, _) = steady_state(&m, eta, Init::rest(), &cfg).unwrap();
            if p.method != "not-settling" {
                continue;
            }
            fired += 1;
            let (r, _) = march(&m, eta, Init::rest());
            assert!(
                !r.steady,
                "{name} η {eta}: stopped early as not settling after {} periods, but the plain march settles (period {:?}, A1 {:?})",
                p.periods,
                r.period_multiple,
                r.amplitude1
            );
            assert!(p.periods < cfg.max_periods, "{name} η {eta}: saved nothing");
            assert!(!p.steady && p.period_multiple.is_none());
            let g = p.range.expect("a not-settling point reports its range");
            let a1 = p.amplitude1.unwrap();
            assert!(
                g.amplitude1_min <= g.amplitude1_max
                    && g.amplitude2_min <= g.amplitude2_max
                    && g.amplitude1_min > 0.0,
                "{name} η {eta}: range {g:?}"
            );
            // The reported amplitude is a window of the last ≤ 50 periods:
            // within the range seen (up to the window's merging of periods).
            assert!(
                a1 >= g.amplitude1_min * (1.0 - 1e-12),
                "{name} η {eta}: A1 {a1} below the range {g:?}"
            );
        }
    }
    (fired, points)
}

/// CI subset of the grid below (the low-η region where period-3 orbits and
/// non-periodic responses live, and a coarse pass over the rest).
#[test]
fn early_stop_only_where_march_does_not_settle_subset() {
    let mut etas = grid(0.2, 0.45, 0.01);
    etas.extend(grid(0.5, 1.6, 0.05));
    let (fired, points) = early_stop_only_where_march_does_not_settle(&laws(), &etas);
    eprintln!("early stop fired at {fired} of {points} points");
    assert!(fired > 0, "the subset must exercise the early stop");
}

/// Behind a contact spring the early stop's tangent is carried in the
/// extended state (the held slider's position a fifth coordinate, issue
/// 34): a quasi-periodic response of a compliant pad (κ 5, ρs 0.5, ρd 0.4,
/// D 0.003, η 0.96 from rest) stops early as `not-settling`, where the
/// plain 20 000-period march does not settle either. (Before, the tangent
/// was not carried behind a contact and such points marched to the end of
/// the budget.)
#[test]
fn early_stop_behind_a_contact_spring() {
    let m = behind_a_contact(0.5, 0.4, 5.0);
    let (fired, points) = early_stop_only_where_march_does_not_settle(&[("κ 5", m)], &[0.96]);
    assert_eq!((fired, points), (1, 1));
}

/// The attractor issue's full grid: seven laws × η 0.2–1.6 in steps of
/// 0.01, from rest. `cargo test --release --test attractor -- --ignored`.
#[test]
#[ignore = "long: seven laws x 141 eta, a 20000-period march at every early stop"]
fn early_stop_only_where_march_does_not_settle_full_grid() {
    let (fired, points) =
        early_stop_only_where_march_does_not_settle(&laws(), &grid(0.2, 1.6, 0.01));
    eprintln!("early stop fired at {fired} of {points} points");
    assert!(fired > 0);
}

/// Laws on the absorber of the early stop's counterexample below (m = 2,
/// k = 0.5, D = 0.01): its own law and four others.
fn other_absorber_laws() -> Vec<(&'static str, Model)> {
    let on = |law: Law, stop_below: Option<f64>| Model {
        absorber: Absorber {
            m: 2.0,
            k: 0.5,
            damping: 0.01,
        },
        law,
        stop_below,
        contact_stiffness: None,
    };
    let lin = |rho_s: f64, rho_d: f64, slope: f64| Law::Linear {
        rho_s,
        rho_d,
        slope,
        minus: None,
    };
    vec![
        (
            "m 2: static/dynamic 0.8/0.48",
            on(lin(0.8, 0.48, 0.0), None),
        ),
        ("m 2: coulomb 0.3", on(Law::coulomb(0.3), None)),
        ("m 2: coulomb 0.8", on(Law::coulomb(0.8), None)),
        (
            "m 2: static/dynamic 0.5/0.25",
            on(lin(0.5, 0.25, 0.0), None),
        ),
        ("m 2: decreasing 0.4", on(lin(0.4, 0.4, -0.04), Some(0.5))),
    ]
}

/// The same check on another absorber, η 0.3–1.2 in steps of 0.01.
/// `cargo test --release --test attractor -- --ignored`.
#[test]
#[ignore = "long: five laws x 91 eta, a 20000-period march at every early stop"]
fn early_stop_only_where_march_does_not_settle_other_absorber() {
    let (fired, points) =
        early_stop_only_where_march_does_not_settle(&other_absorber_laws(), &grid(0.3, 1.2, 0.01));
    eprintln!("early stop fired at {fired} of {points} points");
    assert!(fired > 0, "the grid must exercise the early stop");
}

/// The counterexample of the early stop's first criterion: on another
/// absorber (m = 2, k = 0.5, D = 0.01; ρs 0.8, ρd 0.48, η 0.62) the
/// trajectory from rest wanders chaotically for thousands of periods, its
/// section coming no closer to any orbit, yet the plain march settles.
/// Its finite-time Lyapunov exponent (+0.07…+0.11 per period) tells it
/// from a quasi-periodic response, so the early stop holds off; both the
/// default and the early stop find that steady state. How long a chaotic
/// transient lasts depends on every rounding of the trajectory (12 045
/// periods with one event-refinement sequence, 23 959 with another that
/// moves events by a rounding step), so the march here has a budget of
/// 100 000 periods; what must hold is that the early stop does not fire.
#[test]
fn early_stop_counterexample_settles_by_default() {
    const BUDGET: u64 = 100_000;
    let m = Model {
        absorber: Absorber {
            m: 2.0,
            k: 0.5,
            damping: 0.01,
        },
        law: Law::Linear {
            rho_s: 0.8,
            rho_d: 0.48,
            slope: 0.0,
            minus: None,
        },
        stop_below: None,
        contact_stiffness: None,
    };
    let eta = 0.62;
    let sim = Sim::new(&m, eta).unwrap();
    let opts = SimOptions {
        init: Init::rest(),
        shortcuts: false,
        max_periods: BUDGET,
        ..SimOptions::default()
    };
    let r = simulate(&sim, &opts, &mut ());
    assert!(r.steady, "the plain march settles here");
    let default = SteadyConfig {
        max_periods: BUDGET,
        ..SteadyConfig::default()
    };
    let (p, _) = steady_state(&m, eta, Init::rest(), &default).unwrap();
    assert!(p.steady, "default steady_state: {}", p.method);
    assert!(rel(p.amplitude1.unwrap(), r.amplitude1.unwrap()) <= 1e-6);
    let early = SteadyConfig {
        early_stop: true,
        ..default
    };
    let (q, _) = steady_state(&m, eta, Init::rest(), &early).unwrap();
    assert!(
        q.steady && rel(q.amplitude1.unwrap(), r.amplitude1.unwrap()) <= 1e-6,
        "the early stop must not fire on this chaotic transient: {} after {} periods",
        q.method,
        q.periods
    );
}

/// Shooting's acceptance needs the trajectory to keep the orbit's
/// switching events. At ρs 0.9, ρd 0.7, κ 60 (m 4, k 1, D 0.003), η 0.8
/// Newton finds a weakly stable period-1 orbit (A1 0.884, multipliers of
/// modulus 0.996) that the response from rest wanders around (A1 about
/// 1.2, extra stick phases in some periods); its deviations followed the
/// linearisation within 10 % for three iterates, and the orbit was
/// reported as the steady state from rest (until session 38). The plain
/// 20 000-period march from rest does not settle.
#[test]
fn shooting_does_not_report_an_orbit_the_trajectory_wanders_around() {
    let m = behind_a_contact(0.9, 0.7, 60.0);
    let (p, _) = steady_state(&m, 0.8, Init::rest(), &SteadyConfig::default()).unwrap();
    assert_ne!(p.method, "shooting", "{p:?}");
    assert!(!p.steady, "{p:?}");
    let a1 = p.amplitude1.unwrap();
    assert!(
        a1 > 1.1,
        "A1 {a1}: the orbit's 0.884, not the wandering response"
    );
    let (r, _) = march(&m, 0.8, Init::rest());
    assert!(!r.steady && !r.interrupted);
}
