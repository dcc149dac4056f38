//! Small dense linear algebra for the engine's set-up work: the complex
//! eigen-decomposition of a phase matrix (faer), complex solves on fixed-size
//! arrays, and a matrix exponential for the degenerate cases the modal form
//! cannot represent (defective matrices, undamped forcing at an
//! eigenfrequency).

use num_complex::Complex;

/// Complex double.
pub type C64 = Complex<f64>;

/// Eigen-decomposition `A = V·diag(λ)·V⁻¹` of a real N×N matrix.
#[derive(Debug, Clone, Copy)]
pub struct Modal<const N: usize> {
    /// Eigenvalues λ.
    pub lambda: [C64; N],
    /// Right eigenvectors, column j for λj (stored `v[row][col]`).
    pub v: [[C64; N]; N],
    /// Inverse of `v`.
    pub vinv: [[C64; N]; N],
    /// ‖V‖∞·‖V⁻¹‖∞: the condition number that bounds the modal form's error.
    pub cond: f64,
}

/// Eigen-decomposes `a` with faer; `None` if faer does not converge or the
/// eigenvector matrix is singular.
pub fn modal<const N: usize>(a: &[[f64; N]; N]) -> Option<Modal<N>> {
    let m = faer::Mat::<f64>::from_fn(N, N, |i, j| a[i][j]);
    let evd = m.eigen().ok()?;
    let (u, s) = (evd.U(), evd.S());
    let mut lambda = [C64::new(0.0, 0.0); N];
    let mut v = [[C64::new(0.0, 0.0); N]; N];
    for j in 0..N {
        lambda[j] = s.column_vector()[j];
        for i in 0..N {
            v[i][j] = u[(i, j)];
        }
    }
    let vinv = inverse(&v)?;
    let cond = norm_inf(&v) * norm_inf(&vinv);
    if !cond.is_finite()
        || lambda
            .iter()
            .any(|l| !l.re.is_finite() || !l.im.is_finite())
    {
        return None;
    }
    Some(Modal {
        lambda,
        v,
        vinv,
        cond,
    })
}

fn norm_inf<const N: usize>(a: &[[C64; N]; N]) -> f64 {
    a.iter()
        .map(|r| r.iter().map(|z| z.norm()).sum::<f64>())
        .fold(0.0, f64::max)
}

/// Inverse by Gauss–Jordan with partial pivoting; `None` if singular.
pub fn inverse<const N: usize>(a: &[[C64; N]; N]) -> Option<[[C64; N]; N]> {
    let mut m = *a;
    let mut inv = [[C64::new(0.0, 0.0); N]; N];
    for (i, row) in inv.iter_mut().enumerate() {
        row[i] = C64::new(1.0, 0.0);
    }
    for col in 0..N {
        let piv = (col..N).max_by(|&i, &j| m[i][col].norm().total_cmp(&m[j][col].norm()))?;
        if m[piv][col].norm() == 0.0 || !m[piv][col].norm().is_finite() {
            return None;
        }
        m.swap(col, piv);
        inv.swap(col, piv);
        let p = C64::new(1.0, 0.0) / m[col][col];
        for j in 0..N {
            m[col][j] *= p;
            inv[col][j] *= p;
        }
        for i in 0..N {
            if i != col {
                let f = m[i][col];
                if f != C64::new(0.0, 0.0) {
                    for j in 0..N {
                        let (mc, ic) = (m[col][j], inv[col][j]);
                        m[i][j] -= f * mc;
                        inv[i][j] -= f * ic;
                    }
                }
            }
        }
    }
    Some(inv)
}

/// Solves `(z·I − A)·x = b` for complex z; `None` if singular to working
/// precision (z is an eigenvalue).
pub fn shifted_solve<const N: usize>(a: &[[f64; N]; N], z: C64, b: &[f64; N]) -> Option<[C64; N]> {
    let mut m = [[C64::new(0.0, 0.0); N]; N];
    for i in 0..N {
        for j in 0..N {
            m[i][j] = C64::new(-a[i][j], 0.0);
        }
        m[i][i] += z;
    }
    let scale = norm_inf(&m);
    let inv = inverse(&m)?;
    // Reject near-singular shifts: the particular solution would be swamped
    // by cancellation (resonance of an undamped mode).
    if norm_inf(&inv) * scale > 1e10 {
        return None;
    }
    let mut x = [C64::new(0.0, 0.0); N];
    for i in 0..N {
        for j in 0..N {
            x[i] += inv[i][j] * b[j];
        }
    }
    Some(x)
}

