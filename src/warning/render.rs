//! The messages users read: [`Warning`]'s `Display` (what JSON's
//! `warnings` holds), one arm per variant with its numbers, in one
//! function per family of warnings.

use super::*;
use std::fmt;

impl fmt::Display for Warning {
    /// Hands the warning to the renderer of its family. This match is
    /// exhaustive, so a new variant must be given a family here; each
    /// family's renderer matches only the variants routed to it.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        use Warning::*;
        match self {
            MapIgnored
            | ChannelAbsent { .. }
            | NoAccelerometer
            | NoVelocityChannel
            | ChannelEmpty { .. }
            | ChannelNoMessages { .. }
            | ChannelNulls { .. }
            | UnknownTopic { .. }
            | UnitAssumed { .. }
            | UnfinishedSegment { .. }
            | MixedSampleIntervals { .. }
            | SampleRateMismatch { .. } => fmt_ingest(self, f),
            Clipped { .. }
            | VelocityDrift { .. }
            | VelocityGain { .. }
            | AccelerationGain { .. }
            | ChannelDelay { .. }
            | VelocityLag { .. }
            | AccelerationLag { .. } => fmt_sensor(self, f),
            VelocityDerived { .. }
            | AccelerationFilled { .. }
            | VelocityDistrusted { .. }
            | SliderHeld { .. }
            | RoughCost { .. }
            | FewSlipSamples { .. }
            | LawNotFitted { .. }
            | NoSimpleLaw { .. }
            | NeverSticks
            | NoBreakaway
            | PositionDelays { .. } => fmt_identify(self, f),
            RefinementFailed { .. }
            | StribeckFailed { .. }
            | ShortSticks { .. }
            | BoundsContradict { .. }
            | LawChanged { .. }
            | ThresholdNotIdentified { .. }
            | DropNotResolved { .. }
            | StribeckUnconfirmed { .. }
            | VelocityScaleUnresolved { .. }
            | NestedCoulomb { .. }
            | PadRefinementFailed { .. }
            | DirectionDependent { .. }
            | LevelsByDirection { .. }
            | DirectionBounded { .. }
            | ContactCompliance { .. }
            | NonlinearSpring { .. }
            | Untested { .. }
            | Inadequate { .. } => fmt_refinement(self, f),
            NormalForceNegative { .. }
            | NormalForceZero
            | DriveAmplitude { .. }
            | DriveFrequency { .. }
            | BiasUnknown => fmt_rig(self, f),
            SweepDriveAmplitude { .. }
            | StepUnmeasured { .. }
            | StepTooShort { .. }
            | StepFewSamples { .. }
            | DriveShape { .. }
            | SweepRigMismatch { .. }
            | InvalidDraws { .. }
            | BandImprecise { .. }
            | NoSteadyState => fmt_validate(self, f),
            RecommendationAtEdge
            | NoCliff { .. }
            | NoRecommendation { .. }
            | MissingSteadyStates { .. }
            | BatchDriveAmplitude { .. }
            | LogNormalForceZero { .. }
            | NoStaticInformation { .. }
            | NoSlidingLevel { .. }
            | NormalForceNotPositive { .. }
            | EmptyStaticBounds { .. }
            | EstimatesDisagree { .. }
            | BatchPadNotSimulated { .. }
            | BatchPadScatter { .. }
            | Conflict { .. }
            | UnresolvedConflict { .. }
            | ConflictSetAside { .. }
            | FewStaticPoints { .. }
            | Intercept { .. }
            | MuDAboveMuS { .. }
            | CensoredDisagrees { .. }
            | BatchRigMismatch { .. } => fmt_batch(self, f),
            DuplicateFile { .. } | DuplicateTest { .. } | SameRecord { .. } => {
                fmt_pipeline(self, f)
            }
        }
    }
}

