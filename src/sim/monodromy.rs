//! The Jacobian of the exact engine's p-period map (the monodromy matrix),
//! from the variational equations of the piecewise-linear system, for
//! Newton shooting ([`super::sweep`]).
//!
//! Within a phase the flow is affine with a constant matrix A, so a
//! perturbation of the state is carried by e^{AΔ} (Δ: the phase's length);
//! the drive and the constant friction input drop out. At a switching
//! event g(x) = 0 the perturbation jumps by the saltation matrix
//!
//! ```text
//! S = I + (f⁺ − f⁻)·∇gᵀ / (∇g·f⁻)
//! ```
//!
//! (f∓: the vector fields just before and after the event; Aizerman &
//! Gantmacher 1958, Leine & Nijmeijer 2004, §7). For the absorber (state
//! `[ζ1, ζ1', ζ2, ζ2']`, M2's equation normalised to unit mass) only ζ2''
//! jumps at an event, so S differs from I in its last row only:
//!
//! * slip → stick (g = ζ2'): ζ2''⁺ = 0, S = I − e4·e4ᵀ (a stuck M2 has no
//!   velocity perturbation);
//! * stick → slip (g = F ∓ ρs, F = ζ1 − ζ2 + D(ζ1' − ζ2')):
//!   S = I + e4·ζ2''⁺·∇Fᵀ/F', ∇F = (1, D, −1, −D), F' = ζ1' + D·ζ1'' in the
//!   stick, ζ2''⁺ = F − ρd(dir)·dir with the dynamic level of the new
//!   sliding direction (I when ρs = ρd);
//! * reversal (g = ζ2'): S = I + e4·e4ᵀ·(ζ2''⁺ − ζ2''⁻)/ζ2''⁻.
//!
//! A stuck phase carries ζ2 as a constant input of M1's equation:
//! e^{A4Δ} = [[E, B⁻¹(E − I)·c, 0], [0, 1, 0], [0, 0, 0]] with E = e^{BΔ}
//! of the 2×2 stick matrix B and c = (0, 1/m).
//!
//! Behind a contact spring κ (issue 34) the slider's position ζs is a
//! fifth coordinate while it is held (state `[ζ1, ζ1', ζ2, ζ2', ζs]`; in a
//! slip the massless slider follows M2, ζs = ζ2 − f/κ, and carries no
//! perturbation of its own). The held phase is linear with ζs a constant
//! input κζs of M2's equation: e^{A5Δ} = [[E, κH⁻¹(E − I)·e4], [0, 1]]
//! with E = e^{HΔ} of the 4×4 held matrix H. Its events:
//!
//! * slide end (slip → held, g = ζ2'): the slider stops where the spring
//!   holds the sliding level, ζs = ζ2 − ρd(dir)·dir/κ (a reset R with
//!   ∂ζs⁺/∂x = e3ᵀ); M2's acceleration F − ρd(dir)·dir is the same on both
//!   sides (f⁺ = R·f⁻), so S = R: only ζs's row changes, to e3ᵀ;
//! * breakaway (held → slip, g = κ(ζ2 − ζs) ∓ ρs): ∇g = κ(e3 − e5),
//!   ∇g·f⁻ = κζ2', and ζ2'' jumps from F − κ(ζ2 − ζs) = F − ρs(dir)·dir to
//!   F − ρd(dir)·dir − D*ζ2', so ζ2'’s row gains
//!   (ζ2''⁺ − ζ2''⁻)/ζ2' · (e3 − e5)ᵀ (grazing where ζ2' vanishes); ζs's
//!   row becomes 0 (the slider follows M2).
//!
//! One run gives the Jacobian that forward differences need dim + 1 runs
//! for, and it is exact where they carry an O(h) error. Where the formula
//! does not hold — a grazing event (∇g·f⁻ ≈ 0), several switches at one
//! instant, an interruption, a law the exact engine does not integrate, an
//! ill-conditioned modal form — [`Monodromy::map`] returns `None` and the
//! caller falls back to differences.

