//! The `sweep` job: a family of frequency-response curves (one per model
//! and direction) over an η grid, in parallel, optionally one shard of it;
//! its table ([`FrcRow`]s, coexisting branches marked), written as a table
//! and a figure through the write transaction ([`crate::io::txn`]), and
//! its JSON object ([`SweepJson`]).
//!
//! A family is asked for as the `sweep` command describes it
//! ([`SweepRequest`]: a list of static thresholds, the dynamic level of
//! each, the continuation, the contact stiffnesses and the model's shape
//! ([`FamilySpec`]), an η range ([`EtaRange`]), a shard and the outputs);
//! [`SweepRequest::job`] checks it and lays out the curves
//! ([`FamilySpec::curves`]) as a [`SweepJob`].

use super::shape::ShapeSpec;
use super::Progress;
use crate::report::frc_json::{self, SweepJson};
use crate::report::plot;
use crate::report::table::{self, FrcRow};
use crate::sim::sweep::{self, CurveSpec, Direction, Shard, SteadyConfig};
use crate::sim::SimError;
use std::path::{Path, PathBuf};

/// One family (or one shard of it).
#[derive(Debug, Clone)]
pub struct SweepJob {
    /// The curves: one model and direction each.
    pub specs: Vec<CurveSpec>,
    /// The η grid every curve is computed on.
    pub etas: Vec<f64>,
    /// How each steady state is found.
    pub config: SteadyConfig,
    /// The slice of the family computed.
    pub shard: Shard,
    /// The shard as given (`K/N`), for the JSON object.
    pub shard_label: Option<String>,
    /// Write the table here (.parquet or .csv).
    pub out: Option<PathBuf>,
    /// Replace an `out` file that is not a sweep table.
    pub force: bool,
    /// Draw the family here (.svg or .png).
    pub plot: Option<PathBuf>,
    /// Title of the figure (default: from the first curve's law).
    pub title: Option<String>,
}

impl SweepJob {
    /// Steady states the job computes (its units of progress).
    pub fn steady_states(&self) -> u64 {
        self.specs.len() as u64 * self.etas.len() as u64 / self.shard.count as u64
    }
}

/// Parses a comma-separated list of static thresholds ρs (blanks around
/// each ignored; `inf`, `infinity` or `Inf`: always stuck).
pub fn parse_rho_list(s: &str) -> crate::Result<Vec<f64>> {
    s.split(',')
        .map(|t| {
            let t = t.trim();
            match t {
                "inf" | "infinity" | "Inf" => Ok(f64::INFINITY),
                _ => t
                    .parse::<f64>()
                    .map_err(|_| bad(format!("--rho-s: `{t}` is not a number"))),
            }
        })
        .collect()
}

/// The dynamic level ρd of each curve of a family.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum DynamicLevel {
    /// The model's default: ρd = ρs (0 where ρs = ∞).
    Default,
    /// The same ρd for every curve.
    Fixed(f64),
    /// ρd = R·ρs (the default where ρs = ∞); the paper's Fig. 5 uses 0.5.
    Ratio(f64),
}

impl DynamicLevel {
    /// From `--rho-d` and `--rho-d-ratio` (the command line gives at most
    /// one; a fixed level wins over a ratio).
    pub fn of(rho_d: Option<f64>, ratio: Option<f64>) -> Self {
        match (rho_d, ratio) {
            (Some(v), _) => DynamicLevel::Fixed(v),
            (None, Some(r)) => DynamicLevel::Ratio(r),
            (None, None) => DynamicLevel::Default,
        }
    }

    /// The dynamic level of the curve with static threshold `rho_s` (None:
    /// the model's default, [`ShapeSpec::model_with`]).
    pub fn at(self, rho_s: f64) -> Option<f64> {
        match self {
            DynamicLevel::Fixed(v) => Some(v),
            DynamicLevel::Ratio(r) if rho_s.is_finite() => Some(r * rho_s),
            _ => None,
        }
    }
}

/// How each curve's steady states follow one another along η.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Continuation {
    /// Increasing η, each from the previous steady state.
    Up,
    /// Decreasing η.
    Down,
    /// One curve each way.
    Both,
}

/// A family of curves: one per static threshold, contact stiffness and
/// direction, in that order.
#[derive(Debug, Clone, PartialEq)]
pub struct FamilySpec {
    /// The absorber and the law's shape (with the contact stiffnesses:
    /// one set of curves per value).
    pub shape: ShapeSpec,
    /// The static thresholds ρs, one set of curves each (∞: stuck).
    pub rho_s: Vec<f64>,
    /// The dynamic level of each curve.
    pub rho_d: DynamicLevel,
    /// The continuation (ignored where `from_rest`).
    pub continuation: Continuation,
    /// Start every η from rest instead of continuing.
    pub from_rest: bool,
}

impl FamilySpec {
    /// The directions each model is swept in.
    pub fn directions(&self) -> Vec<Direction> {
        if self.from_rest {
            return vec![Direction::Rest];
        }
        match self.continuation {
            Continuation::Up => vec![Direction::Up],
            Continuation::Down => vec![Direction::Down],
            Continuation::Both => vec![Direction::Up, Direction::Down],
        }
    }

