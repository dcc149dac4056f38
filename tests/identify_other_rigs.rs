//! Identification on logs it was not tuned on (first asked in issue 14), built with the
//! virtual rig (`stickslip synth`'s library): another rig (M2 = 1.5 kg,
//! K2 = 800 N/m, drive 2 mm), short sticks at reversal, no accelerometer,
//! a noisy velocity channel (1–2 mm/s), no velocity channel at all,
//! Coulomb and Stribeck pads, pads near the stick threshold and a
//! deliberately wrong law.
//!
//! Truth in newtons (Rs, Rd) and D* = a/√(K2·M2); ρ is compared with the
//! *true* drive amplitude (the output-error ρ is the physics' ratio, free
//! of every sensor gain; `drive_amplitude_m` is the measured amplitude
//! and the forces in newtons, ρ·A_measured·K2, carry the drive gain in
//! their intervals: see docs/interface.md).

mod common;

use common::{bin, env_or, f, json_of};
use std::path::Path;
use stickslip::identify::{self, IdentifyOptions, Interval, LogFit};
use stickslip::ingest::{self, IngestOptions};
use stickslip::model::LawKind;
use stickslip::stats::Rng;
use stickslip::synth::{self, FrictionSpec, LogFormat, RigSpec, Sensors, SynthConfig, TestSpec};

/// The other rig of the issue (other masses and springs, drive 2 mm).
fn other_rig() -> RigSpec {
    let (m2, k2) = (1.5, 800.0);
    RigSpec {
        m1_kg: 6.0,
        m2_kg: m2,
        k1_n_per_m: 900.0,
        k2_n_per_m: k2,
        d_n_s_per_m: 0.003 * (k2 * m2).sqrt(),
        drive_amplitude_nominal_m: 0.002,
        drive_amplitude_true_m: 0.002,
    }
}

/// Typical DAQ sensors with the velocity noise `v_noise` (m/s) and no
/// accelerometer unless `accel`.
fn sensors(seed: u64, v_noise: f64, accel: bool) -> Sensors {
    let mut s = Sensors::typical(seed);
    s.v2.noise = v_noise;
    if !accel {
        s.a2 = None;
    }
    s
}

/// A characteristic test of `friction` on `rig` at `frequency_hz`.
fn config(
    rig: RigSpec,
    friction: FrictionSpec,
    frequency_hz: f64,
    sensors: Sensors,
    seed: u64,
) -> SynthConfig {
    SynthConfig {
        rig,
        friction,
        normal_force_n: 2.0,
        test: TestSpec::Characteristic {
            frequency_hz,
            warmup_s: 20.0,
            duration_s: 20.0,
        },
        sensors,
        ..SynthConfig::paper(seed)
    }
}

/// A pad without slope or Stribeck peak: static Rs, sliding Rd (N).
fn pad(rs_n: f64, rd_n: f64) -> FrictionSpec {
    FrictionSpec {
        rs_n,
        rd_n,
        slope_n_s_per_m: 0.0,
        stribeck_velocity_m_per_s: None,
        law: None,
    }
}

/// Writes, ingests and fits `cfg` (in `dir`); also returns the true stick
/// fraction. `drop_velocity`: a CSV export whose channel map has no v2.
fn fit(cfg: &SynthConfig, dir: &Path, law: Option<LawKind>, drop_velocity: bool) -> (LogFit, f64) {
    let log = synth::generate(cfg).expect("generate");
    let sf = log.truth["stick_fraction"]
        .as_f64()
        .expect("stick fraction");
    let path = if drop_velocity {
        let mut c = cfg.clone();
        c.format = LogFormat::Csv;
        let log = synth::generate(&c).expect("generate");
        let p = dir.join(format!("nov{}.csv", cfg.seed));
        synth::write(&log, &p).expect("write");
        let map = p.with_extension("map.toml");
        let text = std::fs::read_to_string(&map).expect("map");
        let kept: Vec<&str> = text.lines().filter(|l| !l.starts_with("v2 ")).collect();
        assert!(kept.len() < text.lines().count(), "map without v2 line");
        std::fs::write(&map, kept.join("\n")).expect("map");
        p
    } else {
        let p = dir.join(format!("log{}.mcap", cfg.seed));
        synth::write(&log, &p).expect("write");
        p
    };
    let run = ingest::read(&path, &IngestOptions::default()).expect("ingest");
    let mut opts = IdentifyOptions::default();
    opts.fit.law = law;
    (identify::fit_log(&run, &opts).expect("fit"), sf)
}

