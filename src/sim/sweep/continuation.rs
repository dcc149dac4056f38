//! Continuation: one frequency-response curve, marched η by η with the
//! section state carried over; its η grid and the coexistence test.

use super::*;
use crate::model::Model;
use crate::sim::engine::Init;
use crate::sim::SimError;

/// One frequency-response curve: the model at each η in order of the
/// direction (`etas` ascending; `Down` runs them descending but returns them
/// ascending).
pub fn curve(
    model: &Model,
    etas: &[f64],
    direction: Direction,
    cfg: &SteadyConfig,
) -> Result<Vec<Point>, SimError> {
    let mut order: Vec<usize> = (0..etas.len()).collect();
    if direction == Direction::Down {
        order.reverse();
    }
    let mut out: Vec<Option<Point>> = vec![None; etas.len()];
    let mut state = Init::rest();
    let mut engine = None;
    for i in order {
        let start = if direction == Direction::Rest {
            Init::rest()
        } else {
            state
        };
        let (p, next) = steady_state_with(&mut engine, model, etas[i], start, cfg)?;
        state = next;
        out[i] = Some(p);
    }
    Ok(out
        .into_iter()
        .map(|p| p.expect("every eta computed"))
        .collect())
}

/// Relative difference of an amplitude above which the steady states of
/// two branches (up, down, rest) at one η are distinct stable states.
pub const COEXISTING_REL: f64 = 1e-6;

/// Whether two *settled* points at the same η are different stable states:
/// A1/A or A2/A differ by more than [`COEXISTING_REL`] relative (1e-12
/// absolute near zero, e.g. A2 of two stuck orbits). Points that did not
/// settle (amplitudes over a window of a non-periodic response) or have no
/// amplitude (interrupted) are never called coexisting.
pub fn distinct_states(a: &Point, b: &Point) -> bool {
    let settled = |p: &Point| p.steady && p.amplitude1.is_some() && p.amplitude2.is_some();
    if !settled(a) || !settled(b) {
        return false;
    }
    let differ = |x: Option<f64>, y: Option<f64>| match (x, y) {
        (Some(x), Some(y)) => (x - y).abs() > (COEXISTING_REL * x.abs().max(y.abs())).max(1e-12),
        _ => false,
    };
    differ(a.amplitude1, b.amplitude1) || differ(a.amplitude2, b.amplitude2)
}

/// `n` equally spaced η in [lo, hi].
pub fn eta_grid(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    match n {
        0 => vec![],
        1 => vec![lo],
        _ => (0..n)
            .map(|i| lo + (hi - lo) * i as f64 / (n - 1) as f64)
            .collect(),
    }
}
