//! The compared data of a log: the measured positions, the drive, the
//! shooting segments and their anchors.

use super::*;

/// A shooting start.
#[derive(Debug, Clone, Copy)]
pub(super) struct Anchor {
    pub(super) i: usize,
    /// Mean x2 over the stick's inner half (stick anchors).
    pub(super) x2_stick: Option<f64>,
}

/// The data the cost needs (owned, so a copy with perturbed gains is cheap).
#[derive(Debug, Clone)]
pub(super) struct Data {
    pub(super) t: Vec<f64>,
    pub(super) x1: Vec<f64>,
    pub(super) x2: Vec<f64>,
    pub(super) x1s: Vec<f64>,
    pub(super) v1s: Vec<f64>,
    pub(super) x2s: Vec<f64>,
    pub(super) v2s: Vec<f64>,
    /// Drive channel minus its offset (m), for the sampled drive.
    pub(super) x0: Vec<f64>,
    pub(super) anchors: Vec<Anchor>,
    pub(super) segs: Vec<(usize, usize)>,
    /// The compared samples of each segment: every stride-th sample after
    /// its start, up to its end, where x1 and x2 are both measured; their
    /// index and dimensionless time τ = (t − t_start)·ω from the start.
    pub(super) compared: Vec<Vec<(usize, f64)>>,
    /// Drive amplitude, frequency (Hz) and phase of `A·cos(2πf·t − φ)`.
    pub(super) a: f64,
    pub(super) freq: f64,
    pub(super) phase: f64,
    pub(super) drive: DriveModel,
    pub(super) dt: f64,
    /// Per-sample averages: x1, x2, M1·ẍ1 + d·ẋ1, d·ẋ2, drive.
    pub(super) means: [f64; 5],
    pub(super) sig: (f64, f64),
    /// The accelerometer (m/s², NaN where it has no data) and its noise,
    /// if the log has one.
    pub(super) a2: Option<(Vec<f64>, f64)>,
    /// Profile the x1, x2 lags behind the drive out of the residuals.
    pub(super) delays: bool,
}

impl Data {
    /// The same data with the sensor gains multiplied by `g` (x0, x1, x2, v2).
    pub(super) fn scaled(&self, g: &Gains) -> Data {
        let s = |v: &[f64], k: f64| v.iter().map(|x| x * k).collect::<Vec<_>>();
        let mut d = self.clone();
        d.x1 = s(&self.x1, g.x1);
        d.x1s = s(&self.x1s, g.x1);
        d.v1s = s(&self.v1s, g.x1);
        d.x2 = s(&self.x2, g.x2);
        d.x2s = s(&self.x2s, g.x2);
        d.v2s = s(&self.v2s, g.v2);
        d.x0 = s(&self.x0, g.x0);
        d.a = self.a * g.x0;
        for an in d.anchors.iter_mut() {
            an.x2_stick = an.x2_stick.map(|x| x * g.x2);
        }
        let m = self.means;
        d.means = [
            m[0] * g.x1,
            m[1] * g.x2,
            m[2] * g.x1,
            m[3] * g.x2,
            m[4] * g.x0,
        ];
        d.sig = (self.sig.0 * g.x1, self.sig.1 * g.x2);
        d
    }
}