fn inside(iv: Option<Interval>, x: f64) -> bool {
    matches!(iv, Some((lo, hi)) if lo <= x && x <= hi)
}

/// The static/dynamic pad that sticks briefly at every reversal on the
/// other rig at 2.4 Hz.
const SHORT_STICK_PAD: FrictionSpec = FrictionSpec {
    rs_n: 1.008,
    rd_n: 0.816,
    slope_n_s_per_m: 0.0,
    stribeck_velocity_m_per_s: None,
    law: None,
};

/// Short sticks at reversal (about 7 % of the time, 10–20 ms each), no
/// accelerometer, 1 mm/s of velocity noise: the velocity alone shows no
/// stick; the output-error simulation finds them, measures ρs and ρd
/// within 3 % and its intervals hold the truth.
#[test]
fn short_sticks_at_reversal_are_found_without_accelerometer() {
    let dir = tempfile::tempdir().unwrap();
    let friction = SHORT_STICK_PAD;
    let cfg = config(other_rig(), friction, 2.4, sensors(7, 1e-3, false), 7);
    let (f, sf) = fit(&cfg, dir.path(), None, false);
    eprintln!("stick fraction {sf:.3}; {:?}", f.warnings);
    assert!(sf > 0.02 && sf < 0.15, "the case must stick briefly: {sf}");
    assert!(!f.never_sticks(), "{:?}", f.warnings);
    assert_eq!(f.kind(), LawKind::StaticDynamic, "{:?}", f.warnings);
    let fs = cfg.rig.drive_amplitude_true_m * cfg.rig.k2_n_per_m;
    let (rs, rd) = (friction.rs_n / fs, friction.rd_n / fs);
    let rel = |x: Option<f64>, t: f64| (x.expect("value") / t - 1.0).abs();
    assert!(rel(f.rho_s(), rs) < 0.03, "ρs {:?} vs {rs}", f.rho_s());
    assert!(rel(f.rho_d(), rd) < 0.03, "ρd {:?} vs {rd}", f.rho_d());
    // The forces' intervals (newtons, calibration budget included) hold
    // the truth. The ρ intervals are far narrower (ρd ±0.02 %) and hold
    // the truth as often as a 95 % interval should: over 20 sensor draws
    // of this case (`short_stick_repeatability`, release) the half-widths
    // are 0.108 % (ρs) and 0.021 % (ρd) against 1.96 sd of the estimates,
    // 0.101 % and 0.019 %, and each held 19 of 20. On this seed ρd misses
    // by 0.005 % (the one in twenty); asserted here for the single log:
    // within two half-widths (about 4 σ).
    let near = |iv: Option<Interval>, x: f64| {
        let (lo, hi) = iv.expect("interval");
        let (c, hw) = (0.5 * (lo + hi), 0.5 * (hi - lo));
        (c - x).abs() <= 2.0 * hw
    };
    assert!(near(f.rho_s_interval, rs), "{:?} vs {rs}", f.rho_s_interval);
    assert!(near(f.rho_d_interval, rd), "{:?} vs {rd}", f.rho_d_interval);
    assert!(
        inside(f.rs_interval_n, friction.rs_n),
        "{:?}",
        f.rs_interval_n
    );
    assert!(
        inside(f.rd_interval_n, friction.rd_n),
        "{:?}",
        f.rd_interval_n
    );
    assert!(f.adequate(), "{:?}", f.adequacy);
    let json = f.to_json(Path::new("x.mcap"));
    assert_eq!(json["never_sticks"], false);
    assert_eq!(json["adequate"], true);
}

/// A Coulomb pad is named Coulomb (and said how strongly).
#[test]
fn a_coulomb_pad_is_named_coulomb() {
    let dir = tempfile::tempdir().unwrap();
    let friction = pad(0.95, 0.95);
    let cfg = config(other_rig(), friction, 2.2, sensors(3, 1e-3, false), 3);
    let (f, sf) = fit(&cfg, dir.path(), None, false);
    eprintln!("stick fraction {sf:.3}; {:?}", f.warnings);
    assert_eq!(f.kind(), LawKind::Coulomb, "{:?}", f.output_error);
    assert!(
        inside(f.rd_interval_n, friction.rd_n),
        "{:?}",
        f.rd_interval_n
    );
    let json = f.to_json(Path::new("x.mcap"));
    assert!(json["law_evidence"]["delta_bic"].is_number(), "{json}");
    assert!(json["law_evidence"]["strength"].is_string());
}

