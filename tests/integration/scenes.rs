//! The dynamic scenes: the derived equations of motion against the seed's closed forms
//! (eq. 43–44, 48, 53, 55) and the textbook ones, both routes where both exist, the structure
//! flags, and the exact solutions against their differential equations.

use approx::assert_relative_eq;
use lagrangian::scenes::{
    BallInSphere, ChargedParticle, DampedOscillator, DoublePendulum, DrivenPendulum,
    ElasticPendulum, ForcedTwoMass, HenonHeiles, Kepler, RadialDamping, RollingCylinder,
    SimplePendulum, elliptic_k,
};
use lagrangian::{Dynamics, Error};
use std::f64::consts::PI;

/// Ten varied states of `n` coordinates (and a time for each), deterministic.
fn states(n: usize) -> Vec<(f64, Vec<f64>, Vec<f64>)> {
    (0..10)
        .map(|k| {
            let t = -1.3 + 0.77 * k as f64;
            let q = (0..n)
                .map(|i| 0.3 + 0.7 * ((i * 7 + k * 3) as f64).sin())
                .collect();
            let qd = (0..n)
                .map(|i| -0.4 + 1.1 * ((i * 5 + k * 11) as f64).cos())
                .collect();
            (t, q, qd)
        })
        .collect()
}

/// `got` equals `want` to 1e-12 relative to the largest entry of `want`.
fn assert_close(got: &[f64], want: &[f64]) {
    assert_eq!(got.len(), want.len());
    let scale = want.iter().fold(0.0_f64, |s, x| s.max(x.abs()));
    for (g, w) in got.iter().zip(want) {
        assert_relative_eq!(*g, *w, max_relative = 1e-12, epsilon = 1e-12 * scale);
    }
}

/// The accelerations of `sys` at (t, q, q̇) as a plain vector.
fn acc(sys: &impl Dynamics, t: f64, q: &[f64], qd: &[f64]) -> Vec<f64> {
    sys.accelerations(t, q, qd)
        .unwrap()
        .iter()
        .copied()
        .collect()
}

/// Fourth-order central differences (first, second derivative) of `f` at `t` with step `h`.
fn derivatives<const N: usize>(f: impl Fn(f64) -> [f64; N], t: f64, h: f64) -> [[f64; N]; 2] {
    let (m2, m1, z, p1, p2) = (f(t - 2.0 * h), f(t - h), f(t), f(t + h), f(t + 2.0 * h));
    let first = std::array::from_fn(|i| (m2[i] - 8.0 * m1[i] + 8.0 * p1[i] - p2[i]) / (12.0 * h));
    let second = std::array::from_fn(|i| {
        (-m2[i] + 16.0 * m1[i] - 30.0 * z[i] + 16.0 * p1[i] - p2[i]) / (12.0 * h * h)
    });
    [first, second]
}

/// Classical RK4 on y' = f(t, y), `steps` steps of size `h` from (0, y0).
fn rk4<const N: usize>(
    f: impl Fn(f64, &[f64; N]) -> [f64; N],
    y0: [f64; N],
    h: f64,
    steps: usize,
) -> [f64; N] {
    let add = |y: &[f64; N], k: &[f64; N], s: f64| -> [f64; N] {
        std::array::from_fn(|i| y[i] + s * k[i])
    };
    let mut y = y0;
    for n in 0..steps {
        let t = n as f64 * h;
        let k1 = f(t, &y);
        let k2 = f(t + 0.5 * h, &add(&y, &k1, 0.5 * h));
        let k3 = f(t + 0.5 * h, &add(&y, &k2, 0.5 * h));
        let k4 = f(t + h, &add(&y, &k3, h));
        y = std::array::from_fn(|i| y[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]));
    }
    y
}

