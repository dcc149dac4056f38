//! The common time base: gap analysis per channel and resampling of every
//! channel onto one uniform grid.
//!
//! Rules (the same for every format):
//!
//! * Times are seconds from the log start: the earliest sample of any channel
//!   (MCAP), or the first row (tables; a column with a negative `shift_s`
//!   then has samples before 0).
//! * Within a channel, time must increase strictly; otherwise the log is refused.
//! * A *missing* stretch is where consecutive samples are more than 1.5
//!   nominal intervals apart (a lost DAQ buffer), or where a channel starts
//!   (ends) more than 1.5 intervals after (before) the log does. Every one
//!   is recorded as a [`Gap`] of kind [`GapKind::Missing`], whatever its length.
//! * A *dropout* is a run of null samples. Runs of more than
//!   [`MAX_BRIDGE_SAMPLES`] samples are recorded as gaps of kind
//!   [`GapKind::Dropout`]; shorter runs are only counted.
//! * Resampling interpolates linearly between two consecutive valid samples
//!   only if at most [`MAX_BRIDGE_SAMPLES`] samples are missing between them
//!   (nulls or lost time alike); everywhere else the grid holds NaN. No
//!   extrapolation beyond a channel's first or last valid sample.
//! * The grid runs from 0 at the rate of the fastest position channel up to
//!   the last position sample.

use super::delays::{self, ChannelDelays};
use super::{ContentError, IngestError, LogFormat, Quantity, RawChannel, RawLog, RigMeta};
use crate::warning::Warning;
use rayon::prelude::*;
use std::cmp::Ordering;
use std::path::{Path, PathBuf};

/// The longest run of missing samples that resampling bridges by linear
/// interpolation. At the slowest position rate of the rig (250 Hz) this is
/// 20 ms, far below a drive period (≥ 0.25 s at 4 Hz), so the interpolation
/// error stays at the level of a sample-to-sample change.
pub const MAX_BRIDGE_SAMPLES: usize = 5;

/// More grid rows than this many times the fastest position channel's sample
/// count mean inconsistent time stamps (guards against huge allocations).
const MAX_GRID_INFLATION: usize = 10;

/// What kind of hole a [`Gap`] is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GapKind {
    /// Samples absent from the log (a lost DAQ buffer, a late start, an early end).
    Missing,
    /// A run of more than [`MAX_BRIDGE_SAMPLES`] null samples.
    Dropout,
}

impl GapKind {
    /// The name used in JSON output.
    pub fn as_str(self) -> &'static str {
        match self {
            GapKind::Missing => "missing",
            GapKind::Dropout => "dropout",
        }
    }
}

/// A stretch of one channel without data. `start_s`/`end_s` are the last
/// valid sample before and the first valid sample after the hole (at the log
/// edges: the log start or end).
#[derive(Debug, Clone, PartialEq)]
pub struct Gap {
    /// Canonical channel name (`x1`, ...).
    pub channel: String,
    /// Start of the hole (s from log start).
    pub start_s: f64,
    /// End of the hole (s from log start).
    pub end_s: f64,
    /// What kind of hole.
    pub kind: GapKind,
}

/// A drive setpoint (sweeps).
#[derive(Debug, Clone, PartialEq)]
pub struct Setpoint {
    /// When it took effect (s from log start).
    pub t_s: f64,
    /// Commanded drive frequency (Hz).
    pub frequency_hz: f64,
    /// Commanded drive amplitude (m), where the log says.
    pub amplitude_m: Option<f64>,
}

/// One channel as recorded: original samples in SI.
#[derive(Debug, Clone)]
pub struct Channel {
    /// Which quantity.
    pub quantity: Quantity,
    /// Topic or column it came from.
    pub source: String,
    /// Nominal sample rate (Hz).
    pub rate_hz: f64,
    /// Sample times (s from log start), strictly increasing (shared by
    /// the channels of a table that were sampled together).
    pub t: Column,
    /// Values (SI), NaN where the sensor dropped out.
    pub v: Vec<f64>,
    /// Number of null (dropout) samples.
    pub dropouts: usize,
}

impl Channel {
    /// Canonical name.
    pub fn name(&self) -> &'static str {
        self.quantity.name()
    }
    /// SI unit.
    pub fn unit(&self) -> &'static str {
        self.quantity.unit()
    }
}

/// A grid column that later stages share instead of copying (the
/// contact force's times and positions at unit gain are these).
pub type Column = std::sync::Arc<[f64]>;

/// All channels on one uniform time base (NaN where there is no data).
#[derive(Debug, Clone)]
pub struct Resampled {
    /// Grid rate (Hz).
    pub rate_hz: f64,
    /// Grid times (s from log start): `i / rate_hz`.
    pub t: Column,
    /// Drive displacement x0 (m).
    pub x0: Vec<f64>,
    /// Main mass displacement x1 (m).
    pub x1: Column,
    /// Absorber mass displacement x2 (m).
    pub x2: Column,
    /// Absorber mass velocity (m/s); all NaN when the log has no velocity
    /// channel ([`Run::has_velocity`]).
    pub v2: Vec<f64>,
    /// Absorber mass acceleration (m/s²), if recorded.
    pub a2: Option<Vec<f64>>,
    /// Normal force (N), if recorded.
    pub normal_force: Option<Vec<f64>>,
    /// Commanded frequency (Hz) in force at each row, if the log has setpoints.
    pub setpoint_hz: Option<Vec<f64>>,
}