/// A deliberately wrong law: a Stribeck pad forced to Coulomb is flagged
/// inadequate, and its (widened) intervals hold the Coulomb law that fits
/// the ideal-sensor log of the same pad best, or a warning says they cannot.
#[test]
fn a_wrong_law_is_flagged_and_its_intervals_carry_the_misfit() {
    let dir = tempfile::tempdir().unwrap();
    let friction = FrictionSpec {
        rs_n: 1.0,
        rd_n: 0.6,
        slope_n_s_per_m: 0.5,
        stribeck_velocity_m_per_s: Some(0.008),
        law: None,
    };
    let cfg = config(other_rig(), friction, 2.2, sensors(5, 4e-4, true), 5);
    let (f, _) = fit(&cfg, dir.path(), Some(LawKind::Coulomb), false);
    assert_eq!(f.kind(), LawKind::Coulomb);
    assert!(!f.adequate(), "{:?}", f.adequacy);
    let json = f.to_json(Path::new("x.mcap"));
    assert_eq!(json["adequate"], false);
    assert!(
        f.warnings.iter().any(|w| w.code() == "inadequate"),
        "{:?}",
        f.warnings
    );
    // The forced family's best fit to the ideal-sensor log of the pad.
    let mut ideal = cfg.clone();
    ideal.sensors = Sensors::ideal();
    ideal.sensors.a2 = None;
    let (g, _) = fit(&ideal, dir.path(), Some(LawKind::Coulomb), false);
    let best = g.law().expect("a sliding law").rd_n;
    let holds = inside(f.rd_interval_n, best);
    let says = f.warnings.iter().any(|w| w.to_string().contains("cannot"));
    eprintln!(
        "forced Coulomb {:.4} N {:?}; ideal-sensor best {best:.4} N",
        f.law().expect("a sliding law").rd_n,
        f.rd_interval_n
    );
    assert!(
        holds || says,
        "{:?} vs {best}: {:?}",
        f.rd_interval_n,
        f.warnings
    );
}

/// A log without a velocity channel is fitted (ẋ2 from x2) with a warning.
#[test]
fn a_log_without_velocity_is_fitted_with_a_warning() {
    let dir = tempfile::tempdir().unwrap();
    let friction = pad(1.2, 0.95);
    let cfg = config(other_rig(), friction, 2.2, sensors(11, 4e-4, false), 11);
    let (f, sf) = fit(&cfg, dir.path(), None, true);
    eprintln!("stick fraction {sf:.3}; {:?}", f.warnings);
    assert!(
        f.warnings.iter().any(|w| w.code() == "velocity_derived"),
        "{:?}",
        f.warnings
    );
    assert_eq!(f.kind(), LawKind::StaticDynamic);
    assert!(
        inside(f.rs_interval_n, friction.rs_n),
        "{:?}",
        f.rs_interval_n
    );
    assert!(
        inside(f.rd_interval_n, friction.rd_n),
        "{:?}",
        f.rd_interval_n
    );
}

