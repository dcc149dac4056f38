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

use faer::linalg::solvers::Solve;

use super::engine::{net_force, Event, Flow, Init, Mode, Observer, PeriodStats, Sim, Status};
use super::linear;
use super::monodromy::Monodromy;
use super::steady::{merge_back, Tracker, MAX_PERIOD_MULTIPLE, RING};
use super::SimError;
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

/// The contact mode of a section state (stuck iff ζ2' = 0 and |F| < ρs).
pub fn mode_of(model: &Model, x: &[f64; 4]) -> Mode {
    if x[3] == 0.0 && net_force(model, x).abs() < model.law.rho_s() {
        Mode::Stick { z2: x[2] }
    } else if x[3] == 0.0 {
        Mode::Slip {
            dir: net_force(model, x).signum(),
        }
    } else {
        Mode::Slip { dir: x[3].signum() }
    }
}

/// Proves that M2, stuck at ζ2* with the 1-DOF state (ζ1, ζ1'), never
/// breaks away: the stuck motion is the steady 1-DOF response plus a free
/// part whose energy E = ½mζ1h'² + ½(1+k)ζ1h² never grows (D ≥ 0), so
/// |F| ≤ max|F_ss| + √(2E/(1+k)) + D·√(2E/m) < ρs for all later times.
fn permanently_stuck(model: &Model, eta: f64, x: &[f64; 4], z2: f64) -> bool {
    let ab = &model.absorber;
    let xs = linear::stuck_response(ab, eta);
    let c = z2 / (1.0 + ab.k);
    // F_ss = ζ1ss − z2 + Dζ1ss' = Re(X(1 + iηD) e^{iητ}) + c − z2.
    let f_amp = (xs * num_complex::Complex::new(1.0, eta * ab.damping)).norm();
    let f_max = f_amp + (c - z2).abs();
    // Free part at τ = 0 mod T (the section).
    let ss = linear::stuck_state(ab, eta, z2);
    let (h, dh) = (x[0] - ss[0], x[1] - ss[1]);
    let e = 0.5 * ab.m * dh * dh + 0.5 * (1.0 + ab.k) * h * h;
    let bound = (2.0 * e / (1.0 + ab.k)).sqrt() + ab.damping * (2.0 * e / ab.m).sqrt();
    f_max + bound < model.law.rho_s() * (1.0 - 1e-12)
}

/// Stage 1 of [`steady_state`]: the closed forms of a frictionless and of
/// an always-stuck law (None for any other law). Inlined: as a call it
/// made the closed-form sweep (`benches/sweep.rs`, baseline) ~50 % slower.
#[inline(always)]
fn closed_form(model: &Model, eta: f64, init: &Init) -> Option<(Point, Init)> {
    let ab = &model.absorber;
    if model.law.is_frictionless() {
        let (a1, a2) = linear::free_amplitudes(ab, model.law.slope(), eta);
        if !linear::bounded(a1.max(a2)) {
            return Some((resonant(eta), Init::rest()));
        }
        let x = linear::free_state(ab, model.law.slope(), eta);
        let p = Point {
            eta,
            amplitude1: Some(a1),
            amplitude2: Some(a2),
            steady: true,
            period_multiple: Some(1),
            stick_fraction: 0.0,
            interrupted: false,
            periods: 0,
            method: "closed-form",
            range: None,
        };
        return Some((
            p,
            Init {
                x,
                mode: Mode::Slip { dir: 1.0 },
            },
        ));
    }
    if model.law.is_always_stuck() {
        let z2 = if init.x[2].is_finite() {
            init.x[2]
        } else {
            0.0
        };
        let (a1, _) = linear::stuck_amplitudes(ab, eta);
        if !linear::bounded(a1) {
            return Some((resonant(eta), Init::rest()));
        }
        let p = stuck_point(eta, a1, 0, "closed-form");
        return Some((
            p,
            Init {
                x: linear::stuck_state(ab, eta, z2),
                mode: Mode::Stick { z2 },
            },
        ));
    }
    None
}

/// The steady state of M2 stuck for good: period 1, A1/A = `a1`, A2/A = 0
/// (after `periods` forcing periods; `method` says how it was found).
#[inline(always)]
fn stuck_point(eta: f64, a1: f64, periods: u64, method: &'static str) -> Point {
    Point {
        eta,
        amplitude1: Some(a1),
        amplitude2: Some(0.0),
        steady: true,
        period_multiple: Some(1),
        stick_fraction: 1.0,
        interrupted: false,
        periods,
        method,
        range: None,
    }
}

