//! Predictions of a measured sweep with a fitted law, their 95 % bands,
//! the steady-state call per step and the score.
//!
//! * **Steady state**: the periodic response of the fitted law at each
//!   measured η, continued from step to step in the order the sweep ran
//!   (from rest at the first step), as [`crate::sim::sweep::curve`] does.
//! * **Replay**: the simulator driven through the sweep as it was run
//!   (the measured frequency plan: dwells exact, ramps numerical, continuous
//!   drive phase, from rest), with the amplitude taken over each point's own
//!   measurement window. It predicts unsettled steps too.
//! * **Bands**: the fit's uncertainty is propagated by re-running both
//!   predictions for laws drawn from the fit's 95 % intervals (see
//!   [`draw_laws`]); the band is the 2.5–97.5 % range of the resulting
//!   amplitudes at each point (the central prediction included). Runs in
//!   parallel; the draws come from a fixed seed and are collected in order,
//!   so the bands do not depend on the thread count.
//! * **How many draws** ([`BandPrecision`]): as many as the scores computed
//!   from the band need. The draws come in rounds (`band_min_samples`,
//!   then doubling, at most `samples`). After each round the Monte-Carlo
//!   standard error of the replay coverages is estimated by resampling the
//!   draws (a bootstrap in which every resample is a whole set of drawn
//!   sweeps, so the errors' correlation along η is kept), and the draws
//!   stop once every coverage is known to `band_coverage_se`. Where the cap
//!   comes first, a warning gives the precision reached. Draw k is the same
//!   law whatever the number drawn (one seeded sequence): a larger cap only
//!   adds draws. The further rounds replay only: the steady-state band
//!   keeps the first round's draws (no score is computed from it).
//! * **Steady-state call**: a step counts as having reached its steady
//!   state when the replay's amplitude over its window is within
//!   [`PredictOptions::steady_tolerance`] of the steady-state prediction
//!   (both amplitudes) *and* the data's own trend does not say otherwise.
//!   The replay is the model's view of the transient, the trend the data's.
//!
//! Every ρ here is made dimensionless with the *sweep's* measured drive
//! amplitude: a law fitted on a characteristic log is kept in newtons and
//! re-scaled ([`Scales`]).
//!
//! * **Real pads** ([`PadSi`]): where the fit chose a threshold split by
//!   direction or a contact spring, every prediction simulates them (Rs⁻
//!   with equal dynamic levels, κ = kt/K2 of the sweep's rig); the draws
//!   take Rs⁻ and ln κ from their intervals on streams of their own, so a
//!   rigid symmetric fit draws exactly what it drew before. Steady states
//!   behind a contact spring are marched (shooting does not vary the
//!   slider's position).

use super::frc::{MeasuredFrc, SweepKind};
use super::ValidateError;
use crate::identify::{Estimate, LogFit};
use crate::ingest::RigMeta;
use crate::model::{Absorber, Law, Levels, Model, Scales, Schedule, Segment, SiLaw};
use crate::sim::engine::{Event, Init, Observer};
use crate::sim::numeric::NumericOptions;
use crate::sim::schedule::{run_schedule, SegmentObserver};
use crate::sim::sweep::{steady_state_with, SteadyConfig};
use crate::sim::SimError;
use crate::stats::Rng;
use crate::stats::{quantile_sorted, quantile_unbiased_sorted};

