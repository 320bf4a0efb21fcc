//! Forward sensitivities from Rust (`lagrangian::sensitivity`) on models built on the expression
//! graph, against closed forms: the harmonic oscillator in k and the initial state by hand, the
//! damped oscillator in k, c and the initial state by dual numbers on its exact solution;
//! `Options::with_error_coordinates` (error control on (q, q̇) alone) and what refuses it; events.

use approx::assert_relative_eq;
use lagrangian::integrators::Event;
use lagrangian::num_dual::{Dual64, DualNum};
use lagrangian::sensitivity::{Direction, SensitivitySolution, Variational, solve_sensitivities};
use lagrangian::tape::{Binary, Energies, Graph};
use lagrangian::{Error, Method, Options, Output};

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
