//! `stickslip synth`: the virtual rig. The SI options become a
//! [`SynthJob`]; the configuration, its checks and the writing are
//! [`crate::pipeline::synth`]'s. This module parses and prints (most of
//! it is the clap option list).

use crate::model::LawKind;
use crate::pipeline::synth::{SynthJob, SynthOutcome, SynthTest};
use crate::synth::LogFormat;
use clap::{Args, ValueEnum};
use std::path::PathBuf;

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
    /// Calibrated position zeros: draw the x0, x1 and x2 offsets within
    /// this bound (m) and write it as the rig key
    /// `position_zero_uncertainty_m` (default: offsets of up to 0.1 mm,
    /// unknown to the analyst).
    #[arg(long = "position-zero-uncertainty-m", allow_hyphen_values = true)]
    pub position_zero_uncertainty: Option<f64>,
    /// Replace an existing log at --out (and its channel map); without it
    /// an existing file is refused.
    #[arg(long)]
    pub force: bool,
    /// Print one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
}

impl From<FormatArg> for LogFormat {
    fn from(f: FormatArg) -> Self {
        match f {
            FormatArg::Mcap => LogFormat::Mcap,
            FormatArg::McapLz4 => LogFormat::McapLz4,
            FormatArg::McapPlain => LogFormat::McapPlain,
            FormatArg::Csv => LogFormat::Csv,
            FormatArg::Parquet => LogFormat::Parquet,
        }
    }
}

impl SynthArgs {
    /// The job these options describe.
    pub fn job(self) -> SynthJob {
        SynthJob {
            out: self.out,
            format: self.format.map(LogFormat::from),
            test: match self.test {
                TestArg::Characteristic => SynthTest::Characteristic,
                TestArg::Stepped => SynthTest::Stepped,
                TestArg::Continuous => SynthTest::Continuous,
            },
            normal_force_n: self.normal_force,
            law: self.law,
            mu_s: self.mu_s,
            mu_d: self.mu_d,
            rs_n: self.rs_n,
            rd_n: self.rd_n,
            slope_n_s_per_m: self.slope,
            v_s_m_per_s: self.v_s,
            m1_kg: self.m1,
            m2_kg: self.m2,
            k1_n_per_m: self.k1,
            k2_n_per_m: self.k2,
            d_n_s_per_m: self.d,
            amplitude_m: self.amplitude,
            true_amplitude_m: self.true_amplitude,
            frequency_hz: self.frequency,
            warmup_s: self.warmup,
            duration_s: self.duration,
            setpoints_hz: self.setpoints,
            dwell_s: self.dwell,
            from_hz: self.from_hz,
            to_hz: self.to_hz,
            sweep_s: self.sweep_s,
            seed: self.seed,
            no_accelerometer: self.no_accelerometer,
            ideal_sensors: self.ideal_sensors,
            sensors: self.sensors,
            channel_delay: self.channel_delay,
            offset_drift: self.offset_drift,
            table_rate_hz: self.table_rate,
            csv_drive_shift_s: self.csv_drive_shift,
            clip: self.clip,
            clip_low: self.clip_low,
            stroke_gradient_per_m: self.stroke_gradient,
            hardening_per_m2: self.hardening,
            rs_minus_n: self.rs_minus_n,
            rd_minus_n: self.rd_minus_n,
            contact_stiffness_n_per_m: self.contact_stiffness,
            position_zero_uncertainty_m: self.position_zero_uncertainty,
            force: self.force,
        }
    }
}

/// The `synth` request.
pub fn request(args: SynthArgs) -> crate::Result<super::Request> {
    let json = args.json;
    Ok(super::Request::quiet(
        crate::pipeline::Job::Synth(Box::new(args.job())),
        json,
    ))
}

/// Prints what was written.
pub fn print(done: &SynthOutcome, view: &super::View) -> crate::Result<()> {
    if view.json {
        return super::print_json(&crate::io::json::to_value(&done.json));
    }
    eprintln!(
        "wrote {} ({}, {} test, {} s, {} bytes); truth in {}",
        done.written.log.display(),
        done.config.format.as_str(),
        done.json.test.as_str().unwrap_or("?"),
        done.config.test.duration_s(),
        done.written.bytes,
        done.written.truth.display()
    );
    Ok(())
}
