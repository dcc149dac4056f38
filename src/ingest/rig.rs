//! The `rig` metadata record: parsed from its string map into [`RigMeta`]
//! (SI units) and checked, with the dimensionless conversions of the model.

use std::collections::BTreeMap;

/// The only rig-log format version this reader understands.
pub const FORMAT_VERSION: &str = "stickslip-rig-log/1";

/// Keys that every `rig` record must carry.
const REQUIRED: [&str; 9] = [
    "format",
    "test",
    "m1_kg",
    "m2_kg",
    "k1_n_per_m",
    "k2_n_per_m",
    "d_n_s_per_m",
    "drive_amplitude_m",
    "normal_force_n",
];

/// The optional key declaring calibrated position zeros (m).
pub const ZERO_UNCERTAINTY: &str = "position_zero_uncertainty_m";

/// Keys read into typed fields (everything else lands in [`RigMeta::extra`]).
const KNOWN: [&str; 15] = [
    "format",
    "test",
    "m1_kg",
    "m2_kg",
    "k1_n_per_m",
    "k2_n_per_m",
    "d_n_s_per_m",
    "drive_amplitude_m",
    "normal_force_n",
    "drive_frequency_hz",
    "sweep_kind",
    "rig_id",
    "operator",
    "notes",
    "recorded_at",
];

/// What kind of test a log records.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum TestKind {
    /// Fixed drive frequency: the friction characteristic is identified from it.
    Characteristic,
    /// A frequency response (stepped or continuous sweep).
    Sweep,
}

impl TestKind {
    /// The name used in the log and in JSON output.
    pub fn as_str(self) -> &'static str {
        match self {
            TestKind::Characteristic => "characteristic",
            TestKind::Sweep => "sweep",
        }
    }
}

/// How a sweep moves through its frequencies.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum SweepKind {
    /// Dwell at each setpoint.
    Stepped,
    /// A slow chirp.
    Continuous,
}

impl SweepKind {
    /// The name used in the log and in JSON output.
    pub fn as_str(self) -> &'static str {
        match self {
            SweepKind::Stepped => "stepped",
            SweepKind::Continuous => "continuous",
        }
    }
}

/// The rig description of one log, in SI units.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct RigMeta {
    /// Format version (always [`FORMAT_VERSION`] once parsed).
    pub format: String,
    /// The kind of test.
    pub test: TestKind,
    /// Main mass M1 (kg).
    pub m1_kg: f64,
    /// Absorber mass M2 (kg).
    pub m2_kg: f64,
    /// Spring rate K1 (N/m).
    pub k1_n_per_m: f64,
    /// Spring rate K2 (N/m).
    pub k2_n_per_m: f64,
    /// Viscous damping d between the masses (N s/m).
    pub d_n_s_per_m: f64,
    /// Nominal drive amplitude A (m).
    pub drive_amplitude_m: f64,
    /// Normal force set at the friction member (N).
    pub normal_force_n: f64,
    /// Commanded drive frequency of a characteristic test (Hz).
    pub drive_frequency_hz: Option<f64>,
    /// Sweep kind of a sweep test.
    pub sweep_kind: Option<SweepKind>,
    /// Free text: rig identifier.
    pub rig_id: Option<String>,
    /// Free text: operator.
    pub operator: Option<String>,
    /// Free text: notes (may contain any characters).
    pub notes: Option<String>,
    /// Free text: recording time stamp as written.
    pub recorded_at: Option<String>,
    /// Every other key, kept verbatim.
    pub extra: BTreeMap<String, String>,
}

/// Why a `rig` record was refused (the caller adds the file name).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RigError {
    /// A required key is absent.
    #[error("rig metadata lacks the required key `{0}`")]
    Missing(&'static str),
    /// A numeric key holds something that is not a number.
    #[error("rig metadata `{key}` = {value:?} is not a number")]
    NotNumeric {
        /// The key.
        key: String,
        /// Its value as written.
        value: String,
    },
    /// A numeric key is out of its physical range.
    #[error("rig metadata `{key}` = {value} is invalid: {why}")]
    OutOfRange {
        /// The key.
        key: String,
        /// Its value as written.
        value: String,
        /// The rule it breaks.
        why: &'static str,
    },
    /// A format version this reader does not know.
    #[error("unsupported format version {0:?} (this reader understands only {FORMAT_VERSION:?})")]
    Version(String),
    /// An enumerated key with a value outside its set.
    #[error("rig metadata `{key}` = {value:?} is not one of {allowed}")]
    BadChoice {
        /// The key.
        key: &'static str,
        /// Its value as written.
        value: String,
        /// The accepted values.
        allowed: &'static str,
    },
}

