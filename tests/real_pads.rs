//! Real pads (issue 34): friction levels that depend on the sliding
//! direction, in the exact engine, the numerical engine and RK4. Reference
//! values: the mirror symmetry of the equations (an exact identity), the
//! energy balance, and the engines against each other on random cases.
#![allow(clippy::needless_range_loop)]

use stickslip::model::{Absorber, Drive, Law, Levels, Model};
use stickslip::sim::numeric::{NumericOptions, NumericSim};
use stickslip::sim::rk4::Rk4;
use stickslip::sim::{simulate, Event, Init, Mode, Sim, SimOptions};

#[derive(Default)]
struct Collect {
    events: Vec<Event>,
}
impl stickslip::sim::Observer for Collect {
    fn event(&mut self, ev: &Event) {
        self.events.push(*ev);
    }
}

/// A linear law with levels (ρs⁺, ρd⁺) forwards and (ρs⁻, ρd⁻) backwards.
fn pad(plus: (f64, f64), minus: (f64, f64), slope: f64) -> Law {
    Law::Linear {
        rho_s: plus.0,
        rho_d: plus.1,
        slope,
        minus: Some(Levels {
            rho_s: minus.0,
            rho_d: minus.1,
        }),
    }
}

fn model(absorber: Absorber, law: Law) -> Model {
    Model {
        absorber,
        law,
        stop_below: None,
        contact_stiffness: None,
    }
}

/// Gauss–Legendre nodes and weights on [−1, 1] (10 points, positive half).
const GL: [(f64, f64); 5] = [
    (0.148_874_338_981_631_2, 0.295_524_224_714_752_9),
    (0.433_395_394_129_247_2, 0.269_266_719_309_996_4),
    (0.679_409_568_299_024_4, 0.219_086_362_515_982_04),
    (0.865_063_366_688_984_5, 0.149_451_349_150_580_6),
    (0.973_906_528_517_171_7, 0.066_671_344_308_688_14),
];

/// A phase of a recorded orbit: its start τ, state and mode.
type Phase = (f64, [f64; 4], Mode);

/// Gauss–Legendre quadrature over the phases of an orbit that ends at `t`
/// (pieces of at most `piece` in τ): the drive's work ∫ k·cos(ητ)·ζ1', the
/// viscous dissipation ∫ D(ζ1' − ζ2')², and ∫ `slip(dir, |ζ2'|)` over the
/// slips (one value per closure in `slip`).
fn orbit_work<const N: usize>(
    sim: &Sim,
    phases: &[Phase],
    t: f64,
    piece: f64,
    slip: [&dyn Fn(f64, f64) -> f64; N],
) -> (f64, f64, [f64; N]) {
    let m = sim.model();
    let (d, k, eta) = (m.absorber.damping, m.absorber.k, sim.eta());
    let (mut w_in, mut w_visc, mut w_slip) = (0.0, 0.0, [0.0; N]);
    for (i, &(s0, x, mode)) in phases.iter().enumerate() {
        let s1 = phases.get(i + 1).map_or(t, |p| p.0);
        let pieces = ((s1 - s0) / piece).ceil().max(1.0) as usize;
        let h = (s1 - s0) / pieces as f64;
        for j in 0..pieces {
            let mid = s0 + (j as f64 + 0.5) * h;
            for &(node, w) in &GL {
                for sgn in [-1.0, 1.0] {
                    let tau = mid + sgn * node * 0.5 * h;
                    let y = sim.state_in_phase(&x, mode, s0, tau - s0);
                    let wt = w * 0.5 * h;
                    w_in += wt * k * (eta * tau).cos() * y[1];
                    w_visc += wt * d * (y[1] - y[3]).powi(2);
                    if let Mode::Slip { dir } = mode {
                        for (acc, f) in w_slip.iter_mut().zip(&slip) {
                            *acc += wt * f(dir, y[3].abs());
                        }
                    }
                }
            }
        }
    }
    (w_in, w_visc, w_slip)
}

/// RK4 with steps `steps` against the exact engine over `periods` from
/// rest: the same events, and the observed orders of the largest event
/// time and final state errors, each asserted within 3.5–4.6.
fn assert_rk4_fourth_order(m: &Model, eta: f64, periods: u64, steps: [f64; 3]) {
    let mut exact = Collect::default();
    let e_end = Sim::new(m, eta)
        .unwrap()
        .run(Init::rest(), periods, &mut exact);
    let mut errs = Vec::new();
    for h in steps {
        let mut c = Collect::default();
        let end = Rk4::new(m, eta, h)
            .unwrap()
            .run(Init::rest(), periods, &mut c);
        assert_eq!(c.events.len(), exact.events.len(), "H {h}: event count");
        let mut err: f64 = 0.0;
        for (a, b) in c.events.iter().zip(&exact.events) {
            assert_eq!(a.kind, b.kind);
            err = err.max((a.tau - b.tau).abs());
        }
        for i in 0..4 {
            err = err.max((end.x[i] - e_end.x[i]).abs());
        }
        errs.push(err);
    }
    let orders: Vec<f64> = errs.windows(2).map(|w| (w[0] / w[1]).log2()).collect();
    eprintln!("{}: rk4 errors {errs:?}, observed orders {orders:?}", m.law);
    for p in orders {
        assert!((3.5..4.6).contains(&p), "observed order {p}");
    }
}

/// The exact engine against Dormand–Prince (rtol 1e-12) on `m` at η over
/// `periods` from rest: the same event sequence (kinds collected into
/// `kinds`), event times within 1e-9 relative and final states within
/// 1e-8; returns the worst relative event-time difference.
fn assert_engines_agree(
    m: &Model,
    eta: f64,
    periods: u64,
    label: &str,
    kinds: &mut std::collections::BTreeSet<&'static str>,
) -> f64 {
    let mut a = Collect::default();
    let ea = Sim::new(m, eta).unwrap().run(Init::rest(), periods, &mut a);
    let drive = Drive::Harmonic {
        eta,
        phase: 0.0,
        amplitude: 1.0,
    };
    let opts = NumericOptions {
        rtol: 1e-12,
        atol: 1e-14,
    };
    let mut b = Collect::default();
    let eb = NumericSim::new(m, drive, opts).unwrap().run(
        Init::rest(),
        periods as f64 * 2.0 * std::f64::consts::PI / eta,
        &mut b,
    );
    assert_eq!(a.events.len(), b.events.len(), "{label}");
    let mut worst: f64 = 0.0;
    for (x, y) in a.events.iter().zip(&b.events) {
        assert_eq!(x.kind, y.kind, "{label}");
        kinds.insert(x.kind.as_str());
        worst = worst.max((x.tau - y.tau).abs() / x.tau);
    }
    assert!(worst < 1e-9, "{label}: {worst:e}");
    for i in 0..4 {
        assert!((ea.x[i] - eb.x[i]).abs() < 1e-8, "{label}");
    }
    worst
}

/// Prints the worst event-time difference of a random study and checks that
/// its cases met sticks and slips both ways.
fn report_random_cases(worst: f64, kinds: &std::collections::BTreeSet<&'static str>) {
    eprintln!("worst relative event-time difference {worst:e}; kinds {kinds:?}");
    for k in ["stick", "slip+", "slip-"] {
        assert!(kinds.contains(k), "no {k} event in the cases: {kinds:?}");
    }
}

/// A small deterministic generator (SplitMix64) for the random cases.
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 53) as f64
    }
    fn in_range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.next()
    }
}

/// The equations are odd under ζ → −ζ, ζ0 → −ζ0 with the levels of the
/// two directions exchanged: a pad with levels (P forwards, Q backwards)
/// driven by cos(ητ) moves exactly as the mirror image of the pad (Q, P)
/// driven by −cos(ητ). Both runs start at rest, so the exact engine must
/// give mirrored events (slip+ ↔ slip-) at the same times and mirrored
/// states; a threshold or a dynamic level taken from the wrong direction
/// anywhere (breakaway, slip, end of slip, interruption) breaks it.
#[test]
fn mirror_image_swaps_the_directions() {
    let swap = |k: &str| {
        match k {
            "slip+" => "slip-",
            "slip-" => "slip+",
            "reverse+" => "reverse-",
            "reverse-" => "reverse+",
            other => other,
        }
        .to_string()
    };
    let cases = [
        ((0.5, 0.4), (0.3, 0.2), 0.0, 0.6),
        ((0.375, 0.375), (0.45, 0.45), -0.02, 0.9),
        ((0.2, 0.15), (0.12, 0.12), 0.01, 1.2),
        ((1.0, 0.8), (0.6, 0.5), 0.0, 0.45),
    ];
    let mut kinds = std::collections::BTreeSet::new();
    for (p, q, slope, eta) in cases {
        let a = model(Absorber::default(), pad(p, q, slope));
        let b = model(Absorber::default(), pad(q, p, slope));
        let (sa, sb) = (Sim::new(&a, eta).unwrap(), Sim::new(&b, eta).unwrap());
        let (mut ca, mut cb) = (Collect::default(), Collect::default());
        let ea = sa.run_periods(Init::rest(), 0.0, 1.0, 30, &mut ca);
        let eb = sb.run_periods(Init::rest(), 0.0, -1.0, 30, &mut cb);
        assert!(ca.events.len() > 20, "{p:?} {q:?}: too few events");
        assert_eq!(ca.events.len(), cb.events.len(), "{p:?} {q:?} eta {eta}");
        for (x, y) in ca.events.iter().zip(&cb.events) {
            kinds.insert(x.kind.as_str());
            assert_eq!(x.kind.as_str(), swap(y.kind.as_str()));
            assert!(
                (x.tau - y.tau).abs() <= 1e-12 * x.tau,
                "{} vs {}",
                x.tau,
                y.tau
            );
            for i in 0..4 {
                assert!((x.x[i] + y.x[i]).abs() <= 1e-12, "{:?} vs {:?}", x.x, y.x);
            }
        }
        for i in 0..4 {
            assert!((ea.x[i] + eb.x[i]).abs() <= 1e-12);
        }
    }
    for k in ["stick", "slip+", "slip-"] {
        assert!(kinds.contains(k), "no {k} event in the cases: {kinds:?}");
    }
}

/// Energy balance over one steady orbit with direction-dependent levels:
/// drive work = viscous dissipation + ∫ g_dir(|ζ2'|)|ζ2'| dτ with the
/// sliding law of each phase's direction, to 1e-9 relative. (With the
/// symmetric level of either direction instead, the balance is off by the
/// levels' difference, far above that: checked below.)
#[test]
fn energy_balance_with_direction_dependent_levels() {
    let cases = [
        (pad((0.375, 0.3), (0.3, 0.25), 0.0), 0.6),
        (pad((0.375, 0.375), (0.45, 0.4), -0.02), 0.9),
        (pad((0.5, 0.25), (0.4, 0.3), 0.0), 1.1),
    ];
    for (law, eta) in cases {
        let m = model(Absorber::default(), law);
        let sim = Sim::new(&m, eta).unwrap();
        let s = simulate(&sim, &SimOptions::default(), &mut ());
        assert!(s.steady, "{law} eta {eta}: {}", s.status);
        let p = s.period_multiple.unwrap() as u64;
        // Settle further than the steady-state test asks (a falling law
        // converges slowly), so the orbit closes to rounding.
        let settle = sim.run(
            Init {
                x: s.final_state,
                mode: stickslip::sim::sweep::mode_of(&m, &s.final_state),
            },
            400 * p,
            &mut (),
        );
        let (x0, mode0) = (settle.x, settle.mode);
        let mut c = Collect::default();
        let end = sim.run(Init { x: x0, mode: mode0 }, p, &mut c);
        let t = p as f64 * sim.period();
        let mut phases = vec![(0.0, x0, mode0)];
        for ev in &c.events {
            let mode = match ev.kind.as_str() {
                "stick" => Mode::Stick { z2: ev.x[2] },
                "slip+" | "reverse+" => Mode::Slip { dir: 1.0 },
                _ => Mode::Slip { dir: -1.0 },
            };
            phases.push((ev.tau, ev.x, mode));
        }
        let slid = [1.0, -1.0].map(|dir| {
            phases
                .iter()
                .any(|p| matches!(p.2, Mode::Slip { dir: d } if d == dir))
        });
        let own = |dir: f64, v: f64| law.toward(dir).sliding(v) * v;
        let forwards = |_: f64, v: f64| law.toward(1.0).sliding(v) * v;
        let (w_in, w_visc, [w_fric, w_sym]) = orbit_work(&sim, &phases, t, 0.25, [&own, &forwards]);
        let rel = (w_in - w_visc - w_fric).abs() / w_in;
        let rel_sym = (w_in - w_visc - w_sym).abs() / w_in;
        eprintln!("{law} eta {eta}: W_in {w_in:.12} W_fric {w_fric:.12} rel {rel:e} (one level for both directions: {rel_sym:e})");
        assert!(slid[0] && slid[1], "the orbit slides both ways");
        assert!(rel < 1e-9, "energy balance off by {rel:e}");
        assert!(rel_sym > 1e-3, "the check cannot tell the levels apart");
        for i in 0..4 {
            assert!(
                (end.x[i] - x0[i]).abs() < 1e-9,
                "orbit not periodic: {:?} after {p} periods from {x0:?}",
                end.x
            );
        }
    }
}

