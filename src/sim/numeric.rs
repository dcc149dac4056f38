//! The numerical engine: the same switching logic and event location as the
//! exact engine, with slip and stick phases integrated by Dormand–Prince
//! 5(4) ([`super::dopri`]). It serves what has no closed form: nonlinear
//! friction laws (Stribeck) and drives other than a single harmonic
//! (chirps, ramps, measured signals). Events are located on the dense output
//! of each accepted step (bracketing with the grazing test, then the same
//! safeguarded refinement), so their accuracy is that of the integration
//! tolerance.
//!
//! The right-hand sides are written from the equations of motion (paper
//! eqs. 1–2 with the law's sliding magnitude g):
//! slip ζ2'' = F − dir·g(dir·ζ2'), stick ζ2'' = 0, and their time
//! derivatives for the switching functions' curvature.

use super::dopri::Dopri5;
use super::event_loop::{self, side, Advance, Init, Mode, Observer, RunEnd, Stepper, Watch};
use super::events::{self, EventFn, Jet, Switch};
use super::{linalg, phase::absorber, SimError};
use crate::model::{Drive, Law, Model};
use std::cell::Cell;

/// A switching function of the numerical engine.
#[derive(Debug, Clone, Copy)]
enum NumSwitch<'a> {
    /// Linear in the state.
    Lin(EventFn<4>),
    /// Slip interruption for a nonlinear law: h = g(dir·ζ2') − threshold
    /// (the law's decay taken from the run's memo).
    Friction {
        dir: f64,
        thr: f64,
        /// The law of the sliding direction ([`Law::toward`]).
        law: Law,
        memo: &'a Memo,
    },
}

impl Switch<Jet<4>> for NumSwitch<'_> {
    #[inline]
    fn eval(&self, j: &Jet<4>) -> (f64, f64, f64) {
        match self {
            NumSwitch::Lin(f) => f.eval(j),
            NumSwitch::Friction {
                dir,
                thr,
                law,
                memo,
            } => {
                let u = dir * j.x[3];
                let (du, ddu) = (dir * j.dx[3], dir * j.ddx[3]);
                let v = u.max(0.0);
                let (g, g1, g2) = law.sliding_jet_with(v, memo.decay(law, v));
                (g - thr, g1 * du, g2 * du * du + g1 * ddu)
            }
        }
    }
}

/// What a run evaluates repeatedly at one argument, kept from the last
/// evaluation: the drive at a time (a step's last two stages, the jet at
/// its end and the next step's start share the time t + h; a harmonic
/// drive's angle as its sine and cosine, the anchor of the next step's
/// stages) and the law's decay ([`crate::model::Law::decay`]) at a speed
/// (the last stage, the jet's rate and slope and the interruption function
/// share the end state's ζ2'). The values are those of a fresh evaluation
/// (the drive's position from `eval` is the one `position` gives: the same
/// cosine).
#[derive(Debug)]
struct Memo {
    drive: Cell<(f64, (f64, f64, f64))>,
    /// τ and (sin, cos) of a harmonic drive's angle ητ + φ there.
    phasor: Cell<(f64, (f64, f64))>,
    decay: Cell<(f64, f64)>,
}

/// `CIS_RADIUS[m]`: the largest |w| for which the Taylor polynomials of
/// cos w to degree 2m and of sin w to degree 2m + 1 are within 2⁻⁵⁶ of them
/// (alternating series: the first omitted term, |w|^{2m+2}/(2m+2)!, bounds
/// the error). Rounded down.
const CIS_RADIUS: [f64; 10] = [
    5.26e-9, 1.35e-4, 4.64e-3, 2.94e-2, 9.33e-2, 0.208, 0.377, 0.601, 0.874, 1.19,
];