impl Resampled {
    /// The column of a quantity, if present.
    pub fn column(&self, q: Quantity) -> Option<&[f64]> {
        match q {
            Quantity::X0 => Some(&self.x0),
            Quantity::X1 => Some(&self.x1),
            Quantity::X2 => Some(&self.x2),
            Quantity::V2 => Some(&self.v2),
            Quantity::A2 => self.a2.as_deref(),
            Quantity::NormalForce => self.normal_force.as_deref(),
        }
    }

    /// Number of rows.
    pub fn len(&self) -> usize {
        self.t.len()
    }

    /// Whether the grid has no rows.
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    /// Time covered by the rows: rows / rate (s).
    pub fn duration_s(&self) -> f64 {
        self.t.len() as f64 / self.rate_hz
    }
}

/// One clean run: the rig, every channel as recorded, the common time base,
/// gaps, setpoints and warnings.
#[derive(Debug, Clone)]
pub struct Run {
    /// The log it came from.
    pub source: PathBuf,
    /// The log's format.
    pub format: LogFormat,
    /// Rig metadata (SI).
    pub rig: RigMeta,
    /// Channels as recorded, in [`Quantity::ALL`] order.
    pub channels: Vec<Channel>,
    /// Whether an accelerometer channel was recorded.
    pub has_acceleration: bool,
    /// Drive setpoints, in time order.
    pub setpoints: Vec<Setpoint>,
    /// The common time base.
    pub resampled: Resampled,
    /// Every stretch without data, by channel then time.
    pub gaps: Vec<Gap>,
    /// Things the user should know that did not stop the ingest.
    pub warnings: Vec<Warning>,
    /// Channel delays against x1 (declared, estimated, applied) and the
    /// velocity channel's consistency with x2 (see `delays`).
    pub delays: ChannelDelays,
}

impl Run {
    /// Whether the log has a velocity channel (v2 is optional).
    pub fn has_velocity(&self) -> bool {
        self.resampled.v2.iter().any(|v| v.is_finite())
    }
    /// The recorded channel of a quantity.
    pub fn channel(&self, q: Quantity) -> Option<&Channel> {
        self.channels.iter().find(|c| c.quantity == q)
    }

    /// The gaps of one channel, in time order.
    pub fn gaps_of(&self, q: Quantity) -> impl Iterator<Item = &Gap> {
        self.gaps.iter().filter(move |g| g.channel == q.name())
    }

    /// Rows of the canonical run.
    pub fn samples(&self) -> usize {
        self.resampled.len()
    }

    /// Duration of the canonical run (s).
    pub fn duration_s(&self) -> f64 {
        self.resampled.duration_s()
    }
}

/// Builds the [`Run`] from what a format reader delivered.
pub(crate) fn build(path: &Path, raw: RawLog) -> Result<Run, IngestError> {
    let RawLog {
        format,
        rig,
        channels,
        origin,
        mut setpoints,
        mut warnings,
        declared_shifts,
    } = raw;
    let checked = check_channels(path, channels, &mut warnings)?;
    let (channels, dropouts): (Vec<RawChannel>, Vec<usize>) = checked.into_iter().unzip();
    note_missing(path, format, &channels, &mut warnings)?;
    // Log start and end over all channels.
    let origin = origin.unwrap_or_else(|| {
        channels
            .iter()
            .filter_map(|c| c.t.first().copied())
            .fold(f64::INFINITY, f64::min)
    });
    let log_end = channels
        .iter()
        .filter_map(|c| c.t.last().copied())
        .fold(f64::NEG_INFINITY, f64::max)
        - origin;
    // Channels are independent: analysed in parallel, gaps kept in channel
    // order (identical whatever the thread count).
    let analysed: Vec<(Channel, Vec<Gap>)> = channels
        .into_par_iter()
        .zip(dropouts)
        .map(|(c, dropouts)| {
            let mut t = c.t;
            // x - (+0.0) == x for every x: an MCAP log's times already
            // start at +0.0, so they skip this pass (and a table's shared
            // times stay shared).
            if origin.to_bits() != 0 {
                for x in std::sync::Arc::make_mut(&mut t).iter_mut() {
                    *x -= origin;
                }
            }
            let mut gaps = Vec::new();
            find_gaps(c.quantity, &t, &c.v, c.dt_s, log_end, &mut gaps);
            let channel = Channel {
                quantity: c.quantity,
                source: c.source,
                rate_hz: 1.0 / c.dt_s,
                t,
                v: c.v,
                dropouts,
            };
            (channel, gaps)
        })
        .collect();
    let mut out_channels = Vec::with_capacity(analysed.len());
    let mut gaps = Vec::new();
    for (c, g) in analysed {
        out_channels.push(c);
        gaps.extend(g);
    }
    for s in &mut setpoints {
        s.t_s -= origin;
    }
    setpoints.sort_by(|a, b| a.t_s.total_cmp(&b.t_s));
    // Saturated runs are blanked before anything reads the channels: a
    // rail value taken for a measurement biases the delay estimation.
    let clipped = super::clip::mark(&mut out_channels);
    let mut resampled = resample(path, &out_channels, &setpoints)?;
    super::clip::blank_grid(&out_channels, &clipped, &mut resampled);
    let delays = align_channels(
        path,
        &rig,
        (&mut out_channels, &mut gaps, &setpoints),
        &mut resampled,
        &declared_shifts,
        &mut warnings,
    )?;
    super::clip::blank_grid(&out_channels, &clipped, &mut resampled);
    let has_acceleration = resampled.a2.is_some();
    for c in &out_channels {
        let bad = c.dropouts;
        if bad * 20 > c.v.len() {
            warnings.push(Warning::ChannelNulls {
                channel: c.name(),
                nulls: bad,
                samples: c.v.len(),
            });
        }
    }
    warnings.extend(clipped.iter().map(|(_, cl)| cl.warning()));
    Ok(Run {
        source: path.to_path_buf(),
        format,
        rig,
        channels: out_channels,
        has_acceleration,
        setpoints,
        resampled,
        gaps,
        warnings,
        delays,
    })
}

