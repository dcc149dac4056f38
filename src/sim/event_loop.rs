//! The one event loop of every integrator (exact, numerical, RK4) and the
//! switching logic they share. An integrator is a [`Stepper`]: it advances
//! one contact mode to its next event or to a boundary it is given, with
//! dense output for samples and extremes; the loop owns time (forcing
//! period n, offset s), switching, the interruption rule, chatter guards,
//! period statistics and the observer.
//!
//! # Switching logic (derived from the physics, paper §2)
//!
//! Let `F = ζ1 − ζ2 + D(ζ1' − ζ2')` be the net non-friction force on M2.
//!
//! * **Stick** (ζ2 ≡ ζ2*, ζ2' = 0): the friction is passive, R = F, which
//!   the pad can hold while |F| ≤ ρs. The stick ends when |F| reaches ρs
//!   (eq. 4; the paper's ρ of eq. 5 is −F).
//! * **Breakaway direction**: M2 departs in the direction of F, the net
//!   force the pad can no longer hold: just after release ζ2'' =
//!   F − sgn(ζ2')·g(0⁺), which has the sign of F because |F| = ρs ≥ g(0⁺).
//!   The paper's text says sgn ζ2' = sgn ρ with ρ = ζ2* − ζ1 − Dζ1' = −F;
//!   that would accelerate M2 *against* the net force and contradict its own
//!   equation of motion, so we follow the physics. The reference trajectory
//!   in `datasets/reference/H1.json` (exact, 40 digits) uses sgn F too.
//! * **Slip** in direction s: friction −s·g(|ζ2'|); the slip ends when ζ2'
//!   reaches 0 (eq. 3). Then, with F at that instant: |F| < ρs → stick;
//!   |F| > ρs → reversal into direction sgn F (necessarily −s: a slip that
//!   decelerated to rest had s·F ≤ g(0⁺) ≤ ρs). At |F| = ρs to rounding:
//!   stick while |F| < ρs or F' points inward, else slip along F.
//! * **Interruption** (paper §3): a slip whose friction g(|ζ2'|) falls below
//!   `stop_below·ρs`, or would turn negative, ends the run.
//! * **Direction-dependent levels** (issue 34): everything above with the
//!   levels of the direction at hand ([`crate::model::Law::levels`]): the
//!   pad holds −ρs⁻ < F < ρs⁺, a slip in direction s uses g_s and the
//!   interruption level of s, and the end-of-slip test compares F with the
//!   threshold of F's side. (The reversal argument holds per side: a slip
//!   in direction s that decelerated to rest had s·F ≤ g_s(0⁺) ≤ ρs_s.)
//!
//! Time is kept as (period index n, offset s within the period), so the
//! forcing phase η·s stays exact over arbitrarily long runs.

use super::events::{self, Jet};
use crate::model::Model;

/// The contact state of M2.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Mode {
    /// M2 sticks at ζ2 = `z2`.
    Stick {
        /// The frozen displacement ζ2*.
        z2: f64,
    },
    /// M2 slides in direction `dir` (+1 or −1).
    Slip {
        /// Sign of ζ2'.
        dir: f64,
    },
}

/// Kind of a switching event (names as in the `--events` CSV).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EventKind {
    /// Slip → stick.
    Stick,
    /// Stick → slip with ζ2' > 0.
    SlipPlus,
    /// Stick → slip with ζ2' < 0.
    SlipMinus,
    /// Slip reversal to ζ2' > 0 without sticking.
    ReversePlus,
    /// Slip reversal to ζ2' < 0 without sticking.
    ReverseMinus,
    /// The paper's interruption rule fired; the run ends.
    Interrupt,
}

impl EventKind {
    /// Name in the `--events` CSV.
    pub fn as_str(self) -> &'static str {
        match self {
            EventKind::Stick => "stick",
            EventKind::SlipPlus => "slip+",
            EventKind::SlipMinus => "slip-",
            EventKind::ReversePlus => "reverse+",
            EventKind::ReverseMinus => "reverse-",
            EventKind::Interrupt => "interrupt",
        }
    }
}

/// A switching event.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Event {
    /// Time τ.
    pub tau: f64,
    /// What happened.
    pub kind: EventKind,
    /// State `[ζ1, ζ1', ζ2, ζ2']` at the event.
    pub x: [f64; 4],
}

