//! Saturation: channels clipped at a constant extreme value.
//!
//! A sensor or DAQ input that saturates reports one value, exactly, for as
//! long as the true signal lies beyond its range. Such samples are not
//! measurements of the motion: they are left out of everything downstream
//! (the raw samples and the common time base rows interpolated from them
//! become NaN, like a dropout), and a warning names the channel, the side
//! and the fraction ("clipped: x1 flat at its maximum …").
//!
//! ## The test
//! For each motion channel (x0, x1, x2, v2, a2; the normal force is a
//! static level, not tested) and each side, the candidate runs are
//! stretches of at least [`MIN_RUN`] consecutive samples exactly at the
//! channel's extreme (within 1e-9 of its range). Flat runs also come from
//! a mass that really stands still (x2 while M2 sticks, noise-free) and
//! from the peaks of a quantised, noise-free signal. What sets saturation
//! apart is that the signal *arrives and leaves with speed*: it crosses the
//! rail, it does not stop at it. With the channel's speed scale V (98th
//! percentile of |Δv|/Δt over a lag L) and the window W = L·dt ≈ 0.063 ×
//! range/V (2 % of a period for a sinusoid), a run is saturation only if,
//! on each side where the log has 2L valid samples:
//!
//! * the mean speed over the last window before (first after) the run is at
//!   least [`MIN_ENTRY_SPEED`]·V (a sinusoid clipped below about 99 % of its
//!   peak; a stop in the middle of the swing arrives with zero speed, so
//!   its mean speed over W is about π·W/T·V ≈ 0.06 V);
//! * that speed is at least [`MIN_SPEED_RATIO`] of the speed over the window
//!   before it (a crossing keeps its speed, a stop loses it: a parabolic
//!   stop gives 1/3);
//! * the run is at least [`MIN_LENGTH_RATIO`] times longer than the longest
//!   run of equal values in those windows (a quantised peak's plateau is
//!   only about 2.7 times its neighbouring levels').
//!
//! Saturation at 99.5 % of a sinusoid's peak or above is not detected (it
//! looks like a peak; it also barely moves a fit). Saturation whose rail
//! value carries noise (noise added after the saturating stage) is not
//! detected: the test relies on the rail value being constant.

use super::{Channel, Quantity, Resampled, Run};

/// Fewest samples of a flat run at the extreme that can be saturation.
pub const MIN_RUN: usize = 3;
/// Least mean speed at entry/exit over the channel's speed scale.
pub const MIN_ENTRY_SPEED: f64 = 0.15;
/// Least ratio of the speed next to the run to the speed one window out.
pub const MIN_SPEED_RATIO: f64 = 0.6;
/// Least ratio of the run's length to the longest flat run next to it.
pub const MIN_LENGTH_RATIO: f64 = 4.0;

/// One saturated side of one channel.
#[derive(Debug, Clone, PartialEq)]
pub struct Clipped {
    /// The channel.
    pub quantity: Quantity,
    /// The high side (maximum) or the low side (minimum).
    pub high: bool,
    /// The rail value (SI).
    pub level: f64,
    /// Index ranges (inclusive) of the saturated runs in the channel.
    pub runs: Vec<(usize, usize)>,
    /// Samples in those runs.
    pub samples: usize,
    /// Valid samples of the channel.
    pub valid: usize,
}

impl Clipped {
    /// Fraction of the channel's valid samples at the rail.
    pub fn fraction(&self) -> f64 {
        self.samples as f64 / self.valid.max(1) as f64
    }

    /// The warning (code `clipped`; its message starts with `clipped:`).
    pub fn warning(&self) -> crate::warning::Warning {
        crate::warning::Warning::Clipped {
            channel: self.quantity.name(),
            high: self.high,
            level: self.level,
            unit: self.quantity.unit(),
            fraction: self.fraction(),
            samples: self.samples,
            runs: self.runs.len(),
        }
    }
}

