//! The frequency-response family as `sweep --json` prints it (the
//! interface's `curves` keys plus details), as library types: one
//! [`SweepCurve`] per curve of a table of [`FrcRow`]s, in the table's
//! order, and the figure of a table's family. Serialised with serde, read
//! back with serde (`serde_json::from_str::<SweepJson>`).

use crate::report::plot::{FrcCurve, FrcFigure};
use crate::report::table::FrcRow;
use crate::sim::sweep::AmplitudeRange;
use serde::{Deserialize, Serialize};

/// The `sweep --json` object.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SweepJson {
    /// One entry per curve, in the table's order.
    pub curves: Vec<SweepCurve>,
    /// Wall time of the sweep (s).
    pub seconds: f64,
    /// Steady states computed (rows of the table).
    pub points: usize,
    /// Rows where another branch of the same model settles elsewhere.
    pub coexisting_points: usize,
    /// The shard `K/N` computed (`None`: the whole family).
    pub shard: Option<String>,
}

impl SweepJson {
    /// The object of a table computed in `seconds` (shard `shard`).
    pub fn of(table: &[FrcRow], seconds: f64, shard: Option<String>) -> Self {
        SweepJson {
            curves: curves(table),
            seconds,
            points: table.len(),
            coexisting_points: table.iter().filter(|r| r.coexisting).count(),
            shard,
        }
    }
}

/// One curve: the model of its first row, then one entry per point (in η
/// order). Amplitudes are A1/A and A2/A; `None` where no steady state was
/// found (then `amplitude*_min`/`_max` give the range of the per-period
/// amplitudes).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SweepCurve {
    /// ρs.
    pub rho_s: f64,
    /// ρd.
    pub rho_d: f64,
    /// D*.
    pub slope: f64,
    /// ρs⁻ of a direction-dependent law (absent when symmetric).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rho_s_minus: Option<f64>,
    /// ρd⁻ of a direction-dependent law (absent when symmetric).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rho_d_minus: Option<f64>,
    /// κ of a contact spring (absent for a rigid stick).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub contact_stiffness: Option<f64>,
    /// `up`, `down` or `rest`.
    pub direction: String,
    /// η of each point.
    pub eta: Vec<f64>,
    /// A1/A.
    pub amplitude1: Vec<Option<f64>>,
    /// A2/A.
    pub amplitude2: Vec<Option<f64>>,
    /// A periodic response was found.
    pub steady: Vec<bool>,
    /// n of a period-n response.
    pub period_multiple: Vec<Option<u32>>,
    /// Fraction of the period M2 sticks.
    pub stick_fraction: Vec<f64>,
    /// Interrupted by the paper's rule.
    pub interrupted: Vec<bool>,
    /// Another branch of the same model settles elsewhere at this η.
    pub coexisting: Vec<bool>,
    /// Smallest per-period A1/A where no steady state was found.
    pub amplitude1_min: Vec<Option<f64>>,
    /// Largest per-period A1/A where no steady state was found.
    pub amplitude1_max: Vec<Option<f64>>,
    /// Smallest per-period A2/A where no steady state was found.
    pub amplitude2_min: Vec<Option<f64>>,
    /// Largest per-period A2/A where no steady state was found.
    pub amplitude2_max: Vec<Option<f64>>,
    /// How each point was settled.
    pub method: Vec<String>,
}

/// The η axis of the figure of a table without rows.
pub const EMPTY_ETA_RANGE: (f64, f64) = (0.0, 2.0);