/// Extremes and stick time of one forcing period.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PeriodStats {
    /// min ζ1, min ζ2.
    pub min: [f64; 2],
    /// max ζ1, max ζ2.
    pub max: [f64; 2],
    /// Time spent sticking.
    pub stick_time: f64,
}

impl PeriodStats {
    /// Statistics of a period starting at state x.
    pub fn new_at(x: &[f64; 4]) -> Self {
        Self::new(x)
    }

    fn new(x: &[f64; 4]) -> Self {
        Self {
            min: [x[0], x[2]],
            max: [x[0], x[2]],
            stick_time: 0.0,
        }
    }
    /// Includes a point (ζ1, ζ2).
    #[inline]
    pub fn add(&mut self, z1: f64, z2: f64) {
        self.min[0] = self.min[0].min(z1);
        self.max[0] = self.max[0].max(z1);
        self.min[1] = self.min[1].min(z2);
        self.max[1] = self.max[1].max(z2);
    }
}

/// What an observer wants after a period.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Flow {
    /// Go on.
    Continue,
    /// Stop the run here.
    Stop,
}

/// Receives what the engine computes; every method has a no-op default.
pub trait Observer {
    /// A switching event.
    fn event(&mut self, _ev: &Event) {}
    /// End of forcing period `n` (1-based count of completed periods) with
    /// the state on the Poincaré section and the period's statistics.
    fn period(&mut self, _n: u64, _x: &[f64; 4], _mode: Mode, _stats: &PeriodStats) -> Flow {
        Flow::Continue
    }
    /// The next time τ (from the run's start) at which a trajectory sample
    /// is wanted; asked once at the start and after each delivered sample
    /// (None: no more samples). Times must not decrease.
    fn next_sample(&mut self) -> Option<f64> {
        None
    }
    /// A trajectory sample: the exact state and its time derivative
    /// (ζ1', ζ1'', ζ2', ζ2'') at τ.
    fn sample(&mut self, _tau: f64, _x: &[f64; 4], _dx: &[f64; 4]) {}
    /// Whether ζ1's extremes must be located exactly (for amplitudes).
    fn wants_extremes(&self) -> bool {
        true
    }
}

impl Observer for () {
    fn wants_extremes(&self) -> bool {
        false
    }
}

/// Sample times on a grid of `per_period` samples per forcing period `t`
/// (τ = j·t/per_period, j = 0, 1, …): the usual trajectory output.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PeriodGrid {
    /// Forcing period.
    pub t: f64,
    /// Samples per period.
    pub per_period: u32,
    /// Index of the next sample.
    pub j: u64,
}

impl PeriodGrid {
    /// The next grid time (and moves past it).
    pub fn advance(&mut self) -> f64 {
        let per = u64::from(self.per_period);
        let tau = (self.j / per) as f64 * self.t
            + (self.j % per) as f64 * self.t / f64::from(self.per_period);
        self.j += 1;
        tau
    }
}

/// Why a run ended.
#[derive(Debug, Clone, PartialEq)]
pub enum Status {
    /// All requested periods were integrated.
    Completed,
    /// The observer stopped the run (e.g. steady state reached).
    Stopped,
    /// The paper's interruption rule fired.
    Interrupted(String),
    /// Events accumulate (Zeno/chattering) faster than the engine resolves.
    Chatter(String),
}

/// Where a run ended.
#[derive(Debug, Clone, PartialEq)]
pub struct RunEnd {
    /// Why it ended.
    pub status: Status,
    /// Completed forcing periods.
    pub periods: u64,
    /// Final time τ.
    pub tau: f64,
    /// Final state.
    pub x: [f64; 4],
    /// Final contact mode.
    pub mode: Mode,
    /// Number of switching events.
    pub events: u64,
    /// Total time spent sticking.
    pub stick_time: f64,
}

/// Initial condition of a run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Init {
    /// State `[ζ1, ζ1', ζ2, ζ2']`.
    pub x: [f64; 4],
    /// Contact mode (for `Stick` the state's ζ2 is used and ζ2' set to 0).
    pub mode: Mode,
}

impl Init {
    /// At rest, M2 sticking at ζ2 = 0 (the paper's start).
    pub fn rest() -> Self {
        Self {
            x: [0.0; 4],
            mode: Mode::Stick { z2: 0.0 },
        }
    }
}

