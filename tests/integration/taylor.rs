//! The Taylor method (issue 16) against closed forms: Kepler's orbit (e = 0.6) and the seed's
//! forced two-mass system (eq. 41–44), each to within 10 × the tolerance over tol = 1e-6 … 1e-15
//! with the error proportional to the tolerance; dense output and events on the step's
//! polynomial; a long run switching to the unrolled expansion bit for bit; the errors it gives
//! for what it cannot do.

use lagrangian::integrators::{Event, Method, Options, Output, solve, solve_partial};
use lagrangian::scenes::ForcedTwoMass;
use lagrangian::tape::{
    Binary, Energies, EnergyModel, EomFunction, EomProgram, Function, Graph, Inputs, Tape, models,
};
use lagrangian::{Dynamics, Error};
use std::sync::Arc;

/// The model of `parts` on `g` with its derived (compiled) program bound to `params`.
fn model(g: Graph, dof: usize, parts: &Energies, params: &[f64]) -> EnergyModel {
    model_with(g, dof, parts, params, Build::Native)
}

/// How a test model's program is made: compiled, interpreted, or compiled with its small
/// Taylor expansions unrolled from their first run (as the Python models are).
#[derive(Clone, Copy)]
enum Build {
    Native,
    Interpreted,
    EarlyUnroll,
}

/// [`model`], with its program made as `build` says.
fn model_with(
    mut g: Graph,
    dof: usize,
    parts: &Energies,
    params: &[f64],
    build: Build,
) -> EnergyModel {
    let program = EomProgram::new(&mut g, dof, params.len(), parts).unwrap();
    let program = match build {
        Build::Native => program,
        Build::Interpreted => program.interpreted(),
        Build::EarlyUnroll => program.unroll_small_early(),
    };
    let f = |nodes: &[usize], inputs: Inputs| {
        Function::new(
            Arc::new(Tape::new(&g, nodes, inputs, "part").unwrap()),
            params,
        )
        .unwrap()
    };
    let all = Inputs::kinetic(dof, params.len());
    EnergyModel::new(
        dof,
        f(&[parts.kinetic], all),
        parts
            .potential
            .map(|u| f(&[u], Inputs::potential(dof, params.len()))),
        parts.dissipation.map(|r| f(&[r], all)),
        parts.forces.as_ref().map(|q| f(q, all)),
    )
    .unwrap()
    .with_program(program.bind(params).unwrap())
    .unwrap()
}

/// Kepler's problem in polar coordinates (r, θ), μ = 1: T = ½(ṙ² + r²θ̇²), U = −μ/r.
fn kepler() -> EnergyModel {
    kepler_with(Build::Native)
}

/// [`kepler`], its program made as `build` says.
fn kepler_with(build: Build) -> EnergyModel {
    let mut g = Graph::new();
    let (r, rd, thd, mu) = (g.coord(0), g.velocity(0), g.velocity(1), g.param(0));
    let half = g.constant(0.5);
    let rd2 = g.powi(rd, 2).unwrap();
    let r2 = g.powi(r, 2).unwrap();
    let thd2 = g.powi(thd, 2).unwrap();
    let rt = g.binary(Binary::Mul, r2, thd2).unwrap();
    let sum = g.binary(Binary::Add, rd2, rt).unwrap();
    let kinetic = g.binary(Binary::Mul, half, sum).unwrap();
    let over = g.binary(Binary::Div, mu, r).unwrap();
    let potential = g.unary(lagrangian::tape::Unary::Neg, over).unwrap();
    let parts = Energies {
        kinetic,
        potential: Some(potential),
        dissipation: None,
        forces: None,
    };
    model_with(g, 2, &parts, &[1.0], build)
}

/// The orbit of semi-major axis 1 and eccentricity e from the pericentre at t = 0, μ = 1: (r, θ,
/// ṙ, θ̇) at t from Kepler's equation E − e sin E = t (Newton to round-off), θ unwrapped.
fn kepler_exact(e: f64, t: f64) -> [f64; 4] {
    let mean = t;
    let mut big_e = if e > 0.8 { std::f64::consts::PI } else { mean };
    for _ in 0..50 {
        let step = (big_e - e * big_e.sin() - mean) / (1.0 - e * big_e.cos());
        big_e -= step;
        if step.abs() < 1e-16 * big_e.abs().max(1.0) {
            break;
        }
    }
    let r = 1.0 - e * big_e.cos();
    let half =
        ((1.0 + e).sqrt() * (big_e / 2.0).sin()).atan2((1.0 - e).sqrt() * (big_e / 2.0).cos());
    // ν/2 is within π/2 of E/2: the branch of atan2 that follows E.
    let pi = std::f64::consts::PI;
    let theta = 2.0 * (half + pi * ((big_e / 2.0 - half) / pi).round());
    let h = (1.0 - e * e).sqrt();
    [r, theta, e * big_e.sin() / r, h / (r * r)]
}

