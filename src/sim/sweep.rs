//! Steady states and frequency-response curves (paper §3, Figs. 3–5).
//!
//! One steady state, cheapest sure method first:
//! 1. the linear limits in closed form (ρs = 0: 2-DOF; ρs = ∞: 1-DOF);
//! 2. a short transient by the exact engine, watched on the Poincaré
//!    section (stick phases often reach the periodic orbit in finite time);
//! 3. a **proven permanent stick**: M2 sticks at the section and the
//!    1-DOF motion can never load the pad up to ρs — the contact force is
//!    bounded by its steady part plus a bound on the decaying free part from
//!    its (non-increasing) energy — so the answer is the 1-DOF closed form;
//! 4. **Newton shooting** on the Poincaré map at the forcing period, with a
//!    finite-difference monodromy matrix (in the stuck or slipping
//!    coordinates of the section state); accepted only if it converges, the
//!    contact mode repeats and the orbit is stable (spectral radius < 1);
//! 5. otherwise time-marching until the section repeats (period-n, n ≤ 8)
//!    or the period budget runs out (`steady: false`).
//!
//! A curve continues each η from the previous η's steady state (like a slow
//! rig sweep, up or down in η) or starts every η from rest. An interrupted
//! point (the paper's rule) has no amplitude; the next η starts from rest.
//! Curves are independent, so families run in parallel (rayon) with results
//! identical for any thread count.

use faer::linalg::solvers::Solve;

use super::engine::{net_force, Flow, Init, Mode, Observer, PeriodStats, Sim, Status};
use super::linear;
use super::steady::Tracker;
use super::SimError;
use crate::model::Model;

/// How each η of a curve starts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Direction {
    /// Continuation with increasing η.
    Up,
    /// Continuation with decreasing η.
    Down,
    /// Every η from rest.
    Rest,
}

impl Direction {
    /// Name in tables and JSON.
    pub fn as_str(self) -> &'static str {
        match self {
            Direction::Up => "up",
            Direction::Down => "down",
            Direction::Rest => "rest",
        }
    }
}

/// Settings of the steady-state solver.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SteadyConfig {
    /// Transient periods marched before shooting.
    pub transient: u64,
    /// Period budget of the time-marching fallback.
    pub max_periods: u64,
    /// Relative tolerance on the Poincaré section.
    pub tol: f64,
    /// Use Newton shooting.
    pub shooting: bool,
}

impl Default for SteadyConfig {
    fn default() -> Self {
        Self {
            transient: 16,
            max_periods: 20_000,
            tol: 1e-9,
            shooting: true,
        }
    }
}

/// One point of a frequency-response curve.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Point {
    /// η.
    pub eta: f64,
    /// A1/A (None if interrupted or chattering).
    pub amplitude1: Option<f64>,
    /// A2/A.
    pub amplitude2: Option<f64>,
    /// Periodic response found.
    pub steady: bool,
    /// n of a period-n response.
    pub period_multiple: Option<u32>,
    /// Fraction of the (last) orbit M2 sticks.
    pub stick_fraction: f64,
    /// The interruption rule fired.
    pub interrupted: bool,
    /// Forcing periods integrated (including shooting's trial periods).
    pub periods: u64,
    /// Which method settled it (`closed-form`, `marching`, `stick-proof`,
    /// `shooting`, `not-settled`, `interrupted`, `chatter`).
    pub method: &'static str,
}

/// Counts periods and keeps the last period's statistics.
struct Last {
    stats: Option<PeriodStats>,
}

impl Observer for Last {
    fn period(&mut self, _n: u64, _x: &[f64; 4], _m: Mode, s: &PeriodStats) -> Flow {
        self.stats = Some(*s);
        Flow::Continue
    }
}

