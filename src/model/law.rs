//! One vocabulary for friction laws, shared by every stage:
//!
//! * [`LawKind`]: the family names of the JSON contract (`coulomb`,
//!   `decreasing`, `static-dynamic`, `stribeck`);
//! * [`Family`]: how each family's free parameters map to a law (one
//!   implementation per family; the output-error refinement optimises these
//!   parameters);
//! * [`SiLaw`]: a law in SI (N, N·s/m, m/s), as fitted and reported;
//! * [`Law`]: the dimensionless law the engine integrates;
//! * [`Scales`]: the one place where SI becomes dimensionless
//!   ([`SiLaw::to_rho`]), built by [`Scales::from_rig`].

use super::{check, ParamError, RigConstants};
use serde::{Deserialize, Serialize};
use std::fmt;

/// A friction-law family (names as in the JSON contract's `law` key).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "kebab-case")]
pub enum LawKind {
    /// ρd = ρs, no slope.
    Coulomb,
    /// ρd = ρs with a linear slope D* of either sign.
    Decreasing,
    /// ρd < ρs, no slope.
    StaticDynamic,
    /// ρd + (ρs − ρd)·exp(−(v/v_s)²) + D*·v.
    Stribeck,
}

impl LawKind {
    /// Every family, simplest first.
    pub const ALL: [LawKind; 4] = [
        LawKind::Coulomb,
        LawKind::Decreasing,
        LawKind::StaticDynamic,
        LawKind::Stribeck,
    ];

    /// The name used in options and in the `law` key.
    pub fn as_str(self) -> &'static str {
        self.family().name()
    }

    /// Parses a law name.
    ///
    /// ```
    /// use stickslip::model::LawKind;
    /// assert_eq!(LawKind::parse("static-dynamic"), Some(LawKind::StaticDynamic));
    /// assert_eq!(LawKind::parse("static_dynamic"), None);
    /// ```
    pub fn parse(s: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|k| k.as_str() == s)
    }

    /// The family's parameterisation.
    pub fn family(self) -> &'static dyn Family {
        match self {
            LawKind::Coulomb => &Coulomb,
            LawKind::Decreasing => &Decreasing,
            LawKind::StaticDynamic => &StaticDynamic,
            LawKind::Stribeck => &Stribeck,
        }
    }
}

impl fmt::Display for LawKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// The free parameters of one law family: how a parameter vector (SI, in
/// the order of [`Family::params`]) becomes an [`SiLaw`] and back. Adding a
/// family means one implementation here, one [`LawKind`] variant, its
/// regression basis in `identify::fit` and its start points in
/// `identify::output_error`.
pub trait Family: Sync {
    /// The family.
    fn kind(&self) -> LawKind;
    /// Its name in the JSON contract.
    fn name(&self) -> &'static str;
    /// Names of the free parameters, in vector order.
    fn params(&self) -> &'static [&'static str];
    /// True when the family has a static threshold of its own (ρs free
    /// above the sliding level).
    fn has_threshold(&self) -> bool;
    /// The law of parameter vector `p` (`p.len() ≥ self.params().len()`).
    fn unpack(&self, p: &[f64]) -> SiLaw;
    /// The parameter vector of `law` (parameters the family lacks are
    /// dropped).
    fn pack(&self, law: &SiLaw) -> Vec<f64>;
}

/// ρd = ρs, no slope: parameters `[Rd]`.
#[derive(Debug, Clone, Copy)]
pub struct Coulomb;
/// ρd = ρs plus a slope: parameters `[Rd, a]`.
#[derive(Debug, Clone, Copy)]
pub struct Decreasing;
/// ρd < ρs, no slope: parameters `[Rs, Rd]`.
#[derive(Debug, Clone, Copy)]
pub struct StaticDynamic;
/// Stribeck type: parameters `[Rs, Rd, a, v_s]`.
#[derive(Debug, Clone, Copy)]
pub struct Stribeck;

fn si(kind: LawKind, rs_n: f64, rd_n: f64, slope: f64, vs: Option<f64>) -> SiLaw {
    SiLaw {
        kind,
        rs_n,
        rd_n,
        slope_n_s_per_m: slope,
        vs_m_per_s: vs,
    }
}

