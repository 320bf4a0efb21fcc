//! Issue 41's speed target "a chain stated in Cartesian coordinates with constraints against the
//! same chain in minimal coordinates: ≤ 2× per unit of simulated time at equal error".
//!
//! The N-link planar pendulum (N = 2, 4, 8; unit masses and lengths, g = 9.81), released from
//! rest with every angle 0.5 rad, stated twice:
//!
//! - **minimal**: the angles, the crate's [`NPendulum`] scene (T from the bobs' velocities as
//!   running sums, so M depends on q);
//! - **cartesian**: the bobs' 2N coordinates, T = ½ Σ m |ẋᵢ|² (constant M), U = Σ m g yᵢ, and N
//!   holonomic rows |xᵢ − xᵢ₋₁|² − l² = 0 (x₀ the pivot) through [`Constraints`] and
//!   [`Constrained::new`]: index-1 q̈ and λ at every evaluation, each accepted step projected
//!   back onto the rows.
//!
//! Equal error: the reference end state at t = 5 is DOP853 at rtol = atol = 1e-13 in minimal
//! coordinates; for each formulation the loosest DOP853 tolerance of the grid 10^{-k/4} whose
//! end-position error (the largest distance of a bob from its reference position) stays at most
//! 1e-7 — it and every tighter tolerance of the grid — is found once, before timing. Then:
//!
//! - `cartesian_chain/{minimal,cartesian}/N`: one run to t = 5 at that tolerance;
//! - `cartesian_chain_rhs/{minimal,cartesian,cartesian_free,jacobian,gamma,mass_matrix}/N`: one
//!   evaluation at the initial state of the minimal q̈, the constrained q̈, and the parts of the
//!   latter that the public API shows (the unconstrained q̈₀ with its cached constant M, the
//!   constraints' Jacobian G, γ, and M = ∂²T/∂q̇², which `Constrained` factors once when it is
//!   constant and before did at every evaluation).
//!
//! The tolerances, errors and evaluation counts go to `cartesian_chain_meta.json` beside
//! criterion's estimates; `python3 benches/cartesian_chain.py` runs the bench (or, with
//! `--no-run`, reads a finished one) and prints the table of docs/site/integrators.rst.

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use lagrangian::integrators::{Method, Options, Output, Statistics, solve};
use lagrangian::scenes::NPendulum;
use lagrangian::{Constrained, Constraints, Dynamics, KineticEnergy, Potential, Scalar, System};
use std::hint::black_box;
use std::time::Duration;

const G: f64 = 9.81;
/// The simulated time of a timed run.
const T_END: f64 = 5.0;
/// The initial angle of every link, from the downward vertical.
const THETA0: f64 = 0.5;
/// The end-position error the tolerances are chosen for.
const TARGET: f64 = 1e-7;
/// The reference run's tolerance.
const REFERENCE_TOL: f64 = 1e-13;
/// The tolerance grid 10^{-k/4}, loosest first: 1e-4 … 1e-12.
const GRID: std::ops::RangeInclusive<i32> = 16..=48;

/// N unit point masses in the plane, coordinates (x₁, y₁, …, x_N, y_N): T = ½ m Σ |ẋᵢ|², a
/// constant mass matrix, and gravity U = m g Σ yᵢ.
struct Bobs {
    m: f64,
}

impl KineticEnergy for Bobs {
    fn kinetic<D: Scalar>(&self, _t: D, _q: &[D], qd: &[D]) -> D {
        qd.iter().fold(D::zero(), |s, &v| s + v * v) * (0.5 * self.m)
    }
    fn depends_on_time(&self) -> bool {
        false
    }
    fn depends_on_position(&self) -> bool {
        false
    }
    fn constant_mass_matrix(&self) -> bool {
        true
    }
}

impl Potential for Bobs {
    fn potential<D: Scalar>(&self, _t: D, q: &[D]) -> D {
        q.iter().skip(1).step_by(2).fold(D::zero(), |s, &y| s + y) * (self.m * G)
    }
    fn depends_on_time(&self) -> bool {
        false
    }
}

/// The chain's rods: row i is |xᵢ − xᵢ₋₁|² − l² = 0, x₀ the pivot at the origin.
struct Rods {
    n: usize,
    l: f64,
}