use super::engine::{Event, EventKind, Init, Mode, Observer, Sim, Status};
use super::event_loop::side;
use super::linalg::{self, C64};
use super::phase::{absorber, conjugate_terms};
use crate::model::{Absorber, Law};

/// Condition number of an eigenvector matrix above which the modal
/// exponential is not trusted (its error grows like cond·ε).
const MAX_COND: f64 = 1e6;

/// A denominator ∇g·f⁻ below this fraction of its terms' size is a grazing
/// event, where the saltation matrix does not exist.
const GRAZING: f64 = 1e-8;

/// Per-model set-up of the variational propagation (independent of η).
#[derive(Debug, Clone)]
pub struct Monodromy {
    ab: Absorber,
    /// Dynamic levels by sliding direction (ρd⁺, ρd⁻).
    rho_d: [f64; 2],
    slip: Spectral<4>,
    stick: Spectral<2>,
    /// B⁻¹ of the 2×2 stick matrix.
    stick_inv: [[f64; 2]; 2],
    /// Behind a contact spring: the held phase's set-up.
    contact: Option<Box<Contact>>,
}

/// The held phase of a pad behind a contact spring (see the module doc).
#[derive(Debug, Clone)]
struct Contact {
    kappa: f64,
    /// Breakaway thresholds by sliding direction (ρs⁺, ρs⁻).
    rho_s: [f64; 2],
    /// The slope D* of the sliding friction.
    slope: f64,
    held: Spectral<4>,
    /// H⁻¹ of the 4×4 held matrix.
    held_inv: [[f64; 4]; 4],
}

/// A 5×5 Jacobian in the state `[ζ1, ζ1', ζ2, ζ2', ζs]` (ζs: the slider's
/// position behind a contact spring while it is held).
pub type M5 = [[f64; 5]; 5];

/// Records a run's events (nothing else; no exact extremes).
#[derive(Default)]
pub(crate) struct Events(pub(crate) Vec<Event>);

impl Observer for Events {
    fn event(&mut self, ev: &Event) {
        self.0.push(*ev);
    }
    fn wants_extremes(&self) -> bool {
        false
    }
}

/// A 4×4 Jacobian in the state `[ζ1, ζ1', ζ2, ζ2']`.
pub type M4 = [[f64; 4]; 4];

/// Whether an event's rate `v` (∇g·f⁻) vanishes against the size of its
/// terms (or is not a number).
fn grazing(v: f64, size: f64) -> bool {
    v.abs().partial_cmp(&(GRAZING * size)) != Some(std::cmp::Ordering::Greater)
}

fn identity() -> M4 {
    let mut m = [[0.0; 4]; 4];
    for (i, r) in m.iter_mut().enumerate() {
        r[i] = 1.0;
    }
    m
}

/// The product of two N×N matrices (4: the state; 5: the extended state).
fn mul<const N: usize>(a: &[[f64; N]; N], b: &[[f64; N]; N]) -> [[f64; N]; N] {
    let mut c = [[0.0; N]; N];
    for i in 0..N {
        for k in 0..N {
            let aik = a[i][k];
            if aik != 0.0 {
                for j in 0..N {
                    c[i][j] += aik * b[k][j];
                }
            }
        }
    }
    c
}

/// e^{AΔ} = Re(V·diag(e^{λΔ})·V⁻¹) = Σ_k Re(e^{λkΔ}·Pk) of a real matrix,
/// with the spectral projectors Pk = V[:, k]·V⁻¹[k, :] precomputed; of a
/// conjugate pair only one term is kept, weighted by 2.
#[derive(Debug, Clone)]
struct Spectral<const N: usize> {
    terms: Vec<(C64, [[C64; N]; N])>,
}

