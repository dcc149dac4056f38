//! The multiple-shooting layout of a log: the anchors (mid-stick and
//! slip velocity peaks), the shooting segments over them, and the sums of
//! M1's equation terms behind the zero offset p1.

use super::*;

/// Anchors at the middle of every stick run (ends excluded): M2 at rest,
/// ζ2 from the mean of x2 over the stick's inner half.
pub(super) fn stick_anchors(
    c: &Contact,
    seg: &Segmentation,
    ok_state: &impl Fn(usize) -> bool,
) -> Vec<Anchor> {
    let n = c.t.len();
    let mut anchors: Vec<Anchor> = Vec::new();
    let mut i = 0;
    while i < n {
        if !seg.stick[i] {
            i += 1;
            continue;
        }
        let s = i;
        while i < n && seg.stick[i] {
            i += 1;
        }
        let e = i;
        if s == 0 || e >= n || e - s < 5 {
            continue;
        }
        let (lo, hi) = (s + (e - s) / 4, e - (e - s) / 4);
        let vals: Vec<f64> = c.x2[lo..hi]
            .iter()
            .copied()
            .filter(|v| v.is_finite())
            .collect();
        let mid = (s + e) / 2;
        if vals.len() < 3 || !ok_state(mid) {
            continue;
        }
        anchors.push(Anchor {
            i: mid,
            x2_stick: Some(vals.iter().sum::<f64>() / vals.len() as f64),
        });
    }
    anchors
}

/// Velocity peaks of the slips where sticks are far apart (more than 3/4
/// of a drive period of `per_n` samples between the stick anchors): one
/// per half period where |ẋ2| exceeds twice the stick threshold.
pub(super) fn slip_anchors(
    c: &Contact,
    seg: &Segmentation,
    anchors: &[Anchor],
    per_n: usize,
    ok_state: &impl Fn(usize) -> bool,
) -> Vec<Anchor> {
    let n = c.t.len();
    let mut bounds: Vec<usize> = vec![0];
    bounds.extend(anchors.iter().map(|a| a.i));
    bounds.push(n - 1);
    let half = per_n / 2;
    let mut extra = Vec::new();
    for w in bounds.windows(2) {
        let (lo, hi) = (w[0], w[1]);
        if hi - lo <= 3 * per_n / 4 {
            continue;
        }
        let mut k = lo + half / 4;
        while k + half <= hi {
            let best = (k..k + half)
                .filter(|&j| c.v2_smooth[j].is_finite() && ok_state(j) && !seg.stick[j])
                .max_by(|&p, &q| c.v2_smooth[p].abs().total_cmp(&c.v2_smooth[q].abs()));
            if let Some(b) = best {
                if c.v2_smooth[b].abs() > 2.0 * seg.hi {
                    extra.push(Anchor {
                        i: b,
                        x2_stick: None,
                    });
                }
            }
            k += half;
        }
    }
    extra
}

/// Segments over `span` consecutive anchor intervals, each interval at
/// most 1.5 periods long; shorter spans where the log is too short for a
/// dozen segments.
pub(super) fn shooting_segments(
    anchors: &[Anchor],
    span: usize,
    per_n: usize,
) -> Vec<(usize, usize)> {
    let span = span.min(anchors.len().saturating_sub(1) / 12).max(1);
    let mut segs: Vec<(usize, usize)> = Vec::new();
    let mut k = 0;
    while k + span < anchors.len() {
        if (k..k + span).all(|j| anchors[j + 1].i - anchors[j].i <= 3 * per_n / 2) {
            segs.push((k, k + span));
            k += span;
        } else {
            k += 1;
        }
    }
    segs
}

/// Sums of M1's equation terms (x1, x2, M1·ẍ1 + d·ẋ1, d·ẋ2, the drive
/// sinusoid) over the samples where every term is known, and their count.
pub(super) fn m1_sums(
    c: &Contact,
    rig: &RigMeta,
    a1: &[f64],
    v1s: &[f64],
    v2p: &[f64],
    harmonic: &impl Fn(f64) -> f64,
) -> ([f64; 5], usize) {
    let n = c.t.len();
    let mut sums = [0.0f64; 5];
    let mut cnt = 0usize;
    for i in 0..n {
        let ok = [c.x1[i], c.x2[i], a1[i], v1s[i], v2p[i]]
            .iter()
            .all(|v| v.is_finite());
        if !ok {
            continue;
        }
        sums[0] += c.x1[i];
        sums[1] += c.x2[i];
        sums[2] += rig.m1_kg * a1[i] + rig.d_n_s_per_m * v1s[i];
        sums[3] += rig.d_n_s_per_m * v2p[i];
        sums[4] += harmonic(c.t[i]);
        cnt += 1;
    }
    (sums, cnt)
}
