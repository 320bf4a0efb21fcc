//! A finished run as `simulate` hands it to the package: [`PySolution`] (`NativeSolution` in
//! Python) is the base class of the package's `Solution`, and each of its fields (arrays, the
//! statistics dict, the events, the message) becomes a Python object only when first read.
//!
//! Why: a short run's cost is mostly its fixed cost. Building every field up front was a third
//! of it (one-step Taylor run of the forced two-mass system, callgrind: 7 800 of the 25 000
//! instructions of the native call went to four NumPy arrays, the dict, the message and the
//! tuple holding them). Making them on first read in Python (`__getattr__`) cost 5 800
//! instructions of interpreter per field (the failed slot lookup raises an `AttributeError`
//! first); a native getter costs a few hundred, and a field read again is the object kept.

use super::events;
use crate::integrators::{Solution, Statistics, Status};
use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray1};
use pyo3::exceptions::{PyAttributeError, PyRuntimeError, PyValueError};
use pyo3::intern;
use pyo3::prelude::*;
use pyo3::sync::PyOnceLock;
use pyo3::types::{PyDict, PyList, PyString, PyTuple, PyType};
use pyo3::{PyTraverseError, PyVisit};
use std::sync::{Mutex, MutexGuard, TryLockError};

/// SciPy's status of a run: 0 it reached t_end, 1 a terminal event stopped it, −1 it failed.
pub(crate) fn status_code(status: &Status) -> i8 {
    match status {
        Status::Finished => 0,
        Status::Terminated { .. } => 1,
        Status::Failed | Status::Unfinished { .. } => -1,
    }
}

/// What a run computed: the solution, the energy function h at its points and whether h is a
/// constant of the run (`stats["conserved"]`).
pub(crate) struct RunOutput {
    pub(crate) sol: Solution,
    pub(crate) energy: Vec<f64>,
    pub(crate) conserved: bool,
    /// The multipliers and reactions at the run's points, for a constrained model.
    pub(crate) reactions: Option<Reactions>,
    /// The sensitivities at the run's points and of its events' times, for a run of the
    /// variational system (`simulate(..., sensitivities=[...])`).
    pub(crate) sensitivities: Option<super::sensitivity::Sensitivities>,
}

/// λ (k per point) and the generalized reactions Gᵀλ (n per point) along a constrained run,
/// evaluated at its output states after the run.
#[derive(Debug, Default)]
pub(crate) struct Reactions {
    pub(crate) multipliers: Vec<f64>,
    pub(crate) rows: usize,
    pub(crate) forces: Vec<f64>,
}

/// The fields, listed once below: the `SolutionField` enum, their Python names, and the class's methods
/// with a getter and a setter per field (`del` is refused: a field keeps its value).
macro_rules! fields {
    ($($py:ident: $get:ident, $set:ident => $field:ident),* $(,)?) => {
        /// The fields of a `Solution`, in the order of [`FIELDS`].
        #[derive(Clone, Copy, PartialEq, Eq)]
        enum SolutionField {
            $($field,)*
        }

        /// The Python names of the fields (`NativeSolution.FIELDS`: what a pickle keeps).
        const FIELDS: &[&str] = &[$(stringify!($py)),*];

        #[pymethods]
        impl PySolution {
            /// An empty solution (the package's `Solution.__init__` assigns the fields; a
            /// native run is moved in by `simulate`).
            #[new]
            #[pyo3(signature = (*_args, **_kwargs))]
            fn new(
                _args: &Bound<'_, PyTuple>,
                _kwargs: Option<&Bound<'_, PyDict>>,
            ) -> Self {
                Self {
                    source: Mutex::new(Source { run: None, taken: 0 }),
                    making: std::array::from_fn(|_| PyOnceLock::new()),
                    values: Mutex::new(Default::default()),
                }
            }

            /// The names of the fields, in order (what a pickle keeps).
            #[classattr]
            #[allow(non_snake_case)]
            fn FIELDS(py: Python<'_>) -> PyResult<Py<PyTuple>> {
                Ok(PyTuple::new(py, FIELDS)?.unbind())
            }

            fn __traverse__(&self, visit: PyVisit<'_>) -> Result<(), PyTraverseError> {
                // Never locked while Python runs (see the type); a lock held elsewhere would
                // only skip this visit.
                let values = match self.values.try_lock() {
                    Ok(values) => values,
                    Err(TryLockError::Poisoned(p)) => p.into_inner(),
                    Err(TryLockError::WouldBlock) => return Ok(()),
                };
                for value in values.iter().flatten() {
                    visit.call(value)?;
                }
                Ok(())
            }

            fn __clear__(&self) {
                let values = std::mem::take(&mut *self.values());
                drop(values);
            }

            $(
                #[getter($py)]
                fn $get(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
                    self.get(py, SolutionField::$field)
                }

                #[setter($py)]
                fn $set(&self, value: Py<PyAny>) {
                    self.set(SolutionField::$field, value)
                }
            )*
        }
    };
}

