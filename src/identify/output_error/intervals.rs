//! Intervals of the refined law: a sandwich over shooting segments,
//! Student t, and the calibration budget.

use super::*;
use crate::identify::Interval;

/// The inverse of a small matrix, column by column.
fn inverse(hm: &[Vec<f64>]) -> Option<Vec<Vec<f64>>> {
    let p = hm.len();
    let cols = (0..p)
        .map(|k| {
            let mut e = vec![0.0; p];
            e[k] = 1.0;
            solve_small(hm, &e)
        })
        .collect::<Option<Vec<_>>>()?;
    // H is symmetric: its inverse is too, so columns serve as rows.
    Some(cols)
}

/// The inverse of a symmetric positive semi-definite matrix whose
/// parameters differ widely in scale (a Stribeck velocity in m/s beside
/// forces in N: diagonal entries 3e5 to 6e19, past the pivot test of
/// [`solve_small`]): D⁻¹·(D⁻¹HD⁻¹)⁻¹·D⁻¹ with D = √diag H. Used only where
/// the plain inverse fails, so well-scaled fits keep their bits.
fn inverse_equilibrated(hm: &[Vec<f64>]) -> Option<Vec<Vec<f64>>> {
    let p = hm.len();
    let d: Vec<f64> = (0..p).map(|k| hm[k][k].sqrt()).collect();
    if d.iter().any(|v| !(v.is_finite() && *v > 0.0)) {
        return None;
    }
    let scaled: Vec<Vec<f64>> = (0..p)
        .map(|a| (0..p).map(|b| hm[a][b] / (d[a] * d[b])).collect())
        .collect();
    let inv = inverse(&scaled)?;
    Some(
        (0..p)
            .map(|a| (0..p).map(|b| inv[a][b] / (d[a] * d[b])).collect())
            .collect(),
    )
}

/// The sensors' gains' part of Rs's and Rd's intervals (95 % half-widths,
/// N; see [`OutputErrorFit::calibration_half_width_n`]).
pub(super) type CalibrationPart = (Option<f64>, Option<f64>);

/// One linearisation of the residuals at θ̂: the Jacobian (row-major),
/// H⁻¹ and the sandwich covariance.
type Linearisation = (Vec<f64>, Vec<Vec<f64>>, Vec<Vec<f64>>);

/// Rounds of secant Jacobians at the intervals' scale.
const SECANT_ROUNDS: usize = 3;

/// Largest ratio of a secant's to the tangent's width (either way) of a
/// smooth cost: beyond it every secant's width is kept.
pub(super) const MAX_SECANT_RATIO: f64 = 1.25;

/// Quantities reported of a refined law: Rs⁺, Rd, a, ρs⁺, ρd, D*, then
/// Rs⁻ (N), ρs⁻, the split Δ (N) and ln κ (NaN where not fitted), then
/// the levels per direction where the position zeros are calibrated
/// ([`CalibratedLevels`]): the force bias b (N), Rs⁺, Rd⁺, Rs⁻, Rd⁻ (N)
/// and ρs⁺, ρd⁺, ρs⁻, ρd⁻.
const NQ: usize = 19;

/// Index of the first calibrated quantity (the bias) in [`NQ`]'s list.
const QCAL: usize = 10;