/// Why a prediction failed: a [`ValidateError`] of the inputs, or the
/// simulation.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PredictError {
    /// The inputs do not give a prediction.
    #[error(transparent)]
    Validate(#[from] ValidateError),
    /// The simulation failed.
    #[error(transparent)]
    Sim(#[from] SimError),
}
use rayon::prelude::*;
use std::f64::consts::PI;

mod replay;
pub mod sensitive;

pub use replay::schedule;
use replay::*;

/// The absorber (m, k, D) of a rig.
pub fn absorber(rig: &RigMeta) -> Absorber {
    rig.constants().absorber()
}

/// Default largest number of laws drawn for a band.
pub const DEFAULT_BAND_SAMPLES: usize = 160;

/// Default period budget of the fitted law's steady state per point.
pub const DEFAULT_STEADY_PERIODS: u64 = 20_000;

/// Options of the predictions.
#[derive(Debug, Clone)]
pub struct PredictOptions {
    /// Most laws drawn from the fit's intervals for the bands (0: no
    /// bands; see [`BandPrecision`] for how many are drawn).
    pub samples: usize,
    /// Laws drawn in the first round (fewer if `samples` is smaller). 40:
    /// with the central value the 2.5 % point is then an interpolation
    /// between order statistics, not the smallest value (see
    /// [`quantile_unbiased_sorted`]).
    pub band_min_samples: usize,
    /// Bootstrap standard error (a fraction) to which every replay
    /// coverage must be known before the draws stop, or half a point's
    /// share of the coverage (0.5/points) where that is larger: a coverage
    /// of 21 steps is not known better than to about one step (0: always
    /// draw `samples`).
    pub band_coverage_se: f64,
    /// Seed of the draws.
    pub seed: u64,
    /// Steady-state solver settings.
    pub steady: SteadyConfig,
    /// Integrator tolerances of the replay's ramps (and Stribeck laws).
    pub numeric: NumericOptions,
    /// Relative distance of the replay from the steady state below which a
    /// step counts as settled (0.03: the rig's own convention in the data
    /// set's documentation, "within 3 % of the steady state").
    pub steady_tolerance: f64,
    /// Period budget of the steady-state solver's time-marching fallback
    /// for the laws drawn for the bands (the central law uses
    /// `steady.max_periods`). Steady states that exist are found within a
    /// few dozen periods (shooting, stick proofs); only points without a
    /// periodic response run the whole budget, and there a draw simply
    /// contributes nothing.
    pub band_max_periods: u64,
    /// The draws' budget where the central law has no steady state.
    pub band_unsettled_periods: u64,
    /// Trajectory samples per drive period for the replay's amplitudes
    /// (extremes are refined between samples and switching events by cubic
    /// Hermite interpolation of the exact positions and velocities; at 48
    /// per period a smooth extremum is within (2π/48)⁴/384 ≈ 8e-7 relative,
    /// far below any rig's noise).
    pub samples_per_period: u32,
    /// Assess which steps are sensitive ([`super::sensitive`]; about
    /// 29 re-runs of each step).
    pub sensitivity: bool,
}

impl Default for PredictOptions {
    fn default() -> Self {
        Self {
            samples: DEFAULT_BAND_SAMPLES,
            band_min_samples: 40,
            band_coverage_se: 0.025,
            seed: 0x0ba5_e11e,
            steady: SteadyConfig {
                max_periods: DEFAULT_STEADY_PERIODS,
                // Unsettled points are not scored: no amplitude ranges.
                ranges: false,
                ..SteadyConfig::default()
            },
            numeric: NumericOptions {
                rtol: 1e-8,
                atol: 1e-10,
            },
            steady_tolerance: 0.03,
            band_max_periods: 2_000,
            band_unsettled_periods: 200,
            samples_per_period: 48,
            sensitivity: true,
        }
    }
}

/// A predicted response at the measured points with its 95 % band
/// (`None` where the model interrupts or does not settle).
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct Predicted {
    /// η of each point.
    pub eta: Vec<f64>,
    /// A1/A.
    pub amplitude1: Vec<Option<f64>>,
    /// A2/A.
    pub amplitude2: Vec<Option<f64>>,
    /// Band of A1/A: low.
    pub amplitude1_low: Vec<Option<f64>>,
    /// Band of A1/A: high.
    pub amplitude1_high: Vec<Option<f64>>,
    /// Band of A2/A: low.
    pub amplitude2_low: Vec<Option<f64>>,
    /// Band of A2/A: high.
    pub amplitude2_high: Vec<Option<f64>>,
}

/// Scores of the predictions against the measured response (steady-state
/// scores over the steps that reached their steady state; replay scores
/// over every step; nrms = RMS / measured peak).
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct Score {
    /// RMS of predicted − measured A1/A (steady, settled steps).
    pub rms_amplitude1: Option<f64>,
    /// RMS of A2/A.
    pub rms_amplitude2: Option<f64>,
    /// RMS over the measured peak A1/A.
    pub nrms_amplitude1: Option<f64>,
    /// RMS over the measured peak A2/A.
    pub nrms_amplitude2: Option<f64>,
    /// η of the predicted A1 peak minus η of the measured one (settled
    /// steps).
    pub peak_eta_error: Option<f64>,
    /// nrms of the replay's A1/A over every point.
    pub replay_nrms_amplitude1: Option<f64>,
    /// nrms of the replay's A2/A.
    pub replay_nrms_amplitude2: Option<f64>,
    /// nrms of the replay's A1/A over the points not marked sensitive
    /// ([`Prediction::replay_sensitive`]).
    pub replay_nrms_robust_amplitude1: Option<f64>,
    /// The same for A2/A.
    pub replay_nrms_robust_amplitude2: Option<f64>,
    /// Fraction of points whose measured A1/A, within its own 95 %
    /// measurement uncertainty (sensor noise and gain budget, see
    /// [`super::frc::MeasuredPoint::amplitude1_u`]), lies inside the replay
    /// band: the band holds the fit's uncertainty only, the measurement has
    /// its own, so the two intervals must overlap.
    pub replay_coverage_amplitude1: Option<f64>,
    /// The same for A2/A.
    pub replay_coverage_amplitude2: Option<f64>,
    /// Fraction of points whose measured A1/A itself lies inside the band
    /// (no measurement uncertainty).
    pub replay_coverage_strict_amplitude1: Option<f64>,
    /// The same for A2/A.
    pub replay_coverage_strict_amplitude2: Option<f64>,
    /// Median relative half-width of the replay's A1 band.
    pub band_median_rel_halfwidth1: Option<f64>,
    /// Points scored in the steady-state scores.
    pub steady_points: usize,
}

/// Predictions of one sweep with one fitted law.
#[derive(Debug, Clone, PartialEq)]
pub struct Prediction {
    /// The dimensionless law used (with the sweep's drive amplitude).
    pub law: Law,
    /// The contact stiffness κ = kt/K2 simulated (None: rigid).
    pub contact_stiffness: Option<f64>,
    /// The absorber of the sweep's rig.
    pub absorber: Absorber,
    /// Steady-state prediction.
    pub steady: Predicted,
    /// Replay of the sweep as it was run.
    pub replay: Predicted,
    /// The tool's call per point: had it reached its steady state?
    pub steady_reached: Vec<Option<bool>>,
    /// The replay's own call: replay within tolerance of the steady state.
    pub replay_settled: Vec<Option<bool>>,
    /// Per point: does the replay hinge on details finer than the
    /// measurement resolves? `None`: not assessed (continuous sweeps,
    /// steps without a measured start state, or `sensitivity` off).
    pub replay_sensitive: Vec<Option<bool>>,
    /// The assessment behind `replay_sensitive` (see
    /// [`super::sensitive`]).
    pub replay_sensitivity: Vec<Option<super::sensitive::Sensitivity>>,
    /// Scores.
    pub score: Score,
    /// Laws drawn for the replay band.
    pub draws: usize,
    /// Of those, the laws whose steady states make the steady-state band
    /// (the first round's: no score is computed from that band).
    pub steady_band_draws: usize,
    /// How precisely the draws fix the band's scores.
    pub band: BandPrecision,
    /// Things the user should know.
    pub warnings: Vec<crate::warning::Warning>,
}

/// A draw from a split normal with the interval as its 2.5/97.5 % points.
fn split_normal(rng: &mut Rng, est: f64, iv: Option<(f64, f64)>) -> f64 {
    let z = rng.normal();
    match iv {
        Some((lo, hi)) if lo.is_finite() && hi.is_finite() => {
            let s = if z < 0.0 { est - lo } else { hi - est };
            est + z * s.max(0.0) / 1.96
        }
        _ => est,
    }
}

/// What a fit found beyond the paper's symmetric rigid pad, in SI, as the
/// predictions simulate it (the default: the paper's pad).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct PadSi {
    /// The static threshold towards − (N), the dynamic level shared;
    /// None: symmetric.
    pub rs_minus_n: Option<f64>,
    /// The contact's tangential stiffness kt (N/m); None: rigid.
    pub kt_n_per_m: Option<f64>,
}

impl PadSi {
    /// The fit's extensions: Rs⁻ where the threshold is split (a side only
    /// bounded takes its lowest admitted threshold, as a never-sticking
    /// log's Rs does), kt where a contact spring was chosen.
    pub fn of(fit: &LogFit) -> Self {
        let rs_minus_n = fit
            .pads()
            .filter(|_| fit.direction_dependent())
            .and_then(|p| p.rs_minus_n.or(p.rs_minus_interval_n.map(|iv| iv.0)));
        PadSi {
            rs_minus_n,
            kt_n_per_m: fit.contact_stiffness().map(|k| k * fit.k2_n_per_m()),
        }
    }

