//! Physics defects of the virtual rig, for tests only: friction that
//! depends on the position along the stroke, a hardening coupling spring
//! and friction that depends on the sliding direction. The model the tool
//! identifies has none of them; a log made with them must be flagged (the
//! direction-dependent levels are also the data of a later model).
//!
//! With any defect the trajectory comes from a dedicated integrator here
//! (the exact and the numerical engines are untouched): classical
//! Runge–Kutta with steps of at most [`MAX_STEP_TAU`] in τ, landing on every
//! requested sample time, and events (slip → stick, stick → slip, slip
//! reversal) located by bisection on the step length to 1e-14 in τ. In the
//! paper's variables (ζ = x/A_true, forces over A_true·K2), with
//! δ = ζ1 − ζ2 and the coupling force F = δ·(1 + ε·δ²) + D·(ζ1' − ζ2')
//! (ε = β·A_true², β = `hardening_per_m2`):
//!
//! * m·ζ1'' = k·(ζ0 − ζ1) − F;
//! * slip in direction s = ±1: ζ2'' = F − s·f(ζ2)·g_s(s·ζ2'), with g₊ the
//!   law and g₋ the law with Rs, Rd replaced by `rs_minus_n`, `rd_minus_n`;
//! * stick: ζ2' = 0 while −f(ζ2)·ρs₋ ≤ F ≤ f(ζ2)·ρs₊;
//!
//! where f(ζ2) = max(0.05, 1 + G·A_true·ζ2) is the stroke factor of the
//! friction levels (G = `stroke_friction_gradient_per_m`: both levels
//! change by G·x2 relative, x2 in metres). RK4's error per step is about
//! h⁵/120 of the state in units of the motion (h ≤ 0.005: below 1e-13), so
//! the trajectory is accurate to far below any sensor's noise.

use super::*;

/// Largest RK4 step (dimensionless τ).
pub const MAX_STEP_TAU: f64 = 0.005;
/// Most switching events per unit τ before the run is called chattering.
const MAX_EVENTS_PER_TAU: f64 = 200.0;

/// Physics defects of the virtual rig (all off by default).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct PhysicsDefects {
    /// Relative change of both friction levels per metre of x2: the levels
    /// at position x2 are the law's times max(0.05, 1 + G·x2) (1/m).
    #[serde(default)]
    pub stroke_friction_gradient_per_m: f64,
    /// Hardening of the coupling spring: its force is K2·δ·(1 + β·δ²) with
    /// δ = x1 − x2 (1/m²).
    #[serde(default)]
    pub hardening_per_m2: f64,
    /// Static threshold for sliding in the negative direction (N); None:
    /// the law's Rs.
    #[serde(default)]
    pub rs_minus_n: Option<f64>,
    /// Dynamic level for sliding in the negative direction (N); None: the
    /// law's Rd.
    #[serde(default)]
    pub rd_minus_n: Option<f64>,
}

impl PhysicsDefects {
    /// Whether any defect is on.
    pub fn any(&self) -> bool {
        self.stroke_friction_gradient_per_m != 0.0
            || self.hardening_per_m2 != 0.0
            || self.rs_minus_n.is_some()
            || self.rd_minus_n.is_some()
    }

    /// Checks the values against the law.
    pub(super) fn validate(&self, f: &FrictionSpec) -> Result<(), SynthError> {
        if !self.stroke_friction_gradient_per_m.is_finite() {
            return Err(bad("stroke friction gradient must be finite"));
        }
        if !(self.hardening_per_m2.is_finite() && self.hardening_per_m2 >= 0.0) {
            return Err(bad("hardening (1/m^2) must be finite and >= 0"));
        }
        let minus = self.minus_spec(f);
        if self.rs_minus_n.is_some() || self.rd_minus_n.is_some() {
            minus
                .validate()
                .map_err(|e| bad(format!("negative-direction friction: {e}")))?;
        }
        Ok(())
    }

    /// The law for sliding in the negative direction.
    fn minus_spec(&self, f: &FrictionSpec) -> FrictionSpec {
        FrictionSpec {
            rs_n: self.rs_minus_n.unwrap_or(f.rs_n),
            rd_n: self.rd_minus_n.unwrap_or(f.rd_n),
            ..*f
        }
    }
}