impl Family for Coulomb {
    fn kind(&self) -> LawKind {
        LawKind::Coulomb
    }
    fn name(&self) -> &'static str {
        "coulomb"
    }
    fn params(&self) -> &'static [&'static str] {
        &["Rd"]
    }
    fn has_threshold(&self) -> bool {
        false
    }
    fn unpack(&self, p: &[f64]) -> SiLaw {
        si(self.kind(), p[0], p[0], 0.0, None)
    }
    fn pack(&self, l: &SiLaw) -> Vec<f64> {
        vec![l.rd_n]
    }
}

impl Family for Decreasing {
    fn kind(&self) -> LawKind {
        LawKind::Decreasing
    }
    fn name(&self) -> &'static str {
        "decreasing"
    }
    fn params(&self) -> &'static [&'static str] {
        &["Rd", "a"]
    }
    fn has_threshold(&self) -> bool {
        false
    }
    fn unpack(&self, p: &[f64]) -> SiLaw {
        si(self.kind(), p[0], p[0], p[1], None)
    }
    fn pack(&self, l: &SiLaw) -> Vec<f64> {
        vec![l.rd_n, l.slope_n_s_per_m]
    }
}

impl Family for StaticDynamic {
    fn kind(&self) -> LawKind {
        LawKind::StaticDynamic
    }
    fn name(&self) -> &'static str {
        "static-dynamic"
    }
    fn params(&self) -> &'static [&'static str] {
        &["Rs", "Rd"]
    }
    fn has_threshold(&self) -> bool {
        true
    }
    fn unpack(&self, p: &[f64]) -> SiLaw {
        si(self.kind(), p[0], p[1], 0.0, None)
    }
    fn pack(&self, l: &SiLaw) -> Vec<f64> {
        vec![l.rs_n, l.rd_n]
    }
}

impl Family for Stribeck {
    fn kind(&self) -> LawKind {
        LawKind::Stribeck
    }
    fn name(&self) -> &'static str {
        "stribeck"
    }
    fn params(&self) -> &'static [&'static str] {
        &["Rs", "Rd", "a", "v_s"]
    }
    fn has_threshold(&self) -> bool {
        true
    }
    fn unpack(&self, p: &[f64]) -> SiLaw {
        si(self.kind(), p[0], p[1], p[2], Some(p[3]))
    }
    fn pack(&self, l: &SiLaw) -> Vec<f64> {
        vec![
            l.rs_n,
            l.rd_n,
            l.slope_n_s_per_m,
            l.vs_m_per_s.unwrap_or(f64::NAN),
        ]
    }
}

/// A friction law in SI: g(v) = Rd + (Rs − Rd)·exp(−(v/v_s)²) + a·v for the
/// Stribeck type, Rd + a·v (threshold Rs) otherwise.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SiLaw {
    /// Family.
    pub kind: LawKind,
    /// Static threshold Rs (N).
    pub rs_n: f64,
    /// Dynamic level Rd (N).
    pub rd_n: f64,
    /// Slope a (N·s/m).
    pub slope_n_s_per_m: f64,
    /// Stribeck velocity (m/s), Stribeck type only.
    pub vs_m_per_s: Option<f64>,
}

impl SiLaw {
    /// The dimensionless law under `scales` (None if a parameter is unknown
    /// or the law is not physical). A linear family's Rd above Rs is
    /// clipped to Rs.
    ///
    /// ```
    /// use stickslip::model::{LawKind, RigConstants, Scales, SiLaw};
    /// let rig = RigConstants::paper();
    /// let scales = Scales::from_rig(&rig, 0.0025); // A·K2 = 1.675 N
    /// let law = SiLaw { kind: LawKind::Coulomb, rs_n: 0.67, rd_n: 0.67,
    ///                   slope_n_s_per_m: 0.0, vs_m_per_s: None };
    /// let rho = law.to_rho(&scales).unwrap();
    /// assert!((rho.rho_s() - 0.4).abs() < 1e-12);
    /// ```
    pub fn to_rho(&self, scales: &Scales) -> Option<Law> {
        let (rs, rd, a) = (
            self.rs_n / scales.force_n,
            self.rd_n / scales.force_n,
            self.slope_n_s_per_m / scales.slope_n_s_per_m,
        );
        if !(rs.is_finite() && rd.is_finite() && a.is_finite()) {
            return None;
        }
        let law = match (self.kind, self.vs_m_per_s) {
            (LawKind::Stribeck, Some(vs)) => Law::Stribeck {
                rho_s: rs,
                rho_d: rd,
                slope: a,
                v_s: vs / scales.velocity_m_per_s,
            },
            _ => Law::Linear {
                rho_s: rs,
                rho_d: rd.min(rs),
                slope: a,
            },
        };
        law.validate().ok().map(|_| law)
    }

