//! `stickslip synth`: the virtual rig. Turns SI options into a
//! [`SynthConfig`], runs [`synth::generate`] and writes the log (and
//! `truth.json` beside it) atomically.

use crate::io::Output;
use crate::model::LawKind;
use crate::synth::{
    self, FrictionSpec, LogFormat, PhysicsDefects, RigSpec, Sensors, SynthConfig, TestSpec,
};
use clap::{Args, ValueEnum};
use serde_json::json;
use std::path::{Path, PathBuf};

/// Output format.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum FormatArg {
    /// MCAP with zstd chunks and a summary section.
    Mcap,
    /// MCAP with lz4 chunks.
    McapLz4,
    /// MCAP with uncompressed chunks and no summary.
    McapPlain,
    /// DAQ CSV (mm, mm/s) with NAME.map.toml.
    Csv,
    /// Parquet table (SI).
    Parquet,
}

/// The test run by the rig.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum TestArg {
    /// One drive frequency after a warm-up.
    Characteristic,
    /// Stepped frequency sweep (dwells, 0.5 s ramps).
    Stepped,
    /// Continuous linear chirp.
    Continuous,
}

/// Arguments of `stickslip synth`.
#[derive(Debug, Args)]
pub struct SynthArgs {
    /// The log to write (.mcap, .csv or .parquet).
    #[arg(long)]
    pub out: PathBuf,
    /// Output format (default: from the extension of --out).
    #[arg(long, value_enum)]
    pub format: Option<FormatArg>,
    /// The test.
    #[arg(long, value_enum, default_value_t = TestArg::Characteristic)]
    pub test: TestArg,
    /// Normal force at the friction member (N).
    #[arg(
        long = "normal-force",
        default_value_t = 2.2,
        allow_hyphen_values = true
    )]
    pub normal_force: f64,
    /// Friction law family.
    #[arg(long, default_value = "static-dynamic", value_parser = super::args::law_kind())]
    pub law: LawKind,
    /// Static friction coefficient (Rs = mu_s·N unless --rs-n).
    #[arg(long = "mu-s", default_value_t = 0.42, allow_hyphen_values = true)]
    pub mu_s: f64,
    /// Dynamic friction coefficient (Rd = mu_d·N unless --rd-n; static-dynamic, stribeck).
    #[arg(long = "mu-d", default_value_t = 0.34, allow_hyphen_values = true)]
    pub mu_d: f64,
    /// Static friction force Rs (N).
    #[arg(long = "rs-n", allow_hyphen_values = true)]
    pub rs_n: Option<f64>,
    /// Dynamic friction force Rd (N).
    #[arg(long = "rd-n", allow_hyphen_values = true)]
    pub rd_n: Option<f64>,
    /// Slope a of the characteristic (N s/m; decreasing: default −3).
    #[arg(long = "slope-n-s-per-m", allow_hyphen_values = true)]
    pub slope: Option<f64>,
    /// Velocity scale v_s (m/s) of a law that has one (stribeck,
    /// exponential); the option keeps its name.
    #[arg(
        long = "stribeck-velocity-m-per-s",
        default_value_t = 0.005,
        allow_hyphen_values = true
    )]
    pub v_s: f64,
    /// M1 (kg).
    #[arg(long = "m1-kg", default_value_t = 8.35, allow_hyphen_values = true)]
    pub m1: f64,
    /// M2 (kg).
    #[arg(long = "m2-kg", default_value_t = 2.0875, allow_hyphen_values = true)]
    pub m2: f64,
    /// K1 (N/m).
    #[arg(
        long = "k1-n-per-m",
        default_value_t = 670.0,
        allow_hyphen_values = true
    )]
    pub k1: f64,
    /// K2 (N/m).
    #[arg(
        long = "k2-n-per-m",
        default_value_t = 670.0,
        allow_hyphen_values = true
    )]
    pub k2: f64,
    /// Damping d (N s/m; default: D = 0.003).
    #[arg(long = "d-n-s-per-m", allow_hyphen_values = true)]
    pub d: Option<f64>,
    /// Nominal drive amplitude A (m).
    #[arg(
        long = "amplitude-m",
        default_value_t = 0.0025,
        allow_hyphen_values = true
    )]
    pub amplitude: f64,
    /// True drive amplitude (m; default: the nominal one).
    #[arg(long = "true-amplitude-m", allow_hyphen_values = true)]
    pub true_amplitude: Option<f64>,
    /// Drive frequency of a characteristic test (Hz).
    #[arg(
        long = "frequency-hz",
        default_value_t = 1.72,
        allow_hyphen_values = true
    )]
    pub frequency: f64,
    /// Unlogged warm-up of a characteristic test (s).
    #[arg(long = "warmup-s", default_value_t = 40.0, allow_hyphen_values = true)]
    pub warmup: f64,
    /// Logged duration of a characteristic test (s).
    #[arg(
        long = "duration-s",
        default_value_t = 20.0,
        allow_hyphen_values = true
    )]
    pub duration: f64,
    /// Setpoints of a stepped sweep (Hz, comma separated; default 11 from 0.9 to 3.4).
    #[arg(
        long = "setpoints-hz",
        value_delimiter = ',',
        allow_hyphen_values = true
    )]
    pub setpoints: Vec<f64>,
    /// Dwell per setpoint (s; one value or one per setpoint).
    #[arg(long = "dwell-s", value_delimiter = ',', default_values_t = vec![15.0], allow_hyphen_values = true)]
    pub dwell: Vec<f64>,
    /// Continuous sweep: start frequency (Hz).
    #[arg(long = "from-hz", default_value_t = 0.9, allow_hyphen_values = true)]
    pub from_hz: f64,
    /// Continuous sweep: end frequency (Hz).
    #[arg(long = "to-hz", default_value_t = 3.4, allow_hyphen_values = true)]
    pub to_hz: f64,
    /// Continuous sweep: chirp duration (s).
    #[arg(long = "sweep-s", default_value_t = 240.0, allow_hyphen_values = true)]
    pub sweep_s: f64,
    /// Seed of every random choice.
    #[arg(long, default_value_t = 1, allow_hyphen_values = true)]
    pub seed: u64,
    /// No accelerometer channel.
    #[arg(long)]
    pub no_accelerometer: bool,
    /// Ideal sensors: no noise, quantisation, gain/offset errors, filters,
    /// jitter or losses.
    #[arg(long)]
    pub ideal_sensors: bool,
    /// Sensor models from a JSON file (the `Sensors` structure).
    #[arg(long)]
    pub sensors: Option<PathBuf>,
    /// Channel delays (s), e.g. `x2=0.003,v2=0.003`: the value stamped t was
    /// measured at t − delay (the channel lags). Overrides the sensor
    /// models' `delay_s`.
    #[arg(
        long = "channel-delay-s",
        value_delimiter = ',',
        allow_hyphen_values = true
    )]
    pub channel_delay: Vec<String>,
    /// Linear offset drifts (SI per second), e.g. `v2=0.0004`: the channel's
    /// offset grows by this much per second of the log. Overrides the sensor
    /// models' `offset_drift_per_s`.
    #[arg(
        long = "offset-drift-per-s",
        value_delimiter = ',',
        allow_hyphen_values = true
    )]
    pub offset_drift: Vec<String>,
    /// Row rate of CSV/Parquet tables (Hz).
    #[arg(
        long = "table-rate-hz",
        default_value_t = 1000.0,
        allow_hyphen_values = true
    )]
    pub table_rate: f64,
    /// CSV: time shift of the drive column (s), written to the map.
    #[arg(long = "csv-drive-shift-s", allow_hyphen_values = true)]
    pub csv_drive_shift: Option<f64>,
    /// Saturate a channel's high side at a fraction of its swing:
    /// `x1=0.85` flat-tops x1 at mid + 0.85·(max − mid) of its noise-free
    /// signal (repeatable; channels x0, x1, x2, v2, a2, normal_force).
    #[arg(long = "clip", value_name = "CHANNEL=FRACTION")]
    pub clip: Vec<String>,
    /// The same for the low side (mid − f·(mid − min)).
    #[arg(long = "clip-low", value_name = "CHANNEL=FRACTION")]
    pub clip_low: Vec<String>,
    /// Test defect: both friction levels change by G·x2 relative along the
    /// stroke (1/m; levels × max(0.05, 1 + G·x2)).
    #[arg(
        long = "stroke-friction-gradient-per-m",
        default_value_t = 0.0,
        allow_hyphen_values = true
    )]
    pub stroke_gradient: f64,
    /// Test defect: hardening coupling spring, force K2·δ·(1 + β·δ²) with
    /// δ = x1 − x2 (β in 1/m²).
    #[arg(long = "hardening-per-m2", default_value_t = 0.0)]
    pub hardening: f64,
    /// Test defect: static threshold for sliding in the negative direction (N).
    #[arg(long = "rs-minus-n")]
    pub rs_minus_n: Option<f64>,
    /// Test defect: dynamic level for sliding in the negative direction (N).
    #[arg(long = "rd-minus-n")]
    pub rd_minus_n: Option<f64>,
    /// Pre-sliding: the tangential contact stiffness kt (N/m) between M2
    /// and its friction slider (a Jenkins element; default: a rigid stick).
    #[arg(long = "contact-stiffness-n-per-m", allow_hyphen_values = true)]
    pub contact_stiffness: Option<f64>,
    /// Replace an existing log at --out (and its channel map); without it
    /// an existing file is refused.
    #[arg(long)]
    pub force: bool,
    /// Print one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
}

