//! The adequacy test: residuals against the sensor noise, structure in
//! the residuals, and the evidence that decides a family.

use super::*;

/// Noise (1σ) of a position record from its second differences.
pub(super) fn noise(x: &[f64]) -> f64 {
    let d2: Vec<f64> = (1..x.len().saturating_sub(1))
        .map(|i| x[i + 1] - 2.0 * x[i] + x[i - 1])
        .filter(|v| v.is_finite())
        .collect();
    mad_sigma(&d2) / 6f64.sqrt()
}

/// The 97.5 % quantile of Student's t with `nu` degrees of freedom.
pub(super) fn student_t975(nu: f64) -> f64 {
    crate::stats::student_t_quantile(0.975, nu)
}

/// Integrated autocorrelation time of residuals within segments.
pub(super) fn tau_int(seg: &[u32], r: &[f64]) -> f64 {
    crate::identify::smooth::tau_int(r, usize::MAX, 20, |k, lag| seg[k + lag] == seg[k])
}

/// A BIC difference below this is no evidence either way (Kass–Raftery).
pub(super) const BIC_WEAK: f64 = 2.0;

/// A BIC difference above this is very strong evidence (Kass–Raftery).
pub(super) const BIC_STRONG: f64 = 10.0;

/// Simulated stick time (fraction of the compared samples) above which a
/// law is said to stick in a log the segmentation called never-sticking.
pub(super) const MIN_STICK_FRACTION: f64 = 0.005;

/// Largest residual/noise ratio of an adequate law. The noise is measured
/// past its correlation length (`identify::noise`): the right law leaves
/// 0.93–1.03 of it on the bundled logs, at most 1.16 on 60 synth logs of
/// four rigs with filtered, interpolated sensors (with the lags it fits),
/// at most 1.085 on the 163 sticking logs of the 200-case round trip, and
/// keeps 40 clean logs of the defects study adequate. 2.0 until session
/// 16: a hardening coupling spring then hid behind fitted position lags at
/// 1.4–1.7× the noise (docs/measurements.md). (Second differences of
/// neighbours, used before, read interpolated or filtered noise low: the
/// right law then showed 1.2–1.7.)
pub const MAX_NOISE_RATIO: f64 = 1.4;

/// Largest standardised structure statistic of an adequate law (the
/// Wilson–Hilferty z of a binned χ²; 3.7 ≈ p = 1e-4 per test, about 1e-3
/// over the eight tests).
pub const MAX_STRUCTURE_Z: f64 = 3.7;

/// Smallest structure (RMS of the bin means over the noise) that counts:
/// the binned χ² is exquisitely sensitive with thousands of samples, and
/// residuals correlated beyond the estimated autocorrelation time make it
/// significant without mattering (the public in-family logs show effects
/// up to 0.25 of the noise).
pub const MAX_STRUCTURE_EFFECT: f64 = 0.5;

/// Bins of each structure test.
pub(super) const STRUCTURE_BINS: usize = 12;

/// How strongly the data prefer the chosen family.
#[derive(Debug, Clone, Copy, serde::Serialize, serde::Deserialize)]
pub struct Evidence {
    /// The best other family.
    pub against: LawKind,
    /// Its BIC minus the chosen one's (positive: the chosen is better;
    /// 2–6 positive, 6–10 strong, > 10 very strong evidence).
    pub delta_bic: f64,
}

impl Evidence {
    /// The verbal grade of the difference (Kass–Raftery).
    pub fn strength(&self) -> &'static str {
        let d = self.delta_bic;
        if d < 0.0 {
            "simpler law preferred (slightly worse criterion)"
        } else if d < 2.0 {
            "weak"
        } else if d < 6.0 {
            "positive"
        } else if d < 10.0 {
            "strong"
        } else {
            "very strong"
        }
    }
}

/// One structure test: binned residual means against their noise.
#[derive(Debug, Clone, Copy, serde::Serialize)]
pub struct Structure {
    /// `x1` or `x2`.
    pub channel: &'static str,
    /// `drive phase`, `velocity`, `position` or `time`.
    pub against: &'static str,
    /// χ² of the bin means per degree of freedom (≈ 1 without structure).
    pub chi2_per_dof: f64,
    /// Wilson–Hilferty standard score of that χ².
    pub z: f64,
    /// Size of the structure: RMS of the bin means in units of the noise,
    /// less what the noise alone gives (0 when within the noise).
    pub effect: f64,
}

