//! `stickslip fit`: fit the friction law of each characteristic log, in
//! parallel; a bad log gives its `error:` line and an entry with `error`,
//! the others complete, and the exit status is 1 at the end.

use crate::identify::{self, IdentifyOptions, LawKind, LogFit};
use crate::ingest::{self, IngestOptions};
use clap::{Args, ValueEnum};
use serde_json::{json, Value};
use std::path::{Path, PathBuf};

/// `--law` choices.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum LawChoice {
    /// Choose by information criterion.
    Auto,
    /// ρd = ρs, no slope.
    Coulomb,
    /// ρd = ρs plus a linear slope of either sign.
    Decreasing,
    /// ρd < ρs.
    StaticDynamic,
    /// Stribeck-type law.
    Stribeck,
}

/// Arguments of `stickslip fit`.
#[derive(Debug, Args)]
pub struct FitArgs {
    /// Characteristic logs (.mcap, .csv with channel map, .parquet).
    #[arg(required = true)]
    pub logs: Vec<PathBuf>,
    /// Law family.
    #[arg(long, value_enum, default_value_t = LawChoice::Auto)]
    pub law: LawChoice,
    /// Write the JSON result to this file (atomically).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Relative gain uncertainty of each sensor in the calibration budget.
    #[arg(long, default_value_t = 0.01)]
    pub gain_uncertainty: f64,
    /// Bootstrap replicates over drive periods.
    #[arg(long, default_value_t = 400)]
    pub bootstrap: usize,
    /// Print one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
}

/// A float for JSON: non-finite values become `null`.
pub(crate) fn num(x: f64) -> Value {
    if x.is_finite() {
        json!(x)
    } else {
        Value::Null
    }
}

fn opt(x: Option<f64>) -> Value {
    x.map_or(Value::Null, num)
}

fn interval(i: Option<(f64, f64)>) -> Value {
    match i {
        Some((a, b)) if a.is_finite() && b.is_finite() => json!([a, b]),
        _ => Value::Null,
    }
}

/// The JSON entry of one fitted log (keys fixed by `interface.md`).
pub fn entry(log: &Path, f: &LogFit) -> Value {
    let e = &f.fit;
    let fs = f.force_scale_n;
    let vel = f.velocity_scale_m_per_s;
    let law_json = |l: &identify::SiLaw| {
        json!({
            "law": l.kind.as_str(),
            "rho_s": num(l.rs_n / fs),
            "rho_d": num(l.rd_n / fs),
            "slope": num(l.slope_n_s_per_m / f.slope_scale),
            "v_s": l.vs_m_per_s.map_or(Value::Null, |v| num(v / vel)),
            "r_s_n": num(l.rs_n),
            "r_d_n": num(l.rd_n),
            "slope_n_s_per_m": num(l.slope_n_s_per_m),
            "v_s_m_per_s": l.vs_m_per_s.map_or(Value::Null, num),
        })
    };
    json!({
        "log": log.display().to_string(),
        "law": e.law.kind.as_str(),
        "rho_s": opt(f.rho_s()),
        "rho_d": opt(f.rho_d()),
        "slope": opt(f.dstar()),
        "rho_s_interval": interval(f.rho_s_interval),
        "rho_d_interval": interval(f.rho_d_interval),
        "slope_interval": interval(f.dstar_interval),
        "r_s_n": num(e.law.rs_n),
        "r_d_n": num(e.law.rd_n),
        "slope_n_s_per_m": num(e.law.slope_n_s_per_m),
        "r_s_interval_n": interval(f.rs_interval_n),
        "r_d_interval_n": interval(f.rd_interval_n),
        "slope_interval_n_s_per_m": interval(f.slope_interval_n_s_per_m),
        "normal_force_n": num(f.normal_force_n),
        "eta": num(f.eta),
        "drive_frequency_hz": num(f.drive.frequency_hz),
        "stuck": e.stuck,
        "rho_s_lower_bound": opt(f.rho_s_lower_bound),
        "r_s_lower_bound_n": opt(f.rs_lower_bound_n),
        "never_sticks": e.never_sticks,
        "drive_amplitude_m": num(f.drive.amplitude_m),
        "residual_rms": num(e.residual_rms_n / fs),
        "residual_rms_n": num(e.residual_rms_n),
        "warnings": f.warnings,
        "stribeck": e.stribeck.as_ref().map_or(Value::Null, law_json),
        "simple_law": e.simple.as_ref().map_or(Value::Null, law_json),
        "criteria": e.criteria.iter().map(|(k, c)| json!({"law": k.as_str(), "bic": num(*c)})).collect::<Vec<_>>(),
        "estimate": "equation-error",
        "output_error": Value::Null,
        "gain_uncertainty": num(f.gain_uncertainty),
        "bias_n": num(e.bias_n),
        "slip_samples": e.n_slip,
        "effective_samples": num(e.n_eff),
        "breakaways": e.n_breakaways,
        "notes": f.notes,
    })
}

