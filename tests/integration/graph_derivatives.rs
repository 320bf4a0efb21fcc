//! Derivatives on the expression graph (`tape::tangent`, `tape::EomProgram`) against the dual
//! numbers the tapes are otherwise evaluated with, and eq. 55 compiled as one program against
//! [`EnergyModel`] on the same energies.
//!
//! The timing at the end is not a timed assertion: run it with
//! `CARGO_PROFILE_RELEASE_LTO=false cargo test --release --features jit --test integration graph_derivatives:: -- --ignored --nocapture`.

use crate::common::{Rng, time};
use lagrangian::num_dual::Dual64;
use lagrangian::tape::{
    Binary, Energies, EnergyModel, EomProgram, Function, Graph, Inputs, Seeds, Tape, Unary, Wrt,
    eom_graph, gradient, models, tangent,
};
use lagrangian::{Dynamics, Error};
use std::hint::black_box;
use std::sync::Arc;
use std::time::Instant;

/// Shorthands over a [`Graph`].
struct B<'g>(&'g mut Graph);

impl B<'_> {
    fn c(&mut self, x: f64) -> usize {
        self.0.constant(x)
    }
    fn b(&mut self, f: Binary, x: usize, y: usize) -> usize {
        self.0.binary(f, x, y).unwrap()
    }
    fn u(&mut self, f: Unary, x: usize) -> usize {
        self.0.unary(f, x).unwrap()
    }
    fn add(&mut self, x: usize, y: usize) -> usize {
        self.b(Binary::Add, x, y)
    }
    fn sub(&mut self, x: usize, y: usize) -> usize {
        self.b(Binary::Sub, x, y)
    }
    fn mul(&mut self, x: usize, y: usize) -> usize {
        self.b(Binary::Mul, x, y)
    }
    fn sq(&mut self, x: usize) -> usize {
        self.0.powi(x, 2).unwrap()
    }
    fn sin(&mut self, x: usize) -> usize {
        self.u(Unary::Sin, x)
    }
    fn cos(&mut self, x: usize) -> usize {
        self.u(Unary::Cos, x)
    }
    /// x² + ½: positive, for the functions with a restricted domain.
    fn pos(&mut self, x: usize) -> usize {
        let x2 = self.sq(x);
        let h = self.c(0.5);
        self.add(x2, h)
    }
}

const DOF: usize = 3;

/// A random expression over t, q, q̇ (3 coordinates) and 2 parameters using every function,
/// with arguments kept in their domains; returns its node.
fn random_expression(g: &mut Graph, rng: &mut Rng, size: usize) -> usize {
    let mut b = B(g);
    let mut pool = vec![b.0.time(), b.0.param(0), b.0.param(1)];
    for i in 0..DOF {
        pool.push(b.0.coord(i));
        pool.push(b.0.velocity(i));
    }
    let x = rng.uniform(-2.0, 2.0);
    pool.push(b.c(x));
    for _ in 0..size {
        let a = pool[rng.below(pool.len())];
        let c = pool[rng.below(pool.len())];
        let node = match rng.below(21) {
            0 => b.u(Unary::Neg, a),
            1 => b.sin(a),
            2 => b.cos(a),
            3 => {
                let s = b.sin(a);
                b.u(Unary::Tan, s)
            }
            4 => {
                let s = b.sin(a);
                b.u(Unary::Exp, s)
            }
            5 => {
                let p = b.pos(a);
                b.u(Unary::Ln, p)
            }
            6 => {
                let p = b.pos(a);
                b.u(Unary::Sqrt, p)
            }
            7 => {
                let s = b.sin(a);
                b.u(Unary::Sinh, s)
            }
            8 => {
                let s = b.sin(a);
                b.u(Unary::Cosh, s)
            }
            9 => b.u(Unary::Tanh, a),
            10 => b.u(Unary::Abs, a),
            11 | 12 => b.add(a, c),
            13 => b.sub(a, c),
            14 | 15 => {
                let (sa, sc) = (b.sin(a), b.cos(c));
                b.mul(sa, sc)
            }
            16 => {
                let p = b.pos(c);
                b.b(Binary::Div, a, p)
            }
            17 => {
                // A variable exponent, and a literal non-integral one.
                let p = b.pos(a);
                let e = b.sin(c);
                if rng.below(2) == 0 {
                    b.b(Binary::Pow, p, e)
                } else {
                    let e = b.c(1.5);
                    b.b(Binary::Pow, p, e)
                }
            }
            18 => b.b(Binary::Atan2, a, c),
            19 => {
                let k = [-2, -1, 2, 3, 4][rng.below(5)];
                let base = if k < 0 { b.pos(a) } else { b.sin(a) };
                b.0.powi(base, k).unwrap()
            }
            _ => {
                let e = b.c(2.0);
                b.b(Binary::Pow, a, e)
            }
        };
        pool.push(node);
    }
    // Sum the last few so that several branches reach the result.
    let mut out = pool[pool.len() - 1];
    for &x in &pool[pool.len() - 4..pool.len() - 1] {
        out = b.add(out, x);
    }
    out
}

