//! The equilibrium solver: a root of the residual at rest, classified by the modes there.

use super::linearize::{Linearization, linearize, modes_unchecked};
use super::residual::{STEADY_OFFSETS, STEADY_TOLERANCE, StaticProblem};
use super::stability::{Stability, classify};
use crate::checks::check_state;
use crate::dynamics::Dynamics;
use crate::error::{Error, Result};
use crate::nonlinear::{Stopping, damped_newton};
use nalgebra::{Complex, DMatrix, DVector};

/// Stopping rules and tolerances of [`equilibrium`].
///
/// The iteration stops successfully when either
/// - |r| ≤ `abs_tolerance` + `rel_tolerance` · F, where F is the largest of |∂U/∂q| and of the
///   other forces |Q″ + ∂T/∂q − ∂Φ/∂q̇ − ∂²T/∂q̇∂t| met at any accepted iterate (the guess
///   included) — the size of the loads being balanced, since the total residual may cancel to
///   zero at the root (Euclidean norms throughout); or
/// - an undamped Newton step Δq satisfies |Δq|∞ ≤ `step_tolerance` · |q|∞: Newton converges
///   quadratically there, so the step is taken and its end point returned.
///
/// A converged point then gets one more Newton step, kept if it does not increase |r| (counted
/// in the iterations, and skipped when none are left): it squares the error of a regular root, so q is far more accurate than
/// the residual tolerance alone would make it.
///
/// Because F is the largest load met, a force that only decays towards an "equilibrium at
/// infinity" (U = eˣ) is reported once it has fallen by `rel_tolerance`; check the returned q.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StaticsOptions {
    /// Absolute tolerance on |r|, in the units of the generalized forces (default 0: off).
    pub abs_tolerance: f64,
    /// Tolerance on |r| relative to the load scale F (default 1e-12).
    pub rel_tolerance: f64,
    /// Relative size of a Newton step below which the iteration has converged (default 1e-12).
    pub step_tolerance: f64,
    /// Upper bound on Newton/Levenberg–Marquardt iterations, failed line searches included
    /// (default 100).
    pub max_iterations: usize,
    /// Largest change of any coordinate in one iteration, |Δq|∞ (default ∞: no limit; set it to
    /// keep angles within one well, say).
    pub max_step: f64,
    /// Eigenvalues within ± `stability_tolerance` of the largest count as zero when the
    /// equilibrium is classified (default 1e-9; see [`crate::Modes::stability`]).
    pub stability_tolerance: f64,
    /// Solve for the balance of the forces frozen at the given t even when the equations depend
    /// on t (default `false`: such a system has no static equilibrium in general, and
    /// [`equilibrium`] fails with [`Error::NoStaticEquilibrium`]).
    pub frozen_time: bool,
}

impl Default for StaticsOptions {
    fn default() -> Self {
        Self {
            abs_tolerance: 0.0,
            rel_tolerance: 1e-12,
            step_tolerance: 1e-12,
            max_iterations: 100,
            max_step: f64::INFINITY,
            stability_tolerance: 1e-9,
            frozen_time: false,
        }
    }
}

impl StaticsOptions {
    /// The rules the solver stops by.
    fn stopping(&self) -> Stopping {
        Stopping {
            abs_tolerance: self.abs_tolerance,
            rel_tolerance: self.rel_tolerance,
            step_tolerance: self.step_tolerance,
            max_iterations: self.max_iterations,
            max_step: self.max_step,
        }
    }

    pub(super) fn validate(&self) -> Result<()> {
        let nonneg = [
            ("abs_tolerance", self.abs_tolerance),
            ("rel_tolerance", self.rel_tolerance),
            ("step_tolerance", self.step_tolerance),
            ("stability_tolerance", self.stability_tolerance),
        ];
        for (what, v) in nonneg {
            if !(v.is_finite() && v >= 0.0) {
                return Err(Error::InvalidInput {
                    what,
                    why: format!("{v} is not a finite non-negative number"),
                });
            }
        }
        if self.max_step.is_nan() || self.max_step <= 0.0 {
            return Err(Error::InvalidInput {
                what: "max_step",
                why: format!(
                    "{} is not positive (use f64::INFINITY for no limit)",
                    self.max_step
                ),
            });
        }
        Ok(())
    }
}