/// The exact engine against the numerical one (Dormand–Prince, rtol 1e-12)
/// on 40 random direction-dependent pads (levels up to 40 % apart, static
/// above dynamic or not, slopes of both signs, several absorbers and
/// frequencies): the same event sequence over 12 periods, event times
/// within 1e-9 relative.
#[test]
fn exact_and_numeric_engines_agree_on_random_direction_dependent_pads() {
    let mut rng = Rng(34);
    let mut kinds = std::collections::BTreeSet::new();
    let mut worst_all: f64 = 0.0;
    for case in 0..40 {
        let absorber = Absorber {
            m: rng.in_range(1.0, 6.0),
            k: rng.in_range(0.5, 2.0),
            damping: rng.in_range(0.0, 0.03),
        };
        let rs = rng.in_range(0.1, 1.0);
        let rs_minus = rs * rng.in_range(0.6, 1.4);
        let rd = rs * rng.in_range(0.6, 1.0);
        let rd_minus = rs_minus * rng.in_range(0.6, 1.0);
        let slope = rng.in_range(-0.01, 0.03);
        let eta = rng.in_range(0.3, 1.5);
        let m = model(absorber, pad((rs, rd), (rs_minus, rd_minus), slope));
        let label = format!("case {case}: {:?} {} eta {eta}", m.absorber, m.law);
        let worst = assert_engines_agree(&m, eta, 12, &label, &mut kinds);
        worst_all = worst_all.max(worst);
    }
    report_random_cases(worst_all, &kinds);
}

/// The paper's RK4 converges to the exact engine at fourth order on a
/// direction-dependent pad: halving H divides the event-time and state
/// errors by about 16 (15 periods; the same event sequence).
#[test]
fn rk4_converges_on_a_direction_dependent_pad() {
    let m = model(Absorber::default(), pad((0.5, 0.4), (0.35, 0.3), 0.0));
    assert_rk4_fourth_order(&m, 0.6, 15, [0.04, 0.02, 0.01]);
}

/// Levels given equal in both directions are the symmetric law, to the
/// bit: the extension costs the paper's model nothing.
#[test]
fn equal_levels_are_the_symmetric_law() {
    let sym = Law::Linear {
        rho_s: 0.5,
        rho_d: 0.4,
        slope: -0.01,
        minus: None,
    };
    let both = pad((0.5, 0.4), (0.5, 0.4), -0.01);
    assert!(!both.is_direction_dependent());
    for eta in [0.5, 0.8, 1.2] {
        let (mut a, mut b) = (Collect::default(), Collect::default());
        let ea = Sim::new(&model(Absorber::default(), sym), eta)
            .unwrap()
            .run(Init::rest(), 20, &mut a);
        let eb = Sim::new(&model(Absorber::default(), both), eta)
            .unwrap()
            .run(Init::rest(), 20, &mut b);
        assert_eq!(ea.x, eb.x);
        assert_eq!(a.events.len(), b.events.len());
        for (x, y) in a.events.iter().zip(&b.events) {
            assert_eq!((x.tau, x.x), (y.tau, y.x));
        }
    }
}

/// A direction-dependent law is refused where it describes no pad.
#[test]
fn unphysical_levels_are_refused() {
    for (p, q) in [
        ((0.5, 0.4), (0.3, 0.35)), // ρd⁻ > ρs⁻
        ((0.5, 0.4), (0.0, 0.0)),  // friction in one direction only
        ((0.5, 0.4), (-0.1, 0.0)), // negative
        ((0.5, 0.4), (f64::NAN, 0.1)),
    ] {
        let m = model(Absorber::default(), pad(p, q, 0.0));
        assert!(m.validate().is_err(), "{p:?} {q:?}");
        assert!(Sim::new(&m, 0.6).is_err());
    }
}

/// What a log cannot tell: a pad whose levels are all shifted by the same
/// amount δ in one direction (ρs⁺ − ρs⁻ = ρd⁺ − ρd⁻ = −2δ) moves exactly
/// as the symmetric pad of the mean levels with both positions offset by
/// constants (ζ1 by δ/k, ζ2 by δ/k + δ: the static deflection of the two
/// springs under a constant force δ on M2). A constant force on M2 is what
/// the sensors' zero offsets look like, so from positions with unknown
/// zeros only the part of the asymmetry that differs between the static
/// and the dynamic level, (ρs⁺ − ρs⁻) − (ρd⁺ − ρd⁻), is identifiable
/// (`docs/real-pads.md`). Shown here to rounding on three pads.
#[test]
fn a_common_shift_of_the_levels_is_a_sensor_offset() {
    let k = Absorber::default().k;
    for ((rs, rd), delta, eta) in [
        ((0.3, 0.3), 0.05, 0.6),
        ((0.35, 0.28), -0.03, 0.5),
        ((0.2, 0.16), 0.02, 1.2),
    ] {
        let sym = model(Absorber::default(), pad((rs, rd), (rs, rd), 0.0));
        let asym = model(
            Absorber::default(),
            pad((rs - delta, rd - delta), (rs + delta, rd + delta), 0.0),
        );
        let (s1, s2) = (delta / k, delta / k + delta);
        let (mut a, mut b) = (Collect::default(), Collect::default());
        let ea = Sim::new(&sym, eta).unwrap().run(Init::rest(), 30, &mut a);
        let start = Init {
            x: [s1, 0.0, s2, 0.0],
            mode: Mode::Stick { z2: s2 },
        };
        let eb = Sim::new(&asym, eta).unwrap().run(start, 30, &mut b);
        assert!(a.events.len() > 20, "{} events", a.events.len());
        assert_eq!(a.events.len(), b.events.len(), "rs {rs} delta {delta}");
        let shift = [s1, 0.0, s2, 0.0];
        for (x, y) in a.events.iter().zip(&b.events) {
            assert_eq!(x.kind, y.kind);
            assert!(
                (x.tau - y.tau).abs() <= 1e-11 * x.tau,
                "{} vs {}",
                x.tau,
                y.tau
            );
            for i in 0..4 {
                assert!(
                    (x.x[i] + shift[i] - y.x[i]).abs() <= 1e-11,
                    "{:?} vs {:?}",
                    x.x,
                    y.x
                );
            }
        }
        for i in 0..4 {
            assert!((ea.x[i] + shift[i] - eb.x[i]).abs() <= 1e-11);
        }
    }
}

mod common;