/// Stage 3 of [`steady_state`]: the stuck state after the transient
/// (`state`, `used` periods) where it is proven permanent. Inlined like
/// [`closed_form`].
#[inline(always)]
fn stick_proof(model: &Model, eta: f64, state: &Init, used: u64) -> Option<(Point, Init)> {
    let ab = &model.absorber;
    if let Mode::Stick { z2 } = state.mode {
        if permanently_stuck(model, eta, &state.x, z2) {
            let (a1, _) = linear::stuck_amplitudes(ab, eta);
            let p = stuck_point(eta, a1, used, "stick-proof");
            return Some((
                p,
                Init {
                    x: linear::stuck_state(ab, eta, z2),
                    mode: state.mode,
                },
            ));
        }
    }
    None
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

/// [`steady_state`] with the engine of the previous point of a sweep in
/// `engine` (replaced by this point's): the model's eigen-decompositions
/// are reused ([`Sim::at_eta`]) where it is the same model. Results are
/// bit-identical to [`steady_state`].
pub fn steady_state_with(
    engine: &mut Option<Sim>,
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
    let sim = match engine.as_ref() {
        Some(s) if s.model() == model => s.at_eta(eta)?,
        _ => Sim::new(model, eta)?,
    };
    let r = march_to_steady(&sim, model, eta, init, cfg);
    *engine = Some(sim);
    r
}

/// Stages 2–5 of [`steady_state`] on the engine `sim` at η.
fn march_to_steady(
    sim: &Sim,
    model: &Model,
    eta: f64,
    init: Init,
    cfg: &SteadyConfig,
) -> Result<(Point, Init), SimError> {
    march_to_steady_extremes(sim, model, eta, init, cfg, false)
}

/// [`march_to_steady`], locating every period's extremes from the start
/// when `eager` (the reference the lazy default is tested against).
fn march_to_steady_extremes(
    sim: &Sim,
    model: &Model,
    eta: f64,
    init: Init,
    cfg: &SteadyConfig,
    eager: bool,
) -> Result<(Point, Init), SimError> {
    let t = 2.0 * std::f64::consts::PI / eta;
    let mut unit = ();
    let mut w = Walk {
        sim,
        tr: Tracker::new(&mut unit, cfg.tol, true),
        start: init,
        state: init,
        dwell: 0,
        used: 0,
        exact_from: eager.then_some(0),
        tangent: None,
    };
    // 2. Transient, watched on the section, with 3. the proof of a
    //    permanent stick tried after 2, 4, 8, … periods of it: once it
    //    holds it holds for good (the stuck position stays, the free
    //    motion's energy only decreases), so the rest of the transient
    //    would end in the same closed form.
    let transient = cfg.transient.min(cfg.max_periods);
    let mut marched = 0;
    let mut chunk = PROOF_FIRST.min(transient);
    loop {
        if let Some(r) = w.march_watched(chunk, eta, t) {
            return Ok(r);
        }
        marched += chunk;
        if let Some(r) = stick_proof(model, eta, &w.state, w.used) {
            return Ok(r);
        }
        if marched >= transient {
            break;
        }
        chunk = marched.min(transient - marched);
    }
    // 4. Newton shooting on the p-th iterate, accepted only where the
    //    trajectory itself is seen to approach the orbit found; between
    //    attempts the trajectory marches on.
    if cfg.shooting {
        let mut block = cfg.transient.max(16);
        for _ in 0..SHOOTING_ATTEMPTS {
            match w.try_shooting(model, eta, t, cfg) {
                Shot::Accepted(r) => return Ok(r),
                Shot::Failed(p) => return Ok((p, Init::rest())),
                Shot::Settled(p) => return Ok(w.settled(eta, p, t)),
                Shot::Rejected => {}
            }
            let left = cfg.max_periods.saturating_sub(w.dwell);
            if left == 0 {
                break;
            }
            if let Some(r) = w.march_watched(block.min(left), eta, t) {
                return Ok(r);
            }
            block *= 2;
        }
    }
    // 5. Time marching to the end of the budget, in blocks of EARLY_BLOCK
    //    periods. Past EARLY_MIN periods, a trajectory whose section came
    //    no closer to closing any orbit (the smallest distance between an
    //    iterate and the one p periods before, p = 1..=MAX) in two blocks
    //    in a row than in the block before them is not approaching a
    //    periodic response; it stops early only where it is moreover
    //    regular, its finite-time Lyapunov exponent in both blocks within
    //    ±REGULAR_FTLE (a quasi-periodic response on an invariant torus).
    //    A trajectory approaching an orbit, however slowly, comes closer
    //    every block (geometric convergence); a chaotic one (a positive
    //    exponent) may still fall onto an orbit after thousands of periods
    //    and marches on to the end of the budget.
    w.tr.take_closest();
    w.tr.take_range();
    // The amplitude range needs every period's exact extremes from here on.
    if cfg.ranges {
        w.exact_from = Some(w.dwell);
    }
    let mut closest = [f64::INFINITY; 3];
    let mut lyapunov = [None; 3];
    let mut method = "not-settled";
    loop {
        let left = cfg.max_periods.saturating_sub(w.dwell);
        if left == 0 {
            break;
        }
        // The exponent is judged over the two blocks before a decision.
        if cfg.early_stop
            && w.tangent.is_none()
            && w.dwell + 2 * EARLY_BLOCK >= EARLY_MIN
            && cfg.max_periods > EARLY_MIN
        {
            w.tangent = sim
                .monodromy()
                .map(|m| Tangent::new(m, eta, t, w.state.mode));
        }
        // Without ranges, the last block locates extremes only over the
        // final window whose amplitudes an unsettled point reports.
        let block = left.min(EARLY_BLOCK);
        let tail = if w.exact_from.is_none() && block == left {
            block.min(FINAL_WINDOW)
        } else {
            0
        };
        if block > tail {
            if let Some(r) = w.march_watched(block - tail, eta, t) {
                return Ok(r);
            }
        }
        if tail > 0 {
            w.exact_from = Some(w.dwell);
            if let Some(r) = w.march_watched(tail, eta, t) {
                return Ok(r);
            }
        }
        closest = [closest[1], closest[2], w.tr.take_closest()];
        lyapunov = [
            lyapunov[1],
            lyapunov[2],
            w.tangent.as_mut().and_then(Tangent::take),
        ];
        let regular = |l: Option<f64>| l.is_some_and(|l: f64| l.abs() <= REGULAR_FTLE);
        if cfg.early_stop
            && w.dwell >= EARLY_MIN
            && closest[1].min(closest[2]) >= closest[0]
            && regular(lyapunov[1])
            && regular(lyapunov[2])
            && w.dwell < cfg.max_periods
        {
            method = "not-settling";
            break;
        }
    }
    let n = w.tr.seen().clamp(1, FINAL_WINDOW);
    let Some(st) = w.window(n) else {
        return Err(SimError::Unsupported(
            "no forcing period was integrated (period budget 0)".into(),
        ));
    };
    let mut pt = point_from(eta, &st, 1, t, w.used, method);
    pt.steady = false;
    pt.period_multiple = None;
    pt.stick_fraction = (st.stick_time / (n as f64 * t)).clamp(0.0, 1.0);
    pt.range =
        w.tr.take_range()
            .filter(|_| cfg.ranges)
            .map(|r| AmplitudeRange {
                amplitude1_min: r[0],
                amplitude1_max: r[1],
                amplitude2_min: r[2],
                amplitude2_max: r[3],
            });
    Ok((pt, w.state))
}

/// Transient periods before the first attempt at the permanent-stick proof
/// (then after twice as many, and so on, to the end of the transient).
const PROOF_FIRST: u64 = 2;

/// Periods whose merged statistics give an unsettled point's amplitudes.
const FINAL_WINDOW: u64 = 50;

/// Periods per block of the marching fallback (stage 5 of
/// [`steady_state`]).
const EARLY_BLOCK: u64 = 1000;
/// Periods of a trajectory before the early stop may judge it.
const EARLY_MIN: u64 = 4000;
/// Largest |finite-time Lyapunov exponent| per forcing period, over a
/// block of [`EARLY_BLOCK`] periods, of a regular (quasi-periodic) motion
/// for the early stop. Measured over 1000-period blocks: within ±9e-4 on
/// the quasi-periodic response of the paper's absorber (m 4, k 1, D 0.003,
/// ρs 1.004, ρd 0.813, η 0.74; a bounded tangent oscillation c gives
/// |λ| ≤ c/1000), +0.07…+0.11 on the chaotic transient that settles after
/// 12 045 periods (m 2, k 0.5, D 0.01, ρs 0.8, ρd 0.48, η 0.62).
const REGULAR_FTLE: f64 = 0.01;

/// Shooting attempts before marching to the end of the budget.
const SHOOTING_ATTEMPTS: usize = 3;
/// Iterates of the p-th return map over which the trajectory must follow
/// the linearisation about a shooting fixed point before it is accepted.
const VERIFY_ITERATES: usize = 3;

/// Forwards the engine's period callbacks to a [`Tracker`] with a running
/// period count, so that one tracker watches a trajectory integrated in
/// several pieces.
struct Offset<'t, 'a, 's> {
    tr: &'t mut Tracker<'a, ()>,
    base: u64,
    /// Locate the extremes exactly (see [`Walk::exact_from`]).
    extremes: bool,
    /// The tangent carried along (the early stop's Lyapunov exponent).
    tangent: Option<&'t mut Tangent<'s>>,
}

