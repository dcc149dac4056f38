//! Running the virtual rig: the exact trajectory sampled by each
//! channel's sensor model, into DAQ buffers or table rows.
//!
//! Everything per sample is streamed through the engine's observer: each
//! channel's request times (its samples, with the fine low-pass points
//! before each sample of a low-passed channel) are generated lazily
//! ([`ChannelRequests`]) and merged into one time-ordered stream
//! ([`RequestMerge`], a k-way merge that breaks ties by channel order: the
//! order a stable sort of every channel's request times gives). Each exact
//! value goes through its channel's low-pass, gain and offset at once
//! ([`Sink`]); only the noise-free sensed value of each logged sample is
//! kept, in place in the channel's buffers, and the truth's amplitudes are
//! accumulated on the way ([`ExactSummary`]). After the run, noise,
//! saturation, quantisation and dropouts are applied in place (clip levels
//! from fractions of the swing need the whole log), with the RNG draws in
//! the order they always had.

use super::butterworth::Butterworth;
use super::*;

/// One request of a channel: its time in seconds from the log start and
/// whether it is a logged sample (else a fine low-pass point).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Request {
    /// Seconds from the log start (the time the value is measured at).
    pub(super) t: f64,
    /// A logged sample (true) or a fine point of the low-pass (false).
    pub(super) real: bool,
}

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
}

impl Plan {
    /// The time (s from the log start) at which sample `i` of the buffer
    /// starting `t0` ns after the log start is measured: a delayed
    /// channel's value stamped t was measured at t − delay.
    fn sample_t(&self, t0: u64, i: usize) -> f64 {
        (t0 + i as u64 * self.dt_ns) as f64 * 1e-9 + self.shift_s - self.sensor.delay_s
    }

    /// The time of the channel's last request (its last logged sample).
    pub(super) fn last_t(&self) -> Option<f64> {
        let &(t0, n) = self.buffers.last()?;
        Some(self.sample_t(t0, n - 1))
    }

    /// The channel's requests in time order, generated lazily (`warm`:
    /// the warm-up in s, before which a low-pass never starts).
    pub(super) fn requests(&self, warm: f64) -> ChannelRequests<'_> {
        let dt = self.dt_ns as f64 * 1e-9;
        ChannelRequests {
            plan: self,
            tc: self.sensor.lowpass_hz.map(|fc| 1.0 / (2.0 * PI * fc)),
            h: dt / LOWPASS_SUBSTEPS as f64,
            warm,
            b: 0,
            i: 0,
            prev: None,
            fine: None,
        }
    }
}

/// The fine points still to come before a logged sample of a low-passed
/// channel: `start + (t − start)·j/k` for j up to k − 1 (and `start`
/// itself first, at j = 0, before the channel's first sample), then t.
#[derive(Clone, Copy)]
struct Fine {
    start: f64,
    t: f64,
    k: usize,
    j: usize,
}

/// The request times of one channel in time order, one at a time: the
/// logged samples of its kept buffers and, for a low-passed channel, the
/// points of a grid [`LOWPASS_SUBSTEPS`] times finer before each sample
/// (first-order hold), starting 10 time constants per filter order before
/// the first sample (or at the rig's start).
pub(super) struct ChannelRequests<'a> {
    plan: &'a Plan,
    /// The first-order time constant 1/(2π f_c) of a low-passed channel.
    tc: Option<f64>,
    /// The fine grid's step (s).
    h: f64,
    warm: f64,
    /// The next sample: buffer `b`, sample `i` in it.
    b: usize,
    i: usize,
    /// The previous logged sample's time.
    prev: Option<f64>,
    fine: Option<Fine>,
}