    /// `n` draws (Rs⁻ and kt) from the fit's intervals, in order, on
    /// streams of their own: a split normal for a measured Rs⁻ (uniform
    /// between the bounds of one only bounded), a split normal in ln kt.
    fn draws(fit: &LogFit, n: usize, seed: u64) -> Vec<PadSi> {
        let central = Self::of(fit);
        let pads = fit.pads();
        let mut rng_s = Rng::with_stream(seed, 0x5_9117);
        let mut rng_k = Rng::with_stream(seed, 0xC0_47AC7);
        (0..n)
            .map(|_| PadSi {
                rs_minus_n: central.rs_minus_n.map(|rs| {
                    let p = pads.expect("a split comes from the pads");
                    match (p.rs_minus_n, p.rs_minus_interval_n) {
                        (Some(_), iv) => split_normal(&mut rng_s, rs, iv).max(0.0),
                        (None, Some((lo, hi))) => lo + (hi - lo) * rng_s.uniform(),
                        (None, None) => rs,
                    }
                }),
                kt_n_per_m: central.kt_n_per_m.map(|kt| {
                    let iv = pads
                        .and_then(|p| p.contact_stiffness_interval)
                        .filter(|(l, h)| *l > 0.0 && *h > 0.0)
                        .map(|(l, h)| (l.ln(), h.ln()));
                    let k2 = fit.k2_n_per_m();
                    (split_normal(&mut rng_k, (kt / k2).ln(), iv)).exp() * k2
                }),
            })
            .collect()
    }

    /// `model` with these extensions under `scales` (Rs⁻ scaled as the
    /// law's levels are; its dynamic level the law's own), for a rig of
    /// coupling stiffness `k2` (N/m).
    fn apply(&self, mut model: Model, scales: &Scales, k2: f64) -> Model {
        if let Some(rs) = self.rs_minus_n {
            let rho_d = model.law.rho_d();
            model.law = model.law.with_minus(Some(Levels {
                rho_s: (rs / scales.force_n).max(rho_d),
                rho_d,
            }));
        }
        model.contact_stiffness = self.kt_n_per_m.map(|kt| kt / k2);
        model
    }
}

/// The central law of a fit (SI) and `n` laws drawn from its uncertainty.
///
/// Each parameter is drawn from a split normal whose 2.5 % and 97.5 %
/// points are the fit's interval ends; the law parameters are drawn
/// independently (Rs comes from the breakaways, Rd and the slope from the
/// slip samples). The sensors' *common* scale errors are drawn once per
/// law, because they move every force together:
///
/// * the sweep's own drive sensor: the sweep's ρ = R/(A·K2) uses its
///   measured A, whose gain is known to ±u (the fit's `gain_uncertainty`);
///   every force of a draw is scaled by one factor 1 + e, e uniform on
///   [−u, u] (the calibration budget's rectangular bound);
/// * for the output-error estimate, the characteristic log's drive sensor
///   too: that fit compares positions with the model driven by the
///   measured drive, so it is precise in ρ (relative to the measured drive
///   amplitude) and its forces in newtons carry the drive gain whole. Its
///   parameters are drawn from the ρ and D* intervals (which hold the
///   statistical part and every calibration effect on ρ) and turned into
///   newtons with the measured amplitude times a second common factor.
///   Drawing Rs and Rd independently from their newton intervals instead
///   would make the common part too small and their difference too large.
///   The equation-error estimate computes forces from M2's own sensors (no
///   drive gain in newtons), so its newton intervals are used as they are.
///
/// Where ρs is only bounded (a never-sticking log), Rs is uniform between
/// its bounds and the central law takes Rs = Rd (the lower bound). The
/// family's constraints are kept: Coulomb and `decreasing` laws keep
/// Rs = Rd; a static-dynamic draw keeps Rd ≤ Rs.
///
/// A stuck log has no sliding level: an error (nothing to predict with).
pub fn draw_laws(fit: &LogFit, n: usize, seed: u64) -> Result<(SiLaw, Vec<SiLaw>), PredictError> {
    let (central, draws) = draw_laws_gains(fit, n, seed)?;
    Ok((central, draws.into_iter().map(|(l, _)| l).collect()))
}

/// [`draw_laws`] with each draw's sweep drive-gain factor 1 + e (the
/// factor its forces carry for the sweep's drive sensor).
fn draw_laws_gains(
    fit: &LogFit,
    n: usize,
    seed: u64,
) -> Result<(SiLaw, Vec<(SiLaw, f64)>), PredictError> {
    // A never-sticking log's law carries Rs = Rd (Measured::NeverSticks);
    // the draws take Rs from its bounds.
    let Some(central) = fit.law() else {
        return Err(ValidateError::NeverSlid.into());
    };
    let u = if fit.gain_uncertainty.is_finite() {
        fit.gain_uncertainty.clamp(0.0, 0.5)
    } else {
        0.0
    };
    // The frame of the draws: newton intervals and whether the
    // characteristic log's drive gain is a common factor on top.
    let scale = |iv: Option<(f64, f64)>, s: f64| iv.map(|(lo, hi)| (lo * s, hi * s));
    let oe = fit.estimate == Estimate::OutputError;
    // The chosen law's own threshold interval where the reported one was
    // widened for the threshold's identifiability (the draws simulate the
    // chosen law).
    let (rs_n_iv, rho_s_iv) = match fit.law_threshold_interval {
        Some((n, rho)) => (Some(n), rho),
        None => (fit.rs_interval_n, fit.rho_s_interval),
    };
    let (rs_iv, rd_iv, slope_iv) = if oe {
        (
            scale(rho_s_iv, fit.force_scale_n),
            scale(fit.rho_d_interval, fit.force_scale_n),
            scale(fit.dstar_interval, fit.slope_scale),
        )
    } else {
        (rs_n_iv, fit.rd_interval_n, fit.slope_interval_n_s_per_m)
    };
    let tied = central.kind.family().tied_threshold();
    let mut rng = Rng::new(seed);
    let mut out = Vec::with_capacity(n);
    for _ in 0..n {
        let mut l = central;
        l.rd_n = split_normal(&mut rng, central.rd_n, rd_iv).max(0.0);
        l.slope_n_s_per_m = if central.slope_n_s_per_m == 0.0 && !central.kind.family().free_slope()
        {
            0.0
        } else {
            split_normal(&mut rng, central.slope_n_s_per_m, slope_iv)
        };
        let sweep_gain = 1.0 + u * (2.0 * rng.uniform() - 1.0);
        let char_gain = if oe {
            1.0 + u * (2.0 * rng.uniform() - 1.0)
        } else {
            1.0
        };
        if fit.never_sticks() {
            // The bounds (newtons) already hold the calibration margin.
            l.rd_n *= char_gain;
            let (lo, hi) = fit.rs_interval_n.unwrap_or((l.rd_n, l.rd_n));
            l.rs_n = (lo + (hi - lo) * rng.uniform()).max(l.rd_n);
        } else if tied {
            l.rd_n *= char_gain;
            l.rs_n = l.rd_n;
        } else {
            l.rs_n = split_normal(&mut rng, central.rs_n, rs_iv) * char_gain;
            l.rd_n *= char_gain;
            l.rs_n = l.rs_n.max(l.rd_n);
        }
        l.rs_n *= sweep_gain;
        l.rd_n *= sweep_gain;
        out.push((l, sweep_gain));
    }
    Ok((central, out))
}

