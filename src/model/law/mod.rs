//! Friction laws: one trait for a law family, one file per family, and the
//! registry of the families. This module owns everything that knows what a
//! family is; every other module asks [`LawKind`] (a handle on a registered
//! family) or the [`LawFamily`] trait behind it, so no code elsewhere
//! matches on a family.
//!
//! * [`LawFamily`]: one family — its parameters, SI ↔ ρ (through [`Scales`]
//!   only), its sliding friction and derivatives, whether it is affine (the
//!   exact engine) or not (the numerical engine), its equation-error
//!   regression basis, its output-error starts and steps, its interval
//!   draws, its description, and its place in `--law auto` ([`Selection`]);
//! * [`LawKind`]: a registered family by name (the JSON contract's `law`
//!   key: `coulomb`, `decreasing`, `static-dynamic`, `stribeck`, …);
//!   [`LawKind::all`] is the registry (`registry.rs`, one line a family);
//! * [`SiLaw`]: a law in SI (N, N·s/m, m/s), as fitted and reported;
//! * [`Law`]: the dimensionless law the engines integrate: affine
//!   ([`Law::Linear`], closed-form slip phases) or shaped by its family
//!   ([`Law::Shaped`], integrated numerically);
//! * [`Scales`]: the one place where SI becomes dimensionless
//!   ([`SiLaw::to_rho`]), built by [`Scales::from_rig`].
//!
//! # Adding a family
//!
//! One file here implementing [`LawFamily`], and its line in
//! `registry.rs` (its `mod` and its entry). A family with
//! [`Selection::OnRequest`] is fitted only with `--law <name>`, so the
//! outputs of `--law auto` do not move.
//!
//! # Real pads (issue 34)
//!
//! * **Levels per sliding direction** (built): a law may carry the levels
//!   of the negative direction ([`Levels`], [`Law::minus`]); its own
//!   levels then hold for the positive one. Callers read the levels
//!   through [`Law::levels`] or the symmetric law of one direction,
//!   [`Law::toward`], so the families do not change.
//! * **A fifth state** (not built yet): a phase may carry the position of
//!   a friction slider behind a contact spring. The trait describes g(v)
//!   of the contact only; the state layout belongs to the engines, so a
//!   slider adds a state to the engine, not a rewrite of the families.

mod registry;

use super::{check, ParamError, RigConstants};
use serde::{Deserialize, Serialize};
use std::fmt;

/// Where a family stands in `--law auto`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Selection {
    /// A candidate of every automatic fit (equation and output error).
    Simple,
    /// A candidate of the equation-error fit; in the output-error
    /// refinement it is tried only when no simple family explains the log
    /// or `limit` (the family it tends to) does with structured residuals.
    Rescue {
        /// The simple family this one tends to (e.g. v_s → 0).
        limit: LawKind,
    },
    /// Fitted only when asked for by name (`--law <name>`).
    OnRequest,
}

/// The optima of the families already refined, by family (θ: the law's
/// parameters, then bias and the two gains), for nested output-error
/// starts.
pub type Optimum<'a> = &'a dyn Fn(LawKind) -> Option<Vec<f64>>;

