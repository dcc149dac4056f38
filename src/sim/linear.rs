//! Closed forms of the two linear limits (paper §3, the reference curves of
//! Figs. 3–5), written from the dynamic-stiffness matrices, independently of
//! the engine's phase machinery:
//!
//! * ρs = 0: the frictionless 2-DOF absorber (a viscous slope D* ≥ 0 adds
//!   damping to M2);
//! * ρs = ∞: M2 never moves; the 1-DOF system m ζ1'' + D ζ1' + (1+k) ζ1 =
//!   ζ2* + k cos ητ;
//! * a friction slider behind a contact spring κ that stays stuck at ζs
//!   (issue 34): the 2-DOF system with M2 tied to ζs by κ (the *held*
//!   system).

use crate::model::Absorber;
use num_complex::Complex;

type C = Complex<f64>;

/// Complex steady-state amplitudes (X1, X2) with ζi = Re(Xi·e^{iητ}) of the
/// frictionless 2-DOF system with extra damping `slope` on M2.
pub fn free_response(ab: &Absorber, slope: f64, eta: f64) -> (C, C) {
    let (m, k, d) = (ab.m, ab.k, ab.damping);
    let i = C::new(0.0, 1.0);
    let z11 = C::new(1.0 + k - m * eta * eta, 0.0) + i * eta * d;
    let z12 = C::new(-1.0, 0.0) - i * eta * d;
    let z22 = C::new(1.0 - eta * eta, 0.0) + i * eta * (d + slope);
    let det = z11 * z22 - z12 * z12;
    (k * z22 / det, -k * z12 / det)
}

/// Complex steady-state amplitude X1 of the stuck 1-DOF system.
pub fn stuck_response(ab: &Absorber, eta: f64) -> C {
    let z = C::new(1.0 + ab.k - ab.m * eta * eta, eta * ab.damping);
    ab.k / z
}

/// Complex steady-state amplitudes (X1, X2) of the held system (M2 on the
/// contact spring κ, its slider stuck), without the constant offset of
/// [`held_offset`].
pub fn held_response(ab: &Absorber, kappa: f64, eta: f64) -> (C, C) {
    let (m, k, d) = (ab.m, ab.k, ab.damping);
    let i = C::new(0.0, 1.0);
    let z11 = C::new(1.0 + k - m * eta * eta, 0.0) + i * eta * d;
    let z12 = C::new(-1.0, 0.0) - i * eta * d;
    let z22 = C::new(1.0 + kappa - eta * eta, 0.0) + i * eta * d;
    let det = z11 * z22 - z12 * z12;
    (k * z22 / det, -k * z12 / det)
}

/// The held system's static offset (ζ1, ζ2) with the slider at ζs: the
/// springs' deflection under the anchor, (1+k)c1 = c2, (1+κ)c2 − c1 = κζs.
pub fn held_offset(ab: &Absorber, kappa: f64, zs: f64) -> (f64, f64) {
    let c2 = kappa * zs / (1.0 + kappa - 1.0 / (1.0 + ab.k));
    (c2 / (1.0 + ab.k), c2)
}

/// Steady amplitudes (A1/A, A2/A) of the held system.
pub fn held_amplitudes(ab: &Absorber, kappa: f64, eta: f64) -> (f64, f64) {
    let (x1, x2) = held_response(ab, kappa, eta);
    (x1.norm(), x2.norm())
}

/// The held steady state `[ζ1, ζ1', ζ2, ζ2']` at τ = 0 (mod T) with the
/// slider at ζs.
pub fn held_state(ab: &Absorber, kappa: f64, eta: f64, zs: f64) -> [f64; 4] {
    let (x1, x2) = held_response(ab, kappa, eta);
    let (c1, c2) = held_offset(ab, kappa, zs);
    [x1.re + c1, -eta * x1.im, x2.re + c2, -eta * x2.im]
}

/// Whether a closed-form amplitude describes a bounded steady state: an
/// undamped system forced at an eigenfrequency has none (the dynamic
/// stiffness is singular to rounding and the "amplitude" is ~1/ε).
pub fn bounded(amplitude: f64) -> bool {
    amplitude.is_finite() && amplitude < 1e9
}

/// Steady amplitudes (A1/A, A2/A) of the frictionless system.
pub fn free_amplitudes(ab: &Absorber, slope: f64, eta: f64) -> (f64, f64) {
    let (x1, x2) = free_response(ab, slope, eta);
    (x1.norm(), x2.norm())
}

/// Steady amplitudes (A1/A, 0) of the stuck system.
pub fn stuck_amplitudes(ab: &Absorber, eta: f64) -> (f64, f64) {
    (stuck_response(ab, eta).norm(), 0.0)
}

/// The frictionless steady state `[ζ1, ζ1', ζ2, ζ2']` at τ = 0 (mod T).
pub fn free_state(ab: &Absorber, slope: f64, eta: f64) -> [f64; 4] {
    let (x1, x2) = free_response(ab, slope, eta);
    [x1.re, -eta * x1.im, x2.re, -eta * x2.im]
}

/// The stuck steady state at τ = 0 (mod T) with M2 held at ζ2*.
pub fn stuck_state(ab: &Absorber, eta: f64, z2: f64) -> [f64; 4] {
    let x1 = stuck_response(ab, eta);
    [x1.re + z2 / (1.0 + ab.k), -eta * x1.im, z2, 0.0]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The classical absorber's antiresonance: without damping A1 = 0 at
    /// η = 1 (M2's own frequency), and A2 = k (it balances the drive force).
    #[test]
    fn antiresonance_at_eta_one() {
        let ab = Absorber {
            damping: 0.0,
            ..Default::default()
        };
        let (a1, a2) = free_amplitudes(&ab, 0.0, 1.0);
        assert!(a1 < 1e-15);
        assert!((a2 - ab.k).abs() < 1e-14);
    }
}
