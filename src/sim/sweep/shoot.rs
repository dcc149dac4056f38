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
    /// The section state in extended coordinates ([`ext`]).
    pub(super) x: [f64; 5],
    /// Its contact mode.
    pub(super) mode: Mode,
    /// M2 (or, behind a contact spring, its slider) is stuck there.
    pub(super) stuck: bool,
    /// Number of extended coordinates varied (3 for a rigid stick, 4
    /// slipping, 5 held behind a contact spring).
    pub(super) dim: usize,
    /// Jacobian of P^p at `x` (`dim`×`dim`; variational where it holds,
    /// else finite differences).
    pub(super) jac: [[f64; 5]; 5],
}

impl Shooting {
    /// The fixed point as a state to run from.
    pub(super) fn init(&self) -> Init {
        from_ext(&self.x, self.mode)
    }
}

/// A section state in the coordinates shooting varies, `[ζ1, ζ1', ζ2,
/// ζ2', ζs]`: a rigid stick varies the first three (ζ2' = 0, ζs = ζ2: the
/// state's ζ2 is the stuck position), a slip the first four (the slider
/// follows M2: ζs = 0 here), a slider held behind a contact spring all
/// five (ζs: the mode's held position).
pub(super) fn ext(init: &Init, contact: bool) -> [f64; 5] {
    let x = init.x;
    match init.mode {
        Mode::Stick { z2 } if contact => [x[0], x[1], x[2], x[3], z2],
        Mode::Stick { .. } => [x[0], x[1], x[2], 0.0, x[2]],
        Mode::Slip { .. } => [x[0], x[1], x[2], x[3], 0.0],
    }
}

/// The number of extended coordinates that vary in `mode` ([`ext`]).
pub(super) fn ext_dim(mode: Mode, contact: bool) -> usize {
    match mode {
        Mode::Stick { .. } if contact => 5,
        Mode::Stick { .. } => 3,
        Mode::Slip { .. } => 4,
    }
}

/// The state of extended coordinates `y` in a mode of `like`'s kind (a
/// stuck start takes its held position from `y`; a rigid stick has
/// ζ2' = 0 and ζ2* = ζ2).
fn from_ext(y: &[f64; 5], like: Mode) -> Init {
    match like {
        Mode::Stick { .. } => Init {
            x: [y[0], y[1], y[2], y[3]],
            mode: Mode::Stick { z2: y[4] },
        },
        Mode::Slip { .. } => Init {
            x: [y[0], y[1], y[2], y[3]],
            mode: like,
        },
    }
}

/// Newton's method on P^p(x) − x for a section state of a period-p orbit,
/// in the extended coordinates of the start's mode ([`ext`]). Only a
/// converged, stable (spectral radius < 1) fixed point with the start's
/// contact mode is returned; whether the trajectory approaches it is the
/// caller's check. `used` counts the periods integrated, whatever the
/// outcome.
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
    let contact = model.contact_stiffness;
    let stuck = matches!(mode0, Mode::Stick { .. });
    let dim = ext_dim(mode0, contact.is_some());
    let same_kind = |m: Mode| matches!(m, Mode::Stick { .. }) == stuck;
    let to_ext = |x: [f64; 4], mode: Mode| ext(&Init { x, mode }, contact.is_some());
    let map = |y: &[f64; 5]| {
        let e = sim.run(from_ext(y, mode0), p, &mut ());
        match e.status {
            Status::Completed => Some((to_ext(e.x, e.mode), e.mode)),
            _ => None,
        }
    };
    // The exact Jacobian from the variational equations where it holds
    // (one run per iteration), else forward differences (dim + 1 runs).
    let mono = cache.get(sim);
    let mut x = to_ext(x0, mode0);
    for _ in 0..8 {
        let exact = mono.and_then(|m| m.map_ext(sim, from_ext(&x, mode0), p));
        let (px, pm) = match &exact {
            Some((px, pm, _)) => (to_ext(*px, *pm), *pm),
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
            let mut jac = [[0.0; 5]; 5];
            for (i, row) in jac.iter_mut().enumerate().take(dim) {
                for (c, v) in row.iter_mut().enumerate().take(dim) {
                    *v = j[(i, c)];
                }
            }
            return Some(Shooting {
                x,
                mode: from_ext(&x, mode0).mode,
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
        let mut step = [0.0f64; 5];
        for i in 0..dim {
            step[i] = dx[(i, 0)];
            if !step[i].is_finite() {
                return None;
            }
        }
        for i in 0..dim {
            x[i] += step[i];
        }
        match (stuck, contact) {
            // The slider must hold the spring's pull κ(ζ2 − ζs).
            (true, Some(kappa)) => {
                if !model.holds(kappa * (x[2] - x[4])) {
                    return None;
                }
            }
            (true, None) => {
                x[3] = 0.0;
                x[4] = x[2];
                if !model.holds(net_force(model, &[x[0], x[1], x[2], x[3]])) {
                    return None;
                }
            }
            (false, _) => {
                if x[3] == 0.0 || x[3].signum() != mode_dir(mode0) {
                    return None;
                }
            }
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
