//! Timing of tape models (not a timed assertion): run with
//! `cargo test --release --test integration tape_speed:: -- --ignored --nocapture`.
//!
//! It times the double pendulum as `benches/python_vs_rust.py` states it in Python, and a chain of
//! n pendulums, through [`EnergyModel`] (what the Python module builds) and through the plain
//! [`TapeSystem`] (every derivative pass evaluated on the tape).

use crate::common::time;
use lagrangian::Dynamics;
use lagrangian::tape::{EnergyModel, Function, Graph, Inputs, Tape, TapeSystem, models};
use std::hint::black_box;

/// T and U of the double pendulum as the Python benchmark writes them, parameters (m, l, g).
fn double_pendulum(g: &mut Graph) -> (usize, usize) {
    let parts = models::double_pendulum_equal(g).unwrap();
    (parts.kinetic, parts.potential.unwrap())
}

/// A chain of n pendulums (parameters m, l, g).
fn chain(g: &mut Graph, n: usize) -> (usize, usize) {
    let parts = models::pendulum_chain(g, n).unwrap();
    (parts.kinetic, parts.potential.unwrap())
}

/// T and U of a model of n coordinates as functions, with parameters (1, 1, 9.81).
fn functions(n: usize, build: impl FnOnce(&mut Graph) -> (usize, usize)) -> (Function, Function) {
    let mut g = Graph::new();
    let (k, u) = build(&mut g);
    let params = [1.0, 1.0, 9.81];
    let t = Tape::new(&g, &[k], Inputs::kinetic(n, 3), "T").unwrap();
    let u = Tape::new(&g, &[u], Inputs::potential(n, 3), "U").unwrap();
    let t = Function::new(t.into(), &params).unwrap();
    let u = Function::new(u.into(), &params).unwrap();
    (t, u)
}

fn model(n: usize, build: impl FnOnce(&mut Graph) -> (usize, usize)) -> EnergyModel {
    let (t, u) = functions(n, build);
    EnergyModel::new(n, t, Some(u), None, None).unwrap()
}

/// [`time`] of 1e5 calls of `accelerations_into`.
fn accelerations(s: &impl Dynamics, q: &[f64], qd: &[f64]) -> f64 {
    let mut out = vec![0.0; q.len()];
    time(100_000, |k| {
        s.accelerations_into(
            black_box(k as f64 * 1e-6),
            black_box(q),
            black_box(qd),
            &mut out,
        )
        .unwrap()
    })
}

fn report(name: &str, energy: &EnergyModel) {
    let system: &TapeSystem = energy.system();
    let n = energy.dof();
    let calls = 100_000;
    let q: Vec<f64> = (0..n).map(|i| 0.3 + 0.1 * i as f64).collect();
    let qd: Vec<f64> = (0..n).map(|i| 0.2 - 0.05 * i as f64).collect();
    let mut out = vec![0.0; n];
    let mut m = vec![0.0; n * n];
    let row = |what: &str, ns: f64| println!("{name:>16} {what:<34} {ns:9.1} ns");
    let t = |k: usize| black_box(k as f64 * 1e-6);
    row("EnergyModel accelerations", accelerations(energy, &q, &qd));
    row("TapeSystem accelerations", accelerations(system, &q, &qd));
    row(
        "mass matrix",
        time(calls, |k| {
            energy.mass_matrix_into(t(k), black_box(&q), black_box(&qd), &mut m)
        }),
    );
    row(
        "momenta",
        time(calls, |k| {
            energy.momenta_into(t(k), black_box(&q), black_box(&qd), &mut out)
        }),
    );
    row(
        "potential gradient",
        time(calls, |k| {
            energy.potential_gradient_into(t(k), black_box(&q), &mut out)
        }),
    );
    black_box((&out, &m));
}

#[test]
#[ignore = "timing; run in release with --ignored --nocapture"]
fn tape_speed_accelerations() {
    report("double pendulum", &model(2, double_pendulum));
    for n in [3, 4, 6] {
        report(&format!("chain n = {n}"), &model(n, |g| chain(g, n)));
    }
}

