//! Andrews' squeezing mechanism (issue 41 item 8; the IVP Test Set's `andrews`) to a relative
//! error of 1e-7 in q at t = 0.03 against the Test Set's reference, each side with DOP853 at the
//! loosest tolerance (of 10^{-k/2}, rtol = atol) that meets it:
//!
//! - `andrews_1e-7/ode_solvers_dop853_hand`: the limit. The Test Set's M, f, G and γ written
//!   out by hand, q̈ and λ from the 13 × 13 augmented system per evaluation
//!   ([`Andrews::test_set_index1`]), integrated by the `ode_solvers` crate's DOP853;
//! - `andrews_1e-7/dop853_hand`: the same right-hand side through this crate's DOP853 (a
//!   [`Dynamics`] written by hand, below);
//! - `andrews_1e-7/dop853_model`: this crate's model from the energies and the constraints
//!   ([`Andrews::model`], [`lagrangian::Constrained`]) with its DOP853 (and its projection
//!   onto the constraints after each step).
//! - `andrews_1e-7/dop853_model_compiled`: the same model with M and f from the eq. 55 program
//!   traced from the same energies ([`lagrangian::trace::eom_program`]) and compiled (native
//!   code with `--features jit`, the tape interpreter without), as a model stated through the
//!   Python API gets it; G and γ still by dual numbers;
//! - `andrews_1e-7/dop853_model_compiled_rows`: and G and γ too from the constraints traced into
//!   a graph and compiled ([`lagrangian::tape::ConstraintProgram`]), the whole right-hand side
//!   derived and compiled.
//!
//! The bench writes `andrews_meta.json` (tolerance, steps, error of each side) next to
//! criterion's estimates; `python3 benches/andrews.py --cargo` runs it and prints the table of
//! docs/site/andrews.rst with SciPy's DOP853 on a NumPy right-hand side beside it.

use criterion::{Criterion, criterion_group, criterion_main};
use lagrangian::integrators::{Method, Options, Output, solve};
use lagrangian::scenes::Andrews;
use lagrangian::tape::{ConstraintProgram, ConstraintRows, EomFunction};
use lagrangian::trace::Traced;
use lagrangian::{
    Constrained, Constraints, DerivedProgram, Dynamics, Potential, Result, Scalar, Structure,
    System,
};
use std::hint::black_box;
use std::time::Duration;

/// The accuracy every side must reach: max_i |qᵢ − qᵢ_ref| / |qᵢ_ref| at t = 0.03.
const TARGET: f64 = 1e-7;

/// End of the Test Set's span.
const T_END: f64 = 0.03;

/// The largest componentwise relative error of q against the Test Set's reference at 0.03.
fn error(q: &[f64]) -> f64 {
    let reference = Andrews::reference_at_0_03().q;
    q.iter()
        .zip(&reference)
        .fold(0.0_f64, |m, (x, r)| m.max((x - r).abs() / r.abs()))
}

// ---------------------------------------------------------------------------------------------
// The hand-written index-1 right-hand side, for `ode_solvers` and for this crate

type State = ode_solvers::SVector<f64, 14>;

struct OdeAndrews(Andrews);
impl ode_solvers::System<f64, State> for OdeAndrews {
    fn system(&self, _t: f64, y: &State, dy: &mut State) {
        let y = y.as_slice();
        let (qdd, _) = self.0.test_set_index1(&y[..7], &y[7..]);
        let dy = dy.as_mut_slice();
        dy[..7].copy_from_slice(&y[7..]);
        dy[7..].copy_from_slice(&qdd);
    }
}

/// The Test Set's index-1 equations as a [`Dynamics`]: everything by hand, nothing derived.
struct HandAndrews(Andrews);

impl HandAndrews {
    fn mass<D: Scalar>(q: &[D], qd: &[D], out: &mut [D]) {
        let m = Andrews::test_set_mass_matrix(q);
        for (o, row) in out.iter_mut().zip(&m) {
            *o = row.iter().zip(qd).fold(D::zero(), |s, (&a, &v)| s + a * v);
        }
    }
}

