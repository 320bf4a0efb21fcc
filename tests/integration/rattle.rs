//! RATTLE (issue 41 item 3): the explicit splittings on constrained separable systems and the
//! midpoint variational integrator's constrained step, against closed forms, with the
//! constraint residual at round-off and the energy error bounded over long runs.

use super::constrained_motion::Still;
use super::constraints::{Diagonal, Linear, PushX, Row, Rows, VRow, holonomic, point};
use lagrangian::integrators::{Method, Options, Output, Solution, solve};
use lagrangian::scenes::{DoublePendulum, elliptic_k};
use lagrangian::{Constrained, Constraints, Dynamics, Error, Scalar, System};

const G: f64 = 9.81;

fn pendulum(m: f64, l: f64) -> Constrained<System<Diagonal, Linear>, Rows> {
    Constrained::new(point(m, true), holonomic(&[Row::Circle(l)]))
}

/// The largest |g| and |ġ| over every output state of `sol`.
fn worst_residual<S: Dynamics, C: Constraints>(system: &Constrained<S, C>, sol: &Solution) -> f64 {
    (0..sol.len())
        .map(|i| {
            system
                .residuals(sol.t[i], sol.q_at(i), sol.qd_at(i))
                .unwrap()
                .max_abs()
        })
        .fold(0.0, f64::max)
}

/// The largest |E − E₀| over the outputs with index in `range`.
fn energy_error<S: Dynamics>(
    system: &S,
    sol: &Solution,
    e0: f64,
    range: std::ops::Range<usize>,
) -> f64 {
    range
        .map(|i| (system.energy(sol.t[i], sol.q_at(i), sol.qd_at(i)).unwrap() - e0).abs())
        .fold(0.0, f64::max)
}

/// Released from rest at θ₀, the pendulum passes the bottom (x = 0, y = −l, at full speed, so
/// that a phase error shows at first order) at t = 5T/4, T = 4 √(l/g) K(sin(θ₀/2)): the largest
/// error of q there with `steps` steps of `method`.
fn period_error(method: Method, steps: usize) -> f64 {
    let (m, l, th0) = (0.9, 1.3, 2.0_f64);
    let p = pendulum(m, l);
    let t = 5.0 * (l / G).sqrt() * elliptic_k((th0 / 2.0).sin()).unwrap();
    let q0 = [l * th0.sin(), -l * th0.cos()];
    let options = Options::fixed(t / steps as f64).with_output(Output::Every(steps));
    let sol = solve(&p, &q0, &[0.0, 0.0], (0.0, t), method, &options).unwrap();
    assert_eq!(sol.stats.accepted_steps, steps);
    let residual = sol.stats.constraint_residual;
    assert!(residual < 1e-13, "{method}: {residual:e}");
    let (_, q, _) = sol.last().unwrap();
    q[0].abs().max((q[1] + l).abs())
}