/// (−1)^k/(2k)! and (−1)^k/(2k+1)!, k = 0..=9: the Taylor coefficients of
/// cos and sin (in w², sin's times w).
const COS_SIN_COEF: [(f64, f64); 10] = {
    let mut c = [(1.0, 1.0); 10];
    let mut f = 1.0; // (2k)!
    let mut k = 1;
    while k < 10 {
        f *= (2 * k - 1) as f64 * (2 * k) as f64;
        let sign = if k % 2 == 1 { -1.0 } else { 1.0 };
        c[k] = (sign / f, sign / (f * (2 * k + 1) as f64));
        k += 1;
    }
    c
};

/// The degree index m of [`cis`] for arguments up to |w| (None beyond
/// `CIS_RADIUS[9]`).
#[inline]
fn cis_degree(w: f64) -> Option<usize> {
    let w = w.abs();
    CIS_RADIUS.iter().position(|&r| w <= r)
}

/// cos w and sin w from their Taylor polynomials of degree 2m and 2m + 1
/// (Horner's rule in w²), for |w| ≤ `CIS_RADIUS[m]`.
#[inline(always)]
fn cis(w: f64, m: usize) -> (f64, f64) {
    let w2 = w * w;
    let (mut c, mut s) = COS_SIN_COEF[m];
    for &(cc, sc) in COS_SIN_COEF[..m].iter().rev() {
        c = c * w2 + cc;
        s = s * w2 + sc;
    }
    (c, s * w)
}

impl Memo {
    fn new() -> Self {
        Self {
            drive: Cell::new((f64::NAN, (0.0, 0.0, 0.0))),
            phasor: Cell::new((f64::NAN, (0.0, 0.0))),
            decay: Cell::new((f64::NAN, 0.0)),
        }
    }

    /// sin and cos of a harmonic drive's angle ητ + φ.
    #[inline]
    fn phasor(&self, eta: f64, phase: f64, tau: f64) -> (f64, f64) {
        let (t, v) = self.phasor.get();
        if t == tau {
            return v;
        }
        let v = (eta * tau + phase).sin_cos();
        self.phasor.set((tau, v));
        v
    }

    /// The drive's ζ0, ζ0', ζ0'' at τ.
    #[inline]
    fn drive(&self, drive: &Drive, tau: f64) -> (f64, f64, f64) {
        if let Drive::Harmonic {
            eta,
            phase,
            amplitude,
        } = *drive
        {
            // (Drive::eval's expressions.)
            let (s, c) = self.phasor(eta, phase, tau);
            return (
                amplitude * c,
                -amplitude * eta * s,
                -amplitude * eta * eta * c,
            );
        }
        let (t, v) = self.drive.get();
        if t == tau {
            return v;
        }
        let v = drive.eval(tau);
        self.drive.set((tau, v));
        v
    }

    /// A harmonic drive's position at τ0 + d from its phasor at τ0
    /// (`anchor`: sine and cosine there) by angle addition, e^{iηd} from
    /// its Taylor polynomial of degree index `m` (see [`cis`]; |ηd| must be
    /// within `CIS_RADIUS[m]`): a few ε from the cosine at τ0 + d (whose
    /// argument alone is rounded by ε·|ητ|). Other drives (or m = None):
    /// the drive's position at `tau` = τ0 + d.
    #[inline(always)]
    fn position_near(drive: &Drive, anchor: (f64, f64), m: Option<usize>, tau: f64, d: f64) -> f64 {
        if let (Drive::Harmonic { eta, amplitude, .. }, Some(m)) = (drive, m) {
            let (c, s) = cis(eta * d, m);
            let (s0, c0) = anchor;
            return amplitude * (c0 * c - s0 * s);
        }
        drive.position(tau)
    }

    /// The law's decay at speed v.
    #[inline]
    fn decay(&self, law: &crate::model::Law, v: f64) -> f64 {
        if let crate::model::Law::Linear { .. } = law {
            return 1.0;
        }
        let (w, e) = self.decay.get();
        if w == v {
            return e;
        }
        let e = law.decay(v);
        self.decay.set((v, e));
        e
    }
}

/// Options of the numerical engine.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NumericOptions {
    /// Relative tolerance of the integration.
    pub rtol: f64,
    /// Absolute tolerance.
    pub atol: f64,
}

