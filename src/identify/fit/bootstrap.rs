//! Statistical intervals of the chosen law by a bootstrap over drive
//! periods: the slip samples and transitions of a period are resampled
//! together, and the normal equations are accumulated per period so each
//! replicate is a small solve. The Stribeck velocity is held at its
//! estimate.

use super::bounds::Brk;
use super::select::Cand;
use super::slip::Sample;
use super::{basis, offset_at, FitOptions, StatIntervals};
use crate::identify::smooth::Normal;
use crate::stats::{median, quantile, Rng};

/// 2.5 % and 97.5 % bootstrap percentiles of Rs, Rd and a of `chosen`
/// (`opts.bootstrap` replicates, seed `opts.seed`; an interval needs 20
/// successful replicates; no Rs interval where the log never sticks).
pub(super) fn bootstrap(
    samples: &[Sample],
    brks: &[Brk],
    chosen: &Cand,
    n_periods: usize,
    opts: &FitOptions,
    never_sticks: bool,
) -> StatIntervals {
    let mut stat = StatIntervals::default();
    if opts.bootstrap == 0 {
        return stat;
    }
    let p = chosen.coef.len();
    let mut per: Vec<Normal> = (0..n_periods).map(|_| Normal::new(p)).collect();
    for (smp, wi) in samples.iter().zip(&chosen.w) {
        per[smp.period.min(n_periods - 1)].add(&basis(chosen.kind, smp, chosen.vs), smp.r, *wi);
    }
    let mut per_brk: Vec<Vec<&Brk>> = vec![Vec::new(); n_periods];
    for k in brks {
        per_brk[k.period.min(n_periods - 1)].push(k);
    }
    let used: Vec<usize> = (0..n_periods)
        .filter(|&i| per[i].n > 0 || !per_brk[i].is_empty())
        .collect();
    let mut rng = Rng::new(opts.seed);
    let (mut rs_b, mut rd_b, mut a_b) = (Vec::new(), Vec::new(), Vec::new());
    for _ in 0..opts.bootstrap {
        let mut ne = Normal::new(p);
        let mut fd: Vec<&Brk> = Vec::new();
        for _ in 0..used.len() {
            let q = used[rng.below(used.len())];
            ne.add_all(&per[q]);
            fd.extend(per_brk[q].iter().copied());
        }
        let Some(cf) = ne.solve() else { continue };
        let rd = cf[1];
        let family = chosen.kind.family();
        let breakaway = if family.rs_from_breakaways() {
            if fd.is_empty() {
                continue;
            }
            let v: Vec<f64> = fd
                .iter()
                .map(|k| k.f - k.dir * offset_at(&cf, k.k1, k.k2))
                .collect();
            median(&v)
        } else {
            f64::NAN
        };
        let rs = family.ee_rs(&cf, breakaway);
        let a = family.ee_law(&cf, rs, chosen.vs).slope_n_s_per_m;
        rs_b.push(rs);
        rd_b.push(rd);
        a_b.push(a);
    }
    let pct = |v: &[f64]| -> Option<(f64, f64)> {
        (v.len() >= 20).then(|| (quantile(v, 0.025), quantile(v, 0.975)))
    };
    stat.rd = pct(&rd_b);
    stat.slope = pct(&a_b);
    stat.rs = if never_sticks { None } else { pct(&rs_b) };
    stat
}
