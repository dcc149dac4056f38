//! The characteristic figure (paper Figs. 8–9): the contact force R(t) and
//! the absorber velocity ẋ2(t) over the first drive periods (left), and R
//! against ẋ2 over the whole log with the fitted law drawn over it (right;
//! stick samples at ẋ2 = 0 with their passive force). A threshold split
//! by direction is drawn as it is: up to Rs⁺ towards +, down to −Rs⁻
//! towards − (a side only bounded is not drawn). Where calibrated position
//! zeros resolve the levels of each direction, the figure is in their
//! gauge: the measured forces as they are (no bias removed) and each law
//! with its own force bias, so the branches sit at Rd⁺ and −Rd⁻.

use super::plot::{backend as e, plot_err, register_font, DrawResult};
use crate::error::Result;
use crate::identify::{Characteristic, Contact, Estimate, LogFit};
use crate::model::SiLaw;
use plotters::prelude::*;
use std::path::Path;

/// What the characteristic figure shows.
#[derive(Debug, Clone, Copy)]
pub struct CharacteristicFigure<'a> {
    /// Title (escaped by the SVG backend).
    pub title: &'a str,
    /// What is drawn of the log ([`CharacteristicPoints::new`]).
    pub points: &'a CharacteristicPoints,
    /// The fitted law (None for a stuck log).
    pub law: Option<SiLaw>,
    /// Legend name of `law` (e.g. "fitted", "output error (used)").
    pub law_label: &'a str,
    /// `law`'s static threshold is measured (false where Rs is only
    /// bounded: the threshold is not drawn).
    pub threshold: bool,
    /// Where the fit split the threshold by direction: Rs⁻ (N) towards −
    /// (`Some(None)`: only bounded, not drawn; `None`: symmetric, −Rs).
    /// Towards + the law's own Rs, unless only bounded (`threshold`).
    pub minus_threshold_n: Option<Option<f64>>,
    /// A force (N) added to `law` where drawn: its force bias where the
    /// points keep theirs (calibrated zeros: the levels become Rd⁺ and
    /// −Rd⁻, the thresholds Rs⁺ and −Rs⁻); 0 where the points have the
    /// bias removed.
    pub law_offset_n: f64,
    /// A second law drawn dashed (e.g. the Stribeck alternative).
    pub alternative: Option<SiLaw>,
    /// Legend name of `alternative`.
    pub alternative_label: &'a str,
    /// `law_offset_n` of `alternative`.
    pub alternative_offset_n: f64,
}

/// Most samples each time panel draws (two drive periods): beyond, every
/// k-th sample (a 560-pixel panel shows no more).
pub const MAX_TIME_PANEL_POINTS: usize = 4096;

/// Most points the R(ẋ2) panel draws: every (n / 2500)-th sample.
pub const MAX_CHARACTERISTIC_POINTS: usize = 2500;

/// What the characteristic figure draws of a log, taken once from its
/// contact signals: at most a few thousand points whatever the log's
/// length, so a pipeline keeps these, not the log, until its report.
#[derive(Debug, Clone, PartialEq)]
pub struct CharacteristicPoints {
    /// Time (s), R − bias (N) and ẋ2 (m/s; 0 in stick) over the first two
    /// drive periods (every k-th sample beyond [`MAX_TIME_PANEL_POINTS`]).
    head: Vec<[f64; 3]>,
    /// The R(ẋ2) panel's ranges over every sample: (ẋ2, R), padded.
    v_range: (f64, f64),
    r_range: (f64, f64),
    /// Every (n / 2500)-th sample's (ẋ2, R) where both are finite.
    points: Vec<(f64, f64)>,
}

impl CharacteristicPoints {
    /// The points of contact signals `c` with stick flags `stick`
    /// (ẋ2 drawn as 0 there) and the force bias `bias_n` removed from R.
    pub fn new(c: &Contact, stick: &[bool], bias_n: f64) -> Self {
        let n = c.t.len().min(c.r.len()).min(c.v2.len()).min(stick.len());
        let r = |i: usize| c.r[i] - bias_n;
        let v = |i: usize| if stick[i] { 0.0 } else { c.v2[i] };
        let n_show = ((2.0 / c.drive.frequency_hz) / c.dt).round() as usize;
        let n_show = n_show.clamp(2, n.max(2)).min(n);
        let head = if n_show >= 2 {
            let every = n_show.div_ceil(MAX_TIME_PANEL_POINTS);
            (0..n_show)
                .step_by(every)
                .map(|i| [c.t[i], r(i), v(i)])
                .collect()
        } else {
            Vec::new()
        };
        let step = (n / MAX_CHARACTERISTIC_POINTS).max(1);
        Self {
            head,
            v_range: range((0..n).map(v)),
            r_range: range((0..n).map(r)),
            points: (0..n)
                .step_by(step)
                .map(|i| (v(i), r(i)))
                .filter(|(v, r)| v.is_finite() && r.is_finite())
                .collect(),
        }
    }