/// One case of the round-trip study over the regimes of issue 14.
fn study_case(seed: u64) -> (SynthConfig, bool, String) {
    let mut r = Rng::new(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ 0x14);
    let mut u = |a: f64, b: f64| a + (b - a) * r.uniform();
    let m2 = u(1.2, 2.5);
    let k2 = u(500.0, 900.0);
    let a = u(0.0018, 0.003);
    let rig = RigSpec {
        m1_kg: m2 * u(3.0, 5.0),
        m2_kg: m2,
        k1_n_per_m: k2 * u(0.8, 1.25),
        k2_n_per_m: k2,
        d_n_s_per_m: u(0.002, 0.006) * (k2 * m2).sqrt(),
        drive_amplitude_nominal_m: a,
        drive_amplitude_true_m: a * u(0.99, 1.01),
    };
    let eta = u(0.56, 0.66);
    let f_hz = eta * rig.omega_ref() / (2.0 * std::f64::consts::PI);
    let fs = rig.drive_amplitude_true_m * k2;
    let ss = (k2 * m2).sqrt();
    // Friction levels around the stick threshold (short sticks at
    // reversal, never-sticking and clearly sticking logs).
    let rho_d = u(0.35, 0.75);
    let family = seed % 4;
    let (rs, rd, slope, vs, name) = match family {
        0 => (rho_d * fs, rho_d * fs, 0.0, None, "coulomb"),
        1 => {
            let k = u(1.1, 1.35);
            (k * rho_d * fs, rho_d * fs, 0.0, None, "static-dynamic")
        }
        2 => {
            let d = -u(0.02, 0.1) * ss;
            (rho_d * fs, rho_d * fs, d, None, "decreasing")
        }
        _ => {
            let k = u(1.2, 1.6);
            (
                k * rho_d * fs,
                rho_d * fs,
                u(0.0, 0.03) * ss,
                Some(u(0.004, 0.012)),
                "stribeck",
            )
        }
    };
    let v_noise = u(4e-4, 2e-3);
    let accel = r.uniform() < 0.3;
    let cfg = SynthConfig {
        normal_force_n: 2.0,
        ..config(
            rig,
            FrictionSpec {
                rs_n: rs,
                rd_n: rd,
                slope_n_s_per_m: slope,
                stribeck_velocity_m_per_s: vs,
                law: None,
            },
            f_hz,
            sensors(seed, v_noise, accel),
            seed,
        )
    };
    let label = format!(
        "seed {seed}: {name} Rs {rs:.3} Rd {rd:.3} D* {:+.3} vs {vs:?} (ρd {rho_d:.2}), v noise {:.1} mm/s, accel {accel}",
        slope / ss,
        v_noise * 1e3
    );
    (cfg, name != "stribeck", label)
}

/// Tallies of the study.
#[derive(Debug, Default)]
struct Tally {
    cases: usize,
    /// Rs (through the bounds where only bounded), Rd, D*: [held, of].
    cover: [[usize; 2]; 3],
    /// never_sticks claimed for a log sticking > 2 % of the time.
    misclaims: usize,
    /// Misses by more than two half-widths, and how many of them were
    /// flagged inadequate.
    big_misses: [usize; 2],
    /// In-family logs and how many were called adequate.
    in_family: [usize; 2],
    /// Logs (all symmetric, rigid pads) fitted with a real-pad extension
    /// (issue 34: a split threshold or a contact spring).
    extended: usize,
    report: Vec<String>,
}

/// The fit of the log at `path` as `stickslip fit --json` reports it: by
/// the library, or by the binary `STUDY_BIN` when set (the same study run
/// against an earlier build: the before/after comparison).
fn fit_json(path: &Path) -> Result<serde_json::Value, String> {
    match std::env::var_os("STUDY_BIN") {
        Some(bin) => {
            let out = std::process::Command::new(bin)
                .arg("fit")
                .arg(path)
                .arg("--json")
                .output()
                .map_err(|e| e.to_string())?;
            if !out.status.success() {
                return Err(String::from_utf8_lossy(&out.stderr).trim().to_string());
            }
            let v: serde_json::Value =
                serde_json::from_slice(&out.stdout).map_err(|e| e.to_string())?;
            Ok(v["fits"][0].clone())
        }
        None => {
            let run = ingest::read(path, &IngestOptions::default()).map_err(|e| e.to_string())?;
            let f =
                identify::fit_log(&run, &IdentifyOptions::default()).map_err(|e| e.to_string())?;
            Ok(f.to_json(path))
        }
    }
}

/// `[low, high]` of a JSON interval.
fn json_interval(v: &serde_json::Value) -> Option<Interval> {
    Some((v.get(0)?.as_f64()?, v.get(1)?.as_f64()?))
}