/// Estimates the channel delays and the velocity's drift and gain on the
/// common grid, applies what matters (re-stamps the channels and their
/// gaps, removes the drift from v2's samples, divides v2 and a2 by a gain
/// off 1) and rebuilds the grid if anything changed. Returns the report
/// (see `delays`).
fn align_channels(
    path: &Path,
    rig: &RigMeta,
    (channels, gaps, setpoints): (&mut [Channel], &mut [Gap], &[Setpoint]),
    resampled: &mut Resampled,
    declared: &[(Quantity, f64)],
    warnings: &mut Vec<Warning>,
) -> Result<ChannelDelays, IngestError> {
    if resampled.len() < 100 {
        return Ok(ChannelDelays::default());
    }
    let est = delays::estimate(resampled, rig);
    let tm = resampled.t[resampled.len() / 2];
    let mut changed = false;
    if let Some(v) = est.velocity.filter(|v| v.drift_corrected) {
        if let Some(c) = channels.iter_mut().find(|c| c.quantity == Quantity::V2) {
            for (x, t) in c.v.iter_mut().zip(c.t.iter()) {
                *x -= v.drift_m_per_s2 * (t - tm);
            }
            changed = true;
        }
    }
    let gains = [
        (
            Quantity::V2,
            est.velocity.filter(|v| v.gain_corrected).map(|v| v.gain),
        ),
        (
            Quantity::A2,
            est.acceleration
                .filter(|a| a.gain_corrected)
                .map(|a| a.gain),
        ),
    ];
    for (q, gain) in gains {
        let Some(g) = gain else { continue };
        if let Some(c) = channels.iter_mut().find(|c| c.quantity == q) {
            for x in c.v.iter_mut() {
                *x /= g;
            }
            changed = true;
        }
    }
    for &(q, s) in &est.applied {
        if s == 0.0 {
            continue;
        }
        if let Some(c) = channels.iter_mut().find(|c| c.quantity == q) {
            for t in std::sync::Arc::make_mut(&mut c.t).iter_mut() {
                *t += s;
            }
            changed = true;
        }
        for g in gaps.iter_mut().filter(|g| g.channel == q.name()) {
            g.start_s += s;
            g.end_s += s;
        }
    }
    if changed {
        *resampled = resample(path, channels, setpoints)?;
    }
    let report = est.report(declared);
    warnings.extend(est.warnings.iter().cloned());
    warnings.extend(delays::shift_warnings(&report, 1.0 / resampled.rate_hz));
    Ok(report)
}

/// The channels sorted by quantity, each checked: one channel per
/// quantity, data present, time finite and increasing, a sane rate. An
/// optional channel without a valid sample is dropped (with a warning).
/// Each kept channel comes with its number of null (NaN) samples.
fn check_channels(
    path: &Path,
    mut channels: Vec<RawChannel>,
    warnings: &mut Vec<Warning>,
) -> Result<Vec<(RawChannel, usize)>, IngestError> {
    channels.sort_by_key(|c| c.quantity);
    for w in channels.windows(2) {
        if w[0].quantity == w[1].quantity {
            return Err(IngestError::content(
                path,
                ContentError::DuplicateQuantity {
                    quantity: w[0].quantity.name(),
                    first: w[0].source.to_string(),
                    second: w[1].source.to_string(),
                },
            ));
        }
    }
    let mut kept = Vec::with_capacity(channels.len());
    for c in channels {
        let label = channel_label(&c);
        if c.t.len() != c.v.len() {
            return Err(IngestError::content(
                path,
                ContentError::LengthMismatch { channel: label },
            ));
        }
        if !(c.dt_s.is_finite() && c.dt_s > 0.0) {
            return Err(IngestError::content(
                path,
                ContentError::NoSampleInterval { channel: label },
            ));
        }
        // The usual case in one counting pass each (no early exit, so the
        // compiler vectorises them); the exact first offender only if
        // there is one.
        if !strictly_increasing_finite(&c.t) {
            if let Some(i) = c.t.iter().position(|t| !t.is_finite()) {
                return Err(IngestError::content(
                    path,
                    ContentError::InvalidTime {
                        channel: label,
                        sample: i,
                    },
                ));
            }
            if let Some(i) = c.t.windows(2).position(|w| w[1] <= w[0]) {
                return Err(IngestError::content(
                    path,
                    ContentError::NonMonotonicTime {
                        channel: label,
                        sample: i + 1,
                        t_s: c.t[i + 1],
                        previous_s: c.t[i],
                    },
                ));
            }
        }
        let (valid, infinite) = count_finite_infinite(&c.v);
        if infinite > 0 {
            let i = c.v.iter().position(|v| v.is_infinite()).unwrap_or(0);
            return Err(IngestError::content(
                path,
                ContentError::InfiniteSample {
                    channel: label,
                    sample: i,
                },
            ));
        }
        if valid == 0 {
            if c.quantity.required() {
                return Err(IngestError::content(
                    path,
                    ContentError::NoValidSample { channel: label },
                ));
            }
            warnings.push(Warning::ChannelEmpty { label });
            continue;
        }
        // Neither finite nor infinite: NaN, a dropout.
        let dropouts = c.v.len() - valid;
        kept.push((c, dropouts));
    }
    Ok(kept)
}

