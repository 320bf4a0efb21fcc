//! `simulate_many`: an ensemble of runs of one model in Rust, on a rayon pool with the GIL
//! released ([`crate::integrators::solve_many`]); `Model.simulate_many` and `Ensemble` in
//! `python/lagrangian/_ensemble.py` wrap it.
//!
//! Each run is exactly what `simulate` computes for it: the same options ([`run_options`]), the
//! same [`solve_partial`](crate::integrators::solve_partial). A parameter sweep binds the
//! compiled model to each run's parameter values (nothing is recompiled) or, for a scene,
//! builds the scene from each run's arguments, on the thread that runs it. Ctrl-C is polled
//! from one place, the calling thread, every 20 ms; the runs only read an atomic flag.

use super::model::AnyModel;
use super::{PyModel, Step, check_finite, run_options, scenes};
use crate::integrators::{Failed, Method, Output, RunResult, Solution, Systems, solve_many};
use crate::scenes::registry::Arguments;
use crate::{Dynamics, Error, Result};
use numpy::ndarray::{Array1, Array2, Array3, ArrayView2};
use numpy::{IntoPyArray, PyArray1, PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList, PyTuple};
use std::collections::HashMap;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{RecvTimeoutError, channel};
use std::time::Duration;

/// The counters of [`crate::integrators::Statistics`], in this order, as columns.
const COUNTERS: [&str; 6] = [
    "accepted_steps",
    "rejected_steps",
    "rhs_evaluations",
    "jacobian_evaluations",
    "factorizations",
    "newton_failures",
];