/// The tangents of random expressions agree with Dual64 evaluation of the same tape, for the
/// seeds ∂/∂q̇ⱼ, ∂/∂qⱼ, ∂/∂t and the derivative along the motion.
#[test]
fn tangent_random_expressions_match_dual_numbers() {
    let mut rng = Rng(12);
    let params = [0.7, -1.3];
    let mut checked = 0;
    for case in 0..300 {
        let mut g = Graph::new();
        let e = random_expression(&mut g, &mut rng, 4 + case % 12);
        let one = g.constant(1.0);
        let j = rng.below(DOF);
        let (seeds, dir): (Seeds, usize) = match case % 4 {
            0 => (Seeds::new().velocity(j, one), 0),
            1 => (Seeds::new().coord(j, one), 1),
            2 => (Seeds::new().time(one), 2),
            _ => {
                let mut s = Seeds::new().time(one);
                for k in 0..DOF {
                    let v = g.velocity(k);
                    s = s.coord(k, v);
                }
                (s, 3)
            }
        };
        let d = tangent(&mut g, e, &seeds).unwrap();
        let inputs = Inputs::kinetic(DOF, 2);
        let f = Function::new(Tape::new(&g, &[e], inputs, "e").unwrap().into(), &params).unwrap();
        let df = Function::new(Tape::new(&g, &[d], inputs, "de").unwrap().into(), &params).unwrap();
        for _ in 0..3 {
            let t = rng.uniform(-1.0, 1.0);
            let q: Vec<f64> = (0..DOF).map(|_| rng.uniform(-1.5, 1.5)).collect();
            let qd: Vec<f64> = (0..DOF).map(|_| rng.uniform(-1.5, 1.5)).collect();
            let td = Dual64::new(t, if dir >= 2 { 1.0 } else { 0.0 });
            let qdual: Vec<Dual64> = (0..DOF)
                .map(|k| {
                    let e = match dir {
                        1 if k == j => 1.0,
                        3 => qd[k],
                        _ => 0.0,
                    };
                    Dual64::new(q[k], e)
                })
                .collect();
            let qddual: Vec<Dual64> = (0..DOF)
                .map(|k| Dual64::new(qd[k], if dir == 0 && k == j { 1.0 } else { 0.0 }))
                .collect();
            let want = f.eval(td, &qdual, &qddual);
            let got = df.eval(t, &q, &qd);
            if !want.re.is_finite() || !want.eps.is_finite() || want.eps.abs() > 1e8 {
                continue;
            }
            let scale = want.eps.abs().max(1.0);
            assert!(
                (got - want.eps).abs() <= 1e-12 * scale,
                "case {case}: tangent {got}, dual {}",
                want.eps
            );
            checked += 1;
        }
    }
    assert!(checked > 600, "only {checked} finite samples");
}

/// Reverse-sweep gradients of random expressions agree with Dual64 evaluation, component by
/// component, in q and in q̇.
#[test]
fn gradient_random_expressions_match_dual_numbers() {
    let mut rng = Rng(34);
    let params = [0.7, -1.3];
    let mut checked = 0;
    for case in 0..150 {
        let mut g = Graph::new();
        let e = random_expression(&mut g, &mut rng, 4 + case % 12);
        let wrt = if case % 2 == 0 {
            Wrt::Velocity
        } else {
            Wrt::Position
        };
        let grad = gradient(&mut g, e, wrt, DOF).unwrap();
        let zero = g.constant(0.0);
        let nodes: Vec<usize> = grad.iter().map(|d| d.unwrap_or(zero)).collect();
        let inputs = Inputs::kinetic(DOF, 2);
        let f = Function::new(Tape::new(&g, &[e], inputs, "e").unwrap().into(), &params).unwrap();
        let df =
            Function::new(Tape::new(&g, &nodes, inputs, "de").unwrap().into(), &params).unwrap();
        let t = rng.uniform(-1.0, 1.0);
        let q: Vec<f64> = (0..DOF).map(|_| rng.uniform(-1.5, 1.5)).collect();
        let qd: Vec<f64> = (0..DOF).map(|_| rng.uniform(-1.5, 1.5)).collect();
        let mut got = [0.0; DOF];
        df.eval_into(t, &q, &qd, &mut got);
        for j in 0..DOF {
            let seed = |x: &[f64], on: bool| -> Vec<Dual64> {
                (0..DOF)
                    .map(|k| Dual64::new(x[k], if on && k == j { 1.0 } else { 0.0 }))
                    .collect()
            };
            let want = f.eval(
                Dual64::from(t),
                &seed(&q, wrt == Wrt::Position),
                &seed(&qd, wrt == Wrt::Velocity),
            );
            if !want.re.is_finite() || !want.eps.is_finite() || want.eps.abs() > 1e8 {
                continue;
            }
            let scale = want.eps.abs().max(1.0);
            assert!(
                (got[j] - want.eps).abs() <= 1e-12 * scale,
                "case {case}, component {j}: gradient {}, dual {}",
                got[j],
                want.eps
            );
            checked += 1;
        }
    }
    assert!(checked > 300, "only {checked} finite samples");
}

