//! Event location: bracketing every sign change of the switching functions
//! with a step bounded by the fastest rate present, including tangential
//! (grazing) zeros, then refinement to machine precision by a safeguarded
//! Newton iteration.
//!
//! Every switching function h is oriented so that h > 0 while the current
//! phase is valid; the event is h reaching 0. Within a bracketing step [a, b]
//! the finder uses h and h' at both ends:
//! * h(a) > 0 ≥ h(b): a crossing, refined on [a, b];
//! * h(a), h(b) > 0 but h' goes from < 0 to > 0: h has a minimum inside;
//!   it is located as the root of h' (refined the same way, using h'') and,
//!   if h ≤ 0 there, the crossing is refined on [a, t_min]. This catches the
//!   grazing zeros that a sign test at the step ends misses.
//!
//! The step is at most one radian of the fastest mode (1/max|λ|), so each
//! step holds at most one extremum of h for the smooth, band-limited
//! solutions of a linear phase.

/// A state with its first two time derivatives.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Jet<const N: usize> {
    /// State.
    pub x: [f64; N],
    /// First derivative.
    pub dx: [f64; N],
    /// Second derivative.
    pub ddx: [f64; N],
}

/// A switching function `h = g·x + g0` (all switching functions of the
/// affine laws are linear in the state).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EventFn<const N: usize> {
    /// Gradient.
    pub g: [f64; N],
    /// Offset.
    pub g0: f64,
}

/// A switching function: h, h' and h'' along a trajectory, at a point `P`
/// of it (a [`Jet`], or any representation from which the function can be
/// evaluated more cheaply, e.g. a closed-form phase's modal factors).
pub trait Switch<P> {
    /// h, h', h'' at a point.
    fn eval(&self, j: &P) -> (f64, f64, f64);

    /// For the bracketing steps: h exactly as [`Switch::eval`] gives it,
    /// h' possibly cheaper, and a bound on how far that h' may be from
    /// `eval`'s (0: it is `eval`'s). The finder decides on these where it
    /// can and evaluates with `eval` where an event is bracketed or a
    /// minimum may be inside (so it finds exactly what it finds with
    /// `eval` alone).
    #[inline(always)]
    fn quick(&self, j: &P) -> (f64, f64, f64) {
        let (h, d, _) = self.eval(j);
        (h, d, 0.0)
    }
}

impl<const N: usize> Switch<Jet<N>> for EventFn<N> {
    /// h, h', h'' at a jet.
    #[inline]
    fn eval(&self, j: &Jet<N>) -> (f64, f64, f64) {
        let (mut h, mut d, mut dd) = (self.g0, 0.0, 0.0);
        for i in 0..N {
            h += self.g[i] * j.x[i];
            d += self.g[i] * j.dx[i];
            dd += self.g[i] * j.ddx[i];
        }
        (h, d, dd)
    }
}

/// Safeguarded Newton (Newton steps kept inside a shrinking bracket, bisection
/// otherwise) for the root of `f` in [a, b] with f(a) > 0 ≥ f(b). `f`
/// returns (value, derivative). Converges to machine precision relative to
/// `scale` (the magnitude of the time the offsets are added to: resolving an
/// offset of 1e-15 to 1e-31 would be meaningless once added to τ).
pub fn refine<F: FnMut(f64) -> (f64, f64, f64)>(
    f: F,
    a: f64,
    b: f64,
    scale: f64,
    guess: f64,
) -> f64 {
    refine_with(f, a, b, scale, guess, false)
}

