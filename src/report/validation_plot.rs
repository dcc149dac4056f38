//! The validation figure (paper Fig. 10 style): measured amplitudes of a
//! sweep (settled steps filled, unsettled hollow) against the steady-state
//! prediction with its 95 % band and the replay with its band, over the two
//! linear limit curves and η0, η1, η2; a third panel shows the residuals.

use super::plot::{colour, plot_err, register_font};
use crate::error::Result;
use crate::model::Absorber;
use crate::sim::linear;
use crate::validate::frc::MeasuredFrc;
use crate::validate::predict::Prediction;
use plotters::prelude::*;
use std::path::Path;

/// Draws the validation figure of one sweep to `path` (SVG), atomically.
pub fn validation_figure(
    title: &str,
    frc: &MeasuredFrc,
    pred: &Prediction,
    path: &Path,
) -> Result<()> {
    register_font();
    let mut s = String::new();
    {
        let root = SVGBackend::with_string(&mut s, (1000, 1150)).into_drawing_area();
        draw(title, frc, pred, &root).map_err(|e| plot_err(path, e))?;
        root.present().map_err(|e| plot_err(path, e))?;
    }
    crate::io::write_atomic(path, s.as_bytes())
}

type Area<'a> = DrawingArea<SVGBackend<'a>, plotters::coord::Shift>;

