//! Closed-form propagation of one stick or slip phase.
//!
//! Within a phase the motion obeys a linear ODE with constant coefficients
//! (paper eqs. 1–2, affine friction law):
//!
//! ```text
//! x' = A·x + b·ζ0(s) + c,    ζ0(s) = Re(U·e^{iηs})
//! ```
//!
//! with the harmonic base motion ζ0 of complex amplitude U (|U| = 1 and the
//! phase φ = arg U for the paper's drive) and a constant input c (the dynamic
//! friction level in a slip, the frozen ζ2* in a stick). Its exact solution is
//!
//! ```text
//! x(s0+δ) = x_c + Re(X·U·e^{iη(s0+δ)}) + Re(V·(y0 ∘ e^{λδ})),
//! x_c = −A⁻¹c,  (iηI − A)·X = b,  y0 = V⁻¹·(x(s0) − x_c − Re(X·U·e^{iηs0}))
//! ```
//!
//! where `A = V·diag(λ)·V⁻¹` is computed once per parameter set (faer) and X
//! once per forcing frequency. Where the modal form is unreliable (a
//! defective or nearly defective A, e.g. critical damping, or undamped
//! forcing at an eigenfrequency, whose particular solution grows secularly)
//! the phase falls back to the matrix exponential of the augmented system
//! `[x, Re, Im, 1]`, which is exact for every matrix.

use super::linalg::{self, Aug, Modal, C64, MAX_AUG};

mod project;

pub use project::{PhaseSwitch, Point, Projection};

/// Condition number of the eigenvector matrix above which the modal form is
/// abandoned for the matrix exponential (its error grows like cond·ε).
const MAX_COND: f64 = 1e6;

/// Sub-steps per bracketing step in the table of anchor factors used by
/// [`LinearPhase::jet_near`]: the remaining offset r from the nearest table
/// point has |λr|, |ηr| ≤ 1/(2·SUB).
const SUB: usize = 16;

/// 1/k!, k = 0..=9: Taylor coefficients of the exponential.
const INV_FACT: [f64; 10] = [
    1.0,
    1.0,
    1.0 / 2.0,
    1.0 / 6.0,
    1.0 / 24.0,
    1.0 / 120.0,
    1.0 / 720.0,
    1.0 / 5040.0,
    1.0 / 40320.0,
    1.0 / 362880.0,
];

/// `TAYLOR_RADIUS[n]`: the largest |w| for which the degree-n Taylor
/// polynomial of e^w has relative error below 2⁻⁵⁶ (remainder bound
/// |w|^{n+1}/(n+1)!·e^{2|w|}/(1 − |w|/(n+2)), the e^{2|w|} covering
/// |e^w| ≥ e^{−|w|}); index 0 is unused. Rounded down.
const TAYLOR_RADIUS: [f64; 10] = [
    0.0, 5.26e-9, 4.36e-6, 1.35e-4, 1.10e-3, 4.63e-3, 1.31e-2, 2.91e-2, 5.48e-2, 9.15e-2,
];

#[derive(Debug, Clone, Copy)]
enum Repr<const N: usize> {
    /// Modal form with the unit-amplitude harmonic response X. Complex
    /// eigenvalues of a real matrix come in conjugate pairs whose terms are
    /// conjugate: only one of each pair is evaluated, weighted by 2.
    Modal {
        md: Modal<N>,
        xh: [C64; N],
        terms: [(usize, f64); N],
        nterms: usize,
    },
    /// Augmented matrix `[[A, b, 0, c̃], [0, 0, −η, 0], [0, η, 0, 0], 0]` without
    /// the constant column (set per phase); exponentials taken per call.
    Expm,
}

/// A linear phase system `x' = A x + b ζ0 + c` at one forcing frequency η,
/// with everything precomputed that does not depend on the initial state.
#[derive(Debug, Clone, Copy)]
pub struct LinearPhase<const N: usize> {
    /// System matrix.
    pub a: [[f64; N]; N],
    /// Drive input vector.
    pub b: [f64; N],
    /// Forcing frequency ratio η.
    pub eta: f64,
    ainv: [[f64; N]; N],
    /// The even rows of (A, b) are the kinematic rows x_{2i}' = x_{2i+1}
    /// (the absorber's): their rates are taken without the zero products
    /// (see [`LinearPhase::rates`]).
    kinematic: bool,
    repr: Repr<N>,
    /// Largest |λ| and η: the fastest rate present (bounds bracketing steps).
    pub fastest: f64,
    /// Bracketing step h = 1/fastest and the modal/forcing multipliers
    /// e^{λh}, e^{iηh} that advance a [`Cursor`] by h without transcendentals
    /// (modal factors by term, as the cursor's).
    pub step: f64,
    lam_step: [C64; N],
    eta_step: C64,
    /// The eigenvectors by term: `v_term[t][i]` = V_ik of term t's
    /// eigenvalue k (modal form).
    v_term: [[C64; N]; N],
    /// e^{λ·j·h/SUB} and e^{iη·j·h/SUB} for j = −SUB..=SUB (index j + SUB):
    /// anchors within a step for [`LinearPhase::jet_near`].
    lam_sub: [[C64; N]; 2 * SUB + 1],
    eta_sub: [C64; 2 * SUB + 1],
}

