//! The truth a log was made with (`truth.json` entries) and its `rig`
//! record.

use super::*;

/// The `rig` metadata record (string values, `rig-log-format.md`).
pub(super) fn rig_record(cfg: &SynthConfig) -> BTreeMap<String, String> {
    let r = &cfg.rig;
    let (freq, sweep_kind) = match &cfg.test {
        TestSpec::Characteristic { frequency_hz, .. } => (Some(*frequency_hz), None),
        TestSpec::Stepped { .. } => (None, Some(SweepKind::Stepped)),
        TestSpec::Continuous { .. } => (None, Some(SweepKind::Continuous)),
    };
    let mut extra = BTreeMap::new();
    extra.insert("synth_seed".to_string(), cfg.seed.to_string());
    if let Some(e) = cfg.position_zero_uncertainty_m {
        extra.insert(crate::ingest::ZERO_UNCERTAINTY.to_string(), e.to_string());
    }
    if let TestSpec::Continuous {
        from_hz,
        to_hz,
        sweep_s,
        ..
    } = &cfg.test
    {
        extra.insert(
            "sweep_rate_hz_per_s".to_string(),
            ((to_hz - from_hz) / sweep_s).to_string(),
        );
    }
    RigMeta {
        format: FORMAT_VERSION.to_string(),
        test: cfg.test.kind(),
        m1_kg: r.m1_kg,
        m2_kg: r.m2_kg,
        k1_n_per_m: r.k1_n_per_m,
        k2_n_per_m: r.k2_n_per_m,
        d_n_s_per_m: r.d_n_s_per_m,
        drive_amplitude_m: r.drive_amplitude_nominal_m,
        normal_force_n: cfg.normal_force_n,
        drive_frequency_hz: freq,
        sweep_kind,
        rig_id: Some("virtual-rig (stickslip synth)".into()),
        operator: Some("stickslip synth".into()),
        notes: Some(format!(
            "synthetic log, seed {}; law {}; truth in truth.json",
            cfg.seed,
            cfg.friction.family().as_str()
        )),
        recorded_at: Some(LOG_START_TEXT.into()),
        extra,
    }
    .to_map()
}

/// The (min, max) of one channel's exact logged values over each response
/// window, accumulated sample by sample (times non-decreasing).
struct WindowRanges {
    /// The next window (in `ExactSummary::order`) not yet opened.
    next: usize,
    /// Windows opened and not yet closed.
    active: Vec<usize>,
    /// Per window: (min, max); (+∞, −∞) while no sample fell in it.
    range: Vec<(f64, f64)>,
}

impl WindowRanges {
    fn new(n: usize) -> Self {
        Self {
            next: 0,
            active: Vec::with_capacity(n.min(16)),
            range: vec![(f64::INFINITY, f64::NEG_INFINITY); n],
        }
    }

    /// Adds the value `u` at time `t` to every window [t0, t1] holding t.
    fn push(&mut self, windows: &[(f64, f64)], order: &[usize], t: f64, u: f64) {
        while let Some(&k) = order.get(self.next) {
            if windows[k].0 > t {
                break;
            }
            self.active.push(k);
            self.next += 1;
        }
        self.active.retain(|&k| windows[k].1 >= t);
        for &k in &self.active {
            let r = &mut self.range[k];
            *r = (r.0.min(u), r.1.max(u));
        }
    }

    /// (max − min)/2 over window `k`, if a sample fell in it.
    fn half_range(&self, k: usize) -> Option<f64> {
        let (lo, hi) = self.range[k];
        (hi >= lo).then_some(0.5 * (hi - lo))
    }
}

/// What the truth needs of the exact (noise-free) trajectory at the logged
/// samples of the X1, X2 and V2 channels, accumulated while the engine
/// runs: the half ranges of x1 and x2 over the test's response windows
/// ([`response_windows`]) and the largest |v2|.
pub(super) struct ExactSummary {
    /// The response windows [t0, t1] (s from the log start), in the order
    /// the truth lists them.
    windows: Vec<(f64, f64)>,
    /// Window indices by start time.
    order: Vec<usize>,
    x1: Option<WindowRanges>,
    x2: Option<WindowRanges>,
    /// max |v2| so far (None: no V2 channel).
    v2_max: Option<f64>,
    a_true: f64,
}