#[test]
fn accelerations_forced_two_mass() {
    let scene = ForcedTwoMass::new(1.3, 0.7, 40.0, 25.0).with_forcing(3.0, -1.5, 4.2);
    let sys = scene.system();
    for (t, q, qd) in states(2) {
        assert_close(
            &acc(&sys, t, &q, &qd),
            &scene.closed_form_accelerations(t, &q, &qd),
        );
        let m = sys.mass_matrix(t, &q, &qd).unwrap();
        assert_close(m.as_slice(), &[1.3, 0.0, 0.0, 0.7]);
        let f = sys.generalized_forces(t, &q, &qd).unwrap();
        assert_close(f.as_slice(), &scene.forcing(t));
        let t_plus_u = 0.5 * (1.3 * qd[0] * qd[0] + 0.7 * qd[1] * qd[1])
            + 0.5 * (40.0 * q[0] * q[0] + 25.0 * (q[1] - q[0]).powi(2));
        assert_relative_eq!(
            sys.energy(t, &q, &qd).unwrap(),
            t_plus_u,
            max_relative = 1e-13
        );
    }
    let s = sys.structure();
    assert!(s.separable && s.constant_mass && s.forced);
    assert!(!s.dissipative && !s.conservative());
    // Without forcing the part reports itself absent.
    let free = ForcedTwoMass::new(1.3, 0.7, 40.0, 25.0)
        .system()
        .structure();
    assert!(free.conservative() && !free.forced);
}

#[test]
fn natural_frequencies_forced_two_mass() {
    let scene = ForcedTwoMass::new(1.3, 0.7, 40.0, 25.0);
    let w = scene.natural_frequencies().unwrap();
    // Against the symmetric eigenproblem M^{-1/2} K M^{-1/2}.
    let (s1, s2) = (1.3_f64.sqrt(), 0.7_f64.sqrt());
    let k = nalgebra::Matrix2::new(
        65.0 / (s1 * s1),
        -25.0 / (s1 * s2),
        -25.0 / (s1 * s2),
        25.0 / (s2 * s2),
    );
    let mut eig: Vec<f64> = k
        .symmetric_eigen()
        .eigenvalues
        .iter()
        .map(|x| x.sqrt())
        .collect();
    eig.sort_by(f64::total_cmp);
    assert_relative_eq!(w[0], eig[0], max_relative = 1e-13);
    assert_relative_eq!(w[1], eig[1], max_relative = 1e-13);
    assert!(matches!(
        ForcedTwoMass::new(1.0, 0.0, 1.0, 1.0).natural_frequencies(),
        Err(Error::InvalidInput { .. })
    ));
}

#[test]
fn exact_solution_forced_two_mass() {
    let (x0, v0) = ([0.1, -0.05], [0.3, 0.7]);
    for scene in [
        ForcedTwoMass::new(1.3, 0.7, 40.0, 25.0).with_forcing(3.0, -1.5, 4.2),
        ForcedTwoMass::new(1.3, 0.7, 40.0, 25.0).with_forcing(0.0, 2.0, 11.0),
        ForcedTwoMass::new(1.3, 0.7, 40.0, 25.0),
    ] {
        let [x, v] = scene.exact_solution(x0, v0, 0.0).unwrap();
        assert_close(&x, &x0);
        assert_close(&v, &v0);
        for t in [0.0, 0.37, 1.1, 2.9, 7.4] {
            let pos = |t| scene.exact_solution(x0, v0, t).unwrap()[0];
            let [d1, d2] = derivatives(pos, t, 1e-3);
            let [x, v] = scene.exact_solution(x0, v0, t).unwrap();
            let a = scene.closed_form_accelerations(t, &x, &v);
            for i in 0..2 {
                assert_relative_eq!(d1[i], v[i], epsilon = 1e-9);
                assert_relative_eq!(d2[i], a[i], epsilon = 1e-6);
            }
        }
    }
    // At a natural frequency the steady response does not exist.
    let base = ForcedTwoMass::new(1.3, 0.7, 40.0, 25.0);
    let w = base.natural_frequencies().unwrap();
    let resonant = base.with_forcing(1.0, 0.0, w[1]);
    assert!(matches!(
        resonant.exact_solution(x0, v0, 1.0),
        Err(Error::InvalidInput { .. })
    ));
}