/// The friction levels of each sliding direction, identifiable where the
/// log declares calibrated position zeros (`position_zero_uncertainty_m`,
/// `docs/real-pads.md` "Levels per direction from calibrated zeros"): the
/// fitted force bias b = K2·(p1 − p2) is then the known offsets' part (0
/// within the declared bound) plus half the difference of the dynamic
/// levels, and every level of the equivalent symmetric law moves by ±b.
/// A static threshold is None where the law's is not measured (a log
/// that never sticks, a side only bounded, a threshold behind a contact
/// that the log does not resolve).
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct CalibratedLevels {
    /// The declared bound (m) on each position channel's zero.
    pub zero_uncertainty_m: f64,
    /// Rd⁺ − Rd⁻ (N): twice the fitted bias.
    pub dynamic_split_n: f64,
    /// Its 95 % interval (N), the zeros' bound included.
    pub dynamic_split_interval_n: Option<Interval>,
    /// |Rd⁺ − Rd⁻| over its standard uncertainty.
    pub z: f64,
    /// The difference is resolved: z² > ln(n_eff) + 2 (the criterion's
    /// price of one parameter plus its preference margin), or the chosen
    /// law splits its threshold.
    pub resolved: bool,
    /// Rs⁺ (N).
    pub rs_plus_n: Option<f64>,
    /// Its interval (N).
    pub rs_plus_interval_n: Option<Interval>,
    /// Rd⁺ (N).
    pub rd_plus_n: f64,
    /// Its interval (N).
    pub rd_plus_interval_n: Option<Interval>,
    /// Rs⁻ (N).
    pub rs_minus_n: Option<f64>,
    /// Its interval (N).
    pub rs_minus_interval_n: Option<Interval>,
    /// Rd⁻ (N).
    pub rd_minus_n: f64,
    /// Its interval (N).
    pub rd_minus_interval_n: Option<Interval>,
    /// ρs⁺, ρd⁺, ρs⁻, ρd⁻ (ρ = R/(A·K2)).
    pub rho: [Option<f64>; 4],
    /// Their intervals.
    pub rho_intervals: [Option<Interval>; 4],
}

/// The reported quantities of one refined law and their variances.
pub(super) struct Variances {
    /// Rs⁺, Rd, a, ρs⁺, ρd, D*, Rs⁻, ρs⁻, Δ, ln κ (NaN where not fitted).
    pub q0: [f64; NQ],
    /// Statistical (sandwich) variance of each.
    pub var_stat: [f64; NQ],
    /// Calibration-budget variance of each: the sensors' gains.
    pub var_cal: [f64; NQ],
    /// The channels' alignment part of it (the drive's and x2's
    /// records shifted by their alignment uncertainty).
    pub var_align: [f64; NQ],
    /// Student t's 97.5 % point for the sandwich's degrees of freedom.
    pub t975: f64,
    /// (H⁻¹)ⱼⱼ of each parameter θⱼ (JᵀJ's inverse: the variance per unit
    /// residual variance of independent residuals; 0 where held).
    pub naive_stat: Vec<f64>,
    /// The sandwich variance of each parameter θⱼ (0 where held).
    pub stat: Vec<f64>,
    /// The largest ratio (either way) of a parameter's statistical width
    /// from the residuals' secants over its interval to its width from
    /// the tangent: 1 on a smooth cost; from [`MAX_SECANT_RATIO`] on,
    /// the reported variances are the widest of the secants'.
    pub secant_ratio: f64,
}

/// The real-pad parameters of a refined law and their 95 % intervals
/// (None where the law does not have them). The split's levels are in the
/// gauge "equal dynamic levels" (see [`Ext`]).
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PadFit {
    /// Rs⁻ (N), the static threshold towards −.
    pub rs_minus_n: Option<f64>,
    /// Its interval (N).
    pub rs_minus_interval_n: Option<Interval>,
    /// ρs⁻.
    pub rho_s_minus: Option<f64>,
    /// Its interval.
    pub rho_s_minus_interval: Option<Interval>,
    /// The split Δ = Rs⁺ − Rs⁻ (N), the drop asymmetry the log identifies.
    pub split_n: Option<f64>,
    /// Its interval (N).
    pub split_interval_n: Option<Interval>,
    /// Contact stiffness κ = kt/K2.
    pub contact_stiffness: Option<f64>,
    /// Its interval (from ln κ's).
    pub contact_stiffness_interval: Option<Interval>,
    /// The simulated law never breaks away towards −: Rs⁻ is only bounded
    /// (`rs_minus_interval_n` holds the bounds).
    pub minus_bounded: bool,
    /// The same towards +: Rs⁺ (the law's Rs) is only bounded.
    pub plus_bounded: bool,
    /// Behind a contact spring the log did not resolve the static
    /// threshold above the sliding level: Rs ≥ Rd only.
    pub threshold_unresolved: bool,
    /// Two readings the log cannot tell apart (a Stribeck law behind the
    /// contact that no accelerometer confirms, beside the chosen law)
    /// disagree on Rs beyond their intervals: Rs is reported as the
    /// interval holding both, without a number.
    #[serde(default)]
    pub rs_between_readings: bool,
    /// The same for κ.
    #[serde(default)]
    pub kappa_between_readings: bool,
    /// The levels per direction where the position zeros are calibrated
    /// (None: zeros unknown; older saved fits).
    #[serde(default)]
    pub calibrated: Option<CalibratedLevels>,
}

