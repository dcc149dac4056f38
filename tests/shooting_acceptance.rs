//! Study (ignored): does shooting's local acceptance change the batch's
//! worst case? The worst case W with the default steady-state settings
//! (shooting accepted where the trajectory follows its linearisation)
//! against the same grid marched only (no shooting, 2000 periods): where
//! shooting reports a stable orbit beside a response from rest that
//! wanders elsewhere, the two differ.
//!
//! Measured (session 37, public rig m 4, k 1, D 0.003, the batch's η
//! grid): rigid pads at ρs 0.81–2.02 agree within 0.5 % (the non-periodic
//! stick-slip near η0 wanders by ±3 % with the run length); at ρs 0.2–0.6
//! marching 2000 periods has not reached the stuck absorber's resonance
//! (W 3657 against shooting's 10 240 at ρs 0.2: shooting is right). Behind
//! a contact spring shooting's W was LOW: κ 60 at ρs 0.9 (ρd 0.7) 1.043
//! against 1.201 marched (−13 %), κ 20 at ρs 0.9 (ρd 0.72) 1.109 against
//! 1.340 (−17 %), κ 20 at ρs 1.2 −6.4 %, κ 60 at ρs 1.2 −1.1 %: at η
//! 0.80 the response from rest wanders (A1 about 1.2) around a weakly
//! stable period-1 orbit (A1 0.88, multipliers 0.996) that shooting
//! accepted on the "rest" branch.
//!
//! Session 38, with shooting's event check (every verification iterate
//! keeps the orbit's switching events): the four contact rows +0.17 %,
//! +0.25 %, +0.00 %, +0.05 %; the rigid rows and ρs 0.2–0.6 unchanged
//! (10 240 at ρs 0.2). docs/real-pads.md, "The event check".
mod common;

use stickslip::batch::{worst_case, BatchOptions, PadShape};
use stickslip::sim::sweep::SteadyConfig;

/// The batch's steady-state settings without shooting, marching up to
/// 2000 periods.
fn marched_only(o: &BatchOptions) -> SteadyConfig {
    SteadyConfig {
        shooting: false,
        max_periods: 2000,
        ..o.steady
    }
}

#[test]
#[ignore = "study: prints W with and without shooting"]
fn worst_case_with_and_without_shooting() {
    let (ab, etas) = common::public_batch_grid();
    let o = BatchOptions::default();
    let marched = marched_only(&o);
    let rigid = PadShape::PAPER;
    let contact = |k: f64| PadShape {
        contact_stiffness: Some(k),
        ..PadShape::PAPER
    };
    let mut cases = Vec::new();
    for rho in [0.2, 0.4, 0.6, 0.8145, 0.9478, 1.1455, 1.2833, 1.673, 2.0219] {
        cases.push(("rigid", rigid, rho, 0.8));
    }
    for rho in [0.5, 0.9, 1.2] {
        cases.push(("κ 60", contact(60.0), rho, 0.7 / 0.9));
        cases.push(("κ 20", contact(20.0), rho, 0.8));
    }
    for (name, shape, rho, ratio) in cases {
        let t = std::time::Instant::now();
        let a = worst_case(&ab, shape, rho, ratio * rho, &etas, &o.steady).unwrap();
        let ta = t.elapsed().as_secs_f64();
        let t = std::time::Instant::now();
        let b = worst_case(&ab, shape, rho, ratio * rho, &etas, &marched).unwrap();
        let tb = t.elapsed().as_secs_f64();
        eprintln!(
            "STUDY {name} ρs {rho}: W shooting {:.4} at η {:.4} ({:?}, unsettled {}) | marched {:.4} at η {:.4} ({:?}, unsettled {}) | {:+.2} % | {ta:.1} s / {tb:.1} s",
            a.amplitude1,
            a.eta,
            a.branch,
            a.unsettled,
            b.amplitude1,
            b.eta,
            b.branch,
            b.unsettled,
            100.0 * (a.amplitude1 / b.amplitude1 - 1.0)
        );
    }
}

/// Behind a contact spring at ρs 0.9 the batch's worst case equals the
/// marched one (session 38: +0.17 % and +0.25 %); before shooting's event
/// check it was 13 % and 17 % low (the weakly stable orbit at η 0.80
/// reported instead of the wandering response from rest). The margin, 3 %,
/// is the run-length spread of such a non-periodic response's window.
#[test]
fn the_worst_case_behind_a_contact_is_the_response_from_rest() {
    let (ab, etas) = common::public_batch_grid();
    let o = BatchOptions::default();
    let marched = marched_only(&o);
    let rho = 0.9;
    for (k, rd) in [(20.0, 0.8 * rho), (60.0, 0.7)] {
        let shape = PadShape {
            contact_stiffness: Some(k),
            ..PadShape::PAPER
        };
        let a = worst_case(&ab, shape, rho, rd, &etas, &o.steady).unwrap();
        let b = worst_case(&ab, shape, rho, rd, &etas, &marched).unwrap();
        let r = a.amplitude1 / b.amplitude1 - 1.0;
        assert!(
            r.abs() < 0.03,
            "κ {k}: W {} against {} marched ({:+.1} %)",
            a.amplitude1,
            b.amplitude1,
            100.0 * r
        );
    }
}
