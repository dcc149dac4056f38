//! Running the virtual rig: the exact trajectory sampled by each
//! channel's sensor model, into DAQ buffers or table rows.

use super::*;

/// A sample request: engine time and the channel/point it belongs to.
#[derive(Clone, Copy)]
pub(super) struct Request {
    pub(super) tau: f64,
    pub(super) chan: u32,
}

/// The observer: hands out the merged request times, stores each
/// channel's exact signal, and tracks the contact mode over the log.
pub(super) struct Collector<'a> {
    pub(super) requests: &'a [Request],
    pub(super) next: usize,
    /// Per channel: exact signal at its requests, in order.
    pub(super) out: Vec<Vec<f64>>,
    pub(super) quantities: Vec<Quantity>,
    pub(super) drives: &'a Drives,
    pub(super) a: f64,
    pub(super) w: f64,
    pub(super) normal_force: f64,
    /// Logged window in τ.
    pub(super) log: (f64, f64),
    pub(super) stick_since: Option<f64>,
    pub(super) stick_time: f64,
    pub(super) events_in_log: u64,
    pub(super) slid_in_log: bool,
    pub(super) slid_before_log: bool,
}

impl Collector<'_> {
    pub(super) fn add_stick(&mut self, from: f64, to: f64) {
        let (a, b) = (from.max(self.log.0), to.min(self.log.1));
        if b > a {
            self.stick_time += b - a;
        }
    }
}

impl Observer for Collector<'_> {
    fn event(&mut self, ev: &Event) {
        let in_log = ev.tau >= self.log.0 && ev.tau <= self.log.1;
        if in_log {
            self.events_in_log += 1;
        }
        match ev.kind {
            EventKind::Stick => {
                if self.stick_since.is_none() {
                    self.stick_since = Some(ev.tau);
                }
            }
            _ => {
                if let Some(s) = self.stick_since.take() {
                    self.add_stick(s, ev.tau);
                }
                if in_log {
                    self.slid_in_log = true;
                } else if ev.tau < self.log.0 {
                    self.slid_before_log = true;
                }
            }
        }
    }
    fn next_sample(&mut self) -> Option<f64> {
        self.requests.get(self.next).map(|r| r.tau)
    }
    fn sample(&mut self, tau: f64, x: &[f64; 4], dx: &[f64; 4]) {
        let r = self.requests[self.next];
        self.next += 1;
        let q = self.quantities[r.chan as usize];
        let (a, w) = (self.a, self.w);
        let u = match q {
            Quantity::X0 => a * self.drives.zeta0(tau),
            Quantity::X1 => a * x[0],
            Quantity::X2 => a * x[2],
            Quantity::V2 => a * w * x[3],
            Quantity::A2 => a * w * w * dx[3],
            Quantity::NormalForce => self.normal_force,
        };
        self.out[r.chan as usize].push(u);
    }
    fn wants_extremes(&self) -> bool {
        false
    }
}

impl SegmentObserver for Collector<'_> {}

/// The sample plan of one channel.
pub(super) struct Plan {
    pub(super) quantity: Quantity,
    pub(super) sensor: SensorModel,
    pub(super) dt_ns: u64,
    pub(super) shift_s: f64,
    /// Per kept buffer: t0 (ns from the log start) and sample count.
    pub(super) buffers: Vec<(u64, usize)>,
    pub(super) lost: usize,
    pub(super) first_offset_ns: u64,
    /// Request times in seconds from the log start (with fine low-pass
    /// points); `real[i]`: whether request i is a logged sample.
    pub(super) req_t: Vec<f64>,
    pub(super) real: Vec<bool>,
}

