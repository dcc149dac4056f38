//! The dimensionless absorber of the paper (§2, eqs. 1–2) and its friction
//! laws: parameter types, their validation, and the friction characteristic
//! as a small abstraction.
//!
//! State order everywhere: `[ζ1, ζ1', ζ2, ζ2']`. Time τ = t·√(K2/M2).
//!
//! * Sliding (eq. 1, with a general characteristic):
//!   `m ζ1'' + D(ζ1' − ζ2') + (1+k)ζ1 − ζ2 = k·ζ0(τ)`,
//!   `ζ2'' = F − sgn(ζ2')·g(|ζ2'|)` with the net non-friction force on M2
//!   `F = ζ1 − ζ2 + D(ζ1' − ζ2')` and the sliding friction magnitude `g`.
//!   For the paper's laws `g(v) = ρd + D*·v`, which is eq. (1) exactly.
//! * Sticking (eq. 2): ζ2 ≡ ζ2*, and the friction is the passive contact
//!   force R = F, admissible while |F| ≤ ρs. The paper's eq. (5) writes the
//!   switching quantity as ρ = ζ2* − ζ1 − Dζ1' = −F; we use F, whose sign is
//!   the direction in which M2 departs (see [`crate::sim`]).
//!
//! ζ0(τ) is the base motion divided by A: `cos(ητ)` for the paper's drive.

mod stiffness;
pub use stiffness::{IntegrableError, MAX_MODE_TO_DRIVE_RATIO, STIFFNESS_RATIO_RANGE};
mod drive;
mod law;

pub use drive::{Drive, Schedule, ScheduleError, Segment};
pub use law::{
    Law, LawFamily, LawFamily as Family, LawKind, Levels, Optimum, Scales, Selection, SiLaw,
};

/// A number as a person reads it: plain where short, else in exponent form
/// (1e308, not three hundred digits).
fn short(x: f64) -> String {
    let plain = format!("{x}");
    if plain.len() <= 12 {
        plain
    } else {
        format!("{x:e}")
    }
}

/// A parameter that describes no physical absorber.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("invalid parameter {name} = {}: {why}", short(*.value))]
pub struct ParamError {
    /// The parameter's option name.
    pub name: &'static str,
    /// Its value, as given.
    pub value: f64,
    /// Why it is rejected.
    pub why: &'static str,
}

fn check(name: &'static str, value: f64, ok: bool, why: &'static str) -> Result<(), ParamError> {
    if ok {
        Ok(())
    } else {
        Err(ParamError { name, value, why })
    }
}

/// The linear part of the absorber (paper §2): mass ratio m = M1/M2,
/// stiffness ratio k = K1/K2 and viscous damping D = d/√(K2·M2).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Absorber {
    /// m = M1/M2.
    pub m: f64,
    /// k = K1/K2.
    pub k: f64,
    /// D = d/√(K2·M2), the damper between the masses.
    pub damping: f64,
}

impl Default for Absorber {
    /// The paper's values: m = 4, k = 1, D = 0.005.
    fn default() -> Self {
        Self {
            m: 4.0,
            k: 1.0,
            damping: 0.005,
        }
    }
}

impl Absorber {
    /// Checks that the absorber is physical (finite, m > 0, k > 0, D ≥ 0).
    pub fn validate(&self) -> Result<(), ParamError> {
        check(
            "m",
            self.m,
            self.m.is_finite() && self.m > 0.0,
            "must be finite and > 0",
        )?;
        check(
            "k",
            self.k,
            self.k.is_finite() && self.k > 0.0,
            "must be finite and > 0",
        )?;
        check(
            "damping",
            self.damping,
            self.damping.is_finite() && self.damping >= 0.0,
            "must be finite and >= 0",
        )
    }

    /// Natural frequencies η1 < η2 of the frictionless 2-DOF system
    /// (undamped): roots of m·η⁴ − (1 + k + m)·η² + k = 0.
    pub fn eta_linear(&self) -> (f64, f64) {
        let (m, k) = (self.m, self.k);
        let b = 1.0 + k + m;
        let disc = (b * b - 4.0 * m * k).sqrt();
        // Stable quadratic roots in η².
        let big = (b + disc) / (2.0 * m);
        let small = k / (m * big);
        (small.sqrt(), big.sqrt())
    }

    /// Natural frequency η0 = √((1+k)/m) of the 1-DOF system (M2 stuck).
    pub fn eta_stuck(&self) -> f64 {
        ((1.0 + self.k) / self.m).sqrt()
    }
}

