//! The virtual rig's configuration: rig constants, friction law (as the
//! truth files spell it), the test, the log format and the whole
//! [`SynthConfig`] with its checks.

use super::*;
use crate::model::{LawKind, SiLaw};

/// Rig constants in SI.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RigSpec {
    /// Main mass M1 (kg).
    pub m1_kg: f64,
    /// Absorber mass M2 (kg).
    pub m2_kg: f64,
    /// Spring K1 (base to M1, N/m).
    pub k1_n_per_m: f64,
    /// Spring K2 (M1 to M2, N/m).
    pub k2_n_per_m: f64,
    /// Viscous damping d between the masses (N s/m).
    pub d_n_s_per_m: f64,
    /// Nominal drive amplitude A written in the `rig` record (m).
    pub drive_amplitude_nominal_m: f64,
    /// The amplitude the shaker really moves with (m).
    pub drive_amplitude_true_m: f64,
}

impl RigSpec {
    /// The paper's rig: M1 = 8.35 kg, M2 = 2.0875 kg, K1 = K2 = 670 N/m,
    /// D = 0.003, A = 2.5 mm.
    pub fn paper() -> Self {
        let (m2, k2) = (2.0875, 670.0);
        Self {
            m1_kg: 8.35,
            m2_kg: m2,
            k1_n_per_m: 670.0,
            k2_n_per_m: k2,
            d_n_s_per_m: 0.003 * (k2 * m2).sqrt(),
            drive_amplitude_nominal_m: 0.0025,
            drive_amplitude_true_m: 0.0025,
        }
    }

    /// The rig's constants (masses, springs, damper).
    pub fn constants(&self) -> RigConstants {
        RigConstants {
            m1_kg: self.m1_kg,
            m2_kg: self.m2_kg,
            k1_n_per_m: self.k1_n_per_m,
            k2_n_per_m: self.k2_n_per_m,
            d_n_s_per_m: self.d_n_s_per_m,
        }
    }

    /// ω = √(K2/M2) (rad/s): τ = ω·t.
    pub fn omega_ref(&self) -> f64 {
        self.constants().omega_ref()
    }

    /// The dimensionless absorber (m, k, D).
    pub fn absorber(&self) -> Absorber {
        self.constants().absorber()
    }

    /// Checks every constant.
    pub fn validate(&self) -> Result<(), SynthError> {
        positive("M1 (m1_kg)", self.m1_kg)?;
        positive("M2 (m2_kg)", self.m2_kg)?;
        positive("K1 (k1_n_per_m)", self.k1_n_per_m)?;
        positive("K2 (k2_n_per_m)", self.k2_n_per_m)?;
        non_negative("d (d_n_s_per_m)", self.d_n_s_per_m)?;
        positive("nominal drive amplitude", self.drive_amplitude_nominal_m)?;
        positive("true drive amplitude", self.drive_amplitude_true_m)
    }
}

/// Family of a friction law as the truth files spell it (a registered
/// family's name with `_` for `-`, e.g. `static_dynamic`, plus `linear` for
/// any other affine law). Test data keep their spelling; everything else
/// speaks [`crate::model::LawKind`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LawFamily {
    /// A registered family.
    Law(LawKind),
    /// Any other affine law Rd + a·v.
    Linear,
}

impl LawFamily {
    /// The family's name in truth files.
    pub fn as_str(self) -> String {
        match self {
            LawFamily::Law(k) => k.as_str().replace('-', "_"),
            LawFamily::Linear => "linear".into(),
        }
    }
}

impl Serialize for LawFamily {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(&self.as_str())
    }
}

impl<'de> Deserialize<'de> for LawFamily {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let s = String::deserialize(d)?;
        if s == "linear" {
            return Ok(LawFamily::Linear);
        }
        LawKind::parse(&s.replace('_', "-"))
            .map(LawFamily::Law)
            .ok_or_else(|| serde::de::Error::custom(format!("unknown law family `{s}`")))
    }
}

