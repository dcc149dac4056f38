//! The `simulate` job: one forcing frequency with the exact engine (or
//! the paper's RK4, or Dormand–Prince for laws without a closed form);
//! the event and trajectory files are streamed to disk in constant memory
//! and written atomically, through the write transaction
//! ([`crate::io::txn`]). Its JSON object is [`SimulateJson`].

use super::Progress;
use crate::io::AtomicFile;
use crate::io::Output;
use crate::model::Model;
use crate::sim::rk4::Rk4;
use crate::sim::{self, Event, Flow, Mode, Observer, PeriodGrid, PeriodStats, Sim, SimOptions};
use serde::Serialize;
use std::io::Write;
use std::path::PathBuf;

/// Integration method.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Method {
    /// Exact event-driven closed-form engine.
    Exact,
    /// The paper's classical RK4 with switching-time determination.
    Rk4,
    /// Dormand–Prince 5(4) with events on its dense output (any law).
    Dopri,
}

impl Method {
    /// The method's name (the JSON's `method`).
    pub fn as_str(self) -> &'static str {
        match self {
            Method::Exact => "exact",
            Method::Rk4 => "rk4",
            Method::Dopri => "dopri",
        }
    }
}

/// One simulation at one forcing frequency.
#[derive(Debug, Clone, PartialEq)]
pub struct SimulateJob {
    /// The validated model.
    pub model: Model,
    /// Forcing frequency ratio η = Ω·sqrt(M2/K2).
    pub eta: f64,
    /// Integrate exactly this many forcing periods (None: until the
    /// response is periodic, or declared not periodic).
    pub periods: Option<u64>,
    /// Longest run until periodic, in forcing periods.
    pub max_periods: u64,
    /// Write every switching event to this CSV.
    pub events: Option<PathBuf>,
    /// Write the trajectory (uniform samples) to this CSV.
    pub trajectory: Option<PathBuf>,
    /// Trajectory samples per forcing period.
    pub samples_per_period: u32,
    /// Largest event or trajectory file to write (MB; the estimate is
    /// checked before the run).
    pub max_output_mb: u64,
    /// Integration method (`Exact` on a law without a closed form runs
    /// `Dopri`).
    pub method: Method,
    /// RK4 step size H (dimensionless time).
    pub step: f64,
    /// Relative tolerance of Dormand–Prince.
    pub tol: f64,
}

/// The `simulate --json` object: the run's summary, how it was integrated
/// and which law.
#[derive(Debug, Clone, Serialize)]
pub struct SimulateJson {
    /// The run's summary (its keys, flattened).
    #[serde(flatten)]
    pub summary: sim::steady::Summary,
    /// The method that ran ([`Method::as_str`]).
    pub method: &'static str,
    /// The law's name.
    pub law: &'static str,
    /// ζs at the end, with a contact spring.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub slider_position: Option<f64>,
    /// κ, with a contact spring.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub contact_stiffness: Option<f64>,
}

/// What [`run_simulate`] produced.
#[derive(Debug, Clone)]
pub struct SimulateOutcome {
    /// The model that was run.
    pub model: Model,
    /// The JSON result (with the run's summary).
    pub json: SimulateJson,
}

/// Streams events and samples into CSV files.
struct Files {
    events: Option<AtomicFile>,
    traj: Option<(AtomicFile, PeriodGrid)>,
    err: Option<crate::Error>,
    /// The slider behind a contact spring, followed through the events
    /// (None: a rigid stick, no `zeta_s` column).
    slider: Option<Slider>,
}

/// The friction slider of a pad with a contact spring, followed through
/// the events: where it sticks, or the direction it slides in (its
/// position from the model's rules, [`Model::slider_at_rest`] and
/// [`Model::slider_sliding`]).
struct Slider {
    model: Model,
    /// `Some(ζs)` while it sticks; `None` while it slides.
    stuck_at: Option<f64>,
    /// Direction of the last slide.
    dir: f64,
}

impl Slider {
    /// Follows an event.
    fn event(&mut self, ev: &Event) {
        match ev.kind.as_str() {
            "slip+" | "reverse+" => (self.stuck_at, self.dir) = (None, 1.0),
            "slip-" | "reverse-" => (self.stuck_at, self.dir) = (None, -1.0),
            "stick" => self.stuck_at = self.model.slider_at_rest(self.dir, ev.x[2]),
            _ => {}
        }
    }

