//! Choosing among the refined families: the effective sample size, each
//! family's fit and criterion, the parsimony and never-sticks rules, and
//! the chosen law's adequacy, intervals and bounds ([`OutputErrorFit`]).

use super::*;

impl Refinement {
    /// The number of residual samples per channel and the effective number
    /// of independent ones (n over the correlation time of the residuals of
    /// the richest fit) for the criterion.
    pub(super) fn effective_samples(&self, fits: &[Refined]) -> Result<(usize, f64), RefineError> {
        // The criterion: n_eff from the residuals of the richest fit.
        let richest = fits
            .iter()
            .max_by_key(|f| f.fam().n_params())
            .expect("non-empty");
        let mut res = Res::new();
        let proj = self.proj(richest)?;
        self.problem(&self.data, richest.fam())
            .eval(&richest.th, Some(&proj), Some(&mut res))
            .ok_or(RefineError::NotSimulable)?;
        let seg: Vec<u32> = res.iter().map(|r| r.0).collect();
        let r1: Vec<f64> = res.iter().map(|r| r.1).collect();
        let r2: Vec<f64> = res.iter().map(|r| r.2).collect();
        let n = res.len();
        let tau = tau_int(&seg, &r1).max(tau_int(&seg, &r2));
        let n_eff = (n as f64 / tau).max(2.0);
        Ok((n, n_eff))
    }

    /// Each refined family's law, nuisance parameters, criterion, RMS and
    /// sticking (one more simulation each).
    fn family_fits(&self, fits: &[Refined], n: usize, n_eff: f64) -> Vec<FamilyFit> {
        let mut families: Vec<FamilyFit> = Vec::new();
        for f in fits {
            let Refined {
                th,
                cost,
                iterations: it,
                ..
            } = f;
            let prob = self.problem(&self.data, f.fam());
            let (_, b, g1, g2) = prob.unpack(th);
            let (law, rs_minus_n, kappa) = prob.pad_law(th);
            let k = f.fam().n_params() as f64;
            let bic = n_eff * (cost / (2 * n) as f64).ln() + k * n_eff.ln();
            let rms = self.rms(&prob, th);
            prob.sticks.set((0, 0));
            prob.dirs.set(DirStats::default());
            let m = self
                .proj(f)
                .ok()
                .and_then(|proj| prob.eval(th, Some(&proj), None))
                .map_or(0, |_| n);
            let (ss, runs) = prob.sticks.get();
            let dirs = prob.dirs.get();
            let fs = self.data.a * self.rig.k2;
            let bound = |v: f64| v.is_finite().then_some(v * fs);
            let df = prob.delays.get();
            // 95 % intervals: the variances times the residuals'
            // correlation time (n / n_eff samples per independent one).
            let half = |v: f64| 1.96 * (v * n as f64 / n_eff).sqrt();
            let delays_s = df.lag_s;
            let delays_interval_s = (
                (
                    df.lag_s.0 - half(df.var_s2.0),
                    df.lag_s.0 + half(df.var_s2.0),
                ),
                (
                    df.lag_s.1 - half(df.var_s2.1),
                    df.lag_s.1 + half(df.var_s2.1),
                ),
            );
            families.push(FamilyFit {
                law,
                bias_n: b,
                gains: (g1, g2),
                cost: *cost,
                bic,
                rms_m: rms,
                iterations: *it,
                stick_fraction: if m > 0 { ss as f64 / m as f64 } else { 0.0 },
                stick_runs: runs,
                delays_s,
                delays_interval_s,
                ext: f.ext,
                rs_minus_n,
                contact_stiffness: kappa,
                breakaways: (dirs.breakaways[0], dirs.breakaways[1]),
                reversal_bound_n: (bound(dirs.reversal_force[0]), bound(dirs.reversal_force[1])),
            });
        }
        families
    }

