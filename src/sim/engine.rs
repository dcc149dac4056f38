//! The exact event-driven engine: pieces together closed-form stick and slip
//! phases (see [`super::phase`]) at switching events located to machine
//! precision (see [`super::events`]).
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
//!
//! Time is kept as (period index n, offset s within the period), so the
//! forcing phase η·s stays exact over arbitrarily long runs.

use super::events::{self, EventFn, Jet};
use super::linalg::C64;
use super::monodromy::Monodromy;
use super::phase::{absorber, LinearPhase, Projection, Sampler};
use super::SimError;
use crate::model::Model;
use std::cell::{Cell, RefCell};
use std::f64::consts::PI;
use std::sync::{Arc, OnceLock};

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

/// Bracketing steps per forcing period above which [`Sim::new`] refuses a
/// model (fastest mode · 2π/η): a run would not finish in useful time.
pub const MAX_STEPS_PER_PERIOD: f64 = 1e7;

/// Work budget: events are bracketed on one radian of the fastest mode, so
/// a forcing period costs about fastest·2π/η steps; beyond
/// [`MAX_STEPS_PER_PERIOD`] a run would take minutes to hours per period
/// (e.g. m = 1e-6 with k = 1e6): refused with the numbers instead.
fn check_work(stick: &LinearPhase<2>, slip: &LinearPhase<4>, eta: f64) -> Result<(), SimError> {
    let steps = stick.fastest.max(slip.fastest) * 2.0 * PI / eta;
    if steps.is_nan() || steps > MAX_STEPS_PER_PERIOD {
        return Err(SimError::Unsupported(format!(
            "the absorber is too stiff for this forcing frequency: its fastest mode needs {steps:.2e} bracketing steps per forcing period (limit {MAX_STEPS_PER_PERIOD:.0e}); raise eta or bring m and k closer to 1"
        )));
    }
    Ok(())
}

/// The slip's switching functions' gradients ±e3 projected on its closed
/// form (see [`Sim::slip_events`]).
fn slip_projections(slip: &LinearPhase<4>) -> [Projection<4>; 2] {
    [
        slip.projection([0.0, 0.0, 0.0, 1.0]),
        slip.projection([0.0, 0.0, 0.0, -1.0]),
    ]
}

/// The engine for one model at one forcing frequency: all per-parameter-set
/// work (eigen-decompositions, particular solutions) is done here, once.
#[derive(Debug, Clone)]
pub struct Sim {
    model: Model,
    eta: f64,
    period: f64,
    stick: LinearPhase<2>,
    slip: LinearPhase<4>,
    /// The slip's switching functions projected on its closed form:
    /// gradients e3 and −e3 (ζ2' and −ζ2').
    slip_proj: [Projection<4>; 2],
    rho_s: f64,
    rho_d: f64,
    /// Speed at which the slip friction reaches the interruption level.
    v_interrupt: Option<f64>,
    /// Event times are refined to `resolution · ε`-ish relative to the
    /// period (1: machine precision).
    resolution: f64,
    /// The variational set-up for shooting's Jacobians, made on first use
    /// and shared by the engines of the same model at other η.
    monodromy: OnceLock<Option<Arc<Monodromy>>>,
}

