//! Forward sensitivities from Rust (`lagrangian::sensitivity`) on models built on the expression
//! graph, against closed forms: the harmonic oscillator in k and the initial state by hand, the
//! damped oscillator in k, c and the initial state by dual numbers on its exact solution;
//! `Options::with_error_coordinates` (error control on (q, q̇) alone) and what refuses it; events.

use approx::assert_relative_eq;
use lagrangian::integrators::Event;
use lagrangian::num_dual::{Dual64, DualNum};
use lagrangian::sensitivity::{
    ConstraintNodes, Direction, EventCondition, SensitivityProblem, SensitivitySolution,
    Variational, solve_sensitivities,
};
use lagrangian::tape::{
    Binary, Energies, EnergyModel, EomProgram, ExprConstraints, Function, Graph, Inputs, Tape,
    Unary,
};
use lagrangian::{Constrained, Error, Method, Options, Output, solve};
use std::sync::Arc;

/// m ẍ + c ẋ + k x = 0 with m = 1 from T = ½ ẋ², U = ½ k x², Φ = ½ c ẋ² (parameters k, c).
fn oscillator() -> (Graph, Energies) {
    let mut g = Graph::new();
    let (k, c, x, v, half) = (
        g.param(0),
        g.param(1),
        g.coord(0),
        g.velocity(0),
        g.constant(0.5),
    );
    let mut mul = |a, b| g.binary(Binary::Mul, a, b).unwrap();
    let v2 = mul(v, v);
    let kinetic = mul(half, v2);
    let x2 = mul(x, x);
    let kx2 = mul(k, x2);
    let potential = mul(half, kx2);
    let cv2 = mul(c, v2);
    let dissipation = mul(half, cv2);
    let parts = Energies {
        kinetic,
        potential: Some(potential),
        dissipation: Some(dissipation),
        ..Energies::default()
    };
    (g, parts)
}

const ALL: [Direction; 4] = [
    Direction::Parameter(0),
    Direction::Parameter(1),
    Direction::Position(0),
    Direction::Velocity(0),
];

fn run(
    params: [f64; 2],
    state: (f64, f64),
    t_end: f64,
    method: Method,
    options: &Options,
) -> lagrangian::Result<SensitivitySolution> {
    let (g, parts) = oscillator();
    let variational = Variational::new(&g, 1, 2, &parts, None, &ALL)?;
    solve_sensitivities(
        &variational,
        &params,
        &[state.0],
        &[state.1],
        (0.0, t_end),
        method,
        options,
    )
}

/// (x, ẋ) of the damped oscillator at t: x = e^{−γt}(x₀ cos ωt + (v₀ + γx₀)/ω sin ωt),
/// γ = c/2, ω = √(k − γ²), in dual numbers so that the seeded input's derivative comes along.
fn damped_exact(t: f64, k: Dual64, c: Dual64, x0: Dual64, v0: Dual64) -> [Dual64; 2] {
    let g = c * 0.5;
    let w = (k - g * g).sqrt();
    let (s, co) = ((w * t).sin(), (w * t).cos());
    let e = (-g * t).exp();
    let b = (v0 + g * x0) / w;
    let x = e * (x0 * co + b * s);
    // ẋ = −γ x + e^{−γt} ω (b cos ωt − x₀ sin ωt).
    let v = -g * x + e * w * (b * co - x0 * s);
    [x, v]
}

/// The derivative of the exact (x, ẋ) at t along input `j` of (k, c, x₀, v₀).
fn damped_derivative(t: f64, inputs: [f64; 4], j: usize) -> [f64; 2] {
    let d: Vec<Dual64> = (0..4)
        .map(|i| Dual64::new(inputs[i], if i == j { 1.0 } else { 0.0 }))
        .collect();
    damped_exact(t, d[0], d[1], d[2], d[3]).map(|z| z.eps)
}