    /// ζs at state x: where it sticks, or where it slides with M2.
    fn position(&self, x: &[f64; 4]) -> f64 {
        self.stuck_at
            .or_else(|| self.model.slider_sliding(self.dir, x))
            .unwrap_or(f64::NAN)
    }
}

impl Files {
    fn write(&mut self, which: bool, line: std::fmt::Arguments<'_>) {
        if self.err.is_some() {
            return;
        }
        let f = if which {
            self.events.as_mut()
        } else {
            self.traj.as_mut().map(|t| &mut t.0)
        };
        if let Some(f) = f {
            if let Err(e) = f.writer().write_fmt(line) {
                self.err = Some(f.io_err(e));
            }
        }
    }
}

impl Observer for Files {
    fn event(&mut self, ev: &Event) {
        let x = ev.x;
        let zs = self.slider.as_mut().map(|s| {
            s.event(ev);
            format!(",{}", s.position(&x))
        });
        self.write(
            true,
            format_args!(
                "{},{},{},{},{},{}{}\n",
                ev.tau,
                ev.kind.as_str(),
                x[0],
                x[1],
                x[2],
                x[3],
                zs.unwrap_or_default()
            ),
        );
    }
    fn next_sample(&mut self) -> Option<f64> {
        self.traj.as_mut().map(|t| t.1.advance())
    }
    fn sample(&mut self, tau: f64, x: &[f64; 4], _dx: &[f64; 4]) {
        let zs = self.slider.as_ref().map(|s| format!(",{}", s.position(x)));
        self.write(
            false,
            format_args!(
                "{},{},{},{},{}{}\n",
                tau,
                x[0],
                x[1],
                x[2],
                x[3],
                zs.unwrap_or_default()
            ),
        );
    }
    fn period(&mut self, _n: u64, _x: &[f64; 4], _m: Mode, _s: &PeriodStats) -> Flow {
        if self.err.is_some() {
            Flow::Stop
        } else {
            Flow::Continue
        }
    }
}

/// Most forcing periods of one `simulate --periods` run.
pub const MAX_PERIODS: u64 = 100_000_000;
/// Most RK4 steps of one run (about a minute of work).
const MAX_RK4_STEPS: f64 = 2e9;

/// Refuses runs whose output files or RK4 work would exceed the limits,
/// with the numbers and the flag to change.
fn check_budget(job: &SimulateJob) -> crate::Result<()> {
    let too_big = |flag: &str, what: String| -> crate::Error {
        crate::sim::SimError::Unsupported(format!("{flag}: {what}")).into()
    };
    let periods = job.periods.unwrap_or(job.max_periods) as f64;
    // CSV rows: about 5 numbers of 20 characters.
    const ROW_BYTES: f64 = 110.0;
    let limit = job.max_output_mb as f64 * 1e6;
    if job.trajectory.is_some() {
        let bytes = periods * f64::from(job.samples_per_period) * ROW_BYTES;
        if bytes > limit {
            return Err(too_big(
                "--trajectory",
                format!(
                    "{periods:.3e} periods x {} samples would write about {:.1} GB, over the {} MB limit: lower --periods or --samples-per-period, or raise --max-output-mb",
                    job.samples_per_period,
                    bytes / 1e9,
                    job.max_output_mb
                ),
            ));
        }
    }
    if job.events.is_some() {
        // Up to four switching events per period in stick-slip.
        let bytes = periods * 4.0 * ROW_BYTES;
        if bytes > limit {
            return Err(too_big(
                "--events",
                format!(
                    "{periods:.3e} periods (up to 4 events each) could write about {:.1} GB, over the {} MB limit: lower --periods (or --max-periods), or raise --max-output-mb",
                    bytes / 1e9,
                    job.max_output_mb
                ),
            ));
        }
    }
    if job.method == Method::Rk4 && job.step.is_finite() && job.step > 0.0 {
        let steps = periods * 2.0 * std::f64::consts::PI / job.eta / job.step;
        if steps > MAX_RK4_STEPS {
            return Err(too_big(
                "--step",
                format!(
                    "{steps:.3e} RK4 steps ({periods:.3e} periods at H = {}); the limit is {MAX_RK4_STEPS:.0e}: raise --step or lower --periods",
                    job.step
                ),
            ));
        }
    }
    Ok(())
}