    /// [Rs, Rd, a, ρs, ρd, D*] with force scale `force_n` (A·K2) and slope
    /// scale `slope_scale` (√(K2·M2)): the quantities whose calibration
    /// sensitivity the identification propagates.
    pub fn si_and_rho(&self, force_n: f64, slope_scale: f64) -> [f64; 6] {
        [
            self.rs_n,
            self.rd_n,
            self.slope_n_s_per_m,
            self.rs_n / force_n,
            self.rd_n / force_n,
            self.slope_n_s_per_m / slope_scale,
        ]
    }
}

/// The scales that make an SI law dimensionless for one drive amplitude.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Scales {
    /// A·K2 (N): ρ = R/(A·K2).
    pub force_n: f64,
    /// √(K2·M2) (N·s/m): D* = a/√(K2·M2).
    pub slope_n_s_per_m: f64,
    /// A·√(K2/M2) (m/s): the unit of a dimensionless velocity.
    pub velocity_m_per_s: f64,
}

impl Scales {
    /// Scales of a rig driven with amplitude `amplitude_m`.
    pub fn from_rig(rig: &RigConstants, amplitude_m: f64) -> Self {
        Self {
            force_n: amplitude_m * rig.k2_n_per_m,
            slope_n_s_per_m: rig.slope_scale(),
            velocity_m_per_s: amplitude_m * rig.omega_ref(),
        }
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
        self.sliding_with(v, self.decay(v))
    }

    /// g, dg/dv and d²g/dv² at speed v ≥ 0 (one exponential for the
    /// Stribeck law).
    #[inline]
    pub fn sliding_jet(&self, v: f64) -> (f64, f64, f64) {
        self.sliding_jet_with(v, self.decay(v))
    }

    /// dg/dv at speed v ≥ 0.
    #[inline]
    pub fn sliding_slope(&self, v: f64) -> f64 {
        self.sliding_slope_with(v, self.decay(v))
    }

    /// The one transcendental of g at speed v: the Stribeck law's decay
    /// e^{−(v/v_s)²} (1 for a linear law, which does not use it). The
    /// `_with` forms take it precomputed, so a caller evaluating g and its
    /// derivatives at one speed (the numerical engine: a step's last stage,
    /// the jet there and the interruption function) takes one exponential;
    /// they give the same numbers as the plain forms.
    #[inline]
    pub fn decay(&self, v: f64) -> f64 {
        match *self {
            Law::Linear { .. } => 1.0,
            Law::Stribeck { v_s, .. } => {
                let r = v / v_s;
                (-r * r).exp()
            }
        }
    }

    /// [`Law::sliding`] with its [`Law::decay`] `ex` at v.
    #[inline]
    pub fn sliding_with(&self, v: f64, ex: f64) -> f64 {
        match *self {
            Law::Linear { rho_d, slope, .. } => rho_d + slope * v,
            Law::Stribeck {
                rho_s,
                rho_d,
                slope,
                ..
            } => rho_d + (rho_s - rho_d) * ex + slope * v,
        }
    }

    /// [`Law::sliding_jet`] with its [`Law::decay`] `ex` at v.
    #[inline]
    pub fn sliding_jet_with(&self, v: f64, ex: f64) -> (f64, f64, f64) {
        match *self {
            Law::Linear { rho_d, slope, .. } => (rho_d + slope * v, slope, 0.0),
            Law::Stribeck {
                rho_s,
                rho_d,
                slope,
                v_s,
            } => {
                let r = v / v_s;
                let e = (rho_s - rho_d) * ex;
                (
                    rho_d + e + slope * v,
                    slope - 2.0 * r / v_s * e,
                    -2.0 / (v_s * v_s) * e * (1.0 - 2.0 * r * r),
                )
            }
        }
    }