/// The exact solution marched on the bracketing grid δ = j·h: modal terms
/// and the forcing phasor are multiplied by precomputed e^{λh}, e^{iηh}
/// (rounding grows like j·ε, j ≤ a few dozen per phase; events and phase
/// ends are evaluated directly).
///
/// Modal factors are stored by term t (eigenvalue k = `terms[t]`, the
/// first `nterms` entries), as are the phase's y0, step tables and
/// eigenvectors (`v_term`) and a [`Point`]'s factors: no gathers by
/// eigenvalue in the inner loops.
#[derive(Debug, Clone, Copy)]
pub struct Cursor<const N: usize> {
    z: [C64; N],
    e: C64,
    /// Offset δ of the cursor (accumulated like the bracketing grid).
    pub delta: f64,
    /// Steps taken: the factors are those of the offset `steps·h` exactly.
    steps: f64,
}

/// Samples rotated on from one evaluated like `jet_near` (tabulated
/// factors, exact to a few ε) before the next such anchor (see
/// [`LinearPhase::sample_near`]).
pub const SAMPLE_RUN: u32 = 16;

/// The trajectory sampler's state for one phase system over a run: the
/// sample spacing Δ with its factors e^{λΔ}, e^{iηΔ} (made once the spacing
/// repeats, kept across phases), and within the current phase the last
/// sample's offset and factors and the samples rotated since the last
/// anchor.
#[derive(Debug, Clone, Copy)]
pub struct Sampler<const N: usize> {
    gap: f64,
    step: Option<([C64; N], C64)>,
    prev: f64,
    k: u32,
    z: [C64; N],
    e: C64,
}

impl<const N: usize> Default for Sampler<N> {
    fn default() -> Self {
        Self {
            gap: f64::NAN,
            step: None,
            prev: f64::NAN,
            k: SAMPLE_RUN,
            z: [C64::new(0.0, 0.0); N],
            e: C64::new(0.0, 0.0),
        }
    }
}

impl<const N: usize> Sampler<N> {
    /// A new phase: offsets restart, the spacing and its factors stay.
    #[inline]
    pub fn begin_phase(&mut self) {
        self.k = SAMPLE_RUN;
        self.prev = f64::NAN;
    }
}

/// A phase started from a given state: evaluates the exact solution at any
/// offset δ ≥ 0 from its start.
#[derive(Debug, Clone, Copy)]
pub struct Started<const N: usize> {
    x0: [f64; N],
    c: [f64; N],
    xc: [f64; N],
    u: C64,
    s0: f64,
    /// The forcing phasor at the start, U·e^{iηs0} (one sincos per phase,
    /// shared by the modal projection, the δ = 0 jet and the cursor).
    e0: C64,
    /// Modal amplitudes V⁻¹·(…) of the representative terms, by term.
    y0: [C64; N],
}

impl<const N: usize> LinearPhase<N> {
    /// Precomputes the phase system; `None` only if A is singular (it never
    /// is for a physical absorber: det ∝ k > 0).
    pub fn new(a: [[f64; N]; N], b: [f64; N], eta: f64) -> Option<Self> {
        let ainv = linalg::real_inverse(&a)?;
        let md = linalg::modal(&a);
        let fastest = md
            .as_ref()
            .map(modal_rate)
            .unwrap_or_else(|| {
                (0..N)
                    .map(|i| (0..N).map(|j| a[i][j].abs()).sum::<f64>())
                    .fold(0.0, f64::max)
            })
            .max(eta);
        let repr = match md {
            Some(md) if md.cond < MAX_COND => {
                match (
                    linalg::shifted_solve(&a, C64::new(0.0, eta), &b),
                    conjugate_terms(&md),
                ) {
                    (Some(xh), Some((terms, nterms))) => Repr::Modal {
                        md,
                        xh,
                        terms,
                        nterms,
                    },
                    _ => Repr::Expm,
                }
            }
            _ => Repr::Expm,
        };
        let step = 1.0 / fastest;
        // The matrix-exponential form marches and evaluates without tables.
        let ((lam_step, lam_sub), eta_sub) = match &repr {
            Repr::Modal {
                md, terms, nterms, ..
            } => (lam_tables(md, terms, *nterms, step), eta_table(eta, step)),
            Repr::Expm => (
                (
                    [C64::new(0.0, 0.0); N],
                    [[C64::new(0.0, 0.0); N]; 2 * SUB + 1],
                ),
                [C64::new(0.0, 0.0); 2 * SUB + 1],
            ),
        };
        let mut v_term = [[C64::new(0.0, 0.0); N]; N];
        if let Repr::Modal {
            md, terms, nterms, ..
        } = &repr
        {
            for (t, &(k, _)) in terms[..*nterms].iter().enumerate() {
                for i in 0..N {
                    v_term[t][i] = md.v[i][k];
                }
            }
        }
        Some(Self {
            a,
            b,
            eta,
            ainv,
            v_term,
            kinematic: kinematic(&a, &b),
            repr,
            fastest,
            step,
            lam_step,
            eta_step: C64::from_polar(1.0, eta * step),
            lam_sub,
            eta_sub,
        })
    }

