//! Stages 1 and 3 of a steady state: the linear limits in closed form, and
//! the proof that M2 stays stuck for good (then the 1-DOF closed form).

use super::*;
use crate::model::Model;
use crate::sim::engine::{Init, Mode};
use crate::sim::linear;

/// Proves that M2, stuck at ζ2* with the 1-DOF state (ζ1, ζ1'), never
/// breaks away: the stuck motion is the steady 1-DOF response plus a free
/// part whose energy E = ½mζ1h'² + ½(1+k)ζ1h² never grows (D ≥ 0), so
/// F stays within F_ss ± (√(2E/(1+k)) + D·√(2E/m)), inside (−ρs⁻, ρs⁺)
/// for all later times.
pub(super) fn permanently_stuck(model: &Model, eta: f64, x: &[f64; 4], z2: f64) -> bool {
    let ab = &model.absorber;
    let xs = linear::stuck_response(ab, eta);
    let c = z2 / (1.0 + ab.k);
    // F_ss = ζ1ss − z2 + Dζ1ss' = Re(X(1 + iηD) e^{iητ}) + c − z2.
    let f_amp = (xs * num_complex::Complex::new(1.0, eta * ab.damping)).norm();
    let centre = c - z2;
    // Free part at τ = 0 mod T (the section).
    let ss = linear::stuck_state(ab, eta, z2);
    let (h, dh) = (x[0] - ss[0], x[1] - ss[1]);
    let e = 0.5 * ab.m * dh * dh + 0.5 * (1.0 + ab.k) * h * h;
    let bound = (2.0 * e / (1.0 + ab.k)).sqrt() + ab.damping * (2.0 * e / ab.m).sqrt();
    // F stays within centre ± reach; the pad holds it for ever when that
    // band lies inside (−ρs⁻, ρs⁺) with a margin for rounding.
    let reach = f_amp + bound;
    let (plus, minus) = model.thresholds();
    centre + reach < plus * (1.0 - 1e-12) && reach - centre < minus * (1.0 - 1e-12)
}

/// Proves that a slider behind a contact spring κ, stuck at ζs with the
/// state `x`, never breaks away: the motion is the held system's steady
/// response ([`linear::held_state`]) plus a free part h whose energy
/// E = ½mh1'² + ½h2'² + ½hᵀKh, K = [[1+k, −1], [−1, 1+κ]], never grows
/// (D ≥ 0), so |h2| ≤ √(2E·(K⁻¹)₂₂) with (K⁻¹)₂₂ = (1+k)/det K, and the
/// pull P = κ(ζ2 − ζs) stays within κ(c2 − ζs) ± κ(|X2| + |h2|max), inside
/// (−ρs⁻, ρs⁺) for all later times.
pub(super) fn permanently_held(model: &Model, kappa: f64, eta: f64, x: &[f64; 4], zs: f64) -> bool {
    let ab = &model.absorber;
    let (_, x2) = linear::held_response(ab, kappa, eta);
    let (_, c2) = linear::held_offset(ab, kappa, zs);
    let ss = linear::held_state(ab, kappa, eta, zs);
    let h: [f64; 4] = std::array::from_fn(|i| x[i] - ss[i]);
    let kk = [[1.0 + ab.k, -1.0], [-1.0, 1.0 + kappa]];
    let potential = kk[0][0] * h[0] * h[0] + 2.0 * kk[0][1] * h[0] * h[2] + kk[1][1] * h[2] * h[2];
    let e = 0.5 * ab.m * h[1] * h[1] + 0.5 * h[3] * h[3] + 0.5 * potential;
    let det = kk[0][0] * kk[1][1] - 1.0;
    let h2_max = (2.0 * e * kk[0][0] / det).sqrt();
    let centre = kappa * (c2 - zs);
    let reach = kappa * (x2.norm() + h2_max);
    let (plus, minus) = model.thresholds();
    centre + reach < plus * (1.0 - 1e-12) && reach - centre < minus * (1.0 - 1e-12)
}

/// The steady state of a slider held for good behind its contact spring:
/// period 1, the held system's amplitudes (after `periods` forcing
/// periods; `method` says how it was found).
fn held_point(eta: f64, (a1, a2): (f64, f64), periods: u64, method: &'static str) -> Point {
    Point {
        eta,
        amplitude1: Some(a1),
        amplitude2: Some(a2),
        ..stuck_point(eta, a1, periods, method)
    }
}

