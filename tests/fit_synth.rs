//! Round trips of the identification through the virtual rig (the library
//! behind `stickslip synth`): random friction laws (Coulomb, `decreasing`
//! with a falling or a rising, viscous characteristic, static-dynamic),
//! random rig constants, normal forces, drive amplitudes and frequencies,
//! sensor noise levels from 0.5× to 2× the typical DAQ's, with and without
//! an accelerometer; written as MCAP (DAQ buffers, jitter, lost buffers,
//! dropouts, gains and offsets) and read back through ingest.
//!
//! Logs whose absorber never slides or never sticks are skipped (they only
//! bound ρs; their semantics are tested on the public data set).

mod common;

use common::env_or;
use std::path::Path;
use stickslip::identify::{self, IdentifyOptions, Interval, LogFit};
use stickslip::ingest::{self, IngestOptions};
use stickslip::stats::Rng;
use stickslip::synth::{self, FrictionSpec, RigSpec, Sensors, SynthConfig, TestSpec};

/// Uniform deviate in [a, b) from the project's SplitMix64 generator
/// (deterministic cases).
fn range(rng: &mut Rng, a: f64, b: f64) -> f64 {
    a + (b - a) * rng.uniform()
}

/// A random characteristic test: its configuration and a description.
fn random_case(seed: u64) -> (SynthConfig, String) {
    let mut r = Rng::new(seed.wrapping_mul(0x2545_F491_4F6C_DD1D) ^ 0xA5A5);
    let m2 = range(&mut r, 1.5, 3.0);
    let k2 = range(&mut r, 500.0, 900.0);
    let a_nom = range(&mut r, 0.002, 0.003);
    let rig = RigSpec {
        m1_kg: m2 * range(&mut r, 3.0, 5.0),
        m2_kg: m2,
        k1_n_per_m: k2 * range(&mut r, 0.8, 1.25),
        k2_n_per_m: k2,
        d_n_s_per_m: range(&mut r, 0.002, 0.008) * (k2 * m2).sqrt(),
        drive_amplitude_nominal_m: a_nom,
        drive_amplitude_true_m: a_nom * range(&mut r, 0.985, 1.015),
    };
    // η between the first resonance and the stuck system's.
    let eta = range(&mut r, 0.55, 0.68);
    let frequency_hz = eta * rig.omega_ref() / (2.0 * std::f64::consts::PI);
    let fs = rig.drive_amplitude_true_m * k2;
    let ss = (k2 * m2).sqrt();
    // Normal force and friction coefficients such that ρs is in [0.35, 1.5].
    let rho = range(&mut r, 0.35, 1.5);
    let mu = range(&mut r, 0.3, 0.6);
    let normal = rho * fs / mu;
    let family = (seed % 4) as u32;
    let rs = mu * normal;
    let (rd, slope, name) = match family {
        0 => (rs, 0.0, "coulomb"),
        1 => (rs, -range(&mut r, 0.03, 0.15) * ss, "decreasing"),
        2 => (rs, range(&mut r, 0.03, 0.15) * ss, "viscous"),
        _ => (rs * range(&mut r, 0.7, 0.9), 0.0, "static-dynamic"),
    };
    let noise = range(&mut r, 0.5, 2.0);
    let accel = r.uniform() < 0.5;
    let mut sensors = Sensors::typical(seed);
    for m in [
        &mut sensors.x0,
        &mut sensors.x1,
        &mut sensors.x2,
        &mut sensors.v2,
    ] {
        m.noise *= noise;
    }
    sensors.a2 = if accel {
        sensors.a2.map(|mut a| {
            a.noise *= noise;
            a
        })
    } else {
        None
    };
    let cfg = SynthConfig {
        rig,
        friction: FrictionSpec {
            rs_n: rs,
            rd_n: rd,
            slope_n_s_per_m: slope,
            stribeck_velocity_m_per_s: None,
            law: None,
        },
        normal_force_n: normal,
        test: TestSpec::Characteristic {
            frequency_hz,
            warmup_s: 30.0,
            duration_s: 20.0,
        },
        sensors,
        ..SynthConfig::paper(seed)
    };
    let label = format!(
        "seed {seed}: {name} Rs {rs:.3} Rd {rd:.3} D* {:+.3} (ρs {:.2}), η {eta:.3}, noise ×{noise:.2}, accel {accel}",
        slope / ss,
        rs / fs
    );
    (cfg, label)
}

