//! Equilibria of the equations of motion, linearization and modes against closed forms: the
//! bead on a spinning hoop (the relative equilibrium the virtual-work solver missed), the seed's
//! two masses (eq. 41–44), pendulum chains (Laguerre zeros), the ball in a sphere (eq. 53), the
//! damped oscillator, the charged particle, gyroscopic stabilization, the inverted pendulum, and
//! the linearization at a moving state against finite differences.

use approx::assert_relative_eq;
use lagrangian::scenes::{
    BallInSphere, ChargedParticle, DampedOscillator, DoublePendulum, DrivenPendulum, ForcedTwoMass,
    NPendulum, SimplePendulum,
};
use lagrangian::{
    Dynamics, Error, KineticEnergy, ModeProblem, ParticleSystem, Particles, Potential, Scalar,
    Stability, StaticsOptions, System, equilibrium, linearize, modes, static_stiffness,
};

fn opts() -> StaticsOptions {
    StaticsOptions::default()
}

/// A bead of mass m on a hoop of radius R spinning at Ω about its vertical diameter, in gravity
/// g: T = ½ m R² (θ̇² + Ω² sin²θ), U = −m g R cos θ.
#[derive(Clone, Copy)]
struct Hoop {
    m: f64,
    r: f64,
    omega: f64,
    g: f64,
}

impl KineticEnergy for Hoop {
    fn kinetic<D: Scalar>(&self, _t: D, q: &[D], qd: &[D]) -> D {
        let s = q[0].sin();
        (qd[0] * qd[0] + s * s * (self.omega * self.omega)) * (0.5 * self.m * self.r * self.r)
    }
    fn depends_on_time(&self) -> bool {
        false
    }
}

impl Potential for Hoop {
    fn potential<D: Scalar>(&self, _t: D, q: &[D]) -> D {
        -q[0].cos() * (self.m * self.g * self.r)
    }
    fn depends_on_time(&self) -> bool {
        false
    }
}

/// The same bead by its position on the turning hoop, r(t, θ) = R (sin θ cos Ωt, sin θ sin Ωt,
/// −cos θ): T comes from the particle route, with t in the positions.
impl Particles for Hoop {
    fn dof(&self) -> usize {
        1
    }
    fn dim(&self) -> usize {
        3
    }
    fn count(&self) -> usize {
        1
    }
    fn mass(&self, _j: usize) -> f64 {
        self.m
    }
    fn positions<D: Scalar>(&self, t: D, q: &[D], r: &mut [D]) {
        let (s, c) = (q[0].sin(), q[0].cos());
        let phase = t * self.omega;
        r[0] = s * phase.cos() * self.r;
        r[1] = s * phase.sin() * self.r;
        r[2] = -c * self.r;
    }
}

impl Hoop {
    fn energy(self) -> System<Self, Self> {
        System::new(1, self).with_potential(self)
    }
    fn particles(self) -> ParticleSystem<Self> {
        ParticleSystem::new(self).with_gravity([0.0, 0.0, -self.g])
    }
}

/// The bead on a fast hoop, on both routes: from every guess off the axis the bead settles at
/// cos θ* = g/(RΩ²), stable with ω² = Ω² sin²θ*; θ = 0 is an unstable equilibrium.
fn check_fast_hoop<S: Dynamics>(system: &S, hoop: Hoop) {
    let Hoop { r, omega, g, .. } = hoop;
    let theta = (g / (r * omega * omega)).acos();
    // (From a guess near the axis, say 0.3, Newton may take the nearer root θ = 0, now labelled
    // unstable.)
    for guess in [0.8, 1.0, 1.2, 1.5] {
        let eq = equilibrium(system, 0.0, &[guess], &opts()).unwrap();
        assert_relative_eq!(eq.q[0], theta, max_relative = 1e-13);
        assert_eq!(eq.stability, Stability::Stable, "{}", eq.reason);
        assert!(eq.reason.contains("positive definite"), "{}", eq.reason);
        // K = m R² Ω² sin²θ*: the centrifugal stiffness included.
        let k = hoop.m * r * r * omega * omega * theta.sin().powi(2);
        assert_relative_eq!(eq.stiffness[(0, 0)], k, max_relative = 1e-12);
        // At rest there, the bead stays at rest.
        let a = system.accelerations(0.0, &[theta], &[0.0]).unwrap();
        assert!(a[0].abs() < 1e-12, "θ̈ = {}", a[0]);
        let found = modes(system, 0.0, eq.q.as_slice()).unwrap();
        let w = omega * theta.sin();
        assert_relative_eq!(found.frequencies[0], w, max_relative = 1e-12);
        assert!(found.damping_ratios[0].abs() < 1e-12);
    }
    // θ = 0 is still an equilibrium, but an unstable one: λ = ±√(Ω² − g/R).
    let top = equilibrium(system, 0.0, &[0.0], &opts()).unwrap();
    assert_eq!(top.q[0], 0.0);
    assert_eq!(top.stability, Stability::Unstable, "{}", top.reason);
    assert!(top.reason.contains("divergence"), "{}", top.reason);
    let spectrum = top.spectrum.unwrap();
    let growth = (omega * omega - g / r).sqrt();
    let largest = spectrum.iter().map(|v| v.re).fold(f64::MIN, f64::max);
    assert_relative_eq!(largest, growth, max_relative = 1e-12);
}

