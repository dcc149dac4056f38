//! Round trips of the identification on synthetic logs with a known law:
//! an independent time-stepping simulation of the rig (semi-implicit Euler
//! at 20 µs with explicit stick/slip switching, not the crate's engine),
//! sampled at 1 kHz with sensor noise, offsets and gain errors of the
//! size the data set README states for rig A, with and without an
//! accelerometer. The tolerances are the (3 % on forces, 0.01 on
//! D*); intervals must hold the truth with at most one miss overall.

use std::collections::BTreeMap;
use std::path::PathBuf;
use stickslip::identify::{self, IdentifyOptions};
use stickslip::ingest::{Channel, LogFormat, Quantity, Resampled, RigMeta, Run, TestKind};
use stickslip::stats::Rng;

struct Law {
    rs: f64,
    rd: f64,
    a: f64,
}

// Rig A of the data set README.
const M1: f64 = 8.35;
const M2: f64 = 2.0875;
const K1: f64 = 670.0;
const K2: f64 = 670.0;
const D: f64 = 0.11211;
const AMP: f64 = 0.0025;
const FREQ: f64 = 1.72;

/// Simulates 20 s of log after 20 s of warm-up from rest; returns the run.
fn synth(law: &Law, accel: bool, seed: u64) -> Run {
    synth_noise(law, accel, seed, 1.0)
}

/// As [`synth`], with the sensor noise scaled by `noise_scale`.
fn synth_noise(law: &Law, accel: bool, seed: u64, noise_scale: f64) -> Run {
    synth_drive(law, accel, seed, noise_scale, 0.0)
}