impl Iterator for ChannelRequests<'_> {
    type Item = Request;

    fn next(&mut self) -> Option<Request> {
        if let Some(f) = &mut self.fine {
            let r = if f.j == 0 {
                f.j = 1;
                Request {
                    t: f.start,
                    real: false,
                }
            } else if f.j < f.k {
                let j = f.j;
                f.j += 1;
                Request {
                    t: f.start + (f.t - f.start) * j as f64 / f.k as f64,
                    real: false,
                }
            } else {
                let t = f.t;
                self.fine = None;
                Request { t, real: true }
            };
            return Some(r);
        }
        let plan = self.plan;
        let t0 = loop {
            let &(t0, n) = plan.buffers.get(self.b)?;
            if self.i < n {
                break t0;
            }
            self.b += 1;
            self.i = 0;
        };
        let t = plan.sample_t(t0, self.i);
        self.i += 1;
        let prev = self.prev.replace(t);
        let Some(tc) = self.tc else {
            return Some(Request { t, real: true });
        };
        let start = match prev {
            Some(p) => p,
            // (10 time constants per order: higher orders settle later)
            None => (t - 10.0 * tc * f64::from(plan.sensor.lowpass_order.max(1))).max(-self.warm),
        };
        let k = ((t - start) / self.h).ceil() as usize;
        self.fine = Some(Fine {
            start,
            t,
            k,
            j: if prev.is_none() { 0 } else { 1 },
        });
        self.next()
    }
}

/// Engine time τ of a request at `t` s from the log start (clamped at the
/// rig's start).
fn tau_of(t: f64, warm: f64, w: f64) -> f64 {
    ((warm + t) * w).max(0.0)
}

/// Every channel's requests merged into one stream in engine time: the
/// smallest τ first, ties in channel order (within a channel, request
/// order), which is the order a stable sort of the concatenated requests
/// by τ gives. Holds one pending request per channel.
pub(super) struct RequestMerge<'a> {
    chans: Vec<ChannelRequests<'a>>,
    /// Per channel: its next request and that request's τ.
    heads: Vec<Option<(f64, Request)>>,
    /// The channel whose head comes next.
    best: Option<usize>,
    warm: f64,
    w: f64,
}

impl<'a> RequestMerge<'a> {
    /// The merged requests of `plans` (`warm`: warm-up in s, `w`: ω).
    pub(super) fn new(plans: &'a [Plan], warm: f64, w: f64) -> Self {
        let mut chans: Vec<ChannelRequests<'a>> = plans.iter().map(|p| p.requests(warm)).collect();
        let heads = chans
            .iter_mut()
            .map(|c| c.next().map(|r| (tau_of(r.t, warm, w), r)))
            .collect();
        let mut m = Self {
            chans,
            heads,
            best: None,
            warm,
            w,
        };
        m.find_best();
        m
    }

    fn find_best(&mut self) {
        let mut best: Option<(usize, f64)> = None;
        for (c, h) in self.heads.iter().enumerate() {
            if let Some((tau, _)) = h {
                if best.is_none_or(|(_, b)| tau.total_cmp(&b).is_lt()) {
                    best = Some((c, *tau));
                }
            }
        }
        self.best = best.map(|(c, _)| c);
    }

    /// The τ of the next request, if any.
    pub(super) fn peek(&self) -> Option<f64> {
        self.best.and_then(|c| self.heads[c].map(|(tau, _)| tau))
    }

    /// Takes the next request: its channel and the request.
    pub(super) fn pop(&mut self) -> Option<(usize, Request)> {
        let c = self.best?;
        let (_, r) = self.heads[c]?;
        let (warm, w) = (self.warm, self.w);
        self.heads[c] = self.chans[c].next().map(|r| (tau_of(r.t, warm, w), r));
        self.find_best();
        Some((c, r))
    }

    /// How many requests are still to come.
    pub(super) fn remaining(&mut self) -> usize {
        let pending = self.heads.iter().filter(|h| h.is_some()).count();
        pending + self.chans.iter_mut().map(|c| c.count()).sum::<usize>()
    }
}

/// The first-order low-pass y' = (u − y)/tc, fed one point (t, u) at a
/// time, exact for u linear between points; y starts at the first u.
pub(super) struct FirstOrder {
    tc: f64,
    /// The previous point (t, u) and the output there.
    prev: Option<(f64, f64, f64)>,
}

impl FirstOrder {
    /// A filter with time constant `tc` (s), not yet started.
    pub(super) fn new(tc: f64) -> Self {
        Self { tc, prev: None }
    }

    /// Feeds (t, u) and returns y(t).
    pub(super) fn push(&mut self, t: f64, u: f64) -> f64 {
        let y = match self.prev {
            None => u,
            Some((tp, up, yn)) => {
                let h = t - tp;
                if h <= 0.0 {
                    yn
                } else {
                    let tc = self.tc;
                    let alpha = (-h / tc).exp();
                    let b = (u - up) / h;
                    u - b * tc + alpha * (yn - up + b * tc)
                }
            }
        };
        self.prev = Some((t, u, y));
        y
    }
}