    /// Heap bytes held.
    pub fn bytes(&self) -> usize {
        self.head.capacity() * std::mem::size_of::<[f64; 3]>()
            + self.points.capacity() * std::mem::size_of::<(f64, f64)>()
    }
}

/// Draws the figure to `path` (SVG), atomically.
pub fn characteristic_figure(fig: &CharacteristicFigure<'_>, path: &Path) -> Result<()> {
    register_font();
    let mut s = String::new();
    {
        let root = SVGBackend::with_string(&mut s, (1100, 520)).into_drawing_area();
        draw(fig, &root).map_err(|e| plot_err(path, e))?;
        root.present().map_err(|e| plot_err(path, e))?;
    }
    crate::io::write_atomic(path, s.as_bytes())
}

/// The characteristic figure of a fitted log `log` (its characteristic
/// `ch`, its fit `f`) to `path`: the law used downstream and, beside it, the
/// equation-error law (the one fitted to these very points) where the
/// output error refined it, else the Stribeck alternative. A stuck log
/// shows no law; a never-sticking one no static threshold.
pub fn fit_figure(
    log: &Path,
    points: &CharacteristicPoints,
    f: &LogFit,
    path: &Path,
) -> Result<()> {
    let e = &f.fit;
    let split = f.pads().filter(|_| f.direction_dependent());
    // Calibrated zeros: the points keep the force bias (`fit_points`),
    // each law is drawn with its own.
    let (law_offset_n, alternative_offset_n) = match f.calibrated_bias_n() {
        Some(b) => (b, e.bias_n),
        None => (0.0, 0.0),
    };
    let (law, law_label, alternative, alternative_label) = if f.stuck() {
        (None, "fitted", None, "alternative")
    } else if f.estimate == Estimate::OutputError {
        (
            f.law(),
            "output error (used)",
            Some(e.law),
            "equation error",
        )
    } else {
        let alt = e.stribeck.filter(|s| s.kind != e.law.kind);
        (Some(e.law), "fitted", alt, "alternative")
    };
    let title = format!(
        "Characteristic of {}",
        log.file_name()
            .map_or("log".into(), |n| n.to_string_lossy())
    );
    characteristic_figure(
        &CharacteristicFigure {
            title: &title,
            points,
            law,
            law_label,
            // (No threshold where the fit gives Rs no number: bounded
            // towards +, unresolved behind a contact, between readings.)
            threshold: !f.never_sticks()
                && !f
                    .pads()
                    .is_some_and(crate::identify::output_error::PadFit::rs_unmeasured),
            minus_threshold_n: split.map(|p| p.rs_minus_n.filter(|_| !p.minus_bounded)),
            law_offset_n,
            alternative,
            alternative_label,
            alternative_offset_n,
        },
        path,
    )
}

/// The points [`fit_figure`] draws of a log's characteristic `ch` with its
/// fit `f` (the fit's force bias removed, unless calibrated zeros resolve
/// the levels of each direction: then the measured forces as they are).
pub fn fit_points(ch: &Characteristic, f: &LogFit) -> CharacteristicPoints {
    let bias = match f.calibrated_bias_n() {
        Some(_) => 0.0,
        None => f.fit.bias_n,
    };
    CharacteristicPoints::new(
        &ch.contact,
        &ch.segmentation.stick,
        if bias.is_finite() { bias } else { 0.0 },
    )
}

type Area<'a> = DrawingArea<SVGBackend<'a>, plotters::coord::Shift>;

fn range(v: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = v
        .filter(|x| x.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
            (a.min(x), b.max(x))
        });
    if !(lo.is_finite() && hi.is_finite()) {
        return (-1.0, 1.0);
    }
    let pad = 0.06 * (hi - lo).max(1e-12);
    (lo - pad, hi + pad)
}