/// A tangent vector carried along the march by the variational equations
/// ([`Monodromy::carry`], period by period), for the largest finite-time
/// Lyapunov exponent per block of the marching fallback: about zero on a
/// quasi-periodic response (an invariant torus), clearly positive on a
/// chaotic transient, negative while an orbit is approached.
struct Tangent<'s> {
    mono: &'s Monodromy,
    eta: f64,
    period: f64,
    v: [f64; 4],
    /// The current period's events and the mode it started in.
    events: Vec<Event>,
    mode: Mode,
    log_growth: f64,
    periods: u64,
    /// A period whose Jacobian the formula does not give (grazing).
    lost: bool,
}

impl<'s> Tangent<'s> {
    const START: [f64; 4] = [0.8, 0.4, 0.4, 0.2];

    fn new(mono: &'s Monodromy, eta: f64, period: f64, mode: Mode) -> Self {
        let mut v = Self::START;
        if matches!(mode, Mode::Stick { .. }) {
            v[3] = 0.0;
        }
        Self {
            mono,
            eta,
            period,
            v,
            events: Vec::with_capacity(16),
            mode,
            log_growth: 0.0,
            periods: 0,
            lost: false,
        }
    }

    /// End of period `n` of a run (1-based), in mode `mode`.
    fn period_end(&mut self, n: u64, mode: Mode) {
        let t0 = (n - 1) as f64 * self.period;
        let t1 = n as f64 * self.period;
        let grown = self
            .mono
            .carry(self.mode, &self.events, t0, t1, self.eta)
            .map(|m| -> [f64; 4] {
                std::array::from_fn(|i| (0..4).map(|c| m[i][c] * self.v[c]).sum())
            });
        let norm = grown.map_or(f64::NAN, |w| w.iter().map(|q| q * q).sum::<f64>().sqrt());
        match grown {
            Some(w) if norm.is_finite() && norm > 0.0 => {
                self.log_growth += norm.ln();
                self.v = w.map(|q| q / norm);
            }
            _ => {
                self.lost = true;
                self.v = Self::START;
                if matches!(mode, Mode::Stick { .. }) {
                    self.v[3] = 0.0;
                }
            }
        }
        self.periods += 1;
        self.events.clear();
        self.mode = mode;
    }

