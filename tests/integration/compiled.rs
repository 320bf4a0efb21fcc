//! Eq. 55 compiled, on random models over every function of the expression graph: the machine
//! code (`EomProgram` with the `jit` feature) against the same program interpreted — M and f bit
//! for bit, q̈ to rounding (the machine code has the LDLᵀ solve unrolled into it), errors alike —
//! also where the mathematics fails (log or square root of a negative number, division by zero,
//! overflow, a singular mass matrix); and the derived program against the energy route's
//! dual-number passes ([`EnergyModel`]) on models kept inside their domains.
//!
//! `NativeTape` itself is checked instruction by instruction against the interpreter in
//! `src/native/tape.rs`; here the whole path — derivation, compilation, the LDLᵀ tail — is.

use lagrangian::tape::{
    Binary, Energies, EnergyModel, EomFunction, EomProgram, Function, Graph, Inputs, StepRule,
    Tape, Unary,
};
use lagrangian::{Dynamics, Result};
use std::sync::Arc;

use crate::common::Rng;

const UNARY: [Unary; Unary::ALL.len()] = Unary::ALL;
const BINARY: [Binary; 6] = Binary::ALL;

/// Random expressions on a graph; `safe` keeps every function inside its domain and away from
/// overflow (arguments of ln, √, a variable power's base and a divisor are ≥ ½; those of exp,
/// sinh, cosh and tan are sines).
struct Gen<'a> {
    g: &'a mut Graph,
    rng: &'a mut Rng,
    safe: bool,
}

impl Gen<'_> {
    fn c(&mut self, x: f64) -> usize {
        self.g.constant(x)
    }
    fn un(&mut self, f: Unary, a: usize) -> usize {
        self.g.unary(f, a).unwrap()
    }
    fn bin(&mut self, f: Binary, a: usize, b: usize) -> usize {
        self.g.binary(f, a, b).unwrap()
    }
    /// x² + ½.
    fn pos(&mut self, x: usize) -> usize {
        let x2 = self.g.powi(x, 2).unwrap();
        let h = self.c(0.5);
        self.bin(Binary::Add, x2, h)
    }
    fn sin(&mut self, x: usize) -> usize {
        self.un(Unary::Sin, x)
    }

    /// A random expression of depth at most `depth` over `leaves`.
    fn expr(&mut self, leaves: &[usize], depth: usize) -> usize {
        if depth == 0 || self.rng.below(5) == 0 {
            return if self.rng.below(5) == 0 {
                let x = self.rng.uniform(-2.0, 2.0);
                self.c(x)
            } else {
                leaves[self.rng.below(leaves.len())]
            };
        }
        let a = self.expr(leaves, depth - 1);
        match self.rng.below(10) {
            0..=3 => {
                let f = UNARY[self.rng.below(UNARY.len())];
                let a = match f {
                    Unary::Ln | Unary::Sqrt if self.safe => self.pos(a),
                    Unary::Exp | Unary::Sinh | Unary::Cosh | Unary::Tan if self.safe => self.sin(a),
                    _ => a,
                };
                self.un(f, a)
            }
            4 => {
                // A literal exponent: an integer power, a square root, or `pow`.
                let k: f64 =
                    [-3.0, -2.0, -1.0, 0.0, 1.0, 2.0, 3.0, 5.0, 0.5, 1.5, -0.5][self.rng.below(11)];
                let a = if self.safe && (k < 0.0 || k.fract() != 0.0) {
                    self.pos(a)
                } else {
                    a
                };
                let k = self.c(k);
                self.bin(Binary::Pow, a, k)
            }
            _ => {
                let f = BINARY[self.rng.below(BINARY.len())];
                let b = self.expr(leaves, depth - 1);
                let (a, b) = match f {
                    Binary::Div if self.safe => (a, self.pos(b)),
                    Binary::Pow if self.safe => {
                        let (a, b) = (self.pos(a), self.sin(b));
                        (a, b)
                    }
                    _ => (a, b),
                };
                self.bin(f, a, b)
            }
        }
    }
}

