//! Cost of the integrators on the AD-derived equations of motion against the same method on a
//! hand-written closed form, and against the `ode_solvers` crate's DOP853 on that closed form.
//!
//! Groups:
//! - `step_double_pendulum/{ad,closed}_<method>`: 100 fixed steps of every method that fits
//!   the double pendulum (the explicit splittings need a separable system), plus
//!   `ode_solvers_dop853` held at the same step;
//! - `step_n_pendulum/{ad,closed}_<method>/N` for N = 2, 4, 8, 16, 32, and
//!   `step_n_pendulum/ode_solvers_dop853/N`;
//! - `error_1e-8_double_pendulum/{ad,closed}_<method>`: the adaptive methods at the loosest
//!   tolerance (of 10^{-k/2}) whose error at t = 10 is below 1e-8, and `ode_solvers_dop853`.
//!
//! `python3 benches/ratios.py integrators` prints the tables of docs/site/integrators.rst from
//! criterion's estimates and from `integrators_meta.json`, which this bench writes next to them.

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use lagrangian::Dynamics;
use lagrangian::integrators::{Method, Options, Output, solve};
use lagrangian::scenes::{DoublePendulum, NPendulum};

// Only the double pendulum and the chain (and their check) are used here.
#[allow(dead_code)]
mod closed_forms;
use closed_forms::{ClosedDoublePendulum, ClosedNPendulum};
use std::hint::black_box;
use std::time::Duration;

/// Every method that fits a non-separable system.
const METHODS: [Method; 7] = [
    Method::Rk4,
    Method::Dopri5,
    Method::Dop853,
    Method::Midpoint,
    Method::Gauss4,
    Method::Gauss6,
    Method::Radau5,
];

/// Steps per timed run of the per-step benches.
const STEPS: usize = 100;

// ---------------------------------------------------------------------------------------------
// The same closed forms for `ode_solvers`

type State4 = ode_solvers::Vector4<f64>;
type StateN = ode_solvers::DVector<f64>;

struct OdeDoublePendulum(DoublePendulum);
impl ode_solvers::System<f64, State4> for OdeDoublePendulum {
    fn system(&self, _t: f64, y: &State4, dy: &mut State4) {
        let a = self
            .0
            .closed_form_accelerations(&[y[0], y[1]], &[y[2], y[3]]);
        dy[0] = y[2];
        dy[1] = y[3];
        dy[2] = a[0];
        dy[3] = a[1];
    }
}

struct OdeNPendulum(ClosedNPendulum);
impl ode_solvers::System<f64, StateN> for OdeNPendulum {
    fn system(&self, _t: f64, y: &StateN, dy: &mut StateN) {
        let n = y.len() / 2;
        let (q, v) = y.as_slice().split_at(n);
        let (dq, dv) = dy.as_mut_slice().split_at_mut(n);
        dq.copy_from_slice(v);
        self.0.accelerations_into(0.0, q, v, dv).unwrap();
    }
}

/// ode_solvers' DOP853 over `STEPS` steps of `dt` from `y0`: initial and largest step `dt`,
/// tolerances far looser than its error, so it takes the same steps as the fixed-step runs.
/// Output `Sparse` (the state after every step; `Dense` would add three evaluations per step).
/// Returns the steps taken.
macro_rules! ode_fixed {
    ($f:expr, $y0:expr, $dt:expr) => {{
        let span = $dt * STEPS as f64;
        let mut s = ode_solvers::dop853::Dop853::from_param(
            $f,
            0.0,
            span,
            span,
            $y0,
            1e-2,
            1e-2,
            0.9,
            0.0,
            0.333,
            6.0,
            $dt,
            $dt,
            1_000_000,
            1000,
            ode_solvers::OutputType::Sparse,
        );
        s.integrate().unwrap().accepted_steps
    }};
}

// ---------------------------------------------------------------------------------------------
// Benches

