//! The worst-case frequency response over the drive range, for a friction
//! level and its uncertainty box; the drive grid; the rig check.

use super::*;

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
    let (lo, hi) = range;
    let mut v = crate::sim::sweep::eta_grid(lo, hi, points);
    if fine_step > 0.0 && fine_half > 0.0 {
        let (e1, e2) = ab.eta_linear();
        let k = (fine_half / fine_step).round() as i64;
        for c in [e1, ab.eta_stuck(), e2] {
            for i in -k..=k {
                let e = c + i as f64 * fine_step;
                if e >= lo && e <= hi {
                    v.push(e);
                }
            }
        }
    }
    v.sort_by(f64::total_cmp);
    v.dedup_by(|a, b| (*a - *b).abs() <= 1e-9 * b.abs().max(1.0));
    v
}

/// The default drive range [0.5·η1, 1.4·η2] of an absorber.
pub fn default_eta_range(ab: &Absorber) -> (f64, f64) {
    let (e1, e2) = ab.eta_linear();
    (0.5 * e1, 1.4 * e2)
}

/// W = max over `etas` of A1/A, the worse of the steady states continued
/// upwards, downwards and from rest, for the law (ρs, ρd) without slope.
pub fn worst_case(
    ab: &Absorber,
    rho_s: f64,
    rho_d: f64,
    etas: &[f64],
    cfg: &SteadyConfig,
) -> std::result::Result<Worst, SimError> {
    let model = Model {
        absorber: *ab,
        law: Law::Linear {
            rho_s,
            rho_d: rho_d.min(rho_s),
            slope: 0.0,
        },
        stop_below: None,
    };
    model.law.validate()?;
    let branches = [Direction::Up, Direction::Down, Direction::Rest];
    let curves: std::result::Result<Vec<Vec<crate::sim::sweep::Point>>, SimError> = branches
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
    let mut w = Worst {
        rho_s,
        rho_d: rho_d.min(rho_s),
        amplitude1: 0.0,
        eta: etas.first().copied().unwrap_or(f64::NAN),
        branch: Direction::Up,
        unsettled: 0,
        missing: 0,
        coexisting: 0,
        coexisting_eta: f64::NAN,
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
    for (d, c) in branches.iter().zip(&curves) {
        for p in c {
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
    Ok(w)
}

/// W on a table of ρs nodes, computed lazily and reused: every node has W
/// at the estimated ratio ρd/ρs; nodes in the refined region also at the
/// ends of the ratio's interval.
pub(super) struct Table<'a> {
    pub(super) ab: Absorber,
    pub(super) etas: &'a [f64],
    pub(super) cfg: SteadyConfig,
    pub(super) ratios: Vec<f64>,
    /// Sorted ρs nodes and, per node, W for the first 1 or all ratios.
    pub(super) nodes: Vec<(f64, Vec<Worst>)>,
    pub(super) evaluations: usize,
    pub(super) tick: &'a (dyn Fn(u64) + Sync),
}

impl Table<'_> {
    /// Evaluates W at the nodes `rhos` (new ones added; with `all`, every
    /// ratio), in parallel, in a fixed order.
    pub(super) fn add(&mut self, rhos: &[f64], all: bool) -> std::result::Result<(), SimError> {
        let k = if all { self.ratios.len() } else { 1 };
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
        let ratios = &self.ratios;
        let ws: std::result::Result<Vec<Worst>, SimError> = work
            .par_iter()
            .map(|&(r, q)| {
                let w = worst_case(&ab, r, ratios[q] * r, etas, &cfg);
                tick(1);
                w
            })
            .collect();
        let ws = ws?;
        self.evaluations += ws.len();
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
        self.nodes[i].1.len() == self.ratios.len()
    }

    /// Max over ratios (or W at the estimated ratio, `nominal`) at ρ,
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

    /// Robust worst case over ρ ∈ [a, b]: every ratio (or the estimated
    /// one, `nominal`) at the nodes inside and interpolated at the ends;
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
pub fn rig_warnings(rigs: &[(PathBuf, RigMeta)]) -> Vec<String> {
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
                out.push(format!(
                    "rig constant {name} of {} ({b}) differs from {} ({a}): a batch should be one pad on one rig",
                    p.display(),
                    p0.display()
                ));
            }
        }
    }
    out
}