/// A random model: its graph, parts, number of coordinates and parameter values.
struct Model {
    graph: Graph,
    dof: usize,
    parts: Energies,
    params: Vec<f64>,
}

/// T = ½ Σ (a + eᵢ²) q̇ᵢ² + 0.3 cos(e) q̇₀ q̇ₙ₋₁ + e q̇₀ + 0.05 e² q̇₀⁴ with random e(t, q) (M
/// depends on t, q and q̇), and random U, Φ and Q″ — each part only sometimes.
fn random_model(rng: &mut Rng, safe: bool) -> Model {
    let dof = 1 + rng.below(3);
    let mut graph = Graph::new();
    let g = &mut graph;
    let (a, b) = (g.param(0), g.param(1));
    let mut positions = vec![g.time(), a, b];
    positions.extend((0..dof).map(|i| g.coord(i)));
    let mut everything = positions.clone();
    everything.extend((0..dof).map(|i| g.velocity(i)));
    let v: Vec<usize> = (0..dof).map(|i| g.velocity(i)).collect();
    let mut gr = Gen { g, rng, safe };
    let half = gr.c(0.5);
    let mut kinetic = None;
    let mut add = |gr: &mut Gen, term: usize| {
        kinetic = Some(match kinetic {
            Some(k) => gr.bin(Binary::Add, k, term),
            None => term,
        });
    };
    for &vi in &v {
        let m = if gr.rng.below(3) == 0 {
            a
        } else {
            let e = gr.expr(&positions, 2);
            let e2 = gr.g.powi(e, 2).unwrap();
            gr.bin(Binary::Add, a, e2)
        };
        let v2 = gr.g.powi(vi, 2).unwrap();
        let hm = gr.bin(Binary::Mul, half, m);
        let term = gr.bin(Binary::Mul, hm, v2);
        add(&mut gr, term);
    }
    if dof > 1 && gr.rng.below(2) == 0 {
        let e = gr.expr(&positions, 2);
        let c = gr.un(Unary::Cos, e);
        let k = gr.c(0.3);
        let c = gr.bin(Binary::Mul, k, c);
        let vv = gr.bin(Binary::Mul, v[0], v[dof - 1]);
        let term = gr.bin(Binary::Mul, c, vv);
        add(&mut gr, term);
    }
    if gr.rng.below(2) == 0 {
        let e = gr.expr(&positions, 2);
        let term = gr.bin(Binary::Mul, e, v[0]);
        add(&mut gr, term);
    }
    if gr.rng.below(3) == 0 {
        let e = gr.expr(&positions, 2);
        let e2 = gr.g.powi(e, 2).unwrap();
        let v4 = gr.g.powi(v[0], 4).unwrap();
        let k = gr.c(0.05);
        let s = gr.bin(Binary::Mul, k, e2);
        let term = gr.bin(Binary::Mul, s, v4);
        add(&mut gr, term);
    }
    let potential = (gr.rng.below(4) != 0).then(|| gr.expr(&positions, 4));
    let dissipation = (gr.rng.below(2) == 0).then(|| gr.expr(&everything, 3));
    let forces =
        (gr.rng.below(2) == 0).then(|| (0..dof).map(|_| gr.expr(&everything, 3)).collect());
    let params = vec![rng.uniform(0.5, 2.0), rng.uniform(-2.0, 2.0)];
    Model {
        graph,
        dof,
        parts: Energies {
            kinetic: kinetic.unwrap(),
            potential,
            dissipation,
            forces,
        },
        params,
    }
}

impl Model {
    fn program(&self) -> EomProgram {
        let mut g = self.graph.clone();
        EomProgram::new(&mut g, self.dof, self.params.len(), &self.parts).unwrap()
    }

