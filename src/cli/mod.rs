//! The command-line interface (`docs/interface.md`): clap parsing, one
//! module per subcommand. Each subcommand turns its arguments into a
//! checked [`crate::pipeline::Job`] (its `request`) and prints the job's
//! outcome (its `print`); [`main`] runs every job through the one door,
//! [`crate::pipeline::execute`]. Nothing here computes physics.

use crate::pipeline;
use clap::{Parser, Subcommand};
use std::process::ExitCode;

mod args;
mod batch;
mod bench;
mod characteristic;
mod fit;
mod ingest;
mod merge;
mod run;
mod simulate;
pub mod sweep;
mod synth;
mod validate;

pub use args::ModelArgs;

/// Command line of the `stickslip` binary.
#[derive(Debug, Parser)]
#[command(
    name = "stickslip",
    version,
    about = "Dry-friction vibration absorber: identify, simulate, validate"
)]
pub struct Cli {
    /// The job to run.
    #[command(subcommand)]
    pub command: Command,
}

/// The subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Simulate the absorber at one forcing frequency (exact event-driven engine).
    Simulate(simulate::SimulateArgs),
    /// Read a rig log (MCAP, CSV + channel map, Parquet) into one clean run.
    Ingest(ingest::IngestArgs),
    /// Frequency-response curves and families (paper Figs. 3-5).
    Sweep(sweep::SweepArgs),
    /// Merge the partial tables of a sharded sweep, or the parts of a sharded fit.
    Merge(merge::MergeArgs),
    /// Work-precision benchmark of the integrators.
    Bench(bench::BenchArgs),
    /// Contact force and stick/slip table of a characteristic log (paper eq. 7).
    Characteristic(characteristic::CharacteristicArgs),
    /// Fit the friction law of characteristic logs, with 95 % intervals.
    Fit(fit::FitArgs),
    /// Virtual rig: write a rig log (MCAP, CSV + map, Parquet) from the simulator, with truth.json.
    Synth(Box<synth::SynthArgs>),
    /// The whole pipeline on an experiment plan (ingest, fit, validate, batch) with one HTML report.
    Run(run::RunArgs),
    /// Predict a sweep's frequency response with the law fitted on a characteristic log, and score it.
    Validate(validate::ValidateArgs),
    /// Batch comparison of normal-force settings of one pad: μs, μd and the recommended normal force.
    Batch(batch::BatchArgs),
}

/// Parses the command line, runs the job and returns the exit status:
/// 0 success, 2 bad command line (clap), 1 bad input or failed job.
pub fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(c) => c,
        Err(e) => {
            let _ = e.print();
            return match e.kind() {
                clap::error::ErrorKind::DisplayHelp | clap::error::ErrorKind::DisplayVersion => {
                    ExitCode::SUCCESS
                }
                _ => ExitCode::from(2),
            };
        }
    };
    install_signal_cleanup();
    crate::io::thread_budget();
    // Every output of the command is renamed into place at the end, all
    // or nothing (see `crate::io::txn`).
    crate::io::txn::begin();
    let mut code = ExitCode::SUCCESS;
    let result = request(cli.command).and_then(|req| {
        let outcome = pipeline::execute(&req.job, req.progress.as_ref());
        req.progress.done();
        print(outcome?, &req.view)
    });
    let result = match result {
        Ok(complete) => {
            if !complete {
                // `fit`: the others' fits are written; the exit status is 1.
                code = ExitCode::from(1);
            }
            crate::io::txn::commit()
        }
        Err(e) => {
            crate::io::txn::abort();
            Err(e)
        }
    };
    match result {
        Ok(()) => code,
        Err(e @ crate::Error::Interrupted) => {
            eprintln!("error: {e}");
            ExitCode::from(130)
        }
        Err(e) => {
            // One line, whatever the source's message holds (polars puts
            // hints on lines of their own).
            let msg = e.to_string();
            let one: Vec<&str> = msg
                .lines()
                .map(str::trim)
                .filter(|l| !l.is_empty())
                .collect();
            eprintln!("error: {}", clip_line(&one.join(" ")));
            ExitCode::from(1)
        }
    }
}

/// A subcommand's request to the pipeline: the job its arguments
/// describe (checked), the display of the job's progress and lines, and
/// what its printing needs.
pub(crate) struct Request {
    /// The job.
    pub job: pipeline::Job,
    /// Where the job reports.
    pub progress: Box<dyn pipeline::Progress>,
    /// How the outcome is printed.
    pub view: View,
}

impl Request {
    /// A request whose job says nothing while it runs.
    fn quiet(job: pipeline::Job, json: bool) -> Self {
        Request {
            job,
            progress: Box::new(()),
            view: View::new(json),
        }
    }
}

/// What every subcommand's printing needs.
#[derive(Debug, Clone, Copy)]
pub(crate) struct View {
    /// One JSON object on stdout (`--json`) rather than lines on stderr.
    pub json: bool,
    /// When the command started its work (its `done in` line).
    pub started: std::time::Instant,
}

impl View {
    /// From now.
    pub fn new(json: bool) -> Self {
        View {
            json,
            started: std::time::Instant::now(),
        }
    }
}

/// Lines for a person on stderr, unless `--json`.
pub(crate) struct Say(pub bool);

impl pipeline::Progress for Say {
    fn say(&self, line: &str) {
        if !self.0 {
            eprintln!("{line}");
        }
    }
}

