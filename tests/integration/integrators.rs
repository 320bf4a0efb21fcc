//! Integrators: observed orders of convergence, order conditions of the tableaux, long-time
//! energy behaviour of the symplectic methods, time reversibility, tolerance proportionality,
//! dense output and backward integration (method choice and the typed failures:
//! `integrator_refusals.rs`). The problems here are shared with that file.

use approx::assert_relative_eq;
use lagrangian::integrators::{
    Method, Options, Output, Solution, SymplecticTableau, Tableau, solve,
};
use lagrangian::scenes::{DampedOscillator, DoublePendulum, ForcedTwoMass, Kepler, NPendulum};
use lagrangian::{Dynamics, GeneralizedForces, Potential, Scalar, System};
use std::f64::consts::PI;

// ---------------------------------------------------------------------------------------------
// Problems

/// The harmonic oscillator q̈ = −4q (ω = 2), the undamped case of the scene.
pub(crate) fn oscillator() -> DampedOscillator {
    DampedOscillator::new(1.0, 4.0, 0.0)
}

/// Kepler's problem with m = μ = a = 1 (period 2π), from periapsis.
pub(crate) fn kepler(e: f64) -> (System<Kepler, Kepler>, [f64; 2], [f64; 2]) {
    let k = Kepler::new(1.0, 1.0);
    let (q0, qd0) = k.periapsis_state(1.0, e).unwrap();
    (k.system(), q0, qd0)
}

/// The exact Kepler orbit (μ = a = 1) at time t after periapsis, as (x, y, ẋ, ẏ).
fn kepler_exact(e: f64, t: f64) -> [f64; 4] {
    let (q, qd) = Kepler::new(1.0, 1.0).exact_state(1.0, e, t).unwrap();
    [q[0], q[1], qd[0], qd[1]]
}

/// U = −q⁴/2: q̈ = 2q³, and from (1, 1) the exact q = 1/(1 − t) blows up at t = 1.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Quartic;
impl Potential for Quartic {
    fn potential<D: Scalar>(&self, _t: D, q: &[D]) -> D {
        -q[0].powi(4) * 0.5
    }
    fn depends_on_time(&self) -> bool {
        false
    }
}

/// U = ⅔ q^{3/2}: q̈ = −√q, defined only for q ≥ 0 (NaN beyond, as a model would give).
#[derive(Debug, Clone, Copy)]
pub(crate) struct SqrtWell;
impl Potential for SqrtWell {
    fn potential<D: Scalar>(&self, _t: D, q: &[D]) -> D {
        q[0].powf(1.5) * (2.0 / 3.0)
    }
    fn depends_on_time(&self) -> bool {
        false
    }
}

/// Air drag Q″ = −c q̇|q̇|: a velocity-dependent generalized force.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Drag(pub(crate) f64);
impl GeneralizedForces for Drag {
    fn forces<D: Scalar>(&self, _t: D, _q: &[D], qd: &[D], out: &mut [D]) {
        out[0] -= qd[0] * qd[0].abs() * self.0;
    }
    fn depends_on_time(&self) -> bool {
        false
    }
}

fn row(sol: &Solution, i: usize) -> Vec<f64> {
    sol.q_at(i).iter().chain(sol.qd_at(i)).copied().collect()
}

pub(crate) fn final_state(sol: &Solution) -> Vec<f64> {
    row(sol, sol.len() - 1)
}

pub(crate) fn max_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

pub(crate) const SYMPLECTIC: [Method; 5] = [
    Method::StormerVerlet,
    Method::Yoshida4,
    Method::Yoshida6,
    Method::Yoshida8,
    Method::BlanesMoan4,
];

// ---------------------------------------------------------------------------------------------
// Orders of convergence

/// Least-squares slope of ln(error) against ln(steps) over N = base · 2^{k/2}, k = 0..4 (a
/// factor 4 in step size).
fn observed_order(base: usize, error: impl Fn(usize) -> f64) -> f64 {
    observed_order_over(base, 5, error)
}

