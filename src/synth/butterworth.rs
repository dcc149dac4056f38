//! The n-th order Butterworth low-pass of a sensor model (n ≥ 2; order 1
//! is [`super::generate::FirstOrder`], exact for a piecewise-linear input).
//!
//! The filter is the cascade of its second-order sections
//! y'' + 2ζ_k·ω·y' + ω²·y = ω²·u, ζ_k = sin((2k − 1)π/(2n)), plus one
//! first-order section y' = ω·(u − y) for odd n (ω = 2π·f_c): unit DC
//! gain, |H(f_c)| = 1/√2. The input is linear between the given points
//! (first-order hold, as for order 1) and the whole cascade is integrated
//! by classical Runge–Kutta with sub-steps of at most 0.02/ω, so the
//! integration error (≈ (ωh)⁵/120 per step relative) stays below 1e-10 of
//! the signal. It starts in steady state at u(t₀).

/// The sections of an order-`n` Butterworth low-pass (its coefficients).
struct Sections {
    w: f64,
    n2: usize,
    odd: bool,
    dim: usize,
    zetas: Vec<f64>,
}

impl Sections {
    /// The cascade's derivative `ds` at state `s` for input `inp`.
    fn rhs(&self, inp: f64, s: &[f64], ds: &mut [f64]) {
        let (w, n2, dim) = (self.w, self.n2, self.dim);
        let mut x = inp;
        for k in 0..n2 {
            let (p, v) = (s[2 * k], s[2 * k + 1]);
            ds[2 * k] = v;
            ds[2 * k + 1] = w * w * (x - p) - 2.0 * self.zetas[k] * w * v;
            x = p;
        }
        if self.odd {
            ds[dim - 1] = w * (x - s[dim - 1]);
        }
    }

    /// The filter's output at state `s`.
    fn out(&self, s: &[f64]) -> f64 {
        if self.odd {
            s[self.dim - 1]
        } else {
            s[2 * self.n2 - 2]
        }
    }
}

/// The order-`n` Butterworth low-pass with corner `fc_hz`, fed one point
/// (t, u) at a time (times non-decreasing), as the engine's observer runs
/// it (the same arithmetic as filtering the whole series at once).
/// Allocates only when built.
pub(super) struct Butterworth {
    sec: Sections,
    /// State: per second-order section (y, y'), then the first-order y.
    s: Vec<f64>,
    k1: Vec<f64>,
    k2: Vec<f64>,
    k3: Vec<f64>,
    k4: Vec<f64>,
    tmp: Vec<f64>,
    /// The previous point (t, u); None before the first.
    prev: Option<(f64, f64)>,
}

impl Butterworth {
    /// A filter of order `n` (≥ 1) with corner `fc_hz`, not yet started.
    pub(super) fn new(fc_hz: f64, n: u32) -> Self {
        let w = 2.0 * std::f64::consts::PI * fc_hz;
        let n2 = (n / 2) as usize;
        let odd = n % 2 == 1;
        let zetas: Vec<f64> = (1..=n2)
            .map(|k| ((2 * k - 1) as f64 * std::f64::consts::PI / (2 * n) as f64).sin())
            .collect();
        let dim = 2 * n2 + usize::from(odd);
        Self {
            sec: Sections {
                w,
                n2,
                odd,
                dim,
                zetas,
            },
            s: vec![0.0; dim],
            k1: vec![0.0; dim],
            k2: vec![0.0; dim],
            k3: vec![0.0; dim],
            k4: vec![0.0; dim],
            tmp: vec![0.0; dim],
            prev: None,
        }
    }