impl Default for NumericOptions {
    fn default() -> Self {
        Self {
            rtol: 1e-10,
            atol: 1e-12,
        }
    }
}

/// The numerical engine for one model and drive.
#[derive(Debug, Clone)]
pub struct NumericSim {
    model: Model,
    drive: Drive,
    ode: Dopri5,
    /// The interruption level by sliding direction ([`side`]).
    thr: [f64; 2],
    /// The law by sliding direction ([`Law::toward`]).
    laws: [Law; 2],
}

impl NumericSim {
    /// Prepares the engine; any valid law and drive.
    pub fn new(model: &Model, drive: Drive, opts: NumericOptions) -> Result<Self, SimError> {
        model.validate()?;
        if !(opts.rtol > 0.0 && opts.atol > 0.0) {
            return Err(SimError::Unsupported("tolerances must be > 0".into()));
        }
        let ab = &model.absorber;
        // The fastest linear rate present bounds the step (one extremum of a
        // switching function per step, as in the exact engine).
        let rate = |a: &[[f64; 4]; 4]| {
            linalg::modal(a).map(|m| m.lambda.iter().map(|l| l.norm()).fold(0.0, f64::max))
        };
        let stick = linalg::modal(&absorber::stick_matrix(ab))
            .map(|m| m.lambda.iter().map(|l| l.norm()).fold(0.0, f64::max));
        let slip = rate(&absorber::slip_matrix(ab, model.law.slope()));
        let held = model
            .contact_stiffness
            .and_then(|kappa| rate(&absorber::held_matrix(ab, kappa)));
        let fastest = [stick, slip, held, Some(drive.fastest())]
            .into_iter()
            .flatten()
            .fold(1e-300, f64::max);
        // The exact engine's work budget, per forcing period of the drive.
        let steps = fastest * 2.0 * std::f64::consts::PI / drive.fastest();
        let limit = crate::sim::engine::MAX_STEPS_PER_PERIOD;
        if steps.is_nan() || steps > limit {
            return Err(SimError::Unsupported(format!(
                "the absorber is too stiff for this forcing frequency: its fastest mode needs {steps:.2e} steps per forcing period (limit {limit:.0e}); raise eta or bring m and k closer to 1"
            )));
        }
        Ok(Self {
            model: *model,
            drive,
            ode: Dopri5 {
                rtol: opts.rtol,
                atol: opts.atol,
                h_max: 1.0 / fastest,
            },
            thr: [model.interrupt_level(1.0), model.interrupt_level(-1.0)],
            laws: [model.law.toward(1.0), model.law.toward(-1.0)],
        })
    }

    /// The model integrated.
    pub fn model(&self) -> &Model {
        &self.model
    }

    /// The forcing period of a harmonic drive (`None` for other drives).
    pub fn forcing_period(&self) -> Option<f64> {
        match self.drive {
            Drive::Harmonic { eta, .. } => Some(2.0 * std::f64::consts::PI / eta),
            _ => None,
        }
    }

    /// 2π/(the drive's fastest frequency): the span per which events are
    /// counted without a forcing period.
    pub fn event_window(&self) -> f64 {
        2.0 * std::f64::consts::PI / self.drive.fastest()
    }

    /// The same engine with its harmonic drive's phase set to `phase`,
    /// keeping the per-model set-up (modal rates, step bound); `None` for
    /// other drives.
    pub fn with_phase(&self, phase: f64) -> Option<Self> {
        match self.drive {
            Drive::Harmonic { eta, amplitude, .. } => Some(Self {
                drive: Drive::Harmonic {
                    eta,
                    phase,
                    amplitude,
                },
                ..self.clone()
            }),
            _ => None,
        }
    }

    fn rhs(&self, mode: Mode, t: f64, x: &[f64; 4], memo: &Memo) -> [f64; 4] {
        self.rhs_at(mode, self.drive.position(t), x, memo)
    }

