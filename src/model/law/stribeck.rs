//! The Stribeck-type law: g(v) = Rd + (Rs − Rd)·exp(−(v/v_s)²) + a·v, a
//! peak Rs at rest falling to Rd over the Stribeck velocity v_s. Not
//! affine: the numerical engine integrates its slip phases.

use super::super::{Law, LawFamily, Optimum, Selection, SiLaw};
use super::LawKind;

/// Stribeck type: parameters `[Rs, Rd, a, v_s]`.
#[derive(Debug, Clone, Copy)]
pub struct Stribeck;

impl LawFamily for Stribeck {
    fn name(&self) -> &'static str {
        "stribeck"
    }
    fn describe(&self) -> &'static str {
        "g(v) = Rd + (Rs − Rd)·exp(−(v/v_s)²) + a·v"
    }
    fn params(&self) -> &'static [&'static str] {
        &["Rs", "Rd", "a", "v_s"]
    }
    fn has_threshold(&self) -> bool {
        true
    }
    fn has_velocity_scale(&self) -> bool {
        true
    }
    /// The static/dynamic law is its limit v_s → 0.
    fn selection(&self) -> Selection {
        Selection::Rescue {
            limit: LawKind::StaticDynamic,
        }
    }
    fn unpack(&self, p: &[f64]) -> SiLaw {
        law(p[0], p[1], p[2], Some(p[3]))
    }
    fn pack(&self, l: &SiLaw) -> Vec<f64> {
        vec![
            l.rs_n,
            l.rd_n,
            l.slope_n_s_per_m,
            l.vs_m_per_s.unwrap_or(f64::NAN),
        ]
    }
    fn law(&self, rho_s: f64, rho_d: f64, slope: f64, v_s: Option<f64>) -> Option<Law> {
        v_s.map(|v_s| Law::Shaped {
            kind: LawKind::Stribeck,
            rho_s,
            rho_d,
            slope,
            v_s,
            minus: None,
        })
    }
    #[inline]
    fn decay(&self, v: f64, v_s: f64) -> f64 {
        let r = v / v_s;
        (-r * r).exp()
    }
    #[inline]
    fn jet_with(
        &self,
        rho_s: f64,
        rho_d: f64,
        slope: f64,
        v_s: f64,
        v: f64,
        ex: f64,
    ) -> (f64, f64, f64) {
        let r = v / v_s;
        let e = (rho_s - rho_d) * ex;
        (
            rho_d + e + slope * v,
            slope - 2.0 * r / v_s * e,
            -2.0 / (v_s * v_s) * e * (1.0 - 2.0 * r * r),
        )
    }
    #[inline]
    fn slope_with(&self, rho_s: f64, rho_d: f64, slope: f64, v_s: f64, v: f64, ex: f64) -> f64 {
        let r = v / v_s;
        slope - 2.0 * r / v_s * (rho_s - rho_d) * ex
    }
    fn si_sliding(&self, l: &SiLaw, u: f64) -> f64 {
        let mut g = l.rd_n + l.slope_n_s_per_m * u;
        if let Some(vs) = l.vs_m_per_s {
            g += (l.rs_n - l.rd_n) * self.decay(u, vs);
        }
        g
    }
    /// For given v_s the law is linear in (b, Rd, Rs − Rd, a).
    fn basis(&self, s: f64, u: f64, k1: f64, k2: f64, vs: f64) -> ([f64; 6], usize) {
        ([1.0, s, s * self.decay(u, vs), s * u, k1, k2], 6)
    }
    /// s·decay(u, v_s).
    fn scale_column(&self) -> Option<usize> {
        Some(2)
    }
    /// g(0+) = Rd + (Rs − Rd).
    fn ee_rs(&self, coef: &[f64], _breakaway: f64) -> f64 {
        coef[1] + coef[2]
    }
    /// A peak (ρs > ρd): a dip or a vanishing peak is a simple law with an
    /// idle extra term.
    fn ee_admissible(&self, coef: &[f64], _rs: f64) -> bool {
        coef[2].partial_cmp(&0.0) == Some(std::cmp::Ordering::Greater)
    }
    fn ee_law(&self, coef: &[f64], rs: f64, vs: f64) -> SiLaw {
        law(rs, coef[1], coef[3], Some(vs))
    }
    fn oe_steps(&self, th: &[f64], f: f64, rs_step: f64) -> Vec<f64> {
        vec![rs_step, 0.01 * f, 0.3, 0.1 * th[3]]
    }
    /// From the static-dynamic optimum with v_s at 10 % of A·ω.
    fn oe_fallback(&self, optimum: Optimum, a: f64, omega: f64) -> Option<SiLaw> {
        optimum(LawKind::StaticDynamic).map(|ts| law(ts[0], ts[1], 0.0, Some(0.1 * a * omega)))
    }
    /// From the static-dynamic optimum, with Stribeck velocities from 3 %
    /// to 30 % of the drive's velocity scale A·ω.
    fn oe_nested(&self, _th_ee: &[f64], optimum: Optimum, va: f64) -> Vec<Vec<f64>> {
        let Some(ts) = optimum(LawKind::StaticDynamic) else {
            return Vec::new();
        };
        [0.03, 0.1, 0.3]
            .iter()
            .map(|f| [&[ts[0], ts[1], 0.0, f * va][..], &ts[2..]].concat())
            .collect()
    }
    fn oe_jac_step(&self, j: usize, law: &SiLaw) -> Option<f64> {
        match j {
            2 => Some(0.02),
            3 => Some(0.01 * law.vs_m_per_s.unwrap_or(0.0)),
            _ => None,
        }
    }
    fn synth_law(&self, rs: f64, rd: f64, slope: Option<f64>, vs: f64) -> SiLaw {
        law(rs, rd, slope.unwrap_or(0.0), Some(vs))
    }
}

fn law(rs: f64, rd: f64, a: f64, vs: Option<f64>) -> SiLaw {
    SiLaw {
        kind: LawKind::Stribeck,
        rs_n: rs,
        rd_n: rd,
        slope_n_s_per_m: a,
        vs_m_per_s: vs,
    }
}