#[test]
fn a_million_rattle_steps_stay_on_the_circle_with_bounded_energy() {
    // Issue 41's target: the constraint residual after 10⁶ RATTLE steps ≤ 1e-12. Störmer–
    // Verlet as RATTLE, θ₀ = 1 rad, h = 0.01 (≈ 0.5 % of the period), t = 10⁴ (≈ 4900 periods).
    let (m, l, th0) = (1.0, 1.0, 1.0_f64);
    let p = Constrained::new(point(m, true), Still(holonomic(&[Row::Circle(l)])));
    let q0 = [l * th0.sin(), -l * th0.cos()];
    let e0 = p.energy(0.0, &q0, &[0.0, 0.0]).unwrap();
    let steps = 1_000_000;
    let options = Options::fixed(0.01).with_output(Output::Every(100));
    let sol = solve(
        &p,
        &q0,
        &[0.0, 0.0],
        (0.0, 1e4),
        Method::StormerVerlet,
        &options,
    )
    .unwrap();
    assert_eq!(sol.stats.accepted_steps, steps);
    // Worst |g|, |ġ| over every step (the run's statistic) and over the outputs.
    let worst = sol.stats.constraint_residual;
    eprintln!("RATTLE-Verlet, 10⁶ steps: worst residual {worst:e}");
    assert!(worst <= 1e-12, "{worst:e}");
    assert!(worst_residual(&p, &sol) <= 1e-12);
    assert_eq!(sol.stats.projections, 0);
    // Bounded energy error, no drift: the worst error over the last tenth of the run is no
    // larger than over the first tenth (up to the sampling of the oscillation), and small.
    let len = sol.len();
    let first = energy_error(&p, &sol, e0, 0..len / 10);
    let last = energy_error(&p, &sol, e0, len - len / 10..len);
    eprintln!("RATTLE-Verlet energy error: first tenth {first:e}, last tenth {last:e} (E₀ = {e0})");
    // Against the oscillation's energy m g l (1 − cos θ₀): an O(h²) error.
    let swing = m * G * l * (1.0 - th0.cos());
    assert!(first < 5e-4 * swing, "{first:e}");
    assert!(last < 1.2 * first, "drift: {first:e} then {last:e}");
}

#[test]
fn yoshida4_as_rattle_holds_the_circle_and_the_energy() {
    // 10⁵ steps of the triple jump: 3·10⁵ RATTLE steps.
    let (m, l, th0) = (1.0, 1.0, 1.0_f64);
    let p = pendulum(m, l);
    let q0 = [l * th0.sin(), -l * th0.cos()];
    let e0 = p.energy(0.0, &q0, &[0.0, 0.0]).unwrap();
    let options = Options::fixed(0.02).with_output(Output::Every(50));
    let sol = solve(&p, &q0, &[0.0, 0.0], (0.0, 2e3), Method::Yoshida4, &options).unwrap();
    assert_eq!(sol.stats.accepted_steps, 100_000);
    let worst = sol.stats.constraint_residual;
    assert!(worst <= 1e-12, "{worst:e}");
    assert!(worst_residual(&p, &sol) <= 1e-12);
    let len = sol.len();
    let first = energy_error(&p, &sol, e0, 0..len / 10);
    let last = energy_error(&p, &sol, e0, len - len / 10..len);
    eprintln!(
        "RATTLE-Yoshida4: residual {worst:e}, energy error first tenth {first:e}, last tenth {last:e}"
    );
    let swing = m * G * l * (1.0 - th0.cos());
    assert!(first < 1e-5 * swing, "{first:e}");
    assert!(last < 1.2 * first, "drift: {first:e} then {last:e}");
}

#[test]
fn rattle_orders_on_the_elliptic_period() {
    for (method, coarse, order) in [
        (Method::StormerVerlet, 400, 2.0),
        (Method::Yoshida4, 100, 4.0),
        (Method::Yoshida6, 100, 6.0),
        (Method::Midpoint, 400, 2.0),
    ] {
        let e1 = period_error(method, coarse);
        let e2 = period_error(method, 2 * coarse);
        let rate = (e1 / e2).log2();
        eprintln!(
            "{method}: error {e1:e} at {coarse} steps, {e2:e} at {}: order {rate:.3}",
            2 * coarse
        );
        assert!(
            (rate - order).abs() < 0.15,
            "{method}: order {rate} (errors {e1:e}, {e2:e})"
        );
    }
}