/// One friction-law family. Parameter vectors are SI, in the order of
/// [`LawFamily::params`]. The dimensionless methods (`decay`, `jet_with`,
/// `slope_with`) are used only for a non-affine family (they
/// are what the numerical engine calls within slip phases); an affine
/// family is integrated in closed form from [`Law::Linear`].
pub trait LawFamily: Sync + Send {
    /// Its name in options and in the JSON contract's `law` key.
    fn name(&self) -> &'static str;
    /// Its sliding friction in one line (SI symbols).
    fn describe(&self) -> &'static str;
    /// Names of the free parameters, in vector order.
    fn params(&self) -> &'static [&'static str];
    /// True when the family has a static threshold of its own (Rs free
    /// above the sliding level).
    fn has_threshold(&self) -> bool;
    /// True when the family has a velocity scale v_s (found by variable
    /// projection in the equation-error fit; the law is then not affine).
    fn has_velocity_scale(&self) -> bool {
        false
    }
    /// Where the family stands in `--law auto`.
    fn selection(&self) -> Selection;
    /// The law of parameter vector `p` (`p.len() ≥ self.params().len()`).
    fn unpack(&self, p: &[f64]) -> SiLaw;
    /// The parameter vector of `law` (parameters the family lacks are
    /// dropped).
    fn pack(&self, law: &SiLaw) -> Vec<f64>;

    /// The dimensionless law with levels ρs, ρd, slope D* and (for a family
    /// with a velocity scale) v_s; None where v_s is missing or not > 0.
    /// Not validated (see [`Law::validate`]).
    fn law(&self, rho_s: f64, rho_d: f64, slope: f64, v_s: Option<f64>) -> Option<Law> {
        let _ = v_s;
        Some(Law::Linear {
            rho_s,
            rho_d,
            slope,
            minus: None,
        })
    }
    /// The one transcendental of g at speed v ≥ 0 (1 for an affine law).
    fn decay(&self, v: f64, v_s: f64) -> f64 {
        let _ = (v, v_s);
        1.0
    }
    /// (g, dg/dv, d²g/dv²) with the decay `ex` at v.
    #[allow(clippy::too_many_arguments)]
    fn jet_with(
        &self,
        rho_s: f64,
        rho_d: f64,
        slope: f64,
        v_s: f64,
        v: f64,
        ex: f64,
    ) -> (f64, f64, f64) {
        let _ = (rho_s, v_s, ex);
        (rho_d + slope * v, slope, 0.0)
    }
    /// dg/dv with the decay `ex` at v.
    fn slope_with(&self, rho_s: f64, rho_d: f64, slope: f64, v_s: f64, v: f64, ex: f64) -> f64 {
        let _ = (rho_s, rho_d, v_s, v, ex);
        slope
    }
    /// The sliding friction magnitude (N) of an SI law at speed u ≥ 0 (m/s).
    fn si_sliding(&self, law: &SiLaw, u: f64) -> f64 {
        law.rd_n + law.slope_n_s_per_m * u
    }

    /// Equation-error regressors of a slip sample (direction `s`, speed
    /// `u`, gain terms `k1`, `k2`; velocity scale `vs` where the family has
    /// one): the bias, the law's terms, then `k1`, `k2`; their number.
    fn basis(&self, s: f64, u: f64, k1: f64, k2: f64, vs: f64) -> ([f64; 6], usize);
    /// The one column of [`LawFamily::basis`] that depends on `vs` (None
    /// for a family without a velocity scale): the rest of the normal
    /// equations is accumulated once per velocity-scale search.
    fn scale_column(&self) -> Option<usize> {
        None
    }
    /// True when Rs is the breakaway level (the median over breakaways)
    /// rather than a value of the slip fit.
    fn rs_from_breakaways(&self) -> bool {
        false
    }
    /// Rs of the equation-error coefficients `coef` (bias, the law's terms,
    /// gains); `breakaway` is the median breakaway level where
    /// [`LawFamily::rs_from_breakaways`].
    fn ee_rs(&self, coef: &[f64], breakaway: f64) -> f64 {
        let _ = breakaway;
        coef[1]
    }
    /// False where the coefficients are not this family (static above
    /// dynamic, a peak not a dip): then it is no candidate.
    fn ee_admissible(&self, coef: &[f64], rs: f64) -> bool {
        let _ = (coef, rs);
        true
    }
    /// The law of the equation-error coefficients, Rs `rs` and velocity
    /// scale `vs`.
    fn ee_law(&self, coef: &[f64], rs: f64, vs: f64) -> SiLaw;

    /// Output-error Nelder–Mead steps of the law's parameters `th` (the
    /// start), with `f` the force scale and `rs_step` the threshold step.
    fn oe_steps(&self, th: &[f64], f: f64, rs_step: f64) -> Vec<f64>;
    /// An output-error start where the equation-error fit gave none, from
    /// the optima of simpler families (`a`: drive amplitude, m; `omega`:
    /// √(K2/M2), 1/s).
    fn oe_fallback(&self, optimum: Optimum, a: f64, omega: f64) -> Option<SiLaw> {
        let _ = (optimum, a, omega);
        None
    }
    /// Nested output-error starts (full θ) from the optima of simpler
    /// families, so a richer family never ends worse than one it contains;
    /// `th_ee` is its equation-error start, `va` = A·ω (m/s).
    fn oe_nested(&self, th_ee: &[f64], optimum: Optimum, va: f64) -> Vec<Vec<f64>> {
        let _ = (th_ee, optimum, va);
        Vec::new()
    }
    /// True when the start also screens a grid of thresholds above the
    /// Coulomb optimum (short sticks at reversal hide in a narrow basin).
    fn oe_threshold_screen(&self) -> bool {
        false
    }
    /// The finite-difference step of law parameter `j` for the Jacobian of
    /// the intervals (None: 2e-3 of the force scale).
    fn oe_jac_step(&self, j: usize, law: &SiLaw) -> Option<f64> {
        let _ = (j, law);
        None
    }
    /// True when the intervals hold the Coulomb law this family nests
    /// (D* = 0, ρs = ρd): the extra parameter is not supported.
    fn nests_coulomb(
        &self,
        law: &SiLaw,
        rs_interval: Option<(f64, f64)>,
        slope_interval: Option<(f64, f64)>,
    ) -> bool {
        let _ = (law, rs_interval, slope_interval);
        false
    }

    /// Interval draws: true where Rs is tied to Rd (no threshold of its
    /// own), so a draw of Rd moves Rs with it.
    fn tied_threshold(&self) -> bool {
        !self.has_threshold()
    }
    /// Interval draws: true where the slope is a parameter of the family
    /// (drawn even where it is 0).
    fn free_slope(&self) -> bool {
        self.params().contains(&"a")
    }

    /// The law a synthetic rig uses: threshold `rs`, sliding level `rd`,
    /// slope `slope` if given, velocity scale `vs` (N, N·s/m, m/s).
    fn synth_law(&self, rs: f64, rd: f64, slope: Option<f64>, vs: f64) -> SiLaw;
}

