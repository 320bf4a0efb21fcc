//! A run kept between calls: [`PyIntegrator`] (`lagrangian.Integrator`, made by
//! `Model.integrator`) holds a state (t, q, q̇) and the method and options, parsed once, and
//! `propagate_until(t)` integrates that state to t in place.
//!
//! Why: a short run through `simulate` pays for its arguments, its options, the `Solution` and
//! its arrays on every call (most of a run of a few dozen steps: see docs/site/taylor.rst's
//! comparison with heyoka.py, whose `taylor_adaptive.propagate_until` is this interface). Here the options
//! are parsed once, only the final state is kept, and nothing is made in Python but what is read.

use super::args::{check_finite, check_vector};
use super::error::{self, guard};
use super::interrupt::{ctrl_c, interrupted};
use super::{solution, states};
use crate::dynamics::Dynamics;
use crate::error::Error;
use crate::integrators::{Method, Options, Output, Solution, Statistics, Status, solve_resumed};
use crate::python::model::AnyModel;
use numpy::PyArray1;
use pyo3::prelude::*;
use pyo3::sync::PyOnceLock;
use pyo3::types::PyDict;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::sync::{Arc, Mutex};

/// An integrator standing at a state (t, q, q̇), with its method and options: each
/// `propagate_until(t)` continues from where the last one ended (or from a state assigned to
/// `t`, `q`, `qd`).
///
/// Made by `Model.integrator`. ``"auto"`` chooses its method at the first `propagate_until`
/// (from the state and that span) and keeps it. A terminal event ends a call where it fires;
/// the next call starts from there. A call that fails raises with the last accepted state as
/// `err.t`, `err.q`, `err.qd` and leaves the integrator where it was. Not for sharing between
/// threads (a second thread's call while one runs raises `RuntimeError`); not picklable.
#[pyclass(name = "Integrator", module = "lagrangian._lagrangian")]
pub struct PyIntegrator {
    model: Arc<AnyModel>,
    method: Method,
    options: Options,
    /// Whether h is a constant of the runs (`stats["conserved"]`).
    conserved: bool,
    t: f64,
    /// q then q̇.
    y: Vec<f64>,
    /// The last finished call's work, with the choice of `"auto"` kept from the first.
    stats: Option<Statistics>,
    /// The name of the terminal event that ended the last call, if one did.
    event: Option<String>,
    /// The events whose root the integrator stands on (the last call's end, until `t` changes,
    /// also when q or q̇ are assigned): the next call takes their sign a thousandth into its
    /// first step, as a run does after a reset, so that they do not fire again where they just
    /// did (a crossing before that thousandth is not seen).
    settling: Vec<usize>,
}

impl PyIntegrator {
    /// An integrator at (t0, q0, q̇0) with `method` and `options`, checked here once (each
    /// call's run checks them again, at a fraction of its cost); the output is the final state.
    pub(super) fn new(
        model: Arc<AnyModel>,
        (t0, q0, qd0): (f64, Vec<f64>, Vec<f64>),
        method: Method,
        mut options: Options,
        conserved: bool,
    ) -> PyResult<Self> {
        let n = model.dof();
        check_finite("t0", t0)?;
        check_vector("q0", &q0, n)?;
        check_vector("qd0", &qd0, n)?;
        options.output = Output::Final;
        options.dense = false;
        // Any span: with `Output::Final` the checks do not depend on it.
        options.validate(t0, t0 + 1.0)?;
        options.check_method(method)?;
        method.check_fits(&*model, t0, &q0, &qd0)?;
        let mut y = q0;
        y.extend_from_slice(&qd0);
        Ok(Self {
            model,
            method,
            options,
            conserved,
            t: t0,
            y,
            stats: None,
            event: None,
            settling: Vec::new(),
        })
    }

    /// A state vector assigned from Python ([`state_vector`]).
    fn vector(&self, what: &str, v: &Bound<'_, PyAny>) -> PyResult<Vec<f64>> {
        state_vector(what, v, self.model.dof())
    }

    /// Stand at the end of a finished call: its state, its work, and the events that ended it
    /// or sit on their roots there (a terminal one, or a reset within round-off of the end).
    fn stand(&mut self, sol: Solution, t0: f64) -> PyResult<&'static str> {
        let n = self.model.dof();
        let Some((t, q, qd)) = sol.last() else {
            return Err(error::LagrangianError::new_err(
                "internal error in lagrangian (a finished run kept no state); please report it",
            ));
        };
        self.t = t;
        self.y[..n].copy_from_slice(q);
        self.y[n..].copy_from_slice(qd);
        // Events found at one stop lie within round-off of each other, relative to t and to the
        // step (at most the span).
        let scale = t.abs().max((t - t0).abs());
        let near = |s: f64| (t - s).abs() <= 10.0 * f64::EPSILON * scale.max(s.abs());
        self.settling = (sol.events.iter().enumerate())
            .filter(|(_, found)| found.t.last().is_some_and(|&s| near(s)))
            .map(|(i, _)| i)
            .collect();
        let mut stats = sol.stats;
        if self.method == Method::Auto {
            self.method = stats.method;
        } else if let Some(first) = &self.stats {
            stats.choice.clone_from(&first.choice);
        }
        self.stats = Some(stats);
        self.event = match sol.status {
            Status::Terminated { name, .. } => Some(name),
            _ => None,
        };
        Ok(if self.event.is_some() {
            "terminated"
        } else {
            "finished"
        })
    }
}