/// Short measurements: the full run takes a few minutes.
fn config<'a>(
    c: &'a mut Criterion,
    name: &str,
) -> criterion::BenchmarkGroup<'a, criterion::measurement::WallTime> {
    let mut g = c.benchmark_group(name);
    g.sample_size(10)
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_millis(1500));
    g
}

/// `STEPS` fixed steps of `method`; the number of steps taken.
fn run_steps<S: Dynamics>(sys: &S, q0: &[f64], qd0: &[f64], method: Method, dt: f64) -> usize {
    let opts = Options::fixed(dt).with_output(Output::Every(usize::MAX));
    let sol = solve(sys, q0, qd0, (0.0, dt * STEPS as f64), method, &opts).unwrap();
    black_box(sol.last().unwrap().1[0]);
    sol.stats.accepted_steps
}

fn step_double_pendulum(c: &mut Criterion) {
    let dp = DoublePendulum::new(1.0, 1.0, 1.0, 1.0, 9.81);
    let ad = dp.system();
    let closed = ClosedDoublePendulum(dp);
    closed_forms::check(
        "double pendulum",
        &closed,
        &ad,
        &closed_forms::states(2, 0.0),
    );
    let (q0, qd0) = ([0.7, -0.4], [0.3, 1.2]);
    let dt = 0.01;
    let mut g = config(c, "step_double_pendulum");
    for method in METHODS {
        g.bench_function(format!("ad_{method}"), |b| {
            b.iter(|| run_steps(&ad, &q0, &qd0, method, dt))
        });
        g.bench_function(format!("closed_{method}"), |b| {
            b.iter(|| run_steps(&closed, &q0, &qd0, method, dt))
        });
    }
    let y0 = State4::new(q0[0], q0[1], qd0[0], qd0[1]);
    assert_eq!(ode_fixed!(OdeDoublePendulum(dp), y0, dt) as usize, STEPS);
    g.bench_function("ode_solvers_dop853", |b| {
        b.iter(|| ode_fixed!(OdeDoublePendulum(dp), y0, dt))
    });
    g.finish();
}

fn step_n_pendulum(c: &mut Criterion) {
    let mut g = config(c, "step_n_pendulum");
    for n in [2, 4, 8, 16, 32] {
        let chain = NPendulum::uniform(n, 1.0, 1.0, 9.81);
        let ad = chain.clone().system();
        let closed = ClosedNPendulum::new(chain.clone());
        closed_forms::check("N-pendulum", &closed, &ad, &closed_forms::states(n, 0.0));
        let q0: Vec<f64> = (0..n).map(|i| 0.5 * (i as f64 * 0.7).sin()).collect();
        let qd0: Vec<f64> = (0..n).map(|i| 0.3 * (i as f64 * 1.3).cos()).collect();
        let dt = 0.002;
        for method in METHODS {
            g.bench_with_input(BenchmarkId::new(format!("ad_{method}"), n), &n, |b, _| {
                b.iter(|| run_steps(&ad, &q0, &qd0, method, dt))
            });
            g.bench_with_input(
                BenchmarkId::new(format!("closed_{method}"), n),
                &n,
                |b, _| b.iter(|| run_steps(&closed, &q0, &qd0, method, dt)),
            );
        }
        let y0 = StateN::from_iterator(2 * n, q0.iter().chain(&qd0).copied());
        g.bench_with_input(BenchmarkId::new("ode_solvers_dop853", n), &n, |b, _| {
            b.iter(|| {
                ode_fixed!(
                    OdeNPendulum(ClosedNPendulum::new(chain.clone())),
                    y0.clone(),
                    dt
                )
            })
        });
    }
    g.finish();
}

