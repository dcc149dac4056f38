//! Steady states and frequency-response curves (paper §3, Figs. 3–5).
//!
//! One steady state, cheapest sure method first:
//! 1. the linear limits in closed form (ρs = 0: 2-DOF; ρs = ∞: 1-DOF);
//! 2. a short transient by the exact engine, watched on the Poincaré
//!    section (stick phases often reach the periodic orbit in finite time);
//! 3. a **proven permanent stick**: M2 sticks at the section and the
//!    1-DOF motion can never load the pad up to ρs — the contact force is
//!    bounded by its steady part plus a bound on the decaying free part from
//!    its (non-increasing) energy — so the answer is the 1-DOF closed form
//!    (tried after 2, 4, 8 and 16 periods of the transient: a proof that
//!    holds stays true);
//! 4. **Newton shooting** on the p-th return map P^p (p ≤ 8, the smallest
//!    p whose section return distance ‖x_n − x_{n−p}‖ is within 4× the
//!    best), with the Jacobian in the stuck or slipping coordinates of the
//!    section state from the variational equations (phase exponentials and
//!    saltation matrices at the events, [`super::monodromy`]: one run per
//!    Newton iteration), or by forward differences where those do not hold
//!    (grazing events, several switches at one instant); a converged,
//!    stable (spectral radius < 1) fixed point x* with the start's contact
//!    mode is only a *candidate*. Shooting may speed up convergence to the
//!    orbit the trajectory is approaching, never pick another attractor:
//!    the trajectory marches on p periods at a time and x* is accepted
//!    only when its own iterates follow the linearisation,
//!    ‖e_{k+1} − J·e_k‖ ≤ 0.1·‖e_k‖ + 10·tol (e_k = x_{n+kp} − x*), for up
//!    to three iterates or until it is within tol. Otherwise the trajectory
//!    marches a block (16, 32, 64 periods) and shooting is tried again (three
//!    attempts). The reported period is the smallest divisor q of p after
//!    which the orbit returns within 1e-6 (relative);
//! 5. otherwise time-marching until the section repeats (period-n, n ≤ 8)
//!    or the period budget runs out (`steady: false`, `not-settled`); past
//!    4000 periods a quasi-periodic march stops early (`not-settling`):
//!    its section comes no closer to any orbit in two 1000-period blocks
//!    and its finite-time Lyapunov exponent, from a tangent carried by
//!    the variational equations, is within ±0.01 per period of zero in
//!    both (chaotic transients, +0.07…+0.11 on the counterexample in
//!    `tests/attractor.rs`, march on).
//!
//! ## Continuation (`Direction::Up`, `Down`)
//!
//! A curve is one time-march of a plan: at each η in turn, the absorber
//! starts from the state carried over, the trajectory is marched until
//! its section repeats (steps 2–5 only accelerate that march), then on to
//! the next whole multiple of the response's period n counted from the
//! switch, and that **section state** (forcing phase 0) is carried to the
//! next η. No ramp is modelled: the drive's frequency changes at phase 0,
//! where its displacement (A) and velocity (0) are the same for both
//! frequencies, so the base motion stays continuous with a continuous
//! velocity. An interrupted point (the paper's rule) has no amplitude and
//! the next η starts from rest; a point that does not settle within the
//! budget carries its last state. `tests/attractor.rs` checks curves
//! against a plain time-march of this plan, and steady states from rest
//! against a plain march from rest (same amplitudes to 1e-6, same period).
//! `Direction::Rest` starts every η from rest.
//!
//! Curves are independent, so families run in parallel (rayon) with results
//! identical for any thread count. Along a curve the model is set up once
//! and retuned to each η ([`steady_state_with`], [`Sim::at_eta`]).
//!
//! ## Files
//!
//! * [`closed`]: the linear limits in closed form and the permanent-stick
//!   proof (stages 1 and 3);
//! * [`march`]: the march on the Poincaré section and the order of the
//!   stages (2–5), with the finite-time Lyapunov exponent's tangent;
//! * [`shoot`]: Newton shooting on the p-th return map (stage 4);
//! * [`continuation`]: one curve, its η grid and the coexistence test;
//! * [`family`]: families of curves in parallel, and their shards.