/// What one round trip gave.
struct Outcome {
    /// Per parameter (Rs, Rd, a): the interval of the estimate used holds
    /// the truth.
    hits: [bool; 3],
    /// The same for the equation-error intervals.
    ee_hits: [bool; 3],
    /// ρs, ρd, D* (truth with the true drive amplitude).
    rho_hits: [bool; 3],
    family_ok: bool,
    /// The equation-error criterion's family is right.
    ee_family_ok: bool,
    report: String,
}

fn inside(iv: Option<Interval>, x: f64) -> bool {
    matches!(iv, Some((lo, hi)) if lo <= x && x <= hi)
}

/// Generates, writes, ingests and fits one case; None when the absorber
/// never slid or never stuck in the log.
fn round_trip(seed: u64, dir: &Path) -> Option<Outcome> {
    let (cfg, label) = random_case(seed);
    let log = synth::generate(&cfg).expect("generate");
    let truth = &log.truth;
    if truth["stuck"] == true || truth["stick_fraction"].as_f64().unwrap() <= 0.0 {
        return None;
    }
    let path = dir.join(format!("case{seed}.mcap"));
    synth::write(&log, &path).expect("write");
    let run = ingest::read(&path, &IngestOptions::default()).expect("ingest");
    let fit: LogFit = identify::fit_log(&run, &IdentifyOptions::default()).expect("fit");
    if fit.stuck() || fit.never_sticks() {
        return None;
    }
    let f = &cfg.friction;
    let want = match (f.rd_n < f.rs_n, f.slope_n_s_per_m != 0.0) {
        (true, _) => "static-dynamic",
        (false, true) => "decreasing",
        _ => "coulomb",
    };
    let x = [f.rs_n, f.rd_n, f.slope_n_s_per_m];
    let iv = [
        fit.rs_interval_n,
        fit.rd_interval_n,
        fit.slope_interval_n_s_per_m,
    ];
    let ee = &fit.equation_error;
    let ee_iv = [ee.rs_n, ee.rd_n, ee.slope_n_s_per_m];
    let hits = [0, 1, 2].map(|k| inside(iv[k], x[k]));
    let ee_hits = [0, 1, 2].map(|k| inside(ee_iv[k], x[k]));
    let fs = cfg.rig.drive_amplitude_true_m * cfg.rig.k2_n_per_m;
    let ss = (cfg.rig.k2_n_per_m * cfg.rig.m2_kg).sqrt();
    let xr = [f.rs_n / fs, f.rd_n / fs, f.slope_n_s_per_m / ss];
    let ivr = [fit.rho_s_interval, fit.rho_d_interval, fit.dstar_interval];
    let rho_hits = [0, 1, 2].map(|k| inside(ivr[k], xr[k]));
    let law = fit.law().expect("a sliding law");
    let report = format!(
        "{label} a {:.3}\n    {} {}: Rs {:.4} {:?} Rd {:.4} {:?} a {:.3} {:?} | EE {} Rs {:.4} Rd {:.4} a {:.3} {:?} OE {:?}",
        f.slope_n_s_per_m,
        fit.estimate.as_str(),
        law.kind.as_str(),
        law.rs_n,
        iv[0],
        law.rd_n,
        iv[1],
        law.slope_n_s_per_m,
        iv[2],
        fit.fit.law.kind.as_str(),
        fit.fit.law.rs_n,
        fit.fit.law.rd_n,
        fit.fit.law.slope_n_s_per_m,
        fit.fit.criteria,
        fit.output_error
            .as_ref()
            .map(|o| o.families.iter().map(|f| (f.law.kind, f.bic, f.law.slope_n_s_per_m)).collect::<Vec<_>>()),
    );
    Some(Outcome {
        hits,
        ee_hits,
        rho_hits,
        family_ok: law.kind.as_str() == want,
        ee_family_ok: fit.fit.law.kind.as_str() == want,
        report,
    })
}

