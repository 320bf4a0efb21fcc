//! Integrators: the method choice, the symplectic methods on the systems they fit and their
//! refusal of the others, every typed failure of a run and bad input (the problems are those of
//! `integrators.rs`).

use crate::common::UnitMass;
use crate::integrators::{
    Drag, Quartic, SYMPLECTIC, SqrtWell, final_state, kepler, max_diff, observed_order_over,
    oscillator,
};
use approx::assert_relative_eq;
use lagrangian::integrators::{Method, Options, Output, solve};
use lagrangian::scenes::{DampedOscillator, DoublePendulum, ForcedTwoMass, SimplePendulum};
use lagrangian::{Dynamics, Error, Potential, Scalar, System};
use std::f64::consts::PI;

// ---------------------------------------------------------------------------------------------
// Method choice

#[test]
fn auto_choice_from_structure() {
    let osc = oscillator().system();
    let sol = solve(
        &osc,
        &[1.0],
        &[0.0],
        (0.0, 1.0),
        Method::Auto,
        &Options::fixed(0.01),
    )
    .unwrap();
    assert_eq!(sol.stats.method, Method::BlanesMoan4);
    assert!(sol.stats.choice.as_deref().unwrap().contains("separable"));
    let sol = solve(
        &osc,
        &[1.0],
        &[0.0],
        (0.0, 1.0),
        Method::Auto,
        &Options::default(),
    )
    .unwrap();
    assert_eq!(sol.stats.method, Method::Dop853);
    assert!(sol.stats.choice.is_some());
    // Conservative but not separable, with a fixed step: the implicit symplectic gauss4.
    let dp = DoublePendulum::new(1.0, 1.0, 1.0, 1.0, 9.81).system();
    let sol = solve(
        &dp,
        &[0.5, 0.2],
        &[0.0, 0.0],
        (0.0, 1.0),
        Method::Auto,
        &Options::fixed(0.01),
    )
    .unwrap();
    assert_eq!(sol.stats.method, Method::Gauss4);
    assert_eq!(sol.stats.accepted_steps, 100);
    // Forced (not conservative) but separable: DOP853.
    let ftm = ForcedTwoMass::new(1.0, 1.0, 1.0, 1.0)
        .with_forcing(1.0, 0.0, 0.5)
        .system();
    let sol = solve(
        &ftm,
        &[0.0, 0.0],
        &[0.0, 0.0],
        (0.0, 1.0),
        Method::Auto,
        &Options::fixed(0.1),
    )
    .unwrap();
    assert_eq!(sol.stats.method, Method::Dop853);
    // A method asked for by name is recorded without a reason.
    let sol = solve(
        &osc,
        &[1.0],
        &[0.0],
        (0.0, 1.0),
        Method::Yoshida6,
        &Options::fixed(0.1),
    )
    .unwrap();
    assert_eq!(
        (sol.stats.method, sol.stats.choice),
        (Method::Yoshida6, None)
    );
}

#[test]
fn method_names_round_trip() {
    for &m in Method::ALL {
        assert_eq!(m.name().parse::<Method>().unwrap(), m);
        assert_eq!(m.to_string(), m.name());
    }
    assert_eq!("AUTO".parse::<Method>().unwrap(), Method::Auto);
    assert!(matches!(
        "radau7".parse::<Method>(),
        Err(Error::InvalidInput { what: "method", .. })
    ));
}

// ---------------------------------------------------------------------------------------------
// Symplectic methods on the systems they fit, and refusing the others

#[test]
fn symplectic_driven_two_mass_exact() {
    // Q″(t) only: the kick stays exact, the splitting keeps its order.
    let scene = ForcedTwoMass::new(1.0, 0.5, 3.0, 2.0).with_forcing(0.7, -0.4, 1.3);
    let (x0, v0) = ([0.2, -0.1], [0.0, 0.3]);
    let exact = scene.exact_solution(x0, v0, 8.0).unwrap();
    let want = [exact[0][0], exact[0][1], exact[1][0], exact[1][1]];
    for method in SYMPLECTIC {
        let sol = solve(
            &scene.system(),
            &x0,
            &v0,
            (0.0, 8.0),
            method,
            &Options::fixed(0.002),
        )
        .unwrap();
        let err = max_diff(&final_state(&sol), &want);
        assert!(err < 1e-5, "{method}: {err:e}");
    }
}