/// The curves of a table.
pub fn curves(table: &[FrcRow]) -> Vec<SweepCurve> {
    group(table)
        .into_iter()
        .map(|c| {
            let h = c[0];
            let all = |f: fn(&FrcRow) -> bool| c.iter().map(|r| f(r)).collect::<Vec<_>>();
            let range = |f: fn(&AmplitudeRange) -> f64| {
                c.iter()
                    .map(|r| r.range.as_ref().map(f))
                    .collect::<Vec<_>>()
            };
            SweepCurve {
                rho_s: h.rho_s,
                rho_d: h.rho_d,
                slope: h.slope,
                rho_s_minus: h.rho_s_minus,
                rho_d_minus: h.rho_d_minus,
                contact_stiffness: h.contact_stiffness,
                direction: h.direction.clone(),
                eta: c.iter().map(|r| r.eta).collect(),
                amplitude1: c.iter().map(|r| r.amplitude1).collect(),
                amplitude2: c.iter().map(|r| r.amplitude2).collect(),
                steady: all(|r| r.steady),
                period_multiple: c.iter().map(|r| r.period_multiple).collect(),
                stick_fraction: c.iter().map(|r| r.stick_fraction).collect(),
                interrupted: all(|r| r.interrupted),
                coexisting: all(|r| r.coexisting),
                amplitude1_min: range(|g| g.amplitude1_min),
                amplitude1_max: range(|g| g.amplitude1_max),
                amplitude2_min: range(|g| g.amplitude2_min),
                amplitude2_max: range(|g| g.amplitude2_max),
                method: c.iter().map(|r| r.method.clone()).collect(),
            }
        })
        .collect()
}

/// Groups table rows into curves (by `curve` index, rows in η order).
pub fn group(table: &[FrcRow]) -> Vec<Vec<&FrcRow>> {
    let mut out: Vec<Vec<&FrcRow>> = Vec::new();
    for r in table {
        match out.last_mut() {
            Some(c) if c[0].curve == r.curve => c.push(r),
            _ => out.push(vec![r]),
        }
    }
    out
}

/// The figure of a table's family.
pub fn figure(table: &[FrcRow], title: String) -> FrcFigure {
    let groups = group(table);
    let absorber = table
        .first()
        .map(|r| crate::model::Absorber {
            m: r.m,
            k: r.k,
            damping: r.damping,
        })
        .unwrap_or_default();
    let lo = table.iter().map(|r| r.eta).fold(f64::INFINITY, f64::min);
    let hi = table
        .iter()
        .map(|r| r.eta)
        .fold(f64::NEG_INFINITY, f64::max);
    let curves = groups
        .into_iter()
        .map(|c| {
            let h = c[0];
            let mut label = format!("ρs = {}", h.rho_s);
            if h.rho_d != h.rho_s && h.rho_s.is_finite() {
                label += &format!(", ρd = {}", h.rho_d);
            }
            if let (Some(s), Some(d)) = (h.rho_s_minus, h.rho_d_minus) {
                label += &format!("; ρs⁻ = {s}");
                if d != s {
                    label += &format!(", ρd⁻ = {d}");
                }
            }
            if let Some(kappa) = h.contact_stiffness {
                label += &format!("; κ = {kappa}");
            }
            if h.direction != "up" {
                label += &format!(" ({})", h.direction);
            }
            FrcCurve {
                label,
                eta: c.iter().map(|r| r.eta).collect(),
                a1: c.iter().map(|r| r.amplitude1).collect(),
                a2: c.iter().map(|r| r.amplitude2).collect(),
                coexisting: c.iter().map(|r| r.coexisting).collect(),
            }
        })
        .collect();
    FrcFigure {
        title,
        absorber,
        curves,
        // A shard without rows (a sharded family of fewer curves than
        // shards) has no η: the axes then span the paper's range.
        eta_range: if lo < hi {
            (lo, hi)
        } else if lo.is_finite() && lo > 0.0 {
            (lo * 0.9, lo * 1.1)
        } else {
            EMPTY_ETA_RANGE
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An empty table (a shard that holds no curve) gives no curve and a
    /// finite η axis (an infinite one hung the figure's drawing); the
    /// JSON object reads back as written.
    #[test]
    fn an_empty_table_has_a_drawable_figure_and_json() {
        let fig = figure(&[], "empty".into());
        assert!(fig.curves.is_empty());
        assert_eq!(fig.eta_range, EMPTY_ETA_RANGE);
        let j = SweepJson::of(&[], 0.5, Some("2/3".into()));
        let text = serde_json::to_string(&j).unwrap();
        assert_eq!(serde_json::from_str::<SweepJson>(&text).unwrap(), j);
        assert!(text.contains("\"curves\":[]"), "{text}");
    }
}