    /// The right-hand side for the drive's position z0.
    #[inline]
    fn rhs_at(&self, mode: Mode, z0: f64, x: &[f64; 4], memo: &Memo) -> [f64; 4] {
        let ab = &self.model.absorber;
        let (m, k, d) = (ab.m, ab.k, ab.damping);
        match mode {
            // Behind a contact spring κ (slider stuck at ζs = z2) M2 moves.
            Mode::Stick { z2 } if self.model.contact_stiffness.is_some() => {
                self.held_rhs(z0, z2, x)
            }
            Mode::Stick { z2 } => [
                x[1],
                (k * z0 - d * x[1] - (1.0 + k) * x[0] + z2) / m,
                0.0,
                0.0,
            ],
            Mode::Slip { dir } => {
                let a1 = (k * z0 - d * (x[1] - x[3]) - (1.0 + k) * x[0] + x[2]) / m;
                let fric = self.friction(dir, x[3], memo);
                [x[1], a1, x[3], d * (x[1] - x[3]) + x[0] - x[2] - fric]
            }
        }
    }

    /// The held phase's right-hand side (a contact spring κ, its slider
    /// stuck at ζs = `zs`; out of line, so the rigid model's right-hand
    /// side stays small).
    #[inline(never)]
    fn held_rhs(&self, z0: f64, zs: f64, x: &[f64; 4]) -> [f64; 4] {
        let ab = &self.model.absorber;
        let (m, k, d) = (ab.m, ab.k, ab.damping);
        let kappa = self.model.contact_stiffness.unwrap_or(0.0);
        let a1 = (k * z0 - d * (x[1] - x[3]) - (1.0 + k) * x[0] + x[2]) / m;
        let a2 = d * (x[1] - x[3]) + x[0] - x[2] - kappa * (x[2] - zs);
        [x[1], a1, x[3], a2]
    }

    /// The held phase's second derivative of the state (drive rate `dz0`,
    /// rate `dx`).
    #[inline(never)]
    fn held_rate2(&self, dz0: f64, x: &[f64; 4], dx: &[f64; 4]) -> [f64; 4] {
        let ab = &self.model.absorber;
        let (m, k, d) = (ab.m, ab.k, ab.damping);
        let kappa = self.model.contact_stiffness.unwrap_or(0.0);
        let da1 = (k * dz0 - d * (dx[1] - dx[3]) - (1.0 + k) * x[1] + x[3]) / m;
        let da2 = d * (dx[1] - dx[3]) + x[1] - x[3] - kappa * x[3];
        [dx[1], da1, dx[3], da2]
    }

    /// Friction force on M2 in a slip of direction `dir` at velocity v.
    #[inline]
    fn friction(&self, dir: f64, v: f64, memo: &Memo) -> f64 {
        let law = &self.laws[side(dir)];
        if law.is_frictionless() {
            law.slope() * v
        } else {
            let u = (dir * v).max(0.0);
            dir * law.sliding_with(u, memo.decay(law, u))
        }
    }

    fn jet(&self, mode: Mode, t: f64, x: [f64; 4], memo: &Memo) -> Jet<4> {
        let ab = &self.model.absorber;
        let (m, k, d) = (ab.m, ab.k, ab.damping);
        // One drive evaluation for the rate and its derivative.
        let (z0, dz0, _) = memo.drive(&self.drive, t);
        let dx = self.rhs_at(mode, z0, &x, memo);
        let ddx = match mode {
            Mode::Stick { .. } if self.model.contact_stiffness.is_some() => {
                self.held_rate2(dz0, &x, &dx)
            }
            Mode::Stick { .. } => [
                dx[1],
                (k * dz0 - d * dx[1] - (1.0 + k) * x[1]) / m,
                0.0,
                0.0,
            ],
            Mode::Slip { dir } => {
                let da1 = (k * dz0 - d * (dx[1] - dx[3]) - (1.0 + k) * x[1] + x[3]) / m;
                let dfric = if self.model.law.is_frictionless() {
                    self.model.law.slope() * dx[3]
                } else {
                    let law = &self.laws[side(dir)];
                    let u = (dir * x[3]).max(0.0);
                    law.sliding_slope_with(u, memo.decay(law, u)) * dx[3]
                };
                [dx[1], da1, dx[3], d * (dx[1] - dx[3]) + x[1] - x[3] - dfric]
            }
        };
        Jet { x, dx, ddx }
    }

