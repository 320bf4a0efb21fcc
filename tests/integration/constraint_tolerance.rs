//! How closely a constrained run holds its constraints, and what it does at a change point
//! (issue 49's defects 1 and 3), against closed forms and conserved quantities: a row's
//! tolerance is its own (a coordinate it does not read, or one that winds without bound, does
//! not loosen it), and a parallelogram four-bar either stays on its branch with bounded
//! multipliers or stops with the typed error at the change point.

use super::constraints::{Diagonal, Linear, Row, holonomic};
use lagrangian::integrators::{Method, Options, Solution, solve};
use lagrangian::{Constrained, Constraints, Dynamics, Error, KineticEnergy, Potential, Scalar};
use lagrangian::{PROJECTION_TOLERANCE, System};

const G: f64 = 9.81;

/// The largest |gᵢ| over the outputs with index in `range`.
fn position_residual<S: Dynamics, C: Constraints>(
    system: &Constrained<S, C>,
    sol: &Solution,
    range: std::ops::Range<usize>,
) -> f64 {
    range
        .map(|i| {
            let r = system
                .residuals(sol.t[i], sol.q_at(i), sol.qd_at(i))
                .unwrap();
            r.position.amax()
        })
        .fold(0.0, f64::max)
}

#[test]
fn a_free_coordinate_does_not_loosen_the_rod() {
    // A pendulum rod x² + y² = 1 beside a free coordinate z (T = ½(ẋ² + ẏ² + ż²), U = g y):
    // z = ż t exactly, and the rod holds to the same residual whether z stays at 0 or runs to
    // 10⁵ (it was judged against the largest |q|: 2.7e-5 at ż = 1000 against 1.7e-8).
    let pendulum = Constrained::new(
        System::new(3, Diagonal(vec![1.0; 3])).with_potential(Linear(vec![0.0, G, 0.0])),
        holonomic(&[Row::Circle(1.0)]),
    );
    let th = 0.7_f64;
    let (t_end, tol) = (100.0, 1e-8);
    let options = Options::adaptive(tol, tol);
    let mut residuals = Vec::new();
    for zd in [0.0, 1000.0] {
        let q0 = [th.sin(), -th.cos(), 0.0];
        let qd0 = [0.0, 0.0, zd];
        let sol = solve(&pendulum, &q0, &qd0, (0.0, t_end), Method::Dop853, &options).unwrap();
        let worst = position_residual(&pendulum, &sol, 0..sol.len());
        // Each row within atol + rtol·ℓ (ℓ ≤ 1) as a distance |g| / max|∂g/∂q| = |g| / 2|x|_max.
        assert!(worst <= 2.0 * 2.0 * tol, "ż = {zd}: residual {worst:e}");
        // The statistics report it: the worst after any step, at least the outputs' worst.
        let stats = sol.stats.constraint_residual;
        assert!(stats >= worst && stats <= 4.0 * tol, "ż = {zd}: {stats:e}");
        assert!(sol.stats.projections > 0);
        // z = ż t, and the pendulum's own energy ½(ẋ² + ẏ²) + g y is conserved.
        let e = |i: usize| {
            let (q, v) = (sol.q_at(i), sol.qd_at(i));
            0.5 * (v[0] * v[0] + v[1] * v[1]) + G * q[1]
        };
        let e0 = e(0);
        for i in 0..sol.len() {
            let z = sol.q_at(i)[2];
            assert!(
                (z - zd * sol.t[i]).abs() <= 1e-9 * (1.0 + z.abs()),
                "z = {z}"
            );
            assert!((e(i) - e0).abs() < 1e-5, "energy {} against {e0}", e(i));
        }
        residuals.push(worst);
    }
    assert!(residuals[1] <= 3.0 * residuals[0].max(tol), "{residuals:?}");
}

/// A planar four-bar in its three link angles: crank a from the origin, coupler b, rocker c
/// from the ground pivot (d, 0); uniform rods of unit mass, gravity g along −y.
struct FourBar {
    a: f64,
    b: f64,
    c: f64,
    d: f64,
    g: f64,
}

impl KineticEnergy for FourBar {
    fn kinetic<D: Scalar>(&self, _t: D, q: &[D], qd: &[D]) -> D {
        let (a, b, c) = (self.a, self.b, self.c);
        // The coupler's centre moves with the crank's tip and turns with θ₂.
        let vx = -(q[0].sin() * qd[0]) * a - q[1].sin() * qd[1] * (b / 2.0);
        let vy = q[0].cos() * qd[0] * a + q[1].cos() * qd[1] * (b / 2.0);
        qd[0] * qd[0] * (a * a / 6.0)
            + qd[2] * qd[2] * (c * c / 6.0)
            + (vx * vx + vy * vy) * 0.5
            + qd[1] * qd[1] * (b * b / 24.0)
    }
    fn depends_on_time(&self) -> bool {
        false
    }
}

