//! The batch figure: worst-case main-mass amplitude max_η A1/A (worse of
//! the up, down and from-rest branches) against the normal force, log–log,
//! at the estimated μs, μd; the robust worst case (over each setting's
//! uncertainty box) beside it; the measured settings, the recommendation
//! with its window and the cliff where the η1 peak returns marked.

use super::plot::{backend, colour, plot_err, register_font, DrawError, DrawResult};
use crate::batch::{Batch, StaticObs};
use crate::error::Result;
use plotters::coord::combinators::LogCoord;
use plotters::prelude::*;
use std::path::Path;

/// Draws the batch figure to `path` (SVG), atomically.
pub fn batch_figure(b: &Batch, title: &str, path: &Path) -> Result<()> {
    register_font();
    let mut s = String::new();
    {
        let root = SVGBackend::with_string(&mut s, (1000, 640)).into_drawing_area();
        draw(b, title, &root).map_err(|e| plot_err(path, e))?;
        root.present().map_err(|e| plot_err(path, e))?;
    }
    crate::io::write_atomic(path, s.as_bytes())
}

type Area<'a> = DrawingArea<SVGBackend<'a>, plotters::coord::Shift>;
type Chart<'a, 'b> = ChartContext<'a, SVGBackend<'b>, Cartesian2d<LogCoord<f64>, LogCoord<f64>>>;

fn e(x: DrawingAreaErrorKind<std::io::Error>) -> DrawError {
    backend(x)
}

/// Whether `x` can be drawn on a log axis.
fn pos(x: f64) -> bool {
    x.is_finite() && x > 0.0
}

fn draw(b: &Batch, title: &str, root: &Area<'_>) -> DrawResult {
    root.fill(&WHITE).map_err(e)?;
    let root = root.titled(title, ("sans-serif", 22)).map_err(e)?;
    let (x0, x1, y0, y1) = ranges(b)?;
    let mut chart = ChartBuilder::on(&root)
        .margin(14)
        .x_label_area_size(45)
        .y_label_area_size(65)
        .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
        .map_err(e)?;
    chart
        .configure_mesh()
        .x_desc("normal force N (newtons)")
        .y_desc("worst case max_η A1/A")
        .label_style(("sans-serif", 15))
        .axis_desc_style(("sans-serif", 17))
        .x_label_formatter(&|v| format!("{v}"))
        .y_label_formatter(&|v| format!("{v}"))
        .max_light_lines(1)
        .light_line_style(RGBColor(240, 240, 240))
        .draw()
        .map_err(e)?;
    window(&mut chart, b, y0, y1)?;
    curves(&mut chart, b)?;
    cliff(&mut chart, b, y0, y1)?;
    measured(&mut chart, b)?;
    recommendation(&mut chart, b)?;
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.9))
        .border_style(RGBColor(200, 200, 200))
        .label_font(("sans-serif", 13))
        .draw()
        .map_err(e)?;
    Ok(())
}

/// The axis ranges `(x0, x1, y0, y1)` over the drawable (positive) normal
/// forces and amplitudes of the curves and the logs; an error when there
/// is nothing to draw.
fn ranges(b: &Batch) -> DrawResult<(f64, f64, f64, f64)> {
    let xs = b
        .curve
        .iter()
        .map(|c| c.normal_force_n)
        .chain(b.logs.iter().map(|l| l.normal_force_n))
        .filter(|x| pos(*x));
    let (xmin, xmax) = xs.fold((f64::INFINITY, 0.0f64), |(a, c), x| (a.min(x), c.max(x)));
    let ys = b
        .curve
        .iter()
        .flat_map(|c| [Some(c.worst.amplitude1), c.robust])
        .flatten()
        .chain(b.logs.iter().filter_map(|l| l.worst.map(|w| w.amplitude1)))
        .filter(|y| pos(*y));
    let (ymin, ymax) = ys.fold((f64::INFINITY, 0.0f64), |(a, c), y| (a.min(y), c.max(y)));
    if !(pos(xmin) && pos(xmax) && pos(ymin) && pos(ymax)) {
        return Err(DrawError::NothingToDraw);
    }
    let (x0, x1) = (xmin / 1.15, xmax * 1.15);
    let (y0, y1) = ((ymin / 1.5).min(0.5), ymax * 2.0);
    Ok((x0, x1, y0, y1))
}

