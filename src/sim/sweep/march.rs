//! Stages 2–5 of a steady state: the march on the Poincaré section, with
//! the stick proof and shooting tried on the way, and the early stop of a
//! quasi-periodic march from its finite-time Lyapunov exponent.

use super::*;
use crate::model::Model;
use crate::sim::engine::{Event, EventKind, Flow, Init, Mode, Observer, PeriodStats, Status};
use crate::sim::monodromy::Monodromy;
use crate::sim::steady::{merge_back, Tracker, MAX_PERIOD_MULTIPLE, RING};
use crate::sim::SimError;

/// Stages 2–5 of [`steady_state`] on the engine `eng` at η.
pub(super) fn march_to_steady(
    eng: &SweepEngine,
    model: &Model,
    eta: f64,
    init: Init,
    cfg: &SteadyConfig,
) -> Result<(Point, Init), SimError> {
    march_to_steady_extremes(eng, model, eta, init, cfg, false)
}

/// [`march_to_steady`], locating every period's extremes from the start
/// when `eager` (the reference the lazy default is tested against).
pub(super) fn march_to_steady_extremes(
    eng: &SweepEngine,
    model: &Model,
    eta: f64,
    init: Init,
    cfg: &SteadyConfig,
    eager: bool,
) -> Result<(Point, Init), SimError> {
    let t = 2.0 * std::f64::consts::PI / eta;
    let mut unit = ();
    let mut w = Walk {
        sim: &eng.engine,
        shooting: &eng.shooting,
        tr: Tracker::new(&mut unit, cfg.tol, true),
        start: init,
        state: init,
        dwell: 0,
        used: 0,
        exact_from: eager.then_some(0),
        tangent: None,
    };
    // 2. Transient, watched on the section, with 3. the proof of a
    //    permanent stick tried after 2, 4, 8, … periods of it: once it
    //    holds it holds for good (the stuck position stays, the free
    //    motion's energy only decreases), so the rest of the transient
    //    would end in the same closed form.
    let transient = cfg.transient.min(cfg.max_periods);
    let mut marched = 0;
    let mut chunk = PROOF_FIRST.min(transient);
    loop {
        if let Some(r) = w.march_watched(chunk, eta, t) {
            return Ok(r);
        }
        marched += chunk;
        if let Some(r) = stick_proof(model, eta, &w.state, w.used) {
            return Ok(r);
        }
        if marched >= transient {
            break;
        }
        chunk = marched.min(transient - marched);
    }
    // 4. Newton shooting on the p-th iterate, accepted only where the
    //    trajectory itself is seen to approach the orbit found; between
    //    attempts the trajectory marches on.
    if cfg.shooting {
        let mut block = cfg.transient.max(16);
        for _ in 0..SHOOTING_ATTEMPTS {
            match w.try_shooting(eta, t, cfg) {
                Shot::Accepted(r) => return Ok(r),
                Shot::Failed(p) => return Ok((p, Init::rest())),
                Shot::Settled(p) => return Ok(w.settled(eta, p, t)),
                Shot::Rejected => {}
            }
            let left = cfg.max_periods.saturating_sub(w.dwell);
            if left == 0 {
                break;
            }
            if let Some(r) = w.march_watched(block.min(left), eta, t) {
                return Ok(r);
            }
            block *= 2;
        }
    }
    // 5. Time marching to the end of the budget, in blocks of EARLY_BLOCK
    //    periods. Past EARLY_MIN periods, a trajectory whose section came
    //    no closer to closing any orbit (the smallest distance between an
    //    iterate and the one p periods before, p = 1..=MAX) in two blocks
    //    in a row than in the block before them is not approaching a
    //    periodic response; it stops early only where it is moreover
    //    regular, its finite-time Lyapunov exponent in both blocks within
    //    ±REGULAR_FTLE (a quasi-periodic response on an invariant torus).
    //    A trajectory approaching an orbit, however slowly, comes closer
    //    every block (geometric convergence); a chaotic one (a positive
    //    exponent) may still fall onto an orbit after thousands of periods
    //    and marches on to the end of the budget.
    w.tr.take_closest();
    w.tr.take_range();
    // The amplitude range needs every period's exact extremes from here on.
    if cfg.ranges {
        w.exact_from = Some(w.dwell);
    }
    let mut closest = [f64::INFINITY; 3];
    let mut lyapunov = [None; 3];
    let mut method = "not-settled";
    loop {
        let left = cfg.max_periods.saturating_sub(w.dwell);
        if left == 0 {
            break;
        }
        // The exponent is judged over the two blocks before a decision.
        if cfg.early_stop
            && w.tangent.is_none()
            && w.dwell + 2 * EARLY_BLOCK >= EARLY_MIN
            && cfg.max_periods > EARLY_MIN
        {
            w.tangent = eng
                .engine
                .exact()
                .and_then(|sim| eng.shooting.get(sim))
                .map(|m| Tangent::new(m, eta, t, w.state.mode));
        }
        // Without ranges, the last block locates extremes only over the
        // final window whose amplitudes an unsettled point reports.
        let block = left.min(EARLY_BLOCK);
        let tail = if w.exact_from.is_none() && block == left {
            block.min(FINAL_WINDOW)
        } else {
            0
        };
        if block > tail {
            if let Some(r) = w.march_watched(block - tail, eta, t) {
                return Ok(r);
            }
        }
        if tail > 0 {
            w.exact_from = Some(w.dwell);
            if let Some(r) = w.march_watched(tail, eta, t) {
                return Ok(r);
            }
        }
        closest = [closest[1], closest[2], w.tr.take_closest()];
        lyapunov = [
            lyapunov[1],
            lyapunov[2],
            w.tangent.as_mut().and_then(Tangent::take),
        ];
        let regular = |l: Option<f64>| l.is_some_and(|l: f64| l.abs() <= REGULAR_FTLE);
        if cfg.early_stop
            && w.dwell >= EARLY_MIN
            && closest[1].min(closest[2]) >= closest[0]
            && regular(lyapunov[1])
            && regular(lyapunov[2])
            && w.dwell < cfg.max_periods
        {
            method = "not-settling";
            break;
        }
    }
    let n = w.tr.seen().clamp(1, FINAL_WINDOW);
    let Some(st) = w.window(n) else {
        return Err(SimError::Unsupported(
            "no forcing period was integrated (period budget 0)".into(),
        ));
    };
    let mut pt = point_from(eta, &st, 1, t, w.used, method);
    pt.steady = false;
    pt.period_multiple = None;
    pt.stick_fraction = (st.stick_time / (n as f64 * t)).clamp(0.0, 1.0);
    pt.range =
        w.tr.take_range()
            .filter(|_| cfg.ranges)
            .map(|r| AmplitudeRange {
                amplitude1_min: r[0],
                amplitude1_max: r[1],
                amplitude2_min: r[2],
                amplitude2_max: r[3],
            });
    Ok((pt, w.state))
}