impl ExactSummary {
    /// An empty summary for the channels of `plans`.
    pub(super) fn new(cfg: &SynthConfig, plans: &[Plan], setpoints: &[SynthSetpoint]) -> Self {
        let windows = response_windows(cfg, setpoints);
        let mut order: Vec<usize> = (0..windows.len()).collect();
        order.sort_by(|a, b| windows[*a].0.total_cmp(&windows[*b].0));
        let has = |q: Quantity| plans.iter().any(|p| p.quantity == q);
        let n = windows.len();
        ExactSummary {
            x1: has(Quantity::X1).then(|| WindowRanges::new(n)),
            x2: has(Quantity::X2).then(|| WindowRanges::new(n)),
            v2_max: has(Quantity::V2).then_some(0.0),
            windows,
            order,
            a_true: cfg.rig.drive_amplitude_true_m,
        }
    }

    /// Adds the exact value `u` of a logged sample of `q` measured at `t`
    /// (s from the log start).
    pub(super) fn push(&mut self, q: Quantity, t: f64, u: f64) {
        let ranges = match q {
            Quantity::X1 => self.x1.as_mut(),
            Quantity::X2 => self.x2.as_mut(),
            Quantity::V2 => {
                if let Some(m) = self.v2_max.as_mut() {
                    *m = m.max(u.abs());
                }
                None
            }
            _ => None,
        };
        if let Some(r) = ranges {
            r.push(&self.windows, &self.order, t, u);
        }
    }

    /// The amplitudes (a1, a2) over response window `k`, relative to the
    /// true A.
    fn amp(&self, k: usize) -> (Value, Value) {
        let a = |r: &Option<WindowRanges>| {
            r.as_ref()
                .and_then(|r| r.half_range(k))
                .map_or(Value::Null, |v| num(v / self.a_true))
        };
        (a(&self.x1), a(&self.x2))
    }
}

/// The windows (s from the log start) the truth gives amplitudes over, in
/// its order: the last 5 s of a characteristic test, the settle window of
/// each step of a stepped sweep, 1.5 drive periods either side of each
/// setpoint message of a continuous one.
fn response_windows(cfg: &SynthConfig, setpoints: &[SynthSetpoint]) -> Vec<(f64, f64)> {
    let duration = cfg.test.duration_s();
    match &cfg.test {
        TestSpec::Characteristic { .. } => vec![((duration - 5.0).max(0.0), duration)],
        TestSpec::Stepped {
            setpoints_hz,
            dwell_s,
            ramp_s,
            preroll_s,
        } => steps(setpoints_hz, dwell_s, *ramp_s, *preroll_s)
            .iter()
            .map(|s| s.window)
            .collect(),
        TestSpec::Continuous { .. } => setpoints
            .iter()
            .map(|sp| {
                let (t, half) = continuous_window(sp);
                (t - half, t + half)
            })
            .collect(),
    }
}

/// A setpoint message's time (s from the log start) and the half width of
/// its response window (1.5 drive periods).
fn continuous_window(sp: &SynthSetpoint) -> (f64, f64) {
    let t = (sp.t_ns - LOG_START_NS) as f64 * 1e-9;
    (t, 1.5 / sp.frequency_hz)
}