/// Tallies of a study.
#[derive(Debug, Default)]
struct Tally {
    /// Cases fitted (both sticking and slipping).
    cases: usize,
    /// Cases skipped (stuck or never sticking).
    skipped: usize,
    /// Intervals of the estimate used holding the truth, per parameter
    /// (Rs, Rd, a) and in total.
    per: [usize; 3],
    hits: usize,
    /// The same for ρs, ρd, D*.
    rho_per: [usize; 3],
    /// The same for the equation-error intervals (total).
    ee_hits: usize,
    /// Families chosen right.
    families: usize,
    /// The same by the equation-error criterion.
    ee_families: usize,
    /// Cases with a miss.
    report: Vec<String>,
}

/// Runs `n` cases from `first`.
fn study(first: u64, n: u64) -> Tally {
    let dir = tempfile::tempdir().unwrap();
    let mut t = Tally::default();
    for seed in first..first + n {
        let Some(o) = round_trip(seed, dir.path()) else {
            t.skipped += 1;
            continue;
        };
        t.cases += 1;
        for k in 0..3 {
            t.per[k] += usize::from(o.hits[k]);
            t.rho_per[k] += usize::from(o.rho_hits[k]);
        }
        t.hits += o.hits.iter().filter(|h| **h).count();
        t.ee_hits += o.ee_hits.iter().filter(|h| **h).count();
        t.families += usize::from(o.family_ok);
        t.ee_families += usize::from(o.ee_family_ok);
        if !o.family_ok || o.hits.iter().any(|h| !h) || o.rho_hits.iter().any(|h| !h) {
            t.report.push(format!(
                "{} (covered {:?}, ρ {:?}, family ok {})",
                o.report, o.hits, o.rho_hits, o.family_ok
            ));
        }
    }
    t
}

/// CI: 12 random round trips. Per parameter set (SI: Rs, Rd, a; and
/// dimensionless: ρs, ρd, D*) up to 36 intervals; with a true coverage of
/// 95 % the misses are binomial with mean ≤ 1.8 and P(misses ≥ 5) ≤ 3.6 %,
/// so at most 4 misses each. The family must be right in all but one.
/// Measured: 26/27 and 26/27, families 9/9 (3 of 12 skipped).
#[test]
fn synth_round_trips_cover_the_truth() {
    let t = study(1, 12);
    for r in &t.report {
        eprintln!("{r}");
    }
    let n = 3 * t.cases;
    let rho: usize = t.rho_per.iter().sum();
    eprintln!(
        "coverage {}/{n} (ρ {rho}/{n}), families {}/{}, skipped {}",
        t.hits, t.families, t.cases, t.skipped
    );
    assert!(
        t.cases >= 8,
        "only {} of 12 cases both stick and slip",
        t.cases
    );
    assert!(n - t.hits <= 4, "{}/{n}: {:#?}", t.hits, t.report);
    assert!(n - rho <= 4, "ρ {rho}/{n}: {:#?}", t.report);
    assert!(t.families + 1 >= t.cases, "{:#?}", t.report);
}

/// Static/dynamic truths whose residuals carry the Stribeck screen's
/// signature (x2 structure against the drive phase, z about 4) from
/// sensor effects, not from a drop: the screen refines the Stribeck
/// family, which with position lags fitted collapsed to v_s ≈ 1e-8 m/s
/// (a step between two samples) plus a spurious slope, and won by ΔBIC 44
/// and 115 with Rs intervals that miss. A Stribeck law screened in this
/// way must resolve its drop (v_s above the speed gained within one
/// sample after breakaway); these stay static/dynamic.
#[test]
fn static_dynamic_truths_are_not_read_as_a_collapsed_stribeck() {
    let dir = tempfile::tempdir().unwrap();
    for seed in [63, 155] {
        let o = round_trip(seed, dir.path()).expect("sticks and slips");
        assert!(o.family_ok, "{}", o.report);
        assert!(o.hits[0] && o.hits[1], "{}", o.report);
    }
}

