//! Andrews' squeezing mechanism (Hairer & Wanner II §VII.7; the IVP Test Set's `andrews`):
//! seven bodies, six loop closures, stated by their energies and constraints
//! ([`Andrews::model`]) and integrated to t = 0.03 with DOP853 at a few tolerances. Prints the
//! error in q against the Test Set's reference, the steps, the worst constraint residual and
//! the run time.
//!
//! Run with `cargo run --release --example andrews`.

use lagrangian::integrators::{Method, Options, Output, solve};
use lagrangian::scenes::{ANDREWS_COORDINATES, Andrews};
use std::time::Instant;

fn main() -> lagrangian::Result<()> {
    let model = Andrews::default().model();
    let (q0, qd0) = Andrews::initial_state();
    let reference = Andrews::reference_at_0_03();
    println!(
        "{:>7} {:>12} {:>6} {:>12} {:>12} {:>10}",
        "tol", "error in q", "steps", "projections", "residual", "time"
    );
    let mut last = Vec::new();
    for tol in [1e-6, 1e-8, 1e-10, 1e-12] {
        let options = Options::adaptive(tol, tol).with_output(Output::Final);
        let start = Instant::now();
        let sol = solve(&model, &q0, &qd0, (0.0, 0.03), Method::Dop853, &options)?;
        let took = start.elapsed();
        let (_, q, _) = sol.last().expect("the final state is kept");
        // Componentwise relative error against the Test Set's reference.
        let error = q
            .iter()
            .zip(&reference.q)
            .fold(0.0_f64, |m, (x, r)| m.max((x - r).abs() / r.abs()));
        println!(
            "{tol:>7.0e} {error:>12.2e} {:>6} {:>12} {:>12.1e} {:>8.3} ms",
            sol.stats.accepted_steps,
            sol.stats.projections,
            sol.stats.constraint_residual,
            took.as_secs_f64() * 1e3
        );
        last = q.to_vec();
    }
    println!("\nq(0.03) at tol 1e-12 against the Test Set's reference:");
    for ((name, x), r) in ANDREWS_COORDINATES.iter().zip(&last).zip(&reference.q) {
        println!("{name:>8} {x:>22.15e} {r:>22.15e}");
    }
    // The reactions at the end: this crate's λ is the Test Set's −λ.
    let end = model.evaluate(0.03, &reference.q, &reference.qd)?;
    println!(
        "\nλ at the reference state (Test Set's sign): {:?}",
        -end.multipliers
    );
    Ok(())
}