/// What the defect integrator measured over the logged window.
#[derive(Debug, Clone, Copy)]
pub(super) struct DefectRun {
    /// Min and max x2 (m) at the integrator's points in the log.
    pub(super) x2_range_m: (f64, f64),
    /// Largest |x1 − x2| (m) in the log.
    pub(super) max_stretch_m: f64,
}

/// Mode of the defect integrator.
#[derive(Clone, Copy, PartialEq)]
enum M {
    Stick(f64),
    Slip(f64),
}

struct Rig {
    m: f64,
    k: f64,
    d: f64,
    eps: f64,
    g: f64,
    plus: Law,
    minus: Law,
}

impl Rig {
    fn stroke(&self, z2: f64) -> f64 {
        (1.0 + self.g * z2).max(0.05)
    }
    fn coupling(&self, x: &[f64; 4]) -> f64 {
        let dl = x[0] - x[2];
        dl * (1.0 + self.eps * dl * dl) + self.d * (x[1] - x[3])
    }
    fn rhs(&self, mode: M, z0: f64, x: &[f64; 4]) -> [f64; 4] {
        let f = self.coupling(x);
        let a1 = (self.k * (z0 - x[0]) - f) / self.m;
        match mode {
            M::Stick(_) => [x[1], a1, 0.0, 0.0],
            M::Slip(dir) => {
                let law = if dir > 0.0 { &self.plus } else { &self.minus };
                let u = (dir * x[3]).max(0.0);
                let fr = dir * self.stroke(x[2]) * law.sliding(u);
                [x[1], a1, x[3], f - fr]
            }
        }
    }
    /// Stick: the margins to breakaway on each side (both ≥ 0 while it
    /// holds).
    fn stick_margins(&self, x: &[f64; 4]) -> (f64, f64) {
        let f = self.coupling(x);
        let s = self.stroke(x[2]);
        (s * self.plus.rho_s() - f, f + s * self.minus.rho_s())
    }
}