/// The Taylor method's end state (q, q̇) at t_end from t = 0 at rtol = atol = tol, and its steps.
fn end_state(
    model: &EnergyModel,
    q0: &[f64],
    v0: &[f64],
    t_end: f64,
    tol: f64,
) -> (Vec<f64>, usize) {
    let options = Options::adaptive(tol, tol);
    let sol = solve(model, q0, v0, (0.0, t_end), Method::Taylor, &options).unwrap();
    let (_, q, qd) = sol.last().unwrap();
    ([q, qd].concat(), sol.stats.accepted_steps)
}

/// max |yᵢ − exactᵢ| / max(1, |exactᵢ|).
fn error(y: &[f64], exact: &[f64]) -> f64 {
    y.iter()
        .zip(exact)
        .map(|(a, b)| (a - b).abs() / b.abs().max(1.0))
        .fold(0.0, f64::max)
}

/// The end state's error for each tolerance, checked against 10 × tol, and the slope of
/// log(error) against log(tol) over the tolerances where round-off does not dominate.
fn to_the_tolerance(
    what: &str,
    run: impl Fn(f64) -> (Vec<f64>, usize),
    exact: &[f64],
) -> Vec<(f64, f64)> {
    let mut errors = Vec::new();
    for tol in [
        1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12, 1e-13, 1e-14, 1e-15,
    ] {
        let (y, steps) = run(tol);
        let err = error(&y, exact);
        eprintln!("{what}: tol {tol:e}, error {err:.2e}, {steps} steps");
        assert!(err <= 10.0 * tol, "{what}: tol {tol:e}, error {err:e}");
        errors.push((tol, err));
    }
    // Proportional to the tolerance: the least-squares slope over 1e-6 … 1e-12.
    let pts: Vec<(f64, f64)> = errors
        .iter()
        .filter(|(tol, _)| *tol >= 1e-12)
        .map(|&(tol, e)| (tol.log10(), e.log10()))
        .collect();
    let n = pts.len() as f64;
    let (sx, sy) = pts.iter().fold((0.0, 0.0), |(a, b), p| (a + p.0, b + p.1));
    let (mx, my) = (sx / n, sy / n);
    let num: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let den: f64 = pts.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let slope = num / den;
    eprintln!("{what}: slope of log error against log tol {slope:.3}");
    assert!((0.8..=1.25).contains(&slope), "{what}: slope {slope}");
    errors
}

#[test]
fn kepler_orbit_to_the_tolerance() {
    let e: f64 = 0.6;
    let model = kepler();
    let q0 = [1.0 - e, 0.0];
    let v0 = [0.0, (1.0 - e * e).sqrt() / ((1.0 - e) * (1.0 - e))];
    // Two orbits and a half: through the pericentre twice, ending near the apocentre.
    let t_end = 5.0 * std::f64::consts::PI;
    let exact = kepler_exact(e, t_end);
    to_the_tolerance(
        "Kepler e = 0.6",
        |tol| end_state(&model, &q0, &v0, t_end, tol),
        &exact,
    );
}

/// A run long enough for the switch to the unrolled expansion (after 10⁴ expansions at one
/// order): 300 Kepler orbits at tol 1e-6 (order 8), the end state bit for bit the interpreter's,
/// the switch made, and the orbit still closing on the start.
#[test]
fn long_run_switches_to_the_unrolled_expansion_bit_for_bit() {
    let e: f64 = 0.6;
    let q0 = [1.0 - e, 0.0];
    let v0 = [0.0, (1.0 - e * e).sqrt() / ((1.0 - e) * (1.0 - e))];
    let t_end = 300.0 * 2.0 * std::f64::consts::PI;
    let (native, interpreted) = (kepler(), kepler_with(Build::Interpreted));
    let (a, steps) = end_state(&native, &q0, &v0, t_end, 1e-6);
    let (b, _) = end_state(&interpreted, &q0, &v0, t_end, 1e-6);
    assert!(steps > 10_000, "{steps} steps");
    let program = EomFunction::of(native.derived_program().unwrap())
        .taylor()
        .0;
    // p = ⌈ln 10⁶ / 2 + 1⌉ = 8.
    assert_eq!(program.is_unrolled(8), cfg!(feature = "jit"));
    for (x, y) in a.iter().zip(&b) {
        assert_eq!(x.to_bits(), y.to_bits(), "{a:?} against {b:?}");
    }
    // The energy −μ/2a = −½ and the angular momentum r²θ̇ = √(1 − e²) kept to the tolerance
    // over the 300 orbits (the phase drifts: ṙ at the pericentre is off by 1e-2).
    let (r, rd, thd) = (a[0], a[2], a[3]);
    let energy = 0.5 * (rd * rd + r * r * thd * thd) - 1.0 / r;
    let momentum = r * r * thd;
    let (de, dh) = (
        (energy + 0.5).abs(),
        (momentum - (1.0 - e * e).sqrt()).abs(),
    );
    eprintln!("300 orbits at tol 1e-6, {steps} steps: energy off by {de:.1e}, momentum {dh:.1e}");
    assert!(de < 1e-5 && dh < 1e-5, "{de:e} {dh:e}");
}

