//! Option groups shared by several subcommands.

use crate::model::{LawKind, Model};
use crate::pipeline::shape::ShapeSpec;
use clap::Args;

/// The parser of a family name among `kinds` (the help and the error list
/// the names).
fn kind_parser(
    kinds: impl Iterator<Item = LawKind>,
) -> impl clap::builder::TypedValueParser<Value = LawKind> {
    use clap::builder::TypedValueParser;
    let names: Vec<&'static str> = kinds.map(LawKind::as_str).collect();
    clap::builder::PossibleValuesParser::new(names)
        .map(|s: String| LawKind::parse(&s).expect("a registered name"))
}

/// The parser of a registered family's name.
pub fn law_kind() -> impl clap::builder::TypedValueParser<Value = LawKind> {
    kind_parser(LawKind::all().iter().copied())
}

/// The parser of the name of a family with a velocity scale.
pub fn shaped_law_kind() -> impl clap::builder::TypedValueParser<Value = LawKind> {
    kind_parser(
        LawKind::all()
            .iter()
            .copied()
            .filter(|k| k.family().has_velocity_scale()),
    )
}

/// Parser of a relative gain uncertainty: a finite fraction in [0, 0.5).
pub fn gain_fraction(s: &str) -> Result<f64, String> {
    let v = number(s)?;
    if v.is_finite() && (0.0..0.5).contains(&v) {
        Ok(v)
    } else {
        Err("must be a finite fraction in [0, 0.5)".into())
    }
}

/// Parser of a length bound (m): a finite number ≥ 0 (the position
/// zeros' calibration uncertainty).
pub fn length_bound(s: &str) -> Result<f64, String> {
    let v = number(s)?;
    if v.is_finite() && v >= 0.0 {
        Ok(v)
    } else {
        Err(format!(
            "{v} is not a length bound: give a finite number ≥ 0 in metres, e.g. 1e-5"
        ))
    }
}

/// A number (any f64 syntax, surrounding blanks ignored).
fn number(s: &str) -> Result<f64, String> {
    s.trim()
        .parse()
        .map_err(|_| format!("`{s}` is not a number"))
}

/// Parser of an engine tolerance: a finite number in (0, 0.1] (a NaN or
/// infinite tolerance would make the error control accept any step).
pub fn tolerance(s: &str) -> Result<f64, String> {
    let v = number(s)?;
    if v.is_finite() && v > 0.0 && v <= 0.1 {
        Ok(v)
    } else {
        Err(format!(
            "{v} is not a tolerance: give a finite number in (0, 0.1], e.g. 1e-10"
        ))
    }
}

/// Parser of a period budget: 1 to 1e8 periods.
pub fn periods() -> clap::builder::RangedU64ValueParser<u64> {
    clap::value_parser!(u64).range(1..=100_000_000)
}