/// The rig's constants in SI: the two masses, the two springs and the
/// damper between the masses. The one place where they become the
/// dimensionless absorber and the time and slope scales.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RigConstants {
    /// Main mass M1 (kg).
    pub m1_kg: f64,
    /// Absorber mass M2 (kg).
    pub m2_kg: f64,
    /// Spring K1, base to M1 (N/m).
    pub k1_n_per_m: f64,
    /// Spring K2, M1 to M2 (N/m).
    pub k2_n_per_m: f64,
    /// Viscous damping d between the masses (N·s/m).
    pub d_n_s_per_m: f64,
}

impl RigConstants {
    /// The paper's rig: M1 = 8.35 kg, M2 = 2.0875 kg, K1 = K2 = 670 N/m,
    /// D = 0.003.
    pub fn paper() -> Self {
        let (m2, k2) = (2.0875, 670.0);
        Self {
            m1_kg: 8.35,
            m2_kg: m2,
            k1_n_per_m: 670.0,
            k2_n_per_m: k2,
            d_n_s_per_m: 0.003 * (k2 * m2).sqrt(),
        }
    }

    /// ω = √(K2/M2) (rad/s): τ = ω·t.
    pub fn omega_ref(&self) -> f64 {
        (self.k2_n_per_m / self.m2_kg).sqrt()
    }

    /// √(K2·M2) (N·s/m): D = d/√(K2·M2), D* = a/√(K2·M2).
    pub fn slope_scale(&self) -> f64 {
        (self.k2_n_per_m * self.m2_kg).sqrt()
    }

    /// The dimensionless absorber: m = M1/M2, k = K1/K2, D = d/√(K2·M2).
    pub fn absorber(&self) -> Absorber {
        Absorber {
            m: self.m1_kg / self.m2_kg,
            k: self.k1_n_per_m / self.k2_n_per_m,
            damping: self.d_n_s_per_m / self.slope_scale(),
        }
    }
}

/// A complete model: absorber, friction law and the paper's interruption
/// rule.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Model {
    /// Linear part.
    pub absorber: Absorber,
    /// Friction characteristic.
    pub law: Law,
    /// Interrupt when the sliding friction falls below `stop_below·ρs`
    /// (paper §3: 0.5 for its decreasing characteristic). A friction force
    /// that would turn negative always interrupts.
    pub stop_below: Option<f64>,
    /// Pre-sliding (issue 34): κ = kt/K2, the stiffness of the tangential
    /// contact spring between M2 and a massless friction slider (a Jenkins
    /// element); None: the paper's rigid stick. With a contact spring,
    /// [`crate::sim::Mode::Stick`]'s position is the slider's, ζs, and M2
    /// moves on the spring while the slider sticks.
    pub contact_stiffness: Option<f64>,
}

impl Model {
    /// Validates every parameter.
    pub fn validate(&self) -> Result<(), ParamError> {
        self.absorber.validate()?;
        self.law.validate()?;
        if let Some(f) = self.stop_below {
            check(
                "stop-below",
                f,
                f.is_finite() && (0.0..=1.0).contains(&f),
                "must be in [0, 1]",
            )?;
        }
        if let Some(kappa) = self.contact_stiffness {
            check(
                "contact-stiffness",
                kappa,
                kappa.is_finite() && kappa > 0.0,
                "must be > 0 (inf: a rigid stick)",
            )?;
            check(
                "contact-stiffness",
                kappa,
                kappa <= MAX_CONTACT_STIFFNESS,
                "is above the supported 1e8: the contact mode rings at sqrt(1 + kappa) per unit tau and the held phase is marched one radian of it at a time (14 ms per forcing period at 1e8 for a pad that sticks a third of the time, growing as sqrt(kappa)), while M2's travel on the spring, rho_s/kappa of the drive amplitude, is below 1e-8 of it; give inf for a rigid stick",
            )?;
            check(
                "contact-stiffness",
                kappa,
                !self.law.is_frictionless(),
                "a contact spring needs friction (rho-s > 0)",
            )?;
        }
        Ok(())
    }

    /// The friction level below which a slip phase in direction `dir` is
    /// interrupted: `stop_below·ρs` of that direction (0 without the rule:
    /// negative friction always stops).
    pub fn interrupt_level(&self, dir: f64) -> f64 {
        let rho_s = self.law.levels(dir).rho_s;
        match self.stop_below {
            Some(f) if rho_s.is_finite() => f * rho_s,
            _ => 0.0,
        }
    }