/// Renders an ingest warning (reading a log: options, absent or empty
/// channels, units, TDMS segments, sample intervals).
fn fmt_ingest(w: &Warning, f: &mut fmt::Formatter<'_>) -> fmt::Result {
    use Warning::*;
    match w {
        MapIgnored => f.write_str("--map applies to CSV, TDMS and MAT logs only; ignored"),
        ChannelAbsent { channel } => write!(f, "no {channel} channel"),
        NoAccelerometer => f.write_str(
            "no accelerometer channel (a2): acceleration must be derived from velocity",
        ),
        NoVelocityChannel => f.write_str(
            "no velocity channel (v2): identification derives the velocity of M2 from x2",
        ),
        ChannelEmpty { label } => {
            write!(f, "channel {label} has no valid sample; treated as absent")
        }
        ChannelNoMessages { topic, quantity } => {
            write!(f, "channel {topic} ({quantity}) has no messages")
        }
        ChannelNulls {
            channel,
            nulls,
            samples,
        } => write!(f, "channel {channel} is null in {nulls} of {samples} samples"),
        UnknownTopic { topic } => write!(f, "ignored unknown topic {topic}"),
        UnitAssumed { topic, unit } => {
            write!(f, "channel {topic} states no unit; {unit} assumed")
        }
        UnfinishedSegment { byte, ignored } => write!(
            f,
            "the last TDMS segment (at byte {byte}) was not finished by its writer: {ignored} bytes of an incomplete chunk ignored"
        ),
        MixedSampleIntervals {
            topic,
            min_ns,
            max_ns,
            nominal_ns,
        } => write!(
            f,
            "channel {topic}: buffers use different sample intervals ({min_ns}..{max_ns} ns); {nominal_ns} ns taken as nominal"
        ),
        SampleRateMismatch {
            topic,
            rate_hz,
            dt_ns,
        } => write!(
            f,
            "channel {}: sample_rate_hz {} disagrees with dt_ns {} ({} Hz); dt_ns used",
            topic,
            rate_hz,
            dt_ns,
            1.0 / (*dt_ns as f64 * 1e-9)
        ),
        _ => unreachable!("not an ingest warning: {}", w.code()),
    }
}

/// Renders a sensor warning (checking the sensors: clipped channels,
/// velocity drift and gain, channel delays).
fn fmt_sensor(w: &Warning, f: &mut fmt::Formatter<'_>) -> fmt::Result {
    use Warning::*;
    match w {
        Clipped {
            channel,
            high,
            level,
            unit,
            fraction,
            samples,
            runs,
        } => write!(
            f,
            "clipped: {} flat at its {} ({:.4e} {}) in {:.1} % of the samples ({} samples in {} runs): saturated sensor or DAQ input; those samples are left out of every fit",
            channel,
            if *high { "maximum" } else { "minimum" },
            level,
            unit,
            100.0 * fraction,
            samples,
            runs
        ),
        VelocityDrift {
            drift_m_per_s2: drift,
            span_s: span,
            half_width_m_per_s2: half,
        } => write!(
            f,
            "velocity channel v2: its offset drifts by {:.3} mm/s over the log ({:.4} ± {:.4} mm/s per s against d/dt x2); removed",
            drift * span * 1e3,
            drift * 1e3,
            half * 1e3
        ),
        // Written before the correction existed (a fit artifact): v2 was
        // not rescaled then.
        VelocityGain { gain, tolerance, .. } if *tolerance == 0.0 => write!(
            f,
            "velocity channel v2: its gain is {gain:.3} times that of d/dt x2; not corrected (x2 sets the scale)"
        ),
        VelocityGain {
            gain,
            half_width,
            tolerance,
        } => write!(
            f,
            "velocity channel v2: its gain is {gain:.4} ± {half_width:.4} times that of d/dt x2 (more than {:.0} % off); v2 divided by it (x2 sets the scale)",
            tolerance * 100.0
        ),
        AccelerationGain {
            gain,
            half_width,
            tolerance,
        } => write!(
            f,
            "accelerometer a2: its gain is {gain:.4} ± {half_width:.4} times that of d²/dt² x2 (more than {:.0} % off); a2 divided by it (x2 sets the scale)",
            tolerance * 100.0
        ),
        ChannelDelay {
            channel,
            shift_s: est,
            interval_s: (lo, hi),
            declared_s,
        } => write!(
            f,
            "channel {} {} x1 by {:.2} ms (95 % interval of its shift {:.2} to {:.2} ms){}; corrected",
            channel,
            if *est < 0.0 { "lags" } else { "leads" },
            est.abs() * 1e3,
            lo * 1e3,
            hi * 1e3,
            if *declared_s != 0.0 {
                format!(" beyond the declared shift_s {:.2} ms", declared_s * 1e3)
            } else {
                String::new()
            }
        ),
        VelocityLag { lag_s } => write!(
            f,
            "velocity channel lags the position x2 by {:.2} ms; corrected",
            lag_s * 1e3
        ),
        AccelerationLag { lag_s } => write!(
            f,
            "acceleration channel lags the velocity by {:.2} ms; corrected",
            lag_s * 1e3
        ),
        _ => unreachable!("not a sensor warning: {}", w.code()),
    }
}

