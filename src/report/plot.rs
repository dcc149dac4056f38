//! Figures drawn like the paper's: frequency-response families (Figs. 3–5)
//! with both amplitudes, the two linear limit curves (no friction; rigid
//! stick) and the natural frequencies η0, η1, η2 marked.
//!
//! SVG or PNG by the file extension; PNG text uses the bundled DejaVu Sans
//! (`fonts/`, Bitstream Vera licence), so figures render the same on any
//! machine without system fonts.

use crate::error::{Error, Result};
use crate::model::Absorber;
use crate::sim::linear;
use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;
use std::sync::Once;

static FONT: Once = Once::new();

pub(crate) fn register_font() {
    FONT.call_once(|| {
        let bytes: &'static [u8] = include_bytes!("fonts/DejaVuSans.ttf");
        // The bundled font is valid; a failure would only lose text.
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, bytes);
    });
}

/// One curve of a frequency-response family.
#[derive(Debug, Clone, PartialEq)]
pub struct FrcCurve {
    /// Legend text.
    pub label: String,
    /// η values (ascending).
    pub eta: Vec<f64>,
    /// A1/A (None: no amplitude, e.g. interrupted).
    pub a1: Vec<Option<f64>>,
    /// A2/A.
    pub a2: Vec<Option<f64>>,
    /// Points where another branch settles to a different stable state
    /// (drawn as open circles); empty or all false when not known.
    pub coexisting: Vec<bool>,
}

/// A frequency-response figure.
#[derive(Debug, Clone, PartialEq)]
pub struct FrcFigure {
    /// Title.
    pub title: String,
    /// The absorber (limit curves and natural frequencies).
    pub absorber: Absorber,
    /// The curves.
    pub curves: Vec<FrcCurve>,
    /// η range of the axes.
    pub eta_range: (f64, f64),
}

/// Why a figure could not be drawn (the doors, e.g. [`frc`], name the file
/// through [`plot_err`]).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub(crate) enum DrawError {
    /// The plotting backend failed (its message).
    #[error("{0}")]
    Backend(String),
    /// The figure's η range is empty or not finite.
    #[error("no η range to draw ({lo} to {hi})")]
    NoEtaRange {
        /// Lower end.
        lo: f64,
        /// Upper end.
        hi: f64,
    },
    /// A work-precision figure without a row that has an error.
    #[error("no rows with an error to plot")]
    NoErrorRows,
    /// The batch figure has no positive normal force or amplitude.
    #[error("nothing to draw")]
    NothingToDraw,
}

/// Result of a drawing step.
pub(crate) type DrawResult<T = ()> = std::result::Result<T, DrawError>;

/// A plotting backend's error as a [`DrawError::Backend`].
pub(crate) fn backend<E: std::error::Error + Send + Sync>(x: DrawingAreaErrorKind<E>) -> DrawError {
    DrawError::Backend(x.to_string())
}

pub(crate) fn plot_err(path: &Path, e: impl std::fmt::Display) -> Error {
    Error::Input {
        path: path.to_path_buf(),
        msg: format!("cannot draw the figure: {e}"),
    }
}

/// Draws the figure to `path` (`.svg` or `.png`), atomically.
pub fn frc(fig: &FrcFigure, path: &Path) -> Result<()> {
    register_font();
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    let size = (1000, 900);
    match ext.as_str() {
        "svg" => {
            let mut s = String::new();
            {
                let root = SVGBackend::with_string(&mut s, size).into_drawing_area();
                draw_frc(fig, &root).map_err(|e| plot_err(path, e))?;
                root.present().map_err(|e| plot_err(path, e))?;
            }
            crate::io::write_atomic(path, s.as_bytes())
        }
        "png" => {
            let dest = crate::io::resolve_output(path);
            let tmp = crate::io::temp_beside(&dest, Some("png"))?;
            {
                let root = BitMapBackend::new(tmp.path(), size).into_drawing_area();
                let r = draw_frc(fig, &root).and_then(|_| root.present().map_err(backend));
                if let Err(e) = r {
                    return Err(plot_err(path, e));
                }
            }
            crate::io::txn::finish(tmp, &dest, path)
        }
        _ => Err(Error::Input {
            path: path.to_path_buf(),
            msg: "figure must be .svg or .png".into(),
        }),
    }
}

