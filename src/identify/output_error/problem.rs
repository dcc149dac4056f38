//! The output-error problem of one family: θ ↦ simulated positions ↦
//! residuals, the start-velocity projection, and the cost argmin minimises.

use super::*;
use rayon::prelude::*;

/// Rig constants the model needs.
#[derive(Debug, Clone, Copy)]
pub(super) struct Rig {
    pub(super) absorber: Absorber,
    pub(super) k1: f64,
    pub(super) k2: f64,
    pub(super) omega: f64,
}

/// One family's cost over the prepared data.
pub(super) struct Problem<'a> {
    pub(super) d: &'a Data,
    pub(super) rig: Rig,
    pub(super) kind: LawKind,
    /// Real-pad extensions refined with the law.
    pub(super) ext: Ext,
    pub(super) never_sticks: bool,
    pub(super) evals: &'a std::cell::Cell<usize>,
    /// Simulated stick samples and stick runs since the last reset.
    pub(super) sticks: std::cell::Cell<(usize, usize)>,
    /// Per-direction breakaways and reversal forces since the last reset.
    pub(super) dirs: std::cell::Cell<DirStats>,
    /// When set, the sample index of every compared sample is recorded.
    /// Compared samples and the simulated ẍ2 (m/s²) there, when recorded.
    pub(super) idx: std::cell::RefCell<Option<Vec<(usize, f64)>>>,
    /// The x1, x2 lags profiled out at the last evaluation
    /// ([`Data::delays`]).
    pub(super) delays: std::cell::Cell<DelayFit>,
}

/// Residuals of one evaluation: (segment, r1, r2) per compared sample.
pub(super) type Res = Vec<(u32, f64, f64)>;

/// Number of law parameters of a family in θ.
pub(super) fn n_params(kind: LawKind) -> usize {
    kind.family().params().len()
}

/// Real-pad extensions refined beside a family's law
/// (`docs/real-pads.md`): θ = [law…, bias, g1, g2] then ends in Δ (N) for
/// a static threshold split by direction and ln κ for a contact spring,
/// in that order.
///
/// The split is the one combination of direction-dependent levels that
/// unknown sensor zero offsets leave identifiable: the levels are
/// Rs⁺ = Rs + Δ/2, Rs⁻ = Rs − Δ/2, Rd⁺ = Rd⁻ = Rd (the gauge "equal
/// dynamic levels": a common shift of one direction's levels is a
/// constant force on M2, which the force bias absorbs).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Ext {
    /// The static threshold differs by direction (Δ).
    pub split: bool,
    /// A contact spring (pre-sliding) behind the stick.
    pub contact: bool,
}

impl Ext {
    /// Number of extra parameters.
    pub fn len(self) -> usize {
        self.split as usize + self.contact as usize
    }
    /// No extension: the paper's symmetric, rigid pad.
    pub fn is_empty(self) -> bool {
        self.len() == 0
    }
}

/// A family with its extensions: what one refinement fits.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct Fam {
    pub(super) kind: LawKind,
    pub(super) ext: Ext,
}

impl From<LawKind> for Fam {
    fn from(kind: LawKind) -> Self {
        Fam {
            kind,
            ext: Ext::default(),
        }
    }
}

impl Fam {
    /// Parameters the criterion counts: the law's and the extensions'.
    pub(super) fn n_params(self) -> usize {
        n_params(self.kind) + self.ext.len()
    }
}

/// The extension values of θ: Δ (N, 0 without a split) and κ (None for a
/// rigid stick).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct ExtValues {
    pub(super) split_n: f64,
    pub(super) kappa: Option<f64>,
}