mod closed;
mod continuation;
mod family;
mod march;
mod shoot;

use closed::{closed_form, stick_proof};
pub use continuation::{curve, distinct_states, eta_grid, COEXISTING_REL};
pub use family::{family, CurveSpec, Row, Shard};
use march::march_to_steady;
#[cfg(test)]
use march::march_to_steady_extremes;
use shoot::{ext, shoot, MonodromyCache};

use super::engine::{net_force, Init, Mode, PeriodStats, Sim, Status};
use super::numeric::NumericOptions;
use super::Engine;
use super::SimError;
use crate::model::Drive;
use crate::model::Model;

/// How each η of a curve starts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Direction {
    /// Continuation with increasing η.
    Up,
    /// Continuation with decreasing η.
    Down,
    /// Every η from rest.
    Rest,
}

impl Direction {
    /// Name in tables and JSON.
    pub fn as_str(self) -> &'static str {
        match self {
            Direction::Up => "up",
            Direction::Down => "down",
            Direction::Rest => "rest",
        }
    }
}

/// Settings of the steady-state solver.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SteadyConfig {
    /// Transient periods marched before shooting.
    pub transient: u64,
    /// Period budget of the time-marching fallback.
    pub max_periods: u64,
    /// Relative tolerance on the Poincaré section.
    pub tol: f64,
    /// Use Newton shooting.
    pub shooting: bool,
    /// Stop the marching fallback early where the motion is quasi-periodic:
    /// the section comes no closer to any orbit and the finite-time
    /// Lyapunov exponent is about zero ([`steady_state`], stage 5). On by
    /// default; checked against plain 20 000-period marches on two
    /// absorbers' grids (`tests/attractor.rs`).
    pub early_stop: bool,
    /// Record the range of the per-period amplitudes of a point that does
    /// not settle (`Point::range`, the sweep's `amplitude1_min` …): it needs
    /// every period's exact extremes through the final marching stage. Off
    /// where no one reads it (batch, validation): the same points, faster.
    pub ranges: bool,
}

impl Default for SteadyConfig {
    fn default() -> Self {
        Self {
            transient: 16,
            max_periods: 20_000,
            tol: 1e-9,
            shooting: true,
            early_stop: true,
            ranges: true,
        }
    }
}

/// One point of a frequency-response curve.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Point {
    /// η.
    pub eta: f64,
    /// A1/A (None if interrupted or chattering).
    pub amplitude1: Option<f64>,
    /// A2/A.
    pub amplitude2: Option<f64>,
    /// Periodic response found.
    pub steady: bool,
    /// n of a period-n response.
    pub period_multiple: Option<u32>,
    /// Fraction of the (last) orbit M2 sticks.
    pub stick_fraction: f64,
    /// The interruption rule fired.
    pub interrupted: bool,
    /// Forcing periods integrated (including shooting's trial periods).
    pub periods: u64,
    /// Which method settled it (`closed-form`, `marching`, `stick-proof`,
    /// `shooting`, `not-settled`, `not-settling`, `interrupted`, `chatter`).
    /// `not-settled`: the marching budget ran out; `not-settling`: stopped
    /// early, the section coming no closer to any orbit (see
    /// [`steady_state`]).
    pub method: &'static str,
    /// Where no steady state was found (`not-settled`, `not-settling`):
    /// the range of the per-period half-amplitudes over the periods marched
    /// after shooting. `None` elsewhere.
    pub range: Option<AmplitudeRange>,
}