fields! {
    t: t, set_t => T,
    q: q, set_q => Q,
    qd: qd, set_qd => Qd,
    energy: energy, set_energy => Energy,
    stats: stats, set_stats => Stats,
    t_events: t_events, set_t_events => TEvents,
    q_events: q_events, set_q_events => QEvents,
    qd_events: qd_events, set_qd_events => QdEvents,
    status: status, set_status => Status,
    message: message, set_message => Message,
    _dense: dense, set_dense => Dense,
    names: names, set_names => Names,
    event_names: event_names, set_event_names => EventNames,
    _y: y, set_y => Y,
    multipliers: multipliers, set_multipliers => Multipliers,
    constraint_forces: constraint_forces, set_constraint_forces => ConstraintForces,
    sensitivities: sensitivities, set_sensitivities => Sensitivities,
    event_sensitivities: event_sensitivities, set_event_sensitivities => EventSensitivities,
}

/// A field's value taken out of the run (under its lock, in plain Rust), to be made a Python
/// object after the lock is released.
enum Taken {
    Floats(Vec<f64>),
    Rows(Vec<f64>, usize),
    /// The statistics, whether h is conserved, whether the model is constrained.
    Stats(Box<Statistics>, bool, bool),
    Status(i8),
    Message(String),
    Events(Vec<crate::integrators::Occurrences>, usize),
    Dense(Option<crate::integrators::Dense>),
    /// A field a run without constraints does not have.
    Absent,
}

/// What a run computed, and which fields have been taken from it (a bit per [`SolutionField`]).
struct Source {
    run: Option<RunOutput>,
    taken: u16,
}

/// A run's fields: made from the run on first read, each once, or assigned from Python.
///
/// Frozen (no borrow flag), its mutable parts behind locks that are never held across a call
/// into Python: making a field can allocate, the allocation can collect garbage, a finalizer
/// can run Python code and another thread can read a field meanwhile. That thread waits for a
/// field being made (its gate is a [`PyOnceLock`], which detaches from the interpreter to
/// wait). The values are visited by Python's garbage collector, so a cycle through a solution
/// is collected.
#[pyclass(
    name = "NativeSolution",
    module = "lagrangian._lagrangian",
    subclass,
    frozen
)]
pub struct PySolution {
    /// What the run computed, taken field by field as the fields are made; no run for a
    /// `Solution` built from its fields.
    source: Mutex<Source>,
    /// One gate per field made from the run (one for the three event lists): the make runs
    /// once, and a field being made is waited for.
    making: [PyOnceLock<()>; 14],
    /// The fields' values: made, or assigned from Python (the constructor, unpickling, the
    /// user); an assigned value replaces (and releases) the one before.
    values: Mutex<[Option<Py<PyAny>>; FIELDS.len()]>,
}

/// `simulate`'s result type: the package's `Solution` (a subclass of [`PySolution`]), with the
/// model's coordinate names and the events' names that every run of this call carries.
pub(crate) struct Wrap<'a, 'py> {
    pub(crate) kind: &'a Bound<'py, PyType>,
    pub(crate) names: &'a Bound<'py, PyAny>,
    pub(crate) event_names: &'a Bound<'py, PyAny>,
}

impl<'py> Wrap<'_, 'py> {
    /// The run as an instance of `kind`; `failure` (the error's message) marks the partial
    /// solution of a failed run.
    pub(crate) fn wrap(
        &self,
        mut run: RunOutput,
        failure: Option<String>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let sensitivities = run.sensitivities.take();
        let py = self.kind.py();
        let message = match failure {
            Some(m) => Some(m.into_pyobject(py)?.into_any().unbind()),
            None => None,
        };
        let sol = self
            .kind
            .call_method1(intern!(py, "__new__"), (self.kind,))?;
        let native = sol.cast::<PySolution>()?.get();
        native.source().run = Some(run);
        native.set(SolutionField::Names, self.names.clone().unbind());
        native.set(SolutionField::EventNames, self.event_names.clone().unbind());
        if let Some(message) = message {
            native.set(SolutionField::Message, message);
        }
        if let Some(s) = sensitivities {
            // (outputs, directions, 2n) and, per event, (occurrences, directions): the
            // package names the columns.
            let rows = s.values.len() / (s.columns * s.width).max(1);
            let values =
                numpy::ndarray::Array3::from_shape_vec((rows, s.columns, s.width), s.values)
                    .map_err(|e| PyValueError::new_err(e.to_string()))?;
            native.set(
                SolutionField::Sensitivities,
                values.into_pyarray(py).into_any().unbind(),
            );
            let mut events = Vec::with_capacity(s.events.len());
            for e in s.events {
                let k = e.len() / s.columns.max(1);
                let e = Array2::from_shape_vec((k, s.columns), e)
                    .map_err(|e| PyValueError::new_err(e.to_string()))?;
                events.push(e.into_pyarray(py).into_any());
            }
            native.set(
                SolutionField::EventSensitivities,
                PyList::new(py, events)?.into_any().unbind(),
            );
        }
        Ok(sol)
    }
}