#[test]
fn harmonic_oscillator_in_k_and_the_initial_state() {
    // x = x₀ cos ωt + v₀/ω sin ωt, ω = √k, c = 0. From (1, 0): ∂x/∂k = −t sin(ωt)/(2ω),
    // ∂ẋ/∂k = −sin(ωt)/(2ω) − t cos(ωt)/2, ∂x/∂x₀ = cos ωt, ∂x/∂v₀ = sin(ωt)/ω.
    let k = 4.0_f64;
    let w = k.sqrt();
    let options = Options::adaptive(1e-12, 1e-12);
    let sol = run([k, 0.0], (1.0, 0.0), 3.0, Method::Dop853, &options).unwrap();
    let n = sol.solution.len();
    assert!(n > 5);
    assert_eq!(sol.directions, ALL.to_vec());
    assert_eq!(sol.sensitivities.len(), n * ALL.len() * 2);
    for i in 0..n {
        let t = sol.solution.t[i];
        let (s, c) = (w * t).sin_cos();
        assert_relative_eq!(sol.solution.q[i], c, epsilon = 1e-11);
        let dk = sol.sensitivity(i, 0);
        assert_relative_eq!(dk[0], -t * s / (2.0 * w), epsilon = 1e-10);
        assert_relative_eq!(dk[1], -s / (2.0 * w) - t * c / 2.0, epsilon = 1e-10);
        let dx0 = sol.sensitivity(i, 2);
        assert_relative_eq!(dx0[0], c, epsilon = 1e-10);
        assert_relative_eq!(dx0[1], -w * s, epsilon = 1e-10);
        let dv0 = sol.sensitivity(i, 3);
        assert_relative_eq!(dv0[0], s / w, epsilon = 1e-10);
        assert_relative_eq!(dv0[1], c, epsilon = 1e-10);
    }
    // At t0 the sensitivities are their initial values.
    assert_eq!(sol.sensitivity(0, 0), &[0.0, 0.0]);
    assert_eq!(sol.sensitivity(0, 2), &[1.0, 0.0]);
    assert_eq!(sol.sensitivity(0, 3), &[0.0, 1.0]);
}

#[test]
fn damped_oscillator_closed_form_by_every_method() {
    let (k, c, x0, v0) = (4.0, 0.3, 1.0, 0.5);
    let cases = [
        (Method::Dop853, Options::adaptive(1e-12, 1e-12), 1e-10),
        (Method::Dopri5, Options::adaptive(1e-12, 1e-12), 1e-10),
        (Method::Radau5, Options::adaptive(1e-12, 1e-12), 1e-10),
        (Method::Taylor, Options::adaptive(1e-12, 1e-12), 1e-10),
        (Method::Gauss6, Options::fixed(5e-3), 1e-10),
        (Method::Rk4, Options::fixed(1e-3), 1e-10),
    ];
    for (method, options, tol) in cases {
        let sol = run([k, c], (x0, v0), 3.0, method, &options).unwrap();
        for i in 0..sol.solution.len() {
            let t = sol.solution.t[i];
            for j in 0..4 {
                let exact = damped_derivative(t, [k, c, x0, v0], j);
                let got = sol.sensitivity(i, j);
                for (a, b) in got.iter().zip(exact) {
                    assert!(
                        (a - b).abs() <= tol,
                        "{method:?}, t = {t}, direction {j}: {a} vs {b}"
                    );
                }
            }
        }
    }
}