fn draw(
    title: &str,
    frc: &MeasuredFrc,
    pred: &Prediction,
    root: &Area<'_>,
) -> std::result::Result<(), String> {
    let e = |x: DrawingAreaErrorKind<std::io::Error>| x.to_string();
    root.fill(&WHITE).map_err(e)?;
    let root = root.titled(title, ("sans-serif", 24)).map_err(e)?;
    let (top, bottom) = root.split_vertically(800);
    let panels = top.split_evenly((2, 1));
    let etas: Vec<f64> = frc.points.iter().map(|p| p.eta).collect();
    let (mut lo, mut hi) = etas
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
            (a.min(x), b.max(x))
        });
    if lo.partial_cmp(&hi) != Some(std::cmp::Ordering::Less) {
        lo -= 0.05;
        hi += 0.05;
    }
    let pad = 0.04 * (hi - lo);
    let (lo, hi) = (lo - pad, hi + pad);
    let ab: Absorber = pred.absorber;
    let (eta1, eta2) = ab.eta_linear();
    let eta0 = ab.eta_stuck();
    let grid: Vec<f64> = (0..=600)
        .map(|i| lo + (hi - lo) * i as f64 / 600.0)
        .collect();
    let (c_meas, c_steady, c_replay) = (RGBColor(20, 20, 20), colour(0, 3), colour(2, 3));
    for (panel, which) in panels.iter().zip([0usize, 1]) {
        let meas: Vec<f64> = frc
            .points
            .iter()
            .map(|p| {
                if which == 0 {
                    p.amplitude1
                } else {
                    p.amplitude2
                }
            })
            .collect();
        let (st, st_lo, st_hi, rp, rp_lo, rp_hi) = if which == 0 {
            (
                &pred.steady.amplitude1,
                &pred.steady.amplitude1_low,
                &pred.steady.amplitude1_high,
                &pred.replay.amplitude1,
                &pred.replay.amplitude1_low,
                &pred.replay.amplitude1_high,
            )
        } else {
            (
                &pred.steady.amplitude2,
                &pred.steady.amplitude2_low,
                &pred.steady.amplitude2_high,
                &pred.replay.amplitude2,
                &pred.replay.amplitude2_low,
                &pred.replay.amplitude2_high,
            )
        };
        let data_max = meas
            .iter()
            .copied()
            .chain(st_hi.iter().flatten().copied())
            .chain(rp_hi.iter().flatten().copied())
            .filter(|v| v.is_finite())
            .fold(0.0f64, f64::max);
        let ymax = (data_max * 1.15).max(0.5);
        let mut chart = ChartBuilder::on(panel)
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(55)
            .build_cartesian_2d(lo..hi, 0.0..ymax)
            .map_err(e)?;
        chart
            .configure_mesh()
            .x_desc("η")
            .y_desc(if which == 0 { "A1/A" } else { "A2/A" })
            .label_style(("sans-serif", 16))
            .axis_desc_style(("sans-serif", 18))
            .light_line_style(RGBColor(235, 235, 235))
            .draw()
            .map_err(e)?;
        let grey = RGBColor(150, 150, 150);
        let free: Vec<(f64, f64)> = grid
            .iter()
            .map(|&x| {
                let (a1, a2) = linear::free_amplitudes(&ab, 0.0, x);
                (x, if which == 0 { a1 } else { a2 }.min(ymax * 2.0))
            })
            .collect();
        chart
            .draw_series(DashedLineSeries::new(free, 6, 4, grey.stroke_width(1)))
            .map_err(e)?
            .label("no friction (ρs = 0)")
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], grey));
        let stuck: Vec<(f64, f64)> = grid
            .iter()
            .map(|&x| {
                let (a1, a2) = linear::stuck_amplitudes(&ab, x);
                (x, if which == 0 { a1 } else { a2 }.min(ymax * 2.0))
            })
            .collect();
        let dark = RGBColor(90, 90, 90);
        chart
            .draw_series(DashedLineSeries::new(stuck, 2, 3, dark.stroke_width(1)))
            .map_err(e)?
            .label("rigid stick (ρs = ∞)")
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], dark));
        for (name, v) in [("η1", eta1), ("η0", eta0), ("η2", eta2)] {
            if v > lo && v < hi {
                chart
                    .draw_series(DashedLineSeries::new(
                        vec![(v, 0.0), (v, ymax)],
                        3,
                        3,
                        RGBColor(190, 190, 190).stroke_width(1),
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
        // Steady-state band (polygon over the points that have one) and line.
        let band: Vec<(f64, f64, f64)> = (0..etas.len())
            .filter_map(|i| match (st_lo[i], st_hi[i]) {
                (Some(l), Some(h)) => Some((etas[i], l, h)),
                _ => None,
            })
            .collect();
        if band.len() > 1 {
            let mut sorted = band.clone();
            sorted.sort_by(|a, b| a.0.total_cmp(&b.0));
            let mut poly: Vec<(f64, f64)> = sorted.iter().map(|&(x, l, _)| (x, l)).collect();
            poly.extend(sorted.iter().rev().map(|&(x, _, h)| (x, h)));
            chart
                .draw_series(std::iter::once(Polygon::new(
                    poly,
                    c_steady.mix(0.18).filled(),
                )))
                .map_err(e)?
                .label("steady state, 95 % band")
                .legend(move |(x, y)| {
                    Rectangle::new([(x, y - 5), (x + 20, y + 5)], c_steady.mix(0.3).filled())
                });
        }
        let mut line: Vec<(f64, f64)> = (0..etas.len())
            .filter_map(|i| st[i].map(|v| (etas[i], v)))
            .collect();
        line.sort_by(|a, b| a.0.total_cmp(&b.0));
        chart
            .draw_series(LineSeries::new(line, c_steady.stroke_width(2)))
            .map_err(e)?
            .label("steady-state prediction")
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 20, y)], c_steady.stroke_width(2))
            });
        // Replay: points with error bars.
        let dx = 0.004 * (hi - lo);
        for i in 0..etas.len() {
            if let (Some(l), Some(h)) = (rp_lo[i], rp_hi[i]) {
                let x = etas[i] + dx;
                chart
                    .draw_series(std::iter::once(PathElement::new(
                        vec![(x, l), (x, h)],
                        c_replay.stroke_width(2),
                    )))
                    .map_err(e)?;
            }
        }
        chart
            .draw_series((0..etas.len()).filter_map(|i| {
                rp[i].map(|v| TriangleMarker::new((etas[i] + dx, v), 5, c_replay.filled()))
            }))
            .map_err(e)?
            .label("replay of the sweep, 95 % band")
            .legend(move |(x, y)| TriangleMarker::new((x + 10, y), 5, c_replay.filled()));
        // Measured: settled filled, others hollow.
        let settled = |i: usize| pred.steady_reached.get(i).copied().flatten() == Some(true);
        chart
            .draw_series(
                (0..etas.len())
                    .filter(|&i| settled(i))
                    .map(|i| Circle::new((etas[i], meas[i]), 4, c_meas.filled())),
            )
            .map_err(e)?
            .label("measured, steady state reached")
            .legend(move |(x, y)| Circle::new((x + 10, y), 4, c_meas.filled()));
        chart
            .draw_series(
                (0..etas.len())
                    .filter(|&i| !settled(i))
                    .map(|i| Circle::new((etas[i], meas[i]), 4, c_meas.stroke_width(1))),
            )
            .map_err(e)?
            .label("measured, not settled")
            .legend(move |(x, y)| Circle::new((x + 10, y), 4, c_meas.stroke_width(1)));
        if which == 0 {
            chart
                .configure_series_labels()
                .position(SeriesLabelPosition::UpperRight)
                .background_style(WHITE.mix(0.85))
                .border_style(RGBColor(200, 200, 200))
                .label_font(("sans-serif", 13))
                .draw()
                .map_err(e)?;
        }
    }
    // Residuals of the replay and steady state, relative to the measured peak.
    let peak1 = frc
        .points
        .iter()
        .map(|p| p.amplitude1)
        .fold(0.0f64, f64::max)
        .max(1e-12);
    let res = |v: &[Option<f64>]| -> Vec<(f64, f64)> {
        (0..etas.len())
            .filter_map(|i| v[i].map(|p| (etas[i], (p - frc.points[i].amplitude1) / peak1)))
            .collect()
    };
    let (rr, rs) = (res(&pred.replay.amplitude1), res(&pred.steady.amplitude1));
    let m = rr
        .iter()
        .chain(rs.iter())
        .map(|p| p.1.abs())
        .fold(0.02f64, f64::max)
        .min(1.0)
        * 1.15;
    let mut chart = ChartBuilder::on(&bottom)
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(55)
        .build_cartesian_2d(lo..hi, -m..m)
        .map_err(e)?;
    chart
        .configure_mesh()
        .x_desc("η")
        .y_desc("(pred − meas) A1 / peak")
        .label_style(("sans-serif", 14))
        .axis_desc_style(("sans-serif", 16))
        .light_line_style(RGBColor(235, 235, 235))
        .draw()
        .map_err(e)?;
    chart
        .draw_series(LineSeries::new(
            vec![(lo, 0.0), (hi, 0.0)],
            RGBColor(120, 120, 120),
        ))
        .map_err(e)?;
    chart
        .draw_series(
            rr.iter()
                .map(|&(x, y)| TriangleMarker::new((x, y.clamp(-m, m)), 5, c_replay.filled())),
        )
        .map_err(e)?
        .label("replay")
        .legend(move |(x, y)| TriangleMarker::new((x + 10, y), 5, c_replay.filled()));
    chart
        .draw_series(
            rs.iter()
                .map(|&(x, y)| Circle::new((x, y.clamp(-m, m)), 4, c_steady.filled())),
        )
        .map_err(e)?
        .label("steady state")
        .legend(move |(x, y)| Circle::new((x + 10, y), 4, c_steady.filled()));
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.85))
        .border_style(RGBColor(200, 200, 200))
        .label_font(("sans-serif", 13))
        .draw()
        .map_err(e)?;
    Ok(())
}