    /// The program bound to the parameters, compiled and interpreted; `None` when binding
    /// fails (a parameter outside a function's domain).
    fn bound_both_ways(&self) -> Option<(EomFunction, EomFunction)> {
        let program = self.program();
        let reference = program.clone().interpreted();
        Some((
            program.bind(&self.params).ok()?,
            reference.bind(&self.params).ok()?,
        ))
    }

    /// The same energies through the tapes' dual-number passes.
    fn energy_model(&self) -> Result<EnergyModel> {
        let np = self.params.len();
        let f = |nodes: &[usize], inputs: Inputs| -> Result<Function> {
            let tape = Tape::new(&self.graph, nodes, inputs, "part")?;
            Function::new(Arc::new(tape), &self.params)
        };
        let all = Inputs::kinetic(self.dof, np);
        let potential = Inputs::potential(self.dof, np);
        EnergyModel::new(
            self.dof,
            f(&[self.parts.kinetic], all)?,
            self.parts
                .potential
                .map(|u| f(&[u], potential))
                .transpose()?,
            self.parts.dissipation.map(|r| f(&[r], all)).transpose()?,
            self.parts.forces.as_ref().map(|q| f(q, all)).transpose()?,
        )
    }
}

/// Equal bits, or both NaN.
fn same(a: f64, b: f64) -> bool {
    a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan())
}

/// A state value: ordinary numbers mostly, sometimes where functions fail (0, ±1, ±π/2,
/// overflow for exp, sinh, cosh, powers), now and then not finite at all.
fn value(rng: &mut Rng) -> f64 {
    match rng.below(12) {
        0 => [
            0.0,
            -0.0,
            1.0,
            -1.0,
            std::f64::consts::FRAC_PI_2,
            40.0,
            800.0,
            -800.0,
            1e200,
            f64::INFINITY,
            f64::NAN,
        ][rng.below(11)],
        _ => rng.uniform(-3.0, 3.0),
    }
}

/// Run both, compare M and f bit for bit, q̈ (or the error) to 1e-13 of its largest entry (the
/// worst relative difference to `worst`); whether q̈ was finite.
fn check_state(
    native: &EomFunction,
    interpreted: &EomFunction,
    n: usize,
    (t, q, qd): (f64, &[f64], &[f64]),
    case: usize,
    worst: &mut f64,
) -> bool {
    let (mut m1, mut f1) = (vec![0.0; n * n], vec![0.0; n]);
    let (mut m2, mut f2) = (vec![0.0; n * n], vec![0.0; n]);
    native.mass_and_force(t, q, qd, &mut m1, &mut f1);
    interpreted.mass_and_force(t, q, qd, &mut m2, &mut f2);
    for (k, (x, y)) in m1.iter().zip(&m2).chain(f1.iter().zip(&f2)).enumerate() {
        assert!(
            same(*x, *y),
            "case {case}, output {k} at t = {t}, q = {q:?}, q̇ = {qd:?}: native {x}, \
             interpreter {y}"
        );
    }
    let (mut a1, mut a2) = (vec![0.0; n], vec![0.0; n]);
    let r1 = native.accelerations(t, q, qd, &mut a1);
    let r2 = interpreted.accelerations(t, q, qd, &mut a2);
    // Compared as text: an error at t = NaN is not equal to itself.
    assert_eq!(
        format!("{r1:?}"),
        format!("{r2:?}"),
        "case {case} at t = {t}, q = {q:?}, q̇ = {qd:?}"
    );
    if r1.is_ok() {
        assert!(a1.iter().all(|x| x.is_finite()), "case {case}: {a1:?}");
        // The machine code solves for q̈ with the LDLᵀ unrolled into the program, the
        // interpreter factors M apart: the same arithmetic up to rounding.
        let scale = a2.iter().fold(0.0_f64, |s, x| s.max(x.abs()));
        for (x, y) in a1.iter().zip(&a2) {
            let err = (x - y).abs();
            assert!(err <= 1e-13 * scale, "case {case}: q̈ {a1:?} against {a2:?}");
            *worst = worst.max(err / scale);
        }
    }
    r1.is_ok()
}