#[test]
fn error_coordinates_accepted_by_the_adaptive_methods() {
    // Error control on (x, ẋ) alone: no more steps than with every component controlled, and
    // the sensitivities still follow the closed form to a looser tolerance.
    let (k, c, x0, v0) = (4.0, 0.3, 1.0, 0.5);
    for method in [
        Method::Dop853,
        Method::Dopri5,
        Method::Radau5,
        Method::Taylor,
    ] {
        let all = Options::adaptive(1e-10, 1e-10);
        let leading = Options::adaptive(1e-10, 1e-10).with_error_coordinates(1);
        let on = run([k, c], (x0, v0), 3.0, method, &all).unwrap();
        let off = run([k, c], (x0, v0), 3.0, method, &leading).unwrap();
        assert!(
            off.solution.stats.accepted_steps <= on.solution.stats.accepted_steps,
            "{method:?}"
        );
        let last = off.solution.len() - 1;
        let t = off.solution.t[last];
        assert_relative_eq!(t, 3.0, epsilon = 1e-14);
        for j in 0..4 {
            let exact = damped_derivative(t, [k, c, x0, v0], j);
            for (a, b) in off.sensitivity(last, j).iter().zip(exact) {
                assert!(
                    (a - b).abs() < 1e-7,
                    "{method:?}, direction {j}: {a} vs {b}"
                );
            }
        }
        // Controlling all n(1 + m) = 5 coordinates is the default.
        let every = Options::adaptive(1e-10, 1e-10).with_error_coordinates(5);
        let same = run([k, c], (x0, v0), 3.0, method, &every).unwrap();
        assert_eq!(same.solution.t, on.solution.t, "{method:?}");
    }
}

#[test]
fn error_coordinates_out_of_range_refused() {
    // More coordinates than the system has, and none, are refused by every method.
    for method in [Method::Dop853, Method::Taylor] {
        for k in [0, 9] {
            let options = Options::adaptive(1e-10, 1e-10).with_error_coordinates(k);
            let result = run([4.0, 0.3], (1.0, 0.0), 1.0, method, &options);
            assert!(
                matches!(result, Err(Error::InvalidInput { .. })),
                "{method:?}, {k}: {result:?}"
            );
        }
    }
}

#[test]
fn event_with_reset_refused() {
    let bounce = Event::new("floor", |_t, q, _qd| q[0]).with_reset(|_t, _q, qd| qd[0] *= -1.0);
    let options = Options::adaptive(1e-10, 1e-10).with_event(bounce);
    match run([4.0, 0.0], (1.0, 0.0), 3.0, Method::Dop853, &options) {
        Err(Error::InvalidInput { what, why }) => {
            assert_eq!(what, "sensitivities");
            assert!(why.contains("floor") && why.contains("reset"), "{why}");
        }
        other => panic!("expected InvalidInput, got {other:?}"),
    }
}

#[test]
fn event_states_carry_the_sensitivities() {
    // x = cos 2t crosses zero at t* = π/4: the model's event state has its one coordinate, the
    // variational state all n(1 + m), with ∂x/∂k = −t sin(ωt)/(2ω) there.
    let zero = Event::new("zero", |_t, q, _qd| q[0]).falling().terminal(1);
    let options = Options::adaptive(1e-12, 1e-12)
        .with_event(zero)
        .with_output(Output::Final);
    let sol = run([4.0, 0.0], (1.0, 0.0), 3.0, Method::Dop853, &options).unwrap();
    let t = std::f64::consts::FRAC_PI_4;
    assert_eq!(sol.solution.events.len(), 1);
    assert_eq!(sol.solution.events[0].t.len(), 1);
    assert_relative_eq!(sol.solution.events[0].t[0], t, epsilon = 1e-12);
    assert_eq!(sol.solution.events[0].q.len(), 1);
    assert_eq!(sol.event_states[0].q.len(), 1 + ALL.len());
    assert_relative_eq!(sol.event_states[0].q[1], -t / 4.0, epsilon = 1e-10);
    assert_relative_eq!(sol.solution.t[sol.solution.len() - 1], t, epsilon = 1e-12);
    assert_eq!(sol.solution.len(), 1);
}

