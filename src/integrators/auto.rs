//! [`Method::Auto`]: the choice of a method from the system's structure, the options and the
//! initial state, with the reason recorded in the statistics.

use super::{Method, Options, stiffness};
use crate::dynamics::Dynamics;

/// Choose a method from the system's structure, the options and the initial state (the rule
/// is documented on [`Method::Auto`]); the reason goes to the statistics.
pub(super) fn choose<S: Dynamics + ?Sized>(
    system: &S,
    t0: f64,
    q0: &[f64],
    qd0: &[f64],
    t_end: f64,
    options: &Options,
) -> (Method, String) {
    let s = system.structure();
    if options.dt.is_some() && s.conservative() {
        return if s.separable {
            (
                Method::BlanesMoan4,
                "separable (constant M, U(q)) and conservative, with a fixed dt: the symplectic \
                 Blanes–Moan SRKN of order 4 keeps the energy error bounded over long runs"
                    .into(),
            )
        } else {
            (
                Method::Gauss4,
                "conservative but not separable (M depends on q, or gyroscopic or \
                 velocity-dependent terms), with a fixed dt: Gauss–Legendre of order 4 on (q, p) \
                 is symplectic for any Lagrangian and keeps the energy error bounded"
                    .into(),
            )
        };
    }
    let stiffness = stiffness::estimate_stiffness(system, t0, q0, qd0, t_end - t0);
    if let Some(est) = stiffness.filter(|e| e.stiff()) {
        return (
            Method::Radau5,
            format!(
                "stiff: at the initial state the fastest decaying mode (|λ| ≈ {:.3e}) is {:.0} \
                 times faster than every mode the solution must follow (|λ| ≈ {:.3e}, at least \
                 1/span), so an explicit step would be limited by stability; Radau IIA of order \
                 5 is L-stable",
                est.fastest,
                est.ratio(),
                est.resolved
            ),
        );
    }
    let not_stiff = match stiffness {
        Some(est) => format!(
            "not stiff (fastest mode |λ| ≈ {:.3e}, {:.0} times the slowest one to follow)",
            est.fastest,
            est.ratio()
        ),
        None => "not tested for stiffness (over 64 coordinates, or no Jacobian at the initial \
                 state)"
            .into(),
    };
    let why = match options.dt {
        Some(_) => format!(
            "fixed dt on a system that is forced, dissipative or time-dependent, {not_stiff}: \
             DOP853 (order 8) at that step"
        ),
        None if s.conservative() => format!(
            "no fixed dt (adaptive steps to rtol and atol), {not_stiff}: DOP853 with error \
             control, dense output and stiffness detection (the symplectic methods, {}, need a \
             fixed dt)",
            if s.separable {
                "blanes_moan4"
            } else {
                "gauss4"
            }
        ),
        None => format!(
            "no fixed dt (adaptive steps to rtol and atol), {not_stiff}: DOP853 with error \
             control, dense output and stiffness detection"
        ),
    };
    (Method::Dop853, why)
}