/// Largest number of zero-length phases at one instant before the run is
/// declared chattering (a well-posed switch needs at most two).
pub(crate) const MAX_INSTANT_SWITCHES: u32 = 4;
/// Largest number of events within one forcing period (every integrator).
pub(crate) const MAX_EVENTS_PER_PERIOD: u64 = 100_000;
/// Net non-friction force on M2, `F = ζ1 − ζ2 + D(ζ1' − ζ2')`.
#[inline]
pub fn net_force(model: &Model, x: &[f64; 4]) -> f64 {
    x[0] - x[2] + model.absorber.damping * (x[1] - x[3])
}

/// The outcome of a switching event.
#[derive(Debug, Clone, PartialEq)]
pub enum Switched {
    /// The motion goes on in mode `next` from state `x`.
    To {
        /// State after the switch (ζ2' set to exactly 0 where it vanishes).
        x: [f64; 4],
        /// The event's kind.
        kind: EventKind,
        /// The new mode.
        next: Mode,
        /// A slip came to rest on the threshold and goes on the same way: a
        /// `stick` of zero length precedes the `slip±` event.
        stop_first: bool,
    },
    /// The interruption rule fired.
    Interrupt {
        /// State at the interruption.
        x: [f64; 4],
        /// Why.
        why: String,
    },
}

/// The switch when switching function `which` of `mode` fires at state `x`
/// (drive ζ0 = `z0`, time `tau` for messages). Stick functions: 0 = release
/// forwards (F = +ρs), 1 = backwards; slip functions: 0 = rest (ζ2' = 0),
/// 1 = interruption. Shared by every integrator.
pub fn switch(
    model: &Model,
    mode: Mode,
    which: usize,
    x: &[f64; 4],
    z0: f64,
    tau: f64,
) -> Switched {
    switch_with(model, mode, which, x, || z0, tau)
}

/// [`switch`] with the drive ζ0 evaluated only where it is needed (the
/// tie-break of [`after_slip`] on the threshold): the exact engine's drive
/// is a sincos.
#[inline]
pub(crate) fn switch_with<Z: FnOnce() -> f64>(
    model: &Model,
    mode: Mode,
    which: usize,
    x: &[f64; 4],
    z0: Z,
    tau: f64,
) -> Switched {
    match mode {
        Mode::Stick { z2 } => {
            let dir = if which == 0 { 1.0 } else { -1.0 };
            let kind = if dir > 0.0 {
                EventKind::SlipPlus
            } else {
                EventKind::SlipMinus
            };
            // With a contact spring M2 is moving when its slider breaks
            // away: the state goes on as it is.
            let x = match model.contact_stiffness {
                Some(_) => *x,
                None => [x[0], x[1], z2, 0.0],
            };
            Switched::To {
                x,
                kind,
                next: Mode::Slip { dir },
                stop_first: false,
            }
        }
        Mode::Slip { dir } if which == 1 => {
            let g = model.law.toward(dir).sliding(x[3].abs());
            let why = if g <= 0.0 {
                format!("sliding friction would turn negative at tau = {tau:.6}")
            } else {
                let level = if model.law.is_direction_dependent() && dir < 0.0 {
                    "rho_s_minus"
                } else {
                    "rho_s"
                };
                format!(
                    "sliding friction fell below {}*{level} at tau = {tau:.6}",
                    model.stop_below.unwrap_or(0.0)
                )
            };
            Switched::Interrupt { x: *x, why }
        }
        // Behind a contact spring the slider stops with M2 (ζ2' = 0) and
        // sticks where the spring holds the sliding level it carried
        // (P = ρd⁺ or −ρd⁻). It never reverses at once.
        Mode::Slip { dir } if model.contact_stiffness.is_some() => Switched::To {
            x: [x[0], x[1], x[2], 0.0],
            kind: EventKind::Stick,
            next: Mode::Stick {
                z2: model.slider_at_rest(dir, x[2]).unwrap_or(x[2]),
            },
            stop_first: false,
        },
        Mode::Slip { dir: old } => {
            let x = [x[0], x[1], x[2], 0.0];
            let (kind, next, stop_first) = match after_slip_with(model, &x, z0) {
                Mode::Stick { z2 } => (EventKind::Stick, Mode::Stick { z2 }, false),
                Mode::Slip { dir } if dir != old => {
                    let k = if dir > 0.0 {
                        EventKind::ReversePlus
                    } else {
                        EventKind::ReverseMinus
                    };
                    (k, Mode::Slip { dir }, false)
                }
                Mode::Slip { dir } => {
                    let k = if dir > 0.0 {
                        EventKind::SlipPlus
                    } else {
                        EventKind::SlipMinus
                    };
                    (k, Mode::Slip { dir }, true)
                }
            };
            Switched::To {
                x,
                kind,
                next,
                stop_first,
            }
        }
    }
}

