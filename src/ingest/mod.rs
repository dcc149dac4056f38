//! # Ingest: rig log → one clean [`Run`]
//!
//! This stage owns everything between a file on disk and the typed, checked
//! run that the later stages work on: reading the five log formats of
//! `docs/rig-log-format.md` (MCAP, DAQ CSV, Parquet, NI TDMS and MATLAB
//! MAT level 5; CSV, TDMS and MAT with a channel map),
//! parsing and checking the `rig` metadata ([`RigMeta`]), converting every
//! channel to SI and to seconds from the log start, detecting gaps and
//! dropouts, and laying all channels on one common time base.
//!
//! One door: [`read`]. Everything it refuses comes back as an [`IngestError`]
//! whose message starts with the file concerned.
//!
//! Submodules: `mcap` (streaming MCAP reader), `csv` (DAQ export + TOML
//! channel map), `parquet` (tables, also the writer of canonical runs),
//! `tdms` and `mat` (hand-written readers of NI TDMS and MAT level 5, with
//! the CSV channel map),
//! [`rig`] (metadata), `run` (gaps and the common time base), [`clip`]
//! (saturated channels: their flat samples are left out, with a warning),
//! `delays` (channel delays against x1 and the velocity's consistency with
//! x2, estimated and corrected on every log).

mod buffer_json;
pub mod clip;
mod csv;
mod delays;
mod json;
mod mat;
mod mcap;
mod parquet;
pub mod rig;
mod run;
mod tdms;

use std::path::{Path, PathBuf};

pub use delays::{
    AccelerationConsistency, ChannelDelay, ChannelDelays, VelocityConsistency,
    VELOCITY_GAIN_TOLERANCE,
};
pub use rig::{RigError, RigMeta, SweepKind, TestKind, FORMAT_VERSION, ZERO_UNCERTAINTY};
pub(crate) use run::interpolate;
pub use run::{Channel, Column, Gap, GapKind, Resampled, Run, Setpoint, MAX_BRIDGE_SAMPLES};

/// Options of [`read`].
#[derive(Debug, Clone, Default)]
pub struct IngestOptions {
    /// Channel map of a CSV, TDMS or MAT log (default: `NAME.map.toml`
    /// beside the log).
    pub map: Option<PathBuf>,
    /// Samples the caller can hold (the fit's budget): a CSV log with more
    /// data rows is refused after they are counted, before any column is
    /// read; a Parquet table with more rows, from its footer; an MCAP log
    /// whose position channel has more, as soon as its summary or its
    /// samples say so (`None`: the ingest's own budget only).
    pub max_samples: Option<u64>,
}

/// The log formats [`read`] understands, chosen by file extension.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LogFormat {
    /// `.mcap`: the rig's own recording.
    Mcap,
    /// `.csv`: a DAQ export with a channel map.
    Csv,
    /// `.parquet`: a table on a common time base.
    Parquet,
    /// `.tdms`: an NI TDMS file with a channel map.
    Tdms,
    /// `.mat`: a MATLAB MAT-file (level 5) with a channel map.
    Mat,
}

impl LogFormat {
    /// The format's name.
    pub fn as_str(self) -> &'static str {
        match self {
            LogFormat::Mcap => "mcap",
            LogFormat::Csv => "csv",
            LogFormat::Parquet => "parquet",
            LogFormat::Tdms => "tdms",
            LogFormat::Mat => "mat",
        }
    }

    /// Whether logs of this format need a channel map.
    pub fn needs_map(self) -> bool {
        matches!(self, LogFormat::Csv | LogFormat::Tdms | LogFormat::Mat)
    }
}

/// A physical quantity the rig records (one channel each).
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, serde::Serialize, serde::Deserialize,
)]
pub enum Quantity {
    /// x0: shaker pin displacement (m).
    X0,
    /// x1: main mass displacement (m).
    X1,
    /// x2: absorber mass displacement (m).
    X2,
    /// x2': absorber mass velocity (m/s).
    V2,
    /// x2'': absorber mass acceleration (m/s²); may be absent.
    A2,
    /// Normal force at the friction member (N).
    NormalForce,
}

