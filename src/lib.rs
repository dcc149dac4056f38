//! # stickslip
//!
//! Turns rig logs of a passive vibration absorber with dry friction into
//! validated friction models (Hartung, Schmieg & Vielsack, *Passive vibration
//! absorber with dry friction*; where the model and the paper part:
//! `docs/paper-and-model.md`).
//!
//! The crate is a pipeline. Data flow one way, through small typed structs:
//!
//! ```text
//! characteristic log ─ingest::read─▶ Run ─identify::fit_log─▶ LogFit ─┬─▶ batch::batch ─▶ Batch
//!                                                                     │
//! sweep log ─────────── ingest::read─▶ Run ──────┬──── validate::validate ─▶ Validation
//!                                                │    (measured FRC against the FRC the
//!                                                │     sim engine predicts from LogFit)
//!                                                ▼
//!                                 report (HTML page and figures of all of it)
//! ```
//!
//! The stage doors:
//!
//! * [`ingest`]: [`ingest::read`] turns a rig log (MCAP, CSV + channel map,
//!   Parquet) into one clean [`ingest::Run`].
//! * [`identify`]: [`identify::fit_log`] gives the friction law of a
//!   characteristic log with 95 % intervals and an adequacy verdict
//!   ([`identify::LogFit`]); [`identify::characteristic`] the contact force
//!   R(ẋ2) (eq. 7) and the stick/slip segmentation.
//! * [`sim`]: the exact event-driven engine ([`sim::Sim`]), the numerical
//!   engine, the paper's RK4, steady states and frequency-response curves
//!   ([`sim::sweep`]).
//! * [`validate`]: [`validate::validate`] scores a measured sweep against
//!   the prediction of a fitted law ([`validate::Validation`]).
//! * [`batch`]: [`batch::batch`] compares the logs of one pad at several
//!   normal forces: μs, μd, conflicts, the worst case and the recommended
//!   normal force ([`batch::Batch`]).
//! * [`report`]: HTML pages and figures (plotters); [`report::sections`]
//!   writes a fit's or a validation's figure and returns its view.
//! * [`pipeline`]: the whole experiment plan: [`pipeline::Plan::read`] (the
//!   plan stage) and [`pipeline::run`] (every log read and fitted once,
//!   validations and the batch side by side) giving a
//!   [`pipeline::PipelineReport`] with its JSON and report.
//! * [`model`]: the dimensionless absorber (m, k, D), the rig's constants,
//!   drives, and the friction laws: one [`model::LawFamily`] per family,
//!   registered by name ([`model::LawKind`]), with [`model::SiLaw`],
//!   [`model::Law`] and [`model::Scales`].
//! * [`synth`]: a virtual rig writing logs with known truth from the simulator.
//! * `cli` (feature `cli`, on by default): the command-line layer (parse,
//!   call the doors, print); `cargo build --lib --no-default-features`
//!   builds the library without clap and indicatif.
//! * [`io`], [`error`], [`guard`], [`stats`]: atomic writes (and the Parquet
//!   table writer); the crate's error type; panic containment around
//!   third-party decoders; shared statistics (Student t, normal quantiles).
//! * [`warning`]: the stages' warnings ([`warning::Warning`]: one variant
//!   per condition with its numbers, its message and its stable code).
//!
//! The core is dimensionless (paper §2): τ = t·√(K2/M2), ζi = xi/A,
//! ρ = R/(A·K2); SI units appear only at the edges (ingest, reports).

pub mod batch;
#[cfg(feature = "cli")]
pub mod cli;
pub mod error;
pub mod guard;
pub mod identify;
pub mod ingest;
pub mod io;
pub mod limits;
pub mod model;
pub mod pipeline;
pub mod report;
pub mod sim;
pub mod stats;
pub mod synth;
pub mod validate;
pub mod warning;

pub use error::{Error, Result};