/// The index of sliding direction `dir` in per-direction tables: 0 for
/// positive, 1 for negative.
#[inline]
pub(crate) fn side(dir: f64) -> usize {
    usize::from(dir < 0.0)
}

/// A switch applied: the run goes on, or stops at an interruption.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Applied {
    /// Go on from `x` in `mode`.
    Go { x: [f64; 4], mode: Mode },
    /// The interruption rule fired at `x`.
    Stop { x: [f64; 4], why: String },
}

/// Reports a switch's events to the observer (counting them) and says how
/// the run goes on; shared by every integrator.
pub(crate) fn apply<O: Observer + ?Sized>(
    sw: Switched,
    tau: f64,
    obs: &mut O,
    events: &mut u64,
) -> Applied {
    match sw {
        Switched::Interrupt { x, why } => {
            obs.event(&Event {
                tau,
                kind: EventKind::Interrupt,
                x,
            });
            *events += 1;
            Applied::Stop { x, why }
        }
        Switched::To {
            x,
            kind,
            next,
            stop_first,
        } => {
            if stop_first {
                obs.event(&Event {
                    tau,
                    kind: EventKind::Stick,
                    x,
                });
                *events += 1;
            }
            obs.event(&Event { tau, kind, x });
            *events += 1;
            Applied::Go { x, mode: next }
        }
    }
}

/// The contact mode after a slip has come to rest (ζ2' = 0) with the drive
/// at ζ0 = `z0`; see the module doc for the derivation.
pub fn after_slip(model: &Model, x: &[f64; 4], z0: f64) -> Mode {
    after_slip_with(model, x, || z0)
}

/// [`after_slip`] with ζ0 evaluated only on the threshold.
#[inline]
fn after_slip_with<Z: FnOnce() -> f64>(model: &Model, x: &[f64; 4], z0: Z) -> Mode {
    if model.law.rho_s() == 0.0 {
        return Mode::Slip { dir: 1.0 };
    }
    let f = net_force(model, x);
    // The threshold on F's side (−ρs⁻ < F < ρs⁺ holds the pad).
    let rho_s = model.law.levels(f).rho_s;
    let ab = &model.absorber;
    let tol = 64.0 * f64::EPSILON * (rho_s + x[0].abs() + x[2].abs() + ab.damping * x[1].abs());
    if f.abs() < rho_s - tol {
        return Mode::Stick { z2: x[2] };
    }
    if f.abs() > rho_s + tol {
        return Mode::Slip { dir: f.signum() };
    }
    // On the threshold to rounding: stick while the pad can hold (|F| < ρs)
    // or F' in the stick dynamics points inward; slip along F only when
    // |F| ≥ ρs and F' points outward. (Sliding from |F| < ρs would start
    // with ζ2'' = |F| − ρs < 0 when ρd = ρs: at a maximum of F the slip
    // cannot leave rest, comes back at once, and the tie-break repeated
    // itself: a false chatter. Sticking there is exact: the stick's own
    // switching function releases M2 as soon as |F| reaches ρs.)
    let dd1 = (-ab.damping * x[1] - (1.0 + ab.k) * x[0] + x[2] + ab.k * z0()) / ab.m;
    let df = x[1] + ab.damping * dd1;
    if f.abs() < rho_s || f.signum() * df < 0.0 {
        Mode::Stick { z2: x[2] }
    } else {
        Mode::Slip { dir: f.signum() }
    }
}

