//! The n-th order Butterworth low-pass of a sensor model (n ≥ 2; order 1
//! is [`super::generate::lowpass`], exact for a piecewise-linear input).
//!
//! The filter is the cascade of its second-order sections
//! y'' + 2ζ_k·ω·y' + ω²·y = ω²·u, ζ_k = sin((2k − 1)π/(2n)), plus one
//! first-order section y' = ω·(u − y) for odd n (ω = 2π·f_c): unit DC
//! gain, |H(f_c)| = 1/√2. The input is linear between the given points
//! (first-order hold, as for order 1) and the whole cascade is integrated
//! by classical Runge–Kutta with sub-steps of at most 0.02/ω, so the
//! integration error (≈ (ωh)⁵/120 per step relative) stays below 1e-10 of
//! the signal. It starts in steady state at u(t₀).

/// Filters `u` given at times `t` (non-decreasing) through the order-`n`
/// Butterworth low-pass with corner `fc_hz`.
pub(super) fn butterworth(t: &[f64], u: &[f64], fc_hz: f64, n: u32) -> Vec<f64> {
    let w = 2.0 * std::f64::consts::PI * fc_hz;
    let n2 = (n / 2) as usize;
    let odd = n % 2 == 1;
    let zetas: Vec<f64> = (1..=n2)
        .map(|k| ((2 * k - 1) as f64 * std::f64::consts::PI / (2 * n) as f64).sin())
        .collect();
    // State: per second-order section (y, y'), then the first-order y.
    let dim = 2 * n2 + usize::from(odd);
    let mut y = Vec::with_capacity(u.len());
    let Some(&u0) = u.first() else {
        return y;
    };
    let mut s = vec![0.0; dim];
    for k in 0..n2 {
        s[2 * k] = u0;
    }
    if odd {
        s[dim - 1] = u0;
    }
    let rhs = |inp: f64, s: &[f64], ds: &mut [f64]| {
        let mut x = inp;
        for k in 0..n2 {
            let (p, v) = (s[2 * k], s[2 * k + 1]);
            ds[2 * k] = v;
            ds[2 * k + 1] = w * w * (x - p) - 2.0 * zetas[k] * w * v;
            x = p;
        }
        if odd {
            ds[dim - 1] = w * (x - s[dim - 1]);
        }
    };
    let out = |s: &[f64]| if odd { s[dim - 1] } else { s[2 * n2 - 2] };
    y.push(out(&s));
    let (mut k1, mut k2, mut k3, mut k4, mut tmp) = (
        vec![0.0; dim],
        vec![0.0; dim],
        vec![0.0; dim],
        vec![0.0; dim],
        vec![0.0; dim],
    );
    for i in 1..u.len() {
        let h = t[i] - t[i - 1];
        if h > 0.0 {
            let m = ((h * w / 0.02).ceil() as usize).max(1);
            let hs = h / m as f64;
            let slope = (u[i] - u[i - 1]) / h;
            for j in 0..m {
                let a = u[i - 1] + slope * hs * j as f64;
                let inp = |f: f64| a + slope * hs * f;
                rhs(inp(0.0), &s, &mut k1);
                for q in 0..dim {
                    tmp[q] = s[q] + 0.5 * hs * k1[q];
                }
                rhs(inp(0.5), &tmp, &mut k2);
                for q in 0..dim {
                    tmp[q] = s[q] + 0.5 * hs * k2[q];
                }
                rhs(inp(0.5), &tmp, &mut k3);
                for q in 0..dim {
                    tmp[q] = s[q] + hs * k3[q];
                }
                rhs(inp(1.0), &tmp, &mut k4);
                for q in 0..dim {
                    s[q] += hs / 6.0 * (k1[q] + 2.0 * k2[q] + 2.0 * k3[q] + k4[q]);
                }
            }
        }
        y.push(out(&s));
    }
    y
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
