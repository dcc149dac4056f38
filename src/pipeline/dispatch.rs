//! One door for every job: a [`Job`] is any command's validated work,
//! [`execute`] runs it and gives its [`Outcome`]. The command-line layer
//! builds the job from its arguments, calls [`execute`] once and prints
//! the outcome.

use super::{
    batch, bench, characteristic, fit, job, merge, read, simulate, sweep, synth, validate, Progress,
};

/// The work of one command.
#[derive(Debug, Clone)]
pub enum Job {
    /// `simulate`: one forcing frequency.
    Simulate(simulate::SimulateJob),
    /// `ingest`: one rig log read.
    Ingest(read::IngestJob),
    /// `sweep`: frequency-response curves.
    Sweep(sweep::SweepJob),
    /// `merge`: the parts of a sharded sweep or fit.
    Merge(merge::MergeJob),
    /// `bench`: the work-precision benchmark.
    Bench(bench::BenchJob),
    /// `characteristic`: the contact force of a characteristic log.
    Characteristic(characteristic::CharacteristicJob),
    /// `fit`: the friction law of characteristic logs.
    Fit(fit::FitJob),
    /// `synth`: a virtual rig's log.
    Synth(Box<synth::SynthJob>),
    /// `run`: an experiment plan.
    Run(Box<job::RunJob>),
    /// `validate`: a law against a sweep.
    Validate(Box<validate::ValidateJob>),
    /// `batch`: one pad at several normal forces.
    Batch(Box<batch::BatchJob>),
}

/// What a [`Job`] produced (the variant of its job).
#[derive(Debug)]
pub enum Outcome {
    /// Of [`Job::Simulate`].
    Simulate(Box<simulate::SimulateOutcome>),
    /// Of [`Job::Ingest`].
    Ingest(Box<read::IngestOutcome>),
    /// Of [`Job::Sweep`].
    Sweep(Box<sweep::SweepOutcome>),
    /// Of [`Job::Merge`].
    Merge(Box<merge::MergeOutcome>),
    /// Of [`Job::Bench`].
    Bench(bench::BenchOutcome),
    /// Of [`Job::Characteristic`].
    Characteristic(Box<characteristic::CharacteristicOutcome>),
    /// Of [`Job::Fit`].
    Fit(fit::FitOutcome),
    /// Of [`Job::Synth`].
    Synth(Box<synth::SynthOutcome>),
    /// Of [`Job::Run`].
    Run(Box<job::RunOutcome>),
    /// Of [`Job::Validate`].
    Validate(Box<validate::ValidateOutcome>),
    /// Of [`Job::Batch`].
    Batch(Box<batch::BatchOutcome>),
}

/// Runs `job`, reporting to `progress`; every output goes through the
/// write transaction ([`crate::io::txn`]).
pub fn execute(job: &Job, progress: &dyn Progress) -> crate::Result<Outcome> {
    Ok(match job {
        Job::Simulate(j) => Outcome::Simulate(Box::new(simulate::run_simulate(j, progress)?)),
        Job::Ingest(j) => Outcome::Ingest(Box::new(read::run_ingest(j, progress)?)),
        Job::Sweep(j) => Outcome::Sweep(Box::new(sweep::run_sweep(j, progress)?)),
        Job::Merge(j) => Outcome::Merge(Box::new(merge::run_merge(j)?)),
        Job::Bench(j) => Outcome::Bench(bench::run_bench(j, progress)?),
        Job::Characteristic(j) => {
            Outcome::Characteristic(Box::new(characteristic::run_characteristic(j, progress)?))
        }
        Job::Fit(j) => Outcome::Fit(fit::run_fit(j, progress)?),
        Job::Synth(j) => Outcome::Synth(Box::new(synth::run_synth(j, progress)?)),
        Job::Run(j) => Outcome::Run(Box::new(job::run_job(j, progress)?)),
        Job::Validate(j) => Outcome::Validate(Box::new(validate::run_validate(j, progress)?)),
        Job::Batch(j) => Outcome::Batch(Box::new(batch::run_batch(j, progress)?)),
    })
}
