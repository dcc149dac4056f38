//! The `synth` job: the virtual rig. Turns SI options ([`SynthJob`]) into
//! a checked [`SynthConfig`] ([`SynthJob::config`]), runs
//! [`synth::generate`] and writes the log (and `truth.json` beside it)
//! through the write transaction ([`crate::io::txn`]), with its JSON
//! object ([`SynthJson`]).

use super::Progress;
use crate::io::Output;
use crate::model::LawKind;
use crate::synth::{
    self, FrictionSpec, LogFormat, PhysicsDefects, RigSpec, Sensors, SynthConfig, TestSpec,
};
use serde::Serialize;
use serde_json::Value;
use std::path::{Path, PathBuf};

/// The test the virtual rig runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SynthTest {
    /// One drive frequency after a warm-up.
    Characteristic,
    /// Stepped frequency sweep (dwells, 0.5 s ramps).
    Stepped,
    /// Continuous linear chirp.
    Continuous,
}

/// One synthetic log: the rig, law, test, sensors and output, in SI units
/// (the `synth` command's options).
#[derive(Debug, Clone, PartialEq)]
pub struct SynthJob {
    /// The log to write (.mcap, .csv or .parquet).
    pub out: PathBuf,
    /// The format asked for (None: from the extension of `out`, which must
    /// agree with it otherwise).
    pub format: Option<LogFormat>,
    /// The test.
    pub test: SynthTest,
    /// Normal force at the friction member (N).
    pub normal_force_n: f64,
    /// Friction law family.
    pub law: LawKind,
    /// Static friction coefficient (Rs = μs·N unless `rs_n`).
    pub mu_s: f64,
    /// Dynamic friction coefficient (Rd = μd·N unless `rd_n`).
    pub mu_d: f64,
    /// Static friction force Rs (N).
    pub rs_n: Option<f64>,
    /// Dynamic friction force Rd (N).
    pub rd_n: Option<f64>,
    /// Slope a of the characteristic (N s/m; None: the family's default).
    pub slope_n_s_per_m: Option<f64>,
    /// Velocity scale v_s (m/s) of a law that has one.
    pub v_s_m_per_s: f64,
    /// M1 (kg).
    pub m1_kg: f64,
    /// M2 (kg).
    pub m2_kg: f64,
    /// K1 (N/m).
    pub k1_n_per_m: f64,
    /// K2 (N/m).
    pub k2_n_per_m: f64,
    /// Damping d (N s/m; None: D = 0.003).
    pub d_n_s_per_m: Option<f64>,
    /// Nominal drive amplitude A (m).
    pub amplitude_m: f64,
    /// True drive amplitude (m; None: the nominal one).
    pub true_amplitude_m: Option<f64>,
    /// Drive frequency of a characteristic test (Hz).
    pub frequency_hz: f64,
    /// Unlogged warm-up of a characteristic test (s).
    pub warmup_s: f64,
    /// Logged duration of a characteristic test (s).
    pub duration_s: f64,
    /// Setpoints of a stepped sweep (Hz; empty: 11 from 0.9 to 3.4).
    pub setpoints_hz: Vec<f64>,
    /// Dwell per setpoint (s; one value or one per setpoint).
    pub dwell_s: Vec<f64>,
    /// Continuous sweep: start frequency (Hz).
    pub from_hz: f64,
    /// Continuous sweep: end frequency (Hz).
    pub to_hz: f64,
    /// Continuous sweep: chirp duration (s).
    pub sweep_s: f64,
    /// Seed of every random choice.
    pub seed: u64,
    /// No accelerometer channel.
    pub no_accelerometer: bool,
    /// Ideal sensors (no noise, quantisation, errors, filters, losses).
    pub ideal_sensors: bool,
    /// Sensor models from this JSON file (the [`Sensors`] structure).
    pub sensors: Option<PathBuf>,
    /// Channel delays, each `CHANNEL=SECONDS` (override the models'
    /// `delay_s`).
    pub channel_delay: Vec<String>,
    /// Linear offset drifts, each `CHANNEL=SI_PER_SECOND` (override the
    /// models' `offset_drift_per_s`).
    pub offset_drift: Vec<String>,
    /// Row rate of CSV/Parquet tables (Hz).
    pub table_rate_hz: f64,
    /// CSV only: time shift of the drive column (s), written to the map.
    pub csv_drive_shift_s: Option<f64>,
    /// High-side saturations, each `CHANNEL=FRACTION` of the swing.
    pub clip: Vec<String>,
    /// Low-side saturations, each `CHANNEL=FRACTION` of the swing.
    pub clip_low: Vec<String>,
    /// Test defect: relative friction change along the stroke (1/m).
    pub stroke_gradient_per_m: f64,
    /// Test defect: hardening coupling spring β (1/m²).
    pub hardening_per_m2: f64,
    /// Test defect: static threshold in the negative direction (N).
    pub rs_minus_n: Option<f64>,
    /// Test defect: dynamic level in the negative direction (N).
    pub rd_minus_n: Option<f64>,
    /// Tangential contact stiffness kt (N/m; None: a rigid stick).
    pub contact_stiffness_n_per_m: Option<f64>,
    /// Calibrated position zeros: the x0, x1, x2 offsets drawn within
    /// this bound (m) and the bound written to the rig record.
    pub position_zero_uncertainty_m: Option<f64>,
    /// Replace an existing log at `out` (and its channel map).
    pub force: bool,
}