impl Problem<'_> {
    /// Unpacks θ = [law…, bias, g1, g2] (the law's parameters as its
    /// [`crate::model::LawFamily`] orders them).
    pub(super) fn unpack(&self, th: &[f64]) -> (SiLaw, f64, f64, f64) {
        let family = self.kind.family();
        let k = family.params().len();
        (family.unpack(th), th[k], th[k + 1], th[k + 2])
    }

    /// The law as reported (SI): Rs is the threshold towards + where the
    /// threshold is split (Rs + Δ/2), with Rs⁻ = Rs − Δ/2 (N) and κ.
    pub(super) fn pad_law(&self, th: &[f64]) -> (SiLaw, Option<f64>, Option<f64>) {
        let (mut law, ..) = self.unpack(th);
        let ev = self.ext_values(th);
        let mut minus = None;
        if self.ext.split {
            minus = Some(law.rs_n - 0.5 * ev.split_n);
            law.rs_n += 0.5 * ev.split_n;
        }
        (law, minus, ev.kappa)
    }

    /// The extension values of θ (after [law…, bias, g1, g2]).
    pub(super) fn ext_values(&self, th: &[f64]) -> ExtValues {
        let mut k = n_params(self.kind) + 3;
        let mut next = |on: bool| {
            on.then(|| {
                k += 1;
                th[k - 1]
            })
        };
        let split_n = next(self.ext.split).unwrap_or(0.0);
        let kappa = next(self.ext.contact).map(f64::exp);
        ExtValues { split_n, kappa }
    }

    /// Offsets p1, p2 (m) for a bias and gains (mean of M1's equation).
    pub(super) fn offsets(&self, bias: f64, g1: f64, g2: f64) -> (f64, f64) {
        let q = bias / self.rig.k2;
        let [m1, m2, dy1, dy2, m0] = self.d.means;
        let (m1, m2) = (m1 / g1, m2 / g2);
        let p1 = m1 - m0 + (self.rig.k2 * (m1 - m2 - q) + dy1 / g1 - dy2 / g2) / self.rig.k1;
        (p1, p1 - q)
    }

    /// The model and offsets of θ (None: outside what can be simulated).
    pub(super) fn ctx(&self, th: &[f64]) -> Option<Ctx> {
        self.evals.set(self.evals.get() + 1);
        if th.iter().any(|v| !v.is_finite()) {
            return None;
        }
        let d = self.d;
        let rig = &self.rig;
        let (law, bias, g1, g2) = self.unpack(th);
        if !(g1 > 0.5 && g1 < 2.0 && g2 > 0.5 && g2 < 2.0) {
            return None;
        }
        let fs = d.a * rig.k2;
        let ss = rig.k2 / rig.omega;
        let rd = law.rd_n / fs;
        // A log the segmentation calls never-sticking is still fitted with
        // a free static threshold in the static-dynamic family: the
        // simulator says where sticks happen.
        let rs = if self.never_sticks && !self.kind.family().has_threshold() {
            rd
        } else {
            law.rs_n / fs
        };
        if rd < 0.0 {
            return None;
        }
        // Rd > Rs is outside the family: simulated at Rd = Rs, penalised.
        let excess = (rd - rs).max(0.0);
        let (rho_s, rho_d, slope) = (rs.max(rd), rd.min(rs.max(rd)), law.slope_n_s_per_m / ss);
        if law.vs_m_per_s.is_some_and(|vs| vs.is_nan() || vs <= 0.0) {
            return None;
        }
        let v_s = law.vs_m_per_s.map(|vs| vs / (d.a * rig.omega));
        let ev = self.ext_values(th);
        // A contact whose largest pre-sliding deflection Rs/kt is below
        // 1 % of x2's noise is rigid to the data; on a shaped law (the
        // numerical engine, whose steps follow the contact's ringing) it
        // is refused: a minimisation that wandered to κ 1e8 took two
        // minutes of a 20-s log's fit (docs/real-pads.md).
        if let (Some(kappa), Some(_)) = (ev.kappa, law.vs_m_per_s) {
            if law.rs_n.max(law.rd_n) / (kappa * rig.k2) < RIGID_CONTACT_NOISE * d.sig.1 {
                return None;
            }
        }
        // The split: Rs± = Rs ± Δ/2 (a threshold below Rd is simulated at
        // Rd and penalised, as Rd > Rs is).
        let half = 0.5 * ev.split_n / fs;
        let (rs_p, rs_m) = if self.ext.split {
            (rho_s + half, rho_s - half)
        } else {
            (rho_s, rho_s)
        };
        let excess = excess + (rho_d - rs_p).max(0.0) + (rho_d - rs_m).max(0.0);
        let (rs_p, rs_m) = (rs_p.max(rho_d), rs_m.max(rho_d));
        let mut law = self.kind.family().law(rs_p, rho_d, slope, v_s)?;
        if self.ext.split {
            law = law.with_minus(Some(crate::model::Levels { rho_s: rs_m, rho_d }));
        }
        let model = Model {
            absorber: rig.absorber,
            law,
            stop_below: None,
            contact_stiffness: ev.kappa,
        };
        // (Refuses a κ outside (0, MAX_CONTACT_STIFFNESS] too.)
        model.validate().ok()?;
        // The exact engine where the law is linear in each phase; the
        // numerical engine (same event logic) for a shaped law.
        // Both set up once per parameter vector; each segment only sets
        // the drive's phase.
        let eta = 2.0 * PI * d.freq / rig.omega;
        let engine = match d.drive {
            DriveModel::Harmonic => {
                let drive = Drive::Harmonic {
                    eta,
                    phase: 0.0,
                    amplitude: 1.0,
                };
                Some(Engine::new(&model, drive, NUMERIC).ok()?)
            }
            DriveModel::Sampled => None,
        };
        let (p1, p2) = self.offsets(bias, g1, g2);
        Some(Ctx {
            engine,
            model,
            thr: (rs_p, rs_m),
            g: (g1, g2),
            off: (p1, p2),
            excess,
        })
    }

    /// The measured start of segment `k` plus `dx` (see
    /// [`Segments::init`]).
    pub(super) fn init(&self, cx: &Ctx, k: usize, dx: [f64; 4]) -> Init {
        self.segments().init(cx, k, dx)
    }

    /// The segment simulator of this problem (shared by threads).
    pub(super) fn segments(&self) -> Segments<'_> {
        Segments {
            d: self.d,
            rig: self.rig,
        }
    }

    /// Books what a segment's simulation recorded besides its residuals.
    fn note(&self, o: &SegOut) {
        if let (Some(v), Some(i)) = (self.idx.borrow_mut().as_mut(), o.idx.as_ref()) {
            v.extend_from_slice(i);
        }
        let c = self.sticks.get();
        self.sticks.set((c.0 + o.sticks.0, c.1 + o.sticks.1));
        self.dirs.set(self.dirs.get().merge(o.dirs));
    }

    /// The projection of the start-state errors at θ: per segment, the
    /// residual change per unit change of each free start component, around
    /// the measured start plus `dx` (the current start corrections; none:
    /// the measured start). Also estimates the next start correction (the
    /// linearised least-squares start of each segment).
    pub(super) fn projection(&self, th: &[f64], dx: Option<&[[f64; 4]]>) -> Option<Proj> {
        let cx = self.ctx(th)?;
        let seg = self.segments();
        let d = self.d;
        // Segment by segment in parallel (independent; collected in order).
        // The stick counts of these runs are not booked: nothing reads
        // them (they are reset before the evaluations that report them).
        let contact = self.ext.contact;
        let one = |k: usize| -> Option<SegProj> {
            let mut base = Vec::new();
            let mut pert = Vec::new();
            let x0 = dx.map_or([0.0; 4], |d| d[k]);
            seg.run(&cx, k, seg.init(&cx, k, x0), &mut base, false)
                .ok
                .then_some(())?;
            let mut cols: Vec<Vec<f64>> = Vec::new();
            let mut dirs: Vec<usize> = Vec::new();
            for &e in free(d, k, contact) {
                let x = [0, 1, 2, 3].map(|j| x0[j] + e[j]);
                seg.run(&cx, k, seg.init(&cx, k, x), &mut pert, false)
                    .ok
                    .then_some(())?;
                if pert.len() != base.len() {
                    return None;
                }
                let col: Vec<f64> = pert.iter().zip(&base).map(|(p, b)| (p - b) / DX).collect();
                // A component that changes nothing is not free.
                if col.iter().any(|x| *x != 0.0) {
                    cols.push(col);
                    dirs.push(e.iter().position(|v| *v != 0.0).expect("unit"));
                }
            }
            let m = cols.len();
            let gram: Vec<Vec<f64>> = (0..m)
                .map(|a| (0..m).map(|b| dot(&cols[a], &cols[b])).collect())
                .collect();
            let inv = (0..m)
                .map(|j| {
                    let mut e = vec![0.0; m];
                    e[j] = 1.0;
                    solve_small(&gram, &e)
                })
                .collect::<Option<Vec<_>>>();
            let Some(inv) = inv else {
                return Some(SegProj {
                    cols: Vec::new(),
                    inv: Vec::new(),
                    dx: x0,
                    next: x0,
                });
            };
            // Least-squares start change: δ = −G⁻¹ Sᵀ r (kept if small:
            // a start the data cannot place is left where it was measured).
            let b: Vec<f64> = cols.iter().map(|c| dot(c, &base)).collect();
            let mut next = x0;
            let delta: Vec<f64> = (0..m)
                .map(|a| -(0..m).map(|j| inv[a][j] * b[j]).sum::<f64>())
                .collect();
            if delta.iter().all(|d| d.abs() < MAX_START_CHANGE) {
                for (a, j) in dirs.iter().enumerate() {
                    next[*j] += delta[a];
                }
            }
            Some(SegProj {
                cols,
                inv,
                dx: x0,
                next,
            })
        };
        let segs = (0..self.d.segs.len())
            .into_par_iter()
            .map(one)
            .collect::<Option<Vec<SegProj>>>()?;
        Some(Proj { segs })
    }

    /// Simulates every segment; returns the sum of squared weighted
    /// residuals, with the start-velocity directions of `proj` projected
    /// out (penalised where the law's Rd exceeds its Rs, see
    /// [`PENALTY`]), and writes the (projected) residuals to `out` if
    /// given. None: θ cannot be simulated.
    pub(super) fn eval(
        &self,
        th: &[f64],
        proj: Option<&Proj>,
        out: Option<&mut Res>,
    ) -> Option<f64> {
        let (sum, n, p) = self.residual_sum(th, proj, out)?;
        Some(sum * (1.0 + p) + p * n as f64)
    }

    /// The residual vector whose squared norm is [`Problem::eval`]'s cost
    /// exactly (x1, x2 residuals scaled by √(1 + P), then √(P·n) for the
    /// penalty P), with that cost: what a least-squares minimiser works on.
    pub(super) fn residual_vector(&self, th: &[f64], proj: &Proj) -> Option<(f64, Vec<f64>)> {
        let mut r = Res::new();
        let (sum, n, p) = self.residual_sum(th, Some(proj), Some(&mut r))?;
        let sf = (1.0 + p).sqrt();
        let mut v = Vec::with_capacity(2 * r.len() + 1);
        for x in &r {
            v.push(x.1 * sf);
            v.push(x.2 * sf);
        }
        v.push((p * n as f64).sqrt());
        Some((sum * (1.0 + p) + p * n as f64, v))
    }

    /// [`Problem::eval`]'s parts: the sum of squared residuals, their
    /// number of sample pairs and the penalty factor P = [`PENALTY`]·excess.
    fn residual_sum(
        &self,
        th: &[f64],
        proj: Option<&Proj>,
        mut out: Option<&mut Res>,
    ) -> Option<(f64, usize, f64)> {
        let cx = self.ctx(th)?;
        let seg = self.segments();
        let want_idx = self.idx.borrow().is_some();
        let n_seg = self.d.segs.len();
        let inits: Vec<Init> = (0..n_seg)
            .map(|k| self.init(&cx, k, proj.map_or([0.0; 4], |p| p.segs[k].dx)))
            .collect();
        // The segments are independent: simulated in parallel, then
        // booked in order (every sum as a sequential pass makes it, so
        // the cost does not depend on the thread count), up to the first
        // that fails.
        let runs: Vec<(Vec<f64>, SegOut, bool)> = (0..n_seg)
            .into_par_iter()
            .map(|k| {
                let mut buf = Vec::new();
                let mut o = seg.run(&cx, k, inits[k], &mut buf, want_idx);
                // The delay columns (x1's and x2's, over the interleaved
                // residuals) are projected like the residuals, so that the
                // delays profiled afterwards are the joint least-squares
                // ones (Frisch–Waugh).
                let mut vcols: Vec<Vec<f64>> = if o.vel.len() == buf.len() && !buf.is_empty() {
                    (0..2)
                        .map(|c| {
                            o.vel
                                .iter()
                                .enumerate()
                                .map(|(j, v)| if j % 2 == c { *v } else { 0.0 })
                                .collect()
                        })
                        .collect()
                } else {
                    Vec::new()
                };
                let mut fits = true;
                if let (true, Some(p)) = (o.ok, proj) {
                    let SegProj { cols, inv, .. } = &p.segs[k];
                    if !cols.is_empty() {
                        if cols[0].len() != buf.len() {
                            fits = false;
                        } else {
                            for x in std::iter::once(&mut buf).chain(vcols.iter_mut()) {
                                let b: Vec<f64> = cols.iter().map(|c| dot(c, x)).collect();
                                for (a, ca) in cols.iter().enumerate() {
                                    let coef: f64 = (0..b.len()).map(|j| inv[a][j] * b[j]).sum();
                                    for (r, c) in x.iter_mut().zip(ca) {
                                        *r -= coef * c;
                                    }
                                }
                            }
                        }
                    }
                }
                o.vel = vcols.concat();
                (buf, o, fits)
            })
            .collect();
        let mut runs = runs;
        if self.d.delays {
            self.delays.set(profile_delays(&mut runs));
        }
        let mut sum = 0.0;
        let mut n = 0usize;
        if let Some(o) = out.as_deref_mut() {
            // Sized once (grown by doubling it would hold up to twice the
            // residuals: the largest array of a long log's intervals).
            o.reserve_exact(runs.iter().map(|(buf, _, _)| buf.len() / 2).sum());
        }
        for (k, (buf, o, fits)) in runs.iter().enumerate() {
            self.note(o);
            if !o.ok || !fits {
                return None;
            }
            sum += buf.iter().map(|r| r * r).sum::<f64>();
            n += buf.len() / 2;
            if let Some(o) = out.as_deref_mut() {
                o.extend(buf.chunks(2).map(|c| (k as u32, c[0], c[1])));
            }
        }
        Some((sum, n, PENALTY * cx.excess))
    }
}