impl<const N: usize> Spectral<N> {
    fn new(a: &[[f64; N]; N]) -> Option<Self> {
        let md = linalg::modal(a)?;
        if md.cond > MAX_COND {
            return None;
        }
        let (reps, n) = conjugate_terms(&md)?;
        let terms = reps[..n]
            .iter()
            .map(|&(k, weight)| {
                let p: [[C64; N]; N] = std::array::from_fn(|i| {
                    std::array::from_fn(|j| md.v[i][k] * md.vinv[k][j] * weight)
                });
                (md.lambda[k], p)
            })
            .collect();
        Some(Self { terms })
    }

    fn exp(&self, delta: f64) -> [[f64; N]; N] {
        let mut out = [[0.0; N]; N];
        for (l, p) in &self.terms {
            let e = (*l * delta).exp();
            for i in 0..N {
                for j in 0..N {
                    out[i][j] += e.re * p[i][j].re - e.im * p[i][j].im;
                }
            }
        }
        out
    }
}

impl Monodromy {
    /// The set-up for the engine's model; `None` for a law the exact engine
    /// does not integrate, for a frictionless or never-slipping law, or
    /// where a modal form is ill-conditioned.
    pub fn new(sim: &Sim) -> Option<Self> {
        let model = sim.model();
        let Law::Linear { slope, .. } = model.law else {
            return None;
        };
        let rho_d = [1.0, -1.0].map(|dir| model.law.levels(dir).rho_d);
        if model.law.is_frictionless() || model.law.is_always_stuck() {
            return None;
        }
        let ab = model.absorber;
        let slip = Spectral::new(&absorber::slip_matrix(&ab, slope))?;
        let b = absorber::stick_matrix(&ab);
        let stick = Spectral::new(&b)?;
        let stick_inv = linalg::real_inverse(&b)?;
        let contact = match model.contact_stiffness {
            Some(kappa) => {
                let h = absorber::held_matrix(&ab, kappa);
                Some(Box::new(Contact {
                    kappa,
                    rho_s: [1.0, -1.0].map(|dir| model.law.levels(dir).rho_s),
                    slope,
                    held: Spectral::new(&h)?,
                    held_inv: linalg::real_inverse(&h)?,
                }))
            }
            None => None,
        };
        Some(Self {
            ab,
            rho_d,
            slip,
            stick,
            stick_inv,
            contact,
        })
    }

    /// Whether the model has a contact spring (the state then has a fifth
    /// coordinate while held: [`Monodromy::map_ext`]).
    pub fn is_contact(&self) -> bool {
        self.contact.is_some()
    }

    /// e^{A4Δ} of a stuck phase in the full state (see the module doc).
    fn stick_flow(&self, delta: f64) -> M4 {
        let e = self.stick.exp(delta);
        let c1 = 1.0 / self.ab.m;
        // B⁻¹(E − I)·c with c = (0, c1).
        let w = [e[0][1] * c1, (e[1][1] - 1.0) * c1];
        let col = [
            self.stick_inv[0][0] * w[0] + self.stick_inv[0][1] * w[1],
            self.stick_inv[1][0] * w[0] + self.stick_inv[1][1] * w[1],
        ];
        [
            [e[0][0], e[0][1], col[0], 0.0],
            [e[1][0], e[1][1], col[1], 0.0],
            [0.0, 0.0, 1.0, 0.0],
            [0.0, 0.0, 0.0, 0.0],
        ]
    }

    fn flow(&self, mode: Mode, delta: f64) -> M4 {
        match mode {
            Mode::Stick { .. } => self.stick_flow(delta),
            Mode::Slip { .. } => self.slip.exp(delta),
        }
    }

