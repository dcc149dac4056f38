//! Work-precision study (`stickslip bench`): run time against error for the
//! exact event-driven engine (root tolerances), the paper's RK4 with
//! switching-time determination (step sizes) and Dormand–Prince 5(4) with
//! event location (tolerances), on fixed scenarios. The error of a setting is
//! the worst, over the scenarios, of the steady amplitudes' error (relative
//! to the larger amplitude) and of the event times' error (relative to the
//! time, at least one period) of a 10-period transient from rest, against
//! the exact engine at machine precision.

use super::engine::{Event, Init, Observer, RunEnd, Sim};
use super::monodromy::Events;
use super::numeric::{NumericOptions, NumericSim};
use super::rk4::Rk4;
use super::steady::{simulate_with, SimOptions, Summary};
use crate::model::{Absorber, Drive, Law, Model};
use std::time::Instant;

/// One row of the study.
#[derive(Debug, Clone, PartialEq)]
pub struct WpRow {
    /// `exact`, `rk4`, `dopri5` or a workload name.
    pub method: String,
    /// The setting (root tolerance, step, rtol).
    pub setting: String,
    /// Wall time of the setting over all scenarios, seconds.
    pub seconds: f64,
    /// Worst relative error (None: the method failed on a scenario, e.g. it
    /// found a different event sequence; or a pure timing row).
    pub error: Option<f64>,
}

/// The scenarios: (name, model, η).
pub fn scenarios() -> Vec<(&'static str, Model, f64)> {
    let m = |law, stop_below| Model {
        absorber: Absorber::default(),
        law,
        stop_below,
        contact_stiffness: None,
    };
    vec![
        ("coulomb, eta 0.6", m(Law::coulomb(0.375), None), 0.6),
        (
            "decreasing, eta 0.9",
            m(
                Law::Linear {
                    rho_s: 0.375,
                    rho_d: 0.375,
                    slope: -0.04,
                    minus: None,
                },
                Some(0.5),
            ),
            0.9,
        ),
        (
            "static>dynamic, eta 1.1",
            m(
                Law::Linear {
                    rho_s: 0.5,
                    rho_d: 0.25,
                    slope: 0.0,
                    minus: None,
                },
                None,
            ),
            1.1,
        ),
        ("coulomb near eta2", m(Law::coulomb(0.2), None), 1.14),
        ("coulomb stick-dominated", m(Law::coulomb(1.0), None), 0.5),
    ]
}

type Runner<'a> = Box<dyn Fn(Init, u64, &mut dyn Observer) -> RunEnd + 'a>;

/// Forwards everything to a dynamically typed observer.
struct Fwd<'a>(&'a mut dyn Observer);
impl Observer for Fwd<'_> {
    fn event(&mut self, ev: &Event) {
        self.0.event(ev)
    }
    fn period(
        &mut self,
        n: u64,
        x: &[f64; 4],
        mode: super::engine::Mode,
        st: &super::engine::PeriodStats,
    ) -> super::engine::Flow {
        self.0.period(n, x, mode, st)
    }
    fn next_sample(&mut self) -> Option<f64> {
        self.0.next_sample()
    }
    fn sample(&mut self, tau: f64, x: &[f64; 4], dx: &[f64; 4]) {
        self.0.sample(tau, x, dx)
    }
    fn wants_extremes(&self) -> bool {
        self.0.wants_extremes()
    }
}

/// `nominal`: the setting's nominal accuracy; the Poincaré-section test of
/// the steady run uses max(1e-9, 10·nominal), since a section cannot repeat
/// more precisely than the method computes it.
fn evaluate(
    run: &Runner<'_>,
    eta: f64,
    nominal: f64,
    reference: &(Vec<Event>, Summary),
) -> Option<f64> {
    let t = 2.0 * std::f64::consts::PI / eta;
    let mut evs = Events(Vec::new());
    run(Init::rest(), 10, &mut evs);
    if evs.0.len() != reference.0.len() {
        return None;
    }
    let mut err = 0.0f64;
    for (a, b) in evs.0.iter().zip(&reference.0) {
        if a.kind != b.kind {
            return None;
        }
        err = err.max((a.tau - b.tau).abs() / b.tau.max(t));
    }
    let opts = SimOptions {
        shortcuts: false,
        tol: (10.0 * nominal).max(1e-9),
        ..SimOptions::default()
    };
    let s = simulate_with(&opts, eta, |init, n, obs| run(init, n, obs), t, &mut ());
    // Amplitude errors relative to the response's size (A2 of a stuck
    // absorber is 0: relative to itself it would be meaningless).
    let r = &reference.1;
    let scale = r
        .amplitude1
        .unwrap_or(0.0)
        .max(r.amplitude2.unwrap_or(0.0))
        .max(1e-300);
    for (a, b) in [(s.amplitude1, r.amplitude1), (s.amplitude2, r.amplitude2)] {
        match (a, b) {
            (Some(a), Some(b)) => err = err.max((a - b).abs() / scale),
            (None, None) => {}
            _ => return None,
        }
    }
    Some(err)
}