fn study(first: u64, n: u64) -> Tally {
    let dir = tempfile::tempdir().unwrap();
    let mut t = Tally::default();
    for seed in first..first + n {
        let (cfg, in_family, label) = study_case(seed);
        let log = synth::generate(&cfg).expect("generate");
        let sf = log.truth["stick_fraction"].as_f64().unwrap();
        let path = dir.path().join(format!("s{seed}.mcap"));
        synth::write(&log, &path).expect("write");
        let clock = std::time::Instant::now();
        let fitted = fit_json(&path);
        let seconds = clock.elapsed().as_secs_f64();
        let f = match fitted {
            Ok(f) => f,
            Err(e) => {
                t.report.push(format!("{label}: error {e}"));
                continue;
            }
        };
        t.cases += 1;
        let fr = &cfg.friction;
        let ss = (cfg.rig.k2_n_per_m * cfg.rig.m2_kg).sqrt();
        let never_sticks = f["never_sticks"].as_bool() == Some(true);
        let stuck = f["stuck"].as_bool() == Some(true);
        // Builds before the adequacy check flag nothing.
        let adequate = f["adequate"].as_bool() != Some(false);
        let mut line = format!(
            "{label} sf {sf:.4} → {} ns {never_sticks} stuck {stuck} adequate {} ΔBIC {} ({seconds:.2} s)",
            f["law"].as_str().unwrap_or("?"),
            f["adequate"],
            f["law_evidence"]["delta_bic"]
        );
        if f["direction_dependent"].as_bool() == Some(true)
            || f["contact_stiffness"].as_f64().is_some()
        {
            t.extended += 1;
            line.push_str(" REAL-PAD EXTENSION");
        }
        if never_sticks && sf > 0.02 {
            t.misclaims += 1;
            line.push_str(" NEVER-STICKS MISCLAIM");
        }
        let mut any_big = false;
        let checks: [(Option<Interval>, f64, Option<f64>); 3] = if stuck {
            [
                (
                    f["r_s_lower_bound_n"].as_f64().map(|b| (b, f64::INFINITY)),
                    fr.rs_n,
                    None,
                ),
                (None, f64::NAN, None),
                (None, f64::NAN, None),
            ]
        } else {
            [
                (
                    json_interval(&f["r_s_interval_n"]),
                    fr.rs_n,
                    f["r_s_n"].as_f64(),
                ),
                (
                    json_interval(&f["r_d_interval_n"]),
                    fr.rd_n,
                    f["r_d_n"].as_f64(),
                ),
                (
                    json_interval(&f["slope_interval"]),
                    fr.slope_n_s_per_m / ss,
                    f["slope"].as_f64(),
                ),
            ]
        };
        // Stribeck pads: Rs and Rd are the law's; D* is not comparable
        // with a simple family's slope (skipped there).
        for (k, (iv, x, est)) in checks.iter().enumerate() {
            if !x.is_finite() || (k == 2 && fr.stribeck_velocity_m_per_s.is_some()) {
                continue;
            }
            t.cover[k][1] += 1;
            let held = inside(*iv, *x);
            t.cover[k][0] += usize::from(held);
            if !held {
                line.push_str(&format!(" miss[{k}] {iv:?} vs {x:.4}"));
                match (iv, est) {
                    (Some((lo, hi)), Some(e)) if lo <= hi => {
                        let hw = 0.5 * (hi - lo);
                        if (e - x).abs() > 2.0 * hw {
                            any_big = true;
                        }
                    }
                    _ => any_big = true,
                }
            }
        }
        if any_big {
            t.big_misses[0] += 1;
            t.big_misses[1] += usize::from(!adequate);
        }
        if in_family {
            t.in_family[0] += 1;
            t.in_family[1] += usize::from(adequate);
        }
        t.report.push(line);
    }
    t
}

fn print(t: &Tally) {
    for r in &t.report {
        eprintln!("{r}");
    }
    eprintln!(
        "cases {}: coverage Rs {}/{}, Rd {}/{}, D* {}/{}; never-sticks misclaims {}; big misses {} (flagged {}); in-family adequate {}/{}; real-pad extensions chosen {}",
        t.cases,
        t.cover[0][0],
        t.cover[0][1],
        t.cover[1][0],
        t.cover[1][1],
        t.cover[2][0],
        t.cover[2][1],
        t.misclaims,
        t.big_misses[0],
        t.big_misses[1],
        t.in_family[1],
        t.in_family[0],
        t.extended
    );
}

/// CI: 8 cases of the study (two per family). No never-sticks misclaim;
/// every miss by more than two half-widths flagged inadequate.
#[test]
fn issue14_round_trips_small() {
    let t = study(1, 8);
    print(&t);
    assert_eq!(t.cases, 8, "{:#?}", t.report);
    assert_eq!(t.misclaims, 0, "{:#?}", t.report);
    assert_eq!(t.big_misses[0], t.big_misses[1], "{:#?}", t.report);
    assert_eq!(t.extended, 0, "{:#?}", t.report);
}

