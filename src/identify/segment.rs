//! Stick/slip separation under noise.
//!
//! 1. The velocity noise is estimated from the data: first from the second
//!    differences of the raw velocity (robust MAD, insensitive to the smooth
//!    signal), then, once sticks are found, directly as the robust spread of
//!    the smoothed velocity inside them (where the physics says ẋ2 = 0).
//! 2. Hysteresis on the smoothed velocity: a candidate stick starts when
//!    |v| drops below `lo` = 4σ and ends when |v| exceeds `hi` = 8σ.
//! 3. A candidate is a stick only if the velocity is *flat* in it: the
//!    change of a straight line fitted through it over its duration is
//!    below `lo`. A reversal (the velocity ramps through zero) crosses the
//!    whole band and fails this test, whatever the noise; this is the
//!    minimum-duration rule stated in terms of the data (a stick must last
//!    longer than the ramps into and out of it) plus a floor of one
//!    smoothing window.
//! 4. Short excursions above `hi` between two sticks (shorter than one
//!    smoothing window) are noise, not slips, and are merged into the stick.
//! 5. Breakaways: the time the mass leaves a stick is located by a hinge
//!    fit to the raw velocity (v = 0 before t_b, α(t−t_b) + β(t−t_b)² after),
//!    which serves both a jump in acceleration (static > dynamic) and a
//!    smooth start (Coulomb). Reversals without a stick are located as zero
//!    crossings of the smoothed velocity.

use super::smooth::savgol_weights;
use crate::stats::mad_sigma;

/// A located stick → slip transition.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Breakaway {
    /// Time of the breakaway, in samples (fractional).
    pub at: f64,
    /// Direction of the slip that follows (+1 or −1).
    pub direction: f64,
    /// Index range of the stick it ends.
    pub stick: (usize, usize),
}

/// A reversal of the velocity without a stick.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reversal {
    /// Time of the zero crossing, in samples (fractional).
    pub at: f64,
    /// Direction of the motion after it (+1 or −1).
    pub direction: f64,
}

/// The stick/slip segmentation of one log.
#[derive(Debug, Clone)]
pub struct Segmentation {
    /// Per sample: M2 sticks.
    pub stick: Vec<bool>,
    /// Stick phases `[start, end)`.
    pub sticks: Vec<(usize, usize)>,
    /// Noise (1σ) of the smoothed velocity (m/s).
    pub noise_v: f64,
    /// Noise (1σ) of the raw velocity (m/s).
    pub noise_v_raw: f64,
    /// Lower hysteresis threshold (m/s).
    pub lo: f64,
    /// Upper hysteresis threshold (m/s).
    pub hi: f64,
    /// Stick → slip transitions.
    pub breakaways: Vec<Breakaway>,
    /// Reversals without a stick.
    pub reversals: Vec<Reversal>,
    /// Number of finite samples classified as slip.
    pub slip_samples: usize,
}

impl Segmentation {
    /// The mass never slid.
    pub fn stuck(&self) -> bool {
        self.slip_samples == 0 && !self.sticks.is_empty()
    }
    /// The mass slid throughout (no stick at all).
    pub fn never_sticks(&self) -> bool {
        self.sticks.is_empty() && self.slip_samples > 0
    }
}

/// Candidate sticks by hysteresis: runs that start below `lo` and end above
/// `hi`. A hole in the record (a run of non-finite samples) longer than
/// `max_hole` samples ends an open run at the hole: M2 may have slid and
/// stuck again inside it, so a stick is never carried across it (a run
/// carried over a lost 100 ms buffer put a shooting anchor, M2 at rest,
/// where M2 was sliding; that one segment's residual made a log's law
/// inadequate at 8× its noise).
fn hysteresis(v: &[f64], lo: f64, hi: f64, max_hole: usize) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut start: Option<usize> = None;
    let mut hole: Option<usize> = None;
    for (i, x) in v.iter().enumerate() {
        if !x.is_finite() {
            let h = *hole.get_or_insert(i);
            if let Some(s) = start.filter(|_| i - h >= max_hole) {
                out.push((s, h));
                start = None;
            }
            continue;
        }
        hole = None;
        match start {
            None if x.abs() < lo => start = Some(i),
            Some(s) if x.abs() > hi => {
                out.push((s, i));
                start = None;
            }
            _ => {}
        }
    }
    if let Some(s) = start {
        out.push((s, hole.unwrap_or(v.len())));
    }
    out
}