/// A run whose first step says it will take past 10⁴ steps compiles the unrolled expansion
/// then, not after 10⁴ expansions (it would be compiled within the run anyway): 300 Kepler
/// orbits at tol 1e-6 stopped after 20 steps leave the expansion unrolled; a short run (an
/// orbit, about 60 steps) leaves it to the series kernel.
#[test]
fn long_run_compiles_the_unrolled_expansion_at_its_start() {
    let e: f64 = 0.6;
    let q0 = [1.0 - e, 0.0];
    let v0 = [0.0, (1.0 - e * e).sqrt() / ((1.0 - e) * (1.0 - e))];
    let orbit = 2.0 * std::f64::consts::PI;
    let model = kepler();
    let program = EomFunction::of(model.derived_program().unwrap()).taylor().0;
    let (_, steps) = end_state(&model, &q0, &v0, orbit, 1e-6);
    assert!(steps < 1_000, "{steps} steps");
    assert!(!program.is_unrolled(8));
    let options = Options::adaptive(1e-6, 1e-6).with_max_steps(20);
    let stopped = solve(
        &model,
        &q0,
        &v0,
        (0.0, 300.0 * orbit),
        Method::Taylor,
        &options,
    );
    assert!(
        matches!(stopped, Err(Error::TooManySteps { .. })),
        "{stopped:?}"
    );
    assert_eq!(program.is_unrolled(8), cfg!(feature = "jit"));
}

/// A program run again and again (`EomProgram::unroll_small_early`, as a Python model's) compiles
/// its small expansion unrolled at the first expansion to an order, not after 10⁴: one Kepler
/// orbit (about 60 steps) leaves it unrolled, with the end state bit for bit the default
/// program's, which stays on the series kernel.
#[test]
fn early_unroll_compiles_at_the_first_run_with_the_same_bits() {
    let e: f64 = 0.6;
    let q0 = [1.0 - e, 0.0];
    let v0 = [0.0, (1.0 - e * e).sqrt() / ((1.0 - e) * (1.0 - e))];
    let orbit = 2.0 * std::f64::consts::PI;
    let (late, early) = (kepler(), kepler_with(Build::EarlyUnroll));
    let (a, steps) = end_state(&late, &q0, &v0, orbit, 1e-6);
    let (b, _) = end_state(&early, &q0, &v0, orbit, 1e-6);
    assert!(steps < 1_000, "{steps} steps");
    let unrolled = |m: &EnergyModel| {
        EomFunction::of(m.derived_program().unwrap())
            .taylor()
            .0
            .is_unrolled(8)
    };
    assert!(!unrolled(&late));
    assert_eq!(unrolled(&early), cfg!(feature = "jit"));
    for (x, y) in a.iter().zip(&b) {
        assert_eq!(x.to_bits(), y.to_bits(), "{a:?} against {b:?}");
    }
}