/// The large study (`just studies`; `STUDY_N` cases from `STUDY_FIRST`,
/// default 60 from 1).
#[test]
#[ignore = "study: issue-14 regimes (60 logs, about 2.5 min in release)"]
fn issue14_round_trip_study() {
    let n = env_or("STUDY_N", 60);
    let first = env_or("STUDY_FIRST", 1);
    let t = study(first, n);
    print(&t);
    if std::env::var_os("STUDY_BIN").is_some() {
        return; // an earlier build: numbers only
    }
    // The issue's targets: each interval holds the truth in ≥ 90 % of the
    // cases; no never-sticks misclaim; every big miss flagged; ≥ 90 % of
    // the in-family logs adequate.
    let at_least_90 = |[held, of]: [usize; 2]| 10 * held >= 9 * of;
    for (k, name) in ["Rs", "Rd", "D*"].iter().enumerate() {
        assert!(at_least_90(t.cover[k]), "{name} {:?}", t.cover[k]);
    }
    assert_eq!(t.misclaims, 0);
    assert_eq!(t.big_misses[0], t.big_misses[1]);
    assert!(at_least_90(t.in_family), "{:?}", t.in_family);
    // Issue 34's parsimony: no real-pad extension on more than 5 % of
    // these symmetric, rigid pads.
    assert!(20 * t.extended <= t.cases, "{} extended", t.extended);
}

/// Repeatability of the short-stick case under new sensor draws
/// (`STUDY_N` draws, default 20): the spread of ρs, ρd against the
/// reported half-widths, and how often the ρ and force intervals hold the
/// truth.
#[test]
#[ignore = "study: 20 fits of the short-stick case (about 1 min in release)"]
fn short_stick_repeatability() {
    let n: u64 = env_or("STUDY_N", 20);
    let dir = tempfile::tempdir().unwrap();
    let friction = SHORT_STICK_PAD;
    let (mut rho, mut hw, mut held) = ([vec![], vec![]], [vec![], vec![]], [0usize; 4]);
    let rig = other_rig();
    let fs = rig.drive_amplitude_true_m * rig.k2_n_per_m;
    let truth = [friction.rs_n / fs, friction.rd_n / fs];
    for seed in 100..100 + n {
        let cfg = config(rig, friction, 2.4, sensors(seed, 1e-3, false), seed);
        let (f, _) = fit(&cfg, dir.path(), None, false);
        let ivs = [f.rho_s_interval, f.rho_d_interval];
        let fivs = [
            (f.rs_interval_n, friction.rs_n),
            (f.rd_interval_n, friction.rd_n),
        ];
        for k in 0..2 {
            let (lo, hi) = ivs[k].unwrap_or((f64::NAN, f64::NAN));
            rho[k].push(0.5 * (lo + hi) / truth[k] - 1.0);
            hw[k].push(0.5 * (hi - lo) / truth[k]);
            held[k] += usize::from(inside(ivs[k], truth[k]));
            held[2 + k] += usize::from(inside(fivs[k].0, fivs[k].1));
        }
    }
    for (k, name) in ["ρs", "ρd"].iter().enumerate() {
        let m = rho[k].iter().sum::<f64>() / n as f64;
        let sd = (rho[k].iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n as f64 - 1.0)).sqrt();
        let h = hw[k].iter().sum::<f64>() / n as f64;
        eprintln!(
            "{name}: mean error {:+.4} %, sd {:.4} %, mean half-width {:.4} % (≈ 1.96 sd would be {:.4} %); ρ interval held {}/{n}, force interval held {}/{n}",
            100.0 * m,
            100.0 * sd,
            100.0 * h,
            196.0 * sd,
            held[k],
            held[2 + k]
        );
    }
}

/// The sharp-Stribeck rig (5 kg, 1 kg, 400 N/m, 2 Hz, Rs 0.5 N, Rd 0.38 N,
/// seed 1) as `synth` arguments; a test adds the law.
const SHARP_RIG: [&str; 16] = [
    "--seed",
    "1",
    "--m1-kg",
    "5",
    "--m2-kg",
    "1",
    "--k1-n-per-m",
    "400",
    "--k2-n-per-m",
    "400",
    "--frequency-hz",
    "2",
    "--rs-n",
    "0.5",
    "--rd-n",
    "0.38",
];

