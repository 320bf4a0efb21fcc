//! The Taylor method against DOP853 on the N-link pendulum chain (`tape::models::pendulum_chain`,
//! positions as running sums), rtol = atol = 1e-12, t = 0–1: the time of the first Taylor run
//! (which compiles the recurrences), then best of REPEAT (default 5), Taylor in its steady state
//! (after 10⁴ expansions, when a small enough program's expansion is compiled unrolled).
//! `N=16 cargo run --release --features jit --example taylor_chain`.
use lagrangian::integrators::{Method, Options, Output, solve};
use lagrangian::tape::{EnergyModel, EomProgram, Function, Graph, Inputs, Tape, models};
use std::sync::Arc;
use std::time::Instant;
fn main() {
    let n: usize = std::env::var("N")
        .ok()
        .and_then(|r| r.parse().ok())
        .unwrap_or(8);
    let repeat: usize = std::env::var("REPEAT")
        .ok()
        .and_then(|r| r.parse().ok())
        .unwrap_or(5);
    let params = [1.0, 1.0, 9.81];
    let mut g = Graph::new();
    let parts = models::pendulum_chain(&mut g, n).unwrap();
    let f = |g: &Graph, nodes: &[usize], inputs: Inputs| {
        Function::new(
            Arc::new(Tape::new(g, nodes, inputs, "part").unwrap()),
            &params,
        )
        .unwrap()
    };
    let kinetic = f(&g, &[parts.kinetic], Inputs::kinetic(n, 3));
    let potential = f(&g, &[parts.potential.unwrap()], Inputs::potential(n, 3));
    let program = EomProgram::new(&mut g, n, 3, &parts).unwrap();
    let model = EnergyModel::new(n, kinetic, Some(potential), None, None)
        .unwrap()
        .with_program(program.bind(&params).unwrap())
        .unwrap();
    let (q0, v0) = (vec![0.3; n], vec![0.0; n]);
    let t0 = Instant::now();
    solve(
        &model,
        &q0,
        &v0,
        (0.0, 0.01),
        Method::Taylor,
        &Options::adaptive(1e-12, 1e-12),
    )
    .unwrap();
    println!(
        "first Taylor run (kernel compile) {:.1} ms",
        t0.elapsed().as_secs_f64() * 1e3
    );
    for method in [Method::Dop853, Method::Taylor] {
        let options = Options::adaptive(1e-12, 1e-12).with_output(Output::Every(usize::MAX));
        if method == Method::Taylor {
            // The steady state: past the 10⁴ expansions to this order after which a small
            // enough program's whole expansion is compiled unrolled (`UNROLL_AFTER`).
            let t0 = Instant::now();
            let mut steps = 0;
            while steps <= 10_000 {
                steps += solve(&model, &q0, &v0, (0.0, 1.0), method, &options)
                    .unwrap()
                    .stats
                    .accepted_steps;
            }
            println!(
                "warm-up past 10⁴ expansions {:.1} ms",
                t0.elapsed().as_secs_f64() * 1e3
            );
        }
        let mut best = f64::INFINITY;
        let mut steps = 0;
        for _ in 0..repeat {
            let t0 = Instant::now();
            let s = solve(&model, &q0, &v0, (0.0, 1.0), method, &options).unwrap();
            best = best.min(t0.elapsed().as_secs_f64());
            steps = s.stats.accepted_steps;
        }
        println!(
            "N {n} {method}: {:.3} ms, {steps} steps, {:.1} us/step",
            best * 1e3,
            best * 1e6 / steps as f64
        );
    }
}