/// `sweep` of a direction-dependent pad through the binary: the curves
/// carry the negative levels, every steady point from rest agrees with
/// `simulate --steady` of the same pad (marching, an independent path to
/// the steady state: the sweep shoots), and a sharded study with the new
/// columns merges back to exactly the unsharded table.
#[test]
fn sweep_of_a_direction_dependent_pad() {
    use common::bin;
    use stickslip::report::table::read_frc;
    let dir = tempfile::tempdir().unwrap();
    let p = |n: &str| dir.path().join(n);
    let pad = [
        "--rho-s",
        "0.4",
        "--rho-d",
        "0.3",
        "--rho-s-minus",
        "0.3",
        "--rho-d-minus",
        "0.25",
    ];
    let sweep = ["sweep", "--points", "9", "--from-rest"];
    let out = bin()
        .args(sweep)
        .args(pad)
        .arg("--out")
        .arg(p("all.csv"))
        .arg("--json")
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let c = &v["curves"][0];
    assert_eq!(c["rho_s_minus"], 0.3);
    assert_eq!(c["rho_d_minus"], 0.25);
    let etas = c["eta"].as_array().unwrap();
    let mut compared = 0;
    for (i, eta) in etas.iter().enumerate() {
        if c["steady"][i] != true {
            continue;
        }
        let eta = eta.as_f64().unwrap().to_string();
        let o = bin()
            .args([
                "simulate",
                "--steady",
                "--from-rest",
                "--eta",
                &eta,
                "--json",
            ])
            .args(pad)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let s: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        if s["period_multiple"] != c["period_multiple"][i] {
            continue;
        }
        for key in ["amplitude1", "amplitude2"] {
            let (a, b) = (c[key][i].as_f64().unwrap(), s[key].as_f64().unwrap());
            assert!(
                (a - b).abs() <= 1e-6 * b,
                "eta {eta} {key}: sweep {a}, simulate {b}"
            );
        }
        compared += 1;
    }
    assert!(compared >= 6, "only {compared} points compared");
    // Shards in both table formats merge to the unsharded table, columns
    // of the negative levels included.
    for (k, name) in [(1, "a.parquet"), (2, "b.csv")] {
        let o = bin()
            .args(sweep)
            .args(pad)
            .args(["--shard", &format!("{k}/2"), "--out"])
            .arg(p(name))
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
    let o = bin()
        .arg("merge")
        .arg(p("a.parquet"))
        .arg(p("b.csv"))
        .arg("--out")
        .arg(p("merged.parquet"))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let all = read_frc(&p("all.csv")).unwrap();
    assert!(all
        .iter()
        .all(|r| r.rho_s_minus == Some(0.3) && r.rho_d_minus == Some(0.25)));
    assert_eq!(all, read_frc(&p("merged.parquet")).unwrap());
}

/// A pad with a contact spring κ (pre-sliding, a Jenkins element):
/// the paper's absorber with levels `plus` and a symmetric law.
fn compliant(law: Law, kappa: f64) -> Model {
    Model {
        contact_stiffness: Some(kappa),
        ..model(Absorber::default(), law)
    }
}

/// e^{A·t} by scaling and squaring of a 30-term Taylor series (an
/// independent reference for the engine's closed form).
fn expm(a: &[[f64; 7]; 7], t: f64) -> [[f64; 7]; 7] {
    let norm = a
        .iter()
        .map(|r| r.iter().map(|v| v.abs()).sum::<f64>())
        .fold(0.0, f64::max)
        * t.abs();
    let j = (norm / 0.25).log2().ceil().max(0.0) as i32;
    let h = t / 2f64.powi(j);
    let mul = |x: &[[f64; 7]; 7], y: &[[f64; 7]; 7]| {
        let mut z = [[0.0; 7]; 7];
        for i in 0..7 {
            for k in 0..7 {
                for c in 0..7 {
                    z[i][c] += x[i][k] * y[k][c];
                }
            }
        }
        z
    };
    let mut e = [[0.0; 7]; 7];
    let mut term = [[0.0; 7]; 7];
    for i in 0..7 {
        e[i][i] = 1.0;
        term[i][i] = 1.0;
    }
    let ah: Vec<[f64; 7]> = a.iter().map(|r| r.map(|v| v * h)).collect();
    let ah: [[f64; 7]; 7] = ah.try_into().unwrap();
    for n in 1..30 {
        term = mul(&term, &ah).map(|r| r.map(|v| v / n as f64));
        for i in 0..7 {
            for c in 0..7 {
                e[i][c] += term[i][c];
            }
        }
    }
    for _ in 0..j {
        e = mul(&e, &e);
    }
    e
}

/// With the slider stuck the absorber is linear (two free masses, M2 on
/// the contact spring): the engine's closed form of that phase equals the
/// matrix exponential of the system augmented with the drive's cosine and
/// sine and the spring's anchor κζs, to 1e-12, for κ from 0.5 to 400.
#[test]
fn held_phase_matches_the_matrix_exponential() {
    let ab = Absorber::default();
    let (m, k, d) = (ab.m, ab.k, ab.damping);
    for (kappa, eta, zs) in [(0.5, 0.6, 0.1), (20.0, 1.1, -0.3), (400.0, 0.4, 0.02)] {
        let sim = Sim::new(&compliant(Law::coulomb(0.4), kappa), eta).unwrap();
        // y = [ζ1, ζ1', ζ2, ζ2', cos ητ, sin ητ, 1].
        let mut a = [[0.0; 7]; 7];
        a[0][1] = 1.0;
        a[1] = [-(1.0 + k) / m, -d / m, 1.0 / m, d / m, k / m, 0.0, 0.0];
        a[2][3] = 1.0;
        a[3] = [1.0, d, -1.0 - kappa, -d, 0.0, 0.0, kappa * zs];
        a[4][5] = -eta;
        a[5][4] = eta;
        let x0 = [0.2, -0.1, 0.15, 0.05];
        let s0 = 0.7;
        for delta in [0.01, 0.5, 3.0, 9.0] {
            let got = sim.state_in_phase(&x0, Mode::Stick { z2: zs }, s0, delta);
            let e = expm(&a, delta);
            let y0 = [
                x0[0],
                x0[1],
                x0[2],
                x0[3],
                (eta * s0).cos(),
                (eta * s0).sin(),
                1.0,
            ];
            for i in 0..4 {
                let want: f64 = (0..7).map(|c| e[i][c] * y0[c]).sum();
                assert!(
                    (got[i] - want).abs() <= 1e-12 * (1.0 + want.abs()),
                    "kappa {kappa} delta {delta} state {i}: {} against {want}",
                    got[i]
                );
            }
        }
    }
}

/// The exact engine against the numerical one on 30 random pads with a
/// contact spring (κ 0.5–300, symmetric and direction-dependent levels,
/// static above dynamic or not, slopes of both signs): the same event
/// sequence over 10 periods, event times within 1e-9 relative.
#[test]
fn exact_and_numeric_engines_agree_on_random_compliant_pads() {
    let mut rng = Rng(3434);
    let mut kinds = std::collections::BTreeSet::new();
    let mut worst_all: f64 = 0.0;
    for case in 0..30 {
        let kappa = 10f64.powf(rng.in_range(-0.3, 2.5));
        let rs = rng.in_range(0.1, 1.0);
        let rs_minus = if case % 2 == 0 {
            rs
        } else {
            rs * rng.in_range(0.7, 1.3)
        };
        let rd = rs * rng.in_range(0.6, 1.0);
        let rd_minus = if case % 2 == 0 {
            rd
        } else {
            rs_minus * rng.in_range(0.6, 1.0)
        };
        let slope = rng.in_range(-0.01, 0.03);
        let eta = rng.in_range(0.3, 1.5);
        let m = compliant(pad((rs, rd), (rs_minus, rd_minus), slope), kappa);
        let label = format!("case {case}: kappa {kappa} {} eta {eta}", m.law);
        let worst = assert_engines_agree(&m, eta, 10, &label, &mut kinds);
        worst_all = worst_all.max(worst);
    }
    report_random_cases(worst_all, &kinds);
}

/// RK4 converges to the exact engine at fourth order on a pad with a
/// contact spring (κ = 20, static above dynamic): the same events over 10
/// periods, errors falling by about 16 per halving of H.
#[test]
fn rk4_converges_on_a_compliant_pad() {
    let m = compliant(pad((0.5, 0.4), (0.5, 0.4), 0.0), 20.0);
    assert_rk4_fourth_order(&m, 0.6, 10, [0.02, 0.01, 0.005]);
}

/// A contact stiffness outside what the engine supports is refused with
/// the reason: not positive, without friction, or above 1e8 (the contact
/// mode's ringing); 1e8 itself runs.
#[test]
fn unsupported_contact_stiffness_is_refused() {
    for kappa in [0.0, -1.0, f64::NAN, 2e8] {
        let m = compliant(Law::coulomb(0.4), kappa);
        assert!(m.validate().is_err(), "{kappa}");
        assert!(Sim::new(&m, 0.6).is_err(), "{kappa}");
    }
    let frictionless = compliant(Law::coulomb(0.0), 10.0);
    assert!(frictionless.validate().is_err());
    let e = compliant(Law::coulomb(0.4), 2e8).validate().unwrap_err();
    assert!(e.to_string().contains("supported 1e8"), "{e}");
    let ok = compliant(Law::coulomb(0.4), 1e8);
    let end = Sim::new(&ok, 0.6).unwrap().run(Init::rest(), 5, &mut ());
    assert!(end.x.iter().all(|v| v.is_finite()));
}

/// `sweep --contact-stiffness` through the binary: the curve carries κ,
/// and every steady point from rest agrees with the steady state of the
/// numerical engine (`simulate --method dopri`, an independent integrator)
/// to 1e-7; `simulate` reports the slider and its `zeta_s` columns.
#[test]
fn sweep_and_simulate_of_a_compliant_pad() {
    use common::bin;
    let dir = tempfile::tempdir().unwrap();
    let pad = [
        "--rho-s",
        "0.5",
        "--rho-d",
        "0.4",
        "--contact-stiffness",
        "20",
    ];
    let out = bin()
        .args(["sweep", "--points", "7", "--from-rest", "--json"])
        .args(pad)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let c = &v["curves"][0];
    assert_eq!(c["contact_stiffness"], 20.0);
    let mut compared = 0;
    for (i, eta) in c["eta"].as_array().unwrap().iter().enumerate() {
        if c["steady"][i] != true {
            continue;
        }
        let eta = eta.as_f64().unwrap().to_string();
        let o = bin()
            .args([
                "simulate", "--steady", "--method", "dopri", "--tol", "1e-12",
            ])
            .args(["--eta", &eta, "--json"])
            .args(pad)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let s: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        for key in ["amplitude1", "amplitude2"] {
            let (a, b) = (c[key][i].as_f64().unwrap(), s[key].as_f64().unwrap());
            assert!(
                (a - b).abs() <= 1e-7 * b.max(1e-3),
                "eta {eta} {key}: sweep {a}, dopri {b}"
            );
        }
        compared += 1;
    }
    assert!(compared >= 6, "only {compared} points compared");
    // simulate: the slider's position and the zeta_s columns.
    let (ev, tr) = (dir.path().join("ev.csv"), dir.path().join("tr.csv"));
    let o = bin()
        .args(["simulate", "--eta", "0.6", "--periods", "20", "--json"])
        .args(pad)
        .arg("--events")
        .arg(&ev)
        .arg("--trajectory")
        .arg(&tr)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let s: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(s["slider_position"].as_f64().unwrap().is_finite());
    assert_eq!(s["contact_stiffness"], 20.0);
    let events = std::fs::read_to_string(&ev).unwrap();
    assert!(events.starts_with("tau,kind,zeta1,dzeta1,zeta2,dzeta2,zeta_s\n"));
    // At each stick the spring holds the sliding level: P = κ(ζ2 − ζs) = ±ρd.
    let mut sticks = 0;
    for line in events.lines().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        if f[1] == "stick" {
            let (z2, zs): (f64, f64) = (f[4].parse().unwrap(), f[6].parse().unwrap());
            let pull = 20.0 * (z2 - zs);
            assert!((pull.abs() - 0.4).abs() < 1e-9, "{line}");
            sticks += 1;
        }
    }
    assert!(sticks > 5);
    let traj = std::fs::read_to_string(&tr).unwrap();
    assert!(traj.starts_with("tau,zeta1,dzeta1,zeta2,dzeta2,zeta_s\n"));
    // A list of stiffnesses is a family of curves in sweep (inf: rigid),
    // one value only in simulate.
    let o = bin()
        .args(["sweep", "--rho-s", "0.5", "--points", "3", "--from-rest"])
        .args(["--contact-stiffness", "inf,20", "--json"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let curves = v["curves"].as_array().unwrap();
    assert_eq!(curves.len(), 2);
    assert!(curves[0].get("contact_stiffness").is_none());
    assert_eq!(curves[1]["contact_stiffness"], 20.0);
    let o = bin()
        .args([
            "simulate",
            "--rho-s",
            "0.5",
            "--eta",
            "0.6",
            "--periods",
            "2",
        ])
        .args(["--contact-stiffness", "inf,20"])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1));
}

/// `synth --contact-stiffness-n-per-m`: the log is generated with the
/// contact spring (truth.json names kt and κ = kt/K2); combined with the
/// test defects (whose integrator has a rigid stick) it is refused and no
/// file is written.
#[test]
fn synth_writes_a_compliant_pad() {
    use common::bin;
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("kt.mcap");
    let o = bin()
        .args(["synth", "--out"])
        .arg(&log)
        .args(["--contact-stiffness-n-per-m", "20000", "--duration-s", "4"])
        .args(["--warmup-s", "5", "--seed", "7", "--json"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let truth: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("truth.json")).unwrap())
            .unwrap();
    let law = &truth["files"]["kt.mcap"]["law"];
    assert_eq!(law["contact_stiffness_n_per_m"], 20000.0);
    let kappa = law["contact_stiffness"].as_f64().unwrap();
    assert!((kappa - 20000.0 / 670.0).abs() < 1e-12, "{kappa}");
    let bad = dir.path().join("bad.mcap");
    let o = bin()
        .args(["synth", "--out"])
        .arg(&bad)
        .args([
            "--contact-stiffness-n-per-m",
            "20000",
            "--rs-minus-n",
            "0.8",
        ])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("contact stiffness"));
    assert!(!bad.exists());
}

/// Energy balance over a steady orbit of a pad with a contact spring
/// (D* = 0): drive work = viscous dissipation + the slider's: ρd of the
/// direction times M2's travel in every slip, plus at every breakaway the
/// contact spring's energy drop (ρs² − ρd²)/(2κ) of that direction (the
/// massless slider jumps from the pull ρs to ρd). To 1e-9 relative, on
/// symmetric and direction-dependent pads; without the jumps' term it is
/// off by far more.
#[test]
fn energy_balance_with_a_contact_spring() {
    for (law, kappa, eta) in [
        (pad((0.5, 0.4), (0.5, 0.4), 0.0), 20.0, 0.6),
        (pad((0.375, 0.375), (0.375, 0.375), 0.0), 5.0, 0.9),
        (pad((0.5, 0.35), (0.4, 0.3), 0.0), 50.0, 0.7),
    ] {
        let m = compliant(law, kappa);
        let sim = Sim::new(&m, eta).unwrap();
        let settle = sim.run(Init::rest(), 600, &mut ());
        let (x0, mode0) = (settle.x, settle.mode);
        let mut c = Collect::default();
        let end = sim.run(Init { x: x0, mode: mode0 }, 1, &mut c);
        for i in 0..4 {
            assert!(
                (end.x[i] - x0[i]).abs() < 1e-9,
                "{law} kappa {kappa}: not a period-1 orbit"
            );
        }
        let t = sim.period();
        let mut phases = vec![(0.0, x0, mode0)];
        // The direction of the slip in progress (or the last one), for the
        // pull a stick leaves on the spring.
        let mut dir = match mode0 {
            Mode::Slip { dir } => dir,
            Mode::Stick { z2 } => (x0[2] - z2).signum(),
        };
        let mut jumps = 0.0;
        for ev in &c.events {
            let mode = match ev.kind.as_str() {
                "stick" => {
                    let pull = dir * law.levels(dir).rho_d;
                    Mode::Stick {
                        z2: ev.x[2] - pull / kappa,
                    }
                }
                "slip+" | "slip-" => {
                    dir = if ev.kind.as_str() == "slip+" {
                        1.0
                    } else {
                        -1.0
                    };
                    let l = law.levels(dir);
                    jumps += (l.rho_s * l.rho_s - l.rho_d * l.rho_d) / (2.0 * kappa);
                    Mode::Slip { dir }
                }
                other => panic!("unexpected event {other}"),
            };
            phases.push((ev.tau, ev.x, mode));
        }
        let travel = |dir: f64, v: f64| law.levels(dir).rho_d * v;
        let (w_in, w_visc, [w_slip]) = orbit_work(&sim, &phases, t, 0.05, [&travel]);
        let rel = (w_in - w_visc - w_slip - jumps).abs() / w_in;
        let rel_no_jumps = (w_in - w_visc - w_slip).abs() / w_in;
        eprintln!("{law} kappa {kappa} eta {eta}: W_in {w_in:.12} slips {w_slip:.12} jumps {jumps:.3e} rel {rel:e} (without jumps {rel_no_jumps:e})");
        assert!(c.events.len() >= 2, "no stick-slip in the orbit");
        assert!(rel < 1e-9, "energy balance off by {rel:e}");
        if jumps > 0.0 {
            assert!(rel_no_jumps > 1e3 * rel.max(1e-15));
        }
    }
}