/// The lags (s) of the x1 and x2 records behind the drive's time base
/// that fit the residuals best, by least squares on their linearisation
/// r(δ) = r(0) − δ·ẋ/σ (x1's column and x2's, each projected like the
/// residuals) (good while δ·ω stays small: at 2 ms and 2 Hz the
/// second-order term is below a micrometre), removed from the residuals.
/// Sensor filters and DAQ channels delay position records by fractions
/// of a millisecond to milliseconds; at the absorber's sliding speeds a
/// lag of 0.4 ms alone leaves residuals several times the noise.
/// Segments that did not run or fit are left out (the cost fails on
/// them anyway); sums in segment order, so the result does not depend on
/// the thread count.
fn profile_delays(runs: &mut [(Vec<f64>, SegOut, bool)]) -> DelayFit {
    // Normal equations of r ≈ Σc dc·Vc over the usable segments (Vc the
    // projected delay columns, stored one after the other in `vel`).
    let usable =
        |buf: &Vec<f64>, o: &SegOut, fits: bool| o.ok && fits && o.vel.len() == 2 * buf.len();
    let mut g = [[0.0f64; 2]; 2];
    let mut b = [0.0f64; 2];
    for (buf, o, fits) in runs.iter() {
        if !usable(buf, o, *fits) {
            continue;
        }
        let (v1, v2) = o.vel.split_at(buf.len());
        for ((r, a), c) in buf.iter().zip(v1).zip(v2) {
            g[0][0] += a * a;
            g[0][1] += a * c;
            g[1][1] += c * c;
            b[0] += r * a;
            b[1] += r * c;
        }
    }
    let det = g[0][0] * g[1][1] - g[0][1] * g[0][1];
    // Singular or undefined (NaN) normal equations: no lags.
    if det.is_nan() || det <= 1e-12 * g[0][0] * g[1][1] {
        return DelayFit::default();
    }
    let d = [
        (b[0] * g[1][1] - b[1] * g[0][1]) / det,
        (b[1] * g[0][0] - b[0] * g[0][1]) / det,
    ];
    // Residual mean squares per channel after the lags (noise units).
    let mut rss = [0.0f64; 2];
    let mut cnt = [0usize; 2];
    for (buf, o, fits) in runs.iter_mut() {
        if o.vel.len() != 2 * buf.len() {
            continue;
        }
        let ok = o.ok && *fits;
        let (v1, v2) = o.vel.split_at(buf.len());
        for (k, ((r, a), c)) in buf.iter_mut().zip(v1).zip(v2).enumerate() {
            *r -= d[0] * a + d[1] * c;
            if ok && (*a != 0.0 || *c != 0.0) {
                rss[k % 2] += *r * *r;
                cnt[k % 2] += 1;
            }
        }
    }
    let ms = |c: usize| {
        if cnt[c] > 0 {
            rss[c] / cnt[c] as f64
        } else {
            f64::NAN
        }
    };
    // r ≈ −lag·ẋ/σ: the lags are the coefficients' negatives.
    DelayFit {
        lag_s: (-d[0], -d[1]),
        var_s2: (g[1][1] / det * ms(0), g[0][0] / det * ms(1)),
    }
}

