//! Helpers shared by the integration tests (`crate::common` in each test module; each uses some).
#![allow(dead_code)]

use lagrangian::{KineticEnergy, Scalar};
use std::time::Instant;

/// T = ½ q̇² per coordinate: a constant unit mass matrix, to make a `System` around a test
/// potential or force.
#[derive(Debug, Clone, Copy)]
pub struct UnitMass;
impl KineticEnergy for UnitMass {
    fn kinetic<D: Scalar>(&self, _t: D, _q: &[D], qd: &[D]) -> D {
        qd.iter().fold(D::zero(), |s, &v| s + v * v) * 0.5
    }
    fn depends_on_time(&self) -> bool {
        false
    }
    fn depends_on_position(&self) -> bool {
        false
    }
    fn constant_mass_matrix(&self) -> bool {
        true
    }
}

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

/// A deterministic pseudo-random generator (SplitMix64).
pub struct Rng(pub u64);

impl Rng {
    pub fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    pub fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }
    pub fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }
}