/// References: exact engine at machine precision (the events of the first
/// 10 periods and the steady state, shortcuts off) of each scenario.
fn references(sc: &[(&'static str, Model, f64)]) -> Vec<(Vec<Event>, Summary)> {
    sc.iter()
        .map(|(_, m, eta)| {
            let sim = Sim::new(m, *eta).expect("valid scenario");
            let mut ev = Events(Vec::new());
            sim.run(Init::rest(), 10, &mut ev);
            let opts = SimOptions {
                shortcuts: false,
                ..SimOptions::default()
            };
            let s = super::steady::simulate(&sim, &opts, &mut ());
            (ev.0, s)
        })
        .collect()
}

/// The Fig. 3 workload (13 ρs × 141 η, Coulomb, steady states): a timing
/// row.
fn fig3_row() -> WpRow {
    use super::sweep::{eta_grid, family, CurveSpec, Direction, Shard, SteadyConfig};
    let specs: Vec<CurveSpec> = [
        0.0, 0.05, 0.1, 0.2, 0.3, 0.33, 0.35, 0.375, 0.4, 0.6, 1.0, 2.0, 5.0,
    ]
    .iter()
    .map(|&rs| CurveSpec {
        model: Model {
            absorber: Absorber::default(),
            law: Law::coulomb(rs),
            stop_below: None,
            contact_stiffness: None,
        },
        direction: Direction::Up,
    })
    .collect();
    let start = Instant::now();
    let ok = family(
        &specs,
        &eta_grid(0.2, 1.6, 141),
        &SteadyConfig::default(),
        Shard::ALL,
        &|_| {},
    )
    .is_ok();
    WpRow {
        method: "fig3-family".into(),
        setting: if ok {
            "13 rho_s x 141 eta, steady"
        } else {
            "13 rho_s x 141 eta, FAILED"
        }
        .into(),
        seconds: start.elapsed().as_secs_f64(),
        // A timing row: no error is measured.
        error: None,
    }
}

/// Runs the study; `quick` uses fewer settings and scenarios.
pub fn study(quick: bool) -> Vec<WpRow> {
    let mut sc = scenarios();
    if quick {
        sc.truncate(3);
    }
    let refs = references(&sc);
    let mut rows = Vec::new();
    let mut measure =
        |method: &str,
         setting: String,
         nominal: f64,
         make: &dyn Fn(&Model, f64) -> Option<Runner<'static>>| {
            let start = Instant::now();
            let mut worst = Some(0.0f64);
            for ((_, m, eta), r) in sc.iter().zip(&refs) {
                let e = make(m, *eta).and_then(|run| evaluate(&run, *eta, nominal, r));
                worst = match (worst, e) {
                    (Some(w), Some(e)) => Some(w.max(e)),
                    _ => None,
                };
            }
            rows.push(WpRow {
                method: method.into(),
                setting,
                seconds: start.elapsed().as_secs_f64(),
                error: worst,
            });
        };
    let root_tols: &[f64] = if quick {
        &[1e-6, 1e-12]
    } else {
        &[1e-4, 1e-6, 1e-8, 1e-10, 1e-12]
    };
    for &tol in root_tols {
        measure("exact", format!("root tol {tol:e}"), tol, &|m, eta| {
            let sim = Sim::new(m, eta).ok()?.with_root_tolerance(tol);
            Some(Box::new(move |init, n, o: &mut dyn Observer| {
                sim.run(init, n, &mut Fwd(o))
            }))
        });
    }
    let steps: &[f64] = if quick {
        &[0.04, 0.01]
    } else {
        &[0.08, 0.04, 0.02, 0.01, 0.005]
    };
    for &h in steps {
        // RK4's global error ~ H⁴ (unit constant as the nominal accuracy).
        measure("rk4", format!("H {h}"), h.powi(4), &|m, eta| {
            let rk = Rk4::new(m, eta, h).ok()?;
            Some(Box::new(move |init, n, o: &mut dyn Observer| {
                rk.run(init, n, &mut Fwd(o))
            }))
        });
    }
    let rtols: &[f64] = if quick {
        &[1e-6, 1e-10]
    } else {
        &[1e-4, 1e-6, 1e-8, 1e-10, 1e-12]
    };
    for &rtol in rtols {
        measure("dopri5", format!("rtol {rtol:e}"), rtol, &|m, eta| {
            let drive = Drive::Harmonic {
                eta,
                phase: 0.0,
                amplitude: 1.0,
            };
            let ns = NumericSim::new(
                m,
                drive,
                NumericOptions {
                    rtol,
                    atol: rtol * 1e-2,
                },
            )
            .ok()?;
            let t = 2.0 * std::f64::consts::PI / eta;
            Some(Box::new(move |init, n, o: &mut dyn Observer| {
                ns.run(init, n as f64 * t, &mut Fwd(o))
            }))
        });
    }
    // The Fig. 3 workload (13 ρs × 141 η, Coulomb, steady states).
    if !quick {
        rows.push(fig3_row());
    }
    rows
}