/// As [`synth_noise`], with a second harmonic of relative size `h2` in the
/// drive (a shaker that does not move sinusoidally).
fn synth_drive(law: &Law, accel: bool, seed: u64, noise_scale: f64, h2: f64) -> Run {
    let dt: f64 = 2e-5;
    let w = 2.0 * std::f64::consts::PI * FREQ;
    let (mut x1, mut v1, mut x2, mut v2) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    let mut stuck = true;
    let warm: f64 = 20.0;
    let dur: f64 = 20.0;
    let every = (1e-3 / dt).round() as usize;
    let steps = ((warm + dur) / dt).round() as usize;
    let mut rec: Vec<[f64; 5]> = Vec::new();
    for k in 0..steps {
        let t = k as f64 * dt;
        let x0 = AMP * ((w * t).cos() + h2 * (2.0 * w * t + 0.3).cos());
        let a1 = (-D * (v1 - v2) - K1 * (x1 - x0) - K2 * (x1 - x2)) / M1;
        let p = -K2 * (x2 - x1) + D * v1; // passive force on M2 with v2 = 0
        let a2 = if stuck {
            if p.abs() > law.rs {
                stuck = false;
                (p - p.signum() * law.rd) / M2
            } else {
                0.0
            }
        } else {
            let g = law.rd + law.a * v2.abs();
            (-D * (v2 - v1) - K2 * (x2 - x1) - v2.signum() * g) / M2
        };
        if k % every == 0 && t >= warm {
            rec.push([x0, x1, x2, v2, a2]);
        }
        v1 += a1 * dt;
        x1 += v1 * dt;
        let v2_new = v2 + a2 * dt;
        if !stuck && v2 != 0.0 && v2_new.signum() != v2.signum() {
            // Velocity reversal: stick if the passive force cannot move it.
            let p = -K2 * (x2 - x1) + D * v1;
            if p.abs() <= law.rs {
                stuck = true;
                v2 = 0.0;
                continue;
            }
        }
        if stuck && a2 == 0.0 {
            v2 = 0.0;
        } else {
            v2 = if v2 == 0.0 && !stuck && v2_new == 0.0 {
                1e-12 * p.signum()
            } else {
                v2_new
            };
            x2 += v2 * dt;
        }
    }
    let mut rng = Rng::new(seed);
    // Sensor model: gain, offset, white noise (README's rig A sizes).
    let gains = [
        1.0 + 0.004 * (2.0 * rng.uniform() - 1.0),
        1.0 + 0.01 * (2.0 * rng.uniform() - 1.0),
        1.0 + 0.01 * (2.0 * rng.uniform() - 1.0),
        1.0 + 0.01 * (2.0 * rng.uniform() - 1.0),
        1.0 + 0.01 * (2.0 * rng.uniform() - 1.0),
    ];
    let offsets = [1e-5, 1.2e-4, -9e-5, 8e-5, 0.02];
    let noise = [2e-6, 4e-6, 3e-6, 5e-4, 0.03];
    let n = rec.len();
    let mut cols: Vec<Vec<f64>> = (0..5).map(|_| Vec::with_capacity(n)).collect();
    for r in &rec {
        for q in 0..5 {
            cols[q].push(gains[q] * r[q] + offsets[q] + noise_scale * noise[q] * rng.normal());
        }
    }
    let t: Vec<f64> = (0..n).map(|i| i as f64 * 1e-3).collect();
    let qs = [
        Quantity::X0,
        Quantity::X1,
        Quantity::X2,
        Quantity::V2,
        Quantity::A2,
    ];
    let channels: Vec<Channel> = qs
        .iter()
        .zip(&cols)
        .filter(|(q, _)| accel || **q != Quantity::A2)
        .map(|(q, v)| Channel {
            quantity: *q,
            source: q.name().to_string(),
            rate_hz: 1000.0,
            t: t.as_slice().into(),
            v: v.clone(),
            dropouts: 0,
        })
        .collect();
    let rig = RigMeta {
        format: "stickslip-rig-log/1".into(),
        test: TestKind::Characteristic,
        m1_kg: M1,
        m2_kg: M2,
        k1_n_per_m: K1,
        k2_n_per_m: K2,
        d_n_s_per_m: D,
        drive_amplitude_m: AMP,
        normal_force_n: 3.0,
        drive_frequency_hz: Some(FREQ),
        sweep_kind: None,
        rig_id: None,
        operator: None,
        notes: None,
        recorded_at: None,
        extra: BTreeMap::new(),
    };
    Run {
        source: PathBuf::from(format!("synthetic-{seed}")),
        format: LogFormat::Parquet,
        rig,
        channels,
        has_acceleration: accel,
        setpoints: Vec::new(),
        resampled: Resampled {
            rate_hz: 1000.0,
            t: t.into(),
            x0: cols[0].clone(),
            x1: cols[1].as_slice().into(),
            x2: cols[2].as_slice().into(),
            v2: cols[3].clone(),
            a2: accel.then(|| cols[4].clone()),
            normal_force: None,
            setpoint_hz: None,
        },
        gaps: Vec::new(),
        warnings: Vec::new(),
        delays: Default::default(),
    }
}

#[test]
fn known_laws_are_recovered_within_tolerance_and_intervals() {
    // (law, accelerometer, expected family)
    let cases = [
        (
            Law {
                rs: 1.25,
                rd: 1.0,
                a: 0.0,
            },
            true,
            "static-dynamic",
        ),
        (
            Law {
                rs: 1.25,
                rd: 1.0,
                a: 0.0,
            },
            false,
            "static-dynamic",
        ),
        (
            Law {
                rs: 0.9,
                rd: 0.9,
                a: 0.0,
            },
            true,
            "coulomb",
        ),
        (
            Law {
                rs: 1.1,
                rd: 1.1,
                a: -4.0,
            },
            false,
            "decreasing",
        ),
        (
            Law {
                rs: 0.8,
                rd: 0.8,
                a: 3.0,
            },
            true,
            "decreasing",
        ),
    ];
    let ss = (K2 * M2).sqrt();
    let mut misses = Vec::new();
    let mut checked = 0;
    for (i, (law, accel, family)) in cases.iter().enumerate() {
        let run = synth(law, *accel, 100 + i as u64);
        let fit = identify::fit_log(&run, &IdentifyOptions::default()).expect("fit");
        let label = format!("case {i} ({family}, accel {accel})");
        assert!(
            !fit.stuck() && !fit.never_sticks(),
            "{label}: stuck {} never {} {:?}",
            fit.stuck(),
            fit.never_sticks(),
            fit.notes
        );
        // The estimate used downstream (the output-error refinement).
        let e = fit.law().expect("a sliding law");
        assert_eq!(fit.estimate, identify::Estimate::OutputError, "{label}");
        assert_eq!(
            e.kind.as_str(),
            *family,
            "{label}: {:?}",
            fit.output_error.as_ref().map(|o| &o.families)
        );
        assert!(
            (e.rs_n / law.rs - 1.0).abs() <= 0.03,
            "{label}: Rs {}",
            e.rs_n
        );
        assert!(
            (e.rd_n / law.rd - 1.0).abs() <= 0.03,
            "{label}: Rd {}",
            e.rd_n
        );
        let dstar = law.a / ss;
        assert!(
            (fit.dstar().unwrap() - dstar).abs() <= 0.01,
            "{label}: D* {:?} vs {dstar}; {:?}",
            fit.dstar(),
            fit.notes
        );
        for (name, iv, x) in [
            ("Rs", fit.rs_interval_n, law.rs),
            ("Rd", fit.rd_interval_n, law.rd),
            ("a", fit.slope_interval_n_s_per_m, law.a),
        ] {
            checked += 1;
            match iv {
                Some((lo, hi)) if lo <= x && x <= hi => {}
                _ => misses.push(format!("{label} {name}: {iv:?} vs {x}")),
            }
        }
    }
    assert!(
        misses.len() <= 1,
        "{} of {checked}: {misses:#?}",
        misses.len()
    );
}

