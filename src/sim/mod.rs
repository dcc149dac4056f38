//! The simulation stage: the exact event-driven engine of the absorber and
//! what is built on it.
//!
//! * [`phase`]: closed-form propagation of one stick or slip phase;
//! * [`events`]: bracketing and refinement of switching events;
//! * [`event_loop`]: the one event loop of every integrator and the
//!   switching logic (derivation there);
//! * [`engine`]: the exact engine (closed-form phases) as its stepper;
//! * [`linear`]: closed forms of the two linear limits (ρs = 0, ρs = ∞);
//! * [`monodromy`]: the Jacobian of the period map for Newton shooting;
//! * [`steady`]: amplitudes (paper eq. 6), steady-state and period-n
//!   detection on the Poincaré section;
//! * [`rk4`]: the paper's own method, classical RK4 with switching-time
//!   determination, for cross-checks and benchmarks.

// Index loops mirror the matrix formulas (A·x, V·y) and read clearer here.
#![allow(clippy::needless_range_loop)]

pub mod dopri;
pub mod engine;
pub mod event_loop;
pub mod events;
pub mod linalg;
pub mod linear;
pub mod monodromy;
pub mod numeric;
pub mod phase;
pub mod rk4;
pub mod schedule;
pub mod steady;
pub mod sweep;
pub mod workprec;

pub use engine::{
    Event, EventKind, Flow, Init, Mode, Observer, PeriodGrid, PeriodStats, RunEnd, Sim, Status,
};
pub use steady::{simulate, SimOptions, Summary};

/// A simulation that cannot be carried out as asked.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SimError {
    /// Invalid model parameters.
    #[error(transparent)]
    Param(#[from] crate::model::ParamError),
    /// The request is outside what the engine can compute.
    #[error("{0}")]
    Unsupported(String),
    /// A drive schedule that gives no drives.
    #[error(transparent)]
    Schedule(#[from] crate::model::ScheduleError),
}

/// The integrator for one model and drive, chosen in one place
/// ([`Engine::new`]): the exact engine for a harmonic drive and a law
/// that is affine in each phase, the numerical engine for every other law
/// or drive. Both run through the one event loop ([`event_loop`]).
#[derive(Debug, Clone)]
pub enum Engine {
    /// The exact engine and its harmonic drive's phase and amplitude.
    Exact {
        /// The engine (set up for the drive's η).
        sim: Box<Sim>,
        /// The drive's phase φ in `amplitude·cos(ητ + φ)`.
        phase: f64,
        /// The drive's amplitude.
        amplitude: f64,
    },
    /// The numerical engine (boxed like the exact one: the variants stay
    /// small).
    Numeric(Box<numeric::NumericSim>),
}

impl Engine {
    /// The engine for `model` driven by `drive` (`opts`: the numerical
    /// engine's tolerances, where it is the one).
    pub fn new(
        model: &crate::model::Model,
        drive: crate::model::Drive,
        opts: numeric::NumericOptions,
    ) -> Result<Self, SimError> {
        match drive {
            crate::model::Drive::Harmonic {
                eta,
                phase,
                amplitude,
            } if model.law.affine().is_some() => Ok(Engine::Exact {
                sim: Box::new(Sim::new(model, eta)?),
                phase,
                amplitude,
            }),
            other => Ok(Engine::Numeric(Box::new(numeric::NumericSim::new(
                model, other, opts,
            )?))),
        }
    }

    /// Integrates `duration` from `init` (τ from the run's start).
    pub fn run<O: Observer>(&self, init: Init, duration: f64, obs: &mut O) -> RunEnd {
        match self {
            Engine::Exact {
                sim,
                phase,
                amplitude,
            } => sim.run_span(init, *phase, *amplitude, duration, obs),
            Engine::Numeric(sim) => sim.run(init, duration, obs),
        }
    }

    /// Integrates `periods` whole forcing periods from `init` (period
    /// callbacks at each; a drive without a period runs `periods` spans of
    /// 2π/(its fastest frequency), without callbacks).
    pub fn run_periods<O: Observer>(&self, init: Init, periods: u64, obs: &mut O) -> RunEnd {
        match self {
            Engine::Exact {
                sim,
                phase,
                amplitude,
            } => sim.run_periods(init, *phase, *amplitude, periods, obs),
            Engine::Numeric(sim) => {
                let t = sim.forcing_period().unwrap_or(sim.event_window());
                sim.run(init, periods as f64 * t, obs)
            }
        }
    }

    /// The model integrated.
    pub fn model(&self) -> &crate::model::Model {
        match self {
            Engine::Exact { sim, .. } => sim.model(),
            Engine::Numeric(sim) => sim.model(),
        }
    }

    /// The exact engine, where it is the one.
    pub fn exact(&self) -> Option<&Sim> {
        match self {
            Engine::Exact { sim, .. } => Some(sim),
            Engine::Numeric(_) => None,
        }
    }

    /// [`Engine::run`] with a harmonic drive's phase set to `phase` (the
    /// set-up kept); `None` for other drives.
    pub fn run_at_phase<O: Observer>(
        &self,
        init: Init,
        phase: f64,
        duration: f64,
        obs: &mut O,
    ) -> Option<RunEnd> {
        match self {
            Engine::Exact { sim, amplitude, .. } => {
                Some(sim.run_span(init, phase, *amplitude, duration, obs))
            }
            Engine::Numeric(sim) => Some(sim.with_phase(phase)?.run(init, duration, obs)),
        }
    }
}