/// The same over `runs` step counts N = base · 2^{k/2}, k < runs.
pub(crate) fn observed_order_over(base: usize, runs: usize, error: impl Fn(usize) -> f64) -> f64 {
    let pts: Vec<(f64, f64)> = (0..runs)
        .map(|k| {
            let n = (base as f64 * 2f64.powf(k as f64 / 2.0)).round() as usize;
            ((n as f64).ln(), error(n).ln())
        })
        .collect();
    let count = runs as f64;
    let mx = pts.iter().map(|p| p.0).sum::<f64>() / count;
    let my = pts.iter().map(|p| p.1).sum::<f64>() / count;
    let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let sxx: f64 = pts.iter().map(|p| (p.0 - mx) * (p.0 - mx)).sum();
    -sxy / sxx
}

/// Error at t = 2π (one period) of the e = 0.6 orbit with `steps` fixed steps.
fn kepler_error(method: Method, steps: usize) -> f64 {
    let e = 0.6;
    let (sys, q0, qd0) = kepler(e);
    let opts = Options::fixed(2.0 * PI / steps as f64).with_output(Output::Every(usize::MAX));
    let sol = solve(&sys, &q0, &qd0, (0.0, 2.0 * PI), method, &opts).unwrap();
    max_diff(&final_state(&sol), &kepler_exact(e, 2.0 * PI))
}

/// Error at t = 10 of the oscillator (ω = 2) from (1, 0.5) with `steps` fixed steps.
fn oscillator_error(method: Method, steps: usize) -> f64 {
    let osc = oscillator();
    let opts = Options::fixed(10.0 / steps as f64).with_output(Output::Every(usize::MAX));
    let sol = solve(&osc.system(), &[1.0], &[0.5], (0.0, 10.0), method, &opts).unwrap();
    let (q, v) = osc.exact_solution(1.0, 0.5, 10.0).unwrap();
    max_diff(&final_state(&sol), &[q, v])
}

/// (method, first N for Kepler, first N for the oscillator): chosen in each method's
/// asymptotic range, with errors well above round-off.
const ORDER_RUNS: [(Method, usize, usize); 8] = [
    (Method::Rk4, 400, 200),
    (Method::Dopri5, 200, 200),
    (Method::Dop853, 100, 40),
    (Method::StormerVerlet, 400, 400),
    (Method::Yoshida4, 400, 200),
    (Method::Yoshida6, 200, 100),
    (Method::Yoshida8, 200, 80),
    (Method::BlanesMoan4, 400, 200),
];

#[test]
fn order_kepler_all_methods() {
    for (method, base, _) in ORDER_RUNS {
        let p = observed_order(base, |n| kepler_error(method, n));
        let nominal = method.order().unwrap() as f64;
        assert!(
            (p - nominal).abs() <= 0.3,
            "{method}: observed order {p:.2}, nominal {nominal}"
        );
    }
}

#[test]
fn order_oscillator_all_methods() {
    for (method, _, base) in ORDER_RUNS {
        let p = observed_order(base, |n| oscillator_error(method, n));
        let nominal = method.order().unwrap() as f64;
        assert!(
            (p - nominal).abs() <= 0.3,
            "{method}: observed order {p:.2}, nominal {nominal}"
        );
    }
}

// ---------------------------------------------------------------------------------------------
// Order conditions of the tableaux (Butcher trees)

/// Rooted trees up to order `max`: each tree is the sorted list of its subtrees' indices.
fn trees(max: usize) -> (Vec<Vec<usize>>, Vec<usize>) {
    let mut children: Vec<Vec<usize>> = vec![vec![]];
    let mut order = vec![1];
    for n in 2..=max {
        // Non-decreasing sequences of existing trees whose orders sum to n − 1.
        let existing = children.len();
        let mut stack: Vec<(Vec<usize>, usize, usize)> = vec![(vec![], 0, n - 1)];
        while let Some((seq, from, left)) = stack.pop() {
            if left == 0 {
                children.push(seq);
                order.push(n);
                continue;
            }
            for i in from..existing {
                if order[i] <= left {
                    let mut s = seq.clone();
                    s.push(i);
                    stack.push((s, i, left - order[i]));
                }
            }
        }
    }
    (children, order)
}

