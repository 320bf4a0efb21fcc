//! The stepping loops alone (issue 43 item 1): the double pendulum's hand-written closed-form
//! right-hand side ([`accelerations`], the same function on both sides) integrated to t = 10
//! with only the final state kept (no dense output, no events), by this crate's loops and by
//! the limit:
//!
//! - `loops_dop853_<tol>/{ode_solvers,ours}` at rtol = atol = 1e-6 and 1e-9: `ode_solvers`' DOP853
//!   (`OutputType::Sparse`: no dense-output stages) against [`solve`] with [`Method::Dop853`]
//!   and [`Output::Final`];
//! - `loops_dopri5_<tol>/{ode_solvers,ours}`: the same with DOPRI5;
//! - `loops_rk4/{hand,ours}`: 1 000 fixed steps of RK4 (dt = 0.01), a loop over `[f64; 4]`
//!   written out by hand against [`solve`] with [`Method::Rk4`] and [`Options::fixed`];
//! - `loops_{stormer_verlet,yoshida4}/{hand,ours}`: the explicit splittings, 1 000 steps on
//!   Kepler's problem (e = 0.5, a separable system; [`HandKepler`]), a hand-written loop over
//!   `[f64; 2]` with the same coefficients against [`solve`].
//!
//! The two sides of a pair take nearly the same steps, not the same ones (their step-size
//! controls differ in details); the bench writes each side's evaluation count to
//! `loops_meta.json` next to criterion's estimates, and `python3 benches/loops.py` prints the
//! ratios, of time and of time per evaluation.

use criterion::{Criterion, criterion_group, criterion_main};
use lagrangian::integrators::{Method, Options, Output, SymplecticTableau, solve};
use lagrangian::scenes::{DoublePendulum, Kepler};
use lagrangian::{Dynamics, Result, Scalar, Structure};
use std::hint::black_box;
use std::time::Duration;

// Only the double pendulum (and its check) are used here.
#[allow(dead_code)]
mod closed_forms;
use closed_forms::ClosedDoublePendulum;

/// End of the span.
const T_END: f64 = 10.0;
/// The initial state (q₀, q̇₀): both links swinging wide.
const Q0: [f64; 2] = [0.7, -0.4];
const QD0: [f64; 2] = [0.3, 1.2];

type State = ode_solvers::Vector4<f64>;

/// The double pendulum's accelerations written out by hand: the one right-hand side both sides
/// evaluate. The arguments are read before the first libm call, so that the compiler fuses
/// sin(q₀ − q₁) and cos(q₀ − q₁) into one `sincos` wherever it is compiled (a bounds check
/// between them kept them apart in one of two copies of [`ClosedDoublePendulum`]'s, which
/// made the two sides' right-hand sides differ by a third).
fn accelerations<D: Scalar>(dp: &DoublePendulum, q: [D; 2], qd: [D; 2]) -> [D; 2] {
    let DoublePendulum { m1, m2, l1, l2, g } = *dp;
    let (s, c) = (q[0] - q[1]).sin_cos();
    let (a, b, d) = (
        D::from((m1 + m2) * l1 * l1),
        c * (m2 * l1 * l2),
        D::from(m2 * l2 * l2),
    );
    let e = -s * qd[1] * qd[1] * (m2 * l1 * l2) - q[0].sin() * ((m1 + m2) * g * l1);
    let f = s * qd[0] * qd[0] * (m2 * l1 * l2) - q[1].sin() * (m2 * g * l2);
    let det = a * d - b * b;
    [(e * d - b * f) / det, (a * f - b * e) / det]
}

/// [`ClosedDoublePendulum`] with [`accelerations`] as its right-hand side.
struct Hand(ClosedDoublePendulum);

impl Dynamics for Hand {
    fn dof(&self) -> usize {
        2
    }
    fn structure(&self) -> Structure {
        self.0.structure()
    }
    fn kinetic_energy<D: Scalar>(&self, t: D, q: &[D], qd: &[D]) -> D {
        self.0.kinetic_energy(t, q, qd)
    }
    fn potential_energy<D: Scalar>(&self, t: D, q: &[D]) -> D {
        self.0.potential_energy(t, q)
    }
    fn potential_gradient_into<D: Scalar>(&self, t: D, q: &[D], out: &mut [D]) {
        self.0.potential_gradient_into(t, q, out)
    }
    fn generalized_forces_into<D: Scalar>(&self, t: D, q: &[D], qd: &[D], out: &mut [D]) {
        self.0.generalized_forces_into(t, q, qd, out)
    }
    fn dissipative_forces_into<D: Scalar>(&self, t: D, q: &[D], qd: &[D], out: &mut [D]) {
        self.0.dissipative_forces_into(t, q, qd, out)
    }
    fn momenta_into<D: Scalar>(&self, t: D, q: &[D], qd: &[D], out: &mut [D]) {
        self.0.momenta_into(t, q, qd, out)
    }
    fn mass_matrix_into<D: Scalar>(&self, t: D, q: &[D], qd: &[D], out: &mut [D]) {
        self.0.mass_matrix_into(t, q, qd, out)
    }
    fn accelerations_into<D: Scalar>(&self, _t: D, q: &[D], qd: &[D], out: &mut [D]) -> Result<()> {
        let a = accelerations(&self.0.0, [q[0], q[1]], [qd[0], qd[1]]);
        out.copy_from_slice(&a);
        Ok(())
    }
}

