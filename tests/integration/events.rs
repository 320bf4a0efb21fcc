//! Events (issue 14): sign changes of conditions located on each step's interpolant, terminal
//! events, resets, and the continuous solution, against closed forms.

use crate::common::UnitMass;
use lagrangian::integrators::{
    Direction, Event, Method, Options, Output, Solution, Status, solve, solve_partial,
};
use lagrangian::scenes::{HenonHeiles, SimplePendulum, elliptic_k};
use lagrangian::{Dynamics, Error, Potential, Scalar, System};

/// U = g y on the second coordinate: a projectile (x, y) in a uniform field, unit mass.
#[derive(Debug, Clone, Copy)]
struct Gravity(f64);
impl Potential for Gravity {
    fn potential<D: Scalar>(&self, _t: D, q: &[D]) -> D {
        q[q.len() - 1] * self.0
    }
    fn depends_on_time(&self) -> bool {
        false
    }
}

/// Released from rest at θ₀ = 2.5 (l = 1, g = 9.81): the falling zero crossings of θ are at
/// T/4 + kT, T = 4√(l/g) K(sin(θ₀/2)), with an adaptive and with symplectic methods.
#[test]
fn pendulum_zero_crossings_at_quarter_periods() {
    let (l, g, theta0): (f64, f64, f64) = (1.0, 9.81, 2.5);
    let period = 4.0 * (l / g).sqrt() * elliptic_k((theta0 / 2.0).sin()).unwrap();
    let pendulum = SimplePendulum::new(1.0, l, g).system();
    let crossing = Event::new("theta = 0", |_t, q, _qd| q[0]).falling();
    let t_end = 5.2 * period;
    let runs = [
        (
            Method::Dop853,
            Options::adaptive(1e-13, 1e-14).with_event(crossing.clone()),
        ),
        (
            Method::Yoshida8,
            Options::fixed(2e-3).with_event(crossing.clone()),
        ),
        (
            Method::BlanesMoan4,
            Options::fixed(2e-4).with_event(crossing.clone()),
        ),
        (Method::Gauss6, Options::fixed(2e-3).with_event(crossing)),
    ];
    for (method, options) in runs {
        let sol = solve(&pendulum, &[theta0], &[0.0], (0.0, t_end), method, &options).unwrap();
        let found = &sol.events[0];
        assert_eq!(found.t.len(), 5, "{method}");
        for (k, &t) in found.t.iter().enumerate() {
            let exact = period / 4.0 + k as f64 * period;
            assert!((t - exact).abs() < 1e-10, "{method}: {t} vs {exact}");
            // The recorded state is on the surface θ = 0, moving down.
            assert!(found.q[k].abs() < 1e-12, "{method}: θ = {}", found.q[k]);
            assert!(found.qd[k] < 0.0);
        }
        assert_eq!(sol.status, Status::Finished);
        assert_eq!(*sol.t.last().unwrap(), t_end);
    }
}

/// A projectile launched at speed v, angle α, stopped by a terminal event at y = 0 (falling):
/// flight time 2 v sin α / g and range v² sin 2α / g.
#[test]
fn projectile_stops_at_the_ground() {
    let (v, alpha, g) = (12.0, 0.7_f64, 9.81);
    let system = System::new(2, UnitMass).with_potential(Gravity(g));
    let ground = Event::new("ground", |_t, q, _qd| q[1])
        .falling()
        .terminal(1);
    let qd0 = [v * alpha.cos(), v * alpha.sin()];
    let flight = 2.0 * v * alpha.sin() / g;
    let range = v * v * (2.0 * alpha).sin() / g;
    for (method, options) in [
        (Method::Dop853, Options::adaptive(1e-10, 1e-12)),
        (Method::Dopri5, Options::adaptive(1e-10, 1e-12)),
        (Method::Radau5, Options::adaptive(1e-10, 1e-12)),
        (Method::StormerVerlet, Options::fixed(0.01)),
        (Method::Rk4, Options::fixed(0.01)),
        (Method::Midpoint, Options::fixed(0.01)),
    ] {
        let options = options.with_event(ground.clone());
        let sol = solve(&system, &[0.0, 0.0], &qd0, (0.0, 100.0), method, &options).unwrap();
        // The motion is a parabola, which every method integrates to round-off.
        let (t, q, _) = sol.last().unwrap();
        assert!(
            (t - flight).abs() < 1e-12 * flight,
            "{method}: {t} vs {flight}"
        );
        assert!(
            (q[0] - range).abs() < 1e-11 * range,
            "{method}: {} vs {range}",
            q[0]
        );
        assert!(q[1].abs() < 1e-12);
        assert_eq!(
            sol.status,
            Status::Terminated {
                event: 0,
                name: "ground".into(),
                t
            }
        );
        assert_eq!(
            sol.status.to_string(),
            format!("terminal event ground at t = {t}")
        );
        assert_eq!(sol.events[0].t, vec![t]);
    }
}

