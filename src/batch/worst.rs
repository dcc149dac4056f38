//! The worst-case frequency response over the drive range, for a friction
//! level and its uncertainty box; the drive grid; the rig check.

use super::*;
use crate::sim::sweep::Point;

/// The η grid of the drive range: `points` uniform values over `range`
/// plus windows of step `fine_step` and half-width `fine_half` around η1,
/// η0 and η2 (inside the range), ascending and without duplicates.
pub fn drive_etas(
    ab: &Absorber,
    range: (f64, f64),
    points: usize,
    fine_step: f64,
    fine_half: f64,
) -> Vec<f64> {
    drive_grid(ab, range, points, fine_step, fine_half, 1).etas
}

/// The η grid of a worst case ([`worst_case_on`]): every η it may evaluate
/// (the grid of [`drive_etas`], ascending) and which of them it evaluates
/// in any case (the coarse grid).
#[derive(Debug, Clone, PartialEq)]
pub struct DriveGrid {
    /// Every η the worst case may evaluate, ascending.
    pub etas: Vec<f64>,
    /// Per η: evaluated in any case. The others are evaluated only next to
    /// a local maximum of a branch (see [`worst_case_on`]).
    pub coarse: Vec<bool>,
}

impl DriveGrid {
    /// Every η is evaluated (the uniform search of [`worst_case`]).
    pub fn is_uniform(&self) -> bool {
        self.coarse.iter().all(|&c| c)
    }
}

/// The grid of [`drive_etas`] with its coarse part: every `stride`-th
/// uniform point (and the last) and every `stride`-th point of each fine
/// window, counted from its centre (η1, η0 or η2 itself, where the linear
/// limits peak). `stride` 1 (or 0) evaluates every point.
pub fn drive_grid(
    ab: &Absorber,
    range: (f64, f64),
    points: usize,
    fine_step: f64,
    fine_half: f64,
    stride: usize,
) -> DriveGrid {
    let (lo, hi) = range;
    let stride = stride.max(1);
    let mut v: Vec<(f64, bool)> = crate::sim::sweep::eta_grid(lo, hi, points)
        .into_iter()
        .enumerate()
        .map(|(i, e)| (e, i % stride == 0 || i + 1 == points))
        .collect();
    if fine_step > 0.0 && fine_half > 0.0 {
        let (e1, e2) = ab.eta_linear();
        let k = (fine_half / fine_step).round() as i64;
        for c in [e1, ab.eta_stuck(), e2] {
            for i in -k..=k {
                let e = c + i as f64 * fine_step;
                if e >= lo && e <= hi {
                    v.push((e, i.rem_euclid(stride as i64) == 0));
                }
            }
        }
    }
    v.sort_by(|a, b| a.0.total_cmp(&b.0));
    // Near-equal values: the first is kept, coarse if either is.
    let mut out: Vec<(f64, bool)> = Vec::with_capacity(v.len());
    for (e, c) in v {
        match out.last_mut() {
            Some(last) if (e - last.0).abs() <= 1e-9 * last.0.abs().max(1.0) => last.1 |= c,
            _ => out.push((e, c)),
        }
    }
    DriveGrid {
        etas: out.iter().map(|p| p.0).collect(),
        coarse: out.iter().map(|p| p.1).collect(),
    }
}

/// The default drive range [0.5·η1, 1.4·η2] of an absorber.
pub fn default_eta_range(ab: &Absorber) -> (f64, f64) {
    let (e1, e2) = ab.eta_linear();
    (0.5 * e1, 1.4 * e2)
}

/// W = max over `etas` of A1/A, the worse of the steady states continued
/// upwards, downwards and from rest, for the law (ρs, ρd) without slope on
/// a pad of shape `shape` ([`PadShape::PAPER`]: symmetric and rigid).
/// Every η is evaluated; [`worst_case_on`] evaluates a coarse grid and
/// refines it next to the branches' maxima.
pub fn worst_case(
    ab: &Absorber,
    shape: PadShape,
    rho_s: f64,
    rho_d: f64,
    etas: &[f64],
    cfg: &SteadyConfig,
) -> std::result::Result<Worst, SimError> {
    let model = worst_model(ab, shape, rho_s, rho_d)?;
    let curves: std::result::Result<Vec<Vec<Point>>, SimError> = BRANCHES
        .par_iter()
        .map(|&d| match d {
            Direction::Rest => etas
                .par_iter()
                .map_init(
                    || None,
                    |engine, &e| {
                        steady_state_with(engine, &model, e, Init::rest(), cfg).map(|(p, _)| p)
                    },
                )
                .collect(),
            _ => curve(&model, etas, d, cfg),
        })
        .collect();
    let curves = curves?;
    Ok(summarise(rho_s, rho_d.min(rho_s), etas, &curves))
}