/// The closed form for `ode_solvers`.
struct Ode(DoublePendulum);
impl ode_solvers::System<f64, State> for Ode {
    fn system(&self, _t: f64, y: &State, dy: &mut State) {
        let a = accelerations(&self.0, [y[0], y[1]], [y[2], y[3]]);
        dy[0] = y[2];
        dy[1] = y[3];
        dy[2] = a[0];
        dy[3] = a[1];
    }
}

fn pendulum() -> Hand {
    Hand(ClosedDoublePendulum(DoublePendulum::new(
        1.0, 1.0, 1.0, 1.0, 9.81,
    )))
}

fn y0() -> State {
    State::new(Q0[0], Q0[1], QD0[0], QD0[1])
}

/// `ode_solvers`' DOP853 to `T_END`: the final state and the evaluations.
fn ode_dop853(tol: f64) -> (State, u32) {
    let mut s =
        ode_solvers::dop853::Dop853::new(Ode(pendulum().0.0), 0.0, T_END, T_END, y0(), tol, tol);
    s.set_output(ode_solvers::OutputType::Sparse);
    let stats = s.integrate().unwrap();
    (*s.y_out().last().unwrap(), stats.num_eval)
}

/// `ode_solvers`' DOPRI5 to `T_END`: the final state and the evaluations.
fn ode_dopri5(tol: f64) -> (State, u32) {
    let mut s =
        ode_solvers::dopri5::Dopri5::new(Ode(pendulum().0.0), 0.0, T_END, T_END, y0(), tol, tol);
    s.set_output(ode_solvers::OutputType::Sparse);
    let stats = s.integrate().unwrap();
    (*s.y_out().last().unwrap(), stats.num_eval)
}

/// This crate's `method` to `T_END`, the final state kept: that state and the evaluations.
fn ours(sys: &Hand, method: Method, options: &Options) -> ([f64; 4], usize) {
    let sol = solve(sys, &Q0, &QD0, (0.0, T_END), method, options).unwrap();
    let (_, q, qd) = sol.last().unwrap();
    ([q[0], q[1], qd[0], qd[1]], sol.stats.rhs_evaluations)
}

