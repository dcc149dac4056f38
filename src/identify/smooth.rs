//! Numerical helpers of the identify stage: Savitzky–Golay smoothing and
//! differentiation that is correct at the edges of every contiguous block of
//! data (gaps are NaN), small dense least squares, robust statistics and a
//! tiny deterministic random generator for the bootstrap.
//!
//! The least-squares problems here have at most five unknowns and are
//! accumulated as normal equations per drive period (so the bootstrap only
//! adds small matrices); faer's own documentation says it is not the tool for
//! such tiny systems, so they are solved here by Gaussian elimination with
//! partial pivoting.

/// Solves the small dense system `a·x = b` (Gaussian elimination, partial
/// pivoting). `None` if the matrix is singular to working precision.
pub fn solve_small(a: &[Vec<f64>], b: &[f64]) -> Option<Vec<f64>> {
    let n = b.len();
    let mut m: Vec<Vec<f64>> = a.to_vec();
    let mut x = b.to_vec();
    let scale = a
        .iter()
        .flat_map(|r| r.iter())
        .fold(0.0f64, |s, v| s.max(v.abs()));
    if scale.is_nan() || scale <= 0.0 || !scale.is_finite() {
        return None;
    }
    for c in 0..n {
        let p = (c..n).max_by(|&i, &j| m[i][c].abs().total_cmp(&m[j][c].abs()))?;
        if m[p][c].abs() <= 1e-13 * scale {
            return None;
        }
        m.swap(c, p);
        x.swap(c, p);
        for r in c + 1..n {
            let f = m[r][c] / m[c][c];
            if f != 0.0 {
                for k in c..n {
                    m[r][k] -= f * m[c][k];
                }
                x[r] -= f * x[c];
            }
        }
    }
    for c in (0..n).rev() {
        let mut s = x[c];
        for k in c + 1..n {
            s -= m[c][k] * x[k];
        }
        x[c] = s / m[c][c];
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
}

/// Most unknowns of a [`Normal`] (a law's row: bias, four law terms at
/// most, two gains).
pub const NORMAL_MAX: usize = 6;

/// Normal equations `XᵀWX`, `XᵀWy`, `yᵀWy` of a weighted linear
/// least-squares problem with at most [`NORMAL_MAX`] unknowns, accumulated
/// row by row (and summable, which the period bootstrap uses). Fixed arrays
/// on the stack: the slip fit adds every slip sample to one of these tens
/// of times per log.
#[derive(Debug, Clone, PartialEq)]
pub struct Normal {
    /// XᵀWX (upper triangle).
    xtx: [[f64; NORMAL_MAX]; NORMAL_MAX],
    /// XᵀWy.
    xty: [f64; NORMAL_MAX],
    /// yᵀWy.
    pub yty: f64,
    /// Unknowns.
    p: usize,
    /// Number of rows accumulated.
    pub n: usize,
}

impl Normal {
    /// Empty normal equations for `p` unknowns (panics above
    /// [`NORMAL_MAX`]: a programming error).
    pub fn new(p: usize) -> Self {
        assert!(p <= NORMAL_MAX, "{p} unknowns, at most {NORMAL_MAX}");
        Self {
            xtx: [[0.0; NORMAL_MAX]; NORMAL_MAX],
            xty: [0.0; NORMAL_MAX],
            yty: 0.0,
            p,
            n: 0,
        }
    }

    /// Adds one row `x` (of the `p` unknowns) with target `y` and weight
    /// `w` (upper triangle of XᵀWX only; [`Normal::solve`] mirrors it).
    #[inline]
    pub fn add(&mut self, x: &[f64], y: f64, w: f64) {
        let p = self.p;
        let x = &x[..p];
        for i in 0..p {
            let wx = w * x[i];
            let row = &mut self.xtx[i];
            for j in i..p {
                row[j] += wx * x[j];
            }
            self.xty[i] += wx * y;
        }
        self.yty += w * y * y;
        self.n += 1;
    }

    /// [`Normal::add`] for the entries that do not involve unknown `col`
    /// (and yᵀWy, the row count): with [`Normal::add_column`] of the same
    /// rows, in the same order, the same sums bit for bit. A regression
    /// whose column `col` alone changes (the velocity-scale search)
    /// accumulates the rest once.
    pub fn add_except(&mut self, col: usize, x: &[f64], y: f64, w: f64) {
        let p = self.p;
        let x = &x[..p];
        for i in (0..p).filter(|&i| i != col) {
            let wx = w * x[i];
            let row = &mut self.xtx[i];
            for j in (i..p).filter(|&j| j != col) {
                row[j] += wx * x[j];
            }
            self.xty[i] += wx * y;
        }
        self.yty += w * y * y;
        self.n += 1;
    }

    /// [`Normal::add`] for the entries that involve unknown `col` only
    /// (see [`Normal::add_except`]).
    #[inline]
    pub fn add_column(&mut self, col: usize, x: &[f64], y: f64, w: f64) {
        let p = self.p;
        let x = &x[..p];
        for i in 0..col {
            self.xtx[i][col] += (w * x[i]) * x[col];
        }
        let wx = w * x[col];
        let row = &mut self.xtx[col];
        for j in col..p {
            row[j] += wx * x[j];
        }
        self.xty[col] += wx * y;
    }

    /// Adds another accumulation (same size).
    pub fn add_all(&mut self, o: &Normal) {
        for i in 0..self.p {
            for j in 0..self.p {
                self.xtx[i][j] += o.xtx[i][j];
            }
            self.xty[i] += o.xty[i];
        }
        self.yty += o.yty;
        self.n += o.n;
    }

    /// XᵀWX with both triangles.
    pub fn full(&self) -> Vec<Vec<f64>> {
        let p = self.p;
        let mut m: Vec<Vec<f64>> = self.xtx[..p].iter().map(|r| r[..p].to_vec()).collect();
        for i in 0..p {
            for j in 0..i {
                m[i][j] = m[j][i];
            }
        }
        m
    }

    /// XᵀWy.
    pub fn xty(&self) -> &[f64] {
        &self.xty[..self.p]
    }

    /// The least-squares solution, if the problem is well posed.
    pub fn solve(&self) -> Option<Vec<f64>> {
        solve_small(&self.full(), self.xty())
    }
}

/// Savitzky–Golay weights for the `deriv`-th derivative at offset 0 of a
/// polynomial of degree `degree` fitted to samples at integer offsets
/// `lo..=hi` (lo ≤ 0 ≤ hi), with sample spacing `dt`.
pub fn savgol_weights(lo: i64, hi: i64, degree: usize, deriv: usize, dt: f64) -> Option<Vec<f64>> {
    let p = degree + 1;
    let n = (hi - lo + 1) as usize;
    if n < p || deriv > degree {
        return None;
    }
    // Offsets scaled to about [-1, 1] for conditioning.
    let s = (hi.max(-lo).max(1)) as f64;
    let z: Vec<f64> = (lo..=hi).map(|j| j as f64 / s).collect();
    let mut vtv = vec![vec![0.0; p]; p];
    for &zj in &z {
        let mut pw = vec![1.0; p];
        for k in 1..p {
            pw[k] = pw[k - 1] * zj;
        }
        for a in 0..p {
            for b in 0..p {
                vtv[a][b] += pw[a] * pw[b];
            }
        }
    }
    // Row `deriv` of (VᵀV)⁻¹: solve (VᵀV) c = e_deriv (symmetric).
    let mut e = vec![0.0; p];
    e[deriv] = 1.0;
    let c = solve_small(&vtv, &e)?;
    let fact: f64 = (1..=deriv).map(|k| k as f64).product();
    let unit = fact / (s * dt).powi(deriv as i32);
    Some(
        z.iter()
            .map(|&zj| {
                let mut acc = 0.0;
                let mut pw = 1.0;
                for ck in c.iter() {
                    acc += ck * pw;
                    pw *= zj;
                }
                acc * unit
            })
            .collect(),
    )
}

/// Maximal runs `[start, end)` of finite values.
pub fn finite_blocks(y: &[f64]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut i = 0;
    while i < y.len() {
        if !y[i].is_finite() {
            i += 1;
            continue;
        }
        let s = i;
        while i < y.len() && y[i].is_finite() {
            i += 1;
        }
        out.push((s, i));
    }
    out
}

/// Savitzky–Golay filter (smoothing for `deriv` = 0, differentiation
/// otherwise) with window `2·half + 1`, applied separately to every
/// contiguous block of finite samples. Near a block's edge the window is
/// shifted inside the block (not padded), so the result is the derivative of
/// the local least-squares polynomial there too. Blocks shorter than
/// `degree + 2` samples give NaN.
pub fn savgol(y: &[f64], dt: f64, half: usize, degree: usize, deriv: usize) -> Vec<f64> {
    savgol_within(y, dt, half, degree, deriv, 0..y.len())
}

/// [`savgol`] of `y` at the samples `keep` only (NaN elsewhere): the same
/// values there, bit for bit, without the edge windows' weights of the
/// samples not wanted (a window's amplitude smooths a slice with margins
/// whose edge weights were most of its cost).
pub fn savgol_within(
    y: &[f64],
    dt: f64,
    half: usize,
    degree: usize,
    deriv: usize,
    keep: std::ops::Range<usize>,
) -> Vec<f64> {
    let mut out = vec![f64::NAN; y.len()];
    let h = half as i64;
    let interior = savgol_weights(-h, h, degree, deriv, dt);
    for (s, e) in finite_blocks(y) {
        let n = e - s;
        if n < degree + 2 {
            continue;
        }
        let w = (2 * half + 1).min(n) as i64;
        for i in s.max(keep.start)..e.min(keep.end) {
            let ii = i as i64;
            // Window [a, a + w) inside [s, e), as centred on i as possible.
            let a = (ii - w / 2).clamp(s as i64, e as i64 - w);
            let (lo, hi) = (a - ii, a + w - 1 - ii);
            let edge;
            let weights = if lo == -h && hi == h {
                interior.as_deref()
            } else {
                edge = savgol_weights(lo, hi, degree.min(w as usize - 1), deriv, dt);
                edge.as_deref()
            };
            if let Some(wt) = weights {
                let mut acc = 0.0;
                for (k, wk) in wt.iter().enumerate() {
                    acc += wk * y[(a as usize) + k];
                }
                out[i] = acc;
            }
        }
    }
    out
}

/// Integrated autocorrelation time of residuals `r` (initial positive
/// sequence: lags are summed until the autocorrelation turns negative),
/// counting only pairs (k, k + lag) that `same_run` says lie in one
/// contiguous run; lags up to `max_lag`, stopping when fewer than
/// `min_pairs` pairs remain (also the least n to estimate anything).
pub fn tau_int(
    r: &[f64],
    max_lag: usize,
    min_pairs: usize,
    same_run: impl Fn(usize, usize) -> bool,
) -> f64 {
    let n = r.len();
    if n < min_pairs {
        return 1.0;
    }
    let mean = r.iter().sum::<f64>() / n as f64;
    let var = r.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n as f64;
    if var <= 0.0 {
        return 1.0;
    }
    let mut tau = 1.0;
    for lag in 1..max_lag.min(n / 2) {
        let (mut s, mut m) = (0.0, 0usize);
        for k in 0..n - lag {
            if same_run(k, lag) {
                s += (r[k] - mean) * (r[k + lag] - mean);
                m += 1;
            }
        }
        if m < min_pairs {
            break;
        }
        let rho = s / m as f64 / var;
        if rho <= 0.0 {
            break;
        }
        tau += 2.0 * rho;
    }
    tau
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stats::Rng;

    /// `savgol_within` gives `savgol`'s values bit for bit on the kept
    /// samples (edges of the record and of a gap included) and NaN
    /// elsewhere.
    #[test]
    fn savgol_within_is_savgol_on_the_kept_samples() {
        let mut rng = Rng::new(7);
        let mut y: Vec<f64> = (0..300)
            .map(|i| (i as f64 * 0.05).sin() + 0.01 * rng.normal())
            .collect();
        for v in y.iter_mut().skip(140).take(5) {
            *v = f64::NAN;
        }
        for deriv in [0, 1] {
            let full = savgol(&y, 1e-3, 12, 4, deriv);
            for keep in [0..300, 0..20, 100..160, 280..300, 150..150] {
                let part = savgol_within(&y, 1e-3, 12, 4, deriv, keep.clone());
                for (i, (p, f)) in part.iter().zip(&full).enumerate() {
                    if keep.contains(&i) {
                        assert_eq!(p.to_bits(), f.to_bits(), "sample {i}");
                    } else {
                        assert!(p.is_nan(), "sample {i}");
                    }
                }
            }
        }
    }

    #[test]
    fn savgol_differentiates_cubics_exactly_interior_and_edges() {
        // A cubic is reproduced exactly by a degree-3 local fit, so its
        // derivative is exact everywhere, edges and both sides of a gap.
        let dt = 1e-3;
        let f = |t: f64| 2.0 + 3.0 * t - 40.0 * t * t + 500.0 * t * t * t;
        let df = |t: f64| 3.0 - 80.0 * t + 1500.0 * t * t;
        let mut y: Vec<f64> = (0..200).map(|i| f(i as f64 * dt)).collect();
        for v in y.iter_mut().skip(90).take(7) {
            *v = f64::NAN;
        }
        let d = savgol(&y, dt, 6, 3, 1);
        for (i, di) in d.iter().enumerate() {
            if y[i].is_finite() {
                assert!((di - df(i as f64 * dt)).abs() < 1e-7, "i={i} {di}");
            } else {
                assert!(di.is_nan());
            }
        }
        let s = savgol(&y, dt, 6, 3, 0);
        for i in [0usize, 5, 89, 97, 199] {
            assert!((s[i] - f(i as f64 * dt)).abs() < 1e-10);
        }
    }

    #[test]
    fn savgol_derivative_beats_finite_difference_on_noise() {
        let dt = 1e-3;
        let mut rng = Rng::new(7);
        let y: Vec<f64> = (0..2000)
            .map(|i| (i as f64 * dt * 10.0).sin() + 1e-3 * rng.normal())
            .collect();
        let d = savgol(&y, dt, 10, 3, 1);
        let fd: Vec<f64> = y.windows(2).map(|w| (w[1] - w[0]) / dt).collect();
        let err = |i: usize, v: f64| v - 10.0 * (i as f64 * dt * 10.0).cos();
        let rms_sg = (d
            .iter()
            .enumerate()
            .map(|(i, v)| err(i, *v).powi(2))
            .sum::<f64>()
            / d.len() as f64)
            .sqrt();
        let rms_fd = (fd
            .iter()
            .enumerate()
            .map(|(i, v)| err(i, *v).powi(2))
            .sum::<f64>()
            / fd.len() as f64)
            .sqrt();
        assert!(rms_sg < rms_fd / 10.0, "{rms_sg} vs {rms_fd}");
    }

    #[test]
    fn a_column_accumulated_apart_gives_the_same_sums_bit_for_bit() {
        let rows: Vec<[f64; 5]> = (0..50)
            .map(|k| {
                let t = k as f64 * 0.37;
                [1.0, t.sin(), (-t).exp() * 3.1, t * t - 2.0, t.cos() / 7.0]
            })
            .collect();
        for col in 0..5 {
            let (mut whole, mut apart) = (Normal::new(5), Normal::new(5));
            for (k, x) in rows.iter().enumerate() {
                let (y, w) = (0.3 * k as f64 - 1.0, 1.0 + (k % 3) as f64 * 0.25);
                whole.add(x, y, w);
                apart.add_except(col, x, y, w);
            }
            for (k, x) in rows.iter().enumerate() {
                let (y, w) = (0.3 * k as f64 - 1.0, 1.0 + (k % 3) as f64 * 0.25);
                apart.add_column(col, x, y, w);
            }
            assert_eq!(whole, apart, "column {col}");
        }
    }

    #[test]
    fn normal_equations_recover_a_line() {
        let mut ne = Normal::new(2);
        for i in 0..10 {
            let x = i as f64;
            ne.add(&[1.0, x], 1.5 - 0.25 * x, 1.0);
        }
        let c = ne.solve().unwrap();
        assert!((c[0] - 1.5).abs() < 1e-12 && (c[1] + 0.25).abs() < 1e-12);
    }

    #[test]
    fn robust_statistics() {
        use crate::stats::{mad_sigma, median, quantile};
        assert_eq!(median(&[3.0, 1.0, 2.0, f64::NAN]), 2.0);
        assert!((quantile(&[0.0, 1.0, 2.0, 3.0, 4.0], 0.25) - 1.0).abs() < 1e-12);
        let mut rng = Rng::new(1);
        let v: Vec<f64> = (0..20000).map(|_| 2.0 * rng.normal()).collect();
        assert!((mad_sigma(&v) - 2.0).abs() < 0.05);
    }
}