/// Seed eq. 41–44 as expressions: T = ½ m₁ẋ₁² + ½ m₂ẋ₂², U = ½ k₁x₁² + ½ k₂(x₂ − x₁)², Q″ =
/// F cos Ωt, with the parameters (m₁, m₂, k₁, k₂, F₁, F₂, Ω).
fn forced_two_mass(params: [f64; 7]) -> EnergyModel {
    let mut g = Graph::new();
    let p: Vec<usize> = (0..7).map(|i| g.param(i)).collect();
    let (x1, x2, v1, v2, t) = (
        g.coord(0),
        g.coord(1),
        g.velocity(0),
        g.velocity(1),
        g.time(),
    );
    let half = g.constant(0.5);
    let quad = |g: &mut Graph, k: usize, x: usize| {
        let x2 = g.powi(x, 2).unwrap();
        let kx = g.binary(Binary::Mul, k, x2).unwrap();
        g.binary(Binary::Mul, half, kx).unwrap()
    };
    let t1 = quad(&mut g, p[0], v1);
    let t2 = quad(&mut g, p[1], v2);
    let kinetic = g.binary(Binary::Add, t1, t2).unwrap();
    let u1 = quad(&mut g, p[2], x1);
    let stretch = g.binary(Binary::Sub, x2, x1).unwrap();
    let u2 = quad(&mut g, p[3], stretch);
    let potential = g.binary(Binary::Add, u1, u2).unwrap();
    let wt = g.binary(Binary::Mul, p[6], t).unwrap();
    let c = g.unary(lagrangian::tape::Unary::Cos, wt).unwrap();
    let forces = vec![
        g.binary(Binary::Mul, p[4], c).unwrap(),
        g.binary(Binary::Mul, p[5], c).unwrap(),
    ];
    let parts = Energies {
        kinetic,
        potential: Some(potential),
        dissipation: None,
        forces: Some(forces),
    };
    model(g, 2, &parts, &params)
}

#[test]
fn forced_two_mass_to_the_tolerance() {
    let (m1, m2, k1, k2, f1, f2, omega) = (1.0, 2.0, 3.0, 1.5, 0.5, 0.2, 1.3);
    let scene = ForcedTwoMass::new(m1, m2, k1, k2).with_forcing(f1, f2, omega);
    let model = forced_two_mass([m1, m2, k1, k2, f1, f2, omega]);
    let (x0, v0) = ([0.3, -0.2], [0.1, 0.4]);
    let t_end = 20.0;
    let [x, v] = scene.exact_solution(x0, v0, t_end).unwrap();
    let exact = [x[0], x[1], v[0], v[1]];
    to_the_tolerance(
        "forced two-mass",
        |tol| end_state(&model, &x0, &v0, t_end, tol),
        &exact,
    );
}

/// Dense output is each step's Taylor polynomial: on Kepler's orbit it matches the exact
/// solution between the steps as well as at them, and an event (the apocentre, ṙ = 0 falling)
/// is found on it at the exact time (half a period, π).
#[test]
fn kepler_dense_output_and_apocentre_event() {
    let e: f64 = 0.6;
    let model = kepler();
    let q0 = [1.0 - e, 0.0];
    let v0 = [0.0, (1.0 - e * e).sqrt() / ((1.0 - e) * (1.0 - e))];
    let options = Options::adaptive(1e-13, 1e-13)
        .with_dense(true)
        .with_event(Event::new("apocentre", |_t, _q, qd| qd[0]).falling());
    let sol = solve(&model, &q0, &v0, (0.0, 7.0), Method::Taylor, &options).unwrap();
    let found = &sol.events[0];
    assert_eq!(found.t.len(), 1);
    assert!(
        (found.t[0] - std::f64::consts::PI).abs() < 1e-11,
        "{}",
        found.t[0]
    );
    let dense = sol.dense.as_ref().unwrap();
    let mut y = [0.0; 4];
    for i in 0..=200 {
        let t = 7.0 * i as f64 / 200.0;
        dense.eval(t, &mut y).unwrap();
        let err = error(&y, &kepler_exact(e, t));
        assert!(err < 1e-11, "t = {t}: error {err:e}");
    }
}

/// What the Taylor method cannot do is a typed error: a fixed step, and a model with no
/// expression graph (Rust types implementing the energy traits).
#[test]
fn taylor_refuses_fixed_steps_and_models_without_a_graph() {
    let model = kepler();
    let err = solve(
        &model,
        &[0.4, 0.0],
        &[0.0, 2.0],
        (0.0, 1.0),
        Method::Taylor,
        &Options::fixed(0.01),
    )
    .unwrap_err();
    assert!(
        matches!(err, Error::InvalidInput { what: "dt", .. }),
        "{err:?}"
    );
    let scene = ForcedTwoMass::new(1.0, 1.0, 1.0, 1.0).system();
    assert!(scene.derived_program().is_none());
    let err = solve(
        &scene,
        &[0.1, 0.0],
        &[0.0, 0.0],
        (0.0, 1.0),
        Method::Taylor,
        &Options::adaptive(1e-9, 1e-9),
    )
    .unwrap_err();
    assert!(format!("{err}").contains("expression"), "{err}");
}