#[test]
fn bad_directions_and_states() {
    let (g, parts) = oscillator();
    for wrt in [
        vec![],
        vec![Direction::Parameter(2)],
        vec![Direction::Position(1)],
        vec![Direction::Velocity(3)],
    ] {
        let result = Variational::new(&g, 1, 2, &parts, None, &wrt);
        assert!(
            matches!(result, Err(Error::InvalidInput { .. })),
            "{wrt:?}: {result:?}"
        );
    }
    let variational = Variational::new(&g, 1, 2, &parts, None, &ALL).unwrap();
    assert_eq!(variational.dof(), 1);
    assert_eq!(variational.directions(), &ALL);
    assert!(matches!(
        variational.initial_state(0.0, &[1.0, 2.0], &[0.0], &[4.0, 0.3]),
        Err(Error::DimensionMismatch { what: "q0", .. })
    ));
    let (q, qd) = variational
        .initial_state(0.0, &[0.7], &[-0.2], &[4.0, 0.3])
        .unwrap();
    assert_eq!(q, vec![0.7, 0.0, 0.0, 1.0, 0.0]);
    assert_eq!(qd, vec![-0.2, 0.0, 0.0, 0.0, 1.0]);
}

#[test]
fn interpreted_system_agrees() {
    let (g, parts) = oscillator();
    let variational = Variational::new(&g, 1, 2, &parts, None, &ALL)
        .unwrap()
        .interpreted();
    let options = Options::adaptive(1e-12, 1e-12).with_output(Output::Times(vec![1.0, 2.5]));
    let sol = solve_sensitivities(
        &variational,
        &[4.0, 0.3],
        &[1.0],
        &[0.5],
        (0.0, 3.0),
        Method::Dop853,
        &options,
    )
    .unwrap();
    assert_eq!(sol.solution.len(), 2);
    for (i, &t) in [1.0, 2.5].iter().enumerate() {
        for j in 0..4 {
            let exact = damped_derivative(t, [4.0, 0.3, 1.0, 0.5], j);
            for (a, b) in sol.sensitivity(i, j).iter().zip(exact) {
                assert!((a - b).abs() < 1e-10, "t = {t}, direction {j}: {a} vs {b}");
            }
        }
    }
}

/// A model of `dof` coordinates from the energies `parts` of `graph` at the parameter values
/// `params`, with its eq. 55 program (so that every method, Taylor's too, runs it).
fn energy_model(graph: &Graph, dof: usize, parts: &Energies, params: &[f64]) -> EnergyModel {
    let count = params.len();
    let bind = |node: usize, inputs: Inputs| {
        let tape = Tape::new(graph, &[node], inputs, "energy").unwrap();
        Function::new(Arc::new(tape), params).unwrap()
    };
    let kinetic = bind(parts.kinetic, Inputs::kinetic(dof, count));
    let potential = parts
        .potential
        .map(|u| bind(u, Inputs::potential(dof, count)));
    let mut g = graph.clone();
    let program = EomProgram::new(&mut g, dof, count, parts).unwrap();
    EnergyModel::new(dof, kinetic, potential, None, None)
        .unwrap()
        .with_program(program.bind(params).unwrap())
        .unwrap()
}

