//! `stickslip characteristic`: the contact force R(t) of a characteristic log
//! (paper eq. 7) with ẋ2 and the stick flag, as a CSV table.

use crate::identify::{self, Gains};
use crate::ingest::{self, IngestOptions};
use crate::io::AtomicFile;
use clap::Args;
use serde_json::json;
use std::io::Write;
use std::path::PathBuf;

/// Arguments of `stickslip characteristic`.
#[derive(Debug, Args)]
pub struct CharacteristicArgs {
    /// The characteristic log.
    pub log: PathBuf,
    /// Write the table (CSV: t_s, r_n, v2_m_per_s, stick, rho, v2_dimless);
    /// R has the estimated force bias removed.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Write the figure (SVG).
    #[arg(long)]
    pub plot: Option<PathBuf>,
    /// Print one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
}

/// Runs `characteristic`.
pub fn run(args: CharacteristicArgs) -> crate::Result<()> {
    if let Some(p) = &args.plot {
        let ext = p
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase());
        if ext.as_deref() != Some("svg") {
            return Err(crate::Error::Input {
                path: p.clone(),
                msg: "--plot writes SVG only (no PNG backend in this build): give a .svg file"
                    .into(),
            });
        }
    }
    let run = ingest::read(&args.log, &IngestOptions::default())?;
    let ch = identify::characteristic(&run, &Gains::default())?;
    let c = &ch.contact;
    // The force bias (unknown position offsets) as the fit estimates it.
    let fit = identify::fit::fit(
        c,
        &ch.segmentation,
        &identify::FitOptions {
            bootstrap: 0,
            ..Default::default()
        },
    )
    .ok();
    let mut warnings = c.warnings.clone();
    let bias = match fit.as_ref().map(|f| f.bias_n) {
        Some(b) if b.is_finite() => b,
        _ => {
            warnings
                .push("force bias unknown (M2 never slid): R includes the sensors' offsets".into());
            0.0
        }
    };
    let fs = c.drive.amplitude_m * run.rig.k2_n_per_m;
    let vs = c.drive.amplitude_m * run.rig.omega_ref();
    if let Some(out) = &args.out {
        let mut f = AtomicFile::create(out)?;
        let mut text = String::from("t_s,r_n,v2_m_per_s,stick,rho,v2_dimless\n");
        for i in 0..c.t.len() {
            let (r, v) = (
                c.r[i] - bias,
                if ch.segmentation.stick[i] {
                    0.0
                } else {
                    c.v2[i]
                },
            );
            let cell = |x: f64| {
                if x.is_finite() {
                    format!("{x:.9e}")
                } else {
                    String::new()
                }
            };
            text.push_str(&format!(
                "{},{},{},{},{},{}\n",
                c.t[i],
                cell(r),
                cell(v),
                u8::from(ch.segmentation.stick[i]),
                cell(r / fs),
                cell(v / vs)
            ));
        }
        f.writer()
            .write_all(text.as_bytes())
            .map_err(|e| f.io_err(e))?;
        f.commit()?;
    }
    if let Some(path) = &args.plot {
        let law = fit.as_ref().filter(|f| !f.stuck).map(|f| f.law);
        let svg = figure(
            c,
            &ch.segmentation.stick,
            bias,
            law,
            &args.log.display().to_string(),
        );
        crate::io::write_atomic(path, svg.as_bytes())?;
    }
    let seg = &ch.segmentation;
    if args.json {
        super::print_json(&json!({
            "log": args.log.display().to_string(),
            "samples": c.t.len(),
            "drive_amplitude_m": super::fit::num(c.drive.amplitude_m),
            "drive_frequency_hz": super::fit::num(c.drive.frequency_hz),
            "acceleration_source": c.acceleration_source,
            "sticks": seg.sticks.len(),
            "breakaways": seg.breakaways.len(),
            "reversals": seg.reversals.len(),
            "stuck": seg.stuck(),
            "never_sticks": seg.never_sticks(),
            "velocity_noise_m_per_s": super::fit::num(seg.noise_v_raw),
            "out": args.out.as_ref().map(|p| p.display().to_string()),
            "bias_n": super::fit::num(bias),
            "warnings": warnings,
        }));
    } else {
        eprintln!(
            "{}: {} samples, {} sticks, {} reversals, acceleration from {}",
            args.log.display(),
            c.t.len(),
            seg.sticks.len(),
            seg.reversals.len(),
            c.acceleration_source
        );
    }
    Ok(())
}

/// Linear map of `[lo, hi]` onto pixels `[a, b]`.
fn scale(lo: f64, hi: f64, a: f64, b: f64) -> impl Fn(f64) -> f64 {
    let span = if hi > lo { hi - lo } else { 1.0 };
    move |x| a + (x - lo) / span * (b - a)
}