/// The smallest x2 structure against velocity or drive phase (RMS of the
/// bin means, in noise units) that makes an adequate static/dynamic law try
/// the Stribeck family ([`Structure::suggests_a_sharper_drop`]): the sharp
/// drops that needed it showed 0.05–0.15 (sharp-Stribeck rig, v_s 0.5–1
/// mm/s); a 3000-s static/dynamic log showed 0.006 at z 4.
pub const MIN_RESCUE_EFFECT: f64 = 0.02;

/// The largest significant structure (effect, in noise units; 0 where
/// none) of x1's or x2's residuals against velocity or drive phase: the
/// signature a position lag leaves ([`Structure::follows_the_motion`]).
pub fn motion_structure(structure: &[Structure]) -> f64 {
    structure
        .iter()
        .filter(|s| s.follows_the_motion())
        .map(|s| s.effect)
        .fold(0.0, f64::max)
}

/// The names a structure test can carry (channels, then what the residuals
/// are binned against).
const STRUCTURE_NAMES: [&str; 7] = [
    "x1",
    "x2",
    "force",
    "drive phase",
    "velocity",
    "position",
    "time",
];

/// A [`Structure`] as saved (a fit artifact), with owned names.
#[derive(serde::Deserialize)]
struct SavedStructure {
    channel: String,
    against: String,
    chi2_per_dof: f64,
    z: f64,
    effect: f64,
}

impl<'de> serde::Deserialize<'de> for Structure {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let s = SavedStructure::deserialize(d)?;
        let known = |n: &str| {
            STRUCTURE_NAMES
                .iter()
                .find(|k| **k == n)
                .copied()
                .ok_or_else(|| {
                    serde::de::Error::custom(format!("unknown structure test name `{n}`"))
                })
        };
        Ok(Structure {
            channel: known(&s.channel)?,
            against: known(&s.against)?,
            chi2_per_dof: s.chi2_per_dof,
            z: s.z,
            effect: s.effect,
        })
    }
}

impl Structure {
    /// Significant (z above [`MAX_STRUCTURE_Z`]) and large (effect above
    /// [`MAX_STRUCTURE_EFFECT`]).
    pub fn flagged(&self) -> bool {
        self.z > MAX_STRUCTURE_Z && self.effect > MAX_STRUCTURE_EFFECT
    }
    /// A significant structure (z above [`MAX_STRUCTURE_Z`], whatever its
    /// size) of x1's or x2's residuals against the velocity or the drive
    /// phase: the signature of a position record that lags the drive (a
    /// lag δ leaves −δ·ẋ in the residual), and in x2 of a friction drop
    /// sharper than the law has (the Stribeck screen).
    pub fn follows_the_motion(&self) -> bool {
        self.z > MAX_STRUCTURE_Z
            && self.channel != "force"
            && (self.against == "velocity" || self.against == "drive phase")
    }
    /// x2's residuals follow the velocity or the drive phase significantly
    /// and by at least [`MIN_RESCUE_EFFECT`] of the noise: an adequate
    /// static/dynamic law then also tries the Stribeck family (a drop
    /// sharper than the law has). The floor keeps a test whose z grows as
    /// √n from calling every long log's tiny structure a drop.
    pub fn suggests_a_sharper_drop(&self) -> bool {
        self.channel == "x2" && self.follows_the_motion() && self.effect >= MIN_RESCUE_EFFECT
    }
    /// Counted in the verdict: the positions' tests are, the force's
    /// (accelerometer) tests are reported only.
    pub fn counted(&self) -> bool {
        self.channel != "force"
    }
}

/// The adequacy verdict of a refined law.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct Adequacy {
    /// RMS residual of x1, x2 over the sensor noise measured in the log
    /// (second differences): ≈ 1 when the law explains the log.
    pub noise_ratio: (f64, f64),
    /// Robust (MAD) residual/noise ratios of x1, x2.
    pub robust_ratio: (f64, f64),
    /// RMS force residual over the accelerometer's noise (M2·ẍ2 measured
    /// against simulated; the accelerometer's gain and zero fitted), when
    /// the log has an accelerometer. Reported only, as are the force's
    /// structure tests: the accelerometer's dynamics at the stick-slip
    /// jumps are not modelled, so its residuals exceed the noise even
    /// under the true law.
    pub force_ratio: Option<f64>,
    /// The same from the MAD.
    pub robust_force_ratio: Option<f64>,
    /// The structure tests.
    pub structure: Vec<Structure>,
    /// Residuals at the noise (ratio ≤ [`MAX_NOISE_RATIO`]) and without
    /// structure (no test [`Structure::flagged`]).
    pub adequate: bool,
    /// Factor applied to the statistical half-widths (1 when adequate,
    /// else the largest of the noise ratios and √(χ²/dof)).
    pub inflation: f64,
}

