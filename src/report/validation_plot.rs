//! The validation figure (paper Fig. 10 style): measured amplitudes of a
//! sweep (settled steps filled, unsettled hollow) with their own 95 % error
//! bars (sensor noise and gain), against the steady-state prediction with
//! its 95 % band and the replay with its band (the law's and the drive's
//! uncertainty), over the two linear limit curves and η0, η1, η2; a
//! measured value outside the replay band is ringed; a third panel shows
//! the residuals.

use super::plot::{backend, colour, plot_err, register_font, DrawError, DrawResult};
use crate::error::Result;
use crate::model::Absorber;
use crate::validate::frc::MeasuredFrc;
use crate::validate::predict::Prediction;
use plotters::coord::types::RangedCoordf64;
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
type Chart<'a, 'b> = ChartContext<'a, SVGBackend<'b>, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

fn e(x: DrawingAreaErrorKind<std::io::Error>) -> DrawError {
    backend(x)
}

/// What both amplitude panels and the residual panel share: the measured
/// η of each point, the padded η range, the absorber's η0, η1, η2, the
/// grid of the limit curves and the colours.
struct Frame {
    etas: Vec<f64>,
    lo: f64,
    hi: f64,
    ab: Absorber,
    eta0: f64,
    eta1: f64,
    eta2: f64,
    grid: Vec<f64>,
    c_meas: RGBColor,
    c_steady: RGBColor,
    c_replay: RGBColor,
}

impl Frame {
    fn new(frc: &MeasuredFrc, pred: &Prediction) -> Frame {
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
        Frame {
            etas,
            lo,
            hi,
            ab,
            eta0,
            eta1,
            eta2,
            grid,
            c_meas,
            c_steady,
            c_replay,
        }
    }
}

/// The series of one amplitude panel (`which` 0: mass 1, 1: mass 2): the
/// measured amplitudes and the steady-state and replay predictions with
/// their 95 % bands.
struct PanelData<'p> {
    which: usize,
    /// Steps whose replay is sensitive to its measured start.
    sensitive: Vec<bool>,
    meas: Vec<f64>,
    /// The measured values' own 95 % error bars.
    u: Vec<f64>,
    st: &'p [Option<f64>],
    st_lo: &'p [Option<f64>],
    st_hi: &'p [Option<f64>],
    rp: &'p [Option<f64>],
    rp_lo: &'p [Option<f64>],
    rp_hi: &'p [Option<f64>],
}