/// Tangents of subgraphs that read no seeded input are exact zeros, and the simplifications
/// leave a derivative like ∂(½ m q̇²)/∂q̇ as m q̇ with no multiplication by 1.
#[test]
fn tangent_simplifies_and_skips_untouched_subgraphs() {
    let mut g = Graph::new();
    let mut b = B(&mut g);
    let (m, q, w) = (b.0.param(0), b.0.coord(0), b.0.velocity(0));
    let half = b.c(0.5);
    let hm = b.mul(half, m);
    let w2 = b.sq(w);
    let t = b.mul(hm, w2);
    let sq = b.sin(q);
    let one = g.constant(1.0);
    let zero = g.constant(0.0);
    let len = g.len();
    // sin q does not read q̇.
    assert_eq!(
        tangent(&mut g, sq, &Seeds::new().velocity(0, one)).unwrap(),
        zero
    );
    assert_eq!(g.len(), len);
    let p = tangent(&mut g, t, &Seeds::new().velocity(0, one)).unwrap();
    let tape = Tape::new(&g, &[p], Inputs::kinetic(1, 1), "p").unwrap();
    // (½ m)·(2 q̇): 2 q̇ folded to one product with a constant, then one product.
    assert!(
        tape.instructions() <= 2,
        "{} instructions",
        tape.instructions()
    );
    let f = Function::new(tape.into(), &[3.0]).unwrap();
    assert_eq!(f.eval(0.0, &[0.0], &[2.0]), 6.0);
    let m2 = tangent(&mut g, p, &Seeds::new().velocity(0, one)).unwrap();
    // ∂²T/∂q̇² = m: a function of parameters only, no instruction.
    let tape = Tape::new(&g, &[m2], Inputs::kinetic(1, 1), "M").unwrap();
    assert_eq!(tape.instructions(), 0);
    let f = Function::new(tape.into(), &[3.0]).unwrap();
    assert_eq!(f.constant_values(), vec![3.0]);
}

/// A model: its graph, energies, number of parameters and their values.
struct Model {
    graph: Graph,
    dof: usize,
    parts: Energies,
    params: Vec<f64>,
}

impl Model {
    fn energy_model(&self) -> EnergyModel {
        let np = self.params.len();
        let f = |nodes: &[usize], inputs: Inputs| {
            let tape = Tape::new(&self.graph, nodes, inputs, "part").unwrap();
            Function::new(Arc::new(tape), &self.params).unwrap()
        };
        let k = Inputs::kinetic(self.dof, np);
        EnergyModel::new(
            self.dof,
            f(&[self.parts.kinetic], k),
            self.parts
                .potential
                .map(|u| f(&[u], Inputs::potential(self.dof, np))),
            self.parts.dissipation.map(|r| f(&[r], k)),
            self.parts.forces.as_ref().map(|q| f(q, k)),
        )
        .unwrap()
    }

    fn program(&self) -> EomProgram {
        let mut g = self.graph.clone();
        EomProgram::new(&mut g, self.dof, self.params.len(), &self.parts).unwrap()
    }
}

/// A model of `tape::models` with T and U only.
fn example(dof: usize, params: Vec<f64>, build: impl FnOnce(&mut Graph) -> Energies) -> Model {
    let mut graph = Graph::new();
    let parts = build(&mut graph);
    Model {
        graph,
        dof,
        parts,
        params,
    }
}

/// [`models::pendulum_chain`] of n links (parameters m, l, g).
fn chain(n: usize) -> Model {
    example(n, vec![1.3, 0.8, 9.81], |g| {
        models::pendulum_chain(g, n).unwrap()
    })
}

/// [`models::double_pendulum`], parameters (m₁, m₂, l₁, l₂, g).
fn double_pendulum() -> Model {
    example(2, vec![1.0, 2.0, 1.5, 0.7, 9.81], |g| {
        models::double_pendulum(g).unwrap()
    })
}