/// Stage 1 of [`steady_state`]: the closed forms of a frictionless and of
/// an always-stuck law (None for any other law). Inlined: as a call it
/// made the closed-form sweep (`benches/sweep.rs`, baseline) ~50 % slower.
#[inline(always)]
pub(super) fn closed_form(model: &Model, eta: f64, init: &Init) -> Option<(Point, Init)> {
    let ab = &model.absorber;
    if model.law.is_frictionless() {
        let (a1, a2) = linear::free_amplitudes(ab, model.law.slope(), eta);
        if !linear::bounded(a1.max(a2)) {
            return Some((resonant(eta), Init::rest()));
        }
        let x = linear::free_state(ab, model.law.slope(), eta);
        let p = Point {
            eta,
            amplitude1: Some(a1),
            amplitude2: Some(a2),
            steady: true,
            period_multiple: Some(1),
            stick_fraction: 0.0,
            interrupted: false,
            periods: 0,
            method: "closed-form",
            range: None,
        };
        return Some((
            p,
            Init {
                x,
                mode: Mode::Slip { dir: 1.0 },
            },
        ));
    }
    // Behind a contact spring a slider that never slides leaves M2 on the
    // spring: the held system's closed form.
    if let (true, Some(kappa)) = (model.law.is_always_stuck(), model.contact_stiffness) {
        let zs = match init.mode {
            Mode::Stick { z2 } if z2.is_finite() => z2,
            _ => 0.0,
        };
        let (a1, a2) = linear::held_amplitudes(ab, kappa, eta);
        if !linear::bounded(a1.max(a2)) {
            return Some((resonant(eta), Init::rest()));
        }
        return Some((
            held_point(eta, (a1, a2), 0, "closed-form"),
            Init {
                x: linear::held_state(ab, kappa, eta, zs),
                mode: Mode::Stick { z2: zs },
            },
        ));
    }
    if model.law.is_always_stuck() {
        let z2 = if init.x[2].is_finite() {
            init.x[2]
        } else {
            0.0
        };
        let (a1, _) = linear::stuck_amplitudes(ab, eta);
        if !linear::bounded(a1) {
            return Some((resonant(eta), Init::rest()));
        }
        let p = stuck_point(eta, a1, 0, "closed-form");
        return Some((
            p,
            Init {
                x: linear::stuck_state(ab, eta, z2),
                mode: Mode::Stick { z2 },
            },
        ));
    }
    None
}

/// The steady state of M2 stuck for good: period 1, A1/A = `a1`, A2/A = 0
/// (after `periods` forcing periods; `method` says how it was found).
#[inline(always)]
pub(super) fn stuck_point(eta: f64, a1: f64, periods: u64, method: &'static str) -> Point {
    Point {
        eta,
        amplitude1: Some(a1),
        amplitude2: Some(0.0),
        steady: true,
        period_multiple: Some(1),
        stick_fraction: 1.0,
        interrupted: false,
        periods,
        method,
        range: None,
    }
}

/// Stage 3 of [`steady_state`]: the stuck state after the transient
/// (`state`, `used` periods) where it is proven permanent. Inlined like
/// [`closed_form`].
#[inline(always)]
pub(super) fn stick_proof(
    model: &Model,
    eta: f64,
    state: &Init,
    used: u64,
) -> Option<(Point, Init)> {
    let ab = &model.absorber;
    if let Some(kappa) = model.contact_stiffness {
        let Mode::Stick { z2: zs } = state.mode else {
            return None;
        };
        if !permanently_held(model, kappa, eta, &state.x, zs) {
            return None;
        }
        let amplitudes = linear::held_amplitudes(ab, kappa, eta);
        return Some((
            held_point(eta, amplitudes, used, "stick-proof"),
            Init {
                x: linear::held_state(ab, kappa, eta, zs),
                mode: state.mode,
            },
        ));
    }
    if let Mode::Stick { z2 } = state.mode {
        if permanently_stuck(model, eta, &state.x, z2) {
            let (a1, _) = linear::stuck_amplitudes(ab, eta);
            let p = stuck_point(eta, a1, used, "stick-proof");
            return Some((
                p,
                Init {
                    x: linear::stuck_state(ab, eta, z2),
                    mode: state.mode,
                },
            ));
        }
    }
    None
}