/// A registered friction-law family (names as in the JSON contract's `law`
/// key). A handle: the behaviour is its [`LawFamily`] ([`LawKind::family`]).
#[derive(Clone, Copy)]
pub struct LawKind(&'static dyn LawFamily);

#[allow(non_upper_case_globals)]
impl LawKind {
    /// ρd = ρs, no slope.
    pub const Coulomb: LawKind = LawKind(&registry::coulomb::Coulomb);
    /// ρd = ρs with a linear slope D* of either sign.
    pub const Decreasing: LawKind = LawKind(&registry::decreasing::Decreasing);
    /// ρd < ρs, no slope.
    pub const StaticDynamic: LawKind = LawKind(&registry::static_dynamic::StaticDynamic);
    /// ρd + (ρs − ρd)·exp(−(v/v_s)²) + D*·v.
    pub const Stribeck: LawKind = LawKind(&registry::stribeck::Stribeck);

    /// Every registered family, simplest first.
    pub fn all() -> &'static [LawKind] {
        registry::REGISTRY
    }

    /// The families of `--law auto` in the equation-error fit (the simple
    /// ones and the rescues), in registry order.
    pub fn auto() -> impl Iterator<Item = LawKind> {
        Self::all()
            .iter()
            .copied()
            .filter(|k| k.family().selection() != Selection::OnRequest)
    }

    /// The name used in options and in the `law` key.
    pub fn as_str(self) -> &'static str {
        self.0.name()
    }

    /// Parses a law name.
    ///
    /// ```
    /// use stickslip::model::LawKind;
    /// assert_eq!(LawKind::parse("static-dynamic"), Some(LawKind::StaticDynamic));
    /// assert_eq!(LawKind::parse("static_dynamic"), None);
    /// ```
    pub fn parse(s: &str) -> Option<Self> {
        Self::all().iter().copied().find(|k| k.as_str() == s)
    }

    /// The family's behaviour.
    pub fn family(self) -> &'static dyn LawFamily {
        self.0
    }
}

