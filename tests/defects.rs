//! Saturation and physics defects (issue 30, items 3 and 6), on two rigs
//! other than the bundled one, with the virtual rig's defects:
//!
//! * a clipped position sensor (x1 flat-topped at 85 % of its swing): the
//!   `clipped` warning names the channel and the fraction, and either Rs,
//!   Rd are within 3 % with covering 95 % intervals or the log is marked
//!   `adequate: false`;
//! * friction that changes along the stroke, and a hardening coupling
//!   spring: `adequate: false` (the numbers are printed);
//! * no `clipped` warning on any bundled log, on clean synthetic logs with
//!   quantisation, nor on noise-free quantised logs whose x2 stands still
//!   at its extremes.
//!
//! The small cases run in CI; the seed studies (`*_study`, 20 seeds per
//! rig and defect) are `#[ignore]`d: `cargo test --release --test defects
//! -- --ignored --nocapture` (results in docs/measurements.md).

mod common;

use common::{bin, data, env_or, json_of};
use std::path::Path;
use stickslip::identify::{self, IdentifyOptions, Interval, LogFit};
use stickslip::ingest::{self, IngestOptions};
use stickslip::synth::{self, FrictionSpec, RigSpec, Sensors, SynthConfig, TestSpec};
use stickslip::warning::Warning;

/// Rig A: M1 5 kg, M2 1 kg, K1 = K2 = 400 N/m, drive 2 mm at 2.3 Hz
/// (η 0.72); Rs 0.44 N, Rd 0.36 N stick about 10 % of the time.
/// Rig B: M1 12 kg, M2 2.5 kg, K1 = K2 = 1000 N/m, drive 2 mm at 2.0 Hz
/// (η 0.63); Rs 1.1 N, Rd 0.9 N stick about 13 % of the time.
#[derive(Debug, Clone, Copy)]
struct Case {
    name: &'static str,
    rig: RigSpec,
    friction: FrictionSpec,
    frequency_hz: f64,
}

fn rig(m1: f64, m2: f64, k: f64) -> RigSpec {
    RigSpec {
        m1_kg: m1,
        m2_kg: m2,
        k1_n_per_m: k,
        k2_n_per_m: k,
        d_n_s_per_m: 0.003 * (k * m2).sqrt(),
        drive_amplitude_nominal_m: 0.002,
        drive_amplitude_true_m: 0.002,
    }
}

fn pad(rs_n: f64, rd_n: f64) -> FrictionSpec {
    FrictionSpec {
        rs_n,
        rd_n,
        slope_n_s_per_m: 0.0,
        stribeck_velocity_m_per_s: None,
        law: None,
    }
}

fn cases() -> [Case; 2] {
    [
        Case {
            name: "A (5/1 kg, 400 N/m, 2.3 Hz)",
            rig: rig(5.0, 1.0, 400.0),
            friction: pad(0.44, 0.36),
            frequency_hz: 2.3,
        },
        Case {
            name: "B (12/2.5 kg, 1000 N/m, 2.0 Hz)",
            rig: rig(12.0, 2.5, 1000.0),
            friction: pad(1.1, 0.9),
            frequency_hz: 2.0,
        },
    ]
}

/// The seeds of a study: `STUDY_FROM` (default 1) to `STUDY_N` (default
/// `n`), so that one seed can be looked at again.
fn study_seeds(n: u64) -> std::ops::RangeInclusive<u64> {
    env_or("STUDY_FROM", 1u64)..=env_or("STUDY_N", n)
}

/// The study's cases: both rigs, or the one whose name starts with
/// `STUDY_CASE` ("A" or "B").
fn study_cases() -> Vec<Case> {
    let only = std::env::var("STUDY_CASE").unwrap_or_default();
    cases()
        .into_iter()
        .filter(|c| c.name.starts_with(only.as_str()))
        .collect()
}

/// Where a study writes its logs: `STUDY_DIR` when set (kept, to look at
/// a log again), else a temporary directory.
fn study_dir() -> (Option<tempfile::TempDir>, std::path::PathBuf) {
    match std::env::var_os("STUDY_DIR").filter(|d| !d.is_empty()) {
        Some(d) => (None, d.into()),
        None => {
            let t = tempfile::tempdir().unwrap();
            let p = t.path().to_path_buf();
            (Some(t), p)
        }
    }
}

fn config(case: &Case, seed: u64) -> SynthConfig {
    SynthConfig {
        rig: case.rig,
        friction: case.friction,
        normal_force_n: 2.0,
        test: TestSpec::Characteristic {
            frequency_hz: case.frequency_hz,
            warmup_s: 20.0,
            duration_s: 20.0,
        },
        sensors: Sensors::typical(seed),
        ..SynthConfig::paper(seed)
    }
}