pub(super) fn plan_channel(
    cfg: &SynthConfig,
    q: Quantity,
    sensor: SensorModel,
    duration_s: f64,
    rng: &mut Rng,
) -> Plan {
    let mut buffers = Vec::new();
    let mut lost = 0;
    let (dt_ns, shift_s, first_offset_ns);
    if cfg.format.is_table() {
        dt_ns = (1e9 / cfg.table_rate_hz).round() as u64;
        let n = (duration_s * 1e9 / dt_ns as f64).floor() as usize;
        buffers.push((0, n.max(1)));
        shift_s = cfg.csv_shift_s.get(q.name()).copied().unwrap_or(0.0);
        first_offset_ns = 0;
    } else {
        dt_ns = sensor.dt_ns();
        shift_s = 0.0;
        let offset = match sensor.start_offset_ns {
            Some(o) => o,
            None => rng.int(sensor.jitter_ns as i64, dt_ns as i64 - 1) as u64,
        };
        first_offset_ns = offset;
        let n_total = ((duration_s * 1e9 - offset as f64) / dt_ns as f64)
            .ceil()
            .max(1.0) as usize;
        let per = ((sensor.buffer_s * 1e9 / dt_ns as f64).round() as usize).max(1);
        let mut start = 0;
        while start < n_total {
            let n = per.min(n_total - start);
            let nominal = offset + start as u64 * dt_ns;
            let j = if sensor.jitter_ns > 0 {
                rng.int(-(sensor.jitter_ns as i64), sensor.jitter_ns as i64)
            } else {
                0
            };
            let t0 = (nominal as i64 + j).max(0) as u64;
            let lose = rng.uniform() < sensor.p_lost_buffer;
            if lose {
                lost += 1;
            } else {
                buffers.push((t0, n));
            }
            start += n;
        }
    }
    // Request times: the samples, with fine points before each sample of a
    // low-passed channel (first-order hold on a grid of dt/LOWPASS_SUBSTEPS).
    let mut req_t = Vec::new();
    let mut real = Vec::new();
    let dt = dt_ns as f64 * 1e-9;
    let lp_tc = sensor.lowpass_hz.map(|fc| 1.0 / (2.0 * PI * fc));
    let warm = cfg.test.warmup_s();
    let mut prev: Option<f64> = None;
    for &(t0, n) in &buffers {
        for i in 0..n {
            // A delayed channel's value stamped t was measured at t − delay.
            let t = (t0 + i as u64 * dt_ns) as f64 * 1e-9 + shift_s - sensor.delay_s;
            if let Some(tc) = lp_tc {
                let start = match prev {
                    Some(p) => p,
                    // (10 time constants per order: higher orders settle later)
                    None => (t - 10.0 * tc * f64::from(sensor.lowpass_order.max(1))).max(-warm),
                };
                let h = dt / LOWPASS_SUBSTEPS as f64;
                let k = ((t - start) / h).ceil() as usize;
                if prev.is_none() {
                    req_t.push(start);
                    real.push(false);
                }
                for j in 1..k {
                    req_t.push(start + (t - start) * j as f64 / k as f64);
                    real.push(false);
                }
            }
            req_t.push(t);
            real.push(true);
            prev = Some(t);
        }
    }
    Plan {
        quantity: q,
        sensor,
        dt_ns,
        shift_s,
        buffers,
        lost,
        first_offset_ns,
        req_t,
        real,
    }
}

/// The first-order low-pass y' = (u − y)/tc over points (t, u), exact for
/// u linear between points; y starts at u(t_0).
pub(super) fn lowpass(t: &[f64], u: &[f64], tc: f64) -> Vec<f64> {
    let mut y = Vec::with_capacity(u.len());
    let Some(&u0) = u.first() else {
        return y;
    };
    let mut yn = u0;
    y.push(yn);
    for i in 1..u.len() {
        let h = t[i] - t[i - 1];
        if h <= 0.0 {
            y.push(yn);
            continue;
        }
        let alpha = (-h / tc).exp();
        let b = (u[i] - u[i - 1]) / h;
        yn = u[i] - b * tc + alpha * (yn - u[i - 1] + b * tc);
        y.push(yn);
    }
    y
}

pub(super) fn quantise(v: f64, q: f64) -> f64 {
    if q > 0.0 {
        (v / q).round() * q
    } else {
        v
    }
}