#[test]
fn accelerations_rolling_cylinder() {
    let (m, r) = (2.0, 0.3);
    let scene = RollingCylinder::new(m, 0.5 * m * r * r, r, 9.81, 0.4);
    let sys = scene.system();
    // A solid cylinder rolls with ẍ = (2/3) g sin α (eq. 48 with J = ½ m r²).
    assert_relative_eq!(
        scene.acceleration(),
        2.0 / 3.0 * 9.81 * 0.4_f64.sin(),
        max_relative = 1e-15
    );
    for (t, q, qd) in states(1) {
        assert_close(
            &acc(&sys, t, &q, &qd),
            &scene.closed_form_accelerations(&q, &qd),
        );
        let mm = sys.mass_matrix(t, &q, &qd).unwrap();
        assert_relative_eq!(mm[(0, 0)], 1.5 * m, max_relative = 1e-15);
        let t_plus_u = 0.75 * m * qd[0] * qd[0] - m * 9.81 * q[0] * 0.4_f64.sin();
        assert_relative_eq!(
            sys.energy(t, &q, &qd).unwrap(),
            t_plus_u,
            max_relative = 1e-13
        );
    }
    let s = sys.structure();
    assert!(s.separable && s.conservative());
    for t in [0.0, 0.5, 2.0] {
        let pos = |t| [scene.exact_solution(0.2, -0.4, t).0];
        let [d1, d2] = derivatives(pos, t, 1e-2);
        let (x, v) = scene.exact_solution(0.2, -0.4, t);
        assert_relative_eq!(d1[0], v, epsilon = 1e-12);
        assert_relative_eq!(
            d2[0],
            scene.closed_form_accelerations(&[x], &[v])[0],
            epsilon = 1e-9
        );
    }
    assert_eq!(scene.exact_solution(0.2, -0.4, 0.0), (0.2, -0.4));
}

#[test]
fn accelerations_ball_in_sphere() {
    let (m, r2) = (0.4, 0.05);
    let scene = BallInSphere::new(m, 0.4 * m * r2 * r2, 1.2, r2, 9.81);
    let sys = scene.system();
    for (t, q, qd) in states(1) {
        assert_close(
            &acc(&sys, t, &q, &qd),
            &scene.closed_form_accelerations(&q, &qd),
        );
        let h = 1.4 * m * 1.15 * 1.15 * qd[0] * qd[0] / 2.0 - m * 9.81 * 1.15 * q[0].cos();
        assert_relative_eq!(sys.energy(t, &q, &qd).unwrap(), h, max_relative = 1e-13);
    }
    let s = sys.structure();
    assert!(s.separable && s.conservative());
}

#[test]
fn derivatives_ball_in_sphere() {
    let (m, j, r1, r2) = (0.4, 3e-4, 1.2, 0.05);
    let sys = BallInSphere::new(m, j, r1, r2, 9.81).system();
    // Eq. 52 by hand: M = (m + J/r₂²)(r₁ − r₂)², p = M θ̇₁.
    let hand = (m + j / (r2 * r2)) * (r1 - r2) * (r1 - r2);
    for (t, q, qd) in states(1) {
        let mm = sys.mass_matrix(t, &q, &qd).unwrap();
        assert_relative_eq!(mm[(0, 0)], hand, max_relative = 1e-14);
        let p = sys.momenta(t, &q, &qd).unwrap();
        assert_relative_eq!(p[0], hand * qd[0], max_relative = 1e-14);
    }
}

#[test]
fn elliptic_k_known_values() {
    // Reference values from mpmath.ellipk(k²) at 30 digits.
    let cases = [
        (0.0, PI / 2.0),
        (0.5, 1.685_750_354_812_596),
        (std::f64::consts::FRAC_1_SQRT_2, 1.854_074_677_301_371_9),
        (0.9, 2.280_549_138_422_770_2),
        (0.99_f64.sqrt(), 3.695_637_362_989_874_7),
        (-0.5, 1.685_750_354_812_596),
    ];
    for (k, want) in cases {
        assert_relative_eq!(elliptic_k(k).unwrap(), want, max_relative = 2e-15);
    }
    // Near k = 1 the AGM still converges: K(√0.999999) = 8.2940514636154399…
    assert_relative_eq!(
        elliptic_k(0.999_999_f64.sqrt()).unwrap(),
        8.294_051_463_615_44,
        max_relative = 1e-9
    );
    for bad in [1.0, -1.0, 1.5, f64::NAN] {
        assert!(matches!(elliptic_k(bad), Err(Error::InvalidInput { .. })));
    }
}