/// A slider that can never break away again leaves a linear system, M2 on
/// its contact spring: the steady state has a closed form. Written here
/// from the dynamic-stiffness matrix (independently of `sim::linear`), it
/// equals the sweep's steady states where the proof that the slider stays
/// held fires (`stick-proof`: a pad that sticks for good after its
/// transient) and `simulate`'s closed form of a slider that never slides,
/// to 1e-8; the period is the minimal one (1) and M2 moves (A2 > 0).
#[test]
fn a_slider_held_for_good_has_the_closed_form() {
    use num_complex::Complex;
    use stickslip::sim::sweep::{steady_state, SteadyConfig};
    let ab = Absorber::default();
    let (m, k, d) = (ab.m, ab.k, ab.damping);
    let reference = |kappa: f64, eta: f64| {
        let i = Complex::new(0.0, 1.0);
        let z11 = Complex::new(1.0 + k - m * eta * eta, 0.0) + i * eta * d;
        let z12 = -Complex::new(1.0, 0.0) - i * eta * d;
        let z22 = Complex::new(1.0 + kappa - eta * eta, 0.0) + i * eta * d;
        let det = z11 * z22 - z12 * z12;
        ((k * z22 / det).norm(), (k * z12 / det).norm())
    };
    let mut proofs = 0;
    for kappa in [2.0, 5.0, 50.0] {
        for eta in [0.3, 0.55, 0.8, 1.3, 1.9] {
            let (a1, a2) = reference(kappa, eta);
            // A pad that holds for good once the transient has passed.
            let pad = compliant(Law::coulomb(20.0), kappa);
            let (p, _) = steady_state(&pad, eta, Init::rest(), &SteadyConfig::default()).unwrap();
            assert!(p.steady && p.period_multiple == Some(1), "{p:?}");
            if p.method == "stick-proof" {
                proofs += 1;
            }
            // A slider that never slides: the closed form at once.
            let held = compliant(Law::coulomb(f64::INFINITY), kappa);
            let (q, _) = steady_state(&held, eta, Init::rest(), &SteadyConfig::default()).unwrap();
            assert_eq!(q.method, "closed-form");
            for (got, want) in [
                (p.amplitude1.unwrap(), a1),
                (p.amplitude2.unwrap(), a2),
                (q.amplitude1.unwrap(), a1),
                (q.amplitude2.unwrap(), a2),
            ] {
                assert!(
                    (got - want).abs() <= 1e-8 * want,
                    "kappa {kappa} eta {eta}: {got} against {want}"
                );
            }
            assert!(a2 > 0.0);
        }
    }
    assert!(proofs >= 12, "the proof fired at {proofs} of 15 points");
}

/// Samples on a regular grid (what the output-error refinement asks for):
/// every `h` from 0 up to `n·h`, as (ζ1, ζ2).
struct Grid {
    h: f64,
    n: usize,
    got: Vec<[f64; 2]>,
}

impl stickslip::sim::Observer for Grid {
    fn next_sample(&mut self) -> Option<f64> {
        (self.got.len() < self.n).then_some(self.got.len() as f64 * self.h)
    }
    fn sample(&mut self, _tau: f64, x: &[f64; 4], _dx: &[f64; 4]) {
        self.got.push([x[0], x[2]]);
    }
    fn wants_extremes(&self) -> bool {
        false
    }
}

/// Trajectory samples on a regular grid through held and sliding phases
/// (the exact engine rotates samples on with cached factors e^{λΔ} of the
/// phase system, one cache per system) equal the numerical engine's to
/// 1e-8, with a contact spring and with a rigid stick. (With the held
/// phase sharing the slip phase's cache, samples after a switch were off
/// by up to 0.02 of the stroke.)
#[test]
fn regular_samples_through_held_phases_match_the_numerical_engine() {
    let eta = 0.9;
    let n = 4000;
    let h = 20.0 * 2.0 * std::f64::consts::PI / eta / n as f64;
    let opts = NumericOptions {
        rtol: 1e-12,
        atol: 1e-14,
    };
    let drive = Drive::Harmonic {
        eta,
        phase: 0.0,
        amplitude: 1.0,
    };
    for kappa in [Some(20.0), Some(69.0), None] {
        let m = Model {
            contact_stiffness: kappa,
            ..model(Absorber::default(), pad((0.55, 0.45), (0.5, 0.45), 0.0))
        };
        let mut a = Grid {
            h,
            n,
            got: Vec::new(),
        };
        Sim::new(&m, eta).unwrap().run(Init::rest(), 21, &mut a);
        let mut b = Grid {
            h,
            n,
            got: Vec::new(),
        };
        NumericSim::new(&m, drive.clone(), opts).unwrap().run(
            Init::rest(),
            n as f64 * h + 1.0,
            &mut b,
        );
        assert_eq!(a.got.len(), n, "{kappa:?}");
        assert_eq!(b.got.len(), n, "{kappa:?}");
        let worst = a
            .got
            .iter()
            .zip(&b.got)
            .map(|(x, y)| (x[0] - y[0]).abs().max((x[1] - y[1]).abs()))
            .fold(0.0, f64::max);
        assert!(worst < 1e-8, "kappa {kappa:?}: {worst:e}");
    }
}

/// Synthesises a characteristic log (20 s, N = 2.2 N: Rs 0.924 N, Rd
/// 0.748 N, the bundled rig's realistic sensors with their zero offsets)
/// with the real-pad options `extra`, fits it and returns the fit entry.
fn synth_and_fit(
    dir: &std::path::Path,
    name: &str,
    seed: u64,
    extra: &[&str],
) -> serde_json::Value {
    synth_and_fit_for(dir, name, seed, 20.0, extra)
}

/// [`synth_and_fit`] with a log of `secs` seconds.
fn synth_and_fit_for(
    dir: &std::path::Path,
    name: &str,
    seed: u64,
    secs: f64,
    extra: &[&str],
) -> serde_json::Value {
    let mut args: Vec<String> = ["--normal-force", "2.2", "--duration-s"]
        .map(String::from)
        .to_vec();
    args.extend([secs.to_string(), "--seed".into(), seed.to_string()]);
    args.extend(extra.iter().map(|a| a.to_string()));
    synth_to_and_fit(&dir.join(name), &args)
}

/// `fit --json` of `log`: its fit entry.
fn fit_entry(log: &std::path::Path) -> serde_json::Value {
    fit_entry_with(log, &[])
}

/// [`fit_entry`] with the options `opts` (`--law stribeck`).
fn fit_entry_with(log: &std::path::Path, opts: &[&str]) -> serde_json::Value {
    let o = common::bin()
        .arg("fit")
        .arg(log)
        .args(opts)
        .arg("--json")
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    v["fits"][0].clone()
}

fn covers(v: &serde_json::Value, key: &str, truth: f64) -> bool {
    let iv = &v[key];
    iv[0].as_f64().unwrap() <= truth && truth <= iv[1].as_f64().unwrap()
}

/// A slider held for good behind a compliant contact (the bundled rig at
/// 30 N, kt 13400 N/m: Rs 12.6 N is never reached): M2 rides on the
/// contact spring, so its velocity shows no stick, and the fit once read a
/// static/dynamic law with Rs 0.037 N (untested, refinement failed). It is
/// stuck, with a lower bound below the true Rs and the `slider_held`
/// warning giving the contact stiffness (within 2 %).
#[test]
fn a_slider_held_behind_a_contact_is_stuck() {
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("held.mcap");
    let o = common::bin()
        .args(["synth", "--normal-force", "30", "--seed", "5"])
        .args(["--contact-stiffness-n-per-m", "13400", "--out"])
        .arg(&log)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let f = fit_entry(&log);
    assert_eq!(f["stuck"], true, "{f}");
    assert_eq!(f["never_sticks"], false);
    let lb = f["r_s_lower_bound_n"].as_f64().unwrap();
    assert!(lb > 2.0 && lb <= 12.6, "{lb}");
    let codes = f["warning_codes"].as_array().unwrap();
    let i = codes
        .iter()
        .position(|c| c == "slider_held")
        .unwrap_or_else(|| panic!("{codes:?}"));
    let w = f["warnings"][i].as_str().unwrap();
    let kt: f64 = w
        .split("kt ")
        .nth(1)
        .and_then(|t| t.split(' ').next())
        .and_then(|t| t.parse().ok())
        .unwrap_or_else(|| panic!("{w}"));
    assert!((kt / 13400.0 - 1.0).abs() < 0.02, "{w}");
}

/// A pad whose static threshold is lower backwards (Rs⁻ 0.80 N against
/// Rs⁺ 0.924 N, equal dynamic levels) sticks at one reversal only: the
/// screen sees breakaways towards + only, the split threshold wins the
/// criterion, Rs⁺ and Rd are measured (intervals covering the truth) and
/// Rs⁻ is only bounded (null, its interval the bounds, covering 0.80 N).
#[test]
fn direction_dependent_pad_is_identified() {
    let dir = tempfile::tempdir().unwrap();
    let f = synth_and_fit(
        dir.path(),
        "drop.mcap",
        4,
        &["--rs-minus-n", "0.80", "--rd-minus-n", "0.748"],
    );
    assert_eq!(f["direction_dependent"], true, "{f:#}");
    assert_eq!(f["law"], "static-dynamic");
    assert!(
        covers(&f, "r_s_interval_n", 0.924),
        "{}",
        f["r_s_interval_n"]
    );
    assert!(
        covers(&f, "r_d_interval_n", 0.748),
        "{}",
        f["r_d_interval_n"]
    );
    assert!((f["r_s_n"].as_f64().unwrap() / 0.924 - 1.0).abs() < 0.03);
    assert!(f["r_s_minus_n"].is_null());
    assert!(
        covers(&f, "r_s_minus_interval_n", 0.80),
        "{}",
        f["r_s_minus_interval_n"]
    );
    assert_eq!(f["r_d_minus_n"], f["r_d_n"]);
    let screen = &f["pad_screen"]["direction"];
    assert_eq!(screen["flagged"], true);
    assert!(f["warning_codes"]
        .as_array()
        .unwrap()
        .iter()
        .any(|c| c == "direction_dependent"));
}

/// Pre-sliding of 80 µm (kt = 11 550 N/m, κ = 17.24) and of 20 µm (kt =
/// 46 200 N/m, κ = 68.96): the contact rings on its spring after every
/// slip, so the velocity shows no stick; the rigid laws fail the adequacy
/// test, the contact spring is refined and chosen, κ within 20 % with an
/// interval covering it, Rd covered. At 80 µm Rs is measured (covered);
/// at 20 µm the threshold's extra deflection (Rs − Rd)/kt = 3.8 µm is
/// below what the log resolves: Rs null, not a number that misses, its
/// interval the bounds the profile in Rs gives, and κ's interval widened
/// over every admitted threshold (also on a 12-s log of that pad).
#[test]
fn compliant_contacts_are_identified() {
    let dir = tempfile::tempdir().unwrap();
    // (kt N/m, seed, seconds, whether the log resolves Rs above Rd.)
    for (kt, seed, secs, rs_known) in [
        (11550.0, 6, 20.0, true),
        (46200.0, 5, 20.0, false),
        (46200.0, 5, 12.0, false),
    ] {
        let kappa = kt / 670.0;
        let f = synth_and_fit_for(
            dir.path(),
            &format!("kt{kt}_{secs}.mcap"),
            seed,
            secs,
            &["--contact-stiffness-n-per-m", &kt.to_string()],
        );
        let label = format!("kt {kt}, {secs} s: {f:#}");
        let k = f["contact_stiffness"].as_f64().expect(&label);
        // The issue's criterion (within 20 % or inside the interval), and
        // the interval covers κ where the threshold is unresolved too: it
        // holds every threshold the log admits (the profile in Rs). Before
        // the profile the 12-s log gave 69.85 [69.58, 70.14] (truth 68.96).
        assert!((k / kappa - 1.0).abs() < 0.2, "{label}");
        assert!(covers(&f, "contact_stiffness_interval", kappa), "{label}");
        assert!(f["contact_stiffness_lower_bound"].is_null());
        assert!((f["kt_n_per_m"].as_f64().unwrap() / k - 670.0).abs() < 1e-6);
        assert!(covers(&f, "r_d_interval_n", 0.748), "{label}");
        assert_eq!(f["adequate"], true, "{label}");
        // Measured, or bounded: [Rd's low end, the profile's upper bound],
        // a finite bound above the truth. The bound holds the channels'
        // alignment (the profile again with the drive's and x2's records
        // shifted by ± their standard uncertainty, 167 µs and 77 µs here:
        // the highest admitted threshold rises from 0.947 N to 1.394 N
        // and 1.176 N): 1.75 N (20 s) and 1.79 N (12 s), where it was
        // 0.952 N and 1.048 N without that part. Not a blow-up: the
        // deviance's change over its slope, extrapolated, had put such
        // bounds at 10–18 times the truth on the compliant study.
        assert!(covers(&f, "r_s_interval_n", 0.924), "{label}");
        if !rs_known {
            assert!(f["r_s_n"].is_null() && f["rho_s"].is_null(), "{label}");
            let hi = f["r_s_interval_n"][1].as_f64().unwrap();
            assert!(hi < 2.5 * 0.924, "{label}");
        }
        assert_eq!(f["direction_dependent"], false);
    }
}