/// Runs the virtual rig: the whole log in memory with its truth.
///
/// ```
/// use stickslip::synth::{generate, SynthConfig, TestSpec};
/// // The paper's rig and a static-dynamic pad at 2.2 N, 2 s logged at 2.5 Hz.
/// let cfg = SynthConfig {
///     test: TestSpec::Characteristic { frequency_hz: 2.5, warmup_s: 4.0, duration_s: 2.0 },
///     ..SynthConfig::paper(7)
/// };
/// let log = generate(&cfg)?;
/// // The truth the log was made with travels with it.
/// assert_eq!(log.truth["law"]["family"], "static_dynamic");
/// assert!(!log.channels.is_empty());
/// # Ok::<(), stickslip::synth::SynthError>(())
/// ```
pub fn generate(cfg: &SynthConfig) -> Result<SynthLog, SynthError> {
    cfg.validate()?;
    let rig = &cfg.rig;
    let w = rig.omega_ref();
    let a_true = rig.drive_amplitude_true_m;
    let model = cfg.model();
    let duration_s = cfg.test.duration_s();
    let warm = cfg.test.warmup_s();
    let (mut drives, mut schedule, setpoints) = drives_of(cfg, w);

    // Sample plans, one RNG stream per channel.
    let sensors = cfg.sensors.channels();
    let mut rngs: Vec<Rng> = sensors
        .iter()
        .map(|(q, _)| Rng::with_stream(cfg.seed, 1 + *q as u64))
        .collect();
    let plans: Vec<Plan> = sensors
        .iter()
        .zip(rngs.iter_mut())
        .map(|((q, s), r)| plan_channel(cfg, *q, *s, duration_s, r))
        .collect();

    let requests = merged_requests(&plans, warm, w);
    let total_tau = (warm + duration_s) * w;
    // A CSV column shifted forward can ask past the end: run a bit longer.
    let run_tau = requests.last().map_or(total_tau, |r| r.tau.max(total_tau));
    if let Some(s) = schedule.as_mut() {
        if run_tau > total_tau {
            drives = hold_last_frequency(s, run_tau - total_tau)?;
        }
    }

    let mut col = Collector {
        requests: &requests,
        next: 0,
        out: plans
            .iter()
            .map(|p| Vec::with_capacity(p.req_t.len()))
            .collect(),
        quantities: plans.iter().map(|p| p.quantity).collect(),
        drives: &drives,
        a: a_true,
        w,
        normal_force: cfg.normal_force_n,
        log: (warm * w, (warm + duration_s) * w),
        stick_since: if model.law.is_frictionless() {
            None
        } else {
            Some(0.0)
        },
        stick_time: 0.0,
        events_in_log: 0,
        slid_in_log: false,
        slid_before_log: false,
    };
    let opts = NumericOptions {
        rtol: cfg.rtol,
        atol: cfg.rtol * 1e-2,
    };
    let mut defect_run = None;
    if cfg.defects.any() {
        defect_run = Some(run_defects(cfg, &drives, run_tau, &mut col)?);
    } else {
        let end = run_rig(&model, &drives, schedule.as_ref(), run_tau, opts, &mut col)?;
        match &end.status {
            Status::Completed => {}
            Status::Stopped => {}
            Status::Interrupted(why) | Status::Chatter(why) => {
                return Err(SynthError::Sim(format!(
                    "the motion cannot be simulated to the end of the log: {why}"
                )))
            }
        }
    }
    if col.next != requests.len() {
        return Err(SynthError::Sim(format!(
            "the engine delivered {} of {} samples",
            col.next,
            requests.len()
        )));
    }
    if let Some(s) = col.stick_since.take() {
        col.add_stick(s, f64::INFINITY);
    }
    let exact = std::mem::take(&mut col.out);

    // Sensor models.
    let channels: Vec<SynthChannel> = plans
        .iter()
        .zip(exact.iter())
        .zip(rngs.iter_mut())
        .map(|((plan, u), rng)| sense(plan, u, rng))
        .collect();

    let rig_record = rig_record(cfg);
    let table_rows = if cfg.format.is_table() {
        channels[0].buffers[0].values.len()
    } else {
        0
    };
    let mut truth = truth(
        cfg,
        &model,
        &plans,
        &exact,
        &channels,
        &rig_record,
        &col,
        &setpoints,
    );
    if let (Some(r), Some(o)) = (defect_run, truth.as_object_mut()) {
        o.insert("defects".into(), defects::truth_of(cfg, &r));
    }
    Ok(SynthLog {
        config: cfg.clone(),
        rig_record,
        channels,
        setpoints,
        table_rows,
        truth,
    })
}

