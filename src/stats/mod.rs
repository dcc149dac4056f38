//! Shared statistics, one implementation each: distribution quantiles
//! (statrs), sample medians and quantiles, the robust σ, the one seeded
//! random number generator ([`Rng`]), the one line search
//! ([`golden_section`], argmin's) and cluster-robust least squares on
//! smoothed signals ([`regress`]).

pub mod regress;
mod rng;

use argmin::core::{CostFunction, Executor};
use argmin::solver::goldensectionsearch::GoldenSectionSearch;
pub use rng::Rng;
use statrs::distribution::{ChiSquared, ContinuousCDF, Normal, StudentsT};

/// The `p`-quantile of Student's t with `dof` degrees of freedom; the
/// normal quantile where `dof` is not positive and finite (no scatter to
/// estimate: the σ is taken as known).
pub fn student_t_quantile(p: f64, dof: f64) -> f64 {
    if dof.is_finite() && dof > 0.0 {
        if let Ok(t) = StudentsT::new(0.0, 1.0, dof) {
            return t.inverse_cdf(p);
        }
    }
    normal_quantile(p)
}

/// The `p`-quantile of the χ² distribution with `dof` degrees of freedom
/// (NaN where `dof` is not positive and finite).
pub fn chi_squared_quantile(p: f64, dof: f64) -> f64 {
    match ChiSquared::new(dof) {
        Ok(c) if dof.is_finite() => c.inverse_cdf(p),
        _ => f64::NAN,
    }
}

/// The `p`-quantile of the standard normal distribution.
pub fn normal_quantile(p: f64) -> f64 {
    match Normal::new(0.0, 1.0) {
        Ok(n) => n.inverse_cdf(p),
        Err(_) => f64::NAN,
    }
}

/// Sample standard deviation (0 for fewer than two values).
pub fn sample_sd(v: &[f64]) -> f64 {
    if v.len() < 2 {
        return 0.0;
    }
    let m = v.iter().sum::<f64>() / v.len() as f64;
    (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (v.len() - 1) as f64).sqrt()
}

/// Median of the finite values (NaN if none).
pub fn median(v: &[f64]) -> f64 {
    let mut w: Vec<f64> = v.iter().copied().filter(|x| x.is_finite()).collect();
    if w.is_empty() {
        return f64::NAN;
    }
    let n = w.len();
    // Selection, not a full sort: O(n).
    let (lower, hi, _) = w.select_nth_unstable_by(n / 2, f64::total_cmp);
    let hi = *hi;
    if n % 2 == 1 {
        hi
    } else {
        let lo = lower.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        0.5 * (lo + hi)
    }
}

/// Quantile `q` ∈ [0, 1] of the finite values, linear interpolation (NaN if none).
pub fn quantile(v: &[f64], q: f64) -> f64 {
    let mut w: Vec<f64> = v.iter().copied().filter(|x| x.is_finite()).collect();
    if w.is_empty() {
        return f64::NAN;
    }
    w.sort_by(f64::total_cmp);
    quantile_sorted(&w, q)
}

/// Quantile `q` ∈ [0, 1] of values already sorted ascending (non-empty),
/// linear interpolation between order statistics.
pub fn quantile_sorted(sorted: &[f64], q: f64) -> f64 {
    let pos = q.clamp(0.0, 1.0) * (sorted.len() - 1) as f64;
    let i = pos.floor() as usize;
    let f = pos - i as f64;
    if i + 1 < sorted.len() {
        sorted[i] * (1.0 - f) + sorted[i + 1] * f
    } else {
        sorted[i]
    }
}

/// Quantile `q` ∈ [0, 1] of N values sorted ascending (non-empty) at the
/// plotting position q·(N + 1) (Hyndman–Fan type 6), linear between order
/// statistics and clamped to the sample's ends. For a continuous
/// distribution E[F(X₍ₖ₎)] = k/(N + 1), so the estimate's expected
/// probability content is q wherever 1 ≤ q·(N + 1) ≤ N: a [2.5 %, 97.5 %]
/// range of N ≥ 39 values holds 95 % on average. [`quantile_sorted`]
/// (type 7, position q·(N − 1) + 1) is biased towards the median at the
/// tails: from 41 values its 2.5 % point is X₍₂₎, which holds 4.8 %.
pub fn quantile_unbiased_sorted(sorted: &[f64], q: f64) -> f64 {
    let n = sorted.len();
    let pos = (q.clamp(0.0, 1.0) * (n + 1) as f64 - 1.0).clamp(0.0, (n - 1) as f64);
    let i = pos.floor() as usize;
    let f = pos - i as f64;
    if i + 1 < n {
        sorted[i] * (1.0 - f) + sorted[i + 1] * f
    } else {
        sorted[i]
    }
}

/// Robust standard deviation: 1.4826 × median absolute deviation.
pub fn mad_sigma(v: &[f64]) -> f64 {
    let m = median(v);
    let d: Vec<f64> = v.iter().map(|x| (x - m).abs()).collect();
    1.4826 * median(&d)
}

