//! `simulate_many`: an ensemble of runs of one model in Rust, on a rayon pool with the GIL
//! released ([`crate::integrators::solve_many`]); `Model.simulate_many` and `Ensemble` in
//! `python/lagrangian/_ensemble.py` wrap it.
//!
//! Each run is exactly what `simulate` computes for it: the same options ([`run_options`]), the
//! same [`solve_partial`](crate::integrators::solve_partial). A parameter sweep binds the
//! compiled model to each run's parameter values (nothing is recompiled) or, for a scene,
//! builds the scene from each run's arguments, on the thread that runs it. Ctrl-C is polled
//! from one place, the calling thread, every 20 ms; the runs only read an atomic flag.

use super::args::{StepOptions, check_finite, run_options};
use super::events::{CompiledEvent, EventSpec};
use super::model::{AnyModel, Backend};
use super::py_model::{PyModel, scene_run};
use super::scenes;
use crate::dynamics::Dynamics;
use crate::error::{Error, Result};
use crate::integrators::{
    Failed, Method, Occurrences, Output, RunResult, Solution, Statistics, Status, Systems,
    solve_many,
};
use crate::scenes::registry::Arguments;
use crate::trace::FastPath;
use numpy::ndarray::{Array1, Array2, Array3, ArrayView2};
use numpy::{IntoPyArray, PyArray1, PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::IntoPyObjectExt;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList, PyTuple};
use std::collections::HashMap;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{RecvTimeoutError, channel};
use std::time::Duration;

/// Integrate the model from each row of `q0`, `qd0` (shape (k, n)) over (t0, t_end), on
/// `workers` threads (0: one per core). `params` (shape (k, p)) binds a compiled model to each
/// run's parameter values; `scenes` gives a scene's arguments for each run. `events` are
/// compiled once (with `backend`); an event whose `event_params` entry is an array (shape
/// (k, its parameters)) is bound to row i in run i, the others to their spec's values. Returns
/// `(t, q, qd, reached, counters, method, choice, choices, failures, status, events,
/// residuals, path, paths)`, where
/// by output mode:
///
/// - `t_eval`: `t` the times, `q` and `qd` of shape (k, len(t), n);
/// - `final_only`: `t` of shape (k,), `q` and `qd` of shape (k, n);
/// - otherwise: lists of k arrays, one per run;
///
/// rows not reached by a failed run are zeros, and `reached` (k,) counts the rows each run
/// filled. `counters` (k, 6) are the statistics in [`Statistics::COUNTERS`]' order, `method` (k,) the index
/// of the method that ran in `methods()` (−1: none ran), `choice` (k,) the index of Auto's reason
/// in `choices` (−1: none), and `failures` a list of `(run, error class name, message, t)`
/// with `t` the last accepted time (`None` when the run failed before its first step);
/// `status` (k,) is as `simulate`'s (0 reached t_end, 1 a terminal event, −1 failed) and
/// `events` per run a pair: one (t, q, qd) per event, as `simulate`'s, and the message of the
/// terminal event that stopped it (else `None`) — an empty list when there are no events;
/// `residuals` (k,) the worst constraint residual after an accepted step of each run (0 without
/// constraints); `path` (k,) the index of a scene's route in `paths` (−1: not a scene, or the
/// Taylor method). `error_coordinates` is [`Options::error_coordinates`](crate::Options) (a
/// variational system's runs with the sensitivities left out of error control).
#[pyfunction]
#[pyo3(signature = (model, q0, qd0, t_end, t0=0.0, params=None, scenes=None, method="auto",
                    dt=None, rtol=1e-6, atol=1e-9, t_eval=None, max_steps=None,
                    final_only=false, workers=0, events=Vec::new(), event_params=Vec::new(),
                    backend="native", error_coordinates=None))]
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
    events: Vec<EventSpec>,
    event_params: Vec<Option<PyReadonlyArray2<'py, f64>>>,
    backend: &str,
    error_coordinates: Option<usize>,
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
        StepOptions { dt, rtol, atol },
        max_steps,
        (times.clone(), None),
    )?;
    options.error_coordinates = error_coordinates;
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
    let events = ensemble_events(events, event_params, k, n, backend)?;
    let per_run = events.iter().any(|(_, p)| p.is_some());
    if !per_run {
        options.events = events
            .iter()
            .map(|(e, _)| e.bind(None))
            .collect::<Result<_>>()?;
    } else if params.is_none() && scenes.is_none() {
        return Err(PyValueError::new_err(
            "event parameters per run need a parameter sweep",
        ));
    }
    // Every event bound for run i, in the order given (only with parameters per run).
    let bind_events = |i: usize| -> Result<Vec<crate::integrators::Event>> {
        events
            .iter()
            .map(|(e, p)| {
                let w = e.parameters();
                e.bind(p.as_ref().map(|p| &p[i * w..(i + 1) * w]))
            })
            .collect()
    };
    // Each run as `simulate` runs it: a scene's on its own `FastPath` (the switch counts the
    // run's evaluations, so a run in an ensemble is the run alone, bit for bit).
    let run = |m: AnyModel| {
        if m.is_scene() {
            Route::Scene(scene_run(Box::new(m)))
        } else {
            Route::Owned(Box::new(m))
        }
    };
    let with_events = |i: usize| -> Result<(Route, Vec<crate::integrators::Event>)> {
        Ok((run(bind(i)?), bind_events(i)?))
    };
    let each = |i: usize| bind(i).map(run);
    let shared = &*model.model;
    let one = |_: usize| -> Result<Route<'_>> { Ok(Route::Shared(scene_run(shared))) };
    let systems = if per_run {
        Systems::EachWithEvents(&with_events)
    } else if params.is_some() || scenes.is_some() {
        Systems::Each(&each)
    } else if shared.is_scene() {
        Systems::Each(&one)
    } else {
        Systems::One(&Route::Borrowed(shared))
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
        (Output::Final, _) => OutputLayout::Final,
        (_, Some(times)) => OutputLayout::Times(times),
        _ => OutputLayout::Steps,
    };
    ensemble_tuple(py, runs, mode, n, events.len())
}

