//! Linearization and modes for Python ([`crate::linearize`], [`crate::modes`]): matrices as
//! NumPy arrays, complex values as separate real and imaginary arrays (assembled in
//! `python/lagrangian/_linear.py`).

use super::model::CompiledModel;
use crate::dynamics::Dynamics;
use crate::statics::{Linearization, ModeProblem, Modes, Stability, linearize, modes};
use nalgebra::{Complex, DMatrix, DVector};
use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray1, PyArray2};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyTuple;

/// The name Python uses for a stability verdict.
pub(super) fn stability_name(s: Stability) -> &'static str {
    match s {
        Stability::Stable => "stable",
        Stability::Unstable => "unstable",
        Stability::Neutral => "neutral",
    }
}

fn matrix<'py>(py: Python<'py>, m: &DMatrix<f64>) -> Bound<'py, PyArray2<f64>> {
    Array2::from_shape_fn(m.shape(), |(i, j)| m[(i, j)]).into_pyarray(py)
}

fn vector<'py>(py: Python<'py>, v: &DVector<f64>) -> Bound<'py, PyArray1<f64>> {
    PyArray1::from_slice(py, v.as_slice())
}

/// (re, im) of complex values.
pub(super) fn complex_vector<'py>(
    py: Python<'py>,
    v: &DVector<Complex<f64>>,
) -> (Bound<'py, PyArray1<f64>>, Bound<'py, PyArray1<f64>>) {
    let re: Vec<f64> = v.iter().map(|z| z.re).collect();
    let im: Vec<f64> = v.iter().map(|z| z.im).collect();
    (PyArray1::from_vec(py, re), PyArray1::from_vec(py, im))
}

/// (t, q, qd, accelerations, M, C, K, A, eigenvalues re, eigenvalues im).
fn linearization_tuple<'py>(py: Python<'py>, lin: &Linearization) -> PyResult<Bound<'py, PyTuple>> {
    let (re, im) = complex_vector(py, &lin.eigenvalues);
    (
        lin.t,
        vector(py, &lin.q),
        vector(py, &lin.qd),
        vector(py, &lin.accelerations),
        matrix(py, &lin.m),
        matrix(py, &lin.c),
        matrix(py, &lin.k),
        matrix(py, &lin.a),
        re,
        im,
    )
        .into_pyobject(py)
}

/// [`linearize`] as a pair: the tuple of `linearization_tuple`, and B = ∂ẋ/∂u for the
/// parameters `inputs` (indices; `None` for no B), which only a model with an expression graph
/// (`compiled`) can give.
pub(super) fn linearize_py<'py, S: Dynamics + ?Sized>(
    py: Python<'py>,
    system: &S,
    compiled: Option<&CompiledModel>,
    (t, q, qd): (f64, &[f64], &[f64]),
    inputs: Option<(&[usize], &[f64])>,
) -> PyResult<Bound<'py, PyTuple>> {
    let lin = linearize(system, t, q, qd)?;
    let b = match inputs {
        None => None,
        Some((inputs, params)) => {
            let compiled = compiled.ok_or_else(|| {
                PyValueError::new_err(
                    "inputs= needs a model stated in Python (lg.Model with parameters=...): a \
                     ready-made scene is written in Rust and has no expressions to differentiate",
                )
            })?;
            Some(matrix(py, &compiled.input_matrix(params, inputs, &lin)?))
        }
    };
    (linearization_tuple(py, &lin)?, b).into_pyobject(py)
}

/// [`modes`] as a tuple: (problem, frequencies, ω², damping ratios, shapes re, shapes im,
/// eigenvalues re, eigenvalues im, stability, reason, linearization tuple).
pub(super) fn modes_py<'py, S: Dynamics + ?Sized>(
    py: Python<'py>,
    system: &S,
    t: f64,
    q: &[f64],
) -> PyResult<Bound<'py, PyTuple>> {
    let found: Modes = modes(system, t, q)?;
    modes_tuple(py, &found)
}

/// A [`Modes`] as the tuple of [`modes_py`].
pub(super) fn modes_tuple<'py>(py: Python<'py>, found: &Modes) -> PyResult<Bound<'py, PyTuple>> {
    let problem = match found.problem {
        ModeProblem::Undamped => "undamped",
        ModeProblem::StateSpace => "state_space",
    };
    let (re, im) = complex_vector(py, &found.eigenvalues);
    let shapes_re = found.shapes.map(|z| z.re);
    let shapes_im = found.shapes.map(|z| z.im);
    (
        problem,
        vector(py, &found.frequencies),
        vector(py, &found.omega_squared),
        vector(py, &found.damping_ratios),
        matrix(py, &shapes_re),
        matrix(py, &shapes_im),
        re,
        im,
        stability_name(found.stability),
        found.reason.clone(),
        linearization_tuple(py, &found.linearization)?,
    )
        .into_pyobject(py)
}