    /// The family's curves, each model validated: one per ρs, contact
    /// stiffness and direction; a law with a velocity scale is marched by
    /// the numerical engine.
    pub fn curves(&self) -> crate::Result<Vec<CurveSpec>> {
        let directions = self.directions();
        let mut specs = Vec::new();
        for &rs in &self.rho_s {
            let rd = self.rho_d.at(rs);
            for kappa in self.shape.contact_stiffnesses() {
                let model = self.shape.model_with(rs, rd, kappa)?;
                for &d in &directions {
                    specs.push(CurveSpec {
                        model,
                        direction: d,
                    });
                }
            }
        }
        Ok(specs)
    }
}

/// The η grid of a family: `points` values from `min` to `max`, checked
/// (0 < min ≤ max, both finite).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EtaRange {
    min: f64,
    max: f64,
    points: usize,
}

impl EtaRange {
    /// The range, or the error naming `--eta-min` and `--eta-max`.
    pub fn new(min: f64, max: f64, points: usize) -> crate::Result<Self> {
        if !(min.is_finite() && min > 0.0 && max.is_finite() && max >= min) {
            return Err(bad("need 0 < --eta-min <= --eta-max".into()));
        }
        Ok(EtaRange { min, max, points })
    }

    /// The grid ([`sweep::eta_grid`]).
    pub fn grid(&self) -> Vec<f64> {
        sweep::eta_grid(self.min, self.max, self.points)
    }
}

/// A sweep as the `sweep` command asks for it; [`SweepRequest::job`]
/// checks it and gives the job.
#[derive(Debug, Clone, PartialEq)]
pub struct SweepRequest {
    /// The curves.
    pub family: FamilySpec,
    /// The η grid.
    pub etas: EtaRange,
    /// Period budget of the time-marching fallback per point.
    pub max_periods: u64,
    /// Stop quasi-periodic points early as `not-settling` (see
    /// [`SteadyConfig::early_stop`]).
    pub early_stop: bool,
    /// Compute slice K of N of the family (`K/N`, 1-based K).
    pub shard: Option<String>,
    /// Write the table here (.parquet or .csv).
    pub out: Option<PathBuf>,
    /// Replace an `out` file that is not a sweep table.
    pub force: bool,
    /// Draw the family here (.svg or .png).
    pub plot: Option<PathBuf>,
    /// Title of the figure (default: from the first curve's law).
    pub title: Option<String>,
}

impl SweepRequest {
    /// The job: `out` checked ([`refuse_replacing_other`]), the shard
    /// parsed ([`parse_shard`]) and the curves laid out
    /// ([`FamilySpec::curves`]), in that order.
    pub fn job(self) -> crate::Result<SweepJob> {
        if let Some(p) = &self.out {
            refuse_replacing_other(p, self.force)?;
        }
        let shard = match &self.shard {
            Some(s) => parse_shard(s)?,
            None => Shard::ALL,
        };
        Ok(SweepJob {
            specs: self.family.curves()?,
            etas: self.etas.grid(),
            config: SteadyConfig {
                max_periods: self.max_periods,
                early_stop: self.early_stop,
                ..SteadyConfig::default()
            },
            shard,
            shard_label: self.shard,
            out: self.out,
            force: self.force,
            plot: self.plot,
            title: self.title,
        })
    }
}

/// What [`run_sweep`] produced.
#[derive(Debug)]
pub struct SweepOutcome {
    /// The table, in curve and point order.
    pub table: Vec<FrcRow>,
    /// Wall seconds of the family.
    pub seconds: f64,
    /// The JSON object of the table.
    pub json: SweepJson,
    /// Curves of the family (the job's specs).
    pub curves: usize,
}

fn bad(msg: String) -> crate::Error {
    SimError::Unsupported(msg).into()
}

/// Refuses to replace an existing `out` file that is not a sweep table
/// (a rig log, say) unless `force`, as `synth` refuses to replace a log.
pub fn refuse_replacing_other(out: &Path, force: bool) -> crate::Result<()> {
    let exists = std::fs::metadata(out).is_ok_and(|m| m.is_file());
    if exists && !force && !table::is_sweep_table(out) {
        return Err(crate::Error::Input {
            path: out.to_path_buf(),
            msg: "exists and is not a sweep table (a rig log?): --out does not replace it without --force".into(),
        });
    }
    Ok(())
}

/// Parses `K/N` (1 ≤ K ≤ N).
pub fn parse_shard(s: &str) -> crate::Result<Shard> {
    let parts: Vec<&str> = s.split('/').collect();
    let nums: Option<(usize, usize)> = match parts.as_slice() {
        [a, b] => a.trim().parse().ok().zip(b.trim().parse().ok()),
        _ => None,
    };
    match nums {
        Some((_, n)) if n as u64 > crate::io::budget::MAX_FAMILY_POINTS => Err(bad(format!(
            "--shard {s}: {n} shards is more than there can be steady states in a family ({}); give N at most the number of work units",
            crate::io::budget::MAX_FAMILY_POINTS
        ))),
        Some((k, n)) if n >= 1 && (1..=n).contains(&k) => Ok(Shard {
            index: k - 1,
            count: n,
        }),
        _ => Err(bad(format!(
            "--shard must be K/N with 1 <= K <= N, got `{s}`"
        ))),
    }
}

