//! Families of curves, one per model and direction, run in parallel with
//! results identical for any thread count; shards of a family.

use super::*;
use crate::model::Model;
use crate::sim::engine::Init;
use crate::sim::SimError;

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
        .map_init(
            || None,
            |engine, &(c, p)| {
                let spec = &specs[c];
                match p {
                    Some(p) => {
                        let (v, _) =
                            steady_state_with(engine, &spec.model, etas[p], Init::rest(), cfg)?;
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
            },
        )
        .collect();
    let mut rows: Vec<Row> = parts?.into_iter().flatten().collect();
    rows.sort_by_key(|r| (r.curve, r.point));
    Ok(rows)
}