#[test]
fn period_ball_in_sphere() {
    let (m, r2) = (0.4, 0.05);
    let scene = BallInSphere::new(m, 0.4 * m * r2 * r2, 1.2, r2, 9.81);
    let w0 = scene.small_oscillation_frequency().unwrap();
    // Solid ball: ω₀² = g / (1.4 (r₁ − r₂)).
    assert_relative_eq!(w0, (9.81 / (1.4 * 1.15_f64)).sqrt(), max_relative = 1e-15);
    // Small amplitudes: T → 2π/ω₀ (1 + θ₀²/16 + 11 θ₀⁴/3072).
    let th: f64 = 0.01;
    let series = 2.0 * PI / w0 * (1.0 + th * th / 16.0 + 11.0 * th.powi(4) / 3072.0);
    assert_relative_eq!(scene.period(th).unwrap(), series, max_relative = 1e-12);
    // Large amplitude: integrating eq. 53 for a quarter period from rest at θ₀ reaches the
    // bottom with speed 2 ω₀ sin(θ₀/2) (energy conservation).
    for th0 in [0.5, 1.5, 2.8] {
        let quarter = scene.period(th0).unwrap() / 4.0;
        let steps = 4000;
        let f =
            |_t: f64, y: &[f64; 2]| [y[1], scene.closed_form_accelerations(&y[..1], &y[1..])[0]];
        let y = rk4(f, [th0, 0.0], quarter / steps as f64, steps);
        assert!(y[0].abs() < 1e-10, "θ({quarter}) = {} for θ₀ = {th0}", y[0]);
        assert_relative_eq!(y[1], -2.0 * w0 * (0.5 * th0).sin(), max_relative = 1e-10);
    }
    assert!(matches!(scene.period(PI), Err(Error::InvalidInput { .. })));
    assert!(matches!(
        BallInSphere::new(m, 0.0, 0.05, 0.1, 9.81).period(0.1),
        Err(Error::InvalidInput { .. })
    ));
}

#[test]
fn accelerations_damped_oscillator() {
    let scene = DampedOscillator::new(1.7, 30.0, 0.9);
    let sys = scene.system();
    for (t, q, qd) in states(1) {
        assert_close(
            &acc(&sys, t, &q, &qd),
            &scene.closed_form_accelerations(&q, &qd),
        );
        let mut d = [0.0];
        sys.dissipative_forces_into(t, &q, &qd, &mut d);
        assert_relative_eq!(d[0], -0.9 * qd[0], max_relative = 1e-14);
        let t_plus_u = 0.5 * 1.7 * qd[0] * qd[0] + 15.0 * q[0] * q[0];
        assert_relative_eq!(
            sys.energy(t, &q, &qd).unwrap(),
            t_plus_u,
            max_relative = 1e-13
        );
    }
    let s = sys.structure();
    assert!(s.dissipative && s.separable && !s.forced && !s.conservative());
    assert!(
        DampedOscillator::new(1.7, 30.0, 0.0)
            .system()
            .structure()
            .conservative()
    );
}

#[test]
fn exact_solution_damped_oscillator() {
    // Under-damped, exactly critical (γ = ω₀ = 2), over-damped, and just either side of critical.
    let scenes = [
        DampedOscillator::new(1.0, 4.0, 0.8),
        DampedOscillator::new(1.0, 4.0, 4.0),
        DampedOscillator::new(1.0, 4.0, 10.0),
        DampedOscillator::new(1.0, 4.0, 4.0 - 1e-9),
        DampedOscillator::new(1.0, 4.0, 4.0 + 1e-9),
    ];
    let ratios: Vec<f64> = scenes.iter().map(|s| s.damping_ratio()).collect();
    assert!(ratios[0] < 1.0 && ratios[1] == 1.0 && ratios[2] > 1.0);
    for scene in scenes {
        let (x0, v0) = (0.3, -1.1);
        assert_eq!(scene.exact_solution(x0, v0, 0.0).unwrap(), (x0, v0));
        for t in [0.1, 0.6, 1.7, 4.0] {
            let pos = |t| [scene.exact_solution(x0, v0, t).unwrap().0];
            let [d1, d2] = derivatives(pos, t, 1e-3);
            let (x, v) = scene.exact_solution(x0, v0, t).unwrap();
            assert_relative_eq!(d1[0], v, epsilon = 1e-8);
            assert_relative_eq!(
                d2[0],
                scene.closed_form_accelerations(&[x], &[v])[0],
                epsilon = 1e-7
            );
        }
    }
    // Continuity across critical damping: both sides agree with the critical formula.
    let at = |c: f64| {
        DampedOscillator::new(1.0, 4.0, c)
            .exact_solution(0.3, -1.1, 1.3)
            .unwrap()
    };
    let critical = at(4.0);
    for c in [4.0 - 1e-9, 4.0 + 1e-9] {
        assert_relative_eq!(at(c).0, critical.0, max_relative = 1e-8);
        assert_relative_eq!(at(c).1, critical.1, max_relative = 1e-8);
    }
    // Far into the over-damped tail nothing overflows.
    let (x, v) = DampedOscillator::new(1.0, 4.0, 10.0)
        .exact_solution(0.3, -1.1, 800.0)
        .unwrap();
    assert!(x.is_finite() && v.is_finite() && x.abs() < 1e-30);
    assert!(matches!(
        DampedOscillator::new(0.0, 4.0, 1.0).exact_solution(0.3, 0.0, 1.0),
        Err(Error::InvalidInput { .. })
    ));
}

