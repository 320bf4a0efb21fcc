//! States from Python on the fast path: `model.accelerations(t, q, qd)` and its siblings read
//! (t, q, q̇) here when they already have the form the core needs, and evaluate one state or a
//! batch of them without a round trip through NumPy in Python.
//!
//! The form: t a float or an int, q and q̇ C-contiguous float64 NumPy arrays of the same shape
//! (n,) or (k, n), or lists of n floats or ints, every entry finite. Anything else is `None`: the package
//! then converts and checks the arguments in Python (`_validate.py` holds every message) and
//! calls again, so this module never has to say what is wrong, only that it is not the fast form.

use numpy::{PyArray1, PyArray2, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyFloat, PyInt, PyList};

/// One state (`rows` = `None`) or k states, row after row in `q` and `qd`.
pub(super) struct States {
    pub(super) t: f64,
    pub(super) q: Vec<f64>,
    pub(super) qd: Vec<f64>,
    pub(super) rows: Option<usize>,
}

impl States {
    /// (t, q, q̇) in the fast form for a model with `n` coordinates, or `None`.
    pub(super) fn read(
        t: &Bound<'_, PyAny>,
        q: &Bound<'_, PyAny>,
        qd: &Bound<'_, PyAny>,
        n: usize,
    ) -> Option<Self> {
        let t = number(t).filter(|t| t.is_finite())?;
        let (q, q_rows) = entries(q, n)?;
        let (qd, qd_rows) = entries(qd, n)?;
        (q_rows == qd_rows).then_some(Self {
            t,
            q,
            qd,
            rows: q_rows,
        })
    }

    /// The number of states.
    pub(super) fn count(&self) -> usize {
        self.rows.unwrap_or(1)
    }

    /// State `k` as (q, q̇) slices of length `n`.
    pub(super) fn state(&self, k: usize, n: usize) -> (&[f64], &[f64]) {
        let at = k * n..(k + 1) * n;
        (&self.q[at.clone()], &self.qd[at])
    }
}

/// One state vector of `n` finite entries in the fast form (a float64 array of shape (n,) or a
/// list of n floats or ints), or `None`.
pub(super) fn vector(v: &Bound<'_, PyAny>, n: usize) -> Option<Vec<f64>> {
    match entries(v, n)? {
        (values, None) => Some(values),
        _ => None,
    }
}

/// A float or an int (not a bool), as `f64`.
fn number(x: &Bound<'_, PyAny>) -> Option<f64> {
    let int = x.is_instance_of::<PyInt>() && !x.is_instance_of::<PyBool>();
    if x.is_instance_of::<PyFloat>() || int {
        x.extract::<f64>().ok()
    } else {
        None
    }
}

/// The finite entries of a float64 array of shape (n,) or (k, n), or of a list of n floats, and
/// k for the 2-D case.
fn entries(v: &Bound<'_, PyAny>, n: usize) -> Option<(Vec<f64>, Option<usize>)> {
    // `cast` and `to_vec` skip NumPy's borrow tracking (measured: 1 µs of a 2 µs call); the
    // values are copied at once, with the GIL held, so nothing can change them meanwhile.
    // A list first: its check is a flag of its type, NumPy's a look-up of NumPy's types.
    let (values, rows) = if let Ok(list) = v.cast::<PyList>() {
        (list.len() == n).then_some(())?;
        let mut values = Vec::with_capacity(n);
        for x in list.iter() {
            values.push(number(&x)?);
        }
        (values, None)
    } else if let Ok(a) = v.cast::<PyArray1<f64>>() {
        (a.len() == n).then_some(())?;
        (a.to_vec().ok()?, None)
    } else if let Ok(a) = v.cast::<PyArray2<f64>>() {
        (a.shape()[1] == n).then_some(())?;
        (a.to_vec().ok()?, Some(a.shape()[0]))
    } else {
        return None;
    };
    values
        .iter()
        .all(|x| x.is_finite())
        .then_some((values, rows))
}