/// Renders an identification warning (preparing the signals and choosing
/// the law: derived velocity, stick and slip, law choice, position delays).
fn fmt_identify(w: &Warning, f: &mut fmt::Formatter<'_>) -> fmt::Result {
    use Warning::*;
    match w {
        VelocityDerived { half_window: half } => write!(
            f,
            "no velocity channel: ẋ2 derived from x2 (Savitzky–Golay derivative over ±{half} samples); its noise sets the stick detection threshold"
        ),
        AccelerationFilled { samples } => write!(
            f,
            "{samples} samples without accelerometer data use the differentiated velocity"
        ),
        VelocityDistrusted { why } => write!(
            f,
            "{why}: the velocity channel is distrusted; stick, slip and ẋ2 come from x2"
        ),
        SliderHeld {
            kt_n_per_m,
            x2_range_m,
            force_amplitude_n,
        } => write!(
            f,
            "M2 rode on a contact spring (kt {kt_n_per_m:.0} N/m; x2 moved {:.0} µm, the contact force in proportion) and the slider never broke away: reported as stuck behind a compliant contact (Rs ≥ {force_amplitude_n:.3} N, the contact force's amplitude)",
            x2_range_m * 1e6
        ),
        RoughCost { secant_ratio } => write!(
            f,
            "the fit's cost is not smooth at the scale of its intervals (short sticks switch with the parameters): widths from secants over the intervals stray from the tangent's by up to ×{secant_ratio:.2}; each interval is the widest of them"
        ),
        FewSlipSamples { samples } => write!(
            f,
            "M2 slid in only {samples} usable samples: reported as stuck"
        ),
        LawNotFitted { law } => write!(
            f,
            "law {} could not be fitted to this log; chose by BIC instead",
            law.as_str()
        ),
        NoSimpleLaw {
            stribeck_velocity_m_per_s: vs,
            best,
        } => write!(
            f,
            "none of the simple laws fits: residuals are structured (Stribeck-like peak near zero velocity, v_s = {:.2} mm/s); best simple law {}",
            vs.unwrap_or(f64::NAN) * 1e3,
            best.as_str()
        ),
        NeverSticks => f.write_str(
            "M2 never sticks in this log: the static threshold is only bounded (rho_s_interval holds the bounds)",
        ),
        NoBreakaway => f.write_str("no stick → slip transition could be located"),
        PositionDelays {
            x1_s: d1,
            x1_interval_s: i1,
            x2_s: d2,
            x2_interval_s: i2,
            delta_bic,
        } => {
            write!(
                f,
                "position records lag the drive: x1 by {:.3} ms [{:.3}, {:.3}], x2 by {:.3} ms [{:.3}, {:.3}] ",
                d1 * 1e3, i1.0 * 1e3, i1.1 * 1e3, d2 * 1e3, i2.0 * 1e3, i2.1 * 1e3
            )?;
            match delta_bic {
                None => f.write_str("(fitted with the law: without these lags it does not explain the log"),
                Some(d) => write!(
                    f,
                    "(fitted with the law: without them its residuals follow the velocity or the drive phase, and the lags lower the BIC by {d:.0}"
                ),
            }?;
            f.write_str("; a sensor filter at f_c lags by about 1/(2π·f_c))")
        }
        _ => unreachable!("not an identification warning: {}", w.code()),
    }
}