/// Locates the extremes of ζ1 and ζ2 inside a step (sign changes of ζ1',
/// ζ2') exactly. (Within a slip with friction ζ2' cannot change sign, a
/// zero of ζ2' is an event; without friction it can.)
///
/// Only the extreme *value* is wanted, and it is stationary in time: from
/// the Hermite guess, Newton steps on ζ' (up to [`EXTREMUM_NEWTON`]) until
/// the next step dt = −ζ'/ζ'' is below 1e-6 of the step length h ≤
/// 1/(fastest rate); the value is then ζ − ζ'²/(2ζ''), whose neglected
/// term ζ'''·dt³/6 is below 2e-19 of the motion's size (|ζ'''| is at most
/// the fastest rate cubed times it), far below rounding. Usually
/// three solution evaluations where refining the time to machine precision
/// took five or six. An extremum at the step's end b (the Newton step from
/// b within the same tolerance) is taken from the jet at b without any
/// evaluation: so is the last step of a slip that ends at rest (ζ2' = 0 at
/// the event, where its sign is rounding's, so that it seems to change
/// sign inside the step; Newton from inside stepped past b every time, and
/// the fallback below bisected to b in about 45 evaluations). Where Newton
/// leaves the bracket or has not converged, the time is refined to machine
/// precision as before. (The numerical engines call this on their own
/// integration steps and dense output, whose interpolation error is far
/// above the neglected term.)
#[inline]
pub(crate) fn track_extremum<E: Fn(f64) -> Jet<4>>(
    eval: &E,
    st: &mut PeriodStats,
    a: f64,
    ja: &Jet<4>,
    b: f64,
    jb: &Jet<4>,
) {
    for c in [0, 2] {
        let (va, vb) = (ja.dx[c], jb.dx[c]);
        if va * vb < 0.0 {
            let accb = jb.ddx[c];
            if acc_step_within(vb, accb, b - a) {
                // The extremum is at b: its value ζ(b) − ζ'(b)²/(2ζ''(b)).
                let mut p = [jb.x[0], jb.x[2]];
                p[c / 2] = jb.x[c] - 0.5 * vb * vb / accb;
                st.add(p[0], p[1]);
                continue;
            }
            let sgn = va.signum();
            let g =
                events::hermite_guess(a, sgn * va, sgn * ja.ddx[c], b, sgn * vb, sgn * jb.ddx[c]);
            match extremum_newton(eval, c, a, b, g) {
                Some((value, j)) => {
                    // The extreme of ζc, and the other coordinate at the
                    // trajectory point next to it.
                    let mut p = [j.x[0], j.x[2]];
                    p[c / 2] = value;
                    st.add(p[0], p[1]);
                }
                None => {
                    let r = events::refine(
                        |d| {
                            let j = eval(d);
                            (sgn * j.dx[c], sgn * j.ddx[c], 0.0)
                        },
                        a,
                        b,
                        b,
                        g,
                    );
                    let j = eval(r);
                    st.add(j.x[0], j.x[2]);
                }
            }
        }
    }
    st.add(jb.x[0], jb.x[2]);
}

/// Whether the Newton step −v/acc to a zero of ζ' is within the tolerance
/// of [`track_extremum`] for a step of length `h` (see there).
#[inline]
fn acc_step_within(v: f64, acc: f64, h: f64) -> bool {
    acc != 0.0 && acc.is_finite() && (v / acc).abs() <= 1e-6 * h
}

/// Newton steps allowed by [`track_extremum`] before it falls back to
/// refining the time.
const EXTREMUM_NEWTON: usize = 4;

/// The extreme value of coordinate `c` inside (a, b) from the guess `g` by
/// Newton steps on its velocity (see [`track_extremum`]), with the jet of
/// the last point evaluated; `None` where Newton leaves (a, b) or does not
/// converge.
#[inline]
fn extremum_newton<E: Fn(f64) -> Jet<4>>(
    eval: &E,
    c: usize,
    a: f64,
    b: f64,
    g: f64,
) -> Option<(f64, Jet<4>)> {
    let mut t = if g > a && g < b { g } else { 0.5 * (a + b) };
    for _ in 0..EXTREMUM_NEWTON {
        let j = eval(t);
        let (v, acc) = (j.dx[c], j.ddx[c]);
        if acc == 0.0 || !acc.is_finite() {
            return None;
        }
        if acc_step_within(v, acc, b - a) {
            return Some((j.x[c] - 0.5 * v * v / acc, j));
        }
        let dt = -v / acc;
        t += dt;
        if !(t > a && t < b) {
            return None;
        }
    }
    None
}