/// The figure of the paper's Figs. 8–9: R(t) and ẋ2(t) over the first 1.5
/// drive periods (left), and R against ẋ2 over the whole log with the
/// fitted law over it (right). Plain SVG, no dependencies.
fn figure(
    c: &crate::identify::Contact,
    stick: &[bool],
    bias: f64,
    law: Option<crate::identify::SiLaw>,
    title: &str,
) -> String {
    let (w, h) = (960.0, 420.0);
    let (top, bottom) = (40.0, h - 50.0);
    let esc = |s: &str| {
        s.replace('&', "&amp;")
            .replace('<', "&lt;")
            .replace('>', "&gt;")
            .replace('"', "&quot;")
    };
    let r: Vec<f64> = c.r.iter().map(|x| x - bias).collect();
    let v: Vec<f64> = (0..c.v2.len())
        .map(|i| if stick[i] { 0.0 } else { c.v2[i] })
        .collect();
    let fin = |x: &[f64]| -> (f64, f64) {
        x.iter()
            .filter(|x| x.is_finite())
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
                (a.min(x), b.max(x))
            })
    };
    let (rlo, rhi) = fin(&r);
    let (vlo, vhi) = fin(&v);
    let mut s = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{h}\" font-family=\"sans-serif\" font-size=\"12\">\n<rect width=\"{w}\" height=\"{h}\" fill=\"white\"/>\n<text x=\"10\" y=\"18\">{}</text>\n",
        esc(title)
    );
    // Left: R(t) (blue, left axis) and v2(t) (red, right axis).
    let n_show = ((1.5 / c.drive.frequency_hz) / c.dt).round() as usize;
    let n_show = n_show.min(c.t.len()).max(2);
    let (x0, x1) = (60.0, 440.0);
    let tx = scale(c.t[0], c.t[n_show - 1], x0, x1);
    let ry = scale(rlo, rhi, bottom, top);
    let vy = scale(vlo, vhi, bottom, top);
    let path = |ys: &dyn Fn(usize) -> f64,
                sel: &mut dyn Iterator<Item = usize>,
                xs: &dyn Fn(usize) -> f64| {
        let mut d = String::new();
        let mut pen = false;
        for i in sel {
            let (x, y) = (xs(i), ys(i));
            if x.is_finite() && y.is_finite() {
                d.push_str(&format!(
                    "{}{:.1},{:.1} ",
                    if pen { "L" } else { "M" },
                    x,
                    y
                ));
                pen = true;
            } else {
                pen = false;
            }
        }
        d
    };
    s.push_str(&format!("<rect x=\"{x0}\" y=\"{top}\" width=\"{}\" height=\"{}\" fill=\"none\" stroke=\"black\"/>\n", x1 - x0, bottom - top));
    let d = path(&|i| ry(r[i]), &mut (0..n_show), &|i| tx(c.t[i]));
    s.push_str(&format!(
        "<path d=\"{d}\" fill=\"none\" stroke=\"#1f4e9c\" stroke-width=\"1\"/>\n"
    ));
    let d = path(&|i| vy(v[i]), &mut (0..n_show), &|i| tx(c.t[i]));
    s.push_str(&format!(
        "<path d=\"{d}\" fill=\"none\" stroke=\"#b22222\" stroke-width=\"1\"/>\n"
    ));
    s.push_str(&format!(
        "<text x=\"{x0}\" y=\"{}\">t [s] {:.2} … {:.2}</text>\n<text x=\"{x0}\" y=\"{}\" fill=\"#1f4e9c\">R [N] {:.3} … {:.3}</text>\n<text x=\"{}\" y=\"{}\" fill=\"#b22222\">ẋ2 [m/s] {:.4} … {:.4}</text>\n",
        bottom + 20.0, c.t[0], c.t[n_show - 1], top - 8.0, rlo, rhi, x1 - 170.0, top - 8.0, vlo, vhi
    ));
    // Right: R against v2 with the law.
    let (x0, x1) = (520.0, 930.0);
    let vx = scale(vlo, vhi, x0, x1);
    s.push_str(&format!("<rect x=\"{x0}\" y=\"{top}\" width=\"{}\" height=\"{}\" fill=\"none\" stroke=\"black\"/>\n", x1 - x0, bottom - top));
    let d = path(&|i| ry(r[i]), &mut (0..r.len()).step_by(2), &|i| vx(v[i]));
    s.push_str(&format!("<path d=\"{d}\" fill=\"none\" stroke=\"#1f4e9c\" stroke-width=\"0.4\" stroke-opacity=\"0.6\"/>\n"));
    if let Some(l) = law {
        let g = |u: f64| {
            let mut y = l.rd_n + l.slope_n_s_per_m * u;
            if let Some(vs) = l.vs_m_per_s {
                y += (l.rs_n - l.rd_n) * (-(u / vs).powi(2)).exp();
            }
            y
        };
        let mut d = String::new();
        let m = 200;
        for k in 0..=m {
            let u = vlo + (vhi - vlo) * k as f64 / m as f64;
            if u < 0.0 {
                d.push_str(&format!(
                    "{}{:.1},{:.1} ",
                    if k == 0 { "M" } else { "L" },
                    vx(u),
                    ry(-g(-u))
                ));
            }
        }
        if l.rs_n.is_finite() {
            d.push_str(&format!(
                "L{:.1},{:.1} L{:.1},{:.1} ",
                vx(0.0),
                ry(-l.rs_n),
                vx(0.0),
                ry(l.rs_n)
            ));
        }
        for k in 0..=m {
            let u = vlo + (vhi - vlo) * k as f64 / m as f64;
            if u > 0.0 {
                d.push_str(&format!("L{:.1},{:.1} ", vx(u), ry(g(u))));
            }
        }
        s.push_str(&format!(
            "<path d=\"{d}\" fill=\"none\" stroke=\"black\" stroke-width=\"1.5\"/>\n"
        ));
        s.push_str(&format!(
            "<text x=\"{x0}\" y=\"{}\">fitted law: {}</text>\n",
            top - 8.0,
            l.kind.as_str()
        ));
    }
    s.push_str(&format!(
        "<text x=\"{x0}\" y=\"{}\">ẋ2 [m/s] (x) against R [N] (y)</text>\n",
        bottom + 20.0
    ));
    s.push_str("</svg>\n");
    s
}