/// U(t, q) = ½ω²q² − F q cos Ωt: a separable system whose potential depends on time, so the
/// drifts must carry t along.
#[derive(Debug, Clone, Copy)]
struct DrivenSpring {
    omega: f64,
    force: f64,
    drive: f64,
}
impl Potential for DrivenSpring {
    fn potential<D: Scalar>(&self, t: D, q: &[D]) -> D {
        q[0] * q[0] * (0.5 * self.omega * self.omega) - q[0] * (t * self.drive).cos() * self.force
    }
}

#[test]
fn order_time_dependent_potential_symplectic() {
    let u = DrivenSpring {
        omega: 2.0,
        force: 0.8,
        drive: 1.3,
    };
    let sys = System::new(1, UnitMass).with_potential(u);
    assert!(sys.structure().separable && sys.structure().time_dependent);
    // q̈ + ω²q = F cos Ωt: q = (q₀ − A) cos ωt + v₀/ω sin ωt + A cos Ωt, A = F/(ω² − Ω²).
    let (q0, v0, t1) = (0.3, -0.2, 5.0);
    let a = u.force / (u.omega * u.omega - u.drive * u.drive);
    let exact = [
        (q0 - a) * (u.omega * t1).cos()
            + v0 / u.omega * (u.omega * t1).sin()
            + a * (u.drive * t1).cos(),
        -(q0 - a) * u.omega * (u.omega * t1).sin() + v0 * (u.omega * t1).cos()
            - a * u.drive * (u.drive * t1).sin(),
    ];
    // Yoshida 8 reaches its asymptotic range late (its error constants are large) and
    // round-off soon after: four runs, errors 1e-10 … 3e-14.
    for (method, base, runs) in [
        (Method::StormerVerlet, 200, 5),
        (Method::Yoshida4, 100, 5),
        (Method::Yoshida6, 50, 5),
        (Method::Yoshida8, 60, 4),
        (Method::BlanesMoan4, 100, 5),
    ] {
        let p = observed_order_over(base, runs, |n| {
            let opts = Options::fixed(t1 / n as f64).with_output(Output::Every(usize::MAX));
            let sol = solve(&sys, &[q0], &[v0], (0.0, t1), method, &opts).unwrap();
            max_diff(&final_state(&sol), &exact)
        });
        let nominal = method.order().unwrap() as f64;
        assert!(
            (p - nominal).abs() <= 0.3,
            "{method}: observed order {p:.2}"
        );
    }
}

#[test]
fn symplectic_unsupported_double_pendulum() {
    let dp = DoublePendulum::new(1.0, 1.0, 1.0, 1.0, 9.81).system();
    for method in SYMPLECTIC {
        let err = solve(
            &dp,
            &[0.5, 0.2],
            &[0.0, 0.0],
            (0.0, 1.0),
            method,
            &Options::fixed(0.01),
        )
        .unwrap_err();
        let Error::UnsupportedMethod {
            method: name,
            why,
            fits,
        } = err
        else {
            panic!("{method}: expected UnsupportedMethod, got {err:?}")
        };
        assert_eq!(name, method.name());
        assert!(why.contains("separable"), "{why}");
        assert_eq!(
            fits,
            [
                "rk4", "dopri5", "dop853", "midpoint", "gauss4", "gauss6", "radau5"
            ]
        );
    }
    // The particle route of the same pendulum is refused as well.
    let particles = DoublePendulum::new(1.0, 1.0, 1.0, 1.0, 9.81).particles();
    let err = solve(
        &particles,
        &[0.5, 0.2],
        &[0.0, 0.0],
        (0.0, 1.0),
        Method::Yoshida4,
        &Options::fixed(0.01),
    );
    assert!(matches!(err, Err(Error::UnsupportedMethod { .. })));
}