/// Change of the least-squares line through the finite `v[s..e]` over the run.
fn ramp(v: &[f64], s: usize, e: usize) -> f64 {
    let (mut n, mut st, mut sv, mut stt, mut stv) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for (i, x) in v[s..e].iter().enumerate() {
        if x.is_finite() {
            let t = i as f64;
            n += 1.0;
            st += t;
            sv += x;
            stt += t * t;
            stv += t * x;
        }
    }
    let den = n * stt - st * st;
    if n < 3.0 || den <= 0.0 {
        return f64::INFINITY;
    }
    ((n * stv - st * sv) / den * (e - s) as f64).abs()
}

/// Classifies candidates with thresholds; returns the stick runs.
fn sticks_for(v_s: &[f64], lo: f64, hi: f64, min_len: usize) -> Vec<(usize, usize)> {
    let mut sticks: Vec<(usize, usize)> = hysteresis(v_s, lo, hi, min_len)
        .into_iter()
        .filter(|&(s, e)| e - s >= min_len && ramp(v_s, s, e) < lo)
        .collect();
    // Merge sticks separated by an excursion shorter than one window.
    let mut merged: Vec<(usize, usize)> = Vec::new();
    for s in sticks.drain(..) {
        if let Some(last) = merged.last_mut() {
            if s.0 - last.1 < min_len {
                last.1 = s.1;
                continue;
            }
        }
        merged.push(s);
    }
    merged
}

/// Least-squares hinge fit over `[a, b)`: for a breakaway time t_b the
/// finite data are regressed (no intercept) on the two regressors
/// `reg(i, t_b)` (None: the sample carries no regressor, its residual is the
/// value itself); t_b minimises the residual sum of squares, first on the
/// sample grid, then by golden section within ±1 sample. In samples.
fn hinge_fit(
    x: &[f64],
    a: usize,
    b: usize,
    reg: impl Fn(usize, f64) -> Option<(f64, f64)>,
) -> Option<f64> {
    let sse_at = |tb: f64| -> f64 {
        let (mut s11, mut s12, mut s22, mut s1v, mut s2v, mut svv) = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
        for (i, v) in x.iter().enumerate().take(b).skip(a) {
            if !v.is_finite() {
                continue;
            }
            svv += v * v;
            let Some((p, q)) = reg(i, tb) else { continue };
            s11 += p * p;
            s12 += p * q;
            s22 += q * q;
            s1v += p * v;
            s2v += q * v;
        }
        let det = s11 * s22 - s12 * s12;
        if det <= 1e-12 * (s11 * s22).max(1e-300) {
            return if s11 > 0.0 {
                svv - s1v * s1v / s11
            } else {
                svv
            };
        }
        let c1 = (s22 * s1v - s12 * s2v) / det;
        let c2 = (s11 * s2v - s12 * s1v) / det;
        svv - c1 * s1v - c2 * s2v
    };
    let mut best = (a as f64, f64::INFINITY);
    for i in a..b.saturating_sub(3) {
        let f = sse_at(i as f64);
        if f < best.1 {
            best = (i as f64, f);
        }
    }
    if !best.1.is_finite() {
        return None;
    }
    Some(crate::stats::golden_section(
        best.0 - 1.0,
        best.0 + 1.0,
        25,
        sse_at,
    ))
}

/// Hinge fit of the raw velocity over `[a, b)`: v on (t−t_b)₊ and
/// (t−t_b)₊² (no intercept: v = 0 while stuck); the breakaway time (samples).
fn hinge(v: &[f64], a: usize, b: usize) -> Option<f64> {
    hinge_fit(v, a, b, |i, tb| {
        let u = (i as f64 - tb).max(0.0);
        Some((u, u * u))
    })
}