/// The first-order low-pass over a whole series (points (t, u)).
#[cfg(test)]
pub(super) fn lowpass(t: &[f64], u: &[f64], tc: f64) -> Vec<f64> {
    let mut f = FirstOrder::new(tc);
    t.iter().zip(u).map(|(t, u)| f.push(*t, *u)).collect()
}

/// A channel's low-pass.
enum Filter {
    /// None: the exact value.
    Through,
    /// First order.
    First(FirstOrder),
    /// Butterworth of order ≥ 2.
    Butter(Butterworth),
}

impl Filter {
    fn of(s: &SensorModel) -> Self {
        match s.lowpass_hz {
            Some(fc) if s.lowpass_order >= 2 => {
                Filter::Butter(Butterworth::new(fc, s.lowpass_order))
            }
            Some(fc) => Filter::First(FirstOrder::new(1.0 / (2.0 * PI * fc))),
            None => Filter::Through,
        }
    }

    fn push(&mut self, t: f64, u: f64) -> f64 {
        match self {
            Filter::Through => u,
            Filter::First(f) => f.push(t, u),
            Filter::Butter(f) => f.push(t, u),
        }
    }
}

/// Where one channel's values go while the engine runs: its low-pass and
/// its buffers (allocated up front, one per kept buffer of the plan),
/// filled in order with the noise-free sensed value of each logged sample.
pub(super) struct Sink<'a> {
    plan: &'a Plan,
    filter: Filter,
    buffers: Vec<Buffer>,
    /// The buffer being filled.
    b: usize,
}

impl<'a> Sink<'a> {
    fn new(plan: &'a Plan) -> Self {
        Self {
            plan,
            filter: Filter::of(&plan.sensor),
            buffers: plan
                .buffers
                .iter()
                .map(|&(t0, n)| Buffer {
                    t0_ns: LOG_START_NS + t0,
                    values: Vec::with_capacity(n),
                })
                .collect(),
            b: 0,
        }
    }

    /// Feeds the exact value `u` of request `r`; a logged sample keeps the
    /// noise-free sensed value: gain (with its drift over time from the log
    /// start) times the filtered signal, plus the offset.
    fn push(&mut self, r: Request, u: f64) {
        let v = self.filter.push(r.t, u);
        if !r.real {
            return;
        }
        let s = &self.plan.sensor;
        let g = if s.gain_drift_per_s != 0.0 {
            s.gain * (1.0 + s.gain_drift_per_s * r.t)
        } else {
            s.gain
        };
        while self.buffers[self.b].values.len() == self.plan.buffers[self.b].1 {
            self.b += 1;
        }
        self.buffers[self.b].values.push(Some(g * v + s.offset));
    }
}

/// The observer: hands out the merged request times, passes each
/// channel's exact signal through its [`Sink`], accumulates the truth's
/// exact summaries and tracks the contact mode over the log.
pub(super) struct Collector<'a> {
    pub(super) merge: RequestMerge<'a>,
    pub(super) sinks: Vec<Sink<'a>>,
    /// Requests delivered so far.
    pub(super) delivered: usize,
    pub(super) exact: ExactSummary,
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
        self.merge.peek()
    }
    fn sample(&mut self, tau: f64, x: &[f64; 4], dx: &[f64; 4]) {
        let (c, r) = self.merge.pop().expect("a sample the collector asked for");
        self.delivered += 1;
        let sink = &mut self.sinks[c];
        let q = sink.plan.quantity;
        let (a, w) = (self.a, self.w);
        let u = match q {
            Quantity::X0 => a * self.drives.zeta0(tau),
            Quantity::X1 => a * x[0],
            Quantity::X2 => a * x[2],
            Quantity::V2 => a * w * x[3],
            Quantity::A2 => a * w * w * dx[3],
            Quantity::NormalForce => self.normal_force,
        };
        sink.push(r, u);
        if r.real {
            self.exact.push(q, r.t, u);
        }
    }
    fn wants_extremes(&self) -> bool {
        false
    }
}

