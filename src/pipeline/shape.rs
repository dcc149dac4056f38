//! The dimensionless model of `simulate` and `sweep` from plain values:
//! the absorber and the shape of the law ([`ShapeSpec`]), completed by a
//! static threshold ρs, a dynamic level ρd and a contact stiffness κ into
//! a validated [`Model`] ([`ShapeSpec::model_with`]). The command line's
//! model options fill a [`ShapeSpec`]; a library user fills one directly
//! (its [`Default`] is the paper's absorber with a Coulomb law).

use crate::model::{Absorber, Law, LawKind, Levels, Model};
use crate::sim::SimError;

/// The model options shared by `simulate` and `sweep` (all but ρs and
/// ρd), as plain values.
#[derive(Debug, Clone, PartialEq)]
pub struct ShapeSpec {
    /// Mass ratio m = M1/M2.
    pub m: f64,
    /// Stiffness ratio k = K1/K2.
    pub k: f64,
    /// Viscous damping D = d/sqrt(K2 M2).
    pub damping: f64,
    /// Slope D* of the characteristic (ignored where ρs = 0: no friction).
    pub slope: f64,
    /// Velocity scale v_s of a law that has one (None: an affine law).
    pub v_s: Option<f64>,
    /// Family of a law with a velocity scale (None: stribeck); used only
    /// with `v_s`.
    pub law: Option<LawKind>,
    /// Interrupt when the sliding friction falls below F·ρs (of the current
    /// sliding direction).
    pub stop_below: Option<f64>,
    /// Direction-dependent friction: the static threshold for sliding in the
    /// negative direction (None: ρs, which then holds both ways).
    pub rho_s_minus: Option<f64>,
    /// The dynamic level for sliding in the negative direction (None:
    /// `rho_s_minus` where it is given, else ρd).
    pub rho_d_minus: Option<f64>,
    /// Pre-sliding: contact stiffnesses κ = kt/K2 (empty: the rigid stick;
    /// inf: the rigid stick). One model takes at most one ([`Self::model`]);
    /// a family takes one set of curves per value
    /// ([`Self::contact_stiffnesses`]).
    pub contact_stiffness: Vec<f64>,
}

impl Default for ShapeSpec {
    /// The paper's absorber (m = 4, k = 1, D = 0.005) with an affine law
    /// of slope 0, in both directions alike, with a rigid stick.
    fn default() -> Self {
        ShapeSpec {
            m: 4.0,
            k: 1.0,
            damping: 0.005,
            slope: 0.0,
            v_s: None,
            law: None,
            stop_below: None,
            rho_s_minus: None,
            rho_d_minus: None,
            contact_stiffness: Vec::new(),
        }
    }
}

impl ShapeSpec {
    /// The validated model with static threshold `rho_s` and dynamic level
    /// `rho_d` (default: ρs, or 0 when ρs = ∞) and the one contact
    /// stiffness given, if any (more than one is refused: a list is for a
    /// family).
    pub fn model(&self, rho_s: f64, rho_d: Option<f64>) -> crate::Result<Model> {
        let kappa = match self.contact_stiffness[..] {
            [] => None,
            [k] => Some(k),
            _ => {
                return Err(SimError::Unsupported(
                    "--contact-stiffness: give one value here (a list is for sweep)".into(),
                )
                .into())
            }
        };
        self.model_with(rho_s, rho_d, kappa)
    }

    /// The contact stiffnesses of a family: one set of curves per value
    /// (`None`: the rigid stick, where none is given).
    pub fn contact_stiffnesses(&self) -> Vec<Option<f64>> {
        if self.contact_stiffness.is_empty() {
            vec![None]
        } else {
            self.contact_stiffness.iter().map(|&k| Some(k)).collect()
        }
    }

    /// [`ShapeSpec::model`] with the contact stiffness `kappa` (None or
    /// inf: the rigid stick).
    pub fn model_with(
        &self,
        rho_s: f64,
        rho_d: Option<f64>,
        kappa: Option<f64>,
    ) -> crate::Result<Model> {
        // ρs = 0 means no friction device: no slope, no dynamic level.
        let slope = if rho_s == 0.0 { 0.0 } else { self.slope };
        let rho_d = match rho_d {
            _ if rho_s == 0.0 => 0.0,
            Some(v) => v,
            None if rho_s.is_finite() => rho_s,
            None => 0.0,
        };
        let linear = Law::Linear {
            rho_s,
            rho_d,
            slope,
            minus: None,
        };
        // The command line admits only families with a velocity scale, and
        // --law only with --v-s.
        let shaped = self.law.unwrap_or(LawKind::Stribeck);
        let law = match self.v_s {
            Some(v_s) if rho_s > 0.0 => Law::of(shaped, rho_s, rho_d, slope, Some(v_s)),
            _ => None,
        }
        .unwrap_or(linear);
        let minus = match (self.rho_s_minus, self.rho_d_minus) {
            (None, None) => None,
            (Some(rs), rd) => Some(Levels {
                rho_s: rs,
                rho_d: rd.unwrap_or(if rs.is_finite() { rs } else { 0.0 }),
            }),
            (None, Some(rd)) => Some(Levels { rho_s, rho_d: rd }),
        };
        let law = law.with_minus(minus);
        let model = Model {
            absorber: Absorber {
                m: self.m,
                k: self.k,
                damping: self.damping,
            },
            law,
            stop_below: self.stop_below,
            // inf is the paper's rigid stick.
            contact_stiffness: kappa.filter(|k| *k != f64::INFINITY),
        };
        model.validate()?;
        Ok(model)
    }
}