#[test]
fn symplectic_unsupported_dissipation_and_drag() {
    let damped = DampedOscillator::new(1.0, 4.0, 0.3).system();
    let err = solve(
        &damped,
        &[1.0],
        &[0.0],
        (0.0, 1.0),
        Method::StormerVerlet,
        &Options::fixed(0.01),
    )
    .unwrap_err();
    assert!(
        matches!(&err, Error::UnsupportedMethod { why, .. } if why.contains("dissipation")),
        "{err}"
    );
    // Drag ∝ q̇|q̇| starting at rest: found by the probe at a shifted velocity.
    let drag = System::new(1, UnitMass)
        .with_potential(Quartic)
        .with_forces(Drag(0.1));
    let err = solve(
        &drag,
        &[0.1],
        &[0.0],
        (0.0, 1.0),
        Method::BlanesMoan4,
        &Options::fixed(0.01),
    )
    .unwrap_err();
    assert!(
        matches!(&err, Error::UnsupportedMethod { why, .. } if why.contains("q̇")),
        "{err}"
    );
    // Fixed-step methods need a step.
    let osc = oscillator().system();
    let err = solve(
        &osc,
        &[1.0],
        &[0.0],
        (0.0, 1.0),
        Method::Yoshida4,
        &Options::default(),
    )
    .unwrap_err();
    assert!(matches!(err, Error::InvalidInput { what: "dt", .. }));
    let err = solve(
        &osc,
        &[1.0],
        &[0.0],
        (0.0, 1.0),
        Method::Rk4,
        &Options::default(),
    )
    .unwrap_err();
    assert!(matches!(err, Error::InvalidInput { what: "dt", .. }));
}

// ---------------------------------------------------------------------------------------------
// Typed failures of a run

#[test]
fn too_many_steps_kepler() {
    let (sys, q0, qd0) = kepler(0.6);
    let opts = Options::adaptive(1e-10, 1e-10).with_max_steps(10);
    let err = solve(&sys, &q0, &qd0, (0.0, 2.0 * PI), Method::Dop853, &opts).unwrap_err();
    let Error::TooManySteps {
        t,
        steps,
        needed: None,
    } = err
    else {
        panic!("{err:?}")
    };
    assert_eq!(steps, 10);
    assert!(t > 0.0 && t < 2.0 * PI);
    // A fixed-step run that would need more steps is refused before the first.
    let opts = Options::fixed(1e-3).with_max_steps(1000);
    let err = solve(
        &sys,
        &q0,
        &qd0,
        (0.0, 2.0 * PI),
        Method::StormerVerlet,
        &opts,
    )
    .unwrap_err();
    assert_eq!(
        err,
        Error::TooManySteps {
            t: 0.0,
            steps: 1000,
            needed: Some(6284),
        }
    );
}

#[test]
fn fixed_dt_takes_the_steps_asked_for() {
    // Issue 40: rk4 with dt = 1e-4 to t = 300 (3·10⁶ steps) was refused up front with
    // "1000000 steps taken by t = 0", though no step was taken. A fixed dt sets no budget; here
    // 10⁶ + 10 steps, just past the old default, in debug-build time.
    assert_eq!(Options::fixed(1e-4).max_steps, usize::MAX);
    assert_eq!(Options::default().max_steps, 1_000_000);
    let osc = oscillator().system();
    let t_end = 100.001;
    let opts = Options::fixed(1e-4).with_output(Output::Final);
    let sol = solve(&osc, &[1.0], &[0.0], (0.0, t_end), Method::Rk4, &opts).unwrap();
    assert_eq!(sol.stats.accepted_steps, 1_000_010);
    let (t, q, _) = sol.last().unwrap();
    assert_eq!(t, t_end);
    assert_relative_eq!(q[0], (2.0 * t_end).cos(), epsilon = 1e-9);
    // A budget the caller sets is kept, and the refusal says that no step was taken.
    let opts = Options::fixed(1e-4).with_max_steps(1_000_000);
    let err = solve(&osc, &[1.0], &[0.0], (0.0, 300.0), Method::Rk4, &opts).unwrap_err();
    assert_eq!(
        err,
        Error::TooManySteps {
            t: 0.0,
            steps: 1_000_000,
            needed: Some(3_000_000),
        }
    );
    let message = err.to_string();
    assert!(
        message.contains("needs 3000000 steps") && message.contains("no step was taken"),
        "{message}"
    );
    assert!(!message.contains("steps taken"), "{message}");
}