/// A drive with a 5 % second harmonic is not a sinusoid to within its
/// noise: the refinement simulates the sampled drive channel (numerical
/// engine) and still recovers the law.
#[test]
fn a_distorted_drive_is_simulated_as_sampled() {
    let law = Law {
        rs: 1.25,
        rd: 1.0,
        a: 0.0,
    };
    let mut run = synth_drive(&law, true, 77, 1.0, 0.05);
    // 8 s of log keep the numerical engine's share of the test short.
    let keep = 8000;
    let r = &mut run.resampled;
    for col in [&mut r.t, &mut r.x1, &mut r.x2] {
        *col = col[..keep].into();
    }
    for col in [&mut r.x0, &mut r.v2] {
        col.truncate(keep);
    }
    if let Some(a) = r.a2.as_mut() {
        a.truncate(keep);
    }
    let t0 = std::time::Instant::now();
    let fit = identify::fit_log(&run, &IdentifyOptions::default()).expect("fit");
    eprintln!(
        "fit of an 8-s log with a sampled drive: {:.2} s",
        t0.elapsed().as_secs_f64()
    );
    let o = fit.output_error.as_ref().expect("refined");
    assert_eq!(o.drive.as_str(), "sampled");
    assert_eq!(fit.estimate, identify::Estimate::OutputError);
    let l = fit.law().expect("a sliding law");
    assert_eq!(l.kind.as_str(), "static-dynamic", "{:?}", o.families);
    for (name, x, t, iv) in [
        ("Rs", l.rs_n, law.rs, fit.rs_interval_n),
        ("Rd", l.rd_n, law.rd, fit.rd_interval_n),
    ] {
        assert!((x / t - 1.0).abs() <= 0.03, "{name} {x} vs {t}");
        assert!(
            matches!(iv, Some((a, b)) if a <= t && t <= b),
            "{name} {iv:?} vs {t}"
        );
    }
}

#[test]
fn a_log_shorter_than_two_periods_is_refused_not_called_stuck() {
    let mut run = synth(
        &Law {
            rs: 1.25,
            rd: 1.0,
            a: 0.0,
        },
        true,
        7,
    );
    // 0.9 s at 1.72 Hz: about 1.5 drive periods.
    let keep = 900;
    let r = &mut run.resampled;
    for col in [&mut r.t, &mut r.x1, &mut r.x2] {
        *col = col[..keep].into();
    }
    for col in [&mut r.x0, &mut r.v2] {
        col.truncate(keep);
    }
    if let Some(a) = r.a2.as_mut() {
        a.truncate(keep);
    }
    let err = identify::fit_log(&run, &IdentifyOptions::default()).unwrap_err();
    assert!(err.to_string().contains("two drive periods"), "{err}");
}