impl Quantity {
    /// All quantities, in canonical column order.
    pub const ALL: [Quantity; 6] = [
        Quantity::X0,
        Quantity::X1,
        Quantity::X2,
        Quantity::V2,
        Quantity::A2,
        Quantity::NormalForce,
    ];

    /// Canonical name (column of the canonical run, key of a channel map).
    pub fn name(self) -> &'static str {
        match self {
            Quantity::X0 => "x0",
            Quantity::X1 => "x1",
            Quantity::X2 => "x2",
            Quantity::V2 => "v2",
            Quantity::A2 => "a2",
            Quantity::NormalForce => "normal_force",
        }
    }

    /// The MCAP topic that carries it.
    pub fn topic(self) -> &'static str {
        match self {
            Quantity::X0 => "/drive/position",
            Quantity::X1 => "/mass1/position",
            Quantity::X2 => "/mass2/position",
            Quantity::V2 => "/mass2/velocity",
            Quantity::A2 => "/mass2/acceleration",
            Quantity::NormalForce => "/friction/normal_force",
        }
    }

    /// Its SI unit.
    pub fn unit(self) -> &'static str {
        match self {
            Quantity::X0 | Quantity::X1 | Quantity::X2 => "m",
            Quantity::V2 => "m/s",
            Quantity::A2 => "m/s^2",
            Quantity::NormalForce => "N",
        }
    }

    /// Whether a log without it is refused (x0, x1, x2; the velocity v2
    /// may be absent: identification then derives ẋ2 from x2).
    pub fn required(self) -> bool {
        matches!(self, Quantity::X0 | Quantity::X1 | Quantity::X2)
    }

    /// Whether it is a position channel (these set the common time base).
    pub fn is_position(self) -> bool {
        matches!(self, Quantity::X0 | Quantity::X1 | Quantity::X2)
    }

    /// The quantity of a canonical name.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|q| q.name() == name)
    }

    /// The quantity carried by an MCAP topic.
    pub fn from_topic(topic: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|q| q.topic() == topic)
    }
}

/// Why a log could not be ingested. Every message starts with the file.
#[derive(Debug, thiserror::Error)]
pub enum IngestError {
    /// The file could not be opened or read.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file concerned.
        path: PathBuf,
        /// What the operating system said.
        source: std::io::Error,
    },
    /// The `rig` metadata is missing something or holds a bad value.
    #[error("{}: {source}", path.display())]
    Rig {
        /// The log.
        path: PathBuf,
        /// What is wrong with the record.
        source: RigError,
    },
    /// What is wrong with the log, whatever its format (a kind with
    /// its numbers).
    #[error("{}: {source}", path.display())]
    Content {
        /// The log.
        path: PathBuf,
        /// What is wrong.
        source: ContentError,
    },
    /// Anything else wrong with the content (what a format's reader found).
    #[error("{}: {msg}", path.display())]
    Invalid {
        /// The file concerned.
        path: PathBuf,
        /// What is wrong.
        msg: String,
    },
}