/// One merged, sorted request stream (engine τ, clamped at the start) of
/// every channel's sample times.
fn merged_requests(plans: &[Plan], warm: f64, w: f64) -> Vec<Request> {
    let total: usize = plans.iter().map(|p| p.req_t.len()).sum();
    let mut requests = Vec::with_capacity(total);
    for (c, p) in plans.iter().enumerate() {
        for &t in &p.req_t {
            requests.push(Request {
                tau: ((warm + t) * w).max(0.0),
                chan: c as u32,
            });
        }
    }
    requests.sort_by(|a, b| a.tau.total_cmp(&b.tau));
    requests
}

/// Holds the last frequency of a schedule for requests past its end
/// (`past`: how far, in τ) and returns the drives of the longer schedule.
fn hold_last_frequency(s: &mut Schedule, past: f64) -> Result<Drives, SynthError> {
    let eta_last = match s.segments.last() {
        Some(Segment::Dwell { eta, .. }) | Some(Segment::Ramp { eta, .. }) => *eta,
        None => unreachable!("validated schedule"),
    };
    s.segments.push(Segment::Dwell {
        eta: eta_last,
        // (past the last request: a span's end sample is not delivered)
        duration: past + 1.0,
    });
    Ok(Drives(
        s.drives().map_err(|e| SynthError::Sim(e.to_string()))?,
    ))
}

/// Runs the engine over the whole log into `col`: one harmonic piece
/// (event-driven engine for an affine law, numeric otherwise), or the
/// schedule of a sweep.
fn run_rig(
    model: &Model,
    drives: &Drives,
    schedule: Option<&Schedule>,
    run_tau: f64,
    opts: NumericOptions,
    col: &mut Collector<'_>,
) -> Result<RunEnd, SynthError> {
    let sim_err = |e: crate::sim::SimError| SynthError::Sim(e.to_string());
    let end: RunEnd = match schedule {
        None => {
            let (eta, extra) = match &drives.0[0].1 {
                Drive::Harmonic { eta, .. } => (*eta, run_tau - drives.0[0].2),
                _ => unreachable!("a characteristic test drives harmonically"),
            };
            // Extend the single harmonic piece if a request lies past it.
            let dur = drives.0[0].2 + if extra > 0.0 { extra + 1.0 } else { 0.0 };
            if model.law.affine().is_some() {
                Sim::new(model, eta)
                    .map_err(sim_err)?
                    .run_span(Init::rest(), 0.0, 1.0, dur, col)
            } else {
                NumericSim::new(model, drives.0[0].1.clone(), opts)
                    .map_err(sim_err)?
                    .run(Init::rest(), dur, col)
            }
        }
        Some(s) => run_schedule(model, s, Init::rest(), opts, col).map_err(sim_err)?,
    };
    Ok(end)
}