    /// Feeds the point (t, u) and returns the filter's output at t (the
    /// first point starts the filter in steady state at u).
    pub(super) fn push(&mut self, t: f64, u: f64) -> f64 {
        let Self {
            sec,
            s,
            k1,
            k2,
            k3,
            k4,
            tmp,
            prev,
        } = self;
        let Some((t_prev, u_prev)) = prev.replace((t, u)) else {
            for k in 0..sec.n2 {
                s[2 * k] = u;
            }
            if sec.odd {
                s[sec.dim - 1] = u;
            }
            return sec.out(s);
        };
        let (w, dim) = (sec.w, sec.dim);
        let h = t - t_prev;
        if h > 0.0 {
            let m = ((h * w / 0.02).ceil() as usize).max(1);
            let hs = h / m as f64;
            let slope = (u - u_prev) / h;
            for j in 0..m {
                let a = u_prev + slope * hs * j as f64;
                let inp = |f: f64| a + slope * hs * f;
                sec.rhs(inp(0.0), s, k1);
                for q in 0..dim {
                    tmp[q] = s[q] + 0.5 * hs * k1[q];
                }
                sec.rhs(inp(0.5), tmp, k2);
                for q in 0..dim {
                    tmp[q] = s[q] + 0.5 * hs * k2[q];
                }
                sec.rhs(inp(0.5), tmp, k3);
                for q in 0..dim {
                    tmp[q] = s[q] + hs * k3[q];
                }
                sec.rhs(inp(1.0), tmp, k4);
                for q in 0..dim {
                    s[q] += hs / 6.0 * (k1[q] + 2.0 * k2[q] + 2.0 * k3[q] + k4[q]);
                }
            }
        }
        sec.out(s)
    }
}

/// Filters `u` given at times `t` (non-decreasing) through the order-`n`
/// Butterworth low-pass with corner `fc_hz` (a [`Butterworth`] fed every
/// point).
#[cfg(test)]
pub(super) fn butterworth(t: &[f64], u: &[f64], fc_hz: f64, n: u32) -> Vec<f64> {
    let mut f = Butterworth::new(fc_hz, n);
    t.iter().zip(u).map(|(t, u)| f.push(*t, *u)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Steady-state gain and phase of a sine through orders 2–5 match the
    /// Butterworth magnitude 1/√(1 + (f/fc)^(2n)) and the cascade's phase.
    #[test]
    fn sine_response_matches_the_butterworth_magnitude() {
        let fc = 50.0;
        for n in 2..=5u32 {
            for f in [10.0, 50.0, 120.0] {
                let dt = 1e-4;
                let t: Vec<f64> = (0..40_000).map(|i| i as f64 * dt).collect();
                let u: Vec<f64> = t
                    .iter()
                    .map(|t| (2.0 * std::f64::consts::PI * f * t).sin())
                    .collect();
                let y = butterworth(&t, &u, fc, n);
                // Amplitude over the last 2 s (transients gone).
                let tail = &y[20_000..];
                let amp = tail.iter().fold(0.0f64, |m, v| m.max(v.abs()));
                let ex = 1.0 / (1.0 + (f / fc).powi(2 * n as i32)).sqrt();
                assert!(
                    (amp - ex).abs() < 2e-3 * ex + 1e-4,
                    "n {n} f {f}: {amp} vs {ex}"
                );
            }
        }
    }

    /// A constant input stays put (steady start); a step settles to it.
    #[test]
    fn constant_and_step_inputs() {
        let t: Vec<f64> = (0..2000).map(|i| i as f64 * 1e-3).collect();
        let u = vec![0.7; 2000];
        let y = butterworth(&t, &u, 20.0, 4);
        assert!(y.iter().all(|v| (v - 0.7).abs() < 1e-12));
        let mut u = vec![0.0; 2000];
        for v in u.iter_mut().skip(10) {
            *v = 1.0;
        }
        let y = butterworth(&t, &u, 20.0, 3);
        assert!((y[1999] - 1.0).abs() < 1e-9);
        // Butterworth order 3 overshoots a step by about 8 %.
        let peak = y.iter().fold(0.0f64, |m, v| m.max(*v));
        assert!(peak > 1.05 && peak < 1.1, "{peak}");
    }
}