/// Each event compiled once, with the values for each run (row-major, k rows) where given.
fn ensemble_events(
    specs: Vec<EventSpec>,
    params: Vec<Option<PyReadonlyArray2<'_, f64>>>,
    k: usize,
    n: usize,
    backend: &str,
) -> PyResult<Vec<(CompiledEvent, Option<Vec<f64>>)>> {
    if params.len() > specs.len() {
        return Err(PyValueError::new_err(format!(
            "{} event parameter arrays for {} events",
            params.len(),
            specs.len()
        )));
    }
    let backend = Backend::named(backend)?;
    let mut params = params.into_iter();
    specs
        .into_iter()
        .map(|spec| {
            let event = CompiledEvent::new(spec, n, backend)?;
            let values = match params.next().flatten() {
                None => None,
                Some(p) => {
                    let w = event.parameters();
                    if p.shape() != [k, w] {
                        return Err(PyValueError::new_err(format!(
                            "event parameters of shape {:?}: {k} runs of an event in {w} \
                             parameters need ({k}, {w})",
                            p.shape()
                        )));
                    }
                    Some(rows(p.as_array()))
                }
            };
            Ok((event, values))
        })
        .collect()
}

/// The entries of a 2-D array, row after row.
fn rows(a: ArrayView2<'_, f64>) -> Vec<f64> {
    a.iter().copied().collect()
}

/// How the runs' states are laid out for Python.
enum OutputLayout {
    Times(Vec<f64>),
    Final,
    Steps,
}

