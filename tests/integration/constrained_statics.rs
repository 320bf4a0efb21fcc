//! Equilibria on the constraint manifold (issue 41 item 6): r(q) = Gᵀλ with g(t, q) = 0,
//! against the seed's closed forms (§3.2 examples 3 and 4) and a Cartesian pendulum.

use lagrangian::scenes::{DoublePendulum, SimplePendulum};
use lagrangian::{
    Constrained, Constraints, Error, GeneralizedForces, KineticEnergy, Potential, Scalar,
    Stability, StaticsOptions, System, constrained_equilibrium, constrained_modes, modes,
};

const G: f64 = 9.81;

/// ½ m |q̇|².
struct Mass(f64);
impl KineticEnergy for Mass {
    fn kinetic<D: Scalar>(&self, _t: D, _q: &[D], qd: &[D]) -> D {
        qd.iter()
            .fold(D::zero(), |s, &v| s + v * v * (0.5 * self.0))
    }
    fn depends_on_time(&self) -> bool {
        false
    }
}

/// x² + y² − l² = 0 (a rod, a rhombus's half-diagonals), stated `times` times over.
struct Circle {
    l: f64,
    times: usize,
}
impl Constraints for Circle {
    fn holonomic_count(&self) -> usize {
        self.times
    }
    fn holonomic<D: Scalar>(&self, _t: D, q: &[D], out: &mut [D]) {
        for (i, o) in out.iter_mut().enumerate() {
            *o = (q[0] * q[0] + q[1] * q[1] - self.l * self.l) * (i + 1) as f64;
        }
    }
    fn depends_on_time(&self) -> bool {
        false
    }
    fn name(&self, row: usize) -> String {
        format!("circle {row}")
    }
}

fn circle(l: f64) -> Circle {
    Circle { l, times: 1 }
}

/// Uniform gravity on the second coordinate: m g y.
struct Weight(f64);
impl Potential for Weight {
    fn potential<D: Scalar>(&self, _t: D, q: &[D]) -> D {
        q[1] * (self.0 * G)
    }
    fn depends_on_time(&self) -> bool {
        false
    }
}

fn tight() -> StaticsOptions {
    StaticsOptions::default()
}

/// Seed §3.2 example 3, the rhombus link, with OA = x, OB = y as coordinates under
/// x² + y² = l²: the loads do the virtual work δW = 2(P δx + Q δy), so Q″ = (2P, 2Q), and the
/// balance is Q = P tan θ, with −2P = 2xλ: λ = −P / (l cos θ) = −√(P² + Q²) / l.
#[test]
fn rhombus_link_q_equals_p_tan_theta() {
    struct Loads(f64, f64);
    impl GeneralizedForces for Loads {
        fn forces<D: Scalar>(&self, _t: D, _q: &[D], _qd: &[D], out: &mut [D]) {
            out[0] += 2.0 * self.0;
            out[1] += 2.0 * self.1;
        }
        fn depends_on_time(&self) -> bool {
            false
        }
    }
    let (l, p) = (0.7, 3.0);
    for q_load in [0.4, 3.0, 11.0] {
        let link = Constrained::new(
            System::new(2, Mass(1.0)).with_forces(Loads(p, q_load)),
            circle(l),
        );
        let e = constrained_equilibrium(&link, 0.0, &[0.5, 0.2], &tight()).unwrap();
        let theta = e.q[1].atan2(e.q[0]);
        assert!(
            (q_load - p * theta.tan()).abs() < 1e-12 * q_load.max(p),
            "Q = {q_load}, P tan θ = {}",
            p * theta.tan()
        );
        assert!((e.q[0] - l * theta.cos()).abs() < 1e-15);
        assert!(e.constraint_residuals[0].abs() < 1e-14);
        let lambda = -p / (l * theta.cos());
        assert!((e.multipliers[0] - lambda).abs() < 1e-12 * lambda.abs());
        assert!((e.multipliers[0] + (p * p + q_load * q_load).sqrt() / l).abs() < 1e-12 * p);
        // The reactions balance the loads: Gᵀλ = r = −Q″.
        assert!((e.reaction_forces[0] + 2.0 * p).abs() < 1e-12 * p);
        assert!((e.reaction_forces[1] + 2.0 * q_load).abs() < 1e-12 * p);
        assert!(e.residual < 1e-12 * p);
        assert_eq!(e.stability, Stability::Stable, "{}", e.reason);
        assert!(e.iterations <= 20);
    }
}