/// Transient periods before the first attempt at the permanent-stick proof
/// (then after twice as many, and so on, to the end of the transient).
pub(super) const PROOF_FIRST: u64 = 2;

/// Periods whose merged statistics give an unsettled point's amplitudes.
pub(super) const FINAL_WINDOW: u64 = 50;

/// Periods per block of the marching fallback (stage 5 of
/// [`steady_state`]).
pub(super) const EARLY_BLOCK: u64 = 1000;
/// Periods of a trajectory before the early stop may judge it.
pub(super) const EARLY_MIN: u64 = 4000;
/// Largest |finite-time Lyapunov exponent| per forcing period, over a
/// block of [`EARLY_BLOCK`] periods, of a regular (quasi-periodic) motion
/// for the early stop. Measured over 1000-period blocks: within ±9e-4 on
/// the quasi-periodic response of the paper's absorber (m 4, k 1, D 0.003,
/// ρs 1.004, ρd 0.813, η 0.74; a bounded tangent oscillation c gives
/// |λ| ≤ c/1000), +0.07…+0.11 on the chaotic transient that settles after
/// 12 045 periods (m 2, k 0.5, D 0.01, ρs 0.8, ρd 0.48, η 0.62).
pub(super) const REGULAR_FTLE: f64 = 0.01;

/// Shooting attempts before marching to the end of the budget.
pub(super) const SHOOTING_ATTEMPTS: usize = 3;
/// Iterates of the p-th return map over which the trajectory must follow
/// the linearisation about a shooting fixed point before it is accepted.
pub(super) const VERIFY_ITERATES: usize = 3;

/// Forwards the engine's period callbacks to a [`Tracker`] with a running
/// period count, so that one tracker watches a trajectory integrated in
/// several pieces.
pub(super) struct Offset<'t, 'a, 's> {
    tr: &'t mut Tracker<'a, ()>,
    base: u64,
    /// Locate the extremes exactly (see [`Walk::exact_from`]).
    extremes: bool,
    /// The tangent carried along (the early stop's Lyapunov exponent).
    tangent: Option<&'t mut Tangent<'s>>,
    /// The march's switching events counted by kind.
    events: &'t mut EventCounts,
}

