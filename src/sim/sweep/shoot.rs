//! Stage 4 of a steady state: Newton shooting on the p-th return map, with
//! the exact Jacobian from the variational equations where it holds.

use faer::linalg::solvers::Solve;

use crate::sim::engine::{net_force, Init, Mode, Sim, Status};
use crate::sim::monodromy::Monodromy;
use std::sync::{Arc, OnceLock};

/// Shooting's variational set-up ([`Monodromy`]) for one model: made on
/// first use and shared by that model's engines at every η of a sweep (it
/// does not depend on η).
#[derive(Debug, Clone, Default)]
pub(super) struct MonodromyCache(Arc<OnceLock<Option<Monodromy>>>);

impl MonodromyCache {
    /// The set-up for `sim`'s model; `None` where it does not apply.
    pub(super) fn get(&self, sim: &Sim) -> Option<&Monodromy> {
        self.0.get_or_init(|| Monodromy::new(sim)).as_ref()
    }
}

/// A fixed point of the p-th return map found by [`shoot`].
pub(super) struct Shooting {
    /// The section state.
    pub(super) x: [f64; 4],
    /// Its contact mode.
    pub(super) mode: Mode,
    /// M2 sticks there (coordinates ζ1, ζ1', ζ2; else all four).
    pub(super) stuck: bool,
    /// Number of coordinates varied (3 stuck, 4 slipping).
    pub(super) dim: usize,
    /// Jacobian of P^p at `x` (`dim`×`dim`; variational where it holds,
    /// else finite differences).
    pub(super) jac: [[f64; 4]; 4],
}

/// Newton's method on P^p(x) − x for a section state of a period-p orbit.
/// Stuck states vary (ζ1, ζ1', ζ2) with ζ2' = 0; slipping states all four
/// components. Only a converged, stable (spectral radius < 1) fixed point
/// with the start's contact mode is returned; whether the trajectory
/// approaches it is the caller's check. `used` counts the periods
/// integrated, whatever the outcome.
pub(super) fn shoot(
    sim: &Sim,
    cache: &MonodromyCache,
    x0: [f64; 4],
    mode0: Mode,
    p: u64,
    tol: f64,
    used: &mut u64,
) -> Option<Shooting> {
    let model = sim.model();
    let stuck = matches!(mode0, Mode::Stick { .. });
    let dim = if stuck { 3 } else { 4 };
    let same_kind = |m: Mode| matches!(m, Mode::Stick { .. }) == stuck;
    // A section state in the start's contact mode (a stuck M2 at its ζ2).
    let start = |x: &[f64; 4]| Init {
        x: *x,
        mode: if stuck {
            Mode::Stick { z2: x[2] }
        } else {
            mode0
        },
    };
    let map = |x: &[f64; 4]| {
        let e = sim.run(start(x), p, &mut ());
        match e.status {
            Status::Completed => Some((e.x, e.mode)),
            _ => None,
        }
    };
    // The exact Jacobian from the variational equations where it holds
    // (one run per iteration), else forward differences (dim + 1 runs).
    let mono = cache.get(sim);
    let mut x = x0;
    for _ in 0..8 {
        let exact = mono.and_then(|m| m.map(sim, start(&x), p));
        let (px, pm) = match &exact {
            Some((px, pm, _)) => (*px, *pm),
            None => map(&x)?,
        };
        *used += p;
        if !same_kind(pm) {
            return None;
        }
        let scale = 1.0 + x.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        let r: Vec<f64> = (0..dim).map(|i| px[i] - x[i]).collect();
        let rn = r.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        let mut j = faer::Mat::<f64>::zeros(dim, dim);
        if let Some((_, _, jm)) = &exact {
            for i in 0..dim {
                for c in 0..dim {
                    j[(i, c)] = jm[i][c];
                }
            }
        } else {
            // Jacobian of P^p by forward differences.
            for c in 0..dim {
                let h = 1e-7 * (1.0 + x[c].abs());
                let mut xp = x;
                xp[c] += h;
                let (pp, pmm) = map(&xp)?;
                *used += p;
                if !same_kind(pmm) {
                    return None;
                }
                for i in 0..dim {
                    j[(i, c)] = (pp[i] - px[i]) / h;
                }
            }
        }
        if rn <= tol * scale {
            // Converged: accept only a stable orbit.
            let ev = j.eigenvalues().ok()?;
            let rho = ev.iter().map(|z| z.norm()).fold(0.0, f64::max);
            if rho >= 1.0 - 1e-9 {
                return None;
            }
            let mut jac = [[0.0; 4]; 4];
            for (i, row) in jac.iter_mut().enumerate().take(dim) {
                for (c, v) in row.iter_mut().enumerate().take(dim) {
                    *v = j[(i, c)];
                }
            }
            return Some(Shooting {
                x,
                mode: start(&x).mode,
                stuck,
                dim,
                jac,
            });
        }
        let mut a = j.clone();
        for i in 0..dim {
            a[(i, i)] -= 1.0;
        }
        let rhs = faer::Mat::<f64>::from_fn(dim, 1, |i, _| -r[i]);
        let dx = a.full_piv_lu().solve(&rhs);
        let mut step = [0.0f64; 4];
        for i in 0..dim {
            step[i] = dx[(i, 0)];
            if !step[i].is_finite() {
                return None;
            }
        }
        for i in 0..dim {
            x[i] += step[i];
        }
        if stuck {
            x[3] = 0.0;
            if !model.holds(net_force(model, &x)) {
                return None;
            }
        } else if x[3] == 0.0 || x[3].signum() != mode_dir(mode0) {
            return None;
        }
    }
    None
}

pub(super) fn mode_dir(m: Mode) -> f64 {
    match m {
        Mode::Slip { dir } => dir,
        Mode::Stick { .. } => 0.0,
    }
}