/// The lags of x1 and x2 behind the drive fitted at one evaluation.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct DelayFit {
    /// The lags (s).
    pub(super) lag_s: (f64, f64),
    /// Their least-squares variances (s²) for independent residuals; the
    /// residuals' correlation time multiplies them.
    pub(super) var_s2: (f64, f64),
}

/// Weight of the penalty on a law whose Rd exceeds its Rs (by the
/// excess ρd − ρs of `Ctx`, dimensionless): the cost is Σr²·(1 + P) + P·n
/// with P = PENALTY·excess.
pub(super) const PENALTY: f64 = 1e3;

/// A contact spring is rigid to the data where its largest pre-sliding
/// deflection is below this fraction of x2's noise (refused on shaped
/// laws, [`Problem::ctx`]).
const RIGID_CONTACT_NOISE: f64 = 0.01;

/// Change of a start component (dimensionless) for the projection's
/// finite differences: small against the motion (ζ, ζ' ~ 1), large
/// against rounding.
pub(super) const DX: f64 = 1e-3;

pub(super) fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// Where a start-state projection was computed: θ and the start
/// corrections. [`Problem::projection`] at these gives it again, bit for
/// bit; a refined family keeps this, and the projection itself only where
/// it is small (`OeOptions::keep_projection_values`: its columns are the
/// size of the residuals for each free start component, and with every
/// family's held at once they were the largest arrays of a long log's
/// fit).
#[derive(Clone)]
pub(super) struct ProjAt {
    pub(super) th: Vec<f64>,
    pub(super) dx: Vec<[f64; 4]>,
    pub(super) kept: Option<std::sync::Arc<Proj>>,
}