/// Switching events of a run counted by kind (stick, slip+, slip−,
/// reversal+, reversal−): shooting's check that a trajectory keeps its
/// orbit's event sequence.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(super) struct EventCounts([u64; 5]);

impl EventCounts {
    fn add(&mut self, kind: EventKind) {
        let i = match kind {
            EventKind::Stick => 0,
            EventKind::SlipPlus => 1,
            EventKind::SlipMinus => 2,
            EventKind::ReversePlus => 3,
            EventKind::ReverseMinus => 4,
            EventKind::Interrupt => return,
        };
        self.0[i] += 1;
    }
}

/// A tangent vector carried along the march by the variational equations
/// ([`Monodromy::carry`], behind a contact spring [`Monodromy::carry_ext`]
/// in the extended state, period by period), for the largest finite-time
/// Lyapunov exponent per block of the marching fallback: about zero on a
/// quasi-periodic response (an invariant torus), clearly positive on a
/// chaotic transient, negative while an orbit is approached.
pub(super) struct Tangent<'s> {
    mono: &'s Monodromy,
    eta: f64,
    period: f64,
    /// In the extended state `[ζ1, ζ1', ζ2, ζ2', ζs]` (ζs: a slider held
    /// behind a contact spring; 0 otherwise).
    v: [f64; 5],
    /// The current period's events and the mode it started in.
    events: Vec<Event>,
    mode: Mode,
    log_growth: f64,
    periods: u64,
    /// A period whose Jacobian the formula does not give (grazing).
    lost: bool,
}

impl<'s> Tangent<'s> {
    const START: [f64; 4] = [0.8, 0.4, 0.4, 0.2];

    /// The start vector in `mode`: a rigid stick has no velocity
    /// perturbation of M2; a slider held behind a contact spring gets a
    /// perturbation of its own.
    fn start(mono: &Monodromy, mode: Mode) -> [f64; 5] {
        let [a, b, c, d] = Self::START;
        match mode {
            Mode::Stick { .. } if mono.is_contact() => [a, b, c, d, 0.3],
            Mode::Stick { .. } => [a, b, c, 0.0, 0.0],
            Mode::Slip { .. } => [a, b, c, d, 0.0],
        }
    }

    fn new(mono: &'s Monodromy, eta: f64, period: f64, mode: Mode) -> Self {
        let v = Self::start(mono, mode);
        Self {
            mono,
            eta,
            period,
            v,
            events: Vec::with_capacity(16),
            mode,
            log_growth: 0.0,
            periods: 0,
            lost: false,
        }
    }

    /// End of period `n` of a run (1-based), in mode `mode`.
    fn period_end(&mut self, n: u64, mode: Mode) {
        let t0 = (n - 1) as f64 * self.period;
        let t1 = n as f64 * self.period;
        let grown = if self.mono.is_contact() {
            self.mono
                .carry_ext(self.mode, &self.events, t0, t1)
                .map(|m| -> [f64; 5] {
                    std::array::from_fn(|i| (0..5).map(|c| m[i][c] * self.v[c]).sum())
                })
        } else {
            self.mono
                .carry(self.mode, &self.events, t0, t1, self.eta)
                .map(|m| -> [f64; 5] {
                    std::array::from_fn(|i| {
                        if i < 4 {
                            (0..4).map(|c| m[i][c] * self.v[c]).sum()
                        } else {
                            0.0
                        }
                    })
                })
        };
        let norm = grown.map_or(f64::NAN, |w| w.iter().map(|q| q * q).sum::<f64>().sqrt());
        match grown {
            Some(w) if norm.is_finite() && norm > 0.0 => {
                self.log_growth += norm.ln();
                self.v = w.map(|q| q / norm);
            }
            _ => {
                self.lost = true;
                self.v = Self::start(self.mono, mode);
            }
        }
        self.periods += 1;
        self.events.clear();
        self.mode = mode;
    }

    /// The exponent (per forcing period) since the last call; `None` if a
    /// period's Jacobian was lost or no period passed.
    fn take(&mut self) -> Option<f64> {
        let r = (!self.lost && self.periods > 0).then(|| self.log_growth / self.periods as f64);
        self.log_growth = 0.0;
        self.periods = 0;
        self.lost = false;
        r
    }
}