    /// The same phase system at another forcing frequency η, bit-identical
    /// to `LinearPhase::new(a, b, η)` but cheaper: the eigen-decomposition
    /// (which does not depend on η) is reused, and so are the modal step
    /// tables where the bracketing step stays the same (η below the
    /// fastest mode). A sweep over η calls this once per point.
    pub fn at_eta(&self, eta: f64) -> Option<Self> {
        let Repr::Modal {
            md, terms, nterms, ..
        } = &self.repr
        else {
            return Self::new(self.a, self.b, eta);
        };
        let Some(xh) = linalg::shifted_solve(&self.a, C64::new(0.0, eta), &self.b) else {
            return Self::new(self.a, self.b, eta);
        };
        let fastest = modal_rate(md).max(eta);
        let step = 1.0 / fastest;
        let (lam_step, lam_sub) = if step.to_bits() == self.step.to_bits() {
            (self.lam_step, self.lam_sub)
        } else {
            lam_tables(md, terms, *nterms, step)
        };
        Some(Self {
            eta,
            repr: Repr::Modal {
                md: *md,
                xh,
                terms: *terms,
                nterms: *nterms,
            },
            fastest,
            step,
            lam_step,
            eta_step: C64::from_polar(1.0, eta * step),
            lam_sub,
            eta_sub: eta_table(eta, step),
            ..*self
        })
    }

    /// True when the closed form is the modal one (false: matrix exponential).
    pub fn is_modal(&self) -> bool {
        matches!(self.repr, Repr::Modal { .. })
    }

    /// Starts the phase at state `x0`, offset `s0` within the drive frame
    /// (forcing ζ0 = Re(U e^{iη(s0+δ)})), with constant input `c`.
    #[inline]
    pub fn start(&self, x0: [f64; N], s0: f64, u: C64, c: [f64; N]) -> Started<N> {
        // x_c = −A⁻¹c, each row summed over j in order; a zero c_j adds a
        // zero product, which leaves every partial sum (+0 or nonzero) as
        // it is: skipped (the inputs have one or two nonzero entries).
        let mut xc = [0.0; N];
        for j in 0..N {
            if c[j] != 0.0 {
                for i in 0..N {
                    xc[i] -= self.ainv[i][j] * c[j];
                }
            }
        }
        let mut y0 = [C64::new(0.0, 0.0); N];
        // At s0 = 0 (a period's start) e^{iη·0} = 1 exactly: no sincos.
        let e0 = u * if s0 == 0.0 {
            C64::new(1.0, 0.0)
        } else {
            C64::from_polar(1.0, self.eta * s0)
        };
        if let Repr::Modal {
            md,
            xh,
            terms,
            nterms,
        } = &self.repr
        {
            let mut r = [0.0; N];
            for i in 0..N {
                r[i] = x0[i] - xc[i] - (xh[i] * e0).re;
            }
            // By term (see [`Cursor`]): only the representative terms are
            // ever evaluated.
            for (t, &(k, _)) in terms[..*nterms].iter().enumerate() {
                for (i, ri) in r.iter().enumerate() {
                    y0[t] += md.vinv[k][i] * ri;
                }
            }
        }
        Started {
            x0,
            c,
            xc,
            u,
            s0,
            e0,
            y0,
        }
    }

    /// The drive ζ0 and its derivative at frame offset s.
    #[inline]
    pub fn drive(&self, u: C64, s: f64) -> (f64, f64) {
        let e = u * C64::from_polar(1.0, self.eta * s);
        (e.re, -self.eta * e.im)
    }

    /// Exact state at offset δ from the phase start (the first part of
    /// [`LinearPhase::jet`]).
    #[inline]
    pub fn state(&self, p: &Started<N>, delta: f64) -> [f64; N] {
        self.jet(p, delta).0
    }

    fn state_expm(&self, p: &Started<N>, delta: f64) -> [f64; N] {
        let n = N + 3;
        let mut m: Aug = [[0.0; MAX_AUG]; MAX_AUG];
        for i in 0..N {
            for j in 0..N {
                m[i][j] = self.a[i][j] * delta;
            }
            m[i][N] = self.b[i] * delta;
            m[i][N + 2] = p.c[i] * delta;
        }
        m[N][N + 1] = -self.eta * delta;
        m[N + 1][N] = self.eta * delta;
        let e = linalg::expm(&m, n);
        let w = p.e0;
        let mut y = [0.0; MAX_AUG];
        y[..N].copy_from_slice(&p.x0);
        y[N] = w.re;
        y[N + 1] = w.im;
        y[N + 2] = 1.0;
        let mut x = [0.0; N];
        for (i, xi) in x.iter_mut().enumerate() {
            *xi = (0..n).map(|j| e[i][j] * y[j]).sum();
        }
        x
    }

    /// State and its first two derivatives at offset δ (one forcing
    /// evaluation shared by all three).
    #[inline]
    pub fn jet(&self, p: &Started<N>, delta: f64) -> ([f64; N], [f64; N], [f64; N]) {
        if delta == 0.0 {
            // Exactly the initial state: the modal reconstruction carries
            // rounding of order ε·cond(V), which must not move a switching
            // function off the boundary the phase starts on.
            let (d1, d2) = self.derivs_e(p, &p.x0, p.e0);
            return (p.x0, d1, d2);
        }
        match &self.repr {
            Repr::Modal {
                md,
                xh,
                terms,
                nterms,
            } => {
                let e = p.u * C64::from_polar(1.0, self.eta * (p.s0 + delta));
                let mut z = [C64::new(0.0, 0.0); N];
                for (t, &(k, _)) in terms[..*nterms].iter().enumerate() {
                    z[t] = p.y0[t] * (md.lambda[k] * delta).exp();
                }
                let x = self.modal_state(xh, terms, *nterms, p, &z, e);
                let (d1, d2) = self.derivs_e(p, &x, e);
                (x, d1, d2)
            }
            Repr::Expm => {
                let x = self.state_expm(p, delta);
                let e = p.u * C64::from_polar(1.0, self.eta * (p.s0 + delta));
                let (d1, d2) = self.derivs_e(p, &x, e);
                (x, d1, d2)
            }
        }
    }