#[test]
fn non_finite_state_sqrt_well() {
    // q̈ = −√q from q = 1 moving down at 3: q turns negative and √q is NaN.
    let sys = System::new(1, UnitMass).with_potential(SqrtWell);
    let dt = 0.01;
    for method in [Method::StormerVerlet, Method::Rk4] {
        let err = solve(
            &sys,
            &[1.0],
            &[-3.0],
            (0.0, 2.0),
            method,
            &Options::fixed(dt),
        )
        .unwrap_err();
        let Error::NonFinite { t, .. } = err else {
            panic!("{method}: {err:?}")
        };
        assert!(t > 0.2 && t < 0.6, "{method}: at t = {t}");
        // One step earlier everything was finite, with q still ≥ 0 (or, for RK4, a stage beyond).
        let before = (t / dt).floor() * dt - dt;
        let sol = solve(
            &sys,
            &[1.0],
            &[-3.0],
            (0.0, before),
            method,
            &Options::fixed(dt),
        )
        .unwrap();
        assert!(sol.last().unwrap().1[0] > -1e-12, "{method}");
    }
    // The adaptive method shrinks its step towards the edge, then reports where it stopped.
    let err = solve(
        &sys,
        &[1.0],
        &[-3.0],
        (0.0, 2.0),
        Method::Dop853,
        &Options::default(),
    )
    .unwrap_err();
    let Error::NonFinite { t, .. } = err else {
        panic!("{err:?}")
    };
    let reached = solve(
        &sys,
        &[1.0],
        &[-3.0],
        (0.0, t * (1.0 - 1e-9)),
        Method::Dop853,
        &Options::default(),
    )
    .unwrap();
    assert!(
        reached.last().unwrap().1[0].abs() < 1e-6,
        "stopped away from q = 0"
    );
}

#[test]
fn step_size_floor_quartic_blow_up() {
    let sys = System::new(1, UnitMass).with_potential(Quartic);
    // Exact q = 1/(1 − t): the step shrinks with 1 − t until it hits 10 ε t.
    let err = solve(
        &sys,
        &[1.0],
        &[1.0],
        (0.0, 2.0),
        Method::Dop853,
        &Options::default(),
    )
    .unwrap_err();
    let Error::StepSizeTooSmall { t, h } = err else {
        panic!("{err:?}")
    };
    // The numerical blow-up time is 1 up to the global error.
    assert!((t - 1.0).abs() < 1e-6 && h < 1e-13, "t = {t}, h = {h}");
    // A user floor stops it earlier, before 1 − t is much below it.
    let opts = Options::default().with_min_step(1e-6);
    let err = solve(&sys, &[1.0], &[1.0], (0.0, 2.0), Method::Dopri5, &opts).unwrap_err();
    let Error::StepSizeTooSmall { t, h } = err else {
        panic!("{err:?}")
    };
    assert!(h <= 1e-6 && t < 1.0 && 1.0 - t < 1e-3, "t = {t}, h = {h}");
}