/// How one advance of a [`Stepper`] ended.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Advance {
    /// No event within `delta` of the advance's start, at state `x`; `end`:
    /// the boundary it was given is reached (to rounding).
    Moved {
        /// Time advanced.
        delta: f64,
        /// State there.
        x: [f64; 4],
        /// Whether the boundary is reached.
        end: bool,
    },
    /// Switching function `which` of the mode vanishes after `delta`, at
    /// state `x` (see [`switch`] for the numbering).
    Hit {
        /// Time to the event.
        delta: f64,
        /// Which switching function.
        which: usize,
        /// State at the event.
        x: [f64; 4],
    },
    /// The integrator's step size underflowed at τ = `tau` (reported as
    /// [`Status::Chatter`]). (No message here: the advance stays `Copy`,
    /// with no drop glue in the loop.)
    Underflow {
        /// Where.
        tau: f64,
    },
}

/// What the loop lends a stepper during one advance: the observer's
/// trajectory samples and the period's extremes.
pub(crate) struct Watch<'a, O: ?Sized> {
    obs: &'a mut O,
    pending: &'a mut Option<f64>,
    stats: &'a mut PeriodStats,
    extremes: bool,
}

impl<O: Observer + ?Sized> Watch<'_, O> {
    /// The next sample time wanted (absolute τ), if any.
    #[inline]
    pub(crate) fn pending(&self) -> Option<f64> {
        *self.pending
    }

    /// Delivers the pending sample (state and rate at its time).
    #[inline]
    pub(crate) fn deliver(&mut self, tau: f64, x: &[f64; 4], dx: &[f64; 4]) {
        self.obs.sample(tau, x, dx);
        *self.pending = self.obs.next_sample();
    }

    /// Delivers the samples inside the step [a, b] of a phase that starts
    /// at τ = `origin`, from the phase's evaluator f(δ) → (state, rate).
    #[inline]
    pub(crate) fn samples(
        &mut self,
        origin: f64,
        a: f64,
        b: f64,
        f: &mut dyn FnMut(f64) -> ([f64; 4], [f64; 4]),
    ) {
        while let Some(ts) = *self.pending {
            let rel = ts - origin;
            if rel > b {
                break;
            }
            let (x, dx) = f(rel.max(a));
            self.deliver(ts, &x, &dx);
        }
    }

    /// Whether the observer wants ζ1's and ζ2's extremes located exactly.
    #[inline]
    pub(crate) fn wants_extremes(&self) -> bool {
        self.extremes
    }

    /// Locates the extremes inside the step [a, b] from the dense output
    /// `eval` (where wanted; see [`track_extremum`]).
    #[inline]
    pub(crate) fn extremes<E: Fn(f64) -> Jet<4>>(
        &mut self,
        eval: &E,
        a: f64,
        ja: &Jet<4>,
        b: f64,
        jb: &Jet<4>,
    ) {
        if self.extremes {
            track_extremum(eval, self.stats, a, ja, b, jb);
        }
    }

    /// Includes a trajectory point in the period's statistics (integrators
    /// that take amplitudes from their step points).
    #[inline]
    pub(crate) fn point(&mut self, x: &[f64; 4]) {
        self.stats.add(x[0], x[2]);
    }
}

/// An integrator of the contact modes: what differs between the exact,
/// numerical and RK4 engines. Time is (forcing period n, offset s); a
/// drive without a period has n = 0 and s = τ.
pub(crate) trait Stepper {
    /// The model integrated.
    fn model(&self) -> &Model;
    /// The forcing period; `None`: the drive has none (events are then
    /// counted per [`Stepper::window`] for the chatter guard).
    fn period(&self) -> Option<f64>;
    /// The span per which events are counted without a forcing period.
    fn window(&self) -> f64 {
        f64::INFINITY
    }
    /// A phase begins in `mode` at `x`, offset `s` of period `n` (`first`:
    /// the run's start; otherwise right after a switch).
    fn begin(&mut self, mode: Mode, x: &[f64; 4], n: u64, s: f64, first: bool);
    /// Advances `mode` from `x` at (n, s) to its next event or at most to
    /// offset `s_end` of the period, delivering the samples and extremes
    /// inside through `watch`.
    fn advance<O: Observer + ?Sized>(
        &mut self,
        mode: Mode,
        x: &[f64; 4],
        n: u64,
        s: f64,
        s_end: f64,
        watch: &mut Watch<'_, O>,
    ) -> Advance;
    /// The time τ of (n, s), as events, messages and the run's end report
    /// it: n·T + s (s without a period). A stepper that keeps its own clock
    /// (the numerical engine's is absolute, so that its memoised drive
    /// values hit) returns it.
    fn now(&self, n: u64, s: f64) -> f64 {
        match self.period() {
            Some(t) => n as f64 * t + s,
            None => s,
        }
    }
    /// The drive's position ζ0 at (n, s).
    fn drive(&self, n: u64, s: f64) -> f64;
    /// The state's rate in `mode` at (n, s).
    fn rate(&self, mode: Mode, x: &[f64; 4], n: u64, s: f64) -> [f64; 4];
}