    /// The exponent (per forcing period) since the last call; `None` if a
    /// period's Jacobian was lost or no period passed.
    fn take(&mut self) -> Option<f64> {
        let r = (!self.lost && self.periods > 0).then(|| self.log_growth / self.periods as f64);
        self.log_growth = 0.0;
        self.periods = 0;
        self.lost = false;
        r
    }
}

/// Records the statistics of each period of a re-run window.
struct Periods {
    stats: [PeriodStats; RING],
    n: usize,
}

impl Observer for Periods {
    fn wants_extremes(&self) -> bool {
        true
    }
    fn period(&mut self, _n: u64, _x: &[f64; 4], _m: Mode, s: &PeriodStats) -> Flow {
        if self.n < RING {
            self.stats[self.n] = *s;
            self.n += 1;
        }
        Flow::Continue
    }
}

impl Observer for Offset<'_, '_, '_> {
    fn wants_extremes(&self) -> bool {
        self.extremes
    }
    fn event(&mut self, ev: &Event) {
        if let Some(t) = self.tangent.as_deref_mut() {
            t.events.push(*ev);
        }
    }
    fn period(&mut self, n: u64, x: &[f64; 4], mode: Mode, stats: &PeriodStats) -> Flow {
        if let Some(t) = self.tangent.as_deref_mut() {
            t.period_end(n, mode);
        }
        self.tr.period(self.base + n, x, mode, stats)
    }
}

/// The physical trajectory at one η: its state after `dwell` whole forcing
/// periods from the start state, watched on the section by `tr`; `used`
/// counts every integrated period (shooting's trial periods too).
struct Walk<'s, 'a> {
    sim: &'s Sim,
    tr: Tracker<'a, ()>,
    /// The state the walk started from (dwell 0).
    start: Init,
    state: Init,
    dwell: u64,
    used: u64,
    /// The dwell from which the march locates every period's extremes
    /// (`None`: not yet). The transient and shooting stages march without
    /// them (a third of a stick-slip period's cost); a settled point's
    /// statistics come from re-running its last periods from their
    /// recorded section state ([`Walk::window`]), which repeats the same
    /// trajectory bit for bit.
    exact_from: Option<u64>,
    /// The tangent of the early stop's Lyapunov exponent, carried while
    /// it is `Some`.
    tangent: Option<Tangent<'s>>,
}

/// What a shooting attempt concluded.
enum Shot {
    /// The trajectory approaches the orbit found: the point and the state
    /// to continue from.
    Accepted((Point, Init)),
    /// No orbit, or one the trajectory is not seen to approach.
    Rejected,
    /// The marching detector settled during the check (period p).
    Settled(u32),
    /// Interrupted or chattering during the check.
    Failed(Point),
}