/// A friction law in SI: sliding magnitude g(v) of its family, static
/// threshold Rs. A serde adapter: the behaviour is the family's
/// ([`crate::model::LawFamily`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct FrictionSpec {
    /// Static threshold Rs (N).
    pub rs_n: f64,
    /// Dynamic level Rd ≤ Rs (N).
    pub rd_n: f64,
    /// Slope a of the characteristic (N s/m).
    pub slope_n_s_per_m: f64,
    /// Velocity scale v_s (m/s) of a family that has one (the Stribeck
    /// velocity; the key keeps its name).
    pub stribeck_velocity_m_per_s: Option<f64>,
    /// The family of a law with a velocity scale (None: the Stribeck type
    /// where a velocity is given, as configurations written before the
    /// family registry mean; else the affine family the values give).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub law: Option<LawKind>,
}

impl FrictionSpec {
    /// The spec of an SI law; the family is named only where it has a
    /// velocity scale and the values alone would read as another family.
    pub fn from_si(l: &SiLaw) -> Self {
        let mut spec = Self {
            rs_n: l.rs_n,
            rd_n: l.rd_n,
            slope_n_s_per_m: l.slope_n_s_per_m,
            stribeck_velocity_m_per_s: l.vs_m_per_s,
            law: None,
        };
        if l.kind.family().has_velocity_scale() && spec.family() != LawFamily::Law(l.kind) {
            spec.law = Some(l.kind);
        }
        spec
    }

    /// The family this law belongs to.
    pub fn family(&self) -> LawFamily {
        if let Some(k) = self.law {
            LawFamily::Law(k)
        } else if self.stribeck_velocity_m_per_s.is_some() {
            LawFamily::Law(LawKind::Stribeck)
        } else if self.rd_n == self.rs_n && self.slope_n_s_per_m == 0.0 {
            LawFamily::Law(LawKind::Coulomb)
        } else if self.rd_n == self.rs_n && self.slope_n_s_per_m < 0.0 {
            LawFamily::Law(LawKind::Decreasing)
        } else if self.rd_n < self.rs_n && self.slope_n_s_per_m == 0.0 {
            LawFamily::Law(LawKind::StaticDynamic)
        } else {
            LawFamily::Linear
        }
    }

    /// The dimensionless law for the rig, with forces divided by A·K2 for
    /// amplitude `a_m` and velocities by A·ω (unchecked: the model checks
    /// it; a family with a velocity scale but none given has v_s = NaN).
    pub fn law(&self, rig: &RigSpec, a_m: f64) -> Law {
        let s = Scales::from_rig(&rig.constants(), a_m);
        let (rho_s, rho_d) = (self.rs_n / s.force_n, self.rd_n / s.force_n);
        let slope = self.slope_n_s_per_m / s.slope_n_s_per_m;
        let linear = Law::Linear {
            rho_s,
            rho_d,
            slope,
            minus: None,
        };
        match self.family() {
            LawFamily::Law(k) => {
                let vs = self.stribeck_velocity_m_per_s.unwrap_or(f64::NAN);
                Law::of(k, rho_s, rho_d, slope, Some(vs / s.velocity_m_per_s)).unwrap_or(linear)
            }
            LawFamily::Linear => linear,
        }
    }

    /// Checks the values (the dimensionless law is checked by the model).
    pub fn validate(&self) -> Result<(), SynthError> {
        non_negative("Rs (static friction)", self.rs_n)?;
        non_negative("Rd (dynamic friction)", self.rd_n)?;
        if self.rd_n > self.rs_n {
            return Err(bad(format!(
                "Rd ({} N) must not exceed Rs ({} N)",
                self.rd_n, self.rs_n
            )));
        }
        if !self.slope_n_s_per_m.is_finite() {
            return Err(bad("slope a must be finite"));
        }
        if let Some(vs) = self.stribeck_velocity_m_per_s {
            positive("Stribeck velocity", vs)?;
        }
        if let Some(k) = self.law {
            if k.family().has_velocity_scale() && self.stribeck_velocity_m_per_s.is_none() {
                return Err(bad(format!("the {k} law needs a velocity scale")));
            }
        }
        Ok(())
    }
}