/// Runs `periods` forcing periods and a `tail` (without a forcing period:
/// `periods` = 0 and the whole duration as the tail) from `init` with the
/// integrator `st`, reporting to `obs`: the one event loop.
///
/// It owns the contact mode, time, the switch at each event (with the
/// interruption rule), the chatter guards (zero-length phases at one
/// instant, events per forcing period), stick time, period statistics and
/// the observer's period callbacks and final samples. Its state stays in
/// locals; the stepper is monomorphised into it.
pub(crate) fn run<S: Stepper, O: Observer>(
    mut st: S,
    init: Init,
    periods: u64,
    tail: f64,
    obs: &mut O,
) -> RunEnd {
    let model = *st.model();
    // A rigid stick freezes M2 at the stick position; behind a contact
    // spring the stick position is the slider's and M2 moves.
    let rigid = model.contact_stiffness.is_none();
    let mut mode = if model.law.is_frictionless() {
        Mode::Slip { dir: 1.0 }
    } else if model.law.is_always_stuck() {
        match init.mode {
            Mode::Stick { z2 } if !rigid => Mode::Stick { z2 },
            _ => Mode::Stick { z2: init.x[2] },
        }
    } else {
        init.mode
    };
    let mut x = init.x;
    if let Mode::Stick { z2 } = mode {
        if rigid {
            x[2] = z2;
            x[3] = 0.0;
        }
    }
    let period = st.period();
    let t = period.unwrap_or(f64::INFINITY);
    let extremes = obs.wants_extremes();
    let mut pending = obs.next_sample();
    let (mut n, mut s) = (0u64, 0.0f64);
    let (mut events, mut stick_time) = (0u64, 0.0f64);
    let mut stats = PeriodStats::new(&x);
    let mut instant = 0u32;
    // Events are counted per forcing period (per the stepper's window
    // without one).
    let window = period.unwrap_or_else(|| st.window());
    let (mut window_end, mut window_events) = (window, 0u64);
    st.begin(mode, &x, 0, 0.0, true);
    let status = loop {
        let in_tail = n == periods;
        // (Not `s >= tail`: a NaN tail ends the run too.)
        let before_end = s < tail;
        if in_tail && !before_end {
            break Status::Completed;
        }
        let s_end = if in_tail { tail } else { t };
        let step = st.advance(
            mode,
            &x,
            n,
            s,
            s_end,
            &mut Watch {
                obs: &mut *obs,
                pending: &mut pending,
                stats: &mut stats,
                extremes,
            },
        );
        let stuck = matches!(mode, Mode::Stick { .. });
        match step {
            Advance::Underflow { tau } => {
                break Status::Chatter(format!("step size underflow at tau = {tau}"))
            }
            Advance::Moved { delta, x: xe, end } => {
                if stuck {
                    stick_time += delta;
                    stats.stick_time += delta;
                }
                x = xe;
                if let Mode::Stick { z2 } = mode {
                    if rigid {
                        x[2] = z2;
                        x[3] = 0.0;
                    }
                }
                instant = 0;
                if !end {
                    s += delta;
                    continue;
                }
                stats.add(x[0], x[2]);
                if in_tail {
                    s = tail;
                    break Status::Completed;
                }
                n += 1;
                s = 0.0;
                let flow = obs.period(n, &x, mode, &stats);
                stats = PeriodStats::new(&x);
                if flow == Flow::Stop {
                    break Status::Stopped;
                }
            }
            Advance::Hit {
                delta,
                which,
                x: hx,
            } => {
                instant = if delta == 0.0 { instant + 1 } else { 0 };
                if instant > MAX_INSTANT_SWITCHES {
                    break Status::Chatter(format!(
                        "{} switches at one instant (tau = {})",
                        instant,
                        st.now(n, s)
                    ));
                }
                if stuck {
                    stick_time += delta;
                    stats.stick_time += delta;
                }
                s += delta;
                let tau = st.now(n, s);
                let sw = switch_with(&model, mode, which, &hx, || st.drive(n, s), tau);
                match apply(sw, tau, obs, &mut events) {
                    Applied::Stop { x: xi, why } => {
                        stats.add(xi[0], xi[2]);
                        x = xi;
                        break Status::Interrupted(why);
                    }
                    Applied::Go { x: xn, mode: next } => {
                        x = xn;
                        mode = next;
                    }
                }
                stats.add(x[0], x[2]);
                st.begin(mode, &x, n, s, false);
                if tau >= window_end {
                    window_end = ((tau / window).floor() + 1.0) * window;
                    window_events = 0;
                }
                window_events += 1;
                if window_events > MAX_EVENTS_PER_PERIOD {
                    break Status::Chatter(format!(
                        "more than {MAX_EVENTS_PER_PERIOD} events in one forcing period at tau = {tau}"
                    ));
                }
            }
        }
    };
    if status == Status::Completed {
        // A sample requested exactly at the end (up to rounding).
        let tau_end = st.now(n, s);
        while let Some(ts) = pending {
            if ts > tau_end * (1.0 + 8.0 * f64::EPSILON) {
                break;
            }
            let dx = st.rate(mode, &x, n, s);
            obs.sample(ts, &x, &dx);
            pending = obs.next_sample();
        }
    }
    RunEnd {
        status,
        periods: n,
        tau: st.now(n, s),
        x,
        mode,
        events,
        stick_time,
    }
}