/// A ball dropped from height h bounces with restitution e (reset ẏ → −e ẏ at y = 0): impact k
/// is at t₁ + Σⱼ₌₁..ₖ₋₁ 2eʲv₁/g with t₁ = √(2h/g), v₁ = g t₁; the run goes on through them.
#[test]
fn bouncing_ball_impacts_form_a_geometric_series() {
    let (h, e, g) = (2.0, 0.8, 9.81);
    let system = System::new(1, UnitMass).with_potential(Gravity(g));
    let bounce = Event::new("floor", |_t, q, _qd| q[0])
        .falling()
        .with_reset(move |_t, _q, qd| qd[0] *= -e);
    let t1 = (2.0 * h / g).sqrt();
    let v1 = g * t1;
    let mut impacts = vec![t1];
    for j in 1..10 {
        impacts.push(impacts[j - 1] + 2.0 * e.powi(j as i32) * v1 / g);
    }
    let t_end = impacts[9] + 0.01;
    for (method, options) in [
        (Method::Dop853, Options::adaptive(1e-12, 1e-12)),
        (Method::Radau5, Options::adaptive(1e-12, 1e-12)),
        (Method::Yoshida4, Options::fixed(1e-3)),
        (Method::Gauss4, Options::fixed(1e-3)),
    ] {
        let options = options.with_event(bounce.clone());
        let sol = solve(&system, &[h], &[0.0], (0.0, t_end), method, &options).unwrap();
        let found = &sol.events[0];
        assert_eq!(found.t.len(), 10, "{method}");
        for (k, (&t, &exact)) in found.t.iter().zip(&impacts).enumerate() {
            assert!(
                (t - exact).abs() < 1e-9,
                "{method}: impact {k} at {t}, exact {exact}"
            );
            // Before the reset: falling at e^k v₁.
            let speed = v1 * e.powi(k as i32);
            assert!((found.qd[k] + speed).abs() < 1e-8 * speed, "{method}");
        }
        assert_eq!(sol.status, Status::Finished);
        // The trajectory shows each jump: the state before and after the reset at t_k.
        let k = sol.t.iter().position(|&t| t == found.t[0]).unwrap();
        assert_eq!(sol.t[k + 1], sol.t[k]);
        assert!((sol.qd_at(k + 1)[0] + e * sol.qd_at(k)[0]).abs() < 1e-12);
        assert!(
            sol.q.iter().all(|&y| y > -1e-9),
            "{method}: below the floor"
        );
    }
}

/// Hénon–Heiles Poincaré section x = 0 (rising): every point lies on the section and has the
/// energy of the start.
#[test]
fn henon_heiles_section_points_are_on_the_section() {
    let system = HenonHeiles::new().system();
    let (q0, qd0) = ([0.0, 0.1], [0.35, 0.05]);
    let e0 = system.energy(0.0, &q0, &qd0).unwrap();
    let section = Event::new("x = 0", |_t, q, _qd| q[0]).rising();
    let options = Options::adaptive(1e-12, 1e-12).with_event(section);
    let sol = solve(&system, &q0, &qd0, (0.0, 500.0), Method::Dop853, &options).unwrap();
    let found = &sol.events[0];
    assert!(found.t.len() > 50, "{} points", found.t.len());
    for k in 0..found.t.len() {
        let (q, qd) = (&found.q[2 * k..2 * k + 2], &found.qd[2 * k..2 * k + 2]);
        assert!(q[0].abs() <= 1e-12, "x = {}", q[0]);
        assert!(qd[0] > 0.0);
        let e = system.energy(found.t[k], q, qd).unwrap();
        assert!((e - e0).abs() < 1e-10, "energy {e} vs {e0}");
    }
}

