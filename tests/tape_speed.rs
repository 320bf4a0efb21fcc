//! Timing of tape models (not a timed assertion): run with
//! `cargo test --release --test tape_speed -- --ignored --nocapture`.
//!
//! It times the double pendulum as `benches/python_vs_rust.py` states it in Python, and a chain of
//! n pendulums, through [`EnergyModel`] (what the Python module builds) and through the plain
//! [`TapeSystem`] (every derivative pass evaluated on the tape).

use lagrangian::Dynamics;
use lagrangian::tape::{Binary, EnergyModel, Function, Graph, Inputs, Tape, TapeSystem, Unary};
use std::hint::black_box;
use std::time::Instant;

/// T and U of the double pendulum as the Python benchmark writes them, parameters (m, l, g):
/// T = ½ m l² (2 θ̇₁² + θ̇₂² + 2 θ̇₁ θ̇₂ cos(θ₁ − θ₂)), U = −m g l (2 cos θ₁ + cos θ₂).
fn double_pendulum(g: &mut Graph) -> (usize, usize) {
    let b = |g: &mut Graph, f, x, y| g.binary(f, x, y).unwrap();
    let (m, l, grav) = (g.param(0), g.param(1), g.param(2));
    let (th1, th2, w1, w2) = (g.coord(0), g.coord(1), g.velocity(0), g.velocity(1));
    let (half, two) = (g.constant(0.5), g.constant(2.0));
    let l2 = g.powi(l, 2).unwrap();
    let k = b(g, Binary::Mul, half, m);
    let k = b(g, Binary::Mul, k, l2);
    let w1s = g.powi(w1, 2).unwrap();
    let w2s = g.powi(w2, 2).unwrap();
    let a = b(g, Binary::Mul, two, w1s);
    let a = b(g, Binary::Add, a, w2s);
    let d = b(g, Binary::Sub, th1, th2);
    let c = g.unary(Unary::Cos, d).unwrap();
    let x = b(g, Binary::Mul, two, w1);
    let x = b(g, Binary::Mul, x, w2);
    let x = b(g, Binary::Mul, x, c);
    let a = b(g, Binary::Add, a, x);
    let kinetic = b(g, Binary::Mul, k, a);
    let mgl = b(g, Binary::Mul, m, grav);
    let mgl = b(g, Binary::Mul, mgl, l);
    let c1 = g.unary(Unary::Cos, th1).unwrap();
    let c2 = g.unary(Unary::Cos, th2).unwrap();
    let c1 = b(g, Binary::Mul, two, c1);
    let s = b(g, Binary::Add, c1, c2);
    let u = b(g, Binary::Mul, mgl, s);
    let potential = g.unary(Unary::Neg, u).unwrap();
    (kinetic, potential)
}

/// A chain of n unit pendulums (parameters m, l, g): T = ½ m Σₖ |vₖ|², U = m g Σₖ yₖ.
fn chain(g: &mut Graph, n: usize) -> (usize, usize) {
    let b = |g: &mut Graph, f, x, y| g.binary(f, x, y).unwrap();
    let (m, l, grav) = (g.param(0), g.param(1), g.param(2));
    let half = g.constant(0.5);
    let (mut vx, mut vy, mut y) = (None, None, None);
    let (mut kin, mut pot) = (None, None);
    let add = |g: &mut Graph, acc: Option<usize>, x: usize| match acc {
        None => x,
        Some(a) => g.binary(Binary::Add, a, x).unwrap(),
    };
    for i in 0..n {
        let (th, w) = (g.coord(i), g.velocity(i));
        let (s, c) = (
            g.unary(Unary::Sin, th).unwrap(),
            g.unary(Unary::Cos, th).unwrap(),
        );
        let lw = b(g, Binary::Mul, l, w);
        let dx = b(g, Binary::Mul, lw, c);
        let dy = b(g, Binary::Mul, lw, s);
        vx = Some(add(g, vx, dx));
        vy = Some(add(g, vy, dy));
        let lc = b(g, Binary::Mul, l, c);
        let h = g.unary(Unary::Neg, lc).unwrap();
        y = Some(add(g, y, h));
        let v2x = g.powi(vx.unwrap(), 2).unwrap();
        let v2y = g.powi(vy.unwrap(), 2).unwrap();
        let v2 = b(g, Binary::Add, v2x, v2y);
        kin = Some(add(g, kin, v2));
        pot = Some(add(g, pot, y.unwrap()));
    }
    let hm = b(g, Binary::Mul, half, m);
    let kinetic = b(g, Binary::Mul, hm, kin.unwrap());
    let mg = b(g, Binary::Mul, m, grav);
    let potential = b(g, Binary::Mul, mg, pot.unwrap());
    (kinetic, potential)
}

fn model(n: usize, build: impl FnOnce(&mut Graph) -> (usize, usize)) -> EnergyModel {
    let mut g = Graph::new();
    let (k, u) = build(&mut g);
    let params = [1.0, 1.0, 9.81];
    let t = Tape::new(&g, &[k], Inputs::kinetic(n, 3), "T").unwrap();
    let u = Tape::new(&g, &[u], Inputs::potential(n, 3), "U").unwrap();
    let t = Function::new(t.into(), &params).unwrap();
    let u = Function::new(u.into(), &params).unwrap();
    EnergyModel::new(n, t, Some(u), None, None).unwrap()
}

/// Nanoseconds per call of `f`: the best of `calls / 200` rounds of 200 calls (short rounds, so
/// that on a busy machine some run undisturbed).
fn time(calls: usize, mut f: impl FnMut(usize)) -> f64 {
    let per_round = 200;
    (0..calls / per_round)
        .map(|_| {
            let start = Instant::now();
            for k in 0..per_round {
                f(k);
            }
            start.elapsed().as_secs_f64() * 1e9 / per_round as f64
        })
        .fold(f64::INFINITY, f64::min)
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
    type Build<'a> = &'a dyn Fn(&mut Graph) -> (usize, usize);
    let cases: [(&str, usize, Build); 3] = [
        ("double pendulum", 2, &double_pendulum),
        ("chain n = 8", 8, &|g| chain(g, 8)),
        ("chain n = 32", 32, &|g| chain(g, 32)),
    ];
    for (name, n, build) in cases {
        let start = Instant::now();
        let mut g = Graph::new();
        let (k, u) = build(&mut g);
        let params = [1.0, 1.0, 9.81];
        let t = Tape::new(&g, &[k], Inputs::kinetic(n, 3), "T").unwrap();
        let u = Tape::new(&g, &[u], Inputs::potential(n, 3), "U").unwrap();
        let t = Function::new(t.into(), &params).unwrap();
        let u = Function::new(u.into(), &params).unwrap();
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