impl Sim {
    /// Prepares the engine; rejects invalid parameters and laws the exact
    /// engine cannot integrate in closed form.
    pub fn new(model: &Model, eta: f64) -> Result<Self, SimError> {
        model.validate().map_err(SimError::Param)?;
        crate::model::validate_eta(eta).map_err(SimError::Param)?;
        let Some((rho_d, slope)) = model.law.affine() else {
            let affine: Vec<&str> = crate::model::LawKind::all()
                .iter()
                .filter(|k| !k.family().has_velocity_scale())
                .map(|k| k.as_str())
                .collect();
            return Err(SimError::Unsupported(format!(
                "the exact engine needs an affine friction law ({}); \
                 the {} law needs the numerical integrator",
                affine.join(", "),
                model.law.name()
            )));
        };
        let ab = &model.absorber;
        let stick = LinearPhase::new(absorber::stick_matrix(ab), absorber::stick_input(ab), eta)
            .ok_or_else(|| SimError::Unsupported("singular stick matrix".into()))?;
        let slip = LinearPhase::new(
            absorber::slip_matrix(ab, slope),
            absorber::slip_input(ab),
            eta,
        )
        .ok_or_else(|| SimError::Unsupported("singular slip matrix".into()))?;
        check_work(&stick, &slip, eta)?;
        let slip_proj = slip_projections(&slip);
        let thr = model.interrupt_level();
        let v_interrupt = if rho_d < thr {
            Some(0.0)
        } else if slope < 0.0 {
            Some((rho_d - thr) / -slope)
        } else {
            None
        };
        Ok(Self {
            model: *model,
            eta,
            period: 2.0 * PI / eta,
            stick,
            slip,
            slip_proj,
            rho_s: model.law.rho_s(),
            rho_d,
            v_interrupt,
            resolution: 1.0,
            monodromy: OnceLock::new(),
        })
    }

    /// The engine for the same model at another forcing frequency η,
    /// bit-identical to `Sim::new(model, η)` (with this one's root
    /// tolerance) but reusing its eigen-decompositions and step tables
    /// ([`LinearPhase::at_eta`]): a sweep over η sets the model up once.
    pub fn at_eta(&self, eta: f64) -> Result<Self, SimError> {
        crate::model::validate_eta(eta).map_err(SimError::Param)?;
        let stick = self
            .stick
            .at_eta(eta)
            .ok_or_else(|| SimError::Unsupported("singular stick matrix".into()))?;
        let slip = self
            .slip
            .at_eta(eta)
            .ok_or_else(|| SimError::Unsupported("singular slip matrix".into()))?;
        check_work(&stick, &slip, eta)?;
        let slip_proj = slip_projections(&slip);
        Ok(Self {
            eta,
            period: 2.0 * PI / eta,
            stick,
            slip,
            slip_proj,
            ..self.clone()
        })
    }

    /// Loosens the event-time resolution to about `tol` relative to the
    /// forcing period (default: machine precision). For work-precision
    /// studies only.
    pub fn with_root_tolerance(mut self, tol: f64) -> Self {
        self.resolution = (tol / (2.0 * f64::EPSILON)).max(1.0);
        self
    }

    /// The model.
    pub fn model(&self) -> &Model {
        &self.model
    }

    /// Forcing frequency ratio η.
    pub fn eta(&self) -> f64 {
        self.eta
    }

    /// Forcing period 2π/η.
    pub fn period(&self) -> f64 {
        self.period
    }

    /// The Jacobian machinery of the period map ([`Monodromy`]) for this
    /// model, `None` where it does not apply; set up once per model.
    pub fn monodromy(&self) -> Option<&Monodromy> {
        self.monodromy
            .get_or_init(|| Monodromy::new(self).map(Arc::new))
            .as_deref()
    }

    /// The state at offset δ into a phase that starts at `x` with mode
    /// `mode` at period offset `s0` (dense output of the exact solution,
    /// valid up to the phase's next event).
    pub fn state_in_phase(&self, x: &[f64; 4], mode: Mode, s0: f64, delta: f64) -> [f64; 4] {
        match mode {
            Mode::Stick { z2 } => {
                let p = self
                    .stick
                    .start([x[0], x[1]], s0, C64::new(1.0, 0.0), self.stick_c(z2));
                let y = self.stick.state(&p, delta);
                [y[0], y[1], z2, 0.0]
            }
            Mode::Slip { dir } => {
                let p = self
                    .slip
                    .start(*x, s0, C64::new(1.0, 0.0), self.slip_c(dir));
                self.slip.state(&p, delta)
            }
        }
    }

    #[inline]
    fn stick_c(&self, z2: f64) -> [f64; 2] {
        [0.0, z2 / self.model.absorber.m]
    }

    #[inline]
    fn slip_c(&self, dir: f64) -> [f64; 4] {
        [0.0, 0.0, 0.0, -dir * self.rho_d]
    }

    /// Integrates `periods` forcing periods from `init`, reporting to `obs`.
    pub fn run<O: Observer>(&self, init: Init, periods: u64, obs: &mut O) -> RunEnd {
        self.run_inner(init, C64::new(1.0, 0.0), periods, 0.0, obs)
    }