/// [`refine`], with the Halley steps aimed a quarter of the resolution past
/// the estimated root when `biased` (crossings in [`first_event`], whose
/// first guess is within O(h⁶) so that one step lands within rounding of
/// the root): the point evaluated there is then usually on the event side
/// already and converged, and is returned, instead of a point just short
/// of the root followed by one more evaluation a resolution past it.
#[inline]
fn refine_with<F: FnMut(f64) -> (f64, f64, f64)>(
    mut f: F,
    mut a: f64,
    mut b: f64,
    scale: f64,
    guess: f64,
    biased: bool,
) -> f64 {
    // The result is always on the event side (f ≤ 0): a switching state
    // must satisfy its switching condition (e.g. |F| ≥ ρs at breakaway, so
    // the slip starts with an acceleration of the right sign).
    let mut x = if guess > a && guess < b {
        guess
    } else {
        0.5 * (a + b)
    };
    for _ in 0..200 {
        let (v, d, dd) = f(x);
        if v <= 0.0 {
            b = x;
        } else {
            a = x;
        }
        let res = 2.0 * f64::EPSILON * x.abs().max(scale);
        if v == 0.0 || b - a <= res {
            return b;
        }
        // Halley's step (cubic convergence; Newton's when f'' is unknown).
        let den = 2.0 * d * d - v * dd;
        let newton = if den != 0.0 {
            x - 2.0 * v * d / den
        } else {
            x - v / d
        };
        let small = d != 0.0 && (newton - x).abs() <= 0.5 * res;
        if small && v <= 0.0 {
            return x;
        }
        x = if small {
            // Converged from the valid side: step just past the root.
            (x + res).min(b)
        } else if d != 0.0 && newton.is_finite() && newton > a && newton < b {
            let past = newton + 0.25 * res;
            if biased && past < b {
                past
            } else {
                newton
            }
        } else {
            0.5 * (a + b)
        };
    }
    b
}

/// Root in [a, b] of the cubic Hermite interpolant of f through the values
/// and slopes at both ends (f(a) > 0 ≥ f(b)): a first guess within O(h⁴)
/// of the root, found without evaluating the solution.
pub fn hermite_guess(a: f64, fa: f64, da: f64, b: f64, fb: f64, db: f64) -> f64 {
    let h = b - a;
    let (ma, mb) = (da * h, db * h);
    let p = |t: f64| {
        let (t2, t3) = (t * t, t * t * t);
        (2.0 * t3 - 3.0 * t2 + 1.0) * fa
            + (t3 - 2.0 * t2 + t) * ma
            + (-2.0 * t3 + 3.0 * t2) * fb
            + (t3 - t2) * mb
    };
    let dp = |t: f64| {
        let t2 = t * t;
        (6.0 * t2 - 6.0 * t) * fa
            + (3.0 * t2 - 4.0 * t + 1.0) * ma
            + (-6.0 * t2 + 6.0 * t) * fb
            + (3.0 * t2 - 2.0 * t) * mb
    };
    let (mut lo, mut hi) = (0.0, 1.0);
    let mut t = if fa - fb > 0.0 { fa / (fa - fb) } else { 0.5 };
    for _ in 0..8 {
        let v = p(t);
        if v > 0.0 {
            lo = t;
        } else {
            hi = t;
        }
        let d = dp(t);
        let n = t - v / d;
        let next = if d != 0.0 && n > lo && n < hi {
            n
        } else {
            0.5 * (lo + hi)
        };
        // A first guess only: the solution itself refines it (Halley).
        let done = (next - t).abs() < 1e-7;
        t = next;
        if done {
            break;
        }
    }
    a + t * h
}

/// First guess of the root in [a, b] of f with f(a) > 0 ≥ f(b), from f,
/// f', f'' at both ends: where f decreases at both ends (so throughout, a
/// step holding at most one extremum of f), the quintic Hermite
/// interpolant of the inverse function t(f) (t' = 1/f', t'' = −f''/f'³)
/// evaluated at f = 0, within O(h⁶) of the root and without iterations;
/// otherwise (or if that lands outside the bracket) [`hermite_guess`].
#[inline]
pub fn crossing_guess(
    a: f64,
    (fa, da, dda): (f64, f64, f64),
    b: f64,
    (fb, db, ddb): (f64, f64, f64),
) -> f64 {
    if da < 0.0 && db < 0.0 {
        // In s = (f − fa)/(fb − fa) ∈ [0, 1]: t(s) with dt/ds = H/f' and
        // d²t/ds² = −H²·f''/f'³, H = fb − fa.
        let hh = fb - fa;
        let s = -fa / hh;
        let (ta1, tb1) = (hh / da, hh / db);
        let (ta2, tb2) = (
            -hh * hh * dda / (da * da * da),
            -hh * hh * ddb / (db * db * db),
        );
        let (s2, s3) = (s * s, s * s * s);
        let t = a
            + (b - a) * (s3 * (10.0 - 15.0 * s + 6.0 * s2))
            + ta1 * (s - s3 * (6.0 - 8.0 * s + 3.0 * s2))
            + ta2 * (0.5 * s2 - 0.5 * s3 * (3.0 - 3.0 * s + s2))
            - tb1 * (s3 * (4.0 - 7.0 * s + 3.0 * s2))
            + tb2 * (0.5 * s3 * (1.0 - 2.0 * s + s2));
        if t > a && t < b {
            return t;
        }
    }
    hermite_guess(a, fa, da, b, fb, db)
}

