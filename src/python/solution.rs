//! A finished run as `simulate` hands it to the package ([`PySolution`], `NativeSolution` in
//! Python): the package's `Solution` keeps it and makes each of its fields (arrays, the
//! statistics dict, the events, the message) a Python object only when it is first read.
//!
//! Why: a short run's cost is mostly its fixed cost, and building every field up front was a
//! third of it (measured on a one-step Taylor run of the forced two-mass system, callgrind:
//! 7 800 of the 25 000 instructions of the native call went to four NumPy arrays, the dict, the
//! message and the 9-tuple holding them).

use super::{ensemble, events};
use crate::integrators::{Solution, Status};
use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray1};
use pyo3::exceptions::{PyAttributeError, PyValueError};
use pyo3::intern;
use pyo3::prelude::*;
use pyo3::sync::PyOnceLock;
use pyo3::types::{PyDict, PyTuple};

/// SciPy's status of a run: 0 it reached t_end, 1 a terminal event stopped it, −1 it failed.
pub(crate) fn status_code(status: &Status) -> i8 {
    match status {
        Status::Finished => 0,
        Status::Terminated { .. } => 1,
        Status::Failed | Status::Unfinished { .. } => -1,
    }
}

/// A run's solution, the energy function h at its points, whether h is a constant of the run
/// (`stats["conserved"]`), and the fields made so far.
#[pyclass(name = "NativeSolution", module = "lagrangian._lagrangian")]
pub struct PySolution {
    sol: Solution,
    energy: Vec<f64>,
    conserved: bool,
    made: Vec<(String, Py<PyAny>)>,
}

impl PySolution {
    pub(crate) fn new(sol: Solution, energy: Vec<f64>, conserved: bool) -> Self {
        Self {
            sol,
            energy,
            conserved,
            made: Vec::new(),
        }
    }

    /// The field `name`, made now (its arrays take the solution's vectors, without a copy).
    fn make<'py>(&mut self, py: Python<'py>, name: &str) -> PyResult<Bound<'py, PyAny>> {
        let n = self.sol.dof;
        let sol = &mut self.sol;
        match name {
            "t" => Ok(PyArray1::from_vec(py, std::mem::take(&mut sol.t)).into_any()),
            "q" => Self::rows(py, std::mem::take(&mut sol.q), n),
            "qd" => Self::rows(py, std::mem::take(&mut sol.qd), n),
            "energy" => Ok(PyArray1::from_vec(py, std::mem::take(&mut self.energy)).into_any()),
            "stats" => Ok(self.stats(py)?.into_any()),
            "events" => {
                let found = events::occurrences(py, std::mem::take(&mut sol.events), n)?;
                let (mut t, mut q, mut qd) = (Vec::new(), Vec::new(), Vec::new());
                for o in found {
                    t.push(o.get_item(0)?);
                    q.push(o.get_item(1)?);
                    qd.push(o.get_item(2)?);
                }
                Ok(PyTuple::new(py, [t, q, qd])?.into_any())
            }
            "status" => Ok(status_code(&sol.status).into_pyobject(py)?.into_any()),
            "message" => Ok(sol.status.to_string().into_pyobject(py)?.into_any()),
            "_dense" => match sol.dense.take() {
                Some(d) => Ok(Bound::new(py, events::PyDense::new(d))?.into_any()),
                None => Ok(py.None().into_bound(py)),
            },
            _ => Err(PyAttributeError::new_err(format!(
                "a run has no field {name:?}"
            ))),
        }
    }

    /// The statistics dict: a copy of a template that has every key (no key made, hashed or
    /// inserted on a call, no growing of the table).
    fn stats<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        static STATS: PyOnceLock<Py<PyDict>> = PyOnceLock::new();
        let template = STATS.get_or_try_init(py, || -> PyResult<Py<PyDict>> {
            let d = PyDict::new(py);
            let keys = ["method", "choice"].into_iter().chain(ensemble::COUNTERS);
            for key in keys.chain(["conserved"]) {
                d.set_item(key, py.None())?;
            }
            Ok(d.unbind())
        })?;
        let s = &self.sol.stats;
        let stats = template.bind(py).copy()?;
        stats.set_item(intern!(py, "method"), s.method.name())?;
        stats.set_item(intern!(py, "choice"), s.choice.clone())?;
        stats.set_item(intern!(py, "accepted_steps"), s.accepted_steps)?;
        stats.set_item(intern!(py, "rejected_steps"), s.rejected_steps)?;
        stats.set_item(intern!(py, "rhs_evaluations"), s.rhs_evaluations)?;
        stats.set_item(intern!(py, "jacobian_evaluations"), s.jacobian_evaluations)?;
        stats.set_item(intern!(py, "factorizations"), s.factorizations)?;
        stats.set_item(intern!(py, "newton_failures"), s.newton_failures)?;
        stats.set_item(intern!(py, "conserved"), self.conserved)?;
        Ok(stats)
    }

    /// Rows of `n` values as an array of shape (rows, n), without a copy.
    fn rows<'py>(py: Python<'py>, values: Vec<f64>, n: usize) -> PyResult<Bound<'py, PyAny>> {
        let rows = values.len().checked_div(n).unwrap_or(0);
        let a = Array2::from_shape_vec((rows, n), values)
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        Ok(a.into_pyarray(py).into_any())
    }
}

#[pymethods]
impl PySolution {
    /// The `Solution` attribute `name` (`t`, `q`, `qd`, `energy`, `stats`, `events` — the
    /// three event lists as a tuple —, `status`, `message` or `_dense`): made at the first
    /// request, the same object at the next ones.
    fn field<'py>(&mut self, py: Python<'py>, name: &str) -> PyResult<Bound<'py, PyAny>> {
        if let Some((_, made)) = self.made.iter().find(|(n, _)| n == name) {
            return Ok(made.bind(py).clone());
        }
        let made = self.make(py, name)?;
        self.made.push((name.to_owned(), made.clone().unbind()));
        Ok(made)
    }
}