/// A program too large for loops in the code (its convolutions are calls of the interpreter's
/// sum): the 12-link chain's coefficients bit for bit against the interpreter's.
#[test]
fn large_program_coefficients_match_the_interpreter() {
    let n = 12;
    let mut g = Graph::new();
    let parts = lagrangian::tape::models::pendulum_chain(&mut g, n).unwrap();
    let program = EomProgram::new(&mut g, n, 3, &parts).unwrap();
    let params = [1.0, 0.8, 9.81];
    let native = program.bind(&params).unwrap();
    let interpreted = program.interpreted().bind(&params).unwrap();
    let (a, _) = native.taylor();
    let (b, _) = interpreted.taylor();
    assert!(a.recurrences() > 400, "{}", a.recurrences());
    assert_eq!(a.is_native(), cfg!(feature = "jit"));
    let q: Vec<f64> = (0..n).map(|i| 0.3 - 0.05 * i as f64).collect();
    let qd: Vec<f64> = (0..n).map(|i| 0.1 * (i % 3) as f64).collect();
    let (mut x, mut y) = (a.expansion(&params, 16), b.expansion(&params, 16));
    x.expand(0.0, &q, &qd).unwrap();
    y.expand(0.0, &q, &qd).unwrap();
    for k in 0..=16 {
        for (u, v) in x.q(k).iter().zip(y.q(k)).chain(x.qd(k).iter().zip(y.qd(k))) {
            assert_eq!(u.to_bits(), v.to_bits(), "order {k}: {u} against {v}");
        }
    }
}

/// A ball bouncing on the floor (T = ½ẏ², U = g y, e = 0.8), stated as expressions: the impacts
/// at the geometric series of times, and the step-by-step solver giving `solve`'s run bit for
/// bit, resets included.
#[test]
fn bouncing_ball_impacts_and_stepping() {
    use lagrangian::integrators::{Solver, StepOutcome};
    let (e, g_) = (0.8, 9.81);
    let mut g = Graph::new();
    let (y, v, grav) = (g.coord(0), g.velocity(0), g.param(0));
    let half = g.constant(0.5);
    let v2 = g.powi(v, 2).unwrap();
    let kinetic = g.binary(Binary::Mul, half, v2).unwrap();
    let potential = g.binary(Binary::Mul, grav, y).unwrap();
    let parts = Energies {
        kinetic,
        potential: Some(potential),
        dissipation: None,
        forces: None,
    };
    let ball = model(g, 1, &parts, &[g_]);
    let bounce = Event::new("floor", |_t, q, _qd| q[0])
        .falling()
        .with_reset(move |_t, _q, qd| qd[0] *= -e);
    let options = Options::adaptive(1e-12, 1e-12).with_event(bounce);
    let span = (0.0, 2.5);
    let whole = solve(&ball, &[1.0], &[0.0], span, Method::Taylor, &options).unwrap();
    // Impact k at t₁ (1 + 2e + … + 2eᵏ⁻¹), t₁ = √(2h/g).
    let t1 = (2.0_f64 / g_).sqrt();
    let found = &whole.events[0].t;
    assert!(found.len() >= 4, "{found:?}");
    let mut expected = t1;
    for (k, &t) in found.iter().enumerate() {
        assert!(
            (t - expected).abs() < 1e-10,
            "impact {k}: {t} against {expected}"
        );
        expected += 2.0 * t1 * e.powi(k as i32 + 1);
    }
    let mut solver = Solver::new(&ball, &[1.0], &[0.0], span, Method::Taylor, &options).unwrap();
    let mut row = 0;
    loop {
        let outcome = solver.step().unwrap();
        row += if matches!(outcome, StepOutcome::Reset { .. }) {
            2
        } else {
            1
        };
        assert_eq!(solver.t(), whole.t[row]);
        match outcome {
            StepOutcome::Stepped | StepOutcome::Reset { .. } => {}
            StepOutcome::Finished => break,
            other => panic!("{other:?}"),
        }
    }
    assert_eq!(solver.solution(), whole);
}

