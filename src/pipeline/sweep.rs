//! The `sweep` job: a family of frequency-response curves (one per model
//! and direction) over an η grid, in parallel, optionally one shard of it;
//! its table ([`FrcRow`]s, coexisting branches marked), written as a table
//! and a figure through the write transaction ([`crate::io::txn`]), and
//! its JSON object ([`SweepJson`]).

use super::Progress;
use crate::report::frc_json::{self, SweepJson};
use crate::report::plot;
use crate::report::table::{self, FrcRow};
use crate::sim::sweep::{self, CurveSpec, Shard, SteadyConfig};
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