impl Walk<'_, '_> {
    /// Marches `n` more periods (stops early when the section repeats).
    fn march(&mut self, n: u64) -> super::engine::RunEnd {
        let mut off = Offset {
            tr: &mut self.tr,
            base: self.dwell,
            extremes: self.exact_from.is_some(),
            tangent: self.tangent.as_mut(),
        };
        let end = self.sim.run(self.state, n, &mut off);
        self.dwell += end.periods;
        self.used += end.periods;
        self.state = Init {
            x: end.x,
            mode: end.mode,
        };
        end
    }

    /// Marches `n` more periods and returns the point where that ends the
    /// search: an interruption or chatter (continue from rest), or a
    /// section that repeats (the settled point). `None`: march on.
    #[inline(always)]
    fn march_watched(&mut self, n: u64, eta: f64, t: f64) -> Option<(Point, Init)> {
        let end = self.march(n);
        if let Some(p) = failed(&end.status, eta, self.used) {
            return Some((p, Init::rest()));
        }
        let p = self.tr.steady?;
        Some(self.settled(eta, p, t))
    }

    /// The point of a trajectory the detector found period-`p`, and the
    /// state to continue from: the trajectory marched on to the next whole
    /// multiple of p periods of its dwell (see [`curve`]).
    fn settled(&mut self, eta: f64, p: u32, t: f64) -> (Point, Init) {
        let st = self
            .window(p as u64)
            .expect("the detector has seen at least 2p periods");
        let extra = (p as u64 - self.dwell % p as u64) % p as u64;
        if extra > 0 {
            let end = self.sim.run(self.state, extra, &mut ());
            self.used += end.periods;
            self.dwell += end.periods;
            self.state = Init {
                x: end.x,
                mode: end.mode,
            };
        }
        (
            point_from(eta, &st, p, t, self.used, "marching"),
            self.state,
        )
    }

    /// Merged statistics with exact extremes over the last `w` periods
    /// marched (w ≤ periods seen, ≤ 64): the tracker's own where those
    /// periods were marched with extremes, else those of a re-run of the
    /// window from its recorded section state (the engine's trajectory
    /// does not depend on whether extremes are located, and a run started
    /// at a period boundary repeats the continuing one bit for bit: unit
    /// test `lazy_extremes_are_bit_identical`).
    fn window(&mut self, w: u64) -> Option<PeriodStats> {
        let n = self.tr.seen();
        let w = w.min(n).min(RING as u64);
        if w == 0 {
            return None;
        }
        if self.exact_from.is_some_and(|d| n - w >= d) {
            return self.tr.window(w);
        }
        let from = if w == n {
            self.start
        } else {
            self.tr.section_mode(w)?
        };
        let mut rec = Periods {
            stats: [PeriodStats::new_at(&from.x); RING],
            n: 0,
        };
        let end = self.sim.run(from, w, &mut rec);
        self.used += end.periods;
        debug_assert_eq!(Some(end.x), self.tr.section(0).map(|s| s.0));
        merge_back(rec.stats[..rec.n].iter().rev())
    }