/// Hinge fit of the acceleration over `[a, b)`: a = 0 before t_b,
/// α + β·(t − t_b) after (a jump α for static > dynamic friction, α ≈ 0 for
/// a smooth start); the breakaway time in samples.
fn hinge_acc(acc: &[f64], a: usize, b: usize) -> Option<f64> {
    hinge_fit(acc, a, b, |i, tb| {
        let t = i as f64 - tb;
        // Fractional step at the sample straddling t_b.
        let h = (t + 0.5).clamp(0.0, 1.0);
        (h != 0.0).then_some((h, t.max(0.0)))
    })
}

/// Breakaways: every stick followed by data, located by a hinge fit over
/// the last part of the stick and the slip until |v_s| passes 4·`hi` (on
/// the accelerometer record where it has data throughout).
fn breakaways_of(
    v: &[f64],
    v_s: &[f64],
    acc: Option<&[f64]>,
    sticks: &[(usize, usize)],
    half: usize,
    hi: f64,
) -> Vec<Breakaway> {
    let n = v.len();
    let mut breakaways = Vec::new();
    for &(s, e) in sticks {
        if e >= n {
            continue;
        }
        // Window: the last part of the stick, and the slip until |v_s| passes 4·hi.
        let a = s.max(e.saturating_sub(4 * half + 2));
        let mut b = e;
        while b < n && b < e + 8 * half + 8 && v_s[b].is_finite() && v_s[b].abs() < 4.0 * hi {
            b += 1;
        }
        if b >= n || !v_s[b].is_finite() || (a..b).any(|i| !v[i].is_finite()) {
            continue;
        }
        let dir = v_s[b].signum();
        // With an accelerometer, the onset of acceleration is sharper than
        // that of velocity (a jump for static > dynamic friction).
        let located = match acc {
            Some(ac) if (a..=b).all(|i| ac[i].is_finite()) => hinge_acc(ac, a, b + 1),
            _ => hinge(v, a, b + 1),
        };
        if let Some(at) = located {
            breakaways.push(Breakaway {
                at,
                direction: dir,
                stick: (s, e),
            });
        }
    }
    breakaways
}

/// Reversals: passages from beyond +hi to beyond −hi (or back) outside
/// sticks, located at the last zero crossing of v_s in between; a noisy
/// passage through zero counts once.
fn reversals_of(v_s: &[f64], stick: &[bool], hi: f64) -> Vec<Reversal> {
    let n = stick.len();
    let mut reversals = Vec::new();
    let mut side = 0.0f64;
    let mut last_zero: Option<f64> = None;
    let mut prev: Option<usize> = None;
    for i in 0..n {
        if stick[i] {
            side = 0.0;
            last_zero = None;
            prev = None;
            continue;
        }
        if !v_s[i].is_finite() {
            prev = None;
            continue;
        }
        if let Some(p) = prev {
            if v_s[p] != 0.0 && v_s[i].signum() != v_s[p].signum() {
                last_zero = Some(p as f64 + (i - p) as f64 * v_s[p] / (v_s[p] - v_s[i]));
            }
        }
        prev = Some(i);
        if v_s[i].abs() > hi {
            let s = v_s[i].signum();
            if side != 0.0 && s != side {
                if let Some(at) = last_zero {
                    reversals.push(Reversal { at, direction: s });
                }
            }
            side = s;
            last_zero = None;
        }
    }
    reversals
}

