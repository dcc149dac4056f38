//! The `run` job: an experiment plan ([`super::run`]) with its report and
//! its JSON result ([`RunJson`]), written through the write transaction
//! ([`crate::io::txn`]) — nothing where a step of the plan failed.

use super::{Options, PipelineReport, Plan, PlanJson, Progress, StageSeconds};
use serde::Serialize;
use std::path::PathBuf;
use std::time::Instant;

/// One run of a plan.
#[derive(Debug, Clone)]
pub struct RunJob {
    /// The plan (as [`Plan::read`] gives it).
    pub plan: Plan,
    /// Where the plan was read from (named in the result).
    pub plan_path: PathBuf,
    /// The run's options.
    pub options: Options,
    /// Write the HTML report into this directory.
    pub report: Option<PathBuf>,
    /// Write the JSON result to this file.
    pub out: Option<PathBuf>,
    /// The command line shown on the report.
    pub command: String,
}

/// The `run --json` object: the plan's result
/// ([`PipelineReport::plan_json`]) with the report's path and the wall
/// seconds.
#[derive(Debug, Clone, Serialize)]
pub struct RunJson {
    /// The plan's result (its keys, flattened).
    #[serde(flatten)]
    pub result: PlanJson,
    /// The report's index page, where one was written.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub report: Option<String>,
    /// Wall seconds per stage.
    pub stage_seconds: StageSeconds,
    /// Wall seconds of the job.
    pub seconds: f64,
}

/// What [`run_job`] produced. Where `failure` is set, nothing was
/// written.
#[derive(Debug)]
pub struct RunOutcome {
    /// Everything the plan produced (its `errors`, one line per failure).
    pub report: PipelineReport,
    /// The JSON result (as written to `out`).
    pub json: RunJson,
    /// Why the job failed (how many steps), if it did.
    pub failure: Option<crate::Error>,
}

/// Runs the plan ([`super::run`]; the progress display is done once it
/// returns), then, where no step failed, writes the report and `out`.
pub fn run_job(job: &RunJob, progress: &dyn Progress) -> crate::Result<RunOutcome> {
    let t0 = Instant::now();
    let report = super::run(&job.plan, &job.options, progress);
    progress.done();
    let report = report?;
    let mut json = RunJson {
        result: report.plan_json(&job.plan, &job.plan_path),
        report: None,
        stage_seconds: report.seconds.clone(),
        seconds: 0.0,
    };
    if !report.errors.is_empty() {
        // A failed job writes no file.
        json.seconds = t0.elapsed().as_secs_f64();
        let failure = crate::Error::Failed {
            what: format!(
                "{} step(s) of the plan failed (listed above)",
                report.errors.len()
            ),
        };
        return Ok(RunOutcome {
            report,
            json,
            failure: Some(failure),
        });
    }
    if let Some(dir) = &job.report {
        let clock = Instant::now();
        let index = report.write_report(&job.plan, &job.plan_path, dir, &job.command)?;
        json.stage_seconds.report = clock.elapsed().as_secs_f64();
        progress.say(&format!("report: {}", index.display()));
        json.report = Some(index.display().to_string());
    }
    json.seconds = t0.elapsed().as_secs_f64();
    if let Some(path) = &job.out {
        crate::io::json::write_pretty(path, &crate::io::json::to_value(&json))?;
    }
    Ok(RunOutcome {
        report,
        json,
        failure: None,
    })
}