/// What is wrong with a log whatever its format: the file, its channels
/// and their times, the signal, the rig ([`IngestError::Content`]).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ContentError {
    /// The file's extension names no log format.
    #[error("unknown log type {:?}: expected a .mcap, .csv, .parquet, .tdms or .mat file", if .extension.is_empty() { "(no extension)" } else { .extension.as_str() })]
    UnknownType {
        /// The extension, lower case (empty: none).
        extension: String,
    },
    /// A directory was given.
    #[error("is a directory, not a log file")]
    Directory,
    /// The file is empty.
    #[error("file is empty")]
    Empty,
    /// Two channels carry one quantity.
    #[error("two channels carry {quantity} ({first} and {second})")]
    DuplicateQuantity {
        /// The quantity's name.
        quantity: &'static str,
        /// The first channel.
        first: String,
        /// The second channel.
        second: String,
    },
    /// A channel's times and values differ in length.
    #[error("{channel}: times and values differ in length")]
    LengthMismatch {
        /// The channel.
        channel: String,
    },
    /// A channel without a valid sample interval.
    #[error("{channel}: no valid sample interval")]
    NoSampleInterval {
        /// The channel.
        channel: String,
    },
    /// A sample whose time is not finite.
    #[error("{channel}: sample {sample} has no valid time")]
    InvalidTime {
        /// The channel.
        channel: String,
        /// The sample (0-based).
        sample: usize,
    },
    /// A sample whose time does not follow the one before.
    #[error("non-monotonic time on channel {channel}: sample {sample} at {t_s:.6} s does not follow {previous_s:.6} s")]
    NonMonotonicTime {
        /// The channel.
        channel: String,
        /// The sample (0-based).
        sample: usize,
        /// Its time (s).
        t_s: f64,
        /// The time of the sample before (s).
        previous_s: f64,
    },
    /// An infinite sample.
    #[error("{channel}: sample {sample} is infinite")]
    InfiniteSample {
        /// The channel.
        channel: String,
        /// The sample (0-based).
        sample: usize,
    },
    /// A required channel without a valid sample.
    #[error("no data: channel {channel} has no valid sample")]
    NoValidSample {
        /// The channel.
        channel: String,
    },
    /// A required channel is missing.
    #[error("no data for required channel {quantity} ({source_name})")]
    MissingChannel {
        /// The quantity's name.
        quantity: &'static str,
        /// Its topic (MCAP) or column name.
        source_name: &'static str,
    },
    /// The position channels' time span does not fit their samples.
    #[error("time stamps inconsistent: the position channels span {span_s:.3} s but hold only {samples} samples at {rate_hz} Hz")]
    InconsistentTimes {
        /// The span (s).
        span_s: f64,
        /// The most samples of a position channel.
        samples: usize,
        /// Their rate (Hz).
        rate_hz: f64,
    },
    /// Motion channels without signal.
    #[error("the channel{} {} carr{} no signal (every sample the same value): nothing moved or the sensor was not connected; there is nothing to fit", if .channels.len() > 1 { "s" } else { "" }, .channels.join(", "), if .channels.len() > 1 { "y" } else { "ies" })]
    NoSignal {
        /// The flat channels.
        channels: Vec<&'static str>,
    },
    /// Rig constants the engines cannot integrate.
    #[error("rig metadata: {0}")]
    NotIntegrable(#[from] crate::model::IntegrableError),
    /// More samples than the caller can fit
    /// ([`IngestOptions::max_samples`]), known before the log was decoded.
    #[error("{}", crate::limits::fit_refusal(.subject, *.samples, *.max))]
    OverFitBudget {
        /// What was counted, for the message (`12000000 data rows`).
        subject: String,
        /// The count.
        samples: u64,
        /// The most samples the caller fits.
        max: u64,
        /// How `samples` relates to the log's common grid.
        count: SampleCount,
    },
}

/// What an [`ContentError::OverFitBudget`] count says about the log's
/// common grid (which runs at the fastest position channel's rate).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SampleCount {
    /// The grid's samples (CSV and Parquet rows; the longest position
    /// channel of a TDMS or MAT log, or as an MCAP summary announces it).
    Grid,
    /// Only a lower bound (samples decoded so far; an MCAP log without a
    /// summary, or whose position channels did not all announce theirs).
    AtLeast,
}