/// Segments a velocity record.
///
/// `v` is the corrected raw velocity, `v_s` its smoothed version, `acc` the
/// accelerometer record if there is one (used to locate breakaways), `half`
/// the smoothing half-window (samples), `degree` the smoothing degree.
pub fn segment(
    v: &[f64],
    v_s: &[f64],
    acc: Option<&[f64]>,
    half: usize,
    degree: usize,
) -> Segmentation {
    let n = v.len();
    // Noise of the raw velocity from second differences (var = 6σ² for white noise).
    let d2: Vec<f64> = (1..n.saturating_sub(1))
        .map(|i| v[i + 1] - 2.0 * v[i] + v[i - 1])
        .collect();
    let noise_raw = mad_sigma(&d2) / 6f64.sqrt();
    let h = half as i64;
    let w = savgol_weights(-h, h, degree, 0, 1.0).unwrap_or_else(|| vec![1.0]);
    let gain = w.iter().map(|x| x * x).sum::<f64>().sqrt();
    let mut noise = noise_raw * gain;
    if noise.is_nan() || noise <= 0.0 {
        noise = f64::EPSILON;
    }
    let min_len = 2 * half + 1;
    let mut sticks = sticks_for(v_s, 4.0 * noise, 8.0 * noise, min_len);
    // Second pass: the noise measured where the mass sticks.
    let inside: Vec<f64> = sticks
        .iter()
        .flat_map(|&(s, e)| {
            let (a, b) = (s + half, e.saturating_sub(half));
            v_s[a.min(b)..b].iter().copied()
        })
        .collect();
    if inside.len() >= 50 {
        let measured = mad_sigma(&inside);
        if measured.is_finite() && measured > 0.0 {
            noise = measured;
            sticks = sticks_for(v_s, 4.0 * noise, 8.0 * noise, min_len);
        }
    }
    let (lo, hi) = (4.0 * noise, 8.0 * noise);
    let mut stick = vec![false; n];
    for &(s, e) in &sticks {
        for x in stick.iter_mut().take(e).skip(s) {
            *x = true;
        }
    }
    let slip_samples = (0..n).filter(|&i| !stick[i] && v_s[i].is_finite()).count();

    let breakaways = breakaways_of(v, v_s, acc, &sticks, half, hi);
    // The samples from a breakaway to the end of its stick (still inside
    // the hysteresis band) are sliding already.
    for bk in &breakaways {
        let from = (bk.at.ceil().max(0.0) as usize).max(bk.stick.0);
        for x in stick.iter_mut().take(bk.stick.1).skip(from) {
            *x = false;
        }
    }
    let reversals = reversals_of(v_s, &stick, hi);
    Segmentation {
        stick,
        sticks,
        noise_v: noise,
        noise_v_raw: noise_raw,
        lo,
        hi,
        breakaways,
        reversals,
        slip_samples,
    }
}

#[cfg(test)]
mod tests {
    use super::super::smooth::savgol;
    use super::*;
    use crate::stats::Rng;

    /// A velocity record with sticks of known extent plus white noise.
    fn synthetic(noise: f64, seed: u64) -> (Vec<f64>, Vec<(usize, usize)>, Vec<f64>) {
        let mut rng = Rng::new(seed);
        let mut v = Vec::new();
        let mut sticks = Vec::new();
        let mut breaks = Vec::new();
        // Pattern: stick 150 samples, slip as a half sine of 300 samples,
        // alternating sign; then a reversal without stick (full sine period).
        let mut sign = 1.0;
        for _ in 0..6 {
            let s = v.len();
            v.extend(std::iter::repeat_n(0.0, 150));
            sticks.push((s, v.len()));
            breaks.push(v.len() as f64);
            for k in 0..300 {
                v.push(sign * 0.03 * (std::f64::consts::PI * k as f64 / 300.0).sin());
            }
            sign = -sign;
        }
        for k in 0..600 {
            v.push(0.03 * (2.0 * std::f64::consts::PI * k as f64 / 600.0).sin());
        }
        for x in v.iter_mut() {
            *x += noise * rng.normal();
        }
        (v, sticks, breaks)
    }