/// Whether every time is finite and each follows the one before (the
/// checks of `check_channels`, without locating the offender). Strictly
/// increasing comparisons are false for NaN, and they leave room for an
/// infinity only at the ends.
fn strictly_increasing_finite(t: &[f64]) -> bool {
    let (Some(first), Some(last)) = (t.first(), t.last()) else {
        return true;
    };
    let after = t
        .iter()
        .zip(&t[1..])
        .fold(0usize, |n, (a, b)| n + usize::from(b > a));
    after == t.len() - 1 && first.is_finite() && last.is_finite()
}

/// How many of `v` are finite, and how many infinite (one pass).
fn count_finite_infinite(v: &[f64]) -> (usize, usize) {
    // Every value is finite, infinite or NaN: two counts give the third.
    let (nan, infinite) = v.iter().fold((0, 0), |(nan, infinite), x| {
        (
            nan + usize::from(x.is_nan()),
            infinite + usize::from(x.abs() == f64::INFINITY),
        )
    });
    (v.len() - nan - infinite, infinite)
}

/// Refuses a log without a required channel; warns of each optional one
/// that is absent.
fn note_missing(
    path: &Path,
    format: LogFormat,
    channels: &[RawChannel],
    warnings: &mut Vec<Warning>,
) -> Result<(), IngestError> {
    for q in Quantity::ALL {
        if channels.iter().any(|c| c.quantity == q) {
            continue;
        }
        if q.required() {
            return Err(IngestError::content(
                path,
                ContentError::MissingChannel {
                    quantity: q.name(),
                    source_name: match format {
                        LogFormat::Mcap => q.topic(),
                        _ => q.name(),
                    },
                },
            ));
        }
        match q {
            Quantity::A2 => warnings.push(Warning::NoAccelerometer),
            Quantity::V2 => warnings.push(Warning::NoVelocityChannel),
            _ => warnings.push(Warning::ChannelAbsent { channel: q.name() }),
        }
    }
    Ok(())
}

/// The channels on one common grid: the rate of the fastest position
/// channel, up to the last position sample. Refuses time stamps that would
/// inflate the grid far beyond the samples held.
fn resample(
    path: &Path,
    channels: &[Channel],
    setpoints: &[Setpoint],
) -> Result<Resampled, IngestError> {
    let positions = || channels.iter().filter(|c| c.quantity.is_position());
    let rate_hz = positions().map(|c| c.rate_hz).fold(0.0, f64::max);
    let pos_end = positions()
        .filter_map(|c| c.t.last().copied())
        .fold(0.0, f64::max);
    let most_samples = positions().map(|c| c.t.len()).max().unwrap_or(0);
    let rows_f = (pos_end * rate_hz + 1e-6).floor() + 1.0;
    if !rows_f.is_finite() || rows_f > (MAX_GRID_INFLATION * most_samples.max(1000)) as f64 {
        return Err(IngestError::content(
            path,
            ContentError::InconsistentTimes {
                span_s: pos_end,
                samples: most_samples,
                rate_hz,
            },
        ));
    }
    let rows = rows_f as usize;
    let grid: Vec<f64> = (0..rows).map(|i| i as f64 / rate_hz).collect();
    let resample = |q: Quantity| -> Option<Vec<f64>> {
        channels
            .iter()
            .find(|c| c.quantity == q)
            .map(|c| interpolate(&c.t, &c.v, 1.0 / c.rate_hz, &grid))
    };
    // Columns are independent: interpolated in parallel, each by the same
    // sequential code (identical whatever the thread count).
    let mut cols: Vec<Option<Vec<f64>>> = Quantity::ALL.par_iter().map(|&q| resample(q)).collect();
    let mut take = |q: Quantity| {
        let k = Quantity::ALL.iter().position(|&p| p == q)?;
        cols[k].take()
    };
    let mut col = |q: Quantity| take(q).unwrap_or_else(|| vec![f64::NAN; rows]);
    let (x0, x1, x2, v2) = (
        col(Quantity::X0),
        col(Quantity::X1),
        col(Quantity::X2),
        col(Quantity::V2),
    );
    let setpoint_hz = if setpoints.is_empty() {
        None
    } else {
        Some(step_function(setpoints, &grid))
    };
    Ok(Resampled {
        rate_hz,
        x0,
        x1: x1.into(),
        x2: x2.into(),
        v2,
        a2: take(Quantity::A2),
        normal_force: take(Quantity::NormalForce),
        setpoint_hz,
        t: grid.into(),
    })
}

fn channel_label(c: &RawChannel) -> String {
    if c.source == c.quantity.name() {
        c.source.clone()
    } else {
        format!("{} ({})", c.source, c.quantity.name())
    }
}

/// Number of samples missing between two samples `span` apart.
#[cfg(test)]
fn missing_between(span: f64, dt: f64) -> usize {
    let n = (span / dt).round() - 1.0;
    if n <= 0.0 {
        0
    } else if n >= usize::MAX as f64 {
        usize::MAX
    } else {
        n as usize
    }
}

/// Samples [`find_gaps`] checks at once for the usual case (all valid, on
/// time).
const GAP_BLOCK: usize = 64;