    /// The index of the family the criterion chooses: the simplest within
    /// [`BIC_WEAK`] of the lowest, stick-free where the segmentation saw no
    /// stick unless a threshold wins by more than [`BIC_STRONG`].
    fn pick_family(&self, families: &[FamilyFit]) -> usize {
        // Parsimony: the simplest family within 2 of the lowest criterion
        // (a difference below 2 is no evidence either way).
        let bmin = families.iter().map(|f| f.bic).fold(f64::INFINITY, f64::min);
        let mut best = (0..families.len())
            .filter(|&a| families[a].bic <= bmin + BIC_WEAK)
            .min_by(|&a, &b| {
                families[a]
                    .n_params()
                    .cmp(&families[b].n_params())
                    .then(families[a].bic.total_cmp(&families[b].bic))
            })
            .expect("non-empty");
        // Overruling the segmentation's never-sticks verdict takes very
        // strong evidence: a static threshold is kept only if it beats
        // every stick-free family by more than BIC_STRONG.
        // (Not behind a contact spring: M2 rings on it after every slip, so
        // the velocity cannot show the slider's sticks.)
        if self.never_sticks
            && families[best].law.kind.family().has_threshold()
            && !families[best].ext.contact
        {
            let other = (0..families.len())
                .filter(|&a| !families[a].law.kind.family().has_threshold())
                .min_by(|&a, &b| families[a].bic.total_cmp(&families[b].bic));
            if let Some(o) = other {
                if families[o].bic - families[best].bic < BIC_STRONG {
                    best = o;
                }
            }
        }
        best
    }

    /// A split threshold is measured only in a direction the simulated law
    /// breaks away towards (at least [`MIN_DIRECTION_BREAKAWAYS`] times);
    /// where it does not, M2 reverses there without sticking, and the
    /// threshold is only bounded: above Rd (the interval's low end), below
    /// the smallest |F| at those reversals. That side's value and the split
    /// become None, its interval holds the bounds (None if they
    /// contradict).
    fn bound_split_sides(&self, f: &FamilyFit, iv: &mut Intervals, pads: &mut PadFit) {
        let fs = self.data.a * self.rig.k2;
        let rd_lo = iv.rd_n.map(|r| r.0);
        let bounds = |ub: Option<f64>| match (rd_lo, ub) {
            (Some(lo), Some(hi)) if lo <= hi => Some((lo, hi)),
            _ => None,
        };
        let scaled = |b: Option<crate::identify::Interval>| b.map(|(l, h)| (l / fs, h / fs));
        if f.breakaways.1 < MIN_DIRECTION_BREAKAWAYS {
            let b = bounds(f.reversal_bound_n.1);
            pads.rs_minus_n = None;
            pads.rho_s_minus = None;
            pads.rs_minus_interval_n = b;
            pads.rho_s_minus_interval = scaled(b);
            pads.minus_bounded = true;
        }
        if f.breakaways.0 < MIN_DIRECTION_BREAKAWAYS {
            let b = bounds(f.reversal_bound_n.0);
            iv.rs_n = b;
            iv.rho_s = scaled(b);
            pads.plus_bounded = true;
        }
        if pads.minus_bounded || pads.plus_bounded {
            pads.split_n = None;
            pads.split_interval_n = None;
        }
    }

    /// The static thresholds of each direction with calibrated zeros
    /// ([`PadFit::calibrated`]): a side is measured where the chosen law
    /// breaks away towards it at least [`MIN_DIRECTION_BREAKAWAYS`] times
    /// and its threshold is resolved; otherwise its value is None and its
    /// interval is the symmetric gauge's bounds (the threshold's interval,
    /// or [Rd's low end, the reversals' bound] of a side never broken
    /// towards) moved by the side's shift ±b, widened by b's half-width.
    fn calibrated_sides(&self, f: &FamilyFit, iv: &Intervals, pads: &mut PadFit) {
        let fs = self.data.a * self.rig.k2;
        let split = f.ext.split;
        let (minus_bounded, plus_bounded, unresolved) = (
            pads.minus_bounded,
            pads.plus_bounded,
            pads.threshold_unresolved,
        );
        let rs_minus_iv = pads.rs_minus_interval_n;
        let Some(c) = pads.calibrated.as_mut() else {
            return;
        };
        let b = 0.5 * c.dynamic_split_n;
        let hw_b = c
            .dynamic_split_interval_n
            .map_or(0.0, |(l, h)| 0.25 * (h - l));
        let rd_lo = iv.rd_n.map(|r| r.0);
        // Per side: its index in `rho`, its shift, breakaways towards it,
        // whether the chosen split bounded it, the reversals' bound.
        for (k, shift, breakaways, bounded, ub) in [
            (0, b, f.breakaways.0, plus_bounded, f.reversal_bound_n.0),
            (2, -b, f.breakaways.1, minus_bounded, f.reversal_bound_n.1),
        ] {
            let measured = iv.rs_n.is_some()
                && !bounded
                && !unresolved
                && breakaways >= MIN_DIRECTION_BREAKAWAYS;
            if measured {
                continue;
            }
            let gauge = if breakaways < MIN_DIRECTION_BREAKAWAYS && !bounded {
                match (rd_lo, ub) {
                    (Some(lo), Some(hi)) if lo <= hi => Some((lo, hi)),
                    _ => None,
                }
            } else if k == 2 && split {
                rs_minus_iv
            } else {
                iv.rs_n
            };
            let moved = gauge.map(|(lo, hi)| (lo + shift - hw_b, hi + shift + hw_b));
            let (value, interval) = if k == 0 {
                (&mut c.rs_plus_n, &mut c.rs_plus_interval_n)
            } else {
                (&mut c.rs_minus_n, &mut c.rs_minus_interval_n)
            };
            *value = None;
            *interval = moved;
            c.rho[k] = None;
            c.rho_intervals[k] = moved.map(|(l, h)| (l / fs, h / fs));
        }
    }

