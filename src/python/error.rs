//! The exception classes of the Python module and the mapping of [`Error`] onto them.
//!
//! Bad input (wrong lengths, unknown names, invalid options, a method that cannot serve the
//! system) is a `ValueError`; failures of the mathematics are subclasses of `LagrangianError`,
//! each message saying where (t) and what to try; [`Error::Interrupted`] is `KeyboardInterrupt`.
//! A failure of `simulate` during the run carries what was computed (see [`with_partial`]).

use crate::error::Error;
use crate::integrators::Failed;
use numpy::PyArray1;
use pyo3::create_exception;
use pyo3::exceptions::{PyKeyboardInterrupt, PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use std::panic::{AssertUnwindSafe, catch_unwind};

create_exception!(
    lagrangian,
    LagrangianError,
    PyRuntimeError,
    "Base class of the failures of the mathematics: a singular mass matrix, a step size that \
     collapses, stiffness, Newton iterations that do not converge, non-finite values."
);
create_exception!(
    lagrangian,
    SingularMassMatrixError,
    LagrangianError,
    "The mass matrix M = ∂²T/∂q̇² is singular, indefinite or not finite at some state: a \
     coordinate without inertia, or a degenerate parametrisation."
);
create_exception!(
    lagrangian,
    StepSizeError,
    LagrangianError,
    "An adaptive step size fell below its floor, or the step budget ran out, before the end of \
     the span."
);
create_exception!(
    lagrangian,
    TooManyStepsError,
    StepSizeError,
    "The step budget `max_steps` ran out before the end of the span, or a fixed step needs more \
     steps than it allows (then no step was taken)."
);
create_exception!(
    lagrangian,
    StiffnessError,
    LagrangianError,
    "An explicit method found its step size limited by stability rather than accuracy: use an \
     implicit method such as radau5."
);
create_exception!(
    lagrangian,
    ConvergenceError,
    LagrangianError,
    "A Newton iteration (statics, or an implicit step) did not converge."
);
create_exception!(
    lagrangian,
    NonFiniteError,
    LagrangianError,
    "A NaN or an infinity appeared in the model or the solution."
);

/// Every variant is listed (no wildcard), so a new error variant cannot compile until it has a
/// Python class.
impl From<Error> for PyErr {
    fn from(e: Error) -> Self {
        let msg = e.to_string();
        match e {
            Error::DimensionMismatch { .. }
            | Error::InvalidInput { .. }
            | Error::SceneArgument { .. }
            | Error::NotTraceable { .. }
            | Error::UnsupportedMethod { .. }
            | Error::NoStaticEquilibrium { .. }
            | Error::DependentConstraints { .. }
            | Error::NonlinearVelocityConstraint { .. } => PyValueError::new_err(msg),
            Error::InconsistentState { .. } => PyValueError::new_err(msg),
            Error::ProjectionFailed { .. } => PyValueError::new_err(msg),
            Error::SingularMassMatrix { .. } => SingularMassMatrixError::new_err(msg),
            Error::NonFinite { .. } => NonFiniteError::new_err(msg),
            Error::StepSizeTooSmall { .. } => StepSizeError::new_err(format!(
                "{msg}. Try method=\"radau5\" if the problem is stiff, looser rtol/atol, or look \
                 at the model near this t for a singularity"
            )),
            Error::TooManySteps { .. } => TooManyStepsError::new_err(msg),
            Error::Stiffness { .. } | Error::UnstableStep { .. } => StiffnessError::new_err(msg),
            Error::NoConvergence { .. } | Error::NewtonFailure { .. } => {
                ConvergenceError::new_err(msg)
            }
            Error::Interrupted { .. } => PyKeyboardInterrupt::new_err(msg),
        }
    }
}

/// Attributes of every `LagrangianError` that a failed run fills: the partial solution and
/// the last accepted state `t`, `q`, `qd`. They are `None` on the class, so on any failure
/// that came before the first step (or outside `simulate`).
pub(crate) const PARTIAL_ATTRIBUTES: [&str; 4] = ["solution", "t", "q", "qd"];

/// The Python exception of a failed run, carrying the partial solution (made by `wrap`, with
/// the error's message) and the last accepted state when the run had started. `energy` is the
/// partial trajectory's energy, `conserved` whether it is a constant of the run.
pub(crate) fn with_partial(
    py: Python<'_>,
    failed: Failed,
    energy: Vec<f64>,
    reactions: Option<super::solution::Reactions>,
    conserved: bool,
    wrap: &super::solution::Wrap<'_, '_>,
) -> PyErr {
    let Failed {
        error,
        partial,
        last,
    } = failed;
    let err = PyErr::from(error);
    if let (Some(sol), Some(last)) = (partial, last) {
        let value = err.value(py);
        let attach = || -> PyResult<()> {
            let run = super::solution::RunOutput {
                sol,
                energy,
                conserved,
                reactions,
                sensitivities: None,
            };
            let message = value.str()?.to_string();
            value.setattr("solution", wrap.wrap(run, Some(message))?)?;
            Ok(())
        };
        if let Err(e) = attach() {
            return e;
        }
        return with_last(py, err, Some(last));
    }
    err
}

/// `err` carrying the last accepted state of a failed run as `t`, `q`, `qd`, when it had one.
pub(crate) fn with_last(
    py: Python<'_>,
    err: PyErr,
    last: Option<(f64, Vec<f64>, Vec<f64>)>,
) -> PyErr {
    if let Some((t, q, qd)) = last {
        let value = err.value(py);
        let attach = || -> PyResult<()> {
            value.setattr("t", t)?;
            value.setattr("q", PyArray1::from_vec(py, q))?;
            value.setattr("qd", PyArray1::from_vec(py, qd))?;
            Ok(())
        };
        if let Err(e) = attach() {
            return e;
        }
    }
    err
}

/// A panic caught at the boundary: a bug, reported as `LagrangianError` rather than
/// `PanicException` (which does not derive from `Exception`).
pub(crate) fn panic_error(payload: Box<dyn std::any::Any + Send>) -> PyErr {
    let what = payload
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| payload.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "unknown panic".into());
    LagrangianError::new_err(format!(
        "internal error in lagrangian ({what}); please report it with the model that caused it"
    ))
}

/// Run `f`, turning a panic into `LagrangianError`.
pub(super) fn guard<T>(f: impl FnOnce() -> PyResult<T>) -> PyResult<T> {
    catch_unwind(AssertUnwindSafe(f)).unwrap_or_else(|p| Err(panic_error(p)))
}