/// Colours for up to 16 curves (the paper's families have 7–13).
pub(crate) fn colour(i: usize, n: usize) -> RGBColor {
    let t = if n <= 1 {
        0.0
    } else {
        i as f64 / (n - 1) as f64
    };
    // A perceptually ordered ramp: blue → green → orange → red.
    let stops = [
        (31, 119, 180),
        (44, 160, 44),
        (255, 127, 14),
        (214, 39, 40),
        (148, 103, 189),
    ];
    let x = t * (stops.len() - 1) as f64;
    let k = (x.floor() as usize).min(stops.len() - 2);
    let f = x - k as f64;
    let lerp = |a: u8, b: u8| (a as f64 + (b as f64 - a as f64) * f).round() as u8;
    RGBColor(
        lerp(stops[k].0, stops[k + 1].0),
        lerp(stops[k].1, stops[k + 1].1),
        lerp(stops[k].2, stops[k + 1].2),
    )
}

type FrcChart<'a, DB> = ChartContext<'a, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// Points (η, amplitude) of a curve.
pub(crate) type Points = Vec<(f64, f64)>;

/// The linear limits of an amplitude panel (`which`: 0 for A1/A, 1 for
/// A2/A) on `grid`, clipped at 2·`ymax`: (no friction, ρs = 0; rigid
/// stick, ρs = ∞).
pub(crate) fn limit_points(
    ab: &crate::model::Absorber,
    grid: &[f64],
    which: usize,
    ymax: f64,
) -> (Points, Points) {
    let pick = |(a1, a2): (f64, f64)| if which == 0 { a1 } else { a2 }.min(ymax * 2.0);
    let free = grid
        .iter()
        .map(|&x| (x, pick(linear::free_amplitudes(ab, 0.0, x))))
        .collect();
    let stuck = grid
        .iter()
        .map(|&x| (x, pick(linear::stuck_amplitudes(ab, x))))
        .collect();
    (free, stuck)
}

/// The linear system's natural frequencies (`markers`: label and η) as
/// dashed verticals with their labels, where they fall inside `(lo, hi)`.
pub(crate) fn eta_markers<DB: DrawingBackend>(
    chart: &mut FrcChart<'_, DB>,
    markers: [(&str, f64); 3],
    (lo, hi): (f64, f64),
    ymax: f64,
    colour: RGBColor,
) -> DrawResult {
    let e = backend::<DB::ErrorType>;
    for (name, v) in markers {
        if v > lo && v < hi {
            chart
                .draw_series(DashedLineSeries::new(
                    vec![(v, 0.0), (v, ymax)],
                    3,
                    3,
                    colour.stroke_width(1),
                ))
                .map_err(e)?;
            chart
                .draw_series(std::iter::once(Text::new(
                    name.to_string(),
                    (v, ymax * 0.97),
                    ("sans-serif", 15),
                )))
                .map_err(e)?;
        }
    }
    Ok(())
}

fn draw_frc<DB: DrawingBackend>(fig: &FrcFigure, root: &DrawingArea<DB, Shift>) -> DrawResult {
    let e = backend::<DB::ErrorType>;
    root.fill(&WHITE).map_err(e)?;
    let root = root.titled(&fig.title, ("sans-serif", 26)).map_err(e)?;
    let panels = root.split_evenly((2, 1));
    let (lo, hi) = fig.eta_range;
    if !(lo.is_finite() && hi.is_finite() && lo < hi) {
        return Err(DrawError::NoEtaRange { lo, hi });
    }
    let grid: Vec<f64> = (0..=800)
        .map(|i| lo + (hi - lo) * i as f64 / 800.0)
        .collect();
    for (panel, which) in panels.iter().zip([0usize, 1]) {
        frc_panel(fig, panel, which, &grid)?;
    }
    Ok(())
}