fn point_from(
    eta: f64,
    st: &PeriodStats,
    p: u32,
    t: f64,
    periods: u64,
    method: &'static str,
) -> Point {
    Point {
        eta,
        amplitude1: Some(0.5 * (st.max[0] - st.min[0])),
        amplitude2: Some(0.5 * (st.max[1] - st.min[1])),
        steady: true,
        period_multiple: Some(p),
        stick_fraction: (st.stick_time / (p as f64 * t)).clamp(0.0, 1.0),
        interrupted: false,
        periods,
        method,
    }
}

/// The contact mode of a section state (stuck iff ζ2' = 0 and |F| < ρs).
pub fn mode_of(model: &Model, x: &[f64; 4]) -> Mode {
    if x[3] == 0.0 && net_force(model, x).abs() < model.law.rho_s() {
        Mode::Stick { z2: x[2] }
    } else if x[3] == 0.0 {
        Mode::Slip {
            dir: net_force(model, x).signum(),
        }
    } else {
        Mode::Slip { dir: x[3].signum() }
    }
}

/// Proves that M2, stuck at ζ2* with the 1-DOF state (ζ1, ζ1'), never
/// breaks away: the stuck motion is the steady 1-DOF response plus a free
/// part whose energy E = ½mζ1h'² + ½(1+k)ζ1h² never grows (D ≥ 0), so
/// |F| ≤ max|F_ss| + √(2E/(1+k)) + D·√(2E/m) < ρs for all later times.
fn permanently_stuck(model: &Model, eta: f64, x: &[f64; 4], z2: f64) -> bool {
    let ab = &model.absorber;
    let xs = linear::stuck_response(ab, eta);
    let c = z2 / (1.0 + ab.k);
    // F_ss = ζ1ss − z2 + Dζ1ss' = Re(X(1 + iηD) e^{iητ}) + c − z2.
    let f_amp = (xs * num_complex::Complex::new(1.0, eta * ab.damping)).norm();
    let f_max = f_amp + (c - z2).abs();
    // Free part at τ = 0 mod T (the section).
    let ss = linear::stuck_state(ab, eta, z2);
    let (h, dh) = (x[0] - ss[0], x[1] - ss[1]);
    let e = 0.5 * ab.m * dh * dh + 0.5 * (1.0 + ab.k) * h * h;
    let bound = (2.0 * e / (1.0 + ab.k)).sqrt() + ab.damping * (2.0 * e / ab.m).sqrt();
    f_max + bound < model.law.rho_s() * (1.0 - 1e-12)
}