    /// [`Law::sliding_slope`] with its [`Law::decay`] `ex` at v.
    #[inline]
    pub fn sliding_slope_with(&self, v: f64, ex: f64) -> f64 {
        match *self {
            Law::Linear { slope, .. } => slope,
            Law::Stribeck {
                rho_s,
                rho_d,
                slope,
                v_s,
            } => {
                let r = v / v_s;
                slope - 2.0 * r / v_s * (rho_s - rho_d) * ex
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

    /// The law's family: the Stribeck type, else static-dynamic where
    /// ρd < ρs, decreasing where it has a slope, Coulomb otherwise.
    pub fn kind(&self) -> LawKind {
        match *self {
            Law::Stribeck { .. } => LawKind::Stribeck,
            Law::Linear {
                rho_s,
                rho_d,
                slope,
            } => {
                if rho_d < rho_s {
                    LawKind::StaticDynamic
                } else if slope != 0.0 {
                    LawKind::Decreasing
                } else {
                    LawKind::Coulomb
                }
            }
        }
    }

    /// The law's name in the interface (`coulomb`, `decreasing`,
    /// `static-dynamic`, `stribeck`).
    pub fn name(&self) -> &'static str {
        self.kind().as_str()
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

#[cfg(test)]
mod tests {

    use super::*;

    /// `sliding_jet` agrees with `sliding`, `sliding_slope` and a central
    /// difference of the slope for both law families.
    #[test]
    fn sliding_jet_matches_parts() {
        for law in [
            Law::Stribeck {
                rho_s: 1.0,
                rho_d: 0.6,
                slope: 0.01,
                v_s: 0.3,
            },
            Law::Linear {
                rho_s: 1.0,
                rho_d: 0.8,
                slope: -0.02,
            },
        ] {
            for v in [0.0, 0.05, 0.2, 0.3, 0.7, 2.0] {
                let (g, g1, g2) = law.sliding_jet(v);
                assert!((g - law.sliding(v)).abs() <= 1e-15, "{law:?} {v}");
                assert!((g1 - law.sliding_slope(v)).abs() <= 1e-15, "{law:?} {v}");
                let (e, sl) = (1e-6, |v: f64| law.sliding_slope(v));
                let fd = if v >= e {
                    (sl(v + e) - sl(v - e)) / (2.0 * e)
                } else {
                    (sl(v + e) - sl(v)) / e
                };
                assert!(
                    (g2 - fd).abs() <= 1e-4 * (1.0 + g2.abs()),
                    "{law:?} {v}: {g2} vs {fd}"
                );
            }
        }
    }

    #[test]
    fn kinds_round_trip_through_names_serde_and_families() {
        for k in LawKind::ALL {
            assert_eq!(LawKind::parse(k.as_str()), Some(k));
            let json = serde_json::to_string(&k).unwrap();
            assert_eq!(json, format!("\"{}\"", k.as_str()));
            let f = k.family();
            assert_eq!(f.kind(), k);
            let p: Vec<f64> = (0..f.params().len()).map(|i| 1.0 + i as f64).collect();
            assert_eq!(f.pack(&f.unpack(&p)), p, "{k}");
        }
    }

    #[test]
    fn to_rho_scales_each_parameter() {
        let rig = RigConstants::paper();
        let s = Scales::from_rig(&rig, 0.002);
        let l = SiLaw {
            kind: LawKind::Stribeck,
            rs_n: 1.0,
            rd_n: 0.5,
            slope_n_s_per_m: 0.3,
            vs_m_per_s: Some(0.01),
        };
        let Some(Law::Stribeck {
            rho_s,
            rho_d,
            slope,
            v_s,
        }) = l.to_rho(&s)
        else {
            panic!("not a Stribeck law")
        };
        let (k2, m2) = (rig.k2_n_per_m, rig.m2_kg);
        assert!((rho_s - 1.0 / (0.002 * k2)).abs() < 1e-12);
        assert!((rho_d - 0.5 / (0.002 * k2)).abs() < 1e-12);
        assert!((slope - 0.3 / (k2 * m2).sqrt()).abs() < 1e-12);
        assert!((v_s - 0.01 / (0.002 * (k2 / m2).sqrt())).abs() < 1e-12);
        let unknown = SiLaw {
            rs_n: f64::NAN,
            ..l
        };
        assert_eq!(unknown.to_rho(&s), None);
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