/// A pendulum whose pivot moves as y = A cos ωt (T depends on t), with viscous damping
/// Φ = ½ c θ̇² and a torque Q″ = τ sin(Ω t) θ̇⁰; parameters (m, l, g, A, ω, c, τ, Ω).
fn driven_pendulum() -> Model {
    let mut graph = Graph::new();
    let mut b = B(&mut graph);
    let p: Vec<usize> = (0..8).map(|i| b.0.param(i)).collect();
    let (m, l, grav, amp, om, damp, tau, big) = (p[0], p[1], p[2], p[3], p[4], p[5], p[6], p[7]);
    let (th, w, t) = (b.0.coord(0), b.0.velocity(0), b.0.time());
    let half = b.c(0.5);
    let wt = b.mul(om, t);
    let swt = b.sin(wt);
    let cwt = b.cos(wt);
    let (s, c) = (b.sin(th), b.cos(th));
    let lw = b.mul(l, w);
    let vx = b.mul(lw, c);
    let aw = b.mul(amp, om);
    let pivot_v = b.mul(aw, swt);
    let lws = b.mul(lw, s);
    let vy = b.sub(lws, pivot_v);
    let vx2 = b.sq(vx);
    let vy2 = b.sq(vy);
    let v2 = b.add(vx2, vy2);
    let hm = b.mul(half, m);
    let kinetic = b.mul(hm, v2);
    let ya = b.mul(amp, cwt);
    let lc = b.mul(l, c);
    let y = b.sub(ya, lc);
    let mg = b.mul(m, grav);
    let potential = b.mul(mg, y);
    let w2 = b.sq(w);
    let hc = b.mul(half, damp);
    let dissipation = b.mul(hc, w2);
    let bt = b.mul(big, t);
    let sbt = b.sin(bt);
    let force = b.mul(tau, sbt);
    Model {
        graph,
        dof: 1,
        parts: Energies {
            kinetic,
            potential: Some(potential),
            dissipation: Some(dissipation),
            forces: Some(vec![force]),
        },
        params: vec![1.2, 0.9, 9.81, 0.3, 7.0, 0.4, 0.5, 1.7],
    }
}

/// A charged particle in the plane in a non-uniform magnetic field: T = ½ m |q̇|² + e q̇·A(q)
/// with A = (−½ B y, ½ B x (1 + κ x²)), U = ½ k |q|², Φ = ½ c (1 + x²) |q̇|², and
/// Q″ = (a sin t, b cos x); parameters (m, e, B, κ, k, c, a, b).
fn charged_particle() -> Model {
    let mut graph = Graph::new();
    let mut b = B(&mut graph);
    let p: Vec<usize> = (0..8).map(|i| b.0.param(i)).collect();
    let (m, e, bf, kappa, k, damp, fa, fb) = (p[0], p[1], p[2], p[3], p[4], p[5], p[6], p[7]);
    let (x, y, vx, vy, t) = (
        b.0.coord(0),
        b.0.coord(1),
        b.0.velocity(0),
        b.0.velocity(1),
        b.0.time(),
    );
    let (half, one) = (b.c(0.5), b.c(1.0));
    let vx2 = b.sq(vx);
    let vy2 = b.sq(vy);
    let v2 = b.add(vx2, vy2);
    let hm = b.mul(half, m);
    let t0 = b.mul(hm, v2);
    let hb = b.mul(half, bf);
    let ax = b.mul(hb, y);
    let ax = b.u(Unary::Neg, ax);
    let x2 = b.sq(x);
    let kx2 = b.mul(kappa, x2);
    let g1 = b.add(one, kx2);
    let ay = b.mul(hb, x);
    let ay = b.mul(ay, g1);
    let pa = b.mul(vx, ax);
    let pb = b.mul(vy, ay);
    let va = b.add(pa, pb);
    let eva = b.mul(e, va);
    let kinetic = b.add(t0, eva);
    let y2 = b.sq(y);
    let r2 = b.add(x2, y2);
    let hk = b.mul(half, k);
    let potential = b.mul(hk, r2);
    let ox = b.add(one, x2);
    let hc = b.mul(half, damp);
    let d = b.mul(hc, ox);
    let dissipation = b.mul(d, v2);
    let st = b.sin(t);
    let f0 = b.mul(fa, st);
    let cx = b.cos(x);
    let f1 = b.mul(fb, cx);
    Model {
        graph,
        dof: 2,
        parts: Energies {
            kinetic,
            potential: Some(potential),
            dissipation: Some(dissipation),
            forces: Some(vec![f0, f1]),
        },
        params: vec![1.1, 0.7, 2.3, 0.4, 3.0, 0.2, 0.5, 0.6],
    }
}

