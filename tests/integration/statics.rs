//! Statics by virtual work (seed §3.1–3.2): the five examples against the seed's closed forms,
//! the stability of their equilibria (by K where M is singular, by the linearization where it is
//! not), and the solver's failures as typed errors.

use crate::common::UnitMass;
use approx::assert_relative_eq;
use lagrangian::scenes::{
    DifferentialPulley, Lever, RhombusLink, SimplePendulum, SpringRhombus, TwoSprings,
};
use lagrangian::{
    Dynamics, Error, Potential, Scalar, Stability, StaticsOptions, System, equilibrium,
    static_stiffness,
};
use std::f64::consts::PI;

fn opts() -> StaticsOptions {
    StaticsOptions::default()
}

/// Angles in (0, π/2) for checking that Q″ from eq. 39 is the seed's δ*W/δθ.
const ANGLES: [f64; 5] = [0.05, 0.4, 0.785, 1.1, 1.5];

#[test]
fn lever_closed_form() {
    for (l1, l2, p, q) in [
        (1.0, 1.0, 1.0, 1.0),
        (0.3, 1.2, 50.0, 3.0),
        (2.0, 0.5, 0.1, 40.0),
        (1.7, 0.9, 12.5, 7.25),
    ] {
        let lever = Lever::new(l1, l2, p, q);
        let eq = equilibrium(&lever.particles(), 0.0, &[0.3], &opts()).unwrap();
        let theta = lever.closed_form_angle();
        assert_relative_eq!(eq.q[0], theta, epsilon = 1e-14);
        assert_relative_eq!((p * l1) / (q * l2), eq.q[0].tan(), max_relative = 1e-12);
        assert_eq!(eq.stability, Stability::Stable);
        // K = −d/dθ (P l₁ cos θ − Q l₂ sin θ) = P l₁ sin θ + Q l₂ cos θ
        let k = p * l1 * theta.sin() + q * l2 * theta.cos();
        assert_relative_eq!(eq.eigenvalues[0], k, max_relative = 1e-12);
        assert!(eq.iterations <= 12, "{} iterations", eq.iterations);
    }
}

#[test]
fn lever_virtual_work_seed_expression() {
    let lever = Lever::new(1.3, 0.6, 4.0, 9.0);
    let system = lever.particles();
    for theta in ANGLES {
        let q = system.generalized_forces(0.0, &[theta], &[0.0]).unwrap();
        assert_relative_eq!(q[0], lever.virtual_work(theta), epsilon = 1e-14);
    }
}

#[test]
fn lever_massless_accelerations_fail() {
    let system = Lever::new(1.0, 1.0, 1.0, 1.0).particles();
    let e = system.accelerations(0.0, &[0.3], &[0.0]).unwrap_err();
    assert!(matches!(e, Error::SingularMassMatrix { .. }), "{e:?}");
    // Statics needs no M: K alone classifies the equilibrium, and says so.
    let eq = equilibrium(&system, 0.0, &[0.3], &opts()).unwrap();
    assert_eq!(eq.stability, Stability::Stable);
    assert!(eq.spectrum.is_none());
    assert!(eq.reason.contains("statics only"), "{}", eq.reason);
}

#[test]
fn moving_systems_classified_by_their_eigenvalues() {
    // The pendulum has mass, so the linearization decides: ±i√(g/l) at the bottom, ±√(g/l) on
    // top.
    let (m, l, g) = (1.5, 0.8, 9.81);
    let system = SimplePendulum::new(m, l, g).system();
    let w = (g / l).sqrt();
    let bottom = equilibrium(&system, 0.0, &[0.4], &opts()).unwrap();
    let spectrum = bottom.spectrum.unwrap();
    assert_relative_eq!(spectrum[1].im, w, max_relative = 1e-13);
    assert!(
        bottom.reason.contains("positive definite"),
        "{}",
        bottom.reason
    );
    let top = equilibrium(&system, 0.0, &[2.5], &opts()).unwrap();
    let spectrum = top.spectrum.unwrap();
    assert_relative_eq!(spectrum[1].re, w, max_relative = 1e-13);
    assert!(top.reason.contains("divergence"), "{}", top.reason);
}

