//! The simulation stage: the exact event-driven engine of the absorber and
//! what is built on it.
//!
//! * [`phase`]: closed-form propagation of one stick or slip phase;
//! * [`events`]: bracketing and refinement of switching events;
//! * [`engine`]: the event loop and its switching logic (derivation there);
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