impl SegmentObserver for Collector<'_> {}

/// The sample plan of one channel: its buffers (kept and lost), drawn
/// from its RNG stream.
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
    Plan {
        quantity: q,
        sensor,
        dt_ns,
        shift_s,
        buffers,
        lost,
        first_offset_ns,
    }
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

    let total_tau = (warm + duration_s) * w;
    // A CSV column shifted forward can ask past the end: run a bit longer.
    let run_tau = plans
        .iter()
        .filter_map(Plan::last_t)
        .map(|t| tau_of(t, warm, w))
        .reduce(f64::max)
        .map_or(total_tau, |tau| tau.max(total_tau));
    if let Some(s) = schedule.as_mut() {
        if run_tau > total_tau {
            drives = hold_last_frequency(s, run_tau - total_tau)?;
        }
    }

    let mut col = Collector {
        merge: RequestMerge::new(&plans, warm, w),
        sinks: plans.iter().map(Sink::new).collect(),
        delivered: 0,
        exact: ExactSummary::new(cfg, &plans, &setpoints),
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
    let remaining = col.merge.remaining();
    if remaining > 0 {
        return Err(SynthError::Sim(format!(
            "the engine delivered {} of {} samples",
            col.delivered,
            col.delivered + remaining
        )));
    }
    if let Some(s) = col.stick_since.take() {
        col.add_stick(s, f64::INFINITY);
    }
    let sinks = std::mem::take(&mut col.sinks);

    // Sensor models: noise, saturation, quantisation, dropouts.
    let channels: Vec<SynthChannel> = sinks
        .into_iter()
        .zip(rngs.iter_mut())
        .map(|(sink, rng)| sense(sink.plan, sink.buffers, rng))
        .collect();

    let rig_record = rig_record(cfg);
    let table_rows = if cfg.format.is_table() {
        channels[0].buffers[0].values.len()
    } else {
        0
    };
    let mut truth = truth(cfg, &model, &channels, &rig_record, &col, &setpoints);
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

/// The rest of the sensor model of one channel, over the noise-free
/// sensed values its [`Sink`] left in `buffers`: the offset's drift with
/// the stamped time, noise, saturation, quantisation and dropouts, in
/// place.
fn sense(plan: &Plan, mut buffers: Vec<Buffer>, rng: &mut Rng) -> SynthChannel {
    let s = &plan.sensor;
    const SENSED: &str = "the engine delivered every sample";
    let (clip_lo, clip_hi) = clip_levels(
        s,
        buffers
            .iter()
            .flat_map(|b| &b.values)
            .map(|v| v.expect(SENSED)),
    );
    let mut nulls = 0;
    let mut burst = 0u32;
    // Correlated noise: n_k = a·n_(k−1) + √(1 − a²)·σ·N(0, 1) (stationary σ).
    let ar = (s.noise_correlation_s > 0.0)
        .then(|| (-(plan.dt_ns as f64 * 1e-9) / s.noise_correlation_s).exp());
    let mut n_prev: Option<f64> = None;
    for (buffer, &(t0, n)) in buffers.iter_mut().zip(&plan.buffers) {
        assert_eq!(buffer.values.len(), n, "one value per sample");
        for (i, value) in buffer.values.iter_mut().enumerate() {
            let y = value.expect(SENSED);
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
                *value = None;
            } else {
                *value = Some(v);
            }
        }
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
/// values (in sample order), the tighter of the two on each side.
pub(super) fn clip_levels(s: &SensorModel, sensed: impl Iterator<Item = f64>) -> (f64, f64) {
    let (mut lo, mut hi) = (
        s.clip_low.unwrap_or(f64::NEG_INFINITY),
        s.clip_high.unwrap_or(f64::INFINITY),
    );
    if s.clip_low_fraction.is_some() || s.clip_high_fraction.is_some() {
        let (mn, mx) = sensed.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The request times of one channel as they were materialised before
    /// the stream (`req_t`, `real`): the reference for [`ChannelRequests`].
    fn materialised(plan: &Plan, warm: f64) -> Vec<Request> {
        let mut out = Vec::new();
        let dt = plan.dt_ns as f64 * 1e-9;
        let lp_tc = plan.sensor.lowpass_hz.map(|fc| 1.0 / (2.0 * PI * fc));
        let mut prev: Option<f64> = None;
        for &(t0, n) in &plan.buffers {
            for i in 0..n {
                let t =
                    (t0 + i as u64 * plan.dt_ns) as f64 * 1e-9 + plan.shift_s - plan.sensor.delay_s;
                if let Some(tc) = lp_tc {
                    let order = f64::from(plan.sensor.lowpass_order.max(1));
                    let start = match prev {
                        Some(p) => p,
                        None => (t - 10.0 * tc * order).max(-warm),
                    };
                    let h = dt / LOWPASS_SUBSTEPS as f64;
                    let k = ((t - start) / h).ceil() as usize;
                    if prev.is_none() {
                        out.push(Request {
                            t: start,
                            real: false,
                        });
                    }
                    for j in 1..k {
                        out.push(Request {
                            t: start + (t - start) * j as f64 / k as f64,
                            real: false,
                        });
                    }
                }
                out.push(Request { t, real: true });
                prev = Some(t);
            }
        }
        out
    }

    /// The lazy streams are the requests the collector used to
    /// materialise: per channel the same times bit for bit, and merged the
    /// stable sort by τ of all channels' requests (ties in channel order),
    /// with a first-order, a Butterworth and an unfiltered channel, lost
    /// buffers, a delay that reaches before the rig's start (τ clamped at
    /// 0, where ties occur) and both table and DAQ plans.
    #[test]
    fn merged_stream_is_the_stable_sort_of_every_channel_request() {
        // (warm-up, x2's delay, format, whether τ ties occur)
        for (warm, delay, format, ties) in [
            (0.0, 0.02, LogFormat::Mcap, true),
            (1.0, -0.01, LogFormat::Mcap, false),
            (0.0, 0.0, LogFormat::Csv, true),
        ] {
            let mut cfg = SynthConfig {
                test: TestSpec::Characteristic {
                    frequency_hz: 1.72,
                    warmup_s: warm,
                    duration_s: 1.5,
                },
                format,
                ..SynthConfig::paper(3)
            };
            cfg.sensors.x1.p_lost_buffer = 0.3;
            cfg.sensors.x2.delay_s = delay;
            cfg.sensors.x0.lowpass_hz = Some(120.0);
            cfg.sensors.x0.lowpass_order = 3;
            let w = cfg.rig.omega_ref();
            let plans: Vec<Plan> = cfg
                .sensors
                .channels()
                .into_iter()
                .map(|(q, s)| {
                    let mut rng = Rng::with_stream(cfg.seed, 1 + q as u64);
                    plan_channel(&cfg, q, s, 1.5, &mut rng)
                })
                .collect();
            let mut all = Vec::new();
            for (c, p) in plans.iter().enumerate() {
                let lazy: Vec<Request> = p.requests(warm).collect();
                let reference = materialised(p, warm);
                assert_eq!(lazy.len(), reference.len(), "{:?}", p.quantity);
                for (a, b) in lazy.iter().zip(&reference) {
                    assert_eq!((a.t.to_bits(), a.real), (b.t.to_bits(), b.real));
                }
                let logged: usize = p.buffers.iter().map(|b| b.1).sum();
                assert_eq!(lazy.iter().filter(|r| r.real).count(), logged);
                assert_eq!(p.last_t(), lazy.last().map(|r| r.t));
                all.extend(reference.into_iter().map(|r| (tau_of(r.t, warm, w), c, r)));
            }
            all.sort_by(|a, b| a.0.total_cmp(&b.0));
            let mut merge = RequestMerge::new(&plans, warm, w);
            let mut merged = Vec::new();
            while let Some(tau) = merge.peek() {
                let (c, r) = merge.pop().expect("peeked");
                merged.push((tau, c, r));
            }
            assert_eq!(merged.len(), all.len());
            for (a, b) in merged.iter().zip(&all) {
                assert_eq!(
                    (a.0.to_bits(), a.1, a.2.t.to_bits()),
                    (b.0.to_bits(), b.1, b.2.t.to_bits())
                );
            }
            assert_eq!(all.windows(2).any(|p| p[0].0 == p[1].0), ties);
            assert_eq!(merge.remaining(), 0);
        }
    }
}