/// The model options shared by `simulate` and `sweep` (all but ρs, ρd).
#[derive(Debug, Clone, Args)]
pub struct ShapeArgs {
    /// Mass ratio m = M1/M2.
    #[arg(long, default_value_t = ShapeSpec::default().m, allow_hyphen_values = true)]
    pub m: f64,
    /// Stiffness ratio k = K1/K2.
    #[arg(long, default_value_t = ShapeSpec::default().k, allow_hyphen_values = true)]
    pub k: f64,
    /// Viscous damping D = d/sqrt(K2 M2).
    #[arg(long, default_value_t = ShapeSpec::default().damping, allow_hyphen_values = true)]
    pub damping: f64,
    /// Slope D* of the characteristic (ignored where rho_s = 0: no friction).
    #[arg(long, default_value_t = ShapeSpec::default().slope, allow_hyphen_values = true)]
    pub slope: f64,
    /// Velocity scale v_s of a law that has one: with the default
    /// `--law stribeck`, ρd + (ρs − ρd)·exp(−(v/v_s)²) + D*·v.
    #[arg(long = "v-s", allow_hyphen_values = true)]
    pub v_s: Option<f64>,
    /// Family of a law with a velocity scale (needs --v-s; default
    /// stribeck). An affine law is given by --rho-d and --slope.
    #[arg(long = "law", value_parser = shaped_law_kind(), requires = "v_s")]
    pub law: Option<LawKind>,
    /// Interrupt when the sliding friction falls below F·rho_s (of the
    /// current sliding direction).
    #[arg(long = "stop-below", allow_hyphen_values = true)]
    pub stop_below: Option<f64>,
    /// Direction-dependent friction: the static threshold for sliding in
    /// the negative direction (default: rho-s, which then holds for the
    /// positive direction only).
    #[arg(long = "rho-s-minus", allow_hyphen_values = true)]
    pub rho_s_minus: Option<f64>,
    /// The dynamic level for sliding in the negative direction (default:
    /// rho-s-minus where it is given, else rho-d).
    #[arg(long = "rho-d-minus", allow_hyphen_values = true)]
    pub rho_d_minus: Option<f64>,
    /// Pre-sliding: the tangential contact stiffness κ = kt/K2 between M2
    /// and its friction slider (a Jenkins element; inf: the rigid stick).
    /// `sweep` takes a list (one family of curves per value).
    #[arg(
        long = "contact-stiffness",
        allow_hyphen_values = true,
        value_delimiter = ','
    )]
    pub contact_stiffness: Vec<f64>,
}

impl ShapeArgs {
    /// The options as the library's plain model shape (the model is built
    /// and checked there: [`ShapeSpec::model_with`]).
    pub fn spec(&self) -> ShapeSpec {
        ShapeSpec {
            m: self.m,
            k: self.k,
            damping: self.damping,
            slope: self.slope,
            v_s: self.v_s,
            law: self.law,
            stop_below: self.stop_below,
            rho_s_minus: self.rho_s_minus,
            rho_d_minus: self.rho_d_minus,
            contact_stiffness: self.contact_stiffness.clone(),
        }
    }
}

/// The dimensionless model options of `simulate`.
#[derive(Debug, Clone, Args)]
pub struct ModelArgs {
    /// Absorber and law shape.
    #[command(flatten)]
    pub shape: ShapeArgs,
    /// Static threshold rho_s (0: no friction; inf: always stuck).
    #[arg(long = "rho-s", default_value_t = 0.0, allow_hyphen_values = true)]
    pub rho_s: f64,
    /// Dynamic level rho_d (default: equal to rho_s).
    #[arg(long = "rho-d", allow_hyphen_values = true)]
    pub rho_d: Option<f64>,
}

impl ModelArgs {
    /// The validated model.
    pub fn model(&self) -> crate::Result<Model> {
        self.shape.spec().model(self.rho_s, self.rho_d)
    }
}

/// A count in `lo..=hi` for a flag, with the limit and its reason named.
fn count_in(s: &str, lo: usize, hi: usize, why: &str) -> Result<usize, String> {
    let n: usize = s
        .trim()
        .parse()
        .map_err(|_| format!("`{s}` is not a whole number"))?;
    if n < lo || n > hi {
        return Err(format!("{n} is outside {lo}..={hi} ({why})"));
    }
    Ok(n)
}

/// `--samples` of validate/run: laws drawn for the prediction bands.
pub fn band_samples(s: &str) -> Result<usize, String> {
    count_in(s, 0, 2000, "each draw is a whole predicted sweep")
}

/// `--band-coverage-se` of validate/run: a fraction in [0, 0.5].
pub fn coverage_se(s: &str) -> Result<f64, String> {
    let v = number(s)?;
    if !(0.0..=0.5).contains(&v) {
        return Err(format!(
            "{v} is outside 0..=0.5 (a standard error of a fraction)"
        ));
    }
    Ok(v)
}

/// `--bootstrap`: replicates over drive periods.
pub fn bootstrap_replicates(s: &str) -> Result<usize, String> {
    count_in(s, 0, 100_000, "beyond that the interval no longer improves")
}

/// `--points` of a sweep.
pub fn sweep_points(s: &str) -> Result<usize, String> {
    count_in(s, 1, 100_000, "each point is a steady state per curve")
}
