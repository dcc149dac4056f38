//! `stickslip fit`: fit the friction law of each characteristic log, in
//! parallel; a bad log gives its `error:` line and an entry with `error`,
//! the others complete, and the exit status is 1 at the end.

use crate::identify::artifact::{self, FitArtifact};
use crate::identify::{self, IdentifyOptions, LogFit};
use crate::io::Output;
use crate::model::LawKind;
use clap::{Args, ValueEnum};
use serde_json::json;
use std::path::{Path, PathBuf};

/// `--law`: a family, or `auto` (None: choose by information criterion).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LawPick(pub Option<LawKind>);

/// The `--law` parser: `auto` or a [`LawKind`] name (the help and the
/// error list the names).
pub fn law_pick() -> impl clap::builder::TypedValueParser<Value = LawPick> {
    let names = std::iter::once("auto").chain(LawKind::all().iter().map(|k| k.as_str()));
    use clap::builder::TypedValueParser;
    clap::builder::PossibleValuesParser::new(names).map(|s: String| LawPick(LawKind::parse(&s)))
}

/// `--estimate` choices.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum EstimateChoice {
    /// The output-error refinement where it applies (default), else the
    /// equation-error estimate.
    OutputError,
    /// The equation-error estimate only (no refinement).
    EquationError,
}

/// Arguments of `stickslip fit`.
#[derive(Debug, Args)]
pub struct FitArgs {
    /// Characteristic logs (.mcap, .csv with channel map, .parquet).
    #[arg(required = true)]
    pub logs: Vec<PathBuf>,
    /// Law family.
    #[arg(long, default_value = "auto", value_parser = law_pick(), allow_hyphen_values = true)]
    pub law: LawPick,
    /// Write the JSON result to this file (atomically).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Relative gain uncertainty of each sensor in the calibration budget.
    #[arg(long, default_value_t = 0.01, value_parser = super::args::gain_fraction, allow_hyphen_values = true)]
    pub gain_uncertainty: f64,
    /// Bootstrap replicates over drive periods (0 to 100000).
    #[arg(long, default_value_t = 400, value_parser = super::args::bootstrap_replicates, allow_hyphen_values = true)]
    pub bootstrap: usize,
    /// Which estimate is reported as the law (and used downstream).
    #[arg(long, value_enum, default_value_t = EstimateChoice::OutputError)]
    pub estimate: EstimateChoice,
    /// Fit only slice K of N of the logs (K = 1..N; contiguous, balanced
    /// slices in the order given); the result records K/N and the sha256
    /// list of all the logs, for `merge`.
    #[arg(long, value_name = "K/N")]
    pub shard: Option<String>,
    /// Print one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
}

/// Most shards of a fit (far more than logs one command is given).
pub const MAX_FIT_SHARDS: usize = 1_000_000;

/// Parses `--shard K/N` of `fit` (1 ≤ K ≤ N ≤ [`MAX_FIT_SHARDS`]).
pub fn parse_fit_shard(s: &str) -> crate::Result<(usize, usize)> {
    let parts: Vec<&str> = s.split('/').collect();
    let nums: Option<(usize, usize)> = match parts.as_slice() {
        [a, b] => a.trim().parse().ok().zip(b.trim().parse().ok()),
        _ => None,
    };
    let bad = |msg: String| crate::Error::Input {
        path: PathBuf::from("--shard"),
        msg,
    };
    match nums {
        Some((_, n)) if n > MAX_FIT_SHARDS => Err(bad(format!(
            "{s}: at most {MAX_FIT_SHARDS} shards"
        ))),
        Some((k, n)) if n >= 1 && (1..=n).contains(&k) => Ok((k, n)),
        Some((0, n)) if n >= 1 => Err(bad(format!(
            "must be K/N with 1 <= K <= N, got `{s}`: K is 1-based (a job array numbered from 0 gives K = task id - min task id + 1)"
        ))),
        _ => Err(bad(format!("must be K/N with 1 <= K <= N, got `{s}`"))),
    }
}

/// The logs of shard K of N among `n` logs: a contiguous slice, the
/// slices' sizes differing by at most one (some are empty when N > n).
pub fn shard_range(k: usize, shards: usize, n: usize) -> std::ops::Range<usize> {
    let at = |i: usize| (i as u128 * n as u128 / shards as u128) as usize;
    at(k - 1)..at(k)
}

