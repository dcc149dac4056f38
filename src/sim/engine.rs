//! The exact event-driven engine: pieces together closed-form stick and slip
//! phases (see [`super::phase`]) at switching events located to machine
//! precision (see [`super::events`]), as a [`Stepper`] of the one event
//! loop ([`super::event_loop`], which owns the switching logic).
//!
//! Time is kept as (period index n, offset s within the period), so the
//! forcing phase η·s stays exact over arbitrarily long runs.

use super::event_loop::{self, side, Advance, Stepper, Watch};
pub use super::event_loop::{
    after_slip, net_force, switch, Event, EventKind, Flow, Init, Mode, Observer, PeriodGrid,
    PeriodStats, RunEnd, Status, Switched,
};
use super::events::{self, EventFn, Jet};
use super::linalg::C64;
use super::phase::{absorber, LinearPhase, Projection, Sampler};
use super::SimError;
use crate::model::Model;
use std::cell::{Cell, RefCell};
use std::f64::consts::PI;

/// Bracketing steps per forcing period above which [`Sim::new`] refuses a
/// model (fastest mode · 2π/η): a run would not finish in useful time.
pub const MAX_STEPS_PER_PERIOD: f64 = 1e7;

/// Work budget: events are bracketed on one radian of the fastest mode, so
/// a forcing period costs about fastest·2π/η steps; beyond
/// [`MAX_STEPS_PER_PERIOD`] a run would take minutes to hours per period
/// (e.g. m = 1e-6 with k = 1e6): refused with the numbers instead.
fn check_work(
    stick: &LinearPhase<2>,
    slip: &LinearPhase<4>,
    held: Option<&LinearPhase<4>>,
    eta: f64,
) -> Result<(), SimError> {
    let held = held.map_or(0.0, |h| h.fastest);
    let steps = stick.fastest.max(slip.fastest).max(held) * 2.0 * PI / eta;
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
    /// Stick thresholds by sliding direction ([`side`]: ρs⁺, ρs⁻).
    rho_s: [f64; 2],
    /// Dynamic levels by sliding direction (ρd⁺, ρd⁻).
    rho_d: [f64; 2],
    /// Speed at which the slip friction reaches the interruption level, by
    /// sliding direction.
    v_interrupt: [Option<f64>; 2],
    /// Event times are refined to `resolution · ε`-ish relative to the
    /// period (1: machine precision).
    resolution: f64,
    /// With a contact spring κ (issue 34): the held phase (slider stuck at
    /// ζs, M2 on the spring) and κ.
    /// (Boxed: the paper's model copies a small engine.)
    held: Option<Box<(LinearPhase<4>, f64)>>,
}