    /// The last row of the saltation matrix S of event `ev` entered from
    /// `before` (the other rows are those of I), at drive ζ0 = `z0`;
    /// `None` at a grazing event or an interruption.
    fn saltation_row(&self, before: Mode, ev: &Event, z0: f64) -> Option<[f64; 4]> {
        let ab = &self.ab;
        let x = &ev.x;
        let d = ab.damping;
        let force = x[0] - x[2] + d * (x[1] - x[3]);
        match (ev.kind, before) {
            (EventKind::Stick, Mode::Slip { .. }) => Some([0.0; 4]),
            (EventKind::SlipPlus | EventKind::SlipMinus, Mode::Stick { .. }) => {
                let dir = if ev.kind == EventKind::SlipPlus {
                    1.0
                } else {
                    -1.0
                };
                // F' along the stick's flow (ζ2' = ζ2'' = 0).
                let acc1 = (-(1.0 + ab.k) * x[0] - d * x[1] + x[2] + ab.k * z0) / ab.m;
                let rate = x[1] + d * acc1;
                let size = x[1].abs() + d * acc1.abs();
                if grazing(rate, size) {
                    return None;
                }
                let jump = (force - self.rho_d[side(dir)] * dir) / rate;
                Some([jump, jump * d, -jump, 1.0 - jump * d])
            }
            (EventKind::ReversePlus | EventKind::ReverseMinus, Mode::Slip { dir: old }) => {
                let new = -old;
                let acc_before = force - self.rho_d[side(old)] * old;
                let acc_after = force - self.rho_d[side(new)] * new;
                if grazing(acc_before, force.abs() + self.rho_d[side(old)]) {
                    return None;
                }
                Some([0.0, 0.0, 0.0, acc_after / acc_before])
            }
            _ => None,
        }
    }

    /// P^p(x) from `init` (p = `periods`) by `sim`, with the Jacobian
    /// ∂P^p/∂x in the full state (rows and columns ζ1, ζ1', ζ2, ζ2'); for a
    /// stuck start the columns of ζ1, ζ1' and ζ2 (ζ2' = 0, ζ2* = ζ2) are
    /// the meaningful ones. `None` where the run does not complete or the
    /// variational formula does not hold (see the module doc).
    pub fn map(&self, sim: &Sim, init: Init, periods: u64) -> Option<([f64; 4], Mode, M4)> {
        let mut rec = Events(Vec::with_capacity(8 * periods as usize));
        let end = sim.run(init, periods, &mut rec);
        if !matches!(end.status, Status::Completed) {
            return None;
        }
        let m = self.carry(init.mode, &rec.0, 0.0, end.tau, sim.eta())?;
        Some((end.x, end.mode, m))
    }

    /// The Jacobian of the flow over the span [`t0`, `t1`] of a run (τ from
    /// the run's start, drive cos(ητ)) that starts in `mode` and meets
    /// `events` (in order, inside the span). `None` where the variational
    /// formula does not hold (see the module doc).
    /// Behind a contact spring the held state has five coordinates:
    /// `None` (see [`Monodromy::carry_ext`]).
    pub fn carry(&self, mode: Mode, events: &[Event], t0: f64, t1: f64, eta: f64) -> Option<M4> {
        if self.contact.is_some() {
            return None;
        }
        let mut m = identity();
        let mut mode = mode;
        let mut t_prev = t0;
        for ev in events {
            let delta = ev.tau - t_prev;
            if delta <= 0.0 {
                // Several switches at one instant.
                return None;
            }
            m = mul(&self.flow(mode, delta), &m);
            let row = self.saltation_row(mode, ev, (eta * ev.tau).cos())?;
            // S·M with S = I except its last row.
            m[3] = std::array::from_fn(|j| (0..4).map(|k| row[k] * m[k][j]).sum());
            mode = match ev.kind {
                EventKind::Stick => Mode::Stick { z2: ev.x[2] },
                EventKind::SlipPlus | EventKind::ReversePlus => Mode::Slip { dir: 1.0 },
                _ => Mode::Slip { dir: -1.0 },
            };
            t_prev = ev.tau;
        }
        let delta = t1 - t_prev;
        if delta < 0.0 {
            return None;
        }
        Some(mul(&self.flow(mode, delta), &m))
    }