/// Runs `fit`; `Ok(false)` when some log failed (its error line is printed).
pub fn run(args: FitArgs) -> crate::Result<bool> {
    // A missing or unreadable log is a per-log `error` entry (the
    // contract); a FIFO or device would hang the read, so it is refused
    // up front.
    crate::io::check_inputs(
        args.logs
            .iter()
            .map(PathBuf::as_path)
            .filter(|p| std::fs::metadata(p).is_ok_and(|m| !m.is_file())),
    )?;
    let outputs: Vec<Output> = args
        .out
        .iter()
        .map(|p| Output::file("--out", p, super::ext::JSON))
        .collect();
    crate::io::check_outputs(args.logs.iter().map(PathBuf::as_path), &outputs)?;
    let shard = args.shard.as_deref().map(parse_fit_shard).transpose()?;
    // Every log's sha256 (a part records the whole list; a log that cannot
    // be read has none, and its fit fails below).
    let sha = |p: &PathBuf| identify::artifact::sha256_file(p).ok();
    let (all_shas, logs): (Vec<Option<String>>, &[PathBuf]) = match shard {
        Some((k, n)) => (
            args.logs.iter().map(sha).collect(),
            &args.logs[shard_range(k, n, args.logs.len())],
        ),
        None => (Vec::new(), &args.logs),
    };
    let opts = IdentifyOptions {
        fit: identify::FitOptions {
            law: args.law.0,
            bootstrap: args.bootstrap,
            ..Default::default()
        },
        gain_uncertainty: args.gain_uncertainty,
        output_error: args.estimate == EstimateChoice::OutputError,
        ..Default::default()
    };
    // Parallel over logs, each panic-guarded (one failing log does not
    // stop the others).
    let results = identify::fit_logs(logs, &opts, &|| {});
    let mut failed: Vec<String> = Vec::new();
    let mut fits = Vec::new();
    for (log, r) in logs.iter().zip(results) {
        let log_sha = r.as_ref().ok().and_then(|_| sha(log));
        match (r, log_sha) {
            (Ok((rig, f)), Some(log_sha256)) => {
                if !args.json {
                    eprintln!("{}", summary(log, &f));
                }
                let a = FitArtifact {
                    log: log.clone(),
                    log_sha256,
                    rig,
                    fit: f,
                };
                fits.push(a.to_record()?);
            }
            (r, _) => {
                let e = match r {
                    Err(e) => e.to_string(),
                    Ok(_) => format!("{}: cannot be read again for its sha256", log.display()),
                };
                eprintln!("error: {e}");
                failed.push(log.display().to_string());
                fits.push(artifact::failed_record(log, sha(log).as_deref(), &e));
            }
        }
    }
    let out = match shard {
        Some((k, n)) => {
            json!({ "shard": k, "shards": n, "log_sha256s": all_shas, "fits": fits })
        }
        None => json!({ "fits": fits }),
    };
    if let Some(path) = &args.out {
        super::write_json(path, &out)?;
    }
    if args.json {
        super::print_json(&out)?;
    }
    // The last line names every log that failed (the contract's one
    // exception to "a failed command writes nothing": the others' fits
    // are written).
    if !failed.is_empty() && logs.len() > 1 {
        eprintln!(
            "error: {} of {} logs failed: {}",
            failed.len(),
            logs.len(),
            failed.join(", ")
        );
    }
    Ok(failed.is_empty())
}

/// One human-readable line per log.
fn summary(log: &Path, f: &LogFit) -> String {
    let e = &f.fit;
    let law = f.law();
    let fmt = |x: Option<f64>| x.map_or("-".to_string(), |v| format!("{v:.4}"));
    let mut s = format!(
        "{}: law {}, rho_s {}, rho_d {}, D* {}, Rs {} N, Rd {} N, A {:.4} mm ({} estimate)",
        log.display(),
        f.kind().as_str(),
        fmt(f.rho_s()),
        fmt(f.rho_d()),
        fmt(f.dstar()),
        fmt(f.rs_n()),
        fmt(law.map(|l| l.rd_n)),
        f.drive.amplitude_m * 1e3,
        f.estimate.as_str()
    );
    if e.stuck {
        s.push_str(&format!(
            ", stuck (rho_s >= {})",
            fmt(f.rho_s_lower_bound())
        ));
    }
    if f.never_sticks() {
        s.push_str(", never sticks");
    }
    s.push_str(if f.adequate() {
        ", adequate"
    } else {
        ", NOT ADEQUATE"
    });
    for w in &f.warnings {
        s.push_str(&format!("\n  warning: {w}"));
    }
    s
}
