//! Least squares with a cluster-robust covariance, and the zero-phase
//! smoothing and derivatives of sampled signals the regressions read
//! (channel delays in `ingest`, the spring screen in `identify`).

// Index loops mirror the formulas (several arrays indexed together).
#![allow(clippy::needless_range_loop)]

use super::student_t_quantile;

/// Width of the Gaussian low-pass applied to every signal before the
/// regressions of M1's equation (its σ, in drive periods; zero phase, so it
/// moves no channel in time). 1/40 of a period keeps the harmonics up to
/// about the 6th (the stick-slip content that separates x2's shift from its
/// gain) and damps the noise of ẍ1 (∝ σ^−2.5): on synthetic logs of two
/// rigs the shift's error fell from 0.13 ms RMS at σ = 3 ms to 0.05 ms at
/// 12 ms.
pub const SMOOTH_SIGMA_PERIODS: f64 = 1.0 / 40.0;

/// The sampling scales of a regression on a drive-periodic record.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Scales {
    /// Sample interval (s).
    pub dt: f64,
    /// The filter's σ in samples ([`SMOOTH_SIGMA_PERIODS`] of a period, at
    /// least 1.5).
    pub sigma: f64,
    /// Cluster length in samples: half a drive period (at least 20).
    pub block: usize,
}

impl Scales {
    /// The scales of a grid at `rate_hz` for a drive at `drive_hz` (0.5 s
    /// periods where it is unknown).
    pub fn of(rate_hz: f64, drive_hz: Option<f64>) -> Self {
        let dt = 1.0 / rate_hz;
        let period = drive_hz
            .filter(|f| f.is_finite() && *f > 0.0)
            .map_or(0.5, |f| 1.0 / f);
        Scales {
            dt,
            sigma: (SMOOTH_SIGMA_PERIODS * period / dt).max(1.5),
            block: ((0.5 * period / dt).round() as usize).max(20),
        }
    }
}

/// Zero-phase Gaussian low-pass (σ in samples); NaN wherever the window
/// holds a NaN or runs past an end.
pub fn gauss_smooth(y: &[f64], sigma: f64) -> Vec<f64> {
    let h = (3.0 * sigma).ceil().max(1.0) as usize;
    let w: Vec<f64> = (0..=2 * h)
        .map(|k| {
            let u = (k as f64 - h as f64) / sigma;
            (-0.5 * u * u).exp()
        })
        .collect();
    let sw: f64 = w.iter().sum();
    let n = y.len();
    let mut out = vec![f64::NAN; n];
    if n < 2 * h + 1 {
        return out;
    }
    for (i, o) in out.iter_mut().enumerate().take(n - h).skip(h) {
        *o = dot(&w, &y[i - h..=i + h]) / sw;
    }
    out
}

/// Σ a·b over equal-length slices, in four independent partial sums (so
/// the loop vectorises; NaN and ∞ propagate as in a plain sum).
fn dot(a: &[f64], b: &[f64]) -> f64 {
    let mut acc = [0.0; 4];
    let (ca, cb) = (a.chunks_exact(4), b.chunks_exact(4));
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        for j in 0..4 {
            acc[j] += x[j] * y[j];
        }
    }
    let tail: f64 = ra.iter().zip(rb).map(|(x, y)| x * y).sum();
    (acc[0] + acc[1]) + (acc[2] + acc[3]) + tail
}

/// Central-difference derivative (NaN at the ends and next to NaN).
pub fn deriv(y: &[f64], dt: f64) -> Vec<f64> {
    let n = y.len();
    let mut d = vec![f64::NAN; n];
    for i in 1..n.saturating_sub(1) {
        d[i] = (y[i + 1] - y[i - 1]) / (2.0 * dt);
    }
    d
}

/// Least squares with a cluster-robust covariance over contiguous blocks.
pub struct Ols {
    /// Coefficients.
    pub beta: Vec<f64>,
    /// Their covariance (cluster-robust, small-sample corrected).
    pub cov: Vec<Vec<f64>>,
    /// Residuals (NaN where a row was left out).
    pub resid: Vec<f64>,
    /// t quantile (97.5 %) for blocks − parameters degrees of freedom.
    pub tq: f64,
}

/// Solves the symmetric positive definite system `a x = b` (Cholesky);
/// `None` when `a` is singular.
fn solve_spd(a: &[Vec<f64>], b: &[f64]) -> Option<Vec<f64>> {
    let p = b.len();
    let mut l = vec![vec![0.0; p]; p];
    for i in 0..p {
        for j in 0..=i {
            let mut s = a[i][j];
            for k in 0..j {
                s -= l[i][k] * l[j][k];
            }
            if i == j {
                if s <= a[i][i].abs() * 1e-13 || s <= 0.0 {
                    return None;
                }
                l[i][i] = s.sqrt();
            } else {
                l[i][j] = s / l[j][j];
            }
        }
    }
    let mut z = vec![0.0; p];
    for i in 0..p {
        let mut s = b[i];
        for k in 0..i {
            s -= l[i][k] * z[k];
        }
        z[i] = s / l[i][i];
    }
    let mut x = vec![0.0; p];
    for i in (0..p).rev() {
        let mut s = z[i];
        for k in i + 1..p {
            s -= l[k][i] * x[k];
        }
        x[i] = s / l[i][i];
    }
    Some(x)
}

/// The sandwich `H⁻¹ M H⁻¹ · corr` of a cluster-robust covariance (`hinv`:
/// the inverse Hessian, `meat`: the sum of the clusters' score products,
/// `corr`: the small-sample factor K/(K − p)).
pub fn sandwich(hinv: &[Vec<f64>], meat: &[Vec<f64>], corr: f64) -> Vec<Vec<f64>> {
    let p = hinv.len();
    let mut cov = vec![vec![0.0; p]; p];
    for a in 0..p {
        for b in 0..p {
            let mut s = 0.0;
            for j in 0..p {
                for k in 0..p {
                    s += hinv[a][j] * meat[j][k] * hinv[k][b];
                }
            }
            cov[a][b] = s * corr;
        }
    }
    cov
}