#[test]
fn event_time_of_a_ball_thrown_up_against_its_closed_form() {
    // y″ = −g from (y₀, v₀): it lands (y = 0, falling) at t* = (v₀ + r)/g, r = √(v₀² + 2 g y₀),
    // so dt*/dg = −(v₀ + r)/g² + y₀/(r g), dt*/dy₀ = 1/r and dt*/dv₀ = (1 + v₀/r)/g.
    let mut graph = Graph::new();
    let (g, y, v, half) = (
        graph.param(0),
        graph.coord(0),
        graph.velocity(0),
        graph.constant(0.5),
    );
    let v2 = graph.binary(Binary::Mul, v, v).unwrap();
    let kinetic = graph.binary(Binary::Mul, half, v2).unwrap();
    let potential = graph.binary(Binary::Mul, g, y).unwrap();
    let parts = Energies {
        kinetic,
        potential: Some(potential),
        ..Energies::default()
    };
    let (gravity, y0, v0) = (9.81_f64, 0.5, 3.0);
    let params = [gravity];
    let model = energy_model(&graph, 1, &parts, &params);
    let wrt = [
        Direction::Parameter(0),
        Direction::Position(0),
        Direction::Velocity(0),
    ];
    let variational = Variational::new(&graph, 1, 1, &parts, None, &wrt).unwrap();
    let r = (v0 * v0 + 2.0 * gravity * y0).sqrt();
    let landing = (v0 + r) / gravity;
    let exact = [
        -(v0 + r) / (gravity * gravity) + y0 / (r * gravity),
        1.0 / r,
        (1.0 + v0 / r) / gravity,
    ];
    let cases = [
        (Method::Dop853, Options::adaptive(1e-12, 1e-12), 1e-12),
        (Method::Radau5, Options::adaptive(1e-12, 1e-12), 1e-10),
        (Method::Taylor, Options::adaptive(1e-12, 1e-12), 1e-12),
        (Method::Rk4, Options::fixed(1e-3), 1e-12),
    ];
    for (method, options, tol) in cases {
        let ground = Event::new("ground", |_t, q, _qd| q[0])
            .falling()
            .terminal(1);
        let options = options.with_event(ground).with_output(Output::Final);
        let condition = EventCondition::new(&graph, y, &variational, &[0], &params).unwrap();
        let sol = SensitivityProblem::new(&model, &variational, &params)
            .unwrap()
            .with_event_conditions(vec![condition])
            .solve(&[y0], &[v0], (0.0, 10.0), method, &options)
            .unwrap();
        assert_relative_eq!(sol.solution.events[0].t[0], landing, epsilon = 1e-12);
        assert_eq!(sol.event_times.len(), 1);
        assert_eq!(sol.event_times[0].len(), 3, "{method:?}");
        for (j, (&got, want)) in sol.event_times[0].iter().zip(exact).enumerate() {
            assert!(
                (got - want).abs() <= tol,
                "{method:?}, direction {j}: {got} vs {want}"
            );
        }
    }
    // Without the conditions the events are found but their times not differentiated; a
    // number of conditions other than the events' is refused.
    let options = Options::adaptive(1e-10, 1e-10)
        .with_event(Event::new("ground", |_t, q, _qd| q[0]).falling());
    let problem = SensitivityProblem::new(&model, &variational, &params).unwrap();
    let plain = problem
        .solve(&[y0], &[v0], (0.0, 1.0), Method::Dop853, &options)
        .unwrap();
    assert!(plain.event_times.is_empty());
    let condition = EventCondition::new(&graph, y, &variational, &[0], &params).unwrap();
    let two = problem.with_event_conditions(vec![condition.clone(), condition]);
    assert!(matches!(
        two.solve(&[y0], &[v0], (0.0, 1.0), Method::Dop853, &options),
        Err(Error::InvalidInput { .. })
    ));
    assert!(matches!(
        EventCondition::new(&graph, y, &variational, &[0, 1], &params),
        Err(Error::DimensionMismatch { .. })
    ));
}

