//! Static above dynamic friction (Fig. 2c): g(v) = Rd, threshold Rs > Rd
//! (the breakaway level).

use super::super::{LawFamily, Optimum, Selection, SiLaw};
use super::LawKind;

/// ρd < ρs, no slope: parameters `[Rs, Rd]`.
#[derive(Debug, Clone, Copy)]
pub struct StaticDynamic;

impl LawFamily for StaticDynamic {
    fn name(&self) -> &'static str {
        "static-dynamic"
    }
    fn describe(&self) -> &'static str {
        "g(v) = Rd, threshold Rs > Rd"
    }
    fn params(&self) -> &'static [&'static str] {
        &["Rs", "Rd"]
    }
    fn has_threshold(&self) -> bool {
        true
    }
    fn selection(&self) -> Selection {
        Selection::Simple
    }
    fn unpack(&self, p: &[f64]) -> SiLaw {
        law(p[0], p[1], 0.0)
    }
    fn pack(&self, l: &SiLaw) -> Vec<f64> {
        vec![l.rs_n, l.rd_n]
    }
    fn basis(&self, s: f64, _u: f64, k1: f64, k2: f64, _vs: f64) -> ([f64; 6], usize) {
        ([1.0, s, k1, k2, 0.0, 0.0], 4)
    }
    fn rs_from_breakaways(&self) -> bool {
        true
    }
    fn ee_rs(&self, _coef: &[f64], breakaway: f64) -> f64 {
        breakaway
    }
    /// Static > dynamic is the family's definition: a breakaway level at
    /// or below the slip level is not this family.
    fn ee_admissible(&self, coef: &[f64], rs: f64) -> bool {
        rs.partial_cmp(&coef[1]) == Some(std::cmp::Ordering::Greater)
    }
    fn ee_law(&self, coef: &[f64], rs: f64, _vs: f64) -> SiLaw {
        law(rs, coef[1], 0.0)
    }
    fn oe_steps(&self, _th: &[f64], f: f64, rs_step: f64) -> Vec<f64> {
        vec![rs_step, 0.01 * f]
    }
    /// A never-sticking segmentation: thresholds 10 % above the Coulomb
    /// optimum (the simulator decides where sticks happen).
    fn oe_fallback(&self, optimum: Optimum, _a: f64, _omega: f64) -> Option<SiLaw> {
        optimum(LawKind::Coulomb).map(|tc| law(1.1 * tc[0], tc[0], 0.0))
    }
    /// From the Coulomb optimum: the threshold at the sliding level, and
    /// the equation-error law.
    fn oe_nested(&self, th_ee: &[f64], optimum: Optimum, _va: f64) -> Vec<Vec<f64>> {
        let Some(tc) = optimum(LawKind::Coulomb) else {
            return Vec::new();
        };
        let (r, nuis) = (tc[0], &tc[1..]);
        [[r, r], [th_ee[0], th_ee[1]]]
            .iter()
            .map(|l| [&l[..], nuis].concat())
            .collect()
    }
    fn oe_threshold_screen(&self) -> bool {
        true
    }
    fn nests_coulomb(&self, l: &SiLaw, rs: Option<(f64, f64)>, _slope: Option<(f64, f64)>) -> bool {
        rs.is_some_and(|(lo, _)| lo <= l.rd_n)
    }
    fn synth_law(&self, rs: f64, rd: f64, slope: Option<f64>, _vs: f64) -> SiLaw {
        law(rs, rd, slope.unwrap_or(0.0))
    }
}

fn law(rs: f64, rd: f64, a: f64) -> SiLaw {
    SiLaw {
        kind: LawKind::StaticDynamic,
        rs_n: rs,
        rd_n: rd,
        slope_n_s_per_m: a,
        vs_m_per_s: None,
    }
}