/// Splits a span of length `duration` into whole forcing periods of length
/// `t` and a remainder (a remainder within rounding of a whole period
/// counts as one).
pub(crate) fn split_span(duration: f64, t: f64) -> (u64, f64) {
    let mut full = (duration / t).floor();
    let mut tail = duration - full * t;
    if tail < 0.0 {
        tail = 0.0;
    }
    if t - tail <= 4.0 * f64::EPSILON * duration.max(t) {
        full += 1.0;
        tail = 0.0;
    }
    (full as u64, tail)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// ζ1 = cos t + 0.3 sin(2.7t + 0.4) (fastest rate 2.7) and
    /// ζ2 = 0.5 cos(0.6t + 1), with their derivatives.
    fn jet(t: f64) -> Jet<4> {
        let (w, p) = (2.7, 0.4);
        let (v, q) = (0.6, 1.0);
        let x1 = t.cos() + 0.3 * (w * t + p).sin();
        let d1 = -t.sin() + 0.3 * w * (w * t + p).cos();
        let dd1 = -t.cos() - 0.3 * w * w * (w * t + p).sin();
        let x2 = 0.5 * (v * t + q).cos();
        let d2 = -0.5 * v * (v * t + q).sin();
        let dd2 = -0.5 * v * v * (v * t + q).cos();
        Jet {
            x: [x1, d1, x2, d2],
            dx: [d1, dd1, d2, dd2],
            ddx: [dd1, 0.0, dd2, 0.0],
        }
    }

    /// The extremes from Newton plus the quadratic correction equal the
    /// extremes at times refined to machine precision (the previous
    /// method), to rounding, step by step over 40 steps with many extremes
    /// of both coordinates.
    #[test]
    fn extremum_value_matches_refined_time() {
        let h = 1.0 / 2.7;
        let mut found = 0;
        for k in 0..40 {
            let (a, b) = (k as f64 * h, (k + 1) as f64 * h);
            let (ja, jb) = (jet(a), jet(b));
            let mut fast = PeriodStats::new(&ja.x);
            let mut exact = PeriodStats::new(&ja.x);
            track_extremum(&jet, &mut fast, a, &ja, b, &jb);
            for c in [0, 2] {
                if ja.dx[c] * jb.dx[c] < 0.0 {
                    found += 1;
                    let sgn = ja.dx[c].signum();
                    let r = events::refine(
                        |d| {
                            let j = jet(d);
                            (sgn * j.dx[c], sgn * j.ddx[c], 0.0)
                        },
                        a,
                        b,
                        b,
                        f64::NAN,
                    );
                    let j = jet(r);
                    exact.add(j.x[0], j.x[2]);
                }
            }
            exact.add(jb.x[0], jb.x[2]);
            for i in 0..2 {
                for (f, e) in [(fast.min[i], exact.min[i]), (fast.max[i], exact.max[i])] {
                    assert!((f - e).abs() <= 4.0 * f64::EPSILON, "step {k}: {f} vs {e}");
                }
            }
        }
        assert!(found >= 8, "{found} extremes");
    }
}
