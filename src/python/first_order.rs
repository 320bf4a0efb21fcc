//! The model as a first-order system y = (q, q̇), ẏ = (q̇, q̈), in SciPy's `fun(t, y)` and
//! `jac(t, y)` conventions, so that a model can be handed to `scipy.integrate.solve_ivp` as it is.
//!
//! The Jacobian is the one Radau IIA uses, by forward-mode AD
//! ([`crate::dynamics::acceleration_jacobian`]); no finite differences.

use crate::dynamics::Dynamics;
use crate::dynamics::acceleration_jacobian;
use nalgebra::DMatrix;
use num_dual::Dual64;
use numpy::ndarray::{Array2, ArrayViewD, Axis, Dimension, Ix1, Ix2, IxDyn};
use pyo3::PyResult;
use pyo3::exceptions::PyValueError;

/// `ValueError` unless every entry of `y` is finite.
fn check_finite_entries(y: &ArrayViewD<'_, f64>) -> PyResult<()> {
    match y.indexed_iter().find(|(_, x)| !x.is_finite()) {
        None => Ok(()),
        Some((at, x)) => {
            let at = at.slice().iter().map(|i| i.to_string()).collect::<Vec<_>>();
            Err(PyValueError::new_err(format!(
                "y[{}] = {x} is not finite",
                at.join(", ")
            )))
        }
    }
}

/// `ValueError` unless `t` is finite.
fn check_time(t: f64) -> PyResult<()> {
    if t.is_finite() {
        Ok(())
    } else {
        Err(PyValueError::new_err(format!("t = {t} is not finite")))
    }
}

fn shape_error(shape: &[usize], n: usize, batch: bool) -> pyo3::PyErr {
    let wanted = if batch {
        format!("({}, k) for k states", 2 * n)
    } else {
        format!("({},)", 2 * n)
    };
    PyValueError::new_err(format!(
        "y has shape {shape:?} but needs {wanted}: y = (q, q̇) of a model with {n} coordinates"
    ))
}

/// dy/dt = (q̇, q̈) at (t, y): y of shape (2n,), or (2n, k) for k states as `solve_ivp`'s
/// `vectorized=True` passes them (one column per state).
pub(super) fn rhs<S: Dynamics + ?Sized>(
    system: &S,
    t: f64,
    y: ArrayViewD<'_, f64>,
) -> PyResult<numpy::ndarray::ArrayD<f64>> {
    let n = system.dof();
    let shape = y.shape().to_vec();
    let batch = shape.len() == 2;
    if !(shape.len() == 1 || batch) || shape[0] != 2 * n {
        return Err(shape_error(&shape, n, batch));
    }
    check_time(t)?;
    check_finite_entries(&y)?;
    let columns = if batch { shape[1] } else { 1 };
    let y2 = if batch {
        y.into_dimensionality::<Ix2>()
    } else {
        y.into_dimensionality::<Ix1>()
            .map(|v| v.insert_axis(Axis(1)))
    }
    .map_err(|e| PyValueError::new_err(e.to_string()))?;
    let mut out = Array2::<f64>::zeros((2 * n, columns));
    let (mut q, mut qd, mut qdd) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    for (k, column) in y2.axis_iter(Axis(1)).enumerate() {
        for i in 0..n {
            q[i] = column[i];
            qd[i] = column[n + i];
        }
        system.accelerations_into(t, &q, &qd, &mut qdd)?;
        for i in 0..n {
            out[(i, k)] = qd[i];
            out[(n + i, k)] = qdd[i];
        }
    }
    let dims = if batch {
        IxDyn(&[2 * n, columns])
    } else {
        IxDyn(&[2 * n])
    };
    out.into_shape_with_order(dims)
        .map_err(|e| PyValueError::new_err(e.to_string()))
}

/// The 2n × 2n Jacobian ∂ẏ/∂y = [[0, I], [∂q̈/∂q, ∂q̈/∂q̇]] at (t, y), y of shape (2n,).
pub(super) fn jacobian<S: Dynamics + ?Sized>(
    system: &S,
    t: f64,
    y: ArrayViewD<'_, f64>,
) -> PyResult<Array2<f64>> {
    let n = system.dof();
    let shape = y.shape().to_vec();
    if shape.len() != 1 || shape[0] != 2 * n {
        return Err(shape_error(&shape, n, false));
    }
    check_time(t)?;
    check_finite_entries(&y)?;
    let y = y.iter().copied().collect::<Vec<f64>>();
    let mut xd = vec![Dual64::from_re(0.0); 2 * n];
    let mut fd = vec![Dual64::from_re(0.0); n];
    let mut lower = DMatrix::<f64>::zeros(n, 2 * n);
    acceleration_jacobian(system, t, &y, &mut xd, &mut fd, &mut lower)?;
    crate::checks::finite(lower.as_slice(), "Jacobian", t)?;
    Ok(Array2::from_shape_fn((2 * n, 2 * n), |(i, j)| {
        if i < n {
            if j == n + i { 1.0 } else { 0.0 }
        } else {
            lower[(i - n, j)]
        }
    }))
}
