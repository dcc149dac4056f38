//! # stickslip
//!
//! Turns rig logs of a passive vibration absorber with dry friction into
//! validated friction models (Hartung, Schmieg & Vielsack, *Passive vibration
//! absorber with dry friction*).
//!
//! The crate is a pipeline; each stage is one module with one door
//! (`run(input, config) -> Result<output>` on small typed structs):
//!
//! ```text
//! log ──ingest──▶ Run ──identify──▶ Characteristic ──fit──▶ FittedLaw
//! sweep log ──ingest──▶ Run ──measure──▶ MeasuredFrc         │
//!                                           │         sim (exact engine)
//!                                           ▼                │
//!                                  validate: Score ◀── PredictedFrc ── report
//! ```
//!
//! * [`ingest`]: rig logs (MCAP, CSV + channel map, Parquet) into one clean `Run`.
//! * [`identify`]: contact force (eq. 7), stick/slip, friction-law fit with intervals.
//! * [`model`]: the dimensionless absorber (m, k, D), friction laws, drives.
//! * [`sim`]: the exact event-driven engine, the paper's RK4 and closed forms.
//! * [`synth`]: a virtual rig writing logs with known truth from the simulator.
//! * [`cli`]: the thin command-line layer over the library.
//!
//! The core is dimensionless (paper §2): τ = t·√(K2/M2), ζi = xi/A,
//! ρ = R/(A·K2); SI units appear only at the edges (ingest, reports).

pub mod cli;
pub mod error;
pub mod identify;
pub mod ingest;
pub mod io;
pub mod model;
pub mod report;
pub mod sim;
pub mod synth;
pub mod validate;

pub use error::{Error, Result};