/// One draw of the sweep's drive within its measurement uncertainty,
/// drawn jointly with a law (one draw = one law and one drive).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DriveDraw {
    /// Measured over true drive amplitude, A_m/A: the x0 gain (drawn with
    /// the law, [`draw_laws`]) times the amplitude's statistical error. The
    /// law's friction levels carry it (ρ = R/(A·K2) with the true A) and the
    /// predicted A_i/A is divided by it (the rig reads A_i over A_m).
    pub amplitude_factor: f64,
    /// Drive phase error (rad).
    pub phase_rad: f64,
    /// Relative error of the plan's frequencies.
    pub frequency_rel: f64,
    /// Timing error of the drive against x1 (s).
    pub shift_s: f64,
}

impl DriveDraw {
    /// The drive as measured.
    pub const NOMINAL: DriveDraw = DriveDraw {
        amplitude_factor: 1.0,
        phase_rad: 0.0,
        frequency_rel: 0.0,
        shift_s: 0.0,
    };
}

/// The central law of a fit and `n` joint draws of law and drive: each
/// law as [`draw_laws`] draws it (same stream, same laws up to the drive's
/// statistical amplitude factor), each drive from the measured sweep's
/// [`super::frc::DriveUncertainty`] (normal errors, a stream of its own)
/// and the law's x0 gain factor.
pub fn draw_joint(
    fit: &LogFit,
    frc: &MeasuredFrc,
    n: usize,
    seed: u64,
) -> Result<(SiLaw, Vec<(SiLaw, DriveDraw)>), PredictError> {
    let (central, laws) = draw_laws_gains(fit, n, seed)?;
    let u = frc.drive_uncertainty;
    let mut rng = Rng::with_stream(seed, 0xD1_17E);
    let out = laws
        .into_iter()
        .map(|(mut l, gain)| {
            let stat = 1.0 + u.amplitude_rel * rng.normal();
            l.rs_n *= stat;
            l.rd_n *= stat;
            let d = DriveDraw {
                amplitude_factor: gain * stat,
                phase_rad: u.phase_rad * rng.normal(),
                frequency_rel: u.frequency_rel * rng.normal(),
                shift_s: u.delay_s * rng.normal(),
            };
            (l, d)
        })
        .collect();
    Ok((central, out))
}

/// One law's steady-state curve at the measured η, continued in the
/// sweep's order from rest and advanced a stretch of points at a time;
/// `budgets[i]` caps the marching fallback at point i (None:
/// `cfg.max_periods`). A point that fails (an interruption) has no
/// amplitude and the continuation restarts from rest after it.
struct Continuation<'m> {
    model: &'m Model,
    state: Init,
    engine: Option<crate::sim::sweep::SweepEngine>,
    out: Vec<Option<(f64, f64)>>,
}

impl<'m> Continuation<'m> {
    fn new(model: &'m Model) -> Self {
        Self {
            model,
            state: Init::rest(),
            engine: None,
            out: Vec::new(),
        }
    }

    /// Continues up to point `upto` (exclusive) of `etas`.
    fn advance(&mut self, etas: &[f64], upto: usize, cfg: &SteadyConfig, budgets: Option<&[u64]>) {
        while self.out.len() < upto.min(etas.len()) {
            let i = self.out.len();
            let c = SteadyConfig {
                max_periods: budgets.map_or(cfg.max_periods, |b| b[i]),
                ..*cfg
            };
            match steady_state_with(&mut self.engine, self.model, etas[i], self.state, &c) {
                Ok((p, next)) => {
                    self.state = next;
                    self.out.push(match (p.amplitude1, p.amplitude2) {
                        (Some(a1), Some(a2)) if p.steady => Some((a1, a2)),
                        _ => None,
                    });
                }
                Err(_) => {
                    self.state = Init::rest();
                    self.out.push(None);
                }
            }
        }
    }
}

/// Points per stretch of [`steady_all`]'s pipeline.
const STRETCH: usize = 16;

/// The steady states of the central law and of the draws. A draw's
/// marching budget at a point is `band_max_periods` where the central law
/// has a steady state there and `band_unsettled_periods` where it has none
/// (a point with no periodic response for the central law rarely has one
/// for a nearby law, and its band needs half the draws), so the draws
/// follow the central continuation: they run a stretch behind it, side by
/// side with its next stretch, instead of waiting for all of it (the
/// central continuation is sequential and the longest single task of a
/// validation). Every continuation computes exactly what it would alone.
fn steady_all(
    model: &Model,
    draws: &[Model],
    etas: &[f64],
    opts: &PredictOptions,
) -> (Amps, Vec<Amps>) {
    let budget = |c: &Option<(f64, f64)>| draw_budget(c, opts);
    let n = etas.len();
    let mut central = Continuation::new(model);
    let mut followers: Vec<Continuation> = draws.iter().map(Continuation::new).collect();
    central.advance(etas, STRETCH, &opts.steady, None);
    loop {
        let ready = central.out.len();
        let budgets: Vec<u64> = central.out.iter().map(budget).collect();
        rayon::join(
            || central.advance(etas, ready + STRETCH, &opts.steady, None),
            || {
                followers
                    .par_iter_mut()
                    .for_each(|f| f.advance(etas, ready, &opts.steady, Some(&budgets)))
            },
        );
        if ready == n {
            break;
        }
    }
    (central.out, followers.into_iter().map(|f| f.out).collect())
}

/// A draw's marching budget at a point where the central law's steady
/// state is `c` (see [`steady_all`]).
fn draw_budget(c: &Option<(f64, f64)>, opts: &PredictOptions) -> u64 {
    if c.is_some() {
        opts.band_max_periods
    } else {
        opts.band_unsettled_periods
    }
    .min(opts.steady.max_periods)
}

/// The 2.5–97.5 % band at one point, `[low1, high1, low2, high2]`, from
/// its values over the central run and `n_draws` draws (a band needs at
/// least half of the draws); `v1`, `v2` are scratch.
fn band_of(
    vals: impl Iterator<Item = Option<(f64, f64)>>,
    n_draws: usize,
    v1: &mut Vec<f64>,
    v2: &mut Vec<f64>,
) -> Option<[f64; 4]> {
    v1.clear();
    v2.clear();
    for (a1, a2) in vals.flatten() {
        v1.push(a1);
        v2.push(a2);
    }
    if n_draws == 0 || v1.len() * 2 < n_draws + 1 {
        return None;
    }
    v1.sort_unstable_by(f64::total_cmp);
    v2.sort_unstable_by(f64::total_cmp);
    let q = quantile_unbiased_sorted;
    Some([q(v1, 0.025), q(v1, 0.975), q(v2, 0.025), q(v2, 0.975)])
}