/// Checks the outputs and the budget, then opens the event and trajectory
/// files (atomic: nothing appears unless the run completes).
fn open_files(job: &SimulateJob, model: &Model) -> crate::Result<Files> {
    let mut outputs = Vec::new();
    if let Some(p) = &job.events {
        outputs.push(Output::file("--events", p, &["csv"]));
    }
    if let Some(p) = &job.trajectory {
        outputs.push(Output::file("--trajectory", p, &["csv"]));
    }
    crate::io::check_outputs([], &outputs)?;
    check_budget(job)?;
    let mut files = Files {
        events: None,
        traj: None,
        err: None,
        slider: model.contact_stiffness.map(|_| Slider {
            model: *model,
            // From rest: ζs = 0, P = 0, the slider stuck.
            stuck_at: Some(0.0),
            dir: 1.0,
        }),
    };
    let zs = if files.slider.is_some() {
        ",zeta_s"
    } else {
        ""
    };
    if let Some(p) = &job.events {
        let mut f = AtomicFile::create(p)?;
        writeln!(f.writer(), "tau,kind,zeta1,dzeta1,zeta2,dzeta2{zs}").map_err(|e| f.io_err(e))?;
        files.events = Some(f);
    }
    if let Some(p) = &job.trajectory {
        let mut f = AtomicFile::create(p)?;
        writeln!(f.writer(), "tau,zeta1,dzeta1,zeta2,dzeta2{zs}").map_err(|e| f.io_err(e))?;
        let grid = PeriodGrid {
            t: 2.0 * std::f64::consts::PI / job.eta,
            per_period: job.samples_per_period,
            j: 0,
        };
        files.traj = Some((f, grid));
    }
    Ok(files)
}

/// Runs the simulation: checks η, the outputs and the budget, opens the
/// files, integrates and commits the files.
pub fn run_simulate(job: &SimulateJob, _progress: &dyn Progress) -> crate::Result<SimulateOutcome> {
    let model = job.model;
    crate::model::validate_eta(job.eta)?;
    let mut files = open_files(job, &model)?;
    let opts = SimOptions {
        periods: job.periods,
        max_periods: job.max_periods,
        // Files want the integrated trajectory, not a closed-form answer.
        shortcuts: job.events.is_none() && job.trajectory.is_none(),
        ..SimOptions::default()
    };
    let method = match job.method {
        Method::Exact if model.law.affine().is_none() => Method::Dopri,
        m => m,
    };
    let period = 2.0 * std::f64::consts::PI / job.eta;
    let summary = match method {
        Method::Dopri => {
            let drive = crate::model::Drive::Harmonic {
                eta: job.eta,
                phase: 0.0,
                amplitude: 1.0,
            };
            let opts_n = crate::sim::numeric::NumericOptions {
                rtol: job.tol,
                atol: job.tol * 1e-2,
            };
            let ns = crate::sim::numeric::NumericSim::new(&model, drive, opts_n)?;
            sim::steady::simulate_with(
                &opts,
                job.eta,
                |init, n, obs| ns.run(init, n as f64 * period, obs),
                period,
                &mut files,
            )
        }
        Method::Exact => {
            let sim = Sim::new(&model, job.eta)?;
            sim::simulate(&sim, &opts, &mut files)
        }
        Method::Rk4 => {
            let rk = Rk4::new(&model, job.eta, job.step)?;
            sim::steady::simulate_with(
                &opts,
                job.eta,
                |init, n, obs| rk.run(init, n, obs),
                2.0 * std::f64::consts::PI / job.eta,
                &mut files,
            )
        }
    };
    if let Some(e) = files.err.take() {
        return Err(e);
    }
    if let Some(f) = files.events.take() {
        f.commit()?;
    }
    if let Some((f, _)) = files.traj.take() {
        f.commit()?;
    }
    let json = SimulateJson {
        method: method.as_str(),
        law: model.law.name(),
        slider_position: files
            .slider
            .as_ref()
            .map(|sl| sl.position(&summary.final_state)),
        contact_stiffness: model.contact_stiffness,
        summary,
    };
    Ok(SimulateOutcome { model, json })
}