/// A whole run takes the steps that nothing watches (output kept every k-th step, or at the
/// end only) in a row without handing each out, and once its expansion is compiled unrolled,
/// in rows of compiled code: the same steps, bit for bit, as a run keeping every one with the
/// expansion interpreted, on Kepler's orbit and the double pendulum (M varies: factored in the
/// row), and the forced two-mass system (t read: its row set in the row); and a run that fails among them names the
/// state it reached (the step budget spent on Kepler's orbit; ẍ = x², which blows up at t = √6
/// from x = 1, ẋ = √(2/3)).
#[test]
fn runs_keeping_fewer_steps_take_the_same_steps() {
    let e: f64 = 0.6;
    let kepler_start = (
        vec![1.0 - e, 0.0],
        vec![0.0, (1.0 - e * e).sqrt() / ((1.0 - e) * (1.0 - e))],
    );
    let forced = forced_two_mass([1.0, 2.0, 3.0, 1.5, 0.5, 0.2, 1.3]);
    let forced_start = (vec![0.3, -0.2], vec![0.1, 0.4]);
    let orbit = kepler();
    let mut g = Graph::new();
    let parts = lagrangian::tape::models::double_pendulum(&mut g).unwrap();
    let pendulum = model(g, 2, &parts, &[1.0, 2.0, 1.5, 0.7, 9.81]);
    let pendulum_start = (vec![1.0, -0.5], vec![0.3, 2.0]);
    let options = |output: Output| Options::adaptive(1e-10, 1e-10).with_output(output);
    // p = ⌈ln 10¹⁰ / 2 + 1⌉ = 13.
    let unroll = |model: &EnergyModel| {
        let program = EomFunction::of(model.derived_program().unwrap()).taylor().0;
        assert_eq!(program.unroll(13), cfg!(feature = "jit"));
    };
    let row = |sol: &lagrangian::integrators::Solution, i: usize| {
        [vec![sol.t[i]], sol.q_at(i).to_vec(), sol.qd_at(i).to_vec()].concat()
    };
    let bits = |x: &[f64]| x.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
    for (model, (q0, v0), span) in [
        (&orbit, &kepler_start, (0.0, 4.0 * std::f64::consts::PI)),
        (&forced, &forced_start, (0.0, 40.0)),
        (&pendulum, &pendulum_start, (0.0, 5.0)),
    ] {
        let run = |o: &Options| {
            solve_partial(model, q0, v0, span, Method::Taylor, o, None).map_err(Box::new)
        };
        let all = run(&options(Output::Steps)).unwrap();
        let steps = all.stats.accepted_steps;
        assert!(steps > 60, "{steps} steps");
        for unrolled in [false, true] {
            if unrolled {
                unroll(model);
            }
            for (output, kept) in [
                (Output::Every(1), (0..=steps).collect::<Vec<_>>()),
                (
                    Output::Every(7),
                    (0..=steps).filter(|i| i % 7 == 0 || *i == steps).collect(),
                ),
                (Output::Every(usize::MAX), vec![0, steps]),
                (Output::Final, vec![steps]),
            ] {
                let sol = run(&options(output.clone())).unwrap();
                let case = format!("{output:?}, unrolled {unrolled}");
                assert_eq!(sol.stats.accepted_steps, steps, "{case}");
                assert_eq!(sol.len(), kept.len(), "{case}");
                for (j, &i) in kept.iter().enumerate() {
                    let (a, b) = (row(&sol, j), row(&all, i));
                    assert_eq!(bits(&a), bits(&b), "{case}, step {i}: {a:?} against {b:?}");
                }
            }
            // The budget of 50 steps spent: the failure names the 50th step's state, whatever
            // is kept.
            let limited = |output: Output| options(output).with_max_steps(50);
            for output in [Output::Steps, Output::Every(7), Output::Final] {
                let failed = run(&limited(output.clone())).unwrap_err();
                let case = format!("{output:?}, unrolled {unrolled}");
                assert!(
                    matches!(failed.error, Error::TooManySteps { steps: 50, .. }),
                    "{case}: {:?}",
                    failed.error
                );
                let (t, q, qd) = failed.last.unwrap();
                assert_eq!([vec![t], q, qd].concat(), row(&all, 50), "{case}");
                let partial = failed.partial.unwrap();
                assert_eq!(row(&partial, partial.len() - 1), row(&all, 50), "{case}");
            }
        }
    }
    // ẍ = x² (T = ½ẋ², U = −x³/3): x = 6 / (√6 − t)². Every run stops at the same state, at
    // the blow-up, unrolled or not.
    let mut g = Graph::new();
    let (x, v) = (g.coord(0), g.velocity(0));
    let (half, third) = (g.constant(0.5), g.constant(-1.0 / 3.0));
    let (v2, x3) = (g.powi(v, 2).unwrap(), g.powi(x, 3).unwrap());
    let parts = Energies {
        kinetic: g.binary(Binary::Mul, half, v2).unwrap(),
        potential: Some(g.binary(Binary::Mul, third, x3).unwrap()),
        dissipation: None,
        forces: None,
    };
    let blowup = model(g, 1, &parts, &[]);
    let mut stops = Vec::new();
    for unrolled in [false, true] {
        if unrolled {
            unroll(&blowup);
        }
        for output in [Output::Steps, Output::Every(7), Output::Final] {
            let o = options(output);
            let failed = solve_partial(
                &blowup,
                &[1.0],
                &[(2.0_f64 / 3.0).sqrt()],
                (0.0, 3.0),
                Method::Taylor,
                &o,
                None,
            )
            .unwrap_err();
            let (t, q, qd) = failed.last.unwrap();
            stops.push((format!("{:?}", failed.error), [vec![t], q, qd].concat()));
        }
    }
    let (t, x) = (stops[0].1[0], stops[0].1[1]);
    assert!((t - 6.0_f64.sqrt()).abs() < 1e-9 && x > 1e20, "{stops:?}");
    assert!(stops.iter().all(|s| *s == stops[0]), "{stops:?}");
}