/// The branches of a worst case, in the order of [`Worst::branch`] ties.
const BRANCHES: [Direction; 3] = [Direction::Up, Direction::Down, Direction::Rest];

/// The model of a worst case: the law (ρs, min(ρd, ρs)) without slope, on
/// the pad `shape` (a split threshold ρs⁻ = ratio·ρs with the dynamic
/// level shared, at most ρs⁻; a contact spring κ, at this ρs where it
/// depends on N).
pub(super) fn worst_model(
    ab: &Absorber,
    shape: PadShape,
    rho_s: f64,
    rho_d: f64,
) -> std::result::Result<Model, SimError> {
    let rho_d = rho_d.min(rho_s);
    let model = Model {
        absorber: *ab,
        law: Law::Linear {
            rho_s,
            rho_d,
            slope: 0.0,
            minus: shape.rs_minus_ratio.map(|r| crate::model::Levels {
                rho_s: r * rho_s,
                rho_d: rho_d.min(r * rho_s),
            }),
        },
        stop_below: None,
        contact_stiffness: shape.contact_at(rho_s),
    };
    model.validate().map_err(SimError::Param)?;
    Ok(model)
}

/// W and its counts from the three branches' points at `etas`.
fn summarise(rho_s: f64, rho_d: f64, etas: &[f64], curves: &[Vec<Point>]) -> Worst {
    let mut w = Worst {
        rho_s,
        rho_d,
        amplitude1: 0.0,
        eta: etas.first().copied().unwrap_or(f64::NAN),
        branch: Direction::Up,
        unsettled: 0,
        missing: 0,
        coexisting: 0,
        coexisting_eta: f64::NAN,
        points: etas.len(),
        periods: 0,
    };
    for (i, &eta) in etas.iter().enumerate() {
        let differ = (0..curves.len()).any(|a| {
            (a + 1..curves.len())
                .any(|b| crate::sim::sweep::distinct_states(&curves[a][i], &curves[b][i]))
        });
        if differ {
            w.coexisting += 1;
            if w.coexisting == 1 {
                w.coexisting_eta = eta;
            }
        }
    }
    for (d, c) in BRANCHES.iter().zip(curves) {
        for p in c {
            w.periods += p.periods;
            if !p.steady {
                w.unsettled += 1;
            }
            match p.amplitude1 {
                Some(a) if a.is_finite() => {
                    if a > w.amplitude1 {
                        w.amplitude1 = a;
                        w.eta = p.eta;
                        w.branch = *d;
                    }
                }
                _ => w.missing += 1,
            }
        }
    }
    w
}

/// A local maximum of a branch at or above this fraction of the largest
/// A1/A seen so far has its neighbouring intervals refined.
pub const REFINE_FRACTION: f64 = 0.5;

/// One evaluated point of a continuation branch: the steady state, the
/// section state it hands on, and the grid index it was continued from.
#[derive(Debug, Clone, Copy)]
struct Continued {
    point: Point,
    next: Init,
    from: Option<usize>,
}