impl IngestError {
    /// An [`IngestError::Content`] of `kind` for `path`.
    pub(crate) fn content(path: &Path, kind: ContentError) -> Self {
        IngestError::Content {
            path: path.to_path_buf(),
            source: kind,
        }
    }
    /// An [`IngestError::Invalid`] for `path`.
    /// The message is folded onto one line (errors of other crates, e.g.
    /// TOML's, can span several).
    pub(crate) fn invalid(path: &Path, msg: impl Into<String>) -> Self {
        let msg: String = msg.into();
        let msg = if msg.contains('\n') {
            msg.lines()
                .map(str::trim)
                .filter(|l| !l.is_empty())
                .collect::<Vec<_>>()
                .join(" ")
        } else {
            msg
        };
        IngestError::Invalid {
            path: path.to_path_buf(),
            msg,
        }
    }

    /// An [`IngestError::Io`] for `path`.
    pub(crate) fn io(path: &Path, source: std::io::Error) -> Self {
        IngestError::Io {
            path: path.to_path_buf(),
            source,
        }
    }

    /// An [`IngestError::Rig`] for `path`.
    pub(crate) fn rig(path: &Path, source: RigError) -> Self {
        IngestError::Rig {
            path: path.to_path_buf(),
            source,
        }
    }
}

/// One channel as a format reader delivers it, before gap analysis.
#[derive(Debug, Clone)]
pub(crate) struct RawChannel {
    pub quantity: Quantity,
    /// Topic or column name it came from.
    pub source: String,
    /// Nominal sample interval (s).
    pub dt_s: f64,
    /// Sample times (s) on the reader's clock (any origin); channels of
    /// one table share theirs.
    pub t: Column,
    /// Values in SI, NaN for a dropout.
    pub v: Vec<f64>,
}

/// What a format reader delivers.
#[derive(Debug, Clone)]
pub(crate) struct RawLog {
    pub format: LogFormat,
    pub rig: RigMeta,
    pub channels: Vec<RawChannel>,
    /// The log start on the reader's clock (tables: the first row's time);
    /// `None`: the earliest sample of any channel.
    pub origin: Option<f64>,
    /// Setpoints, times on the same clock as the channels.
    pub setpoints: Vec<Setpoint>,
    pub warnings: Vec<crate::warning::Warning>,
    /// Time shifts declared per channel (a CSV map's `shift_s`), already
    /// applied to the times.
    pub declared_shifts: Vec<(Quantity, f64)>,
}

/// The samples of the log's common grid as far as they are known before
/// its channels are decoded, for planning memory (several logs fitted at
/// once): the CSV row count, the Parquet footer's, the longest position
/// channel of a TDMS or MAT log or as an MCAP summary announces it
/// ([`read`] with a budget of no sample, whose refusal carries the count).
/// `None` where only a lower bound is known before decoding (an MCAP log
/// without a summary). A log that cannot be read gives `Some(0)`: its read
/// fails as early.
///
/// ```
/// use stickslip::ingest::{planned_samples, read, IngestOptions};
/// let path = "datasets/char_N4.mcap".as_ref();
/// let planned = planned_samples(path, &IngestOptions::default()).unwrap();
/// let grid = read(path, &IngestOptions::default())?.samples() as u64;
/// // Counted from the summary before decoding: within 1 % of the grid.
/// assert!(planned.abs_diff(grid) <= grid / 100, "{planned} vs {grid}");
/// # Ok::<(), stickslip::ingest::IngestError>(())
/// ```
pub fn planned_samples(path: &Path, opts: &IngestOptions) -> Option<u64> {
    let probe = IngestOptions {
        max_samples: Some(0),
        ..opts.clone()
    };
    match read(path, &probe) {
        Err(IngestError::Content {
            source: ContentError::OverFitBudget { samples, count, .. },
            ..
        }) => (count == SampleCount::Grid).then_some(samples),
        Ok(run) => Some(run.samples() as u64),
        Err(_) => Some(0),
    }
}