/// A sharp Stribeck pad (the friction falls from Rs 0.5 N to Rd 0.38 N
/// within about 1 mm/s) on another rig (5 kg, 1 kg, 400 N/m, 2 Hz): the
/// static/dynamic law explains it to the noise but read Rs 12 % high with
/// intervals that missed (0.562 N [0.556, 0.569]). x2's residuals follow
/// the velocity and drive phase (z 6–10), which makes the fit try the
/// Stribeck family; the BIC prefers it by about 150.
#[test]
fn a_sharp_stribeck_pad_is_not_read_as_static_dynamic() {
    let dir = tempfile::tempdir().expect("tempdir");
    let log = dir.path().join("sharp.mcap");
    common::synth_log(
        &log,
        None,
        &[
            &SHARP_RIG[..],
            &["--law", "stribeck", "--stribeck-velocity-m-per-s", "0.001"],
        ]
        .concat(),
    );
    let j = json_of(bin().arg("fit").arg(&log).arg("--json"));
    let fit = &j["fits"][0];
    assert_eq!(fit["law"], "stribeck", "{}", fit["warnings"]);
    assert_eq!(fit["adequate"], true);
    let (rs, rd) = (f(&fit["r_s_n"]), f(&fit["r_d_n"]));
    let iv = &fit["r_s_interval_n"];
    assert!(f(&iv[0]) <= 0.5 && 0.5 <= f(&iv[1]), "Rs {rs} {iv}");
    assert!((rs / 0.5 - 1.0).abs() < 0.03, "Rs {rs}");
    assert!((rd / 0.38 - 1.0).abs() < 0.03, "Rd {rd}");
    // The law used is reported in `stribeck` with its v_s (it was null when
    // the Stribeck law came from the output-error refinement); the drop is
    // resolved (v_s well above the 0.06 mm/s gained in one sample).
    let vs = f(&fit["stribeck"]["v_s_m_per_s"]);
    assert_eq!(fit["stribeck"]["r_s_n"], fit["r_s_n"]);
    assert!((vs / 0.001 - 1.0).abs() < 0.3, "v_s {vs}");
}

/// A Stribeck drop too fast for the log (v_s 0.5 mm/s: the drop is over
/// within about 4 ms of breakaway, while x2 moves about 1 µm against 3 µm of
/// noise) on the same rig: the static/dynamic law explains the log to the
/// noise with its threshold 9 % high (0.5455 N [0.5392, 0.5519], missing
/// the true 0.5 N by seven half-widths, before session 23). The profile in
/// v_s (Stribeck refits with v_s held, issue 30 item 5) finds that a drop
/// of 0.67 mm/s explains it at least as well with Rs 0.493 N: the interval
/// is widened down to hold it, with a `threshold_not_identified` warning.
/// The static/dynamic truth of the same rig is covered too, its interval
/// widened the same way (the log cannot tell the two apart); a resolved
/// drop (v_s 1 mm/s, the test above) is fitted as Stribeck, unwidened.
#[test]
fn a_drop_the_log_cannot_resolve_widens_the_threshold() {
    let dir = tempfile::tempdir().expect("tempdir");
    for (name, law) in [
        (
            "drop.mcap",
            &["--law", "stribeck", "--stribeck-velocity-m-per-s", "0.0005"][..],
        ),
        ("step.mcap", &["--law", "static-dynamic"][..]),
    ] {
        let log = dir.path().join(name);
        common::synth_log(&log, None, &[&SHARP_RIG[..], law].concat());
        let j = json_of(bin().arg("fit").arg(&log).arg("--json"));
        let fit = &j["fits"][0];
        assert_eq!(fit["law"], "static-dynamic", "{name}: {}", fit["warnings"]);
        assert_eq!(fit["adequate"], true, "{name}");
        let rs = f(&fit["r_s_n"]);
        let iv = &fit["r_s_interval_n"];
        assert!(f(&iv[0]) <= 0.5 && 0.5 <= f(&iv[1]), "{name}: Rs {rs} {iv}");
        assert!(
            common::codes_of(fit).contains(&"threshold_not_identified"),
            "{name}: {}",
            fit["warnings"]
        );
        let dp = &fit["output_error"]["drop_profile"];
        let (low, vs) = (f(&dp["r_s_n"]), f(&dp["v_s_m_per_s"]));
        assert!(
            low < rs && vs > f(&dp["resolution_m_per_s"]),
            "{name}: {dp}"
        );
        assert!(f(&dp["delta_bic"]) < 10.0, "{name}: {dp}");
    }
}