/// Parses a number the way a rig record writes it (trimmed decimal text).
fn number(map: &BTreeMap<String, String>, key: &'static str) -> Result<Option<f64>, RigError> {
    let Some(raw) = map.get(key) else {
        return Ok(None);
    };
    let v: f64 = raw.trim().parse().map_err(|_| RigError::NotNumeric {
        key: key.into(),
        value: raw.clone(),
    })?;
    if !v.is_finite() {
        return Err(RigError::OutOfRange {
            key: key.into(),
            value: raw.clone(),
            why: "not finite",
        });
    }
    Ok(Some(v))
}

fn required(map: &BTreeMap<String, String>, key: &'static str) -> Result<f64, RigError> {
    number(map, key)?.ok_or(RigError::Missing(key))
}

fn positive(map: &BTreeMap<String, String>, key: &'static str) -> Result<f64, RigError> {
    let v = required(map, key)?;
    if v <= 0.0 {
        return Err(RigError::OutOfRange {
            key: key.into(),
            value: map.get(key).cloned().unwrap_or_default(),
            why: "must be positive",
        });
    }
    Ok(v)
}

impl RigMeta {
    /// Parses and checks a `rig` record given as its key/value strings.
    ///
    /// Required keys: `format`, `test`, masses, springs, damping, drive
    /// amplitude and normal force. Masses, springs and the amplitude must be
    /// finite and positive, damping and normal force finite and not negative.
    /// Unknown keys are kept in [`RigMeta::extra`].
    pub fn from_map(map: &BTreeMap<String, String>) -> Result<Self, RigError> {
        // The version first: a newer format may well lack or rename keys.
        if let Some(format) = map.get("format") {
            if format.trim() != FORMAT_VERSION {
                return Err(RigError::Version(format.clone()));
            }
        }
        for key in REQUIRED {
            if !map.contains_key(key) {
                return Err(RigError::Missing(key));
            }
        }
        let test_raw = map.get("test").cloned().unwrap_or_default();
        let test = match test_raw.trim() {
            "characteristic" => TestKind::Characteristic,
            "sweep" => TestKind::Sweep,
            _ => {
                return Err(RigError::BadChoice {
                    key: "test",
                    value: test_raw,
                    allowed: "`characteristic`, `sweep`",
                })
            }
        };
        let m1_kg = positive(map, "m1_kg")?;
        let m2_kg = positive(map, "m2_kg")?;
        let k1_n_per_m = positive(map, "k1_n_per_m")?;
        let k2_n_per_m = positive(map, "k2_n_per_m")?;
        let drive_amplitude_m = positive(map, "drive_amplitude_m")?;
        let d_n_s_per_m = required(map, "d_n_s_per_m")?;
        if d_n_s_per_m < 0.0 {
            return Err(RigError::OutOfRange {
                key: "d_n_s_per_m".into(),
                value: map.get("d_n_s_per_m").cloned().unwrap_or_default(),
                why: "damping must not be negative",
            });
        }
        let normal_force_n = required(map, "normal_force_n")?;
        if normal_force_n < 0.0 {
            return Err(RigError::OutOfRange {
                key: "normal_force_n".into(),
                value: map.get("normal_force_n").cloned().unwrap_or_default(),
                why: "normal force must not be negative",
            });
        }
        let drive_frequency_hz = number(map, "drive_frequency_hz")?;
        if let Some(f) = drive_frequency_hz {
            if f <= 0.0 {
                return Err(RigError::OutOfRange {
                    key: "drive_frequency_hz".into(),
                    value: map.get("drive_frequency_hz").cloned().unwrap_or_default(),
                    why: "must be positive",
                });
            }
        }
        let sweep_kind = match map.get("sweep_kind").map(|s| s.trim()) {
            None => None,
            Some("stepped") => Some(SweepKind::Stepped),
            Some("continuous") => Some(SweepKind::Continuous),
            Some(other) => {
                return Err(RigError::BadChoice {
                    key: "sweep_kind",
                    value: other.to_string(),
                    allowed: "`stepped`, `continuous`",
                })
            }
        };
        // Optional: the position channels' calibrated zeros (kept in
        // `extra`, checked here so a bad value is refused, not ignored).
        if let Some(e) = number(map, ZERO_UNCERTAINTY)? {
            if e < 0.0 {
                return Err(RigError::OutOfRange {
                    key: ZERO_UNCERTAINTY.into(),
                    value: map.get(ZERO_UNCERTAINTY).cloned().unwrap_or_default(),
                    why: "must not be negative",
                });
            }
        }
        let extra = map
            .iter()
            .filter(|(k, _)| !KNOWN.contains(&k.as_str()))
            .map(|(k, v)| (k.clone(), v.clone()))
            .collect();
        Ok(Self {
            format: FORMAT_VERSION.to_string(),
            test,
            m1_kg,
            m2_kg,
            k1_n_per_m,
            k2_n_per_m,
            d_n_s_per_m,
            drive_amplitude_m,
            normal_force_n,
            drive_frequency_hz,
            sweep_kind,
            rig_id: map.get("rig_id").cloned(),
            operator: map.get("operator").cloned(),
            notes: map.get("notes").cloned(),
            recorded_at: map.get("recorded_at").cloned(),
            extra,
        })
    }