impl Potential for FourBar {
    fn potential<D: Scalar>(&self, _t: D, q: &[D]) -> D {
        let (a, b, c) = (self.a, self.b, self.c);
        (q[0].sin() * (a / 2.0) + q[0].sin() * a + q[1].sin() * (b / 2.0) + q[2].sin() * (c / 2.0))
            * self.g
    }
    fn depends_on_time(&self) -> bool {
        false
    }
}

impl Constraints for FourBar {
    fn holonomic_count(&self) -> usize {
        2
    }
    fn holonomic<D: Scalar>(&self, _t: D, q: &[D], out: &mut [D]) {
        let (a, b, c, d) = (self.a, self.b, self.c, self.d);
        out[0] = q[0].cos() * a + q[1].cos() * b - q[2].cos() * c - d;
        out[1] = q[0].sin() * a + q[1].sin() * b - q[2].sin() * c;
    }
    fn depends_on_time(&self) -> bool {
        false
    }
    fn name(&self, row: usize) -> String {
        ["loop x", "loop y"][row].into()
    }
}

fn four_bar(
    a: f64,
    b: f64,
    c: f64,
    d: f64,
    g: f64,
) -> Constrained<System<FourBar, FourBar>, FourBar> {
    let link = || FourBar { a, b, c, d, g };
    Constrained::new(System::new(3, link()).with_potential(link()), link())
}

/// A consistent state of the four-bar with the crank at `th1` turning at `w1`, the coupler's
/// far joint on the side `branch` (±1) of the line from the crank's tip to the ground pivot.
fn four_bar_state([a, b, c, d]: [f64; 4], th1: f64, w1: f64, branch: f64) -> ([f64; 3], [f64; 3]) {
    let (ax, ay) = (a * th1.cos(), a * th1.sin());
    let (ex, ey) = (d - ax, -ay);
    let l = ex.hypot(ey);
    let along = (b * b - c * c + l * l) / (2.0 * l);
    let h = (b * b - along * along).sqrt();
    let (ux, uy) = (ex / l, ey / l);
    let (bx, by) = (
        ax + along * ux - branch * h * uy,
        ay + along * uy + branch * h * ux,
    );
    let th2 = (by - ay).atan2(bx - ax);
    let th3 = by.atan2(bx - d);
    // G [ω₁ ω₂ ω₃]ᵀ = 0 for ω₂, ω₃ by Cramer's rule.
    let (g11, g12, g13) = (-a * th1.sin(), -b * th2.sin(), c * th3.sin());
    let (g21, g22, g23) = (a * th1.cos(), b * th2.cos(), -c * th3.cos());
    let (r1, r2) = (-g11 * w1, -g21 * w1);
    let det = g12 * g23 - g13 * g22;
    let w2 = (r1 * g23 - g13 * r2) / det;
    let w3 = (g12 * r2 - r1 * g22) / det;
    ([th1, th2, th3], [w1, w2, w3])
}

#[test]
fn a_winding_crank_does_not_drift() {
    // A Grashof crank-rocker (a = 1, b = 3, c = 2, d = 3) without gravity: the crank winds round
    // to θ₁ ≈ 700 rad by t = 200. Its loop residual stays at the tolerance, the same in the
    // second half of the run as in the first (judged against |θ₁| it grew linearly), and the
    // energy is conserved.
    let bar = four_bar(1.0, 3.0, 2.0, 3.0, 0.0);
    let (q0, qd0) = four_bar_state([1.0, 3.0, 2.0, 3.0], std::f64::consts::FRAC_PI_2, 3.0, 1.0);
    let e0 = bar.energy(0.0, &q0, &qd0).unwrap();
    let tol = 1e-6;
    let options = Options::adaptive(tol, tol);
    let sol = solve(&bar, &q0, &qd0, (0.0, 200.0), Method::Dop853, &options).unwrap();
    let (_, q_end, _) = sol.last().unwrap();
    assert!(q_end[0] > 600.0, "the crank turned to {}", q_end[0]);
    let half = sol.len() / 2;
    let first = position_residual(&bar, &sol, 0..half);
    let second = position_residual(&bar, &sol, half..sol.len());
    // |g| ≤ max|∂g/∂q| (atol + rtol) ≤ 3 · 2 tol.
    assert!(
        first <= 6.0 * tol && second <= 6.0 * tol,
        "{first:e}, {second:e}"
    );
    // The statistics report the worst after any step, velocities too: |ġ| ≤ 3 (atol + rtol |q̇|).
    let v_max = (0..sol.len())
        .flat_map(|i| sol.qd_at(i).iter().map(|v| v.abs()))
        .fold(0.0, f64::max);
    let stats = sol.stats.constraint_residual;
    assert!(stats >= first.max(second) && stats <= 3.0 * tol * (1.0 + v_max));
    let energy = (0..sol.len())
        .map(|i| (bar.energy(sol.t[i], sol.q_at(i), sol.qd_at(i)).unwrap() - e0).abs())
        .fold(0.0, f64::max);
    assert!(energy < 1e-2 * e0, "energy error {energy:e} of {e0}");
}