/// W on `grid` ([`worst_case`] when every η is coarse). Otherwise the three
/// branches are computed on the coarse η, then, round by round, every
/// interval next to a local maximum of a branch (A1/A at least
/// [`REFINE_FRACTION`] of the largest so far) gets the grid point in its
/// middle, until the maxima's neighbours are adjacent grid points. A point
/// inserted into a continuation branch is continued from its predecessor
/// (in the direction of the branch), and the branch is continued again
/// from there until it reaches a steady state it had before (the same
/// attractor: the rest of the branch stands). So a branch that jumps off
/// next to its maximum is followed as far as the fine grid follows it;
/// broad maxima (friction-damped) are found to the grid's resolution.
/// Counts (`unsettled`, `coexisting`, `points`) are over the η evaluated.
pub fn worst_case_on(
    ab: &Absorber,
    shape: PadShape,
    rho_s: f64,
    rho_d: f64,
    grid: &DriveGrid,
    cfg: &SteadyConfig,
) -> std::result::Result<Worst, SimError> {
    if grid.is_uniform() {
        return worst_case(ab, shape, rho_s, rho_d, &grid.etas, cfg);
    }
    let model = worst_model(ab, shape, rho_s, rho_d)?;
    let etas = &grid.etas;
    let n = etas.len();
    let mut active = grid.coarse.clone();
    let mut up: Vec<Option<Continued>> = vec![None; n];
    let mut down: Vec<Option<Continued>> = vec![None; n];
    let mut rest: Vec<Option<Point>> = vec![None; n];
    let mut fresh: Vec<usize> = (0..n).filter(|&i| active[i]).collect();
    // Periods of points continued again (their first result replaced).
    let mut replaced = 0u64;
    loop {
        let order: Vec<usize> = (0..n).filter(|&i| active[i]).collect();
        let (r_up, (r_down, r_rest)) = rayon::join(
            || continue_branch(&model, etas, &order, &mut up, cfg),
            || {
                rayon::join(
                    || {
                        let rev: Vec<usize> = order.iter().rev().copied().collect();
                        continue_branch(&model, etas, &rev, &mut down, cfg)
                    },
                    || -> std::result::Result<Vec<(usize, Point)>, SimError> {
                        fresh
                            .par_iter()
                            .map_init(
                                || None,
                                |engine, &i| {
                                    steady_state_with(engine, &model, etas[i], Init::rest(), cfg)
                                        .map(|(p, _)| (i, p))
                                },
                            )
                            .collect()
                    },
                )
            },
        );
        replaced += r_up? + r_down?;
        for (i, p) in r_rest? {
            rest[i] = Some(p);
        }
        let a1 = |p: &Point| p.amplitude1.filter(|a| a.is_finite());
        let value = |b: usize, i: usize| -> Option<f64> {
            match b {
                0 => up[i].as_ref().and_then(|c| a1(&c.point)),
                1 => down[i].as_ref().and_then(|c| a1(&c.point)),
                _ => rest[i].as_ref().and_then(a1),
            }
        };
        let top = (0..3)
            .flat_map(|b| order.iter().filter_map(move |&i| value(b, i)))
            .fold(0.0f64, f64::max);
        let mut add: Vec<usize> = Vec::new();
        for b in 0..3 {
            for (k, &i) in order.iter().enumerate() {
                let Some(v) = value(b, i) else { continue };
                if v < REFINE_FRACTION * top {
                    continue;
                }
                let left = k.checked_sub(1).map(|k| order[k]);
                let right = order.get(k + 1).copied();
                let below = |j: Option<usize>| j.and_then(|j| value(b, j)).is_none_or(|u| u <= v);
                if !(below(left) && below(right)) {
                    continue;
                }
                if let Some(l) = left {
                    if i - l > 1 {
                        add.push((l + i) / 2);
                    }
                }
                if let Some(r) = right {
                    if r - i > 1 {
                        add.push((i + r) / 2);
                    }
                }
            }
        }
        add.sort_unstable();
        add.dedup();
        if add.is_empty() {
            break;
        }
        for &i in &add {
            active[i] = true;
        }
        fresh = add;
    }
    let order: Vec<usize> = (0..n).filter(|&i| active[i]).collect();
    let pick = |i: usize, b: usize| -> Point {
        match b {
            0 => up[i].expect("continued").point,
            1 => down[i].expect("continued").point,
            _ => rest[i].expect("from rest"),
        }
    };
    let curves: Vec<Vec<Point>> = (0..3)
        .map(|b| order.iter().map(|&i| pick(i, b)).collect())
        .collect();
    let at: Vec<f64> = order.iter().map(|&i| etas[i]).collect();
    let mut w = summarise(rho_s, rho_d.min(rho_s), &at, &curves);
    w.periods += replaced;
    Ok(w)
}