/// The tuple [`simulate_many`] returns.
fn ensemble_tuple<'py>(
    py: Python<'py>,
    runs: Vec<RunResult>,
    mode: OutputLayout,
    n: usize,
    events: usize,
) -> PyResult<Bound<'py, PyTuple>> {
    let k = runs.len();
    let mut status = Array1::<i8>::from_elem(k, -1);
    let found = PyList::empty(py);
    let mut reached = Array1::<i64>::zeros(k);
    let mut counters = Array2::<i64>::zeros((k, Statistics::COUNTERS.len()));
    let mut residuals = Array1::<f64>::zeros(k);
    let mut method = Array1::<i64>::from_elem(k, -1);
    let mut choice = Array1::<i64>::from_elem(k, -1);
    let mut choices: HashMap<String, usize> = HashMap::new();
    let mut path = Array1::<i64>::from_elem(k, -1);
    let mut paths: HashMap<String, usize> = HashMap::new();
    let failures = PyList::empty(py);
    let mut solutions: Vec<Option<Solution>> = Vec::with_capacity(k);
    for (i, run) in runs.into_iter().enumerate() {
        let mut sol = match run {
            Ok(sol) => {
                status[i] = super::solution::status_code(&sol.status);
                Some(sol)
            }
            Err(Failed {
                error,
                partial,
                last,
            }) => {
                failures.append(failure(py, i, error, last.map(|(t, _, _)| t))?)?;
                partial
            }
        };
        // Without events nothing per run: a sweep of 10⁶ runs would otherwise build 10⁶ empty
        // Python lists.
        if events > 0 {
            let occurrences = match &mut sol {
                Some(sol) => std::mem::take(&mut sol.events),
                None => vec![Occurrences::default(); events],
            };
            // The message of a terminal event, as `simulate` gives it; the others follow from
            // the status (or the failure).
            let terminal = sol
                .as_ref()
                .filter(|s| matches!(s.status, Status::Terminated { .. }))
                .map(|s| s.status.to_string());
            found.append((super::events::occurrences(py, occurrences, n)?, terminal))?;
        }
        if let Some(sol) = &sol {
            let s = &sol.stats;
            reached[i] = sol.len() as i64;
            for (j, (_, count)) in Statistics::COUNTERS.iter().enumerate() {
                counters[(i, j)] = count(s) as i64;
            }
            residuals[i] = s.constraint_residual;
            method[i] = 1 + Method::ALL.iter().position(|m| *m == s.method).unwrap_or(0) as i64;
            if let Some(why) = &s.choice {
                let next = choices.len();
                choice[i] = *choices.entry(why.clone()).or_insert(next) as i64;
            }
            if let Some(why) = &s.scene_path {
                let next = paths.len();
                path[i] = *paths.entry(why.clone()).or_insert(next) as i64;
            }
        }
        solutions.push(sol);
    }
    let mut choices: Vec<(String, usize)> = choices.into_iter().collect();
    choices.sort_by_key(|(_, j)| *j);
    let choices: Vec<String> = choices.into_iter().map(|(s, _)| s).collect();
    let mut paths: Vec<(String, usize)> = paths.into_iter().collect();
    paths.sort_by_key(|(_, j)| *j);
    let paths: Vec<String> = paths.into_iter().map(|(s, _)| s).collect();
    let (t, q, qd) = match mode {
        OutputLayout::Times(times) => {
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
        OutputLayout::Final => {
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
        OutputLayout::Steps => {
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
    // More items than pyo3's tuples convert: each converted alone.
    PyTuple::new(
        py,
        [
            t,
            q,
            qd,
            reached.into_pyarray(py).into_any(),
            counters.into_pyarray(py).into_any(),
            method.into_pyarray(py).into_any(),
            choice.into_pyarray(py).into_any(),
            choices.into_bound_py_any(py)?,
            failures.into_any(),
            status.into_pyarray(py).into_any(),
            found.into_any(),
            residuals.into_pyarray(py).into_any(),
            path.into_pyarray(py).into_any(),
            paths.into_bound_py_any(py)?,
        ],
    )
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

/// A run of an ensemble: the model as it is, or a scene on its own [`FastPath`] (as `simulate`
/// runs it).
#[derive(Debug)]
enum Route<'a> {
    Borrowed(&'a AnyModel),
    Owned(Box<AnyModel>),
    Shared(FastPath<&'a AnyModel>),
    Scene(FastPath<Box<AnyModel>>),
}

/// `$body` with `$s` bound to the system inside whichever variant `$route` is.
macro_rules! route {
    ($route:expr, $s:ident => $body:expr) => {
        match $route {
            Route::Borrowed(m) => {
                let $s: &AnyModel = m;
                $body
            }
            Route::Owned(m) => {
                let $s: &AnyModel = m;
                $body
            }
            Route::Shared($s) => $body,
            Route::Scene($s) => $body,
        }
    };
}

impl Dynamics for Route<'_> {
    crate::dynamics::forward_dynamics!(route!: dof, structure, kinetic_energy, potential_energy,
        potential_gradient_into, generalized_forces_into, dissipative_forces_into, momenta_into,
        mass_matrix_into, accelerations_into, lagrangian, derived_program, taylor_program, energy,
        constraints);
    fn scene_path(&self) -> Option<String> {
        route!(self, s => s.scene_path())
    }
}