/// The long study (`cargo test --release --test fit_synth -- --ignored
/// --nocapture`; `STUDY_N` cases from `STUDY_FIRST`, default 200 from 1).
///
/// Measured (session 16; 200 cases, 174 both sticking and slipping, 26
/// skipped): intervals of the estimate used hold the truth for 514/522 SI
/// parameters (Rs 174, Rd 173, a 167 of 174) and 508/522 dimensionless
/// ones (ρs 171, ρd 170, D* 167); the equation-error intervals alone
/// 417/522. Family right in 173/174 (by the equation-error criterion
/// alone: 138/174; the miss: seed 93, a falling `decreasing` law at
/// ρs = 1.37 that barely sticks, read as Coulomb by the equation error
/// with the slope's interval holding 0). Most misses of the intervals are
/// slopes and ρ of the `decreasing` family, whose intervals are narrow
/// (D* to ±0.0003).
#[test]
#[ignore = "study: 200 random round trips (about 2 minutes in release)"]
fn synth_round_trip_study() {
    let n = env_or("STUDY_N", 200);
    let first = env_or("STUDY_FIRST", 1);
    let t = study(first, n);
    for r in &t.report {
        eprintln!("{r}");
    }
    eprintln!(
        "coverage {}/{} (Rs, Rd, a: {:?}; ρs, ρd, D*: {:?}; equation error {}/{}), families {}/{} (equation error {}), skipped {}",
        t.hits,
        3 * t.cases,
        t.per,
        t.rho_per,
        t.ee_hits,
        3 * t.cases,
        t.families,
        t.cases,
        t.ee_families,
        t.skipped
    );
}

/// Repeatability of one law (the paper's rig, a static/dynamic pad at
/// 4 N) under new sensor draws (typical DAQ): the spread of the estimates
/// against their intervals. Measured over 200 draws: ρs error mean
/// +0.004 %, sd 0.025 %, 3 intervals of 200 miss the truth; ρd mean
/// −0.003 %, sd 0.015 %, 10 of 200 miss. With one anchor interval per
/// segment instead of three the mean ρs error was −0.027 % (12 draws; the
/// incidental-parameter bias of per-segment start states).
#[test]
#[ignore = "study: repeatability under new sensor draws"]
fn synth_repeatability_study() {
    let dir = tempfile::tempdir().unwrap();
    let n: u64 = env_or("STUDY_N", 20);
    let (mut e_s, mut e_d, mut miss) = (Vec::new(), Vec::new(), [0, 0]);
    for seed in 0..n {
        let mut cfg = SynthConfig::paper(seed);
        cfg.friction = FrictionSpec {
            rs_n: 1.68,
            rd_n: 1.36,
            slope_n_s_per_m: 0.0,
            stribeck_velocity_m_per_s: None,
            law: None,
        };
        let log = synth::generate(&cfg).expect("generate");
        let path = dir.path().join(format!("r{seed}.mcap"));
        synth::write(&log, &path).expect("write");
        let run = ingest::read(&path, &IngestOptions::default()).expect("ingest");
        let fit = identify::fit_log(&run, &IdentifyOptions::default()).expect("fit");
        let fs = cfg.rig.drive_amplitude_true_m * cfg.rig.k2_n_per_m;
        let (rs, rd) = (1.68 / fs, 1.36 / fs);
        e_s.push(100.0 * (fit.rho_s().unwrap() / rs - 1.0));
        e_d.push(100.0 * (fit.rho_d().unwrap() / rd - 1.0));
        miss[0] += usize::from(!inside(fit.rho_s_interval, rs));
        miss[1] += usize::from(!inside(fit.rho_d_interval, rd));
    }
    let ms = |v: &[f64]| {
        let m = v.iter().sum::<f64>() / v.len() as f64;
        let sd = (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (v.len() - 1) as f64).sqrt();
        (m, sd)
    };
    eprintln!(
        "ρs error (mean, sd) {:?} %, misses {}; ρd {:?} %, misses {} (of {n})",
        ms(&e_s),
        miss[0],
        ms(&e_d),
        miss[1]
    );
}