#[test]
fn compiled_eom_matches_interpreter_on_random_models() {
    let mut rng = Rng(0x1e55_0a12);
    let (mut models, mut finite, mut failed, mut rejected) = (0, 0, 0, 0);
    let mut worst = 0.0_f64;
    let mut errors = std::collections::BTreeSet::new();
    for case in 0..300 {
        let model = random_model(&mut rng, false);
        let program = model.program();
        let expected = if cfg!(feature = "jit") {
            "native"
        } else {
            "interpreter"
        };
        assert_eq!(program.backend(), expected, "case {case}");
        let reference = program.clone().interpreted();
        assert_eq!(reference.backend(), "interpreter");
        // Parameters that make a constant part non-finite are rejected when binding, by both.
        let (native, interpreted) =
            match (program.bind(&model.params), reference.bind(&model.params)) {
                (Ok(a), Ok(b)) => (a, b),
                (Err(a), Err(b)) => {
                    assert_eq!(a, b);
                    rejected += 1;
                    continue;
                }
                (a, b) => panic!("case {case}: binding {a:?} against {b:?}"),
            };
        models += 1;
        let n = model.dof;
        for _ in 0..12 {
            let t = value(&mut rng);
            let q: Vec<f64> = (0..n).map(|_| value(&mut rng)).collect();
            let qd: Vec<f64> = (0..n).map(|_| value(&mut rng)).collect();
            if check_state(&native, &interpreted, n, (t, &q, &qd), case, &mut worst) {
                finite += 1;
            } else {
                failed += 1;
                let mut out = vec![0.0; n];
                let e = native.accelerations(t, &q, &qd, &mut out).unwrap_err();
                errors.insert(
                    format!("{e:?}")
                        .split([' ', '{'])
                        .next()
                        .unwrap()
                        .to_owned(),
                );
            }
        }
    }
    println!(
        "{models} models ({rejected} rejected when bound): {finite} finite states, {failed} \
         failing ({errors:?}); q̈ differs by {worst:.2e} of its largest entry at most"
    );
    // Both outcomes well represented, and both typed errors.
    assert!(
        models >= 200 && finite >= 1000 && failed >= 300,
        "{models} {finite} {failed}"
    );
    assert!(errors.contains("NonFinite") && errors.contains("SingularMassMatrix"));
}