/// Writes, ingests and fits `cfg` in `dir`; returns the fit and the truth.
fn fit(cfg: &SynthConfig, dir: &Path) -> (LogFit, serde_json::Value) {
    let log = synth::generate(cfg).expect("generate");
    let p = dir.join(format!("log{}.mcap", cfg.seed));
    synth::write(&log, &p).expect("write");
    let run = ingest::read(&p, &IngestOptions::default()).expect("ingest");
    let f = identify::fit_log(&run, &IdentifyOptions::default()).expect("fit");
    (f, log.truth)
}

fn inside(iv: Option<Interval>, x: f64) -> bool {
    matches!(iv, Some((lo, hi)) if lo <= x && x <= hi)
}

/// The clipped fraction of channel `ch` in a fit's warnings (its
/// `clipped` warning's number).
fn clipped_fraction(warnings: &[Warning], ch: &str) -> Option<f64> {
    warnings.iter().find_map(|w| match w {
        Warning::Clipped {
            channel, fraction, ..
        } if *channel == ch => Some(*fraction),
        _ => None,
    })
}

/// The clipped-warning of channel `ch` in a JSON `warnings` list, and the
/// percentage its message states.
fn clipped_warning(warnings: &[String], ch: &str) -> Option<(String, f64)> {
    let w = warnings
        .iter()
        .find(|w| w.starts_with(&format!("clipped: {ch} ")))?;
    let pct = w
        .split(" in ")
        .nth(1)?
        .split(" %")
        .next()?
        .trim()
        .parse()
        .ok()?;
    Some((w.clone(), pct))
}

/// One clipped log: (warning found with a fraction within 1 point of the
/// truth, Rs and Rd within 3 % with covering intervals, adequate), the
/// numbers printed.
fn clipped_case(case: &Case, seed: u64, dir: &Path) -> (bool, bool, bool) {
    let mut cfg = config(case, seed);
    cfg.sensors.x1.clip_high_fraction = Some(0.85);
    let (f, truth) = fit(&cfg, dir);
    let true_frac = truth["sensors"]["/mass1/position"]["clipped_fraction"]
        .as_f64()
        .expect("clipped fraction in the truth");
    let warned = clipped_fraction(&f.warnings, "x1");
    let warned_ok = matches!(warned, Some(frac) if (frac - true_frac).abs() < 0.01);
    let (rs, rd) = (case.friction.rs_n, case.friction.rd_n);
    let err = |x: Option<f64>, t: f64| x.map_or(f64::NAN, |x| x / t - 1.0);
    let law = f.law();
    let (ers, erd) = (err(f.rs_n(), rs), err(law.map(|l| l.rd_n), rd));
    let covered = inside(f.rs_interval_n, rs) && inside(f.rd_interval_n, rd);
    let good = ers.abs() < 0.03 && erd.abs() < 0.03 && covered;
    let noise = f
        .adequacy
        .as_ref()
        .map_or((f64::NAN, f64::NAN), |a| a.noise_ratio);
    eprintln!(
        "clip {} seed {seed}: true {:.1} %, warned {:?}; law {:?} Rs {:+.2} % Rd {:+.2} % covered {covered}; adequate {} (x1 {:.2}, x2 {:.2} noise)",
        case.name,
        100.0 * true_frac,
        warned.map(|f| 100.0 * f),
        f.kind(),
        100.0 * ers,
        100.0 * erd,
        f.adequate(),
        noise.0,
        noise.1
    );
    (warned_ok, good, f.adequate())
}