impl PadFit {
    /// The log gives the static threshold towards + no number, only an
    /// interval: the law never breaks away that way, the threshold is not
    /// resolved behind a contact, or two readings disagree on it.
    pub fn rs_unmeasured(&self) -> bool {
        self.plus_bounded || self.threshold_unresolved || self.rs_between_readings
    }
}

/// Why a fit's intervals could not be formed (named in the warning when
/// a refinement gives up for it).
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum IntervalsFailure {
    /// The law at its optimum cannot be simulated over the log.
    #[error("the law at its optimum cannot be simulated over the log")]
    OptimumNotSimulable,
    /// Neither side of a parameter's difference step can be simulated.
    #[error("the law cannot be simulated on either side of parameter {parameter}'s step")]
    StepNotSimulable {
        /// The parameter's index in θ.
        parameter: usize,
    },
    /// The residuals do not depend on some combination of the parameters
    /// (the information matrix is singular).
    #[error("the residuals do not determine every parameter (singular information matrix)")]
    Singular,
    /// Too few shooting segments hold residuals for the cluster-robust
    /// sandwich.
    #[error("too few shooting segments ({used}) for {params} parameters")]
    TooFewSegments {
        /// Segments with residuals.
        used: usize,
        /// Parameters.
        params: usize,
    },
    /// The log with a sensor's gain or a channel's alignment perturbed
    /// cannot be simulated.
    #[error("the law cannot be simulated with the calibration perturbed")]
    CalibrationNotSimulable,
}