/// Memory a synthetic log takes while built and written, per logged
/// sample of any channel (bytes). The engine's requests, the low-pass
/// points and the sensor models are streamed through its observer; what
/// stays is each logged value (16 bytes) until the writer is done, plus
/// Parquet's own copy of the table. Measured at the typical rates (the
/// growth of the peak resident set from 600 s to 1200 s logged): MCAP 16.6,
/// CSV 15.9, Parquet 26.9 (a two-hour log's whole peak: 17.1, 16.3, 27.3);
/// rounded up with margin to 32 (it was 200 when every request was
/// materialised).
pub const SYNTH_BYTES_PER_SAMPLE: f64 = 32.0;

/// Most drive periods a synthetic test may simulate (warm-up included).
pub const MAX_SYNTH_PERIODS: f64 = 1e6;
/// Most samples a synthetic log may hold per channel (or table rows).
pub const MAX_SYNTH_SAMPLES: f64 = 5e7;

/// The test the virtual rig runs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum TestSpec {
    /// Fixed drive frequency; the rig runs `warmup_s` from rest before the
    /// log starts, then logs `duration_s`.
    Characteristic {
        /// Drive frequency (Hz).
        frequency_hz: f64,
        /// Unlogged run-in from rest (s).
        warmup_s: f64,
        /// Logged time (s).
        duration_s: f64,
    },
    /// Stepped sweep from rest: `preroll_s` at the first setpoint, then for
    /// each setpoint a `ramp_s` linear ramp (continuous phase; none before
    /// the first) and a dwell.
    Stepped {
        /// The setpoints (Hz), in sweep order.
        setpoints_hz: Vec<f64>,
        /// Dwell per setpoint (s): one value for all, or one per setpoint.
        dwell_s: Vec<f64>,
        /// Ramp between setpoints (s).
        ramp_s: f64,
        /// Hold at the first setpoint before its dwell (s).
        preroll_s: f64,
    },
    /// Continuous linear chirp from rest: hold at `from_hz`, ramp linearly
    /// to `to_hz` over `sweep_s`, hold at `to_hz`.
    Continuous {
        /// Start frequency (Hz).
        from_hz: f64,
        /// End frequency (Hz).
        to_hz: f64,
        /// Chirp duration (s).
        sweep_s: f64,
        /// Hold before the chirp (s).
        hold_before_s: f64,
        /// Hold after the chirp (s).
        hold_after_s: f64,
    },
}

impl TestSpec {
    /// The paper's characteristic test: 1.72 Hz, 40 s warm-up, 20 s logged.
    pub fn characteristic() -> Self {
        TestSpec::Characteristic {
            frequency_hz: 1.72,
            warmup_s: 40.0,
            duration_s: 20.0,
        }
    }

    /// A stepped sweep over `n` equally spaced setpoints in [from, to] Hz.
    pub fn stepped(from_hz: f64, to_hz: f64, n: usize, dwell_s: f64) -> Self {
        let setpoints_hz = (0..n)
            .map(|i| {
                if n == 1 {
                    from_hz
                } else {
                    from_hz + (to_hz - from_hz) * i as f64 / (n - 1) as f64
                }
            })
            .collect();
        TestSpec::Stepped {
            setpoints_hz,
            dwell_s: vec![dwell_s],
            ramp_s: 0.5,
            preroll_s: 2.0,
        }
    }

    /// The test's name in the `rig` record (`characteristic` or `sweep`).
    pub fn kind(&self) -> TestKind {
        match self {
            TestSpec::Characteristic { .. } => TestKind::Characteristic,
            _ => TestKind::Sweep,
        }
    }