#[test]
fn compiled_eom_matches_energy_route_on_random_models() {
    // Inside their domains: the derived, compiled program against the dual-number passes of
    // the same energies, q̈ and M to 1e-13 relative to the largest entry.
    let mut rng = Rng(0xdecaf);
    let (mut compared, mut singular, mut worst) = (0, 0, 0.0_f64);
    for case in 0..200 {
        let model = random_model(&mut rng, true);
        let eom = model.program().bind(&model.params).unwrap();
        let energy = model.energy_model().unwrap();
        let n = model.dof;
        let (mut got, mut m, mut f) = (vec![0.0; n], vec![0.0; n * n], vec![0.0; n]);
        for _ in 0..10 {
            let t = rng.uniform(-2.0, 2.0);
            let q: Vec<f64> = (0..n).map(|_| rng.uniform(-2.0, 2.0)).collect();
            let qd: Vec<f64> = (0..n).map(|_| rng.uniform(-2.0, 2.0)).collect();
            let want = energy.accelerations(t, &q, &qd);
            let have = eom.accelerations(t, &q, &qd, &mut got);
            let want = match (want, have) {
                (Ok(want), Ok(())) => want,
                (Err(a), Err(b)) => {
                    // Near a singular M the two may differ only in the reason.
                    assert_eq!(
                        std::mem::discriminant(&a),
                        std::mem::discriminant(&b),
                        "case {case}: {a:?} against {b:?}"
                    );
                    singular += 1;
                    continue;
                }
                (a, b) => panic!("case {case} at t = {t}, q = {q:?}, q̇ = {qd:?}: {a:?} {b:?}"),
            };
            // The models are of size one (parameters, states and the functions' values in
            // their domains): a small q̈ is a cancellation of terms of that size, so 1 is the
            // floor of the scale, as in tests/integration/graph_derivatives.rs.
            let scale = want.iter().fold(1.0_f64, |s, x| s.max(x.abs()));
            for i in 0..n {
                let err = (got[i] - want[i]).abs() / scale;
                worst = worst.max(err);
                assert!(
                    err <= 1e-13,
                    "case {case}, q̈[{i}] at t = {t}, q = {q:?}, q̇ = {qd:?}: derived {}, \
                     energy route {} ({err:.2e})",
                    got[i],
                    want[i]
                );
            }
            let want_m = energy.mass_matrix(t, &q, &qd).unwrap();
            eom.mass_and_force(t, &q, &qd, &mut m, &mut f);
            let scale = want_m.iter().fold(1.0_f64, |s, x| s.max(x.abs()));
            for i in 0..n {
                for j in 0..n {
                    let err = (m[i * n + j] - want_m[(i, j)]).abs() / scale;
                    assert!(err <= 1e-13, "case {case}, M[{i}][{j}] ({err:.2e})");
                }
            }
            compared += 1;
        }
    }
    println!("{compared} states compared, {singular} failing alike, worst q̈ error {worst:.2e}");
    assert!(compared >= 1500, "{compared}");
}

/// The Taylor recurrences as machine code against the same recurrences interpreted, on random
/// models over every function: every coefficient bit for bit, errors alike (issue 16). Most
/// expansions run the recurrences order by order (`SeriesKernel`), some the whole expansion
/// unrolled (`ExpansionKernel`, compiled ahead with `unroll`).
#[test]
fn taylor_kernel_matches_interpreter_on_random_models() {
    let mut rng = Rng(0x7a11_0516);
    let (mut expanded, mut failed, mut unrolled, mut stepped) = (0, 0, 0, 0);
    for case in 0..150 {
        let model = random_model(&mut rng, case % 2 == 0);
        let Some((native, interpreted)) = model.bound_both_ways() else {
            continue;
        };
        let (a, params) = native.taylor();
        let (b, _) = interpreted.taylor();
        assert_eq!(a.is_native(), cfg!(feature = "jit"), "case {case}");
        assert!(!b.is_native(), "case {case}");
        let n = model.dof;
        for _ in 0..4 {
            let t = rng.uniform(-2.0, 2.0);
            let q: Vec<f64> = (0..n).map(|_| rng.uniform(-2.0, 2.0)).collect();
            let qd: Vec<f64> = (0..n).map(|_| rng.uniform(-2.0, 2.0)).collect();
            let order = 3 + rng.below(20);
            // Orders up to 8 only: compiling the unrolled code is quadratic in the order, and
            // the test builds run Cranelift unoptimized.
            if order <= 8 && rng.below(4) == 0 {
                assert_eq!(a.unroll(order), cfg!(feature = "jit"), "case {case}");
                assert!(!b.unroll(order), "case {case}");
                unrolled += 1;
            }
            let (mut x, mut y) = (a.expansion(params, order), b.expansion(params, order));
            let (r1, r2) = (x.expand(t, &q, &qd), y.expand(t, &q, &qd));
            assert_eq!(format!("{r1:?}"), format!("{r2:?}"), "case {case}");
            if r1.is_err() {
                failed += 1;
                continue;
            }
            expanded += 1;
            for k in 0..=order {
                for (u, v) in x.q(k).iter().zip(y.q(k)).chain(x.qd(k).iter().zip(y.qd(k))) {
                    assert!(same(*u, *v), "case {case}, order {k}: {u} against {v}");
                }
            }
            // A Taylor step from there (one call of machine code once unrolled): the time it
            // reaches, the new state and its compensation, or the error, alike.
            let state = [q.as_slice(), qd.as_slice()].concat();
            let tol = 10f64.powf(-rng.uniform(3.0, 15.0));
            let rule = StepRule {
                rtol: tol,
                atol: tol * rng.uniform(0.5, 2.0),
                h_max: rng.uniform(0.01, 2.0),
                min_step: 0.0,
                t_end: t + rng.uniform(-1.0, 1.0),
                dir: if rng.below(2) == 0 { 1.0 } else { -1.0 },
                // Every coordinate, or the first few only (a variational system's own).
                controlled: if rng.below(2) == 0 {
                    f64::INFINITY
                } else {
                    (1 + rng.below(n)) as f64
                },
            };
            let lost: Vec<f64> = (0..2 * n).map(|_| rng.uniform(-1e-17, 1e-17)).collect();
            let (mut la, mut lb) = (lost.clone(), lost);
            let (mut ya, mut yb) = (vec![0.0; 2 * n], vec![0.0; 2 * n]);
            let sa = x.step(t, &state, &rule, &mut la, &mut ya);
            let sb = y.step(t, &state, &rule, &mut lb, &mut yb);
            match (sa, sb) {
                (Ok((ta, ea)), Ok((tb, eb))) => {
                    assert!(
                        same(ta, tb) && ea == eb,
                        "case {case}: {ta} {ea} against {tb} {eb}"
                    );
                    for (u, v) in ya.iter().zip(&yb).chain(la.iter().zip(&lb)) {
                        assert!(same(*u, *v), "case {case}, step to {ta}: {u} against {v}");
                    }
                    stepped += 1;
                }
                (a, b) => assert_eq!(format!("{a:?}"), format!("{b:?}"), "case {case}"),
            }
        }
    }
    println!(
        "{expanded} expansions equal bit for bit, {failed} failing alike, {unrolled} unrolled, \
         {stepped} steps alike"
    );
    assert!(
        expanded >= 300 && failed >= 10 && unrolled >= 25 && stepped >= 200,
        "{expanded} {failed} {unrolled} {stepped}"
    );
}