    /// Picks the period multiple the section iterates suggest (the
    /// smallest p whose return distance is within 4× the best), shoots on
    /// P^p from the current state and accepts the orbit only if the next
    /// iterates of the trajectory follow its linearisation.
    fn try_shooting(&mut self, model: &Model, eta: f64, t: f64, cfg: &SteadyConfig) -> Shot {
        let Some((x_now, s_now)) = self.tr.section(0) else {
            return Shot::Rejected;
        };
        let mut d = [f64::INFINITY; MAX_PERIOD_MULTIPLE + 1];
        for (p, dp) in d.iter_mut().enumerate().skip(1) {
            if let Some((y, sy)) = self.tr.section(p as u64) {
                if sy == s_now {
                    *dp = dist(&x_now, &y, 4);
                }
            }
        }
        let best = d.iter().copied().fold(f64::INFINITY, f64::min);
        let Some(p) = (1..=MAX_PERIOD_MULTIPLE).find(|&p| d[p] <= 4.0 * best) else {
            // Fewer than two section points, or contact modes that never repeat.
            return Shot::Rejected;
        };
        let mut used = 0;
        let shot = shoot(
            self.sim,
            model,
            self.state.x,
            self.state.mode,
            p as u64,
            cfg.tol,
            &mut used,
        );
        self.used += used;
        let Some(sh) = shot else {
            return Shot::Rejected;
        };
        let dim = sh.dim;
        let lim = |x: &[f64; 4]| cfg.tol * (1.0 + x.iter().fold(0.0f64, |a, v| a.max(v.abs())));
        // The check: e_{k+1} = J·e_k + O(|e_k|²) for the deviations of the
        // trajectory's own p-th iterates from the fixed point.
        let mut e = diff(&self.state.x, &sh.x, dim);
        let mut ok = norm(&e, dim) <= lim(&sh.x);
        for _ in 0..VERIFY_ITERATES {
            if ok {
                break;
            }
            let end = self.march(p as u64);
            if let Some(pt) = failed(&end.status, eta, self.used) {
                return Shot::Failed(pt);
            }
            if let Some(q) = self.tr.steady {
                return Shot::Settled(q);
            }
            if end.periods < p as u64 {
                return Shot::Rejected;
            }
            if matches!(self.state.mode, Mode::Stick { .. }) != sh.stuck {
                return Shot::Rejected;
            }
            let e1 = diff(&self.state.x, &sh.x, dim);
            let mut miss = [0.0; 4];
            for i in 0..dim {
                let pred: f64 = (0..dim).map(|j| sh.jac[i][j] * e[j]).sum();
                miss[i] = e1[i] - pred;
            }
            if norm(&miss, dim) > 0.1 * norm(&e, dim) + 10.0 * lim(&sh.x) {
                return Shot::Rejected;
            }
            ok = norm(&e1, dim) <= lim(&sh.x);
            e = e1;
        }
        // Accepted: the orbit's statistics over p periods from the fixed
        // point, its minimal period q and the continuation state.
        let mut orbit = Orbit {
            stats: None,
            sections: Vec::with_capacity(p),
        };
        let start = Init {
            x: sh.x,
            mode: sh.mode,
        };
        let e = self.sim.run(start, p as u64, &mut orbit);
        self.used += e.periods;
        let (Some(st), true) = (orbit.stats, matches!(e.status, Status::Completed)) else {
            return Shot::Rejected;
        };
        // A divisor q of p is the minimal period when the orbit returns
        // within 1e-6 (relative) after q periods: Newton's residual bounds
        // the fixed point's error only through (I − J)⁻¹, and orbits that
        // differ by less are not told apart anywhere in the tool.
        let l = 1e-6 * (1.0 + sh.x.iter().fold(0.0f64, |a, v| a.max(v.abs())));
        let q = (1..=p)
            .filter(|q| p % q == 0)
            .find(|&q| {
                let (y, m) = orbit.sections[q - 1];
                matches!(m, Mode::Stick { .. }) == sh.stuck && dist(&y, &sh.x, 4) <= l
            })
            .unwrap_or(p);
        // The fixed point is the orbit's state at dwell ≡ dwell (mod q);
        // continue from its state at the next whole multiple of q.
        let j = ((q as u64 - self.dwell % q as u64) % q as u64) as usize;
        let next = if j == 0 {
            start
        } else {
            let (x, mode) = orbit.sections[j - 1];
            Init { x, mode }
        };
        let mut pt = point_from(eta, &st, p as u32, t, self.used, "shooting");
        pt.period_multiple = Some(q as u32);
        Shot::Accepted((pt, next))
    }
}

/// Merged statistics and section states of a run (an orbit).
struct Orbit {
    stats: Option<PeriodStats>,
    sections: Vec<([f64; 4], Mode)>,
}

impl Observer for Orbit {
    fn wants_extremes(&self) -> bool {
        true
    }
    fn period(&mut self, _n: u64, x: &[f64; 4], m: Mode, s: &PeriodStats) -> Flow {
        self.stats = Some(match self.stats {
            None => *s,
            Some(a) => PeriodStats {
                min: [a.min[0].min(s.min[0]), a.min[1].min(s.min[1])],
                max: [a.max[0].max(s.max[0]), a.max[1].max(s.max[1])],
                stick_time: a.stick_time + s.stick_time,
            },
        });
        self.sections.push((*x, m));
        Flow::Continue
    }
}

fn diff(a: &[f64; 4], b: &[f64; 4], dim: usize) -> [f64; 4] {
    let mut d = [0.0; 4];
    for i in 0..dim {
        d[i] = a[i] - b[i];
    }
    d
}

fn norm(a: &[f64; 4], dim: usize) -> f64 {
    a[..dim].iter().fold(0.0f64, |m, v| m.max(v.abs()))
}