/// Appends the gaps of one channel (times from log start) to `gaps`.
fn find_gaps(q: Quantity, t: &[f64], v: &[f64], dt: f64, log_end: f64, gaps: &mut Vec<Gap>) {
    let name = q.name();
    let mut push = |start_s: f64, end_s: f64, kind: GapKind| {
        gaps.push(Gap {
            channel: name.to_string(),
            start_s,
            end_s,
            kind,
        })
    };
    let Some(first) = v.iter().position(|x| x.is_finite()) else {
        return;
    };
    let last = v.iter().rposition(|x| x.is_finite()).unwrap_or(first);
    let late = |a: f64, b: f64| b - a > 1.5 * dt;
    // Leading edge.
    if late(0.0, t[0]) {
        push(0.0, t[first], GapKind::Missing);
    } else if first > MAX_BRIDGE_SAMPLES {
        push(0.0_f64.max(t[0]), t[first], GapKind::Dropout);
    }
    // Interior: between consecutive valid samples. Blocks of samples that
    // are all valid and on time (the usual case) are passed by one
    // branch-free test each; the others sample by sample.
    let mut a = first;
    let mut from = first + 1;
    while from <= last {
        let to = (from + GAP_BLOCK).min(last + 1);
        if a + 1 == from {
            let on_time = t[from - 1..to - 1]
                .iter()
                .zip(&t[from..to])
                .zip(&v[from..to])
                .fold(true, |ok, ((&t0, &t1), x)| {
                    ok & x.is_finite() & !late(t0, t1)
                });
            if on_time {
                a = to - 1;
                from = to;
                continue;
            }
        }
        for b in from..to {
            if !v[b].is_finite() {
                continue;
            }
            if b == a + 1 {
                if late(t[a], t[b]) {
                    push(t[a], t[b], GapKind::Missing);
                }
            } else {
                let lost_time = (a..b).any(|i| late(t[i], t[i + 1]));
                if lost_time {
                    push(t[a], t[b], GapKind::Missing);
                } else if b - a - 1 > MAX_BRIDGE_SAMPLES {
                    push(t[a], t[b], GapKind::Dropout);
                }
            }
            a = b;
        }
        from = to;
    }
    // Trailing edge.
    let n = t.len();
    if late(t[n - 1], log_end) {
        push(t[last], log_end, GapKind::Missing);
    } else if n - 1 - last > MAX_BRIDGE_SAMPLES {
        push(t[last], t[n - 1], GapKind::Dropout);
    }
}

/// Linear interpolation of (t, v) onto `grid` (non-decreasing), bridging
/// holes of at most [`MAX_BRIDGE_SAMPLES`] missing samples only; NaN
/// elsewhere.
///
/// One pass over the rows. The bracketing valid samples `a` and `b` and
/// whether the hole between them is bridged are kept in locals, updated as
/// `b` is passed; past the last valid sample, `b`'s time is +inf (never
/// passed) and nothing is bridged. The loops make no calls (the search for
/// the next valid sample and the bridging test are inline, and the latter
/// needs no rounding call), so the whole state, `eps` and `quick` stay in
/// registers.
pub(crate) fn interpolate(t: &[f64], v: &[f64], dt: f64, grid: &[f64]) -> Vec<f64> {
    let n = t.len().min(v.len());
    let (t, v) = (&t[..n], &v[..n]);
    let Some(first) = v.iter().position(|x| x.is_finite()) else {
        return vec![f64::NAN; grid.len()];
    };
    let mut out = vec![0.0; grid.len()];
    // Grid points this close to a sample take its value (float noise only).
    let eps = dt * 1e-6;
    let start = t[first] - eps;
    // Spans up to `quick` are below 1.5 intervals for certain, whatever
    // the rounding of `span / dt` (dt normal: relative errors ~1e-16).
    let quick = if dt >= f64::MIN_POSITIVE {
        1.25 * dt
    } else {
        0.0
    };
    // Rows before the first valid sample: a prefix (the grid does not
    // decrease).
    let lead = grid.iter().take_while(|&&g| g < start).count();
    out[..lead].fill(f64::NAN);
    let (grid, rows) = (&grid[lead..], &mut out[lead..]);
    let (mut ta, mut va) = (t[first], v[first]);
    let (mut b, mut tb, mut vb) = valid_after(t, v, first);
    let mut bridged = b < n && bridges(tb - ta, quick, dt);
    for (&g, o) in grid.iter().zip(rows.iter_mut()) {
        // Pass every valid sample at or before this row's time (+ eps).
        let ge = g + eps;
        while tb <= ge {
            (ta, va) = (tb, vb);
            match (t.get(b + 1), v.get(b + 1)) {
                // The usual case: the next sample is valid and close.
                (Some(&tn), Some(&x)) if x.is_finite() && tn - tb <= quick => {
                    (b, tb, vb) = (b + 1, tn, x);
                    bridged = true;
                }
                _ => {
                    (b, tb, vb) = valid_after(t, v, b);
                    bridged = b < n && bridges(tb - ta, quick, dt);
                }
            }
        }
        *o = if (g - ta).abs() <= eps {
            va
        } else if bridged {
            let w = (g - ta) / (tb - ta);
            va + w * (vb - va)
        } else {
            f64::NAN // a hole too long, or past the last valid sample
        };
    }
    out
}

