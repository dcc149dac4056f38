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

mod drive;

pub use drive::{Drive, Schedule, Segment};
use std::fmt;

/// A parameter that describes no physical absorber.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("invalid parameter {name} = {value}: {why}")]
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

/// The friction characteristic of the pad, dimensionless (forces / (A·K2),
/// velocities in units of A·√(K2/M2)).
///
/// The static threshold is ρs; while sliding at speed v > 0 the friction
/// magnitude is `g(v)`. The paper's three laws (Fig. 2) are [`Law::Linear`];
/// [`Law::Stribeck`] is a fitted law of another shape (nonlinear in v), which
/// the engine integrates numerically within slip phases.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Law {
    /// `g(v) = ρd + D*·v`: Coulomb (ρd = ρs, D* = 0), decreasing
    /// characteristic (ρd = ρs, D* < 0; or increasing/viscous D* > 0), and
    /// static > dynamic (ρd < ρs).
    Linear {
        /// Static threshold ρs (may be +∞: never slides).
        rho_s: f64,
        /// Dynamic level ρd ≤ ρs.
        rho_d: f64,
        /// Slope D* = a/√(K2·M2) of the characteristic.
        slope: f64,
    },
    /// `g(v) = ρd + (ρs − ρd)·exp(−(v/v_s)²) + D*·v` (g(0+) = ρs).
    Stribeck {
        /// Static threshold ρs = g(0+).
        rho_s: f64,
        /// Dynamic level ρd ≤ ρs.
        rho_d: f64,
        /// Slope D*.
        slope: f64,
        /// Stribeck velocity v_s > 0.
        v_s: f64,
    },
}

impl Law {
    /// Coulomb's law, ρd = ρs (Fig. 2a). For ρs = ∞ (never slides) the
    /// unused dynamic level is set to 0.
    pub fn coulomb(rho_s: f64) -> Self {
        Law::Linear {
            rho_s,
            rho_d: if rho_s.is_finite() { rho_s } else { 0.0 },
            slope: 0.0,
        }
    }

    /// Static threshold ρs.
    pub fn rho_s(&self) -> f64 {
        match *self {
            Law::Linear { rho_s, .. } | Law::Stribeck { rho_s, .. } => rho_s,
        }
    }

    /// Dynamic level ρd.
    pub fn rho_d(&self) -> f64 {
        match *self {
            Law::Linear { rho_d, .. } | Law::Stribeck { rho_d, .. } => rho_d,
        }
    }

    /// Slope D*.
    pub fn slope(&self) -> f64 {
        match *self {
            Law::Linear { slope, .. } | Law::Stribeck { slope, .. } => slope,
        }
    }

    /// Sliding friction magnitude g(v) at speed v ≥ 0 (may be negative for
    /// a falling characteristic at high speed: the engine interrupts there).
    #[inline]
    pub fn sliding(&self, v: f64) -> f64 {
        match *self {
            Law::Linear { rho_d, slope, .. } => rho_d + slope * v,
            Law::Stribeck {
                rho_s,
                rho_d,
                slope,
                v_s,
            } => {
                let r = v / v_s;
                rho_d + (rho_s - rho_d) * (-r * r).exp() + slope * v
            }
        }
    }

    /// dg/dv at speed v ≥ 0.
    #[inline]
    pub fn sliding_slope(&self, v: f64) -> f64 {
        match *self {
            Law::Linear { slope, .. } => slope,
            Law::Stribeck {
                rho_s,
                rho_d,
                slope,
                v_s,
            } => {
                let r = v / v_s;
                slope - 2.0 * r / v_s * (rho_s - rho_d) * (-r * r).exp()
            }
        }
    }

    /// `Some((ρd, D*))` when g is affine in v, so slip phases are linear ODEs
    /// with a closed-form solution.
    pub fn affine(&self) -> Option<(f64, f64)> {
        match *self {
            Law::Linear { rho_d, slope, .. } => Some((rho_d, slope)),
            Law::Stribeck { .. } => None,
        }
    }