impl Sim {
    /// Prepares the engine; rejects invalid parameters and laws the exact
    /// engine cannot integrate in closed form.
    pub fn new(model: &Model, eta: f64) -> Result<Self, SimError> {
        model.validate().map_err(SimError::Param)?;
        crate::model::validate_eta(eta).map_err(SimError::Param)?;
        let Some((_, slope)) = model.law.affine() else {
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
        let held = match model.contact_stiffness {
            Some(kappa) => Some(Box::new((
                LinearPhase::new(
                    absorber::held_matrix(ab, kappa),
                    absorber::slip_input(ab),
                    eta,
                )
                .ok_or_else(|| SimError::Unsupported("singular held matrix".into()))?,
                kappa,
            ))),
            None => None,
        };
        check_work(&stick, &slip, held.as_ref().map(|h| &h.0), eta)?;
        let slip_proj = slip_projections(&slip);
        let levels = [model.law.levels(1.0), model.law.levels(-1.0)];
        let v_interrupt = [1.0, -1.0].map(|dir| model.interrupt_speed(dir));
        Ok(Self {
            model: *model,
            eta,
            period: 2.0 * PI / eta,
            stick,
            slip,
            slip_proj,
            rho_s: levels.map(|l| l.rho_s),
            rho_d: levels.map(|l| l.rho_d),
            v_interrupt,
            resolution: 1.0,
            held,
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
        let held = match &self.held {
            Some(h) => Some(Box::new((
                h.0.at_eta(eta)
                    .ok_or_else(|| SimError::Unsupported("singular held matrix".into()))?,
                h.1,
            ))),
            None => None,
        };
        check_work(&stick, &slip, held.as_ref().map(|h| &h.0), eta)?;
        let slip_proj = slip_projections(&slip);
        Ok(Self {
            held,
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

    /// The state at offset δ into a phase that starts at `x` with mode
    /// `mode` at period offset `s0` (dense output of the exact solution,
    /// valid up to the phase's next event).
    pub fn state_in_phase(&self, x: &[f64; 4], mode: Mode, s0: f64, delta: f64) -> [f64; 4] {
        match mode {
            Mode::Stick { z2 } if self.held.is_some() => {
                let (held, kappa) = &**self.held.as_ref().expect("held");
                let p = held.start(*x, s0, C64::new(1.0, 0.0), held_c(*kappa, z2));
                held.state(&p, delta)
            }
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
        [0.0, 0.0, 0.0, -dir * self.rho_d[side(dir)]]
    }

    /// Integrates `periods` forcing periods from `init`, reporting to `obs`.
    pub fn run<O: Observer>(&self, init: Init, periods: u64, obs: &mut O) -> RunEnd {
        let st = Exact::new(self, C64::new(1.0, 0.0));
        event_loop::run(st, init, periods, 0.0, obs)
    }

    /// Integrates `periods` whole forcing periods of the drive
    /// `amplitude·cos(ητ + phase)` from `init`.
    pub fn run_periods<O: Observer>(
        &self,
        init: Init,
        phase: f64,
        amplitude: f64,
        periods: u64,
        obs: &mut O,
    ) -> RunEnd {
        let st = Exact::new(self, C64::from_polar(amplitude, phase));
        event_loop::run(st, init, periods, 0.0, obs)
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
        let (full, tail) = event_loop::split_span(duration, self.period);
        let st = Exact::new(self, C64::from_polar(amplitude, phase));
        event_loop::run(st, init, full, tail, obs)
    }

    /// Time derivative of the state in `mode` at period offset s.
    fn rate(&self, x: &[f64; 4], mode: Mode, s: f64, u: C64) -> [f64; 4] {
        match mode {
            Mode::Stick { z2 } if self.held.is_some() => {
                let (held, kappa) = &**self.held.as_ref().expect("held");
                let p = held.start(*x, s, u, held_c(*kappa, z2));
                held.jet(&p, 0.0).1
            }
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
        // F = ζ1 − z2 + Dζ1'; h+ = ρs⁺ − F, h− = ρs⁻ + F.
        [
            EventFn {
                g: [-1.0, -d, 0.0, 0.0],
                g0: self.rho_s[0] + z2,
            },
            EventFn {
                g: [1.0, d, 0.0, 0.0],
                g0: self.rho_s[1] - z2,
            },
        ]
    }

    /// The held phase's switching functions (slider stuck at `zs`): the
    /// spring's pull P = κ(ζ2 − ζs) reaches ρs⁺ (h+ = ρs⁺ − P) or −ρs⁻
    /// (h− = ρs⁻ + P).
    fn held_events(&self, kappa: f64, zs: f64) -> [EventFn<4>; 2] {
        [
            EventFn {
                g: [0.0, 0.0, -kappa, 0.0],
                g0: self.rho_s[0] + kappa * zs,
            },
            EventFn {
                g: [0.0, 0.0, kappa, 0.0],
                g0: self.rho_s[1] - kappa * zs,
            },
        ]
    }

    fn slip_events(&self, dir: f64, frictionless: bool) -> ([EventFn<4>; 2], usize) {
        let end = EventFn {
            g: [0.0, 0.0, 0.0, dir],
            g0: 0.0,
        };
        let v_interrupt = self.v_interrupt[side(dir)];
        let stop = EventFn {
            g: [0.0, 0.0, 0.0, -dir],
            g0: v_interrupt.unwrap_or(0.0),
        };
        if frictionless {
            ([end, stop], 0)
        } else if v_interrupt.is_some() {
            ([end, stop], 2)
        } else {
            ([end, stop], 1)
        }
    }
}

/// The exact engine as a [`Stepper`]: one closed-form phase per advance,
/// marched in steps of one radian of its fastest mode, with the drive
/// `u·e^{iητ}` (a complex amplitude) and the samplers' scratch.
struct Exact<'a> {
    sim: &'a Sim,
    u: C64,
    frictionless: bool,
    samp_stick: Sampler<2>,
    samp_slip: Sampler<4>,
    /// The held phase's own sampler: a sampler caches its phase system's
    /// factors e^{λΔ}, so the held and slip systems cannot share one.
    samp_held: Sampler<4>,
}

impl<'a> Exact<'a> {
    fn new(sim: &'a Sim, u: C64) -> Self {
        Self {
            sim,
            u,
            frictionless: sim.model.law.is_frictionless(),
            samp_stick: Sampler::default(),
            samp_slip: Sampler::default(),
            samp_held: Sampler::default(),
        }
    }
}

impl Stepper for Exact<'_> {
    fn model(&self) -> &Model {
        &self.sim.model
    }

    fn period(&self) -> Option<f64> {
        Some(self.sim.period)
    }

    fn begin(&mut self, _mode: Mode, _x: &[f64; 4], _n: u64, _s: f64, _first: bool) {}

    /// One whole phase: to its first event or to `s_end`. The two phase
    /// arms hand monomorphised closures (jet evaluator, marching cursor,
    /// sampler) to [`events::first_event`]; allocation-free.
    #[inline]
    fn advance<O: Observer + ?Sized>(
        &mut self,
        mode: Mode,
        x: &[f64; 4],
        n: u64,
        s: f64,
        s_end: f64,
        watch: &mut Watch<'_, O>,
    ) -> Advance {
        let sim = self.sim;
        let (t, u) = (sim.period, self.u);
        let left = s_end - s;
        let origin = n as f64 * t + s;
        let scale = sim.resolution * t;
        let (hit, x_end) = match mode {
            Mode::Stick { z2 } if sim.held.is_some() => {
                let (held, kappa) = &**sim.held.as_ref().expect("held");
                let fns = sim.held_events(*kappa, z2);
                let nf = if sim.rho_s[0].is_finite() { 2 } else { 0 };
                let c = held_c(*kappa, z2);
                let span = (left, scale, origin);
                march4(
                    held,
                    x,
                    s,
                    u,
                    c,
                    &fns[..nf],
                    span,
                    &mut self.samp_held,
                    watch,
                )
            }
            Mode::Stick { z2 } => {
                let p = sim.stick.start([x[0], x[1]], s, u, sim.stick_c(z2));
                // The marching cursor is shared: arbitrary offsets are
                // evaluated from it (within one step, no libm). (The
                // two-dimensional stick state is as cheap as projecting
                // its two switching functions on the closed form.)
                let cur = Cell::new(sim.stick.cursor(&p));
                let eval = |d: f64| stick_jet(sim.stick.jet_near(&p, &cur.get(), d), z2);
                let next = |b: f64| {
                    let mut c = cur.get();
                    if b == c.delta + sim.stick.step {
                        let j = stick_jet(sim.stick.advance(&p, &mut c), z2);
                        cur.set(c);
                        j
                    } else {
                        eval(b)
                    }
                };
                let samp = &mut self.samp_stick;
                samp.begin_phase();
                let mut sample = |d: f64| {
                    let (y, dy) = sim.stick.sample_near(&p, &cur.get(), samp, d);
                    ([y[0], y[1], z2, 0.0], [dy[0], dy[1], 0.0, 0.0])
                };
                let fns = sim.stick_events(z2);
                let nf = if sim.rho_s[0].is_finite() { 2 } else { 0 };
                let (hit, jb) = events::first_event(
                    &eval,
                    next,
                    &fns[..nf],
                    left,
                    sim.stick.step,
                    scale,
                    |a, ja, b, jb| {
                        watch.extremes(&eval, a, ja, b, jb);
                        watch.samples(origin, a, b, &mut sample);
                    },
                );
                (hit.map(|h| (h.delta, h.which, h.jet.x)), jb.x)
            }
            // With exact extremes every step's jet is wanted: the finder
            // marches jets.
            Mode::Slip { dir } if watch.wants_extremes() || sim.held.is_some() => {
                let (fns, nf) = sim.slip_events(dir, self.frictionless);
                let c = sim.slip_c(dir);
                let span = (left, scale, origin);
                march4(
                    &sim.slip,
                    x,
                    s,
                    u,
                    c,
                    &fns[..nf],
                    span,
                    &mut self.samp_slip,
                    watch,
                )
            }
            Mode::Slip { dir } => {
                let p = sim.slip.start(*x, s, u, sim.slip_c(dir));
                // The event finder sees phase points, on which the
                // switching functions are projections (a few complex
                // multiply-adds); jets are assembled only where needed.
                // The cursor is borrowed in place (no copies of it).
                // (Without extremes: the steady-state marches.)
                let cur = RefCell::new(sim.slip.cursor(&p));
                let point = |d: f64| sim.slip.point_near(&p, &cur.borrow(), d);
                let next = |b: f64| {
                    let mut c = cur.borrow_mut();
                    if b == c.delta + sim.slip.step {
                        sim.slip.advance_point(&p, &mut c)
                    } else {
                        sim.slip.point_near(&p, &c, b)
                    }
                };
                let samp = &mut self.samp_slip;
                samp.begin_phase();
                let mut sample = |d: f64| sim.slip.sample_near(&p, &cur.borrow(), samp, d);
                let (fns, nf) = sim.slip_events(dir, self.frictionless);
                // End of the slip: gradient dir·e3; interruption: −dir·e3.
                let (pe, ps) = if dir > 0.0 { (0, 1) } else { (1, 0) };
                // (The interruption's function only where it is used.)
                let sw0 = sim.slip.switch_start(&sim.slip_proj[pe], &p, fns[0].g0);
                let sw = [
                    sw0,
                    if nf > 1 {
                        sim.slip.switch_start(&sim.slip_proj[ps], &p, fns[1].g0)
                    } else {
                        sw0
                    },
                ];
                let (hit, qb) = events::first_event(
                    &point,
                    next,
                    &sw[..nf],
                    left,
                    sim.slip.step,
                    scale,
                    |a, _, b, _| watch.samples(origin, a, b, &mut sample),
                );
                match hit {
                    Some(h) => (Some((h.delta, h.which, sim.slip.state_of(&p, &h.jet))), *x),
                    None => (None, sim.slip.state_of(&p, &qb)),
                }
            }
        };
        match hit {
            Some((delta, which, x)) => Advance::Hit { delta, which, x },
            None => Advance::Moved {
                delta: left,
                x: x_end,
                end: true,
            },
        }
    }

    #[inline]
    fn drive(&self, _n: u64, s: f64) -> f64 {
        self.sim.stick.drive(self.u, s).0
    }

    fn rate(&self, mode: Mode, x: &[f64; 4], _n: u64, s: f64) -> [f64; 4] {
        self.sim.rate(x, mode, s, self.u)
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

/// The held phase's constant input: κζs on M2 (the spring's anchor).
#[inline]
fn held_c(kappa: f64, zs: f64) -> [f64; 4] {
    [0.0, 0.0, 0.0, kappa * zs]
}

/// How a phase ended: the hit (time, switching function, state), if any,
/// and the state at the end of the span.
type PhaseEnd = (Option<(f64, usize, [f64; 4])>, [f64; 4]);

/// One four-state phase (a slip, or the held phase of a pad with a contact
/// spring) from `x` at offset `s` with input `c`, marched on jets to its
/// first event among `fns` or to the span's end (`span`: time left, root
/// resolution, the phase's absolute origin), extremes and samples
/// delivered through `watch`. Returns the hit (time, function, state) and
/// the state at the end. (Always inlined: the slip's arm of [`Exact`]'s
/// advance was one inline block before it was shared.)
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn march4<O: Observer + ?Sized>(
    phase: &LinearPhase<4>,
    x: &[f64; 4],
    s: f64,
    u: C64,
    c: [f64; 4],
    fns: &[EventFn<4>],
    (left, scale, origin): (f64, f64, f64),
    samp: &mut Sampler<4>,
    watch: &mut Watch<'_, O>,
) -> PhaseEnd {
    let p = phase.start(*x, s, u, c);
    let cur = Cell::new(phase.cursor(&p));
    let eval = |d: f64| slip_jet(phase.jet_near(&p, &cur.get(), d));
    let next = |b: f64| {
        let mut c = cur.get();
        if b == c.delta + phase.step {
            let j = slip_jet(phase.advance(&p, &mut c));
            cur.set(c);
            j
        } else {
            eval(b)
        }
    };
    samp.begin_phase();
    let mut sample = |d: f64| phase.sample_near(&p, &cur.get(), samp, d);
    let (hit, jb) =
        events::first_event(&eval, next, fns, left, phase.step, scale, |a, ja, b, jb| {
            watch.extremes(&eval, a, ja, b, jb);
            watch.samples(origin, a, b, &mut sample);
        });
    (hit.map(|h| (h.delta, h.which, h.jet.x)), jb.x)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Law;

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
                    minus: None,
                },
                stop_below: None,
                contact_stiffness: None,
            },
            Model {
                absorber: Absorber {
                    m: 1.0,
                    k: 3.0,
                    damping: 4.0,
                },
                law: Law::coulomb(0.5),
                stop_below: None,
                contact_stiffness: None,
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
}