impl<'p> PanelData<'p> {
    fn new(frc: &MeasuredFrc, pred: &'p Prediction, which: usize) -> PanelData<'p> {
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
        let u: Vec<f64> = frc
            .points
            .iter()
            .map(|p| {
                let u = if which == 0 {
                    p.amplitude1_u
                } else {
                    p.amplitude2_u
                };
                if u.is_finite() {
                    u
                } else {
                    0.0
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
        PanelData {
            which,
            sensitive: pred
                .replay_sensitive
                .iter()
                .map(|s| *s == Some(true))
                .collect(),
            meas,
            u,
            st,
            st_lo,
            st_hi,
            rp,
            rp_lo,
            rp_hi,
        }
    }
}

fn draw(title: &str, frc: &MeasuredFrc, pred: &Prediction, root: &Area<'_>) -> DrawResult {
    root.fill(&WHITE).map_err(e)?;
    let root = root.titled(title, ("sans-serif", 24)).map_err(e)?;
    let (top, bottom) = root.split_vertically(800);
    let panels = top.split_evenly((2, 1));
    let f = Frame::new(frc, pred);
    for (panel, which) in panels.iter().zip([0usize, 1]) {
        amplitude_panel(panel, &f, pred, &PanelData::new(frc, pred, which))?;
    }
    residual_panel(&bottom, &f, frc, pred)
}

/// Rows of the legend without the sensitive steps' row.
const LEGEND_ROWS: usize = 10;
/// Width of the legend box (px, its longest label at 13 px).
const LEGEND_WIDTH_PX: f64 = 440.0;

/// One amplitude panel: axes, limit curves, steady state, replay, measured
/// points and (on the first panel) the legend.
fn amplitude_panel(
    panel: &Area<'_>,
    f: &Frame,
    pred: &Prediction,
    d: &PanelData<'_>,
) -> DrawResult {
    let (lo, hi) = (f.lo, f.hi);
    let data_max = d
        .meas
        .iter()
        .copied()
        .chain(d.st_hi.iter().flatten().copied())
        .chain(d.rp_hi.iter().flatten().copied())
        .filter(|v| v.is_finite())
        .fold(0.0f64, f64::max);
    let mut ymax = (data_max * 1.15).max(0.5);
    if d.which == 0 {
        // The legend (upper right) must not cover a point: raise the top
        // until the values under the legend's box stay below it.
        let (w_px, h_px) = panel.dim_in_pixel();
        let plot_w = (w_px as f64 - 55.0 - 24.0).max(100.0);
        let plot_h = (h_px as f64 - 40.0 - 24.0).max(100.0);
        let rows = LEGEND_ROWS + usize::from(d.sensitive.iter().any(|&s| s));
        let hf = ((rows as f64 * 19.0 + 16.0) / plot_h).min(0.7);
        let x0 = hi - (LEGEND_WIDTH_PX / plot_w).min(0.9) * (hi - lo);
        let under = (0..f.etas.len())
            .filter(|&i| f.etas[i] >= x0)
            .flat_map(|i| {
                [
                    Some(d.meas[i] + d.u[i]),
                    d.st_hi[i],
                    d.rp_hi[i],
                    d.rp[i],
                    d.st[i],
                ]
            })
            .flatten()
            .filter(|v| v.is_finite())
            .fold(0.0f64, f64::max);
        ymax = ymax.max(1.04 * under / (1.0 - hf));
    }
    let mut chart = ChartBuilder::on(panel)
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(55)
        .build_cartesian_2d(lo..hi, 0.0..ymax)
        .map_err(e)?;
    chart
        .configure_mesh()
        .x_desc("η")
        .y_desc(if d.which == 0 { "A1/A" } else { "A2/A" })
        .label_style(("sans-serif", 16))
        .axis_desc_style(("sans-serif", 18))
        .light_line_style(RGBColor(235, 235, 235))
        .draw()
        .map_err(e)?;
    limit_curves(&mut chart, f, d.which, ymax)?;
    steady_series(&mut chart, f, d)?;
    replay_series(&mut chart, f, d)?;
    measured_series(&mut chart, f, pred, d)?;
    if d.which == 0 {
        legend(&mut chart)?;
    }
    Ok(())
}

/// The linear limit curves (no friction, rigid stick) and the η0, η1, η2
/// markers of an amplitude panel.
fn limit_curves(chart: &mut Chart<'_, '_>, f: &Frame, which: usize, ymax: f64) -> DrawResult {
    let (lo, hi, ab) = (f.lo, f.hi, &f.ab);
    let grey = RGBColor(150, 150, 150);
    let (free, stuck) = super::plot::limit_points(ab, &f.grid, which, ymax);
    chart
        .draw_series(DashedLineSeries::new(free, 6, 4, grey.stroke_width(1)))
        .map_err(e)?
        .label("no friction (ρs = 0)")
        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], grey));
    let dark = RGBColor(90, 90, 90);
    chart
        .draw_series(DashedLineSeries::new(stuck, 2, 3, dark.stroke_width(1)))
        .map_err(e)?
        .label("rigid stick (ρs = ∞)")
        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], dark));
    super::plot::eta_markers(
        chart,
        [("η1", f.eta1), ("η0", f.eta0), ("η2", f.eta2)],
        (lo, hi),
        ymax,
        RGBColor(190, 190, 190),
    )
}