impl PartialEq for LawKind {
    fn eq(&self, other: &Self) -> bool {
        self.as_str() == other.as_str()
    }
}

impl Eq for LawKind {}

impl std::hash::Hash for LawKind {
    fn hash<H: std::hash::Hasher>(&self, state: &mut H) {
        self.as_str().hash(state)
    }
}

impl fmt::Debug for LawKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

impl fmt::Display for LawKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

impl Serialize for LawKind {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.as_str())
    }
}

impl<'de> Deserialize<'de> for LawKind {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let s = String::deserialize(d)?;
        LawKind::parse(&s).ok_or_else(|| {
            let names: Vec<&str> = LawKind::all().iter().map(|k| k.as_str()).collect();
            serde::de::Error::custom(format!(
                "unknown law `{s}` (expected one of {})",
                names.join(", ")
            ))
        })
    }
}

/// A friction law in SI: the sliding friction g(v) of its family
/// ([`LawFamily::describe`]), static threshold Rs.
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
    /// Velocity scale v_s (m/s) of a family that has one.
    pub vs_m_per_s: Option<f64>,
}

impl SiLaw {
    /// The dimensionless law under `scales` (None if a parameter is unknown
    /// or the law is not physical). An affine family's Rd above Rs is
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
        let vs = self.vs_m_per_s.map(|vs| vs / scales.velocity_m_per_s);
        let law = match self.kind.family().law(rs, rd, a, vs)? {
            Law::Linear { .. } => Law::Linear {
                rho_s: rs,
                rho_d: rd.min(rs),
                slope: a,
                minus: None,
            },
            shaped => shaped,
        };
        law.validate().ok().map(|_| law)
    }

    /// The sliding friction magnitude (N) at speed u ≥ 0 (m/s).
    pub fn sliding_n(&self, u: f64) -> f64 {
        self.kind.family().si_sliding(self, u)
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
/// a law of another shape is [`Law::Shaped`] by its family (nonlinear in
/// v), which the engine integrates numerically within slip phases.
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
        /// The levels of the negative sliding direction of a
        /// direction-dependent pad (None: the same as `rho_s`, `rho_d`,
        /// which then hold for both directions).
        minus: Option<Levels>,
    },
    /// A law of family `kind` with a velocity scale:
    /// g(v) = ρd + (ρs − ρd)·φ(v) + D*·v with the family's decay φ
    /// ([`LawFamily::decay`], φ(0) = 1, so g(0+) = ρs).
    Shaped {
        /// The family (its [`LawFamily::decay`] and derivatives).
        kind: LawKind,
        /// Static threshold ρs = g(0+).
        rho_s: f64,
        /// Dynamic level ρd ≤ ρs.
        rho_d: f64,
        /// Slope D*.
        slope: f64,
        /// Velocity scale v_s > 0.
        v_s: f64,
        /// The levels of the negative sliding direction (None: symmetric).
        minus: Option<Levels>,
    },
}

/// The two levels of one sliding direction of a direction-dependent law
/// (dimensionless): its static threshold and its dynamic level.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Levels {
    /// Static threshold of the direction (breakaway towards it).
    pub rho_s: f64,
    /// Dynamic level of the direction, ≤ its threshold.
    pub rho_d: f64,
}

impl Law {
    /// Coulomb's law, ρd = ρs (Fig. 2a). For ρs = ∞ (never slides) the
    /// unused dynamic level is set to 0.
    pub fn coulomb(rho_s: f64) -> Self {
        Law::Linear {
            rho_s,
            rho_d: if rho_s.is_finite() { rho_s } else { 0.0 },
            slope: 0.0,
            minus: None,
        }
    }

    /// The law of family `kind` (levels ρs, ρd, slope D*, velocity scale
    /// v_s where the family has one); None where the family needs a v_s
    /// and `v_s` is missing or not > 0. Not validated.
    pub fn of(kind: LawKind, rho_s: f64, rho_d: f64, slope: f64, v_s: Option<f64>) -> Option<Self> {
        kind.family().law(rho_s, rho_d, slope, v_s)
    }