/// Records the statistics of each period of a re-run window.
pub(super) struct Periods {
    stats: [PeriodStats; RING],
    n: usize,
}

impl Observer for Periods {
    fn wants_extremes(&self) -> bool {
        true
    }
    fn period(&mut self, _n: u64, _x: &[f64; 4], _m: Mode, s: &PeriodStats) -> Flow {
        if self.n < RING {
            self.stats[self.n] = *s;
            self.n += 1;
        }
        Flow::Continue
    }
}

impl Observer for Offset<'_, '_, '_> {
    fn wants_extremes(&self) -> bool {
        self.extremes
    }
    fn event(&mut self, ev: &Event) {
        self.events.add(ev.kind);
        if let Some(t) = self.tangent.as_deref_mut() {
            t.events.push(*ev);
        }
    }
    fn period(&mut self, n: u64, x: &[f64; 4], mode: Mode, stats: &PeriodStats) -> Flow {
        if let Some(t) = self.tangent.as_deref_mut() {
            t.period_end(n, mode);
        }
        self.tr.period(self.base + n, x, mode, stats)
    }
}

/// The physical trajectory at one η: its state after `dwell` whole forcing
/// periods from the start state, watched on the section by `tr`; `used`
/// counts every integrated period (shooting's trial periods too).
pub(super) struct Walk<'s, 'a> {
    sim: &'s Engine,
    /// Shooting's variational set-up for the model.
    shooting: &'s MonodromyCache,
    tr: Tracker<'a, ()>,
    /// The state the walk started from (dwell 0).
    start: Init,
    state: Init,
    dwell: u64,
    used: u64,
    /// The dwell from which the march locates every period's extremes
    /// (`None`: not yet). The transient and shooting stages march without
    /// them (a third of a stick-slip period's cost); a settled point's
    /// statistics come from re-running its last periods from their
    /// recorded section state ([`Walk::window`]), which repeats the same
    /// trajectory bit for bit.
    exact_from: Option<u64>,
    /// The tangent of the early stop's Lyapunov exponent, carried while
    /// it is `Some`.
    tangent: Option<Tangent<'s>>,
}

/// What a shooting attempt concluded.
pub(super) enum Shot {
    /// The trajectory approaches the orbit found: the point and the state
    /// to continue from.
    Accepted((Point, Init)),
    /// No orbit, or one the trajectory is not seen to approach.
    Rejected,
    /// The marching detector settled during the check (period p).
    Settled(u32),
    /// Interrupted or chattering during the check.
    Failed(Point),
}

impl Walk<'_, '_> {
    /// Marches `n` more periods (stops early when the section repeats).
    fn march(&mut self, n: u64) -> crate::sim::engine::RunEnd {
        self.march_counted(n).0
    }

    /// [`Walk::march`], with the march's switching events counted by kind.
    fn march_counted(&mut self, n: u64) -> (crate::sim::engine::RunEnd, EventCounts) {
        let mut events = EventCounts::default();
        let mut off = Offset {
            tr: &mut self.tr,
            base: self.dwell,
            extremes: self.exact_from.is_some(),
            tangent: self.tangent.as_mut(),
            events: &mut events,
        };
        let end = self.sim.run_periods(self.state, n, &mut off);
        self.dwell += end.periods;
        self.used += end.periods;
        self.state = Init {
            x: end.x,
            mode: end.mode,
        };
        (end, events)
    }

    /// Marches `n` more periods and returns the point where that ends the
    /// search: an interruption or chatter (continue from rest), or a
    /// section that repeats (the settled point). `None`: march on.
    #[inline(always)]
    fn march_watched(&mut self, n: u64, eta: f64, t: f64) -> Option<(Point, Init)> {
        let end = self.march(n);
        if let Some(p) = failed(&end.status, eta, self.used) {
            return Some((p, Init::rest()));
        }
        let p = self.tr.steady?;
        Some(self.settled(eta, p, t))
    }

    /// The point of a trajectory the detector found period-`p`, and the
    /// state to continue from: the trajectory marched on to the next whole
    /// multiple of p periods of its dwell (see [`curve`]).
    fn settled(&mut self, eta: f64, p: u32, t: f64) -> (Point, Init) {
        let st = self
            .window(p as u64)
            .expect("the detector has seen at least 2p periods");
        let extra = (p as u64 - self.dwell % p as u64) % p as u64;
        if extra > 0 {
            let end = self.sim.run_periods(self.state, extra, &mut ());
            self.used += end.periods;
            self.dwell += end.periods;
            self.state = Init {
                x: end.x,
                mode: end.mode,
            };
        }
        (
            point_from(eta, &st, p, t, self.used, "marching"),
            self.state,
        )
    }

