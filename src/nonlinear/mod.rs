//! Nonlinear solving, apart from the ODE code (as diffsol keeps `nonlinear_solver/`): an
//! in-place LU for Newton's linear systems (`lu`), the convergence test of a Newton iteration
//! run to round-off and the simplified-Newton update (`convergence`), used by the implicit
//! integrators (Gauss–Legendre, variational, Radau), and Newton's method globalised by a line
//! search and Levenberg–Marquardt damping (`damped`), used by the equilibria. The Jacobians
//! come from [`crate::dynamics`] (forward-mode AD).

mod convergence;
mod damped;
mod lu;

pub(crate) use convergence::{Convergence, Verdict, max_norm, newton_update, same_step};
pub(crate) use damped::{Residual, Stopping, damped_newton};
pub(crate) use lu::Lu;