/// A mass matrix that does not factor at the start is a typed error naming the state, whether
/// the step is taken alone or in a row of compiled steps: T = ½ x² ẋ² (M = x²), and T = ½ (x² ẋ²
/// + ẏ²) (M = diag(x², 1)), at x = 0.
#[test]
fn a_singular_mass_matrix_stops_the_run_with_its_error() {
    for dof in [1, 2] {
        let mut g = Graph::new();
        let (x, v) = (g.coord(0), g.velocity(0));
        let half = g.constant(0.5);
        let xv = g.binary(Binary::Mul, x, v).unwrap();
        let mut twice = g.powi(xv, 2).unwrap();
        if dof == 2 {
            let (_, w) = (g.coord(1), g.velocity(1));
            let w2 = g.powi(w, 2).unwrap();
            twice = g.binary(Binary::Add, twice, w2).unwrap();
        }
        let parts = Energies {
            kinetic: g.binary(Binary::Mul, half, twice).unwrap(),
            potential: None,
            dissipation: None,
            forces: None,
        };
        let singular = model(g, dof, &parts, &[]);
        let (q0, v0) = (&[0.0, 0.3][..dof], &[1.0, 0.5][..dof]);
        for unrolled in [false, true] {
            if unrolled {
                let program = EomFunction::of(singular.derived_program().unwrap())
                    .taylor()
                    .0;
                assert_eq!(program.unroll(8), cfg!(feature = "jit"));
            }
            for output in [Output::Steps, Output::Final] {
                let o = Options::adaptive(1e-6, 1e-6).with_output(output.clone());
                let span = (0.0, 1.0);
                let failed =
                    solve_partial(&singular, q0, v0, span, Method::Taylor, &o, None).unwrap_err();
                let case = format!("{dof} coordinates, {output:?}, unrolled {unrolled}");
                match &failed.error {
                    Error::SingularMassMatrix { t, q, .. } => {
                        assert_eq!((*t, q.as_slice()), (0.0, q0), "{case}")
                    }
                    other => panic!("{case}: {other:?}"),
                }
                assert_eq!(
                    failed.last.unwrap(),
                    (0.0, q0.to_vec(), v0.to_vec()),
                    "{case}"
                );
            }
        }
    }
}

/// Backwards in time: Kepler's orbit from t = 5π back to 0 returns to the pericentre.
#[test]
fn kepler_backwards_to_the_start() {
    let e: f64 = 0.6;
    let model = kepler();
    let t_end = 5.0 * std::f64::consts::PI;
    let [r, th, rd, thd] = kepler_exact(e, t_end);
    let sol = solve(
        &model,
        &[r, th],
        &[rd, thd],
        (t_end, 0.0),
        Method::Taylor,
        &Options::adaptive(1e-13, 1e-13),
    )
    .unwrap();
    assert!(sol.t.windows(2).all(|w| w[1] < w[0]));
    let (t, q, qd) = sol.last().unwrap();
    assert_eq!(t, 0.0);
    let back = [q, qd].concat();
    let start = kepler_exact(e, 0.0);
    assert!(error(&back, &start) < 1e-11, "{back:?} against {start:?}");
}