/// A physics-defect log: returns (adequate, the line printed).
fn defect_case(case: &Case, seed: u64, dir: &Path, set: impl Fn(&mut SynthConfig)) -> bool {
    let mut cfg = config(case, seed);
    set(&mut cfg);
    let (f, truth) = fit(&cfg, dir);
    let (rs, rd) = (case.friction.rs_n, case.friction.rd_n);
    let err = |x: Option<f64>, t: f64| x.map_or(f64::NAN, |x| 100.0 * (x / t - 1.0));
    let a = f.adequacy.as_ref();
    let largest = a
        .and_then(|a| {
            a.structure
                .iter()
                .max_by(|x, y| x.effect.total_cmp(&y.effect))
                .map(|s| {
                    format!(
                        "{} vs {} effect {:.2} z {:.1}",
                        s.channel, s.against, s.effect, s.z
                    )
                })
        })
        .unwrap_or_default();
    let spring = f.spring_screen.map_or("no spring screen".into(), |s| {
        format!(
            "spring {:+.2} % [{:+.2}, {:+.2}] z {:.1}",
            100.0 * s.stiffness_change,
            100.0 * s.interval.0,
            100.0 * s.interval.1,
            s.z
        )
    });
    eprintln!(
        "{} seed {seed}: stick {:.3}, {}; law {:?} Rs {:+.2} % Rd {:+.2} % never_sticks {}; adequate {} (noise x1 {:.2}, x2 {:.2}; {largest}; {spring})",
        case.name,
        truth["stick_fraction"].as_f64().unwrap_or(f64::NAN),
        truth["defects"],
        f.kind(),
        err(f.rs_n(), rs),
        err(f.law().map(|l| l.rd_n), rd),
        f.never_sticks(),
        f.adequate(),
        a.map_or(f64::NAN, |a| a.noise_ratio.0),
        a.map_or(f64::NAN, |a| a.noise_ratio.1),
    );
    f.adequate()
}

/// Friction levels × (1 + G·x2) with G = 50/m (about ±10 % over the
/// stroke of these rigs).
fn stroke(c: &mut SynthConfig) {
    c.defects.stroke_friction_gradient_per_m = 50.0;
}

/// Coupling spring K2·δ·(1 + β·δ²), β = 5000/m² (about +10 % stiffness
/// at the largest stretch of these rigs).
fn hardening(c: &mut SynthConfig) {
    c.defects.hardening_per_m2 = 5000.0;
}

/// CI: one clipped log per rig is warned about with the right fraction,
/// and is either measured within 3 % with covering intervals or flagged.
#[test]
fn clipped_x1_is_warned_and_left_out() {
    let dir = tempfile::tempdir().unwrap();
    for case in cases() {
        let (warned, good, adequate) = clipped_case(&case, 1, dir.path());
        assert!(
            warned,
            "{}: no clipped warning with the fraction",
            case.name
        );
        assert!(good || !adequate, "{}: wrong and adequate", case.name);
    }
}

/// CI: clipped samples are left out before the channel delays are
/// estimated. Rig B, seed 9, x1 clipped at 85 % (the truth has no delay):
/// with the rail values in M1's equation the estimator applied delays of
/// 4–8 ms to x0, x2, v2 and a2 and the fit lost Rs (session 26); now no
/// delay is applied and Rs is measured within 3 % with a covering interval.
#[test]
fn a_clipped_channel_does_not_make_up_delays() {
    let dir = tempfile::tempdir().unwrap();
    let case = cases()[1];
    let mut cfg = config(&case, 9);
    cfg.sensors.x1.clip_high_fraction = Some(0.85);
    let (f, _) = fit(&cfg, dir.path());
    let applied: Vec<_> = f
        .channel_delays
        .channels
        .iter()
        .filter(|c| c.applied)
        .map(|c| (c.quantity, c.shift_s))
        .collect();
    assert!(applied.is_empty(), "delays applied: {applied:?}");
    let rs = f.rs_n().expect("Rs measured");
    assert!((rs / case.friction.rs_n - 1.0).abs() < 0.03, "Rs {rs}");
    assert!(
        inside(f.rs_interval_n, case.friction.rs_n),
        "{:?}",
        f.rs_interval_n
    );
}

/// The CLI: `synth --clip x1=0.85` writes the truth; `fit --json` carries
/// the warning.
#[test]
fn cli_clip_flag_and_fit_warning() {
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("clip.mcap");
    let s = json_of(bin().args([
        "synth",
        "--out",
        log.to_str().unwrap(),
        "--clip",
        "x1=0.85",
        "--duration-s",
        "10",
        "--warmup-s",
        "10",
        "--json",
    ]));
    assert!(s["out"].is_string());
    let truth: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("truth.json")).unwrap())
            .unwrap();
    let t = &truth["files"]["clip.mcap"]["sensors"]["/mass1/position"];
    let frac = t["clipped_fraction"].as_f64().expect("fraction");
    assert!(frac > 0.05 && frac < 0.3, "{frac}");
    let fit = json_of(bin().args(["fit", log.to_str().unwrap(), "--json"]));
    let w: Vec<String> = fit["fits"][0]["warnings"]
        .as_array()
        .expect("warnings")
        .iter()
        .map(|w| w.as_str().unwrap_or_default().to_string())
        .collect();
    let codes = fit["fits"][0]["warning_codes"]
        .as_array()
        .expect("warning_codes");
    assert_eq!(codes.len(), w.len());
    let (text, pct) = clipped_warning(&w, "x1").expect("clipped warning");
    let i = w.iter().position(|x| *x == text).expect("found");
    assert_eq!(codes[i], "clipped");
    assert!((pct / 100.0 - frac).abs() < 0.01, "{pct} % vs {frac}");
    // A bad --clip is one clear error.
    let out = bin()
        .args([
            "synth",
            "--out",
            dir.path().join("bad.mcap").to_str().unwrap(),
            "--clip",
            "x7=0.5",
        ])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("error:") && err.contains("unknown channel"),
        "{err}"
    );
}

