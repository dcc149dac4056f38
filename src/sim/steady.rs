//! Amplitudes (paper eq. 6), steady state and period-n detection on the
//! Poincaré section at the forcing period, and the `simulate` job built on
//! the engine.
//!
//! The Poincaré map P samples the state at τ = nT. For each p ≤ 8 the
//! distance d(n) = ‖P(n) − P(n−p)‖∞ is watched; for a linearly converging
//! orbit with contraction r = d(n)/d(n−p) < 1 the distance to the periodic
//! orbit is about d(n)·r/(1 − r) (not d(n): slowly contracting, lightly
//! damped orbits would be declared steady far too early). A response is
//! period-p when that estimate, and d(n), stay ≤ tol·(1 + ‖x‖∞) for 2p
//! consecutive periods (two whole orbits) with the same contact mode; the
//! smallest such p is reported. Amplitudes are then (max ζi − min ζi)/2 over the last p
//! periods, with the extremes located exactly (roots of ζ1', events for ζ2).

use super::engine::{Event, Flow, Init, Mode, Observer, PeriodStats, Sim, Status};
use super::linear;

/// Largest period multiple detected.
pub const MAX_PERIOD_MULTIPLE: usize = 8;
pub(crate) const RING: usize = 64;

/// What to simulate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SimOptions {
    /// Integrate exactly this many periods (`None`: until steady).
    pub periods: Option<u64>,
    /// Longest run when integrating until steady.
    pub max_periods: u64,
    /// Periods over which a non-periodic response's amplitude is taken.
    pub window: u64,
    /// Relative tolerance of the Poincaré-map periodicity test.
    pub tol: f64,
    /// Initial condition.
    pub init: Init,
    /// Use the closed form where it is exact (ρs = 0, ρs = ∞) for steady runs.
    pub shortcuts: bool,
}

impl Default for SimOptions {
    fn default() -> Self {
        Self {
            periods: None,
            max_periods: 20_000,
            window: 10,
            tol: 1e-9,
            init: Init::rest(),
            shortcuts: true,
        }
    }
}

/// The result of a `simulate` job (the interface's JSON keys).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Summary {
    /// η.
    pub eta: f64,
    /// Final time.
    pub tau_end: f64,
    /// Final state.
    pub final_state: [f64; 4],
    /// Number of switching events.
    pub events: u64,
    /// A1/A by eq. 6 (None if interrupted).
    pub amplitude1: Option<f64>,
    /// A2/A by eq. 6 (None if interrupted).
    pub amplitude2: Option<f64>,
    /// Whether the response is periodic on the Poincaré section.
    pub steady: bool,
    /// n of a period-n response.
    pub period_multiple: Option<u32>,
    /// Fraction of the simulated time M2 sticks (over the amplitude window).
    pub stick_fraction: f64,
    /// The interruption rule fired.
    pub interrupted: bool,
    /// How the run ended (`steady`, `completed`, `interrupted`, `chatter`,
    /// `not-settled`, `closed-form`).
    pub status: &'static str,
    /// Why the run ended early, if it did.
    pub reason: Option<String>,
    /// Forcing periods integrated.
    pub periods: u64,
}

/// Tracks the Poincaré section and per-period statistics; forwards events
/// and samples to an inner observer.
pub struct Tracker<'a, O: Observer> {
    inner: &'a mut O,
    tol: f64,
    stop_when_steady: bool,
    n: u64,
    points: [([f64; 4], bool); RING],
    modes: [Mode; RING],
    stats: [PeriodStats; RING],
    streak: [u64; MAX_PERIOD_MULTIPLE + 1],
    dist: [[f64; MAX_PERIOD_MULTIPLE]; MAX_PERIOD_MULTIPLE + 1],
    /// Smallest section distance d_p/scale (over p = 1..=MAX) since the
    /// last [`Tracker::take_closest`].
    closest: f64,
    /// Range of the per-period half-amplitudes [min A1, max A1, min A2,
    /// max A2] since the last [`Tracker::take_range`].
    range: [f64; 4],
    /// Detected period multiple.
    pub steady: Option<u32>,
}

const EMPTY_RANGE: [f64; 4] = [
    f64::INFINITY,
    f64::NEG_INFINITY,
    f64::INFINITY,
    f64::NEG_INFINITY,
];