/// Reads a rig log (`.mcap`, `.csv`, `.parquet`, `.tdms` or `.mat`; CSV,
/// TDMS and MAT with a channel map) into one clean [`Run`].
///
/// The format is chosen by the file extension. A channel map is
/// `opts.map`, or `NAME.map.toml` beside the log.
///
/// ```
/// use stickslip::ingest::{read, IngestOptions, TestKind};
/// let run = read("datasets/char_N4.mcap".as_ref(), &IngestOptions::default())?;
/// assert_eq!(run.rig.test, TestKind::Characteristic);
/// assert!((run.rig.k2_n_per_m - 670.0).abs() < 1e-9);
/// assert!(run.resampled.t.len() > 1000);
/// # Ok::<(), stickslip::ingest::IngestError>(())
/// ```
pub fn read(path: &Path, opts: &IngestOptions) -> Result<Run, IngestError> {
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    let format = match ext.as_str() {
        "mcap" => LogFormat::Mcap,
        "csv" => LogFormat::Csv,
        "parquet" | "pq" => LogFormat::Parquet,
        "tdms" => LogFormat::Tdms,
        "mat" => LogFormat::Mat,
        _ => {
            return Err(IngestError::content(
                path,
                ContentError::UnknownType { extension: ext },
            ))
        }
    };
    let meta = std::fs::metadata(path).map_err(|e| IngestError::io(path, e))?;
    if meta.is_dir() {
        return Err(IngestError::content(path, ContentError::Directory));
    }
    if meta.len() == 0 {
        return Err(IngestError::content(path, ContentError::Empty));
    }
    let held = match format {
        LogFormat::Tdms => Some(("TDMS", tdms::MAX_TDMS_BYTES)),
        LogFormat::Mat => Some(("MAT", mat::MAX_MAT_BYTES)),
        _ => None,
    };
    if let Some((kind, max)) = held {
        if meta.len() > max {
            // Refused before any read: the reader holds the whole file.
            return Err(IngestError::invalid(
                path,
                format!(
                    "is {} bytes; a {kind} log is read whole and its channels take up to 8 times its size, over {}: {kind} logs up to {max} bytes are read; split it into shorter logs",
                    meta.len(),
                    crate::limits::budget_text()
                ),
            ));
        }
    }
    let mut raw = match format {
        LogFormat::Mcap => mcap::read(path, opts.max_samples)?,
        LogFormat::Csv => csv::read(path, opts.map.as_deref(), opts.max_samples)?,
        LogFormat::Parquet => parquet::read(path, opts.max_samples)?,
        LogFormat::Tdms => tdms::read(path, opts.map.as_deref(), opts.max_samples)?,
        LogFormat::Mat => mat::read(path, opts.map.as_deref(), opts.max_samples)?,
    };
    if opts.map.is_some() && !format.needs_map() {
        raw.warnings.push(crate::warning::Warning::MapIgnored);
    }
    let run = run::build(path, raw)?;
    check_signal(path, &run)?;
    // Rig constants the engines cannot integrate (fit, validate and batch
    // simulate the rig): refused with the numbers.
    let drive_hz = run.rig.drive_frequency_hz.unwrap_or(0.0);
    run.rig
        .constants()
        .check_integrable(drive_hz)
        .map_err(|e| IngestError::content(path, e.into()))?;
    Ok(run)
}

/// Refuses a log whose motion channels carry no signal (every finite
/// sample of x0, x1 or x2 the same, e.g. an all-zero log): nothing moved,
/// or the sensors were not connected, and any fit of it would be made up.
fn check_signal(path: &Path, run: &Run) -> Result<(), IngestError> {
    let r = &run.resampled;
    let flat: Vec<&str> = [("x0", &r.x0[..]), ("x1", &r.x1), ("x2", &r.x2)]
        .into_iter()
        .filter(|(_, v)| {
            let mut finite = v.iter().copied().filter(|x| x.is_finite());
            match finite.next() {
                Some(first) => {
                    let mut n = 1usize;
                    let same = finite.all(|x| {
                        n += 1;
                        x == first
                    });
                    same && n >= 2
                }
                None => false,
            }
        })
        .map(|(name, _)| name)
        .collect();
    if flat.is_empty() {
        return Ok(());
    }
    Err(IngestError::content(
        path,
        ContentError::NoSignal { channels: flat },
    ))
}

