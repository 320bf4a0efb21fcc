//! Python's arguments checked and converted before any work: vectors of the model's length,
//! finite times, counts from Python's signed integers, and a run's method and [`Options`] from
//! `simulate`'s keywords (validated by [`Options`]' own checks). Shared by `simulate`, the
//! ensemble and the integrator, so that each refuses the same input with the same `ValueError`.

use crate::integrators::{Method, Options, Output};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use std::str::FromStr;

/// `ValueError` unless `v` has `n` finite entries.
pub(super) fn check_vector(what: &str, v: &[f64], n: usize) -> PyResult<()> {
    if v.len() != n {
        return Err(PyValueError::new_err(format!(
            "{what} has {} entries but the model has {n} coordinates",
            v.len()
        )));
    }
    if let Some((i, x)) = v.iter().enumerate().find(|(_, x)| !x.is_finite()) {
        return Err(PyValueError::new_err(format!(
            "{what}[{i}] = {x} is not finite"
        )));
    }
    Ok(())
}

/// A count from Python's signed integers: `ValueError` for a negative one (zero and up are
/// validated with the options).
pub(super) fn count(what: &str, v: i64) -> PyResult<usize> {
    usize::try_from(v)
        .map_err(|_| PyValueError::new_err(format!("{what} = {v}: a count cannot be negative")))
}

/// How a run steps, as Python states it: a signed fixed `dt`, or tolerances.
pub(super) struct StepOptions {
    pub(super) dt: Option<f64>,
    pub(super) rtol: f64,
    pub(super) atol: f64,
}

/// The method and options of a run over `span` from Python's arguments (a signed `dt`, counts
/// as signed integers, `t_eval` or `every`), validated by [`Options`]' own checks.
pub(super) fn run_options(
    span: (f64, f64),
    method: &str,
    step: StepOptions,
    max_steps: Option<i64>,
    output: (Option<Vec<f64>>, Option<i64>),
) -> PyResult<(Method, Options)> {
    let method = Method::from_str(method)?;
    let mut options = match step.dt {
        Some(dt) => Options::fixed_towards(dt, span)?,
        None => Options::adaptive(step.rtol, step.atol),
    };
    if let Some(max_steps) = max_steps {
        options.max_steps = count("max_steps", max_steps)?;
    }
    options.output = match output {
        (Some(_), Some(_)) => {
            return Err(PyValueError::new_err(
                "give t_eval or output_every, not both",
            ));
        }
        (Some(times), None) => Output::Times(times),
        (None, Some(k)) => Output::Every(count("output_every", k)?),
        (None, None) => Output::Steps,
    };
    options.validate(span.0, span.1)?;
    options.check_method(method)?;
    Ok((method, options))
}

/// `ValueError` unless `x` is finite.
pub(super) fn check_finite(what: &str, x: f64) -> PyResult<()> {
    if x.is_finite() {
        Ok(())
    } else {
        Err(PyValueError::new_err(format!("{what} = {x} is not finite")))
    }
}