impl<'a, O: Observer> Tracker<'a, O> {
    /// A tracker forwarding to `inner`.
    pub fn new(inner: &'a mut O, tol: f64, stop_when_steady: bool) -> Self {
        let empty = PeriodStats {
            min: [0.0; 2],
            max: [0.0; 2],
            stick_time: 0.0,
        };
        Self {
            inner,
            tol,
            stop_when_steady,
            n: 0,
            points: [([0.0; 4], false); RING],
            modes: [Mode::Slip { dir: 1.0 }; RING],
            stats: [empty; RING],
            streak: [0; MAX_PERIOD_MULTIPLE + 1],
            dist: [[f64::INFINITY; MAX_PERIOD_MULTIPLE]; MAX_PERIOD_MULTIPLE + 1],
            closest: f64::INFINITY,
            range: EMPTY_RANGE,
            steady: None,
        }
    }

    /// The smallest relative section distance between an iterate and the
    /// one p periods before (p = 1..=MAX, same contact mode) seen since the
    /// last call, and restarts it: how close the trajectory came to closing
    /// an orbit.
    pub fn take_closest(&mut self) -> f64 {
        std::mem::replace(&mut self.closest, f64::INFINITY)
    }

    /// The range of the per-period half-amplitudes `[min A1, max A1, min
    /// A2, max A2]` seen since the last call (`None`: no period), and
    /// restarts it.
    pub fn take_range(&mut self) -> Option<[f64; 4]> {
        let r = std::mem::replace(&mut self.range, EMPTY_RANGE);
        r[0].is_finite().then_some(r)
    }

    /// Merged statistics over the last `w` periods (w ≤ periods seen, ≤ 64).
    pub fn window(&self, w: u64) -> Option<PeriodStats> {
        let w = w.min(self.n).min(RING as u64);
        if w == 0 {
            return None;
        }
        merge_back((0..w).map(|j| &self.stats[((self.n - 1 - j) % RING as u64) as usize]))
    }
}

/// Merges per-period statistics given from the last period backwards (the
/// order fixes the rounding of the summed stick time).
pub(crate) fn merge_back<'s>(
    mut periods: impl Iterator<Item = &'s PeriodStats>,
) -> Option<PeriodStats> {
    let mut acc = *periods.next()?;
    for s in periods {
        for i in 0..2 {
            acc.min[i] = acc.min[i].min(s.min[i]);
            acc.max[i] = acc.max[i].max(s.max[i]);
        }
        acc.stick_time += s.stick_time;
    }
    Some(acc)
}

impl<O: Observer> Tracker<'_, O> {
    /// Section periods seen so far.
    pub fn seen(&self) -> u64 {
        self.n
    }

    /// The section state `back` periods before the last one with its
    /// contact mode, as a state to restart from; `None` beyond the ring
    /// (64) or before the start.
    pub fn section_mode(&self, back: u64) -> Option<Init> {
        (back < self.n && back < RING as u64).then(|| {
            let i = ((self.n - 1 - back) % RING as u64) as usize;
            Init {
                x: self.points[i].0,
                mode: self.modes[i],
            }
        })
    }

    /// The section state `back` periods before the last one (0: the last)
    /// and whether M2 was stuck there; `None` beyond the ring (64) or
    /// before the start.
    pub fn section(&self, back: u64) -> Option<([f64; 4], bool)> {
        (back < self.n && back < RING as u64)
            .then(|| self.points[((self.n - 1 - back) % RING as u64) as usize])
    }

    /// The smallest divisor q of a converged period p whose shift maps the
    /// last p section points onto the q before each within `lim` (all of
    /// them inside the converged streak of 2p periods; oscillating
    /// convergence can make a period-1 orbit pass the test at p = 2 first).
    fn minimal_period(&self, p: usize, n: u64, lim: f64) -> u32 {
        for q in 1..p {
            if !p.is_multiple_of(q) {
                continue;
            }
            let ok = (0..p as u64).all(|j| {
                let (a, sa) = self.points[((n - 1 - j) % RING as u64) as usize];
                let (b, sb) = self.points[((n - 1 - j - q as u64) % RING as u64) as usize];
                sa == sb && a.iter().zip(&b).all(|(u, v)| (u - v).abs() <= lim)
            });
            if ok {
                return q as u32;
            }
        }
        p as u32
    }
}