/// The window of the recommendation.
fn window(chart: &mut Chart<'_, '_>, b: &Batch, y0: f64, y1: f64) -> DrawResult {
    let green = RGBColor(44, 160, 44);
    if let Some(r) = &b.recommendation {
        chart
            .draw_series(std::iter::once(Rectangle::new(
                [(r.interval_n.0, y0), (r.interval_n.1, y1)],
                green.mix(0.12).filled(),
            )))
            .map_err(e)?
            .label(format!(
                "window {:.2}–{:.2} N (robust worst case within {:.0} %)",
                r.interval_n.0,
                r.interval_n.1,
                100.0 * b.window
            ))
            .legend(move |(x, y)| {
                Rectangle::new([(x, y - 5), (x + 20, y + 5)], green.mix(0.25).filled())
            });
    }
    Ok(())
}

/// Nominal and robust curves.
fn curves(chart: &mut Chart<'_, '_>, b: &Batch) -> DrawResult {
    let blue = colour(0, 3);
    let nominal: Vec<(f64, f64)> = b
        .curve
        .iter()
        .map(|c| (c.normal_force_n, c.worst.amplitude1))
        .filter(|(x, y)| pos(*x) && pos(*y))
        .collect();
    chart
        .draw_series(LineSeries::new(nominal.clone(), blue.stroke_width(2)))
        .map_err(e)?
        .label(format!(
            "W at μs = {:.4}, μd = {:.4} (worse of up, down, from rest)",
            b.mu_s.mu, b.mu_d.mu
        ))
        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], blue.stroke_width(2)));
    chart
        .draw_series(
            nominal
                .iter()
                .map(|&(x, y)| Circle::new((x, y), 2, blue.filled())),
        )
        .map_err(e)?;
    let orange = RGBColor(255, 127, 14);
    let robust: Vec<(f64, f64)> = b
        .curve
        .iter()
        .filter_map(|c| c.robust.map(|r| (c.normal_force_n, r)))
        .filter(|(x, y)| pos(*x) && pos(*y))
        .collect();
    chart
        .draw_series(DashedLineSeries::new(robust, 6, 4, orange.stroke_width(2)))
        .map_err(e)?
        .label(format!(
            "robust: worst over μ intervals and ±{:.0} % setting",
            100.0 * b.setting_tolerance
        ))
        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], orange.stroke_width(2)));
    Ok(())
}

/// The cliff.
fn cliff(chart: &mut Chart<'_, '_>, b: &Batch, y0: f64, y1: f64) -> DrawResult {
    let grey = RGBColor(110, 110, 110);
    if let Some(c) = &b.cliff {
        chart
            .draw_series(DashedLineSeries::new(
                vec![(c.normal_force_n, y0), (c.normal_force_n, y1)],
                4,
                4,
                grey.stroke_width(1),
            ))
            .map_err(e)?
            .label(format!(
                "cliff at {:.2} N (ρs = {:.3}): η1 peak returns",
                c.normal_force_n, c.rho_s
            ))
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 20, y)], grey.stroke_width(1))
            });
    }
    Ok(())
}

/// Measured settings.
fn measured(chart: &mut Chart<'_, '_>, b: &Batch) -> DrawResult {
    let black = RGBColor(20, 20, 20);
    let mut first = true;
    for l in &b.logs {
        let Some(w) = l.worst else { continue };
        let (x, y) = (l.normal_force_n, w.amplitude1);
        if !(pos(x) && pos(y)) {
            continue;
        }
        let censored = !matches!(l.static_obs, StaticObs::Point { .. });
        let style = if censored {
            black.stroke_width(2)
        } else {
            black.filled()
        };
        let s = chart
            .draw_series(std::iter::once(Circle::new((x, y), 6, style)))
            .map_err(e)?;
        if first {
            s.label("measured settings (hollow: Rs only bounded)")
                .legend(move |(x, y)| Circle::new((x + 10, y), 5, black.filled()));
            first = false;
        }
        let name = l
            .log
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        chart
            .draw_series(std::iter::once(Text::new(
                name,
                (x * 1.03, y * 1.25),
                ("sans-serif", 13).into_font().color(&black),
            )))
            .map_err(e)?;
    }
    Ok(())
}

/// The recommendation.
fn recommendation(chart: &mut Chart<'_, '_>, b: &Batch) -> DrawResult {
    let red = RGBColor(214, 39, 40);
    if let Some(r) = &b.recommendation {
        chart
            .draw_series(std::iter::once(TriangleMarker::new(
                (r.normal_force_n, r.worst.amplitude1),
                9,
                red.filled(),
            )))
            .map_err(e)?
            .label(format!(
                "recommended {:.2} N (ρs = {:.3}): W = {:.3}, robust {:.3}",
                r.normal_force_n, r.rho_s, r.worst.amplitude1, r.worst_interval.1
            ))
            .legend(move |(x, y)| TriangleMarker::new((x + 10, y), 6, red.filled()));
    }
    Ok(())
}
