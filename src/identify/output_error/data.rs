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

/// A sample column shared between copies of [`Data`] (and with the
/// contact force's signals).
pub(super) use crate::ingest::Column;

/// The data the cost needs (owned; the columns shared, so a copy with
/// perturbed gains copies no column).
#[derive(Debug, Clone)]
pub(super) struct Data {
    pub(super) t: Column,
    pub(super) x1: Column,
    pub(super) x2: Column,
    pub(super) x1s: Column,
    pub(super) v1s: Column,
    pub(super) x2s: Column,
    pub(super) v2s: Column,
    /// Drive channel minus its offset (m), for the sampled drive.
    pub(super) x0: Column,
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
    pub(super) a2: Option<(Column, f64)>,
    /// Profile the x1, x2 lags behind the drive out of the residuals.
    pub(super) delays: bool,
    /// Sensor gains applied as the columns are read (x0; x1 to x1, x1s
    /// and v1s; x2 to x2 and x2s; v2 to v2s): a copy with perturbed gains
    /// shares every column ([`Data::scaled`]).
    pub(super) gains: Gains,
}

impl Data {
    /// x1 at sample `j`, with its gain.
    pub(super) fn x1_at(&self, j: usize) -> f64 {
        self.x1[j] * self.gains.x1
    }
    /// x2 at sample `j`, with its gain.
    pub(super) fn x2_at(&self, j: usize) -> f64 {
        self.x2[j] * self.gains.x2
    }
    /// Smoothed x1 at sample `j`, with x1's gain.
    pub(super) fn x1s_at(&self, j: usize) -> f64 {
        self.x1s[j] * self.gains.x1
    }
    /// Smoothed ẋ1 at sample `j`, with x1's gain.
    pub(super) fn v1s_at(&self, j: usize) -> f64 {
        self.v1s[j] * self.gains.x1
    }
    /// Smoothed x2 at sample `j`, with x2's gain.
    pub(super) fn x2s_at(&self, j: usize) -> f64 {
        self.x2s[j] * self.gains.x2
    }
    /// Smoothed ẋ2 at sample `j`, with v2's gain.
    pub(super) fn v2s_at(&self, j: usize) -> f64 {
        self.v2s[j] * self.gains.v2
    }
    /// The drive at sample `j`, with its gain.
    pub(super) fn x0_at(&self, j: usize) -> f64 {
        self.x0[j] * self.gains.x0
    }

    /// The same data with the drive record shifted by `s0` and x2's
    /// records by `s2` (s; the value stamped t taken at t + s), to first
    /// order: x(t + s) ≈ x(t) + s·ẋ(t) with central differences (0 where a
    /// neighbour is missing). The harmonic drive shifts its phase. For the
    /// calibration budget of the channel alignment.
    pub(super) fn shifted(&self, s0: f64, s2: f64) -> Data {
        let mut d = self.clone();
        let dt = self.dt;
        let shift = |x: &Column, of: &Column, s: f64| -> Column {
            let n = x.len();
            (0..n)
                .map(|i| {
                    let slope = if i > 0 && i + 1 < n {
                        (of[i + 1] - of[i - 1]) / (2.0 * dt)
                    } else {
                        f64::NAN
                    };
                    x[i] + if slope.is_finite() { s * slope } else { 0.0 }
                })
                .collect()
        };
        if s0 != 0.0 {
            d.phase = self.phase - 2.0 * std::f64::consts::PI * self.freq * s0;
            d.x0 = shift(&self.x0, &self.x0, s0);
        }
        if s2 != 0.0 {
            d.x2 = shift(&self.x2, &self.x2s, s2);
            d.x2s = shift(&self.x2s, &self.x2s, s2);
            d.v2s = shift(&self.v2s, &self.v2s, s2);
        }
        d
    }

    /// The same data with the sensor gains multiplied by `g` (x0, x1, x2,
    /// v2): every column shared, the gains applied as they are read (the
    /// same products as scaled copies of the columns, bit for bit; a copy
    /// per perturbed gain was up to three columns of a long log).
    pub(super) fn scaled(&self, g: &Gains) -> Data {
        let mut d = self.clone();
        d.gains = Gains {
            x0: self.gains.x0 * g.x0,
            x1: self.gains.x1 * g.x1,
            x2: self.gains.x2 * g.x2,
            v2: self.gains.v2 * g.v2,
            // (The accelerometer's column is not scaled, as before.)
            a2: self.gains.a2,
        };
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
