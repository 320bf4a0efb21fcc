//! Failures keep what was computed: [`solve_partial`] on a run that blows up (ẍ = x²) returns
//! the trajectory up to the last accepted step, and it agrees with the closed form there.

use crate::common::UnitMass;
use lagrangian::integrators::{Failed, Method, Options, Output, solve, solve_partial};
use lagrangian::{Error, Potential, Scalar, System};

/// U = −x³/3: ẍ = x².
#[derive(Debug, Clone, Copy)]
struct Cubic;
impl Potential for Cubic {
    fn potential<D: Scalar>(&self, _t: D, q: &[D]) -> D {
        -q[0].powi(3) * (1.0 / 3.0)
    }
    fn depends_on_time(&self) -> bool {
        false
    }
}

/// From x₀ with ẋ₀ = √(2/3) x₀^{3/2} (energy 0): x = x₀ / (1 − √(x₀/6) t)², which blows up at
/// t* = √(6/x₀). Returns (x, ẋ).
fn exact(x0: f64, t: f64) -> (f64, f64) {
    let a = (x0 / 6.0).sqrt();
    let s = 1.0 - a * t;
    (x0 / (s * s), 2.0 * x0 * a / (s * s * s))
}

const X0: f64 = 1.0;

fn start() -> ([f64; 1], [f64; 1]) {
    ([X0], [(2.0_f64 / 3.0).sqrt() * X0.powf(1.5)])
}

fn blow_up_time() -> f64 {
    (6.0 / X0).sqrt()
}

/// The failure of a run of ẍ = x² from [`start`] over (0, `t_end`).
fn blow_up(method: Method, options: &Options, t_end: f64) -> Failed {
    let system = System::new(1, UnitMass).with_potential(Cubic);
    let (q0, qd0) = start();
    solve_partial(&system, &q0, &qd0, (0.0, t_end), method, options, None).unwrap_err()
}

#[test]
fn adaptive_run_that_blows_up_keeps_its_trajectory() {
    let system = System::new(1, UnitMass).with_potential(Cubic);
    let (q0, qd0) = start();
    let options = Options::adaptive(1e-12, 1e-12);
    let failed = blow_up(Method::Dop853, &options, 5.0);
    // The error is the one `solve` returns.
    let plain = solve(&system, &q0, &qd0, (0.0, 5.0), Method::Dop853, &options).unwrap_err();
    assert_eq!(failed.error, plain);
    assert!(
        matches!(
            failed.error,
            Error::StepSizeTooSmall { .. } | Error::NonFinite { .. }
        ),
        "{:?}",
        failed.error
    );
    let sol = failed.partial.as_ref().unwrap();
    let t_star = blow_up_time();
    let t_last = *sol.t.last().unwrap();
    // The run follows the solution up to round-off of t* (x ~ 1e26 there), then the step
    // size collapses.
    assert!((t_last - t_star).abs() < 1e-12, "{t_last} vs {t_star}");
    assert!(sol.q_at(sol.len() - 1)[0] > 1e20);
    assert_eq!(sol.len(), 1 + sol.stats.accepted_steps);
    for i in 0..sol.len() {
        let (t, x) = (sol.t[i], sol.q_at(i)[0]);
        // Where x(t) is well conditioned (1 − t/t* ≥ 1e-4), the state to 1e-6 relative.
        if x <= 1e8 {
            let (x_exact, v_exact) = exact(X0, t);
            let rel = ((x - x_exact) / x_exact)
                .abs()
                .max(((sol.qd_at(i)[0] - v_exact) / v_exact).abs());
            assert!(rel < 1e-6, "t = {t}: relative error {rel:e}");
        }
        // Everywhere, up to the blow-up: the time at which the exact x reaches the computed x,
        // t(x) = (1 − √(x₀/x)) t*, is the time of the point.
        let t_of_x = (1.0 - (X0 / x).sqrt()) * t_star;
        assert!((t_of_x - t).abs() < 1e-9, "t = {t}: t(x) = {t_of_x}");
    }
    let (t, q, qd) = failed.last.clone().unwrap();
    assert_eq!((t, q.as_slice(), qd.as_slice()), sol.last().unwrap());
}