/// The `synth --json` object.
#[derive(Debug, Clone, Serialize)]
pub struct SynthJson {
    /// The log written.
    pub out: String,
    /// Its channel map (CSV), else `null`.
    pub map: Option<String>,
    /// The truth file.
    pub truth: String,
    /// The format ([`LogFormat::as_str`]).
    pub format: &'static str,
    /// The test (the truth entry's `test`).
    pub test: Value,
    /// Bytes of the log.
    pub bytes: u64,
    /// Logged seconds (the truth entry's `duration_s`).
    pub duration_s: Value,
    /// The seed.
    pub seed: u64,
    /// The channels (the truth entry's `channels`).
    pub channels: Value,
    /// Fraction of the logged time M2 sticks (the truth entry's).
    pub stick_fraction: Value,
    /// Stick-slip events (the truth entry's `n_stick_slip_events`).
    pub n_stick_slip_events: Value,
    /// DAQ buffers lost, over every channel.
    pub lost_buffers: usize,
    /// Null samples, over every channel.
    pub null_samples: usize,
}

/// What [`run_synth`] produced.
#[derive(Debug)]
pub struct SynthOutcome {
    /// The configuration that was run.
    pub config: SynthConfig,
    /// The files written.
    pub written: synth::Written,
    /// The JSON result.
    pub json: SynthJson,
}

fn input_err(path: &Path, msg: impl Into<String>) -> crate::Error {
    crate::Error::Input {
        path: path.to_path_buf(),
        msg: msg.into(),
    }
}

/// The `--format` name of a log format.
pub fn format_flag(f: LogFormat) -> &'static str {
    match f {
        LogFormat::Mcap => "mcap",
        LogFormat::McapLz4 => "mcap-lz4",
        LogFormat::McapPlain => "mcap-plain",
        LogFormat::Csv => "csv",
        LogFormat::Parquet => "parquet",
    }
}

/// The log format of `out`: `asked`, which must agree with the extension,
/// or the extension's.
pub fn log_format(asked: Option<LogFormat>, out: &Path) -> crate::Result<LogFormat> {
    let ext = out
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    let format = match (asked, ext.as_str()) {
        (Some(LogFormat::Mcap), "mcap") | (None, "mcap") => LogFormat::Mcap,
        (Some(LogFormat::McapLz4), "mcap") => LogFormat::McapLz4,
        (Some(LogFormat::McapPlain), "mcap") => LogFormat::McapPlain,
        (Some(LogFormat::Csv), "csv") | (None, "csv") => LogFormat::Csv,
        (Some(LogFormat::Parquet), "parquet") | (None, "parquet") => LogFormat::Parquet,
        (None, _) => {
            return Err(input_err(
                out,
                "unknown output type: give a .mcap, .csv or .parquet file (or --format)",
            ))
        }
        (Some(f), _) => {
            return Err(input_err(
                out,
                format!(
                    "--format {} needs a .{} file",
                    format_flag(f),
                    match f {
                        LogFormat::Csv => "csv",
                        LogFormat::Parquet => "parquet",
                        _ => "mcap",
                    }
                ),
            ))
        }
    };
    Ok(format)
}

/// `NAME=NUMBER` (a finite number) as its two parts.
fn parse_channel_value(item: &str) -> Option<(&str, f64)> {
    let (name, value) = item.split_once('=')?;
    let v: f64 = value.trim().parse().ok()?;
    v.is_finite().then_some((name.trim(), v))
}

impl SynthJob {
    /// The friction law in SI (Rs = μs·N unless given, Rd likewise).
    fn friction(&self) -> FrictionSpec {
        let n = self.normal_force_n;
        let rs = self.rs_n.unwrap_or(self.mu_s * n);
        let rd_given = self.rd_n.unwrap_or(self.mu_d * n);
        FrictionSpec::from_si(&self.law.family().synth_law(
            rs,
            rd_given,
            self.slope_n_s_per_m,
            self.v_s_m_per_s,
        ))
    }