/// RK4 written out by hand over `[f64; 4]`: `steps` steps of `T_END / steps`.
fn hand_rk4(sys: &Hand, steps: usize) -> [f64; 4] {
    let f = |y: &[f64; 4]| -> [f64; 4] {
        let a = accelerations(&sys.0.0, [y[0], y[1]], [y[2], y[3]]);
        [y[2], y[3], a[0], a[1]]
    };
    let axpy = |y: &[f64; 4], h: f64, k: &[f64; 4]| -> [f64; 4] {
        std::array::from_fn(|i| y[i] + h * k[i])
    };
    let h = T_END / steps as f64;
    let mut y = [Q0[0], Q0[1], QD0[0], QD0[1]];
    for _ in 0..steps {
        let k1 = f(&y);
        let k2 = f(&axpy(&y, 0.5 * h, &k1));
        let k3 = f(&axpy(&y, 0.5 * h, &k2));
        let k4 = f(&axpy(&y, h, &k3));
        for i in 0..4 {
            y[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
        }
    }
    y
}

/// Kepler's problem (m = μ = 1) by hand, for the splittings: T = |q̇|²/2, U = −1/|q|,
/// ∂U/∂q = q/|q|³, M = I.
struct HandKepler;

impl Dynamics for HandKepler {
    fn dof(&self) -> usize {
        2
    }
    fn structure(&self) -> Structure {
        Structure {
            dof: 2,
            time_dependent: false,
            constant_mass: true,
            separable: true,
            dissipative: false,
            forced: false,
        }
    }
    fn kinetic_energy<D: Scalar>(&self, _t: D, _q: &[D], qd: &[D]) -> D {
        (qd[0] * qd[0] + qd[1] * qd[1]) * 0.5
    }
    fn potential_energy<D: Scalar>(&self, _t: D, q: &[D]) -> D {
        -(q[0] * q[0] + q[1] * q[1]).sqrt().recip()
    }
    fn potential_gradient_into<D: Scalar>(&self, _t: D, q: &[D], out: &mut [D]) {
        let g = kepler_gradient([q[0], q[1]]);
        out.copy_from_slice(&g);
    }
    fn generalized_forces_into<D: Scalar>(&self, _t: D, _q: &[D], _qd: &[D], out: &mut [D]) {
        out.fill(D::zero());
    }
    fn dissipative_forces_into<D: Scalar>(&self, _t: D, _q: &[D], _qd: &[D], out: &mut [D]) {
        out.fill(D::zero());
    }
    fn momenta_into<D: Scalar>(&self, _t: D, _q: &[D], qd: &[D], out: &mut [D]) {
        out.copy_from_slice(qd);
    }
    fn mass_matrix_into<D: Scalar>(&self, _t: D, _q: &[D], _qd: &[D], out: &mut [D]) {
        out.copy_from_slice(&[D::one(), D::zero(), D::zero(), D::one()]);
    }
    fn accelerations_into<D: Scalar>(
        &self,
        _t: D,
        q: &[D],
        _qd: &[D],
        out: &mut [D],
    ) -> Result<()> {
        let g = kepler_gradient([q[0], q[1]]);
        out.copy_from_slice(&[-g[0], -g[1]]);
        Ok(())
    }
}

/// ∂U/∂q = q/|q|³: the force both sides of the splittings' pairs evaluate.
fn kepler_gradient<D: Scalar>(q: [D; 2]) -> [D; 2] {
    let r2 = q[0] * q[0] + q[1] * q[1];
    let s = (r2 * r2.sqrt()).recip();
    [q[0] * s, q[1] * s]
}

/// A splitting written out by hand over `[f64; 2]`: `steps` steps of `T_END / steps` of the
/// kick–drift sequence `tab` (the same coefficients as the library's, in the same order).
fn hand_splitting(tab: &SymplecticTableau, q0: [f64; 2], v0: [f64; 2], steps: usize) -> [f64; 4] {
    let h = T_END / steps as f64;
    let force = |q: &[f64; 2]| {
        let g = kepler_gradient(*q);
        [-g[0], -g[1]]
    };
    let (mut q, mut v) = (q0, v0);
    let mut acc = force(&q);
    let s = tab.a.len();
    for _ in 0..steps {
        for j in 0..s {
            let hb = h * tab.b[j];
            v = [v[0] + hb * acc[0], v[1] + hb * acc[1]];
            let ha = h * tab.a[j];
            q = [q[0] + ha * v[0], q[1] + ha * v[1]];
            acc = force(&q);
        }
        let hb = h * tab.b[s];
        v = [v[0] + hb * acc[0], v[1] + hb * acc[1]];
    }
    [q[0], q[1], v[0], v[1]]
}

/// Short measurements: the machine is shared.
fn config<'a>(
    c: &'a mut Criterion,
    name: &str,
) -> criterion::BenchmarkGroup<'a, criterion::measurement::WallTime> {
    let mut g = c.benchmark_group(name);
    g.sample_size(20)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(2));
    g
}

/// The fastest run of each side over `BLOCKS` blocks of `RUNS` runs, the sides taking turns by
/// block: on a shared machine the other load only adds time, and taking turns exposes both
/// sides to the same load (criterion's medians of one side's samples, taken seconds apart from
/// the other side's, moved by ±20 % between runs), while the runs of a block find the caches
/// and branch predictors warm as a loop's do (run by run, the larger code of a side paid for
/// the other's in between).
fn paired(mut a: impl FnMut(), mut b: impl FnMut()) -> (f64, f64) {
    const BLOCKS: usize = 60;
    const RUNS: usize = 25;
    let best = |f: &mut dyn FnMut()| {
        (0..RUNS).fold(f64::INFINITY, |best, _| {
            let start = std::time::Instant::now();
            f();
            best.min(start.elapsed().as_nanos() as f64)
        })
    };
    (0..BLOCKS).fold((f64::INFINITY, f64::INFINITY), |(ta, tb), _| {
        (ta.min(best(&mut a)), tb.min(best(&mut b)))
    })
}

fn close(a: &[f64], b: &[f64], tol: f64, what: &str) {
    for (x, y) in a.iter().zip(b) {
        assert!(
            (x - y).abs() <= tol * (1.0 + y.abs()),
            "{what}: {a:?} against {b:?}"
        );
    }
}