/// Central values and the 2.5–97.5 % band (over the central run and the
/// draws) per point. A band needs at least half of the draws.
fn banded(
    etas: &[f64],
    central: &[Option<(f64, f64)>],
    draws: &[Vec<Option<(f64, f64)>>],
) -> Predicted {
    let mut p = Predicted {
        eta: etas.to_vec(),
        ..Predicted::default()
    };
    let (mut v1, mut v2) = (Vec::new(), Vec::new());
    for (i, &c) in central.iter().enumerate().take(etas.len()) {
        p.amplitude1.push(c.map(|v| v.0));
        p.amplitude2.push(c.map(|v| v.1));
        let vals = std::iter::once(c).chain(draws.iter().map(|d| d[i]));
        let b = band_of(vals, draws.len(), &mut v1, &mut v2);
        p.amplitude1_low.push(b.map(|b| b[0]));
        p.amplitude1_high.push(b.map(|b| b[1]));
        p.amplitude2_low.push(b.map(|b| b[2]));
        p.amplitude2_high.push(b.map(|b| b[3]));
    }
    p
}

/// Fraction of the points whose measured value (within its uncertainty
/// `u`, if given) lies inside the band (None: no band anywhere).
fn coverage(
    lo: &[Option<f64>],
    hi: &[Option<f64>],
    meas: &[f64],
    u: Option<&[f64]>,
) -> Option<f64> {
    let n = meas.len();
    (n > 0 && lo.iter().any(|l| l.is_some())).then(|| {
        (0..n)
            .filter(|&i| {
                let ui = u.map_or(0.0, |u| if u[i].is_finite() { u[i] } else { 0.0 });
                matches!((lo[i], hi[i]), (Some(l), Some(h)) if meas[i] + ui >= l && meas[i] - ui <= h)
            })
            .count() as f64
            / n as f64
    })
}

/// Median over the points of the band's half-width relative to the
/// central value (None: no band).
fn median_rel_halfwidth(
    lo: &[Option<f64>],
    hi: &[Option<f64>],
    central: &[Option<f64>],
) -> Option<f64> {
    let mut half: Vec<f64> = (0..central.len())
        .filter_map(|i| match (lo[i], hi[i], central[i]) {
            (Some(l), Some(h), Some(c)) if c > 0.0 => Some(0.5 * (h - l) / c),
            _ => None,
        })
        .collect();
    half.sort_by(f64::total_cmp);
    (!half.is_empty()).then(|| quantile_sorted(&half, 0.5))
}

/// How precisely the draws fix the scores computed from the replay band:
/// bootstrap standard errors over the draws (see the module notes).
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct BandPrecision {
    /// Laws drawn.
    pub draws: usize,
    /// Most laws that could have been drawn (`samples`).
    pub draws_max: usize,
    /// Standard error of `replay_coverage_amplitude1` (a fraction).
    pub coverage_se_amplitude1: Option<f64>,
    /// Standard error of `replay_coverage_amplitude2`.
    pub coverage_se_amplitude2: Option<f64>,
    /// Standard error of `replay_coverage_strict_amplitude1`.
    pub coverage_strict_se_amplitude1: Option<f64>,
    /// Standard error of `replay_coverage_strict_amplitude2`.
    pub coverage_strict_se_amplitude2: Option<f64>,
    /// Standard error of `band_median_rel_halfwidth1`, relative to it.
    pub halfwidth_rel_se: Option<f64>,
    /// The target of the coverages' standard errors: `band_coverage_se`,
    /// or 0.5/points where that is larger.
    pub target: f64,
    /// Every coverage is known to the target.
    pub reached: bool,
}

/// Bootstrap resamples of [`band_precision`].
const BOOTSTRAP: usize = 200;

/// The bootstrap standard errors of the replay coverages and of the
/// band's median half-width (`halfwidth`, over every draw): the band and
/// its scores are recomputed for [`BOOTSTRAP`] resamples (with
/// replacement) of the whole drawn sweeps. Deterministic: each resample
/// has its own random stream of `seed`.
fn band_precision(
    frc: &MeasuredFrc,
    central: &Amps,
    draws: &[Amps],
    draws_max: usize,
    halfwidth: Option<f64>,
    target: f64,
    seed: u64,
) -> BandPrecision {
    let n = draws.len();
    let mut out = BandPrecision {
        draws: n,
        draws_max,
        target: target.max(0.5 / frc.points.len().max(1) as f64),
        ..BandPrecision::default()
    };
    if n == 0 {
        return out;
    }
    let m1: Vec<f64> = frc.points.iter().map(|p| p.amplitude1).collect();
    let m2: Vec<f64> = frc.points.iter().map(|p| p.amplitude2).collect();
    let u1: Vec<f64> = frc.points.iter().map(|p| p.amplitude1_u).collect();
    let u2: Vec<f64> = frc.points.iter().map(|p| p.amplitude2_u).collect();
    let c1: Vec<Option<f64>> = central.iter().map(|c| c.map(|v| v.0)).collect();
    // Per resample: the four coverages and the median half-width.
    let stats: Vec<[Option<f64>; 5]> = (0..BOOTSTRAP)
        .into_par_iter()
        .map(|b| {
            let mut rng = Rng::with_stream(seed, 1 + b as u64);
            let idx: Vec<usize> = (0..n).map(|_| rng.below(n)).collect();
            let npts = central.len();
            let mut e: [Vec<Option<f64>>; 4] = std::array::from_fn(|_| Vec::with_capacity(npts));
            let (mut v1, mut v2) = (Vec::new(), Vec::new());
            for (i, &c) in central.iter().enumerate() {
                let vals = std::iter::once(c).chain(idx.iter().map(|&k| draws[k][i]));
                let band = band_of(vals, n, &mut v1, &mut v2);
                for (k, ek) in e.iter_mut().enumerate() {
                    ek.push(band.map(|b| b[k]));
                }
            }
            [
                coverage(&e[0], &e[1], &m1, Some(&u1)),
                coverage(&e[2], &e[3], &m2, Some(&u2)),
                coverage(&e[0], &e[1], &m1, None),
                coverage(&e[2], &e[3], &m2, None),
                median_rel_halfwidth(&e[0], &e[1], &c1),
            ]
        })
        .collect();
    let sd = |k: usize| -> Option<f64> {
        let v: Vec<f64> = stats.iter().filter_map(|s| s[k]).collect();
        (v.len() >= 2).then(|| {
            if v.iter().all(|x| *x == v[0]) {
                return 0.0;
            }
            let mean = v.iter().sum::<f64>() / v.len() as f64;
            (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (v.len() - 1) as f64).sqrt()
        })
    };
    out.coverage_se_amplitude1 = sd(0);
    out.coverage_se_amplitude2 = sd(1);
    out.coverage_strict_se_amplitude1 = sd(2);
    out.coverage_strict_se_amplitude2 = sd(3);
    out.halfwidth_rel_se = sd(4)
        .zip(halfwidth)
        .filter(|(_, h)| *h > 0.0)
        .map(|(s, h)| s / h);
    out.reached = [
        out.coverage_se_amplitude1,
        out.coverage_se_amplitude2,
        out.coverage_strict_se_amplitude1,
        out.coverage_strict_se_amplitude2,
    ]
    .iter()
    .all(|s| s.is_none_or(|s| s <= out.target));
    out
}