    fn switches<'a>(&self, mode: Mode, memo: &'a Memo) -> ([NumSwitch<'a>; 2], usize) {
        let law = &self.model.law;
        let (rho_plus, rho_minus) = self.model.thresholds();
        let d = self.model.absorber.damping;
        match mode {
            Mode::Stick { z2 } if self.model.contact_stiffness.is_some() => {
                // The spring's pull P = κ(ζ2 − ζs) reaches ρs⁺ or −ρs⁻.
                let kappa = self.model.contact_stiffness.unwrap_or(0.0);
                let n = if rho_plus.is_finite() { 2 } else { 0 };
                (
                    [
                        NumSwitch::Lin(EventFn {
                            g: [0.0, 0.0, -kappa, 0.0],
                            g0: rho_plus + kappa * z2,
                        }),
                        NumSwitch::Lin(EventFn {
                            g: [0.0, 0.0, kappa, 0.0],
                            g0: rho_minus - kappa * z2,
                        }),
                    ],
                    n,
                )
            }
            Mode::Stick { z2 } => {
                let n = if rho_plus.is_finite() { 2 } else { 0 };
                (
                    [
                        NumSwitch::Lin(EventFn {
                            g: [-1.0, -d, 0.0, 0.0],
                            g0: rho_plus + z2,
                        }),
                        NumSwitch::Lin(EventFn {
                            g: [1.0, d, 0.0, 0.0],
                            g0: rho_minus - z2,
                        }),
                    ],
                    n,
                )
            }
            Mode::Slip { dir } => {
                let end = NumSwitch::Lin(EventFn {
                    g: [0.0, 0.0, 0.0, dir],
                    g0: 0.0,
                });
                let stop = NumSwitch::Friction {
                    dir,
                    thr: self.thr[side(dir)],
                    law: self.laws[side(dir)],
                    memo,
                };
                if law.is_frictionless() {
                    ([end, stop], 0)
                } else {
                    ([end, stop], 2)
                }
            }
        }
    }

    /// Integrates from `init` over `duration`. With a harmonic drive the
    /// observer's period callbacks come every forcing period; trajectory
    /// samples come at the times the observer asks for.
    pub fn run<O: Observer>(&self, init: Init, duration: f64, obs: &mut O) -> RunEnd {
        let period = match self.drive {
            Drive::Harmonic { eta, .. } => Some(2.0 * std::f64::consts::PI / eta),
            _ => None,
        };
        let (periods, tail) = match period {
            Some(p) => event_loop::split_span(duration, p),
            None => (0, duration),
        };
        let st = Numeric {
            sim: self,
            period,
            st: NumState {
                memo: Memo::new(),
                h: self.ode.h_max * 0.1,
                f0: [0.0; 4],
                carry: None,
                t: 0.0,
            },
        };
        event_loop::run(st, init, periods, tail, obs)
    }
}

/// The numerical engine as a [`Stepper`]: one Dormand–Prince step per
/// advance, with the state carried between steps in [`NumState`].
struct Numeric<'a> {
    sim: &'a NumericSim,
    period: Option<f64>,
    st: NumState,
}

/// What the numerical engine carries from one step to the next.
struct NumState {
    memo: Memo,
    /// The next step's size.
    h: f64,
    /// The derivative at the next step's start.
    f0: [f64; 4],
    /// The jet at the next step's start where the last step ended there
    /// without an event.
    carry: Option<Jet<4>>,
    /// Absolute time τ of the current state: t₀ + h after a step, the
    /// event's time after a hit, the boundary at one (the loop's (n, s) is
    /// the same time rounded otherwise; the memo's drive values and the
    /// reported times use this one).
    t: f64,
}