/// One refined family: θ̂, its cost, the Nelder–Mead iterations, where
/// the start-state projection the cost refers to was computed, and its
/// start θ.
pub(super) struct Refined {
    pub(super) kind: LawKind,
    pub(super) ext: Ext,
    pub(super) th: Vec<f64>,
    pub(super) cost: f64,
    pub(super) iterations: u64,
    pub(super) proj_at: ProjAt,
    pub(super) start: Vec<f64>,
}

impl Refined {
    /// The family and its extensions.
    pub(super) fn fam(&self) -> Fam {
        Fam {
            kind: self.kind,
            ext: self.ext,
        }
    }
}

/// The model and offsets of one parameter vector.
pub(super) struct Ctx {
    /// The engine of a harmonic drive (drive phase 0; exact for a linear
    /// law, numerical for a shaped one); `None` for a sampled drive.
    pub(super) engine: Option<Engine>,
    pub(super) model: Model,
    /// Static thresholds used towards + and towards − (dimensionless).
    pub(super) thr: (f64, f64),
    pub(super) g: (f64, f64),
    pub(super) off: (f64, f64),
    /// Amount by which ρd exceeds ρs (penalised).
    pub(super) excess: f64,
}

/// Tolerances of the numerical engine (sampled drives, Stribeck laws):
/// 1e-8 relative against sensor noise of about 1e-3 of the stroke.
pub(super) const NUMERIC: NumericOptions = NumericOptions {
    rtol: 1e-8,
    atol: 1e-10,
};