fn rms(pairs: &[(f64, f64)]) -> Option<f64> {
    (!pairs.is_empty()).then(|| {
        (pairs.iter().map(|(p, m)| (p - m).powi(2)).sum::<f64>() / pairs.len() as f64).sqrt()
    })
}

/// Predicts the measured sweep `frc` (of a rig with constants `rig`) with
/// the law fitted in `fit`, with bands, the steady-state call and scores.
pub fn predict(
    fit: &LogFit,
    rig: &RigMeta,
    frc: &MeasuredFrc,
    opts: &PredictOptions,
) -> Result<Prediction, PredictError> {
    let (central, draws) = draw_joint(fit, frc, opts.samples, opts.seed)?;
    let pad = PadSi::of(fit);
    let pads = if pad == PadSi::default() {
        Vec::new()
    } else {
        PadSi::draws(fit, draws.len(), opts.seed)
    };
    predict_pads(&central, &draws, (&pad, &pads), rig, frc, opts)
}

/// A draw's predicted A_i/A as the rig reads them: over the measured drive
/// amplitude, i.e. divided by the draw's amplitude factor.
fn divided(a: Amps, d: &DriveDraw) -> Amps {
    let g = d.amplitude_factor;
    if g == 1.0 {
        return a;
    }
    a.into_iter()
        .map(|v| v.map(|(x, y)| (x / g, y / g)))
        .collect()
}

/// The steady-state call per point (`(replay_settled, steady_reached)`):
/// the replay settled where it agrees with the steady state within `tol`;
/// a step reached its steady state unless the replay or the data say
/// otherwise (a continuous sweep: the replay's call alone).
fn steady_call(
    frc: &MeasuredFrc,
    c_replay: &Amps,
    c_steady: &Amps,
    tol: f64,
) -> (Vec<Option<bool>>, Vec<Option<bool>>) {
    let n = frc.points.len();
    let mut replay_settled = Vec::with_capacity(n);
    let mut steady_reached = Vec::with_capacity(n);
    for (i, p) in frc.points.iter().enumerate() {
        let r = match (c_replay[i], c_steady[i]) {
            (Some((r1, r2)), Some((s1, s2))) => {
                let close = |r: f64, s: f64| (r - s).abs() <= tol * s.abs().max(1e-9);
                Some(close(r1, s1) && close(r2, s2))
            }
            _ => None,
        };
        replay_settled.push(r);
        let call = match (r, p.settled) {
            (Some(false), _) | (_, Some(false)) => Some(false),
            (Some(true), _) => Some(true),
            (None, data) => data,
        };
        steady_reached.push(if frc.kind == SweepKind::Continuous {
            r
        } else {
            call
        });
    }
    (replay_settled, steady_reached)
}

/// Predicts the measured sweep `frc` with the SI law `central`, the band
/// from the laws `draws` (empty: no band) with the drive as measured.
pub fn predict_with(
    central: &SiLaw,
    draws: &[SiLaw],
    rig: &RigMeta,
    frc: &MeasuredFrc,
    opts: &PredictOptions,
) -> Result<Prediction, PredictError> {
    let joint: Vec<(SiLaw, DriveDraw)> = draws.iter().map(|l| (*l, DriveDraw::NOMINAL)).collect();
    predict_joint(central, &joint, rig, frc, opts)
}

/// Predicts the measured sweep `frc` with the SI law `central`, the band
/// from joint draws of law and drive (`draws`, see [`draw_joint`]; empty:
/// no band): each draw's replay runs its own drive (phase, frequencies,
/// timing of the windows) and its predicted A_i/A, replay and steady
/// state, is divided by its amplitude factor.
pub fn predict_joint(
    central: &SiLaw,
    draws: &[(SiLaw, DriveDraw)],
    rig: &RigMeta,
    frc: &MeasuredFrc,
    opts: &PredictOptions,
) -> Result<Prediction, PredictError> {
    predict_pads(central, draws, (&PadSi::default(), &[]), rig, frc, opts)
}