    /// Static threshold ρs.
    pub fn rho_s(&self) -> f64 {
        match *self {
            Law::Linear { rho_s, .. } | Law::Shaped { rho_s, .. } => rho_s,
        }
    }

    /// Dynamic level ρd.
    pub fn rho_d(&self) -> f64 {
        match *self {
            Law::Linear { rho_d, .. } | Law::Shaped { rho_d, .. } => rho_d,
        }
    }

    /// Slope D*.
    pub fn slope(&self) -> f64 {
        match *self {
            Law::Linear { slope, .. } | Law::Shaped { slope, .. } => slope,
        }
    }

    /// Velocity scale v_s of a shaped law (None for an affine one).
    pub fn v_s(&self) -> Option<f64> {
        match *self {
            Law::Linear { .. } => None,
            Law::Shaped { v_s, .. } => Some(v_s),
        }
    }

    /// The negative direction's levels of a direction-dependent law (None:
    /// symmetric).
    pub fn minus(&self) -> Option<Levels> {
        match *self {
            Law::Linear { minus, .. } | Law::Shaped { minus, .. } => minus,
        }
    }

    /// The same law with the negative direction's levels `minus` (None:
    /// symmetric). Not validated.
    pub fn with_minus(mut self, minus: Option<Levels>) -> Self {
        match &mut self {
            Law::Linear { minus: m, .. } | Law::Shaped { minus: m, .. } => *m = minus,
        }
        self
    }

    /// True when the levels differ by sliding direction.
    pub fn is_direction_dependent(&self) -> bool {
        self.minus()
            .is_some_and(|l| l.rho_s != self.rho_s() || l.rho_d != self.rho_d())
    }

    /// The levels (threshold, dynamic level) of sliding direction `dir`
    /// (> 0: positive, the law's own `rho_s`, `rho_d`; < 0: negative).
    #[inline]
    pub fn levels(&self, dir: f64) -> Levels {
        match self.minus() {
            Some(l) if dir < 0.0 => l,
            _ => Levels {
                rho_s: self.rho_s(),
                rho_d: self.rho_d(),
            },
        }
    }

    /// The symmetric law that acts while sliding in direction `dir` (or
    /// breaking away towards it): the levels of that direction, the slope
    /// and the velocity scale shared.
    ///
    /// ```
    /// use stickslip::model::{Law, Levels};
    /// let law = Law::coulomb(0.4).with_minus(Some(Levels { rho_s: 0.3, rho_d: 0.25 }));
    /// assert_eq!(law.toward(1.0), Law::coulomb(0.4));
    /// assert_eq!(law.toward(-1.0).rho_s(), 0.3);
    /// assert_eq!(law.toward(-1.0).rho_d(), 0.25);
    /// ```
    pub fn toward(&self, dir: f64) -> Law {
        let Levels { rho_s, rho_d } = self.levels(dir);
        match *self {
            Law::Linear { slope, .. } => Law::Linear {
                rho_s,
                rho_d,
                slope,
                minus: None,
            },
            Law::Shaped {
                kind, slope, v_s, ..
            } => Law::Shaped {
                kind,
                rho_s,
                rho_d,
                slope,
                v_s,
                minus: None,
            },
        }
    }

    /// Sliding friction magnitude g(v) at speed v ≥ 0 (may be negative for
    /// a falling characteristic at high speed: the engine interrupts there).
    #[inline]
    pub fn sliding(&self, v: f64) -> f64 {
        self.sliding_with(v, self.decay(v))
    }

    /// g, dg/dv and d²g/dv² at speed v ≥ 0 (one transcendental for a
    /// shaped law).
    #[inline]
    pub fn sliding_jet(&self, v: f64) -> (f64, f64, f64) {
        self.sliding_jet_with(v, self.decay(v))
    }

    /// dg/dv at speed v ≥ 0.
    #[inline]
    pub fn sliding_slope(&self, v: f64) -> f64 {
        self.sliding_slope_with(v, self.decay(v))
    }