/// Golden-section minimisation of a unimodal `f` on `[a, b]` (argmin's
/// `GoldenSectionSearch`, started at the midpoint): at most `iters`
/// iterations (one evaluation each), fewer once the bracket is at rounding
/// level (relative 1e-14). Returns the best point evaluated; the midpoint
/// where the bracket is empty or not finite, or no cost was finite.
pub fn golden_section(a: f64, b: f64, iters: u64, f: impl Fn(f64) -> f64) -> f64 {
    struct Cost<F>(F);
    impl<F: Fn(f64) -> f64> CostFunction for Cost<F> {
        type Param = f64;
        type Output = f64;
        fn cost(&self, x: &f64) -> Result<f64, argmin::core::Error> {
            Ok((self.0)(*x))
        }
    }
    let mid = 0.5 * (a + b);
    if !(a.is_finite() && b.is_finite() && a < b) {
        return mid;
    }
    let Ok(solver) = GoldenSectionSearch::new(a, b).and_then(|s| s.with_tolerance(1e-14)) else {
        return mid;
    };
    Executor::new(Cost(f), solver)
        .configure(|s| s.param(mid).max_iters(iters))
        .run()
        .ok()
        .and_then(|r| r.state.best_param)
        .unwrap_or(mid)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// χ² quantiles against tabulated values: 95 % with 1 and 3 degrees
    /// of freedom (3.8415, 7.8147); the 3σ point with one is 3² = 9.
    #[test]
    fn chi_squared_quantiles() {
        assert!((chi_squared_quantile(0.95, 1.0) - 3.841_459).abs() < 1e-5);
        assert!((chi_squared_quantile(0.95, 3.0) - 7.814_728).abs() < 1e-5);
        let p3 = 1.0 - 2.0 * (1.0 - 0.998_650_1);
        assert!((chi_squared_quantile(p3, 1.0) - 9.0).abs() < 1e-3);
        assert!(chi_squared_quantile(0.9, 0.0).is_nan());
    }

    /// The type-6 tails hold their nominal probability on average; type 7
    /// (linear between X₍₁₎ and X₍N₎) does not. Uniform samples of 41
    /// values (40 draws and a central value): the mean of F at the 2.5 %
    /// point is 1.05/42 = 0.025 (type 7: X₍₂₎, 2/42 = 0.048).
    #[test]
    fn unbiased_tail_quantiles() {
        let mut rng = Rng::new(11);
        let (mut m6, mut m7) = (0.0, 0.0);
        let reps = 20_000;
        for _ in 0..reps {
            let mut v: Vec<f64> = (0..41).map(|_| rng.uniform()).collect();
            v.sort_by(f64::total_cmp);
            m6 += quantile_unbiased_sorted(&v, 0.025);
            m7 += quantile_sorted(&v, 0.025);
        }
        let (m6, m7) = (m6 / reps as f64, m7 / reps as f64);
        // Standard error of the mean: about 0.033/√20000 = 2.3e-4.
        assert!((m6 - 1.05 / 42.0).abs() < 1e-3, "type 6: {m6}");
        assert!((m7 - 2.0 / 42.0).abs() < 1e-3, "type 7: {m7}");
        // Both ends, and the clamp below 1/(N + 1).
        let v = [1.0, 2.0, 3.0];
        assert_eq!(quantile_unbiased_sorted(&v, 0.5), 2.0);
        assert_eq!(quantile_unbiased_sorted(&v, 0.1), 1.0);
        assert_eq!(quantile_unbiased_sorted(&v, 0.95), 3.0);
    }

    /// Against 12-digit values from the regularized incomplete beta
    /// function at 30 digits (mpmath: the upper tail
    /// I(ν/(ν+t²); ν/2, 1/2)/2 solved for t); dof 1 is also the closed form
    /// tan(π(p − ½)).
    #[test]
    fn quantiles_match_reference_values() {
        for (p, dof, q) in [
            (0.975, 1.0, 12.706_204_736_2),
            (0.975, 2.0, 4.302_652_729_75),
            (0.975, 10.0, 2.228_138_851_99),
            (0.975, 30.0, 2.042_272_456_3),
            (0.975, 31.0, 2.039_513_446_4),
            (0.975, 1000.0, 1.962_339_080_83),
            (0.998_65, 1.0, 235.783_687_158),
            (0.998_65, 10.0, 3.956_889_989_51),
        ] {
            let got = student_t_quantile(p, dof);
            assert!(
                (got / q - 1.0).abs() < 1e-8,
                "t({p}; {dof}) = {got}, not {q}"
            );
        }
        assert!((normal_quantile(0.975) - 1.959_963_985).abs() < 1e-8);
        assert_eq!(student_t_quantile(0.975, 0.0), normal_quantile(0.975));
    }

    #[test]
    fn golden_section_finds_the_minimum_to_rounding() {
        let x = golden_section(0.0, 3.0, 200, |x| (x - 1.234_567).powi(2) + 2.0);
        assert!((x - 1.234_567).abs() < 1e-7, "{x}");
        // A minimum at the bracket's edge.
        let x = golden_section(0.0, 1.0, 200, |x| x);
        assert!(x < 1e-7, "{x}");
        // Empty bracket: its midpoint, f never called.
        assert_eq!(golden_section(2.0, 2.0, 10, |_| unreachable!()), 2.0);
    }
}