/// The saturated sides of one channel's samples `v` at times `t` (NaN:
/// no data), sample interval `dt`.
pub fn detect(q: Quantity, t: &[f64], v: &[f64], dt: f64) -> Vec<Clipped> {
    let valid = v.iter().filter(|x| x.is_finite()).count();
    let (mn, mx) = v
        .iter()
        .filter(|x| x.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
            (a.min(*x), b.max(*x))
        });
    let range = mx - mn;
    if valid < 8 * MIN_RUN || range.is_nan() || range <= 0.0 || dt.is_nan() || dt <= 0.0 {
        return Vec::new();
    }
    // Consecutive (no hole) between i and i + 1.
    let next_ok = |i: usize| {
        i + 1 < v.len() && v[i].is_finite() && v[i + 1].is_finite() && t[i + 1] - t[i] <= 1.5 * dt
    };
    // Speed scale and window lag, iterated from L = 1.
    let mut lag = 1usize;
    let mut speed = 0.0;
    for _ in 0..3 {
        let mut s: Vec<f64> = (0..v.len().saturating_sub(lag))
            .filter(|&i| v[i].is_finite() && v[i + lag].is_finite())
            .map(|i| (v[i + lag] - v[i]).abs() / (t[i + lag] - t[i]))
            .filter(|x| x.is_finite())
            .collect();
        if s.len() < 8 {
            return Vec::new();
        }
        let k = ((s.len() as f64 * 0.98) as usize).min(s.len() - 1);
        s.select_nth_unstable_by(k, |a, b| a.total_cmp(b));
        speed = s[k];
        if speed.is_nan() || speed <= 0.0 {
            return Vec::new();
        }
        let w = 0.063 * range / speed;
        lag = ((w / dt).round() as usize).clamp(1, v.len() / 8);
    }
    let tol = 1e-9 * range;
    let mut out = Vec::new();
    for high in [true, false] {
        let level = if high { mx } else { mn };
        let at = |i: usize| v[i].is_finite() && (v[i] - level).abs() <= tol;
        let mut runs = Vec::new();
        let mut i = 0;
        while i < v.len() {
            if !at(i) {
                i += 1;
                continue;
            }
            let i0 = i;
            while next_ok(i) && at(i + 1) {
                i += 1;
            }
            let i1 = i;
            i += 1;
            if i1 + 1 - i0 >= MIN_RUN && saturated(v, t, i0, i1, lag, speed, level, high, &next_ok)
            {
                runs.push((i0, i1));
            }
        }
        let samples: usize = runs.iter().map(|(a, b)| b + 1 - a).sum();
        if samples >= MIN_RUN {
            out.push(Clipped {
                quantity: q,
                high,
                level,
                runs,
                samples,
                valid,
            });
        }
    }
    out
}

/// Whether the flat run [i0, i1] at `level` is saturation (see the module
/// comment): judged on each side that has 2·lag contiguous valid samples;
/// a run with neither is not judged saturated.
#[allow(clippy::too_many_arguments)]
fn saturated(
    v: &[f64],
    t: &[f64],
    i0: usize,
    i1: usize,
    lag: usize,
    speed: f64,
    level: f64,
    high: bool,
    next_ok: &dyn Fn(usize) -> bool,
) -> bool {
    let n = i1 + 1 - i0;
    let sgn = if high { 1.0 } else { -1.0 };
    // Indices of one side, from next to the run outwards.
    let side = |before: bool| -> Option<Vec<usize>> {
        let mut idx = Vec::with_capacity(2 * lag + 1);
        let mut j = if before { i0 } else { i1 };
        idx.push(j);
        for _ in 0..2 * lag {
            let k = if before {
                if j == 0 || !next_ok(j - 1) {
                    return None;
                }
                j - 1
            } else {
                if !next_ok(j) {
                    return None;
                }
                j + 1
            };
            idx.push(k);
            j = k;
        }
        Some(idx)
    };
    let mut judged = 0;
    for before in [true, false] {
        let Some(idx) = side(before) else {
            continue;
        };
        judged += 1;
        let (a, b, c) = (idx[0], idx[lag], idx[2 * lag]);
        let near = sgn * (level - v[b]) / (t[a] - t[b]).abs();
        let far = sgn * (v[b] - v[c]) / (t[b] - t[c]).abs();
        if !(near >= MIN_ENTRY_SPEED * speed && near >= MIN_SPEED_RATIO * far) {
            return false;
        }
        // Longest run of equal values in the windows next to the run.
        let mut longest = 1;
        let mut cur = 1;
        for w in idx[1..].windows(2) {
            if v[w[0]] == v[w[1]] {
                cur += 1;
                longest = longest.max(cur);
            } else {
                cur = 1;
            }
        }
        if (n as f64) < MIN_LENGTH_RATIO * longest as f64 {
            return false;
        }
    }
    judged > 0
}

