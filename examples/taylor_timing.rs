//! The Taylor method against DOP853 at the same tolerances on the double pendulum (the numbers
//! in docs/site/integrators.rst): best of REPEAT (default 5) runs, error against DOP853
//! at 1e-15 (so its own row at 1e-15 reads 0). Taylor is timed in its steady state, once the
//! model has expanded 10⁴ times at the order (its whole expansion is then compiled unrolled). `TOL=1e-9 REPEAT=2000` runs one tolerance, for a
//! profiler. Run with `cargo run --release --features jit --example taylor_timing`.
use lagrangian::integrators::{Method, Options, solve};
use lagrangian::tape::{EnergyModel, EomProgram, Function, Graph, Inputs, Tape, models};
use std::sync::Arc;
use std::time::Instant;

fn main() {
    let params = [1.0, 1.0, 1.0, 1.0, 9.81];
    let mut g = Graph::new();
    let parts = models::double_pendulum(&mut g).unwrap();
    let f = |g: &Graph, nodes: &[usize], inputs: Inputs| {
        Function::new(
            Arc::new(Tape::new(g, nodes, inputs, "part").unwrap()),
            &params,
        )
        .unwrap()
    };
    let kinetic = f(&g, &[parts.kinetic], Inputs::kinetic(2, 5));
    let potential = f(&g, &[parts.potential.unwrap()], Inputs::potential(2, 5));
    let program = EomProgram::new(&mut g, 2, 5, &parts).unwrap();
    let model = EnergyModel::new(2, kinetic, Some(potential), None, None)
        .unwrap()
        .with_program(program.bind(&params).unwrap())
        .unwrap();
    let (q0, v0) = ([1.0, 0.5], [0.0, 0.0]);
    let span = (0.0, 10.0);
    let reference = solve(
        &model,
        &q0,
        &v0,
        span,
        Method::Dop853,
        &Options::adaptive(1e-15, 1e-15),
    )
    .unwrap();
    let (_, qr, vr) = reference.last().unwrap();
    let repeat: usize = std::env::var("REPEAT")
        .ok()
        .and_then(|r| r.parse().ok())
        .unwrap_or(5);
    let only: Option<f64> = std::env::var("TOL").ok().and_then(|r| r.parse().ok());
    for tol in [1e-6, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12, 1e-13, 1e-15] {
        if only.is_some_and(|o| o != tol) {
            continue;
        }
        for method in [Method::Dop853, Method::Taylor] {
            if only.is_some() && method != Method::Taylor {
                continue;
            }
            let options = Options::adaptive(tol, tol)
                .with_output(lagrangian::integrators::Output::Every(usize::MAX));
            if method == Method::Taylor {
                // The steady state: past the 10⁴ expansions to this order after which the
                // whole expansion is compiled unrolled (`UNROLL_AFTER`).
                let mut steps = 0;
                while steps <= 10_000 {
                    steps += solve(&model, &q0, &v0, span, method, &options)
                        .unwrap()
                        .stats
                        .accepted_steps;
                }
            }
            let mut best = f64::INFINITY;
            let mut sol = None;
            for _ in 0..repeat {
                let t0 = Instant::now();
                let s = solve(&model, &q0, &v0, span, method, &options).unwrap();
                best = best.min(t0.elapsed().as_secs_f64());
                sol = Some(s);
            }
            let sol = sol.unwrap();
            let (_, q, v) = sol.last().unwrap();
            let err = q
                .iter()
                .zip(qr)
                .chain(v.iter().zip(vr))
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max);
            println!(
                "tol {tol:e} {method}: {:.3} ms, error {err:.1e}, steps {}",
                best * 1e3,
                sol.stats.accepted_steps
            );
        }
    }
}