    /// A cursor at δ = 0.
    #[inline]
    pub fn cursor(&self, p: &Started<N>) -> Cursor<N> {
        Cursor {
            z: p.y0,
            e: p.e0,
            delta: 0.0,
            steps: 0.0,
        }
    }

    /// The jet at offset δ evaluated from a nearby cursor instead of the
    /// phase start: for |δ − c| ≤ h (the bracketing step, so |λ(δ − c)| ≤ 1)
    /// the cursor's modal and forcing factors are multiplied by a tabulated
    /// e^{λ·j·h/SUB}, e^{iη·j·h/SUB} (nearest j) and by e^{λr}, e^{iηr} for
    /// the rest |r| ≤ h/(2·SUB), taken from a Taylor polynomial whose degree
    /// keeps its truncation below 2⁻⁵⁶ relative (no libm call). Each factor
    /// is exact to a few ε, so the result differs from [`LinearPhase::jet`]
    /// by rounding only (the cursor's own drift, a few ε per step, is of the
    /// order of the argument rounding ε·|λδ| of the direct evaluation).
    /// Elsewhere, at δ = 0 and for the matrix-exponential form: `jet`.
    #[inline]
    pub fn jet_near(
        &self,
        p: &Started<N>,
        c: &Cursor<N>,
        delta: f64,
    ) -> ([f64; N], [f64; N], [f64; N]) {
        if let Repr::Modal {
            xh, terms, nterms, ..
        } = &self.repr
        {
            if let Some((z, e)) = self.factors_near(c, delta) {
                let x = self.modal_state(xh, terms, *nterms, p, &z, e);
                let (d1, d2) = self.derivs_e(p, &x, e);
                return (x, d1, d2);
            }
        }
        self.jet(p, delta)
    }

    /// The modal and forcing factors (z, e) at offset δ from a nearby
    /// cursor, as [`LinearPhase::jet_near`] takes them (tabulated anchor
    /// times a Taylor polynomial); `None` at δ = 0, off the table, with
    /// more than two modal terms and for the matrix-exponential form.
    #[inline(always)]
    fn factors_near(&self, c: &Cursor<N>, delta: f64) -> Option<([C64; N], C64)> {
        let Repr::Modal {
            md, terms, nterms, ..
        } = &self.repr
        else {
            return None;
        };
        if delta == 0.0 || *nterms > 2 {
            return None;
        }
        let t = delta - c.steps * self.step;
        // Nearest table point j = round(t·SUB/h) (as an index j + SUB).
        let q = t * (SUB as f64 * self.fastest) + (SUB as f64 + 0.5);
        if !(q >= 0.0 && q < (2 * SUB + 1) as f64) {
            return None;
        }
        let idx = q as usize;
        let r = t - table_offset(idx, self.step);
        let wmax = (self.fastest * r).abs();
        let mut n = 1;
        while n < 9 && wmax > TAYLOR_RADIUS[n] {
            n += 1;
        }
        // Up to two modal terms and the forcing: a Horner chain each (two
        // for one modal term, e.g. a stick phase; the chains are
        // independent, so each factor is the same either way).
        let eta_r = self.eta * r;
        let (fz, fe) = if *nterms == 1 {
            let (f, fe) = exp_taylor(&[md.lambda[terms[0].0] * r], eta_r, n);
            ([f[0], C64::new(0.0, 0.0)], fe)
        } else {
            let mut w = [C64::new(0.0, 0.0); 2];
            for (wi, &(k, _)) in w.iter_mut().zip(&terms[..*nterms]) {
                *wi = md.lambda[k] * r;
            }
            exp_taylor(&w, eta_r, n)
        };
        let ls = &self.lam_sub[idx];
        let mut z = [C64::new(0.0, 0.0); N];
        for t in 0..*nterms {
            z[t] = c.z[t] * ls[t] * fz[t];
        }
        Some((z, c.e * self.eta_sub[idx] * fe))
    }