/// A condition that crosses zero twice inside one fixed step: both crossings are found.
#[test]
fn two_crossings_inside_one_step_are_both_found() {
    // A free particle at unit speed: q = t; g = (q − 0.3)(q − 0.5) crosses at 0.3 and 0.5.
    let system = System::new(1, UnitMass);
    let twice = Event::new("window", |_t, q, _qd| (q[0] - 0.3) * (q[0] - 0.5));
    for method in [Method::Rk4, Method::StormerVerlet, Method::Gauss4] {
        let options = Options::fixed(1.0).with_event(twice.clone());
        let sol = solve(&system, &[0.0], &[1.0], (0.0, 1.0), method, &options).unwrap();
        assert_eq!(sol.stats.accepted_steps, 1);
        let t = &sol.events[0].t;
        assert_eq!(t.len(), 2, "{method}: {t:?}");
        assert!(
            (t[0] - 0.3).abs() < 1e-14 && (t[1] - 0.5).abs() < 1e-14,
            "{t:?}"
        );
    }
    // Without interior samples the step's ends have the same sign: nothing is seen.
    let blind = Event::new("window", |_t, q, _qd| (q[0] - 0.3) * (q[0] - 0.5)).with_samples(0);
    let options = Options::fixed(1.0).with_event(blind);
    let sol = solve(&system, &[0.0], &[1.0], (0.0, 1.0), Method::Rk4, &options).unwrap();
    assert!(sol.events[0].t.is_empty());
}

/// Directions, a terminal count, several events at once, and requested output times stopping
/// with the run.
#[test]
fn directions_counts_and_output_times() {
    // x = sin t (unit oscillator): zeros at kπ, rising at even k.
    let spring = System::new(1, UnitMass).with_potential(Quadratic);
    let events = [
        Event::new("up", |_t, q, _qd| q[0]).rising(),
        Event::new("down", |_t, q, _qd| q[0]).with_direction(Direction::Falling),
        Event::new("any", |_t, q, _qd| q[0]).terminal(5),
    ];
    let times: Vec<f64> = (0..200).map(|k| 0.1 * k as f64).collect();
    let mut options = Options::adaptive(1e-12, 1e-12).with_output(Output::Times(times));
    options.events = events.to_vec();
    let sol = solve(
        &spring,
        &[0.0],
        &[1.0],
        (0.0, 20.0),
        Method::Dop853,
        &options,
    )
    .unwrap();
    let pi = std::f64::consts::PI;
    let close = |t: &[f64], k: &[f64]| {
        t.len() == k.len() && t.iter().zip(k).all(|(a, b)| (a - b * pi).abs() < 1e-10)
    };
    // x(0) = 0 is not a crossing; the 5th of "any" at 5π stops the run.
    assert!(
        close(&sol.events[2].t, &[1.0, 2.0, 3.0, 4.0, 5.0]),
        "{:?}",
        sol.events[2].t
    );
    assert!(
        close(&sol.events[0].t, &[2.0, 4.0]),
        "{:?}",
        sol.events[0].t
    );
    assert!(
        close(&sol.events[1].t, &[1.0, 3.0, 5.0]),
        "{:?}",
        sol.events[1].t
    );
    let stop = 5.0 * pi;
    assert!(
        matches!(sol.status, Status::Terminated { event: 2, t, .. } if (t - stop).abs() < 1e-10)
    );
    // Requested times up to the stop only, each on the exact solution.
    assert_eq!(sol.len(), (stop / 0.1).floor() as usize + 1);
    for i in 0..sol.len() {
        assert!((sol.q_at(i)[0] - sol.t[i].sin()).abs() < 1e-10);
    }
}

/// U = ½ x².
#[derive(Debug, Clone, Copy)]
struct Quadratic;
impl Potential for Quadratic {
    fn potential<D: Scalar>(&self, _t: D, q: &[D]) -> D {
        q[0] * q[0] * 0.5
    }
    fn depends_on_time(&self) -> bool {
        false
    }
}

/// Backwards in time, the same crossings are found in reverse order.
#[test]
fn events_backwards_in_time() {
    let spring = System::new(1, UnitMass).with_potential(Quadratic);
    let options = Options::adaptive(1e-12, 1e-12).with_event(Event::new("x", |_t, q, _qd| q[0]));
    let sol = solve(
        &spring,
        &[0.0],
        &[1.0],
        (0.0, -7.0),
        Method::Dop853,
        &options,
    )
    .unwrap();
    let pi = std::f64::consts::PI;
    let t = &sol.events[0].t;
    assert_eq!(t.len(), 2);
    assert!(
        (t[0] + pi).abs() < 1e-10 && (t[1] + 2.0 * pi).abs() < 1e-10,
        "{t:?}"
    );
}

