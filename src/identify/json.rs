//! The JSON entry of one fitted log (one element of `fits` in `stickslip
//! fit --json`, and the `fit` object of `validate`/`run`). Interface keys
//! (`interface.md`) are those of the estimate used (`estimate`:
//! `output-error` or `equation-error`, [`LogFit::estimate`]); both
//! estimates are kept in full under `equation_error` and `output_error`
//! (null where not computed), each with its law, intervals and
//! diagnostics. `residual_rms` (an interface key) and the top-level
//! `criteria` stay those of the equation-error fit (the scatter of the
//! characteristic R(ẋ2) about the law); the output-error residuals are
//! `output_error.rms_x1_m`, `rms_x2_m` and its criteria
//! `output_error.criteria`. `bias_n` is the estimate used's.
//!
//! `adequate` (interface key, [`LogFit::adequate`]) with its numbers under
//! `adequacy` (residual/noise ratios of x1, x2, the structure tests, the
//! interval inflation; null where only the equation-error estimate was
//! computed), `contradictions` (bounds that contradict each other) and
//! `law_evidence` (the BIC difference to the best other family and its
//! Kass–Raftery grade).

use super::{Estimate, Intervals, LogFit, SiLaw};
use crate::io::json::{interval, num, opt};
use serde_json::{json, Value};
use std::path::Path;

impl LogFit {
    /// A law in SI and dimensionless with this log's scales.
    fn law_json(&self, l: &SiLaw) -> Value {
        let fs = self.force_scale_n;
        let vel = self.velocity_scale_m_per_s;
        json!({
            "law": l.kind.as_str(),
            "rho_s": num(l.rs_n / fs),
            "rho_d": num(l.rd_n / fs),
            "slope": num(l.slope_n_s_per_m / self.slope_scale),
            "v_s": l.vs_m_per_s.map_or(Value::Null, |v| num(v / vel)),
            "r_s_n": num(l.rs_n),
            "r_d_n": num(l.rd_n),
            "slope_n_s_per_m": num(l.slope_n_s_per_m),
            "v_s_m_per_s": l.vs_m_per_s.map_or(Value::Null, num),
        })
    }

    /// A law with its intervals (Rs NaN where only bounded).
    fn estimate_json(&self, l: &SiLaw, iv: &Intervals) -> Value {
        let mut l = *l;
        if self.never_sticks() {
            l.rs_n = f64::NAN;
        }
        let mut v = self.law_json(&l);
        let o = v.as_object_mut().expect("object");
        for (k, x) in [
            ("rho_s_interval", iv.rho_s),
            ("rho_d_interval", iv.rho_d),
            ("slope_interval", iv.dstar),
            ("r_s_interval_n", iv.rs_n),
            ("r_d_interval_n", iv.rd_n),
            ("slope_interval_n_s_per_m", iv.slope_n_s_per_m),
        ] {
            o.insert(k.into(), interval(x));
        }
        v
    }