#[test]
fn constrained_midpoint_holds_the_circle_and_the_energy() {
    // 2·10⁴ steps of the constrained variational midpoint (≈ 100 periods).
    let (m, l, th0) = (1.0, 1.0, 1.0_f64);
    let p = pendulum(m, l);
    let q0 = [l * th0.sin(), -l * th0.cos()];
    let e0 = p.energy(0.0, &q0, &[0.0, 0.0]).unwrap();
    let options = Options::fixed(0.01).with_output(Output::Every(10));
    let sol = solve(
        &p,
        &q0,
        &[0.0, 0.0],
        (0.0, 200.0),
        Method::Midpoint,
        &options,
    )
    .unwrap();
    assert_eq!(sol.stats.accepted_steps, 20_000);
    assert_eq!(sol.stats.newton_failures, 0);
    let worst = sol.stats.constraint_residual;
    assert!(worst <= 1e-12, "{worst:e}");
    assert!(worst_residual(&p, &sol) <= 1e-12);
    let len = sol.len();
    let first = energy_error(&p, &sol, e0, 0..len / 10);
    let last = energy_error(&p, &sol, e0, len - len / 10..len);
    eprintln!(
        "constrained midpoint: residual {worst:e}, energy error first tenth {first:e}, last tenth {last:e}"
    );
    let swing = m * G * l * (1.0 - th0.cos());
    assert!(first < 5e-4 * swing, "{first:e}");
    assert!(last < 1.2 * first, "drift: {first:e} then {last:e}");
}

/// Two rods in Cartesian coordinates (x₁, y₁, x₂, y₂): x₁² + y₁² = l₁², |p₂ − p₁|² = l₂².
struct Rods(f64, f64);
impl Constraints for Rods {
    fn holonomic_count(&self) -> usize {
        2
    }
    fn holonomic<D: Scalar>(&self, _t: D, q: &[D], out: &mut [D]) {
        let (dx, dy) = (q[2] - q[0], q[3] - q[1]);
        out[0] = q[0] * q[0] + q[1] * q[1] - self.0 * self.0;
        out[1] = dx * dx + dy * dy - self.1 * self.1;
    }
    fn name(&self, row: usize) -> String {
        ["upper rod", "lower rod"][row].into()
    }
}

#[test]
fn cartesian_double_pendulum_with_rattle_follows_the_angle_form() {
    // The same double pendulum in angles (the scene, minimal coordinates) integrated by
    // DOP853 to 1e-13: Yoshida4 as RATTLE in Cartesian coordinates with two rods agrees to
    // its O(h⁴) error at t = 3, stays on both rods, and holds the energy.
    let (m1, m2, l1, l2) = (1.0, 0.7, 1.0, 0.8);
    let cart = Constrained::new(
        System::new(4, Diagonal(vec![m1, m1, m2, m2])).with_potential(Linear(vec![
            0.0,
            m1 * G,
            0.0,
            m2 * G,
        ])),
        Rods(l1, l2),
    );
    let angles = DoublePendulum::new(m1, m2, l1, l2, G).system();
    let (a1, a2, w1, w2) = (1.2_f64, -0.5_f64, 0.3, -0.8);
    let to_cart = |a: &[f64], w: &[f64]| {
        let (s1, c1, s2, c2) = (a[0].sin(), a[0].cos(), a[1].sin(), a[1].cos());
        (
            [l1 * s1, -l1 * c1, l1 * s1 + l2 * s2, -l1 * c1 - l2 * c2],
            [
                l1 * c1 * w[0],
                l1 * s1 * w[0],
                l1 * c1 * w[0] + l2 * c2 * w[1],
                l1 * s1 * w[0] + l2 * s2 * w[1],
            ],
        )
    };
    let (q0, qd0) = to_cart(&[a1, a2], &[w1, w2]);
    let t = 3.0;
    let reference = solve(
        &angles,
        &[a1, a2],
        &[w1, w2],
        (0.0, t),
        Method::Dop853,
        &Options::adaptive(1e-13, 1e-13),
    )
    .unwrap();
    let (_, a, w) = reference.last().unwrap();
    let (q_ref, qd_ref) = to_cart(a, w);
    let e0 = cart.energy(0.0, &q0, &qd0).unwrap();
    let mut errors = Vec::new();
    for steps in [3000, 6000] {
        let options = Options::fixed(t / steps as f64).with_output(Output::Every(10));
        let sol = solve(&cart, &q0, &qd0, (0.0, t), Method::Yoshida4, &options).unwrap();
        assert!(
            sol.stats.constraint_residual < 1e-12,
            "{:e}",
            sol.stats.constraint_residual
        );
        assert!(worst_residual(&cart, &sol) < 1e-12);
        let de = energy_error(&cart, &sol, e0, 0..sol.len());
        assert!(de < 1e-8 * e0.abs(), "energy error {de:e} (E₀ = {e0})");
        let (_, q, qd) = sol.last().unwrap();
        let err = (0..4)
            .map(|i| {
                (q[i] - q_ref[i])
                    .abs()
                    .max((qd[i] - qd_ref[i]).abs() / 10.0)
            })
            .fold(0.0, f64::max);
        errors.push(err);
    }
    eprintln!("double pendulum, yoshida4 errors {errors:?}");
    assert!(errors[1] < 1e-9, "{errors:?}");
    assert!(errors[0] / errors[1] > 12.0, "{errors:?}");
}