    /// Whether a family's law sticks (see [`OutputErrorFit::sticks_found`]).
    fn sticks_of(&self, f: &FamilyFit) -> bool {
        !self.never_sticks || (f.stick_fraction > MIN_STICK_FRACTION && f.stick_runs >= 4)
    }

    /// Chooses among the refined families `fits` (the criterion, the
    /// parsimony rules, the never-sticks rule) unless `forced`, and gives
    /// the chosen law's adequacy and intervals.
    pub(super) fn conclude(
        &self,
        fits: &[Refined],
        forced: Option<LawKind>,
        u: f64,
        t0: std::time::Instant,
    ) -> Result<OutputErrorFit, RefineError> {
        let (n, n_eff) = self.effective_samples(fits)?;
        let families = self.family_fits(fits, n, n_eff);
        let mut best = self.pick_family(&families);
        let mut notes = Vec::new();
        let sticks_of = |f: &FamilyFit| self.sticks_of(f);
        let assess = |i: usize| -> Result<
            (Adequacy, Intervals, PadFit, CalibrationPart, f64),
            RefineError,
        > {
            let f = &fits[i];
            let proj = self.proj(f)?;
            let adequacy = self.adequacy(f.fam(), &f.th, &proj)?;
            let (intervals, pads, cal, secants) = self.intervals(
                f.fam(),
                &f.th,
                &proj,
                u,
                sticks_of(&families[i]),
                adequacy.inflation,
                &[],
            )?;
            Ok((adequacy, intervals, pads, cal, secants))
        };
        let (mut adequacy, mut intervals, mut pads, mut calibration, mut secant_ratio) =
            assess(best)?;
        // Parsimony, second rule: an extra parameter whose interval holds
        // its nested value (D* = 0; ρs = ρd; the split Δ = 0) is not
        // supported by the data.
        if fits[best].ext.split
            && pads
                .split_interval_n
                .is_some_and(|(lo, hi)| lo <= 0.0 && 0.0 <= hi)
        {
            let without = Ext {
                split: false,
                ..fits[best].ext
            };
            if let Some(c) = fits
                .iter()
                .position(|f| f.kind == fits[best].kind && f.ext == without)
            {
                best = c;
                (adequacy, intervals, pads, calibration, secant_ratio) = assess(c)?;
            }
        }
        if forced.is_none()
            && families[best].law.kind != LawKind::Coulomb
            && fits[best].ext.is_empty()
        {
            let l = families[best].law;
            let nested =
                l.kind
                    .family()
                    .nests_coulomb(&l, intervals.rs_n, intervals.slope_n_s_per_m);
            if let Some(c) = fits
                .iter()
                .position(|f| f.kind == LawKind::Coulomb && f.ext.is_empty())
            {
                if nested {
                    notes.push(crate::warning::Warning::NestedCoulomb { law: l.kind });
                    best = c;
                    (adequacy, intervals, pads, calibration, secant_ratio) = assess(c)?;
                }
            }
        }
        if fits[best].ext.split {
            self.bound_split_sides(&families[best], &mut intervals, &mut pads);
        }
        // Behind a contact spring the threshold shows only as the extra
        // deflection (Rs − Rd)/kt before each breakaway: a law without a
        // threshold (Rs = Rd by assumption), or one whose Rs interval
        // reaches Rd, has not measured it, and Rs is only bounded below
        // by Rd (on a compliant pad with (Rs − Rd)/kt = 3.8 µm and 3 µm
        // of position noise every start, the true Rs included, ended at
        // Rs = Rd). Its bounds, and κ's interval over every threshold the
        // log admits, then come from the profile in Rs (the chosen fit's
        // own intervals are conditional on its threshold).
        if fits[best].ext.contact {
            let l = families[best].law;
            let reaches_rd = match intervals.rs_n {
                Some((lo, _)) => intervals.rd_n.is_some_and(|(_, hi)| lo <= hi),
                None => true,
            };
            if !l.kind.family().has_threshold() || reaches_rd {
                intervals.rs_n = None;
                intervals.rho_s = None;
                pads.threshold_unresolved = true;
            }
        }
        if pads.calibrated.is_some() {
            if let Some(c) = pads.calibrated.as_mut() {
                // The difference of the dynamic levels is resolved when it
                // would pay for its parameter by the criterion (z² is the
                // χ² it buys) or the chosen law splits its threshold.
                c.resolved = fits[best].ext.split || c.z * c.z > n_eff.max(1.0).ln() + 2.0;
            }
        }
        if secant_ratio >= MAX_SECANT_RATIO {
            notes.push(crate::warning::Warning::RoughCost { secant_ratio });
        }
        let fam = fits[best].fam();
        let chosen = families[best].clone();
        // How strongly the data prefer the chosen family over the best
        // other one (BIC difference, Kass–Raftery scale).
        // (Among the laws with the chosen one's real-pad extensions: the
        // extensions have their own comparison in `families`.)
        let evidence = families
            .iter()
            .enumerate()
            .filter(|(i, f)| *i != best && f.ext == chosen.ext)
            .min_by(|a, b| a.1.bic.total_cmp(&b.1.bic))
            .map(|(_, f)| Evidence {
                against: f.law.kind,
                delta_bic: f.bic - chosen.bic,
            });
        let start_rms_m = self.rms(&self.problem(&self.data, fam), &fits[best].start);
        Ok(OutputErrorFit {
            law: chosen.law,
            sticks_found: sticks_of(&chosen),
            chosen,
            families,
            start_rms_m,
            intervals,
            calibration_half_width_n: calibration,
            interval_secant_ratio: secant_ratio,
            pads,
            segments: self.data.segs.len(),
            samples: n,
            n_eff,
            evaluations: self.evals.get(),
            drive: self.data.drive,
            seconds: t0.elapsed().as_secs_f64(),
            position_delays: self.data.delays,
            adequacy,
            evidence,
            notes,
            drop_profile: None,
        })
    }