/// The continuous solution of every method reproduces the oscillator between the steps to
/// the accuracy of its interpolant, and is right-continuous across a reset.
#[test]
fn dense_solution_between_steps() {
    let spring = System::new(1, UnitMass).with_potential(Quadratic);
    for (method, options, tol, order) in [
        (Method::Dop853, Options::adaptive(1e-12, 1e-12), 1e-10, 7),
        (Method::Dopri5, Options::adaptive(1e-10, 1e-12), 1e-7, 4),
        (Method::Radau5, Options::adaptive(1e-10, 1e-12), 1e-7, 5),
        (Method::Yoshida6, Options::fixed(0.01), 1e-10, 5),
        (Method::Gauss6, Options::fixed(0.01), 1e-10, 5),
    ] {
        let sol = solve(
            &spring,
            &[0.0],
            &[1.0],
            (0.0, 10.0),
            method,
            &options.with_dense(true),
        )
        .unwrap();
        let dense = sol.dense.as_ref().unwrap();
        assert_eq!(dense.order(), order, "{method}");
        assert_eq!(dense.steps(), sol.stats.accepted_steps);
        let mut y = [0.0; 2];
        for k in 0..=1000 {
            let t = 0.01 * k as f64;
            dense.eval(t, &mut y).unwrap();
            assert!((y[0] - t.sin()).abs() < tol, "{method}: x({t}) = {}", y[0]);
            assert!((y[1] - t.cos()).abs() < 10.0 * tol, "{method}: v({t})");
        }
        assert!(dense.eval(10.5, &mut y).is_err());
        assert!(dense.eval(f64::NAN, &mut y).is_err());
    }
    // Without `dense` nothing is kept.
    let sol = solve(
        &spring,
        &[0.0],
        &[1.0],
        (0.0, 1.0),
        Method::Dop853,
        &Options::default(),
    );
    assert!(sol.unwrap().dense.is_none());
    // Across a reset (v → −v at x = 0.5): at the event's time the state before it, just after
    // it the state after it.
    let wall = Event::new("wall", |_t, q, _qd| q[0] - 0.5).with_reset(|_t, _q, qd| qd[0] = -qd[0]);
    let options = Options::adaptive(1e-12, 1e-12)
        .with_event(wall)
        .with_dense(true);
    let sol = solve(
        &spring,
        &[0.0],
        &[1.0],
        (0.0, 1.0),
        Method::Dop853,
        &options,
    )
    .unwrap();
    let t_hit = sol.events[0].t[0];
    assert!((t_hit - (0.5_f64).asin()).abs() < 1e-12);
    let mut y = [0.0; 2];
    let dense = sol.dense.as_ref().unwrap();
    dense.eval(t_hit, &mut y).unwrap();
    assert!((y[1] - t_hit.cos()).abs() < 1e-10, "{y:?}");
    dense.eval(t_hit + 1e-9, &mut y).unwrap();
    assert!((y[1] + t_hit.cos()).abs() < 1e-8, "{y:?}");
}

/// A condition that is not finite fails the run with a typed error naming it; the partial
/// solution keeps the occurrences found before.
#[test]
fn non_finite_condition_is_a_typed_error() {
    let spring = System::new(1, UnitMass).with_potential(Quadratic);
    let options = Options::adaptive(1e-10, 1e-12)
        .with_event(Event::new("x", |_t, q, _qd| q[0]))
        .with_event(Event::new("log", |t, _q, _qd| (5.0 - t).ln()));
    let failed = solve_partial(
        &spring,
        &[0.0],
        &[1.0],
        (0.0, 8.0),
        Method::Dop853,
        &options,
        None,
    )
    .unwrap_err();
    assert!(
        matches!(failed.error, Error::NonFinite { what: "event condition", t } if t > 5.0),
        "{:?}",
        failed.error
    );
    let partial: Solution = failed.partial.unwrap();
    assert_eq!(partial.events[0].t.len(), 1); // x = 0 at π
    assert_eq!(partial.status, Status::Failed);
    // A terminal count of zero is refused before the run.
    let options = Options::default().with_event(Event::new("x", |_t, q, _qd| q[0]).terminal(0));
    let err = solve(
        &spring,
        &[0.0],
        &[1.0],
        (0.0, 1.0),
        Method::Dop853,
        &options,
    )
    .unwrap_err();
    assert!(err.to_string().contains("count ≥ 1"), "{err}");
}