    /// The test the rig runs.
    fn test_spec(&self) -> TestSpec {
        match self.test {
            SynthTest::Characteristic => TestSpec::Characteristic {
                frequency_hz: self.frequency_hz,
                warmup_s: self.warmup_s,
                duration_s: self.duration_s,
            },
            SynthTest::Stepped => {
                let mut t = TestSpec::stepped(0.9, 3.4, 11, 15.0);
                if let TestSpec::Stepped {
                    setpoints_hz,
                    dwell_s,
                    ..
                } = &mut t
                {
                    if !self.setpoints_hz.is_empty() {
                        *setpoints_hz = self.setpoints_hz.clone();
                    }
                    *dwell_s = self.dwell_s.clone();
                }
                t
            }
            SynthTest::Continuous => TestSpec::Continuous {
                from_hz: self.from_hz,
                to_hz: self.to_hz,
                sweep_s: self.sweep_s,
                hold_before_s: 10.0,
                hold_after_s: 5.0,
            },
        }
    }

    /// The sensor models: from `sensors`, ideal, or typical (slower
    /// channels for the long sweeps); then the clips, delays and drifts.
    fn sensor_models(&self) -> crate::Result<Sensors> {
        let mut sensors = match &self.sensors {
            Some(p) => {
                let text = crate::io::paths::read_small_text(p, "sensor set", 4_000_000)?;
                serde_json::from_str::<Sensors>(&text)
                    .map_err(|e| input_err(p, format!("not a sensor set: {e}")))?
            }
            None if self.ideal_sensors => Sensors::ideal(),
            None => {
                let mut s = Sensors::typical(self.seed);
                if self.test != SynthTest::Characteristic {
                    // Sweeps are long: slower position and velocity channels.
                    s.x0.rate_hz = 250.0;
                    for m in [&mut s.x1, &mut s.x2, &mut s.v2] {
                        m.rate_hz = 500.0;
                    }
                }
                s
            }
        };
        if self.no_accelerometer {
            sensors.a2 = None;
        }
        self.apply_clips(&mut sensors)?;
        self.apply_channel_values(&mut sensors)?;
        if let Some(e) = self.position_zero_uncertainty_m {
            if !(e.is_finite() && e >= 0.0) {
                return Err(input_err(
                    &self.out,
                    format!("--position-zero-uncertainty-m {e}: must be finite and >= 0"),
                ));
            }
            // Calibrated zeros: each position offset uniform within ±e,
            // on a stream of its own (the other draws unchanged).
            let mut r = crate::stats::Rng::with_stream(self.seed, 0x2E20_CA1B);
            for m in [&mut sensors.x0, &mut sensors.x1, &mut sensors.x2] {
                m.offset = r.range(-e, e);
            }
        }
        Ok(sensors)
    }

    /// `clip` and `clip_low` (`CHANNEL=FRACTION`) on the sensor models.
    fn apply_clips(&self, sensors: &mut Sensors) -> crate::Result<()> {
        for (specs, high) in [(&self.clip, true), (&self.clip_low, false)] {
            for spec in specs {
                let flag = if high { "--clip" } else { "--clip-low" };
                let bad = |why: &str| {
                    input_err(
                        &self.out,
                        format!("{flag} {spec:?}: {why} (expected CHANNEL=FRACTION, e.g. x1=0.85)"),
                    )
                };
                let (name, frac) = spec.split_once('=').ok_or_else(|| bad("no '='"))?;
                let f: f64 = frac
                    .trim()
                    .parse()
                    .map_err(|_| bad("the fraction is not a number"))?;
                let model = sensors
                    .channel_mut(name.trim())
                    .ok_or_else(|| bad("unknown channel"))?
                    .ok_or_else(|| bad("that channel is not written"))?;
                if high {
                    model.clip_high_fraction = Some(f);
                } else {
                    model.clip_low_fraction = Some(f);
                }
            }
        }
        Ok(())
    }

    /// `channel_delay` and `offset_drift` (`CHANNEL=NUMBER`) on the sensor
    /// models.
    fn apply_channel_values(&self, sensors: &mut Sensors) -> crate::Result<()> {
        for (list, flag, delay) in [
            (&self.channel_delay, "--channel-delay-s", true),
            (&self.offset_drift, "--offset-drift-per-s", false),
        ] {
            for item in list {
                let (name, value) = parse_channel_value(item).ok_or_else(|| {
                    input_err(
                        &self.out,
                        format!("{flag}: expected CHANNEL=NUMBER, got `{item}`"),
                    )
                })?;
                let model = sensors
                    .channel_mut(name)
                    .ok_or_else(|| {
                        input_err(
                            &self.out,
                            format!(
                                "{flag}: unknown channel `{name}` (x0, x1, x2, v2, a2, normal_force)"
                            ),
                        )
                    })?
                    .ok_or_else(|| {
                        input_err(&self.out, format!("{flag}: the log has no channel {name}"))
                    })?;
                if delay {
                    model.delay_s = value;
                } else {
                    model.offset_drift_per_s = value;
                }
            }
        }
        Ok(())
    }