/// The first event of a phase.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit<P> {
    /// Offset from the phase start.
    pub delta: f64,
    /// Index of the switching function that fired.
    pub which: usize,
    /// The solution there (a [`Jet`], or the point type of the evaluator).
    pub jet: P,
}

/// Finds the earliest zero of the switching functions `fns` on (0, end]
/// for the solution `eval(δ)`, stepping by `step`. `next(b)` gives the jet
/// at the step ends b = step, 2·step, … (a marching evaluator may serve
/// them cheaply) and at `end`; `eval` serves arbitrary offsets.
///
/// `on_step(a, jet_a, b, jet_b)` sees every step that is fully inside the
/// phase before the event (for observers such as extremum tracking).
///
/// A function that is ≤ 0 at δ = 0 (the phase starts on its boundary, e.g.
/// ζ2' = 0 at breakaway) is taken as leaving the boundary if it is positive
/// somewhere in the first step; the bracket then starts at the first
/// positive point found by halving. If it is not, the event is at δ = 0 (a
/// phase of zero length: immediate re-stick, reversal).
///
/// Why this stays one function (≈130 lines): it is the innermost loop of
/// every engine (called once per contact phase or integration step). The
/// march over steps, the bracketing per switching function (`lo`,
/// `boundary`) and the root refinement share the memoised evaluator and the
/// bracket state `(a, ja)`; all are fixed-size arrays on the stack, and the
/// generic closures inline into it. Split, the refinement would need the
/// memo, the brackets and the step ends passed in and out of each call.
#[allow(clippy::too_many_arguments)]
pub fn first_event<P, W, E, M, S>(
    eval: &E,
    mut next: M,
    fns: &[W],
    end: f64,
    step: f64,
    scale: f64,
    mut on_step: S,
) -> (Option<Hit<P>>, P)
where
    P: Copy,
    W: Switch<P>,
    E: Fn(f64) -> P,
    M: FnMut(f64) -> P,
    S: FnMut(f64, &P, f64, &P),
{
    // The refinement's last evaluation is usually at the root it returns:
    // remember it so the hit's jet is not computed twice.
    let j0 = eval(0.0);
    let memo: std::cell::RefCell<(f64, P)> = std::cell::RefCell::new((0.0, j0));
    let eval = |d: f64| -> P {
        let mut m = memo.borrow_mut();
        if m.0 != d {
            *m = (d, eval(d));
        }
        m.1
    };
    let mut a = 0.0;
    let mut ja = j0;
    // Lower bracket ends per function (nonzero only for boundary starts).
    // Every phase has at most two switching functions: per-step copies of
    // these arrays stay small.
    let mut lo = [0.0f64; 2];
    assert!(fns.len() <= lo.len());
    let mut boundary = [false; 2];
    // h, h' and the bound of h' (`Switch::quick`) of each function at the
    // step's ends (those at its end are the next step's start values).
    let mut va = [(0.0, 0.0, 0.0); 2];
    for (i, f) in fns.iter().enumerate() {
        let (h, d, _) = f.eval(&j0);
        va[i] = (h, d, 0.0);
        boundary[i] = h <= 0.0;
    }
    let mut vb = va;
    loop {
        let b = (a + step).min(end);
        let jb = next(b);
        let mut best: Option<(f64, usize)> = None;
        for (v, f) in vb.iter_mut().zip(fns) {
            *v = f.quick(&jb);
        }
        for (i, f) in fns.iter().enumerate() {
            let (ha, qa, ta) = va[i];
            let (hb, qb, tb) = vb[i];
            let mut lo_i = a;
            if boundary[i] && a == 0.0 {
                // Leave the boundary: find a point with h > 0 inside (0, b].
                if hb > 0.0 {
                    lo[i] = b;
                    // h > 0 at b; a dip below zero inside the first step would
                    // need two extrema in one step: excluded by the step bound.
                    continue;
                }
                let mut t = b;
                let mut found = None;
                for _ in 0..64 {
                    t *= 0.5;
                    if t <= 0.0 {
                        break;
                    }
                    if f.eval(&eval(t)).0 > 0.0 {
                        found = Some(t);
                        break;
                    }
                }
                match found {
                    None => {
                        // No positive point: the phase ends where it starts.
                        if best.is_none_or(|(d, _)| 0.0 < d) {
                            best = Some((0.0, i));
                        }
                        continue;
                    }
                    Some(t) => {
                        lo[i] = t;
                        lo_i = t;
                    }
                }
                let r = refine(|d| deriv1(f, &eval(d)), lo_i, b, scale, f64::NAN);
                if best.is_none_or(|(d, _)| r < d) {
                    best = Some((r, i));
                }
                continue;
            }
            if boundary[i] && a < lo[i] {
                continue;
            }
            if hb <= 0.0 && ha > 0.0 {
                let (_, da, dda) = f.eval(&ja);
                let (_, db, ddb) = f.eval(&jb);
                let g = crossing_guess(lo_i, (ha, da, dda), b, (hb, db, ddb));
                let r = refine_with(|d| deriv1(f, &eval(d)), lo_i, b, scale, g, true);
                if best.is_none_or(|(d, _)| r < d) {
                    best = Some((r, i));
                }
            } else if ha > 0.0 && hb > 0.0 && qa < ta && qb > -tb {
                // Maybe h' < 0 at a and > 0 at b: decided on eval's h'.
                let (_, da, dda) = f.eval(&ja);
                let (_, db, ddb) = f.eval(&jb);
                if !(da < 0.0 && db > 0.0) {
                    continue;
                }
                // A minimum inside: grazing candidate.
                let g = hermite_guess(a, -da, -dda, b, -db, -ddb);
                let tm = refine(|d| deriv2(f, &eval(d)), a, b, scale, g);
                let (hm, _, _) = f.eval(&eval(tm));
                if hm <= 0.0 {
                    let r = refine(|d| deriv1(f, &eval(d)), a, tm, scale, f64::NAN);
                    if best.is_none_or(|(d, _)| r < d) {
                        best = Some((r, i));
                    }
                }
            }
        }
        if let Some((d, i)) = best {
            let jd = eval(d);
            on_step(a, &ja, d, &jd);
            return (
                Some(Hit {
                    delta: d,
                    which: i,
                    jet: jd,
                }),
                jb,
            );
        }
        on_step(a, &ja, b, &jb);
        if b >= end {
            return (None, jb);
        }
        a = b;
        ja = jb;
        va = vb;
    }
}

