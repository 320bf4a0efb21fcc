//! The crate's one error type. Numerical failure is returned, never panicked or turned into NaN.

use thiserror::Error;

/// Everything that can go wrong when deriving or solving the equations of motion.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum Error {
    /// The mass matrix M = ∂²T/∂q̇² cannot be inverted at this state.
    #[error(
        "mass matrix is {reason} at t = {t}, q = {q:?}: check that every coordinate carries inertia \
         (a massless body or a degenerate parametrisation makes M singular)"
    )]
    SingularMassMatrix {
        /// Time of the evaluation.
        t: f64,
        /// Configuration of the evaluation.
        q: Vec<f64>,
        /// What was found: "singular", "not positive definite" or "non-finite".
        reason: &'static str,
    },

    /// A model or an input produced a NaN or an infinity.
    #[error(
        "non-finite {what} at t = {t}: check the model and the inputs for overflow or division by zero"
    )]
    NonFinite {
        /// Which quantity was not finite.
        what: &'static str,
        /// Time at which it appeared.
        t: f64,
    },

    /// A slice had the wrong length for the system's number of degrees of freedom.
    #[error("{what} has length {got}, expected {expected}")]
    DimensionMismatch {
        /// Which argument.
        what: &'static str,
        /// Expected length.
        expected: usize,
        /// Length given.
        got: usize,
    },

    /// The constraints' Jacobian G (∂g/∂q stacked with the velocity rows' ∂(a·q̇ + b)/∂q̇) has
    /// dependent rows at this state, so the multipliers λ are not unique and the Schur
    /// complement G M⁻¹ Gᵀ cannot be factored: a constraint is stated twice (or follows from the
    /// others), or the mechanism is at a dead point (a singular configuration).
    #[error(
        "constraints are dependent at t = {t}, q = {q:?}: {row} is a combination of {others:?} \
         (G = ∂g/∂q has rank below its number of rows, so the reaction forces are not \
         determined); remove a redundant constraint, or, at a mechanism's dead point, start from \
         a configuration away from it"
    )]
    DependentConstraints {
        /// Time of the evaluation.
        t: f64,
        /// Configuration of the evaluation.
        q: Vec<f64>,
        /// The row found dependent (its [`Constraints::name`](crate::Constraints::name)).
        row: String,
        /// The earlier rows it combines (their names; every earlier row when the combination
        /// could not be isolated).
        others: Vec<String>,
    },

    /// A velocity constraint a(t, q)·q̇ + b(t, q) = 0 is not linear in q̇ at this state.
    #[error(
        "velocity constraint {row} is not linear in q̇ at t = {t} (its second derivative in q̇ \
         has an entry of {second_derivative:e}): a velocity constraint must read a(t, q)·q̇ + \
         b(t, q); state a position constraint g(t, q) = 0 instead when one exists"
    )]
    NonlinearVelocityConstraint {
        /// Time of the evaluation.
        t: f64,
        /// The row's name ([`Constraints::name`](crate::Constraints::name)).
        row: String,
        /// The largest entry of ∂²(a·q̇ + b)/∂q̇² found.
        second_derivative: f64,
    },

    /// A state does not satisfy the constraints: g(t, q) ≠ 0 (position level) or
    /// ġ = G q̇ + ∂g/∂t, a·q̇ + b ≠ 0 (velocity level) beyond the tolerance.
    #[error(
        "inconsistent state at t = {t}: {constraint} is violated at the {level} level (residual \
         {residual:e}); call Constrained::project (model.project in Python) for the nearest \
         consistent state"
    )]
    InconsistentState {
        /// Time of the state.
        t: f64,
        /// The worst row's name ([`Constraints::name`](crate::Constraints::name)).
        constraint: String,
        /// "position" (g) or "velocity" (ġ, a·q̇ + b).
        level: &'static str,
        /// The row's residual.
        residual: f64,
    },

    /// The projection of a state onto the constraints (Gauss–Newton for the positions) did not
    /// converge within its iterations.
    #[error(
        "projection onto the constraints failed at t = {t} after {iterations} iterations: \
         {constraint} keeps a residual of {residual:e}; start closer to a configuration that \
         satisfies it, or check that it has a real solution near q"
    )]
    ProjectionFailed {
        /// Time of the state.
        t: f64,
        /// The worst row's name ([`Constraints::name`](crate::Constraints::name)).
        constraint: String,
        /// The row's last residual.
        residual: f64,
        /// Iterations performed.
        iterations: usize,
    },

    /// An option or parameter is outside its valid range.
    #[error("invalid {what}: {why}")]
    InvalidInput {
        /// Which option or parameter.
        what: &'static str,
        /// Why it is rejected, and what to use instead.
        why: String,
    },

    /// A Rust system cannot be traced into an expression graph ([`crate::trace`]): its energies
    /// read a value (a branch, a comparison) or call a function the graph lacks. Nothing is
    /// derived from such a trace, so no wrong model results.
    #[error("{what} cannot be traced into an expression graph: {why}")]
    NotTraceable {
        /// The system (a scene's name).
        what: String,
        /// The first operation that could not be recorded.
        why: String,
    },

    /// A scene's argument is unknown, repeated, of the wrong kind, not finite, or missing.
    #[error("{scene}: invalid argument {parameter}: {why}")]
    SceneArgument {
        /// The scene.
        scene: &'static str,
        /// The parameter, as given.
        parameter: String,
        /// What is wrong with it.
        why: String,
    },

    /// Newton's method did not converge.
    #[error(
        "Newton iteration did not converge after {iterations} iterations (residual {residual:e}, \
         q = {q:?}): try another initial guess, or check that an equilibrium exists"
    )]
    NoConvergence {
        /// Iterations performed.
        iterations: usize,
        /// Final residual norm.
        residual: f64,
        /// Last iterate.
        q: Vec<f64>,
    },

    /// The equations of motion depend on t explicitly, so what balances at one instant does
    /// not at the next: no static equilibrium exists in general.
    #[error(
        "no static equilibrium: the equations of motion depend on t explicitly (at q = {q:?} the \
         forces at rest change by {change:e} between t = {t} and t = {other}), so a system at \
         rest there does not stay at rest; pass the time to solve at (t= in Python, \
         StaticsOptions::frozen_time in Rust) for the balance of the forces frozen at that instant"
    )]
    NoStaticEquilibrium {
        /// Time asked for.
        t: f64,
        /// A later time at which the forces differ.
        other: f64,
        /// Configuration at which they were compared.
        q: Vec<f64>,
        /// Norm of the change of the residual between the two times.
        change: f64,
    },

    /// An adaptive step size fell below its floor (`Options::min_step`, at least 10 ε |t|).
    #[error(
        "step size {h:e} at t = {t} fell below its floor: the solution may be singular there, \
         or the problem is stiff for this method"
    )]
    StepSizeTooSmall {
        /// Time reached.
        t: f64,
        /// Step size that was too small.
        h: f64,
    },

    /// The step budget `Options::max_steps` ran out before the end of the span, or a fixed-step
    /// run needs more steps than a budget the caller set and is refused before taking them.
    #[error("{}", too_many_steps(*t, *steps, *needed))]
    TooManySteps {
        /// Time reached (for a refused fixed-step run, where it stands: nothing was taken from it).
        t: f64,
        /// Steps taken; for a refused fixed-step run, the budget.
        steps: usize,
        /// The steps a refused fixed-step run needs in all; `None` when the budget ran out
        /// during the run.
        needed: Option<usize>,
    },

    /// An explicit method's step size is limited by stability, not accuracy (Hairer's test).
    #[error(
        "the problem looks stiff for {method} at t = {t} after {steps} steps: the step size is \
         limited by stability, not accuracy; use an implicit method such as {suggestion}"
    )]
    Stiffness {
        /// Time at which stiffness was detected.
        t: f64,
        /// The method that detected it.
        method: &'static str,
        /// A method suited to stiff problems.
        suggestion: &'static str,
        /// Steps accepted until then.
        steps: usize,
    },

    /// A fixed step beyond the stability limit of an explicit method: a mode of the linearised
    /// equations at the start would grow by `growth` per step instead of oscillating or decaying.
    #[error(
        "dt = {dt:e} is beyond the stability limit of {method}: the equations linearised at \
         t = {t} have a mode with |λ| = {mode:.3e} (time scale {:.3e}) that this step would amplify \
         {growth:.3} times per step; take dt ≤ {limit:.3e}, or an implicit method that is \
         stable at any step (radau5 for stiff springs and heavy damping, gauss4 or midpoint for \
         conservative systems)",
        1.0 / mode
    )]
    UnstableStep {
        /// The explicit method.
        method: &'static str,
        /// The step asked for.
        dt: f64,
        /// Time of the linearisation (the start of the run).
        t: f64,
        /// |λ| of the fastest offending mode.
        mode: f64,
        /// Spectral radius of the method's one-step propagator on that mode at `dt`.
        growth: f64,
        /// The largest stable step for that mode.
        limit: f64,
    },

    /// The Newton iteration of an implicit step did not converge, even after the step was
    /// halved as often as allowed.
    #[error(
        "Newton iteration of an implicit step did not converge at t = {t} after {iterations} \
         iterations (residual {residual:e}): use a smaller dt or tighter tolerances, check the \
         model for a singularity or a blow-up near t, or use radau5 if the problem is stiff"
    )]
    NewtonFailure {
        /// Start time of the step that failed.
        t: f64,
        /// Newton iterations in the last attempt.
        iterations: usize,
        /// Norm of the last residual (or of the last Newton increment), scaled as the method
        /// measures convergence.
        residual: f64,
    },

    /// The method cannot integrate this system.
    #[error("{method} cannot integrate this system: {why}; methods that fit: {fits:?}")]
    UnsupportedMethod {
        /// The method asked for.
        method: &'static str,
        /// What in the system rules it out.
        why: String,
        /// The methods that fit.
        fits: Vec<&'static str>,
    },

    /// The caller's interrupt check stopped the run (see `integrators::solve_with_interrupt`).
    #[error("integration interrupted at t = {t}")]
    Interrupted {
        /// Time reached.
        t: f64,
    },
}

/// Shorthand for results of this crate.
pub type Result<T> = std::result::Result<T, Error>;

/// The message of [`Error::TooManySteps`]: a refused fixed-step run says that no step was taken.
fn too_many_steps(t: f64, steps: usize, needed: Option<usize>) -> String {
    match needed {
        None => format!(
            "{steps} steps taken by t = {t} without reaching the end of the span: raise max_steps, \
             loosen the tolerances or use a larger dt"
        ),
        Some(_) if steps == usize::MAX => format!(
            "the fixed step needs more than {steps} steps to reach the end of the span: no step \
             was taken from t = {t}; use a larger dt"
        ),
        Some(needed) => format!(
            "the fixed step needs {needed} steps to reach the end of the span, more than \
             max_steps = {steps}: no step was taken from t = {t}; raise max_steps or use a \
             larger dt"
        ),
    }
}