/// The steady state at η from `init`; returns the point and the state on the
/// section to continue from.
pub fn steady_state(
    model: &Model,
    eta: f64,
    init: Init,
    cfg: &SteadyConfig,
) -> Result<(Point, Init), SimError> {
    let ab = &model.absorber;
    let t = 2.0 * std::f64::consts::PI / eta;
    // 1. Closed forms.
    if model.law.is_frictionless() {
        let (a1, a2) = linear::free_amplitudes(ab, model.law.slope(), eta);
        if !linear::bounded(a1.max(a2)) {
            return Ok((resonant(eta), Init::rest()));
        }
        let x = linear::free_state(ab, model.law.slope(), eta);
        let p = Point {
            eta,
            amplitude1: Some(a1),
            amplitude2: Some(a2),
            steady: true,
            period_multiple: Some(1),
            stick_fraction: 0.0,
            interrupted: false,
            periods: 0,
            method: "closed-form",
        };
        return Ok((
            p,
            Init {
                x,
                mode: Mode::Slip { dir: 1.0 },
            },
        ));
    }
    if model.law.is_always_stuck() {
        let z2 = if init.x[2].is_finite() {
            init.x[2]
        } else {
            0.0
        };
        let (a1, _) = linear::stuck_amplitudes(ab, eta);
        if !linear::bounded(a1) {
            return Ok((resonant(eta), Init::rest()));
        }
        let p = Point {
            eta,
            amplitude1: Some(a1),
            amplitude2: Some(0.0),
            steady: true,
            period_multiple: Some(1),
            stick_fraction: 1.0,
            interrupted: false,
            periods: 0,
            method: "closed-form",
        };
        return Ok((
            p,
            Init {
                x: linear::stuck_state(ab, eta, z2),
                mode: Mode::Stick { z2 },
            },
        ));
    }
    let sim = Sim::new(model, eta)?;
    let mut used = 0u64;
    // 2. Transient, watched on the section.
    let mut tr_inner = ();
    let mut tr = Tracker::new(&mut tr_inner, cfg.tol, true);
    let end = sim.run(init, cfg.transient, &mut tr);
    used += end.periods;
    if let Some(p) = failed(&end.status, eta, used) {
        return Ok((p, Init::rest()));
    }
    if let Some(p) = tr.steady {
        let st = tr.window(p as u64).expect("periods seen");
        return Ok((
            point_from(eta, &st, p, t, used, "marching"),
            Init {
                x: end.x,
                mode: end.mode,
            },
        ));
    }
    let mut x = end.x;
    let mut mode = end.mode;
    // 3. Proven permanent stick.
    if let Mode::Stick { z2 } = mode {
        if permanently_stuck(model, eta, &x, z2) {
            let (a1, _) = linear::stuck_amplitudes(ab, eta);
            let p = Point {
                eta,
                amplitude1: Some(a1),
                amplitude2: Some(0.0),
                steady: true,
                period_multiple: Some(1),
                stick_fraction: 1.0,
                interrupted: false,
                periods: used,
                method: "stick-proof",
            };
            return Ok((
                p,
                Init {
                    x: linear::stuck_state(ab, eta, z2),
                    mode,
                },
            ));
        }
    }
    // 4. Newton shooting on the period-1 Poincaré map.
    if cfg.shooting {
        if let Some((xs, ms, n)) = shoot(&sim, model, x, mode, cfg.tol) {
            used += n;
            let mut last = Last { stats: None };
            let e = sim.run(Init { x: xs, mode: ms }, 1, &mut last);
            used += 1;
            if matches!(e.status, Status::Completed) {
                if let Some(st) = last.stats {
                    return Ok((
                        point_from(eta, &st, 1, t, used, "shooting"),
                        Init { x: xs, mode: ms },
                    ));
                }
            }
        } else {
            used += 4 * (1 + 4);
        }
    }
    // 5. Time marching.
    let mut tr_inner = ();
    let mut tr = Tracker::new(&mut tr_inner, cfg.tol, true);
    let end = sim.run(Init { x, mode }, cfg.max_periods, &mut tr);
    used += end.periods;
    if let Some(p) = failed(&end.status, eta, used) {
        return Ok((p, Init::rest()));
    }
    x = end.x;
    mode = end.mode;
    let cont = Init { x, mode };
    match tr.steady {
        Some(p) => {
            let st = tr.window(p as u64).expect("periods seen");
            Ok((point_from(eta, &st, p, t, used, "marching"), cont))
        }
        None => {
            let w = 50.min(end.periods);
            let st = tr.window(w).expect("periods seen");
            let mut pt = point_from(eta, &st, 1, t, used, "not-settled");
            pt.steady = false;
            pt.period_multiple = None;
            pt.stick_fraction = (st.stick_time / (w as f64 * t)).clamp(0.0, 1.0);
            Ok((pt, cont))
        }
    }
}

/// An undamped linear limit forced at its eigenfrequency: no steady state.
fn resonant(eta: f64) -> Point {
    Point {
        eta,
        amplitude1: None,
        amplitude2: None,
        steady: false,
        period_multiple: None,
        stick_fraction: 0.0,
        interrupted: false,
        periods: 0,
        method: "resonance",
    }
}

fn failed(status: &Status, eta: f64, periods: u64) -> Option<Point> {
    let method = match status {
        Status::Interrupted(_) => "interrupted",
        Status::Chatter(_) => "chatter",
        _ => return None,
    };
    Some(Point {
        eta,
        amplitude1: None,
        amplitude2: None,
        steady: false,
        period_multiple: None,
        stick_fraction: 0.0,
        interrupted: matches!(status, Status::Interrupted(_)),
        periods,
        method,
    })
}