#[test]
fn bead_on_fast_hoop_energy_route() {
    let hoop = Hoop {
        m: 0.3,
        r: 0.5,
        omega: 7.0,
        g: 9.81,
    };
    check_fast_hoop(&hoop.energy(), hoop);
}

#[test]
fn bead_on_fast_hoop_particle_route() {
    let hoop = Hoop {
        m: 0.3,
        r: 0.5,
        omega: 7.0,
        g: 9.81,
    };
    let system = hoop.particles();
    // t is in the positions, yet the balance does not change with it: a steady rotation.
    assert!(system.structure().time_dependent);
    check_fast_hoop(&system, hoop);
}

#[test]
fn bead_on_slow_hoop_bottom_is_stable() {
    // Ω² < g/R: θ = 0 is the only equilibrium below the equator, stable with ω² = g/R − Ω².
    let hoop = Hoop {
        m: 1.2,
        r: 2.0,
        omega: 1.5,
        g: 9.81,
    };
    for system in [&hoop.energy() as &dyn Probe, &hoop.particles()] {
        let (q, stability, w) = system.probe(0.8);
        assert!(q.abs() < 1e-14, "θ = {q}");
        assert_eq!(stability, Stability::Stable);
        assert_relative_eq!(w, (9.81 / 2.0 - 1.5 * 1.5_f64).sqrt(), max_relative = 1e-12);
    }
}

/// Equilibrium from a guess and the lowest frequency there, over either route.
trait Probe {
    fn probe(&self, guess: f64) -> (f64, Stability, f64);
}

impl<S: Dynamics> Probe for S {
    fn probe(&self, guess: f64) -> (f64, Stability, f64) {
        let eq = equilibrium(self, 0.0, &[guess], &opts()).unwrap();
        let found = modes(self, 0.0, eq.q.as_slice()).unwrap();
        (eq.q[0], eq.stability, found.frequencies[0])
    }
}

#[test]
fn two_mass_frequencies_solve_the_generalized_eigenproblem() {
    // Seed eq. 41–44: det(K − ω² M) = m₁m₂ ω⁴ − (m₁k₂ + m₂(k₁ + k₂)) ω² + k₁k₂ = 0, by hand.
    for (m1, m2, k1, k2) in [(1.0, 2.0, 30.0, 20.0), (3.0, 0.5, 7.0, 110.0)] {
        let system = ForcedTwoMass::new(m1, m2, k1, k2).system();
        let found = modes(&system, 0.0, &[0.0, 0.0]).unwrap();
        let (a, b, c) = (m1 * m2, -(m1 * k2 + m2 * (k1 + k2)), k1 * k2);
        let disc = (b * b - 4.0 * a * c).sqrt();
        let w2 = [2.0 * c / (-b + disc), (-b + disc) / (2.0 * a)];
        assert_eq!(found.problem, ModeProblem::Undamped);
        for i in 0..2 {
            assert_relative_eq!(found.omega_squared[i], w2[i], max_relative = 1e-13);
            assert_relative_eq!(found.frequencies[i], w2[i].sqrt(), max_relative = 1e-13);
            assert_eq!(found.damping_ratios[i], 0.0);
        }
        // Shapes: mass-normalized, and (K − ω² M) φ = 0.
        let lin = &found.linearization;
        let phi = found.shapes.map(|z| z.re);
        assert!(found.shapes.iter().all(|z| z.im == 0.0));
        let gram = phi.transpose() * &lin.m * &phi;
        assert_relative_eq!(gram, nalgebra::DMatrix::identity(2, 2), epsilon = 1e-13);
        for i in 0..2 {
            let r = (&lin.k - &lin.m * w2[i]) * phi.column(i);
            assert!(r.norm() < 1e-12 * lin.k.norm(), "residual {}", r.norm());
        }
        assert_eq!(found.stability, Stability::Stable);
        // Resonance: the forced response amplitude X = (K − Ω² M)⁻¹ F grows without bound as
        // Ω approaches a natural frequency.
        let response = |w: f64| {
            let d = &lin.k - &lin.m * (w * w);
            d.lu()
                .solve(&nalgebra::DVector::from_vec(vec![1.0, 0.0]))
                .unwrap()
                .norm()
        };
        let w1 = found.frequencies[0];
        assert!(response(w1 * (1.0 + 1e-6)) > 1e4 * response(0.5 * w1));
    }
}

