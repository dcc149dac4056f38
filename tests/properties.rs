//! Property tests of the exact engine over wide random parameters (issue:
//! m 0.1–100, k 0.01–100, D 0–1, ρs 0–10, ρd in (0, ρs], D* in [−0.1, 0.1],
//! η 0.05–5): no panic, no NaN, the stick force never exceeds ρs, events in
//! time order.

use proptest::prelude::*;
use stickslip::model::{Absorber, Law, Model};
use stickslip::sim::engine::net_force;
use stickslip::sim::{Event, EventKind, Init, Mode, Observer, PeriodGrid, Sim, Status};

struct Check {
    model: Model,
    events: Vec<Event>,
    stuck_samples: u64,
    worst_excess: f64,
    nan: bool,
    grid: PeriodGrid,
    wrong_departure: bool,
    mode: Mode,
}

impl Observer for Check {
    fn event(&mut self, ev: &Event) {
        self.nan |= ev.x.iter().any(|v| !v.is_finite()) || !ev.tau.is_finite();
        self.mode = match ev.kind {
            EventKind::Stick => Mode::Stick { z2: ev.x[2] },
            EventKind::SlipPlus | EventKind::ReversePlus => Mode::Slip { dir: 1.0 },
            _ => Mode::Slip { dir: -1.0 },
        };
        if ev.kind == EventKind::Stick {
            self.check_force(&ev.x);
        }
        // Breakaway: M2 departs in the direction of the net non-friction
        // force F on it (physics; the paper's eq. 5 text has the sign of −F).
        let f = net_force(&self.model, &ev.x);
        match ev.kind {
            EventKind::SlipPlus => self.wrong_departure |= f <= 0.0,
            EventKind::SlipMinus => self.wrong_departure |= f >= 0.0,
            _ => {}
        }
        self.events.push(*ev);
    }
    fn next_sample(&mut self) -> Option<f64> {
        Some(self.grid.advance())
    }
    fn sample(&mut self, _tau: f64, x: &[f64; 4], _dx: &[f64; 4]) {
        self.nan |= x.iter().any(|v| !v.is_finite());
        if let Mode::Stick { .. } = self.mode {
            self.stuck_samples += 1;
            self.check_force(x);
        }
    }
}

impl Check {
    fn check_force(&mut self, x: &[f64; 4]) {
        let f = net_force(&self.model, x).abs();
        let rs = self.model.law.rho_s();
        let scale = rs + x[0].abs() + x[2].abs() + self.model.absorber.damping * x[1].abs();
        self.worst_excess = self.worst_excess.max((f - rs) / scale);
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 96, ..ProptestConfig::default() })]

    #[test]
    fn engine_is_robust(
        lm in (0.1f64).ln()..(100f64).ln(),
        lk in (0.01f64).ln()..(100f64).ln(),
        d in 0.0f64..1.0,
        rs in 0.0f64..10.0,
        frac in 0.001f64..=1.0,
        slope in -0.1f64..0.1,
        leta in (0.05f64).ln()..(5f64).ln(),
    ) {
        let slope = if rs == 0.0 { slope.abs() } else { slope };
        let model = Model {
            absorber: Absorber { m: lm.exp(), k: lk.exp(), damping: d },
            law: Law::Linear { rho_s: rs, rho_d: frac * rs, slope, minus: None },
            stop_below: None,
contact_stiffness: None,
};
        let eta = leta.exp();
        let sim = Sim::new(&model, eta).unwrap();
        let mut c = Check {
            model,
            events: Vec::new(),
            stuck_samples: 0,
            worst_excess: f64::NEG_INFINITY,
            nan: false,
            grid: PeriodGrid { t: 2.0 * std::f64::consts::PI / eta, per_period: 16, j: 0 },
            wrong_departure: false,
            // The engine's start: frictionless runs slide from the outset.
            mode: if rs == 0.0 { Mode::Slip { dir: 1.0 } } else { Mode::Stick { z2: 0.0 } },
        };
        let end = sim.run(Init::rest(), 12, &mut c);
        prop_assert!(!c.nan, "NaN in the trajectory");
        prop_assert!(!c.wrong_departure, "M2 departed against the net force");
        prop_assert!(end.x.iter().all(|v| v.is_finite()));
        // Stick force within ρs up to rounding of the switching location.
        prop_assert!(c.worst_excess <= 1e-12, "stick force exceeds rho_s by {:e}", c.worst_excess);
        // Events in time order; equal times only for instantaneous switch
        // sequences (a stop touching the threshold), never more than a few.
        let mut equal_run = 0;
        for w in c.events.windows(2) {
            prop_assert!(w[1].tau >= w[0].tau, "events out of order");
            if w[1].tau == w[0].tau { equal_run += 1; prop_assert!(equal_run <= 4); } else { equal_run = 0; }
        }
        match end.status {
            Status::Completed => prop_assert_eq!(end.periods, 12),
            Status::Interrupted(_) => prop_assert!(slope < 0.0),
            Status::Chatter(_) | Status::Stopped => {}
        }
    }
}