#[pymethods]
impl PyIntegrator {
    /// Integrate from the current state to `t` (before the current time integrates backwards)
    /// and stand there. Returns ``"finished"`` when it reached `t`, ``"terminated"`` when a
    /// terminal event stopped it first (the integrator stands at the event; `event` names it).
    // `Failed` is a few hundred bytes, once per call (as in `solve_partial`).
    #[allow(clippy::result_large_err)]
    fn propagate_until(&mut self, py: Python<'_>, t: f64) -> PyResult<&'static str> {
        check_finite("t", t)?;
        if t == self.t {
            self.event = None;
            return Ok("finished");
        }
        let n = self.model.dof();
        let (q, qd) = self.y.split_at(n);
        let (model, method, options, t0) = (&*self.model, self.method, &self.options, self.t);
        let settling = &self.settling[..];
        let pending: Mutex<Option<PyErr>> = Mutex::new(None);
        let outcome = py.detach(|| {
            catch_unwind(AssertUnwindSafe(|| {
                let interrupt = ctrl_c(&pending);
                let span = (t0, t);
                solve_resumed(
                    model,
                    q,
                    qd,
                    span,
                    method,
                    options,
                    Some(&interrupt),
                    settling,
                )
            }))
        });
        match outcome {
            Err(panic) => Err(error::panic_error(panic)),
            Ok(Err(failed)) => Err(match failed.error {
                Error::Interrupted { t } => interrupted(&pending, t),
                e => error::with_last(py, e.into(), failed.last),
            }),
            Ok(Ok(sol)) => self.stand(sol, t0),
        }
    }

    /// The current time.
    #[getter]
    fn get_t(&self) -> f64 {
        self.t
    }

    /// Move to time `t`, the state unchanged (the events the integrator stood on the roots of no
    /// longer settle there, unless `t` is unchanged).
    #[setter]
    fn set_t(&mut self, t: f64) -> PyResult<()> {
        check_finite("t", t)?;
        if t != self.t {
            self.settling.clear();
        }
        self.t = t;
        Ok(())
    }

    /// The current coordinates (a copy).
    #[getter]
    fn get_q<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, &self.y[..self.model.dof()])
    }

    /// Assign the coordinates: `dof` finite numbers.
    #[setter]
    fn set_q(&mut self, q: &Bound<'_, PyAny>) -> PyResult<()> {
        let q = self.vector("q", q)?;
        self.y[..q.len()].copy_from_slice(&q);
        Ok(())
    }

    /// The current velocities (a copy).
    #[getter]
    fn get_qd<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, &self.y[self.model.dof()..])
    }

    /// Assign the velocities: `dof` finite numbers. At a terminal event the event keeps
    /// settling on its root, so that an impact law of one's own (q̇ reversed) goes on from it.
    #[setter]
    fn set_qd(&mut self, qd: &Bound<'_, PyAny>) -> PyResult<()> {
        let qd = self.vector("qd", qd)?;
        let n = qd.len();
        self.y[n..].copy_from_slice(&qd);
        Ok(())
    }

    /// The method: the one `"auto"` chose once the first call has run, else the one given.
    #[getter]
    fn method(&self) -> &'static str {
        self.method.name()
    }

    /// The terminal event that stopped the last call (its name), or `None`.
    #[getter]
    fn event(&self) -> Option<&str> {
        self.event.as_deref()
    }

    /// The work of the last call that finished, as `Solution.stats` (`None` before one has);
    /// ``"choice"`` says why `"auto"` chose the method.
    #[getter]
    fn stats<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        guard(|| {
            self.stats
                .as_ref()
                .map(|s| {
                    let constrained = self.model.constrained().is_some();
                    solution::stats_dict(py, s, self.conserved, constrained)
                })
                .transpose()
        })
    }

    fn __repr__(&self) -> String {
        format!(
            "Integrator(method={:?}, t={}, dof={})",
            self.method.name(),
            self.t,
            self.model.dof()
        )
    }
}

/// A state vector of `n` entries from Python, for the constructor and the setters alike: the
/// fast form (a list of n numbers, a float64 array of shape (n,), finite) read here, anything
/// else converted and checked by the package's `vector`, so both accept the same and say the
/// same (a new integrator per run spent 3 µs in `vector` and `list` before).
pub(super) fn state_vector(what: &str, v: &Bound<'_, PyAny>, n: usize) -> PyResult<Vec<f64>> {
    if let Some(v) = states::vector(v, n) {
        return Ok(v);
    }
    static VECTOR: PyOnceLock<Py<PyAny>> = PyOnceLock::new();
    let py = v.py();
    let vector = VECTOR.get_or_try_init(py, || -> PyResult<Py<PyAny>> {
        Ok(py
            .import("lagrangian._validate")?
            .getattr("vector")?
            .unbind())
    })?;
    vector.bind(py).call1((what, v, n))?.extract()
}