/// No bundled log has a clipped channel.
#[test]
fn no_bundled_log_is_clipped() {
    let mut n = 0;
    for e in std::fs::read_dir(data("")).unwrap() {
        let p = e.unwrap().path();
        let ext = p.extension().and_then(|e| e.to_str()).unwrap_or("");
        if !matches!(ext, "mcap" | "csv" | "parquet") {
            continue;
        }
        let run = ingest::read(&p, &IngestOptions::default()).expect("ingest");
        let w: Vec<&Warning> = run
            .warnings
            .iter()
            .filter(|w| w.code() == "clipped")
            .collect();
        assert!(w.is_empty(), "{}: {w:?}", p.display());
        n += 1;
    }
    assert!(n >= 13, "{n} logs");
}

/// No clipped warning on clean synthetic logs with quantisation (typical
/// sensors), nor on noise-free quantised ones whose x2 stands still at its
/// extremes (flat but not saturated).
#[test]
fn clean_and_quantised_logs_are_not_clipped() {
    let dir = tempfile::tempdir().unwrap();
    let seeds = env_or("STUDY_N", 3u64);
    for case in cases() {
        for seed in 1..=seeds {
            for noise_free in [false, true] {
                let mut cfg = config(&case, seed);
                if noise_free {
                    let mut s = Sensors::ideal();
                    for (m, q) in [
                        (&mut s.x0, 1e-6),
                        (&mut s.x1, 1e-6),
                        (&mut s.x2, 1e-6),
                        (&mut s.v2, 1e-5),
                    ] {
                        m.quant = q;
                    }
                    cfg.sensors = s;
                }
                let log = synth::generate(&cfg).expect("generate");
                assert!(log.truth["stick_fraction"].as_f64().unwrap() > 0.02);
                let p = dir.path().join(format!("c{seed}{noise_free}.mcap"));
                synth::write(&log, &p).expect("write");
                let run = ingest::read(&p, &IngestOptions::default()).expect("ingest");
                let w: Vec<&Warning> = run
                    .warnings
                    .iter()
                    .filter(|w| w.code() == "clipped")
                    .collect();
                assert!(
                    w.is_empty(),
                    "{} seed {seed} noise-free {noise_free}: {w:?}",
                    case.name
                );
            }
        }
    }
}

/// CI: friction that changes along the stroke is flagged on both rigs.
#[test]
fn stroke_dependent_friction_is_flagged() {
    let dir = tempfile::tempdir().unwrap();
    for case in cases() {
        assert!(
            !defect_case(&case, 1, dir.path(), stroke),
            "{}: stroke-dependent friction called adequate",
            case.name
        );
    }
}

/// CI: a hardening coupling spring on rig A (5.3 % stiffer at its largest
/// stretch) is flagged by the spring screen (M1's friction-free equation):
/// `nonlinear_spring`, with an interval that holds the truth. Measured
/// (session 26): 20 of 20 seeds, +5.5 … +5.8 % ± 0.9 %.
#[test]
fn hardening_spring_is_flagged_by_the_spring_screen() {
    let dir = tempfile::tempdir().unwrap();
    let case = cases()[0];
    let mut cfg = config(&case, 1);
    hardening(&mut cfg);
    let (f, truth) = fit(&cfg, dir.path());
    let want = truth["defects"]["hardening_stiffness_increase_at_max_stretch"]
        .as_f64()
        .expect("truth");
    let s = f.spring_screen.expect("screened");
    assert!(s.flagged, "{s:?}");
    assert!(!f.adequate());
    assert!(f.warnings.iter().any(|w| w.code() == "nonlinear_spring"));
    assert!(
        s.interval.0 <= want && want <= s.interval.1,
        "{s:?} vs {want}"
    );
}