/// The subcommand's arguments as a checked request (the one dispatch of
/// parsed arguments to their module).
fn request(command: Command) -> crate::Result<Request> {
    match command {
        Command::Simulate(a) => simulate::request(a),
        Command::Ingest(a) => ingest::request(a),
        Command::Sweep(a) => sweep::request(a),
        Command::Merge(a) => merge::request(a),
        Command::Bench(a) => bench::request(a),
        Command::Characteristic(a) => characteristic::request(a),
        Command::Fit(a) => fit::request(a),
        Command::Synth(a) => synth::request(*a),
        Command::Validate(a) => validate::request(a),
        Command::Batch(a) => batch::request(a),
        Command::Run(a) => run::request(a),
    }
}

/// Prints the outcome of a job, by its module; `Ok(false)`: the command
/// fails (exit 1) although its outputs are written (`fit`).
fn print(outcome: pipeline::Outcome, view: &View) -> crate::Result<bool> {
    use pipeline::Outcome as O;
    match outcome {
        O::Simulate(o) => simulate::print(&o, view),
        O::Ingest(o) => ingest::print(&o, view),
        O::Sweep(o) => sweep::print(&o, view),
        O::Merge(o) => merge::print(&o, view),
        O::Bench(o) => bench::print(&o, view),
        O::Characteristic(o) => characteristic::print(&o, view),
        O::Fit(o) => return fit::print(&o, view),
        O::Synth(o) => synth::print(&o, view),
        O::Validate(o) => validate::print(&o, view),
        O::Batch(o) => batch::print(*o, view),
        O::Run(o) => run::print(*o, view),
    }
    .map(|()| true)
}

/// The longest `error:` line printed (bytes): a message that echoes a
/// huge input (a 4 GB CSV line) is cut, with the number of bytes left out.
const MAX_ERROR_LINE: usize = 2000;

/// `line`, cut to [`MAX_ERROR_LINE`] bytes at a character boundary.
fn clip_line(line: &str) -> std::borrow::Cow<'_, str> {
    if line.len() <= MAX_ERROR_LINE {
        return line.into();
    }
    let mut cut = MAX_ERROR_LINE;
    while !line.is_char_boundary(cut) {
        cut -= 1;
    }
    format!(
        "{} … ({} more bytes of this message left out)",
        &line[..cut],
        line.len() - cut
    )
    .into()
}

/// On SIGINT or SIGTERM: remove the temporary files being written (an
/// interrupted job leaves no partial output) and the report directory it
/// created, say so, exit 130. Once the final renames have begun, the
/// interrupt is only recorded: the write transaction undoes the renames
/// and the command exits 130 itself (see `crate::io::txn`).
fn install_signal_cleanup() {
    let _ = ctrlc::set_handler(|| {
        if !crate::io::txn::on_interrupt() {
            return;
        }
        crate::io::remove_live_temps();
        crate::io::txn::remove_created_dirs();
        eprintln!("error: interrupted; the outputs being written were removed");
        std::process::exit(130);
    });
}

/// The checks before any work: every input a readable regular file, every
/// output a fitting new name or regular file (see [`crate::io::paths`]).
pub(crate) fn check_paths<'a>(
    inputs: impl IntoIterator<Item = &'a std::path::Path> + Clone,
    outputs: &[crate::io::Output],
) -> crate::Result<()> {
    crate::io::check_inputs(inputs.clone())?;
    crate::io::check_outputs(inputs, outputs)
}

/// The outputs of a command with `--out FILE.json` and `--report DIR`.
pub(crate) fn json_and_report<'a>(
    out: Option<&'a std::path::Path>,
    report: Option<&'a std::path::Path>,
) -> Vec<crate::io::Output<'a>> {
    let mut outputs = Vec::new();
    if let Some(p) = out {
        outputs.push(crate::io::Output::file("--out", p, ext::JSON));
    }
    if let Some(p) = report {
        outputs.push(crate::io::Output::dir("--report", p));
    }
    outputs
}

/// Extensions of the formats the commands write.
pub(crate) mod ext {
    /// JSON results (`--out`).
    pub const JSON: &[&str] = &["json"];
    /// Tables (`sweep`, `merge`).
    pub const TABLE: &[&str] = &["parquet", "csv"];
    /// CSV tables.
    pub const CSV: &[&str] = &["csv"];
    /// Parquet tables.
    pub const PARQUET: &[&str] = &["parquet"];
    /// SVG figures.
    pub const SVG: &[&str] = &["svg"];
    /// Figures that may also be PNG.
    pub const FIGURE: &[&str] = &["svg", "png"];
}

/// Prints one JSON object on stdout (non-finite numbers become `null`).
/// A closed stdout (e.g. `| head`) is not an error of the job; any other
/// write error (a full disk) is, and fails the command before its outputs
/// are renamed into place.
pub(crate) fn print_json(value: &serde_json::Value) -> crate::Result<()> {
    use std::io::Write;
    let mut out = std::io::stdout().lock();
    let r = writeln!(out, "{value}").and_then(|_| out.flush());
    match r {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => Err(crate::Error::Io {
            path: "stdout (--json)".into(),
            source: e,
        }),
        _ => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn long_error_lines_are_cut() {
        let long = "x".repeat(10_000);
        let c = super::clip_line(&long);
        assert!(c.len() < 2100 && c.ends_with("(8000 more bytes of this message left out)"));
        assert_eq!(super::clip_line("short"), "short");
    }
}