impl Dynamics for HandAndrews {
    fn dof(&self) -> usize {
        7
    }
    fn structure(&self) -> Structure {
        Structure {
            dof: 7,
            time_dependent: false,
            constant_mass: false,
            separable: false,
            dissipative: false,
            forced: false,
        }
    }
    fn kinetic_energy<D: Scalar>(&self, _t: D, q: &[D], qd: &[D]) -> D {
        let mut p = [D::zero(); 7];
        Self::mass(q, qd, &mut p);
        p.iter().zip(qd).fold(D::zero(), |s, (&a, &v)| s + a * v) * 0.5
    }
    fn potential_energy<D: Scalar>(&self, t: D, q: &[D]) -> D {
        self.0.potential(t, q)
    }
    fn potential_gradient_into<D: Scalar>(&self, _t: D, q: &[D], out: &mut [D]) {
        // f at rest is the torque and the spring alone: −∂U/∂q.
        let f = self.0.test_set_forces(q, &[D::zero(); 7]);
        for (o, x) in out.iter_mut().zip(f) {
            *o = -x;
        }
    }
    fn generalized_forces_into<D: Scalar>(&self, _t: D, _q: &[D], _qd: &[D], out: &mut [D]) {
        out.fill(D::zero());
    }
    fn dissipative_forces_into<D: Scalar>(&self, _t: D, _q: &[D], _qd: &[D], out: &mut [D]) {
        out.fill(D::zero());
    }
    fn momenta_into<D: Scalar>(&self, _t: D, q: &[D], qd: &[D], out: &mut [D]) {
        Self::mass(q, qd, out);
    }
    fn mass_matrix_into<D: Scalar>(&self, _t: D, q: &[D], _qd: &[D], out: &mut [D]) {
        let m = Andrews::test_set_mass_matrix(q);
        for (o, x) in out.iter_mut().zip(m.iter().flatten()) {
            *o = *x;
        }
    }
    fn accelerations_into<D: Scalar>(&self, _t: D, q: &[D], qd: &[D], out: &mut [D]) -> Result<()> {
        let (qdd, _) = self.0.test_set_index1(q, qd);
        out.copy_from_slice(&qdd);
        Ok(())
    }
}

/// The squeezer's system with its traced, compiled eq. 55 program: everything passes through to
/// the Rust system, and [`Dynamics::derived_program`] hands out the program, from which
/// [`lagrangian::Constrained`] takes M and f at `f64` states in one run.
struct Compiled {
    system: System<Andrews, Andrews>,
    program: EomFunction,
}

impl Dynamics for Compiled {
    fn dof(&self) -> usize {
        self.system.dof()
    }
    fn structure(&self) -> Structure {
        self.system.structure()
    }
    fn kinetic_energy<D: Scalar>(&self, t: D, q: &[D], qd: &[D]) -> D {
        self.system.kinetic_energy(t, q, qd)
    }
    fn potential_energy<D: Scalar>(&self, t: D, q: &[D]) -> D {
        self.system.potential_energy(t, q)
    }
    fn potential_gradient_into<D: Scalar>(&self, t: D, q: &[D], out: &mut [D]) {
        self.system.potential_gradient_into(t, q, out)
    }
    fn generalized_forces_into<D: Scalar>(&self, t: D, q: &[D], qd: &[D], out: &mut [D]) {
        self.system.generalized_forces_into(t, q, qd, out)
    }
    fn dissipative_forces_into<D: Scalar>(&self, t: D, q: &[D], qd: &[D], out: &mut [D]) {
        self.system.dissipative_forces_into(t, q, qd, out)
    }
    fn momenta_into<D: Scalar>(&self, t: D, q: &[D], qd: &[D], out: &mut [D]) {
        self.system.momenta_into(t, q, qd, out)
    }
    fn mass_matrix_into<D: Scalar>(&self, t: D, q: &[D], qd: &[D], out: &mut [D]) {
        self.system.mass_matrix_into(t, q, qd, out)
    }
    fn accelerations_into<D: Scalar>(&self, t: D, q: &[D], qd: &[D], out: &mut [D]) -> Result<()> {
        self.system.accelerations_into(t, q, qd, out)
    }
    fn derived_program(&self) -> Option<&dyn DerivedProgram> {
        Some(&self.program)
    }
}

/// The squeezer under its constraints with M and f from its traced, compiled eq. 55 program.
fn compiled_model(squeezer: Andrews) -> Constrained<Compiled, Andrews> {
    let system = squeezer.system();
    let program = lagrangian::trace::eom_program(&system, "andrews").unwrap();
    Constrained::new(Compiled { system, program }, squeezer.constraints())
}

/// The squeezer's loop closures with G and γ from their traced, compiled rows
/// ([`Constraints::compiled_rows`]); the rows themselves pass through.
struct CompiledRows {
    squeezer: Andrews,
    rows: ConstraintRows,
}

