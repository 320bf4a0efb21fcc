//! Events stated in Python (`lagrangian.Event`), compiled like the energies, and the continuous
//! solution (`simulate(..., dense=True)`) as a Python object.
//!
//! A condition and a reset are expressions in t, q, q̇ and the model's parameters; each is
//! compiled to a tape over the model's inputs (machine code with the `native` backend) and
//! bound to the parameter values, so the search on every step runs no Python.

use std::collections::HashMap;
use std::sync::{Arc, Mutex};

use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray1, PyArray2, PyReadonlyArray1};
use pyo3::prelude::*;
use pyo3::types::PyTuple;

use super::model::{Backend, RawNode, node_ids};
use crate::error::{Error, Result};
use crate::integrators::{Dense, DenseParts, Direction, Event};
use crate::native::tape::NativeFunction;
use crate::program::{compile::Tape, eval::Function, inputs::Inputs};

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

/// An event's expressions, compiled and bound to parameter values: machine code, or the tape
/// interpreted.
#[derive(Clone)]
enum EventFunction {
    Native(NativeFunction),
    Interpreted(Function),
}

/// What a compiled event expression is made of: the serialized graph (numbers as bits), its
/// outputs, the model's coordinates and the parameters read, and whether it is machine code.
type CacheKey = (Vec<(String, u64, i64, i64)>, Vec<usize>, usize, usize, bool);

/// The compiled conditions and resets of recent events. `simulate(..., events=[...])` in a loop
/// would otherwise compile the same expressions on every call: measured 0.15 ms a call for one
/// condition with the native backend, half the double pendulum's whole run. Bounded: emptied
/// when it holds [`CACHE_SIZE`] entries.
static CACHE: Mutex<Option<HashMap<CacheKey, EventFunction>>> = Mutex::new(None);
const CACHE_SIZE: usize = 64;

impl EventFunction {
    /// The outputs `roots` of the serialized graph as one function of (t, q, q̇) at `f64`,
    /// from [`CACHE`] when these expressions were compiled before.
    fn new(
        nodes: &[RawNode],
        roots: &[usize],
        dof: usize,
        params: &[f64],
        backend: Backend,
        what: &'static str,
    ) -> Result<Self> {
        let key: CacheKey = (
            nodes
                .iter()
                .map(|(op, x, a, b)| (op.clone(), x.to_bits(), *a, *b))
                .collect(),
            roots.to_vec(),
            dof,
            params.len(),
            backend == Backend::Native,
        );
        let cache = || CACHE.lock().unwrap_or_else(|p| p.into_inner());
        if let Some(hit) = cache().as_ref().and_then(|c| c.get(&key)).cloned() {
            return hit.with_parameters(params);
        }
        let compiled = Self::compile(nodes, roots, dof, params, backend, what)?;
        let mut cache = cache();
        let map = cache.get_or_insert_with(HashMap::new);
        if map.len() >= CACHE_SIZE {
            map.clear();
        }
        map.insert(key, compiled.clone());
        Ok(compiled)
    }

    /// [`EventFunction::new`] without the cache.
    fn compile(
        nodes: &[RawNode],
        roots: &[usize],
        dof: usize,
        params: &[f64],
        backend: Backend,
        what: &'static str,
    ) -> Result<Self> {
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
            return Ok(Self::Native(native));
        }
        Ok(Self::Interpreted(function))
    }

    /// The same code with other parameter values.
    fn with_parameters(&self, params: &[f64]) -> Result<Self> {
        Ok(match self {
            Self::Native(f) => Self::Native(f.with_parameters(params)?),
            Self::Interpreted(f) => Self::Interpreted(f.with_parameters(params)?),
        })
    }

    #[inline]
    fn eval_into(&self, t: f64, q: &[f64], qd: &[f64], out: &mut [f64]) {
        match self {
            Self::Native(f) => f.eval_into(t, q, qd, out),
            Self::Interpreted(f) => f.eval_into(t, q, qd, out),
        }
    }
}

/// What each reset value overwrites: (velocity or not, coordinate).
type Targets = Arc<[(bool, usize)]>;

/// An event of a spec, compiled once and bound to parameter values by [`CompiledEvent::bind`]
/// (once for `simulate`, once per run for an ensemble that sweeps its parameters).
pub(crate) struct CompiledEvent {
    name: String,
    condition: EventFunction,
    direction: Direction,
    terminal: Option<usize>,
    samples: usize,
    reset: Option<(Targets, EventFunction)>,
    /// How many parameter values the expressions read.
    params: usize,
}

impl CompiledEvent {
    /// The event of a spec, for a model with `dof` coordinates, bound to the spec's values.
    pub(crate) fn new(spec: EventSpec, dof: usize, backend: Backend) -> Result<Self> {
        let (nodes, condition, targets, resets, params, direction, terminal, name, samples) = spec;
        let bad = |why: String| Error::InvalidInput { what: "event", why };
        let condition = EventFunction::new(
            &nodes,
            &[condition],
            dof,
            &params,
            backend,
            "event condition",
        )?;
        let direction = Direction::from_sign(direction)?;
        let samples = usize::try_from(samples)
            .map_err(|_| bad(format!("event {name:?}: samples = {samples} is negative")))?;
        let terminal = match terminal {
            0 => None,
            k if k > 0 => Some(k as usize),
            _ => {
                return Err(bad(format!(
                    "event {name:?}: terminal = {terminal}: give True, False or a count ≥ 1"
                )));
            }
        };
        let reset = if targets.is_empty() {
            None
        } else {
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
            let values = EventFunction::new(&nodes, &resets, dof, &params, backend, "event reset")?;
            Some((targets.into(), values))
        };
        Ok(Self {
            name,
            condition,
            direction,
            terminal,
            samples,
            reset,
            params: params.len(),
        })
    }

    /// How many parameter values [`CompiledEvent::bind`] takes.
    pub(crate) fn parameters(&self) -> usize {
        self.params
    }

    /// The [`Event`], with other parameter values than the spec's when `params` is given.
    pub(crate) fn bind(&self, params: Option<&[f64]>) -> Result<Event> {
        let rebind = |c: &EventFunction| match params {
            Some(p) => c.with_parameters(p),
            None => Ok(c.clone()),
        };
        let g = rebind(&self.condition)?;
        let mut event = Event::new(self.name.clone(), move |t, q, qd| {
            let mut out = [0.0];
            g.eval_into(t, q, qd, &mut out);
            out[0]
        })
        .with_direction(self.direction)
        .with_samples(self.samples);
        if let Some(k) = self.terminal {
            event = event.terminal(k);
        }
        if let Some((targets, values)) = &self.reset {
            let (targets, values) = (targets.clone(), rebind(values)?);
            event = event.with_reset(move |t, q, qd| {
                // Every new value from the state before the reset, then written.
                let mut new = vec![0.0; targets.len()];
                values.eval_into(t, q, qd, &mut new);
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
}

/// The [`Event`] of a spec, for a model with `dof` coordinates.
pub(crate) fn event(spec: EventSpec, dof: usize, backend: Backend) -> Result<Event> {
    CompiledEvent::new(spec, dof, backend)?.bind(None)
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