    /// The checked configuration this job describes.
    pub fn config(&self) -> crate::Result<SynthConfig> {
        let out = &self.out;
        let format = log_format(self.format, out)?;
        let friction = self.friction();
        let d = self
            .d_n_s_per_m
            .unwrap_or(0.003 * (self.k2_n_per_m * self.m2_kg).abs().sqrt());
        let rig = RigSpec {
            m1_kg: self.m1_kg,
            m2_kg: self.m2_kg,
            k1_n_per_m: self.k1_n_per_m,
            k2_n_per_m: self.k2_n_per_m,
            d_n_s_per_m: d,
            drive_amplitude_nominal_m: self.amplitude_m,
            drive_amplitude_true_m: self.true_amplitude_m.unwrap_or(self.amplitude_m),
        };
        let test = self.test_spec();
        let sensors = self.sensor_models()?;
        let mut csv_shift_s = std::collections::BTreeMap::new();
        if let Some(s) = self.csv_drive_shift_s {
            if format != LogFormat::Csv {
                return Err(input_err(
                    out,
                    "--csv-drive-shift-s applies to CSV output only",
                ));
            }
            csv_shift_s.insert("x0".to_string(), s);
        }
        let cfg = SynthConfig {
            rig,
            friction,
            normal_force_n: self.normal_force_n,
            test,
            sensors,
            seed: self.seed,
            format,
            table_rate_hz: self.table_rate_hz,
            csv_shift_s,
            rtol: 1e-10,
            defects: PhysicsDefects {
                stroke_friction_gradient_per_m: self.stroke_gradient_per_m,
                hardening_per_m2: self.hardening_per_m2,
                rs_minus_n: self.rs_minus_n,
                rd_minus_n: self.rd_minus_n,
            },
            contact_stiffness_n_per_m: self.contact_stiffness_n_per_m,
            position_zero_uncertainty_m: self.position_zero_uncertainty_m,
        };
        cfg.validate().map_err(|e| input_err(out, e.to_string()))?;
        Ok(cfg)
    }
}

/// Runs the job: checks the sensor file, the configuration and the
/// outputs (the log, a CSV's channel map; an existing one only with
/// `force`), then generates and writes the log.
pub fn run_synth(job: &SynthJob, _progress: &dyn Progress) -> crate::Result<SynthOutcome> {
    crate::io::check_inputs(job.sensors.as_deref())?;
    let cfg = job.config()?;
    let map = (cfg.format == LogFormat::Csv).then(|| {
        let stem = job.out.file_stem().unwrap_or_default().to_string_lossy();
        job.out.with_file_name(format!("{stem}.map.toml"))
    });
    let exts: &'static [&'static str] = match cfg.format {
        LogFormat::Csv => &["csv"],
        LogFormat::Parquet => &["parquet"],
        _ => &["mcap"],
    };
    let mut outputs = vec![Output::file("--out", &job.out, exts)];
    if let Some(m) = &map {
        outputs.push(Output::file("--out (its channel map)", m, &["toml"]));
    }
    crate::io::check_inputs(job.sensors.as_deref())?;
    crate::io::check_outputs(job.sensors.as_deref(), &outputs)?;
    if !job.force {
        for o in &outputs {
            if std::fs::symlink_metadata(o.path).is_ok() {
                return Err(input_err(
                    o.path,
                    "exists: synth does not replace a log without --force",
                ));
            }
        }
    }
    let log = synth::generate(&cfg).map_err(|e| input_err(&job.out, e.to_string()))?;
    let written = synth::write(&log, &job.out)?;
    let t = &log.truth;
    let json = SynthJson {
        out: written.log.display().to_string(),
        map: written.map.as_ref().map(|p| p.display().to_string()),
        truth: written.truth.display().to_string(),
        format: cfg.format.as_str(),
        test: t["test"].clone(),
        bytes: written.bytes,
        duration_s: t["duration_s"].clone(),
        seed: cfg.seed,
        channels: t["channels"].clone(),
        stick_fraction: t["stick_fraction"].clone(),
        n_stick_slip_events: t["n_stick_slip_events"].clone(),
        lost_buffers: log.channels.iter().map(|c| c.lost_buffers).sum(),
        null_samples: log.channels.iter().map(|c| c.null_samples).sum(),
    };
    Ok(SynthOutcome {
        config: cfg,
        written,
        json,
    })
}
