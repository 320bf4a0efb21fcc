//! Helpers shared by the integration tests (`mod common;` in each test file).

use std::time::Instant;

/// Nanoseconds per call of `f`: the best of `calls / 200` rounds of 200 calls (short rounds, so
/// that on a busy machine some run undisturbed).
pub fn time(calls: usize, mut f: impl FnMut(usize)) -> f64 {
    let per_round = 200;
    (0..calls / per_round)
        .map(|_| {
            let start = Instant::now();
            for k in 0..per_round {
                f(k);
            }
            start.elapsed().as_secs_f64() * 1e9 / per_round as f64
        })
        .fold(f64::INFINITY, f64::min)
}