/// The error of a field that neither was assigned nor can be made.
fn missing(name: &str) -> PyErr {
    PyAttributeError::new_err(format!("the solution has no attribute '{name}'"))
}

impl PySolution {
    fn source(&self) -> MutexGuard<'_, Source> {
        self.source.lock().unwrap_or_else(|p| p.into_inner())
    }

    fn values(&self) -> MutexGuard<'_, [Option<Py<PyAny>>; FIELDS.len()]> {
        self.values.lock().unwrap_or_else(|p| p.into_inner())
    }

    fn value(&self, py: Python<'_>, field: SolutionField) -> Option<Py<PyAny>> {
        self.values()[field as usize]
            .as_ref()
            .map(|v| v.clone_ref(py))
    }

    /// The field: its value, else made from the run (once), else `None` for the names, the
    /// `y` cache and the sensitivities (assigned when the run has them); `AttributeError` for a field neither assigned nor in a run.
    fn get(&self, py: Python<'_>, field: SolutionField) -> PyResult<Py<PyAny>> {
        if let Some(value) = self.value(py, field) {
            return Ok(value);
        }
        // The gate: the field's index, the event lists' shared one, two fewer after them.
        let k = field as usize;
        let gate = match field {
            SolutionField::Names
            | SolutionField::EventNames
            | SolutionField::Y
            | SolutionField::Sensitivities
            | SolutionField::EventSensitivities => {
                return Ok(py.None());
            }
            SolutionField::TEvents | SolutionField::QEvents | SolutionField::QdEvents => {
                SolutionField::TEvents as usize
            }
            _ if k > SolutionField::QdEvents as usize => k - 2,
            _ => k,
        };
        self.making[gate].get_or_try_init(py, || self.make(py, field))?;
        self.value(py, field)
            .ok_or_else(|| missing(FIELDS[field as usize]))
    }

    /// Assign the field; the value it replaces is dropped after the lock is released (dropping
    /// it may run Python code).
    fn set(&self, field: SolutionField, value: Py<PyAny>) {
        let old = self.values()[field as usize].replace(value);
        drop(old);
    }

    /// Keep a made value, unless one was assigned meanwhile (then the made one is dropped).
    fn keep(&self, field: SolutionField, made: Py<PyAny>) {
        let mut values = self.values();
        let slot = &mut values[field as usize];
        let unused = if slot.is_none() {
            *slot = Some(made);
            None
        } else {
            Some(made)
        };
        drop(values);
        drop(unused);
    }

    /// The field's value taken out of the run (its vectors moved, not copied; the three event
    /// lists together). Taken once: a second take means the first make failed (a moved value
    /// is gone), which is an error rather than an empty value.
    fn take(&self, field: SolutionField) -> PyResult<Taken> {
        let mut source = self.source();
        let Source { run, taken } = &mut *source;
        let name = FIELDS[field as usize];
        let field = match field {
            SolutionField::QEvents | SolutionField::QdEvents => SolutionField::TEvents,
            f => f,
        };
        let Some(RunOutput {
            sol,
            energy,
            conserved,
            reactions,
            ..
        }) = run.as_mut()
        else {
            // A solution built from its fields (or unpickled from a version before
            // constraints) has no reactions: `None`, as a run without constraints.
            if matches!(
                field,
                SolutionField::Multipliers | SolutionField::ConstraintForces
            ) {
                return Ok(Taken::Absent);
            }
            return Err(missing(name));
        };
        let bit = 1 << field as usize;
        if *taken & bit != 0 {
            return Err(PyRuntimeError::new_err(format!(
                "the solution's {name} could not be made (an earlier attempt failed)"
            )));
        }
        *taken |= bit;
        Ok(match field {
            SolutionField::T => Taken::Floats(std::mem::take(&mut sol.t)),
            SolutionField::Q => Taken::Rows(std::mem::take(&mut sol.q), sol.dof),
            SolutionField::Qd => Taken::Rows(std::mem::take(&mut sol.qd), sol.dof),
            SolutionField::Energy => Taken::Floats(std::mem::take(energy)),
            SolutionField::Stats => {
                Taken::Stats(Box::new(sol.stats.clone()), *conserved, reactions.is_some())
            }
            SolutionField::TEvents | SolutionField::QEvents | SolutionField::QdEvents => {
                Taken::Events(std::mem::take(&mut sol.events), sol.dof)
            }
            SolutionField::Status => Taken::Status(status_code(&sol.status)),
            SolutionField::Message => Taken::Message(sol.status.to_string()),
            SolutionField::Dense => Taken::Dense(sol.dense.take()),
            SolutionField::Multipliers => match reactions {
                Some(r) => Taken::Rows(std::mem::take(&mut r.multipliers), r.rows),
                None => Taken::Absent,
            },
            SolutionField::ConstraintForces => match reactions {
                Some(r) => Taken::Rows(std::mem::take(&mut r.forces), sol.dof),
                None => Taken::Absent,
            },
            SolutionField::Names
            | SolutionField::EventNames
            | SolutionField::Y
            | SolutionField::Sensitivities
            | SolutionField::EventSensitivities => unreachable!("not made from a run"),
        })
    }

    /// Make the field a Python object from what the run computed, and keep it (the three
    /// event lists together).
    fn make(&self, py: Python<'_>, field: SolutionField) -> PyResult<()> {
        let taken = self.take(field)?;
        let made = match taken {
            Taken::Floats(values) => PyArray1::from_vec(py, values).into_any(),
            Taken::Rows(values, n) => {
                // Rows of n values as an array of shape (rows, n), without a copy (k = 0
                // multipliers: as many empty rows as points is not recoverable, so none).
                let rows = values.len().checked_div(n).unwrap_or(0);
                Array2::from_shape_vec((rows, n), values)
                    .map_err(|e| PyValueError::new_err(e.to_string()))?
                    .into_pyarray(py)
                    .into_any()
            }
            Taken::Stats(stats, conserved, constrained) => {
                stats_dict(py, &stats, conserved, constrained)?.into_any()
            }
            Taken::Events(found, n) => {
                let (mut t, mut q, mut qd) = (Vec::new(), Vec::new(), Vec::new());
                for o in events::occurrences(py, found, n)? {
                    t.push(o.get_item(0)?);
                    q.push(o.get_item(1)?);
                    qd.push(o.get_item(2)?);
                }
                let (t, q) = (PyList::new(py, t)?, PyList::new(py, q)?);
                self.keep(SolutionField::TEvents, t.into_any().unbind());
                self.keep(SolutionField::QEvents, q.into_any().unbind());
                PyList::new(py, qd)?.into_any()
            }
            Taken::Status(code) => code.into_pyobject(py)?.into_any(),
            Taken::Message(message) => message.into_pyobject(py)?.into_any(),
            Taken::Dense(Some(d)) => Bound::new(py, events::PyDense::new(d))?.into_any(),
            Taken::Dense(None) | Taken::Absent => py.None().into_bound(py),
        };
        let field = match field {
            SolutionField::TEvents | SolutionField::QEvents => SolutionField::QdEvents,
            f => f,
        };
        self.keep(field, made.unbind());
        Ok(())
    }
}

