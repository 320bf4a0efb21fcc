//! The natural frequencies and forced response of the seed's two-mass system (eq. 41–44):
//! the roots of det(K − ω² M) = 0, and the amplitude (K − Ω² M)⁻¹ F that resonates there.
//! Shown on the documentation site's page on equilibria and modes (docs/site/modes.rst).
//!
//! Run with `cargo run --example two_mass_modes`.

use approx::assert_relative_eq;
use lagrangian::scenes::ForcedTwoMass;
use lagrangian::{Stability, linearize, modes};

fn main() {
    let (m1, m2, k1, k2) = (1.0, 2.0, 30.0, 20.0);
    let system = ForcedTwoMass::new(m1, m2, k1, k2).system(); // the free system
    let found = modes(&system, 0.0, &[0.0, 0.0]).unwrap();
    // 2ω⁴ − 120ω² + 600 = 0
    assert_relative_eq!(
        found.frequencies[0],
        (30.0 - 600.0_f64.sqrt()).sqrt(),
        max_relative = 1e-13
    );
    assert_relative_eq!(
        found.frequencies[1],
        (30.0 + 600.0_f64.sqrt()).sqrt(),
        max_relative = 1e-13
    );
    assert_eq!(found.stability, Stability::Stable);
    // The forced response to F cos Ωt, F = (1, 0): amplitude (K − Ω² M)⁻¹ F, near and far from
    // resonance.
    let lin = linearize(&system, 0.0, &[0.0, 0.0], &[0.0, 0.0]).unwrap();
    let amplitude = |w: f64| {
        let f = nalgebra::DVector::from_vec(vec![1.0, 0.0]);
        (&lin.k - &lin.m * (w * w)).lu().solve(&f).unwrap().norm()
    };
    assert!(amplitude(found.frequencies[0] * 1.001) > 100.0 * amplitude(0.0));
    println!(
        "ω = {:.12}, {:.12} rad/s",
        found.frequencies[0], found.frequencies[1]
    );
}