    /// The one transcendental of g at speed v ([`LawFamily::decay`]; 1 for
    /// a linear law, which does not use it). The `_with` forms take it
    /// precomputed, so a caller evaluating g and its derivatives at one
    /// speed (the numerical engine: a step's last stage, the jet there and
    /// the interruption function) takes one transcendental; they give the
    /// same numbers as the plain forms.
    #[inline]
    pub fn decay(&self, v: f64) -> f64 {
        match *self {
            Law::Linear { .. } => 1.0,
            Law::Shaped { kind, v_s, .. } => kind.0.decay(v, v_s),
        }
    }

    /// [`Law::sliding`] with its [`Law::decay`] `ex` at v.
    #[inline]
    pub fn sliding_with(&self, v: f64, ex: f64) -> f64 {
        match *self {
            Law::Linear { rho_d, slope, .. } => rho_d + slope * v,
            Law::Shaped {
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
            Law::Shaped {
                kind,
                rho_s,
                rho_d,
                slope,
                v_s,
                ..
            } => kind.0.jet_with(rho_s, rho_d, slope, v_s, v, ex),
        }
    }

    /// [`Law::sliding_slope`] with its [`Law::decay`] `ex` at v.
    #[inline]
    pub fn sliding_slope_with(&self, v: f64, ex: f64) -> f64 {
        match *self {
            Law::Linear { slope, .. } => slope,
            Law::Shaped {
                kind,
                rho_s,
                rho_d,
                slope,
                v_s,
                ..
            } => kind.0.slope_with(rho_s, rho_d, slope, v_s, v, ex),
        }
    }

    /// `Some((ρd, D*))` when g is affine in v, so slip phases are linear ODEs
    /// with a closed-form solution.
    pub fn affine(&self) -> Option<(f64, f64)> {
        match *self {
            Law::Linear { rho_d, slope, .. } => Some((rho_d, slope)),
            Law::Shaped { .. } => None,
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
        if let Some(l) = self.minus() {
            check(
                "rho-s-minus",
                l.rho_s,
                !l.rho_s.is_nan() && l.rho_s >= 0.0,
                "must be >= 0 (inf allowed)",
            )?;
            check(
                "rho-s-minus",
                l.rho_s,
                (l.rho_s == 0.0) == (rs == 0.0) && l.rho_s.is_finite() == rs.is_finite(),
                "must be 0 (no friction) or inf (always stuck) exactly where rho-s is",
            )?;
            check(
                "rho-d-minus",
                l.rho_d,
                l.rho_d.is_finite() && l.rho_d >= 0.0,
                "must be finite and >= 0",
            )?;
            check(
                "rho-d-minus",
                l.rho_d,
                l.rho_d <= l.rho_s,
                "must not exceed rho-s-minus (dynamic > static friction)",
            )?;
        }
        if let Some(v_s) = self.v_s() {
            check(
                "v-s",
                v_s,
                v_s.is_finite() && v_s > 0.0,
                "must be finite and > 0",
            )?;
        }
        Ok(())
    }

    /// The law's family: its own for a shaped law; for an affine one
    /// static-dynamic where ρd < ρs, decreasing where it has a slope,
    /// Coulomb otherwise.
    pub fn kind(&self) -> LawKind {
        match *self {
            Law::Shaped { kind, .. } => kind,
            Law::Linear {
                rho_s,
                rho_d,
                slope,
                minus,
            } => {
                let dips = minus.is_some_and(|l| l.rho_d < l.rho_s);
                if rho_d < rho_s || dips {
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
    /// `static-dynamic`, `stribeck`, …).
    pub fn name(&self) -> &'static str {
        self.kind().as_str()
    }
}

impl fmt::Display for Law {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} (rho_s={}, rho_d={}, slope={}",
            self.name(),
            self.rho_s(),
            self.rho_d(),
            self.slope()
        )?;
        if let Some(l) = self.minus() {
            write!(f, ", rho_s_minus={}, rho_d_minus={}", l.rho_s, l.rho_d)?;
        }
        f.write_str(")")
    }
}

#[cfg(test)]
mod tests;
