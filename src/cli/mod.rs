//! The command-line interface (`docs/interface.md`): clap parsing, one
//! module per subcommand. Each subcommand turns its arguments into a validated
//! plan, calls the library and prints; nothing here computes physics.

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
    /// Merge the partial tables of a sharded sweep.
    Merge(merge::MergeArgs),
    /// Work-precision benchmark of the integrators.
    Bench(bench::BenchArgs),
    /// Contact force and stick/slip table of a characteristic log (paper eq. 7).
    Characteristic(characteristic::CharacteristicArgs),
    /// Fit the friction law of characteristic logs, with 95 % intervals.
    Fit(fit::FitArgs),
    /// Virtual rig: write a rig log (MCAP, CSV + map, Parquet) from the simulator, with truth.json.
    Synth(synth::SynthArgs),
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
    let result = match cli.command {
        Command::Simulate(a) => simulate::run(a),
        Command::Ingest(a) => ingest::run(a),
        Command::Sweep(a) => sweep::run(a),
        Command::Merge(a) => merge::run(a),
        Command::Bench(a) => bench::run(a),
        Command::Characteristic(a) => characteristic::run(a),
        Command::Fit(a) => match fit::run(a) {
            Ok(true) => Ok(()),
            Ok(false) => return ExitCode::from(1),
            Err(e) => Err(e),
        },
        Command::Synth(a) => synth::run(a),
        Command::Validate(a) => validate::run(a),
        Command::Batch(a) => match batch::run(a) {
            Ok(true) => Ok(()),
            Ok(false) => return ExitCode::from(1),
            Err(e) => Err(e),
        },
        Command::Run(a) => match run::run(a) {
            Ok(true) => Ok(()),
            Ok(false) => return ExitCode::from(1),
            Err(e) => Err(e),
        },
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(1)
        }
    }
}

/// Writes a JSON result to `path` (pretty, atomically: `--out`).
pub(crate) fn write_json(path: &std::path::Path, value: &serde_json::Value) -> crate::Result<()> {
    let text = serde_json::to_string_pretty(value).map_err(|e| crate::Error::Input {
        path: path.to_path_buf(),
        msg: e.to_string(),
    })?;
    crate::io::write_atomic(path, text.as_bytes())
}

/// Prints one JSON object on stdout (non-finite numbers become `null`).
pub(crate) fn print_json(value: &serde_json::Value) {
    use std::io::Write;
    // A closed stdout (e.g. `| head`) is not an error of the job.
    let mut out = std::io::stdout().lock();
    let _ = writeln!(out, "{value}");
    let _ = out.flush();
}

/// Relative difference of a rig constant (M1, M2, K1, K2, d) above which
/// two logs count as different rigs.
pub(crate) const RIG_TOLERANCE: f64 = 0.01;

/// Refuses logs whose rig constants (M1, M2, K1, K2, d) differ by more
/// than 1 % from the first log's, unless `allow` (then `None`): one error
/// naming both logs and every differing constant.
pub(crate) fn refuse_mixed_rigs(
    rigs: &[(std::path::PathBuf, crate::ingest::RigMeta)],
    allow: bool,
) -> crate::Result<()> {
    if allow {
        return Ok(());
    }
    let Some((p0, r0)) = rigs.first() else {
        return Ok(());
    };
    for (p, r) in &rigs[1..] {
        let diffs: Vec<String> = [
            ("M1", "kg", r0.m1_kg, r.m1_kg),
            ("M2", "kg", r0.m2_kg, r.m2_kg),
            ("K1", "N/m", r0.k1_n_per_m, r.k1_n_per_m),
            ("K2", "N/m", r0.k2_n_per_m, r.k2_n_per_m),
            ("d", "N s/m", r0.d_n_s_per_m, r.d_n_s_per_m),
        ]
        .iter()
        .filter(|(_, _, a, b)| (a - b).abs() > RIG_TOLERANCE * a.abs().max(b.abs()))
        .map(|(name, unit, a, b)| {
            format!(
                "{name} = {b} {unit} against {a} {unit} ({:+.1} %)",
                100.0 * (b / a - 1.0)
            )
        })
        .collect();
        if !diffs.is_empty() {
            return Err(crate::Error::Input {
                path: p.clone(),
                msg: format!(
                    "rig constants differ from {} by more than 1 %: {}; logs of different rigs are refused (give --allow-mixed-rigs to use them together)",
                    p0.display(),
                    diffs.join(", ")
                ),
            });
        }
    }
    Ok(())
}

/// What identifies one test for finding it given twice: the file, its rig
/// record and what was measured in it.
pub(crate) struct TestId<'a> {
    /// The log as given.
    pub path: &'a std::path::Path,
    /// Its rig record.
    pub rig: &'a crate::ingest::RigMeta,
    /// Measured normal force (N).
    pub normal_force_n: f64,
    /// Measured drive amplitude (m).
    pub drive_amplitude_m: f64,
    /// Measured drive frequency (Hz).
    pub drive_frequency_hz: f64,
}

/// Finds the same test given twice: the same file (after resolving the
/// path), or the same test in another format (the same rig record, with a
/// `recorded_at`, and the same measured normal force, drive amplitude and
/// frequency within 2 %, 1 % and 0.5 %). Returns which entries to keep (the
/// first of each test) and a warning per duplicate; two logs with the same
/// record whose data differ are kept, with a warning.
pub(crate) fn find_duplicates(ids: &[TestId<'_>]) -> (Vec<bool>, Vec<String>) {
    let mut keep = vec![true; ids.len()];
    let mut warnings = Vec::new();
    let canon: Vec<Option<std::path::PathBuf>> = ids
        .iter()
        .map(|t| std::fs::canonicalize(t.path).ok())
        .collect();
    let close = |a: f64, b: f64, tol: f64| (a - b).abs() <= tol * a.abs().max(b.abs());
    for j in 0..ids.len() {
        for i in 0..j {
            if !keep[i] {
                continue;
            }
            let (a, b) = (&ids[i], &ids[j]);
            if canon[i].is_some() && canon[i] == canon[j] {
                keep[j] = false;
                warnings.push(format!("{} is given twice: counted once", b.path.display()));
                break;
            }
            if a.rig.recorded_at.is_some() && a.rig.to_map() == b.rig.to_map() {
                if close(a.normal_force_n, b.normal_force_n, 0.02)
                    && close(a.drive_amplitude_m, b.drive_amplitude_m, 0.01)
                    && close(a.drive_frequency_hz, b.drive_frequency_hz, 0.005)
                {
                    keep[j] = false;
                    warnings.push(format!(
                        "{} is the same test as {} (same rig record, recorded_at {}, same measured normal force and drive): counted once",
                        b.path.display(),
                        a.path.display(),
                        a.rig.recorded_at.as_deref().unwrap_or("?")
                    ));
                    break;
                }
                warnings.push(format!(
                    "{} and {} carry the same rig record and recorded_at but their data differ (normal force {:.3} / {:.3} N, drive {:.4} / {:.4} mm): kept as two tests",
                    a.path.display(),
                    b.path.display(),
                    a.normal_force_n,
                    b.normal_force_n,
                    a.drive_amplitude_m * 1e3,
                    b.drive_amplitude_m * 1e3
                ));
            }
        }
    }
    (keep, warnings)
}