/// [`predict_joint`] with a real pad's extensions: the central one and
/// one per draw (`pads.1` empty: the central one for every draw).
pub fn predict_pads(
    central: &SiLaw,
    draws: &[(SiLaw, DriveDraw)],
    pads: (&PadSi, &[PadSi]),
    rig: &RigMeta,
    frc: &MeasuredFrc,
    opts: &PredictOptions,
) -> Result<Prediction, PredictError> {
    if frc.points.is_empty() {
        return Err(ValidateError::NoPoints.into());
    }
    let scales = Scales::from_rig(&rig.constants(), frc.drive_amplitude_m);
    let absorber = absorber(rig);
    let mut warnings = Vec::new();
    let to_model = |l: &SiLaw, pad: &PadSi| {
        let model = l.to_rho(&scales).map(|law| Model {
            absorber,
            law,
            stop_below: None,
            contact_stiffness: None,
        })?;
        if *pad == PadSi::default() {
            return Some(model);
        }
        let model = pad.apply(model, &scales, rig.k2_n_per_m);
        model.validate().is_ok().then_some(model)
    };
    let Some(model) = to_model(central, pads.0) else {
        return Err(ValidateError::InvalidLaw.into());
    };
    let (models, drives): (Vec<Model>, Vec<DriveDraw>) = draws
        .iter()
        .enumerate()
        .filter_map(|(i, (l, d))| to_model(l, pads.1.get(i).unwrap_or(pads.0)).map(|m| (m, *d)))
        .unzip();
    if models.len() < draws.len() {
        warnings.push(crate::warning::Warning::InvalidDraws {
            invalid: draws.len() - models.len(),
            draws: draws.len(),
        });
    }
    let etas: Vec<f64> = frc.points.iter().map(|p| p.eta).collect();
    let sched = schedule(frc)?;
    let windows = replay_windows(frc, opts);

    // Round 1: the steady states (the central continuation, the draws' a
    // stretch behind it) beside the replays, which need nothing from them.
    let n_max = models.len();
    let n0 = if opts.band_coverage_se > 0.0 {
        opts.band_min_samples.max(1).min(n_max)
    } else {
        n_max
    };
    let w_ref = frc.omega_ref_rad_s;
    let replays = |ms: &[Model], ds: &[DriveDraw]| -> Vec<Amps> {
        ms.par_iter()
            .zip(ds)
            .map(|(m, d)| {
                let s = drawn_schedule(&sched, d);
                let w: Vec<(f64, f64, f64)> = windows
                    .iter()
                    .map(|&(a, b, h)| (a + d.shift_s * w_ref, b + d.shift_s * w_ref, h))
                    .collect();
                divided(replay_one(m, &s, &w, opts), d)
            })
            .collect()
    };
    let ((c_steady, d_steady), (c_replay, mut d_replay)) = rayon::join(
        || {
            let (c, d) = steady_all(&model, &models[..n0], &etas, opts);
            let d = d
                .into_iter()
                .zip(&drives)
                .map(|(a, dr)| divided(a, dr))
                .collect::<Vec<_>>();
            (c, d)
        },
        || {
            rayon::join(
                || replay_one(&model, &sched, &windows, opts),
                || replays(&models[..n0], &drives[..n0]),
            )
        },
    );
    // Further rounds (twice as many draws each) until the coverages are
    // known to the target or every draw is in: replays only. The steady
    // band keeps the first round's draws: no score is computed from it
    // (the coverages are the replay band's), and the draws' steady states
    // were most of the cost of the further rounds (continuous sweep, 160
    // draws: 54 % of the run in the draws' steady states).
    // The replay band of the draws so far and the precision of its scores.
    let precision = |d_replay: &[Amps]| {
        let r = banded(&etas, &c_replay, d_replay);
        let hw = median_rel_halfwidth(&r.amplitude1_low, &r.amplitude1_high, &r.amplitude1);
        let b = band_precision(
            frc,
            &c_replay,
            d_replay,
            n_max,
            hw,
            opts.band_coverage_se,
            opts.seed,
        );
        (r, b)
    };
    let (mut replay, mut band) = precision(&d_replay);
    while d_replay.len() < n_max && !band.reached {
        let (lo, hi) = (d_replay.len(), (2 * d_replay.len()).min(n_max));
        d_replay.extend(replays(&models[lo..hi], &drives[lo..hi]));
        (replay, band) = precision(&d_replay);
    }
    if n_max > 0 && !band.reached {
        let worst = [
            band.coverage_se_amplitude1,
            band.coverage_se_amplitude2,
            band.coverage_strict_se_amplitude1,
            band.coverage_strict_se_amplitude2,
        ]
        .into_iter()
        .flatten()
        .fold(0.0, f64::max);
        warnings.push(crate::warning::Warning::BandImprecise {
            standard_error: worst,
            draws: band.draws,
            target: band.target,
        });
    }
    let (c_steady, c_replay) = (&c_steady, &c_replay);
    let steady = banded(&etas, c_steady, &d_steady);

    let (replay_settled, steady_reached) =
        steady_call(frc, c_replay, c_steady, opts.steady_tolerance);

    // Sensitive steps: ensembles from each step's measured start; a
    // sensitive step's band also holds the ensemble's range.
    let replay_sensitivity = if opts.sensitivity {
        super::sensitive::assess(&model, &sched, frc, &windows, opts)
    } else {
        vec![None; frc.points.len()]
    };
    let replay_sensitive: Vec<Option<bool>> = replay_sensitivity
        .iter()
        .map(|s| s.map(|s| s.sensitive))
        .collect();
    for (i, s) in replay_sensitivity.iter().enumerate() {
        let Some(s) = s.filter(|s| s.sensitive) else {
            continue;
        };
        let widen = |lo: &mut Option<f64>, hi: &mut Option<f64>, (a, b): (f64, f64)| {
            *lo = Some(lo.map_or(a, |l| l.min(a)));
            *hi = Some(hi.map_or(b, |h| h.max(b)));
        };
        widen(
            &mut replay.amplitude1_low[i],
            &mut replay.amplitude1_high[i],
            s.range1,
        );
        widen(
            &mut replay.amplitude2_low[i],
            &mut replay.amplitude2_high[i],
            s.range2,
        );
    }
    let score = score(frc, &steady, &replay, &steady_reached, &replay_sensitive);
    if score.steady_points == 0 {
        warnings.push(crate::warning::Warning::NoSteadyState);
    }
    Ok(Prediction {
        law: model.law,
        contact_stiffness: model.contact_stiffness,
        absorber,
        steady,
        replay,
        steady_reached,
        replay_settled,
        replay_sensitive,
        replay_sensitivity,
        score,
        draws: d_replay.len(),
        steady_band_draws: d_steady.len(),
        band,
        warnings,
    })
}