impl CompiledRows {
    fn new(squeezer: Andrews) -> Self {
        let (mut graph, nodes) = lagrangian::trace::record(7, |t, q, _qd| {
            let mut out = vec![Traced::number(0.0); 6];
            squeezer.holonomic(t, q, &mut out);
            out
        })
        .unwrap();
        let program = ConstraintProgram::new(&mut graph, 7, 0, &nodes, &[], false).unwrap();
        let rows = program.bind(&[]).unwrap();
        Self { squeezer, rows }
    }
}

impl Constraints for CompiledRows {
    fn holonomic_count(&self) -> usize {
        self.squeezer.holonomic_count()
    }
    fn holonomic<D: Scalar>(&self, t: D, q: &[D], out: &mut [D]) {
        self.squeezer.holonomic(t, q, out)
    }
    fn depends_on_time(&self) -> bool {
        false
    }
    fn name(&self, row: usize) -> String {
        self.squeezer.name(row)
    }
    fn compiled_rows(
        &self,
        t: f64,
        q: &[f64],
        qd: &[f64],
        g: &mut [f64],
        gamma: &mut [f64],
    ) -> bool {
        self.rows.eval(t, q, qd, g, gamma);
        true
    }
}

/// The squeezer with M, f, G and γ all from compiled programs derived on the graph.
fn compiled_rows_model(squeezer: Andrews) -> Constrained<Compiled, CompiledRows> {
    let system = squeezer.system();
    let program = lagrangian::trace::eom_program(&system, "andrews").unwrap();
    Constrained::new(Compiled { system, program }, CompiledRows::new(squeezer))
}

// ---------------------------------------------------------------------------------------------
// Runs

/// q at 0.03 and the accepted steps of this crate's DOP853 on `system` at rtol = atol = `tol`.
fn crate_run<S: Dynamics>(system: &S, tol: f64) -> (Vec<f64>, usize) {
    let (q0, qd0) = Andrews::initial_state();
    let options = Options::adaptive(tol, tol).with_output(Output::Final);
    let sol = solve(system, &q0, &qd0, (0.0, T_END), Method::Dop853, &options).unwrap();
    let (_, q, _) = sol.last().unwrap();
    (q.to_vec(), sol.stats.accepted_steps)
}

/// The same with `ode_solvers`' DOP853 on the hand-written right-hand side.
fn ode_run(tol: f64) -> (Vec<f64>, usize) {
    let (q0, qd0) = Andrews::initial_state();
    let mut y0 = State::zeros();
    y0.as_mut_slice()[..7].copy_from_slice(&q0);
    y0.as_mut_slice()[7..].copy_from_slice(&qd0);
    let mut s = ode_solvers::dop853::Dop853::new(
        OdeAndrews(Andrews::default()),
        0.0,
        T_END,
        T_END,
        y0,
        tol,
        tol,
    );
    // Sparse: the state after every step, no dense-output stages.
    s.set_output(ode_solvers::OutputType::Sparse);
    let stats = s.integrate().unwrap();
    let y = s.y_out().last().unwrap();
    (y.as_slice()[..7].to_vec(), stats.accepted_steps as usize)
}

/// A run at rtol = atol = tol: q at 0.03 and the accepted steps.
type Run<'a> = &'a dyn Fn(f64) -> (Vec<f64>, usize);

/// The loosest tolerance 10^{-k/2} (k = 8..=28) whose run meets [`TARGET`], its error and steps.
fn loosest(run: Run) -> Option<(f64, f64, usize)> {
    (8..=28)
        .map(|k| 10f64.powf(-k as f64 / 2.0))
        .map(|tol| {
            let (q, steps) = run(tol);
            (tol, error(&q), steps)
        })
        .find(|&(_, e, _)| e <= TARGET)
}