fn dist(a: &[f64; 4], b: &[f64; 4], dim: usize) -> f64 {
    norm(&diff(a, b, dim), dim)
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

/// A fixed point of the p-th return map found by [`shoot`].
struct Shooting {
    /// The section state.
    x: [f64; 4],
    /// Its contact mode.
    mode: Mode,
    /// M2 sticks there (coordinates ζ1, ζ1', ζ2; else all four).
    stuck: bool,
    /// Number of coordinates varied (3 stuck, 4 slipping).
    dim: usize,
    /// Jacobian of P^p at `x` (`dim`×`dim`; variational where it holds,
    /// else finite differences).
    jac: [[f64; 4]; 4],
}

/// Newton's method on P^p(x) − x for a section state of a period-p orbit.
/// Stuck states vary (ζ1, ζ1', ζ2) with ζ2' = 0; slipping states all four
/// components. Only a converged, stable (spectral radius < 1) fixed point
/// with the start's contact mode is returned; whether the trajectory
/// approaches it is the caller's check. `used` counts the periods
/// integrated, whatever the outcome.
fn shoot(
    sim: &Sim,
    model: &Model,
    x0: [f64; 4],
    mode0: Mode,
    p: u64,
    tol: f64,
    used: &mut u64,
) -> Option<Shooting> {
    let stuck = matches!(mode0, Mode::Stick { .. });
    let dim = if stuck { 3 } else { 4 };
    let same_kind = |m: Mode| matches!(m, Mode::Stick { .. }) == stuck;
    // A section state in the start's contact mode (a stuck M2 at its ζ2).
    let start = |x: &[f64; 4]| Init {
        x: *x,
        mode: if stuck {
            Mode::Stick { z2: x[2] }
        } else {
            mode0
        },
    };
    let map = |x: &[f64; 4]| {
        let e = sim.run(start(x), p, &mut ());
        match e.status {
            Status::Completed => Some((e.x, e.mode)),
            _ => None,
        }
    };
    // The exact Jacobian from the variational equations where it holds
    // (one run per iteration), else forward differences (dim + 1 runs).
    let mono = sim.monodromy();
    let mut x = x0;
    for _ in 0..8 {
        let exact = mono.and_then(|m| m.map(sim, start(&x), p));
        let (px, pm) = match &exact {
            Some((px, pm, _)) => (*px, *pm),
            None => map(&x)?,
        };
        *used += p;
        if !same_kind(pm) {
            return None;
        }
        let scale = 1.0 + x.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        let r: Vec<f64> = (0..dim).map(|i| px[i] - x[i]).collect();
        let rn = r.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        let mut j = faer::Mat::<f64>::zeros(dim, dim);
        if let Some((_, _, jm)) = &exact {
            for i in 0..dim {
                for c in 0..dim {
                    j[(i, c)] = jm[i][c];
                }
            }
        } else {
            // Jacobian of P^p by forward differences.
            for c in 0..dim {
                let h = 1e-7 * (1.0 + x[c].abs());
                let mut xp = x;
                xp[c] += h;
                let (pp, pmm) = map(&xp)?;
                *used += p;
                if !same_kind(pmm) {
                    return None;
                }
                for i in 0..dim {
                    j[(i, c)] = (pp[i] - px[i]) / h;
                }
            }
        }
        if rn <= tol * scale {
            // Converged: accept only a stable orbit.
            let ev = j.eigenvalues().ok()?;
            let rho = ev.iter().map(|z| z.norm()).fold(0.0, f64::max);
            if rho >= 1.0 - 1e-9 {
                return None;
            }
            let mut jac = [[0.0; 4]; 4];
            for (i, row) in jac.iter_mut().enumerate().take(dim) {
                for (c, v) in row.iter_mut().enumerate().take(dim) {
                    *v = j[(i, c)];
                }
            }
            return Some(Shooting {
                x,
                mode: start(&x).mode,
                stuck,
                dim,
                jac,
            });
        }
        let mut a = j.clone();
        for i in 0..dim {
            a[(i, i)] -= 1.0;
        }
        let rhs = faer::Mat::<f64>::from_fn(dim, 1, |i, _| -r[i]);
        let dx = a.full_piv_lu().solve(&rhs);
        let mut step = [0.0f64; 4];
        for i in 0..dim {
            step[i] = dx[(i, 0)];
            if !step[i].is_finite() {
                return None;
            }
        }
        for i in 0..dim {
            x[i] += step[i];
        }
        if stuck {
            x[3] = 0.0;
            if net_force(model, &x).abs() >= model.law.rho_s() {
                return None;
            }
        } else if x[3] == 0.0 || x[3].signum() != mode_dir(mode0) {
            return None;
        }
    }
    None
}

fn mode_dir(m: Mode) -> f64 {
    match m {
        Mode::Slip { dir } => dir,
        Mode::Stick { .. } => 0.0,
    }
}

/// One frequency-response curve: the model at each η in order of the
/// direction (`etas` ascending; `Down` runs them descending but returns them
/// ascending).
pub fn curve(
    model: &Model,
    etas: &[f64],
    direction: Direction,
    cfg: &SteadyConfig,
) -> Result<Vec<Point>, SimError> {
    let mut order: Vec<usize> = (0..etas.len()).collect();
    if direction == Direction::Down {
        order.reverse();
    }
    let mut out: Vec<Option<Point>> = vec![None; etas.len()];
    let mut state = Init::rest();
    let mut engine = None;
    for i in order {
        let start = if direction == Direction::Rest {
            Init::rest()
        } else {
            state
        };
        let (p, next) = steady_state_with(&mut engine, model, etas[i], start, cfg)?;
        state = next;
        out[i] = Some(p);
    }
    Ok(out
        .into_iter()
        .map(|p| p.expect("every eta computed"))
        .collect())
}

/// Relative difference of an amplitude above which the steady states of
/// two branches (up, down, rest) at one η are distinct stable states.
pub const COEXISTING_REL: f64 = 1e-6;

/// Whether two *settled* points at the same η are different stable states:
/// A1/A or A2/A differ by more than [`COEXISTING_REL`] relative (1e-12
/// absolute near zero, e.g. A2 of two stuck orbits). Points that did not
/// settle (amplitudes over a window of a non-periodic response) or have no
/// amplitude (interrupted) are never called coexisting.
pub fn distinct_states(a: &Point, b: &Point) -> bool {
    let settled = |p: &Point| p.steady && p.amplitude1.is_some() && p.amplitude2.is_some();
    if !settled(a) || !settled(b) {
        return false;
    }
    let differ = |x: Option<f64>, y: Option<f64>| match (x, y) {
        (Some(x), Some(y)) => (x - y).abs() > (COEXISTING_REL * x.abs().max(y.abs())).max(1e-12),
        _ => false,
    };
    differ(a.amplitude1, b.amplitude1) || differ(a.amplitude2, b.amplitude2)
}

/// `n` equally spaced η in [lo, hi].
pub fn eta_grid(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    match n {
        0 => vec![],
        1 => vec![lo],
        _ => (0..n)
            .map(|i| lo + (hi - lo) * i as f64 / (n - 1) as f64)
            .collect(),
    }
}

/// One curve of a family.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CurveSpec {
    /// The model (its law carries ρs, ρd, D*).
    pub model: Model,
    /// Continuation policy.
    pub direction: Direction,
}