/// The sliding friction of a law at velocity v (signed).
fn law_force(l: &SiLaw, v: f64) -> f64 {
    l.sliding_n(v.abs()) * v.signum()
}

const BLUE: RGBColor = RGBColor(31, 78, 156);
const RED: RGBColor = RGBColor(178, 34, 34);

fn draw(fig: &CharacteristicFigure<'_>, root: &Area<'_>) -> DrawResult {
    root.fill(&WHITE).map_err(e)?;
    let root = root.titled(fig.title, ("sans-serif", 20)).map_err(e)?;
    let (left, right) = root.split_horizontally(560);
    let (l_top, l_bot) = left.split_vertically(240);
    time_panels(&fig.points.head, &l_top, &l_bot)?;
    characteristic_panel(fig, &right)
}

/// Left: two drive periods of R(t) and ẋ2(t) (`head`: t, R, ẋ2).
fn time_panels<'a>(head: &[[f64; 3]], l_top: &Area<'a>, l_bot: &Area<'a>) -> DrawResult {
    let (blue, red) = (BLUE, RED);
    if let (Some(first), Some(last)) = (head.first(), head.last()) {
        let (t0, t1) = (first[0], last[0]);
        for (panel, col_i, col, label) in [(l_top, 1, blue, "R [N]"), (l_bot, 2, red, "ẋ2 [m/s]")]
        {
            let (lo, hi) = range(head.iter().map(|p| p[col_i]));
            let mut chart = ChartBuilder::on(panel)
                .margin(8)
                .x_label_area_size(32)
                .y_label_area_size(62)
                .build_cartesian_2d(t0..t1, lo..hi)
                .map_err(e)?;
            chart
                .configure_mesh()
                .x_desc("t [s]")
                .y_desc(label)
                .label_style(("sans-serif", 13))
                .axis_desc_style(("sans-serif", 15))
                .light_line_style(RGBColor(235, 235, 235))
                .draw()
                .map_err(e)?;
            // Finite runs as separate lines (gaps stay gaps).
            let mut run: Vec<(f64, f64)> = Vec::new();
            for p in head {
                let (t, y) = (p[0], p[col_i]);
                if y.is_finite() {
                    run.push((t, y));
                } else if !run.is_empty() {
                    chart
                        .draw_series(LineSeries::new(std::mem::take(&mut run), col))
                        .map_err(e)?;
                }
            }
            if !run.is_empty() {
                chart.draw_series(LineSeries::new(run, col)).map_err(e)?;
            }
        }
    }
    Ok(())
}

/// The curve of a law over [vlo, vhi] (300 points each side), with the
/// vertical static threshold at ẋ2 = 0 from −`minus` to +`plus` (each side
/// drawn where given: the law's Rs, or Rs⁻ of a split threshold).
fn law_curve(
    l: &SiLaw,
    (minus, plus): (Option<f64>, Option<f64>),
    vlo: f64,
    vhi: f64,
) -> Vec<(f64, f64)> {
    let m = 300;
    let mut pts = Vec::with_capacity(2 * m + 4);
    for k in 0..=m {
        let u = vlo + (0.0 - vlo) * k as f64 / m as f64;
        if u < 0.0 {
            pts.push((u, law_force(l, u)));
        }
    }
    let finite = |x: Option<f64>| x.filter(|x| x.is_finite());
    // The sliding levels at ±0 (where no threshold is drawn, the curve
    // joins them through zero velocity).
    let at_zero = l.sliding_n(0.0);
    pts.push((0.0, finite(minus).map_or(-at_zero, |m| -m)));
    pts.push((0.0, finite(plus).unwrap_or(at_zero)));
    for k in 0..=m {
        let u = vhi * k as f64 / m as f64;
        if u > 0.0 {
            pts.push((u, law_force(l, u)));
        }
    }
    pts
}