/// Samples a simulated stick must last for its breakaway to count as
/// measuring that direction's threshold ([`DirStats`]).
pub(super) const MIN_STICK_SAMPLES: f64 = 3.0;

/// Largest start change (dimensionless) accepted from the data.
pub(super) const MAX_START_CHANGE: f64 = 0.05;

/// One segment's free start directions.
pub(super) struct SegProj {
    /// Residual change per unit change of each free start component
    /// (columns over the segment's interleaved residuals).
    pub(super) cols: Vec<Vec<f64>>,
    /// Inverse of their Gram matrix.
    pub(super) inv: Vec<Vec<f64>>,
    /// The start correction the columns were computed at.
    pub(super) dx: [f64; 4],
    /// The least-squares start correction there.
    pub(super) next: [f64; 4],
}

/// The start-state projection of every segment.
pub(super) struct Proj {
    pub(super) segs: Vec<SegProj>,
}

impl Proj {
    /// The number of column values it holds.
    pub(super) fn values(&self) -> usize {
        self.segs
            .iter()
            .map(|s| s.cols.iter().map(Vec::len).sum::<usize>())
            .sum()
    }
    /// The least-squares start corrections.
    pub(super) fn corrected(&self) -> Vec<[f64; 4]> {
        self.segs.iter().map(|s| s.next).collect()
    }
    /// The start corrections the projection was computed at.
    pub(super) fn current(&self) -> Vec<[f64; 4]> {
        self.segs.iter().map(|s| s.dx).collect()
    }
}

/// Free start directions of segment `k`: ζ1 and ζ1' always, ζ2 and ζ2'
/// for a slip start (a stick start has ζ2' = 0 exactly and ζ2 from the
/// mean over the stick).
fn free(d: &Data, k: usize, contact: bool) -> &'static [[f64; 4]] {
    if d.anchors[d.segs[k].0].x2_stick.is_some() && !contact {
        &[
            [DX, 0.0, 0.0, 0.0],
            [0.0, DX, 0.0, 0.0],
            [0.0, 0.0, DX, 0.0],
        ]
    } else {
        &[
            [DX, 0.0, 0.0, 0.0],
            [0.0, DX, 0.0, 0.0],
            [0.0, 0.0, DX, 0.0],
            [0.0, 0.0, 0.0, DX],
        ]
    }
}

/// The segment simulator of a [`Problem`]: what a simulation of one
/// segment needs (no interior mutability, so threads can share it).
#[derive(Clone, Copy)]
pub(super) struct Segments<'a> {
    d: &'a Data,
    rig: Rig,
}

/// What a simulated law did in each direction: breakaways towards plus
/// and towards minus, and the smallest |F| at a reversal without stick
/// towards each (it bounds that direction's threshold from above: M2 did
/// not stick there, so |F| exceeded it). Dimensionless.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct DirStats {
    pub(super) breakaways: [usize; 2],
    pub(super) reversal_force: [f64; 2],
}

impl Default for DirStats {
    fn default() -> Self {
        DirStats {
            breakaways: [0, 0],
            reversal_force: [f64::INFINITY; 2],
        }
    }
}

impl DirStats {
    /// Both together.
    pub(super) fn merge(self, o: DirStats) -> DirStats {
        DirStats {
            breakaways: [
                self.breakaways[0] + o.breakaways[0],
                self.breakaways[1] + o.breakaways[1],
            ],
            reversal_force: [
                self.reversal_force[0].min(o.reversal_force[0]),
                self.reversal_force[1].min(o.reversal_force[1]),
            ],
        }
    }
}

/// One segment's simulation besides its residuals.
pub(super) struct SegOut {
    /// Per-direction breakaways and reversal forces.
    dirs: DirStats,
    /// It ran to the segment's end.
    ok: bool,
    /// Compared samples at which the simulated M2 sticks, and stick runs.
    sticks: (usize, usize),
    /// Compared sample indices and the simulated ẍ2 there, if recorded.
    idx: Option<Vec<(usize, f64)>>,
    /// The simulated velocities over the noise, (ẋ1/σ1, ẋ2/σ2) interleaved
    /// per compared sample (1/s), when [`Data::delays`] is set: a residual
    /// changes by −δ·ẋ/σ when its channel lags by δ.
    vel: Vec<f64>,
}