/// The unrolled expansion at the orders the Taylor method runs at tight tolerances (p = 13 at
/// 1e-12, 19 at 1e-15), where its sums run in two-lane vectors over mirrored series, against
/// the interpreter on random models: every coefficient bit for bit.
#[test]
fn unrolled_expansion_at_high_orders_matches_interpreter() {
    let mut rng = Rng(0x0516_2026);
    let (mut compared, mut cases) = (0, 0);
    while cases < 4 {
        let model = random_model(&mut rng, true);
        let Some((native, interpreted)) = model.bound_both_ways() else {
            continue;
        };
        cases += 1;
        let (a, params) = native.taylor();
        let (b, _) = interpreted.taylor();
        let n = model.dof;
        for order in [13, 19] {
            assert_eq!(a.unroll(order), cfg!(feature = "jit"));
            let t = rng.uniform(-1.0, 1.0);
            let q: Vec<f64> = (0..n).map(|_| rng.uniform(-1.0, 1.0)).collect();
            let qd: Vec<f64> = (0..n).map(|_| rng.uniform(-1.0, 1.0)).collect();
            let (mut x, mut y) = (a.expansion(params, order), b.expansion(params, order));
            let (r1, r2) = (x.expand(t, &q, &qd), y.expand(t, &q, &qd));
            assert_eq!(format!("{r1:?}"), format!("{r2:?}"));
            if r1.is_err() {
                continue;
            }
            for k in 0..=order {
                for (u, v) in x.q(k).iter().zip(y.q(k)).chain(x.qd(k).iter().zip(y.qd(k))) {
                    assert!(same(*u, *v), "order {k} of {order}: {u} against {v}");
                }
            }
            compared += 1;
        }
    }
    assert!(compared >= 5, "{compared}");
}