/// `Method::Auto` runs the Taylor method where its estimated cost is below DOP853's: on Kepler's
/// problem at 1e-15 (the run `Method::Taylor` gives, bit for bit, to within 10 × tol of the
/// closed form), not at 1e-9, and never on the 4-link chain, whose series of M cost several
/// DOP853 steps per Taylor step (`benches/taylor_choice.py`).
#[test]
fn auto_runs_taylor_where_it_is_estimated_cheaper() {
    let estimate = |choice: &str| -> f64 {
        let at = choice.find("estimated at ").expect(choice) + "estimated at ".len();
        choice[at..].split(' ').next().unwrap().parse().unwrap()
    };
    let e: f64 = 0.6;
    let (q0, v0) = (
        [1.0 - e, 0.0],
        [0.0, (1.0 - e * e).sqrt() / ((1.0 - e) * (1.0 - e))],
    );
    // As `kepler_orbit_to_the_tolerance`: ending near the apocentre.
    let t_end = 5.0 * std::f64::consts::PI;
    let orbit = kepler();
    let run = |method, tol| {
        solve(
            &orbit,
            &q0,
            &v0,
            (0.0, t_end),
            method,
            &Options::adaptive(tol, tol),
        )
        .unwrap()
    };
    let tight = run(Method::Auto, 1e-15);
    let choice = tight.stats.choice.clone().unwrap();
    assert_eq!(tight.stats.method, Method::Taylor, "{choice}");
    assert!(
        estimate(&choice) < 1.0 && choice.contains("not stiff"),
        "{choice}"
    );
    let named = run(Method::Taylor, 1e-15);
    assert_eq!(tight.last().unwrap(), named.last().unwrap());
    let (_, q, v) = tight.last().unwrap();
    let err = error(&[q, v].concat(), &kepler_exact(e, t_end));
    assert!(err <= 1e-14, "{err:e}");
    let loose = run(Method::Auto, 1e-9);
    let choice = loose.stats.choice.unwrap();
    assert_eq!(loose.stats.method, Method::Dop853, "{choice}");
    assert!(estimate(&choice) > 1.0, "{choice}");

    let mut g = Graph::new();
    let parts = lagrangian::tape::models::pendulum_chain(&mut g, 4).unwrap();
    let chain = model(g, 4, &parts, &[1.0, 1.0, 9.81]);
    let sol = solve(
        &chain,
        &[0.3; 4],
        &[0.0; 4],
        (0.0, 1.0),
        Method::Auto,
        &Options::adaptive(1e-15, 1e-15),
    )
    .unwrap();
    let choice = sol.stats.choice.unwrap();
    assert_eq!(sol.stats.method, Method::Dop853, "{choice}");
    assert!(estimate(&choice) > 1.5, "{choice}");
}

/// The double pendulum as expressions, with its derived program.
fn double_pendulum_model(params: &[f64]) -> EnergyModel {
    let mut g = Graph::new();
    let parts = models::double_pendulum(&mut g).unwrap();
    let f = |g: &Graph, nodes: &[usize], inputs: Inputs| {
        Function::new(
            Arc::new(Tape::new(g, nodes, inputs, "part").unwrap()),
            params,
        )
        .unwrap()
    };
    let kinetic = f(&g, &[parts.kinetic], Inputs::kinetic(2, 5));
    let potential = f(&g, &[parts.potential.unwrap()], Inputs::potential(2, 5));
    let program = EomProgram::new(&mut g, 2, 5, &parts).unwrap();
    EnergyModel::new(2, kinetic, Some(potential), None, None)
        .unwrap()
        .with_program(program.bind(params).unwrap())
        .unwrap()
}

/// The end state within 100 × the tolerance of a tight DOP853 reference (moved from
/// `src/integrators/taylor.rs`).
#[test]
fn double_pendulum_to_the_tolerance() {
    let params = [1.0, 2.0, 1.5, 0.7, 9.81];
    let model = double_pendulum_model(&params);
    let (q0, v0) = ([1.0, -0.5], [0.3, 2.0]);
    let span = (0.0, 5.0);
    let reference = solve(
        &model,
        &q0,
        &v0,
        span,
        Method::Dop853,
        &Options::adaptive(1e-14, 1e-14),
    )
    .unwrap();
    let (_, qr, vr) = reference.last().unwrap();
    for tol in [1e-6, 1e-9, 1e-12] {
        let sol = solve(
            &model,
            &q0,
            &v0,
            span,
            Method::Taylor,
            &Options::adaptive(tol, tol),
        )
        .unwrap();
        let (t, q, v) = sol.last().unwrap();
        assert_eq!(t, 5.0);
        let err = q
            .iter()
            .zip(qr)
            .chain(v.iter().zip(vr))
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(err < 100.0 * tol.max(1e-13), "tol {tol}: error {err:e}");
        eprintln!(
            "tol {tol:e}: error {err:e}, steps {}",
            sol.stats.accepted_steps
        );
    }
}