/// Finds the saturated runs of every motion channel (the normal force is
/// a static level, not tested), blanks their samples (NaN) and returns
/// them with the index of their channel. Called before anything reads the
/// channels (the delay estimation included), so no estimate sees a rail
/// value as a measurement.
pub(crate) fn mark(channels: &mut [Channel]) -> Vec<(usize, Clipped)> {
    let mut found = Vec::new();
    for (ci, c) in channels.iter_mut().enumerate() {
        if c.quantity == Quantity::NormalForce {
            continue;
        }
        let clipped = detect(c.quantity, &c.t, &c.v, 1.0 / c.rate_hz);
        for cl in clipped {
            for &(i0, i1) in &cl.runs {
                for x in &mut c.v[i0..=i1] {
                    *x = f64::NAN;
                }
            }
            found.push((ci, cl));
        }
    }
    found
}

/// Blanks (NaN) the grid rows strictly between the valid samples around
/// each clipped run of `found` (the runs [`mark`] returned for these
/// channels): the interpolation would otherwise bridge a short run. Called
/// again whenever the grid is rebuilt (channels re-stamped by a delay).
pub(crate) fn blank_grid(channels: &[Channel], found: &[(usize, Clipped)], rs: &mut Resampled) {
    for (ci, cl) in found {
        let c = &channels[*ci];
        let grid_t = rs.t.clone();
        let col: Option<&mut [f64]> = match c.quantity {
            Quantity::X0 => Some(&mut rs.x0),
            Quantity::X1 => Some(std::sync::Arc::make_mut(&mut rs.x1)),
            Quantity::X2 => Some(std::sync::Arc::make_mut(&mut rs.x2)),
            Quantity::V2 => Some(&mut rs.v2),
            Quantity::A2 => rs.a2.as_deref_mut(),
            Quantity::NormalForce => None,
        };
        let Some(col) = col else { continue };
        for &(i0, i1) in &cl.runs {
            let lo = if i0 > 0 {
                c.t[i0 - 1]
            } else {
                f64::NEG_INFINITY
            };
            let hi = c.t.get(i1 + 1).copied().unwrap_or(f64::INFINITY);
            let start = grid_t.partition_point(|t| *t <= lo);
            for r in start..grid_t.len() {
                if grid_t[r] >= hi {
                    break;
                }
                col[r] = f64::NAN;
            }
        }
    }
}