/// Native code (`jit` feature) against the interpreter on the f64 evaluation of T and U: compile
/// time and ns per call.
#[cfg(feature = "jit")]
#[test]
#[ignore = "timing; run in release with --ignored --nocapture"]
fn tape_speed_native() {
    use std::time::Instant;
    type Build<'a> = &'a dyn Fn(&mut Graph) -> (usize, usize);
    let cases: [(&str, usize, Build); 3] = [
        ("double pendulum", 2, &double_pendulum),
        ("chain n = 8", 8, &|g| chain(g, 8)),
        ("chain n = 32", 32, &|g| chain(g, 32)),
    ];
    for (name, n, build) in cases {
        let start = Instant::now();
        let (t, u) = functions(n, build);
        let tapes = start.elapsed().as_secs_f64() * 1e3;
        // The best of five compilations (the machine may be busy).
        let mut compile = f64::INFINITY;
        let (mut nt, mut nu) = (None, None);
        for _ in 0..5 {
            let start = Instant::now();
            nt = Some(t.compile_native().unwrap());
            nu = Some(u.compile_native().unwrap());
            compile = compile.min(start.elapsed().as_secs_f64() * 1e3);
        }
        let (nt, nu) = (nt.unwrap(), nu.unwrap());
        println!(
            "{name:>16}: T {} + U {} instructions; graph and tapes {tapes:.2} ms, native \
             compilation of both {compile:.2} ms",
            t.tape().instructions(),
            u.tape().instructions()
        );
        let q: Vec<f64> = (0..n).map(|i| 0.3 + 0.1 * i as f64).collect();
        let qd: Vec<f64> = (0..n).map(|i| 0.2 - 0.05 * i as f64).collect();
        let tk = |k: usize| black_box(k as f64 * 1e-6);
        let calls = 200_000;
        let interp = time(calls, |k| {
            black_box(t.eval(tk(k), black_box(&q), black_box(&qd)));
        });
        let native = time(calls, |k| {
            black_box(nt.eval(tk(k), black_box(&q), black_box(&qd)));
        });
        println!("{name:>16}: T per call: interpreter {interp:8.1} ns, native {native:8.1} ns");
        let interp = time(calls, |k| {
            black_box(u.eval(tk(k), black_box(&q), black_box(&qd)));
        });
        let native = time(calls, |k| {
            black_box(nu.eval(tk(k), black_box(&q), black_box(&qd)));
        });
        println!("{name:>16}: U per call: interpreter {interp:8.1} ns, native {native:8.1} ns");
    }
}

/// Compile time of a 10 000-instruction tape (`jit` feature).
#[cfg(feature = "jit")]
#[test]
#[ignore = "timing; run in release with --ignored --nocapture"]
fn tape_speed_native_compile_large() {
    use lagrangian::tape::{Binary, Unary};
    use std::time::Instant;
    let mut g = Graph::new();
    let (x, y) = (g.coord(0), g.velocity(0));
    let mut nodes = vec![x, y];
    let ops = [Binary::Add, Binary::Mul, Binary::Sub, Binary::Div];
    let mut outs = Vec::new();
    for k in 0..3400 {
        let last = *nodes.last().unwrap();
        let c = g.constant(1.0 + (k % 97) as f64 / 97.0);
        let p = g.binary(ops[k % 4], last, c).unwrap();
        let f = [Unary::Sin, Unary::Tanh, Unary::Abs][k % 3];
        let n = g.unary(f, p).unwrap();
        let b = nodes[nodes.len() - 1 - (k * 7919) % nodes.len().min(8)];
        let n = g.binary(ops[(k / 4) % 3], n, b).unwrap();
        nodes.push(n);
        if k % 1000 == 999 || k == 3399 {
            outs.push(n);
        }
    }
    let tape = Tape::new(&g, &outs, Inputs::kinetic(1, 0), "large").unwrap();
    let f = Function::new(tape.into(), &[]).unwrap();
    let mut compile = f64::INFINITY;
    let mut native = None;
    for _ in 0..3 {
        let start = Instant::now();
        native = Some(f.compile_native().unwrap());
        compile = compile.min(start.elapsed().as_secs_f64() * 1e3);
    }
    let native = native.unwrap();
    println!(
        "{} instructions: native compilation {compile:.1} ms (best of 3)",
        f.tape().instructions(),
    );
    black_box(native.eval(0.0, &[0.4], &[-0.2]));
}