/// Whether the hole between valid samples `span` apart is bridged: under
/// 1.5 intervals nothing is missing; otherwise `round(span / dt) - 1`
/// samples are, at most [`MAX_BRIDGE_SAMPLES`] of them while `span / dt`
/// is below `MAX_BRIDGE_SAMPLES + 1.5` (round halves away from zero). A NaN
/// ratio counted as 0 missing (`NaN as usize`): bridged.
/// Spans up to `quick` (1.25 `dt`) need no division.
#[inline(always)]
fn bridges(span: f64, quick: f64, dt: f64) -> bool {
    const LIMIT: f64 = MAX_BRIDGE_SAMPLES as f64 + 1.5;
    span <= quick || {
        let r = span / dt;
        r < LIMIT || r.is_nan()
    }
}

/// The first valid sample after `k` as (index, time, value), or
/// (`v.len()`, +inf, NaN) if there is none.
#[inline(always)]
fn valid_after(t: &[f64], v: &[f64], k: usize) -> (usize, f64, f64) {
    match v.iter().skip(k + 1).position(|x| x.is_finite()) {
        Some(i) => (k + 1 + i, t[k + 1 + i], v[k + 1 + i]),
        None => (v.len(), f64::INFINITY, f64::NAN),
    }
}

/// The setpoint frequency in force at each grid time (NaN before the first).
///
/// Setpoint by setpoint: the rows before setpoint `j` takes effect (the
/// run of rows where `t_s <= g` fails) hold the frequency of `j - 1`, and
/// are filled at once; the last setpoint holds for the rows left.
fn step_function(setpoints: &[Setpoint], grid: &[f64]) -> Vec<f64> {
    let mut out = Vec::with_capacity(grid.len());
    let mut row = 0;
    for j in 0..=setpoints.len() {
        let value = match j.checked_sub(1) {
            Some(k) => setpoints[k].frequency_hz,
            None => f64::NAN,
        };
        let rows = match setpoints.get(j) {
            Some(s) => grid[row..]
                .iter()
                .take_while(|&&g| {
                    !matches!(
                        s.t_s.partial_cmp(&g),
                        Some(Ordering::Less | Ordering::Equal)
                    )
                })
                .count(),
            None => grid.len() - row,
        };
        out.resize(row + rows, value);
        row += rows;
    }
    out
}