/// The table rows of a family's steady states.
fn table_of(specs: &[CurveSpec], rows: &[sweep::Row]) -> Vec<FrcRow> {
    let mut table: Vec<FrcRow> = rows
        .iter()
        .map(|r| {
            let s = &specs[r.curve];
            let law = &s.model.law;
            let v = &r.value;
            FrcRow {
                curve: r.curve as u32,
                point: r.point as u32,
                m: s.model.absorber.m,
                k: s.model.absorber.k,
                damping: s.model.absorber.damping,
                rho_s: law.rho_s(),
                rho_d: law.rho_d(),
                slope: law.slope(),
                v_s: law.v_s(),
                stop_below: s.model.stop_below,
                rho_s_minus: law.minus().map(|l| l.rho_s),
                rho_d_minus: law.minus().map(|l| l.rho_d),
                contact_stiffness: s.model.contact_stiffness,
                direction: s.direction.as_str().to_string(),
                eta: v.eta,
                amplitude1: v.amplitude1,
                amplitude2: v.amplitude2,
                steady: v.steady,
                period_multiple: v.period_multiple,
                stick_fraction: v.stick_fraction,
                interrupted: v.interrupted,
                method: v.method.to_string(),
                periods: v.periods,
                coexisting: false,
                range: v.range,
            }
        })
        .collect();
    table::mark_coexisting(&mut table);
    table
}

/// Runs the family: checks `out` and the family's size against the
/// budget, computes every steady state of the shard (in parallel, one
/// [`Progress::advance`] each), and writes the table and the figure.
pub fn run_sweep(job: &SweepJob, progress: &dyn Progress) -> crate::Result<SweepOutcome> {
    if let Some(p) = &job.out {
        refuse_replacing_other(p, job.force)?;
    }
    crate::io::budget::check_family(
        job.specs.len() as u64,
        job.etas.len() as u64,
        job.shard.count as u64,
    )
    .map_err(|e| bad(e.to_string()))?;
    let start = std::time::Instant::now();
    let rows = sweep::family(&job.specs, &job.etas, &job.config, job.shard, &|n| {
        progress.advance(n)
    });
    progress.done();
    let rows = rows?;
    let seconds = start.elapsed().as_secs_f64();
    let table = table_of(&job.specs, &rows);
    if let Some(p) = &job.out {
        let meta = table::TableMeta {
            shard: job.shard.index + 1,
            shards: job.shard.count,
            curves: job.specs.len(),
            points: job.etas.len(),
        };
        table::write_frc(&table, &meta, p)?;
    }
    if let Some(p) = &job.plot {
        let title = job
            .title
            .clone()
            .unwrap_or_else(|| default_title(&job.specs));
        plot::frc(&frc_json::figure(&table, title), p)?;
    }
    let json = SweepJson::of(&table, seconds, job.shard_label.clone());
    Ok(SweepOutcome {
        table,
        seconds,
        json,
        curves: job.specs.len(),
    })
}

/// The figure's title: the first curve's law.
fn default_title(specs: &[CurveSpec]) -> String {
    match specs.first() {
        Some(s) => {
            let l = &s.model.law;
            let mut t = format!("Frequency response, {} friction", l.name());
            if l.slope() != 0.0 {
                t += &format!(", D* = {}", l.slope());
            }
            t
        }
        None => "Frequency response".into(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_family_without_clap() {
        let family = FamilySpec {
            shape: ShapeSpec {
                contact_stiffness: vec![2.0, f64::INFINITY],
                ..ShapeSpec::default()
            },
            rho_s: parse_rho_list("0.4, inf").unwrap(),
            rho_d: DynamicLevel::of(None, Some(0.5)),
            continuation: Continuation::Both,
            from_rest: false,
        };
        let job = SweepRequest {
            family,
            etas: EtaRange::new(0.5, 1.5, 3).unwrap(),
            max_periods: 100,
            early_stop: true,
            shard: Some("1/2".into()),
            out: None,
            force: false,
            plot: None,
            title: None,
        }
        .job()
        .unwrap();
        // ρs × κ × direction, in that order.
        assert_eq!(job.specs.len(), 8);
        let first = &job.specs[0];
        assert_eq!(first.model.law.rho_d(), 0.2);
        assert_eq!(first.model.contact_stiffness, Some(2.0));
        assert_eq!(job.specs[1].direction, Direction::Down);
        assert_eq!(job.specs[2].model.contact_stiffness, None);
        // ρs = ∞: the ratio does not apply, ρd is 0.
        assert_eq!(job.specs[4].model.law.rho_d(), 0.0);
        assert_eq!((job.etas.len(), job.shard.count), (3, 2));
        assert!(parse_rho_list("0.1,x").is_err());
        assert!(EtaRange::new(0.0, 1.0, 3).is_err());
    }
}