/// Whether weights `b` with matrix `a` satisfy every order condition up to `p`
/// (Σ bᵢ Φᵢ(τ) = 1/γ(τ)), within `tol`.
fn satisfies(a: &[Vec<f64>], b: &[f64], p: usize, tol: f64) -> bool {
    let s = b.len();
    let (kids, order) = trees(p);
    let mut phi: Vec<Vec<f64>> = Vec::new(); // Φ_i(τ) per stage
    let mut gamma: Vec<f64> = Vec::new();
    let aij = |i: usize, j: usize| if j < a[i].len() { a[i][j] } else { 0.0 };
    for t in 0..kids.len() {
        let mut g = order[t] as f64;
        let mut v = vec![1.0; s];
        for &k in &kids[t] {
            g *= gamma[k];
            for i in 0..s {
                let inner: f64 = (0..s).map(|j| aij(i, j) * phi[k][j]).sum();
                v[i] *= inner;
            }
        }
        let lhs: f64 = (0..s).map(|i| b[i] * v[i]).sum();
        if (lhs - 1.0 / g).abs() > tol {
            return false;
        }
        phi.push(v);
        gamma.push(g);
    }
    true
}

#[test]
fn trees_count_matches_oeis() {
    let (_, order) = trees(9);
    let count = |n| order.iter().filter(|&&o| o == n).count();
    let counts: Vec<usize> = (1..=9).map(count).collect();
    assert_eq!(counts, [1, 1, 2, 4, 9, 20, 48, 115, 286]);
}

#[test]
fn tableau_order_conditions_runge_kutta() {
    for (tab, p) in [
        (Tableau::rk4(), 4),
        (Tableau::dopri5(), 5),
        (Tableau::dop853(), 8),
    ] {
        assert_eq!(tab.order, p);
        assert!(
            satisfies(&tab.a, &tab.b, p, 1e-13),
            "{} fails order {p}",
            tab.name
        );
        assert!(
            !satisfies(&tab.a, &tab.b, p + 1, 1e-13),
            "{} is of order {}",
            tab.name,
            p + 1
        );
    }
    // The embedded solutions: b̂ = b − e.
    let d5 = Tableau::dopri5();
    let Some(lagrangian::integrators::ErrorEstimate::Embedded { e, order }) = &d5.error else {
        panic!("dopri5 has an embedded pair")
    };
    let bhat: Vec<f64> = d5.b.iter().zip(e).map(|(b, e)| b - e).collect();
    assert!(satisfies(&d5.a, &bhat, *order, 1e-13));
    assert!(!satisfies(&d5.a, &bhat, order + 1, 1e-13));
    let d8 = Tableau::dop853();
    let Some(lagrangian::integrators::ErrorEstimate::Dop853 { e5, e3 }) = &d8.error else {
        panic!("dop853 has Hairer's estimator")
    };
    let b5: Vec<f64> = d8.b.iter().zip(e5).map(|(b, e)| b - e).collect();
    let b3: Vec<f64> = d8.b.iter().zip(e3).map(|(b, e)| b - e).collect();
    assert!(satisfies(&d8.a, &b5, 5, 1e-13));
    assert!(satisfies(&d8.a, &b3, 3, 1e-13));
}

#[test]
fn symplectic_tableaux_consistent_and_symmetric() {
    for (tab, order, stages) in [
        (SymplecticTableau::stormer_verlet(), 2, 1),
        (SymplecticTableau::yoshida4(), 4, 3),
        (SymplecticTableau::yoshida6(), 6, 7),
        (SymplecticTableau::yoshida8(), 8, 15),
        (SymplecticTableau::blanes_moan4(), 4, 6),
    ] {
        assert_eq!(tab.order, order);
        assert_eq!(tab.stages(), stages);
        assert!(tab.is_symmetric(), "{}", tab.name);
        assert_relative_eq!(tab.a.iter().sum::<f64>(), 1.0, epsilon = 1e-14);
        assert_relative_eq!(tab.b.iter().sum::<f64>(), 1.0, epsilon = 1e-14);
        assert_eq!(
            Method::ALL
                .iter()
                .find(|m| m.name() == tab.name)
                .unwrap()
                .order(),
            Some(order)
        );
    }
}

// ---------------------------------------------------------------------------------------------
// Long-time energy behaviour