impl Constraints for Rods {
    fn holonomic_count(&self) -> usize {
        self.n
    }
    fn holonomic<D: Scalar>(&self, _t: D, q: &[D], out: &mut [D]) {
        let (mut px, mut py) = (D::zero(), D::zero());
        for (i, o) in out.iter_mut().enumerate() {
            let (x, y) = (q[2 * i], q[2 * i + 1]);
            let (dx, dy) = (x - px, y - py);
            *o = dx * dx + dy * dy - self.l * self.l;
            (px, py) = (x, y);
        }
    }
    fn depends_on_time(&self) -> bool {
        false
    }
    fn name(&self, row: usize) -> String {
        format!("rod {}", row + 1)
    }
}

type Cartesian = Constrained<System<Bobs, Bobs>, Rods>;

fn cartesian(n: usize) -> Cartesian {
    let bobs = System::new(2 * n, Bobs { m: 1.0 }).with_potential(Bobs { m: 1.0 });
    Constrained::new(bobs, Rods { n, l: 1.0 })
}

/// The bobs' positions (x₁, y₁, …) of the chain at angles `th`, and their velocities at
/// angular velocities `w`.
fn bobs_of_angles(th: &[f64], w: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let (mut x, mut y, mut vx, mut vy) = (0.0, 0.0, 0.0, 0.0);
    let (mut q, mut qd) = (Vec::new(), Vec::new());
    for (&a, &wa) in th.iter().zip(w) {
        let (s, c) = a.sin_cos();
        x += s;
        y -= c;
        vx += c * wa;
        vy += s * wa;
        q.extend([x, y]);
        qd.extend([vx, vy]);
    }
    (q, qd)
}

/// The largest distance of a bob from its place in `reference` (both as (x₁, y₁, …)).
fn position_error(q: &[f64], reference: &[f64]) -> f64 {
    q.chunks(2)
        .zip(reference.chunks(2))
        .map(|(a, b)| (a[0] - b[0]).hypot(a[1] - b[1]))
        .fold(0.0, f64::max)
}

/// One DOP853 run to `T_END` at rtol = atol = `tol`, keeping only the final state.
fn run<S: Dynamics>(sys: &S, q0: &[f64], qd0: &[f64], tol: f64) -> (Vec<f64>, Statistics) {
    let opts = Options::adaptive(tol, tol).with_output(Output::Final);
    let sol = solve(sys, q0, qd0, (0.0, T_END), Method::Dop853, &opts).unwrap();
    (sol.last().unwrap().1.to_vec(), sol.stats)
}

/// The loosest tolerance of the grid whose end-position error (by `error` of the end q) is at
/// most `TARGET`, it and every tighter one: (tolerance, error, statistics).
fn calibrate(
    mut end: impl FnMut(f64) -> (Vec<f64>, Statistics),
    error: impl Fn(&[f64]) -> f64,
) -> (f64, f64, Statistics) {
    let mut best = None;
    for k in GRID.rev() {
        let tol = 10f64.powf(-f64::from(k) / 4.0);
        let (q, stats) = end(tol);
        let e = error(&q);
        if e > TARGET {
            break;
        }
        best = Some((tol, e, stats));
    }
    best.expect("the tightest tolerance of the grid meets the target error")
}

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

fn stats_json(s: &Statistics) -> String {
    format!(
        "{{\"accepted_steps\": {}, \"rejected_steps\": {}, \"rhs_evaluations\": {}, \
         \"projections\": {}, \"constraint_residual\": {:e}}}",
        s.accepted_steps, s.rejected_steps, s.rhs_evaluations, s.projections, s.constraint_residual
    )
}