/// The derived program's accelerations and M against [`EnergyModel`] at random states.
fn check_against_energy_model(model: &Model, seed: u64) {
    let energy = model.energy_model();
    let program = model.program();
    let eom = program.bind(&model.params).unwrap();
    let n = model.dof;
    // Momenta and energy function from the derived graph, as a tape of their own.
    let mut g = model.graph.clone();
    let derived = eom_graph(&mut g, n, &model.parts).unwrap();
    let mut roots = derived.momenta.clone();
    roots.push(derived.energy);
    let inputs = Inputs::kinetic(n, model.params.len());
    let extra = Function::new(
        Tape::new(&g, &roots, inputs, "p, h").unwrap().into(),
        &model.params,
    )
    .unwrap();
    let mut rng = Rng(seed);
    let (mut got, mut m, mut f) = (vec![0.0; n], vec![0.0; n * n], vec![0.0; n]);
    for _ in 0..20 {
        let t = rng.uniform(-2.0, 2.0);
        let q: Vec<f64> = (0..n).map(|_| rng.uniform(-1.5, 1.5)).collect();
        let qd: Vec<f64> = (0..n).map(|_| rng.uniform(-2.0, 2.0)).collect();
        let want = energy.accelerations(t, &q, &qd).unwrap();
        eom.accelerations(t, &q, &qd, &mut got).unwrap();
        let scale = want.iter().fold(1.0_f64, |a, x| a.max(x.abs()));
        for i in 0..n {
            assert!(
                (got[i] - want[i]).abs() <= 1e-13 * scale,
                "q̈[{i}] = {} derived, {} energy route (n = {n})",
                got[i],
                want[i]
            );
        }
        let (want_p, want_h) = (
            energy.momenta(t, &q, &qd).unwrap(),
            energy.energy(t, &q, &qd).unwrap(),
        );
        let mut ph = vec![0.0; n + 1];
        extra.eval_into(t, &q, &qd, &mut ph);
        let scale = want_p
            .iter()
            .fold(want_h.abs().max(1.0), |a, x| a.max(x.abs()));
        for i in 0..n {
            assert!((ph[i] - want_p[i]).abs() <= 1e-13 * scale, "p[{i}]");
        }
        assert!(
            (ph[n] - want_h).abs() <= 1e-13 * scale,
            "h {} {want_h}",
            ph[n]
        );
        let want_m = energy.mass_matrix(t, &q, &qd).unwrap();
        eom.mass_and_force(t, &q, &qd, &mut m, &mut f);
        let scale = want_m.iter().fold(1.0_f64, |a, x| a.max(x.abs()));
        for i in 0..n {
            for j in 0..n {
                assert!((m[i * n + j] - want_m[(i, j)]).abs() <= 1e-13 * scale);
            }
        }
    }
}

#[test]
fn eom_program_double_pendulum_matches_energy_model() {
    check_against_energy_model(&double_pendulum(), 1);
    check_against_energy_model(&chain(2), 2);
}

#[test]
fn eom_program_chains_match_energy_model() {
    check_against_energy_model(&chain(3), 3);
    check_against_energy_model(&chain(6), 4);
    // The largest system whose solve is unrolled into machine code, and one past it.
    check_against_energy_model(&chain(16), 5);
    check_against_energy_model(&chain(17), 6);
}

#[test]
fn eom_program_time_dependent_kinetic_energy_matches_energy_model() {
    let model = driven_pendulum();
    let mut g = model.graph.clone();
    let eom = eom_graph(&mut g, 1, &model.parts).unwrap();
    assert!(eom.time && !eom.constant_mass);
    check_against_energy_model(&model, 5);
}

#[test]
fn eom_program_velocity_dependent_lagrangian_matches_energy_model() {
    let model = charged_particle();
    assert!(model.program().constant_mass_matrix());
    check_against_energy_model(&model, 6);
}

#[test]
fn eom_program_detects_constant_mass_matrix() {
    // Cartesian coordinates: M is constant, and M's entries cost no instruction.
    let mut graph = Graph::new();
    let mut b = B(&mut graph);
    let (m1, m2, k) = (b.0.param(0), b.0.param(1), b.0.param(2));
    let (x1, x2, v1, v2) = (b.0.coord(0), b.0.coord(1), b.0.velocity(0), b.0.velocity(1));
    let half = b.c(0.5);
    let a = b.sq(v1);
    let a = b.mul(m1, a);
    let c = b.sq(v2);
    let c = b.mul(m2, c);
    let s = b.add(a, c);
    let kinetic = b.mul(half, s);
    let d = b.sub(x2, x1);
    let d2 = b.sq(d);
    let x12 = b.sq(x1);
    let s = b.add(d2, x12);
    let hk = b.mul(half, k);
    let potential = b.mul(hk, s);
    let model = Model {
        graph,
        dof: 2,
        parts: Energies {
            kinetic,
            potential: Some(potential),
            ..Energies::default()
        },
        params: vec![1.0, 3.0, 2.0],
    };
    let program = model.program();
    assert!(program.constant_mass_matrix());
    // M's entries are constants of the tape: the program costs what f alone costs.
    let mut g = model.graph.clone();
    let derived = eom_graph(&mut g, 2, &model.parts).unwrap();
    let f_only = Tape::new(&g, &derived.force, Inputs::kinetic(2, 3), "f").unwrap();
    assert_eq!(program.tape().instructions(), f_only.instructions());
    check_against_energy_model(&model, 7);
    // Not constant: the double pendulum and a chain.
    assert!(!double_pendulum().program().constant_mass_matrix());
    assert!(!chain(3).program().constant_mass_matrix());
}