/// A hardening coupling spring is flagged on both rigs. Rig A: see the
/// test above. Rig B (12/2.5 kg, 4.4 % stiffer at the largest stretch): a
/// Stribeck law with fitted position lags explains the positions to the
/// noise (x1 0.97, x2 1.02) with Rs 8–9 % low, and the spring screen reads
/// +0.4 … +7.7 % ± 2.2 % (z 0.2–3.6, flagged in 0 of 20 seeds): x1's noise
/// (3 µm) through M1·ẍ1, with x2's lag against x1 free, leaves the screen
/// short of z 4 (docs/measurements.md, session 26). Issue 30 stays open
/// for it.
#[test]
#[ignore = "open (issue 30): a 4.4 % hardening spring on rig B is read as an adequate Stribeck law; the spring screen's z stays below 4; see the doc comment"]
fn hardening_spring_is_flagged() {
    let dir = tempfile::tempdir().unwrap();
    for case in cases() {
        assert!(
            !defect_case(&case, 1, dir.path(), hardening),
            "{}: hardening spring called adequate",
            case.name
        );
    }
}

/// Study: 20 seeds per rig of a clipped x1 (85 %): warned with the right
/// fraction in every log; measured (3 %, covering) or flagged in ≥ 90 %.
#[test]
#[ignore]
fn clipping_study() {
    let (_keep, dir) = study_dir();
    let seeds = study_seeds(20);
    let n = seeds.clone().count();
    for case in study_cases() {
        let (mut warned, mut ok, mut good, mut flagged) = (0, 0, 0, 0);
        for seed in seeds.clone() {
            let (w, g, a) = clipped_case(&case, seed, &dir);
            warned += usize::from(w);
            good += usize::from(g);
            flagged += usize::from(!a);
            ok += usize::from(g || (!a && w));
        }
        eprintln!(
            "CLIP {}: warned {warned}/{n}, within 3 % and covered {good}/{n}, flagged {flagged}/{n}, acceptable {ok}/{n}",
            case.name
        );
        assert_eq!(warned, n, "{}", case.name);
        assert!(ok as f64 >= 0.9 * n as f64, "{}", case.name);
    }
}

/// Study: 20 seeds per rig of each physics defect: how many are flagged.
#[test]
#[ignore]
fn physics_defects_study() {
    let (_keep, dir) = study_dir();
    let seeds = study_seeds(20);
    let n = seeds.clone().count();
    let mut summary = Vec::new();
    for (what, set) in [
        ("stroke", stroke as fn(&mut SynthConfig)),
        ("hardening", hardening as fn(&mut SynthConfig)),
    ] {
        // STUDY_DEFECT (stroke or hardening) runs one defect.
        if !what.starts_with(std::env::var("STUDY_DEFECT").unwrap_or_default().as_str()) {
            continue;
        }
        for case in study_cases() {
            let flagged = seeds
                .clone()
                .filter(|&seed| !defect_case(&case, seed, &dir, set))
                .count();
            summary.push(format!("{what} {}: flagged {flagged}/{n}", case.name));
        }
    }
    for s in &summary {
        eprintln!("DEFECT {s}");
    }
}

/// Control for the studies: the same rigs, seeds and sensors without any
/// defect (how often a clean log of these rigs is measured within 3 %
/// with covering intervals, and how often it is called adequate).
#[test]
#[ignore]
fn clean_control_study() {
    let (_keep, dir) = study_dir();
    let seeds = study_seeds(20);
    let n = seeds.clone().count();
    for case in study_cases() {
        let (mut good, mut adequate, mut warned) = (0, 0, 0);
        for seed in seeds.clone() {
            let cfg = config(&case, seed);
            let (f, _) = fit(&cfg, &dir);
            let (rs, rd) = (case.friction.rs_n, case.friction.rd_n);
            let err = |x: Option<f64>, t: f64| x.map_or(f64::NAN, |x| x / t - 1.0);
            let (ers, erd) = (err(f.rs_n(), rs), err(f.law().map(|l| l.rd_n), rd));
            let covered = inside(f.rs_interval_n, rs) && inside(f.rd_interval_n, rd);
            good += usize::from(ers.abs() < 0.03 && erd.abs() < 0.03 && covered);
            adequate += usize::from(f.adequate());
            warned += usize::from(f.warnings.iter().any(|w| w.code() == "clipped"));
            eprintln!(
                "clean {} seed {seed}: law {:?} Rs {:+.2} % Rd {:+.2} % covered {covered}; adequate {}; spring {:?}",
                case.name,
                f.kind(),
                100.0 * ers,
                100.0 * erd,
                f.adequate(),
                f.spring_screen.map(|s| (s.stiffness_change, s.z))
            );
        }
        eprintln!(
            "CLEAN {}: within 3 % and covered {good}/{n}, adequate {adequate}/{n}, clipped warnings {warned}/{n}",
            case.name
        );
        assert_eq!(warned, 0, "{}", case.name);
    }
}