impl<O: Observer> Observer for Tracker<'_, O> {
    fn event(&mut self, ev: &Event) {
        self.inner.event(ev);
    }
    fn next_sample(&mut self) -> Option<f64> {
        self.inner.next_sample()
    }
    fn sample(&mut self, tau: f64, x: &[f64; 4], dx: &[f64; 4]) {
        self.inner.sample(tau, x, dx);
    }
    fn wants_extremes(&self) -> bool {
        true
    }
    fn period(&mut self, n: u64, x: &[f64; 4], mode: Mode, stats: &PeriodStats) -> Flow {
        let idx = ((n - 1) % RING as u64) as usize;
        let stuck = matches!(mode, Mode::Stick { .. });
        let (a1, a2) = (
            0.5 * (stats.max[0] - stats.min[0]),
            0.5 * (stats.max[1] - stats.min[1]),
        );
        let r = &mut self.range;
        (r[0], r[1], r[2], r[3]) = (r[0].min(a1), r[1].max(a1), r[2].min(a2), r[3].max(a2));
        self.points[idx] = (*x, stuck);
        self.modes[idx] = mode;
        self.stats[idx] = *stats;
        self.n = n;
        let scale = 1.0 + x.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        self.steady = None;
        for p in 1..=MAX_PERIOD_MULTIPLE {
            if n <= p as u64 {
                self.streak[p] = 0;
                continue;
            }
            let back = ((n - 1 - p as u64) % RING as u64) as usize;
            let (y, ystuck) = self.points[back];
            let d = if ystuck == stuck {
                let d = x
                    .iter()
                    .zip(&y)
                    .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
                // The stick position too: behind a contact spring it is the
                // slider's, a fifth coordinate (for a rigid stick it is ζ2,
                // already compared).
                match (mode, self.modes[back]) {
                    (Mode::Stick { z2: a }, Mode::Stick { z2: b }) => d.max((a - b).abs()),
                    _ => d,
                }
            } else {
                f64::INFINITY
            };
            self.closest = self.closest.min(d / scale);
            // d(n − p), kept in a ring of p slots.
            let slot = (n % p as u64) as usize;
            let prev = self.dist[p][slot];
            self.dist[p][slot] = d;
            let lim = self.tol * scale;
            let close = if d <= 1e-3 * lim {
                true // converged in finite time (stick phases reset the state)
            } else {
                let r = d / prev;
                d <= lim && r < 1.0 && d * r / (1.0 - r) <= lim
            };
            self.streak[p] = if close { self.streak[p] + 1 } else { 0 };
            if self.steady.is_none() && self.streak[p] >= 2 * p as u64 {
                // Every iterate is within `lim` of its orbit point, so those
                // of a period-q orbit are within 2·lim of each other q
                // periods apart; 4·lim leaves room for the estimate.
                self.steady = Some(self.minimal_period(p, n, 4.0 * lim));
            }
        }
        let inner = self.inner.period(n, x, mode, stats);
        if inner == Flow::Stop || (self.stop_when_steady && self.steady.is_some()) {
            Flow::Stop
        } else {
            Flow::Continue
        }
    }
}