    pub(super) fn validate(&self) -> Result<(), SynthError> {
        match self {
            TestSpec::Characteristic {
                frequency_hz,
                warmup_s,
                duration_s,
            } => {
                positive("drive frequency", *frequency_hz)?;
                non_negative("warm-up", *warmup_s)?;
                positive("duration", *duration_s)
            }
            TestSpec::Stepped {
                setpoints_hz,
                dwell_s,
                ramp_s,
                preroll_s,
            } => {
                if setpoints_hz.is_empty() {
                    return Err(bad("a stepped sweep needs at least one setpoint"));
                }
                for f in setpoints_hz {
                    positive("setpoint frequency", *f)?;
                }
                if !(dwell_s.len() == 1 || dwell_s.len() == setpoints_hz.len()) {
                    return Err(bad(format!(
                        "give one dwell time or one per setpoint ({} setpoints, {} dwell times)",
                        setpoints_hz.len(),
                        dwell_s.len()
                    )));
                }
                for d in dwell_s {
                    positive("dwell time", *d)?;
                }
                positive("ramp time", *ramp_s)?;
                non_negative("pre-roll", *preroll_s)
            }
            TestSpec::Continuous {
                from_hz,
                to_hz,
                sweep_s,
                hold_before_s,
                hold_after_s,
            } => {
                positive("sweep start frequency", *from_hz)?;
                positive("sweep end frequency", *to_hz)?;
                positive("sweep duration", *sweep_s)?;
                positive("hold before the sweep", *hold_before_s)?;
                non_negative("hold after the sweep", *hold_after_s)
            }
        }
    }

    /// Logged duration (s).
    pub fn duration_s(&self) -> f64 {
        match self {
            TestSpec::Characteristic { duration_s, .. } => *duration_s,
            TestSpec::Stepped {
                setpoints_hz,
                dwell_s,
                ramp_s,
                preroll_s,
            } => {
                let n = setpoints_hz.len();
                preroll_s
                    + (0..n).map(|i| dwell_of(dwell_s, i)).sum::<f64>()
                    + (n.saturating_sub(1)) as f64 * ramp_s
            }
            TestSpec::Continuous {
                sweep_s,
                hold_before_s,
                hold_after_s,
                ..
            } => hold_before_s + sweep_s + hold_after_s,
        }
    }

    /// Unlogged run-in before the log starts (s).
    pub fn warmup_s(&self) -> f64 {
        match self {
            TestSpec::Characteristic { warmup_s, .. } => *warmup_s,
            _ => 0.0,
        }
    }
}

pub(super) fn dwell_of(dwell_s: &[f64], i: usize) -> f64 {
    if dwell_s.len() == 1 {
        dwell_s[0]
    } else {
        dwell_s[i]
    }
}

/// The file format of a synthetic log.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LogFormat {
    /// MCAP, zstd chunks, summary section.
    Mcap,
    /// MCAP with lz4 chunks.
    McapLz4,
    /// MCAP with uncompressed chunks and no summary section.
    McapPlain,
    /// DAQ CSV (mm, mm/s) + `NAME.map.toml`.
    Csv,
    /// Parquet table (SI) with the rig metadata as key-value metadata.
    Parquet,
}

impl LogFormat {
    /// The `format` field of truth.json.
    pub fn as_str(self) -> &'static str {
        match self {
            LogFormat::Mcap => "mcap/zstd",
            LogFormat::McapLz4 => "mcap/lz4",
            LogFormat::McapPlain => "mcap/none/no-summary",
            LogFormat::Csv => "csv",
            LogFormat::Parquet => "parquet",
        }
    }

    /// Whether it is a table on a common time base.
    pub fn is_table(self) -> bool {
        matches!(self, LogFormat::Csv | LogFormat::Parquet)
    }
}

