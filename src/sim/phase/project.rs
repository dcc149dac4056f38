//! The event finder's view of a phase: switching functions projected on
//! the closed form ([`Projection`], [`PhaseSwitch`]) and evaluated on
//! solution points ([`Point`]) before any state is assembled.

use super::*;
use crate::sim::events::Switch;

/// A point of a started phase's solution as the event finder sees it:
/// what the closed form has at an offset δ before the state is assembled.
/// Switching functions are evaluated on it by projection
/// ([`PhaseSwitch`]); the state and its derivatives only where they are
/// needed ([`LinearPhase::jet_of`]). Small (56 bytes for N = 4): the event
/// finder copies points at every bracketing step.
#[derive(Debug, Clone, Copy)]
pub enum Point<const N: usize> {
    /// δ = 0: exactly the initial state (see [`LinearPhase::jet`]).
    Start,
    /// The factors z_t = y0_k·e^{λ_k δ} of the (at most two) representative
    /// modal terms t (eigenvalue k = `terms[t]`) and the forcing phasor
    /// e = U·e^{iη(s0+δ)}.
    Modal {
        /// Modal factors, by term.
        z: [C64; 2],
        /// Forcing phasor.
        e: C64,
    },
    /// The state and the forcing phasor (matrix-exponential form, and
    /// modal forms with more than two terms).
    Full {
        /// State.
        x: [f64; N],
        /// Forcing phasor.
        e: C64,
    },
}

/// A linear switching function h = g·x + g0 projected on a phase system's
/// closed form: with x(δ) = x_c + Re(X·e) + Σ_k w_k·Re(V_k·z_k),
///
/// ```text
/// h(δ)  = (g0 + g·x_c) + Re(β·e)      + Σ_k Re(α_k·z_k),
/// h'(δ) =                Re(iη·β·e)   + Σ_k Re(λ_k·α_k·z_k),
/// h''(δ) =               Re(−η²·β·e)  + Σ_k Re(λ_k²·α_k·z_k),
/// ```
///
/// β = g·X, α_k = w_k·g·V_k: a few complex multiply-adds per evaluation
/// instead of the state and its two derivatives. The coefficients depend on
/// g and the phase system only (not on the phase's start): made once.
/// Summed in the order of [`LinearPhase::jet`]'s state, so that for a
/// gradient ±e_i the value h is that of the state component bit for bit.
#[derive(Debug, Clone, Copy)]
pub struct Projection<const N: usize> {
    g: [f64; N],
    /// g = ±e_i: the projected h is the state component's, bit for bit.
    unit: bool,
    /// For g = ±e_i: i (the jet's other components are not needed).
    axis: usize,
    /// α_t·{1, λ_t, λ_t²} by term t (zero past the terms).
    modal: [[C64; 3]; 2],
    /// β·{1, iη, −η²}.
    forced: [C64; 3],
}

/// A [`Projection`] at one started phase: the switching function
/// h = g·x + g0 on that phase's [`Point`]s.
#[derive(Debug, Clone, Copy)]
pub struct PhaseSwitch<'a, const N: usize> {
    proj: &'a Projection<N>,
    phase: &'a LinearPhase<N>,
    p: &'a Started<N>,
    g0: f64,
    /// g·x_c.
    gxc: f64,
    /// h, h', h'' at δ = 0 from the exact initial jet.
    h0: (f64, f64, f64),
}

/// Relative bound used for the projected h' against the jet's (rounding
/// of either is a few ε·cond(V) of the terms summed, cond(V) < 1e6).
const PROJ_SLACK: f64 = 1e-8;

impl<const N: usize> Switch<Point<N>> for PhaseSwitch<'_, N> {
    /// From the jet of the point, exactly as [`super::events::EventFn`]
    /// evaluates it. For a gradient ±e_i only the jet's component i is
    /// formed ([`LinearPhase::jet_component`]): the zero terms of g·x add
    /// nothing, so h, h', h'' are the same numbers.
    #[inline(always)]
    fn eval(&self, pt: &Point<N>) -> (f64, f64, f64) {
        match pt {
            Point::Start => self.h0,
            _ if self.proj.unit => {
                let s = self.proj.g[self.proj.axis];
                let (x, d1, d2) = self.phase.jet_component(self.p, pt, self.proj.axis);
                (self.g0 + s * x, s * d1, s * d2)
            }
            _ => {
                let (x, d1, d2) = self.phase.jet_of(self.p, pt);
                dot_jet(&self.proj.g, self.g0, &[x, d1, d2])
            }
        }
    }

    /// By projection (see [`Projection`]): h bit for bit as `eval` for a
    /// gradient ±e_i (summed in the state's order, g0 last), h' to
    /// [`PROJ_SLACK`] of the terms summed.
    #[inline(always)]
    fn quick(&self, pt: &Point<N>) -> (f64, f64, f64) {
        let re = |a: C64, b: C64| a.re * b.re - a.im * b.im;
        match pt {
            Point::Modal { z, e } if self.proj.unit => {
                let (f, m) = (&self.proj.forced, &self.proj.modal);
                let (h0, h1, h2) = (re(f[0], *e), re(m[0][0], z[0]), re(m[1][0], z[1]));
                let (d0, d1, d2) = (re(f[1], *e), re(m[0][1], z[0]), re(m[1][1], z[1]));
                let h = self.g0 + (self.gxc + h0 + h1 + h2);
                let size = d0.abs()
                    + d1.abs()
                    + d2.abs()
                    + self.phase.fastest * (self.gxc.abs() + h0.abs() + h1.abs() + h2.abs());
                (h, d0 + d1 + d2, PROJ_SLACK * size)
            }
            Point::Start => (self.h0.0, self.h0.1, 0.0),
            _ => {
                let (h, d, _) = self.eval(pt);
                (h, d, 0.0)
            }
        }
    }
}