/// Runs `fit`; `Ok(false)` when some log failed (its error line is printed).
pub fn run(args: FitArgs) -> crate::Result<bool> {
    if !(args.gain_uncertainty.is_finite() && (0.0..0.5).contains(&args.gain_uncertainty)) {
        return Err(crate::Error::Input {
            path: PathBuf::from("--gain-uncertainty"),
            msg: "must be a finite fraction in [0, 0.5)".into(),
        });
    }
    crate::io::ensure_not_inputs(args.logs.iter().map(PathBuf::as_path), args.out.as_deref())?;
    let opts = IdentifyOptions {
        fit: identify::FitOptions {
            law: match args.law {
                LawChoice::Auto => None,
                LawChoice::Coulomb => Some(LawKind::Coulomb),
                LawChoice::Decreasing => Some(LawKind::Decreasing),
                LawChoice::StaticDynamic => Some(LawKind::StaticDynamic),
                LawChoice::Stribeck => Some(LawKind::Stribeck),
            },
            bootstrap: args.bootstrap,
            ..Default::default()
        },
        gain_uncertainty: args.gain_uncertainty,
    };
    let one = |log: &PathBuf| -> crate::Result<LogFit> {
        let run = ingest::read(log, &IngestOptions::default())?;
        identify::fit_log(&run, &opts)
    };
    // Parallel over logs, at most as many threads as cores.
    let threads = std::thread::available_parallelism()
        .map_or(1, |n| n.get())
        .min(args.logs.len())
        .max(1);
    let mut results: Vec<Option<crate::Result<LogFit>>> =
        (0..args.logs.len()).map(|_| None).collect();
    let next = std::sync::atomic::AtomicUsize::new(0);
    let slots: Vec<std::sync::Mutex<Option<crate::Result<LogFit>>>> = (0..args.logs.len())
        .map(|_| std::sync::Mutex::new(None))
        .collect();
    std::thread::scope(|s| {
        for _ in 0..threads {
            s.spawn(|| loop {
                let i = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                if i >= args.logs.len() {
                    break;
                }
                let r =
                    std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| one(&args.logs[i])))
                        .unwrap_or_else(|_| {
                            Err(crate::Error::Input {
                                path: args.logs[i].clone(),
                                msg: "internal error while fitting this log".into(),
                            })
                        });
                *slots[i].lock().unwrap_or_else(|e| e.into_inner()) = Some(r);
            });
        }
    });
    for (r, s) in results.iter_mut().zip(slots) {
        *r = s.into_inner().unwrap_or_else(|e| e.into_inner());
    }
    let mut failed = false;
    let mut fits = Vec::new();
    for (log, r) in args.logs.iter().zip(results) {
        match r {
            Some(Ok(f)) => {
                if !args.json {
                    eprintln!("{}", summary(log, &f));
                }
                fits.push(entry(log, &f));
            }
            Some(Err(e)) => {
                eprintln!("error: {e}");
                failed = true;
                fits.push(json!({"log": log.display().to_string(), "error": e.to_string()}));
            }
            None => unreachable!("every slot is filled"),
        }
    }
    let out = json!({ "fits": fits });
    if let Some(path) = &args.out {
        let text = serde_json::to_string_pretty(&out).map_err(|e| crate::Error::Input {
            path: path.clone(),
            msg: e.to_string(),
        })?;
        crate::io::write_atomic(path, text.as_bytes())?;
    }
    if args.json {
        super::print_json(&out);
    }
    Ok(!failed)
}

/// One human-readable line per log.
fn summary(log: &Path, f: &LogFit) -> String {
    let e = &f.fit;
    let fmt = |x: Option<f64>| x.map_or("-".to_string(), |v| format!("{v:.4}"));
    let mut s = format!(
        "{}: law {}, rho_s {}, rho_d {}, D* {}, Rs {} N, Rd {} N, A {:.4} mm",
        log.display(),
        e.law.kind.as_str(),
        fmt(f.rho_s()),
        fmt(f.rho_d()),
        fmt(f.dstar()),
        fmt(e.law.rs_n.is_finite().then_some(e.law.rs_n)),
        fmt(e.law.rd_n.is_finite().then_some(e.law.rd_n)),
        f.drive.amplitude_m * 1e3
    );
    if e.stuck {
        s.push_str(&format!(", stuck (rho_s >= {})", fmt(f.rho_s_lower_bound)));
    }
    if e.never_sticks {
        s.push_str(", never sticks");
    }
    for w in &f.warnings {
        s.push_str(&format!("\n  warning: {w}"));
    }
    s
}