/// The scores (see [`Score`]).
pub fn score(
    frc: &MeasuredFrc,
    steady: &Predicted,
    replay: &Predicted,
    steady_reached: &[Option<bool>],
    sensitive: &[Option<bool>],
) -> Score {
    let m1: Vec<f64> = frc.points.iter().map(|p| p.amplitude1).collect();
    let m2: Vec<f64> = frc.points.iter().map(|p| p.amplitude2).collect();
    let settled: Vec<usize> = (0..m1.len())
        .filter(|&i| steady_reached[i] == Some(true))
        .collect();
    let pairs = |pred: &[Option<f64>], meas: &[f64], idx: &mut dyn Iterator<Item = usize>| {
        idx.filter_map(|i| pred[i].map(|p| (p, meas[i])))
            .collect::<Vec<_>>()
    };
    let peak = |meas: &[f64], idx: &[usize]| {
        idx.iter()
            .map(|&i| meas[i])
            .fold(f64::NEG_INFINITY, f64::max)
    };
    let s1 = pairs(&steady.amplitude1, &m1, &mut settled.iter().copied());
    let s2 = pairs(&steady.amplitude2, &m2, &mut settled.iter().copied());
    let all: Vec<usize> = (0..m1.len()).collect();
    let r1 = pairs(&replay.amplitude1, &m1, &mut all.iter().copied());
    let r2 = pairs(&replay.amplitude2, &m2, &mut all.iter().copied());
    let nrms = |r: Option<f64>, pk: f64| r.filter(|_| pk > 0.0).map(|r| r / pk);
    let robust: Vec<usize> = (0..m1.len())
        .filter(|&i| sensitive.get(i).copied().flatten() != Some(true))
        .collect();
    let rr1 = pairs(&replay.amplitude1, &m1, &mut robust.iter().copied());
    let rr2 = pairs(&replay.amplitude2, &m2, &mut robust.iter().copied());
    let (pk1s, pk2s) = (peak(&m1, &settled), peak(&m2, &settled));
    let (pk1, pk2) = (peak(&m1, &all), peak(&m2, &all));
    let argmax = |v: &mut dyn Iterator<Item = (usize, f64)>| {
        v.fold(None, |b: Option<(usize, f64)>, (i, x)| match b {
            Some((_, bx)) if bx >= x => b,
            _ => Some((i, x)),
        })
        .map(|(i, _)| i)
    };
    let pm = argmax(&mut settled.iter().map(|&i| (i, m1[i])));
    let pp = argmax(
        &mut settled
            .iter()
            .filter_map(|&i| steady.amplitude1[i].map(|a| (i, a))),
    );
    let eta = |i: usize| frc.points[i].eta;
    let u1: Vec<f64> = frc.points.iter().map(|p| p.amplitude1_u).collect();
    let u2: Vec<f64> = frc.points.iter().map(|p| p.amplitude2_u).collect();
    Score {
        rms_amplitude1: rms(&s1),
        rms_amplitude2: rms(&s2),
        nrms_amplitude1: nrms(rms(&s1), pk1s),
        nrms_amplitude2: nrms(rms(&s2), pk2s),
        peak_eta_error: match (pp, pm) {
            (Some(a), Some(b)) => Some(eta(a) - eta(b)),
            _ => None,
        },
        replay_nrms_amplitude1: nrms(rms(&r1), pk1),
        replay_nrms_amplitude2: nrms(rms(&r2), pk2),
        replay_nrms_robust_amplitude1: nrms(rms(&rr1), peak(&m1, &robust)),
        replay_nrms_robust_amplitude2: nrms(rms(&rr2), peak(&m2, &robust)),
        replay_coverage_amplitude1: coverage(
            &replay.amplitude1_low,
            &replay.amplitude1_high,
            &m1,
            Some(&u1),
        ),
        replay_coverage_amplitude2: coverage(
            &replay.amplitude2_low,
            &replay.amplitude2_high,
            &m2,
            Some(&u2),
        ),
        replay_coverage_strict_amplitude1: coverage(
            &replay.amplitude1_low,
            &replay.amplitude1_high,
            &m1,
            None,
        ),
        replay_coverage_strict_amplitude2: coverage(
            &replay.amplitude2_low,
            &replay.amplitude2_high,
            &m2,
            None,
        ),
        band_median_rel_halfwidth1: median_rel_halfwidth(
            &replay.amplitude1_low,
            &replay.amplitude1_high,
            &replay.amplitude1,
        ),
        steady_points: settled.len(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The replay stops with the segment that holds the last window's end:
    /// a tail after it is not simulated, and the amplitudes of the windows
    /// are bit-identical to a replay of the whole schedule.
    #[test]
    fn replay_skips_the_tail_after_the_last_window() {
        let dwell = |eta, duration| Segment::Dwell { eta, duration };
        let sched = Schedule {
            segments: vec![dwell(0.8, 300.0), dwell(1.0, 300.0), dwell(1.2, 3000.0)],
            phase: 0.0,
            amplitude: 1.0,
        };
        let windows = vec![(200.0, 290.0, 0.2), (500.0, 590.0, 0.2)];
        let cut = shown_part(&sched, &windows);
        assert_eq!(cut.segments, sched.segments[..2].to_vec());
        // A window ending inside the last segment keeps everything.
        assert_eq!(shown_part(&sched, &[(0.0, 700.0, 1.0)]).segments.len(), 3);
        let model = Model {
            absorber: Absorber::default(),
            law: Law::coulomb(0.4),
            stop_below: None,
            contact_stiffness: None,
        };
        let opts = PredictOptions::default();
        let whole = {
            let mut obs = Windows::new(windows.clone());
            run_schedule(&model, &sched, Init::rest(), opts.numeric, &mut obs).unwrap();
            obs.amplitudes()
        };
        assert_eq!(replay_one(&model, &sched, &windows, &opts), whole);
        assert!(whole.iter().all(Option::is_some));
    }

    /// The Hermite extremum of samples of a cosine is its true maximum to
    /// the interpolation error O(h⁴).
    #[test]
    fn hermite_extremum_of_a_cosine() {
        let (t0, t1) = (-0.1, 0.15);
        let e = hermite_extremes(t0, t0.cos(), -t0.sin(), t1, t1.cos(), -t1.sin());
        let v = e.into_iter().flatten().fold(f64::NEG_INFINITY, f64::max);
        assert!((v - 1.0).abs() < 1e-5, "{v}");
        // No interior extremum on a monotone piece.
        let (t0, t1) = (0.2, 0.4);
        let e = hermite_extremes(t0, t0.cos(), -t0.sin(), t1, t1.cos(), -t1.sin());
        assert!(e.iter().all(|x| x.is_none()), "{e:?}");
    }

    /// Percentiles interpolate linearly between order statistics.
    #[test]
    fn percentiles() {
        let v = [1.0, 2.0, 3.0, 4.0, 5.0];
        assert_eq!(quantile_sorted(&v, 0.5), 3.0);
        assert_eq!(quantile_sorted(&v, 0.0), 1.0);
        assert_eq!(quantile_sorted(&v, 1.0), 5.0);
        assert!((quantile_sorted(&v, 0.025) - 1.1).abs() < 1e-12);
    }
}

#[cfg(test)]
mod replay_tests {
    use super::*;
    use crate::sim::sweep::steady_state;

    /// A long dwell replayed through a schedule settles on the steady state
    /// found by the steady-state solver (independent paths: schedule +
    /// sampled windows with Hermite extremes vs shooting with exact
    /// extremes). Coulomb ρs = 0.375 at η = 0.6 and ρs = 0.3 at η = 0.45;
    /// D = 0.05 so 400 periods leave no measurable transient.
    #[test]
    fn long_dwell_replay_equals_steady_state() {
        for (eta, rho) in [(0.6, 0.375), (0.45, 0.3)] {
            let model = Model {
                absorber: Absorber {
                    damping: 0.05,
                    ..Absorber::default()
                },
                law: Law::coulomb(rho),
                stop_below: None,
                contact_stiffness: None,
            };
            let t = 2.0 * PI / eta;
            let sched = Schedule {
                segments: vec![Segment::Dwell {
                    eta,
                    duration: 400.0 * t,
                }],
                phase: 0.3,
                amplitude: 1.0,
            };
            // 200 samples per period: the cubic Hermite error bound of a
            // smooth extremum, (2π/200)⁴/384 ≈ 2.5e-9 relative.
            let windows = vec![(395.0 * t, 400.0 * t, t / 200.0)];
            let opts = PredictOptions::default();
            let r = replay_one(&model, &sched, &windows, &opts)[0].unwrap();
            let (p, _) = steady_state(&model, eta, Init::rest(), &opts.steady).unwrap();
            let (s1, s2) = (p.amplitude1.unwrap(), p.amplitude2.unwrap());
            assert!(
                (r.0 - s1).abs() < 1e-8 * s1,
                "η {eta}: A1 replay {} vs steady {s1}",
                r.0
            );
            assert!(
                (r.1 - s2).abs() < 1e-8 * s2.max(1.0),
                "η {eta}: A2 replay {} vs steady {s2}",
                r.1
            );
        }
    }

    /// The split-normal draws reproduce the interval ends as their 2.5 and
    /// 97.5 % points.
    #[test]
    fn split_normal_quantiles() {
        let mut rng = Rng::new(7);
        let mut v: Vec<f64> = (0..40_000)
            .map(|_| split_normal(&mut rng, 1.0, Some((0.9, 1.3))))
            .collect();
        v.sort_by(f64::total_cmp);
        let (lo, hi) = (quantile_sorted(&v, 0.025), quantile_sorted(&v, 0.975));
        assert!(
            (lo - 0.9).abs() < 0.01 && (hi - 1.3).abs() < 0.01,
            "{lo} {hi}"
        );
    }
}