/// The sensor model of one channel over its exact signal `u`: low-pass,
/// gain, offset (drifting linearly with the stamped time), noise,
/// quantisation and dropouts, into its buffers.
fn sense(plan: &Plan, u: &[f64], rng: &mut Rng) -> SynthChannel {
    let s = &plan.sensor;
    let filtered = match s.lowpass_hz {
        Some(fc) if s.lowpass_order >= 2 => {
            super::butterworth::butterworth(&plan.req_t, u, fc, s.lowpass_order)
        }
        Some(fc) => lowpass(&plan.req_t, u, 1.0 / (2.0 * PI * fc)),
        None => u.to_vec(),
    };
    // The noise-free sensed value of each logged sample: gain (with its
    // drift over time from the log start) times the filtered signal, plus
    // the offset.
    let sensed: Vec<f64> = filtered
        .iter()
        .zip(&plan.req_t)
        .zip(&plan.real)
        .filter(|(_, r)| **r)
        .map(|((v, t), _)| {
            let g = if s.gain_drift_per_s != 0.0 {
                s.gain * (1.0 + s.gain_drift_per_s * t)
            } else {
                s.gain
            };
            g * v + s.offset
        })
        .collect();
    let (clip_lo, clip_hi) = clip_levels(s, &sensed);
    let mut real = sensed.iter().copied();
    let mut buffers = Vec::with_capacity(plan.buffers.len());
    let mut nulls = 0;
    let mut burst = 0u32;
    // Correlated noise: n_k = a·n_(k−1) + √(1 − a²)·σ·N(0, 1) (stationary σ).
    let ar = (s.noise_correlation_s > 0.0)
        .then(|| (-(plan.dt_ns as f64 * 1e-9) / s.noise_correlation_s).exp());
    let mut n_prev: Option<f64> = None;
    for &(t0, n) in &plan.buffers {
        let mut values = Vec::with_capacity(n);
        for i in 0..n {
            let y = real.next().expect("one value per sample");
            let t_stamp = (t0 + i as u64 * plan.dt_ns) as f64 * 1e-9 + plan.shift_s;
            let offset = s.offset + s.offset_drift_per_s * t_stamp;
            let noise = if s.noise > 0.0 {
                let e = s.noise * rng.normal();
                match (ar, n_prev) {
                    (Some(a), Some(p)) => a * p + (1.0 - a * a).sqrt() * e,
                    _ => e,
                }
            } else {
                0.0
            };
            n_prev = Some(noise);
            // The offset's drift (0 without one: bit for bit as before).
            let drift = offset - s.offset;
            let v = quantise((y + drift + noise).clamp(clip_lo, clip_hi), s.quant);
            if burst == 0 && s.p_dropout > 0.0 && rng.uniform() < s.p_dropout {
                burst = rng.int(1, i64::from(s.dropout_burst_max)) as u32;
            }
            if burst > 0 {
                burst -= 1;
                nulls += 1;
                values.push(None);
            } else {
                values.push(Some(v));
            }
        }
        buffers.push(Buffer {
            t0_ns: LOG_START_NS + t0,
            values,
        });
    }
    let clipped = buffers
        .iter()
        .flat_map(|b| &b.values)
        .flatten()
        .filter(|v| {
            (clip_lo.is_finite() && **v <= quantise(clip_lo, s.quant))
                || (clip_hi.is_finite() && **v >= quantise(clip_hi, s.quant))
        })
        .count();
    SynthChannel {
        quantity: plan.quantity,
        sensor: *s,
        clip: (clip_lo, clip_hi, clipped),
        dt_ns: plan.dt_ns,
        shift_s: plan.shift_s,
        buffers,
        lost_buffers: plan.lost,
        null_samples: nulls,
        first_sample_offset_ns: plan.first_offset_ns,
    }
}

/// The saturation levels of a channel (−∞/+∞: none) from its absolute
/// levels and its fractions of the swing of the noise-free `sensed`
/// values, the tighter of the two on each side.
pub(super) fn clip_levels(s: &SensorModel, sensed: &[f64]) -> (f64, f64) {
    let (mut lo, mut hi) = (
        s.clip_low.unwrap_or(f64::NEG_INFINITY),
        s.clip_high.unwrap_or(f64::INFINITY),
    );
    if s.clip_low_fraction.is_some() || s.clip_high_fraction.is_some() {
        let (mn, mx) = sensed
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
                (a.min(*v), b.max(*v))
            });
        if mx >= mn {
            let mid = 0.5 * (mx + mn);
            if let Some(f) = s.clip_high_fraction {
                hi = hi.min(mid + f * (mx - mid));
            }
            if let Some(f) = s.clip_low_fraction {
                lo = lo.max(mid - f * (mid - mn));
            }
        }
    }
    (lo, hi)
}