/// Detects saturation in every motion channel of `run`, blanks the clipped
/// samples and the grid rows between their neighbours, adds a warning per
/// clipped side and returns what it found. `ingest::read` does this before
/// estimating the channel delays; a run it returned has nothing left to
/// find (its rail samples are already NaN).
pub fn apply(run: &mut Run) -> Vec<Clipped> {
    let found = mark(&mut run.channels);
    blank_grid(&run.channels, &found, &mut run.resampled);
    run.warnings
        .extend(found.iter().map(|(_, cl)| cl.warning()));
    found.into_iter().map(|(_, cl)| cl).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    fn grid(n: usize, dt: f64) -> Vec<f64> {
        (0..n).map(|i| i as f64 * dt).collect()
    }

    fn quantise(x: f64, q: f64) -> f64 {
        (x / q).round() * q
    }

    /// A sinusoid flat-topped at 85 % of its peak: the high side is found
    /// with the right fraction, the low side not.
    #[test]
    fn clipped_sinusoid_is_found() {
        let dt = 1e-3;
        let t = grid(20_000, dt);
        let w = 2.0 * PI * 1.72;
        let v: Vec<f64> = t
            .iter()
            .enumerate()
            .map(|(i, t)| {
                let noise = 3e-6 * ((i as f64 * 12.9898).sin() * 43758.5453).fract();
                quantise((2.5e-3 * (w * t).cos() + noise).min(0.85 * 2.5e-3), 1e-6)
            })
            .collect();
        let c = detect(Quantity::X1, &t, &v, dt);
        assert_eq!(c.len(), 1, "{c:?}");
        assert!(c[0].high);
        // acos(0.85)/π of each period.
        let ex = (0.85f64).acos() / PI;
        assert!(
            (c[0].fraction() - ex).abs() < 0.01,
            "{} vs {ex}",
            c[0].fraction()
        );
        assert_eq!(c[0].warning().code(), "clipped");
        assert!(c[0]
            .warning()
            .to_string()
            .starts_with("clipped: x1 flat at its maximum"));
    }

    /// A noise-free quantised sinusoid (plateaus at its peaks, on both
    /// sides) is not saturation, for quantisation steps up to 1 % of the
    /// amplitude.
    #[test]
    fn quantised_peaks_are_not_saturation() {
        let dt = 1e-3;
        let t = grid(20_000, dt);
        let w = 2.0 * PI * 1.72;
        for q in [1e-7, 1e-6, 5e-6, 2.5e-5] {
            let v: Vec<f64> = t
                .iter()
                .map(|t| quantise(2.5e-3 * (w * t).cos(), q))
                .collect();
            assert!(detect(Quantity::X1, &t, &v, dt).is_empty(), "q {q}");
        }
    }

    /// A mass that stops at its turning points and stays there (a
    /// noise-free stuck x2, also at the extremes of the log) is not
    /// saturation.
    #[test]
    fn a_mass_standing_still_is_not_saturation() {
        let dt = 1e-3;
        let t = grid(20_000, dt);
        let period = 1.0 / 1.72;
        // Per period: stuck at +A for 30 %, parabolic moves between.
        let a = 1e-3;
        let v: Vec<f64> = t
            .iter()
            .map(|t| {
                let p = (t / period).fract();
                let x = if p < 0.3 {
                    a
                } else if p < 0.5 {
                    // From +A to −A, starting and ending at rest.
                    let s = (p - 0.3) / 0.2;
                    a * (PI * s).cos()
                } else if p < 0.8 {
                    -a
                } else {
                    let s = (p - 0.8) / 0.2;
                    -a * (PI * s).cos()
                };
                quantise(x, 1e-6)
            })
            .collect();
        assert!(detect(Quantity::X2, &t, &v, dt).is_empty());
    }

    /// Clipped samples and the grid rows between their neighbours become
    /// NaN.
    #[test]
    fn apply_blanks_the_clipped_rows() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("datasets/char_N4.mcap");
        let mut run = crate::ingest::read(&path, &Default::default()).expect("read");
        assert!(apply(&mut run).is_empty());
        let x1 = &run.resampled.x1;
        let peak = x1
            .iter()
            .filter(|v| v.is_finite())
            .fold(f64::MIN, |m, v| m.max(*v));
        let lo = x1
            .iter()
            .filter(|v| v.is_finite())
            .fold(f64::MAX, |m, v| m.min(*v));
        let rail = 0.5 * (peak + lo) + 0.85 * 0.5 * (peak - lo);
        let c = run
            .channels
            .iter_mut()
            .find(|c| c.quantity == Quantity::X1)
            .expect("x1");
        for v in c.v.iter_mut() {
            *v = v.min(rail);
        }
        for v in std::sync::Arc::make_mut(&mut run.resampled.x1).iter_mut() {
            *v = v.min(rail);
        }
        let found = apply(&mut run);
        assert_eq!(found.len(), 1, "{found:?}");
        assert!(found[0].fraction() > 0.05 && found[0].fraction() < 0.25);
        // Rows still at the rail: only where the rail was touched by fewer
        // than MIN_RUN samples (peaks just reaching it), a few per cent.
        let left = run.resampled.x1.iter().filter(|v| **v >= rail).count();
        assert!(
            (left as f64) < 0.05 * found[0].samples as f64,
            "{left} rows at the rail left of {}",
            found[0].samples
        );
        assert!(run
            .warnings
            .iter()
            .any(|w| matches!(w, crate::warning::Warning::Clipped { channel: "x1", .. })));
    }
}