/// The truth entry of a log (`truth.json`): rig, law, drive, the collector's
/// counts, the sensors of each channel and the response of the test.
pub(super) fn truth(
    cfg: &SynthConfig,
    model: &Model,
    channels: &[SynthChannel],
    rig_record: &BTreeMap<String, String>,
    col: &Collector<'_>,
    setpoints: &[SynthSetpoint],
) -> Value {
    let r = &cfg.rig;
    let w = r.omega_ref();
    let (a_nom, a_true) = (r.drive_amplitude_nominal_m, r.drive_amplitude_true_m);
    let ab = r.absorber();
    let f = &cfg.friction;
    let law_nom = f.law(r, a_nom);
    let mu = |x: f64| {
        if cfg.normal_force_n > 0.0 {
            num(x / cfg.normal_force_n)
        } else {
            Value::Null
        }
    };
    let duration = cfg.test.duration_s();
    let ex = &col.exact;
    let sensors = sensors_json(cfg, channels);
    let mut e = json!({
        "test": cfg.test.kind().as_str(),
        "format": cfg.format.as_str(),
        "generator": "stickslip synth",
        "rig": {
            "m1_kg": r.m1_kg, "m2_kg": r.m2_kg,
            "k1_n_per_m": r.k1_n_per_m, "k2_n_per_m": r.k2_n_per_m,
            "d_n_s_per_m": r.d_n_s_per_m,
            "drive_amplitude_nominal_m": a_nom,
            "omega_ref_rad_s": w,
            "m": ab.m, "k": ab.k, "D": ab.damping,
        },
        "law": {
            "family": f.family().as_str(),
            "rs_n": f.rs_n, "rd_n": f.rd_n,
            "slope_n_s_per_m": f.slope_n_s_per_m,
            "stribeck_velocity_m_per_s": f.stribeck_velocity_m_per_s,
            "mu_s": mu(f.rs_n), "mu_d": mu(f.rd_n),
            "rho_s": law_nom.rho_s(), "rho_d": law_nom.rho_d(), "Dstar": law_nom.slope(),
            "rho_s_true_amplitude": model.law.rho_s(),
            "rho_d_true_amplitude": model.law.rho_d(),
            "v_s_dimensionless_true_amplitude": model.law.v_s().map_or(Value::Null, num),
        },
        "drive_amplitude_true_m": a_true,
        "drive_amplitude_nominal_m": a_nom,
        "drive_amplitude_ratio": a_true / a_nom,
        "normal_force_n": cfg.normal_force_n,
        "mu_s": mu(f.rs_n), "mu_d": mu(f.rd_n),
        "stuck": !col.slid_in_log,
        "slid_during_warmup": col.slid_before_log,
        "warmup_s": cfg.test.warmup_s(),
        "duration_s": duration,
        "stick_fraction": col.stick_time / (duration * w),
        "n_stick_slip_events": col.events_in_log,
        "max_abs_v2_m_per_s": ex.v2_max.map_or(Value::Null, num),
        "channels": channels.iter().map(|c| if cfg.format.is_table() { c.quantity.name() } else { c.quantity.topic() }).collect::<Vec<_>>(),
        "sensors": sensors,
        "seed": cfg.seed,
        "metadata": rig_record,
        "sample_times": "the exact trajectory is sampled at each written sample's time; amplitudes a1/a2 are (max-min)/2 of those exact samples over the window, divided by the true A",
    });
    let obj = e.as_object_mut().expect("object");
    // The shift that re-aligns each channel with x1 (a channel map's
    // `shift_s` convention: the value stamped t was taken at t + shift),
    // declared column shifts included: what `channel_delays_s` should say.
    let own = |c: &SynthChannel| c.shift_s - c.sensor.delay_s;
    let x1_shift = channels
        .iter()
        .find(|c| c.quantity == crate::ingest::Quantity::X1)
        .map_or(0.0, own);
    let delays: BTreeMap<&str, f64> = channels
        .iter()
        .filter(|c| {
            !matches!(
                c.quantity,
                crate::ingest::Quantity::X1 | crate::ingest::Quantity::NormalForce
            )
        })
        .map(|c| (c.quantity.name(), own(c) - x1_shift))
        .collect();
    obj.insert("channel_delays_s".into(), json!(delays));
    // A contact spring (pre-sliding): kt and κ = kt/K2 with the law.
    if let (Some(kt), Some(kappa)) = (cfg.contact_stiffness_n_per_m, model.contact_stiffness) {
        if let Some(law) = obj.get_mut("law").and_then(Value::as_object_mut) {
            law.insert("contact_stiffness_n_per_m".into(), num(kt));
            law.insert("contact_stiffness".into(), num(kappa));
        }
    }
    // The same with each first-order low-pass's low-frequency group delay
    // 1/(2π f_c) (a filtered channel lags by that much as well).
    let filter_lag = |c: &SynthChannel| c.sensor.lowpass_hz.map_or(0.0, |fc| 1.0 / (2.0 * PI * fc));
    let x1_lag = channels
        .iter()
        .find(|c| c.quantity == crate::ingest::Quantity::X1)
        .map_or(0.0, filter_lag);
    let lags: BTreeMap<&str, f64> = channels
        .iter()
        .filter(|c| delays.contains_key(c.quantity.name()))
        .map(|c| {
            let d = delays[c.quantity.name()];
            (c.quantity.name(), d - (filter_lag(c) - x1_lag))
        })
        .collect();
    obj.insert("channel_lags_s".into(), json!(lags));
    if cfg.format.is_table() {
        obj.insert("common_rate_hz".into(), json!(cfg.table_rate_hz));
        let shifts: BTreeMap<&str, f64> = channels
            .iter()
            .map(|c| (c.quantity.name(), c.shift_s))
            .collect();
        obj.insert("column_time_shifts_s".into(), json!(shifts));
    }
    insert_response(obj, cfg, ex, setpoints, w);
    e
}