    /// The record as key/value strings again (for writing a Parquet run).
    pub fn to_map(&self) -> BTreeMap<String, String> {
        let mut map = self.extra.clone();
        let mut put = |k: &str, v: String| {
            map.insert(k.to_string(), v);
        };
        put("format", self.format.clone());
        put("test", self.test.as_str().into());
        put("m1_kg", self.m1_kg.to_string());
        put("m2_kg", self.m2_kg.to_string());
        put("k1_n_per_m", self.k1_n_per_m.to_string());
        put("k2_n_per_m", self.k2_n_per_m.to_string());
        put("d_n_s_per_m", self.d_n_s_per_m.to_string());
        put("drive_amplitude_m", self.drive_amplitude_m.to_string());
        put("normal_force_n", self.normal_force_n.to_string());
        if let Some(f) = self.drive_frequency_hz {
            put("drive_frequency_hz", f.to_string());
        }
        if let Some(s) = self.sweep_kind {
            put("sweep_kind", s.as_str().into());
        }
        for (k, v) in [
            ("rig_id", &self.rig_id),
            ("operator", &self.operator),
            ("notes", &self.notes),
            ("recorded_at", &self.recorded_at),
        ] {
            if let Some(v) = v {
                put(k, v.clone());
            }
        }
        map
    }

    /// The rig's constants (masses, springs, damper).
    pub fn constants(&self) -> crate::model::RigConstants {
        crate::model::RigConstants {
            m1_kg: self.m1_kg,
            m2_kg: self.m2_kg,
            k1_n_per_m: self.k1_n_per_m,
            k2_n_per_m: self.k2_n_per_m,
            d_n_s_per_m: self.d_n_s_per_m,
        }
    }

    /// Mass ratio m = M1/M2.
    pub fn mass_ratio(&self) -> f64 {
        self.constants().absorber().m
    }

    /// Stiffness ratio k = K1/K2.
    pub fn stiffness_ratio(&self) -> f64 {
        self.constants().absorber().k
    }

    /// Dimensionless damping D = d/sqrt(K2·M2).
    pub fn damping_ratio(&self) -> f64 {
        self.constants().absorber().damping
    }

    /// Reference angular frequency sqrt(K2/M2) (rad/s): τ = t·omega_ref.
    pub fn omega_ref(&self) -> f64 {
        self.constants().omega_ref()
    }

    /// Time scale sqrt(M2/K2) (s).
    pub fn time_scale_s(&self) -> f64 {
        (self.m2_kg / self.k2_n_per_m).sqrt()
    }

    /// Force scale A·K2 (N) with the nominal amplitude: ρ = R / force_scale.
    pub fn force_scale_n(&self) -> f64 {
        self.drive_amplitude_m * self.k2_n_per_m
    }