/// Integrate the model from each row of `q0`, `qd0` (shape (k, n)) over (t0, t_end), on
/// `workers` threads (0: one per core). `params` (shape (k, p)) binds a compiled model to each
/// run's parameter values; `scenes` gives a scene's arguments for each run. Returns
/// `(t, q, qd, reached, counters, method, choice, choices, failures)`, where by output mode:
///
/// - `t_eval`: `t` the times, `q` and `qd` of shape (k, len(t), n);
/// - `final_only`: `t` of shape (k,), `q` and `qd` of shape (k, n);
/// - otherwise: lists of k arrays, one per run;
///
/// rows not reached by a failed run are zeros, and `reached` (k,) counts the rows each run
/// filled. `counters` (k, 6) are the statistics in [`COUNTERS`]' order, `method` (k,) the index
/// of the method that ran in `methods()` (−1: none ran), `choice` (k,) the index of Auto's reason
/// in `choices` (−1: none), and `failures` a list of `(run, error class name, message, t)`
/// with `t` the last accepted time (`None` when the run failed before its first step).
#[pyfunction]
#[pyo3(signature = (model, q0, qd0, t_end, t0=0.0, params=None, scenes=None, method="auto",
                    dt=None, rtol=1e-6, atol=1e-9, t_eval=None, max_steps=None,
                    final_only=false, workers=0))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn simulate_many<'py>(
    py: Python<'py>,
    model: &PyModel,
    q0: PyReadonlyArray2<'py, f64>,
    qd0: PyReadonlyArray2<'py, f64>,
    t_end: f64,
    t0: f64,
    params: Option<PyReadonlyArray2<'py, f64>>,
    scenes: Option<(String, Vec<Bound<'py, PyDict>>)>,
    method: &str,
    dt: Option<f64>,
    rtol: f64,
    atol: f64,
    t_eval: Option<PyReadonlyArray1<'py, f64>>,
    max_steps: Option<i64>,
    final_only: bool,
    workers: usize,
) -> PyResult<Bound<'py, PyTuple>> {
    let n = model.model.dof();
    let k = q0.shape()[0];
    for (what, v) in [("q0", &q0), ("qd0", &qd0)] {
        if v.shape() != [k, n] {
            return Err(PyValueError::new_err(format!(
                "{what} has shape {:?} but {k} runs of {n} coordinates need ({k}, {n})",
                v.shape()
            )));
        }
    }
    let (q0, qd0) = (rows(q0.as_array()), rows(qd0.as_array()));
    check_finite("t0", t0)?;
    check_finite("t_end", t_end)?;
    let times: Option<Vec<f64>> = t_eval.map(|t| t.as_array().iter().copied().collect());
    let (method, mut options) = run_options(
        (t0, t_end),
        method,
        Step { dt, rtol, atol },
        max_steps,
        (times.clone(), None),
    )?;
    if final_only {
        if times.is_some() {
            return Err(PyValueError::new_err("give t_eval or final_only, not both"));
        }
        options.output = Output::Final;
    }
    let params = params.map(|p| rows(p.as_array()));
    let scenes = scenes
        .map(|(name, each)| {
            each.iter()
                .map(|args| scenes::arguments(&name, args))
                .collect::<PyResult<Vec<Arguments>>>()
        })
        .transpose()?;
    let compiled = model.compiled.as_deref();
    let bind = |i: usize| -> Result<AnyModel> {
        match (&params, compiled, &scenes) {
            (Some(p), Some(c), _) => c.bind(&p[i * c.params..(i + 1) * c.params]),
            (_, _, Some(s)) => AnyModel::scene(&s[i]),
            _ => unreachable!("checked below"),
        }
    };
    match (&params, compiled, &scenes) {
        (Some(p), Some(c), None) if p.len() == k * c.params => {}
        (None, _, Some(s)) if s.len() == k => {}
        (None, _, None) => {}
        _ => {
            return Err(PyValueError::new_err(format!(
                "parameters for {k} runs: a (k, p) array for a compiled model, or k scene \
                 arguments for a scene"
            )));
        }
    }
    let systems = if params.is_some() || scenes.is_some() {
        Systems::Each(&bind)
    } else {
        Systems::One(&*model.model)
    };
    let initial: Vec<(&[f64], &[f64])> = q0.chunks_exact(n).zip(qd0.chunks_exact(n)).collect();

    let stop = AtomicBool::new(false);
    let pending: Mutex<Option<PyErr>> = Mutex::new(None);
    let interrupt = |_t: f64| stop.load(Ordering::Relaxed);
    let outcome = py.detach(|| {
        std::thread::scope(|scope| {
            let (done, finished) = channel();
            let (systems, initial, options) = (&systems, &initial, &options);
            scope.spawn(move || {
                let runs = catch_unwind(AssertUnwindSafe(|| {
                    solve_many(
                        *systems,
                        initial,
                        (t0, t_end),
                        method,
                        options,
                        workers,
                        Some(&interrupt),
                    )
                }));
                // The receiver waits for this message; it cannot have gone.
                let _ = done.send(runs);
            });
            // Poll Python's signal handlers (Ctrl-C) here, every 20 ms, until the runs end.
            loop {
                match finished.recv_timeout(Duration::from_millis(20)) {
                    Ok(runs) => return runs,
                    Err(RecvTimeoutError::Timeout) => {
                        if !stop.load(Ordering::Relaxed)
                            && let Err(e) = Python::attach(|py| py.check_signals())
                        {
                            *pending.lock().unwrap_or_else(|p| p.into_inner()) = Some(e);
                            stop.store(true, Ordering::Relaxed);
                        }
                    }
                    Err(RecvTimeoutError::Disconnected) => {
                        let why: Box<dyn std::any::Any + Send> =
                            Box::new("the ensemble's thread ended without a result");
                        return Err(why);
                    }
                }
            }
        })
    });
    let runs = outcome.map_err(super::error::panic_error)??;
    if let Some(e) = pending.lock().unwrap_or_else(|p| p.into_inner()).take() {
        return Err(e);
    }
    let mode = match (&options.output, times) {
        (Output::Final, _) => Mode::Final,
        (_, Some(times)) => Mode::Times(times),
        _ => Mode::Steps,
    };
    ensemble_tuple(py, runs, mode, n)
}

/// The entries of a 2-D array, row after row.
fn rows(a: ArrayView2<'_, f64>) -> Vec<f64> {
    a.iter().copied().collect()
}

/// How the runs' states are laid out for Python.
enum Mode {
    Times(Vec<f64>),
    Final,
    Steps,
}