fn chains(c: &mut Criterion) {
    let mut meta = Vec::new();
    let mut g = config(c, "cartesian_chain");
    for n in [2, 4, 8] {
        let minimal = NPendulum::uniform(n, 1.0, 1.0, G).system();
        let cart = cartesian(n);
        let th0 = vec![THETA0; n];
        let w0 = vec![0.0; n];
        let (x0, v0) = bobs_of_angles(&th0, &w0);
        cart.check_consistent(0.0, &x0, &v0, None)
            .expect("the Cartesian initial state lies on the rods");

        let (th_ref, _) = run(&minimal, &th0, &w0, REFERENCE_TOL);
        let (x_ref, _) = bobs_of_angles(&th_ref, &w0);
        // The reference's own error, estimated against a run ten times looser.
        let (th_loose, _) = run(&minimal, &th0, &w0, 10.0 * REFERENCE_TOL);
        let reference_error = position_error(&bobs_of_angles(&th_loose, &w0).0, &x_ref);

        let (tol_min, err_min, st_min) = calibrate(
            |tol| run(&minimal, &th0, &w0, tol),
            |th| position_error(&bobs_of_angles(th, &w0).0, &x_ref),
        );
        let (tol_cart, err_cart, st_cart) = calibrate(
            |tol| run(&cart, &x0, &v0, tol),
            |x| position_error(x, &x_ref),
        );
        eprintln!(
            "N = {n}: minimal rtol {tol_min:.1e} (error {err_min:.1e}, {} evaluations); \
             cartesian rtol {tol_cart:.1e} (error {err_cart:.1e}, {} evaluations, {} \
             projections); reference error ~{reference_error:.0e}",
            st_min.rhs_evaluations, st_cart.rhs_evaluations, st_cart.projections
        );
        meta.push(format!(
            "\"{n}\": {{\"t_end\": {T_END}, \"reference_error\": {reference_error:e}, \
             \"minimal\": {{\"rtol\": {tol_min:e}, \"error\": {err_min:e}, \"stats\": {}}}, \
             \"cartesian\": {{\"rtol\": {tol_cart:e}, \"error\": {err_cart:e}, \"stats\": {}}}}}",
            stats_json(&st_min),
            stats_json(&st_cart)
        ));

        g.bench_with_input(BenchmarkId::new("minimal", n), &n, |b, _| {
            b.iter(|| black_box(run(&minimal, &th0, &w0, tol_min)))
        });
        g.bench_with_input(BenchmarkId::new("cartesian", n), &n, |b, _| {
            b.iter(|| black_box(run(&cart, &x0, &v0, tol_cart)))
        });
    }
    g.finish();
    let dir = std::env::var("CARGO_TARGET_DIR").unwrap_or_else(|_| "../target".into());
    let path = std::path::Path::new(&dir)
        .join("criterion")
        .join("cartesian_chain_meta.json");
    let _ = std::fs::write(&path, format!("{{{}}}\n", meta.join(", ")));
}

/// One evaluation of each right-hand side and of the constrained one's parts, at the initial
/// state moved a little (so no velocity is zero).
fn evaluations(c: &mut Criterion) {
    let mut g = config(c, "cartesian_chain_rhs");
    for n in [2, 4, 8] {
        let minimal = NPendulum::uniform(n, 1.0, 1.0, G).system();
        let cart = cartesian(n);
        let th: Vec<f64> = (0..n).map(|i| THETA0 + 0.1 * i as f64).collect();
        let w: Vec<f64> = (0..n).map(|i| 0.3 - 0.2 * i as f64).collect();
        let (x, v) = bobs_of_angles(&th, &w);
        let (mut a_min, mut a_cart) = (vec![0.0; n], vec![0.0; 2 * n]);
        g.bench_with_input(BenchmarkId::new("minimal", n), &n, |b, _| {
            b.iter(|| minimal.accelerations_into(0.0, &th, &w, &mut a_min))
        });
        g.bench_with_input(BenchmarkId::new("cartesian", n), &n, |b, _| {
            b.iter(|| cart.accelerations_into(0.0, &x, &v, &mut a_cart))
        });
        g.bench_with_input(BenchmarkId::new("cartesian_free", n), &n, |b, _| {
            b.iter(|| cart.system().accelerations_into(0.0, &x, &v, &mut a_cart))
        });
        g.bench_with_input(BenchmarkId::new("jacobian", n), &n, |b, _| {
            b.iter(|| cart.constraint_jacobian(0.0, &x, &v))
        });
        g.bench_with_input(BenchmarkId::new("gamma", n), &n, |b, _| {
            b.iter(|| cart.gamma(0.0, &x, &v))
        });
        let mut m = vec![0.0; 4 * n * n];
        g.bench_with_input(BenchmarkId::new("mass_matrix", n), &n, |b, _| {
            b.iter(|| cart.mass_matrix_into(0.0, &x, &v, &mut m))
        });
    }
    g.finish();
}

criterion_group!(benches, chains, evaluations);
criterion_main!(benches);
