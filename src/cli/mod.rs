//! The command-line interface (`../shared/interface.md`): clap parsing, one
//! module per subcommand. Each subcommand turns its arguments into a validated
//! plan, calls the library and prints; nothing here computes physics.

use clap::{Parser, Subcommand};
use std::process::ExitCode;

mod args;
mod ingest;
mod simulate;
mod synth;

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
    /// Virtual rig: write a rig log (MCAP, CSV + map, Parquet) from the simulator, with truth.json.
    Synth(synth::SynthArgs),
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
    let result = match cli.command {
        Command::Simulate(a) => simulate::run(a),
        Command::Ingest(a) => ingest::run(a),
        Command::Synth(a) => synth::run(a),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(1)
        }
    }
}

/// Prints one JSON object on stdout (non-finite numbers become `null`).
pub(crate) fn print_json(value: &serde_json::Value) {
    println!("{value}");
}