/// A Stribeck pad behind a compliant contact (M1 3 kg, M2 1 kg, K1 200
/// N/m, K2 500 N/m; Rs 0.581 N, Rd 0.394 N, v_s 6.8 mm/s, kt 6272 N/m:
/// 93 µm of pre-sliding), sensors drawn from realistic specifications (no
/// accelerometer). The decreasing law's optimum has x1's gain at the edge
/// of its range (2, where the model one step beyond cannot be simulated);
/// the central differences of its Jacobian failed there, so the output
/// error gave up and the equation error's decreasing law was reported, Rd
/// 0.071 N (82 % low). With one-sided differences at the edge the
/// refinement goes on (a contact spring on the static/dynamic family): no
/// family here is a Stribeck pad behind a spring, so the fit is flagged,
/// but Rd, Rs and κ are covered.
#[test]
fn a_fit_at_the_edge_of_a_gain_range_still_gets_intervals() {
    let (rs, rd, kt) = (0.581230932033889, 0.3937837263132712, 6271.989373566756);
    let f = synth_with_sensors_and_fit(
        "--m1-kg 3 --m2-kg 1 --k1-n-per-m 200 --k2-n-per-m 500 \
         --d-n-s-per-m 0.08944271909999159 --amplitude-m 0.002 \
         --frequency-hz 2.549378372768607 --normal-force 2.0 --law stribeck \
         --stribeck-velocity-m-per-s 0.006826934655731421 --rs-n 0.581230932033889 \
         --rd-n 0.3937837263132712 --contact-stiffness-n-per-m 6271.989373566756 --seed 703",
        SENSORS_S003,
    );
    let label = format!("{f:#}");
    assert!(
        !warned(&f, "output-error refinement not possible"),
        "{label}"
    );
    assert_covered(&f, rs, rd, kt / 500.0);
    assert_eq!(f["adequate"], false, "{label}");
}

/// Stribeck pads behind a contact spring (`scripts/stribeck_compliant_study.py`,
/// s001 and s004: two rigs, sensors drawn as `scripts/adequacy_study.py`
/// draws them, with an accelerometer; 124 µm and 35 µm of pre-sliding).
/// Before session 32 the Stribeck family got a contact spring only where
/// its rigid law had been chosen: s001's small drop (Rs 0.369 N over Rd
/// 0.314 N) read as Coulomb + contact, κ 2.3 % low with an interval that
/// missed; s004's as static/dynamic + contact, κ 30 % low. Now the
/// Stribeck family with the chosen law's contact is refined where x2's
/// residuals follow the velocity, from the static/dynamic + contact fit,
/// each velocity-scale start minimised again until it stops falling, and
/// replaces the law where the accelerometer's force record agrees.
#[test]
fn stribeck_pads_behind_a_contact_are_read_as_such() {
    for (args, sensors, (rs, rd, kt, k2)) in [
        (
            "--m1-kg 5 --m2-kg 1 --k1-n-per-m 400 --k2-n-per-m 400 --d-n-s-per-m 0.1 \
             --amplitude-m 0.0025 --frequency-hz 1.471260998300953 --normal-force 2.0 \
             --rs-n 0.3692489287159804 --rd-n 0.3136437757959605 --law stribeck \
             --stribeck-velocity-m-per-s 0.011778684091468719 \
             --contact-stiffness-n-per-m 2989.3555414306124 --seed 701",
            SENSORS_STRIBECK_S001,
            (
                0.3692489287159804,
                0.3136437757959605,
                2989.3555414306124,
                400.0,
            ),
        ),
        (
            "--m1-kg 8.35 --m2-kg 2.0875 --k1-n-per-m 670 --k2-n-per-m 670 \
             --d-n-s-per-m 0.11219458543084866 --amplitude-m 0.0025 \
             --frequency-hz 1.556278000300377 --normal-force 2.0 --rs-n 0.4927369242325076 \
             --rd-n 0.4411561034979252 --law stribeck \
             --stribeck-velocity-m-per-s 0.011672106538749168 \
             --contact-stiffness-n-per-m 13954.32272568054 --seed 704",
            SENSORS_STRIBECK_S004,
            (
                0.4927369242325076,
                0.4411561034979252,
                13954.32272568054,
                670.0,
            ),
        ),
    ] {
        let f = synth_with_sensors_and_fit(args, sensors);
        let label = format!("{f:#}");
        assert_eq!(f["law"], "stribeck", "{label}");
        assert_eq!(f["adequate"], true, "{label}");
        assert_covered(&f, rs, rd, kt / k2);
    }
}

/// c003 of the compliant study (`scripts/compliant_study.py`: M1 3 kg, M2
/// 1 kg, K1 200 N/m, K2 500 N/m; a static/dynamic pad, Rs 0.507 N, Rd
/// 0.369 N, kt 20 278 N/m, 25 µm of pre-sliding; its sensors, with an
/// accelerometer). x2's residuals under static/dynamic + contact follow the
/// drive phase (z 6.8), so the Stribeck family behind the contact is tried
/// ([`stribeck_pads_behind_a_contact_are_read_as_such`]); it wins the
/// criterion with a hump 27 % below the true threshold (Rs 0.372 N, its
/// interval missing the truth, Rd's too), but the accelerometer's force
/// residual rises from 1.15 to 1.38 of its noise: the law stays
/// static/dynamic + contact, every interval holding its truth. Without
/// the accelerometer the positions alone cannot tell the two (the
/// Stribeck law read Rs 0.372 N [0.366, 0.378]): the law is not replaced.
#[test]
fn a_static_dynamic_pad_behind_a_contact_is_not_read_as_stribeck() {
    let (rs, rd, kt) = (0.5074511777422439, 0.3690295985825405, 20278.15245341368);
    let mut without: serde_json::Value = serde_json::from_str(SENSORS_C003).unwrap();
    without["a2"] = serde_json::Value::Null;
    for sensors in [SENSORS_C003.to_string(), without.to_string()] {
        let f = synth_with_sensors_and_fit(
            "--m1-kg 3 --m2-kg 1 --k1-n-per-m 200 --k2-n-per-m 500 \
             --d-n-s-per-m 0.08944271909999159 --amplitude-m 0.002 \
             --frequency-hz 2.1089726154231485 --normal-force 2.0 \
             --rs-n 0.5074511777422439 --rd-n 0.3690295985825405 --law static-dynamic \
             --contact-stiffness-n-per-m 20278.15245341368 --seed 503",
            &sensors,
        );
        let label = format!("{f:#}");
        assert_eq!(f["law"], "static-dynamic", "{label}");
        assert_eq!(f["adequate"], true, "{label}");
        assert_covered(&f, rs, rd, kt / 500.0);
        // Without the accelerometer the Stribeck reading is reported
        // beside the chosen law (its numbers, ΔBIC, and the intervals
        // holding both); with it, the accelerometer refutes it.
        let accelerometer = sensors == SENSORS_C003;
        assert_eq!(
            warned(&f, "a Stribeck law behind the contact"),
            !accelerometer,
            "{label}"
        );
        // The readings disagree on Rs beyond their intervals (0.507 N
        // against 0.372 N [0.366, 0.378]): without the accelerometer the
        // log does not tell which, so Rs has no number, only the interval
        // holding both.
        assert_eq!(f["r_s_n"].is_null(), !accelerometer, "{label}");
        assert_eq!(
            warned(&f, "this log does not identify Rs"),
            !accelerometer,
            "{label}"
        );
    }
}

/// Whether a warning of the fit entry `f` contains `s`.
fn warned(f: &serde_json::Value, s: &str) -> bool {
    f["warnings"]
        .as_array()
        .unwrap()
        .iter()
        .any(|w| w.as_str().unwrap().contains(s))
}

/// s000 of `scripts/stribeck_compliant_study.py`: a Stribeck pad (Rs
/// 0.986 N, Rd 0.723 N, v_s 5.1 mm/s) behind a contact (kt 25 513 N/m,
/// 39 µm of pre-sliding) on rig B (M1 8.35 kg, K2 670 N/m), sensors
/// without an accelerometer, x2 lagging. `--law auto` reads it as
/// static/dynamic + contact (Rs +58 %, κ −18 %): the positions prefer the
/// Stribeck law behind the contact, but without an accelerometer the tool
/// cannot tell it from a filtered x2 (c003,
/// [`a_static_dynamic_pad_behind_a_contact_is_not_read_as_stribeck`]), so
/// it says so with both readings, and the intervals hold both (before
/// session 33 Rs's, Rd's and κ's missed); since session 37 Rs and κ,
/// on which the readings disagree, are reported as those intervals
/// without a number. `--law stribeck` once gave up
/// (the rigid Stribeck law's intervals not formed, reported as "too few
/// shooting segments", the equation-error decreasing law used): it now
/// reaches the contact as `--law auto` does (static/dynamic, its contact,
/// the Stribeck law from it; the lags where the lag-free refinement
/// fails) and is within 6 % with every interval covering.
#[test]
fn a_stribeck_pad_behind_a_contact_without_an_accelerometer() {
    let tmp = tempfile::tempdir().unwrap();
    let log = synth_with_sensor_file(
        tmp.path(),
        SENSORS_STRIBECK_S000,
        "s000.mcap",
        "--m1-kg 8.35 --m2-kg 2.0875 --k1-n-per-m 670 --k2-n-per-m 670 \
             --d-n-s-per-m 0.11219458543084866 --amplitude-m 0.0025 \
             --frequency-hz 1.805502038889993 --normal-force 2.0 \
             --rs-n 0.9859327653273926 --rd-n 0.7226247545938849 --law stribeck \
             --stribeck-velocity-m-per-s 0.005106886016104284 \
             --contact-stiffness-n-per-m 25513.475626173822 --seed 700 --duration-s 20",
    );
    let (rs, rd, kappa) = (
        0.9859327653273926,
        0.7226247545938849,
        25513.475626173822 / 670.0,
    );
    let auto = fit_entry(&log);
    let label = format!("{auto:#}");
    assert!(
        warned(&auto, "a Stribeck law behind the contact"),
        "{label}"
    );
    assert_covered(&auto, rs, rd, kappa);
    // The two readings disagree on Rs (1.555 N against 0.935 N [0.837,
    // 1.033]) and κ (31.1 against 38.9 [37.7, 40.0]) beyond their
    // intervals: neither gets a number (before session 37: Rs +58 %, κ
    // −18 % as the numbers), Rd does (both readings agree on it).
    assert!(auto["r_s_n"].is_null(), "{label}");
    assert!(auto["contact_stiffness"].is_null(), "{label}");
    assert!(auto["kt_n_per_m"].is_null(), "{label}");
    assert!(
        warned(&auto, "this log does not identify Rs and κ"),
        "{label}"
    );
    let rd_fit = auto["r_d_n"].as_f64().unwrap();
    assert!((rd_fit / rd - 1.0).abs() < 0.03, "{label}");
    let forced = fit_entry_with(&log, &["--law", "stribeck"]);
    let label = format!("{forced:#}");
    assert_eq!(forced["law"], "stribeck", "{label}");
    assert_eq!(forced["adequate"], true, "{label}");
    assert_covered(&forced, rs, rd, kappa);
    for (key, truth) in [("r_s_n", rs), ("r_d_n", rd), ("contact_stiffness", kappa)] {
        let v = forced[key].as_f64().unwrap();
        assert!(
            (v / truth - 1.0).abs() < 0.06,
            "{key} {v} for {truth}: {label}"
        );
    }
}

/// Rs's, Rd's and κ's intervals in the fit entry `f` hold the truths.
fn assert_covered(f: &serde_json::Value, rs: f64, rd: f64, kappa: f64) {
    for (key, truth) in [
        ("r_s_interval_n", rs),
        ("r_d_interval_n", rd),
        ("contact_stiffness_interval", kappa),
    ] {
        assert!(covers(f, key, truth), "{key} misses {truth}: {f:#}");
    }
}

/// Synthesises a 20-s log with the options `args` (rig, pad, seed;
/// whitespace-separated) and the sensors `sensors` (`synth --sensors`
/// JSON) and fits it.
fn synth_with_sensors_and_fit(args: &str, sensors: &str) -> serde_json::Value {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let sensors_json = dir.join("sensors.json");
    std::fs::write(&sensors_json, sensors).unwrap();
    let mut args: Vec<String> = args.split_whitespace().map(String::from).collect();
    args.extend(["--duration-s", "20", "--sensors"].map(String::from));
    args.push(sensors_json.to_str().unwrap().into());
    synth_to_and_fit(&dir.join("log.mcap"), &args)
}