fn andrews(c: &mut Criterion) {
    let squeezer = Andrews::default();
    let hand = HandAndrews(squeezer);
    let model = squeezer.model();
    let compiled = compiled_model(squeezer);
    let compiled_rows = compiled_rows_model(squeezer);
    let sides: [(&str, Run); 5] = [
        ("ode_solvers_dop853_hand", &ode_run),
        ("dop853_hand", &|tol| crate_run(&hand, tol)),
        ("dop853_model", &|tol| crate_run(&model, tol)),
        ("dop853_model_compiled", &|tol| crate_run(&compiled, tol)),
        ("dop853_model_compiled_rows", &|tol| {
            crate_run(&compiled_rows, tol)
        }),
    ];
    let mut g = c.benchmark_group("andrews_1e-7");
    g.sample_size(10)
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_millis(1500));
    let mut meta = Vec::new();
    for (name, run) in sides {
        let Some((tol, err, steps)) = loosest(run) else {
            meta.push(format!("\"{name}\": null"));
            continue;
        };
        meta.push(format!(
            "\"{name}\": {{\"tol\": {tol:e}, \"steps\": {steps}, \"error\": {err:e}}}"
        ));
        g.bench_function(name, |b| b.iter(|| black_box(run(tol))));
    }
    g.finish();
    let dir = std::env::var("CARGO_TARGET_DIR").unwrap_or_else(|_| "target".into());
    let path = std::path::Path::new(&dir)
        .join("criterion")
        .join("andrews_meta.json");
    let _ = std::fs::create_dir_all(path.parent().unwrap());
    let _ = std::fs::write(&path, format!("{{{}}}\n", meta.join(", ")));
}

/// One evaluation of the right-hand side and of its parts at the reference state, to show where
/// the model's time goes: `andrews_evaluation/{hand_index1, model_evaluate,
/// model_compiled_evaluate, model_compiled_rows_evaluate, model_compiled_rows_accelerations,
/// compiled_rows, compiled_mass_and_force, unconstrained_accelerations, mass_matrix, constraint_jacobian,
/// gamma}`.
fn andrews_evaluation(c: &mut Criterion) {
    let squeezer = Andrews::default();
    let model = squeezer.model();
    let system = squeezer.system();
    let r = Andrews::reference_at_0_03();
    let (q, qd) = (&r.q[..], &r.qd[..]);
    let mut g = c.benchmark_group("andrews_evaluation");
    g.sample_size(10)
        .warm_up_time(Duration::from_millis(200))
        .measurement_time(Duration::from_millis(600));
    g.bench_function("hand_index1", |b| {
        b.iter(|| squeezer.test_set_index1(black_box(q), black_box(qd)))
    });
    g.bench_function("model_evaluate", |b| {
        b.iter(|| model.evaluate(0.0, black_box(q), black_box(qd)).unwrap())
    });
    let compiled = compiled_model(squeezer);
    g.bench_function("model_compiled_evaluate", |b| {
        b.iter(|| compiled.evaluate(0.0, black_box(q), black_box(qd)).unwrap())
    });
    let all = compiled_rows_model(squeezer);
    g.bench_function("model_compiled_rows_evaluate", |b| {
        b.iter(|| all.evaluate(0.0, black_box(q), black_box(qd)).unwrap())
    });
    // What the integrators call (the inherent `Constrained::accelerations` goes through
    // `evaluate`).
    let mut qdd = [0.0; 7];
    g.bench_function("model_compiled_rows_accelerations", |b| {
        b.iter(|| {
            Dynamics::accelerations_into(&all, 0.0, black_box(q), black_box(qd), &mut qdd).unwrap()
        })
    });
    let (mut gm, mut gamma) = ([0.0; 42], [0.0; 6]);
    g.bench_function("compiled_rows", |b| {
        b.iter(|| {
            all.constraints()
                .rows
                .eval(0.0, black_box(q), black_box(qd), &mut gm, &mut gamma)
        })
    });
    let program = &compiled.system().program;
    let (mut m, mut f) = ([0.0; 49], [0.0; 7]);
    g.bench_function("compiled_mass_and_force", |b| {
        b.iter(|| program.mass_and_force(0.0, black_box(q), black_box(qd), &mut m, &mut f))
    });
    g.bench_function("unconstrained_accelerations", |b| {
        b.iter(|| {
            system
                .accelerations(0.0, black_box(q), black_box(qd))
                .unwrap()
        })
    });
    g.bench_function("mass_matrix", |b| {
        b.iter(|| {
            system
                .mass_matrix(0.0, black_box(q), black_box(qd))
                .unwrap()
        })
    });
    g.bench_function("constraint_jacobian", |b| {
        b.iter(|| {
            model
                .constraint_jacobian(0.0, black_box(q), black_box(qd))
                .unwrap()
        })
    });
    g.bench_function("gamma", |b| {
        b.iter(|| model.gamma(0.0, black_box(q), black_box(qd)).unwrap())
    });
    g.finish();
}

criterion_group!(benches, andrews, andrews_evaluation);
criterion_main!(benches);