    /// Integrates a span of length `duration` of the drive
    /// `amplitude·cos(ητ + phase)` (τ from the span's start): whole periods,
    /// then the remainder. Period callbacks come at whole periods from the
    /// span's start.
    pub fn run_span<O: Observer>(
        &self,
        init: Init,
        phase: f64,
        amplitude: f64,
        duration: f64,
        obs: &mut O,
    ) -> RunEnd {
        let t = self.period;
        let mut full = (duration / t).floor();
        let mut tail = duration - full * t;
        if tail < 0.0 {
            tail = 0.0;
        }
        if t - tail <= 4.0 * f64::EPSILON * duration.max(t) {
            // The remainder is a whole period up to rounding.
            full += 1.0;
            tail = 0.0;
        }
        self.run_inner(
            init,
            C64::from_polar(amplitude, phase),
            full as u64,
            tail,
            obs,
        )
    }

    /// The event-driven integration loop behind [`Sim::run_span`]: `periods`
    /// whole forcing periods and a `tail`, from `init`, the drive `u`.
    ///
    /// Why this stays one function (≈220 lines): it is one loop over contact
    /// phases, the hot path of every sweep, fit and replay (see
    /// `benches/engine.rs`). Its loop state — the state `x` and `mode`, the
    /// period `n` and offset `s`, the pending sample time, the counters
    /// `events`, `period_events` and `instant`, `stick_time` and the period
    /// statistics — lives in locals the optimiser keeps in registers, and the
    /// two phase arms hand monomorphised closures (jet evaluator, marching
    /// cursor, sampler) to [`events::first_event`]. Splitting the phase step
    /// or the switch handling out would thread about ten mutable values and
    /// the observer through each call, and turn the early returns (stop,
    /// chatter, interruption) into status plumbing; it is allocation-free
    /// and must stay so.
    fn run_inner<O: Observer>(
        &self,
        init: Init,
        u: C64,
        periods: u64,
        tail: f64,
        obs: &mut O,
    ) -> RunEnd {
        let frictionless = self.model.law.is_frictionless();
        let mut mode = if frictionless {
            Mode::Slip { dir: 1.0 }
        } else if self.model.law.is_always_stuck() {
            Mode::Stick { z2: init.x[2] }
        } else {
            init.mode
        };
        let mut x = init.x;
        if let Mode::Stick { z2 } = mode {
            x[2] = z2;
            x[3] = 0.0;
        }
        let extremes = obs.wants_extremes();
        let mut pending = obs.next_sample();
        let t = self.period;
        let mut n: u64 = 0;
        let mut s = 0.0;
        let mut events: u64 = 0;
        let mut period_events: u64 = 0;
        let mut stick_time = 0.0;
        let mut stats = PeriodStats::new(&x);
        let mut instant = 0u32;
        let mut samp_stick = Sampler::<2>::default();
        let mut samp_slip = Sampler::<4>::default();
        let end = |n: u64, s: f64, x: [f64; 4], mode, status, events, stick_time| RunEnd {
            status,
            periods: n,
            tau: n as f64 * t + s,
            x,
            mode,
            events,
            stick_time,
        };
        while n < periods || (n == periods && s < tail) {
            let in_tail = n == periods;
            let left = if in_tail { tail - s } else { t - s };
            let tau0 = n as f64 * t;
            // Requested samples inside each step [a, b] of the phase, from
            // the phase's sample evaluator f(δ) → (state, rate).
            let mut sampler =
                |a: f64, b: f64, f: &mut dyn FnMut(f64) -> ([f64; 4], [f64; 4]), obs: &mut O| {
                    while let Some(ts) = pending {
                        let rel = ts - (tau0 + s);
                        if rel > b {
                            break;
                        }
                        let (x, dx) = f(rel.max(a));
                        obs.sample(ts, &x, &dx);
                        pending = obs.next_sample();
                    }
                };
            let (hit, x_end) = match mode {
                Mode::Stick { z2 } => {
                    let p = self.stick.start([x[0], x[1]], s, u, self.stick_c(z2));
                    // The marching cursor is shared: arbitrary offsets are
                    // evaluated from it (within one step, no libm). (The
                    // two-dimensional stick state is as cheap as projecting
                    // its two switching functions on the closed form.)
                    let cur = Cell::new(self.stick.cursor(&p));
                    let eval = |d: f64| stick_jet(self.stick.jet_near(&p, &cur.get(), d), z2);
                    let next = |b: f64| {
                        let mut c = cur.get();
                        if b == c.delta + self.stick.step {
                            let j = stick_jet(self.stick.advance(&p, &mut c), z2);
                            cur.set(c);
                            j
                        } else {
                            eval(b)
                        }
                    };
                    samp_stick.begin_phase();
                    let mut sample = |d: f64| {
                        let (y, dy) = self.stick.sample_near(&p, &cur.get(), &mut samp_stick, d);
                        ([y[0], y[1], z2, 0.0], [dy[0], dy[1], 0.0, 0.0])
                    };
                    let fns = self.stick_events(z2);
                    let nf = if self.rho_s.is_finite() { 2 } else { 0 };
                    let (hit, jb) = events::first_event(
                        &eval,
                        next,
                        &fns[..nf],
                        left,
                        self.stick.step,
                        self.resolution * t,
                        |a, ja, b, jb| {
                            if extremes {
                                track_extremum(&eval, &mut stats, a, ja, b, jb);
                            }
                            sampler(a, b, &mut sample, obs);
                        },
                    );
                    (hit.map(|h| (h.delta, h.which, h.jet.x)), jb.x)
                }
                // With exact extremes every step's jet is wanted: the
                // finder marches jets.
                Mode::Slip { dir } if extremes => {
                    let p = self.slip.start(x, s, u, self.slip_c(dir));
                    let cur = Cell::new(self.slip.cursor(&p));
                    let eval = |d: f64| slip_jet(self.slip.jet_near(&p, &cur.get(), d));
                    let next = |b: f64| {
                        let mut c = cur.get();
                        if b == c.delta + self.slip.step {
                            let j = slip_jet(self.slip.advance(&p, &mut c));
                            cur.set(c);
                            j
                        } else {
                            eval(b)
                        }
                    };
                    samp_slip.begin_phase();
                    let mut sample =
                        |d: f64| self.slip.sample_near(&p, &cur.get(), &mut samp_slip, d);
                    let (fns, nf) = self.slip_events(dir, frictionless);
                    let (hit, jb) = events::first_event(
                        &eval,
                        next,
                        &fns[..nf],
                        left,
                        self.slip.step,
                        self.resolution * t,
                        |a, ja, b, jb| {
                            track_extremum(&eval, &mut stats, a, ja, b, jb);
                            sampler(a, b, &mut sample, obs);
                        },
                    );
                    (hit.map(|h| (h.delta, h.which, h.jet.x)), jb.x)
                }
                Mode::Slip { dir } => {
                    let p = self.slip.start(x, s, u, self.slip_c(dir));
                    // The event finder sees phase points, on which the
                    // switching functions are projections (a few complex
                    // multiply-adds); jets are assembled only where needed.
                    // The cursor is borrowed in place (no copies of it).
                    // (Without extremes: the steady-state marches.)
                    let cur = RefCell::new(self.slip.cursor(&p));
                    let point = |d: f64| self.slip.point_near(&p, &cur.borrow(), d);
                    let next = |b: f64| {
                        let mut c = cur.borrow_mut();
                        if b == c.delta + self.slip.step {
                            self.slip.advance_point(&p, &mut c)
                        } else {
                            self.slip.point_near(&p, &c, b)
                        }
                    };
                    samp_slip.begin_phase();
                    let mut sample =
                        |d: f64| self.slip.sample_near(&p, &cur.borrow(), &mut samp_slip, d);
                    let (fns, nf) = self.slip_events(dir, frictionless);
                    // End of the slip: gradient dir·e3; interruption: −dir·e3.
                    let (pe, ps) = if dir > 0.0 { (0, 1) } else { (1, 0) };
                    // (The interruption's function only where it is used.)
                    let sw0 = self.slip.switch_start(&self.slip_proj[pe], &p, fns[0].g0);
                    let sw = [
                        sw0,
                        if nf > 1 {
                            self.slip.switch_start(&self.slip_proj[ps], &p, fns[1].g0)
                        } else {
                            sw0
                        },
                    ];
                    let (hit, qb) = events::first_event(
                        &point,
                        next,
                        &sw[..nf],
                        left,
                        self.slip.step,
                        self.resolution * t,
                        |a, _, b, _| sampler(a, b, &mut sample, obs),
                    );
                    match hit {
                        Some(h) => (Some((h.delta, h.which, self.slip.state_of(&p, &h.jet))), x),
                        None => (None, self.slip.state_of(&p, &qb)),
                    }
                }
            };
            match hit {
                None => {
                    if let Mode::Stick { .. } = mode {
                        stick_time += left;
                        stats.stick_time += left;
                    }
                    x = x_end;
                    if let Mode::Stick { z2 } = mode {
                        x[2] = z2;
                        x[3] = 0.0;
                    }
                    stats.add(x[0], x[2]);
                    if in_tail {
                        s = tail;
                        break;
                    }
                    n += 1;
                    s = 0.0;
                    instant = 0;
                    period_events = 0;
                    let flow = obs.period(n, &x, mode, &stats);
                    stats = PeriodStats::new(&x);
                    if flow == Flow::Stop {
                        return end(n, 0.0, x, mode, Status::Stopped, events, stick_time);
                    }
                }
                Some((h_delta, h_which, h_x)) => {
                    if h_delta == 0.0 {
                        instant += 1;
                        if instant > MAX_INSTANT_SWITCHES {
                            return end(
                                n,
                                s,
                                x,
                                mode,
                                Status::Chatter(format!(
                                    "{} switches at one instant (tau = {})",
                                    instant,
                                    n as f64 * t + s
                                )),
                                events,
                                stick_time,
                            );
                        }
                    } else {
                        instant = 0;
                    }
                    if let Mode::Stick { .. } = mode {
                        stick_time += h_delta;
                        stats.stick_time += h_delta;
                    }
                    s += h_delta;
                    let tau = n as f64 * t + s;
                    let z0 = || self.stick.drive(u, s).0;
                    match apply(
                        switch_with(&self.model, mode, h_which, &h_x, z0, tau),
                        tau,
                        obs,
                        &mut events,
                    ) {
                        Applied::Stop { x: xi, why } => {
                            stats.add(xi[0], xi[2]);
                            return end(
                                n,
                                s,
                                xi,
                                mode,
                                Status::Interrupted(why),
                                events,
                                stick_time,
                            );
                        }
                        Applied::Go { x: xn, mode: next } => {
                            x = xn;
                            mode = next;
                        }
                    }
                    stats.add(x[0], x[2]);
                    period_events += 1;
                    if period_events > MAX_EVENTS_PER_PERIOD {
                        return end(
                            n,
                            s,
                            x,
                            mode,
                            Status::Chatter(format!(
                                "more than {MAX_EVENTS_PER_PERIOD} events in one forcing period at tau = {tau}"
                            )),
                            events,
                            stick_time,
                        );
                    }
                }
            }
        }
        // A sample requested exactly at the end (up to rounding).
        let tau_end = n as f64 * t + s;
        while let Some(ts) = pending {
            if ts > tau_end * (1.0 + 8.0 * f64::EPSILON) {
                break;
            }
            let dx = self.rate(&x, mode, s, u);
            obs.sample(ts, &x, &dx);
            pending = obs.next_sample();
        }
        end(n, s, x, mode, Status::Completed, events, stick_time)
    }