    /// The JSON entry of this fit for `log` (interface keys plus details).
    pub fn to_json(&self, log: &Path) -> Value {
        let e = &self.fit;
        let fs = self.force_scale_n;
        let law = self.law();
        let ee = if e.stuck {
            Value::Null
        } else {
            let mut v = self.estimate_json(&e.law, &self.equation_error);
            let o = v.as_object_mut().expect("object");
            o.insert("residual_rms_n".into(), num(e.residual_rms_n));
            o.insert("bias_n".into(), num(e.bias_n));
            o.insert(
                "criteria".into(),
                e.criteria
                    .iter()
                    .map(|(k, c)| json!({"law": k.as_str(), "bic": num(*c)}))
                    .collect(),
            );
            v
        };
        let oe = self.output_error.as_ref().map_or(Value::Null, |o| {
            let mut v = self.estimate_json(&o.law, &o.intervals);
            let c = &o.chosen;
            let obj = v.as_object_mut().expect("object");
            for (k, x) in [
                ("rms_x1_m", json!(num(c.rms_m.0))),
                ("rms_x2_m", json!(num(c.rms_m.1))),
                ("start_rms_x1_m", json!(num(o.start_rms_m.0))),
                ("start_rms_x2_m", json!(num(o.start_rms_m.1))),
                ("bias_n", num(c.bias_n)),
                ("gains", json!([num(c.gains.0), num(c.gains.1)])),
                ("iterations", json!(c.iterations)),
                ("evaluations", json!(o.evaluations)),
                ("segments", json!(o.segments)),
                ("samples", json!(o.samples)),
                ("effective_samples", num(o.n_eff)),
                ("drive", json!(o.drive.as_str())),
                ("seconds", num(o.seconds)),
                (
                    "criteria",
                    o.families
                        .iter()
                        .map(|f| {
                            json!({
                                "law": f.law.kind.as_str(),
                                "bic": num(f.bic),
                                "stick_fraction": num(f.stick_fraction),
                                "stick_phases": f.stick_runs,
                                "rms_x1_m": num(f.rms_m.0),
                                "rms_x2_m": num(f.rms_m.1),
                            })
                        })
                        .collect(),
                ),
            ] {
                obj.insert(k.into(), x);
            }
            v
        });
        json!({
            "log": log.display().to_string(),
            "law": self.kind().as_str(),
            "rho_s": opt(self.rho_s()),
            "rho_d": opt(self.rho_d()),
            "slope": opt(self.dstar()),
            "rho_s_interval": interval(self.rho_s_interval),
            "rho_d_interval": interval(self.rho_d_interval),
            "slope_interval": interval(self.dstar_interval),
            "r_s_n": opt(self.rs_n()),
            "r_d_n": opt(law.map(|l| l.rd_n)),
            "slope_n_s_per_m": opt(law.map(|l| l.slope_n_s_per_m)),
            "r_s_interval_n": interval(self.rs_interval_n),
            "r_d_interval_n": interval(self.rd_interval_n),
            "slope_interval_n_s_per_m": interval(self.slope_interval_n_s_per_m),
            "normal_force_n": num(self.normal_force_n),
            "eta": num(self.eta),
            "drive_frequency_hz": num(self.drive.frequency_hz),
            "stuck": e.stuck,
            "rho_s_lower_bound": opt(self.rho_s_lower_bound()),
            "r_s_lower_bound_n": opt(self.rs_lower_bound_n()),
            "never_sticks": self.never_sticks(),
            "adequate": self.adequate(),
            "adequacy": self.adequacy.as_ref().map_or(Value::Null, |a| json!({
                "noise_ratio_x1": num(a.noise_ratio.0),
                "noise_ratio_x2": num(a.noise_ratio.1),
                "robust_ratio_x1": num(a.robust_ratio.0),
                "robust_ratio_x2": num(a.robust_ratio.1),
                "noise_ratio_force": a.force_ratio.map_or(Value::Null, num),
                "robust_ratio_force": a.robust_force_ratio.map_or(Value::Null, num),
                "max_noise_ratio": num(super::output_error::MAX_NOISE_RATIO),
                "max_structure_z": num(super::output_error::MAX_STRUCTURE_Z),
                "max_structure_effect": num(super::output_error::MAX_STRUCTURE_EFFECT),
                "interval_inflation": num(a.inflation),
                "structure": a.structure.iter().map(|s| json!({
                    "channel": s.channel,
                    "against": s.against,
                    "chi2_per_dof": num(s.chi2_per_dof),
                    "z": num(s.z),
                    "effect": num(s.effect),
                })).collect::<Vec<_>>(),
            })),
            "contradictions": self.contradictions,
            "law_evidence": match (&self.output_error, self.estimate) {
                (Some(o), Estimate::OutputError) => o.evidence.map_or(Value::Null, |ev| json!({
                    "against": ev.against.as_str(),
                    "delta_bic": num(ev.delta_bic),
                    "strength": ev.strength(),
                })),
                _ => Value::Null,
            },
            "drive_amplitude_m": num(self.drive.amplitude_m),
            "residual_rms": num(e.residual_rms_n / fs),
            "residual_rms_n": num(e.residual_rms_n),
            "warnings": self.warnings,
            "stribeck": e.stribeck.as_ref().map_or(Value::Null, |l| self.law_json(l)),
            "simple_law": e.simple.as_ref().map_or(Value::Null, |l| self.law_json(l)),
            "criteria": e.criteria.iter().map(|(k, c)| json!({"law": k.as_str(), "bic": num(*c)})).collect::<Vec<_>>(),
            "estimate": self.estimate.as_str(),
            "equation_error": ee,
            "output_error": oe,
            "gain_uncertainty": num(self.gain_uncertainty),
            "bias_n": num(match (&self.output_error, self.estimate) {
                (Some(o), Estimate::OutputError) => o.chosen.bias_n,
                _ => e.bias_n,
            }),
            "slip_samples": e.n_slip,
            "effective_samples": num(e.n_eff),
            "breakaways": e.n_breakaways,
            "notes": self.notes,
        })
    }
}