/// Renders a refinement warning (refining the law and testing its adequacy:
/// output-error and Stribeck refinement, short sticks, bounds, parsimony,
/// adequacy).
fn fmt_refinement(w: &Warning, f: &mut fmt::Formatter<'_>) -> fmt::Result {
    use Warning::*;
    match w {
        RefinementFailed { reason } => write!(
            f,
            "output-error refinement not possible ({reason}); the equation-error estimate is used"
        ),
        StribeckFailed { reason } => write!(
            f,
            "the Stribeck family could not be refined ({reason}); the best simple law is kept"
        ),
        ShortSticks {
            law,
            stick_fraction,
            stick_runs,
            run_s,
        } => write!(
            f,
            "the velocity shows no stick, but the output-error law ({}) sticks {:.1} % of the time in {} phases of about {:.0} ms (short sticks at reversal): ρs is measured, not bounded",
            law.as_str(),
            100.0 * stick_fraction,
            stick_runs,
            run_s * 1e3
        ),
        BoundsContradict {
            upper_n: ub,
            lower_n: lo,
            output_error,
        } => {
            write!(
                f,
                "the never-sticks bounds contradict each other: the reversal forces bound Rs above by {ub:.4} N, the sliding level below by {lo:.4} N"
            )?;
            if *output_error {
                f.write_str("; no stick-free law explains this log")?;
            }
            Ok(())
        }
        LawChanged {
            output_error,
            equation_error,
        } => write!(
            f,
            "the output-error refinement chose the law {} (equation error: {})",
            output_error.as_str(),
            equation_error.as_str()
        ),
        ThresholdNotIdentified {
            other,
            delta_bic,
            other_rs_n,
            interval_n: (lo, hi),
        } => write!(
            f,
            "this log does not identify the breakaway threshold: the {} law explains it almost as well (ΔBIC {delta_bic:.1}) with Rs {other_rs_n:.4} N, outside the chosen law's interval [{lo:.4}, {hi:.4}] N; the Rs interval is widened to hold it",
            other.as_str()
        ),
        StribeckUnconfirmed {
            delta_bic,
            rs_n,
            rs_interval_n,
            rd_n,
            rd_interval_n,
            vs_m_per_s,
            kappa,
            kappa_interval,
            own_rs_interval_n,
            own_kappa_interval,
            rs_not_identified,
            kappa_not_identified,
        } => {
            let iv = |i: &Option<(f64, f64)>, p: usize| {
                i.map_or(String::new(), |(a, b)| format!(" [{a:.p$}, {b:.p$}]"))
            };
            let own = [
                own_rs_interval_n.map(|_| format!("Rs{} N", iv(own_rs_interval_n, 4))),
                own_kappa_interval.map(|_| format!("κ{}", iv(own_kappa_interval, 2))),
            ]
            .into_iter()
            .flatten()
            .collect::<Vec<_>>()
            .join(", ");
            let own = if own.is_empty() {
                own
            } else {
                format!(" (its own: {own})")
            };
            let vs = vs_m_per_s.map_or(String::new(), |v| format!(", v_s {:.3} mm/s", v * 1e3));
            let k = kappa.map_or(String::new(), |k| {
                format!(", κ {k:.2}{}", iv(kappa_interval, 2))
            });
            write!(
                f,
                "the positions are explained better by a Stribeck law behind the contact (ΔBIC {delta_bic:.1}: Rs {rs_n:.4} N{}, Rd {rd_n:.4} N{}{vs}{k}), but the log has no accelerometer to confirm it (a position sensor's filter leaves x2 the same residuals); the chosen law is kept and its Rs, Rd and κ intervals{own} are widened to hold both readings",
                iv(rs_interval_n, 4),
                iv(rd_interval_n, 4)
            )?;
            let (which, its) = match (rs_not_identified, kappa_not_identified) {
                (true, true) => ("Rs and κ", "their intervals"),
                (true, false) => ("Rs", "its interval"),
                (false, true) => ("κ", "its interval"),
                (false, false) => return Ok(()),
            };
            write!(
                f,
                "; the readings disagree on {which} beyond their intervals: this log does not identify {which}, reported as {its} only"
            )
        }
        DropNotResolved {
            vs_m_per_s,
            vs_admitted_m_per_s,
            delta_bic,
            other_rs_n,
            interval_n: (lo, hi),
            low_n,
        } => write!(
            f,
            "this log does not identify the breakaway threshold: a Stribeck drop within a few samples of breakaway (v_s {:.3} mm/s; the criterion admits v_s up to {:.3} mm/s) explains it {} (ΔBIC {delta_bic:.1}) with Rs {other_rs_n:.4} N, below the chosen law's interval [{lo:.4}, {hi:.4}] N; the Rs interval is widened down to {low_n:.4} N",
            vs_m_per_s * 1e3,
            vs_admitted_m_per_s * 1e3,
            if *delta_bic < 0.0 { "better" } else { "almost as well" }
        ),
        VelocityScaleUnresolved {
            law,
            vs_m_per_s,
            resolution_m_per_s,
        } => write!(
            f,
            "the {} law's velocity scale v_s = {vs_m_per_s:.2e} m/s is below what this log resolves (the slider gains {resolution_m_per_s:.2e} m/s within one sample after breakaway): its drop is a step to the data, so v_s is not identified and the law acts as a step from Rs to Rd",
            law.as_str()
        ),
        PadRefinementFailed { reason } => write!(
            f,
            "a real-pad extension could not be refined ({reason}); the law without it is kept"
        ),
        DirectionDependent {
            split_n,
            interval_n,
        } => write!(
            f,
            "the static threshold depends on the sliding direction: Rs⁺ − Rs⁻ = {:.4} N [{:.4}, {:.4}] with equal dynamic levels; \
             with unknown sensor zero offsets only this difference of the drops Rs − Rd is identified \
             (shifting one direction's levels against the other's is an x2 offset): calibrate the zeros to split the levels",
            split_n, interval_n.0, interval_n.1
        ),
        LevelsByDirection {
            zero_uncertainty_m,
            rd_split_n,
            interval_n,
            levels_n,
        } => {
            write!(
                f,
                "the friction levels depend on the sliding direction (position zeros calibrated to ±{:.1} µm): ",
                zero_uncertainty_m * 1e6
            )?;
            for (i, (name, v)) in ["Rs⁺", "Rd⁺", "Rs⁻", "Rd⁻"].iter().zip(levels_n).enumerate() {
                let sep = if i == 0 { "" } else { ", " };
                match v {
                    Some(v) => write!(f, "{sep}{name} {v:.4}")?,
                    None => write!(f, "{sep}{name} only bounded")?,
                }
            }
            write!(
                f,
                " N; Rd⁺ − Rd⁻ = {rd_split_n:.4} N [{:.4}, {:.4}]",
                interval_n.0, interval_n.1
            )
        }
        DirectionBounded { side, bounds_n } => {
            write!(
                f,
                "the static threshold depends on the sliding direction: M2 sticks and breaks away towards the other side only, \
                 and reverses towards {side} without sticking, so the threshold there is only bounded: "
            )?;
            match bounds_n {
                Some((lo, hi)) => write!(
                    f,
                    "{lo:.4}–{hi:.4} N (null value, the interval holds the bounds)"
                ),
                None => write!(f, "the bounds contradict each other (no interval)"),
            }
        }
        ContactCompliance {
            kappa,
            interval,
            kt_n_per_m,
            presliding_m,
            threshold_unresolved,
        } => write!(
            f,
            "the contact is compliant (pre-sliding): κ = kt/K2 = {:.3} [{:.3}, {:.3}], kt = {:.0} N/m, up to {:.1} µm before sliding{}",
            kappa,
            interval.0,
            interval.1,
            kt_n_per_m,
            presliding_m * 1e6,
            if *threshold_unresolved {
                "; behind it the static threshold shows only as the extra deflection (Rs − Rd)/kt before each breakaway, \
                 which this log does not resolve: Rs ≥ Rd only (rho_s null; its interval holds the bounds the log admits, \
                 and κ's interval every admitted threshold)"
            } else {
                ""
            }
        ),
        NonlinearSpring {
            change,
            interval,
            z,
            max_stretch_m,
        } => write!(
            f,
            "the coupling spring is not linear: by M1's equation of motion (friction-free) its stiffness changes by {:+.1} % [{:+.1}, {:+.1}] (z {:.1}) at the largest stretch x1 − x2 of {:.3} mm; \
             the model's springs are linear, so the fitted law absorbs the difference (adequate: false)",
            100.0 * change,
            100.0 * interval.0,
            100.0 * interval.1,
            z,
            max_stretch_m * 1e3
        ),
        NestedCoulomb { law } => write!(
            f,
            "the {} family's extra parameter is consistent with Coulomb friction (its 95 % interval holds the nested value): Coulomb chosen",
            law.as_str()
        ),
        Untested { law } => write!(
            f,
            "adequacy not tested: the {} law is the equation-error estimate, not checked against the positions (adequate: false); its intervals carry no model error",
            law.as_str()
        ),
        Inadequate {
            law,
            noise_ratio,
            force_ratio,
            max_noise_ratio,
            worst,
            inflation,
        } => {
            let worst = worst.map_or(String::new(), |st| {
                format!(
                    "; largest structure: {} residuals against {}, {:.2} of the noise (χ²/dof {:.1}, z {:.1})",
                    st.channel, st.against, st.effect, st.chi2_per_dof, st.z
                )
            });
            write!(
                f,
                "the law {} does not explain the log down to its sensor noise: residual/noise x1 {:.2}, x2 {:.2}{} (adequate: ≤ {:.1}){worst}; the statistical intervals are widened ×{:.2}",
                law.as_str(),
                noise_ratio.0,
                noise_ratio.1,
                force_ratio.map_or(String::new(), |r| format!(", force {r:.2}")),
                max_noise_ratio,
                inflation
            )
        }
        _ => unreachable!("not a refinement warning: {}", w.code()),
    }
}