/// The statistics dict: a copy of a template that has every key (no key made, hashed or
/// inserted on a call, no growing of the table); the counters' keys are interned once, from
/// [`Statistics::COUNTERS`].
/// A constrained model's run adds the worst constraint residual after an accepted step
/// (`constraint_residual`), a scene's run its route (`scene_path`).
pub(super) fn stats_dict<'py>(
    py: Python<'py>,
    s: &Statistics,
    conserved: bool,
    constrained: bool,
) -> PyResult<Bound<'py, PyDict>> {
    type Template = (Py<PyDict>, Vec<Py<PyString>>);
    static STATS: PyOnceLock<Template> = PyOnceLock::new();
    let (template, counters) = STATS.get_or_try_init(py, || -> PyResult<Template> {
        let d = PyDict::new(py);
        let counters: Vec<Py<PyString>> = Statistics::COUNTERS
            .iter()
            .map(|(name, _)| PyString::intern(py, name).unbind())
            .collect();
        d.set_item(intern!(py, "method"), py.None())?;
        d.set_item(intern!(py, "choice"), py.None())?;
        for key in &counters {
            d.set_item(key.bind(py), py.None())?;
        }
        d.set_item(intern!(py, "conserved"), py.None())?;
        Ok((d.unbind(), counters))
    })?;
    let stats = template.bind(py).copy()?;
    stats.set_item(intern!(py, "method"), s.method.name())?;
    stats.set_item(intern!(py, "choice"), s.choice.clone())?;
    for (key, (_, count)) in counters.iter().zip(Statistics::COUNTERS) {
        stats.set_item(key.bind(py), count(s))?;
    }
    stats.set_item(intern!(py, "conserved"), conserved)?;
    if constrained {
        stats.set_item(intern!(py, "constraint_residual"), s.constraint_residual)?;
    }
    if let Some(path) = &s.scene_path {
        stats.set_item(intern!(py, "scene_path"), path)?;
    }
    Ok(stats)
}