/// Runs a `simulate` job: `opts.periods` periods, or until steady.
///
/// ```
/// use stickslip::model::{Absorber, Law, Model};
/// use stickslip::sim::{simulate, Sim, SimOptions};
/// // The paper's absorber (m = 4, k = 1, D = 0.005), Coulomb ρ = 0.5, η = 1.
/// let model = Model { absorber: Absorber::default(), law: Law::coulomb(0.5), stop_below: None, contact_stiffness: None };
/// let sim = Sim::new(&model, 1.0)?;
/// let s = simulate(&sim, &SimOptions::default(), &mut ());
/// assert!(s.steady);
/// assert!(s.amplitude1.unwrap() > 0.0 && s.stick_fraction > 0.0);
/// # Ok::<(), stickslip::sim::SimError>(())
/// ```
pub fn simulate<O: Observer>(sim: &Sim, opts: &SimOptions, obs: &mut O) -> Summary {
    let model = sim.model();
    let eta = sim.eta();
    if opts.periods.is_none() && opts.shortcuts && opts.init == Init::rest() {
        // The linear limits are exact in closed form: skip the integration.
        let closed = if model.law.is_frictionless() {
            let (a1, a2) = linear::free_amplitudes(&model.absorber, model.law.slope(), eta);
            Some((
                a1,
                a2,
                linear::free_state(&model.absorber, model.law.slope(), eta),
                0.0,
            ))
        } else if model.law.is_always_stuck() {
            Some(match model.contact_stiffness {
                None => {
                    let (a1, a2) = linear::stuck_amplitudes(&model.absorber, eta);
                    (a1, a2, linear::stuck_state(&model.absorber, eta, 0.0), 1.0)
                }
                // The slider never slides: M2 on its contact spring.
                Some(kappa) => {
                    let (a1, a2) = linear::held_amplitudes(&model.absorber, kappa, eta);
                    (
                        a1,
                        a2,
                        linear::held_state(&model.absorber, kappa, eta, 0.0),
                        1.0,
                    )
                }
            })
        } else {
            None
        };
        if let Some((a1, a2, x, sf)) = closed {
            if !linear::bounded(a1.max(a2)) {
                return Summary {
                    eta,
                    tau_end: 0.0,
                    final_state: [f64::NAN; 4],
                    events: 0,
                    amplitude1: None,
                    amplitude2: None,
                    steady: false,
                    period_multiple: None,
                    stick_fraction: sf,
                    interrupted: false,
                    status: "resonance",
                    reason: Some("undamped forcing at an eigenfrequency: no steady state (the response grows secularly)".into()),
                    periods: 0,
                };
            }
            return Summary {
                eta,
                tau_end: 0.0,
                final_state: x,
                events: 0,
                amplitude1: Some(a1),
                amplitude2: Some(a2),
                steady: true,
                period_multiple: Some(1),
                stick_fraction: sf,
                interrupted: false,
                status: "closed-form",
                reason: None,
                periods: 0,
            };
        }
    }
    simulate_with(
        opts,
        eta,
        |init, n, o| sim.run(init, n, o),
        sim.period(),
        obs,
    )
}

/// The `simulate` job over any integrator with the engine's observer
/// protocol (`run(init, periods, observer)`), e.g. the paper's RK4.
pub fn simulate_with<O, R>(opts: &SimOptions, eta: f64, run: R, period: f64, obs: &mut O) -> Summary
where
    O: Observer,
    R: FnOnce(Init, u64, &mut Tracker<'_, O>) -> super::engine::RunEnd,
{
    let periods = opts.periods.unwrap_or(opts.max_periods);
    let mut tr = Tracker::new(obs, opts.tol, opts.periods.is_none());
    let end = run(opts.init, periods, &mut tr);
    let steady = tr.steady;
    let w = match steady {
        Some(p) => p as u64,
        None if opts.periods.is_none() => opts.window.max(50),
        None => opts.window,
    };
    let stats = tr.window(w);
    let (status, reason, interrupted) = match &end.status {
        Status::Interrupted(r) => ("interrupted", Some(r.clone()), true),
        Status::Chatter(r) => ("chatter", Some(r.clone()), false),
        Status::Stopped => ("steady", None, false),
        Status::Completed if steady.is_some() => ("steady", None, false),
        Status::Completed if opts.periods.is_none() => (
            "not-settled",
            Some(format!(
                "no period-n response (n <= 8) within {periods} periods"
            )),
            false,
        ),
        Status::Completed => ("completed", None, false),
    };
    let ok = !interrupted && !matches!(end.status, Status::Chatter(_));
    let amp = |i: usize| stats.filter(|_| ok).map(|s| 0.5 * (s.max[i] - s.min[i]));
    let stick_fraction = match stats {
        Some(s) if ok => s.stick_time / (w.min(end.periods) as f64 * period),
        _ if end.tau > 0.0 => end.stick_time / end.tau,
        _ => 0.0,
    };
    Summary {
        eta,
        tau_end: end.tau,
        final_state: end.x,
        events: end.events,
        amplitude1: amp(0),
        amplitude2: amp(1),
        steady: steady.is_some() && ok,
        period_multiple: steady.filter(|_| ok),
        stick_fraction,
        interrupted,
        status,
        reason,
        periods: end.periods,
    }
}
