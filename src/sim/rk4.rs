//! The paper's own integration procedure (§2): classical fourth-order
//! Runge–Kutta with fixed step H on eqs. (1)/(2), and switching-time
//! determination by re-integrating the step that contains a sign change of a
//! switching function with a shorter step until the switching function is
//! zero. Written directly from the equations of motion, independently of the
//! exact engine's matrices, so it cross-checks them; the switching decisions
//! are the same physics ([`super::event_loop::after_slip`]). Errors are O(H⁴).

use super::event_loop::{
    self, net_force, side, Advance, Init, Mode, Observer, RunEnd, Stepper, Watch,
};
use super::events;
use super::SimError;
use crate::model::Model;
use std::f64::consts::PI;

/// The paper's RK4 integrator with step `h` (dimensionless time).
#[derive(Debug, Clone)]
pub struct Rk4 {
    model: Model,
    eta: f64,
    h: f64,
    /// Dynamic levels by sliding direction (ρd⁺, ρd⁻).
    rho_d: [f64; 2],
    /// Interruption speeds by sliding direction.
    v_interrupt: [Option<f64>; 2],
}

impl Rk4 {
    /// Prepares the integrator (affine laws only, like the exact engine).
    pub fn new(model: &Model, eta: f64, h: f64) -> Result<Self, SimError> {
        model.validate()?;
        crate::model::validate_eta(eta)?;
        if !(h.is_finite() && h > 0.0) {
            return Err(SimError::Unsupported(format!(
                "step must be finite and > 0, got {h}"
            )));
        }
        // RK4 is stable for an undamped mode ω while h·ω ≤ 2√2; beyond it
        // the numbers grow without bound (A1/A = 1e42 "completed").
        let a = model.absorber;
        let held = model.contact_stiffness.map_or(0.0, |kappa| {
            super::linalg::modal(&super::phase::absorber::held_matrix(&a, kappa))
                .map_or(f64::INFINITY, |m| {
                    m.lambda.iter().map(|l| l.norm()).fold(0.0, f64::max)
                })
        });
        let omega_max = a.eta_linear().1.max(a.eta_stuck()).max(held);
        let h_max = 2.0 * std::f64::consts::SQRT_2 / omega_max;
        if h > h_max {
            return Err(SimError::Unsupported(format!(
                "RK4 step H = {h} is unstable for this model: its fastest mode has eta = {omega_max:.4}, and RK4 needs H <= 2*sqrt(2)/eta = {h_max:.4}: give a smaller --step (accuracy wants far less)"
            )));
        }
        if model.law.affine().is_none() {
            return Err(SimError::Unsupported(
                "rk4 supports affine laws only".into(),
            ));
        };
        let rho_d = [1.0, -1.0].map(|dir| model.law.levels(dir).rho_d);
        let v_interrupt = [1.0, -1.0].map(|dir| model.interrupt_speed(dir));
        Ok(Self {
            model: *model,
            eta,
            h,
            rho_d,
            v_interrupt,
        })
    }

    /// Right-hand side of eq. (1) (slip) or eq. (2) (stick) at period offset s.
    fn rhs(&self, mode: Mode, s: f64, x: &[f64; 4]) -> [f64; 4] {
        let ab = &self.model.absorber;
        let (m, k, d) = (ab.m, ab.k, ab.damping);
        let drive = k * (self.eta * s).cos();
        match mode {
            // Behind a contact spring κ (slider stuck at ζs = z2) M2 moves.
            Mode::Stick { z2 } if self.model.contact_stiffness.is_some() => {
                let kappa = self.model.contact_stiffness.unwrap_or(0.0);
                let a1 = (drive - d * (x[1] - x[3]) - (1.0 + k) * x[0] + x[2]) / m;
                let a2 = d * (x[1] - x[3]) + x[0] - x[2] - kappa * (x[2] - z2);
                [x[1], a1, x[3], a2]
            }
            Mode::Stick { z2 } => {
                let a1 = (drive - d * x[1] - (1.0 + k) * x[0] + z2) / m;
                [x[1], a1, 0.0, 0.0]
            }
            Mode::Slip { dir } => {
                let a1 = (drive - d * (x[1] - x[3]) - (1.0 + k) * x[0] + x[2]) / m;
                let fric = if self.model.law.is_frictionless() {
                    self.model.law.slope() * x[3]
                } else {
                    dir * self.rho_d[side(dir)] + self.model.law.slope() * x[3]
                };
                let a2 = d * (x[1] - x[3]) + x[0] - x[2] - fric;
                [x[1], a1, x[3], a2]
            }
        }
    }