#[test]
fn eom_program_singular_mass_matrix_is_a_typed_error() {
    // A constant singular M: the second coordinate carries no inertia.
    let mut graph = Graph::new();
    let mut b = B(&mut graph);
    let (v, x) = (b.0.velocity(0), b.0.coord(0));
    let y = b.0.coord(1);
    let kinetic = b.sq(v);
    let potential = b.mul(x, y);
    let parts = Energies {
        kinetic,
        potential: Some(potential),
        ..Energies::default()
    };
    let program = EomProgram::new(&mut graph, 2, 0, &parts).unwrap();
    assert!(program.constant_mass_matrix());
    let eom = program.bind(&[]).unwrap();
    let mut out = [0.0; 2];
    let err = eom
        .accelerations(0.5, &[1.0, 2.0], &[0.0, 0.0], &mut out)
        .unwrap_err();
    assert_eq!(
        err,
        Error::SingularMassMatrix {
            t: 0.5,
            q: vec![1.0, 2.0],
            reason: "singular"
        }
    );
    // M = q² vanishes at q = 0, as in the energy route.
    let mut graph = Graph::new();
    let mut b = B(&mut graph);
    let (v, x) = (b.0.velocity(0), b.0.coord(0));
    let v2 = b.sq(v);
    let x2 = b.sq(x);
    let kinetic = b.mul(x2, v2);
    let model = Model {
        graph,
        dof: 1,
        parts: Energies {
            kinetic,
            ..Energies::default()
        },
        params: vec![],
    };
    let eom = model.program().bind(&[]).unwrap();
    let mut out = [0.0];
    let err = eom
        .accelerations(0.0, &[0.0], &[1.0], &mut out)
        .unwrap_err();
    let want = model
        .energy_model()
        .accelerations(0.0, &[0.0], &[1.0])
        .unwrap_err();
    assert_eq!(err, want);
    assert!(matches!(err, Error::SingularMassMatrix { .. }));
}

#[test]
#[ignore = "timing; run in release with --ignored --nocapture"]
fn eom_program_speed() {
    use lagrangian::scenes::{DoublePendulum, NPendulum};
    // The hand-written closed forms of the same systems: Cramer's rule for the double
    // pendulum, an assembled and Cholesky-factored matrix for the chain.
    type Closed = Box<dyn Fn(&[f64], &[f64]) -> Vec<f64>>;
    let dp = DoublePendulum::new(1.0, 2.0, 1.5, 0.7, 9.81);
    let cases: Vec<(String, Model, Closed)> = std::iter::once((
        "double pendulum".into(),
        double_pendulum(),
        Box::new(move |q: &[f64], qd: &[f64]| dp.closed_form_accelerations(q, qd).to_vec())
            as Closed,
    ))
    .chain([4, 8, 16, 32].map(|n| {
        let links = NPendulum::uniform(n, 1.3, 0.8, 9.81);
        let closed: Closed = Box::new(move |q, qd| links.closed_form_accelerations(q, qd));
        (format!("chain n = {n}"), chain(n), closed)
    }))
    .collect();
    println!(
        "{:>16} {:>8} {:>8} {:>10} {:>10} {:>10} {:>10} {:>10} {:>10} {:>8}",
        "model",
        "T ins",
        "eom ins",
        "build ms",
        "native ns",
        "interp ns",
        "M, f ns",
        "passes ns",
        "closed ns",
        "ratio"
    );
    for (name, model, closed) in cases {
        let n = model.dof;
        let start = Instant::now();
        let program = model.program();
        let build = start.elapsed().as_secs_f64() * 1e3;
        let eom = program.bind(&model.params).unwrap();
        let interpreted = program.clone().interpreted().bind(&model.params).unwrap();
        let energy = model.energy_model();
        let t_ins = energy.system().kinetic.tape().instructions();
        let q: Vec<f64> = (0..n).map(|i| 0.3 + 0.1 * i as f64).collect();
        let qd: Vec<f64> = (0..n).map(|i| 0.2 - 0.05 * i as f64).collect();
        let mut out = vec![0.0; n];
        let calls = if n > 16 { 4_000 } else { 40_000 };
        let mut run = |eom: &lagrangian::tape::EomFunction, calls| {
            time(calls, |k| {
                eom.accelerations(
                    black_box(k as f64 * 1e-6),
                    black_box(&q),
                    black_box(&qd),
                    &mut out,
                )
                .unwrap()
            })
        };
        let native = run(&eom, calls);
        let interp = run(&interpreted, calls / 4);
        let (mut m, mut f) = (vec![0.0; n * n], vec![0.0; n]);
        let program_ns = time(calls, |k| {
            eom.mass_and_force(
                black_box(k as f64 * 1e-6),
                black_box(&q),
                black_box(&qd),
                &mut m,
                &mut f,
            )
        });
        black_box((&m, &f));
        let passes = time(calls / 4, |k| {
            energy
                .accelerations_into(
                    black_box(k as f64 * 1e-6),
                    black_box(&q),
                    black_box(&qd),
                    &mut out,
                )
                .unwrap()
        });
        let closed_ns = time(calls, |_| {
            black_box(closed(black_box(&q), black_box(&qd)));
        });
        println!(
            "{name:>16} {t_ins:>8} {:>8} {build:>10.2} {native:>10.0} {interp:>10.0} \
             {program_ns:>10.0} {passes:>10.0} {closed_ns:>10.0} {:>8.2}",
            program.tape().instructions(),
            native / closed_ns
        );
        // ∂q̈/∂(q, q̇): the compiled Jacobian against 2n runs of the program on dual numbers.
        let mut jac = vec![0.0; 2 * n * n];
        let compiled = eom.acceleration_jacobian(0.1, &q, &qd, &mut jac).then(|| {
            time(calls / 4, |k| {
                black_box(eom.acceleration_jacobian(k as f64 * 1e-6, &q, &qd, &mut jac));
            })
        });
        let mut x: Vec<Dual64> = q.iter().chain(&qd).map(|&v| Dual64::from_re(v)).collect();
        let mut a = vec![Dual64::from_re(0.0); n];
        let dual = time(calls / 20, |k| {
            let t = Dual64::from_re(k as f64 * 1e-6);
            for j in 0..2 * n {
                x[j].eps = 1.0;
                eom.accelerations_dual(t, &x[..n], &x[n..], &mut a).unwrap();
                x[j].eps = 0.0;
                black_box(&a);
            }
        });
        println!(
            "{name:>16} Jacobian: compiled {} ns, dual numbers {dual:.0} ns",
            compiled.map_or("—".into(), |c| format!("{c:.0}"))
        );
    }
}