/// Largest |E − E₀| over the first and the last tenth of the run.
fn energy_error_windows<S: Dynamics>(sys: &S, sol: &Solution) -> (f64, f64) {
    let e0 = sys.energy(sol.t[0], sol.q_at(0), sol.qd_at(0)).unwrap();
    let errs: Vec<f64> = (0..sol.len())
        .map(|i| (sys.energy(sol.t[i], sol.q_at(i), sol.qd_at(i)).unwrap() - e0).abs())
        .collect();
    let w = errs.len() / 10;
    let first = errs[..w].iter().copied().fold(0.0, f64::max);
    let last = errs[errs.len() - w..].iter().copied().fold(0.0, f64::max);
    (first, last)
}

/// Energy error of each symplectic method on the oscillator over `periods` periods, sampled
/// every 997 steps (a stride that does not alias the period).
fn oscillator_energy(periods: f64) {
    let sys = oscillator().system();
    let t_end = periods * PI;
    for (method, per_period) in [
        (Method::StormerVerlet, 20.0),
        (Method::Yoshida4, 10.0),
        (Method::Yoshida6, 8.0),
        (Method::Yoshida8, 6.0),
        (Method::BlanesMoan4, 8.0),
    ] {
        let opts = Options::fixed(PI / per_period)
            .with_output(Output::Every(997))
            .with_max_steps(100_000_000);
        let sol = solve(&sys, &[1.0], &[0.0], (0.0, t_end), method, &opts).unwrap();
        let (first, last) = energy_error_windows(&sys, &sol);
        assert!(
            first > 1e-13,
            "{method}: energy error {first:e} should be resolved"
        );
        // E₀ = 2; Störmer–Verlet at hω = π/10 errs by about (hω)²/8 · 2E₀ ≈ 0.05.
        assert!(first < 0.1, "{method}: energy error {first:e}");
        assert!(
            last <= 1.5 * first,
            "{method}: energy error grew from {first:e} to {last:e}"
        );
    }
    // The test can fail: RK4, even at 40 steps per period, drifts linearly (shown over a tenth
    // of the run, to keep the test fast).
    let opts = Options::fixed(PI / 40.0).with_output(Output::Every(97));
    let sol = solve(
        &sys,
        &[1.0],
        &[0.0],
        (0.0, t_end / 10.0),
        Method::Rk4,
        &opts,
    )
    .unwrap();
    let (first, last) = energy_error_windows(&sys, &sol);
    assert!(last > 5.0 * first, "RK4: {first:e} → {last:e}");
}

#[test]
fn energy_bounded_oscillator_symplectic() {
    oscillator_energy(1e4);
}

/// The full 10⁵ periods (about two minutes in a debug build).
#[test]
#[ignore]
fn energy_bounded_oscillator_symplectic_1e5_periods() {
    oscillator_energy(1e5);
}

fn kepler_energy(periods: f64) {
    let (sys, q0, qd0) = kepler(0.6);
    let t_end = periods * 2.0 * PI;
    for (method, per_period) in [
        (Method::StormerVerlet, 400.0),
        (Method::Yoshida4, 200.0),
        (Method::Yoshida6, 100.0),
        (Method::Yoshida8, 60.0),
        (Method::BlanesMoan4, 100.0),
    ] {
        let opts = Options::fixed(2.0 * PI / per_period)
            .with_output(Output::Every(97))
            .with_max_steps(100_000_000);
        let sol = solve(&sys, &q0, &qd0, (0.0, t_end), method, &opts).unwrap();
        let (first, last) = energy_error_windows(&sys, &sol);
        assert!(
            first > 1e-12 && first < 1e-2,
            "{method}: energy error {first:e}"
        );
        assert!(
            last <= 1.5 * first,
            "{method}: energy error grew from {first:e} to {last:e}"
        );
    }
}

#[test]
fn energy_bounded_kepler_symplectic() {
    kepler_energy(200.0);
}

/// 10⁴ orbits (about a minute in a debug build).
#[test]
#[ignore]
fn energy_bounded_kepler_symplectic_1e4_periods() {
    kepler_energy(1e4);
}

// ---------------------------------------------------------------------------------------------
// Reversibility and backward integration