    /// Merged statistics with exact extremes over the last `w` periods
    /// marched (w ≤ periods seen, ≤ 64): the tracker's own where those
    /// periods were marched with extremes, else those of a re-run of the
    /// window from its recorded section state (the engine's trajectory
    /// does not depend on whether extremes are located, and a run started
    /// at a period boundary repeats the continuing one bit for bit: unit
    /// test `lazy_extremes_are_bit_identical`).
    fn window(&mut self, w: u64) -> Option<PeriodStats> {
        let n = self.tr.seen();
        let w = w.min(n).min(RING as u64);
        if w == 0 {
            return None;
        }
        if self.exact_from.is_some_and(|d| n - w >= d) {
            return self.tr.window(w);
        }
        let from = if w == n {
            self.start
        } else {
            self.tr.section_mode(w)?
        };
        let mut rec = Periods {
            stats: [PeriodStats::new_at(&from.x); RING],
            n: 0,
        };
        let end = self.sim.run_periods(from, w, &mut rec);
        self.used += end.periods;
        // The exact engine repeats the trajectory bit for bit; the
        // numerical one restarts its step size, so to its tolerance.
        debug_assert!(self.sim.exact().is_none() || Some(end.x) == self.tr.section(0).map(|s| s.0));
        merge_back(rec.stats[..rec.n].iter().rev())
    }