#[test]
fn fixed_step_run_that_blows_up_keeps_its_trajectory() {
    let dt = 1e-3;
    let failed = blow_up(Method::Rk4, &Options::fixed(dt), 5.0);
    let sol = failed.partial.as_ref().unwrap();
    assert_eq!(sol.len(), 1 + sol.stats.accepted_steps);
    let t_last = *sol.t.last().unwrap();
    // RK4's own solution blows up a few steps after t* and overflows.
    assert!((t_last - blow_up_time()).abs() < 0.01, "{t_last}");
    for i in 0..sol.len() {
        assert!(sol.q_at(i)[0].is_finite() && sol.qd_at(i)[0].is_finite());
        // The grid of equal steps over the span.
        assert!((sol.t[i] - i as f64 * dt).abs() < 1e-12);
        if sol.t[i] <= 2.0 {
            let (x, v) = exact(X0, sol.t[i]);
            let rel = ((sol.q_at(i)[0] - x) / x)
                .abs()
                .max(((sol.qd_at(i)[0] - v) / v).abs());
            assert!(rel < 1e-6, "t = {}: relative error {rel:e}", sol.t[i]);
        }
    }
    assert_eq!(failed.last.as_ref().unwrap().0, t_last);
}

#[test]
fn too_many_steps_carries_every_step_taken() {
    let options = Options {
        max_steps: 40,
        ..Options::adaptive(1e-12, 1e-12)
    };
    let failed = blow_up(Method::Dop853, &options, 2.0);
    assert!(matches!(
        failed.error,
        Error::TooManySteps { steps: 40, .. }
    ));
    let sol = failed.partial.unwrap();
    assert_eq!(sol.stats.accepted_steps + sol.stats.rejected_steps, 40);
    assert_eq!(sol.len(), 1 + sol.stats.accepted_steps);
    assert_eq!(failed.last.unwrap().0, *sol.t.last().unwrap());
}

#[test]
fn requested_times_keep_only_those_reached_and_every_keeps_the_last_state() {
    let times: Vec<f64> = (0..=40).map(|k| 0.1 * k as f64).collect();
    let options = Options::adaptive(1e-12, 1e-12).with_output(Output::Times(times.clone()));
    let failed = blow_up(Method::Dop853, &options, 5.0);
    let sol = failed.partial.unwrap();
    let (t_last, _, _) = failed.last.unwrap();
    // Every requested time before the last accepted step, and no other.
    let reached: Vec<f64> = times.iter().copied().filter(|&t| t <= t_last).collect();
    assert_eq!(sol.t, reached);
    assert!(t_last > 0.97 * blow_up_time());

    let options = Options::adaptive(1e-12, 1e-12).with_output(Output::Every(1000));
    let failed = blow_up(Method::Dop853, &options, 5.0);
    let sol = failed.partial.unwrap();
    let (t_last, q_last, _) = failed.last.unwrap();
    assert_eq!(sol.len(), 2);
    assert_eq!(sol.last().unwrap().0, t_last);
    assert_eq!(sol.last().unwrap().1, q_last.as_slice());
}

#[test]
fn bad_input_carries_nothing() {
    let system = System::new(1, UnitMass).with_potential(Cubic);
    let failed = solve_partial(
        &system,
        &[1.0, 2.0],
        &[0.0],
        (0.0, 1.0),
        Method::Dop853,
        &Options::default(),
        None,
    )
    .unwrap_err();
    assert!(matches!(failed.error, Error::DimensionMismatch { .. }));
    assert!(failed.partial.is_none() && failed.last.is_none());
}

/// U = √x: the force −1/(2√x) pulls x to the edge of the model's domain, where U is NaN.
#[derive(Debug, Clone, Copy)]
struct RootWell;
impl Potential for RootWell {
    fn potential<D: Scalar>(&self, _t: D, q: &[D]) -> D {
        q[0].sqrt()
    }
    fn depends_on_time(&self) -> bool {
        false
    }
}

/// From x = ½, ẋ = −3 the motion reaches x = 0 at t* = √2 [2E(√E − √w₀) − ⅔(E^{3/2} − w₀^{3/2})],
/// with E = ẋ²/2 + √x the energy and w₀ = ẋ₀²/2 (u = √x, w = E − u in ∫ dx / √(2(E − √x))).
fn edge_time() -> f64 {
    let w0 = 4.5_f64;
    let e = w0 + 0.5_f64.sqrt();
    2f64.sqrt() * (2.0 * e * (e.sqrt() - w0.sqrt()) - (2.0 / 3.0) * (e.powf(1.5) - w0.powf(1.5)))
}