/// A slice `index` (0-based) of `count` of a family's work: whole curves for
/// continuation (each η depends on the previous one), single points for
/// curves from rest. Deterministic, so partial tables of a job array merge
/// into exactly the unsharded result.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shard {
    /// This slice, 0 ≤ index < count.
    pub index: usize,
    /// Number of slices.
    pub count: usize,
}

impl Shard {
    /// The whole family.
    pub const ALL: Shard = Shard { index: 0, count: 1 };

    fn owns(&self, unit: usize) -> bool {
        unit % self.count == self.index
    }
}

/// One computed point of a family: curve index, η index, result.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Row {
    /// Index of the curve in the family.
    pub curve: usize,
    /// Index of η in the grid.
    pub point: usize,
    /// The steady state there.
    pub value: Point,
}

/// Computes the family's curves (or this shard's part of them) in
/// parallel; `tick(n)` is called as n points complete. Rows are returned
/// ordered by (curve, point) whatever the thread count.
pub fn family(
    specs: &[CurveSpec],
    etas: &[f64],
    cfg: &SteadyConfig,
    shard: Shard,
    tick: &(dyn Fn(u64) + Sync),
) -> Result<Vec<Row>, SimError> {
    use rayon::prelude::*;
    // Work units: (curve, Some(point)) for curves from rest, (curve, None)
    // for continuation curves; numbered in this fixed order.
    let mut units = Vec::new();
    for (c, s) in specs.iter().enumerate() {
        if s.direction == Direction::Rest {
            units.extend((0..etas.len()).map(|p| (c, Some(p))));
        } else {
            units.push((c, None));
        }
    }
    let mine: Vec<(usize, Option<usize>)> = units
        .into_iter()
        .enumerate()
        .filter(|(u, _)| shard.owns(*u))
        .map(|(_, w)| w)
        .collect();
    let parts: Result<Vec<Vec<Row>>, SimError> = mine
        .par_iter()
        .map_init(
            || None,
            |engine, &(c, p)| {
                let spec = &specs[c];
                match p {
                    Some(p) => {
                        let (v, _) =
                            steady_state_with(engine, &spec.model, etas[p], Init::rest(), cfg)?;
                        tick(1);
                        Ok(vec![Row {
                            curve: c,
                            point: p,
                            value: v,
                        }])
                    }
                    None => {
                        let pts = curve(&spec.model, etas, spec.direction, cfg)?;
                        tick(pts.len() as u64);
                        Ok(pts
                            .into_iter()
                            .enumerate()
                            .map(|(p, v)| Row {
                                curve: c,
                                point: p,
                                value: v,
                            })
                            .collect())
                    }
                }
            },
        )
        .collect();
    let mut rows: Vec<Row> = parts?.into_iter().flatten().collect();
    rows.sort_by_key(|r| (r.curve, r.point));
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;

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
                },
                stop_below: None,
            };
            for budget in [40, 200] {
                let cfg = SteadyConfig {
                    max_periods: budget,
                    ..SteadyConfig::default()
                };
                let mut state = Init::rest();
                for k in 0..24 {
                    let eta = 0.3 + 0.05 * k as f64;
                    let sim = Sim::new(&model, eta).unwrap();
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
                    },
                    stop_below: None,
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
