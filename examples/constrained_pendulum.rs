//! A pendulum stated in Cartesian coordinates with its rod as a constraint, x² + y² − l² = 0
//! (seed §2: a particle under one constraint), integrated without drift; the rod's tension is
//! the multiplier, T = −2 λ l, against m (v²/l + g cos θ).
//!
//! Run with `cargo run --example constrained_pendulum`.

use lagrangian::integrators::{Method, Options, solve};
use lagrangian::scenes::elliptic_k;
use lagrangian::{Constrained, Constraints, KineticEnergy, Potential, Scalar, System};

/// T = ½ m (ẋ² + ẏ²).
struct Point(f64);
impl KineticEnergy for Point {
    fn kinetic<D: Scalar>(&self, _t: D, _q: &[D], qd: &[D]) -> D {
        (qd[0] * qd[0] + qd[1] * qd[1]) * (0.5 * self.0)
    }
}

/// U = m g y.
struct Gravity(f64);
impl Potential for Gravity {
    fn potential<D: Scalar>(&self, _t: D, q: &[D]) -> D {
        q[1] * (self.0 * 9.81)
    }
}

/// The rod: x² + y² − l² = 0.
struct Rod(f64);
impl Constraints for Rod {
    fn holonomic_count(&self) -> usize {
        1
    }
    fn holonomic<D: Scalar>(&self, _t: D, q: &[D], out: &mut [D]) {
        out[0] = q[0] * q[0] + q[1] * q[1] - self.0 * self.0;
    }
    fn depends_on_time(&self) -> bool {
        false
    }
    fn name(&self, _row: usize) -> String {
        "rod".into()
    }
}

fn main() -> lagrangian::Result<()> {
    let (m, l, g, theta0) = (0.5, 1.2, 9.81, 2.5_f64);
    let pendulum = Constrained::new(System::new(2, Point(m)).with_potential(Gravity(m)), Rod(l));
    // Released from rest at θ₀: one period is T = 4 √(l/g) K(sin(θ₀/2)).
    let period = 4.0 * (l / g).sqrt() * elliptic_k((theta0 / 2.0).sin())?;
    let q0 = [l * theta0.sin(), -l * theta0.cos()];
    let sol = solve(
        &pendulum,
        &q0,
        &[0.0, 0.0],
        (0.0, period),
        Method::Dop853,
        &Options::adaptive(1e-12, 1e-12),
    )?;
    let (_, q, _) = sol.last().expect("a run keeps its end");
    let back = (q[0] - q0[0]).hypot(q[1] - q0[1]);
    println!("period {period:.12} s: back at the start within {back:.1e} m");
    println!(
        "{} steps, {} projected back onto the rod, worst residual {:.1e}",
        sol.stats.accepted_steps, sol.stats.projections, sol.stats.constraint_residual
    );
    assert!(back < 1e-8);
    assert!(sol.stats.constraint_residual < 1e-10);

    // The tension along the swing, from the multiplier and from Newton's law in polar form.
    println!("{:>8} {:>18} {:>18}", "t", "T = −2λl", "m(v²/l + g cos θ)");
    for i in (0..sol.len()).step_by(sol.len() / 6) {
        let (t, q, qd) = (sol.t[i], sol.q_at(i), sol.qd_at(i));
        let lambda = pendulum.evaluate(t, q, qd)?.multipliers[0];
        let tension = -2.0 * lambda * l;
        let cos_theta = -q[1] / l;
        let v2 = qd[0] * qd[0] + qd[1] * qd[1];
        let newton = m * (v2 / l + g * cos_theta);
        println!("{t:>8.4} {tension:>18.12} {newton:>18.12}");
        assert!((tension - newton).abs() < 1e-9 * (1.0 + newton.abs()));
    }
    Ok(())
}