/// The sensors of each channel (its name: the column of a table, the topic
/// of an MCAP log) as written.
fn sensors_json(cfg: &SynthConfig, channels: &[SynthChannel]) -> serde_json::Map<String, Value> {
    channels
        .iter()
        .map(|c| {
            let s = &c.sensor;
            let n_samples: usize = c.buffers.iter().map(|b| b.values.len()).sum();
            (
                if cfg.format.is_table() {
                    c.quantity.name().to_string()
                } else {
                    c.quantity.topic().to_string()
                },
                json!({
                    "topic": c.quantity.topic(),
                    "quantity": c.quantity.name(),
                    "unit": c.quantity.unit(),
                    "rate_hz": if cfg.format.is_table() { cfg.table_rate_hz } else { s.rate_hz },
                    "noise": s.noise,
                    "quant": s.quant,
                    "gain": s.gain,
                    "offset": s.offset,
                    "lowpass_hz": s.lowpass_hz,
                    "buffer_s": if cfg.format.is_table() { Value::Null } else { json!(s.buffer_s) },
                    "jitter_ns": if cfg.format.is_table() { 0 } else { s.jitter_ns },
                    "p_lost_buffer": if cfg.format.is_table() { 0.0 } else { s.p_lost_buffer },
                    "p_dropout": s.p_dropout,
                    "dropout_burst_max": s.dropout_burst_max,
                    "dt_ns": c.dt_ns,
                    "n_samples": n_samples,
                    "n_buffers": c.buffers.len() + c.lost_buffers,
                    "lost_buffers": c.lost_buffers,
                    "null_samples": c.null_samples,
                    "first_sample_offset_ns": c.first_sample_offset_ns,
                    "shift_s": c.shift_s,
                    "delay_s": s.delay_s,
                    "offset_drift_per_s": s.offset_drift_per_s,
                })
                .as_object()
                .cloned()
                .map(|mut o| {
                    defect_keys(&mut o, c, n_samples);
                    Value::Object(o)
                })
                .unwrap_or(Value::Null),
            )
        })
        .collect()
}

/// The keys of the realistic sensor defects, only where a channel has
/// them (the truth of a log without them stays as it was): the low-pass
/// order, the gain drift, the saturation levels applied (SI) and the
/// count and fraction of written samples at them.
fn defect_keys(o: &mut serde_json::Map<String, Value>, c: &SynthChannel, n_samples: usize) {
    let s = &c.sensor;
    if s.lowpass_order != 1 {
        o.insert("lowpass_order".into(), json!(s.lowpass_order));
    }
    if s.gain_drift_per_s != 0.0 {
        o.insert("gain_drift_per_s".into(), json!(s.gain_drift_per_s));
    }
    let (lo, hi, n) = c.clip;
    if lo.is_finite() || hi.is_finite() {
        let level = |v: f64| if v.is_finite() { num(v) } else { Value::Null };
        o.insert("clip_low".into(), level(lo));
        o.insert("clip_high".into(), level(hi));
        o.insert("clipped_samples".into(), json!(n));
        o.insert(
            "clipped_fraction".into(),
            json!(n as f64 / n_samples.max(1) as f64),
        );
    }
}