/// Sensors of log035 of the adequacy study (`scripts/adequacy_study.py`,
/// seed 2026).
const LOG035_SENSORS: &str = r#"{"x0": {"rate_hz": 2000.0, "noise": 4.6344569139542725e-06, "quant": 1e-06, "gain": 0.9915009879350125, "offset": -0.0002758866600327096, "lowpass_hz": null, "buffer_s": 0.05, "start_offset_ns": null, "jitter_ns": 0, "p_lost_buffer": 0.01, "p_dropout": 0.0002, "dropout_burst_max": 4, "noise_correlation_s": 0.0}, "x1": {"rate_hz": 2000.0, "noise": 1.3211884040952739e-06, "quant": 2.5e-06, "gain": 1.0088738747280388, "offset": -0.0015811718113713763, "lowpass_hz": 464.87158486949636, "buffer_s": 0.1, "start_offset_ns": null, "jitter_ns": 0, "p_lost_buffer": 0.01, "p_dropout": 0.0002, "dropout_burst_max": 4, "noise_correlation_s": 0.0}, "x2": {"rate_hz": 2000.0, "noise": 7.65873370268075e-06, "quant": 2.5e-06, "gain": 1.008504252696497, "offset": -0.0006003695612463269, "lowpass_hz": null, "buffer_s": 0.1, "start_offset_ns": null, "jitter_ns": 10000, "p_lost_buffer": 0.0, "p_dropout": 0.0002, "dropout_burst_max": 4, "noise_correlation_s": 0.001120088713682467}, "v2": {"rate_hz": 500.0, "noise": 0.0005806764151524515, "quant": 1e-05, "gain": 0.9977574256657924, "offset": -4.07865657244701e-05, "lowpass_hz": 155.8681394119809, "buffer_s": 0.05, "start_offset_ns": null, "jitter_ns": 0, "p_lost_buffer": 0.0, "p_dropout": 0.0, "dropout_burst_max": 4, "noise_correlation_s": 0.0}, "a2": null, "normal_force": {"rate_hz": 10.0, "noise": 0.0, "quant": 0.01, "gain": 1.004938218969958, "offset": 0.006984253039124148, "lowpass_hz": null, "buffer_s": 0.5, "start_offset_ns": null, "jitter_ns": 2000, "p_lost_buffer": 0.01, "p_dropout": 0.0, "dropout_burst_max": 4, "noise_correlation_s": 0.0}}"#;

/// A Coulomb pad whose log hardly tells Coulomb from static/dynamic
/// (ΔBIC 6.7) while the two put Rs 4 % apart: the Coulomb interval
/// [0.4760, 0.4873] N alone would claim a precision the log does not
/// have. The interval is widened to hold the static/dynamic Rs
/// (0.4953 N), with a `threshold_not_identified` warning (issue 30,
/// item 5).
#[test]
fn an_unidentified_threshold_widens_the_interval_and_says_so() {
    let dir = tempfile::tempdir().expect("tempdir");
    let log = dir.path().join("l035.mcap");
    common::synth_log(
        &log,
        Some(LOG035_SENSORS),
        &[
            &["--seed", "135", "--frequency-hz", "2.0134485103396687"][..],
            &common::STUDY_RIG,
            &[
                "--rs-n",
                "0.4857591193985702",
                "--rd-n",
                "0.4857591193985702",
                "--law",
                "coulomb",
            ],
        ]
        .concat(),
    );
    let j = json_of(bin().arg("fit").arg(&log).arg("--json"));
    let fit = &j["fits"][0];
    let codes = common::codes_of(fit);
    assert!(codes.contains(&"threshold_not_identified"), "{codes:?}");
    assert_eq!(fit["law"], "coulomb");
    let iv = &fit["r_s_interval_n"];
    let truth = 0.485_759_119_398_570_2;
    assert!(f(&iv[0]) <= truth && truth <= f(&iv[1]), "{iv}");
    // Widened up to the static/dynamic Rs (0.4953 N), past the Coulomb
    // interval's own upper end (0.4873 N).
    assert!(f(&iv[1]) > 0.49, "{iv}");
}