/// `y ≈ Σ β_j x_j` over the rows where everything is finite; clusters of
/// `block` consecutive rows. Columns are scaled internally.
pub fn ols(cols: &[&[f64]], y: &[f64], block: usize) -> Option<Ols> {
    let p = cols.len();
    let n = y.len();
    let rows: Vec<usize> = (0..n)
        .filter(|&i| y[i].is_finite() && cols.iter().all(|c| c[i].is_finite()))
        .collect();
    if rows.len() < 20 * p {
        return None;
    }
    let scale: Vec<f64> = cols
        .iter()
        .map(|c| {
            let s = (rows.iter().map(|&i| c[i] * c[i]).sum::<f64>() / rows.len() as f64).sqrt();
            if s > 0.0 && s.is_finite() {
                s
            } else {
                1.0
            }
        })
        .collect();
    let mut xtx = vec![vec![0.0; p]; p];
    let mut xty = vec![0.0; p];
    let mut row = vec![0.0; p];
    for &i in &rows {
        for j in 0..p {
            row[j] = cols[j][i] / scale[j];
        }
        for j in 0..p {
            xty[j] += row[j] * y[i];
            for k in 0..=j {
                xtx[j][k] += row[j] * row[k];
            }
        }
    }
    for j in 0..p {
        for k in j + 1..p {
            xtx[j][k] = xtx[k][j];
        }
    }
    let b = solve_spd(&xtx, &xty)?;
    let mut resid = vec![f64::NAN; n];
    // Meat: Σ over blocks of g gᵀ, g = Σ_rows x_i r_i.
    let mut meat = vec![vec![0.0; p]; p];
    let mut g = vec![0.0; p];
    let mut clusters = 0usize;
    let mut current = usize::MAX;
    let flush = |g: &mut [f64], meat: &mut [Vec<f64>]| {
        for j in 0..p {
            for k in 0..p {
                meat[j][k] += g[j] * g[k];
            }
        }
        g.iter_mut().for_each(|v| *v = 0.0);
    };
    for &i in &rows {
        let blk = i / block.max(1);
        if blk != current {
            if current != usize::MAX {
                flush(&mut g, &mut meat);
            }
            current = blk;
            clusters += 1;
        }
        let mut fit = 0.0;
        for j in 0..p {
            row[j] = cols[j][i] / scale[j];
            fit += row[j] * b[j];
        }
        let r = y[i] - fit;
        resid[i] = r;
        for j in 0..p {
            g[j] += row[j] * r;
        }
    }
    flush(&mut g, &mut meat);
    if clusters <= p + 1 {
        return None;
    }
    // Cov = H⁻¹ M H⁻¹ · K/(K − p).
    let mut hinv = vec![vec![0.0; p]; p];
    for j in 0..p {
        let mut e = vec![0.0; p];
        e[j] = 1.0;
        let col = solve_spd(&xtx, &e)?;
        for k in 0..p {
            hinv[k][j] = col[k];
        }
    }
    let corr = clusters as f64 / (clusters - p) as f64;
    let mut cov = sandwich(&hinv, &meat, corr);
    for a in 0..p {
        for bb in 0..p {
            cov[a][bb] /= scale[a] * scale[bb];
        }
    }
    let beta = b.iter().zip(&scale).map(|(b, s)| b / s).collect();
    Some(Ols {
        beta,
        cov,
        resid,
        tq: student_t_quantile(0.975, (clusters - p) as f64),
    })
}

/// The ratio β_num/β_den with its delta-method variance.
pub fn ratio(o: &Ols, num: usize, den: usize) -> Option<(f64, f64)> {
    let (a, b) = (o.beta[num], o.beta[den]);
    if b == 0.0 || !a.is_finite() || !b.is_finite() {
        return None;
    }
    let s = a / b;
    let (ga, gb) = (1.0 / b, -a / (b * b));
    let var =
        ga * ga * o.cov[num][num] + 2.0 * ga * gb * o.cov[num][den] + gb * gb * o.cov[den][den];
    Some((s, var.max(0.0)))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The partial sums give the plain convolution to rounding, keep the
    /// ends NaN and let a NaN in the window through.
    #[test]
    fn gauss_smooth_is_the_plain_convolution() {
        let y: Vec<f64> = (0..200)
            .map(|i| (0.37 * i as f64).sin() + 1e-3 * (i % 7) as f64)
            .collect();
        for sigma in [0.3f64, 1.0, 2.5, 7.0] {
            let h = (3.0 * sigma).ceil().max(1.0) as usize;
            let w: Vec<f64> = (0..=2 * h)
                .map(|k| (-0.5 * ((k as f64 - h as f64) / sigma).powi(2)).exp())
                .collect();
            let sw: f64 = w.iter().sum();
            let s = gauss_smooth(&y, sigma);
            for i in 0..y.len() {
                if i < h || i + h >= y.len() {
                    assert!(s[i].is_nan());
                    continue;
                }
                let plain: f64 = (0..=2 * h).map(|k| w[k] * y[i + k - h]).sum::<f64>() / sw;
                assert!((s[i] - plain).abs() < 1e-14, "σ {sigma}, i {i}");
            }
        }
        let mut z = y.clone();
        z[100] = f64::NAN;
        let s = gauss_smooth(&z, 2.0);
        assert!(s[97].is_nan() && s[103].is_nan() && s[90].is_finite());
    }
}
