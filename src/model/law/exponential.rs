//! Velocity weakening: g(v) = Rd + (Rs − Rd)·exp(−|v|/v_s), a peak Rs at
//! rest decaying exponentially to Rd over the velocity v_s (no slope). Not
//! affine: the numerical engine integrates its slip phases. Fitted only
//! when asked for (`--law exponential`).

use super::super::{Law, LawFamily, Optimum, Selection, SiLaw};
use super::LawKind;

/// Velocity weakening: parameters `[Rs, Rd, v_s]`.
#[derive(Debug, Clone, Copy)]
pub struct Exponential;

/// This family's handle.
const KIND: LawKind = LawKind(&Exponential);

impl LawFamily for Exponential {
    fn name(&self) -> &'static str {
        "exponential"
    }
    fn describe(&self) -> &'static str {
        "g(v) = Rd + (Rs − Rd)·exp(−v/v_s)"
    }
    fn params(&self) -> &'static [&'static str] {
        &["Rs", "Rd", "v_s"]
    }
    fn has_threshold(&self) -> bool {
        true
    }
    fn has_velocity_scale(&self) -> bool {
        true
    }
    fn selection(&self) -> Selection {
        Selection::OnRequest
    }
    fn unpack(&self, p: &[f64]) -> SiLaw {
        law(p[0], p[1], Some(p[2]))
    }
    fn pack(&self, l: &SiLaw) -> Vec<f64> {
        vec![l.rs_n, l.rd_n, l.vs_m_per_s.unwrap_or(f64::NAN)]
    }
    fn law(&self, rho_s: f64, rho_d: f64, slope: f64, v_s: Option<f64>) -> Option<Law> {
        v_s.map(|v_s| Law::Shaped {
            kind: KIND,
            rho_s,
            rho_d,
            slope,
            v_s,
            minus: None,
        })
    }
    #[inline]
    fn decay(&self, v: f64, v_s: f64) -> f64 {
        (-v / v_s).exp()
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
        let e = (rho_s - rho_d) * ex;
        (rho_d + e + slope * v, slope - e / v_s, e / (v_s * v_s))
    }
    #[inline]
    fn slope_with(&self, rho_s: f64, rho_d: f64, slope: f64, v_s: f64, _v: f64, ex: f64) -> f64 {
        slope - (rho_s - rho_d) * ex / v_s
    }
    fn si_sliding(&self, l: &SiLaw, u: f64) -> f64 {
        let mut g = l.rd_n + l.slope_n_s_per_m * u;
        if let Some(vs) = l.vs_m_per_s {
            g += (l.rs_n - l.rd_n) * self.decay(u, vs);
        }
        g
    }
    /// For given v_s the law is linear in (b, Rd, Rs − Rd).
    fn basis(&self, s: f64, u: f64, k1: f64, k2: f64, vs: f64) -> ([f64; 6], usize) {
        ([1.0, s, s * self.decay(u, vs), k1, k2, 0.0], 5)
    }
    /// s·decay(u, v_s).
    fn scale_column(&self) -> Option<usize> {
        Some(2)
    }
    /// g(0+) = Rd + (Rs − Rd).
    fn ee_rs(&self, coef: &[f64], _breakaway: f64) -> f64 {
        coef[1] + coef[2]
    }
    /// Weakening (Rs > Rd): a dip or a vanishing peak is no such law.
    fn ee_admissible(&self, coef: &[f64], _rs: f64) -> bool {
        coef[2].partial_cmp(&0.0) == Some(std::cmp::Ordering::Greater)
    }
    fn ee_law(&self, coef: &[f64], rs: f64, vs: f64) -> SiLaw {
        law(rs, coef[1], Some(vs))
    }
    fn oe_steps(&self, th: &[f64], f: f64, rs_step: f64) -> Vec<f64> {
        vec![rs_step, 0.01 * f, 0.1 * th[2]]
    }
    /// From the static-dynamic optimum (its limit v_s → 0) with v_s at
    /// 10 % of A·ω.
    fn oe_fallback(&self, optimum: Optimum, a: f64, omega: f64) -> Option<SiLaw> {
        optimum(LawKind::StaticDynamic).map(|ts| law(ts[0], ts[1], Some(0.1 * a * omega)))
    }
    /// From the static-dynamic optimum, with v_s from 3 % to 30 % of A·ω.
    fn oe_nested(&self, _th_ee: &[f64], optimum: Optimum, va: f64) -> Vec<Vec<f64>> {
        let Some(ts) = optimum(LawKind::StaticDynamic) else {
            return Vec::new();
        };
        [0.03, 0.1, 0.3]
            .iter()
            .map(|f| [&[ts[0], ts[1], f * va][..], &ts[2..]].concat())
            .collect()
    }
    fn oe_jac_step(&self, j: usize, law: &SiLaw) -> Option<f64> {
        (j == 2).then(|| 0.01 * law.vs_m_per_s.unwrap_or(0.0))
    }
    /// The family has no slope: a given one is not this law.
    fn synth_law(&self, rs: f64, rd: f64, _slope: Option<f64>, vs: f64) -> SiLaw {
        law(rs, rd, Some(vs))
    }
}

fn law(rs: f64, rd: f64, vs: Option<f64>) -> SiLaw {
    SiLaw {
        kind: KIND,
        rs_n: rs,
        rd_n: rd,
        slope_n_s_per_m: 0.0,
        vs_m_per_s: vs,
    }
}