#[inline]
fn deriv1<P, W: Switch<P>>(f: &W, j: &P) -> (f64, f64, f64) {
    f.eval(j)
}

/// h' and h'' oriented for a minimum: h' < 0 before, > 0 after, so the root
/// of −h' is refined with f(a) > 0 ≥ f(b).
#[inline]
fn deriv2<P, W: Switch<P>>(f: &W, j: &P) -> (f64, f64, f64) {
    let (_, d, dd) = f.eval(j);
    (-d, -dd, 0.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The inverse-Hermite first guess of a crossing of f = cos t − 0.3
    /// (root acos 0.3): sixth order in the step (halving the step divides
    /// the error by ~64) and far better than the cubic guess (order 4); with the
    /// slope's sign changing in the bracket it falls back to the cubic one.
    #[test]
    fn crossing_guess_is_sixth_order() {
        let root = 0.3f64.acos();
        let f = |t: f64| (t.cos() - 0.3, -t.sin(), -t.cos());
        let err = |h: f64| {
            let (a, b) = (root - 0.4 * h, root + 0.6 * h);
            let g = crossing_guess(a, f(a), b, f(b));
            let (fa, da, _) = f(a);
            let (fb, db, _) = f(b);
            let cubic = hermite_guess(a, fa, da, b, fb, db);
            ((g - root).abs(), (cubic - root).abs())
        };
        let (e1, _) = err(0.2);
        let (e2, c2) = err(0.1);
        // Measured: 1.2e-7, 1.9e-9 (cubic 7.4e-8), 3.1e-11 at h 0.2, 0.1, 0.05.
        assert!(e2 < 0.1 * c2, "{e2} against cubic {c2}");
        let order = (e1 / e2).log2();
        assert!((5.0..7.5).contains(&order), "order {order} ({e1}, {e2})");
        // cos t − 0.99 on [−0.5, 0.3]: f' changes sign, the cubic guess.
        let g = |t: f64| (t.cos() - 0.99, -t.sin(), -t.cos());
        let (a, b) = (-0.05, 0.3);
        let (fa, da, _) = g(a);
        let (fb, db, _) = g(b);
        assert_eq!(
            crossing_guess(a, g(a), b, g(b)),
            hermite_guess(a, fa, da, b, fb, db)
        );
    }

    fn jet_cos(t: f64, w: f64, off: f64) -> Jet<1> {
        Jet {
            x: [(w * t).cos() + off],
            dx: [-w * (w * t).sin()],
            ddx: [-w * w * (w * t).cos()],
        }
    }

    #[test]
    fn refine_reaches_machine_precision() {
        let r = refine(|x| (2.0 - x * x, -2.0 * x, -2.0), 1.0, 2.0, 0.0, f64::NAN);
        assert!((r - 2f64.sqrt()).abs() <= 2.0 * f64::EPSILON);
    }

    /// h = cos t + 1 − 1e-9 touches zero only near t = π: a grazing zero that
    /// step-end signs miss (both ends positive) must still be found.
    #[test]
    fn finds_grazing_zero() {
        let f = EventFn { g: [1.0], g0: 0.0 };
        let eval = |t: f64| jet_cos(t, 1.0, 1.0 - 1e-9);
        let (hit, _) = first_event(&eval, eval, &[f], 10.0, 1.0, 10.0, |_, _, _, _| {});
        let hit = hit.expect("grazing zero found");
        let exact = std::f64::consts::PI - (2e-9f64).sqrt();
        // The root is ill-conditioned: h' = sin t ≈ 4.5e-5 there, so a value
        // rounded to ε moves it by ε/h' ≈ 5e-12; allow 4 such units.
        let cond = f64::EPSILON / (2e-9f64).sqrt();
        assert!(
            (hit.delta - exact).abs() < 4.0 * cond,
            "{} vs {exact}",
            hit.delta
        );
        // A pure touch that stays positive is not an event.
        let eval = |t: f64| jet_cos(t, 1.0, 1.0 + 1e-9);
        assert!(
            first_event(&eval, eval, &[f], 10.0, 1.0, 10.0, |_, _, _, _| {})
                .0
                .is_none()
        );
    }

    /// A function starting on its boundary (h(0) = 0, leaving upwards) must
    /// not fire at 0 but at its next zero: h = sin t fires at π.
    #[test]
    fn boundary_start_skips_initial_zero() {
        let f = EventFn { g: [1.0], g0: 0.0 };
        let eval = |t: f64| Jet {
            x: [t.sin()],
            dx: [t.cos()],
            ddx: [-t.sin()],
        };
        let (hit, _) = first_event(&eval, eval, &[f], 10.0, 1.0, 10.0, |_, _, _, _| {});
        // Machine precision relative to the time scale passed (10).
        assert!((hit.unwrap().delta - std::f64::consts::PI).abs() <= 4.0 * f64::EPSILON * 10.0);
        // Leaving downwards: zero-length phase.
        let eval = |t: f64| Jet {
            x: [-t * t],
            dx: [-2.0 * t],
            ddx: [-2.0],
        };
        assert_eq!(
            first_event(&eval, eval, &[f], 10.0, 1.0, 10.0, |_, _, _, _| {})
                .0
                .unwrap()
                .delta,
            0.0
        );
    }
}