impl Refinement {
    /// Sandwich intervals over segments plus the calibration budget, the
    /// real-pad parameters' intervals, the gains' part of Rs's and Rd's
    /// (their calibration half-widths, N: see
    /// [`OutputErrorFit::calibration_half_width_n`]) and the secants'
    /// ratio ([`Variances::secant_ratio`]); conditional on the
    /// parameters θⱼ, j in `fixed` (a profile point: those held, not
    /// estimated).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn intervals(
        &self,
        fam: Fam,
        th: &[f64],
        proj: &Proj,
        u: f64,
        rs_known: bool,
        inflation: f64,
        fixed: &[usize],
    ) -> Result<(Intervals, PadFit, CalibrationPart, f64), IntervalsFailure> {
        let Variances {
            q0,
            var_stat,
            var_cal,
            var_align,
            t975,
            secant_ratio,
            ..
        } = self.variances(fam, th, proj, u, inflation, fixed)?;
        let iv = |k: usize, present: bool| -> Option<(f64, f64)> {
            if !present || !q0[k].is_finite() {
                return None;
            }
            // Student t with K − p degrees of freedom for the sandwich part
            // (few clusters); the calibration part is a bound (normal).
            // An inadequate law: the statistical part widened by the misfit.
            let ts = t975 * inflation;
            let hw = (ts * ts * var_stat[k] + 1.96 * 1.96 * (var_cal[k] + var_align[k])).sqrt();
            Some((q0[k] - hw, q0[k] + hw))
        };
        let value = |k: usize| q0[k].is_finite().then_some(q0[k]);
        let pads = PadFit {
            rs_minus_n: value(6).filter(|_| rs_known),
            rs_minus_interval_n: iv(6, rs_known),
            rho_s_minus: value(7).filter(|_| rs_known),
            rho_s_minus_interval: iv(7, rs_known),
            split_n: value(8),
            split_interval_n: iv(8, true),
            contact_stiffness: value(9).map(f64::exp),
            contact_stiffness_interval: iv(9, true).map(|(l, h)| (l.exp(), h.exp())),
            minus_bounded: false,
            plus_bounded: false,
            threshold_unresolved: false,
            rs_between_readings: false,
            kappa_between_readings: false,
            calibrated: self.zero_uncertainty_m.map(|e| {
                let ivc = |k: usize| iv(k, true);
                // b's standard uncertainty: its interval's half-width / 1.96.
                let sd = ivc(QCAL).map_or(f64::INFINITY, |(l, h)| 0.5 * (h - l) / 1.96);
                let q = |k: usize| q0[k];
                let known = |k: usize| value(k).filter(|_| rs_known);
                CalibratedLevels {
                    zero_uncertainty_m: e,
                    dynamic_split_n: 2.0 * q(QCAL),
                    dynamic_split_interval_n: ivc(QCAL).map(|(l, h)| (2.0 * l, 2.0 * h)),
                    z: q(QCAL).abs() / sd,
                    resolved: false,
                    rs_plus_n: known(QCAL + 1),
                    rs_plus_interval_n: iv(QCAL + 1, rs_known),
                    rd_plus_n: q(QCAL + 2),
                    rd_plus_interval_n: ivc(QCAL + 2),
                    rs_minus_n: known(QCAL + 3),
                    rs_minus_interval_n: iv(QCAL + 3, rs_known),
                    rd_minus_n: q(QCAL + 4),
                    rd_minus_interval_n: ivc(QCAL + 4),
                    rho: [
                        known(QCAL + 5),
                        value(QCAL + 6),
                        known(QCAL + 7),
                        value(QCAL + 8),
                    ],
                    rho_intervals: [
                        iv(QCAL + 5, rs_known),
                        ivc(QCAL + 6),
                        iv(QCAL + 7, rs_known),
                        ivc(QCAL + 8),
                    ],
                }
            }),
        };
        let cal = |k: usize, present: bool| {
            let c = 1.96 * var_cal[k].sqrt();
            (present && q0[k].is_finite() && c.is_finite()).then_some(c)
        };
        Ok((
            Intervals {
                rs_n: iv(0, rs_known),
                rd_n: iv(1, true),
                slope_n_s_per_m: iv(2, true),
                rho_s: iv(3, rs_known),
                rho_d: iv(4, true),
                dstar: iv(5, true),
            },
            pads,
            (cal(0, rs_known), cal(1, true)),
            secant_ratio,
        ))
    }

    /// The reported quantities at θ (see [`NQ`]) with their statistical
    /// (sandwich) and calibration variances; conditional on the parameters
    /// θⱼ, j in `fixed`.
    pub(super) fn variances(
        &self,
        fam: Fam,
        th: &[f64],
        proj: &Proj,
        u: f64,
        inflation: f64,
        fixed: &[usize],
    ) -> Result<Variances, IntervalsFailure> {
        let prob = self.problem(&self.data, fam);
        let p = th.len();
        let mut r0 = Res::new();
        prob.eval(th, Some(proj), Some(&mut r0))
            .ok_or(IntervalsFailure::OptimumNotSimulable)?;
        // The held columns out, and back as zero rows and columns.
        let free_ix: Vec<usize> = (0..p).filter(|j| !fixed.contains(j)).collect();
        let sandwich_at = |jac: &[f64]| {
            let (h, c, t) = self.sandwich(jac, p, &free_ix, &r0)?;
            let expand = |a: Vec<Vec<f64>>| -> Vec<Vec<f64>> {
                let mut out = vec![vec![0.0; p]; p];
                for (i, row) in a.into_iter().enumerate() {
                    for (k, v) in row.into_iter().enumerate() {
                        out[free_ix[i]][free_ix[k]] = v;
                    }
                }
                out
            };
            Ok((expand(h), expand(c), t))
        };
        let tangent = Self::tangent_steps(&prob, fam.kind, th);
        let jac = self.jacobian(&prob, th, proj, &r0, &tangent)?;
        let (hinv, cov, t975) = sandwich_at(&jac)?;
        // The intervals are linear in the residuals: checked at their own
        // scale by the residuals' secants over each parameter's half-width
        // (widened by the misfit as the intervals are). Where the cost is
        // smooth the secants agree with the tangent (the bundled logs'
        // widths to 0.2 %); where short sticks switch with the parameters
        // (a contact ringing after each slip) the tangent sees the steep
        // pieces between the jumps and the secants scatter by factors:
        // there every secant's linearisation is kept, and each quantity
        // takes the widest.
        let mut lins: Vec<Linearisation> = Vec::new();
        let ratio = |a: &[Vec<f64>], b: &[Vec<f64>]| {
            free_ix
                .iter()
                .map(|&j| (a[j][j] / b[j][j]).sqrt())
                .map(|r| {
                    if r.is_finite() {
                        r.max(1.0 / r)
                    } else {
                        f64::INFINITY
                    }
                })
                .fold(1.0f64, f64::max)
        };
        let mut secant_ratio = 1.0f64;
        for _ in 0..SECANT_ROUNDS {
            let last = lins.last().map_or(&cov, |l| &l.2);
            let steps: Vec<f64> = (0..p)
                .map(|j| tangent[j].max(inflation.max(1.0) * t975 * last[j][j].sqrt()))
                .collect();
            // A secant whose ends the engine cannot simulate (or whose
            // sandwich is singular) ends the check: the tangent stands.
            let Ok((jn, (hn, cn, _))) = self
                .jacobian(&prob, th, proj, &r0, &steps)
                .and_then(|j| sandwich_at(&j).map(|s| (j, s)))
            else {
                break;
            };
            secant_ratio = secant_ratio.max(ratio(&cn, &cov));
            let settled = ratio(&cn, last) < 1.1;
            lins.push((jn, hn, cn));
            if settled && secant_ratio < 1.1 {
                break;
            }
        }
        if secant_ratio < MAX_SECANT_RATIO {
            lins.clear();
        }
        lins.insert(0, (jac, hinv, cov));
        // The reported quantities as functions of θ (and the amplitude).
        let k2 = self.rig.k2;
        let ss = k2 / self.rig.omega;
        let quantities = |th: &[f64], a: f64| -> [f64; NQ] {
            let (l, rs_minus, kappa) = prob.pad_law(th);
            let b = l.si_and_rho(a * k2, ss);
            let rs_minus = rs_minus.unwrap_or(f64::NAN);
            let split = if fam.ext.split {
                prob.ext_values(th).split_n
            } else {
                f64::NAN
            };
            let ln_kappa = kappa.map_or(f64::NAN, f64::ln);
            // The levels per direction with calibrated zeros: the bias
            // is the levels' common shift (see `CalibratedLevels`).
            let bias = prob.unpack(th).1;
            let rs_m = if fam.ext.split { rs_minus } else { l.rs_n };
            let fs = a * k2;
            let (sp, dp, sm, dm) = (l.rs_n + bias, l.rd_n + bias, rs_m - bias, l.rd_n - bias);
            [
                b[0],
                b[1],
                b[2],
                b[3],
                b[4],
                b[5],
                rs_minus,
                rs_minus / (a * k2),
                split,
                ln_kappa,
                bias,
                sp,
                dp,
                sm,
                dm,
                sp / fs,
                dp / fs,
                sm / fs,
                dm / fs,
            ]
        };
        let q0 = quantities(th, self.data.a);
        // Statistical variance of each quantity (linear in θ for fixed A).
        let mut var_stat = [0.0f64; NQ];
        for (qi, v) in var_stat.iter_mut().enumerate() {
            let grad: Vec<f64> = (0..p)
                .map(|j| {
                    let mut t = th.to_vec();
                    let h = 1e-6 * (1.0 + th[j].abs());
                    t[j] += h;
                    (quantities(&t, self.data.a)[qi] - q0[qi]) / h
                })
                .collect();
            let quad = |cov: &[Vec<f64>]| {
                let mut s = 0.0;
                for a in 0..p {
                    for b in 0..p {
                        s += grad[a] * cov[a][b] * grad[b];
                    }
                }
                s.max(0.0)
            };
            *v = lins.iter().map(|l| quad(&l.2)).fold(0.0, f64::max);
        }
        let mut var_cal = [0.0f64; NQ];
        let mut var_align = [0.0f64; NQ];
        for (jac, hinv, _) in &lins {
            let (c, a) = self
                .calibration_variance(fam, th, proj, u, (&r0, jac, hinv), &quantities, &q0)
                .ok_or(IntervalsFailure::CalibrationNotSimulable)?;
            for k in 0..NQ {
                var_cal[k] = var_cal[k].max(c[k]);
                var_align[k] = var_align[k].max(a[k]);
            }
        }
        // The declared zeros' part of the bias: b_cal = K2·(p1 − p2) with
        // each offset within ±ε (rectangular: variance ε²/3 each).
        if let Some(e) = self.zero_uncertainty_m {
            let var_b = k2 * k2 * 2.0 * e * e / 3.0;
            let fs = self.data.a * k2;
            for (k, v) in var_cal.iter_mut().enumerate().skip(QCAL) {
                *v += if k < QCAL + 5 {
                    var_b
                } else {
                    var_b / (fs * fs)
                };
            }
        }
        let (_, hinv, cov) = &lins[0];
        Ok(Variances {
            q0,
            var_stat,
            var_cal,
            var_align,
            t975,
            naive_stat: (0..p).map(|j| hinv[j][j]).collect(),
            stat: (0..p).map(|j| cov[j][j]).collect(),
            secant_ratio,
        })
    }

    /// The central-difference steps of θ's components at θ (the
    /// tangent's): the family's own, forces 0.2 % of the sliding level,
    /// ln κ 0.01, the gains 3e-4.
    fn tangent_steps(prob: &Problem<'_>, kind: LawKind, th: &[f64]) -> Vec<f64> {
        let (law, _, _, _) = prob.unpack(th);
        let kl = n_params(kind);
        (0..th.len())
            .map(|j| {
                if j < kl {
                    kind.family()
                        .oe_jac_step(j, &law)
                        .unwrap_or(2e-3 * law.rd_n.abs().max(1e-2))
                } else if j == kl || (j == kl + 3 && prob.ext.split) {
                    // The bias and the split Δ: forces.
                    2e-3 * law.rd_n.abs().max(1e-2)
                } else if j >= kl + 3 {
                    // ln κ.
                    1e-2
                } else {
                    3e-4
                }
            })
            .collect()
    }

    /// The Jacobian of the residuals by central differences, row-major
    /// (2m rows: r1 and r2 per sample, `m` samples; one column per
    /// parameter; `r0` the residuals at θ): one allocation, not one per
    /// row. A parameter at the edge of its admissible range (a gain at its
    /// bound, where the model one step beyond cannot be simulated) takes
    /// the one-sided difference towards the inside.
    fn jacobian(
        &self,
        prob: &Problem<'_>,
        th: &[f64],
        proj: &Proj,
        r0: &Res,
        steps: &[f64],
    ) -> Result<Vec<f64>, IntervalsFailure> {
        let p = th.len();
        let m = r0.len();
        let mut jac = vec![0.0; 2 * m * p];
        for (j, &h) in steps.iter().enumerate() {
            let at = |d: f64| {
                let mut t = th.to_vec();
                t[j] += d;
                let mut r = Res::new();
                prob.eval(&t, Some(proj), Some(&mut r))
                    .filter(|_| r.len() == m)
                    .map(|_| r)
            };
            let (rp, rm, span) = match (at(h), at(-h)) {
                (Some(rp), Some(rm)) => (rp, rm, 2.0 * h),
                (Some(rp), None) => (rp, r0.clone(), h),
                (None, Some(rm)) => (r0.clone(), rm, h),
                (None, None) => return Err(IntervalsFailure::StepNotSimulable { parameter: j }),
            };
            for i in 0..m {
                jac[2 * i * p + j] = (rp[i].1 - rm[i].1) / span;
                jac[(2 * i + 1) * p + j] = (rp[i].2 - rm[i].2) / span;
            }
        }
        Ok(jac)
    }

    /// The sandwich over shooting segments for the Jacobian columns
    /// `cols` of `jac` (row-major, `stride` columns, 2m rows): H⁻¹
    /// (H = JᵀJ), the covariance H⁻¹·(Σ g_k g_kᵀ)·H⁻¹ with the small-sample
    /// factor K/(K − p), and Student t's 97.5 % point for K − p degrees of
    /// freedom (K: segments with residuals, p the columns). None with too
    /// few segments.
    #[allow(clippy::type_complexity)]
    fn sandwich(
        &self,
        jac: &[f64],
        stride: usize,
        cols: &[usize],
        r0: &Res,
    ) -> Result<(Vec<Vec<f64>>, Vec<Vec<f64>>, f64), IntervalsFailure> {
        let m = r0.len();
        let p = cols.len();
        // H = JᵀJ and the per-segment scores g_k = J_kᵀ r_k.
        let nseg = self.data.segs.len();
        let mut hm = vec![vec![0.0; p]; p];
        let mut g = vec![vec![0.0; p]; nseg];
        let mut jr = vec![0.0; p];
        for i in 0..m {
            let s = r0[i].0 as usize;
            for (row, r) in [(2 * i, r0[i].1), (2 * i + 1, r0[i].2)] {
                let full = &jac[row * stride..(row + 1) * stride];
                for (v, &c) in jr.iter_mut().zip(cols) {
                    *v = full[c];
                }
                for a in 0..p {
                    g[s][a] += jr[a] * r;
                    for b in 0..p {
                        hm[a][b] += jr[a] * jr[b];
                    }
                }
            }
        }
        let hinv = inverse(&hm)
            .or_else(|| inverse_equilibrated(&hm))
            .ok_or(IntervalsFailure::Singular)?;
        let used = g.iter().filter(|v| v.iter().any(|x| *x != 0.0)).count();
        if used <= p + 1 {
            return Err(IntervalsFailure::TooFewSegments { used, params: p });
        }
        let mut meat = vec![vec![0.0; p]; p];
        for gk in &g {
            for a in 0..p {
                for b in 0..p {
                    meat[a][b] += gk[a] * gk[b];
                }
            }
        }
        let corr = used as f64 / (used - p) as f64;
        let t975 = student_t975((used - p) as f64);
        let cov = crate::stats::regress::sandwich(&hinv, &meat, corr);
        Ok((hinv, cov, t975))
    }

    /// Calibration: linear response of the reported quantities to each
    /// sensor's gain at 1 + u, as variances of a rectangular ±u, and to a
    /// shift of the drive's and of x2's records by the standard
    /// uncertainty of their alignment with x1
    /// ([`Refinement::with_alignment_uncertainty`]), as variances of a
    /// normal error (Δθ = −H⁻¹ Jᵀ Δr from the residuals `r0`, the
    /// Jacobian and H⁻¹ of `lin`): the gains' variances and the
    /// alignment's apart.
    #[allow(clippy::too_many_arguments)]
    fn calibration_variance(
        &self,
        fam: Fam,
        th: &[f64],
        proj: &Proj,
        u: f64,
        lin: (&Res, &[f64], &[Vec<f64>]),
        quantities: &impl Fn(&[f64], f64) -> [f64; NQ],
        q0: &[f64; NQ],
    ) -> Option<([f64; NQ], [f64; NQ])> {
        let (r0, jac, hinv) = lin;
        let p = th.len();
        let m = r0.len();
        let mut var_cal = [0.0f64; NQ];
        let mut var_align = [0.0f64; NQ];
        // The perturbed data, the divisor of each squared response
        // (rectangular ±u: σ = |δ|/√3; a one-σ shift: 1) and whether it is
        // an alignment.
        let mut perturbed: Vec<(Data, f64, bool)> = Vec::new();
        if u > 0.0 {
            for gk in 0..4 {
                let mut gains = Gains::default();
                match gk {
                    0 => gains.x0 = 1.0 + u,
                    1 => gains.x1 = 1.0 + u,
                    2 => gains.x2 = 1.0 + u,
                    _ => gains.v2 = 1.0 + u,
                }
                perturbed.push((self.data.scaled(&gains), 3.0, false));
            }
        }
        let (s0, s2) = self.alignment_sigma;
        if s0 > 0.0 {
            perturbed.push((self.data.shifted(s0, 0.0), 1.0, true));
        }
        if s2 > 0.0 {
            perturbed.push((self.data.shifted(0.0, s2), 1.0, true));
        }
        for (dp, divisor, align) in &perturbed {
            let pp = self.problem(dp, fam);
            let mut rp = Res::new();
            pp.eval(th, Some(proj), Some(&mut rp))?;
            if rp.len() != m {
                return None;
            }
            // Δθ = −H⁻¹ Jᵀ Δr.
            let mut jtr = vec![0.0; p];
            for i in 0..m {
                let (d1, d2) = (rp[i].1 - r0[i].1, rp[i].2 - r0[i].2);
                for a in 0..p {
                    jtr[a] += jac[2 * i * p + a] * d1 + jac[(2 * i + 1) * p + a] * d2;
                }
            }
            let mut t = th.to_vec();
            for a in 0..p {
                t[a] -= (0..p).map(|b| hinv[a][b] * jtr[b]).sum::<f64>();
            }
            let q = quantities(&t, dp.a);
            let var = if *align { &mut var_align } else { &mut var_cal };
            for k in 0..NQ {
                let dq = q[k] - q0[k];
                if dq.is_finite() {
                    var[k] += dq * dq / divisor;
                }
            }
        }
        Some((var_cal, var_align))
    }
}