    /// The state and its rate at offset δ for a trajectory sample: as
    /// [`LinearPhase::jet_near`], except that where δ lies about one sample
    /// spacing Δ after the previous sample δp of this phase, the previous
    /// sample's factors are multiplied by e^{λΔ}, e^{iηΔ} (kept in `s`
    /// across the phases of a run) and by e^{λd}, e^{iηd} for the
    /// deviation d = δ − δp − Δ of this spacing (degree-2 Taylor, exact to
    /// 2⁻⁵⁶ for |λd| ≤ 4.36e-6: sample times carry their log's rounding and
    /// jitter). So each sample is evaluated at its own time; each rotation
    /// adds a few ε and an evaluation like `jet_near` re-anchors every
    /// [`SAMPLE_RUN`] samples (unit test `samples_match_jet`). Output-error
    /// fits sample thousands of times per event: this is their hot path.
    #[inline]
    pub fn sample_near(
        &self,
        p: &Started<N>,
        c: &Cursor<N>,
        s: &mut Sampler<N>,
        delta: f64,
    ) -> ([f64; N], [f64; N]) {
        let Repr::Modal {
            md,
            xh,
            terms,
            nterms,
        } = &self.repr
        else {
            let (x, d1, _) = self.jet(p, delta);
            return (x, d1);
        };
        let g = delta - s.prev;
        let dev = g - s.gap;
        // (NaN before the first sample of a phase and without a spacing.)
        let near = (self.fastest * dev).abs() <= TAYLOR_RADIUS[2];
        let factors = if s.k < SAMPLE_RUN && near {
            let (lam, eta) = match s.step {
                Some(m) => m,
                None => {
                    let mut lam = [C64::new(0.0, 0.0); N];
                    for (t, &(k, _)) in terms[..*nterms].iter().enumerate() {
                        lam[t] = (md.lambda[k] * s.gap).exp();
                    }
                    let m = (lam, C64::from_polar(1.0, self.eta * s.gap));
                    s.step = Some(m);
                    m
                }
            };
            let fix = |w: C64| C64::new(1.0, 0.0) + w * (C64::new(1.0, 0.0) + w * 0.5);
            if dev == 0.0 {
                for t in 0..*nterms {
                    s.z[t] *= lam[t];
                }
                s.e *= eta;
            } else {
                for (t, &(k, _)) in terms[..*nterms].iter().enumerate() {
                    s.z[t] *= lam[t] * fix(md.lambda[k] * dev);
                }
                s.e *= eta * fix(C64::new(0.0, self.eta * dev));
            }
            s.k += 1;
            Some((s.z, s.e))
        } else {
            let f = self.factors_near(c, delta);
            if let Some((z, e)) = f {
                // A new spacing (rotated only while it is at most one
                // bracketing step: |λΔ| ≤ 1 keeps the rotation exact); the
                // first sample of a phase keeps the run's spacing.
                if g.is_finite() && !near {
                    s.gap = if g > 0.0 && g * self.fastest <= 1.0 {
                        g
                    } else {
                        f64::NAN
                    };
                    s.step = None;
                }
                s.k = 0;
                s.z = z;
                s.e = e;
            } else {
                s.k = SAMPLE_RUN;
            }
            f
        };
        s.prev = delta;
        match factors {
            Some((z, e)) => {
                let x = self.modal_state(xh, terms, *nterms, p, &z, e);
                let (d1, _) = self.derivs_e(p, &x, e);
                (x, d1)
            }
            None => {
                let (x, d1, _) = self.jet(p, delta);
                (x, d1)
            }
        }
    }

    /// Advances the cursor by one bracketing step and returns the jet there.
    #[inline]
    pub fn advance(&self, p: &Started<N>, c: &mut Cursor<N>) -> ([f64; N], [f64; N], [f64; N]) {
        c.delta += self.step;
        c.steps += 1.0;
        match &self.repr {
            Repr::Modal {
                xh, terms, nterms, ..
            } => {
                for t in 0..*nterms {
                    c.z[t] *= self.lam_step[t];
                }
                c.e *= self.eta_step;
                let x = self.modal_state(xh, terms, *nterms, p, &c.z, c.e);
                let (d1, d2) = self.derivs_e(p, &x, c.e);
                (x, d1, d2)
            }
            Repr::Expm => self.jet(p, c.delta),
        }
    }

    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn modal_state(
        &self,
        xh: &[C64; N],
        terms: &[(usize, f64); N],
        nterms: usize,
        p: &Started<N>,
        z: &[C64],
        e: C64,
    ) -> [f64; N] {
        let mut x = [0.0; N];
        for i in 0..N {
            x[i] = p.xc[i] + (xh[i] * e).re;
        }
        for (t, &(_, w)) in terms[..nterms].iter().enumerate() {
            let ey = z[t] * w;
            let v = &self.v_term[t];
            for (i, xi) in x.iter_mut().enumerate() {
                *xi += v[i].re * ey.re - v[i].im * ey.im;
            }
        }
        x
    }

    #[inline(always)]
    fn derivs_e(&self, p: &Started<N>, x: &[f64; N], e: C64) -> ([f64; N], [f64; N]) {
        let (z, dz) = (e.re, -self.eta * e.im);
        let d1 = self.rates(*x, |r| self.b[r] * z + p.c[r]);
        let d2 = self.rates(d1, |r| self.b[r] * dz);
        (d1, d2)
    }
}

/// Whether the even rows of (A, b) are x_{2i}' = x_{2i+1} (N even).
fn kinematic<const N: usize>(a: &[[f64; N]; N], b: &[f64; N]) -> bool {
    N.is_multiple_of(2)
        && (0..N)
            .step_by(2)
            .all(|r| b[r] == 0.0 && (0..N).all(|j| a[r][j] == if j == r + 1 { 1.0 } else { 0.0 }))
}

/// The largest |λ| of a modal decomposition (the fastest mode's rate).
fn modal_rate<const N: usize>(md: &Modal<N>) -> f64 {
    md.lambda.iter().map(|l| l.norm()).fold(0.0, f64::max)
}