/// Renders a rig warning (the rig's normal force and drive as the
/// identification measures them).
fn fmt_rig(w: &Warning, f: &mut fmt::Formatter<'_>) -> fmt::Result {
    use Warning::*;
    match w {
        NormalForceNegative { normal_force_n } => write!(
            f,
            "the normal force is negative ({normal_force_n} N): a sign or unit mistake in the log? Friction coefficients from it would be meaningless (batch refuses it)"
        ),
        NormalForceZero => f.write_str(
            "the normal force is zero: the friction member may be off; no friction coefficient (μ) can be formed",
        ),
        DriveAmplitude {
            measured_m,
            nominal_m,
        } => write!(
            f,
            "measured drive amplitude {:.4} mm differs from the nominal {:.4} mm by {:+.1} %; ρ uses the measured one",
            measured_m * 1e3,
            nominal_m * 1e3,
            (measured_m / nominal_m - 1.0) * 100.0
        ),
        DriveFrequency {
            metadata_hz: meta,
            measured_hz: measured,
            tolerance,
        } => write!(
            f,
            "the metadata's drive frequency {meta} Hz contradicts the measured {measured:.4} Hz (by {:+.1} %, more than {} %); η and the fit use the measured one",
            (meta / measured - 1.0) * 100.0,
            tolerance * 100.0
        ),
        BiasUnknown => f.write_str(
            "force bias unknown (M2 never slid): R includes the sensors' offsets",
        ),
        _ => unreachable!("not a rig warning: {}", w.code()),
    }
}