    /// [`Monodromy::map`] in the extended state `[ζ1, ζ1', ζ2, ζ2', ζs]`
    /// (ζs: the slider held behind a contact spring, from a held start the
    /// mode's `z2`); for a rigid stick the 4×4 Jacobian in the upper left
    /// (its ζs row and column are zero).
    pub fn map_ext(&self, sim: &Sim, init: Init, periods: u64) -> Option<([f64; 4], Mode, M5)> {
        if self.contact.is_none() {
            let (x, mode, m) = self.map(sim, init, periods)?;
            let mut j = [[0.0; 5]; 5];
            for (r, row) in m.iter().enumerate() {
                j[r][..4].copy_from_slice(row);
            }
            return Some((x, mode, j));
        }
        let mut rec = Events(Vec::with_capacity(8 * periods as usize));
        let end = sim.run(init, periods, &mut rec);
        if !matches!(end.status, Status::Completed) {
            return None;
        }
        let m = self.carry_ext(init.mode, &rec.0, 0.0, end.tau)?;
        Some((end.x, end.mode, m))
    }

    /// [`Monodromy::carry`] for a pad behind a contact spring, in the
    /// extended state (see the module doc; its saltations do not involve
    /// the drive); `None` for a rigid stick or where the variational
    /// formula does not hold.
    pub fn carry_ext(&self, mode: Mode, events: &[Event], t0: f64, t1: f64) -> Option<M5> {
        let c = self.contact.as_deref()?;
        let mut m: M5 = std::array::from_fn(|i| std::array::from_fn(|j| f64::from(i == j)));
        let mut mode = mode;
        let mut t_prev = t0;
        for ev in events {
            let delta = ev.tau - t_prev;
            if delta <= 0.0 {
                return None;
            }
            m = mul(&self.flow_ext(c, mode, delta), &m);
            let x = &ev.x;
            match (ev.kind, mode) {
                (EventKind::Stick, Mode::Slip { .. }) => {
                    // S = R: the slider stops at ζ2 − ρd·dir/κ.
                    m[4] = m[2];
                }
                (EventKind::SlipPlus | EventKind::SlipMinus, Mode::Stick { .. }) => {
                    let dir = if ev.kind == EventKind::SlipPlus {
                        1.0
                    } else {
                        -1.0
                    };
                    let force = x[0] - x[2] + self.ab.damping * (x[1] - x[3]);
                    let before = force - c.rho_s[side(dir)] * dir;
                    let after = force - self.rho_d[side(dir)] * dir - c.slope * x[3];
                    if grazing(x[3], x[1].abs() + x[3].abs()) {
                        return None;
                    }
                    let jump = (after - before) / x[3];
                    let (r2, r4) = (m[2], m[4]);
                    for (j, v) in m[3].iter_mut().enumerate() {
                        *v += jump * (r2[j] - r4[j]);
                    }
                    m[4] = [0.0; 5];
                }
                _ => return None,
            }
            mode = match ev.kind {
                EventKind::Stick => Mode::Stick { z2: 0.0 },
                EventKind::SlipPlus => Mode::Slip { dir: 1.0 },
                _ => Mode::Slip { dir: -1.0 },
            };
            t_prev = ev.tau;
        }
        let delta = t1 - t_prev;
        if delta < 0.0 {
            return None;
        }
        Some(mul(&self.flow_ext(c, mode, delta), &m))
    }