/// Right: R against ẋ2 over the whole log, the laws over it.
fn characteristic_panel(fig: &CharacteristicFigure<'_>, right: &Area<'_>) -> DrawResult {
    let (blue, red) = (BLUE, RED);
    let (vlo, vhi) = fig.points.v_range;
    let mut rr = fig.points.r_range;
    let sides = |l: &SiLaw| -> (Option<f64>, Option<f64>) {
        let plus = fig.threshold.then_some(l.rs_n);
        let minus = match fig.minus_threshold_n {
            None => plus,
            Some(m) => m,
        };
        (minus, plus)
    };
    if let Some(l) = fig.law {
        let (minus, plus) = sides(&l);
        let off = fig.law_offset_n;
        if let Some(m) = minus.filter(|m| m.is_finite()) {
            rr.0 = rr.0.min(1.05 * (off - m));
        }
        if let Some(p) = plus.filter(|p| p.is_finite()) {
            rr.1 = rr.1.max(1.05 * (p + off));
        }
    }
    let shifted = |pts: Vec<(f64, f64)>, off: f64| -> Vec<(f64, f64)> {
        pts.into_iter().map(|(v, r)| (v, r + off)).collect()
    };
    let mut chart = ChartBuilder::on(right)
        .margin(8)
        .x_label_area_size(36)
        .y_label_area_size(62)
        .build_cartesian_2d(vlo..vhi, rr.0..rr.1)
        .map_err(e)?;
    chart
        .configure_mesh()
        .x_desc("ẋ2 [m/s]")
        .y_desc("R [N]")
        .label_style(("sans-serif", 13))
        .axis_desc_style(("sans-serif", 15))
        .light_line_style(RGBColor(235, 235, 235))
        .draw()
        .map_err(e)?;
    // At most ~2500 points keep the SVG small.
    chart
        .draw_series(
            fig.points
                .points
                .iter()
                .map(|&(v, r)| Circle::new((v, r), 1, blue.mix(0.35).filled())),
        )
        .map_err(e)?
        .label("measured")
        .legend(move |(x, y)| Circle::new((x + 10, y), 3, blue.filled()));
    if let Some(l) = fig.law {
        let off = fig.law_offset_n;
        let mut split = match fig.minus_threshold_n {
            Some(Some(m)) => format!(" (Rs⁺ {:.3} N, Rs⁻ {:.3} N)", l.rs_n + off, m - off),
            Some(None) => " (Rs⁻ only bounded)".to_string(),
            None => String::new(),
        };
        if off != 0.0 {
            let rd = l.sliding_n(0.0);
            split += &format!(
                " (calibrated zeros: Rd⁺ {:.3} N, Rd⁻ {:.3} N)",
                rd + off,
                rd - off
            );
        }
        chart
            .draw_series(LineSeries::new(
                shifted(law_curve(&l, sides(&l), vlo, vhi), off),
                BLACK.stroke_width(2),
            ))
            .map_err(e)?
            .label(format!("{}: {}{split}", fig.law_label, l.kind.as_str()))
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLACK.stroke_width(2)));
    }
    if let Some(l) = fig.alternative {
        let pts = shifted(
            law_curve(&l, (Some(l.rs_n), Some(l.rs_n)), vlo, vhi),
            fig.alternative_offset_n,
        );
        let dashed = DashedLineSeries::new(pts, 6, 4, red.stroke_width(2));
        chart
            .draw_series(dashed)
            .map_err(e)?
            .label(format!("{}: {}", fig.alternative_label, l.kind.as_str()))
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], red.stroke_width(2)));
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperLeft)
        .background_style(WHITE.mix(0.85))
        .border_style(RGBColor(200, 200, 200))
        .label_font(("sans-serif", 13))
        .draw()
        .map_err(e)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::LawKind;

    /// The points kept of a log are a few thousand whatever its length:
    /// a log 40 times as long at a 40th of the drive frequency keeps at
    /// most [`MAX_TIME_PANEL_POINTS`] of its two periods and about
    /// [`MAX_CHARACTERISTIC_POINTS`] of R(ẋ2), with the ranges of every
    /// sample (the tiles': the short log's).
    #[test]
    fn the_points_kept_are_bounded_whatever_the_length() {
        let run = crate::ingest::read(
            "datasets/char_N4.mcap".as_ref(),
            &crate::ingest::IngestOptions::default(),
        )
        .unwrap();
        let ch = crate::identify::characteristic(&run, &Default::default()).unwrap();
        let (c, stick) = (&ch.contact, &ch.segmentation.stick);
        let n = c.t.len();
        let short = CharacteristicPoints::new(c, stick, 0.1);
        let n_show = ((2.0 / c.drive.frequency_hz) / c.dt).round() as usize;
        assert!(n_show < MAX_TIME_PANEL_POINTS && n_show > 100, "{n_show}");
        assert_eq!(short.head.len(), n_show);
        assert_eq!(
            short.head[7],
            [c.t[7], c.r[7] - 0.1, if stick[7] { 0.0 } else { c.v2[7] }]
        );
        assert!(short.points.len() <= 2 * MAX_CHARACTERISTIC_POINTS);
        let k = 40;
        let tile = |x: &[f64]| -> crate::ingest::Column { (0..k * n).map(|i| x[i % n]).collect() };
        let mut long = c.clone();
        long.t = (0..k * n).map(|i| i as f64 * c.dt).collect();
        long.r = tile(&c.r);
        long.v2 = tile(&c.v2);
        long.drive.frequency_hz /= k as f64;
        let long_stick: Vec<bool> = (0..k * n).map(|i| stick[i % n]).collect();
        let p = CharacteristicPoints::new(&long, &long_stick, 0.1);
        assert!(p.head.len() <= MAX_TIME_PANEL_POINTS, "{}", p.head.len());
        assert!(
            p.head.len() >= MAX_TIME_PANEL_POINTS / 2,
            "{}",
            p.head.len()
        );
        assert!(p.points.len() <= 2 * MAX_CHARACTERISTIC_POINTS);
        assert!(p.points.len() >= MAX_CHARACTERISTIC_POINTS / 2);
        assert_eq!((p.v_range, p.r_range), (short.v_range, short.r_range));
        assert!(p.bytes() < 200_000, "{}", p.bytes());
    }

    /// A split threshold is drawn from −Rs⁻ to +Rs⁺ at ẋ2 = 0; a side not
    /// given joins the sliding level there; the branches are the law's.
    #[test]
    fn the_threshold_is_drawn_per_direction() {
        let l = SiLaw {
            kind: LawKind::StaticDynamic,
            rs_n: 0.924,
            rd_n: 0.748,
            slope_n_s_per_m: 0.0,
            vs_m_per_s: None,
        };
        let at0 = |pts: &[(f64, f64)]| -> Vec<f64> {
            pts.iter().filter(|p| p.0 == 0.0).map(|p| p.1).collect()
        };
        let split = law_curve(&l, (Some(0.80), Some(0.924)), -0.1, 0.1);
        assert_eq!(at0(&split), vec![-0.80, 0.924]);
        let bounded = law_curve(&l, (None, Some(0.924)), -0.1, 0.1);
        assert_eq!(at0(&bounded), vec![-0.748, 0.924]);
        assert_eq!(split.first(), Some(&(-0.1, -0.748)));
        assert_eq!(split.last(), Some(&(0.1, 0.748)));
    }

    /// In the calibrated zeros' gauge the law is drawn with its force bias
    /// b: the legend gives Rd⁺ = Rd + b and Rd⁻ = Rd − b, and a split
    /// threshold's sides Rs⁺ + b and Rs⁻ − b.
    #[test]
    fn calibrated_zeros_draw_the_levels_of_each_direction() {
        let l = SiLaw {
            kind: LawKind::StaticDynamic,
            rs_n: 0.88,
            rd_n: 0.714,
            slope_n_s_per_m: 0.0,
            vs_m_per_s: None,
        };
        let points = CharacteristicPoints {
            head: vec![],
            v_range: (-0.1, 0.1),
            r_range: (-1.0, 1.0),
            points: vec![(0.05, 0.748), (-0.05, -0.68)],
        };
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("c.svg");
        let draw = |offset: f64, minus: Option<Option<f64>>| {
            characteristic_figure(
                &CharacteristicFigure {
                    title: "t",
                    points: &points,
                    law: Some(l),
                    law_label: "output error (used)",
                    threshold: true,
                    minus_threshold_n: minus,
                    law_offset_n: offset,
                    alternative: None,
                    alternative_label: "",
                    alternative_offset_n: 0.0,
                },
                &path,
            )
            .unwrap();
            std::fs::read_to_string(&path).unwrap()
        };
        let svg = draw(0.034, None);
        assert!(
            svg.contains("calibrated zeros: Rd⁺ 0.748 N, Rd⁻ 0.680 N"),
            "{svg}"
        );
        let svg = draw(0.034, Some(Some(0.874)));
        assert!(svg.contains("Rs⁺ 0.914 N, Rs⁻ 0.840 N"), "{svg}");
        let svg = draw(0.0, None);
        assert!(!svg.contains("calibrated"), "{svg}");
    }
}