/// Renders a validation warning (sweep drive, skipped steps, rig
/// mismatch, replay band, steady states).
fn fmt_validate(w: &Warning, f: &mut fmt::Formatter<'_>) -> fmt::Result {
    use Warning::*;
    match w {
        SweepDriveAmplitude {
            measured_m,
            nominal_m,
        } => write!(
            f,
            "measured drive amplitude {:.4} mm differs from the nominal {:.4} mm by {:+.1} %; A_i/A uses the measured one",
            measured_m * 1e3,
            nominal_m * 1e3,
            (measured_m / nominal_m - 1.0) * 100.0
        ),
        StepUnmeasured { step, frequency_hz } => write!(
            f,
            "step {step} ({frequency_hz} Hz): the drive channel has too few samples to measure it"
        ),
        StepTooShort { step, frequency_hz } => write!(
            f,
            "step {step} ({frequency_hz:.3} Hz): the hold is shorter than one drive period"
        ),
        StepFewSamples {
            step,
            frequency_hz,
            window_s,
        } => write!(
            f,
            "step {} ({:.3} Hz): x1/x2 have too few samples in the window {:.2}-{:.2} s",
            step, frequency_hz, window_s.0, window_s.1
        ),
        DriveShape { rms_m } => write!(
            f,
            "the drive signal departs from a slowly swept sinusoid (residual {:.1} µm RMS): the measured frequency plan may be off",
            rms_m * 1e6
        ),
        SweepRigMismatch {
            constant,
            characteristic,
            sweep,
        } => write!(
            f,
            "rig constant {constant} differs between the characteristic log ({characteristic}) and the sweep ({sweep}): are they from the same rig?"
        ),
        InvalidDraws { invalid, draws } => {
            write!(f, "{invalid} of {draws} drawn laws were invalid and skipped")
        }
        BandImprecise {
            standard_error,
            draws,
            target,
        } => write!(
            f,
            "the replay band's coverages are known to ±{:.1} percentage points (bootstrap standard error over {} drawn laws), more than the target ±{:.1}: draw more laws (--samples) for a more precise band",
            100.0 * standard_error,
            draws,
            100.0 * target
        ),
        NoSteadyState => f.write_str(
            "no step reached its steady state: the steady-state scores are null",
        ),
        _ => unreachable!("not a validation warning: {}", w.code()),
    }
}