#[test]
fn event_time_of_a_velocity_condition_against_its_closed_form() {
    // The oscillator x = cos 2t (k = 4, c = 0, from rest at x₀ = 1): ẋ = −2 sin 2t rises
    // through 0 at t* = π/ω, ω = √k. Along k, dt*/dk = −π/(2 k^{3/2}); along c, 0 (ω moves
    // with c² only); along x₀, 0 (the amplitude does not move the turn); along v₀, by the
    // implicit function theorem, −cos(ωt*)/ẍ(t*) = 1/(x₀ ω²). The condition reads q̇, so its
    // rate takes q̈ at the root.
    let (g, parts) = oscillator();
    let params = [4.0, 0.0];
    let model = energy_model(&g, 1, &parts, &params);
    let variational = Variational::new(&g, 1, 2, &parts, None, &ALL).unwrap();
    let mut graph = g.clone();
    let v = graph.velocity(0);
    let condition = EventCondition::new(&graph, v, &variational, &[0, 1], &params).unwrap();
    let turn = Event::new("turn", |_t, _q, qd| qd[0]).rising().terminal(1);
    let options = Options::adaptive(1e-12, 1e-12)
        .with_event(turn)
        .with_output(Output::Final);
    let sol = SensitivityProblem::new(&model, &variational, &params)
        .unwrap()
        .with_event_conditions(vec![condition])
        .solve(&[1.0], &[0.0], (0.0, 3.0), Method::Dop853, &options)
        .unwrap();
    let pi = std::f64::consts::PI;
    assert_relative_eq!(sol.solution.events[0].t[0], pi / 2.0, epsilon = 1e-12);
    let exact = [-pi / 16.0, 0.0, 0.0, 0.25];
    for (j, (&got, want)) in sol.event_times[0].iter().zip(exact).enumerate() {
        assert!((got - want).abs() < 1e-10, "direction {j}: {got} vs {want}");
    }
}

/// The pendulum in Cartesian coordinates (x, y) under its rod x² + y² = l² (m = 1, parameters
/// g and l): the graph, its energies and the rod's node.
fn cartesian_pendulum() -> (Graph, Energies, usize) {
    let mut g = Graph::new();
    let (gravity, l, x, y, vx, vy, half) = (
        g.param(0),
        g.param(1),
        g.coord(0),
        g.coord(1),
        g.velocity(0),
        g.velocity(1),
        g.constant(0.5),
    );
    let mut mul = |a, b| g.binary(Binary::Mul, a, b).unwrap();
    let (vx2, vy2, x2, y2, l2) = (mul(vx, vx), mul(vy, vy), mul(x, x), mul(y, y), mul(l, l));
    let potential = mul(gravity, y);
    let twice = g.binary(Binary::Add, vx2, vy2).unwrap();
    let kinetic = g.binary(Binary::Mul, half, twice).unwrap();
    let r2 = g.binary(Binary::Add, x2, y2).unwrap();
    let rod = g.binary(Binary::Sub, r2, l2).unwrap();
    let parts = Energies {
        kinetic,
        potential: Some(potential),
        ..Energies::default()
    };
    (g, parts, rod)
}

/// The same pendulum in its angle θ (x = l sin θ, y = −l cos θ): T = ½ l² θ̇², U = −g l cos θ.
fn angle_pendulum() -> (Graph, Energies) {
    let mut g = Graph::new();
    let (gravity, l, th, w, half) = (
        g.param(0),
        g.param(1),
        g.coord(0),
        g.velocity(0),
        g.constant(0.5),
    );
    let cos = g.unary(Unary::Cos, th).unwrap();
    let mut mul = |a, b| g.binary(Binary::Mul, a, b).unwrap();
    let (l2, w2, gl) = (mul(l, l), mul(w, w), mul(gravity, l));
    let l2w2 = mul(l2, w2);
    let kinetic = mul(half, l2w2);
    let glc = mul(gl, cos);
    let potential = g.unary(Unary::Neg, glc).unwrap();
    let parts = Energies {
        kinetic,
        potential: Some(potential),
        ..Energies::default()
    };
    (g, parts)
}