/// An equilibrium found by [`equilibrium`].
#[derive(Debug, Clone, PartialEq)]
pub struct Equilibrium {
    /// The equilibrium configuration.
    pub q: DVector<f64>,
    /// |r(q)| at `q` (Euclidean norm).
    pub residual: f64,
    /// Iterations used (0 when the guess already satisfies the tolerance).
    pub iterations: usize,
    /// Stable, unstable or neutral.
    pub stability: Stability,
    /// Why: which eigenvalues decided, in words.
    pub reason: String,
    /// Eigenvalues of the symmetric part of K at `q`, ascending.
    pub eigenvalues: DVector<f64>,
    /// The stiffness K = ∂r/∂q at `q`: ∂²U/∂q² − ∂Q″/∂q, plus the centrifugal −∂²T₀/∂q².
    pub stiffness: DMatrix<f64>,
    /// Eigenvalues of the state matrix A of the linearization at (q, q̇ = 0)
    /// ([`crate::Modes::eigenvalues`]); `None` where M is singular.
    pub spectrum: Option<DVector<Complex<f64>>>,
}

/// Find an equilibrium of the equations of motion near `q_guess`: r(q) = 0 at q̇ = 0 (see the
/// module documentation), which is ∂U/∂q = Q″ (virtual work, eq. 27–29) when T is quadratic
/// in q̇ and the relative equilibrium of U − T₀ otherwise.
///
/// The residual is evaluated at time `t`. Fails with [`Error::NoStaticEquilibrium`] when the
/// equations depend on t and `options.frozen_time` is not set, [`Error::NoConvergence`] when no
/// root is reached within the options' bounds (there may be none: a net load that nothing
/// balances), [`Error::DimensionMismatch`] or [`Error::NonFinite`] for a bad guess,
/// [`Error::NonFinite`] when the model returns a non-finite residual at the guess or cannot
/// avoid one, and [`Error::InvalidInput`] for bad options.
///
/// ```
/// use lagrangian::{equilibrium, Stability, StaticsOptions};
/// use lagrangian::scenes::SimplePendulum;
/// # use approx::assert_relative_eq;
/// let pendulum = SimplePendulum::new(1.0, 2.0, 9.81).system();
/// let top = equilibrium(&pendulum, 0.0, &[2.8], &StaticsOptions::default()).unwrap();
/// assert_relative_eq!(top.q[0], std::f64::consts::PI, epsilon = 1e-12);
/// assert_eq!(top.stability, Stability::Unstable);
/// ```
pub fn equilibrium<S: Dynamics>(
    system: &S,
    t: f64,
    q_guess: &[f64],
    options: &StaticsOptions,
) -> Result<Equilibrium> {
    options.validate()?;
    check_state(system.dof(), t, q_guess, None)?;
    let mut problem = StaticProblem::new(system, t);
    let steady = !options.frozen_time && !system.structure().conservative();
    let solution = damped_newton(
        &mut problem,
        DVector::from_column_slice(q_guess),
        &options.stopping(),
    )?;
    if steady {
        problem.check_steady(solution.q.as_slice())?;
    }
    let (eigenvalues, static_verdict) = classify(&solution.k, options.stability_tolerance);
    let q = solution.q.as_slice();
    let (stability, reason, spectrum) =
        match modes_unchecked(system, t, q, options.stability_tolerance) {
            Ok(modes) if steady && parametric(system, &modes.linearization)? => (
                Stability::Neutral,
                "the linearized equations change with t here (parametric excitation, a driven \
                 support): the eigenvalues at one instant do not decide, Floquet theory does"
                    .to_string(),
                Some(modes.eigenvalues),
            ),
            Ok(modes) => (modes.stability, modes.reason, Some(modes.eigenvalues)),
            Err(Error::SingularMassMatrix { .. }) => {
                let (stability, why) = static_verdict;
                let reason = format!(
                    "M is singular here (a model for statics only), so the stiffness alone \
                     decides (energy criterion): {why}"
                );
                (stability, reason, None)
            }
            Err(e) => return Err(e),
        };
    Ok(Equilibrium {
        q: solution.q,
        residual: solution.r.norm(),
        iterations: solution.iterations,
        stability,
        reason,
        eigenvalues,
        stiffness: solution.k,
        spectrum,
    })
}

/// Whether the state matrix A at the equilibrium changes with t (at the [`STEADY_OFFSETS`]).
fn parametric<S: Dynamics>(system: &S, lin: &Linearization) -> Result<bool> {
    let q = lin.q.as_slice();
    let rest = vec![0.0; q.len()];
    for dt in STEADY_OFFSETS {
        let other = linearize(system, lin.t + dt, q, &rest)?;
        if (&other.a - &lin.a).amax() > STEADY_TOLERANCE * lin.a.amax().max(other.a.amax()) {
            return Ok(true);
        }
    }
    Ok(false)
}
