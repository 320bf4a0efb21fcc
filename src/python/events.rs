//! Events stated in Python (`lagrangian.Event`), compiled like the energies, and the continuous
//! solution (`simulate(..., dense=True)`) as a Python object.
//!
//! A condition and a reset are expressions in t, q, q̇ and the model's parameters; each is
//! compiled to a tape over the model's inputs (machine code with the `native` backend) and
//! bound to the parameter values, so the search on every step runs no Python.

use std::sync::Arc;

use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray1, PyArray2, PyReadonlyArray1};
use pyo3::prelude::*;
use pyo3::types::PyTuple;

use super::model::{Backend, RawNode, node_ids};
use crate::error::{Error, Result};
use crate::integrators::{Dense, DenseParts, Direction, Event};
use crate::tape::{Function, Inputs, Tape};

/// One event as the package sends it: the serialized expressions, the condition's output, the
/// reset's targets (velocity or not, coordinate) and outputs, the parameter values, direction
/// (−1, 0, +1), terminal count (0: not terminal), name and interior samples per step.
pub(crate) type EventSpec = (
    Vec<RawNode>,
    usize,
    Vec<(bool, usize)>,
    Vec<usize>,
    Vec<f64>,
    i64,
    i64,
    String,
    i64,
);

/// f(t, q, q̇, out) of compiled expressions.
type Eval = Arc<dyn Fn(f64, &[f64], &[f64], &mut [f64]) + Send + Sync>;

/// The outputs `roots` of the serialized graph as one function of (t, q, q̇) at `f64`.
fn compile(
    nodes: &[RawNode],
    roots: &[usize],
    dof: usize,
    params: &[f64],
    backend: Backend,
    what: &'static str,
) -> Result<Eval> {
    let (g, ids) = node_ids(nodes)?;
    let roots = roots
        .iter()
        .map(|&o| {
            ids.get(o).copied().ok_or_else(|| Error::InvalidInput {
                what: "event",
                why: format!("{what}: output {o} is not a node"),
            })
        })
        .collect::<Result<Vec<_>>>()?;
    let tape = Tape::new(&g, &roots, Inputs::kinetic(dof, params.len()), what)?;
    let function = Function::new(Arc::new(tape), params)?;
    if backend == Backend::Native
        && let Ok(native) = function.compile_native()
    {
        return Ok(Arc::new(move |t, q, qd, out| {
            native.eval_into(t, q, qd, out)
        }));
    }
    Ok(Arc::new(move |t, q, qd, out| {
        function.eval_into(t, q, qd, out)
    }))
}

/// The [`Event`] of a spec, for a model with `dof` coordinates.
pub(crate) fn event(spec: EventSpec, dof: usize, backend: Backend) -> Result<Event> {
    let (nodes, condition, targets, resets, params, direction, terminal, name, samples) = spec;
    let bad = |why: String| Error::InvalidInput { what: "event", why };
    let g = compile(
        &nodes,
        &[condition],
        dof,
        &params,
        backend,
        "event condition",
    )?;
    let mut event = Event::new(name.clone(), move |t, q, qd| {
        let mut out = [0.0];
        g(t, q, qd, &mut out);
        out[0]
    })
    .with_direction(Direction::from_sign(direction)?)
    .with_samples(
        usize::try_from(samples)
            .map_err(|_| bad(format!("event {name:?}: samples = {samples} is negative")))?,
    );
    if terminal < 0 {
        return Err(bad(format!(
            "event {name:?}: terminal = {terminal}: give True, False or a count ≥ 1"
        )));
    }
    if terminal > 0 {
        event = event.terminal(terminal as usize);
    }
    if !targets.is_empty() {
        if targets.len() != resets.len() {
            return Err(bad(format!(
                "event {name:?}: {} reset targets for {} values",
                targets.len(),
                resets.len()
            )));
        }
        if let Some(&(_, i)) = targets.iter().find(|(_, i)| *i >= dof) {
            return Err(bad(format!(
                "event {name:?}: reset of coordinate {i} in a model of {dof}"
            )));
        }
        let values = compile(&nodes, &resets, dof, &params, backend, "event reset")?;
        event = event.with_reset(move |t, q, qd| {
            // Every new value from the state before the reset, then written.
            let mut new = vec![0.0; targets.len()];
            values(t, q, qd, &mut new);
            for (&(velocity, i), v) in targets.iter().zip(new) {
                if velocity {
                    qd[i] = v;
                } else {
                    q[i] = v;
                }
            }
        });
    }
    Ok(event)
}