/// Resets that come ever faster (a ball kicked up at 1 mm/s at every touch of the floor) end
/// with a typed error within the step budget, counted across the segments between resets.
#[test]
fn endless_resets_end_within_the_step_budget() {
    let system = System::new(1, UnitMass).with_potential(Gravity(9.81));
    let floor = Event::new("floor", |_t, q, _qd| q[0])
        .falling()
        .with_reset(|_t, q, qd| {
            q[0] = 0.0;
            qd[0] = 1e-3;
        });
    // 10⁴ fixed steps cover the span; the resets restart the grid and add to the count.
    for (method, options) in [
        (
            Method::Dop853,
            Options::adaptive(1e-8, 1e-10).with_max_steps(5000),
        ),
        (
            Method::StormerVerlet,
            Options::fixed(1e-3).with_max_steps(15000),
        ),
        (
            Method::StormerVerlet,
            Options::fixed(2e-3).with_max_steps(10000),
        ),
    ] {
        let options = options.with_event(floor.clone());
        let failed = solve_partial(&system, &[1.0], &[0.0], (0.0, 10.0), method, &options, None)
            .unwrap_err();
        assert!(
            matches!(failed.error, Error::TooManySteps { .. }),
            "{:?}",
            failed.error
        );
        // Every touch after the first is a bounce of 2 v / g ≈ 0.2 ms.
        let t = &failed.partial.unwrap().events[0].t;
        assert!(t.len() > 100, "{method}: {} bounces", t.len());
        assert!(
            t.windows(2).all(|w| w[1] > w[0]),
            "{method}: an impact found twice"
        );
        assert!(((t[2] - t[1]) - 2e-3 / 9.81).abs() < 1e-9, "{method}");
    }
}

/// The step-by-step solver is what `solve` runs: the same trajectory bit for bit, for every
/// method; each step's state is the row recorded for it, and a reset says so.
#[test]
fn solver_steps_are_the_runs_steps() {
    use lagrangian::integrators::{Solver, StepOutcome};
    let (e, g) = (0.8, 9.81);
    let system = System::new(1, UnitMass).with_potential(Gravity(g));
    let bounce = Event::new("floor", |_t, q, _qd| q[0])
        .falling()
        .with_reset(move |_t, _q, qd| qd[0] *= -e);
    // taylor needs an expression model: `taylor.rs` steps its bouncing ball.
    for method in Method::ALL.iter().copied().filter(|&m| m != Method::Taylor) {
        let options = match method.is_adaptive() {
            Some(true) => Options::adaptive(1e-9, 1e-9),
            _ => Options::fixed(1e-2),
        }
        .with_event(bounce.clone());
        let whole = solve(&system, &[1.0], &[0.0], (0.0, 2.0), method, &options).unwrap();
        let mut solver =
            Solver::new(&system, &[1.0], &[0.0], (0.0, 2.0), method, &options).unwrap();
        let (mut resets, mut row) = (0, 0);
        loop {
            let outcome = solver.step().unwrap();
            row += if matches!(outcome, StepOutcome::Reset { .. }) {
                2
            } else {
                1
            };
            let (q, qd) = solver.state();
            assert_eq!(solver.t(), whole.t[row], "{method}");
            assert_eq!((q, qd), (whole.q_at(row), whole.qd_at(row)), "{method}");
            match outcome {
                StepOutcome::Stepped => {}
                StepOutcome::Reset { event: 0, t } => {
                    resets += 1;
                    assert_eq!(t, whole.events[0].t[resets - 1]);
                }
                StepOutcome::Finished => break,
                other => panic!("{method}: {other:?}"),
            }
        }
        // Once finished it stays finished.
        assert_eq!(solver.step().unwrap(), StepOutcome::Finished);
        let mut early = Solver::new(&system, &[1.0], &[0.0], (0.0, 2.0), method, &options).unwrap();
        early.step().unwrap();
        let t = early.t();
        assert_eq!(
            early.solution().status,
            Status::Unfinished { t },
            "{method}"
        );
        assert_eq!(resets, whole.events[0].t.len(), "{method}");
        assert!(resets >= 2, "{method}");
        assert_eq!(solver.solution(), whole, "{method}");
    }
}