    #[test]
    fn finds_sticks_and_no_fake_sticks_under_noise() {
        for seed in 0..5 {
            let (v, truth, breaks) = synthetic(5e-4, seed);
            let vs = savgol(&v, 1.0, 10, 3, 0);
            let seg = segment(&v, &vs, None, 10, 3);
            assert_eq!(
                seg.sticks.len(),
                truth.len(),
                "seed {seed}: {:?}",
                seg.sticks
            );
            for (a, b) in seg.sticks.iter().zip(&truth) {
                // The found stick covers most of the true one.
                let overlap = a.1.min(b.1).saturating_sub(a.0.max(b.0));
                assert!(overlap as f64 > 0.8 * (b.1 - b.0) as f64, "{a:?} vs {b:?}");
            }
            // The reversals without stick (from the last half sine into the
            // full sine at sample 2700, and its own zero at 3000) are not
            // sticks, and each noisy zero crossing counts once.
            assert_eq!(seg.reversals.len(), 2, "seed {seed}: {:?}", seg.reversals);
            for (r, t) in seg.reversals.iter().zip([2700.0, 3000.0]) {
                assert!((r.at - t).abs() < 3.0, "{} vs {t}", r.at);
            }
            // Breakaways located within a few samples (the velocity ramps
            // as a sine from the breakaway: slope 0.03·π/300 per sample).
            // The hinge on a noisy velocity has a spread of a few samples
            // (noise 5e-4 against a ramp of 3.1e-4 per sample): the median
            // error is small, an occasional one is off by up to ~16 samples
            // (hence the median over breakaways in the fit).
            let errs: Vec<f64> = seg
                .breakaways
                .iter()
                .zip(&breaks)
                .map(|(bk, t)| (bk.at - t).abs())
                .collect();
            assert_eq!(errs.len(), breaks.len());
            assert!(crate::stats::median(&errs) < 4.0, "{errs:?}");
            assert!(errs.iter().all(|e| *e < 20.0), "{errs:?}");
            assert!(!seg.stuck() && !seg.never_sticks());
        }
    }

    #[test]
    fn a_stick_is_never_carried_across_a_lost_buffer() {
        // A lost buffer (NaN) hides the end of one stick, a whole slip and
        // the start of the next stick: the record reads "at rest" on both
        // sides, but the mass slid inside the hole.
        for seed in 0..5 {
            let (mut v, _, _) = synthetic(5e-4, seed);
            let hole = 100..500; // stick 0..150, slip 150..450, stick 450..600
            for x in &mut v[hole.clone()] {
                *x = f64::NAN;
            }
            let vs = savgol(&v, 1.0, 10, 3, 0);
            let seg = segment(&v, &vs, None, 10, 3);
            for &(a, b) in &seg.sticks {
                assert!(
                    b <= hole.start + 10 || a >= hole.end - 10,
                    "seed {seed}: stick {a}..{b} spans the hole {hole:?}"
                );
            }
            // The sticks on both sides are still found, and no breakaway is
            // invented at the hole.
            assert!(seg.sticks.iter().any(|&(a, b)| a < 100 && b > 50));
            assert!(seg.sticks.iter().any(|&(a, b)| a < 600 && b > 550));
            assert!(seg.breakaways.iter().all(|bk| bk.at > 500.0));
        }
        // A short hole (a few dropped samples) inside a stick does not
        // split it.
        let (mut v, truth, _) = synthetic(5e-4, 7);
        for x in &mut v[60..64] {
            *x = f64::NAN;
        }
        let vs = savgol(&v, 1.0, 10, 3, 0);
        let seg = segment(&v, &vs, None, 10, 3);
        assert_eq!(seg.sticks.len(), truth.len(), "{:?}", seg.sticks);
    }

    #[test]
    fn noise_estimate_matches_the_truth() {
        let (v, _, _) = synthetic(5e-4, 11);
        let vs = savgol(&v, 1.0, 10, 3, 0);
        let seg = segment(&v, &vs, None, 10, 3);
        assert!(
            (seg.noise_v_raw / 5e-4 - 1.0).abs() < 0.1,
            "{}",
            seg.noise_v_raw
        );
    }

    #[test]
    fn stuck_and_never_sticking_records() {
        let mut rng = Rng::new(2);
        let stuck: Vec<f64> = (0..3000).map(|_| 5e-4 * rng.normal()).collect();
        let vs = savgol(&stuck, 1.0, 10, 3, 0);
        let seg = segment(&stuck, &vs, None, 10, 3);
        assert!(seg.stuck(), "{:?}", seg.sticks);
        let slide: Vec<f64> = (0..3000)
            .map(|k| {
                0.03 * (2.0 * std::f64::consts::PI * k as f64 / 600.0).sin() + 5e-4 * rng.normal()
            })
            .collect();
        let vs = savgol(&slide, 1.0, 10, 3, 0);
        let seg = segment(&slide, &vs, None, 10, 3);
        assert!(seg.never_sticks(), "{:?}", seg.sticks);
        assert_eq!(seg.reversals.len(), 9);
    }
}