    /// e^{A5Δ} of a phase behind a contact spring (see the module doc): a
    /// slip carries no perturbation of ζs.
    fn flow_ext(&self, c: &Contact, mode: Mode, delta: f64) -> M5 {
        let mut out = [[0.0; 5]; 5];
        match mode {
            Mode::Slip { .. } => {
                let e = self.slip.exp(delta);
                for (o, r) in out.iter_mut().zip(&e) {
                    o[..4].copy_from_slice(r);
                }
            }
            Mode::Stick { .. } => {
                let e = c.held.exp(delta);
                // κH⁻¹(E − I)·e4.
                let w: [f64; 4] = std::array::from_fn(|i| e[i][3] - f64::from(i == 3));
                for (i, (o, r)) in out.iter_mut().zip(&e).enumerate() {
                    o[..4].copy_from_slice(r);
                    o[4] = c.kappa * (0..4).map(|k| c.held_inv[i][k] * w[k]).sum::<f64>();
                }
                out[4][4] = 1.0;
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Model;

    fn model(rho_s: f64, rho_d: f64, slope: f64) -> Model {
        Model {
            absorber: Absorber {
                m: 4.0,
                k: 1.0,
                damping: 0.003,
            },
            law: Law::Linear {
                rho_s,
                rho_d,
                slope,
                minus: None,
            },
            stop_below: None,
            contact_stiffness: None,
        }
    }

    /// Central differences of P^p in the coordinates shooting varies.
    fn differences(sim: &Sim, x: [f64; 4], mode: Mode, p: u64) -> M4 {
        let stuck = matches!(mode, Mode::Stick { .. });
        let dim = if stuck { 3 } else { 4 };
        let run = |y: [f64; 4]| {
            let mode = if stuck {
                Mode::Stick { z2: y[2] }
            } else {
                mode
            };
            let e = sim.run(Init { x: y, mode }, p, &mut ());
            e.x
        };
        central(x, dim, 4, run)
    }

    /// Central differences of `run` at `x`: columns 0..`cols`, rows
    /// 0..`rows` (the rest 0).
    fn central<const N: usize>(
        x: [f64; N],
        cols: usize,
        rows: usize,
        run: impl Fn([f64; N]) -> [f64; N],
    ) -> [[f64; N]; N] {
        let mut j = [[0.0; N]; N];
        for c in 0..cols {
            let h = 1e-6 * (1.0 + x[c].abs());
            let (mut a, mut b) = (x, x);
            a[c] += h;
            b[c] -= h;
            let (pa, pb) = (run(a), run(b));
            for i in 0..rows {
                j[i][c] = (pa[i] - pb[i]) / (2.0 * h);
            }
        }
        j
    }

    /// The variational Jacobian agrees with central differences on runs
    /// with sticks, releases (ρs ≠ ρd, with and without slope) and
    /// reversals, from stuck and slipping starts, over 1 and 3 periods, on
    /// two absorbers, with symmetric and direction-dependent levels.
    #[test]
    fn jacobian_matches_differences() {
        let sym = None;
        let cases = [
            // (ρs, ρd, slope, η, negative levels): stick-slip with sticks,
            // static > dynamic.
            (0.375, 0.3, 0.0, 0.6, sym),
            (0.375, 0.375, 0.0, 0.6, sym),
            (0.5, 0.4, -0.02, 0.75, sym),
            // Light friction: slips through with reversals.
            (0.05, 0.05, 0.0, 0.45, sym),
            (1.2, 0.9, 0.0, 0.7, sym),
            // Direction-dependent pads: the saltation of each direction's
            // breakaway and reversal uses that direction's dynamic level.
            (0.5, 0.4, 0.0, 0.6, Some((0.35, 0.25))),
            (0.375, 0.375, -0.01, 0.6, Some((0.45, 0.45))),
            (0.06, 0.05, 0.0, 0.45, Some((0.04, 0.04))),
            (1.2, 0.9, 0.0, 0.7, Some((0.8, 0.7))),
        ];
        let mut kinds = std::collections::BTreeSet::new();
        // The same cases on a second absorber (m 2, k 0.5, D 0.01).
        let other = Absorber {
            m: 2.0,
            k: 0.5,
            damping: 0.01,
        };
        let models = cases.iter().flat_map(|&(rs, rd, slope, eta, minus)| {
            let mut paper = model(rs, rd, slope);
            paper.law = paper
                .law
                .with_minus(minus.map(|(rho_s, rho_d)| crate::model::Levels { rho_s, rho_d }));
            let second = Model {
                absorber: other,
                ..paper
            };
            [(paper, eta), (second, eta)]
        });
        for (m, eta) in models {
            let Law::Linear {
                rho_s: rs,
                rho_d: rd,
                slope,
                ..
            } = m.law
            else {
                unreachable!()
            };
            let sim = Sim::new(&m, eta).unwrap();
            let mono = Monodromy::new(&sim).unwrap();
            // A state on the attractor (after a transient).
            let e = sim.run(Init::rest(), 60, &mut ());
            let start = Init {
                x: e.x,
                mode: e.mode,
            };
            for p in [1, 3] {
                record_kinds(&sim, start, p, &mut kinds);
                let Some((x, mode, j)) = mono.map(&sim, start, p) else {
                    panic!(
                        "no variational Jacobian for m {} rho {rs} {rd} minus {:?} slope {slope} eta {eta} p {p}",
                        m.absorber.m,
                        m.law.minus()
                    );
                };
                assert_eq!(x, e_map(&sim, start, p).0);
                assert_eq!(mode, e_map(&sim, start, p).1);
                let fd = differences(&sim, start.x, start.mode, p);
                let dim = if matches!(start.mode, Mode::Stick { .. }) {
                    3
                } else {
                    4
                };
                let scale = fd
                    .iter()
                    .flat_map(|r| r[..dim].iter())
                    .fold(1.0f64, |a, v| a.max(v.abs()));
                for i in 0..4 {
                    for c in 0..dim {
                        assert!(
                            (j[i][c] - fd[i][c]).abs() <= 1e-7 * scale,
                            "case m {} rho {rs} {rd} minus {:?} slope {slope} eta {eta} p {p}: J[{i}][{c}] = {} against {} (differences)",
                            m.absorber.m,
                            m.law.minus(),
                            j[i][c],
                            fd[i][c]
                        );
                    }
                }
            }
        }
        // The cases exercise every kind of switch.
        for k in ["stick", "slip+", "slip-", "reverse+", "reverse-"] {
            assert!(kinds.contains(k), "no {k} event in the cases: {kinds:?}");
        }
    }

    /// Extended coordinates of a state behind a contact spring (held: ζs
    /// the mode's slider position; slipping: four).
    fn ext(init: &Init) -> ([f64; 5], usize) {
        let x = init.x;
        match init.mode {
            Mode::Stick { z2 } => ([x[0], x[1], x[2], x[3], z2], 5),
            Mode::Slip { .. } => ([x[0], x[1], x[2], x[3], 0.0], 4),
        }
    }

    /// The variational Jacobian behind a contact spring agrees with central
    /// differences in the extended state, from held and sliding starts, over
    /// 1 and 3 periods: stiff and soft contacts, ρs above and equal to ρd,
    /// with a slope, direction-dependent levels, on two absorbers.
    #[test]
    fn contact_jacobian_matches_differences() {
        let sym = None;
        // (ρs, ρd, slope, η, κ, negative levels).
        let cases = [
            (0.375, 0.3, 0.0, 0.6, 20.0, sym),
            (0.375, 0.375, 0.0, 0.6, 5.0, sym),
            (0.5, 0.4, -0.02, 0.75, 100.0, sym),
            (0.05, 0.05, 0.0, 0.45, 40.0, sym),
            (1.2, 0.9, 0.0, 0.7, 10.0, sym),
            (0.5, 0.4, 0.0, 0.6, 20.0, Some((0.35, 0.25))),
            (0.375, 0.375, -0.01, 0.9, 8.0, Some((0.45, 0.45))),
        ];
        let other = Absorber {
            m: 2.0,
            k: 0.5,
            damping: 0.01,
        };
        let mut kinds = std::collections::BTreeSet::new();
        let mut starts = [0usize; 2];
        for &(rs, rd, slope, eta, kappa, minus) in &cases {
            let mut paper = model(rs, rd, slope);
            paper.law = paper
                .law
                .with_minus(minus.map(|(rho_s, rho_d)| crate::model::Levels { rho_s, rho_d }));
            paper.contact_stiffness = Some(kappa);
            let second = Model {
                absorber: other,
                ..paper
            };
            for m in [paper, second] {
                let sim = Sim::new(&m, eta).unwrap();
                let mono = Monodromy::new(&sim).unwrap();
                assert!(mono.is_contact());
                // States on the attractor at several drive phases (held and
                // sliding starts where the orbit has both), each run from
                // drive phase 0.
                for frac in [0.0, 0.3, 0.55, 0.8] {
                    let e = sim.run_span(
                        Init::rest(),
                        0.0,
                        1.0,
                        (60.0 + frac) * sim.period(),
                        &mut (),
                    );
                    let st = Init {
                        x: e.x,
                        mode: e.mode,
                    };
                    for p in [1, 3] {
                        record_kinds(&sim, st, p, &mut kinds);
                        let label = format!(
                            "m {} rho {rs} {rd} minus {minus:?} slope {slope} eta {eta} kappa {kappa} p {p} from {:?}",
                            m.absorber.m, st.mode
                        );
                        let Some((x, mode, j)) = mono.map_ext(&sim, st, p) else {
                            panic!("no variational Jacobian: {label}");
                        };
                        let end = sim.run(st, p, &mut ());
                        assert_eq!((x, mode), (end.x, end.mode), "{label}");
                        let (y, dim) = ext(&st);
                        let (_, dim_end) = ext(&Init { x, mode });
                        let run = |y: [f64; 5]| {
                            let init = Init {
                                x: [y[0], y[1], y[2], y[3]],
                                mode: match st.mode {
                                    Mode::Stick { .. } => Mode::Stick { z2: y[4] },
                                    slip => slip,
                                },
                            };
                            let e = sim.run(init, p, &mut ());
                            assert_eq!(
                                matches!(e.mode, Mode::Stick { .. }),
                                matches!(mode, Mode::Stick { .. }),
                                "{label}: a difference step changed the end mode"
                            );
                            ext(&Init {
                                x: e.x,
                                mode: e.mode,
                            })
                            .0
                        };
                        let fd = central(y, dim, dim_end, run);
                        let scale = fd
                            .iter()
                            .flat_map(|r| r[..dim].iter())
                            .fold(1.0f64, |a, v| a.max(v.abs()));
                        for i in 0..dim_end {
                            for c in 0..dim {
                                assert!(
                                    (j[i][c] - fd[i][c]).abs() <= 1e-6 * scale,
                                    "{label}: J[{i}][{c}] = {} against {} (differences)",
                                    j[i][c],
                                    fd[i][c]
                                );
                            }
                        }
                        starts[usize::from(dim == 4)] += 1;
                    }
                }
            }
        }
        for k in ["stick", "slip+", "slip-"] {
            assert!(kinds.contains(k), "no {k} event in the cases: {kinds:?}");
        }
        assert!(
            starts[0] > 0 && starts[1] > 0,
            "held and sliding starts: {starts:?}"
        );
    }

    /// Adds the kinds of the events of `p` periods from `start` to `kinds`.
    fn record_kinds(
        sim: &Sim,
        start: Init,
        p: u64,
        kinds: &mut std::collections::BTreeSet<&'static str>,
    ) {
        let mut rec = Events::default();
        sim.run(start, p, &mut rec);
        for ev in &rec.0 {
            kinds.insert(ev.kind.as_str());
        }
    }

    fn e_map(sim: &Sim, init: Init, p: u64) -> ([f64; 4], Mode) {
        let e = sim.run(init, p, &mut ());
        (e.x, e.mode)
    }

    #[test]
    fn no_jacobian_for_laws_it_cannot_carry() {
        let frictionless = model(0.0, 0.0, 0.0);
        let sim = Sim::new(&frictionless, 0.6).unwrap();
        assert!(Monodromy::new(&sim).is_none());
    }
}