#[test]
fn rattle_follows_a_moving_constraint() {
    // A bead on a wire turning at ω (∂g/∂t ≠ 0 in the velocity stage): r = r₀ cosh ωt, order 2.
    let (m, w, r0) = (0.5, 1.2, 0.3);
    let bead = Constrained::new(point(m, false), holonomic(&[Row::Wire(w)]));
    let t = 1.5;
    let exact = r0 * (w * t).cosh();
    let error = |steps: usize| {
        let options = Options::fixed(t / steps as f64);
        let sol = solve(
            &bead,
            &[r0, 0.0],
            &[0.0, w * r0],
            (0.0, t),
            Method::StormerVerlet,
            &options,
        )
        .unwrap();
        assert!(sol.stats.constraint_residual < 1e-13);
        assert!(worst_residual(&bead, &sol) < 1e-13);
        let (_, q, _) = sol.last().unwrap();
        assert!((q[1].atan2(q[0]) - w * t).abs() < 1e-13);
        (q[0].hypot(q[1]) - exact).abs()
    };
    let (e1, e2) = (error(200), error(400));
    assert!(e1 < 1e-4 * exact, "{e1:e}");
    assert!(((e1 / e2).log2() - 2.0).abs() < 0.1, "{e1:e} {e2:e}");
}

#[test]
fn an_event_finds_the_quarter_period_on_the_rattle_interpolant() {
    // The interpolant's ends carry the constrained q̈: x = 0 is found at T/4 to the method's
    // error there, and the Gauss methods say what serves a constrained model.
    let (m, l, th0) = (1.0, 0.7, 1.0_f64);
    let p = pendulum(m, l);
    let quarter = (l / G).sqrt() * elliptic_k((th0 / 2.0).sin()).unwrap();
    let q0 = [l * th0.sin(), -l * th0.cos()];
    let mut errors = Vec::new();
    for dt in [1e-3, 5e-4] {
        let options = Options::fixed(dt).with_event(
            lagrangian::integrators::Event::new("x = 0", |_t, q, _qd| q[0]).terminal(1),
        );
        let sol = solve(
            &p,
            &q0,
            &[0.0, 0.0],
            (0.0, 10.0),
            Method::Yoshida4,
            &options,
        )
        .unwrap();
        let (t, q, _) = sol.last().unwrap();
        assert!(q[0].abs() < 1e-12 && (q[1] + l).abs() < 1e-9, "{q:?}");
        errors.push((t - quarter).abs());
    }
    assert!(
        errors[0] < 1e-9 && errors[1] < errors[0] / 8.0,
        "{errors:?}"
    );
    match solve(
        &p,
        &q0,
        &[0.0, 0.0],
        (0.0, 1.0),
        Method::Gauss4,
        &Options::fixed(0.01),
    ) {
        Err(Error::UnsupportedMethod { why, .. }) => assert!(why.contains("RATTLE"), "{why}"),
        other => panic!("{other:?}"),
    }
}