/// Continues a branch over the grid indices `order` (in the branch's
/// direction). A point is (re)computed when it is new, when its
/// predecessor in `order` is not the one it was continued from, or when
/// its predecessor was recomputed into a different steady state (or into
/// one that settles where the old did not, or the reverse); otherwise it
/// stands. Deterministic: the points are computed in order. Returns the
/// periods of the points it replaced.
fn continue_branch(
    model: &Model,
    etas: &[f64],
    order: &[usize],
    slots: &mut [Option<Continued>],
    cfg: &SteadyConfig,
) -> std::result::Result<u64, SimError> {
    let mut replaced = 0;
    let mut engine = None;
    let mut prev: Option<usize> = None;
    let mut prev_changed = false;
    for &i in order {
        let redo = match &slots[i] {
            None => true,
            Some(c) => c.from != prev || prev_changed,
        };
        if redo {
            let start = prev
                .and_then(|p| slots[p].as_ref().map(|c| c.next))
                .unwrap_or_else(Init::rest);
            let (point, next) = steady_state_with(&mut engine, model, etas[i], start, cfg)?;
            prev_changed = match &slots[i] {
                None => true,
                Some(old) => {
                    replaced += old.point.periods;
                    old.point.steady != point.steady
                        || crate::sim::sweep::distinct_states(&old.point, &point)
                }
            };
            slots[i] = Some(Continued {
                point,
                next,
                from: prev,
            });
        } else {
            prev_changed = false;
        }
        prev = Some(i);
    }
    Ok(replaced)
}

/// W on a table of ρs nodes, computed lazily and reused: every node has W
/// of the estimated pad (ratio ρd/ρs and shape); nodes in the refined
/// region also of its variants (`variants[1..]`: the ends of the ratio's
/// interval, of κ's and of ρs⁻/ρs⁺'s, one at a time).
pub(super) struct Table<'a> {
    pub(super) ab: Absorber,
    pub(super) etas: &'a DriveGrid,
    pub(super) cfg: SteadyConfig,
    /// The estimated pad first, then its variants: (ρd/ρs, shape).
    pub(super) variants: Vec<(f64, PadShape)>,
    /// Sorted ρs nodes and, per node, W for the first 1 or all variants.
    pub(super) nodes: Vec<(f64, Vec<Worst>)>,
    pub(super) evaluations: usize,
    /// Forcing periods integrated by the evaluations.
    pub(super) periods: u64,
    pub(super) tick: &'a (dyn Fn(u64) + Sync),
}