    /// Picks the period multiple the section iterates suggest (the
    /// smallest p whose return distance is within 4× the best), shoots on
    /// P^p from the current state and accepts the orbit only if the next
    /// iterates of the trajectory follow its linearisation.
    fn try_shooting(&mut self, eta: f64, t: f64, cfg: &SteadyConfig) -> Shot {
        let Some((x_now, s_now)) = self.tr.section(0) else {
            return Shot::Rejected;
        };
        let mut d = [f64::INFINITY; MAX_PERIOD_MULTIPLE + 1];
        for (p, dp) in d.iter_mut().enumerate().skip(1) {
            if let Some((y, sy)) = self.tr.section(p as u64) {
                if sy == s_now {
                    *dp = dist(&x_now, &y, 4);
                }
            }
        }
        let best = d.iter().copied().fold(f64::INFINITY, f64::min);
        let Some(p) = (1..=MAX_PERIOD_MULTIPLE).find(|&p| d[p] <= 4.0 * best) else {
            // Fewer than two section points, or contact modes that never repeat.
            return Shot::Rejected;
        };
        let mut used = 0;
        // (Shooting needs the exact engine.)
        let Some(sim) = self.sim.exact() else {
            return Shot::Rejected;
        };
        let contact = sim.model().contact_stiffness.is_some();
        let shot = shoot(
            sim,
            self.shooting,
            self.state.x,
            self.state.mode,
            p as u64,
            cfg.tol,
            &mut used,
        );
        self.used += used;
        let Some(sh) = shot else {
            return Shot::Rejected;
        };
        let dim = sh.dim;
        let lim = |x: &[f64; 5]| cfg.tol * (1.0 + x.iter().fold(0.0f64, |a, v| a.max(v.abs())));
        // The check: e_{k+1} = J·e_k + O(|e_k|²) for the deviations of the
        // trajectory's own p-th iterates from the fixed point (in the
        // coordinates shooting varied), the remainder within a tenth of
        // |e_k|, and every iterate with the orbit's switching events (J is
        // the derivative of the map with the orbit's event sequence: an
        // iterate with a stick phase more or less is not described by it).
        // Without the event check a trajectory that wanders around a weakly
        // stable orbit could follow J for three iterates and never arrive;
        // the orbit was then reported beside the response the trajectory
        // keeps to (docs/real-pads.md, sessions 34 and 38). The orbit is
        // run first: its statistics over p periods from the fixed point,
        // its section states and its switching events.
        let mut orbit = Orbit {
            stats: None,
            sections: Vec::with_capacity(p),
            events: EventCounts::default(),
        };
        let start = sh.init();
        let end = self.sim.run_periods(start, p as u64, &mut orbit);
        self.used += end.periods;
        let (Some(st), true) = (orbit.stats, matches!(end.status, Status::Completed)) else {
            return Shot::Rejected;
        };
        let mut e = diff(&ext(&self.state, contact), &sh.x, dim);
        let mut ok = norm(&e, dim) <= lim(&sh.x);
        for _ in 0..VERIFY_ITERATES {
            if ok {
                break;
            }
            let (end, events) = self.march_counted(p as u64);
            if let Some(pt) = failed(&end.status, eta, self.used) {
                return Shot::Failed(pt);
            }
            if let Some(q) = self.tr.steady {
                return Shot::Settled(q);
            }
            if end.periods < p as u64 {
                return Shot::Rejected;
            }
            if matches!(self.state.mode, Mode::Stick { .. }) != sh.stuck {
                return Shot::Rejected;
            }
            // The linearisation J holds for the orbit's sequence of
            // switching events only: an iterate with other events (a stick
            // phase more or less, a reversal instead of a stick) is not
            // described by it, however close its deviation came to J·e.
            if events != orbit.events {
                return Shot::Rejected;
            }
            let e1 = diff(&ext(&self.state, contact), &sh.x, dim);
            let mut miss = [0.0; 5];
            for i in 0..dim {
                let pred: f64 = (0..dim).map(|j| sh.jac[i][j] * e[j]).sum();
                miss[i] = e1[i] - pred;
            }
            if norm(&miss, dim) > 0.1 * norm(&e, dim) + 10.0 * lim(&sh.x) {
                return Shot::Rejected;
            }
            ok = norm(&e1, dim) <= lim(&sh.x);
            e = e1;
        }
        // Accepted: the orbit's minimal period q and the continuation
        // state. A divisor q of p is the minimal period when the orbit
        // returns within 1e-6 (relative) after q periods: Newton's residual
        // bounds the fixed point's error only through (I − J)⁻¹, and orbits
        // that differ by less are not told apart anywhere in the tool.
        let l = 1e-6 * (1.0 + sh.x.iter().fold(0.0f64, |a, v| a.max(v.abs())));
        let q = (1..=p)
            .filter(|q| p % q == 0)
            .find(|&q| {
                let (y, m) = orbit.sections[q - 1];
                matches!(m, Mode::Stick { .. }) == sh.stuck
                    && dist(&ext(&Init { x: y, mode: m }, contact), &sh.x, 5) <= l
            })
            .unwrap_or(p);
        // The fixed point is the orbit's state at dwell ≡ dwell (mod q);
        // continue from its state at the next whole multiple of q.
        let j = ((q as u64 - self.dwell % q as u64) % q as u64) as usize;
        let next = if j == 0 {
            start
        } else {
            let (x, mode) = orbit.sections[j - 1];
            Init { x, mode }
        };
        let mut pt = point_from(eta, &st, p as u32, t, self.used, "shooting");
        pt.period_multiple = Some(q as u32);
        Shot::Accepted((pt, next))
    }
}

/// Merged statistics and section states of a run (an orbit).
pub(super) struct Orbit {
    stats: Option<PeriodStats>,
    sections: Vec<([f64; 4], Mode)>,
    events: EventCounts,
}

impl Observer for Orbit {
    fn wants_extremes(&self) -> bool {
        true
    }
    fn event(&mut self, ev: &Event) {
        self.events.add(ev.kind);
    }
    fn period(&mut self, _n: u64, x: &[f64; 4], m: Mode, s: &PeriodStats) -> Flow {
        self.stats = Some(match self.stats {
            None => *s,
            Some(a) => PeriodStats {
                min: [a.min[0].min(s.min[0]), a.min[1].min(s.min[1])],
                max: [a.max[0].max(s.max[0]), a.max[1].max(s.max[1])],
                stick_time: a.stick_time + s.stick_time,
            },
        });
        self.sections.push((*x, m));
        Flow::Continue
    }
}

pub(super) fn diff<const N: usize>(a: &[f64; N], b: &[f64; N], dim: usize) -> [f64; N] {
    let mut d = [0.0; N];
    for i in 0..dim {
        d[i] = a[i] - b[i];
    }
    d
}

pub(super) fn norm<const N: usize>(a: &[f64; N], dim: usize) -> f64 {
    a[..dim].iter().fold(0.0f64, |m, v| m.max(v.abs()))
}

pub(super) fn dist<const N: usize>(a: &[f64; N], b: &[f64; N], dim: usize) -> f64 {
    norm(&diff(a, b, dim), dim)
}
