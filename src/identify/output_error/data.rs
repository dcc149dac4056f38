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

#[cfg(test)]
mod tests {
    use super::*;

    /// A 2-s record at 1 kHz of harmonic columns (x0 = cos, x1 = 2 sin,
    /// x2 = sin, x2's smoothed copy and its derivative alike).
    fn harmonic_data(f: f64) -> Data {
        let dt = 1e-3;
        let w = 2.0 * std::f64::consts::PI * f;
        let t: Vec<f64> = (0..2000).map(|i| i as f64 * dt).collect();
        let col = |g: &dyn Fn(f64) -> f64| -> Column { t.iter().map(|&t| g(t)).collect() };
        Data {
            t: col(&|t| t),
            x1: col(&|t| 2.0 * (w * t).sin()),
            x2: col(&|t| (w * t).sin()),
            x1s: col(&|t| 2.0 * (w * t).sin()),
            v1s: col(&|t| 2.0 * w * (w * t).cos()),
            x2s: col(&|t| (w * t).sin()),
            v2s: col(&|t| w * (w * t).cos()),
            x0: col(&|t| (w * t).cos()),
            anchors: Vec::new(),
            segs: Vec::new(),
            compared: Vec::new(),
            a: 1.0,
            freq: f,
            phase: 0.3,
            drive: DriveModel::Harmonic,
            dt,
            means: [0.0; 5],
            sig: (1e-6, 1e-6),
            a2: None,
            delays: false,
            gains: Gains::default(),
        }
    }

    /// The shifted records are the signals at t + s to second order (a
    /// 0.5-ms shift of a 5-Hz record: |s·ω|² / 2 ≈ 1.2e-4, central
    /// differences (ω·dt)²/6 ≈ 1.6e-4 relative), the drive's phase moves
    /// by −ω·s, the unshifted channels keep their columns (shared, not
    /// copied), and the samples without two neighbours are left as they
    /// were.
    #[test]
    fn shifted_records_are_the_signals_a_shift_later() {
        let f = 5.0;
        let w = 2.0 * std::f64::consts::PI * f;
        let d = harmonic_data(f);
        let (s0, s2) = (-0.5e-3, 0.5e-3);
        let e = d.shifted(s0, s2);
        let n = d.t.len();
        let mut worst: [f64; 4] = [0.0; 4];
        for i in 1..n - 1 {
            let t = d.t[i];
            let errs = [
                e.x0[i] - (w * (t + s0)).cos(),
                e.x2[i] - (w * (t + s2)).sin(),
                e.x2s[i] - (w * (t + s2)).sin(),
                e.v2s[i] - w * (w * (t + s2)).cos(),
            ];
            for (k, err) in errs.iter().enumerate() {
                worst[k] = worst[k].max(err.abs());
            }
        }
        let bound = (w * s2).powi(2) / 2.0 + s2.abs() * w * (w * d.dt).powi(2) / 6.0;
        for (k, wk) in worst.iter().enumerate() {
            let scale = if k == 3 { w } else { 1.0 };
            assert!(
                *wk <= 1.01 * bound * scale,
                "column {k}: {wk:e} > {:e}",
                bound * scale
            );
            // The first-order term is taken: an unshifted record would be
            // off by |s·ω| ≈ 1.6e-2.
            assert!(*wk < 0.05 * (w * s2).abs() * scale);
        }
        assert!((e.phase - (d.phase - w * s0)).abs() < 1e-15);
        assert!(std::sync::Arc::ptr_eq(&e.x1, &d.x1));
        assert!(std::sync::Arc::ptr_eq(&e.v1s, &d.v1s));
        assert_eq!((e.x0[0], e.x2[n - 1]), (d.x0[0], d.x2[n - 1]));
        // No shift: every column shared and the phase unchanged.
        let z = d.shifted(0.0, 0.0);
        assert!(std::sync::Arc::ptr_eq(&z.x0, &d.x0) && std::sync::Arc::ptr_eq(&z.x2, &d.x2));
        assert_eq!(z.phase, d.phase);
    }
}