#[test]
fn reversible_kepler_symmetric_methods() {
    let (sys, q0, qd0) = kepler(0.6);
    let y0 = [q0[0], q0[1], qd0[0], qd0[1]];
    let opts = Options::fixed(2.0 * PI / 400.0).with_output(Output::Every(usize::MAX));
    let back_error = |method| {
        let fwd = solve(&sys, &q0, &qd0, (0.0, 2.0 * PI), method, &opts).unwrap();
        let (_, q1, qd1) = fwd.last().unwrap();
        let back = solve(&sys, q1, qd1, (2.0 * PI, 0.0), method, &opts).unwrap();
        max_diff(&final_state(&back), &y0)
    };
    for method in SYMPLECTIC {
        let err = back_error(method);
        // Round-off of 400 steps of up to 15 stages with coefficients up to 2 in size.
        assert!(err < 1e-11, "{method}: forward then back misses by {err:e}");
    }
    // RK4 is not symmetric: its return error is the size of its global error.
    let err = back_error(Method::Rk4);
    assert!(err > 1e-7, "RK4 came back within {err:e}");
}

#[test]
fn backward_oscillator_all_methods() {
    let osc = oscillator();
    let (t0, t1) = (3.0, -2.0);
    let (q0, v0) = osc.exact_solution(1.0, 0.5, t0).unwrap();
    let (q1, v1) = osc.exact_solution(1.0, 0.5, t1).unwrap();
    // taylor needs an expression model: its runs backwards, dense output and stepping are in
    // `taylor.rs`.
    for method in Method::ALL.iter().copied().filter(|&m| m != Method::Taylor) {
        let opts = if method.is_adaptive() == Some(true) {
            Options::adaptive(1e-10, 1e-10)
        } else {
            Options::fixed(0.005)
        };
        let sol = solve(&osc.system(), &[q0], &[v0], (t0, t1), method, &opts).unwrap();
        assert_eq!(sol.t[0], t0);
        assert!(
            sol.t.windows(2).all(|w| w[1] < w[0]),
            "{method}: time runs backwards"
        );
        let (t, q, qd) = sol.last().unwrap();
        assert_eq!(t, t1);
        let err = max_diff(&[q[0], qd[0]], &[q1, v1]);
        // The O(h²) error of Störmer–Verlet and the midpoint rule at h = 0.005 is ~4e-5 and
        // ~8e-5; the others are far below.
        let bound = if matches!(method, Method::StormerVerlet | Method::Midpoint) {
            1e-4
        } else {
            1e-7
        };
        assert!(err < bound, "{method}: backward error {err:e}");
    }
}

// ---------------------------------------------------------------------------------------------
// Non-separable systems: the Runge–Kutta methods

#[test]
fn agree_double_pendulum_dop853_rk4() {
    // Chaotic, non-separable: DOP853 at tight tolerance against RK4 at a fine fixed step.
    let dp = DoublePendulum::new(1.3, 0.7, 1.1, 0.8, 9.81).system();
    let (q0, qd0) = ([1.2, -0.4], [0.0, 0.5]);
    let span = (0.0, 3.0);
    let a = solve(
        &dp,
        &q0,
        &qd0,
        span,
        Method::Dop853,
        &Options::adaptive(1e-12, 1e-12),
    )
    .unwrap();
    let b = solve(&dp, &q0, &qd0, span, Method::Rk4, &Options::fixed(5e-4)).unwrap();
    let diff = max_diff(&final_state(&a), &final_state(&b));
    assert!(diff < 1e-8, "DOP853 and RK4 differ by {diff:e}");
    // The energy function is conserved to the tolerance along the whole run.
    let e0 = dp.energy(0.0, &q0, &qd0).unwrap();
    for i in 0..a.len() {
        let e = dp.energy(a.t[i], a.q_at(i), a.qd_at(i)).unwrap();
        assert_relative_eq!(e, e0, max_relative = 1e-10);
    }
}

#[test]
fn energy_conserved_npendulum_dopri5() {
    let chain = NPendulum::uniform(4, 1.0, 0.5, 9.81).system();
    let (q0, qd0) = ([0.6, 0.3, -0.2, 0.4], [0.0, 0.0, 0.0, 0.0]);
    let e0 = chain.energy(0.0, &q0, &qd0).unwrap();
    let sol = solve(
        &chain,
        &q0,
        &qd0,
        (0.0, 2.0),
        Method::Dopri5,
        &Options::adaptive(1e-10, 1e-10),
    )
    .unwrap();
    let (t, q, qd) = sol.last().unwrap();
    assert_relative_eq!(chain.energy(t, q, qd).unwrap(), e0, max_relative = 1e-8);
}