fn loops(c: &mut Criterion) {
    let sys = pendulum();
    closed_forms::check(
        "double pendulum",
        &sys,
        &sys.0.0.system(),
        &closed_forms::states(2, 0.0),
    );
    let mut meta = Vec::new();
    type Peer = fn(f64) -> (State, u32);
    let adaptive: [(Method, &str, Peer); 2] = [
        (Method::Dop853, "dop853", ode_dop853),
        (Method::Dopri5, "dopri5", ode_dopri5),
    ];
    for (method, name, peer) in adaptive {
        for tol in [1e-6, 1e-9] {
            let options = Options::adaptive(tol, tol).with_output(Output::Final);
            let (y_peer, n_peer) = peer(tol);
            let (y_ours, n_ours) = ours(&sys, method, &options);
            // Both sides solve the same problem: their end states agree to the tolerance's
            // scale (the pendulum's chaos amplifies the local errors over the span).
            close(&y_ours, y_peer.as_slice(), 1e3 * tol, name);
            let group = format!("loops_{name}_{tol:e}");
            let (t_peer, t_ours) = paired(
                || {
                    black_box(peer(tol));
                },
                || {
                    black_box(ours(&sys, method, &options));
                },
            );
            meta.push(format!(
                "\"{group}\": {{\"rhs\": {{\"ode_solvers\": {n_peer}, \"ours\": {n_ours}}}, \
                 \"best_ns\": {{\"ode_solvers\": {t_peer}, \"ours\": {t_ours}}}}}"
            ));
            let mut g = config(c, &group);
            g.bench_function("ode_solvers", |b| b.iter(|| black_box(peer(tol))));
            g.bench_function("ours", |b| {
                b.iter(|| black_box(ours(&sys, method, &options)))
            });
            g.finish();
        }
    }
    let steps = 1000;
    let options = Options::fixed(T_END / steps as f64).with_output(Output::Final);
    let (y_ours, n_ours) = ours(&sys, Method::Rk4, &options);
    close(&y_ours, &hand_rk4(&sys, steps), 1e-12, "rk4");
    let (t_hand, t_ours) = paired(
        || {
            black_box(hand_rk4(&sys, steps));
        },
        || {
            black_box(ours(&sys, Method::Rk4, &options));
        },
    );
    meta.push(format!(
        "\"loops_rk4\": {{\"rhs\": {{\"hand\": {}, \"ours\": {n_ours}}}, \
         \"best_ns\": {{\"hand\": {t_hand}, \"ours\": {t_ours}}}}}",
        4 * steps
    ));
    let mut g = config(c, "loops_rk4");
    g.bench_function("hand", |b| b.iter(|| black_box(hand_rk4(&sys, steps))));
    g.bench_function("ours", |b| {
        b.iter(|| black_box(ours(&sys, Method::Rk4, &options)))
    });
    g.finish();
    let kepler = HandKepler;
    closed_forms::check(
        "Kepler",
        &kepler,
        &Kepler::new(1.0, 1.0).system(),
        &closed_forms::states(2, 2.0),
    );
    let (q0, v0) = Kepler::new(1.0, 1.0).periapsis_state(1.0, 0.5).unwrap();
    let splittings = [
        (Method::StormerVerlet, SymplecticTableau::stormer_verlet()),
        (Method::Yoshida4, SymplecticTableau::yoshida4()),
    ];
    for (method, tab) in &splittings {
        let method = *method;
        let run = |options: &Options| {
            let sol = solve(&kepler, &q0, &v0, (0.0, T_END), method, options).unwrap();
            let (_, q, qd) = sol.last().unwrap();
            ([q[0], q[1], qd[0], qd[1]], sol.stats.rhs_evaluations)
        };
        let (y_ours, n_ours) = run(&options);
        close(
            &y_ours,
            &hand_splitting(tab, q0, v0, steps),
            1e-12,
            tab.name,
        );
        let group = format!("loops_{}", tab.name);
        let (t_hand, t_ours) = paired(
            || {
                black_box(hand_splitting(tab, q0, v0, steps));
            },
            || {
                black_box(run(&options));
            },
        );
        meta.push(format!(
            "\"{group}\": {{\"rhs\": {{\"hand\": {}, \"ours\": {n_ours}}}, \
             \"best_ns\": {{\"hand\": {t_hand}, \"ours\": {t_ours}}}}}",
            1 + (tab.b.len() - 1) * steps
        ));
        let mut g = config(c, &group);
        g.bench_function("hand", |b| {
            b.iter(|| black_box(hand_splitting(tab, q0, v0, steps)))
        });
        g.bench_function("ours", |b| b.iter(|| black_box(run(&options))));
        g.finish();
    }
    let dir = std::env::var("CARGO_TARGET_DIR").unwrap_or_else(|_| "target".into());
    let path = std::path::Path::new(&dir)
        .join("criterion")
        .join("loops_meta.json");
    let _ = std::fs::create_dir_all(path.parent().unwrap());
    let _ = std::fs::write(&path, format!("{{{}}}\n", meta.join(", ")));
}

criterion_group!(benches, loops);
criterion_main!(benches);