/// The range of the per-period half-amplitudes (A1/A, A2/A) of a response
/// that does not settle.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct AmplitudeRange {
    /// Smallest A1/A of a period.
    pub amplitude1_min: f64,
    /// Largest A1/A of a period.
    pub amplitude1_max: f64,
    /// Smallest A2/A of a period.
    pub amplitude2_min: f64,
    /// Largest A2/A of a period.
    pub amplitude2_max: f64,
}

fn point_from(
    eta: f64,
    st: &PeriodStats,
    p: u32,
    t: f64,
    periods: u64,
    method: &'static str,
) -> Point {
    Point {
        eta,
        amplitude1: Some(0.5 * (st.max[0] - st.min[0])),
        amplitude2: Some(0.5 * (st.max[1] - st.min[1])),
        steady: true,
        period_multiple: Some(p),
        stick_fraction: (st.stick_time / (p as f64 * t)).clamp(0.0, 1.0),
        interrupted: false,
        periods,
        method,
        range: None,
    }
}

/// The contact mode of a section state (stuck iff ζ2' = 0 and
/// −ρs⁻ < F < ρs⁺).
pub fn mode_of(model: &Model, x: &[f64; 4]) -> Mode {
    if x[3] == 0.0 && model.holds(net_force(model, x)) {
        Mode::Stick { z2: x[2] }
    } else if x[3] == 0.0 {
        Mode::Slip {
            dir: net_force(model, x).signum(),
        }
    } else {
        Mode::Slip { dir: x[3].signum() }
    }
}

/// The steady state at η from `init`; returns the point and the state on the
/// section to continue from.
pub fn steady_state(
    model: &Model,
    eta: f64,
    init: Init,
    cfg: &SteadyConfig,
) -> Result<(Point, Init), SimError> {
    steady_state_with(&mut None, model, eta, init, cfg)
}

/// The engine a sweep carries from one η to the next
/// ([`steady_state_with`]): the exact engine (retuned by [`Sim::at_eta`],
/// with shooting's variational set-up, which does not depend on η, kept)
/// or, for a law with a velocity scale, the numerical engine; chosen by
/// [`Engine::new`] for a harmonic drive of phase 0 and amplitude 1.
#[derive(Debug, Clone)]
pub struct SweepEngine {
    engine: Engine,
    shooting: MonodromyCache,
}

/// The sweep's drive at η.
fn unit_drive(eta: f64) -> Drive {
    Drive::Harmonic {
        eta,
        phase: 0.0,
        amplitude: 1.0,
    }
}

impl SweepEngine {
    /// The engine for `model` at η (a sweep's first point).
    pub fn new(model: &Model, eta: f64) -> Result<Self, SimError> {
        Ok(Self {
            engine: Engine::new(model, unit_drive(eta), NumericOptions::default())?,
            shooting: MonodromyCache::default(),
        })
    }

    /// The exact engine (`None` for a shaped law, which the numerical
    /// engine integrates).
    pub fn sim(&self) -> Option<&Sim> {
        self.engine.exact()
    }
}

/// [`steady_state`] with the engine of the previous point of a sweep in
/// `engine` (replaced by this point's): the model's eigen-decompositions
/// are reused ([`Sim::at_eta`]) where it is the same model. Results are
/// bit-identical to [`steady_state`].
pub fn steady_state_with(
    engine: &mut Option<SweepEngine>,
    model: &Model,
    eta: f64,
    init: Init,
    cfg: &SteadyConfig,
) -> Result<(Point, Init), SimError> {
    // 1. Closed forms.
    if let Some(r) = closed_form(model, eta, &init) {
        return Ok(r);
    }
    if cfg.max_periods == 0 {
        return Err(SimError::Unsupported(
            "the period budget (max_periods) must be at least 1".into(),
        ));
    }
    let eng = match engine.as_ref() {
        Some(e) if e.engine.model() == model => match e.engine.exact() {
            Some(sim) => SweepEngine {
                engine: Engine::Exact {
                    sim: Box::new(sim.at_eta(eta)?),
                    phase: 0.0,
                    amplitude: 1.0,
                },
                shooting: e.shooting.clone(),
            },
            None => SweepEngine::new(model, eta)?,
        },
        _ => SweepEngine::new(model, eta)?,
    };
    let r = march_to_steady(&eng, model, eta, init, cfg);
    *engine = Some(eng);
    r
}