/// Inserts the response of the test into the truth entry: the last 5 s of
/// a characteristic test, each step of a stepped sweep, each setpoint of a
/// continuous one (the amplitudes over [`response_windows`], in order).
fn insert_response(
    obj: &mut serde_json::Map<String, Value>,
    cfg: &SynthConfig,
    ex: &ExactSummary,
    setpoints: &[SynthSetpoint],
    w: f64,
) {
    match &cfg.test {
        TestSpec::Characteristic { frequency_hz, .. } => {
            obj.insert("drive_frequency_hz".into(), json!(frequency_hz));
            obj.insert("eta".into(), json!(2.0 * PI * frequency_hz / w));
            let (a1, a2) = ex.amp(0);
            obj.insert("a1_last5s".into(), a1);
            obj.insert("a2_last5s".into(), a2);
        }
        TestSpec::Stepped {
            setpoints_hz,
            dwell_s,
            ramp_s,
            preroll_s,
        } => {
            obj.insert("sweep_kind".into(), json!("stepped"));
            let steps: Vec<Value> = steps(setpoints_hz, dwell_s, *ramp_s, *preroll_s)
                .iter()
                .enumerate()
                .map(|(k, s)| {
                    let (t0, t_end) = s.window;
                    let (a1, a2) = ex.amp(k);
                    json!({
                        "frequency_hz": s.frequency_hz,
                        "eta": 2.0 * PI * s.frequency_hz / w,
                        "t_setpoint_s": s.t_setpoint,
                        "t_dwell_start_s": s.t_dwell_start,
                        "t_end_s": t_end,
                        "settle_window_s": [t0, t_end],
                        "a1": a1, "a2": a2,
                    })
                })
                .collect();
            obj.insert("response".into(), Value::Array(steps));
        }
        TestSpec::Continuous {
            from_hz,
            to_hz,
            sweep_s,
            ..
        } => {
            obj.insert("sweep_kind".into(), json!("continuous"));
            obj.insert(
                "sweep_rate_hz_per_s".into(),
                json!((to_hz - from_hz) / sweep_s),
            );
            let resp: Vec<Value> = setpoints
                .iter()
                .enumerate()
                .map(|(k, sp)| {
                    let (t, _) = continuous_window(sp);
                    let (a1, a2) = ex.amp(k);
                    json!({"t_s": t, "frequency_hz": sp.frequency_hz,
                           "eta": 2.0 * PI * sp.frequency_hz / w, "a1": a1, "a2": a2})
                })
                .collect();
            obj.insert("response".into(), Value::Array(resp));
        }
    }
}

/// One step of a stepped sweep: its setpoint, the times of its setpoint
/// message and dwell start, and its settle window [t0, t_end] (s).
struct Step {
    frequency_hz: f64,
    t_setpoint: f64,
    t_dwell_start: f64,
    window: (f64, f64),
}

/// The steps of a stepped sweep: times of each setpoint, dwell and settle
/// window (the last whole drive periods of the dwell, at most 5 s).
fn steps(setpoints_hz: &[f64], dwell_s: &[f64], ramp_s: f64, preroll_s: f64) -> Vec<Step> {
    let mut t = preroll_s;
    let mut steps = Vec::new();
    for (i, &fr) in setpoints_hz.iter().enumerate() {
        let t_set = t;
        if i > 0 {
            t += ramp_s;
        }
        let d = dwell_of(dwell_s, i);
        let t_end = t + d;
        // Settle window: the last whole drive periods, at most 5 s.
        let period = 1.0 / fr;
        let n = ((d.min(5.0)) / period).floor().max(1.0);
        let t0 = (t_end - n * period).max(t);
        steps.push(Step {
            frequency_hz: fr,
            t_setpoint: t_set,
            t_dwell_start: t,
            window: (t0, t_end),
        });
        t = t_end;
    }
    steps
}
