//! The stability limit of a fixed step (`src/integrators/step_limit.rs`), the linear stability
//! check of fixed-step explicit methods: steps beyond a method's stability limit for a mode of
//! the linearised system are refused with a typed error whose limit matches the method's known
//! stability interval; implicit methods and growing (physical) modes pass.

use approx::assert_relative_eq;
use lagrangian::integrators::{Method, Options, solve};
use lagrangian::scenes::{DampedOscillator, ElasticPendulum, SimplePendulum};
use lagrangian::{Dynamics, Error};
use std::f64::consts::PI;

/// The step limit reported by a run refused for instability (panics if the run was not refused).
fn refused_limit<S: Dynamics>(system: &S, q0: &[f64], qd0: &[f64], method: Method, dt: f64) -> f64 {
    match solve(
        system,
        q0,
        qd0,
        (0.0, 100.0 * dt),
        method,
        &Options::fixed(dt),
    ) {
        Err(Error::UnstableStep {
            limit,
            growth,
            dt: asked,
            ..
        }) => {
            assert_eq!(asked, dt);
            assert!(growth > 1.0, "growth {growth}");
            limit
        }
        other => panic!("{method} at dt = {dt}: expected UnstableStep, got {other:?}"),
    }
}

#[test]
fn verlet_limit_is_two_over_omega_oscillator() {
    // Störmer–Verlet is stable for ω dt < 2 (ω = 3 here).
    let osc = DampedOscillator::new(1.0, 9.0, 0.0).system();
    let limit = refused_limit(&osc, &[1.0], &[0.0], Method::StormerVerlet, 0.7);
    assert_relative_eq!(limit, 2.0 / 3.0, max_relative = 1e-6);
    assert!(
        solve(
            &osc,
            &[1.0],
            &[0.0],
            (0.0, 60.0),
            Method::StormerVerlet,
            &Options::fixed(0.6)
        )
        .is_ok()
    );
}

#[test]
fn rk4_limits_on_imaginary_and_real_axes_oscillator() {
    // RK4's stability region meets the imaginary axis at 2√2 and the real axis at −2.785293563…
    let undamped = DampedOscillator::new(1.0, 1.0, 0.0).system();
    let limit = refused_limit(&undamped, &[1.0], &[0.0], Method::Rk4, 3.0);
    assert_relative_eq!(limit, 2.0 * 2f64.sqrt(), max_relative = 1e-6);
    // Over-damped: roots −1 and −1000, the fast one sets the limit.
    let damped = DampedOscillator::new(1.0, 1000.0, 1001.0).system();
    let limit = refused_limit(&damped, &[1.0], &[0.0], Method::Rk4, 0.01);
    assert_relative_eq!(limit, 2.785_293_563_405_282 / 1000.0, max_relative = 1e-6);
    assert!(
        solve(
            &damped,
            &[1.0],
            &[0.0],
            (0.0, 1.0),
            Method::Rk4,
            &Options::fixed(0.0025)
        )
        .is_ok()
    );
}

#[test]
fn stiff_spring_refused_by_explicit_methods_elastic_pendulum() {
    // k = 1e9: the radial mode has ω = √(k/m) ≈ 3.2e4, far beyond dt = 1e-3 for every explicit
    // method; the implicit ones run.
    let sys = ElasticPendulum::new(1.0, 1e9, 1.0, 9.81).system();
    let (q0, qd0) = ([1.0 + 9.81 / 1e9, 0.3], [0.0, 0.0]);
    let omega = 1e9f64.sqrt();
    for method in [Method::Rk4, Method::Dopri5, Method::Dop853] {
        let limit = refused_limit(&sys, &q0, &qd0, method, 1e-3);
        assert!(
            limit * omega < 6.0 && limit * omega > 0.5,
            "{method}: ω·limit = {}",
            limit * omega
        );
    }
    // The splittings need a separable system: the same stiff spring alone.
    let spring = DampedOscillator::new(1.0, 1e9, 0.0).system();
    for method in [
        Method::StormerVerlet,
        Method::Yoshida4,
        Method::Yoshida6,
        Method::Yoshida8,
        Method::BlanesMoan4,
    ] {
        let limit = refused_limit(&spring, &[1e-3], &[0.0], method, 1e-3);
        assert!(
            limit * omega < 6.0 && limit * omega > 0.5,
            "{method}: ω·limit = {}",
            limit * omega
        );
    }
    for method in [Method::Gauss4, Method::Midpoint] {
        assert!(solve(&sys, &q0, &qd0, (0.0, 0.01), method, &Options::fixed(1e-3)).is_ok());
    }
}

#[test]
fn growing_mode_is_physics_not_instability_inverted_pendulum() {
    // Upside down, the pendulum's linearisation has λ = ±√(g/l): growth that every method must
    // follow, so no step is refused for it.
    let sys = SimplePendulum::new(1.0, 1.0, 9.81).system();
    let sol = solve(
        &sys,
        &[PI - 1e-3],
        &[0.0],
        (0.0, 1.0),
        Method::StormerVerlet,
        &Options::fixed(0.5),
    );
    assert!(sol.is_ok(), "{sol:?}");
}