/// c021 of the compliant study (`scripts/compliant_study.py`: M1 5 kg, M2
/// 1 kg, K1 = K2 = 400 N/m; Rs 0.536 N, Rd 0.448 N, kt 3921 N/m, 137 µm of
/// pre-sliding; its sensors): the log does not resolve Rs above Rd, and
/// the profile's upper bound, with the gains' part only, was 0.533 N, 0.6 %
/// short of the truth. With the alignment's part (the profile again with
/// the drive's and x2's records shifted by ± their standard uncertainty)
/// it is 0.589 N.
#[test]
fn the_threshold_bound_holds_the_channels_alignment() {
    let (rs, rd, kt) = (0.5363204051584902, 0.4476822766325222, 3920.864781846307);
    let f = synth_with_sensors_and_fit(
        "--m1-kg 5 --m2-kg 1 --k1-n-per-m 400 --k2-n-per-m 400 --d-n-s-per-m 0.1 \
         --amplitude-m 0.0025 --frequency-hz 1.906684915302423 --normal-force 2.0 \
         --law static-dynamic --rs-n 0.5363204051584902 --rd-n 0.4476822766325222 \
         --contact-stiffness-n-per-m 3920.864781846307 --seed 521",
        SENSORS_C021,
    );
    let label = format!("{f:#}");
    assert!(f["r_s_n"].is_null(), "{label}");
    assert_covered(&f, rs, rd, kt / 400.0);
    assert!(
        f["r_s_interval_n"][1].as_f64().unwrap() < 1.5 * rs,
        "{label}"
    );
}

/// The sensors of [`the_threshold_bound_holds_the_channels_alignment`].
const SENSORS_C021: &str = include_str!("sensors/c021.json");

/// The sensors of [`a_fit_at_the_edge_of_a_gain_range_still_gets_intervals`]
/// (`synth --sensors`, drawn as `scripts/adequacy_study.py` draws them).
const SENSORS_S003: &str = include_str!("sensors/s003.json");

/// Synthesises a 20-s characteristic log of a static/dynamic pad behind
/// a contact spring kt (N/m) on the study rig at `freq_hz` (the options
/// `extra` added: seed, sensors, delays) to `log` and fits it.
fn synth_compliant_and_fit(
    log: &std::path::Path,
    freq_hz: &str,
    (rs, rd, kt): (f64, f64, f64),
    extra: &[&str],
) -> serde_json::Value {
    let mut args: Vec<String> = common::STUDY_RIG.iter().map(|a| a.to_string()).collect();
    args.extend(
        [
            "--frequency-hz",
            freq_hz,
            "--law",
            "static-dynamic",
            "--rs-n",
            &rs.to_string(),
            "--rd-n",
            &rd.to_string(),
            "--contact-stiffness-n-per-m",
            &kt.to_string(),
            "--duration-s",
            "20",
        ]
        .map(String::from),
    );
    args.extend(extra.iter().map(|a| a.to_string()));
    synth_to_and_fit(log, &args)
}

/// `stickslip synth ARGS --out LOG`, then the fit entry of `log`.
fn synth_to_and_fit(log: &std::path::Path, args: &[String]) -> serde_json::Value {
    synth_to(log, args);
    fit_entry(log)
}