/// One panel of the FRC figure (`which` 0: A1, 1: A2): axes, limits,
/// curves, coexisting states and (first panel) the legend.
fn frc_panel<DB: DrawingBackend>(
    fig: &FrcFigure,
    panel: &DrawingArea<DB, Shift>,
    which: usize,
    grid: &[f64],
) -> DrawResult {
    let e = backend::<DB::ErrorType>;
    let (lo, hi) = fig.eta_range;
    let data_max = fig
        .curves
        .iter()
        .flat_map(|c| if which == 0 { c.a1.iter() } else { c.a2.iter() })
        .flatten()
        .copied()
        .filter(|v| v.is_finite())
        .fold(0.0f64, f64::max);
    // Resonance peaks of the lightly damped limits reach ~70: cap the
    // axis so the friction curves stay readable (peaks are clipped).
    let ymax = (data_max * 1.15).clamp(1.0, 15.0);
    let ylabel = if which == 0 { "A1/A" } else { "A2/A" };
    let mut chart = ChartBuilder::on(panel)
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(55)
        .build_cartesian_2d(lo..hi, 0.0..ymax)
        .map_err(e)?;
    chart
        .configure_mesh()
        .x_desc("η")
        .y_desc(ylabel)
        .label_style(("sans-serif", 16))
        .axis_desc_style(("sans-serif", 18))
        .light_line_style(RGBColor(235, 235, 235))
        .draw()
        .map_err(e)?;
    frc_limits(&mut chart, fig, which, ymax, grid)?;
    frc_curves(&mut chart, fig, which)?;
    frc_coexisting(&mut chart, fig, which, ymax)?;
    if which == 0 {
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .background_style(WHITE.mix(0.85))
            .border_style(RGBColor(200, 200, 200))
            .label_font(("sans-serif", 14))
            .draw()
            .map_err(e)?;
    }
    Ok(())
}

/// The two limits, no friction (ρs = 0) and rigid stick (ρs = ∞, first
/// panel only), and the η0, η1, η2 markers.
fn frc_limits<DB: DrawingBackend>(
    chart: &mut FrcChart<'_, DB>,
    fig: &FrcFigure,
    which: usize,
    ymax: f64,
    grid: &[f64],
) -> DrawResult {
    let e = backend::<DB::ErrorType>;
    let (lo, hi) = fig.eta_range;
    let ab = &fig.absorber;
    let (eta1, eta2) = ab.eta_linear();
    let eta0 = ab.eta_stuck();
    // The two limits: no friction (ρs = 0) and rigid stick (ρs = ∞).
    let grey = RGBColor(120, 120, 120);
    let (free, stuck) = limit_points(ab, grid, which, ymax);
    chart
        .draw_series(DashedLineSeries::new(free, 6, 4, grey.stroke_width(1)))
        .map_err(e)?
        .label("no friction")
        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], grey));
    if which == 0 {
        let dark = RGBColor(60, 60, 60);
        chart
            .draw_series(DashedLineSeries::new(stuck, 2, 3, dark.stroke_width(1)))
            .map_err(e)?
            .label("rigid stick")
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], dark));
    }
    // η0, η1, η2.
    eta_markers(
        chart,
        [("η1", eta1), ("η0", eta0), ("η2", eta2)],
        (lo, hi),
        ymax,
        RGBColor(170, 170, 170),
    )?;
    Ok(())
}

/// The curves, one colour each, broken where a point has no amplitude.
fn frc_curves<DB: DrawingBackend>(
    chart: &mut FrcChart<'_, DB>,
    fig: &FrcFigure,
    which: usize,
) -> DrawResult {
    let e = backend::<DB::ErrorType>;
    let n = fig.curves.len();
    for (i, c) in fig.curves.iter().enumerate() {
        let col = colour(i, n);
        let ys = if which == 0 { &c.a1 } else { &c.a2 };
        // Break the line where a point has no amplitude.
        let mut seg: Vec<(f64, f64)> = Vec::new();
        let mut first = true;
        let mut flush = |seg: &mut Vec<(f64, f64)>, chart: &mut FrcChart<'_, DB>| -> DrawResult {
            if seg.is_empty() {
                return Ok(());
            }
            let s = chart
                .draw_series(LineSeries::new(std::mem::take(seg), col.stroke_width(2)))
                .map_err(e)?;
            if first {
                s.label(c.label.clone()).legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], col.stroke_width(2))
                });
                first = false;
            }
            Ok(())
        };
        for (x, y) in c.eta.iter().zip(ys) {
            match y {
                Some(v) if v.is_finite() => seg.push((*x, *v)),
                _ => flush(&mut seg, chart)?,
            }
        }
        flush(&mut seg, chart)?;
    }
    Ok(())
}