impl Adequacy {
    /// Some structure test [`Structure::suggests_a_sharper_drop`]: the
    /// rescue's rule (rigid, and again behind a contact spring).
    pub fn suggests_a_sharper_drop(&self) -> bool {
        self.structure
            .iter()
            .any(Structure::suggests_a_sharper_drop)
    }
}

/// Binned-mean structure tests of the residuals `r` (noise units; NaN
/// where not measured) of channel `name` against each key.
pub(super) fn structure_of(
    name: &'static str,
    seg: &[u32],
    r: &[f64],
    keys: &[(&'static str, Vec<f64>)],
    out: &mut Vec<Structure>,
) {
    let ok: Vec<usize> = (0..r.len()).filter(|&i| r[i].is_finite()).collect();
    if ok.is_empty() {
        return;
    }
    let seg_ok: Vec<u32> = ok.iter().map(|&i| seg[i]).collect();
    let r_ok: Vec<f64> = ok.iter().map(|&i| r[i]).collect();
    let tau = tau_int(&seg_ok, &r_ok).max(1.0);
    let var = r_ok.iter().map(|x| x * x).sum::<f64>() / r_ok.len() as f64;
    for (against, key) in keys {
        // Equal-count bins by the key's rank.
        let mut order: Vec<usize> = ok.iter().copied().filter(|&i| key[i].is_finite()).collect();
        order.sort_by(|&a, &b| key[a].total_cmp(&key[b]));
        let m = order.len();
        if m < 10 * STRUCTURE_BINS {
            continue;
        }
        let mut sums = [0.0f64; STRUCTURE_BINS];
        let mut cnt = [0usize; STRUCTURE_BINS];
        for (rank, &i) in order.iter().enumerate() {
            let b = rank * STRUCTURE_BINS / m;
            sums[b] += r[i];
            cnt[b] += 1;
        }
        let chi2: f64 = (0..STRUCTURE_BINS)
            .map(|b| {
                let c = cnt[b] as f64;
                let mean = sums[b] / c;
                mean * mean / (var * tau / c)
            })
            .sum();
        let k = (STRUCTURE_BINS - 1) as f64;
        let c = 2.0 / (9.0 * k);
        let z = ((chi2 / k).cbrt() - (1.0 - c)) / c.sqrt();
        let ms: f64 = (0..STRUCTURE_BINS)
            .map(|b| sums[b] * sums[b] / cnt[b] as f64)
            .sum::<f64>()
            / m as f64;
        let expected = var * tau * STRUCTURE_BINS as f64 / m as f64;
        out.push(Structure {
            channel: name,
            against,
            chi2_per_dof: chi2 / k,
            z,
            effect: (ms - expected).max(0.0).sqrt(),
        });
    }
}

/// The force residual of the accelerometer: M2·(a2 − c·ẍ2,sim − o) in
/// units of the accelerometer's noise, with its gain c and zero o fitted
/// by least squares (nuisance parameters, as the position gains are); NaN
/// where the accelerometer has no data. None without an accelerometer.
pub(super) fn force_residuals(d: &Data, idx: &[(usize, f64)]) -> Option<Vec<f64>> {
    let (a2, sig) = d.a2.as_ref()?;
    let pairs: Vec<(f64, f64)> = idx
        .iter()
        .map(|&(j, sim)| (a2.get(j).copied().unwrap_or(f64::NAN), sim))
        .collect();
    let fin: Vec<&(f64, f64)> = pairs
        .iter()
        .filter(|p| p.0.is_finite() && p.1.is_finite())
        .collect();
    if fin.len() < 10 * STRUCTURE_BINS {
        return None;
    }
    let n = fin.len() as f64;
    let (ma, ms) = (
        fin.iter().map(|p| p.0).sum::<f64>() / n,
        fin.iter().map(|p| p.1).sum::<f64>() / n,
    );
    let sxy: f64 = fin.iter().map(|p| (p.1 - ms) * (p.0 - ma)).sum();
    let sxx: f64 = fin.iter().map(|p| (p.1 - ms).powi(2)).sum();
    let c = if sxx > 0.0 { sxy / sxx } else { 1.0 };
    let o = ma - c * ms;
    Some(pairs.iter().map(|&(a, s)| (a - c * s - o) / sig).collect())
}

/// The adequacy of residuals `res` (in noise units) at the samples of
/// `idx` (sample index, simulated ẍ2): x1, x2 and, with an accelerometer,
/// the force M2·ẍ2.
pub(super) fn adequacy_of(d: &Data, res: &Res, idx: &[(usize, f64)]) -> Adequacy {
    let n = res.len() as f64;
    let seg: Vec<u32> = res.iter().map(|r| r.0).collect();
    let chans: [(&'static str, Vec<f64>); 2] = [
        ("x1", res.iter().map(|r| r.1).collect()),
        ("x2", res.iter().map(|r| r.2).collect()),
    ];
    let ratio = |r: &[f64]| (r.iter().map(|x| x * x).sum::<f64>() / n).sqrt();
    let noise_ratio = (ratio(&chans[0].1), ratio(&chans[1].1));
    let force = force_residuals(d, idx);
    let force_fin: Vec<f64> = force
        .iter()
        .flatten()
        .copied()
        .filter(|x| x.is_finite())
        .collect();
    let force_ratio = force
        .as_ref()
        .map(|_| (force_fin.iter().map(|x| x * x).sum::<f64>() / force_fin.len() as f64).sqrt());
    let w = 2.0 * PI * d.freq;
    let keys: [(&'static str, Vec<f64>); 4] = [
        (
            "drive phase",
            idx.iter()
                .map(|&(j, _)| (w * d.t[j] - d.phase).rem_euclid(2.0 * PI))
                .collect(),
        ),
        ("velocity", idx.iter().map(|&(j, _)| d.v2s_at(j)).collect()),
        ("position", idx.iter().map(|&(j, _)| d.x2s_at(j)).collect()),
        ("time", idx.iter().map(|&(j, _)| d.t[j]).collect()),
    ];
    let mut structure = Vec::new();
    for (name, r) in &chans {
        structure_of(name, &seg, r, &keys, &mut structure);
    }
    if let Some(f) = &force {
        structure_of("force", &seg, f, &keys, &mut structure);
    }
    // The force is reported, not held to the limits: the accelerometer's
    // own dynamics at the stick-slip jumps are not modelled. The true law
    // of `law_coulomb.mcap` gives a force ratio of 2.37 (robust 1.57), and
    // counting the force's structure tests marked 3 of 45 in-family logs
    // of the issue-14 study inadequate whose positions are explained.
    let worst_ratio = noise_ratio.0.max(noise_ratio.1);
    let counted = |s: &&Structure| s.counted();
    let adequate =
        worst_ratio <= MAX_NOISE_RATIO && !structure.iter().filter(counted).any(Structure::flagged);
    let worst_chi = structure
        .iter()
        .filter(counted)
        .map(|s| s.chi2_per_dof)
        .fold(1.0f64, f64::max);
    let inflation = if adequate {
        1.0
    } else {
        worst_ratio.max(worst_chi.sqrt()).max(1.0)
    };
    Adequacy {
        noise_ratio,
        robust_ratio: (mad_sigma(&chans[0].1), mad_sigma(&chans[1].1)),
        force_ratio,
        robust_force_ratio: force.as_ref().map(|_| mad_sigma(&force_fin)),
        structure,
        adequate,
        inflation,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The rescue's trigger: a significant x2 structure against velocity
    /// or drive phase of at least [`MIN_RESCUE_EFFECT`]; the 3000-s log's
    /// 0.006 at z 4.0 is not one, the sharp-Stribeck rig's 0.05 at z 4.4
    /// is; x1, position, and insignificant structures never are.
    #[test]
    fn only_a_visible_x2_structure_suggests_a_sharper_drop() {
        let s = |channel, against, z, effect| Structure {
            channel,
            against,
            chi2_per_dof: 1.0,
            z,
            effect,
        };
        assert!(!s("x2", "velocity", 4.0, 0.006).suggests_a_sharper_drop());
        assert!(s("x2", "drive phase", 4.4, 0.05).suggests_a_sharper_drop());
        assert!(s("x2", "velocity", 8.5, 0.15).suggests_a_sharper_drop());
        assert!(!s("x1", "velocity", 8.5, 0.15).suggests_a_sharper_drop());
        assert!(!s("x2", "position", 8.5, 0.15).suggests_a_sharper_drop());
        assert!(!s("x2", "velocity", 3.0, 0.15).suggests_a_sharper_drop());
    }
}