/// Newton's method on P(x) − x for the period-1 section state. Stuck states
/// vary (ζ1, ζ1', ζ2) with ζ2' = 0; slipping states all four components.
/// Returns the fixed point, its mode and the periods used.
fn shoot(
    sim: &Sim,
    model: &Model,
    x0: [f64; 4],
    mode0: Mode,
    tol: f64,
) -> Option<([f64; 4], Mode, u64)> {
    let stuck = matches!(mode0, Mode::Stick { .. });
    let dim = if stuck { 3 } else { 4 };
    let same_kind = |m: Mode| matches!(m, Mode::Stick { .. }) == stuck;
    let map = |x: &[f64; 4]| {
        let mode = if stuck {
            Mode::Stick { z2: x[2] }
        } else {
            mode0
        };
        let e = sim.run(Init { x: *x, mode }, 1, &mut ());
        match e.status {
            Status::Completed => Some((e.x, e.mode)),
            _ => None,
        }
    };
    let mut x = x0;
    let mut used = 0;
    for _ in 0..8 {
        let (px, pm) = map(&x)?;
        used += 1;
        if !same_kind(pm) {
            return None;
        }
        let scale = 1.0 + x.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        let r: Vec<f64> = (0..dim).map(|i| px[i] - x[i]).collect();
        let rn = r.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        // Jacobian of P by forward differences.
        let mut j = faer::Mat::<f64>::zeros(dim, dim);
        for c in 0..dim {
            let h = 1e-7 * (1.0 + x[c].abs());
            let mut xp = x;
            xp[c] += h;
            let (pp, pmm) = map(&xp)?;
            used += 1;
            if !same_kind(pmm) {
                return None;
            }
            for i in 0..dim {
                j[(i, c)] = (pp[i] - px[i]) / h;
            }
        }
        if rn <= tol * scale {
            // Converged: accept only a stable orbit.
            let ev = j.eigenvalues().ok()?;
            let rho = ev.iter().map(|z| z.norm()).fold(0.0, f64::max);
            return if rho < 1.0 - 1e-9 {
                Some((x, if stuck { Mode::Stick { z2: x[2] } } else { pm }, used))
            } else {
                None
            };
        }
        let mut a = j.clone();
        for i in 0..dim {
            a[(i, i)] -= 1.0;
        }
        let rhs = faer::Mat::<f64>::from_fn(dim, 1, |i, _| -r[i]);
        let dx = a.full_piv_lu().solve(&rhs);
        let mut step = [0.0f64; 4];
        for i in 0..dim {
            step[i] = dx[(i, 0)];
            if !step[i].is_finite() {
                return None;
            }
        }
        for i in 0..dim {
            x[i] += step[i];
        }
        if stuck {
            x[3] = 0.0;
            if net_force(model, &x).abs() >= model.law.rho_s() {
                return None;
            }
        } else if x[3] == 0.0 || x[3].signum() != mode_dir(mode0) {
            return None;
        }
    }
    None
}

fn mode_dir(m: Mode) -> f64 {
    match m {
        Mode::Slip { dir } => dir,
        Mode::Stick { .. } => 0.0,
    }
}

/// One frequency-response curve: the model at each η in order of the
/// direction (`etas` ascending; `Down` runs them descending but returns them
/// ascending).
pub fn curve(
    model: &Model,
    etas: &[f64],
    direction: Direction,
    cfg: &SteadyConfig,
) -> Result<Vec<Point>, SimError> {
    let mut order: Vec<usize> = (0..etas.len()).collect();
    if direction == Direction::Down {
        order.reverse();
    }
    let mut out: Vec<Option<Point>> = vec![None; etas.len()];
    let mut state = Init::rest();
    for i in order {
        let start = if direction == Direction::Rest {
            Init::rest()
        } else {
            state
        };
        let (p, next) = steady_state(model, etas[i], start, cfg)?;
        state = next;
        out[i] = Some(p);
    }
    Ok(out
        .into_iter()
        .map(|p| p.expect("every eta computed"))
        .collect())
}