#[test]
fn constrained_run_with_sensitivities_stays_on_the_rod() {
    // Defect 2 of issue 49: a long run at the default tolerances. The variational system is
    // projected with the model (the state as the plain run projects it, the sensitivities onto
    // the tangent space at the projected state), so its reported residual is the true residual
    // of the states it returns, at the plain run's level; and the sensitivities along g and l
    // stay those of the pendulum in its angle, mapped to (x, y).
    let (g, parts, rod) = cartesian_pendulum();
    let params = [9.81, 1.5];
    let l = params[1];
    let rows = {
        let tape = Tape::new(&g, &[rod], Inputs::potential(2, 2), "rod").unwrap();
        ExprConstraints::new(
            2,
            Some(Function::new(Arc::new(tape), &params).unwrap()),
            None,
            Vec::new(),
        )
        .unwrap()
    };
    let model = Constrained::new(energy_model(&g, 2, &parts, &params), rows);
    let wrt = [Direction::Parameter(0), Direction::Parameter(1)];
    let nodes = ConstraintNodes {
        holonomic: &[rod],
        velocity: &[],
        moving: false,
    };
    let variational = Variational::new(&g, 2, 2, &parts, Some(nodes), &wrt).unwrap();
    let th0 = 1.0_f64;
    let (q0, qd0) = ([l * th0.sin(), -l * th0.cos()], [0.0, 0.0]);
    let t_end = 100.0;
    let (ag, aparts) = angle_pendulum();
    let angle = energy_model(&ag, 1, &aparts, &params);
    let angle_wrt = Variational::new(&ag, 1, 2, &aparts, None, &wrt).unwrap();
    for method in [Method::Dop853, Method::Radau5] {
        let options = Options::default();
        let plain = solve(&model, &q0, &qd0, (0.0, t_end), method, &options).unwrap();
        let sol = SensitivityProblem::new(&model, &variational, &params)
            .unwrap()
            .solve(&q0, &qd0, (0.0, t_end), method, &options)
            .unwrap();
        let run = &sol.solution;
        assert!(run.stats.projections > 0, "{method:?}");
        // The residual reported is the worst of the states returned (every accepted step).
        let worst = (1..run.len())
            .map(|i| {
                model
                    .residuals(run.t[i], run.q_at(i), run.qd_at(i))
                    .unwrap()
                    .max_abs()
            })
            .fold(0.0, f64::max);
        let reported = run.stats.constraint_residual;
        assert_eq!(reported, worst, "{method:?}");
        let level = plain.stats.constraint_residual;
        assert!(
            reported > 0.0 && reported <= 3.0 * level,
            "{method:?}: {reported:e} with sensitivities, {level:e} in the plain run"
        );
        // The pendulum in its angle at the same times, to round-off.
        let times = Options::adaptive(1e-13, 1e-13).with_output(Output::Times(run.t.clone()));
        let reference = SensitivityProblem::new(&angle, &angle_wrt, &params)
            .unwrap()
            .solve(&[th0], &[0.0], (0.0, t_end), Method::Dop853, &times)
            .unwrap();
        assert_eq!(reference.solution.len(), run.len());
        // The run's own error in x, y, and its sensitivities' against x = l sin θ:
        // ∂x/∂g = l cos θ ∂θ/∂g, ∂x/∂l = sin θ + l cos θ ∂θ/∂l (θ₀ kept as l moves).
        let (mut state, mut along, mut size) = (0.0_f64, 0.0_f64, 0.0_f64);
        for i in 0..run.len() {
            let th = reference.solution.q[i];
            let (s, c) = th.sin_cos();
            state = state
                .max((run.q_at(i)[0] - l * s).abs())
                .max((run.q_at(i)[1] + l * c).abs());
            let dg = reference.sensitivity(i, 0)[0];
            let dl = reference.sensitivity(i, 1)[0];
            let want = [[l * c * dg, l * s * dg], [s + l * c * dl, -c + l * s * dl]];
            for (j, w) in want.iter().enumerate() {
                let got = &sol.sensitivity(i, j)[..2];
                for k in 0..2 {
                    along = along.max((got[k] - w[k]).abs());
                    size = size.max(w[k].abs());
                }
            }
        }
        // The sensitivities are as accurate, relative to their size, as the state (both about
        // 2e-5 here; unprojected, the run drifted off the rod to 1e-3 and both to 1e-2).
        assert!(
            along / size <= 3.0 * state / l && along / size < 1e-4,
            "{method:?}: sensitivity error {along:e} of {size:e}, state error {state:e}"
        );
    }
}
