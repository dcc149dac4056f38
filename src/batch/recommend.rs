//! The recommendation search on the table of worst cases: the region of
//! good candidates refined over their whole uncertainty boxes (stage 2),
//! the recommended setting with its window, and the cliff below it.

use super::worst::{geom_node, worst_case_on, DriveGrid, Table};
use super::{BatchOptions, Cliff, Recommendation, REFINE};
use crate::model::Absorber;
use crate::sim::SimError;

/// Everything the search needs besides the table.
pub(super) struct Search<'a> {
    /// The absorber.
    pub ab: Absorber,
    /// The pad's shape.
    pub shape: super::PadShape,
    /// The η grid of a worst case.
    pub etas: &'a DriveGrid,
    /// The batch options.
    pub opts: &'a BatchOptions,
    /// The estimated ratio ρd/ρs.
    pub ratio: f64,
    /// The coarse geometric ρs grid (stage 1) and its number of steps.
    pub coarse: &'a [f64],
    /// Steps of the coarse grid.
    pub steps: usize,
    /// The grid's ends.
    pub rho_min: f64,
    /// See `rho_min`.
    pub rho_max: f64,
    /// A setting's uncertainty box as factors (fa, fb) on its nominal ρs.
    pub fa: f64,
    /// See `fa`.
    pub fb: f64,
    /// The box is narrow enough to search for.
    pub box_ok: bool,
    /// μs and its interval, in words (for the reasons).
    pub mu_words: String,
    /// μs's 95 % interval.
    pub mu_s_interval: (f64, f64),
    /// Unresolved μs conflicts remain.
    pub unresolved: bool,
    /// Normal force (N) of a ρs.
    pub n_of: &'a dyn Fn(f64) -> f64,
    /// Progress: one per worst case evaluated.
    pub tick: &'a (dyn Fn(u64) + Sync),
}

/// The recommendation and its cliff, or why there is none.
pub(super) type Outcome = Result<(Recommendation, Option<Cliff>), NoRecommendation>;

/// What the logs' contradiction adds to [`NoRecommendation::Unbounded`]
/// and [`NoRecommendation::BoxTooWide`] when they are unresolved.
const UNRESOLVED: &str = " (the logs contradict each other on Rs and the data do not say which is off: see the conflicts)";

/// Why the search recommends no normal force (the reason of
/// [`crate::warning::Warning::NoRecommendation`]).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub(super) enum NoRecommendation {
    /// The μs box reaches down to zero or is unbounded.
    #[error("{mu_words}{} reaches down to zero or is unbounded: the logs do not pin down the static friction, so no normal force can be shown to keep the main mass quiet; add logs at normal forces where the absorber sticks and slips", if *.unresolved { UNRESOLVED } else { "" })]
    Unbounded {
        /// The μ interval in words.
        mu_words: String,
        /// Whether the logs contradict each other unresolved.
        unresolved: bool,
    },
    /// The μs box spans too wide a factor.
    #[error("{mu_words}{} spans a factor of {factor:.0}: any normal force could be anywhere from sliding freely to stuck; add logs at normal forces where the absorber sticks and slips", if *.unresolved { UNRESOLVED } else { "" })]
    BoxTooWide {
        /// The μ interval in words.
        mu_words: String,
        /// Whether the logs contradict each other unresolved.
        unresolved: bool,
        /// Upper over lower end of the μs interval.
        factor: f64,
    },
    /// No coarse node's whole box is inside the ρs grid.
    #[error("no setting on the ρs grid [{rho_min}, {rho_max}] has its whole uncertainty range ({mu_words}, setting ±{:.0} %) inside the grid; widen --rho-min/--rho-max", 100.0 * .setting_tolerance)]
    NoBoxInGrid {
        /// Lower end of the grid.
        rho_min: f64,
        /// Upper end of the grid.
        rho_max: f64,
        /// The μ interval in words.
        mu_words: String,
        /// The setting tolerance (fraction).
        setting_tolerance: f64,
    },
    /// Measured logs contradict each other on Rs and the data do not say
    /// which is off.
    #[error("the logs contradict each other on Rs and the data do not say which is off ({mu_words}, widened by their disagreement): the batch's premise, one pad whose friction is proportional to the normal force, does not hold for these logs, so no normal force is recommended; see the conflicts, and check which log is of another pad or setting, or add logs")]
    Contradicted {
        /// The μ interval in words.
        mu_words: String,
    },
    /// No node's whole box was evaluated.
    #[error("no setting on the ρs grid [{rho_min}, {rho_max}] has its whole uncertainty range ({mu_words}) evaluated; widen --rho-min/--rho-max")]
    NoBoxEvaluated {
        /// Lower end of the grid.
        rho_min: f64,
        /// Upper end of the grid.
        rho_max: f64,
        /// The μ interval in words.
        mu_words: String,
    },
    /// The recommended node is no longer in the table.
    #[error("the recommended node left the table")]
    NodeLeftTable,
}