/// Steady-state band (polygon over the points that have one) and line.
fn steady_series(chart: &mut Chart<'_, '_>, f: &Frame, d: &PanelData<'_>) -> DrawResult {
    let (etas, c_steady) = (&f.etas, f.c_steady);
    let band: Vec<(f64, f64, f64)> = (0..etas.len())
        .filter_map(|i| match (d.st_lo[i], d.st_hi[i]) {
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
        .filter_map(|i| d.st[i].map(|v| (etas[i], v)))
        .collect();
    line.sort_by(|a, b| a.0.total_cmp(&b.0));
    chart
        .draw_series(LineSeries::new(line, c_steady.stroke_width(2)))
        .map_err(e)?
        .label("steady-state prediction")
        .legend(move |(x, y)| {
            PathElement::new(vec![(x, y), (x + 20, y)], c_steady.stroke_width(2))
        });
    Ok(())
}

/// Replay: points with error bars.
fn replay_series(chart: &mut Chart<'_, '_>, f: &Frame, d: &PanelData<'_>) -> DrawResult {
    let (etas, c_replay) = (&f.etas, f.c_replay);
    let dx = 0.004 * (f.hi - f.lo);
    for (i, &eta) in etas.iter().enumerate() {
        if let (Some(l), Some(h)) = (d.rp_lo[i], d.rp_hi[i]) {
            let x = eta + dx;
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
            d.rp[i].map(|v| TriangleMarker::new((etas[i] + dx, v), 5, c_replay.filled()))
        }))
        .map_err(e)?
        .label("replay of the sweep as run, 95 % band (law and drive)")
        .legend(move |(x, y)| TriangleMarker::new((x + 10, y), 5, c_replay.filled()));
    // Sensitive steps: the replay hinges on its measured start (the band
    // holds the ensemble's range).
    if d.sensitive.iter().any(|&s| s) {
        let c_sens = RGBColor(230, 140, 0);
        chart
            .draw_series((0..etas.len()).filter(|&i| d.sensitive[i]).filter_map(|i| {
                d.rp[i].map(|v| Cross::new((etas[i] + dx, v), 7, c_sens.stroke_width(2)))
            }))
            .map_err(e)?
            .label("replay sensitive to its measured start (band holds the spread)")
            .legend(move |(x, y)| Cross::new((x + 10, y), 6, c_sens.stroke_width(2)));
    }
    Ok(())
}

/// Measured: settled filled, others hollow.
fn measured_series(
    chart: &mut Chart<'_, '_>,
    f: &Frame,
    pred: &Prediction,
    d: &PanelData<'_>,
) -> DrawResult {
    let (etas, meas, c_meas) = (&f.etas, &d.meas, f.c_meas);
    let settled = |i: usize| pred.steady_reached.get(i).copied().flatten() == Some(true);
    // Each measured value's own 95 % error bar, with caps.
    let cap = 0.002 * (f.hi - f.lo);
    chart
        .draw_series(
            (0..etas.len())
                .filter(|&i| d.u[i] > 0.0 && meas[i].is_finite())
                .flat_map(|i| {
                    let (x, lo, hi) = (etas[i], (meas[i] - d.u[i]).max(0.0), meas[i] + d.u[i]);
                    [
                        PathElement::new(vec![(x, lo), (x, hi)], c_meas.stroke_width(1)),
                        PathElement::new(
                            vec![(x - cap, lo), (x + cap, lo)],
                            c_meas.stroke_width(1),
                        ),
                        PathElement::new(
                            vec![(x - cap, hi), (x + cap, hi)],
                            c_meas.stroke_width(1),
                        ),
                    ]
                }),
        )
        .map_err(e)?
        .label("measured value's own 95 % error bar (sensor noise, gain)")
        .legend(move |(x, y)| {
            PathElement::new(
                vec![(x + 10, y - 7), (x + 10, y + 7)],
                c_meas.stroke_width(1),
            )
        });
    // Measured values outside the replay band (strict coverage misses).
    let outside = |i: usize| match (d.rp_lo[i], d.rp_hi[i]) {
        (Some(l), Some(h)) => meas[i] < l || meas[i] > h,
        _ => false,
    };
    let c_out = RGBColor(200, 30, 30);
    chart
        .draw_series(
            (0..etas.len())
                .filter(|&i| outside(i))
                .map(|i| Circle::new((etas[i], meas[i]), 8, c_out.stroke_width(2))),
        )
        .map_err(e)?
        .label("measured value outside the replay band")
        .legend(move |(x, y)| Circle::new((x + 10, y), 7, c_out.stroke_width(2)));
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
    Ok(())
}

/// The legend box of a panel (upper right).
fn legend<'a, 'b: 'a>(chart: &mut Chart<'a, 'b>) -> DrawResult {
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.85))
        .border_style(RGBColor(200, 200, 200))
        .label_font(("sans-serif", 13))
        .draw()
        .map_err(e)
}

/// Residuals of the replay and steady state, relative to the measured peak.
fn residual_panel(
    bottom: &Area<'_>,
    f: &Frame,
    frc: &MeasuredFrc,
    pred: &Prediction,
) -> DrawResult {
    let (etas, lo, hi) = (&f.etas, f.lo, f.hi);
    let (c_steady, c_replay) = (f.c_steady, f.c_replay);
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
    let mut chart = ChartBuilder::on(bottom)
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
    legend(&mut chart)
}