    /// Time derivative of the state in `mode` at period offset s.
    fn rate(&self, x: &[f64; 4], mode: Mode, s: f64, u: C64) -> [f64; 4] {
        match mode {
            Mode::Stick { z2 } => {
                let p = self.stick.start([x[0], x[1]], s, u, self.stick_c(z2));
                let (_, d, _) = self.stick.jet(&p, 0.0);
                [d[0], d[1], 0.0, 0.0]
            }
            Mode::Slip { dir } => {
                let p = self.slip.start(*x, s, u, self.slip_c(dir));
                self.slip.jet(&p, 0.0).1
            }
        }
    }

    fn stick_events(&self, z2: f64) -> [EventFn<4>; 2] {
        let d = self.model.absorber.damping;
        // F = ζ1 − z2 + Dζ1'; h+ = ρs − F, h− = ρs + F.
        [
            EventFn {
                g: [-1.0, -d, 0.0, 0.0],
                g0: self.rho_s + z2,
            },
            EventFn {
                g: [1.0, d, 0.0, 0.0],
                g0: self.rho_s - z2,
            },
        ]
    }

    fn slip_events(&self, dir: f64, frictionless: bool) -> ([EventFn<4>; 2], usize) {
        let end = EventFn {
            g: [0.0, 0.0, 0.0, dir],
            g0: 0.0,
        };
        let stop = EventFn {
            g: [0.0, 0.0, 0.0, -dir],
            g0: self.v_interrupt.unwrap_or(0.0),
        };
        if frictionless {
            ([end, stop], 0)
        } else if self.v_interrupt.is_some() {
            ([end, stop], 2)
        } else {
            ([end, stop], 1)
        }
    }
}

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
            Switched::To {
                x: [x[0], x[1], z2, 0.0],
                kind,
                next: Mode::Slip { dir },
                stop_first: false,
            }
        }
        Mode::Slip { .. } if which == 1 => {
            let g = model.law.sliding(x[3].abs());
            let why = if g <= 0.0 {
                format!("sliding friction would turn negative at tau = {tau:.6}")
            } else {
                format!(
                    "sliding friction fell below {}*rho_s at tau = {tau:.6}",
                    model.stop_below.unwrap_or(0.0)
                )
            };
            Switched::Interrupt { x: *x, why }
        }
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
    let rho_s = model.law.rho_s();
    if rho_s == 0.0 {
        return Mode::Slip { dir: 1.0 };
    }
    let f = net_force(model, x);
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