// ---------------------------------------------------------------------------------------------
// Adaptive methods: tolerance, dense output, statistics

#[test]
fn tolerance_met_oscillator_adaptive() {
    let osc = oscillator();
    let (q1, v1) = osc.exact_solution(1.0, 0.5, 10.0).unwrap();
    for method in [Method::Dopri5, Method::Dop853] {
        let mut previous_steps = 0;
        for k in 4..=10 {
            let tol = 10f64.powi(-k);
            let opts = Options::adaptive(tol, tol);
            let sol = solve(&osc.system(), &[1.0], &[0.5], (0.0, 10.0), method, &opts).unwrap();
            let err = max_diff(&final_state(&sol), &[q1, v1]);
            assert!(err <= 10.0 * tol, "{method} tol {tol:e}: error {err:e}");
            // Tighter tolerances take more steps.
            assert!(sol.stats.accepted_steps >= previous_steps);
            previous_steps = sol.stats.accepted_steps;
        }
    }
}

#[test]
fn tolerance_met_forced_two_mass_adaptive() {
    let scene = ForcedTwoMass::new(1.0, 0.5, 3.0, 2.0).with_forcing(0.7, -0.4, 1.3);
    let sys = scene.system();
    let (x0, v0) = ([0.2, -0.1], [0.0, 0.3]);
    let exact = scene.exact_solution(x0, v0, 8.0).unwrap();
    for method in [Method::Dopri5, Method::Dop853] {
        for k in [4, 6, 8, 10] {
            let tol = 10f64.powi(-k);
            let opts = Options::adaptive(tol, tol);
            let sol = solve(&sys, &x0, &v0, (0.0, 8.0), method, &opts).unwrap();
            let want = [exact[0][0], exact[0][1], exact[1][0], exact[1][1]];
            let err = max_diff(&final_state(&sol), &want);
            assert!(err <= 10.0 * tol, "{method} tol {tol:e}: error {err:e}");
        }
    }
}

#[test]
fn dense_output_oscillator_all_methods() {
    let osc = oscillator();
    // Off-grid times, two equal ones, and the end point itself.
    let mut times: Vec<f64> = (0..40)
        .map(|i| 0.25 * i as f64 + 0.013 * (i % 3) as f64)
        .collect();
    times.insert(5, times[4]);
    times.push(10.0);
    // taylor needs an expression model: its runs backwards, dense output and stepping are in
    // `taylor.rs`.
    for method in Method::ALL.iter().copied().filter(|&m| m != Method::Taylor) {
        let (opts, bound) = if method.is_adaptive() == Some(true) {
            (Options::adaptive(1e-9, 1e-9), 1e-8)
        } else {
            // The midpoint rule's phase error at hω = 0.02 is about 1e-3 by t = 8.
            let bound = if method == Method::Midpoint {
                3e-3
            } else {
                1e-3
            };
            (Options::fixed(0.01), bound)
        };
        let steps = solve(&osc.system(), &[1.0], &[0.5], (0.0, 10.0), method, &opts).unwrap();
        let dense = solve(
            &osc.system(),
            &[1.0],
            &[0.5],
            (0.0, 10.0),
            method,
            &opts.clone().with_output(Output::Times(times.clone())),
        )
        .unwrap();
        assert_eq!(dense.t, times);
        // The same steps were taken.
        assert_eq!(
            dense.stats.accepted_steps, steps.stats.accepted_steps,
            "{method}"
        );
        assert_eq!(final_state(&dense), final_state(&steps), "{method}");
        for i in 0..dense.len() {
            let (q, v) = osc.exact_solution(1.0, 0.5, dense.t[i]).unwrap();
            let err = max_diff(&row(&dense, i), &[q, v]);
            assert!(err < bound, "{method} at t = {}: {err:e}", dense.t[i]);
        }
    }
}