fn input_err(path: &Path, msg: impl Into<String>) -> crate::Error {
    crate::Error::Input {
        path: path.to_path_buf(),
        msg: msg.into(),
    }
}

impl SynthArgs {
    /// The log format: from --format, which must agree with the
    /// extension of --out, or from the extension.
    fn format(&self, out: &Path) -> crate::Result<LogFormat> {
        let ext = out
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase())
            .unwrap_or_default();
        let format = match (self.format, ext.as_str()) {
            (Some(FormatArg::Mcap), "mcap") | (None, "mcap") => LogFormat::Mcap,
            (Some(FormatArg::McapLz4), "mcap") => LogFormat::McapLz4,
            (Some(FormatArg::McapPlain), "mcap") => LogFormat::McapPlain,
            (Some(FormatArg::Csv), "csv") | (None, "csv") => LogFormat::Csv,
            (Some(FormatArg::Parquet), "parquet") | (None, "parquet") => LogFormat::Parquet,
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
                        f.to_possible_value()
                            .map_or("?".into(), |v| v.get_name().to_string()),
                        match f {
                            FormatArg::Csv => "csv",
                            FormatArg::Parquet => "parquet",
                            _ => "mcap",
                        }
                    ),
                ))
            }
        };
        Ok(format)
    }

    /// The friction law in SI (Rs = μs·N unless given, Rd likewise).
    fn friction(&self) -> FrictionSpec {
        let n = self.normal_force;
        let rs = self.rs_n.unwrap_or(self.mu_s * n);
        let rd_given = self.rd_n.unwrap_or(self.mu_d * n);
        FrictionSpec::from_si(
            &self
                .law
                .family()
                .synth_law(rs, rd_given, self.slope, self.v_s),
        )
    }

    /// The test the rig runs.
    fn test_spec(&self) -> TestSpec {
        match self.test {
            TestArg::Characteristic => TestSpec::Characteristic {
                frequency_hz: self.frequency,
                warmup_s: self.warmup,
                duration_s: self.duration,
            },
            TestArg::Stepped => {
                let mut t = TestSpec::stepped(0.9, 3.4, 11, 15.0);
                if let TestSpec::Stepped {
                    setpoints_hz,
                    dwell_s,
                    ..
                } = &mut t
                {
                    if !self.setpoints.is_empty() {
                        *setpoints_hz = self.setpoints.clone();
                    }
                    *dwell_s = self.dwell.clone();
                }
                t
            }
            TestArg::Continuous => TestSpec::Continuous {
                from_hz: self.from_hz,
                to_hz: self.to_hz,
                sweep_s: self.sweep_s,
                hold_before_s: 10.0,
                hold_after_s: 5.0,
            },
        }
    }

    /// The sensor models: from --sensors, ideal, or typical (slower
    /// channels for the long sweeps); no accelerometer with
    /// --no-accelerometer.
    fn sensors(&self) -> crate::Result<Sensors> {
        let mut sensors = match &self.sensors {
            Some(p) => {
                let text = crate::io::paths::read_small_text(p, "sensor set", 4_000_000)?;
                serde_json::from_str::<Sensors>(&text)
                    .map_err(|e| input_err(p, format!("not a sensor set: {e}")))?
            }
            None if self.ideal_sensors => Sensors::ideal(),
            None => {
                let mut s = Sensors::typical(self.seed);
                if !matches!(self.test, TestArg::Characteristic) {
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
        Ok(sensors)
    }

    /// The configuration these options describe.
    pub fn config(&self) -> crate::Result<SynthConfig> {
        let out = &self.out;
        let format = self.format(out)?;
        let n = self.normal_force;
        let friction = self.friction();
        let d = self.d.unwrap_or(0.003 * (self.k2 * self.m2).abs().sqrt());
        let rig = RigSpec {
            m1_kg: self.m1,
            m2_kg: self.m2,
            k1_n_per_m: self.k1,
            k2_n_per_m: self.k2,
            d_n_s_per_m: d,
            drive_amplitude_nominal_m: self.amplitude,
            drive_amplitude_true_m: self.true_amplitude.unwrap_or(self.amplitude),
        };
        let test = self.test_spec();
        let sensors = self.sensors()?;
        let mut csv_shift_s = std::collections::BTreeMap::new();
        if let Some(s) = self.csv_drive_shift {
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
            normal_force_n: n,
            test,
            sensors,
            seed: self.seed,
            format,
            table_rate_hz: self.table_rate,
            csv_shift_s,
            rtol: 1e-10,
            defects: PhysicsDefects {
                stroke_friction_gradient_per_m: self.stroke_gradient,
                hardening_per_m2: self.hardening,
                rs_minus_n: self.rs_minus_n,
                rd_minus_n: self.rd_minus_n,
            },
            contact_stiffness_n_per_m: self.contact_stiffness,
        };
        cfg.validate().map_err(|e| input_err(out, e.to_string()))?;
        Ok(cfg)
    }
}

/// `NAME=NUMBER` (a finite number) as its two parts.
fn parse_channel_value(item: &str) -> Option<(&str, f64)> {
    let (name, value) = item.split_once('=')?;
    let v: f64 = value.trim().parse().ok()?;
    v.is_finite().then_some((name.trim(), v))
}

/// Runs `synth`.
pub fn run(args: SynthArgs) -> crate::Result<()> {
    crate::io::check_inputs(args.sensors.as_deref())?;
    let cfg = args.config()?;
    let map = (cfg.format == LogFormat::Csv).then(|| {
        let stem = args.out.file_stem().unwrap_or_default().to_string_lossy();
        args.out.with_file_name(format!("{stem}.map.toml"))
    });
    let exts: &'static [&'static str] = match cfg.format {
        LogFormat::Csv => super::ext::CSV,
        LogFormat::Parquet => super::ext::PARQUET,
        _ => &["mcap"],
    };
    let mut outputs = vec![Output::file("--out", &args.out, exts)];
    if let Some(m) = &map {
        outputs.push(Output::file("--out (its channel map)", m, &["toml"]));
    }
    super::check_paths(args.sensors.as_deref(), &outputs)?;
    if !args.force {
        for o in &outputs {
            if std::fs::symlink_metadata(o.path).is_ok() {
                return Err(input_err(
                    o.path,
                    "exists: synth does not replace a log without --force",
                ));
            }
        }
    }
    let log = synth::generate(&cfg).map_err(|e| input_err(&args.out, e.to_string()))?;
    let written = synth::write(&log, &args.out)?;
    let t = &log.truth;
    if args.json {
        super::print_json(&json!({
            "out": written.log.display().to_string(),
            "map": written.map.as_ref().map(|p| p.display().to_string()),
            "truth": written.truth.display().to_string(),
            "format": cfg.format.as_str(),
            "test": t["test"],
            "bytes": written.bytes,
            "duration_s": t["duration_s"],
            "seed": cfg.seed,
            "channels": t["channels"],
            "stick_fraction": t["stick_fraction"],
            "n_stick_slip_events": t["n_stick_slip_events"],
            "lost_buffers": log.channels.iter().map(|c| c.lost_buffers).sum::<usize>(),
            "null_samples": log.channels.iter().map(|c| c.null_samples).sum::<usize>(),
        }))?;
    } else {
        eprintln!(
            "wrote {} ({}, {} test, {} s, {} bytes); truth in {}",
            written.log.display(),
            cfg.format.as_str(),
            t["test"].as_str().unwrap_or("?"),
            cfg.test.duration_s(),
            written.bytes,
            written.truth.display()
        );
    }
    Ok(())
}