#[inline]
fn stick_jet((y, dy, ddy): ([f64; 2], [f64; 2], [f64; 2]), z2: f64) -> Jet<4> {
    Jet {
        x: [y[0], y[1], z2, 0.0],
        dx: [dy[0], dy[1], 0.0, 0.0],
        ddx: [ddy[0], ddy[1], 0.0, 0.0],
    }
}

#[inline]
fn slip_jet((x, dx, ddx): ([f64; 4], [f64; 4], [f64; 4])) -> Jet<4> {
    Jet { x, dx, ddx }
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Law;

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

    /// An engine retuned to another η gives the same trajectory, to the
    /// last bit, as one set up for it: below and above the fastest mode
    /// (the step tables change there), for a static-dynamic law with a
    /// slope, and for a critically damped stick system (matrix exponential
    /// instead of the modal form).
    #[test]
    fn retuned_engine_is_bit_identical() {
        use crate::model::Absorber;
        let models = [
            Model {
                absorber: Absorber::default(),
                law: Law::Linear {
                    rho_s: 0.4,
                    rho_d: 0.3,
                    slope: -0.02,
                },
                stop_below: None,
            },
            Model {
                absorber: Absorber {
                    m: 1.0,
                    k: 3.0,
                    damping: 4.0,
                },
                law: Law::coulomb(0.5),
                stop_below: None,
            },
        ];
        for model in &models {
            let first = Sim::new(model, 0.37).unwrap();
            for eta in [0.6, 0.95, 1.3, 2.5, 7.0] {
                let fresh = Sim::new(model, eta).unwrap();
                let tuned = first.at_eta(eta).unwrap();
                assert_eq!(fresh.stick.is_modal(), tuned.stick.is_modal());
                let a = fresh.run(Init::rest(), 20, &mut ());
                let b = tuned.run(Init::rest(), 20, &mut ());
                assert_eq!(a.events, b.events, "eta {eta}");
                for i in 0..4 {
                    assert_eq!(a.x[i].to_bits(), b.x[i].to_bits(), "eta {eta}, x{i}");
                }
            }
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