/// The continuous extensions match the step error: at tight tolerance, dense output between
/// steps is as accurate as the steps themselves.
#[test]
fn dense_output_kepler_dop853() {
    let e = 0.6;
    let (sys, q0, qd0) = kepler(e);
    let times: Vec<f64> = (0..=97).map(|i| 2.0 * PI * i as f64 / 97.0).collect();
    for method in [Method::Dopri5, Method::Dop853] {
        let opts = Options::adaptive(1e-11, 1e-11).with_output(Output::Times(times.clone()));
        let sol = solve(&sys, &q0, &qd0, (0.0, 2.0 * PI), method, &opts).unwrap();
        for i in 0..sol.len() {
            let err = max_diff(&row(&sol, i), &kepler_exact(e, sol.t[i]));
            assert!(err < 2e-8, "{method} at t = {}: {err:e}", sol.t[i]);
        }
    }
}

#[test]
fn output_every_kth_step() {
    let osc = oscillator();
    let opts = Options::fixed(0.1).with_output(Output::Every(7));
    let sol = solve(
        &osc.system(),
        &[1.0],
        &[0.0],
        (0.0, 10.0),
        Method::Rk4,
        &opts,
    )
    .unwrap();
    // t0, steps 7, 14, …, 98, and the final step 100.
    assert_eq!(sol.len(), 1 + 14 + 1);
    assert_relative_eq!(sol.t[1], 0.7, epsilon = 1e-14);
    assert_eq!(*sol.t.last().unwrap(), 10.0);
}

#[test]
fn statistics_count_evaluations() {
    let osc = oscillator();
    let sys = osc.system();
    let fixed = Options::fixed(0.1);
    let rk4 = solve(&sys, &[1.0], &[0.0], (0.0, 10.0), Method::Rk4, &fixed).unwrap();
    assert_eq!(rk4.stats.accepted_steps, 100);
    assert_eq!(rk4.stats.rhs_evaluations, 4 * 100 + 1);
    // FSAL splittings: one force evaluation per drift, plus the first.
    for (method, stages) in [
        (Method::StormerVerlet, 1),
        (Method::BlanesMoan4, 6),
        (Method::Yoshida8, 15),
    ] {
        let sol = solve(&sys, &[1.0], &[0.0], (0.0, 10.0), method, &fixed).unwrap();
        assert_eq!(sol.stats.rhs_evaluations, stages * 100 + 1, "{method}");
        assert_eq!(sol.stats.factorizations, 1);
        assert_eq!(sol.stats.rejected_steps, 0);
    }
    // Adaptive: f(t0) and Hairer's initial-step probe, then per attempt the stages after the
    // first; DOP853 adds f(t + h, y₁) per accepted step, DOPRI5 has it as its FSAL stage.
    let (ksys, q0, qd0) = kepler(0.6);
    let tol = Options::adaptive(1e-9, 1e-9);
    let d5 = solve(&ksys, &q0, &qd0, (0.0, 2.0 * PI), Method::Dopri5, &tol).unwrap();
    let s = &d5.stats;
    assert_eq!(
        s.rhs_evaluations,
        2 + 6 * (s.accepted_steps + s.rejected_steps)
    );
    // A given first step skips the probe; one far too large forces rejections.
    let big = tol.clone().with_initial_step(1.0);
    for (method, stages) in [(Method::Dopri5, 6), (Method::Dop853, 11)] {
        let sol = solve(&ksys, &q0, &qd0, (0.0, 2.0 * PI), method, &big).unwrap();
        let s = &sol.stats;
        assert!(s.rejected_steps > 0);
        let f_new = if method == Method::Dop853 {
            s.accepted_steps
        } else {
            0
        };
        assert_eq!(
            s.rhs_evaluations,
            1 + stages * (s.accepted_steps + s.rejected_steps) + f_new,
            "{method}"
        );
    }
    let d8 = solve(&ksys, &q0, &qd0, (0.0, 2.0 * PI), Method::Dop853, &tol).unwrap();
    let s = &d8.stats;
    assert_eq!(
        s.rhs_evaluations,
        2 + 11 * (s.accepted_steps + s.rejected_steps) + s.accepted_steps
    );
    assert_eq!(
        s.jacobian_evaluations + s.factorizations + s.newton_failures,
        0
    );
    assert!(d8.stats.accepted_steps < d5.stats.accepted_steps);
}