#[test]
fn accelerations_kepler() {
    let scene = Kepler::new(0.8, 3.5);
    let (sys, part) = (scene.system(), scene.particles());
    for (t, q, qd) in states(2) {
        let want = scene.closed_form_accelerations(&q, &qd);
        assert_close(&acc(&sys, t, &q, &qd), &want);
        assert_close(&acc(&part, t, &q, &qd), &want);
        assert_close(
            sys.mass_matrix(t, &q, &qd).unwrap().as_slice(),
            &[0.8, 0.0, 0.0, 0.8],
        );
        let r = q[0].hypot(q[1]);
        let t_plus_u = 0.4 * (qd[0] * qd[0] + qd[1] * qd[1]) - 3.5 * 0.8 / r;
        assert_relative_eq!(
            sys.energy(t, &q, &qd).unwrap(),
            t_plus_u,
            max_relative = 1e-13
        );
        assert_relative_eq!(
            part.energy(t, &q, &qd).unwrap(),
            t_plus_u,
            max_relative = 1e-13
        );
    }
    let s = sys.structure();
    assert!(s.separable && s.conservative());
    // The centre itself is a typed error, not a NaN.
    assert!(sys.accelerations(0.0, &[0.0, 0.0], &[1.0, 0.0]).is_err());
}

#[test]
fn orbit_kepler() {
    let scene = Kepler::new(0.8, 3.5);
    let sys = scene.system();
    let (a, e) = (1.7, 0.6);
    let (q, qd) = scene.periapsis_state(a, e).unwrap();
    assert_relative_eq!(
        sys.energy(0.0, &q, &qd).unwrap(),
        scene.orbit_energy(a).unwrap(),
        max_relative = 1e-14
    );
    assert_relative_eq!(
        scene.angular_momentum(&q, &qd),
        scene.orbit_angular_momentum(a, e).unwrap(),
        max_relative = 1e-14
    );
    // One period of the closed-form flow returns to periapsis (RK4, 20 000 steps).
    let period = scene.period(a).unwrap();
    let steps = 20_000;
    let f = |_t: f64, y: &[f64; 4]| {
        let [ax, ay] = scene.closed_form_accelerations(&y[..2], &y[2..]);
        [y[2], y[3], ax, ay]
    };
    let y = rk4(f, [q[0], q[1], qd[0], qd[1]], period / steps as f64, steps);
    assert_relative_eq!(y[0], q[0], max_relative = 1e-7);
    assert!(y[1].abs() < 1e-7 * q[0], "y after one period: {}", y[1]);
    assert!(matches!(
        scene.periapsis_state(a, 1.0),
        Err(Error::InvalidInput { .. })
    ));
    assert!(matches!(
        scene.period(-1.0),
        Err(Error::InvalidInput { .. })
    ));
}

#[test]
fn accelerations_elastic_pendulum() {
    let scene = ElasticPendulum::new(0.9, 35.0, 1.1, 9.81);
    let (sys, part) = (scene.system(), scene.particles());
    let (damped, damped_part) = (
        scene.damped(0.6),
        scene.particles().with_dissipation(RadialDamping { c: 0.6 }),
    );
    for (t, mut q, qd) in states(2) {
        q[0] += 1.0; // a stretched spring, r > 0
        let want = scene.closed_form_accelerations(&q, &qd);
        assert_close(&acc(&sys, t, &q, &qd), &want);
        assert_close(&acc(&part, t, &q, &qd), &want);
        let want = scene.closed_form_damped_accelerations(0.6, &q, &qd);
        assert_close(&acc(&damped, t, &q, &qd), &want);
        assert_close(&acc(&damped_part, t, &q, &qd), &want);
        let hand = [0.9, 0.0, 0.0, 0.9 * q[0] * q[0]];
        assert_close(sys.mass_matrix(t, &q, &qd).unwrap().as_slice(), &hand);
        assert_close(part.mass_matrix(t, &q, &qd).unwrap().as_slice(), &hand);
        let t_plus_u = 0.45 * (qd[0] * qd[0] + q[0] * q[0] * qd[1] * qd[1])
            + 17.5 * (q[0] - 1.1).powi(2)
            - 0.9 * 9.81 * q[0] * q[1].cos();
        assert_relative_eq!(
            sys.energy(t, &q, &qd).unwrap(),
            t_plus_u,
            max_relative = 1e-13
        );
        assert_relative_eq!(
            part.energy(t, &q, &qd).unwrap(),
            t_plus_u,
            max_relative = 1e-13
        );
    }
    let s = sys.structure();
    assert!(!s.separable && !s.constant_mass && s.conservative());
    assert!(damped.structure().dissipative && damped_part.structure().dissipative);
    assert!(!scene.damped(0.0).structure().dissipative);
    // r = 0 makes M singular: a typed error.
    assert!(matches!(
        sys.accelerations(0.0, &[0.0, 0.3], &[0.1, 0.2]),
        Err(Error::SingularMassMatrix { .. })
    ));
}

