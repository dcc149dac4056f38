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

/// Why the engines cannot integrate a rig (see
/// [`RigConstants::check_integrable`]); the message names the numbers.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum IntegrableError {
    /// K1/K2 outside [`STIFFNESS_RATIO_RANGE`].
    #[error("stiffness ratio K1/K2 = {k1_n_per_m} / {k2_n_per_m} N/m = {ratio:.3e} is outside the {low:e}-{high:e} the engines integrate: check the spring constants (units N/m)")]
    StiffnessRatio {
        /// K1 (N/m).
        k1_n_per_m: f64,
        /// K2 (N/m).
        k2_n_per_m: f64,
        /// K1/K2.
        ratio: f64,
        /// The lowest ratio integrated.
        low: f64,
        /// The highest ratio integrated.
        high: f64,
    },
    /// The fastest natural frequency is more than
    /// [`MAX_MODE_TO_DRIVE_RATIO`] times the drive frequency.
    #[error("the rig's fastest natural frequency is {fastest_hz:.4e} Hz (K1 {k1_n_per_m} N/m, K2 {k2_n_per_m} N/m, M1 {m1_kg} kg, M2 {m2_kg} kg), {ratio:.3e} times the drive frequency {drive_hz} Hz; the engines integrate at most {limit:e} natural periods per drive period: check the stiffness and masses (units N/m, kg)")]
    ModeTooFast {
        /// The fastest natural frequency (Hz).
        fastest_hz: f64,
        /// K1 (N/m).
        k1_n_per_m: f64,
        /// K2 (N/m).
        k2_n_per_m: f64,
        /// M1 (kg).
        m1_kg: f64,
        /// M2 (kg).
        m2_kg: f64,
        /// `fastest_hz / drive_hz`.
        ratio: f64,
        /// The drive frequency (Hz).
        drive_hz: f64,
        /// [`MAX_MODE_TO_DRIVE_RATIO`].
        limit: f64,
    },
}

impl RigConstants {
    /// Refuses rig constants the engines cannot integrate in reasonable time,
    /// with the numbers: a stiffness ratio K1/K2 outside
    /// [`STIFFNESS_RATIO_RANGE`], or a fastest natural frequency more than
    /// [`MAX_MODE_TO_DRIVE_RATIO`] times the drive frequency `drive_hz`.
    pub fn check_integrable(&self, drive_hz: f64) -> Result<(), IntegrableError> {
        let rig = self;
        let ratio = rig.k1_n_per_m / rig.k2_n_per_m;
        let (lo, hi) = STIFFNESS_RATIO_RANGE;
        if !(lo..=hi).contains(&ratio) {
            return Err(IntegrableError::StiffnessRatio {
                k1_n_per_m: rig.k1_n_per_m,
                k2_n_per_m: rig.k2_n_per_m,
                ratio,
                low: lo,
                high: hi,
            });
        }
        let (_, eta2) = rig.absorber().eta_linear();
        let fastest_hz = eta2 * rig.omega_ref() / (2.0 * std::f64::consts::PI);
        if drive_hz > 0.0 && fastest_hz / drive_hz > MAX_MODE_TO_DRIVE_RATIO {
            return Err(IntegrableError::ModeTooFast {
                fastest_hz,
                k1_n_per_m: rig.k1_n_per_m,
                k2_n_per_m: rig.k2_n_per_m,
                m1_kg: rig.m1_kg,
                m2_kg: rig.m2_kg,
                ratio: fastest_hz / drive_hz,
                drive_hz,
                limit: MAX_MODE_TO_DRIVE_RATIO,
            });
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
        let e = stiff.check_integrable(1.72).unwrap_err();
        assert!(
            matches!(e, IntegrableError::StiffnessRatio { ratio, .. } if ratio == paper.k1_n_per_m / 1e12),
            "{e:?}"
        );
        // The message, as before the error was typed.
        assert_eq!(
            e.to_string(),
            format!(
                "stiffness ratio K1/K2 = {} / {} N/m = {:.3e} is outside the {:e}-{:e} the engines integrate: check the spring constants (units N/m)",
                paper.k1_n_per_m,
                1e12,
                paper.k1_n_per_m / 1e12,
                STIFFNESS_RATIO_RANGE.0,
                STIFFNESS_RATIO_RANGE.1
            )
        );
        let both = RigConstants {
            k1_n_per_m: 1e12,
            k2_n_per_m: 1e12,
            ..paper
        };
        let e = both.check_integrable(1.72).unwrap_err();
        assert!(matches!(e, IntegrableError::ModeTooFast { .. }), "{e:?}");
        assert!(e.to_string().contains("times the drive frequency"), "{e}");
        let IntegrableError::ModeTooFast {
            fastest_hz, ratio, ..
        } = e
        else {
            unreachable!()
        };
        assert_eq!(
            e.to_string(),
            format!(
                "the rig's fastest natural frequency is {fastest_hz:.4e} Hz (K1 {} N/m, K2 {} N/m, M1 {} kg, M2 {} kg), {:.3e} times the drive frequency {} Hz; the engines integrate at most {MAX_MODE_TO_DRIVE_RATIO:e} natural periods per drive period: check the stiffness and masses (units N/m, kg)",
                1e12, 1e12, paper.m1_kg, paper.m2_kg, ratio, 1.72
            )
        );
    }
}