#[test]
fn rattle_and_the_constrained_midpoint_are_time_reversible() {
    // Symmetric methods: 2000 steps forward, then 2000 steps back from the end state with the
    // velocities reversed, land on the start to round-off (the merged half kicks of the
    // composed RATTLE steps and the velocity stage keep the symmetry).
    let (m, l, th0) = (1.0, 1.0, 1.3_f64);
    let p = pendulum(m, l);
    let q0 = [l * th0.sin(), -l * th0.cos()];
    let qd0 = [0.4 * th0.cos(), 0.4 * th0.sin()];
    for method in [Method::StormerVerlet, Method::Yoshida4, Method::Midpoint] {
        let options = Options::fixed(0.01).with_output(Output::Every(2000));
        let there = solve(&p, &q0, &qd0, (0.0, 20.0), method, &options).unwrap();
        let (_, q1, qd1) = there.last().unwrap();
        let back: Vec<f64> = qd1.iter().map(|v| -v).collect();
        let sol = solve(&p, q1, &back, (0.0, 20.0), method, &options).unwrap();
        let (_, q, qd) = sol.last().unwrap();
        let err = (0..2)
            .map(|i| (q[i] - q0[i]).abs().max((qd[i] + qd0[i]).abs()))
            .fold(0.0, f64::max);
        assert!(err < 1e-11, "{method}: {err:e}");
    }
}

#[test]
fn a_drift_that_cannot_reach_the_circle_is_a_newton_failure() {
    // A free particle on the unit circle at speed 3 with h = 0.5: the drift's line q̃ − sW
    // (radial through q̃, 1.5 from the origin) never meets the circle. A typed error in a
    // bounded number of iterations, never a hang or NaN.
    let ring = Constrained::new(point(1.0, false), holonomic(&[Row::Circle(1.0)]));
    for method in [Method::StormerVerlet, Method::Yoshida4] {
        match solve(
            &ring,
            &[1.0, 0.0],
            &[0.0, 3.0],
            (0.0, 2.0),
            method,
            &Options::fixed(0.5),
        ) {
            Err(Error::NewtonFailure { t, iterations, .. }) => {
                // Dated by the failing step's start, the first.
                assert!(t == 0.0 && iterations <= 30, "{method}: {t} {iterations}");
            }
            other => panic!("{method}: {other:?}"),
        }
    }
}

#[test]
fn splittings_refuse_what_rattle_does_not_hold() {
    // Blanes–Moan is not a composition of Verlet steps; a velocity row has no drift equation.
    let p = pendulum(1.0, 1.0);
    match solve(
        &p,
        &[0.0, -1.0],
        &[0.5, 0.0],
        (0.0, 1.0),
        Method::BlanesMoan4,
        &Options::fixed(0.01),
    ) {
        Err(Error::UnsupportedMethod { why, fits, .. }) => {
            assert!(why.contains("composition"), "{why}");
            assert!(fits.contains(&"yoshida4"), "{fits:?}");
        }
        other => panic!("{other:?}"),
    }
    let knife = Constrained::new(
        System::new(3, Diagonal(vec![1.0, 1.0, 0.2])).with_forces(PushX(0.0)),
        Rows {
            holonomic: Vec::new(),
            velocity: vec![VRow::Knife],
        },
    );
    for method in [Method::StormerVerlet, Method::Yoshida4, Method::Midpoint] {
        match solve(
            &knife,
            &[0.0; 3],
            &[1.0, 0.0, 0.5],
            (0.0, 1.0),
            method,
            &Options::fixed(0.01),
        ) {
            Err(Error::UnsupportedMethod { why, fits, .. }) => {
                assert!(
                    why.contains("velocity (nonholonomic) rows"),
                    "{method}: {why}"
                );
                assert_eq!(fits, ["rk4", "dopri5", "dop853", "radau5"], "{method}");
            }
            other => panic!("{method}: {other:?}"),
        }
    }
}