/// Offset of table point j (index j + SUB) for the bracketing step `step`.
#[inline]
fn table_offset(j: usize, step: f64) -> f64 {
    (j as f64 - SUB as f64) * (step / SUB as f64)
}

/// e^{w_i} and e^{iy} for |w_i|, |y| ≤ `TAYLOR_RADIUS[n]`: the degree-n
/// Taylor polynomials by Horner's rule, the chains interleaved (fixed
/// length: kept in registers). The chain of the imaginary argument iy (the
/// forcing's) takes the product q·iy as (−q_im·y, q_re·y): the same numbers
/// as the complex product with w = (0, y), whose products with the zero
/// real part add nothing (q_re > 0; q_im·0 is a zero added to q_re·y, which
/// is +0 or nonzero), in half the multiplications.
#[inline(always)]
fn exp_taylor<const M: usize>(w: &[C64; M], y: f64, n: usize) -> ([C64; M], C64) {
    let mut p = [C64::new(INV_FACT[n], 0.0); M];
    let mut q = C64::new(INV_FACT[n], 0.0);
    for &cf in INV_FACT[..n].iter().rev() {
        for (pi, wi) in p.iter_mut().zip(w) {
            *pi = *pi * wi + cf;
        }
        q = C64::new(cf - q.im * y, q.re * y);
    }
    (p, q)
}

/// The modal factors e^{λh} of one bracketing step h and e^{λ·j·h/SUB},
/// j = −SUB..=SUB, of the table of [`LinearPhase::jet_near`].
#[allow(clippy::type_complexity)]
fn lam_tables<const N: usize>(
    md: &Modal<N>,
    terms: &[(usize, f64); N],
    nterms: usize,
    step: f64,
) -> ([C64; N], [[C64; N]; 2 * SUB + 1]) {
    let mut lam_step = [C64::new(0.0, 0.0); N];
    let mut lam_sub = [[C64::new(0.0, 0.0); N]; 2 * SUB + 1];
    for (t, &(k, _)) in terms[..nterms].iter().enumerate() {
        lam_step[t] = (md.lambda[k] * step).exp();
    }
    for (j, ls) in lam_sub.iter_mut().enumerate() {
        let off = table_offset(j, step);
        for (t, &(k, _)) in terms[..nterms].iter().enumerate() {
            ls[t] = (md.lambda[k] * off).exp();
        }
    }
    (lam_step, lam_sub)
}

/// The forcing factors e^{iη·j·h/SUB}, j = −SUB..=SUB.
fn eta_table(eta: f64, step: f64) -> [C64; 2 * SUB + 1] {
    let mut eta_sub = [C64::new(0.0, 0.0); 2 * SUB + 1];
    for (j, es) in eta_sub.iter_mut().enumerate() {
        let off = table_offset(j, step);
        *es = C64::from_polar(1.0, eta * off);
    }
    eta_sub
}

/// Pairs conjugate eigenvalues: returns the representative terms with their
/// weights (2 for a pair, 1 for a real eigenvalue); `None` if the spectrum
/// does not pair up (then the modal form is not used).
pub(crate) fn conjugate_terms<const N: usize>(md: &Modal<N>) -> Option<([(usize, f64); N], usize)> {
    let mut terms = [(0usize, 0.0f64); N];
    let mut n = 0;
    let mut used = [false; N];
    for k in 0..N {
        if used[k] {
            continue;
        }
        used[k] = true;
        let l = md.lambda[k];
        let tol = 1e-12 * l.norm().max(1e-300);
        if l.im.abs() <= tol {
            terms[n] = (k, 1.0);
        } else {
            let j = (0..N)
                .find(|&j| !used[j] && (md.lambda[j] - l.conj()).norm() <= 1e-9 * l.norm())?;
            used[j] = true;
            terms[n] = (k, 2.0);
        }
        n += 1;
    }
    Some((terms, n))
}

/// Phase matrices of the absorber (paper eqs. 1–2) for an affine law.
pub mod absorber {
    use crate::model::Absorber;

    /// Slip-phase matrix for state `[ζ1, ζ1', ζ2, ζ2']` with slope D* (the
    /// velocity-proportional part of the friction acts like extra damping).
    pub fn slip_matrix(a: &Absorber, slope: f64) -> [[f64; 4]; 4] {
        let (m, k, d) = (a.m, a.k, a.damping);
        [
            [0.0, 1.0, 0.0, 0.0],
            [-(1.0 + k) / m, -d / m, 1.0 / m, d / m],
            [0.0, 0.0, 0.0, 1.0],
            [1.0, d, -1.0, -(d + slope)],
        ]
    }

    /// Matrix of the held phase of a pad with a contact spring κ (issue 34):
    /// the slider sticks at ζs and M2 moves on the spring,
    /// ζ2'' = ζ1 − ζ2 + D(ζ1' − ζ2') − κ(ζ2 − ζs) (the constant κζs is an
    /// input, see [`crate::sim::Sim`]). Two free masses: a linear phase.
    pub fn held_matrix(a: &Absorber, kappa: f64) -> [[f64; 4]; 4] {
        let mut m = slip_matrix(a, 0.0);
        m[3][2] = -1.0 - kappa;
        m
    }

    /// Drive input of the slip phase: k·ζ0 acts on M1.
    pub fn slip_input(a: &Absorber) -> [f64; 4] {
        [0.0, a.k / a.m, 0.0, 0.0]
    }