/// The adaptive methods at the loosest tolerance 10^{-k/2} whose error at t = 10 on the double
/// pendulum is below 1e-8 (against DOP853 at 1e-14), chosen before timing.
fn error_double_pendulum(c: &mut Criterion) {
    let dp = DoublePendulum::new(1.0, 1.0, 1.0, 1.0, 9.81);
    let ad = dp.system();
    let closed = ClosedDoublePendulum(dp);
    let (q0, qd0) = ([0.4, 0.3], [0.0, 0.0]);
    let span = (0.0, 10.0);
    let end = |sys: &dyn Fn(&Options) -> Vec<f64>, tol: f64| {
        sys(&Options::adaptive(tol, tol).with_output(Output::Every(usize::MAX)))
    };
    let ad_ref = &ad;
    let solve_ad = |method: Method| {
        move |o: &Options| {
            let sol = solve(ad_ref, &q0, &qd0, span, method, o).unwrap();
            let (_, q, qd) = sol.last().unwrap();
            vec![q[0], q[1], qd[0], qd[1], sol.stats.accepted_steps as f64]
        }
    };
    let reference = end(&solve_ad(Method::Dop853), 1e-14);
    let err = |y: &[f64]| (0..4).fold(0.0_f64, |m, i| m.max((y[i] - reference[i]).abs()));
    let tolerances: Vec<f64> = (8..=28).map(|k| 10f64.powf(-k as f64 / 2.0)).collect();
    let mut meta = Vec::new();
    let mut g = config(c, "error_1e-8_double_pendulum");
    for method in [Method::Dopri5, Method::Dop853, Method::Radau5] {
        let run = solve_ad(method);
        let Some((tol, y)) = tolerances
            .iter()
            .map(|&tol| (tol, end(&run, tol)))
            .find(|(_, y)| err(y) < 1e-8)
        else {
            continue;
        };
        meta.push(format!(
            "\"{method}\": {{\"tol\": {tol:e}, \"steps\": {}, \"error\": {:e}}}",
            y[4],
            err(&y)
        ));
        let opts = Options::adaptive(tol, tol).with_output(Output::Every(usize::MAX));
        g.bench_function(format!("ad_{method}"), |b| {
            b.iter(|| {
                solve(&ad, &q0, &qd0, span, method, &opts)
                    .unwrap()
                    .stats
                    .accepted_steps
            })
        });
        g.bench_function(format!("closed_{method}"), |b| {
            b.iter(|| {
                solve(&closed, &q0, &qd0, span, method, &opts)
                    .unwrap()
                    .stats
                    .accepted_steps
            })
        });
    }
    // ode_solvers' DOP853 on the closed form, at its own loosest tolerance meeting 1e-8.
    let y0 = State4::new(q0[0], q0[1], qd0[0], qd0[1]);
    let ode = |tol: f64| {
        let mut s =
            ode_solvers::dop853::Dop853::new(OdeDoublePendulum(dp), 0.0, 10.0, 10.0, y0, tol, tol);
        // Sparse: the state after every step, no dense-output stages (Dense would add three
        // evaluations per step).
        s.set_output(ode_solvers::OutputType::Sparse);
        let stats = s.integrate().unwrap();
        let y = *s.y_out().last().unwrap();
        (vec![y[0], y[1], y[2], y[3]], stats.accepted_steps)
    };
    if let Some((tol, (y, steps))) = tolerances
        .iter()
        .map(|&t| (t, ode(t)))
        .find(|(_, (y, _))| err(y) < 1e-8)
    {
        meta.push(format!(
            "\"ode_solvers_dop853\": {{\"tol\": {tol:e}, \"steps\": {steps}, \"error\": {:e}}}",
            err(&y)
        ));
        g.bench_function("ode_solvers_dop853", |b| b.iter(|| ode(tol).1));
    }
    g.finish();
    let dir = std::env::var("CARGO_TARGET_DIR").unwrap_or_else(|_| "target".into());
    let path = std::path::Path::new(&dir)
        .join("criterion")
        .join("integrators_meta.json");
    let _ = std::fs::create_dir_all(path.parent().unwrap());
    let _ = std::fs::write(&path, format!("{{{}}}\n", meta.join(", ")));
}

criterion_group!(
    benches,
    step_double_pendulum,
    step_n_pendulum,
    error_double_pendulum
);
criterion_main!(benches);