/// An undamped linear limit forced at its eigenfrequency: no steady state.
fn resonant(eta: f64) -> Point {
    Point {
        eta,
        amplitude1: None,
        amplitude2: None,
        steady: false,
        period_multiple: None,
        stick_fraction: 0.0,
        interrupted: false,
        periods: 0,
        method: "resonance",
        range: None,
    }
}

fn failed(status: &Status, eta: f64, periods: u64) -> Option<Point> {
    let method = match status {
        Status::Interrupted(_) => "interrupted",
        Status::Chatter(_) => "chatter",
        _ => return None,
    };
    Some(Point {
        eta,
        amplitude1: None,
        amplitude2: None,
        steady: false,
        period_multiple: None,
        stick_fraction: 0.0,
        interrupted: matches!(status, Status::Interrupted(_)),
        periods,
        method,
        range: None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::linear;

    /// Marching without extremes and re-running a settled point's last
    /// periods gives bit for bit the point (amplitudes, stick fraction,
    /// period multiple, method, range) and the continuation state of
    /// marching with extremes throughout, over settled-by-marching,
    /// shooting, stick-proof and not-settled points (budgets 40 and 200),
    /// from rest and continued.
    #[test]
    fn lazy_extremes_are_bit_identical() {
        let ab = crate::model::Absorber {
            damping: 0.003,
            ..crate::model::Absorber::default()
        };
        let mut methods = std::collections::BTreeSet::new();
        for (rho, ratio) in [(0.5, 0.8), (0.9, 0.8), (1.2, 1.0), (0.375, 1.0)] {
            let model = Model {
                absorber: ab,
                law: crate::model::Law::Linear {
                    rho_s: rho,
                    rho_d: ratio * rho,
                    slope: 0.0,
                    minus: None,
                },
                stop_below: None,
                contact_stiffness: None,
            };
            for budget in [40, 200] {
                let cfg = SteadyConfig {
                    max_periods: budget,
                    ..SteadyConfig::default()
                };
                let mut state = Init::rest();
                for k in 0..24 {
                    let eta = 0.3 + 0.05 * k as f64;
                    let sim = SweepEngine::new(&model, eta).unwrap();
                    for init in [Init::rest(), state] {
                        let lazy = march_to_steady_extremes(&sim, &model, eta, init, &cfg, false);
                        let eager = march_to_steady_extremes(&sim, &model, eta, init, &cfg, true);
                        let ((a, sa), (b, sb)) = (lazy.unwrap(), eager.unwrap());
                        // The same point bit for bit (its range aside).
                        let same = |a: &Point, b: &Point| {
                            let bits = |x: Option<f64>| x.map(f64::to_bits);
                            bits(a.amplitude1) == bits(b.amplitude1)
                                && bits(a.amplitude2) == bits(b.amplitude2)
                                && a.stick_fraction.to_bits() == b.stick_fraction.to_bits()
                                && a.period_multiple == b.period_multiple
                                && a.method == b.method
                                && a.steady == b.steady
                        };
                        assert!(
                            same(&a, &b) && a.range == b.range && sa == sb,
                            "ρs {rho} η {eta} budget {budget}: {a:?} vs {b:?}"
                        );
                        methods.insert(a.method);
                        // Without the range: the same point, no range.
                        let no_range = SteadyConfig {
                            ranges: false,
                            ..cfg
                        };
                        let (c, sc) =
                            march_to_steady_extremes(&sim, &model, eta, init, &no_range, false)
                                .unwrap();
                        assert!(
                            same(&c, &b) && c.range.is_none() && sc == sb,
                            "ρs {rho} η {eta} budget {budget}, no range: {c:?} vs {b:?}"
                        );
                    }
                    state = march_to_steady(&sim, &model, eta, state, &cfg).unwrap().1;
                }
            }
        }
        for m in ["marching", "shooting", "not-settled"] {
            assert!(methods.contains(m), "no {m} point among {methods:?}");
        }
    }
    use crate::model::{Absorber, Law};

    fn coulomb(rs: f64) -> Model {
        Model {
            absorber: Absorber::default(),
            law: Law::coulomb(rs),
            stop_below: None,
            contact_stiffness: None,
        }
    }

    /// Shooting and marching agree on the same steady state (H1 case:
    /// a pure-slip period-1 orbit that marching reaches only slowly).
    #[test]
    fn shooting_agrees_with_marching() {
        let m = coulomb(0.375);
        let shoot = SteadyConfig::default();
        let march = SteadyConfig {
            shooting: false,
            ..shoot
        };
        let (a, _) = steady_state(&m, 0.6, Init::rest(), &shoot).unwrap();
        let (b, _) = steady_state(&m, 0.6, Init::rest(), &march).unwrap();
        assert!(a.steady && b.steady);
        let (a1, b1) = (a.amplitude1.unwrap(), b.amplitude1.unwrap());
        assert!(
            (a1 - b1).abs() < 1e-7 * b1,
            "{a1} vs {b1} ({} vs {})",
            a.method,
            b.method
        );
    }

    /// Behind a contact spring, shooting (Newton in the extended state with
    /// the held slider's position, exact Jacobian) and marching agree on
    /// every steady state of a sweep, held and sliding sections alike, and
    /// shooting settles some of them.
    #[test]
    fn contact_shooting_agrees_with_marching() {
        let ab = Absorber {
            damping: 0.003,
            ..Absorber::default()
        };
        let mut methods = std::collections::BTreeSet::new();
        let mut held = 0;
        for (rs, rd, kappa) in [(0.375, 0.3, 20.0), (0.375, 0.375, 5.0), (0.9, 0.7, 60.0)] {
            let model = Model {
                absorber: ab,
                law: Law::Linear {
                    rho_s: rs,
                    rho_d: rd,
                    slope: 0.0,
                    minus: None,
                },
                stop_below: None,
                contact_stiffness: Some(kappa),
            };
            let shoot = SteadyConfig {
                max_periods: 4000,
                ..SteadyConfig::default()
            };
            let march = SteadyConfig {
                shooting: false,
                ..shoot
            };
            for k in 0..12 {
                let eta = 0.45 + 0.05 * k as f64;
                let (a, sa) = steady_state(&model, eta, Init::rest(), &shoot).unwrap();
                let (b, _) = steady_state(&model, eta, Init::rest(), &march).unwrap();
                let label = format!("rho {rs} {rd} kappa {kappa} eta {eta}: {a:?} vs {b:?}");
                let agree = |a: &Point, b: &Point| {
                    [(a.amplitude1, b.amplitude1), (a.amplitude2, b.amplitude2)]
                        .iter()
                        .all(|&(x, y)| {
                            let (x, y) = (x.unwrap(), y.unwrap());
                            (x - y).abs() <= 1e-7 * y.abs().max(1e-3)
                        })
                        && (a.stick_fraction - b.stick_fraction).abs() <= 1e-6
                };
                // Shooting settles every point marching settles, on the
                // same orbit.
                assert!(a.steady || !b.steady, "{label}");
                if b.steady {
                    assert!(agree(&a, &b), "{label}");
                }
                if a.method == "shooting" {
                    // The orbit is a steady state: marched from its own
                    // section state it repeats at once. (Where the march
                    // from rest has not settled, shooting may have found
                    // a stable orbit beside the wandering trajectory: at
                    // ρs 0.9, ρd 0.7, κ 60, η 0.8 the orbit's Floquet
                    // multipliers are 0.996 in modulus and the trajectory
                    // from rest wanders 0.15–0.46 away for 100 000
                    // periods. Both are answers; see docs/real-pads.md.)
                    let (c, _) = steady_state(&model, eta, sa, &march).unwrap();
                    assert!(
                        c.steady && c.periods <= 40 && agree(&a, &c),
                        "{label}: {c:?}"
                    );
                    held += usize::from(matches!(sa.mode, Mode::Stick { .. }));
                }
                methods.insert(a.method);
            }
        }
        assert!(methods.contains("shooting"), "methods {methods:?}");
        assert!(held > 0, "no held shooting section");
    }

    /// The limits in closed form and the proven permanent stick.
    #[test]
    fn limits_and_stick_proof() {
        let ab = Absorber::default();
        for eta in [0.3, 0.7, 1.2] {
            let (p, _) =
                steady_state(&coulomb(0.0), eta, Init::rest(), &SteadyConfig::default()).unwrap();
            let (a1, a2) = linear::free_amplitudes(&ab, 0.0, eta);
            assert_eq!((p.amplitude1.unwrap(), p.amplitude2.unwrap()), (a1, a2));
            let (p, _) = steady_state(
                &coulomb(f64::INFINITY),
                eta,
                Init::rest(),
                &SteadyConfig::default(),
            )
            .unwrap();
            assert_eq!(p.amplitude1.unwrap(), linear::stuck_amplitudes(&ab, eta).0);
        }
        // ρs = 5 at η = 1.2 (stuck orbit's largest contact force ≈ 1.4 ≪ 5):
        // the proof applies after the transient, with the 1-DOF amplitude.
        let (p, _) =
            steady_state(&coulomb(5.0), 1.2, Init::rest(), &SteadyConfig::default()).unwrap();
        assert_eq!(p.method, "stick-proof");
        assert!((p.amplitude1.unwrap() - linear::stuck_amplitudes(&ab, 1.2).0).abs() < 1e-15);
    }

    /// Shards partition the work and reassemble to the unsharded family.
    #[test]
    fn shards_reassemble_exactly() {
        let etas = eta_grid(0.3, 1.3, 9);
        let specs = [
            CurveSpec {
                model: coulomb(0.2),
                direction: Direction::Up,
            },
            CurveSpec {
                model: coulomb(0.4),
                direction: Direction::Down,
            },
            CurveSpec {
                model: coulomb(0.3),
                direction: Direction::Rest,
            },
        ];
        let cfg = SteadyConfig::default();
        let all = family(&specs, &etas, &cfg, Shard::ALL, &|_| {}).unwrap();
        let mut parts = Vec::new();
        for index in 0..3 {
            parts.extend(family(&specs, &etas, &cfg, Shard { index, count: 3 }, &|_| {}).unwrap());
        }
        parts.sort_by_key(|r| (r.curve, r.point));
        assert_eq!(all, parts);
        assert_eq!(all.len(), 27);
    }
}

#[cfg(test)]
mod determinism {
    use super::*;
    use crate::model::{Absorber, Law};

    /// The same family on 1 and on 3 worker threads: identical rows.
    #[test]
    fn results_do_not_depend_on_thread_count() {
        let etas = eta_grid(0.3, 1.3, 11);
        let specs: Vec<CurveSpec> = [0.1, 0.4, 1.0]
            .iter()
            .flat_map(|&rs| {
                let model = Model {
                    absorber: Absorber::default(),
                    law: Law::Linear {
                        rho_s: rs,
                        rho_d: 0.5 * rs,
                        slope: 0.0,
                        minus: None,
                    },
                    stop_below: None,
                    contact_stiffness: None,
                };
                [Direction::Up, Direction::Rest].map(|direction| CurveSpec { model, direction })
            })
            .collect();
        let cfg = SteadyConfig::default();
        let on = |n: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(n)
                .build()
                .unwrap()
                .install(|| family(&specs, &etas, &cfg, Shard::ALL, &|_| {}).unwrap())
        };
        assert_eq!(on(1), on(3));
    }
}