/// `n` equally spaced η in [lo, hi].
pub fn eta_grid(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    match n {
        0 => vec![],
        1 => vec![lo],
        _ => (0..n)
            .map(|i| lo + (hi - lo) * i as f64 / (n - 1) as f64)
            .collect(),
    }
}

/// One curve of a family.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CurveSpec {
    /// The model (its law carries ρs, ρd, D*).
    pub model: Model,
    /// Continuation policy.
    pub direction: Direction,
}

/// A slice `index` (0-based) of `count` of a family's work: whole curves for
/// continuation (each η depends on the previous one), single points for
/// curves from rest. Deterministic, so partial tables of a job array merge
/// into exactly the unsharded result.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shard {
    /// This slice, 0 ≤ index < count.
    pub index: usize,
    /// Number of slices.
    pub count: usize,
}

impl Shard {
    /// The whole family.
    pub const ALL: Shard = Shard { index: 0, count: 1 };

    fn owns(&self, unit: usize) -> bool {
        unit % self.count == self.index
    }
}

/// One computed point of a family: curve index, η index, result.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Row {
    /// Index of the curve in the family.
    pub curve: usize,
    /// Index of η in the grid.
    pub point: usize,
    /// The steady state there.
    pub value: Point,
}

/// Computes the family's curves (or this shard's part of them) in
/// parallel; `tick(n)` is called as n points complete. Rows are returned
/// ordered by (curve, point) whatever the thread count.
pub fn family(
    specs: &[CurveSpec],
    etas: &[f64],
    cfg: &SteadyConfig,
    shard: Shard,
    tick: &(dyn Fn(u64) + Sync),
) -> Result<Vec<Row>, SimError> {
    use rayon::prelude::*;
    // Work units: (curve, Some(point)) for curves from rest, (curve, None)
    // for continuation curves; numbered in this fixed order.
    let mut units = Vec::new();
    for (c, s) in specs.iter().enumerate() {
        if s.direction == Direction::Rest {
            units.extend((0..etas.len()).map(|p| (c, Some(p))));
        } else {
            units.push((c, None));
        }
    }
    let mine: Vec<(usize, Option<usize>)> = units
        .into_iter()
        .enumerate()
        .filter(|(u, _)| shard.owns(*u))
        .map(|(_, w)| w)
        .collect();
    let parts: Result<Vec<Vec<Row>>, SimError> = mine
        .par_iter()
        .map(|&(c, p)| {
            let spec = &specs[c];
            match p {
                Some(p) => {
                    let (v, _) = steady_state(&spec.model, etas[p], Init::rest(), cfg)?;
                    tick(1);
                    Ok(vec![Row {
                        curve: c,
                        point: p,
                        value: v,
                    }])
                }
                None => {
                    let pts = curve(&spec.model, etas, spec.direction, cfg)?;
                    tick(pts.len() as u64);
                    Ok(pts
                        .into_iter()
                        .enumerate()
                        .map(|(p, v)| Row {
                            curve: c,
                            point: p,
                            value: v,
                        })
                        .collect())
                }
            }
        })
        .collect();
    let mut rows: Vec<Row> = parts?.into_iter().flatten().collect();
    rows.sort_by_key(|r| (r.curve, r.point));
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{Absorber, Law};

    fn coulomb(rs: f64) -> Model {
        Model {
            absorber: Absorber::default(),
            law: Law::coulomb(rs),
            stop_below: None,
        }
    }

    /// Shooting and marching agree on the same steady state (H1 case:
    /// a pure-slip period-1 orbit that marching reaches only slowly).
    #[test]
    fn shooting_agrees_with_marching() {
        let m = coulomb(0.375);
        let shoot = SteadyConfig::default();
        let march = SteadyConfig {
            shooting: false,
            ..shoot
        };
        let (a, _) = steady_state(&m, 0.6, Init::rest(), &shoot).unwrap();
        let (b, _) = steady_state(&m, 0.6, Init::rest(), &march).unwrap();
        assert!(a.steady && b.steady);
        let (a1, b1) = (a.amplitude1.unwrap(), b.amplitude1.unwrap());
        assert!(
            (a1 - b1).abs() < 1e-7 * b1,
            "{a1} vs {b1} ({} vs {})",
            a.method,
            b.method
        );
    }

    /// The limits in closed form and the proven permanent stick.
    #[test]
    fn limits_and_stick_proof() {
        let ab = Absorber::default();
        for eta in [0.3, 0.7, 1.2] {
            let (p, _) =
                steady_state(&coulomb(0.0), eta, Init::rest(), &SteadyConfig::default()).unwrap();
            let (a1, a2) = linear::free_amplitudes(&ab, 0.0, eta);
            assert_eq!((p.amplitude1.unwrap(), p.amplitude2.unwrap()), (a1, a2));
            let (p, _) = steady_state(
                &coulomb(f64::INFINITY),
                eta,
                Init::rest(),
                &SteadyConfig::default(),
            )
            .unwrap();
            assert_eq!(p.amplitude1.unwrap(), linear::stuck_amplitudes(&ab, eta).0);
        }
        // ρs = 5 at η = 1.2 (stuck orbit's largest contact force ≈ 1.4 ≪ 5):
        // the proof applies after the transient, with the 1-DOF amplitude.
        let (p, _) =
            steady_state(&coulomb(5.0), 1.2, Init::rest(), &SteadyConfig::default()).unwrap();
        assert_eq!(p.method, "stick-proof");
        assert!((p.amplitude1.unwrap() - linear::stuck_amplitudes(&ab, 1.2).0).abs() < 1e-15);
    }

    /// Shards partition the work and reassemble to the unsharded family.
    #[test]
    fn shards_reassemble_exactly() {
        let etas = eta_grid(0.3, 1.3, 9);
        let specs = [
            CurveSpec {
                model: coulomb(0.2),
                direction: Direction::Up,
            },
            CurveSpec {
                model: coulomb(0.4),
                direction: Direction::Down,
            },
            CurveSpec {
                model: coulomb(0.3),
                direction: Direction::Rest,
            },
        ];
        let cfg = SteadyConfig::default();
        let all = family(&specs, &etas, &cfg, Shard::ALL, &|_| {}).unwrap();
        let mut parts = Vec::new();
        for index in 0..3 {
            parts.extend(family(&specs, &etas, &cfg, Shard { index, count: 3 }, &|_| {}).unwrap());
        }
        parts.sort_by_key(|r| (r.curve, r.point));
        assert_eq!(all, parts);
        assert_eq!(all.len(), 27);
    }
}

#[cfg(test)]
mod determinism {
    use super::*;
    use crate::model::{Absorber, Law};

    /// The same family on 1 and on 3 worker threads: identical rows.
    #[test]
    fn results_do_not_depend_on_thread_count() {
        let etas = eta_grid(0.3, 1.3, 11);
        let specs: Vec<CurveSpec> = [0.1, 0.4, 1.0]
            .iter()
            .flat_map(|&rs| {
                let model = Model {
                    absorber: Absorber::default(),
                    law: Law::Linear {
                        rho_s: rs,
                        rho_d: 0.5 * rs,
                        slope: 0.0,
                    },
                    stop_below: None,
                };
                [Direction::Up, Direction::Rest].map(|direction| CurveSpec { model, direction })
            })
            .collect();
        let cfg = SteadyConfig::default();
        let on = |n: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(n)
                .build()
                .unwrap()
                .install(|| family(&specs, &etas, &cfg, Shard::ALL, &|_| {}).unwrap())
        };
        assert_eq!(on(1), on(3));
    }
}