impl Table<'_> {
    /// Evaluates W at the nodes `rhos` (new ones added; with `all`, every
    /// ratio), in parallel, in a fixed order.
    pub(super) fn add(&mut self, rhos: &[f64], all: bool) -> std::result::Result<(), SimError> {
        let k = if all { self.variants.len() } else { 1 };
        let mut want: Vec<f64> = rhos.to_vec();
        want.sort_by(f64::total_cmp);
        want.dedup_by(|a, b| (*a - *b).abs() <= 1e-12 * b.abs());
        // (node value, ratio index) still missing.
        let mut work: Vec<(f64, usize)> = Vec::new();
        for &r in &want {
            let have = self.find(r).map_or(0, |i| self.nodes[i].1.len());
            let r = self.find(r).map_or(r, |i| self.nodes[i].0);
            work.extend((have..k).map(|q| (r, q)));
        }
        let (ab, etas, cfg, tick) = (self.ab, self.etas, self.cfg, self.tick);
        let variants = &self.variants;
        let ws: std::result::Result<Vec<Worst>, SimError> = work
            .par_iter()
            .map(|&(r, q)| {
                let (ratio, shape) = variants[q];
                let w = worst_case_on(&ab, shape, r, ratio * r, etas, &cfg);
                tick(1);
                w
            })
            .collect();
        let ws = ws?;
        self.evaluations += ws.len();
        self.periods += ws.iter().map(|w| w.periods).sum::<u64>();
        for ((r, q), w) in work.into_iter().zip(ws) {
            match self.find(r) {
                Some(i) => {
                    debug_assert_eq!(self.nodes[i].1.len(), q);
                    self.nodes[i].1.push(w);
                }
                None => {
                    debug_assert_eq!(q, 0);
                    self.nodes.push((r, vec![w]));
                    self.nodes.sort_by(|a, b| a.0.total_cmp(&b.0));
                }
            }
        }
        Ok(())
    }

    /// The node at ρ (relative tolerance 1e-12).
    pub(super) fn find(&self, rho: f64) -> Option<usize> {
        let j = self
            .nodes
            .partition_point(|(x, _)| *x < rho * (1.0 - 1e-12));
        (j < self.nodes.len() && (self.nodes[j].0 - rho).abs() <= 1e-12 * rho).then_some(j)
    }

    /// W at the estimated ratio of node i.
    pub(super) fn w(&self, i: usize) -> f64 {
        self.nodes[i].1[0].amplitude1
    }

    pub(super) fn full(&self, i: usize) -> bool {
        self.nodes[i].1.len() == self.variants.len()
    }

    /// Max over the variants (or W of the estimated pad, `nominal`) at ρ,
    /// interpolated linearly in ln ρ between nodes; None off the grid or
    /// where a node lacks a ratio.
    pub(super) fn interp_max(&self, rho: f64, nominal: bool) -> Option<f64> {
        let n = &self.nodes;
        let take = |w: &[Worst]| if nominal { w[0].amplitude1 } else { max_w(w) };
        if let Some(i) = self.find(rho) {
            return (nominal || self.full(i)).then(|| take(&n[i].1));
        }
        let j = n.partition_point(|(x, _)| *x < rho);
        if j == 0 || j >= n.len() || !(nominal || (self.full(j - 1) && self.full(j))) {
            return None;
        }
        if nominal {
            let (x0, x1) = (n[j - 1].0.ln(), n[j].0.ln());
            let t = ((rho.ln() - x0) / (x1 - x0)).clamp(0.0, 1.0);
            let (a, b) = (n[j - 1].1[0].amplitude1, n[j].1[0].amplitude1);
            return Some(a + t * (b - a));
        }
        let (x0, x1) = (n[j - 1].0.ln(), n[j].0.ln());
        let t = ((rho.ln() - x0) / (x1 - x0)).clamp(0.0, 1.0);
        Some(
            n[j - 1]
                .1
                .iter()
                .zip(&n[j].1)
                .map(|(a, b)| a.amplitude1 + t * (b.amplitude1 - a.amplitude1))
                .fold(0.0, f64::max),
        )
    }

    /// Robust worst case over ρ ∈ [a, b]: every variant (or the estimated
    /// pad, `nominal`) at the nodes inside and interpolated at the ends;
    /// None unless all of them are known.
    pub(super) fn robust(&self, a: f64, b: f64, nominal: bool) -> Option<f64> {
        let ea = self.interp_max(a, nominal)?;
        let eb = self.interp_max(b, nominal)?;
        let mut m = ea.max(eb);
        for (i, (x, w)) in self.nodes.iter().enumerate() {
            if *x > a && *x < b {
                if nominal {
                    m = m.max(w[0].amplitude1);
                } else if !self.full(i) {
                    return None;
                } else {
                    m = m.max(max_w(w));
                }
            }
        }
        Some(m)
    }
}

pub(super) fn max_w(ws: &[Worst]) -> f64 {
    ws.iter().map(|w| w.amplitude1).fold(0.0, f64::max)
}

/// Node k of the geometric grid from `lo` to `hi` with `steps` intervals.
pub(super) fn geom_node(lo: f64, hi: f64, steps: usize, k: usize) -> f64 {
    lo * (hi / lo).powf(k as f64 / steps.max(1) as f64)
}

/// Checks that the logs come from one rig (M1, M2, K1, K2, d within 1 %);
/// returns a warning per differing constant.
pub fn rig_warnings(rigs: &[(PathBuf, RigMeta)]) -> Vec<crate::warning::Warning> {
    let mut out = Vec::new();
    let Some((p0, r0)) = rigs.first() else {
        return out;
    };
    for (p, r) in &rigs[1..] {
        for (name, a, b) in [
            ("M1", r0.m1_kg, r.m1_kg),
            ("M2", r0.m2_kg, r.m2_kg),
            ("K1", r0.k1_n_per_m, r.k1_n_per_m),
            ("K2", r0.k2_n_per_m, r.k2_n_per_m),
            ("d", r0.d_n_s_per_m, r.d_n_s_per_m),
            ("nominal A", r0.drive_amplitude_m, r.drive_amplitude_m),
        ] {
            if (a - b).abs() > 0.01 * a.abs().max(b.abs()) {
                out.push(crate::warning::Warning::BatchRigMismatch {
                    constant: name,
                    log: p.clone(),
                    value: b,
                    reference_log: p0.clone(),
                    reference: a,
                });
            }
        }
    }
    out
}