#[test]
fn differential_pulley_balance_reading() {
    for (r1, r2, p, q, k) in [
        (0.2, 0.18, 0.0, 1000.0, 5000.0),
        (0.15, 0.05, 0.0, 300.0, 80.0),
        (0.3, 0.25, 20.0, 900.0, 2.0e4),
        (0.1, 0.09, 60.0, 500.0, 1.0e3),
    ] {
        let pulley = DifferentialPulley::new(r1, r2, p, q, k);
        let eq = equilibrium(&pulley.particles(), 0.0, &[0.0], &opts()).unwrap();
        let theta = pulley.closed_form_angle().unwrap();
        assert_relative_eq!(eq.q[0], theta, max_relative = 1e-14);
        // The spring balance supplies what the hand does not: reading + P = Q (r₁ − r₂)/(2 r₁).
        let effort = pulley.balance_reading(eq.q[0]) + p;
        assert_relative_eq!(effort, q * (r1 - r2) / (2.0 * r1), max_relative = 1e-14);
        assert_relative_eq!(effort, pulley.balancing_pull(), max_relative = 1e-12);
        assert_eq!(eq.stability, Stability::Stable);
        assert_relative_eq!(eq.eigenvalues[0], k * r1 * r1, max_relative = 1e-12);
        assert!(eq.iterations <= 3, "{} iterations", eq.iterations);
    }
}

#[test]
fn differential_pulley_virtual_work_seed_expression() {
    let pulley = DifferentialPulley::new(0.2, 0.17, 35.0, 800.0, 0.0);
    let system = pulley.particles();
    for theta in [-3.0, -0.2, 0.0, 0.7, 5.0] {
        let q = system.generalized_forces(0.0, &[theta], &[0.0]).unwrap();
        assert_relative_eq!(q[0], pulley.virtual_work(), epsilon = 1e-12);
    }
}

#[test]
fn differential_pulley_neutral_at_balancing_pull() {
    // Without the spring balance, the balancing effort holds the load at every θ. Dyadic numbers
    // make P r₁ and Q (r₁ − r₂)/2 cancel exactly; a rounding-level net load would have no root.
    let (r1, r2, q) = (0.25, 0.125, 8.0);
    let p = DifferentialPulley::new(r1, r2, 0.0, q, 0.0).balancing_pull();
    assert_eq!(p, 2.0);
    let pulley = DifferentialPulley::new(r1, r2, p, q, 0.0);
    for guess in [-1.0, 0.0, 2.5] {
        let eq = equilibrium(&pulley.particles(), 0.0, &[guess], &opts()).unwrap();
        assert_eq!(eq.q[0], guess);
        assert_eq!(eq.iterations, 0);
        assert_eq!(eq.stability, Stability::Neutral);
        assert_eq!(eq.eigenvalues[0], 0.0);
    }
}

#[test]
fn differential_pulley_unbalanced_no_convergence() {
    let pulley = DifferentialPulley::new(0.2, 0.18, 5.0, 1000.0, 0.0);
    let e = equilibrium(&pulley.particles(), 0.0, &[0.0], &opts()).unwrap_err();
    match e {
        Error::NoConvergence { residual, .. } => {
            assert_relative_eq!(residual, pulley.virtual_work().abs(), max_relative = 1e-12)
        }
        other => panic!("expected NoConvergence, got {other:?}"),
    }
}

#[test]
fn rhombus_link_closed_form() {
    for (l, p, q) in [
        (1.0, 1.0, 1.0),
        (0.5, 10.0, 2.0),
        (2.0, 3.0, 45.0),
        (1.3, 7.7, 0.4),
    ] {
        let rhombus = RhombusLink::new(l, p, q);
        let eq = equilibrium(&rhombus.particles(), 0.0, &[PI / 4.0], &opts()).unwrap();
        let theta = rhombus.closed_form_angle();
        assert_relative_eq!(eq.q[0], theta, epsilon = 1e-14);
        assert_relative_eq!(q, p * eq.q[0].tan(), max_relative = 1e-12);
        assert_eq!(eq.stability, Stability::Stable);
        // K = −d/dθ [2l(−P sin θ + Q cos θ)] = 2l(P cos θ + Q sin θ)
        let k = 2.0 * l * (p * theta.cos() + q * theta.sin());
        assert_relative_eq!(eq.eigenvalues[0], k, max_relative = 1e-12);
        assert!(eq.iterations <= 12, "{} iterations", eq.iterations);
    }
}