fn rk4(rig: &Rig, mode: M, drives: &Drives, t: f64, x: &[f64; 4], h: f64) -> [f64; 4] {
    let add = |a: &[f64; 4], b: &[f64; 4], s: f64| {
        [
            a[0] + s * b[0],
            a[1] + s * b[1],
            a[2] + s * b[2],
            a[3] + s * b[3],
        ]
    };
    let k1 = rig.rhs(mode, drives.zeta0(t), x);
    let k2 = rig.rhs(mode, drives.zeta0(t + 0.5 * h), &add(x, &k1, 0.5 * h));
    let k3 = rig.rhs(mode, drives.zeta0(t + 0.5 * h), &add(x, &k2, 0.5 * h));
    let k4 = rig.rhs(mode, drives.zeta0(t + h), &add(x, &k3, h));
    let mut y = *x;
    for i in 0..4 {
        y[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
    }
    if let M::Stick(z2) = mode {
        y[2] = z2;
        y[3] = 0.0;
    }
    y
}

/// The switching function of a mode (negative: the mode ends).
fn switching(rig: &Rig, mode: M, x: &[f64; 4]) -> f64 {
    match mode {
        M::Stick(_) => {
            let (a, b) = rig.stick_margins(x);
            a.min(b)
        }
        M::Slip(dir) => dir * x[3],
    }
}

/// Runs the rig with its defects from rest over `run_tau` into `col`.
pub(super) fn run_defects(
    cfg: &SynthConfig,
    drives: &Drives,
    run_tau: f64,
    col: &mut Collector<'_>,
) -> Result<DefectRun, SynthError> {
    let r = &cfg.rig;
    let a = r.drive_amplitude_true_m;
    let ab = r.absorber();
    let def = &cfg.defects;
    let rig = Rig {
        m: ab.m,
        k: ab.k,
        d: ab.damping,
        eps: def.hardening_per_m2 * a * a,
        g: def.stroke_friction_gradient_per_m * a,
        plus: cfg.friction.law(r, a),
        minus: def.minus_spec(&cfg.friction).law(r, a),
    };
    let mut x = [0.0; 4];
    let mut t = 0.0;
    let mut mode = M::Stick(0.0);
    let mut events = 0u64;
    let max_events = (MAX_EVENTS_PER_TAU * run_tau).max(1000.0) as u64;
    let mut run = DefectRun {
        x2_range_m: (f64::INFINITY, f64::NEG_INFINITY),
        max_stretch_m: 0.0,
    };
    // A mode change at the state x (time t): emits the event, returns the
    // new mode.
    let transition = |mode: M, x: &mut [f64; 4]| -> (M, EventKind) {
        match mode {
            M::Stick(_) => {
                let (up, down) = rig.stick_margins(x);
                if up < down {
                    (M::Slip(1.0), EventKind::SlipPlus)
                } else {
                    (M::Slip(-1.0), EventKind::SlipMinus)
                }
            }
            M::Slip(_) => {
                x[3] = 0.0;
                let (up, down) = rig.stick_margins(x);
                if up >= 0.0 && down >= 0.0 {
                    (M::Stick(x[2]), EventKind::Stick)
                } else if up < 0.0 {
                    (M::Slip(1.0), EventKind::ReversePlus)
                } else {
                    (M::Slip(-1.0), EventKind::ReverseMinus)
                }
            }
        }
    };
    // A log starting at rest may break away at once.
    if switching(&rig, mode, &x) < 0.0 {
        let (m, kind) = transition(mode, &mut x);
        mode = m;
        col.event(&Event { tau: t, kind, x });
    }
    while t < run_tau {
        let target = match col.next_sample() {
            Some(ts) if ts <= run_tau => ts,
            _ => run_tau,
        };
        if target <= t {
            let dx = rig.rhs(mode, drives.zeta0(t), &x);
            col.sample(t, &x, &dx);
            continue;
        }
        let h = (target - t).min(MAX_STEP_TAU);
        let y = rk4(&rig, mode, drives, t, &x, h);
        let g0 = switching(&rig, mode, &x);
        let g1 = switching(&rig, mode, &y);
        // A slip that starts exactly at rest ends only once it has moved.
        let ends = g1 < 0.0 && !(matches!(mode, M::Slip(_)) && g0 <= 0.0 && g1 > -1e-15);
        if ends {
            // Bisection on the step length: g(s_lo) ≥ 0 > g(s_hi).
            let (mut lo, mut hi) = (0.0, h);
            let mut y_hi = y;
            while hi - lo > 1e-14 * (1.0 + t.abs()) {
                let mid = 0.5 * (lo + hi);
                let ym = rk4(&rig, mode, drives, t, &x, mid);
                if switching(&rig, mode, &ym) < 0.0 {
                    hi = mid;
                    y_hi = ym;
                } else {
                    lo = mid;
                }
            }
            t += hi;
            x = y_hi;
            let (m, kind) = transition(mode, &mut x);
            mode = m;
            col.event(&Event { tau: t, kind, x });
            events += 1;
            if events > max_events {
                return Err(SynthError::Sim(format!(
                    "the defective rig chatters: more than {max_events} stick/slip events"
                )));
            }
        } else {
            t += h;
            x = y;
        }
        if t >= col.log.0 && t <= col.log.1 {
            run.x2_range_m.0 = run.x2_range_m.0.min(a * x[2]);
            run.x2_range_m.1 = run.x2_range_m.1.max(a * x[2]);
            run.max_stretch_m = run.max_stretch_m.max(a * (x[0] - x[2]).abs());
        }
        if !x.iter().all(|v| v.is_finite()) {
            return Err(SynthError::Sim(
                "the defective rig's motion diverged".into(),
            ));
        }
    }
    // Samples at the very end.
    while let Some(ts) = col.next_sample() {
        if ts > t + 1e-9 {
            break;
        }
        let dx = rig.rhs(mode, drives.zeta0(t), &x);
        col.sample(ts, &x, &dx);
    }
    Ok(run)
}

/// The truth of the defects: their parameters and what they did in the
/// log (the stroke factor's range over the logged x2, the hardening's
/// relative stiffness increase 3β·δ² at the largest stretch).
pub(super) fn truth_of(cfg: &SynthConfig, run: &DefectRun) -> Value {
    let d = &cfg.defects;
    let g = d.stroke_friction_gradient_per_m;
    let (lo, hi) = run.x2_range_m;
    let f = |x: f64| (1.0 + g * x).max(0.05);
    json!({
        "stroke_friction_gradient_per_m": g,
        "stroke_factor_range_in_log": [f(lo).min(f(hi)), f(lo).max(f(hi))],
        "x2_range_in_log_m": [lo, hi],
        "hardening_per_m2": d.hardening_per_m2,
        "max_stretch_in_log_m": run.max_stretch_m,
        "hardening_stiffness_increase_at_max_stretch": 3.0 * d.hardening_per_m2 * run.max_stretch_m.powi(2),
        "rs_minus_n": d.rs_minus_n.unwrap_or(cfg.friction.rs_n),
        "rd_minus_n": d.rd_minus_n.unwrap_or(cfg.friction.rd_n),
        "note": "test defects of synth: the identified model has none of them; the log must be flagged",
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cfg() -> SynthConfig {
        SynthConfig {
            test: TestSpec::Characteristic {
                frequency_hz: 1.72,
                warmup_s: 10.0,
                duration_s: 5.0,
            },
            sensors: Sensors::ideal(),
            ..SynthConfig::paper(3)
        }
    }

    /// With a zero defect (forced through the dedicated integrator) the
    /// trajectory is the exact engine's to well below sensor noise.
    #[test]
    fn defect_integrator_matches_the_exact_engine() {
        let c = cfg();
        let exact = generate(&c).expect("exact");
        let mut d = c.clone();
        // Rs− equal to Rs: no physical change, but the defect path runs.
        d.defects.rs_minus_n = Some(c.friction.rs_n);
        let num = generate(&d).expect("defect path");
        for q in [Quantity::X1, Quantity::X2, Quantity::V2] {
            let u = exact.channel(q).expect("ch").samples().1;
            let v = num.channel(q).expect("ch").samples().1;
            let scale = u.iter().fold(0.0f64, |m, x| m.max(x.abs()));
            let err = u
                .iter()
                .zip(&v)
                .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
            assert!(err < 1e-6 * scale, "{q:?}: {err} of {scale}");
        }
        assert_eq!(
            exact.truth["n_stick_slip_events"],
            num.truth["n_stick_slip_events"]
        );
    }

    /// A hardening spring and a stroke gradient change the motion, and
    /// the truth carries them.
    #[test]
    fn defects_change_the_motion_and_are_in_the_truth() {
        let c = cfg();
        let base = generate(&c).expect("base");
        let mut d = c.clone();
        d.defects.hardening_per_m2 = 2e4;
        let h = generate(&d).expect("hardening");
        let x1a = base.channel(Quantity::X1).expect("x1").samples().1;
        let x1b = h.channel(Quantity::X1).expect("x1").samples().1;
        let diff = x1a
            .iter()
            .zip(&x1b)
            .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
        assert!(diff > 1e-5, "{diff}");
        assert_eq!(h.truth["defects"]["hardening_per_m2"], 2e4);
        let inc = h.truth["defects"]["hardening_stiffness_increase_at_max_stretch"]
            .as_f64()
            .expect("number");
        assert!(inc > 0.0 && inc < 1.0, "{inc}");
        let mut d = c.clone();
        d.defects.stroke_friction_gradient_per_m = 100.0;
        let s = generate(&d).expect("stroke");
        let r = &s.truth["defects"]["stroke_factor_range_in_log"];
        let (lo, hi) = (r[0].as_f64().expect("lo"), r[1].as_f64().expect("hi"));
        assert!(lo < 1.0 && hi > 1.0, "{lo} {hi}");
    }

    #[test]
    fn bad_defects_are_refused() {
        let mut c = cfg();
        c.defects.hardening_per_m2 = -1.0;
        assert!(generate(&c).unwrap_err().to_string().contains("hardening"));
        let mut c = cfg();
        c.defects.rd_minus_n = Some(2.0 * c.friction.rs_n);
        assert!(generate(&c)
            .unwrap_err()
            .to_string()
            .contains("negative-direction"));
    }
}