#[test]
fn accelerations_henon_heiles() {
    let scene = HenonHeiles::new();
    let (sys, part) = (scene.system(), scene.particles());
    for (t, q, qd) in states(2) {
        let want = scene.closed_form_accelerations(&q, &qd);
        assert_close(&acc(&sys, t, &q, &qd), &want);
        assert_close(&acc(&part, t, &q, &qd), &want);
        let (x, y) = (q[0], q[1]);
        let h = 0.5 * (qd[0] * qd[0] + qd[1] * qd[1]) + 0.5 * (x * x + y * y) + x * x * y
            - y.powi(3) / 3.0;
        assert_relative_eq!(sys.energy(t, &q, &qd).unwrap(), h, max_relative = 1e-13);
    }
    let s = sys.structure();
    assert!(s.separable && s.constant_mass && s.conservative());
    // The saddle at (0, 1) sits at the escape energy.
    assert_relative_eq!(
        sys.potential_energy(0.0, &[0.0, 1.0]),
        HenonHeiles::ESCAPE_ENERGY,
        max_relative = 1e-15
    );
}

#[test]
fn accelerations_driven_pendulum() {
    let scene = DrivenPendulum::new(0.6, 0.9, 9.81, 0.05, 40.0);
    let (sys, part) = (scene.system(), scene.particles());
    for (t, q, qd) in states(1) {
        let want = scene.closed_form_accelerations(t, &q, &qd);
        assert_close(&acc(&sys, t, &q, &qd), &want);
        assert_close(&acc(&part, t, &q, &qd), &want);
        assert_relative_eq!(
            sys.mass_matrix(t, &q, &qd).unwrap()[(0, 0)],
            0.6 * 0.81,
            max_relative = 1e-14
        );
        // Both routes state the same L, pivot motion included.
        assert_relative_eq!(
            sys.lagrangian_at(t, &q, &qd).unwrap(),
            part.lagrangian_at(t, &q, &qd).unwrap(),
            max_relative = 1e-13
        );
    }
    // The drive matters: at t = 0 the pivot accelerates down at a ω² = 80 > g, flipping gravity.
    let a0 = acc(&sys, 0.0, &[0.3], &[0.0])[0];
    assert!(a0 > 0.0);
    assert!(sys.structure().time_dependent && part.structure().time_dependent);
    assert!(!sys.structure().separable && sys.structure().constant_mass);
    // No drive, no time dependence.
    assert!(
        !DrivenPendulum::new(0.6, 0.9, 9.81, 0.0, 40.0)
            .system()
            .structure()
            .time_dependent
    );
}

#[test]
fn accelerations_simple_pendulum_both_routes() {
    let scene = SimplePendulum::new(0.7, 1.3, 9.81);
    let (sys, part) = (scene.system(), scene.particles());
    for (t, q, qd) in states(1) {
        let want = scene.closed_form_accelerations(&q, &qd);
        assert_close(&acc(&sys, t, &q, &qd), &want);
        assert_close(&acc(&part, t, &q, &qd), &want);
    }
    // θ-coordinates make the simple pendulum separable; the double pendulum is not.
    assert!(sys.structure().separable);
    assert!(
        !DoublePendulum::new(1.0, 1.0, 1.0, 1.0, 9.81)
            .system()
            .structure()
            .separable
    );
}