/// Random laws, normal-force levels and noise levels, with and without an
/// accelerometer, from the independent simulator above: cases `first..first + n`.
/// Returns (intervals holding the truth, parameters, skipped logs, misses).
fn random_coverage(first: u64, n: u64) -> (usize, usize, usize, Vec<String>) {
    let ss = (K2 * M2).sqrt();
    let (mut hits, mut total, mut skipped) = (0, 0, 0);
    let mut report = Vec::new();
    for case in first..first + n {
        // Each case draws from its own stream (the CI subset and the long
        // run share their first cases).
        let mut rng = Rng::new(0xC0FFEE ^ case.wrapping_mul(0x9E37_79B9_7F4A_7C15));
        let family = case % 4;
        let rd = 0.6 + 1.0 * rng.uniform();
        let law = match family {
            0 => Law {
                rs: rd * (1.1 + 0.3 * rng.uniform()),
                rd,
                a: 0.0,
            },
            1 => Law { rs: rd, rd, a: 0.0 },
            2 => Law {
                rs: rd,
                rd,
                a: -(1.0 + 4.0 * rng.uniform()),
            },
            _ => Law {
                rs: rd,
                rd,
                a: 1.0 + 3.0 * rng.uniform(),
            },
        };
        let accel = rng.uniform() < 0.5;
        let noise = 0.5 + 1.5 * rng.uniform();
        let run = synth_noise(&law, accel, 1000 + case, noise);
        let fit = identify::fit_log(&run, &IdentifyOptions::default()).expect("fit");
        if fit.stuck() || fit.never_sticks() {
            skipped += 1;
            continue;
        }
        for (name, iv, x) in [
            ("Rs", fit.rs_interval_n, law.rs),
            ("Rd", fit.rd_interval_n, law.rd),
            ("a", fit.slope_interval_n_s_per_m, law.a),
        ] {
            total += 1;
            if matches!(iv, Some((lo, hi)) if lo <= x && x <= hi) {
                hits += 1;
            } else {
                report.push(format!(
                    "case {case} (family {family}, accel {accel}, noise ×{noise:.2}) {name}: {iv:?} vs {x}; law {} D* {:?} vs {}",
                    fit.kind().as_str(),
                    fit.dstar(),
                    law.a / ss
                ));
            }
        }
    }
    (hits, total, skipped, report)
}

/// The 95 % intervals hold the truth in about 95 % of the parameters.
///
/// 12 random logs × 3 parameters in CI. With a true coverage of 95 %, the
/// number of misses among 36 parameters is binomial with mean 1.8;
/// P(misses ≥ 5) ≈ 3.6 %, so at most 4 misses is the bar (it fails a
/// coverage of 85 % with probability 71 %). The long run (`just`, ignored)
/// has 60 logs. Measured with the output-error estimate: 32/33 (12 logs,
/// one never sticks) and 161/162 (60 logs, 6 skipped); the equation-error
/// estimate alone had 19/30 on the first 12 of the former draw (moderate
/// slopes under high noise were not selected).
#[test]
fn random_round_trips_cover_the_truth() {
    let (hits, total, skipped, report) = random_coverage(0, 12);
    eprintln!("coverage {hits}/{total}, skipped {skipped}: {report:#?}");
    assert!(skipped <= 2, "{skipped} cases neither stick nor slip");
    assert!(total - hits <= 4, "{hits}/{total}: {report:#?}");
}

/// The long run of the coverage study: 60 logs, up to 180 parameters
/// (binomial, p = 0.05: mean 9 misses; P(misses ≥ 15) ≈ 4 %, so the bar
/// is 14).
#[test]
#[ignore = "long coverage run (60 logs); `cargo test --release --test identify_roundtrip -- --ignored`"]
fn random_round_trips_cover_the_truth_long() {
    let (hits, total, skipped, report) = random_coverage(0, 60);
    eprintln!("coverage {hits}/{total}, skipped {skipped}: {report:#?}");
    assert!(skipped <= 10, "{skipped} cases neither stick nor slip");
    assert!(total - hits <= 14, "{hits}/{total}: {report:#?}");
}