/// Seed §3.2 example 4, the spring rhombus: half-diagonals x = a sin θ (the spring BD = 2x),
/// y = a cos θ (AC = 2y), x² + y² = a²; U = 2k(L0 − x)² − 2Mg y. The balance is
/// Mg sin θ = 2k(L0 − a sin θ) cos θ, and −2Mg = 2yλ gives λ = −Mg / (a cos θ).
#[test]
fn spring_rhombus_closed_form() {
    struct Spring {
        k: f64,
        l0: f64,
        m: f64,
    }
    impl Potential for Spring {
        fn potential<D: Scalar>(&self, _t: D, q: &[D]) -> D {
            let stretch = -q[0] + self.l0;
            stretch * stretch * (2.0 * self.k) - q[1] * (2.0 * self.m * G)
        }
        fn depends_on_time(&self) -> bool {
            false
        }
    }
    for (a, l0, k, m) in [
        (1.0, 0.8, 50.0, 2.0),
        (0.5, 0.6, 20.0, 3.0),
        (2.0, 0.3, 400.0, 0.7),
    ] {
        let f = |th: f64| m * G * th.sin() - 2.0 * k * (l0 - a * th.sin()) * th.cos();
        let (mut lo, mut hi) = (0.0, (l0 / a).min(1.0).asin());
        assert!(f(lo) < 0.0 && f(hi) >= 0.0);
        while hi - lo > 1e-15 {
            let mid = 0.5 * (lo + hi);
            if f(mid) < 0.0 {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let theta = 0.5 * (lo + hi);
        let rhombus = Constrained::new(
            System::new(2, Mass(m)).with_potential(Spring { k, l0, m }),
            circle(a),
        );
        let guess = [0.5 * a, 0.8 * a];
        let e = constrained_equilibrium(&rhombus, 0.0, &guess, &tight()).unwrap();
        let got = e.q[0].atan2(e.q[1]);
        assert!(
            (got - theta).abs() < 1e-13,
            "θ = {got}, closed form {theta}"
        );
        let lambda = -m * G / (a * theta.cos());
        assert!((e.multipliers[0] - lambda).abs() < 1e-11 * lambda.abs());
        assert!(e.constraint_residuals[0].abs() < 1e-14 * a * a);
        assert_eq!(e.stability, Stability::Stable, "{}", e.reason);
    }
}

/// A Cartesian pendulum x² + y² = l² under gravity: stable at the bottom with the rod in
/// tension, λ = −mg / (2l) (R = Gᵀλ = (0, mg)); unstable at the top, λ = +mg / (2l).
#[test]
fn cartesian_pendulum_bottom_and_top() {
    let (m, l) = (2.0, 1.5);
    let pendulum = Constrained::new(System::new(2, Mass(m)).with_potential(Weight(m)), circle(l));
    let bottom = constrained_equilibrium(&pendulum, 0.0, &[0.4, -1.0], &tight()).unwrap();
    assert!(bottom.q[0].abs() < 1e-14 && (bottom.q[1] + l).abs() < 1e-14);
    assert!((bottom.multipliers[0] + m * G / (2.0 * l)).abs() < 1e-12);
    assert!((bottom.reaction_forces[1] - m * G).abs() < 1e-12);
    assert!(bottom.reaction_forces[0].abs() < 1e-12);
    assert_eq!(bottom.stability, Stability::Stable, "{}", bottom.reason);
    // The reduced Hessian: m g / l along the tangent.
    assert_eq!(bottom.eigenvalues.len(), 1);
    assert!((bottom.eigenvalues[0] - m * G / l).abs() < 1e-11);
    assert!(bottom.iterations <= 10, "{} iterations", bottom.iterations);

    let top = constrained_equilibrium(&pendulum, 0.0, &[-0.3, 1.2], &tight()).unwrap();
    assert!(top.q[0].abs() < 1e-14 && (top.q[1] - l).abs() < 1e-14);
    assert!((top.multipliers[0] - m * G / (2.0 * l)).abs() < 1e-12);
    assert_eq!(top.stability, Stability::Unstable, "{}", top.reason);
    assert!(top.reason.contains("negative eigenvalue"), "{}", top.reason);
    assert!((top.eigenvalues[0] + m * G / l).abs() < 1e-11);
}

#[test]
fn dependent_constraints_are_typed() {
    let pendulum = |times| {
        Constrained::new(
            System::new(2, Mass(1.0)).with_potential(Weight(1.0)),
            Circle { l: 1.0, times },
        )
    };
    // The rod stated twice: G has rank 1 everywhere.
    match constrained_equilibrium(&pendulum(2), 0.0, &[0.2, -0.9], &tight()) {
        Err(Error::DependentConstraints { row, others, .. }) => {
            assert_eq!(row, "circle 1");
            assert_eq!(others, vec!["circle 0".to_string()]);
        }
        other => panic!("expected DependentConstraints, got {other:?}"),
    }
    // Once, but at the centre, where ∂g/∂q = 0.
    match constrained_equilibrium(&pendulum(1), 0.0, &[0.0, 0.0], &tight()) {
        Err(Error::DependentConstraints { row, others, q, .. }) => {
            assert_eq!(row, "circle 0");
            assert!(others.is_empty());
            assert_eq!(q, vec![0.0, 0.0]);
        }
        other => panic!("expected DependentConstraints, got {other:?}"),
    }
}

#[test]
fn no_convergence_is_typed_and_bounded() {
    /// x² + y² + 1 = 0: an empty manifold, nothing to converge to.
    struct Empty;
    impl Constraints for Empty {
        fn holonomic_count(&self) -> usize {
            1
        }
        fn holonomic<D: Scalar>(&self, _t: D, q: &[D], out: &mut [D]) {
            out[0] = q[0] * q[0] + q[1] * q[1] + 1.0;
        }
        fn depends_on_time(&self) -> bool {
            false
        }
    }
    let empty = Constrained::new(System::new(2, Mass(1.0)).with_potential(Weight(1.0)), Empty);
    match constrained_equilibrium(&empty, 0.0, &[0.3, 0.4], &tight()) {
        Err(Error::NoConvergence { q, residual, .. }) => {
            assert_eq!(q.len(), 2);
            assert!(q.iter().all(|x| x.is_finite()) && residual.is_finite());
        }
        other => panic!("expected NoConvergence, got {other:?}"),
    }
    // Too few iterations from far away.
    let pendulum = Constrained::new(
        System::new(2, Mass(1.0)).with_potential(Weight(1.0)),
        circle(1.0),
    );
    let few = StaticsOptions {
        max_iterations: 1,
        ..tight()
    };
    match constrained_equilibrium(&pendulum, 0.0, &[3.0, 5.0], &few) {
        Err(Error::NoConvergence { iterations, q, .. }) => {
            assert_eq!(iterations, 1);
            assert_eq!(q.len(), 2);
        }
        other => panic!("expected NoConvergence, got {other:?}"),
    }
}

#[test]
fn non_finite_input_is_typed() {
    let pendulum = Constrained::new(
        System::new(2, Mass(1.0)).with_potential(Weight(1.0)),
        circle(1.0),
    );
    for bad in [[f64::NAN, -1.0], [0.0, f64::INFINITY]] {
        match constrained_equilibrium(&pendulum, 0.0, &bad, &tight()) {
            Err(Error::NonFinite { .. }) => {}
            other => panic!("expected NonFinite, got {other:?}"),
        }
    }
    assert!(matches!(
        constrained_equilibrium(&pendulum, f64::NAN, &[0.0, -1.0], &tight()),
        Err(Error::NonFinite { .. })
    ));
    assert!(matches!(
        constrained_equilibrium(&pendulum, 0.0, &[0.0], &tight()),
        Err(Error::DimensionMismatch { .. })
    ));
    let bad_options = StaticsOptions {
        rel_tolerance: f64::NAN,
        ..tight()
    };
    assert!(matches!(
        constrained_equilibrium(&pendulum, 0.0, &[0.0, -1.0], &bad_options),
        Err(Error::InvalidInput { .. })
    ));
}

/// Velocity rows do not restrict positions: a pendulum with a velocity row is solved as
/// without it.
#[test]
fn velocity_rows_are_ignored() {
    struct RodAndVelocity;
    impl Constraints for RodAndVelocity {
        fn holonomic_count(&self) -> usize {
            1
        }
        fn holonomic<D: Scalar>(&self, _t: D, q: &[D], out: &mut [D]) {
            out[0] = q[0] * q[0] + q[1] * q[1] - 1.0;
        }
        fn velocity_count(&self) -> usize {
            1
        }
        fn velocity<D: Scalar>(&self, _t: D, q: &[D], qd: &[D], out: &mut [D]) {
            out[0] = qd[0] * q[1] - qd[1] * q[0];
        }
        fn depends_on_time(&self) -> bool {
            false
        }
    }
    let system = Constrained::new(
        System::new(2, Mass(1.0)).with_potential(Weight(1.0)),
        RodAndVelocity,
    );
    let e = constrained_equilibrium(&system, 0.0, &[0.2, -0.9], &tight()).unwrap();
    assert_eq!(e.multipliers.len(), 1);
    assert!((e.q[1] + 1.0).abs() < 1e-14);
}

/// A rod whose length changes with t has no static equilibrium; frozen at t it balances at the
/// length of that instant.
#[test]
fn moving_constraint_needs_frozen_time() {
    struct Growing;
    impl Constraints for Growing {
        fn holonomic_count(&self) -> usize {
            1
        }
        fn holonomic<D: Scalar>(&self, t: D, q: &[D], out: &mut [D]) {
            let l = t * 0.1 + 1.0;
            out[0] = q[0] * q[0] + q[1] * q[1] - l * l;
        }
    }
    let system = Constrained::new(
        System::new(2, Mass(1.0)).with_potential(Weight(1.0)),
        Growing,
    );
    assert!(matches!(
        constrained_equilibrium(&system, 2.0, &[0.1, -1.0], &tight()),
        Err(Error::NoStaticEquilibrium { .. })
    ));
    let frozen = StaticsOptions {
        frozen_time: true,
        ..tight()
    };
    let e = constrained_equilibrium(&system, 2.0, &[0.1, -1.0], &frozen).unwrap();
    assert!((e.q[1] + 1.2).abs() < 1e-14 && e.q[0].abs() < 1e-14);
    assert!((e.multipliers[0] + G / 2.4).abs() < 1e-12);
}

/// Two bobs in the plane, coordinates (x₁, y₁, x₂, y₂), masses m₁, m₂, gravity along −y.
struct TwoBobs {
    m1: f64,
    m2: f64,
}
impl KineticEnergy for TwoBobs {
    fn kinetic<D: Scalar>(&self, _t: D, _q: &[D], qd: &[D]) -> D {
        (qd[0] * qd[0] + qd[1] * qd[1]) * (0.5 * self.m1)
            + (qd[2] * qd[2] + qd[3] * qd[3]) * (0.5 * self.m2)
    }
    fn depends_on_time(&self) -> bool {
        false
    }
}
impl Potential for TwoBobs {
    fn potential<D: Scalar>(&self, _t: D, q: &[D]) -> D {
        q[1] * (self.m1 * G) + q[3] * (self.m2 * G)
    }
    fn depends_on_time(&self) -> bool {
        false
    }
}

/// x₁² + y₁² − l₁² and (x₂ − x₁)² + (y₂ − y₁)² − l₂².
struct TwoRods {
    l1: f64,
    l2: f64,
}
impl Constraints for TwoRods {
    fn holonomic_count(&self) -> usize {
        2
    }
    fn holonomic<D: Scalar>(&self, _t: D, q: &[D], out: &mut [D]) {
        out[0] = q[0] * q[0] + q[1] * q[1] - self.l1 * self.l1;
        let (dx, dy) = (q[2] - q[0], q[3] - q[1]);
        out[1] = dx * dx + dy * dy - self.l2 * self.l2;
    }
    fn depends_on_time(&self) -> bool {
        false
    }
}

fn cartesian_double(
    m1: f64,
    m2: f64,
    l1: f64,
    l2: f64,
) -> Constrained<System<TwoBobs, TwoBobs>, TwoRods> {
    Constrained::new(
        System::new(4, TwoBobs { m1, m2 }).with_potential(TwoBobs { m1, m2 }),
        TwoRods { l1, l2 },
    )
}

fn close(a: f64, b: f64, rel: f64) -> bool {
    (a - b).abs() <= rel * a.abs().max(b.abs())
}

/// The Cartesian double pendulum, equal masses and lengths, hanging at rest: ω² = (g/l)(2 ∓ √2)
/// with the angle ratios θ₂/θ₁ = ±√2 (θ₁ = δx₁/l, θ₂ = (δx₂ − δx₁)/l at the bottom).
#[test]
fn cartesian_double_pendulum_modes_closed_form() {
    let (m, l) = (1.3, 0.8);
    let system = cartesian_double(m, m, l, l);
    let e = constrained_equilibrium(&system, 0.0, &[0.1, -0.7, 0.3, -1.5], &tight()).unwrap();
    assert_eq!(e.stability, Stability::Stable, "{}", e.reason);
    let found = constrained_modes(&system, 0.0, e.q.as_slice(), e.multipliers.as_slice()).unwrap();
    assert_eq!(found.frequencies.len(), 2);
    assert_eq!(found.stability, Stability::Stable, "{}", found.reason);
    let r2 = 2.0_f64.sqrt();
    for (i, (w2, ratio)) in [((G / l) * (2.0 - r2), r2), ((G / l) * (2.0 + r2), -r2)]
        .into_iter()
        .enumerate()
    {
        assert!(
            close(found.omega_squared[i], w2, 1e-10),
            "{} vs {w2}",
            found.omega_squared[i]
        );
        assert!(close(found.frequencies[i], w2.sqrt(), 1e-10));
        let phi: Vec<f64> = (0..4).map(|r| found.shapes[(r, i)].re).collect();
        assert!((0..4).all(|r| found.shapes[(r, i)].im == 0.0));
        // Horizontal motion only, to first order.
        assert!(phi[1].abs() < 1e-12 && phi[3].abs() < 1e-12, "{phi:?}");
        let (th1, th2) = (phi[0] / l, (phi[2] - phi[0]) / l);
        assert!(close(th2 / th1, ratio, 1e-10), "{} vs {ratio}", th2 / th1);
        // M-normalized.
        let norm = m * phi.iter().map(|v| v * v).sum::<f64>();
        assert!(close(norm, 1.0, 1e-12), "{norm}");
    }
}

/// Unequal masses and lengths: the Cartesian reduction agrees with the minimal-coordinate
/// double pendulum's modes.
#[test]
fn cartesian_double_pendulum_matches_minimal_coordinates() {
    let (m1, m2, l1, l2) = (1.7, 0.6, 1.1, 0.45);
    let system = cartesian_double(m1, m2, l1, l2);
    let e = constrained_equilibrium(&system, 0.0, &[0.2, -1.0, -0.1, -1.4], &tight()).unwrap();
    let found = constrained_modes(&system, 0.0, e.q.as_slice(), e.multipliers.as_slice()).unwrap();
    let minimal = modes(
        &DoublePendulum::new(m1, m2, l1, l2, G).system(),
        0.0,
        &[0.0, 0.0],
    )
    .unwrap();
    assert_eq!(found.frequencies.len(), 2);
    for i in 0..2 {
        assert!(
            close(found.frequencies[i], minimal.frequencies[i], 1e-10),
            "{} vs {}",
            found.frequencies[i],
            minimal.frequencies[i]
        );
        // The same shape in angles: θ = (δx₁/l₁, (δx₂ − δx₁)/l₂) against the minimal one.
        let phi: Vec<f64> = (0..4).map(|r| found.shapes[(r, i)].re).collect();
        let (th1, th2) = (phi[0] / l1, (phi[2] - phi[0]) / l2);
        let (a1, a2) = (minimal.shapes[(0, i)].re, minimal.shapes[(1, i)].re);
        assert!(
            close(th2 / th1, a2 / a1, 1e-10),
            "{} vs {}",
            th2 / th1,
            a2 / a1
        );
    }
}

/// The Cartesian pendulum: ω² = g/l at the bottom, moving sideways; at the top a divergence,
/// reported as `modes` reports the minimal pendulum upside down.
#[test]
fn cartesian_pendulum_modes_bottom_and_top() {
    let (m, l) = (2.0, 1.5);
    let pendulum = Constrained::new(System::new(2, Mass(m)).with_potential(Weight(m)), circle(l));
    let bottom = constrained_equilibrium(&pendulum, 0.0, &[0.4, -1.0], &tight()).unwrap();
    let found = constrained_modes(
        &pendulum,
        0.0,
        bottom.q.as_slice(),
        bottom.multipliers.as_slice(),
    )
    .unwrap();
    assert_eq!(found.omega_squared.len(), 1);
    assert!(close(found.omega_squared[0], G / l, 1e-10));
    assert!(close(found.shapes[(0, 0)].re, 1.0 / m.sqrt(), 1e-12));
    assert!(found.shapes[(1, 0)].norm() < 1e-12);
    assert_eq!(found.stability, Stability::Stable, "{}", found.reason);

    let top = constrained_equilibrium(&pendulum, 0.0, &[-0.3, 1.2], &tight()).unwrap();
    let found =
        constrained_modes(&pendulum, 0.0, top.q.as_slice(), top.multipliers.as_slice()).unwrap();
    let minimal = modes(
        &SimplePendulum::new(m, l, G).system(),
        0.0,
        &[std::f64::consts::PI],
    )
    .unwrap();
    assert!(close(found.omega_squared[0], -G / l, 1e-10));
    assert!(close(
        found.omega_squared[0],
        minimal.omega_squared[0],
        1e-10
    ));
    assert!(close(found.frequencies[0], minimal.frequencies[0], 1e-10));
    assert_eq!(found.stability, Stability::Unstable, "{}", found.reason);
    assert_eq!(minimal.stability, Stability::Unstable);
    assert!(found.reason.contains("divergence"), "{}", found.reason);
    assert_eq!(found.eigenvalues.len(), 2);
    assert!(close(found.eigenvalues[1].re, (G / l).sqrt(), 1e-10));
}

#[test]
fn constrained_modes_errors_are_typed() {
    let pendulum = Constrained::new(
        System::new(2, Mass(1.0)).with_potential(Weight(1.0)),
        circle(1.0),
    );
    let lambda = [-G / 2.0];
    assert!(matches!(
        constrained_modes(&pendulum, 0.0, &[0.0], &lambda),
        Err(Error::DimensionMismatch { .. })
    ));
    assert!(matches!(
        constrained_modes(&pendulum, 0.0, &[0.0, -1.0], &[1.0, 2.0]),
        Err(Error::DimensionMismatch { .. })
    ));
    assert!(matches!(
        constrained_modes(&pendulum, 0.0, &[f64::NAN, -1.0], &lambda),
        Err(Error::NonFinite { .. })
    ));
    assert!(matches!(
        constrained_modes(&pendulum, 0.0, &[0.0, -1.0], &[f64::NAN]),
        Err(Error::NonFinite { .. })
    ));
    assert!(matches!(
        constrained_modes(&pendulum, f64::NAN, &[0.0, -1.0], &lambda),
        Err(Error::NonFinite { .. })
    ));
    // Off the manifold, or a wrong multiplier: not an equilibrium.
    assert!(matches!(
        constrained_modes(&pendulum, 0.0, &[0.0, -1.1], &lambda),
        Err(Error::InvalidInput { .. })
    ));
    assert!(matches!(
        constrained_modes(&pendulum, 0.0, &[0.0, -1.0], &[1.0]),
        Err(Error::InvalidInput { .. })
    ));
    // The same row twice: G is rank-deficient.
    let doubled = Constrained::new(
        System::new(2, Mass(1.0)).with_potential(Weight(1.0)),
        Circle { l: 1.0, times: 2 },
    );
    assert!(matches!(
        constrained_modes(&doubled, 0.0, &[0.0, -1.0], &[-G / 2.0, 0.0]),
        Err(Error::DependentConstraints { .. })
    ));
}