    /// What a conclusion still lacks ([`Self::conclude`] leaves it to the
    /// conclusion a pass keeps: the profile is costly): behind a contact
    /// whose threshold the log does not resolve, the profile in Rs
    /// ([`Self::profile_unresolved`]); with calibrated zeros, the levels
    /// of each direction from the final intervals
    /// ([`Self::calibrated_sides`]). Nothing a decision between
    /// conclusions reads (law, cost, adequacy, b's z) changes.
    pub(super) fn settle(&self, fits: &[Refined], out: &mut OutputErrorFit, u: f64) {
        let chosen = fits
            .iter()
            .find(|f| f.kind == out.chosen.law.kind && f.ext == out.chosen.ext);
        if let (Some(f), true) = (chosen, out.pads.threshold_unresolved) {
            self.profile_unresolved(
                fits,
                f,
                out.adequacy.inflation,
                u,
                &mut out.intervals,
                &mut out.pads,
            );
        }
        if out.pads.calibrated.is_some() {
            self.calibrated_sides(&out.chosen, &out.intervals, &mut out.pads);
        }
    }

    /// Behind a contact whose threshold the log did not resolve: the
    /// profile in Rs of the static-dynamic fit with the chosen extensions
    /// bounds Rs from above (the Rs interval then holds [Rd's low end, that
    /// bound]) and widens κ's interval to every admitted threshold (the
    /// chosen fit's interval is conditional on its own threshold).
    fn profile_unresolved(
        &self,
        fits: &[Refined],
        chosen: &Refined,
        inflation: f64,
        u: f64,
        intervals: &mut Intervals,
        pads: &mut PadFit,
    ) {
        // (A forced shaped law's is a helper, not among `fits`.)
        let helper = self.profile_helper.borrow();
        let matches = |f: &&Refined| f.kind == LawKind::StaticDynamic && f.ext == chosen.ext;
        let Some(sd) = fits
            .iter()
            .find(matches)
            .or_else(|| helper.as_ref().filter(matches))
        else {
            return;
        };
        let Some(pr) = self.profile_threshold(sd, inflation, u) else {
            return;
        };
        if let (Some(hi), Some((lo, _))) = (pr.rs_upper_n, intervals.rd_n) {
            let fs = self.data.a * self.rig.k2;
            if lo <= hi {
                intervals.rs_n = Some((lo, hi));
                intervals.rho_s = Some((lo / fs, hi / fs));
            }
        }
        if let (Some((a, b)), Some((l, h))) = (pr.kappa_interval, pads.contact_stiffness_interval) {
            pads.contact_stiffness_interval = Some((l.min(a), h.max(b)));
        }
    }
}