    /// The sliding speed at which an affine law's friction in direction
    /// `dir` reaches the interruption level ([`Model::interrupt_level`]):
    /// 0 where its dynamic level is already below it, None where a slip
    /// never gets there (a law that does not fall).
    pub fn interrupt_speed(&self, dir: f64) -> Option<f64> {
        let (rho_d, thr) = (self.law.levels(dir).rho_d, self.interrupt_level(dir));
        let slope = self.law.slope();
        if rho_d < thr {
            Some(0.0)
        } else if slope < 0.0 {
            Some((rho_d - thr) / -slope)
        } else {
            None
        }
    }

    /// Behind a contact spring: where the slider sticks when a slip in
    /// direction `dir` ends with M2 at `z2` (the spring keeps the sliding
    /// level it carried, P = ±ρd: ζs = ζ2 − dir·ρd/κ). None: a rigid stick.
    pub fn slider_at_rest(&self, dir: f64, z2: f64) -> Option<f64> {
        let kappa = self.contact_stiffness?;
        Some(z2 - dir * self.law.levels(dir).rho_d / kappa)
    }

    /// Behind a contact spring: the slider's position while it slides in
    /// direction `dir` with M2 at state `x` (the spring carries the signed
    /// sliding friction f: ζs = ζ2 − f/κ). None: a rigid stick.
    pub fn slider_sliding(&self, dir: f64, x: &[f64; 4]) -> Option<f64> {
        let kappa = self.contact_stiffness?;
        Some(x[2] - dir * self.law.toward(dir).sliding(x[3].abs()) / kappa)
    }

    /// True when the pad holds a net force `f` on M2: −ρs⁻ < F < ρs⁺.
    #[inline]
    pub fn holds(&self, f: f64) -> bool {
        f < self.law.rho_s() && -f < self.law.levels(-1.0).rho_s
    }

    /// The stick thresholds (ρs⁺, ρs⁻): M2 sticks while −ρs⁻ < F < ρs⁺.
    #[inline]
    pub fn thresholds(&self) -> (f64, f64) {
        (self.law.levels(1.0).rho_s, self.law.levels(-1.0).rho_s)
    }
}

/// Largest contact stiffness κ = kt/K2 accepted (see [`Model::validate`]
/// and `docs/real-pads.md`).
pub const MAX_CONTACT_STIFFNESS: f64 = 1e8;

/// Validates a forcing frequency ratio η.
pub fn validate_eta(eta: f64) -> Result<(), ParamError> {
    check(
        "eta",
        eta,
        eta.is_finite() && eta > 0.0 && eta <= MAX_ETA,
        "must be > 0 and at most 1e6 (the forcing over the absorber's natural frequency)",
    )
}

/// Largest forcing frequency ratio η accepted (the paper's figures span
/// 0.2–1.6; far above the modes the response is the drive's alone).
pub const MAX_ETA: f64 = 1e6;

#[cfg(test)]
mod tests {
    use super::*;

    /// η0, η1, η2 for m = 4, k = 1 as printed with the paper's Figs. 3–5.
    #[test]
    #[allow(clippy::approx_constant)] // 0.7071 is the paper's printed η0
    fn paper_natural_frequencies() {
        let a = Absorber::default();
        let (e1, e2) = a.eta_linear();
        assert!((e1 - 0.4370).abs() < 5e-5, "{e1}");
        assert!((e2 - 1.1441).abs() < 5e-5, "{e2}");
        assert!((a.eta_stuck() - 0.7071).abs() < 5e-5);
    }

    #[test]
    fn rejects_unphysical() {
        let bad = [
            Absorber {
                m: 0.0,
                ..Default::default()
            },
            Absorber {
                k: -1.0,
                ..Default::default()
            },
            Absorber {
                damping: f64::NAN,
                ..Default::default()
            },
        ];
        for a in bad {
            assert!(a.validate().is_err(), "{a:?}");
        }
        let laws = [
            Law::Linear {
                rho_s: 0.3,
                rho_d: 0.4,
                slope: 0.0,
                minus: None,
            },
            Law::Linear {
                rho_s: f64::NAN,
                rho_d: 0.0,
                slope: 0.0,
                minus: None,
            },
            Law::Linear {
                rho_s: 0.3,
                rho_d: 0.3,
                slope: f64::INFINITY,
                minus: None,
            },
            Law::Shaped {
                kind: LawKind::Stribeck,
                rho_s: 0.3,
                rho_d: 0.2,
                slope: 0.0,
                v_s: 0.0,
                minus: None,
            },
        ];
        for l in laws {
            assert!(l.validate().is_err(), "{l:?}");
        }
        assert!(Law::coulomb(f64::INFINITY).validate().is_ok());
    }
}