/// The times at which the parallelogram four-bar (a = c = 1, b = d = 2, g = 9.81) started at
/// θ₁ = π/2 with θ̇₁ = 3 on its parallelogram branch (θ₂ = 0, θ₃ = θ₁) reaches θ₁ = π and 2π,
/// its change points: on the branch J θ̇²/2 + 2 g sin θ is conserved (J = 1/3 + 1/3 + 1), so
/// t(θ) = ∫ dθ / θ̇, by composite Simpson's rule.
fn change_points() -> [f64; 2] {
    let j = 5.0 / 3.0;
    let rate = |th: f64| (9.0 + 4.0 * G * (1.0 - th.sin()) / j).sqrt();
    let simpson = |from: f64, to: f64| {
        let n = 4000;
        let h = (to - from) / n as f64;
        let sum: f64 = (0..=n)
            .map(|i| {
                let w = if i == 0 || i == n {
                    1.0
                } else if i % 2 == 1 {
                    4.0
                } else {
                    2.0
                };
                w / rate(from + h * i as f64)
            })
            .sum();
        sum * h / 3.0
    };
    let pi = std::f64::consts::PI;
    let first = simpson(pi / 2.0, pi);
    [first, first + simpson(pi, 2.0 * pi)]
}

#[test]
fn a_change_point_is_never_crossed_onto_the_other_branch() {
    // All four links collinear at θ₁ = π, 2π (G of rank 1): a run either goes on along the
    // parallelogram (θ₂ = 0, θ₃ = θ₁, multipliers bounded, energy conserved), or stops with
    // DependentConstraints at a change point; never onto the antiparallelogram with
    // multipliers of 10¹³ (which default tolerances did).
    let bar = four_bar(1.0, 2.0, 1.0, 2.0, G);
    let half_pi = std::f64::consts::FRAC_PI_2;
    let (q0, qd0) = ([half_pi, 0.0, half_pi], [3.0, 0.0, 3.0]);
    let e0 = bar.energy(0.0, &q0, &qd0).unwrap();
    let typical = bar.evaluate(0.0, &q0, &qd0).unwrap().multipliers.amax();
    let stops = change_points();
    let mut outcomes = Vec::new();
    for method in [Method::Dop853, Method::Dopri5, Method::Radau5] {
        for (rtol, atol) in [(1e-6, 1e-9), (1e-8, 1e-8), (1e-10, 1e-10)] {
            let options = Options::adaptive(rtol, atol);
            match solve(&bar, &q0, &qd0, (0.0, 1.0), method, &options) {
                Err(Error::DependentConstraints { t, row, .. }) => {
                    let near = stops.iter().any(|s| (t - s).abs() < 1e-4);
                    assert!(
                        near,
                        "{method} at {rtol}: stopped at t = {t}, not at {stops:?}"
                    );
                    assert!(row.starts_with("loop"));
                    outcomes.push("stopped");
                }
                Err(e) => panic!("{method} at {rtol}: {e}"),
                Ok(sol) => {
                    for i in 0..sol.len() {
                        let (q, qd) = (sol.q_at(i), sol.qd_at(i));
                        let on_branch = q[1].abs().max((q[2] - q[0]).abs());
                        assert!(
                            on_branch < 1e-5,
                            "{method} at {rtol}: left the branch: {q:?}"
                        );
                        let lambda = bar.evaluate(sol.t[i], q, qd).unwrap().multipliers.amax();
                        assert!(lambda < 1e3 * typical, "{method} at {rtol}: λ = {lambda:e}");
                        let e = bar.energy(sol.t[i], q, qd).unwrap();
                        assert!((e - e0).abs() < 1e3 * rtol * e0, "{method}: energy {e}");
                    }
                    outcomes.push("went on");
                }
            }
        }
    }
    assert_eq!(outcomes.len(), 9);
}

#[test]
fn a_run_of_fixed_steps_holds_each_row_to_its_own_scale() {
    // RK4 at fixed steps: the rod holds to PROJECTION_TOLERANCE as a distance, with z at 10⁴.
    let pendulum = Constrained::new(
        System::new(3, Diagonal(vec![1.0; 3])).with_potential(Linear(vec![0.0, G, 0.0])),
        holonomic(&[Row::Circle(1.0)]),
    );
    let q0 = [0.6_f64.sin(), -0.6_f64.cos(), 0.0];
    let options = Options::fixed(1e-2);
    let sol = solve(
        &pendulum,
        &q0,
        &[0.0, 0.0, 1e3],
        (0.0, 10.0),
        Method::Rk4,
        &options,
    )
    .unwrap();
    let worst = position_residual(&pendulum, &sol, 0..sol.len());
    assert!(worst <= 4.0 * PROJECTION_TOLERANCE, "{worst:e}");
    assert!(sol.stats.constraint_residual <= 4.0 * PROJECTION_TOLERANCE);
}