/// g·x + g0, g·x', g·x'' of a jet (in the order [`super::events::EventFn`]
/// sums them).
#[inline(always)]
fn dot_jet<const N: usize>(g: &[f64; N], g0: f64, j: &[[f64; N]; 3]) -> (f64, f64, f64) {
    let (mut h, mut d, mut dd) = (g0, 0.0, 0.0);
    for i in 0..N {
        h += g[i] * j[0][i];
        d += g[i] * j[1][i];
        dd += g[i] * j[2][i];
    }
    (h, d, dd)
}

impl<const N: usize> LinearPhase<N> {
    /// The projection of the switching function with gradient g on this
    /// phase system (see [`Projection`]).
    pub fn projection(&self, g: [f64; N]) -> Projection<N> {
        let nonzero = g.iter().filter(|v| **v != 0.0).count();
        let mut pr = Projection {
            g,
            unit: nonzero == 1 && g.iter().any(|v| v.abs() == 1.0),
            axis: g.iter().position(|v| *v != 0.0).unwrap_or(0),
            modal: [[C64::new(0.0, 0.0); 3]; 2],
            forced: [C64::new(0.0, 0.0); 3],
        };
        if let Repr::Modal {
            md,
            xh,
            terms,
            nterms,
        } = &self.repr
        {
            let mut beta = C64::new(0.0, 0.0);
            for i in 0..N {
                beta += xh[i] * g[i];
            }
            let ie = C64::new(0.0, self.eta);
            pr.forced = [beta, beta * ie, beta * (ie * ie)];
            if *nterms <= 2 {
                for (t, &(k, w)) in terms[..*nterms].iter().enumerate() {
                    let mut alpha = C64::new(0.0, 0.0);
                    for i in 0..N {
                        alpha += md.v[i][k] * g[i];
                    }
                    alpha *= w;
                    let l = md.lambda[k];
                    pr.modal[t] = [alpha, alpha * l, alpha * l * l];
                }
            }
        }
        pr
    }