#[test]
fn accelerations_charged_particle() {
    let scene = ChargedParticle::new(0.5, 1.6, 2.2).with_electric_field(0.7, -1.3);
    let (sys, part) = (scene.system(), scene.particles());
    for (t, q, qd) in states(2) {
        let want = scene.closed_form_accelerations(&q, &qd);
        assert_close(&acc(&sys, t, &q, &qd), &want);
        assert_close(&acc(&part, t, &q, &qd), &want);
    }
    let s = sys.structure();
    assert!(!s.separable && s.constant_mass && s.conservative());
}

#[test]
fn derivatives_charged_particle() {
    let (m, e, b) = (0.5, 1.6, 2.2);
    for scene in [
        ChargedParticle::new(m, e, b),
        ChargedParticle::new(m, e, b).with_electric_field(0.7, -1.3),
    ] {
        let sys = scene.system();
        for (t, q, qd) in states(2) {
            assert_close(
                sys.mass_matrix(t, &q, &qd).unwrap().as_slice(),
                &[m, 0.0, 0.0, m],
            );
            // p = m v + e A, A = (B/2)(−y, x).
            let p = [
                m * qd[0] - 0.5 * e * b * q[1],
                m * qd[1] + 0.5 * e * b * q[0],
            ];
            assert_close(sys.momenta(t, &q, &qd).unwrap().as_slice(), &p);
            // h = q̇·p − L = ½ m v² + U: the magnetic term drops out.
            let u = -e * (scene.ex * q[0] + scene.ey * q[1]);
            let h = 0.5 * m * (qd[0] * qd[0] + qd[1] * qd[1]) + u;
            assert_relative_eq!(sys.energy(t, &q, &qd).unwrap(), h, max_relative = 1e-13);
        }
    }
}

#[test]
fn cyclotron_charged_particle() {
    let scene = ChargedParticle::new(0.5, 1.6, 2.2);
    let sys = scene.system();
    let w = scene.cyclotron_frequency();
    assert_relative_eq!(w, 1.6 * 2.2 / 0.5, max_relative = 1e-15);
    let (q0, v0) = ([0.3, -0.2], [1.1, 0.4]);
    let centre = [q0[0] + v0[1] / w, q0[1] - v0[0] / w];
    let radius = v0[0].hypot(v0[1]) / w.abs();
    for t in [0.0, 0.1, 0.45, 1.3, 2.0 * PI / w] {
        let [x, v] = scene.exact_solution(q0, v0, t).unwrap();
        // On the circle of radius |v|/ω_c about the centre, speed unchanged …
        assert_relative_eq!(
            (x[0] - centre[0]).hypot(x[1] - centre[1]),
            radius,
            max_relative = 1e-13
        );
        assert_relative_eq!(v[0].hypot(v[1]), v0[0].hypot(v0[1]), max_relative = 1e-13);
        // … and the derived accelerations are the centripetal −ω_c² (r − centre).
        let a = acc(&sys, t, &x, &v);
        assert_close(
            &a,
            &[-w * w * (x[0] - centre[0]), -w * w * (x[1] - centre[1])],
        );
    }
    // After one cyclotron period 2π m/(eB) the particle is back.
    let [x, v] = scene.exact_solution(q0, v0, 2.0 * PI / w).unwrap();
    assert_close(&x, &q0);
    assert_close(&v, &v0);
    // With E the exact solution (gyration plus E × B drift) solves the equations of motion.
    let drifting = scene.with_electric_field(0.7, -1.3);
    let dsys = drifting.system();
    for t in [0.2, 1.0, 3.3] {
        let pos = |t| drifting.exact_solution(q0, v0, t).unwrap()[0];
        let [d1, d2] = derivatives(pos, t, 1e-3);
        let [x, v] = drifting.exact_solution(q0, v0, t).unwrap();
        let a = acc(&dsys, t, &x, &v);
        for i in 0..2 {
            assert_relative_eq!(d1[i], v[i], epsilon = 1e-9);
            assert_relative_eq!(d2[i], a[i], epsilon = 1e-6);
        }
    }
    assert!(matches!(
        ChargedParticle::new(0.5, 1.6, 0.0).exact_solution(q0, v0, 1.0),
        Err(Error::InvalidInput { .. })
    ));
}