/// The tuple [`simulate_many`] returns.
fn ensemble_tuple<'py>(
    py: Python<'py>,
    runs: Vec<RunResult>,
    mode: Mode,
    n: usize,
) -> PyResult<Bound<'py, PyTuple>> {
    let k = runs.len();
    let mut reached = Array1::<i64>::zeros(k);
    let mut counters = Array2::<i64>::zeros((k, COUNTERS.len()));
    let mut method = Array1::<i64>::from_elem(k, -1);
    let mut choice = Array1::<i64>::from_elem(k, -1);
    let mut choices: HashMap<String, usize> = HashMap::new();
    let failures = PyList::empty(py);
    let mut solutions: Vec<Option<Solution>> = Vec::with_capacity(k);
    for (i, run) in runs.into_iter().enumerate() {
        let sol = match run {
            Ok(sol) => Some(sol),
            Err(Failed {
                error,
                partial,
                last,
            }) => {
                failures.append(failure(py, i, error, last.map(|(t, _, _)| t))?)?;
                partial
            }
        };
        if let Some(sol) = &sol {
            let s = &sol.stats;
            reached[i] = sol.len() as i64;
            let c = [
                s.accepted_steps,
                s.rejected_steps,
                s.rhs_evaluations,
                s.jacobian_evaluations,
                s.factorizations,
                s.newton_failures,
            ];
            for (j, v) in c.into_iter().enumerate() {
                counters[(i, j)] = v as i64;
            }
            method[i] = 1 + Method::ALL.iter().position(|m| *m == s.method).unwrap_or(0) as i64;
            if let Some(why) = &s.choice {
                let next = choices.len();
                choice[i] = *choices.entry(why.clone()).or_insert(next) as i64;
            }
        }
        solutions.push(sol);
    }
    let mut choices: Vec<(String, usize)> = choices.into_iter().collect();
    choices.sort_by_key(|(_, j)| *j);
    let choices: Vec<String> = choices.into_iter().map(|(s, _)| s).collect();
    let (t, q, qd) = match mode {
        Mode::Times(times) => {
            let m = times.len();
            let mut q = Array3::<f64>::zeros((k, m, n));
            let mut qd = Array3::<f64>::zeros((k, m, n));
            for (i, sol) in solutions.iter().enumerate() {
                if let Some(sol) = sol {
                    for r in 0..sol.len() {
                        for j in 0..n {
                            q[(i, r, j)] = sol.q_at(r)[j];
                            qd[(i, r, j)] = sol.qd_at(r)[j];
                        }
                    }
                }
            }
            (
                PyArray1::from_vec(py, times).into_any(),
                q.into_pyarray(py).into_any(),
                qd.into_pyarray(py).into_any(),
            )
        }
        Mode::Final => {
            let mut t = Array1::<f64>::zeros(k);
            let mut q = Array2::<f64>::zeros((k, n));
            let mut qd = Array2::<f64>::zeros((k, n));
            for (i, sol) in solutions.iter().enumerate() {
                if let Some((ti, qi, qdi)) = sol.as_ref().and_then(|s| s.last()) {
                    t[i] = ti;
                    for j in 0..n {
                        q[(i, j)] = qi[j];
                        qd[(i, j)] = qdi[j];
                    }
                }
            }
            (
                t.into_pyarray(py).into_any(),
                q.into_pyarray(py).into_any(),
                qd.into_pyarray(py).into_any(),
            )
        }
        Mode::Steps => {
            let (ts, qs, qds) = (PyList::empty(py), PyList::empty(py), PyList::empty(py));
            for sol in solutions {
                let (t, q, qd) = sol.map_or_else(
                    || (Vec::new(), Vec::new(), Vec::new()),
                    |s| (s.t, s.q, s.qd),
                );
                let rows = t.len();
                let shape = |v: Vec<f64>| {
                    Array2::from_shape_vec((rows, n), v)
                        .map_err(|e| PyValueError::new_err(e.to_string()))
                };
                ts.append(PyArray1::from_vec(py, t))?;
                qs.append(shape(q)?.into_pyarray(py))?;
                qds.append(shape(qd)?.into_pyarray(py))?;
            }
            (ts.into_any(), qs.into_any(), qds.into_any())
        }
    };
    (
        t,
        q,
        qd,
        reached.into_pyarray(py),
        counters.into_pyarray(py),
        method.into_pyarray(py),
        choice.into_pyarray(py),
        choices,
        failures,
    )
        .into_pyobject(py)
}

/// `(run, error class name, message, t)` of a failed run: the class and message its Python
/// exception would have ([`super::error`]).
fn failure<'py>(
    py: Python<'py>,
    run: usize,
    error: Error,
    t: Option<f64>,
) -> PyResult<Bound<'py, PyTuple>> {
    let err = PyErr::from(error);
    let class = err.get_type(py).name()?.to_string();
    let message = err.value(py).str()?.to_string();
    (run, class, message, t).into_pyobject(py)
}