/// Parses and checks a CSV channel map (the TOML text of `NAME.map.toml`)
/// without reading a log, as [`read`] does before the table; `path` names
/// the map in errors. The entry point of the map parser's fuzz target.
pub fn check_channel_map(path: &Path, text: &str) -> Result<(), IngestError> {
    csv::parse_map(path, text).map(|_| ())
}

/// Converts a value in `unit` to the SI unit of `q`: the factor to multiply
/// by, or `None` if the unit is not one of `q`'s dimension.
pub(crate) fn unit_factor(q: Quantity, unit: &str) -> Option<f64> {
    let u: String = unit
        .trim()
        .chars()
        .filter(|c| !c.is_whitespace())
        .collect::<String>()
        .replace('²', "^2")
        .replace("**", "^")
        .replace("s2", "s^2")
        .replace(['µ', 'μ'], "u");
    let u = u.as_str();
    match q {
        Quantity::X0 | Quantity::X1 | Quantity::X2 => match u {
            "m" => Some(1.0),
            "mm" => Some(1e-3),
            "um" => Some(1e-6),
            _ => None,
        },
        Quantity::V2 => match u {
            "m/s" => Some(1.0),
            "mm/s" => Some(1e-3),
            "um/s" => Some(1e-6),
            _ => None,
        },
        Quantity::A2 => match u {
            "m/s^2" => Some(1.0),
            "mm/s^2" => Some(1e-3),
            _ => None,
        },
        Quantity::NormalForce => match u {
            "N" => Some(1.0),
            "kN" => Some(1e3),
            "mN" => Some(1e-3),
            _ => None,
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantities_round_trip_names_and_topics() {
        for q in Quantity::ALL {
            assert_eq!(Quantity::from_name(q.name()), Some(q));
            assert_eq!(Quantity::from_topic(q.topic()), Some(q));
            assert_eq!(unit_factor(q, q.unit()), Some(1.0));
        }
        assert_eq!(Quantity::from_topic("/drive/setpoint"), None);
    }

    #[test]
    fn unit_factors() {
        assert_eq!(unit_factor(Quantity::X1, "mm"), Some(1e-3));
        assert_eq!(unit_factor(Quantity::A2, "m/s²"), Some(1.0));
        assert_eq!(unit_factor(Quantity::X1, "m/s"), None);
        assert_eq!(unit_factor(Quantity::NormalForce, "furlong"), None);
    }

    #[test]
    fn unknown_extension_and_empty_file_are_refused() {
        let dir = tempfile::tempdir().expect("tempdir");
        let odd = dir.path().join("log.txt");
        std::fs::write(&odd, b"hello").expect("write");
        let e = read(&odd, &IngestOptions::default()).unwrap_err();
        assert!(
            matches!(&e, IngestError::Content { source: ContentError::UnknownType { extension }, .. } if extension == "txt"),
            "{e:?}"
        );
        let e = e.to_string();
        assert!(
            e.contains("log.txt")
                && e.ends_with("unknown log type \"txt\": expected a .mcap, .csv, .parquet, .tdms or .mat file"),
            "{e}"
        );
        let e = read(&dir.path().join("log"), &IngestOptions::default())
            .unwrap_err()
            .to_string();
        assert!(e.contains("unknown log type \"(no extension)\""), "{e}");
        for name in [
            "empty.mcap",
            "empty.csv",
            "empty.parquet",
            "empty.tdms",
            "empty.mat",
        ] {
            let p = dir.path().join(name);
            std::fs::write(&p, b"").expect("write");
            let e = read(&p, &IngestOptions::default()).unwrap_err();
            assert!(
                matches!(
                    e,
                    IngestError::Content {
                        source: ContentError::Empty,
                        ..
                    }
                ),
                "{e:?}"
            );
            let e = e.to_string();
            assert!(e.contains(name) && e.ends_with(": file is empty"), "{e}");
        }
    }
}
