//! EXPERIMENT (exp13-lm): Levenberg–Marquardt on the projected residual
//! vector, as an alternative to Nelder–Mead in [`Refinement::minimise`].
//!
//! Selected by `STICKSLIP_OE_MIN=lm|hybrid` (default: Nelder–Mead).
//! Knobs (environment, for the experiment only):
//! * `STICKSLIP_LM_FD`: finite-difference step as a fraction of the
//!   Nelder–Mead steps (default 0.01: 0.1, 0.3, 1 leave larger gaps in
//!   the kinked costs of misfit families);
//! * `STICKSLIP_LM_CENTRAL=1`: central differences (default forward);
//! * `STICKSLIP_LM_RTOL`: stop when an accepted step lowers the cost by
//!   less than this fraction (default 1e-12);
//! * `STICKSLIP_POLISH_ITERS`: Nelder–Mead iterations of the hybrid's
//!   polish (default 100), `STICKSLIP_POLISH_STEP` its simplex steps as a
//!   fraction of the Nelder–Mead steps (default 0.1);
//! * `STICKSLIP_OE_TRACE=1`: one line per pass on stderr.

use super::*;
use crate::identify::smooth::solve_small;

/// Which minimiser refines each family.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Minimiser {
    /// Nelder–Mead (argmin).
    NelderMead,
    /// Levenberg–Marquardt on the residual vector.
    Lm,
    /// Levenberg–Marquardt, then a short Nelder–Mead polish.
    Hybrid,
}

impl Minimiser {
    /// From `STICKSLIP_OE_MIN` (nm, lm, hybrid); Nelder–Mead by default.
    pub fn from_env() -> Self {
        match std::env::var("STICKSLIP_OE_MIN").as_deref() {
            Ok("lm") => Minimiser::Lm,
            Ok("hybrid") => Minimiser::Hybrid,
            _ => Minimiser::NelderMead,
        }
    }
}

pub(super) fn env_f64(name: &str, default: f64) -> f64 {
    std::env::var(name)
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(default)
}

pub(super) fn trace() -> bool {
    std::env::var("STICKSLIP_OE_TRACE").is_ok_and(|s| s == "1")
}

/// The residual vector whose squared norm is the cost exactly (the
/// penalty of Rd > Rs folded in: `Σr²(1 + P) + P·n` with P = 1e3·excess,
/// recovered from the cost and the raw residuals).
fn residuals(prob: &Problem<'_>, proj: &Proj, th: &[f64]) -> Option<(f64, Vec<f64>)> {
    let mut r = Res::new();
    let c = prob.eval(th, Some(proj), Some(&mut r))?;
    let s: f64 = r.iter().map(|x| x.1 * x.1 + x.2 * x.2).sum();
    let n = r.len() as f64;
    let pen = if c - s > 1e-10 * c.max(1.0) {
        (c - s) / (s + n)
    } else {
        0.0
    };
    let sf = (1.0 + pen).sqrt();
    let mut v = Vec::with_capacity(2 * r.len() + 1);
    for x in &r {
        v.push(x.1 * sf);
        v.push(x.2 * sf);
    }
    v.push((pen * n).sqrt());
    Some((c, v))
}

