//! The integration-method registry seen from Python: the method names, what a name stands for,
//! and the check of a method and its step options that `simulate` makes, without a run.

use super::args::{StepOptions, run_options};
use crate::integrators::Method;
use pyo3::prelude::*;
use std::str::FromStr;

/// The integration method names `simulate` accepts: "auto" and every method of the registry.
#[pyfunction]
pub(super) fn methods() -> Vec<&'static str> {
    std::iter::once("auto")
        .chain(Method::ALL.iter().map(|m| m.name()))
        .collect()
}

/// `(name, adaptive, order)` of a method name (case-insensitive, aliases such as "verlet"
/// resolved); `adaptive` and `order` are `None` for "auto".
#[pyfunction]
pub(super) fn method_info(name: &str) -> PyResult<(&'static str, Option<bool>, Option<usize>)> {
    let m = Method::from_str(name)?;
    Ok((m.name(), m.is_adaptive(), m.order()))
}

/// Check a method and its step options as `simulate` checks them, without running: the same
/// `ValueError`, for callers that plan many runs (work–precision).
#[pyfunction]
#[pyo3(signature = (t0, t_end, method="auto", dt=None, rtol=1e-6, atol=1e-9))]
pub(super) fn check_options(
    t0: f64,
    t_end: f64,
    method: &str,
    dt: Option<f64>,
    rtol: f64,
    atol: f64,
) -> PyResult<()> {
    run_options(
        (t0, t_end),
        method,
        StepOptions { dt, rtol, atol },
        None,
        (None, None),
    )
    .map(|_| ())
}
