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

/// (max − min)/2 of the values at times in [t0, t1].
pub(super) fn half_range(t: &[f64], u: &[f64], t0: f64, t1: f64) -> Option<f64> {
    let mut lo = f64::INFINITY;
    let mut hi = f64::NEG_INFINITY;
    for (ti, ui) in t.iter().zip(u) {
        if *ti >= t0 && *ti <= t1 {
            lo = lo.min(*ui);
            hi = hi.max(*ui);
        }
    }
    (hi >= lo).then_some(0.5 * (hi - lo))
}

/// The exact (noise-free) trajectory at the real samples of the X1, X2 and
/// V2 channels, and the true drive amplitude the amplitudes are divided by.
struct ExactSignals {
    x1: Option<(Vec<f64>, Vec<f64>)>,
    x2: Option<(Vec<f64>, Vec<f64>)>,
    v2: Option<(Vec<f64>, Vec<f64>)>,
    a_true: f64,
}

impl ExactSignals {
    fn new(plans: &[Plan], exact: &[Vec<f64>], a_true: f64) -> ExactSignals {
        // Exact signals at the real samples of a channel.
        let exact_of = |q: Quantity| -> Option<(Vec<f64>, Vec<f64>)> {
            let i = plans.iter().position(|p| p.quantity == q)?;
            let p = &plans[i];
            let (t, u): (Vec<f64>, Vec<f64>) = p
                .req_t
                .iter()
                .zip(&exact[i])
                .zip(&p.real)
                .filter(|(_, r)| **r)
                .map(|((t, u), _)| (*t, *u))
                .unzip();
            Some((t, u))
        };
        ExactSignals {
            x1: exact_of(Quantity::X1),
            x2: exact_of(Quantity::X2),
            v2: exact_of(Quantity::V2),
            a_true,
        }
    }

    /// The amplitudes (a1, a2) over [t0, t1], relative to the true A.
    fn amp(&self, t0: f64, t1: f64) -> (Value, Value) {
        let a = |s: &Option<(Vec<f64>, Vec<f64>)>| {
            s.as_ref()
                .and_then(|(t, u)| half_range(t, u, t0, t1))
                .map_or(Value::Null, |v| num(v / self.a_true))
        };
        (a(&self.x1), a(&self.x2))
    }
}

/// The truth entry of a log (`truth.json`): rig, law, drive, the collector's
/// counts, the sensors of each channel and the response of the test.
#[allow(clippy::too_many_arguments)]
pub(super) fn truth(
    cfg: &SynthConfig,
    model: &Model,
    plans: &[Plan],
    exact: &[Vec<f64>],
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
    let ex = ExactSignals::new(plans, exact, a_true);
    let v2 = &ex.v2;
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
        "max_abs_v2_m_per_s": v2.as_ref().map_or(Value::Null, |(_, u)| num(u.iter().fold(0.0f64, |m, x| m.max(x.abs())))),
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
    insert_response(obj, cfg, &ex, setpoints, w);
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
/// continuous one.
fn insert_response(
    obj: &mut serde_json::Map<String, Value>,
    cfg: &SynthConfig,
    ex: &ExactSignals,
    setpoints: &[SynthSetpoint],
    w: f64,
) {
    let duration = cfg.test.duration_s();
    let amp = |t0: f64, t1: f64| ex.amp(t0, t1);
    match &cfg.test {
        TestSpec::Characteristic { frequency_hz, .. } => {
            obj.insert("drive_frequency_hz".into(), json!(frequency_hz));
            obj.insert("eta".into(), json!(2.0 * PI * frequency_hz / w));
            let (a1, a2) = amp((duration - 5.0).max(0.0), duration);
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
            let steps = stepped_response(setpoints_hz, dwell_s, *ramp_s, *preroll_s, w, ex);
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
                .map(|sp| {
                    let t = (sp.t_ns - LOG_START_NS) as f64 * 1e-9;
                    let half = 1.5 / sp.frequency_hz;
                    let (a1, a2) = amp(t - half, t + half);
                    json!({"t_s": t, "frequency_hz": sp.frequency_hz,
                           "eta": 2.0 * PI * sp.frequency_hz / w, "a1": a1, "a2": a2})
                })
                .collect();
            obj.insert("response".into(), Value::Array(resp));
        }
    }
}

/// The steps of a stepped sweep: times of each setpoint, dwell and settle
/// window, and the amplitudes over that window.
fn stepped_response(
    setpoints_hz: &[f64],
    dwell_s: &[f64],
    ramp_s: f64,
    preroll_s: f64,
    w: f64,
    ex: &ExactSignals,
) -> Vec<Value> {
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
        let (a1, a2) = ex.amp(t0, t_end);
        steps.push(json!({
            "frequency_hz": fr,
            "eta": 2.0 * PI * fr / w,
            "t_setpoint_s": t_set,
            "t_dwell_start_s": t,
            "t_end_s": t_end,
            "settle_window_s": [t0, t_end],
            "a1": a1, "a2": a2,
        }));
        t = t_end;
    }
    steps
}