    fn step(&self, mode: Mode, s: f64, x: &[f64; 4], dt: f64) -> [f64; 4] {
        let add = |a: &[f64; 4], b: &[f64; 4], f: f64| {
            std::array::from_fn::<f64, 4, _>(|i| a[i] + f * b[i])
        };
        let k1 = self.rhs(mode, s, x);
        let k2 = self.rhs(mode, s + 0.5 * dt, &add(x, &k1, 0.5 * dt));
        let k3 = self.rhs(mode, s + 0.5 * dt, &add(x, &k2, 0.5 * dt));
        let k4 = self.rhs(mode, s + dt, &add(x, &k3, dt));
        std::array::from_fn(|i| x[i] + dt / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]))
    }

    /// Switching functions of a mode, each > 0 while the mode holds.
    fn switching(&self, mode: Mode, x: &[f64; 4]) -> [f64; 2] {
        match mode {
            Mode::Stick { z2 } if self.model.contact_stiffness.is_some() => {
                let (rho_plus, rho_minus) = self.model.thresholds();
                let pull = self.model.contact_stiffness.unwrap_or(0.0) * (x[2] - z2);
                [rho_plus - pull, rho_minus + pull]
            }
            Mode::Stick { .. } => {
                let (rho_plus, rho_minus) = self.model.thresholds();
                let f = net_force(&self.model, x);
                [rho_plus - f, rho_minus + f]
            }
            Mode::Slip { dir } => {
                let vi = self.v_interrupt[side(dir)].map_or(f64::INFINITY, |v| v - dir * x[3]);
                if self.model.law.is_frictionless() {
                    [f64::INFINITY, f64::INFINITY]
                } else {
                    [dir * x[3], vi]
                }
            }
        }
    }

    /// Integrates `periods` forcing periods (same observer protocol as the
    /// exact engine, without extremum location: amplitudes from step points).
    pub fn run<O: Observer>(&self, init: Init, periods: u64, obs: &mut O) -> RunEnd {
        let st = Stepping {
            rk: self,
            period: 2.0 * PI / self.eta,
            fresh: true,
        };
        event_loop::run(st, init, periods, 0.0, obs)
    }
}

/// RK4 as a [`Stepper`]: one fixed step per advance (shortened to the
/// boundary), the step containing a sign change re-integrated with a
/// shorter step until the switching function is zero.
struct Stepping<'a> {
    rk: &'a Rk4,
    period: f64,
    /// A phase has just begun: a switching function on its boundary counts
    /// as positive (it leaves the boundary).
    fresh: bool,
}

impl Stepper for Stepping<'_> {
    fn model(&self) -> &Model {
        &self.rk.model
    }

    fn period(&self) -> Option<f64> {
        Some(self.period)
    }

    fn begin(&mut self, _mode: Mode, _x: &[f64; 4], _n: u64, _s: f64, _first: bool) {
        self.fresh = true;
    }

    fn advance<O: Observer + ?Sized>(
        &mut self,
        mode: Mode,
        x: &[f64; 4],
        _n: u64,
        s: f64,
        s_end: f64,
        watch: &mut Watch<'_, O>,
    ) -> Advance {
        let rk = self.rk;
        let left = s_end - s;
        let dt = rk.h.min(left);
        let x1 = rk.step(mode, s, x, dt);
        let h0 = rk.switching(mode, x);
        let h1 = rk.switching(mode, &x1);
        // Earliest sign change (a function on its boundary at a fresh phase
        // start counts as positive: it leaves the boundary).
        let mut best: Option<(f64, usize)> = None;
        for i in 0..2 {
            let pos0 = h0[i] > 0.0 || (self.fresh && h0[i] == 0.0);
            if pos0 && h1[i] <= 0.0 {
                let f = |d: f64| {
                    let y = rk.step(mode, s, x, d);
                    let dy = rk.rhs(mode, s + d, &y);
                    let g = rk.switching(mode, &y)[i];
                    let dg = match (mode, i) {
                        (Mode::Stick { .. }, _) if rk.model.contact_stiffness.is_some() => {
                            let dp = rk.model.contact_stiffness.unwrap_or(0.0) * dy[2];
                            if i == 0 {
                                -dp
                            } else {
                                dp
                            }
                        }
                        (Mode::Stick { .. }, _) => {
                            let df = dy[0] + rk.model.absorber.damping * dy[1];
                            if i == 0 {
                                -df
                            } else {
                                df
                            }
                        }
                        (Mode::Slip { dir }, 0) => dir * dy[3],
                        (Mode::Slip { dir }, _) => -dir * dy[3],
                    };
                    (g, dg, 0.0)
                };
                // Bracket start: a point where the function is > 0.
                let mut lo = 0.0;
                if h0[i] <= 0.0 {
                    lo = dt;
                    for _ in 0..60 {
                        lo *= 0.5;
                        if f(lo).0 > 0.0 {
                            break;
                        }
                    }
                }
                let r = if f(lo).0 > 0.0 {
                    events::refine(f, lo, dt, self.period, f64::NAN)
                } else {
                    0.0
                };
                if best.is_none_or(|(b, _)| r < b) {
                    best = Some((r, i));
                }
            }
        }
        self.fresh = false;
        match best {
            None => {
                watch.point(&x1);
                Advance::Moved {
                    delta: dt,
                    x: x1,
                    end: dt == left,
                }
            }
            Some((d, which)) => Advance::Hit {
                delta: d,
                which,
                x: rk.step(mode, s, x, d),
            },
        }
    }

    fn drive(&self, _n: u64, s: f64) -> f64 {
        (self.rk.eta * s).cos()
    }

    fn rate(&self, mode: Mode, x: &[f64; 4], _n: u64, s: f64) -> [f64; 4] {
        self.rk.rhs(mode, s, x)
    }
}