/// `synth ARGS --out LOG`, which must succeed.
fn synth_to<S: AsRef<std::ffi::OsStr>>(log: &std::path::Path, args: impl IntoIterator<Item = S>) {
    let o = common::bin()
        .arg("synth")
        .args(args)
        .arg("--out")
        .arg(log)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

/// A compliant contact on another rig (M1 3 kg, M2 1 kg, K1 200 N/m, K2
/// 500 N/m; Rs 0.585 N, Rd 0.366 N, κ 9.06, 130 µm of pre-sliding; the
/// typical sensors) whose x1 record lags by 0.7 ms, below one sample and
/// declared nowhere. Behind the contact the threshold shows only as the
/// extra deflection before each breakaway, so the lag matters: before
/// session 27 the lag was reported, not applied, and Rs came out 3.5 %
/// low with an interval that missed, the law adequate; with x2's shift
/// applied but the contact refined from the best-ranked κ start only, the
/// fit ended at κ 83 with a decreasing law 37 % below Rd. Now: the shift
/// applied, every κ start refined, the alignment's uncertainty in the
/// intervals: κ, Rs and Rd within 3 % and covered.
#[test]
fn a_sub_sample_lag_behind_a_compliant_contact_is_corrected() {
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("lagged.mcap");
    let (rs, rd, kt) = (0.5852552822899103, 0.3662798040994145, 4528.506141633922);
    let f = &synth_compliant_and_fit(
        &log,
        "1.7310587367826507",
        (rs, rd, kt),
        &["--channel-delay-s", "x1=0.0007", "--seed", "2"],
    );
    let label = format!("{f:#}");
    // The lag was measured and x2 (the other channels) shifted by it.
    let x2 = f["channel_delays_s"]["x2"].as_f64().expect(&label);
    assert!((x2 - 0.0007).abs() < 0.0002, "x2 shift {x2}");
    assert_eq!(f["law"], "static-dynamic", "{label}");
    assert_eq!(f["adequate"], true, "{label}");
    let kappa = kt / 500.0;
    let k = f["contact_stiffness"].as_f64().expect(&label);
    assert!((k / kappa - 1.0).abs() < 0.03, "κ {k} for {kappa}");
    assert!(covers(f, "contact_stiffness_interval", kappa), "{label}");
    let fitted_rs = f["r_s_n"].as_f64().expect(&label);
    assert!(
        (fitted_rs / rs - 1.0).abs() < 0.03,
        "Rs {fitted_rs} for {rs}"
    );
    assert!(covers(f, "r_s_interval_n", rs), "{}", f["r_s_interval_n"]);
    assert!(covers(f, "r_d_interval_n", rd), "{}", f["r_d_interval_n"]);
}

/// A rigid, symmetric pad (the bundled char_N4.mcap): no extension is
/// chosen, and the sticks bound κ from below (x2 stays flat while
/// sticking to within its noise).
#[test]
fn rigid_symmetric_pad_keeps_the_paper_model() {
    use common::bin;
    let log = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("datasets/char_N4.mcap");
    let o = bin().arg("fit").arg(&log).arg("--json").output().unwrap();
    assert!(o.status.success());
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let f = &v["fits"][0];
    assert_eq!(f["direction_dependent"], false);
    assert!(f["contact_stiffness"].is_null() && f["rho_s_minus"].is_null());
    let lb = f["contact_stiffness_lower_bound"].as_f64().unwrap();
    assert!(lb > 100.0, "{lb}");
    assert_eq!(f["pad_screen"]["direction"]["flagged"], false);
    assert_eq!(f["pad_screen"]["compliance"]["flagged"], false);
    // A smooth cost: the secants over the intervals agree with the
    // tangent (to 0.2 % on the bundled logs), and no `rough_cost`.
    let r = f["output_error"]["interval_secant_ratio"].as_f64().unwrap();
    assert!((1.0..1.01).contains(&r), "{r}");
    assert!(!f["warning_codes"].to_string().contains("rough_cost"));
}

/// `validate` simulates the pad the fit found: a characteristic log of
/// the 80-µm compliant pad (kt 11 550 N/m) and a stepped sweep of the same
/// pad. Before, the prediction used the rigid symmetric law and missed
/// the measured curve by 20 % (nrms of A1, replay coverage 1 of 5); with
/// the contact spring in every prediction (and κ drawn in the band) the
/// curve is met to 0.2 % and the bands cover it.
#[test]
fn validation_simulates_the_fitted_contact_spring() {
    use common::bin;
    let dir = tempfile::tempdir().unwrap();
    let (ch, sw) = (dir.path().join("ch.mcap"), dir.path().join("sw.mcap"));
    let synth = |out: &std::path::Path, extra: &[&str]| {
        let o = bin()
            .args([
                "synth",
                "--normal-force",
                "2.2",
                "--contact-stiffness-n-per-m",
                "11550",
            ])
            .args(extra)
            .arg("--out")
            .arg(out)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    };
    synth(&ch, &["--duration-s", "20", "--seed", "6"]);
    synth(
        &sw,
        &[
            "--test",
            "stepped",
            "--seed",
            "7",
            "--setpoints-hz",
            "1.2,1.6,1.9,2.2,2.6",
            "--dwell-s",
            "10",
        ],
    );
    let o = bin()
        .args(["validate", "--json", "--characteristic"])
        .arg(&ch)
        .arg("--sweep")
        .arg(&sw)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let s = &v["score"];
    let nrms = s["nrms_amplitude1"].as_f64().expect("score");
    assert!(nrms < 0.02, "{s:#}");
    for key in ["replay_coverage_amplitude1", "replay_coverage_amplitude2"] {
        assert!(s[key].as_f64().unwrap() >= 0.8, "{key}: {s:#}");
    }
}

/// A compliant contact whose response is a long-period orbit (the
/// compliant study's c015: static/dynamic pad, 29 µm of pre-sliding on
/// the study rig at η 0.46; the true motion repeats only after about 54
/// drive periods, where every other log of the study is period-1). The
/// contact rings after every slip and its velocity grazes zero, so
/// whether a short stick happens switches with the parameters and the
/// output-error cost jumps: the fit once ended on a decreasing law with
/// Rd 6.6 % low, and with every donor start minimised its tangent
/// intervals (Rs ±0.9 %, κ ±1.5 %) missed Rs and κ. Now the levels come
/// within 3 %, the cost's roughness is reported (`rough_cost`: the
/// secants over the intervals stray from the tangent), and every interval
/// or bound holds the truth.
#[test]
fn a_long_period_compliant_orbit_finds_the_levels() {
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("c015.mcap");
    let sensors = dir.path().join("sensors.json");
    // The study's sensors for this log (scripts/compliant_study.py, seed 515).
    let pos = |noise: f64, gain: f64, offset: f64, lp: &str, buf: f64, lost: f64, drop: f64| {
        format!(
            r#"{{"rate_hz": 1000.0, "noise": {noise}, "quant": 0.0, "gain": {gain}, "offset": {offset}, "lowpass_hz": {lp}, "buffer_s": {buf}, "start_offset_ns": null, "jitter_ns": 10000, "p_lost_buffer": {lost}, "p_dropout": {drop}, "dropout_burst_max": 4, "noise_correlation_s": 0.0}}"#
        )
    };
    let json = format!(
        r#"{{"x0": {}, "x1": {}, "x2": {}, "v2": {}, "a2": null, "normal_force": {}}}"#,
        pos(
            4.445141857772943e-06,
            1.0016920936858627,
            -0.00019117505567669375,
            "130.80469713794898",
            0.1,
            0.01,
            0.0
        ),
        pos(
            1.2952449869121874e-06,
            1.0025983703214159,
            0.00154856125745193,
            "null",
            0.05,
            0.0,
            0.0
        ),
        pos(
            7.100258488933575e-06,
            1.0049855067538414,
            0.0017291303405120428,
            "null",
            0.2,
            0.0,
            0.0002
        ),
        r#"{"rate_hz": 1000.0, "noise": 0.000460402308688974, "quant": 1e-05, "gain": 0.9979651431402498, "offset": -1.0412201106375687e-05, "lowpass_hz": 280.11657023159194, "buffer_s": 0.2, "start_offset_ns": null, "jitter_ns": 10000, "p_lost_buffer": 0.01, "p_dropout": 0.0, "dropout_burst_max": 4, "noise_correlation_s": 0.0}"#,
        r#"{"rate_hz": 10.0, "noise": 0.0, "quant": 0.01, "gain": 1.00404190261198, "offset": 0.0011224126198191263, "lowpass_hz": null, "buffer_s": 0.5, "start_offset_ns": null, "jitter_ns": 10000, "p_lost_buffer": 0.01, "p_dropout": 0.0, "dropout_burst_max": 4, "noise_correlation_s": 0.0}"#,
    );
    std::fs::write(&sensors, json).unwrap();
    let (rs, rd, kt) = (0.5271203268220095, 0.4494496858305175, 17982.038514015785);
    let sensors = sensors.to_str().unwrap();
    let f = &synth_compliant_and_fit(
        &log,
        "1.6427615600187577",
        (rs, rd, kt),
        &["--seed", "515", "--sensors", sensors],
    );
    let label = format!("{f:#}");
    let codes = f["warning_codes"].to_string();
    assert!(codes.contains("rough_cost"), "{codes}");
    assert!(f["output_error"]["interval_secant_ratio"].as_f64().unwrap() >= 1.25);
    // Rs measured within 3 %, or only bounded: either way its interval
    // (the bounds where unresolved) holds the truth.
    if let Some(fitted_rs) = f["r_s_n"].as_f64() {
        assert!(
            (fitted_rs / rs - 1.0).abs() < 0.03,
            "Rs {fitted_rs} for {rs}"
        );
    }
    assert!(covers(f, "r_s_interval_n", rs), "{}", f["r_s_interval_n"]);
    let fitted_rd = f["r_d_n"].as_f64().expect(&label);
    assert!(
        (fitted_rd / rd - 1.0).abs() < 0.03,
        "Rd {fitted_rd} for {rd}"
    );
    assert!(covers(f, "r_d_interval_n", rd), "{}", f["r_d_interval_n"]);
    let kappa = kt / 500.0;
    let k = f["contact_stiffness"].as_f64().expect(&label);
    assert!((k / kappa - 1.0).abs() < 0.05, "κ {k} for {kappa}");
    assert!(covers(f, "contact_stiffness_interval", kappa), "{label}");
}

/// The sensors of s004 in [`stribeck_pads_behind_a_contact_are_read_as_such`].
const SENSORS_STRIBECK_S004: &str = include_str!("sensors/stribeck_s004.json");

/// The sensors of s001 in [`stribeck_pads_behind_a_contact_are_read_as_such`].
const SENSORS_STRIBECK_S001: &str = include_str!("sensors/stribeck_s001.json");

/// The sensors of [`a_stribeck_pad_behind_a_contact_without_an_accelerometer`]
/// (no accelerometer).
/// Writes `sensors` (a sensor model's JSON) and a log `name` made by
/// `synth ARGS --sensors …` into `dir`; the log's path.
fn synth_with_sensor_file(
    dir: &std::path::Path,
    sensors: &str,
    name: &str,
    args: &str,
) -> std::path::PathBuf {
    let file = dir.join("sensors.json");
    std::fs::write(&file, sensors).unwrap();
    let log = dir.join(name);
    let o = common::bin()
        .arg("synth")
        .args(args.split_whitespace())
        .arg("--sensors")
        .arg(&file)
        .arg("--out")
        .arg(&log)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    log
}

const SENSORS_STRIBECK_S000: &str = include_str!("sensors/stribeck_s000.json");
const SENSORS_STRIBECK_S006: &str = include_str!("sensors/stribeck_s006.json");

/// The sensors of [`a_static_dynamic_pad_behind_a_contact_is_not_read_as_stribeck`].
const SENSORS_C003: &str = include_str!("sensors/c003.json");

/// `batch --json` of characteristic logs of one static/dynamic pad (μs
/// 0.42, μd 0.34, the bundled rig) at the normal forces `forces`, seeds
/// from `seed`, each with the synth options `extra(N)`.
fn batch_of_synth_logs(
    dir: &std::path::Path,
    seed: u64,
    forces: &[f64],
    extra: impl Fn(f64) -> Vec<String>,
) -> serde_json::Value {
    let mut logs = Vec::new();
    for (i, &n) in forces.iter().enumerate() {
        let log = dir.join(format!("pad_{n}.mcap"));
        let o = common::bin()
            .args([
                "synth",
                "--test",
                "characteristic",
                "--law",
                "static-dynamic",
            ])
            .args(["--mu-s", "0.42", "--mu-d", "0.34"])
            .args(["--normal-force", &n.to_string()])
            .args(extra(n))
            .args(["--seed", &(seed + i as u64).to_string(), "--out"])
            .arg(&log)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        logs.push(log);
    }
    common::json_of(common::bin().arg("batch").args(&logs).arg("--json"))
}

/// The batch simulates the contact spring its logs fitted (issue 34): one
/// compliant pad (the bundled rig, μs 0.42, μd 0.34, kt 11 550 N/m, κ
/// 17.24, 80–140 µm of pre-sliding at 4–7 N) at three normal forces. Every
/// log fits κ, the batch combines them (within 3 % of the truth) and
/// its worst case at the recommended setting is the compliant pad's
/// (within 2 % of the worst case of the true pad over the batch's whole η
/// grid), not the rigid pad's, which lies more than twice that away (5.7 %
/// below it since session 38: the true pad's worst case is the response
/// from rest that wanders at η 0.80, A1 1.38, which shooting used to
/// replace by a weakly stable orbit of A1 1.14, then 17 % below the rigid
/// pad's).
#[test]
fn the_batch_simulates_the_fitted_contact_spring() {
    use stickslip::batch::{worst_case, BatchOptions, PadShape};
    let dir = tempfile::tempdir().unwrap();
    let kt = 11_550.0;
    let kappa = kt / 670.0;
    let b = batch_of_synth_logs(dir.path(), 41, &[2.2, 4.0, 7.2], |_| {
        vec!["--contact-stiffness-n-per-m".into(), kt.to_string()]
    });
    let pad = &b["pad_model"];
    let k = pad["contact_stiffness"]
        .as_f64()
        .expect("a contact simulated");
    assert!((k / kappa - 1.0).abs() < 0.03, "κ {k} for {kappa}: {pad}");
    assert_eq!(pad["contact"]["logs_chosen"], 3, "{pad}");
    // One κ at every setting: no power law in N.
    assert!(pad["contact"]["by_normal_force"].is_null(), "{pad}");
    assert!(pad["rho_s_minus_ratio"].is_null(), "{pad}");
    assert!(!common::codes_of(&b).contains(&"pad_not_simulated"));
    let (rs, rd) = (
        common::f(&b["recommended_rho_s"]),
        common::f(&b["recommended_rho_d"]),
    );
    let w = common::f(&b["worst_amplitude1"]);
    let (ab, etas) = common::public_batch_grid();
    let o = BatchOptions::default();
    let on = |shape| worst_case(&ab, shape, rs, rd, &etas, &o.steady).unwrap();
    let truth = on(PadShape {
        contact_stiffness: Some(kappa),
        ..PadShape::PAPER
    });
    let rigid = on(PadShape::PAPER);
    assert!(
        (w / truth.amplitude1 - 1.0).abs() < 0.02,
        "batch W {w}, the true pad's {}, the rigid pad's {}",
        truth.amplitude1,
        rigid.amplitude1
    );
    assert!(
        (rigid.amplitude1 / truth.amplitude1 - 1.0).abs() > 0.04,
        "{rigid:?} {truth:?}"
    );
    // The robust worst case holds the pad at both ends of κ's interval
    // (at the recommended setting, within the grids' 2 %). (κ is known to
    // 0.07 % here, so its ends barely move W: the unit test
    // `batch::tests::the_robust_worst_case_holds_every_pad_variant` is the
    // one that tells the variants apart.)
    assert_eq!(pad["contact"]["in_robust_worst_case"], true, "{pad}");
    let iv = &pad["contact"]["interval"];
    let robust = common::f(&b["worst_amplitude1_robust"]);
    for end in [common::f(&iv[0]), common::f(&iv[1])] {
        let w_end = on(PadShape {
            contact_stiffness: Some(end),
            ..PadShape::PAPER
        });
        assert!(
            robust >= 0.98 * w_end.amplitude1,
            "robust {robust}, κ {end}: {}",
            w_end.amplitude1
        );
    }
}

/// A contact whose stiffness grows with the normal force (kt = 11 550
/// N/m·(N/4 N)^0.5, κ 12.8–23.1 over 2.2–7.2 N): one κ does not explain
/// the logs (χ²/dof in the hundreds), the batch fits κ ∝ N^γ with γ's
/// interval holding 0.5 and simulates κ at each setting from it; its
/// worst case at the recommended setting is the true pad's there (within
/// 1 %).
#[test]
fn the_batch_simulates_a_contact_stiffness_that_grows_with_the_normal_force() {
    use stickslip::batch::{worst_case, BatchOptions, PadShape};
    let dir = tempfile::tempdir().unwrap();
    let kt = |n: f64| 11_550.0 * (n / 4.0).sqrt();
    let b = batch_of_synth_logs(dir.path(), 41, &[2.2, 4.0, 7.2], |n| {
        vec!["--contact-stiffness-n-per-m".into(), kt(n).to_string()]
    });
    let pad = &b["pad_model"];
    let law = &pad["contact"]["by_normal_force"];
    assert!(law.is_object(), "a power law in N: {pad}");
    let g = common::f(&law["exponent"]);
    let (g_lo, g_hi) = (
        common::f(&law["exponent_interval"][0]),
        common::f(&law["exponent_interval"][1]),
    );
    assert!(g_lo < 0.5 && 0.5 < g_hi && (g - 0.5).abs() < 0.1, "{law}");
    // κ at the reference force within 3 % of the truth there.
    let n_ref = common::f(&law["reference_normal_force_n"]);
    let k_ref = common::f(&pad["contact_stiffness"]);
    assert!((k_ref / (kt(n_ref) / 670.0) - 1.0).abs() < 0.03, "{pad}");
    let (n, rs, rd) = (
        common::f(&b["recommended_normal_force_n"]),
        common::f(&b["recommended_rho_s"]),
        common::f(&b["recommended_rho_d"]),
    );
    let w = common::f(&b["worst_amplitude1"]);
    let (ab, etas) = common::public_batch_grid();
    let o = BatchOptions::default();
    let truth = worst_case(
        &ab,
        PadShape {
            contact_stiffness: Some(kt(n) / 670.0),
            ..PadShape::PAPER
        },
        rs,
        rd,
        &etas,
        &o.steady,
    )
    .unwrap();
    assert!(
        (w / truth.amplitude1 - 1.0).abs() < 0.01,
        "batch W {w} at {n} N, the true pad's {}",
        truth.amplitude1
    );
    assert_eq!(pad["contact"]["in_robust_worst_case"], true, "{pad}");
}

/// The batch simulates the split static threshold its logs fitted: one
/// pad whose threshold towards − is 0.88 of the one towards + (μs 0.42,
/// μd 0.34 both ways) at three normal forces. The two higher settings
/// resolve Rs⁻, the lowest bounds it; the batch simulates ρs⁻/ρs⁺ within
/// 2 % of 0.88.
#[test]
fn the_batch_simulates_the_fitted_split_threshold() {
    let dir = tempfile::tempdir().unwrap();
    let b = batch_of_synth_logs(dir.path(), 61, &[2.2, 4.0, 7.2], |n| {
        vec!["--rs-minus-n".into(), (0.88 * 0.42 * n).to_string()]
    });
    let pad = &b["pad_model"];
    let r = pad["rho_s_minus_ratio"]
        .as_f64()
        .expect("a split simulated");
    assert!((r / 0.88 - 1.0).abs() < 0.02, "{pad}");
    assert!(pad["contact_stiffness"].is_null(), "{pad}");
    assert_eq!(pad["split"]["simulated"], true, "{pad}");
}

/// `fit --law stribeck` on a Stribeck pad behind a contact whose threshold
/// the log does not resolve (the Stribeck compliant study's s006: another
/// rig, M1 12 kg, M2 2.5 kg, K1 1500 N/m, K2 1000 N/m; Rs 1.751 N, Rd
/// 1.273 N, v_s 13 mm/s, κ 37.3, 47 µm of pre-sliding; no accelerometer).
/// The forced law's threshold is bounded by the profile of the static/
/// dynamic fit behind the contact, as in `--law auto`, where that fit
/// is only a helper of the forced family's starts: Rs in [1.19, 4.04] N.
/// (Before session 34 the forced fit gave Rs no value and no interval.)
#[test]
fn a_forced_stribeck_pad_behind_a_contact_bounds_its_unresolved_threshold() {
    let tmp = tempfile::tempdir().unwrap();
    let log = synth_with_sensor_file(
        tmp.path(),
        SENSORS_STRIBECK_S006,
        "s006.mcap",
        "--m1-kg 12 --m2-kg 2.5 --k1-n-per-m 1500 --k2-n-per-m 1000 \
             --d-n-s-per-m 0.1 --amplitude-m 0.003 --frequency-hz 1.6726663501316728 \
             --normal-force 2.0 --rs-n 1.751289765241449 --rd-n 1.2730136430545147 \
             --law stribeck --stribeck-velocity-m-per-s 0.013370699080826148 \
             --contact-stiffness-n-per-m 37250.9638924838 --seed 706 --duration-s 20",
    );
    let (rs, rd, kappa) = (1.751289765241449, 1.2730136430545147, 37.2509638924838);
    let forced = fit_entry_with(&log, &["--law", "stribeck"]);
    let label = format!("{forced:#}");
    assert_eq!(forced["law"], "stribeck", "{label}");
    assert!(forced["r_s_interval_n"].is_array(), "{label}");
    assert_covered(&forced, rs, rd, kappa);
}

/// A Stribeck pad whose static threshold depends on the sliding direction
/// (the bundled rig at 2.2 N: Rs 0.924 N towards +, 0.80 N towards −, Rd
/// 0.748 N both ways, v_s 5 mm/s): the Stribeck family's levels split as
/// the simple families' do (v_s shared). Before session 34 no family
/// explained it: static/dynamic, inadequate, Rs [0.84, 1.13], 40 s; now
/// the split Stribeck law, adequate, Rs⁺ within 1 % and covered, Rd
/// covered, Rs⁻ bounded or measured, its interval covering, 7 s.
#[test]
fn a_direction_dependent_stribeck_pad_is_identified() {
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("ds1.mcap");
    let o = common::bin()
        .args(["synth", "--test", "characteristic", "--normal-force", "2.2"])
        .args(["--law", "stribeck", "--rs-n", "0.924", "--rd-n", "0.748"])
        .args([
            "--stribeck-velocity-m-per-s",
            "0.005",
            "--rs-minus-n",
            "0.80",
        ])
        .args(["--seed", "7", "--out"])
        .arg(&log)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let f = fit_entry(&log);
    let label = format!("{f:#}");
    assert_eq!(f["law"], "stribeck", "{label}");
    assert_eq!(f["direction_dependent"], true, "{label}");
    assert_eq!(f["adequate"], true, "{label}");
    let rs = f["r_s_n"].as_f64().unwrap();
    assert!((rs / 0.924 - 1.0).abs() < 0.01, "{label}");
    assert!(covers(&f, "r_s_interval_n", 0.924), "{label}");
    assert!(covers(&f, "r_d_interval_n", 0.748), "{label}");
    assert!(covers(&f, "r_s_minus_interval_n", 0.80), "{label}");
}

/// Levels per direction from calibrated position zeros (the rig key
/// `position_zero_uncertainty_m`, 10 µm here; the synth draws the x0, x1,
/// x2 offsets within it): the fitted force bias is then half the
/// difference of the dynamic levels plus the zeros' part, so every level
/// of each direction is measured. On the bundled rig (Rs⁺ 0.924, Rd⁺
/// 0.748, Rs⁻ 0.84, Rd⁻ 0.68 N: 9 % apart) and on a second rig (M1 5 kg,
/// M2 1 kg, K 400 N/m; Rs⁺ 0.591, Rd⁺ 0.510, Rs⁻ 0.683, Rd⁻ 0.570 N: 12–16 %
/// apart), typical sensors: all four levels within 3 % with covering
/// intervals. A symmetric pad with calibrated zeros: no difference
/// claimed (the dynamic difference's interval holds 0, no warning). The
/// same direction-dependent pad without the key: no levels per direction
/// (the zeros are unknown), as before.
#[test]
fn calibrated_zeros_give_the_levels_of_each_direction() {
    let dir = tempfile::tempdir().unwrap();
    let second_rig: Vec<&str> = "--m1-kg 5 --m2-kg 1 --k1-n-per-m 400 --k2-n-per-m 400 \
         --d-n-s-per-m 0.1 --amplitude-m 0.0025 --frequency-hz 1.48 --normal-force 2 \
         --rs-n 0.591 --rd-n 0.510 --seed 11"
        .split_whitespace()
        .collect();
    let bundled = ["--normal-force", "2.2", "--seed", "3"];
    let calibrated = ["--position-zero-uncertainty-m", "1e-5"];
    let cases: [(&str, Vec<&str>, [f64; 4]); 3] = [
        (
            "bundled.mcap",
            [
                &bundled[..],
                &calibrated,
                &["--rs-minus-n", "0.84", "--rd-minus-n", "0.68"],
            ]
            .concat(),
            [0.924, 0.748, 0.84, 0.68],
        ),
        // The same pad as a Parquet table (1 kHz rows): there a rigid
        // Stribeck law that never sticks towards − stood in for the split
        // threshold (Rs⁺ 0.849 N, missed) until the calibrated difference
        // triggered the split wherever the log sticks.
        (
            "bundled.parquet",
            [
                &bundled[..],
                &calibrated,
                &["--rs-minus-n", "0.84", "--rd-minus-n", "0.68"],
            ]
            .concat(),
            [0.924, 0.748, 0.84, 0.68],
        ),
        (
            "second.mcap",
            [
                &second_rig[..],
                &calibrated,
                &["--rs-minus-n", "0.683", "--rd-minus-n", "0.570"],
            ]
            .concat(),
            [0.591, 0.510, 0.683, 0.570],
        ),
    ];
    let keys = [
        ("r_s_n", "r_s_interval_n"),
        ("r_d_n", "r_d_interval_n"),
        ("r_s_minus_n", "r_s_minus_interval_n"),
        ("r_d_minus_n", "r_d_minus_interval_n"),
    ];
    for (name, args, truth) in &cases {
        let log = dir.path().join(name);
        let args: Vec<String> = args.iter().map(|a| a.to_string()).collect();
        let f = synth_to_and_fit(&log, &args);
        let t: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(dir.path().join("truth.json")).unwrap())
                .unwrap();
        // (The truth names an MCAP's channels by topic, a table's by
        // quantity.)
        let sensors = &t["files"][name]["sensors"];
        for (topic, quantity) in [
            ("/drive/position", "x0"),
            ("/mass1/position", "x1"),
            ("/mass2/position", "x2"),
        ] {
            let off = sensors[topic]["offset"]
                .as_f64()
                .or(sensors[quantity]["offset"].as_f64())
                .unwrap();
            assert!(off.abs() <= 1e-5, "{name} {topic}: offset {off}");
        }
        let label = format!("{name}: {f:#}");
        assert_eq!(f["levels_gauge"], "calibrated zeros", "{label}");
        assert_eq!(f["direction_dependent"], true, "{label}");
        assert_eq!(f["levels_by_direction"]["resolved"], true, "{label}");
        for ((v, iv), t) in keys.iter().zip(truth) {
            let x = f[v].as_f64().unwrap_or_else(|| panic!("{v} null: {label}"));
            assert!((x / t - 1.0).abs() < 0.03, "{v} {x} against {t}: {label}");
            assert!(covers(&f, iv, *t), "{iv} {} misses {t}: {label}", f[iv]);
        }
        assert!(
            f["warnings"].as_array().unwrap().iter().any(|w| w
                .as_str()
                .unwrap()
                .contains("friction levels depend on the sliding direction")),
            "{label}"
        );
    }
    // Symmetric, calibrated: nothing claimed, the numbers given.
    let f = synth_to_and_fit(
        &dir.path().join("symmetric.mcap"),
        &[&bundled[..], &calibrated]
            .concat()
            .iter()
            .map(|a| a.to_string())
            .collect::<Vec<_>>(),
    );
    let label = format!("symmetric: {f:#}");
    let c = &f["levels_by_direction"];
    assert_eq!(c["resolved"], false, "{label}");
    assert!(covers(c, "dynamic_split_interval_n", 0.0), "{label}");
    assert!(f["levels_gauge"].is_null(), "{label}");
    assert_eq!(f["direction_dependent"], false, "{label}");
    assert!(f["r_d_minus_n"].is_null(), "{label}");
    assert!(
        !f["warning_codes"]
            .as_array()
            .unwrap()
            .iter()
            .any(|c| c == "direction_dependent"),
        "{label}"
    );
    // The direction-dependent pad, zeros unknown: no levels per direction.
    let args: Vec<String> = [
        &bundled[..],
        &["--rs-minus-n", "0.84", "--rd-minus-n", "0.68"],
    ]
    .concat()
    .iter()
    .map(|a| a.to_string())
    .collect();
    let f = synth_to_and_fit(&dir.path().join("unknown.mcap"), &args);
    assert!(f["levels_by_direction"].is_null(), "{f:#}");
    assert_ne!(f["levels_gauge"], "calibrated zeros");
}