impl Numeric<'_> {
    /// Absolute time τ of offset `s_end` in period n: (n + 1)·T for a
    /// period's end.
    #[inline]
    fn boundary(&self, n: u64, s_end: f64) -> f64 {
        match self.period {
            Some(p) if s_end == p => (n + 1) as f64 * p,
            Some(p) => n as f64 * p + s_end,
            None => s_end,
        }
    }
}

/// Whether `t` is within rounding of `boundary`.
#[inline]
fn at_boundary(t: f64, boundary: f64) -> bool {
    boundary - t <= 4.0 * f64::EPSILON * boundary.abs().max(1.0)
}

impl Stepper for Numeric<'_> {
    fn model(&self) -> &Model {
        &self.sim.model
    }

    fn period(&self) -> Option<f64> {
        self.period
    }

    fn window(&self) -> f64 {
        self.sim.event_window()
    }

    fn begin(&mut self, mode: Mode, x: &[f64; 4], _n: u64, _s: f64, first: bool) {
        if first {
            self.st.h = self.sim.ode.h_max * 0.1;
            self.st.t = 0.0;
        }
        self.st.f0 = self.sim.rhs(mode, self.st.t, x, &self.st.memo);
        self.st.carry = None;
    }

    fn now(&self, _n: u64, _s: f64) -> f64 {
        self.st.t
    }

    /// One accepted step (to the boundary at most) and the first event on
    /// its dense output.
    fn advance<O: Observer + ?Sized>(
        &mut self,
        mode: Mode,
        x: &[f64; 4],
        n: u64,
        _s: f64,
        s_end: f64,
        watch: &mut Watch<'_, O>,
    ) -> Advance {
        let boundary = self.boundary(n, s_end);
        self.sim.step(&mut self.st, mode, x, boundary, watch)
    }

    fn drive(&self, _n: u64, _s: f64) -> f64 {
        self.st.memo.drive(&self.sim.drive, self.st.t).0
    }

    fn rate(&self, mode: Mode, x: &[f64; 4], _n: u64, _s: f64) -> [f64; 4] {
        self.sim.jet(mode, self.st.t, *x, &self.st.memo).dx
    }
}