    /// The switching function h = g·x + g0 (g that of `proj`) on the points
    /// of the started phase `p`, whose jet at δ = 0 (`jet_of` the start
    /// point, shared by a phase's functions) is `j0`.
    #[inline]
    pub fn switch<'a>(
        &'a self,
        proj: &'a Projection<N>,
        p: &'a Started<N>,
        g0: f64,
        j0: &[[f64; N]; 3],
    ) -> PhaseSwitch<'a, N> {
        let mut gxc = 0.0;
        for i in 0..N {
            gxc += proj.g[i] * p.xc[i];
        }
        PhaseSwitch {
            proj,
            phase: self,
            p,
            g0,
            gxc,
            h0: dot_jet(&proj.g, g0, j0),
        }
    }

    /// [`LinearPhase::switch`] with the jet at δ = 0 formed here: for a
    /// gradient ±e_i only its component i ([`LinearPhase::jet_component`]),
    /// whose h, h', h'' are `dot_jet`'s (the zero terms add nothing), and
    /// h', h'' only where h > 0 (see below).
    #[inline]
    pub fn switch_start<'a>(
        &'a self,
        proj: &'a Projection<N>,
        p: &'a Started<N>,
        g0: f64,
    ) -> PhaseSwitch<'a, N> {
        if !proj.unit {
            let (x, d1, d2) = self.jet_of(p, &Point::Start);
            return self.switch(proj, p, g0, &[x, d1, d2]);
        }
        let i = proj.axis;
        let s = proj.g[i];
        let h = g0 + s * p.x0[i];
        // A phase starting on the boundary (h ≤ 0, e.g. ζ2' = 0 after an
        // event) never has h', h'' read at δ = 0: the finder leaves the
        // boundary from points inside the first step
        // ([`super::events::first_event`]). They are formed where h > 0.
        let h0 = if h > 0.0 {
            let (x, d1, d2) = self.jet_component(p, &Point::Start, i);
            (g0 + s * x, s * d1, s * d2)
        } else {
            (h, 0.0, 0.0)
        };
        PhaseSwitch {
            proj,
            phase: self,
            p,
            g0,
            gxc: s * p.xc[i],
            h0,
        }
    }

    /// The [`Point`] at offset δ, evaluated like [`LinearPhase::jet_near`]
    /// (whose jet is [`LinearPhase::jet_of`] this point, bit for bit).
    #[inline]
    pub fn point_near(&self, p: &Started<N>, c: &Cursor<N>, delta: f64) -> Point<N> {
        if delta == 0.0 {
            return Point::Start;
        }
        if let Repr::Modal { terms, nterms, .. } = &self.repr {
            if let Some((z, e)) = self.factors_near(c, delta) {
                return Point::Modal { z: [z[0], z[1]], e };
            }
            if *nterms <= 2 {
                let Repr::Modal { md, .. } = &self.repr else {
                    unreachable!()
                };
                let e = p.u * C64::from_polar(1.0, self.eta * (p.s0 + delta));
                let mut z = [C64::new(0.0, 0.0); 2];
                for (t, (v, &(k, _))) in z.iter_mut().zip(&terms[..*nterms]).enumerate() {
                    *v = p.y0[t] * (md.lambda[k] * delta).exp();
                }
                return Point::Modal { z, e };
            }
        }
        let (x, _, _) = self.jet(p, delta);
        let e = p.u * C64::from_polar(1.0, self.eta * (p.s0 + delta));
        Point::Full { x, e }
    }

    /// Advances the cursor by one bracketing step and returns the
    /// [`Point`] there (the jet of [`LinearPhase::advance`] is its
    /// [`LinearPhase::jet_of`]).
    #[inline(always)]
    pub fn advance_point(&self, p: &Started<N>, c: &mut Cursor<N>) -> Point<N> {
        match &self.repr {
            Repr::Modal { terms, nterms, .. } if *nterms <= 2 => {
                c.delta += self.step;
                c.steps += 1.0;
                let mut z = [C64::new(0.0, 0.0); 2];
                for (t, v) in z.iter_mut().enumerate().take(*nterms) {
                    c.z[t] *= self.lam_step[t];
                    *v = c.z[t];
                }
                c.e *= self.eta_step;
                Point::Modal { z, e: c.e }
            }
            _ => {
                let (x, _, _) = self.advance(p, c);
                let e = if self.is_modal() {
                    c.e
                } else {
                    p.u * C64::from_polar(1.0, self.eta * (p.s0 + c.delta))
                };
                Point::Full { x, e }
            }
        }
    }

    /// The state and its first two derivatives at a [`Point`] of the
    /// started phase `p`.
    #[inline]
    pub fn jet_of(&self, p: &Started<N>, pt: &Point<N>) -> ([f64; N], [f64; N], [f64; N]) {
        let (x, e) = match pt {
            Point::Start => (p.x0, p.e0),
            Point::Modal { e, .. } => (self.state_of(p, pt), *e),
            Point::Full { x, e } => (*x, *e),
        };
        let (d1, d2) = self.derivs_e(p, &x, e);
        (x, d1, d2)
    }

    /// Component i of [`LinearPhase::jet_of`] (the same numbers: the
    /// state and its rate are formed whole, the second derivative only in
    /// row i).
    #[inline(always)]
    pub fn jet_component(&self, p: &Started<N>, pt: &Point<N>, i: usize) -> (f64, f64, f64) {
        let (x, e) = match pt {
            Point::Start => (p.x0, p.e0),
            Point::Modal { e, .. } => (self.state_of(p, pt), *e),
            Point::Full { x, e } => (*x, *e),
        };
        let (z, dz) = (e.re, -self.eta * e.im);
        let d1 = self.rates(x, |r| self.b[r] * z + p.c[r]);
        let mut d2 = self.b[i] * dz;
        for j in 0..N {
            d2 += self.a[i][j] * d1[j];
        }
        (x[i], d1[i], d2)
    }

    /// s_r + Σ_j A_rj·v_j for every row r, summed in order (s_r: the drive
    /// and constant input of the row). A kinematic row (see
    /// [`LinearPhase::kinematic`]) is s_r + v_{r+1}: its zero products add
    /// nothing to a partial sum that is nonzero or +0 (a rate that is
    /// exactly −0 may come out +0; the values are the same).
    #[inline(always)]
    pub(super) fn rates(&self, v: [f64; N], s: impl Fn(usize) -> f64) -> [f64; N] {
        let mut d = [0.0; N];
        if self.kinematic {
            for r in (0..N).step_by(2) {
                d[r] = s(r) + v[r + 1];
                let mut t = s(r + 1);
                for j in 0..N {
                    t += self.a[r + 1][j] * v[j];
                }
                d[r + 1] = t;
            }
        } else {
            for r in 0..N {
                let mut t = s(r);
                for j in 0..N {
                    t += self.a[r][j] * v[j];
                }
                d[r] = t;
            }
        }
        d
    }

    /// The state at a [`Point`] (the first part of [`LinearPhase::jet_of`]).
    #[inline(always)]
    pub fn state_of(&self, p: &Started<N>, pt: &Point<N>) -> [f64; N] {
        match pt {
            Point::Start => p.x0,
            Point::Modal { z, e } => {
                let Repr::Modal {
                    xh, terms, nterms, ..
                } = &self.repr
                else {
                    unreachable!("modal point of a matrix-exponential phase")
                };
                self.modal_state(xh, terms, *nterms, p, z, *e)
            }
            Point::Full { x, .. } => *x,
        }
    }
}
