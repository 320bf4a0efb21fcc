//! `Method::Auto` with a fixed step on the double pendulum: M depends on q, so the system is not
//! separable and the choice is the implicit symplectic Gauss–Legendre 4, which keeps the energy.
//! Shown on the documentation site's integrator page (docs/site/integrators.rst).
//!
//! Run with `cargo run --example auto_fixed_step`.

use lagrangian::Dynamics;
use lagrangian::integrators::{Method, Options, solve};
use lagrangian::scenes::DoublePendulum;

fn main() -> Result<(), lagrangian::Error> {
    let dp = DoublePendulum::new(1.0, 1.0, 1.0, 1.0, 9.81).system();
    let (q0, qd0) = ([0.4, 0.3], [0.0, 0.0]);
    // M depends on q: not separable, so a fixed step gets the implicit symplectic gauss4.
    let sol = solve(
        &dp,
        &q0,
        &qd0,
        (0.0, 10.0),
        Method::Auto,
        &Options::fixed(0.05),
    )?;
    assert_eq!(sol.stats.method, Method::Gauss4);
    let (t, q, qd) = sol.last().unwrap();
    let e0 = dp.energy(0.0, &q0, &qd0)?;
    assert!((dp.energy(t, q, qd)? - e0).abs() < 1e-6 * e0.abs());
    println!(
        "{:?}: energy kept to 1e-6 over {} steps",
        sol.stats.method, sol.stats.accepted_steps
    );
    Ok(())
}