#[cfg(test)]
mod inverse_tests {
    use super::*;

    #[test]
    fn a_badly_scaled_normal_matrix_is_inverted_after_equilibration() {
        // Parameters of scales 1 and 1e10 (a force beside a Stribeck
        // velocity): H = D·C·D with C well conditioned.
        let c = [[2.0, 0.5, 0.2], [0.5, 1.5, 0.3], [0.2, 0.3, 1.0]];
        let d = [1.0, 1e10, 3.0];
        let h: Vec<Vec<f64>> = (0..3)
            .map(|a| (0..3).map(|b| d[a] * c[a][b] * d[b]).collect())
            .collect();
        assert!(inverse(&h).is_none(), "the plain pivot test refuses it");
        let inv = inverse_equilibrated(&h).expect("equilibrated");
        // Against D⁻¹·C⁻¹·D⁻¹ (C⁻¹ of the well-conditioned C).
        let cv: Vec<Vec<f64>> = c.iter().map(|r| r.to_vec()).collect();
        let ci = inverse(&cv).unwrap();
        for a in 0..3 {
            for b in 0..3 {
                let want = ci[a][b] / (d[a] * d[b]);
                assert!(
                    (inv[a][b] / want - 1.0).abs() < 1e-12,
                    "({a},{b}) {} {want}",
                    inv[a][b]
                );
            }
        }
    }
}