/// Renders a batch warning (the recommendation, per-log exclusions,
/// conflicts, the μ fits).
fn fmt_batch(w: &Warning, f: &mut fmt::Formatter<'_>) -> fmt::Result {
    use Warning::*;
    match w {
        RecommendationAtEdge => f.write_str(
            "the recommendation lies at the edge of the candidates whose box fits the grid: widen --rho-min/--rho-max",
        ),
        NoCliff { threshold, rho_min } => write!(
            f,
            "no cliff found: W stays below twice the recommendation's ({threshold:.3}) down to ρs = {rho_min}"
        ),
        NoRecommendation { reason } => write!(f, "no normal force recommended: {reason}"),
        MissingSteadyStates { missing } => write!(
            f,
            "{missing} steady states without amplitude (interrupted or resonant) were left out of the worst case"
        ),
        BatchDriveAmplitude { measured_m, used_m } => write!(
            f,
            "the logs' median measured drive amplitude {:.4} mm differs from the amplitude used for ρ ({:.4} mm) by more than 3 %",
            measured_m * 1e3,
            used_m * 1e3
        ),
        LogNormalForceZero { log } => write!(
            f,
            "{}: the normal force is zero (the friction member may be off): its μ is null",
            log.display()
        ),
        NoStaticInformation { log } => write!(
            f,
            "{}: no usable static-friction information (no estimate, bound or interval)",
            log.display()
        ),
        NoSlidingLevel { log } => write!(
            f,
            "{}: no usable sliding level with an interval: left out of μd",
            log.display()
        ),
        NormalForceNotPositive {
            log,
            normal_force_n: n,
        } => write!(
            f,
            "{}: measured normal force {n} N is not positive: left out of the fits",
            log.display()
        ),
        EmptyStaticBounds { log, low_n, high_n } => write!(
            f,
            "{}: static-friction bounds are empty ({low_n:.4} N ≥ {high_n:.4} N): the log contradicts its own never-sticks call; left out of μs",
            log.display()
        ),
        BatchPadNotSimulated {
            extension,
            chosen,
            eligible,
            value,
        } => write!(
            f,
            "{chosen} of {eligible} logs that slid chose {extension} (combined {value:.4}); fewer than half: the worst cases simulate the pad without it"
        ),
        BatchPadScatter {
            extension,
            model,
            chi2_per_dof,
            dof,
            range,
            value,
            interval,
        } => write!(
            f,
            "{extension}: the logs' values ({:.4} to {:.4}) scatter beyond their intervals about {model} (χ²/dof {chi2_per_dof:.2} on {dof} degrees of freedom, above χ²'s 99 % point {:.2}); the worst cases simulate {value:.4} with its 95 % interval widened to [{:.4}, {:.4}]: something the logs do not record (wear, temperature, settling of the contact) differs between them, or one log is off",
            range.0,
            range.1,
            crate::stats::chi_squared_quantile(0.99, *dof as f64) / *dof as f64,
            interval.0,
            interval.1
        ),
        EstimatesDisagree { log, quantity: q, z } => write!(
            f,
            "{}: its equation-error and output-error {q} differ by {z:.1}σ: the log's {q} is in doubt",
            log.display()
        ),
        Conflict { what } => write!(f, "conflict: {what}"),
        UnresolvedConflict { quantity: sym } => write!(
            f,
            "{sym}: the logs contradict each other and the data do not say which log is off: {sym} uses every log, its interval widened by their scatter"
        ),
        ConflictSetAside {
            quantity: sym,
            robust,
            all,
        } => write!(
            f,
            "{sym}: {:.4}, 95 % [{:.4}, {:.4}] without the conflicting log(s); {:.4}, 95 % [{:.4}, {:.4}] with every log",
            robust.0, robust.1, robust.2, all.0, all.1, all.2
        ),
        FewStaticPoints { points } => write!(
            f,
            "μs rests on {points} measured log(s) (the others only bound it): its interval is wide"
        ),
        Intercept {
            quantity: name,
            intercept_n: a,
            half_width_n: hw,
        } => write!(
            f,
            "{name}: the free fit's intercept {a:.4} N is significant (95 % half-width {hw:.4} N): the forces are not proportional to the measured normal force (normal-force offset?)"
        ),
        MuDAboveMuS { mu_d, mu_s } => write!(
            f,
            "μd = {mu_d:.4} exceeds μs = {mu_s:.4}: the recommendation uses ρd = ρs"
        ),
        CensoredDisagrees { log, interval } => write!(
            f,
            "{}: its bound on Rs disagrees with the fitted μs interval [{:.4}, {:.4}]",
            log.display(),
            interval.0,
            interval.1
        ),
        BatchRigMismatch {
            constant,
            log,
            value,
            reference_log,
            reference,
        } => write!(
            f,
            "rig constant {constant} of {} ({value}) differs from {} ({reference}): a batch should be one pad on one rig",
            log.display(),
            reference_log.display()
        ),
        _ => unreachable!("not a batch warning: {}", w.code()),
    }
}

/// Renders a pipeline warning (the pipeline's file checks: duplicate files
/// and tests, shared rig records).
fn fmt_pipeline(w: &Warning, f: &mut fmt::Formatter<'_>) -> fmt::Result {
    use Warning::*;
    match w {
        DuplicateFile { log } => write!(f, "{} is given twice: counted once", log.display()),
        DuplicateTest {
            log,
            of,
            recorded_at,
        } => write!(
            f,
            "{} is the same test as {} (same rig record, recorded_at {}, same measured normal force and drive): counted once",
            log.display(),
            of.display(),
            recorded_at.as_deref().unwrap_or("?")
        ),
        SameRecord {
            first,
            second,
            normal_force_n: n,
            drive_amplitude_m: a,
        } => write!(
            f,
            "{} and {} carry the same rig record and recorded_at but their data differ (normal force {:.3} / {:.3} N, drive {:.4} / {:.4} mm): kept as two tests",
            first.display(),
            second.display(),
            n.0,
            n.1,
            a.0 * 1e3,
            a.1 * 1e3
        ),
        _ => unreachable!("not a pipeline warning: {}", w.code()),
    }
}
