//! Coulomb's law (Fig. 2a): g(v) = Rd, threshold Rs = Rd.

use super::super::{LawFamily, Selection, SiLaw};
use super::LawKind;

/// ρd = ρs, no slope: parameters `[Rd]`.
#[derive(Debug, Clone, Copy)]
pub struct Coulomb;

impl LawFamily for Coulomb {
    fn name(&self) -> &'static str {
        "coulomb"
    }
    fn describe(&self) -> &'static str {
        "g(v) = Rd, threshold Rs = Rd"
    }
    fn params(&self) -> &'static [&'static str] {
        &["Rd"]
    }
    fn has_threshold(&self) -> bool {
        false
    }
    fn selection(&self) -> Selection {
        Selection::Simple
    }
    fn unpack(&self, p: &[f64]) -> SiLaw {
        law(p[0])
    }
    fn pack(&self, l: &SiLaw) -> Vec<f64> {
        vec![l.rd_n]
    }
    fn basis(&self, s: f64, _u: f64, k1: f64, k2: f64, _vs: f64) -> ([f64; 6], usize) {
        ([1.0, s, k1, k2, 0.0, 0.0], 4)
    }
    fn ee_law(&self, coef: &[f64], _rs: f64, _vs: f64) -> SiLaw {
        law(coef[1])
    }
    fn oe_steps(&self, _th: &[f64], f: f64, _rs_step: f64) -> Vec<f64> {
        vec![0.01 * f]
    }
    fn synth_law(&self, rs: f64, _rd: f64, _slope: Option<f64>, _vs: f64) -> SiLaw {
        law(rs)
    }
}

fn law(r: f64) -> SiLaw {
    SiLaw {
        kind: LawKind::Coulomb,
        rs_n: r,
        rd_n: r,
        slope_n_s_per_m: 0.0,
        vs_m_per_s: None,
    }
}