    /// The bound (m) within which the position channels x0, x1, x2 read
    /// zero at the rig's rest state (drive centred, both springs at their
    /// free length): the optional key `position_zero_uncertainty_m`. With
    /// it, the friction levels of each sliding direction are identifiable
    /// (`docs/real-pads.md`); None: the zeros are unknown.
    pub fn position_zero_uncertainty_m(&self) -> Option<f64> {
        self.extra_number(ZERO_UNCERTAINTY).filter(|e| *e >= 0.0)
    }

    /// An extra key read as a number (e.g. `sweep_rate_hz_per_s` of a
    /// continuous sweep); `None` if absent or not a finite number.
    pub fn extra_number(&self, key: &str) -> Option<f64> {
        self.extra
            .get(key)
            .and_then(|v| v.trim().parse::<f64>().ok())
            .filter(|v| v.is_finite())
    }

    /// The rig metadata as a JSON object: numbers as numbers, text as text.
    /// Extra keys whose name ends in a unit suffix (`_hz`, `_s`, `_m`, `_n`,
    /// `_kg`, `_per_m`, `_per_s`) and that hold a finite number become
    /// numbers; every other extra value stays text (a serial "0042" must not
    /// lose its zeros).
    pub fn to_json(&self) -> serde_json::Value {
        const UNIT_SUFFIXES: [&str; 7] = ["_hz", "_s", "_m", "_n", "_kg", "_per_m", "_per_s"];
        let mut obj = serde_json::Map::new();
        for (k, v) in &self.extra {
            let value = match self.extra_number(k) {
                Some(x) if UNIT_SUFFIXES.iter().any(|s| k.ends_with(s)) => serde_json::json!(x),
                _ => serde_json::Value::String(v.clone()),
            };
            obj.insert(k.clone(), value);
        }
        let num = |v: f64| serde_json::json!(v);
        obj.insert("format".into(), self.format.clone().into());
        obj.insert("test".into(), self.test.as_str().into());
        obj.insert("m1_kg".into(), num(self.m1_kg));
        obj.insert("m2_kg".into(), num(self.m2_kg));
        obj.insert("k1_n_per_m".into(), num(self.k1_n_per_m));
        obj.insert("k2_n_per_m".into(), num(self.k2_n_per_m));
        obj.insert("d_n_s_per_m".into(), num(self.d_n_s_per_m));
        obj.insert("drive_amplitude_m".into(), num(self.drive_amplitude_m));
        obj.insert("normal_force_n".into(), num(self.normal_force_n));
        obj.insert(
            "drive_frequency_hz".into(),
            self.drive_frequency_hz.map_or(serde_json::Value::Null, num),
        );
        obj.insert(
            "sweep_kind".into(),
            self.sweep_kind
                .map_or(serde_json::Value::Null, |s| s.as_str().into()),
        );
        for (k, v) in [
            ("rig_id", &self.rig_id),
            ("operator", &self.operator),
            ("notes", &self.notes),
            ("recorded_at", &self.recorded_at),
        ] {
            obj.insert(
                k.into(),
                v.clone().map_or(serde_json::Value::Null, Into::into),
            );
        }
        obj.insert("m".into(), num(self.mass_ratio()));
        obj.insert("k".into(), num(self.stiffness_ratio()));
        obj.insert("D".into(), num(self.damping_ratio()));
        obj.insert("omega_ref_rad_s".into(), num(self.omega_ref()));
        obj.insert("time_scale_s".into(), num(self.time_scale_s()));
        obj.insert("force_scale_n".into(), num(self.force_scale_n()));
        serde_json::Value::Object(obj)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rig_a() -> BTreeMap<String, String> {
        [
            ("format", FORMAT_VERSION),
            ("test", "characteristic"),
            ("m1_kg", "8.35"),
            ("m2_kg", "2.0875"),
            ("k1_n_per_m", "670"),
            ("k2_n_per_m", "670"),
            ("d_n_s_per_m", "0.112195"),
            ("drive_amplitude_m", "0.0025"),
            ("normal_force_n", "2.2"),
            ("drive_frequency_hz", "1.72"),
            ("notes", "<b>x</b>, \"y\""),
            ("daq_firmware", "4.2.1"),
        ]
        .into_iter()
        .map(|(k, v)| (k.to_string(), v.to_string()))
        .collect()
    }

    #[test]
    fn parses_rig_a_and_converts() {
        let r = RigMeta::from_map(&rig_a()).expect("valid");
        assert_eq!(r.test, TestKind::Characteristic);
        assert!((r.mass_ratio() - 4.0).abs() < 1e-12);
        assert!((r.stiffness_ratio() - 1.0).abs() < 1e-12);
        assert!((r.damping_ratio() - 0.003).abs() < 1e-5);
        assert!((r.omega_ref() - 17.9153).abs() < 1e-3);
        assert!((r.time_scale_s() * r.omega_ref() - 1.0).abs() < 1e-12);
        assert!((r.force_scale_n() - 1.675).abs() < 1e-12);
        assert_eq!(
            r.extra.get("daq_firmware").map(String::as_str),
            Some("4.2.1")
        );
        assert_eq!(r.notes.as_deref(), Some("<b>x</b>, \"y\""));
        assert_eq!(r.drive_frequency_hz, Some(1.72));
    }

    #[test]
    fn json_has_numbers_as_numbers() {
        let mut m = rig_a();
        m.insert("sweep_rate_hz_per_s".into(), "0.0104167".into());
        m.insert("serial".into(), "0042".into());
        let r = RigMeta::from_map(&m).expect("valid");
        let j = r.to_json();
        assert_eq!(j["m2_kg"], 2.0875);
        assert_eq!(j["drive_frequency_hz"], 1.72);
        assert_eq!(j["sweep_rate_hz_per_s"], 0.0104167);
        assert_eq!(r.extra_number("sweep_rate_hz_per_s"), Some(0.0104167));
        assert_eq!(j["serial"], "0042");
        assert_eq!(j["daq_firmware"], "4.2.1");
        assert_eq!(j["test"], "characteristic");
        assert!(j["sweep_kind"].is_null());
    }

    #[test]
    fn round_trips_through_map() {
        let r = RigMeta::from_map(&rig_a()).expect("valid");
        let again = RigMeta::from_map(&r.to_map()).expect("valid");
        assert_eq!(r, again);
    }

    #[test]
    fn names_missing_key() {
        let mut m = rig_a();
        m.remove("k2_n_per_m");
        let e = RigMeta::from_map(&m).unwrap_err();
        assert!(e.to_string().contains("k2_n_per_m"), "{e}");
    }

    #[test]
    fn names_non_numeric_key_and_value() {
        let mut m = rig_a();
        m.insert("m1_kg".into(), "eight point three".into());
        let e = RigMeta::from_map(&m).unwrap_err().to_string();
        assert!(
            e.contains("m1_kg") && e.contains("eight point three"),
            "{e}"
        );
    }

    #[test]
    fn rejects_bad_ranges_and_versions() {
        for (k, v) in [
            ("m2_kg", "-2.0875"),
            ("m1_kg", "0"),
            ("k1_n_per_m", "inf"),
            ("k2_n_per_m", "NaN"),
            ("drive_amplitude_m", "0"),
            ("d_n_s_per_m", "-0.1"),
            ("format", "stickslip-rig-log/2"),
            ("test", "impact"),
            ("position_zero_uncertainty_m", "-1e-5"),
            ("position_zero_uncertainty_m", "ten microns"),
        ] {
            let mut m = rig_a();
            m.insert(k.into(), v.into());
            let e = RigMeta::from_map(&m);
            assert!(e.is_err(), "{k}={v} accepted");
        }
        let mut m = rig_a();
        m.insert("d_n_s_per_m".into(), "0".into());
        assert!(RigMeta::from_map(&m).is_ok(), "zero damping is legal");
        m.insert("position_zero_uncertainty_m".into(), " 1e-5 ".into());
        let r = RigMeta::from_map(&m).unwrap();
        assert_eq!(r.position_zero_uncertainty_m(), Some(1e-5));
        assert_eq!(
            RigMeta::from_map(&rig_a())
                .unwrap()
                .position_zero_uncertainty_m(),
            None
        );
    }
}
