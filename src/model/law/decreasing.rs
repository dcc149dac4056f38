//! The decreasing (or increasing) characteristic (Fig. 2b): g(v) = Rd + a·v,
//! threshold Rs = Rd.

use super::super::{LawFamily, Optimum, Selection, SiLaw};
use super::LawKind;

/// ρd = ρs plus a slope: parameters `[Rd, a]`.
#[derive(Debug, Clone, Copy)]
pub struct Decreasing;

impl LawFamily for Decreasing {
    fn name(&self) -> &'static str {
        "decreasing"
    }
    fn describe(&self) -> &'static str {
        "g(v) = Rd + a·v, threshold Rs = Rd"
    }
    fn params(&self) -> &'static [&'static str] {
        &["Rd", "a"]
    }
    fn has_threshold(&self) -> bool {
        false
    }
    fn selection(&self) -> Selection {
        Selection::Simple
    }
    fn unpack(&self, p: &[f64]) -> SiLaw {
        law(p[0], p[1])
    }
    fn pack(&self, l: &SiLaw) -> Vec<f64> {
        vec![l.rd_n, l.slope_n_s_per_m]
    }
    fn basis(&self, s: f64, u: f64, k1: f64, k2: f64, _vs: f64) -> ([f64; 6], usize) {
        ([1.0, s, s * u, k1, k2, 0.0], 5)
    }
    fn ee_law(&self, coef: &[f64], _rs: f64, _vs: f64) -> SiLaw {
        law(coef[1], coef[2])
    }
    fn oe_steps(&self, _th: &[f64], f: f64, _rs_step: f64) -> Vec<f64> {
        vec![0.01 * f, 0.3]
    }
    /// From the Coulomb optimum: no slope, and the equation-error slope.
    fn oe_nested(&self, th_ee: &[f64], optimum: Optimum, _va: f64) -> Vec<Vec<f64>> {
        let Some(tc) = optimum(LawKind::Coulomb) else {
            return Vec::new();
        };
        let (r, nuis) = (tc[0], &tc[1..]);
        [[r, 0.0], [r, th_ee[1]]]
            .iter()
            .map(|l| [&l[..], nuis].concat())
            .collect()
    }
    fn oe_jac_step(&self, j: usize, _law: &SiLaw) -> Option<f64> {
        (j == 1).then_some(0.02)
    }
    fn nests_coulomb(
        &self,
        _l: &SiLaw,
        _rs: Option<(f64, f64)>,
        slope: Option<(f64, f64)>,
    ) -> bool {
        slope.is_some_and(|(lo, hi)| lo <= 0.0 && 0.0 <= hi)
    }
    fn synth_law(&self, rs: f64, _rd: f64, slope: Option<f64>, _vs: f64) -> SiLaw {
        law(rs, slope.unwrap_or(-3.0))
    }
}

fn law(r: f64, a: f64) -> SiLaw {
    SiLaw {
        kind: LawKind::Decreasing,
        rs_n: r,
        rd_n: r,
        slope_n_s_per_m: a,
        vs_m_per_s: None,
    }
}