/// Bounces of random balls with every kind of method: each impact is found once, falling, in
/// order, and the ball stays above the floor — also when the next impact comes within the
/// first sample interval after a reset.
#[test]
fn every_bounce_found_once() {
    let mut rng = crate::common::Rng(14);
    let g = 9.81;
    let system = System::new(1, UnitMass).with_potential(Gravity(g));
    for run in 0..120 {
        let (e, h0) = (rng.uniform(0.2, 0.9), rng.uniform(0.1, 2.0));
        let bounce = Event::new("floor", |_t, q, _qd| q[0])
            .falling()
            .with_reset(move |_t, _q, qd| qd[0] *= -e);
        let t1 = (2.0 * h0 / g).sqrt();
        // Stop before the impacts come closer than round-off (Zeno time t₁ (1 + e) / (1 − e)).
        let t_end = t1 + 2.0 * t1 * e * (1.0 - e.powi(6)) / (1.0 - e);
        let (method, options) = match run % 4 {
            0 => (Method::Rk4, Options::fixed(rng.uniform(0.05, 0.5))),
            1 => (
                Method::StormerVerlet,
                Options::fixed(rng.uniform(0.05, 0.5)),
            ),
            2 => (Method::Gauss4, Options::fixed(rng.uniform(0.05, 0.5))),
            _ => (Method::Dop853, Options::adaptive(1e-10, 1e-12)),
        };
        let options = options.with_event(bounce);
        let sol = solve(&system, &[h0], &[0.0], (0.0, t_end), method, &options)
            .unwrap_or_else(|err| panic!("run {run} ({method}), e = {e}, h0 = {h0}: {err:?}"));
        let found = &sol.events[0];
        assert!(found.t.len() >= 5, "run {run} ({method}): {:?}", found.t);
        assert!(
            found.t.windows(2).all(|w| w[1] > w[0]),
            "run {run} ({method}): {:?}",
            found.t
        );
        assert!(
            found.qd.iter().all(|&v| v < 0.0),
            "run {run} ({method}): {:?}",
            found.qd
        );
        assert!((found.t[0] - t1).abs() < 1e-9, "run {run} ({method})");
        assert!(
            sol.q.iter().all(|&y| y > -1e-9),
            "run {run} ({method}): below the floor"
        );
    }
}

/// Events at the same time as another's reset are recorded too, whatever their order; a
/// reset within round-off of the end ends the run with the output times asked for.
#[test]
fn simultaneous_events_and_resets_at_the_end() {
    let g = 9.81;
    let system = System::new(1, UnitMass).with_potential(Gravity(g));
    let floor = Event::new("floor", |_t, q, _qd| q[0])
        .falling()
        .with_reset(|_t, _q, qd| qd[0] *= -0.8);
    let touch = Event::new("touch", |_t, q, _qd| q[0]).falling();
    let options = Options::adaptive(1e-10, 1e-12);
    let first = options
        .clone()
        .with_event(floor.clone())
        .with_event(touch.clone());
    let second = options.clone().with_event(touch).with_event(floor.clone());
    let a = solve(&system, &[1.0], &[0.0], (0.0, 3.0), Method::Dop853, &first).unwrap();
    let b = solve(&system, &[1.0], &[0.0], (0.0, 3.0), Method::Dop853, &second).unwrap();
    assert!(a.events[0].t.len() >= 5);
    assert_eq!(a.events[0].t, a.events[1].t);
    assert_eq!(a.events[0].t, b.events[1].t);
    assert_eq!(b.events[0].t, b.events[1].t);
    let t1 = (2.0 / g).sqrt();
    for k in 1..12 {
        let t_end = t1 * (1.0 + k as f64 * 1e-16);
        for method in [Method::Dop853, Method::Radau5] {
            let options = options
                .clone()
                .with_event(floor.clone())
                .with_output(Output::Times(vec![0.0, 0.5 * t1, t_end]));
            let sol = solve(&system, &[1.0], &[0.0], (0.0, t_end), method, &options).unwrap();
            assert_eq!(sol.t, vec![0.0, 0.5 * t1, t_end], "{method}, k = {k}");
            // At t_end the state after the bounce if the run saw it before the end (at the
            // bounce's own time, the state before it).
            let bounced = sol.events[0].t.first().is_some_and(|&t| t < t_end);
            assert_eq!(sol.qd_at(2)[0] > 0.0, bounced, "{method}, k = {k}");
        }
    }
}