#[test]
#[ignore = "diagnostic"]
fn eom_program_size_breakdown() {
    for n in [8, 16, 32] {
        let model = chain(n);
        let mut g = model.graph.clone();
        let eom = eom_graph(&mut g, n, &model.parts).unwrap();
        let k = Inputs::kinetic(n, 3);
        let m = Tape::new(&g, &eom.mass, k, "M").unwrap().instructions();
        let f = Tape::new(&g, &eom.force, k, "f").unwrap().instructions();
        let all: Vec<usize> = eom.mass.iter().chain(&eom.force).copied().collect();
        let both = Tape::new(&g, &all, k, "Mf").unwrap().instructions();
        println!(
            "n = {n}: M {m}, f {f}, together {both}, graph nodes {}",
            g.len()
        );
    }
}

#[test]
fn eom_program_non_finite_accelerations_are_a_typed_error() {
    // U = 1/q: the force is infinite at q = 0, in both routes the same error.
    let mut graph = Graph::new();
    let mut b = B(&mut graph);
    let (v, x) = (b.0.velocity(0), b.0.coord(0));
    let kinetic = b.sq(v);
    let one = b.c(1.0);
    let potential = b.b(Binary::Div, one, x);
    let model = Model {
        graph,
        dof: 1,
        parts: Energies {
            kinetic,
            potential: Some(potential),
            ..Energies::default()
        },
        params: vec![],
    };
    let mut g = model.graph.clone();
    let derived = eom_graph(&mut g, 1, &model.parts).unwrap();
    assert!(!derived.time && derived.constant_mass);
    let eom = model.program().bind(&[]).unwrap();
    let mut out = [0.0];
    let err = eom
        .accelerations(0.25, &[0.0], &[1.0], &mut out)
        .unwrap_err();
    assert_eq!(
        err,
        Error::NonFinite {
            what: "accelerations",
            t: 0.25
        }
    );
    let mut want = [0.0];
    let energy = model
        .energy_model()
        .accelerations_into(0.25, &[0.0], &[1.0], &mut want)
        .unwrap_err();
    assert_eq!(err, energy);
}

