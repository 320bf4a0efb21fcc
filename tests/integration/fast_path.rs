//! A scene's run on `trace::FastPath`: a long run switches from the Rust route to the traced,
//! compiled eq. 55 program and agrees with the Rust route to round-off (and with Kepler's
//! closed form to the tolerance); a short run does not switch and is the Rust route's bit for
//! bit; events and dense output on a run that switches land where Kepler's orbit puts them.

use lagrangian::integrators::{Event, Method, Options, Solution, solve};
use lagrangian::scenes::Kepler;
use lagrangian::tape::EomFunction;
use lagrangian::trace::{FastPath, SWITCH_WORK, WithProgram};
use lagrangian::{Dynamics, Result, System};

type Scene = WithProgram<System<Kepler, Kepler>>;

/// An orbit of μ = 1, a = 1, e = 0.5 from periapsis: period 2π.
const A: f64 = 1.0;
const E: f64 = 0.5;

fn kepler() -> (Scene, [f64; 2], [f64; 2]) {
    let kepler = Kepler::new(1.0, 1.0);
    let (q0, v0) = kepler.periapsis_state(A, E).unwrap();
    (WithProgram::new(kepler.system(), "kepler"), q0, v0)
}

fn program(s: &Scene) -> Result<&EomFunction> {
    s.program()
}

fn run(system: &impl Dynamics, q0: &[f64], v0: &[f64], t_end: f64, options: &Options) -> Solution {
    solve(system, q0, v0, (0.0, t_end), Method::Dop853, options).unwrap()
}

/// The largest difference between the last states of two runs.
fn gap(a: &Solution, b: &Solution) -> f64 {
    let ((_, qa, va), (_, qb, vb)) = (a.last().unwrap(), b.last().unwrap());
    qa.iter()
        .chain(va)
        .zip(qb.iter().chain(vb))
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

#[test]
fn a_long_run_switches_and_agrees_with_the_rust_route() {
    let (scene, q0, v0) = kepler();
    let options = Options::adaptive(1e-11, 1e-11);
    let t_end = 20.0 * std::f64::consts::TAU;
    let rust = run(&scene, &q0, &v0, t_end, &options);
    let fast = FastPath::new(&scene, program);
    assert_eq!(fast.switch_at(), SWITCH_WORK / 2);
    let sol = run(&fast, &q0, &v0, t_end, &options);
    assert!(rust.stats.rhs_evaluations > 2 * fast.switch_at());
    assert!(fast.route().starts_with("compiled"), "{}", fast.route());
    // The same steps until the switch; after it round-off, which twenty orbits amplify no
    // more than the tolerance.
    assert!(gap(&rust, &sol) < 1e-9, "{}", gap(&rust, &sol));
    // On the closed form within the method's own global error over twenty orbits (a phase lag
    // of about 1e-7, the Rust route's too).
    let (q, v) = Kepler::new(1.0, 1.0).exact_state(A, E, t_end).unwrap();
    let (_, qe, ve) = sol.last().unwrap();
    for (x, y) in qe.iter().chain(ve).zip(q.iter().chain(&v)) {
        assert!((x - y).abs() < 1e-6, "{x} vs {y}");
    }
    // Compiled from the first evaluation: the same orbit to round-off.
    let compiled = FastPath::switching_at(&scene, program, 0);
    let sol = run(&compiled, &q0, &v0, t_end, &options);
    assert!(compiled.route().starts_with("compiled"));
    assert!(gap(&rust, &sol) < 1e-9, "{}", gap(&rust, &sol));
}

#[test]
fn a_short_run_stays_on_the_rust_route_bit_for_bit() {
    let (scene, q0, v0) = kepler();
    let options = Options::adaptive(1e-10, 1e-10);
    let rust = run(&scene, &q0, &v0, 3.0, &options);
    let fast = FastPath::new(&scene, program);
    let sol = run(&fast, &q0, &v0, 3.0, &options);
    assert!(fast.route().starts_with("rust"), "{}", fast.route());
    assert_eq!(sol.t, rust.t);
    assert_eq!(sol.q, rust.q);
    assert_eq!(sol.qd, rust.qd);
    // Held on the Rust route, a long run too.
    let held = FastPath::switching_at(&scene, program, usize::MAX);
    let t_end = 20.0 * std::f64::consts::TAU;
    let sol = run(&held, &q0, &v0, t_end, &options);
    assert_eq!(sol.q, run(&scene, &q0, &v0, t_end, &options).q);
    assert!(held.route().starts_with("rust"));
}

#[test]
fn events_and_dense_output_of_a_run_that_switches() {
    let (scene, q0, v0) = kepler();
    let periapsis = Event::new("y = 0 rising", |_t, q, _qd| q[1]).rising();
    let options = Options::adaptive(1e-11, 1e-11)
        .with_event(periapsis)
        .with_dense(true);
    let t_end = 20.5 * std::f64::consts::TAU;
    let fast = FastPath::new(&scene, program);
    let sol = run(&fast, &q0, &v0, t_end, &options);
    assert!(fast.route().starts_with("compiled"));
    // Periapsis at every whole period (the start, on the surface, is not a crossing).
    let found = &sol.events[0].t;
    assert_eq!(found.len(), 20, "{found:?}");
    for (k, t) in found.iter().enumerate() {
        let exact = (k + 1) as f64 * std::f64::consts::TAU;
        assert!((t - exact).abs() < 1e-6, "{t} vs {exact}");
    }
    // The continuous solution, between steps after the switch, on the closed form.
    let dense = sol.dense.as_ref().unwrap();
    let mut y = [0.0; 4];
    for t in [10.3, 60.7, 127.1] {
        dense.eval(t, &mut y).unwrap();
        let (q, v) = Kepler::new(1.0, 1.0).exact_state(A, E, t).unwrap();
        let exact = [q[0], q[1], v[0], v[1]];
        for (x, e) in y.iter().zip(exact) {
            assert!((x - e).abs() < 1e-6, "t = {t}: {x} vs {e}");
        }
    }
}