impl Segments<'_> {
    /// The measured start of segment `k` plus `dx` (added to ζ1, ζ1', ζ2,
    /// ζ2'; ζ2 and ζ2' of a stick start are exact and not changed).
    pub(super) fn init(&self, cx: &Ctx, k: usize, dx: [f64; 4]) -> Init {
        let d = self.d;
        let (a, w) = (d.a, self.rig.omega);
        let (g1, g2) = cx.g;
        let (p1, p2) = cx.off;
        let an = d.anchors[d.segs[k].0];
        let i = an.i;
        let z1 = (d.x1s_at(i) / g1 - p1) / a + dx[0];
        let dz1 = d.v1s_at(i) / g1 / (a * w) + dx[1];
        // A start outside the friction cone slides along F.
        let mode_of = |f: f64, zs: f64| {
            if f > cx.thr.0 {
                Mode::Slip { dir: 1.0 }
            } else if f < -cx.thr.1 {
                Mode::Slip { dir: -1.0 }
            } else {
                Mode::Stick { z2: zs }
            }
        };
        match (an.x2_stick, cx.model.contact_stiffness) {
            // Behind a contact spring M2 rides on the spring while the
            // slider sticks: ζ2 and ζ2' as measured at the anchor, and the
            // slider where the spring holds the net force quasi-statically
            // (P = κ(ζ2 − ζs) = F, M2's inertia neglected at the anchor;
            // the free start components absorb the rest).
            (Some(_), Some(kappa)) => {
                let z2 = (d.x2s_at(i) / g2 - p2) / a + dx[2];
                let dz2 = d.v2s_at(i) / g2 / (a * w) + dx[3];
                let f = z1 - z2 + self.rig.absorber.damping * (dz1 - dz2);
                Init {
                    x: [z1, dz1, z2, dz2],
                    mode: mode_of(f, z2 - f / kappa),
                }
            }
            (Some(x2), None) => {
                let z2 = (x2 / g2 - p2) / a + dx[2];
                let f = z1 - z2 + self.rig.absorber.damping * dz1;
                Init {
                    x: [z1, dz1, z2, 0.0],
                    mode: mode_of(f, z2),
                }
            }
            (None, _) => {
                let v = d.v2s_at(i) / g2 / (a * w) + dx[3];
                Init {
                    x: [z1, dz1, (d.x2s_at(i) / g2 - p2) / a + dx[2], v],
                    mode: Mode::Slip { dir: v.signum() },
                }
            }
        }
    }

    /// Simulates segment `k` from `init`; its weighted residuals (r1, r2
    /// interleaved) go to `buf` (cleared first).
    fn run(&self, cx: &Ctx, k: usize, init: Init, buf: &mut Vec<f64>, want_idx: bool) -> SegOut {
        buf.clear();
        let d = self.d;
        let w = self.rig.omega;
        let (k0, k1) = d.segs[k];
        let i = d.anchors[k0].i;
        let end = d.anchors[k1].i;
        let list = &d.compared[k];
        buf.reserve(2 * list.len());
        let mut obs = Collect {
            d,
            omega: w,
            list,
            pos: 0,
            g: cx.g,
            off: cx.off,
            buf,
            sticks: (0, 0),
            sticking: false,
            dirs: DirStats::default(),
            damping: self.rig.absorber.damping,
            stick_since: matches!(init.mode, Mode::Stick { .. }).then_some(f64::NEG_INFINITY),
            min_stick: MIN_STICK_SAMPLES * d.dt * w,
            slider: cx
                .model
                .contact_stiffness
                .map(|_| matches!(init.mode, Mode::Slip { .. })),
            idx: want_idx.then(|| Vec::with_capacity(list.len())),
            vel: if d.delays {
                Vec::with_capacity(2 * list.len())
            } else {
                Vec::new()
            },
        };
        let dur = (d.t[end] - d.t[i]) * w;
        let phase = 2.0 * PI * d.freq * d.t[i] - d.phase;
        let simulate = |obs: &mut Collect| -> Option<Status> {
            Some(match (&cx.engine, d.drive) {
                (Some(engine), _) => engine.run_at_phase(init, phase, dur, obs)?.status,
                (None, DriveModel::Harmonic) => return None,
                (None, DriveModel::Sampled) => {
                    let hi = (end + 3).min(d.x0.len());
                    let values: Vec<f64> = (i..hi).map(|k| d.x0_at(k) / d.a).collect();
                    let drive = Drive::Sampled {
                        dt: d.dt * w,
                        values,
                    };
                    let sim = NumericSim::new(&cx.model, drive, NUMERIC).ok()?;
                    sim.run(init, dur, obs).status
                }
            })
        };
        match simulate(&mut obs) {
            // Not simulated at all: nothing recorded.
            None => SegOut {
                ok: false,
                dirs: DirStats::default(),
                sticks: (0, 0),
                idx: None,
                vel: Vec::new(),
            },
            Some(status) => SegOut {
                ok: status == Status::Completed,
                dirs: obs.dirs,
                sticks: obs.sticks,
                idx: obs.idx,
                vel: obs.vel,
            },
        }
    }
}