    /// Stick-phase matrix for state `[ζ1, ζ1']` (eq. 2).
    pub fn stick_matrix(a: &Absorber) -> [[f64; 2]; 2] {
        [[0.0, 1.0], [-(1.0 + a.k) / a.m, -a.damping / a.m]]
    }

    /// Drive input of the stick phase.
    pub fn stick_input(a: &Absorber) -> [f64; 2] {
        [0.0, a.k / a.m]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Absorber;
    use crate::sim::events::Switch;

    fn both_reprs(a: [[f64; 4]; 4], b: [f64; 4], eta: f64) -> (LinearPhase<4>, LinearPhase<4>) {
        let modal = LinearPhase::new(a, b, eta).unwrap();
        assert!(modal.is_modal());
        let mut expm = modal;
        expm.repr = Repr::Expm;
        (modal, expm)
    }

    /// Trajectory samples rotated on from the previous one agree with the
    /// direct closed form to the bound `sample_near` documents, over
    /// several phases of one run (the spacing kept across them), a gap, a
    /// coarsely jittered stretch (evaluated from the table) and one with
    /// timestamp-like jitter (rotated with the deviation's factor); and
    /// rotation is really used.
    #[test]
    fn samples_match_jet() {
        let ab = Absorber::default();
        let ph = LinearPhase::new(
            absorber::slip_matrix(&ab, -0.04),
            absorber::slip_input(&ab),
            0.6,
        )
        .unwrap();
        let u = C64::from_polar(1.0, 0.7);
        let c = [0.0, 0.0, 0.0, -0.375];
        let mut smp = Sampler::<4>::default();
        let gap = ph.step / 37.0;
        let (mut rotated, mut worst) = (0, 0.0f64);
        for (start, x0) in [(0.0, [0.3, -0.1, 0.2, 0.05]), (7.1, [-0.2, 0.4, 0.1, -0.3])] {
            let p = ph.start(x0, start, u, c);
            let mut cur = ph.cursor(&p);
            smp.begin_phase();
            let mut j = 0usize;
            let mut tau_rel = 0.0;
            while tau_rel < 12.0 * ph.step {
                j += 1;
                // A gap after 100 samples, jitter from 200 to 260.
                tau_rel = (j + if j > 100 { 9 } else { 0 }) as f64 * gap;
                if (200..260).contains(&j) {
                    tau_rel += 1e-3 * gap * ((j * 7919) % 11) as f64;
                }
                // Timestamp-like jitter: rotated with the deviation's factor.
                if (300..360).contains(&j) {
                    tau_rel += 1e-9 * gap * ((j * 7919) % 11) as f64;
                }
                while tau_rel > cur.delta + ph.step {
                    ph.advance(&p, &mut cur);
                }
                let k0 = smp.k;
                let (x, dx) = ph.sample_near(&p, &cur, &mut smp, tau_rel);
                if smp.k > 0 && smp.k != SAMPLE_RUN && smp.k == k0 + 1 {
                    rotated += 1;
                }
                let (xd, dxd, _) = ph.jet(&p, tau_rel);
                let bound = 4.0 * SAMPLE_RUN as f64 * f64::EPSILON;
                let scale = |v: &[f64; 4]| v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
                for i in 0..4 {
                    // Relative to the motion's size, plus the rounding of
                    // the offsets (the grid here is exact: j·Δ) times the
                    // rate; the rate likewise with the acceleration.
                    let tol_x = bound * (scale(&xd) + tau_rel * scale(&dxd));
                    worst = worst.max((x[i] - xd[i]).abs() / tol_x);
                    let tol_dx = bound * (scale(&dxd) + tau_rel * scale(&xd));
                    worst = worst.max((dx[i] - dxd[i]).abs() / tol_dx);
                }
            }
        }
        assert!(worst <= 1.0, "samples off by {worst} of the bound");
        // About 15 of 16 of the ~770 samples outside the coarse jitter.
        assert!(rotated > 650, "only {rotated} samples rotated");
    }

    /// A switching function on phase points: `eval` is the function of the
    /// assembled jet bit for bit; `quick` projects on the closed form, with
    /// h bit for bit for the gradients ±e3 of the slip's switching
    /// functions (any offset) and h' within its bound, which is itself
    /// far above rounding yet far below h' (on grid points: marched cursor;
    /// off-grid: tabulated factors; far offsets: libm factors; δ = 0: the
    /// exact start). The matrix-exponential form evaluates the jet itself.
    #[test]
    fn projected_switch_matches_jet() {
        use crate::sim::events::{EventFn, Jet};
        let ab = Absorber::default();
        let (ph, ex) = both_reprs(
            absorber::slip_matrix(&ab, -0.04),
            absorber::slip_input(&ab),
            0.6,
        );
        let u = C64::from_polar(1.0, 0.7);
        let c = [0.0, 0.0, 0.0, -0.375];
        let x0 = [0.3, -0.1, 0.2, 0.05];
        let grads = [
            ([0.0, 0.0, 0.0, 1.0], 0.0),
            ([0.0, 0.0, 0.0, -1.0], 0.0),
            ([0.0, 0.0, 0.0, -1.0], 0.3),
            ([1.0, ab.damping, -1.0, -ab.damping], 0.375),
        ];
        let (mut worst, mut projected) = (0.0f64, 0);
        for phase in [&ph, &ex] {
            let p = phase.start(x0, 1.3, u, c);
            let (xs, ds, dds) = phase.jet_of(&p, &Point::Start);
            let j0 = [xs, ds, dds];
            for (g, g0) in grads {
                let proj = phase.projection(g);
                let sw = phase.switch(&proj, &p, g0, &j0);
                // From the start state alone: the same h at δ = 0, and the
                // same h', h'' where h > 0 (on the boundary they are unread).
                let (h0, q0) = (sw.eval(&Point::Start), phase.switch_start(&proj, &p, g0));
                let q0 = q0.eval(&Point::Start);
                assert_eq!(h0.0.to_bits(), q0.0.to_bits());
                if h0.0 > 0.0 {
                    assert_eq!(h0, q0);
                }
                let ev = EventFn { g, g0 };
                let mut pts = vec![(0.0, Point::Start)];
                let mut cur = phase.cursor(&p);
                for _ in 0..6 {
                    let q = phase.advance_point(&p, &mut cur);
                    pts.push((cur.delta, q));
                    for f in [0.13, 0.5, 0.91] {
                        let d = cur.delta + f * phase.step;
                        pts.push((d, phase.point_near(&p, &cur, d)));
                    }
                }
                pts.push((40.0, phase.point_near(&p, &cur, 40.0)));
                for (d, q) in pts {
                    let (x, dx, ddx) = phase.jet_of(&p, &q);
                    assert_eq!(phase.state_of(&p, &q), x);
                    let want = ev.eval(&Jet { x, dx, ddx });
                    assert_eq!(sw.eval(&q), want, "δ = {d}");
                    let (h, dq, tol) = sw.quick(&q);
                    assert_eq!(h.to_bits(), want.0.to_bits(), "δ = {d}");
                    assert!((dq - want.1).abs() <= tol, "δ = {d}: {dq} vs {}", want.1);
                    if tol > 0.0 {
                        projected += 1;
                        // Rounding is ~1e-16 of the terms; the bound 1e-8.
                        worst = worst.max((dq - want.1).abs() / tol);
                        assert!(tol < 1e-6 * (want.1.abs() + dx[3].abs() + x[3].abs()));
                    }
                }
            }
        }
        assert_eq!(projected, 3 * 25);
        assert!(worst < 1e-6, "projected h' off by {worst} of its bound");
    }

    /// The modal closed form and the matrix exponential are two independent
    /// exact solutions: they must agree to rounding over a long offset.
    #[test]
    fn modal_agrees_with_expm() {
        let ab = Absorber::default();
        let (p, q) = both_reprs(
            absorber::slip_matrix(&ab, -0.04),
            absorber::slip_input(&ab),
            0.6,
        );
        let x0 = [0.3, -0.1, 0.2, 0.05];
        let u = C64::from_polar(1.0, 0.7);
        let c = [0.0, 0.0, 0.0, -0.375];
        let (sp, sq) = (p.start(x0, 1.3, u, c), q.start(x0, 1.3, u, c));
        for &d in &[0.0, 0.1, 1.0, 5.0, 10.0] {
            let (xp, xq) = (p.state(&sp, d), q.state(&sq, d));
            for i in 0..4 {
                assert!(
                    (xp[i] - xq[i]).abs() < 2e-13,
                    "δ={d} i={i}: {} vs {}",
                    xp[i],
                    xq[i]
                );
            }
        }
    }

    /// Critical damping of the stick system makes A defective: the phase
    /// must fall back and still match the closed form of a critically damped
    /// oscillator, x(t) = (x0 + (v0 + ω x0) t) e^{−ω t}.
    #[test]
    fn critical_damping_is_exact() {
        let ab = Absorber {
            m: 1.0,
            k: 3.0,
            damping: 4.0, // D² = 4 m (1+k): critical
        };
        let p = LinearPhase::new(absorber::stick_matrix(&ab), [0.0, 0.0], 0.5).unwrap();
        assert!(!p.is_modal());
        let w = 2.0;
        let (x0, v0) = (0.4, -0.3);
        let s = p.start([x0, v0], 0.0, C64::new(0.0, 0.0), [0.0, 0.0]);
        for &t in &[0.1, 1.0, 3.0] {
            let x = p.state(&s, t);
            let exact = (x0 + (v0 + w * x0) * t) * (-w * t).exp();
            assert!((x[0] - exact).abs() < 1e-14, "{} vs {exact}", x[0]);
        }
    }

    /// Undamped forcing at the eigenfrequency: x'' + ω²x = cos(ωt) from rest
    /// has the secular solution t·sin(ωt)/(2ω).
    #[test]
    fn undamped_resonance_grows_secularly() {
        let w: f64 = 0.7;
        let p = LinearPhase::new([[0.0, 1.0], [-w * w, 0.0]], [0.0, 1.0], w).unwrap();
        assert!(!p.is_modal());
        let s = p.start([0.0, 0.0], 0.0, C64::new(1.0, 0.0), [0.0, 0.0]);
        for &t in &[1.0, 10.0, 40.0] {
            let x = p.state(&s, t);
            let exact = t * (w * t).sin() / (2.0 * w);
            assert!(
                (x[0] - exact).abs() < 1e-12 * (1.0 + exact.abs()),
                "{} vs {exact}",
                x[0]
            );
        }
    }
}