/// Real matrix inverse (for the constant particular solution).
pub fn real_inverse<const N: usize>(a: &[[f64; N]; N]) -> Option<[[f64; N]; N]> {
    let mut c = [[C64::new(0.0, 0.0); N]; N];
    for i in 0..N {
        for j in 0..N {
            c[i][j] = C64::new(a[i][j], 0.0);
        }
    }
    let inv = inverse(&c)?;
    let mut r = [[0.0; N]; N];
    for i in 0..N {
        for j in 0..N {
            r[i][j] = inv[i][j].re;
        }
    }
    Some(r)
}

/// Largest size of the augmented matrices used by [`expm`].
pub const MAX_AUG: usize = 7;

/// A small square matrix of size `n ≤ MAX_AUG` on a fixed array.
pub type Aug = [[f64; MAX_AUG]; MAX_AUG];

/// Matrix exponential `exp(M)` of the leading n×n block by scaling and
/// squaring with a degree-20 Taylor polynomial (‖M/2^s‖ ≤ 1/2, truncation
/// below 1e-25 relative). Slow but exact for any matrix, defective or not;
/// used only where the modal form is ill-conditioned.
pub fn expm(m: &Aug, n: usize) -> Aug {
    let norm = (0..n)
        .map(|i| (0..n).map(|j| m[i][j].abs()).sum::<f64>())
        .fold(0.0, f64::max);
    let mut s = 0;
    let mut scale = 1.0;
    while norm * scale > 0.5 && s < 1100 {
        scale *= 0.5;
        s += 1;
    }
    let mut a = [[0.0; MAX_AUG]; MAX_AUG];
    for i in 0..n {
        for j in 0..n {
            a[i][j] = m[i][j] * scale;
        }
    }
    // Horner: I + A(I + A/2(I + A/3(...))).
    let mut r = identity(n);
    for k in (1..=20).rev() {
        let ar = matmul(&a, &r, n);
        r = identity(n);
        for i in 0..n {
            for j in 0..n {
                r[i][j] += ar[i][j] / k as f64;
            }
        }
    }
    for _ in 0..s {
        r = matmul(&r, &r, n);
    }
    r
}

fn identity(n: usize) -> Aug {
    let mut r = [[0.0; MAX_AUG]; MAX_AUG];
    for (i, row) in r.iter_mut().enumerate().take(n) {
        row[i] = 1.0;
    }
    r
}

fn matmul(a: &Aug, b: &Aug, n: usize) -> Aug {
    let mut r = [[0.0; MAX_AUG]; MAX_AUG];
    for i in 0..n {
        for k in 0..n {
            let aik = a[i][k];
            if aik != 0.0 {
                for j in 0..n {
                    r[i][j] += aik * b[k][j];
                }
            }
        }
    }
    r
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn modal_reconstructs_matrix() {
        let a = [[0.0, 1.0], [-2.0, -0.1]];
        let md = modal(&a).unwrap();
        for i in 0..2 {
            for j in 0..2 {
                let mut s = C64::new(0.0, 0.0);
                for k in 0..2 {
                    s += md.v[i][k] * md.lambda[k] * md.vinv[k][j];
                }
                assert!((s.re - a[i][j]).abs() < 1e-14 && s.im.abs() < 1e-14);
            }
        }
    }

    /// exp of a rotation generator is the rotation (closed form).
    #[test]
    fn expm_rotation_and_jordan_block() {
        let mut m = [[0.0; MAX_AUG]; MAX_AUG];
        m[0][1] = -2.0;
        m[1][0] = 2.0;
        let e = expm(&m, 2);
        assert!((e[0][0] - 2f64.cos()).abs() < 1e-15);
        assert!((e[1][0] - 2f64.sin()).abs() < 1e-15);
        // Defective: exp([[a,1],[0,a]]) = e^a [[1,1],[0,1]].
        let mut j = [[0.0; MAX_AUG]; MAX_AUG];
        j[0][0] = -0.3;
        j[1][1] = -0.3;
        j[0][1] = 1.0;
        let e = expm(&j, 2);
        let ea = (-0.3f64).exp();
        assert!((e[0][0] - ea).abs() < 1e-15 && (e[0][1] - ea).abs() < 1e-15 && e[1][0] == 0.0);
    }
}