    /// True when there is no friction at all (ρs = 0 and so ρd = 0).
    pub fn is_frictionless(&self) -> bool {
        self.rho_s() == 0.0 && self.slope() == 0.0
    }

    /// True when M2 can never slide (ρs = +∞).
    pub fn is_always_stuck(&self) -> bool {
        self.rho_s() == f64::INFINITY
    }

    /// Checks the law: ρs ≥ 0 (may be +∞), 0 ≤ ρd ≤ ρs finite, D* finite,
    /// v_s > 0 finite.
    pub fn validate(&self) -> Result<(), ParamError> {
        let (rs, rd, sl) = (self.rho_s(), self.rho_d(), self.slope());
        check(
            "rho-s",
            rs,
            !rs.is_nan() && rs >= 0.0,
            "must be >= 0 (inf allowed)",
        )?;
        check(
            "rho-d",
            rd,
            rd.is_finite() && rd >= 0.0,
            "must be finite and >= 0",
        )?;
        check(
            "rho-d",
            rd,
            rd <= rs,
            "must not exceed rho-s (dynamic > static friction)",
        )?;
        check("slope", sl, sl.is_finite(), "must be finite")?;
        if rs == 0.0 {
            check(
                "slope",
                sl,
                sl >= 0.0,
                "a negative slope without friction is an active damper",
            )?;
        }
        if let Law::Stribeck { v_s, .. } = *self {
            check(
                "v-s",
                v_s,
                v_s.is_finite() && v_s > 0.0,
                "must be finite and > 0",
            )?;
        }
        Ok(())
    }

    /// The law's name in the interface (`coulomb`, `decreasing`,
    /// `static-dynamic`, `stribeck`).
    pub fn name(&self) -> &'static str {
        match *self {
            Law::Stribeck { .. } => "stribeck",
            Law::Linear {
                rho_s,
                rho_d,
                slope,
            } => {
                if rho_d < rho_s {
                    "static-dynamic"
                } else if slope != 0.0 {
                    "decreasing"
                } else {
                    "coulomb"
                }
            }
        }
    }
}

impl fmt::Display for Law {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} (rho_s={}, rho_d={}, slope={})",
            self.name(),
            self.rho_s(),
            self.rho_d(),
            self.slope()
        )
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
        Ok(())
    }

    /// The friction level below which a slip phase is interrupted:
    /// `stop_below·ρs` (0 without the rule: negative friction always stops).
    pub fn interrupt_level(&self) -> f64 {
        match self.stop_below {
            Some(f) if self.law.rho_s().is_finite() => f * self.law.rho_s(),
            _ => 0.0,
        }
    }
}

/// Validates a forcing frequency ratio η.
pub fn validate_eta(eta: f64) -> Result<(), ParamError> {
    check(
        "eta",
        eta,
        eta.is_finite() && eta > 0.0,
        "must be finite and > 0",
    )
}

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
            },
            Law::Linear {
                rho_s: f64::NAN,
                rho_d: 0.0,
                slope: 0.0,
            },
            Law::Linear {
                rho_s: 0.3,
                rho_d: 0.3,
                slope: f64::INFINITY,
            },
            Law::Stribeck {
                rho_s: 0.3,
                rho_d: 0.2,
                slope: 0.0,
                v_s: 0.0,
            },
        ];
        for l in laws {
            assert!(l.validate().is_err(), "{l:?}");
        }
        assert!(Law::coulomb(f64::INFINITY).validate().is_ok());
    }

    #[test]
    fn law_names() {
        assert_eq!(Law::coulomb(0.3).name(), "coulomb");
        assert_eq!(
            Law::Linear {
                rho_s: 0.3,
                rho_d: 0.3,
                slope: -0.04
            }
            .name(),
            "decreasing"
        );
        assert_eq!(
            Law::Linear {
                rho_s: 0.3,
                rho_d: 0.15,
                slope: 0.0
            }
            .name(),
            "static-dynamic"
        );
    }
}