/// Collects the residuals of one segment.
pub(super) struct Collect<'a, 'o> {
    pub(super) d: &'a Data,
    pub(super) omega: f64,
    /// The segment's compared samples ([`Data::compared`]) and the next
    /// one's position in it.
    pub(super) list: &'a [(usize, f64)],
    pub(super) pos: usize,
    pub(super) g: (f64, f64),
    pub(super) off: (f64, f64),
    pub(super) buf: &'o mut Vec<f64>,
    /// Compared samples at which the simulated M2 sticks (ζ2' = 0 exactly)
    /// and the number of stick runs among them.
    pub(super) sticks: (usize, usize),
    pub(super) sticking: bool,
    /// Per-direction breakaways and reversal forces.
    pub(super) dirs: DirStats,
    /// The absorber's D (for F at a reversal).
    pub(super) damping: f64,
    /// When the current stick began (τ), if sticking.
    pub(super) stick_since: Option<f64>,
    /// Shortest stick (τ) whose breakaway counts in [`DirStats`]: one the
    /// log's samples could show.
    pub(super) min_stick: f64,
    /// Behind a contact spring: whether the slider slides (its events
    /// tell; M2 itself moves while the slider sticks). None: rigid stick.
    pub(super) slider: Option<bool>,
    /// Indices of the compared samples and the simulated ẍ2 (m/s²) there,
    /// when recorded.
    pub(super) idx: Option<Vec<(usize, f64)>>,
    /// [`SegOut::vel`].
    pub(super) vel: Vec<f64>,
}

impl Observer for Collect<'_, '_> {
    fn next_sample(&mut self) -> Option<f64> {
        self.list.get(self.pos).map(|&(_, tau)| tau)
    }
    fn sample(&mut self, _tau: f64, x: &[f64; 4], dx: &[f64; 4]) {
        let d = self.d;
        let j = self.list[self.pos].0;
        self.buf
            .push((d.x1_at(j) / self.g.0 - self.off.0 - d.a * x[0]) / d.sig.0);
        self.buf
            .push((d.x2_at(j) / self.g.1 - self.off.1 - d.a * x[2]) / d.sig.1);
        let stuck = match self.slider {
            Some(sliding) => !sliding,
            None => x[3] == 0.0 && dx[3] == 0.0,
        };
        if stuck {
            self.sticks.0 += 1;
            if !self.sticking {
                self.sticks.1 += 1;
            }
        }
        self.sticking = stuck;
        if let Some(v) = self.idx.as_mut() {
            v.push((j, d.a * self.omega * self.omega * dx[3]));
        }
        if d.delays {
            let s = d.a * self.omega;
            self.vel.push(s * dx[0] / d.sig.0);
            self.vel.push(s * dx[2] / d.sig.1);
        }
        self.pos += 1;
    }
    fn wants_extremes(&self) -> bool {
        false
    }
    fn event(&mut self, ev: &crate::sim::Event) {
        use crate::sim::EventKind as K;
        if let Some(s) = self.slider.as_mut() {
            match ev.kind {
                K::Stick => *s = false,
                K::SlipPlus | K::SlipMinus => *s = true,
                _ => {}
            }
        }
        let x = ev.x;
        let f = x[0] - x[2] + self.damping * (x[1] - x[3]);
        let r = &mut self.dirs.reversal_force;
        // A stick too short for the samples to show is a reversal to the
        // data: its breakaway does not count as measuring the threshold.
        let seen = self
            .stick_since
            .is_some_and(|t0| ev.tau - t0 >= self.min_stick);
        match ev.kind {
            K::Stick => self.stick_since = Some(ev.tau),
            K::SlipPlus if seen => self.dirs.breakaways[0] += 1,
            K::SlipMinus if seen => self.dirs.breakaways[1] += 1,
            K::ReversePlus => r[0] = r[0].min(f),
            K::ReverseMinus => r[1] = r[1].min(-f),
            _ => {}
        }
        if matches!(ev.kind, K::SlipPlus | K::SlipMinus) {
            self.stick_since = None;
        }
    }
}

pub(super) struct Cost<'a, 'b>(pub(super) &'a Problem<'b>, pub(super) Option<&'a Proj>);

impl CostFunction for Cost<'_, '_> {
    type Param = Vec<f64>;
    type Output = f64;
    fn cost(&self, p: &Vec<f64>) -> Result<f64, argmin::core::Error> {
        // Nelder–Mead sorts by cost: an unsimulable point is just worse.
        Ok(self.0.eval(p, self.1, None).unwrap_or(1e300))
    }
}