impl NumericSim {
    /// One accepted step of [`Numeric`] from `st` (to the absolute time
    /// `boundary` at most) and the first event on its dense output.
    #[inline(always)]
    fn step<O: Observer + ?Sized>(
        &self,
        st: &mut NumState,
        mode: Mode,
        x: &[f64; 4],
        boundary: f64,
        watch: &mut Watch<'_, O>,
    ) -> Advance {
        let sim = self;
        let rigid = sim.model.contact_stiffness.is_none();
        let t = st.t;
        if at_boundary(t, boundary) {
            if t != boundary {
                st.carry = None; // the step ended within rounding of it
            }
            st.t = boundary;
            return Advance::Moved {
                delta: 0.0,
                x: *x,
                end: true,
            };
        }
        let memo = &st.memo;
        // Dormand–Prince's last two stages (and the FSAL derivative) share
        // the time t + h with the jet at the step's end: the drive there is
        // evaluated once (with its rate, for the jet). The stages within the
        // step take a harmonic drive from its phasor at t (the last step's
        // end: no transcendental), with the polynomial degree of the
        // attempt's step h set at its first stage (t + h/5: every stage is
        // within η·h).
        let (anchor, eta) = match sim.drive {
            Drive::Harmonic { eta, phase, .. } => (memo.phasor(eta, phase, t), eta),
            _ => ((0.0, 0.0), f64::NAN),
        };
        let deg = Cell::new(None);
        let f = |stage: usize, tt: f64, y: &[f64; 4]| {
            let z0 = if stage >= 6 {
                memo.drive(&sim.drive, tt).0
            } else {
                let d = tt - t;
                if stage == 2 {
                    deg.set(cis_degree(eta * d * 5.0));
                }
                Memo::position_near(&sim.drive, anchor, deg.get(), tt, d)
            };
            sim.rhs_at(mode, z0, y, memo)
        };
        let Some((step, h_next)) = sim.ode.step(&f, t, x, &st.f0, st.h, boundary) else {
            return Advance::Underflow { tau: t };
        };
        let (t0, x0) = (t, *x);
        // The state at offset d in the step (dense output).
        let state = |d: f64| {
            let mut y = if d == 0.0 {
                x0
            } else if d == step.h {
                step.y1
            } else {
                step.eval(d)
            };
            if let Mode::Stick { z2 } = mode {
                if rigid {
                    y[2] = z2;
                    y[3] = 0.0;
                }
            }
            y
        };
        // The jet at the step's start is the last step's end jet (same
        // mode, time and state) unless an event intervened.
        let carry = &st.carry;
        let eval = |d: f64| match carry {
            Some(j) if d == 0.0 => *j,
            _ => sim.jet(mode, t0 + d, state(d), memo),
        };
        let (fns, nf) = sim.switches(mode, memo);
        // Samples within the step: the drive from the phasor at t0.
        let deg = cis_degree(eta * step.h);
        let (hit, jb) = events::first_event(
            &eval,
            eval,
            &fns[..nf],
            step.h,
            step.h,
            t0 + step.h,
            |a, ja, b, jb| {
                watch.extremes(&eval, a, ja, b, jb);
                while let Some(ts) = watch.pending() {
                    if ts > t0 + b {
                        break;
                    }
                    // State and rate only (no second derivative).
                    let d = (ts - t0).max(a);
                    let y = state(d);
                    let z0 = Memo::position_near(&sim.drive, anchor, deg, t0 + d, d);
                    watch.deliver(ts, &y, &sim.rhs_at(mode, z0, &y, memo));
                }
            },
        );
        match hit {
            None => {
                let t1 = t0 + step.h;
                let end = at_boundary(t1, boundary);
                st.carry = if end && t1 != boundary {
                    None
                } else {
                    Some(jb)
                };
                st.t = if end { boundary } else { t1 };
                st.f0 = step.f1;
                st.h = h_next;
                Advance::Moved {
                    delta: step.h,
                    x: jb.x,
                    end,
                }
            }
            Some(hit) => {
                st.t = t0 + hit.delta;
                st.h = st.h.min(h_next).max(sim.ode.h_max * 1e-3);
                Advance::Hit {
                    delta: hit.delta,
                    which: hit.which,
                    x: hit.jet.x,
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The Taylor cosine and sine agree with libm's to a few ε over each
    /// degree's radius, and the harmonic drive taken from a phasor by angle
    /// addition with its position.
    #[test]
    fn cis_matches_libm() {
        for m in 0..CIS_RADIUS.len() {
            let r = CIS_RADIUS[m];
            for k in -100..=100 {
                let w = r * (k as f64 / 100.0);
                assert_eq!(cis_degree(w).map(|d| d <= m), Some(true));
                let (c, s) = cis(w, m);
                assert!((c - w.cos()).abs() <= 4.0 * f64::EPSILON, "cos {m} {w}");
                assert!((s - w.sin()).abs() <= 4.0 * f64::EPSILON, "sin {m} {w}");
            }
        }
        assert_eq!(cis_degree(1.2), None);
        let drive = Drive::Harmonic {
            eta: 0.83,
            phase: 0.4,
            amplitude: 1.3,
        };
        let memo = Memo::new();
        for t0 in [0.0, 3.7, 151.2] {
            let anchor = memo.phasor(0.83, 0.4, t0);
            for k in 0..=50 {
                let d = k as f64 / 50.0 / 0.83;
                let z = Memo::position_near(&drive, anchor, cis_degree(0.83 * d), t0 + d, d);
                let exact = drive.position(t0 + d);
                // (The argument's rounding: ε·|ητ|.)
                let tol = 8.0 * f64::EPSILON * (1.0 + 0.83 * (t0 + d));
                assert!((z - exact).abs() <= tol, "{t0} {d}: {z} {exact}");
            }
        }
    }
}