/// Everything the virtual rig needs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SynthConfig {
    /// Rig constants.
    pub rig: RigSpec,
    /// Friction law.
    pub friction: FrictionSpec,
    /// Normal force at the friction member (N), logged and recorded.
    pub normal_force_n: f64,
    /// The test.
    pub test: TestSpec,
    /// Sensor models.
    pub sensors: Sensors,
    /// Seed of every random choice.
    pub seed: u64,
    /// Output format (decides buffers vs a common time base).
    pub format: LogFormat,
    /// Row rate of CSV/Parquet tables (Hz).
    pub table_rate_hz: f64,
    /// CSV only: column time shifts (s) by quantity name (`x0`, …): the
    /// value in a row was taken at row time + shift.
    pub csv_shift_s: BTreeMap<String, f64>,
    /// Relative tolerance of the numerical engine (ramps, chirps, Stribeck).
    pub rtol: f64,
    /// Physics defects for tests (none by default; see `defects`).
    #[serde(default)]
    pub defects: PhysicsDefects,
    /// Pre-sliding (issue 34): the tangential contact stiffness kt (N/m)
    /// between M2 and its friction slider; None: the rigid stick.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub contact_stiffness_n_per_m: Option<f64>,
    /// Calibrated position zeros: the bound (m) written as the rig key
    /// `position_zero_uncertainty_m`; the sensor models' x0, x1 and x2
    /// offsets must lie within it. None: zeros unknown (not written).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub position_zero_uncertainty_m: Option<f64>,
}

impl SynthConfig {
    /// The paper's rig with a static/dynamic pad at 2.2 N (μs = 0.42,
    /// μd = 0.34), the characteristic test at 1.72 Hz, typical sensors.
    pub fn paper(seed: u64) -> Self {
        let n = 2.2;
        Self {
            rig: RigSpec::paper(),
            friction: FrictionSpec {
                rs_n: 0.42 * n,
                rd_n: 0.34 * n,
                slope_n_s_per_m: 0.0,
                stribeck_velocity_m_per_s: None,
                law: None,
            },
            normal_force_n: n,
            test: TestSpec::characteristic(),
            sensors: Sensors::typical(seed),
            seed,
            format: LogFormat::Mcap,
            table_rate_hz: 1000.0,
            csv_shift_s: BTreeMap::new(),
            rtol: 1e-10,
            defects: PhysicsDefects::default(),
            contact_stiffness_n_per_m: None,
            position_zero_uncertainty_m: None,
        }
    }

    /// Checks the whole configuration.
    pub fn validate(&self) -> Result<(), SynthError> {
        self.rig.validate()?;
        non_negative("normal force", self.normal_force_n)?;
        self.friction.validate()?;
        self.defects.validate(&self.friction)?;
        if let Some(kt) = self.contact_stiffness_n_per_m {
            if !(kt.is_finite() && kt > 0.0) {
                return Err(bad(format!(
                    "contact stiffness must be finite and > 0 N/m, got {kt}"
                )));
            }
            if self.defects.any() {
                return Err(bad(
                    "a contact stiffness cannot be combined with the test defects (their integrator has a rigid stick)"
                        .to_string(),
                ));
            }
        }
        if let Some(e) = self.position_zero_uncertainty_m {
            non_negative("position zero uncertainty", e)?;
            for (name, m) in [
                ("x0", &self.sensors.x0),
                ("x1", &self.sensors.x1),
                ("x2", &self.sensors.x2),
            ] {
                if m.offset.abs() > e {
                    return Err(bad(format!(
                        "the {name} offset {} m is outside the declared zero uncertainty {e} m",
                        m.offset
                    )));
                }
            }
        }
        self.test.validate()?;
        for (q, s) in self.sensors.channels() {
            s.validate(q)?;
        }
        positive("table rate", self.table_rate_hz)?;
        self.check_budget()?;
        if !(self.rtol > 0.0 && self.rtol < 1e-3) {
            return Err(bad("rtol must be in (0, 1e-3)"));
        }
        for (k, v) in &self.csv_shift_s {
            let q = Quantity::from_name(k)
                .ok_or_else(|| bad(format!("csv shift for unknown column {k:?}")))?;
            if !v.is_finite() || v.abs() > 1.0 {
                return Err(bad(format!(
                    "csv shift of {} must be within ±1 s",
                    q.name()
                )));
            }
            if *v != 0.0 && self.format != LogFormat::Csv {
                return Err(bad("column time shifts exist in CSV channel maps only"));
            }
        }
        let model = self.model();
        model
            .validate()
            .map_err(|e| bad(format!("friction law: {e}")))?;
        Ok(())
    }