impl Search<'_> {
    /// Runs the search on `table` (worst cases added as needed); a failed
    /// simulation is the error, a search that cannot recommend is
    /// `Ok(Err(reason))`.
    pub fn run(
        &self,
        table: &mut Table<'_>,
        warnings: &mut Vec<crate::warning::Warning>,
    ) -> Result<Outcome, SimError> {
        if !self.box_ok {
            return Ok(Err(self.no_box_reason()));
        }
        // A setting robust over an interval that only holds the
        // contradicting logs' values (Student's t on their scatter) would
        // still be a guess.
        if self.unresolved {
            return Ok(Err(NoRecommendation::Contradicted {
                mu_words: self.mu_words.clone(),
            }));
        }
        if let Err(reason) = self.refine_region(table)? {
            return Ok(Err(reason));
        }
        let (fa, fb) = (self.fa, self.fb);
        let (rho_min, rho_max) = (self.rho_min, self.rho_max);
        let rob = robust_all(table, fa, fb);
        let Some(best) = rob
            .iter()
            .enumerate()
            .filter_map(|(i, r)| r.map(|v| (i, v)))
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(i, _)| i)
        else {
            return Ok(Err(NoRecommendation::NoBoxEvaluated {
                rho_min,
                rho_max,
                mu_words: self.mu_words.clone(),
            }));
        };
        let rho_rec = table.nodes[best].0;
        let (box_a, box_b) = (rho_rec * fa, rho_rec * fb);
        // The box ends, evaluated directly (every ratio).
        table.add(&[box_a, box_b], true)?;
        let in_box: Vec<f64> = table
            .nodes
            .iter()
            .filter(|(x, _)| *x >= box_a * (1.0 - 1e-12) && *x <= box_b * (1.0 + 1e-12))
            .flat_map(|(_, w)| w.iter().map(|w| w.amplitude1))
            .collect();
        let worst_interval = (
            in_box.iter().copied().fold(f64::INFINITY, f64::min),
            in_box.iter().copied().fold(0.0, f64::max),
        );
        let Some(best) = table.find(rho_rec) else {
            return Ok(Err(NoRecommendation::NodeLeftTable));
        };
        let w_rec = table.nodes[best].1[0];
        // Window of settings within `window` of the robust optimum.
        let rob = robust_all(table, fa, fb);
        let limit = worst_interval.1 * (1.0 + self.opts.window);
        let ok = |i: usize| rob[i].is_some_and(|v| v <= limit);
        let (mut lo_i, mut hi_i) = (best, best);
        while lo_i > 0 && ok(lo_i - 1) {
            lo_i -= 1;
        }
        while hi_i + 1 < rob.len() && ok(hi_i + 1) {
            hi_i += 1;
        }
        let n_of = self.n_of;
        let recommendation = Recommendation {
            normal_force_n: n_of(rho_rec),
            interval_n: (n_of(table.nodes[lo_i].0), n_of(table.nodes[hi_i].0)),
            rho_s: rho_rec,
            rho_d: self.ratio * rho_rec,
            worst: w_rec,
            worst_interval,
            rho_s_box: (box_a, box_b),
        };
        // At the grid's edge: the box of the next coarse setting beyond the
        // recommendation would leave the grid, so a better setting may lie
        // outside it. (Not the edge of the refined region: the robust
        // optimum often lies at its low end, next to the cliff, where the
        // box of any lower setting reaches the cliff; the coarse search has
        // ruled out those settings. The former test, on the refined region,
        // fired there on the bundled batch at 40 grid points and not at 80.)
        let q = (rho_max / rho_min).powf(1.0 / self.steps.max(1) as f64);
        if box_a / q < rho_min || box_b * q > rho_max {
            warnings.push(crate::warning::Warning::RecommendationAtEdge);
        }
        let cliff = self.cliff(table, best, rho_rec, w_rec.amplitude1, warnings)?;
        Ok(Ok((recommendation, cliff)))
    }

    /// Why a box too wide (or unbounded) is not searched.
    fn no_box_reason(&self) -> NoRecommendation {
        let mu_words = self.mu_words.clone();
        let unresolved = self.unresolved;
        if self.fa <= 0.0 || !self.fb.is_finite() {
            NoRecommendation::Unbounded {
                mu_words,
                unresolved,
            }
        } else {
            NoRecommendation::BoxTooWide {
                mu_words,
                unresolved,
                factor: self.mu_s_interval.1 / self.mu_s_interval.0,
            }
        }
    }

    /// Stage 2: the region of good candidates (coarse robust value at the
    /// estimated ratio within 25 % of the best), over their whole boxes and
    /// one coarse step beyond, on the finer grid with every ratio.
    fn refine_region(
        &self,
        table: &mut Table<'_>,
    ) -> Result<Result<(), NoRecommendation>, SimError> {
        let (fa, fb) = (self.fa, self.fb);
        let (rho_min, rho_max, steps) = (self.rho_min, self.rho_max, self.steps);
        let coarse_rob: Vec<Option<f64>> = self
            .coarse
            .iter()
            .map(|r| table.robust(r * fa, r * fb, true))
            .collect();
        let Some(rmin) = coarse_rob.iter().flatten().copied().min_by(f64::total_cmp) else {
            return Ok(Err(NoRecommendation::NoBoxInGrid {
                rho_min,
                rho_max,
                mu_words: self.mu_words.clone(),
                setting_tolerance: self.opts.setting_tolerance,
            }));
        };
        let q = (rho_max / rho_min).powf(1.0 / steps as f64);
        let (fine_steps, factor) = if self.opts.refine {
            (steps * REFINE, REFINE)
        } else {
            (steps, 1)
        };
        let mut region: Vec<usize> = Vec::new();
        for (i, r) in coarse_rob.iter().enumerate() {
            if r.is_some_and(|v| v <= 1.25 * rmin) {
                let rho = self.coarse[i];
                let (a, b) = (rho * fa / q, rho * fb * q);
                let ka =
                    ((a / rho_min).ln() / (rho_max / rho_min).ln() * fine_steps as f64).floor();
                let kb = ((b / rho_min).ln() / (rho_max / rho_min).ln() * fine_steps as f64).ceil();
                let ka = ka.max(0.0) as usize;
                let kb = (kb.max(0.0) as usize).min(fine_steps);
                region.extend(ka..=kb);
            }
        }
        region.sort_unstable();
        region.dedup();
        let fine: Vec<f64> = region
            .iter()
            .map(|&k| {
                if k % factor == 0 {
                    self.coarse[k / factor]
                } else {
                    geom_node(rho_min, rho_max, fine_steps, k)
                }
            })
            .collect();
        table.add(&fine, true)?;
        Ok(Ok(()))
    }

    /// The cliff: the largest ρs below the recommendation (node `best`,
    /// ρs `rho_rec`, worst amplitude `w_rec`) with W > 2·W_rec, bisected on
    /// a log scale between the table's nodes.
    fn cliff(
        &self,
        table: &mut Table<'_>,
        best: usize,
        rho_rec: f64,
        w_rec: f64,
        warnings: &mut Vec<crate::warning::Warning>,
    ) -> Result<Option<Cliff>, SimError> {
        let threshold = 2.0 * w_rec;
        let Some(i) = (0..best).rev().find(|&i| table.w(i) > threshold) else {
            warnings.push(crate::warning::Warning::NoCliff {
                threshold,
                rho_min: self.rho_min,
            });
            return Ok(None);
        };
        let (mut bad, mut good) = (table.nodes[i].0, table.nodes[i + 1].0);
        let mut w_bad = table.nodes[i].1[0];
        for _ in 0..7 {
            let m = (bad * good).sqrt();
            let w = worst_case_on(
                &self.ab,
                self.shape,
                m,
                self.ratio * m,
                self.etas,
                &self.opts.steady,
            )?;
            table.evaluations += 1;
            table.periods += w.periods;
            (self.tick)(1);
            if w.amplitude1 > threshold {
                bad = m;
                w_bad = w;
            } else {
                good = m;
            }
        }
        let rho_c = (bad * good).sqrt();
        let n_of = self.n_of;
        Ok(Some(Cliff {
            rho_s: rho_c,
            bracket: (bad, good),
            normal_force_n: n_of(rho_c),
            threshold,
            worst_below: w_bad,
            margin_rho_s: rho_rec - rho_c,
            margin_n: n_of(rho_rec) - n_of(rho_c),
            margin_rel: rho_rec / rho_c - 1.0,
        }))
    }
}

/// The robust worst case of every node's box.
pub(super) fn robust_all(table: &Table<'_>, fa: f64, fb: f64) -> Vec<Option<f64>> {
    table
        .nodes
        .iter()
        .map(|(r, _)| table.robust(r * fa, r * fb, false))
        .collect()
}