/// Nominal sample interval from sample times: the median spacing, with the
/// rate rounded to 9 significant digits (time columns written in decimal
/// carry float noise that would otherwise show as 1000.0000000001 Hz).
pub(crate) fn median_interval(t: &[f64]) -> Option<f64> {
    let steps: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
    let dt = crate::stats::median(&steps);
    if !(dt.is_finite() && dt > 0.0) {
        return None;
    }
    let rate = 1.0 / dt;
    let scale = 10f64.powi(8 - rate.log10().floor() as i32);
    let rounded = (rate * scale).round() / scale;
    Some(if rounded > 0.0 { 1.0 / rounded } else { dt })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The previous [`interpolate`] (reference for tests).
    /// Linear interpolation of (t, v) onto `grid`, bridging holes of at most
    /// [`MAX_BRIDGE_SAMPLES`] missing samples only; NaN elsewhere.
    fn interpolate_reference(t: &[f64], v: &[f64], dt: f64, grid: &[f64]) -> Vec<f64> {
        // One pass writing each row once (no NaN fill first); the samples
        // around the current row are kept in locals.
        let mut out = Vec::with_capacity(grid.len());
        let n = t.len().min(v.len());
        let (t, v) = (&t[..n], &v[..n]);
        let next_valid = |from: usize| (from..n).find(|&i| v[i].is_finite());
        let Some(first) = next_valid(0) else {
            out.resize(grid.len(), f64::NAN);
            return out;
        };
        // Grid points this close to a sample take its value (float noise only).
        let eps = dt * 1e-6;
        let start = t[first] - eps;
        // `a`: the last valid sample <= g; `b`: the next valid sample, if any;
        // `bridged`: whether the hole between them is short enough (cached).
        let (mut ta, mut va) = (t[first], v[first]);
        let mut b = next_valid(first + 1);
        let mut bridged: Option<bool> = None;
        for &g in grid {
            if g < start {
                out.push(f64::NAN);
                continue;
            }
            while let Some(nb) = b {
                if t[nb] > g + eps {
                    break;
                }
                (ta, va) = (t[nb], v[nb]);
                b = next_valid(nb + 1);
                bridged = None;
            }
            if (g - ta).abs() <= eps {
                out.push(va);
                continue;
            }
            let Some(b) = b else {
                out.push(f64::NAN); // past the last valid sample
                continue;
            };
            let (tb, vb) = (t[b], v[b]);
            let bridged = *bridged.get_or_insert_with(|| {
                let span = tb - ta;
                // Under 1.5 intervals apart nothing is missing (the usual case;
                // spares `missing_between` its rounding).
                span / dt < 1.5 || missing_between(span, dt) <= MAX_BRIDGE_SAMPLES
            });
            if !bridged {
                out.push(f64::NAN);
                continue;
            }
            let w = (g - ta) / (tb - ta);
            out.push(va + w * (vb - va));
        }
        out
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(3000))]
        /// The interpolation is bit-identical to the previous one: jittered
        /// times, lost stretches, null runs, grids finer and coarser than
        /// the samples, starting before and after them.
        #[test]
        fn interpolation_matches_the_previous_one(
            steps in proptest::collection::vec((0.9f64..1.1, 0u8..14, 0u8..10), 0..120),
            dt in 1e-4f64..0.1,
            offset in -5.0f64..5.0,
            grid_step in 0.2f64..3.0,
            rows in 0usize..300,
        ) {
            let (mut t, mut v) = (Vec::new(), Vec::new());
            let mut now = offset * dt;
            for (k, &(jitter, lost, null)) in steps.iter().enumerate() {
                // Now and then exactly one interval (grid points on
                // samples), 1.25 to 1.5 intervals, or a lost stretch of 4,
                // 9 or 16 intervals (bridged or not).
                now += match lost {
                    0 => dt,
                    9 => dt * (1.25 + 0.25 * (jitter - 0.9) * 5.0),
                    10.. => dt * f64::from(lost - 9).powi(2),
                    _ => dt * jitter,
                };
                t.push(now);
                v.push(if null < 2 { f64::NAN } else { (k as f64 * 0.37).sin() });
            }
            let grid: Vec<f64> = (0..rows).map(|i| i as f64 / (1.0 / (dt * grid_step))).collect();
            let bits = |x: Vec<f64>| x.into_iter().map(f64::to_bits).collect::<Vec<_>>();
            proptest::prop_assert_eq!(
                bits(interpolate(&t, &v, dt, &grid)),
                bits(interpolate_reference(&t, &v, dt, &grid))
            );
        }
    }

    /// The previous bridging test (reference): count the missing samples.
    fn bridges_reference(span: f64, quick: f64, dt: f64) -> bool {
        span <= quick || span / dt < 1.5 || missing_between(span, dt) <= MAX_BRIDGE_SAMPLES
    }

    /// The bridging test without rounding agrees with counting the missing
    /// samples, around every boundary (±1 ulp) and for odd inputs.
    #[test]
    fn bridges_agrees_with_counting_the_missing_samples() {
        let dts = [
            1e-3,
            2e-3,
            4e-3,
            0.1,
            1.0,
            3.0,
            f64::MIN_POSITIVE,
            5e-324,
            1e300,
            f64::INFINITY,
            f64::NAN,
            0.0,
            -1e-3,
        ];
        let near = |x: f64| {
            let b = x.to_bits();
            [
                x,
                f64::from_bits(b.wrapping_add(1)),
                f64::from_bits(b.wrapping_sub(1)),
            ]
        };
        for dt in dts {
            let quick = if dt >= f64::MIN_POSITIVE {
                1.25 * dt
            } else {
                0.0
            };
            let mut spans = vec![
                0.0,
                -0.0,
                -1.0,
                1.0,
                f64::INFINITY,
                f64::NEG_INFINITY,
                f64::NAN,
                1e300,
                5e-324,
            ];
            for r in [
                1.0, 1.25, 1.5, 2.0, 5.5, 6.0, 6.25, 6.5, 6.75, 7.0, 7.5, 1e20,
            ] {
                spans.extend(near(r * dt));
                spans.extend(near(r).map(|r| r * dt));
            }
            for span in spans {
                assert_eq!(
                    bridges(span, quick, dt),
                    bridges_reference(span, quick, dt),
                    "span {span:e}, dt {dt:e}"
                );
            }
        }
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(3000))]
        #[test]
        fn bridges_matches_the_reference(r in 0.0f64..10.0, dt in 1e-6f64..10.0) {
            let quick = 1.25 * dt;
            let span = r * dt;
            proptest::prop_assert_eq!(bridges(span, quick, dt), bridges_reference(span, quick, dt));
        }
    }

    /// The previous sample-by-sample [`find_gaps`] (reference for tests).
    /// Appends the gaps of one channel (times from log start) to `gaps`.
    fn find_gaps_reference(
        q: Quantity,
        t: &[f64],
        v: &[f64],
        dt: f64,
        log_end: f64,
        gaps: &mut Vec<Gap>,
    ) {
        let name = q.name();
        let mut push = |start_s: f64, end_s: f64, kind: GapKind| {
            gaps.push(Gap {
                channel: name.to_string(),
                start_s,
                end_s,
                kind,
            })
        };
        let Some(first) = v.iter().position(|x| x.is_finite()) else {
            return;
        };
        let last = v.iter().rposition(|x| x.is_finite()).unwrap_or(first);
        let late = |a: f64, b: f64| b - a > 1.5 * dt;
        // Leading edge.
        if late(0.0, t[0]) {
            push(0.0, t[first], GapKind::Missing);
        } else if first > MAX_BRIDGE_SAMPLES {
            push(0.0_f64.max(t[0]), t[first], GapKind::Dropout);
        }
        // Interior: between consecutive valid samples.
        let mut a = first;
        for b in first + 1..=last {
            if !v[b].is_finite() {
                continue;
            }
            if b == a + 1 {
                if late(t[a], t[b]) {
                    push(t[a], t[b], GapKind::Missing);
                }
            } else {
                let lost_time = (a..b).any(|i| late(t[i], t[i + 1]));
                if lost_time {
                    push(t[a], t[b], GapKind::Missing);
                } else if b - a - 1 > MAX_BRIDGE_SAMPLES {
                    push(t[a], t[b], GapKind::Dropout);
                }
            }
            a = b;
        }
        // Trailing edge.
        let n = t.len();
        if late(t[n - 1], log_end) {
            push(t[last], log_end, GapKind::Missing);
        } else if n - 1 - last > MAX_BRIDGE_SAMPLES {
            push(t[last], t[n - 1], GapKind::Dropout);
        }
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(3000))]
        /// The block-wise gap search finds exactly the gaps of the
        /// sample-by-sample one: lost time, null runs of every length,
        /// at the edges and across block boundaries.
        #[test]
        fn gaps_match_the_sample_by_sample_reference(
            steps in proptest::collection::vec((0.9f64..1.1, 0u8..40, 0u8..60), 1..400),
            null_runs in proptest::collection::vec((0usize..400, 1usize..12), 0..6),
            dt in 1e-4f64..0.1,
            start in 0.0f64..3.0,
            end_extra in 0.0f64..3.0,
        ) {
            let (mut t, mut v) = (Vec::new(), Vec::new());
            let mut now = start * dt;
            for (k, &(jitter, lost, null)) in steps.iter().enumerate() {
                now += if lost == 0 { dt * 2.5 } else { dt * jitter };
                t.push(now);
                v.push(if null == 0 { f64::NAN } else { k as f64 });
            }
            for &(at, len) in &null_runs {
                for x in v.iter_mut().skip(at).take(len) {
                    *x = f64::NAN;
                }
            }
            let log_end = now + end_extra * dt;
            let (mut got, mut want) = (Vec::new(), Vec::new());
            find_gaps(Quantity::X1, &t, &v, dt, log_end, &mut got);
            find_gaps_reference(Quantity::X1, &t, &v, dt, log_end, &mut want);
            proptest::prop_assert_eq!(got, want);
        }
    }

    #[test]
    fn interpolation_bridges_short_holes_only() {
        let dt = 0.01;
        let t: Vec<f64> = (0..40).map(|i| i as f64 * dt).collect();
        let mut v: Vec<f64> = t.iter().map(|t| 2.0 * t + 1.0).collect();
        for x in &mut v[5..5 + MAX_BRIDGE_SAMPLES] {
            *x = f64::NAN; // short dropout: bridged
        }
        for x in &mut v[20..20 + MAX_BRIDGE_SAMPLES + 1] {
            *x = f64::NAN; // one sample too long: not bridged
        }
        let grid: Vec<f64> = (0..79).map(|i| i as f64 * dt / 2.0).collect();
        let out = interpolate(&t, &v, dt, &grid);
        for (g, o) in grid.iter().zip(&out) {
            let inside_long = *g > 19.0 * dt + 1e-9 && *g < 26.0 * dt - 1e-9;
            if inside_long {
                assert!(o.is_nan(), "bridged a long hole at {g}");
            } else {
                assert!((o - (2.0 * g + 1.0)).abs() < 1e-12, "at {g}: {o}");
            }
        }
    }

    #[test]
    fn interpolation_never_extrapolates_and_skips_lost_time() {
        let dt = 0.001;
        let mut t: Vec<f64> = (0..10).map(|i| 0.0005 + i as f64 * dt).collect();
        t.extend((0..10).map(|i| 0.1005 + i as f64 * dt)); // lost buffer
        let v: Vec<f64> = t.iter().map(|t| t * 10.0).collect();
        let grid: Vec<f64> = (0..111).map(|i| i as f64 * dt).collect();
        let out = interpolate(&t, &v, dt, &grid);
        assert!(out[0].is_nan(), "extrapolated before the first sample");
        assert!((out[1] - 0.01).abs() < 1e-12);
        assert!(out[50].is_nan(), "bridged a lost buffer");
        assert!((out[105] - 1.05).abs() < 1e-12);
        assert!(out[110].is_nan(), "extrapolated past the last sample");
    }

    #[test]
    fn gaps_of_lost_buffers_and_long_dropouts() {
        let dt = 0.001;
        let mut t: Vec<f64> = (0..100).map(|i| i as f64 * dt).collect();
        t.extend((200..300).map(|i| i as f64 * dt)); // lost 100 samples
        let mut v = vec![1.0; t.len()];
        v[10] = f64::NAN; // short dropout: no gap
        for x in &mut v[150..160] {
            *x = f64::NAN; // long dropout: a gap
        }
        let mut gaps = Vec::new();
        find_gaps(Quantity::X1, &t, &v, dt, 0.299, &mut gaps);
        assert_eq!(gaps.len(), 2, "{gaps:?}");
        assert_eq!(gaps[0].kind, GapKind::Missing);
        assert!((gaps[0].start_s - 0.099).abs() < 1e-12 && (gaps[0].end_s - 0.2).abs() < 1e-12);
        assert_eq!(gaps[1].kind, GapKind::Dropout);
        assert!((gaps[1].start_s - 0.249).abs() < 1e-12 && (gaps[1].end_s - 0.26).abs() < 1e-12);
    }

    #[test]
    fn gaps_at_the_edges() {
        let dt = 0.001;
        let t: Vec<f64> = (100..200).map(|i| i as f64 * dt).collect();
        let v = vec![0.0; t.len()];
        let mut gaps = Vec::new();
        find_gaps(Quantity::X2, &t, &v, dt, 0.3, &mut gaps);
        assert_eq!(gaps.len(), 2, "{gaps:?}");
        assert!(gaps.iter().all(|g| g.kind == GapKind::Missing));
        assert_eq!(gaps[0].start_s, 0.0);
        assert!((gaps[1].end_s - 0.3).abs() < 1e-12);
    }

    #[test]
    fn step_function_holds_last_setpoint() {
        let sp = [
            Setpoint {
                t_s: 0.0,
                frequency_hz: 1.0,
                amplitude_m: None,
            },
            Setpoint {
                t_s: 1.0,
                frequency_hz: 2.0,
                amplitude_m: None,
            },
        ];
        let out = step_function(&sp, &[-0.5, 0.0, 0.5, 1.0, 3.0]);
        assert!(out[0].is_nan());
        assert_eq!(&out[1..], &[1.0, 1.0, 2.0, 2.0]);
    }
}