#[test]
fn eom_program_abs_at_zero_matches_dual_numbers() {
    // Φ = c |q̇|³ / 3 (drag growing with the square of the speed): ∂Φ/∂q̇ = c q̇ |q̇|, whose
    // derivative rule d|x| = sign(x) ẋ must stay finite at q̇ = 0, where x / |x| would be 0/0.
    // U = ½ k |q|² · |q| has |q| at q = 0 too.
    let mut graph = Graph::new();
    let mut b = B(&mut graph);
    let (m, c, k) = (b.0.param(0), b.0.param(1), b.0.param(2));
    let (x, v) = (b.0.coord(0), b.0.velocity(0));
    let half = b.c(0.5);
    let third = b.c(1.0 / 3.0);
    let v2 = b.sq(v);
    let kinetic = b.mul(half, m);
    let kinetic = b.mul(kinetic, v2);
    let av = b.u(Unary::Abs, v);
    let av3 = b.mul(av, v2);
    let dissipation = b.mul(c, av3);
    let dissipation = b.mul(third, dissipation);
    let ax = b.u(Unary::Abs, x);
    let x2 = b.sq(x);
    let potential = b.mul(ax, x2);
    let potential = b.mul(k, potential);
    let potential = b.mul(half, potential);
    let model = Model {
        graph,
        dof: 1,
        parts: Energies {
            kinetic,
            potential: Some(potential),
            dissipation: Some(dissipation),
            ..Energies::default()
        },
        params: vec![1.5, 0.4, 3.0],
    };
    let energy = model.energy_model();
    let eom = model.program().bind(&model.params).unwrap();
    let mut got = [0.0];
    for (q, qd) in [(0.0, 0.0), (0.7, 0.0), (0.0, -1.2), (-0.3, 0.8)] {
        let want = energy.accelerations(0.0, &[q], &[qd]).unwrap();
        eom.accelerations(0.0, &[q], &[qd], &mut got).unwrap();
        // m q̈ = −(3/2) k q |q| − c q̇ |q̇|
        let exact = (-1.5 * 3.0 * q * q.abs() - 0.4 * qd * qd.abs()) / 1.5;
        assert!(
            (got[0] - want[0]).abs() <= 1e-15,
            "({q}, {qd}): {} vs {}",
            got[0],
            want[0]
        );
        assert!(
            (got[0] - exact).abs() <= 1e-14,
            "({q}, {qd}): {} vs {exact}",
            got[0]
        );
    }
}

#[test]
fn eom_program_native_code_matches_interpreter_bit_for_bit() {
    // With the `jit` feature the program runs as machine code; the interpreter is the reference:
    // M and f agree bit for bit. The accelerations of machine code come from the solve unrolled
    // into it (up to 16 coordinates), the interpreter's from the run-time LDLᵀ: the same
    // arithmetic in another order, so they agree to round-off. The momenta have a tape of
    // their own: bit for bit again.
    for (k, model) in [
        double_pendulum(),
        chain(6),
        driven_pendulum(),
        charged_particle(),
    ]
    .iter()
    .enumerate()
    {
        let program = model.program();
        let expected = if cfg!(feature = "jit") {
            "native"
        } else {
            "interpreter"
        };
        assert_eq!(program.backend(), expected);
        let native = program.bind(&model.params).unwrap();
        let reference = program.interpreted();
        assert_eq!(reference.backend(), "interpreter");
        let reference = reference.bind(&model.params).unwrap();
        let n = model.dof;
        let mut rng = Rng(40 + k as u64);
        let (mut a, mut b) = (vec![0.0; n], vec![0.0; n]);
        let (mut ma, mut fa) = (vec![0.0; n * n], vec![0.0; n]);
        let (mut mb, mut fb) = (vec![0.0; n * n], vec![0.0; n]);
        for _ in 0..50 {
            let t = rng.uniform(-2.0, 2.0);
            let q: Vec<f64> = (0..n).map(|_| rng.uniform(-3.0, 3.0)).collect();
            let qd: Vec<f64> = (0..n).map(|_| rng.uniform(-3.0, 3.0)).collect();
            native.mass_and_force(t, &q, &qd, &mut ma, &mut fa);
            reference.mass_and_force(t, &q, &qd, &mut mb, &mut fb);
            for (i, (x, y)) in ma.iter().chain(&fa).zip(mb.iter().chain(&fb)).enumerate() {
                assert_eq!(x.to_bits(), y.to_bits(), "model {k}, M and f entry {i}");
            }
            native.momenta(t, &q, &qd, &mut a);
            reference.momenta(t, &q, &qd, &mut b);
            for i in 0..n {
                assert_eq!(a[i].to_bits(), b[i].to_bits(), "model {k}, p[{i}]");
            }
            native.accelerations(t, &q, &qd, &mut a).unwrap();
            reference.accelerations(t, &q, &qd, &mut b).unwrap();
            let scale = b.iter().fold(1.0_f64, |s, x| s.max(x.abs()));
            for i in 0..n {
                assert!(
                    (a[i] - b[i]).abs() <= 1e-13 * scale,
                    "model {k}, q̈[{i}]: {} native, {} interpreted",
                    a[i],
                    b[i]
                );
            }
        }
    }
}