impl Refinement {
    /// Levenberg–Marquardt (Marquardt's diagonal scaling, Nielsen's
    /// damping update) from `th0`; finite-difference steps `fd·step`.
    /// Returns θ̂, its cost and the number of Jacobians.
    pub(super) fn lm(
        &self,
        prob: &Problem<'_>,
        proj: &Proj,
        th0: &[f64],
        step: &[f64],
        max_iters: u64,
    ) -> Result<(Vec<f64>, f64, u64), String> {
        let fail = "the refined law cannot be simulated";
        let fd = env_f64("STICKSLIP_LM_FD", 0.01);
        let central = std::env::var("STICKSLIP_LM_CENTRAL").is_ok_and(|s| s == "1");
        let rtol = env_f64("STICKSLIP_LM_RTOL", 1e-12);
        let p = th0.len();
        let mut th = th0.to_vec();
        let (mut c, mut r) = residuals(prob, proj, &th).ok_or(fail)?;
        let mut lambda = 1e-3;
        let mut nu = 2.0;
        let mut it = 0u64;
        'outer: while it < max_iters {
            it += 1;
            // Jacobian, column by column.
            let mut jac: Vec<Vec<f64>> = Vec::with_capacity(p);
            for j in 0..p {
                let h = fd * step[j];
                let col = if central {
                    let mut tp = th.clone();
                    tp[j] += h;
                    let mut tm = th.clone();
                    tm[j] -= h;
                    match (residuals(prob, proj, &tp), residuals(prob, proj, &tm)) {
                        (Some((_, rp)), Some((_, rm))) if rp.len() == r.len() && rm.len() == r.len() => rp
                            .iter()
                            .zip(&rm)
                            .map(|(a, b)| (a - b) / (2.0 * h))
                            .collect(),
                        _ => return Err(fail.into()),
                    }
                } else {
                    let mut tp = th.clone();
                    tp[j] += h;
                    let (hh, rp) = match residuals(prob, proj, &tp) {
                        Some((_, rp)) if rp.len() == r.len() => (h, rp),
                        _ => {
                            tp[j] = th[j] - h;
                            match residuals(prob, proj, &tp) {
                                Some((_, rp)) if rp.len() == r.len() => (-h, rp),
                                _ => return Err(fail.into()),
                            }
                        }
                    };
                    rp.iter().zip(&r).map(|(a, b)| (a - b) / hh).collect()
                };
                jac.push(col);
            }
            let mut a = vec![vec![0.0; p]; p];
            let mut g = vec![0.0; p];
            for i in 0..p {
                g[i] = dot(&jac[i], &r);
                for k in i..p {
                    a[i][k] = dot(&jac[i], &jac[k]);
                    a[k][i] = a[i][k];
                }
            }
            let dmax = (0..p).map(|i| a[i][i]).fold(0.0f64, f64::max);
            let d: Vec<f64> = (0..p).map(|i| a[i][i].max(1e-12 * dmax).sqrt()).collect();
            if !(dmax > 0.0 && dmax.is_finite()) {
                break;
            }
            loop {
                let mut m = vec![vec![0.0; p]; p];
                for i in 0..p {
                    for k in 0..p {
                        m[i][k] = a[i][k] / (d[i] * d[k]);
                    }
                    m[i][i] += lambda;
                }
                let b: Vec<f64> = (0..p).map(|i| -g[i] / d[i]).collect();
                let Some(z) = solve_small(&m, &b) else {
                    lambda *= nu;
                    nu *= 2.0;
                    if lambda > 1e12 {
                        break 'outer;
                    }
                    continue;
                };
                let delta: Vec<f64> = (0..p).map(|i| z[i] / d[i]).collect();
                if (0..p).all(|i| delta[i].abs() < 1e-9 * step[i]) {
                    break 'outer;
                }
                // Predicted decrease of the linear model.
                let mut pred = -2.0 * dot(&delta, &g);
                for i in 0..p {
                    for k in 0..p {
                        pred -= delta[i] * a[i][k] * delta[k];
                    }
                }
                let tn: Vec<f64> = th.iter().zip(&delta).map(|(t, s)| t + s).collect();
                match residuals(prob, proj, &tn) {
                    Some((cn, rn)) if cn < c && rn.len() == r.len() => {
                        let rho = (c - cn) / pred.max(1e-300);
                        let rel = (c - cn) / c;
                        th = tn;
                        c = cn;
                        r = rn;
                        lambda *= (1.0f64 / 3.0).max(1.0 - (2.0 * rho - 1.0).powi(3));
                        lambda = lambda.max(1e-12);
                        nu = 2.0;
                        if rel < rtol {
                            break 'outer;
                        }
                        break;
                    }
                    _ => {
                        lambda *= nu;
                        nu *= 2.0;
                        if lambda > 1e12 {
                            break 'outer;
                        }
                    }
                }
            }
        }
        Ok((th, c, it))
    }

    /// Nelder–Mead from `th` with simplex steps `steps`.
    pub(super) fn nm(
        &self,
        prob: &Problem<'_>,
        proj: &Proj,
        th: &[f64],
        steps: &[f64],
        max_iters: u64,
    ) -> Result<(Vec<f64>, f64, u64), String> {
        let mut simplex = vec![th.to_vec()];
        for (k, s) in steps.iter().enumerate() {
            let mut p = th.to_vec();
            p[k] += s;
            simplex.push(p);
        }
        let c0 = prob.eval(th, Some(proj), None).unwrap_or(1.0);
        let solver = NelderMead::new(simplex)
            .with_sd_tolerance(1e-8 * c0.max(1.0))
            .map_err(|e| e.to_string())?;
        let res = Executor::new(Cost(prob, Some(proj)), solver)
            .configure(|s| s.max_iters(max_iters))
            .run()
            .map_err(|e| e.to_string())?;
        let th = res.state.best_param.clone().ok_or("no optimum")?;
        Ok((th, res.state.best_cost, res.state.iter))
    }
}