/// Zeros declared on the command line (`fit --position-zero-uncertainty-m`)
/// for a log that lacks the key: the calibrated pad of
/// [`calibrated_zeros_give_the_levels_of_each_direction`] as a CSV export
/// with its `position_zero_uncertainty_m` header line removed gives no
/// levels per direction by itself, and with the option the same levels
/// as the log that carries the key; the option overrides the key (a wider
/// bound widens b's interval); a negative or non-finite bound is refused
/// before anything is read or written.
#[test]
fn zeros_declared_on_the_command_line() {
    let dir = tempfile::tempdir().unwrap();
    let keyed = dir.path().join("keyed.csv");
    synth_to(
        &keyed,
        "--normal-force 2.2 --seed 3 --position-zero-uncertainty-m 1e-5 \
         --rs-minus-n 0.84 --rd-minus-n 0.68"
            .split_whitespace(),
    );
    let text = std::fs::read_to_string(&keyed).unwrap();
    let stripped: String = text
        .lines()
        .filter(|l| !l.starts_with("#position_zero_uncertainty_m,"))
        .map(|l| format!("{l}\n"))
        .collect();
    assert_eq!(stripped.lines().count() + 1, text.lines().count());
    let bare = dir.path().join("bare.csv");
    std::fs::write(&bare, stripped).unwrap();
    std::fs::copy(
        dir.path().join("keyed.map.toml"),
        dir.path().join("bare.map.toml"),
    )
    .unwrap();
    let with_key = fit_entry(&keyed);
    let levels = &with_key["levels_by_direction"];
    assert_eq!(with_key["levels_gauge"], "calibrated zeros", "{with_key:#}");
    let without = fit_entry(&bare);
    assert!(without["levels_by_direction"].is_null(), "{without:#}");
    let declared = fit_entry_with(&bare, &["--position-zero-uncertainty-m", "1e-5"]);
    assert_eq!(&declared["levels_by_direction"], levels, "{declared:#}");
    assert_eq!(declared["rho_s_minus"], with_key["rho_s_minus"]);
    // The option overrides the key: a bound of 50 µm widens b's interval.
    let wider = fit_entry_with(&keyed, &["--position-zero-uncertainty-m", "5e-5"]);
    let c = &wider["levels_by_direction"];
    assert_eq!(c["zero_uncertainty_m"], 5e-5, "{c:#}");
    let width = |c: &serde_json::Value| {
        let iv = &c["dynamic_split_interval_n"];
        iv[1].as_f64().unwrap() - iv[0].as_f64().unwrap()
    };
    assert!(width(c) > width(levels), "{c:#} {levels:#}");
    for bad in ["-1e-5", "nan", "inf", "ten"] {
        let out = dir.path().join("never.json");
        let o = common::bin()
            .arg("fit")
            .arg(&bare)
            .args(["--position-zero-uncertainty-m", bad, "--out"])
            .arg(&out)
            .output()
            .unwrap();
        assert_eq!(o.status.code(), Some(2), "{bad}");
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(
            err.contains("error:") && err.contains("position-zero"),
            "{bad}: {err}"
        );
        assert!(!out.exists(), "{bad}");
    }
}

/// A never-sticking static/dynamic pad whose position records lag behind
/// their anti-alias filters (third rig of the calibrated study: M1 12 kg,
/// M2 2.5 kg, K1 1500, K2 1000 N/m, A 3 mm; x0 and x2 behind ~400-Hz
/// low-passes; calibrated zeros, levels 7–9 % lower towards −; the
/// study's z022). The lag-free laws are not adequate (cost 43 times the
/// lagged one's); the lagged Coulomb law is, and is kept without
/// finishing the lag-free pass, whose profile in Rs behind a ringing
/// contact and Stribeck law behind it took 385 s (the fit now takes about
/// 2 s; `cargo bench --bench fit` times it). The dynamic levels of each
/// direction within 3 % and covered; the thresholds, never reached, only
/// bounded, their intervals holding the truth.
#[test]
fn a_never_sticking_pad_whose_records_lag() {
    let dir = tempfile::tempdir().unwrap();
    let sensors = dir.path().join("sensors.json");
    std::fs::write(&sensors, NEVER_STICKS_SENSORS).unwrap();
    let log = dir.path().join("z022.mcap");
    let sensors = sensors.to_str().expect("a UTF-8 temp path");
    synth_to(
        &log,
        NEVER_STICKS_ARGS
            .split_whitespace()
            .chain(["--sensors", sensors]),
    );
    let f = fit_entry(&log);
    let label = format!("{f:#}");
    assert_eq!(f["adequate"], true, "{label}");
    let codes = f["warning_codes"].as_array().unwrap();
    assert!(codes.iter().any(|c| c == "position_delay"), "{codes:?}");
    let c = &f["levels_by_direction"];
    for (key, truth) in [
        ("rd_plus", 1.3496596723261098),
        ("rd_minus", 1.2904654309338992),
    ] {
        let v = c[format!("{key}_n")].as_f64().unwrap();
        assert!(
            (v / truth - 1.0).abs() < 0.03,
            "{key} {v} for {truth}: {label}"
        );
        assert!(
            covers(c, &format!("{key}_interval_n"), truth),
            "{key}: {label}"
        );
    }
    for (key, truth) in [
        ("rs_plus", 1.5767969069539283),
        ("rs_minus", 1.4704867615251511),
    ] {
        assert!(c[format!("{key}_n")].is_null(), "{key}: {label}");
        assert!(
            covers(c, &format!("{key}_interval_n"), truth),
            "{key}: {label}"
        );
    }
}

/// The synth arguments and sensors of
/// [`a_never_sticking_pad_whose_records_lag`]'s log
/// (`scripts/calibrated_levels_study.py`'s z022; `benches/fit.rs` times
/// its fit).
const NEVER_STICKS_ARGS: &str = include_str!("logs/never_sticks_lagging.args");
/// Its sensors (`synth --sensors`), as the study drew them.
const NEVER_STICKS_SENSORS: &str = include_str!("logs/never_sticks_lagging.sensors.json");