#[test]
fn exact_state_kepler_general_orbit() {
    // μ = 3, a = 2, e = 0.6: the exact state keeps E and L and satisfies q̈ = −μ q/|q|³.
    let k = Kepler::new(1.5, 3.0);
    let (a, e) = (2.0, 0.6);
    let (q0, qd0) = k.exact_state(a, e, 0.0).unwrap();
    let (p0, v0) = k.periapsis_state(a, e).unwrap();
    for i in 0..2 {
        assert_relative_eq!(q0[i], p0[i], epsilon = 1e-15);
        assert_relative_eq!(qd0[i], v0[i], epsilon = 1e-14);
    }
    let sys = k.system();
    let h = 1e-4;
    for t in [0.3, 1.7, 4.2, 9.0] {
        let (q, qd) = k.exact_state(a, e, t).unwrap();
        assert_relative_eq!(
            sys.energy(t, &q, &qd).unwrap(),
            k.orbit_energy(a).unwrap(),
            max_relative = 1e-13
        );
        assert_relative_eq!(
            k.angular_momentum(&q, &qd),
            k.orbit_angular_momentum(a, e).unwrap(),
            max_relative = 1e-13
        );
        let (_, vp) = k.exact_state(a, e, t + h).unwrap();
        let (_, vm) = k.exact_state(a, e, t - h).unwrap();
        let acc = k.closed_form_accelerations(&q, &qd);
        for i in 0..2 {
            assert_relative_eq!(
                (vp[i] - vm[i]) / (2.0 * h),
                acc[i],
                epsilon = 1e-7 * (1.0 + acc[i].abs())
            );
        }
    }
    assert!(k.exact_state(a, e, f64::NAN).is_err());
}

/// A particle of mass m in the plane, in polar coordinates (r, φ), in the time-dependent
/// potential U = ½ k(t) r² − ε t r cos φ with k(t) = k₀(1 + ½ sin t), plus `extra` uncoupled
/// unit oscillators (so the same equations run through the one-pass scheme with U folded into
/// it, without, and the chunked scheme).
/// T depends on r, U on t: the accelerations need ∂L/∂q with both parts of L.
struct PolarWell {
    m: f64,
    k0: f64,
    eps: f64,
    extra: usize,
}

impl PolarWell {
    fn stiffness(&self, t: f64) -> f64 {
        self.k0 * (1.0 + 0.5 * t.sin())
    }

    /// By hand: m r̈ = m r φ̇² − k r + ε t cos φ, m r² φ̈ + 2 m r ṙ φ̇ = −ε t r sin φ, ẍ_i = −x_i.
    fn closed_form(&self, t: f64, q: &[f64], qd: &[f64]) -> Vec<f64> {
        let (r, phi, rd, phid) = (q[0], q[1], qd[0], qd[1]);
        let mut a = vec![
            r * phid * phid + (-self.stiffness(t) * r + self.eps * t * phi.cos()) / self.m,
            (-self.eps * t * r * phi.sin() - 2.0 * self.m * r * rd * phid) / (self.m * r * r),
        ];
        a.extend(q[2..].iter().map(|x| -x));
        a
    }
}

impl lagrangian::KineticEnergy for PolarWell {
    fn kinetic<D: lagrangian::Scalar>(&self, _t: D, q: &[D], qd: &[D]) -> D {
        let r = q[0];
        let mut t = (qd[0] * qd[0] + r * r * qd[1] * qd[1]) * (0.5 * self.m);
        for v in &qd[2..] {
            t += *v * *v * 0.5;
        }
        t
    }
    fn depends_on_time(&self) -> bool {
        false
    }
}

impl lagrangian::Potential for PolarWell {
    fn potential<D: lagrangian::Scalar>(&self, t: D, q: &[D]) -> D {
        let k = ((t.sin() * 0.5) + 1.0) * self.k0;
        let mut u = k * q[0] * q[0] * 0.5 - t * q[0] * q[1].cos() * self.eps;
        for x in &q[2..] {
            u += *x * *x * 0.5;
        }
        u
    }
}

#[test]
fn time_dependent_potential_with_position_dependent_kinetic_energy() {
    for extra in [0, 1, 3] {
        let well = PolarWell {
            m: 1.7,
            k0: 2.3,
            eps: 0.6,
            extra,
        };
        let n = 2 + well.extra;
        let sys = lagrangian::System::new(n, well).with_potential(PolarWell {
            m: 1.7,
            k0: 2.3,
            eps: 0.6,
            extra,
        });
        for (t, mut q, qd) in states(n) {
            q[0] = 0.5 + q[0].abs();
            assert_close(&acc(&sys, t, &q, &qd), &sys.kinetic.closed_form(t, &q, &qd));
        }
    }
}