/// The zeros of the Laguerre polynomial L_N, ascending: for N equal pendulums of length l in a
/// chain, ω² = (g/l) x_k.
fn laguerre_zeros(n: usize) -> Vec<f64> {
    let eval = |x: f64| {
        let (mut p0, mut p1) = (1.0, 1.0 - x);
        for k in 1..n {
            let k = k as f64;
            let p2 = ((2.0 * k + 1.0 - x) * p1 - k * p0) / (k + 1.0);
            p0 = p1;
            p1 = p2;
        }
        p1
    };
    // Bracket sign changes on a fine grid (the zeros lie in (0, 4N)), then bisect.
    let steps = 20_000;
    let top = 4.0 * n as f64 + 2.0;
    let mut zeros = Vec::new();
    for i in 0..steps {
        let (mut lo, mut hi) = (
            top * i as f64 / steps as f64,
            top * (i + 1) as f64 / steps as f64,
        );
        if eval(lo) * eval(hi) > 0.0 {
            continue;
        }
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if eval(lo) * eval(mid) <= 0.0 {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        zeros.push(0.5 * (lo + hi));
    }
    zeros
}

#[test]
fn double_pendulum_frequencies() {
    let (m, l, g) = (0.7, 1.3, 9.81);
    let system = DoublePendulum::new(m, m, l, l, g).system();
    let found = modes(&system, 0.0, &[0.0, 0.0]).unwrap();
    let r2 = 2.0_f64.sqrt();
    assert_relative_eq!(
        found.omega_squared[0],
        g / l * (2.0 - r2),
        max_relative = 1e-13
    );
    assert_relative_eq!(
        found.omega_squared[1],
        g / l * (2.0 + r2),
        max_relative = 1e-13
    );
    // The slow mode swings both bobs the same way, the fast one opposite.
    let phi = found.shapes.map(|z| z.re);
    assert!(phi[(0, 0)] * phi[(1, 0)] > 0.0 && phi[(0, 1)] * phi[(1, 1)] < 0.0);
}

#[test]
fn pendulum_chain_frequencies_are_laguerre_zeros() {
    let (m, l, g) = (0.4, 0.9, 9.81);
    for n in 2..=6 {
        let system = NPendulum::new(vec![m; n], vec![l; n], g).system();
        let found = modes(&system, 0.0, &vec![0.0; n]).unwrap();
        let zeros = laguerre_zeros(n);
        assert_eq!(zeros.len(), n);
        for (w2, x) in found.omega_squared.iter().zip(&zeros) {
            assert_relative_eq!(*w2, g / l * x, max_relative = 1e-11);
        }
        assert_eq!(found.stability, Stability::Stable);
    }
}

#[test]
fn ball_in_sphere_frequency_of_eq_53() {
    let ball = BallInSphere::new(0.2, 0.4 * 0.2 * 0.05 * 0.05, 1.0, 0.05, 9.81);
    let w0 = ball.small_oscillation_frequency().unwrap();
    for found in [
        modes(&ball.system(), 0.0, &[0.0]).unwrap(),
        modes(&ball.particles(), 0.0, &[0.0]).unwrap(),
    ] {
        assert_relative_eq!(found.frequencies[0], w0, max_relative = 1e-12);
        assert_eq!(found.stability, Stability::Stable);
    }
}

#[test]
fn damped_oscillator_ratio_and_damped_frequency() {
    for (m, k, c) in [(2.0, 50.0, 1.5), (0.5, 8.0, 3.9), (1.0, 4.0, 10.0)] {
        let osc = DampedOscillator::new(m, k, c);
        let found = modes(&osc.system(), 0.0, &[0.0]).unwrap();
        let (w0, zeta) = ((k / m).sqrt(), c / (2.0 * (k * m).sqrt()));
        assert_eq!(found.problem, ModeProblem::StateSpace);
        assert_relative_eq!(found.frequencies[0], w0, max_relative = 1e-12);
        assert_relative_eq!(found.damping_ratios[0], zeta, max_relative = 1e-12);
        assert_relative_eq!(found.linearization.c[(0, 0)], c, max_relative = 1e-14);
        assert_eq!(found.stability, Stability::Stable);
        assert!(found.reason.contains("asymptotically"), "{}", found.reason);
        if zeta < 1.0 {
            // λ = −ζω₀ ± iω₀√(1 − ζ²): the damped frequency.
            let wd = w0 * (1.0 - zeta * zeta).sqrt();
            let upper = found.eigenvalues.iter().find(|v| v.im > 0.0).unwrap();
            assert_relative_eq!(upper.im, wd, max_relative = 1e-12);
            assert_relative_eq!(upper.re, -zeta * w0, max_relative = 1e-12);
        }
    }
}

#[test]
fn charged_particle_eigenvalues() {
    // ±i eB/m and a double zero (the centre of the circle is free): neutral.
    let (m, e, b) = (0.5, 1.5, 2.0);
    let scene = ChargedParticle::new(m, e, b);
    let wc = e * b / m;
    for lin in [
        linearize(&scene.system(), 0.0, &[0.3, -0.2], &[0.0, 0.0]).unwrap(),
        linearize(&scene.particles(), 0.0, &[0.3, -0.2], &[0.0, 0.0]).unwrap(),
    ] {
        let ev = &lin.eigenvalues;
        assert!(ev[0].norm() < 1e-12 && ev[1].norm() < 1e-12, "{ev:?}");
        assert!(ev[2].re.abs() < 1e-12 && ev[3].re.abs() < 1e-12, "{ev:?}");
        assert_relative_eq!(ev[2].im, -wc, max_relative = 1e-13);
        assert_relative_eq!(ev[3].im, wc, max_relative = 1e-13);
        // C is the gyroscopic e B J, skew.
        assert_relative_eq!(lin.c[(0, 1)], -e * b, max_relative = 1e-13);
        assert_relative_eq!(lin.c[(1, 0)], e * b, max_relative = 1e-13);
    }
    let found = modes(&scene.system(), 0.0, &[0.3, -0.2]).unwrap();
    assert_eq!(found.stability, Stability::Neutral);
    assert!(found.reason.contains("zero eigenvalue"), "{}", found.reason);
    assert_relative_eq!(found.frequencies[1], wc, max_relative = 1e-13);
}

/// A charge in the field B ẑ on a potential hill U = −½ k (x² + y²) (m = 1): the magnetic
/// force holds it when (eB)² ≥ 4k, λ⁴ + ((eB)² − 2k) λ² + k² = 0.
#[derive(Clone, Copy)]
struct Trap {
    eb: f64,
    k: f64,
}

impl KineticEnergy for Trap {
    fn kinetic<D: Scalar>(&self, _t: D, q: &[D], qd: &[D]) -> D {
        (qd[0] * qd[0] + qd[1] * qd[1]) * 0.5 + (q[0] * qd[1] - q[1] * qd[0]) * (0.5 * self.eb)
    }
}

impl Potential for Trap {
    fn potential<D: Scalar>(&self, _t: D, q: &[D]) -> D {
        (q[0] * q[0] + q[1] * q[1]) * (-0.5 * self.k)
    }
}

#[test]
fn gyroscopic_stabilization_and_flutter() {
    let strong = Trap { eb: 3.0, k: 1.0 };
    let system = System::new(2, strong).with_potential(strong);
    let eq = equilibrium(&system, 0.0, &[0.1, -0.2], &opts()).unwrap();
    assert!(eq.q.norm() < 1e-14);
    assert_eq!(eq.stability, Stability::Stable, "{}", eq.reason);
    assert!(eq.reason.contains("gyroscopic"), "{}", eq.reason);
    // K alone says unstable: both eigenvalues −k.
    assert!(eq.eigenvalues.iter().all(|&v| v < 0.0));
    let found = modes(&system, 0.0, &[0.0, 0.0]).unwrap();
    let b = strong.eb * strong.eb - 2.0 * strong.k;
    let disc = (b * b - 4.0 * strong.k * strong.k).sqrt();
    let w2 = [(b - disc) / 2.0, (b + disc) / 2.0];
    let lin = &found.linearization;
    let cplx = |m: &nalgebra::DMatrix<f64>| m.map(|x| nalgebra::Complex::new(x, 0.0));
    let (m, c, k) = (cplx(&lin.m), cplx(&lin.c), cplx(&lin.k));
    for i in 0..2 {
        assert_relative_eq!(found.frequencies[i], w2[i].sqrt(), max_relative = 1e-12);
        // The whirl shapes: (K + λC + λ²M) φ = 0 at λ = iω, and φᴴ M φ = 1.
        let lambda = nalgebra::Complex::new(0.0, found.frequencies[i]);
        let phi = found.shapes.column(i).into_owned();
        let r = (&k + &c * lambda + &m * (lambda * lambda)) * &phi;
        assert!(r.norm() < 1e-12 * k.norm(), "residual {}", r.norm());
        assert_relative_eq!(phi.dotc(&(&m * &phi)).re, 1.0, max_relative = 1e-12);
    }
    let weak = Trap { eb: 1.0, k: 1.0 };
    let system = System::new(2, weak).with_potential(weak);
    let eq = equilibrium(&system, 0.0, &[0.0, 0.0], &opts()).unwrap();
    assert_eq!(eq.stability, Stability::Unstable);
    assert!(eq.reason.contains("flutter"), "{}", eq.reason);
}

#[test]
fn inverted_pendulum_one_positive_eigenvalue() {
    let (m, l, g) = (1.1, 0.6, 9.81);
    let system = SimplePendulum::new(m, l, g).system();
    let found = modes(&system, 0.0, &[std::f64::consts::PI]).unwrap();
    let positive: Vec<_> = found.eigenvalues.iter().filter(|v| v.re > 0.0).collect();
    assert_eq!(positive.len(), 1);
    assert_relative_eq!(positive[0].re, (g / l).sqrt(), max_relative = 1e-13);
    assert_eq!(positive[0].im, 0.0);
    assert_eq!(found.stability, Stability::Unstable);
    assert!(found.omega_squared[0] < 0.0);
}

#[test]
fn linearization_at_a_moving_state_matches_finite_differences() {
    let system = DoublePendulum::new(1.0, 0.6, 1.2, 0.8, 9.81).system();
    let (t, q, qd) = (0.0, [0.7, -1.1], [1.3, -0.4]);
    let lin = linearize(&system, t, &q, &qd).unwrap();
    let acc = |q: &[f64], qd: &[f64]| system.accelerations(t, q, qd).unwrap();
    let h = 1e-5;
    for j in 0..4 {
        let (mut up, mut down) = ([q, qd].concat(), [q, qd].concat());
        up[j] += h;
        down[j] -= h;
        let diff = (acc(&up[..2], &up[2..]) - acc(&down[..2], &down[2..])) / (2.0 * h);
        for i in 0..2 {
            let exact = lin.a[(2 + i, j)];
            assert!(
                (exact - diff[i]).abs() < 1e-7 * (1.0 + exact.abs()),
                "∂a{i}/∂x{j}: {exact} vs {}",
                diff[i]
            );
        }
    }
    // Away from rest the q̇-terms (Coriolis) are in C; the kinematic rows are [0, I].
    assert!(lin.c.amax() > 0.1);
    assert_eq!(lin.a[(0, 2)], 1.0);
    assert_eq!(lin.a[(0, 0)], 0.0);
    assert_eq!(lin.accelerations, system.accelerations(t, &q, &qd).unwrap());
}

#[test]
fn time_dependent_forcing_has_no_static_equilibrium() {
    let (k1, k2, f1, omega) = (30.0, 20.0, 3.0, 2.0);
    let system = ForcedTwoMass::new(1.0, 2.0, k1, k2)
        .with_forcing(f1, 0.0, omega)
        .system();
    let e = equilibrium(&system, 0.0, &[0.0, 0.0], &opts()).unwrap_err();
    assert!(matches!(e, Error::NoStaticEquilibrium { .. }), "{e:?}");
    assert!(e.to_string().contains("frozen"), "{e}");
    // Frozen at t: K x = F cos Ωt.
    let t = 0.4;
    let frozen = StaticsOptions {
        frozen_time: true,
        ..opts()
    };
    let eq = equilibrium(&system, t, &[0.0, 0.0], &frozen).unwrap();
    let x1 = f1 * (omega * t).cos() / k1;
    assert_relative_eq!(eq.q[0], x1, max_relative = 1e-13);
    assert_relative_eq!(eq.q[1], x1, max_relative = 1e-13);
}

#[test]
fn modes_refuse_a_non_equilibrium_and_bad_input() {
    let system = SimplePendulum::new(1.0, 1.0, 9.81).system();
    let e = modes(&system, 0.0, &[0.4]).unwrap_err();
    assert!(matches!(e, Error::InvalidInput { what: "q", .. }), "{e:?}");
    let e = linearize(&system, 0.0, &[0.4, 0.1], &[0.0]).unwrap_err();
    assert!(matches!(e, Error::DimensionMismatch { .. }), "{e:?}");
    let e = linearize(&system, 0.0, &[f64::NAN], &[0.0]).unwrap_err();
    assert!(matches!(e, Error::NonFinite { .. }), "{e:?}");
}

#[test]
fn stiffness_includes_the_centrifugal_part() {
    // K = m g R cos θ − m R² Ω² cos 2θ, away from equilibrium too.
    let hoop = Hoop {
        m: 0.3,
        r: 0.5,
        omega: 7.0,
        g: 9.81,
    };
    for theta in [0.0_f64, 0.4, 1.3] {
        let want = hoop.m * hoop.g * hoop.r * theta.cos()
            - hoop.m * hoop.r * hoop.r * hoop.omega * hoop.omega * (2.0 * theta).cos();
        for k in [
            static_stiffness(&hoop.energy(), 0.0, &[theta]).unwrap(),
            static_stiffness(&hoop.particles(), 0.0, &[theta]).unwrap(),
        ] {
            assert_relative_eq!(k[(0, 0)], want, max_relative = 1e-12, epsilon = 1e-13);
        }
    }
}

#[test]
fn driven_pivot_stiffness_has_the_time_derivative_of_the_momentum() {
    // T = ½ m [(l cos θ θ̇)² + (l sin θ θ̇ − a ω sin ωt)²]: at q̇ = 0 the pivot's acceleration
    // enters only through −∂²T/∂q̇∂t, so K = m l (g − a ω² cos ωt) cos θ, on both routes and
    // equal to the K of the linearization.
    let (m, l, g, a, w) = (0.8, 0.7, 9.81, 0.1, 20.0);
    let scene = DrivenPendulum::new(m, l, g, a, w);
    for t in [0.0, 0.13, 0.4] {
        for theta in [0.0_f64, 0.5] {
            let want = m * l * (g - a * w * w * (w * t).cos()) * theta.cos();
            let k = static_stiffness(&scene.system(), t, &[theta]).unwrap();
            assert_relative_eq!(k[(0, 0)], want, max_relative = 1e-12);
            let k = static_stiffness(&scene.particles(), t, &[theta]).unwrap();
            assert_relative_eq!(k[(0, 0)], want, max_relative = 1e-12);
        }
        let lin = linearize(&scene.system(), t, &[0.0], &[0.0]).unwrap();
        assert_relative_eq!(
            lin.k[(0, 0)],
            m * l * (g - a * w * w * (w * t).cos()),
            max_relative = 1e-12
        );
    }
}

#[test]
fn driven_pendulum_hanging_is_an_equilibrium_its_stability_parametric() {
    // θ = 0 stays an equilibrium at every t (sin 0 = 0), but its linearization changes with t:
    // neutral, with the reason, not the verdict of one instant.
    let scene = DrivenPendulum::new(1.0, 1.0, 9.81, 0.1, 20.0);
    let eq = equilibrium(&scene.system(), 0.0, &[0.0], &opts()).unwrap();
    assert_eq!(eq.q[0], 0.0);
    assert_eq!(eq.stability, Stability::Neutral);
    assert!(eq.reason.contains("parametric"), "{}", eq.reason);
    // Frozen at an instant, the same root, classified by that instant's eigenvalues.
    let frozen = StaticsOptions {
        frozen_time: true,
        ..opts()
    };
    let at = equilibrium(&scene.system(), 0.0, &[0.0], &frozen).unwrap();
    assert_eq!(at.q[0], 0.0);
    assert_ne!(at.stability, Stability::Neutral, "{}", at.reason);
}