#[test]
fn rhombus_link_virtual_work_seed_expression() {
    let rhombus = RhombusLink::new(0.8, 3.0, 5.0);
    let system = rhombus.particles();
    for theta in ANGLES {
        let q = system.generalized_forces(0.0, &[theta], &[0.0]).unwrap();
        assert_relative_eq!(q[0], rhombus.virtual_work(theta), epsilon = 1e-14);
    }
}

/// The seed's equilibrium equation of example 4, f(θ) = Mg sin θ − 2k(L₀ − a sin θ) cos θ.
fn rhombus_balance(s: &SpringRhombus, theta: f64) -> f64 {
    s.m * s.g * theta.sin() - 2.0 * s.k * (s.l0 - s.a * theta.sin()) * theta.cos()
}

/// Bisection on f(θ) itself (not the squared quartic the scene uses), over 0 < θ < asin(L₀/a).
fn bisect_balance(s: &SpringRhombus) -> f64 {
    let (mut lo, mut hi) = (0.0_f64, (s.l0 / s.a).min(1.0).asin());
    while hi - lo > 0.0 {
        let mid = 0.5 * (lo + hi);
        if mid <= lo || mid >= hi {
            break;
        }
        if rhombus_balance(s, mid) < 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

const SPRING_RHOMBI: [(f64, f64, f64, f64); 5] = [
    // (a, k, L₀, M)
    (1.0, 100.0, 0.8, 2.0),
    (0.5, 2000.0, 0.3, 10.0),
    (0.3, 50.0, 0.5, 1.0),
    (1.2, 10.0, 1.0, 5.0),
    (0.8, 400.0, 0.2, 0.5),
];

#[test]
fn spring_rhombus_quartic_root() {
    for (a, k, l0, m) in SPRING_RHOMBI {
        let rhombus = SpringRhombus::new(a, k, l0, m, 9.81);
        let eq = equilibrium(&rhombus.particles(), 0.0, &[0.3], &opts()).unwrap();
        let theta = eq.q[0];
        assert_relative_eq!(theta, rhombus.closed_form_angle(), epsilon = 1e-14);
        assert_relative_eq!(theta, bisect_balance(&rhombus), epsilon = 1e-14);
        assert!(theta.sin() > 0.0 && theta.sin() < (l0 / a).min(1.0));
        let scale = m * 9.81 + 2.0 * k * l0;
        assert!(rhombus_balance(&rhombus, theta).abs() < 1e-13 * scale);
        assert_eq!(eq.stability, Stability::Stable);
        assert!(eq.iterations <= 15, "{} iterations", eq.iterations);
    }
}

#[test]
fn spring_rhombus_potential_seed_expression() {
    let rhombus = SpringRhombus::new(0.7, 300.0, 0.5, 3.0, 9.81);
    let system = rhombus.particles();
    for theta in ANGLES {
        let u = system.potential_energy(0.0, &[theta]);
        assert_relative_eq!(u, rhombus.closed_form_potential(theta), epsilon = 1e-12);
        // δ*W = −δU (seed §3.2 (3)).
        let mut grad = [0.0];
        system.potential_gradient_into(0.0, &[theta], &mut grad);
        assert_relative_eq!(-grad[0], rhombus.virtual_work(theta), epsilon = 1e-11);
    }
}

#[test]
fn spring_rhombus_rest_at_equilibrium() {
    // The mass at C makes this a moving system too: at rest in equilibrium, q̈ = 0.
    let rhombus = SpringRhombus::new(1.0, 100.0, 0.8, 2.0, 9.81);
    let system = rhombus.particles();
    let eq = equilibrium(&system, 0.0, &[0.3], &opts()).unwrap();
    let qdd = system.accelerations(0.0, eq.q.as_slice(), &[0.0]).unwrap();
    assert!(qdd[0].abs() < 1e-12, "q̈ = {}", qdd[0]);
}

#[test]
fn two_springs_closed_form() {
    for (k1, k2, f1, f2) in [
        (1.0, 1.0, 1.0, 1.0),
        (100.0, 250.0, 3.0, -7.0),
        (2.5e4, 30.0, 0.0, 12.0),
        (0.3, 4.0e3, -5.0, 0.0),
    ] {
        let springs = TwoSprings::new(1.0, 2.0, k1, k2, f1, f2);
        let eq = equilibrium(&springs.system(), 0.0, &[0.0, 0.0], &opts()).unwrap();
        let x = springs.closed_form_displacements();
        for i in 0..2 {
            assert_relative_eq!(eq.q[i], x[i], max_relative = 1e-14, epsilon = 1e-16);
        }
        assert_eq!(eq.stability, Stability::Stable);
        // The eigensolver is backward stable: errors are relative to the largest eigenvalue.
        let lambda = springs.closed_form_eigenvalues();
        for i in 0..2 {
            assert_relative_eq!(eq.eigenvalues[i], lambda[i], epsilon = 1e-14 * lambda[1]);
        }
        let kk = springs.stiffness_matrix();
        for i in 0..2 {
            for j in 0..2 {
                assert_relative_eq!(eq.stiffness[(i, j)], kk[i][j], max_relative = 1e-14);
            }
        }
        // Linear: one Newton step lands on the root, a second one polishes.
        assert!(eq.iterations <= 2, "{} iterations", eq.iterations);
    }
}

#[test]
fn two_springs_rest_at_equilibrium() {
    let springs = TwoSprings::new(1.5, 0.5, 40.0, 25.0, 2.0, -3.0);
    let system = springs.system();
    let x = springs.closed_form_displacements();
    let qdd = system.accelerations(0.0, &x, &[0.0, 0.0]).unwrap();
    for a in qdd.iter() {
        assert!(a.abs() < 1e-13, "q̈ = {a}");
    }
}

#[test]
fn static_stiffness_two_springs() {
    let springs = TwoSprings::new(1.0, 1.0, 7.0, 3.0, 1.0, 2.0);
    let k = static_stiffness(&springs.system(), 0.0, &[0.4, -1.0]).unwrap();
    let kk = springs.stiffness_matrix();
    for i in 0..2 {
        for j in 0..2 {
            assert_eq!(k[(i, j)], kk[i][j]);
        }
    }
}

#[test]
fn simple_pendulum_equilibria() {
    let (m, l, g) = (1.5, 0.8, 9.81);
    let system = SimplePendulum::new(m, l, g).system();
    let bottom = equilibrium(&system, 0.0, &[0.4], &opts()).unwrap();
    assert!(bottom.q[0].abs() < 1e-15, "θ = {}", bottom.q[0]);
    assert_eq!(bottom.stability, Stability::Stable);
    assert_relative_eq!(bottom.eigenvalues[0], m * g * l, max_relative = 1e-12);

    let top = equilibrium(&system, 0.0, &[2.5], &opts()).unwrap();
    assert_relative_eq!(top.q[0], PI, epsilon = 1e-15);
    assert_eq!(top.stability, Stability::Unstable);
    assert_relative_eq!(top.eigenvalues[0], -m * g * l, max_relative = 1e-12);

    // A guess on the equilibrium itself is accepted as it is.
    let exact = equilibrium(&system, 0.0, &[PI], &opts()).unwrap();
    assert_relative_eq!(exact.q[0], PI, epsilon = 1e-15);
    assert!(exact.iterations <= 1);
}

#[test]
fn max_step_limits_each_iteration() {
    let system = SimplePendulum::new(1.0, 1.0, 9.81).system();
    let limited = StaticsOptions {
        max_step: 0.1,
        ..opts()
    };
    let eq = equilibrium(&system, 0.0, &[2.0], &limited).unwrap();
    assert_relative_eq!(eq.q[0], PI, epsilon = 1e-15);
    // |π − 2| = 1.14 needs at least 12 steps of 0.1.
    assert!(eq.iterations >= 12, "{} iterations", eq.iterations);
}

/// U = q³/3 + q: ∂U/∂q = q² + 1 never vanishes.
struct NoStationaryPoint;
impl Potential for NoStationaryPoint {
    fn potential<D: Scalar>(&self, _t: D, q: &[D]) -> D {
        q[0].powi(3) * (1.0 / 3.0) + q[0]
    }
    fn depends_on_time(&self) -> bool {
        false
    }
}

/// U = q^{3/2}: not finite for q < 0.
struct RootPotential;
impl Potential for RootPotential {
    fn potential<D: Scalar>(&self, _t: D, q: &[D]) -> D {
        q[0].powf(1.5)
    }
    fn depends_on_time(&self) -> bool {
        false
    }
}

#[test]
fn no_stationary_point_no_convergence() {
    let system = System::new(1, UnitMass).with_potential(NoStationaryPoint);
    for guess in [-3.0, 0.0, 0.5, 4.0] {
        match equilibrium(&system, 0.0, &[guess], &opts()).unwrap_err() {
            Error::NoConvergence {
                iterations,
                residual,
                q,
            } => {
                assert!(iterations <= 100);
                assert!(residual >= 1.0);
                assert_eq!(q.len(), 1);
                assert!(q[0].is_finite());
            }
            other => panic!("expected NoConvergence, got {other:?}"),
        }
    }
}

#[test]
fn max_iterations_no_convergence() {
    let system = SimplePendulum::new(1.0, 1.0, 9.81).system();
    let few = StaticsOptions {
        max_iterations: 3,
        max_step: 0.1,
        ..opts()
    };
    let e = equilibrium(&system, 0.0, &[2.0], &few).unwrap_err();
    assert!(
        matches!(e, Error::NoConvergence { iterations: 3, .. }),
        "{e:?}"
    );
}

#[test]
fn bad_guess_typed_errors() {
    let system = TwoSprings::new(1.0, 1.0, 1.0, 1.0, 1.0, 1.0).system();
    let e = equilibrium(&system, 0.0, &[0.0], &opts()).unwrap_err();
    assert_eq!(
        e,
        Error::DimensionMismatch {
            what: "q",
            expected: 2,
            got: 1
        }
    );
    let e = equilibrium(&system, 0.0, &[0.0, f64::NAN], &opts()).unwrap_err();
    assert!(matches!(e, Error::NonFinite { .. }), "{e:?}");
    let e = equilibrium(&system, f64::INFINITY, &[0.0, 0.0], &opts()).unwrap_err();
    assert!(matches!(e, Error::NonFinite { .. }), "{e:?}");
    let e = static_stiffness(&system, 0.0, &[0.0, 0.0, 0.0]).unwrap_err();
    assert!(matches!(e, Error::DimensionMismatch { .. }), "{e:?}");
}

#[test]
fn bad_options_invalid_input() {
    let system = TwoSprings::new(1.0, 1.0, 1.0, 1.0, 1.0, 1.0).system();
    for bad in [
        StaticsOptions {
            rel_tolerance: -1.0,
            ..opts()
        },
        StaticsOptions {
            abs_tolerance: f64::NAN,
            ..opts()
        },
        StaticsOptions {
            step_tolerance: f64::INFINITY,
            ..opts()
        },
        StaticsOptions {
            max_step: 0.0,
            ..opts()
        },
        StaticsOptions {
            stability_tolerance: -0.1,
            ..opts()
        },
    ] {
        let e = equilibrium(&system, 0.0, &[0.0, 0.0], &bad).unwrap_err();
        assert!(matches!(e, Error::InvalidInput { .. }), "{e:?}");
    }
}

#[test]
fn non_finite_model_typed_error() {
    let system = System::new(1, UnitMass).with_potential(RootPotential);
    let e = equilibrium(&system, 0.0, &[-1.0], &opts()).unwrap_err();
    assert!(matches!(e, Error::NonFinite { .. }), "{e:?}");
}