#[test]
fn non_finite_inside_an_implicit_step_is_reported_as_non_finite() {
    // Every method meets the NaN beyond x = 0 in the step that reaches t*: the explicit ones in
    // their state, the implicit ones inside the Newton iteration of a stage. Both are
    // `NonFinite`, naming the quantity and a time within a step of t*, not a Newton failure
    // with a residual of NaN.
    let system = System::new(1, UnitMass).with_potential(RootWell);
    let t_star = edge_time();
    let dt = 0.01;
    let runs = [
        (Method::Rk4, Options::fixed(dt)),
        (Method::Midpoint, Options::fixed(dt)),
        (Method::Gauss4, Options::fixed(dt)),
        (Method::Gauss6, Options::fixed(dt)),
        (Method::Radau5, Options::fixed(dt)),
        (Method::Radau5, Options::adaptive(1e-8, 1e-10)),
    ];
    for (method, options) in runs {
        let failed = solve_partial(&system, &[0.5], &[-3.0], (0.0, 1.0), method, &options, None)
            .unwrap_err();
        let Error::NonFinite { what, t } = failed.error else {
            panic!("{method} {:?}: {:?}", options.dt, failed.error)
        };
        println!("{method} {:?}: {}", options.dt, failed.error);
        assert!(
            [
                "state",
                "accelerations",
                "forces",
                "momenta",
                "stage positions",
                "stage state",
                "Jacobian",
            ]
            .contains(&what),
            "{method}: {what}"
        );
        assert!((t - t_star).abs() <= dt, "{method}: t = {t}, t* = {t_star}");
        // The partial trajectory stops at the edge (to the run's own error), with every
        // value finite.
        let (t_last, q_last, _) = failed.last.unwrap();
        assert!((t_last - t_star).abs() <= dt, "{method}: {t_last}");
        assert!(q_last[0] > 0.0 && q_last[0].is_finite());
    }
}

/// The explicit Runge–Kutta methods take the steps that nothing watches in a row, only counted
/// (issue 43): kept every 7th step or at the end only, a run takes the same steps, bit for bit,
/// as one keeping every step — on ẍ = x² up to t = 2 and, over (0, 5), up to its blow-up, where
/// the failure names the same last accepted state and the same work.
#[test]
fn runge_kutta_runs_keeping_fewer_steps_take_the_same_steps() {
    let system = System::new(1, UnitMass).with_potential(Cubic);
    let (q0, qd0) = start();
    let row = |sol: &lagrangian::integrators::Solution, i: usize| {
        [sol.t[i], sol.q_at(i)[0], sol.qd_at(i)[0]].map(f64::to_bits)
    };
    for method in [Method::Rk4, Method::Dopri5, Method::Dop853] {
        let options = |output: Output| {
            match method {
                Method::Rk4 => Options::fixed(1e-3),
                _ => Options::adaptive(1e-10, 1e-10),
            }
            .with_output(output)
        };
        let run = |output: Output, t_end: f64| {
            solve_partial(
                &system,
                &q0,
                &qd0,
                (0.0, t_end),
                method,
                &options(output),
                None,
            )
            .map_err(Box::new)
        };
        // A finished run.
        let all = run(Output::Steps, 2.0).unwrap();
        let steps = all.stats.accepted_steps;
        assert!(steps > 20, "{method}: {steps} steps");
        for (output, kept) in [
            (
                Output::Every(7),
                (0..=steps)
                    .filter(|i| i % 7 == 0 || *i == steps)
                    .collect::<Vec<_>>(),
            ),
            (Output::Final, vec![steps]),
        ] {
            let some = run(output.clone(), 2.0).unwrap();
            assert_eq!(some.stats, all.stats, "{method} {output:?}");
            assert_eq!(some.len(), kept.len(), "{method} {output:?}");
            for (i, &k) in kept.iter().enumerate() {
                assert_eq!(row(&some, i), row(&all, k), "{method} {output:?} row {i}");
            }
        }
        // A failed run: the same last state and work.
        let all = run(Output::Steps, 5.0).unwrap_err();
        let sol = all.partial.as_ref().unwrap();
        for output in [Output::Every(7), Output::Final] {
            let some = run(output.clone(), 5.0).unwrap_err();
            assert_eq!(some.error, all.error, "{method} {output:?}");
            assert_eq!(some.last, all.last, "{method} {output:?}");
            let partial = some.partial.as_ref().unwrap();
            assert_eq!(partial.stats, sol.stats, "{method} {output:?}");
            assert_eq!(
                row(partial, partial.len() - 1),
                row(sol, sol.len() - 1),
                "{method} {output:?}"
            );
        }
    }
}