#[test]
fn stiffness_detected_stiff_damped_spring() {
    // k = 1e8, c = 1e5 (ζ = 5): eigenvalues ≈ −1e3 and −1e5. After the fast transient the
    // explicit step is held at the stability edge, |hλ| ≈ 6, and Hairer's test fires.
    let osc = DampedOscillator::new(1.0, 1e8, 1e5);
    for (method, bound) in [(Method::Dop853, 6.1), (Method::Dopri5, 3.25)] {
        let err = solve(
            &osc.system(),
            &[1e-3],
            &[0.0],
            (0.0, 10.0),
            method,
            &Options::default(),
        )
        .unwrap_err();
        let Error::Stiffness {
            t,
            method: name,
            suggestion,
            steps,
        } = err
        else {
            panic!("{method}: {err:?}")
        };
        assert_eq!((name, suggestion), (method.name(), "radau5"));
        // The first test is at step 1000, the 15th positive one soon after.
        assert!((1000..1100).contains(&steps), "{method}: {steps} steps");
        // Steps near the stability bound |hλ| ≤ bound: t is about steps · bound / 1e5.
        assert!(t < 2.0 * steps as f64 * bound / 9.9e4, "{method}: t = {t}");
    }
    // Without the test the run completes, slowly: the step count is that of stability.
    let opts = Options::default().with_stiffness_check(None);
    let sol = solve(
        &osc.system(),
        &[1e-3],
        &[0.0],
        (0.0, 0.05),
        Method::Dop853,
        &opts,
    )
    .unwrap();
    assert!(sol.stats.accepted_steps > 500);
    // The non-stiff oscillator never triggers it.
    let sol = solve(
        &oscillator().system(),
        &[1.0],
        &[0.0],
        (0.0, 2000.0),
        Method::Dopri5,
        &Options::adaptive(1e-6, 1e-6),
    )
    .unwrap();
    assert!(sol.stats.accepted_steps > 1000);
}

// ---------------------------------------------------------------------------------------------
// Bad input

#[test]
fn invalid_input_simple_pendulum() {
    let sys = SimplePendulum::new(1.0, 1.0, 9.81).system();
    let run = |q: &[f64], qd: &[f64], span, opts: Options| {
        solve(&sys, q, qd, span, Method::Dop853, &opts)
    };
    let ok = Options::default();
    assert!(matches!(
        run(&[0.1, 0.2], &[0.0], (0.0, 1.0), ok.clone()),
        Err(Error::DimensionMismatch { what: "q", .. })
    ));
    assert!(matches!(
        run(&[0.1], &[], (0.0, 1.0), ok.clone()),
        Err(Error::DimensionMismatch { what: "qd", .. })
    ));
    assert!(matches!(
        run(&[f64::NAN], &[0.0], (0.0, 1.0), ok.clone()),
        Err(Error::NonFinite { .. })
    ));
    assert!(matches!(
        run(&[0.1], &[f64::INFINITY], (0.0, 1.0), ok.clone()),
        Err(Error::NonFinite { .. })
    ));
    assert!(matches!(
        run(&[0.1], &[0.0], (f64::NAN, 1.0), ok.clone()),
        Err(Error::NonFinite { .. })
    ));
    assert!(matches!(
        run(&[0.1], &[0.0], (0.0, f64::INFINITY), ok.clone()),
        Err(Error::NonFinite { .. })
    ));
    assert!(matches!(
        run(&[0.1], &[0.0], (1.0, 1.0), ok.clone()),
        Err(Error::InvalidInput { what: "span", .. })
    ));
    let bad = |opts: Options, what: &str| {
        let err = run(&[0.1], &[0.0], (0.0, 1.0), opts).unwrap_err();
        assert!(
            matches!(&err, Error::InvalidInput { what: w, .. } if *w == what),
            "{err:?}"
        );
    };
    bad(Options::adaptive(-1e-6, 1e-9), "rtol");
    bad(Options::adaptive(1e-6, -1e-9), "atol");
    bad(Options::adaptive(1e-6, f64::NAN), "atol");
    bad(Options::adaptive(0.0, 0.0), "rtol");
    bad(Options::fixed(0.0), "dt");
    bad(Options::fixed(-0.1), "dt");
    bad(Options::default().with_initial_step(-1.0), "initial_step");
    bad(Options::default().with_max_step(0.0), "max_step");
    bad(Options::default().with_min_step(f64::NAN), "min_step");
    bad(Options::default().with_max_steps(0), "max_steps");
    bad(
        Options::default().with_stiffness_check(Some(0)),
        "stiffness_check",
    );
    bad(Options::default().with_output(Output::Every(0)), "output");
    bad(
        Options::default().with_output(Output::Times(vec![0.5, 2.0])),
        "output",
    );
    bad(
        Options::default().with_output(Output::Times(vec![0.5, 0.25])),
        "output",
    );
    bad(
        Options::default().with_output(Output::Times(vec![f64::NAN])),
        "output",
    );
}
