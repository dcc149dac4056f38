//! Rig constants the engines can integrate (issue 29): a stiffness ratio
//! or a mode so fast that a run would take minutes to hours is refused up
//! front with the numbers, by `synth` and when a log is read.

use super::RigConstants;

/// Stiffness ratios K1/K2 the engines integrate (beyond, the two masses'
/// time scales are so far apart that a run takes minutes to hours).
pub const STIFFNESS_RATIO_RANGE: (f64, f64) = (1e-3, 1e3);

/// Most natural periods of the absorber's fastest mode per drive period
/// (a stiff spring makes the engines resolve that many oscillations per
/// period; K2 = 1e12 N/m gave 6e4 and ran for minutes).
pub const MAX_MODE_TO_DRIVE_RATIO: f64 = 1e3;

impl RigConstants {
    /// Refuses rig constants the engines cannot integrate in reasonable time,
    /// with the numbers: a stiffness ratio K1/K2 outside
    /// [`STIFFNESS_RATIO_RANGE`], or a fastest natural frequency more than
    /// [`MAX_MODE_TO_DRIVE_RATIO`] times the drive frequency `drive_hz`.
    pub fn check_integrable(&self, drive_hz: f64) -> Result<(), String> {
        let rig = self;
        let ratio = rig.k1_n_per_m / rig.k2_n_per_m;
        let (lo, hi) = STIFFNESS_RATIO_RANGE;
        if !(lo..=hi).contains(&ratio) {
            return Err(format!(
                "stiffness ratio K1/K2 = {} / {} N/m = {ratio:.3e} is outside the {lo:e}-{hi:e} the engines integrate: check the spring constants (units N/m)",
                rig.k1_n_per_m, rig.k2_n_per_m
            ));
        }
        let (_, eta2) = rig.absorber().eta_linear();
        let fastest_hz = eta2 * rig.omega_ref() / (2.0 * std::f64::consts::PI);
        if drive_hz > 0.0 && fastest_hz / drive_hz > MAX_MODE_TO_DRIVE_RATIO {
            return Err(format!(
                "the rig's fastest natural frequency is {fastest_hz:.4e} Hz (K1 {} N/m, K2 {} N/m, M1 {} kg, M2 {} kg), {:.3e} times the drive frequency {drive_hz} Hz; the engines integrate at most {MAX_MODE_TO_DRIVE_RATIO:e} natural periods per drive period: check the stiffness and masses (units N/m, kg)",
                rig.k1_n_per_m,
                rig.k2_n_per_m,
                rig.m1_kg,
                rig.m2_kg,
                fastest_hz / drive_hz
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stiff_rigs_are_refused_with_numbers() {
        let paper = RigConstants::paper();
        assert!(paper.check_integrable(1.72).is_ok());
        let stiff = RigConstants {
            k2_n_per_m: 1e12,
            ..paper
        };
        assert!(stiff.check_integrable(1.72).unwrap_err().contains("K1/K2"));
        let both = RigConstants {
            k1_n_per_m: 1e12,
            k2_n_per_m: 1e12,
            ..paper
        };
        let e = both.check_integrable(1.72).unwrap_err();
        assert!(e.contains("times the drive frequency"), "{e}");
    }
}