    /// Refuses a test whose work or output exceeds the documented limits
    /// ([`MAX_SYNTH_PERIODS`] drive periods simulated, [`MAX_SYNTH_SAMPLES`]
    /// samples per channel or table rows), naming the numbers: a typo such
    /// as `--duration-s 1e9` would otherwise run for days or fill the disk.
    fn check_budget(&self) -> Result<(), SynthError> {
        let (simulated_s, max_hz) = match &self.test {
            TestSpec::Characteristic {
                frequency_hz,
                warmup_s,
                duration_s,
            } => (warmup_s + duration_s, *frequency_hz),
            TestSpec::Stepped { setpoints_hz, .. } => (
                self.test.duration_s(),
                setpoints_hz.iter().copied().fold(0.0, f64::max),
            ),
            TestSpec::Continuous { from_hz, to_hz, .. } => {
                (self.test.duration_s(), from_hz.max(*to_hz))
            }
        };
        self.rig
            .constants()
            .check_integrable(max_hz)
            .map_err(|e| bad(e.to_string()))?;
        let periods = simulated_s * max_hz;
        if periods.is_nan() || periods > MAX_SYNTH_PERIODS {
            return Err(bad(format!(
                "the test simulates {simulated_s:.3e} s at up to {max_hz} Hz = {periods:.3e} drive periods; the limit is {MAX_SYNTH_PERIODS:.0e}: shorten --duration-s/--warmup-s/--sweep-s/--dwell-s"
            )));
        }
        let logged_s = self.test.duration_s();
        let mut rates: Vec<(&str, f64)> = self
            .sensors
            .channels()
            .into_iter()
            .map(|(q, s)| (q.name(), s.rate_hz))
            .collect();
        if matches!(self.format, LogFormat::Csv | LogFormat::Parquet) {
            rates.push(("table (--table-rate-hz)", self.table_rate_hz));
        }
        // Memory: the logged values are held until they are written, about
        // SYNTH_BYTES_PER_SAMPLE per logged sample of every channel (at the
        // typical 6 kHz of samples a two-hour log needs about 1.4 GB by
        // this estimate; measured peaks: docs/measurements.md). Checked
        // after the per-channel limits, whose messages name the flag to
        // change.
        let total: f64 = rates.iter().map(|(_, r)| logged_s * r).sum();
        for (name, rate) in rates {
            let samples = logged_s * rate;
            if samples.is_nan() || samples > MAX_SYNTH_SAMPLES {
                return Err(bad(format!(
                    "{name}: {logged_s} s logged at {rate} Hz = {samples:.3e} samples; the limit is {MAX_SYNTH_SAMPLES:.0e} per channel: shorten the test or lower the rate"
                )));
            }
        }
        let bytes = total * SYNTH_BYTES_PER_SAMPLE;
        let budget = crate::io::budget::MEMORY_BUDGET_BYTES as f64;
        if bytes.is_nan() || bytes > budget {
            return Err(bad(format!(
                "{logged_s} s logged at {:.0} samples/s over all channels = {total:.3e} samples would need about {} in memory ({SYNTH_BYTES_PER_SAMPLE} bytes per sample), over {}: at most {:.3} s at these rates; shorten the test or lower the channel rates (--sensors)",
                total / logged_s,
                crate::io::budget::human(bytes),
                crate::io::budget::budget_text(),
                budget / SYNTH_BYTES_PER_SAMPLE / (total / logged_s)
            )));
        }
        Ok(())
    }

    /// The dimensionless model the engine runs (true amplitude).
    pub fn model(&self) -> Model {
        Model {
            absorber: self.rig.absorber(),
            law: self
                .friction
                .law(&self.rig, self.rig.drive_amplitude_true_m),
            stop_below: None,
            contact_stiffness: self
                .contact_stiffness_n_per_m
                .map(|kt| kt / self.rig.k2_n_per_m),
        }
    }
}