/// The continuous solution of a run (`Solution.__call__` in the package).
#[pyclass(name = "DenseSolution", module = "lagrangian._lagrangian", frozen)]
pub struct PyDense {
    dense: Dense,
}

impl PyDense {
    pub(crate) fn new(dense: Dense) -> Self {
        Self { dense }
    }
}

#[pymethods]
impl PyDense {
    /// (q, q̇) at the times `t` (1-D), each of shape (len(t), dof).
    fn eval<'py>(
        &self,
        py: Python<'py>,
        t: PyReadonlyArray1<'py, f64>,
    ) -> PyResult<Bound<'py, PyTuple>> {
        let times = t.as_slice()?;
        let dim = self.dense.dim();
        let n = dim / 2;
        let mut q = Array2::<f64>::zeros((times.len(), n));
        let mut qd = Array2::<f64>::zeros((times.len(), n));
        let mut y = vec![0.0; dim];
        for (k, &ti) in times.iter().enumerate() {
            self.dense.eval(ti, &mut y)?;
            for i in 0..n {
                q[(k, i)] = y[i];
                qd[(k, i)] = y[n + i];
            }
        }
        let (q, qd): (Bound<'py, PyArray2<f64>>, Bound<'py, PyArray2<f64>>) =
            (q.into_pyarray(py), qd.into_pyarray(py));
        (q, qd).into_pyobject(py)
    }

    /// Order of the interpolant.
    #[getter]
    fn order(&self) -> usize {
        self.dense.order()
    }

    /// What interpolates between the steps.
    #[getter]
    fn interpolant(&self) -> &'static str {
        self.dense.interpolant()
    }

    /// (first, last) time covered.
    #[getter]
    fn span(&self) -> Option<(f64, f64)> {
        self.dense.span()
    }

    /// Steps kept.
    #[getter]
    fn steps(&self) -> usize {
        self.dense.steps()
    }

    /// Pickling: rebuilt from its parts by `_restore`.
    fn __reduce__<'py>(slf: &Bound<'py, Self>) -> PyResult<(Bound<'py, PyAny>, (DenseParts,))> {
        let restore = slf.get_type().getattr("_restore")?;
        Ok((restore, (slf.get().dense.to_parts(),)))
    }

    /// The solution of pickled parts.
    #[staticmethod]
    fn _restore(parts: DenseParts) -> PyResult<Self> {
        Ok(Self::new(Dense::from_parts(parts)?))
    }
}

/// The occurrences of each event as (t, q, q̇) arrays, q and q̇ of shape (k, dof).
pub(crate) fn occurrences<'py>(
    py: Python<'py>,
    found: Vec<crate::integrators::Occurrences>,
    n: usize,
) -> PyResult<Vec<Bound<'py, PyTuple>>> {
    found
        .into_iter()
        .map(|o| {
            let k = o.t.len();
            let shape = |v: Vec<f64>| {
                Array2::from_shape_vec((k, n), v)
                    .map_err(|e| pyo3::exceptions::PyValueError::new_err(e.to_string()))
            };
            let (q, qd) = (shape(o.q)?, shape(o.qd)?);
            let t: Bound<'py, PyArray1<f64>> = PyArray1::from_vec(py, o.t);
            (t, q.into_pyarray(py), qd.into_pyarray(py)).into_pyobject(py)
        })
        .collect()
}