/// Coexisting stable states: open circles on every branch's point.
fn frc_coexisting<DB: DrawingBackend>(
    chart: &mut FrcChart<'_, DB>,
    fig: &FrcFigure,
    which: usize,
    ymax: f64,
) -> DrawResult {
    let e = backend::<DB::ErrorType>;
    let marks: Vec<(f64, f64)> = fig
        .curves
        .iter()
        .flat_map(|c| {
            let ys = if which == 0 { &c.a1 } else { &c.a2 };
            c.eta
                .iter()
                .zip(ys)
                .zip(c.coexisting.iter().chain(std::iter::repeat(&false)))
                .filter_map(|((x, y), f)| match y {
                    Some(v) if *f && v.is_finite() => Some((*x, v.min(ymax))),
                    _ => None,
                })
        })
        .collect();
    if !marks.is_empty() {
        let black = RGBColor(0, 0, 0);
        chart
            .draw_series(
                marks
                    .into_iter()
                    .map(|p| Circle::new(p, 4, black.stroke_width(1))),
            )
            .map_err(e)?
            .label("coexisting stable states (branches differ)")
            .legend(move |(x, y)| Circle::new((x + 10, y), 4, black.stroke_width(1)));
    }
    Ok(())
}

/// A work-precision figure: error against run time, log–log, one series per
/// method (points labelled by their setting in the table, not the figure).
pub fn work_precision(rows: &[crate::sim::workprec::WpRow], path: &Path) -> Result<()> {
    register_font();
    let mut s = String::new();
    {
        let root = SVGBackend::with_string(&mut s, (900, 650)).into_drawing_area();
        draw_wp(rows, &root).map_err(|e| plot_err(path, e))?;
        root.present().map_err(|e| plot_err(path, e))?;
    }
    crate::io::write_atomic(path, s.as_bytes())
}

fn draw_wp<DB: DrawingBackend>(
    rows: &[crate::sim::workprec::WpRow],
    root: &DrawingArea<DB, Shift>,
) -> DrawResult {
    let e = backend::<DB::ErrorType>;
    root.fill(&WHITE).map_err(e)?;
    let pts: Vec<(&str, f64, f64)> = rows
        .iter()
        .filter_map(|r| {
            r.error
                .map(|err| (r.method.as_str(), r.seconds, err.max(1e-17)))
        })
        .collect();
    let (tmin, tmax) = pts.iter().fold((f64::INFINITY, 0.0f64), |(a, b), p| {
        (a.min(p.1), b.max(p.1))
    });
    let (emin, emax) = pts.iter().fold((f64::INFINITY, 0.0f64), |(a, b), p| {
        (a.min(p.2), b.max(p.2))
    });
    if pts.is_empty() {
        return Err(DrawError::NoErrorRows);
    }
    let mut chart = ChartBuilder::on(root)
        .caption(
            "Work-precision: worst relative error against run time",
            ("sans-serif", 22),
        )
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(70)
        .build_cartesian_2d(
            (tmin * 0.7..tmax * 1.4).log_scale(),
            (emin * 0.3..emax * 3.0).log_scale(),
        )
        .map_err(e)?;
    chart
        .configure_mesh()
        .x_desc("run time over all scenarios [s]")
        .y_desc("worst relative error")
        .label_style(("sans-serif", 15))
        .axis_desc_style(("sans-serif", 17))
        .draw()
        .map_err(e)?;
    let methods: Vec<&str> = {
        let mut m: Vec<&str> = pts.iter().map(|p| p.0).collect();
        m.dedup();
        m
    };
    for (i, m) in methods.iter().enumerate() {
        let col = colour(i, methods.len());
        let mut series: Vec<(f64, f64)> = pts
            .iter()
            .filter(|p| p.0 == *m)
            .map(|p| (p.1, p.2))
            .collect();
        series.sort_by(|a, b| a.0.total_cmp(&b.0));
        chart
            .draw_series(LineSeries::new(series.clone(), col.stroke_width(2)))
            .map_err(e)?
            .label(m.to_string())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], col.stroke_width(2)));
        chart
            .draw_series(series.into_iter().map(|p| Circle::new(p, 4, col.filled())))
            .map_err(e)?;
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.85))
        .border_style(RGBColor(200, 200, 200))
        .label_font(("sans-serif", 15))
        .draw()
        .map_err(e)?;
    Ok(())
}
